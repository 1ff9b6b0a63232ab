"""The linear solve on the active grid, seed (2.22), with its failure modes
turned into errors.

Grid nodes without point support have empty rows; the system is condensed
onto the active DOFs that are not supported, and a singular or unusable
factorisation raises :class:`~skfem_mpm.errors.SingularSystemError` instead
of scipy's warning followed by garbage.

"""
import warnings
from typing import Callable, Optional

import numpy as np
from numpy import ndarray
from scipy.sparse import spmatrix
from scipy.sparse.linalg import MatrixRankWarning, splu
from skfem import condense, solve

from .errors import InvalidInputError, SingularSystemError

__all__ = ["support_dofs", "free_dofs", "solver_direct_checked",
           "solve_active"]


def support_dofs(supports, basis) -> ndarray:
    """Turn ``supports`` into a sorted array of DOF indices.

    ``supports`` is an array of DOF indices, a scikit-fem ``DofsView``
    (anything with ``.all()``), or a callable taking the grid basis and
    returning one of those, e.g. ``lambda b: b.get_dofs("left")``.

    """
    if callable(supports):
        supports = supports(basis)
    if not isinstance(supports, ndarray) and hasattr(supports, "all"):
        supports = supports.all()
    D = np.unique(np.asarray(supports, dtype=np.int64).ravel())
    if D.size and (D.min() < 0 or D.max() >= basis.N):
        raise InvalidInputError(
            "support DOF indices must lie in [0, {}), got {}..{}"
            .format(basis.N, D.min(), D.max()))
    return D


def free_dofs(active: ndarray, D: ndarray) -> ndarray:
    """The active DOFs that are not supported.

    Raises :class:`~skfem_mpm.errors.SingularSystemError` when no active DOF
    is supported: the body could move freely.

    """
    free = np.setdiff1d(active, D, assume_unique=True)
    if free.size == active.size:
        raise SingularSystemError(
            "none of the {} active grid DOFs is supported; the body can move "
            "freely (rigid-body modes): add supports on grid nodes the body "
            "occupies".format(active.size))
    return free


def solver_direct_checked(pivot_tol: float = 1e-10) -> Callable:
    """scipy's sparse LU (SuperLU) as a scikit-fem solver ``f(A, b) -> x``
    that refuses singular systems.

    A stiffness with rigid-body modes factorises with a pivot at round-off
    level (1e-16 to 1e-11 of the largest pivot, growing with the size) where
    a supported body's smallest pivot is a sizeable fraction of the largest
    one; pivots below ``pivot_tol`` times the largest raise
    :class:`~skfem_mpm.errors.SingularSystemError`.

    """
    def solver(A, b, **kwargs):
        try:
            lu = splu(A.tocsc())
        except RuntimeError as err:
            raise SingularSystemError(
                "the stiffness on {} free DOFs is singular ({}): the active "
                "grid has rigid-body modes; add supports".format(A.shape[0],
                                                                 err)) from err
        pivots = np.abs(lu.U.diagonal())
        ratio = pivots.min() / pivots.max()
        if not ratio >= pivot_tol:
            raise SingularSystemError(
                "the stiffness on {} free DOFs is singular: smallest pivot "
                "{:.1e} of the largest (below {:.0e}); the active grid has "
                "rigid-body modes: add supports".format(A.shape[0], ratio,
                                                        pivot_tol))
        return lu.solve(b)

    return solver


def solve_active(K: spmatrix, f: ndarray, free: ndarray,
                 solver: Optional[Callable] = None, tol: float = 1e-8,
                 ) -> ndarray:
    """Solve ``K u = f`` on the DOFs ``free`` (zero elsewhere) with
    scikit-fem's ``condense`` and ``solve``.

    ``solver`` is a scikit-fem solver ``f(A, b) -> x``; default
    :func:`solver_direct_checked`.

    Raises
    ------
    SingularSystemError
        When the condensed system is empty, singular (rigid-body modes:
        missing supports) or its solution does not satisfy it to ``tol``.

    """
    if free.size == 0:
        raise SingularSystemError("no free degree of freedom: every active "
                                  "grid DOF is supported")
    with warnings.catch_warnings():
        warnings.simplefilter("error", MatrixRankWarning)
        try:
            A, b, x, I = condense(K, f, I=free)
            u = solve(A, b, x, I, solver=solver_direct_checked()
                      if solver is None else solver)
        except (MatrixRankWarning, RuntimeError) as err:
            raise SingularSystemError(
                "the stiffness on {} free DOFs is singular ({}): the active "
                "grid has rigid-body modes; add supports".format(free.size,
                                                                 err)) from err
    r = A @ u[I] - b
    scale = max(np.linalg.norm(b), np.finfo(float).tiny)
    if not np.all(np.isfinite(u)) or np.linalg.norm(r) > tol * scale:
        raise SingularSystemError(
            "the stiffness on {} free DOFs is singular or too ill-conditioned:"
            " relative residual {:.2e} of the solve; the active grid probably"
            " has rigid-body modes (missing supports)".format(
                free.size, np.linalg.norm(r) / scale))
    return u
