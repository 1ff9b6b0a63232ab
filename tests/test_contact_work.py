"""Dynamics' energies: the work of the contact forces (with obstacles
and between bodies) booked apart from the points' stresses'
(``contact_work`` beside ``internal_work``; trial 98's block dropped on a
floor kept the floor's work, 71.55 J, in its internal work in flight)."""
import json

import numpy as np
import pytest

from skfem_mpm.scenes.scene import run_scene
from skfem_mpm.scenes.scene_file import load_scene
from skfem_mpm.solve.dynamics import StepInertia

DROP = """
name = "block dropped on a floor"
[grid]
x = [0.0, 1.0, 5]
y = [0.0, 1.0, 5]
z = [-0.2, 1.0, 6]
[[bodies]]
name = "block"
region = { x = [0.3, 0.7], y = [0.3, 0.7], z = [0.4, 0.8] }
points_per_cell = 2
density = 1000.0
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
[gravity]
acceleration = [0.0, 0.0, -9.81]
[[obstacles]]
name = "floor"
box = { x = [-1.0, 2.0], y = [-1.0, 2.0], z = [-1.0, 0.0] }
[dynamics]
time_step = 0.02
duration = 0.5
"""


def booked_together(monkeypatch):
    """Per step, the trapezoidal work of the whole internal force (the
    points' stresses and the terms' forces, each step's start force as
    the energies book it), as the internal work was booked before the
    contact's work was kept apart."""
    together = []
    commit = StepInertia.commit

    def wrapped(self, problem, trial, du, new, record):
        f_int = problem.internal_force(du, trial.response)
        points = getattr(self, "f_points0", None)   # (None: booked whole)
        start = self.f_work0 if points is None else points \
            if self.f_work0 is None else points + self.f_work0
        together.append(.5 * float((start + f_int) @ du))
        commit(self, problem, trial, du, new, record)

    monkeypatch.setattr(StepInertia, "commit", wrapped)
    return together


def strain_energy(points) -> float:
    """The points' stored elastic energy, sum of sigma : eps V / 2."""
    return .5 * float((np.einsum("ijn,ijn->n", points.stress, points.strain)
                       * points.volume).sum())


def test_a_bounced_block_s_internal_work_is_its_strain_energy(
        tmp_path, monkeypatch):
    """Trial 98's block (64 kg, E = 1e6) dropped 0.4 m on a smooth floor:
    in flight after its bounce its internal work is the points' strain
    energy (was 71.55 J, the strain energy under 1e-3 J), the floor's
    work as the trapezoid books it is ``contact_work``, zero before the
    landing, and the two together are the work booked before, to
    round-off (the balance unchanged)."""
    path = tmp_path / "drop.toml"
    path.write_text(DROP)
    together = booked_together(monkeypatch)
    stored, floor = [], []

    def callback(record, points):
        stored.append(strain_energy(points))
        floor.append(record.obstacle_forces[0, 2])

    result = run_scene(load_scene(path), callback=callback)
    e = result.energies()
    floor = np.array(floor)
    landed = np.flatnonzero(floor < 0)[0]
    left = landed + np.flatnonzero(floor[landed:] == 0)[0]
    assert left < len(floor) - 3
    internal, contact = e["internal_work"][1:], e["contact_work"][1:]
    peak = max(stored)
    # before the landing no force but gravity's: nothing booked (the
    # stresses' round-off)
    assert np.abs(internal[:landed]).max() < 1e-12 * peak
    assert np.all(contact[:landed] == 0)
    # in flight after the bounce: the stored energy, to round-off of the
    # work of the impact's forces
    assert np.abs(internal - stored)[left:].max() < 1e-12 * peak
    assert max(stored[left:]) < .01 * peak
    # the contact's work is what the floor left in the booking, constant
    # in flight (the floor exerts nothing there)
    assert contact[-1] > .1 * e["external_work"][-1]
    assert np.ptp(contact[left:]) < 1e-12 * contact[-1]
    # together: the work booked before, step by step, and the balance
    steps = [r.energy["internal_work"] + r.energy["contact_work"]
             for r in result.history]
    scale = max(abs(x) for x in together)
    assert np.abs(np.array(steps) - together).max() < 1e-12 * scale
    old = e["kinetic"] + np.r_[0., np.cumsum(together)] - e["external_work"]
    assert np.abs(e["balance"] - old).max() < 1e-12 * e["kinetic"].max()


SAG = DROP.split("[[obstacles]]")[0].replace(
    "z = [0.4, 0.8]", "z = [0.0, 0.4]") + """
[[supports]]
name = "base"
region = { x = [0.0, 1.0], y = [0.0, 1.0], z = [0.0, 0.0] }
[dynamics]
time_step = 0.02
duration = 0.2
"""


@pytest.mark.parametrize("ghost", ["", "[solver]\nghost = 0.1\n"])
def test_without_contact_the_energies_are_as_before(tmp_path, monkeypatch,
                                                     ghost):
    """A block on a fixed base sagging under its weight (no obstacle, no
    contact; also with the ghost penalty on, a grid term that is not a
    contact): ``contact_work`` zero at every step, the internal work bit
    for bit the trapezoidal work of the internal force as it was booked
    before, and the balance ``kinetic + internal_work - external_work``
    bit for bit."""
    path = tmp_path / "sag.toml"
    path.write_text(SAG + ghost)
    together = booked_together(monkeypatch)
    result = run_scene(load_scene(path))
    e = result.energies()
    assert e["internal_work"].max() > .1 * e["external_work"].max() > 0
    assert all(r.energy["contact_work"] == 0. for r in result.history)
    assert [r.energy["internal_work"] for r in result.history] == together
    assert np.array_equal(e["balance"], e["kinetic"] + e["internal_work"]
                          - e["external_work"])
    assert np.array_equal(e["contact_work"], np.zeros(len(e["time"])))


def test_an_old_checkpoint_resumes_with_its_contact_work_inside(tmp_path):
    """A checkpoint written before ``contact_work`` was kept apart (its
    history one column short, the contact's work in ``internal_work``)
    resumes: the run ends bit for bit as the uninterrupted one, its
    summary's ``contact_work`` zero over the old steps with their
    internal work holding it, and the balance the same; ``energies`` in
    ``summary.json`` carries ``contact_work``."""
    from skfem_mpm.cli import main
    from skfem_mpm.scenes.checkpoint import CHECKPOINT, HISTORY_KEYS
    path = tmp_path / "drop.toml"
    path.write_text(DROP.replace("duration = 0.5", "duration = 0.4"))
    full, part = tmp_path / "full", tmp_path / "part"
    assert main(["run", str(path), "--out", str(full), "--no-progress"]) == 0
    assert main(["run", str(path), "--out", str(part), "--no-progress",
                 "--max-steps", "16", "--checkpoint-every", "1"]) == 0
    # as the checkpoint was written before: 12 columns, the contact's
    # work inside the internal work
    with np.load(part / CHECKPOINT) as data:
        arrays = dict(data)
    history = arrays["history"]
    assert history.shape[1] == len(HISTORY_KEYS)
    internal, contact = (HISTORY_KEYS.index(k) for k in ("internal_work",
                                                         "contact_work"))
    assert history[:, contact].any()             # the landing's steps
    old = np.delete(history, contact, axis=1)
    old[:, internal] = history[:, internal] + history[:, contact]
    arrays["history"] = old
    np.savez(part / CHECKPOINT, **arrays)
    assert main(["run", "--resume", str(part), "--no-progress"]) == 0
    a, b = (json.loads((d / "summary.json").read_text())["energies"]
            for d in (full, part))
    n = len(history) + 1                    # the start and the old steps
    assert b["contact_work"][:n] == [0.] * n
    assert np.allclose(np.array(b["internal_work"][:n]),
                       np.array(a["internal_work"][:n])
                       + a["contact_work"][:n], rtol=1e-13, atol=0.)
    assert np.allclose(b["balance"], a["balance"], rtol=0.,
                       atol=1e-12 * max(a["kinetic"]))
    assert b["kinetic"] == a["kinetic"]
    for name in ("internal_work", "contact_work"):   # the new steps'
        steps = np.diff(a[name])[n - 1:], np.diff(b[name])[n - 1:]
        assert np.allclose(*steps, rtol=1e-12, atol=1e-12)
    import meshio
    last = sorted(full.glob("points_*.vtu"))[-1].name
    assert np.array_equal(meshio.read(full / last).points,
                          meshio.read(part / last).points)
