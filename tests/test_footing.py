"""Rigid footings in scenes: scene keys, the summary's load-displacement
curve and plot, the bearing-capacity reference and its refusals."""
import json

import meshio
import numpy as np
import pytest

from skfem_mpm import DruckerPrager, MohrCoulomb, ModifiedCamClay, \
    RigidBody, VonMises, simulate
from skfem_mpm.errors import InvalidInputError, SceneError
from skfem_mpm.cli import main
from skfem_mpm.scenes.scene import run_scene
from skfem_mpm.scenes.scene_file import load_scene, parse_scene
from skfem_mpm.scenes.footing import soil_strength
from skfem_mpm.studies.footing import bearing_capacity_factor
from skfem_mpm.studies.study import study

try:
    import tomllib
except ImportError:                       # Python 3.10
    import tomli as tomllib

# a coarse smooth footing on von Mises soil: h = 1/8, yields in 6 steps
FOOTING = """
name = "coarse-footing"
reference = "bearing_capacity"
[grid]
x = [0.0, 1.0, 8]
y = [0.0, 0.625, 5]
[[bodies]]
name = "soil"
region = { x = [0.0, 1.0], y = [0.0, 0.5] }
material = { model = "von_mises", E = 1e4, nu = 0.3, yield_stress = 100.0 }
[[bodies]]
name = "footing"
region = { x = [0.0, 0.25], y = [0.5, 0.625] }
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
rigid = { displacement = [0.0, -0.03], rough = false }
[[supports]]
boundary = "bottom"
[[supports]]
boundary = "left"
components = ["x"]
[[supports]]
boundary = "right"
components = ["x"]
[solver]
steps = 6
antilocking = true
"""


def prandtl_reissner(phi_degrees):
    """N_c from its formula, N_q = e^(pi tan phi) tan^2(45 + phi/2)."""
    t = np.tan(np.radians(phi_degrees))
    nq = np.exp(np.pi * t) * np.tan(np.radians(45 + phi_degrees / 2)) ** 2
    return (nq - 1) / t


def test_bearing_capacity_factor():
    for phi in (5., 20., 30., 40.):
        assert bearing_capacity_factor(phi) == pytest.approx(
            prandtl_reissner(phi), rel=1e-14)
    # continuous into Prandtl's 2 + pi at phi = 0 (N_c - (2 + pi) ~ phi)
    assert bearing_capacity_factor(0.) == 2 + np.pi
    assert abs(bearing_capacity_factor(1e-4) - (2 + np.pi)) < 1e-4


def test_soil_strength_and_its_refusals():
    assert soil_strength(VonMises(1e5, .3, 100.)) == (100 / np.sqrt(3), 0.)
    mc = MohrCoulomb(1e5, .3, cohesion=5., friction_angle=25.,
                     dilation_angle=25.)
    assert soil_strength(mc) == (5., 25.)
    for material, words in [
            (DruckerPrager(1e5, .3, cohesion=5., friction_angle=25.,
                           dilation_angle=25.), "plane_strain"),
            (MohrCoulomb(1e5, .3, cohesion=5., friction_angle=25.),
             "associated"),
            (ModifiedCamClay(.01, .1, 1., 1e3, 100., 100.), "Mohr-Coulomb")]:
        with pytest.raises(InvalidInputError, match=words):
            soil_strength(material)


def test_scene_footing_is_the_python_api_footing():
    scene = parse_scene(tomllib.loads(FOOTING))
    result = run_scene(scene)
    mesh, elem = scene.grid.build()
    from skfem_mpm.scenes.scene import build_points
    points = build_points(scene, mesh)

    def supports(basis):
        return np.concatenate([
            basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
            basis.get_dofs(lambda x: np.isclose(x[0], 0.)
                           | np.isclose(x[0], 1.)).all("u^1")])
    direct = simulate(mesh, elem, points, [b.material for b in scene.bodies],
                      supports, nsteps=6, antilocking=True,
                      rigid_bodies=RigidBody(1, [0., -.03], rough=False))
    a = np.array([r.rigid_forces for r in result.history])
    b = np.array([r.rigid_forces for r in direct.history])
    assert np.array_equal(a, b)
    assert (a[:, 0, 1] < 0).all() and np.abs(a[:, 0, 0]).max() < 1e-8 * \
        np.abs(a).max()                    # smooth: no horizontal force
    assert sum(r.n_yielded for r in result.history) > 0


@pytest.mark.slow
def test_footing_summary_plot_error_and_resume(tmp_path):
    scene = tmp_path / "footing.toml"
    scene.write_text(FOOTING)
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main(["run", str(scene), "--out", str(straight),
                 "--no-progress"]) == 0
    assert main(["run", str(scene), "--out", str(split), "--max-steps", "3",
                 "--no-progress"]) == 0
    assert main(["run", "--resume", str(split), "--no-progress"]) == 0
    a = json.loads((straight / "summary.json").read_text())
    b = json.loads((split / "summary.json").read_text())
    assert a["rigid_bodies"] == b["rigid_bodies"] and a["error"] == b["error"]
    curve = a["rigid_bodies"]["footing"]
    assert np.allclose(np.array(curve["displacement"])[:, 1],
                       -.03 * np.arange(1, 7) / 6, rtol=1e-14)
    assert set(a["reactions"]) == {"support-1", "support-2", "support-3"}
    # the error: peak pressure over the footing's width 0.25 against
    # (2 + pi) c_u with c_u = 100 / sqrt(3)
    pressure = -np.array(curve["force"])[:, 1] / .25
    assert a["error"] == pytest.approx(abs(
        pressure.max() / ((2 + np.pi) * 100 / np.sqrt(3)) - 1), rel=1e-12)
    assert (straight / "rigid_bodies.png").stat().st_size > 10_000
    # the peak resistance and where it was reached, beside the final force
    # (the summary gave only the last before)
    forces = np.array(curve["force"])
    peak = int(np.argmax(-forces[:, 1]))
    assert curve["peak_force"] == forces[peak].tolist()
    assert curve["peak_displacement"] == curve["displacement"][peak]
    assert curve["final_force"] == forces[-1].tolist()
    # the plastic zone and the von Mises stress of the final state drawn
    for name in ("plastic_zone.png", "final_von_mises.png"):
        assert (straight / name).stat().st_size > 10_000, name
    # the yield flag in the VTU: plastic flow in the step, also after the
    # resume; none in the rigid body
    for step in (3, 4, 6):
        a_vtu, b_vtu = (meshio.read(d / "points_{:04d}.vtu".format(step))
                        for d in (straight, split))
        flag = a_vtu.point_data["yielding"]
        assert np.array_equal(flag, b_vtu.point_data["yielding"])
        assert flag.sum() > 0 and not flag[a_vtu.point_data["body"] == 1].any()
    grew = meshio.read(straight / "points_0006.vtu").point_data[
        "equivalent_plastic_strain"] > meshio.read(
            straight / "points_0005.vtu").point_data[
                "equivalent_plastic_strain"]
    assert np.array_equal(grew, flag == 1)
    # the study measures the same error
    rows = study(load_scene(scene), {"loadsteps": [6]}, tmp_path / "study",
                 progress=False)
    assert rows[0]["error"] == pytest.approx(a["error"], rel=1e-12)


@pytest.mark.parametrize("change, words", [
    (("antilocking = true", 'antilocking = false\nmethod = "cpgimp"'),
     "need method 'mpm' or 'fem'"),
    (("displacement = [0.0, -0.03]", "displacement = [0.0, 0.0]"),
     "must not be zero"),
    (("rough = false", 'rough = "no"'), "must be true or false"),
    (('reference = "bearing_capacity"', 'reference = "bearing_capacity"\n'
      '[gravity]\nbody_force = [0.0, -10.0]'), "weightless"),
    (("displacement = [0.0, -0.03]", "displacement = [0.01, -0.03]"),
     "pushed down"),
    (("displacement = [0.0, -0.03]", "displacement = [0.0, 0.03]"),
     "pushed down"),
    (("x = [0.0, 0.25], y = [0.5", "x = [0.0, 0.3], y = [0.5"),
     "between grid lines"),
    (("x = [0.0, 0.25], y = [0.5", "x = [0.0, 1.5], y = [0.5"),
     "body 'footing' reaches outside the grid"),
    (('name = "soil"', 'name = "footing"'), "body names must differ"),
    (('model = "von_mises", E = 1e4, nu = 0.3, yield_stress = 100.0',
      'model = "mohr_coulomb", E = 1e4, nu = 0.3, cohesion = 0.0, '
      'friction_angle = 20.0, dilation_angle = 20.0'), "without cohesion"),
    (('model = "von_mises", E = 1e4, nu = 0.3, yield_stress = 100.0',
      'model = "drucker_prager", E = 1e4, nu = 0.3, cohesion = 5.0, '
      'friction_angle = 20.0'), "plane_strain"),
])
def test_footing_scene_keys_are_checked(change, words):
    parse_scene(tomllib.loads(FOOTING))
    text = FOOTING.replace(*change)
    assert text != FOOTING
    with pytest.raises(SceneError, match=words):
        parse_scene(tomllib.loads(text))


@pytest.mark.slow
def test_a_failed_footing_run_keeps_its_curve(tmp_path):
    """Non-convergence is often the collapse: the summary of a failed run
    still holds the curve of its converged steps, and the plot."""
    scene = tmp_path / "footing.toml"
    scene.write_text(FOOTING.replace("steps = 6", "steps = 6\n"
                                     "max_iterations = 2"))
    assert main(["run", str(scene), "--out", str(tmp_path / "out"),
                 "--no-progress"]) == 1
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["status"] == "failed"
    steps = summary["last_converged_step"]
    assert steps >= 1
    assert len(summary["rigid_bodies"]["footing"]["force"]) == steps
    assert (tmp_path / "out" / "rigid_bodies.png").exists()


# the footing as a smooth box obstacle (contact at the soil's surface, its
# edge on a grid line): half model, the box reaching past the symmetry line
PUNCH = FOOTING.replace('''[[bodies]]
name = "footing"
region = { x = [0.0, 0.25], y = [0.5, 0.625] }
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
rigid = { displacement = [0.0, -0.03], rough = false }
''', '''[[obstacles]]
name = "punch"
box = { x = [-0.5, 0.25], y = [0.5, 1.0] }
displacement = [0.0, -0.03]
''').replace("steps = 6", "steps = 4")


@pytest.mark.slow
def test_a_bearing_capacity_footing_may_be_a_box_obstacle(tmp_path):
    """A trial's smooth punch (a box obstacle reaching past the symmetry
    line) was refused as a footing: 'needs one rigid body'.  Its pressure
    is the material's force on it over its width over the soil (0.25
    here), in the summary's error, the picture and the study alike."""
    assert PUNCH != FOOTING and "rigid" not in PUNCH
    scene = tmp_path / "punch.toml"
    scene.write_text(PUNCH)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out),
                 "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    force = np.array(summary["obstacles"]["punch"]["force"])
    assert force.shape == (4, 2) and (force[:, 1] > 0).all()
    pressure = force[:, 1] / .25
    assert summary["error"] == pytest.approx(abs(
        pressure.max() / ((2 + np.pi) * 100 / np.sqrt(3)) - 1), rel=1e-12)
    for name in ("bearing_capacity.png", "obstacles.png"):
        assert (out / name).stat().st_size > 10_000, name
    rows = study(load_scene(scene), {"loadsteps": [4]}, tmp_path / "study",
                 progress=False)
    assert rows[0]["error"] == pytest.approx(summary["error"], rel=1e-12)


@pytest.mark.parametrize("change, words", [
    (("box = { x = [-0.5, 0.25], y = [0.5, 1.0] }",
      "polygon = [[0.0, 0.5], [0.3, 0.5], [0.3, 1.0], [0.0, 1.0]]"),
     "'punch' as a box"),
    (("displacement = [0.0, -0.03]", "displacement = [0.01, -0.03]"),
     r"one footing pushed down.*obstacle 'punch' \[0.01, -0.03\]"),
    (("displacement = [0.0, -0.03]\n", "displacement = [0.0, -0.03]\n"
      '[[obstacles]]\nname = "second"\nbox = { x = [0.6, 0.8], '
      "y = [0.5, 1.0] }\ndisplacement = [0.0, -0.01]\n"),
     "one footing pushed down.*'punch'.*'second'"),
    (("box = { x = [-0.5, 0.25]", "box = { x = [-0.5, -0.1]"),
     r"over no soil \(x from 0.0 to 1.0\)"),
    (("box = { x = [-0.5, 0.25]", "box = { x = [-0.5, 1.5]"),
     "covers the soil's whole surface"),
])
def test_obstacle_footing_refusals(change, words):
    text = PUNCH.replace(*change)
    assert text != PUNCH
    with pytest.raises(SceneError, match=words):
        parse_scene(tomllib.loads(text))


def test_an_obstacle_footing_s_width_is_over_the_soil():
    """A reviewer's find: the width was the box's part inside the grid, so
    a grid reaching a cell past the soil's symmetry line (x = 0) made the
    same punch 0.5 wide where it presses 0.25 of soil (the error 0.47
    where it is 0.03)."""
    from skfem_mpm.scenes.footing import scene_footing
    shifted = PUNCH.replace("x = [0.0, 1.0, 8]", "x = [-0.25, 1.0, 10]")
    assert shifted != PUNCH
    for text in (PUNCH, shifted):
        assert scene_footing(parse_scene(tomllib.loads(text))).width == .25
