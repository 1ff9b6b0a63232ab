"""What each method's accuracy costs in time: the seed's column and the
user cantilever with every method at matched grids and points per cell.

Each set-up is a function of the cell size ``h``, the method and the
points per cell and axis, and returns its result and its quantity: the
column (1D, finite deformation, 20 load steps) its error (2.28) against
the seed's closed form; the cantilever
(:func:`~skfem_mpm.studies.elastica.untuned_cantilever`, ``P L^2 / EI =
3``, 20 steps, every setting the default) its tip deflection over the
length.  The elastica is a beam theory: the plane-strain beam of depth
L/10 it is compared with deflects about 1% more (shear, stretching), so
the cantilever's error is measured against the continuum's own tip
deflection, extrapolated from FE on fine grids
(:func:`cantilever_reference`, the self-convergence of
:mod:`~skfem_mpm.studies.convergence`).  Every case records its CPU and
wall seconds, Newton iterations and the step from which the ghost
penalty was on (0: never).

"""
import time
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..quadrature.points import seed_points
from ..solve.core import simulate
from ..solve.options import Options
from .column import HEIGHT, LOAD, MATERIAL, column_error, column_grid, \
    column_supports
from .convergence import SelfConvergence, self_convergence
from .elastica import untuned_cantilever
from .study import fitted_rate

__all__ = ["METHODS", "column", "cantilever", "cantilever_reference",
           "methods_study", "orders", "cheapest", "plot_methods"]

#: every method, in the order of the tables
METHODS = ("fem", "mpm", "ugimp", "cpgimp", "bspline", "bspline-gimp")


def column(h: float, method: str, per_cell: int = 2, nsteps: int = 20):
    """The seed's column (1D, ``HEIGHT / h`` elements, finite
    deformation): its result and its error (2.28).

    Examples
    --------
    >>> from skfem_mpm.studies.methods import column
    >>> res, error = column(12.5, "mpm", nsteps=1)
    >>> round(error, 4)       # small strain: h / (4 L0) = 0.0625
    0.0613
    """
    mesh, elem = column_grid(int(round(HEIGHT / h)))
    res = simulate(mesh, elem, seed_points(mesh, per_cell), MATERIAL,
                   column_supports(1), [-LOAD], nsteps=nsteps, method=method,
                   kinematics="finite", options=Options(keep_snapshots=False))
    return res, column_error(res.points)


def cantilever(h: float, method: str, per_cell: int = 2):
    """The user cantilever: its result and its tip deflection over L."""
    res, _ = untuned_cantilever(h, per_cell, method)
    tip = np.flatnonzero(res.points.x0[0] > res.points.x0[0].max() - 1e-9)
    return res, float(-res.points.displacement[1, tip].mean() / 10.)


def cantilever_reference(sizes: Sequence[float] = (.25, .125, .0625),
                         per_cell: int = 2) -> SelfConvergence:
    """The continuum's tip deflection of the user cantilever over L: FE
    (``method="fem"``) on grids of ``sizes``, extrapolated by
    :func:`~skfem_mpm.studies.convergence.self_convergence`
    (``reference``, with the finest grid's ``uncertainties``)."""
    values = [cantilever(h, "fem", per_cell)[1] for h in sizes]
    return self_convergence(sizes, values, formal_order=2.)


SETUPS = {"column": column, "cantilever": cantilever}
#: the spread of CPU times over which an order in time is drawn
TIME_SPAN = 4.


def methods_study(setup: str, sizes: Sequence[float],
                  methods: Sequence[str] = METHODS, per_cell: int = 2,
                  reference: Optional[float] = None) -> List[dict]:
    """Run ``setup`` (``"column"`` or ``"cantilever"``) with every method
    on grids of cell ``sizes``: one row per case with ``setup``,
    ``method``, ``h``, ``value`` (the column's error, the cantilever's
    tip deflection over L), ``error`` (``|value / reference - 1|``, or the
    value itself without a ``reference``), ``cpu_seconds``,
    ``wall_seconds``, ``points``, ``newton_iterations`` and
    ``ghost_from_step``.  Each method first runs its largest cell size
    once untimed, so that no timed case pays for setting up caches or
    compiling kernels.

    Examples
    --------
    >>> from skfem_mpm.studies.methods import methods_study
    >>> rows = methods_study("column", [12.5], ["mpm"])
    >>> rows[0]["method"], rows[0]["points"], rows[0]["ghost_from_step"]
    ('mpm', 8, 0)
    """
    rows = []
    for method in methods:
        SETUPS[setup](max(sizes), method, per_cell)
        for h in sizes:
            cpu, wall = time.process_time(), time.perf_counter()
            res, value = SETUPS[setup](h, method, per_cell)
            rows.append(dict(
                setup=setup, method=method, h=float(h), value=float(value),
                error=float(value if reference is None
                            else abs(value / reference - 1.)),
                cpu_seconds=time.process_time() - cpu,
                wall_seconds=time.perf_counter() - wall,
                points=int(res.points.n),
                newton_iterations=int(res.counters["newton_iterations"]),
                ghost_from_step=int(res.counters["ghost_from_step"])))
    return rows


def orders(rows: List[dict]) -> Dict[str, dict]:
    """Per method the fitted orders of the rows' ``error``: in the cell
    size (``error ~ h^p``, ``"h"``) and in CPU time (``error ~
    t^-q``, ``"time"``), over all the method's grids.

    Examples
    --------
    >>> from skfem_mpm.studies.methods import orders
    >>> rows = [dict(method="a", h=h, error=h * h, cpu_seconds=1 / h ** 4)
    ...         for h in (1., .5, .25)]
    >>> orders(rows)
    {'a': {'h': 2.0, 'time': 0.5}}
    """
    found = {}
    for method in dict.fromkeys(r["method"] for r in rows):
        mine = [r for r in rows if r["method"] == method]
        error = [r["error"] for r in mine]
        found[method] = {
            "h": fitted_rate([1. / r["h"] for r in mine], error),
            "time": fitted_rate([r["cpu_seconds"] for r in mine], error)}
    return found


def cheapest(rows: List[dict], target: float) -> Dict[str, dict]:
    """Per method the case of least CPU time from whose cell size on the
    ``error`` stays at most ``target`` (that grid's and every finer one's:
    a coarse grid that is right by chance does not count), ``None`` where
    none is.

    Examples
    --------
    >>> from skfem_mpm.studies.methods import cheapest
    >>> rows = [dict(method="a", h=h, error=e, cpu_seconds=t) for h, e, t
    ...         in ((1., .001, 1.), (.5, .05, 3.), (.25, .01, 9.))]
    >>> cheapest(rows, .02)["a"]["cpu_seconds"], cheapest(rows, .005)["a"]
    (9.0, None)
    """
    found = {}
    for method in dict.fromkeys(r["method"] for r in rows):
        mine = sorted((r for r in rows if r["method"] == method),
                      key=lambda r: r["h"])
        good = [r for k, r in enumerate(mine)
                if all(f["error"] <= target for f in mine[:k + 1])]
        found[method] = min(good, key=lambda r: r["cpu_seconds"]) \
            if good else None
    return found


def plot_methods(studies: Dict[str, List[dict]], path, titles: Dict[str, str]):
    """One panel per study (``titles`` by its name): each method's error
    against CPU seconds on log axes, its fitted order in the cell size in
    the legend, and in time where the method's CPU times span a factor of
    :data:`TIME_SPAN` (below it the runs' fixed costs dominate and a
    slope says nothing); written to ``path`` (PNG)."""
    from matplotlib.ticker import NullFormatter
    from ..scenes import plot
    from ..scenes.plot import pyplot, series_styles
    fig, axes = pyplot().subplots(1, len(studies),
                                  figsize=(5.5 * len(studies), 4.5))
    for ax, (name, rows) in zip(np.atleast_1d(axes), studies.items()):
        found = orders(rows)
        for style, method in zip(series_styles(len(found)), found):
            mine = sorted((r for r in rows if r["method"] == method),
                          key=lambda r: -r["h"])           # refinement
            cpu = [r["cpu_seconds"] for r in mine]
            label = "{} (order {:.2f} in h".format(method, found[method]["h"])
            if max(cpu) >= TIME_SPAN * min(cpu):
                label += ", {:.2f} in time".format(found[method]["time"])
            ax.loglog(cpu, [r["error"] for r in mine], ms=4, lw=.8,
                      label=label + ")", **style)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("CPU seconds per run (s), the grids refined along "
                      "each line")
        ax.set_ylabel("error (-)")
        ax.set_title(titles[name], fontsize=9)
        ax.legend(fontsize=6)
    fig.tight_layout()
    plot.save_figure(fig, path)
    return path
