"""The material-point basis: a scikit-fem ``CellBasis`` whose quadrature is
the material points.

Only elements that hold points are active (empty elements are ignored, seed
2.2.2).  Points are grouped per element; an element holding fewer points
than the fullest one is padded with zero-weight slots, so scikit-fem sees a
quadrature of shape (dim, n_active_elements, max_points_per_element) and
``asm``, forms, ``interpolate``, ``condense`` and ``solve`` work unchanged.
Grid nodes without point support have empty rows: condense them away with
the supports (:attr:`MaterialPointBasis.inactive_dofs`).

Padding costs work where the point counts per element vary (random or
clustered points): :func:`material_point_bases` splits the points into
bases of elements with (about) equal counts, which scikit-fem's
``asm(form, bases)`` sums.

"""
import logging
from typing import List, Optional, Tuple

import numpy as np
from numpy import ndarray
from skfem.assembly import CellBasis, Dofs
from skfem.assembly.basis import AbstractBasis
from skfem.element import DiscreteField, Element, ElementComposite, \
    ElementH1, ElementHex1, ElementQuad1, ElementVector
from skfem.mesh import Mesh

from ..errors import InvalidInputError
from ..graph import distinct
from ..kernels import auto_kernels, check_kernels, import_timed
from .locate import locate_points
from .mapping import PointMapping, fresh_mapping
from .points import MaterialPoints

logger = logging.getLogger(__name__)

__all__ = ["MaterialPointBasis", "material_point_bases"]

#: the elements whose fields a compiled pass forms on their own
#: isoparametric mesh (:mod:`skfem_mpm.kernels.basis`), by its name
COMPILED_FIELDS = {ElementQuad1: "quad1_fields", ElementHex1: "hex1_fields"}
_KERNELS = {}           # compiled_kernels's modules by name


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
        :func:`~skfem_mpm.locate_points` when not given.  A basis
        locating its own points logs a warning where no cell holds
        points enough for a form in the gradients to see its functions
        (:func:`thin_cells`: P2 triangles with one point, Q2 with one,
        Q2 hexahedra with 2 x 2 x 2); the runs check their own seeding.
    dofs
        Optional scikit-fem ``Dofs`` of ``(mesh, elem)`` to reuse between
        load steps.  When given, global DOF locations (``doflocs``) are
        computed only if asked for.
    subset
        Optional sorted, distinct indices of the points this basis
        integrates with (default: all); the others are left to other bases
        (:func:`material_point_bases`).
    kernels
        ``"auto"`` (default), ``"numpy"`` or ``"compiled"``: whether the
        slots and fields are formed by compiled passes, equal to the numpy
        path's to the bit (:func:`compiled_kernels`).

    Attributes
    ----------
    point_index
        (n_active_elements, max_points_per_element) index of the point in
        each quadrature slot, -1 in padding slots.
    subset
        The indices of the points integrated, sorted: the order of
        :meth:`point_values`.

    Notes
    -----
    scikit-fem's ``with_element``, ``with_elements`` and ``split_bases``
    give material-point bases on the same points (those in the elements
    asked for: ``with_elements``).  Points at the centres of equal
    sub-cells (:func:`~skfem_mpm.seed_points`) integrate exactly only
    what is linear in a cell: quadratic elements lose an order of
    convergence on them (the README gives the numbers).

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
                 dofs: Optional[Dofs] = None,
                 subset: Optional[ndarray] = None, kernels: str = "auto"):
        tind, X = _located(mesh, points, location)
        self.subset = _check_subset(subset, points.n)
        self._npoints = points.n
        self._basis = None
        passes = compiled_kernels(kernels=kernels) \
            if subset is None and points.n else None
        self._passes = passes        # its slots' kernels (nodal_values)
        (elements, Xq, dx, self.point_index, self._slot_of_point,
         self._padding, self._groups) = _slots(
             tind, X, points.volume, self.subset) + (None,) \
            if passes is None else passes.point_slots(
                tind, np.ascontiguousarray(X, dtype=np.float64),
                np.ascontiguousarray(points.volume, dtype=np.float64))
        shape = dx.shape
        self._doflocs = None
        self._scalar_fields = None
        mapping = fresh_mapping(mesh)
        if dofs is not None and isinstance(mapping, PointMapping) \
                and type(elem).gbasis is ElementH1.gbasis:
            # scikit-fem's CellBasis, its fields formed in one pass
            AbstractBasis.__init__(self, mesh, elem, mapping,
                                   quadrature=(Xq, dx), refdom=mesh.refdom,
                                   dofs=dofs, disable_doflocs=True)
            self.tind = mesh.normalize_elements(elements)
            self.nelems = len(self.tind)
            fields = compiled_fields(elem, mapping, Xq, self.tind, kernels)
            # the fields as scikit-fem's (:attr:`basis`) on first use
            self._scalar_fields = _h1_fields(
                elem, self.Nbfun, mapping, Xq, self.tind) \
                if fields is None else fields
        else:
            super().__init__(mesh, elem, mapping=mapping, elements=elements,
                             quadrature=(Xq, dx), dofs=dofs,
                             disable_doflocs=dofs is not None)
        if isinstance(mapping, PointMapping):
            mapping.forget()        # the fields are formed: not kept
        self.dx = dx
        logger.debug("material-point basis: %d points in %d active elements "
                     "(at most %d per element)", points.n, *shape)
        if location is None:            # a user's basis (the runs check
            thin = thin_cells(elem, shape[1])   # their own seeding)
            if thin:
                logger.warning(thin)

    def with_element(self, elem: Element) -> "MaterialPointBasis":
        """A material-point basis of ``elem`` on the same points, slots and
        volumes: what a fresh :class:`MaterialPointBasis` of ``elem`` on
        the points gives (scikit-fem's ``CellBasis.with_element``).

        >>> from skfem import MeshQuad, ElementQuad1, ElementQuad2
        >>> from skfem_mpm import MaterialPointBasis, seed_points
        >>> mesh = MeshQuad().refined(1)
        >>> basis = MaterialPointBasis(mesh, ElementQuad1(),
        ...                            seed_points(mesh, 3))
        >>> quadratic = basis.with_element(ElementQuad2())
        >>> int(quadratic.N), quadratic.dx.shape == basis.dx.shape
        (25, True)
        """
        return self._on_slots(elem, self.tind, self.X, self.dx,
                              self.point_index, self._passes)

    def with_elements(self, elements=None) -> "MaterialPointBasis":
        """A material-point basis of the points in the grid's ``elements``
        (indices, a boolean mask or a callable of the element centres, as
        scikit-fem's ``CellBasis.with_elements``): what a fresh
        :class:`MaterialPointBasis` with ``subset=`` those points gives.
        Elements holding no points of this basis add nothing; none of
        them holding any is refused.

        >>> from skfem import MeshQuad, ElementQuad1
        >>> from skfem_mpm import MaterialPointBasis, seed_points
        >>> mesh = MeshQuad().refined(1)
        >>> basis = MaterialPointBasis(mesh, ElementQuad1(),
        ...                            seed_points(mesh, 2))
        >>> left = basis.with_elements(lambda x: x[0] < .5)
        >>> left.tind.tolist(), left.subset.size, float(left.dx.sum())
        ([0, 3], 8, 0.5)
        """
        wanted = np.zeros(self.mesh.nelements, dtype=bool)
        wanted[self.mesh.normalize_elements(
            True if elements is None else elements)] = True
        rows = np.flatnonzero(wanted[self.tind])
        if rows.size == 0:
            raise InvalidInputError(
                "with_elements: none of the {} element(s) asked for holds "
                "a point of this basis (its {} active elements)".format(
                    int(wanted.sum()), self.nelems))
        index = self.point_index[rows]
        width = int((index >= 0).sum(axis=1).max())  # points fill the
        return self._on_slots(self.elem, self.tind[rows],  # first slots
                              self.X[:, rows, :width],
                              self.dx[rows, :width], index[:, :width],
                              passes=None)    # a subset's: the numpy path

    def split_bases(self) -> List["MaterialPointBasis"]:
        """Material-point bases of the solution's components (scikit-fem's
        ``split_bases``), on the same points: :meth:`with_element`."""
        if isinstance(self.elem, ElementComposite):
            return [self.with_element(e) for e in self.elem.elems]
        if isinstance(self.elem, ElementVector):
            return [self.with_element(self.elem.elem)
                    for _ in range(self.elem.dim)]
        return [self]

    def _on_slots(self, elem: Element, elements: ndarray, Xq: ndarray,
                  dx: ndarray, point_index: ndarray,
                  passes) -> "MaterialPointBasis":
        """A basis of ``elem`` on the slots ``point_index`` (rows: the
        active ``elements``) at the local coordinates ``Xq`` with the
        volumes ``dx``, formed as a fresh basis without ``dofs`` forms
        its own; ``passes``: its compiled slot kernels or ``None``."""
        new = object.__new__(type(self))
        real = point_index.ravel() >= 0
        flat = np.flatnonzero(real)
        order = point_index.ravel()[flat]
        new.subset = np.sort(order)
        new._slot_of_point = flat[np.argsort(order)]   # by subset
        new.point_index, new._padding = point_index, np.flatnonzero(~real)
        new._npoints, new._passes = self._npoints, passes
        new._basis = new._doflocs = new._scalar_fields = new._groups = None
        mapping = fresh_mapping(self.mesh)
        CellBasis.__init__(new, self.mesh, elem, mapping=mapping,
                           elements=elements, quadrature=(Xq, dx))
        if isinstance(mapping, PointMapping):
            mapping.forget()
        new.dx = dx
        return new

    @property
    def basis(self) -> list:
        """scikit-fem's fields, ``[(DiscreteField(values, gradients),)]``
        a function: where the basis formed them in one pass (its
        :meth:`scalar_fields`), made of views of those arrays when first
        asked for (the compiled passes never ask: 8-10 us a load step at
        56 points in 2D)."""
        if self._basis is None:
            values, gradients = self._scalar_fields
            self._basis = [(DiscreteField(values[i], gradients[i]),)
                           for i in range(len(values))]
        return self._basis

    @basis.setter
    def basis(self, fields: list):
        self._basis = fields

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
        """The DOFs of the active elements (grid nodes with point support)."""
        return distinct(self.element_dofs, self.N)

    @property
    def inactive_dofs(self) -> ndarray:
        """The DOFs without point support, sorted; their rows and columns
        are empty.

        Condense them away with the supports, the scikit-fem way:
        ``solve(*condense(K, f, D=np.union1d(D, basis.inactive_dofs)))``.

        Examples
        --------
        >>> import numpy as np
        >>> from skfem import MeshQuad, ElementQuad1, asm, condense, solve
        >>> from skfem.models.poisson import laplace, unit_load
        >>> from skfem_mpm import MaterialPointBasis, seed_points
        >>> mesh = MeshQuad().refined(2)                  # 4 x 4 cells
        >>> basis = MaterialPointBasis(mesh, ElementQuad1(), seed_points(
        ...     mesh, 2, region=lambda x: x[0] < .5))     # the left half
        >>> basis.inactive_dofs.size                      # 2 columns of 5
        10
        >>> D = np.union1d(basis.get_dofs().all(), basis.inactive_dofs)
        >>> u = solve(*condense(asm(laplace, basis), asm(unit_load, basis),
        ...                     D=D))
        >>> bool(np.isfinite(u).all() and u.max() > 0)
        True

        """
        unsupported = np.ones(self.N, dtype=bool)
        unsupported[self.element_dofs] = False
        return np.flatnonzero(unsupported)

    def scalar_fields(self) -> Tuple[ndarray, ndarray]:
        """The shape functions (nloc, nelems, slots) of a scalar element at
        the points and their gradients (nloc, dim, nelems, slots), each in
        one array, computed once; the basis's own fields become views of
        them, so that they exist once in memory (196 bytes a point in 3D).

        Examples
        --------
        >>> from skfem import MeshQuad, ElementQuad1
        >>> from skfem_mpm import MaterialPointBasis, seed_points
        >>> mesh = MeshQuad().refined(1)
        >>> basis = MaterialPointBasis(mesh, ElementQuad1(),
        ...                            seed_points(mesh, 2))
        >>> values, gradients = basis.scalar_fields()
        >>> values.shape, gradients.shape
        ((4, 4, 4), (4, 2, 4, 4))
        >>> bool(values.sum(axis=0).round(12).min() == 1.)
        True
        """
        if self._scalar_fields is None:
            if any(len(f) != 1 or f[0].ndim != 2 for f in self.basis):
                raise InvalidInputError("scalar_fields: the basis has a "
                                        "vector element")
            values = np.array([np.asarray(f[0]) for f in self.basis])
            gradients = np.array([f[0].grad for f in self.basis])
            self.basis = [(DiscreteField(values[i], gradients[i],
                                         *f[0].astuple[2:]),)
                          for i, f in enumerate(self.basis)]
            self._scalar_fields = (values, gradients)
        return self._scalar_fields

    def share_gradients(self, gradients: ndarray):
        """Take ``gradients`` (nloc, dim, nelems, slots), equal to those of
        :meth:`scalar_fields` but in another memory layout (a view of the
        compiled passes' points-first array), as the basis's own: its
        fields' gradients become views of it and the array it held is
        released (196 bytes a point in 3D).

        >>> import numpy as np
        >>> from skfem import MeshQuad, ElementQuad1
        >>> from skfem_mpm import MaterialPointBasis, seed_points
        >>> basis = MaterialPointBasis(MeshQuad().refined(1), ElementQuad1(),
        ...                            seed_points(MeshQuad().refined(1), 2))
        >>> values, gradients = basis.scalar_fields()
        >>> first = np.ascontiguousarray(gradients.transpose(2, 3, 0, 1))
        >>> basis.share_gradients(first.transpose(2, 3, 0, 1))
        >>> bool(np.shares_memory(basis.basis[0][0].grad, first))
        True
        """
        values, before = self.scalar_fields()
        if gradients.shape != before.shape:
            raise InvalidInputError(
                "share_gradients: gradients of shape {}, the basis's are {}"
                .format(gradients.shape, before.shape))
        for i, (field,) in enumerate(self._basis or ()):  # the basis's own
            field.grad = gradients[i]     # fields (made anew: 20-40 us)
        self._scalar_fields = (values, gradients)

    def groups(self, keep: bool = True) -> Tuple[ndarray, ndarray, ndarray]:
        """The points element by element: ``(runs, in_slots, flat)``, the
        first of each active element's points and the end (``runs``,
        nelems + 1), the points in slot order (``point_index`` of the
        filled slots) and their flat slots (int64 each); from the compiled
        slot layout where it formed them (20 us a load step at 56 points
        in 2D), else from :attr:`point_index`.  ``keep=False``: the caller
        takes them over (and may write them), the basis forgets them (16
        bytes a point kept otherwise: the 3D heap's peak).

        >>> from skfem import MeshQuad, ElementQuad1
        >>> from skfem_mpm import MaterialPointBasis, seed_points
        >>> mesh = MeshQuad().refined(1)
        >>> runs, in_slots, flat = MaterialPointBasis(
        ...     mesh, ElementQuad1(), seed_points(mesh, 1)).groups()
        >>> runs.tolist(), in_slots.tolist(), flat.tolist()
        ([0, 1, 2, 3, 4], [0, 1, 2, 3], [0, 1, 2, 3])
        """
        if self._groups is None:
            real = self.point_index >= 0
            runs = np.zeros(real.shape[0] + 1, dtype=np.int64)
            np.cumsum(real.sum(axis=1), out=runs[1:])
            self._groups = (runs, self.point_index[real].astype(np.int64),
                            np.flatnonzero(real.ravel()).astype(np.int64))
        groups = self._groups
        if not keep:
            self._groups = None
        return groups

    def point_values(self, field: ndarray) -> ndarray:
        """Reorder a quadrature field (..., nelems, nqp) into the order of
        the points in :attr:`subset` (..., len(subset)), dropping padding
        slots."""
        flat = field.reshape(field.shape[:-2] + (-1,))
        return np.take(flat, self._slot_of_point, axis=-1)

    def nodal_values(self, shape_values: ndarray, scalar_dofs: ndarray,
                     u: ndarray, dim: int) -> Optional[ndarray]:
        """The values (dim, n) at the points of the nodal vector ``u``
        (``dim`` components a node) through the shape values (nloc, nelems,
        nqp) at the element DOFs ``scalar_dofs`` (nloc, nelems), by one
        compiled pass where this basis's slots came from one
        (:func:`~skfem_mpm.kernels.basis.point_values`: equal to the
        gather, ``einsum`` and :meth:`point_values` of the numpy path to
        the bit; a standard MPM commit's ``values`` inside one-step runs
        at 56 points in 2D 41-57 -> 13-21 us); else ``None``."""
        if self._passes is None or shape_values.ndim != 3:
            return None
        args = (shape_values, scalar_dofs, np.ascontiguousarray(
            u, dtype=np.float64), dim, self._slot_of_point,
                self.point_index.shape[1])
        return in_chunks(self._slot_of_point.size, "values_in_chunks",
                         self._passes.point_values, args)

    def nodal_loads(self, shape_values: ndarray, scalar_dofs: ndarray,
                    f: ndarray, size: int) -> Optional[ndarray]:
        """The nodal loads (size,) of the point forces ``f`` (dim, n)
        through the shape values (nloc, nelems, nqp) at the element DOFs
        ``scalar_dofs`` (nloc, nelems), DOF ``dim k + a`` component a of
        node k, by one compiled pass where this basis's slots came from
        one and numpy's ``einsum`` sums as the pass does
        (:func:`einsum_order`; :func:`~skfem_mpm.kernels.basis.
        point_loads`: equal to the numpy path's :meth:`quadrature_field`,
        ``einsum`` and ``bincount`` to the bit); else ``None``."""
        if self._passes is None or shape_values.ndim != 3 \
                or not shape_values.flags.c_contiguous \
                or shape_values.dtype != np.float64 \
                or not einsum_order(self._passes):
            return None
        return self._passes.point_loads(
            shape_values, np.ascontiguousarray(f, dtype=np.float64),
            self.point_index, scalar_dofs, f.shape[0], size)

    def quadrature_field(self, values: ndarray) -> ndarray:
        """Scatter the values (..., n) of all points into a quadrature
        field (..., nelems, nqp) of the points in :attr:`subset`, zero in
        padding slots: the inverse of :meth:`point_values`, for point data
        entering forms.  Values of another count than the points' are
        refused.

        >>> import numpy as np
        >>> from skfem import MeshQuad, ElementQuad1
        >>> from skfem_mpm import MaterialPointBasis, seed_points
        >>> mesh = MeshQuad().refined(1)
        >>> basis = MaterialPointBasis(mesh, ElementQuad1(),
        ...                            seed_points(mesh, 2))
        >>> basis.quadrature_field(np.arange(16.)).shape
        (4, 4)
        """
        values = np.asarray(values)
        if values.ndim == 0 or values.shape[-1] != self._npoints:
            raise InvalidInputError(
                "quadrature_field: values of shape {}, the last axis must "
                "hold one value for each of the basis's {} points (all of "
                "them, not only its subset)".format(values.shape,
                                                    self._npoints))
        out = np.take(values, self.point_index.ravel(), axis=-1)
        out[..., self._padding] = 0.
        return out.reshape(values.shape[:-1] + self.point_index.shape)


def thin_cells(elem: Element, slots: int) -> str:
    """Where ``slots`` points, the most an active element holds, are too
    few for a form in the gradients of the H1 element ``elem`` (scalar or
    ``ElementVector``, c components, nloc functions) to see each cell's
    functions less the c constants, a sentence saying so, else ``""``.
    k points give an element matrix of a form in the gradients rank at
    most c dim k, below nloc - c in every cell: zero-energy modes, a
    singular matrix or a polluted solution (P2 triangles with one point:
    an L2 error of 3.6e15; a user trial).  A few integer products: no work
    over the points.  Forms in the symmetric gradient (elasticity) need
    more (the runs' own check, a Q2 cell 15 strain states of its 18
    DOFs; ``underintegrated_cells``).

    >>> from skfem import ElementTriP2, ElementQuad2
    >>> thin_cells(ElementQuad2(), 4)
    ''
    >>> thin_cells(ElementTriP2(), 1)[:43]
    'material-point basis of ElementTriP2: at mo'
    """
    scalar, c = (elem.elem, elem.dim) if isinstance(elem, ElementVector) \
        else (elem, 1)
    if not isinstance(scalar, ElementH1):
        return ""
    nloc, dim = scalar.doflocs.shape[0], scalar.dim
    if c * dim * slots >= c * (nloc - 1):
        return ""
    least = -(-(nloc - 1) // dim)
    # seed_points(mesh, n): n per axis, n^dim a cell (n^2 sub-triangles)
    axis = next(n for n in range(1, least + 1) if n ** dim >= least)
    return (
        "material-point basis of {}: at most {} point(s) in any cell, "
        "which give a form in the gradients rank at most {} a cell, below "
        "the {} its {} functions less the constants need: zero-energy "
        "modes in every cell (a singular matrix, or a solution polluted by "
        "them where the supports do not hold them); seed at least {} "
        "points in every cell (seed_points(mesh, {}) seeds {} a cell: its "
        "n is per cell and axis, n^{} a cell)".format(
            type(elem).__name__, slots, c * dim * slots, c * (nloc - 1),
            c * nloc, least, axis, axis ** dim, dim))


def _h1_fields(elem: Element, nloc: int, mapping: PointMapping,
               X: ndarray, tind: ndarray) -> Tuple[ndarray, ndarray]:
    """The values (nloc, nelems, slots) and gradients (nloc, dim, nelems,
    slots) of the ``nloc`` functions of a scalar H1 element at the
    quadrature ``X`` of the elements
    ``tind``: what scikit-fem's ``CellBasis`` forms function by function
    (``ElementH1.gbasis``: ``grad = invDF^T dphi``, the same products
    summed in the same order, equal to the bit), without its per-function
    fields and its quadrature weights (a material-point basis sets its
    own), in half the time.

    >>> import numpy as np
    >>> from skfem import MeshQuad, ElementQuad1, CellBasis
    >>> from skfem_mpm.quadrature.mapping import PointMapping
    >>> mesh = MeshQuad().refined(1)
    >>> X, tind = np.random.default_rng(0).random((2, 4, 3)), np.arange(4)
    >>> values, gradients = _h1_fields(ElementQuad1(), 4,
    ...                                PointMapping(mesh), X, tind)
    >>> basis = CellBasis(mesh, ElementQuad1(), elements=tind,
    ...                   quadrature=(X, np.ones(3)))
    >>> bool(np.array_equal(gradients[2], basis.basis[2][0].grad))
    True
    """
    invDF = mapping.invDF(X, tind)             # refuses a zero determinant
    values = np.empty((nloc,) + X.shape[1:])
    gradients = np.empty((nloc,) + X.shape)
    for i in range(nloc):
        values[i], dphi = elem.lbasis(X, i)
        grad = gradients[i]
        np.multiply(invDF[0], dphi[0], out=grad)
        for a in range(1, len(dphi)):
            grad += invDF[a] * dphi[a]
    return values, gradients


def _slots(tind: ndarray, X: ndarray, volume: ndarray, subset: ndarray):
    """``(elements, Xq, dx, point_index, slot_of_point, padding)``: the
    points of ``subset`` grouped by element (the active ones ascending,
    a stable order within each), in the slots of a padded (element, slot)
    layout, the padding slots at their element's first point."""
    by_element = np.argsort(tind[subset], kind="stable")
    order = subset[by_element]
    elements, start, counts = np.unique(tind[order], return_index=True,
                                        return_counts=True)
    shape = (len(elements), int(counts.max()))
    # the flat slot (element, slot) of each point in ``order``: flat
    # indices into the fields, not (row, slot) pairs (2.5 times faster)
    flat = np.arange(len(order)) + np.repeat(
        np.arange(len(elements)) * shape[1] - start, counts)
    Xq = np.repeat(X[:, order[start]][:, :, None], shape[1], axis=2)
    Xq.reshape(len(X), -1)[:, flat] = X[:, order]
    dx = np.zeros(shape)
    dx.reshape(-1)[flat] = volume[order]
    point_index = np.full(shape, -1, dtype=np.int64)
    point_index.reshape(-1)[flat] = order
    # flat slot of every point of the subset, and the padding slots
    slot_of_point = np.empty(len(order), dtype=np.int64)
    slot_of_point[by_element] = flat
    return (elements, Xq, dx, point_index, slot_of_point,
            np.flatnonzero(point_index.ravel() < 0))


def compiled_kernels(name: str = "basis", kernels: str = "auto"):
    """The compiled kernels ``skfem_mpm.kernels.<name>`` (``"basis"``:
    :mod:`skfem_mpm.kernels.basis`, ``"graph"``) where numba imports and
    ``kernels`` is ``"compiled"``, or ``"auto"`` and the environment lets
    it be (:func:`~skfem_mpm.kernels.auto_kernels`); else ``None`` (the
    numpy path, the reference: they give its numbers to the bit).

    >>> compiled_kernels(kernels="numpy") is None
    True
    """
    if check_kernels(kernels) == "numpy" or (
            kernels == "auto" and auto_kernels() != "auto"):
        return None
    if name not in _KERNELS:
        try:
            _KERNELS[name] = import_timed("skfem_mpm.kernels." + name)
        except ImportError:             # no numba: the numpy path
            _KERNELS[name] = None
    return _KERNELS[name]


def einsum_order(kernels) -> bool:
    """Whether numpy's ``einsum("iem,aem->iae")`` over C-contiguous
    arrays sums each element's slots as
    :func:`~skfem_mpm.kernels.basis.slot_sum` does (two lanes, no fused
    multiply-add: x86-64's baseline build), found once (``kernels``:
    :mod:`skfem_mpm.kernels.basis`) on slot counts 1 to 19 with signed
    zeros; where not (another build's vector width or
    fused products), :meth:`MaterialPointBasis.nodal_loads` leaves the
    point forces to the numpy path."""
    if "einsum_order" not in _KERNELS:
        rng = np.random.default_rng(0)
        same = True
        for slots in range(1, 20):
            N, F = (rng.standard_normal((k, 3, slots)) * 10. ** rng.integers(
                -8, 8, (k, 3, slots)) for k in (4, 2))
            F[:, 1] = -0.
            want = np.einsum("iem,aem->iae", N, F)
            got = kernels.slot_sums(N, F)
            same = same and np.array_equal(got, want) and np.array_equal(
                np.signbit(got), np.signbit(want))
        if not same:
            logger.info("numpy's einsum sums in another order than the "
                        "compiled point loads: the numpy path serves them")
        _KERNELS["einsum_order"] = same
    return _KERNELS["einsum_order"]


def compiled_fields(elem: Element, mapping: PointMapping, X: ndarray,
                    tind: ndarray, kernels: str = "auto"
                    ) -> Optional[Tuple[ndarray, ndarray]]:
    """:func:`_h1_fields` by a compiled pass, equal to the bit, where one
    serves: the element one of :data:`COMPILED_FIELDS`, on its own
    isoparametric mesh (the mapping's element of its type), ``kernels``
    not the numpy path's (:func:`compiled_kernels`) and numba
    importable; else (or at a zero Jacobian determinant, which the numpy
    path refuses) ``None``.  A load step's basis at 1024 points in 2D:
    the fields 0.37 -> 0.02 ms (the Jacobian, its inverse and the element
    function by function, some 90 numpy calls)."""
    name = COMPILED_FIELDS.get(type(elem))
    kernels = compiled_kernels(kernels=kernels) if name is not None \
        and type(mapping.elem) is type(elem) else None
    if kernels is None:
        return None
    nloc = elem.doflocs.shape[0]
    values = np.empty((nloc,) + X.shape[1:])
    gradients = np.empty((nloc,) + X.shape)
    # the elements' nodes read in the pass (a gathered copy: 5 us a step)
    args = (np.ascontiguousarray(mapping.mesh.doflocs, dtype=np.float64),
            np.ascontiguousarray(mapping.mesh.dofs.element_dofs,
                                 dtype=np.int64),
            np.ascontiguousarray(tind, dtype=np.int64),
            np.ascontiguousarray(X, dtype=np.float64), values, gradients)
    if in_chunks(X.shape[1] * X.shape[2], "fields_in_chunks",
                 getattr(kernels, name), args, (name == "hex1_fields",)):
        return None                     # a zero determinant: refused there
    return values, gradients


def in_chunks(n: int, chunked: str, serial, args: tuple, lead=()):
    """``serial(*args)``, a compiled pass over ``n`` points (or their
    slots), or where ``n`` is large (:func:`~skfem_mpm.kernels.parallel.
    split_count`) its twin ``chunked`` of :mod:`skfem_mpm.kernels.
    parallel` on the machine's cores (``chunked(count, *lead, *args)``),
    the same answer to the bit: at 1e6
    points in 2D (two cores) a step's basis 0.091 -> 0.073 s, a vector's
    values 0.025 -> 0.012 s (the commit's, and its check of thrown
    points'), the least of six."""
    # the caller's pass is compiled: numba imports, the chunks serve too
    parallel = compiled_kernels("parallel", "compiled")
    count = 1 if parallel is None else parallel.split_count(n)
    if count == 1:
        return serial(*args)
    with parallel.LOCK:
        return getattr(parallel, chunked)(count, *lead, *args)


def _located(mesh: Mesh, points: MaterialPoints,
             location: Optional[Tuple[ndarray, ndarray]]
             ) -> Tuple[ndarray, ndarray]:
    """``(tind, X)`` of the points: located on the mesh, or ``location``
    checked against them."""
    if not isinstance(points, MaterialPoints):
        raise InvalidInputError("points must be MaterialPoints, got {}"
                                .format(type(points).__name__))
    tind, X = locate_points(mesh, points.x) if location is None \
        else location
    if tind.shape != (points.n,) or X.shape != points.x.shape:
        raise InvalidInputError(
            "location (tind {}, X {}) does not match {} points of "
            "dimension {}".format(tind.shape, X.shape, points.n, points.dim))
    return tind, X


def _check_subset(subset: Optional[ndarray], n: int) -> ndarray:
    """The point indices of a basis: all n, or ``subset`` checked to be
    non-empty, sorted, distinct and below n."""
    if subset is None:
        return np.arange(n)
    subset = np.asarray(subset)
    if subset.ndim != 1 or subset.size == 0 \
            or not np.issubdtype(subset.dtype, np.integer) \
            or subset[0] < 0 or subset[-1] >= n \
            or (np.diff(subset) <= 0).any():
        raise InvalidInputError(
            "subset must be sorted, distinct point indices in [0, {}), got "
            "{}".format(n, np.array2string(subset, threshold=6)))
    return subset.astype(np.int64, copy=False)


def material_point_bases(mesh: Mesh, elem: Element, points: MaterialPoints,
                         location: Optional[Tuple[ndarray, ndarray]] = None,
                         dofs: Optional[Dofs] = None,
                         max_padding: float = .25
                         ) -> List[MaterialPointBasis]:
    """Material-point bases grouping elements of (about) equal point counts.

    One :class:`MaterialPointBasis` pads every element to the fullest
    element's count; with random or clustered points most quadrature slots
    are then empty, and ``asm`` spends its time on them.  Here the elements
    are binned by their point counts, geometrically: within a bin the
    largest count is at most ``1 + max_padding`` times the smallest, so
    padding adds at most that share of slots to any element.  scikit-fem's
    ``asm(form, bases)`` sums over the list, equal to ``asm`` on the single
    padded basis to round-off.

    Point fields entering a form are scattered per basis with
    :meth:`MaterialPointBasis.quadrature_field` (each basis takes the
    values of all points), the parts summed as ``asm`` sums them::

        K = sum(form.elemental(b, sig=b.quadrature_field(S))
                for b in bases).todefault()

    and a quadrature field of every basis gathers back into point order
    with :meth:`MaterialPointBasis.point_values` and
    :attr:`MaterialPointBasis.subset`::

        out[..., b.subset] = b.point_values(field)

    The DOFs without point support are those inactive in every basis:
    ``functools.reduce(np.intersect1d, [b.inactive_dofs for b in bases])``.

    Parameters
    ----------
    mesh, elem, points, location
        As in :class:`MaterialPointBasis`.
    dofs
        Optional scikit-fem ``Dofs`` of ``(mesh, elem)``; built once and
        shared by the bases when not given.
    max_padding
        Largest share of padding slots in an element, >= 0; 0 groups by
        exact point count.

    Returns
    -------
    list of MaterialPointBasis
        One basis per occupied bin, in order of increasing point count.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad, ElementQuad1, asm, BilinearForm
    >>> from skfem_mpm import (MaterialPointBasis, MaterialPoints,
    ...                        material_point_bases)
    >>> mesh = MeshQuad().refined(3)
    >>> x = np.random.default_rng(0).random((2, 500))
    >>> points = MaterialPoints(x=x, volume=np.full(500, 1 / 500))
    >>> bases = material_point_bases(mesh, ElementQuad1(), points)
    >>> padded = MaterialPointBasis(mesh, ElementQuad1(), points)
    >>> padded.dx.size, sum(b.dx.size for b in bases)   # quadrature slots
    (896, 527)
    >>> mass = BilinearForm(lambda u, v, w: u * v)
    >>> float(abs(asm(mass, bases) - asm(mass, padded)).max()) < 1e-15
    True

    """
    if not max_padding >= 0.:
        raise InvalidInputError("max_padding must be >= 0, got {}"
                                .format(max_padding))
    location = _located(mesh, points, location)
    counts = np.bincount(location[0], minlength=mesh.nelements)
    if max_padding > 0.:
        # geometric bins: counts in [(1 + p)^k, (1 + p)^(k + 1)) share k
        label = np.floor(np.log(np.maximum(counts, 1))
                         / np.log1p(max_padding)).astype(np.int64)
    else:
        label = counts
    point_label = label[location[0]]
    order = np.argsort(point_label, kind="stable")   # ascending in a bin
    cuts = np.flatnonzero(np.diff(point_label[order])) + 1
    if dofs is None:
        dofs = Dofs(mesh, elem)
    bases = [MaterialPointBasis(mesh, elem, points, location=location,
                                dofs=dofs, subset=subset)
             for subset in np.split(order, cuts)]
    logger.debug("%d material-point bases, %d quadrature slots for %d "
                 "points", len(bases), sum(b.dx.size for b in bases),
                 points.n)
    return bases
