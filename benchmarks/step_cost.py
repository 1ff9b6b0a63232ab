"""Cost of an implicit MPM load step per phase, 2D plane strain (or 3D).

A square block on a Q1 grid, 2x2 points per cell, fixed base, body force
(``--dim 3``: a cube on a hexahedral grid, 2x2x2 points per cell).
For each method (standard MPM or cpGIMP) and kinematics (small strain: two
load steps; finite deformation: one load step, Newton), prints per size:
seconds per load step (the sum of its phases), each phase's points per
second, the share of the linear solve ("solve": condensation,
factorisation, substitution and the backward-error check), the non-solve
cost per point and per Newton iteration, the run's one-off set-up (grid
basis, DOFs, stiffness pattern), the peak of the numpy/Python heap per
point (tracemalloc, in a separate untimed run: the factorisation,
allocated by SuperLU or MKL, is not in it) and the growth of the resident
set per point (factorisation included); then the fitted exponents of the non-solve time per step and
per Newton iteration against the number of points, the cost of a Newton
iteration fitted as ``a + b * points`` (the fixed cost ``a`` in ms and the
slope ``b`` in us per point; whole iteration and non-solve part, fitted
to relative residuals so that every size counts), and the iterations per
step.

    python benchmarks/step_cost.py [--max-points 1e6] [--solver scipy]
        [--cases mpm:small,mpm:finite,cpgimp:finite] [--dim 2]
"""
import argparse
import platform
import time
import tracemalloc

import numpy as np
from skfem import ElementHex1, ElementQuad1, MeshHex, MeshQuad

from skfem_mpm import (LinearElastic, Options, point_locator, seed_points,
                       solve_finite, solve_mpm)
from skfem_mpm.solve.results import PHASES
from skfem_mpm.solve.backends import get_solver
from skfem_mpm.studies.study import PeakMemory

SIZES = {2: (16, 50, 158, 500),            # cells per side: 1e3 .. 1e6 points
         3: (5, 11, 24, 40)}               # 1e3 .. 5.1e5 points
GRIDS = {2: (MeshQuad, ElementQuad1), 3: (MeshHex, ElementHex1)}


def block(ncells: int, dim: int = 2):
    """A unit square (cube) of material in a grid two cells wider on each
    side and 20% higher (room for the Poisson expansion)."""
    h = 1. / ncells
    lateral = np.linspace(-2 * h, 1. + 2 * h, ncells + 5)
    vertical = np.linspace(0., 1.2, int(1.2 * ncells) + 1)
    mesh = GRIDS[dim][0].init_tensor(*[lateral] * (dim - 1), vertical)
    points = seed_points(mesh, 2, region=lambda p: (p[-1] < 1.) & np.all(
        (p[:-1] > 0) & (p[:-1] < 1.), axis=0))
    return mesh, points


def run(ncells: int, method: str, kinematics: str, solver: str,
        dim: int = 2):
    """Times from the faster of two runs, the resident-set growth from the
    first, the heap peak from a third under tracemalloc (whose
    bookkeeping slowed the numpy calls of the timed phases by up to 40% at
    1e5 points)."""
    mesh, points = block(ncells, dim)
    args = (mesh, GRIDS[dim][1](), points, LinearElastic(1e6, .3),
            lambda b: b.get_dofs(lambda x: x[-1] == 0))

    def simulate():
        used = get_solver(solver, dim)
        kwargs = dict(body_force=np.r_[np.zeros(dim - 1), -1e4],
                      options=Options(locator=point_locator(mesh),
                                      keep_snapshots=False, solver=used))
        if kinematics == "small":
            return solve_mpm(*args, nsteps=2, **kwargs), used
        return solve_finite(*args, nsteps=1, method=method, **kwargs), used
    with PeakMemory() as memory:
        tic = time.perf_counter()
        res, used = simulate()
        wall = time.perf_counter() - tic
    # again, timed in the steady state: the first run in a process pays
    # the page faults of its first allocations (20% at 1e5 points)
    tic = time.perf_counter()
    again, used = simulate()
    if sum(again.timings().values()) < sum(res.timings().values()):
        res, wall = again, time.perf_counter() - tic
    tracemalloc.start()
    simulate()
    heap = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    nsteps = len(res.history)
    per_step = {p: t / nsteps for p, t in res.timings().items()}
    step = sum(per_step.values())
    iterations = max(res.counters["newton_iterations"], nsteps)
    return dict(points=points.n, dofs=res.history[-1].n_free_dofs,
                step=step, phases=per_step,
                setup=wall - step * nsteps,
                iteration_us=(step - per_step["solve"])
                * nsteps / iterations / points.n * 1e6,
                iteration_s=step * nsteps / iterations,
                heap=heap / points.n, memory=memory.peak / points.n,
                iterations=round(iterations / nsteps, 1),
                amg=getattr(used, "iterations", None))


def fixed_and_slope(n, t):
    """``(a, b)`` of ``t ~ a + b n`` by least squares on relative
    residuals."""
    n, t = np.asarray(n, float), np.asarray(t, float)
    A = np.column_stack([np.ones_like(n), n]) / t[:, None]
    return np.linalg.lstsq(A, np.ones_like(t), rcond=None)[0]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-points", type=float, default=1e6)
    parser.add_argument("--solver", default="scipy")
    parser.add_argument("--cases", default="mpm:small,mpm:finite,cpgimp:finite")
    parser.add_argument("--dim", type=int, default=2, choices=(2, 3))
    args = parser.parse_args()
    print("machine: {} {}, Python {}, solver {}, {}D".format(
        platform.system(), platform.machine(), platform.python_version(),
        args.solver, args.dim))
    for case in args.cases.split(","):
        method, kinematics = case.split(":")
        print("\n{} with {} kinematics".format(method, kinematics))
        print("{:>8} {:>7} {:>8} | {} | {:>6} {:>9} {:>7} {:>7} {:>7}".format(
            "points", "dofs", "s/step",
            " ".join("{:>9}".format(p) for p in PHASES), "solve",
            "us/pt/it", "setup", "heap/pt", "RSS/pt"))
        # us/pt/it: non-solve seconds per point and Newton iteration (per
        # step for small strain); setup: seconds, once per run; heap/pt:
        # bytes, tracemalloc peak; RSS/pt: bytes, resident-set growth, the
        # factorisation included
        rows = []
        # untimed: loads the solver's libraries (MKL: 0.25 s), which the
        # smallest size would otherwise pay for
        run(SIZES[args.dim][0], method, kinematics, args.solver, args.dim)
        for ncells in SIZES[args.dim]:
            if (2 * ncells) ** args.dim > args.max_points * 1.01:
                break
            r = run(ncells, method, kinematics, args.solver, args.dim)
            rows.append(r)
            print("{:>8} {:>7} {:>8.3f} | {} | {:>6.0%} {:>9.2f} {:>7.2f} "
                  "{:>7.0f} {:>7.0f}".format(
                      r["points"], r["dofs"], r["step"], " ".join(
                          "{:>9.1e}".format(r["points"] / r["phases"][p])
                          for p in PHASES), r["phases"]["solve"] / r["step"],
                      r["iteration_us"], r["setup"], r["heap"],
                      r["memory"]), flush=True)
        if len(rows) >= 2:
            n = np.array([r["points"] for r in rows], float)
            big = n >= 1e4
            for what, t in (
                    ("per step", [r["step"] - r["phases"]["solve"]
                                  for r in rows]),
                    ("per Newton iteration", [r["iteration_us"] * r["points"]
                                              for r in rows])):
                t = np.array(t)
                print("non-solve time {} ~ points^{:.2f} (from 1e4 points: "
                      "^{:.2f})".format(what, np.polyfit(
                          np.log(n), np.log(t), 1)[0], np.polyfit(
                              np.log(n[big]), np.log(t[big]), 1)[0]
                          if big.sum() >= 2 else float("nan")))
            whole = [r["iteration_s"] for r in rows]
            nonsolve = [r["iteration_us"] * r["points"] * 1e-6 for r in rows]
            (a, b), (c, d) = fixed_and_slope(n, whole), fixed_and_slope(
                n, nonsolve)
            print("per Newton iteration: {:.2f} ms + {:.2f} us/point; "
                  "non-solve part {:.2f} ms + {:.2f} us/point".format(
                      a * 1e3, b * 1e6, c * 1e3, d * 1e6))
            print("Newton iterations per step:", " ".join(
                str(r["iterations"]) for r in rows))
            if rows[0]["amg"] is not None:
                print("AMG-CG iterations per solve:", "; ".join(
                    " ".join(map(str, r["amg"])) for r in rows))


if __name__ == "__main__":
    main()
