"""The eighteenth performance round (issue 32): a standard MPM
operator's values at the points by one compiled pass, and the compiled
slot layout's points by element by counting, both equal to the numpy
path to the bit."""
import numpy as np
import pytest
from skfem import ElementHex1, ElementQuad1, MeshHex, MeshQuad

from skfem_mpm import MaterialPointBasis, seed_points
from skfem_mpm.methods.operators import PointOperator

pytest.importorskip("numba")
pytestmark = pytest.mark.slow       # numba compiles its passes once


@pytest.mark.parametrize("mesh, elem", [(MeshQuad().refined(3),
                                         ElementQuad1()),
                                        (MeshHex().refined(2),
                                         ElementHex1())])
def test_compiled_values_equal_the_numpy_path_to_the_bit(mesh, elem):
    """``PointOperator.values`` on a basis of compiled slots takes the
    compiled pass (``nodal_values``), whose sums over an element's nodes
    equal the gather, ``einsum`` and ``take`` of the numpy path bit for
    bit, signs of zeros included, at points jittered off the seeding
    (cells of fewer points) and at increments near underflow and
    overflow; a numpy basis keeps the numpy path."""
    rng = np.random.default_rng(4)
    points = seed_points(mesh, 2)
    points.x[:] = np.clip(points.x + rng.uniform(-.05, .05, points.x.shape),
                          0., 1.)
    op = PointOperator(MaterialPointBasis(mesh, elem, points,
                                          kernels="compiled"))
    numpy_op = PointOperator(MaterialPointBasis(mesh, elem, points,
                                                kernels="numpy"))
    for scale in (1., 1e-310, 1e300):
        u = rng.standard_normal(op.N) * scale
        u[rng.random(op.N) < .3] = -0.
        got = op.basis.nodal_values(op.shape_values, op.scalar_dofs, u,
                                    op.dim)
        want = op._at_points(u, op.shape_values)
        assert got.shape == want.shape == (op.dim, points.n)
        assert np.array_equal(got, want, equal_nan=True)
        assert np.array_equal(np.signbit(got), np.signbit(want))
        assert np.array_equal(op.values(u), want, equal_nan=True)
        assert np.array_equal(numpy_op.values(u), want, equal_nan=True)
    assert numpy_op.basis.nodal_values(numpy_op.shape_values,
                                       numpy_op.scalar_dofs, u, 2) is None


def test_points_by_element_are_numpys_stable_order():
    """The compiled slots' order of the points by element, by counting
    the points of each element, is ``np.argsort(kind="stable")``'s: in
    seeding order, at random with empty elements between, one element,
    no points, and with negative elements (numpy's sort then)."""
    from skfem_mpm.kernels.basis import by_element
    rng = np.random.default_rng(5)
    cases = [np.repeat(np.arange(40), 4), rng.integers(0, 500, 3000),
             rng.choice(np.arange(0, 90, 9), 400), np.full(7, 3),
             np.zeros(0, dtype=np.int64), rng.integers(-3, 20, 300)]
    for tind in cases:
        for dtype in (np.int64, np.int32):
            t = tind.astype(dtype)
            got = by_element(t)
            assert got.dtype == np.int64
            assert np.array_equal(got, np.argsort(t, kind="stable"))
