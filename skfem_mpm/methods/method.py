"""Methods: how the points of a load step become its point operator.

A method piece answers, for the load-step core: where are the points
(``locate``), what is the step's point operator (``operator``), do the
points move at the end of a step (``moves``), and how do GIMP domains
follow the deformation (``domains``).

- ``"fem"``: finite elements with the points as quadrature: the points are
  located once and never move, so the operator is built once (in finite
  deformation the scheme is total Lagrangian);
- ``"mpm"``: standard MPM, the scikit-fem element evaluated at the points
  (:class:`~skfem_mpm.methods.operators.PointOperator`), rebuilt every step
  at the points' positions (updated Lagrangian);
- ``"ugimp"``, ``"cpgimp"``: GIMP, weights averaged over the points'
  domains (:mod:`skfem_mpm.methods.gimp`); cpGIMP stretches the domains
  with the deformation, uGIMP keeps them.  GIMP needs an axis-aligned
  tensor-product grid and point domains: refused at set-up otherwise;
- ``"bspline"``: quadratic B-splines with the grid's nodes as control
  points (:mod:`skfem_mpm.methods.bspline`), C1 across grid lines (no
  cell-crossing error); points move as in standard MPM.  Needs a uniformly
  spaced axis-aligned tensor-product grid of linear elements;
- ``"bspline-gimp"``: the same splines averaged over the points' domains
  (as GIMP averages the grid's hats), the domains stretched as cpGIMP's:
  no quadrature floor once the points leave the knots (``docs/bspline.md``).
  Needs point domains: refused at its first operator otherwise;
- ``"bspline3"``, ``"bspline3-gimp"``: the same with cubic B-splines
  (knots at the nodes, C2, 4^dim nodes a point;
  :class:`~skfem_mpm.methods.bspline.CubicBSpline`).

"""
from typing import Optional

import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix

from ..errors import InvalidInputError, PointsOutsideGridError, \
    check_choice
from ..kernels import check_kernels, run_clock
from ..quadrature.basis import MaterialPointBasis
from ..quadrature.locate import using_kernels
from .bspline import CubicBSpline, QuadraticBSpline
from .fields import FieldMethod
from .gimp import gimp_operators, stretched_domains
from .operators import PointOperator, SparseOperator

__all__ = ["METHODS", "DOMAIN_METHODS", "make_method"]

#: the method names (``method=``, scene key ``solver.method``)
METHODS = ("fem", "mpm", "ugimp", "cpgimp", "bspline", "bspline-gimp",
           "bspline3", "bspline3-gimp")
#: the methods that average over the points' domains (need them)
DOMAIN_METHODS = ("ugimp", "cpgimp", "bspline-gimp", "bspline3-gimp")


class PointMethod:
    """Standard MPM (``moves=True``) or finite elements with the points
    as quadrature (``moves=False``: located once, operator kept).  Every
    operator carries ``point_elements``, the cell holding each point."""

    #: the run's ``kernels`` option (:class:`~skfem_mpm.solve.options.
    #: Options`): whether the material-point basis takes compiled passes
    #: (:func:`~skfem_mpm.quadrature.basis.compiled_kernels`), and the
    #: supports' check (:func:`~skfem_mpm.solve.motion.check_held`)
    kernels = "auto"

    def __init__(self, name: str, mesh, scalar, scalar_dofs, pattern,
                 locate, counters: dict):
        self.name, self.mesh, self.scalar = name, mesh, scalar
        self.scalar_dofs, self.pattern = scalar_dofs, pattern
        self._locate, self.counters = locate, counters
        self.moves = name != "fem"
        self._operator = None
        self._located = (None, None)

    def locate(self, x, step: int, timings: dict, converged):
        """Element and local coordinates of the positions ``x`` (located
        once: the location after a step's update serves the next step);
        the error carries the step and the last converged points."""
        if self._located[0] is x:
            return self._located[1]
        tic = run_clock()
        self.counters["locate"] += 1
        try:
            self._located = (x, self._locate(x))
            return self._located[1]
        except PointsOutsideGridError as err:
            err.step, err.state = step, converged
            err.at_start = x is converged.x
            raise
        finally:
            timings["locate"] += run_clock() - tic

    def operator(self, points, step: int, timings: dict):
        """The step's point operator (seconds go to ``timings``: locate,
        assemble)."""
        if self._operator is not None:
            return self._operator
        location = self.locate(points.x, step, timings, points)
        tic = run_clock()
        op = PointOperator(MaterialPointBasis(
            self.mesh, self.scalar, points, location, dofs=self.scalar_dofs,
            kernels=self.kernels), self.pattern)
        op.point_elements = location[0]
        if not self.moves:
            self._operator = op
        timings["assemble"] += run_clock() - tic
        return op

    def domains(self, domain0: Optional[ndarray], F: ndarray):
        return None

    def check_supports(self, op, fixed: ndarray, nodal_dofs: ndarray,
                       step: int):
        """Refuse held DOFs that would not hold the material where they
        are (the grid's DOFs are the field's values at the nodes here:
        none)."""


class GimpMethod(PointMethod):
    """uGIMP (domains fixed) or cpGIMP (domains stretched by ``U``)."""

    def __init__(self, name, mesh, scalar, scalar_dofs, pattern, locate,
                 counters):
        super().__init__(name, mesh, scalar, scalar_dofs, pattern, locate,
                         counters)
        self._grid = mesh, scalar, locate
        self._boxes = None          # the step's points' centres and domains
        self.kernels = PointMethod.kernels

    @property
    def kernels(self) -> str:
        """The run's ``kernels`` option (:attr:`PointMethod.kernels`),
        the sub-point basis's too (quadratic elements)."""
        return self._kernels

    @kernels.setter
    def kernels(self, kernels: str):
        if getattr(self, "_kernels", None) != kernels:    # set up once
            self._kernels = kernels
            mesh, scalar, locate = self._grid
            self.gimp = gimp_operators(mesh, scalar,
                                       using_kernels(locate, kernels),
                                       kernels=kernels)

    def locate(self, x, step: int, timings: dict, converged):
        """:meth:`PointMethod.locate`; the step's points' centres and
        domains are kept for :meth:`face_weights` (also where the fields
        of bodies in contact build the operator per field)."""
        self._boxes = (converged.x, converged.domain)
        return super().locate(x, step, timings, converged)

    def operator(self, points, step: int, timings: dict):
        location = self.locate(points.x, step, timings, points)
        tic = run_clock()
        op = self.sparse_operator(points.x, points.domain)
        op.point_elements = location[0]
        timings["assemble"] += run_clock() - tic
        return op

    def sparse_operator(self, x: ndarray, domain: ndarray):
        """The GIMP operator of points at ``x`` with half-lengths
        ``domain``."""
        return self.gimp(x, domain)

    def face_weights(self, x: ndarray, idx: ndarray, axis: int,
                     sign: int):
        """The GIMP weights of the faces normal to ``axis`` on the side
        ``sign`` (+1 or -1) of points ``idx`` (``x``, the material's faces'
        centres, unused): the faces of their domains in the step's
        operator (flat along ``axis``), where surface loads act, so a
        traction loads the nodes the domains reach as their internal force
        does (the side the load's, not the material face's: a domain's box
        does not turn with a body turned past a right angle).  The grid
        element's shape functions in the point's cell, extrapolated to a
        face a thousandth of a cell past a grid line, put nothing on the
        node beyond, where the domain's sliver did: that node's balance
        took the stress of the loaded column of points to zero, and the
        column beside it carried twice the load (a GIMP block stretched in
        two steps; cpGIMP's column compressed by 30% went 0.46 off its
        homogeneous displacement at step 18 and left the grid).  The domain's face, not
        the material's (``x + F d0``, beyond uGIMP's fixed domain when
        stretched): there the stretched block's loaded column was 7% off."""
        centre, domain = self._boxes
        face = domain[:, idx].copy()
        at = centre[:, idx].copy()
        at[axis] += sign * face[axis]
        face[axis] = 0.
        return self.gimp(at, face)

    def domains(self, domain0: Optional[ndarray], F: ndarray):
        if self.name == "cpgimp":
            return stretched_domains(domain0, F)
        return None


class BSplineMethod(PointMethod):
    """B-spline MPM: points move as in standard MPM, the operator is
    rebuilt every step from the splines at their positions (``"bspline"``,
    cubic ``"bspline3"``) or averaged over their domains, stretched as
    cpGIMP's (``"bspline-gimp"``, ``"bspline3-gimp"``);
    ``point_elements`` is the cell holding each point."""

    def __init__(self, name, mesh, scalar, scalar_dofs, pattern, locate,
                 counters, extended: bool = False, held: ndarray = None):
        super().__init__(name, mesh, scalar, scalar_dofs, pattern, locate,
                         counters)
        self.spline = (CubicBSpline if name.startswith("bspline3")
                       else QuadraticBSpline)(mesh, scalar, name)
        self.averaged = name.endswith("-gimp")
        self.extended, self.held = extended, held
        self._extension = None      # the step's extension (extended splines)
        self._filled = None         # what it was formed from
        self._boxes = None          # the step's points' centres and domains
        self._lattice = None        # nodes' grid indices, and inverse

    def locate(self, x, step: int, timings: dict, converged):
        """:meth:`PointMethod.locate`; the step's points' centres and
        domains are kept for :meth:`weights_at` (also where the fields of
        bodies in contact build the operator per field)."""
        self._boxes = (converged.x, converged.domain)
        return super().locate(x, step, timings, converged)

    def operator(self, points, step: int, timings: dict):
        location = self.locate(points.x, step, timings, points)
        tic = run_clock()
        op = self.sparse_operator(points.x, points.domain)
        if self.extended:
            touched = np.zeros(op.S.shape[1], dtype=bool)
            touched[op.S.indices] = True
            self._filled = (points.x, points.volume, touched)
            self._extension = E = self.spline.extension(
                points.x, points.volume, touched, self.held)
            if E is not None:
                op = extended_operator(op, E)
        op.point_elements = location[0]
        timings["assemble"] += run_clock() - tic
        return op

    def sparse_operator(self, x: ndarray, domain=None):
        """The splines' operator of points at ``x``: at the points
        (``"bspline"``, ``"bspline3"``: domains play no part) or averaged
        over their boxes of half-lengths ``domain``."""
        if not self.averaged:
            return self.spline(x)
        if domain is None:
            raise InvalidInputError(
                "method {!r} averages the splines over the points' domains "
                "and needs them (MaterialPoints.domain; seed_points sets "
                "them on tensor-product grids); method {!r} evaluates the "
                "splines at the points".format(self.name,
                                               self.name[:-len("-gimp")]))
        return self.spline(x, domain)

    def weights_at(self, x: ndarray, idx: ndarray = None,
                   axis: int = None):
        """The splines' operator at positions ``x`` (dim, m) of points
        ``idx``: at the centres of their faces normal to ``axis``, where
        surface loads act, so a traction loads the nodes the method's
        displacement field is made of, or (``axis`` None) at the corners
        of their domains (contacts between bodies).  With
        ``"bspline-gimp"`` a face's centre takes the average over the face
        of the point's domain in the step's operator (flat along ``axis``:
        a sheared domain's face centre is offset along the other axes too,
        by more than half the domain at a shear of 0.5); a corner takes
        the splines there."""
        if axis is None or not self.averaged or idx is None or \
                self._boxes is None:
            op = self.spline(x)
        else:
            face = self._boxes[1][:, idx].copy()
            face[axis] = 0.
            op = self.spline(x, face)
        if self._filled is None:
            return op
        x, volume, touched = self._filled
        reached = np.zeros_like(touched)
        reached[op.S.indices] = True
        E = self._extension
        if (reached & ~touched).any():
            # nodes a face reaches that no point does: folded as well (they
            # are no DOF; a tip traction lost 1.2e-3 of itself on them)
            E = self.spline.extension(x, volume, touched | reached,
                                      self.held)
        return op if E is None else extended_operator(op, E)

    def face_weights(self, x: ndarray, idx: ndarray, axis: int,
                     sign: int):
        """:meth:`weights_at` the centres ``x`` of the faces normal to
        ``axis`` of points ``idx`` (surface loads; ``sign``, their side,
        is where ``x`` lies)."""
        return self.weights_at(x, idx, axis)

    def domains(self, domain0: Optional[ndarray], F: ndarray):
        if self.averaged:
            return stretched_domains(domain0, F)
        return None

    def check_folded_supports(self, held: ndarray, nodal_dofs: ndarray,
                              step: int):
        """Refuse a held DOF of a node that the step's extended splines
        fold into nodes not held alike: the material by it (filling no
        knot span there) would no longer be held."""
        E = self._extension
        folded = folded_nodes(E)
        for a in range(nodal_dofs.shape[0]):
            held_a = held[nodal_dofs[a]]
            rows = folded[held_a[folded]]
            if rows.size == 0:
                continue
            loose = abs(E[rows]) @ (~held_a).astype(float) > 0
            if loose.any():
                raise InvalidInputError(
                    "step {}: the extended splines fold {} held grid nodes "
                    "(the first at {}, component {}) into free ones: no knot "
                    "span by them is filled by material, and the support "
                    "would no longer hold it; let the material reach the "
                    "support, or leave extended_splines off".format(
                        step, int(loose.sum()),
                        np.round(self.mesh.p[:, rows[loose][0]], 6).tolist(),
                        a))

    def check_supports(self, op, fixed: ndarray, nodal_dofs: ndarray,
                       step: int):
        """Refuse a held DOF that points carry weight on where a grid
        neighbour's DOF of the same component is free and carries weight
        too, along an axis on which the node is not at the grid's end.  A
        node is a control point: the field's value only where the splines
        interpolate, at the grid's ends along each axis, so a support
        holds the material only as a whole edge (face) of the grid held
        alike.  Before, a block pressed against a held line inside the
        grid carried 11% less force than it should, and one on a base
        held only under it had stresses 15-19% off, without a warning.

        Parameters
        ----------
        op
            The step's point operator (its ``active_dofs``).
        fixed
            The step's held DOFs.
        nodal_dofs
            The grid's vector DOF of each node, (dim, nodes); on the
            fields of bodies in contact, of every field's copy of the
            grid in turn (each checked as a grid of its own).
        step
            The step, for the message.
        """
        held = np.zeros(nodal_dofs.max() + 1, dtype=bool)
        held[fixed] = True
        if self._extension is not None:
            self.check_folded_supports(held, nodal_dofs, step)
        active = np.zeros_like(held)
        active[op.active_dofs] = True
        if not (held & active).any():
            return
        if self._lattice is None:     # node numbers by their grid indices
            index = np.array([np.rint((self.mesh.p[b] - a[0]) / (a[1] - a[0]))
                              for b, a in enumerate(self.spline.axes)],
                             dtype=int)
            lattice = np.full([len(a) for a in self.spline.axes], -1)
            lattice[tuple(index)] = np.arange(self.mesh.nvertices)
            self._lattice = index, lattice
        index, lattice = self._lattice
        nv = self.mesh.nvertices
        loose = np.zeros(nodal_dofs.shape[1], dtype=bool)
        for a in range(nodal_dofs.shape[0]):          # component
            pinned = held[nodal_dofs[a]] & active[nodal_dofs[a]]
            free = ~held[nodal_dofs[a]] & active[nodal_dofs[a]]
            for b, size in enumerate(lattice.shape):  # along axis b
                interior = np.flatnonzero((index[b] > 0)
                                          & (index[b] < size - 1))
                for side in (-1, 1):
                    near = index[:, interior].copy()
                    near[b] += side
                    neighbour = lattice[tuple(near)]
                    for k in range(0, nodal_dofs.shape[1], nv):  # field
                        loose[k + interior] |= pinned[k + interior] \
                            & free[k + neighbour]
        nodes = np.flatnonzero(loose) % nv
        if nodes.size:
            raise InvalidInputError(
                "step {}: method {!r} holds DOFs at {} grid nodes beside "
                "free ones that points carry weight on (the first at {}): "
                "the nodes are the splines' control points, which equal the "
                "displacement only at the grid's ends, so a support inside "
                "the grid, or along part of its edge, does not hold the "
                "material there; hold a whole edge of the grid (make the "
                "grid end at the support), or push or hold the material "
                "with an Obstacle (a punch, a footing, a wall: "
                "docs/contact.md)".format(
                    step, self.name, nodes.size,
                    np.round(self.mesh.p[:, nodes[0]], 6).tolist()))


def folded_nodes(E) -> ndarray:
    """The (scalar) DOFs an extension ``E`` folds: its rows that are not
    the identity's."""
    return np.flatnonzero((np.diff(E.indptr) != 1) | (E.diagonal() != 1.))


def extended_operator(op: SparseOperator, E) -> SparseOperator:
    """The operator ``S E``, ``G E`` of a spline operator ``op`` and an
    extension ``E`` (:meth:`~skfem_mpm.methods.bspline.QuadraticBSpline.
    extension`), on one sparsity pattern.  Only the rows of points that
    carry weight on a folded node change: theirs take the structure of the
    product of the two patterns (scipy's product drops entries that cancel
    to zero, which would part the patterns of ``S E`` and ``G E``), each
    product's entries placed in it; the other rows are kept."""
    S, N = op.S, E.shape[1]
    n = S.shape[0]
    folded = np.zeros(N, dtype=bool)
    folded[folded_nodes(E)] = True
    row_of = np.repeat(np.arange(n), np.diff(S.indptr))
    hit = np.zeros(n, dtype=bool)
    hit[row_of[folded[S.indices]]] = True
    rows = np.flatnonzero(hit)

    def ones(A):
        return csr_matrix((np.ones(A.nnz), A.indices, A.indptr),
                          shape=A.shape)

    def keys(A):
        return np.repeat(np.arange(A.shape[0], dtype=np.int64) * N,
                         np.diff(A.indptr)) + A.indices
    pattern = ones(S[rows]) @ ones(E)
    pattern.sort_indices()
    where = keys(pattern)
    counts = np.diff(S.indptr)
    counts[rows] = np.diff(pattern.indptr)
    indptr = np.concatenate(([0], np.cumsum(counts)))
    kept = ~hit[row_of]
    old = np.flatnonzero(kept)
    to_old = indptr[row_of[old]] + old - S.indptr[row_of[old]]
    sub_row = np.repeat(np.arange(rows.size), np.diff(pattern.indptr))
    to_new = indptr[rows[sub_row]] + np.arange(pattern.nnz) \
        - pattern.indptr[sub_row]
    indices = np.empty(indptr[-1], dtype=S.indices.dtype)
    indices[to_old] = S.indices[old]
    indices[to_new] = pattern.indices

    def product(X):
        XE = X[rows] @ E
        XE.sort_indices()
        data = np.empty(indptr[-1])
        data[to_old] = X.data[old]
        data[to_new] = 0.
        data[to_new[np.searchsorted(where, keys(XE))]] = XE.data
        return csr_matrix((data, indices, indptr), shape=(n, N))
    return SparseOperator(product(S), [product(G) for G in op.G],
                          op.elements)


#: the piece of each method that is not :class:`PointMethod`
KINDS = {"ugimp": GimpMethod, "cpgimp": GimpMethod,
         "bspline": BSplineMethod, "bspline-gimp": BSplineMethod,
         "bspline3": BSplineMethod, "bspline3-gimp": BSplineMethod}


def make_method(name: str, mesh, scalar, scalar_dofs, pattern, locate,
                counters: dict, fields=None, extended: bool = False,
                held: ndarray = None, kernels: str = "auto"):
    """The method piece called ``name`` (one of :data:`METHODS`); with
    ``fields`` (:class:`~skfem_mpm.methods.fields.Fields`, contacts
    between bodies), on the copies of the grid: standard MPM and FE on the
    extended mesh (given as ``mesh``, ``scalar_dofs``, ``pattern``), the
    others built on the grid and moved to the copies
    (:class:`~skfem_mpm.methods.fields.FieldMethod`); ``extended``: the
    splines extended (:meth:`~skfem_mpm.methods.bspline.QuadraticBSpline.
    extension`; B-spline methods without fields only), ``held`` the
    grid's nodes a support holds (bool per node); ``kernels`` the run's
    option (:attr:`PointMethod.kernels`)."""
    piece = _method(name, mesh, scalar, scalar_dofs, pattern, locate,
                    counters, fields, extended, held)
    piece.kernels = check_kernels(kernels)
    if isinstance(piece, FieldMethod):       # the piece it moves, too
        piece.piece.kernels = piece.kernels
    for each in (piece, getattr(piece, "piece", None)):   # its locator
        if isinstance(each, PointMethod):
            each._locate = using_kernels(each._locate, piece.kernels)
    return piece


def _method(name, mesh, scalar, scalar_dofs, pattern, locate, counters,
            fields, extended, held):
    """:func:`make_method`'s piece, before its ``kernels``."""
    check_choice("method", name, METHODS)
    kind = KINDS.get(name, PointMethod)
    if extended and (kind is not BSplineMethod or fields is not None):
        raise InvalidInputError(
            "extended splines are for the B-spline methods ('bspline', "
            "'bspline-gimp', 'bspline3', 'bspline3-gimp') without contacts "
            "between bodies, got method {!r}{}".format(
                name, " with contacts" if fields is not None else ""))
    if fields is None:
        return kind(name, mesh, scalar, scalar_dofs, pattern, locate,
                    counters, **({"extended": True, "held": held}
                                 if extended else {}))
    if kind is PointMethod:
        return kind(name, fields.mesh, scalar, fields.scalar_dofs,
                    fields.pattern, fields.locate, counters)
    return FieldMethod(kind(name, mesh, scalar, scalar_dofs, pattern, locate,
                            counters), fields)
