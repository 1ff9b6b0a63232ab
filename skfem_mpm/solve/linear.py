"""The linear solve on the active grid, seed (2.22), with its failure modes
turned into errors.

Grid nodes without point support have empty rows; the system is condensed
onto the active DOFs that are not supported, and a singular or unusable
factorisation raises :class:`~skfem_mpm.errors.SingularSystemError` instead
of scipy's warning followed by garbage.  The Newton iterations of a load
step assemble into one sparsity pattern and keep their free DOFs: a
:class:`Condensation` gathers the free-free block of each from an index
map built once, where scikit-fem's ``condense`` would index the sparse
matrix anew every iteration.

"""
import logging
import warnings
from contextlib import contextmanager
from typing import Callable, Optional

import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix, spmatrix
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import MatrixRankWarning
from skfem import condense
from skfem.assembly.dofs import DofsView

from ..errors import InvalidInputError, SingularSystemError
from ..graph import distinct
from ..methods.assembly import PatternMatrices
from ..quadrature.basis import compiled_kernels
from . import backends
from .backends import TINY, get_solver

logger = logging.getLogger(__name__)
#: the logger of :func:`warn_interior_supports`, apart so that a run
#: that means it silences it alone
interior_logger = logging.getLogger("skfem_mpm.supports.interior")

__all__ = ["support_dofs", "free_dofs", "check_rigid_body_modes",
           "solve_active", "factorise_active", "factorise_condensed",
           "condensed", "Condensation"]


def warn_interior_supports(mesh, nodal_dofs: ndarray, held: ndarray,
                           cells: ndarray) -> None:
    """Log a warning where the supports hold grid nodes inside a body:
    nodes off the grid's boundary with material (a point of ``cells``,
    each point's cell) in every cell around them, among the nodes of
    ``nodal_dofs`` (dim, nodes) that the DOFs ``held`` hold in every
    component (a symmetry plane or axis through a body holds one: the
    shipped cylinder's axis, x held on x = 0.5 through the disc, is not
    warned).  A user
    trial's base support, a tolerance about y = 0.1 that also took the
    row of nodes at y = 0.308 inside its backfill, ran silently to a wall
    force 20% off Rankine's; an anchor held inside a body on purpose
    silences it by its logger (``logging.getLogger(
    "skfem_mpm.supports.interior").setLevel(logging.ERROR)``)."""
    nodes = np.flatnonzero(np.isin(nodal_dofs, held).all(axis=0))
    if not nodes.size or not len(cells):
        return
    t = mesh.t
    filled = np.zeros(t.shape[1], dtype=bool)
    filled[np.asarray(cells)[np.asarray(cells) >= 0]] = True
    around = np.zeros(mesh.p.shape[1], dtype=int)
    full = np.zeros(mesh.p.shape[1], dtype=int)
    np.add.at(around, t.ravel(), 1)
    np.add.at(full, t[:, filled].ravel(), 1)
    inside = np.ones(mesh.p.shape[1], dtype=bool)
    inside[mesh.boundary_nodes()] = False
    nodes = nodes[inside[nodes] & (full[nodes] == around[nodes])]
    if not nodes.size:
        return
    x = mesh.p[:, nodes]
    lines = [axis for axis in range(x.shape[0]) if np.ptp(x[axis]) == 0.]
    interior_logger.warning(
        "supports: %d grid node(s) held have material in every cell "
        "around them, inside a body, %s: a support there holds the "
        "body's inside (a tolerance that took a row of nodes beyond the "
        "boundary meant? a trial's wall force came out 20%% off); if "
        "meant (an anchor), silence this by logging.getLogger("
        "'skfem_mpm.supports.interior').setLevel(logging.ERROR)",
        nodes.size, ("along {}".format(" and ".join(
            "{} = {:.6g}".format("xyz"[a], x[a, 0]) for a in lines))
            + ", " if lines else "") + "from ({}) to ({})".format(
                ", ".join("{:.6g}".format(v) for v in x.min(axis=1)),
                ", ".join("{:.6g}".format(v) for v in x.max(axis=1))))


def support_dofs(supports, basis) -> ndarray:
    """Turn ``supports`` into a sorted array of DOF indices.

    ``supports`` is an array of DOF indices, a scikit-fem ``DofsView``
    (anything with ``.all()``), or a callable taking the grid basis and
    returning one of those, e.g. ``lambda b: b.get_dofs("left")``.

    """
    given = supports
    if callable(supports):
        with SupportSelections(basis) as watched:
            supports = supports(basis)
        # a part of supports that hold elsewhere (no support at all is a
        # dynamic run's own, or the supports' check's error)
        empty = watched.empty if len(watched.empty) < watched.calls else []
        for selection in empty:
            logger.warning(
                "supports: get_dofs %s selected no grid DOF (the grid "
                "spans %s): that part of the supports holds nothing",
                selection, ", ".join(
                    "{} {:.6g} to {:.6g}".format(axis, lo, hi)
                    for axis, lo, hi in zip("xyz", basis.mesh.p.min(axis=1),
                                            basis.mesh.p.max(axis=1))))
        for selection in watched.unnamed:
            logger.warning(
                "supports: get_dofs %s: that part of the supports holds "
                "nothing (scikit-fem counts a vector's components from "
                "u^1)",
                selection)
    if not isinstance(supports, ndarray) and hasattr(supports, "all"):
        check_view_basis(supports, basis)
        supports = supports.all()
    try:
        raw = np.asarray(supports)
    except (TypeError, ValueError):
        raw = np.asarray(None)
    if supports is None or isinstance(supports, str) or \
            raw.dtype.kind not in "iub" and not (
                raw.dtype.kind == "f" and raw.size == 0):
        raise InvalidInputError(
            "supports must be grid DOF indices, a scikit-fem DofsView or a "
            "function of the grid basis returning one (e.g. lambda b: "
            "b.get_dofs(lambda x: x[1] == 0)){}, got {}".format(
                " (a side name is a scene-file key)" if isinstance(
                    supports, str) else "; [] for none",
                "{!r}, which returned {!r}".format(given, supports)
                if callable(given) else repr(given)))
    if raw.dtype.kind == "b":
        raise InvalidInputError("supports must be DOF indices, not a "
                                "boolean mask (np.flatnonzero(mask))")
    D = np.unique(raw.astype(np.int64).ravel())
    if D.size and (D.min() < 0 or D.max() >= basis.N):
        raise InvalidInputError(
            "support DOF indices must lie in [0, {}), got {}..{}"
            .format(basis.N, D.min(), D.max()))
    warn_ends_held_alone(D, basis)
    return D


def check_view_basis(view, basis) -> None:
    """Refuse a scikit-fem ``DofsView`` of a basis other than the grid's
    vector ``basis``: the indices of a scalar ``Basis(mesh,
    ElementQuad1())`` number one DOF per node and, read as the vector
    basis's, hold other DOFs (a user trial: a cantilever's supports so
    written gave deflections 100 times too large, unsaid)."""
    dofs = getattr(view, "obj", None)
    own = getattr(dofs, "element", None)
    if own is None:
        return
    grid = basis.elem
    same = list(own.dofnames) == list(grid.dofnames) and \
        getattr(dofs, "N", basis.N) == basis.N
    scalar = getattr(grid, "elem", grid)
    if same or basis.mesh.dim() == 1 and type(own) is type(scalar) \
            and getattr(dofs, "N", None) == basis.N:
        return                     # 1D: the scalar DOFs are the vector's
    raise InvalidInputError(
        "supports: the DofsView comes from a basis of {} ({} DOFs), not "
        "the grid's displacement basis of ElementVector({}) ({} DOFs, "
        "u^1 .. u^{} at each node): its indices would hold other DOFs; "
        "pass a function of the grid basis, e.g. lambda b: b.get_dofs("
        "lambda x: x[1] == 0), or take the DOFs from Basis(mesh, "
        "ElementVector({}()))".format(
            type(own).__name__, getattr(dofs, "N", "?"),
            type(scalar).__name__, basis.N, basis.mesh.dim(),
            type(scalar).__name__))


def warn_ends_held_alone(D: ndarray, basis) -> None:
    """Warn where the held DOFs ``D`` of the grid's vector ``basis`` hold
    a component at every vertex of an edge or facet but not at its own
    DOFs (the midside nodes of ``ElementQuad2``):
    ``get_dofs(...).nodal`` selects the vertices alone, and rollers so
    written on Q2 cells left their midside nodes free (a patch test's
    uniform stress of 100 came out between -150 and 234, a user trial)."""
    dim, mesh = basis.mesh.dim(), basis.mesh
    held = np.zeros(basis.N, dtype=bool)
    held[D] = True
    nodal = basis.nodal_dofs
    places = [("facet", mesh.facets, basis.facet_dofs)]
    if dim == 3:
        places.append(("edge", mesh.edges, basis.edge_dofs))
    for place, vertices, dofs in places:
        for c in range(dim):
            own = dofs[c::dim]
            if not own.size:
                continue
            ends = held[nodal[c::dim][:, vertices]].all(axis=(0, 1))
            free = ends & ~held[own].all(axis=0)
            if free.any():
                logger.warning(
                    "supports: u^%d is held at every vertex of %d %s(s) "
                    "of the grid but not at their own DOFs (%s's nodes "
                    "between the vertices; get_dofs(...).nodal selects "
                    "the vertices alone, .all(\"u^%d\") every DOF), e.g. "
                    "the %s of %s: the support holds only its vertices",
                    c + 1, int(free.sum()), place,
                    type(getattr(basis.elem, "elem", basis.elem)).__name__,
                    c + 1, place, ", ".join(
                        str(mesh.p[:, v].tolist()) for v in
                        vertices[:, np.flatnonzero(free)[0]]))


class SupportSelections:
    """While in use (a context manager), each ``get_dofs`` call on
    ``basis`` is counted (:attr:`calls`) and each that selects no DOF
    noted in :attr:`empty` (its place among the calls and its
    arguments): a side missed by a predicate (``x[0] == 46`` on a grid
    ending at 45) would hold nothing without a word.  The basis itself
    is what a supports function receives (its type, every attribute).

    Examples
    --------
    >>> from skfem import Basis, ElementQuad1, MeshQuad
    >>> basis = Basis(MeshQuad(), ElementQuad1())
    >>> with SupportSelections(basis) as watched:
    ...     held = basis.get_dofs(lambda x: x[0] == 0.).flatten().tolist()
    ...     none = basis.get_dofs(lambda x: x[0] == 2.).flatten().size
    >>> held, none, watched.calls, watched.empty
    ([0, 3], 0, 2, ['call 2 (<lambda>)'])
    >>> "get_dofs" in vars(basis)         # the basis as it was
    False
    """

    def __init__(self, basis):
        self.basis = basis
        self.empty = []
        self.unnamed = []
        self.calls = 0

    def __enter__(self):
        get_dofs = self.basis.get_dofs

        def watched(*args, **kwargs):
            dofs = get_dofs(*args, **kwargs)
            self.calls += 1
            if hasattr(dofs, "flatten") and dofs.flatten().size == 0:
                self.empty.append("call {} ({})".format(self.calls, ", ".join(
                    [getattr(a, "__name__", repr(a)) for a in args]
                    + ["{}={}".format(k, getattr(v, "__name__", repr(v)))
                       for k, v in kwargs.items()])))
            elif isinstance(dofs, DofsView):
                dofs.keep = self.kept(dofs, self.calls)
            return dofs
        self.basis.get_dofs = watched
        return self

    def __exit__(self, *exc):
        vars(self.basis).pop("get_dofs", None)
        return False

    def kept(self, dofs, call: int):
        """``dofs.keep`` (``.all(names)`` calls it), noting in
        :attr:`unnamed` names that keep none of the selection's DOFs:
        scikit-fem names a vector's components ``u^1``, ``u^2``, ``u^3``,
        and a trial's rollers ``.all("u^0")`` held nothing unsaid."""
        keep = type(dofs).keep.__get__(dofs)

        def watched(dofnames):
            kept = keep(dofnames)
            if kept.flatten().size == 0:
                self.unnamed.append(
                    "call {}: .all({!r}) kept none of its {} DOFs, named "
                    "{}".format(call, dofnames, dofs.flatten().size,
                                ", ".join(sorted(set(
                                    dofs.obj.element.dofnames)))))
            return kept
        return watched


def free_dofs(active: ndarray, D: ndarray) -> ndarray:
    """The active DOFs that are not supported (both sorted, distinct)."""
    if active.size == 0:
        return active
    mask = np.zeros(int(max(active[-1], D[-1] if D.size else 0)) + 1,
                    dtype=bool)
    mask[active] = True
    mask[D] = False
    return np.flatnonzero(mask)


def rigid_modes(xyz: ndarray, dim: int) -> ndarray:
    """Rigid-body modes at nodes xyz (dim, m) as (m, dim, nmodes):
    translations, then rotations about the nodes' centroid, scaled by the
    nodes' extent."""
    rel = xyz - xyz.mean(axis=1, keepdims=True)
    rel = rel / max(np.abs(rel).max(), np.finfo(float).tiny)
    rotations = ((0, 1), (1, 2), (2, 0))[:{1: 0, 2: 1, 3: 3}[dim]]
    modes = np.zeros((xyz.shape[1], dim, dim + len(rotations)))
    modes[:, np.arange(dim), np.arange(dim)] = 1.
    for j, (a, b) in enumerate(rotations, start=dim):
        modes[:, a, j], modes[:, b, j] = -rel[b], rel[a]
    return modes


def held_modes(doflocs: ndarray, held: ndarray, dim: int) -> ndarray:
    """The rows of the held vector DOFs ``held`` in :func:`rigid_modes`
    of their nodes, (held.size, nmodes): ``rigid_modes(doflocs[:, held //
    dim], dim)[np.arange(held.size), held % dim]``, the same numbers
    without the modes of every component (31 -> 12 us a supports'
    check at 56 points)."""
    k, a = held // dim, held % dim
    xyz = doflocs[:, k]
    rel = xyz - xyz.mean(axis=1, keepdims=True)
    rel = rel / max(np.abs(rel).max(), TINY)
    rotations = ((0, 1), (1, 2), (2, 0))[:{1: 0, 2: 1, 3: 3}[dim]]
    R = np.zeros((held.size, dim + len(rotations)))
    R[np.arange(held.size), a] = 1.
    for j, (p, q) in enumerate(rotations, start=dim):
        R[:, j] = np.where(a == p, -rel[q], np.where(a == q, rel[p], 0.))
    return R


MODE_NAMES = {1: ["translation along x"],
              2: ["translation along x", "translation along y", "rotation"],
              3: ["translation along x", "translation along y",
                  "translation along z", "rotation about z",
                  "rotation about x", "rotation about y"]}


def component_labels(graph, kernels: str = "auto") -> ndarray:
    """scipy's ``connected_components(graph, directed=False)`` labels of
    a square CSR node graph, by a compiled union of its entries' ends
    where ``kernels`` is not the numpy path's
    (:func:`~skfem_mpm.quadrature.basis.compiled_kernels`;
    :mod:`skfem_mpm.kernels.graph`: the same labels, without scipy's
    validation, conversion and transpose of the graph, 70-80 us a
    supports' check)."""
    passes = compiled_kernels("graph", kernels) \
        if isinstance(graph, csr_matrix) and graph.shape[0] == \
        graph.shape[1] else None
    if passes is None:
        return connected_components(graph, directed=False)[1]
    return passes.component_labels(graph.shape[0], graph.indptr,
                                   graph.indices)[1]


def element_labels(element_dofs: ndarray, dim: int, n_nodes: int,
                   kernels: str = "auto") -> Optional[ndarray]:
    """:func:`component_labels` of :func:`~skfem_mpm.graph.
    element_adjacency` (the chain of each element's nodes, of its vector
    DOFs ``element_dofs``), by a compiled union of the elements' nodes
    without the graph where ``kernels`` takes the compiled passes
    (:mod:`skfem_mpm.kernels.graph`); else ``None`` (form the graph)."""
    passes = compiled_kernels("graph", kernels)
    if passes is None:
        return None
    nodes = np.ascontiguousarray(element_dofs[::dim] // dim, dtype=np.int64)
    return passes.element_labels(n_nodes, nodes)[1]


#: a bound from below on the least eigenvalue of the Gram matrix of a
#: part's held DOFs' rows of the modes over its largest, at or above
#: which the compiled supports' check finds the part held (the singular
#: values' ratio is then 1e-4 or more, and the rank test's 1e-8 passes
#: whatever the round-off); below it, the rank test decides
CLEARLY_HELD = 1e-8


def check_rigid_body_modes(adjacency, doflocs: ndarray, active: ndarray,
                           D: ndarray, dim: int, kernels: str = "auto",
                           step=None):
    """Raise :class:`~skfem_mpm.errors.SingularSystemError` if a connected
    part of the active grid can move rigidly.

    Parameters
    ----------
    adjacency
        Sparse (n_nodes, n_nodes) matrix, nonzero where two scalar DOFs
        (nodes) share a point or an active element (the graphs of
        :mod:`skfem_mpm.graph`), or its component labels (n_nodes,)
        (:func:`component_labels`, :func:`element_labels`).
    doflocs
        Scalar DOF locations (dim, n_nodes).
    active, D
        Active and supported (or prescribed) vector DOFs; vector DOF
        ``dim * k + a`` is component a of node k.
    kernels
        The run's ``kernels`` option (:func:`component_labels` of a
        graph; the compiled passes find the parts clearly held in one
        pass, :data:`CLEARLY_HELD`: 95 -> 15 us at 56 points).

    """
    label = adjacency if isinstance(adjacency, ndarray) \
        and adjacency.ndim == 1 else component_labels(adjacency, kernels)
    passes = compiled_kernels("graph", kernels)
    # contiguous arrays: one compiled signature (the run's DOF locations,
    # every dim-th column of the grid's, another 14 s of compiling)
    if passes is not None and passes.clearly_held(
            label, np.ascontiguousarray(active, dtype=np.int64),
            np.ascontiguousarray(D, dtype=np.int64),
            np.ascontiguousarray(doflocs, dtype=np.float64), dim,
            CLEARLY_HELD):
        return
    n = len(label)
    nodes = distinct(active // dim, n)
    # inactive nodes join nothing: the graph's components, read at the
    # active nodes, are theirs (no subgraph to cut out)
    parts = distinct(label[nodes], n)
    label = np.searchsorted(parts, label)
    is_node = np.zeros(n, dtype=bool)
    is_node[nodes] = True
    fixed = D[is_node[D // dim]]
    # DOFs without a place (ElementQuadP's facet modes, NaN in doflocs)
    # hold no rigid motion that their cell's vertices do not: the check
    # reads the placed ones (NaN made numpy's SVD fail, a user trial)
    fixed = fixed[np.isfinite(doflocs[:, fixed // dim]).all(axis=0)]
    fixed_label = label[fixed // dim]
    where = "" if step is None else "step {}: ".format(step)
    def body(c):
        members = nodes[label[nodes] == c]
        members = members[np.isfinite(doflocs[:, members]).all(axis=0)]
        return "{}a body on {} grid nodes (bounding box {} to {})".format(
            where, members.size, doflocs[:, members].min(axis=1).round(
                6).tolist(), doflocs[:, members].max(axis=1).round(6).tolist())
    for c in range(parts.size):
        held = fixed[fixed_label == c]
        if held.size == 0:
            raise SingularSystemError(
                "{} touches no supported node: it can move freely (rigid-body "
                "modes); add supports".format(body(c)))
        R = held_modes(doflocs, held, dim)
        sv = np.linalg.svd(R, compute_uv=False)
        nmodes = R.shape[1]
        if held.size < nmodes or sv.min() < 1e-8 * sv.max():
            _, _, vt = np.linalg.svd(R)
            free = np.abs(vt[-1]) > 1e-6
            names = [n for n, f in zip(MODE_NAMES[dim], free) if f]
            raise SingularSystemError(
                "{} is not held against {}: its supports allow a rigid-body "
                "motion; add supports".format(body(c), " / ".join(names)))


#: entries of a pattern (rows of about so many) scanned at a time for
#: those a :class:`Condensation` keeps on the numpy path: its masks,
#: 8-byte positions and the copies ``np.take`` makes of indices.  2 ** 20
#: entries' were the peak of a 3D run's heap while the map was built (155
#: bytes a point at 1.1e5 points), 2 ** 16 with a mask of all entries 60
#: bytes a point at 3.3e4 points
TAKE_BLOCK = 1 << 14
#: entries a :class:`Condensation` gathers at a time on the numpy path
#: (their values and their 8-byte positions, expanded from the map's
#: runs: 320 kB; the compiled path copies a run at a time); a map
#: of fewer entries keeps their positions whole (:attr:`Condensation.
#: take`) and gathers them by one fancy indexing
GATHER_BLOCK = 1 << 14


class Condensation:
    """The free-free block ``K[free][:, free]`` of CSR matrices of one
    sparsity pattern, gathered from ``K.data`` through an index map built
    once (by indexing a matrix of entry numbers the way ``condense``
    indexes ``K``).

    The map is kept as runs of consecutive entries of ``K.data``
    (:attr:`runs`: a 3D grid's kept entries come some 28 to a run, the
    free nodes of a row side by side), expanded to positions a block of
    :data:`GATHER_BLOCK` entries at a time; a map of fewer entries also
    as the positions (:attr:`take`).  Kept whole, the positions were 121
    bytes a point at the peak of a 3D run's heap (3.3e4 points).  Where
    ``kernels`` takes the compiled kernels, the map is built in one pass
    over the rows and gathered a run at a time, no positions formed
    (:func:`~skfem_mpm.kernels.graph.condensation_runs`,
    :func:`~skfem_mpm.kernels.graph.gather_runs`: the same arrays; at
    5.3e5 kept entries the gather 1.0-1.7 ms against the numpy path's
    2.9-4.9 and 2.1-2.8 for positions kept whole, the build 2.1-4.4
    against 12-21).

    Parameters
    ----------
    K
        A canonical CSR matrix (sorted indices, no duplicates): the
        pattern.
    free
        The free DOFs (rows and columns kept).
    kernels
        ``"auto"``, ``"numpy"`` or ``"compiled"``
        (:func:`~skfem_mpm.quadrature.basis.compiled_kernels`).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.sparse import random
    >>> from skfem_mpm.solve.linear import Condensation
    >>> K = random(6, 6, density=.5, format="csr", random_state=0)
    >>> free = np.array([0, 2, 3, 5])
    >>> condensed = Condensation(K, free)
    >>> K.data *= 2.                       # a new iteration, same pattern
    >>> bool((condensed(K) != K[free][:, free]).nnz == 0)
    True

    """

    def __init__(self, K: csr_matrix, free: ndarray,
                 kernels: str = "auto"):
        if not (isinstance(K, csr_matrix) and K.has_canonical_format):
            raise InvalidInputError("a Condensation needs a canonical CSR "
                                    "matrix (sorted indices, no duplicates)")
        self.free = free
        self.indices, self.indptr = K.indices, K.indptr
        # the entries in free rows and columns, without scipy's two fancy
        # indexings of K (0.3 ms at 56 points), a matrix of entry numbers
        # or a mask of all entries (each the peak of a 3D run's heap in
        # turn): for sorted free DOFs in K's order, canonical as it is (the
        # free DOFs are renumbered in their order); else sorted by row and
        # column as renumbered
        index = np.int32 if K.nnz < 2 ** 31 - 1 else np.int64
        position = np.full(K.shape[0], -1, dtype=index)
        position[free] = np.arange(free.size, dtype=index)
        #: the compiled kernels of the map's build and gather
        #: (:func:`~skfem_mpm.kernels.graph.condensation_runs`,
        #: :func:`~skfem_mpm.kernels.graph.gather_runs`), or None
        self.graph = graph = compiled_kernels("graph", kernels)
        if graph is not None:                # the same arrays, one pass
            columns, bounds, shift = graph.condensation_runs(
                K.indptr, K.indices, position)
        else:
            columns, bounds, shift = self._runs_by_blocks(K, position)
        done = int(bounds[-1])
        #: the map as runs ``(bounds, shift)``: the kept entries ``bounds[r]
        #: <= i < bounds[r + 1]`` are ``K.data[i + shift[r]]``
        self.runs = (bounds, shift)
        indptr = np.zeros(free.size + 1, dtype=index)
        #: the kept entries in the tangent's order (the map ascending):
        #: they can be gathered within its data (:meth:`__call__`)
        self.ascending = bool(np.all(free[1:] > free[:-1]))
        if self.ascending:                    # the kept entries by row end
            indptr[1:] = self._kept_before(K.indptr[free + 1])
        else:
            take = self._sources(0, done)
            rows = position[np.searchsorted(K.indptr, take, side="right")
                            - 1]
            order = np.lexsort((columns, rows))
            take, columns = take[order], columns[order]
            np.cumsum(np.bincount(rows, minlength=free.size), out=indptr[1:])
            self.runs = runs_of(take, index)
        #: the map's positions where it has fewer than :data:`GATHER_BLOCK`
        #: entries, else None (expanded from :attr:`runs` a block at a time)
        self.take = self._sources(0, done) if done < GATHER_BLOCK else None
        self.block = (columns, indptr)
        self._matrices = PatternMatrices(csr_matrix)

    @staticmethod
    def _runs_by_blocks(K: csr_matrix, position: ndarray) -> tuple:
        """``(columns, bounds, shift)`` of the kept entries (those in rows
        and columns ``position`` numbers) in ``K``'s order, found for
        blocks of rows of about :data:`TAKE_BLOCK` entries in two passes
        (count, then fill): the numpy path of
        :func:`~skfem_mpm.kernels.graph.condensation_runs`."""
        index = position.dtype
        is_free = position >= 0
        indptr, nrows = K.indptr, K.shape[0]
        step = max(1, TAKE_BLOCK * nrows // max(K.nnz, 1))

        def kept(first):
            """The kept entries of the rows from ``first`` (a block)."""
            last = min(first + step, nrows)
            lo, hi = indptr[first], indptr[last]
            mask = np.repeat(is_free[first:last], np.diff(
                indptr[first:last + 1]))
            mask &= np.take(is_free, K.indices[lo:hi])
            return np.flatnonzero(mask) + lo

        blocks = range(0, nrows, step)
        columns = np.empty(sum(kept(first).size for first in blocks),
                           dtype=index)
        starts, shifts, done, after = [], [], 0, -1
        for first in blocks:                 # a second pass: no list of
            found = kept(first)              # blocks beside the columns
            if found.size == 0:
                continue
            stop = done + found.size
            np.take(position, np.take(K.indices, found),
                    out=columns[done:stop])
            # the runs of consecutive entries, one carried over the block
            begin = np.flatnonzero(found[1:] != found[:-1] + 1) + 1
            if found[0] != after:
                begin = np.r_[0, begin]
            starts.append(begin + done)
            shifts.append(found[begin] - begin - done)
            done, after = stop, found[-1] + 1
        bounds = np.empty(sum(map(len, starts)) + 1, dtype=index)
        bounds[-1] = done
        if starts:
            np.concatenate(starts, out=bounds[:-1], casting="unsafe")
        return columns, bounds, (np.concatenate(shifts).astype(index)
                                 if shifts else np.zeros(0, dtype=index))

    def _sources(self, start: int, stop: int) -> ndarray:
        """The positions in ``K.data`` of the kept entries ``start`` to
        ``stop`` (:attr:`runs` expanded), as ``np.intp``."""
        bounds, shift = self.runs
        first = np.searchsorted(bounds, start, side="right") - 1
        last = np.searchsorted(bounds, stop, side="left")
        sources = np.arange(start, stop)
        sources += np.repeat(shift[first:last], np.diff(np.clip(
            bounds[first:last + 1], start, stop)))
        return sources

    def _kept_before(self, ends: ndarray) -> ndarray:
        """How many kept entries lie before each position ``ends`` of
        ``K.data`` (the map ascending)."""
        bounds, shift = self.runs
        if shift.size == 0:
            return np.zeros(ends.shape, dtype=bounds.dtype)
        begins = bounds[:-1] + shift              # the runs in K.data
        run = np.maximum(np.searchsorted(begins, ends, side="right") - 1, 0)
        return bounds[run] + np.clip(ends - begins[run], 0, np.diff(
            bounds)[run])

    def fits(self, K, free: ndarray) -> bool:
        """Whether ``K`` has this pattern (canonical CSR) and ``free`` is
        these free DOFs: the same array, or equal (a later load step's
        DOFs where the active cells and supports are the step's before:
        the map serves it, and ``free`` becomes the array compared)."""
        fits = isinstance(K, csr_matrix) \
            and K.has_canonical_format \
            and K.shape[0] == self.indptr.size - 1 \
            and K.indices.shape == self.indices.shape \
            and (K.indptr is self.indptr
                 or np.array_equal(K.indptr, self.indptr)) \
            and (K.indices is self.indices
                 or np.array_equal(K.indices, self.indices))
        if not fits or free is self.free:
            return fits
        if free.dtype != self.free.dtype \
                or not np.array_equal(free, self.free):
            return False
        self.free = free
        return True

    def __call__(self, K: csr_matrix, consume: bool = False) -> csr_matrix:
        """The free-free block of ``K``; with ``consume`` (``K`` is not
        read again: its owner hands it over) gathered within ``K``'s data,
        which is then shortened to the block's entries and becomes the
        block's, where the kept entries are in ``K``'s order, ``K`` owns
        its data and the block has :data:`GATHER_BLOCK` entries or more
        (a smaller one is copied faster): no second array of entries
        while both are alive (248 bytes a point at the peak of a 3D run's
        heap), the same values."""
        n, take, size = self.free.size, self.take, int(self.runs[0][-1])
        if take is not None:                 # a small map: one indexing
            return self._matrices(K.data[take], *self.block, (n, n))
        data = whole_array(K.data) if consume and self.ascending else None
        bounds, shift, graph = *self.runs, self.graph
        if data is None:
            data = np.empty(size)
            if graph is not None:            # a copy a run, no positions
                graph.gather_runs(bounds, shift, K.data, data)
            else:
                for start in range(0, size, GATHER_BLOCK):
                    stop = min(start + GATHER_BLOCK, size)
                    np.take(K.data, self._sources(start, stop),
                            out=data[start:stop])
            return self._matrices(data, *self.block, (n, n))
        K.data = data               # scipy's view of it released
        # forward: the sources lie at or after the places they fill, so
        # no entry is read after it is written
        if graph is not None:
            graph.gather_runs(bounds, shift, data, data)
        else:
            for start in range(0, size, GATHER_BLOCK):
                stop = min(start + GATHER_BLOCK, size)
                data[start:stop] = np.take(data, self._sources(start, stop))
        data.resize(size, refcheck=False)  # K is not read again
        return self._matrices(data, *self.block, (n, n))


def runs_of(take: ndarray, index) -> tuple:
    """``(bounds, shift)`` of :attr:`Condensation.runs` for the positions
    ``take``, as ``index`` integers: its runs of consecutive positions.

    >>> import numpy as np
    >>> bounds, shift = runs_of(np.array([3, 4, 5, 9, 2]), np.int32)
    >>> bounds.tolist(), shift.tolist()
    ([0, 3, 4, 5], [3, 6, -2])
    """
    begin = np.flatnonzero(take[1:] != take[:-1] + 1) + 1
    if take.size:
        begin = np.r_[0, begin]
    return (np.r_[begin, take.size].astype(index),
            (take[begin] - begin).astype(index))


def whole_array(data: ndarray) -> Optional[ndarray]:
    """The array that owns the memory of the 1D array ``data``, where it is
    ``data`` or a view of all of it (scipy's sparse constructors view the
    data they are given) and may be resized; else None."""
    owner = data if data.base is None else data.base
    # a contiguous view of as many items of the owner's type starts where
    # the owner does
    if isinstance(owner, ndarray) and owner.base is None \
            and owner.flags.owndata and owner.flags.writeable \
            and owner.flags.c_contiguous and data.flags.c_contiguous \
            and owner.ndim == data.ndim == 1 \
            and owner.dtype == data.dtype and owner.size == data.size:
        return owner
    return None


def row_sums(A: csr_matrix, block: int = 1 << 16) -> ndarray:
    """The sums of the magnitudes of the rows of a CSR matrix, for rows of
    about ``block`` entries at a time (the magnitudes of all entries at
    once were the peak of a 3D run's heap, 260 bytes a point).

    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> A = csr_matrix(np.array([[1., -2.], [0., 0.], [-3., 4.]]))
    >>> row_sums(A, block=1).tolist()
    [3.0, 0.0, 7.0]
    """
    indptr = A.indptr
    if A.nnz <= block and A.shape[0] \
            and (indptr[1:] > indptr[:-1]).all():    # no empty row
        return np.add.reduceat(np.abs(A.data[:A.nnz]), indptr[:-1])
    sums = np.zeros(A.shape[0])
    # each block ends at a row boundary: a row's sum is reduced as a whole
    ends = [A.shape[0]] if A.nnz <= block else np.minimum(np.maximum(
        np.unique(np.searchsorted(indptr, np.arange(
            block, A.nnz + block, block), side="right") - 1), 1), A.shape[0])
    start = 0
    for end in ends:
        if end <= start:
            continue
        rows = start + np.flatnonzero(np.diff(indptr[start:end + 1]))
        if rows.size:                                 # reduceat: not empty
            first = indptr[rows[0]]
            sums[rows] = np.add.reduceat(
                np.abs(A.data[first:indptr[end]]), indptr[rows] - first)
        start = end
    return sums


def factorise_active(K: spmatrix, free: ndarray,
                     solver: Optional[Callable] = None, tol: float = 1e-10,
                     doflocs: Optional[ndarray] = None,
                     condensation: Optional[Condensation] = None
                     ) -> Callable:
    """``solve(f) -> u``: ``K u = f`` on the DOFs ``free`` (zero
    elsewhere) for any number of right-hand sides, ``K`` condensed and
    factorised once (by the back end's ``factorise`` where it has one:
    :func:`~skfem_mpm.solve.backends.factorised`).  Every solve is checked
    as :func:`solve_active` checks its one.  Arguments as there.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.sparse import diags
    >>> from skfem_mpm.solve.linear import factorise_active
    >>> K = diags([-1., 2., -1.], [-1, 0, 1], shape=(4, 4)).tocsr()
    >>> solve = factorise_active(K, np.array([1, 2]))
    >>> solve(np.array([0., 1., 1., 0.])).tolist()
    [0.0, 1.0, 1.0, 0.0]
    >>> solve(np.array([0., 3., 0., 0.])).tolist()
    [0.0, 2.0, 1.0, 0.0]
    """
    return factorise_condensed(condensed(K, free, condensation), free,
                               K.shape[0], solver, tol, doflocs)


def condensed(K: spmatrix, free: ndarray,
              condensation: Optional[Condensation] = None,
              consume: bool = False) -> csr_matrix:
    """``K[free][:, free]`` as canonical CSR: by ``condensation`` where it
    fits ``K`` and ``free`` (within ``K``'s data with ``consume``: ``K``
    is not read again, :meth:`Condensation.__call__`), else by
    scikit-fem's ``condense``.

    >>> import numpy as np
    >>> from scipy.sparse import diags
    >>> K = diags([-1., 2., -1.], [-1, 0, 1], shape=(4, 4)).tocsr()
    >>> condensed(K, np.array([1, 2])).toarray().tolist()
    [[2.0, -1.0], [-1.0, 2.0]]
    """
    if condensation is not None and condensation.fits(K, free):
        return condensation(K, consume)
    A = condense(K, np.zeros(K.shape[0]), I=free)[0].tocsr()
    A.sort_indices()      # a matrix of its own: canonical in place
    return A


def factorise_condensed(A: csr_matrix, free: ndarray, n: int,
                        solver: Optional[Callable] = None, tol: float = 1e-10,
                        doflocs: Optional[ndarray] = None) -> Callable:
    """:func:`factorise_active` of the condensed matrix ``A`` (the block
    of a matrix of size ``n`` on the DOFs ``free``, :func:`condensed`): a
    caller that has condensed need not keep the whole matrix alive while
    ``A`` is factorised.

    >>> import numpy as np
    >>> from scipy.sparse import diags
    >>> K = diags([-1., 2., -1.], [-1, 0, 1], shape=(4, 4)).tocsr()
    >>> free = np.array([1, 2])
    >>> solve = factorise_condensed(condensed(K, free), free, 4)
    >>> solve(np.array([0., 1., 1., 0.])).tolist()
    [0.0, 1.0, 1.0, 0.0]
    """
    solve = checked_solves(A, free, n, solver, tol, doflocs)
    return lambda f: solve(f[free])


def checked_solves(A: spmatrix, free: ndarray, n: int, solver, tol: float,
                   doflocs: Optional[ndarray]) -> Callable:
    """``solve(b, x=None) -> u`` of the condensed ``A`` (on the DOFs
    ``free`` of ``n``), factorised once; ``u`` is ``x`` (zero by default)
    elsewhere.  Each solve is refused where it underflows or its backward
    error exceeds ``tol``."""
    if free.size == 0:
        raise SingularSystemError("no free degree of freedom: every active "
                                  "grid DOF is supported")
    solver = get_solver(solver, 2 if doflocs is None else doflocs.shape[0])
    kwargs = {}
    if getattr(solver, "wants_modes", False) and doflocs is not None:
        dim = doflocs.shape[0]
        kwargs["modes"] = rigid_modes(doflocs[:, free // dim * dim],
                                      dim)[np.arange(free.size), free % dim]
    with singular_as_error(free.size):
        factorised = backends.factorised(solver, A, **kwargs)
    largest_row = []

    def solve(b: ndarray, x: Optional[ndarray] = None) -> ndarray:
        u = np.zeros(n) if x is None else x.copy()
        with singular_as_error(free.size):
            y = factorised(b)
        u[free] = y
        y = u[free] if x is not None else y       # as u holds it
        largest, loads = np.abs(y).max(), np.abs(b).max()
        if largest < TINY and loads > 0.:
            raise InvalidInputError(
                "the solution underflows (largest {:.1e} from forces up to "
                "{:.1e} and a stiffness up to {:.1e}): rescale the units "
                "(e.g. kN, MPa, mm)".format(largest, loads, abs(A).max()))
        # normwise backward error of the solve
        if not largest_row:
            largest_row.append(row_sums(A).max())
        r = np.abs(A @ y - b).max()
        scale = largest_row[0] * largest + loads
        error = r / max(scale, TINY)
        if not np.isfinite(u if x is not None else y).all() or error > tol:
            raise SingularSystemError(
                "the stiffness on {} free DOFs is singular: the solve's "
                "backward error is {:.2e}; the active grid probably has "
                "rigid-body modes (missing supports)".format(free.size,
                                                             error))
        return u
    return solve


@contextmanager
def singular_as_error(nfree: int):
    """scipy's rank warning and a factorisation's runtime error as a
    :class:`~skfem_mpm.errors.SingularSystemError`."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", MatrixRankWarning)
        try:
            yield
        except (MatrixRankWarning, RuntimeError) as err:
            raise SingularSystemError(
                "the stiffness on {} free DOFs is singular ({}): the active "
                "grid has rigid-body modes; add supports".format(
                    nfree, err)) from err


def solve_active(K: spmatrix, f: ndarray, free: ndarray,
                 solver: Optional[Callable] = None, tol: float = 1e-10,
                 x: Optional[ndarray] = None,
                 doflocs: Optional[ndarray] = None,
                 condensation: Optional[Condensation] = None) -> ndarray:
    """Solve ``K u = f`` on the DOFs ``free`` (zero elsewhere), condensed
    with scikit-fem's ``condense`` or by ``condensation``.

    ``solver`` is a scikit-fem solver ``f(A, b) -> x`` or a name for
    :func:`~skfem_mpm.solve.backends.get_solver`; default ``"auto"``.
    ``x`` holds prescribed values on the DOFs that are not free (zero by
    default).  ``doflocs`` (dim, N) gives solvers that want them
    (algebraic multigrid) the rigid-body modes of the free DOFs.
    ``condensation``, a :class:`Condensation` of ``K``'s pattern and
    ``free``, gathers the condensed matrix without indexing ``K`` (used
    when it fits and ``x`` is not given).

    Raises
    ------
    SingularSystemError
        When the condensed system is empty, singular (rigid-body modes:
        missing supports) or its solution does not satisfy it to ``tol``.

    """
    if x is None:
        return factorise_active(K, free, solver, tol, doflocs,
                                condensation)(f)
    A, b, x, _ = condense(K, f, x=x, I=free)
    return checked_solves(A, free, K.shape[0], solver, tol, doflocs)(b, x)
