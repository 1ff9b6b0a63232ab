"""The twenty-second performance round (issue 32): a standard MPM
operator's point forces (the external loads' weight and point loads) by
one compiled pass, equal to the numpy path's gather, ``einsum`` and
``bincount`` to the bit."""
import numpy as np
import pytest
from skfem import ElementHex1, ElementQuad1, MeshHex, MeshQuad

from skfem_mpm import MaterialPointBasis, seed_points
from skfem_mpm.methods import operators
from skfem_mpm.methods.operators import PointOperator
from skfem_mpm.quadrature import basis as basis_module

pytest.importorskip("numba")
pytestmark = pytest.mark.slow       # numba compiles its passes once


def numpy_loads(op, f):
    """The numpy path's point forces, written out: the slots' field, the
    element vectors and their scatter."""
    F = op.basis.quadrature_field(f)
    local = np.einsum("iem,aem->iae", op.shape_values, F)
    return np.bincount(op.element_dofs.ravel(),
                       weights=local.reshape(-1, op.nelems).ravel(),
                       minlength=op.N)


@pytest.mark.parametrize("mesh, elem, per_cell", [
    (MeshQuad().refined(3), ElementQuad1(), 2),
    (MeshQuad().refined(2), ElementQuad1(), 5),      # 25 slots: blocks of 8
    (MeshHex().refined(2), ElementHex1(), 2)])
def test_compiled_point_force_equals_the_numpy_path_to_the_bit(
        mesh, elem, per_cell, monkeypatch):
    """``PointOperator.point_force`` on a basis of compiled slots takes
    the compiled pass (``nodal_loads``; the numpy path's element vectors
    are not formed), whose loads equal the numpy path's bit for bit,
    signs of zeros included, at points jittered off the seeding (cells
    of fewer and more points, padding slots) and at forces near underflow
    and overflow; a numpy basis keeps the numpy path."""
    rng = np.random.default_rng(6)
    points = seed_points(mesh, per_cell)
    points.x[:] = np.clip(points.x + rng.uniform(-.1, .1, points.x.shape),
                          0., 1.)
    op, numpy_op = (PointOperator(MaterialPointBasis(
        mesh, elem, points, kernels=kernels))
        for kernels in ("compiled", "numpy"))
    assert (op.basis.point_index < 0).any()          # padding slots
    # where this numpy's einsum sums in another order, the numpy path
    # serves (equal all the same)
    compiled = basis_module.einsum_order(op.basis._passes)
    for scale in (1., 1e-310, 1e300):
        f = rng.standard_normal((op.dim, points.n)) * scale
        f[rng.random(f.shape) < .3] = -0.
        want = numpy_loads(numpy_op, f)
        assert np.array_equal(numpy_op.point_force(f), want)
        with monkeypatch.context() as m:
            if compiled:
                m.setattr(operators, "local_load", None)   # not called
            got = op.point_force(f)
        assert got.shape == (op.N,)
        assert np.array_equal(got, want, equal_nan=True)
        assert np.array_equal(np.signbit(got), np.signbit(want))
    assert numpy_op.basis.nodal_loads(numpy_op.shape_values,
                                      numpy_op.scalar_dofs, f,
                                      op.N) is None


def test_slot_sums_are_einsums_and_another_order_goes_to_numpy(
        monkeypatch):
    """The compiled slot sums equal ``np.einsum("iem,aem->iae")`` to the
    bit at 1 to 33 slots (blocks of eight slots and their rest) exactly
    where :func:`einsum_order` finds this numpy's einsum summing in their
    order (on the project's AVX-512 machine: yes), and are not a sum
    in slot order; where numpy's ``einsum`` sums otherwise the numpy path
    serves the loads."""
    from skfem_mpm.kernels.basis import slot_sums
    rng = np.random.default_rng(7)
    same, differs = True, 0
    for slots in range(1, 34):
        N = rng.standard_normal((8, 20, slots))
        F = rng.standard_normal((3, 20, slots)) * 10. ** rng.integers(
            -6, 6, (3, 20, slots))
        got = slot_sums(N, F)
        same &= np.array_equal(got, np.einsum("iem,aem->iae", N, F))
        in_order = np.zeros_like(got)
        for m in range(slots):
            in_order += N[:, None, :, m] * F[None, :, :, m]
        differs += np.count_nonzero(in_order != got)
    assert differs > 0
    mesh = MeshQuad().refined(2)
    op = PointOperator(MaterialPointBasis(mesh, ElementQuad1(),
                                          seed_points(mesh, 2),
                                          kernels="compiled"))
    f = rng.standard_normal((2, op.n_points))
    assert basis_module.einsum_order(op.basis._passes) == same
    monkeypatch.setitem(basis_module._KERNELS, "einsum_order", False)
    assert op.basis.nodal_loads(op.shape_values, op.scalar_dofs, f,
                                op.N) is None
    assert np.array_equal(op.point_force(f), numpy_loads(op, f))
