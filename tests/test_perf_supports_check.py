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


@pytest.mark.slow
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_the_compiled_check_finds_held_what_the_rank_test_does(dim):
    """The compiled pass (``clearly_held``) finds two bars of nodes held
    where the rank test does, at random supports (a third of them not
    held: too few DOFs, a bar held at one node or along one direction, a
    bar not held), and leaves every other to it."""
    from skfem_mpm.errors import SingularSystemError
    from skfem_mpm.kernels.graph import clearly_held
    from skfem_mpm.solve.linear import CLEARLY_HELD, check_rigid_body_modes
    rng = np.random.default_rng(dim)
    label = np.repeat(np.arange(2, dtype=np.int32), 5)
    doflocs = rng.random((dim, 10)) * 10.
    active = np.arange(10 * dim)
    found = []
    for _ in range(60):
        D = np.flatnonzero(rng.random(10 * dim) < rng.choice([.2, .5, .8]))
        try:
            check_rigid_body_modes(label, doflocs, active, D, dim, "numpy")
            held = True
        except SingularSystemError:
            held = False
        assert clearly_held(label, active, D, doflocs, dim,
                            CLEARLY_HELD) == held
        found.append(held)
    assert 20 <= sum(found) <= 50
