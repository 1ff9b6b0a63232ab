"""Nothing lost: a run interrupted anywhere (``--max-steps``, SIGKILL at
random moments, repeatedly, across cut-backs) and resumed ends
bit-identical to the uninterrupted run, with a summary and a series that
cover the whole run; a checkpoint is checked field by field and against its
scene."""
import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

from skfem_mpm.scenes.checkpoint import (CHECKPOINT, HISTORY_KEYS,
                                         CheckpointError, load_checkpoint)
from skfem_mpm.cli import main
from skfem_mpm.scenes.io import TEMPORARY_PREFIX

# a finite-deformation cpGIMP block sheared and squashed by a traction,
# with at most 3 Newton iterations a step: the 3 load steps converge in
# cut-back sub-steps (a load factor that is not step / nsteps), the first
# failure switching the ghost penalty on
CUT_BACK_SCENE = """
name = "cut-back block"
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
traction = [30.0, -100.0]
[solver]
method = "cpgimp"
kinematics = "finite"
steps = 3
max_iterations = 3
"""

VOLATILE = ("wall_seconds", "timings", "compile_seconds")
OPTIONAL_FIELDS = ("tied_traction", "contact_sides", "series_every",
                   "series_steps",
                   "warnings")


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    """The uninterrupted run."""
    folder = tmp_path_factory.mktemp("resume")
    scene = folder / "scene.toml"
    scene.write_text(CUT_BACK_SCENE)
    out = folder / "straight"
    assert main(["run", str(scene), "--out", str(out), "--no-progress"]) == 0
    return scene, out


def summary(out):
    data = json.loads((out / "summary.json").read_text())
    return {k: v for k, v in data.items() if k not in VOLATILE}


def assert_same_run(a, b):
    """Final points bit-identical, the summary equal (but for timings; the
    counters too: a resumed invocation's location of the checkpoint's
    points, which the checkpoint's step had counted, is not counted again)
    and the series listing every converged step once."""
    sa, sb = summary(a), summary(b)
    assert sa["counters"]["locate"] == sa["steps_run"] + 1
    assert sa == sb
    last = "points_{:04d}.vtu".format(sa["steps_run"])
    pa, pb = meshio.read(a / last), meshio.read(b / last)
    assert np.array_equal(pa.points, pb.points)
    assert pa.point_data.keys() == pb.point_data.keys()
    for name in pa.point_data:
        assert np.array_equal(pa.point_data[name], pb.point_data[name]), name
    for series in ("points.pvd", "grid.pvd"):
        assert (a / series).read_text() == (b / series).read_text()
    assert not list(b.glob(TEMPORARY_PREFIX + "*"))


@pytest.mark.slow
def test_the_scene_cuts_back(straight):
    """The premise: more converged sub-steps than load steps, and the
    ghost penalty switched on by a failed step (it must stay on across
    resumes)."""
    data = summary(straight[1])
    assert data["status"] == "completed" and data["steps"] == 3
    assert data["steps_run"] > 3 * 3
    assert data["counters"]["ghost_from_step"] == 1


@pytest.mark.slow
def test_repeated_resumes_after_cut_backs_are_bit_identical(straight,
                                                             tmp_path):
    scene, reference = straight
    out = tmp_path / "split"
    assert main(["run", str(scene), "--out", str(out), "--max-steps", "3",
                 "--checkpoint-every", "2", "--no-progress"]) == 0
    factors = [load_checkpoint(out).load_factor]
    resumes = 0
    def stopped():
        return json.loads((out / "summary.json").read_text())[
            "status"] != "completed"

    while stopped() and resumes < 20:
        assert main(["run", "--resume", str(out), "--max-steps", "3",
                     "--no-progress"]) == 0
        resumes += 1
        if stopped():
            factors.append(load_checkpoint(out).load_factor)
    # the checkpoints stood between load steps (after cut-backs)
    assert any(abs(f * 3 - round(f * 3)) > 1e-9 for f in factors)
    assert len(factors) >= 4
    assert_same_run(reference, out)


@pytest.mark.slow
def test_sigkill_at_random_moments_then_resume_is_bit_identical(straight,
                                                                tmp_path):
    """SIGKILL after a random delay (fixed seed), resume (killed again at
    random), until one invocation completes; a kill before the first
    checkpoint starts the run again."""
    scene, reference = straight
    out = tmp_path / "killed"
    rng = np.random.default_rng(20261123)
    command = [sys.executable, "-c", "import sys; from skfem_mpm.cli "
               "import main; sys.exit(main())"]
    kills, returncode = 0, None
    for attempt in range(12):
        resumable = (out / CHECKPOINT).exists()
        args = ["run", "--resume", str(out)] if resumable else [
            "run", str(scene), "--out", str(out)]
        process = subprocess.Popen(
            command + args + ["--checkpoint-every", "1", "--no-progress"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        if attempt < 8:                      # the last attempts run through
            try:
                returncode = process.wait(timeout=rng.uniform(.4, 1.6))
            except subprocess.TimeoutExpired:
                os.kill(process.pid, signal.SIGKILL)
                process.wait()
                kills += 1
                continue
        else:
            returncode = process.wait(timeout=120)
        assert returncode == 0, process.stderr.read().decode()
        break
    assert returncode == 0 and kills >= 2
    assert_same_run(reference, out)


@pytest.mark.slow
def test_stale_and_corrupted_checkpoints_are_refused(straight, tmp_path):
    """A checkpoint of another scene, and a campaign of corruptions
    (truncation, flipped bytes, missing fields, wrong dtypes, impossible
    values): each refused with exit code 2 and one line naming the file,
    never a traceback, never a run on wrong state."""
    scene, reference = straight
    out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--max-steps", "4",
                 "--no-progress"]) == 0
    good = (out / CHECKPOINT).read_bytes()
    text = (out / "scene.toml").read_text()
    (out / "scene.toml").write_text(text.replace("100.0", "101.0"))
    with pytest.raises(CheckpointError, match="another scene"):
        load_checkpoint(out, _digest(out))
    assert main(["run", "--resume", str(out), "--no-progress"]) == 2
    (out / "scene.toml").write_text(text)

    with np.load(out / CHECKPOINT) as data:
        fields = {k: data[k] for k in data.files}

    def rewrite(**changes):
        arrays = dict(fields)
        for name, value in changes.items():
            if value is None:
                del arrays[name]
            else:
                arrays[name] = value
        with open(out / CHECKPOINT, "wb") as f:
            np.savez(f, **arrays)

    refused = [lambda n=n: (out / CHECKPOINT).write_bytes(good[:n])
               for n in (0, 10, len(good) // 2, len(good) - 1)]
    # every field but those whose absence is an older checkpoint's: the
    # mark of tied obstacles' tractions (refused only for a run with tied
    # obstacles: test_a_tied_checkpoint_written_before_its_traction_...),
    # the series' N and steps (read as every step)
    refused += [lambda n=name: rewrite(**{n: None}) for name in fields
                if name not in OPTIONAL_FIELDS]
    n = fields["points_x"].shape[1]
    for change in (dict(step=np.array(99)), dict(step=np.array(2.5)),
                   dict(nsteps=np.array(3.)), dict(nsteps=np.array(0)),
                   dict(load_factor=np.array(1.5)),
                   dict(load_factor=np.array(np.nan)),
                   dict(increment=np.array(0.)),
                   dict(points_volume0=np.zeros(n)),
                   dict(points_x=fields["points_x"].astype(np.float32)),
                   dict(points_x=np.full_like(fields["points_x"], 1e9)),
                   dict(points_body=np.full(n, .5)),
                   dict(points_F=-fields["points_F"]),
                   dict(domain0=np.array("x")),
                   dict(history=fields["history"][:, :3]),
                   dict(reactions=fields["reactions"][:1]),
                   dict(counter_values=np.array(["x"] * fields[
                       "counter_values"].size)),
                   dict(scene_sha256=np.array(3))):
        refused.append(lambda c=change: rewrite(**c))
    for k, corrupt in enumerate(refused):
        corrupt()
        code, _ = _resume(out)
        assert code == 2, k
    # the field changed is the one named: a step beyond the history of
    # steps 1 to 4 (and their reactions) blamed the history (trial 114);
    # a history cut short is the history's
    rewrite(step=np.array(99))
    with pytest.raises(CheckpointError, match="'step' is 99 but the "
                       "history and the reactions hold steps 1 to 4"):
        load_checkpoint(out, _digest(out))
    rewrite(history=fields["history"][:3])
    with pytest.raises(CheckpointError, match=r"'history' has shape \(3, "):
        load_checkpoint(out, _digest(out))
    # a flipped byte is caught by the zip's CRC-32 or its structure; one
    # in a part nothing reads may pass, and must then change nothing
    rng = np.random.default_rng(7)
    passed = 0
    for at in rng.integers(len(good), size=16):
        flipped = bytearray(good)
        flipped[at] ^= 0xFF
        (out / CHECKPOINT).write_bytes(bytes(flipped))
        code, trial = _resume(out)
        assert code in (0, 2)
        if code == 0:
            passed += 1
            assert_same_run(reference, trial)
    # (5 of these 16 since the series' fields joined the file: a flip in
    # the zip's bytes nothing reads, each run bit-identical above)
    assert passed <= 6
    # a field of Python objects (pickled): refused in the package's words,
    # not numpy's advice to load it unsafely if one trusts the file
    rewrite(points_x=np.array([None, 1], dtype=object))
    with pytest.raises(CheckpointError, match="holds pickled") as caught:
        load_checkpoint(out, _digest(out))
    assert "allow_pickle" not in str(caught.value)
    (out / CHECKPOINT).write_bytes(good)
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert_same_run(reference, out)


def _digest(out):
    from skfem_mpm.scenes.checkpoint import scene_digest
    return scene_digest(out / "scene.toml")


def _resume(out):
    """Resume a copy of ``out`` (a refused resume must leave it as it
    was): the exit code (2 for a refusal; any exception fails the test)
    and the copy."""
    import shutil
    trial = out.parent / "trial"
    shutil.rmtree(trial, ignore_errors=True)
    shutil.copytree(out, trial)
    return main(["run", "--resume", str(trial), "--no-progress"]), trial


def non_associated_footing() -> str:
    """The shipped strip footing, coarser, shorter, with non-associated
    flow (dilation 5 degrees, friction 20): its tangents are not
    symmetric, and Pardiso factorises them as general matrices, whose
    analysis holds a scaling computed from the values."""
    text = (Path(__file__).parents[1] / "examples"
            / "strip_footing.toml").read_text()
    for old, new in (('reference = "bearing_capacity"\n', ""),
                     ("x = [0.0, 2.0, 64]", "x = [0.0, 2.0, 32]"),
                     ("y = [0.0, 1.0625, 34]", "y = [0.0, 1.0625, 17]"),
                     ("dilation_angle = 20.0", "dilation_angle = 5.0"),
                     ("steps = 20", 'steps = 8\nlinear = "pypardiso"')):
        assert old in text
        text = text.replace(old, new)
    return text


@pytest.mark.slow
def test_resume_with_pardiso_on_non_symmetric_tangents_is_bit_identical(
        tmp_path):
    """Pardiso analyses a general matrix anew at every load step, so that
    a resumed run factorises as the uninterrupted one (before, the
    uninterrupted run kept an analysis from an earlier step: stresses
    differed by 6e-13 after the resume)."""
    from skfem_mpm.solve.backends import available_solvers
    assert "pypardiso" in available_solvers()           # the test extra
    scene = tmp_path / "scene.toml"
    scene.write_text(non_associated_footing())
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main(["run", str(scene), "--out", str(straight),
                 "--no-progress"]) == 0
    assert summary(straight)["counters"]["return_maps"] > 0
    assert main(["run", str(scene), "--out", str(split), "--max-steps", "3",
                 "--no-progress"]) == 0
    assert main(["run", "--resume", str(split), "--no-progress"]) == 0
    assert_same_run(straight, split)


def listed(out, series):
    """The files a PVD collection lists, in order."""
    return re.findall(r'file="([^"]+)"', (out / series).read_text())


@pytest.mark.slow
def test_ctrl_c_inside_a_steps_grid_vtu_then_resume(straight, tmp_path,
                                                    monkeypatch, capsys):
    """Issue 30: Ctrl-C between the points and the grid VTU of a step
    checkpointed the step anyway, so that the resumed series lacked
    grid_N.vtu while grid.pvd listed it.  A step counts as written only
    once both its VTUs are: the checkpoint holds the step before, the
    resume writes the interrupted step again, and every file either PVD
    lists exists and equals the uninterrupted run's."""
    scene, reference = straight
    out = tmp_path / "cut"
    write = meshio.write

    def interrupted(path, *args, **kwargs):
        if "grid_0004" in str(path):
            raise KeyboardInterrupt
        return write(path, *args, **kwargs)
    monkeypatch.setattr(meshio, "write", interrupted)
    assert main(["run", str(scene), "--out", str(out), "--no-progress"]) \
        == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--resume {}".format(out) in err[0], err
    assert (out / "points_0004.vtu").exists()            # half a step
    assert not (out / "grid_0004.vtu").exists()
    assert load_checkpoint(out).step == 3
    assert summary(out)["last_converged_step"] == 3
    monkeypatch.setattr(meshio, "write", write)
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    for series in ("points.pvd", "grid.pvd"):
        names = listed(out, series)
        assert names == listed(reference, series)
        for name in names:
            a, b = meshio.read(reference / name), meshio.read(out / name)
            assert np.array_equal(a.points, b.points), name
            for field in a.point_data:
                assert np.array_equal(a.point_data[field],
                                      b.point_data[field]), (name, field)
    assert_same_run(reference, out)


@pytest.mark.slow
def test_ctrl_c_while_saving_a_checkpoint_keeps_the_previous_one(
        straight, tmp_path, monkeypatch, capsys):
    """Issue 30: Ctrl-C during the checkpoint write once printed a zipfile
    traceback.  Interrupted inside np.savez (and again when the
    interruption tries to save the step), the run leaves the previous
    checkpoint whole, no partial file, one line naming the step it
    resumes from; the resume ends where the uninterrupted run does."""
    scene, reference = straight
    out = tmp_path / "cut"
    savez, calls = np.savez, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) > 1:
            raise KeyboardInterrupt
        return savez(*args, **kwargs)
    monkeypatch.setattr(np, "savez", interrupted)
    assert main(["run", str(scene), "--out", str(out), "--no-progress",
                 "--checkpoint-every", "2"]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "while saving the checkpoint of step 4" in err[0]
    assert "the checkpoint of step 2 stands" in err[0]
    assert "--resume {}".format(out) in err[0]
    monkeypatch.setattr(np, "savez", savez)
    assert load_checkpoint(out).step == 2
    assert not list(out.glob(TEMPORARY_PREFIX + "*"))
    data = summary(out)
    assert data["status"] == "interrupted" and data["checkpoint"]
    assert data["checkpoint_step"] == 2
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert_same_run(reference, out)



@pytest.mark.parametrize("names, dated", [
    (["contact_body_corner{}{}".format(a, c) for a in range(2)
      for c in range(4)], True),
    (["contact_body_corner00", "eps_p"], False),
    (["contact_body1_r{}{}".format(a, c) for a in range(2)
      for c in range(4)], True),
    (["contact_body1_r00", "contact_body1_p00"], False),
])
def test_a_checkpoint_without_the_contact_corners_says_why(names, dated):
    """A B-spline contact's corners and the pressures' rates between
    bodies became point state: a checkpoint written before lacks them,
    and the refusal says so (only where they are all it lacks), first,
    and counts the names it lacks, naming a few (a trial's named some 70
    before its reason, 2.9 kB on one line)."""
    from types import SimpleNamespace
    from skfem import MeshQuad
    from skfem_mpm import seed_points
    from skfem_mpm.scenes.checkpoint import check_against
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    points = seed_points(mesh, 2)
    with pytest.raises(CheckpointError, match="'state_\\*'") as caught:
        check_against("ckpt", SimpleNamespace(points=points,
                                              domain0=points.domain),
                      points, names, mesh)
    text = str(caught.value)
    assert ("run the scene again from its start" in text) == dated
    assert "it lacks {} ({}".format(len(names), min(names)) in text
    assert not dated or text.index("run the scene again") < text.index(
        "it lacks")
    assert names[-1] not in text or len(names) <= 4


def test_a_checkpoint_whose_points_moved_names_the_file_and_field():
    """A checkpoint whose positions were moved 1e-3 from their initial
    ones plus their displacement is refused naming the file and
    ``points_x`` (the run's refusal said how to seed moved points, and
    named no file, a user trial)."""
    from types import SimpleNamespace
    from skfem import MeshQuad
    from skfem_mpm import seed_points
    from skfem_mpm.scenes.checkpoint import check_against
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    points = seed_points(mesh, 2)
    saved = SimpleNamespace(points=points.copy(), domain0=points.domain)
    saved.points.displacement[1] = -.01
    saved.points.x = saved.points.x0 + saved.points.displacement
    check_against("ckpt", saved, points, [], mesh)      # as a run left it
    saved.points.x = saved.points.x + 1e-3
    with pytest.raises(CheckpointError, match="ckpt: field 'points_x' puts "
                       "{} point.* by 0.001".format(points.n)):
        check_against("ckpt", saved, points, [], mesh)


@pytest.mark.slow
def straight_and_resumed(scene):
    """Run the scene file ``scene`` straight through, and again stopped
    after its first step and resumed: the two output folders (beside the
    scene)."""
    straight, resumed = scene.parent / "straight", scene.parent / "resumed"
    assert main(["run", str(scene), "--out", str(straight),
                 "--no-progress"]) == 0
    assert main(["run", str(scene), "--out", str(resumed), "--no-progress",
                 "--max-steps", "1"]) == 0
    assert main(["run", "--resume", str(resumed), "--no-progress"]) == 0
    return straight, resumed


@pytest.mark.slow
def test_a_small_strain_plastic_run_resumes(tmp_path):
    """A user trial: once small strain kept the points' rotation as point
    state, every small-strain run's resume was refused ("holds the
    internal variables ['equivalent_plastic_strain', 'rotation'], the
    scene's materials have ['equivalent_plastic_strain']").  Resumed after
    its first step it ends bit-identical to the run straight through."""
    scene = tmp_path / "scene.toml"
    scene.write_text(CUT_BACK_SCENE.replace(
        '"linear_elastic", E = 1e3, nu = 0.3',
        '"von_mises", E = 1e3, nu = 0.3, yield_stress = 150.0').replace(
        'method = "cpgimp"\nkinematics = "finite"',
        'method = "mpm"\nkinematics = "small"').replace(
        "max_iterations = 3", ""))
    straight, resumed = straight_and_resumed(scene)
    data = summary(straight)
    assert data["status"] == "completed"
    last = meshio.read(straight / "points_{:04d}.vtu".format(
        data["steps_run"]))
    assert np.abs(last.point_data["rotation"]).max() > 0
    assert_same_run(straight, resumed)


def test_a_folder_without_a_run_says_there_is_nothing_to_resume(tmp_path,
                                                                capsys):
    """A user trial resumed a folder whose run had been refused before it
    started and read "scene.toml: not a regular file"."""
    (tmp_path / "refused").mkdir()
    for folder in (tmp_path / "refused", tmp_path / "absent"):
        assert main(["run", "--resume", str(folder), "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert "no run to resume there (scene.toml is missing" in err, err


@pytest.mark.slow
def test_a_checkpoint_from_before_the_rotation_resumes(tmp_path, caplog):
    """A small-strain checkpoint written before the points kept their
    rotation (here: the field taken out) resumes, the rotation counted
    from the resume and said so: it is a diagnostic the mechanics never
    read (a reviewer: such checkpoints were refused)."""
    scene = tmp_path / "scene.toml"
    scene.write_text(CUT_BACK_SCENE.replace(
        'method = "cpgimp"\nkinematics = "finite"',
        'method = "mpm"\nkinematics = "small"'))
    out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out), "--no-progress",
                 "--max-steps", "1"]) == 0
    data = dict(np.load(out / CHECKPOINT))
    del data["state_rotation"]
    np.savez(out / CHECKPOINT, **data)
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert "written before small-strain runs kept the points' rotation" \
        in caplog.text
    assert summary(out)["status"] == "completed"


FALLING_BLOCK = """
name = "block falling onto a slab body"
[grid]
x = [0.0, 1.0, 4]
y = [0.0, 1.5, 6]
[[bodies]]
name = "slab"
region = { x = [0.0, 1.0], y = [0.0, 0.5] }
density = 1000.0
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
[[bodies]]
name = "block"
region = { x = [0.25, 0.75], y = [0.75, 1.0] }
density = 1000.0
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
[[contacts]]
first = "slab"
second = "block"
[[supports]]
name = "base"
boundary = "bottom"
[gravity]
acceleration = [0.0, -9.81]
[dynamics]
time_step = 0.05
duration = 0.1
"""


@pytest.mark.slow
def test_a_resumed_contact_run_warns_as_its_first_invocation(tmp_path,
                                                             caplog):
    """Trial 57: the warning that bodies meeting inside grid cells may
    lean came from the positions at each invocation's start, so a resumed
    run warned where the first had not.  A block whose sides all lie on
    grid lines falls inside a cell in its first step (by g dt^2 / 2 =
    0.012); neither invocation warns, and the resumed run ends as the
    straight one."""
    scene = tmp_path / "scene.toml"
    scene.write_text(FALLING_BLOCK)
    straight, resumed = straight_and_resumed(scene)
    assert "may lean" not in caplog.text
    first = meshio.read(resumed / "points_0001.vtu")
    fell = -first.point_data["displacement"][:, 1].min()
    assert fell == pytest.approx(9.81 * .05 ** 2 / 2, rel=.05)
    assert_same_run(straight, resumed)


COLLIDING_BLOCKS = """
name = "two blocks colliding"
[grid]
x = [0.0, 1.2, 24]
y = [0.0, 0.4, 8]
[[bodies]]
name = "left"
region = { x = [0.1, 0.3], y = [0.1, 0.3] }
density = 1000.0
initial_velocity = [2.0, 0.0]
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
[[bodies]]
name = "right"
region = { x = [0.32, 0.52], y = [0.1, 0.3] }
density = 1000.0
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
[[contacts]]
first = "left"
second = "right"
[dynamics]
time_step = 0.002
duration = 0.03
"""


def test_a_collision_resumed_in_contact_books_its_energies_as_straight(
        tmp_path):
    """Two blocks colliding, stopped after step 8 (in contact) and
    resumed: the energies of every step are the straight run's to the
    bit.  The checkpoint carries the contact's force where step 8 ended,
    which step 9 books the contact's work from; without it the resumed
    step 9's internal work was booked from its start force."""
    scene = tmp_path / "scene.toml"
    scene.write_text(COLLIDING_BLOCKS)
    straight, resumed = tmp_path / "straight", tmp_path / "resumed"
    assert main(["run", str(scene), "--out", str(straight),
                 "--no-progress", "--checkpoint-every", "100"]) == 0
    assert main(["run", str(scene), "--out", str(resumed), "--no-progress",
                 "--max-steps", "8"]) == 0
    assert np.abs(load_checkpoint(resumed).end_force).max() > 0
    assert main(["run", "--resume", str(resumed), "--no-progress"]) == 0
    assert_same_run(straight, resumed)
    a, b = load_checkpoint(straight), load_checkpoint(resumed)
    assert a.history.shape == (15, len(HISTORY_KEYS))
    assert np.array_equal(a.history, b.history)
    data = dict(np.load(straight / CHECKPOINT))
    data["end_force"] = np.full(3, np.nan)
    np.savez(straight / CHECKPOINT, **data)
    with pytest.raises(CheckpointError, match="'end_force' holds NaN"):
        load_checkpoint(straight)


def test_the_report_counts_the_steps_taken(tmp_path, capsys):
    """The terminal's report names the steps taken, cut-backs' included,
    and the steps planned (a trial's run printed "1 time steps" where it
    had taken 22)."""
    scene = tmp_path / "scene.toml"
    scene.write_text(CUT_BACK_SCENE)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--no-progress"]) == 0
    taken = json.loads((out / "summary.json").read_text())["steps_run"]
    assert taken > 3
    assert ", {} load steps (3 planned, cut back)\n".format(taken) in \
        capsys.readouterr().out


def outputs(out):
    """Every file of ``out``: its bytes and modification time."""
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted(out.iterdir())}


def test_a_completed_run_s_resume_does_nothing(tmp_path, capsys):
    """A user trial: a run with --checkpoint-every 5 over 20 steps left its
    checkpoint at step 15 (load factor 0.75), and ``--resume`` of the
    completed run computed steps 16-20 again, saying nothing of it.  A
    run that keeps checkpoints ends with one at its end; the resume of a
    completed run, with a checkpoint or without one, says so, exit 0,
    and leaves every output as it was."""
    out, bare = tmp_path / "out", tmp_path / "bare"
    assert main(["run", "--out", str(out), "--steps", "3",
                 "--checkpoint-every", "2", "--no-progress"]) == 0
    assert main(["run", "--out", str(bare), "--steps", "2",
                 "--no-progress"]) == 0
    end = load_checkpoint(out)
    assert (end.step, end.load_factor) == (3, 1.) and end.complete
    assert not (bare / CHECKPOINT).exists()
    capsys.readouterr()
    for folder, why in ((out, "its checkpoint holds its end, 3 load "
                         "steps"), (bare, "summary.json; it "
                                              "kept no checkpoint")):
        before = outputs(folder)
        # a kill while the run drew its figures leaves a partial file
        # (the SIGKILL campaign's resume kept one): removed
        partial = folder / (TEMPORARY_PREFIX + "deformed_shape.x1.png")
        partial.write_bytes(b"\x89PNG")
        assert main(["run", "--resume", str(folder), "--no-progress"]) == 0
        printed = capsys.readouterr()
        assert printed.out == "column: the run in {} is complete ({}): " \
            "nothing to resume, every output left as it was\n".format(
                folder, why)
        assert printed.err == ""
        assert outputs(folder) == before
    # a folder of the versions before, its checkpoint short of the end of
    # a completed run (summary.json says so): not run again either
    old = tmp_path / "old"
    assert main(["run", "--out", str(old), "--steps", "2", "--max-steps",
                 "1", "--no-progress"]) == 0
    summary = json.loads((old / "summary.json").read_text())
    summary["status"] = "completed"
    (old / "summary.json").write_text(json.dumps(summary))
    before = outputs(old)
    capsys.readouterr()
    assert main(["run", "--resume", str(old), "--no-progress"]) == 0
    assert "is complete (summary.json; its checkpoint is an earlier " \
        "step's)" in capsys.readouterr().out
    assert outputs(old) == before


def test_a_completed_run_interrupted_in_its_figures_says_so_at_resume(
        tmp_path, capsys, monkeypatch):
    """A completed run interrupted while drawing its figures said
    "figures missing" once, and a later ``--resume`` said only that the
    run was complete: its summary says the figures are missing, and so
    does the resume, which draws none (exit 0)."""
    import skfem_mpm.cli as cli

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(cli, "plot_outputs", interrupted)
    out = tmp_path / "out"
    assert main(["run", "--out", str(out), "--steps", "2",
                 "--no-progress"]) == 130
    assert "while drawing the figures" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["status"], summary["figures"]) == (
        "completed", cli.FIGURES_MISSING)
    monkeypatch.undo()
    before = outputs(out)
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert capsys.readouterr().out == (
        "column: the run in {} is complete (summary.json; it kept no "
        "checkpoint): nothing to resume, every output left as it was; its "
        "figures are missing (the run was interrupted while drawing them): "
        "run the scene again to draw them\n".format(out))
    assert outputs(out) == before


def test_a_stopped_run_resumed_to_its_end_ends_with_its_checkpoint(
        tmp_path, capsys):
    """``--max-steps`` stops at a checkpoint as before; the resume that
    completes the run writes one at the end, and the next resume has
    nothing to do."""
    out = tmp_path / "out"
    assert main(["run", "--out", str(out), "--steps", "2", "--max-steps",
                 "1", "--no-progress"]) == 0
    stopped = load_checkpoint(out)
    assert (stopped.step, stopped.load_factor) == (1, .5)
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert "resumed" in capsys.readouterr().out
    end = load_checkpoint(out)
    assert (end.step, end.load_factor) == (2, 1.)
    assert end.complete and not stopped.complete
    assert end.history.shape[0] == 2 and end.reactions.shape[0] == 2
    assert main(["run", "--resume", str(out), "--no-progress"]) == 0
    assert "is complete" in capsys.readouterr().out


def test_a_resumed_run_s_load_displacement_curve_starts_at_its_resume(
        tmp_path, monkeypatch):
    """A resumed run holds the steps since its resume alone: its
    ``load_displacement.png`` drew a line from (0, 0) to the resume's
    first step (a third invocation's: to load factor 0.58 and 0.095 m),
    a path the body never took.  It draws the steps it holds, from the first, and its title
    says which."""
    from skfem_mpm.scenes import plot
    drawn = {}
    save = plot.save_figure

    def keep(fig, path, *args, **kwargs):
        if path.name == "load_displacement.png":
            ax = fig.axes[0]
            drawn[path.parent.name] = (ax.get_title(),
                                       ax.lines[0].get_ydata().tolist())
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", keep)
    scene = tmp_path / "scene.toml"
    scene.write_text(CUT_BACK_SCENE)
    out = tmp_path / "split"
    assert main(["run", str(scene), "--out", str(out), "--max-steps", "3",
                 "--no-progress"]) == 0
    title, factors = drawn.pop("split")
    assert factors[0] == 0. and "resumed" not in title
    assert main(["run", "--resume", str(out), "--max-steps", "3",
                 "--no-progress"]) == 0
    title, factors = drawn.pop("split")
    assert len(factors) == 3 and factors[0] > 0.
    assert title.endswith("material points, steps 4 to 6 (resumed)")


@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_a_cpgimp_run_resumes_without_its_initial_domains(kinematics):
    """``Resume.after(record)`` without ``domain0`` on a cpGIMP run was
    refused ("resuming a cpgimp run needs Resume.domain0", a user trial),
    where its docstring says the points' domains unstretched by ``F`` are
    the default: an elastic block (cells 0.3, domains 0.075) pushed down
    by a plate in 4 steps, stopped by its callback after step 2 and
    resumed, ends as the straight run, bit for bit (in finite
    deformation its domains were stretched where it stopped)."""
    from skfem import ElementQuad1, MeshQuad
    from skfem_mpm import (LinearElastic, Obstacle, Options, Resume,
                           seed_points, simulate)
    mesh = MeshQuad.init_tensor(np.linspace(0, 2.1, 8),
                                np.linspace(0, 2.1, 8))
    pts = seed_points(mesh, 2, region=lambda x: x[1] < 1.2 + 1e-9)
    args = (mesh, ElementQuad1(), pts, LinearElastic(1e3, .3),
            lambda b: b.get_dofs(lambda x: x[1] == 0))
    kwargs = dict(nsteps=4, method="cpgimp", kinematics=kinematics,
                  obstacles=[Obstacle(box=[[-1, 3], [1.2, 1.9]],
                                      displacement=[0, -.05])])
    straight = simulate(*args, **kwargs)
    kept = {}

    class Stop(Exception):
        pass

    def stop(record, points):
        if record.step == 2:
            kept.update(points=points.copy(), record=record)
            raise Stop

    with pytest.raises(Stop):
        simulate(*args, options=Options(callback=stop), **kwargs)
    resumed = simulate(args[0], args[1], kept["points"], *args[3:],
                       options=Options(resume=Resume.after(kept["record"])),
                       **kwargs)
    stretched = np.abs(kept["points"].domain - pts.domain).max() > 1e-4
    assert stretched == (kinematics == "finite")
    assert np.array_equal(resumed.domain0, pts.domain)
    for name in ("x", "stress", "domain", "F"):
        assert np.array_equal(getattr(resumed.points, name),
                              getattr(straight.points, name)), name


SHEARED_BLOCK = """
name = "block sheared on a slab body"
[grid]
x = [0.0, 2.0, 8]
y = [0.0, 1.5, 6]
[[bodies]]
name = "slab"
region = { x = [0.0, 2.0], y = [0.0, 0.5] }
material = { model = "linear_elastic", E = 1e3, nu = 0.3 }
[[bodies]]
name = "block"
region = { x = [0.5, 1.5], y = [0.5, 1.0] }
material = { model = "linear_elastic", E = 1e3, nu = 0.3 }
[[contacts]]
first = "FIRST"
second = "SECOND"
friction = 0.5
[[tractions]]
body = "block"
side = "top"
traction = [4.0, -20.0]
[[supports]]
name = "base"
boundary = "bottom"
[solver]
method = "mpm"
steps = 2
"""


@pytest.mark.slow
@pytest.mark.parametrize("first, second", [("block", "slab"),
                                           ("slab", "block")])
def test_a_contact_checkpoint_from_before_its_sides_are_paired_by_volume(
        tmp_path, capsys, first, second):
    """Each interface between bodies pairs its smaller side's corners
    since 2026-11-30, where its point state (pressures, gaps, friction
    tractions) lies; before, the declared second body's.  A checkpoint
    written before (here: its ``contact_sides`` taken out) of a block
    declared first on a larger slab, resumed, would read the block's
    friction at the slab's points: refused, naming the file and the
    contact.  Declared the other way round (the pairing unchanged) it
    resumes to the straight run's end, bit for bit."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SHEARED_BLOCK.replace("FIRST", first).replace(
        "SECOND", second))
    straight, resumed = tmp_path / "straight", tmp_path / "resumed"
    assert main(["run", str(scene), "--out", str(straight),
                 "--no-progress"]) == 0
    assert main(["run", str(scene), "--out", str(resumed), "--no-progress",
                 "--max-steps", "1"]) == 0
    kept = dict(np.load(resumed / CHECKPOINT))
    assert kept["contact_sides"].item() is True
    assert np.abs(kept["state_contact_body0_t00"]).max() > 0.  # friction
    del kept["contact_sides"]
    np.savez(resumed / CHECKPOINT, **kept)
    assert not load_checkpoint(resumed).contact_sides
    if first == "block":
        assert main(["run", "--resume", str(resumed), "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert "{}: written before each interface between bodies paired " \
            "its smaller side's corners".format(resumed / CHECKPOINT) \
            in err, err
        assert "the other side of contact(s) 'block-slab'" in err, err
        return
    assert main(["run", "--resume", str(resumed), "--no-progress"]) == 0
    assert_same_run(straight, resumed)


PLATE = """
name = "block under a plate"
[grid]
x = [0.0, 2.0, 8]
y = [0.0, 2.0, 8]
[[bodies]]
name = "block"
region = { x = [0.0, 2.0], y = [0.0, 1.0] }
material = { model = "linear_elastic", E = 1e3, nu = 0.3 }
[[obstacles]]
name = "plate"
box = { x = [-1.0, 3.0], y = [1.0, 1.7] }
displacement = [0.0, -0.02]
friction = "FRICTION"
[[supports]]
name = "base"
boundary = "bottom"
[solver]
method = "mpm"
steps = 2
"""


@pytest.mark.parametrize("friction", ["tied", "rough"])
def test_a_tied_checkpoint_written_before_its_traction_is_refused(
        tmp_path, capsys, friction):
    """A tied obstacle's point state became its traction (it was the
    multiplier): a checkpoint written before, resumed, took the
    multiplier for the traction, the tied force shifted by the penalty's
    share of the corners' mismatch, silently.  Such a checkpoint (here:
    its ``tied_traction`` taken out) is refused, naming the file and
    saying to run again; one with it resumes to the straight run's end,
    and one of a rough plate without it too, bit for bit."""
    scene = tmp_path / "scene.toml"
    scene.write_text(PLATE.replace("FRICTION", friction))
    straight, resumed = tmp_path / "straight", tmp_path / "resumed"
    assert main(["run", str(scene), "--out", str(straight),
                 "--no-progress"]) == 0
    assert main(["run", str(scene), "--out", str(resumed), "--no-progress",
                 "--max-steps", "1"]) == 0
    kept = dict(np.load(resumed / CHECKPOINT))
    assert kept["tied_traction"].item() is True
    assert load_checkpoint(resumed).tied_traction
    if friction == "tied":
        assert main(["run", str(scene), "--out", str(tmp_path / "new"),
                     "--no-progress", "--max-steps", "1"]) == 0
    del kept["tied_traction"]
    np.savez(resumed / CHECKPOINT, **kept)
    assert not load_checkpoint(resumed).tied_traction
    if friction == "tied":
        assert main(["run", "--resume", str(resumed), "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert "{}: written before a tied obstacle's point state".format(
            resumed / CHECKPOINT) in err, err
        assert "shifting the force of tied obstacle(s) 'plate'): run the " \
            "scene again from its start" in err, err
        resumed = tmp_path / "new"
    assert main(["run", "--resume", str(resumed), "--no-progress"]) == 0
    assert_same_run(straight, resumed)
