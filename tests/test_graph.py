"""The node graphs of :mod:`skfem_mpm.graph`, built as CSR directly, join
the nodes the COO construction joins."""
import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from skfem_mpm.graph import edge_graph, element_adjacency


def same_partition(a, b):
    """Two labellings split the nodes alike (labels may be renumbered)."""
    pairs = np.unique(np.c_[a, b], axis=0)
    return (np.unique(pairs[:, 0]).size == pairs.shape[0]
            == np.unique(pairs[:, 1]).size)


@pytest.mark.parametrize("seed", range(4))
def test_edge_graph_equals_the_coo_construction(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 60))
    # few edges: many components; repeated edges and self-loops included
    m = int(rng.integers(0, n + 5))
    rows, cols = rng.integers(0, n, m), rng.integers(0, n, m)
    graph = edge_graph(rows, cols, n)
    old = coo_matrix((np.ones(m), (rows, cols)), shape=(n, n)).tocsr()
    # the same entries, duplicates stored apart rather than summed
    assert graph.nnz == m
    assert np.array_equal(graph.toarray(), old.toarray())
    label = connected_components(graph, directed=False)[1]
    reference = connected_components(old, directed=False)[1]
    assert same_partition(label, reference)


def test_element_adjacency_joins_each_elements_nodes():
    rng = np.random.default_rng(4)
    n_nodes, dim = 40, 2
    nodes = rng.integers(0, n_nodes, (4, 15))
    element_dofs = (dim * np.repeat(nodes, dim, axis=0)
                    + np.tile(np.arange(dim), 4)[:, None])
    label = connected_components(element_adjacency(element_dofs, dim,
                                                   n_nodes),
                                 directed=False)[1]
    # the full adjacency: every pair of an element's nodes
    a, b = np.meshgrid(np.arange(4), np.arange(4))
    full = coo_matrix((np.ones(16 * 15), (nodes[a.ravel()].ravel(),
                                          nodes[b.ravel()].ravel())),
                      shape=(n_nodes, n_nodes))
    assert same_partition(label,
                          connected_components(full, directed=False)[1])
