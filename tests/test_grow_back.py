"""With ``NewtonOptions(grow_back=True)`` a cut-back's increment grows
back once the hard part is past
(:func:`~skfem_mpm.solve.core.grown_increment`): a trial's footing cut
back 7 times and crawled 128 sub-steps of 3.9e-4 to the end of its step
of 0.05, in 7 to 12 Newton iterations each.  Here a hard stretch of a
128th of a step (attempts over it fail, as Newton did there) makes the
second of 4 load steps cut back 7 times; the rest of the step is easy.
A resumed run goes on from the count of easy sub-steps, bit for bit.
By default (its changed load path failed two runs that complete without
it) the increment stays cut back, as before, and a run says so once."""
import json
import logging

import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (LinearElastic, NewtonDivergenceError, NewtonOptions,
                       Options, Resume, seed_points, simulate)
from skfem_mpm.cli import main
from skfem_mpm.scenes.checkpoint import load_checkpoint
from skfem_mpm.solve import core

NSTEPS = 4
#: the option on
GROW = Options(NewtonOptions(grow_back=True))
#: the hard stretch: from the second step's start, a 128th of a step
HARD, WIDTH = .25, .25 / 128


def hard_stretch(monkeypatch):
    """Attempts over more than the hard stretch's width that reach into
    it fail (by load factor, so a resumed run fails alike)."""
    attempt, failed = core.attempt, []

    def failing(run, points, f_old, f_new, step):
        if f_new > HARD + 1e-12 and f_old < HARD + WIDTH - 1e-12 and \
                f_new - f_old > WIDTH * (1 + 1e-9):
            failed.append((f_old, f_new))
            raise NewtonDivergenceError("made to fail")
        return attempt(run, points, f_old, f_new, step)
    monkeypatch.setattr(core, "attempt", failing)
    return failed


def block():
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    return (mesh, ElementQuad1(), seed_points(mesh, 2),
            LinearElastic(1e3, .3),
            lambda b: b.get_dofs(lambda x: x[1] == 0).all(), [0., -50.])


def test_a_cut_back_increment_grows_back_after_easy_sub_steps(monkeypatch,
                                                              caplog):
    """7 cut-backs at the second step's start, then sub-steps of a 128th
    that converge in 2 or 3 Newton iterations (of 25): the increment
    doubles after every two, 13 sub-steps to the step's end where 128
    were taken before (16 in all, 131 before), each doubling logged.  The
    points move with the sub-steps (MPM), so the answer depends on them:
    it ends 3.4e-4 of the largest motion from an uncut run's, closer than
    the 128 sub-steps' 4.1e-4 (``test_a_hard_sub_step_...``)."""
    failed = hard_stretch(monkeypatch)
    with caplog.at_level(logging.INFO, logger="skfem_mpm.solve.core"):
        res = simulate(*block(), nsteps=NSTEPS, kinematics="finite",
                       options=GROW)
    assert len(failed) == 7
    second = [r for r in res.history if .25 < r.load_factor <= .5]
    assert len(second) == 13 and len(res.history) == 16
    assert max(r.newton_iterations for r in second) <= 12
    steps = np.diff([.25] + [r.load_factor for r in second]) / WIDTH
    assert np.allclose(steps, [1, 1, 2, 2, 4, 4, 8, 8, 16, 16, 32, 32, 2])
    grown = [r.getMessage() for r in caplog.records
             if "growing the load increment back" in r.getMessage()]
    assert len(grown) == 6
    assert grown[0] == "step 3: growing the load increment back to " \
        "3.906e-03 (2 sub-steps in a row converged in at most 12 Newton " \
        "iterations)"
    monkeypatch.undo()
    uncut = simulate(*block(), nsteps=NSTEPS, kinematics="finite")
    assert len(uncut.history) == NSTEPS
    moved = np.abs(uncut.points.x - block()[2].x).max()
    assert np.abs(res.points.x - uncut.points.x).max() < 3.5e-4 * moved



#: the default's crawl on main before grow-back (``numpy`` kernels and
#: compiled alike): the sums of the final points' arrays
CRAWL = {"x": 15.799865457171904, "stress": -594.6395844878734,
         "F": 47.7716009376998, "volume": 0.9856081017528092}


def test_the_default_crawls_as_before_and_says_so_once(monkeypatch,
                                                       caplog):
    """Without ``grow_back`` the increment stays cut back to the step's
    end, 128 sub-steps of a 128th (131 in all), the run the package made
    before grow-back (its sums as recorded then, to the digests' 1e-12;
    the same bits as ``grow_back=False`` given), and no
    ``easy_sub_steps`` counter; one INFO line, at the second easy
    sub-step, names the option in Python and in a scene file."""
    hard_stretch(monkeypatch)
    with caplog.at_level(logging.INFO, logger="skfem_mpm.solve.core"):
        res = simulate(*block(), nsteps=NSTEPS, kinematics="finite")
    second = [r for r in res.history if .25 < r.load_factor <= .5]
    assert len(second) == 128 and len(res.history) == 131
    assert np.allclose(np.diff([.25] + [r.load_factor for r in second]),
                       WIDTH, rtol=1e-9, atol=0)
    assert all(r.increment == WIDTH for r in second[:-1])
    assert all("easy_sub_steps" not in r.counters for r in res.history)
    assert "easy_sub_steps" not in res.counters
    for name, value in CRAWL.items():
        assert abs(getattr(res.points, name).sum() - value) <= \
            1e-12 * abs(value), name
    assert "growing" not in caplog.text
    hints = [r for r in caplog.records if "stays cut back" in r.getMessage()]
    assert len(hints) == 1 and hints[0].levelno == logging.INFO
    assert hints[0].getMessage().startswith(
        "step 3: the load increment stays cut back to 1.953e-03 to the "
        "load step's end, though 2 sub-steps in a row converged in at "
        "most 12 Newton iterations; to double it after two such "
        "sub-steps: NewtonOptions(grow_back=True); scene file: [solver] "
        "grow_back = true (")
    off = simulate(*block(), nsteps=NSTEPS, kinematics="finite",
                   options=Options(NewtonOptions(grow_back=False)))
    for name in ("x", "stress", "F", "volume"):
        assert np.array_equal(getattr(off.points, name),
                              getattr(res.points, name)), name
    assert off.counters == res.counters


def test_grow_back_must_be_a_bool():
    """``NewtonOptions(grow_back=...)`` refuses what is not True or False
    (a string, 1), and the scene key likewise, named by the key."""
    from skfem_mpm import InvalidInputError
    for value in ("yes", 1, None):
        with pytest.raises(InvalidInputError,
                           match="grow_back must be True or False"):
            NewtonOptions(grow_back=value)
    assert NewtonOptions(grow_back=np.bool_(True)).grow_back
    from skfem_mpm.errors import SceneError
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    assert parse_scene(tomllib.loads(SCENE)).newton.grow_back is True
    assert parse_scene(tomllib.loads(SCENE.replace(
        "grow_back = true\n", ""))).newton.grow_back is False
    with pytest.raises(SceneError, match="solver.grow_back: must be true "
                       "or false"):
        parse_scene(tomllib.loads(SCENE.replace("grow_back = true",
                                                'grow_back = "yes"')))


def test_a_hard_sub_step_starts_the_count_again(monkeypatch):
    """A sub-step of more than half ``max_iter`` iterations is not easy:
    with ``max_iter`` 3 (these sub-steps take 2 or 3) the increment stays
    cut back to the step's end, 128 sub-steps, as before grow-back; the
    run ends 4.1e-4 of the largest motion from an uncut run's."""
    hard_stretch(monkeypatch)
    res = simulate(*block(), nsteps=NSTEPS, kinematics="finite",
                   options=Options(NewtonOptions(max_iter=3,
                                                 grow_back=True)))
    second = [r for r in res.history if .25 < r.load_factor <= .5]
    assert min(r.newton_iterations for r in second) == 2
    assert len(second) == 128
    assert all(r.counters["easy_sub_steps"] == 0 for r in second)
    monkeypatch.undo()
    uncut = simulate(*block(), nsteps=NSTEPS, kinematics="finite")
    moved = np.abs(uncut.points.x - block()[2].x).max()
    assert np.abs(res.points.x - uncut.points.x).max() > 4e-4 * moved


def test_a_resume_between_easy_sub_steps_is_bit_identical(monkeypatch):
    """``Resume.after`` the first easy sub-step (the count at 1, carried
    in the record's counters): the resumed run doubles after one more, as
    the whole run does, and ends bit-identical to it, its counters too.
    Without the count it would wait for two (a 14th sub-step)."""
    hard_stretch(monkeypatch)
    saved = {}

    def keep(record, state):
        if record.counters.get("easy_sub_steps") == 1 and not saved:
            saved.update(record=record, state=state)
    whole = simulate(*block(), nsteps=NSTEPS, kinematics="finite",
                     options=Options(GROW.newton, callback=keep))
    record = saved["record"]
    assert record.load_factor == HARD + WIDTH
    mesh, elem, _, material, supports, force = block()
    rest = simulate(mesh, elem, saved["state"], material, supports, force,
                    nsteps=NSTEPS, kinematics="finite", options=Options(
                        GROW.newton, resume=Resume.after(record)))
    assert [r.load_factor for r in rest.history] == \
        [r.load_factor for r in whole.history[record.step:]]
    for name in ("x", "stress", "F", "volume"):
        assert np.array_equal(getattr(rest.points, name),
                              getattr(whole.points, name)), name
    assert rest.counters == whole.counters
    forgot = simulate(mesh, elem, saved["state"], material, supports, force,
                      nsteps=NSTEPS, kinematics="finite", options=Options(
                          GROW.newton, resume=Resume(record.step + 1,
                                                     record.load_factor,
                                                     record.increment)))
    assert len(forgot.history) == len(rest.history) + 1


SCENE = """
name = "grow-back block"
[grid]
x = [0.0, 1.0, 2]
y = [0.0, 1.0, 2]
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
traction = [10.0, -50.0]
[solver]
method = "mpm"
kinematics = "finite"
steps = 4
grow_back = true
"""


@pytest.mark.slow
def test_resumes_from_checkpoints_across_a_grow_back_are_bit_identical(
        monkeypatch, tmp_path):
    """The scene runner (``[solver] grow_back = true``) stopped every 3
    sub-steps (``--max-steps``) and resumed from its checkpoint, through
    the cut-backs and every grow-back: the same summary (counters, ``easy_sub_steps`` too) and
    final points as the run straight through; checkpoints stood at easy
    counts of 0 and 1."""
    import meshio
    hard_stretch(monkeypatch)
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main(["run", str(scene), "--out", str(straight),
                 "--no-progress"]) == 0

    def summary(out):
        data = json.loads((out / "summary.json").read_text())
        return {k: v for k, v in data.items()
                if k not in ("wall_seconds", "timings", "compile_seconds")}
    assert summary(straight)["steps_run"] == 16
    assert main(["run", str(scene), "--out", str(split), "--max-steps",
                 "3", "--no-progress"]) == 0
    counts = set()
    for _ in range(10):
        if summary(split)["status"] == "completed":
            break
        counts.add(load_checkpoint(split).counters.get("easy_sub_steps"))
        assert main(["run", "--resume", str(split), "--max-steps", "3",
                     "--no-progress"]) == 0
    assert summary(split) == summary(straight)
    assert {0, 1} <= counts
    last = "points_{:04d}.vtu".format(16)
    a, b = meshio.read(straight / last), meshio.read(split / last)
    assert np.array_equal(a.points, b.points)
    for name in a.point_data:
        assert np.array_equal(a.point_data[name], b.point_data[name]), name
