from skfem_mpm.cli import main


def test_run_default_scene_prints_summary_and_plots(tmp_path, capsys):
    assert main(["run", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "error (2.28)" in out and "20 load steps" in out
    error = float(out.split("error (2.28)")[1].split()[0])
    assert 1e-2 < error < 5e-2          # 20 elements, 20 steps: plateau
    assert (tmp_path / "column_stress.png").stat().st_size > 10_000


def test_run_one_step_2d(tmp_path, capsys):
    assert main(["run", "--dim", "2", "--elements", "8", "--steps", "1",
                 "--out", str(tmp_path)]) == 0
    error = float(capsys.readouterr().out.split("error (2.28)")[1].split()[0])
    assert abs(error - 1 / 32) < 1e-12


def test_bad_arguments_exit_2(tmp_path, capsys):
    assert main(["run", "--elements", "0", "--out", str(tmp_path)]) == 2
    assert "--elements must be a positive integer" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
