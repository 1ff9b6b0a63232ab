"""Cost of a Newton iteration with quadratic B-splines against cpGIMP.

The block of ``step_cost.py`` (a unit square of material, 2x2 points per
cell, in a grid two cells wider on each side: ``(2 ncells)^2`` points),
finite deformation (Hencky), elastic, fixed base, its weight in 2 load
steps, every setting the default; methods standard MPM, cpGIMP and
B-splines, at the points and averaged over their domains
(``bspline-gimp``), run in turn ``--repeat`` times (so that a machine
shared with other jobs slows each alike).  Prints per case the CPU and wall seconds
per Newton iteration (the run's over its iterations, the best of the
repeats), the wall seconds per iteration of each phase in the run of
least CPU time (assemble: the point operator, the stresses and the
tangent; solve: condensation, factorisation, substitution; update;
locate), the grid nodes per point of the operator, the non-zeros of the
stiffness per active DOF, and the ratio of the CPU time per iteration to
cpGIMP's.

    python benchmarks/bspline_cost.py [--ncells 50,158] [--repeat 2]
"""
import argparse
import platform
import time

import numpy as np
from skfem import ElementQuad1

from skfem_mpm import LinearElastic, Options, simulate
from skfem_mpm.methods.bspline import QuadraticBSpline
from skfem_mpm.methods.gimp_linear import LinearGimp
from step_cost import block

METHODS = ("cpgimp", "bspline", "bspline-gimp", "mpm")


def run(mesh, points, method):
    """CPU and wall time and result of the block under its weight in 2
    steps."""
    cpu, tic = time.process_time(), time.perf_counter()
    result = simulate(mesh, ElementQuad1(), points, LinearElastic(1e6, .3),
                      lambda b: b.get_dofs(lambda x: x[-1] == 0),
                      body_force=[0., -1e4], nsteps=2, method=method,
                      kinematics="finite",
                      options=Options(keep_snapshots=False))
    return time.process_time() - cpu, time.perf_counter() - tic, result


def operator(mesh, points, method):
    """The method's point operator at the seeded points (standard MPM's
    as GIMP's with domains of 1e-9 of their size)."""
    if method.startswith("bspline"):
        return QuadraticBSpline(mesh, ElementQuad1())(
            points.x, points.domain if method == "bspline-gimp" else None)
    return LinearGimp(mesh, ElementQuad1())(
        points.x, points.domain * (1. if method == "cpgimp" else 1e-9))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ncells", default="50,158",
                        help="cells per side of the block, comma-separated")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print("machine: {} {}, Python {}, numpy {}".format(
        platform.system(), platform.machine(), platform.python_version(),
        np.__version__))
    print("{:>7} {:>12} {:>4} {:>7} {:>7} | {:>8} {:>8} {:>8} {:>8} | {:>5}"
          " {:>6} | {:>6}".format("points", "method", "its", "cpu/it",
                                  "wall/it", "assemble", "solve", "update",
                                  "locate", "nodes", "nnz/N", "/cpgimp"))
    for ncells in (int(n) for n in args.ncells.split(",")):
        mesh, points = block(ncells)
        runs = {method: [] for method in METHODS}
        for _ in range(args.repeat):
            for method in METHODS:
                runs[method].append(run(mesh, points, method))
        per_iteration = {}
        for method in METHODS:
            cpu, _, result = min(runs[method], key=lambda r: r[0])
            wall = min(r[1] for r in runs[method])
            its = result.counters["newton_iterations"]
            t = result.timings()
            op = operator(mesh, points, method)
            K = op.stiffness(np.broadcast_to(
                np.ones((2, 2, 2, 2, 1)), (2, 2, 2, 2, points.n)),
                points.volume)
            per_iteration[method] = cpu / its
            print("{:>7} {:>12} {:>4} {:>7.4f} {:>7.4f} | {:>8.4f} {:>8.4f} "
                  "{:>8.4f} {:>8.4f} | {:>5.2f} {:>6.1f} | {:>6.2f}".format(
                      points.n, method, its, cpu / its, wall / its,
                      t["assemble"] / its, t["solve"] / its,
                      t["update"] / its, t["locate"] / its,
                      op.S.nnz / points.n, K.nnz / len(op.active_dofs),
                      per_iteration[method] / per_iteration["cpgimp"]),
                  flush=True)


if __name__ == "__main__":
    main()
