from functools import reduce

import numpy as np
import pytest
from scipy.sparse.linalg import MatrixRankWarning
from skfem import (Basis, BilinearForm, ElementQuad1, ElementVector,
                   Functional, LinearForm, MeshQuad, asm, condense, solve)
from skfem.helpers import ddot, dot, grad
from skfem.models.elasticity import linear_elasticity
from skfem.models.poisson import laplace

from meshes import FAMILIES
from skfem_mpm import (InvalidInputError, LinearElastic, MaterialPointBasis,
                       MaterialPoints, material_point_bases,
                       seed_gauss_points, seed_points, solve_mpm)


def test_vector_elasticity_equals_fe_at_gauss_points(family):
    name, mesh, elem = family
    elem = ElementVector(elem)
    fe = Basis(mesh, elem, intorder=2)
    mp = MaterialPointBasis(mesh, elem, seed_gauss_points(mesh, 2))
    form = linear_elasticity(1.3, .7)
    K_fe, K_mp = asm(form, fe), asm(form, mp)
    assert abs(K_mp - K_fe).max() <= 1e-12 * abs(K_fe).max()
    load = LinearForm(lambda v, w: dot(w.x, v))
    f_fe, f_mp = asm(load, fe), asm(load, mp)
    assert np.abs(f_mp - f_fe).max() <= 1e-12 * np.abs(f_fe).max()
    area = Functional(lambda w: 1. + 0. * w.x[0])
    assert abs(asm(area, mp) - asm(area, fe)) < 1e-13


def arbitrary_points(mesh, n, seed=0, clustered=False):
    """Random points inside random elements, with random positive volumes;
    ``clustered``: crowded into the first elements (element k with a
    frequency falling like k^(-2/3))."""
    rng = np.random.default_rng(seed)
    if clustered:
        tind = (rng.random(n) ** 3 * mesh.nelements).astype(np.int64)
    else:
        tind = rng.integers(0, mesh.nelements, n)
    X = rng.random((mesh.dim(), n))
    if mesh.refdom.name in ("Triangular", "Tetrahedral"):
        X *= (rng.random(n) / X.sum(axis=0))[None]   # inside the simplex
    from skfem_mpm.quadrature.mapping import fresh_mapping
    x = fresh_mapping(mesh).F(X[:, :, None], tind=tind)[:, :, 0]
    return MaterialPoints(x=x, volume=rng.uniform(.1, 1., n))


def test_partition_of_unity_and_linear_reproduction(family):
    name, mesh, elem = family
    points = arbitrary_points(mesh, 300)
    basis = MaterialPointBasis(mesh, elem, points)
    dim = mesh.dim()
    # sum of shape functions is one, sum of gradients zero
    one = basis.interpolate(np.ones(basis.N))
    assert np.abs(basis.point_values(np.asarray(one)) - 1.).max() < 1e-13
    assert np.abs(basis.point_values(one.grad)).max() < 1e-12
    # nodal coordinates interpolate to the point positions, gradient = I
    for d in range(dim):
        field = basis.interpolate(basis.doflocs[d])
        assert np.abs(basis.point_values(np.asarray(field)) - points.x[d]).max() \
            < 1e-13
        grad = basis.point_values(field.grad)
        assert np.abs(grad - np.eye(dim)[d][:, None]).max() < 1e-11


def test_padding_slots_carry_no_weight():
    mesh = MeshQuad().refined(1)
    # 3 points in element holding (.1, .1), 1 point elsewhere
    x = np.array([[.1, .2, .15, .7], [.1, .2, .3, .8]])
    pts = MaterialPoints(x=x, volume=np.array([1., 2., 3., 4.]))
    basis = MaterialPointBasis(mesh, ElementQuad1(), pts)
    assert basis.nelems == 2 and basis.point_index.shape == (2, 3)
    assert (basis.point_index == -1).sum() == 2
    np.testing.assert_allclose(basis.dx.sum(), 10.)
    mass = asm(BilinearForm(lambda u, v, w: u * v), basis)
    assert abs(mass.sum() - 10.) < 1e-13
    values = np.arange(4.) * 10
    np.testing.assert_array_equal(
        basis.point_values(basis.quadrature_field(values)), values)
    # active DOFs: the nodes of the two active elements
    assert basis.active_dofs.size == 7


def test_condense_and_solve_on_the_active_grid():
    """Poisson with points in part of the domain: scikit-fem's condense and
    solve on the active DOFs reproduce a linear field exactly."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 1, 5))
    pts = seed_gauss_points(mesh, 2, region=lambda x: x[0] < .5)
    basis = MaterialPointBasis(mesh, ElementQuad1(), pts)
    K = asm(laplace, basis)
    exact = 1. + 2. * basis.doflocs[0] - basis.doflocs[1]
    active = basis.active_dofs
    x, y = basis.doflocs[:, active]
    D = active[(x == 0) | (x == .5) | (y == 0) | (y == 1)]
    I = np.setdiff1d(active, D)
    u = solve(*condense(K, np.zeros(basis.N), x=exact, I=I))
    assert np.abs(u[active] - exact[active]).max() < 1e-12


def test_inactive_dofs_condense_to_the_solvers_answer():
    """The README's body filling the lower 10 of a 12-high grid:
    scikit-fem's condense with the supports and the inactive DOFs solves to
    the grid displacement of solve_mpm's linear step (1e-12); with the
    supports alone the condensed matrix keeps the inactive DOFs' empty rows
    and scipy only warns and returns NaN."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 4, 5), np.linspace(0, 12, 13))
    points = seed_points(mesh, 2, region=lambda x: x[1] < 10)
    material = LinearElastic(1e6, .3)
    basis = MaterialPointBasis(mesh, ElementVector(ElementQuad1()), points)
    K = asm(linear_elasticity(material.lam, material.mu), basis)
    f = asm(LinearForm(lambda v, w: -800. * v[1]), basis)
    D = basis.get_dofs(lambda x: x[1] == 0).all()
    inactive = basis.inactive_dofs
    assert inactive.size == 2 * 5 * 2          # the nodes at y = 11 and 12
    np.testing.assert_array_equal(np.union1d(basis.active_dofs, inactive),
                                  np.arange(basis.N))
    assert np.isin(inactive, basis.active_dofs).sum() == 0
    u = solve(*condense(K, f, D=np.union1d(D, inactive)))
    reference = solve_mpm(mesh, ElementQuad1(), points, material,
                          supports=lambda b: b.get_dofs(lambda x: x[1] == 0),
                          body_force=[0., -800.]).history[0].u
    assert np.isfinite(u).all() and np.abs(reference).max() > 1e-3
    assert np.abs(u - reference).max() <= 1e-12 * np.abs(reference).max()
    A = condense(K, f, D=D)[0]
    assert (abs(A).sum(axis=1) == 0).sum() == inactive.size
    with pytest.warns(MatrixRankWarning):
        singular = solve(*condense(K, f, D=D))
    assert np.isnan(np.delete(singular, D)).all()     # every unknown


@pytest.mark.parametrize("name", ["quad", "quad-distorted", "tri"])
@pytest.mark.parametrize("clustered", [False, True])
@pytest.mark.parametrize("max_padding", [0., .25])
def test_grouped_bases_equal_the_padded_basis(name, clustered, max_padding):
    """asm over material_point_bases equals asm over the one padded basis to
    round-off: stiffness, a mass matrix weighted by a point field, a load
    vector of a point stress field, a functional; point fields scattered
    and gathered per basis; the inactive DOFs are those inactive in every
    basis; padding stays within max_padding."""
    make_mesh, elem = FAMILIES[name]
    mesh = make_mesh().refined(1)
    points = arbitrary_points(mesh, 400, seed=2, clustered=clustered)
    elem = ElementVector(elem())
    padded = MaterialPointBasis(mesh, elem, points)
    bases = material_point_bases(mesh, elem, points, max_padding=max_padding)
    counts = (padded.point_index >= 0).sum(axis=1)     # per element
    assert len(bases) > 1 and counts.max() > 2 * counts.min()
    np.testing.assert_array_equal(
        np.sort(np.concatenate([b.subset for b in bases])),
        np.arange(points.n))
    for b in bases:
        assert b.dx.size <= (1 + max_padding) * b.subset.size
    assert sum(b.dx.size for b in bases) < .8 * padded.dx.size

    def close(grouped, reference, rtol=1e-13):
        assert abs(grouped - reference).max() <= rtol * abs(reference).max()

    form = linear_elasticity(1.3, .7)
    close(asm(form, bases), asm(form, padded))
    rng = np.random.default_rng(3)
    rho, S = rng.random(points.n), rng.random((2, 2, points.n))
    mass = BilinearForm(lambda u, v, w: w.rho * dot(u, v))
    force = LinearForm(lambda v, w: ddot(w.sig, grad(v)))
    close(sum(mass.elemental(b, rho=b.quadrature_field(rho))
              for b in bases).todefault(),
          asm(mass, padded, rho=padded.quadrature_field(rho)))
    close(sum(force.elemental(b, sig=b.quadrature_field(S))
              for b in bases).todefault(),
          asm(force, padded, sig=padded.quadrature_field(S)))
    area = Functional(lambda w: 1. + 0. * w.x[0])
    assert abs(asm(area, bases) - points.volume.sum()) \
        < 1e-13 * points.volume.sum()
    gathered = np.zeros_like(S)
    for b in bases:
        gathered[..., b.subset] = b.point_values(b.quadrature_field(S))
    np.testing.assert_array_equal(gathered, S)
    np.testing.assert_array_equal(
        reduce(np.intersect1d, [b.inactive_dofs for b in bases]),
        padded.inactive_dofs)


def test_bad_grouping_input():
    mesh = MeshQuad().refined(1)
    pts = MaterialPoints(x=np.full((2, 3), .3), volume=np.ones(3))
    for subset in ([2, 1], [0, 0], [0, 3], [], [[0, 1]], [0., 1.]):
        with pytest.raises(InvalidInputError, match="subset must be sorted"):
            MaterialPointBasis(mesh, ElementQuad1(), pts, subset=subset)
    with pytest.raises(InvalidInputError, match="max_padding must be >= 0"):
        material_point_bases(mesh, ElementQuad1(), pts, max_padding=-.1)
    with pytest.raises(InvalidInputError, match="must be MaterialPoints"):
        material_point_bases(mesh, ElementQuad1(), pts.x)
    with pytest.raises(InvalidInputError, match="does not match 3 points"):
        material_point_bases(mesh, ElementQuad1(), pts, location=(
            np.zeros(2, dtype=int), np.zeros((2, 2))))


def test_bad_basis_input():
    mesh = MeshQuad()
    with pytest.raises(InvalidInputError, match="must be MaterialPoints"):
        MaterialPointBasis(mesh, ElementQuad1(), np.zeros((2, 3)))
    pts = MaterialPoints(x=np.full((2, 2), .5), volume=np.ones(2))
    with pytest.raises(InvalidInputError, match="does not match 2 points"):
        MaterialPointBasis(mesh, ElementQuad1(), pts,
                           location=(np.zeros(3, dtype=int), np.zeros((2, 3))))


def test_fast_path_equals_asm(family):
    """The vectorised force and stiffness assembly equals scikit-fem's asm
    to round-off (points at random, unequal counts per element)."""
    from skfem_mpm.methods.operators import AsmOperator, PointOperator
    name, mesh, elem = family
    points = arbitrary_points(mesh, 120, seed=4)
    basis = MaterialPointBasis(mesh, ElementVector(elem), points)
    fast = PointOperator(MaterialPointBasis(mesh, elem, points))
    reference = AsmOperator(basis)
    u = np.random.default_rng(9).random(fast.N)
    assert np.abs(fast.values(u) - reference.values(u)).max() < 1e-14
    assert np.abs(fast.gradients(u) - reference.gradients(u)).max() \
        < 1e-12 * np.abs(reference.gradients(u)).max()
    np.testing.assert_array_equal(fast.active_dofs, reference.active_dofs)
    dim, n = mesh.dim(), points.n
    rng = np.random.default_rng(5)
    A, P = rng.random((dim,) * 4 + (n,)), rng.random((dim, dim, n))
    K1, K2 = fast.stiffness(A, points.volume), reference.stiffness(
        A, points.volume)
    assert abs(K1 - K2).max() <= 1e-13 * abs(K2).max()
    f1, f2 = fast.force(P, points.volume), reference.force(P, points.volume)
    assert np.abs(f1 - f2).max() <= 1e-13 * np.abs(f2).max()
    # the small-strain stiffness of the solver equals skfem's model
    from skfem_mpm.mechanics.materials import elastic_tensor
    K3 = fast.stiffness(elastic_tensor(LinearElastic(2., .3), n, dim),
                        points.volume)
    K4 = asm(linear_elasticity(LinearElastic(2., .3).lam,
                               LinearElastic(2., .3).mu), basis)
    assert abs(K3 - K4).max() <= 1e-13 * abs(K4).max()


def test_fast_point_forces_equal_asm(family):
    from skfem_mpm.methods.operators import AsmOperator, PointOperator
    name, mesh, elem = family
    points = arbitrary_points(mesh, 60, seed=6)
    basis = MaterialPointBasis(mesh, ElementVector(elem), points)
    f = np.random.default_rng(8).random((mesh.dim(), points.n))
    fast = PointOperator(MaterialPointBasis(mesh, elem, points)).point_force(f)
    reference = AsmOperator(basis).point_force(f)
    assert np.abs(fast - reference).max() <= 1e-14 * np.abs(reference).max()
    # the total force is kept (partition of unity)
    assert np.allclose(fast.reshape(-1, mesh.dim()).sum(axis=0),
                       f.sum(axis=1), rtol=1e-12)


def test_point_mapping_caches_by_identity_and_stays_bounded():
    from skfem.mapping import MappingIsoparametric
    from skfem_mpm.quadrature.mapping import PointMapping
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 4), np.r_[0., .3, 1.])
    mapping, reference = PointMapping(mesh), MappingIsoparametric(
        mesh, mesh.elem(), mesh.bndelem)
    rng = np.random.default_rng(3)
    for _ in range(5):                     # new points every "step"
        X = rng.random((2, 4))                # reference points, all cells
        first = mapping.invDF(X)
        assert mapping.invDF(X) is first   # computed once per set of points
        assert np.abs(first - reference.invDF(X)).max() < 1e-14
        assert np.abs(mapping.detDF(X) - reference.detDF(X)).max() < 1e-15
    assert len(mapping._entries) == 5      # invDF and the four J: bounded


@pytest.mark.parametrize("b, blocked", [(1, True), (2, True), (3, True),
                                        (3, False)])
def test_element_pattern_equals_a_coo_sum(b, blocked):
    """Element matrices scattered through the pattern (per node pair where
    the DOFs come in blocks of three, per entry otherwise: one or two
    components, or three numbered apart) equal scipy's sum of duplicates,
    in canonical CSR."""
    from scipy.sparse import coo_matrix
    from skfem_mpm.methods.assembly import ElementPattern
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 1, 4))
    nodes, n = mesh.t, mesh.nvertices
    if blocked:
        dofs = (b * nodes[:, None] + np.arange(b)[:, None]).reshape(
            -1, mesh.nelements)
    else:                          # component c of node i: DOF c n + i
        dofs = (nodes[:, None] + n * np.arange(b)[:, None]).reshape(
            -1, mesh.nelements)
    pattern = ElementPattern(dofs, b * n)
    assert pattern.block_size() == (3 if blocked and b == 3 else 1)
    rng = np.random.default_rng(b)
    local = rng.standard_normal((mesh.nelements,) + (dofs.shape[0],) * 2)
    order = rng.permutation(mesh.nelements)
    K = pattern.matrix([(order[:5], local[order[:5]]),
                        (order[5:], local[order[5:]])])
    rows = np.repeat(dofs.T[:, :, None], dofs.shape[0], axis=2)
    reference = coo_matrix((local.ravel(), (rows.ravel(), np.swapaxes(
        rows, 1, 2).ravel())), shape=K.shape).tocsr()
    assert K.has_canonical_format
    assert abs(K - reference).max() <= 1e-15 * abs(reference).max()
    np.testing.assert_array_equal(K.indptr, reference.indptr)
    np.testing.assert_array_equal(K.indices, reference.indices)
    empty = ElementPattern(np.zeros((dofs.shape[0], 0), dtype=int), b * n)
    assert empty.matrix([]).nnz == 0


@pytest.mark.parametrize("dim", [2, 3])
def test_tangent_formed_by_blocks_equals_the_whole_tangent(dim):
    """The finite-deformation stiffness from the tangent formed block by
    block of elements (3D's default: no tangent of all points in memory)
    equals, bit for bit, the one from the whole tangent, with padding
    slots (points crowded into the first elements) and yielded points.
    The numpy path's response (``kernels="numpy"``): a compiled response
    brings its own stiffness pass, and its tangents of all points and by
    blocks, which no run feeds to this stiffness, differ by round-off
    (1.7e-16 here; the test failed under ``kernels="auto"``)."""
    from collections import Counter
    from skfem import ElementHex1, MeshHex
    from skfem_mpm import VonMises
    from skfem_mpm.mechanics.kinematics import FiniteStrain
    from skfem_mpm.mechanics.materials import initial_state
    from skfem_mpm.methods.operators import PointOperator
    grid, elem = (MeshQuad, ElementQuad1) if dim == 2 else (MeshHex,
                                                             ElementHex1)
    mesh = grid.init_tensor(*[np.linspace(0., 1., 4)] * dim)
    points = arbitrary_points(mesh, 150, seed=2, clustered=True)
    op = PointOperator(MaterialPointBasis(mesh, elem(), points))
    assert op.tangent_blocks == (dim == 3)
    assert (op.basis.point_index < 0).any()               # padding slots
    material = VonMises(1e3, .3, 50.)
    points.state = initial_state(material, points.n)
    kinematics = FiniteStrain(material, dim, Counter(), kernels="numpy")
    du = np.random.default_rng(4).standard_normal(op.N) * .02
    response = kinematics.response(op, du, points)
    assert response.yielded.any() and not response.yielded.all()
    assert response.stiffness is None                  # the numpy path
    whole = op.stiffness(response.tangent(), response.w)
    blocks = op.stiffness(response.tangent_of, response.w)
    assert whole.nnz == blocks.nnz and (whole != blocks).nnz == 0


def test_an_inversion_names_the_most_inverted_point():
    """A trial increment that inverts several points: the error names the
    one whose ``det dF`` is least first, with its position and the value
    (it named the lowest index, far from where the trial failed)."""
    from collections import Counter
    from skfem_mpm import InversionError, LinearElastic
    from skfem_mpm.mechanics.kinematics import FiniteStrain
    from skfem_mpm.methods.operators import PointOperator
    mesh = MeshQuad.init_tensor(np.linspace(0., 1., 5), np.linspace(0., 1., 5))
    points = arbitrary_points(mesh, 60, seed=3)
    op = PointOperator(MaterialPointBasis(mesh, ElementQuad1(), points))
    X, Y = mesh.p
    du = np.zeros(op.N)
    du[0::2] = -1.5 * X * (Y > .5) - 3. * X * (X > .5) * (Y > .5)
    det = np.linalg.det(np.eye(2) + np.moveaxis(op.gradients(du), -1, 0))
    worst = int(np.argmin(det))
    assert (det <= 0).sum() > 1 and worst != np.flatnonzero(det <= 0)[0]
    with pytest.raises(InversionError, match=r"the most \[{}".format(worst)):
        FiniteStrain(LinearElastic(1e3, .3), 2, Counter()).response(
            op, du, points)


@pytest.mark.slow
def test_compiled_fields_equal_scikit_fems_to_the_bit(monkeypatch):
    """The compiled values and gradients of the bilinear quadrilateral and
    the trilinear hexahedron (``kernels="auto"``) are the numpy path's to
    the bit, signs of zeros included, on distorted meshes at random
    points of half their elements; other elements, ``SKFEM_MPM_KERNELS=
    numpy`` and a zero Jacobian determinant (which the numpy path refuses)
    get none."""
    pytest.importorskip("numba")
    from skfem import ElementHex1, ElementQuad2, MeshHex, MeshQuad
    from skfem_mpm.quadrature.basis import _h1_fields, compiled_fields
    from skfem_mpm.quadrature.mapping import PointMapping
    monkeypatch.setenv("SKFEM_MPM_KERNELS", "auto")
    rng = np.random.default_rng(0)
    for M, elem in ((MeshQuad, ElementQuad1()), (MeshHex, ElementHex1())):
        mesh = M().refined(3)
        inner = (mesh.p > 0.) & (mesh.p < 1.)
        mesh = M(mesh.p + .02 * rng.standard_normal(mesh.p.shape) * inner,
                 mesh.t)
        tind = rng.permutation(mesh.nelements)[:mesh.nelements // 2]
        X = rng.random((mesh.dim(), tind.size, 5))
        X[:, 0, 0] = 0.                               # zeros of the fields
        fields = compiled_fields(elem, PointMapping(mesh), X, tind)
        expected = _h1_fields(elem, elem.doflocs.shape[0],
                              PointMapping(mesh), X, tind)
        for got, want in zip(fields, expected):
            assert got.shape == want.shape
            assert np.array_equal(got, want)
            assert np.array_equal(np.signbit(got), np.signbit(want))
        flat = M(mesh.p * np.r_[1., np.zeros(mesh.dim() - 1)][:, None],
                 mesh.t)                          # every determinant zero
        assert compiled_fields(elem, PointMapping(flat), X, tind) is None
        monkeypatch.setenv("SKFEM_MPM_KERNELS", "numpy")
        assert compiled_fields(elem, PointMapping(mesh), X, tind) is None
        monkeypatch.setenv("SKFEM_MPM_KERNELS", "auto")
    mesh = MeshQuad().refined(2)
    assert compiled_fields(ElementQuad2(), PointMapping(mesh),
                           rng.random((2, 4, 2)), np.arange(4)) is None


@pytest.mark.slow
def test_compiled_slots_equal_the_numpy_layout(monkeypatch):
    """The compiled slot layout of a basis over all points (``kernels=
    "auto"``) is the numpy path's array for array, dtypes included: the
    points of random cells (unsorted, one to nine a cell, empty cells
    between) by element in a stable order, padding at each element's
    first point; and the basis built on it is the numpy path's."""
    pytest.importorskip("numba")
    from skfem_mpm.kernels.basis import point_slots
    from skfem_mpm.quadrature.basis import _slots
    rng = np.random.default_rng(1)
    tind = rng.choice(np.arange(0, 60, 3), size=200)
    X = rng.random((3, 200))
    volume = rng.random(200)
    got = point_slots(tind, X, volume)
    want = _slots(tind, X, volume, np.arange(200))
    assert len(got) == len(want) + 1
    for a, b in zip(got, want):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    mesh = MeshQuad().refined(3)
    points = seed_points(mesh, 3)
    points.x[:, ::7] += .01                      # some cells hold fewer
    bases = []
    for kernels in ("auto", "numpy"):
        monkeypatch.setenv("SKFEM_MPM_KERNELS", kernels)
        bases.append(MaterialPointBasis(mesh, ElementQuad1(), points))
    for name in ("tind", "X", "dx", "point_index", "_slot_of_point",
                 "_padding"):
        assert np.array_equal(getattr(bases[0], name),
                              getattr(bases[1], name)), name
    # the groups the compiled layout formed are the numpy path's
    assert bases[0]._groups is not None and bases[1]._groups is None
    for a, b in zip(bases[0].groups(), bases[1].groups()):
        assert a.dtype == b.dtype == np.int64 and np.array_equal(a, b)
    # handed over (the kernel layout's): forgotten, formed again if asked
    taken = bases[0].groups(keep=False)
    assert bases[0]._groups is None
    for a, b in zip(taken, bases[0].groups()):
        assert a is not b and np.array_equal(a, b)
    for a, b in zip(bases[0].scalar_fields(), bases[1].scalar_fields()):
        assert np.array_equal(a, b)


def test_the_fields_are_made_when_first_asked_for():
    """A load step's basis of a scalar H1 element forms its values and
    gradients in one pass and scikit-fem's per-function fields only when
    ``basis`` is read (the compiled passes never read them): then views
    of those arrays, and ``share_gradients`` before or after reaches
    them alike."""
    from skfem import Dofs
    mesh = MeshQuad().refined(2)
    points = seed_points(mesh, 2)
    bases = [MaterialPointBasis(mesh, ElementQuad1(), points,
                                dofs=Dofs(mesh, ElementQuad1()))
             for _ in range(2)]
    assert all(b._basis is None for b in bases)
    values, gradients = bases[0].scalar_fields()
    fields = bases[0].basis
    assert len(fields) == 4 and bases[0]._basis is fields
    for i, (field,) in enumerate(fields):
        assert np.shares_memory(field, values)
        assert np.array_equal(field.grad, gradients[i])
    for basis in bases:                  # fields made, and not made yet
        values, gradients = basis.scalar_fields()
        first = np.ascontiguousarray(gradients.transpose(2, 3, 0, 1))
        basis.share_gradients(first.transpose(2, 3, 0, 1))
    assert bases[1]._basis is None
    for basis in bases:
        assert all(np.shares_memory(field.grad, basis.scalar_fields()[1])
                   for (field,) in basis.basis)


@pytest.mark.parametrize("elem", ["ElementQuad1", "ElementQuad2"])
def test_operator_slivers_are_the_value_matrix_ones(elem):
    """A step's sliver nodes found from the operator's shape values
    (:func:`~skfem_mpm.solve.dynamics.operator_slivers`, no value matrix
    formed) are the value matrix's (:func:`~skfem_mpm.solve.dynamics.
    sliver_nodes`), negative shape values (quadratic elements) by their
    size: points clustered in one corner leave the far nodes empty, and
    a point's tiny volume makes its nodes slivers."""
    import skfem
    from skfem_mpm.methods.operators import PointOperator
    from skfem_mpm.solve.dynamics import (operator_slivers,
                                          operator_supports, sliver_nodes,
                                          value_matrix)
    mesh = MeshQuad.init_tensor(*[np.linspace(0., 1., 5)] * 2)
    points = arbitrary_points(mesh, 60, seed=3, clustered=True)
    volume = np.full(points.n, 1e-2)
    volume[np.argmax(points.x[0] + points.x[1])] = 1e-9
    op = PointOperator(MaterialPointBasis(mesh, getattr(skfem, elem)(),
                                          points))
    assert (op.basis.point_index < 0).any()               # padding slots
    assert (op.shape_values < 0).any() == (elem == "ElementQuad2")
    least = 1e-3 / 16
    expected = sliver_nodes(value_matrix(op), volume, least)
    found = operator_slivers(op, volume, least)
    assert 0 < expected.size < op.N // 2
    assert found.tolist() == expected.tolist()
    # the weights formed in place: the sums of the product formed apart,
    # to the bit (the same products, summed in the same order)
    rows = op.basis.point_index
    weights = np.abs(op.shape_values) * np.where(rows >= 0, volume[rows],
                                                 0.)[None]
    before = np.bincount(np.broadcast_to(op.scalar_dofs[:, :, None],
                                         weights.shape).ravel(),
                         weights.ravel(), minlength=op.N // op.dim)
    assert np.array_equal(operator_supports(op, volume), before)
