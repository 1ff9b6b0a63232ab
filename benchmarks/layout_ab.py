"""The compiled passes on the same inputs in two memory layouts: the
arrays as this checkout lays them out (points first in memory where the
compiled path keeps them so, ``mechanics/compiled.py``) against
C-contiguous copies, points last in memory (the layout before the
thirteenth round), alternating in one process so that the machine's
drift falls on both.

The block of ``step_cost.py`` (standard MPM, finite deformation,
``LinearElastic(1e6, 0.3)``, one load step) is run once with the first
call of the residual pass, the stiffness pass and the commit's pass
(``finite_commit``) recorded; then each pass runs on copies of those
arguments, ``--reps`` rounds of the best of 15 calls a layout; microseconds
a point a call.

    python benchmarks/layout_ab.py [--cells 158] [--dim 2] [--reps 5]
"""
import argparse
import time

import numpy as np

from compiled_cost import once
from step_cost import GRIDS, block
from skfem_mpm.kernels import passes


def recorded(cells: int, dim: int) -> dict:
    """The arguments of the first call of each pass in a one-step run,
    copied as they were at the call (each array's layout kept)."""
    calls, passes_of, commit = {}, passes.passes_of, passes.finite_commit

    def record(name, function):
        def call(*args):
            calls.setdefault(name, [a.copy(order="K") if isinstance(
                a, np.ndarray) else a for a in args])
            return function(*args)
        return call

    def recording(d):
        finite, small, stiffness = passes_of(d)
        return (record("residual", finite), small,
                record("stiffness", stiffness))
    passes.passes_of = recording
    passes.finite_commit = record("commit", commit)
    try:
        mesh, points = block(cells, dim)
        once(mesh, GRIDS[dim][1](), points)
    finally:
        passes.passes_of, passes.finite_commit = passes_of, commit
    return calls


def runs(calls: dict, dim: int, contiguous: bool) -> dict:
    """A function per pass running it on (copies of) the recorded
    arguments: fresh outputs where the pass writes new arrays."""
    args = {name: [np.ascontiguousarray(a) if contiguous and isinstance(
        a, np.ndarray) else a for a in values]
        for name, values in calls.items()}
    finite, _, stiffness = passes.passes_of(dim)

    def assemble():
        data = np.zeros_like(args["stiffness"][-1])
        stiffness(*args["stiffness"][:-1], data)

    def commit():
        a = list(args["commit"])
        for i in range(7, 11):            # F, J, b_e, strain: new arrays
            a[i] = np.empty_like(a[i], order="C")
        passes.finite_commit(*a)
    return {"residual": lambda: finite(*args["residual"]),
            "stiffness": assemble, "commit": commit}


def best(function, calls: int = 15) -> float:
    seconds = np.inf
    for _ in range(calls):
        tic = time.perf_counter()
        function()
        seconds = min(seconds, time.perf_counter() - tic)
    return seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=158)
    parser.add_argument("--dim", type=int, default=2)
    parser.add_argument("--reps", type=int, default=5)
    args = parser.parse_args()
    calls = recorded(args.cells, args.dim)
    n = len(calls["residual"][5])                 # the points' order
    layouts = runs(calls, args.dim, False), runs(calls, args.dim, True)
    times = {name: ([], []) for name in layouts[0]}
    for layout in layouts:                        # compiled, untimed
        for function in layout.values():
            function()
    for _ in range(args.reps):
        for name in times:
            for k, layout in enumerate(layouts):
                times[name][k].append(best(layout[name]) / n * 1e6)
    print("{} points, {}D; us a point a call: as laid out | points last "
          "(C-contiguous copies)".format(n, args.dim))
    for name, (laid, last) in times.items():
        print("{:>10} {} | {}".format(name, " ".join(
            "{:.3f}".format(t) for t in laid), " ".join(
            "{:.3f}".format(t) for t in last)))


if __name__ == "__main__":
    main()
