"""Cost of an implicit MPM load step per phase, 2D plane strain.

A square block on a Q1 grid, 2x2 points per cell, fixed base, body force,
two load steps (the second assembles internal forces of moved points).
Prints, per size: seconds per step and points per second for each phase,
and the share of the step spent in the linear solve.

    python benchmarks/step_cost.py [--max-points 1e6]
"""
import argparse
import platform
import time

import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import LinearElastic, point_locator, seed_points, solve_mpm
from skfem_mpm.solver import PHASES


def block(ncells: int):
    x = np.linspace(0., 1., ncells + 1)
    mesh = MeshQuad.init_tensor(x, np.linspace(0., 1.2, int(1.2 * ncells) + 1))
    points = seed_points(mesh, 2, region=lambda p: p[1] < 1.)
    return mesh, points


def run(ncells: int, nsteps: int = 2):
    mesh, points = block(ncells)
    locator = point_locator(mesh)
    tic = time.perf_counter()
    res = solve_mpm(mesh, ElementQuad1(), points, LinearElastic(1e6, .3),
                    lambda b: b.get_dofs(lambda x: x[1] == 0),
                    body_force=[0., -1e3], nsteps=nsteps, locator=locator,
                    keep_snapshots=False)
    wall = (time.perf_counter() - tic) / nsteps
    per_step = {p: t / nsteps for p, t in res.timings().items()}
    return points.n, res.history[-1].n_free_dofs, per_step, wall


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-points", type=float, default=1e6)
    args = parser.parse_args()
    print("machine: {} {}, {} ({})".format(platform.system(),
                                           platform.machine(),
                                           platform.python_version(),
                                           platform.processor() or "cpu"))
    header = "{:>9} {:>8} {:>8} | ".format("points", "dofs", "s/step") + \
        " ".join("{:>16}".format(p) for p in PHASES) + " | solve share"
    print(header)
    print("{:>28} | ".format("") + " ".join(
        "{:>16}".format("s (points/s)") for _ in PHASES))
    for ncells in (16, 50, 158, 500):
        if 4 * ncells ** 2 > args.max_points * 1.01:
            break
        n, dofs, per_step, wall = run(ncells)
        cells = " ".join("{:>16}".format("{:.3f} ({:.1e})".format(
            per_step[p], n / per_step[p] if per_step[p] > 0 else np.inf))
            for p in PHASES)
        print("{:>9} {:>8} {:>8.3f} | {} | {:>6.0%}".format(
            n, dofs, wall, cells, per_step["solve"] / wall), flush=True)


if __name__ == "__main__":
    main()
