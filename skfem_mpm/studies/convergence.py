"""Error without a closed form: self-convergence of a quantity over grid
refinement, its observed order, extrapolated value and the uncertainty of
every grid's value.

The procedure follows Eca and Hoekstra (2014), "A procedure for the
estimation of the numerical uncertainty of CFD calculations based on grid
refinement studies", J. Comput. Phys. 262, 104-130, which extends the
grid convergence index of Roache (1998) and Celik et al. (2008), J. Fluids
Eng. 130, 078001, from three grids to all of them.  With cell sizes
``h_i`` (``(V/N)^(1/d)``, Celik et al.) and values ``f_i``:

1. The order is fitted by least squares over *all* grids,
   ``f_i = f_0 + alpha h_i^p`` (``p`` in (0, 20], the best of a scan
   refined by Levenberg-Marquardt; over three grids the fit passes through
   them and is Celik et al.'s Richardson extrapolation).  Its standard
   deviation is ``sigma = sqrt(sum r_i^2 / (n - 1))``, ``r_i`` the
   residuals.
2. The values oscillate when the differences between successive grids
   change sign; differences within round-off are not counted.
3. The fit is *trusted* when the values do not oscillate, the order lies
   in the credible range ``[0.5, 2 P]`` (``P`` the method's formal order
   for the quantity, e.g. 2 for displacements of linear elements), the
   local orders of the last three triplets of successive grids are stable
   (each at least 0.5, within a factor 2 of each other:
   :func:`unstable_orders`; four grids or more) and ``sigma`` is below
   the data range per grid ``(max f - min f) / (n - 1)``.
   Then the reference is ``f_0``, each grid's error estimate is
   ``eps_i = |alpha| h_i^p`` and its uncertainty
   ``U_i = F_s eps_i + sigma + |r_i|``, with Eca and Hoekstra's safety
   factor ``F_s = 1.25`` for ``0.5 <= p < P + 0.1`` (their ``p < 2.1``
   for ``P = 2``) and ``F_s = 3`` for an order above the formal one:
   convergence faster than the method's is less sure (said under
   ``caution``).
4. An order above ``2 P`` (or a scattered fit) falls back to the fits
   with the fixed orders 1 and 2 (the one of smaller ``sigma``, if it is
   below the data range per grid): the reference is its ``f_0``,
   ``U_i = 3 eps_i + sigma + |r_i|``.
5. Otherwise -- oscillating values, an order below 0.5, unstable local
   orders, no fixed-order fit, two grids, values that agree to round-off
   (all of them, or the two finest: "converged to round-off", basis
   ``"round-off"``, no order fitted) -- nothing is extrapolated ("not
   credible", with the reason): the
   reference is the finest value, its uncertainty ``U = 3 Delta`` with
   the data range ``Delta = max |f_i - f_j|`` and its own error unknown
   (``None``, at most ``U``); every other grid's error estimate is its
   distance to the finest ``|f_i - f_finest|``, its uncertainty that
   plus ``3 Delta`` (:func:`from_data_range`).

No error or uncertainty is ever exactly zero: below round-off the data
cannot tell, and that is what is reported; only the finest case's error
where nothing was extrapolated is unknown.  Round-off is relative to the
largest of the values: :data:`ROUNDOFF` (1e-12, the arithmetic's), or for
the values of runs that iterate to equilibrium with a tolerance ``tol``
(a study passes its scene's Newton tolerance) :data:`SOLVER_ROUNDOFF`
times it where that is larger (:func:`roundoff_floor`: 1e-8 at the
default 1e-9).  Differences within it are not counted as convergence,
oscillation or disagreement, and no order is fitted to them.  Every
result says in words why the reference was or was not extrapolated.
An observed order is only as good as the data are asymptotic: standard
MPM's grid-crossing error (seed 2.2.3) gives erratic orders, which the
values' plot shows.

"""
from dataclasses import asdict, dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np

__all__ = ["SelfConvergence", "self_convergence", "from_data_range",
           "roundoff_floor", "roundoff_words", "fit_order",
           "fit_fixed_order", "sign_changes", "local_orders",
           "unstable_orders", "relative_errors"]

#: safety factors of the uncertainty: a trusted fit, anything else
SAFETY_TRUSTED, SAFETY_UNTRUSTED = 1.25, 3.
#: an observed order at least this far above the formal one ``P`` gets
#: the safety factor 3, not 1.25 (Eca and Hoekstra 2014: 1.25 for
#: ``0.5 <= p < 2.1`` with ``P = 2``)
ABOVE_FORMAL = .1
#: the lowest credible order; the highest is twice the formal order
LOWEST_CREDIBLE_ORDER = .5
#: the fixed orders fitted when the observed one is not credible
FIXED_ORDERS = (1., 2.)
#: orders scanned by the least-squares fit
ORDERS = np.geomspace(1e-3, 20., 400)
#: differences below this fraction of the values are round-off
ROUNDOFF = 1e-12
#: differences below this many times the runs' Newton tolerance, relative
#: to the values, are the solver's round-off (:func:`roundoff_floor`)
SOLVER_ROUNDOFF = 10.


def roundoff_floor(tol: Optional[float] = None) -> float:
    """The fraction of a quantity's values below which their differences
    are round-off: :data:`ROUNDOFF`, or for runs that iterate to
    equilibrium with the tolerance ``tol`` (on the out-of-balance force,
    relative to the forces that drive the run) :data:`SOLVER_ROUNDOFF`
    times it where larger.  A run stops once its residual is below
    ``tol``, so a quantity differs from the equilibrium's by about that
    fraction, two runs by about twice; a factor 10 covers that and a
    quantity that is part of the forces (a user trial: a wall pushed
    along a Coulomb floor, ``tol = 1e-9``: the push of mpm and cpgimp on
    14, 28 and 56 elements all within 2.6e-9 of Coulomb's mu W = 24
    kN/m, which the study had fitted a rate 2.93 to, extrapolated from
    and called a disagreement).

    >>> from skfem_mpm.studies.convergence import roundoff_floor
    >>> roundoff_floor(), roundoff_floor(1e-9), roundoff_floor(1e-15)
    (1e-12, 1e-08, 1e-12)
    """
    return ROUNDOFF if tol is None else max(ROUNDOFF, SOLVER_ROUNDOFF * tol)


def roundoff_words(tol: Optional[float] = None) -> str:
    """What :func:`roundoff_floor` is, in words.

    >>> from skfem_mpm.studies.convergence import roundoff_words
    >>> roundoff_words(1e-9)
    "1e-08 of the values: 10 x the solver's tolerance 1e-09"
    """
    floor = roundoff_floor(tol)
    return "{:g} of the values{}".format(floor, "" if floor == ROUNDOFF
                                         else ": {:g} x the solver's "
                                         "tolerance {:g}".format(
                                             SOLVER_ROUNDOFF, tol))


@dataclass
class SelfConvergence:
    """A quantity's convergence over refinement.

    Attributes
    ----------
    reference
        The value errors are measured against: the extrapolation ``f_0``,
        or the finest value where nothing was extrapolated.
    uncertainty
        ``U`` of the finest value, in the quantity's unit (``None`` with
        one grid: nothing to estimate it from).
    order
        The order the reference was extrapolated with (the observed one,
        or a fixed 1 or 2), ``None`` where nothing was extrapolated.
    against
        ``"richardson"`` (extrapolated) or ``"finest"``.
    why
        In words, why the reference was or was not extrapolated.
    oscillatory
        Whether the differences between successive grids change sign.
    caution
        Why the uncertainty may be less reliable than a trusted fit's
        ("" when no reason is seen): an extrapolation with a fixed order.
    observed_order
        The least-squares order over all grids (``None`` below three).
    formal_order, credible_orders
        The method's formal order ``P`` and the range ``[0.5, 2 P]``.
    basis
        ``"observed order"``, ``"fixed order"``, ``"data range"``,
        ``"round-off"`` (the values, or the two finest, agree to
        round-off: converged, no order) or ``"one grid"``.
    safety_factor
        1.25 for a trusted fit of an order below ``P + 0.1``, 3
        otherwise.
    data_range, standard_deviation
        ``max |f_i - f_j|`` and the fit's ``sigma`` (``None``: no fit).
    sign_changes
        How often the differences between successive grids change sign.
    errors, uncertainties
        Per grid, in the order the values were given: the error estimate
        (``|f_i - f_0|``; where nothing was extrapolated the distance to
        the finest value, the finest's own ``None``: unknown, at most its
        uncertainty) and ``U_i``, in the quantity's unit; never zero.
    tolerance, roundoff
        The runs' Newton tolerance (``None``: not given) and the
        fraction of the values below which differences are round-off
        (:func:`roundoff_floor`); errors and uncertainties are at least
        that fraction of the largest value.
    """
    reference: float
    uncertainty: Optional[float]
    order: Optional[float]
    against: str
    why: str = ""
    oscillatory: bool = False
    caution: str = ""
    observed_order: Optional[float] = None
    formal_order: float = 2.
    credible_orders: Tuple[float, float] = (LOWEST_CREDIBLE_ORDER, 4.)
    basis: str = ""
    safety_factor: Optional[float] = None
    data_range: float = 0.
    standard_deviation: Optional[float] = None
    sign_changes: int = 0
    errors: List[Optional[float]] = field(default_factory=list)
    uncertainties: List[Optional[float]] = field(default_factory=list)
    tolerance: Optional[float] = None
    roundoff: float = ROUNDOFF

    def as_dict(self) -> dict:
        return asdict(self)


def _projection_residuals(h: np.ndarray, f: np.ndarray, orders: np.ndarray
                          ) -> np.ndarray:
    """Residuals of ``f ~ f_0 + alpha h^p`` for each of ``orders`` (rows),
    by projection of the centred values on the centred column ``h^p``
    (stable where ``h^p`` is nearly constant)."""
    y = f - f.mean()
    x = h[None, :] ** orders[:, None]
    x = x - x.mean(axis=1, keepdims=True)
    norm = np.sqrt((x * x).sum(axis=1, keepdims=True))
    x = np.divide(x, norm, out=np.zeros_like(x), where=norm > 0)
    return y[None, :] - (x @ y)[:, None] * x


def fit_fixed_order(h: Sequence[float], f: Sequence[float], p: float):
    """``(f_0, alpha, residuals)`` of ``f ~ f_0 + alpha h^p`` by least
    squares for a given ``p``.

    >>> from skfem_mpm.studies.convergence import fit_fixed_order
    >>> f0, alpha, r = fit_fixed_order([1., 2., 4.], [4., 7., 13.], 1.)
    >>> round(f0, 12), round(alpha, 12), bool(abs(r).max() < 1e-12)
    (1.0, 3.0, True)
    """
    h, f = np.asarray(h, float), np.asarray(f, float)
    x = h ** p
    xc = x - x.mean()
    alpha = float(xc @ (f - f.mean()) / (xc @ xc))
    f0 = float(f.mean() - alpha * x.mean())
    return f0, alpha, f - f0 - alpha * x


def fit_order(h: Sequence[float], f: Sequence[float]):
    """``(p, f_0, alpha, residuals)`` of ``f ~ f_0 + alpha h^p`` by least
    squares over ``p`` in (0, 20] (at least three values): the best of
    :data:`ORDERS`, refined by Levenberg-Marquardt on all three
    parameters.

    >>> import numpy as np
    >>> from skfem_mpm.studies.convergence import fit_order
    >>> h = np.array([.4, .2, .1, .05])
    >>> p, f0, alpha, r = fit_order(h, 1. + .3 * h ** 1.5)
    >>> round(p, 9), round(f0, 12), round(alpha, 12)
    (1.5, 1.0, 0.3)
    """
    from scipy.optimize import least_squares
    h, f = np.asarray(h, float), np.asarray(f, float)
    scale = h.max()
    s = h / scale
    squares = (_projection_residuals(s, f, ORDERS) ** 2).sum(axis=1)
    p = float(ORDERS[np.argmin(squares)])
    f0, alpha, r = fit_fixed_order(s, f, p)
    size = np.abs(f).max() or 1.

    def residual(x):
        return (x[0] + x[1] * s ** x[2] - f) / size
    try:
        with np.errstate(all="ignore"):         # trial orders may overflow
            found = least_squares(residual, [f0, alpha, p], method="lm",
                                  xtol=1e-15, ftol=1e-15, gtol=1e-15)
        better = ORDERS[0] <= found.x[2] <= ORDERS[-1] and \
            (residual(found.x) ** 2).sum() <= (r / size) @ (r / size)
    except (ValueError, FloatingPointError):
        better = False
    if better:
        p = float(found.x[2])
        f0, alpha, r = fit_fixed_order(s, f, p)
    return p, f0, float(alpha / scale ** p), r


def sign_changes(values: Sequence[float], roundoff: float = 0.) -> int:
    """How often the differences between successive values change sign,
    differences within ``roundoff`` not counted.

    >>> from skfem_mpm.studies.convergence import sign_changes
    >>> sign_changes([1., 1.1, 1.05, 1.07]), sign_changes([3., 2., 1.5])
    (2, 0)
    """
    d = np.diff(np.asarray(values, float))
    signs = np.sign(d[np.abs(d) > roundoff])
    return int((signs[1:] != signs[:-1]).sum())


def local_orders(sizes: Sequence[float], values: Sequence[float]
                 ) -> List[float]:
    """The order of each three successive grids (cell ``sizes``
    ascending, ``values`` theirs): the ``p`` of ``f = f_0 + alpha h^p``
    through the three (Celik et al.'s, for any refinement ratios), a
    negative one where the differences grow with refinement (the ratio of
    the differences over that of the cell sizes, in logarithms), ``nan``
    where a difference is zero or they change sign.

    >>> from skfem_mpm.studies.convergence import local_orders
    >>> [round(p, 9) for p in local_orders([.1, .2, .4, .8],
    ...                                    [1.01, 1.04, 1.16, 1.64])]
    [2.0, 2.0]
    """
    from scipy.optimize import brentq
    h, f = np.asarray(sizes, float), np.asarray(values, float)
    found = []
    for k in range(h.size - 2):
        (h0, h1, h2), (f0, f1, f2) = h[k:k + 3], f[k:k + 3]
        fine, coarse = f1 - f0, f2 - f1
        if fine == 0. or coarse == 0. or (fine > 0) != (coarse > 0):
            found.append(float("nan"))
            continue
        ratio = coarse / fine

        def gap(p):
            return np.log((h2 ** p - h1 ** p) / (h1 ** p - h0 ** p)) - \
                np.log(ratio)
        low, high = 1e-6, 40.
        if gap(low) < 0 < gap(high):
            found.append(float(brentq(gap, low, high, xtol=1e-12)))
        else:   # no positive order passes through them
            found.append(float(np.log(ratio) / np.log(
                np.sqrt(h2 / h0))))
    return found


#: the local orders of the last three triplets of grids agree to this
#: factor where the values are in the asymptotic range
STABLE_ORDERS = 2.


def unstable_orders(sizes, values, lowest: float = LOWEST_CREDIBLE_ORDER
                    ) -> str:
    """Where the local orders (:func:`local_orders`) of the last three
    triplets of grids (the finest; all where there are fewer) are not
    stable -- one below ``lowest``, or two apart by more than the factor
    :data:`STABLE_ORDERS` -- in words, else ``""`` (three grids give one
    triplet, the least-squares fit itself: nothing to compare).  A least-
    squares order over all grids averages over a drift: a user trial's
    standard MPM on a column in 20 load steps, the top displacement
    0.970, 0.983, 0.995, 1.003, 1.008 m over 8..128 elements (away from
    cpGIMP's 0.962), was fitted the order 0.85 and extrapolated to 1.026
    +- 0.022 m, where the triplets' orders are 0.14, 0.69, 0.45.

    >>> from skfem_mpm.studies.convergence import unstable_orders
    >>> unstable_orders([.1, .2, .4, .8], [1.01, 1.04, 1.16, 1.64])
    ''
    >>> print(unstable_orders([1, 2, 4, 8, 16], [1.0083, 1.0028,
    ...                       .9953, .9832, .9699]))
    ... # doctest: +NORMALIZE_WHITESPACE
    the local orders of successive triplets of grids, 0.45, 0.69, 0.14
    (finest first), are not stable (below 0.5; apart by more than a factor
    2): the values are not in the asymptotic range (their differences do
    not shrink geometrically)
    >>> print(unstable_orders([1, 2, 4, 8], [1., 1.01, 1., 1.02]))
    ... # doctest: +NORMALIZE_WHITESPACE
    the local orders of successive triplets of grids, nan, nan (finest
    first), are not stable (a triplet's differences change sign or
    vanish): the values are not in the asymptotic range (their
    differences do not shrink geometrically)
    """
    h, f = np.asarray(sizes, float), np.asarray(values, float)
    order = np.argsort(h)
    orders = local_orders(h[order], f[order])[:3]
    if len(orders) < 2:
        return ""
    reasons = []
    if any(np.isnan(p) for p in orders):       # (local_orders: no order)
        reasons.append("a triplet's differences change sign or vanish")
    if any(p < lowest for p in orders):
        reasons.append("below {:g}".format(lowest))
    positive = [p for p in orders if p > 0]
    if len(positive) == len(orders) and \
            max(positive) > STABLE_ORDERS * min(positive):
        reasons.append("apart by more than a factor {:g}".format(
            STABLE_ORDERS))
    if not reasons:
        return ""
    return "the local orders of successive triplets of grids, {} (finest " \
        "first), are not stable ({}): the values are not in the " \
        "asymptotic range (their differences do not shrink " \
        "geometrically)".format(", ".join(
            "nan" if p != p else "{:.2f}".format(p) for p in orders),
            "; ".join(reasons))


def _number(x: float) -> str:
    return "{:.3g}".format(x)


def from_data_range(values: Sequence[float], reference: int, why: str,
                    tolerance: Optional[float] = None, **found
                    ) -> SelfConvergence:
    """No extrapolation: the reference is ``values[reference]`` (the
    finest case), its uncertainty three times the data range
    ``Delta = max |f_i - f_j|`` (at least round-off: of the runs' Newton
    ``tolerance`` where given, :func:`roundoff_floor`) and its own
    error unknown (``None``: at most that uncertainty); every other
    value's error estimate is its distance to the reference
    ``|f_i - f_ref|`` (at least round-off), its uncertainty that plus the
    reference's
    ``3 Delta`` (its distance to the answer is at most its distance to
    the reference plus the reference's).  ``why`` (in words) gains how
    the uncertainty was found.

    A grid three times further from the finest than another shows an
    error three times larger (a user trial's footing force at 24, 36 and
    48 elements, no credible order: every case had been given the same
    error, the data range, and the plots drew the coarsest grid as
    accurate as the finest).

    >>> from skfem_mpm.studies.convergence import from_data_range
    >>> c = from_data_range([1.4, 1.2, 1.1], 2, "no order")
    >>> c.reference, round(c.uncertainty, 12)
    (1.1, 0.9)
    >>> [e if e is None else round(e, 12) for e in c.errors]
    [0.3, 0.1, None]
    >>> [round(u, 12) for u in c.uncertainties]
    [1.2, 1.0, 0.9]
    >>> print(c.why)  # doctest: +NORMALIZE_WHITESPACE
    no order: no extrapolation; uncertainty 3 x the data range 0.3; each
    other case's error its distance to the finest case, its uncertainty
    that plus the finest's
    """
    f = np.asarray(values, float)
    spread = float(f.max() - f.min())
    floor = roundoff_floor(tolerance)
    roundoff = max(floor * np.abs(f).max(), np.finfo(float).tiny)
    uncertainty = SAFETY_UNTRUSTED * max(spread, roundoff)
    errors = [None if i == reference else
              max(float(abs(v - f[reference])), roundoff)
              for i, v in enumerate(f)]
    found.setdefault("basis", "data range")
    return SelfConvergence(
        float(f[reference]), uncertainty, None, "finest",
        why + ": no extrapolation; uncertainty {:g} x {}; each other "
        "case's error its distance to the finest case, its uncertainty "
        "that plus the finest's".format(
            SAFETY_UNTRUSTED, "the data range " + _number(spread)
            if spread >= roundoff else "round-off ({})".format(
                roundoff_words(tolerance))),
        safety_factor=SAFETY_UNTRUSTED, data_range=spread, errors=errors,
        uncertainties=[uncertainty + (e or 0.) for e in errors],
        tolerance=tolerance, roundoff=floor, **found)


def self_convergence(sizes: Sequence[float], values: Sequence[float],
                     formal_order: float = 2., tol: Optional[float] = None
                     ) -> SelfConvergence:
    """The convergence of ``values`` over cell ``sizes`` (any order, at
    least one; equal sizes are not allowed) of a method whose formal order
    for this quantity is ``formal_order``, the values of runs iterated to
    equilibrium with the Newton tolerance ``tol`` (``None``: round-off is
    the arithmetic's alone): differences within :func:`roundoff_floor`
    of the values are round-off, and where all the values, or the two
    finest, agree so, they have converged to round-off and no order is
    fitted (basis ``"round-off"``).

    Examples
    --------
    A quantity converging at second order, ``f(h) = 1 + h^2``:

    >>> from skfem_mpm.studies.convergence import self_convergence
    >>> c = self_convergence([.4, .2, .1], [1.16, 1.04, 1.01])
    >>> round(c.order, 9), round(c.reference, 9), c.against
    (2.0, 1.0, 'richardson')
    >>> print(c.why)  # doctest: +NORMALIZE_WHITESPACE
    observed order 2.00 (least squares over 3 grids) within [0.5, 4],
    values monotone: extrapolated; uncertainty 1.25 x the error estimate
    of the fit

    Values that differ by the solver's round-off alone (a trial's push,
    Coulomb's 24 kN/m, on 14, 28, 56 elements, Newton tolerance 1e-9):

    >>> c = self_convergence([.125, .0625, .03125], [-24.000000061685,
    ...                      -23.999999999469868, -23.999999991564227],
    ...                      tol=1e-9)
    >>> c.order, c.basis, c.reference
    (None, 'round-off', -23.999999991564227)
    >>> print(c.why)  # doctest: +NORMALIZE_WHITESPACE
    converged to round-off (differences within 1e-08 of the values: 10 x
    the solver's tolerance 1e-09): no order is fitted to round-off: no
    extrapolation; uncertainty 3 x round-off (1e-08 of the values: 10
    x the solver's tolerance 1e-09); each other case's error its distance
    to the finest case, its uncertainty that plus the finest's
    """
    h = np.asarray(sizes, float)
    f = np.asarray(values, float)
    if np.unique(h).size != h.size:
        raise ValueError("cell sizes repeat: {}".format(list(h)))
    order = np.argsort(h)
    hs, fs = h[order], f[order]
    n = h.size
    lo, hi = LOWEST_CREDIBLE_ORDER, 2. * formal_order
    credible = "[{:g}, {:g}]".format(lo, hi)
    found = dict(formal_order=float(formal_order),
                 credible_orders=(lo, hi), tolerance=tol)
    finest = int(order[0])
    if n == 1:
        return SelfConvergence(
            float(f[0]), None, None, "finest", "one grid: nothing to "
            "compare, no extrapolation and no uncertainty", basis="one grid",
            errors=[None], uncertainties=[None],
            roundoff=roundoff_floor(tol), **found)
    roundoff = roundoff_floor(tol) * np.abs(f).max()
    spread = float(f.max() - f.min())
    if n == 2:
        return from_data_range(f, finest, "two grids: an order needs "
                               "three", **found)
    if spread <= roundoff:
        return from_data_range(
            f, finest, "converged to round-off (differences within {}): "
            "no order is fitted to round-off".format(
                roundoff_words(tol)), basis="round-off", **found)
    if abs(fs[1] - fs[0]) <= roundoff:
        return from_data_range(
            f, finest, "converged to round-off on the finest grids: the "
            "two finest values agree within {}; no order is fitted to a "
            "round-off difference (the uncertainty, from all the values, "
            "holds the coarser grids' differences)".format(
                roundoff_words(tol)), basis="round-off", **found)
    changes = sign_changes(fs, roundoff)
    p, f0, alpha, r = fit_order(hs, fs)
    sigma = float(np.sqrt(r @ r / (n - 1)))
    per_grid = spread / (n - 1)
    found.update(observed_order=p, oscillatory=bool(changes),
                 sign_changes=changes, standard_deviation=sigma)
    seen = "observed order {:.2f}".format(p) if ORDERS[0] < p < ORDERS[-1] \
        else "observed order at the fit's limit {:g}".format(p)
    if changes:
        return from_data_range(
            f, finest, "values oscillate with refinement (the differences "
            "between successive grids change sign {} time{}); {}{}".format(
                changes, "s" if changes > 1 else "", seen,
                " outside " + credible if not lo <= p <= hi else
                ", not trusted on oscillating values"), **found)
    if p < lo:
        return from_data_range(
            f, finest, "{} outside {}: the values do not converge at a "
            "credible rate".format(seen, credible), **found)
    unstable = unstable_orders(hs, fs, lo)
    if unstable:
        return from_data_range(
            f, finest, "{} (least squares over {} grids), not credible: "
            "{}".format(seen, n, unstable), **found)
    safety, caution = SAFETY_TRUSTED, ""
    if p <= hi and sigma < per_grid:
        above = p >= formal_order + ABOVE_FORMAL
        if above:                   # Eca and Hoekstra: 1.25 below P only
            safety = SAFETY_UNTRUSTED
            caution = "observed order {:.2f} above the formal order {:g}: " \
                "safety factor {:g}, not {:g} (Eca and Hoekstra 2014: " \
                "1.25 only for 0.5 <= p < {:g})".format(
                    p, formal_order, safety, SAFETY_TRUSTED,
                    formal_order + ABOVE_FORMAL)
        why = "{} (least squares over {} grids) within {}, values " \
            "monotone: extrapolated; uncertainty {:g} x the error estimate " \
            "of the fit".format(seen, n, credible, safety)
        if sigma > roundoff:
            why += " + its standard deviation {}".format(_number(sigma))
        if above:
            why += " (the order is above the formal order {:g}: Eca and " \
                "Hoekstra's 1.25 holds for 0.5 <= p < {:g} only)".format(
                    formal_order, formal_order + ABOVE_FORMAL)
    else:
        reason = "{} outside {}".format(seen, credible) if p > hi else \
            "{} but its fit scatters (standard deviation {} above the data " \
            "range per grid {})".format(seen, _number(sigma),
                                        _number(per_grid))
        fits = []
        for q in FIXED_ORDERS:
            if lo <= q <= hi:
                q0, qa, qr = fit_fixed_order(hs, fs, q)
                fits.append((np.sqrt(qr @ qr / (n - 1)), q, q0, qa, qr))
        if not fits or min(fits)[0] >= per_grid:
            return from_data_range(f, finest, reason + " and no fit of a "
                                   "fixed order 1 or 2 is closer",
                                   **found)
        above = False
        sigma, p, f0, alpha, r = min(fits)
        sigma = float(sigma)
        found["standard_deviation"] = sigma
        safety = SAFETY_UNTRUSTED
        why = caution = "{}: extrapolated with the fixed order {:g} (the " \
            "closer of the fits of orders 1 and 2); uncertainty {:g} x its " \
            "error estimate".format(reason, p, safety)
    estimate = np.abs(alpha) * hs ** p
    floor = max(roundoff, np.finfo(float).tiny)
    U = np.maximum(safety * estimate + sigma + np.abs(r), floor)
    errors = np.maximum(np.abs(fs - f0), floor)
    back = np.empty(n, int)
    back[order] = np.arange(n)
    found.update(basis="fixed order" if caution and not above else
                 "observed order")
    return SelfConvergence(
        float(f0), float(U[0]), float(p), "richardson", why,
        caution=caution, safety_factor=safety, data_range=spread,
        errors=errors[back].tolist(), uncertainties=U[back].tolist(),
        roundoff=roundoff_floor(tol), **found)


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
