"""What accuracy costs in time: run a scene over a grid of choices
(elements, points per cell, load steps, method, right-hand side), measure
its quantities of interest (:mod:`~skfem_mpm.scenes.quantities`) and the
time of every phase, and draw the trade-off.

The error of a case is measured against the scene's closed-form reference
where it has one (``reference = "column"``: the error measure (2.28) of
Charlton (2018), the seed; ``"elastica"``,
``"bearing_capacity"``), and otherwise against the study itself
(:mod:`~skfem_mpm.studies.convergence`, after Eca and Hoekstra 2014): each
quantity's order is fitted by least squares over all the element counts
of a group of cases, and a case's error is its relative distance to the
extrapolation where the fit is credible, else its relative distance to
the group's finest case (whose own error is unknown, at most its
uncertainty: three times the group's data range); every case's value
carries an uncertainty (``relative_errors`` and
``relative_uncertainties`` per quantity, the first quantity's as
``error`` and ``uncertainty``), never zero.  Cases whose runs switched
the ghost penalty of ``ghost="auto"`` on at different steps solve
different discretisations: no order is fitted across them, and the
study says so (:func:`same_stabilisation`).  Every quantity's
observed order, reference, uncertainty and the reason, in words, why it
was or was not extrapolated are written to ``study.json`` under
``"convergence"``, with what the error measures under ``"error"``.

Cases are independent: they run serially (with a progress line) or on a
Dask cluster (``dask.distributed``, an optional extra: a local cluster or
``scheduler=ADDRESS``).  A local cluster has at most one worker per core
(more are capped, with a warning) and each worker one thread (OpenMP,
MKL, OpenBLAS and numba limited to one before the worker imports numpy).  Every
case records its wall time and its CPU time (``time.process_time`` of the
process that ran it): workers that share cores, memory bandwidth or the
machine with the study's own process stretch wall times, not CPU times,
so compare CPU times across serial and parallel studies.  Before the
first case of each method and solver choice, every process that runs
cases warms up (:func:`warm_up`: the first load step of the study's
smallest case of those choices, with each linear solver the case may
take), untimed: a case's times are what it costs, not its process's
one-off start (numba loading the compiled kernels from its cache,
Pardiso's library and first factorisation: 0.6-1.5 s of CPU, 10-20 times
a small case's); the warm-ups' times are kept apart, in ``study.json``
under ``"warm_up"`` and in the summary's last line.  Results are
appended per case, atomically, to ``study.json`` and ``study.csv``; an
interrupted study resumes without re-running finished cases, and refuses
a folder whose cases ran on another scene (:func:`finished_rows`).
:func:`estimate` puts a rough time on the cases before they start (from
the cases finished before, or from the smallest ones, run first), which
``skfem-mpm study`` prints.

"""
import csv
import hashlib
import io
import itertools
import json
import logging
import math
import os
import re
import socket
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..errors import InvalidInputError, MPMError
from ..repeats import warnings_once
from ..scenes.io import atomic_path
from ..scenes.quantities import Quantity, check_quantities
from ..scenes.regions import Ball, Polygon, bounding_box, region_shape
from ..scenes.scene import (METHODS, Grid, Scene, build_points,
                             point_bound, run_scene, support_names)
from ..solve.backends import (AUTO_AMG_FROM, AUTO_PARDISO_FROM,
                              available_solvers)
from ..solve.core import DEFAULT_GHOST, SMALL_STRAIN_GHOST
from ..solve.newton import LINE_SEARCHES, NEWTON, RHS
from ..solve.results import PHASES
from .column import SOURCE, column_error, column_extent
from .convergence import (ROUNDOFF, from_data_range, roundoff_floor,
                          roundoff_words, self_convergence)

logger = logging.getLogger(__name__)

__all__ = ["study", "refine", "case_error", "check_reference", "analyse",
           "report",
           "formal_order", "scene_quantities", "worker_count", "check_vary",
           "cases_of", "estimate", "time_model", "time_left", "clock",
           "disagreements", "VARIABLES",
           "DEFAULT_VARY", "DEFAULT_QUANTITY", "FOOTING_QUANTITY",
           "CASES_UNASKED",
           "default_vary", "default_elements", "whole_cells_step",
           "not_whole", "geometry_step", "lost_lines", "own_lines",
           "not_a_variable"]

VARIABLES = ("elements", "ppc", "loadsteps", "method", "rhs",
             "line_search", "newton")
CHOICES = {"method": METHODS, "rhs": RHS,     # the variables named by words
           "line_search": LINE_SEARCHES, "newton": NEWTON}
DEFAULT_VARY = {"elements": [4, 8, 16, 32, 64, 128, 256],
                "ppc": [2, 3, 4, 5], "loadsteps": [1, 2, 20]}
#: what a study measures when the scene names nothing
DEFAULT_QUANTITY = Quantity("displacement", "magnitude", reduce="max",
                            name="largest point displacement")
#: what a study of a footing scene (``reference = "bearing_capacity"``)
#: measures when it names nothing: the quantity its reference judges
FOOTING_QUANTITY = Quantity("footing_pressure", "peak")


def scene_quantities(scene) -> Sequence[Quantity]:
    """The scene's ``outputs``, or by default the peak footing pressure
    of a footing scene (:data:`FOOTING_QUANTITY`: its largest point
    displacement is about the footing's prescribed push, whose
    convergence says nothing; a user trial) and the largest point
    displacement (:data:`DEFAULT_QUANTITY`) of any other."""
    if scene.outputs:
        return list(scene.outputs)
    return [FOOTING_QUANTITY if scene.reference == "bearing_capacity"
            else DEFAULT_QUANTITY]


def whole_cells_step(scene: Scene) -> int:
    """The least ``elements`` that scales every axis of the scene's grid
    to whole cells in proportion (:func:`refine`): ``ref / gcd`` of the
    cell counts above one (``ref`` the largest); the values that do are
    its multiples.

    >>> from skfem_mpm.scenes.scene_file import EMBEDDED, load_scene
    >>> whole_cells_step(load_scene(EMBEDDED))        # 1 x 20 cells
    1
    """
    counts = [n for _, _, n in scene.grid.axes if n > 1]
    return max(counts) // math.gcd(*counts) if counts else 1


def geometry_step(scene: Scene) -> int:
    """The least ``elements`` that scales every axis of the scene's grid
    to whole cells (:func:`whole_cells_step`) and keeps on a grid line
    every feature line (:func:`feature_lines`) that the scene's own grid
    has on one; the values that do are its multiples.  A line ``k`` cells
    from an axis's start of the scene's ``n`` is ``k elements / ref``
    cells from it on the grid of ``elements`` (``ref`` the largest
    count), a whole number for the multiples of ``ref / gcd(k, ref)``.
    A trial's soil top on a line of the scene's 12 cells a side, 8 cells
    up, lay inside cells on grids of 4, 8, 16 and 32 elements (an error
    of 2.7e-2 where 12, 24 and 48 gave 5.9e-6).

    >>> from skfem_mpm.scenes.scene import Body, Grid, Scene
    >>> grid = Grid(axes=[(0., 1., 12), (0., 1.5, 12)])
    >>> soil = Body(name="soil", region=[[0., 1.], [0., 1.]], material=None)
    >>> whole_cells_step(Scene(grid=grid, bodies=[soil]))
    1
    >>> geometry_step(Scene(grid=grid, bodies=[soil]))   # y = 1: 8 of 12
    3
    """
    axes = scene.grid.axes
    ref = max(n for _, _, n in axes)
    step = whole_cells_step(scene)
    for axis, value, _ in own_lines(scene):
        lo, hi, n = axes[axis]
        k = int(round((value - lo) / (hi - lo) * n))
        step = step * (ref // math.gcd(k, ref)) // math.gcd(
            step, ref // math.gcd(k, ref))
    return step


def lost_lines(scene: Scene, values: Sequence[int]) -> str:
    """Why a study of the ``elements`` of ``values`` would model another
    geometry than the scene's, in words ("" where one of them keeps
    it): every one of them puts inside a cell a feature line that the
    scene's own grid has on a grid line (:func:`geometry_step`); the
    line, and the values that keep it.

    >>> from skfem_mpm.scenes.scene import Body, Grid, Scene
    >>> soil = Body(name="soil", region=[[0., 1.], [0., 1.]], material=None)
    >>> scene = Scene(grid=Grid(axes=[(0., 1., 12), (0., 1.5, 12)]),
    ...               bodies=[soil])
    >>> lost_lines(scene, [12, 16])
    ''
    >>> print(lost_lines(scene, [4, 8, 16]))
    ... # doctest: +ELLIPSIS +NORMALIZE_WHITESPACE
    elements = 4, 8, 16 put body 'soil' y = 1 inside a cell on every
    grid, where the scene's own grid of 12 x 12 cells has it on a grid
    line: ... the multiples of 3 (3, 6, 9, 12, ...)
    """
    step = geometry_step(scene)
    if any(int(v) % step == 0 for v in values):
        return ""
    axes = scene.grid.axes
    kept = own_lines(scene)
    lost = [off_grid_lines(scene, int(v), kept) for v in values]
    common = [line for line in lost[0]
              if all(line in off for off in lost[1:])]

    def face(line):
        return "{} {} = {:g}".format(line[2], "xyz"[line[0]], line[1])
    where = "put {} inside a cell on every grid".format(face(common[0])) \
        if common else "each put inside a cell a face ({})".format("; ".join(
            "{}: {}".format(int(v), face(off[0]))
            for v, off in zip(values, lost)))
    return ("elements = {} {}, where the scene's own grid of {} cells has "
            "it on a grid line: each case would model another geometry "
            "(bodies are seeded by cells, supports and obstacles meet "
            "them elsewhere), and the study's error and cost would not be "
            "the scene's.  The values that keep every such line on a "
            "grid line are the multiples of {} ({}, ...)".format(
                ", ".join(str(int(v)) for v in values), where,
                " x ".join(str(n) for _, _, n in axes),
                step, ", ".join(str(step * k) for k in range(1, 5))))


def own_lines(scene: Scene) -> list:
    """The feature lines (:func:`feature_lines`) that the scene's own grid
    has on grid lines: the geometry a study's grids keep."""
    lines = feature_lines(scene)
    off = _off_lines(scene.grid.axes, lines)
    return [line for line in lines if line not in off]


def _counts(scene: Scene, elements: int) -> list:
    """Each axis's cell count scaled to ``elements`` along the most
    refined one, unrounded (an axis one cell across stays so where
    another has more: :func:`scaled_axes`)."""
    ref = max(n for _, _, n in scene.grid.axes)
    scaled = scaled_axes(scene)
    return [n * elements / ref if d in scaled else n
            for d, (_, _, n) in enumerate(scene.grid.axes)]


def scaled_axes(scene: Scene) -> list:
    """The axes a study's ``elements`` refines (:func:`refine`): those of
    more than one cell, or every axis of a grid of one cell.  An axis one
    cell across stays one cell: a strip one cell wide between rollers,
    such as the column, is a 1D problem, which more cells across would
    make dearer without changing it; its cells lengthen or shorten along
    the other axes only.

    >>> from skfem_mpm.scenes.scene import Grid, Scene
    >>> strip = Grid(axes=[(0., 2.5, 1), (0., 50., 20)])    # 1 x 20
    >>> scaled_axes(Scene(grid=strip, bodies=[]))
    [1]
    >>> [n for _, _, n in refine(Scene(grid=strip, bodies=[]),
    ...                          160).grid.axes]
    [1, 160]
    """
    axes = scene.grid.axes
    many = [d for d, (_, _, n) in enumerate(axes) if n > 1]
    return many or list(range(len(axes)))


def _rounded(scene: Scene, elements: int) -> Scene:
    """The scene on the grid of :func:`refine` with each count rounded:
    the grid an older study ran a case of ``elements`` on, which did not
    scale the axes to whole cells (for :func:`cell_size` and
    :func:`off_grid_lines` of its recorded rows)."""
    new = [(lo, hi, max(1, round(n))) for (lo, hi, _), n in zip(
        scene.grid.axes, _counts(scene, elements))]
    return replace(scene, grid=Grid(axes=new, element=scene.grid.element))


def not_whole(scene: Scene, values: Sequence[int]) -> str:
    """Why the ``elements`` of ``values`` that do not scale every axis of
    the scene's grid to whole cells cannot refine it, in words ("" where
    all do): the first such value's axis, the count it would need and
    what rounding it would do (the cells' sizes, a feature line of the
    scene moved inside a cell), and the values that keep whole cells.

    >>> from skfem_mpm.scenes.scene import Grid, Scene
    >>> from skfem_mpm.studies.study import not_whole
    >>> scene = Scene(grid=Grid(axes=[(0., 2.5, 20), (-0.125, 1., 9)]),
    ...               bodies=[])
    >>> why = not_whole(scene, [10, 20, 40])
    >>> print(why)    # doctest: +ELLIPSIS +NORMALIZE_WHITESPACE
    elements = 10 does not scale the grid's 20 x 9 cells in proportion:
    it needs 4.5 cells along y (9 x 10 / 20); ... the multiples of 20
    (20, 40, 60, 80, ...)
    """
    bad = [e for e in values if any(
        n != int(n) for n in _counts(scene, int(e)))]
    if not bad:
        return ""
    axes = scene.grid.axes
    counts = [n for _, _, n in axes]
    ref = max(counts)
    e = int(bad[0])
    scaled = _counts(scene, e)
    axis = next(d for d, n in enumerate(scaled) if n != int(n))
    rounded = _rounded(scene, e)
    sizes = " x ".join("{:.4g}".format((hi - lo) / n)
                       for lo, hi, n in rounded.grid.axes)
    off = _off_lines(rounded.grid.axes, own_lines(scene))
    moved = "" if not off else ", and put {} {} = {:g} inside a cell{}" \
        .format(off[0][2], "xyz"[off[0][0]], off[0][1],
                "" if len(off) == 1 else " (and {} more line{})".format(
                    len(off) - 1, "s" if len(off) > 2 else ""))
    step = whole_cells_step(scene)
    return ("elements = {} does not scale the grid's {} cells in "
            "proportion: it needs {:.4g} cells along {} ({} x {} / {}); "
            "rounding would make the cells {} against the scene's {}{}"
            "{}.  The values that keep whole cells along every axis are "
            "the multiples of {} ({}, ...)".format(
                e, " x ".join(str(n) for n in counts), scaled[axis],
                "xyz"[axis], counts[axis], e, ref, sizes, " x ".join(
                    "{:.4g}".format((hi - lo) / n) for lo, hi, n in axes),
                moved, "" if len(bad) == 1 else "; elements = {} {} not "
                "either".format(", ".join(str(v) for v in bad[1:]),
                                "does" if len(bad) == 2 else "do"),
                step, ", ".join(str(step * k) for k in range(1, 5))))


def refine(scene: Scene, elements: int) -> Scene:
    """The scene on a grid with ``elements`` cells along its most refined
    axis, the other axes in proportion, but an axis one cell across
    stays one cell where another has more (:func:`scaled_axes`: the
    column's 1 x 20 cells at 160 elements are 1 x 160): the same cells'
    shape along the axes refined and the same grid lines at the scene's
    faces as on its own grid, coarser or finer.

    Raises
    ------
    InvalidInputError
        Where ``elements`` does not scale some axis to whole cells
        (:func:`not_whole`: the axis, the count it would need, the values
        that keep whole cells, the multiples of :func:`whole_cells_step`).
        Rounding the count, as this did before, changed the cells' shape
        and moved the scene's faces off the grid lines: a trial's floor
        obstacle, its top at y = 0 on a grid of 20 x 9 cells of 0.125
        from y = -0.125, at 10 elements (4.5 cells along y, rounded to
        4: cells 0.25 x 0.281) held the soil at the start or not at
        all, and every case failed with no word about the grid.
    """
    why = not_whole(scene, [elements])
    if why:
        raise InvalidInputError(why)
    new = [(lo, hi, int(n)) for (lo, hi, _), n in zip(
        scene.grid.axes, _counts(scene, elements))]
    return replace(scene, grid=Grid(axes=new, element=scene.grid.element))


def configure(scene: Scene, params: dict) -> Scene:
    """The scene with one case's choices applied (every method runs with
    the scene's kinematics)."""
    out = scene
    if "elements" in params:
        out = refine(out, int(params["elements"]))
    if "ppc" in params:
        out = replace(out, bodies=[replace(b, points_per_cell=int(
            params["ppc"])) for b in out.bodies])
    if "loadsteps" in params:
        out = replace(out, nsteps=int(params["loadsteps"]))
    if "method" in params:
        out = replace(out, method=params["method"])
    newton = {name: params[name] for name in ("rhs", "line_search", "newton")
              if name in params}
    if newton:
        out = replace(out, newton=replace(out.newton, **newton))
    return out


#: per scene reference: a short label and what its error measures
REFERENCE_ERRORS = {
    "column": ("error measure (2.28) of " + SOURCE,
               "the column's closed form, Ch. 2 of " + SOURCE,
               "error measure (2.28) of {}, Ch. 2: stress at the points "
               "against the column's closed form".format(SOURCE)),
    "elastica": ("tip deflection error", "the elastica",
                 "relative error of the loaded points' tip deflection "
                 "against the elastica"),
    "bearing_capacity": ("peak pressure error", "N_c c (Prandtl-Reissner)",
                         "relative error of the footing's peak pressure "
                         "against N_c c (Prandtl-Reissner)")}


def check_reference(scene: Scene) -> None:
    """Refuse, before any run, a scene whose closed-form ``reference``
    cannot measure it: ``"column"`` without gravity along the last axis or
    without a body of some height in the grid
    (:func:`~skfem_mpm.studies.column.column_extent`); ``"elastica"``
    whose first body (the beam: its length and depth enter the load
    parameter) is not a box; a bearing-capacity
    scene is checked with the scene itself
    (:meth:`~skfem_mpm.scenes.scene.Scene.check`).

    Raises
    ------
    InvalidInputError
        Saying why the reference does not apply.
    """
    if scene.reference == "column":
        column_extent(scene)
    if scene.reference == "elastica":
        shape = region_shape(scene.bodies[0].region)
        if shape != "box":
            raise InvalidInputError(
                "reference 'elastica': body {!r} (the beam) needs a box "
                "region, region = {{ x = [lo, hi], y = [lo, hi] }} (its "
                "length and depth enter the load parameter), not a "
                "{}".format(scene.bodies[0].name, shape))


def case_error(scene: Scene, result) -> float:
    """The scene's error measure: ``reference = "column"`` gives the
    error measure (2.28) of Charlton (2018); ``"elastica"`` the relative
    error of the loaded points' tip
    deflection at full load against the elastica; ``"bearing_capacity"``
    the relative error of the footing's peak pressure against ``N_c c``;
    NaN without a reference."""
    pts = result.points
    if scene.reference == "column":
        load, base, height = column_extent(scene)
        return column_error(pts, load, height, base)
    if scene.reference == "elastica":
        from .elastica import elastica_tip
        body = scene.bodies[0]
        (x0, x1), (y0, y1) = body.region[0], body.region[1]
        length, depth = x1 - x0, y1 - y0
        E, nu = body.material.E, body.material.nu
        load = sum(abs(p.force[1]) for p in scene.point_loads)
        alpha = load * length ** 2 / (E / (1 - nu ** 2) * depth ** 3 / 12)
        loaded = np.flatnonzero(pts.force[1])
        v = -pts.displacement[1, loaded].mean() / length
        return float(abs(v / elastica_tip([alpha])[0][0] - 1))
    if scene.reference == "bearing_capacity":
        from ..scenes.footing import footing_forces
        from .footing import footing_error
        return footing_error(scene, footing_forces(scene, result.history))
    return float("nan")


class PeakMemory:
    """Peak growth of the resident set size while the block runs, sampled
    every ``interval`` seconds in a thread (no tracing overhead)."""

    def __init__(self, interval: float = .005):
        self.interval = interval
        self.peak = 0

    @staticmethod
    def rss() -> int:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    def _sample(self):
        while not self._stop.wait(self.interval):
            self.peak = max(self.peak, self.rss() - self.start)

    def __enter__(self):
        self.start = self.rss()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, self.rss() - self.start)


#: the run's counters of what it switched on by itself that a study's
#: rows record (:func:`run_case`), 0 where it never did: the ghost penalty
#: of ``ghost="auto"`` (it changes the equations, so cases that differ in
#: it solve different discretisations: :func:`same_stabilisation`), and
#: the line search that later steps start with (it keeps each step's
#: equations: recorded, not compared)
SWITCHES = ("ghost_from_step", "line_search_from_step")


def run_case(scene: Scene, params: dict, quantities=()) -> dict:
    """One case, timed inside: error against the scene's reference (if it
    has one), the ``quantities``' ``values``, wall time and CPU time
    (``time.process_time`` of this process: all its threads), time per
    phase, Newton iterations, DOFs, points, peak memory (growth of the
    resident set during the case) and the step from which the run
    switched on what it switches on by itself (:data:`SWITCHES`, 0:
    never).  The times are those of the run
    (:func:`~skfem_mpm.scenes.scene.run_scene`: seeding, set-up, every
    step, everything that grows with the case), not of measuring its
    quantities; they include what the process does the first time (numba
    loading compiled kernels, Pardiso's start) unless it has been warmed
    up (:func:`warm_up`, as :func:`study` does)."""
    case = configure(scene, params)
    with PeakMemory() as memory:
        tic, cpu = time.perf_counter(), time.process_time()
        try:
            result = run_scene(case)
            failure = ""
        except MPMError as err:
            result, failure = None, "{}: {}".format(type(err).__name__, err)
        cpu = time.process_time() - cpu
        wall = time.perf_counter() - tic
    row = dict(params)
    row.update(wall_seconds=wall, cpu_seconds=cpu,
               peak_mb=memory.peak / 2 ** 20, failure=failure)
    if result is None:
        return row
    timings = result.timings()
    row.update({"t_" + p: timings[p] for p in PHASES})
    if case.reference is not None:
        row["reference_error"] = case_error(case, result)
    try:
        row["values"] = {q.label: q.measure(case, result)
                         for q in quantities}
        # where an extreme over the points lies (moving_extremes)
        row["extreme_at"] = {
            q.label: [float(v) for v in at] for q, at in (
                (q, q.extreme_point(case, result)) for q in quantities)
            if at is not None}
        row["extreme_component"] = {
            q.label: q.extreme_component(case, result) for q in quantities
            if q.label in row["extreme_at"]}
        # the size of each kind of quantity, to tell a zero (zero_values)
        row["scale"] = {q.label: q.scale(case, result) for q in quantities}
    except MPMError as err:
        row["failure"] = "{}: {}".format(type(err).__name__, err)
    row.update(
        points=int(result.points.n),
        dofs=int(max(r.n_free_dofs for r in result.history)),
        newton_iterations=int(result.counters["newton_iterations"]),
        factorisations=int(result.counters["factorisations"]),
        steps_run=len(result.history),
        **{name: int(result.counters.get(name, 0)) for name in SWITCHES})
    return row


class _FirstStepDone(Exception):
    """Raised by a warm-up's callback to end its run after one step."""


#: what this process has warmed up: ``(scene, choices, solver)`` -> its
#: record
WARMED: Dict[tuple, dict] = {}


def process_name() -> str:
    """This process in a study's rows and warm-ups: host and process
    id."""
    return "{}:{}".format(socket.gethostname(), os.getpid())


def scene_key(scene: Scene) -> str:
    """The scene as text (its ``repr`` without the memory addresses of
    functions it holds, which differ between the copies of a scene that
    Dask workers unpickle): a process warmed up for a scene is warm for
    every case of it, not for another scene's kinematics, materials,
    obstacles or dimension."""
    return re.sub(r" at 0x[0-9a-fA-F]+", "", repr(scene))


def scene_sha256(scene: Scene) -> str:
    """The SHA-256 of the scene's content (:func:`scene_key`) but its
    ``outputs``, recorded with each case of a study (``scene_sha256``): a
    study resumed in a folder refuses the cases of another scene
    (:func:`finished_rows`; a user trial resumed a study after doubling E
    and the load steps, and its old cases were read back as the new
    scene's).  The outputs are the study's quantities, recorded apart
    (:func:`measure_key`): a quantity added or defined otherwise runs
    the cases again, on the same scene."""
    return hashlib.sha256(scene_key(replace(scene, outputs=()))
                          .encode()).hexdigest()


#: what :func:`scene_sha256` sees, said where it refuses a study
SCENE_SEEN = ("a field of the scene as Python holds it differs, defaults "
              "included: the material, loads, steps or name, or the "
              "solver, kernels, units or a field a later version of "
              "skfem-mpm added, which may leave the numbers alone; "
              "functions count by their names only")


def scene_file_sha256(path) -> str:
    """The SHA-256 of a scene file's settings but its ``[[outputs]]``
    (its TOML parsed, numbers as floats, keys sorted: comments, layout
    and ``1000`` for ``1000.0`` count as the same), recorded with each
    case of a study run on the file (``scene_file_sha256``, beside
    :func:`scene_sha256`): a study resumed on the same file reads its
    cases back whatever a later version of skfem-mpm adds to the scene's
    defaults, and refuses them where a setting of the file differs
    (:func:`finished_rows`)."""
    from ..scenes.scene_file import tomllib
    data = tomllib.loads(Path(path).read_bytes().decode("utf-8"))
    data.pop("outputs", None)

    def plain(value):
        if isinstance(value, dict):
            return {k: plain(v) for k, v in value.items()}
        if isinstance(value, list):
            return [plain(v) for v in value]
        if isinstance(value, int) and not isinstance(value, bool):
            return float(value)
        return value
    return hashlib.sha256(json.dumps(plain(data), sort_keys=True,
                                     default=str).encode()).hexdigest()


def measure_key(quantity: Quantity) -> str:
    """A quantity's whole definition as text (recorded with each case
    under ``measures``, per label): a case whose quantity of a label was
    defined otherwise (a user's ``name`` kept over a changed point or
    component) runs again on resume (:func:`finished_rows`)."""
    return re.sub(r" at 0x[0-9a-fA-F]+", "", repr(quantity))


def choices_of(params: dict) -> dict:
    """The choices of a case that select code (method, right-hand side,
    line search, Newton variant): cases sharing them run the same compiled
    kernels and solver paths, whatever their grid, points and steps."""
    return {k: params[k] for k in CHOICES if k in params}


def dof_bound(scene: Scene) -> float:
    """The grid DOFs a scene's bodies can take at the start, without
    building anything: the nodes of the cells each body's box (a
    polygon's or disc's bounding box) reaches with one cell around it
    (every node of the grid for another function region or a ready
    mesh), per body (each its own grid where bodies are in
    contact) and times the dimension.  Whether ``"auto"`` may take
    Pardiso or AMG for a case (:func:`case_solvers`) is judged by it."""
    grid, dim = scene.grid, scene.grid.dim
    if grid.mesh is not None:
        return float(grid.mesh.nvertices * dim * len(scene.bodies))
    degree = 2 if grid.element == "Q2" else 1
    nodes = 0.
    for body in scene.bodies:
        region = bounding_box(body.region)
        if region is None:
            region = [(lo, hi) for lo, hi, _ in grid.axes]
        nodes += float(np.prod([
            degree * min(n, np.ceil(max(min(hi, b_hi) - max(lo, b_lo), 0.)
                                    / (hi - lo) * n) + 2) + 1
            for (lo, hi, n), (b_lo, b_hi) in zip(grid.axes, region)]))
    return nodes * dim


def case_solvers(scene: Scene, params: dict) -> List[str]:
    """The linear solvers (scene ``solver`` names) a case may run: the
    scene's own, and where that is ``"auto"``, ``"pypardiso"`` and
    ``"pyamg"`` too where they are installed and the case's
    :func:`dof_bound` reaches the size from which ``"auto"`` takes them
    (:data:`~skfem_mpm.solve.backends.AUTO_PARDISO_FROM`,
    :data:`~skfem_mpm.solve.backends.AUTO_AMG_FROM`)."""
    case = configure(scene, params)
    if case.solver != "auto":
        return [case.solver]
    installed, dim, dofs = available_solvers(), case.grid.dim, \
        dof_bound(case)
    direct = "pypardiso" if "pypardiso" in installed else "scipy (SuperLU)"
    return ["auto"] + [name for name, size in (
        ("pypardiso", AUTO_PARDISO_FROM[dim]),
        ("pyamg", AUTO_AMG_FROM[direct][dim]))
        if name in installed and dofs >= size]


def warm_up(scene: Scene, params: dict, smallest: dict) -> List[dict]:
    """Warm this process up for a case, untimed: for each of its
    :func:`case_solvers` not yet warmed up here with the case's
    :func:`choices_of`, the first load step of ``smallest`` (the study's
    smallest case with those choices; if it fails, of the case itself)
    run with that solver.  That loads what a process does once, whatever
    the case's size: the compiled kernels from numba's cache (numba's
    import, about 0.7 s, and each kernel's first call), lazy imports, the
    point finder's set-up, Pardiso's library and first factorisation
    (0.6-1.4 s), pyamg's import (0.6 s).  Returns the records of the warm-ups
    run: ``process`` (host and process id), ``choices``, ``solver``,
    ``case`` (the case whose first step ran), ``wall_seconds``,
    ``cpu_seconds`` and ``failure`` (empty, or why no candidate ran)."""
    choices = choices_of(params)
    records = []
    for solver in case_solvers(scene, params):
        key = (scene_key(scene), _key(choices), solver)
        if key in WARMED:
            continue
        tic, cpu = time.perf_counter(), time.process_time()
        failure = ""
        for candidate in (smallest, params)[:1 + (smallest != params)]:
            failure = first_step(replace(configure(scene, candidate),
                                         solver=solver))
            if not failure:
                break
        WARMED[key] = dict(
            process=process_name(), choices=choices, solver=solver
            if isinstance(solver, str) else getattr(
                solver, "__name__", type(solver).__name__),
            case=candidate,
            wall_seconds=time.perf_counter() - tic,
            cpu_seconds=time.process_time() - cpu, failure=failure)
        records.append(WARMED[key])
    return records


def first_step(scene: Scene) -> str:
    """Run the scene's first load step; ``""``, or why it failed."""
    def stop(record, points):
        raise _FirstStepDone
    try:
        run_scene(scene, callback=stop)
    except _FirstStepDone:
        pass
    except MPMError as err:
        return "{}: {}".format(type(err).__name__, err)
    return ""


def warm_case(scene: Scene, params: dict, quantities, smallest: dict):
    """``(row, warm-ups)``: :func:`warm_up` for the case, then the case
    (:func:`run_case`), whose times leave the warm-ups out; the row names
    its ``process`` (:func:`process_name`).  What a study's process
    (serial) or worker (Dask) runs for each case."""
    records = warm_up(scene, params, smallest)
    row = run_case(scene, params, quantities)
    row["process"] = process_name()
    return row, records


def _key(params: dict) -> str:
    return json.dumps({k: params[k] for k in VARIABLES if k in params},
                      sort_keys=True)


def cell_size(scene: Scene, elements: int) -> float:
    """The representative cell size ``(V / N)^(1/d)`` (Celik et al. 2008)
    of the scene's grid refined to ``elements`` (:func:`refine`; for a
    row of an older study whose ``elements`` did not scale every axis to
    whole cells, the grid it ran on, the counts rounded), over the ``d``
    axes it refines (:func:`scaled_axes`): over all, a strip one cell
    wide, the column's 1 x 20 cells, had its cell size shrink as the
    square root of the cells along it, and orders fitted against it
    came out twice the order in the cells' length.

    >>> from skfem_mpm.scenes.scene import Grid, Scene
    >>> strip = Grid(axes=[(0., 2.5, 1), (0., 50., 20)])    # 1 x 20
    >>> cell_size(Scene(grid=strip, bodies=[]), 40)   # 50 m in 40 cells
    1.25
    """
    axes = _rounded(scene, elements).grid.axes
    scaled = scaled_axes(scene)
    return float(np.prod([(axes[d][1] - axes[d][0]) / axes[d][2]
                          for d in scaled]) ** (1. / len(scaled)))


def feature_lines(scene: Scene) -> list:
    """The coordinates ``(axis, value, what)``, each once, where the
    scene's geometry has a face inside the grid: the bounds of its
    bodies' boxes and their polygons' vertices, of its obstacles' boxes
    and polygons' vertices at the start, of its supports' boxes,
    polygons and points (a disc or ball has none: its side, curved, lies
    on no grid line)."""
    axes = scene.grid.axes
    found = []

    def add(axis, values, what):
        lo, hi = axes[axis][:2]
        found.extend((axis, float(v), what) for v in np.ravel(values)
                     if lo < v < hi and not any(
                         (a, x) == (axis, v) for a, x, _ in found))
    for body in scene.bodies:
        if isinstance(body.region, Polygon):
            for d in range(len(axes)):
                add(d, body.region.vertices[d], "body {!r}".format(
                    body.name))
        elif not callable(body.region):
            for d, bounds in enumerate(body.region):
                add(d, bounds, "body {!r}".format(body.name))
    for ob in scene.obstacles:
        corners = ob.box if ob.box is not None else ob.vertices.T
        for d in range(len(axes)):
            add(d, corners[d], "obstacle {!r}".format(ob.name))
    for name, support in zip(support_names(scene), scene.supports):
        region = support.region
        for d, bounds in enumerate(
                region.vertices if isinstance(region, Polygon)
                else () if region is None or isinstance(region, Ball)
                else region):
            add(d, bounds, "support {!r}".format(name))
        for d, value in enumerate(support.at or ()):
            add(d, value, "support {!r}".format(name))
    return found


def off_grid_lines(scene: Scene, elements: int, lines: list) -> list:
    """Of the feature ``lines`` (:func:`feature_lines`), those that the
    scene's grid refined to ``elements`` (:func:`refine`; rounded as in
    :func:`cell_size` for an older study's row) puts inside a cell."""
    return _off_lines(_rounded(scene, elements).grid.axes, lines)


def _off_lines(axes, lines: list) -> list:
    """Of the feature ``lines``, those inside a cell of the grid of
    ``axes``."""
    off = []
    for axis, value, what in lines:
        lo, hi, n = axes[axis]
        k = (value - lo) / (hi - lo) * n
        if abs(k - round(k)) > 1e-9 * n:
            off.append((axis, value, what))
    return off


def formal_order(scene: Scene, quantity: Quantity) -> int:
    """The formal order of convergence of ``quantity`` on the scene's
    grid: the element degree plus one for displacements and forces
    (reactions, rigid-body forces: integrals of the stresses), the degree
    for stresses (derivatives of the displacement).  The observed order is
    credible from 0.5 to twice this (:mod:`~.convergence`).

    >>> from skfem_mpm.scenes.quantities import Quantity
    >>> from skfem_mpm.scenes.scene_file import EMBEDDED, load_scene
    >>> from skfem_mpm.studies.study import formal_order
    >>> column = load_scene(EMBEDDED)
    >>> formal_order(column, Quantity("displacement", "x", at=(50.,)))
    2
    >>> formal_order(column, Quantity("stress", "xx", at=(25.,)))
    1
    """
    degree = 2 if scene.grid.element == "Q2" else 1
    return degree if quantity.quantity == "stress" else degree + 1


def _relative(x: Optional[float], scale: float) -> float:
    """``x / scale``, NaN for an unknown ``x`` (one case: nothing to
    compare; written as null)."""
    return float("nan") if x is None else float(x / scale)


def _groups(rows: List[dict], keys: Sequence[str]):
    """``(choices, members)`` of the ``rows`` that share the values of
    ``keys`` (those a row has), in order of appearance."""
    groups = {}
    for r in rows:
        groups.setdefault(tuple(r.get(k) for k in keys), []).append(r)
    return [({k: v for k, v in zip(keys, group) if v is not None}, members)
            for group, members in groups.items()]


def analyse(scene: Scene, rows: List[dict], quantities) -> dict:
    """Errors of every finished case, without a closed form.

    With ``elements`` varied, each group of cases sharing every other
    choice gives each quantity's :func:`~.convergence.self_convergence`
    over the cell size (the group's grids that share the finest one's
    geometry, :func:`same_geometry`, and the finest one's ghost penalty,
    :func:`same_stabilisation`; the others measured against its
    reference, three times their error their uncertainty; with fewer than
    three such grids no extrapolation over all,
    :func:`~.convergence.from_data_range`; the quantity's
    :func:`formal_order`): the reference, each case's error and
    uncertainty (relative to the reference); without, every group
    (sharing method, right-hand side, line search and Newton variant) is
    judged by :func:`~.convergence.from_data_range` against the case
    with the most points (then load steps): each other case's error its
    distance to that case.  Sets
    ``row["relative_errors"]`` and ``row["relative_uncertainties"]`` (per
    quantity, relative to its reference),
    ``row["other_geometry"]`` (``elements`` varied: whether the case's
    grid models a geometry other than the finest one's,
    :func:`same_geometry`: left out of the fit where three grids remain,
    and of the rate of a closed-form error always),
    ``row["other_stabilisation"]`` (whether the ghost penalty switched on
    otherwise than in the group's finest case: left out alike),
    ``row["error"]`` (the scene's closed-form error where it has one,
    else the first quantity's) and ``row["uncertainty"]`` (the first
    quantity's, ``None`` against a closed form), and returns what was
    measured, for ``study.json``: per quantity and group its
    ``convergence`` (:class:`~.convergence.SelfConvergence`'s fields, in
    the quantity's unit, its per-case lists as ``absolute_errors`` and
    ``absolute_uncertainties``; ``ghost_from_step`` of the cases fitted;
    ``mixed_stabilisation``, the words of :func:`same_stabilisation`).
    A group of one case has no error and no uncertainty (NaN, written as
    null); the finest case of a group where nothing was extrapolated has
    no error (unknown: at most its uncertainty).

    Differences within round-off are no convergence and no disagreement:
    the scene's Newton tolerance ``tol`` sets it,
    :func:`~.convergence.roundoff_floor` (10 ``tol`` of a quantity's
    largest value, 1e-8 at the default; at least 1e-12), which
    ``"error"`` holds as ``roundoff`` (with ``roundoff_is``, in words):
    values that agree so have converged to round-off (no order, no
    extrapolation, no rate of their errors) and no error or uncertainty
    is below it.
    """
    done = [r for r in rows if not r["failure"] and "values" in r]
    refined = any("elements" in r for r in rows)   # all failed: varied
    keys = [k for k in VARIABLES if k != "elements"] if refined else \
        list(CHOICES)
    convergence = []
    tol = scene.newton.tol      # the runs' round-off (studies vary no tol)
    lines = feature_lines(scene) if refined else []
    for choices, members in _groups(done, keys):
        if refined:     # coarse to fine (they came in the order done)
            members = sorted(members, key=lambda r: r["elements"])
        fitted, left_out = (same_geometry(scene, members, lines) if refined
                            else (members, ""))
        alike, mixed = same_stabilisation(members, refined, choices)
        for r in members:
            if refined:
                r["other_geometry"] = not any(r is f for f in fitted)
            # (elements not varied: the data range of all holds it)
            r["other_stabilisation"] = refined and not any(
                r is a for a in alike)
            r["mixed_stabilisation"] = bool(mixed)
        if refined:
            fitted = [r for r in fitted if any(r is a for a in alike)]
        kept = [k for k, r in enumerate(members)
                if any(r is f for f in fitted)]
        if len(fitted) < 3:             # no order without three grids
            fitted = members
        # on at the end or not, grids left out for it
        ends = refined and len(alike) < len(members)
        others = " and ".join(words for words in (
            "the scene's geometry (other: {})".format(left_out) if left_out
            else "", "the finest grid's ghost penalty (ghost=\"auto\": {})"
            .format(mixed) if ends else "") if words)
        failed = failed_cases(scene, rows, keys, choices) if refined \
            else []
        finer = [f for f in failed if f["elements"] > max(
            r["elements"] for r in members)]
        for q in quantities:
            values = [r["values"][q.label] for r in fitted]
            if refined and fitted is members and others:
                sizes = [cell_size(scene, r["elements"]) for r in fitted]
                # the reference: the finest grid of the scene's geometry
                # and stabilisation (a finest grid of another geometry,
                # left out, had been the reference of those that keep it)
                found = from_data_range(
                    values, min(kept or range(len(members)),
                                key=lambda k: sizes[k]),
                    "fewer than three grids share " + others, tol)
            elif refined:
                sizes = [cell_size(scene, r["elements"]) for r in fitted]
                found = self_convergence(sizes, values,
                                         formal_order(scene, q), tol)
                if left_out:
                    found.why += "; left out of the fit, a geometry other " \
                        "than the scene's: " + left_out
                if mixed:
                    found.why += "; {} (ghost=\"auto\"): {}".format(
                        "left out of the fit, the ghost penalty on at the "
                        "end otherwise than on the finest grid" if ends
                        else "fitted over grids whose ghost penalty "
                        "switched on at different steps", mixed)
            else:
                sizes = []
                finest = max(range(len(members)), key=lambda k: (
                    members[k]["points"], members[k].get("loadsteps", 0)))
                found = from_data_range(
                    values, finest, "elements not varied: the case with "
                    "the most points (then load steps) is the reference",
                    tol)
                if len(members) == 1:
                    found.errors = found.uncertainties = [None]
                    found.uncertainty = None
                if mixed:
                    found.why += "; the range mixes cases whose ghost " \
                        "penalty switched on otherwise (ghost=\"auto\"): " \
                        + mixed
            if finer:
                found = finest_failed(found, finer, fitted, values, [
                    cell_size(scene, r["elements"]) for r in fitted])
            scale = abs(found.reference) or max(abs(v) for v in values) \
                or 1.
            for r, e, u in zip(fitted, found.errors, found.uncertainties):
                r.setdefault("relative_errors", {})[q.label] = _relative(
                    e, scale)
                r.setdefault("relative_uncertainties", {})[q.label] = \
                    _relative(u, scale)
            for r in members:   # left out of the fit: measured against it
                if not any(r is f for f in fitted):
                    # its distance to the reference, its uncertainty that
                    # plus the reference's (from_data_range's rule: three
                    # times the distance was zero where the two agreed)
                    error = max(abs(r["values"][q.label] - found.reference),
                                found.roundoff * abs(found.reference))
                    r.setdefault("relative_errors", {})[q.label] = \
                        _relative(error, scale)
                    r.setdefault("relative_uncertainties", {})[q.label] = \
                        _relative(error + (found.uncertainty or 0.), scale)
            found = found.as_dict()
            found["absolute_errors"] = found.pop("errors")
            found["absolute_uncertainties"] = found.pop("uncertainties")
            convergence.append(dict(
                quantity=q.label,
                unit=q.unit(len(scene.grid.axes), scene.units),
                choices=choices, cell_sizes=sizes, values=values,
                ghost_from_step=[r.get("ghost_from_step") for r in fitted],
                mixed_stabilisation=mixed, stabilisation_left_out=ends,
                failed=failed, **found))
    first = quantities[0].label
    for r in done:
        r["error"] = r["reference_error"] if scene.reference else \
            r["relative_errors"][first]
        r["uncertainty"] = None if scene.reference else \
            r["relative_uncertainties"][first]
    if scene.reference:
        label, against, what = REFERENCE_ERRORS[scene.reference]
        if scene.reference == "bearing_capacity":  # the number itself
            from ..scenes.units import unit
            from .footing import limit_pressure
            what += " = {:.6g} {}".format(limit_pressure(scene), unit(
                "stress", scene.units))
    else:
        label = "relative error of {}".format(first)
        against, reference = (
            "its least-squares extrapolation (or the finest case)",
            "its extrapolation with the order fitted by least squares over "
            "the element counts where that order is credible; where it is "
            "not, the finest case, every other case's error being its "
            "distance to it, |f_i - f_finest| / |reference|, and its "
            "uncertainty that plus the finest's 3 x the data range "
            "max |f_i - f_j| / |reference| of the group; the finest's own "
            "error is unknown (-), at most its uncertainty "
            "(convergence: why)") \
            if refined else (
            "the finest case of those sharing method and solver",
            "the case with the most points (then load steps) among those "
            "sharing method, right-hand side, line search and Newton "
            "variant, every other case's error being its distance to it, "
            "|f_i - f_finest| / |reference|, and its uncertainty that plus "
            "the finest's 3 x the data range max |f_i - f_j| / |reference| "
            "of those cases; the finest's own error is unknown (-), at "
            "most its uncertainty: elements were not varied")
        what = "|value - reference| / |reference| of {} ({}), the " \
            "reference being {}".format(
                first, quantities[0].unit(
                    len(scene.grid.axes), scene.units), reference)
        what += "; it measures what the group's varied choices change, " \
            "not an error its cases share (of points per cell, a " \
            "penalty, the method): groups whose references disagree are " \
            "named (disagreements)"
    return {"error": {"label": label, "against": against, "measures": what,
                      "closed_form": bool(scene.reference),
                      "quantity": None if scene.reference else first,
                      "roundoff": roundoff_floor(tol),
                      "roundoff_is": roundoff_words(tol)},
            "convergence": convergence,
            "disagreements": [] if scene.reference else
            disagreements(convergence)}


def model_error(measured: dict, found: List[dict],
                kept: List[dict]) -> str:
    """Words for a group whose errors against a closed form fall and
    then rise with refinement while its quantity converges by itself
    (``found``: its convergence, extrapolated), else ``""``: the closed
    form's own model error may then dominate (a trial's cantilever
    against the elastica: 5.0%, 1.2%, 4.3% at 10, 20, 40 elements while
    the tip's displacement converged, 0.717, 0.767, 0.790 m)."""
    errors = [r["error"] for r in sorted(kept, key=lambda r: r["elements"])
              if r.get("error") is not None and np.isfinite(r["error"])]
    if not (measured["error"].get("closed_form") and found
            and found[0]["against"] == "richardson" and len(errors) > 2
            and errors[-1] > min(errors)):
        return ""
    c = found[0]
    return "; yet {} converges by itself (extrapolated {} +- {} {}): the " \
        "closed form's own model error (what its theory leaves out) may " \
        "dominate on the finer grids, where the discretisation's is the " \
        "smaller".format(c["quantity"], _number(c["reference"], "{:.6g}"),
                         _number(c["uncertainty"], "{:.2g}"), c["unit"])


def circular(convergence: dict) -> bool:
    """Whether a group's errors (``convergence``, of :func:`analyse`) are
    distances to an extrapolation with the observed order through exactly
    three grids: the fit passes through them, the errors are ``|alpha|
    h^p`` exactly, and their rate is that order again (a trial's "rate
    3.59 ...; standard error 0.00; local rates 3.59, 3.59"), no
    independent measure."""
    return (convergence["against"] == "richardson"
            and convergence["basis"] == "observed order"
            and len(convergence["values"]) == 3)


def failed_cases(scene: Scene, rows: List[dict], keys: Sequence[str],
                 choices: dict) -> List[dict]:
    """The failed cases of a refinement's group (its ``choices`` of
    ``keys``), coarse to fine: ``elements``, ``cell_size``, the error's
    class (``error``), the load factor its run last converged at
    (``load_factor``, ``None`` if its message names none) and
    ``collapse``: whether the message says the body may be collapsing
    (:func:`finest_failed`)."""
    out = []
    for r in rows:
        if not r["failure"] or "elements" not in r or any(
                r.get(k) != choices.get(k) for k in keys):
            continue
        load = re.search(r"load factor ([0-9.]+(?:e[-+]?[0-9]+)?)",
                         r["failure"])
        out.append(dict(
            elements=r["elements"],
            cell_size=cell_size(scene, r["elements"]),
            error=r["failure"].split(":")[0],
            load_factor=float(load.group(1)) if load else None,
            collapse="collapse" in r["failure"]))
    return sorted(out, key=lambda f: f["elements"])


def _failed_words(failed: List[dict]) -> str:
    return ", ".join("{} elements ({}{})".format(
        f["elements"], f["error"], "" if f["load_factor"] is None else
        " after load factor {:g}".format(f["load_factor"]))
        for f in failed)


def finest_failed(found, finer: List[dict], fitted: List[dict],
                  values: List[float], sizes: List[float]):
    """``found`` (a :class:`~.convergence.SelfConvergence`) of a group
    whose finest cases ``finer`` failed (:func:`failed_cases`): its
    ``why`` says so, and that an extrapolation stands on the coarser
    grids only; where a failure says the body may be collapsing, nothing
    is extrapolated (the finer grid did not carry the load the coarser
    ones did, and their values need not converge to any solution: a
    trial's pad, 128 elements, stopped at load factor 0.975 "yielding
    towards a collapse" while 16, 32 and 64 gave an extrapolation
    +- 0.34%): the reference is then the finest case that ran, with
    :func:`~.convergence.from_data_range`'s uncertainty."""
    words = _failed_words(finer)
    coarser = ", ".join(str(r["elements"]) for r in fitted)
    if any(f["collapse"] for f in finer) and found.against == "richardson":
        finest = min(range(len(sizes)), key=lambda k: sizes[k])
        return from_data_range(
            values, finest, "the finest case{} failed, saying the body "
            "may be collapsing: {}; the coarser grids ({} elements), "
            "whose fit alone gave {} (order {:.2f}), carried a load a "
            "finer one did not and need not converge to any solution"
            .format("s" if len(finer) > 1 else "", words, coarser,
                    _number(found.reference, "{:.6g}"), found.order),
            found.tolerance, formal_order=found.formal_order,
            credible_orders=found.credible_orders,
            observed_order=found.observed_order)
    found.why += "; the finest case{} failed: {}: {} on the coarser grids " \
        "only ({} elements){}".format(
            "s" if len(finer) > 1 else "", words,
            "extrapolated" if found.against == "richardson" else
            "the reference is", coarser,
            ", where a failure that says collapse would refuse it"
            if found.against == "richardson" else "")
    return found


def failed_finest(measured: dict) -> List[str]:
    """A warning per quantity and group whose finest cases failed
    (``convergence``'s ``failed`` finer than every case that ran; a
    trial's study said "extrapolated ... values monotone", exit 0, and
    its figure left the failed case out without a mark)."""
    lines = []
    for c in measured["convergence"]:
        sizes = c["cell_sizes"] or []
        finer = [f for f in c.get("failed", ())
                 if sizes and f["cell_size"] < min(sizes)]
        if not finer:
            continue
        where = ", ".join("{}={}".format(k, v)
                          for k, v in c["choices"].items())
        lines.append(
            "WARNING: {}{}: the finest case{} failed: {}; {}".format(
                c["quantity"], " [" + where + "]" if where else "",
                "s" if len(finer) > 1 else "", _failed_words(finer),
                "the reference is extrapolated from the coarser grids "
                "only" if c["against"] == "richardson" else
                "nothing is extrapolated (a failure says collapse)"
                if any(f["collapse"] for f in finer) else
                "the reference is the finest case that ran"))
    return lines


#: the summary names this many pairs of disagreeing groups, the furthest
#: apart first (``study.json`` keeps them all)
SHOWN_PAIRS = 5


def disagreements(convergence: List[dict]) -> List[dict]:
    """Per quantity, the pairs of groups (their ``choices``) whose
    references lie further apart than the sum of their uncertainties and
    the round-off (each group's ``roundoff``,
    :func:`~.convergence.roundoff_floor` of its runs' Newton tolerance,
    :data:`~.convergence.ROUNDOFF` where it has none, of the larger
    reference: a user trial's push, mu W = 24 kN/m within 2.6e-9 in
    every case of mpm and cpgimp, tolerance 1e-9, was named):
    both converge to the one answer of the scene's problem, so at least
    one carries an error its refinement did not remove, or claims too
    small an uncertainty (a user trial's passive wall: cpGIMP's reference
    77 567 +- 21 N/m and an error of 9e-5 where FE gives Rankine's
    76 000: 2% that no column showed).  Each has the ``quantity``, both
    ``choices``, ``references`` and ``uncertainties``, and ``apart``,
    their distance relative to the first reference.

    >>> from skfem_mpm.studies.study import disagreements
    >>> c = [dict(quantity="F", choices={"method": m}, reference=r,
    ...           uncertainty=u) for m, r, u in
    ...      [("mpm", 100., 1.), ("cpgimp", 102., .5), ("fem", 100.5, 1.)]]
    >>> [(d["choices"][1]["method"], round(d["apart"], 4))
    ...  for d in disagreements(c)]
    [('cpgimp', 0.02)]
    >>> disagreements([dict(quantity="F", choices={"rhs": r}, reference=v,
    ...                     uncertainty=0.) for r, v in
    ...                [("residual", 1.), ("increment", 1. + 2e-16)]])
    []
    >>> disagreements([dict(quantity="F", choices={"method": m},
    ...                     reference=v, uncertainty=u, roundoff=1e-8)
    ...                for m, v, u in [("mpm", -24.0000000036, 3.6e-9),
    ...                                ("cpgimp", -23.9999999995, 1.5e-9)]])
    []
    """
    found = []
    for i, a in enumerate(convergence):
        for b in convergence[i + 1:]:
            if a["quantity"] != b["quantity"] or None in (
                    a["uncertainty"], b["uncertainty"]):
                continue
            apart = abs(a["reference"] - b["reference"])
            # within round-off the data cannot tell (a linear run, equal
            # to 2e-16 with rhs varied, was named; a reviewer's)
            floor = max(a.get("roundoff", ROUNDOFF),
                        b.get("roundoff", ROUNDOFF))
            if apart > a["uncertainty"] + b["uncertainty"] + floor * max(
                    abs(a["reference"]), abs(b["reference"])):
                found.append(dict(
                    quantity=a["quantity"],
                    choices=[a["choices"], b["choices"]],
                    references=[a["reference"], b["reference"]],
                    uncertainties=[a["uncertainty"], b["uncertainty"]],
                    apart=apart / (abs(a["reference"]) or 1.)))
    return found


def _size(r: dict, refined: bool) -> tuple:
    """How fine a case of a group is: its elements, or without
    ``elements`` varied its points (then load steps)."""
    return (r["elements"],) if refined else (r["points"],
                                             r.get("loadsteps", 0))


def _ghost_words(step) -> str:
    return "never on" if not step else "on from step {}".format(step)


def same_stabilisation(members: List[dict], refined: bool, choices: dict):
    """``(alike, words)``: the cases of a group of ``members`` (sharing
    ``choices``) that end with the ghost penalty on where the finest
    case (:func:`_size`) does, off where it is never on there (a row's
    ``ghost_from_step``, :data:`SWITCHES`: ``ghost="auto"`` switches it
    on for the rest of a run), and the words naming every case of the
    group with the step its penalty switched on from, where any differ
    ("" where none does; a case of a study from before the rows recorded
    it is taken as alike).

    The penalty changes the equations: cases that end with it and cases
    without solve different discretisations, and an order fitted across
    them measures the switch, not the grid: a trial's cantilever sagging
    under its weight (cpGIMP, finite deformation, 56, 112 and 224
    elements, the penalty on from steps 2 and 7 on the coarse grids and
    never on the fine one) was fitted the order 0.85 and
    -1.7236 +- 0.0063 m, 0.0078 from the -1.71582 +- 0.00024 that every
    grid gives with ``ghost = 0.1`` (FE: -1.71581); such cases are left
    out of the fit (:func:`analyse`).  Cases that all end with it,
    switched on at different steps, differ in the steps before: named
    in the words, not left out (the cantilever at 14, 28 and 56
    elements, on from steps 2, 5 and 6: the ends moved by 0, 5.8e-4 and
    9.5e-5 m against the penalty on from the start, the extrapolation
    by 2e-4 of its +- 0.014; left out, the data range would have given
    +- 0.82)."""
    step = max(members, key=lambda r: _size(r, refined)).get(
        "ghost_from_step")
    alike = [r for r in members if r.get("ghost_from_step") is None
             or step is None or bool(r["ghost_from_step"]) == bool(step)]
    steps = {r.get("ghost_from_step") for r in members} - {None}
    if len(steps) < 2:
        return alike, ""
    return alike, "; ".join("{}: {}".format(
        "{} elements".format(r["elements"]) if refined else " ".join(
            "{}={}".format(k, r[k]) for k in VARIABLES
            if k in r and k not in choices),
        _ghost_words(r.get("ghost_from_step")))
        for r in sorted(members, key=lambda r: _size(r, refined)))


def same_geometry(scene: Scene, members: List[dict], lines: list):
    """The cases of a group of ``members`` (varied ``elements``) whose grids
    put every feature line (:func:`feature_lines`) that the finest one or
    the scene's own grid has on a grid line on one too, and the words
    naming the others and a line each puts inside a cell ("" where none):
    a coarse grid that puts a footing's edge or the soil's surface inside
    a cell solves another geometry, and a study over 15, 30 and 60
    elements, the 15 such, fitted an order 3.53 and an uncertainty of
    94 N/m that 90 elements missed by 27 times (a user trial)."""
    finest = max(members, key=lambda r: r["elements"])
    off_finest, own = off_grid_lines(scene, finest["elements"], lines), \
        own_lines(scene)
    kept_lines = [line for line in lines
                  if line not in off_finest or line in own]
    fitted, words = [], []
    for r in members:
        off = off_grid_lines(scene, r["elements"], kept_lines)
        if not off:
            fitted.append(r)
            continue
        axis, value, what = off[0]
        words.append("{} elements ({} {} = {:g} inside a cell{})".format(
            r["elements"], what, "xyz"[axis], value,
            "" if len(off) == 1 else ", and {} more".format(len(off) - 1)))
    return fitted, "; ".join(words)


def _number(x, form: str) -> str:
    """``x`` formatted, ``-`` where it is unknown (None or NaN)."""
    return "-" if x is None or x != x else form.format(x)


def report(rows: List[dict], measured: dict, keys: Sequence[str]
           ) -> List[str]:
    """The lines of a study's summary (``skfem-mpm study`` prints them):
    what the error measures, a table of the cases (the ``keys`` varied,
    the first quantity's value, error, uncertainty, wall and CPU seconds,
    points, Newton iterations, factorisations), the fitted rate of the
    error per group where the error has one (a closed form, or a
    reference extrapolated with a credible order; fitted to the cases
    whose grids model the finest one's geometry, the others named: a
    trial's footing study over 10, 20 and 40 elements printed a rate of
    2.95 for standard MPM, its coarse grids putting the soil's surface
    inside cells; none where the values converged to round-off, and
    errors at round-off, :func:`error_floor`, left out of it and named:
    a trial's push, within 2.6e-9 of Coulomb's answer in every case,
    printed a rate 2.93), and per quantity and group its reference and
    uncertainty with, in words, why it was or was not extrapolated.
    :func:`study`'s docstring shows it from Python.

    Parameters
    ----------
    rows
        The cases: what :func:`study` returns, or ``study.json``'s
        ``"rows"``.
    measured
        What :func:`analyse` found over them (``rows.measured`` of what
        :func:`study` returns; ``study.json`` holds its fields beside
        the rows: ``"error"``, ``"convergence"``, ``"disagreements"``).
    keys
        The names varied (``"elements"``, ``"ppc"``, ...), shown as the
        table's first columns in this order; a group's rate is fitted
        over ``"elements"`` where it is one of them.
    """
    lines = ["error: {}{}".format(
        measured["error"]["measures"], "; uncertainty -: against a closed "
        "form the error is measured, not estimated, so it has none (each "
        "quantity's own convergence, below, carries one)"
        if measured["error"].get("closed_form") else "")]
    first = measured["convergence"][0]["quantity"] \
        if measured["convergence"] else None
    if first is not None:
        lines.append("value: {} ({}) of each case".format(
            first, measured["convergence"][0]["unit"]))
    lines.append(" ".join("{:>9}".format(k) for k in keys) +
                 " {:>12} {:>10} {:>11} {:>8} {:>8} {:>8} {:>10} {:>14}"
                 .format("value", "error", "uncertainty", "wall s", "CPU s",
                         "points", "iterations", "factorisations"))
    for r in rows:
        lines.append(" ".join("{:>9}".format(r[k]) for k in keys) + (
            " failed: " + r["failure"] if r["failure"] else
            " {:>12} {:>10} {:>11} {:>8.3f} {:>8} {:>8} {:>10} {:>14}"
            .format(
                _number(r.get("values", {}).get(first), "{:.6g}"),
                _number(r.get("error"), "{:.3e}"),
                _number(r.get("uncertainty"), "{:.3e}"), r["wall_seconds"],
                _number(r.get("cpu_seconds"), "{:.3f}"), r["points"],
                r["newton_iterations"], r.get("factorisations", "-"))))
    if "elements" in keys:
        for mine, members in _groups([r for r in rows if not r["failure"]],
                                     [k for k in keys if k != "elements"]):
            where = ", ".join("{}={}".format(k, v) for k, v in
                              mine.items()) or "all"
            found = [c for c in measured["convergence"]
                     if c["quantity"] == first and c["choices"] == mine]
            # against a closed form the errors are the closed form's, a
            # rate theirs (the review: values agreeing to round-off 1%
            # off the closed form were said converged, with no rate)
            if found and found[0].get("basis") == "round-off" and not \
                    measured["error"].get("closed_form"):
                lines.append("rate of the error {}: none: {} converged to "
                             "round-off (within {}), no rate".format(
                                 where, first, roundoff_is(measured)))
                continue
            if not measured["error"].get("closed_form") and not (
                    found and found[0]["against"] == "richardson"):
                lines.append("rate of the error {}: none (no extrapolation:"
                             " the errors are distances to the finest "
                             "case)".format(where))
                continue
            kept = [r for r in members if not r.get("other_geometry")
                    and not r.get("other_stabilisation")]
            other = [str(r["elements"]) for r in members
                     if r.get("other_geometry")]
            ghost = [str(r["elements"]) for r in members
                     if r.get("other_stabilisation")]
            noise_floor = error_floor(measured, found[0] if found else None)
            errors = above_roundoff([r["error"] for r in kept], noise_floor)
            noise = [str(r["elements"]) for r, e in zip(kept, errors)
                     if e is None and r["error"] is not None
                     and np.isfinite(r["error"])]
            rate = fitted_rate([r["elements"] for r in kept], errors)
            left = "{}{}{}".format(
                "; left out, their grids modelling a geometry other than "
                "the finest one's: {} elements".format(", ".join(other))
                if other else "", "; left out, the ghost penalty switched "
                "on otherwise than on the finest grid: {} elements".format(
                    ", ".join(ghost)) if ghost else "",
                "; left out, their errors round-off (at most {:.2g}, {}): "
                "{} elements".format(noise_floor, roundoff_is(measured),
                                     ", ".join(noise))
                if noise else "")
            if noise and not np.isfinite(rate):
                lines.append("rate of the error {}: none: the errors are "
                             "round-off, no rate{}".format(where, left))
                continue
            if found and not measured["error"].get("closed_form") and \
                    circular(found[0]):
                lines.append(
                    "rate of the error {}: {:.2f}, the observed order of "
                    "the extrapolation the errors are measured against, "
                    "which passes through the three grids ({} elements): "
                    "no independent rate from three grids (a fourth grid "
                    "or a closed form gives one){}".format(
                        where, rate, ", ".join(
                            str(r["elements"]) for r in kept), left))
                continue
            rising = not_falling([r["elements"] for r in kept],
                                 errors)
            floor = levelling_off([r["elements"] for r in kept],
                                  errors, rate)
            lines.append("rate of the error {}: {}{}{}".format(
                where, "none: the errors do not fall with every "
                "refinement ({}; a slope fitted to them, {:.2f}, would "
                "be no rate: the grids are not in the asymptotic range, "
                "or the error is noise)".format(rising, rate) if rising
                else "{:.2f} ({}{})".format(
                    rate, rate_spread([r["elements"] for r in kept],
                                      errors),
                    "; " + floor if floor else "")
                if np.isfinite(rate) else
                "needs two cases with a non-zero error", left,
                model_error(measured, found, kept) if rising else ""))
    for c in measured["convergence"]:
        where = ", ".join("{}={}".format(k, v) for k, v in
                          c["choices"].items())
        lines.append("{}{}: {}{} {} +- {} {}: {}".format(
            c["quantity"], " [" + where + "]" if where else "",
            "its own convergence (the table's errors are against the "
            "closed form), " if measured["error"].get("closed_form")
            else "",
            "extrapolated" if c["against"] == "richardson" else "reference",
            _number(c["reference"], "{:.6g}"),
            _number(c["uncertainty"], "{:.2g}"), c["unit"], c["why"]))
    lines.extend(mixed_stabilisation(measured))
    lines.extend(failed_finest(measured))
    lines.extend(moving_extremes(rows))
    lines.extend(zero_values(rows))
    lines.extend(own_references(measured))
    pairs = measured.get("disagreements", ())
    for d in sorted(pairs, key=lambda d: -d["apart"])[:SHOWN_PAIRS]:
        where = [", ".join("{}={}".format(k, v) for k, v in c.items())
                 for c in d["choices"]]
        lines.append(
            "{} disagrees: [{}] {} +- {} against [{}] {} +- {}, {} "
            "apart, further than their uncertainties: at least one "
            "carries an error its group's varied choices do not change "
            "(points per cell, a penalty, the method) or claims too small "
            "an uncertainty".format(
                d["quantity"], where[0], _number(d["references"][0],
                                                 "{:.6g}"),
                _number(d["uncertainties"][0], "{:.2g}"), where[1],
                _number(d["references"][1], "{:.6g}"),
                _number(d["uncertainties"][1], "{:.2g}"),
                percent(d["apart"])))
    if len(pairs) > SHOWN_PAIRS:
        lines.append("{} more pairs of groups disagree (study.json: "
                     "disagreements)".format(len(pairs) - SHOWN_PAIRS))
    if getattr(rows, "warm_up", None):
        lines.append(warm_up_summary(rows.warm_up))
    return lines


def roundoff_is(measured: dict) -> str:
    """What round-off is in a study's analysis (:func:`analyse`), in
    words (a ``study.json`` from before it said: the arithmetic's)."""
    return measured["error"].get("roundoff_is", roundoff_words())


def error_floor(measured: dict, convergence: Optional[dict]) -> float:
    """The relative error at and below which a group's errors are
    round-off: the analysis' round-off (:func:`analyse`'s
    ``"roundoff"``, :func:`~.convergence.roundoff_floor`); without a
    closed form, where the group's errors are distances to its
    ``convergence``'s reference, that fraction of its largest value over
    the reference (what :func:`~.convergence.self_convergence` makes the
    least error).

    >>> from skfem_mpm.studies.study import error_floor
    >>> measured = {"error": {"closed_form": False, "roundoff": 1e-8}}
    >>> round(error_floor(measured, dict(values=[-24.5, -24.],
    ...                                  reference=-24., roundoff=1e-8)), 11)
    1.021e-08
    """
    floor = measured["error"].get("roundoff", ROUNDOFF)
    if measured["error"].get("closed_form", True) or not convergence or \
            not convergence.get("values") or not convergence["reference"]:
        return floor
    return convergence.get("roundoff", floor) * max(
        abs(v) for v in convergence["values"]) / abs(
            convergence["reference"])


def above_roundoff(errors: Sequence, floor: float) -> list:
    """``errors`` with those at most ``floor`` (:func:`error_floor`,
    with a margin of 1e-9 of it) as ``None``: unknown to a rate, which
    round-off differences do not have (a user trial's push: errors 3e-9,
    4e-10, 5e-11 of mpm at 14, 28, 56 elements, Newton tolerance 1e-9,
    printed the rate 2.93).

    >>> from skfem_mpm.studies.study import above_roundoff
    >>> above_roundoff([3e-9, 2e-6, None, 1e-8], 1e-8)
    [None, 2e-06, None, None]
    """
    return [None if e is None or e <= floor * (1. + 1e-9) else e
            for e in errors]


def moving_extremes(rows: List[dict]) -> List[str]:
    """A warning per quantity that takes an extreme over the points
    (``reduce`` ``"max"``, ``"min"``, ``"max_abs"``, as the default
    largest point displacement) at points of different initial positions
    on the grids of a refinement (``row["extreme_at"]`` of
    :func:`run_case`): each grid holds other points, and the extreme's
    value moves with where they lie, an error first order in the cell
    size that every method shares (a user trial's sagging plate, its tip
    corner point: 1e-2 apart at h = 0.5, the cubic splines' rate 0.95
    where the tip's deflection ``at`` one place converged 10-100 times
    closer), so the errors and rates rank the methods by it.  Names the
    ``--measure`` to use instead, at the finest grid's point.

    >>> rows = [dict(elements=n, failure="", extreme_at={"u": [4 - 1 / n,
    ...              1 - 1 / n]}) for n in (10, 20)]
    >>> print(moving_extremes(rows)[0][:60])
    WARNING: u is taken at a different material point on each gr
    """
    lines = []
    done = [r for r in rows if not r.get("failure") and "elements" in r
            and r.get("extreme_at")]
    for label in sorted({k for r in done for k in r["extreme_at"]}):
        at = [(r["elements"], np.asarray(r["extreme_at"][label]))
              for r in done if label in r["extreme_at"]]
        if len({n for n, _ in at}) < 2:
            continue
        spread = max(np.abs(x - at[0][1]).max() for _, x in at)
        size = max(np.abs(x).max() for _, x in at) or 1.
        if spread <= 1e-9 * size:
            continue
        finest = max(at, key=lambda a: a[0])
        where = ", ".join("{:.4g}".format(v) for v in finest[1])
        # the component that carries the extreme at the finest grid's
        # point: "y" was named in a 1D scene (which has none) and in a
        # 3D column, whose sideways "y" its rollers hold at zero
        carried = [r.get("extreme_component", {}).get(label) for r in done
                   if r["elements"] == finest[0]]
        component = next((c for c in carried if c), "xyz"[len(
            finest[1]) - 1])
        kind = "stress" if len(component) == 2 or component in (
            "mises", "pressure") else "displacement"
        lines.append(
            "WARNING: {} is taken at a different material point on each "
            "grid (on {} elements at x0 = [{}], on {} at [{}]): its value "
            "moves with where the grid's points lie, an error first order "
            "in the cell size that every method shares, so the errors, "
            "rates and ranking measure that; measure the field at one "
            "place instead, e.g. --measure 'quantity=\"{}\", "
            "component=\"{}\", at=[{}]' (a place of the body's surface "
            "such as a tip is extrapolated from the points near it)".format(
                label, min(at, key=lambda a: a[0])[0], ", ".join(
                    "{:.4g}".format(v) for v in min(
                        at, key=lambda a: a[0])[1]),
                finest[0], where, kind, component, where))
    return lines


#: a quantity whose values are all within this fraction of the run's
#: largest value of its kind (:meth:`~skfem_mpm.scenes.quantities.
#: Quantity.scale`) is zero: :func:`zero_values`
ZERO_FRACTION = 1e-9


def zero_values(rows: List[dict]) -> List[str]:
    """A warning per quantity that is zero, or round-off against the
    largest value of its kind in the run (:data:`ZERO_FRACTION`), in
    every case: its convergence then reads "converged to round-off",
    which says nothing of the run's accuracy (a trial's 3D
    column on rollers, its sideways displacement at the top: 0 in every
    case, reported as converged to +- 6.7e-308 m).

    >>> rows = [dict(failure="", values={"u y": v}, scale={"u y": 2.})
    ...         for v in (0., 3e-16)]
    >>> print(zero_values(rows)[0][:75])
    WARNING: u y is zero in every case (largest 3e-16, round-off against the la

    A row read back from an older ``study.json`` has no scale:

    >>> del rows[0]["scale"]
    >>> print(zero_values(rows)[0][36:94])
    largest 3e-16, round-off against the largest 2 of its kind
    """
    lines = []
    done = [r for r in rows if not r.get("failure") and r.get("values")]
    for label in sorted({k for r in done for k in r["values"]}):
        pairs = [(r["values"][label], (r.get("scale") or {}).get(label))
                 for r in done if label in r["values"]]
        if not all(np.isfinite(v) and abs(v) <= ZERO_FRACTION * (s or 0.)
                   for v, s in pairs):
            continue
        largest = max(abs(v) for v, _ in pairs)
        lines.append(
            "WARNING: {} is zero in every case ({}{}): its "
            "convergence and errors say nothing of the runs' accuracy; a "
            "support or symmetry may hold it, measure a component that "
            "carries the load".format(
                label, "largest {:.2g}".format(largest) if largest else
                "exactly 0", ", round-off against the largest {:.3g} "
                "of its kind".format(max(s for _, s in pairs
                                         if s is not None))
                if largest else ""))
    return lines


def own_groups(measured: dict) -> List[dict]:
    """The convergence groups of the error's quantity where there is no
    closed form and more than one group (each its own reference), else
    ``[]``."""
    if measured["error"].get("closed_form", True):
        return []
    groups = [c for c in measured["convergence"]
              if c["quantity"] == measured["error"]["quantity"]]
    return groups if len(groups) > 1 else []


def own_apart(measured: dict) -> Optional[float]:
    """How far apart the references of :func:`own_groups` lie, relative
    to the largest, ``None`` where there are none or they agree to
    round-off (the groups' ``roundoff``): then they are one reference (a
    trial's NOTE said "-24; -24; 0.00% apart" of a push within 2.6e-9
    of Coulomb's in every case)."""
    groups = own_groups(measured)
    if not groups:
        return None
    refs = [c["reference"] for c in groups]
    spread = (max(refs) - min(refs)) / (abs(max(refs, key=abs)) or 1.)
    if spread <= max(c.get("roundoff", ROUNDOFF) for c in groups):
        return None
    return spread


def own_references(measured: dict) -> List[str]:
    """Without a closed form, where the error's quantity has more than
    one group (methods, solvers): a line saying that each group's errors
    are against its own reference, naming them, so that the table and
    the Pareto front of ``error_vs_time.png`` compare distances to
    different values (a user trial: standard MPM's finest grid 0.49%
    off the value every other method agreed on, its errors against
    itself).

    >>> c = [dict(quantity="u", choices={"method": m}, reference=r)
    ...      for m, r in (("mpm", 1.0), ("bspline", 1.01))]
    >>> print(own_references(dict(error=dict(closed_form=False,
    ...     quantity="u"), convergence=c))[0][:58])
    NOTE: without a closed form each group's errors are agains
    """
    spread = own_apart(measured)
    if spread is None:
        return []
    groups = own_groups(measured)
    return ["NOTE: without a closed form each group's errors are against "
            "its own reference ({}; {} apart): the table's errors and "
            "the Pareto front of error_vs_time.png compare each case with "
            "its own group's answer, not with one answer of the "
            "problem".format("; ".join("{}: {}".format(", ".join(
                "{}={}".format(k, v) for k, v in c["choices"].items())
                or "all", _number(c["reference"], "{:.6g}"))
                for c in groups), percent(spread))]


def percent(fraction: float) -> str:
    """``fraction`` as a percentage, with two decimals, or two
    significant digits below 0.01% (a trial's "0.00% apart").

    >>> from skfem_mpm.studies.study import percent
    >>> percent(.02), percent(3.2e-7)
    ('2.00%', '3.2e-05%')
    """
    return "{:.2%}".format(fraction) if abs(fraction) >= 1e-4 else \
        "{:.2g}%".format(100. * fraction)


def mixed_stabilisation(measured: dict) -> List[str]:
    """A warning per group of cases (``choices``) whose runs switched the
    ghost penalty of ``ghost="auto"`` on at different steps, or in some
    and not in others (convergence ``mixed_stabilisation``,
    :func:`same_stabilisation`), with the remedy: the penalty fixed in
    the scene.  Cases that end with it and cases without solve different
    discretisations: no order or extrapolation is fitted across them
    (``stabilisation_left_out``: the reference is that of the cases
    alike, or the data range of all); cases that all end with it are
    fitted, the steps before the switch differing between them.
    :func:`report` prints them and :func:`study` logs them."""
    found, lines = set(), []
    for c in measured.get("convergence", ()):
        key = json.dumps(c["choices"], sort_keys=True)
        if not c.get("mixed_stabilisation") or key in found:
            continue
        found.add(key)
        where = ", ".join("{}={}".format(k, v)
                          for k, v in c["choices"].items()) or "all"
        if not c["cell_sizes"]:         # elements not varied
            what = "the uncertainties rest on the data range of the " \
                "cases, which holds what the switch changes"
        elif c.get("stabilisation_left_out"):
            what = "some cases end with it and some without, different " \
                "discretisations: no order or extrapolation is fitted " \
                "across them ({})".format(
                    "fitted to the cases alike, the others measured "
                    "against it" if c["against"] == "richardson" else
                    "the uncertainties rest on the data range of all, "
                    "which holds the switch")
        else:
            what = "every case ends with it and its order and " \
                "extrapolation are fitted, but the steps before the " \
                "switch differ between the cases, and what that changes " \
                "counts as the grid's"
        lines.append(
            "WARNING: mixed stabilisation [{}]: ghost=\"auto\" switched "
            "the ghost penalty on otherwise from case to case ({}): {}; "
            "for a study, switch the penalty on in the scene for every "
            "case from the start ([solver] ghost = {:g} in small strain, "
            "{:g} in finite deformation: what \"auto\" switches on), not "
            "off (ghost = 0): \"auto\" switched it on where a step failed "
            "without it, and those cases would fail".format(
                where, c["mixed_stabilisation"], what, SMALL_STRAIN_GHOST,
                DEFAULT_GHOST))
    return lines


def _span(values, form: str = "{:.2f}") -> str:
    low, high = min(values), max(values)
    return form.format(low) if form.format(low) == form.format(high) \
        else (form + "-" + form).format(low, high)


def per_process(warm_ups: Sequence[dict], field: str) -> Dict[str, float]:
    """The ``field`` (``"cpu_seconds"``, ``"wall_seconds"``) of the
    warm-ups summed per process."""
    total = {}
    for r in warm_ups:
        total[r["process"]] = total.get(r["process"], 0.) + r[field]
    return total


def warm_up_summary(warm_ups: Sequence[dict]) -> str:
    """One line on a study's warm-ups (:func:`warm_up`): seconds per
    process that ran cases, the solvers warmed up, failures.

    >>> from skfem_mpm.studies.study import warm_up_summary
    >>> warm_up_summary([dict(process="a", solver="auto", cpu_seconds=.8,
    ...     wall_seconds=.9, failure=""), dict(process="a",
    ...     solver="pypardiso", cpu_seconds=.5, wall_seconds=.6,
    ...     failure="")])    # doctest: +NORMALIZE_WHITESPACE
    'warm-up: 1.30 s CPU (1.50 s wall) per process, 1 process, not charged
    to any case (the first load step of the smallest case of each method
    and solver choice, solvers auto, pypardiso)'
    """
    cpu = per_process(warm_ups, "cpu_seconds")
    wall = per_process(warm_ups, "wall_seconds")
    failed = sum(bool(r["failure"]) for r in warm_ups)
    return "warm-up: {} s CPU ({} s wall) per process, {} process{}, not " \
        "charged to any case (the first load step of the smallest case of " \
        "each method and solver choice, solvers {}){}".format(
            _span(cpu.values()), _span(wall.values()), len(cpu),
            "es" if len(cpu) > 1 else "",
            ", ".join(sorted({r["solver"] for r in warm_ups})),
            "; {} failed: their cases carry their process's start".format(
                failed) if failed else "")


def _known(data):
    """``data`` with every NaN (an error nothing could estimate) as
    ``None``: JSON's null, an empty CSV cell."""
    if isinstance(data, dict):
        return {k: _known(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [_known(v) for v in data]
    if isinstance(data, float) and data != data:
        return None
    return data


#: per-quantity fields of a row, and their columns in study.csv
PER_QUANTITY = {"values": "value: ", "relative_errors": "relative error: ",
                "relative_uncertainties": "relative uncertainty: "}
#: a row's per-quantity fields before they said what they are (read back
#: from an older study.json: :func:`analyse` computes them again)
OLD_PER_QUANTITY = ("errors", "uncertainties")


class StudyRows(list):
    """A study's rows (one dict per case), as :func:`study` returns them.

    ``StudyRows(rows, warm_ups, measured)`` keeps ``warm_ups`` as the
    attribute ``warm_up`` (also readable as ``warm_ups``): the records of
    the warm-ups (:func:`warm_up`) that the processes which ran its cases
    ran before them, over every session of the study (``study.json``
    keeps them under ``"warm_up"``), charged to no case; and ``measured``
    as ``measured``: what :func:`analyse` found over the rows (what the
    error measures, each quantity's convergence per group, the
    disagreements; ``study.json`` holds it beside the rows), the second
    argument of :func:`report`."""

    def __init__(self, rows=(), warm_ups=(), measured=None):
        super().__init__(rows)
        self.warm_up = list(warm_ups)
        self.measured = measured

    @property
    def warm_ups(self) -> list:
        """The same list as ``warm_up``."""
        return self.warm_up


#: what study.json keeps of a case and study.csv not: the definitions of
#: its quantities (:func:`measure_key`), long text read on resume only
NOT_IN_CSV = ("measures",)


def _cell(value):
    """A value of study.csv: a table or list (``extreme_at``,
    ``extreme_component``, ``scale``) as JSON text, which any reader
    parses, not Python's repr of it."""
    if isinstance(value, (dict, list, tuple)):
        return json.dumps(value, sort_keys=True)
    return value


def _write(outdir: Path, rows: List[dict], workers: int, measured: dict,
           warm_ups: Sequence[dict] = ()):
    rows = _known(rows)
    with atomic_path(outdir / "study.json") as tmp:
        Path(tmp).write_text(json.dumps(dict(
            workers=workers, rows=rows, **_known(measured),
            warm_up=_known(list(warm_ups))), indent=1))
    flat = [{**{k: _cell(v) for k, v in r.items()
                if k not in PER_QUANTITY and k not in NOT_IN_CSV},
             **{prefix + k: v for field, prefix in PER_QUANTITY.items()
                for k, v in r.get(field, {}).items()}}
            for r in rows]
    columns = sorted({k for r in flat for k in r})
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns)
    writer.writeheader()
    writer.writerows(flat)
    with atomic_path(outdir / "study.csv") as tmp:
        Path(tmp).write_text(text.getvalue())


def study(scene: Scene, vary: Dict[str, Sequence], outdir,
          scheduler: Optional[str] = None, workers: int = 0,
          progress: bool = True, quantities=None,
          warm_from: Optional[List[dict]] = None,
          warn: bool = True, scene_file=None) -> "StudyRows":
    """Run every combination of ``vary``, measure the quantities of
    interest and the errors (:func:`analyse`), and record it in
    ``outdir``.

    Each process that runs cases (this one, or each Dask worker) warms
    up before the first case of each method and solver choice it meets
    (:func:`warm_up`: the first load step of the smallest case of those
    choices, with each linear solver the case may take), untimed: a
    case's times hold what it costs, whatever ran before it in its
    process, and not the process's one-off start (numba's kernels loaded
    from its cache, Pardiso's first factorisation: 0.6-1.5 s, 10-20 times
    a small case).  The warm-ups' times are in ``study.json`` under
    ``"warm_up"``, in the returned rows' ``warm_up`` and in
    :func:`report`'s last line.  In a serial study the package's
    warnings are said once each (:func:`~skfem_mpm.repeats.warnings_once`):
    the quantities' check, each warm-up and each case seed the points,
    and a trial's study of 12 cases said a polygon's seeding warning 14
    times.

    Parameters
    ----------
    scene
        The base scene.
    vary
        Lists of values for any of ``elements``, ``ppc``, ``loadsteps``,
        ``method``, ``rhs`` (``"residual"``, ``"increment"``: the
        right-hand side of linear steps, :func:`~skfem_mpm.simulate`),
        ``line_search`` (``"backtracking"``, ``"armijo"``, ``"none"``) and
        ``newton`` (``"full"``, ``"modified"``).
    outdir
        Folder of ``study.json`` / ``study.csv`` (and the plots).
    scheduler, workers
        Dask: a scheduler address, or a local cluster of ``workers``
        processes (at most one per core: :func:`worker_count`; one thread
        each); both unset: serial.
    quantities
        :class:`~skfem_mpm.scenes.quantities.Quantity` list; default the
        scene's ``outputs``, or the largest point displacement (a
        footing scene's: its peak footing pressure).
    warm_from
        The cases whose smallest of a case's choices warms a process up
        for it (default: those of ``vary``; :func:`estimate` gives all
        the cases of the study it times).
    warn
        Log the warnings of :func:`warn_mixed` at the end (:func:`estimate`
        runs its timing cases without: the study after them warns, and a
        serial study's warning was logged twice before its report).
    scene_file
        The file ``scene`` was read from, unchanged since
        (``skfem-mpm study`` gives it): the cases record its settings'
        digest (:func:`scene_file_sha256`) and a resume compares those;
        without it the scene's as Python holds it
        (:func:`scene_sha256`), which sees every default and functions by
        their names only.

    Returns
    -------
    rows
        :class:`StudyRows`: one dict per case (finished ones read back on
        resume, unless they lack a value of ``quantities`` or recorded
        another definition of one: those run again; cases of another
        scene are refused, :func:`finished_rows`), with ``values`` and ``relative_errors`` per quantity and
        the headline ``error``; its ``warm_up`` lists the warm-ups.
        Groups whose cases switched the ghost penalty on otherwise are
        warned (:func:`mixed_stabilisation`).

    Examples
    --------
    >>> import tempfile
    >>> from skfem_mpm.scenes.scene_file import EMBEDDED, load_scene
    >>> from skfem_mpm.studies.study import study
    >>> rows = study(load_scene(EMBEDDED), {"elements": [4, 8],
    ...              "loadsteps": [1]}, tempfile.mkdtemp(), progress=False)
    >>> [round(r["error"], 6) for r in rows]
    [0.0625, 0.03125]
    >>> [round(r["values"]["largest point displacement"], 6) for r in rows]
    [0.984375, 0.996094]

    It prints nothing: the summary ``skfem-mpm study`` prints is
    :func:`report`'s lines, of the rows, what was measured over them
    (``rows.measured``) and the names varied, the table's first columns:

    >>> from skfem_mpm.studies.study import report
    >>> lines = report(rows, rows.measured, ["elements", "loadsteps"])
    >>> rows.warm_ups is rows.warm_up   # the warm-ups, under either name
    True
    >>> print("\\n".join(lines[1:5]))  # doctest: +ELLIPSIS
    value: largest point displacement (m) of each case
     elements loadsteps        value      error uncertainty   wall s ...
            4         1     0.984375  6.250e-02           -    ...
            8         1     0.996094  3.125e-02           -    ...

    """
    with warnings_once():
        return _study(scene, vary, outdir, scheduler, workers, progress,
                      quantities, warm_from, warn, scene_file)


def _study(scene: Scene, vary: Dict[str, Sequence], outdir,
           scheduler: Optional[str], workers: int, progress: bool,
           quantities, warm_from: Optional[List[dict]],
           warn: bool, scene_file=None) -> "StudyRows":
    """:func:`study`'s work."""
    check_vary(vary, scene)
    check_reference(scene)
    if scheduler is None and workers:
        workers = worker_count(workers)
    quantities = list(quantities or scene_quantities(scene))
    check_quantities(scene, quantities, build_points(
        scene, scene.grid.build()[0]))
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    cases = cases_of(vary)
    rows = finished_rows(outdir, quantities, scene, scene_file)
    digest = dict(scene_sha256=scene_sha256(scene))
    if scene_file is not None:
        digest.update(scene_file_sha256=scene_file_sha256(scene_file))
    measures = {q.label: measure_key(q) for q in quantities}
    warm_ups = finished_warm_ups(outdir)
    done = {_key(r) for r in rows}
    todo = [c for c in cases if _key(c) not in done]
    logger.info("%d cases, %d already done", len(cases),
                len(cases) - len(todo))
    smallest = smallest_cases(scene, warm_from or cases)

    def add(row, records):
        row.update(digest, measures=measures)
        rows.append(row)
        warm_ups.extend(records)
        for r in records:
            logger.info("warm-up on %s for %s with solver %s: %.2f s CPU, "
                        "not charged to any case", r["process"],
                        _key(r["choices"]), r["solver"], r["cpu_seconds"])
    if scheduler is None and not workers:
        work = {_key(c): case_work(scene, c) for c in todo} \
            if progress else {}
        for k, params in enumerate(todo):
            add(*warm_case(scene, params, quantities, smallest(params)))
            _write(outdir, _in_case_order(rows, cases), 1,
                   analyse(scene, rows, quantities), warm_ups)
            if progress:
                line = "case {}/{} {}{}".format(
                    k + 1, len(todo), _key(params),
                    time_left(rows, work, todo[k + 1:]))
                if sys.stderr.isatty():
                    sys.stderr.write("\r" + line)
                else:
                    logger.info(line)
        if progress and sys.stderr.isatty():
            sys.stderr.write("\n")
        measured = warn_mixed(analyse(scene, rows, quantities), rows, warn)
        _write(outdir, _in_case_order(rows, cases), 1, measured, warm_ups)
        return StudyRows(_ordered(rows, cases), warm_ups, measured)
    import dask
    from dask.distributed import Client, LocalCluster, as_completed
    if not logger.isEnabledFor(logging.INFO):
        logging.getLogger("distributed").setLevel(logging.ERROR)
    cluster = None
    if scheduler is None:
        # set before each worker process starts, so before it imports
        # numpy; no profiler thread taking CPU time beside the case
        spawn = "distributed.nanny.pre-spawn-environ"
        with dask.config.set({spawn: dict(dask.config.get(spawn, {}),
                                          **ONE_THREAD),
                              "distributed.worker.profile.enabled": False}):
            cluster = LocalCluster(
                n_workers=workers, threads_per_worker=1,
                processes=True, host="127.0.0.1",
                dashboard_address="127.0.0.1:0")
    with Client(scheduler or cluster) as client:
        nworkers = len(client.scheduler_info()["workers"])
        futures = [client.submit(warm_case, scene, params, quantities,
                                 smallest(params), pure=False)
                   for params in todo]
        for future in as_completed(futures):
            add(*future.result())
            _write(outdir, _in_case_order(rows, cases), nworkers,
                   analyse(scene, rows, quantities), warm_ups)
        measured = warn_mixed(analyse(scene, rows, quantities), rows,
                              warn)
        _write(outdir, _in_case_order(rows, cases), nworkers, measured,
               warm_ups)
    if cluster is not None:
        cluster.close()
    return StudyRows(_ordered(rows, cases), warm_ups, measured)


def warn_mixed(measured: dict, rows: List[dict], warn: bool = True
               ) -> dict:
    """Log (if ``warn``) the warnings of :func:`mixed_stabilisation`,
    :func:`moving_extremes` and :func:`zero_values`, and one
    where cases read back from an older ``study.json`` do not say whether
    the ghost penalty switched on in them; returns ``measured``."""
    if not warn:
        return measured
    for line in mixed_stabilisation(measured) + failed_finest(measured) \
            + moving_extremes(rows) + zero_values(rows):
        logger.warning("%s", line[len("WARNING: "):])
    unknown = [r for r in rows if not r["failure"]
               and "ghost_from_step" not in r]
    if unknown:
        logger.warning(
            "%d case%s read back from study.json, run before it recorded "
            "ghost_from_step: whether ghost=\"auto\" switched the ghost "
            "penalty on in them is unknown and not compared; a study in a "
            "new --out folder records it", len(unknown),
            "s" if len(unknown) > 1 else "")
    return measured


def default_vary(scene: Scene) -> Dict[str, list]:
    """What a study of ``scene`` varies when told nothing:
    :data:`DEFAULT_VARY`, with the ``elements`` of
    :func:`default_elements` and without ``loadsteps`` for a dynamic
    scene (its steps are its time steps)."""
    vary = {name: list(values) for name, values in DEFAULT_VARY.items()
            if not (name == "loadsteps" and scene.dynamics is not None)}
    if "elements" in vary:
        vary["elements"] = default_elements(scene)
    return vary


def default_elements(scene: Scene) -> List[int]:
    """The ``elements`` a default study of ``scene`` runs: those of
    :data:`DEFAULT_VARY` (4 to 256, doubling) where they scale every axis
    of its grid to whole cells (:func:`refine`) and keep its feature
    lines where its own grid has them (:func:`geometry_step`), else the
    doubling series from the least multiple of :func:`geometry_step` from
    4 up to 256,
    three values at least: 23, 46, 92, 184 on the 22 x 23 cells of
    ``examples/cantilever.toml`` (4 to 256 rounded its cells to other
    shapes and put the beam's faces inside cells on every grid).

    >>> from skfem_mpm.scenes.scene import Grid, Scene
    >>> grid = Grid(axes=[(0., 11., 22), (-9.5, 2., 23)])
    >>> default_elements(Scene(grid=grid, bodies=[]))
    [23, 46, 92, 184]
    """
    values = DEFAULT_VARY["elements"]
    step = geometry_step(scene)
    if all(v % step == 0 for v in values):
        return list(values)
    first, last = min(values), max(values)
    out = [step * -(-first // step)]
    while out[-1] * 2 <= last or len(out) < 3:
        out.append(out[-1] * 2)
    return out


def check_vary(vary: Dict[str, Sequence], scene: Optional[Scene] = None):
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` unless every
    name of ``vary`` is one of :data:`VARIABLES` with distinct, possible
    values, and (given the ``scene``) one the scene has: a dynamic scene
    takes its steps from its time step, and each case of ``loadsteps``
    failed, refused by the scene's check (a user trial); ``elements``
    that do not scale every axis of its grid to whole cells are refused
    with :func:`not_whole`'s words (:func:`refine`), and ``elements`` of
    which none keeps the scene's geometry with :func:`lost_lines`'s;
    choices the scene refuses with :func:`refused_choices`'s."""
    if scene is not None and scene.dynamics is not None and \
            "loadsteps" in vary:
        raise InvalidInputError(
            "cannot vary loadsteps in a dynamic scene: it takes its steps "
            "from [dynamics] (duration / time_step); vary elements, ppc or "
            "method, and the time step in the scene itself")
    for name, values in vary.items():
        if name not in VARIABLES:
            raise InvalidInputError(not_a_variable(name))
        if not len(values):
            raise InvalidInputError("--vary {} has no value".format(name))
        if name in CHOICES and not set(values) <= set(CHOICES[name]):
            raise InvalidInputError("{} must be among {}, got {}".format(
                name, CHOICES[name], list(values)))
        if name not in CHOICES and not all(int(v) == v and v >= 1
                                        for v in values):
            raise InvalidInputError("{} must be positive integers, got {}"
                                    .format(name, list(values)))
        if len(set(values)) != len(values):
            raise InvalidInputError("--vary {} repeats a value: {}".format(
                name, list(values)))
    if scene is not None:
        refused_choices(scene, vary)
    if scene is not None and "elements" in vary:
        why = not_whole(scene, [int(v) for v in vary["elements"]]) or \
            lost_lines(scene, [int(v) for v in vary["elements"]])
        if why:
            raise InvalidInputError(why)


#: names a user may mean for a dynamic scene's time step
TIME_STEP_NAMES = ("time_step", "dt", "timestep", "time-step", "duration")


def not_a_variable(name: str) -> str:
    """The words refusing ``--vary NAME`` of a name not among
    :data:`VARIABLES` (checked before its values: a trial's
    ``--vary time_step=0.1,0.05`` was told "values must be integers"),
    with how to study a dynamic scene's time step, which no study
    varies.

    >>> from skfem_mpm.studies.study import not_a_variable
    >>> not_a_variable("element")[:60]
    "cannot vary 'element': choose from elements, ppc, loadsteps,"
    """
    from ..spelling import did_you_mean
    words = "cannot vary {!r}: choose from {}{}".format(
        name, ", ".join(VARIABLES), did_you_mean(name, VARIABLES))
    if name.lower() in TIME_STEP_NAMES:
        words += "; a dynamic scene's time step is its [dynamics] " \
            "time_step, which a study does not vary: study (or run) one " \
            "copy of the scene file per time step, each with --out of " \
            "its own, and compare their quantities (halving the step " \
            "until they agree)"
    return words


def refused_choices(scene: Scene, vary: Dict[str, Sequence]) -> None:
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` if the scene's
    check (:meth:`~skfem_mpm.scenes.scene.Scene.check`) refuses a
    combination of the values of ``vary`` named by words (method, rhs,
    line_search, newton), naming the values and the scene's reason: each
    such case would fail after the others had run (a trial's study over
    ``method=mpm,cpgimp`` of a scene with a rigid body ran every cpGIMP
    case to the same refusal)."""
    chosen = {name: values for name, values in vary.items()
              if name in CHOICES}
    for case in cases_of(chosen):
        try:
            configure(scene, case).check()
        except InvalidInputError as err:
            raise InvalidInputError(
                "cannot vary {}: the scene refuses {}: {}; leave {} out"
                .format(" and ".join(chosen), ", ".join(
                    "{}={!r}".format(*kv) for kv in case.items()), err,
                        "it" if len(case) == 1 else "one of them")) from err


def cases_of(vary: Dict[str, Sequence]) -> List[dict]:
    """Every combination of the values of ``vary``, one dict a case."""
    names = list(vary)
    return [dict(zip(names, combo))
            for combo in itertools.product(*(vary[n] for n in names))]


#: the study.json files of cases without a scene digest warned of
UNCHECKED = set()


def finished_rows(outdir, quantities, scene: Optional[Scene] = None,
                  scene_file=None) -> List[dict]:
    """The cases ``study.json`` in ``outdir`` holds that need not run
    again: failed ones, and those with a value of every quantity as
    ``quantities`` define it (a case that recorded another definition of
    a quantity's label, :func:`measure_key`, runs again).  Given the
    ``scene``, raise :class:`~skfem_mpm.errors.InvalidInputError` if a
    case there was run on another scene: its numbers are not this
    scene's.  A case run on a scene file compares that file's settings
    (:func:`scene_file_sha256`) where ``scene_file`` is given, else the
    scene as Python holds it (:func:`scene_sha256`: every default
    included).  Cases run before the digest was recorded cannot be told
    apart: a warning says so."""
    path = Path(outdir) / "study.json"
    if not path.exists():
        return []
    rows = json.loads(path.read_text())["rows"]
    if scene is not None:
        digest = scene_sha256(scene)
        text = None if scene_file is None else scene_file_sha256(
            scene_file)

        def kind(r):
            """The digest a case is compared by."""
            return "scene_file_sha256" if text is not None and \
                "scene_file_sha256" in r else "scene_sha256"
        ours = dict(scene_sha256=digest, scene_file_sha256=text)
        other = [r for r in rows
                 if r.get(kind(r), ours[kind(r)]) != ours[kind(r)]]
        if other:
            first = kind(other[0])
            raise InvalidInputError(
                "{}: {} of its {} case{} ran on another scene ({}: {}), "
                "and a study resumed there would read their numbers back "
                "as this scene's; study into another --out folder, or "
                "delete {} to run the cases again".format(
                    path, len(other), len(rows),
                    "s" if len(rows) > 1 else "",
                    "SHA-256 of the scene file's settings but its outputs "
                    "{}..., {}'s {}...".format(
                        other[0][first][:12], scene_file, text[:12])
                    if first == "scene_file_sha256" else
                    "SHA-256 of the scene's content but its outputs "
                    "{}..., this scene's {}...".format(
                        other[0][first][:12], digest[:12]),
                    "its material, loads, steps, name, solver or another "
                    "setting differs" if first == "scene_file_sha256" else
                    SCENE_SEEN + ("" if scene_file is None else
                                  " (the case{} recorded no digest of a "
                                  "scene file: run before studies "
                                  "recorded one)".format(
                                      "s" if len(other) > 1 else "")),
                    path))
        unknown = [r for r in rows if "scene_sha256" not in r]
        if unknown and str(path) not in UNCHECKED:
            UNCHECKED.add(str(path))
            logger.warning(
                "%s: %d case%s ran before studies recorded their scene: "
                "read back as this scene's, unchecked (delete the file "
                "if the scene changed since)", path, len(unknown),
                "s" if len(unknown) > 1 else "")
    labels = {q.label: measure_key(q) for q in quantities}

    def same(r):
        kept = r.get("measures", {})
        return all(kept.get(label, key) == key
                   for label, key in labels.items())
    rows = [r for r in rows if r["failure"] or (
        set(labels) <= set(r.get("values", ())) and same(r))]
    for r in rows:
        for name in OLD_PER_QUANTITY:
            r.pop(name, None)
    return rows


def finished_warm_ups(outdir) -> List[dict]:
    """The warm-ups (:func:`warm_up`) ``study.json`` in ``outdir``
    records, from the sessions that ran its cases before."""
    path = Path(outdir) / "study.json"
    if not path.exists():
        return []
    return list(json.loads(path.read_text()).get("warm_up", []))


def smallest_cases(scene: Scene, cases: List[dict]):
    """``smallest(params)``: of ``cases``, the smallest by
    :func:`case_work` with the :func:`choices_of` of ``params`` (``params``
    itself if none has them)."""
    work = {_key(c): case_work(scene, c) for c in cases}

    def smallest(params):
        mine = [c for c in cases
                if choices_of(c) == choices_of(params)] or [params]
        return min(mine, key=lambda c: work.get(_key(c), 0.))
    return smallest


#: without ``--vary``, ``skfem-mpm study`` starts more cases than this only
#: when told to (``--all``)
CASES_UNASKED = 20


def case_work(scene: Scene, params: dict) -> float:
    """The size of a case for an estimate of its time: an upper bound of
    its points (:func:`~skfem_mpm.scenes.scene.point_bound`, seeding
    nothing) times its steps."""
    case = configure(scene, params)
    return point_bound(case) * case.step_count


def time_model(measured) -> Optional[tuple]:
    """``(a, b)`` of ``seconds = a + b * work`` through the smallest and
    the largest of the ``measured`` ``(work, seconds)`` pairs (a rough,
    linear model: Newton iterations differ from case to case, and the
    solves of large grids grow faster than their points), or ``None``
    with nothing measured.

    >>> from skfem_mpm.studies.study import time_model
    >>> time_model([(10., .1)]), time_model([(10., .2), (110., 1.2)])
    ((0.0, 0.01), (0.1, 0.01))
    """
    measured = sorted((w, t) for w, t in measured if w > 0 and t > 0)
    if not measured:
        return None
    (w0, t0), (w1, t1) = measured[0], measured[-1]
    slope = (t1 - t0) / (w1 - w0) if w1 > w0 else 0.
    if slope <= 0:
        return 0., t1 / w1
    return max(t0 - slope * w0, 0.), slope


def clock(seconds: float) -> str:
    """``m:ss`` (``h:mm:ss`` from an hour on) of a duration.

    >>> from skfem_mpm.studies.study import clock
    >>> clock(75.4), clock(3725)
    ('1:15', '1:02:05')
    """
    m, sec = divmod(int(round(seconds)), 60)
    h, m = divmod(m, 60)
    return "{}:{:02d}:{:02d}".format(h, m, sec) if h else \
        "{}:{:02d}".format(m, sec)


def time_left(rows: List[dict], work: Dict[str, float],
              left: List[dict]) -> str:
    """A serial study's progress: the time the cases ``left`` take by
    the :func:`time_model` of the finished ``rows`` among those whose
    size ``work`` gives (keyed by :func:`_key`), in words ("" with none
    left or nothing measured).  Refitted as cases finish, it rests on
    ever larger cases: the estimate before the start, from small ones,
    was 4 times low for a user trial's largest case (1:28 for 5:41).

    >>> from skfem_mpm.studies.study import time_left
    >>> from skfem_mpm.studies.study import _key
    >>> rows = [dict(elements=n, wall_seconds=t, failure="")
    ...         for n, t in [(4, 1.), (8, 4.)]]
    >>> work = {_key(dict(elements=n)): n * n for n in (4, 8, 16)}
    >>> time_left(rows, work, [dict(elements=16)])
    '; about 0:16 left'
    """
    model = time_model([(work[_key(r)], r["wall_seconds"]) for r in rows
                        if _key(r) in work and not r["failure"]])
    if not left or model is None:
        return ""
    return "; about {} left".format(clock(sum(
        model[0] + model[1] * work[_key(c)] for c in left)))


def estimate(scene: Scene, cases: List[dict], outdir, quantities,
             budget: float = 2., scene_file=None) -> dict:
    """What a study of ``cases`` in ``outdir`` would take: ``cases``,
    ``done`` (finished before), ``ran`` (run now to time them), ``left``,
    the ``largest`` case's point bound and steps, the ``model`` of
    :func:`time_model` and the ``seconds`` the ``left`` cases would take
    by it (serially; ``None`` when nothing could be measured), and
    ``warm_up``: the most wall seconds a process of the study spent on
    its warm-ups (:func:`warm_up`) so far, ``None`` before any.  The model
    rests on the cases finished before and, where they do not span a
    ratio of 4 in size, on small unfinished cases run first (kept in
    ``study.json`` like any case, never run again): the smallest that
    succeeds (trying for ``budget`` seconds), then the largest that the
    first one's pace puts under ``budget`` seconds.  Like the cases'
    times it leaves the warm-ups out: each process that runs cases adds
    its own (for a serial study run after the estimate, in the same
    process, only those of choices and solvers not yet warmed up).
    ``scene_file``: as :func:`study`'s."""
    quantities = list(quantities or scene_quantities(scene))
    rows = {_key(r): r for r in finished_rows(outdir, quantities, scene,
                                              scene_file)}
    work = {_key(c): case_work(scene, c) for c in cases}
    measured = [(work[k], r["wall_seconds"]) for k, r in rows.items()
                if k in work and not r["failure"]]
    todo = sorted((c for c in cases if _key(c) not in rows),
                  key=lambda c: work[_key(c)])

    def spread():
        sizes = [w for w, _ in measured]
        return len(sizes) > 1 and max(sizes) >= 4 * min(sizes)

    def run_first(params):
        row = study(scene, {k: [v] for k, v in params.items()}, outdir,
                    progress=False, quantities=quantities,
                    warm_from=cases, warn=False, scene_file=scene_file)[0]
        todo.remove(params)
        if not row["failure"]:
            measured.append((work[_key(params)], row["wall_seconds"]))
        return row
    tic = time.perf_counter()
    for params in list(todo):                   # the smallest that runs
        if measured or time.perf_counter() - tic > budget:
            break
        run_first(params)
    model = time_model(measured)
    if model is not None and not spread():
        small = min(w for w, _ in measured)
        fits = [c for c in todo if work[_key(c)] >= 4 * small
                and model[0] + model[1] * work[_key(c)] <= budget]
        if fits:
            run_first(fits[-1])
            model = time_model(measured)
    largest = max(cases, key=lambda c: work[_key(c)])
    case = configure(scene, largest)
    done = sum(_key(c) in rows for c in cases)
    warm = per_process(finished_warm_ups(outdir), "wall_seconds")
    return dict(cases=len(cases), done=done,
                ran=len(cases) - done - len(todo), left=len(todo),
                largest=(point_bound(case), case.step_count), model=model,
                seconds=None if model is None else sum(
                    model[0] + model[1] * work[_key(c)] for c in todo),
                warm_up=max(warm.values()) if warm else None)


#: a local cluster's workers each compute on one thread
ONE_THREAD = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1,
              "OPENBLAS_NUM_THREADS": 1, "NUMBA_NUM_THREADS": 1}


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                      # not on Linux
        return os.cpu_count() or 1


def worker_count(workers: int) -> int:
    """``workers`` local worker processes, capped at the :func:`cores`
    (with a warning): more workers than cores take turns on them and
    stretch every case's wall and CPU time.

    >>> from skfem_mpm.studies.study import cores, worker_count
    >>> worker_count(1), worker_count(cores() + 1) == cores()
    (1, True)
    """
    if workers < 1:
        raise InvalidInputError("--workers must be at least 1, got {}"
                                .format(workers))
    available = cores()
    if workers > available:
        logger.warning(
            "--workers %d capped to %d: this process may use %d cores, and "
            "more workers than cores would share them and stretch every "
            "case's time", workers, available, available)
    return min(workers, available)


def _ordered(rows: List[dict], cases: List[dict]) -> List[dict]:
    by_key = {_key(r): r for r in rows}
    return [by_key[_key(c)] for c in cases if _key(c) in by_key]


def _in_case_order(rows: List[dict], cases: List[dict]) -> List[dict]:
    """``rows`` in the order of ``cases``, those of no case (read back
    from an earlier ``study.json``) after them as they were: what
    ``study.json`` holds, whatever order the cases finished in (a
    study's file listed 14, 56, 28 elements in one run of the slow
    suite)."""
    place = {_key(c): k for k, c in enumerate(cases)}
    return sorted(rows, key=lambda r: place.get(_key(r), len(cases)))


def not_falling(x, y) -> str:
    """Where the errors ``y`` (finite, positive entries; others left out)
    do not fall as ``x`` grows, in words (the pairs of elements and
    errors, in order of ``x``), else ``""``: a rate fitted over them is
    no rate (a user trial's footing: 17.1%, 8.2%, 9.2% at 8, 16 and 32
    elements printed "rate of the error all: 0.44").

    >>> from skfem_mpm.studies.study import not_falling
    >>> not_falling([8, 16, 32], [.171, .0817, .0924])
    'errors 1.71e-01, 8.17e-02, 9.24e-02 at 8, 16, 32 elements'
    >>> not_falling([4, 8, 16], [.1, .025, None])
    ''
    """
    x = np.asarray(x, float)
    y = np.array([np.nan if v is None else v for v in y], float)
    ok = np.isfinite(y) & (y > 0)
    order = np.argsort(x[ok], kind="stable")
    xs, ys = x[ok][order], y[ok][order]
    if ys.size < 2 or (np.diff(ys) < 0).all():
        return ""
    return "errors {} at {} elements".format(
        ", ".join("{:.2e}".format(v) for v in ys),
        ", ".join("{:g}".format(v) for v in xs))


def levelling_off(x, y, rate: float) -> str:
    """Where the last refinement of three or more cases with errors ``y``
    at ``x`` has a local rate below half the fitted ``rate``, in words,
    else ``""``: a rate fitted over them hides a floor (a user trial's
    averaged splines on the column, 1.06e-4 at 48 elements and 1.03e-4 at
    96, local rate 0.05, printed only "rate 1.57").

    >>> from skfem_mpm.studies.study import levelling_off
    >>> levelling_off([24, 48, 96], [4e-4, 1.06e-4, 1.03e-4], 1.0)[:48]
    'the last refinement (48 to 96 elements) has a lo'
    >>> levelling_off([24, 48, 96], [4e-4, 1e-4, 2.5e-5], 2.0)
    ''
    """
    x = np.asarray(x, float)
    y = np.array([np.nan if v is None else v for v in y], float)
    ok = np.isfinite(y) & (y > 0)
    order = np.argsort(x[ok], kind="stable")
    xs, ys = x[ok][order], y[ok][order]
    if ys.size < 3 or not rate > 0:
        return ""
    last = float(np.log(ys[-2] / ys[-1]) / np.log(xs[-1] / xs[-2]))
    if last >= rate / 2:
        return ""
    return ("the last refinement ({:g} to {:g} elements) has a local rate "
            "of {:.2f} (errors {:.3e} to {:.3e}): the errors level off "
            "there, a floor the fitted rate does not show".format(
                xs[-2], xs[-1], last, ys[-2], ys[-1]))


def rate_spread(x, y) -> str:
    """Which cases a rate of the errors ``y`` at ``x`` elements
    (:func:`fitted_rate`) was fitted on, the standard error of that
    least-squares slope and the local rates between successive grids with
    their range, in words: a trial's "rate 1.70" for cpGIMP on a column
    came with no range, though its local rates ran 1.41 to 2.03.

    >>> from skfem_mpm.studies.study import rate_spread
    >>> print(rate_spread([8, 16, 32, 64], [.1, .025, .01, .0025]))
    ... # doctest: +NORMALIZE_WHITESPACE
    least squares over 8, 16, 32, 64 elements, the cases with a non-zero
    error; standard error 0.10; local rates 2.00, 1.32, 2.00 (range
    1.32-2.00)
    >>> rate_spread([4, 8, 16], [.1, .025, None])
    'least squares over 4, 8 elements, the cases with a non-zero error'
    """
    x = np.asarray(x, float)
    y = np.array([np.nan if v is None else v for v in y], float)
    ok = np.isfinite(y) & (y > 0)
    order = np.argsort(x[ok], kind="stable")
    xs, ys = x[ok][order], y[ok][order]
    words = "least squares over {} elements, the cases with a non-zero " \
        "error".format(", ".join("{:g}".format(v) for v in xs))
    if xs.size < 3:
        return words
    lx, ly = np.log(xs), np.log(ys)
    slope, cut = np.polyfit(lx, ly, 1)
    residual = ly - (slope * lx + cut)
    error = float(np.sqrt(residual @ residual / (xs.size - 2) /
                          ((lx - lx.mean()) @ (lx - lx.mean()))))
    local = -np.diff(ly) / np.diff(lx)
    return "{}; standard error {:.2f}; local rates {} (range {:.2f}-" \
        "{:.2f})".format(words, error, ", ".join(
            "{:.2f}".format(v) for v in local), local.min(), local.max())


def fitted_rate(x, y) -> float:
    """Slope of -log(y) against log(x) (finite, positive entries; None is
    unknown), rounded to 1e-12 so that equal errors give 0, not -0.

    >>> from skfem_mpm.studies.study import fitted_rate
    >>> fitted_rate([4, 8, 16], [.1, .025, None])
    2.0
    >>> fitted_rate([4, 8], [.1, .1])
    0.0
    """
    x = np.asarray(x, float)
    y = np.array([np.nan if v is None else v for v in y], float)
    ok = np.isfinite(y) & (y > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.round(-np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0],
                          12)) + 0.
