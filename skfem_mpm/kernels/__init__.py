"""Compiled (numba) kernels of a Newton iteration, and their choice.

``kernels="auto"`` (the default) runs the compiled points-first passes
(:mod:`skfem_mpm.kernels.passes`) where they cover a run and numba
imports, the numpy path otherwise; ``"numpy"`` always takes the numpy
path (the tested reference); ``"compiled"`` asks for the compiled passes
and refuses, before any work, a run they cannot serve (numba missing, a
material, dimension or scheme without compiled passes:
:func:`skfem_mpm.mechanics.compiled.compiled_path`).  They serve standard
MPM's element operator and the sparse operators of uGIMP, cpGIMP and
B-splines, with or without mean dilatation
(:mod:`skfem_mpm.kernels.dilatation`; F-bar on the increment in finite
deformation, :mod:`skfem_mpm.kernels.fbar`), in 2D and 3D, small and finite
deformation (not the total Lagrangian scheme of ``method="fem"``),
``LinearElastic``, ``VonMises``, ``DruckerPrager``, ``MohrCoulomb`` and
``ModifiedCamClay``, one for all points or one per body (each point takes
its body's parameters); not a user's material, also as one body's.  numba
is imported only when a run first asks for the passes, so that ``import
skfem_mpm`` stays light; the kernels are cached on disk, so a second
process does not compile them again.  The environment variable
``SKFEM_MPM_KERNELS=numpy`` makes ``"auto"`` take the numpy path
(:func:`auto_kernels`; logged once at INFO): a short run on a machine
whose kernel cache is empty spares the passes' compilation (about 90 s
once), and the README's fast test command runs so.

numba's compilation and its loads from the disk cache in a process are
timed (:func:`compile_seconds`, the first compilation logged at INFO)
and left out of every time the package measures (:func:`run_clock`): a
first run on an empty kernel cache took 27 s, 91% of it booked to the
assembly, where the run itself took 0.7 s.
"""
import importlib
import logging
import os
import threading
import time

from ..errors import InvalidInputError

__all__ = ["KERNELS", "ELASTIC", "VON_MISES", "DRUCKER_PRAGER",
           "MOHR_COULOMB", "CAM_CLAY", "PER_ENTRY", "PER_NODE_PAIR",
           "BISECTION", "AUTO_VARIABLE", "check_kernels", "auto_kernels",
           "compiled_passes", "log_once", "compile_seconds", "run_clock",
           "time_compilation", "import_timed"]

logger = logging.getLogger(__name__)

KERNELS = ("auto", "numpy", "compiled")
#: the material kinds of the compiled return maps, first entry of their
#: parameter vector ``(kind, lam, mu, E, nu, ...)``
#: (:func:`skfem_mpm.mechanics.compiled.material_parameters`)
ELASTIC, VON_MISES, DRUCKER_PRAGER, MOHR_COULOMB = 0., 1., 2., 3.
CAM_CLAY = 4.
#: how the stiffness pass finds the CSR places of a group's entries
#: (:class:`~skfem_mpm.methods.assembly.KernelLayout`): the element
#: pattern's map per entry or per node pair, or bisection of the rows of
#: the node graph
PER_ENTRY, PER_NODE_PAIR, BISECTION = 0, 1, 2

_LOGGED = set()
_PASSES = []
_TIMED = []           # numba's compilations timed (time_compilation)
#: per thread (its ident), the seconds numba has compiled in it
_COMPILING = {}


def log_once(level: int, message: str, *args) -> None:
    """Log ``message % args`` once per process (each text once: a few
    reasons and operator kinds, so the set stays small)."""
    text = message % args
    if text not in _LOGGED:
        _LOGGED.add(text)
        logger.log(level, text)


def check_kernels(kernels) -> str:
    """``kernels`` if it is one of :data:`KERNELS`, else
    :class:`~skfem_mpm.errors.InvalidInputError`.

    >>> check_kernels("fast")
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: kernels must be one of 'auto', 'numpy', 'compiled', got 'fast'
    """
    if not isinstance(kernels, str) or kernels not in KERNELS:
        raise InvalidInputError("kernels must be one of {}, got {!r}".format(
            ", ".join(map(repr, KERNELS)), kernels))
    return kernels


#: the environment variable that says what ``kernels="auto"`` takes
AUTO_VARIABLE = "SKFEM_MPM_KERNELS"


def auto_kernels() -> str:
    """What ``kernels="auto"`` takes: ``"numpy"`` where the environment
    variable :data:`AUTO_VARIABLE` is ``numpy``, ``"auto"`` (the compiled
    passes where they serve a run) where it is ``auto`` or unset; another
    value is refused (:class:`~skfem_mpm.errors.InvalidInputError`).

    >>> import os
    >>> os.environ.get(AUTO_VARIABLE, "auto") == auto_kernels()
    True
    """
    value = os.environ.get(AUTO_VARIABLE, "auto")
    if value not in ("auto", "numpy"):
        raise InvalidInputError(
            "the environment variable {} must be 'auto' or 'numpy', got "
            "{!r}".format(AUTO_VARIABLE, value))
    return value


def compiled_passes():
    """The module :mod:`skfem_mpm.kernels.passes`, or ``None`` where numba
    does not import (logged once: the numpy path serves)."""
    if not _PASSES:
        try:
            passes = import_timed("skfem_mpm.kernels.passes")
        except ImportError as err:
            log_once(logging.INFO, "numba does not import (%s): the numpy "
                     "path serves every run", err)
            passes = None
        _PASSES.append(passes)
    return _PASSES[0]


def import_timed(name: str):
    """The kernels' module ``name``, imported, the import's seconds
    counted as loading (:func:`time_compilation`; those numba's compiler
    lock already counted, once)."""
    tic, counted = time.perf_counter(), compile_seconds()
    module = importlib.import_module(name)
    time_compilation(time.perf_counter() - tic
                     - (compile_seconds() - counted))
    return module


def compile_seconds() -> float:
    """The seconds numba has spent compiling and loading kernels from
    its disk cache in the calling thread (from the first compiled
    kernel asked for on; :func:`time_compilation`)."""
    return _COMPILING.get(threading.get_ident(), 0.)


def run_clock() -> float:
    """``time.perf_counter()`` less :func:`compile_seconds`: the clock of
    every time a run measures (its phases, ``wall_seconds``), so that
    the kernels' compilation, once per installation, is counted in none
    of them (a thread's own: another thread compiling meanwhile is not
    subtracted).

    >>> tic = run_clock()
    >>> 0. <= run_clock() - tic < 1.
    True
    """
    return time.perf_counter() - compile_seconds()


def time_compilation(imported: float = 0.) -> None:
    """Add the seconds numba holds its compiler lock to
    :func:`compile_seconds` of the thread from now on (its
    ``numba:compiler_lock`` events, outermost per thread: compiling a
    kernel, and loading one from the disk cache, about 0.4 s a process,
    which a cached run booked to its first locate, 46-61% of the
    README's column), and log the first compilation at INFO.
    Registered once, when the first compiled kernels are imported;
    ``imported``, the seconds that import took (numba's own, about 0.5
    s), counts as loading too."""
    thread = threading.get_ident()
    _COMPILING[thread] = _COMPILING.get(thread, 0.) + imported
    if _TIMED:
        return
    _TIMED.append(True)
    from numba.core import event

    class LockTimer(event.Listener):
        """The seconds from asking for the lock to releasing it."""

        def __init__(self):
            self.local = threading.local()

        def on_start(self, _):
            depth = getattr(self.local, "depth", 0)
            if depth == 0:
                self.local.tic = time.perf_counter()
            self.local.depth = depth + 1

        def on_end(self, _):
            self.local.depth -= 1
            if self.local.depth == 0:
                thread = threading.get_ident()
                _COMPILING[thread] = _COMPILING.get(thread, 0.) + (
                    time.perf_counter() - self.local.tic)

    class CompileLog(event.Listener):
        def on_start(self, _):
            log_once(logging.INFO, "compiling the kernels (once per "
                     "installation: later processes load them from "
                     "numba's cache); its time is left out of the run's")

        def on_end(self, _):
            pass

    event.register("numba:compiler_lock", LockTimer())
    event.register("numba:compile", CompileLog())
