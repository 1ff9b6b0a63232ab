"""What a scene file's errors say (trial 79): the file named on every
line, a misspelt model said alone, a misspelt key's nearest key, a
material's own keys; the study's advice on the ghost penalty."""
from skfem_mpm.cli import main
from skfem_mpm.errors import SceneError
from skfem_mpm.scenes.scene_file import parse_scene
import pytest

SCENE = """
[grid]
x = [0.0, 3.0, 6]
y = [0.0, 1.5, 3]
[[bodies]]
region = {{ x = [0.0, 3.0], y = [0.0, 1.0] }}
material = {{ {} }}
[[supports]]
boundary = "bottom"
[solver]
steps = 1
"""
MC = ('model = "mohr_coulomb", E = 2e4, nu = 0.3, cohesion = 10.0, '
      'friction_angle = 20.0, dilation_angle = 20.0')


def problems(material):
    import tomllib
    with pytest.raises(SceneError) as err:
        parse_scene(tomllib.loads(SCENE.format(material)))
    return err.value.problems


def test_every_line_names_the_file_once(tmp_path, capsys):
    """``bodies[0].material.E: must be > 0.0`` named no file; a TOML
    syntax error, which did, is not named twice."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(MC.replace("2e4", "0.0")))
    assert main(["run", str(scene), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == ["skfem-mpm: {}: bodies[0].material.E: must be > 0.0, "
                   "got 0.0".format(scene)]
    scene.write_text("[grid\n")
    assert main(["run", str(scene), "--out", str(tmp_path / "o")]) == 2
    err, = capsys.readouterr().err.splitlines()
    assert err.startswith("skfem-mpm: {}: not valid TOML".format(scene))


def test_a_misspelt_model_is_said_alone():
    """``model = "mohr-coulomb"`` was followed by three ``not a parameter
    of model = 'linear_elastic'``, a model the file never named."""
    assert problems(MC.replace("mohr_coulomb", "mohr-coulomb")) == [
        "bodies[0].material.model: must be one of linear_elastic, "
        "von_mises, drucker_prager, mohr_coulomb, cam_clay, got "
        "'mohr-coulomb'; did you mean 'mohr_coulomb'?"]
    assert problems(MC.replace('model = "mohr_coulomb", ', "")) == [
        "bodies[0].material.model: missing (one of linear_elastic, "
        "von_mises, drucker_prager, mohr_coulomb, cam_clay)"]
    # not a string (a reviewer's: a list or table raised TypeError, as a
    # dict's key)
    for model in ('["mohr_coulomb"]', "{a = 1}"):
        said, = problems(MC.replace('"mohr_coulomb"', model))
        assert said.startswith("bodies[0].material.model: must be one of "
                               "linear_elastic,")


def test_a_misspelt_key_gets_the_models_own_keys_and_the_nearest():
    """``friction_angel`` listed every model's keys (kappa, lambda,
    yield_stress, ...) and no guess."""
    first, second = problems(MC.replace("friction_angle", "friction_angel"))
    assert first == (
        "bodies[0].material.friction_angel: unknown key (allowed: model, E, "
        "nu, cohesion, friction_angle, dilation_angle), got 20.0; did you "
        "mean 'friction_angle'?")
    assert second == "bodies[0].material.friction_angle: missing " \
        "(mohr_coulomb)"
    # another model's key: said so, with this model's keys
    assert problems(MC + ", yield_stress = 1.0") == [
        "bodies[0].material.yield_stress: not a parameter of model = "
        "'mohr_coulomb' (its keys: model, E, nu, cohesion, friction_angle, "
        "dilation_angle), got 1.0"]
    # no key near: no guess
    colour, = problems(MC + ", colour = 1.0")
    assert colour.endswith("got 1.0")


def test_a_misspelt_reference_is_refused_not_a_traceback():
    """``reference = "colum"`` raised TypeError (None among the choices
    joined)."""
    import tomllib
    data = tomllib.loads('reference = "colum"\n' + SCENE.format(MC))
    with pytest.raises(SceneError) as err:
        parse_scene(data)
    assert err.value.problems == [
        "reference: must be one of column, elastica, bearing_capacity, got "
        "'colum'; did you mean 'column'?"]


def test_mixed_ghost_advice_says_on_not_off():
    """"fix the penalty in the scene" led a user to ghost = 0, where the
    cases that had switched it on failed."""
    from skfem_mpm.studies.study import mixed_stabilisation
    measured = {"convergence": [dict(
        choices={}, cell_sizes=[],
        mixed_stabilisation="12 elements: on from step 16; 48 elements: "
        "never on")]}
    warning, = mixed_stabilisation(measured)
    assert "switch the penalty on in the scene for every case from the " \
        "start ([solver] ghost = 0.001 in small strain, 0.1 in finite " \
        "deformation" in warning
    assert "not off (ghost = 0)" in warning


def test_geostatic_K0_defaults_to_jaky_for_soils():
    """``geostatic = { }`` was refused, ``K0: missing``: of a Mohr-Coulomb
    or Drucker-Prager soil it is Jaky's 1 - sin(phi), 1 - sin(20 deg) =
    0.65798; other models have no friction angle, and are told so."""
    import math
    import tomllib
    text = SCENE.replace("material =", "geostatic = {{ }}\nmaterial =")
    for material in (MC, MC.replace("mohr_coulomb", "drucker_prager")):
        scene = parse_scene(tomllib.loads(text.format(material)))
        assert scene.bodies[0].K0 == pytest.approx(
            1 - math.sin(math.radians(20.)), rel=1e-12)
        assert scene.bodies[0].K0 == pytest.approx(0.65798, abs=1e-5)
    given = text.replace("{{ }}", "{{ K0 = 0.5 }}")
    assert parse_scene(tomllib.loads(given.format(MC))).bodies[0].K0 == .5
    with pytest.raises(SceneError) as err:
        parse_scene(tomllib.loads(text.format(
            'model = "linear_elastic", E = 1e4, nu = 0.3')))
    assert err.value.problems == [
        "bodies[0].geostatic.K0: missing: Jaky's 1 - sin(phi), the default "
        "of mohr_coulomb and drucker_prager soils, needs a friction angle, "
        "which model = 'linear_elastic' has not; an elastic layer under "
        "uniaxial strain has nu / (1 - nu)"]


PUSHED = """
[grid]
x = [0.0, 2.0, 4]
y = [0.0, 1.5, 3]
[[bodies]]
name = "soil"
region = { x = [0.0, 2.0], y = [0.0, 1.0] }
material = { model = "linear_elastic", E = 1e4, nu = 0.3 }
[[supports]]
name = "base"
boundary = "bottom"
[gravity]
body_force = [0.0, -20.0]
%s
[[obstacles]]
name = "footing"
box = { x = [-0.5, 0.5], y = [1.0, 1.5] }
displacement = [0.0, -0.001]
[solver]
steps = 2
"""


def test_gravity_ramped_with_a_push_is_warned_or_in_full(caplog):
    """Without ``geostatic`` the gravity grows with the load factor
    together with an obstacle's push: said once at the start (trial 79's
    footing: 179 kPa at 0.012 m against 200 from a geostatic start);
    ``[gravity] ramp = false`` puts the whole weight, 20 x 2 x 1 = 40,
    on the base from step 1 (half of it ramped)."""
    import logging
    import tomllib
    from skfem_mpm.scenes.scene import reaction_resultants, run_scene
    bases = {}
    for ramp in ("", "ramp = false"):
        scene = parse_scene(tomllib.loads(PUSHED % ramp))
        assert scene.gravity_ramp is (ramp == "")
        caplog.clear()
        with caplog.at_level(logging.WARNING, "skfem_mpm"):
            result = run_scene(scene)
        said = [r.getMessage() for r in caplog.records
                if "grows with the load factor" in r.getMessage()]
        assert len(said) == (1 if ramp == "" else 0)
        names, resultant = reaction_resultants(scene)
        first = result.history[0]
        base = resultant(first)[names.index("base")][1]
        footing = resultant(first)[names.index("footing")][1]
        bases[ramp] = base - footing       # the base carries the push too
    assert said == [] and bases["ramp = false"] == pytest.approx(40., 1e-6)
    assert bases[""] == pytest.approx(20., rel=1e-6)
    with pytest.raises(SceneError, match="gravity.ramp: must be true or"):
        parse_scene(tomllib.loads(PUSHED % 'ramp = "no"'))
