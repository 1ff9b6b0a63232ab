"""Command line: ``skfem-mpm run`` simulates the seed's column.

The command line prints; the library only logs.

"""
import argparse
import logging
import sys
from pathlib import Path

from .column import column_error, run_column, vertical_stress
from .errors import MPMError
from .solver import PHASES

DESCRIPTION = """\
Implicit Material Point Method on scikit-fem.

  skfem-mpm run                 the seed's column under self weight
                                (20 elements, 2 points each, 20 load steps)
  skfem-mpm run --elements 100 --steps 1 --out results
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="skfem-mpm", description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="simulate the seed's column and plot it")
    run.add_argument("--elements", type=int, default=20,
                     help="grid elements over the height (default 20)")
    run.add_argument("--ppc", type=int, default=2,
                     help="points per element and direction (default 2)")
    run.add_argument("--steps", type=int, default=20,
                     help="load steps (default 20)")
    run.add_argument("--dim", type=int, choices=(1, 2), default=1,
                     help="1D column or 2D plane-strain strip (default 1)")
    run.add_argument("--out", type=Path, default=Path("skfem-mpm-output"),
                     help="output folder (default ./skfem-mpm-output)")
    run.add_argument("-v", "--verbose", action="store_true",
                     help="log every load step")
    return parser


def run(args) -> int:
    from .plot import plot_column_stress

    for name in ("elements", "ppc", "steps"):
        if getattr(args, name) < 1:
            print("skfem-mpm: --{} must be a positive integer, got {}"
                  .format(name, getattr(args, name)), file=sys.stderr)
            return 2
    result = run_column(args.elements, args.ppc, args.steps, dim=args.dim,
                        keep_snapshots=False)
    pts = result.points
    timings = result.timings()
    total = sum(timings.values())
    print("column under self weight: {}D, {} elements, {} points, {} load "
          "steps".format(args.dim, args.elements, pts.n, args.steps))
    print("  error (2.28)              {:.4e}".format(column_error(pts)))
    print("  top displacement          {:.4f}".format(
        pts.displacement[-1][pts.x0[-1].argmax()]))
    print("  base stress (min)         {:.1f}".format(
        vertical_stress(pts).min()))
    print("  max equilibrium residual  {:.1e}".format(
        max(r.residual for r in result.history)))
    print("  time {:.3f} s: ".format(total) + ", ".join(
        "{} {:.0%}".format(p, timings[p] / total) for p in PHASES))
    path = args.out / "column_stress.png"
    plot_column_stress([result], ["MPM, {} steps".format(args.steps)], path,
                       title="{} elements, {} points per element".format(
                           args.elements, args.ppc ** args.dim))
    print("  plot                      {}".format(path))
    return 0


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else
                        logging.WARNING, format="%(name)s: %(message)s")
    try:
        return run(args)
    except MPMError as err:
        print("skfem-mpm: {}: {}".format(type(err).__name__, err),
              file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
