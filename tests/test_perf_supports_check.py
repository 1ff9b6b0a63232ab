"""The supports' check without the node graph: the components of the
elements' node chains by a compiled union, and the held DOFs' rows of the
rigid-body modes, equal to what they replace (issue 32)."""
import numpy as np
import pytest
from scipy.sparse.csgraph import connected_components

from skfem_mpm.graph import element_adjacency
from skfem_mpm.solve.linear import element_labels, held_modes, rigid_modes

pytest.importorskip("numba")


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(4))
def test_element_labels_are_scipys(dim, seed):
    rng = np.random.default_rng(seed)
    n_nodes, nloc = 40, 4
    # a few elements on random nodes: several components and lone nodes
    nodes = rng.integers(0, n_nodes, size=(nloc, 6 + 3 * seed))
    element_dofs = (dim * nodes[:, None] + np.arange(dim)[:, None]).reshape(
        nloc * dim, -1)
    expected = connected_components(element_adjacency(
        element_dofs, dim, n_nodes), directed=False)[1]
    labels = element_labels(element_dofs, dim, n_nodes, "compiled")
    assert labels.max() > 0
    np.testing.assert_array_equal(labels, expected)
    assert element_labels(element_dofs, dim, n_nodes, "numpy") is None


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_held_modes_are_rows_of_the_rigid_modes(dim):
    rng = np.random.default_rng(dim)
    doflocs = rng.random((dim, 12)) * 10.
    held = np.sort(rng.choice(12 * dim, size=7, replace=False))
    expected = rigid_modes(doflocs[:, held // dim], dim)[
        np.arange(held.size), held % dim]
    R = held_modes(doflocs, held, dim)
    assert R.shape == expected.shape
    assert np.array_equal(R, expected)
    assert np.array_equal(np.signbit(R), np.signbit(expected))
