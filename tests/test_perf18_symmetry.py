"""The eighteenth performance round (issue 32): the symmetry test of a
tangent (:func:`~skfem_mpm.solve.backends.is_symmetric`, which picks
Pardiso's factorisation) by one compiled pass, the numpy path's largest
difference and answer; its upper triangle (Pardiso's symmetric input) by
another, the numpy path's arrays."""
import numpy as np
import pytest
from scipy.sparse import csr_matrix, identity, random as sparse_random

from skfem_mpm.solve.backends import is_symmetric

pytest.importorskip("numba")
pytestmark = pytest.mark.slow       # numba compiles its pass once


def matrices():
    """Symmetric matrices, off by round-off and by more, asymmetric
    patterns, a NaN, an empty one, int32 and int64 indices."""
    rng = np.random.default_rng(6)
    for n in (1, 7, 60):
        S = sparse_random(n, n, density=.3, random_state=rng, format="csr")
        S = (S + S.T + 4 * identity(n)).tocsr()
        yield S
        off = S.copy()
        off.data = off.data * (1 + rng.uniform(-1e-13, 1e-13, off.nnz))
        yield off
        rough = S.copy()
        rough.data[rng.integers(0, rough.nnz)] += 1e-6
        yield rough
        lower = csr_matrix(np.tril(S.toarray()) + np.eye(n))
        yield lower                             # asymmetric pattern
        nan = S.copy()
        nan.data[-1] = np.nan
        yield nan
        wide = S.copy()
        wide.indices = wide.indices.astype(np.int64)
        wide.indptr = wide.indptr.astype(np.int64)
        yield wide
    yield csr_matrix((5, 5))


def test_the_compiled_symmetry_test_answers_as_numpy(monkeypatch):
    """The compiled pass's largest ``|a_ij - a_ji|`` is numpy's
    ``|A - A^T|.max()`` where the pattern is symmetric (status 0), the
    pattern's asymmetry and a NaN are reported (status 1, 2), and
    ``is_symmetric`` answers as under ``SKFEM_MPM_KERNELS=numpy`` for
    every matrix and tolerance."""
    from skfem_mpm.kernels.graph import symmetric_deviation
    statuses = set()
    for A in matrices():
        A.sum_duplicates()
        status, largest = symmetric_deviation(A.indptr, A.indices, A.data)
        statuses.add(int(status))
        dense = A.toarray()
        pattern = csr_matrix((np.ones(A.nnz), A.indices, A.indptr),
                             shape=A.shape)
        if np.isnan(A.data).any():
            assert status == 2
        elif status == 0:
            assert (pattern != pattern.T).nnz == 0
            assert largest == np.abs(dense - dense.T).max(initial=0.)
        else:
            assert status == 1 and (pattern != pattern.T).nnz
        for rtol in (1e-12, 1e-9):
            monkeypatch.delenv("SKFEM_MPM_KERNELS", raising=False)
            compiled = is_symmetric(A, rtol)
            monkeypatch.setenv("SKFEM_MPM_KERNELS", "numpy")
            assert compiled == is_symmetric(A, rtol)
    assert statuses == {0, 1, 2}


def test_the_compiled_upper_triangle_is_numpys(monkeypatch):
    """``upper_triangle`` of a canonical CSR matrix by the compiled pass
    (``upper_entries``) is the numpy path's matrix array for array,
    dtypes included, on every matrix of :func:`matrices`."""
    from skfem_mpm.kernels.graph import upper_entries
    from skfem_mpm.solve.backends import upper_triangle
    for A in matrices():
        A.sum_duplicates()
        monkeypatch.delenv("SKFEM_MPM_KERNELS", raising=False)
        got = upper_triangle(A)
        monkeypatch.setenv("SKFEM_MPM_KERNELS", "numpy")
        want = upper_triangle(A)
        assert got.shape == want.shape
        entries = upper_entries(A.indptr, A.indices, A.data)
        for at, name in enumerate(("data", "indices", "indptr")):
            a, b = getattr(got, name), getattr(want, name)
            assert a.dtype == b.dtype
            assert np.array_equal(a, b, equal_nan=True), name
            assert np.array_equal(entries[at], b, equal_nan=True), name
        assert np.array_equal(got.toarray(), np.triu(A.toarray()),
                              equal_nan=True)
