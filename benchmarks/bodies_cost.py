"""Scenes of several bodies on the compiled passes against the numpy path
(issue 32, the nineteenth round): a Newton iteration's cost per point.

The block of ``step_cost.py`` (2D, standard MPM, finite deformation, one
load step under its weight) as soil, ``MohrCoulomb(1e6, 0.3,
cohesion=3e3, friction_angle=30, dilation_angle=5)``, with a pile down
its middle (the points within a tenth of the block's width of its axis:
body 1, ``LinearElastic(1e7, 0.25)``), bonded to the soil (one field);
beside it the same block of soil alone (one body: the per-point cost the
compiled passes had already).  Per size, scene and path, the best of
``--reps`` runs: milliseconds per Newton iteration (whole, and its linear
solve), the non-solve microseconds per point and iteration, the
iterations and the points that yielded.  A path that refuses the scene
(``kernels="compiled"`` before the nineteenth round) prints its refusal.

    python benchmarks/bodies_cost.py [--cells 50 158] [--reps 3]
        [--paths numpy compiled]
"""
import argparse
import time

import numpy as np

from skfem_mpm import (LinearElastic, MohrCoulomb, Options, point_locator,
                       simulate)
from skfem_mpm.errors import InvalidInputError
from step_cost import GRIDS, block

SOIL = MohrCoulomb(1e6, .3, cohesion=3e3, friction_angle=30.,
                   dilation_angle=5.)
PILE = LinearElastic(1e7, .25)


def scene(ncells: int, bodies: int):
    """The block, its pile body 1 where ``bodies`` is 2."""
    mesh, points = block(ncells, 2)
    if bodies == 2:
        points.body = (np.abs(points.x[0] - .5) < .1).astype(np.int64)
    return mesh, points, SOIL if bodies == 1 else [SOIL, PILE]


def once(mesh, points, material, path):
    return simulate(
        mesh, GRIDS[2][1](), points.copy(), material,
        lambda b: b.get_dofs(lambda x: x[-1] == 0),
        body_force=np.r_[0., -1e4], nsteps=1, method="mpm",
        kinematics="finite",
        options=Options(keep_snapshots=False, locator=point_locator(mesh),
                        kernels=path))


def measure(mesh, points, material, path, reps):
    """``(ms per iteration, its solve, iterations, yielded)``, best of
    ``reps`` runs per phase."""
    best = {}
    for _ in range(reps):
        result = once(mesh, points, material, path)
        its = result.counters["newton_iterations"]
        for phase, seconds in result.timings().items():
            best[phase] = min(best.get(phase, np.inf), seconds / its * 1e3)
    return (sum(best.values()), best["solve"], its,
            result.history[-1].n_yielded)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[50, 158])
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--paths", nargs="+", choices=("numpy", "compiled"),
                        default=["numpy", "compiled"])
    args = parser.parse_args()
    # untimed: numba's cached kernels and the solver's libraries load
    mesh, points, material = scene(4, 1)
    for path in args.paths:
        once(mesh, points, material, path)
    tic = time.perf_counter()
    print("2D block, standard MPM, finite deformation, 1 step; ms per Newton "
          "iteration (best of {})".format(args.reps))
    print("{:>7} {:>12} {:>9} | {:>8} {:>8} {:>9} {:>4} {:>7}".format(
        "points", "scene", "path", "total", "solve", "us/pt/it", "its",
        "yielded"))
    for ncells in args.cells:
        for bodies in (1, 2):
            mesh, points, material = scene(ncells, bodies)
            name = "soil" if bodies == 1 else "soil + pile"
            for path in args.paths:
                try:
                    total, solve, its, yielded = measure(
                        mesh, points, material, path, args.reps)
                except InvalidInputError as error:
                    print("{:>7} {:>12} {:>9} | refused: {}".format(
                        points.n, name, path, str(error)[:60]), flush=True)
                    continue
                print("{:>7} {:>12} {:>9} | {:>8.2f} {:>8.2f} {:>9.3f} "
                      "{:>4} {:>7}".format(
                          points.n, name, path, total, solve,
                          (total - solve) * 1e3 / points.n, its, yielded),
                      flush=True)
    print("\n{:.0f} s".format(time.perf_counter() - tic))


if __name__ == "__main__":
    main()
