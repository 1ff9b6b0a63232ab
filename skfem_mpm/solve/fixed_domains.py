"""uGIMP's domains kept at their initial size while the material deforms,
and the warning when the points' volumes have left them.

uGIMP (Bardenhagen and Kober 2004) averages the grid's functions over each
point's domain, whose size it never changes.  In finite deformation the
material's volume at a point is ``det(F)`` times its initial one: compressed,
the domains overlap; stretched, gaps open between them, and the averaged
gradients no longer integrate the body's stress.  A column compressed by
a top traction (2 x 2 points per cell) had its stress from 0.94 to 1.12 of
the load's at 10%, 0.83 to 1.60 at 30% and 0.74 to 2.94 at 50% (a user
trial's, every step converged, unsaid), where cpGIMP, whose domains follow
``F``, is uniform to 1e-9.  :class:`FixedDomainsRange` warns when a point's
volume ratio leaves 1 by more than :data:`VOLUME_WARNING`, and again each
time the largest change passes twice the level it last passed.

"""
import logging

import numpy as np
from numpy import ndarray

from ..protocols import GridTerm

__all__ = ["FixedDomainsRange", "VOLUME_WARNING", "volume_ratio"]

logger = logging.getLogger(__name__)

#: a point whose volume changed by more than this fraction under uGIMP's
#: fixed domains is warned (module docstring)
VOLUME_WARNING = .1


def volume_ratio(F: ndarray) -> ndarray:
    """``det(F)`` of each of the tensors ``F`` (3, 3, n).

    >>> import numpy as np
    >>> F = np.repeat(np.diag([.9, 1., 1.])[:, :, None], 2, axis=2)
    >>> F[0, 1, 1] = .5                            # a shear leaves it
    >>> volume_ratio(F).round(12).tolist()
    [0.9, 0.9]
    """
    return (F[0, 0] * (F[1, 1] * F[2, 2] - F[1, 2] * F[2, 1])
            - F[0, 1] * (F[1, 0] * F[2, 2] - F[1, 2] * F[2, 0])
            + F[0, 2] * (F[1, 0] * F[2, 1] - F[1, 1] * F[2, 0]))


def volume_change(F: ndarray) -> ndarray:
    """``|det(F) - 1|`` of each of the tensors ``F`` (3, 3, n)."""
    return np.abs(volume_ratio(F) - 1.)


class FixedDomainsRange(GridTerm):
    """uGIMP in finite deformation (module docstring): a grid term with no
    force, whose commit warns when a point's volume has changed by more
    than :data:`VOLUME_WARNING`, then 2, 4, 8... times it."""

    def __init__(self):
        self.level = VOLUME_WARNING     # the next change warned

    def begin_run(self, points) -> None:
        # a resumed run's points carry their deformation: the level it
        # passed was warned by the invocation before
        largest = volume_change(points.F).max(initial=0.)
        self.level = VOLUME_WARNING
        while self.level < largest:
            self.level *= 2.

    def begin_step(self, problem):
        return self

    def commit(self, problem, trial, du: ndarray, new, record) -> None:
        change = volume_change(new.F)
        p = int(np.argmax(change)) if change.size else 0
        if not (change.size and change[p] > self.level):
            return
        while self.level < change[p]:
            self.level *= 2.
        logger.warning(
            "step %d: method 'ugimp' keeps the points' domains at their "
            "initial size, and point %d at %s has %s by %.0f%% (det F = "
            "%.3g): the domains %s and the stresses scatter (a column "
            "compressed 10%%: 0.94 to 1.12 of the uniform stress, 30%%: "
            "0.83 to 1.60); method 'cpgimp' stretches the domains with F",
            problem.step, p, np.round(new.x[:, p], 6).tolist(),
            "shrunk" if volume_ratio(new.F[:, :, p:p + 1])[0] < 1
            else "grown", 100 * change[p],
            volume_ratio(new.F[:, :, p:p + 1])[0],
            "overlap" if volume_ratio(new.F[:, :, p:p + 1])[0] < 1
            else "leave gaps")
