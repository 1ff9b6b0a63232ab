"""Error without a closed form: self-convergence of a quantity over grid
refinement, the observed order, Richardson extrapolation and the grid
convergence index (GCI).

The procedure is the standard one of Roache (1998) as set out by Celik et
al. (2008), "Procedure for estimation and reporting of uncertainty due to
discretization in CFD applications", J. Fluids Eng. 130, 078001: from the
three finest grids (cell sizes ``h1 < h2 < h3``, ratios ``r21 = h2/h1``,
``r32 = h3/h2``, values ``f1, f2, f3``) the observed order ``p`` solves::

    p ln r21 = ln|e32 / e21| + q(p),
    q(p) = ln((r21^p - s) / (r32^p - s)),  s = sign(e32 / e21),

with ``e21 = f2 - f1``, ``e32 = f3 - f2``, solved for ``p`` in (0, 20]
by bracketing and Brent's method, the logarithm kept with its sign (no
positive root: the values do not converge); the extrapolated value is
``f_ext = (r21^p f1 - f2) / (r21^p - 1)`` and the fine-grid uncertainty
``GCI = 1.25 |f1 - f2| / (r21^p - 1)`` (absolute, in the quantity's
unit).  Where no order can be observed (two grids, neighbours equal to
round-off, no positive order up to 20) the reference is the finest value and the uncertainty Roache's two-grid
``3 |f1 - f2|``, and the reason is reported.  An observed order is only
as good as the data are asymptotic: standard MPM's grid-crossing error
(seed 2.2.3) gives erratic orders, which the values' plot shows.

"""
from dataclasses import asdict, dataclass
from typing import Optional, Sequence

import numpy as np

__all__ = ["SelfConvergence", "self_convergence", "relative_errors"]

#: safety factors of the GCI: three grids with an observed order, or not
SAFETY_OBSERVED, SAFETY_ASSUMED = 1.25, 3.
#: the highest order the elements here reach (Q2 displacements): an
#: observed order above it says the grids are not yet in the asymptotic
#: range, and the GCI may be overconfident
HIGHEST_FORMAL_ORDER = 3.
#: differences below this fraction of the values are round-off
ROUNDOFF = 1e-12


@dataclass
class SelfConvergence:
    """A quantity's convergence over refinement.

    Attributes
    ----------
    reference
        The value errors are measured against: Richardson's extrapolation,
        or the finest value where no order was observed.
    uncertainty
        The GCI of the finest value, in the quantity's unit.
    order
        The observed order, ``None`` where none was observed (``why``).
    against
        ``"richardson"`` or ``"finest"``.
    why
        Why no order was observed ("" when one was).
    oscillatory
        Whether the three finest values oscillate (``s = -1``).
    caution
        Why the uncertainty may be overconfident ("" when no reason is
        seen): an observed order above :data:`HIGHEST_FORMAL_ORDER`.
    """
    reference: float
    uncertainty: float
    order: Optional[float]
    against: str
    why: str = ""
    oscillatory: bool = False
    caution: str = ""

    def as_dict(self) -> dict:
        return asdict(self)


def observed_order(r21: float, r32: float, e21: float, e32: float,
                   largest: float = 20.) -> Optional[float]:
    """The root ``p`` in (0, ``largest``] of Celik et al.'s equation
    ``p ln r21 = ln|e32 / e21| + q(p)``, bracketed on a grid of orders and
    refined by Brent's method (their fixed-point iteration does not settle
    when the two ratios differ much); None when there is none.  The
    logarithm is taken with its sign (Celik et al. take the magnitude of
    the right-hand side), so that values moving apart under refinement
    (|e21| > |e32| on equal ratios) are not mistaken for convergence.

    >>> from skfem_mpm.studies.convergence import observed_order
    >>> h = [1 / 50, 1 / 40, 1 / 20]              # ratios 1.25 and 2
    >>> f = [1 + .3 * x ** 1.5 for x in h]
    >>> round(observed_order(h[1] / h[0], h[2] / h[1], f[1] - f[0],
    ...                      f[2] - f[1]), 9)
    1.5
    """
    from scipy.optimize import brentq
    s = np.sign(e32 / e21)
    ratio = np.log(abs(e32 / e21))

    def residual(p):
        with np.errstate(all="ignore"):
            return p * np.log(r21) - ratio - np.log(
                (r21 ** p - s) / (r32 ** p - s))
    grid = np.geomspace(1e-3, largest, 400)
    values = residual(grid)
    ok = np.isfinite(values)
    change = np.flatnonzero(ok[:-1] & ok[1:] & (np.sign(values[:-1])
                                                != np.sign(values[1:])))
    if values[ok].size and (values[ok] == 0).any():
        return float(grid[ok][values[ok] == 0][0])
    if not change.size:
        return None
    k = change[0]
    return float(brentq(residual, grid[k], grid[k + 1], xtol=1e-14,
                        rtol=1e-14))


def self_convergence(sizes: Sequence[float], values: Sequence[float]
                     ) -> SelfConvergence:
    """The convergence of ``values`` over cell ``sizes`` (any order, at
    least one; equal sizes are not allowed).

    Examples
    --------
    A quantity converging at second order, ``f(h) = 1 + h^2``:

    >>> from skfem_mpm.studies.convergence import self_convergence
    >>> c = self_convergence([.4, .2, .1], [1.16, 1.04, 1.01])
    >>> round(c.order, 9), round(c.reference, 9), c.against
    (2.0, 1.0, 'richardson')

    """
    h = np.asarray(sizes, float)
    f = np.asarray(values, float)
    order = np.argsort(h)
    h, f = h[order], f[order]
    if np.unique(h).size != h.size:
        raise ValueError("cell sizes repeat: {}".format(list(h)))
    if h.size == 1:
        return SelfConvergence(float(f[0]), 0., None, "finest",
                               "one grid: nothing to compare")
    e21 = f[1] - f[0]
    two_grid = SelfConvergence(float(f[0]), float(SAFETY_ASSUMED * abs(e21)),
                               None, "finest")
    if h.size == 2:
        two_grid.why = "two grids: an order needs three"
        return two_grid
    roundoff = ROUNDOFF * np.abs(f).max()
    if abs(e21) <= roundoff:
        two_grid.why = "the two finest grids agree to round-off"
        return two_grid
    e32 = f[2] - f[1]
    if abs(e32) <= roundoff:
        two_grid.why = "the second and third finest grids agree to " \
            "round-off"
        return two_grid
    r21, r32 = h[1] / h[0], h[2] / h[1]
    p = observed_order(r21, r32, e21, e32)
    if p is None:
        two_grid.why = "no positive order observed (values {})".format(
            ", ".join("{:.6g}".format(v) for v in f[:3]))
        two_grid.oscillatory = bool(e32 * e21 < 0)
        return two_grid
    gain = r21 ** p - 1
    caution = "" if p <= HIGHEST_FORMAL_ORDER else \
        "observed order {:.2f} is above {:g}, the highest formal order " \
        "of the elements: the grids are probably not in the asymptotic " \
        "range and the GCI may be overconfident".format(
            p, HIGHEST_FORMAL_ORDER)
    return SelfConvergence(
        float(f[0] - e21 / gain), float(SAFETY_OBSERVED * abs(e21) / gain),
        float(p), "richardson", oscillatory=bool(e32 * e21 < 0),
        caution=caution)


def relative_errors(values: Sequence[float], reference: float
                    ) -> np.ndarray:
    """``|f - reference| / |reference|``; against a reference of zero the
    scale is the largest ``|f|`` instead (and 1 if every value is zero).

    >>> from skfem_mpm.studies.convergence import relative_errors
    >>> relative_errors([1.1, 0.9], 1.).round(12).tolist()
    [0.1, 0.1]

    """
    f = np.asarray(values, float)
    scale = abs(reference) or np.abs(f).max(initial=0.) or 1.
    return np.abs(f - reference) / scale
