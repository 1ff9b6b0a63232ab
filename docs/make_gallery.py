"""Write the gallery's figures: run each example and its ``visualize()``.

The documentation build does not run the examples (too slow for CI); this
script does, once, and the figures it writes under ``docs/gallery/`` are
committed beside the pages that show them.  Run it from anywhere, after a
change to an example or to its plot::

    .venv/bin/python docs/make_gallery.py              # every example
    .venv/bin/python docs/make_gallery.py column slope # only these

Each example is imported as the test suite imports it (its module-level
code computes the results) and its ``visualize`` writes its PNG files into
``docs/gallery/``.  ``penetration`` takes its results as arguments: it is
run as ``python examples/penetration.py`` runs it (h = B/8, 256 steps,
about 1.5 min), and ``methods`` with its footing study
(``footing_study()``: about 12 min more on the shared 2-core machine, the
longest; ``make_gallery.py methods`` redraws only its two figures).
"""
import importlib.util
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
GALLERY = Path(__file__).resolve().parent / "gallery"


def load(name):
    """Import ``examples/NAME.py`` (runs its computation)."""
    spec = importlib.util.spec_from_file_location(name,
                                                  EXAMPLES / (name + ".py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def penetration(module, outdir):
    cells, steps = 8, 256           # the script's command-line defaults
    result, depths, pressures, _ = module.penetrate(cells, steps)
    module.visualize(result, depths, pressures, outdir,
                     ", h = B/{}".format(cells),
                     obstacle=module.penetrate_with_obstacle(cells, steps)[1:])


def obstacles(module, outdir):
    module.visualize(outdir, module.footing_curves())


def methods(module, outdir):
    module.visualize(outdir, module.footing_study())


# examples whose visualize() is not visualize(outdir)
SPECIAL = {"penetration": penetration, "obstacles": obstacles,
           "methods": methods}


def main(names):
    names = names or sorted(p.stem for p in EXAMPLES.glob("*.py"))
    GALLERY.mkdir(exist_ok=True)
    total = time.perf_counter()
    for name in names:
        start = time.perf_counter()
        module = load(name)
        if name in SPECIAL:
            SPECIAL[name](module, GALLERY)
        else:
            module.visualize(GALLERY)
        print("{:18s} {:6.1f} s".format(name, time.perf_counter() - start),
              flush=True)
    print("{:18s} {:6.1f} s".format("total", time.perf_counter() - total))


if __name__ == "__main__":
    main(sys.argv[1:])
