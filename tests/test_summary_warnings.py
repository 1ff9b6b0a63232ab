"""A run's warnings are in its summary.json, not only on stderr."""
import json

from skfem_mpm.cli import WARNINGS_KEPT, KeptWarnings, main

SCENE = """
[grid]
x = [0.0, 2.0, 4]
y = [0.0, 2.0, 4]
[[bodies]]
region = {{ x = [0.0, 2.0], y = [0.0, 1.0] }}
points_per_cell = {ppc}
material = {{ model = "linear_elastic", E = 1e3, nu = 0.3 }}
[[supports]]
boundary = "bottom"
[gravity]
body_force = [0.0, -10.0]
[solver]
steps = 2
"""


def _summary(tmp_path, ppc):
    scene = tmp_path / "block{}.toml".format(ppc)
    scene.write_text(SCENE.format(ppc=ppc))
    out = tmp_path / "out{}".format(ppc)
    assert main(["run", str(scene), "--out", str(out), "--no-series",
                 "--no-progress"]) == 0
    return json.loads((out / "summary.json").read_text())


def test_a_completed_run_s_warnings_are_in_its_summary(tmp_path):
    """1 point per cell of Q1 completes, warned of its zero-energy modes:
    the summary says it (trial 114: a run that completed with a warning
    said it on stderr only); 2 points per cell warn of nothing."""
    warned = _summary(tmp_path, 1)
    assert warned["status"] == "completed"
    assert len(warned["warnings"]) == 1
    assert "1 point per cell and axis" in warned["warnings"][0]
    assert "zero-energy modes" in warned["warnings"][0]
    assert _summary(tmp_path, 2)["warnings"] == []


def test_the_largest_displacement_is_printed_to_four_digits(tmp_path,
                                                           capsys):
    """A trial's 4e-6 m printed as 0.0000 m: four significant digits."""
    summary = _summary(tmp_path, 2)
    line = [text for text in capsys.readouterr().out.splitlines()
            if "largest displacement" in text]
    assert line == ["  largest displacement      {:.4g} m".format(
        summary["max_displacement"])]
    assert not line[0].endswith(" 0.0000 m")


def test_kept_warnings_once_each_and_counted_past_the_limit():
    import logging
    kept = KeptWarnings()
    log = logging.getLogger("skfem_mpm.test_kept")
    log.addHandler(kept)
    try:
        for k in range(WARNINGS_KEPT + 5):
            log.warning("warning %d", k)
            log.warning("warning %d", k)          # said twice: kept once
        log.info("not a warning")
    finally:
        log.removeHandler(kept)
    assert len(kept.said) == WARNINGS_KEPT + 1
    assert kept.said[:2] == ["warning 0", "warning 1"]
    assert kept.said[-1] == "... and 5 more (the log has them)"
