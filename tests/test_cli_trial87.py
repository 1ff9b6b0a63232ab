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
