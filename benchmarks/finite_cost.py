"""Accuracy and cost of finite-deformation MPM and GIMP.

Column under self weight (plane strain, one element wide, 2x2 points per
cell, 20 load steps) from 2^2 to 2^10 elements with standard MPM and
cpGIMP: error, Newton iterations, seconds per load step and the share of
each phase.  Then the large-deflection cantilever at h = 0.5 and 0.25.

    python benchmarks/finite_cost.py
"""
import sys
import time
from pathlib import Path

import numpy as np

from skfem_mpm import Options, seed_points, solve_finite
from skfem_mpm.studies.column import (LOAD, MATERIAL, column_error, column_grid,
                              column_supports)
from skfem_mpm.solve.results import PHASES

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "examples"))


def row(label, result, seconds, error=None):
    timings = result.timings()
    total = sum(timings.values())
    iterations = [len(r.newton_residuals) - 1 for r in result.history]
    print("{:>24} {:>7} {:>10} {:>6.2f} {:>9.4f} | {}".format(
        label, result.points.n,
        "-" if error is None else "{:.3e}".format(error),
        np.mean(iterations), seconds / len(result.history),
        " ".join("{:>8.0%}".format(timings[p] / total) for p in PHASES)),
        flush=True)


def main():
    print("{:>24} {:>7} {:>10} {:>6} {:>9} | {}".format(
        "case", "points", "error", "iters", "s/step",
        " ".join("{:>8}".format(p) for p in PHASES)))
    for method in ("mpm", "cpgimp"):
        for k in range(2, 11):
            mesh, elem = column_grid(2 ** k, dim=2)
            tic = time.perf_counter()
            res = solve_finite(mesh, elem, seed_points(mesh, 2), MATERIAL,
                               column_supports(2), body_force=[0., -LOAD],
                               nsteps=20, method=method,
                               options=Options(keep_snapshots=False))
            row("column {} {:4d} el".format(method, 2 ** k), res,
                time.perf_counter() - tic, column_error(res.points))
    import cantilever
    for h in (.5, .25):
        tic = time.perf_counter()
        res, alpha, v, u = cantilever.cantilever(h=h)
        row("cantilever h={}".format(h), res, time.perf_counter() - tic)


if __name__ == "__main__":
    main()
