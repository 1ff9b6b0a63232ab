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
extrapolation where the fit is credible, else the data range of the
group; every case's value carries an uncertainty (``uncertainties``, the
first quantity's as ``uncertainty``), never zero.  Every quantity's
observed order, reference, uncertainty and the reason, in words, why it
was or was not extrapolated are written to ``study.json`` under
``"convergence"``, with what the error measures under ``"error"``.

Cases are independent: they run serially (with a progress line) or on a
Dask cluster (``dask.distributed``, an optional extra: a local cluster or
``scheduler=ADDRESS``).  A local cluster has at most one worker per core
(more are capped, with a warning) and each worker one thread (OpenMP,
MKL and OpenBLAS limited to one before the worker imports numpy).  Every
case records its wall time and its CPU time (``time.process_time`` of the
process that ran it): workers that share cores, memory bandwidth or the
machine with the study's own process stretch wall times, not CPU times,
so compare CPU times across serial and parallel studies.  Results are
appended per case, atomically, to ``study.json`` and ``study.csv``; an
interrupted study resumes without re-running finished cases.
:func:`estimate` puts a rough time on the cases before they start (from
the cases finished before, or from the smallest ones, run first), which
``skfem-mpm study`` prints.

"""
import csv
import io
import itertools
import json
import logging
import os
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..errors import InvalidInputError, MPMError
from ..scenes.io import atomic_path
from ..scenes.quantities import Quantity, check_quantities
from ..scenes.scene import (METHODS, Grid, Scene, build_points,
                             point_bound, run_scene)
from ..solve.newton import LINE_SEARCHES, NEWTON, RHS
from ..solve.results import PHASES
from .column import SOURCE, column_error, column_extent
from .convergence import from_data_range, self_convergence

logger = logging.getLogger(__name__)

__all__ = ["study", "refine", "case_error", "check_reference", "analyse",
           "report",
           "formal_order", "scene_quantities", "worker_count", "check_vary",
           "cases_of", "estimate", "time_model", "VARIABLES",
           "DEFAULT_VARY", "DEFAULT_QUANTITY", "CASES_UNASKED"]

VARIABLES = ("elements", "ppc", "loadsteps", "method", "rhs",
             "line_search", "newton")
CHOICES = {"method": METHODS, "rhs": RHS,     # the variables named by words
           "line_search": LINE_SEARCHES, "newton": NEWTON}
DEFAULT_VARY = {"elements": [4, 8, 16, 32, 64, 128, 256],
                "ppc": [2, 3, 4, 5], "loadsteps": [1, 2, 20]}
#: what a study measures when the scene names nothing
DEFAULT_QUANTITY = Quantity("displacement", "magnitude", reduce="max",
                            name="largest point displacement")


def scene_quantities(scene) -> Sequence[Quantity]:
    """The scene's ``outputs``, or :data:`DEFAULT_QUANTITY`."""
    return list(scene.outputs) or [DEFAULT_QUANTITY]


def refine(scene: Scene, elements: int) -> Scene:
    """The scene on a grid with ``elements`` cells along its most refined
    axis; other axes scale in proportion, axes one cell across stay so."""
    axes = list(scene.grid.axes)
    counts = [n for _, _, n in axes]
    ref = max(counts)
    new = [(lo, hi, n if n == 1 else max(1, round(n * elements / ref)))
           for lo, hi, n in axes]
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
    (:func:`~skfem_mpm.studies.column.column_extent`); a bearing-capacity
    scene is checked with the scene itself
    (:meth:`~skfem_mpm.scenes.scene.Scene.check`).

    Raises
    ------
    InvalidInputError
        Saying why the reference does not apply.
    """
    if scene.reference == "column":
        column_extent(scene)


def case_error(scene: Scene, result) -> float:
    """The scene's error measure: ``reference = "column"`` gives the
    error measure (2.28) of Charlton (2018); ``"elastica"`` the relative error of the loaded points' tip
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
        from .footing import footing_error
        return footing_error(scene, np.array(
            [r.rigid_forces[0] for r in result.history]))
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


def run_case(scene: Scene, params: dict, quantities=()) -> dict:
    """One case, timed inside: error against the scene's reference (if it
    has one), the ``quantities``' ``values``, wall time and CPU time
    (``time.process_time`` of this process: all its threads), time per phase,
    Newton iterations, DOFs, points and peak memory (growth of the
    resident set during the case)."""
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
    except MPMError as err:
        row["failure"] = "{}: {}".format(type(err).__name__, err)
    row.update(
        points=int(result.points.n),
        dofs=int(max(r.n_free_dofs for r in result.history)),
        newton_iterations=int(result.counters["newton_iterations"]),
        factorisations=int(result.counters["factorisations"]),
        steps_run=len(result.history))
    return row


def _key(params: dict) -> str:
    return json.dumps({k: params[k] for k in VARIABLES if k in params},
                      sort_keys=True)


def cell_size(scene: Scene, elements: int) -> float:
    """The representative cell size ``(V / N)^(1/d)`` (Celik et al. 2008)
    of the scene's grid refined to ``elements`` (:func:`refine`): the
    rounding of the other axes' counts enters the refinement ratios."""
    axes = refine(scene, elements).grid.axes
    return float(np.prod([(hi - lo) / n for lo, hi, n in axes])
                 ** (1. / len(axes)))


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
    over the cell size (all of the group's grids, the quantity's
    :func:`formal_order`): the reference, each case's error and
    uncertainty (relative to the reference); without, every group
    (sharing method, right-hand side, line search and Newton variant) is
    judged by its data range (:func:`~.convergence.from_data_range`)
    against the case with the most points (then load steps).  Sets
    ``row["errors"]`` and ``row["uncertainties"]`` (per quantity),
    ``row["error"]`` (the scene's closed-form error where it has one,
    else the first quantity's) and ``row["uncertainty"]`` (the first
    quantity's, ``None`` against a closed form), and returns what was
    measured, for ``study.json``.  A group of one case has no error and
    no uncertainty (NaN, written as null).
    """
    done = [r for r in rows if not r["failure"] and "values" in r]
    refined = any("elements" in r for r in done)
    keys = [k for k in VARIABLES if k != "elements"] if refined else \
        list(CHOICES)
    convergence = []
    for choices, members in _groups(done, keys):
        for q in quantities:
            values = [r["values"][q.label] for r in members]
            if refined:
                sizes = [cell_size(scene, r["elements"]) for r in members]
                found = self_convergence(sizes, values,
                                         formal_order(scene, q))
            else:
                sizes = []
                finest = max(range(len(members)), key=lambda k: (
                    members[k]["points"], members[k].get("loadsteps", 0)))
                found = from_data_range(
                    values, finest, "elements not varied: the case with "
                    "the most points (then load steps) is the reference")
                if len(members) == 1:
                    found.errors = found.uncertainties = [None]
                    found.uncertainty = None
            scale = abs(found.reference) or max(abs(v) for v in values) \
                or 1.
            for r, e, u in zip(members, found.errors, found.uncertainties):
                r.setdefault("errors", {})[q.label] = _relative(e, scale)
                r.setdefault("uncertainties", {})[q.label] = \
                    _relative(u, scale)
            convergence.append(dict(
                quantity=q.label, unit=q.unit(len(scene.grid.axes)),
                choices=choices, cell_sizes=sizes, values=values,
                **found.as_dict()))
    first = quantities[0].label
    for r in done:
        r["error"] = r["reference_error"] if scene.reference else \
            r["errors"][first]
        r["uncertainty"] = None if scene.reference else \
            r["uncertainties"][first]
    if scene.reference:
        label, against, what = REFERENCE_ERRORS[scene.reference]
    else:
        label = "relative error of {}".format(first)
        against, reference = (
            "its least-squares extrapolation (or the data range)",
            "its extrapolation with the order fitted by least squares over "
            "the element counts where that order is credible; where it is "
            "not, the finest case, every case's error being the data range "
            "max |f_i - f_j| / |reference| of its group (convergence: why)") \
            if refined else (
            "the data range of cases sharing method and solver",
            "the case with the most points (then load steps) among those "
            "sharing method, right-hand side, line search and Newton "
            "variant, every case's error being the data range "
            "max |f_i - f_j| / |reference| of those cases: elements were "
            "not varied")
        what = "|value - reference| / |reference| of {} ({}), the " \
            "reference being {}".format(
                first, quantities[0].unit(len(scene.grid.axes)), reference)
    return {"error": {"label": label, "against": against, "measures": what,
                      "closed_form": bool(scene.reference)},
            "convergence": convergence}


def _number(x, form: str) -> str:
    """``x`` formatted, ``-`` where it is unknown (None or NaN)."""
    return "-" if x is None or x != x else form.format(x)


def report(rows: List[dict], measured: dict, keys: Sequence[str]
           ) -> List[str]:
    """The lines of a study's summary (``skfem-mpm study`` prints them):
    what the error measures, a table of the cases (the ``keys`` varied,
    error, uncertainty, wall and CPU seconds, points, Newton iterations,
    factorisations), the fitted rate of the error per group where the
    error has one (a closed form, or a reference extrapolated with a
    credible order), and per quantity and group its reference and
    uncertainty with, in words, why it was or was not extrapolated."""
    lines = ["error: {}".format(measured["error"]["measures"])]
    lines.append(" ".join("{:>9}".format(k) for k in keys) +
                 " {:>10} {:>11} {:>8} {:>8} {:>8} {:>10} {:>14}".format(
                     "error", "uncertainty", "wall s", "CPU s", "points",
                     "iterations", "factorisations"))
    for r in rows:
        lines.append(" ".join("{:>9}".format(r[k]) for k in keys) + (
            " failed: " + r["failure"] if r["failure"] else
            " {:>10} {:>11} {:>8.3f} {:>8} {:>8} {:>10} {:>14}".format(
                _number(r.get("error"), "{:.3e}"),
                _number(r.get("uncertainty"), "{:.3e}"), r["wall_seconds"],
                _number(r.get("cpu_seconds"), "{:.3f}"), r["points"],
                r["newton_iterations"], r.get("factorisations", "-"))))
    first = measured["convergence"][0]["quantity"] \
        if measured["convergence"] else None
    if "elements" in keys:
        for mine, members in _groups([r for r in rows if not r["failure"]],
                                     [k for k in keys if k != "elements"]):
            where = ", ".join("{}={}".format(k, v) for k, v in
                              mine.items()) or "all"
            found = [c for c in measured["convergence"]
                     if c["quantity"] == first and c["choices"] == mine]
            if not measured["error"].get("closed_form") and not (
                    found and found[0]["against"] == "richardson"):
                lines.append("rate of the error {}: none (no extrapolation:"
                             " every error is the data range)".format(where))
                continue
            rate = fitted_rate([r["elements"] for r in members],
                               [r["error"] for r in members])
            lines.append("rate of the error {}: {}".format(
                where, "{:.2f} (fitted to the cases with a non-zero "
                "error)".format(rate) if np.isfinite(rate) else
                "needs two cases with a non-zero error"))
    for c in measured["convergence"]:
        where = ", ".join("{}={}".format(k, v) for k, v in
                          c["choices"].items())
        lines.append("{}{}: {} {} +- {} {}: {}".format(
            c["quantity"], " [" + where + "]" if where else "",
            "extrapolated" if c["against"] == "richardson" else "reference",
            _number(c["reference"], "{:.6g}"),
            _number(c["uncertainty"], "{:.2g}"), c["unit"], c["why"]))
    return lines


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
PER_QUANTITY = {"values": "value: ", "errors": "error: ",
                "uncertainties": "uncertainty: "}


def _write(outdir: Path, rows: List[dict], workers: int, measured: dict):
    rows = _known(rows)
    with atomic_path(outdir / "study.json") as tmp:
        Path(tmp).write_text(json.dumps(dict(
            workers=workers, rows=rows, **_known(measured)), indent=1))
    flat = [{**{k: v for k, v in r.items() if k not in PER_QUANTITY},
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
          progress: bool = True, quantities=None) -> List[dict]:
    """Run every combination of ``vary``, measure the quantities of
    interest and the errors (:func:`analyse`), and record it in
    ``outdir``.

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
        scene's ``outputs``, or the largest point displacement.

    Returns
    -------
    rows
        One dict per case (finished ones read back on resume, unless they
        lack a value of ``quantities``: those run again), with
        ``values`` and ``errors`` per quantity and the headline ``error``.

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

    """
    check_vary(vary)
    check_reference(scene)
    if scheduler is None and workers:
        workers = worker_count(workers)
    quantities = list(quantities or scene_quantities(scene))
    check_quantities(scene, quantities, build_points(
        scene, scene.grid.build()[0]))
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    cases = cases_of(vary)
    rows = finished_rows(outdir, quantities)
    done = {_key(r) for r in rows}
    todo = [c for c in cases if _key(c) not in done]
    logger.info("%d cases, %d already done", len(cases), len(cases) - len(todo))
    if scheduler is None and not workers:
        for k, params in enumerate(todo):
            rows.append(run_case(scene, params, quantities))
            _write(outdir, rows, 1, analyse(scene, rows, quantities))
            if progress and sys.stderr.isatty():
                sys.stderr.write("\rcase {}/{} {}".format(k + 1, len(todo),
                                                         _key(params)))
        if progress and sys.stderr.isatty():
            sys.stderr.write("\n")
        _write(outdir, rows, 1, analyse(scene, rows, quantities))
        return _ordered(rows, cases)
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
        futures = [client.submit(run_case, scene, params, quantities,
                                 pure=False) for params in todo]
        for future in as_completed(futures):
            rows.append(future.result())
            _write(outdir, rows, nworkers, analyse(scene, rows, quantities))
        _write(outdir, rows, nworkers, analyse(scene, rows, quantities))
    if cluster is not None:
        cluster.close()
    return _ordered(rows, cases)


def check_vary(vary: Dict[str, Sequence]):
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` unless every
    name of ``vary`` is one of :data:`VARIABLES` with distinct, possible
    values."""
    for name, values in vary.items():
        if name not in VARIABLES:
            raise InvalidInputError("cannot vary {!r}: choose from {}".format(
                name, ", ".join(VARIABLES)))
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


def cases_of(vary: Dict[str, Sequence]) -> List[dict]:
    """Every combination of the values of ``vary``, one dict a case."""
    names = list(vary)
    return [dict(zip(names, combo))
            for combo in itertools.product(*(vary[n] for n in names))]


def finished_rows(outdir, quantities) -> List[dict]:
    """The cases ``study.json`` in ``outdir`` holds that need not run
    again: failed ones, and those with a value of every quantity."""
    path = Path(outdir) / "study.json"
    if not path.exists():
        return []
    labels = {q.label for q in quantities}
    return [r for r in json.loads(path.read_text())["rows"]
            if r["failure"] or labels <= set(r.get("values", ()))]


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


def estimate(scene: Scene, cases: List[dict], outdir, quantities,
             budget: float = 2.) -> dict:
    """What a study of ``cases`` in ``outdir`` would take: ``cases``,
    ``done`` (finished before), ``ran`` (run now to time them), ``left``,
    the ``largest`` case's point bound and steps, the ``model`` of
    :func:`time_model` and the ``seconds`` the ``left`` cases would take
    by it (serially; ``None`` when nothing could be measured).  The model
    rests on the cases finished before and, where they do not span a
    ratio of 4 in size, on small unfinished cases run first (kept in
    ``study.json`` like any case, never run again): the smallest that
    succeeds (trying for ``budget`` seconds), then the largest that the first one's pace (which
    over-estimates, start-up included) puts under ``budget`` seconds."""
    quantities = list(quantities or scene_quantities(scene))
    rows = {_key(r): r for r in finished_rows(outdir, quantities)}
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
                    progress=False, quantities=quantities)[0]
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
    return dict(cases=len(cases), done=done,
                ran=len(cases) - done - len(todo), left=len(todo),
                largest=(point_bound(case), case.step_count), model=model,
                seconds=None if model is None else sum(
                    model[0] + model[1] * work[_key(c)] for c in todo))


#: a local cluster's workers each compute on one thread
ONE_THREAD = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1,
              "OPENBLAS_NUM_THREADS": 1}


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
