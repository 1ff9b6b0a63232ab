"""What each method's accuracy costs in time: the seed's column, the
user cantilever and Prandtl's footing with every method at matched grids
and points per cell.

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
:mod:`~skfem_mpm.studies.convergence`).  The footing (:func:`footing`)
is a smooth rigid box (an :class:`~skfem_mpm.Obstacle`, so that every
method runs it on the same fixed grid) pushed a fraction of a cell into
weightless Tresca soil; its quantity is the pressure on the plateau over
``c_u``, its reference Prandtl's ``(2 + pi)`` (:func:`footing_reference`).
Every case records its CPU and wall seconds, load steps, Newton
iterations and the step from which the ghost penalty was on (0: never).

"""
import time
from typing import Dict, List, Optional, Sequence

import numpy as np
from skfem import ElementQuad1

from ..mechanics.materials import VonMises
from ..quadrature.points import seed_points
from ..scenes.footing import soil_strength
from ..solve.core import simulate
from ..solve.obstacles import Obstacle
from ..solve.options import Options, Stabilisation
from .column import HEIGHT, LOAD, MATERIAL, column_error, column_grid, \
    column_supports
from .convergence import SelfConvergence, self_convergence
from .elastica import untuned_cantilever
from .footing import bearing_capacity_factor
from .study import fitted_rate
from .user_setups import base_and_rollers, grid

__all__ = ["METHODS", "column", "cantilever", "cantilever_reference",
           "footing", "footing_reference", "methods_study", "orders",
           "series", "cheapest", "plot_methods", "plot_footing"]

#: the methods compared, in the order of the tables: every method but the
#: cubic splines (the study seeds 2 points a cell and axis, too few for
#: their stiffness: ``docs/bspline.md``)
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


#: the footing's soil: weightless von Mises, in plane strain Tresca with
#: ``c_u = 100 / sqrt 3``; stiff (``E / c_u = 1.7e4``) so that the
#: pressure is on its plateau from a settlement of about 0.001 B on
FOOTING_SOIL = VonMises(E=1e6, nu=.3, yield_stress=100.)
#: the footing's width B, its settlement over B at the end (0.02, 0.04,
#: 0.08 and 0.16 of a cell at B / h = 4, 8, 16 and 32) and its load steps
FOOTING_WIDTH, FOOTING_PUSH, FOOTING_STEPS = 1., .005, 20


def footing_reference(material=FOOTING_SOIL) -> float:
    """Prandtl's collapse pressure of a smooth strip footing on the
    weightless soil ``material`` over its cohesion: ``N_c`` of
    :func:`~skfem_mpm.studies.footing.bearing_capacity_factor` at the
    soil's friction angle, ``2 + pi`` for von Mises.

    Examples
    --------
    >>> from skfem_mpm.studies.methods import footing_reference
    >>> round(footing_reference(), 6)
    5.141593
    """
    return bearing_capacity_factor(soil_strength(material)[1])


def footing(h: float, method: str, per_cell: int = 2,
            nsteps: int = FOOTING_STEPS, kinematics: str = "small"):
    """Prandtl's smooth strip footing on a fixed grid of spacing ``h``: a
    rigid box (a smooth :class:`~skfem_mpm.Obstacle`) of half-width
    B / 2 on the symmetry line x = 0, pushed ``FOOTING_PUSH * B`` in
    ``nsteps`` steps into weightless soil 2.5 B wide and 1.5 B deep
    (:data:`FOOTING_SOIL`, in ``kinematics``: ``"small"`` strain by
    default, or ``"finite"`` deformation; the mean dilatation against
    volumetric locking), base fixed, sides on rollers, two empty rows of
    cells above.  Returns the result, the footing pressure over ``c_u``
    at the end, and the row's details: ``drift``, the pressure's relative
    change over the second half of the push (how flat the plateau is),
    and per step ``settlement`` (over B) and ``pressure`` (over ``c_u``).

    Examples
    --------
    >>> from skfem_mpm.studies.methods import footing
    >>> res, q, details = footing(.25, "fem")       # B / h = 4
    >>> round(q, 2), len(details["pressure"]), abs(details["drift"]) < 1e-3
    (5.88, 20, True)
    """
    B, depth = FOOTING_WIDTH, 1.5 * FOOTING_WIDTH
    mesh = grid((0., 2.5 * B), (0., depth + 2 * h), h)
    push = Obstacle(box=[[-1., B / 2], [depth, depth + h]],
                    displacement=[0., -FOOTING_PUSH * B], name="footing")
    res = simulate(mesh, ElementQuad1(),
                   seed_points(mesh, per_cell, region=lambda x: x[1] < depth),
                   FOOTING_SOIL, base_and_rollers(2.5 * B), nsteps=nsteps,
                   method=method, kinematics=kinematics, obstacles=[push],
                   options=Options(
                       stabilisation=Stabilisation(antilocking=True),
                       keep_snapshots=False))
    load = np.array([r.load_factor for r in res.history])
    pressure = np.array([r.obstacle_forces[0, 1] for r in res.history]) \
        / (B / 2) / soil_strength(FOOTING_SOIL)[0]
    return res, float(pressure[-1]), dict(
        drift=float(pressure[-1] / np.interp(.5, load, pressure) - 1.),
        settlement=(load * FOOTING_PUSH).tolist(),
        pressure=pressure.tolist())


SETUPS = {"column": column, "cantilever": cantilever, "footing": footing}
#: the spread of CPU times over which an order in time is drawn
TIME_SPAN = 4.


def methods_study(setup: str, sizes: Sequence[float],
                  methods: Sequence[str] = METHODS, per_cell: int = 2,
                  reference: Optional[float] = None) -> List[dict]:
    """Run ``setup`` (``"column"``, ``"cantilever"`` or ``"footing"``) with
    every method on grids of cell ``sizes``: one row per case with
    ``setup``, ``method``, ``h``, ``per_cell``, ``value`` (the column's
    error, the cantilever's tip deflection over L, the footing's pressure
    over ``c_u``), ``error`` (``|value / reference - 1|``, or the value itself
    without a ``reference``), ``cpu_seconds``, ``wall_seconds``,
    ``points``, ``steps`` (load steps, cut-backs included),
    ``newton_iterations`` and ``ghost_from_step``, and the set-up's own
    details (the footing's: :func:`footing`).  Each method first runs its
    largest cell size once untimed, so that no timed case pays for
    setting up caches or compiling kernels.

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
            res, value, *details = SETUPS[setup](h, method, per_cell)
            rows.append(dict(
                setup=setup, method=method, h=float(h), per_cell=per_cell,
                value=float(value),
                error=float(value if reference is None
                            else abs(value / reference - 1.)),
                cpu_seconds=time.process_time() - cpu,
                wall_seconds=time.perf_counter() - wall,
                points=int(res.points.n), steps=len(res.history),
                newton_iterations=int(res.counters["newton_iterations"]),
                ghost_from_step=int(res.counters["ghost_from_step"]),
                **(details[0] if details else {})))
    return rows


def series(rows: List[dict]) -> Dict[str, List[dict]]:
    """The rows by series, in their order: a method's name, with its
    points per cell and axis where the rows have more than one count.

    Examples
    --------
    >>> from skfem_mpm.studies.methods import series
    >>> rows = [dict(method="a", per_cell=2), dict(method="a", per_cell=3)]
    >>> list(series(rows)), list(series(rows[:1]))
    (['a, 2 points', 'a, 3 points'], ['a'])
    """
    mixed = len({r.get("per_cell") for r in rows}) > 1
    found = {}
    for r in rows:
        found.setdefault(r["method"] + (", {} points".format(r["per_cell"])
                                        if mixed else ""), []).append(r)
    return found


def orders(rows: List[dict]) -> Dict[str, dict]:
    """Per series (:func:`series`: a method) the fitted orders of the
    rows' ``error``: in the cell size (``error ~ h^p``, ``"h"``) and in
    CPU time (``error ~ t^-q``, ``"time"``), over all its grids.

    Examples
    --------
    >>> from skfem_mpm.studies.methods import orders
    >>> rows = [dict(method="a", h=h, error=h * h, cpu_seconds=1 / h ** 4)
    ...         for h in (1., .5, .25)]
    >>> orders(rows)
    {'a': {'h': 2.0, 'time': 0.5}}
    """
    return {name: {"h": fitted_rate([1. / r["h"] for r in mine],
                                    [r["error"] for r in mine]),
                   "time": fitted_rate([r["cpu_seconds"] for r in mine],
                                       [r["error"] for r in mine])}
            for name, mine in series(rows).items()}


def cheapest(rows: List[dict], target: float) -> Dict[str, dict]:
    """Per series (:func:`series`: a method) the case of least CPU time
    from whose cell size on the ``error`` stays at most ``target`` (that
    grid's and every finer one's: a coarse grid that is right by chance
    does not count), ``None`` where none is.

    Examples
    --------
    >>> from skfem_mpm.studies.methods import cheapest
    >>> rows = [dict(method="a", h=h, error=e, cpu_seconds=t) for h, e, t
    ...         in ((1., .001, 1.), (.5, .05, 3.), (.25, .01, 9.))]
    >>> cheapest(rows, .02)["a"]["cpu_seconds"], cheapest(rows, .005)["a"]
    (9.0, None)
    """
    found = {}
    for name, mine in series(rows).items():
        mine = sorted(mine, key=lambda r: r["h"])
        good = [r for k, r in enumerate(mine)
                if all(f["error"] <= target for f in mine[:k + 1])]
        found[name] = min(good, key=lambda r: r["cpu_seconds"]) \
            if good else None
    return found


def plot_methods(studies: Dict[str, List[dict]], path, titles: Dict[str, str],
                 places: Optional[Dict[str, dict]] = None):
    """One panel per study (``titles`` by its name): each method's error
    against CPU seconds on log axes, its fitted order in the cell size in
    the legend, and in time where the method's CPU times span a factor of
    :data:`TIME_SPAN` (below it the runs' fixed costs dominate and a
    slope says nothing); the legend where ``places`` says by the study's
    name (keyword arguments of matplotlib's ``legend``: ``loc``,
    ``bbox_to_anchor``), else where it hides least; written to ``path``
    (PNG)."""
    from matplotlib.ticker import NullFormatter
    from ..scenes import plot
    from ..scenes.plot import pyplot, series_styles
    fig, axes = pyplot().subplots(1, len(studies),
                                  figsize=(5.5 * len(studies), 4.5))
    for ax, (name, rows) in zip(np.atleast_1d(axes), studies.items()):
        found = orders(rows)
        for style, (method, mine) in zip(series_styles(len(found)),
                                         series(rows).items()):
            mine = sorted(mine, key=lambda r: -r["h"])     # refinement
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
        ax.legend(fontsize=6, **(places or {}).get(name, {}))
    fig.tight_layout()
    plot.save_figure(fig, path)
    return path


def plot_footing(rows: List[dict], path, reference: float):
    """The footing rows of :func:`methods_study` in two panels: each
    method's pressure over ``c_u`` against the settlement over B on the
    finest grid, and each method's pressure at the end against the
    number of cells across B (the series styled alike, the legend on the
    first), both with Prandtl's ``reference`` (a limit load converges
    from above; a method below it is unsafe); written to ``path``
    (PNG)."""
    from matplotlib.ticker import NullFormatter, ScalarFormatter
    from ..scenes import plot
    from ..scenes.plot import pyplot, series_styles
    fig, (curves, ends) = pyplot().subplots(1, 2, figsize=(11, 4.5))
    lines = series(rows)
    for style, (method, mine) in zip(series_styles(len(lines)),
                                     lines.items()):
        mine = sorted(mine, key=lambda r: -r["h"])
        fine = mine[-1]
        curves.plot([0.] + fine["settlement"], [0.] + fine["pressure"],
                    ms=3, lw=.8,
                    label=method, **style)
        ends.plot([FOOTING_WIDTH / r["h"] for r in mine],
                  [r["value"] for r in mine], ms=4, lw=.8, label=method,
                  **style)
    for ax in (curves, ends):
        ax.axhline(reference, color="k", ls="--",
                   label="Prandtl: (2 + pi) c_u")
        ax.set_ylabel("footing pressure / c_u (-)")
    curves.legend(fontsize=7, loc="lower right")
    curves.set_xlabel("settlement / footing width B (-)")
    curves.set_title("Smooth strip footing on the finest grid (B / h = "
                     "{:g}): load-settlement".format(
                         FOOTING_WIDTH / min(r["h"] for r in rows)),
                     fontsize=9)
    ends.set_xscale("log", base=2)
    ends.set_xticks(sorted({FOOTING_WIDTH / r["h"] for r in rows}))
    ends.xaxis.set_major_formatter(ScalarFormatter())
    ends.xaxis.set_minor_formatter(NullFormatter())
    ends.set_xlabel("cells across the footing width, B / h (-)")
    ends.set_title("Pressure at settlement {:g} B against the grid"
                   .format(FOOTING_PUSH), fontsize=9)
    fig.tight_layout()
    plot.save_figure(fig, path)
    return path
