"""Scenes, scene files, the command line and its output."""
import json
from pathlib import Path

import meshio
import numpy as np
import pytest

from skfem_mpm import LinearElastic, VonMises
from skfem_mpm.errors import InvalidInputError, SceneError
from skfem_mpm.cli import main
from skfem_mpm.scenes.scene import (Body, Grid, PointLoad, Scene, Support,
                                   build_points, run_scene)
from skfem_mpm.scenes.scene_file import load_scene

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def block(method="mpm", kinematics="small", material=None, gravity=None,
          steps=3):
    return Scene(grid=Grid([(0., 4., 4), (0., 3., 3)]),
                 bodies=[Body("block", [(0., 2.), (0., 2.)],
                              material or LinearElastic(1e4, .3))],
                 supports=[Support(boundary="bottom")], gravity=gravity,
                 point_loads=[PointLoad(at=[2., 2.], force=[10., -50.])],
                 method=method, kinematics=kinematics, nsteps=steps)


def test_effect_gating():
    # elastic, small strain, no gravity: no body force, one solve per step,
    # no return map, no Newton iteration
    counters = run_scene(block()).counters
    assert counters == {"locate": 4, "body_force": 0, "linear_solves": 3,
                        "return_maps": 0, "newton_iterations": 0,
                        "line_search_trials": 0,
                        "stabilised_solves": 0, "ghost_from_step": 0,
                        "line_search_from_step": 0, "factorisations": 3}
    # FE mode never relocates the points
    fem = run_scene(block(method="fem"))
    assert fem.counters["locate"] == 1
    assert (fem.points.x == fem.points.x0).all()
    # gravity is assembled once per step only when asked for
    assert run_scene(block(gravity=[0., -1.])).counters["body_force"] == 3
    # finite deformation of an elastic body: Newton, still no return map
    finite = run_scene(block(method="cpgimp", kinematics="finite")).counters
    assert finite["return_maps"] == 0 and finite["newton_iterations"] >= 3
    plastic = run_scene(block(method="mpm", kinematics="finite",
                              material=VonMises(1e4, .3, 1e3))).counters
    assert plastic["return_maps"] > 0


def test_two_bodies_with_their_own_materials():
    """A stiff body on a soft one under a point load: the soft one takes
    the strain, equilibrium holds."""
    scene = Scene(grid=Grid([(0., 2., 2), (0., 4., 4)]),
                  bodies=[Body("soft", [(0., 2.), (0., 2.)],
                               LinearElastic(1e3, .3)),
                          Body("stiff", [(0., 2.), (2., 4.)],
                               LinearElastic(1e6, .3))],
                  supports=[Support(boundary="bottom")],
                  point_loads=[PointLoad(at=[1., 4.], force=[0., -10.],
                                         count=4)])
    res = run_scene(scene)
    pts = res.points
    strain = np.abs(pts.strain[1, 1])
    assert strain[pts.body == 0].mean() > 100 * strain[pts.body == 1].mean()
    assert res.history[-1].residual < 1e-10


@pytest.mark.slow
@pytest.mark.parametrize("name, steps", [("column", 5), ("cantilever", 5),
                                         ("collapse", 8), ("block3d", 2)])
def test_shipped_scene_files_run_from_the_cli(name, steps, tmp_path, capsys):
    out = tmp_path / name
    assert main(["run", str(EXAMPLES / (name + ".toml")), "--out", str(out),
                 "--steps", str(steps), "--no-progress"]) == 0
    assert "load steps" in capsys.readouterr().out
    pvd = (out / "points.pvd").read_text()
    assert pvd.count("<DataSet") == steps + 1          # the start and steps
    assert '<DataSet timestep="0.0" file="points_0000.vtu"/>' in pvd
    cloud = meshio.read(out / "points_{:04d}.vtu".format(steps))
    for field in ("stress", "displacement", "volume", "F", "von_mises",
                  "body"):
        assert field in cloud.point_data
    assert np.isfinite(cloud.point_data["stress"]).all()
    start = meshio.read(out / "points_0000.vtu")
    assert not start.point_data["displacement"].any()
    assert np.array_equal(start.point_data["initial_position"],
                          cloud.point_data["initial_position"])
    grid = meshio.read(out / "grid_{:04d}.vtu".format(steps))
    assert len(grid.cells[0]) > 0
    assert set(grid.point_data) == {"displacement_increment", "reaction"}
    assert json.loads((out / "summary.json").read_text())["bodies"] == [
        b.name for b in load_scene(EXAMPLES / (name + ".toml")).bodies]
    # the reactions on the grid sum to the supports' resultants
    summary = json.loads((out / "summary.json").read_text())
    dim = load_scene(EXAMPLES / (name + ".toml")).grid.dim
    total = sum(np.array(r[-1]) for r in summary["reactions"].values())
    assert np.allclose(grid.point_data["reaction"].sum(axis=0)[:dim],
                       total, rtol=1e-12, atol=1e-9 * np.abs(total).max())
    assert (out / "summary.json").exists()
    assert (out / "final_stress.png").stat().st_size > 5000


def test_default_run_prints_and_plots(tmp_path, capsys):
    assert main(["run", "--out", str(tmp_path), "--no-progress"]) == 0
    out = capsys.readouterr().out
    error = float(out.split("error measure (2.28) of Charlton (2018)")[1]
                  .split()[0])
    assert 1e-2 < error < 5e-2          # 20 elements, 20 steps: plateau
    assert (tmp_path / "column_stress.png").stat().st_size > 10_000


BAD = """
name = 3
[grid]
x = [0.0, 1.0, 0]
colour = "red"
[[bodies]]
region = { x = [0.0, 1.0] }
points_per_cell = 0
material = { model = "linear_elastic", E = -1.0, nu = 0.5 }
[solver]
steps = "many"
"""


def test_bad_scene_files_exit_2_and_write_nothing(tmp_path, capsys):
    scene = tmp_path / "bad.toml"
    scene.write_text(BAD)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 7
    for text in ("grid.x: must be [lo, hi, cells]",
                 "grid.colour: unknown key", "points_per_cell: must be >= 1",
                 "material.E: must be > 0.0, got -1.0",
                 "material.nu: must be < 0.5, got 0.5",
                 "solver.steps: must be an integer, got 'many'",
                 "name: must be a string"):
        assert any(text in line for line in err), text
    assert not out.exists()
    scene.write_text("[grid\nx = 1")
    assert main(["run", str(scene), "--out", str(out)]) == 2
    assert "not valid TOML" in capsys.readouterr().err
    assert main(["run", str(tmp_path / "missing.toml")]) == 2


def test_supports_on_regions(tmp_path):
    """A support on the grid nodes in a closed box (lo = hi: a grid line):
    the nodes inside, components as asked; an inverted box, a box with
    boundary or at too, and a box without grid nodes are refused."""
    from skfem import Basis, ElementQuad1, ElementVector, MeshQuad
    from skfem_mpm.scenes.scene import scene_support_dofs
    from skfem_mpm.scenes.scene_file import parse_scene
    from skfem_mpm.errors import InvalidInputError
    data = {"grid": {"x": [0., 1., 4], "y": [0., 1., 4]},
            "bodies": [{"region": {"y": [0., .5]}, "material": {
                "model": "linear_elastic", "E": 1., "nu": .3}}],
            "supports": [{"region": {"x": [0., .5], "y": [.5, .5]},
                          "components": ["y"]}]}
    scene = parse_scene(data)
    basis = Basis(MeshQuad.init_tensor(*[np.linspace(0, 1, 5)] * 2),
                  ElementVector(ElementQuad1()))
    dofs = scene_support_dofs(scene.supports[0], basis, 2).ravel()
    assert np.allclose(basis.doflocs[1, dofs], .5)
    assert sorted(basis.doflocs[0, dofs]) == [0., .25, .5]
    assert np.all(dofs % 2 == 1)
    with pytest.raises(SceneError, match="names no axis"):
        parse_scene({**data, "supports": [{"region": {}}]})
    # a value per component held, and the message says so (trial 62: "a
    # list of 1 finite numbers" for a value of two with components y)
    with pytest.raises(SceneError, match=r"value: must be a list of 1 "
                       r"finite numbers, one per component held \(y\)"):
        parse_scene({**data, "supports": [{**data["supports"][0],
                                           "value": [0., -.015]}]})
    with pytest.raises(InvalidInputError, match="one \\[lo, hi\\]"):
        scene_support_dofs(Support(region=[(0., .5)]), basis, 2)
    for bad, message in (({"x": [.5, 0.]}, "lo <= hi"),
                         ({"x": [0., .5], "boundary": "left"},
                          "exactly one of boundary, at, region")):
        support = {"region": {"x": bad.pop("x")}, **bad}
        with pytest.raises(SceneError, match=message):
            parse_scene({**data, "supports": [support]})
    # a box without grid nodes: refused by the scene file (trial 98,
    # naming the table and the nearest lines) and from Python
    with pytest.raises(SceneError, match=r"supports\[0\]\.region: support "
                       r"holds no grid node \(x = \[0.1, 0.2\] lies "
                       r"between the grid lines x = 0.0 and x = 0.25; y "):
        parse_scene({**data, "supports": [
            {"region": {"x": [.1, .2], "y": [.1, .2]}}]})
    with pytest.raises(InvalidInputError, match=r"no grid node there \(x "
                       r"= \[0.1, 0.2\] lies between the grid lines x = "
                       r"0.0 and x = 0.25; y "):
        scene_support_dofs(Support(region=[(.1, .2), (.1, .2)]), basis, 2)


def test_a_support_on_a_list_of_sides_holds_their_union():
    """Trial 70: ``boundary = ["left", "right"]`` was refused as not a
    side's name.  A list holds the union of its sides (a corner node
    once; 3D words refused in each), each name checked as one is, and a
    side listed twice (in either spelling) or an empty list refused."""
    from skfem import Basis, ElementQuad1, ElementVector, MeshQuad
    from skfem_mpm.cli import support_marks
    from skfem_mpm.scenes.scene import scene_support_dofs
    from skfem_mpm.scenes.scene_file import parse_scene
    data = {"grid": {"x": [0., 1., 4], "y": [0., 1., 4]},
            "bodies": [{"region": {"y": [0., .5]}, "material": {
                "model": "linear_elastic", "E": 1., "nu": .3}}],
            "supports": [{"boundary": ["left", "y-"],
                          "components": ["x"], "name": "walls"}]}
    scene = parse_scene(data)
    assert scene.supports[0].boundary == ["left", "y-"]
    basis = Basis(MeshQuad.init_tensor(*[np.linspace(0, 1, 5)] * 2),
                  ElementVector(ElementQuad1()))
    dofs = scene_support_dofs(scene.supports[0], basis, 2).ravel()
    x, y = basis.doflocs[:, dofs]
    assert dofs.size == 9 == np.unique(dofs).size and np.all(dofs % 2 == 0)
    assert np.all((x == 0.) | (y == 0.))
    alone = [scene_support_dofs(Support(boundary=side, components=["x"]),
                                basis, 2).ravel() for side in ("x-", "y-")]
    assert set(dofs) == set(np.concatenate(alone))
    assert parse_scene({**data, "supports": [{"boundary": ["top"]}]}
                       ).supports[0].boundary == "top"
    mesh = MeshQuad.init_tensor(*[np.linspace(0, 1, 5)] * 2)
    assert support_marks(scene, mesh, ElementQuad1())[0].label.startswith(
        "walls (left + y-): x fixed")
    for sides, message in (
            (["left", "x-"], r"boundary: names a side twice \('left' and "
             r"'x-'\): list each side once"),
            (["top", "top"], r"names a side twice \('top'\)"),
            (["left", "north"], r"boundary\[1\]: must be one of left"),
            ([], "boundary: names no side"),
            ("north", "boundary: must be one of left")):
        with pytest.raises(SceneError, match=message):
            parse_scene({**data, "supports": [{"boundary": sides}]})
    data3 = {**data, "grid": {**data["grid"], "z": [0., 1., 4]},
             "bodies": [{"region": {"y": [0., .5]}, "material": {
                 "model": "linear_elastic", "E": 1., "nu": .3}}]}
    with pytest.raises(SceneError, match=r"boundary\[1\]: in 3D the side "
                       "'top'"):
        parse_scene({**data3, "supports": [{"boundary": ["x-", "top"]}]})


def test_hostile_scene_files_and_folders_get_one_line(tmp_path, capsys,
                                                     monkeypatch):
    """UTF-16, nesting beyond any scene, a FIFO, /dev/zero, --out that is
    a file, a support outside the grid (refused in the first step), a full
    disk: one line on stderr, never a traceback; what is refused writes
    nothing."""
    import os
    column = (EXAMPLES / "column.toml").read_text()
    cases = {"utf16.toml": column.encode("utf-16"),
             "nested.toml": b"a = " + b"[" * 100000 + b"]" * 100000}
    out = tmp_path / "out"
    for name, raw in cases.items():
        (tmp_path / name).write_bytes(raw)
        assert main(["run", str(tmp_path / name), "--out", str(out)]) == 2
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for scene in (fifo, "/dev/zero"):
        assert main(["run", str(scene), "--out", str(out)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert [e.split(": ", 2)[-1][:20] for e in err] == [
        "not UTF-8 text as TO", "nested too deeply to",
        "not a regular file", "not a regular file"]
    assert not out.exists()
    (tmp_path / "afile").write_text("")
    assert main(["run", "--out", str(tmp_path / "afile")]) == 2
    assert "is not a folder" in capsys.readouterr().err
    away = column + '\n[[supports]]\nat = [5.0, 5.0]\n'
    (tmp_path / "away.toml").write_text(away)
    assert main(["run", str(tmp_path / "away.toml"), "--out", str(out),
                 "--no-progress"]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
    assert not out.exists()

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr("meshio.write", full_disk)
    assert main(["run", "--out", str(out), "--no-progress"]) == 1
    assert capsys.readouterr().err.strip().splitlines() == [
        "skfem-mpm: OSError: [Errno 28] No space left on device"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and "No space" in summary["error"]


@pytest.mark.slow
def test_resume_is_bit_identical(tmp_path):
    scene = str(EXAMPLES / "column.toml")
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main(["run", scene, "--out", str(straight), "--steps", "8",
                 "--no-progress"]) == 0
    assert main(["run", scene, "--out", str(split), "--steps", "8",
                 "--checkpoint-every", "3", "--max-steps", "4",
                 "--no-progress"]) == 0
    assert json.loads((split / "summary.json").read_text())["status"] \
        == "stopped"
    assert main(["run", "--resume", str(split), "--no-progress"]) == 0
    a = meshio.read(straight / "points_0008.vtu")
    b = meshio.read(split / "points_0008.vtu")
    assert np.array_equal(a.points, b.points)
    for field in ("stress", "F", "volume", "domain"):
        assert np.array_equal(a.point_data[field], b.point_data[field])
    assert (split / "points.pvd").read_text() == \
        (straight / "points.pvd").read_text()          # 0 to 8, both


def test_compare_draws_fe_and_mpm(tmp_path, capsys):
    assert main(["compare", str(EXAMPLES / "block3d.toml"), "--out",
                 str(tmp_path), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "fem" in out and "mpm" in out
    assert (tmp_path / "compare.png").stat().st_size > 10_000
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["methods"] == ["fem", "mpm"]
    for name in ("fem", "mpm"):
        assert meshio.read(tmp_path / (name + ".vtu")).points.shape[1] == 3


@pytest.mark.parametrize("kinematics", [
    "small", pytest.param("finite", marks=pytest.mark.slow)])
def test_compare_is_like_with_like(kinematics, tmp_path):
    """In one load step MPM's points have not moved when the step is
    solved: FE and MPM are the same computation, in either kinematics, and
    ``compare`` reports a difference at round-off (1e-10 relative); over
    several steps it reports the (non-zero) grid-crossing difference."""
    text = COMBINATION.format(
        material='{ model = "von_mises", E = 1e4, nu = 0.3, '
                 'yield_stress = 20.0 }', method="mpm", kinematics=kinematics,
        ghost=0., antilocking="false", load="traction = [2.0, -10.0]")
    path = tmp_path / "scene.toml"
    for steps, small in ((1, True), (3, False)):
        path.write_text(text.replace("steps = 2", "steps = {}".format(steps)))
        out = tmp_path / str(steps)
        assert main(["compare", str(path), "--out", str(out)]) == 0
        summary = json.loads((out / "summary.json").read_text())
        assert summary["kinematics"] == kinematics
        assert all(run["kinematics"] == kinematics
                   for run in summary["runs"].values())
        relative = summary["difference"]["displacement"]["max_relative"]
        assert (relative < 1e-10) == small, relative


def test_scene_files_load():
    for path in EXAMPLES.glob("*.toml"):
        assert load_scene(path).step_count >= 1


def test_help_and_bad_options(capsys):
    assert main(["--help"]) == 0
    assert "skfem-mpm run --resume DIR" in capsys.readouterr().out
    assert main(["run", "--checkpoint-every", "-1"]) == 2
    assert "--checkpoint-every must be >= 0" in capsys.readouterr().err
    assert main(["frobnicate"]) == 2


@pytest.mark.parametrize("kinematics, method, steps", [
    ("small", "mpm", 4), ("finite", "mpm", 4), ("finite", "cpgimp", 1)])
def test_prescribed_support_values(kinematics, method, steps):
    """A bar pulled at its end by a prescribed displacement of 0.1.  The
    grid is reset every step, so each of n steps stretches the material by
    1 + 0.1/(10 n) about the fixed end: the stretch is (1 + 0.01/n)**n.
    (With GIMP over several steps the end points' domains would reach into
    the empty cell beyond the pulled nodes, hence one step there.)"""
    scene = Scene(grid=Grid([(0., 12., 6), (0., 1., 1)]),
                  bodies=[Body("bar", [(0., 10.), (0., 1.)],
                               LinearElastic(1e3, 0.))],
                  supports=[Support(boundary="left", components=["x"]),
                            Support(boundary="bottom", components=["y"]),
                            Support(where=lambda x: np.isclose(x[0], 10.),
                                    components=["x"], value=[.1])],
                  method=method, kinematics=kinematics, nsteps=steps)
    pts = run_scene(scene).points
    stretch = (1 + .01 / steps) ** steps
    np.testing.assert_allclose(pts.displacement[0], (stretch - 1) * pts.x0[0],
                               rtol=1e-10, atol=1e-12)
    if kinematics == "small":          # strain increments of 0.01 / n
        np.testing.assert_allclose(pts.stress[0, 0], 10., rtol=1e-10)
    else:                              # Hencky: sigma = E ln(stretch) / J
        np.testing.assert_allclose(pts.stress[0, 0], 1e3 * np.log(stretch)
                                   / stretch, rtol=1e-10)


def test_point_load_by_predicate():
    scene = block()
    scene.point_loads = [PointLoad(where=lambda x: x[1] > 1.5,
                                   force=[0., -8.])]
    res = run_scene(scene)
    assert res.points.force[1].sum() == pytest.approx(-8.)
    assert (res.points.force[1][res.points.x0[1] < 1.5] == 0).all()


def test_antilocking_from_a_scene_file(tmp_path, capsys):
    scene = tmp_path / "soft.toml"
    scene.write_text("""
[grid]
x = [0.0, 4.0, 8]
y = [-1.0, 1.0, 4]
[[bodies]]
region = { x = [0.0, 4.0], y = [0.0, 1.0] }
material = { model = "linear_elastic", E = 1e3, nu = 0.499 }
[[supports]]
boundary = "left"
[gravity]
body_force = [0.0, -1.0]
[solver]
antilocking = true
""")
    assert load_scene(scene).stabilisation.antilocking
    assert main(["run", str(scene), "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 0
    scene.write_text(scene.read_text().replace("antilocking = true",
                                               "antilocking = 1"))
    assert main(["run", str(scene), "--out", str(tmp_path / "p")]) == 2
    assert 'solver.antilocking: must be true, false or "fbar"' in \
        capsys.readouterr().err
    # F-bar on the increment: finite deformation with moving points only
    scene.write_text(scene.read_text().replace(
        "antilocking = 1", 'antilocking = "fbar"'))
    assert main(["run", str(scene), "--out", str(tmp_path / "q")]) == 2
    assert "antilocking='fbar' (F-bar on each step's increment) is for " \
        "finite deformation" in capsys.readouterr().err
    scene.write_text(scene.read_text() + 'kinematics = "finite"\n')
    assert load_scene(scene).stabilisation.antilocking == "fbar"
    # compare's FE takes mean dilatation (it refused the scene); a study
    # over methods with fem is refused up front (each fem case failed)
    capsys.readouterr()
    assert main(["compare", str(scene), "--out", str(tmp_path / "c")]) == 0
    assert "FE takes mean dilatation (antilocking = true) where the " \
        "scene's mpm takes F-bar on the increment" in capsys.readouterr().out
    from skfem_mpm.studies.study import check_vary
    with pytest.raises(InvalidInputError, match="cannot vary method: the "
                       "scene refuses method='fem': antilocking='fbar'"):
        check_vary({"method": ["mpm", "fem"]}, load_scene(scene))


@pytest.mark.slow
def test_kernels_from_a_scene_file(tmp_path, capsys):
    """``solver.kernels`` picks the per-point path: a plastic block in
    finite deformation with mean dilatation runs the same on the compiled
    passes as on the numpy path (to round-off); a value not among the
    choices is refused naming the key; ``"compiled"`` for a scene the
    passes do not serve (a 1D grid) is refused when its run is set up."""
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    pytest.importorskip("numba")
    text = COMBINATION.format(
        material='{ model = "von_mises", E = 1e4, nu = 0.3, '
                 'yield_stress = 20.0 }', method="cpgimp",
        kinematics="finite", ghost=0., antilocking="true",
        load="traction = [2.0, -10.0]")
    assert parse_scene(tomllib.loads(text)).kernels == "auto"
    runs = {}
    for kernels in ("numpy", "compiled"):
        scene = parse_scene(tomllib.loads(text + 'kernels = "{}"\n'.format(
            kernels)))
        assert scene.kernels == kernels
        runs[kernels] = run_scene(scene)
    assert runs["numpy"].history[-1].n_yielded > 0
    assert np.abs(runs["compiled"].points.stress - runs["numpy"].points.stress
                  ).max() < 1e-12 * np.abs(runs["numpy"].points.stress).max()
    path = tmp_path / "fast.toml"
    path.write_text(text + 'kernels = "fast"\n')
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "solver.kernels: must be one of auto, numpy, compiled, got " \
        "'fast'" in capsys.readouterr().err
    line = parse_scene(tomllib.loads("""
[grid]
x = [0.0, 4.0, 4]
[[bodies]]
region = { x = [0.0, 2.0] }
material = { model = "linear_elastic", E = 1e4, nu = 0.0 }
[[supports]]
boundary = "left"
[gravity]
body_force = [-1.0]
[solver]
kernels = "compiled"
"""))
    with pytest.raises(InvalidInputError, match="do not serve 1D grids"):
        run_scene(line)


COMBINATION = """
name = "combination"
[grid]
x = [0.0, 3.0, 6]
y = [0.0, 2.0, 4]
[[bodies]]
name = "block"
region = {{ x = [0.0, 2.0], y = [0.0, 1.25] }}
material = {material}
[[supports]]
name = "base"
boundary = "bottom"
[gravity]
body_force = [0.0, -20.0]
[[tractions]]
body = "block"
side = "top"
{load}
[solver]
method = "{method}"
kinematics = "{kinematics}"
steps = 2
ghost = {ghost}
antilocking = {antilocking}
"""

SCENE_MATRIX = [(m, k, p, s) for m in ("fem", "mpm", "ugimp", "cpgimp")
                for k in ("small", "finite") for p in (False, True)
                for s in ("none", "ghost", "antilocking")]


def matrix_params(matrix):
    """The combinations as test parameters: the diagonal of the levels
    (the i-th case takes every factor's level i, cyclically), so every
    level of every factor, in the fast suite, the others behind the slow
    marker (the 48 took 70 s of the fast suite's 198 on a slow hour, a
    quarter of them 19 s of 181; ``.ci/run`` runs both)."""
    levels = [sorted(set(column), key=column.index)
              for column in zip(*matrix)]
    diagonal = {tuple(level[i % len(level)] for level in levels)
                for i in range(max(map(len, levels)))}
    return [pytest.param(*case, marks=() if case in diagonal
                         else pytest.mark.slow) for case in matrix]


@pytest.mark.parametrize("method, kinematics, plastic, stabilisation",
                         matrix_params(SCENE_MATRIX))
def test_every_combination_runs_from_a_scene_file(method, kinematics, plastic,
                                                  stabilisation, tmp_path):
    """Method x kinematics x material x stabilisation from a scene file:
    each runs (the weight and the traction ramped over two steps), the
    reactions of the support named ``base`` balance the loads (to 1e-10 of
    their size in linear steps, to 1e-8 after Newton iterations stopped at
    the tolerance 1e-9), return maps run iff the body is plastic (mean
    dilatation with GIMP too)."""
    material = ('{ model = "von_mises", E = 1e4, nu = 0.3, '
                'yield_stress = 20.0 }' if plastic else
                '{ model = "linear_elastic", E = 1e4, nu = 0.3 }')
    text = COMBINATION.format(
        material=material, method=method, kinematics=kinematics,
        ghost=.1 if stabilisation == "ghost" else 0.,
        antilocking=str(stabilisation == "antilocking").lower(),
        load="traction = [2.0, -10.0]")
    path = tmp_path / "scene.toml"
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-progress",
                 "--no-series"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["steps_run"] == 2
    assert summary["max_residual"] <= 1e-9
    assert summary["units"]["max_displacement"] == "m"
    assert summary["units"]["reactions"] == "N/m"
    assert (summary["counters"]["return_maps"] > 0) == plastic
    weight = 20. * 2. * 1.25                # body force per initial volume
    # linear steps balance to round-off; Newton steps to the residual left
    # on the free DOFs (1e-9 of the load each, summed over the DOFs)
    linear = kinematics == "small" and not plastic
    for factor, reaction in zip((.5, 1.), summary["reactions"]["base"]):
        applied = factor * np.array([2. * 2., -weight - 10. * 2.])
        assert np.abs(np.array(reaction) + applied).max() < (
            1e-10 if linear else 1e-8) * weight


def test_pressure_from_a_scene_file_is_the_traction_in_small_strain(tmp_path):
    """``pressure = p`` on the top equals ``traction = [0, -p]`` in small
    strain, to round-off; unnamed supports are ``support-N``."""
    stresses = []
    for load in ("pressure = 10.0", "traction = [0.0, -10.0]"):
        path = tmp_path / "scene.toml"
        path.write_text(COMBINATION.format(
            material='{ model = "linear_elastic", E = 1e4, nu = 0.3 }',
            method="mpm", kinematics="small", ghost=0., antilocking="false",
            load=load).replace('name = "base"\n', ""))
        result = run_scene(load_scene(path))
        stresses.append(result.points.stress)
    assert np.abs(stresses[0] - stresses[1]).max() < 1e-12 * np.abs(
        stresses[1]).max()
    from skfem_mpm.cli import summarise
    assert list(summarise(load_scene(path), result, 0.)["reactions"]) == \
        ["support-1"]
    path.write_text(path.read_text().replace("traction = [0.0, -10.0]",
                                             "traction = [0.0, -10.0]\n"
                                             "pressure = 1.0"))
    with pytest.raises(SceneError, match="exactly one of traction, pressure"):
        load_scene(path)


def test_output_files_are_readable_by_the_group(tmp_path):
    """Files written atomically take the mode of any new file (0o644 under
    the usual umask 022), not the temporary's owner-only 0o600."""
    import os
    mask = os.umask(0o022)
    try:
        out = tmp_path / "out"
        assert main(["run", "--out", str(out), "--no-progress",
                     "--checkpoint-every", "5"]) == 0
        for name in ("summary.json", "points.pvd", "points_0001.vtu",
                     "final_stress.png"):
            assert (out / name).stat().st_mode & 0o777 == 0o644, name
    finally:
        os.umask(mask)


@pytest.mark.slow
def test_a_new_run_clears_an_earlier_runs_files(tmp_path, caplog):
    """Run into a folder an earlier run wrote: its series files, checkpoint
    and figures are removed first (a 4-step run's points_0004.vtu would
    otherwise sit beside a 2-step run's series), with a warning naming
    them; files the package does not write are kept."""
    import logging
    out = tmp_path / "out"
    assert main(["run", "--out", str(out), "--no-progress", "--steps", "4",
                 "--checkpoint-every", "1", "--max-steps", "3"]) == 0
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert (out / "points_0004.vtu").exists()
    (out / "notes.txt").write_text("mine")
    with caplog.at_level(logging.WARNING):
        assert main(["run", "--out", str(out), "--no-progress", "--steps",
                     "2"]) == 0
    assert not (out / "points_0004.vtu").exists()
    assert not (out / "checkpoint.npz").exists()
    assert (out / "points_0002.vtu").exists()
    assert (out / "notes.txt").read_text() == "mine"
    assert "earlier run" in caplog.text and "checkpoint.npz" in caplog.text
    assert (out / "points.pvd").read_text().count("<DataSet") == 3


@pytest.mark.slow
def test_ctrl_c_keeps_a_checkpoint_and_one_line(tmp_path, capsys,
                                                monkeypatch):
    """Ctrl-C (KeyboardInterrupt) after step 2 of 4: exit code 130, one
    line on stderr naming the resume command, summary.json with status
    'interrupted', a checkpoint of step 2; resumed, the run ends where an
    uninterrupted one does, bit for bit."""
    import json
    import meshio
    import skfem_mpm.cli as cli_module
    real = cli_module.run_scene

    def interrupted(scene, points=None, resume=None, callback=None,
                    **kwargs):
        def stop_after_two(record, pts):
            callback(record, pts)
            if record.step == 2:
                raise KeyboardInterrupt
        return real(scene, points, resume=resume, callback=stop_after_two,
                    **kwargs)
    out, whole = tmp_path / "out", tmp_path / "whole"
    monkeypatch.setattr(cli_module, "run_scene", interrupted)
    assert main(["run", "--out", str(out), "--no-progress", "--steps",
                 "4"]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--resume {}".format(out) in err[0]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert summary["last_converged_step"] == 2 and summary["checkpoint"]
    monkeypatch.setattr(cli_module, "run_scene", real)
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert main(["run", "--out", str(whole), "--no-progress", "--steps",
                 "4"]) == 0
    a, b = (meshio.read(d / "points_0004.vtu") for d in (out, whole))
    assert np.array_equal(a.points, b.points)
    assert np.array_equal(a.point_data["stress"], b.point_data["stress"])


def test_outputs_are_reported_and_bad_ones_refused(tmp_path, capsys):
    """``[[outputs]]`` of a scene file reach ``summary.json`` and the
    terminal with their units: on the 1D column the reaction of the base
    is the weight rho g H and the top settles by about rho g H^2 / (2 E);
    a quantity the scene cannot give is refused before any work, naming
    it."""
    from skfem_mpm.cli import EMBEDDED
    text = EMBEDDED.read_text() + """
[[outputs]]
name = "top settlement"
quantity = "displacement"
component = "x"
at = [50.0]
[[outputs]]
quantity = "reaction"
component = "x"
support = "support-1"
[[outputs]]
quantity = "stress"
component = "xx"
region = { x = [0.0, 10.0] }
reduce = "min"
"""
    path = tmp_path / "column.toml"
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-progress",
                 "--no-series"]) == 0
    printed = capsys.readouterr().out
    assert "top settlement" in printed and "N/m^2" in printed
    outputs = json.loads((out / "summary.json").read_text())["outputs"]
    weight = 800. * 50.
    assert abs(outputs["reaction x of support-1"]["value"] - weight) < \
        1e-9 * weight
    settlement = -800. * 50. ** 2 / (2 * 1e6)
    assert abs(outputs["top settlement"]["value"] / settlement - 1) < 1e-2
    assert outputs["top settlement"]["unit"] == "m"
    stress = outputs["min stress xx over [0..10]"]
    assert stress["unit"] == "Pa" and stress["value"] < -.9 * weight
    for bad, message in (
            ('quantity = "reaction"\ncomponent = "x"\nsupport = "base"',
             "no support 'base'"),
            ('quantity = "stress"\ncomponent = "yy"', "no 'yy' component"),
            ('quantity = "speed"\ncomponent = "x"', "quantity must be one"),
            ('quantity = "displacement"\ncomponent = "x"\ncolour = 1',
             "unknown key colour"),
            ('quantity = "displacement"\ncomponent = "x"\nat = [50.0]\n'
             'reduce = "max"', "nothing to reduce"),
            ('quantity = "reaction"\ncomponent = "x"\nsupport = '
             '"support-1"\nreduce = "max"', "takes no 'reduce'"),
            ('quantity = "stress"\ncomponent = "xx"\nbody = "soil"',
             "no body 'soil'")):
        path.write_text(EMBEDDED.read_text() + "\n[[outputs]]\n" + bad)
        assert main(["run", str(path), "--out", str(tmp_path / "no")]) == 2
        assert message in capsys.readouterr().err, message
    path.write_text(EMBEDDED.read_text() + '\n[[outputs]]\nquantity = '
                    '"displacement"\ncomponent = "x"\nat = [51.0]\n')
    assert main(["run", str(path), "--out", str(tmp_path / "no")]) == 2
    assert "[51.0] lies outside the points (initial positions [0.625] to " \
        "[49.375])" in capsys.readouterr().err
    assert not (tmp_path / "no" / "summary.json").exists()


def test_progress_bar_shows_elapsed_and_remaining_time():
    """Half the load in 10 s: 10 s elapsed, 10 s left; resumed at 0.5, a
    quarter more in 5 s: 5 s left."""
    import io
    from types import SimpleNamespace
    from skfem_mpm.cli import Progress
    now = [0.]
    stream = io.StringIO()
    bar = Progress(4, "always", stream=stream, timer=lambda: now[0])
    now[0] = 10.
    bar(SimpleNamespace(step=2, load_factor=.5, newton_iterations=1,
                        residual=1e-12))
    assert "step    2/4" in stream.getvalue()
    assert "newton 1" in stream.getvalue()
    assert stream.getvalue().endswith("elapsed 0:10 left 0:10")
    resumed = Progress(4, "always", start_factor=.5, stream=stream,
                       timer=lambda: now[0])
    now[0] = 15.
    resumed(SimpleNamespace(step=3, load_factor=.75, newton_iterations=None,
                            residual=0.))
    assert stream.getvalue().endswith("elapsed 0:05 left 0:05")


def test_progress_to_a_log_file_is_a_line_every_interval():
    """Not a terminal (a log file; a trial's 3D run redirected to one
    showed no progress in its 31 s): no bar redrawn in place, a line at
    most every LINE_INTERVAL seconds and one at the end of a run that
    wrote one; a run shorter than the interval writes its last line
    only (the README promises one at the end; a trial's log had none),
    and one stopped early the last step it did."""
    import io
    from types import SimpleNamespace
    from skfem_mpm.cli import LINE_INTERVAL, Progress
    now = [0.]
    stream = io.StringIO()
    log = Progress(4, True, stream=stream, timer=lambda: now[0])
    for step, at in zip((1, 2, 3, 4), (.4, 1.1, 1.2, 1.3)):
        now[0] = at * LINE_INTERVAL
        log(SimpleNamespace(step=step, load_factor=step / 4,
                            newton_iterations=2, residual=1e-12))
    lines = stream.getvalue().split("\n")
    assert "\r" not in stream.getvalue() and lines[-1] == ""
    assert [line.split("/")[0] for line in lines[:-1]] == [
        "step    2", "step    4"]
    short = io.StringIO()
    log = Progress(2, True, stream=short, timer=lambda: 0.)
    for step in (1, 2):
        log(SimpleNamespace(step=step, load_factor=step / 2,
                            newton_iterations=2, residual=1e-12))
    assert short.getvalue().startswith("step    2/2 [") and \
        short.getvalue().count("\n") == 1
    stopped = io.StringIO()
    log = Progress(4, True, stream=stopped, timer=lambda: 0.)
    log(SimpleNamespace(step=1, load_factor=.25, newton_iterations=2,
                        residual=1e-12))
    assert stopped.getvalue() == ""
    log.end()
    assert stopped.getvalue().startswith("step    1/4 [") and \
        stopped.getvalue().count("\n") == 1


def test_a_log_record_after_the_bar_starts_on_its_own_line():
    """A warning while the bar is on its line (a trial's read ``... left
    0:01skfem_mpm.solve.rotation: step 9 ...``) starts on a new line;
    the bar is redrawn on the line after it."""
    import io
    import logging
    from types import SimpleNamespace
    from skfem_mpm.cli import BarBreak, Progress
    stream = io.StringIO()
    handler = logging.StreamHandler(stream)
    handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    handler.addFilter(BarBreak(stream))
    logger = logging.getLogger("skfem_mpm.test_bar")
    logger.addHandler(handler)
    try:
        bar = Progress(4, "always", stream=stream, timer=lambda: 0.)
        bar(SimpleNamespace(step=1, load_factor=.25, newton_iterations=1,
                            residual=1e-12))
        logger.warning("step 2: a note")
        bar(SimpleNamespace(step=2, load_factor=.5, newton_iterations=1,
                            residual=1e-12))
        logger.warning("step 3: another")     # twice: one line break
        logger.warning("step 3: a third")
    finally:
        logger.removeHandler(handler)
    lines = stream.getvalue().split("\n")
    assert lines[0].startswith("\rstep    1/4")
    assert lines[1] == "skfem_mpm.test_bar: step 2: a note"
    assert lines[2].startswith("\rstep    2/4")
    assert lines[3:] == ["skfem_mpm.test_bar: step 3: another",
                         "skfem_mpm.test_bar: step 3: a third", ""]


def test_a_value_at_an_interface_is_one_bodys():
    """Two bodies stacked: ``body`` picks whose points a quantity counts,
    so the stress at their interface is the lower body's (the weight of
    the upper one plus its own above the place), not a mix; the 3D slice
    of a picture shows one layer of points."""
    from skfem_mpm.scenes.quantities import Quantity
    from skfem_mpm.scenes.plot import shown_axes
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    scene = parse_scene(tomllib.loads("""
[grid]
x = [0.0, 1.0, 2]
y = [0.0, 2.0, 4]
[[bodies]]
name = "base"
region = { x = [0.0, 1.0], y = [0.0, 1.0] }
material = { model = "linear_elastic", E = 1e6, nu = 0.0 }
[[bodies]]
name = "top"
region = { x = [0.0, 1.0], y = [1.0, 2.0] }
material = { model = "linear_elastic", E = 1e3, nu = 0.0 }
[[supports]]
boundary = "bottom"
[[supports]]
boundary = "left"
components = ["x"]
[[supports]]
boundary = "right"
components = ["x"]
[gravity]
body_force = [0.0, -10.0]
"""))
    result = run_scene(scene)
    base = Quantity("stress", "yy", at=(.5, 1.), body="base")
    top = Quantity("stress", "yy", at=(.5, 1.), body="top")
    anyone = Quantity("stress", "yy", at=(.5, 1.))
    # uniaxial strain, nu = 0, one linear step: each cell's stress is the
    # weight above its centre, -rho g (H - y_c), constant in the cell: the
    # base's top cells (y_c = 0.75) and the top body's lowest (1.25)
    assert abs(base.measure(scene, result) / (-10. * (2. - .75)) - 1.) < 1e-9
    assert abs(top.measure(scene, result) / (-10. * (2. - 1.25)) - 1.) < 1e-9
    assert abs(anyone.measure(scene, result) / -10. - 1.) < 1e-9  # a mix
    assert base.label == "stress yy of base at (0.5, 1)"
    mixed = Quantity("stress", "yy", region=((0., 1.), (.75, 1.25)))
    assert mixed.label == "mean stress yy over [0..1, 0.75..1.25]"
    from skfem import MeshHex
    from skfem_mpm import seed_points
    cube = seed_points(MeshHex().refined(1), 2)
    axes, slab, note = shown_axes(cube.x, cube.volume)
    assert axes == (1, 2) and np.unique(cube.x[0, slab]).size == 1


def test_every_command_line_argument_has_help():
    """``skfem-mpm --help`` and each command's ``--help`` explain every
    argument."""
    import argparse
    from skfem_mpm.cli import build_parser
    missing = []

    def walk(parser, name):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for command, sub in action.choices.items():
                    walk(sub, command)
            elif not action.help:
                missing.append((name, action.dest))
    walk(build_parser(), "skfem-mpm")
    assert missing == []


def test_a_dof_held_by_a_moving_and_a_fixed_support_reacts_in_the_moving():
    """A piston (prescribed motion) and a fixed wall share the top corner:
    the corner's reaction is the piston's whatever the order of the list,
    and the resultants add up to the total reaction of the grid."""
    from dataclasses import replace
    from skfem_mpm.scenes.scene import reaction_resultants
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    text = """
[grid]
x = [0.0, 1.0, 4]
y = [0.0, 1.0, 4]
[[bodies]]
region = { x = [0.0, 1.0], y = [0.0, 1.0] }
material = { model = "linear_elastic", E = 1e4, nu = 0.3 }
[[supports]]
name = "base"
boundary = "bottom"
components = ["y"]
[[supports]]
name = "piston"
boundary = "top"
value = [0.0, -0.01]
[[supports]]
name = "wall"
boundary = "right"
components = ["x"]
[[supports]]
name = "axis"
boundary = "left"
components = ["x"]
"""
    scene = parse_scene(tomllib.loads(text))
    result = run_scene(scene)
    total = result.history[-1].reactions.reshape(-1, 2).sum(axis=0)
    resultants = {}
    for order in ([0, 1, 2, 3], [0, 2, 3, 1]):
        shuffled = replace(scene, supports=[scene.supports[k] for k in order])
        names, resultant = reaction_resultants(shuffled)
        forces = resultant(run_scene(shuffled).history[-1])
        assert np.allclose(forces.sum(axis=0), total, atol=1e-9)
        resultants[tuple(order)] = dict(zip(names, forces.tolist()))
    first, second = resultants.values()
    for name in first:
        assert np.allclose(first[name], second[name], atol=1e-9), name


def test_verbose_logs_this_package_for_its_own_call_only(tmp_path):
    """-v sets this package's logger to INFO (not scikit-fem's notes); a
    later call without it in the same process is quiet again."""
    import logging
    logger = logging.getLogger("skfem_mpm")
    missing = str(tmp_path / "missing.toml")
    assert main(["run", missing, "-v"]) == 2
    assert logger.level == logging.INFO
    assert logging.getLogger("skfem").getEffectiveLevel() > logging.INFO
    assert main(["run", missing]) == 2
    assert logger.level == logging.NOTSET


@pytest.mark.slow
def test_a_body_reaching_outside_the_grid_is_refused(tmp_path, capsys):
    """Issue 30: a body region larger than the grid was clipped without a
    word (the column of 60 on a grid of 50 ran as a column of 50).  A scene
    file gets one line naming the key, the body, the axis, the box and the
    grid's extent, and nothing is written; a Scene of the Python API is
    refused when its points are seeded, naming the body and the axis."""
    column = (EXAMPLES / "column.toml").read_text()
    box = 'region = { x = [0.0, 2.5], y = [0.0, 50.0] }'
    assert box in column
    scene = tmp_path / "tall.toml"
    scene.write_text(column.replace(box, box.replace("50.0]", "60.0]")))
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "bodies[0].region.y: body 'column' reaches outside the grid, " \
        "whose y extent is [0.0, 50.0]" in err[0]
    assert "got [0.0, 60.0]" in err[0]
    assert not out.exists()
    # an axis left out is all of the grid, as before
    scene.write_text(column.replace(box, 'region = { x = [0.0, 2.5] }'))
    assert main(["run", str(scene), "--out", str(out), "--no-progress",
                 "--no-series", "--steps", "1"]) == 0
    api = block()
    api.bodies[0].region = [(0., 2.), (-1., 2.)]
    with pytest.raises(InvalidInputError, match=r"body 'block': region y = "
                       r"\[-1.0, 2.0\] reaches outside the grid's y extent "
                       r"\[0.0, 3.0\]"):
        run_scene(api)


def test_ctrl_c_while_setting_up_gets_one_line(tmp_path, capsys,
                                              monkeypatch):
    """Issue 30: Ctrl-C within the first second (reading the scene,
    seeding the points) printed a raw KeyboardInterrupt.  Every command
    prints one line and exits with 130; a run interrupted so writes
    nothing."""
    import skfem_mpm.cli as cli_module
    out = tmp_path / "out"

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    for name, argv in (
            ("build_points", ["run", "--out", str(out)]),
            ("load_scene", ["run", "--out", str(out)]),
            ("load_scene", ["compare", str(EXAMPLES / "column.toml"),
                            "--out", str(out)]),
            ("load_scene", ["study", str(EXAMPLES / "column.toml"),
                            "--out", str(out)])):
        with monkeypatch.context() as patch:
            patch.setattr(cli_module, name, interrupted)
            try:
                code = main(argv + ["--no-progress"])
            except KeyboardInterrupt:
                pytest.fail("{} ({}): a raw KeyboardInterrupt".format(
                    argv[0], name))
        assert code == 130
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("skfem-mpm: interrupted")
        if argv[0] == "run":
            assert "nothing written" in err[0]
    assert not out.exists()


def test_ctrl_c_after_a_completed_run_gets_one_line(tmp_path, capsys,
                                                    monkeypatch):
    """Issue 30: Ctrl-C after a completed run (writing its summary, the
    figures) must not pass silently nor as a traceback: the summary is
    finished, one line says what completed, exit code 130."""
    import skfem_mpm.cli as cli_module
    write, calls = cli_module.write_summary, []

    def interrupted(path, summary):
        calls.append(summary["status"])
        if len(calls) == 1:
            raise KeyboardInterrupt
        write(path, summary)
    monkeypatch.setattr(cli_module, "write_summary", interrupted)
    out = tmp_path / "out"
    try:
        code = main(["run", "--out", str(out), "--no-progress", "--steps",
                     "2"])
    except KeyboardInterrupt:
        pytest.fail("a raw KeyboardInterrupt")
    assert code == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "after the run completed" in err[0], err
    assert "summary.json" in err[0]
    assert json.loads((out / "summary.json").read_text())["status"] == \
        "completed"
    assert not (out / "final_stress.png").exists()      # not drawn


@pytest.mark.slow
def test_ctrl_c_as_the_program_exits_is_never_a_silent_sigint(tmp_path):
    """Issue 30: Ctrl-C once a run had printed its report killed the
    interpreter's exit (some 0.2 s after the last line) silently, exit
    status -2.  Run as the program, skfem-mpm then exits with its own
    status (0), or 130 with one line."""
    import signal
    import subprocess
    import sys
    import time
    process = subprocess.Popen(
        [sys.executable, "-m", "skfem_mpm.cli", "run", "--out",
         str(tmp_path / "out"), "--no-progress", "--no-series", "--steps",
         "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for line in process.stdout:
        if line.strip().startswith("output"):
            break
    time.sleep(.02)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode in (0, 130), (process.returncode, err)
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 1


@pytest.mark.slow
def test_a_run_killed_by_sigterm_keeps_what_converged(tmp_path):
    """A user trial: a run killed by a batch system (SIGTERM) left no
    ``summary.json`` and no checkpoint of its last steps (exit status
    -15).  It now stops as on Ctrl-C: a checkpoint of the last converged
    step, an interrupted summary naming it, status 130."""
    import os
    import signal
    import subprocess
    import sys
    import time
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "skfem_mpm.cli", "run", "--out", str(out),
         "--no-progress", "--no-series", "--steps", "20000",
         "--checkpoint-every", "5"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    start = time.monotonic()
    while not (out / "checkpoint.npz").exists():
        assert time.monotonic() - start < 60 and process.poll() is None
        time.sleep(.02)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130, (process.returncode, err)
    assert "Traceback" not in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert summary["checkpoint"]
    assert summary["checkpoint_step"] == summary["last_converged_step"] >= 5
    assert os.path.exists(out / "checkpoint.npz")


@pytest.mark.parametrize("word, axis_names", [
    ("top", "'y+' (as in 2D) or 'z+'"),
    ("back", "'z-' (its meaning here until now) or 'y-'")])
def test_a_3d_side_is_named_by_its_axis(tmp_path, word, axis_names):
    """In 3D, where the top is +z to many users and +y in 2D, ``"top"``,
    ``"bottom"``, ``"back"`` and ``"front"`` are refused, naming the two
    faces meant (a traction on ``"top"`` of a z-up block went to its +y
    side); the axis names ``"x-"`` ... ``"z+"`` load the face they name,
    in scene files and the Python API alike."""
    from skfem import MeshHex
    from skfem_mpm import seed_points
    from skfem_mpm.solve.loads import side_points
    text = (EXAMPLES / "block3d.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('side = "z+"', 'side = "{}"'.format(word)))
    with pytest.raises(SceneError, match=axis_names.replace("(", r"\(")
                       .replace(")", r"\)").replace("+", r"\+")):
        load_scene(bad)
    points = seed_points(MeshHex.init_tensor(*[np.linspace(0, 1, 3)] * 3),
                         2, region=lambda x: x[2] < .5)
    with pytest.raises(InvalidInputError, match="depend on which axis is up"):
        side_points(points, word)
    top = side_points(points, "z+")
    assert np.allclose(points.x[2, top] + points.domain[2, top], .5)
    assert top.size == 16


def test_a_scene_s_time_integration_is_checked(tmp_path):
    """A scene's dynamics (Python ``TimeIntegration``) refuses a scheme it
    does not know and a parameter of another scheme (``"Newmark"`` became
    the generalised-alpha scheme, and ``beta`` with ``"auto"`` was
    dropped); in 3D a support on ``"bottom"`` is refused as its traction
    is."""
    from skfem_mpm.scenes.scene import TimeIntegration
    with pytest.raises(InvalidInputError, match="scheme must be one of"):
        TimeIntegration(.01, 1., scheme="Newmark").dynamics([1e3])
    with pytest.raises(InvalidInputError, match="belongs to scheme 'newmark'"):
        TimeIntegration(.01, 1., scheme="auto", beta=.3).dynamics([1e3])
    assert TimeIntegration(.01, 1., scheme="auto").dynamics(
        [1e3]).scheme is None
    bad = tmp_path / "bottom.toml"
    bad.write_text((EXAMPLES / "block3d.toml").read_text().replace(
        'boundary = "z-"', 'boundary = "bottom"'))
    with pytest.raises(SceneError, match=r"supports\[0\].boundary: in 3D"):
        load_scene(bad)


# a block resting on a floor 3 m wide (the grid is 1 m), a cap on it in
# contact, and a wall it never touches, for 3 steps of 0.01 s
RESTING = """
name = "resting"
[grid]
x = [0.0, 1.0, 4]
y = [-0.25, 1.0, 5]
[[bodies]]
name = "block"
region = { x = [0.25, 0.75], y = [0.0, 0.5] }
density = 1000.0
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
[[bodies]]
name = "cap"
region = { x = [0.25, 0.75], y = [0.5, 0.75] }
density = 1000.0
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
[[contacts]]
first = "block"
second = "cap"
[gravity]
body_force = [0.0, -9810.0]
[[obstacles]]
name = "floor"
box = { x = [-1.0, 2.0], y = [-1.0, 0.0] }
friction = 0.3
[[obstacles]]
name = "wall"
box = { x = [0.9, 2.0], y = [0.2, 0.6] }
[[outputs]]
name = "wall force"
quantity = "obstacle_force"
obstacle = "wall"
component = "x"
[dynamics]
time_step = 0.01
duration = 0.03
"""


@pytest.fixture(scope="module")
def resting(tmp_path_factory):
    """The scene ``RESTING``, its result and its summary (as written)."""
    from skfem_mpm.cli import summarise
    from skfem_mpm.scenes.output import write_summary
    path = tmp_path_factory.mktemp("resting") / "resting.toml"
    path.write_text(RESTING)
    scene = load_scene(path)
    result = run_scene(scene)
    write_summary(path.with_name("summary.json"),
                  summarise(scene, result, 1.))
    return scene, result, json.loads(
        path.with_name("summary.json").read_text())


def test_dynamic_force_curves_have_their_time(resting):
    """In dynamics the obstacles' and contacts' force curves in
    summary.json carry each step's time (s) beside the load factor, which
    there is t / duration (a user trial found only the load factor)."""
    summary = resting[2]
    times = summary["energies"]["time"][1:]
    assert np.allclose(times, [.01, .02, .03], rtol=1e-12)
    for curve in (summary["obstacles"]["floor"], summary["obstacles"]["wall"],
                  summary["contacts"]["block-cap"]):
        assert curve["time"] == times
        assert np.allclose(curve["load_factor"], np.array(times) / .03)
    assert summary["units"]["time"] == "s"


def test_an_untouched_obstacle_s_force_is_zero_not_minus_zero(resting,
                                                               capsys):
    """The wall is never touched: its force is 0 in summary.json and on
    the terminal, not -0.0 and "-0 N/m" (the negated zero reaction)."""
    from skfem_mpm.cli import print_report
    scene, _, summary = resting
    wall = summary["obstacles"]["wall"]
    zeros = np.array(wall["force"] + [wall["final_force"],
                                      wall["peak_force"]])
    assert np.all(zeros == 0.) and not np.signbit(zeros).any()
    assert not np.signbit(summary["outputs"]["wall force"]["value"])
    print_report(scene, summary, 1., Path("out"), False)
    assert "wall force                0 N/m\n" in capsys.readouterr().out


def test_the_deformed_shape_shows_the_material_not_the_whole_floor(
        resting, monkeypatch):
    """The picture spans the block and cap (0.25..0.75 x 0..0.75) with a
    tenth of a margin, not the floor obstacle's 3 m (a user trial's block
    was a tenth of its picture); the floor is cut at its edge and the
    undeformed outline is drawn over the points."""
    from skfem_mpm.cli import plot_deformed_shape
    from skfem_mpm.scenes import plot
    scene, result, _ = resting
    kept = {}
    monkeypatch.setattr(plot, "save_figure",
                        lambda fig, path, **kw: kept.update(fig=fig))
    plot_deformed_shape(scene, result.points, "", None, Path("no.png"), 1.)
    ax = kept["fig"].axes[0]
    assert not plot.figure_problems(kept["fig"])
    u = np.abs(result.points.displacement).max()
    assert 0 < u < 3e-3
    # drawn exaggerated (trial 87): the view follows the points drawn
    u *= 1.2 * plot.displacement_scale(result.points.x0,
                                       result.points.displacement)
    assert np.allclose(ax.get_xlim(), [.25 - .075, .75 + .075], atol=u)
    assert np.allclose(ax.get_ylim(), [-.075, .75 + .075], atol=u)
    floor = ax.patches[0]
    assert floor.get_clip_on() and floor.get_xy()[:, 0].min() == -1.
    points = max(c.get_zorder() for c in ax.collections
                 if c.get_offsets().shape[0] == result.points.n)
    undeformed = [c for c in ax.collections
                  if c.get_linestyle()[0][1] is not None]
    assert len(undeformed) == 1 and undeformed[0].get_zorder() > points
    plot.pyplot().close(kept["fig"])


def test_the_force_curves_legend_covers_no_curve(tmp_path, monkeypatch):
    """``obstacles.png`` (the trial's press and floor: a magnitude rising
    to 12800 N/m and the floor's y falling to -12800): its legend of 8
    entries covered the floor's y curve; it lies beside the axes now.
    The press's y, equal to its magnitude, is not drawn under it (a user
    trial read it as missing)."""
    from types import SimpleNamespace

    from skfem_mpm.cli import plot_contact_forces
    from skfem_mpm.scenes import plot
    scene = SimpleNamespace(name="press", grid=SimpleNamespace(dim=2),
                            dynamics=SimpleNamespace(duration=1.),
                            units="SI")
    t = np.linspace(.01, 1., 100)
    ramp = 12800. * np.minimum(t / .5, 1.)
    curves = {"floor": {"force": np.c_[0. * t, -ramp].tolist(),
                        "load_factor": t.tolist(), "time": t.tolist()},
              "press": {"force": np.c_[0. * t, .8 * ramp].tolist(),
                        "load_factor": t.tolist(), "time": t.tolist()}}
    kept = {}
    monkeypatch.setattr(plot, "save_figure",
                        lambda fig, path, **kw: kept.update(fig=fig))
    plot_contact_forces(scene, curves, {"floor": np.zeros(2),
                                        "press": np.array([0., -.01])},
                        "obstacles", tmp_path / "obstacles.png")
    fig = kept["fig"]
    ax = fig.axes[0]
    fig.canvas.draw()
    legend = ax.get_legend().get_window_extent()
    # the press's y equals its magnitude: named in its label, not drawn
    assert len(ax.get_legend().get_texts()) == 7
    assert "press, magnitude (= y)" in [
        t.get_text() for t in ax.get_legend().get_texts()]
    assert not legend.overlaps(ax.get_window_extent())
    assert legend.x1 <= fig.bbox.x1 + 1       # and inside the figure
    plot.pyplot().close(fig)


def test_supports_and_outputs_on_polygons_and_discs():
    """A support's and an output's region may be a polygon or a disc (a
    body's region keys; before, boxes only): the grid nodes in the
    triangle, on its sides too, the points starting in it, chosen here by
    the triangle's inequalities; a polygon on a 3D grid is refused."""
    from skfem import Basis, ElementQuad1, ElementVector, MeshQuad
    from skfem_mpm.scenes.quantities import Quantity
    from skfem_mpm.scenes.regions import Ball
    from skfem_mpm.scenes.scene import run_scene, scene_support_dofs
    from skfem_mpm.scenes.scene_file import parse_quantity, parse_scene
    triangle = [[0., 0.], [1., 0.], [1., 1.]]            # y <= x
    data = {"grid": {"x": [0., 1., 4], "y": [0., 1., 4]},
            "bodies": [{"region": {"y": [0., .5]}, "material": {
                "model": "linear_elastic", "E": 1e3, "nu": .3}}],
            "supports": [{"region": {"polygon": triangle},
                          "components": ["y"]},
                         {"region": {"x": [0., 0.]}, "components": ["x"]}],
            "gravity": {"body_force": [0., -10.]}}
    scene = parse_scene(data)
    basis = Basis(MeshQuad.init_tensor(*[np.linspace(0, 1, 5)] * 2),
                  ElementVector(ElementQuad1()))
    dofs = scene_support_dofs(scene.supports[0], basis, 2).ravel()
    x, y = basis.doflocs[:, dofs]
    nodes = basis.doflocs[:, ::2]
    assert np.all(dofs % 2 == 1)
    assert dofs.size == np.count_nonzero(nodes[1] <= nodes[0]) == 15
    assert np.all(y <= x)
    disc = scene_support_dofs(Support(region=Ball([0., 0.], .3)), basis, 2)
    assert sorted(map(tuple, basis.doflocs[:, disc.ravel()].T.tolist())) \
        == [(0., 0.), (0., 0.), (0., .25), (0., .25), (.25, 0.), (.25, 0.)]
    with pytest.raises(SceneError, match="2D region, the grid is 3D"):
        parse_scene({**data, "grid": {**data["grid"], "z": [0., 1., 2]},
                     "supports": [{"region": {"polygon": triangle}}]})
    result = run_scene(scene)
    wedge = parse_quantity({"quantity": "stress", "component": "yy",
                            "region": {"polygon": triangle}}, 2)
    wedge.check(scene, result.points)
    x0, stress = result.points.x0, result.points.stress[1, 1]
    inside = x0[1] <= x0[0]
    volume = result.points.volume[inside]
    assert 0 < inside.sum() < result.points.n
    assert wedge.measure(scene, result) == pytest.approx(
        stress[inside] @ volume / volume.sum(), rel=1e-12)
    assert "over Polygon(" in wedge.label
    ball = Quantity("stress", "yy", region=Ball([0., 0., 0.], 1.))
    with pytest.raises(InvalidInputError, match="3 axes given"):
        ball.check(scene, result.points)


def test_max_displacement_is_the_largest_magnitude(tmp_path, capsys):
    """``summary.json``'s ``max_displacement`` is the largest
    displacement magnitude of the final points (a trial's sliding block
    read 0.0634, its largest component, where the largest displacement
    was 0.0717): the block pushed sideways and down as much.  The time's
    shares add up to the time, the rest named (a trial read the phases'
    shares of their sum, 53-60% of the time, as the time's)."""
    text = COMBINATION.format(
        material='{ model = "linear_elastic", E = 1e4, nu = 0.3 }',
        method="mpm", kinematics="small", ghost=0., antilocking="false",
        load="traction = [20.0, -20.0]")
    path = tmp_path / "scene.toml"
    path.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 0
    u = meshio.read(out / "points_0002.vtu").point_data["displacement"]
    summary = json.loads((out / "summary.json").read_text())
    largest = np.sqrt((u ** 2).sum(axis=1)).max()
    assert summary["max_displacement"] == pytest.approx(largest, rel=1e-12)
    assert summary["max_displacement"] > 1.1 * np.abs(u).max()
    line, = [x for x in capsys.readouterr().out.splitlines()
             if x.startswith("  time ")]
    shares = [float(w.rstrip("%,")) for w in line.split() if w.endswith(
        ("%", "%,"))]
    assert len(shares) == 6 and "set-up and output" in line
    assert abs(sum(shares) - 100.) <= 3.
    rest = 1 - sum(summary["timings"].values()) / summary["wall_seconds"]
    assert shares[-1] == pytest.approx(100 * rest, abs=.51)


@pytest.mark.parametrize("element", ["Q1", "Q2"])
def test_a_support_holds_every_dof_at_its_places(element, tmp_path):
    """Trial 61: a ``Q2`` grid's ``boundary = "left"`` held the
    vertices' DOFs alone, its edges' mid-side DOFs free: a clamped
    cantilever under its weight sagged 0.8715 where scikit-fem's
    ``get_dofs`` clamp gives 0.7709 (13%), its reactions balanced.  Now
    a boundary support holds what ``get_dofs(...).all()`` holds, a box
    region every DOF in it (a ``Q2`` cell's centre too), the run's tip
    equals a Python run clamped by ``get_dofs`` to 1e-10."""
    from skfem_mpm import LinearElastic, simulate
    from skfem_mpm.scenes.scene import scene_support_dofs
    from skfem_mpm.solve.core import grid_parts
    text = ('name = "sag"\n[grid]\nx = [0.0, 4.0, 20]\ny = [0.0, 0.4, 2]\n'
            'element = "{}"\n[[bodies]]\nname = "beam"\n'
            'region = {{ x = [0.0, 4.0], y = [0.0, 0.4] }}\n'
            'points_per_cell = 3\n'
            'material = {{ model = "linear_elastic", E = 1e6, nu = 0.3 }}\n'
            '[[supports]]\nboundary = "left"\n[gravity]\n'
            'body_force = [0.0, -350.0]\n[solver]\nmethod = "fem"\n'
            'kinematics = "small"\nsteps = 1\n'.format(element))
    path = tmp_path / "sag.toml"
    path.write_text(text)
    scene = load_scene(path)
    mesh, elem = scene.grid.build()
    grid = grid_parts(mesh, elem)[1]
    held = scene_support_dofs(scene.supports[0], grid, 2)
    clamp = grid.get_dofs(lambda x: x[0] == 0.).all()
    assert np.array_equal(np.sort(held.ravel()), np.sort(clamp))
    assert held.shape == (2, 3 if element == "Q1" else 5)
    box = scene_support_dofs(Support(region=[(-1., .3), (-1., 1.)]), grid,
                             2)
    inside = np.flatnonzero(grid.doflocs[0] <= .3 + 1e-9)
    assert np.array_equal(np.sort(box.ravel()), inside)
    result = run_scene(scene)
    reference = simulate(mesh, elem, build_points(scene, mesh), LinearElastic(
        1e6, .3), lambda b: b.get_dofs(lambda x: x[0] == 0.).all(),
        body_force=[0., -350.], nsteps=1, method="fem")
    tip = np.argmin(result.points.displacement[1])
    assert result.points.displacement[1, tip] == pytest.approx(
        reference.points.displacement[1, tip], rel=1e-10)


@pytest.mark.parametrize("method, right, warned", [
    ("mpm", 3.0, True), ("mpm", 2.0, False), ("bspline", 3.0, True),
    ("bspline", 2.5, False)])
def test_a_support_beyond_the_material_s_reach_is_warned(method, right,
                                                        warned, tmp_path,
                                                        caplog):
    """Trial 61: a roller on the grid's right side, two cells beyond the
    soil's end, held nothing: the soil's face was free, Newton failed at
    the first step (Mohr-Coulomb) or the wall met no resistance (elastic)
    without a word.  A block 1.5 long on a grid of cells 0.5: a support
    on x = ``right`` is warned where it lies past the method's reach
    (MPM: a cell beyond the domains, 3.0 warned, 2.0 not; B-splines: two
    cells from the points, 3.0 warned, 2.5 not); the base never."""
    text = ('name = "reach"\n[grid]\nx = [0.0, {0}, {1}]\n'
            'y = [0.0, 1.0, 2]\n[[bodies]]\nname = "block"\n'
            'region = {{ x = [0.0, 1.5], y = [0.0, 0.5] }}\n'
            'material = {{ model = "linear_elastic", E = 1e4, nu = 0.3 }}\n'
            '[[supports]]\nname = "base"\nboundary = "bottom"\n'
            '[[supports]]\nname = "far"\nboundary = "right"\n'
            'components = ["x"]\n[gravity]\nbody_force = [0.0, -10.0]\n'
            '[solver]\nmethod = "{2}"\nsteps = 1\n'.format(
                right, int(round(right / .5)), method))
    path = tmp_path / "reach.toml"
    path.write_text(text)
    with caplog.at_level("WARNING", logger="skfem_mpm"):
        run_scene(load_scene(path))
    words = [r.getMessage() for r in caplog.records
             if "holds no node" in r.getMessage()]
    assert len(words) == warned
    assert all(w.startswith("support 'far' ") for w in words)


@pytest.mark.parametrize("method", ["fem", "mpm"])
def test_a_scene_on_triangles_runs(method):
    """A scene's grid given as a scikit-fem mesh of triangles (points
    without domains): the start's check of supports that reach no
    material raised TypeError on the missing domains (a user trial's);
    the column under its weight runs, its base reaction the weight."""
    import tomllib
    from dataclasses import replace
    from skfem import ElementTriP1, MeshTri
    from skfem_mpm.scenes.scene import Grid, run_scene
    from skfem_mpm.scenes.scene_file import parse_scene
    scene = parse_scene(tomllib.loads("""
[grid]
x = [0.0, 1.0, 4]
y = [0.0, 4.0, 16]
[[bodies]]
region = { x = [0.0, 1.0], y = [0.0, 3.0] }
material = { model = "linear_elastic", E = 1e5, nu = 0.0 }
[[supports]]
boundary = "bottom"
[[supports]]
boundary = "left"
components = ["x"]
[[supports]]
boundary = "right"
components = ["x"]
[gravity]
body_force = [0.0, -10.0]
[solver]
steps = 2
"""))
    mesh = MeshTri.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 4, 17))
    res = run_scene(replace(scene, grid=Grid(mesh=mesh, elem=ElementTriP1()),
                            method=method))
    assert res.history[-1].reactions.reshape(-1, 2)[:, 1].sum() == \
        pytest.approx(10. * 3., rel=1e-9)


def test_series_collections_list_times_without_summed_round_off(tmp_path):
    # five time steps of 0.01 summed end at 0.049999999999999996, which
    # the collections listed as written (a user trial's PVD)
    from skfem import MeshQuad
    from skfem_mpm import seed_points
    from skfem_mpm.scenes.output import SeriesWriter
    mesh = MeshQuad.init_tensor(np.linspace(0., 1., 3), np.linspace(0., 1.,
                                                                     3))
    points = seed_points(mesh, 1)
    writer = SeriesWriter(tmp_path, mesh, points)
    factor, times = 0., []         # a run of 60 steps over 0.6 s
    for step in range(6):
        times.append(factor * 0.6)
        writer.write(step, times[-1], points, np.arange(mesh.nelements),
                     None)
        factor += 1 / 60
    assert times[5] != 0.05                     # the round-off is there
    pvd = (tmp_path / "points.pvd").read_text()
    assert '<DataSet timestep="0.05" file="points_0005.vtu"/>' in pvd
    assert "99999" not in pvd and "99999" not in (
        tmp_path / "grid.pvd").read_text()
