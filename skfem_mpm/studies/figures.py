"""Figures of studies: the seed column's stress profile and its error over
refinement (panels of seed Figures 2.9 and 2.10), and the figures of an
accuracy-against-cost study (:func:`plot_study`).

Drawn with the helpers of :mod:`skfem_mpm.scenes.plot` (matplotlib,
imported lazily, Agg backend), so they explain themselves as every figure
there does.

"""
from pathlib import Path
from typing import Dict, Sequence

import numpy as np

from ..scenes import plot  # save_figure looked up when called: tests wrap it
from ..scenes.plot import pyplot, series_styles
from ..solve.results import PHASES, Result
from .column import HEIGHT, SOURCE, analytical_stress, vertical_stress
from .study import (VARIABLES, above_roundoff, error_floor, fitted_rate,
                    levelling_off, not_falling, own_apart, percent)

__all__ = ["draw_column_stress", "draw_convergence", "pareto_front",
           "plot_column_stress", "plot_study"]


def draw_column_stress(ax, results: Sequence[Result], labels: Sequence[str],
                       title: str = "", unit: str = "Pa"):
    """Vertical stress of the column's points against their *initial*
    height ``Y``, with the closed form ``-rho0 b (L0 - Y)`` at the same
    heights (a panel of seed Figure 2.9); ``unit``: the stress's
    (:func:`~skfem_mpm.scenes.units.unit`).

    One coordinate for both: the points had been drawn at their current
    heights and the closed form at initial ones on one "height" axis (a
    trial).  The initial height is the one where the closed form is the
    exact Cauchy stress of any elastic law on rollers (the weight above
    over an unchanged area), small strain or finite, and where (2.28)
    compares (:func:`~skfem_mpm.studies.column.column_error`); seed
    (2.27), its law's stress at current heights, is the same line mapped
    to initial heights (:func:`~skfem_mpm.studies.column.
    analytical_stress_current`)."""
    dim = 1
    for res, label in zip(results, labels):
        pts = res.points
        dim = pts.dim
        order = np.argsort(pts.x0[-1])
        ax.plot(-vertical_stress(pts)[order], pts.x0[-1][order], ".-",
                ms=3, lw=.8, label=label)
    Y = np.linspace(0., HEIGHT, 200)
    ax.plot(-analytical_stress(Y), Y, "k--", lw=1,
            label=r"$\rho_0 b (L_0 - Y)$, exact for any elastic law")
    # the field drawn is stress[d, d]: sigma_xx in 1D (a trial: the same
    # run's final_stress.png and VTU said sigma_xx, this one sigma_yy)
    name = "xyz"[dim - 1] * 2
    ax.set_xlabel(r"$-\sigma_{" + name + r"}$, Cauchy stress, compression "
                  "positive (" + unit + ")")
    ax.set_ylabel("initial height Y of the points (m)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8, loc="upper right")


def draw_convergence(ax, nelems: np.ndarray, errors: Dict[str, np.ndarray],
                     rates: Dict[str, object], title: str = ""):
    """Error against number of elements on log-log axes, one curve per
    label with its rate (a panel of seed Figure 2.10): a number, or words
    where the errors have none (``"no rate: ..."``, as
    ``examples/column.py`` judges them)."""
    for label, err in errors.items():
        rate = rates[label]
        ax.loglog(nelems, err, "o-", ms=3, lw=.8, label="{} ({})".format(
            label, rate if isinstance(rate, str)
            else "rate {:.2f}".format(rate)))
    ref = errors[next(iter(errors))][0] * nelems[0] / nelems
    ax.loglog(nelems, ref, "k:", lw=.8, label="slope 1")
    ax.set_xlabel("number of elements (-)")
    ax.set_ylabel("error measure (2.28) of {} (-)".format(SOURCE))
    ax.set_title(title, fontsize=9)
    # below the axes: inside, the verdicts' words covered the curves (a
    # trial: 5 pt over the 2-step panel's data)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(.5, -.18))


def plot_column_stress(results: Sequence[Result], labels: Sequence[str],
                       path, title: str = "", unit: str = "Pa"):
    """One stress-profile panel written to ``path`` (PNG), the stress in
    ``unit``."""
    fig, ax = pyplot().subplots(figsize=(4.5, 4.))
    draw_column_stress(ax, results, labels, title, unit)
    fig.tight_layout()
    plot.save_figure(fig, path)


def _finish(fig, ax, xlabel: str, ylabel: str, title: str, path):
    """Label, title, legend and write one study figure."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    plot.save_figure(fig, path)
    return path


def _known(values) -> np.ndarray:
    """``values`` as floats, an unknown one (None) as NaN."""
    return np.array([np.nan if v is None else v for v in values], float)


def _loglog(ax, x, y, style: dict, label: str, line: bool = True,
            bound=None):
    """Positive ``y`` against ``x`` on log axes, with a bar up to
    ``bound`` (each case's uncertainty: what its error may reach) where
    one is known."""
    x, y = _known(x), _known(y)
    ok = np.isfinite(y) & (y > 0)
    ax.loglog(x[ok], y[ok], ms=3, lw=.8 if line else 0, label=label,
              **style)
    if bound is not None:
        up = _known(bound)
        bar = ok & np.isfinite(up) & (up > y)
        if bar.any():
            ax.errorbar(x[bar], y[bar], yerr=[np.zeros(bar.sum()),
                                              up[bar] - y[bar]],
                        fmt="none", ecolor=style["color"], elinewidth=.6,
                        capsize=2)


#: the legend's words for a case drawn at its uncertainty
UNKNOWN_ERROR = "finest case, no extrapolation: its error unknown,\n" \
    "drawn at its uncertainty (at most that)"


def _unknown(ax, x, rows: list, style: dict, named: bool) -> bool:
    """Draw the ``rows`` whose error is unknown but bounded (the finest
    case of a group where nothing was extrapolated) at their uncertainty
    against ``x``, as open triangles pointing down (the error is at most
    that), named in the legend unless ``named`` already; returns whether
    the legend now names them."""
    x = _known(x)
    error = _known([r.get("error") for r in rows])
    up = _known(_bounds(rows))
    drawn = ~np.isfinite(error) & np.isfinite(up) & (up > 0)
    if not drawn.any():
        return named
    ax.loglog(x[drawn], up[drawn], "v", ms=6, mfc="none", lw=0,
              color=style["color"], gid="unknown error",
              label=None if named else UNKNOWN_ERROR)
    return True


def _bounds(rows: list) -> list:
    """Each case's uncertainty, the bound of its error (None against a
    closed form)."""
    return [r.get("uncertainty") for r in rows]


def _bars(measured: dict) -> str:
    """What the bars of an error plot show, for its title."""
    return "" if measured["error"].get("closed_form", True) else \
        ";\nbars up to each case's uncertainty"


def _convergence(measured: dict, row: dict):
    """The convergence of the error's quantity in ``row``'s group
    (``None`` where there is none: a closed form's error)."""
    mine = {k: row[k] for k in VARIABLES
            if k != "elements" and row.get(k) is not None}
    return next((c for c in measured["convergence"] if c["choices"] == mine
                 and c["quantity"] == measured["error"].get("quantity")),
                None)


def curve_label(measured: dict, name: str, rows: list) -> str:
    """The legend of the curve of a group's errors against elements
    (``rows``, coarse to fine): its rate where the error has one (a
    closed form, or the reference extrapolated), fitted to the errors
    above round-off (:func:`~skfem_mpm.studies.study.above_roundoff`),
    else words: a group whose values converged to round-off has none (a
    trial's push, within 2.6e-9 of Coulomb's answer, was given a rate).

    >>> from skfem_mpm.studies.figures import curve_label
    >>> measured = {"error": {"closed_form": True, "roundoff": 1e-8},
    ...             "convergence": []}
    >>> rows = [dict(elements=n, error=e) for n, e in
    ...         ((8, 4e-3), (16, 1e-3), (32, 2e-9))]
    >>> curve_label(measured, "mpm", rows)
    'mpm (rate 2.00, errors at round-off left out)'
    """
    c = _convergence(measured, rows[0])
    if c is not None and c.get("basis") == "round-off":
        return "{} (converged to round-off: no rate)".format(name)
    if not measured["error"].get("closed_form", True) and not (
            c is not None and c["against"] == "richardson"):
        return "{} (no extrapolation: distance to the finest case)".format(
            name)
    x = [r["elements"] for r in rows]
    y = above_roundoff([r["error"] for r in rows], error_floor(measured, c))
    noise = any(e is None and r["error"] is not None
                and np.isfinite(r["error"]) for r, e in zip(rows, y))
    rate = fitted_rate(x, y)
    if not np.isfinite(rate):
        return "{} ({})".format(name, "errors at round-off: no rate"
                                if noise else "no rate")
    if not_falling(x, y):
        return "{} (errors not falling: no rate)".format(name)
    return "{} (rate {:.2f}{}{})".format(
        name, rate, ", levelling off" if levelling_off(x, y, rate) else "",
        ", errors at round-off left out" if noise else "")


def _disagreement(ax, measured: dict) -> None:
    """Where groups' references of the error's quantity disagree
    (:func:`~skfem_mpm.studies.study.disagreements`), a line at the
    widest distance: each case's error is measured against its own
    group's reference, so an error below the line does not show that the
    case is that close to the problem's answer (a user trial's study
    drew B-splines at 0.2% where the methods' references lay 1.4%
    apart)."""
    apart = [d["apart"] for d in measured.get("disagreements", ())
             if d["quantity"] == measured["error"].get("quantity")]
    if apart:
        ax.axhline(max(apart), color="0.3", ls="--", lw=.8, label=(
            "groups' references {} apart: errors are against each "
            "group's own,\nso the answer is not shown to be closer than "
            "this".format(percent(max(apart)))))


def _failed_mark(ax, x: float, style: dict, elements: int, error: str,
                 load_factor=None) -> None:
    """A dashed vertical line at a failed case (``x``: its elements or
    cell size), named in the legend: a figure without it left a trial's
    failed finest case out unmarked, its curve ending at the grid
    before."""
    ax.axvline(x, color=style["color"], ls="--", lw=.8, label=(
        "{} elements failed: {}{}".format(
            elements, error, "" if load_factor is None else
            " after load factor {:g}".format(load_factor))))


def _group_name(choices: dict) -> str:
    """The name of a study's group of cases (a row or a convergence
    group's ``choices``): its choices but the elements, in one order."""
    return ", ".join("{}={}".format(k, choices[k]) for k in (
        "method", "rhs", "line_search", "newton", "ppc", "loadsteps")
        if choices.get(k) is not None) or "all"


#: CPU seconds below which a case is mostly fixed cost (set-up, the
#: first assembly, the solver's start): a trial's column cases under
#: ~0.2 s repeated only within 10-25% from one run of a study to the next
FIXED_COST_SECONDS = .2


def _fixed_cost_note(rows: list) -> str:
    """A line for a time figure where some cases took under
    :data:`FIXED_COST_SECONDS`, else ``""``."""
    quick = sum(_cost(r) < FIXED_COST_SECONDS for r in rows)
    if not quick:
        return ""
    return ("\n{} of {} cases under {:g} s: mostly fixed cost, their times "
            "repeat only within 10-25%".format(quick, len(rows),
                                               FIXED_COST_SECONDS))


def _cost(r: dict) -> float:
    """A case's CPU seconds (its wall seconds in studies from before
    they were recorded)."""
    return r.get("cpu_seconds", r["wall_seconds"])


def _reference_label(c: dict) -> str:
    """What a group's reference line and band are."""
    if c["against"] == "richardson":
        return "extrapolated with the {} order {:.2f}, band: its " \
            "uncertainty ({:g} x the error estimate)".format(
                "observed" if c.get("basis") == "observed order" else
                "fixed", c["order"], c.get("safety_factor") or 1.25)
    if c["uncertainty"] is None:
        return "the only case (no uncertainty)"
    return "finest case (no extrapolation), band: 3 x the data range"


def pareto_front(rows: list) -> list:
    """``(CPU seconds, error)`` of the cases no other case beats in both
    (:func:`_cost`), cheapest first; cases of unknown error (None, NaN)
    are left out.

    >>> from skfem_mpm.studies.figures import pareto_front
    >>> pareto_front([dict(cpu_seconds=t, wall_seconds=t, error=e)
    ...               for t, e in ((1., .1), (2., .2), (3., .05),
    ...                            (4., None))])
    [(1.0, 0.1), (3.0, 0.05)]
    """
    front, best = [], np.inf
    for r in sorted(rows, key=_cost):
        error = r.get("error")
        if error is not None and 0 < error < best:
            best = error
            front.append((_cost(r), error))
    return front


def plot_study(rows: list, outdir, measured: dict) -> list:
    """The figures of a study (:func:`~skfem_mpm.studies.study.study`;
    ``measured`` from :func:`~skfem_mpm.studies.study.analyse`): (a) the
    error against elements with the fitted rate per curve (where its
    reference was extrapolated or is a closed form), (b) the error
    against CPU time with the Pareto front, both with bars up to each
    case's uncertainty where the error has one (a case whose error is
    unknown, the finest of a group where nothing was extrapolated, drawn
    at its uncertainty), (c) time per phase and
    load step against points with exponents fitted over all cases (every
    method pooled), (d) each quantity of
    interest against the cell size with each value's uncertainty, and
    each group's reference and its uncertainty band.  Returns the files
    written."""
    plt = pyplot()
    outdir = Path(outdir)
    ok = [r for r in rows if not r.get("failure")]
    written = []
    label = measured["error"]["label"]
    ylabel = "{} (-)".format(label)
    refined = ok and "elements" in ok[0]
    # a group keeps its style in every figure (a user trial read mpm and
    # fem in swapped colours from one figure to the next): the curves of
    # a refinement, else the methods
    curves = {}
    for r in ok:
        curves.setdefault(_group_name(r) if refined else r.get(
            "method", "all cases"), []).append(r)
    styles = dict(zip(sorted(curves), series_styles(len(curves))))
    if refined:
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        named = False
        for name, rs in sorted(curves.items()):
            style = styles[name]
            rs = sorted(rs, key=lambda r: r["elements"])
            x = [r["elements"] for r in rs]
            y = [r["error"] for r in rs]
            _loglog(ax, x, y, style, curve_label(measured, name, rs),
                    bound=_bounds(rs))
            named = _unknown(ax, x, rs, style, named)
        for r in rows:
            if r.get("failure") and _group_name(r) in styles:
                _failed_mark(ax, r["elements"], styles[_group_name(r)],
                             r["elements"], r["failure"].split(":")[0])
        _disagreement(ax, measured)
        written.append(_finish(
            fig, ax, "elements along the most refined axis (-)", ylabel,
            "{} over grid refinement,\nagainst {}{}".format(
                label, measured["error"]["against"], _bars(measured)),
            outdir / "error_vs_elements.png"))
    if ok:
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        named = False
        for name, rs in sorted(curves.items()):
            _loglog(ax, [_cost(r) for r in rs], [r["error"] for r in rs],
                    styles[name], name, line=False, bound=_bounds(rs))
            named = _unknown(ax, [_cost(r) for r in rs], rs, styles[name],
                             named)
        front = pareto_front(ok)
        if len(front) > 1:
            ax.loglog(*zip(*front), "k-", lw=.8, label="Pareto front (cases "
                      "of known error)")
        elif front:             # a line of one point draws nothing
            ax.loglog(*zip(*front), "ko", ms=8, mfc="none", lw=0,
                      label="Pareto front: one case, the cheapest of "
                      "least known error")
        _disagreement(ax, measured)
        own = own_apart(measured)
        written.append(_finish(
            fig, ax, "CPU time per case (s)", ylabel,
            "What accuracy costs: {} against CPU time,\nthe error "
            "against {}{}{}{}".format(
                label, measured["error"]["against"], _bars(measured),
                ";\neach group's against its own reference, {} apart"
                .format(percent(own)) if own is not None else "",
                _fixed_cost_note(ok)),
            outdir / "error_vs_time.png"))
    if ok:
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        points = np.array([r["points"] for r in ok], float)
        steps = np.array([max(r["steps_run"], 1) for r in ok], float)
        # the exponents pool every case: methods, solvers, points per cell
        methods = sorted({str(r["method"]) for r in ok if "method" in r})
        pooled = ", pooling the methods {}".format(", ".join(methods)) \
            if len(methods) > 1 else ""
        for style, p in zip(series_styles(len(PHASES)), PHASES):
            t = np.array([r["t_" + p] for r in ok]) / steps
            good = t > 0
            name = p
            if np.unique(points[good]).size >= 2:  # an exponent needs sizes
                slope = np.polyfit(np.log(points[good]), np.log(t[good]),
                                   1)[0]
                name = "{} (exponent {:.2f})".format(p, slope)
            if good.any():
                _loglog(ax, points[good], t[good], style, name, line=False)
        written.append(_finish(
            fig, ax, "material points (-)", "time per load step (s)",
            "Cost of each phase per load step against the points;\n"
            "each exponent fitted over the cases of the {} with a time "
            "in its phase{}{}".format(len(ok), pooled, _fixed_cost_note(ok)),
            outdir / "time_vs_points.png"))
    convergence = [c for c in measured["convergence"] if c["cell_sizes"]]
    if convergence:
        names = list(dict.fromkeys(c["quantity"] for c in convergence))
        # each panel 3.2 in and its legend below it (8 pt: a curve and
        # a reference a group, and its failed cases)
        tall = [3.2 + (.19 * sum(
            2 + len(c.get("failed", ())) for c in convergence
            if c["quantity"] == n)) for n in names]
        fig, axes = plt.subplots(len(names), 1, squeeze=False, figsize=(
            10., sum(tall)), gridspec_kw={"height_ratios": tall})
        for ax, name in zip(axes[:, 0], names):
            mine = [c for c in convergence if c["quantity"] == name]
            for c in mine:
                style = styles[_group_name(c["choices"])]
                order = np.argsort(c["cell_sizes"])[::-1]
                h = np.asarray(c["cell_sizes"])[order]
                f = np.asarray(c["values"])[order]
                ax.semilogx(h, f, ms=3, lw=.8, label=", ".join(
                    "{}={}".format(k, v) for k, v in c["choices"].items())
                    or "all", **style)
                bars = _known(c.get("absolute_uncertainties")
                              or [None] * f.size)
                bars = bars[order]
                if np.isfinite(bars).any():
                    ax.errorbar(h, f, yerr=np.where(np.isfinite(bars), bars,
                                                    0.), fmt="none",
                                ecolor=style["color"], elinewidth=.6,
                                capsize=2)
                ax.axhline(c["reference"], color=style["color"], lw=.6,
                           ls=":", label=_reference_label(c))
                for failed in c.get("failed", ()):
                    _failed_mark(ax, failed["cell_size"], style,
                                 failed["elements"], failed["error"],
                                 failed["load_factor"])
                if c["uncertainty"] is not None:
                    ax.axhspan(c["reference"] - c["uncertainty"],
                               c["reference"] + c["uncertainty"],
                               color=style["color"], alpha=.12)
            ax.invert_xaxis()
            ax.ticklabel_format(axis="y", useOffset=False)
            ax.set_ylabel("{} ({})".format(name, mine[0]["unit"]))
            ax.set_xlabel("cell size (V/N)^(1/d) (m)")
            ax.set_title("{} over refinement, with the reference of each "
                         "group;\nbars and bands: uncertainties".format(name),
                         fontsize=9)
            # below the panel: inside, a group's entries and references
            # covered the lower panel's data (a user trial); beside it
            # at 8 pt its long entries narrowed the panel under its title
            ax.legend(fontsize=8, loc="upper center",
                      bbox_to_anchor=(.5, -.22))
        fig.tight_layout()
        plot.save_figure(fig, outdir / "quantities.png")
        written.append(outdir / "quantities.png")
    return written
