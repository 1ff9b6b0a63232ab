"""Strength reduction: the reduced materials and the bracketing of the
factor of safety (with stand-in runs whose collapse factor is known)."""
from types import SimpleNamespace

import numpy as np
import pytest

from skfem_mpm import (DruckerPrager, LinearElastic, MohrCoulomb,
                       NewtonDivergenceError, PointsOutsideGridError,
                       PrescribedMotionError,
                       SingularSystemError, VonMises)
from skfem_mpm.errors import InvalidInputError
from skfem_mpm.solve.strength_reduction import (reduce_strength,
                                                strength_reduction)


def test_reduced_strength():
    vm = reduce_strength(VonMises(1e4, .3, 120.), 1.5)
    assert vm.yield_stress == 80. and vm.E == 1e4
    for soil in (MohrCoulomb(1e4, .3, cohesion=9., friction_angle=35.,
                             dilation_angle=10.),
                 DruckerPrager(1e4, .3, cohesion=9., friction_angle=35.,
                               dilation_angle=35., fit="plane_strain")):
        weak = reduce_strength(soil, 1.8)
        assert weak.cohesion == pytest.approx(5., rel=1e-15)
        for name in ("friction_angle", "dilation_angle"):
            assert np.tan(np.radians(getattr(weak, name))) == pytest.approx(
                np.tan(np.radians(getattr(soil, name))) / 1.8, rel=1e-14)
        assert type(weak) is type(soil) and weak.E == soil.E
    # associated flow stays associated
    assert reduce_strength(MohrCoulomb(1e4, .3, cohesion=1., friction_angle=
                                       30., dilation_angle=30.), 2.) \
        .dilation_angle == reduce_strength(MohrCoulomb(
            1e4, .3, cohesion=1., friction_angle=30.), 2.).friction_angle
    for material, factor, words in [
            (LinearElastic(1e4, .3), 2., "von Mises, Mohr-Coulomb"),
            (VonMises(1e4, .3, 1.), 0., "positive"),
            (VonMises(1e4, .3, 1.), np.nan, "positive"),
            (DruckerPrager(1e4, .3, cohesion=1., friction_angle=20.,
                           dilation_angle=20., hardening=5.), 2.,
             "hardening")]:
        with pytest.raises(InvalidInputError, match=words):
            reduce_strength(material, factor)


def stand_in(factor, moved=1.):
    """A stand-in result: the run at ``factor`` whose one point moved
    ``moved`` (the same below collapse)."""
    return SimpleNamespace(factor=factor, points=SimpleNamespace(
        displacement=np.array([[0.], [-moved]])))


def collapsing_at(limit, error=NewtonDivergenceError):
    def run(factor):
        if factor > limit:
            raise error("no equilibrium at {}".format(factor))
        return stand_in(factor)
    return run


@pytest.mark.parametrize("limit", [1.0001, 1.37, 1.99, 3.3, 17.])
def test_bisection_brackets_the_collapse(limit):
    s = strength_reduction(collapsing_at(limit), tolerance=1e-3)
    assert s.converged <= limit < s.failed
    assert s.failed - s.converged <= 1e-3 * s.converged
    assert abs(s.factor - limit) <= 1e-3 * limit
    assert s.result.factor == s.converged
    assert all(ok == (f <= limit) for f, ok in s.trials)


@pytest.mark.parametrize("error", [SingularSystemError,
                                   PointsOutsideGridError])
def test_a_mechanism_or_a_slide_out_of_the_grid_is_collapse_too(error):
    s = strength_reduction(collapsing_at(1.5, error), 1., 2., 1e-2)
    assert s.converged <= 1.5 < s.failed


def test_refusals():
    with pytest.raises(InvalidInputError, match="below it"):
        strength_reduction(collapsing_at(.9))
    with pytest.raises(InvalidInputError, match="nothing collapses"):
        strength_reduction(collapsing_at(np.inf))
    with pytest.raises(PrescribedMotionError):       # the caller's error
        strength_reduction(collapsing_at(1.5, PrescribedMotionError))
    with pytest.raises(InvalidInputError, match="0 < low < high"):
        strength_reduction(collapsing_at(1.5), low=2., high=1.)


def test_reduced_angles_below_a_degree_are_not_taken_for_radians():
    """A friction angle of 0.52 given by a user is refused as radians; the
    same angle reached by strength reduction (30 degrees at a factor of 64:
    atan(tan 30 / 64) = 0.517 degrees) is not."""
    from skfem_mpm import InvalidMaterialError, MohrCoulomb, reduce_strength
    soil = MohrCoulomb(1e4, .3, cohesion=10., friction_angle=30.,
                       dilation_angle=30.)
    weak = reduce_strength(soil, 64.)
    expected = np.degrees(np.arctan(np.tan(np.radians(30.)) / 64.))
    assert weak.friction_angle == pytest.approx(expected, rel=1e-12)
    assert 0. < weak.friction_angle < 1.
    with pytest.raises(InvalidMaterialError, match="looks like radians"):
        MohrCoulomb(1e4, .3, cohesion=10., friction_angle=.52)


def slope_runs(nsteps, max_cutbacks):
    """``run(factor)`` of the 45-degree clay slope of ``examples/slope.py``
    as a scene, on the coarse grid h = H/8 (10 m high, toe at x = 10 m,
    c_u = 50 kPa, 20 kN/m^3, 2 x 2 points per cell, standard MPM, mean
    dilatation), gravity in ``nsteps`` load steps with ``max_cutbacks``
    cut-backs."""
    from dataclasses import replace

    from skfem_mpm import NewtonOptions, Stabilisation
    from skfem_mpm.scenes.scene import Body, Grid, Scene, Support, run_scene
    clay = VonMises(E=2e4, nu=.3, yield_stress=50. * np.sqrt(3.))
    slope = Scene(
        grid=Grid([(0., 35., 28), (0., 12.5, 10)]),
        bodies=[Body("clay", lambda x: x[1] < np.clip(x[0] - 10., 0., 10.),
                     clay)],
        supports=[Support(boundary="bottom"),
                  Support(boundary="right", components=["x"])],
        gravity=[0., -20.], nsteps=nsteps,
        newton=NewtonOptions(max_cutbacks=max_cutbacks),
        stabilisation=Stabilisation(antilocking=True))

    def run(factor):
        return run_scene(replace(slope, bodies=[replace(
            slope.bodies[0], material=reduce_strength(clay, factor))]))
    return run


@pytest.mark.slow                       # about 10 s: 16 trials, 8 failing
def test_the_factor_of_safety_does_not_depend_on_the_load_stepping():
    """Issue 30: judged by convergence alone, the slope's factor of safety
    moved with the load stepping: 1.617 with 4 load steps and no
    cut-backs, 1.664 with 16 steps and 4 cut-backs (2.9%, at a tolerance
    of 1%): beyond collapse the points slid away and some runs found
    equilibrium again 1-2 m away.  With the collapse criterion on the
    displacement trend (a converged trial that moves more than 5 times the
    run at F = 1 has collapsed) the two agree within the tolerance, and
    every trial judged standing moved less than the criterion allows."""
    tolerance = .01
    found = [strength_reduction(slope_runs(nsteps, cutbacks), 1., 2.,
                                tolerance)
             for nsteps, cutbacks in ((4, 0), (16, 4))]
    a, b = (s.factor for s in found)
    assert abs(a - b) <= tolerance * min(a, b), (a, b)
    for s in found:
        assert s.failed - s.converged <= tolerance * s.converged
        assert s.reference > 0
        for (factor, stood), moved in zip(s.trials, s.displacements):
            assert stood == (factor <= s.converged)
            if stood:
                assert moved <= 5 * s.reference
        assert s.result.history[-1].n_yielded > 0


@pytest.mark.parametrize("quiet", [True, False])
def test_the_later_trials_warnings_are_counted_not_said(quiet, caplog):
    """As ``skfem-mpm safety`` prints them: the first trial's warnings are
    logged, the later trials' counted (trial 94: about 100 lines of
    Newton's retries for 8 trials of a slope), per trial and in one
    warning at the end; ``quiet=False`` logs them all."""
    import logging
    solver = logging.getLogger("skfem_mpm.solve.core")
    limit, said = 1.37, {}

    def run(factor):
        # a run says more the nearer it is to collapse, each text new
        said[factor] = 1 + int(10 * factor)
        for k in range(said[factor]):
            solver.warning("step %d: retrying at F = %.6f", k, factor)
        if factor > limit:
            raise NewtonDivergenceError("no equilibrium")
        return stand_in(factor)
    with caplog.at_level(logging.WARNING):
        s = strength_reduction(run, tolerance=1e-2, quiet=quiet)
    retries = [r for r in caplog.records if r.name == solver.name]
    factors = [f for f, _ in s.trials]
    later = sum(said[f] for f in factors[1:])
    assert len(factors) > 2 and later > 0
    if quiet:
        assert len(retries) == said[factors[0]]
        assert s.quieted == [0] + [said[f] for f in factors[1:]]
        ending = [r.getMessage() for r in caplog.records
                  if r.name.endswith("strength_reduction")]
        assert len(ending) == 1 and ": {} warning(s) of the trials after " \
            "the first were counted, not logged".format(later) in ending[0]
        assert "F = {:.4f}: {}".format(factors[1], said[factors[1]]) \
            in ending[0]
    else:
        assert len(retries) == said[factors[0]] + later
        assert s.quieted == [0] * len(factors)


def holed(limit, hole, far=None):
    """``(run, retry)``: a stand-in collapsing beyond ``limit`` whose
    ``run`` also fails, for a load step too large, inside ``hole`` (an
    interval below ``limit``) where ``retry`` (more load steps) stands;
    with ``far = (a, b)`` both converge again, slumped 30 times as far,
    between ``a`` and ``b`` (a material point run finding equilibrium
    metres away)."""
    def retry(factor):
        if far is not None and far[0] < factor <= far[1]:
            return stand_in(factor, 30.)
        if factor > limit:
            raise NewtonDivergenceError("no equilibrium at {}".format(
                factor))
        return stand_in(factor)

    def run(factor):
        if hole[0] < factor < hole[1]:
            raise NewtonDivergenceError("step 5: the residual grew at "
                                        "{}".format(factor))
        return retry(factor)
    return run, retry


def test_a_numerical_failure_is_told_by_its_retry():
    """Trial 98: a run fails at one factor and converges at a larger
    one.  A failure inside a hole below the collapse (1.37) stops the
    plain bisection short, unseen among its trials; ``retry`` re-runs
    the failed top of the bracket and the bisection goes on to the
    collapse, each retry a trial, the failures' messages kept."""
    limit, hole = 1.37, (1.30, 1.33)
    run, retry = holed(limit, hole)
    plain = strength_reduction(run, growth=None)
    assert hole[0] <= plain.failed < hole[1]
    assert plain.warnings == [] and plain.span == (plain.converged,
                                                   plain.failed)
    s = strength_reduction(run, growth=None, retry=retry)
    assert s.converged <= limit < s.failed
    assert s.failed - s.converged <= .01 * s.converged
    factors = [f for f, _ in s.trials]
    assert len(s.retried) == len(s.errors) == len(factors)
    again = [f for f, r in zip(factors, s.retried) if r]
    assert 1 <= len(again) <= 3
    # each retry at a factor whose plain run failed just before it
    for k, r in enumerate(s.retried):
        if r:
            assert factors[k] in factors[:k] and \
                s.errors[factors.index(factors[k])] is not None
    holes = [f for f, e in zip(factors, s.errors)
             if e is not None and hole[0] < f < hole[1]]
    assert holes and all("step 5: the residual grew at {}".format(f)
                         in s.errors[factors.index(f)] for f in holes)
    assert all(e.startswith("NewtonDivergenceError: ")
               for e in s.errors if e is not None)
    assert s.span == (s.converged, s.failed)
    said = " ".join(s.warnings)
    for f in holes:
        assert "F = {:.4f} failed".format(f) in said
    assert "was numerical" in said


def test_a_failure_below_a_collapse_that_converged_is_no_warning(caplog):
    """A run that converges but moves past ``growth`` is a collapse: the
    failures below it agree with it, however far away it found
    equilibrium again (as a material point run past collapse often
    does).  The verdict is monotone: the span is the bracket, nothing
    warned (it said "the failures may be numerical ..., the factor of
    safety up to 2", an ordinary search made "uncertain").  Trial 98's
    path (a failure inside a hole below the collapse, slumped runs far
    above) looks the same to the trials: the retry tells them apart."""
    import logging
    limit, hole, far = 1.37, (1.30, 1.33), (1.95, 2.05)

    def slumping(factor):
        # fails from 1.45, converges again at 2, ten times as far
        if 1.45 <= factor < 1.9:
            raise NewtonDivergenceError("no equilibrium at {}".format(
                factor))
        return stand_in(factor, 1. if factor < 1.9 else 10.)
    run, retry = holed(limit, hole, far)
    for runs, collapse in [(slumping, 1.45), (run, hole[0])]:
        with caplog.at_level(logging.WARNING):
            caplog.clear()
            s = strength_reduction(runs)
        assert s.converged < s.failed and collapse <= s.failed
        assert s.failed - s.converged <= .01 * s.converged
        collapsed = [f for (f, stood), e in zip(s.trials, s.errors)
                     if not stood and e is None]
        assert collapsed and min(collapsed) > s.failed
        assert s.span == (s.converged, s.failed) and s.warnings == []
        assert not [r for r in caplog.records
                    if r.levelno == logging.WARNING]
    s = strength_reduction(run, retry=retry)
    assert s.converged <= limit < s.failed
    assert s.span == (s.converged, s.failed)


def test_a_retry_that_stands_at_the_first_high_climbs_again():
    """Every midpoint of the first bracket stood and the retry of its
    top (the first ``high``, where nothing above had run) stands too:
    the bracket doubles again, as at the start, and the bisection finds
    the collapse above (it raised ValueError: min() arg is an empty
    sequence, after every trial had run)."""
    limit, hole, high = 2.5, (1.99, 2.01), 2.
    run, retry = holed(limit, hole)
    s = strength_reduction(run, 1., high, retry=retry)
    assert s.converged <= limit < s.failed
    assert s.failed - s.converged <= .01 * s.converged
    factors = [f for f, _ in s.trials]
    assert 2 * high in factors
    # the first high stood when retried, the final top (a collapse)
    # failed when retried too
    assert [t for t, r in zip(s.trials, s.retried) if r] == [
        (high, True), (s.failed, False)]
    assert s.span == (s.converged, s.failed)


def test_a_trial_that_stands_above_one_that_did_not_is_said():
    """A verdict that is not monotone (a retry stood above a plain
    failure kept) gives the span from the last stand below the first
    failure to the first firm failure above the last stand."""
    from skfem_mpm.solve.strength_reduction import flip_span
    trials = [(1., True), (2., False), (1.5, True), (1.75, False),
              (1.625, False), (1.7, True), (1.8, False)]
    errors = [None, "E: a", None, "E: b", "E: c", None, "E: d"]
    span, said = flip_span(trials, errors, [False] * len(trials))
    assert span == (1.5, 1.75)
    assert "not monotone" in said[-1] and "from 1.5 to 1.75" in said[-1]
    assert "F = 1.6250 failed (E: c) but the one at F = 1.7000" in said[0]


def test_convergence_alone_says_a_trial_that_stood_far_away():
    """Trial 98 with ``--growth none``: F = 1.8906 stood, 28 times as far
    as the run at F = 1, and set 1.896 where the displacement criterion
    gives 1.820: the result says so, naming the smallest such factor."""
    knee, limit = 1.3, 1.37

    def run(factor):
        if factor > limit:
            raise NewtonDivergenceError("no equilibrium")
        return stand_in(factor, 10. if factor > knee else 1.)
    s = strength_reduction(run, growth=None)
    assert s.converged <= limit < s.failed
    far = [f for (f, stood), d in zip(s.trials, s.displacements)
           if stood and d > 5 * s.displacements[0]]
    assert far and knee < min(far)
    assert s.warnings == [
        "judged by convergence alone, the trial at F = {:.4f} stood though "
        "it moved 10 times the run at F = 1; with growth = 5 the factor of "
        "safety is below {:.4g}".format(max(far), min(far))]
    assert strength_reduction(run).warnings == []
