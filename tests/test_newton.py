"""Globalised Newton (skfem_mpm/solve/newton.py): the line search takes the
steps plain Newton cannot, and changes nothing where plain Newton
converges."""
import re
from pathlib import Path

import numpy as np
import pytest

from skfem_mpm import InvalidInputError, InversionError, MPMError, \
    NewtonOptions, Options, Stabilisation
from skfem_mpm.errors import SceneError
from skfem_mpm.scenes.scene import run_scene
from skfem_mpm.scenes.scene_file import load_scene, parse_scene
from skfem_mpm.solve.newton import MERIT_LIMIT, Backtracking, FullStep, \
    make_line_search
from skfem_mpm.studies.elastica import untuned_cantilever

EXAMPLES = Path(__file__).parent.parent / "examples"


def test_guard_follows_plain_newton_where_it_converges():
    """The shipped cantilever in 5 steps: its first full Newton step raises
    the residual 470-fold (measured), plain Newton converges anyway; the
    default takes exactly plain Newton's path (bit for bit), evaluating no
    shortened step."""
    scene = load_scene(EXAMPLES / "cantilever.toml")
    scene.nsteps = 5
    default = run_scene(scene)
    scene.newton = NewtonOptions(line_search="none")
    plain = run_scene(scene)
    assert default.counters["line_search_trials"] == 0
    assert [r.newton_residuals for r in default.history] == \
        [r.newton_residuals for r in plain.history]
    assert max(default.history[0].newton_residuals) > 100.
    assert np.array_equal(default.points.x, plain.points.x)


@pytest.mark.slow
def test_armijo_retry_carries_what_plain_newton_cannot():
    """The untuned cantilever on the coarse grid (h = 0.5, 2 points per
    cell, standard MPM) without the ghost penalty: plain Newton fails at 45%
    of the load even after every cut-back; the Armijo retry completes it
    within the discretisation error of the ghost-stabilised run (measured
    5.7% from the elastica)."""
    with pytest.raises(MPMError) as err:
        untuned_cantilever(.5, 2, "mpm", options=Options(
            NewtonOptions(line_search="none"), Stabilisation(ghost=0.)))
    assert err.value.load_factor < .5
    with pytest.raises(MPMError):     # the guard alone: no better
        untuned_cantilever(.5, 2, "mpm", options=Options(
            NewtonOptions(line_search=Backtracking(watchdog=None)),
            Stabilisation(ghost=0.)))
    res, error = untuned_cantilever(.5, 2, "mpm", options=Options(
        stabilisation=Stabilisation(ghost=0.)))
    assert res.counters["line_search_trials"] > 0
    assert res.history[-1].load_factor == 1.
    assert max(r.residual for r in res.history) <= 1e-9
    assert error < .1


@pytest.mark.parametrize("bad", [
    dict(sufficient_decrease=.5), dict(sufficient_decrease=0.),
    dict(max_trials=0), dict(max_trials=2.), dict(shrink=(.6, .5)),
    dict(shrink=(0., .5)), dict(watchdog=-1), dict(watchdog=True),
    dict(min_step=0.), dict(min_step=1.)])
def test_bad_line_search_settings_are_refused(bad):
    with pytest.raises(InvalidInputError):
        Backtracking(**bad)


def test_line_search_choices():
    first, retry = make_line_search("none")
    assert isinstance(first, FullStep) and retry is None
    assert isinstance(make_line_search(FullStep())[0], FullStep)
    first, retry = make_line_search("backtracking")
    assert first.watchdog is None and retry.watchdog == 0
    custom = Backtracking(watchdog=0, min_step=1e-2)   # from the first attempt
    assert make_line_search(custom) == (custom, None)
    first, retry = make_line_search("armijo")        # Armijo from the first
    assert first.watchdog == 2 and retry is None
    for bad in ("wolfe", None, 1, Backtracking):
        with pytest.raises(InvalidInputError, match="line_search"):
            make_line_search(bad)


def test_searches_count_their_extra_evaluations():
    """``extra`` is the residual evaluations beyond one per iteration.  On
    ``r(u) = -log(u)`` (the tangent ``1/u``): Newton's step from u = 3
    "inverts" (u < 0) and is shortened; a step to where the residual
    overflows is shortened too; a full step the search has already
    rejected is not evaluated again."""
    class State:
        def __init__(self, u):
            if u[0] <= 0:
                raise InversionError("a point inverts")
            self.r = -np.log(u)
            self.merit = float(np.abs(self.r).max()) if u[0] < 1e3 \
                else np.inf
    calls = []

    def evaluate(u):
        calls.append(u[0])
        return State(u)
    guard = Backtracking(min_step=1e-5).guard().start()
    for u0, d in ((3., -3 * np.log(3.)), (.5, 2e3)):
        calls.clear()
        u = np.array([u0])
        new, state, extra = guard(evaluate, u, np.array([d]), State(u),
                                  lambda s: False)
        assert np.isfinite(state.merit) and state.merit < State(u).merit
        assert extra == len(calls) - 1 > 0
    calls.clear()
    plain = Backtracking(watchdog=0).start()
    u = np.array([3.])
    new, state, extra = plain(evaluate, u, np.array([3.]), State(u),
                              lambda s: False)   # not a descent direction
    assert calls.count(6.) == 2 and extra == len(calls) - 1   # s = 1, full


@pytest.mark.parametrize("watchdog", [None, 0, 2])
def test_a_trial_beyond_the_merit_limit_is_rejected_as_a_nan_one(watchdog):
    """A diverging trial's residual comes out NaN or huge depending on
    where its arithmetic overflows first (a review's 3D run: 1e178 on the
    numpy path where the compiled pass gave NaN; the numpy path's search
    then raised OverflowError squaring it, and the two paths took
    different rungs of the retry ladder).  Every search treats the two
    alike: the same trials, the same accepted state, below the start's
    residual (on ``r(u) = -log(u)`` from u = 0.5 along d = 2000, whose
    full step lands where the residual is 1e178 or NaN)."""
    outcomes = []
    for beyond in (1e178, np.nan):
        class State:
            def __init__(self, u):
                self.r = -np.log(u) if u[0] < 1e3 else np.array([beyond])
                self.merit = float(np.abs(self.r).max())
        calls = []

        def evaluate(u):
            calls.append(u[0])
            return State(u)
        search = Backtracking(min_step=1e-5, watchdog=watchdog)
        if watchdog is None:
            search = search.guard()
        u = np.array([.5])
        new, state, extra = search.start()(evaluate, u, np.array([2e3]),
                                           State(u), lambda s: False)
        outcomes.append((calls, new[0], state.merit))
    assert outcomes[0] == outcomes[1]
    assert outcomes[0][2] < -np.log(.5) and len(outcomes[0][0]) > 1
    assert 1e178 > MERIT_LIMIT


def test_scene_files_choose_the_line_search():
    from skfem_mpm.scenes.scene_file import tomllib
    data = tomllib.loads((EXAMPLES / "column.toml").read_text())
    assert parse_scene(data).newton.line_search == "backtracking"
    data["solver"]["line_search"] = "none"
    assert parse_scene(data).newton.line_search == "none"
    data["solver"]["line_search"] = "armijo"
    assert parse_scene(data).newton.line_search == "armijo"
    data["solver"]["line_search"] = "wolfe"
    with pytest.raises(SceneError, match="line_search"):
        parse_scene(data)


def modified_block(material, method, **kwargs):
    """A block under its weight on a 24 x 29 grid, finite deformation, 3
    load steps."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm import seed_points, simulate
    mesh = MeshQuad.init_tensor(np.linspace(-.1, 1.1, 25),
                                np.linspace(0., 1.2, 29))
    points = seed_points(mesh, 2, region=lambda x: (x[1] < 1.) & (
        x[0] > 0.) & (x[0] < 1.))
    return simulate(mesh, ElementQuad1(), points, material,
                    lambda b: b.get_dofs(lambda x: x[1] == 0),
                    body_force=[0., -1e4], nsteps=3, method=method,
                    kinematics="finite", keep_snapshots=False, **kwargs)


@pytest.mark.parametrize("method", ["mpm", "cpgimp"])
@pytest.mark.parametrize("plastic", [False, True])
def test_modified_newton_reaches_the_state_of_full_newton(method, plastic):
    """newton="modified" keeps a step's first factorisation over its
    iterations: converged to the same tolerance, the points land where
    full Newton puts them (measured 1e-14 m of 4e-3 m), with fewer
    factorisations (elastic: 3 for 15 iterations against 9 for 9) and more
    iterations (linear convergence)."""
    from skfem_mpm import LinearElastic, VonMises
    material = VonMises(1e6, .3, 8e3) if plastic else LinearElastic(1e6, .3)
    full = modified_block(material, method)
    modified = modified_block(material, method, newton="modified")
    scale = np.abs(full.points.displacement).max()
    assert np.abs(modified.points.x - full.points.x).max() < 1e-10 * scale
    assert all(r.residual <= 1e-9 for r in modified.history)
    assert full.counters["factorisations"] == \
        full.counters["newton_iterations"]
    assert modified.counters["newton_iterations"] > \
        full.counters["newton_iterations"]
    assert modified.counters["factorisations"] < \
        full.counters["factorisations"]
    if not plastic:         # one factorisation a step
        assert modified.counters["factorisations"] == 3
    for record in modified.history:   # each iteration cuts the residual
        r = np.array(record.newton_residuals)
        assert (r[1:] < r[:-1]).all()


def test_modified_newton_refactorises_where_the_residual_falls_slowly(
        monkeypatch):
    """A refactorisation whenever an iteration with the kept tangent cut
    the residual by less than MODIFIED_RATE: at a rate of 0 every iteration
    refactorises, and the run is full Newton's, bit for bit."""
    from skfem_mpm import LinearElastic
    from skfem_mpm.solve import newton
    full = modified_block(LinearElastic(1e6, .3), "mpm")
    monkeypatch.setattr(newton, "MODIFIED_RATE", 0.)
    always = modified_block(LinearElastic(1e6, .3), "mpm", newton="modified")
    assert np.array_equal(always.points.x, full.points.x)
    assert always.counters["factorisations"] == \
        full.counters["factorisations"]


def test_a_failed_modified_step_is_retried_with_full_newton(caplog):
    """Four iterations allowed: modified Newton's linear rate needs more,
    full Newton three; each step is retried with full Newton (one log line)
    and the run completes at full Newton's state."""
    import logging
    from skfem_mpm import LinearElastic
    full = modified_block(LinearElastic(1e6, .3), "mpm", max_iter=4)
    with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
        retried = modified_block(LinearElastic(1e6, .3), "mpm", max_iter=4,
                                 newton="modified")
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 3
    assert all(line.endswith("retrying with full Newton") for line in lines)
    assert np.array_equal(retried.points.x, full.points.x)


def test_newton_choice_is_checked_and_read_from_scene_files():
    from skfem_mpm import LinearElastic
    from skfem_mpm.scenes.scene_file import tomllib
    with pytest.raises(InvalidInputError, match="newton must be one of"):
        modified_block(LinearElastic(1e6, .3), "mpm", newton="quasi")
    data = tomllib.loads((EXAMPLES / "column.toml").read_text())
    assert parse_scene(data).newton.newton == "full"
    data["solver"]["newton"] = "modified"
    scene = parse_scene(data)
    assert scene.newton.newton == "modified"
    counters = run_scene(scene).counters
    assert counters["factorisations"] < counters["newton_iterations"]
    data["solver"]["newton"] = "broyden"
    with pytest.raises(SceneError, match="newton"):
        parse_scene(data)


def lone_point_column(newton):
    """A block on a 4 x 8 grid and a lone point in an empty cell above it
    (a zero-energy mode), finite deformation under vertical gravity."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm import MaterialPoints, VonMises, seed_points, simulate
    from skfem_mpm.quadrature.points import concatenate_points
    mesh = MeshQuad.init_tensor(np.linspace(0, 4, 5), np.linspace(0, 8, 9))
    points = concatenate_points([
        seed_points(mesh, 2, region=lambda x: x[1] < 4),
        MaterialPoints(x=[[2.3], [4.6]], volume=[.25], domain=[[.25], [.25]])])
    return simulate(mesh, ElementQuad1(), points, VonMises(1e5, .3, 1e9),
                    lambda b: b.get_dofs(lambda x: x[1] == 0),
                    body_force=[0., -10.], kinematics="finite", newton=newton,
                    solver="scipy")


def test_a_kept_factorisation_refused_for_a_right_hand_side_is_redone():
    """SuperLU's pivot check depends on the right-hand side: a later
    iteration's residual can set it off on the kept factorisation of a
    tangent with a zero-energy mode.  The iteration then refactorises the
    current tangent (stabilised where it must be), as full Newton does,
    instead of ending the run (it raised SingularSystemError); the block
    lands where full Newton puts it (the lone point's motion along its
    mode is arbitrary)."""
    full, modified = lone_point_column("full"), lone_point_column("modified")
    assert modified.history[-1].residual <= 1e-9
    scale = np.abs(full.points.displacement).max()
    body = slice(0, full.points.n - 1)
    assert np.abs(modified.points.x[:, body]
                  - full.points.x[:, body]).max() < 1e-10 * scale


def test_modified_newton_counts_what_a_solver_function_factorises():
    """A scikit-fem solver function of one's own has no factorise(A): it
    is called (and factorises) in every iteration, and the counter says
    so; the tangent is kept all the same."""
    from scipy.sparse.linalg import spsolve
    from skfem_mpm import LinearElastic
    calls = []

    def mine(A, b, **kwargs):
        calls.append(A.shape[0])
        return spsolve(A.tocsc(), b)
    result = modified_block(LinearElastic(1e6, .3), "mpm", newton="modified",
                            solver=mine)
    assert result.counters["factorisations"] == len(calls)
    assert result.counters["linear_solves"] == len(calls)
    reference = modified_block(LinearElastic(1e6, .3), "mpm",
                               newton="modified")
    assert reference.counters["factorisations"] < len(calls)


def test_modified_newton_is_refused_with_an_adaptive_time_step():
    """The adaptive time step counts Newton iterations, which modified
    Newton multiplies: refused before any work (API and scene)."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm import Dynamics, LinearElastic, seed_points, simulate
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    with pytest.raises(InvalidInputError, match="adaptive time step"):
        simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
                 LinearElastic(1e6, .3),
                 lambda b: b.get_dofs(lambda x: x[1] == 0),
                 body_force=[0., -1e4], kinematics="finite",
                 newton="modified", dynamics=Dynamics(
                     time_step=.01, duration=.1, density=1e3,
                     target_iterations=4))
    from skfem_mpm.scenes.scene import TimeIntegration
    from skfem_mpm.scenes.scene_file import tomllib
    data = tomllib.loads((EXAMPLES / "column.toml").read_text())
    scene = parse_scene(data)
    from dataclasses import replace
    with pytest.raises(InvalidInputError, match="adaptive time step"):
        replace(scene, newton=NewtonOptions(newton="modified"), nsteps=None,
                bodies=[replace(b, density=1e3) for b in scene.bodies],
                dynamics=TimeIntegration(time_step=.01, duration=.1,
                                         target_iterations=4)).check()


def test_every_factorisation_is_counted_in_dynamics():
    """The first step's mass solve (the initial accelerations) is a
    factorisation too: with full Newton, one per linear solve."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm import Dynamics, LinearElastic, seed_points, simulate
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2, 9))
    result = simulate(mesh, ElementQuad1(), seed_points(
        mesh, 2, region=lambda x: x[1] < 1), LinearElastic(1e6, .3),
        lambda b: b.get_dofs(lambda x: x[1] == 0), body_force=[0., -1e4],
        kinematics="finite", dynamics=Dynamics(time_step=.01, duration=.03,
                                               density=1e3))
    counters = result.counters
    assert counters["factorisations"] == counters["linear_solves"] == \
        counters["newton_iterations"] + 1


def footing_of_nodes(line_search):
    """A smooth strip footing of grid nodes (half-width 0.5, B/h = 4) pushed
    0.1 B into weightless perfectly plastic von Mises soil with finite
    elements, mean dilatation and 2 x 2 points per cell, in 6 steps: the
    run and the pressure over c_u."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm import (NewtonOptions, Options, Prescribed, Stabilisation,
                           VonMises, seed_points, simulate)
    mesh = MeshQuad.init_tensor(np.linspace(0, 2.5, 11), np.linspace(0, 1.5, 7))
    under = np.flatnonzero((mesh.p[1] == 1.5) & (mesh.p[0] <= .5))

    def supports(b):
        return np.concatenate([b.get_dofs(lambda x: x[1] == 0).all(),
                               b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 2.5)
                                          ).all("u^1")])

    def pushed(b, f_old, f_new):
        return b.nodal_dofs[1, under], np.full(under.size,
                                               -.1 * (f_new - f_old))
    res = simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
                   VonMises(1e5, .3, 100.), supports, nsteps=6, method="fem",
                   loads=[Prescribed(pushed)], options=Options(
                       stabilisation=Stabilisation(antilocking=True),
                       newton=NewtonOptions(line_search=line_search)))
    force = res.history[-1].reactions[2 * under + 1].sum()
    return res, abs(force) / .5 / (100. / np.sqrt(3.))


def test_steps_after_one_the_line_search_carried_start_with_it():
    """Full Newton steps fail on perfectly plastic flow under a footing at
    every load step (25 iterations each, before: 6 failed attempts); once
    the retry's search (Armijo's, with the energy's slope) has carried
    one, the later steps start with it: one failed attempt in the run,
    the same iterations otherwise as that search from the first step on,
    and the same pressure to 1e-9."""
    res, pressure = footing_of_nodes("backtracking")
    plain, plain_pressure = footing_of_nodes(
        Backtracking(watchdog=0, slope=True))
    assert res.counters["line_search_from_step"] == 1
    assert plain.counters["line_search_from_step"] == 0
    # the failed full steps stop where Newton went astray: 13 iterations
    # (its residuals flat above twice their smallest), not 25
    assert res.counters["newton_iterations"] == \
        plain.counters["newton_iterations"] + 13
    assert len(res.history) == 6
    assert abs(pressure - plain_pressure) < 1e-9 * pressure
    assert 5 < pressure < 7                          # near 2 + pi


def test_the_dead_loads_norm_follows_the_array_a_step_holds():
    """The norm of a step's dead loads is found once for each array the
    problem holds (a time integrator replaces it in ``begin_step``): a
    replaced ``f_dead`` is measured anew (a stale norm would keep 5)."""
    from types import SimpleNamespace
    from skfem_mpm.solve.problem import StepProblem
    problem = SimpleNamespace(f_dead=np.array([3., 4.]), _kept_norm=None)
    assert StepProblem._dead_norm(problem) == 5.
    assert StepProblem._dead_norm(problem) == 5.
    problem.f_dead = np.array([6., 8.])
    assert StepProblem._dead_norm(problem) == 10.


class StalledStep:
    """A step's problem for :func:`newton` whose residuals are
    ``residuals`` in the order they are asked for, and whose every
    correction is ``correction`` (of an increment starting at 1)."""
    keeps_factorisations, step, linear = True, 3, False
    free, driven = np.arange(1), np.zeros(0, dtype=int)

    def __init__(self, residuals, correction):
        self.residuals, self.correction = iter(residuals), correction
        self.counters = dict.fromkeys(
            ("linear_solves", "newton_iterations", "factorisations",
             "line_search_trials"), 0)
        self.t = {"solve": 0.}

    def residual(self, u, response=None):
        from types import SimpleNamespace
        value = next(self.residuals)
        return SimpleNamespace(r=np.array([value]), merit=value,
                               residual=value)

    def converged(self, trial):
        return trial.residual <= 1e-9

    def rhs(self, trial):
        return trial.r

    def tangent(self, trial):
        return None

    def solve(self, K, r, stabilise):
        return np.array([self.correction]), None


@pytest.mark.parametrize("residuals, correction, ends", [
    ([1., 3e-9, 3.6e-9, 3.3e-9], 1e-15, 2),    # at round-off: ends
    ([1., 1e-4, 1.1e-4] + [1e-4] * 30, 1e-15, None),  # stalled above
    ([1., 3e-9] + [3.6e-9] * 30, 1e-6, None),   # a correction that counts
    ([1., 1e-3, 1e-6, 2e-9, 1e-12], 1e-15, 4)])  # still converging
def test_a_step_ends_at_the_round_off_of_its_residual(residuals, correction,
                                                      ends):
    """A step whose last iteration did not halve the residual, now within
    ``ROUNDOFF_LIMIT``, and whose Newton correction is below
    ``CORRECTION_ROUNDOFF`` of its increment has met the round-off of its
    arithmetic and ends there (a user's Cook's membrane at nu = 0.4999
    stayed at 3e-9 over 24 solves and failed); a stall above the limit, a
    correction that still counts, or a residual still falling quadratically
    go on (a reviewer's translated plastic box, its corrections 1e-12 of a
    large increment, had ended at 4.9e-8 on its way down)."""
    from skfem_mpm.errors import NewtonDivergenceError
    from skfem_mpm.solve.newton import newton
    problem = StalledStep(residuals, correction)
    if ends is None:
        with pytest.raises(NewtonDivergenceError):
            newton(problem, np.ones(1), FullStep().start(), max_iter=25)
        return
    found = newton(problem, np.ones(1), FullStep().start(), max_iter=25)
    assert found.residuals == residuals[:ends + 1]
    assert found.trial.residual == residuals[ends]


def test_cooks_membrane_at_nu_04999_ends_at_round_off(caplog):
    """A user's Cook's membrane (plane strain, E = 250, nu = 0.4999, 64 x
    64 finite elements with mean dilatation, one linear step): its
    residual stays at about 3e-9 however often it is solved again, above
    the default tolerance of 1e-9, and the run failed after 25 solves.
    Now it ends after its third solve (whose correction was 5e-16 of the
    increment) with a warning, its tip displacement
    that of the run whose tolerance the first solve met (1e-8) to 1e-8."""
    import logging
    from skfem import ElementQuad1
    from skfem_mpm import LinearElastic, seed_gauss_points, simulate
    from meshes import cooks_membrane
    n = 64
    mesh = cooks_membrane(n)
    points = seed_gauss_points(mesh, 2)
    edge = np.argsort(points.x[0])[::-1][:2 * n]
    points.force[1, edge] = 100. / edge.size
    tip = np.argmin((points.x[0] - 48) ** 2 + (points.x[1] - 60) ** 2)

    def cook(tol):
        return simulate(
            mesh, ElementQuad1(), points, LinearElastic(250., .4999),
            lambda basis: basis.get_dofs(lambda x: np.isclose(x[0], 0.)),
            nsteps=1, method="fem", options=Options(
                stabilisation=Stabilisation(antilocking=True),
                newton=NewtonOptions(tol=tol)))
    with caplog.at_level(logging.WARNING, logger="skfem_mpm.solve"):
        default = cook(1e-9)
    said = [r.getMessage() for r in caplog.records
            if "round-off" in r.getMessage()]
    assert len(said) == 1 and "stays above the tolerance 1e-09" in said[0]
    assert default.counters["linear_solves"] == 3
    loose = cook(1e-8)
    assert loose.counters["linear_solves"] == 1
    default, loose = default.history[-1], loose.history[-1]
    assert 1e-9 < default.residual < 1e-8
    assert default.displacement[1, tip] == pytest.approx(
        loose.displacement[1, tip], rel=1e-8)
    assert default.displacement[1, tip] == pytest.approx(7.59, rel=1e-3)


@pytest.mark.slow
def test_newton_ends_where_its_correction_is_round_off(caplog):
    """A user's Cook's membrane in finite deformation (second-order finite
    elements, nu = 0.4999, 16 x 16, 5 steps): Newton converged
    quadratically to 1.8e-9 at its first step and then asked for
    corrections of 2e-15 of the increment, the residual staying between
    1.5e-9 and 1.9e-9 above the default tolerance, and every cut-back
    failed.  A correction below ``CORRECTION_ROUNDOFF`` of the increment
    at a residual within ``ROUNDOFF_LIMIT`` ends the step (warned once):
    the run ends where a tolerance of 1e-7 puts it, to 1e-8."""
    import logging
    from skfem import ElementQuad2, MeshQuad2
    from skfem_mpm import LinearElastic, seed_gauss_points, simulate
    from meshes import cooks_membrane
    mesh = MeshQuad2.from_mesh(cooks_membrane(16))
    points = seed_gauss_points(mesh, 4)
    right = np.isclose(points.x[0], points.x[0].max())
    points.force[1, right] = 100. / right.sum()
    tip = np.argmin((points.x[0] - 48) ** 2 + (points.x[1] - 60) ** 2)

    def cook(tol):
        return simulate(
            mesh, ElementQuad2(), points, LinearElastic(250., .4999),
            lambda basis: basis.get_dofs(lambda x: np.isclose(x[0], 0.)),
            nsteps=5, method="fem", kinematics="finite",
            options=Options(newton=NewtonOptions(tol=tol)))
    with caplog.at_level(logging.WARNING, logger="skfem_mpm.solve"):
        default = cook(1e-9)
    said = [r.getMessage() for r in caplog.records
            if "round-off" in r.getMessage()]
    assert len(said) == 1 and "Newton's correction fell below" in said[0]
    assert len(default.history) == 5
    assert max(r.residual for r in default.history) < 1e-8
    loose = cook(1e-7).history[-1].displacement[1, tip]
    assert default.history[-1].displacement[1, tip] == pytest.approx(
        loose, rel=1e-8)
    assert loose == pytest.approx(6.38, rel=1e-3)


def test_slope_search_steps_to_the_energys_minimum():
    """``r(u) = tanh(3 - u)`` from ``u = 0``: Newton's full step goes to
    u = 101 (``|r|`` = 1, past the energy's minimum: ``d r < 0``); the
    search on the slope ``d . r`` takes the step length where it has
    fallen to ``SLOPE_RATIO`` of its start's, 4 iterations (10 residuals)
    where Armijo's on ``|r|^2`` takes 6 (15)."""
    class State:
        def __init__(self, u):
            self.u, self.r = u, np.tanh(3 - u)
            self.merit = float(np.abs(self.r).max())

    def run(search):
        state, evaluations = State(np.zeros(1)), 0
        for it in range(40):
            if state.merit < 1e-12:
                return it, evaluations, float(state.u[0])
            d = state.r / (1 - np.tanh(3 - state.u) ** 2)
            _, state, extra = search(State, state.u, d, state,
                                     lambda s: s.merit < 1e-12)
            evaluations += 1 + extra
    assert run(Backtracking(watchdog=0, slope=True).start()) == \
        (4, 10, pytest.approx(3.))
    assert run(Backtracking(watchdog=0).start()) == (6, 15, pytest.approx(3.))
    assert "slope=True" in repr(Backtracking(slope=True))
    with pytest.raises(InvalidInputError):
        Backtracking(slope="yes")


@pytest.mark.parametrize("residuals, words, asked", [
    ([1., 1e-4, 1.1e-4] + [1e-4] * 30, "stalled at 0.0001", 8),
    ([.99, .52, .36, .35, .48, .87] + [1.] * 30, "went astray", 10),
    ([.997, .821] + [1.] * 30, "last 10 residuals all stayed within a "
     "factor 1.05 of 1: Newton made no progress", 12)])
def test_a_stalled_or_astray_newton_loop_fails_early(residuals, words,
                                                     asked):
    """Newton fails once its last five residuals stay within 5% of each
    other (a c-phi footing sat at 1.59e-6 for 20 iterations of every
    attempt) or all above twice the smallest before them, flat (a 3D footing
    at its collapse sat at 1.000 from iteration 6 to 25, minutes an
    iteration), or its last ten within 5% of each other at any level (a 3D
    footing with mean dilatation sat at 1.000 after a smallest of 0.821),
    its error saying so, not after max_iter = 25."""
    from skfem_mpm.errors import NewtonDivergenceError
    from skfem_mpm.solve.newton import newton
    problem = StalledStep(residuals, 1e-6)
    with pytest.raises(NewtonDivergenceError, match=words) as caught:
        newton(problem, np.ones(1), FullStep().start(), max_iter=25)
    assert len(residuals) - len(list(problem.residuals)) == asked
    assert caught.value.stalled == (1e-4 if "stalled" in words else None)


@pytest.mark.parametrize("material, finite, contact, words, not_words", [
    ("elastic", False, True, "the bodies are elastic, not collapsing: a "
     "tangent near-singular at grid nodes that slivers of material barely "
     "hold, cut cells the ghost penalty ties, or a contact changing within "
     "the step or not holding the load", "collapsing?"),
    ("elastic", True, False, "the bodies are elastic: a tangent "
     "near-singular at grid nodes that slivers of material barely hold, "
     "cut cells the ghost penalty ties, or buckling)", "contact"),
    ("plastic", False, True, "(a tangent that lost its stiffness, the "
     "body collapsing?)", "elastic")])
def test_a_stalled_elastic_body_is_not_asked_whether_it_collapses(
        material, finite, contact, words, not_words):
    """A user trial: an elastic pile with the B-splines in elastic soil
    (a contact between them) stalled at its first step, "Newton made no
    progress (a tangent that lost its stiffness, the body collapsing?)",
    before the ghost penalty on its cut cells carried it.  Elastic bodies
    are not asked that."""
    from types import SimpleNamespace
    from skfem_mpm import LinearElastic, VonMises
    from skfem_mpm.solve.newton import stall_words

    class Contacting:                      # a step's contact term
        contact = True
    Contacting.__module__ = "skfem_mpm.solve.body_contact"
    model = LinearElastic(1e4, .3) if material == "elastic" else \
        VonMises(1e4, .3, 10.)
    terms = [Contacting()] if contact else []
    said = stall_words(("flat", 1e-3), SimpleNamespace(
        run=SimpleNamespace(material=model, finite=finite), terms=terms))
    assert "Newton made no progress (" in said and words in said
    assert not_words not in said


def test_a_line_search_flat_far_from_equilibrium_fails_early():
    """A line search's residuals flat within 5% for ten iterations far
    above the tolerance (a 3D footing with mean dilatation sat at 1.000
    from iteration 6 to 25 of its line search, 2.5 s an iteration, where
    the ladder's next rung converged in 11) fail there; one that falls
    below them goes on."""
    from skfem_mpm.errors import NewtonDivergenceError
    from skfem_mpm.solve.newton import newton

    def search(evaluate, du, d, current, accept):    # (not full steps)
        return du + d, evaluate(du + d), 0
    problem = StalledStep([.997, .821] + [1.] * 30, 1e-6)
    with pytest.raises(NewtonDivergenceError, match="Newton made no "
                       "progress"):
        newton(problem, np.ones(1), search, max_iter=25)
    assert len(list(problem.residuals)) == 20
    problem = StalledStep([.997, .821] + [1.] * 9 + [.9, 1e-10], 1e-6)
    newton(problem, np.ones(1), search, max_iter=25)
    assert not list(problem.residuals)


def test_a_relative_loose_tolerance_is_the_solve_s_first_residual_s():
    """A round after a contact's update far from settling stops at
    ``tol`` times its first residual (``relative``), not at ``tol``: a
    round starting at 1e-4 (a soft block's contact with a stiff one) is
    solved, where at the absolute 1e-3 it stopped before any solve and the
    rounds repeated one update; it still ends where the problem's own test
    holds; and its failure names the tolerance it aimed at."""
    from skfem_mpm.errors import NewtonDivergenceError
    from skfem_mpm.solve.newton import newton
    residuals = [1e-4, 5e-8, 1e-12]
    loose = newton(StalledStep(residuals, 1e-6), np.ones(1),
                   FullStep().start(), max_iter=25, tol=1e-3)
    assert loose.residuals == residuals[:1]
    found = newton(StalledStep(residuals, 1e-6), np.ones(1),
                   FullStep().start(), max_iter=25, tol=1e-3, relative=True)
    assert found.residuals == residuals[:2]      # 5e-8 <= 1e-3 x 1e-4
    found = newton(StalledStep([1e-12], 1e-6), np.ones(1),
                   FullStep().start(), max_iter=25, tol=1e-3, relative=True)
    assert found.residuals == [1e-12]           # converged by its own test
    with pytest.raises(NewtonDivergenceError,
                       match=re.escape("tolerance 5e-07 (0.001 of the "
                                       "solve's first residual) for a "
                                       "round, before the contact's next "
                                       "update")):
        newton(StalledStep([5e-4, 1e-4, 1.1e-4] + [1e-4] * 30, 1e-6),
               np.ones(1), FullStep().start(), max_iter=25, tol=1e-3,
               relative=True)
