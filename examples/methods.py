"""What accuracy costs in time, method by method.

Every method on three problems at matched grids, 2 points per cell and
axis, every setting the default: the seed's column under its weight (1D,
finite deformation, 20 load steps, so that points cross cells; error
(2.28) of Charlton 2018 against the closed form), the user cantilever
of issue 31 (``P L^2 / EI = 3``, 20 steps, clamped; error of the tip
deflection against the continuum's, extrapolated from FE on grids down to
h = 1/32) and Prandtl's smooth strip footing (:func:`footing_study`: a
rigid box obstacle pushed 0.005 B into weightless von Mises soil with
the mean dilatation, B / h = 4 to 16, the B-splines also with 3 points
per cell; error of the pressure at the end against ``(2 + pi) c_u``).
Each case's CPU time is measured; the orders fitted in the cell size and
in time, and the cheapest method for an error asked for, are what a user
needs to choose.

The column and the cantilever are computed on import (about 70 s); the
footing only by :func:`footing_study` (about 12 min on the shared 2-core
machine: GIMP and the B-splines take 1-5 min each at B / h = 16).

Run ``python examples/methods.py [OUTDIR]`` to print the tables and write
``methods.png`` and ``methods_footing.png``.
"""
from skfem_mpm.studies.methods import (cantilever_reference, cheapest,
                                       footing_reference, methods_study,
                                       orders, series)

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


#: the footing's grids: cells across its width B
RATIOS = (4, 8, 16)
#: the methods run again on the footing with 3 points per cell and axis
SPLINES = ("bspline", "bspline-gimp")


def footing_study(ratios=RATIOS):
    """The footing on grids of B / h = ``ratios``: every method with 2
    points per cell and axis, then the B-splines with 3 (at 2 they fall
    short of Prandtl's pressure); the rows of
    :func:`~skfem_mpm.studies.methods.methods_study`, ``value`` the
    pressure over ``c_u`` at a settlement of 0.005 B, ``error`` against
    Prandtl's ``2 + pi``."""
    sizes, limit = [1. / n for n in ratios], footing_reference()
    return (methods_study("footing", sizes, reference=limit)
            + methods_study("footing", sizes, SPLINES, 3, reference=limit))


def visualize(outdir=".", footing=None):
    """``methods.png``: error against CPU time on the column, the
    cantilever and (given ``footing``, the rows of
    :func:`footing_study`) the footing; with ``footing`` also
    ``methods_footing.png``, its curves and pressures against Prandtl's."""
    from pathlib import Path
    from skfem_mpm.studies.methods import plot_footing, plot_methods
    studies = {"column": column, "cantilever": cantilever}
    titles = {"column": "the seed's column, 20 load steps: error (2.28)"
                        " of Charlton (2018)\nat 8 to 1024 elements",
              "cantilever": "the user cantilever, P L^2 / EI = 3: tip "
                            "deflection against\nthe continuum's, h = 1"
                            " to 1/8"}
    if footing is not None:
        studies["footing"] = footing
        ratios = [1 / r["h"] for r in footing]
        titles["footing"] = ("Prandtl's smooth footing: pressure at 0.005 B"
                             " against (2 + pi) c_u,\nB / h = {:g} to {:g}"
                             .format(min(ratios), max(ratios)))
        plot_footing(footing, Path(outdir) / "methods_footing.png",
                     footing_reference())
    plot_methods(studies, Path(outdir) / "methods.png", titles,
                 {"footing": dict(loc="upper left", bbox_to_anchor=(1, 1))})


def print_rows(name, rows):
    """The rows of a study as a table, and each series' fitted orders."""
    print("{}: method, cell size, value, error, CPU s, wall s, steps, "
          "Newton iterations, ghost from step".format(name))
    for label, mine in series(rows).items():
        for r in mine:
            print("  {:24s} {:8.4f} {:9.4g} {:9.2e} {:7.2f} {:7.2f} {:4d} "
                  "{:5d} {:3d}".format(label, r["h"], r["value"],
                                       r["error"], r["cpu_seconds"],
                                       r["wall_seconds"], r["steps"],
                                       r["newton_iterations"],
                                       r["ghost_from_step"]))
    for label, order in orders(rows).items():
        print("  {:24s} order {:5.2f} in h, {:5.2f} in time".format(
            label, order["h"], order["time"]))


if __name__ == "__main__":
    import sys
    for name, rows in (("column", column), ("cantilever", cantilever)):
        print_rows(name, rows)
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
    footing = footing_study()
    print_rows("footing", footing)
    print("footing: drift of the pressure over the second half of the "
          "push: " + ", ".join("{} B/{:g} {:+.2%}".format(
              label, 1 / r["h"], r["drift"])
              for label, mine in series(footing).items() for r in mine))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".", footing)
