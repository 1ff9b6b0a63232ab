"""``run --series-every N``: the VTU series thinned for large runs (trial
82: 250 bytes a point a step in 3D, and no option to write fewer)."""
import json
import re

from skfem_mpm.cli import main
from test_cli_trial53 import PRESSED


def written(out):
    """The steps of the points' VTU files in ``out`` and those its
    collection lists."""
    files = sorted(int(p.stem.split("_")[1]) for p in out.glob(
        "points_*.vtu"))
    listed = [int(n) for n in re.findall(r'file="points_(\d+)\.vtu"',
                                         (out / "points.pvd").read_text())]
    return files, listed


def test_series_every_n_steps_writes_the_start_each_nth_and_the_last(
        tmp_path, monkeypatch, capsys):
    """Four steps with ``--series-every 3``: the start, step 3 and the
    last, step 4, in the files and the collection; where ``--max-steps``
    stops the run (step 2), that step too, and the resume goes on every
    third.  N < 1 and N with ``--no-series`` are refused before any
    work."""
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    scene = tmp_path / "pressed.toml"
    scene.write_text(PRESSED)
    steps = int(re.search(r"steps = (\d+)", PRESSED).group(1))
    out = tmp_path / "thin"
    assert main(["run", str(scene), "--out", str(out), "--series-every",
                 "3", "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["steps_run"] \
        == steps
    assert written(out) == ([0, 3, 4], [0, 3, 4])
    stopped = tmp_path / "stopped"
    assert main(["run", str(scene), "--out", str(stopped), "--series-every",
                 "3", "--max-steps", "2", "--no-progress"]) == 0
    assert written(stopped) == ([0, 2], [0, 2])
    assert main(["run", "--resume", str(stopped), "--series-every", "3",
                 "--no-progress"]) == 0
    assert written(stopped) == ([0, 2, 3, 4], [0, 2, 3, 4])
    capsys.readouterr()
    for extra in (["--series-every", "0"],
                  ["--series-every", "2", "--no-series"]):
        assert main(["run", str(scene), "--out", str(tmp_path / "no"),
                     "--no-progress"] + extra) == 2
        assert "--series-every" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()


def test_the_points_vtus_carry_the_contact_pressure(tmp_path, monkeypatch):
    """Trial 93: the VTUs had the multipliers, not the pressure.  Each
    step's points carry ``contact0_pressure`` and ``contact0_area``,
    whose product sums to the obstacle's force (zero at the start)."""
    import meshio
    import numpy as np

    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    scene = tmp_path / "pressed.toml"
    scene.write_text(PRESSED)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out),
                 "--no-progress"]) == 0
    force = json.loads((out / "summary.json").read_text())["obstacles"]
    force = next(iter(force.values()))["force"]
    pressed = 0
    for step in range(5):
        data = meshio.read(out / "points_{:04d}.vtu".format(step)).point_data
        total = (data["contact0_pressure"] * data["contact0_area"]).sum()
        expected = 0. if step == 0 else abs(force[step - 1][1])
        assert np.isclose(total, expected, rtol=1e-12, atol=0.)
        pressed += total > 0
    assert pressed


def test_a_resume_keeps_the_runs_series_every(tmp_path, monkeypatch,
                                              caplog):
    """Trial 111: started with ``--series-every 2``, the resume wrote
    every step, and its note said the series lacked the states the run
    had been asked to leave out.  The resume keeps the run's N (unless
    told another) and says nothing of the steps N leaves out."""
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    scene = tmp_path / "pressed.toml"
    scene.write_text(PRESSED)
    steps = int(re.search(r"steps = (\d+)", PRESSED).group(1))
    out = tmp_path / "every2"
    assert main(["run", str(scene), "--out", str(out), "--series-every",
                 "2", "--max-steps", "1", "--no-progress"]) == 0
    assert written(out) == ([0, 1], [0, 1])
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    wanted = sorted({0, 1, steps} | set(range(0, steps + 1, 2)))
    assert written(out) == (wanted, wanted)
    summary = json.loads((out / "summary.json").read_text())
    assert "series_note" not in summary
    assert "lacks" not in caplog.text
    # told another N, the resume takes it
    again = tmp_path / "again"
    assert main(["run", str(scene), "--out", str(again), "--series-every",
                 "2", "--max-steps", "1", "--no-progress"]) == 0
    assert main(["run", "--resume", str(again), "--series-every", "1",
                 "--no-progress"]) == 0
    assert written(again)[0] == list(range(steps + 1))
