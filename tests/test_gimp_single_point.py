"""GIMP with one point per cell and axis (skfem_mpm/methods/gimp.py's
single_point_domains): warned at the run's start, and named in a failed
run's error."""
import numpy as np
import pytest
from skfem import ElementLineP1, MeshLine

from skfem_mpm import LinearElastic, seed_points, simulate
from skfem_mpm.errors import SingularTangentError

HEIGHT, CELLS, MODULUS, LOAD = 50., 64, 1e6, 800.


def column(ppc, nsteps, method, kinematics):
    """A lecturer's 1D column under its weight, its top settling 1.3
    cells (``LOAD H^2 / 2 E`` over ``H / CELLS``)."""
    mesh = MeshLine(np.linspace(0., HEIGHT, CELLS + 1))
    return simulate(mesh, ElementLineP1(), seed_points(mesh, ppc),
                    LinearElastic(MODULUS, 0.),
                    lambda b: b.get_dofs(lambda x: x[0] == 0),
                    body_force=[-LOAD], nsteps=nsteps, method=method,
                    kinematics=kinematics)


def test_the_column_settles_more_than_a_cell():
    settlement = LOAD * HEIGHT ** 2 / 2 / MODULUS
    assert settlement / (HEIGHT / CELLS) > 1.


@pytest.mark.parametrize("method", ["ugimp", "cpgimp"])
def test_one_point_per_cell_is_warned_where_points_move(method, caplog):
    """In finite deformation over 20 steps the top points zig-zag, the
    top settling 64% too far (-1.167, -0.707, -1.318, -0.544, -1.576
    against 2 points per cell's -0.962), a grid mode of alternate nodes
    next to free of energy once points have moved half a cell: warned at
    the start, naming the cure; with 2 points per cell, or in one step
    (the points solved where they were seeded), not."""
    res = column(1, 20, method, "finite")
    top = np.argsort(res.points.x0[0])[-5:]
    settled = res.points.x[0, top] - res.points.x0[0, top]
    assert np.ptp(settled) > .1 * np.abs(settled).max()   # the zig-zag
    said = [r.message for r in caplog.records
            if "1 point per cell and axis" in r.message]
    assert len(said) == 1
    assert "2 points per cell and axis" in said[0]
    for ppc, nsteps in ((2, 20), (1, 1)):
        caplog.clear()
        column(ppc, nsteps, method, "finite")
        assert "point per cell and axis" not in caplog.text


def test_one_point_per_cell_in_small_strain_fails_with_the_cause(caplog):
    """Small strain, 20 steps: the stiffness turned singular at step 11
    (even with the ghost penalty switched on), the error suggesting
    ghost=0.1 alone; it now names the single points per cell too."""
    with pytest.raises(SingularTangentError) as failed:
        column(1, 20, "cpgimp", "small")
    assert "1 point per cell and axis" in str(failed.value)
    assert "1 point per cell and axis" in caplog.text
