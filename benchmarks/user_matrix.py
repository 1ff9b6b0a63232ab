"""Set-ups as a new user writes them, nothing tuned: does each complete,
how far from its reference, at what cost.  Prints the table of
``docs/robustness.md``.

Cantilevers: clamped root, end load spread over the tip points,
P L^2 / (E I) = 3 in 20 steps, finite deformation, reference the elastica.
Blocks: a soft block (E = 1e3) squashed by a traction on its top (20% of E)
or sheared (5%), base clamped, 10 steps, reference the finest grid of the
same method (the points' mean top displacement).
Footing: a smooth strip footing pushed 0.02 (8% of its half-width) into
undrained von Mises soil, 10 steps of prescribed displacement of the grid
nodes under it;
quantity the footing pressure / c_u, reference the finest grid of the same
method (Prandtl's collapse pressure 5.14 c_u is the limit of a plateau these
settlements approach).
Slope: a 45 degree undrained slope under its own weight (gamma H / c_u =
3.3, yielding but stable), 10 steps; quantity the crest displacement,
reference the finest grid of the same method.
All set-ups: :mod:`skfem_mpm.studies.user_setups` and
:func:`skfem_mpm.studies.elastica.untuned_cantilever`.

Run: ``python benchmarks/user_matrix.py`` (about ten minutes on 2 cores).
"""
import time

import numpy as np

from skfem_mpm import MPMError
from skfem_mpm.studies.elastica import untuned_cantilever
from skfem_mpm.studies.user_setups import block, footing, slope

HEADER = "{:10s} {:>6s} {:>4s} {:>7s} {:>10s} {:>9s} {:>6s} {:>6s} {:>7s}"
ROW = "{:10s} {:6.3f} {:4d} {:>7s} {:>10s} {:>9s} {:>6} {:>6} {:7.1f}"


def row(name, h, per_cell, method, run, reference=None):
    """One line of the table: ``run()`` returns (result, quantity)."""
    tic = time.perf_counter()
    try:
        res, quantity = run()
        error = quantity if reference is None else np.linalg.norm(
            np.subtract(quantity, reference)) / np.linalg.norm(reference)
        cells = ("completed", "{:.1e}".format(error),
                 res.counters["ghost_from_step"] or "-",
                 res.counters["line_search_trials"])
    except MPMError as e:
        cells = (type(e).__name__[:10], "-", "-", "-")
    print(ROW.format(name, h, per_cell, method, *cells,
                     time.perf_counter() - tic), flush=True)


def main():
    print(HEADER.format("set-up", "h", "ppc", "method", "status", "error",
                        "ghost", "ls", "s"))
    for h in (.5, .25):
        for per_cell in (2, 4):
            for method in ("mpm", "cpgimp"):
                row("cantilever", h, per_cell, method,
                    lambda: untuned_cantilever(h, per_cell, method))
    cases = [("squashed", lambda h, n, m: block(h, n, m, [0., -200.]),
              (.5, .25, .125), 1 / 16),
             ("sheared", lambda h, n, m: block(h, n, m, [50., 0.]),
              (.5, .25, .125), 1 / 16),
             ("footing", footing, (.25, .125, .0625), 1 / 32),
             ("slope", slope, (.5, .25, .125), 1 / 16)]
    for name, setup, spacings, finest in cases:
        for method in ("mpm", "cpgimp"):
            reference = setup(finest, 2, method)[1]
            print("{:10s} reference (h = {:.4f}, 2 ppc, {}): {}".format(
                name, finest, method, np.round(reference, 6)), flush=True)
            for h in spacings:
                for per_cell in (2, 4):
                    row(name, h, per_cell, method,
                        lambda: setup(h, per_cell, method), reference)


if __name__ == "__main__":
    main()
