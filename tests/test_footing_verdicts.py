"""What a footing run says of its peak (a geotechnical engineer's trial):
a soil that never failed, its strength in Pa where the scene's stresses
are in kPa, reported "peak pressure error 9.96e-01" and nothing else;
now its strength above its stiffness is warned of, a peak at the last
step of a curve still rising is no collapse load (warned, in
``summary.json``'s ``warnings``), and the error has its side."""
import json

import pytest

import skfem_mpm.cli as cli
from skfem_mpm import Obstacle
from skfem_mpm.cli import main
from skfem_mpm.scenes.footing import STILL_RISING, still_rising

# a smooth footing (half model) on von Mises clay whose yield stress was
# given in Pa, sqrt(3) x 20000, where the scene is in kPa (E = 1e4 kPa)
IN_PA = """
name = "clay in Pa"
units = "kN-m"
reference = "bearing_capacity"
[grid]
x = [0.0, 1.5, 6]
y = [0.0, 1.0, 4]
[[bodies]]
name = "clay"
region = { x = [0.0, 1.5], y = [0.0, 0.75] }
points_per_cell = 2
material = { model = "von_mises", E = 1e4, nu = 0.3, yield_stress = 34641.0 }
[[supports]]
name = "base"
boundary = "bottom"
[[supports]]
name = "sides"
boundary = ["left", "right"]
components = ["x"]
[[obstacles]]
name = "footing"
box = { x = [-0.3, 0.5], y = [0.75, 1.0] }
displacement = [0.0, -0.01]
friction = 0.0
[solver]
method = "mpm"
steps = 4
antilocking = true
"""


def test_a_soil_that_never_failed_is_said_to(tmp_path, monkeypatch,
                                             capsys):
    monkeypatch.setattr(cli, "plot_outputs", lambda *a, **k: None)
    scene, out = tmp_path / "scene.toml", tmp_path / "out"
    scene.write_text(IN_PA)
    assert main(["run", str(scene), "--out", str(out), "--no-progress",
                 "--no-series"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    warnings = summary["warnings"]
    assert "body 'clay': its yield_stress 34641 kPa exceeds its Young's " \
        "modulus E = 10000 kPa" in warnings[0]
    assert "a unit slipped? Every stress of the scene is in kPa " \
        "(units = 'kN-m')" in warnings[0]
    # elastic: each of the 4 steps adds about as much
    rising = [w for w in warnings if "not a collapse load" in w]
    assert len(rising) == 1
    assert rising[0].startswith(
        "clay in Pa: not a collapse load: the footing pressure peaks at "
        "the last step, 232.032 kPa, and rose 26.51% over that step (more "
        "than 0.5%)")
    footing = summary["bearing_capacity"]
    # N_c c = (2 + pi) 20000: the pressure 0.23% of it, below
    assert footing["limit_pressure"] == pytest.approx(102832., rel=1e-5)
    assert footing["peak_step"] == 4
    assert footing["peak_pressure"] == pytest.approx(232.032, rel=1e-5)
    assert footing["signed_error"] == -summary["error"]
    assert footing["signed_error"] == pytest.approx(-0.99774, abs=1e-5)
    assert summary["units"]["bearing_capacity"] == \
        "kPa (peak_step, signed_error: -)"
    printed = capsys.readouterr().out
    assert "  peak against N_c c        232.032 kPa at step 4, 99.77% " \
        "below N_c c = 102832 kPa\n" in printed


@pytest.mark.parametrize("pressure, rises", [
    ([50., 100., 104.], True),              # still rising, 3.8%
    ([50., 100., 100.1], False),            # a plateau
    ([50., 104., 100.], False),             # the peak before the end
    ([100. * (1 - STILL_RISING) + 1e-9, 100.], False),
    ([99.4, 100.], True),
    ([0., -5.], False),                     # pulled: no pressure
    ([], False)])
def test_a_peak_at_the_last_step_of_a_rising_curve(pressure, rises):
    words = still_rising(pressure, "kPa")
    assert bool(words) == rises
    if rises:
        assert "peaks at the last step, 100 kPa" in words or \
            "104 kPa" in words


def test_the_curve_is_against_settlement_over_the_whole_width(
        tmp_path, monkeypatch):
    """A trial's figure put the settlement over the width of the footing
    over the soil, ``s / (B / 2)`` in a half model, where engineers read
    ``s / B``: its axis is ``s / B`` now, and says what ``B`` is."""
    from skfem_mpm.scenes import plot
    from skfem_mpm.scenes.footing import scene_footing
    from skfem_mpm.scenes.scene_file import load_scene
    monkeypatch.setattr(cli, "plot_outputs", lambda *a, **k: None)
    path, out = tmp_path / "scene.toml", tmp_path / "out"
    path.write_text(IN_PA)
    assert main(["run", str(path), "--out", str(out), "--no-progress",
                 "--no-series"]) == 0
    curves = json.loads((out / "summary.json").read_text())["obstacles"]
    drawn = []
    monkeypatch.setattr(plot, "save_figure", lambda fig, where: (
        drawn.append((fig.axes[0].get_xlabel(),
                      fig.axes[0].lines[0].get_xdata()))))
    scene = load_scene(path)
    footing = scene_footing(scene)
    assert (footing.width, footing.half, footing.B) == (.5, True, 1.)
    cli.plot_bearing_capacity(scene, curves, tmp_path / "b.png")
    label, x = drawn.pop()
    # pushed 0.01 m: s / B = 0.01 with B = 1 m, twice the 0.5 m modelled
    assert x[-1] == pytest.approx(.01, rel=1e-12)
    assert label == ("settlement s / footing width B (-), B = 1 m\n(twice "
                     "the 0.5 m of this half model's footing, from its "
                     "symmetry line)")
    # a footing with soil on both sides is whole: B its width
    whole = load_scene(path)
    whole.obstacles[0] = Obstacle(box=[[.5, 1.], [.75, 1.]],
                                  displacement=[0., -.01], friction=0.,
                                  name="footing")
    footing = scene_footing(whole)
    assert (footing.width, footing.half, footing.B) == (.5, False, .5)
    cli.plot_bearing_capacity(whole, curves, tmp_path / "b.png")
    label, x = drawn.pop()
    assert x[-1] == pytest.approx(.02, rel=1e-12)
    assert label == ("settlement s / footing width B (-), B = 0.5 m\n(the "
                     "width of the footing over the soil)")


@pytest.mark.parametrize("command", ["run", "safety"])
def test_a_place_outside_the_points_names_the_file_and_output(
        tmp_path, capsys, command):
    """A trial's ``at`` outside the points was refused without the file
    and ``outputs[K]`` every other message of a scene file names."""
    path = tmp_path / "at_outside.toml"
    path.write_text(IN_PA + '[[outputs]]\nquantity = "displacement"\n'
                    'component = "y"\nat = [10.0, 0.75]\n')
    assert main([command, str(path), "--out", str(tmp_path / "out"),
                 "--no-progress"]) == 2
    assert capsys.readouterr().err == (
        "skfem-mpm: {}: outputs[0]: displacement y at (10, 0.75): [10.0, "
        "0.75] lies outside the points (initial positions [0.0625, 0.0625]"
        " to [1.4375, 0.6875])\n".format(path))
    assert not (tmp_path / "out").exists()


def test_a_flat_mpm_footing_s_penalty_growth_gives_its_own_reason(
        tmp_path, monkeypatch):
    """A trial's standard-MPM footing (flat box, 30 x 17 cells) grew its
    penalty at step 15, told of "GIMP's corners on a curved face": its
    worst corner lay by the footing's edge.  The reason is its case's."""
    from skfem_mpm.solve.contact import growth_reason
    monkeypatch.setattr(cli, "plot_outputs", lambda *a, **k: None)
    text = IN_PA
    for old, new in (("x = [0.0, 1.5, 6]", "x = [0.0, 3.0, 30]"),
                     ("y = [0.0, 1.0, 4]", "y = [0.0, 1.7, 17]"),
                     ("x = [0.0, 1.5], y = [0.0, 0.75]",
                      "x = [0.0, 3.0], y = [0.0, 1.5]"),
                     ("points_per_cell = 2", "points_per_cell = 3"),
                     ("y = [0.75, 1.0]", "y = [1.5, 1.7]"),
                     ("[0.0, -0.01]", "[0.0, -0.03]"), ("steps = 4",
                                                        "steps = 20")):
        assert old in text
        text = text.replace(old, new)
    path, out = tmp_path / "scene.toml", tmp_path / "out"
    path.write_text(text)
    assert main(["run", str(path), "--out", str(out), "--no-progress",
                 "--no-series"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    grown = [w for w in summary["warnings"] if "the penalty grown" in w]
    assert len(grown) == 1 and summary["counters"][
        "contact_penalty_growths"] == 1
    assert grown[0].endswith("obstacle 'footing' to 100 ({})".format(
        growth_reason(False, False)))
    assert "GIMP" not in grown[0]
