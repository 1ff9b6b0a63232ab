"""The ``skfem-mpm`` command's entry point, and ``python -m skfem_mpm``.

Light on purpose: the package's ``__init__`` imports nothing heavy
(:mod:`skfem_mpm`), and this module imports the command line
(:mod:`skfem_mpm.cli`, with numpy, scipy, scikit-fem and meshio) inside
:func:`main`, so that a Ctrl-C while those load (the first half second of
a run) gets the one line and exit status 130 of a Ctrl-C at any later
moment instead of a ``KeyboardInterrupt`` traceback.

"""
import sys


def main(argv=None) -> int:
    """Import the command line and run ``skfem-mpm`` on ``argv`` (default
    ``sys.argv``): its exit status; 130 with one line on stderr for a
    Ctrl-C while it is imported."""
    try:
        from .cli import main as command
    except KeyboardInterrupt:
        print("skfem-mpm: interrupted while starting (loading the package): "
              "nothing done", file=sys.stderr)
        return 130
    return command(argv)


if __name__ == "__main__":
    sys.exit(main())
