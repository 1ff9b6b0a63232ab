"""A material-point basis in a user's own forms: scikit-fem's basis
methods (with_element, with_elements, split_bases), the quadrature field's
input, a thinly seeded basis's warning and seed_gauss_points' rules with
negative weights (user trial 101)."""
import logging

import numpy as np
import pytest
from skfem import (BilinearForm, ElementHex2, ElementQuad1, ElementQuad2,
                   ElementTriP1, ElementTriP2, ElementVector, LinearForm,
                   MeshHex, MeshQuad, MeshTet, MeshTri, asm)
from skfem.helpers import dot, grad
from skfem.models.elasticity import linear_elasticity
from skfem.quadrature import get_quadrature

from skfem_mpm import (InvalidInputError, MaterialPointBasis,
                       MaterialPoints, locate_points, seed_gauss_points,
                       seed_points)

LAPLACE = BilinearForm(lambda u, v, w: dot(grad(u), grad(v)) * (1 + w.x[0]))
LOAD = LinearForm(lambda v, w: np.sin(3 * w.x[0]) * v)
ELASTIC = linear_elasticity(1.3, .7)
VECTOR_LOAD = LinearForm(lambda v, w: dot(w.x, v))


def random_points(mesh, n=300, seed=0):
    """Points scattered over the unit square: uneven counts per cell."""
    x = np.random.default_rng(seed).random((2, n))
    return MaterialPoints(x=x, volume=np.full(n, 1. / n))


def assert_same_basis(a, b):
    """Two material-point bases alike: slots, volumes and forms."""
    assert np.array_equal(a.tind, b.tind)
    assert np.array_equal(a.point_index, b.point_index)
    assert np.array_equal(a.subset, b.subset)
    assert np.array_equal(a.dx, b.dx) and np.array_equal(a.X, b.X)
    form, load = (ELASTIC, VECTOR_LOAD) \
        if isinstance(a.elem, ElementVector) else (LAPLACE, LOAD)
    assert abs(asm(form, a) - asm(form, b)).max() == 0.
    assert np.array_equal(asm(load, a), asm(load, b))
    field = np.random.default_rng(1).random((2, a._npoints))
    assert np.array_equal(a.quadrature_field(field),
                          b.quadrature_field(field))
    slots = np.random.default_rng(2).random(a.dx.shape)
    assert np.array_equal(a.point_values(slots), b.point_values(slots))


@pytest.mark.parametrize("kernels", ["numpy", "auto"])
@pytest.mark.parametrize("points", [seed_points, random_points])
def test_with_element_equals_a_fresh_basis(points, kernels):
    mesh = MeshQuad().refined(3)
    mp = points(mesh, 2) if points is seed_points else points(mesh)
    basis = MaterialPointBasis(mesh, ElementQuad1(), mp, kernels=kernels)
    for elem in (ElementQuad2(), ElementVector(ElementQuad2())):
        assert_same_basis(basis.with_element(elem),
                          MaterialPointBasis(mesh, elem, mp,
                                             kernels=kernels))


@pytest.mark.parametrize("points", [seed_points, random_points])
def test_with_elements_equals_a_fresh_basis_of_their_points(points):
    mesh = MeshQuad().refined(3)
    mp = points(mesh, 2) if points is seed_points else points(mesh)
    basis = MaterialPointBasis(mesh, ElementQuad1(), mp)
    left = lambda x: x[0] < .5                       # noqa: E731
    cells = mesh.elements_satisfying(left)
    # the points in the left cells, located anew
    subset = np.flatnonzero(np.isin(locate_points(mesh, mp.x)[0], cells))
    fresh = MaterialPointBasis(mesh, ElementQuad1(), mp, subset=subset)
    for elements in (left, cells, np.isin(np.arange(mesh.nelements),
                                          cells)):
        assert_same_basis(basis.with_elements(elements), fresh)
    assert_same_basis(basis.with_elements(), basis)


def test_with_elements_of_no_points_is_refused():
    mesh = MeshQuad().refined(2)
    basis = MaterialPointBasis(mesh, ElementQuad1(), seed_points(
        mesh, 2, region=lambda x: x[0] < .5))
    with pytest.raises(InvalidInputError, match="none of the 8 element"):
        basis.with_elements(lambda x: x[0] > .5)


def test_split_bases_of_a_vector_basis():
    mesh = MeshQuad().refined(2)
    mp = seed_points(mesh, 2)
    basis = MaterialPointBasis(mesh, ElementVector(ElementQuad1()), mp)
    parts = basis.split_bases()
    assert len(parts) == 2
    for part in parts:
        assert_same_basis(part, MaterialPointBasis(mesh, ElementQuad1(), mp))
    u = np.arange(basis.N, dtype=float)
    (ux, bx), (uy, by) = basis.split(u)
    assert np.array_equal(ux, u[0::2]) and np.array_equal(uy, u[1::2])


def test_quadrature_field_refuses_another_count():
    mesh = MeshQuad().refined(2)
    mp = seed_points(mesh, 2)
    basis = MaterialPointBasis(mesh, ElementQuad1(), mp)
    assert basis.quadrature_field(np.ones(mp.n)).shape == basis.dx.shape
    for n in (mp.n + 36, 7):
        with pytest.raises(InvalidInputError,
                           match=r"shape \({},\).*{} points".format(n, mp.n)):
            basis.quadrature_field(np.ones(n))
    with pytest.raises(InvalidInputError, match=r"shape \(2, 3\)"):
        basis.quadrature_field(np.ones((2, 3)))
    # a subset's basis takes the values of all points
    half = MaterialPointBasis(mesh, ElementQuad1(), mp,
                              subset=np.arange(0, mp.n, 2))
    assert half.quadrature_field(np.ones(mp.n)).sum() == mp.n // 2


@pytest.mark.parametrize("mesh, elem, n, thin", [
    (MeshTri().refined(2), ElementTriP2(), 1, True),     # 2 of 5
    (MeshTri().refined(2), ElementTriP2(), 2, False),    # 8 of 5
    (MeshQuad().refined(2), ElementQuad2(), 1, True),    # 2 of 8
    (MeshQuad().refined(2), ElementQuad2(), 2, False),   # 8 of 8
    (MeshHex().refined(1), ElementHex2(), 2, True),      # 24 of 26
    (MeshHex().refined(1), ElementHex2(), 3, False),
    (MeshTri().refined(2), ElementTriP1(), 1, False),    # 2 of 2
])
def test_a_thinly_seeded_basis_is_warned(mesh, elem, n, thin, caplog):
    mp = seed_points(mesh, n)
    for e in (elem, ElementVector(elem)):
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
            basis = MaterialPointBasis(mesh, e, mp)
        warned = [r.getMessage() for r in caplog.records
                  if "zero-energy" in r.getMessage()]
        assert bool(warned) == thin
        if not thin:
            continue
        nloc, c = elem.doflocs.shape[0], 1 if e is elem else mesh.dim()
        assert "rank at most {} a cell, below the {} its".format(
            c * mesh.dim() * basis.dx.shape[1], c * (nloc - 1)) in warned[0]
        if e is elem:      # its Laplacian is singular beyond the constants
            K = asm(BilinearForm(lambda u, v, w: dot(grad(u), grad(v))),
                    basis).toarray()
            assert np.linalg.matrix_rank(K) < K.shape[0] - 1


def test_the_runs_own_bases_are_not_warned(caplog):
    """A basis given its points' location (the solvers') is not checked:
    the runs check their own seeding (underintegrated_cells)."""
    mesh = MeshTri().refined(2)
    mp = seed_points(mesh, 1)
    with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
        MaterialPointBasis(mesh, ElementTriP2(), mp,
                           location=locate_points(mesh, mp.x))
    assert not caplog.records


@pytest.mark.parametrize("mesh", [MeshTri(), MeshTet()])
def test_rules_with_negative_weights_are_refused(mesh):
    for order in range(10):
        try:
            _, W = get_quadrature(mesh.refdom, order)
        except NotImplementedError:
            break
        if (W > 0).all():
            mp = seed_gauss_points(mesh, order)
            assert np.isclose(mp.volume.sum(), 1.)   # the unit square, cube
            continue
        below = [k for k in range(order) if
                 (get_quadrature(mesh.refdom, k)[1] > 0).all()]
        with pytest.raises(InvalidInputError) as err:
            seed_gauss_points(mesh, order)
        message = str(err.value)
        assert "order {} on {}".format(order, mesh.refdom.__name__) \
            in message
        assert "{:.6g}".format(W.min()) in message
        assert "take order {}".format(below[-1]) in message
        for k in range(order + 1, order + 5):     # the next one that works
            try:
                if (get_quadrature(mesh.refdom, k)[1] > 0).all():
                    assert "or {}".format(k) in message
                    break
            except NotImplementedError:
                break


def test_vector_forms_on_the_other_element():
    """linear_elasticity on with_element's basis: a fresh one's matrix."""
    mesh = MeshQuad().refined(2)
    mp = seed_points(mesh, 3)
    basis = MaterialPointBasis(mesh, ElementQuad1(), mp)
    elem = ElementVector(ElementQuad2())
    form = linear_elasticity(1., 1.)
    assert abs(asm(form, basis.with_element(elem))
               - asm(form, MaterialPointBasis(mesh, elem, mp))).max() == 0.


def poisson_errors(elem, n, points):
    """L2 and H1 errors of -lap u = 2 pi^2 sin(pi x) sin(pi y), u = 0 on
    the unit square's sides, of n x n cells, assembled on ``points``."""
    from skfem import Basis, Functional, condense, solve
    from skfem.models.poisson import laplace
    mesh = MeshQuad().refined(int(np.log2(n)))
    pi = np.pi
    basis = MaterialPointBasis(mesh, elem, points(mesh))
    f = LinearForm(lambda v, w: 2 * pi ** 2 * np.sin(pi * w.x[0])
                   * np.sin(pi * w.x[1]) * v)
    u = solve(*condense(asm(laplace, basis), asm(f, basis),
                        D=basis.get_dofs().all()))
    fine = Basis(mesh, elem, intorder=8)
    uh = fine.interpolate(u)

    def exact(x):
        return np.sin(pi * x[0]) * np.sin(pi * x[1]), pi * np.array([
            np.cos(pi * x[0]) * np.sin(pi * x[1]),
            np.sin(pi * x[0]) * np.cos(pi * x[1])])
    l2 = Functional(lambda w: (w.uh - exact(w.x)[0]) ** 2)
    h1 = Functional(lambda w: ((w.uh.grad - exact(w.x)[1]) ** 2).sum(0))
    return (np.sqrt(l2.assemble(fine, uh=uh)),
            np.sqrt(h1.assemble(fine, uh=uh)))


def test_quadratic_cells_lose_an_order_on_equal_sub_cell_points():
    """The README's numbers: the sub-cells' centres integrate exactly
    only what is linear in a cell, so Q2 on them converges as h in H1
    (h^2 in L2), on Gauss points as h^2 (h^3)."""
    def rates(points):
        errors = np.array([poisson_errors(ElementQuad2(), n, points)
                           for n in (8, 16, 32)])
        return np.log2(errors[-2] / errors[-1])
    assert np.allclose(rates(lambda m: seed_points(m, 2)), [2., 1.],
                       atol=.05)
    assert np.allclose(rates(lambda m: seed_gauss_points(m, 3)), [3., 2.],
                       atol=.05)


def test_a_runs_equilibrium_holds_on_the_positions_before_the_update():
    """The README's column after one step: its own reaction on a basis of
    the points' initial positions is the weight, on the final positions
    not."""
    from skfem.helpers import ddot, sym_grad
    from skfem_mpm import LinearElastic, simulate
    mesh = MeshQuad.init_tensor(np.linspace(0, 4, 5), np.linspace(0, 12, 13))
    points = seed_points(mesh, 2, region=lambda x: x[1] < 10)
    weight = 800. * 4 * 10
    for method in ("mpm", "cpgimp"):
        result = simulate(mesh, ElementQuad1(), points,
                          LinearElastic(1e6, .3),
                          supports=lambda b: b.get_dofs(
                              lambda x: x[1] == 0),
                          body_force=[0., -800.], nsteps=1, method=method)
        done = result.points
        assert (result.basis is None) == (method == "cpgimp")
        reactions = []
        for x in (done.x0, done.x):
            basis = MaterialPointBasis(mesh, ElementVector(ElementQuad1()),
                                       MaterialPoints(x=x,
                                                      volume=done.volume))
            residual = asm(LinearForm(lambda v, w: ddot(w.sig, sym_grad(v))
                                      + 800. * v[1]), basis,
                           sig=basis.quadrature_field(done.stress[:2, :2]))
            floor = basis.get_dofs(lambda x: x[1] == 0).nodal["u^2"]
            reactions.append(residual[floor].sum())
        assert abs(reactions[0] - weight) < 1e-9 * weight
        assert abs(reactions[1] - weight) > 1e-4 * weight
