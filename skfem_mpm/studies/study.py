"""What accuracy costs in time: run a scene over a grid of choices
(elements, points per cell, load steps, method, right-hand side), measure
its error against the scene's reference and the time of every phase, and
draw the trade-off.

Cases are independent: they run serially (with a progress line) or on a
Dask cluster (``dask.distributed``, an optional extra: a local cluster or
``scheduler=ADDRESS``).  Timings are taken inside each case, so parallel
execution does not distort them.  Results are appended per case, atomically,
to ``study.json`` and ``study.csv``; an interrupted study resumes without
re-running finished cases.

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
from ..scenes.scene import METHODS, Grid, Scene, run_scene
from ..solve.core import RHS
from ..solve.newton import LINE_SEARCHES
from ..solve.results import PHASES

logger = logging.getLogger(__name__)

__all__ = ["study", "refine", "case_error", "VARIABLES", "DEFAULT_VARY"]

VARIABLES = ("elements", "ppc", "loadsteps", "method", "rhs",
             "line_search")
CHOICES = {"method": METHODS, "rhs": RHS,     # the variables named by words
           "line_search": LINE_SEARCHES}
DEFAULT_VARY = {"elements": [4, 8, 16, 32, 64, 128, 256],
                "ppc": [2, 3, 4, 5], "loadsteps": [1, 2, 20]}


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
        out = replace(out, steps=int(params["loadsteps"]))
    for name in CHOICES:
        if name in params:
            out = replace(out, **{name: params[name]})
    return out


def case_error(scene: Scene, result) -> float:
    """The scene's error measure: ``reference = "column"`` gives seed
    (2.28); ``"elastica"`` the relative error of the loaded points' tip
    deflection at full load against the elastica; ``"bearing_capacity"``
    the relative error of the footing's peak pressure against ``N_c c``;
    NaN without a reference."""
    pts = result.points
    if scene.reference == "column":
        from .column import column_error
        return column_error(pts, abs(scene.gravity[-1]),
                            scene.bodies[0].region[-1][1])
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


def run_case(scene: Scene, params: dict) -> dict:
    """One case, timed inside: error, wall time, time per phase, Newton
    iterations, DOFs, points and peak memory (growth of the resident set
    during the case)."""
    case = configure(scene, params)
    with PeakMemory() as memory:
        tic = time.perf_counter()
        try:
            result = run_scene(case)
            failure = ""
        except MPMError as err:
            result, failure = None, "{}: {}".format(type(err).__name__, err)
        wall = time.perf_counter() - tic
    row = dict(params)
    row.update(wall_seconds=wall, peak_mb=memory.peak / 2 ** 20,
               failure=failure)
    if result is None:
        return row
    timings = result.timings()
    row.update({"t_" + p: timings[p] for p in PHASES})
    row.update(
        error=case_error(case, result), points=int(result.points.n),
        dofs=int(max(r.n_free_dofs for r in result.history)),
        newton_iterations=int(result.counters["newton_iterations"]),
        steps_run=len(result.history))
    return row


def _key(params: dict) -> str:
    return json.dumps({k: params[k] for k in VARIABLES if k in params},
                      sort_keys=True)


def _write(outdir: Path, rows: List[dict], workers: int):
    with atomic_path(outdir / "study.json") as tmp:
        Path(tmp).write_text(json.dumps({"workers": workers, "rows": rows},
                                        indent=1))
    columns = sorted({k for r in rows for k in r})
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    with atomic_path(outdir / "study.csv") as tmp:
        Path(tmp).write_text(text.getvalue())


def study(scene: Scene, vary: Dict[str, Sequence], outdir,
          scheduler: Optional[str] = None, workers: int = 0,
          progress: bool = True) -> List[dict]:
    """Run every combination of ``vary`` and record it in ``outdir``.

    Parameters
    ----------
    scene
        The base scene.
    vary
        Lists of values for any of ``elements``, ``ppc``, ``loadsteps``,
        ``method``, ``rhs`` (``"residual"``, ``"increment"``: the
        right-hand side of linear steps, :func:`~skfem_mpm.simulate`) and
        ``line_search`` (``"backtracking"``, ``"none"``).
    outdir
        Folder of ``study.json`` / ``study.csv`` (and the plots).
    scheduler, workers
        Dask: a scheduler address, or a local cluster of ``workers``
        processes; both unset: serial.

    Returns
    -------
    rows
        One dict per case (finished ones read back on resume).

    Examples
    --------
    >>> import tempfile
    >>> from skfem_mpm.scenes.cli import EMBEDDED
    >>> from skfem_mpm.scenes.scene_file import load_scene
    >>> from skfem_mpm.studies.study import study
    >>> rows = study(load_scene(EMBEDDED), {"elements": [4, 8],
    ...              "loadsteps": [1]}, tempfile.mkdtemp(), progress=False)
    >>> [round(r["error"], 6) for r in rows]
    [0.0625, 0.03125]

    """
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
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    names = list(vary)
    cases = [dict(zip(names, combo))
             for combo in itertools.product(*(vary[n] for n in names))]
    rows = []
    if (outdir / "study.json").exists():
        rows = json.loads((outdir / "study.json").read_text())["rows"]
    done = {_key(r) for r in rows}
    todo = [c for c in cases if _key(c) not in done]
    logger.info("%d cases, %d already done", len(cases), len(cases) - len(todo))
    if scheduler is None and not workers:
        for k, params in enumerate(todo):
            rows.append(run_case(scene, params))
            _write(outdir, rows, 1)
            if progress and sys.stderr.isatty():
                sys.stderr.write("\rcase {}/{} {}".format(k + 1, len(todo),
                                                         _key(params)))
        if progress and sys.stderr.isatty():
            sys.stderr.write("\n")
        return _ordered(rows, cases)
    from dask.distributed import Client, LocalCluster, as_completed
    if not logger.isEnabledFor(logging.INFO):
        logging.getLogger("distributed").setLevel(logging.ERROR)
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                               processes=True, host="127.0.0.1",
                               dashboard_address="127.0.0.1:0")
    with Client(scheduler or cluster) as client:
        nworkers = len(client.scheduler_info()["workers"])
        futures = [client.submit(run_case, scene, params, pure=False)
                   for params in todo]
        for future in as_completed(futures):
            rows.append(future.result())
            _write(outdir, rows, nworkers)
    if cluster is not None:
        cluster.close()
    return _ordered(rows, cases)


def _ordered(rows: List[dict], cases: List[dict]) -> List[dict]:
    by_key = {_key(r): r for r in rows}
    return [by_key[_key(c)] for c in cases if _key(c) in by_key]


def fitted_rate(x, y) -> float:
    """Slope of -log(y) against log(x) (finite, positive entries)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(y) & (y > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(-np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def _finish(fig, ax, xlabel: str, ylabel: str, path: Path) -> Path:
    """Label, legend and write one study figure."""
    from ..scenes.plot import save_figure
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=6)
    fig.tight_layout()
    save_figure(fig, path)
    return path


def plot_study(rows: List[dict], outdir) -> List[Path]:
    """(a) error against elements with the fitted rate per curve, (b) error
    against wall time per method with the Pareto front, (c) time per phase
    against points with fitted exponents.  Returns the files written."""
    from ..scenes.plot import pyplot
    plt = pyplot()
    outdir = Path(outdir)
    ok = [r for r in rows if not r.get("failure")]
    written = []
    curves = {}
    for r in ok:
        label = ", ".join("{}={}".format(k, r[k]) for k in (
            "method", "rhs", "line_search", "ppc", "loadsteps") if k in r)
        curves.setdefault(label, []).append(r)
    if any(np.isfinite(r["error"]) for r in ok) and "elements" in ok[0]:
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        for label, rs in sorted(curves.items()):
            rs = sorted(rs, key=lambda r: r["elements"])
            x = [r["elements"] for r in rs]
            y = [r["error"] for r in rs]
            ax.loglog(x, y, "o-", ms=3, lw=.8, label="{} (rate {:.2f})"
                      .format(label or "all", fitted_rate(x, y)))
        written.append(_finish(fig, ax, "number of elements", "error",
                               outdir / "error_vs_elements.png"))
    if any(np.isfinite(r["error"]) for r in ok):
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        methods = sorted({r.get("method", "scene") for r in ok})
        for m in methods:
            rs = [r for r in ok if r.get("method", "scene") == m]
            ax.loglog([r["wall_seconds"] for r in rs],
                      [r["error"] for r in rs], "o", ms=3, label=m)
        front, best = [], np.inf
        for r in sorted(ok, key=lambda r: r["wall_seconds"]):
            if r["error"] < best:
                best = r["error"]
                front.append((r["wall_seconds"], r["error"]))
        if front:
            ax.loglog(*zip(*front), "k-", lw=.8, label="Pareto front")
        written.append(_finish(fig, ax, "wall time per case [s]", "error",
                               outdir / "error_vs_time.png"))
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    points = np.array([r["points"] for r in ok], float)
    steps = np.array([max(r["steps_run"], 1) for r in ok], float)
    for p in PHASES:
        t = np.array([r["t_" + p] for r in ok]) / steps
        good = t > 0
        if np.unique(points[good]).size >= 2:    # an exponent needs sizes
            slope = np.polyfit(np.log(points[good]), np.log(t[good]), 1)[0]
            label = "{} (exponent {:.2f})".format(p, slope)
        else:
            label = p
        if good.any():
            ax.loglog(points[good], t[good], "o", ms=3, label=label)
    written.append(_finish(fig, ax, "material points",
                           "seconds per load step",
                           outdir / "time_vs_points.png"))
    return written
