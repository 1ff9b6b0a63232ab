"""What a user trial (87) found in the command line: ``--resume`` with
another scene file and ``--steps`` resumed the first run without a word,
a progress count past its planned steps (``step 43/40``), no obstacle or
rigid-body force in the report, no figures after an interrupt, a series
resumed after ``--no-series`` starting late without a word, and messages
that did not name the key or the folder's trouble."""
import json
from types import SimpleNamespace

import pytest

from skfem_mpm.cli import main
from test_cli_trial53 import PRESSED


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "pressed.toml"
    path.write_text(PRESSED)
    return path


@pytest.fixture
def stopped(scene, tmp_path, monkeypatch):
    """The pressed block stopped after its first of 4 steps, no figures
    drawn (they are not what these tests look at)."""
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--max-steps", "1",
                 "--no-progress"]) == 0
    return out


def test_resume_refuses_another_scene_file(stopped, scene, tmp_path,
                                           capsys):
    """``run slope.toml --resume DIR`` resumed DIR's footing: another
    scene's content is refused before any work, the same content (any
    path) is accepted."""
    other = tmp_path / "other.toml"
    other.write_text(PRESSED.replace("steps = 4", "steps = 5"))
    before = (stopped / "summary.json").read_text()
    capsys.readouterr()
    assert main(["run", str(other), "--resume", str(stopped),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "{} with --resume {}: it is not the scene".format(
        other, stopped) in err
    assert (stopped / "summary.json").read_text() == before
    copy = tmp_path / "copy.toml"
    copy.write_text(PRESSED)
    assert main(["run", str(copy), "--resume", str(stopped),
                 "--no-progress", "--max-steps", "1"]) == 0
    assert json.loads((stopped / "summary.json").read_text())[
        "steps_run"] == 2


def test_resume_refuses_other_steps_and_another_out(stopped, tmp_path,
                                                    capsys):
    """``--steps 5`` with ``--resume`` was dropped: refused unless it is
    the run's own count; ``--out`` elsewhere is refused too."""
    planned = json.loads((stopped / "summary.json").read_text())["steps"]
    capsys.readouterr()
    assert main(["run", "--resume", str(stopped), "--steps",
                 str(planned + 1), "--no-progress"]) == 2
    assert "--steps {} with --resume {}: the run there was planned in " \
        "{} steps".format(planned + 1, stopped, planned) in \
        capsys.readouterr().err
    assert main(["run", "--resume", str(stopped), "--out",
                 str(tmp_path / "elsewhere"), "--no-progress"]) == 2
    assert "a resumed run writes to its own folder" in \
        capsys.readouterr().err
    assert not (tmp_path / "elsewhere").exists()
    assert main(["run", "--resume", str(stopped), "--steps", str(planned),
                 "--out", str(stopped), "--no-progress",
                 "--max-steps", "1"]) == 0


def test_resume_takes_the_steps_the_run_was_started_with(
        scene, tmp_path, monkeypatch, capsys):
    """A run completed with ``--steps 6`` (its scene says 4; no checkpoint
    kept) resumed with ``--steps 6`` is complete, nothing to do: it was
    refused as "planned in 4 steps" (scene.toml keeps no ``--steps``; a
    review).  One stopped after its first step resumes with 6 and is
    refused with 4, naming 6 (the checkpoint's count)."""
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    done = tmp_path / "done"
    assert main(["run", str(scene), "--out", str(done), "--steps", "6",
                 "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["run", "--resume", str(done), "--steps", "6",
                 "--no-progress"]) == 0
    assert "is complete" in capsys.readouterr().out
    out = tmp_path / "six"
    assert main(["run", str(scene), "--out", str(out), "--steps", "6",
                 "--max-steps", "1", "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["run", "--resume", str(out), "--steps", "4",
                 "--no-progress"]) == 2
    assert "the run there was planned in 6 steps" in capsys.readouterr().err
    assert main(["run", "--resume", str(out), "--steps", "6",
                 "--max-steps", "1", "--no-progress"]) == 0


def test_progress_past_the_planned_steps_says_planned():
    """After cut-backs a trial's bar read ``step   43/40``."""
    import io
    from skfem_mpm.cli import Progress
    stream = io.StringIO()
    bar = Progress(40, "always", stream=stream, timer=lambda: 0.)
    bar(SimpleNamespace(step=40, load_factor=.9, newton_iterations=1,
                        residual=1e-12))
    assert "step   40/40 [" in stream.getvalue()
    bar(SimpleNamespace(step=43, load_factor=.95, newton_iterations=1,
                        residual=1e-12))
    assert "step   43 (40 planned) [" in stream.getvalue()
    assert "43/40" not in stream.getvalue()


def test_the_report_prints_each_obstacle_s_final_force(scene, tmp_path,
                                                       capsys,
                                                       monkeypatch):
    """A rigid footing's run printed no force, an obstacle's only as an
    ``[[outputs]]``: the report prints each one's final force, its unit
    and its sign convention, as summary.json has it."""
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    out = tmp_path / "out"
    scene.write_text(PRESSED.replace("-0.01]", "-0.05]"))
    assert main(["run", str(scene), "--out", str(out), "--no-series",
                 "--no-progress"]) == 0
    force = json.loads((out / "summary.json").read_text())[
        "obstacles"]["obstacle0"]["final_force"]
    assert force[1] > 0         # the block pushes the plate up
    assert "  obstacle obstacle0 final force ({:.6g}, {:.6g}) N/m: the " \
        "force the material exerts on it\n".format(*force) in \
        capsys.readouterr().out


def test_a_rigid_body_s_force_is_the_one_holding_its_motion():
    from skfem_mpm.cli import force_lines
    summary = {"units": {"force": "kN/m"},
               "rigid_bodies": {"footing": {"final_force": [-1.5, -188.]}},
               "contacts": {"a-b": {"final_force": [0., 3.]}}}
    assert force_lines(summary) == [
        "  rigid body footing final force (-1.5, -188) kN/m: the force "
        "that holds its motion",
        "  contact a-b final force (0, 3) kN/m: the force its first body "
        "exerts on its second"]


def interrupted_after(step, monkeypatch):
    """``run_scene`` interrupted (Ctrl-C, SIGTERM) once ``step`` is
    done."""
    import skfem_mpm.cli as cli
    real = cli.run_scene

    def interrupted(scene, points, resume, callback, **kwargs):
        def stop(record, pts):
            callback(record, pts)
            if record.step == step:
                raise KeyboardInterrupt
        return real(scene, points, resume=resume, callback=stop, **kwargs)
    monkeypatch.setattr(cli, "run_scene", interrupted)


def test_an_interrupted_run_draws_the_figures_of_its_steps(
        scene, tmp_path, monkeypatch, capsys):
    """A SIGTERM left summary, checkpoint and series but no PNG, where
    ``--max-steps`` draws them."""
    interrupted_after(2, monkeypatch)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--no-series",
                 "--no-progress"]) == 130
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and "figures" not in summary
    assert {"deformed_shape.png", "final_stress.png"} <= {
        p.name for p in out.iterdir()}
    assert "interrupted; figures of steps 1 to 2 drawn; continue with" in \
        capsys.readouterr().err


def test_a_second_interrupt_in_the_figures_is_said(scene, tmp_path,
                                                   monkeypatch, capsys):
    import skfem_mpm.cli as cli
    interrupted_after(2, monkeypatch)

    def drawing(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(cli, "plot_outputs", drawing)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--no-series",
                 "--no-progress"]) == 130
    summary = json.loads((out / "summary.json").read_text())
    assert summary["figures"] == cli.FIGURES_INTERRUPTED
    assert "figures not drawn (interrupted again)" in \
        capsys.readouterr().err


@pytest.mark.parametrize("first,then", ((["--no-series"], []),
                                        ([], ["--no-series"])))
def test_a_series_broken_by_no_series_is_said(scene, tmp_path, monkeypatch,
                                               caplog, first, then):
    """A resume after ``--no-series`` began the series at step 8 without a
    word (and one with it ended the series early): the log and
    summary.json say so."""
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--max-steps", "2",
                 "--no-progress"] + first) == 0
    assert main(["run", "--resume", str(out), "--no-progress"] + then) == 0
    note = json.loads((out / "summary.json").read_text())["series_note"]
    assert note in caplog.text
    if first:
        # steps 0, 1 and 2 before the resume at step 3
        assert note.startswith("the VTU series lacks 3 of the 3 states "
                               "before step 3")
    else:
        assert note.startswith("the VTU series stops at step 2")


def test_a_bad_friction_is_named_by_its_key(scene, tmp_path, capsys):
    """``obstacles[0]: Obstacle friction must be ...`` named no key."""
    scene.write_text(PRESSED.replace(
        "displacement = [0.0, -0.01]",
        'displacement = [0.0, -0.01]\nfriction = "rogh"'))
    assert main(["run", str(scene), "--out", str(tmp_path / "out"),
                 "--no-progress"]) == 2
    assert "obstacles[0].friction: must be a coefficient >= 0, 'rough' " \
        "or 'tied', got 'rogh'" in capsys.readouterr().err


def test_an_unwritable_existing_folder_is_said_so(scene, tmp_path, capsys,
                                                 monkeypatch):
    """An existing folder made read-only "refused a new folder"; it
    refuses the run's files (the probe is refused as root is not by a
    mode, so it is made to fail)."""
    import errno
    import skfem_mpm.cli as cli

    def refused(*args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied")
    monkeypatch.setattr(cli.tempfile, "mkdtemp", refused)
    out = tmp_path / "ro"
    out.mkdir()
    assert main(["run", str(scene), "--out", str(out),
                 "--no-progress"]) == 2
    assert capsys.readouterr().err == "skfem-mpm: --out {}: cannot write " \
        "in the output folder (Permission denied)\n".format(out)


def test_a_factor_set_by_growth_says_so():
    """trial87's slope: every trial converged, the factor set by
    ``--growth 5`` (5.69 times F = 1's at 1.8125); the printed result
    read as a collapse."""
    from skfem_mpm.cli import safety_set_by
    reference = .01065
    trials = [dict(factor=f, converged=True, largest_displacement=d)
              for f, d in ((1., reference), (2., .1669), (1.5, .01175),
                           (1.75, .0364), (1.875, .08292),
                           (1.8125, .06056))]
    summary = dict(trials=trials, bracket=[1.75, 1.8125], growth=5.,
                   low=1., reference_displacement=reference)
    kind, words = safety_set_by(summary)
    assert kind == "growth"
    assert "set by --growth 5: at F = 1.8125 the run converged, its " \
        "largest displacement {:.2f} times that at F = 1 (no trial failed " \
        "to converge)".format(.06056 / reference) in words
    trials[-1].update(converged=False, largest_displacement=None)
    assert safety_set_by(summary) == ("convergence", "  set by "
                                      "convergence: the run at F = 1.8125 "
                                      "did not converge")


def test_a_static_run_s_units_name_no_energies():
    """A static run's summary.json gave ``units.energies`` for energies
    it does not have."""
    from skfem_mpm.cli import summary_units
    from skfem_mpm.scenes.units import unit
    assert "energies" not in summary_units(2, system="kN-m")
    assert summary_units(2, True, "kN-m")["energies"] == \
        "{} (time: s)".format(unit("energy", "kN-m", 2))


def test_compare_s_summary_has_the_units_of_its_differences(tmp_path,
                                                            capsys):
    """compare's summary.json gave its differences without units; its
    lines printed "largest displacement 0.0298" and the rms and places
    of the differences without them (session 85, trial 1)."""
    from skfem_mpm.scenes.units import unit
    path = tmp_path / "block.toml"
    path.write_text(PRESSED.replace("steps = 4", "steps = 1").replace(
        'name = "pressed block"', 'name = "pressed block"\nunits = "kN-m"'))
    out = tmp_path / "cmp"
    capsys.readouterr()
    assert main(["compare", str(path), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["units"] == {
        "system": "kN-m", "max_relative": "-",
        "displacement": unit("length", "kN-m", 2),
        "stress": unit("stress", "kN-m", 2)}
    length, stress = unit("length", "kN-m", 2), unit("stress", "kN-m", 2)
    for method in ("fem", "mpm"):
        moved = summary["runs"][method]["max_displacement"]
        assert "{:>7}: largest displacement {:.4g} {}, ".format(
            method, moved, length) in said, said
    for name, what, its in (("displacement", "displacement", length),
                            ("stress", "Cauchy stress", stress)):
        d = summary["difference"][name]
        line = next(x for x in said.splitlines()
                    if x.startswith("  mpm - fem, {}:".format(what)))
        where = ", ".join("{:.4g}".format(v) for v in d["max_at"])
        assert "max {:.3e} {} (".format(d["max"], its) in line
        assert "(at {} {} at the start)".format(where, length) in line
        assert line.endswith("; rms {:.3e} {}".format(d["rms"], its))
