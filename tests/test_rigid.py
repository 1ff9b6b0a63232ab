"""Rigid bodies pushed by prescribed displacement (skfem_mpm/solve/rigid.py):
the same answer as prescribed grid nodes where those still hold, sinking
by many cells where grid nodes would lose their material, the force that
holds the motion, and refusals."""
import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (InvalidInputError, LinearElastic,
                       PrescribedMotionError, RigidBody, VonMises,
                       seed_points, simulate)
from skfem_mpm.quadrature.points import concatenate_points

H, DEPTH, HALF, WIDTH = .125, 1., .25, 1.5
SOIL = VonMises(1e4, .3, yield_stress=100.)


def footing_points(h=H):
    """Soil (body 0) 1.5 wide, 1 deep on a grid of spacing ``h`` with room
    above, and a footing (body 1) of half-width 0.25 in the row of cells
    on the soil's surface."""
    mesh = MeshQuad.init_tensor(np.arange(0., WIDTH + 1e-9, h),
                                np.arange(0., DEPTH + 4 * h + 1e-9, h))
    soil = seed_points(mesh, 2, region=lambda x: x[1] < DEPTH)
    foot = seed_points(mesh, 2, region=lambda x: (x[1] > DEPTH)
                       & (x[1] < DEPTH + h) & (x[0] < HALF))
    foot.body[:] = 1
    return mesh, concatenate_points([soil, foot])


def supports(b):
    return np.concatenate([
        b.get_dofs(lambda x: x[1] == 0).all(),
        b.get_dofs(lambda x: np.isclose(x[0], 0.)
                   | np.isclose(x[0], WIDTH)).all("u^1")])


def test_rough_footing_equals_its_grid_nodes_while_they_hold():
    """While the footing's points stay in their row of cells (settlement
    below a quarter cell), the rigid footing pushes exactly the nodes of
    that row: the soil's state and the footing force equal those of the
    prescribed grid nodes under it (rough: both components) to 1e-9."""
    mesh, points = footing_points()
    settlement = .02
    soil = points.body == 0
    res = simulate(mesh, ElementQuad1(), points,
                   [SOIL, LinearElastic(1e6, .3)], supports,
                   rigid_bodies=[RigidBody(1, [0., -settlement])], nsteps=5)
    under = np.flatnonzero(np.isclose(mesh.p[1], DEPTH)
                           & (mesh.p[0] <= HALF + 1e-9))
    dofs = np.concatenate([2 * under, 2 * under + 1])

    def pushed(b, f_old, f_new):
        return dofs, np.where(dofs % 2, -settlement * (f_new - f_old), 0.)
    nodes = simulate(mesh, ElementQuad1(),
                     seed_points(mesh, 2, region=lambda x: x[1] < DEPTH),
                     SOIL, supports, prescribed=pushed, nsteps=5)
    assert res.history[-1].n_yielded > 0
    scale = np.abs(nodes.points.stress).max()
    assert np.abs(res.points.stress[..., soil]
                  - nodes.points.stress).max() < 1e-9 * scale
    # the roller of the symmetry line keeps its own reaction
    own = dofs[~((dofs % 2 == 0) & (mesh.p[0, dofs // 2] == 0.))]
    for rigid, grid in zip(res.history, nodes.history):
        force = [grid.reactions[own[own % 2 == a]].sum() for a in (0, 1)]
        assert np.allclose(rigid.rigid_forces[0], force, rtol=1e-9,
                           atol=1e-9 * abs(force[1]))
    # the footing moved rigidly: every footing point by the settlement
    assert np.allclose(res.points.displacement[:, ~soil],
                       [[0.], [-settlement]], atol=1e-12)


@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_footing_sinks_through_many_cells(kinematics):
    """A footing pushed 3 cells deep into elastic soil (prescribed grid
    nodes are refused beyond a cell): every step converges, the footing's
    points sink rigidly by the settlement, its force grows with it, and
    it balances the support reactions (no gravity) to 1e-9."""
    mesh, points = footing_points()
    settlement = 3 * H
    res = simulate(mesh, ElementQuad1(), points,
                   [LinearElastic(1e3, .3), LinearElastic(1e6, .3)],
                   supports, rigid_bodies=[RigidBody(1, [0., -settlement],
                                                     rough=False)],
                   nsteps=12, kinematics=kinematics)
    foot = points.body == 1
    assert np.allclose(res.points.displacement[1, foot], -settlement,
                       atol=1e-9)
    forces = np.array([r.rigid_forces[0] for r in res.history])
    assert (np.diff(forces[:, 1]) < 0).all()        # pushes down harder
    assert forces[:, 0].max() == 0.                  # smooth: no x force
    # the supports carry the footing force: all reactions sum to zero
    total = res.history[-1].reactions.reshape(-1, 2).sum(axis=0)
    assert np.abs(total).max() < -1e-9 * forces[-1, 1]


def test_rough_footing_holds_the_soil_sideways():
    """Rough: the soil under the footing cannot slide out, so the footing
    carries a horizontal force; smooth: none."""
    mesh, points = footing_points()
    forces = {}
    for rough in (True, False):
        res = simulate(mesh, ElementQuad1(), points,
                       [LinearElastic(1e3, .3), LinearElastic(1e6, .3)],
                       supports, rigid_bodies=[RigidBody(1, [0., -.02],
                                                         rough=rough)])
        forces[rough] = res.history[-1].rigid_forces[0]
        # every held DOF counted once (the roller of the symmetry line
        # keeps its reaction, not the rough footing): all reactions balance
        total = res.history[-1].reactions.reshape(-1, 2).sum(axis=0)
        assert np.abs(total).max() < 1e-9 * abs(forces[rough][1])
    assert forces[False][0] == 0.
    assert abs(forces[True][0]) > 1e-3 * abs(forces[True][1])


def test_bad_rigid_bodies_are_refused():
    mesh, points = footing_points()
    materials = [SOIL, LinearElastic(1e6, .3)]

    def run(rigid, **kwargs):
        return simulate(mesh, ElementQuad1(), points, materials, supports,
                        rigid_bodies=rigid, **kwargs)
    for rigid, match in [
            (["footing"], "must be a RigidBody"),
            ([RigidBody(1, [0., 0., -1.])], "3 components, the grid 2"),
            ([RigidBody(2, [0., -1.])], "body 2 has no points"),
            ([RigidBody(1, [0., -1.]), RigidBody(1, [0., 1.])],
             "rigid twice"),
            ([RigidBody(0, [0., -1.]), RigidBody(1, [0., -1.])],
             "every body is rigid")]:
        with pytest.raises(InvalidInputError, match=match):
            run(rigid)
    for args, match in [((1, [0., 0.]), "non-zero"),
                        ((-1, [0., 1.]), "body index"),
                        ((1, [0., np.nan]), "finite"),
                        ((1, [0., -1.], "yes"), "rough")]:
        with pytest.raises(InvalidInputError, match=match):
            RigidBody(*args)
    with pytest.raises(InvalidInputError, match="increment"):
        run([RigidBody(1, [0., -.01])], rhs="increment")
    with pytest.raises(InvalidInputError, match="GIMP"):
        run(RigidBody(1, [0., -.01]), method="cpgimp")
    # a footing pushed sideways into the roller of the symmetry line
    with pytest.raises(PrescribedMotionError, match="support"):
        run([RigidBody(1, [.01, 0.])])


def test_a_stiff_smooth_body_is_named_in_a_warning(caplog):
    """A smooth footing as stiff as the soil holds the soil's nodes across
    its motion (rough in effect): said in a warning, and not for a soft
    one."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm import LinearElastic, RigidBody, seed_points, simulate
    from skfem_mpm.quadrature.points import concatenate_points
    mesh = MeshQuad.init_tensor(np.linspace(0., 1., 5),
                                np.linspace(0., 1., 5))
    soil = seed_points(mesh, 2, region=lambda x: x[1] < .75)
    pad = seed_points(mesh, 2, region=lambda x: (x[1] > .75) & (x[0] < .5))
    pad.body[:] = 1
    points = concatenate_points([soil, pad])

    def base(basis):
        return basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all()
    for modulus, warned in ((1e6, True), (1e1, False)):
        caplog.clear()
        simulate(mesh, ElementQuad1(), points,
                 [LinearElastic(1e4, .3), LinearElastic(modulus, .3)], base,
                 rigid_bodies=RigidBody(1, [0., -.01], rough=False))
        assert ("smooth rigid body 1" in caplog.text) == warned


@pytest.mark.parametrize("half, warned", [(.45, True), (HALF, False)])
def test_a_body_that_cuts_its_cells_is_warned_with_both_volumes(
        half, warned, caplog):
    """A footing whose side cuts a cell pushes the whole cell (trial 94's
    circular footing on a square grid: cells of 1.13-1.27 times its area):
    the warning at the run's start names the points' area and the cells',
    computed here from the seeding, and the remedies; a footing on grid
    lines is not warned."""
    mesh = MeshQuad.init_tensor(np.arange(0., WIDTH + 1e-9, H),
                                np.arange(0., DEPTH + 4 * H + 1e-9, H))
    soil = seed_points(mesh, 2, region=lambda x: x[1] < DEPTH)
    foot = seed_points(mesh, 2, region=lambda x: (x[1] > DEPTH)
                       & (x[1] < DEPTH + H) & (x[0] < half))
    foot.body[:] = 1
    area = foot.volume.sum()
    # the sub-cells of width H / 2 whose centres lie left of ``half``
    assert area == pytest.approx(H * H / 2 * np.ceil(half / (H / 2) - .5))
    cells = len(np.unique(np.floor(foot.x[0] / H)))
    with caplog.at_level("WARNING", logger="skfem_mpm.solve.rigid"):
        simulate(mesh, ElementQuad1(), concatenate_points([soil, foot]),
                 [LinearElastic(1e4, .3), LinearElastic(1e1, .3)],
                 supports, rigid_bodies=RigidBody(1, [0., -1e-3]))
    said = [r.getMessage() for r in caplog.records
            if r.getMessage().startswith("rigid body 1: its points")]
    assert len(said) == int(warned)
    if warned:
        assert cells * H * H > 1.05 * area
        assert "an area of {:.4g}, the {} cells they sit in {:.4g} " \
            "({:+.1f}%)".format(area, cells, cells * H * H,
                                100 * (cells * H * H / area - 1)) in said[0]
        for remedy in ("Obstacle", "contacts between bodies",
                       "grid with cell faces on the body's sides"):
            assert remedy in said[0]


def test_a_scene_footing_that_cuts_its_cells_is_warned(caplog):
    """The scene file's rigid body runs through the same check."""
    from skfem_mpm.scenes.scene import run_scene
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    text = """
[grid]
x = [0.0, 1.0, 4]
y = [0.0, 1.5, 6]
[[bodies]]
name = "soil"
region = { x = [0.0, 1.0], y = [0.0, 1.0] }
material = { model = "linear_elastic", E = 1e4, nu = 0.3 }
[[bodies]]
name = "footing"
region = { x = [0.0, 0.4], y = [1.0, 1.25] }
material = { model = "linear_elastic", E = 10.0, nu = 0.3 }
rigid = { displacement = [0.0, -0.001] }
[[supports]]
boundary = "bottom"
[solver]
steps = 1
"""
    with caplog.at_level("WARNING", logger="skfem_mpm.solve.rigid"):
        run_scene(parse_scene(tomllib.loads(text)))
    assert "rigid body 1: its points hold an area of" in caplog.text
