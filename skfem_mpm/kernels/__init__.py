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
(:mod:`skfem_mpm.kernels.dilatation`), in 2D and 3D, small and finite
deformation (not the total Lagrangian scheme of ``method="fem"``),
``LinearElastic``, ``VonMises``, ``DruckerPrager``, ``MohrCoulomb`` and
``ModifiedCamClay``; not a user's material or one material per body.  numba is
imported only when a run first asks for the passes, so that ``import
skfem_mpm`` stays light; the kernels are cached on disk, so a second
process does not compile them again.
"""
import logging

from ..errors import InvalidInputError

__all__ = ["KERNELS", "ELASTIC", "VON_MISES", "DRUCKER_PRAGER",
           "MOHR_COULOMB", "CAM_CLAY", "PER_ENTRY", "PER_NODE_PAIR",
           "BISECTION", "check_kernels", "compiled_passes", "log_once"]

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


def compiled_passes():
    """The module :mod:`skfem_mpm.kernels.passes`, or ``None`` where numba
    does not import (logged once: the numpy path serves)."""
    if not _PASSES:
        try:
            from . import passes
        except ImportError as err:
            log_once(logging.INFO, "numba does not import (%s): the numpy "
                     "path serves every run", err)
            passes = None
        _PASSES.append(passes)
    return _PASSES[0]
