"""Every example is a test: import it and assert its numbers."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / (name +
                                                                     ".py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def column():
    return load("column")


def test_column_figure_2_10(column):
    """The example runs the seed's Algorithm 2.1 (the load increment),
    and gives a rate only where the errors fall and do not level off: a
    slope fitted across the plateau had been printed as "fitted rate
    0.50" (2 steps) and "0.11-0.19" (20 steps)."""
    assert column.SEED_SCHEME.newton.rhs == "increment"
    for ppc in (2, 3, 4, 5):
        # one load step: FE convergence, rate 1
        assert abs(column.rates[1, ppc] - 1.) < .1
        # 20 load steps: the plateau (mostly the model), and no rate
        err20 = column.errors[20, ppc]
        assert np.isnan(column.rates[20, ppc])
        assert np.isnan(column.rates[2, ppc])
        assert "no rate" in column.verdicts[20, ppc][1]
        last = np.log(err20[-2] / err20[-1]) / np.log(2.)
        assert abs(last) < .1
        one = column.errors[1, ppc]
        assert (err20[column.nelems >= 128] > 2 * one[column.nelems >= 128]
                ).all()
        # on coarse grids (no crossing) the step count hardly matters
        np.testing.assert_allclose(err20[:3], column.errors[1, ppc][:3],
                                   rtol=.1)


def test_column_figure_2_9_and_dimensions(column):
    # 10 elements: 20 steps give about the one-step profile; 100 do not
    from skfem_mpm.studies.column import (analytical_stress, column_error,
                                          vertical_stress)
    coarse = [column_error(column.profiles[10, n].points) for n in (1, 20)]
    fine = [column_error(column.profiles[100, n].points) for n in (1, 20)]
    assert coarse[1] < 1.1 * coarse[0]
    assert fine[1] > 2 * fine[0]
    # the spurious oscillations of the seed's 100 elements, 20 steps
    worst = [np.abs(vertical_stress(p) - analytical_stress(p.x0[0])).max()
             for p in (column.profiles[100, n].points for n in (1, 20))]
    assert worst[1] > 10 * worst[0]
    assert column.dim_difference < 1e-9


def test_column_plateau_is_the_small_strain_model():
    """The 20-step plateau of ``examples/column.py`` is mostly the model,
    not grid crossing (a lecturer's trial): small strain with moving
    points and fixed volumes converges to a geometrically nonlinear
    column, which uGIMP (no grid-crossing oscillation) reaches within
    10% with either scheme; standard MPM's excess over it grows with the
    number of steps (the default scheme)."""
    import logging
    from scipy.optimize import brentq
    from skfem import ElementLineP1, MeshLine
    from skfem_mpm import (LinearElastic, NewtonOptions, Options,
                           seed_points, simulate)
    from skfem_mpm.studies.column import (HEIGHT, LOAD, MATERIAL,
                                          column_error)
    E = MATERIAL.E
    Y = np.linspace(0., HEIGHT, 4001)
    q = -LOAD * (HEIGHT - Y)
    # increment scheme: d sigma = lambda dq, lambda = exp(sigma / E)
    inc = -E * np.log(1. - q / E)
    # residual scheme: sigma = E ln(lambda) = lambda q
    lam = np.array([brentq(lambda x: np.log(x) - qi * x / E, .5, 1.)
                    if qi else 1. for qi in q])
    res = lam * q

    def floor(s):
        return np.trapezoid(np.abs(s - q), Y) / (LOAD * HEIGHT ** 2)

    def run(method, rhs, nsteps):
        mesh = MeshLine(np.linspace(0., HEIGHT, 65))
        return column_error(simulate(
            mesh, ElementLineP1(), seed_points(mesh, 2),
            LinearElastic(E, 0.), kinematics="small", method=method,
            supports=lambda b: b.get_dofs(lambda x: x[0] == 0.),
            body_force=[-LOAD], nsteps=nsteps,
            options=Options(keep_snapshots=False,
                            newton=NewtonOptions(rhs=rhs))).points)

    logger = logging.getLogger("skfem_mpm.solve.core")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        ugimp = {rhs: run("ugimp", rhs, 20)
                 for rhs in ("increment", "residual")}
        mpm = {n: run("mpm", "residual", n) for n in (20, 80)}
        mpm_inc = run("mpm", "increment", 20)
    finally:
        logger.setLevel(level)
    assert ugimp["increment"] == pytest.approx(floor(inc), rel=.1)
    assert ugimp["residual"] == pytest.approx(floor(res), rel=.1)
    # the increment scheme: MPM's plateau within 10% of uGIMP's
    assert mpm_inc == pytest.approx(ugimp["increment"], rel=.1)
    # grid crossing (the default scheme): above the model, growing
    assert mpm[20] > 2 * ugimp["residual"]
    assert mpm[80] > 1.3 * mpm[20]


@pytest.mark.slow
def test_column_figures_are_written(column, tmp_path):
    column.visualize(tmp_path)
    for name in ("column_stress_profiles.png", "column_convergence.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    assert not list(tmp_path.glob(".*"))      # no temporary file left


@pytest.fixture(scope="module")
def cantilever():
    return load("cantilever")


def test_cantilever_follows_the_elastica(cantilever):
    """Tip deflections within 2.5% of the elastica for P L^2 / (E I) >= 4
    at h = 0.5, a grid two cells deep (measured 1.4% vertical, 2.1%
    horizontal, with the load on the tip column's two points nearest the
    neutral axis)."""
    assert cantilever.v_error < .025 and cantilever.u_error < .025
    # below P L^2 / (E I) = 4 the grid is stiff, as its docstring says (a
    # lecturer's trial: the accuracy had been stated for large loads only)
    k = np.argmin(np.abs(cantilever.alpha - 1.))
    assert cantilever.v[k] < .97 * cantilever.v_ref[k]
    assert cantilever.u[k] < .9 * cantilever.u_ref[k]
    assert "-5.4%" in cantilever.__doc__ and "-11.5%" in cantilever.__doc__
    assert len(cantilever.result.history) == 50
    assert max(r.residual for r in cantilever.result.history) <= 1e-9


@pytest.mark.slow
def test_cantilever_example_is_its_scene_file(cantilever):
    """examples/cantilever.py and examples/cantilever.toml are one
    problem: the tip column is selected by tolerance (seeded coordinates
    differ by round-off; exact equality took 8 of its 12 points and loaded
    the wrong pair, 1.1% off the scene's deflection), so both load the same
    two points and give the same tip deflection to 1e-12."""
    from skfem_mpm.scenes.scene import run_scene
    from skfem_mpm.scenes.scene_file import load_scene
    result = run_scene(load_scene(EXAMPLES / "cantilever.toml"))
    loaded = np.flatnonzero(result.points.force[1] != 0)
    assert loaded.size == 2
    example = np.flatnonzero(cantilever.result.points.force[1] != 0)
    assert np.array_equal(np.sort(loaded), np.sort(example))
    tip = -result.points.displacement[:, loaded].mean(axis=1) \
        / cantilever.LENGTH
    assert abs(tip[1] / cantilever.v[-1] - 1) < 1e-12
    assert abs(tip[0] / cantilever.u[-1] - 1) < 1e-12


def test_cantilever_newton_is_quadratic(cantilever):
    """r_k+1 <= C r_k^2 with a bounded C once r_k < 1e-3 in each step's
    final descent (the iterations after its last rise of the residual:
    before it, GIMP points change cells within the iteration and the
    residual jumps, 7.4e-4 to 0.29 in step 16) (a linearly converging
    iteration has r_k+1 / r_k^2 growing without bound: at the rate 0.25 it
    would exceed 4e4 at r_k = 6e-6), with r_k+1 above 1e-8 (the round-off
    floor of this residual is 1e-10 to 1e-9), and no step needs more than
    12 iterations (step 10, whose points change cells while it iterates;
    the median is 4).  Measured over 19 pairs: median C 45, 95th
    percentile 197, largest 777."""
    def final_descent(residuals):
        rises = [k for k in range(1, len(residuals))
                 if residuals[k] > residuals[k - 1]]
        return residuals[rises[-1] if rises else 0:]
    pairs = np.array([(a, b) for r in cantilever.result.history
                      for tail in [final_descent(r.newton_residuals)]
                      for a, b in zip(tail[:-1], tail[1:])
                      if a < 1e-3 and b > 1e-8])
    assert len(pairs) >= 15
    C = pairs[:, 1] / pairs[:, 0] ** 2
    assert np.percentile(C, 95) < 1e3
    assert C.max() < 1e4
    assert cantilever.newton_iterations <= 12
    assert np.median([len(r.newton_residuals) - 1
                      for r in cantilever.result.history]) <= 4


@pytest.mark.slow
def test_cantilever_gap_at_small_loads_shrinks_with_h(cantilever):
    from skfem_mpm.studies.elastica import elastica_tip
    _, alpha, v, u = cantilever.cantilever(h=.25)
    v_ref, u_ref = elastica_tip(alpha * (1 - cantilever.NU ** 2))
    for a in (1., 2.):
        coarse = np.argmin(np.abs(cantilever.alpha - a))
        fine = np.argmin(np.abs(alpha - a))
        gap_coarse = abs(cantilever.v[coarse] / cantilever.v_ref[coarse] - 1)
        gap_fine = abs(v[fine] / v_ref[fine] - 1)
        assert gap_fine < .5 * gap_coarse
        gap_coarse = abs(cantilever.u[coarse] / cantilever.u_ref[coarse] - 1)
        gap_fine = abs(u[fine] / u_ref[fine] - 1)
        assert gap_fine < .5 * gap_coarse


@pytest.mark.slow
def test_collapse_runs_conserves_mass_and_collapses(tmp_path):
    collapse = load("collapse")
    history = collapse.result.history
    assert len(history) == 40           # every step converged, no cut-back
    assert max(r.residual for r in history) <= 1e-9
    assert collapse.mass_error == 0.
    pts = collapse.result.points
    density = 1. * pts.volume0 / pts.volume       # rho0 = 1
    assert abs(density @ pts.volume - pts.volume0.sum()) < 1e-12 * 64
    spread = np.interp([.4, 1.], collapse.load, collapse.spread)
    assert spread[0] < .25 and spread[1] > 5.
    assert history[-1].n_yielded > pts.n / 2
    collapse.visualize(tmp_path)
    assert (tmp_path / "collapse.png").stat().st_size > 10_000


def test_cantilever_figure(cantilever, tmp_path, monkeypatch):
    """A lecturer's trial: the dashed (horizontal) elastica had no legend
    entry and the "final shape" panel did not say which load or stress
    it shows."""
    from skfem_mpm.scenes import plot
    kept, save = {}, plot.save_figure

    def keep(fig, path, *args, **kwargs):
        kept[path.name] = fig
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", keep)
    cantilever.visualize(tmp_path)
    assert (tmp_path / "cantilever.png").stat().st_size > 10_000
    curves, shape = kept["cantilever.png"].axes[:2]
    dashed = [line for line in curves.lines if line.get_linestyle() == "--"]
    assert dashed and all(not line.get_label().startswith("_")
                          for line in dashed)
    texts = curves.get_legend().get_texts()
    assert "elastica, horizontal" in [t.get_text() for t in texts]
    assert all(t.get_fontsize() >= 8 for t in texts)
    title = shape.get_title()
    assert "P L^2 / (E I) = {:g}".format(cantilever.ALPHA) in title
    assert "Cauchy, tension positive" in title


@pytest.mark.slow
def test_prandtl_footing_plateau_is_two_plus_pi(tmp_path):
    """Prandtl's smooth strip footing on weightless von Mises soil: once
    the curve reaches 97% of (2 + pi) c_u it stays within 3% of it to the
    end (measured: highest 5.239, last 5.146, Prandtl 5.142, so 1.9%),
    Newton stays quadratic on the yielding steps (log-ratio >= 1.8, measured
    2.2), and the figure is written."""
    prandtl = load("prandtl")
    limit = 2 + np.pi
    on = np.flatnonzero(prandtl.pressure >= .97 * limit)
    assert on.size >= 8 and on[-1] == prandtl.pressure.size - 1
    plateau = prandtl.pressure[on[0]:]
    assert np.abs(plateau / limit - 1).max() < .03
    history = prandtl.result.history
    assert history[-1].n_yielded > 1000
    ratios = [np.log(b) / np.log(a) for r in history
              for a, b in zip(r.newton_residuals[:-1], r.newton_residuals[1:])
              if a < 1e-2 and b > 1e-13]
    assert max(ratios) >= 1.8
    prandtl.visualize(tmp_path)
    assert (tmp_path / "prandtl.png").stat().st_size > 10_000


@pytest.fixture(scope="module")
def penetration():
    """The penetration example and its run at h = B/4 in 128 steps."""
    module = load("penetration")
    return module, module.penetrate(4, 128)


@pytest.mark.slow
def test_footing_penetrates_one_width_with_rising_resistance(penetration,
                                                             tmp_path):
    """A smooth strip footing pushed one footing width into weightless
    undrained clay (finite deformation, the grid moving with the footing,
    h = B/4): runs to the end in equilibrium; the pressure starts near
    (2 + pi) c_u (measured 5.5 at the first step, B/128) and rises as the
    footing embeds: its trend from 0.2 B on is upward (least-squares
    slope measured 1.45 c_u per B) and the last quarter averages above
    1.4 (2 + pi) c_u (measured 8.33); the rigid base that pushes the soil
    carries the footing's force (weightless soil, smooth sides: to 1e-8,
    measured 3e-10); the soil keeps its volume (plastic flow is
    isochoric: within 1%); the figure is written."""
    penetration, (result, depths, pressures, base) = penetration
    assert result.history[-1].load_factor == 1.
    assert max(r.residual for r in result.history) <= 1e-9
    prandtl = 2 + np.pi
    assert prandtl < pressures[1] < 1.2 * prandtl
    later = depths >= .2
    slope = np.polyfit(depths[later], pressures[later], 1)[0]
    assert slope > .5
    assert pressures[depths >= .75].mean() > 1.4 * prandtl
    assert np.abs(base[1:] - pressures[1:]).max() < 1e-8 * pressures.max()
    soil = result.points.body == 0
    J = np.linalg.det(np.moveaxis(result.points.F[:, :, soil], -1, 0))
    assert np.abs(J - 1).max() < .01
    penetration.visualize(result, depths, pressures, tmp_path)
    assert (tmp_path / "penetration.png").stat().st_size > 10_000


@pytest.mark.slow
def test_the_footing_as_an_obstacle_on_a_fixed_grid(penetration, tmp_path):
    """The same penetration with the footing an obstacle on a fixed grid
    (h = B/4, 128 steps): runs to one width; its first pressure within
    10% of the moving grid's (measured 5.49 and 5.51 c_u) and over the
    last tenth within 10% of it (8.5 and 8.4); its largest dip is
    reported in the docstring, not bounded here (a quarter at 0.5 B)."""
    module, (_, depths, pressures, _) = penetration
    result, fixed_depths, fixed = module.penetrate_with_obstacle(4, 128)
    assert result.history[-1].load_factor == 1.
    assert abs(fixed[1] / pressures[1] - 1) < .1
    assert abs(fixed[fixed_depths >= .9].mean()
               / pressures[depths >= .9].mean() - 1) < .1
    module.visualize(result, depths, pressures, tmp_path,
                     obstacle=(fixed_depths, fixed))
    assert (tmp_path / "penetration.png").stat().st_size > 10_000


@pytest.mark.slow
def test_penetration_scene_file_is_the_example(penetration):
    """examples/penetration.toml (supports on grid-line regions) is the
    script's problem: its first 3 steps' footing reactions are the
    script's to 1e-9."""
    from skfem_mpm.scenes.scene import run_scene
    from skfem_mpm.scenes.scene_file import load_scene
    penetration, (_, _, pressures, _) = penetration
    scene = load_scene(EXAMPLES / "penetration.toml")
    mesh, _ = scene.grid.build()
    under = 2 * np.flatnonzero(np.isclose(mesh.p[1], penetration.depth)
                               & (mesh.p[0] <= penetration.half)) + 1
    records = []

    class Enough(Exception):
        pass

    def stop_after_three(record, points):
        records.append(record)
        if len(records) == 3:
            raise Enough
    with pytest.raises(Enough):
        run_scene(scene, callback=stop_after_three)
    footing = np.array([-r.reactions[under].sum() for r in records]) \
        / penetration.half / penetration.cu
    assert np.abs(footing - pressures[1:4]).max() < 1e-9 * footing.max()


@pytest.mark.slow
def test_strip_footing_on_c_phi_soil_reaches_n_c(tmp_path):
    """A smooth footing on weightless c-phi soil (phi = 20 degrees,
    associated, Drucker-Prager's plane-strain fit, graded grid h = B/32 at
    the footing): once at 97% of N_c c the curve stays within 5% of it to
    the end (measured: peak 15.23 c, last 15.23 c, N_c = 14.83: 2.6%), and
    the figure is written."""
    from skfem_mpm.studies.footing import bearing_capacity_factor
    footing = load("strip_footing")
    limit = bearing_capacity_factor(20.)     # tested against its formula
    on = np.flatnonzero(footing.pressure >= .97 * limit)
    assert on.size >= 8 and on[-1] == footing.pressure.size - 1
    assert np.abs(footing.pressure[on[0]:] / limit - 1).max() < .05
    assert footing.result.history[-1].n_yielded > 500
    footing.visualize(tmp_path)
    assert (tmp_path / "strip_footing.png").stat().st_size > 10_000


def slip_circle_safety(ground, cohesion, unit_weight, right):
    """Limit equilibrium of a phi = 0 slope: the least factor of safety
    ``c R L / M_weight`` over slip circles above the firm base y = 0
    (moment equilibrium of the rigid block above the arc, Fellenius),
    integrated over x, by a grid search then Nelder-Mead."""
    from scipy.optimize import minimize
    x = np.linspace(0., right, 4001)
    dx, surface = x[1] - x[0], ground(x)

    def safety(circle):
        xc, yc, radius = circle
        if radius <= 0 or yc - radius < 0:          # below the firm base
            return np.inf
        d = radius ** 2 - (x - xc) ** 2
        inside = d > 0
        root = np.sqrt(np.where(inside, d, 1.))
        depth = np.where(inside, np.clip(surface - (yc - root), 0, None), 0.)
        moment = unit_weight * np.sum((x - xc) * depth) * dx
        arc = np.sum(np.where(depth > 0, radius / root, 0.)) * dx
        return cohesion * radius * arc / moment if moment > 0 else np.inf
    grid = [(xc, yc, r) for xc in np.linspace(0., right / 2, 24)
            for yc in np.linspace(2., 40., 27)
            for r in np.linspace(2., 40., 27)]
    start = min(grid, key=safety)
    return minimize(safety, start, method="Nelder-Mead",
                    options=dict(xatol=1e-6, fatol=1e-10)).fun


@pytest.mark.slow
def test_slope_factor_of_safety_by_strength_reduction(tmp_path):
    """The strength-reduction factor of safety of the 45-degree clay slope
    (h = H/16) within 5% of the limit-equilibrium slip circle computed here
    (measured: 1.570 against 1.519, +3.4%); the bracket is 1% wide and
    every trial below it converged, every one above failed."""
    slope = load("slope")
    reference = slip_circle_safety(slope.ground, 50., slope.unit_weight,
                                   slope.length)
    assert 1.45 < reference < 1.6            # Taylor's chart: ~ 6 c / (g H)
    s = slope.safety
    assert abs(s.factor / reference - 1) < .05
    assert s.failed - s.converged <= .01 * s.converged
    assert all(ok == (f <= s.converged) for f, ok in s.trials)
    assert s.result.history[-1].n_yielded > 100
    slope.visualize(tmp_path)
    assert (tmp_path / "slope.png").stat().st_size > 10_000


@pytest.fixture(scope="module")
def collapse():
    return load("collapse_dynamic")


def test_dynamic_collapse_runs_to_rest(collapse, tmp_path):
    """A clay column released under gravity slumps and comes to rest
    (implicit dynamics, generalised-alpha): kinetic energy at the end below
    1e-4 of its peak (measured 1e-6), the peak between 0.1 and 0.6 s
    (measured 0.28 s); toe out beyond 1.2 m, crest below 1.7 m (measured
    1.31, 1.57); gravity's work taken by the internal work to within 10%
    and never exceeded by it (numerical dissipation measured 5%); every
    step in equilibrium; the figure is written."""
    e = collapse.energies
    assert e["kinetic"][-1] < 1e-4 * e["kinetic"].max()
    assert .1 < e["time"][np.argmax(e["kinetic"])] < .6
    assert collapse.toe > 1.2 and collapse.crest < 1.7
    dissipated = e["external_work"] - e["internal_work"] - e["kinetic"]
    assert dissipated.min() > -1e-6 * e["external_work"][-1]
    assert dissipated[-1] < .1 * e["external_work"][-1]
    assert max(r.residual for r in collapse.result.history) <= 1e-9
    collapse.visualize(tmp_path)
    assert (tmp_path / "collapse_dynamic.png").stat().st_size > 10_000


@pytest.mark.slow
def test_time_step_adapts_to_newtons_effort(collapse):
    """The collapse with time steps of up to 0.1 s adapting to 6 Newton
    iterations: the step shrinks where the column slumps (below 0.025 s;
    measured 0.006 s) and grows back to 0.1 s once it rests (the last five
    steps), ends at t = 2.5 s exactly with every step converged, and the
    toe lands within 5% of the fixed 0.02 s run's (measured 2.3%)."""
    from skfem import ElementQuad1
    from skfem_mpm import Dynamics, GeneralizedAlpha, simulate
    result = simulate(collapse.mesh, ElementQuad1(), collapse.points,
                      collapse.soil, collapse.supports,
                      body_force=[0., -collapse.rho * collapse.g],
                      kinematics="finite", dynamics=Dynamics(
                          .1, 2.5, collapse.rho, scheme=GeneralizedAlpha(.5),
                          target_iterations=6))
    steps = np.array([r.time_step for r in result.history])
    assert steps.min() < .025
    assert np.allclose(steps[-5:], .1, rtol=1e-12)
    assert result.history[-1].time == pytest.approx(2.5, abs=1e-12)
    assert max(r.residual for r in result.history) <= 1e-9
    toe = result.points.x[0].max()
    assert abs(toe / collapse.toe - 1) < .05


@pytest.fixture(scope="module")
def fe_to_mpm():
    return load("fe_to_mpm")


def elastica_under_weight(alpha):
    """Tip deflection of the inextensible elastica of a cantilever under
    its weight (dead load, q L^3 / (E I) = alpha) over the linear one,
    alpha / 8: EI theta'' = -q (L - s) cos(theta), theta(0) = 0 and
    theta'(L) = 0, in s / L."""
    from scipy.integrate import solve_bvp
    s = np.linspace(0., 1., 101)
    solution = solve_bvp(
        lambda s, y: np.vstack([y[1], -alpha * (1 - s) * np.cos(y[0]),
                                np.sin(y[0])]),
        lambda ya, yb: np.array([ya[0], yb[1], ya[2]]), s,
        np.zeros((3, s.size)), tol=1e-10)
    assert solution.status == 0
    return -solution.y[2, -1] / (alpha / 8)


def test_fe_to_mpm(fe_to_mpm, tmp_path):
    """The scikit-fem script turned into MPM: ``solve_fe`` repeats the
    plain scikit-fem solution to round-off (1e-10; measured 9e-12); the FE
    tip deflection is Timoshenko's (plane strain, shear factor 5/6, at the
    tip points) to within 5% (measured 4.2% stiff: Q1 shear locking); MPM's
    first load step per unit load is FE's to within 3% (measured 2.4%
    softer: 2x2 points per cell against 3x3 Gauss points); from there to
    full load the tip deflection per unit load falls like the elastica's
    (computed here) to within 3% (measured 0.940 against 0.921); every
    step in equilibrium; the docstring counts the added lines right; the
    figure is written."""
    import re
    m = fe_to_mpm
    assert np.abs(m.fe.u - m.u).max() <= 1e-10 * np.abs(m.u).max()
    L, q = m.LENGTH, m.WEIGHT * m.DEPTH
    bending = m.E / (1 - m.NU ** 2) * m.DEPTH ** 3 / 12
    shear = 5 / 6 * m.E / (2 * (1 + m.NU)) * m.DEPTH
    x = m.points.x[0, m.tip].mean()
    timoshenko = (q * x ** 2 * (6 * L ** 2 - 4 * L * x + x ** 2)
                  / (24 * bending) + q * (L * x - x ** 2 / 2) / shear)
    assert abs(m.fe_tip / timoshenko - 1) < .05
    per_load = m.mpm_tip / m.load * m.WEIGHT / m.fe_tip
    assert abs(per_load[0] - 1) < .03
    alpha = q * L ** 3 / bending
    stiffening = (elastica_under_weight(alpha)
                  / elastica_under_weight(alpha * m.load[0] / m.WEIGHT))
    assert abs(per_load[-1] / per_load[0] / stiffening - 1) < .03
    assert max(r.residual for r in m.mpm.history) <= 1e-9

    def code(lines):
        return [line for line in lines.splitlines()
                if line.strip() and not line.strip().startswith("#")]
    source = (EXAMPLES / "fe_to_mpm.py").read_text()
    counted = (len([line for line in source.splitlines()
                    if line.startswith("from skfem_mpm")]),
               len(code(source[source.index("# 2. "):
                               source.index("# 3. ")])),
               len(code(source[source.index("# 3. "):
                               source.index("def visualize")])))
    stated = re.search(r"(\d+) import line, (\d+) lines for part 2, (\d+) "
                       r"for part 3", " ".join(m.__doc__.split()))
    assert tuple(int(n) for n in stated.groups()) == counted
    m.visualize(tmp_path)
    assert (tmp_path / "fe_to_mpm.png").stat().st_size > 10_000


@pytest.fixture(scope="module")
def obstacles():
    return load("obstacles")


def test_obstacles_landing_and_slope(obstacles, tmp_path):
    """The dropped block follows free fall to 2% of the fall until the
    landing time, never goes through the floor by more than its
    tolerance, and feels no force before; the block sticks below
    arctan(mu) and slides Coulomb's distance to 2% above."""
    m = obstacles
    falling = (m.times > 0) & (m.times < m.landing_time - .01)
    fall = .5 - .5 * m.g * m.times[falling] ** 2
    assert np.allclose(m.lowest[falling], fall, atol=.02 * .5)
    assert not m.floor_force[falling].any()
    assert m.lowest.min() >= -m.floor.tolerance * .1
    below, above = m.angles
    t, x = m.slides[below]
    assert abs(x[-1]) < 1e-3 * .5 * m.g * t[-1] ** 2
    t, x = m.slides[above]
    assert x[-1] == pytest.approx(m.sliding(above, t[-1]), rel=.02)
    m.visualize(tmp_path)
    assert (tmp_path / "obstacles.png").stat().st_size > 10_000


@pytest.mark.slow
def test_bodies_in_contact(tmp_path):
    """With a contact the dropped block follows free fall to 1e-3 of the
    fall until the landing time and glued it stops half a cell above the
    slab; the block slides Coulomb's distance to 2%, glued it stays; the
    pressed blocks carry sigma_yy = -p and no horizontal stress to 1e-3 of
    p (the contact's default tolerance), glued more than 0.1 p."""
    m = load("bodies_in_contact")
    times, lowest = m.landings["contact"]
    falling = times < m.landing_time - .01
    fall = .5 - .5 * m.g * times[falling] ** 2
    assert np.allclose(lowest[falling], fall, atol=1e-3 * .5)
    assert lowest.min() < 0.           # it reached the slab
    glued = m.landings["glued"][1]
    assert glued.min() > .04           # held in the cell above the slab
    times, x = m.slides["contact"]
    assert x[-1] == pytest.approx(m.sliding(times[-1]), rel=.02)
    assert abs(m.slides["glued"][1][-1]) < 1e-2 * x[-1]
    stress = m.pressed["contact"]
    assert np.abs(stress[0, 0]).max() < 1e-3 * m.p
    assert np.abs(stress[1, 1] + m.p).max() < 1e-3 * m.p
    assert np.abs(m.pressed["glued"][0, 0]).max() > .1 * m.p
    m.visualize(tmp_path)
    assert (tmp_path / "bodies_in_contact.png").stat().st_size > 10_000


@pytest.mark.slow
def test_obstacles_footing_on_a_fixed_grid(obstacles):
    """The smooth footing as an obstacle on a fixed grid (B = 8 h, 3 x 3
    points per cell, 2 cells in 40 steps): past 0.02 B its pressure
    changes between steps by under 3%, as issue 29 asks (measured 2.8%;
    the rigid body of points 21% as it crosses grid lines; 9.4% with 2 x
    2 points per cell before the corners moved with their cell's
    polynomial, 5.0% after), in at most twice the steps asked (measured
    58), and rises from 8% above (2 + pi) c_u to 25% at 0.25 B as the
    footing sinks into the soil (its early plateau: issue 29 asks for 8%,
    not met)."""
    curves = obstacles.footing_curves()
    jumps = {}
    for name, (s, q) in curves.items():
        late = s > .02
        jumps[name] = np.max(np.abs(np.diff(q[late])) / q[late][1:])
    s, q = curves["obstacle"]
    assert jumps["obstacle"] < .03 and 4 * jumps["obstacle"] < \
        jumps["rigid body"]
    assert np.all(np.abs(q[s > .02] / (2 + np.pi) - 1) < .3)
    assert len(s) <= 80
