"""Point operators: what a load step needs from the grid, whatever the
method.

A point operator maps grid displacements to point values and gradients and
assembles forces and tangents from point stresses, with the gradients taken
at the start of the load step.  Standard MPM evaluates the scikit-fem element at
the points through a :class:`~skfem_mpm.MaterialPointBasis` and assembles
with scikit-fem's ``asm`` (:class:`AsmOperator`) or its vectorised twin
(:class:`PointOperator`, the default); GIMP, whose points couple nodes of
several elements, uses sparse per-point operators built in
:mod:`skfem_mpm.methods.gimp`.  Both expose:

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
from scipy.sparse import csr_matrix
from skfem.assembly import BilinearForm, LinearForm, asm
from skfem.helpers import ddot, grad

from ..quadrature.basis import MaterialPointBasis
from ..errors import InvalidInputError
from ..kernels import BISECTION, PER_ENTRY, PER_NODE_PAIR
from ..graph import distinct, edge_graph, element_adjacency
from .assembly import (ElementPattern, GraphPattern, KernelLayout,
                       phased_chunks,
                       local_force, local_load, local_stiffness)
from ..mechanics.forms import body_force

__all__ = ["AsmOperator", "SparseOperator"]

#: the arrays a layout does not use (one type for every call of a pass:
#: the places' arrays C-contiguous in both layouts, so that standard MPM
#: and the sparse operators share each compiled pass)
NO_INDEX = np.zeros(0, dtype=np.int64)
NO_PLACES = np.zeros((0, 0), dtype=np.int32)


@BilinearForm
def pulled_tangent(u, v, w):
    """``A_abcd dv_a/dx_b du_c/dx_d`` with the tangent A at the points."""
    return np.einsum("abcd...,ab...,cd...->...", w.A, grad(v), grad(u))


@LinearForm
def pulled_force(v, w):
    """``P : grad(v)`` with a (non-symmetric) stress P at the points."""
    return ddot(w.P, grad(v))


class AsmOperator:
    """Standard MPM through scikit-fem's ``asm`` on a material-point basis
    with a vector element: the reference the fast :class:`PointOperator` is
    tested against, and the path for user-supplied forms.

    Parameters
    ----------
    basis
        A :class:`~skfem_mpm.MaterialPointBasis` with a vector element.

    """

    #: the grid's connectivity (rigid-body check) follows from the active
    #: elements alone
    connectivity_from_elements = True

    def __init__(self, basis: MaterialPointBasis):
        self.basis = basis
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
        volumes = self.basis.point_values(self.basis.dx)
        return self.basis.quadrature_field(values * (w / volumes))

    def force(self, P: ndarray, w: ndarray) -> ndarray:
        return asm(pulled_force, self.basis, P=self._field(P, w))

    def point_force(self, f: ndarray) -> ndarray:
        return asm(body_force, self.basis,
                   b=self._field(f, np.ones(f.shape[1])))

    def stiffness(self, A: ndarray, w: ndarray):
        return asm(pulled_tangent, self.basis, A=self._field(A, w))

    def adjacency(self):
        return element_adjacency(self.basis.element_dofs, self.dim,
                                 self.N // self.dim)


class PointOperator:
    """Standard MPM, vectorised (:mod:`skfem_mpm.methods.assembly`): the same
    operator as :class:`AsmOperator`, to round-off, from a material-point
    basis of the *scalar* element (the vector DOFs ``dim * k + a`` follow
    scikit-fem's ``ElementVector``).

    Parameters
    ----------
    basis
        A :class:`~skfem_mpm.MaterialPointBasis` with a scalar element.
    pattern
        The grid's vector :class:`~skfem_mpm.methods.assembly.ElementPattern` to
        share between steps (built on first use when not given).

    Attributes
    ----------
    shape_values, shape_gradients
        Scalar shape functions (nloc, nelems, slots) and their gradients
        (dim, nloc, nelems, slots) at the points.
    scalar_dofs, element_dofs
        Scalar (nloc, nelems) and vector (dim * nloc, nelems) element DOFs.
    n_points
        The points of the basis (those of its subset).

    """

    #: the grid's connectivity (rigid-body check) follows from the active
    #: elements alone
    connectivity_from_elements = True

    def __init__(self, basis: MaterialPointBasis,
                 pattern: Optional[ElementPattern] = None):
        self.basis = basis
        self.dim = dim = basis.mesh.dim()
        self.N = dim * basis.N
        self.nelems = basis.nelems
        self.elements = basis.tind
        self.n_points = len(basis.subset)
        self._pattern = pattern
        self.shape_values, gradients = basis.scalar_fields()
        self.shape_gradients = gradients.transpose(1, 0, 2, 3)
        self.scalar_dofs = basis.element_dofs                    # scalar (nloc, e)
        self.element_dofs = (dim * self.scalar_dofs[:, None]
                             + np.arange(dim)[:, None]).reshape(
                                 -1, basis.nelems)
        self.active_dofs = distinct(self.element_dofs, self.N)
        # stiffness takes the tangent as a function of point indices too,
        # formed block by block of elements, in 3D (648 bytes a point less
        # at the same speed; in 2D its inputs cost more to gather than it)
        self.tangent_blocks = dim == 3
        self._layout = None

    def _at_points(self, u: ndarray, shape_fields: ndarray) -> ndarray:
        U = u.reshape(-1, self.dim)[self.scalar_dofs]          # (nloc, e, dim)
        return self.basis.point_values(np.einsum(
            "...iem,iea->a...em", shape_fields, U))

    def values(self, u: ndarray) -> ndarray:
        values = self.basis.nodal_values(self.shape_values, self.scalar_dofs,
                                         u, self.dim)
        return self._at_points(u, self.shape_values) if values is None \
            else values

    def gradients(self, u: ndarray) -> ndarray:
        return self._at_points(u, self.shape_gradients)

    def pattern(self) -> ElementPattern:
        if self._pattern is None:
            grid = (self.dim * self.basis.dofs.element_dofs[:, None]
                    + np.arange(self.dim)[:, None]).reshape(
                        -1, self.basis.mesh.nelements)
            self._pattern = ElementPattern(grid, self.N)
        return self._pattern

    def kernel_layout(self) -> KernelLayout:
        """What the compiled passes (:mod:`skfem_mpm.kernels.passes`)
        read, formed once per operator
        (:class:`~skfem_mpm.methods.assembly.KernelLayout`): a group an
        active element, its points those of its slots, their shape
        gradients points first, the places of the grid's pattern
        (:meth:`~skfem_mpm.methods.assembly.ElementPattern.structure`)."""
        if self._layout is None:
            first, length, expand = self.pattern().structure()[:3]
            runs, in_slots, flat = self.basis.groups(keep=False)
            nel, nloc = self.nelems, self.scalar_dofs.shape[0]
            flat *= nloc            # the layout's own (the basis forgot it)
            first_points = np.ascontiguousarray(
                self.shape_gradients.transpose(2, 3, 1, 0))
            # one copy of the gradients: the operator's and the basis's
            # become views of the points-first one (196 bytes a point in 3D)
            self.shape_gradients = first_points.transpose(3, 2, 0, 1)
            self.basis.share_gradients(first_points.transpose(2, 3, 0, 1))
            G = first_points.reshape(-1, self.dim)
            groups = (G, np.ascontiguousarray(self.scalar_dofs.T,
                                              dtype=np.int64).ravel(),
                      np.arange(nel, dtype=np.int64) * nloc,
                      np.full(nel, nloc, dtype=np.int64),
                      runs, in_slots, flat)
            self._layout = KernelLayout(
                groups,
                (PER_ENTRY if expand is None else PER_NODE_PAIR,
                 np.asarray(self.elements, dtype=np.int64), first,
                 np.ascontiguousarray(length), NO_INDEX, NO_INDEX),
                self.pattern(), phased_chunks(*groups[1:5]))
        return self._layout

    def _scatter(self, local: ndarray) -> ndarray:
        return np.bincount(self.element_dofs.ravel(), weights=local.ravel(),
                           minlength=self.N)

    def force(self, P: ndarray, w: ndarray) -> ndarray:
        return self._scatter(local_force(
            self.shape_gradients, self.basis.quadrature_field(P * w)))

    def point_force(self, f: ndarray) -> ndarray:
        loads = self.basis.nodal_loads(self.shape_values, self.scalar_dofs,
                                       f, self.N)
        return self._scatter(local_load(
            self.shape_values, self.basis.quadrature_field(f))) \
            if loads is None else loads

    def stiffness(self, A: ndarray, w: ndarray):
        return self.pattern().matrix(
            (self.elements[block], local) for block, local in local_stiffness(
                self.shape_gradients, A, w, self.basis.point_index))

    def adjacency(self):
        return element_adjacency(self.element_dofs, self.dim,
                                 self.N // self.dim)


class SparseOperator:
    """Per-point sparse operators ``S`` (values) and ``G[d]`` (gradients),
    each (n_points, n_scalar_dofs), of a scalar element; vector DOFs are
    interleaved as in scikit-fem's ``ElementVector`` (``dim * k + a``).

    Parameters
    ----------
    S, G
        csr matrices of one sparsity pattern: ``S[p, k]`` weight of scalar
        DOF k at point p and ``G[d][p, k]`` its derivative along axis d.
    elements
        The active elements (holding part of a point's domain).

    Attributes
    ----------
    n_points
        The points, rows of ``S``.

    """

    #: the grid's connectivity follows the points' supports, not only
    #: the active elements
    connectivity_from_elements = False

    def __init__(self, S: csr_matrix, G, elements: ndarray):
        self.S, self.G = S, list(G)
        if not all(np.array_equal(g.indptr, S.indptr)
                   and np.array_equal(g.indices, S.indices) for g in self.G):
            raise InvalidInputError("S and G must share one sparsity "
                                    "pattern")
        self.dim = len(self.G)
        self.N = self.dim * S.shape[1]
        self.n_points = S.shape[0]
        self.elements = elements
        self.nelems = len(elements)
        support = distinct(S.indices, S.shape[1])
        self.active_dofs = (self.dim * support[:, None]
                            + np.arange(self.dim)).ravel()
        self._gradient_rows = None
        self._layout = None

    def adjacency(self):
        """The nodes of each point's support joined in a chain."""
        S = self.S
        same = np.repeat(np.arange(S.shape[0]), np.diff(S.indptr))
        link = np.flatnonzero(same[1:] == same[:-1])
        return edge_graph(S.indices[link], S.indices[link + 1],
                           S.shape[1])

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

    def _stacked(self, data: ndarray, component: int) -> csr_matrix:
        """Rows ``(b, p)`` for b < dim, row (b, p) the pattern of point p,
        columns the vector DOFs of ``component``: (dim * n, N)."""
        S, dim = self.S, self.dim
        indptr = np.concatenate([S.indptr[:-1] + b * S.nnz
                                 for b in range(dim)] + [[dim * S.nnz]])
        return csr_matrix((data, np.tile(S.indices * dim + component, dim),
                           indptr), shape=(dim * S.shape[0], self.N))

    def kernel_layout(self) -> KernelLayout:
        """What the compiled passes (:mod:`skfem_mpm.kernels.passes`)
        read, formed once per operator
        (:class:`~skfem_mpm.methods.assembly.KernelLayout`): the gradients
        points first with each row's nodes ascending, a group the points
        of one support (the points of a cell whose domains lie inside it),
        the stiffness's places by bisection of the node graph of the
        supports, on which its
        :class:`~skfem_mpm.methods.assembly.GraphPattern` lies."""
        if self._layout is None:
            S, n = self.S, self.S.shape[0]
            counts = np.diff(S.indptr)
            row = np.repeat(np.arange(n), counts)
            order = np.lexsort((S.indices, row))
            nodes = S.indices[order].astype(np.int64)
            G = np.ascontiguousarray(np.stack([g.data[order]
                                               for g in self.G], axis=1))
            first = S.indptr[:-1].astype(np.int64)
            # points of one support side by side (sorted by their first
            # and last node and count), a group each
            padded = np.full((n, max(counts.max(initial=0), 1)), -1)
            padded[row, np.arange(len(row)) - first[row]] = nodes
            last = padded[np.arange(n), np.maximum(counts - 1, 0)]
            points = np.lexsort((counts, last, padded[:, 0]))
            padded = padded[points]
            runs = np.flatnonzero(np.r_[n > 0, np.any(
                padded[1:] != padded[:-1], axis=1)])
            del padded
            qstart = first[points]
            incidence = csr_matrix((np.ones(len(nodes)), nodes, S.indptr),
                                   shape=S.shape)
            graph = (incidence.T.tocsr() @ incidence).tocsr()
            graph.sort_indices()
            groups = (G, nodes, qstart[runs], counts[points[runs]].astype(
                np.int64), np.append(runs, n).astype(np.int64),
                points.astype(np.int64), qstart)
            self._layout = KernelLayout(
                groups,
                (BISECTION, NO_INDEX, NO_PLACES, NO_PLACES,
                 graph.indptr.astype(np.int64),
                 graph.indices.astype(np.int64)),
                GraphPattern(graph, self.dim), phased_chunks(*groups[1:5]))
        return self._layout

    def stiffness(self, A: ndarray, w: ndarray):
        """``K_(ia)(jc) = sum_(b,d) G_b^T diag(w A_abcd) G_d``: per
        component pair one sparse product of the stacked gradients with
        ``H_(bp)j = sum_d w_p A_abcdp G_d[p, j]``, formed on the shared
        pattern's data."""
        dim, S = self.dim, self.S
        if self._gradient_rows is None:       # G_b^T, one per component a
            g = np.concatenate([G.data for G in self.G])
            self._gradient_rows = [self._stacked(g, a).T.tocsr()
                                   for a in range(dim)]
        counts = np.diff(S.indptr)
        K = None
        for a in range(dim):
            for c in range(dim):
                H = np.concatenate([
                    sum(np.repeat(w * A[a, b, c, d], counts) * self.G[d].data
                        for d in range(dim)) for b in range(dim)])
                M = self._gradient_rows[a] @ self._stacked(H, c)
                K = M if K is None else K + M
        return K.tocsr()
