"""The plain compiled passes of a checkout, called alone on a real run's
arguments: an A/B of two commits' residual and stiffness passes.

The block of ``step_cost.py`` (standard MPM, finite deformation,
``LinearElastic(1e6, 0.3)``, one load step, the compiled kernels),
without anti-locking or with the additive mean dilatation
(``--antilocking``).  The run's last call of the finite residual pass
and of the stiffness pass are kept (their arguments copied); each is
then called ``REPS`` times on fresh copies of them (the copies made
outside the timer) and its microseconds a point printed: the least and
the median.  ``--save FILE`` writes the first call's outputs (every
array argument after it), to compare two checkouts' answers bit by bit
(``--compare A B``).  ``--against PATH`` alternates each call with the
same pass of another commit's kernels on the same arguments, in the same
process (a load that changes between processes cancels): PATH holds a
package ``skfem_pre`` made of that commit's ``skfem_mpm/kernels`` and
``errors.py`` (an empty ``__init__.py``); the two answers are compared
bit by bit.  ``--asm`` then compares the two passes' machine code
(``inspect_asm``, symbols, addresses, labels and stack offsets blanked;
numba inspects only code compiled in the process: run it with
``NUMBA_CACHE_DIR`` set to a new folder).

    python benchmarks/plain_passes_ab.py ROOT [--cells 158]
        [--antilocking] [--reps 20] [--save FILE] [--against PATH]
        [--asm]
    python benchmarks/plain_passes_ab.py --compare A.npz B.npz
"""
import argparse
import difflib
import re
import sys
import time
import warnings

import numpy as np


def copied(args):
    """The arrays of ``args`` copied (tuples of them too), the rest as
    given."""
    return tuple(a.copy() if isinstance(a, np.ndarray) else
                 copied(a) if isinstance(a, tuple) else a for a in args)


def arrays(args):
    """Every array of ``args`` in order (tuples flattened)."""
    out = []
    for a in args:
        if isinstance(a, np.ndarray):
            out.append(a)
        elif isinstance(a, tuple):
            out.extend(arrays(a))
    return out


def machine_code(asm: str) -> list:
    """The instructions of ``asm``, symbols, addresses, labels and stack
    offsets blanked (directives and comments dropped)."""
    asm = re.sub(r"_ZN[0-9A-Za-z_$]+", "SYM", asm)
    asm = re.sub(r"0x[0-9a-f]+", "ADDR", asm)
    asm = re.sub(r"\.L[0-9A-Za-z_$]+", "LBL", asm)
    asm = re.sub(r"-?[0-9]+\(%rsp\)", "STACK", asm)
    asm = re.sub(r"\$[0-9]+, %rsp", "FRAME", asm)
    return [line.strip() for line in asm.splitlines()
            if line.strip() and not line.strip().startswith(
                (".", "#"))]


def compare_code(name, this, other):
    """Print whether ``this`` and ``other`` compiled each signature of
    ``this`` they share to the same instructions."""
    for sig in [s for s in this.signatures if s in other.overloads]:
        x = machine_code(this.inspect_asm(sig))
        y = machine_code(other.inspect_asm(sig))
        diff = [line for line in difflib.unified_diff(
            y, x, lineterm="", n=0) if line[:1] in "+-"
            and line[:3] not in ("+++", "---")]
        print("{}: {} and {} instructions, {} lines differ".format(
            name, len(x), len(y), len(diff)))
        print("\n".join(diff[:40]))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("root", nargs="?")
    parser.add_argument("--cells", type=int, default=158)
    parser.add_argument("--antilocking", action="store_true")
    parser.add_argument("--reps", type=int, default=20)
    parser.add_argument("--save")
    parser.add_argument("--compare", nargs=2)
    parser.add_argument("--against")
    parser.add_argument("--asm", action="store_true")
    opts = parser.parse_args()
    if opts.compare:
        a, b = (np.load(name) for name in opts.compare)
        same = [np.array_equal(a[k], b[k], equal_nan=True) for k in a.files]
        print("bit-identical" if all(same) and a.files == b.files else
              "differ: " + " ".join(k for k, s in zip(a.files, same)
                                    if not s))
        return
    sys.path.insert(0, opts.root)
    sys.path.insert(0, opts.root + "/benchmarks")
    from skfem import ElementQuad1
    from step_cost import block
    from skfem_mpm import LinearElastic, Options, Stabilisation, simulate
    from skfem_mpm.kernels import dilatation, passes

    kept = {}

    def keeping(name, pass_):
        def wrapped(*args):
            kept[name] = (pass_, copied(args))
            return pass_(*args)
        return wrapped
    for module in (passes, dilatation):
        def passes_of(dim, _of=module.passes_of):
            finite, small, stiffness = _of(dim)
            return (keeping("residual", finite), small,
                    keeping("stiffness", stiffness))
        module.passes_of = passes_of
    mesh, points = block(opts.cells)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate(mesh, ElementQuad1(), points.copy(), LinearElastic(1e6, .3),
                 lambda b: b.get_dofs(lambda x: x[-1] == 0),
                 body_force=[0, -1e4], nsteps=1, method="mpm",
                 kinematics="finite", options=Options(
                     keep_snapshots=False, kernels="compiled",
                     stabilisation=Stabilisation(
                         antilocking=opts.antilocking)))
    others = {}
    if opts.against:
        sys.path.insert(0, opts.against)
        from skfem_pre.kernels import dilatation as other_dilatation
        from skfem_pre.kernels import passes as other_passes
        other = (other_dilatation if opts.antilocking
                 else other_passes).passes_of(2)
        others = {"residual": other[0], "stiffness": other[2]}
    saved = {}
    for name in ("residual", "stiffness"):
        pass_, args = kept[name]
        times = {"this": [], "other": []}
        for r in range(opts.reps):
            for which in ("this", "other") if others else ("this",):
                fresh = copied(args)
                call = pass_ if which == "this" else others[name]
                tic = time.perf_counter()
                call(*fresh)
                times[which].append(time.perf_counter() - tic)
                if r == 0:
                    for i, a in enumerate(arrays(fresh)):
                        saved["{}_{}_{}".format(which, name, i)] = a
        for which, seconds in times.items():
            if not seconds:
                continue
            seconds = np.array(seconds) * 1e6 / points.n
            print("{} points, {} {}: least {:.4f}, median {:.4f} us a "
                  "point".format(points.n, which, name, seconds.min(),
                                 np.median(seconds)), flush=True)
        if others:
            count = len(arrays(args))
            print("  answers bit-identical:", all(np.array_equal(
                saved["this_{}_{}".format(name, i)],
                saved["other_{}_{}".format(name, i)], equal_nan=True)
                for i in range(count)))
            if opts.asm:
                compare_code(name, pass_, others[name])
    if opts.save:
        np.savez(opts.save, **saved)


if __name__ == "__main__":
    main()
