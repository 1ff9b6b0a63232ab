"""Point operators: what a load step needs from the grid, whatever the
method.

A point operator maps grid displacements to point values and gradients and
assembles forces and tangents from point stresses, with the gradients taken
at the start of the load step.  Standard MPM uses scikit-fem's ``asm`` on a
:class:`~skfem_mpm.MaterialPointBasis`; GIMP, whose points couple nodes of
several elements, uses sparse per-point operators built in
:mod:`skfem_mpm.gimp`.  Both expose:

- ``N`` (number of vector DOFs), ``active_dofs``, ``nelems`` (active
  elements),
- ``values(u) -> (dim, n)`` and ``gradients(u) -> (dim, dim, n)``,
- ``force(P, w)``: ``f_ai = sum_p w_p P_abp dN_i/dx_b`` (internal force),
- ``point_force(f)``: ``f_ai = sum_p N_i(x_p) f_ap`` (point and body forces),
- ``stiffness(A, w)``: ``K_(ai)(cj) = sum_p w_p A_abcdp dN_i/dx_b dN_j/dx_d``,
- ``adjacency()``: grid nodes coupled by points (for rigid-body checks).

"""
from typing import Optional

import numpy as np
from numpy import ndarray
from scipy.sparse import bmat, csr_matrix
from skfem.assembly import BilinearForm, LinearForm, asm
from skfem.helpers import ddot, grad

from .basis import MaterialPointBasis
from .fastpath import (ElementPattern, local_force, local_load,
                       local_stiffness, scalar_fields)
from .forms import body_force
from .linsolve import element_adjacency

__all__ = ["AsmOperator", "SparseOperator"]


@BilinearForm
def pulled_tangent(u, v, w):
    """``A_abcd dv_a/dx_b du_c/dx_d`` with the tangent A at the points."""
    return np.einsum("abcd...,ab...,cd...->...", w.A, grad(v), grad(u))


@LinearForm
def pulled_force(v, w):
    """``P : grad(v)`` with a (non-symmetric) stress P at the points."""
    return ddot(w.P, grad(v))


class AsmOperator:
    """Standard MPM on a material-point basis: scikit-fem's ``asm``, or the
    vectorised fast path of :mod:`skfem_mpm.fastpath` (equal to round-off)
    for the force and the stiffness.

    Parameters
    ----------
    basis
        A :class:`~skfem_mpm.MaterialPointBasis` with a vector element.
    pattern
        The grid's :class:`~skfem_mpm.fastpath.ElementPattern` to share
        between steps (built here when not given).
    fast
        Assemble forces and stiffness with the fast path.

    """

    def __init__(self, basis: MaterialPointBasis,
                 pattern: Optional[ElementPattern] = None, fast: bool = True):
        self.basis = basis
        self.fast = fast
        if fast:
            self._pattern = pattern
            self._N, self._G = scalar_fields(basis)
        self.dim = basis.mesh.dim()
        self.N = basis.N
        self.nelems = basis.nelems
        self.elements = basis.tind
        self.active_dofs = basis.active_dofs

    def values(self, u: ndarray) -> ndarray:
        return self.basis.point_values(np.asarray(self.basis.interpolate(u)))

    def gradients(self, u: ndarray) -> ndarray:
        return self.basis.point_values(self.basis.interpolate(u).grad)

    def _field(self, values: ndarray, w: ndarray) -> ndarray:
        """Point values times weights over volumes: asm multiplies by dx."""
        return self.basis.quadrature_field(values * (w / self._volumes()))

    def _volumes(self) -> ndarray:
        return self.basis.point_values(self.basis.dx)

    def pattern(self) -> ElementPattern:
        """The grid's stiffness pattern (built on first use if not given)."""
        if self._pattern is None:
            self._pattern = ElementPattern(self.basis.dofs.element_dofs,
                                           self.N)
        return self._pattern

    def force(self, P: ndarray, w: ndarray) -> ndarray:
        if self.fast:
            f = local_force(self._G, self.basis.quadrature_field(P * w))
            return np.bincount(self.basis.element_dofs.ravel(),
                               weights=f.ravel(), minlength=self.N)
        return asm(pulled_force, self.basis, P=self._field(P, w))

    def point_force(self, f: ndarray) -> ndarray:
        if self.fast:
            local = local_load(self._N, self.basis.quadrature_field(f))
            return np.bincount(self.basis.element_dofs.ravel(),
                               weights=local.ravel(), minlength=self.N)
        return asm(body_force, self.basis, b=self._field(f, np.ones(f.shape[1])))

    def stiffness(self, A: ndarray, w: ndarray):
        if self.fast:
            return self.pattern().matrix(local_stiffness(
                self._G, self.basis.quadrature_field(A * w)), self.basis.tind)
        return asm(pulled_tangent, self.basis, A=self._field(A, w))

    def adjacency(self):
        return element_adjacency(self.basis.element_dofs, self.dim,
                                 self.N // self.dim)


class SparseOperator:
    """Per-point sparse operators ``S`` (values) and ``G[d]`` (gradients),
    each (n_points, n_scalar_dofs), of a scalar element; vector DOFs are
    interleaved as in scikit-fem's ``ElementVector`` (``dim * k + a``).

    Parameters
    ----------
    S, G
        csr matrices: ``S[p, k]`` weight of scalar DOF k at point p and
        ``G[d][p, k]`` its derivative along axis d.
    elements
        The active elements (holding part of a point's domain).

    """

    def __init__(self, S: csr_matrix, G, elements: ndarray):
        self.S, self.G = S, list(G)
        self.dim = len(self.G)
        self.N = self.dim * S.shape[1]
        self.elements = elements
        self.nelems = len(elements)
        support = np.unique(np.concatenate([S.indices] +
                                           [g.indices for g in self.G]))
        self.active_dofs = (self.dim * support[:, None]
                            + np.arange(self.dim)).ravel()

    def adjacency(self):
        pattern = self.S.copy()
        pattern.data[:] = 1.
        return (pattern.T @ pattern).tocsr()

    def _components(self, u: ndarray) -> ndarray:
        return u.reshape(-1, self.dim)

    def values(self, u: ndarray) -> ndarray:
        return (self.S @ self._components(u)).T

    def gradients(self, u: ndarray) -> ndarray:
        U = self._components(u)
        return np.array([g @ U for g in self.G]).transpose(2, 0, 1)

    def _interleave(self, parts: ndarray) -> ndarray:
        return np.asarray(parts).T.ravel()

    def force(self, P: ndarray, w: ndarray) -> ndarray:
        return self._interleave([
            sum(self.G[b].T @ (w * P[a, b]) for b in range(self.dim))
            for a in range(self.dim)])

    def point_force(self, f: ndarray) -> ndarray:
        return self._interleave([self.S.T @ f[a] for a in range(self.dim)])

    def stiffness(self, A: ndarray, w: ndarray):
        dim = self.dim
        blocks = [[sum(self.G[b].T @ self.G[d].multiply(
            (w * A[a, b, c, d])[:, None]).tocsr()
            for b in range(dim) for d in range(dim))
            for c in range(dim)] for a in range(dim)]
        K = bmat(blocks, format="csr")
        n = self.S.shape[1]
        order = (np.arange(dim)[None, :] * n + np.arange(n)[:, None]).ravel()
        return K[order][:, order]
