"""The factor of safety of a slope (or any body under its loads) by
strength reduction.

The strength is divided by a trial factor ``F`` (the cohesion ``c``, the
friction ``tan(phi)``; the yield stress of von Mises) and the problem is
run; the factor of safety is the ``F`` beyond which the body no longer
stands (Zienkiewicz, Humpheson and Lewis, *Geotechnique* 25, 1975;
Griffiths and Lane, *Geotechnique* 49, 1999).  The factor is bracketed and
bisected: each trial is a whole run, so its cost is that of a run times
``log2(bracket / tolerance)``.

A trial stands when its run converges *and* its displacement stays within
``growth`` times that of the run at ``low`` (a factor at which the body
stands, well below collapse): a collapse criterion on the displacement
trend over the factors.  Non-convergence alone is not enough in the
material point method: beyond collapse the points move, the slope slumps
and may find equilibrium again metres away, and whether a run gets there
depends on its load steps and cut-backs.  On the 45-degree clay slope of
``examples/slope.py`` at h = H/8 the largest displacement grows from
0.040 m (F = 1) to 0.11-0.14 m at F = 1.61 and 0.18-0.35 m at 1.62, and
beyond that a run either fails or finds equilibrium again some 1.1-1.8 m
away: convergence alone gave factors of safety from 1.617 to 1.664 (2.9%
apart, bracket 1%) with 4 to 16 load steps with or without cut-backs; the
displacement criterion gives 1.617 with each of them
(``tests/test_strength_reduction.py``, ``docs/geomechanics.md``).

Recommended setting: ``growth = 5`` (the default; ``growth`` places the
factor on the knee of the displacement curve: 3 and 10 moved it by about
1% either way on that slope), ``low`` well below the factor of safety (1
for a slope thought to stand), and runs of at least 8 load steps with a
few cut-backs (``NewtonOptions(max_cutbacks=4)``), so that a trial below
collapse converges rather than failing for a load step too large (with 4
steps and no cut-backs the slope at h = H/16 failed at F = 1.55, its
factor 1.551 where 8 or 16 steps give 1.570).

"""
import logging
from dataclasses import dataclass, field, replace
from typing import Callable, Optional

import numpy as np

from ..errors import ConvergenceError, InvalidInputError, \
    PointsOutsideGridError, PrescribedMotionError, SingularSystemError
from ..repeats import OnceEach, warnings_once
from .results import Result

logger = logging.getLogger(__name__)

__all__ = ["reduce_strength", "strength_reduction", "SafetyFactor",
           "largest_displacement"]


def reduce_strength(material, factor: float):
    """The material with its strength divided by ``factor``: cohesion over
    ``factor`` and ``tan(phi)`` over ``factor`` for Mohr-Coulomb and
    Drucker-Prager (the dilation angle reduced likewise, so associated flow
    stays associated), the yield stress over ``factor`` for von Mises.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm import MohrCoulomb, reduce_strength
    >>> soil = MohrCoulomb(1e4, .3, cohesion=10., friction_angle=30.,
    ...                    dilation_angle=30.)
    >>> weak = reduce_strength(soil, 2.)
    >>> weak.cohesion, round(float(np.tan(np.radians(weak.friction_angle))
    ...                           / np.tan(np.radians(30.))), 12)
    (5.0, 0.5)

    """
    from ..mechanics.materials import VonMises
    from ..mechanics.soils import DruckerPrager, MohrCoulomb
    if not (np.isfinite(factor) and factor > 0):
        raise InvalidInputError("the strength reduction factor must be "
                                "positive, got {!r}".format(factor))
    if isinstance(material, VonMises):           # perfectly plastic
        return replace(material, yield_stress=material.yield_stress / factor)
    if isinstance(material, (MohrCoulomb, DruckerPrager)):
        if isinstance(material, DruckerPrager) and material.hardening:
            raise InvalidInputError(
                "strength reduction of a hardening Drucker-Prager material "
                "is not offered (which cohesion would it reduce?)")

        def reduced(angle):
            return float(np.degrees(np.arctan(np.tan(np.radians(angle))
                                              / factor)))
        return replace(material, cohesion=material.cohesion / factor,
                       friction_angle=reduced(material.friction_angle),
                       dilation_angle=reduced(material.dilation_angle),
                       radians_refused=False)
    raise InvalidInputError(
        "strength reduction is offered for von Mises, Mohr-Coulomb and "
        "Drucker-Prager materials, got {}".format(type(material).__name__))


def largest_displacement(result: Result) -> float:
    """The largest displacement magnitude among the points of ``result``
    (m): the default measure of how far a trial has moved.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> moved = SimpleNamespace(points=SimpleNamespace(
    ...     displacement=np.array([[3., 0.], [4., 1.]])))
    >>> largest_displacement(moved)
    5.0
    """
    d = np.asarray(result.points.displacement, float)
    return float(np.sqrt((d ** 2).sum(axis=0)).max()) if d.size else 0.


@dataclass
class SafetyFactor:
    """The factor of safety, bracketed.

    Attributes
    ----------
    factor
        The middle of the bracket.
    converged, failed
        The largest factor whose trial stood (its run converged and moved
        at most ``growth`` times the run at ``low``) and the smallest
        whose trial did not.
    trials
        ``(factor, stood)`` of every run, in order.
    result
        The run at ``converged`` (its displacements show the mechanism
        about to form).
    displacements
        The measured displacement of every trial, in the order of
        ``trials`` (``None`` where the run failed).
    reference
        The displacement of the run at ``low``, the scale of ``growth``
        (``None`` without the displacement criterion).
    quieted
        The number of warnings of each trial, in the order of ``trials``,
        that ``quiet`` kept from the log (0 for the first, whose
        warnings are logged).
    errors
        Why each trial's run failed, ``"ErrorClass: message"``, in the
        order of ``trials`` (``None`` where it converged).
    retried
        Whether each trial was a retry (``retry``: a failed trial at the
        top of the bracket run again more carefully), in the order of
        ``trials``.
    span
        ``(lower, upper)``: where the verdict flips, judged on every
        trial: ``lower`` the largest factor below every trial that did
        not stand, ``upper`` the smallest factor that did not stand
        above every trial that stood, a failed run not counted where a
        trial at a larger factor stood (the failure may be numerical)
        and no retry at its factor failed too; a run that converged but
        moved past ``growth`` is a collapse, and the failures below it
        agree with it.  The bracket where the trials are monotone; wider
        (a :attr:`warnings`) where not.
    warnings
        What makes the factor less certain than its bracket, one
        sentence each: a run that failed below a trial that stood, a
        :attr:`span` wider than the bracket (empty: none).

    Its repr is the factor, the bracket and the trials (``print`` of
    the whole run at ``converged`` ran to thousands of characters):

    >>> from skfem_mpm.solve.strength_reduction import SafetyFactor
    >>> SafetyFactor(1.5, 1.25, 1.75, [(1., True), (2., False)],
    ...              result=object(), displacements=[.1, None],
    ...              reference=.1)
    SafetyFactor(factor=1.5, converged=1.25, failed=1.75, \
trials=[(1.0, True), (2.0, False)])
    """
    factor: float
    converged: float
    failed: float
    trials: list
    result: Result = field(repr=False)
    displacements: list = field(default_factory=list, repr=False)
    reference: Optional[float] = field(default=None, repr=False)
    quieted: list = field(default_factory=list, repr=False)
    errors: list = field(default_factory=list, repr=False)
    retried: list = field(default_factory=list, repr=False)
    span: Optional[tuple] = field(default=None, repr=False)
    warnings: list = field(default_factory=list, repr=False)


def strength_reduction(run: Callable, low: float = 1., high: float = 2.,
                       tolerance: float = .01, growth: Optional[float] = 5.,
                       displacement: Callable = largest_displacement,
                       quiet: bool = True, retry: Optional[Callable] = None,
                       retries: int = 3) -> SafetyFactor:
    """Bracket and bisect the factor of safety.

    Parameters
    ----------
    run
        ``run(factor) -> Result``: the problem with its strength divided by
        ``factor`` (e.g. with :func:`reduce_strength`).  A run that does not
        converge (:class:`~skfem_mpm.errors.ConvergenceError` other than a
        prescribed-motion error), whose stiffness is singular (a mechanism)
        or whose points slide out of the grid is a failure at that factor;
        any other error is the caller's and propagates.
    low, high
        The first bracket: ``low`` must stand; ``high`` is doubled (up to
        five times) until its trial does not.  The run at ``low`` sets the
        scale of the displacement criterion: take it well below the factor
        of safety.
    tolerance
        Relative width of the final bracket.
    growth
        The collapse criterion on the displacement trend: a trial whose run
        converges but whose ``displacement`` exceeds ``growth`` times that
        of the run at ``low`` has collapsed (its points slid away and found
        equilibrium again, or are about to).  ``None``: convergence alone
        decides, as before (the answer then depends on the load steps and
        cut-backs of the runs; see the module's notes).  Recommended: the
        default 5, runs of 8 or more load steps with
        ``NewtonOptions(max_cutbacks=4)``.
    displacement
        ``displacement(result) -> float``: how far a trial moved (default
        :func:`largest_displacement`, the largest point displacement).
    quiet
        ``True`` (default): the first trial's warnings are logged, each
        text once; those of the later trials (Newton's retries and
        cut-backs: a trial near collapse has dozens; a text said before
        is dropped as ever) are counted, per
        trial in :attr:`SafetyFactor.quieted` and the INFO line of the
        trial, and said in one warning at the end, as ``skfem-mpm
        safety`` prints them; ``False``: every trial's warnings are
        logged (each text once).
    retry
        ``retry(factor) -> Result``: a more careful run than ``run`` (more
        load steps, e.g. twice as many), or ``None`` (default: no
        retry).  Where the trial at the top of the final bracket failed
        to converge, it is run again by ``retry``: a failure for a load
        step too large is told from a collapse.  If the retry stands, the
        bisection goes on above it, up to the smallest factor above it
        whose trial did not stand or, where there is none (the top was
        the first ``high``), up to its factor doubled until a trial does
        not stand, as at the start (and its new top is retried in turn);
        at most ``retries`` retries in all (default 3), each a trial in
        :attr:`SafetyFactor.trials` (:attr:`SafetyFactor.retried`).
    retries
        The most retries (each a whole run, longer than a trial).

    Raises
    ------
    InvalidInputError
        If the run at ``low`` already fails (the factor of safety is below
        ``low``: the message says so, with the failure), if it does not
        move (no scale for ``growth``), or none up to ``high * 32``
        collapses (after a retry that stood at ``high``: up to 64 times
        that).

    Notes
    -----
    Whether a run converges is not always monotone in the factor: a run
    fails at one factor and converges at a larger one (trial 98, a
    Mohr-Coulomb slope: 1.8281 failed, 1.8438 converged, 1.875 failed,
    1.8906 converged).  The bisection then depends on its path; every
    trial is judged afterwards: :attr:`SafetyFactor.span` is where the
    verdict flips (the bracket, or wider) and
    :attr:`SafetyFactor.warnings` says why, each logged as a warning.

    Examples
    --------
    A stand-in problem that collapses beyond 1.37 and, as a material
    point run may, converges again far away from 1.5 to 2:

    >>> from types import SimpleNamespace
    >>> import numpy as np
    >>> from skfem_mpm import NewtonDivergenceError, strength_reduction
    >>> def run(factor):
    ...     if 1.37 < factor <= 1.5 or factor > 2:
    ...         raise NewtonDivergenceError("no equilibrium")
    ...     moved = 0.1 if factor <= 1.37 else 3.   # slumped
    ...     return SimpleNamespace(points=SimpleNamespace(
    ...         displacement=np.array([[0.], [-moved]])))
    >>> round(strength_reduction(run, tolerance=1e-3).factor, 2)
    1.37
    >>> round(strength_reduction(run, tolerance=1e-3, growth=None).factor, 2)
    2.0
    """
    if not (0 < low < high) or not (0 < tolerance < 1):
        raise InvalidInputError(
            "strength_reduction needs 0 < low < high and 0 < tolerance < 1, "
            "got low {!r}, high {!r}, tolerance {!r}".format(low, high,
                                                             tolerance))
    if growth is not None and not (np.isfinite(growth) and growth > 1):
        raise InvalidInputError(
            "strength_reduction's growth must be a number > 1 (the "
            "displacement, over that of the run at low, beyond which a "
            "trial has collapsed) or None, got {!r}".format(growth))
    with warnings_once() as once:      # each trial's warnings: once
        found = bisect(run, low, high, tolerance, growth, displacement,
                       once, quiet, retry, retries)
    for sentence in found.warnings:
        # marked: skfem-mpm safety prints them with its summary instead
        logger.warning("strength reduction: %s", sentence,
                       extra={"safety_warning": True})
    said = ["F = {:.4f}: {}".format(f, n)
            for (f, _), n in zip(found.trials, found.quieted) if n]
    if said:
        logger.warning(
            "strength reduction: %d warning(s) of the trials after the "
            "first were counted, not logged (%s); "
            "strength_reduction(..., quiet=False) logs them",
            sum(found.quieted), ", ".join(said))
    return found


def bisect(run: Callable, low: float, high: float, tolerance: float,
           growth: Optional[float], displacement: Callable, once: OnceEach,
           quiet: bool = False, retry: Optional[Callable] = None,
           retries: int = 3) -> SafetyFactor:
    """:func:`strength_reduction`'s bracket and bisection, its arguments
    checked; ``once`` filters the trials' repeated warnings, and hushes
    those of the trials after the first where ``quiet``; a failed trial
    at the top of the final bracket is run again by ``retry`` (at most
    ``retries`` times in all), the bisection going on above it where the
    retry stands."""
    trials, displacements, scale, quieted = [], [], [], []
    errors, retried = [], []

    def attempt(factor, runner=run):
        once.cover()
        before = once.hushed_count
        once.hushed = quiet and bool(trials)
        again = runner is not run
        try:
            result = runner(factor)
        except PrescribedMotionError:
            raise
        except (ConvergenceError, SingularSystemError,
                PointsOutsideGridError) as err:
            quieted.append(once.hushed_count - before)
            logger.info("strength reduction factor %.4f%s: fails (%s)%s",
                        factor, " (retry)" if again else "",
                        type(err).__name__, hushed(quieted[-1]))
            trials.append((factor, False))
            displacements.append(None)
            errors.append("{}: {}".format(type(err).__name__, err))
            retried.append(again)
            return None, err
        finally:
            once.hushed = False
        quieted.append(once.hushed_count - before)
        errors.append(None)
        retried.append(again)
        moved = float(displacement(result))
        displacements.append(moved)
        if scale and not moved <= growth * scale[0]:
            logger.info("strength reduction factor %.4f%s: converges but "
                        "moves %.4g, more than %g times the %.4g at %g: "
                        "collapse%s", factor, " (retry)" if again else "",
                        moved, growth, scale[0], trials[0][0],
                        hushed(quieted[-1]))
            trials.append((factor, False))
            return None, None
        logger.info("strength reduction factor %.4f%s: stands (moves %s)%s",
                    factor, " (retry)" if again else "",
                    "-" if moved is None else "{:.4g}".format(moved),
                    hushed(quieted[-1]))
        trials.append((factor, True))
        return result, None

    result, err = attempt(low)
    if result is None:
        raise InvalidInputError(
            "the run fails already at the strength reduction factor {}: the "
            "factor of safety is below it (or the run cannot converge: {}: "
            "{})".format(low, type(err).__name__, err)) from err
    if growth is not None:
        if not (np.isfinite(displacements[0]) and displacements[0] > 0):
            raise InvalidInputError(
                "the run at the strength reduction factor {} moves {!r}: the "
                "displacement criterion (growth) needs a run that moves; "
                "pass growth=None to judge by convergence alone".format(
                    low, displacements[0]))
        scale.append(displacements[0])

    def climb(low, result, high):
        """The bracket: ``high`` doubled (up to five times) until its
        trial does not stand, ``low`` and ``result`` the last that did."""
        for _ in range(6):
            trial, _ = attempt(high)
            if trial is None:
                return low, result, high
            low, result, high = high, trial, 2 * high
        raise InvalidInputError("no run failed up to the strength reduction "
                                "factor {}: nothing collapses".format(low))

    low, result, high = climb(low, result, high)
    while True:
        while high - low > tolerance * low:
            middle = .5 * (low + high)
            trial, _ = attempt(middle)
            if trial is None:
                high = middle
            else:
                low, result = middle, trial
        # the top of the bracket: its last trial failed, not yet retried
        top = max(k for k, (f, _) in enumerate(trials) if f == high)
        if retry is None or sum(retried) >= retries or \
                errors[top] is None or retried[top]:
            break
        trial, _ = attempt(high, retry)
        if trial is None:
            break
        # a numerical failure: the bisection goes on above it, to the
        # smallest failure there; none where every midpoint stood (the
        # top was the first bracket's): the bracket climbs again
        above = [f for f, stood in trials if not stood and f > high]
        if above:
            low, result, high = high, trial, min(above)
        else:
            low, result, high = climb(high, trial, 2 * high)
    span, warnings = flip_span(trials, errors, retried)
    if growth is None:
        warnings += far_moved(trials, displacements, low)
    return SafetyFactor(.5 * (low + high), low, high, trials, result,
                        displacements, scale[0] if scale else None, quieted,
                        errors, retried, span, warnings)


def far_moved(trials: list, displacements: list, top: float,
              growth: float = 5.) -> list:
    """Judged by convergence alone, the sentence (a list of none or
    one) on the trials up to ``top`` that stood though they moved more
    than ``growth`` times the first trial (trial 98: F = 1.8906 stood,
    28 times the run at F = 1: the factor 1.896 against 1.820 with
    ``growth=5``).

    >>> from skfem_mpm.solve.strength_reduction import far_moved
    >>> far_moved([(1., True), (2., True), (1.5, True)], [.1, .9, .2], 2.)
    ... # doctest: +NORMALIZE_WHITESPACE
    ['judged by convergence alone, the trial at F = 2.0000 stood though
    it moved 9 times the run at F = 1; with growth = 5 the factor of
    safety is below 2']
    """
    first = displacements[0]
    far = [f for (f, stood), d in zip(trials, displacements)
           if stood and f <= top and d is not None and first
           and d > growth * first]
    if not far:
        return []
    k = max(range(len(trials)), key=lambda k: (
        trials[k][0] in far, trials[k][0]))
    return ["judged by convergence alone, the trial at F = {:.4f} stood "
            "though it moved {:.3g} times the run at F = {:g}; with growth "
            "= {:g} the factor of safety is below {:.4g}".format(
                trials[k][0], displacements[k] / first, trials[0][0],
                growth, min(far))]


def flip_span(trials: list, errors: list, retried: list) -> tuple:
    """Where the verdict of ``trials`` (``(factor, stood)``) flips, and
    the sentences that say why it is less certain than the bracket:
    ``((lower, upper), warnings)`` (see :attr:`SafetyFactor.span`);
    ``errors`` and ``retried`` as :class:`SafetyFactor`'s.

    A run stood at 1.8, failed at 1.83 and 1.875, converged (and stood)
    at 1.84 and 1.89; it failed again at 1.9:

    >>> from textwrap import fill
    >>> from skfem_mpm.solve.strength_reduction import flip_span
    >>> span, said = flip_span(
    ...     [(1., True), (1.875, False), (1.8, True), (1.83, False),
    ...      (1.84, True), (1.89, True), (1.9, False)],
    ...     [None, "E: x", None, "E: y", None, None, "E: z"], [False] * 7)
    >>> span
    (1.8, 1.9)
    >>> for line in said:
    ...     print(fill(line, 70))
    the runs at F = 1.8300, 1.8750 failed (E: y, ...) but the one at F =
    1.8400 stood: the failures may be numerical (load steps too large),
    the factor of safety up to 1.9
    the verdict is not monotone in F: a trial stood at F = 1.8900, above
    one that did not at F = 1.8300; the factor of safety lies anywhere
    from 1.8 to 1.9, not only in the bracket
    """
    # a failure whose retry at the same factor converged: the retry's
    # verdict stands for it
    superseded = [k for k, e in enumerate(errors) if e is not None and any(
        retried[j] and errors[j] is None and trials[j][0] == trials[k][0]
        for j in range(k + 1, len(trials)))]
    kept = [k for k in range(len(trials)) if k not in superseded]
    fell = [trials[k][0] for k in kept if not trials[k][1]]
    stood = [trials[k][0] for k in kept if trials[k][1]]
    # a failure below a trial that stood, not confirmed by a failed
    # retry (a run that converged but moved past growth is a collapse:
    # the failures below it agree with it)
    doubtful = [k for k in kept if errors[k] is not None and not any(
        retried[j] and errors[j] is not None and j != k
        and trials[j][0] == trials[k][0] for j in kept) and any(
        trials[j][1] and trials[j][0] > trials[k][0] for j in kept)]
    lower = max([f for f in stood if f < min(fell)] or [min(stood)])
    upper = min(trials[k][0] for k in kept if not trials[k][1] and
                trials[k][0] > max(stood) and k not in doubtful)
    warnings = []
    for k in sorted(superseded, key=lambda k: trials[k][0]):
        warnings.append("the run at F = {:.4f} failed ({}) but stood or "
                        "converged when retried: the failure was "
                        "numerical".format(trials[k][0], errors[k]))
    below = sorted((k for k in doubtful if trials[k][0] < upper),
                   key=lambda k: trials[k][0])
    if below:
        first = trials[below[0]][0]
        warnings.append(
            "the run{} at F = {} failed ({}{}) but the one at F = {:.4f} "
            "stood: {} may be numerical (load steps too large), the "
            "factor of safety up to {:.4g}".format(
                "s" if len(below) > 1 else "",
                ", ".join("{:.4f}".format(trials[k][0]) for k in below),
                errors[below[0]], ", ..." if len(below) > 1 else "",
                min(trials[j][0] for j in kept if trials[j][1]
                    and trials[j][0] > first),
                "the failures" if len(below) > 1 else "the failure",
                upper))
    if max(stood) > min(fell):
        warnings.append(
            "the verdict is not monotone in F: a trial stood at F = {:.4f}, "
            "above one that did not at F = {:.4f}; the factor of safety "
            "lies anywhere from {:.4g} to {:.4g}, not only in the "
            "bracket".format(max(stood), min(fell), lower, upper))
    return (lower, upper), warnings


def hushed(count: int) -> str:
    """The words of a trial's INFO line on the warnings it kept quiet."""
    return "; {} warning(s) counted, not said".format(count) if count else ""
