"""Where a surface load's nodal forces go in standard MPM: a face centre
past its point's cell is mapped by that cell's shape functions
extrapolated (resultant and point of application kept), and a load whose
force bypasses the material onto held DOFs is named (user trial 106: a
one-cell drained triaxial test's cell pressure of 100 was carried as
89.95 in finite deformation; a one-cell isotropic test in small strain
reached p = 387 for 400)."""
import logging

import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (LinearElastic, Prescribed, Pressure, seed_points,
                       side_points, simulate)

P = 100.


def rollers(basis):
    """Rollers on x = 0 and y = 0."""
    return np.union1d(
        basis.get_dofs(lambda x: np.isclose(x[0], 0.)).nodal["u^1"],
        basis.get_dofs(lambda x: np.isclose(x[1], 0.)).nodal["u^2"])


@pytest.mark.parametrize("cells", [1, 2])
def test_a_lateral_pressure_past_the_cell_is_carried_in_full(cells):
    """A unit square in one cell (of a grid of ``cells`` cells along x),
    its top nodes pushed down 0.3, the pressure ``P`` in full on its
    right side: the material grows past its cell along x, and its
    ``sigma_xx`` must stay ``-P`` (the faces' centres clamped onto the
    cell gave ``-P / (1 + the lateral strain)``, -91.5)."""
    grid = MeshQuad.init_tensor(np.linspace(0., cells, cells + 1),
                                np.linspace(0., 1., 2))
    points = seed_points(grid, 2, region=lambda x: x[0] < 1.)
    push = Prescribed(lambda b, f0, f1: (b.get_dofs(
        lambda x: np.isclose(x[1], 1.)).nodal["u^2"], -.3 * (f1 - f0)))
    run = simulate(grid, ElementQuad1(), points, LinearElastic(2e3, .3),
                   rollers, nsteps=5, kinematics="finite", loads=[
                       Pressure(side_points(points, "x+"), "x+", P,
                                ramp=False), push])
    right = (run.points.x[0] + run.points.domain[0]).max()
    assert right > 1.05                 # past the cell by 5% at least
    np.testing.assert_allclose(run.points.stress[0, 0], -P, rtol=1e-7)


def isotropic(kinematics, caplog, nsteps=4):
    """A unit square in one cell on rollers, the pressure 100 in full
    and 300 more ramped on its right and top sides, elastic; returns the
    run, the x+ points' face centres along x after each step and the
    warnings logged."""
    grid = MeshQuad.init_tensor(*(np.linspace(0., 1., 2),) * 2)
    points = seed_points(grid, 2)
    loads = [Pressure(side_points(points, s), s, P, ramp=False)
             for s in ("x+", "y+")] + [
        Pressure(side_points(points, s), s, 3 * P) for s in ("x+", "y+")]
    right, faces = side_points(points, "x+"), []
    d0 = points.domain[0, right]

    def callback(record, state):
        faces.append(state.x[0, right] + state.F[0, 0, right] * d0)
    with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
        caplog.clear()
        run = simulate(grid, ElementQuad1(), points, LinearElastic(5e3, .3),
                       rollers, nsteps=nsteps, kinematics=kinematics,
                       loads=loads, callback=callback)
    said = [r.getMessage() for r in caplog.records
            if "held DOFs across the body" in r.getMessage()]
    return run, faces, said


def test_a_small_strain_load_onto_held_dofs_is_named(caplog):
    """Small strain moves the points' faces into their cell and keeps
    their volumes: the face's force on the far nodes (the rollers') is
    ``1 - x_face / h`` of it, which the stress misses; said with the
    share, the first step it passes 1%."""
    run, faces, said = isotropic("small", caplog)
    assert len(said) == 2           # each side once
    share = 1. - np.mean(faces[0])  # the faces at the start of step 2
    assert share > .01 and 1. - np.mean(faces[-2]) > share
    assert said[0].startswith("step 2: the pressure on side 'x+' (of 2 "
                              "points) puts {:.1f}% of its force".format(
                                  100 * share))
    # the last step's equilibrium: -sigma_xx = 4 P (1 - its share)
    np.testing.assert_allclose(-run.points.stress[0, 0],
                               4 * P * np.mean(faces[-2]), rtol=1e-7)


def test_finite_deformation_carries_the_isotropic_load_unsaid(caplog):
    """The same in finite deformation: the volumes shrink with the faces,
    the stress is ``-4 P`` and nothing is said."""
    run, faces, said = isotropic("finite", caplog)
    assert said == [] and np.mean(faces[-1]) < .97
    np.testing.assert_allclose(run.points.stress[0, 0], -4 * P, rtol=1e-7)
