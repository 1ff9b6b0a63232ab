"""The material's rotation and strain in small strain, and the warnings
when they are no longer small.

Small strain takes the symmetric part of each step's displacement
gradient as the strain increment and adds stress increments in fixed
axes: a body that rotates keeps its stress in the axes it had, and a
rotation ``theta`` makes errors of the order of ``theta`` in the stress
components (a user trial's bracket, loaded to twice its collapse load,
converged in small strain with its arm rotated 40 degrees, and nothing
said the answer was void).  :class:`SmallStrainRange` keeps each
point's rotation, the sum of its steps' infinitesimal rotations (the skew
part of ``grad du``), as point state (``rotation`` in 2D, about the
out-of-plane axis, counter-clockwise; ``rotation_x``, ``rotation_y``,
``rotation_z`` in 3D, the rotation vector), and warns when a point's
rotation passes :data:`ROTATION_WARNING`, naming the point and pointing
to finite deformation, and again each time the largest rotation passes
twice the level it last passed (a user trial's punch was warned at 5.9
degrees and went on to 18.7 unsaid).  Finite deformation needs none of it:
its stresses follow the material's rotation.

Small strain also takes the strain as linear in the displacement and the
points' volumes as fixed: a column compressed by 10% in small strain
(cpGIMP, 10 steps) had its stress from 0.88 to 1.00 of the load's, at
30% from 0.74 (in 20 steps 0.71; a user trial's at 50% settled 0.34 of
its height, unsaid).
:class:`SmallStrainRange` warns when a point's (elastic) strain passes
:data:`STRAIN_WARNING` in a principal direction, and again each time the
largest passes twice the level it last passed.

"""
import logging
from typing import Optional

import numpy as np
from numpy import ndarray

from ..protocols import GridTerm

__all__ = ["SmallStrainRange", "ROTATION_WARNING", "STRAIN_WARNING",
           "rotation_names",
           "rotation_state_names", "rotation_angle",
           "start_missing_rotation"]

logger = logging.getLogger(__name__)

#: a point rotated by more than this (radians, 5.7 degrees) in small strain
#: is warned: the stress components are then wrong by about 10%
ROTATION_WARNING = .1
#: a point strained by more than this in small strain (a principal value
#: of its elastic strain) is warned: the stresses are then wrong by about
#: as much (module docstring)
STRAIN_WARNING = .1


def rotation_names(dim: int) -> list:
    """The point-state names of the rotation kept in ``dim`` dimensions:
    the out-of-plane component in 2D, the vector's in 3D (none in 1D).

    >>> rotation_names(2), rotation_names(3)
    (['rotation'], ['rotation_x', 'rotation_y', 'rotation_z'])
    """
    return {1: [], 2: ["rotation"]}.get(
        dim, ["rotation_x", "rotation_y", "rotation_z"])


def rotation_state_names(dim: int, finite: bool) -> list:
    """The point-state names a run keeps for the rotation: those of
    :func:`rotation_names` in small strain, none in finite deformation
    (a checkpoint's state is checked against them)."""
    return [] if finite else rotation_names(dim)


def start_missing_rotation(points, dim: int, finite: bool) -> bool:
    """Give a resumed run's ``points`` zero rotation where their state
    holds none of the rotation's names (a checkpoint written before the
    rotation was kept): the rotation is a diagnostic, which the mechanics
    never read, so the run goes on, its rotation counted from the resume.
    Returns whether it did (the caller says so).

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> points = SimpleNamespace(state={}, n=3)
    >>> start_missing_rotation(points, 2, False), sorted(points.state)
    (True, ['rotation'])
    >>> start_missing_rotation(points, 2, False)
    False
    """
    names = rotation_state_names(dim, finite)
    if not names or any(name in points.state for name in names):
        return False
    points.state = {**points.state,
                    **{name: np.zeros(points.n) for name in names}}
    return True


def rotation_vector(grad: ndarray, dim: int) -> ndarray:
    """The infinitesimal rotation of displacement gradients ``grad``
    (at least (dim, dim, n)): ``w_z = (du_y/dx - du_x/dy) / 2`` in 2D as
    (1, n), the axial vector of the skew part in 3D as (3, n).

    >>> import numpy as np
    >>> g = np.array([[0., -.2], [.2, 0.]])[:, :, None]   # rotation by .2
    >>> rotation_vector(g, 2)
    array([[0.2]])
    >>> rotation_vector(np.zeros((1, 1, 3)), 1).shape    # none in 1D
    (0, 3)
    """
    if dim == 1:
        return np.zeros((0, grad.shape[-1]))
    pairs = [(1, 0)] if dim == 2 else [(2, 1), (0, 2), (1, 0)]
    return np.array([.5 * (grad[a, b] - grad[b, a]) for a, b in pairs])


def rotation_angle(state: dict, dim: int) -> ndarray:
    """Each point's rotation angle (radians) from its kept ``state``."""
    names = rotation_names(dim)
    return np.sqrt(sum(state[name] ** 2 for name in names))


def largest_strain(strain: ndarray) -> ndarray:
    """The largest principal value in magnitude of each of the symmetric
    tensors ``strain`` (3, 3, n); the eigenvalues are found only where the
    Frobenius norm (their bound) passes :data:`STRAIN_WARNING`.

    >>> import numpy as np
    >>> e = np.zeros((3, 3, 2)); e[0, 1, 1] = e[1, 0, 1] = .3
    >>> largest_strain(e).round(12).tolist()
    [0.0, 0.3]
    """
    norm = np.sqrt((strain ** 2).sum(axis=(0, 1)))
    largest = np.minimum(norm, STRAIN_WARNING)
    far = np.flatnonzero(norm > STRAIN_WARNING)
    if far.size:
        largest[far] = np.abs(np.linalg.eigvalsh(
            np.moveaxis(strain[:, :, far], -1, 0))).max(axis=1)
    return largest


def beyond(values: ndarray, level: float) -> str:
    """How many of ``values`` pass ``level``, in words: whether the
    warning's point is alone (a footing's edge, where the shipped
    examples' points turn by 6-12 degrees) or one of many.

    >>> import numpy as np
    >>> beyond(np.array([.05, .2, .3, .01]), .1)
    '2 of 4 points beyond the warning level'
    """
    return "{} of {} points beyond the warning level".format(
        int(np.count_nonzero(values > level)), values.size)


class SmallStrainRange(GridTerm):
    """The points' rotation and strain in a small-strain run (module
    docstring): a grid term with no force, whose commit adds each step's
    rotation to the point state, and warns when a point's rotation passes
    :data:`ROTATION_WARNING`, or its strain :data:`STRAIN_WARNING`, then
    2, 4, 8... times it (in 1D, where nothing rotates, the strain alone:
    a lecturer's column strained by 20% settled 10.0 against finite
    deformation's 7.3, unsaid)."""

    def __init__(self, dim: int):
        self.dim, self.names = dim, rotation_names(dim)
        self.level = ROTATION_WARNING       # the next rotation warned
        self.strain = STRAIN_WARNING        # the next strain warned

    def begin_run(self, points) -> None:
        for name in self.names:
            points.state.setdefault(name, np.zeros(points.n))
        # a resumed run's points carry their rotation: the level it
        # passed was warned by the invocation before (a reviewer's)
        largest = rotation_angle(points.state, self.dim).max(
            initial=0.) if self.names else 0.
        self.level = ROTATION_WARNING
        while self.level < largest:
            self.level *= 2.
        largest = largest_strain(points.strain).max(initial=0.)
        self.strain = STRAIN_WARNING
        while self.strain < largest:
            self.strain *= 2.

    def begin_step(self, problem) -> Optional[GridTerm]:
        return self

    def commit(self, problem, trial, du: ndarray, new, record) -> None:
        w = rotation_vector(problem.increment_gradients(du), self.dim)
        new.state = dict(new.state)
        for name, increment in zip(self.names, w):
            new.state[name] = new.state[name] + increment
        angle = rotation_angle(new.state, self.dim) if self.names else \
            np.zeros(new.n)
        p = int(np.argmax(angle)) if angle.size else 0
        if angle.size and angle[p] > self.level:
            while self.level < angle[p]:
                self.level *= 2.
            logger.warning(
                "step %d: small strain, and point %d at %s has rotated by "
                "%.1f degrees (%s): small strain keeps the stress in fixed "
                "axes, so its components are wrong by the order of %.0f%% "
                "of the stress there; use kinematics='finite' for rotations "
                "beyond %.1f degrees", problem.step, p,
                np.round(new.x[:, p], 6).tolist(), np.degrees(angle[p]),
                beyond(angle, ROTATION_WARNING), 100 * angle[p],
                np.degrees(ROTATION_WARNING))
        strain = largest_strain(new.strain)
        p = int(np.argmax(strain)) if strain.size else 0
        if strain.size and strain[p] > self.strain:
            while self.strain < strain[p]:
                self.strain *= 2.
            logger.warning(
                "step %d: small strain, and point %d at %s is strained by "
                "%.1f%% (%s): small strain takes the strain as linear in the "
                "displacement and the points' volumes as fixed, so the "
                "stresses are wrong by the order of the strain; use "
                "kinematics='finite' for strains beyond %.0f%%",
                problem.step, p, np.round(new.x[:, p], 6).tolist(),
                100 * strain[p], beyond(strain, STRAIN_WARNING),
                100 * STRAIN_WARNING)
