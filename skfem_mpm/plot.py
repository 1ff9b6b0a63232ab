"""Plots of point results (matplotlib, imported lazily)."""
from typing import Sequence

import numpy as np

from .column import analytical_stress, analytical_stress_current, \
    vertical_stress
from .io import atomic_path
from .solver import Result

__all__ = ["plot_column_stress"]


def plot_column_stress(results: Sequence[Result], labels: Sequence[str],
                       path, title: str = ""):
    """Vertical stress of the column's points against height, with the
    linear solution at initial heights and seed (2.27) at current ones
    (seed Figure 2.9).  Written atomically to ``path`` (PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.5, 4.))
    for res, label in zip(results, labels):
        pts = res.points
        order = np.argsort(pts.x[-1])
        ax.plot(-vertical_stress(pts)[order], pts.x[-1][order], ".-", ms=3,
                lw=.8, label=label)
    pts = results[0].points
    Y = np.linspace(0., pts.x0[-1].max(), 200)
    ax.plot(-analytical_stress(Y), Y, "k--", lw=1,
            label=r"$\rho_0 b (L_0 - Y)$ at initial height")
    top = pts.x[-1].max()
    z = np.linspace(0., top, 200)
    ax.plot(-analytical_stress_current(z, top), z, "k:", lw=1,
            label="(2.27) at current height")
    ax.set_xlabel(r"$-\sigma_{yy}$")
    ax.set_ylabel("height")
    ax.set_title(title)
    ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
