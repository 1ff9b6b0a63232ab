"""What a user trial (89) found: ``run --resume DIR --steps 9`` on a
completed run of 6 steps said "nothing to resume" and exited 0, where an
unfinished run refuses ``--steps`` other than its own (exit 2)."""
import json

import pytest

from skfem_mpm.cli import main
from test_cli_trial53 import PRESSED


@pytest.fixture
def quiet(monkeypatch):
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)


@pytest.mark.parametrize("keep", [True, False])
def test_a_completed_run_refuses_other_steps(quiet, tmp_path, capsys,
                                             keep):
    """A completed run (with its end's checkpoint, or none kept and its
    ``summary.json`` ``completed``) resumed with ``--steps`` other than
    its count is refused naming that count; with its own count it is
    complete, exit 0, as before."""
    scene = tmp_path / "pressed.toml"
    scene.write_text(PRESSED)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--steps", "3",
                 "--checkpoint-every", "1" if keep else "0",
                 "--no-progress"]) == 0
    assert (out / "checkpoint.npz").is_file() == keep
    planned = json.loads((out / "summary.json").read_text())["steps"]
    capsys.readouterr()
    assert main(["run", "--resume", str(out), "--steps",
                 str(planned + 1), "--no-progress"]) == 2
    assert "--steps {} with --resume {}: the run there was planned in " \
        "{} steps".format(planned + 1, out, planned) in \
        capsys.readouterr().err
    assert main(["run", "--resume", str(out), "--steps", str(planned),
                 "--no-progress"]) == 0
    assert "is complete" in capsys.readouterr().out
