"""One finite-deformation load step of a large block: time per phase and
peak memory (does a step of this size fit the machine?).

The block of ``step_cost.py`` with ``--ncells`` cells a side (3D:
``(2 ncells)^3`` points, 2x2x2 per cell; 63 cells: 1984500 points),
standard MPM, Hencky elasticity, body force; prints the free DOFs, the
wall time, seconds per phase, Newton iterations and final residual, the
peak growth of the resident set during the step (sampled, the solver's
memory included) and the process's peak.

    python benchmarks/large_step.py [--ncells 63] [--dim 3] [--solver pyamg]
"""
import argparse
import resource
import time

import numpy as np
from skfem import ElementHex1, ElementQuad1

from skfem_mpm import LinearElastic, Options, solve_finite
from skfem_mpm.studies.study import PeakMemory
from step_cost import block


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ncells", type=int, default=63)
    parser.add_argument("--dim", type=int, default=3, choices=(2, 3))
    parser.add_argument("--solver", default="pyamg")
    args = parser.parse_args()
    mesh, points = block(args.ncells, args.dim)
    print("{} points, {} cells, solver {}".format(points.n, mesh.nelements,
                                                  args.solver), flush=True)
    with PeakMemory() as memory:
        tic = time.perf_counter()
        result = solve_finite(
            mesh, (ElementQuad1 if args.dim == 2 else ElementHex1)(), points,
            LinearElastic(1e6, .3), lambda b: b.get_dofs(lambda x: x[-1] == 0),
            body_force=np.r_[np.zeros(args.dim - 1), -1e4], nsteps=1,
            options=Options(keep_snapshots=False, solver=args.solver))
        wall = time.perf_counter() - tic
    print("free DOFs {}, wall {:.1f} s, phases {}, {} Newton iterations, "
          "residual {:.1e}".format(
              result.history[-1].n_free_dofs, wall,
              {k: round(v, 1) for k, v in result.timings().items()},
              result.counters["newton_iterations"],
              result.history[-1].residual))
    print("peak resident-set growth {:.2f} GB ({:.0f} B per point), process "
          "peak {:.2f} GB".format(
              memory.peak / 1e9, memory.peak / points.n,
              resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6))


if __name__ == "__main__":
    main()
