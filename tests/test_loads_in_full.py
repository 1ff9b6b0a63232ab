"""Tractions and pressures in full from the first step (``ramp=False``,
as ``BodyForce(..., ramp=False)``): a Cam clay sample starting at its
reference pressure is confined by a cell pressure that does not grow
with the load factor (a user trial: the confinement ramped from 0, so
no triaxial path could be set up)."""
import numpy as np
import pytest
from skfem import ElementHex1, ElementQuad1, MeshHex, MeshQuad

from skfem_mpm import (LinearElastic, ModifiedCamClay, NewtonOptions,
                       Obstacle, Options, Prescribed, Pressure, Traction,
                       seed_points, side_points, simulate)
from skfem_mpm.errors import InvalidInputError
from skfem_mpm.scenes.scene import run_scene
from skfem_mpm.scenes.scene_file import parse_scene, tomllib

P0, M = 100., 1.0


def cam_clay(lambda_=.1):
    """Normally consolidated at ``P0``: the stress ``-P0 I`` at zero
    strain."""
    return ModifiedCamClay(kappa=.01, lambda_=lambda_, M=M,
                           shear_modulus=3e3, reference_pressure=P0,
                           preconsolidation_pressure=P0)


def mean_stresses(rows):
    """A callback appending the volume means of the compressive normal
    stresses (xx, yy, zz) after each step to ``rows``."""
    def callback(record, points):
        s, V = points.stress, points.volume
        rows.append([-(s[i, i] @ V) / V.sum() for i in range(3)])
    return callback


def p_q(sx, sy, sz):
    p = (sx + sy + sz) / 3
    return p, np.sqrt(.5 * ((sx - sy) ** 2 + (sy - sz) ** 2
                            + (sz - sx) ** 2))


def triaxial(ramp: bool, nsteps: int = 12, push: float = .3):
    """A drained triaxial test of a Cam clay cube (one hex cell, finite
    elements): cell pressure ``P0`` on x+ and y+ (x-, y-, z- on
    rollers), the top z+ pushed down by ``push``."""
    grid = MeshHex()
    points = seed_points(grid, 2)

    def supports(basis):
        return np.concatenate([basis.get_dofs(
            lambda x, k=k: np.isclose(x[k], 0.)).all("u^{}".format(k + 1))
            for k in range(3)])

    def platen(basis, f_old, f_new):
        dofs = basis.get_dofs(lambda x: np.isclose(x[2], 1.)).all("u^3")
        return dofs, np.full(dofs.size, -push * (f_new - f_old))

    rows = []
    simulate(grid, ElementHex1(), points, cam_clay(.03), supports,
             nsteps=nsteps, method="fem",
             loads=[Pressure(side_points(points, side), side, P0, ramp=ramp)
                    for side in ("x+", "y+")] + [Prescribed(platen)],
             options=Options(callback=mean_stresses(rows)))
    return np.array(rows)


def test_a_drained_triaxial_test_reaches_the_critical_state():
    """The cell pressure held at ``P0`` from the first step: the stress
    path is the triaxial one (``q = 3 (p - P0)``) and ends at the
    critical state ``q = M p``, where ``p = 3 P0 / (3 - M)`` (150 for
    ``M = 1``): q/p 0.9994 at 30% axial strain.  Ramped, the lateral
    stress was 8.3 at the first step and the path no triaxial one."""
    rows = triaxial(ramp=False)
    assert np.allclose(rows[:, :2], P0, rtol=1e-9)       # the cell's
    p, q = p_q(*rows.T)
    assert np.allclose(q, 3 * (p - P0), rtol=1e-6)       # triaxial path
    assert np.all(np.diff(q / p) > 0)
    assert q[-1] / p[-1] == pytest.approx(M, abs=2e-3)
    assert p[-1] == pytest.approx(3 * P0 / (3 - M), rel=1e-3)
    ramped = triaxial(ramp=True)
    assert ramped[0, 0] == pytest.approx(P0 / 12, rel=1e-6)


def test_a_confining_pressure_in_full_holds_from_the_first_step_in_mpm():
    """The user trial's block (plane strain, standard MPM, a smooth
    platen): the lateral stress is the confining pressure at the first
    step (10 at load factor 0.1 when it ramped)."""
    h = .25
    grid = MeshQuad.init_tensor(np.arange(0, 1.5 + 1e-9, h),
                                np.arange(0, 1.25 + 1e-9, h))
    points = seed_points(grid, 2, region=lambda x: (x[0] < 1.)
                         & (x[1] < 1.))

    def supports(basis):
        return np.concatenate([
            basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all("u^2"),
            basis.get_dofs(lambda x: np.isclose(x[0], 0.)).all("u^1")])

    rows = []
    simulate(grid, ElementQuad1(), points, cam_clay(), supports, nsteps=2,
             method="mpm", loads=[Pressure(side_points(points, "right"),
                                           "right", P0, ramp=False)],
             options=Options(callback=mean_stresses(rows)),
             obstacles=[Obstacle(box=[[-1., 2.], [1., 1.2]],
                                 displacement=[0., -.02])])
    rows = np.array(rows)
    assert np.allclose(rows[:, 0], P0, rtol=1e-3)    # 10 when ramped
    assert np.all(rows[:, 1] > P0)                 # the platen's push


def test_an_elastic_block_under_tractions_in_full_is_balanced_at_once():
    """A traction in full and one ramped on a linear elastic block: at
    load factor 1/2 the stress is the first in full, the second half."""
    grid = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    points = seed_points(grid, 2)

    def supports(basis):
        return np.concatenate([
            basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all("u^2"),
            basis.get_dofs(lambda x: np.isclose(x[0], 0.)).all("u^1")])

    rows = []
    simulate(grid, ElementQuad1(), points, LinearElastic(1e4, .3),
             supports, nsteps=2, method="fem", loads=[
                 Traction(side_points(points, "right"), "right", [-10., 0.],
                          ramp=False),
                 Pressure(side_points(points, "top"), "top", 4.)],
             options=Options(callback=mean_stresses(rows)))
    assert np.allclose(np.array(rows)[:, :2], [[10., 2.], [10., 4.]],
                       rtol=1e-9)


def test_ramp_must_be_a_bool_and_increment_refuses_loads_in_full():
    grid = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    points = seed_points(grid, 2)
    right = side_points(points, "right")

    def left(basis):
        return basis.get_dofs(lambda x: np.isclose(x[0], 0.)).all()

    with pytest.raises(InvalidInputError, match="Pressure.ramp must be"):
        simulate(grid, ElementQuad1(), points, LinearElastic(1e4, .3),
                 left, nsteps=1,
                 loads=[Pressure(right, "right", 1., ramp="no")])
    # numpy's False too (a review: ``is False`` let it through, and the
    # increment scheme dropped the load: no displacement, no stress)
    for held in (False, np.False_):
        with pytest.raises(InvalidInputError,
                           match="a traction in full from the first step"):
            simulate(grid, ElementQuad1(), points, LinearElastic(1e4, .3),
                     left, nsteps=1,
                     loads=[Traction(right, "right", [1., 0.], ramp=held)],
                     options=Options(newton=NewtonOptions(rhs="increment")))


def test_proportional_loads_in_full_and_ramped():
    """Loads all ramped, or all in full, keep their direction at every
    load factor; a mix does not."""
    from skfem_mpm.solve.loads import ExternalLoads
    grid = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    points = seed_points(grid, 2)
    right = side_points(points, "right")

    def loads(ramps, gravity_ramp=None):
        return ExternalLoads(
            grid, ElementQuad1(), None,
            None if gravity_ramp is None else np.array([0., -1.]),
            [Pressure(right, "right", 1., ramp=r) for r in ramps],
            points.domain, {}, points.n, ramp_gravity=gravity_ramp
            if gravity_ramp is not None else True)

    assert loads([True, True]).proportional(points)
    assert loads([False, False]).proportional(points)
    assert loads([False], False).proportional(points)
    assert not loads([True, False]).proportional(points)
    assert not loads([True], False).proportional(points)
    assert loads([True], True).all_ramped
    assert not loads([False], True).all_ramped


SCENE = """
[grid]
x = [0.0, 1.5, 6]
y = [0.0, 1.25, 5]
[[bodies]]
name = "clay"
region = { x = [0.0, 1.0], y = [0.0, 1.0] }
[bodies.material]
model = "cam_clay"
kappa = 0.01
lambda = 0.1
M = 1.0
shear_modulus = 3e3
reference_pressure = 100.0
[[supports]]
boundary = "bottom"
components = ["y"]
[[supports]]
boundary = "left"
components = ["x"]
[[tractions]]
body = "clay"
side = "right"
pressure = 100.0
RAMP
[[obstacles]]
box = { x = [-1.0, 2.0], y = [1.0, 1.2] }
displacement = [0.0, -0.02]
[solver]
steps = 2
"""


def test_a_scene_s_pressure_in_full():
    """``ramp = false`` on a scene's ``[[tractions]]``: the cell pressure
    from the first step; anything but a bool refused."""
    rows = []
    scene = parse_scene(tomllib.loads(SCENE.replace("RAMP",
                                                    "ramp = false")))
    assert scene.tractions[0].ramp is False
    run_scene(scene, callback=mean_stresses(rows))
    assert np.allclose(np.array(rows)[:, 0], P0, rtol=1e-3)
    with pytest.raises(Exception, match=r"tractions\[0\]\.ramp"):
        parse_scene(tomllib.loads(SCENE.replace("RAMP", "ramp = 0")))
