"""Compiled connected components of a node graph (the supports' check,
:func:`skfem_mpm.solve.linear.check_rigid_body_modes`): scipy's labels
(``connected_components(graph, directed=False)``) without its graph's
validation, conversion and transpose (70-80 us a check at 56 to 1024
points in 2D), and the parts clearly held in one pass (:func:`clearly_held`:
95 -> 15 us a check at 56 points); a matrix's largest difference from
its transpose without mirror positions (:func:`symmetric_deviation`, for
:func:`skfem_mpm.solve.backends.is_symmetric`) and its upper triangle's
entries (:func:`upper_entries`); a condensation's map as runs of
consecutive entries (:func:`condensation_runs`) and the gather over them
(:func:`gather_runs`, for :class:`skfem_mpm.solve.linear.Condensation`)."""
import numpy as np
from numba import njit

__all__ = ["component_labels", "element_labels", "clearly_held",
           "symmetric_deviation", "upper_entries", "condensation_runs",
           "gather_runs"]


@njit(cache=True)
def _root(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]            # path halving
        a = parent[a]
    return a


@njit(cache=True)
def _join(parent, i, j):
    """The components of nodes ``i`` and ``j`` joined under the smaller
    root."""
    a, b = _root(parent, i), _root(parent, j)
    if a < b:
        parent[b] = a
    elif b < a:
        parent[a] = b


@njit(cache=True)
def _numbered(parent, n):
    """``(count, labels)``: the components by their smallest node."""
    labels = np.empty(n, dtype=np.int32)
    count = 0
    for i in range(n):
        r = _root(parent, i)
        if r == i:
            labels[i] = count
            count += 1
        else:
            labels[i] = labels[r]
    return count, labels


@njit(cache=True)
def element_labels(n, nodes):
    """:func:`component_labels` of the chain graph of the elements' nodes
    ``nodes`` (nloc, nelems) on ``n`` nodes (each element's consecutive
    nodes joined, :func:`~skfem_mpm.graph.element_adjacency`), without
    forming the graph (57 us a supports' check at 56 points in 2D)."""
    parent = np.arange(n)
    for e in range(nodes.shape[1]):
        for i in range(nodes.shape[0] - 1):
            _join(parent, nodes[i, e], nodes[i + 1, e])
    return _numbered(parent, n)


@njit(cache=True)
def component_labels(n, indptr, indices):
    """``(count, labels)`` of the undirected graph of the CSR arrays
    ``indptr``, ``indices`` on ``n`` nodes (every stored entry an edge):
    the components numbered as scipy numbers them, by their smallest
    node, labels int32."""
    parent = np.arange(n)
    for i in range(n):
        for k in range(indptr[i], indptr[i + 1]):
            _join(parent, i, indices[k])
    return _numbered(parent, n)


@njit(cache=True)
def clearly_held(label, active, D, doflocs, dim, margin):
    """Whether each part of the active grid (the components ``label``
    (n,) holds at the nodes of the active vector DOFs ``active``) is held
    against its rigid-body modes with a clear margin by the vector DOFs
    ``D`` on its nodes: as many as the modes, and the Gram matrix of their
    rows of the modes (:func:`~skfem_mpm.solve.linear.held_modes`, nodes
    at ``doflocs`` (dim, n)) with its least eigenvalue at least ``margin``
    times its largest.  ``False`` where a part is held by too few DOFs or
    not clearly: the numpy path's test decides, and names what is not
    held."""
    n = label.size
    is_node = np.zeros(n, dtype=np.bool_)
    for k in range(active.size):
        is_node[active[k] // dim] = True
    part = np.full(n, -1, dtype=np.int64)         # by label
    nparts = 0
    for i in range(n):
        if is_node[i] and part[label[i]] < 0:
            part[label[i]] = nparts
            nparts += 1
    nrot = 0 if dim == 1 else 1 if dim == 2 else 3
    m = dim + nrot
    count = np.zeros(nparts, dtype=np.int64)
    centre = np.zeros((nparts, dim))
    for k in range(D.size):
        node = D[k] // dim
        if is_node[node]:
            c = part[label[node]]
            count[c] += 1
            for d in range(dim):
                centre[c, d] += doflocs[d, node]
    scale = np.zeros(nparts)
    for c in range(nparts):
        if count[c] < m:
            return False
        centre[c] /= count[c]
    for k in range(D.size):
        node = D[k] // dim
        if is_node[node]:
            c = part[label[node]]
            for d in range(dim):
                scale[c] = max(scale[c], abs(doflocs[d, node] - centre[c, d]))
    gram = np.zeros((nparts, m, m))
    row = np.empty(m)
    rel = np.empty(dim)
    for k in range(D.size):
        node, a = D[k] // dim, D[k] % dim
        if is_node[node]:
            c = part[label[node]]
            for d in range(dim):    # (all at one node: no rotation)
                rel[d] = (doflocs[d, node] - centre[c, d]) / scale[c] \
                    if scale[c] > 0. else 0.
            row[:] = 0.
            row[a] = 1.
            for j in range(nrot):       # about (j, j + 1), as held_modes
                p, q = j, (j + 1) % 3
                if a == p:
                    row[dim + j] = -rel[q]
                elif a == q:
                    row[dim + j] = rel[p]
            for i in range(m):
                for j in range(m):
                    gram[c, i, j] += row[i] * row[j]
    for c in range(nparts):
        if not _conditioned(gram[c], margin):
            return False
    return True


@njit(cache=True)
def _conditioned(G, margin):
    """Whether the least eigenvalue of the symmetric ``G`` is certainly
    at least ``margin`` times its largest: ``G`` positive definite (its
    Cholesky factor ``L`` formed) and ``trace(G) trace(G^-1)`` (``G^-1``'s
    trace the squares of ``L^-1``'s entries), which bounds the ratio's
    inverse from above, at most ``1 / margin`` (no LAPACK call)."""
    m = G.shape[0]
    L = np.zeros((m, m))
    for j in range(m):
        s = G[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.:
            return False
        L[j, j] = np.sqrt(s)
        for i in range(j + 1, m):
            t = G[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / L[j, j]
    inverse, trace = 0., 0.
    x = np.empty(m)
    for c in range(m):          # column c of L^-1 by forward substitution
        for i in range(m):
            t = 1. if i == c else 0.
            for k in range(i):
                t -= L[i, k] * x[k]
            x[i] = t / L[i, i]
            inverse += x[i] * x[i]
        trace += G[c, c]
    return trace * inverse * margin <= 1.


@njit(cache=True)
def symmetric_deviation(indptr, indices, data):
    """``(status, largest)`` of a canonical square CSR matrix (sorted
    indices, no duplicates): ``largest = max |a_ij - a_ji|`` over its
    entries (status 0); status 1 where the pattern is not symmetric, 2
    where a difference is not a number (then ``largest`` means nothing:
    the caller's numpy comparison decides).  The rows in order, the
    mirror of row i's entry (i, j), j > i, is the next entry of row j not
    yet matched (``place[j]``), which must be in column i, and every
    entry below the diagonal of row i must be matched when row i comes:
    no search.  The largest of the same differences that
    :func:`~skfem_mpm.solve.backends.is_symmetric`'s numpy path forms
    (``|a - b| = |b - a|`` exactly), without its mirror positions (4
    bytes an entry, kept for patterns up to 2^20 entries)."""
    n = indptr.size - 1
    place = np.empty(n, dtype=np.int64)
    for i in range(n):
        place[i] = indptr[i]
    largest = 0.
    for i in range(n):
        for e in range(indptr[i], indptr[i + 1]):
            j = indices[e]
            if j < i:
                if e >= place[i]:           # no entry (j, i) matched it
                    return 1, 0.
                continue
            mirror = e
            if j > i:
                mirror = place[j]
                if mirror == indptr[j + 1] or indices[mirror] != i:
                    return 1, 0.
                place[j] = mirror + 1
            d = abs(data[e] - data[mirror])
            if not d <= largest:
                if d != d:
                    return 2, 0.
                largest = d
    return 0, largest


@njit(cache=True)
def upper_entries(indptr, indices, data):
    """``(data, indices, indptr)`` of the upper triangle (diagonal
    included) of a CSR matrix, its rows' entries in their order: what
    :func:`~skfem_mpm.solve.backends.upper_triangle`'s numpy path selects
    by a mask, in two passes over the rows (their counts, then the
    entries), the index arrays of the matrix's dtypes."""
    n = indptr.size - 1
    starts = np.zeros(n + 1, dtype=indptr.dtype)
    for i in range(n):
        count = 0
        for e in range(indptr[i], indptr[i + 1]):
            if indices[e] >= i:
                count += 1
        starts[i + 1] = starts[i] + count
    kept = np.empty(starts[n], dtype=indices.dtype)
    values = np.empty(starts[n], dtype=data.dtype)
    k = 0
    for i in range(n):
        for e in range(indptr[i], indptr[i + 1]):
            if indices[e] >= i:
                kept[k] = indices[e]
                values[k] = data[e]
                k += 1
    return values, kept, starts


@njit(cache=True)
def condensation_runs(indptr, indices, position):
    """``(columns, bounds, shift)`` of the entries of a CSR pattern in
    free rows and columns (``position``: a row's or column's number among
    the free ones, -1 where held), in the pattern's order: their columns
    renumbered, and the maximal runs of consecutive entries
    (:attr:`skfem_mpm.solve.linear.Condensation.runs`: the kept entries
    ``bounds[r] <= k < bounds[r + 1]`` are the pattern's ``k + shift[r]``),
    of ``position``'s dtype.  What the numpy path finds for blocks of rows,
    in two passes over the rows (the counts, then the entries), without
    its masks, positions and the runs' lists."""
    n = indptr.size - 1
    kept, runs, after = 0, 0, -1
    for i in range(n):
        if position[i] >= 0:
            for e in range(indptr[i], indptr[i + 1]):
                if position[indices[e]] >= 0:
                    if e != after:
                        runs += 1
                    kept += 1
                    after = e + 1
    columns = np.empty(kept, dtype=position.dtype)
    bounds = np.empty(runs + 1, dtype=position.dtype)
    shift = np.empty(runs, dtype=position.dtype)
    k, r, after = 0, 0, -1
    for i in range(n):
        if position[i] >= 0:
            for e in range(indptr[i], indptr[i + 1]):
                c = position[indices[e]]
                if c >= 0:
                    if e != after:
                        bounds[r] = k
                        shift[r] = e - k
                        r += 1
                    columns[k] = c
                    k += 1
                    after = e + 1
    bounds[runs] = kept
    return columns, bounds, shift


@njit(cache=True)
def gather_runs(bounds, shift, source, out):
    """``out[k] = source[k + shift[r]]`` for the kept entries ``bounds[r]
    <= k < bounds[r + 1]`` of each run ``r`` (a condensation's map,
    :func:`condensation_runs`), a run at a time in order: no positions
    formed.  ``out`` may be ``source`` where every shift is >= 0 (each
    entry read at or after the place it fills, before it is written)."""
    for r in range(shift.size):
        s = shift[r]
        for k in range(bounds[r], bounds[r + 1]):
            out[k] = source[k + s]
