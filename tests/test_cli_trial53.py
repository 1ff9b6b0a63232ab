"""What a new user's trial (53) found in the command line and its output
files: PVD collections listing files an invocation with ``--no-series``
never wrote, runs that failed or were stopped leaving less than a finished
one (no units, reactions, load factor or figures; ``--max-steps``: no
summary at all), times covering only the last invocation, ``--steps 0``
ignored, ``--checkpoint-every 0`` and an unwritable ``--out`` accepted, no
quantity for the force between bodies in contact, and messages and
pictures that misled."""
import json
import re

import numpy as np
import pytest

from skfem_mpm.cli import main
from skfem_mpm.errors import InvalidInputError, NewtonDivergenceError
from skfem_mpm.scenes import plot
from skfem_mpm.scenes.checkpoint import load_checkpoint
from skfem_mpm.scenes.quantities import Quantity
from test_body_contact import STACK_SCENE

# a von Mises block under its weight, pressed by an obstacle: it yields,
# so a run draws every figure a finished one draws (plastic zone and
# obstacle forces included), in four quick steps
PRESSED = """
name = "pressed block"
[grid]
x = [0.0, 2.0, 4]
y = [0.0, 2.0, 4]
[[bodies]]
name = "block"
region = { x = [0.0, 1.0], y = [0.0, 1.0] }
points_per_cell = 2
material = { model = "von_mises", E = 1e6, nu = 0.3, yield_stress = 5e3 }
[[supports]]
name = "base"
boundary = "bottom"
[gravity]
body_force = [0.0, -18000.0]
[[obstacles]]
box = { x = [0.0, 0.5], y = [1.0, 1.5] }
displacement = [0.0, -0.01]
[solver]
method = "mpm"
steps = 4
"""

# two elastic blocks, one on the other, pressed by a traction of 10 Pa on
# the top's 1 m: 10 N/m between them at full load
STACK = STACK_SCENE.format(
    contact='first = "base"\nsecond = "block"\ntolerance = 1e-9')

# repro/outline.toml: a plain elastic block
OUTLINE = """
name = "outline"
[grid]
x = [-0.6, 0.6, 48]
y = [0.0, 1.3, 52]
[[bodies]]
name = "clay"
region = { x = [-0.6, 0.6], y = [0.0, 1.0] }
points_per_cell = 2
material = { model = "linear_elastic", E = 5e6, nu = 0.3 }
[[supports]]
name = "base"
boundary = "bottom"
[solver]
steps = 1
"""

#: what a finished run of PRESSED writes beside its series
FIGURES = {"deformed_shape.png", "final_stress.png", "final_von_mises.png",
           "plastic_zone.png", "obstacles.png"}


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "pressed.toml"
    path.write_text(PRESSED)
    return path


@pytest.fixture
def figures(monkeypatch):
    """The figures the command writes, by file name."""
    kept, save = {}, plot.save_figure

    def keep(fig, path, *args, **kwargs):
        kept[path.name] = fig
        # where the first axes' title lies across the figure (0 to 1)
        box = fig.axes[0].title.get_window_extent(
            fig.canvas.get_renderer())
        kept[path.name + ":title"] = (box.x0 / fig.bbox.width,
                                      box.x1 / fig.bbox.width)
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", keep)
    return kept


def listed(out):
    """The files the PVD collections of ``out`` list."""
    return sorted(name for pvd in ("points.pvd", "grid.pvd") for name in
                  re.findall(r'file="([^"]+)"', (out / pvd).read_text()))


def test_a_series_resumed_after_no_series_lists_only_its_files(
        scene, tmp_path, monkeypatch):
    """repro/pvd.sh: ``--max-steps 2 --no-series`` then ``--resume``
    listed points_0001..0002 and grid_0001..0002, never written."""
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--max-steps", "2",
                 "--no-series", "--no-progress"]) == 0
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert listed(out) == ["grid_0003.vtu", "grid_0004.vtu",
                           "points_0003.vtu", "points_0004.vtu"]
    assert all((out / name).is_file() for name in listed(out))


@pytest.mark.slow
def test_a_stopped_run_leaves_a_summary_and_the_figures(scene, tmp_path):
    """``--max-steps``, a deliberate stop, left no summary.json; now the
    finished run's summary of the steps done (status stopped) and its
    figures; the wall seconds and seconds per phase add up over the
    invocations (the checkpoint keeps them)."""
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--max-steps", "2",
                 "--no-series", "--no-progress"]) == 0
    stopped = json.loads((out / "summary.json").read_text())
    assert stopped["status"] == "stopped"
    assert (stopped["steps_run"], stopped["load_factor"],
            stopped["checkpoint_step"]) == (2, .5, 2)
    assert stopped["units"]["reactions"] == "N/m"
    assert len(stopped["reactions"]["base"]) == 2
    assert len(stopped["obstacles"]["obstacle0"]["force"]) == 2
    assert "error" not in stopped       # no closed form of a partial run
    assert FIGURES <= {p.name for p in out.iterdir()}
    kept = load_checkpoint(out)
    assert 0 < kept.wall_seconds <= stopped["wall_seconds"]
    assert kept.timings == pytest.approx(stopped["timings"])
    assert main(["run", "--resume", str(out), "--no-series",
                 "--no-progress"]) == 0
    done = json.loads((out / "summary.json").read_text())
    assert done["status"] == "completed" and done["steps_run"] == 4
    assert done["wall_seconds"] > kept.wall_seconds
    for phase, seconds in kept.timings.items():
        assert done["timings"][phase] > seconds


@pytest.mark.slow
def test_a_failed_run_leaves_what_a_finished_one_does(scene, tmp_path,
                                                       monkeypatch,
                                                       figures):
    """A failed run's summary had no units, reactions or load factor and
    no obstacles.png was drawn: the step after the second fails here."""
    import skfem_mpm.cli as cli
    real = cli.run_scene

    def failing(scene, points, resume, callback, **kwargs):
        def fail_after_two(record, pts):
            callback(record, pts)
            if record.step == 2:
                raise NewtonDivergenceError("step 3 diverged", state=pts,
                                            load_factor=record.load_factor)
        return real(scene, points, resume=resume, callback=fail_after_two,
                    **kwargs)
    monkeypatch.setattr(cli, "run_scene", failing)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--no-series",
                 "--no-progress"]) == 1
    failed = json.loads((out / "summary.json").read_text())
    assert failed["status"] == "failed"
    assert failed["error"] == "NewtonDivergenceError: step 3 diverged"
    assert (failed["load_factor"], failed["steps_run"],
            failed["last_converged_step"]) == (.5, 2, 2)
    assert failed["units"]["force"] == "N/m"
    assert len(failed["reactions"]["base"]) == 2
    assert FIGURES <= set(figures)
    title = figures["deformed_shape.png"].axes[0].get_title()
    assert "at load factor 0.5,\nthe last converged state" in title


def test_checkpoint_every_0_says_it_means_never(capsys):
    """``--checkpoint-every 0`` wrote no checkpoint, without a word: the
    help says so."""
    assert main(["run", "--help"]) == 0
    assert "every N steps (0, the default: never," in " ".join(
        capsys.readouterr().out.split())


@pytest.mark.parametrize("option", ("--steps", "--max-steps"))
def test_zero_steps_are_refused(scene, tmp_path, capsys, option):
    """``--steps 0`` ran the scene's steps, without a word, where
    ``steps = 0`` in a scene is refused."""
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), option, "0",
                 "--no-progress"]) == 2
    assert capsys.readouterr().err == \
        "skfem-mpm: {} must be >= 1, got 0\n".format(option)
    assert not out.exists()


@pytest.mark.parametrize("command", ("run", "compare", "study"))
def test_an_output_folder_that_cannot_be_made_is_named(scene, capsys,
                                                        command):
    """``--out /proc/nope`` ended in a raw FileNotFoundError (exit 1)."""
    assert main([command, str(scene), "--out", "/proc/nope",
                 "--no-progress"]) == 2
    assert capsys.readouterr().err == (
        "skfem-mpm: --out /proc/nope: cannot make or write the output "
        "folder: /proc refuses a new folder (No such file or directory)\n")


def test_the_force_between_bodies_in_contact_is_a_quantity(tmp_path):
    """``contact_force`` by the contact's name: the traction's 10 N/m."""
    from skfem_mpm.scenes.scene import run_scene
    from skfem_mpm.scenes.scene_file import load_scene
    path = tmp_path / "stack.toml"
    path.write_text(STACK)
    stack = load_scene(path)
    push = Quantity("contact_force", "y", contact="base-block")
    push.check(stack)
    assert push.label == "contact force y of base-block"
    assert push.unit(2) == "N/m"
    result = run_scene(stack)
    assert push.measure(stack, result) == pytest.approx(10., rel=1e-9)
    assert Quantity("contact_force", "magnitude", contact="base-block"
                    ).measure(stack, result) == pytest.approx(10., rel=1e-9)
    with pytest.raises(InvalidInputError, match=r"no contact 'pile' \(the "
                       r"scene has \['base-block'\]\)"):
        Quantity("contact_force", "y", contact="pile").check(stack)
    with pytest.raises(InvalidInputError, match="a contact_force needs the "
                       "contact's name"):
        Quantity("contact_force", "y")


def test_a_scene_file_measures_the_force_between_bodies():
    """``[[outputs]] quantity = "contact_force", contact = ...`` in a
    scene file (its parser refused the ``contact`` key)."""
    from skfem_mpm.scenes.scene_file import parse_quantity
    q = parse_quantity({"quantity": "contact_force", "component": "y",
                        "contact": "base-block"}, 2)
    assert q == Quantity("contact_force", "y", contact="base-block")


def test_component_messages_have_the_article_and_the_dimension(tmp_path):
    """'a obstacle_force has the components ('x', 'y', 'z',
    'magnitude')', z offered in 2D."""
    from skfem_mpm.scenes.scene_file import load_scene
    with pytest.raises(InvalidInputError) as err:
        Quantity("obstacle_force", "yy", obstacle="wall")
    assert str(err.value) == (
        "an obstacle_force has the components x, y (2D, 3D), z (3D only), "
        "magnitude, got 'yy'")
    path = tmp_path / "pressed.toml"
    path.write_text(PRESSED)
    with pytest.raises(InvalidInputError) as err:
        Quantity("obstacle_force", "z", obstacle="obstacle0").check(
            load_scene(path))
    assert str(err.value) == ("obstacle force z of obstacle0: a 2D scene "
                              "has no 'z' component (it has x, y, "
                              "magnitude)")


def test_compare_on_a_contact_scene_says_why(tmp_path, capsys):
    """compare was refused with a message about method 'fem', which the
    user had not chosen; now before any run, saying why."""
    path = tmp_path / "stack.toml"
    path.write_text(STACK)
    assert main(["compare", str(path), "--out", str(tmp_path / "cmp"),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("skfem-mpm: compare runs FE beside the scene's "
                          "method (mpm) on the same scene, and FE has no "
                          "contacts between bodies (the scene has "
                          "'base-block'")
    assert not (tmp_path / "cmp").exists()


def test_the_undeformed_outline_of_a_block_is_one_line(tmp_path):
    """repro/outline.toml: a block on x = [-0.6, 0.6, 48] got dashed
    lines inside it (touching boxes a round-off apart split by a pixel):
    48 contour paths, now the one outline."""
    from skfem_mpm.scenes.scene import build_points
    from skfem_mpm.scenes.scene_file import load_scene
    path = tmp_path / "outline.toml"
    path.write_text(OUTLINE)
    block = load_scene(path)
    points = build_points(block, block.grid.build()[0])
    centres, half = points.x0, np.tile(.5 * points.volume0 ** .5, (2, 1))
    fig, ax = plot.pyplot().subplots()
    contour = plot.outline(ax, centres, half)
    paths = contour.allsegs[0]
    plot.pyplot().close(fig)
    assert len(paths) == 1
    assert np.allclose(paths[0].min(axis=0), [-.6, 0.], atol=.004)
    assert np.allclose(paths[0].max(axis=0), [.6, 1.], atol=.004)


def test_peak_and_final_values_show_the_same_precision():
    """'peak 7e+04' beside 'final 6.555e+04'."""
    fig, ax = plot.pyplot().subplots()
    line, = ax.plot([0., 1., 2.], [0., 7e4, 65550.])
    plot.mark_peak(ax, line, np.array([0., 1., 2.]),
                   np.array([0., 7e4, 65550.]))
    label = ax.lines[-1].get_label()
    plot.pyplot().close(fig)
    assert label == "peak 7.000e+04, final 6.555e+04"


@pytest.mark.slow
def test_the_plastic_zone_title_fits_its_figure(scene, tmp_path, figures):
    """plastic_zone.png's title ran past both edges of its figure."""
    assert main(["run", str(scene), "--out", str(tmp_path / "out"),
                 "--no-series", "--no-progress"]) == 0
    for name in ("plastic_zone.png", "final_stress.png"):
        left, right = figures[name + ":title"]
        assert 0 <= left and right <= 1, name


def documented_arrays():
    """Patterns of the point arrays the README's field table names
    (``<i>``: a number; ``_g<a><c>``: a suffix of the name before)."""
    text = open(__file__.replace("tests/test_cli_trial53.py",
                                 "README.md")).read()
    table = text[text.index("| `points_NNNN.vtu`"):
                 text.index("| `grid_NNNN.vtu`")]
    names = [n for row in table.splitlines()
             for n in re.findall(r"`([^`]+)`", row.split("|")[2])]
    return [re.compile((".*" if n.startswith("_") else "") + re.sub(
        r"<[a-z]>", r"\\d+", re.escape(n).replace(r"\<", "<").replace(
            r"\>", ">"))) for n in names]


@pytest.mark.parametrize("text", (PRESSED, STACK))
def test_the_readme_names_every_point_array_of_contact_runs(text,
                                                           tmp_path):
    """contact_dx*, contact_grad*, contact<i>_p*, contact<i>_t* (and the
    arrays of contacts between bodies) were written without a word."""
    from skfem_mpm.scenes.output import point_cloud
    from skfem_mpm.scenes.scene import run_scene
    from skfem_mpm.scenes.scene_file import load_scene
    path = tmp_path / "scene.toml"
    path.write_text(text)
    cloud = point_cloud(run_scene(load_scene(path)).points)
    patterns = documented_arrays()
    arrays = set(cloud.point_data) - {"yielding"}      # written by series
    assert any(a.startswith("contact") for a in arrays)
    assert [a for a in sorted(arrays) if not any(
        p.fullmatch(a) for p in patterns)] == []
