"""Velocity fields: one copy of the grid per group of bodies in contact.

Bodies of one grid share its nodes' displacements, so they are glued
wherever both are present.  A contact between two bodies
(:class:`~skfem_mpm.Contact`) puts them on separate *fields*: copies of
the grid with their own nodes, overlapping in space, which only the
contact condition couples.  Field ``k`` of a grid of ``nv`` vertices and
``N`` vector DOFs holds vertices ``k nv ...`` and DOFs ``k N ...``; a
point lives on the field of its body, in the copy ``k nelements + e`` of
the cell ``e`` holding it.  The run then solves on the *extended* mesh of
all copies (:func:`extended_mesh`) like on any other mesh: operators,
ghost faces, cell averages and supports are per field by construction.

Bodies glued to each other share a field: the fields are the groups of
bodies connected by pairs *without* a declared contact
(:func:`body_fields`).
"""
from typing import NamedTuple

import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix

from ..kernels import run_clock
from ..errors import InvalidInputError
from .operators import SparseOperator

__all__ = ["body_fields", "extended_mesh", "FieldLocator", "tile_dofs",
           "Fields", "FieldMethod"]


def body_fields(pairs, nbodies: int) -> ndarray:
    """The field of each body (``nbodies``,) given the pairs of bodies in
    contact: bodies joined by a pair with no contact share a field.

    Raises :class:`~skfem_mpm.errors.InvalidInputError` where a declared
    pair would share a field (both glued to a third body that is in
    contact with neither).  Two fields of several bodies each are apart
    where every pair of their bodies has a contact: one interface
    (:func:`~skfem_mpm.solve.body_contact.contact_interfaces`).

    Examples
    --------
    >>> from skfem_mpm.methods.fields import body_fields
    >>> body_fields([(0, 1)], 2).tolist()
    [0, 1]
    >>> body_fields([(0, 1), (0, 2)], 3).tolist()      # 1 and 2 glued
    [0, 1, 1]

    """
    apart = np.zeros((nbodies, nbodies), dtype=bool)
    for a, b in pairs:
        apart[a, b] = apart[b, a] = True
    field = np.arange(nbodies)
    for a in range(nbodies):            # union of the glued pairs
        for b in range(a + 1, nbodies):
            if not apart[a, b]:
                field[field == field[b]] = field[a]
    for a, b in pairs:
        if field[a] == field[b]:
            glue = [c for c in range(nbodies) if c not in (a, b)
                    and field[c] == field[a]]
            raise InvalidInputError(
                "bodies {} and {} are in contact but glued through body "
                "{}, which has no contact with {}: bodies without a "
                "contact are glued, whether they meet or not; declare the "
                "contacts of every pair of bodies that must not be glued "
                "(a cap 2 glued to its pile 1 above soil 0: Contact(0, 2) "
                "too, with the friction of Contact(0, 1): the contacts "
                "between two groups of glued bodies make one "
                "interface)".format(
                    a, b, glue[0], "either" if not (apart[glue[0], a] or
                                                   apart[glue[0], b])
                    else "one of them"))
    return np.unique(field, return_inverse=True)[1]


def extended_mesh(mesh, nfields: int):
    """``nfields`` copies of ``mesh`` in one mesh of its type: the
    vertices tiled, copy ``k``'s cells on vertices ``k nv ...``.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm.methods.fields import extended_mesh
    >>> big = extended_mesh(MeshQuad.init_tensor([0., 1., 2.], [0., 1.]), 2)
    >>> int(big.nvertices), big.nelements, big.boundary_facets().size
    (12, 4, 12)

    """
    nv = mesh.nvertices
    p = np.tile(mesh.p, nfields)
    t = np.hstack([mesh.t + k * nv for k in range(nfields)])
    return type(mesh)(p, t, sort_t=False)


def tile_dofs(dofs: ndarray, N: int, nfields: int) -> ndarray:
    """Grid DOFs ``dofs`` of one field on every field (sorted)."""
    dofs = np.asarray(dofs, dtype=np.int64)
    return (dofs[None, :] + N * np.arange(nfields)[:, None]).ravel()


class FieldLocator:
    """The point locator of a run with fields: ``locate(x)`` of the grid,
    with each point's cell moved to its field's copy.  Called with the
    positions of the run's points (in their order), as the methods do.

    Parameters
    ----------
    locate
        ``point_locator(mesh)`` of the grid.
    field
        The field of each point (n,).
    nelements
        The grid's cells.
    """

    def __init__(self, locate, field: ndarray, nelements: int):
        self.locate, self.field = locate, field
        self.offset = field * nelements
        self.mesh = None               # the extended mesh, set by the run

    def __call__(self, x: ndarray):
        if x.shape[1] != self.offset.size:
            raise InvalidInputError(
                "a run with contacts between bodies locates its {} points, "
                "got {} positions".format(self.offset.size, x.shape[1]))
        tind, X = self.locate(x)
        return tind + self.offset, X


class Fields(NamedTuple):
    """A run's fields: the extended ``mesh``, its scalar DOFs and vector
    stiffness pattern, the locator of the run's points on it, the field
    of each point (``field``), one field's vertices and cells, and the
    vector grid basis of the extended mesh."""
    mesh: object
    scalar_dofs: object
    pattern: object
    locate: FieldLocator
    field: ndarray
    vertices: int
    cells: int
    grid: object = None

    @property
    def count(self) -> int:
        return int(self.field.max()) + 1

    def combine(self, parts, n: int) -> SparseOperator:
        """One operator of ``n`` points from ``(idx, op)``: the operator
        ``op`` of points ``idx`` on the grid (``None``: none), for each
        field in turn, its columns moved to the field's copy."""
        rows, cols, values, elements = [], [], [], []
        for k, (idx, op) in enumerate(parts):
            if op is None:
                continue
            S = op.S.tocoo()
            rows.append(idx[S.row])
            cols.append(S.col + k * self.vertices)
            values.append([S.data] + [G.tocoo().data for G in op.G])
            elements.append(op.elements + k * self.cells)
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        shape = (n, self.count * self.vertices)
        S, *G = [csr_matrix((np.concatenate(data), (rows, cols)),
                            shape=shape) for data in zip(*values)]
        return SparseOperator(S, G, np.concatenate(elements))


class FieldMethod:
    """A method piece whose operator is a sparse one (GIMP, B-splines) on
    the run's fields: each field's points' operator built on the grid by
    ``piece.sparse_operator`` and moved to the field's copy
    (:meth:`Fields.combine`); cells are those of the extended mesh."""

    def __init__(self, piece, fields: Fields):
        self.piece, self.fields = piece, fields
        self.name, self.moves = piece.name, piece.moves
        self.offset = fields.field * fields.cells
        self.members = [np.flatnonzero(fields.field == k)
                        for k in range(fields.count)]
        if hasattr(piece, "weights_at"):
            self.weights_at = self._weights_at
        if hasattr(piece, "face_weights"):
            self.face_weights = self._face_weights

    def locate(self, x, step: int, timings: dict, converged):
        tind, X = self.piece.locate(x, step, timings, converged)
        return tind + self.offset, X

    def domains(self, domain0, F):
        return self.piece.domains(domain0, F)

    def check_supports(self, op, fixed, nodal_dofs, step: int):
        """The piece's check, on each field's copy of the grid."""
        self.piece.check_supports(op, fixed, nodal_dofs, step)

    def operator(self, points, step: int, timings: dict):
        location = self.locate(points.x, step, timings, points)
        tic = run_clock()
        domain = points.domain
        op = self.fields.combine(
            ((idx, self.piece.sparse_operator(
                points.x[:, idx], None if domain is None else domain[:, idx])
              if idx.size else None) for idx in self.members), points.n)
        op.point_elements = location[0]
        timings["assemble"] += run_clock() - tic
        return op

    def _weights_at(self, x: ndarray, idx: ndarray,
                    axis: int = None) -> SparseOperator:
        """The method's weights at positions ``x`` (dim, m) on the fields
        of points ``idx`` (m,): their domains' corners, or with ``axis``
        the centres of their faces normal to it."""
        return self._per_field(self.piece.weights_at, x, idx, axis)

    def _face_weights(self, x: ndarray, idx: ndarray, axis: int,
                      sign: int) -> SparseOperator:
        """The method's weights of the faces normal to ``axis`` on the
        side ``sign`` of points ``idx`` (m,), their centres ``x`` (dim,
        m), on their fields (surface loads)."""
        return self._per_field(self.piece.face_weights, x, idx, axis, sign)

    def _per_field(self, weights, x: ndarray, idx: ndarray, *args):
        """``weights(x, idx, *args)`` of each field's points, on its copy
        of the grid."""
        field = self.fields.field[idx]
        return self.fields.combine(
            ((np.flatnonzero(field == k), weights(
                x[:, field == k], idx[field == k], *args)
              if (field == k).any() else None)
             for k in range(self.fields.count)), x.shape[1])
