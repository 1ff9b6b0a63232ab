"""Checkpoints: the whole state of a run after a converged load step, in
one ``.npz`` of plain arrays (no pickle), written atomically and checked
field by field when read.

A checkpoint holds what a bit-identical resume needs: the points (every
field and internal variable), the load factor reached and the next load
increment (both differ from ``step / nsteps`` after a cut-back), the
counters (a ghost penalty switched on stays on), the initial GIMP domains,
one history row per converged step and the reaction resultants per support
(so that ``summary.json`` covers the whole run across resumes), the wall
seconds and the seconds per phase spent on the steps it holds (so that a
resumed run's ``wall_seconds`` and ``timings`` add its invocations up),
the force of a contact between bodies where a dynamic run's last step
ended (its next step books the contact's work from it), the SHA-256
of the scene file it belongs to (a stale checkpoint is refused) and
``tied_traction``: a tied obstacle's point state (``contact<i>_t<a><c>``)
is its traction (since 2026-11-29; it was the multiplier, and a resume
read it as the traction, shifting the tied force: a checkpoint of a run
with a tied obstacle written before is refused, :func:`check_tied`) and
``contact_sides``: each interface between bodies pairs its smaller side's
corners (since 2026-11-30; the declared second body's before, where its
point state lay: a checkpoint written before, of a scene whose interface
now pairs the other side, is refused, :func:`check_contact_sides`) and
the values of the scene's point outputs (``[[outputs]]`` of a
displacement or stress) at every step (since 2026-11-30, so that their
histories in ``summary.json`` cover the whole run too: a checkpoint
written before has none, and the resumed run's histories of them start
at its resume, :func:`check_outputs`).  A run
that kept checkpoints ends with one at its last step, load factor 1
(:attr:`Checkpoint.complete`): resuming it has nothing to do (a trial's
completed run left its checkpoint at step 15 of 20, and ``--resume``
computed steps 16-20 again).

"""
import hashlib
import re
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError, MPMError, PointsOutsideGridError
from ..quadrature.locate import point_locator
from ..quadrature.points import MaterialPoints
from ..solve.body_contact import swapped_interfaces
from .io import atomic_path

__all__ = ["Checkpoint", "CheckpointError", "save_checkpoint",
           "load_checkpoint", "check_against", "check_tied",
           "check_contact_sides", "check_outputs", "history_rows",
           "scene_digest", "CHECKPOINT", "HISTORY_KEYS"]

CHECKPOINT = "checkpoint.npz"
HISTORY_KEYS = ("step", "load_factor", "residual", "n_active_elements",
                "n_free_dofs", "newton_iterations", "time", "time_step",
                "kinetic_start", "kinetic", "internal_work", "external_work",
                "contact_work")
ENERGY_KEYS = ("kinetic_start", "kinetic", "internal_work", "external_work",
               "contact_work")
#: the history's columns a checkpoint written before ``contact_work`` was
#: kept apart holds (its contact work inside ``internal_work``): read with
#: a ``contact_work`` of zero
HISTORY_KEYS_BEFORE_CONTACT_WORK = HISTORY_KEYS[:-1]
POINT_FIELDS = ("x", "volume", "force", "x0", "stress", "strain",
                "displacement", "volume0", "F", "be", "body", "domain",
                "velocity", "acceleration")
OPTIONAL_POINT_FIELDS = ("domain", "velocity", "acceleration")
#: the times of the invocations so far (absent from a checkpoint written
#: before they were kept)
TIME_FIELDS = ("wall_seconds", "timing_names", "timing_values")
#: the point outputs' values (absent from a checkpoint written before
#: they were kept, 2026-11-30)
OUTPUT_FIELDS = ("output_labels", "output_values", "output_from")


#: point state that runs keep since checkpoints were first written,
#: ``(pattern of the names, what they are, since when)``: a checkpoint
#: that lacks only such names was written before, and its refusal says so
STATE_SINCE = ((r"contact_body_corner\d+", "the B-spline contact corners "
                "(contact_body_corner*)", "2026-11-27"),
               (r"contact_body\d+_r\d+", "the rates of the pressures "
                "between bodies (contact_body<k>_r*)", "2026-11-28"),
               (r"contact_start_dx\d+", "the obstacles' corners at a run's "
                "start (contact_start_dx*)", "2026-11-28"))


def written_before(held, names) -> str:
    """What a refusal adds where the state ``held`` lacks only names of
    :data:`STATE_SINCE` among ``names``: ``""`` otherwise.

    >>> written_before({"eps_p"}, {"eps_p", "contact_body_corner00"})[:30]
    '; the B-spline contact corners'
    >>> written_before({"eps_p"}, {"eps_p", "contact_body0_r00"})[:44]
    '; the rates of the pressures between bodies '
    >>> written_before({"eps_p"}, {"eps_p", "kappa"})
    ''
    """
    missing = set(names) - set(held)
    since = [{(what, date) for pattern, what, date in STATE_SINCE
              if re.fullmatch(pattern, name)} for name in missing]
    if not missing or not set(held) <= set(names) or not all(since):
        return ""
    whats = sorted(set().union(*since))
    return "; {}, and a checkpoint written before lacks it: run the scene " \
        "again from its start".format(" and ".join(
            "{} became point state on {}".format(what, date)
            for what, date in whats))


class CheckpointError(InvalidInputError):
    """A checkpoint file is missing, unreadable, or one of its fields is
    absent or impossible (named in the message)."""


@dataclass
class Checkpoint:
    """The state of a run after ``step`` converged steps of ``nsteps``.

    Attributes
    ----------
    step, nsteps
        Converged steps (sub-steps of cut-backs included) and the scene's
        number of load steps.
    load_factor, increment
        The load factor reached and the load increment the next step
        starts with.
    points
        The material points.
    counters
        The run's counters so far.
    history
        One row per converged step (:data:`HISTORY_KEYS`; newton
        iterations -1 for a linear step).  A checkpoint written before
        ``contact_work`` was kept apart reads with that column zero, its
        contact work inside ``internal_work`` (the balance the same).
    reactions
        Reaction resultants, (steps, supports, dim).
    scene_sha256
        Digest of the scene file the run belongs to.
    domain0
        Initial GIMP domains, or ``None``.
    wall_seconds, timings
        Wall seconds and seconds per phase (locate, assemble, ...) the
        invocations spent up to this checkpoint (a checkpoint written
        before they were kept: 0 and ``{}``).
    end_force
        Dynamic runs with contact between bodies: the contact's force
        where the last step ended, a grid vector
        (:attr:`~skfem_mpm.Resume.end_force`), or ``None``.
    tied_traction
        Whether a tied obstacle's point state is its traction (every
        checkpoint written since 2026-11-29); ``False``: the multiplier,
        read from a checkpoint written before (:func:`check_tied`).
    contact_sides
        Whether each interface between bodies kept its point state on
        its smaller side (every checkpoint written since 2026-11-30);
        ``False``: on the declared second body, read from a checkpoint
        written before (:func:`check_contact_sides`).
    series_every, series_steps
        The ``--series-every`` of the invocation that wrote it (a resume
        keeps it unless told another) and the steps up to ``step`` whose
        states the VTU series was to hold by the ``--series-every`` of
        each invocation (the start, 0, included; written or not: with
        ``--no-series`` none is); a checkpoint written before they were
        kept: 1 and ``None`` (every step).
    warnings
        The warnings the run logged up to the checkpoint, each once, in
        the order first logged (``summary.json``'s ``warnings``: a
        resumed run's summary lists the whole run's); a checkpoint
        written before they were kept: none.
    outputs, outputs_from
        The values of the scene's point outputs (``[[outputs]]`` of a
        displacement or stress, by label) at the steps after
        ``outputs_from`` (0: every step; a run resumed from a checkpoint
        written before they were kept keeps them from its resume on), one
        each, as :func:`~skfem_mpm.cli.summarise` reports them; forces
        and footing pressures come from ``reactions``.  ``None`` (and
        ``step``): a checkpoint written before 2026-11-30, which kept
        none.

    """
    step: int
    nsteps: int
    load_factor: float
    increment: float
    points: MaterialPoints
    counters: dict
    history: ndarray
    reactions: ndarray
    scene_sha256: str
    domain0: Optional[ndarray] = None
    wall_seconds: float = 0.
    timings: dict = field(default_factory=dict)
    end_force: Optional[ndarray] = None
    tied_traction: bool = True
    contact_sides: bool = True
    series_every: int = 1
    series_steps: Optional[ndarray] = None
    warnings: tuple = ()
    outputs: Optional[dict] = None
    outputs_from: int = 0

    @property
    def complete(self) -> bool:
        """Whether the run reached its end (load factor 1, as the
        solver's loop counts it): a resume has nothing to do."""
        return self.load_factor > 1. - 1e-12


def scene_digest(path) -> str:
    """SHA-256 of a scene file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def history_rows(records) -> ndarray:
    """One row of :data:`HISTORY_KEYS` per step record (time and time step
    -1, energies 0 in a quasi-static run)."""
    # time and energies: dynamic runs only (-1 and 0 in quasi-static ones)
    return np.array([[r.step, r.load_factor, r.residual, r.n_active_elements,
                      r.n_free_dofs, -1 if r.newton_iterations is None
                      else r.newton_iterations,
                      -1 if r.time is None else r.time,
                      -1 if r.time_step is None else r.time_step]
                     + [0. if r.energy is None else r.energy.get(k, 0.)
                        for k in ENERGY_KEYS] for r in records],
                    dtype=np.float64).reshape(-1, len(HISTORY_KEYS))


def save_checkpoint(outdir, checkpoint: Checkpoint):
    """Write ``checkpoint.npz`` in ``outdir`` atomically (arrays only)."""
    c = checkpoint
    arrays = {"step": np.array(c.step), "nsteps": np.array(c.nsteps),
              "load_factor": np.array(c.load_factor),
              "increment": np.array(c.increment),
              "history": c.history, "reactions": c.reactions,
              "scene_sha256": np.array(c.scene_sha256),
              "counter_names": np.array(sorted(c.counters), dtype=str),
              "counter_values": np.array([c.counters[k] for k in sorted(
                  c.counters)], dtype=np.int64),
              "wall_seconds": np.array(float(c.wall_seconds)),
              "timing_names": np.array(sorted(c.timings), dtype=str),
              "timing_values": np.array([c.timings[k] for k in sorted(
                  c.timings)], dtype=np.float64),
              "tied_traction": np.array(bool(c.tied_traction)),
              "contact_sides": np.array(bool(c.contact_sides)),
              "series_every": np.array(int(c.series_every)),
              "warnings": np.array(list(c.warnings), dtype=str)}
    for name in POINT_FIELDS:
        value = getattr(c.points, name)
        if value is not None:
            arrays["points_" + name] = value
    for name, value in c.points.state.items():
        arrays["state_" + name] = value
    if c.domain0 is not None:
        arrays["domain0"] = c.domain0
    if c.end_force is not None:
        arrays["end_force"] = c.end_force
    if c.series_steps is not None:
        arrays["series_steps"] = np.asarray(c.series_steps, np.int64)
    if c.outputs is not None:
        labels = sorted(c.outputs)
        arrays.update(output_labels=np.array(labels, dtype=str),
                      output_values=np.array(
                          [c.outputs[k] for k in labels],
                          dtype=np.float64).reshape(
                              len(labels), c.step - c.outputs_from),
                      output_from=np.array(int(c.outputs_from)))
    with atomic_path(Path(outdir) / CHECKPOINT) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)


def load_checkpoint(outdir, scene_sha256: Optional[str] = None) -> Checkpoint:
    """Read and check ``checkpoint.npz`` in ``outdir``.

    Raises
    ------
    CheckpointError
        Naming the file and the field, for a missing or unreadable file, a
        missing field, a wrong type or shape, a non-finite or impossible
        value, or (``scene_sha256`` given) a checkpoint of another scene.

    """
    path = Path(outdir) / CHECKPOINT
    if not path.is_file():
        raise CheckpointError(
            "no checkpoint in {} (a run writes one every N steps and at "
            "its end with --checkpoint-every N, at --max-steps, on Ctrl-C "
            "and on a failure: a run killed without --checkpoint-every "
            "cannot resume)".format(outdir))
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile,
            KeyError, NotImplementedError) as err:   # the last: zipfile
        # on a flipped flag bit ("compressed patched data")
        if isinstance(err, ValueError) and "allow_pickle" in str(err):
            # numpy's advice to load it unsafely if one trusts it: not ours
            raise CheckpointError(
                "{}: unreadable: it holds pickled (object) data, which no "
                "checkpoint of skfem-mpm does (not loaded: it is not this "
                "package's file, or it is damaged)".format(path)) from None
        raise CheckpointError("{}: unreadable ({}: {})".format(
            path, type(err).__name__, err)) from None
    return _checked(path, arrays, scene_sha256)


def _checked(path, a: dict, scene_sha256) -> Checkpoint:
    def bad(name, why):
        return CheckpointError("{}: field {!r} {}".format(path, name, why))

    def get(name, kind, ndim=None):
        if name not in a:
            raise bad(name, "is missing")
        value = a[name]
        if value.dtype.kind not in kind or (      # float32 would round
                value.dtype.kind in "fi" and value.dtype.itemsize != 8):
            raise bad(name, "has dtype {} (expected {})".format(
                value.dtype, {"f": "64-bit float", "i": "64-bit integer",
                              "U": "text", "fi": "64-bit number",
                              "if": "64-bit number", "b": "boolean"}[kind]))
        if ndim is not None and value.ndim != ndim:
            raise bad(name, "has {} dimension(s), expected {}".format(
                value.ndim, ndim))
        if value.dtype.kind == "f" and not np.isfinite(value).all():
            raise bad(name, "holds NaN or inf")
        return value
    step, nsteps = int(get("step", "i", 0)), int(get("nsteps", "i", 0))
    if nsteps < 1:
        raise bad("nsteps", "must be >= 1, got {}".format(nsteps))
    if step < 0:
        raise bad("step", "must be >= 0, got {}".format(step))
    factor = float(get("load_factor", "f", 0))
    if not 0 <= factor <= 1:      # 1: the run's end (completed)
        raise bad("load_factor", "must lie in [0, 1], got {}".format(
            factor))
    increment = float(get("increment", "f", 0))
    if not 0 < increment <= 1. / nsteps * (1 + 1e-12):
        raise bad("increment", "must lie in (0, 1/nsteps], got {}".format(
            increment))
    digest = str(get("scene_sha256", "U", 0))
    if scene_sha256 is not None and digest != scene_sha256:
        raise CheckpointError(
            "{}: the checkpoint belongs to another scene file (SHA-256 {}..., "
            "the scene.toml beside it has {}...): refusing a stale "
            "checkpoint".format(path, digest[:12], scene_sha256[:12]))
    names = get("counter_names", "U", 1)
    values = get("counter_values", "i", 1)
    if names.shape != values.shape:
        raise bad("counter_values", "does not match counter_names")
    wall, timings = 0., {}        # kept since 2026-11-27: all or none
    kept = [k for k in TIME_FIELDS if k in a]
    if kept and len(kept) < len(TIME_FIELDS):
        raise bad(next(k for k in TIME_FIELDS if k not in a),
                  "is missing (the run's times come together)")
    if kept:
        wall = float(get("wall_seconds", "f", 0))
        phases = get("timing_names", "U", 1)
        seconds = get("timing_values", "f", 1)
        if phases.shape != seconds.shape:
            raise bad("timing_values", "does not match timing_names")
        if wall < 0 or (seconds < 0).any():
            raise bad("wall_seconds" if wall < 0 else "timing_values",
                      "must be >= 0")
        timings = {str(k): float(v) for k, v in zip(phases, seconds)}
    history = get("history", "f", 2)
    if history.shape == (step, len(HISTORY_KEYS_BEFORE_CONTACT_WORK)):
        # written before contact_work was kept apart: its contact work is
        # in internal_work, and the balance the same
        history = np.hstack([history, np.zeros((step, 1))])
    reactions = get("reactions", "f", 3)
    if history.shape[1:] == (len(HISTORY_KEYS),) and \
            history.shape[0] != step and \
            reactions.shape[0] == history.shape[0] and np.array_equal(
                history[:, 0], np.arange(1, history.shape[0] + 1)):
        # the history of steps 1 to its rows and the reactions of as many
        # steps agree: the step is the field changed
        raise bad("step", "is {} but the history and the reactions hold "
                  "steps 1 to {}".format(step, history.shape[0]))
    if history.shape != (step, len(HISTORY_KEYS)):
        raise bad("history", "has shape {}, expected ({}, {})".format(
            history.shape, step, len(HISTORY_KEYS)))
    if step and abs(history[-1, 1] - factor) > 1e-12:
        raise bad("load_factor", "{} differs from the last step's {}".format(
            factor, history[-1, 1]))
    if reactions.shape[0] != step:
        raise bad("reactions", "has {} rows for {} steps".format(
            reactions.shape[0], step))
    points = {}
    for name in POINT_FIELDS:
        key = "points_" + name
        if key in a:
            points[name] = get(key, "i" if name == "body" else "f")
        elif name not in OPTIONAL_POINT_FIELDS:
            raise bad(key, "is missing")
    if ("velocity" in points) != ("acceleration" in points):
        raise bad("points_velocity" if "velocity" not in points
                  else "points_acceleration", "is missing (a dynamic run's "
                  "velocity and acceleration come together)")
    if "volume0" in points and not (points["volume0"] > 0).all():
        raise bad("points_volume0", "must be positive")
    points["state"] = {k[len("state_"):]: get(k, "f", 1) for k in a
                       if k.startswith("state_")}
    try:
        state = MaterialPoints(**points)
    except MPMError as err:
        raise CheckpointError("{}: points: {}".format(path, err)) from None
    domain0 = get("domain0", "f", 2) if "domain0" in a else None
    if (domain0 is None) != (state.domain is None):
        raise bad("domain0" if domain0 is None else "points_domain",
                  "is missing (the points' domains and their initial values "
                  "come together)")
    if domain0 is not None and domain0.shape != state.x.shape:
        raise bad("domain0", "has shape {}, expected {}".format(
            domain0.shape, state.x.shape))
    # written since 2026-11-29 (before: a tied obstacle's multiplier)
    tied = bool(get("tied_traction", "b", 0)) if "tied_traction" in a \
        else False
    # written since 2026-11-30 (before: the declared second body's)
    sides = bool(get("contact_sides", "b", 0)) if "contact_sides" in a \
        else False
    end_force = get("end_force", "f", 1) if "end_force" in a else None
    if end_force is not None and (state.velocity is None or step == 0):
        raise bad("end_force", "is a dynamic run's after a step, and this "
                  "checkpoint's {}".format("points have no velocity"
                                          if state.velocity is None
                                          else "step is 0"))
    # kept since 2026-11-30 (before: every step written)
    every = int(get("series_every", "i", 0)) if "series_every" in a else 1
    if every < 1:
        raise bad("series_every", "must be >= 1, got {}".format(every))
    series = get("series_steps", "i", 1) if "series_steps" in a else None
    if series is not None and series.size and (
            series.min() < 0 or series.max() > step):
        raise bad("series_steps", "must lie in [0, step {}]".format(step))
    # kept since 2026-11-30 (before: none)
    warned = tuple(str(w) for w in get("warnings", "U", 1)) \
        if "warnings" in a else ()
    # kept since 2026-11-30 (before: none): all or none
    outputs, first = None, step
    held = [k for k in OUTPUT_FIELDS if k in a]
    if held and len(held) < len(OUTPUT_FIELDS):
        raise bad(next(k for k in OUTPUT_FIELDS if k not in a),
                  "is missing (the outputs' labels, values and first step "
                  "come together)")
    if held:
        labels = get("output_labels", "U", 1)
        first = int(get("output_from", "i", 0))
        if not 0 <= first <= step:
            raise bad("output_from", "must lie in [0, step {}], got {}"
                      .format(step, first))
        measured = get("output_values", "f", 2)
        if measured.shape != (labels.size, step - first):
            raise bad("output_values", "has shape {}, expected ({}, {}): "
                      "a row per label of output_labels, a column per "
                      "step after output_from".format(
                          measured.shape, labels.size, step - first))
        if np.unique(labels).size != labels.size:
            raise bad("output_labels", "names an output twice")
        outputs = {str(k): v for k, v in zip(labels, measured)}
    return Checkpoint(step=step, nsteps=nsteps, load_factor=factor,
                      increment=increment, points=state,
                      counters={str(k): int(v) for k, v in zip(names,
                                                               values)},
                      history=history, reactions=reactions,
                      scene_sha256=digest, domain0=domain0,
                      wall_seconds=wall, timings=timings,
                      end_force=end_force, tied_traction=tied,
                      contact_sides=sides,
                      series_every=every, series_steps=series,
                      warnings=warned, outputs=outputs, outputs_from=first)



def check_against(path, checkpoint: Checkpoint, initial: MaterialPoints,
                  state_names, mesh):
    """Raise :class:`CheckpointError` unless the checkpoint's points are
    those the scene seeds (what never changes: reference positions, initial
    volumes, bodies, initial domains), lie on the scene's grid ``mesh`` and
    carry exactly the point state the scene's materials and grid terms
    keep (``state_names``: internal variables, contact state, the
    rotation in small strain)."""
    points = checkpoint.points

    def bad(name, why):
        return CheckpointError("{}: field {!r} {}".format(path, name, why))
    if points.n != initial.n or points.dim != initial.dim:
        raise bad("points_x", "holds {} points in {}D, the scene seeds {} "
                  "in {}D".format(points.n, points.dim, initial.n,
                                  initial.dim))
    for name, value, seeded in (("points_x0", points.x0, initial.x),
                                ("points_volume0", points.volume0,
                                 initial.volume),
                                ("points_body", points.body, initial.body),
                                ("domain0", checkpoint.domain0,
                                 initial.domain)):
        if (value is None) != (seeded is None) or (
                value is not None and not np.array_equal(value, seeded)):
            raise bad(name, "differs from what the scene seeds")
    moved = np.minimum(                   # FE: x = x0; else x0 + u
        np.abs(points.x - points.x0 - points.displacement).max(axis=0),
        np.abs(points.x - points.x0).max(axis=0))
    off = moved > 1e-9 * np.ptp(mesh.p, axis=1).max()
    if off.any():
        worst = int(np.argmax(moved))
        raise bad("points_x", "puts {} point(s) where points_x0 and "
                  "points_displacement do not (point {} by {:.3g}): the "
                  "file was edited or damaged".format(
                      int(off.sum()), worst, moved[worst]))
    try:
        point_locator(mesh)(points.x)
    except PointsOutsideGridError as err:
        raise bad("points_x", "puts points outside the grid ({})".format(
            err)) from None
    if set(points.state) != set(state_names):
        missing = set(state_names) - set(points.state)
        extra = set(points.state) - set(state_names)
        since = written_before(points.state, state_names)
        raise bad("state_*", "{}: it lacks {} of the point state the "
                  "scene's materials and terms keep, and holds {} beyond "
                  "it".format(
                      since[2:] if since else "differs from the point "
                      "state the scene keeps", some_names(missing),
                      some_names(extra)))


def check_tied(path, checkpoint: Checkpoint, obstacles):
    """Raise :class:`CheckpointError` where the scene's ``obstacles``
    hold a tied one and the checkpoint, written before 2026-11-29, keeps
    its multiplier as point state where the run now keeps its traction:
    resumed, the multiplier read as the traction would add the penalty's
    share of the corners' mismatch to the tied force, silently."""
    tied = ["obstacle{}".format(i) if ob.name is None else ob.name
            for i, ob in enumerate(obstacles) if ob.friction == "tied"]
    if tied and not checkpoint.tied_traction and checkpoint.step > 0:
        raise CheckpointError(
            "{}: written before a tied obstacle's point state "
            "(contact<i>_t<a><c>) became its traction (2026-11-29; it held "
            "the multiplier, which a resume would take for the traction, "
            "shifting the force of tied obstacle(s) {}): run the scene "
            "again from its start".format(path, ", ".join(
                repr(name) for name in tied)))


def check_contact_sides(path, checkpoint: Checkpoint, scene):
    """Raise :class:`CheckpointError` where the checkpoint, written
    before 2026-11-30, keeps the point state of a contact between
    bodies of ``scene`` on its declared second body and the run now
    pairs that interface's other, smaller side
    (:func:`~skfem_mpm.solve.body_contact.swapped_interfaces`): resumed,
    the pressures, gaps and friction tractions would be read at the
    other body's points (zero there), a sticking interface's shear lost,
    silently."""
    if not scene.contacts or checkpoint.contact_sides \
            or checkpoint.step == 0:
        return
    points = checkpoint.points
    swapped = swapped_interfaces(scene.contacts, len(scene.bodies),
                                 [b.name for b in scene.bodies],
                                 points.body, points.volume0)
    if swapped:
        raise CheckpointError(
            "{}: written before each interface between bodies paired its "
            "smaller side's corners (2026-11-30; it paired the declared "
            "second body's, where its point state lies, and the run now "
            "pairs the other side of contact(s) {}, whose pressures and "
            "friction a resume would read at the wrong points): run the "
            "scene again from its start".format(path, ", ".join(
                repr(name) for name in swapped)))


def check_outputs(path, checkpoint: Checkpoint, labels) -> None:
    """Raise :class:`CheckpointError` unless the checkpoint's point
    outputs are the scene's, ``labels`` (the ``[[outputs]]`` of a
    displacement or stress): the scene file is the checkpoint's (its
    SHA-256), so others are an edited or damaged file.  A checkpoint
    written before they were kept (``outputs`` ``None``) passes: the
    resumed run's histories of them start at its resume."""
    if checkpoint.outputs is None or set(checkpoint.outputs) == set(labels):
        return
    raise CheckpointError(
        "{}: field 'output_labels' names the outputs {} where the scene's "
        "point outputs are {}: the file was edited or damaged".format(
            path, sorted(checkpoint.outputs), sorted(labels)))


def some_names(names, shown: int = 4) -> str:
    """A few of ``names``, counted: a refusal's brief list (a trial's
    named some 70 before its reason, 2.9 kB on one line).

    >>> some_names({"b", "a"})
    '2 (a, b)'
    >>> some_names(["n{}".format(k) for k in range(9)], 2)
    '9 (n0, n1, ...)'
    >>> some_names([])
    'none'
    """
    names = sorted(names)
    if not names:
        return "none"
    return "{} ({}{})".format(len(names), ", ".join(names[:shown]),
                              ", ..." if len(names) > shown else "")
