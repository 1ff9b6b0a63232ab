"""Cost of scikit-fem's asm on material points: one padded basis against
bases grouped by point count, and a Gauss-point basis.

n points on a Q1 grid of about n / 4 cells (m x m, m = sqrt(n / 4)), either
random (uniform over the unit square) or clustered (normal about the
centre, standard deviation 0.2, those outside the square dropped); the
plane-strain elasticity form (``linear_elasticity`` on
``ElementVector(ElementQuad1())``) assembled with ``asm``:

- padded: one ``MaterialPointBasis`` (every element padded to the
  fullest element's point count);
- grouped: ``material_point_bases`` (elements binned by point count, at
  most ``--max-padding`` padding), ``asm(form, bases)``;
- Gauss: ``Basis(mesh, elem, intorder=3)``, 2x2 Gauss points per cell:
  as many quadrature points as there are material points.

Each time holds building the basis (locating the points) and ``asm``, best
of ``--repeat`` runs (one run from 1e6 points on); "slots" are the
quadrature slots ``asm`` works on (points plus padding).

    python benchmarks/point_assembly.py [--max-points 1e6]
"""
import argparse
import platform
import time

import numpy as np
from skfem import Basis, ElementQuad1, ElementVector, MeshQuad, asm
from skfem.models.elasticity import linear_elasticity

from skfem_mpm import MaterialPointBasis, MaterialPoints, material_point_bases

FORM = linear_elasticity(1., 1.)
ELEM = ElementVector(ElementQuad1())


def random_points(n, rng):
    return rng.random((2, n))


def clustered_points(n, rng):
    x = rng.normal(.5, .2, (2, int(1.25 * n)))
    inside = (x >= 0.).all(axis=0) & (x < 1.).all(axis=0)
    return x[:, inside][:, :n]


def best_time(build, repeat):
    """Best of ``repeat`` runs of ``asm(FORM, build())``: (seconds, the
    bases of the last run)."""
    best = np.inf
    for _ in range(repeat):
        tic = time.perf_counter()
        bases = build()
        asm(FORM, bases)
        best = min(best, time.perf_counter() - tic)
    return best, bases


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-points", type=float, default=1e6)
    parser.add_argument("--max-padding", type=float, default=.25)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print("machine: {} {}, Python {}; max_padding {}".format(
        platform.system(), platform.machine(), platform.python_version(),
        args.max_padding))
    print("{:>9} {:>8} {:>7} | {:>9} {:>9} {:>6} | {:>8} {:>8} {:>8} | "
          "{:>7} {:>7}".format(
              "points", "layout", "grid", "slots pad", "slots grp", "bases",
              "padded s", "grouped", "Gauss s", "pad/G", "grp/G"))
    rng = np.random.default_rng(0)
    for n in (10_000, 100_000, 1_000_000):
        if n > args.max_points:
            break
        m = int(round(np.sqrt(n / 4)))
        mesh = MeshQuad.init_tensor(*[np.linspace(0., 1., m + 1)] * 2)
        repeat = args.repeat if n < 1_000_000 else 1
        gauss, _ = best_time(lambda: Basis(mesh, ELEM, intorder=3), repeat)
        for layout, make in (("random", random_points),
                             ("cluster", clustered_points)):
            x = make(n, rng)
            points = MaterialPoints(x=x, volume=np.full(x.shape[1], 1. / n))
            padded, basis = best_time(
                lambda: MaterialPointBasis(mesh, ELEM, points), repeat)
            slots_padded = basis.dx.size
            del basis
            grouped, bases = best_time(lambda: material_point_bases(
                mesh, ELEM, points, max_padding=args.max_padding), repeat)
            print("{:>9} {:>8} {:>7} | {:>9} {:>9} {:>6} | {:>8.3f} {:>8.3f} "
                  "{:>8.3f} | {:>7.2f} {:>7.2f}".format(
                      points.n, layout, "{0}x{0}".format(m), slots_padded,
                      sum(b.dx.size for b in bases), len(bases), padded,
                      grouped, gauss, padded / gauss, grouped / gauss),
                  flush=True)
            del bases


if __name__ == "__main__":
    main()
