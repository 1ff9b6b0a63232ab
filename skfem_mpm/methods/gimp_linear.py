"""GIMP weights in closed form for linear tensor-product elements.

On an axis-aligned grid the shape functions of ``ElementLineP1``,
``ElementQuad1`` and ``ElementHex1`` are products of 1D hat functions, and
a point's domain is a box, so its GIMP weight and averaged gradient are
products of 1D integrals over the domain ``[lo, hi]`` of every axis:

- ``S_i = (Phi_i(hi) - Phi_i(lo)) / (hi - lo)`` with ``Phi_i`` the
  antiderivative of the hat ``N_i``,
- ``dS_i/dx = (N_i(hi) - N_i(lo)) / (hi - lo)`` (the average of the
  derivative),

with no sub-points, no point location and no element evaluation; the
result equals the Gauss sub-point construction of :mod:`skfem_mpm.methods.gimp`
to round-off (tested), including its conventions: domains clipped to the
grid, and a domain edge within ``1e-12`` cell sizes of a grid line put on
that line (no sliver coupling).

"""
import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix
from skfem.assembly import Dofs
from skfem.element import (Element, ElementHex1, ElementLineP1,
                           ElementQuad1)
from skfem.mesh import Mesh

from ..errors import UnsupportedElementError
from ..quadrature.locate import RESOLUTION, tensor_grid
from .operators import SparseOperator

__all__ = ["LinearGimp", "LINEAR_ELEMENTS"]

LINEAR_ELEMENTS = (ElementLineP1, ElementQuad1, ElementHex1)
SLIVER = 1e-12          # relative to the cell size; skfem_mpm.methods.gimp's too


def sliver(line: ndarray, h: ndarray) -> ndarray:
    """The distance from a grid ``line`` within which a domain's end is
    on it, for cells of size ``h``: :data:`SLIVER` of the cell and the
    round-off of the line's coordinate (a domain's end on a grid line at
    x = 5e5 lies 1e-10 off it, a sliver of a billionth of a cell that
    GIMP's pile there took for material)."""
    return SLIVER * h + RESOLUTION * np.abs(line)


def _hat_terms(a: ndarray, node: ndarray, x: ndarray):
    """Hat function ``N`` and its antiderivative ``Phi`` (up to a constant
    per node) of nodes ``node`` of the axis ``a`` (padded with one ghost
    node at each end) at x."""
    left, mid, right = a[node], a[node + 1], a[node + 2]
    hl, hr = mid - left, right - mid
    tl = np.clip(x, left, mid) - left
    tr = np.clip(x, mid, right) - mid
    return tl / hl - tr / hr, tl * tl / (2 * hl) + tr - tr * tr / (2 * hr)


def snap_to_lines(a: ndarray, lo: ndarray, hi: ndarray):
    """Domain ends within :func:`sliver` of a grid line, below (lo) or
    above (hi), put on it, and the first and last cell they span."""
    n = len(a) - 1
    h = np.diff(a)
    first = np.clip(np.searchsorted(a, lo, side="right") - 1, 0, n - 1)
    lo = np.where(a[first + 1] - lo <= sliver(a[first + 1], h[first]),
                  a[first + 1], lo)
    last = np.clip(np.searchsorted(a, hi, side="left") - 1, 0, n - 1)
    hi = np.where(hi - a[last] <= sliver(a[last], h[last]), a[last], hi)
    first = np.clip(np.searchsorted(a, lo, side="right") - 1, 0, n - 1)
    last = np.clip(np.searchsorted(a, hi, side="left") - 1, 0, n - 1)
    return lo, hi, first, np.maximum(last, first)


class LinearGimp:
    """GIMP operators of linear tensor-product elements on one grid.

    Parameters
    ----------
    mesh
        An axis-aligned tensor-product grid (see
        :func:`~skfem_mpm.quadrature.locate.tensor_grid`).
    elem
        ``ElementLineP1``, ``ElementQuad1`` or ``ElementHex1`` (scalar).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshLine, ElementLineP1
    >>> gimp = LinearGimp(MeshLine(np.linspace(0., 2., 3)), ElementLineP1())
    >>> op = gimp(np.array([[0.75]]), np.array([[0.5]]))
    >>> op.S.toarray().round(6).tolist()
    [[0.28125, 0.6875, 0.03125]]

    """

    def __init__(self, mesh: Mesh, elem: Element):
        grid = tensor_grid(mesh)
        if grid is None or not isinstance(elem, LINEAR_ELEMENTS):
            raise UnsupportedElementError(
                "closed-form GIMP weights need an axis-aligned tensor-product "
                "grid and ElementLineP1/Quad1/Hex1, got {} and {}".format(
                    type(mesh).__name__, type(elem).__name__))
        self.axes, self.shape, self.cell_to_elem = grid
        self.dim = len(self.axes)
        nodes = tuple(len(a) for a in self.axes)
        index = np.array([np.searchsorted(a, mesh.p[d])
                          for d, a in enumerate(self.axes)])
        self.node_dof = np.empty(np.prod(nodes), dtype=np.int64)
        self.node_dof[np.ravel_multi_index(tuple(index), nodes)] = \
            Dofs(mesh, elem).nodal_dofs[0]
        self.nodes = nodes
        self.N = len(self.node_dof)
        self.padded = [np.concatenate(([2 * a[0] - a[1]], a,
                                       [2 * a[-1] - a[-2]]))
                       for a in self.axes]

    def __call__(self, x: ndarray, domain: ndarray) -> SparseOperator:
        """The operator of points x (dim, n) with half-lengths domain;
        along an axis where a half-length is zero the hat functions at
        the point, with no gradient (a face of a domain:
        :meth:`~skfem_mpm.solve.contact.StepContact.face_rows`)."""
        n = x.shape[1]
        nodes, weights, grads, cells = [], [], [], []
        for d, a in enumerate(self.axes):
            lo, hi, first, last = snap_to_lines(
                a, np.clip(x[d] - domain[d], a[0], a[-1]),
                np.clip(x[d] + domain[d], a[0], a[-1]))
            # a zero half-length: the hat at x (within a sliver below a
            # grid line: on it), no gradient along the axis
            flat = domain[d] == 0
            if flat.any():
                at = snap_to_lines(a, np.clip(x[d], a[0], a[-1]),
                                   np.clip(x[d], a[0], a[-1]))[0]
                lo, hi = np.where(flat, at, lo), np.where(flat, at, hi)
                cell = np.clip(np.searchsorted(a, at, side="right") - 1, 0,
                               len(a) - 2)
                first = np.where(flat, cell, first)
                last = np.where(flat, cell, last)
            m = min(int((last - first).max()) + 2, len(a))
            node = (np.minimum(first, len(a) - m)[None]
                    + np.arange(m)[:, None])                      # (m, n)
            N_hi, Phi_hi = _hat_terms(self.padded[d], node, hi)
            N_lo, Phi_lo = _hat_terms(self.padded[d], node, lo)
            length = np.where(flat, 1., hi - lo)
            nodes.append(node)
            weights.append(np.where(flat, N_hi, (Phi_hi - Phi_lo) / length))
            grads.append(np.where(flat, 0., (N_hi - N_lo) / length))
            cells.append((first, last))
        # tensor products over the axes: (m_1 * ... * m_dim, n)
        node = np.zeros((1, n), dtype=np.int64)
        S = np.ones((1, n))
        G = [np.ones((1, n)) for _ in range(self.dim)]
        for d in range(self.dim):
            node = (node[:, None] * self.nodes[d] + nodes[d][None]).reshape(
                -1, n)
            S = (S[:, None] * weights[d][None]).reshape(-1, n)
            for e in range(self.dim):
                factor = grads[d] if e == d else weights[d]
                G[e] = (G[e][:, None] * factor[None]).reshape(-1, n)
        keep = (S != 0) | np.any([g != 0 for g in G], axis=0)
        counts = keep.sum(axis=0)
        indptr = np.concatenate(([0], np.cumsum(counts)))
        cols = self.node_dof[node.T[keep.T]]

        def matrix(values):
            return csr_matrix((values.T[keep.T], cols, indptr),
                              shape=(n, self.N))

        return SparseOperator(matrix(S), [matrix(g) for g in G],
                              self._elements(cells))

    def _elements(self, cells) -> ndarray:
        """Elements holding part of some domain."""
        span = [int((last - first).max()) + 1 for first, last in cells]
        cell = np.zeros((1,) + cells[0][0].shape, dtype=np.int64)
        inside = np.ones_like(cell, dtype=bool)
        for d, (first, last) in enumerate(cells):
            k = np.arange(span[d])[:, None]
            c = np.minimum(first[None] + k, self.shape[d] - 1)
            inside = (inside[:, None] & (first[None] + k <= last)[None]) \
                .reshape(-1, c.shape[1])
            cell = (cell[:, None] * self.shape[d] + c[None]).reshape(
                -1, c.shape[1])
        return np.unique(self.cell_to_elem[cell[inside]])
