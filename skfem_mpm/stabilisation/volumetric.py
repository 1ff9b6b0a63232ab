"""Mean dilatation on the material points: the B-bar method (Hughes 1980)
against volumetric locking, in small strain and finite deformation, for
every method (standard MPM, finite elements, uGIMP and cpGIMP).

The volumetric part of every point's displacement gradient is replaced by
the volume average over the points whose centre lies in its cell (the
cell's patch; the points carry the cell as ``point_elements``),

    grad_bar(u) = grad(u) + (theta_c(u) - div(u)) I / 3,
    theta_c(u) = sum_(p in c) V_p div(u)_p / sum_(p in c) V_p,

one volumetric constraint per cell holding points instead of one per
point, which removes the locking of Q1 elements as nu -> 0.5.  The
modified gradient is linear in the displacement, so wrapping the step's
point operator is all it takes: stresses follow from ``grad_bar``, and
internal force and tangent use the same operator, so Newton keeps its
quadratic rate.  Homogeneous deformations are unchanged
(``theta_c = div(u)``): the patch test still passes.

Two forms of the same average, chosen by the step's operator:

- standard MPM and finite elements
  (:class:`~skfem_mpm.methods.operators.PointOperator`): a point's
  gradients live in its element, so ``theta_c`` is a vector over the
  element's DOFs (:class:`ElementAverage`, element matrices on the grid's
  pattern);
- GIMP (:class:`~skfem_mpm.methods.operators.SparseOperator`): a point's
  domain overlaps neighbouring cells and its gradients reach their nodes,
  so ``theta_c`` couples the union of the supports of the cell's points, a
  wider stencil (:class:`CellPatchAverage`, sparse matrices), as in Coombs,
  Charlton, Cortis and Augarde, *Comput. Methods Appl. Mech. Engrg.* 333,
  2018 (docs/references.md).  Where every domain lies inside its cell
  (points seeded on a grid, first step) both forms give the same operator.

The tensors are 3x3 whatever the grid's dimension: in plane strain (and
uniaxial strain in 1D) ``grad(u)`` is the 3x3 gradient whose out-of-plane
components are zero, and its volumetric part is replaced as in 3D, so
``grad_bar`` has the out-of-plane diagonal ``(theta_c - div) / 3``.  Plane
strain is then 3D with ``u_z = 0`` (equal to round-off, tested); the
earlier correction over the in-plane components alone (``I / 2`` on the
2x2 block) differed from it by 0.57% of a cantilever's tip deflection at
nu = 0.45.  The operator therefore exchanges (3, 3, n) gradients and
stresses and (3, 3, 3, 3, n) tangents (``components = 3``), whose
out-of-plane parts the kinematics supply.

In finite deformation with points that move, ``antilocking="fbar"``
takes the multiplicative form of this average on each step's increment,
F-bar (:class:`~skfem_mpm.stabilisation.fbar.IncrementFbar`, a
subclass), instead of the additive form below.

In finite deformation the average acts on each load step's increment,
``dF = I + grad_bar(du)`` in the step's configuration (an incremental
mean dilatation, as material points change cells between steps), not on
the total deformation gradient as the F-bar method of de Souza Neto et al.
(1996) for finite elements: the answer then depends on the load path at
the order of the increment.  Measured on a block under gravity with
nu = 0.45 and 50% strain (finite elements, Hencky): 1 and 8 load steps
differ by 0.4% of the displacement (4e-14 without the average).

Finite elements in finite deformation keep their gradients in the initial
configuration (total Lagrangian): there the kinematics put the operator
in the step's configuration ``F_n``
(:meth:`MeanDilatation.in_configuration`), the average is taken of the
increment's spatial divergence ``div_x = tr(grad_X(du) F_n^-1)`` (linear
in ``du``: ``F_n`` is fixed in the step) with the points' current
volumes, and the shift is put back in the material frame,

    grad_X_bar(du) = grad_X(du) + (theta_c - div_x) F_n / 3,

so that ``grad_X_bar F_n^-1`` is the spatial increment with its
volumetric part replaced, as the material point methods' (their
operators live in the step's configuration).  The average of the
material divergence ``tr(grad_X(du))`` is not the increment's volume
change once the body has rotated: a plane-strain cantilever at nu =
0.499, L/D = 8, its tip rotated about 40 degrees, came out 28% too stiff
against the elastica (0.720), now 1.0016 (cpGIMP 1.0033).

The compiled passes (:mod:`skfem_mpm.kernels.dilatation`) read each
average's :class:`CellLayout`: the same averages, their force and
couplings summed cell by cell.

"""
import logging
from functools import cached_property
from typing import NamedTuple, Optional

import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix, diags

from ..errors import InvalidInputError
from ..kernels import BISECTION
from ..methods.assembly import GraphPattern
from ..methods.operators import (NO_INDEX, NO_PLACES, PointOperator,
                                 SparseOperator)
from ..spelling import setting

__all__ = ["MeanDilatation", "ElementAverage", "CellPatchAverage",
           "CellLayout", "warn_sparse_spline_points", "points_per_cell_axis",
           "per_axis_words", "SPLINE_POINTS_PER_AXIS"]

logger = logging.getLogger(__name__)


class CellLayout(NamedTuple):
    """What the compiled passes of mean dilatation
    (:mod:`skfem_mpm.kernels.dilatation`) read of a cell average, formed
    once per step: ``cells``, ``(cell, patch, patch_start, patch_nodes,
    b)``, the cell of every point, for every entry of the point
    operator's layout (its shape gradients points first) the patch entry
    of its node in its point's cell, the patches' nodes (cell c's from
    ``patch_start[c]``, ascending) and their rows of the average (patch
    entries, dim); the stiffness's ``places`` and ``pattern`` (as
    :class:`~skfem_mpm.methods.assembly.KernelLayout`'s), which hold
    every cell's patch."""
    cells: tuple
    places: tuple
    pattern: object


def _traces(A: ndarray, dim: int):
    """``tr1_cd = A_aacd``, ``tr2_ab = A_abcc`` and ``tr12 = A_aacc``."""
    tr1 = np.einsum("aacdp->cdp", A)
    tr2 = np.einsum("abccp->abp", A)
    return tr1, tr2, np.einsum("aap->p", tr1)


class ElementAverage:
    """``theta_c`` of points whose gradients live in their element (a
    :class:`~skfem_mpm.methods.operators.PointOperator`: standard MPM,
    finite elements): ``theta_c(u) = sum_ia b_c[i, a] u_ia`` over the
    element's DOFs.

    Parameters
    ----------
    op
        The step's point operator.
    volume
        Point volumes weighting the averages, (n,).
    inverse
        Where ``op``'s gradients are material ones (finite elements in
        finite deformation): the in-plane ``F_n^-1`` (dim, dim, n) of the
        step's start, which makes ``b_c`` the average of the spatial
        gradients ``grad_X(N) F_n^-1``; ``None``: of ``op``'s.

    """

    def __init__(self, op: PointOperator, volume: ndarray,
                 inverse: Optional[ndarray] = None):
        self.op = op
        field = op.basis.quadrature_field
        W = field(volume)                                    # (e, slots)
        G = op.shape_gradients
        if inverse is not None:     # spatial: dN/dx_a = dN/dX_b F^-1_ba
            G = np.einsum("biem,baem->aiem", G, field(inverse))
        # averaged gradient b_e: theta_e(u) = sum_ia b_e[i, a] u_ia
        self.b = np.einsum("aiem,em->eia", G, W) \
            / W.sum(axis=1)[:, None, None]
        self._layout = None

    def kernel_layout(self) -> CellLayout:
        """The :class:`CellLayout` of the compiled passes: a cell each
        group of the operator's layout (an element's points), its patch
        the element's nodes, the places and pattern the operator's."""
        if self._layout is not None:
            return self._layout
        layout = self.op.kernel_layout()
        G, nodes, _, _, runs, order = layout.groups[:6]
        nel, nloc, dim = self.b.shape
        cell = np.empty(self.op.n_points, dtype=np.int64)
        cell[order] = np.repeat(np.arange(nel), np.diff(runs))
        # the layout's gradients: nloc rows a slot, the slots of an element
        entry = np.arange(len(G))
        patch = entry // (len(G) // max(nel, 1)) * nloc + entry % nloc
        self._layout = CellLayout(
            (cell, patch, np.arange(nel + 1, dtype=np.int64) * nloc, nodes,
             np.ascontiguousarray(self.b.reshape(-1, dim))),
            layout.places, layout.pattern)
        return self._layout

    def at_points(self, u: ndarray) -> ndarray:
        """``theta_c(u)`` of every point's cell, (n,)."""
        U = u.reshape(-1, self.op.dim)[self.op.scalar_dofs]  # (nloc, e, dim)
        theta = np.einsum("eia,iea->e", self.b, U)
        basis = self.op.basis
        return basis.point_values(np.broadcast_to(
            theta[:, None], basis.point_index.shape))

    def _scatter(self, local: ndarray) -> ndarray:
        """Element vectors (e, nloc, dim) onto the grid."""
        return np.bincount(self.op.element_dofs.ravel(),
                           weights=local.reshape(len(local), -1).T.ravel(),
                           minlength=self.op.N)

    def force(self, s: ndarray) -> ndarray:
        """``f = sum_p s_p d theta_c(p) / du`` of point values ``s`` (n,),
        (N,)."""
        s = self.op.basis.quadrature_field(s).sum(axis=1)     # (e,)
        return self._scatter(self.b * s[:, None, None])

    def couplings(self, row: ndarray, column: ndarray, bulk: ndarray):
        """The matrix of ``sum_p theta_c(v) row_p : grad(u) + column_p :
        grad(v) theta_c(u) + bulk_p / 9 theta_c(v) theta_c(u)`` (v the
        row, u the column), of in-plane ``row``, ``column`` (dim, dim, n)
        and ``bulk`` (n,)."""
        op = self.op
        basis, G = op.basis, op.shape_gradients       # (dim, nloc, e, m)
        field = basis.quadrature_field
        h_row = np.einsum("cdem,djem->ejc", field(row), G)
        h_col = np.einsum("abem,biem->eia", field(column), G)
        vol = field(bulk).sum(axis=1) / 9
        e = len(self.b)
        b = self.b.reshape(e, -1)
        local = b[:, :, None] * h_row.reshape(e, -1)[:, None, :] \
            + h_col.reshape(e, -1)[:, :, None] * b[:, None, :] \
            + vol[:, None, None] * b[:, :, None] * b[:, None, :]
        return op.pattern().matrix([(op.elements, local)])


class CellPatchAverage:
    """``theta_c`` of GIMP points (a
    :class:`~skfem_mpm.methods.operators.SparseOperator`), whose gradients
    reach the nodes of every cell their domain overlaps: ``theta_c(u) =
    (B u)_c`` with ``B`` (cells, N) sparse over the union of the supports
    of the points whose centre lies in cell c (Coombs et al. 2018).

    Parameters
    ----------
    op
        The step's point operator, carrying ``point_elements``: the cell
        of each point's centre.
    volume
        Point volumes weighting the averages, (n,).

    """

    def __init__(self, op: SparseOperator, volume: ndarray):
        if getattr(op, "point_elements", None) is None:
            raise InvalidInputError(
                "mean dilatation with GIMP averages over the points whose "
                "centre lies in each cell: the operator needs the cell of "
                "every point (point_elements)")
        self.op, self.dim = op, op.dim
        S, n = op.S, op.S.shape[0]
        _, self.cell = np.unique(op.point_elements, return_inverse=True)
        self.ncells = int(self.cell.max()) + 1 if n else 0
        # the point of every stored entry of S
        self._point = np.repeat(np.arange(n), np.diff(S.indptr))
        # each point's weight in its cell's average
        self._weight = volume / np.bincount(self.cell, volume,
                                            self.ncells)[self.cell]
        self._layout = None

    # the numpy path's matrices, formed on its first call (the compiled
    # passes form the same cell by cell, from the kernel layout)
    @cached_property
    def B(self) -> csr_matrix:
        """The volume averages of the divergence rows over each patch,
        (cells, N)."""
        n = self.op.S.shape[0]
        eye = np.broadcast_to(np.eye(self.dim)[:, :, None],
                              (self.dim, self.dim, n))
        average = csr_matrix((self._weight, (self.cell, np.arange(n))),
                             shape=(self.ncells, n))
        return (average @ self._contracted(eye)).tocsr()

    @cached_property
    def _patch(self) -> csr_matrix:
        """The patch sum (cells, n)."""
        n = self.op.S.shape[0]
        return csr_matrix((np.ones(n), (self.cell, np.arange(n))),
                          shape=(self.ncells, n))

    @cached_property
    def _entries(self):
        """Every stored entry (p, k) of S as dim entries (p, dim k + c):
        their columns and row pointers, and the gradients (dim, nnz)."""
        S, dim = self.op.S, self.dim
        return ((dim * S.indices[:, None] + np.arange(dim)).ravel(),
                dim * S.indptr, np.array([g.data for g in self.op.G]))

    def kernel_layout(self) -> CellLayout:
        """The :class:`CellLayout` of the compiled passes: a cell's patch
        the nodes of its points' supports, its rows of the average summed
        from theirs, the stiffness's places by bisection of the patches'
        node graph (which holds the supports')."""
        if self._layout is not None:
            return self._layout
        S, dim = self.op.S, self.dim
        # the layout's entries: each point's row of S, nodes ascending
        G, nodes = self.op.kernel_layout().groups[:2]
        keys, patch = np.unique(self.cell[self._point] * S.shape[1] + nodes,
                                return_inverse=True)
        patch_cell, patch_nodes = np.divmod(keys, S.shape[1])
        patch_start = np.searchsorted(patch_cell, np.arange(self.ncells + 1))
        weight = self._weight[self._point]
        b = np.stack([np.bincount(patch, weight * G[:, a], len(keys))
                      for a in range(dim)], axis=1)
        incidence = csr_matrix((np.ones(len(keys)), patch_nodes,
                                patch_start), shape=(self.ncells, S.shape[1]))
        graph = (incidence.T @ incidence).tocsr()
        graph.sort_indices()
        self._layout = CellLayout(
            (self.cell.astype(np.int64), patch.astype(np.int64),
             patch_start.astype(np.int64), patch_nodes.astype(np.int64), b),
            (BISECTION, NO_INDEX, NO_PLACES, NO_PLACES,
             graph.indptr.astype(np.int64), graph.indices.astype(np.int64)),
            GraphPattern(graph, dim))
        return self._layout

    def _contracted(self, X: ndarray) -> csr_matrix:
        """``H[p, dim j + c] = sum_d X_cdp G_d[p, j]`` of (dim, dim, n)
        ``X``: the rows that give ``sum_p X_p : grad(u)_p`` (``X = I``: the
        divergence), (n, N); formed component by component (no (dim, dim)
        array per stored entry)."""
        indices, indptr, G = self._entries
        data = np.zeros((G.shape[1], self.dim))
        for c in range(self.dim):
            for d in range(self.dim):
                data[:, c] += X[c, d][self._point] * G[d]
        return csr_matrix((data.ravel(), indices, indptr),
                          shape=(self.op.S.shape[0], self.op.N))

    def at_points(self, u: ndarray) -> ndarray:
        """``theta_c(u)`` of every point's cell, (n,)."""
        return (self.B @ u)[self.cell]

    def force(self, s: ndarray) -> ndarray:
        """``f = sum_p s_p d theta_c(p) / du`` of point values ``s`` (n,),
        (N,)."""
        return self.B.T @ np.bincount(self.cell, s, self.ncells)

    def couplings(self, row: ndarray, column: ndarray, bulk: ndarray):
        """As :meth:`ElementAverage.couplings`, summed patch by patch:
        ``B^T (P H_row) + (P H_col)^T B + B^T diag(P bulk / 9) B`` with
        ``P`` the patch sum."""
        B, P = self.B, self._patch
        BT = B.T.tocsr()
        vol = np.bincount(self.cell, bulk, self.ncells) / 9
        return BT @ (P @ self._contracted(row)) \
            + (P @ self._contracted(column)).T @ B \
            + BT @ diags(vol) @ B


#: the cell average of each kind of point operator
AVERAGES = ((PointOperator, ElementAverage),
            (SparseOperator, CellPatchAverage))


class MeanDilatation:
    """The B-bar twin of one step's point operator: same interface,
    gradients ``grad_bar``, but with 3x3 tensors in every dimension:
    ``gradients(u)`` is (3, 3, n), ``force`` takes a (3, 3, n) stress and
    ``stiffness`` a (3, 3, 3, 3, n) tangent (``components``).

    Parameters
    ----------
    op
        The step's point operator: a
        :class:`~skfem_mpm.methods.operators.PointOperator` (standard MPM,
        FE: :class:`ElementAverage`) or a
        :class:`~skfem_mpm.methods.operators.SparseOperator` (GIMP:
        :class:`CellPatchAverage`) carrying ``point_elements``.
    volume
        Point volumes weighting the cell averages, (n,).

    Examples
    --------
    GIMP points whose domains cross cell boundaries, a linear field: the
    averaged gradient is the gradient (patch test).

    >>> import numpy as np
    >>> from skfem import MeshQuad, ElementQuad1
    >>> from skfem_mpm.methods.gimp_linear import LinearGimp
    >>> axis = np.linspace(0, 2, 3)
    >>> mesh = MeshQuad.init_tensor(axis, axis)
    >>> x = np.array([[.4, .8, 1.3], [.9, .7, 1.2]])
    >>> op = LinearGimp(mesh, ElementQuad1())(x, np.full((2, 3), .25))
    >>> op.point_elements = mesh.element_finder()(*x)
    >>> bar = MeanDilatation(op, np.full(3, .25))
    >>> X, Y = mesh.p
    >>> u = np.vstack((1 + .2 * X, .3 * Y - .1 * X)).T.ravel()
    >>> bar.gradients(u)[:, :, 0].round(12) + 0.
    array([[ 0.2,  0. ,  0. ],
           [-0.1,  0.3,  0. ],
           [ 0. ,  0. ,  0. ]])

    """

    #: the components of the gradients, stresses and tangents exchanged
    #: with the kinematics: the volumetric part of the 3x3 tensor is the one
    #: replaced, in plane strain as in 3D
    components = 3

    def __init__(self, op, volume: ndarray):
        average = next((kind for base, kind in AVERAGES
                        if isinstance(op, base)), None)
        if average is None:
            raise InvalidInputError(
                "antilocking (mean dilatation) needs the point operator of "
                "a method ('mpm', 'fem', 'ugimp', 'cpgimp'), got {}".format(
                    type(op).__name__))
        self.op, self.dim = op, op.dim
        for name in ("N", "nelems", "elements", "active_dofs", "values",
                     "point_force", "adjacency", "point_elements",
                     "connectivity_from_elements", "basis"):
            if hasattr(op, name):
                setattr(self, name, getattr(op, name))
        self.volume = volume
        self.average = average(op, volume)
        #: the step's configuration ``(F_n, F_n^-T)``, (3, 3, n) each,
        #: where the gradients are material (:meth:`in_configuration`)
        self.frame = None

    def in_configuration(self, F: ndarray, F_inv: ndarray):
        """Average in the configuration ``F`` (3, 3, n) of the step's
        start, its inverse ``F_inv``: the operator's gradients are
        material ones ``grad_X`` (finite elements in finite deformation,
        total Lagrangian; the kinematics call it), the average that of
        the increment's spatial divergence ``tr(grad_X(du) F_n^-1)``
        weighted by the points' current volumes, and the shift put back
        in the material frame, ``grad_X + (theta_c - div_x) F_n / 3``,
        so that ``grad_bar F_n^-1 = grad_x + (theta_c - div_x) I / 3``
        (the volumetric part of the spatial increment replaced, as the
        material point methods' operators in the step's configuration
        do).  Once a step (the same ``F`` again: nothing)."""
        if self.frame is not None and self.frame[0] is F:
            return
        if not isinstance(self.average, ElementAverage):
            raise InvalidInputError(
                "mean dilatation in a material frame needs the element "
                "average of finite elements, not {}".format(
                    type(self.average).__name__))
        dim = self.dim
        self.average = ElementAverage(self.op, self.volume,
                                      F_inv[:dim, :dim])
        self.frame = (F, F_inv.transpose(1, 0, 2))

    def gradients(self, u: ndarray) -> ndarray:
        """``grad_bar(u)``, (3, 3, n): out of plane the volumetric shift
        alone (in a material frame that times ``F_n``)."""
        g = self.op.gradients(u)
        if self.dim < 3:
            g = np.concatenate((g, np.zeros((3 - self.dim,) + g.shape[1:])))
            g = np.concatenate((g, np.zeros((3, 3 - self.dim, g.shape[-1]))),
                               axis=1)
        if self.frame is not None:
            F, R = self.frame
            shift = (self.average.at_points(u)
                     - np.einsum("abp,abp->p", R, g)) / 3
            return g + F * shift
        shift = (self.average.at_points(u) - np.einsum("aap->p", g)) / 3
        return g + np.eye(3)[:, :, None] * shift

    def force(self, P: ndarray, w: ndarray) -> ndarray:
        """``sum_p w_p P_p : grad_bar(N)`` of a (3, 3, n) stress ``P``:
        its in-plane deviator (with respect to the 3x3 mean) against the
        gradients, its mean against the cell averages (in a material
        frame the mean ``P : F_n / 3``, taken off along ``F_n^-T``)."""
        dim = self.dim
        if self.frame is not None:
            F, R = self.frame
            mean = np.einsum("abp,abp->p", P, F) / 3
            return self.op.force((P - R * mean)[:dim, :dim], w) \
                + self.average.force(w * mean)
        mean = np.einsum("aap->p", P) / 3
        return self.op.force(P[:dim, :dim] - np.eye(dim)[:, :, None] * mean,
                             w) \
            + self.average.force(w * mean)

    def _framed_stiffness(self, A: ndarray, w: ndarray):
        """:meth:`stiffness` in a material frame: with ``Q = F_n``, ``R =
        F_n^-T`` and ``grad_bar(u) = D(g) + theta_c Q / 3``, ``D(g) = g -
        Q (R : g) / 3``, the parts ``D^T A D`` against the gradients,
        ``Q : A : D / 3`` and ``D^T : A : Q / 3`` against the average,
        ``Q : A : Q`` its bulk (``Q = R = I``: the traces)."""
        dim = self.dim
        Q, R = self.frame
        QA = np.einsum("abp,abcdp->cdp", Q, A)
        AQ = np.einsum("abcdp,cdp->abp", A, Q)
        QAQ = np.einsum("abp,abp->p", QA, Q)
        p = slice(0, dim)                                   # in-plane block
        Q, R, QA, AQ = Q[p, p], R[p, p], QA[p, p], AQ[p, p]
        deviatoric = A[p, p, p, p] \
            - (np.einsum("abp,cdp->abcdp", R, QA)
               + np.einsum("abp,cdp->abcdp", AQ, R)) / 3 \
            + np.einsum("abp,cdp->abcdp", R, R) * QAQ / 9
        row = (QA - R * QAQ / 3) / 3
        column = (AQ - R * QAQ / 3) / 3
        return self.op.stiffness(deviatoric, w) \
            + self.average.couplings(row * w, column * w, QAQ * w)

    def stiffness(self, A: ndarray, w: ndarray):
        """``sum_p w_p grad_bar(N) : A_p : grad_bar(N)`` of a (3, 3, 3, 3,
        n) tangent ``A``: traces over the three components, the in-plane
        block against the gradients."""
        if self.frame is not None:
            return self._framed_stiffness(A, w)
        dim = self.dim
        uniform = A.strides[-1] == 0
        An = A[..., :1] if uniform else A
        tr1, tr2, tr12 = _traces(An, 3)
        p = slice(0, dim)                                   # in-plane block
        An, tr1, tr2 = An[p, p, p, p], tr1[p, p], tr2[p, p]
        eye = np.eye(dim)
        dd = np.einsum("ab,cd->abcd", eye, eye)[..., None]
        deviatoric = An - (np.einsum("ab,cdp->abcdp", eye, tr1)
                           + np.einsum("abp,cd->abcdp", tr2, eye)) / 3 \
            + dd * tr12 / 9
        R = (tr1 - eye[:, :, None] * tr12 / 3) / 3          # row: theta_v
        L = (tr2 - eye[:, :, None] * tr12 / 3) / 3          # column: theta_u
        if uniform:
            n = A.shape[-1]
            deviatoric = np.broadcast_to(deviatoric, deviatoric.shape[:-1]
                                         + (n,))
            R, L, tr12 = (np.broadcast_to(a, a.shape[:-1] + (n,))
                          for a in (R, L, tr12))
        return self.op.stiffness(deviatoric, w) \
            + self.average.couplings(R * w, L * w, tr12 * w)


#: B-splines with mean dilatation need this many points per cell and axis
#: for a limit load (fewer: ``warn_sparse_spline_points``)
SPLINE_POINTS_PER_AXIS = 3


def points_per_cell_axis(mesh, points) -> float:
    """The points per cell and axis of a seeding, the fewest of any body,
    from the median cell's volume and each body's median point volume:
    ``(V_cell / V_point) ** (1 / dim)`` (2.0 for ``seed_points(mesh, 2)``;
    a small body seeded 2 a cell beside a large one seeded 3 is 2, not
    the median over all points' 3)."""
    corners = mesh.p[:, mesh.t]
    cell = np.median(np.prod(np.ptp(corners, axis=1), axis=0))
    largest = max(np.median(points.volume[points.body == b])
                  for b in np.unique(points.body))
    return float((cell / largest) ** (1. / mesh.dim()))


def per_axis_words(per_axis: float) -> str:
    """Points per cell and axis to a tenth, whole counts as integers (a
    trial was told of "2.0 points per cell").

    >>> per_axis_words(2.0000001), per_axis_words(2.52)
    ('2', '2.5')
    """
    return "{:g}".format(round(per_axis, 1))


def warn_sparse_spline_points(method: str, mesh, points, plastic: bool,
                              antilocking: bool, extended: bool = False):
    """Log a warning for a run with B-splines whose points are seeded fewer
    than :data:`SPLINE_POINTS_PER_AXIS` per cell and axis, where that is
    known to go wrong: plastic with mean dilatation (in the strip-footing
    study, ``docs/accuracy_vs_time.md``, pushed 0.005 B, 2 points per cell
    and axis gave limit loads 18-21% below Prandtl's with ``"bspline"``
    and 6-10% with ``"bspline-gimp"`` on every grid, unsafe, where 3
    points converge to it from above; a user trial's, pushed 0.08 B at
    B = 8 h, came out 14-21% above it, 3 points 16%, as other methods
    there 12%), and any run of the cubic splines not ``extended``
    (their Galerkin stiffness needs 4 Gauss points a cell and axis: with
    2, an elastic cantilever two cells deep, its faces inside cells, came
    out 4.1 (``"bspline3"``) and 2.8 (``"bspline3-gimp"``) times too
    flexible, without a word; with 3, within 0.6%)."""
    cubic = method.startswith("bspline3") and not extended
    if not (method.startswith("bspline") and (cubic or plastic
                                               and antilocking)):
        return
    per_axis = points_per_cell_axis(mesh, points)
    if per_axis < 1.5 and method.startswith("bspline3"):
        return      # zero-energy modes: single_point_splines says so
    if per_axis < SPLINE_POINTS_PER_AXIS - .5 and cubic:
        logger.warning(
            "method %r with %s points per cell and axis: the cubic "
            "splines' stiffness needs 4 Gauss points a cell and axis, and "
            "with 2 an elastic cantilever two cells deep came out 2.8-4.1 "
            "times too flexible (docs/bspline.md); seed at least %d points "
            "per cell and axis, or use %s or 'bspline'",
            method, per_axis_words(per_axis), SPLINE_POINTS_PER_AXIS,
            setting("extended_splines", True))
    elif per_axis < SPLINE_POINTS_PER_AXIS - .5:
        logger.warning(
            "method %r with mean dilatation and %s points per cell and "
            "axis: with 2, a strip footing's limit load came out 18-21%% "
            "('bspline') and 6-10%% ('bspline-gimp') below Prandtl's on "
            "every grid of a study pushing it 0.005 B "
            "(docs/accuracy_vs_time.md), and a user's pushed 0.08 B at "
            "B = 8 h 14-21%% above it; seed at least %d points per cell and "
            "axis", method, per_axis_words(per_axis),
            SPLINE_POINTS_PER_AXIS)

