"""Units of a scene's output labels (a new-user trial in kPa read
``sigma_yy (Pa)`` on its colour bar): the scene key ``units`` names the
system its numbers are in, and every label follows it
(:mod:`skfem_mpm.scenes.units`); nothing is converted."""
import json

import pytest

from skfem_mpm.cli import main
from skfem_mpm.errors import InvalidInputError, SceneError
from skfem_mpm.scenes import plot
from skfem_mpm.scenes.quantities import Quantity
from skfem_mpm.scenes.scene_file import parse_scene, tomllib
from skfem_mpm.scenes.units import SHARED, SYSTEMS, check_units, unit

# a rigid footing pressed into von Mises soil under its weight, with a
# support's reaction and a stress among its outputs, in 2 steps
SCENE = """
name = "units-footing"
{units}
[grid]
x = [0.0, 1.0, 8]
y = [0.0, 0.625, 5]
[[bodies]]
name = "soil"
region = {{ x = [0.0, 1.0], y = [0.0, 0.5] }}
material = {{ model = "von_mises", E = 1e4, nu = 0.3, yield_stress = 100.0 }}
[[bodies]]
name = "footing"
region = {{ x = [0.0, 0.25], y = [0.5, 0.625] }}
material = {{ model = "linear_elastic", E = 1e6, nu = 0.3 }}
rigid = {{ displacement = [0.0, -0.01], rough = false }}
[[supports]]
name = "base"
boundary = "bottom"
[[supports]]
boundary = "left"
components = ["x"]
[[supports]]
boundary = "right"
components = ["x"]
[gravity]
body_force = [0.0, -20.0]
[[outputs]]
quantity = "reaction"
support = "base"
component = "y"
[[outputs]]
quantity = "stress"
component = "yy"
at = [0.5, 0.25]
[solver]
steps = 2
"""


def test_the_table_gives_each_kind_per_system_and_dimension():
    assert SYSTEMS == ("SI", "kN-m")
    assert [unit(k, "kN-m") for k in ("length", "force", "stress",
                                      "unit_weight", "density", "mass",
                                      "energy", "time")] == [
        "m", "kN", "kPa", "kN/m^3", "t/m^3", "t", "kJ", "s"]
    assert [unit("force", "SI", d) for d in (1, 2, 3)] == [
        "N/m^2", "N/m", "N"]
    assert unit("energy", "kN-m", 2) == "kJ/m"
    assert unit("stress", "SI", 2) == "Pa"        # not per thickness
    # figures label lengths and times without asking for the system
    assert {"length", "time"} <= set(SHARED)
    assert "stress" not in SHARED and "force" not in SHARED
    assert Quantity("reaction", "y", support="base").unit(2, "kN-m") == \
        "kN/m"
    with pytest.raises(InvalidInputError, match="units must be one of"):
        check_units("kPa")


def test_an_unknown_system_is_refused_before_any_work(tmp_path):
    with pytest.raises(SceneError, match=r"units: must be one of SI, kN-m, "
                       r"got 'kPa'"):
        parse_scene(tomllib.loads(SCENE.format(units='units = "kPa"')))
    path = tmp_path / "scene.toml"
    path.write_text(SCENE.format(units='units = "kN"'))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out),
                 "--no-progress"]) == 2
    assert not out.exists()
    assert parse_scene(tomllib.loads(SCENE.format(units=""))).units == "SI"


def run(tmp_path, monkeypatch, units: str):
    """The summary and the figures' label strings of a run of the scene
    with the ``units`` line: ``{file: [x label, y label, colour bar]}``."""
    labels, save = {}, plot.save_figure

    def keep(fig, path, *args, **kwargs):
        labels[path.name] = [t for ax in fig.axes
                             for t in (ax.get_xlabel(), ax.get_ylabel())]
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", keep)
    folder = tmp_path / (units.split('"')[1] if units else "default")
    folder.mkdir()
    path = folder / "scene.toml"
    path.write_text(SCENE.format(units=units))
    assert main(["run", str(path), "--out", str(folder / "out"),
                 "--no-progress", "--no-series"]) == 0
    return json.loads((folder / "out" / "summary.json").read_text()), labels


def test_kn_m_labels_every_figure_and_the_summary_in_kpa(
        tmp_path, monkeypatch):
    kn, labels = run(tmp_path, monkeypatch, 'units = "kN-m"')
    assert kn["units"]["system"] == "kN-m"
    assert kn["units"]["reactions"] == kn["units"]["force"] == "kN/m"
    assert kn["units"]["max_displacement"] == "m"
    assert [q["unit"] for q in kn["outputs"].values()] == ["kN/m", "kPa"]
    assert labels["final_stress.png"][-1] == "sigma_yy (kPa)"
    assert labels["final_von_mises.png"][-1] == "von Mises stress (kPa)"
    assert labels["rigid_bodies.png"][:2] == [
        "displacement along the motion (m)", "force along the motion "
        "(kN/m)\n(the weight of the points in its cells taken off)"]
    assert labels["deformed_shape.png"][:2] == ["x (m)", "y (m)"]
    text = "\n".join(t for f in labels.values() for t in f)
    assert "(Pa)" not in text and "(N/m)" not in text
    # the default is SI, and the numbers are the same: labels only
    si, labels = run(tmp_path, monkeypatch, "")
    assert si["units"]["system"] == "SI"
    assert si["units"]["reactions"] == "N/m"
    assert labels["final_stress.png"][-1] == "sigma_yy (Pa)"
    for key in ("reactions", "max_displacement", "rigid_bodies",
                "load_factor", "max_residual"):
        assert kn[key] == si[key]
    assert [q["value"] for q in kn["outputs"].values()] == [
        q["value"] for q in si["outputs"].values()]
