"""The condensation of a tangent (``solve/linear.py``, ``Condensation``)
against another checkout's, alternating in one process so that the
machine's drift falls on both: its map's build (once a pattern) and its
gather, copied and within the tangent's data (``consume``), in
milliseconds, the least of ``--reps``.

The other checkout's ``linear.py`` is loaded beside this one's, e.g.
main's::

    git show main:skfem_mpm/solve/linear.py > /tmp/other_linear.py
    python benchmarks/condensation_ab.py /tmp/other_linear.py [--reps 7]

The patterns are a 3D grid's (27 neighbours of 3 DOFs a node, random
entries), free the DOFs of a box of nodes, the bottom ones held:
20 nodes a side, 1.76e6 entries, 5.3e5 kept (the map as runs); 8 a side,
9.6e4 entries, 1.5e4 kept (the small map, positions whole).  This
checkout runs on both kernel paths (``compiled``: the map built and
gathered by :mod:`skfem_mpm.kernels.graph`; ``numpy``).
"""
import argparse
import importlib.util
import time

import numpy as np
from scipy.sparse import diags, kron

from skfem_mpm.solve import linear

#: (nodes a side, the box's nodes along z, y, x)
CASES = ((20, (14, 14, 13)), (8, (5, 5, 4)))


def grid(m: int, box: tuple):
    """A 3D grid's tangent of ``m`` nodes a side and the free DOFs of
    the box ``box`` of nodes above the bottom ones."""
    T = diags([1., 1., 1.], [-1, 0, 1], shape=(m, m))
    K = kron(kron(kron(T, T), T), np.ones((3, 3))).tocsr()
    K.sort_indices()
    K.data = np.random.default_rng(5).standard_normal(K.nnz)
    z, y, x = np.unravel_index(np.arange(m ** 3), (m, m, m))
    nodes = np.flatnonzero((z > 0) & (z <= box[0]) & (y < box[1])
                           & (x < box[2]))
    return K, (3 * nodes[:, None] + np.arange(3)).ravel()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("other", help="another checkout's linear.py")
    parser.add_argument("--reps", type=int, default=7)
    args = parser.parse_args()
    spec = importlib.util.spec_from_file_location(
        "skfem_mpm.solve._other_linear", args.other)
    other = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(other)
    variants = {
        "other": lambda K, f: other.Condensation(K, f),
        "compiled": lambda K, f: linear.Condensation(K, f, "compiled"),
        "numpy": lambda K, f: linear.Condensation(K, f, "numpy")}
    phases = ("build", "copied", "consumed")
    for m, box in CASES:
        K, free = grid(m, box)
        for make in variants.values():            # compiled, warm
            make(K, free)(K.copy(), True)
        best = {(v, p): np.inf for v in variants for p in phases}
        for _ in range(args.reps):
            for v, make in variants.items():
                tic = time.perf_counter()
                condensation = make(K, free)
                toc = time.perf_counter()
                A = condensation(K)
                tac = time.perf_counter()
                tangent = K.copy()
                tuc = time.perf_counter()
                B = condensation(tangent, True)
                for p, t in zip(phases, (toc - tic, tac - toc,
                                         time.perf_counter() - tuc)):
                    best[v, p] = min(best[v, p], t)
                if not np.array_equal(A.data, B.data):
                    raise SystemExit("{}: the gathers differ".format(v))
        print("{} entries, {} kept; ms, least of {}".format(
            K.nnz, A.nnz, args.reps))
        for v in variants:
            print("  {:8s} build {:6.2f}  copied {:5.2f}  consumed {:5.2f}"
                  .format(v, *(1e3 * best[v, p] for p in phases)))


if __name__ == "__main__":
    main()
