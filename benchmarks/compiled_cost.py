"""The compiled points-first passes against the numpy path: the cost of a
Newton iteration per phase, its fixed part and its part per point, 2D and
3D, on the same machine in the same hour (the two paths alternate at each
size).

The block of ``step_cost.py`` (standard MPM, finite deformation, one
load step, ``LinearElastic(1e6, 0.3)``, the default solver), 1e3 to 1e5
points; per size and path the best of ``--reps`` runs per phase
(milliseconds per Newton iteration), the non-solve microseconds per point
and iteration, and the heap peak per point (tracemalloc, a separate run:
the run's own, the input's copy made before tracing, and "+input" with
that copy's size added, the figure of the rounds before the ninth);
then each path's iteration fitted as ``a + b * points`` (whole, and its
non-solve part).  ``--large`` adds the 1e6-point 2D step (both paths):
the share of its time outside the linear solve.  ``--kratos`` prints the
seed's column (2D, one cell wide, 2x2 points a cell) at 1e3 and 4e3
points, the case of the comparison with Kratos in issue 32.
``--compile`` times the first runs of a fresh process with an empty
kernel cache (``NUMBA_CACHE_DIR`` a new folder): what compiling costs
once, then what loading the cached kernels costs each process.
``--method cpgimp`` (or ``ugimp``, ``bspline``) runs the tables with
that method's sparse operator instead of standard MPM's (in 3D to 3.3e4
points: the numpy path's GIMP stiffness takes seconds beyond).
``--antilocking`` runs them with mean dilatation
(``Stabilisation(antilocking=True)``, as the footing examples),
``--antilocking fbar`` with F-bar on the increment
(``antilocking="fbar"``, :mod:`skfem_mpm.kernels.fbar`);
``--cells`` picks the sizes (cells per side of the block: 50 and 158 are
the 1e4 and 1e5 points of 2D, 11 and 24 of 3D); ``--paths compiled``
runs one path only (an A/B of two checkouts: this script with
``PYTHONPATH`` at each).

    python benchmarks/compiled_cost.py [--dim 2] [--reps 3] [--large]
        [--kratos] [--compile] [--method mpm] [--antilocking [fbar]]
        [--cells 50 158] [--paths numpy compiled]

The path is chosen by making the run's kinematics with ``kernels=``
(the core's factory, replaced in this process).
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc

import numpy as np

from skfem_mpm import (LinearElastic, Options, Stabilisation, point_locator,
                       simulate)
from skfem_mpm.solve.results import PHASES
from step_cost import GRIDS, block, fixed_and_slope

SIZES = {2: (16, 32, 50, 100, 158), 3: (5, 8, 11, 16, 24)}
#: the paths the tables run (``--paths``)
PATHS = ["numpy", "compiled"]


KERNELS = {"path": "auto", "method": "mpm", "antilocking": False}


def use(kernels: str):
    """Runs from now on take the path ``kernels`` (``Options.kernels``)."""
    KERNELS["path"] = kernels


def once(mesh, elem, points, nsteps=1, body_force=None, supports=None,
         copy=True):
    """One run of ``points``: a copy of them unless ``copy`` is False
    (the caller's own copy, made outside the traced region)."""
    dim = mesh.dim()
    return simulate(
        mesh, elem, points.copy() if copy else points, LinearElastic(1e6, .3),
        supports or (lambda b: b.get_dofs(lambda x: x[-1] == 0)),
        body_force=np.r_[np.zeros(dim - 1), -1e4] if body_force is None
        else body_force, nsteps=nsteps, method=KERNELS["method"],
        kinematics="finite",
        options=Options(keep_snapshots=False, locator=point_locator(mesh),
                        kernels=KERNELS["path"], stabilisation=Stabilisation(
                            antilocking=KERNELS["antilocking"])))


def measure(mesh, elem, points, reps: int, heap: bool, **kwargs):
    """Milliseconds per Newton iteration per phase (best of ``reps``), and
    where ``heap`` the heap peak per point (bytes): the run's own (the
    input's copy made before tracing starts) and the input's copy's size
    (what the caller holds beside it), else None."""
    best = {}
    for _ in range(reps):
        result = once(mesh, elem, points, **kwargs)
        its = result.counters["newton_iterations"]
        for phase, seconds in result.timings().items():
            best[phase] = min(best.get(phase, np.inf), seconds / its * 1e3)
    peak = None
    if heap:
        tracemalloc.start()
        given = points.copy()
        size = tracemalloc.get_traced_memory()[0]
        tracemalloc.stop()
        del given
        given = points.copy()
        tracemalloc.start()
        once(mesh, elem, given, copy=False, **kwargs)
        peak = (tracemalloc.get_traced_memory()[1] / points.n,
                size / points.n)
        tracemalloc.stop()
    return best, its, peak


def table(dim: int, reps: int, cells=None):
    method = KERNELS["method"]
    print("\n{}D, block of step_cost.py, {}{}, finite deformation, 1 step; "
          "ms per Newton iteration (best of {})".format(
              dim, "standard MPM" if method == "mpm" else method,
              {True: ", mean dilatation", "fbar": ", F-bar on the "
               "increment"}.get(KERNELS["antilocking"], ""), reps))
    print("{:>7} {:>9} | {} | {:>7} {:>9} {:>8} {:>8} {:>4}".format(
        "points", "path", " ".join("{:>8}".format(p) for p in PHASES),
        "total", "us/pt/it", "heap/pt", "+input", "its"))
    rows = {path: [] for path in PATHS}
    elem = GRIDS[dim][1]()
    sizes = cells or (SIZES[dim] if method == "mpm" or dim == 2
                      else SIZES[dim][:4])
    for ncells in sizes:
        mesh, points = block(ncells, dim)
        for path in PATHS:
            use(path)
            best, its, peak = measure(mesh, elem, points, reps,
                                      heap=ncells == sizes[-1])
            total = sum(best.values())
            nonsolve = (total - best["solve"]) * 1e3 / points.n
            rows[path].append((points.n, total, total - best["solve"]))
            print("{:>7} {:>9} | {} | {:>7.2f} {:>9.3f} {:>8} {:>8} {:>4}"
                  .format(points.n, path, " ".join(
                      "{:>8.2f}".format(best[p]) for p in PHASES), total,
                          nonsolve, *("-", "-") if peak is None else (
                              "{:.0f}".format(peak[0]),
                              "{:.0f}".format(sum(peak))), its), flush=True)
    for path in PATHS:
        n, whole, nonsolve = map(np.array, zip(*rows[path]))
        (a, b), (c, d) = fixed_and_slope(n, whole * 1e-3), fixed_and_slope(
            n, nonsolve * 1e-3)
        print("{:>9}: per Newton iteration {:.2f} ms + {:.2f} us/point; "
              "non-solve {:.2f} ms + {:.2f} us/point".format(
                  path, a * 1e3, b * 1e6, c * 1e3, d * 1e6))


def kratos_column(reps: int):
    """The seed's column at 1e3 and 4e3 points (256 and 1024 cells, 20 load
    steps): ms per Newton iteration, both paths."""
    from skfem_mpm import seed_points
    from skfem_mpm.studies.column import (LOAD, column_grid,
                                          column_supports)
    print("\nseed's column, 2D, 20 load steps: ms per Newton iteration "
          "(best of {})".format(reps))
    for cells in (256, 1024):
        mesh, elem = column_grid(cells, dim=2)
        points = seed_points(mesh, 2)
        line = []
        for path in PATHS:
            use(path)
            best, its, _ = measure(mesh, elem, points, reps, False,
                                   nsteps=20, body_force=[0., -LOAD],
                                   supports=column_supports(2))
            line.append("{} {:.3f} (solve {:.3f})".format(
                path, sum(best.values()), best["solve"]))
        print("{:>6} points: {}".format(points.n, "; ".join(line)),
              flush=True)


def large(reps: int):
    """The 1e6-point 2D block, both paths: milliseconds per phase and
    Newton iteration, the share outside the linear solve."""
    mesh, points = block(500, 2)
    print("\n{} points, 2D, ms per Newton iteration".format(points.n))
    for path in PATHS:
        use(path)
        best, its, _ = measure(mesh, GRIDS[2][1](), points, reps, False)
        total = sum(best.values())
        print("{:>9}: {:.0f} ms, {} iterations; {:.0%} outside the linear "
              "solve ({})".format(path, total, its, 1 - best["solve"] / total,
                                  ", ".join("{} {:.0f}".format(p, best[p])
                                            for p in PHASES)), flush=True)


#: a fresh process's first runs, each timed: 2D and 3D, finite and small
#: deformation, elastic and von Mises (every compiled pass), then cpGIMP
#: (the same passes: nothing more to compile), then mean dilatation (its
#: passes, 2D and 3D, finite and small deformation), then the plain
#: passes in chunks on the cores (:mod:`skfem_mpm.kernels.parallel`)
FIRST_RUNS = """
import sys, time
sys.path.insert(0, {here!r})
import numpy as np
from skfem_mpm import (LinearElastic, Options, Stabilisation, VonMises,
                       simulate)
from step_cost import GRIDS, block
tic = time.perf_counter()
import skfem_mpm.kernels.passes
print("import", time.perf_counter() - tic)


def plain_runs(cells, label):
    for dim in (2, 3):
        mesh, points = block(cells, dim)
        for kinematics in ("finite", "small"):
            for material in (LinearElastic(1e6, .3),
                             VonMises(1e6, .3, 1e3)):
                tic = time.perf_counter()
                simulate(mesh, GRIDS[dim][1](), points.copy(), material,
                         lambda b: b.get_dofs(lambda x: x[-1] == 0),
                         body_force=np.r_[np.zeros(dim - 1), -1e4],
                         nsteps=1, method="mpm", kinematics=kinematics)
                print(dim, kinematics, type(material).__name__ + label,
                      time.perf_counter() - tic)


plain_runs(2, "")
mesh, points = block(2, 2)
tic = time.perf_counter()
simulate(mesh, GRIDS[2][1](), points.copy(), LinearElastic(1e6, .3),
         lambda b: b.get_dofs(lambda x: x[-1] == 0), body_force=[0., -1e4],
         nsteps=1, method="cpgimp", kinematics="finite")
print("2 finite LinearElastic cpgimp", time.perf_counter() - tic)
for dim in (2, 3):
    mesh, points = block(2, dim)
    for kinematics in ("finite", "small"):
        tic = time.perf_counter()
        simulate(mesh, GRIDS[dim][1](), points.copy(), VonMises(1e6, .3, 2e4),
                 lambda b: b.get_dofs(lambda x: x[-1] == 0),
                 body_force=np.r_[np.zeros(dim - 1), -1e4], nsteps=1,
                 method="mpm", kinematics=kinematics, options=Options(
                     stabilisation=Stabilisation(antilocking=True)))
        print(dim, kinematics, "mean dilatation", time.perf_counter() - tic)
import skfem_mpm.methods.assembly
# the passes in chunks on the cores (an operator of 3 x 8192 points or
# more): here on a small block, its chunks of 8 points
skfem_mpm.methods.assembly.CHUNK_POINTS = 8
plain_runs(4, " in chunks")
"""


def compile_times():
    """Seconds of the first runs in a fresh process, with an empty kernel
    cache and again with the cache it wrote."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        code = FIRST_RUNS.format(here=os.path.dirname(os.path.abspath(
            __file__)))
        runs = [subprocess.run([sys.executable, "-c", code], env=env,
                               capture_output=True, text=True, check=True
                               ).stdout.split("\n")[:-1] for _ in range(2)]
    print("\nfirst runs of a process (seconds): empty kernel cache / cached")
    for cold, warm in zip(*runs):
        label = cold.rsplit(" ", 1)[0]
        print("{:>28} {:>7.2f} {:>7.2f}".format(
            label, float(cold.split()[-1]), float(warm.split()[-1])))
    total = [sum(float(line.split()[-1]) for line in run) for run in runs]
    print("{:>28} {:>7.2f} {:>7.2f}".format("total", *total))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dim", type=int, nargs="+", default=[2, 3])
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--large", action="store_true")
    parser.add_argument("--kratos", action="store_true")
    parser.add_argument("--compile", action="store_true")
    parser.add_argument("--method", default="mpm",
                        choices=("mpm", "ugimp", "cpgimp", "bspline"))
    parser.add_argument("--antilocking", nargs="?", const=True,
                        default=False, choices=("fbar",))
    parser.add_argument("--cells", type=int, nargs="+")
    parser.add_argument("--paths", nargs="+", choices=("numpy", "compiled"),
                        default=list(PATHS))
    args = parser.parse_args()
    PATHS[:] = args.paths
    KERNELS["method"], KERNELS["antilocking"] = args.method, args.antilocking
    if args.compile:
        compile_times()
    # untimed: numba's cached kernels and the solver's libraries load,
    # the passes in chunks too (an operator of 3 x 8192 points or more,
    # a basis's fields or values of parallel.SPLIT points: here on a
    # small block, in chunks of 8 points; a 1e6-point run loaded them in
    # its first step, 0.06-0.07 s, before)
    import skfem_mpm.methods.assembly as assembly
    from skfem_mpm.quadrature.basis import compiled_kernels
    parallel = compiled_kernels("parallel", "compiled")   # None: no numba
    kept = assembly.CHUNK_POINTS, getattr(parallel, "SPLIT", None)
    for cells, small in ((4, False), (8, True)):
        assembly.CHUNK_POINTS = 8 if small else kept[0]
        if kept[1] is not None:
            parallel.SPLIT = 16 if small else kept[1]
        mesh, points = block(cells, 2)
        for path in PATHS:
            use(path)
            once(mesh, GRIDS[2][1](), points)
    assembly.CHUNK_POINTS = kept[0]
    if kept[1] is not None:
        parallel.SPLIT = kept[1]
    tic = time.perf_counter()
    for dim in args.dim:
        table(dim, args.reps, args.cells)
    if args.kratos:
        kratos_column(args.reps)
    if args.large:
        large(1)
    print("\n{:.0f} s".format(time.perf_counter() - tic))


if __name__ == "__main__":
    main()
