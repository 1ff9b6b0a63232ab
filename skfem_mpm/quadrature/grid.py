"""The grid's own basis: what a run asks of scikit-fem's ``CellBasis`` of
the whole grid (DOFs, DOF locations, facets, ``get_dofs`` for the
supports), without the fields it never reads."""
from functools import lru_cache
from typing import Tuple

import numpy as np
from numpy import ndarray
from skfem.assembly import CellBasis
from skfem.assembly.basis import AbstractBasis
from skfem.element import Element
from skfem.mesh import Mesh
from skfem.quadrature import get_quadrature

__all__ = ["GridBasis"]


@lru_cache(maxsize=8)
def centroid_rule(refdom) -> Tuple[ndarray, ndarray]:
    """One point at the centroid of the reference domain ``refdom`` (its
    order-0 Gauss points averaged) with its volume, read-only; formed once
    for each reference domain (scikit-fem's rule: 0.2 ms)."""
    X, W = get_quadrature(refdom, 0)
    rule = X @ W[:, None] / W.sum(), np.array([W.sum()])
    for a in rule:
        a.flags.writeable = False
    return rule


class GridBasis(CellBasis):
    """A ``CellBasis`` of ``elem`` on ``mesh`` for its DOFs, DOF
    locations and facets; its fields (:attr:`basis`, :attr:`dx`, at the
    centroid of element 0) formed when first read.  ``CellBasis`` forms
    them for each of an element's functions when made (0.6 ms of a
    one-step run's 6 at 56 points); a run never reads them.  Raises
    ``ValueError`` for an element of another reference domain, as
    ``CellBasis``.

    >>> from skfem import MeshQuad, ElementQuad1, ElementVector
    >>> grid = GridBasis(MeshQuad().refined(1), ElementVector(ElementQuad1()))
    >>> int(grid.N), grid.get_dofs(lambda x: x[1] == 0).all().tolist()
    (18, [0, 1, 2, 3, 8, 9])
    >>> len(grid.basis), grid.dx.tolist()
    (8, [[0.25]])
    """

    def __init__(self, mesh: Mesh, elem: Element):
        AbstractBasis.__init__(self, mesh, elem,
                               quadrature=centroid_rule(mesh.refdom),
                               refdom=mesh.refdom)
        self.tind = mesh.normalize_elements(np.array([0]))
        self.nelems = 1
        self._fields = None

    def _formed(self) -> CellBasis:
        if self._fields is None:
            self._fields = CellBasis(
                self.mesh, self.elem, self.mapping, elements=self.tind,
                quadrature=(self.X, self.W), dofs=self.dofs,
                disable_doflocs=True)
        return self._fields

    @property
    def basis(self) -> list:
        """scikit-fem's fields of each function, formed on first use."""
        return self._formed().basis

    @property
    def dx(self) -> ndarray:
        """The quadrature weight of element 0, formed on first use."""
        return self._formed().dx
