"""The material-point basis: a scikit-fem ``CellBasis`` whose quadrature is
the material points.

Only elements that hold points are active (empty elements are ignored, seed
2.2.2).  Points are grouped per element; an element holding fewer points
than the fullest one is padded with zero-weight slots, so scikit-fem sees a
quadrature of shape (dim, n_active_elements, max_points_per_element) and
``asm``, forms, ``interpolate``, ``condense`` and ``solve`` work unchanged.

"""
import logging
from typing import Optional, Tuple

import numpy as np
from numpy import ndarray
from skfem.assembly import CellBasis, Dofs
from skfem.element import Element
from skfem.mesh import Mesh

from ..errors import InvalidInputError
from ..solve.linear import distinct
from .locate import locate_points
from .mapping import fresh_mapping
from .points import MaterialPoints

logger = logging.getLogger(__name__)

__all__ = ["MaterialPointBasis"]


class MaterialPointBasis(CellBasis):
    """A ``CellBasis`` integrating with material points as quadrature.

    Parameters
    ----------
    mesh
        The background grid (any scikit-fem mesh).
    elem
        The scikit-fem element, e.g. ``ElementVector(ElementQuad1())``.
    points
        :class:`~skfem_mpm.MaterialPoints`; their volumes become ``dx``.
    location
        Optional ``(tind, X)`` from a locator; computed with
        :func:`~skfem_mpm.locate_points` when not given.
    dofs
        Optional scikit-fem ``Dofs`` of ``(mesh, elem)`` to reuse between
        load steps.  When given, global DOF locations (``doflocs``) are
        computed only if asked for.

    Attributes
    ----------
    point_index
        (n_active_elements, max_points_per_element) index of the point in
        each quadrature slot, -1 in padding slots.

    Examples
    --------
    >>> from skfem import MeshQuad, ElementQuad1, asm, BilinearForm
    >>> from skfem_mpm import MaterialPointBasis, seed_points
    >>> mesh = MeshQuad().refined(2)
    >>> basis = MaterialPointBasis(mesh, ElementQuad1(), seed_points(mesh, 2))
    >>> mass = BilinearForm(lambda u, v, w: u * v)
    >>> round(float(asm(mass, basis).sum()), 12)
    1.0

    """

    def __init__(self, mesh: Mesh, elem: Element, points: MaterialPoints,
                 location: Optional[Tuple[ndarray, ndarray]] = None,
                 dofs: Optional[Dofs] = None):
        if not isinstance(points, MaterialPoints):
            raise InvalidInputError(
                "points must be MaterialPoints, got {}"
                .format(type(points).__name__))
        tind, X = locate_points(mesh, points.x) if location is None \
            else location
        if tind.shape != (points.n,) or X.shape != points.x.shape:
            raise InvalidInputError(
                "location (tind {}, X {}) does not match {} points of "
                "dimension {}".format(tind.shape, X.shape, points.n,
                                      points.dim))
        order = np.argsort(tind, kind="stable")
        elements, start, counts = np.unique(tind[order], return_index=True,
                                            return_counts=True)
        row = np.repeat(np.arange(len(elements)), counts)
        slot = np.arange(points.n) - np.repeat(start, counts)
        shape = (len(elements), int(counts.max()))
        Xq = np.repeat(X[:, order[start]][:, :, None], shape[1], axis=2)
        Xq[:, row, slot] = X[:, order]
        dx = np.zeros(shape)
        dx[row, slot] = points.volume[order]
        self.point_index = np.full(shape, -1, dtype=np.int64)
        self.point_index[row, slot] = order
        # flat slot of every point, and the padding slots
        self._slot_of_point = np.empty(points.n, dtype=np.int64)
        self._slot_of_point[order] = row * shape[1] + slot
        self._padding = np.flatnonzero(self.point_index.ravel() < 0)
        self._doflocs = None
        super().__init__(mesh, elem, mapping=fresh_mapping(mesh),
                         elements=elements, quadrature=(Xq, dx), dofs=dofs,
                         disable_doflocs=dofs is not None)
        self.dx = dx
        logger.debug("material-point basis: %d points in %d active elements "
                     "(at most %d per element)", points.n, *shape)

    @property
    def doflocs(self) -> ndarray:
        """Global DOF locations, computed on first use when ``dofs`` was
        given."""
        if self._doflocs is None:
            doflocs = self.mapping.F(self.elem.doflocs.T)
            out = np.zeros((doflocs.shape[0], self.N))
            out[:, self.dofs.element_dofs] = doflocs.transpose(0, 2, 1)
            self._doflocs = out
        return self._doflocs

    @doflocs.setter
    def doflocs(self, value: ndarray):
        self._doflocs = value

    @property
    def active_dofs(self) -> ndarray:
        """The DOFs of the active elements: grid nodes with point support."""
        return distinct(self.element_dofs, self.N)

    def point_values(self, field: ndarray) -> ndarray:
        """Reorder a quadrature field (..., nelems, nqp) into point order
        (..., n), dropping padding slots."""
        flat = field.reshape(field.shape[:-2] + (-1,))
        return np.take(flat, self._slot_of_point, axis=-1)

    def quadrature_field(self, values: ndarray) -> ndarray:
        """Scatter point values (..., n) into a quadrature field
        (..., nelems, nqp), zero in padding slots: the inverse of
        :meth:`point_values`, for point data entering forms."""
        out = np.take(values, self.point_index.ravel(), axis=-1)
        out[..., self._padding] = 0.
        return out.reshape(values.shape[:-1] + self.point_index.shape)
