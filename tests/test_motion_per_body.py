"""Prescribed motion on the fields of bodies in contact: it moves a
body's copy of a grid node only where the body's material lies on the
node (:data:`skfem_mpm.solve.motion.MOVED_NEAREST`), and a rigid body
drives its own field's copies only."""
import numpy as np
import pytest
from skfem import Basis, ElementQuad1, ElementVector, MeshQuad

from skfem_mpm import (Contact, Dynamics, InvalidInputError, LinearElastic,
                       Obstacle, Prescribed, RigidBody, seed_points,
                       simulate)
from skfem_mpm.quadrature.points import concatenate_points
from test_body_contact import full_and_resumed

GAMMA = 9810.          # weight per unit volume (density 1000, g 9.81)
H = .1
MOVE = .004


def box(mesh, x0, x1, y0, y1, body, left=None):
    """2 x 2 points per cell of the box, of body ``body``; ``left``: the
    points of its cells squeezed into ``[left, x1]`` (a side inside a
    cell)."""
    p = seed_points(mesh, 2, region=lambda x: (x[0] > x0) & (
        x[0] < x1) & (x[1] > y0) & (x[1] < y1))
    p.body[:] = body
    if left is not None:
        s = (x1 - left) / (x1 - x0)
        p.x0[0] = left + (p.x0[0] - x0) * s
        p.x[0] = p.x0[0]
        p.volume0 *= s
        p.volume[:] = p.volume0
        if p.domain is not None:
            p.domain[0] *= s
    return p


def base(b):
    return b.get_dofs(lambda x: np.isclose(x[1], 0.)).all()


def pushed_beside(method, scale, dynamics=None, resume=None, top=.4,
                  gap=.1 * H, bodies=None):
    """Block A (0.4-0.8 x 0-``top``, its foot 0.4-0.7 below 0.1) pressed
    down by the nodes 0.4 <= x <= 0.8 at y = 0.4 by ``scale`` MOVE
    (``Prescribed(bodies=bodies)``); block B beside it (0.8 + ``gap`` to
    1.2 x 0-0.4: a tenth of a cell apart, in A's cells) on the base,
    smooth contact, gravity."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(0, 1, 11))

    def ram(b, f_old, f_new):
        d = b.get_dofs(lambda x: np.isclose(x[1], .4) & (x[0] > .39)
                       & (x[0] < .81)).nodal["u^2"]
        return d, np.full(d.size, -scale * MOVE * (f_new - f_old))
    pts = concatenate_points([box(mesh, .4, .8, .1, top, 0),
                              box(mesh, .4, .7, 0., .1, 0),
                              box(mesh, .8, 1.2, 0., .4, 1,
                                  left=.8 + gap)])
    timing = dict(nsteps=4) if dynamics is None else dict(
        dynamics=dynamics)
    args = (mesh, ElementQuad1(), pts, LinearElastic(1e6, .3), base)
    kwargs = dict(body_force=[0., -GAMMA], method=method,
                  loads=[Prescribed(ram, bodies=bodies)],
                  contacts=[Contact(0, 1)],
                  **timing)
    if resume is not None:
        return full_and_resumed(args, kwargs, resume)
    return pts, simulate(*args, **kwargs)


def b_s_base(record) -> float:
    """The vertical reaction of the base's nodes under block B (x > 0.75)
    of :func:`pushed_beside`'s grid at a step's end."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(0, 1, 11))
    x = Basis(mesh, ElementVector(ElementQuad1())).doflocs[
        :, record.reaction_dofs]
    under = (record.reaction_dofs % 2 == 1) & np.isclose(x[1], 0.) & (
        x[0] > .75)
    return record.reaction_values[under].sum()


@pytest.mark.parametrize("method", ("mpm", "ugimp", "cpgimp"))
def test_a_block_beside_a_pushed_one_feels_nothing(method):
    """Every field's copy of the pushed nodes was moved: B, a tenth of a
    cell beside A, was dragged down by 0.66 (MPM) and 0.65 (uGIMP) of
    the motion, its base carrying 1.33 times its weight (MPM) with no
    contact force.  Now B moves as it does with A held still, to 1e-10
    of the motion; with MPM its base carries its weight to 1e-8 (with
    GIMP A's domains, pressed down, reach the base nodes under B's
    edge)."""
    pts, still = pushed_beside(method, 0.)
    _, res = pushed_beside(method, 1.)
    b = pts.body == 1
    moved = res.points.displacement[:, b] - still.points.displacement[:, b]
    assert np.abs(moved).max() < 1e-10 * MOVE
    r = res.history[-1]
    assert not r.contact_forces.any()               # apart all along
    if method == "mpm":
        assert b_s_base(r) == pytest.approx(GAMMA * pts.volume[b].sum(),
                                            rel=1e-8)


def test_in_dynamics_too():
    """The same in implicit dynamics (MPM, dt = 0.01, 4 steps): B was
    dragged by 0.65 of the motion; now as with A held still, to 1e-10."""
    dyn = Dynamics(time_step=.01, duration=.04, density=1000.,
                   load=lambda t: t / .04)
    pts, still = pushed_beside("mpm", 0., dyn)
    _, res = pushed_beside("mpm", 1., dyn)
    b = pts.body == 1
    moved = res.points.displacement[:, b] - still.points.displacement[:, b]
    assert np.abs(moved).max() < 1e-10 * MOVE


def test_resume_is_bit_identical():
    """Resumed after step 2 of 4, the pushed blocks end where the whole
    run leaves them, to the bit (which copies move is found from the
    points at each step's start)."""
    full, resumed = pushed_beside("ugimp", 1., resume=2)
    assert np.array_equal(full.points.x, resumed.points.x)
    assert np.array_equal(full.history[-1].reaction_values,
                          resumed.history[-1].reaction_values)


@pytest.mark.parametrize("method", ("mpm", "cpgimp"))
def test_the_pushed_body_named_drags_nothing_beside_it(method, caplog):
    """A's top half a cell below the moved nodes: the rule by distance
    found B's material nearest the node at x = 0.8 and A's copies there
    and at 0.7 apart, and moved B's copy: B was dragged by 0.66 (MPM)
    and 0.65 (cpGIMP) of the motion.  That choice is now warned, naming
    the node and the bodies; with ``Prescribed(bodies=[0])`` B moves as
    it does with A held still, to 1e-10 of the motion, and its base
    carries its weight (MPM) to 1e-8."""
    with caplog.at_level("WARNING"):
        pushed_beside(method, 1., top=.35)
    assert "name the bodies it moves: Prescribed(..., bodies=" \
        in caplog.text
    assert "the bodies [0] and [1]" in caplog.text
    caplog.clear()
    pts, still = pushed_beside(method, 0., top=.35, bodies=[0])
    with caplog.at_level("WARNING"):
        _, res = pushed_beside(method, 1., top=.35, bodies=[0])
    assert "Prescribed(..., bodies=" not in caplog.text
    b, a = pts.body == 1, pts.body == 0
    moved = res.points.displacement[:, b] - still.points.displacement[:, b]
    assert np.abs(moved).max() < 1e-10 * MOVE
    pressed = res.points.displacement[1, a] - still.points.displacement[
        1, a]
    assert pressed.min() < -.5 * MOVE                # A is pushed
    if method == "mpm":
        assert b_s_base(res.history[-1]) == pytest.approx(
            GAMMA * pts.volume[b].sum(), rel=1e-8)


def test_a_pushed_body_touching_another_keeps_the_motion():
    """A and B touching (gap 0), A's top on the moved nodes: A settled a
    few hundredths of a cell below them under the rule by distance, lost
    the motion of its copies at x = 0.7 and 0.8 to B's, and the run
    ended in a ContactError at step 3.  Named, A keeps it: the run ends,
    A's top follows the nodes (its top points, a quarter cell below
    them, move by more than 0.85 of the motion), and B is pushed only
    sideways, by A's lateral expansion through the contact."""
    pts, res = pushed_beside("mpm", 1., gap=0., bodies=[0])
    _, still = pushed_beside("mpm", 0., gap=0., bodies=[0])
    assert len(res.history) == 4
    a, b = pts.body == 0, pts.body == 1
    top = a & (pts.x0[1] > .37)
    pressed = res.points.displacement[1, top] - still.points.displacement[
        1, top]
    assert -MOVE < pressed.mean() < -.85 * MOVE
    pushed = res.points.displacement[:, b] - still.points.displacement[
        :, b]
    assert pushed[0].max() > 0.                          # away from A
    force = res.history[-1].contact_forces[0]
    assert force[0] > 0. and abs(force[1]) < 1e-8 * force[0]  # smooth


def test_named_bodies_are_checked():
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    pts = seed_points(mesh, 1)

    def ram(b, f_old, f_new):
        return np.array([1]), np.array([0.])
    for bad in ([], [-1], "0", [0.5]):
        with pytest.raises(InvalidInputError, match="Prescribed bodies"):
            Prescribed(ram, bodies=bad)
    args = (mesh, ElementQuad1(), pts, LinearElastic(1e3, .3), base)
    with pytest.raises(InvalidInputError, match="has no contacts"):
        simulate(*args, loads=[Prescribed(ram, bodies=[0])])
    pts.body[:2] = 1
    with pytest.raises(InvalidInputError, match="names body 2 that no"):
        simulate(*args[:2], pts, *args[3:], contacts=[Contact(0, 1)],
                 loads=[Prescribed(ram, bodies=[0, 2])])


@pytest.mark.parametrize("way", ([-MOVE, 0.], [0., -MOVE]))
def test_a_rigid_plate_beside_a_block_drives_its_own_field(way):
    """A rigid plate (0.81-1 x 0.1-0.5, a tenth of a cell from the block,
    in its cells) pushed towards the block or down beside it, smooth
    contact: it drives only its own field's copies of its cells' nodes
    (held before this change too), so the block on the base moves as
    with the plate far away, to the bit, and its base carries its weight
    to 1e-8."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(0, 1, 11))
    out = []
    for far in (0., .5):
        pts = concatenate_points([box(mesh, .4, .8, 0., .4, 0),
                                  box(mesh, .8 + far, 1. + far, .1, .5, 1,
                                      left=.8 + far + .1 * H)])
        res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
                       base, body_force=[0., -GAMMA], nsteps=2,
                       loads=[RigidBody(1, way)], contacts=[Contact(0, 1)])
        out.append(res)
    b = pts.body == 0
    assert np.array_equal(out[0].points.displacement[:, b],
                          out[1].points.displacement[:, b])
    r = out[0].history[-1]
    x = Basis(mesh, ElementVector(ElementQuad1())).doflocs[
        :, r.reaction_dofs]
    under = (r.reaction_dofs % 2 == 1) & np.isclose(x[1], 0.)
    weight = GAMMA * pts.volume[b].sum()
    assert r.reaction_values[under].sum() == pytest.approx(weight, rel=1e-8)


def test_a_smooth_footing_in_contact_presses_like_an_obstacle():
    """A rigid footing (0.8-1.2 x 1-1.2) pushed half a cell into elastic
    soil, smooth contact: it drives its own field only and meets the soil
    through the contact, so its force follows the same footing as a
    smooth obstacle box (measured within 0.06-0.96% over the 5 steps;
    glued, one field: up to 8.3% above, as the base crosses cells)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(0, 1.4, 15))
    settle = .05

    def held(b):
        return np.concatenate([
            b.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
            b.get_dofs(lambda x: np.isclose(x[0], 0.)
                       | np.isclose(x[0], 2.)).nodal["u^1"]])
    soil = box(mesh, 0., 2., 0., 1., 0)
    obstacle = simulate(mesh, ElementQuad1(), soil, LinearElastic(1e6, .3),
                        held, nsteps=5, obstacles=[Obstacle(
                            box=[[.8, 1.2], [1., 1.2]],
                            displacement=[0., -settle], friction=0.)])
    pts = concatenate_points([soil, box(mesh, .8, 1.2, 1., 1.2, 1)])
    footing = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
                       held, nsteps=5, loads=[RigidBody(1, [0., -settle])],
                       contacts=[Contact(0, 1)])
    assert len(footing.history) == len(obstacle.history) == 5
    for a, b in zip(obstacle.history, footing.history):
        # the force holding the footing's motion, the soil's on the box
        assert -b.rigid_forces[0][1] == pytest.approx(
            a.obstacle_forces[0][1], rel=.015)


SCENE = """
[grid]
x = [0.0, 2.0, 20]
y = [0.0, 1.0, 10]
[[bodies]]
name = "A"
region = {{ x = [0.4, 0.8], y = [0.0, 0.35] }}
material = {{ model = "linear_elastic", E = 1e6, nu = 0.3 }}
[[bodies]]
name = "B"
region = {{ x = [0.85, 1.2], y = [0.0, 0.4] }}
material = {{ model = "linear_elastic", E = 1e6, nu = 0.3 }}
[[contacts]]
first = "A"
second = "B"
[[supports]]
boundary = "bottom"
[[supports]]
region = {{ x = [0.4, 0.8], y = [0.4, 0.4] }}
components = ["y"]
value = [{move}]
{bodies}
[gravity]
body_force = [0.0, -9810.0]
[solver]
steps = 2
"""


def test_a_scene_s_moving_support_names_its_bodies():
    """``bodies`` of a moving support in a scene file: B, half a cell
    beside A, moves as with the support still (to 1e-10 of the motion),
    A is pushed; bodies that are no body, differ between moving
    supports or come without a value are refused."""
    from skfem_mpm.errors import SceneError
    from skfem_mpm.scenes.scene import run_scene
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib

    def scene(move, bodies='bodies = ["A"]'):
        return parse_scene(tomllib.loads(SCENE.format(move=move,
                                                      bodies=bodies)))
    res, still = run_scene(scene(-MOVE)), run_scene(scene(0.))
    b = res.points.body == 1
    moved = res.points.displacement - still.points.displacement
    assert np.abs(moved[:, b]).max() < 1e-10 * MOVE
    assert moved[1, ~b].min() < -.5 * MOVE
    with pytest.raises(InvalidInputError, match="'C', which is no body"):
        run_scene(scene(-MOVE, 'bodies = ["C"]'))
    two = scene(-MOVE)
    two.supports.append(two.supports[1].__class__(
        at=[1.5, .5], components=["y"], value=[0.], bodies=["B"]))
    with pytest.raises(InvalidInputError, match="name different bodies"):
        run_scene(two)
    with pytest.raises(SceneError, match="bodies: needs a value"):
        parse_scene(tomllib.loads(SCENE.format(move=-MOVE, bodies="")
                                  .replace('boundary = "bottom"',
                                           'boundary = "bottom"\n'
                                           'bodies = ["A"]')))
