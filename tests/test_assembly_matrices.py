"""The compressed matrices of a known pattern made without scipy's checked
constructor (``compressed_matrix``, ``PatternMatrices``): the same
matrices as scipy's, and scipy's constructor where the arrays are not
those it keeps."""
import numpy as np
import pytest
from scipy.sparse import csc_matrix, csr_array, csr_matrix, random

from skfem_mpm.methods.assembly import PatternMatrices, compressed_matrix


def parts(cls, seed=0):
    A = cls(random(37, 29, density=.2, format=cls.__name__[:3],
                   random_state=seed))
    return (A.data.copy(), A.indices.astype(np.int32),
            A.indptr.astype(np.int32), A.shape)


@pytest.mark.parametrize("cls", [csr_matrix, csc_matrix])
def test_compressed_matrix_is_scipys(cls):
    data, indices, indptr, shape = parts(cls)
    ours = compressed_matrix(cls, data, indices, indptr, shape)
    theirs = cls((data, indices, indptr), shape=shape)
    assert type(ours) is cls
    assert sorted(ours.__dict__) == sorted(theirs.__dict__)
    assert ours.shape == theirs.shape == (37, 29)
    assert all(type(n) is int for n in ours.shape)
    for name in ("data", "indices", "indptr"):
        a, b = getattr(ours, name), getattr(theirs, name)
        assert a.dtype == b.dtype and np.array_equal(a, b)
        # views of the arrays given, as scipy's
        assert np.shares_memory(a, b)
    assert ours.has_canonical_format == theirs.has_canonical_format
    assert abs(ours - theirs).max() == 0.
    assert np.array_equal(ours.toarray(), theirs.toarray())


def test_compressed_matrix_copies_a_small_view_as_scipy():
    data, indices, indptr, shape = parts(csr_matrix, 1)
    big = np.zeros(10 * data.size)
    big[:data.size] = data
    ours = compressed_matrix(csr_matrix, big[:data.size], indices, indptr,
                             shape)
    theirs = csr_matrix((big[:data.size], indices, indptr), shape=shape)
    assert not np.shares_memory(ours.data, big)
    assert not np.shares_memory(theirs.data, big)


def test_first_pattern_matrix_skips_scipys_checks(monkeypatch):
    """The first matrix of a pattern is made without scipy's
    ``check_format`` (16 us at 56 points), its entries and canonical
    flag as scipy's, and scipy checks arrays it would convert."""
    calls = []
    check = csr_matrix.check_format

    def counted(self, *args, **kwargs):
        calls.append(1)
        return check(self, *args, **kwargs)
    data, indices, indptr, shape = parts(csr_matrix, 2)
    compressed_matrix(csr_matrix, data, indices, indptr, shape)  # layout
    monkeypatch.setattr(csr_matrix, "check_format", counted)
    make = PatternMatrices(csr_matrix)
    A = make(data, indices, indptr, shape)
    B = make(2. * data, indices, indptr, shape)
    assert len(calls) == 0
    assert A.has_canonical_format and B.has_canonical_format
    assert np.array_equal(B.toarray(), 2. * A.toarray())
    # int64 indices: scipy's constructor (which makes them int32)
    C = PatternMatrices(csr_matrix)(data, indices.astype(np.int64),
                                    indptr.astype(np.int64), shape)
    assert len(calls) == 1 and C.indices.dtype == np.int32
    # a bad pattern is refused as scipy refuses it
    with pytest.raises(ValueError):
        compressed_matrix(csr_matrix, data[:-1], indices, indptr, shape)
    assert len(calls) == 2


def test_array_classes_go_to_scipy():
    data, indices, indptr, shape = parts(csr_matrix, 3)
    A = compressed_matrix(csr_array, data, indices, indptr, shape)
    assert type(A) is csr_array
    assert np.array_equal(A.toarray(), csr_array(
        (data, indices, indptr), shape=shape).toarray())


@pytest.mark.parametrize("seed", range(40))
def test_a_tangent_and_a_contact_term_sum_on_their_patterns_union(seed):
    """``add_within`` / ``add_union`` (a tangent plus a term's matrix of
    a few rows, beyond its pattern where contact couples two fields):
    scipy's sum entry for entry, on the union of both patterns with every
    explicit zero kept, each row's columns in order; the union's places
    kept for the pattern pair serve the next sum of other values."""
    from skfem_mpm.solve.problem import add_union, add_within
    rng = np.random.default_rng(seed)
    n, m = rng.integers(1, 25, size=2)
    K = csr_matrix(random(n, m, density=rng.uniform(0., .6),
                          random_state=rng))
    K.data[rng.random(K.nnz) < .2] = 0.
    few = np.zeros((n, 1))
    few[rng.choice(n, size=rng.integers(0, n + 1), replace=False)] = 1.
    G = csr_matrix(random(n, m, density=rng.uniform(0., .6),
                          random_state=rng).toarray() * few)
    G.data[rng.random(G.nnz) < .2] = 0.
    kept = {}

    def pattern(A):
        return {(i, j) for i in range(A.shape[0])
                for j in A.indices[A.indptr[i]:A.indptr[i + 1]]}
    for values in range(2):
        if values:
            K.data[:] = rng.standard_normal(K.nnz)
            G.data[:] = rng.standard_normal(G.nnz)
        S = add_union(K, G, kept)
        assert np.array_equal(S.toarray(), (K + G).toarray())
        assert pattern(S) == pattern(K) | pattern(G)
        assert S.nnz == len(pattern(S)) and S.has_sorted_indices
        W = add_within(K, G)
        assert np.array_equal(W.toarray(), (K + G).toarray())
        assert pattern(W) == pattern(S) if pattern(G) - pattern(K) \
            else pattern(W) == pattern(K)


@pytest.mark.parametrize("dim, copies", [(2, 2), (2, 3), (3, 2)])
def test_the_pattern_of_grid_copies_is_tiled_from_one_copy(dim, copies):
    """The grid fields of contact between bodies (``copies`` copies of a
    grid, :func:`~skfem_mpm.methods.fields.extended_mesh`) take their
    stiffness pattern from one copy's, tiled (0.2 s at 1e5 points in 2D
    for the pattern of both, 0.1 s for one): every array of it equal to
    the pattern found from all copies' elements, dtypes alike; element
    DOFs that are not copies find it from them all."""
    from skfem import (ElementHex1, ElementQuad1, ElementVector, MeshHex,
                       MeshQuad)
    from skfem_mpm.methods.assembly import ElementPattern
    from skfem_mpm.methods.fields import extended_mesh
    from skfem_mpm.solve.core import grid_parts
    mesh, elem = (MeshQuad.init_tensor(np.linspace(0, 1, 9),
                                       np.linspace(0, 1, 6)), ElementQuad1()) \
        if dim == 2 else (MeshHex.init_tensor(*[np.linspace(0, 1, 4)] * 3),
                          ElementHex1())
    big = extended_mesh(mesh, copies)
    tiled = grid_parts(big, ElementVector(elem), copies)[3]
    whole = grid_parts(big, ElementVector(elem))[3]
    assert tiled.tiled() is not None and whole.copies == 1
    a, b = tiled.structure(), whole.structure()
    assert (a[2] is None) == (b[2] is None) == (dim == 2)
    for x, y in zip(a[:2] + a[3:] + (a[2] or ()),
                    b[:2] + b[3:] + (b[2] or ())):
        assert x.dtype == y.dtype and np.array_equal(x, y)
    mixed = ElementPattern(whole.element_dofs[:, ::-1], whole.N, copies)
    assert mixed.tiled() is None
    assert np.array_equal(mixed.structure()[3], b[3])
