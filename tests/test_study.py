"""Accuracy against cost: studies, serial and on a local Dask cluster."""
import json
from pathlib import Path

import numpy as np

import skfem_mpm.studies.study as study_module
from skfem_mpm.scenes.cli import EMBEDDED, main
from skfem_mpm.scenes.scene_file import load_scene
from skfem_mpm.studies.study import fitted_rate, study

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
COLUMN = load_scene(EMBEDDED)


def rates(rows, **fixed):
    rs = [r for r in rows if all(r[k] == v for k, v in fixed.items())]
    return fitted_rate([r["elements"] for r in rs], [r["error"] for r in rs])


def test_study_rates_agree_with_the_core_and_gimp_tests(tmp_path):
    rows = study(COLUMN, {"elements": [4, 8, 16, 32, 64, 128, 256],
                          "loadsteps": [1, 20]}, tmp_path / "mpm",
                 progress=False)
    assert abs(rates(rows, loadsteps=1) - 1.) <= .1      # as test_solver
    assert abs(rates(rows, loadsteps=20)) < .3           # the plateau
    gimp = study(load_scene(EXAMPLES / "column.toml"),
                 {"elements": [4, 8, 16, 32, 64], "method": ["cpgimp"]},
                 tmp_path / "gimp", progress=False)
    assert rates(gimp) >= 1.3                            # as test_finite
    for r in rows + gimp:
        assert r["failure"] == "" and r["points"] > 0
        assert r["wall_seconds"] >= sum(r["t_" + p] for p in
                                        ("locate", "assemble", "solve",
                                         "update", "check"))
    table = (tmp_path / "mpm" / "study.csv").read_text().splitlines()
    assert len(table) == 15 and "error" in table[0]


def test_dask_local_cluster_gives_the_serial_errors(tmp_path):
    from dask.distributed import Client         # the test extra has it
    assert Client is not None
    vary = {"elements": [4, 8, 16], "loadsteps": [1, 20]}
    serial = study(COLUMN, vary, tmp_path / "serial", progress=False)
    parallel = study(COLUMN, vary, tmp_path / "dask", workers=2,
                     progress=False)
    assert [r["error"] for r in serial] == [r["error"] for r in parallel]
    assert json.loads((tmp_path / "dask" / "study.json").read_text()
                      )["workers"] == 2


def test_interrupted_study_resumes_without_rerunning(tmp_path, monkeypatch):
    vary = {"elements": [4, 8], "ppc": [1, 2]}
    study(COLUMN, vary, tmp_path, progress=False)
    saved = json.loads((tmp_path / "study.json").read_text())
    saved["rows"] = saved["rows"][:3]               # as if interrupted
    (tmp_path / "study.json").write_text(json.dumps(saved))
    calls = []
    original = study_module.run_case
    monkeypatch.setattr(study_module, "run_case",
                        lambda scene, params: calls.append(params) or
                        original(scene, params))
    rows = study(COLUMN, vary, tmp_path, progress=False)
    assert calls == [{"elements": 8, "ppc": 2}]
    assert [(r["elements"], r["ppc"]) for r in rows] == [(4, 1), (4, 2),
                                                         (8, 1), (8, 2)]


def test_study_command(tmp_path, capsys):
    assert main(["study", str(EMBEDDED), "--vary", "elements=4,8,16",
                 "--vary", "loadsteps=1", "--out", str(tmp_path),
                 "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "rate loadsteps=1: 1.00" in out
    for name in ("error_vs_elements.png", "error_vs_time.png",
                 "time_vs_points.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    assert main(["study", str(EMBEDDED), "--vary", "colour=1"]) == 2
    assert "cannot vary 'colour'" in capsys.readouterr().err
    assert main(["study", str(EMBEDDED), "--vary", "elements=a"]) == 2
    assert main(["study", str(EMBEDDED), "--vary", "method=fast"]) == 2


def test_elastica_reference(tmp_path):
    rows = study(load_scene(EXAMPLES / "cantilever.toml"),
                 {"loadsteps": [50]}, tmp_path, progress=False)
    assert rows[0]["error"] < .02
    assert np.isfinite(rows[0]["peak_mb"])


def test_study_varies_the_right_hand_side(tmp_path, capsys):
    """``--vary rhs=residual,increment`` runs both schemes of linear steps
    on the column: with 20 steps on 64 elements the seed's literal scheme
    (load increment) has under a third of the residual scheme's error; a
    value outside the two is refused before any case runs."""
    assert main(["study", str(EMBEDDED), "--vary", "elements=64", "--vary",
                 "loadsteps=20", "--vary", "rhs=residual,increment",
                 "--out", str(tmp_path), "--no-progress"]) == 0
    rows = json.loads((tmp_path / "study.json").read_text())["rows"]
    error = {r["rhs"]: r["error"] for r in rows}
    assert error["increment"] < error["residual"] / 3
    assert main(["study", str(EMBEDDED), "--vary", "rhs=both", "--out",
                 str(tmp_path / "bad")]) == 2
    assert "rhs must be among" in capsys.readouterr().err
