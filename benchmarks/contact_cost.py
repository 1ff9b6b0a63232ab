"""Cost of contact: a step with a floor obstacle against the same step
with the floor as grid-line supports, or (``--bodies``) a step with two
bodies in contact against the same bodies glued.

A unit square of material, 2x2 points per cell, on a Q1 grid with a row
of cells below it; body force, one load step of finite deformation
(standard MPM, Newton).  ``supports``: the grid nodes of the line y = 0
held; ``obstacle``: a smooth floor box below y = 0; both hold x on x = 0
(symmetry; the floor carries the weight through contact at the
material's surface).  ``--bodies``: the square cut at y = 0.5 into two
bodies of the same material, the lower held by the grid nodes of y = 0;
glued (one grid field, the default) against ``Contact(0, 1)`` smooth
(a field per body where both are present; the upper body rests on the
lower through contact at the points' surfaces).
Per size: seconds of the step (all phases, best of ``--repeat``), Newton
iterations, contact's augmented-Lagrangian rounds, seconds per Newton
iteration, and the ratio of the obstacle step to the supported one.
With ``--steps N`` the weight is ramped in N steps and each run prints
every step's wall seconds (from the step callback: the first carries
the run's set-up), Newton iterations and the rounds so far.

    python benchmarks/contact_cost.py [--sizes 32 100 224] [--repeat 2]
        [--bodies] [--steps N]
"""
import argparse
import platform
import time

import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (Contact, LinearElastic, Obstacle, Options,
                       Stabilisation, seed_points, simulate)


def run(cells: int, floor: bool, bodies: bool = False, nsteps: int = 1):
    """One run's (points, seconds, Newton iterations, contact rounds, and
    per step its seconds, Newton iterations and the rounds so far) in
    ``nsteps`` steps: ``floor`` the contact case (an obstacle floor, or
    with ``bodies`` two bodies in contact), else its reference
    (supports, or glued)."""
    h = 1. / cells
    mesh = MeshQuad.init_tensor(np.linspace(0., 1. + 2 * h, cells + 3),
                                np.linspace(-h, 1. + 2 * h, cells + 4))
    points = seed_points(mesh, 2, region=lambda x: (x[0] < 1.)
                         & (x[1] > 0.) & (x[1] < 1.))
    points.body[:] = points.x[1] > .5

    def axis(b):                      # symmetry: x held on x = 0
        return b.get_dofs(lambda x: x[0] == 0).all("u^1")

    def base(b):
        return np.concatenate([axis(b), b.get_dofs(
            lambda x: np.isclose(x[1], 0.)).all()])
    obstacles, contacts = [], []
    if bodies:
        supports = base
        contacts = [Contact(0, 1)] if floor else []
    elif floor:
        supports = axis
        obstacles = [Obstacle(box=[[-1., 2.], [-1., 0.]], name="floor")]
    else:
        supports = base
    stamps = [time.perf_counter()]
    result = simulate(mesh, ElementQuad1(), points, LinearElastic(1e6, .3),
                      supports, body_force=[0., -2e4], nsteps=nsteps,
                      method="mpm", kinematics="finite", obstacles=obstacles,
                      contacts=contacts,
                      options=Options(stabilisation=Stabilisation(ghost=0.),
                                      callback=lambda record, points:
                                      stamps.append(time.perf_counter())))
    seconds = time.perf_counter() - stamps[0]
    steps = [(t, r.newton_iterations, r.counters.get("contact_updates", 0))
             for t, r in zip(np.diff(stamps), result.history)]
    return (points.n, seconds, result.counters["newton_iterations"],
            result.counters.get("contact_updates", 0), steps)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+",
                        default=[32, 100, 224])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--bodies", action="store_true",
                        help="two bodies in contact against glued")
    parser.add_argument("--steps", type=int, default=1,
                        help="load steps (> 1: each step's seconds)")
    args = parser.parse_args()
    print("machine: {} {}, Python {}".format(platform.system(),
                                             platform.machine(),
                                             platform.python_version()))
    print("{:>8} {:>9} {:>9} {:>6} {:>6} {:>10} {:>10} {:>7} {:>7}".format(
        "points", *(("s glued", "s cont.", "it", "it", "s/it glued",
                     "s/it cont.") if args.bodies else
                    ("s sup.", "s obst.", "it", "it", "s/it sup.",
                     "s/it obst.")), "rounds", "ratio"))
    for cells in args.sizes:
        best = {}
        for floor in (False, True):
            runs = [run(cells, floor, args.bodies, args.steps)
                    for _ in range(args.repeat)]
            best[floor] = min(runs, key=lambda r: r[1])
            if args.steps > 1:
                print("  {} steps: {}".format(
                    "contact" if floor else "reference", ", ".join(
                        "{:.3f} s {} it {} rounds".format(*step)
                        for step in best[floor][4])))
        n, t0, it0, _, _ = best[False]
        _, t1, it1, rounds, _ = best[True]
        print("{:>8} {:>9.3f} {:>9.3f} {:>6} {:>6} {:>10.4f} {:>10.4f} "
              "{:>7} {:>7.2f}".format(n, t0, t1, it0, it1, t0 / it0,
                                      t1 / it1, rounds, t1 / t0))


if __name__ == "__main__":
    main()
