"""Prescribed motion on the fields of bodies in contact: it moves a
body's copy of a grid node only where the body's material lies on the
node (:data:`skfem_mpm.solve.motion.MOVED_NEAREST`), and a rigid body
drives its own field's copies only."""
import numpy as np
import pytest
from skfem import Basis, ElementQuad1, ElementVector, MeshQuad

from skfem_mpm import (Contact, Dynamics, LinearElastic, Obstacle,
                       Prescribed, RigidBody, seed_points, simulate)
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


def pushed_beside(method, scale, dynamics=None, resume=None):
    """Block A (0.4-0.8 x 0-0.4, its foot 0.4-0.7 below 0.1) pressed down
    by its top nodes (0.4 <= x <= 0.8, y = 0.4) by ``scale`` MOVE; block
    B beside it (0.81-1.2 x 0-0.4: a tenth of a cell apart, in A's
    cells) on the base, smooth contact, gravity."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(0, 1, 11))

    def ram(b, f_old, f_new):
        d = b.get_dofs(lambda x: np.isclose(x[1], .4) & (x[0] > .39)
                       & (x[0] < .81)).nodal["u^2"]
        return d, np.full(d.size, -scale * MOVE * (f_new - f_old))
    pts = concatenate_points([box(mesh, .4, .8, .1, .4, 0),
                              box(mesh, .4, .7, 0., .1, 0),
                              box(mesh, .8, 1.2, 0., .4, 1,
                                  left=.8 + .1 * H)])
    timing = dict(nsteps=4) if dynamics is None else dict(
        dynamics=dynamics)
    args = (mesh, ElementQuad1(), pts, LinearElastic(1e6, .3), base)
    kwargs = dict(body_force=[0., -GAMMA], method=method,
                  loads=[Prescribed(ram)], contacts=[Contact(0, 1)],
                  **timing)
    if resume is not None:
        return full_and_resumed(args, kwargs, resume)
    return pts, simulate(*args, **kwargs)


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
        mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                    np.linspace(0, 1, 11))
        x = Basis(mesh, ElementVector(ElementQuad1())).doflocs[
            :, r.reaction_dofs]
        under = (r.reaction_dofs % 2 == 1) & np.isclose(x[1], 0.) & (
            x[0] > .75)
        weight = GAMMA * pts.volume[b].sum()
        assert r.reaction_values[under].sum() == pytest.approx(weight,
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
