"""Newton's method for a step problem, and its globalisation: how far to
go along a Newton direction.

:func:`newton` drives a step problem (:class:`~skfem_mpm.solve.problem.
StepProblem`, or anything with its ``residual``, ``tangent``, ``rhs``,
``solve`` and ``converged``) from a start increment to equilibrium: the
predictor of nonlinear FE codes where the step drives prescribed motion,
full or modified Newton, a line search.  It knows nothing of MPM.

The driver starts a search for each attempt at a load step (``search =
strategy.start()``), computes a Newton direction ``d`` from the tangent in
every iteration and calls ``search(evaluate, du, d, current, accept)``,
where ``evaluate`` returns the out-of-balance state at a trial grid
increment.  The search returns the
accepted increment and its evaluated state, which the next iteration
reuses: a full step that is accepted costs nothing extra.  The core never
asks which strategy it runs.

:class:`Backtracking` is Armijo backtracking on the merit function
``phi = |r|^2 / 2`` of the out-of-balance force ``r`` over the free DOFs,
with quadratic interpolation of ``phi`` between trials (Dennis and
Schnabel, *Numerical Methods for Unconstrained Optimization and Nonlinear
Equations*, 1983, section 6.3), guarded by a watchdog (Chamberlain,
Powell, Lemarechal and Pedersen, *Math. Prog. Study* 16, 1982): full
Newton steps are taken as long as the residual falls below the best one so
far within ``watchdog`` iterations; when it does not, or when a full step
inverts a point or fails in arithmetic (an overshoot in finite
deformation), the search returns to the best state and backtracks along its
Newton direction until the residual decreases sufficiently.  With the
consistent tangent ``K``, ``K d = r`` makes ``d`` a descent direction with
``phi'(0) = -|r|^2``.  Where no step length down to ``min_step`` decreases
the residual (one that jumps as points change cell within the iteration),
the full Newton step is taken, as plain Newton would.

Newton's path to a solution of a structural problem often climbs first
(a cantilever's first full step under a large tip load, a nearly
incompressible beam: ``docs/robustness.md``), and a residual line search
slows such steps down.  So the default (``line_search="backtracking"``,
:func:`make_line_search`) runs a load step in two stages: first Newton's
full steps, shortened only where a step cannot be evaluated (a point
inverts: ``watchdog=None``), which changes nothing where plain Newton
converges; a step that fails so is retried with the plain Armijo search
(``watchdog=0``; after the ghost penalty that ``ghost="auto"`` holds in
reserve, before the stabilised tangent and any cut-back), which first
takes the step length on the energy's slope where a full step has gone
past the energy's minimum along its direction (``slope=True``,
:meth:`Backtracking.along_slope`: perfectly plastic points far beyond
yield make the residual's norm a poor merit), and once a retry
has carried a step, the run's later steps start with that search
(``counters["line_search_from_step"]``): where full steps failed one step
they fail its neighbours too.  Perfectly plastic soil under a footing
failed full steps at every one of 40 steps, 25 iterations each, and the
Armijo search with the watchdog then needed cut-backs at 18 of them;
with the plain search from the first step that failed on, the footing
pushed by an obstacle ran in 43 steps instead of 58 and 3.5 times
faster, and the footing of grid nodes with finite elements 3.8 times
faster (``benchmarks/line_search_cost.py``).  ``line_search="armijo"``
runs the Armijo search behind the watchdog from the first attempt on.
:class:`FullStep` is plain Newton.
"""
import logging
import math
import sys
from dataclasses import dataclass
from typing import Callable, List, NamedTuple, Optional, Union

import numpy as np
from numpy import ndarray

from ..kernels import run_clock
from ..errors import (InvalidInputError, InversionError, MPMError,
                      NewtonDivergenceError, SingularSystemError,
                      check_choice, check_int, check_real)
from ..protocols import of_package

logger = logging.getLogger(__name__)

__all__ = ["Backtracking", "FullStep", "make_line_search", "LINE_SEARCHES",
           "newton", "Converged", "MODIFIED_RATE", "MERIT_LIMIT",
           "ROUNDOFF_LIMIT", "CORRECTION_ROUNDOFF", "SLOPE_RATIO",
           "NewtonOptions", "RHS", "NEWTON"]

#: a line search on the slope of the energy (``Backtracking(slope=True)``)
#: takes a step length where the slope along the direction has fallen to
#: this fraction of its start's (Crisfield's 0.5-0.8; 0.5 took the pile
#: scene of :meth:`Backtracking.along_slope` in 23 iterations, 0.8 in 38)
SLOPE_RATIO = .5

#: the right-hand sides of a linear step (``rhs=``): the out-of-balance
#: force, or the seed's literal load increment
RHS = ("residual", "increment")
#: Newton's tangent: refactorised every iteration, or kept over a step
NEWTON = ("full", "modified")

#: modified Newton refactorises the tangent when an iteration with the
#: factorised one reduced the residual by less than this factor (a linear
#: rate of 0.25 reaches a tolerance of 1e-9 in 15 iterations)
MODIFIED_RATE = .25

LINE_SEARCHES = ("backtracking", "armijo", "none")
# what a trial step may raise that a shorter step can avoid
TRIAL_FAILURES = (InversionError, ArithmeticError, np.linalg.LinAlgError)
#: the largest residual norm (``merit``) a trial may have: beyond it the
#: line search's ``phi = merit^2 / 2`` overflows, and such a trial is
#: rejected as one whose residual is NaN (a diverging trial gives either,
#: depending on where its arithmetic overflows first: a numpy pass gave
#: 1e178 where the compiled one gave NaN, and the two took different
#: rungs of the retry ladder)
MERIT_LIMIT = math.sqrt(sys.float_info.max)
#: the largest relative residual a step may end at, above the tolerance,
#: where the arithmetic can do no better (:data:`CORRECTION_ROUNDOFF`)
ROUNDOFF_LIMIT = 1e-6
#: a step (linear or not) whose last iteration did not halve the residual,
#: now within :data:`ROUNDOFF_LIMIT`, and whose Newton correction is
#: smaller than this share of the step's increment (their largest
#: entries) has met the round-off of its residual: it ends there (the
#: correction changes nothing but the increment's last digits).  A user's
#: Cook's membrane at nu = 0.4999 stayed at 3.2e-9-3.7e-9 over 24 solves
#: of its linear step (64 x 64 finite elements), and with elements of
#: second order in finite deformation converged quadratically to 1.8e-9
#: and then asked for corrections of 2e-15 of its increment, its residual
#: between 1.5e-9 and 1.9e-9: both failed.  A step still converging (a
#: reviewer's translated plastic box: corrections of 1e-12 of an increment
#: made large by a rigid translation, its residual falling from 6.6e-5 to
#: 4.9e-8) halves its residual and goes on
CORRECTION_ROUNDOFF = 1e-12
#: a failed Newton loop whose last :data:`LINEAR_ITERATIONS` residuals
#: each fell by a factor within :data:`LINEAR_RATES` converged linearly
#: (:func:`linear_rate`): its error says so, and where a user's material
#: took part, that its tangent may not be its stress's derivative (a
#: trial's material returning the elastic tangent past its knee fell by
#: 0.53 an iteration and failed at 2.1e-9 after 25, with no word why)
LINEAR_ITERATIONS = 5
LINEAR_RATES = (.02, .9)
#: a Newton loop whose last :data:`STALL_ITERATIONS` residuals stay
#: within a factor :data:`STALL_SPREAD` of each other has stalled, and one
#: whose last :data:`STALL_ITERATIONS` all lie above :data:`ASTRAY_FACTOR`
#: times the smallest before them, flat from the second, has gone astray:
#: either fails then, not
#: after ``max_iter`` (:func:`stalled`).  A trial's 3D footing at its
#: collapse sat at a relative residual of 1.000 from iteration 6 to 25,
#: its tangents ever more singular (Pardiso perturbed 2, 12, then 6464
#: pivots of 12152), minutes an iteration; a c-phi footing sat at 1.59e-6
#: for 20 iterations of every attempt and cut-back.  A loop whose last
#: :data:`FLAT_ITERATIONS` residuals stay within :data:`STALL_SPREAD` of
#: each other at any level has made no progress: a trial's 3D footing
#: with mean dilatation sat at 1.000 from iteration 6 to 25 of its line
#: search (its smallest 0.82, so not astray), 2.5 s an iteration, and the
#: ladder's stabilised tangent then converged in 11
STALL_ITERATIONS = 5
FLAT_ITERATIONS = 10
STALL_SPREAD = 1.05
#: the largest relative residual counted as a stall (a floor near
#: equilibrium); Newton sitting higher goes on (a body far too soft for its
#: weight sat at 0.96 and found its way out to another failure)
STALL_LEVEL = 1e-3
ASTRAY_FACTOR = 2.
#: seconds into a Newton loop after which each iteration's residual is
#: logged at INFO, not DEBUG: a trial's 3D step of 22 s said nothing
#: until it ended
SLOW_ITERATIONS = 5.


class FullStep:
    """Plain Newton: the whole step, whatever it does to the residual."""

    def __repr__(self):
        return "FullStep()"

    def start(self) -> Callable:
        """The search of one attempt at a load step: returns ``(du + d,
        evaluate(du + d), 0)`` (no extra evaluations)."""
        def search(evaluate, du, d, current, accept):
            return du + d, evaluate(du + d), 0
        search.full_steps = True        # (:func:`stalled`: astray)
        return search


def trial_state(evaluate: Callable, du: ndarray):
    """``(state, merit)`` of the increment ``du``; ``(None, inf)`` where the
    trial inverts a point, fails in arithmetic or gives a residual that is
    not finite or beyond :data:`MERIT_LIMIT`."""
    try:
        state = evaluate(du)
    except TRIAL_FAILURES as err:
        logger.debug("line search: trial failed: %s", err)
        return None, np.inf
    if not state.merit < MERIT_LIMIT:         # overflow without an error
        logger.debug("line search: trial residual is %s", state.merit)
        return None, np.inf
    return state, state.merit


class Backtracking:
    """Armijo backtracking on ``phi = |r_free|^2 / 2`` behind a watchdog.

    Parameters
    ----------
    sufficient_decrease
        Armijo's constant ``c``: a step length ``s`` from the best state is
        accepted when ``phi(s) <= phi(0) (1 - 2 c s)``, or when its residual
        already meets the step's tolerance.
    max_trials
        Shortened steps evaluated per search at the most (besides the full
        step); when none decreases the residual sufficiently, the full
        Newton step is taken (evaluated once more), as plain Newton would:
        where the residual jumps, e.g. as a point changes cell during the
        iteration, Newton's next iterate may still land in the basin of
        the solution.
    shrink
        Bounds of the factor a rejected step length is multiplied by; within
        them, the minimiser of the quadratic through ``phi(0)``,
        ``phi'(0)`` and ``phi(s)``.
    watchdog
        Full Newton steps taken from the best state before the residual
        must have fallen below it (0: backtrack whenever a full step does
        not decrease the residual sufficiently, the plain Armijo search;
        ``None``: take every full step that can be evaluated, backtrack
        from the current state only where it cannot, as where a point
        inverts).
    min_step
        The shortest step length accepted: a Newton direction along which
        only shorter steps decrease the residual makes no progress (it
        belongs to another branch of a residual that jumps): the full step
        is taken instead of crawling.
    slope
        Where a full step is rejected and has gone past the minimum of
        the energy along the direction, first the step length where the
        energy's slope has fallen (:meth:`along_slope`), whatever the
        residual's norm does there.

    Examples
    --------
    On ``r(u) = 1 - u^3`` from ``u = 0.1`` Newton's full step overshoots to
    ``u = 33.4`` (a residual 4e4 times larger); the watchdog lets it go
    twice, then returns and backtracks:

    >>> import numpy as np
    >>> class State:
    ...     def __init__(self, u):
    ...         self.u, self.r = u, 1 - u ** 3
    ...         self.merit = float(np.abs(self.r).max())
    >>> search, state = Backtracking().start(), State(np.array([.1]))
    >>> for it in range(12):
    ...     d = state.r / (3 * state.u ** 2)
    ...     u, state, extra = search(State, state.u, d, state,
    ...                              lambda s: s.merit < 1e-12)
    >>> float(state.u[0]), state.merit < 1e-12
    (1.0, True)

    """

    def __init__(self, sufficient_decrease: float = 1e-4,
                 max_trials: int = 10, shrink=(.1, .5), watchdog: int = 2,
                 min_step: float = 1e-3, slope: bool = False):
        if isinstance(shrink, (str, bytes)) or np.shape(shrink) != (2,):
            raise InvalidInputError("shrink must be two numbers (low, high), "
                                    "got {!r}".format(shrink))
        low, high = (check_real("shrink", value) for value in shrink)
        sufficient_decrease = check_real("sufficient_decrease",
                                         sufficient_decrease)
        min_step = check_real("min_step", min_step)
        if not (0 < sufficient_decrease < .5 and 0 < low <= high < 1
                and 0 < min_step < 1):
            raise InvalidInputError(
                "Backtracking needs 0 < sufficient_decrease < 0.5, "
                "0 < shrink[0] <= shrink[1] < 1 and 0 < min_step < 1, got "
                "{!r}, {!r} and {!r}".format(sufficient_decrease, shrink,
                                             min_step))
        for name, value, high_ in (("max_trials", max_trials, 60),
                                   ("watchdog", watchdog, 10)):
            if name == "watchdog" and value is None:
                continue
            if isinstance(value, bool) or not isinstance(
                    value, (int, np.integer)) or not (
                        name == "watchdog" or value >= 1) \
                    or not 0 <= value <= high_:
                raise InvalidInputError(
                    "{} must be an integer in [{}, {}], got {!r}".format(
                        name, int(name == "max_trials"), high_, value))
        self.c, self.max_trials = sufficient_decrease, int(max_trials)
        self.shrink = (float(low), float(high))
        self.watchdog = None if watchdog is None else int(watchdog)
        self.min_step = float(min_step)
        if not isinstance(slope, (bool, np.bool_)):
            raise InvalidInputError(
                "slope must be True or False, got {!r}".format(slope))
        self.slope = bool(slope)

    def __repr__(self):
        return "Backtracking(sufficient_decrease={}, max_trials={}, " \
            "shrink={}, watchdog={}, min_step={}{})".format(
                self.c, self.max_trials, self.shrink, self.watchdog,
                self.min_step, ", slope=True" if self.slope else "")

    def guard(self) -> "Backtracking":
        """These settings with ``watchdog=None``: full steps, shortened
        only where they cannot be evaluated."""
        return Backtracking(self.c, self.max_trials, self.shrink, None,
                            self.min_step, self.slope)

    def start(self) -> Callable:
        """The search of one attempt at a load step, with its memory (the
        best state so far, its Newton direction and the merit of its full
        step, the full steps taken since it).  A call returns the accepted
        increment, its state and the residual evaluations it made beyond
        the one a plain Newton step makes."""
        best = {}

        def search(evaluate, du, d, current, accept):
            count = [0]

            def counted(trial):
                count[0] += 1
                return evaluate(trial)
            found = step(counted, du, d, current, accept)
            return found[0], found[1], count[0] - 1
        # full steps (the guard): a residual that rises and stays up went
        # astray (:func:`stalled`); a search's may rise on the energy's
        # slope (a stiff pile's way back to its elastic far field)
        search.full_steps = self.watchdog is None

        def step(evaluate, du, d, current, accept):
            if self.watchdog is None:
                state, merit = trial_state(evaluate, du + d)
                if state is not None:
                    return du + d, state
                best.update(du=du, merit=current.merit, d=d, relaxed=0)
                return finish(evaluate, du, d, accept, merit)
            if not best or current.merit ** 2 <= best["merit"] ** 2 * (
                    1. - 2. * self.c):
                best.clear()
                best.update(du=du, merit=current.merit, d=d, relaxed=0,
                            r=current.r)
            else:
                best["relaxed"] += 1
            if best["relaxed"] < max(self.watchdog, 1):
                state, merit = trial_state(evaluate, du + d)
                if state is not None and (
                        self.watchdog or accept(state) or merit ** 2 <=
                        best["merit"] ** 2 * (1. - 2. * self.c)):
                    if best["relaxed"] == 0:
                        best["full"] = merit
                    return du + d, state
                if best["relaxed"] == 0:
                    best["full"] = merit
                    best["full_slope"] = -np.inf if state is None else \
                        float(d @ state.r)
            return finish(evaluate, du, d, accept, best.get("full"))

        def finish(evaluate, du, d, accept, full):
            found = self.backtrack(evaluate, best, accept, full)
            best.clear()                  # the next call starts afresh
            if found is not None:
                return found
            logger.debug("line search: no sufficient decrease down to a "
                         "step length of %.1e; taking the full Newton step",
                         self.min_step)
            # evaluated again: the trials since have overwritten the
            # kinematics' work arrays that its state refers to
            return du + d, evaluate(du + d)
        return search

    def backtrack(self, evaluate, best: dict, accept, full):
        """Shortened steps from the best state along its Newton direction
        (``full``: the merit of its full step where already evaluated and
        rejected): ``(du, state)`` of the accepted step, or ``None`` when
        none down to ``min_step`` decreases the residual sufficiently.
        With :attr:`slope`, first the step length where the slope of the
        energy along the direction has fallen (:meth:`along_slope`)."""
        if self.slope:
            found = self.along_slope(evaluate, best, accept)
            if found is not None:
                return found
        du, d, merit0 = best["du"], best["d"], best["merit"]
        phi0, slope = .5 * merit0 ** 2, -merit0 ** 2
        low, high = self.shrink
        s = 1.
        for trial in range(self.max_trials + 1):
            if trial or full is None:
                state, merit = trial_state(evaluate, du + s * d)
            else:
                state, merit = None, full
            phi = .5 * merit ** 2
            if state is not None and (accept(state) or phi <= phi0 * (
                    1. - 2. * self.c * s)):
                logger.debug("line search: step length %.3e after %d "
                             "trial(s)", s, trial)
                return du + s * d, state
            if trial == self.max_trials or s <= self.min_step:
                break
            if np.isfinite(phi):
                curvature = phi - phi0 - slope * s
                guess = -slope * s * s / (2. * curvature) \
                    if curvature > 0 else high * s
                s = min(max(guess, low * s), high * s)
            else:
                s *= low
            s = max(s, self.min_step)
        return None

    def along_slope(self, evaluate, best: dict, accept):
        """The step length ``s`` from the best state along its Newton
        direction ``d`` where the slope ``g(s) = d . r(du + s d)`` of the
        energy (``-d . grad``: ``g(0) = r^T K^-1 r > 0`` with a positive
        definite tangent ``K``) has fallen to ``|g(s)| <= SLOPE_RATIO
        g(0)``, found by regula falsi (Illinois) on ``[0, 1]`` where the
        full step has gone past the energy's minimum (``g(1) < 0``): the
        line search of Crisfield (*Non-linear Finite Element Analysis of
        Solids and Structures* 1, 1991, section 9.3) and of Matthies and
        Strang (*IJNME* 14, 1979).  ``(du, state)``, or ``None`` where the
        full step has not gone past it, ``g(0) <= 0`` (no descent of an
        energy) or no trial within :attr:`max_trials` meets the test.

        The residual's norm is the wrong merit where plasticity's energy
        grows only linearly (perfectly plastic points far beyond their
        yield surface, whose tangent is nearly flat): from an elastic
        first trial that yields every point, Newton's direction towards
        the far field's elastic unloading raises ``|r|`` at every step
        length above 1e-3 while it lowers the energy (a pile in von Mises
        soil with mean dilatation: Armijo's steps crawled and the step
        failed at every cut-back; its step lengths here were 0.005 to
        0.5 at first, the full step after)."""
        full_slope = best.get("full_slope")
        if full_slope is None or "r" not in best:
            return None
        du, d = best["du"], best["d"]
        g0 = float(d @ best["r"])
        if not g0 > 0 or not full_slope < -SLOPE_RATIO * g0:
            return None
        a, ga, b, gb = 0., g0, 1., max(full_slope, -1e3 * g0)
        side = 0
        for trial in range(self.max_trials):
            s = (a * gb - b * ga) / (gb - ga)
            s = min(max(s, self.min_step), 1. - self.min_step)
            state, _ = trial_state(evaluate, du + s * d)
            if state is None:               # inverted: shorter
                b, gb, side = s, -g0, -1
                continue
            g = float(d @ state.r)
            if accept(state) or abs(g) <= SLOPE_RATIO * g0:
                logger.debug("line search: step length %.3e on the slope "
                             "after %d trial(s)", s, trial + 1)
                return du + s * d, state
            if g > 0:
                if side == 1:               # Illinois: halve the far end
                    gb /= 2
                a, ga, side = s, g, 1
            else:
                if side == -1:
                    ga /= 2
                b, gb, side = s, g, -1
        return None


def make_line_search(line_search):
    """The strategies of a load step's two Newton attempts for
    ``line_search``: ``(first, retry)``.

    ``"backtracking"``: ``(Backtracking().guard(),
    Backtracking(watchdog=0, slope=True))``, full steps shortened only
    where they cannot be evaluated, then the plain Armijo search, first
    along the energy's slope, on a retry (the run
    starts its later steps with it, :mod:`skfem_mpm.solve.core`);
    ``"armijo"``: ``(Backtracking(), None)``, the Armijo
    search from the first attempt on, as a :class:`Backtracking` of one's
    own, ``(b, None)``; ``"none"`` or a :class:`FullStep`: plain Newton,
    ``(FullStep(), None)``.

    >>> make_line_search("none")
    (FullStep(), None)
    >>> make_line_search("armijo")[1] is None
    True
    """
    if isinstance(line_search, str) and line_search == "backtracking":
        return Backtracking().guard(), Backtracking(watchdog=0, slope=True)
    if isinstance(line_search, str) and line_search == "armijo":
        line_search = Backtracking()
    if isinstance(line_search, Backtracking):
        return line_search, None
    if isinstance(line_search, FullStep) or (
            isinstance(line_search, str) and line_search == "none"):
        return FullStep(), None
    raise InvalidInputError(
        "line_search must be one of {}, a Backtracking(...) or FullStep(), "
        "got {!r}".format(LINE_SEARCHES, line_search))


@dataclass(frozen=True)
class NewtonOptions:
    """How the load steps iterate to equilibrium; validated on creation.

    Parameters
    ----------
    tol
        Tolerance on the out-of-balance force over the free DOFs relative
        to the larger of the external force and the internal force on the
        DOFs whose motion is prescribed (the forces that drive it: a shear
        box under a small weight is measured against its shear force), in
        (0, 1).  A step whose residual the arithmetic cannot bring below
        it, within :data:`ROUNDOFF_LIMIT`, ends there with a warning
        (:data:`CORRECTION_ROUNDOFF`).
    max_iter
        Newton iterations per attempt at a step, 1 to 60.
    max_cutbacks
        A nonlinear step that fails after the retry ladder is bisected,
        down to ``2**-max_cutbacks`` of a step (0 to 60); not where a
        shorter step cannot help (contact with a support that holds the
        material's way, a quasi-static load that no load factor
        balances: :func:`~skfem_mpm.solve.core.no_equilibrium`).  A
        cut-back's increment lasts to the load step's end (a time step's
        to the next multiple of ``time_step``) unless ``grow_back``.
    line_search
        Globalisation: ``"backtracking"`` (default: Newton's full steps,
        shortened only where one inverts a point; a step that fails so is
        retried with Armijo backtracking on the residual, and the steps
        after one so carried start with it:
        ``counters["line_search_from_step"]``), ``"armijo"`` (Armijo
        behind a watchdog from the first attempt), ``"none"`` or :class:`FullStep`
        (plain Newton), or a :class:`Backtracking` of one's own (from the
        first attempt).  Linear steps solve once, and again where the
        residual is still above ``tol`` (:data:`CORRECTION_ROUNDOFF`).
    newton
        ``"full"``: the consistent tangent assembled and factorised in
        every iteration (quadratic convergence).  ``"modified"``: a load
        step's first factorised tangent serves its iterations and is
        refactorised where an iteration reduced the residual by less than
        :data:`MODIFIED_RATE` (linear convergence, the same state to the
        tolerance); a step whose modified iterations fail is retried with
        full Newton.  Refused with an adaptive time step.
    rhs
        Right-hand side of a linear step's solve: ``"residual"`` (the
        out-of-balance force) or ``"increment"`` (the seed's literal load
        increment; linear steps only, which leaves the out-of-balance force
        of earlier steps uncorrected).
    grow_back
        ``False`` (default): as above.  ``True``: a cut-back's increment
        doubles back (up to a whole step) after two sub-steps in a row
        that took at most half ``max_iter`` Newton iterations
        (:func:`~skfem_mpm.solve.core.grown_increment`; fixed time steps
        too; ``counters["easy_sub_steps"]``).  A trade-off, so not the
        default: a trial's footing that crawled 128 sub-steps of 3.9e-4
        to the end of a step after 7 cut-backs takes 13 to 17, but the
        changed load path can fail where the crawl completes: that
        Mohr-Coulomb footing later fails at a load factor of 0.86 and an
        untuned cantilever (``test_newton.py``) at 0.55, both complete
        without it.  Without it a run says once (at INFO) where a
        cut-back's increment went on easily.

    >>> from skfem_mpm import NewtonOptions
    >>> NewtonOptions(tol=1e-10).max_iter
    25
    >>> NewtonOptions(newton="quasi")
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: newton must be one of ('full', 'modified'), got 'quasi'
    """
    tol: float = 1e-9
    max_iter: int = 25
    max_cutbacks: int = 8
    line_search: Union[str, "Backtracking", FullStep] = "backtracking"
    newton: str = "full"
    rhs: str = "residual"
    grow_back: bool = False

    def __post_init__(self):
        tol = check_real("tol", self.tol)
        if not 0 < tol < 1:
            raise InvalidInputError("tol must lie in (0, 1), got {!r}".format(
                self.tol))
        check_int("max_iter", self.max_iter, 1, 60)
        check_int("max_cutbacks", self.max_cutbacks, 0, 60)
        check_choice("newton", self.newton, NEWTON)
        check_choice("rhs", self.rhs, RHS)
        if not isinstance(self.grow_back, (bool, np.bool_)):
            raise InvalidInputError("grow_back must be True or False, got "
                                    "{!r}".format(self.grow_back))
        make_line_search(self.line_search)

    @property
    def strategies(self) -> tuple:
        """The line searches of a step's first attempt and of its retry
        (:func:`make_line_search`)."""
        return make_line_search(self.line_search)


class Converged(NamedTuple):
    """What :func:`newton` returns: the converged increment, its trial
    state, the residual of every iteration and (``keep=True``) the solve
    of the last factorised tangent, or ``None``."""
    du: ndarray
    trial: object
    residuals: List[float]
    factorised: Optional[Callable] = None


def start_share(problem, like: ndarray, first: float) -> Optional[float]:
    """The share of a failed step's first out-of-balance force ``first``
    (its norm) that the step's start holds
    (:meth:`~skfem_mpm.solve.problem.StepProblem.start_imbalance`), or
    ``None`` where the problem does not tell: near 1 where a shorter step
    cannot help, near 0 where the load increment unbalances the step (a
    run's first step from rest: its first residual is 1 at every
    cut-back)."""
    imbalance = getattr(problem, "start_imbalance", None)
    if imbalance is None or not first > 0.:
        return None
    try:
        found = imbalance(like)
    except MPMError:
        return None
    return None if found is None else found / first


def newton(problem, du: ndarray, search: Callable, *, max_iter: int,
           modified: bool = False, stabilise: bool = False,
           single_solve: bool = False, report: dict = None,
           predict: bool = True, keep: bool = False,
           seed: Optional[Callable] = None,
           tol: Optional[float] = None, relative: bool = False,
           response=None) -> Converged:
    """Newton-Raphson on ``problem`` from the grid increment ``du``.

    Parameters
    ----------
    problem
        ``residual(du) -> trial`` (with ``merit``, ``residual``),
        ``converged(trial)``, ``tangent(trial) -> K``, ``rhs(trial)``,
        ``solve(K, r, stabilise) -> (d, factorised solve)``, ``free``
        (the free DOFs), ``driven`` (DOFs of prescribed motion), ``linear``
        (one exact solve makes the step), ``keeps_factorisations``,
        ``step``, ``counters``, ``t``.
    search
        The attempt's line search (``strategy.start()``).
    max_iter
        Iterations at the most; :class:`~skfem_mpm.errors.
        NewtonDivergenceError` after them or at a residual not finite
        (or beyond :data:`MERIT_LIMIT`).
    modified
        Keep the first factorised tangent while each iteration cuts the
        residual by :data:`MODIFIED_RATE` at least.
    stabilise
        Every solve with the stabilised tangent.
    single_solve
        Stop after one solve (the seed's one-solve scheme).
    report
        A dict that receives ``reused``: whether a factorisation served a
        second iteration (so a failure may be modified Newton's), and on
        a failure ``smallest``: the smallest residual reached.
    predict
        Take the predictor below where prescribed motion drives the step
        (``False``: ``du`` is already a solution's neighbour, a step
        solved again after a term's constraint moved).
    keep
        Return the solve of the last factorised tangent (kept alive
        between iterations, so for a problem whose terms may ask for the
        step to be solved again).
    response
        The kinematics' response to ``du`` where it is at hand (the last
        trial's of a solve that a term's constraint moved): the first
        trial is not evaluated again.
    tol
        Converged at this relative residual instead of the problem's own
        test (``problem.converged``): a looser one where a term will move
        its constraint after Newton anyway.
    relative
        ``tol`` is relative to the first residual (or the problem's own
        test holds): a solve after a term
        moved its constraint resolves that move, whatever the residual it
        starts from (a soft block's contact with a stiff one moved it by
        1e-4 of the load: at an absolute loose residual no solve
        followed, and the rounds repeated one update 30 times).
    seed
        A factorised solve to take the first direction with (a
        neighbouring tangent's: the kept one of a solve that a term's
        constraint moved); the iterations after it are Newton's as asked
        (with ``modified``, the seed is the kept tangent).

    A nonlinear step driven by prescribed motion takes its first Newton
    step with the tangent of the step's start and the prescribed
    increments as loads (the predictor of nonlinear FE codes): the tangent
    at the first trial, where only the driven nodes have moved, sees a band
    of spurious yielding along them (a whole soil layer behind a moved
    base) and sends Newton astray.
    """
    predictor = None
    frozen = seed if modified else None
    converged = problem.converged if tol is None else (
        lambda trial: problem.converged(trial) or trial.residual <= tol * (
            residuals[0] if relative else 1.))
    if predict and not problem.linear and problem.driven.size:
        start = problem.residual(np.zeros_like(du))
        K_start = problem.tangent(start)
        predictor = K_start, start.r - K_start @ du
        del K_start
    try:
        current = problem.residual(du, None if predictor is not None
                                   else response)
    except InversionError as err:
        raise InversionError("step {}: {}".format(problem.step, err)) \
            from err
    residuals, last, first_merit = [], None, current.merit
    report = {} if report is None else report
    report["reused"] = False
    started = run_clock()
    for it in range(max_iter + 1):
        residuals.append(float(current.residual))
        logger.log(logging.INFO if run_clock() - started > SLOW_ITERATIONS
                   else logging.DEBUG, "step %d iteration %d: residual %.3e",
                   problem.step, it, residuals[-1])
        if converged(current) or problem.free.size == 0 or (
                single_solve and it == 1):
            break
        stuck = stalled(residuals, getattr(search, "full_steps", False))
        if it == max_iter or not np.isfinite(residuals[-1]) or \
                not current.merit < MERIT_LIMIT or stuck:
            report["smallest"] = min(residuals)
            if stuck and stuck[0] == "stalled":
                report["stalled"] = stuck[1]
            run = getattr(problem, "run", None)    # (a problem of tests)
            material = getattr(run, "material", None)
            terms = getattr(problem, "terms", ())
            words = (stall_words(stuck) + residual_place(problem, current)
                     if stuck and stuck[0] == "stalled" else
                     stall_words(stuck, problem)) + (
                "" if stuck else linear_words(
                    residuals, material, stabilise,
                    modified or report["reused"], report, terms))
            own = suspects(material, terms)
            if own and own not in words and np.isfinite(residuals[-1]) \
                    and not (stuck and stuck[0] == "stalled"):
                # a diverging loop with extensions of the user's own
                # (trial 116's spring matrix 0.3 of its derivative)
                words += "; extensions of your own take part: " + own
            error = NewtonDivergenceError(
                "step {}: {} did not converge in {} iterations (residual "
                "first {:.3g}, smallest {:.3g}, last {:.3g}{}){}".format(
                    problem.step, "the equilibrium iteration"
                    if problem.linear else "Newton-Raphson", it,
                    residuals[0], min(residuals), residuals[-1],
                    tolerance_words(tol, getattr(run, "tol", None),
                                    residuals[0] if relative else None),
                    words))
            error.stalled = report.get("stalled")
            error.first_residual = residuals[0]
            error.start_share = start_share(problem, du, first_merit)
            raise error
        if it == 0 and predictor is not None:
            d = problem.solve(*predictor, stabilise)[0]
            predictor = None              # memory: freed before the tangent
            moved = predicted(problem, du, d, current)
            if moved is not None:
                du, current = moved
                continue
            current = problem.residual(du)
        last = None         # memory: not alive while a tangent is formed
        served = seed if seed is not None else frozen
        d, solve = newton_direction(problem, current, served, residuals,
                                    stabilise, report,
                                    reuse=seed is not None or None)
        seed = None
        if it >= 1 and residuals[-2] / 2 < residuals[-1] <= ROUNDOFF_LIMIT \
                and np.abs(d).max() <= CORRECTION_ROUNDOFF * np.abs(du).max():
            logger.debug("step %d: a correction of %.1e of the increment: "
                         "at the round-off of the residual", problem.step,
                         np.abs(d).max() / np.abs(du).max())
            break
        if modified and solve is not None:
            frozen = solve
        if keep:
            last = solve if solve is not None else served
        del solve, served
        try:
            du, current, extra = search(problem.residual, du, d, current,
                                        converged)
        except InversionError as err:
            raise InversionError("step {}: {}".format(problem.step, err)) \
                from err
        problem.counters["line_search_trials"] += extra
    return Converged(du, current, residuals, last)


def stalled(residuals: List[float],
            full_steps: bool = True) -> Optional[tuple]:
    """``("stalled", level)`` where the last :data:`STALL_ITERATIONS`
    ``residuals`` lie within a factor :data:`STALL_SPREAD` of each other
    (``level``, their smallest) and below :data:`STALL_LEVEL`,
    ``("astray", smallest)`` (``full_steps``: Newton's whole steps,
    no search that may raise the residual on purpose) where they all
    lie above :data:`ASTRAY_FACTOR` times the smallest before them, the
    last but one on, flat (within :data:`STALL_SPREAD`: a Newton loop
    that overshot and comes back down goes on, a cantilever's first full
    step raised its residual 470-fold and converged), ``("flat", level)``
    where the last :data:`FLAT_ITERATIONS` lie within :data:`STALL_SPREAD`
    of each other (a search's too; below :data:`STALL_LEVEL` they have
    stalled first); else ``None``.

    >>> stalled([1e-3, 2e-5, 1.59e-6, 1.59e-6, 1.6e-6, 1.59e-6, 1.59e-6])
    ('stalled', 1.59e-06)
    >>> stalled([.99, .52, .36, .35, .48, .87, 1., 1., 1., 1.])[0]
    'astray'
    >>> stalled([1., .1, .01, .001, 1e-4, 1e-5]) is None
    True
    >>> stalled([.99, .82] + [1.] * 10)
    ('flat', 1.0)
    >>> stalled([.99, .82] + [1.] * 9) is None
    True
    """
    last = np.asarray(residuals[-STALL_ITERATIONS:], dtype=float)
    if len(residuals) <= STALL_ITERATIONS or not np.isfinite(last).all():
        return None
    if 0. < last.min() and last.max() <= STALL_SPREAD * last.min() and \
            last.max() <= STALL_LEVEL:
        return "stalled", float(last.min())
    before = min(residuals[:-STALL_ITERATIONS])
    flat = last[1:].min() > 0. and last[1:].max() <= \
        STALL_SPREAD * last[1:].min()
    if full_steps and last.min() > ASTRAY_FACTOR * before and flat:
        return "astray", float(before)
    level = np.asarray(residuals[-FLAT_ITERATIONS:], dtype=float)
    if len(residuals) >= FLAT_ITERATIONS and \
            level.min() > 0. and level.max() <= STALL_SPREAD * level.min():
        return "flat", float(level.min())
    return None


def stall_words(stuck: Optional[tuple], problem=None) -> str:
    """What a Newton loop :func:`stalled` at says of it, or ``""``;
    where one of ``problem``'s terms says its contact engaged or let go
    within the step (``engaging_words()``), that instead of a body
    collapsing; where the run's material is elastic (no return map:
    ``plastic`` false), grid nodes that slivers of material barely hold
    (an elastic pile with the B-splines, in soil through a contact,
    stalled and was asked whether it was collapsing before the ghost
    penalty carried it: a user trial), buckling in finite deformation,
    or a contact's changes or its load past what it holds.

    >>> from types import SimpleNamespace as S
    >>> from skfem_mpm import LinearElastic
    >>> print(stall_words(("flat", 1e-3), S(run=S(
    ...     material=LinearElastic(1e4, .3), finite=False), terms=())))
    ... # doctest: +NORMALIZE_WHITESPACE
    ; stopped early: the last 10 residuals all stayed within a factor 1.05
    of 0.001: Newton made no progress (the bodies are elastic, not
    collapsing: a tangent near-singular at grid nodes that slivers of
    material barely hold, cut cells the ghost penalty ties)
    """
    if not stuck:
        return ""
    engaging = [words for words in (
        getattr(term, "engaging_words", lambda: "")()
        for term in getattr(problem, "terms", ())) if words]
    run = getattr(problem, "run", None)
    material = getattr(run, "material", None)
    cause = "a tangent that lost its stiffness, the body collapsing?"
    if material is not None and not getattr(material, "plastic", True):
        finite = getattr(run, "finite", False)
        cause = ("the bodies are elastic{}: a tangent near-singular at "
                 "grid nodes that slivers of material barely hold, cut "
                 "cells the ghost penalty ties{}{}".format(
                     "" if finite else ", not collapsing",
                     ", or buckling" if finite else "",
                     ", or a contact changing within the step or not "
                     "holding the load" if any(
                         getattr(term, "contact", False)
                         for term in getattr(problem, "terms", ()))
                     else ""))
    if engaging:
        cause = "; ".join(engaging) + "; or " + cause
    own = suspects(getattr(getattr(problem, "run", None), "material", None),
                   getattr(problem, "terms", ()))
    if own:
        cause += "; or " + own
    if stuck[0] == "stalled":
        return ("; stopped early: the residual stalled at {:.3g} over the "
                "last {} iterations (within a factor {:g}): a floor of the "
                "residual, not a divergence".format(
                    stuck[1], STALL_ITERATIONS, STALL_SPREAD))
    if stuck[0] == "flat":
        return ("; stopped early: the last {} residuals all stayed within "
                "a factor {:g} of {:.3g}: Newton made no progress ({})"
                .format(FLAT_ITERATIONS, STALL_SPREAD, stuck[1], cause))
    return ("; stopped early: the last {} residuals all stayed above {:g} "
            "times the smallest, {:.3g}: Newton went astray ({})".format(
                STALL_ITERATIONS, ASTRAY_FACTOR, stuck[1], cause))


def residual_place(problem, current) -> str:
    """Where a stalled residual sits: the share of its square at the grid
    node of its largest entry, and where that node is (a c-phi footing's
    stalled at two nodes one point held, beside the footing's edge), or
    ``""`` where the problem has no grid positions."""
    free = getattr(problem, "free", None)
    doflocs = getattr(getattr(problem, "grid", None), "doflocs", None)
    if free is None or doflocs is None or not free.size:
        return ""
    r = np.asarray(current.r)[free]
    total = float(r @ r)
    if not total > 0.:
        return ""
    top = free[int(np.argmax(np.abs(r)))]
    node = np.all(doflocs[:, free] == doflocs[:, top][:, None], axis=0)
    return ", {:.0%} of it at the grid node at [{}]".format(
        float(r[node] @ r[node]) / total,
        ", ".join("{:.4g}".format(c) for c in doflocs[:, top]))


def tolerance_words(tol: Optional[float], own: Optional[float],
                    first: Optional[float] = None) -> str:
    """The tolerance a failed solve aimed at: the run's own, or ``tol``,
    the looser one of a round before a term's constraint settles
    (contact's augmented-Lagrangian update), said so with the run's (a
    trial's obstacle run said "tolerance 0.001" where its scene's was
    1e-9, and no more); ``first``: ``tol`` was relative to the solve's
    first residual ``first`` (a round after an update, far from
    settling).

    >>> tolerance_words(None, 1e-9)
    '; tolerance 1e-09'
    >>> for part in tolerance_words(1e-3, 1e-9).split(", "):
    ...     print(part)
    ; tolerance 0.001 for the first round
    before the contact's update; the run's own is 1e-09
    >>> for part in tolerance_words(1e-3, 1e-9, 0.5).split(", "):
    ...     print(part)
    ; tolerance 0.0005 (0.001 of the solve's first residual) for a round
    before the contact's next update; the run's own is 1e-09
    """
    if tol is None:
        return "" if own is None else "; tolerance {:.3g}".format(own)
    return "; tolerance {}, before the contact's {}update{}".format(
        "{:.3g} for the first round".format(tol) if first is None else
        "{:.3g} ({:.3g} of the solve's first residual) for a round".format(
            tol * first, tol), "" if first is None else "next ",
        "" if own is None else "; the run's own is {:.3g}".format(own))


def linear_rate(residuals: List[float]) -> Optional[float]:
    """The factor by which each of the last :data:`LINEAR_ITERATIONS`
    ``residuals`` fell (their geometric mean) where each fell by a factor
    within :data:`LINEAR_RATES`: a linear rate, where Newton's with the
    derivative is quadratic; else ``None``.

    >>> linear_rate([1., .1, .05, .025, .0125, .00625, .003125])
    0.5
    >>> linear_rate([1., 1e-2, 1e-5, 1e-11]) is None
    True
    """
    last = np.asarray(residuals[-LINEAR_ITERATIONS - 1:], dtype=float)
    if last.size <= LINEAR_ITERATIONS or not (last > 0).all():
        return None
    ratios = last[1:] / last[:-1]
    lo, hi = LINEAR_RATES
    if not ((ratios > lo) & (ratios < hi)).all():
        return None
    return float(np.exp(np.log(ratios).mean()))


def linear_words(residuals: List[float], material, stabilised: bool,
                 kept: bool, report: dict, terms=()) -> str:
    """What a failed Newton loop's error adds of its rate: with the
    tangent as assembled (the material's ``D``, not stabilised), every
    iteration's (not ``kept``: modified Newton, a
    kept factorisation, converge linearly by design), the words of
    :func:`linear_hint`, kept in ``report["linear"]`` for the step's
    later attempts; with the tangent ``stabilised`` (whose own rate is
    linear: a floored diagonal slowed a retry past 25 iterations), an
    earlier attempt's words where it had any, else ``""``."""
    if kept:
        return ""
    if stabilised:
        earlier = report.get("linear", "")
        return earlier and "; this attempt's tangent was stabilised; " \
            "an earlier attempt's, with the tangent as assembled: " + \
            earlier
    words = linear_hint(residuals, material, terms)
    if words:
        report["linear"] = words
    return words and "; " + words


def suspects(material, terms=()) -> str:
    """The extensions of the user's own that take part in a step, named
    as suspects of a tangent that is not the derivative of the forces
    (a material's ``D``, a grid term's ``matrix``), or ``""``: names
    only, no solve (trial 116's spring matrix 0.3 of its derivative, a
    material's ``D`` halved, ended in "Newton made no progress (... the
    body collapsing?)", neither named).

    >>> class Bed:
    ...     pass
    >>> Bed.__module__ = "my_terms"          # (a doctest's is ours)
    >>> suspects(None, [Bed()])
    'the matrix of Bed may not be the derivative of its force'
    """
    users = [] if material is None else sorted({
        type(m).__name__ for m in getattr(material, "materials", [material])
        if not of_package(m)})
    own = sorted({type(term).__name__ for term in terms
                  if not of_package(term)})
    words = []
    if users:
        words.append("the tangent D of {}'s principal_update may not be "
                     "the derivative of its stress (check it with "
                     "skfem_mpm.mechanics.element_tests.tangent_error; "
                     "docs/materials.md)".format(" and ".join(users)))
    if own:
        words.append("the matrix of {} may not be the derivative of its "
                     "force".format(" and ".join(own)))
    return ", or ".join(words)


def linear_hint(residuals: List[float], material, terms=()) -> str:
    """Where a failed Newton loop's ``residuals`` fell at a linear rate
    (:func:`linear_rate`), that rate in words, and where ``material`` (or
    one of several bodies') or one of the step's grid ``terms`` is a
    user's (defined outside this package), that its tangent may not be
    the derivative of its force (:func:`suspects`); else ``""``."""
    rate = linear_rate(residuals)
    if rate is None:
        return ""
    own = suspects(material, terms)
    return ("the residual fell by about {:.2g} an iteration over the "
            "last {}: a linear rate (Newton's with the exact derivative is "
            "quadratic){}".format(
                rate, LINEAR_ITERATIONS, "" if not own else
                ": " + own))


def predicted(problem, du: ndarray, d: ndarray, current):
    """The predictor's increment and trial where it lowers the residual;
    else ``None`` (an over-driven cell can lead it to another branch of the
    equilibrium): Newton then starts from the first trial, evaluated again
    (the predictor's trial overwrote the kinematics' work arrays)."""
    trial, merit = trial_state(problem.residual, du + d)
    if trial is not None and merit < current.merit:
        return du + d, trial
    logger.debug("step %d: the predictor raised the residual to %.3e; "
                 "Newton from the first trial", problem.step,
                 merit / max(current.merit, 1e-300) * current.residual)
    problem.counters["line_search_trials"] += 2
    return None


def newton_direction(problem, current, frozen, residuals: list,
                     stabilise: bool, report: dict, reuse: bool = None):
    """Newton's direction at ``current``: by the kept factorisation
    ``frozen`` (modified Newton) where the last iteration cut the residual
    by :data:`MODIFIED_RATE` (or where ``reuse`` says so: a seed), else
    by the tangent at ``current``, which is assembled and factorised;
    returns the direction and the factorised solve (``None`` where the
    kept one served)."""
    r = problem.rhs(current)
    if reuse is None:
        reuse = frozen is not None and residuals[-1] <= MODIFIED_RATE * \
            residuals[-2]
    if reuse:           # modified Newton (the step's tangent) or a seed
        tic = run_clock()
        try:
            d = frozen(r)
        except SingularSystemError as err:
            # a pivot check that this right-hand side set off: the
            # current tangent decides (stabilised where it must be)
            logger.debug("step %d: %s; refactorising", problem.step, err)
        else:
            counters = problem.counters
            counters["newton_iterations"] += 1
            counters["linear_solves"] += 1
            # a solver function without factorise(A) factorises anew
            counters["factorisations"] += not problem.keeps_factorisations
            report["reused"] = True
            return d, None
        finally:
            problem.t["solve"] += run_clock() - tic
    # memory: the next tangent is assembled and factorised with neither
    # this one nor (full Newton) its factorisation alive; handed over, not
    # held here, so that the solve releases it once condensed
    return problem.solve(problem.tangent(current), r, stabilise)
