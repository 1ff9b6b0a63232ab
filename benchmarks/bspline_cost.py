"""Cost of a Newton iteration with quadratic and cubic B-splines and cpGIMP.

The block of ``step_cost.py`` (a unit square of material, 2x2 points per
cell, in a grid two cells wider on each side: ``(2 ncells)^2`` points),
finite deformation (Hencky), elastic, fixed base, its weight in 2 load
steps, every setting the default; methods standard MPM, cpGIMP and
B-splines, quadratic and cubic (``bspline3``), at the points and
averaged over their domains (``bspline-gimp``, ``bspline3-gimp``), run
in turn ``--repeat`` times (so that a machine
shared with other jobs slows each alike).  Prints per case the CPU and wall seconds
per Newton iteration (the run's over its iterations, the best of the
repeats), the wall seconds per iteration of each phase in the run of
least CPU time (assemble: the point operator, the stresses and the
tangent; solve: condensation, factorisation, substitution; update;
locate), the grid nodes per point of the operator, the non-zeros of the
stiffness per active DOF, and the ratio of the CPU time per iteration to
cpGIMP's.

With ``--extended`` the B-spline methods run with
``Stabilisation(extended_splines=True)`` (no ghost penalty in reserve):
the averaged cubic splines' default run of this block switches the
ghost penalty on at step 2 (docs/bspline.md, slivers), which the
extension makes unnecessary.

    python benchmarks/bspline_cost.py [--ncells 50,158] [--repeat 2]
        [--methods cpgimp,bspline3] [--extended]
"""
import argparse
import platform
import time

import numpy as np
from skfem import ElementQuad1

from skfem_mpm import LinearElastic, Options, Stabilisation, simulate
from skfem_mpm.methods.bspline import CubicBSpline, QuadraticBSpline
from skfem_mpm.methods.gimp_linear import LinearGimp
from step_cost import block

METHODS = ("cpgimp", "bspline", "bspline-gimp", "bspline3", "bspline3-gimp",
           "mpm")


def run(mesh, points, method, extended=False):
    """CPU and wall time and result of the block under its weight in 2
    steps (``extended``: B-splines extended)."""
    cpu, tic = time.process_time(), time.perf_counter()
    result = simulate(mesh, ElementQuad1(), points, LinearElastic(1e6, .3),
                      lambda b: b.get_dofs(lambda x: x[-1] == 0),
                      body_force=[0., -1e4], nsteps=2, method=method,
                      kinematics="finite",
                      options=Options(keep_snapshots=False,
                                      stabilisation=Stabilisation(
                                          extended_splines=extended
                                          and method.startswith("bspline"))))
    return time.process_time() - cpu, time.perf_counter() - tic, result


def operator(mesh, points, method):
    """The method's point operator at the seeded points (standard MPM's
    as GIMP's with domains of 1e-9 of their size)."""
    if method.startswith("bspline"):
        spline = CubicBSpline if method.startswith("bspline3") \
            else QuadraticBSpline
        return spline(mesh, ElementQuad1())(
            points.x, points.domain if method.endswith("-gimp") else None)
    return LinearGimp(mesh, ElementQuad1())(
        points.x, points.domain * (1. if method == "cpgimp" else 1e-9))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ncells", default="50,158",
                        help="cells per side of the block, comma-separated")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--extended", action="store_true",
                        help="B-splines with extended_splines=True")
    parser.add_argument("--methods", default=",".join(METHODS),
                        help="comma-separated, cpgimp first (the ratio's "
                        "reference)")
    args = parser.parse_args()
    methods = args.methods.split(",")
    if methods[0] != "cpgimp" or not set(methods) <= set(METHODS):
        parser.error("--methods: cpgimp first, then any of {}".format(
            ", ".join(METHODS[1:])))
    print("machine: {} {}, Python {}, numpy {}".format(
        platform.system(), platform.machine(), platform.python_version(),
        np.__version__))
    print("{:>7} {:>13} {:>4} {:>7} {:>7} | {:>8} {:>8} {:>8} {:>8} | {:>5}"
          " {:>6} | {:>6}".format("points", "method", "its", "cpu/it",
                                  "wall/it", "assemble", "solve", "update",
                                  "locate", "nodes", "nnz/N", "/cpgimp"))
    for ncells in (int(n) for n in args.ncells.split(",")):
        mesh, points = block(ncells)
        runs = {method: [] for method in methods}
        for _ in range(args.repeat):
            for method in methods:
                runs[method].append(run(mesh, points, method,
                                        args.extended))
        per_iteration = {}
        for method in methods:
            cpu, _, result = min(runs[method], key=lambda r: r[0])
            wall = min(r[1] for r in runs[method])
            its = result.counters["newton_iterations"]
            t = result.timings()
            op = operator(mesh, points, method)
            K = op.stiffness(np.broadcast_to(
                np.ones((2, 2, 2, 2, 1)), (2, 2, 2, 2, points.n)),
                points.volume)
            per_iteration[method] = cpu / its
            print("{:>7} {:>13} {:>4} {:>7.4f} {:>7.4f} | {:>8.4f} {:>8.4f} "
                  "{:>8.4f} {:>8.4f} | {:>5.2f} {:>6.1f} | {:>6.2f}".format(
                      points.n, method, its, cpu / its, wall / its,
                      t["assemble"] / its, t["solve"] / its,
                      t["update"] / its, t["locate"] / its,
                      op.S.nnz / points.n, K.nnz / len(op.active_dofs),
                      per_iteration[method] / per_iteration["cpgimp"]),
                  flush=True)


if __name__ == "__main__":
    main()
