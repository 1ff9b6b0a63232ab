"""Set-ups as a new user writes them, nothing tuned: does each complete,
how far from its reference, at what cost.  Prints the table of
``docs/robustness.md``.

Cantilevers: clamped root, end load spread over the tip points,
P L^2 / (E I) = 3 in 20 steps, finite deformation, reference the elastica.
Blocks: a soft block (E = 1e3) squashed by a traction on its top (20% of E)
or sheared (5%), base clamped, 10 steps, reference the finest grid of the
same method (the points' mean top displacement).

Run: ``python benchmarks/user_matrix.py`` (a few minutes on 2 cores).
"""
import time

import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import MPMError, LinearElastic, Traction, seed_points, \
    side_points, simulate
from skfem_mpm.studies.elastica import untuned_cantilever


def block(h, per_cell, method, traction):
    mesh = MeshQuad.init_tensor(np.arange(-.5, 2 + 1e-9, h),
                                np.arange(0, 1.5 + 1e-9, h))
    points = seed_points(mesh, per_cell, region=lambda x: (x[0] > 0)
                         & (x[0] < 1) & (x[1] < 1))
    top = side_points(points, "top")
    res = simulate(mesh, ElementQuad1(), points, LinearElastic(1e3, .3),
                   lambda b: b.get_dofs(lambda x: x[1] == 0),
                   loads=[Traction(top, "top", traction)], nsteps=10,
                   method=method, kinematics="finite")
    return res, res.points.displacement[:, top].mean(axis=1)


def main():
    print("{:10s} {:>5s} {:>4s} {:>7s} {:>10s} {:>9s} {:>6s} {:>7s}".format(
        "set-up", "h", "ppc", "method", "status", "error", "ghost", "s"))
    for h in (.5, .25):
        for per_cell in (2, 4):
            for method in ("mpm", "cpgimp"):
                tic = time.perf_counter()
                try:
                    res, err = untuned_cantilever(h, per_cell, method)
                    row = ("completed", "{:.1e}".format(err),
                           res.counters["ghost_from_step"] or "-")
                except MPMError as e:
                    row = (type(e).__name__[:10], "-", "-")
                print("{:10s} {:5.2f} {:4d} {:>7s} {:>10s} {:>9s} {:>6} "
                      "{:7.1f}".format("cantilever", h, per_cell, method,
                                       *row, time.perf_counter() - tic))
    for name, traction in (("squashed", [0., -200.]),
                           ("sheared", [50., 0.])):
        for method in ("mpm", "cpgimp"):
            fine, u_fine = block(1 / 16, 2, method, traction)
            for h in (.5, .25, .125):
                for per_cell in (2, 4):
                    tic = time.perf_counter()
                    try:
                        res, u = block(h, per_cell, method, traction)
                        row = ("completed", "{:.1e}".format(
                            np.linalg.norm(u - u_fine)
                            / np.linalg.norm(u_fine)),
                            res.counters["ghost_from_step"] or "-")
                    except MPMError as e:
                        row = (type(e).__name__[:10], "-", "-")
                    print("{:10s} {:5.3f} {:4d} {:>7s} {:>10s} {:>9s} {:>6} "
                          "{:7.1f}".format(name, h, per_cell, method, *row,
                                           time.perf_counter() - tic))


if __name__ == "__main__":
    main()
