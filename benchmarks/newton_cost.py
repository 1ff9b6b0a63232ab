"""What modified Newton saves, and what its linear convergence costs.

The block of ``step_cost.py`` (2D: ``(2 ncells)^2`` points; 3D:
``(2 ncells)^3``), finite deformation, 3 load steps, elastic (Hencky) and
von Mises (yield stress 8e3 under a weight of 1e4: a plastic zone at the
base), standard MPM and cpGIMP (2D), with ``newton="full"`` and
``"modified"``.  Prints per case the wall time of the run (best of
``--repeat``), Newton iterations, factorisations, the seconds per phase,
and the largest difference between the two final point positions
relative to the largest displacement.

    python benchmarks/newton_cost.py [--ncells 50,158] [--dim 2]
        [--solver auto] [--repeat 2]
"""
import argparse
import platform
import time

import numpy as np
from skfem import ElementHex1, ElementQuad1

from skfem_mpm import (LinearElastic, NewtonOptions, Options, VonMises,
                       simulate)
from step_cost import block

ELEMENTS = {2: ElementQuad1, 3: ElementHex1}


def run(mesh, points, material, method, newton, solver, dim):
    tic = time.perf_counter()
    result = simulate(mesh, ELEMENTS[dim](), points, material,
                      lambda b: b.get_dofs(lambda x: x[-1] == 0),
                      body_force=np.r_[np.zeros(dim - 1), -1e4], nsteps=3,
                      method=method, kinematics="finite",
                      options=Options(NewtonOptions(newton=newton),
                                      keep_snapshots=False, solver=solver))
    return time.perf_counter() - tic, result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ncells", default="50,158",
                        help="cells per side of the block, comma-separated")
    parser.add_argument("--dim", type=int, default=2, choices=(2, 3))
    parser.add_argument("--solver", default="auto")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    print("machine: {} {}, Python {}, solver {}, {}D".format(
        platform.system(), platform.machine(), platform.python_version(),
        args.solver, args.dim))
    print("{:>8} {:>10} {:>7} {:>9} {:>7} {:>5} {:>5} | {} | {:>9}".format(
        "points", "material", "method", "newton", "s/run", "its", "facts",
        "assemble solve update (s)", "|dx|/|u|"))
    methods = ("mpm", "cpgimp") if args.dim == 2 else ("mpm",)
    for ncells in (int(n) for n in args.ncells.split(",")):
        mesh, points = block(ncells, args.dim)
        for name, material in (("elastic", LinearElastic(1e6, .3)),
                               ("von Mises", VonMises(1e6, .3, 8e3))):
            for method in methods:
                results = {}
                for newton in ("full", "modified"):
                    best, result = min(
                        (run(mesh, points, material, method, newton,
                             args.solver, args.dim)
                         for _ in range(args.repeat)), key=lambda r: r[0])
                    results[newton] = result
                    t, c = result.timings(), result.counters
                    difference = np.abs(
                        result.points.x - results["full"].points.x).max() \
                        / np.abs(results["full"].points.displacement).max()
                    print("{:>8} {:>10} {:>7} {:>9} {:>7.2f} {:>5} {:>5} | "
                          "{:>8.2f} {:>5.2f} {:>6.2f}     | {:>9.1e}".format(
                              points.n, name, method, newton, best,
                              c["newton_iterations"], c["factorisations"],
                              t["assemble"], t["solve"], t["update"],
                              difference), flush=True)


if __name__ == "__main__":
    main()
