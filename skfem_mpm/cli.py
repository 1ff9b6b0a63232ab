"""Command line: ``skfem-mpm run | compare | study | safety`` (also
``python -m skfem_mpm``; the command's entry point is
:mod:`skfem_mpm.__main__`, which imports this module inside its Ctrl-C
handler).

The package's top layer: it builds on :mod:`skfem_mpm.scenes` and
:mod:`skfem_mpm.studies`, and no module of the package imports it.  The
command line prints; the library only logs.

"""
import argparse
import errno
import json
import logging
import os
import shutil
import signal
import sys
import tempfile
import time
from types import SimpleNamespace
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path

import numpy as np

from . import __version__
from .kernels import compile_seconds, run_clock
from .errors import (ConvergenceError, InvalidInputError, MPMError,
                     PointsOutsideGridError, PrescribedMotionError,
                     SceneError, SingularSystemError)
from .mechanics.materials import LinearElastic, state_variables
from .quadrature.locate import locate_points
from .scenes.checkpoint import (CHECKPOINT, HISTORY_KEYS, Checkpoint,
                                check_against, check_contact_sides,
                                check_outputs, check_tied, history_rows,
                                load_checkpoint, save_checkpoint,
                                scene_digest)
from .scenes.footing import scene_footing, soil_strength, still_rising
from .scenes.io import (atomic_path, clear_earlier_run,
                        interrupts_deferred, remove_temporaries,
                        terminate_as_interrupt)
from .scenes.output import (SeriesWriter, contact_pressure_fields,
                             point_cloud, von_mises, without_negative_zeros,
                             write_summary)
from .scenes import plot  # save_figure looked up when called: tests wrap it
from .scenes.plot import (STRESS_NAMES, SupportMarks, body_figure_size,
                          colour_scale, draw_deformed_shape, draw_energies,
                          draw_plastic_zone, draw_points, mark_peak,
                          pyplot)
from .scenes.quantities import (COMPONENTS, POINTWISE, QUANTITIES,
                                check_quantities, quantity_unit)
from .scenes.scene import (build_points, load_scale, obstacle_list,
                           point_bound, reaction_resultants,
                           run_scene, scene_support_dofs, support_names,
                           surface_loads)
from .scenes.scene_file import EMBEDDED, load_scene, parse_quantity, tomllib
from .spelling import did_you_mean
from .scenes.units import unit
from .solve.body_contact import body_contact_state_names, interface_count
from .solve.contact import contact_state_names
from .solve.rotation import rotation_state_names, start_missing_rotation
from .solve.core import grid_parts
from .solve.loads import side_axis
from .solve.options import Resume, end_force_of, resumed_counters
from .solve.results import PHASES, Result
from .solve.strength_reduction import (largest_displacement,
                                       reduce_strength,
                                       strength_reduction)
from .studies.column import SOURCE as COLUMN_SOURCE
from .studies.figures import plot_column_stress, plot_study
from .studies.footing import (bearing_capacity_factor, footing_error,
                              footing_pressure, limit_pressure)
from .studies.study import (CASES_UNASKED, CHOICES, DEFAULT_VARY,
                            REFERENCE_ERRORS, VARIABLES, analyse, case_error,
                            case_work, cases_of, check_reference, check_vary,
                            clock, configure, default_vary, estimate,
                            not_a_variable, report, scene_quantities, study,
                            worker_count)

DESCRIPTION = """\
Implicit Material Point Method on scikit-fem.

  skfem-mpm run                       the seed's column under self weight
                                      (the embedded scene column.toml)
  skfem-mpm run SCENE.toml --out DIR  any scene; DIR gets a ParaView time
                                      series (points.pvd, grid.pvd), PNG
                                      plots and summary.json
  skfem-mpm run SCENE.toml --out DIR --checkpoint-every 5
  skfem-mpm run --resume DIR          continue an interrupted run
  skfem-mpm compare SCENE.toml        FE and MPM on the same scene, side by
                                      side
  skfem-mpm study SCENE.toml --vary elements=4,8,16 --vary ppc=2,3
                                      accuracy against cost over a grid of
                                      choices (--workers N: local Dask)
  skfem-mpm safety SCENE.toml         the factor of safety by strength
                                      reduction (--low, --high,
                                      --tolerance, --growth)

Scene files are TOML; `python -c "import skfem_mpm.scenes.scene_file as s;
print(s.__doc__)"` lists every key, and examples/*.toml are ready to run.
"""

logger = logging.getLogger(__name__)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="skfem-mpm", description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version",
                        version="skfem-mpm {}".format(__version__),
                        help="print the version and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene (default: the column)")
    run.add_argument("scene", nargs="?", type=Path,
                     help="scene file (default: the embedded column)")
    run.add_argument("--out", type=Path, default=None,
                     help="output folder (default ./skfem-mpm-output)")
    run.add_argument("--checkpoint-every", type=int, default=0, metavar="N",
                     help="save the full state every N steps (0, the "
                     "default: never, but where a run stops early: "
                     "--max-steps, Ctrl-C, a failed step), and at the "
                     "run's end where it saved any")
    run.add_argument("--resume", type=Path, metavar="DIR",
                     help="resume the run whose output folder is DIR "
                     "(a completed run: nothing to do, exit 0); it "
                     "continues that run bit for bit, so a scene file "
                     "other than the run's, --steps other than its own "
                     "and --out elsewhere are refused")
    run.add_argument("--max-steps", type=int, metavar="N",
                     help="stop after N >= 1 steps of this invocation "
                          "(resume later with --resume)")
    run.add_argument("--steps", type=int, metavar="N",
                     help="override the scene's number of load steps "
                     "(N >= 1; with --resume only the run's own "
                     "count, completed or not)")
    run.add_argument("--no-series", action="store_true",
                     help="write plots and summary only, no VTU series")
    run.add_argument("--series-every", type=int, metavar="N",
                     help="write the VTU series at the start, every N-th "
                     "step and the last (default 1: every step; with "
                     "--resume the run's own; a large 3D run writes about "
                     "250 bytes a point a step)")
    compare = sub.add_parser("compare",
                             help="run FE and MPM on one scene and plot both")
    compare.add_argument("scene", type=Path, help="scene file")
    compare.add_argument("--out", type=Path,
                         default=Path("skfem-mpm-compare"),
                         help="output folder (default ./skfem-mpm-compare)")
    study = sub.add_parser(
        "study", help="error and cost over a grid of choices",
        description="Vary elements (the cells along the grid's most "
        "refined axis, the other axes in proportion, but an axis of one "
        "cell stays one cell where another has more: a strip one cell "
        "wide, such as the column, stays one, its cell size the cells' "
        "length along it; a value that does "
        "not scale every axis to whole cells is refused before any work, "
        "naming the axis, the count it would need and the values that "
        "keep whole cells, and so are values of which none keeps the "
        "scene's faces on the grid lines its own grid has them on), ppc "
        "(points per cell and axis), "
        "loadsteps, method (fem, mpm, ugimp, cpgimp, bspline, "
        "bspline-gimp, bspline3, bspline3-gimp), "
        "rhs (residual, "
        "increment: the right-hand side of linear steps), line_search "
        "(backtracking, armijo, none) and newton (full, modified: the "
        "tangent factorised once a step); without --vary, "
        "the seed's grid: elements 4..256 doubling (where those do not "
        "scale the scene's grid to whole cells keeping its faces on its "
        "grid lines, the doubling series from "
        "the least value from 4 that does, up to 256, three at least: "
        "23, 46, 92, 184 on 22 x 23 cells), ppc 2..5, loadsteps 1, 2, 20 "
        "(up to 84 cases: refused without --all).  Prints the number of "
        "cases "
        "and an estimate of their time before it starts them (from the "
        "smallest cases, run first).  "
        "Measures the scene's [[outputs]] (or --measure; default: the "
        "largest point displacement, a footing scene's peak footing "
        "pressure) in every case, with the observed "
        "order, the Richardson-extrapolated value and its uncertainty "
        "(GCI) over the element counts; the error of a case is against the "
        "scene's closed-form reference where it has one, else the first "
        "quantity's against its extrapolation.")
    study.add_argument("scene", type=Path, help="scene file")
    study.add_argument("--vary", action="append", default=[],
                       metavar="NAME=V1,V2,...",
                       help="values of one choice: {} (repeat for "
                       "more choices, each once); a dynamic scene's time "
                       "step is not one: study one copy of the scene per "
                       "[dynamics] time_step".format(", ".join(VARIABLES)))
    study.add_argument("--measure", action="append", default=[],
                       metavar="KEY=VALUE,...",
                       help="a quantity of interest as the keys of a "
                       "scene file's [[outputs]] table, e.g. 'quantity="
                       "\"displacement\", component=\"y\", at=[0.5, 50.0]' "
                       "(repeat for more; replaces the scene's outputs)")
    study.add_argument("--out", type=Path, default=Path("skfem-mpm-study"),
                       help="output folder (default ./skfem-mpm-study); "
                       "a study resumes there without re-running cases")
    study.add_argument("--workers", type=int, default=0,
                       help="run on a local Dask cluster of N workers")
    study.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on the Dask scheduler at ADDRESS")
    study.add_argument("--all", action="store_true",
                       help="without --vary, run the whole default grid "
                       "(up to {} cases, {} for a dynamic scene, which "
                       "varies no "
                       "load steps; more than {} are refused without this "
                       "flag)".format(len(cases_of(DEFAULT_VARY)),
                                      len(cases_of({
                                          k: v for k, v in
                                          DEFAULT_VARY.items()
                                          if k != "loadsteps"})),
                                      CASES_UNASKED))
    safety = sub.add_parser(
        "safety", help="the factor of safety by strength reduction",
        description="The factor of safety of a static scene by strength "
        "reduction (skfem_mpm.strength_reduction): the scene is run with "
        "the strength of its bodies divided by trial factors F (c / F and "
        "tan(phi) / F for Mohr-Coulomb and Drucker-Prager, the dilation "
        "angle likewise; the yield stress / F for von Mises; linear "
        "elastic bodies and rigid bodies unchanged), bracketed from "
        "--low and --high (doubled until a trial collapses) and bisected "
        "to --tolerance.  A trial stands when its run converges and its "
        "largest point displacement is at most --growth times that of "
        "the run at --low; it collapses otherwise.  A failed run at the "
        "top of the final bracket is retried with twice the load steps "
        "(up to 3 retries; --no-retry: none); every trial is judged at "
        "the end: a run that failed below a trial that stood (not one "
        "that converged past --growth: a collapse) or a verdict not "
        "monotone in F widens the factor's span beyond its bracket (a "
        "WARNING).  Prints a line per trial; writes safety.json "
        "(every trial with its error message, the factor, its bracket "
        "and span), safety.png (largest displacement against F) and "
        "mechanism.png (the plastic zone of the last trial that stood) "
        "to --out.  Recommended: --low well below the factor (1 for a "
        "slope thought to stand), 8 or more load steps.")
    safety.add_argument("scene", type=Path, help="scene file")
    safety.add_argument("--out", type=Path,
                        default=Path("skfem-mpm-safety"),
                        help="output folder (default ./skfem-mpm-safety)")
    safety.add_argument("--low", default="1", metavar="F",
                        help="first factor, one at which the scene stands "
                        "(its run sets the scale of --growth; default 1)")
    safety.add_argument("--high", default="2", metavar="F",
                        help="first guess of a factor at which it "
                        "collapses, > --low (doubled up to 5 times until "
                        "a trial collapses; default 2)")
    safety.add_argument("--tolerance", default="0.01", metavar="T",
                        help="relative width of the final bracket, "
                        "0 < T < 1 (default 0.01)")
    safety.add_argument("--growth", default="5", metavar="G",
                        help="a trial that converges but moves more than "
                        "G times the run at --low has collapsed (G > 1; "
                        "default 5); 'none': convergence alone decides")
    safety.add_argument("--steps", default=None, metavar="N",
                        help="override the scene's number of load steps "
                        "(N >= 1; 8 or more recommended)")
    safety.add_argument("--no-retry", action="store_true",
                        help="do not retry a failed run at the top of the "
                        "bracket with twice the load steps")
    for p in (run, compare, study, safety):
        p.add_argument("--no-progress", action="store_true",
                       help="no progress bar")
        p.add_argument("-v", "--verbose", action="store_true",
                       help="log every load step (and the linear solver "
                       "chosen)")
    return parser


#: where the progress stream is not a terminal (a log file), a line is
#: written at most this often (seconds), and one at the end: a trial's
#: 3D run redirected to a log showed no progress in its 31 s, another's
#: short run none at all where the README promised one at the end
LINE_INTERVAL = 10.


class Progress:
    """Progress on ``stream`` (stderr): on a terminal (or ``enabled`` is
    ``"always"``) a one-line bar redrawn in place, elsewhere (a log file)
    a line at most every :data:`LINE_INTERVAL` seconds and one at the
    end (of the last step done, also where a run stopped early); each
    with the step, the load factor (or time) as a bar, Newton
    iterations, residual, elapsed time and an estimate of the time left,
    from the pace since ``start_factor`` (where a resumed run began).
    A log record written by a handler with a :class:`BarBreak` while
    the bar is on its line starts on a line of its own."""

    #: the bar on its line, not ended (a log record breaks it first)
    drawn_bar = None

    def __init__(self, total: int, enabled, start_factor: float = 0.,
                 stream=None, timer=time.monotonic, started=None):
        self.total = total
        self.stream = sys.stderr if stream is None else stream
        self.enabled = bool(enabled)
        self.bar = enabled == "always" or (
            self.enabled and self.stream.isatty())
        self.start_factor = start_factor
        self.timer = timer
        # elapsed from ``started`` (the set-up's start: a trial's 1e6
        # points said 0:36 at step 1, 60 s after its launch), the pace
        # from the steps' start
        self.paced = self.written = timer()
        self.started = self.paced if started is None else started
        self.drawn = False      # a bar is on its line, not ended
        self.pending = None     # the last line, not written (no terminal)

    def __call__(self, record):
        if not self.enabled:
            return
        done = int(30 * record.load_factor)
        newton = "" if record.newton_iterations is None else \
            " newton {}".format(record.newton_iterations)
        now = self.timer()
        elapsed = now - self.started
        progressed = record.load_factor - self.start_factor
        left = "" if progressed <= 0 else " left {}".format(clock(
            (now - self.paced) * (1. - record.load_factor) / progressed))
        # past the steps planned (cut-backs), the count is not a share:
        # a trial read "step   43/40"; the bar is the load factor's
        count = "{:4d}/{}".format(record.step, self.total) \
            if record.step <= self.total else "{:4d} ({} planned)".format(
                record.step, self.total)
        words = "step {} [{}{}]{} residual {:.1e} elapsed {}{}".format(
            count, "#" * done, "." * (30 - done), newton,
            record.residual, clock(elapsed), left)
        last = record.load_factor >= 1.
        if self.bar:
            self.stream.write("\r" + words)
            self.drawn = not last
            Progress.drawn_bar = self if self.drawn else None
            if last:
                self.stream.write("\n")
        elif now - self.written >= LINE_INTERVAL or last:
            self.stream.write(words + "\n")
            self.written, self.pending = now, None
        else:
            self.pending = words
            return
        self.stream.flush()

    def end(self):
        """End a bar left on its line, or write the last step's line
        not written (a run that stopped early)."""
        if self.drawn:
            self.stream.write("\n")
            self.drawn = False
        elif self.pending is not None:
            self.stream.write(self.pending + "\n")
            self.pending = None
        else:
            return
        if Progress.drawn_bar is self:
            Progress.drawn_bar = None
        self.stream.flush()


#: a run's set-up says its stages on stderr once it has lasted this long
#: (s), or from the start where the grid holds this many sub-cells
#: (:class:`SetUp`)
LONG_SETUP, LARGE_SETUP = 2., 100_000


class SetUp:
    """The stages of a run's set-up on ``stream`` (stderr) where
    ``enabled`` (the progress is): each as it begins, with the time
    elapsed since the set-up began (``started``), once that is
    :data:`LONG_SETUP` or the run is ``large`` (a trial's 1e6-point run
    wrote its first line 28 s after its launch, its first step 60 s)."""

    def __init__(self, enabled, stream=None, timer=time.monotonic):
        self.enabled = bool(enabled)
        self.stream = sys.stderr if stream is None else stream
        self.timer = timer
        self.started = timer()
        self.large = False

    def __call__(self, stage: str):
        elapsed = self.timer() - self.started
        if self.enabled and (self.large or elapsed >= LONG_SETUP):
            self.stream.write("set-up: {}, elapsed {}\n".format(
                stage, clock(elapsed)))
            self.stream.flush()


class BarBreak(logging.Filter):
    """On a handler writing to ``stream``: a record ends the progress
    bar drawn there first, so that it starts on a line of its own (a
    trial's warning was glued to the bar: ``... left 0:01skfem_mpm.solve
    .rotation: step 9 ...``)."""

    def __init__(self, stream):
        super().__init__()
        self.stream = stream

    def filter(self, record):
        bar = Progress.drawn_bar
        if bar is not None and bar.drawn and bar.stream is self.stream:
            bar.stream.write("\n")
            bar.stream.flush()
            bar.drawn = False
            Progress.drawn_bar = None
        return True


def break_bars_for_logs():
    """A :class:`BarBreak` on each root handler writing to stderr (once)."""
    for handler in logging.getLogger().handlers:
        stream = getattr(handler, "stream", None)
        if stream is sys.stderr and not any(
                isinstance(f, BarBreak) for f in handler.filters):
            handler.addFilter(BarBreak(stream))


class StopRun(Exception):
    """Raised by the step callback to end a run early (``--max-steps``)."""


class RunComplete(Exception):
    """Raised by :func:`load_run` where ``--resume`` names a run that
    completed: nothing to do (the message says so)."""


#: ``summary.json``'s ``figures`` of a completed run interrupted while
#: drawing its figures (a later ``--resume`` said only that it was
#: complete)
FIGURES_MISSING = "missing: the run was interrupted while drawing them"


#: ``summary.json``'s ``figures`` of an interrupted run whose figures of
#: the steps done were not drawn (a second interrupt stopped them)
FIGURES_INTERRUPTED = "missing: a second interrupt stopped their drawing"


def completed_before(outdir: Path) -> bool:
    """Whether ``summary.json`` in ``outdir`` says its run completed
    (unreadable or absent: ``False``)."""
    return summary_of(outdir).get("status") == "completed"


def summary_of(outdir: Path) -> dict:
    """``summary.json`` in ``outdir`` (unreadable or absent: empty)."""
    try:
        summary = json.loads((outdir / "summary.json").read_text())
    except (OSError, ValueError):
        return {}
    return summary if isinstance(summary, dict) else {}


def figures_note(outdir: Path) -> str:
    """The words of a completed run's resume on its figures: ``""``, or
    where its ``summary.json`` says they are missing, that running the
    scene again draws them."""
    if summary_of(outdir).get("figures") != FIGURES_MISSING:
        return ""
    return ("; its figures are missing (the run was interrupted while "
            "drawing them): run the scene again to draw them")


def summarise(scene, result, seconds: float, earlier=None,
              complete: bool = True, measured=None) -> dict:
    """The numbers of a run, for ``summary.json`` and the terminal; with
    ``earlier`` (the :class:`~skfem_mpm.scenes.checkpoint.Checkpoint` a
    run resumed from), over the whole run: history rows, Newton iterations,
    reactions, the outputs' histories and what they give (a footing's
    peak pressure), wall seconds and seconds per phase of the invocations
    before the resume included (``seconds``: this invocation's).  A run
    not ``complete`` (failed, stopped, interrupted: ``result`` holds the
    steps that converged) gets no ``error`` against the scene's closed
    form, which is the full load's.  ``measured``: the scene's point
    outputs (:func:`point_outputs`) at each step of ``result.history``,
    (outputs, steps), as the steps ended (:func:`output_summaries`)."""
    pts = result.points
    history = result.history
    names, resultant = reaction_resultants(scene)
    rows = history_rows(history)
    reactions = np.array([resultant(r) for r in history]).reshape(
        len(history), len(names), pts.dim)
    if earlier is not None:
        rows = np.vstack([earlier.history, rows])
        reactions = np.concatenate([earlier.reactions.reshape(
            len(earlier.history), len(names), pts.dim), reactions])
    summary = {
        "scene": scene.name, "method": scene.method,
        "bodies": [b.name for b in scene.bodies],
        "kinematics": scene.kinematics, "newton": scene.newton.newton,
        "steps": scene.step_count,
        "steps_run": len(rows), "points": int(pts.n),
        "load_factor": float(rows[-1, 1]) if len(rows) else 0.,
        "max_residual": float(rows[:, 2].max()) if len(rows) else 0.,
        "wall_seconds": seconds + (0. if earlier is None
                                   else earlier.wall_seconds),
        "timings": run_timings(result.history, earlier),
        "counters": result.counters,
        "max_displacement": largest_displacement(result),
        "reactions": {name: reactions[:, k].tolist()
                      for k, name in enumerate(names[:len(scene.supports)])},
        "units": summary_units(pts.dim, scene.dynamics is not None,
                               scene.units),
    }
    summary.update(rigid_body_curves(scene, rows, reactions))
    if scene.dynamics is not None and len(rows):
        summary["energies"] = energy_curves(rows)
    if len(rows) and (rows[:, 5] >= 0).any():
        summary["newton_iterations"] = [int(max(k, 0)) for k in rows[:, 5]]
    if not complete:
        error = np.nan
    elif scene.reference == "bearing_capacity":
        error = footing_error(scene,
                              reactions[:, scene_footing(scene).column])
        if len(rows):
            summary["bearing_capacity"] = bearing_capacity(scene, rows,
                                                           reactions)
    else:
        error = case_error(scene, result)
    if np.isfinite(error):
        summary["error"] = error
    if complete and len(rows) and (
            scene.reference == "bearing_capacity" or any(
                q.quantity == "footing_pressure" for q in scene.outputs)):
        rising = still_rising(footing_pressure(scene, reactions[
            :, scene_footing(scene).column]), unit("stress", scene.units))
        if rising:
            logger.warning("%s: %s", scene.name, rising)
    if scene.outputs and len(rows):
        summary["outputs"] = output_summaries(scene, result, rows,
                                              reactions, earlier, measured)
    return without_negative_zeros(summary)    # no "-0 N" printed


def bearing_capacity(scene, rows, reactions) -> dict:
    """A footing scene's peak pressure over the run's history ``rows``
    and ``reactions`` (as :func:`summarise` has them): ``peak_pressure``,
    its ``peak_step``, ``N_c c`` (``limit_pressure``) and
    ``signed_error``, ``peak_pressure / limit_pressure - 1`` (negative
    below ``N_c c``; ``error`` is its size)."""
    pressure = footing_pressure(scene, reactions[
        :, scene_footing(scene).column])
    peak, limit = int(np.argmax(pressure)), limit_pressure(scene)
    return {"peak_pressure": float(pressure[peak]),
            "peak_step": int(rows[peak, 0]), "limit_pressure": limit,
            "signed_error": float(pressure[peak] / limit - 1)}


def point_outputs(scene) -> list:
    """The scene's ``[[outputs]]`` of a displacement or stress of the
    points, in order: measured at each step as it ends (the points'
    state is not kept per step) and kept in a checkpoint."""
    return [q for q in scene.outputs if q.quantity in POINTWISE]


def output_summaries(scene, result, rows, reactions, earlier=None,
                     measured=None) -> dict:
    """``summary.json``'s ``outputs``: per ``[[outputs]]`` label its
    ``value``, ``unit`` and ``history`` (columns ``step``, ``load_factor``,
    ``time`` in dynamics, ``value``) over the run's history ``rows`` and
    ``reactions`` (resumes included, as :func:`summarise` has them).  A
    force or a footing's pressure comes from the reactions (a
    ``footing_pressure``'s ``value`` the largest of its history's), a
    displacement or stress from ``measured``, this invocation's values
    at each step as it ended (a mean over points weighted by that step's
    volumes), after the checkpoint ``earlier``'s (one written before
    2026-11-30 kept none: the history starts at the resume); its
    ``value`` is :meth:`~skfem_mpm.scenes.quantities.Quantity.measure`'s
    on ``result``.  Without ``measured`` (``skfem-mpm compare``'s runs,
    from their start) the records' snapshots give them
    (:meth:`~skfem_mpm.scenes.quantities.Quantity.history`: a mean
    weighted by the final volumes)."""
    dim, pointwise = result.points.dim, point_outputs(scene)
    before = {} if earlier is None else earlier.outputs or {}
    out = {}
    for q in scene.outputs:
        if q.quantity in POINTWISE and measured is None:
            history = q.history(scene, result)
        else:
            values = q.of_forces(scene, reactions) \
                if q.quantity not in POINTWISE else np.r_[
                    before.get(q.label, []), measured[pointwise.index(q)]]
            steps = rows[len(rows) - len(values):]
            history = {"step": steps[:, 0].astype(int).tolist(),
                       "load_factor": steps[:, 1].tolist()}
            if scene.dynamics is not None:
                history["time"] = steps[:, HISTORY_KEYS.index(
                    "time")].tolist()
            history["value"] = np.asarray(values).tolist()
        values = history["value"]
        out[q.label] = {
            "value": q.measure(scene, result) if q.quantity in POINTWISE
            else max(values) if q.quantity == "footing_pressure"
            else values[-1],
            "unit": q.unit(dim, scene.units), "history": history}
    return out


def run_timings(records, earlier=None) -> dict:
    """Seconds per phase (:data:`~skfem_mpm.solve.results.PHASES`) of the
    step ``records``, with those of the invocations before the
    checkpoint ``earlier`` a run resumed from."""
    before = {} if earlier is None else earlier.timings
    return {p: before.get(p, 0.) + sum(r.timings[p] for r in records)
            for p in PHASES}


def summary_units(dim: int, dynamics: bool = False,
                  system: str = "SI") -> dict:
    """The units of a ``summary.json``'s numbers in the scene's units
    ``system`` (:mod:`~skfem_mpm.scenes.units`, named under ``system``):
    its top-level ones by key, and ``force``, ``displacement`` and
    (``dynamics``) ``time`` for the per-step curves of rigid bodies,
    obstacles and contacts (their peaks and final values alike) and the
    ``energies``;
    ``outputs`` carry their own (a user trial read ``max_displacement``
    without one).

    >>> from skfem_mpm.cli import summary_units
    >>> summary_units(2, system="kN-m")["reactions"]
    'kN/m'
    """
    force, length, time = (unit(k, system, dim) for k in (
        "force", "length", "time"))
    units = {"system": system, "max_displacement": length,
             "max_residual": "-", "wall_seconds": "s", "timings": "s",
             "compile_seconds": "s", "load_factor": "-",
             "reactions": force, "force": force, "displacement": length,
             # a count and dimensionless errors (a lecturer's trial
             # found them without a unit)
             "points": "-", "steps": "-", "steps_run": "-", "error": "-",
             # a footing scene's
             "bearing_capacity": "{} (peak_step, signed_error: -)".format(
                 unit("stress", system, dim))}
    if dynamics:      # a static run has no energies (a trial read its
        units["time"] = time        # unit as though it had)
        units["energies"] = "{} (time: {})".format(
            unit("energy", system, dim), time)
    return units


def energy_curves(rows) -> dict:
    """A dynamic run's energies over time from its history ``rows``: at
    the start and after every step, ``time`` (s), ``kinetic`` energy and
    the accumulated ``internal_work`` (the points' stresses'),
    ``external_work`` (the loads') and ``contact_work`` (obstacles' and
    contacts' forces) (J, per unit thickness in 2D) and ``balance``, as
    :meth:`skfem_mpm.Result.energies`."""
    col = {k: rows[:, HISTORY_KEYS.index(k)] for k in HISTORY_KEYS}
    kinetic = np.r_[col["kinetic_start"][0], col["kinetic"]]
    internal = np.r_[0., np.cumsum(col["internal_work"])]
    external = np.r_[0., np.cumsum(col["external_work"])]
    contact = np.r_[0., np.cumsum(col["contact_work"])]
    return {
        "time": [float(col["time"][0] - col["time_step"][0])]
        + col["time"].tolist(),
        "kinetic": kinetic.tolist(), "internal_work": internal.tolist(),
        "external_work": external.tolist(),
        "contact_work": contact.tolist(),
        "balance": (kinetic + internal + contact - external).tolist()}


def rigid_body_curves(scene, rows, reactions) -> dict:
    """``{"rigid_bodies": {name: {"displacement", "force", ...}},
    "obstacles": {name: ...}, "contacts": {name: ...}}`` per step of the
    history ``rows`` and the ``reactions`` (steps, supports + rigid bodies
    + obstacles + contacts, dim) of
    :func:`~skfem_mpm.scenes.scene.reaction_resultants`; a key only where
    the scene has such bodies.  A rigid body's force is the one that
    holds its motion, an obstacle's the one the material exerts on it, a
    contact's the one its first body exerts on its second;
    the peak (:func:`peak_step`) is where the force along the motion that
    resists it is largest, signed (an obstacle that does not move: the
    largest force), ``first_force`` the first step's; in dynamics each
    step's ``time`` (s) beside its ``load_factor`` (there t / duration)."""
    rigid = [(b.name, b.rigid, 1.) for b in scene.bodies
             if b.rigid is not None]
    obstacles = [(o.name, o.displacement, -1.)
                 for o in obstacle_list(scene)]
    contacts = [(c.name, None, 1.) for c in scene.contacts]
    times = None if scene.dynamics is None else \
        rows[:, HISTORY_KEYS.index("time")]
    out, first = {}, len(scene.supports)
    for key, items in (("rigid_bodies", rigid), ("obstacles", obstacles),
                       ("contacts", contacts)):
        if items:
            out[key] = motion_curves(items, rows[:, 1],
                                     load_scale(scene, rows[:, 1]),
                                     reactions[:, first:first + len(items)],
                                     times)
        first += len(items)
    return out


def motion_curves(items, factors, scale, forces, times=None) -> dict:
    """Per item ``(name, displacement at full load, sign)`` its
    displacement and force per step (``forces``: steps x items x dim; the
    steps' load ``factors``, the loads' ``scale`` and, in dynamics, the
    steps' ``times``), the peak and the final force; ``sign`` turns the
    force to the one that resists the motion.  An item with no
    displacement (``None``: a contact between bodies) has no displacement
    keys."""
    curves = {}
    for k, (name, motion, sign) in enumerate(items):
        force = forces[:, k]
        displacement = scale[:, None] * np.asarray(
            np.zeros(force.shape[1]) if motion is None else motion)
        peak = peak_step(force, motion, sign)
        curves[name] = {
            "load_factor": np.asarray(factors).tolist(),
            "displacement": displacement.tolist(), "force": force.tolist(),
            "peak_force": None if peak is None else force[peak].tolist(),
            "peak_displacement": None if peak is None
            else displacement[peak].tolist(),
            "first_force": force[0].tolist() if len(force) else None,
            "final_force": force[-1].tolist() if len(force) else None}
        if times is not None:
            curves[name]["time"] = np.asarray(times).tolist()
        if motion is None:
            del curves[name]["displacement"], \
                curves[name]["peak_displacement"]
    return curves


def peak_step(force, motion, sign: float = -1.):
    """The step (index into ``force``, steps x dim; ``None`` without
    steps) of the peak that ``summary.json`` and the pictures give: where
    the force along the ``motion`` that resists it (``sign``: -1 for the
    force of the material on an obstacle, +1 for the one that holds a
    rigid body's motion) is largest, signed.  The material pushing an
    obstacle along its motion (an active wall moving away from the soil)
    resists it negatively: the peak is then the step it pushes least, the
    active limit (a user trial's wall read 25.41 in summary.json and 25.74
    in the picture, the largest push).  Without a motion (``None`` or
    zero) the largest force.

    >>> import numpy as np
    >>> from skfem_mpm.cli import peak_step
    >>> push = np.array([[25.74, 0.], [25.6, 0.], [25.41, 0.]])
    >>> peak_step(push, [.03, 0.]), peak_step(push, [-.03, 0.])
    (2, 0)
    """
    force = np.asarray(force, dtype=float)
    if not len(force):
        return None
    size = 0. if motion is None else np.linalg.norm(motion)
    if size > 0:
        resistance = sign * force @ (np.asarray(motion) / size)
    else:                                  # a fixed obstacle: the largest
        resistance = np.linalg.norm(force, axis=1)
    return int(np.argmax(resistance))


def at_rest_start(scene) -> bool:
    """Whether the scene's run starts at rest, its forces zero at step 0
    (drawn there in the force curves); ``False`` where a body starts from
    a geostatic stress (``K0``): its forces at step 0 are not computed,
    and a curve from 0 drew a rise that was not there (a user trial's
    wall, at rest at 38.6 kN/m, seemed to rise from 0 to 25.7 as it
    moved away from the soil)."""
    return not any(getattr(b, "K0", None) is not None
                   for b in getattr(scene, "bodies", ()))


def plot_outputs(scene, result, outdir: Path, loaded, summary: dict,
                 initial=None, when=None, load_factor=None):
    """The deformed shape with the supports and rigid bodies
    (``initial``: the points as seeded, for the undeformed outline;
    ``when`` and ``load_factor``: the state the points are in, by default
    the last step's);
    final configuration coloured by the vertical stress and (2D, 3D) by
    the von Mises stress; the plastic zone (equivalent plastic strain)
    where a body yielded; the column's
    stress profile; a load-displacement curve when there are point
    loads; the force-displacement curves of rigid bodies (over the whole
    run, from ``summary``), as footing pressure against settlement for a
    bearing-capacity scene.  A run that did not complete (``summary``'s
    ``status``) draws the same for the steps that converged, but for the
    column's profile against the closed forms of the full load."""
    pts = result.points
    last = result.history[-1] if result.history else None
    if when is None:
        when = "" if last is None else "at t = {:.4g} s".format(
            last.time) if last.time is not None else \
            "at load factor {:.4g}".format(last.load_factor)
    if load_factor is None:
        load_factor = 0. if last is None else last.load_factor
    plot_deformed_shape(scene, pts, when,
                        None if initial is None else initial.domain,
                        outdir / "deformed_shape.png", load_factor)
    d = pts.dim - 1
    name = STRESS_NAMES[d, d]
    stress = unit("stress", scene.units)
    fig, ax = pyplot().subplots(figsize=(6, 4) if pts.dim == 1 else
                                body_figure_size(pts.x[:2]))
    draw_points(fig, ax, pts, pts.stress[d, d],
                "{} ({})".format(name, stress),
                "{}: {} at the final points (Cauchy, tension positive, "
                "global axes)".format(scene.name, name))
    fig.tight_layout()
    plot.save_figure(fig, outdir / "final_stress.png")
    if pts.dim > 1:
        fig, ax = pyplot().subplots(figsize=body_figure_size(pts.x[:2]))
        draw_points(fig, ax, pts, von_mises(pts.stress),
                    "von Mises stress ({})".format(stress),
                    "{}: von Mises stress at the "
                    "final points".format(scene.name))
        fig.tight_layout()
        plot.save_figure(fig, outdir / "final_von_mises.png")
    plastic = pts.state.get("equivalent_plastic_strain")
    if pts.dim > 1 and plastic is not None and np.any(plastic > 0):
        fig, ax = pyplot().subplots(figsize=body_figure_size(pts.x[:2]))
        draw_points(fig, ax, pts, plastic, "equivalent plastic strain (-)",
                    "{}: plastic zone, equivalent plastic strain at the "
                    "final points (0: elastic)".format(scene.name))
        fig.tight_layout()
        plot.save_figure(fig, outdir / "plastic_zone.png")
    if scene.reference == "column" and summary.get("status") in (
            None, "completed"):
        plot_column_stress([result], ["{}, {} steps".format(
            scene.method, scene.step_count)], outdir / "column_stress.png",
            title="{}: vertical stress against initial height,\nwith "
            "the linear solution; (2.28) of {}: {}".format(
                scene.name, COLUMN_SOURCE,
                "{:.3g}".format(summary["error"]) if "error" in summary
                else "-"), unit=stress)
    if loaded.size and result.history and \
            result.history[0].displacement is not None:
        fig, ax = pyplot().subplots(figsize=(5, 4))
        # in dynamics the load factor is t / duration: against time (a
        # user trial's step load read as a load cycled)
        dynamic = scene.dynamics is not None
        # a resumed run holds the steps since its resume alone (the
        # checkpoint keeps no point's displacement per step): drawn from
        # there, not from a start at rest it does not know (a line from
        # (0, 0) to the resume's first step was drawn)
        first = result.history[0].step
        origin = [] if first > 1 else [0.]
        factor = origin + [r.time if dynamic else r.load_factor
                           for r in result.history]
        for k in range(pts.dim):
            disp = origin + [r.displacement[k, loaded].mean()
                             for r in result.history]
            ax.plot(disp, factor, "o-", ms=3, label="xyz"[k])
        ax.set_xlabel("mean displacement of the loaded points ({})"
                      .format(unit("length", scene.units)))
        ax.set_ylabel("time ({})".format(unit("time", scene.units))
                      if dynamic else "load factor (-)")
        ax.set_title("{}: {} against displacement\nof the loaded "
                     "material points{}".format(
                         scene.name, "time" if dynamic else "load",
                         "" if first == 1 else ", steps {} to {} (resumed)"
                         .format(first, result.history[-1].step)))
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 3))
        ax.legend(title="component")
        fig.tight_layout()
        plot.save_figure(fig, outdir / "load_displacement.png")
    if not summary.get("steps_run", 1):     # no curve to draw
        return
    if "rigid_bodies" in summary:
        plot_rigid_bodies(scene, summary["rigid_bodies"],
                          outdir / "rigid_bodies.png")
    if "obstacles" in summary:
        plot_contact_forces(scene, summary["obstacles"], {
            o.name: o.displacement for o in obstacle_list(scene)},
            "obstacles", outdir / "obstacles.png")
        if scene.reference == "bearing_capacity" and \
                scene_footing(scene).kind == "obstacles":
            plot_bearing_capacity(scene, summary["obstacles"],
                                  outdir / "bearing_capacity.png")
    if "contacts" in summary:
        plot_contact_forces(scene, summary["contacts"], {
            c.name: 0. for c in scene.contacts}, "contacts",
            outdir / "contacts.png")
    if "energies" in summary:
        fig, ax = pyplot().subplots(figsize=(6, 4))
        draw_energies(ax, summary["energies"], "{}: energies over time"
                      .format(scene.name),
                      unit=unit("energy", scene.units, pts.dim))
        fig.tight_layout()
        plot.save_figure(fig, outdir / "energies.png")


def support_marks(scene, mesh, elem) -> list:
    """The scene's supports as
    :class:`~skfem_mpm.scenes.plot.SupportMarks` on the grid ``mesh``:
    the nodes each holds, labelled by its name, where it is and what it
    holds (fixed, or moved by its ``value`` at full load)."""
    grid, dim = grid_parts(mesh, elem)[1], mesh.dim()
    marks = []
    for name, s in zip(support_names(scene), scene.supports):
        held = tuple("xyz".index(c) for c in s.components
                     if "xyz".index(c) < dim)
        dofs = scene_support_dofs(s, grid, dim)
        sides = [s.boundary] if isinstance(s.boundary, str) \
            else s.boundary
        where = " + ".join(sides) if sides else (
            "at {}".format(list(s.at)) if s.at is not None
            else "region" if s.region is not None else "where(x)")
        what = ", ".join("xyz"[c] for c in held) + (
            " fixed" if s.value is None else " moved by {} m at full "
            "load".format(list(s.value)))
        marks.append(SupportMarks("{} ({}): {}".format(name, where, what),
                                  grid.doflocs[:, dofs[0]], held,
                                  s.value is not None))
    return marks


def drivers(scene, pts, deformed, mesh, elem) -> tuple:
    """What drives a 3D run besides its obstacles, for the slice of its
    pictures (:func:`~skfem_mpm.scenes.plot.slice_plane`): the boxes
    (3, 2) of the rigid bodies' points at ``deformed`` (their domains'
    reach) and of the nodes of the moving supports, their motions, and
    the symmetry planes: ``(axis, position)`` of each grid side a
    support holds across it alone (a roller)."""
    boxes, motions, mirrors = [], [], []
    spacing = .5 * float(np.cbrt(np.median(pts.volume)))
    for k, body in enumerate(scene.bodies):
        mine = pts.body == k
        if body.rigid is not None and mine.any():
            boxes.append(np.stack([deformed[:, mine].min(axis=1) - spacing,
                                   deformed[:, mine].max(axis=1) + spacing],
                                  axis=1))
            motions.append(np.asarray(body.rigid, float))
    grid, dim = grid_parts(mesh, elem)[1], mesh.dim()
    for s in scene.supports:
        held = ["xyz".index(c) for c in s.components]
        if s.value is not None and np.any(s.value):
            places = grid.doflocs[:, scene_support_dofs(s, grid, dim)[0]]
            motion = np.zeros(dim)
            motion[held] = s.value
            boxes.append(np.stack([places.min(axis=1), places.max(axis=1)],
                                  axis=1))
            motions.append(motion)
        elif s.boundary is not None:
            for side in [s.boundary] if isinstance(s.boundary, str) \
                    else s.boundary:
                axis, sign = side_axis(side, dim)
                if held == [axis]:
                    mirrors.append((axis, float(
                        mesh.p[axis].max() if sign > 0
                        else mesh.p[axis].min())))
    return boxes, motions, mirrors


def plot_deformed_shape(scene, pts, when: str, half, path: Path,
                        load_factor: float):
    """The deformed shape of the points ``pts`` of a run
    (:func:`~skfem_mpm.scenes.plot.draw_deformed_shape`), ``when`` saying
    which state they are in the title: the points coloured by their
    displacement magnitude over the undeformed outline (``half``: the
    initial points' half-widths), the supports, the rigid bodies and the
    obstacles where they are at ``load_factor`` (the run's load factor
    in that state; with dynamics the fraction of the duration), to
    ``path``; in 3D a vertical slice through the obstacles
    (:func:`~skfem_mpm.scenes.plot.slice_plane`), their sections drawn;
    small displacements exaggerated, the title saying by how much
    (:func:`~skfem_mpm.scenes.plot.displacement_scale`)."""
    mesh, elem = scene.grid.build()
    # small displacements exaggerated, the obstacles' motion with them
    # (the body's side: its points' reach, not their centres')
    scale = plot.displacement_scale(
        pts.x0, pts.displacement, half if half is not None else
        pts.volume0 ** (1. / pts.dim) / 2)
    shift = scale * load_scale(scene, [load_factor])[0]
    rigid = {b.name: pts.body == k for k, b in enumerate(scene.bodies)
             if b.rigid is not None}
    deformed = pts.x0 + scale * pts.displacement
    plane, moved = None, [(o.name, o.box + shift * o.displacement[:, None]
                           if o.box is not None else None, o.displacement)
                          for o in obstacle_list(scene)]
    if pts.dim == 2:
        obstacles = [(o.name, o.outline(shift * o.displacement))
                     for o in obstacle_list(scene)]
    elif pts.dim == 3:                  # boxes: a vertical slice through
        boxes, motions, mirrors = drivers(scene, pts, deformed, mesh,
                                          elem)
        plane = plot.slice_plane(
            deformed, [b for _, b, _ in moved] + boxes,
            [d for _, _, d in moved] + motions, mirrors)
        axes = tuple(k for k in range(3) if k != plane[0])
        obstacles = [(name, plot.box_section(box, plane, axes))
                     for name, box, _ in moved]
    else:
        obstacles = ()
    width, height = (7., 3.4) if pts.dim == 1 else body_figure_size(
        np.hstack([pts.x0, deformed])[[0, 1] if plane is None else list(axes)])
    fig, ax = pyplot().subplots(figsize=(width, height + 1.1))
    draw_deformed_shape(
        fig, ax, pts, "{}: deformed shape {}\n({}, the undeformed "
        "body dashed)".format(scene.name, when, plot.scale_note(scale)),
        supports=support_marks(scene, mesh, elem), rigid=rigid,
        obstacles=obstacles, half=half, plane=plane,
        cell=float(np.ptp(mesh.p[:, mesh.t], axis=1).max()), scale=scale,
        loads=plot.scene_load_marks(scene, pts, scale))
    fig.tight_layout()
    plot.save_figure(fig, path, trim=True)


def plot_contact_forces(scene, curves: dict, motion: dict, what: str,
                        path: Path):
    """Per obstacle the force the material exerts on it
    (``what="obstacles"``), or per contact the force between its bodies
    (``"contacts"``), its magnitude (solid) and its components (dashed x,
    dotted y, dash-dotted z: a wedge's sideways force shows), against
    the displacement along its ``motion`` (name: displacement at full
    load) where every one moves, else against the load factor (time in
    dynamics).  A component equal to the magnitude at every step is not
    drawn under it, where it could not be seen (a user trial read the
    pressed blocks' y as missing): the magnitude's label names it.  The
    peak marked is the summary's (:func:`peak_step`); the curves start
    at 0 where the run starts at rest (:func:`at_rest_start`), else at
    the first step."""
    fig, ax = pyplot().subplots(figsize=(8.5, 4.5))
    moving = all(np.any(d) for d in motion.values())
    origin = 1 if at_rest_start(scene) else 0
    for name, curve in curves.items():
        force = np.vstack([np.zeros((origin, len(curve["force"][0]))),
                           curve["force"]])
        if moving:
            disp = np.vstack([np.zeros((origin, force.shape[1])),
                              curve["displacement"]])
            x = disp @ (motion[name] / np.linalg.norm(motion[name]))
        else:                          # in dynamics, the time
            x = np.array([0.] * origin
                         + curve.get("time", curve["load_factor"]))
        magnitude = np.linalg.norm(force, axis=1)
        same = [np.allclose(force[:, k], magnitude, rtol=1e-9, atol=0.)
                for k in range(force.shape[1])]
        line, = ax.plot(x, magnitude, "o-", ms=3,
                        label="{}, magnitude{}".format(name, "".join(
                            " (= {})".format("xyz"[k])
                            for k in np.flatnonzero(same))))
        peak = peak_step(curve["force"], motion[name] if moving else None,
                         -1. if what == "obstacles" else 1.)
        direction = motion[name] / np.linalg.norm(motion[name]) \
            if moving else None
        assisted = moving and what == "obstacles" and \
            np.asarray(curve["force"][peak]) @ direction > 0
        mark_peak(ax, line, x, magnitude, "magnitude", peak=peak + origin,
                  first=not origin, assisted=assisted)
        for k, style in zip(range(force.shape[1]), ("--", ":", "-.")):
            if not same[k]:      # its final value as the terminal says it
                ax.plot(x, force[:, k], style, color=line.get_color(),
                        label="{}, {}: final {}".format(
                            name, "xyz"[k], plot.significant(force[-1, k])))
    ax.axhline(0., color="k", lw=.5)
    ax.set_xlabel("obstacle displacement along its motion ({})".format(
        unit("length", scene.units)) if moving else "time ({})".format(
            unit("time", scene.units)) if scene.dynamics else
        "load factor (-)")
    ax.set_ylabel("{} ({})".format(
        "force of the material on it" if what == "obstacles" else
        "force of the first body on the second",
        quantity_unit("rigid_force", scene.grid.dim, scene.units)))
    ax.set_title("{}: contact force {},\nmagnitude and components".format(
        scene.name, "on the obstacles" if what == "obstacles" else
        "between the bodies"))
    # beside the axes: inside, with a magnitude and its components per
    # obstacle, even "best" covered a curve (a user trial's floor force)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.), borderaxespad=0.,
              fontsize="small", ncol=1 + len(ax.get_lines()) // 20)
    fig.tight_layout()
    plot.save_figure(fig, path)


def plot_rigid_bodies(scene, curves: dict, path: Path):
    """Force along the motion against displacement of each rigid body (a
    bearing-capacity scene's rigid footing: :func:`plot_bearing_capacity`
    instead)."""
    if scene.reference == "bearing_capacity" and \
            scene_footing(scene).kind == "rigid_bodies":
        plot_bearing_capacity(scene, curves, path)
        return
    fig, ax = pyplot().subplots(figsize=(5.5, 4))
    origin = 1 if at_rest_start(scene) else 0
    for name, curve in curves.items():
        disp = np.vstack([np.zeros((origin, len(curve["displacement"][0]))),
                          curve["displacement"]])
        force = np.vstack([np.zeros((origin, disp.shape[1])),
                           curve["force"]])
        direction = disp[-1] / np.linalg.norm(disp[-1])
        line, = ax.plot(disp @ direction, force @ direction, "o-",
                        ms=3, label=name)
        mark_peak(ax, line, disp @ direction, force @ direction,
                  peak=peak_step(curve["force"], direction, 1.) + origin,
                  first=not origin)
    ax.set_xlabel("displacement along the motion ({})".format(
        unit("length", scene.units)))
    ax.set_ylabel("force along the motion ({}){}".format(
        quantity_unit("rigid_force", scene.grid.dim, scene.units),
        weight_taken_off(scene)))
    ax.set_title("{}: force-displacement\nof the rigid bodies".format(
        scene.name))
    ax.legend(loc="lower right")
    fig.tight_layout()
    plot.save_figure(fig, path)


def weight_taken_off(scene) -> str:
    """The second line of a rigid body's force label where the scene has
    a body force (gravity, or an acceleration on bodies with a density):
    the weight of the points in its cells is taken off its force; ``""``
    without one (a user trial's label said so on a scene without
    gravity)."""
    forces = scene.body_forces()
    if forces is None or not np.any(forces):
        return ""
    return "\n(the weight of the points in its cells taken off)"


def plot_bearing_capacity(scene, curves: dict, path: Path):
    """A bearing-capacity scene's footing pressure over the cohesion
    against its settlement ``s`` over the whole footing's width ``B``
    (twice a half model's footing, its ``B``: a trial's axis was
    ``s / (B / 2)``), with ``N_c``, from the ``curves`` of its kind
    (rigid bodies or obstacles; the footing:
    :func:`~skfem_mpm.scenes.footing.scene_footing`)."""
    footing = scene_footing(scene)
    fig, ax = pyplot().subplots(figsize=(5.5, 4))
    c, phi = soil_strength(next(b for b in scene.bodies
                                if b.rigid is None).material)
    curve = curves[footing.name]
    settlement = -np.array([0.] + [d[1] for d in curve["displacement"]])
    pressure = np.concatenate([[0.], footing_pressure(
        scene, np.array(curve["force"]))])
    x = settlement / footing.B
    line, = ax.plot(x, pressure / c, "o-", ms=3, label="{}, {}".format(
        footing.name, scene.method))
    mark_peak(ax, line, x, pressure / c)
    ax.axhline(bearing_capacity_factor(phi), color="k", ls="--",
               label="N_c = {:.2f} (phi = {:g} deg)".format(
                   bearing_capacity_factor(phi), phi))
    length = unit("length", scene.units)
    ax.set_xlabel("settlement s / footing width B (-), B = {}".format(
        "{:g} {}\n(twice the {:g} {} of this half model's footing, from "
        "its symmetry line)".format(footing.B, length, footing.width,
                                    length) if footing.half else
        "{:g} {}\n(the width of the footing {})".format(
            footing.B, length, "body" if footing.kind == "rigid_bodies"
            else "over the soil")))
    ax.set_ylabel("footing pressure / cohesion (-){}".format(
        weight_taken_off(scene) if footing.kind == "rigid_bodies"
        else ""))
    ax.set_title("{}: load-settlement curve\nagainst the bearing "
                 "capacity N_c c".format(scene.name))
    ax.legend(loc="lower right")
    fig.tight_layout()
    plot.save_figure(fig, path)


def check_folder(path: Path, option: str):
    """Refuse, before any work, an output folder ``path`` (given as
    ``option``) that cannot be made or written in: one that is a file, or
    whose nearest existing folder refuses a new entry (a user trial's
    ``--out /proc/nope`` ended the run in a raw FileNotFoundError).  Makes
    and removes a folder there to know; leaves nothing.

    >>> from pathlib import Path
    >>> from skfem_mpm.cli import check_folder
    >>> check_folder(Path("/proc/nope"), "--out")
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: --out /proc/nope: cannot make \
or write the output folder: /proc refuses a new folder (No such file or \
directory)
    """
    if path.exists() and not path.is_dir():
        raise InvalidInputError("{} {}: exists and is not a folder".format(
            option, path))
    probe = path
    while not probe.exists():        # the nearest folder that exists
        probe = probe.parent
    try:
        if not probe.is_dir():
            raise NotADirectoryError(errno.ENOTDIR, "not a folder")
        os.rmdir(tempfile.mkdtemp(prefix=".skfem-mpm-probe.", dir=probe))
    except OSError as err:
        if probe == path:     # a trial's read-only folder "refused a new
            raise InvalidInputError(     # folder": it refuses new files
                "{} {}: cannot write in the output folder ({})".format(
                    option, path, err.strerror)) from None
        raise InvalidInputError(
            "{} {}: cannot make or write the output folder: {} refuses a "
            "new folder ({})".format(option, path, probe, err.strerror)) \
            from None


def refuse_changes(args, source: Path):
    """Refuse, with ``--resume``, what would make the resumed run another
    than the one in its folder (a user trial's ``run slope.toml --resume
    DIR --steps 5`` resumed DIR's footing in its own 20 steps without a
    word): a scene file whose content is not that of ``source``, the
    folder's ``scene.toml``, and ``--out`` naming another folder."""
    if args.scene is not None:
        try:
            same = args.scene.read_bytes() == source.read_bytes()
        except OSError as err:
            raise InvalidInputError("{}: cannot read it ({})".format(
                args.scene, err.strerror)) from None
        if not same:
            raise InvalidInputError(
                "{} with --resume {}: it is not the scene the run there "
                "was started with ({}), and a resume continues that run "
                "bit for bit; leave the scene file out to resume it, or "
                "run {} anew with --out".format(
                    args.scene, args.resume, source, args.scene))
    if args.out is not None and \
            args.out.resolve() != args.resume.resolve():
        raise InvalidInputError(
            "--out {} with --resume {}: a resumed run writes to its own "
            "folder; leave --out out".format(args.out, args.resume))


def refuse_other_steps(args, outdir: Path, planned):
    """Refuse ``--steps`` with ``--resume`` other than ``planned``, the
    run's own count: its checkpoint's, or where a completed run kept none,
    its ``summary.json``'s ``steps`` (``None``: not known, not checked).
    A completed run was told "nothing to resume" for any ``--steps`` (a
    user trial's ``--steps 9`` on a run of 6), an unfinished one refused
    it; a completed run told its own count is still complete."""
    if args.steps and isinstance(planned, int) and args.steps != planned:
        raise InvalidInputError(
            "--steps {} with --resume {}: the run there was planned in "
            "{} steps, and a resume continues it bit for bit; leave "
            "--steps out, or run the scene anew with --out".format(
                args.steps, outdir, planned))


def load_run(args, setup=None):
    """The scene of a run (``--resume``: the checkpoint's), its output
    folder, the checkpoint resumed from (or ``None``), the points to start
    from, the :class:`~skfem_mpm.Resume`, the grid and the points the
    scene seeds.  Writes nothing; ``setup`` (:class:`SetUp`) is told
    its stages."""
    setup = SetUp(False) if setup is None else setup
    earlier, points, resume = None, None, Resume()
    if args.resume is not None:
        outdir = args.resume
        source = outdir / "scene.toml"
        if not source.is_file():
            raise InvalidInputError(
                "--resume {}: no run to resume there ({} is missing: a run "
                "writes it once its scene is accepted, so a run refused "
                "before it started has nothing to resume)".format(
                    outdir, source.name))
        refuse_changes(args, source)
        scene = load_scene(source)
        kept = (outdir / CHECKPOINT).is_file()
        earlier = load_checkpoint(outdir, scene_digest(source)) if kept \
            else None
        if earlier is not None and earlier.complete:   # a trial's resume
            refuse_other_steps(args, outdir, earlier.nsteps)
            raise RunComplete(                          # ran them again
                "{}: the run in {} is complete (its checkpoint holds its "
                "end, {} {} steps{}): nothing to resume, every output left "
                "as it was{}".format(
                    scene.name, outdir, earlier.step,
                    "load" if scene.dynamics is None else "time",
                    "" if earlier.step == earlier.nsteps else
                    ", {} planned".format(earlier.nsteps),
                    figures_note(outdir)))
        if completed_before(outdir):    # a checkpoint short of its end was
            refuse_other_steps(args, outdir, earlier.nsteps
                               if earlier is not None else
                               summary_of(outdir).get("steps"))
            raise RunComplete(         # left before runs ended on one
                "{}: the run in {} is complete (summary.json; {}): nothing "
                "to resume, every output left as it was{}".format(
                    scene.name, outdir, "its checkpoint is an earlier "
                    "step's" if kept else "it kept no checkpoint",
                    figures_note(outdir)))
        if earlier is None:             # the error of a missing one
            earlier = load_checkpoint(outdir, scene_digest(source))
        # the checkpoint's count: scene.toml keeps no --steps given to the
        # run (a review's run started with --steps 5 was told 20)
        refuse_other_steps(args, outdir, earlier.nsteps)
        check_tied(outdir / CHECKPOINT, earlier, scene.obstacles)
        check_contact_sides(outdir / CHECKPOINT, earlier, scene)
        points = earlier.points
        if scene.dynamics is None:
            scene.nsteps = earlier.nsteps
        resume = Resume(first_step=earlier.step + 1,
                        load_factor=earlier.load_factor,
                        increment=earlier.increment, domain0=earlier.domain0,
                        counters=resumed_counters(earlier.counters),
                        end_force=earlier.end_force)
    else:
        outdir = Path("skfem-mpm-output") if args.out is None else args.out
        source = args.scene or EMBEDDED
        scene = load_scene(source)
        if args.steps and scene.dynamics is not None:
            raise InvalidInputError(
                "--steps {}: a dynamic scene takes its steps from "
                "[dynamics] (duration / time_step); change time_step "
                "instead".format(args.steps))
        if args.steps:
            scene.nsteps = args.steps
    check_folder(outdir, "--out" if args.resume is None else "--resume")
    check_reference(scene)
    mesh, _ = scene.grid.build()
    cells = mesh.nelements * sum(b.points_per_cell ** mesh.dim()
                                 for b in scene.bodies)
    setup.large = cells >= LARGE_SETUP
    setup("seeding {} {} on {} cells ({} sub-cells to sample)".format(
        len(scene.bodies), "body" if len(scene.bodies) == 1 else "bodies",
        mesh.nelements, cells))
    initial = build_points(scene, mesh)
    setup("checking the {} points".format(initial.n))
    try:
        check_quantities(scene, scene.outputs, initial, key="outputs")
    except SceneError as err:     # the file named, as the scene's own
        raise SceneError(err.problems, str(source)) from None
    if points is None:
        points = initial
    else:
        if start_missing_rotation(points, mesh.dim(),
                                  scene.kinematics == "finite"):
            logger.warning(
                "%s was written before small-strain runs kept the points' "
                "rotation: it is counted from this resume (step %d)",
                outdir / CHECKPOINT, resume.first_step)
        check_against(outdir / CHECKPOINT, earlier, initial, list(
            state_variables([body.material for body in scene.bodies]))
            + contact_state_names(len(scene.obstacles), mesh.dim(),
                                  scene.kinematics == "finite")
            + body_contact_state_names(
                interface_count(scene.contacts, len(scene.bodies),
                                [body.name for body in scene.bodies]),
                mesh.dim(),
                scene.kinematics == "finite",
                scene.method.startswith("bspline"))
            + rotation_state_names(mesh.dim(),
                                   scene.kinematics == "finite"), mesh)
        labels = [q.label for q in point_outputs(scene)]
        check_outputs(outdir / CHECKPOINT, earlier, labels)
        if labels and earlier.outputs_from:
            logger.warning(
                "%s was written before checkpoints kept the point "
                "outputs' values (2026-11-30): the histories of %s in "
                "summary.json start at step %d, where the run was first "
                "resumed (the forces' cover the whole run)",
                outdir / CHECKPOINT, ", ".join(map(repr, labels)),
                earlier.outputs_from + 1)
    return scene, source, outdir, earlier, points, resume, mesh, initial


class KeptWarnings(logging.Handler):
    """The package's warnings while it is attached to the ``skfem_mpm``
    logger, for ``summary.json``: ``said``, each message once, in the
    order first logged, at most :data:`WARNINGS_KEPT` (then a last line
    counting the rest).  A run that completes with only a warning of what
    went wrong (a trial's traction 1000 E, 62% of it on held DOFs) says
    it in its summary too, not only on stderr."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.said, self.seen, self.more = [], set(), 0

    def restore(self, earlier) -> None:
        """Put the warnings ``earlier`` (a checkpoint's, of the run's
        invocations before this resume) before this invocation's."""
        now = [w for w in self.said if w not in earlier]
        self.said[:] = list(earlier) + now
        self.seen |= set(earlier)

    def emit(self, record):
        message = record.getMessage()
        if message in self.seen:
            return
        self.seen.add(message)
        if len(self.said) < WARNINGS_KEPT:
            self.said.append(message)
            return
        self.more += 1
        line = "... and {} more (the log has them)".format(self.more)
        if self.more == 1:
            self.said.append(line)
        else:
            self.said[-1] = line


#: the distinct warnings a run's summary keeps
WARNINGS_KEPT = 100


def run(args) -> int:
    """``skfem-mpm run``: :func:`run_warned` with the package's warnings
    kept for its summary (:class:`KeptWarnings`)."""
    kept = KeptWarnings()
    package = logging.getLogger("skfem_mpm")
    package.addHandler(kept)
    try:
        return run_warned(args, kept)
    finally:
        package.removeHandler(kept)


def run_warned(args, kept: KeptWarnings) -> int:
    """``skfem-mpm run``; ``kept.said``, the list of the warnings logged
    so far (growing; a resume's begins with the checkpoint's), goes into
    every summary and checkpoint it writes."""
    warned = kept.said
    for name, least in (("checkpoint_every", 0), ("max_steps", 1),
                        ("steps", 1), ("series_every", 1)):
        if getattr(args, name) is not None and getattr(args, name) < least:
            print("skfem-mpm: --{} must be >= {}, got {}".format(
                name.replace("_", "-"), least, getattr(args, name)),
                file=sys.stderr)
            return 2
    if args.no_series and args.series_every not in (None, 1):
        print("skfem-mpm: --series-every {} with --no-series: there is no "
              "series to thin; leave one out".format(args.series_every),
              file=sys.stderr)
        return 2
    setup = SetUp(not args.no_progress)
    try:
        scene, source, outdir, earlier, points, resume, mesh, initial = \
            load_run(args, setup)
    except KeyboardInterrupt:
        print("skfem-mpm: interrupted while setting up the run (reading the "
              "scene, seeding the points): nothing written", file=sys.stderr)
        return 130
    except RunComplete as done:
        # a kill while a completed run drew its figures left their
        # partial files (a SIGKILL campaign's resume kept one)
        if remove_temporaries(args.resume):
            logger.info("removed the partial files of a killed run in %s",
                        args.resume)
        print(done.args[0])
        return 0
    digest = scene_digest(source)
    if earlier is not None:      # the summary lists the whole run's
        kept.restore(earlier.warnings)
    domain0 = points.domain if earlier is None else earlier.domain0
    # points carrying a point load or a surface load (traction, pressure)
    loaded = np.union1d(np.flatnonzero(np.abs(initial.force).sum(axis=0)),
                        np.concatenate([np.asarray(load.points) for load in
                                        surface_loads(scene, initial)] + [
                                            np.array([], dtype=np.int64)]))
    names, resultant = reaction_resultants(scene)
    prepared = []

    def prepare():
        """Make the output folder when there is something to keep (a
        scene refused in its first step writes nothing)."""
        if prepared:
            return
        outdir.mkdir(parents=True, exist_ok=True)
        if remove_temporaries(outdir):
            logger.info("removed the partial files of a killed run in %s",
                        outdir)
        if args.resume is None:
            stale = clear_earlier_run(outdir)
            if stale:
                logger.warning(
                    "removed %d file(s) of an earlier run in %s (%s%s) so "
                    "that none is mistaken for this run's", len(stale),
                    outdir, ", ".join(stale[:4]),
                    ", ..." if len(stale) > 4 else "")
            with atomic_path(outdir / "scene.toml") as tmp:
                shutil.copyfile(source, tmp)
        prepared.append(outdir)

    series = None if args.no_series else SeriesWriter(outdir, mesh, points)
    # a resume keeps the run's --series-every unless told another (trial
    # 111: started with 2, the resume wrote every step); the steps the
    # series was to hold, by each invocation's N, written or not
    every = args.series_every or (1 if earlier is None
                                  else earlier.series_every)
    wanted = [0] if earlier is None else [0] + [
        int(r[0]) for r in earlier.history] \
        if earlier.series_steps is None else list(earlier.series_steps)
    # what a resume's series lacks of those, said in the log and
    # summary.json (a trial's resume after --no-series began its series at
    # step 8 without a word; the steps --series-every left out are not
    # lacking)
    notes = {"warnings": warned}
    if series is not None and earlier is not None:
        series.restore([(int(r[0]), float(r[6] if scene.dynamics else r[1]))
                        for r in earlier.history])
        missing = len(set(wanted) - {int(names[0][7:-4]) for _, names
                                     in series.entries})
        if missing:
            notes["series_note"] = (
                "the VTU series lacks {} of the {} states before step {} "
                "it was to hold (the start, step 0, counted; an "
                "invocation with --no-series writes none): points.pvd and "
                "grid.pvd list the steps written".format(
                    missing, len(wanted), earlier.step + 1))
    elif earlier is not None and (outdir / "points.pvd").is_file():
        notes["series_note"] = (
            "the VTU series stops at step {}: the resume from there ran "
            "with --no-series".format(earlier.step))
    if "series_note" in notes:
        logger.warning("%s: %s", outdir, notes["series_note"])
    # the start, written as step 0 with the first step's frame (so that a
    # run refused before its first step writes nothing)
    start = points.copy() if series is not None and earlier is None \
        else None
    progress = Progress(scene.step_count, not args.no_progress,
                        0. if earlier is None else float(earlier.load_factor),
                        started=setup.started)
    # the records and the last state of the steps written (output and
    # all), and the step the checkpoint on disk holds
    history, latest = [], []
    kept = [None if earlier is None else earlier.step]
    # the point outputs at each step of this invocation, as it ended
    pointwise, measured = point_outputs(scene), []

    def values():
        """``measured`` as (outputs, steps) of the steps in ``history``
        (a Ctrl-C between the two appends leaves one more row)."""
        rows = measured[:len(history)]
        return np.array(rows, dtype=np.float64).reshape(
            len(rows), len(pointwise)).T

    def so_far():
        """History rows and reactions of the run so far (before this
        invocation included)."""
        rows = history_rows(history)
        reactions = np.array([resultant(r) for r in history]).reshape(
            len(history), len(names), mesh.dim())
        if earlier is not None:
            rows = np.vstack([earlier.history, rows])
            reactions = np.concatenate([earlier.reactions, reactions])
        return rows, reactions

    def checkpoint(state, factor, increment, counters):
        """Save the run so far; a Ctrl-C waits until the file is whole
        (np.savez cut short left a zipfile traceback)."""
        prepare()
        rows, reactions = so_far()
        # where the last step converged ended (a contact's force in
        # dynamics: the next step books its work from it)
        end_force = end_force_of(history[-1]) if history \
            else resume.end_force
        before = {q.label: [] for q in pointwise} if earlier is None \
            or earlier.outputs is None else earlier.outputs
        outputs = {q.label: np.r_[before[q.label], row] for q, row in
                   zip(pointwise, values())}
        with interrupts_deferred():
            save_checkpoint(outdir, Checkpoint(
                step=len(rows), nsteps=scene.step_count, load_factor=factor,
                increment=increment, points=state, counters=counters,
                history=rows, reactions=reactions, scene_sha256=digest,
                domain0=domain0, wall_seconds=run_clock() - tic + (
                    0. if earlier is None else earlier.wall_seconds),
                timings=run_timings(history, earlier),
                end_force=end_force, series_every=every,
                series_steps=np.array(wanted, dtype=np.int64),
                warnings=tuple(warned), outputs=outputs,
                outputs_from=0 if earlier is None
                else earlier.outputs_from))
            kept[0] = len(rows)

    def unfinished(status, state, **keys):
        """The summary of a run that stopped short (``status``: failed,
        stopped, interrupted) with the steps that converged, ``state``
        the points of the last (``None``: as they started), and
        ``keys`` saying where it stopped."""
        last = history[-1] if history else None
        partial = Result(
            points=latest[0] if state is None and latest else
            points if state is None else state, history=list(history),
            counters=dict(last.counters if last else
                          earlier.counters if earlier else {}))
        summary = summarise(scene, partial, run_clock() - tic,
                            earlier, complete=False, measured=values())
        summary.update(notes)
        summary.update(status=status, last_converged_step=last.step if last
                       else resume.first_step - 1,
                       compile_seconds=compile_seconds() - compiled, **keys)
        return partial, summary

    def callback(record, pts):
        prepare()
        progress(record)
        if start is not None and not series.entries:
            # the fields of the steps, zero at the start
            series.write(0, 0., start, np.unique(locate_points(
                mesh, start.x)[0]), None, None, {
                    name: np.zeros_like(values) for name, values in
                    contact_pressure_fields(record).items()})
        due = record.step % every == 0 or record.load_factor >= 1. or (
            args.max_steps and len(history) + 1 >= args.max_steps)
        if series is not None and due:
            series.write(record.step, float(
                record.load_factor if record.time is None else record.time),
                pts, record.elements, record.u, record.reactions,
                contact_pressure_fields(record))
        # the step counts once both its VTUs are written: one interrupted
        # between them is neither checkpointed nor listed on resume (nor
        # among the steps the series was to hold: a Ctrl-C inside its grid
        # VTU left a checkpoint of step 3 listing step 4, refused)
        if due:
            wanted.append(record.step)
        measured.append([q.measure(scene, SimpleNamespace(points=pts))
                         for q in pointwise])
        history.append(record)
        latest[:] = [pts]
        if record.load_factor < 1. and (
                (args.checkpoint_every
                 and record.step % args.checkpoint_every == 0)
                or (args.max_steps and len(history) >= args.max_steps)):
            checkpoint(pts, record.load_factor, record.increment,
                       record.counters)
        if args.max_steps and len(history) >= args.max_steps \
                and record.load_factor < 1.:
            raise StopRun(record.step)

    setup("setting up the solver (the grid's operators, supports, "
          "contact) and step {}".format(resume.first_step))
    tic, compiled = run_clock(), compile_seconds()
    try:
        result = run_scene(scene, points, resume=resume, callback=callback,
                           initial=initial)
    except StopRun as stop:      # the checkpoint is written: a summary
        progress.end()
        partial, stopped = unfinished("stopped", None, checkpoint=True,
                                      checkpoint_step=kept[0])
        with interrupts_deferred():
            write_summary(outdir / "summary.json", stopped)
        plot_outputs(scene, partial, outdir, loaded, stopped, initial)
        print("stopped after step {}; continue with: skfem-mpm run "
              "--resume {}".format(stop.args[0], outdir))
        return 0
    except KeyboardInterrupt:         # Ctrl-C: keep what converged
        progress.end()
        # a second Ctrl-C does not cut the saving short
        with interrupts_deferred(reraise=False):
            last = history[-1] if history else None
            cut = ""
            if last is not None and last.load_factor < 1. and \
                    kept[0] != last.step:
                try:
                    checkpoint(latest[0], last.load_factor, last.increment,
                               last.counters)
                except KeyboardInterrupt:   # the previous checkpoint stands
                    cut = " while saving the checkpoint of step {}".format(
                        last.step)
            partial = interrupted = None
            if prepared:
                partial, interrupted = unfinished(
                    "interrupted", None, checkpoint=kept[0] is not None,
                    checkpoint_step=kept[0])
                if history:     # said unless the figures are drawn
                    interrupted["figures"] = FIGURES_INTERRUPTED
                write_summary(outdir / "summary.json", interrupted)
        if history and interrupted is not None:
            # the figures of the steps done, as --max-steps draws them (a
            # trial's SIGTERM left none); a second Ctrl-C stops them, and
            # the summary keeps saying so
            try:
                plot_outputs(scene, partial, outdir, loaded, interrupted,
                             initial)
                del interrupted["figures"]
                with interrupts_deferred(reraise=False):
                    write_summary(outdir / "summary.json", interrupted)
                drawn = "; figures of steps 1 to {} drawn".format(
                    history[-1].step)
            except KeyboardInterrupt:
                drawn = "; figures not drawn (interrupted again)"
            except Exception as err:      # the run's end is said anyway
                drawn = "; figures not drawn ({}: {})".format(
                    type(err).__name__, err)
        else:
            drawn = ""
        if kept[0] is None:
            print("skfem-mpm: interrupted{}{} before a step converged: "
                  "nothing to resume".format(cut, drawn), file=sys.stderr)
        else:
            print("skfem-mpm: interrupted{}{}; {}continue with: skfem-mpm "
                  "run --resume {}".format(
                      cut, drawn, "the checkpoint of step {} stands; ".format(
                          kept[0]) if cut else "", outdir), file=sys.stderr)
        return 130
    except MPMError as err:
        progress.end()
        if isinstance(err, InvalidInputError) and not prepared:
            raise                     # refused before anything converged
        # keep what converged: a checkpoint of the last converged state and
        # a summary saying what failed
        prepare()
        last = history[-1] if history else None
        state = getattr(err, "state", None)
        if state is not None:
            checkpoint(state, err.load_factor, last.increment if last else
                       resume.increment or 1. / scene.step_count,
                       last.counters if last else
                       earlier.counters if earlier else {})
        # the summary and figures of a finished run, of the steps that
        # converged (the curves up to the failure)
        partial, failed = unfinished(
            "failed", state, error="{}: {}".format(type(err).__name__, err),
            checkpoint=kept[0] is not None, checkpoint_step=kept[0])
        write_summary(outdir / "summary.json", failed)
        factor = getattr(err, "load_factor", failed["load_factor"])
        plot_outputs(scene, partial, outdir, loaded, failed, initial,
                     "at load factor {:.4g},\nthe last converged state "
                     "(the next step failed)".format(factor), factor)
        raise
    except OSError as err:    # output failed (read-only or full disk, ...)
        try:                  # the last checkpoint stands (atomic writes)
            write_summary(outdir / "summary.json", {
                "scene": scene.name, "status": "failed",
                "error": "{}: {}".format(type(err).__name__, err),
                "last_converged_step": history[-1].step if history else
                resume.first_step - 1, "warnings": warned})
        except OSError:
            logger.info("no summary either: %s", err)
        raise
    seconds = run_clock() - tic
    summary, stage = None, "writing its summary"

    def completed():
        """The summary of the completed run, written."""
        done = summarise(scene, result, seconds, earlier,
                         measured=values())
        done.update(notes)
        done.update(status="completed",
                    compile_seconds=compile_seconds() - compiled)
        prepare()
        write_summary(outdir / "summary.json", done)
        return done
    try:          # the run is complete: a Ctrl-C now gets what completed
        with interrupts_deferred():
            summary = completed()
        stage = "drawing the figures"
        plot_outputs(scene, result, outdir, loaded, summary, initial)
        # a run that keeps checkpoints ends with one at its end, once
        # every output is written: its resume has nothing to do (a
        # trial's stood at step 15 of 20, and the resume ran 16-20 again)
        stage = "writing its last checkpoint"
        if history and (args.checkpoint_every or kept[0] is not None):
            checkpoint(latest[0], history[-1].load_factor,
                       history[-1].increment, history[-1].counters)
        stage = "printing the report"
        print_report(scene, summary, seconds, outdir, args.resume)
    except KeyboardInterrupt:
        with interrupts_deferred(reraise=False):
            if summary is None:
                summary = completed()
            if stage in ("writing its summary", "drawing the figures"):
                # said again by a later --resume, which has none to draw
                summary["figures"] = FIGURES_MISSING
                write_summary(outdir / "summary.json", summary)
        print("skfem-mpm: interrupted after the run completed ({} steps), "
              "while {}: summary.json{} complete in {}{}".format(
                  summary["steps_run"], stage, "" if args.no_series else
                  " and the VTU series", outdir,
                  "; figures missing" if stage in (
                      "writing its summary", "drawing the figures")
                  else ""), file=sys.stderr)
        return 130
    return 0


#: ``summary.json``'s keys of forces per body, the words of each kind and
#: the sign of its force (docs/contact.md)
FORCE_KINDS = (
    ("rigid_bodies", "rigid body", "the force that holds its motion"),
    ("obstacles", "obstacle", "the force the material exerts on it"),
    ("contacts", "contact", "the force its first body exerts on its "
     "second"))


def force_lines(summary: dict) -> list:
    """The report's lines of the final force of each rigid body, obstacle
    and contact in ``summary``, with the sign it has (a trial's rigid
    footing printed none, an obstacle's only as an ``[[outputs]]``).

    >>> from skfem_mpm.cli import force_lines
    >>> force_lines({"units": {"force": "kN/m"}, "obstacles": {
    ...     "plate": {"final_force": [0.0, 12.5]}}})
    ['  obstacle plate final force (0, 12.5) kN/m: the force the \
material exerts on it']
    """
    lines = []
    for key, kind, sign in FORCE_KINDS:
        for name, curves in summary.get(key, {}).items():
            force = curves.get("final_force")
            if force is None:
                continue
            lines.append("  {} {} final force ({}) {}: {}".format(
                kind, name, ", ".join("{:.6g}".format(f) for f in force),
                summary["units"]["force"], sign))
    return lines


def print_report(scene, summary: dict, seconds: float, outdir: Path,
                 resumed) -> None:
    """The terminal's account of a completed run."""
    # the steps taken, cut-backs' included (a trial's run printed the 1
    # step planned where it took 22)
    steps = "{} {} steps{}".format(
        summary["steps_run"], "load" if scene.dynamics is None else "time",
        "" if summary["steps_run"] == scene.step_count else
        " ({} planned, cut back)".format(scene.step_count))
    print("{}: {} {} ({} kinematics), {} points, {}".format(
        scene.name, "resumed" if resumed else "ran", scene.method,
        scene.kinematics, summary["points"], steps if scene.dynamics is None
        else "{} to t = {:g} s".format(steps, scene.dynamics.duration)))
    if "error" in summary:
        label, against, _ = REFERENCE_ERRORS[scene.reference]
        print("  {:26s}{:.4e} (against {})".format(label + " ",
                                                   summary["error"], against))
    footing = summary.get("bearing_capacity")
    if footing is not None:     # the error's side (a trial's soil that
        # never failed read 9.96e-01, unsaid whether above or below)
        print("  peak against N_c c        {:.6g} {} at step {}, {:.2%} {} "
              "N_c c = {:.6g} {}".format(
                  footing["peak_pressure"], unit("stress", scene.units),
                  footing["peak_step"], abs(footing["signed_error"]),
                  "below" if footing["signed_error"] < 0 else "above",
                  footing["limit_pressure"], unit("stress", scene.units)))
    # four significant digits (a trial's 4e-6 printed 0.0000 m)
    print("  largest displacement      {:.4g} {}".format(
        summary["max_displacement"], unit("length", scene.units)))
    for label, q in summary.get("outputs", {}).items():
        print("  {} {:.6g} {}".format(label.ljust(25), q["value"],
                                      q["unit"]))
    for line in force_lines(summary):
        print(line)
    print("  max equilibrium residual  {:.1e}".format(
        summary["max_residual"]))
    # shares of the run's time: the steps' phases, and the rest (seeding,
    # set-up, output, checkpoints; a trial read the phases' shares of
    # their own sum, 53-60% of the time, as the time's)
    wall = summary["wall_seconds"] or 1.
    rest = max(wall - sum(summary["timings"].values()), 0.)
    print("  time {:.3f} s{}: ".format(summary["wall_seconds"], "" if
                                       not resumed else " ({:.3f} s in "
                                       "this invocation)".format(seconds))
          + ", ".join(
        "{} {:.0%}".format(p, summary["timings"][p] / wall) for p in PHASES)
          + ", set-up and output {:.0%}".format(rest / wall))
    if summary.get("compile_seconds"):
        print("  kernels compiled, loaded  {:.1f} s (compiled once per "
              "installation, loaded once per process; not in the time)"
              .format(summary["compile_seconds"]))
    print("  output                    {}".format(outdir))


def compare(args) -> int:
    """FE (the points as fixed quadrature) against the scene's method (MPM
    when the scene is FE), with the scene's kinematics, material and loads:
    like with like.  Writes both states as VTU, a figure on one colour
    scale and ``summary.json`` with their difference."""
    import meshio

    scene = load_scene(args.scene)
    check_reference(scene)
    check_folder(args.out, "--out")
    if scene.contacts:
        raise InvalidInputError(
            "compare runs FE beside the scene's method ({}) on the same "
            "scene, and FE has no contacts between bodies (the scene has "
            "{}: [[contacts]]); run the scene alone with skfem-mpm run"
            .format(scene.method if scene.method != "fem" else "mpm",
                    ", ".join(repr(c.name) for c in scene.contacts)))
    runs = {}
    for method in ("fem", scene.method if scene.method != "fem" else "mpm"):
        variant = replace(scene, method=method)
        if method == "fem" and scene.stabilisation.antilocking == "fbar":
            # F-bar on the increment is for moving points
            print("FE takes mean dilatation (antilocking = true) where the "
                  "scene's {} takes F-bar on the increment".format(
                      scene.method))
            variant = replace(variant, stabilisation=replace(
                scene.stabilisation, antilocking=True))
        tic = run_clock()
        result = run_scene(variant)
        runs[method] = (variant, result, run_clock() - tic)
    args.out.mkdir(parents=True, exist_ok=True)
    other = list(runs.values())[1][0]
    a, b = (r.points for _, r, _ in runs.values())
    difference = {}
    for name in ("displacement", "stress"):
        d = getattr(b, name) - getattr(a, name)
        scale = np.abs(getattr(a, name)).max()
        where = np.unravel_index(int(np.abs(d).argmax()), d.shape)
        difference[name] = {
            "max": float(np.abs(d).max()),
            "rms": float(np.sqrt(np.mean(d ** 2))),
            "max_relative": float(np.abs(d).max() / scale) if scale else 0.,
            # where the largest difference is: the point (its index and
            # its place at the start, the same in both runs) and component
            "max_at_point": int(where[-1]),
            "max_at": [float(v) for v in a.x0[:, where[-1]]],
            "max_component": ("xyz"[where[0]] if name == "displacement"
                              else STRESS_NAMES[where[0], where[1]])}
    summary = {"scene": scene.name, "kinematics": scene.kinematics,
               "methods": list(runs), "difference": difference,
               "difference_is": "{} minus fem, at the same material points "
                                "(max, root mean square, max over the fem "
                                "field's largest magnitude; the point and "
                                "component of the max, max_at its place "
                                "at the start); stress: the Cauchy "
                                "stress, every component".format(
                                    other.method),
               "runs": {m: summarise(v, r, s) for m, (v, r, s) in
                        runs.items()},
               # the differences' (a trial found none; each run's
               # summary has its own)
               "units": {"system": scene.units, "max_relative": "-",
                         "displacement": unit("length", scene.units, a.dim),
                         "stress": unit("stress", scene.units, a.dim)}}
    write_summary(args.out / "summary.json", summary)
    d = a.dim - 1
    component = STRESS_NAMES[d, d]
    scale = colour_scale(a.stress[d, d], b.stress[d, d])
    deformed = np.hstack([p.x0 + p.displacement for p in (a, b)])
    fig, axes = pyplot().subplots(
        1, 2, figsize=(12, 4) if a.dim == 1 else body_figure_size(
            deformed[:2], panels=2), sharey=True)
    for k, (ax, (method, (variant, result, seconds))) in enumerate(zip(
            axes, runs.items())):
        pts = result.points.copy()
        with atomic_path(args.out / "{}.vtu".format(method)) as tmp:
            meshio.write(tmp, point_cloud(pts), file_format="vtu")
        pts.x = pts.x0 + pts.displacement        # FE points stay at x0
        draw_points(fig, ax, pts, pts.stress[d, d], "{} ({})".format(
                        component, unit("stress", scene.units)),
                    "{} ({} kinematics),\n"
                    "{:.2f} s".format(method, variant.kinematics, seconds),
                    scale=scale, colorbar=k == 1)
        if a.dim == 1:
            ax.set_ylim(scale["vmin"], scale["vmax"])
        # in the scene's unit (a trial's "largest displacement 0.0298")
        print("{:>7}: largest displacement {:.4g} {}, {:.3f} s".format(
            method, largest_displacement(result),
            summary["units"]["displacement"], seconds))
    # one view for both panels (a trial: each body's own limits, the
    # panels' axes unlike), the empty band above the panels trimmed
    for get, put in (("get_xlim", "set_xlim"), ("get_ylim", "set_ylim")):
        lims = np.array([getattr(ax, get)() for ax in axes])
        for ax in axes:
            getattr(ax, put)(lims[:, 0].min(), lims[:, 1].max())
    title = fig.suptitle("{}: {} (Cauchy, tension positive, global "
                         "axes) at the "
                         "deformed points, one colour scale".format(
                             scene.name, component))
    fig.tight_layout(rect=(0., 0., 1., .92))
    # equal aspect leaves the panels lower than their room: the title
    # just above them, and the band left above it trimmed
    renderer = fig.canvas.get_renderer()
    top = max(ax.get_tightbbox(renderer).y1 for ax in fig.axes)
    title.set_verticalalignment("bottom")
    title.set_y(top / fig.bbox.height + .01)
    plot.save_figure(fig, args.out / "compare.png", trim=True)
    for name, what in (("displacement", "displacement"),
                       ("stress", "Cauchy stress")):
        d = difference[name]
        print("  {} - fem, {}: max {:.3e} {} ({:.2e} of FE's largest "
              "|{}|), at point {} (at {} {} at the start) in {}; rms "
              "{:.3e} {}".format(
                  other.method, what, d["max"], summary["units"][name],
                  d["max_relative"], name, d["max_at_point"],
                  ", ".join("{:.4g}".format(v) for v in d["max_at"]),
                  summary["units"]["displacement"], d["max_component"],
                  d["rms"], summary["units"][name]))
    if scene.reference:
        label, against, _ = REFERENCE_ERRORS[scene.reference]
        print("  {} against {}: {}".format(label, against, ", ".join(
            "{} {}".format(m, "-" if "error" not in summary["runs"][m]
                           else "{:.3e}".format(summary["runs"][m]["error"]))
            for m in runs)))
    print("  output {}".format(args.out))
    return 0


def parse_vary(items):
    """``["elements=4,8", "method=mpm,cpgimp"]`` as a dict of lists."""
    vary = {}
    for item in items:
        name, _, values = item.partition("=")
        if not values:
            raise SceneError(["--vary {!r}: expected NAME=V1,V2,...".format(
                item)])
        if name not in VARIABLES:       # the name first, then its values
            raise SceneError([not_a_variable(name)])
        if name in vary:
            raise SceneError([
                "--vary {} is given twice ({} and {}): one would replace "
                "the other; give all its values in one, --vary {}={}"
                .format(name, ",".join(str(v) for v in vary[name]), values,
                        name, ",".join([str(v) for v in vary[name]]
                                       + [values]))])
        values = values.split(",")
        if name not in CHOICES:
            try:
                values = [int(v) for v in values]
            except ValueError:
                raise SceneError(["--vary {}: values must be integers, got "
                                  "{}".format(name, values)])
        vary[name] = values
    return vary


def parse_measures(items, dim: int) -> list:
    """``--measure`` arguments (the keys of an ``[[outputs]]`` table) as
    :class:`~skfem_mpm.scenes.quantities.Quantity` objects."""
    quantities = []
    for k, item in enumerate(items):
        try:
            table = tomllib.loads("measure = {" + item + "}")["measure"]
        except tomllib.TOMLDecodeError as err:
            raise SceneError(["--measure {!r}: not TOML keys ({})".format(
                item, err)])
        named = table.get("quantity")
        if isinstance(named, str) and named not in QUANTITIES:
            raise SceneError(["--measure {!r}: unknown quantity {!r}, "
                              "choose from {}{}".format(
                                  item, named, ", ".join(QUANTITIES),
                                  did_you_mean(named, QUANTITIES))])
        if named in COMPONENTS and "component" not in table:
            raise SceneError(["--measure {!r}: needs a component of {}: "
                              "one of {}".format(item, named, ", ".join(
                                  COMPONENTS[named]))])
        quantities.append(parse_quantity(table, dim, "--measure {!r}"
                                         .format(item)))
    return quantities


def run_study(args) -> int:
    scene = load_scene(args.scene)
    check_folder(args.out, "--out")
    vary = parse_vary(args.vary) if args.vary else default_vary(scene)
    check_vary(vary, scene)
    check_reference(scene)
    quantities = parse_measures(args.measure, len(scene.grid.axes)) or \
        scene_quantities(scene)
    cases = cases_of(vary)
    if not args.vary and len(cases) > CASES_UNASKED and not args.all:
        largest = max(cases, key=lambda c: case_work(scene, c))
        case = configure(scene, largest)
        print("skfem-mpm: without --vary a study runs the default grid: {} "
              "cases ({}), the largest up to {:.3g} points over {} steps; "
              "more than {} start only with --all: choose the cases with "
              "--vary NAME=V1,V2,... or run all {} with --all".format(
                  len(cases), ", ".join("{} {}".format(k, ",".join(
                      str(v) for v in values)) for k, values in vary.items()),
                  point_bound(case), case.step_count, CASES_UNASKED,
                  len(cases)), file=sys.stderr)
        return 2
    try:
        print(announce(estimate(scene, cases, args.out, quantities,
                                scene_file=args.scene),
                       args.workers, args.scheduler), flush=True)
        rows = study(scene, vary, args.out, scheduler=args.scheduler,
                     workers=args.workers, progress=not args.no_progress,
                     quantities=quantities, scene_file=args.scene)
    except KeyboardInterrupt:
        print("skfem-mpm: study interrupted; the finished cases are in {}; "
              "the same command resumes it".format(args.out / "study.json"),
              file=sys.stderr)
        return 130
    measured = analyse(scene, rows, quantities)
    keys = [k for k in VARIABLES if k in vary]
    print("\n".join(report(rows, measured, keys)))
    for path in plot_study(rows, args.out, measured):
        print("  plot {}".format(path))
    return 0


def announce(plan: dict, workers: int, scheduler) -> str:
    """The line a study prints before it starts its cases: how many, the
    largest, the time :func:`~skfem_mpm.studies.study.estimate` puts on
    them, and the warm-up a process spent before its first timed case
    (not charged to any case)."""
    points, steps = plan["largest"]
    line = "study: {} case{}{}, the largest up to {:.3g} points over {} " \
        "step{}".format(plan["cases"], "s" if plan["cases"] > 1 else "",
                        " ({} finished before)".format(plan["done"])
                        if plan["done"] else "", points, steps,
                        "s" if steps > 1 else "")
    if plan["ran"]:
        line += "; {} run first to time them".format(plan["ran"])
    if plan.get("warm_up") is not None:
        line += "; warm-up {:.2g} s a process, untimed".format(
            plan["warm_up"])
    if not plan["left"]:
        return line
    if plan["seconds"] is None:
        return line + "; no estimate of the time (no case succeeded)"
    a, b = plan["model"]
    line += "; the {} take{} about {}".format(
        "{} others".format(plan["left"]) if plan["left"] > 1 else
        "other case" if plan["ran"] + plan["done"] else "case",
        "" if plan["left"] > 1 else "s", clock(plan["seconds"]))
    if workers and not scheduler:
        line += " ({} on {} workers)".format(
            clock(plan["seconds"] / worker_count(workers)),
            worker_count(workers))
    return line + " by a rough, linear estimate: {:.2g} s + {:.2g} s per " \
        "point and step (low for large cases, whose Newton iterations and " \
        "solves grow faster than their points; the progress line refits " \
        "it as cases finish)".format(a, b)


#: the outcomes of a strength reduction trial in ``safety.json``
#: ("converged": not judged, where the bracket failed)
OUTCOMES = ("stands", "collapses", "fails", "converged")


def safety_options(args) -> dict:
    """``skfem-mpm safety``'s numbers from ``args``, checked before any
    work: every problem, one line each, in a
    :class:`~skfem_mpm.errors.SceneError`.

    >>> from types import SimpleNamespace
    >>> from skfem_mpm.cli import safety_options
    >>> safety_options(SimpleNamespace(low="1", high="2", tolerance=".01",
    ...                                growth="none", steps=None))
    {'low': 1.0, 'high': 2.0, 'tolerance': 0.01, 'growth': None, 'steps': None}
    """
    problems, out = [], {}

    def number(name, text, test, wanted, kind=float):
        try:
            value = kind(text)
        except (TypeError, ValueError):
            value = None
        if value is None or not np.isfinite(value) or not test(value):
            problems.append("--{} must be {}, got {!r}".format(
                name, wanted, text))
            return None
        return value

    out["low"] = number("low", args.low, lambda v: v > 0,
                        "a number > 0 (a factor at which the scene stands)")
    out["high"] = number("high", args.high, lambda v: v > 0,
                         "a number > --low (a first guess of a factor at "
                         "which the scene collapses)")
    if None not in (out["low"], out["high"]) and \
            not out["high"] > out["low"]:
        problems.append("--high must be > --low, got --low {!r} and --high "
                        "{!r}".format(args.low, args.high))
    out["tolerance"] = number("tolerance", args.tolerance,
                              lambda v: 0 < v < 1, "a number between 0 and "
                              "1 (the final bracket's relative width)")
    if str(args.growth).strip().lower() == "none":
        out["growth"] = None
    else:
        out["growth"] = number("growth", args.growth, lambda v: v > 1,
                               "a number > 1 (the displacement, over the "
                               "run at --low's, beyond which a trial has "
                               "collapsed) or 'none'")
    out["steps"] = None if args.steps is None else number(
        "steps", args.steps, lambda v: v >= 1, "an integer >= 1", int)
    if problems:
        raise SceneError(problems)
    return out


def reduced_bodies(scene) -> list:
    """The indices of the bodies of ``scene`` whose strength a strength
    reduction divides (every body but the rigid and the linear elastic
    ones), refusing a scene it cannot take: a dynamic one, a body of a
    material without a strength to reduce (Cam clay, hardening
    Drucker-Prager: :func:`~skfem_mpm.reduce_strength` says why), a scene
    with no body to reduce."""
    if scene.dynamics is not None:
        raise InvalidInputError(
            "skfem-mpm safety runs a static scene under its loads: the "
            "scene has [dynamics] (remove it to find the factor of safety)")
    problems, reduced = [], []
    for k, body in enumerate(scene.bodies):
        if body.rigid is not None or type(body.material) is LinearElastic:
            continue
        try:
            reduce_strength(body.material, 1.)
        except InvalidInputError as err:
            problems.append("bodies[{}] ({}): {}".format(k, body.name, err))
            continue
        reduced.append(k)
    if problems:
        raise SceneError(problems)
    if not reduced:
        raise InvalidInputError(
            "skfem-mpm safety divides the strength of von Mises, "
            "Mohr-Coulomb and Drucker-Prager bodies: the scene has none "
            "({})".format(", ".join("{} {}".format(
                b.name, "rigid" if b.rigid is not None else
                type(b.material).__name__) for b in scene.bodies)))
    return reduced


class quiet_logs:
    """Within it, where ``quiet``, the package's log records (warnings:
    Newton's retries and cut-backs, a trial past collapse has dozens) are
    counted rather than printed: ``notes``, a list, gets each record's
    logger name."""

    def __init__(self, quiet: bool):
        self.quiet, self.notes = quiet, []
        self.logger = logging.getLogger("skfem_mpm")

    def __enter__(self):
        if self.quiet:
            self.handler = logging.Handler()
            self.handler.emit = lambda r: self.notes.append(r.name)
            self.logger.addHandler(self.handler)
            self.propagate, self.logger.propagate = self.logger.propagate, \
                False
        return self.notes

    def __exit__(self, *exc):
        if self.quiet:
            self.logger.removeHandler(self.handler)
            self.logger.propagate = self.propagate
        return False


def notes_said(notes: list) -> str:
    """The words of a trial line on the log ``notes`` it kept quiet."""
    return "" if not notes else "; {} solver warning{} (-v prints " \
        "them)".format(len(notes), "s" if len(notes) > 1 else "")


def run_safety(args) -> int:
    """``skfem-mpm safety``: the factor of safety of a scene by
    :func:`~skfem_mpm.solve.strength_reduction.strength_reduction`, a
    line per trial, ``safety.json``, ``safety.png`` and
    ``mechanism.png`` in ``--out``."""
    options = safety_options(args)
    scene = load_scene(args.scene)
    if options["steps"] is not None:
        scene.nsteps = options["steps"]
    try:
        reduced = reduced_bodies(scene)
    except SceneError as err:       # the file named, as the scene's own
        raise SceneError(err.problems, str(args.scene)) from None
    check_folder(args.out, "--out")
    check_reference(scene)
    mesh, _ = scene.grid.build()
    initial = build_points(scene, mesh)
    try:
        check_quantities(scene, scene.outputs, initial, key="outputs")
    except SceneError as err:       # the file named, as the scene's own
        raise SceneError(err.problems, str(args.scene)) from None
    length = unit("length", scene.units)
    kept = [b.name for k, b in enumerate(scene.bodies) if k not in reduced]
    print("{}: strength reduction of {} ({} load steps, {}); bracket from "
          "{:g} to {:g}, tolerance {:g}, {}".format(
              scene.name, ", ".join(scene.bodies[k].name for k in reduced),
              scene.step_count, scene.method, options["low"],
              options["high"], options["tolerance"],
              "collapse beyond {:g} times the displacement at F = {:g}"
              .format(options["growth"], options["low"])
              if options["growth"] is not None else
              "collapse where a run fails (--growth none)")
          + ("; unchanged: {}".format(", ".join(kept)) if kept else ""),
          flush=True)
    trials = []

    def variant(factor):
        """The scene with its bodies' strength divided by ``factor``."""
        return replace(scene, bodies=[
            replace(b, material=reduce_strength(b.material, factor))
            if k in reduced else b for k, b in enumerate(scene.bodies)])

    def trial(factor, steps=scene.step_count):
        """A run at ``factor`` in ``steps`` load steps (more than the
        scene's: a retry), its line printed and its record kept."""
        progress = Progress(steps, not args.no_progress)
        tic = run_clock()
        record = {"factor": factor, "converged": False, "error": None,
                  "largest_displacement": None, "steps": steps,
                  "retry": steps != scene.step_count}
        trials.append(record)
        if record["retry"]:
            print("  F = {:.4f}: its run failed; retried with {} load "
                  "steps (an extra run)".format(factor, steps), flush=True)
        try:
            # the first trial's warnings said (the scene's own, once),
            # the later ones' counted
            with quiet_logs(not args.verbose and len(trials) > 1) as notes:
                result = run_scene(replace(variant(factor), nsteps=steps),
                                   initial=initial,
                                   callback=lambda r, _: progress(r))
        except PrescribedMotionError:
            raise
        except (ConvergenceError, SingularSystemError,
                PointsOutsideGridError) as err:
            record.update(error="{}: {}".format(type(err).__name__, err),
                          seconds=run_clock() - tic)
            progress.end()
            print("  F = {:.4f}: not converged ({}), {:.1f} s{}".format(
                factor, type(err).__name__, record["seconds"],
                notes_said(notes)), flush=True)
            raise
        moved = largest_displacement(result)
        record.update(converged=True, largest_displacement=moved,
                      seconds=run_clock() - tic)
        first = trials[0]["largest_displacement"]
        print("  F = {:.4f}: converged, largest displacement {:.4g} {}{}, "
              "{:.1f} s{}".format(
                  factor, moved, length, "" if len(trials) == 1
                  or not first else " ({:.2f} x F = {:g}'s)".format(
                      moved / first, trials[0]["factor"]),
                  record["seconds"], notes_said(notes)), flush=True)
        if len(trials) == 1 and len(result.history) > scene.step_count:
            # a trial's --low above the factor (1.5 for 1.44) collapsed in
            # cut-backs, and its motion set the scale of --growth: the
            # factor came out 15% high
            print("  the run at --low = {:g} was cut back ({} steps for "
                  "{}): it may be near or past collapse, and its motion "
                  "sets the scale of --growth; a lower --low is "
                  "sounder".format(factor, len(result.history),
                                   scene.step_count), flush=True)
        return result

    tic = run_clock()
    # the factor's warnings: printed with the summary, not logged too
    said_below = logging.getLogger(strength_reduction.__module__)

    def unlogged(record):
        return not getattr(record, "safety_warning", False)
    said_below.addFilter(unlogged)
    try:
        # the trials' lines count the later warnings (quiet_logs)
        found = strength_reduction(
            trial, options["low"], options["high"], options["tolerance"],
            options["growth"], quiet=False, retry=None if args.no_retry
            else lambda f: trial(f, 2 * scene.step_count))
    except KeyboardInterrupt:
        print("skfem-mpm: strength reduction interrupted after {} "
              "trial(s): nothing written".format(len(trials)),
              file=sys.stderr)
        return 130
    except InvalidInputError as err:
        # the bracket failed (not a run refused): keep what the trials said
        if trials and "seconds" in trials[-1]:
            write_safety(args.out, scene, reduced, options, trials, None,
                         run_clock() - tic, "{}".format(err))
        raise
    finally:
        said_below.removeFilter(unlogged)
    summary = write_safety(args.out, scene, reduced, options, trials, found,
                           run_clock() - tic)
    print("  {:>8s}  {:9s}  {}".format("F", "outcome",
                                        "largest displacement ({})".format(
                                            length)))
    for t in sorted(summary["trials"], key=lambda t: t["factor"]):
        print("  {:8.4f}  {:9s}  {}{}".format(
            t["factor"], t["outcome"], "-" if t["largest_displacement"]
            is None else "{:.4g}".format(t["largest_displacement"]),
            "  (retry, {} steps)".format(t["steps"]) if t["retry"]
            else ""))
    retries = sum(t["retry"] for t in trials)
    print("{}: factor of safety {:.3f} (bracket {:.4f} .. {:.4f}, {} "
          "runs{}, {})".format(scene.name, found.factor, found.converged,
                               found.failed, len(trials),
                               " of which {} retr{}".format(
                                   retries, "ies" if retries > 1 else "y")
                               if retries else "",
                               clock(summary["wall_seconds"])))
    print(safety_set_by(summary)[1])
    for sentence in found.warnings:
        print("  WARNING: {}".format(sentence))
    if tuple(found.span) != (found.converged, found.failed):
        print("  WARNING: the factor of safety is uncertain: {:.3f} .. "
              "{:.3f}, not only its bracket (safety.json's span)".format(
                  *found.span))
    width, height = body_figure_size(found.result.points.x[:2])
    # room for the colour bar's label (two lines) beside a low slope
    fig, ax = pyplot().subplots(figsize=(max(width, 8.), max(height, 4.5)))
    if found.result.points.dim == 2 and "equivalent_plastic_strain" in \
            found.result.points.state:
        draw_plastic_zone(fig, ax, found.result.points, "{}: plastic zone "
                          "at F = {:.4f}, the last trial that stood\n"
                          "(factor of safety {:.3f})".format(
                              scene.name, found.converged,
                              found.factor))
        ax.set_xlabel("x ({})".format(length))
        ax.set_ylabel("y ({})".format(length))
        fig.tight_layout()
        plot.save_figure(fig, args.out / "mechanism.png")
        print("  plot {}".format(args.out / "mechanism.png"))
    else:
        pyplot().close(fig)
    print("  plot {}\n  output {}".format(args.out / "safety.png",
                                          args.out / "safety.json"))
    return 0


def safety_set_by(summary: dict) -> tuple:
    """What set the factor of safety of ``safety.json``'s ``summary``:
    ``"growth"`` (the trial above it converged, its displacement past
    ``growth`` times the reference's) or ``"convergence"`` (it did not
    converge), and the words that say so and how to judge it (a trial
    read a factor set by ``--growth 5``, every run converged, as a
    collapse)."""
    upper = [t for t in summary["trials"]
             if t["factor"] == summary["bracket"][1]][-1]
    if not upper["converged"]:
        return "convergence", (
            "  set by convergence: the run at F = {:.4f} did not "
            "converge".format(upper["factor"]))
    failed = sum(not t["converged"] for t in summary["trials"])
    return "growth", (
        "  set by --growth {:g}: at F = {:.4f} the run converged, its "
        "largest displacement {:.2f} times that at F = {:g} ({}); judge "
        "it on safety.png: a steep rise of the displacement at the factor "
        "is a mechanism, a gentle one makes the factor follow --growth "
        "(run again with another --growth to see how far it moves)"
        .format(summary["growth"], upper["factor"],
                upper["largest_displacement"]
                / summary["reference_displacement"], summary["low"],
                "no trial failed to converge" if not failed else
                "{} trial(s) failed to converge".format(failed)))


def write_safety(outdir: Path, scene, reduced: list, options: dict,
                 trials: list, found, seconds: float,
                 error: str = None) -> dict:
    """``safety.json`` and ``safety.png`` of a strength reduction in
    ``outdir``: the bodies ``reduced`` (indices, :func:`reduced_bodies`),
    the ``options``, every one of the ``trials`` (the records
    of the CLI's runs, in order) with its outcome, and the factor of
    safety ``found`` (a :class:`~skfem_mpm.SafetyFactor`; ``None`` where
    the bracket failed, ``error`` saying why)."""
    outdir.mkdir(parents=True, exist_ok=True)
    length = unit("length", scene.units)
    stood = [] if found is None else [s for _, s in found.trials]
    rows = []
    for k, t in enumerate(trials):
        outcome = "fails" if not t["converged"] else \
            "converged" if found is None else \
            "stands" if stood[k] else "collapses"
        rows.append(dict(t, outcome=outcome))
    summary = {
        "scene": scene.name, "status": "completed" if found else "failed",
        "method": scene.method, "steps": scene.step_count,
        "reduced_bodies": [scene.bodies[k].name for k in reduced],
        "low": options["low"], "high": options["high"],
        "tolerance": options["tolerance"], "growth": options["growth"],
        "criterion": "a trial stands when its run converges and its "
        "largest point displacement is at most growth times that of the "
        "run at low (growth null: when its run converges)",
        "factor_of_safety": None if found is None else found.factor,
        "bracket": None if found is None else [found.converged,
                                               found.failed],
        "span": None if found is None else list(found.span),
        "warnings": [] if found is None else list(found.warnings),
        "reference_displacement": None if found is None else
        found.reference,
        "trials": rows, "wall_seconds": seconds,
        "units": {"factor_of_safety": "-", "factor": "-",
                  "largest_displacement": length, "span": "-",
                  "reference_displacement": length, "seconds": "s",
                  "wall_seconds": "s", "system": scene.units}}
    if error is not None:
        summary["error"] = error
    if found is not None:
        summary["set_by"] = safety_set_by(summary)[0]
    write_summary(outdir / "safety.json", summary)
    plot_safety(summary, outdir / "safety.png")
    return summary


def plot_safety(summary: dict, path: Path):
    """The largest displacement of every trial against its factor F
    (``safety.json``'s ``summary``), by outcome, the runs that failed
    marked along the top, the collapse threshold and the factor of safety
    with its bracket."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 4.5))
    length = summary["units"]["largest_displacement"]
    trials = summary["trials"]
    for outcome, label, style in (
            ("stands", "stands", dict(marker="o", color="tab:blue")),
            ("collapses", "converged, moved too far: collapse",
             dict(marker="s", color="tab:red", mfc="none")),
            ("converged", "converged (not judged: no factor found)",
             dict(marker="o", color="tab:gray"))):
        got = [t for t in trials if t["outcome"] == outcome]
        if got:
            ax.plot([t["factor"] for t in got],
                    [t["largest_displacement"] for t in got], ls="",
                    ms=7, label=label, **style)
    failed = [t["factor"] for t in trials if t["outcome"] == "fails"]
    if failed:
        ax.plot(failed, [.97] * len(failed), "x", color="k", ms=8,
                transform=ax.get_xaxis_transform(),
                label="run failed (no displacement)")
    moved = [t["largest_displacement"] for t in trials
             if t["largest_displacement"] is not None]
    if summary["growth"] is not None and moved:
        ax.axhline(summary["growth"] * moved[0], color="tab:red", ls="--",
                   lw=1., label="collapse threshold: {:g} x the run at "
                   "F = {:g}".format(summary["growth"], summary["low"]))
    if summary["factor_of_safety"] is not None and \
            summary.get("span") not in (None, summary["bracket"]):
        ax.axvspan(*summary["span"], color="tab:orange", alpha=.2, lw=0,
                   hatch="//", label="WARNING: uncertain,\n{:.4f} .. "
                   "{:.4f}".format(*summary["span"]))
    if summary["factor_of_safety"] is not None:
        lo, hi = summary["bracket"]
        ax.axvspan(lo, hi, color="tab:green", alpha=.25, lw=0)
        ax.axvline(summary["factor_of_safety"], color="tab:green",
                   label="factor of safety {:.3f} (bracket {:.4f} .. "
                   "{:.4f})".format(summary["factor_of_safety"], lo, hi))
    if moved and min(moved) > 0:
        ax.set_yscale("log")
    ax.set_xlabel("trial factor F (-): the strength divided by F (c / F, "
                  "tan(phi) / F; von Mises: yield stress / F)")
    ax.set_ylabel("largest point displacement ({})".format(length))
    ax.set_title("{}: strength reduction, the largest displacement\n"
                 "against the trial factor F{}".format(
                     summary["scene"], "" if summary["factor_of_safety"]
                     is not None else " (no factor found)"))
    ax.grid(True, which="both", alpha=.3)
    # beside the axes, where it covers no trial
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.), borderaxespad=0.,
              fontsize="small")
    fig.tight_layout()
    plot.save_figure(fig, path)


def main(argv=None) -> int:
    """The ``skfem-mpm`` command on ``argv`` (default ``sys.argv``): its
    exit status.  A Ctrl-C gets one line and status 130 wherever it falls.
    Run as the program (``argv`` not given), it ignores Ctrl-C once its
    work is done: the interpreter's exit that follows (some 0.2 s) would
    otherwise die of it without a word (status -2)."""
    try:
        return dispatch(argv)
    except KeyboardInterrupt:        # outside what a command handles itself
        print("skfem-mpm: interrupted; what was written is whole (every "
              "file is written to a temporary name and renamed)",
              file=sys.stderr)
        return 130
    finally:
        if argv is None:
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def dispatch(argv) -> int:
    """:func:`main` but for Ctrl-C."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exit:
        return int(exit.code or 0)
    logging.basicConfig(level=logging.WARNING,
                        format="%(name)s: %(message)s")
    break_bars_for_logs()
    # -v: this package's steps, not every library's notes (and, without
    # it, back to the root's level in a process that called main before)
    logging.getLogger("skfem_mpm").setLevel(
        logging.INFO if args.verbose else logging.NOTSET)
    try:
        # a scene's run keeps what converged when a batch system kills it
        # (SIGTERM) as on Ctrl-C
        with terminate_as_interrupt() if args.command == "run" \
                else nullcontext():
            return {"run": run, "compare": compare, "study": run_study,
                    "safety": run_safety}[args.command](args)
    except SceneError as err:
        for problem in err.problems:       # each naming the file once
            if err.source and not problem.startswith(err.source):
                problem = "{}: {}".format(err.source, problem)
            print("skfem-mpm: {}".format(problem), file=sys.stderr)
        return 2
    except InvalidInputError as err:
        print("skfem-mpm: {}".format(err), file=sys.stderr)
        return 2
    except MPMError as err:
        print("skfem-mpm: {}: {}".format(type(err).__name__, err),
              file=sys.stderr)
        return 1
    except OSError as err:            # a read-only or full disk, ...
        print("skfem-mpm: {}: {}".format(type(err).__name__, err),
              file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
