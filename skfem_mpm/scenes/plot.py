"""Plots of point results (matplotlib, imported lazily, Agg backend)."""
from typing import Dict, Sequence

import numpy as np

from ..studies.column import analytical_stress, analytical_stress_current, \
    vertical_stress
from .io import atomic_path
from ..solve.results import Result

__all__ = ["pyplot", "save_figure", "draw_column_stress", "draw_convergence",
           "plot_column_stress", "draw_plastic_zone"]


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig, path, dpi: int = 120):
    """Write ``fig`` to ``path`` (PNG) atomically and close it."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    pyplot().close(fig)


def draw_plastic_zone(fig, ax, points, title: str, rigid=None,
                      size: float = 2.):
    """Points (2D, coordinates in m) coloured by their equivalent plastic
    strain, its top 2% clipped so the zone shows beside a singular corner;
    the points where ``rigid`` (bool per point) holds in black."""
    plastic = points.state["equivalent_plastic_strain"]
    soil = np.ones(points.n, dtype=bool) if rigid is None else ~rigid
    sc = ax.scatter(points.x[0, soil], points.x[1, soil], c=plastic[soil],
                    s=size, cmap="viridis",
                    vmax=np.percentile(plastic[soil], 98))
    if rigid is not None:
        ax.scatter(points.x[0, rigid], points.x[1, rigid], c="k", s=size)
    fig.colorbar(sc, ax=ax, label="equivalent plastic strain (-), top 2% "
                 "clipped")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)


def draw_footing_curve(ax, movement: np.ndarray, pressure: np.ndarray,
                       label: str, limit: float, limit_label: str,
                       title: str, motion: str = "settlement",
                       strength: str = "c_u"):
    """A footing's pressure over its strength (``strength``: its symbol)
    against its ``motion`` over its width, with the collapse pressure
    ``limit`` of theory as a dashed line."""
    ax.plot(movement, pressure, "o-", ms=2 if len(movement) > 50 else 3,
            label=label)
    ax.axhline(limit, color="k", ls="--", label=limit_label)
    ax.set_xlabel("{} / footing width B (-)".format(motion))
    ax.set_ylabel("footing pressure / {} (-)".format(strength))
    ax.set_title(title)
    ax.legend(loc="lower right")


def draw_energies(ax, energies: dict, title: str, unit: str = "J",
                  scale: float = 1.):
    """A dynamic run's kinetic energy, work of the internal and external
    forces and what the scheme and the mapping dissipated (external work
    - internal work - kinetic energy) against time; ``energies`` as
    :meth:`skfem_mpm.Result.energies`, divided by ``scale`` (its ``unit``,
    e.g. ``"kJ/m"`` with 1e3 for a 2D run)."""
    t = np.asarray(energies["time"])
    kinetic, internal, external = (np.asarray(energies[k]) / scale for k in (
        "kinetic", "internal_work", "external_work"))
    for values, style, label in ((kinetic, "-", "kinetic energy"),
                                 (internal, "--", "internal work"),
                                 (external, ":", "external work")):
        ax.plot(t, values, style, label=label)
    ax.plot(t, external - internal - kinetic, "-.",
            label="numerical dissipation")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("energy ({})".format(unit))
    ax.set_title(title)
    ax.legend(loc="best")


def draw_column_stress(ax, results: Sequence[Result], labels: Sequence[str],
                       title: str = ""):
    """Vertical stress of the column's points against current height, with
    the linear solution at initial heights and seed (2.27) at current ones
    (a panel of seed Figure 2.9)."""
    for res, label in zip(results, labels):
        pts = res.points
        order = np.argsort(pts.x[-1])
        ax.plot(-vertical_stress(pts)[order], pts.x[-1][order], ".-", ms=3,
                lw=.8, label=label)
    pts = results[0].points
    Y = np.linspace(0., pts.x0[-1].max(), 200)
    ax.plot(-analytical_stress(Y), Y, "k--", lw=1,
            label=r"$\rho_0 b (L_0 - Y)$, initial height")
    top = pts.x[-1].max()
    z = np.linspace(0., top, 200)
    ax.plot(-analytical_stress_current(z, top), z, "k:", lw=1,
            label="(2.27), current height")
    ax.set_xlabel(r"$-\sigma_{yy}$")
    ax.set_ylabel("height")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=6)


def draw_convergence(ax, nelems: np.ndarray, errors: Dict[str, np.ndarray],
                     rates: Dict[str, float], title: str = ""):
    """Error against number of elements on log-log axes, one curve per
    label with its fitted rate (a panel of seed Figure 2.10)."""
    for label, err in errors.items():
        ax.loglog(nelems, err, "o-", ms=3, lw=.8,
                  label="{} (rate {:.2f})".format(label, rates[label]))
    ref = errors[next(iter(errors))][0] * nelems[0] / nelems
    ax.loglog(nelems, ref, "k:", lw=.8, label="slope 1")
    ax.set_xlabel("number of elements")
    ax.set_ylabel("error (2.28)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=6)


def plot_column_stress(results: Sequence[Result], labels: Sequence[str],
                       path, title: str = ""):
    """One stress-profile panel written to ``path`` (PNG)."""
    fig, ax = pyplot().subplots(figsize=(4.5, 4.))
    draw_column_stress(ax, results, labels, title)
    fig.tight_layout()
    save_figure(fig, path)
