"""What accuracy costs in time, method by method.

Every method on two problems at matched grids, 2 points per cell and
axis, every setting the default: the seed's column under its weight (1D,
finite deformation, 20 load steps, so that points cross cells; error
(2.28) of Charlton 2018 against the closed form) and the user cantilever
of issue 31 (``P L^2 / EI = 3``, 20 steps, clamped; error of the tip
deflection against the continuum's, extrapolated from FE on grids down to
h = 1/32).  Each case's CPU time is measured; the orders fitted in the
cell size and in time, and the cheapest method for an error asked for,
are what a user needs to choose.

Run ``python examples/methods.py [OUTDIR]`` to print the tables and write
``methods.png``.
"""
from skfem_mpm.studies.methods import (METHODS, cantilever_reference,
                                       cheapest, methods_study, orders)

ELEMENTS = (8, 16, 32, 64, 128, 256, 512, 1024)
SIZES = (1., .5, .25, .125)

column = methods_study("column", [50. / n for n in ELEMENTS])
reference = cantilever_reference((.25, .125, .0625, .03125))
cantilever = methods_study("cantilever", SIZES,
                           reference=reference.reference)
found = {"column": orders(column), "cantilever": orders(cantilever)}
TARGETS = {"column": (1e-2, 3e-3, 1e-3, 3e-4),
           "cantilever": (3e-2, 1e-2, 3e-3)}
choices = {name: {target: cheapest(rows, target)
                  for target in TARGETS[name]}
           for name, rows in (("column", column),
                              ("cantilever", cantilever))}


def visualize(outdir="."):
    from pathlib import Path
    from skfem_mpm.studies.methods import plot_methods
    plot_methods({"column": column, "cantilever": cantilever},
                 Path(outdir) / "methods.png",
                 {"column": "the seed's column, 20 load steps: error (2.28)"
                            " of Charlton (2018)\nat 8 to 1024 elements",
                  "cantilever": "the user cantilever, P L^2 / EI = 3: tip "
                                "deflection against\nthe continuum's, h = 1"
                                " to 1/8"})


if __name__ == "__main__":
    import sys
    for name, rows in (("column", column), ("cantilever", cantilever)):
        print("{}: method, cell size, error, CPU s, Newton iterations, "
              "ghost from step".format(name))
        for r in rows:
            print("  {:12s} {:8.4f} {:9.2e} {:7.2f} {:5d} {:3d}".format(
                r["method"], r["h"], r["error"], r["cpu_seconds"],
                r["newton_iterations"], r["ghost_from_step"]))
        for method in METHODS:
            print("  {:12s} order {:5.2f} in h, {:5.2f} in time".format(
                method, found[name][method]["h"],
                found[name][method]["time"]))
        for target, best in choices[name].items():
            reached = sorted((r["cpu_seconds"], m) for m, r in best.items()
                             if r is not None)
            print("  error <= {:g} from some grid on: {}".format(
                target, ", ".join("{} {:.2f} s".format(m, t)
                                  for t, m in reached) or "no method"))
    print("cantilever reference v/L = {:.5f} (relative uncertainty of the "
          "finest FE grid {:.1e}; {})".format(
              reference.reference,
              reference.uncertainties[-1] / reference.reference,
              reference.why))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
