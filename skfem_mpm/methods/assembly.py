"""A vectorised fast path for the forms the solvers assemble on a
material-point basis, tested to equal scikit-fem's ``asm`` to round-off.

Element matrices are summed over each element's points in the basis's
padded (element, slot) layout, and scattered into a CSR matrix through the
sparsity pattern of the whole grid, computed once per run (a search of the
element node pairs in the node graph) and shared by every load step and
Newton iteration: each assembly is then one ``np.add.at`` per block of
elements, linear in the number of points.  The
matrix carries explicit zeros on inactive DOFs, which condensing onto the
free DOFs drops.

"""
from typing import NamedTuple, Optional

import numpy as np
from numpy import ndarray
from scipy.sparse import csc_matrix, csr_matrix

__all__ = ["assembled_in_pattern", "ElementPattern", "GraphPattern",
           "KernelLayout", "PatternMatrices", "block_structure",
           "phased_chunks",
           "local_stiffness", "local_force", "local_load"]

CHUNK = 512             # elements per block (bounds the temporaries)
#: the attributes of the matrices scipy's checked constructor makes from
#: ``(data, indices, indptr)`` (scipy 1.11 to 1.17), which
#: :func:`compressed_matrix` sets itself
COMPRESSED_ATTRIBUTES = frozenset(("_shape", "maxprint", "data", "indices",
                                   "indptr"))
INT32_MAX = np.iinfo(np.int32).max
_LAYOUTS = {}       # cls -> the maxprint of its matrices, or None: another
#                     layout


def _viewed(x: ndarray) -> ndarray:
    """What scipy's constructor keeps of an array it is given: a view of
    all of it, copied where it views less than half its base
    (``prune``); an array numba made (its base is numba's memory record,
    not an array) is all of its memory."""
    if isinstance(x.base, ndarray) and x.size < x.base.size // 2:
        return x.copy()
    return x.view()


def compressed_matrix(cls, data: ndarray, indices: ndarray,
                      indptr: ndarray, shape: tuple):
    """``cls((data, indices, indptr), shape=shape)`` (``csr_matrix``,
    ``csc_matrix``), the same matrix, without scipy's constructor where
    the arrays are what it would keep (float64 entries, int32 indices of
    a shape whose sizes fit in int32; scipy's matrix classes, not its
    array classes): its checks, those that take no
    pass over the arrays (lengths, ``indptr[0] == 0``, the entries
    ``indptr[-1]``), made here, in a sixth of its time (a Newton
    iteration makes its first tangent, condensed tangent and CSC matrix
    of a pattern so, 12-16 us each at 56 points).  Other arrays, or
    scipy's matrices holding other attributes than
    :data:`COMPRESSED_ATTRIBUTES`, go to scipy's constructor.

    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> A = compressed_matrix(csr_matrix, np.array([1., 2., 3.]),
    ...                       np.array([0, 1, 1], dtype=np.int32),
    ...                       np.array([0, 2, 3], dtype=np.int32), (2, 2))
    >>> A.toarray().tolist(), A.indices.dtype.name
    ([[1.0, 2.0], [0.0, 3.0]], 'int32')
    """
    if cls not in _LAYOUTS:         # once for each class: scipy's layout
        M = None if cls not in (csr_matrix, csc_matrix) else cls((
            np.zeros(1), np.zeros(1, dtype=np.int32),
            np.array([0, 1], dtype=np.int32)), shape=(1, 1))
        _LAYOUTS[cls] = M.maxprint if M is not None and set(
            M.__dict__) == COMPRESSED_ATTRIBUTES else None
    maxprint = _LAYOUTS[cls]
    shape = (int(shape[0]), int(shape[1]))
    major = shape[0] if cls is csr_matrix else shape[1]
    if not (maxprint is not None and type(data) is ndarray
            and type(indices) is ndarray and type(indptr) is ndarray
            and data.dtype == np.float64
            and indices.dtype == indptr.dtype == np.int32
            and data.ndim == indices.ndim == indptr.ndim == 1
            and 0 < shape[0] <= INT32_MAX and 0 < shape[1] <= INT32_MAX
            and len(indptr) == major + 1 and indptr[0] == 0
            and len(indices) == len(data) == indptr[-1]):
        return cls((data, indices, indptr), shape=shape)
    M = cls.__new__(cls)
    M.__dict__.update(_shape=shape, maxprint=maxprint,
                      indices=_viewed(indices), indptr=indptr.view(),
                      data=_viewed(data))
    return M


class PatternMatrices:
    """``make(data, indices, indptr, shape)``: the compressed sparse
    matrix of class ``cls`` (``csr_matrix``, ``csc_matrix``),
    :func:`compressed_matrix` for the first index arrays given, and for
    the next matrices on the same arrays (the same objects: a load step's
    Newton iterations) a copy of its attributes with the new entries:
    scipy checks the arrays' shapes and types at every construction (16
    us, three or four matrices a Newton iteration, 4% of one at 1e3 points
    in 2D).
    Whether the pattern is canonical (sorted, no duplicates) is found for
    the first and carried by the next (scipy checks each new matrix when
    asked: 0.46 ms at 1e5 points in 2D, 2.4 ms at 1.1e5 in 3D).  The kept
    attributes hold no entries.

    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> make = PatternMatrices(csr_matrix)
    >>> indices, indptr = np.array([0, 1, 1]), np.array([0, 2, 3])
    >>> A = make(np.array([1., 2., 3.]), indices, indptr, (2, 2))
    >>> B = make(np.array([4., 5., 6.]), indices, indptr, (2, 2))
    >>> B.toarray().tolist(), B.has_canonical_format
    ([[4.0, 5.0], [0.0, 6.0]], True)
    """

    def __init__(self, cls):
        self.cls = cls
        self._key = self._attributes = None

    def __call__(self, data: ndarray, indices: ndarray, indptr: ndarray,
                 shape: tuple):
        key = self._key
        if key is not None and key[0] is indices and key[1] is indptr \
                and key[2] == shape and data.dtype == np.float64 \
                and data.shape == (len(self._attributes["indices"]),):
            M = self.cls.__new__(self.cls)
            M.__dict__.update(self._attributes)
            M.data = data
            return M
        M = compressed_matrix(self.cls, data, indices, indptr, shape)
        M.has_canonical_format          # found once, kept for the next
        self._key = (indices, indptr, tuple(shape))
        self._attributes = {name: value for name, value in
                            M.__dict__.items() if name != "data"}
        return M


class ElementPattern:
    """CSR pattern of all elements' DOFs (nloc, nelems) in an N x N matrix.

    Where the element DOFs come in blocks of three consecutive global DOFs
    (the components of a node of a 3D vector grid), the scatter map is kept
    per node pair, nine times smaller than one per entry (64 instead of 576
    integers a hexahedron, 256 bytes a point less at 2x2x2 points a cell):
    the CSR row of DOF ``3 i + a`` is then three times the row of node
    ``i`` in the node graph, so the place of entry ``(3 i + a, 3 j + c)``
    is ``first[e, I, J] + a * length[e, I] + c``.  Forming those places
    costs 2% of a 3D Newton iteration; in 2D, where the map per entry takes
    64 bytes a point, it is kept per entry (the faster gather).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm.methods.assembly import ElementPattern
    >>> pattern = ElementPattern(np.array([[0, 1], [1, 2]]), 3)
    >>> local = np.ones((1, 2, 2))
    >>> pattern.matrix([(np.array([1]), local)]).toarray().tolist()
    [[0.0, 0.0, 0.0], [0.0, 1.0, 1.0], [0.0, 1.0, 1.0]]

    """

    def __init__(self, element_dofs: ndarray, N: int, copies: int = 1):
        self.element_dofs, self.N, self.copies = element_dofs, N, copies
        self._structure = None
        self._matrices = PatternMatrices(csr_matrix)

    def block_size(self) -> int:
        """The ``b`` of the map: 3 where the DOFs come in blocks of three,
        1 otherwise (a map per entry)."""
        dofs, N, b = self.element_dofs, self.N, 3
        if dofs.shape[0] % b or N % b:
            return 1
        blocks = dofs.reshape(dofs.shape[0] // b, b, dofs.shape[1])
        return b if np.all(blocks[:, 0] % b == 0) and np.array_equal(
            blocks, blocks[:, :1] + np.arange(b)[:, None]) else 1

    def structure(self):
        """``(first, length, expand, indices, indptr)``, computed on first
        use (a run that never assembles on the element pattern, GIMP, skips
        it): ``first[e, I, J]`` the CSR place of the entry of the first
        components of element e's nodes (DOFs where the map is per entry)
        I and J, ``length[e, I]`` the length of node I's rows, ``expand``
        the node pair, row node and components of each entry of an element
        matrix (None where the map is per entry)."""
        if self._structure is None and self.copies > 1:
            self._structure = self.tiled()
        if self._structure is None:         # one grid, or not copies
            b = self.block_size()
            nodes = self.element_dofs[::b] // b            # (nnodes, e)
            nnl, nel = nodes.shape
            n = self.N // b
            incidence = csr_matrix((np.ones(nodes.size), nodes.T.ravel(),
                                    np.arange(0, nodes.size + 1, nnl)),
                                   shape=(nel, n))
            graph = (incidence.T @ incidence).tocsr()
            graph.sort_indices()
            del incidence
            indices, indptr = block_structure(graph, b)
            counts = np.diff(graph.indptr).astype(np.int64)
            starts = b * b * graph.indptr[:-1].astype(np.int64)
            index = indices.dtype
            # (row, column) keys of the node graph, ascending
            keys = np.repeat(np.arange(n, dtype=np.int64) * n,
                             counts) + graph.indices
            first = np.empty((nel, nnl * nnl), dtype=index)
            for s in range(0, nel, CHUNK):
                d = nodes[:, s:s + CHUNK].T.astype(np.int64)    # (k, nnl)
                # searched among the keys of the block's rows only (those
                # of neighbouring elements lie close): at 1e6 points in 2D
                # the search among all keys took 2.8 s a run
                lo, hi = graph.indptr[d.min()], graph.indptr[d.max() + 1]
                place = lo + np.searchsorted(keys[lo:hi], (
                    d[:, :, None] * n + d[:, None, :]).reshape(len(d), -1))
                row = np.repeat(d, nnl, axis=1)
                first[s:s + CHUNK] = starts[row] + b * (
                    place - graph.indptr[row])
            length = (b * counts[nodes.T]).astype(index)
            # entry (I a, J c) of an element matrix, flat: its node pair,
            # its row node, a, c
            entry = np.indices((nnl, b, nnl, b), dtype=index).reshape(4, -1)
            expand = (entry[0] * nnl + entry[2], entry[0], entry[1],
                      entry[3]) if b > 1 else None
            self._structure = (first, length, expand, indices, indptr)
        return self._structure

    def tiled(self) -> tuple:
        """:meth:`structure` of a pattern of ``copies`` copies of one
        (the grid fields of contact between bodies: copy ``k``'s elements
        ``k nel ...`` on DOFs ``k N / copies ...``) from that of the first:
        the CSR matrix is block diagonal, each block the first's, so its
        places shift by the first's entries a copy.  At 1e5 points in 2D,
        two copies: 0.08-0.1 s (the first's pattern, then its tiles) where
        the pattern of both took 0.18-0.2 s.  ``None``
        where the element DOFs are not such copies (then the pattern is
        found from them all).

        >>> import numpy as np
        >>> one = np.array([[0, 1], [1, 2]])
        >>> two = ElementPattern(np.hstack([one, one + 3]), 6, copies=2)
        >>> whole = ElementPattern(two.element_dofs, 6)
        >>> all(np.array_equal(a, b) for a, b in zip(
        ...     two.structure()[:2] + two.structure()[3:],
        ...     whole.structure()[:2] + whole.structure()[3:]))
        True
        """
        k, nel = self.copies, self.element_dofs.shape[1] // self.copies
        N = self.N // k
        first_dofs = self.element_dofs[:, :nel]
        if self.N % k or self.element_dofs.shape[1] % k or \
                not np.array_equal(self.element_dofs.reshape(
                    -1, k, nel) - first_dofs[:, None, :],
                    np.broadcast_to(N * np.arange(k)[None, :, None],
                                    (len(first_dofs), k, nel))):
            return None
        first, length, expand, indices, indptr = ElementPattern(
            first_dofs, N).structure()
        nnz = len(indices)
        index = np.int32 if k * nnz < 2 ** 31 else np.int64
        shift = np.arange(k, dtype=index)
        # the copies' places summed into the tiles (no cast copy of the
        # first's: 6.6 MB less at 1e5 points in 2D)
        tiles = np.empty((k,) + first.shape, dtype=index)
        np.add(first, (shift * nnz)[:, None, None], out=tiles, dtype=index)
        first = tiles.reshape(-1, first.shape[1])
        indices = (indices[None].astype(index) + (shift * N)[:, None]
                   ).ravel()
        indptr = np.concatenate([(indptr[:-1][None].astype(index) + (
            shift * nnz)[:, None]).ravel(), [k * nnz]]).astype(index)
        return (first, np.tile(length.astype(index), (k, 1)), expand,
                indices, indptr)

    def matrix(self, blocks) -> csr_matrix:
        """Assemble element matrices given in blocks ``(elements, local)``,
        local (len(elements), nloc, nloc): each block is added in place, so
        only one block of element matrices exists at a time."""
        first, length, expand, indices = self.structure()[:4]
        data = np.zeros(len(indices))
        for elements, local in blocks:
            if expand is None:                                # per entry
                place = first[elements]
            else:
                pair, row, a, c = expand
                place = np.take(first[elements], pair, axis=1)
                place += np.take(length[elements], row, axis=1) * a
                place += c
            np.add.at(data, place.ravel(), local.ravel())
        return self.csr(data)

    def csr(self, data: ndarray) -> csr_matrix:
        """The matrix of the pattern with entries ``data`` (in the
        pattern's CSR order)."""
        return pattern_matrix(self, data, *self.structure()[3:])

    @property
    def nnz(self) -> int:
        """The number of entries of the pattern."""
        return len(self.structure()[3])


def assembled_in_pattern(form, basis, **fields) -> csr_matrix:
    """The bilinear ``form`` on ``basis`` as scikit-fem's ``asm``, with
    every element entry kept: ``asm`` drops the entries that come out
    exactly zero, and which ones do depends on the CPU's vector loops,
    so the pattern, and the solver ``"auto"`` chooses from it
    (:func:`~skfem_mpm.solve.backends.rcm_bandwidth`), would too.

    Examples
    --------
    >>> from skfem import Basis, BilinearForm, ElementQuad1, MeshQuad, asm
    >>> basis = Basis(MeshQuad().refined(2), ElementQuad1())  # 5 x 5 nodes
    >>> nothing = BilinearForm(lambda u, v, w: 0. * u * v)
    >>> asm(nothing, basis).nnz, assembled_in_pattern(nothing, basis).nnz
    (0, 169)
    """
    coo = form.coo_data(basis, **fields)
    return csr_matrix((coo.data, (coo.indices[0], coo.indices[1])),
                      shape=coo.shape)


def pattern_matrix(pattern, data: ndarray, indices: ndarray,
                   indptr: ndarray) -> csr_matrix:
    """The N x N CSR matrix of ``pattern`` (its ``indices``, ``indptr``)
    with entries ``data``, whether its structure is canonical (sorted, no
    duplicates) found for the first and carried by the next: scipy checks
    each new matrix when asked (the condensation asks at every Newton
    iteration), 0.46 ms at 1e5 points in 2D, 2.4 ms at 1.1e5 in 3D."""
    return pattern._matrices(data, indices, indptr, (pattern.N, pattern.N))


def block_structure(graph: csr_matrix, b: int):
    """``(indices, indptr)`` of the CSR matrix of ``b`` x ``b`` blocks on
    the node graph ``graph`` (sorted indices): row ``b i + a`` holds the
    columns ``b j .. b j + b - 1`` of every ``j`` of node row ``i``, so
    the entry ``(b i + a, b j + c)`` is at ``b^2 graph.indptr[i] + a b
    count_i + b (position of j in row i) + c``.

    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> graph = csr_matrix(np.array([[1., 1.], [1., 0.]]))
    >>> [a.tolist() for a in block_structure(graph, 2)]
    [[0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 0, 1], [0, 4, 8, 10, 12]]
    """
    n = graph.shape[0]
    nnz = graph.nnz * b * b
    index = np.int32 if nnz < 2 ** 31 else np.int64
    counts = np.diff(graph.indptr).astype(np.int64)
    # DOF rows b i .. b i + b - 1 repeat node row i, each of its columns j
    # expanded to b j .. b j + b - 1
    starts = b * b * graph.indptr[:-1].astype(np.int64)
    indptr = np.empty(b * n + 1, dtype=index)
    indptr[:-1] = (starts[:, None] + np.arange(b) * b
                   * counts[:, None]).ravel()
    indptr[-1] = nnz
    columns = (b * graph.indices[:, None].astype(index)
               + np.arange(b, dtype=index)).ravel()
    indices = np.empty(nnz, dtype=index)
    for i in range(b):                    # DOF rows of component i: alike
        mask = np.repeat(np.arange(b * n) % b == i, b * np.repeat(counts, b))
        indices[mask] = columns
    return indices, indptr


class GraphPattern:
    """CSR pattern of a field of ``b`` components a node on a node graph
    (:func:`block_structure`): the pattern of the stiffness of a sparse
    point operator, whose points couple the nodes of their supports.

    Parameters
    ----------
    graph
        The node graph (csr, sorted indices).
    b
        Components a node.

    """

    def __init__(self, graph: csr_matrix, b: int):
        self.graph, self.N = graph, b * graph.shape[0]
        self.indices, self.indptr = block_structure(graph, b)
        self._matrices = PatternMatrices(csr_matrix)

    @property
    def nnz(self) -> int:
        """The number of entries of the pattern."""
        return len(self.indices)

    def csr(self, data: ndarray) -> csr_matrix:
        """The matrix of the pattern with entries ``data`` (in the
        pattern's CSR order)."""
        return pattern_matrix(self, data, self.indices, self.indptr)


class KernelLayout(NamedTuple):
    """What the compiled passes (:mod:`skfem_mpm.kernels.passes`) read of
    a point operator, formed once per operator.

    ``groups``: ``(G, nodes, node_start, node_count, runs, order,
    qstart)``, the shape gradients points first (entries, dim; a point's
    from its first entry ``qstart``), the groups of points of one support
    (an element's points, or a run of points of one row of a sparse
    operator: ``node_count[r]`` nodes from ``nodes[node_start[r]]``, the
    points ``order[runs[r]:runs[r + 1]]``); ``places``: ``(mode,
    elements, first, length, graph_indptr, graph_indices)``, how the
    stiffness pass finds the places of a group's entries in the CSR data
    of ``pattern`` (``nnz``, ``csr(data)``): the element pattern's map of
    the grid element ``elements[r]`` (:data:`~skfem_mpm.kernels.
    PER_ENTRY`, :data:`~skfem_mpm.kernels.PER_NODE_PAIR`), or bisection
    of the node graph's rows (:data:`~skfem_mpm.kernels.BISECTION`);
    ``chunks``: the bounds of the groups' chunks that the passes run on
    the machine's cores (:func:`phased_chunks`), or ``None`` (serial)."""
    groups: tuple
    places: tuple
    pattern: object
    chunks: Optional[ndarray] = None


#: the fewest points a chunk takes (an operator of fewer than three times
#: as many runs its passes serial: threads would cost more than they
#: save; the point-by-point passes' chunks too)
CHUNK_POINTS = 8192
#: the most chunks (the even ones, 8, side by side: 8 cores at the most)
MOST_CHUNKS = 16


def phased_chunks(nodes: ndarray, node_start: ndarray, node_count: ndarray,
                  runs: ndarray) -> Optional[ndarray]:
    """The bounds of three chunks or more of consecutive groups (group
    ``r``: ``node_count[r]`` nodes from ``nodes[node_start[r]]``, its
    points from ``runs[r]`` to ``runs[r + 1]``) of about equal points,
    such that no node is in two chunks but neighbouring ones: the even
    chunks may then run side by side, and the odd ones after them
    (:mod:`skfem_mpm.kernels.parallel`; two chunks would run one after
    the other).  As many chunks as :data:`CHUNK_POINTS` and
    :data:`MOST_CHUNKS` allow, halved until the nodes keep them apart;
    ``None`` where fewer than three do (a small operator, or groups in an
    order that spreads a node over chunks).

    >>> nodes = np.array([0, 1, 1, 2, 2, 3, 3, 4])
    >>> start, count = np.arange(0, 8, 2), np.full(4, 2)
    >>> phased_chunks(nodes, start, count, np.arange(0, 40001, 10000))
    array([0, 1, 2, 3, 4])
    >>> phased_chunks(nodes, start, count, np.arange(0, 4001, 1000))
    >>> ring = np.array([0, 1, 1, 2, 2, 3, 3, 0])     # node 0: chunks 0, 3
    >>> phased_chunks(ring, start, count, np.arange(0, 40001, 10000))
    """
    points, groups = int(runs[-1]), len(node_count)
    count = min(MOST_CHUNKS, points // CHUNK_POINTS, groups)
    if count < 3 or not node_count.any():
        return None
    # each node's first and last group: a node in chunks i and j of
    # different parity that are not neighbours (|i - j| > 1) forbids
    # running them side by side
    group = np.repeat(np.arange(groups), node_count)
    start = np.repeat(node_start - np.cumsum(node_count) + node_count,
                      node_count)
    touched = nodes[start + np.arange(group.size)]
    first = np.full(touched.max() + 1, groups)
    last = np.full(touched.max() + 1, -1)
    np.minimum.at(first, touched, group)
    np.maximum.at(last, touched, group)
    used = last >= 0
    first, last = first[used], last[used]
    while count >= 3:
        bounds = np.searchsorted(runs, np.linspace(0., points, count + 1))
        bounds[0], bounds[-1] = 0, groups
        if np.all(np.diff(bounds) > 0):
            spread = np.searchsorted(bounds, last, side="right") \
                - np.searchsorted(bounds, first, side="right")
            if spread.max() <= 1:
                return bounds.astype(np.int64)
        count //= 2
    return None


def local_stiffness(G: ndarray, A: ndarray, w: ndarray, slots: ndarray):
    """Element matrices ``K_(ia)(jc) = sum_slots w A_abcd G_bi G_dj``, block
    by block of elements.

    ``G`` (dim, nloc, nelems, nslots) holds the shape gradients in the
    padded layout of a material-point basis, ``A`` (dim, dim, dim, dim, n)
    and ``w`` (n,) the tangent and weight of every point, in point order
    (A may be one tensor broadcast to all points, or a function of point
    indices ``idx`` returning their tangents (dim, dim, dim, dim,
    len(idx)), called once a block: no tangent of all points is then in
    memory), and ``slots`` (nelems, nslots) the point in every slot (-1 in
    padding).
    Yields ``(block, local)``: a slice of the elements and their matrices
    (len, nloc, nloc) in interleaved vector order (node-major); the tangent
    is gathered into the layout one block at a time, so no padded or
    weighted copy of it exists.

    """
    dim, nodes, nel = G.shape[0], G.shape[1], G.shape[2]
    formed = callable(A)                  # formed for each block's points
    uniform = not formed and A.strides[-1] == 0   # one tensor for all
    for s in range(0, nel, CHUNK):
        e = slice(s, s + CHUNK)
        we = np.where(slots[e] < 0, 0., np.take(w, slots[e]))
        if formed:
            Ae = tangent_in_slots(A, slots[e], dim) * we
        else:
            Ae = (A[..., :1, None] if uniform
                  else np.take(A, slots[e], axis=-1)) * we  # (..., k, slots)
        Ge = G[:, :, e]
        # AG_abcj = sum_d A_abcd G_dj, per element and slot
        AG = Ae[:, :, :, 0, None] * Ge[0][None, None, None]
        for d in range(1, dim):
            AG += Ae[:, :, :, d, None] * Ge[d][None, None, None]
        # K_i(ajc) = sum_(b, slot) G_bi AG_abcj: one small matmul an element
        k = Ge.shape[2]
        left = Ge.transpose(2, 1, 0, 3).reshape(k, nodes, -1)
        right = AG.transpose(4, 1, 5, 0, 3, 2).reshape(k, left.shape[2], -1)
        yield e, np.matmul(left, right).reshape(k, nodes * dim, nodes * dim)


def tangent_in_slots(tangent_of, slots: ndarray, dim: int) -> ndarray:
    """The tangents (dim, dim, dim, dim, *slots.shape) of the points in
    ``slots`` from ``tangent_of(idx)``, zero in padding slots (-1)."""
    real = slots >= 0
    if real.all():
        return tangent_of(slots.ravel()).reshape((dim,) * 4 + slots.shape)
    out = np.zeros((dim,) * 4 + slots.shape)
    out[..., real] = tangent_of(slots[real])
    return out


def local_force(G: ndarray, P: ndarray) -> ndarray:
    """Element vectors ``f_(ia) = sum_slots P_ab G_bi`` with the weights
    folded into P (dim, dim, nelems, slots); returns (nloc, nelems)."""
    dim, nodes = G.shape[0], G.shape[1]
    f = np.einsum("abem,biem->iae", P, G)
    return f.reshape(nodes * dim, -1)


def local_load(N: ndarray, f: ndarray) -> ndarray:
    """Element vectors ``f_(ia) = sum_slots N_i f_a`` of point forces
    (dim, nelems, slots); returns (nloc, nelems)."""
    out = np.einsum("iem,aem->iae", N, f)
    return out.reshape(-1, N.shape[1])
