"""Soil models (skfem_mpm/mechanics/soils.py) and element tests
(skfem_mpm/mechanics/element_tests.py): return maps on the yield surface,
consistent tangents, closed-form strengths, and the models in the core."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from skfem_mpm import (DruckerPrager, NewtonOptions, InvalidInputError,
                       InvalidMaterialError, LinearElastic, MohrCoulomb,
                       simulate, seed_points)
from skfem_mpm.errors import SceneError
from skfem_mpm.mechanics.element_tests import (mixed_path, oedometer,
                                               simple_shear, triaxial)

E, NU, C = 1e4, .3, 10.

MODELS = {
    "dp": DruckerPrager(E, NU, cohesion=C, friction_angle=30.),
    "dp-nonassoc": DruckerPrager(E, NU, cohesion=C, friction_angle=30.,
                                 dilation_angle=10.),
    "dp-hardening": DruckerPrager(E, NU, cohesion=C, friction_angle=25.,
                                  dilation_angle=25., hardening=500.,
                                  fit="plane_strain"),
    "dp-softening": DruckerPrager(E, NU, cohesion=C, friction_angle=20.,
                                  dilation_angle=20., hardening=-200.,
                                  fit="inner"),
    "mc": MohrCoulomb(E, NU, cohesion=C, friction_angle=30.),
    "mc-assoc": MohrCoulomb(E, NU, cohesion=C, friction_angle=30.,
                            dilation_angle=30.),
    "tresca": MohrCoulomb(E, NU, cohesion=C, friction_angle=0.),
}


def yield_function(model, tau, alpha):
    """f of the returned principal stresses, relative to the cohesion."""
    if isinstance(model, DruckerPrager):
        p = tau.mean(axis=0)
        s = tau - p
        return (np.linalg.norm(s, axis=0) / np.sqrt(2) + model.eta * p
                - model.xi * (model.cohesion + model.hardening * alpha)) / C
    s = -np.sort(-tau, axis=0)
    return (model.k * s[0] - s[2] - model.sigma_c) / C


def random_trial(n, seed, size=3e-3):
    rng = np.random.default_rng(seed)
    eps = rng.normal(0., size, (3, n))
    eps[:, :n // 10] = eps[:1, :n // 10]              # isotropic: the apex
    eps[1, n // 10:n // 5] = eps[0, n // 10:n // 5]   # two equal: an edge
    alpha = np.abs(rng.normal(0., 1e-3, n))
    return eps, {"equivalent_plastic_strain": alpha}


@pytest.mark.parametrize("name", MODELS)
def test_return_lands_on_the_yield_surface(name):
    """2000 trial states (isotropic ones, ones on an edge, random): the
    returned stresses satisfy f = 0 to 1e-10 of the cohesion where the
    point yielded and f <= 0 elsewhere; planes, edges and the apex are all
    reached (measured residuals 1e-15 .. 3e-14)."""
    model = MODELS[name]
    eps, state = random_trial(2000, 1)
    tau, eps_e, D, yielded, new = model.principal_update(eps, state)
    f = yield_function(model, tau, new["equivalent_plastic_strain"])
    assert yielded.sum() > 500
    assert np.abs(f[yielded]).max() < 1e-10
    assert f.max() < 1e-10
    # the elastic strains give the stresses back (no lost plastic strain)
    C_el = model.principal_stiffness()
    assert np.abs(C_el @ eps_e - tau).max() < 1e-9 * np.abs(tau).max()
    if not isinstance(model, DruckerPrager) and model.friction_angle > 0:
        at_apex = yielded & (np.ptp(tau, axis=0) < 1e-9 * C)
        assert at_apex.any()
        assert np.allclose(tau[:, at_apex], model.sigma_c / (model.k - 1))
    if isinstance(model, DruckerPrager):
        apex = model.xi * (model.cohesion + model.hardening
                           * new["equivalent_plastic_strain"]) / model.eta
        at_apex = yielded & (np.ptp(tau, axis=0) < 1e-9 * C)
        assert at_apex.any()
        assert np.allclose(tau[0, at_apex], apex[at_apex])


@pytest.mark.parametrize("name", MODELS)
def test_consistent_tangent_matches_finite_differences(name):
    """D = dtau/deps against central differences (h = 1e-7) to 1e-6 of E
    (measured at most 3e-8: planes, edges and apex), at every point where
    the return is smooth within h (forward and backward differences agree;
    a few random states lie within h of a kink between regions)."""
    model = MODELS[name]
    eps, state = random_trial(1000, 2)
    tau, _, D, yielded, _ = model.principal_update(eps, state)
    h = 1e-7
    for j in range(3):
        step = np.zeros((3, 1))
        step[j] = h
        up = model.principal_update(eps + step, state)[0]
        down = model.principal_update(eps - step, state)[0]
        smooth = np.abs((up - tau) - (tau - down)).max(axis=0) / h < 1e-2 * E
        assert smooth.mean() > .98 and smooth[yielded].sum() > 300
        fd = (up - down) / (2 * h)
        assert np.abs(fd - D[:, j])[:, smooth].max() < 1e-6 * E


@settings(max_examples=200, deadline=None, derandomize=True)
@given(name=st.sampled_from(sorted(MODELS)),
       eps=st.lists(st.floats(-.5, .5), min_size=3, max_size=3),
       alpha=st.floats(0., 1e-2))
def test_random_trial_states_never_give_nan_or_leave_the_domain(
        name, eps, alpha):
    model = MODELS[name]
    eps = np.array(eps)[:, None]
    tau, eps_e, D, yielded, new = model.principal_update(
        eps, {"equivalent_plastic_strain": np.array([alpha])})
    for value in (tau, eps_e, D, new["equivalent_plastic_strain"]):
        assert np.isfinite(value).all()
    f = yield_function(model, tau, new["equivalent_plastic_strain"])
    assert f.max() <= 1e-9 * max(1., np.abs(tau).max() / C)
    assert new["equivalent_plastic_strain"][0] >= alpha


def compression_strength(phi, cohesion, confining):
    """Mohr-Coulomb's deviator at failure in triaxial compression:
    ``q = sigma_c + (k - 1) sigma_r``."""
    s = np.sin(np.radians(phi))
    k = (1 + s) / (1 - s)
    return 2 * cohesion * np.cos(np.radians(phi)) / (1 - s) \
        + (k - 1) * confining


@pytest.mark.parametrize("name", ["dp", "dp-nonassoc", "mc", "mc-assoc"])
def test_triaxial_peak_is_the_analytical_strength(name):
    """Drained triaxial compression at a confining stress of 100: the
    plateau of q equals Mohr-Coulomb's compression strength (the outer
    cone passes through its compression corners) to 1e-6 (measured
    round-off); dilatancy only with a dilation angle."""
    model = MODELS[name]
    path = triaxial(model, 100., .05, nsteps=50)
    q = compression_strength(30., C, 100.)
    assert abs(path.q[-1] / q - 1) < 1e-6
    assert path.yielded[-1] and not path.yielded[1]
    volumetric = np.einsum("iis->s", path.strain)
    if model.dilation_angle > 0:          # the sample expands while flowing
        assert volumetric[-1] > volumetric[-2]
    else:
        assert volumetric[-1] < volumetric[-2] + 1e-12


@pytest.mark.slow
def test_plane_strain_fit_gives_mohr_coulomb_in_plane_strain():
    """Plane-strain compression (the out-of-plane strain held, associated
    flow): the plane-strain cone fails at Mohr-Coulomb's in-plane strength
    ``k s1 - s3 = sigma_c`` to 1e-6."""
    for phi in (20., 35.):
        model = DruckerPrager(E, NU, cohesion=C, friction_angle=phi,
                              dilation_angle=phi, fit="plane_strain")
        controlled = np.ones((3, 3), dtype=bool)
        controlled[0, 0] = False                 # x: confining stress
        increment = np.zeros((3, 3))
        increment[2, 2] = -.2                    # z compressed, y held
        target = -100. * np.eye(3)
        path = mixed_path(model, increment, controlled, target, 100,
                          -100. * np.eye(3))
        sx, sz = path.stress[0, 0, -1], path.stress[2, 2, -1]
        s = np.sin(np.radians(phi))
        k, sigma_c = (1 + s) / (1 - s), 2 * C * np.cos(np.radians(phi)) \
            / (1 - s)
        assert abs((k * sx - sz) / sigma_c - 1) < 1e-6


def test_elastic_element_tests_follow_hooke():
    """Oedometer: sigma_z = (lam + 2 mu) eps, sigma_x = lam eps; simple
    shear: tau = mu gamma (closed forms, 1e-12)."""
    model = LinearElastic(E, NU)
    path = oedometer(model, 1e-3, nsteps=3)
    assert path.stress[2, 2, -1] == pytest.approx(
        -(model.lam + 2 * model.mu) * 1e-3, rel=1e-12)
    assert path.stress[0, 0, -1] == pytest.approx(-model.lam * 1e-3,
                                                  rel=1e-12)
    shear = simple_shear(model, 2e-3, vertical_stress=50., nsteps=4)
    assert shear.stress[0, 1, -1] == pytest.approx(model.mu * 2e-3,
                                                   rel=1e-12)
    assert shear.stress[1, 1, -1] == pytest.approx(-50., rel=1e-12)


@pytest.mark.parametrize("kwargs, match", [
    (dict(cohesion=-1., friction_angle=30.), "cohesion"),
    (dict(cohesion=1., friction_angle=90.), "friction_angle"),
    (dict(cohesion=1., friction_angle=-5.), "friction_angle"),
    (dict(cohesion=1., friction_angle=20., dilation_angle=25.), "dilation"),
    (dict(cohesion=1., friction_angle=float("nan")), "friction_angle"),
    (dict(cohesion="1", friction_angle=20.), "cohesion"),
    (dict(cohesion=0., friction_angle=0.), "no strength"),
])
def test_bad_soil_parameters_are_refused(kwargs, match):
    for model in (DruckerPrager, MohrCoulomb):
        with pytest.raises(InvalidMaterialError, match=match):
            model(E, NU, **kwargs)
    with pytest.raises(InvalidMaterialError, match="fit"):
        DruckerPrager(E, NU, cohesion=1., friction_angle=20., fit="mean")
    with pytest.raises(InvalidMaterialError, match="softens faster"):
        DruckerPrager(E, NU, cohesion=1., friction_angle=20., hardening=-1.)


@pytest.mark.parametrize("name", ["dp", "mc"])
@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_soil_block_in_the_core_converges_quadratically(name, kinematics):
    """A frictional block (2 x 1, base clamped) sheared by a prescribed
    top displacement far past yield: every step converges, points yield,
    and Newton is quadratic near convergence (log-ratio >= 1.8)."""
    from skfem import ElementQuad1
    from meshes import sheared_block
    mesh, points, _, shear = sheared_block(.03)
    res = simulate(mesh, ElementQuad1(), points, MODELS[name],
                   lambda b: b.get_dofs(lambda x: x[1] == 0),
                   body_force=[0., -20.], prescribed=shear, nsteps=5,
                   kinematics=kinematics)
    assert res.history[-1].residual <= 1e-9
    assert res.history[-1].n_yielded > 0
    ratios = [np.log(b) / np.log(a) for r in res.history
              for a, b in zip(r.newton_residuals[:-1], r.newton_residuals[1:])
              if a < 1e-2 and b > 1e-13]
    assert ratios and max(ratios) >= 1.8


def test_scene_files_know_the_soil_models():
    from skfem_mpm.scenes.scene_file import parse_scene
    base = {"grid": {"x": [0., 1., 2], "y": [0., 1., 2]},
            "bodies": [{"region": {"x": [0., 1.], "y": [0., 1.]},
                        "material": {}}],
            "supports": [{"boundary": "bottom"}]}

    def material(**kwargs):
        data = dict(base)
        data["bodies"] = [dict(base["bodies"][0], material=kwargs)]
        return parse_scene(data).bodies[0].material
    dp = material(model="drucker_prager", E=1e4, nu=.3, cohesion=5.,
                  friction_angle=25., dilation_angle=5., fit="plane_strain")
    assert dp == DruckerPrager(1e4, .3, cohesion=5., friction_angle=25.,
                               dilation_angle=5., fit="plane_strain")
    mc = material(model="mohr_coulomb", E=1e4, nu=.3, cohesion=5.,
                  friction_angle=25.)
    assert mc == MohrCoulomb(1e4, .3, cohesion=5., friction_angle=25.)
    for bad, match in [
            (dict(cohesion=-5., friction_angle=25.), "cohesion"),
            (dict(cohesion=5., friction_angle=95.), "friction_angle"),
            (dict(cohesion=5., friction_angle=25., dilation_angle=30.),
             "dilation"),
            (dict(cohesion=5.), "friction_angle: missing"),
            (dict(cohesion=5., friction_angle=25., yield_stress=3.),
             "not a parameter"),
            (dict(cohesion=5., friction_angle=25., fit="mean"), "fit")]:
        with pytest.raises(SceneError, match=match):
            material(model="drucker_prager", E=1e4, nu=.3, **bad)


@pytest.mark.parametrize("name", ["elastic", "mc", "dp"])
@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_geostatic_layer_starts_in_equilibrium(name, kinematics):
    """A level layer (4 x 2, gamma = 20) from the K0 state with its weight
    in full from the first step: the stresses are gamma depth (vertical)
    and K0 times it (horizontal) to round-off, the first residual is at
    round-off (measured 1e-16) and nothing moves; ramping the weight up from
    zero instead settles the layer (measured 2.9e-3)."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm.mechanics.geostatic import geostatic_stress
    material = {"elastic": LinearElastic(E, NU), "mc": MODELS["mc"],
                "dp": MODELS["dp"]}[name]
    K0 = NU / (1 - NU) if name == "elastic" else 1 - np.sin(np.radians(30.))
    mesh = MeshQuad.init_tensor(np.linspace(0, 4, 9), np.linspace(0, 2.5, 6))
    points = seed_points(mesh, 2, region=lambda x: x[1] < 2)

    def supports(b):
        return np.concatenate([
            b.get_dofs(lambda x: x[1] == 0).all(),
            b.get_dofs(lambda x: np.isclose(x[0], 0.)
                       | np.isclose(x[0], 4.)).all("u^1")])
    start = geostatic_stress(points, material, [0., -20.], 2., K0)
    depth = 2. - points.x[1]
    assert np.abs(start.stress[1, 1] + 20. * depth).max() < 1e-12 * 40
    assert np.abs(start.stress[0, 0] - K0 * start.stress[1, 1]).max() \
        < 1e-12 * 40
    assert np.abs(start.stress[2, 2] - start.stress[0, 0]).max() < 1e-12
    run = dict(body_force=[0., -20.], nsteps=2, kinematics=kinematics)
    res = simulate(mesh, ElementQuad1(), start, material, supports,
                   ramp_body_force=False, **run)
    first = res.history[0].newton_residuals or [res.history[0].residual]
    assert first[0] < 1e-12
    assert np.abs(res.points.displacement).max() < 1e-12
    assert np.allclose(res.points.stress, start.stress, rtol=0, atol=1e-10)
    settled = simulate(mesh, ElementQuad1(), points, material, supports,
                       **run)
    assert np.abs(settled.points.displacement).max() > 1e-3


def test_bad_geostatic_states_are_refused():
    from skfem import MeshQuad
    from skfem_mpm.mechanics.geostatic import geostatic_stress
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 2, 5))
    points = seed_points(mesh, 2)
    sand = MohrCoulomb(E, NU, cohesion=0., friction_angle=30.)
    # below the active ratio (1 - sin phi) / (1 + sin phi) = 1/3: no soil
    with pytest.raises(InvalidInputError, match="outside the yield"):
        geostatic_stress(points, sand, [0., -20.], 2., .2)
    geostatic_stress(points, sand, [0., -20.], 2., .4)        # stands
    for kwargs, match in [(dict(surface=1.), "above the surface"),
                          (dict(body_force=[5., -20.]), "last axis"),
                          (dict(body_force=[0., 20.]), "pointing down"),
                          (dict(K0=0.), "K0"),
                          (dict(surface=lambda x: np.ones(3)), "one finite")]:
        args = dict(body_force=[0., -20.], surface=2., K0=.5)
        args.update(kwargs)
        with pytest.raises(InvalidInputError, match=match):
            geostatic_stress(points, LinearElastic(E, NU), **args)
    with pytest.raises(InvalidInputError, match="ramp_body_force"):
        simulate(mesh, None, points, LinearElastic(E, NU), [],
                 ramp_body_force="no")


LAYER = """
name = "layer"
[grid]
x = [0.0, 4.0, 8]
y = [0.0, 2.5, 5]
[[bodies]]
name = "soil"
region = { x = [0.0, 4.0], y = [0.0, 2.0] }
geostatic = { K0 = 0.5 }
[bodies.material]
model = "mohr_coulomb"
E = 1e4
nu = 0.3
cohesion = 5.0
friction_angle = 30.0
[[supports]]
name = "base"
boundary = "bottom"
[[supports]]
name = "left"
boundary = "left"
components = ["x"]
[gravity]
body_force = [0.0, -20.0]
[solver]
kinematics = "finite"
steps = 2
[[supports]]
boundary = "right"
components = ["x"]
"""


def test_scene_file_starts_a_layer_from_its_geostatic_stress(tmp_path, capsys):
    """``geostatic = { K0 = 0.5 }``: the CLI run has nothing to do (no
    Newton iteration, residual at round-off, nothing moves) and the
    reactions are the closed forms, the base the weight ``gamma B H`` and
    a side ``K0 gamma H^2 / 2`` (1e-12)."""
    import json
    from skfem_mpm.cli import main
    scene = tmp_path / "layer.toml"
    scene.write_text(LAYER)
    assert main(["run", str(scene), "--out", str(tmp_path / "out"),
                 "--no-progress"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["newton_iterations"] == [0, 0]
    assert summary["max_displacement"] == 0.
    base = summary["reactions"]["base"][-1]
    side = summary["reactions"]["left"][-1]
    assert abs(base[1] - 20. * 4. * 2.) < 1e-12 * 160.
    assert abs(side[0] - .5 * 20. * 2. ** 2 / 2) < 1e-12 * 20.
    for bad, match in [("K0 = 0.5", "K0 = -1.0"), ("K0 = 0.5", "KO = 0.5"),
                       ("K0 = 0.5", "K0 = 0.05")]:
        scene.write_text(LAYER.replace(bad, match))
        assert main(["run", str(scene), "--out", str(tmp_path / "bad"),
                     "--no-progress"]) == 2
        assert not (tmp_path / "bad").exists()


def test_geostatic_scene_with_a_ramped_fill_and_the_material_top(tmp_path):
    """A geostatic layer whose region ends inside a cell (its material's
    top, the points' domains, is the default surface: no imbalance) under
    an elastic fill without K0: the fill's weight is ramped (half of it in
    step 1 of 2), the layer's is there from the start; the base carries
    exactly what is there (1e-10)."""
    from skfem_mpm.scenes.scene import run_scene
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    text = LAYER.replace('y = [0.0, 2.0] }', 'y = [0.0, 1.9] }').replace(
        "[gravity]", """[[bodies]]
name = "fill"
region = { x = [1.0, 3.0], y = [2.0, 2.5] }
[bodies.material]
model = "linear_elastic"
E = 1e4
nu = 0.3
[gravity]""")
    scene = parse_scene(tomllib.loads(text.replace("y = [0.0, 2.5, 5]",
                                                   "y = [0.0, 3.0, 6]")))
    res = run_scene(scene)
    layer, fill = 20. * 4. * 2., 20. * 2. * .5
    for record, share in zip(res.history, (.5, 1.)):
        base = record.reactions.reshape(-1, 2)[:, 1]
        total = res.history[-1].reactions.reshape(-1, 2)[:, 1].sum()
        assert abs(base.sum() - (layer + share * fill)) < 1e-10 * total
    scene.newton = NewtonOptions(rhs="increment")
    scene.kinematics = "small"
    scene.bodies[0].material = LinearElastic(E, NU)
    with pytest.raises(InvalidInputError, match="geostatic"):
        scene.check()


def test_a_body_force_in_full_is_refused_with_the_increment_scheme():
    from skfem import ElementQuad1, MeshQuad
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 2, 5))
    with pytest.raises(InvalidInputError, match="increment"):
        simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
                 LinearElastic(E, NU), lambda b: b.get_dofs(
                     lambda x: x[1] == 0), body_force=[0., -1.],
                 rhs="increment", ramp_body_force=False)
    with pytest.raises(InvalidInputError, match="one bool per body"):
        simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
                 LinearElastic(E, NU), [], ramp_body_force=[True, False])


def test_drucker_prager_apex_and_cone_meet_continuously():
    """Non-associated flow with hardening: along a path of growing volume
    with a small deviator the return switches from the cone to the apex
    without a jump in the stress or in alpha (the apex hardens by
    xi / eta_bar times its volumetric plastic strain, as the cone does)."""
    model = DruckerPrager(E, NU, cohesion=C, friction_angle=30.,
                          dilation_angle=10., hardening=2000.)
    ev = np.linspace(0., .02, 20001)
    eps = np.vstack([ev / 3 + 5e-4, ev / 3 - 2.5e-4, ev / 3 - 2.5e-4])
    tau, _, _, _, new = model.principal_update(
        eps, {"equivalent_plastic_strain": np.zeros(ev.size)})
    apex = np.ptp(tau, axis=0) < 1e-9
    assert apex.any() and not apex.all()
    K = E / (3 * (1 - 2 * NU))
    assert np.abs(np.diff(tau.mean(axis=0))).max() <= 1.001 * K * (ev[1]
                                                                   - ev[0])
    assert np.abs(np.diff(new["equivalent_plastic_strain"])).max() < 1e-5


def test_simple_shear_starts_oedometric_and_refuses_impossible_starts():
    """Simple shear of a cohesionless sand under a vertical stress: from
    the oedometric state the lateral and out-of-plane strains stay zero,
    the shear stress reaches the closed-form strength of Mohr-Coulomb in
    simple shear below tan(phi) times the vertical stress; a start outside
    the yield surface is refused."""
    sand = MohrCoulomb(E, NU, cohesion=0., friction_angle=30.)
    path = simple_shear(sand, .05, vertical_stress=100., nsteps=100)
    assert np.abs(path.strain[0, 0]).max() < 1e-15
    assert np.abs(path.strain[2, 2]).max() < 1e-15
    assert path.stress[1, 1, -1] == pytest.approx(-100., rel=1e-10)
    ratio = path.stress[0, 1, -1] / 100.
    assert path.yielded[-1] and 0 < ratio <= np.tan(np.radians(30.))
    with pytest.raises(InvalidInputError, match="yield surface"):
        mixed_path(sand, np.zeros((3, 3)), np.ones((3, 3), dtype=bool),
                   np.zeros((3, 3)), 1, np.diag([-1., -100., -1.]))
    with pytest.raises(InvalidInputError, match="compressive"):
        triaxial(sand, -5., .01)


@pytest.mark.parametrize("model", [DruckerPrager, MohrCoulomb])
def test_angles_that_look_like_radians_are_refused(model):
    """A friction angle of 0.52 (radians) was taken as 0.52 degrees without
    a word (issue 30): an angle in (0, 1) degree is refused, the message
    saying it is in degrees and what the value is in degrees as radians
    (0.52 rad = 29.8, 0.17 rad = 9.7); 0 stays allowed (Tresca-like, no
    dilation), and so does 1 degree; strength reduction still takes the
    angles below 1 degree it derives (tan(30 deg) / 64: 0.517 degrees)."""
    from skfem_mpm import reduce_strength
    with pytest.raises(InvalidMaterialError,
                       match=r"friction_angle is in degrees, got 0\.52.*"
                             r"0\.52 rad = 29\.8 degrees"):
        model(E, NU, cohesion=C, friction_angle=.52)
    with pytest.raises(InvalidMaterialError,
                       match=r"dilation_angle is in degrees, got 0\.17.*"
                             r"= 9\.7 degrees"):
        model(E, NU, cohesion=C, friction_angle=30., dilation_angle=.17)
    assert model(E, NU, cohesion=C, friction_angle=0.).friction_angle == 0.
    assert model(E, NU, cohesion=C, friction_angle=1.,
                 dilation_angle=0.).friction_angle == 1.
    weak = reduce_strength(model(E, NU, cohesion=C, friction_angle=30.,
                                 dilation_angle=5.), 64.)
    assert weak.friction_angle == pytest.approx(
        np.degrees(np.arctan(np.tan(np.radians(30.)) / 64)), rel=1e-12)
    assert 0. < weak.dilation_angle < weak.friction_angle < 1.


def test_a_hardening_modulus_that_overflows_is_refused():
    """Drucker-Prager's hardening modulus is a modulus too: 1e308 refused
    by name (beyond the limit of 1e300)."""
    with pytest.raises(InvalidMaterialError,
                       match=r"hardening modulus dc/dalpha = 1e\+308 is "
                             r"beyond 1e\+300"):
        DruckerPrager(E, NU, cohesion=C, friction_angle=20., hardening=1e308)


def test_a_weightless_geostatic_start_is_stress_free(caplog):
    """Zero weight (one staged script running a weightless case too; a
    user trial was refused with "pointing down (negative), got [0.0,
    -0.0]"): the stress is zero whatever K0, and the run under the zero
    body force in full does nothing; Cam clay, with no stress-free state,
    refuses it in its own words."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm import BodyForce, ModifiedCamClay
    from skfem_mpm.mechanics.geostatic import geostatic_stress
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 2, 5))
    points = seed_points(mesh, 2)
    for material in (LinearElastic(E, NU), MohrCoulomb(
            E, NU, cohesion=0., friction_angle=30.)):
        start = geostatic_stress(points, material, [0., -0.], 2., .5)
        assert not start.stress.any() and not start.strain.any()
        assert np.array_equal(start.be, np.broadcast_to(
            np.eye(3)[:, :, None], start.be.shape))
    result = simulate(mesh, ElementQuad1(), start, LinearElastic(E, NU),
                      lambda b: b.get_dofs(lambda x: x[1] == 0.).all(),
                      nsteps=1, body_force=BodyForce([0., 0.], ramp=False))
    assert not np.abs(result.history[-1].displacement).any()
    clay = ModifiedCamClay(kappa=.01, lambda_=.1, M=1., shear_modulus=3e3,
                           reference_pressure=100.,
                           preconsolidation_pressure=100.)
    with pytest.raises(InvalidMaterialError, match="compressive mean"):
        geostatic_stress(points, clay, [0., 0.], 2., .5)
    # a surface above the material: no soil's weight is missing (a review
    # found the warning that the stress starts at the weight of 0.5 of
    # soil that is not there, given for a zero stress)
    lower = seed_points(mesh, 2, region=lambda x: x[1] < 1.5)
    with caplog.at_level("WARNING", logger="skfem_mpm"):
        geostatic_stress(lower, LinearElastic(E, NU), [0., 0.], 2., .5)
        geostatic_stress(lower, LinearElastic(E, NU), [0., -1.], 2., .5)
    warned = [r for r in caplog.records
              if "geostatic start" in r.getMessage()]
    assert len(warned) == 1          # the weight's, not the weightless
