"""Material carried through an obstacle by a diverged solution is said to
be one, and retried (trial 115's passive wall: at a load increment of
1.3e-4, the wall moving 3e-4 cells, corners moved 21 cells with
displacement gradients up to 80, and the error said the material went
through the wall, a step too long)."""
from types import SimpleNamespace

import numpy as np
import pytest
from skfem import MeshQuad

from skfem_mpm import Obstacle
from skfem_mpm.errors import GridMotionError, StepTooLongError
from skfem_mpm.solve.contact import DIVERGED_GRADIENT, StepContact

H_CELL = .1          # the grid's cell
HALF = .025          # a point's domain's half width


def passing(gradient: float, shift: float):
    """``check_passing`` of one point at x = 0.9 (its domain's corners
    HALF either side) before a wall at x = 1 to 1.4, whose step moves its
    corners by a displacement ``shift`` and a gradient ``gradient`` along
    x (small strain), the wall still."""
    wall = Obstacle(box=[[1., 1.4], [-1., 2.]], name="wall")
    q = np.array([[-HALF, HALF, HALF, -HALF],
                  [-HALF, -HALF, HALF, HALF]])[:, :, None]
    X = np.array([.9, .5])[:, None, None] + q
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21), np.linspace(0, 1, 11))
    fake = SimpleNamespace(
        term=SimpleNamespace(obstacles=[wall], tol=[1e-3 * H_CELL],
                             h=H_CELL),
        dim=2, q=q, X=X, moved=[np.zeros(2)], shift_old=[np.zeros(2)],
        problem=SimpleNamespace(step=7, run=SimpleNamespace(
            user_grid=SimpleNamespace(mesh=mesh))))
    u = np.array([[shift], [0.]])
    H = np.zeros((2, 2, 1))
    H[0, 0] = gradient
    StepContact.check_passing(fake, u, H)


def test_a_diverged_solution_is_named_and_retried():
    """Corners carried 0.6 - 0.1 past the wall's far face by a gradient
    of 40 (the point's centre still): a diverged solution (retried along
    the ladder: GridMotionError), not a step too long."""
    gradient = 40.
    assert gradient > DIVERGED_GRADIENT
    with pytest.raises(GridMotionError) as err:
        passing(gradient, 0.)
    far = (.9 + HALF + gradient * HALF) - (.9 + HALF)
    assert "up to {:.3g} cells relative to it, while the obstacle moved " \
        "0 cells), with a displacement gradient up to {:.3g} in the " \
        "step: a diverged solution, not a motion of the material".format(
            far / H_CELL, gradient) in str(err.value)
    assert "step too long" not in str(err.value)


def test_a_step_too_long_stays_one():
    """The point carried whole through the wall (0.6, no strain): a step
    too long, cut back, as before."""
    with pytest.raises(StepTooLongError, match="material went through "
                       "obstacle 'wall' within the step"):
        passing(0., .6)
