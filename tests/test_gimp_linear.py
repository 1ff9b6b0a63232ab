"""Closed-form GIMP weights of linear elements against the Gauss
sub-point construction."""
import numpy as np
import pytest
from skfem import (ElementHex1, ElementLineP1, ElementQuad1, ElementQuad2,
                   MeshHex, MeshLine, MeshQuad)

from skfem_mpm import point_locator
from skfem_mpm.methods.gimp import gimp_operators, subpoint_gimp_operator
from skfem_mpm.methods.gimp_linear import LinearGimp

RNG = np.random.default_rng(7)
GRIDS = {
    1: (MeshLine(np.sort(np.r_[0., RNG.random(6), 1.])), ElementLineP1()),
    2: (MeshQuad.init_tensor(np.linspace(0., 1., 5),
                             np.r_[0., .1, .35, .4, .8, 1.]), ElementQuad1()),
    3: (MeshHex.init_tensor(np.linspace(0., 1., 4), np.linspace(0., 2., 3),
                            np.r_[0., .3, 1.]), ElementHex1()),
}


def random_points(mesh, n=300):
    """Points anywhere in the grid, some on grid lines, with domains from a
    hundredth of a cell to several cells (crossing the grid's edge), some
    ending a hair (1e-14) past a grid line."""
    lo, hi = mesh.p.min(axis=1), mesh.p.max(axis=1)
    x = lo[:, None] + (hi - lo)[:, None] * RNG.random((mesh.dim(), n))
    k = min(20, mesh.nvertices)
    x[:, :k] = mesh.p[:, :k]
    domain = 0.6 * RNG.random(x.shape) + 0.005
    lines = np.unique(mesh.p[0])
    below = lines[np.searchsorted(lines, x[0], side="left") - 1]
    sliver = slice(20, 60)
    domain[0, sliver] = np.where(below[sliver] > lo[0], (x[0] - below)[sliver]
                                 * (1 + 1e-14), domain[0, sliver])
    return x, domain


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_closed_form_equals_subpoints(dim):
    mesh, elem = GRIDS[dim]
    x, domain = random_points(mesh)
    ref = subpoint_gimp_operator(mesh, elem, x, domain, point_locator(mesh))
    new = LinearGimp(mesh, elem)(x, domain)
    assert abs(new.S - ref.S).max() < 1e-13
    for g_new, g_ref in zip(new.G, ref.G):
        # gradients scale with 1/h
        assert abs(g_new - g_ref).max() < 1e-12
    # the same coupling, point by point: no node or element from a sliver
    assert np.array_equal(new.S.getnnz(axis=1), ref.S.getnnz(axis=1))
    assert np.array_equal(new.active_dofs, ref.active_dofs)
    assert np.array_equal(new.elements, np.unique(ref.elements))
    # partition of unity and zero-sum gradients
    assert abs(new.S.sum(axis=1) - 1.).max() < 1e-14
    for g in new.G:
        assert abs(g.sum(axis=1)).max() < 1e-11


def test_higher_order_elements_use_subpoints():
    mesh = MeshQuad.init_tensor(np.linspace(0., 1., 4), np.linspace(0., 1., 3))
    build = gimp_operators(mesh, ElementQuad2(), point_locator(mesh))
    assert not isinstance(build, LinearGimp)
    x, domain = random_points(mesh, 20)
    op = build(x, domain)
    assert abs(op.S.sum(axis=1) - 1.).max() < 1e-13
    assert isinstance(gimp_operators(mesh, ElementQuad1(),
                                     point_locator(mesh)), LinearGimp)


@pytest.mark.parametrize("dim", [2, 3])
def test_sparse_stiffness_equals_dense_sum_over_points(dim):
    mesh, elem = GRIDS[dim]
    x, domain = random_points(mesh, 40)
    op = LinearGimp(mesh, elem)(x, domain)
    n = x.shape[1]
    A = RNG.random((dim,) * 4 + (n,))          # no symmetry assumed
    w = RNG.random(n)
    G = np.array([g.toarray() for g in op.G])          # (dim, n, nodes)
    dense = np.einsum("abcdp,p,bpi,dpj->iajc", A, w, G, G).reshape(
        op.N, op.N)
    K = op.stiffness(A, w).toarray()
    assert np.abs(K - dense).max() < 1e-13 * np.abs(dense).max()


def test_bad_input_is_refused():
    from scipy.sparse import csr_matrix
    from skfem import MeshTri
    from skfem_mpm import InvalidInputError, UnsupportedElementError
    from skfem_mpm.methods.operators import SparseOperator
    with pytest.raises(UnsupportedElementError, match="tensor-product"):
        LinearGimp(MeshTri(), ElementQuad1())
    S = csr_matrix(np.array([[.5, .5, 0.]]))
    G = csr_matrix(np.array([[-1., 0., 1.]]))
    with pytest.raises(InvalidInputError, match="one sparsity pattern"):
        SparseOperator(S, [G], np.array([0]))
