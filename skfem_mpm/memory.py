"""What a run would need: sizes this machine cannot hold are refused before
any work, with an estimate, instead of hanging or exhausting the memory.

The per-item figures are measured lower bounds (tracemalloc peaks; the
benchmark tables in ``benchmarks/README.md``), so a refusal is never of a
run that would fit; a run close to the machine's memory may still fail.

Examples
--------
>>> from skfem_mpm.memory import refuse_beyond_memory
>>> refuse_beyond_memory("a tiny run", 1e3, "nothing to change")
>>> try:
...     refuse_beyond_memory("1e12 load steps", 2e15, "use fewer steps")
... except ValueError as err:
...     print(str(err)[:44])
1e12 load steps would need about 2e+15 bytes

"""
import os

from .errors import InvalidInputError

__all__ = ["physical_memory", "refuse_beyond_memory", "GRID_BYTES_PER_CELL",
           "SEED_BYTES_PER_POINT", "RUN_BYTES_PER_POINT", "STEP_RECORD_BYTES"]

#: a scikit-fem tensor mesh with its facets, per cell (324 B measured for
#: quadrilaterals, 762 B for hexahedra)
GRID_BYTES_PER_CELL = {1: 100, 2: 300, 3: 750}
#: seeding (the points' state and the mapping's temporaries; measured 530 B
#: in 2D)
SEED_BYTES_PER_POINT = 500
#: the heap peak of a run per point (1.8 to 2.0 kB in 2D in the
#: benchmarks, 3.6 to 4.3 kB in 3D at 1.1e5 points)
RUN_BYTES_PER_POINT = {1: 1000, 2: 1700, 3: 3300}
#: a step's record in the history without snapshots (scalars, timings,
#: counters)
STEP_RECORD_BYTES = 1500


def physical_memory() -> float:
    """This machine's physical memory in bytes (64 GiB where the system
    does not say)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return 64. * 2 ** 30


def refuse_beyond_memory(what: str, nbytes: float, advice: str):
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` if ``what`` would
    need more than this machine's physical memory."""
    available = physical_memory()
    if nbytes > available:
        raise InvalidInputError(
            "{} would need about {:.3g} bytes ({:.3g} GiB), more than this "
            "machine's {:.3g} GiB: {}".format(what, nbytes, nbytes / 2 ** 30,
                                             available / 2 ** 30, advice))
