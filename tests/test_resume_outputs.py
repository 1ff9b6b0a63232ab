"""A resumed run's ``[[outputs]]`` cover the whole run: their histories,
and what they give (a footing's peak pressure), equal an uninterrupted
run's bit for bit.  A trial's Mohr-Coulomb footing stopped after step 17
of 20 and resumed reported a peak pressure of 229.60 kPa, the largest of
steps 18-20, where the straight run's was 234.22 kPa (step 16), beside
an ``error`` and an obstacle's ``peak_force`` of the whole run."""
import json

import numpy as np
import pytest

import skfem_mpm.cli as cli
from skfem_mpm.cli import main
from skfem_mpm.scenes.checkpoint import (CHECKPOINT, CheckpointError,
                                         check_outputs, load_checkpoint,
                                         scene_digest)

# a small associated Mohr-Coulomb footing (half model) whose pressure
# peaks at step 6 of 10 (233.3 kPa) and falls to 219.1: a run stopped
# after step 7 resumes past its peak
FOOTING = """
name = "small footing"
units = "kN-m"
reference = "bearing_capacity"
[grid]
x = [0.0, 1.5, 18]
y = [0.0, 1.0, 12]
[[bodies]]
name = "clay"
region = { x = [0.0, 1.5], y = [0.0, 0.75] }
points_per_cell = 2
[bodies.material]
model = "mohr_coulomb"
E = 1e4
nu = 0.3
cohesion = 10.0
friction_angle = 25.0
dilation_angle = 25.0
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
displacement = [0.0, -0.04]
friction = 0.0
[[outputs]]
name = "peak pressure"
quantity = "footing_pressure"
component = "peak"
[[outputs]]
name = "footing force"
quantity = "obstacle_force"
component = "y"
obstacle = "footing"
[[outputs]]
name = "settlement"
quantity = "displacement"
component = "y"
at = [0.25, 0.75]
[[outputs]]
name = "stress under it"
quantity = "stress"
component = "yy"
region = { x = [0.0, 0.5], y = [0.5, 0.75] }
[solver]
method = "mpm"
steps = 10
antilocking = true
"""

# an elastic block squashed in finite deformation: its points' volumes
# change from step to step, so a mean over them weighed by the final
# volumes (the volumes where the first invocation stopped, in its
# checkpoint) would differ from the uninterrupted run's
BLOCK = """
name = "squashed block"
[grid]
x = [-0.5, 1.5, 4]
y = [0.0, 2.0, 4]
[[bodies]]
name = "block"
region = { x = [0.0, 1.0], y = [0.0, 1.0] }
points_per_cell = 2
material = { model = "linear_elastic", E = 1e3, nu = 0.3 }
[[supports]]
name = "base"
boundary = "bottom"
[[tractions]]
body = "block"
side = "top"
traction = [0.0, -100.0]
[[outputs]]
name = "mean stress"
quantity = "stress"
component = "yy"
region = { y = [0.5, 1.0] }
[[outputs]]
name = "mean settlement"
quantity = "displacement"
component = "y"
region = { y = [0.5, 1.0] }
[[outputs]]
name = "base reaction"
quantity = "reaction"
component = "y"
support = "base"
[solver]
method = "mpm"
kinematics = "finite"
steps = 4
"""

VOLATILE = ("wall_seconds", "timings", "compile_seconds")


def summary(out):
    data = json.loads((out / "summary.json").read_text())
    return {k: v for k, v in data.items() if k not in VOLATILE}


@pytest.fixture
def quick(monkeypatch):
    """No figures: the summary is what these tests read."""
    monkeypatch.setattr(cli, "plot_outputs", lambda *a, **k: None)


def run(scene, out, *options):
    assert main(["run", str(scene), "--out", str(out), "--no-progress",
                 "--no-series", *options]) == 0


def resume(out, *options):
    assert main(["run", "--resume", str(out), "--no-progress",
                 "--no-series", *options]) == 0


@pytest.fixture(scope="module")
def footing(tmp_path_factory):
    """The footing's scene file and its uninterrupted run."""
    folder = tmp_path_factory.mktemp("footing")
    scene = folder / "scene.toml"
    scene.write_text(FOOTING)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(cli, "plot_outputs", lambda *a, **k: None)
        run(scene, folder / "straight")
    return scene, folder / "straight"


def test_a_footing_resumed_past_its_peak_reports_the_whole_run(
        footing, tmp_path, quick):
    scene, straight = footing
    split = tmp_path / "split"
    run(scene, split, "--max-steps", "7")
    resume(split)
    a, b = summary(straight), summary(split)
    assert a == b
    peak = b["outputs"]["peak pressure"]
    values = peak["history"]["value"]
    assert peak["history"]["step"] == list(range(1, 11))
    assert int(np.argmax(values)) == 5          # step 6, before the stop
    assert peak["value"] == max(values) == pytest.approx(233.3, abs=0.1)
    assert max(values[7:]) < peak["value"] - 3.    # the resume's steps
    # a peak before the end: a collapse load (no warning that it is not)
    assert not [w for w in b["warnings"] if "not a collapse load" in w]
    assert b["bearing_capacity"]["peak_step"] == 6
    # the pressure is the obstacle's force over its width over the soil
    force = b["obstacles"]["footing"]["force"]
    assert values == pytest.approx([f[1] / 0.5 for f in force], rel=1e-14)
    for label in ("footing force", "settlement", "stress under it"):
        assert len(b["outputs"][label]["history"]["value"]) == 10, label
    assert b["outputs"]["footing force"]["history"]["value"] == [
        f[1] for f in force]


def test_a_finite_strain_mean_resumes_bit_for_bit(tmp_path, quick):
    scene, straight, split = (tmp_path / "scene.toml", tmp_path /
                              "straight", tmp_path / "split")
    scene.write_text(BLOCK)
    run(scene, straight)
    run(scene, split, "--max-steps", "2")
    stopped = load_checkpoint(split)
    assert sorted(stopped.outputs) == ["mean settlement", "mean stress"]
    assert stopped.outputs["mean stress"].shape == (2,)
    resume(split)
    a, b = summary(straight), summary(split)
    assert a == b
    history = b["outputs"]["mean stress"]["history"]
    assert history["step"] == [1, 2, 3, 4]
    assert history["value"][:2] == stopped.outputs["mean stress"].tolist()
    # the stress grows with the traction, ~100 at full load
    assert np.all(np.diff(history["value"]) < 0)
    assert history["value"][-1] == pytest.approx(-100., rel=0.1)


def drop_outputs(out):
    """``out``'s checkpoint as one written before it kept the point
    outputs' values."""
    with np.load(out / CHECKPOINT) as data:
        fields = {k: data[k] for k in data.files
                  if not k.startswith("output_")}
    with open(out / CHECKPOINT, "wb") as f:
        np.savez(f, **fields)


def test_an_older_checkpoint_s_point_outputs_start_at_its_resume(
        footing, tmp_path, quick, caplog):
    """A checkpoint written before the point outputs' values were kept:
    their histories start at the first resume (warned, and said in
    ``summary.json``'s warnings), through later resumes too; the forces'
    and the footing's pressure, from the reactions, cover the whole
    run."""
    scene, straight = footing
    split = tmp_path / "split"
    run(scene, split, "--max-steps", "7")
    drop_outputs(split)
    old = load_checkpoint(split)
    assert old.outputs is None and old.outputs_from == 7
    resume(split, "--max-steps", "1")
    kept = load_checkpoint(split)
    assert (kept.step, kept.outputs_from) == (8, 7)
    assert kept.outputs["settlement"].shape == (1,)
    resume(split)
    a, b = summary(straight), summary(split)
    said = ("was written before checkpoints kept the point outputs' "
            "values (2026-11-30): the histories of 'settlement', 'stress "
            "under it' in summary.json start at step 8")
    assert sum(said in w for w in b["warnings"]) == 1
    assert said in caplog.text
    for label in ("peak pressure", "footing force"):
        assert b["outputs"][label] == a["outputs"][label], label
    for label in ("settlement", "stress under it"):
        ours, theirs = b["outputs"][label], a["outputs"][label]
        assert ours["history"]["step"] == [8, 9, 10]
        assert ours["history"]["value"] == theirs["history"]["value"][7:]
        assert ours["value"] == theirs["value"]


def test_the_outputs_fields_are_checked(footing, tmp_path, quick):
    split = tmp_path / "split"
    run(footing[0], split, "--max-steps", "3")
    digest = scene_digest(split / "scene.toml")
    with np.load(split / CHECKPOINT) as data:
        fields = {k: data[k] for k in data.files}
    assert fields["output_labels"].tolist() == ["settlement",
                                                "stress under it"]
    assert fields["output_values"].shape == (2, 3)
    assert int(fields["output_from"]) == 0

    def refused(match, **changes):
        arrays = dict(fields)
        for name, value in changes.items():
            if value is None:
                del arrays[name]
            else:
                arrays[name] = value
        with open(split / CHECKPOINT, "wb") as f:
            np.savez(f, **arrays)
        with pytest.raises(CheckpointError, match=match):
            load_checkpoint(split, digest)
    values = fields["output_values"]
    refused(r"'output_values' has shape \(2, 2\), expected \(2, 3\)",
            output_values=values[:, :2])
    refused(r"'output_values' holds NaN", output_values=values * np.nan)
    refused(r"'output_values' has dtype float32",
            output_values=values.astype(np.float32))
    refused(r"'output_from' must lie in \[0, step 3\], got 4",
            output_from=np.array(4))
    refused(r"'output_labels' is missing \(the outputs' labels, values "
            r"and first step come together\)", output_labels=None)
    refused("'output_labels' names an output twice",
            output_labels=np.array(["settlement", "settlement"]))
    # another scene's outputs: the file was edited
    arrays = dict(fields, output_labels=np.array(["settlement", "other"]))
    with open(split / CHECKPOINT, "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(CheckpointError, match="'output_labels' names the "
                       r"outputs \['other', 'settlement'\] where the "
                       "scene's point outputs are"):
        check_outputs(split / CHECKPOINT, load_checkpoint(split, digest),
                      ["settlement", "stress under it"])
    assert main(["run", "--resume", str(split), "--no-progress"]) == 2
