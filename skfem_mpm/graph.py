"""Graphs of grid DOFs and nodes: which of them appear, and which are joined.

The active DOFs of a grid are the distinct entries of its elements' DOF
arrays; the grid's nodes joined by an element or a shared point form a
sparse graph whose connected components the rigid-body check walks.  Used
by the material point bases (:mod:`skfem_mpm.quadrature`), the point
operators (:mod:`skfem_mpm.methods`) and the linear solves
(:mod:`skfem_mpm.solve`), so it depends on numpy and scipy only.

"""
import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix

__all__ = ["distinct", "element_adjacency", "edge_graph"]


def distinct(indices: ndarray, n: int) -> ndarray:
    """The sorted distinct entries of an index array, through a mask:
    linear in the size, where ``np.unique`` sorts.

    Parameters
    ----------
    indices
        Integer array of any shape, entries in ``[0, n)``.
    n
        A bound on the entries.

    Returns
    -------
    ndarray
        The distinct entries, sorted.

    Examples
    --------
    >>> import numpy as np
    >>> distinct(np.array([[4, 1], [1, 0]]), 5)
    array([0, 1, 4])

    """
    mask = np.zeros(n, dtype=bool)
    mask[np.ravel(indices)] = True
    return np.flatnonzero(mask)


def element_adjacency(element_dofs: ndarray, dim: int,
                      n_nodes: int) -> csr_matrix:
    """The connectivity graph of the nodes of vector element DOFs.

    Each element's nodes are joined in a chain, which has the connected
    components of the full adjacency at a fraction of its size.

    Parameters
    ----------
    element_dofs
        Vector element DOFs (Nbfun, nelems); vector DOF ``dim * k + a`` is
        component ``a`` of node ``k``.
    dim
        The number of components per node.
    n_nodes
        The number of nodes.

    Returns
    -------
    csr_matrix
        Sparse (n_nodes, n_nodes), nonzero where the chain joins two nodes.

    """
    nodes = element_dofs[::dim] // dim
    return edge_graph(nodes[:-1].ravel(), nodes[1:].ravel(), n_nodes)


def edge_graph(rows: ndarray, cols: ndarray, n_nodes: int) -> csr_matrix:
    """The sparse graph with the edges ``rows[k] -- cols[k]``.

    Its CSR arrays are built directly (the edges grouped by their first
    end, a stable sort): scipy's COO to CSR conversion sums duplicates and
    sorts each row, a graph walk needs neither (at 56 points, 120 -> 34 us
    a step).

    Parameters
    ----------
    rows, cols
        The two ends of each edge, node indices in ``[0, n_nodes)``.
    n_nodes
        The number of nodes.

    Returns
    -------
    csr_matrix
        Sparse (n_nodes, n_nodes), an entry 1 at ``(rows[k], cols[k])``
        for each k (a directed edge; connected components taken undirected
        join both ends), in the order of the edges within a row; an edge
        given twice is stored twice (not summed).

    Examples
    --------
    >>> import numpy as np
    >>> edge_graph(np.array([0, 1]), np.array([1, 2]), 4).toarray()
    array([[0., 1., 0., 0.],
           [0., 0., 1., 0.],
           [0., 0., 0., 0.],
           [0., 0., 0., 0.]])

    """
    rows, cols = np.ravel(rows), np.ravel(cols)
    index = np.int32 if max(n_nodes, rows.size) < 2 ** 31 else np.int64
    indptr = np.zeros(n_nodes + 1, dtype=index)
    np.cumsum(np.bincount(rows, minlength=n_nodes), out=indptr[1:])
    indices = cols[np.argsort(rows, kind="stable")].astype(index, copy=False)
    return csr_matrix((np.ones(rows.size), indices, indptr),
                      shape=(n_nodes, n_nodes))
