"""Mean dilatation with GIMP (issue 29, item 4): the volume average of the
dilatation over the points whose centre lies in each cell (Coombs et al.
2018), whose GIMP gradients reach the neighbouring cells, unlocks nearly
incompressible GIMP bodies as B-bar unlocks standard MPM and finite
elements; homogeneous deformations, Newton's quadratic rate and plane
strain as 3D with ``u_z = 0`` are kept."""
import numpy as np
import pytest
from skfem import ElementHex1, ElementQuad1, MeshHex, MeshQuad

from skfem_mpm import (LinearElastic, MaterialPoints, Options, Stabilisation,
                       VonMises, seed_points, simulate)
from skfem_mpm.methods.gimp_linear import LinearGimp
from skfem_mpm.solve.newton import NewtonOptions
from skfem_mpm.stabilisation.volumetric import CellPatchAverage, \
    MeanDilatation


def options(antilocking, tol=1e-9):
    return Options(newton=NewtonOptions(tol=tol),
                   stabilisation=Stabilisation(antilocking=antilocking))


def crossing(grid, points) -> bool:
    """Some point's domain reaches more than 1e-9 past a grid line along
    some axis (its GIMP operator then differs from standard MPM's)."""
    for d in range(grid.dim()):
        lines = np.unique(grid.p[d])
        lo, hi = (points.x[d] + s * (points.domain[d] - 1e-9)
                  for s in (-1, 1))
        if (np.searchsorted(lines, lo, side="right")
                < np.searchsorted(lines, hi, side="left")).any():
            return True
    return False


def random_gimp(mesh, elem, n, rng):
    """A GIMP operator of n points scattered over the grid with domain
    half-lengths 0.1 to 0.3 (cells of 1 or 0.5: most domains cross cell
    boundaries)."""
    dim = mesh.dim()
    lo, hi = mesh.p.min(axis=1), mesh.p.max(axis=1)
    x = lo[:, None] + (hi - lo)[:, None] * rng.uniform(.05, .95, (dim, n))
    op = LinearGimp(mesh, elem)(x, rng.uniform(.1, .3, (dim, n)))
    op.point_elements = mesh.element_finder()(*x)
    return op


@pytest.mark.parametrize("mesh, elem", [
    (MeshQuad.init_tensor(np.linspace(0, 3, 4), np.linspace(0, 2, 3)),
     ElementQuad1()),
    (MeshHex.init_tensor(np.linspace(0, 2, 3), np.linspace(0, 2, 3),
                         np.linspace(0, 1, 3)), ElementHex1())],
    ids=["2d", "3d"])
def test_cell_patch_operator_is_linear_and_its_own_derivative(mesh, elem):
    """40 GIMP points with random domains (crossing cell boundaries),
    weights, volumes, displacement and a random non-symmetric tangent A
    (3x3x3x3 per point, also one tensor for all): the tangent is the exact
    derivative of the force, ``stiffness(A) u = force(A : grad_bar(u))``
    to 1e-13 of the force (measured 2e-16 to 8e-16: Newton's quadratic
    rate needs no more); ``theta_c`` is the volume average of the
    divergence over the points whose centre lies in the cell (to 1e-14,
    against a bincount); a linear field keeps its gradient (1e-14)."""
    rng = np.random.default_rng(0)
    dim, n = mesh.dim(), 40
    op = random_gimp(mesh, elem, n, rng)
    volume, w = rng.uniform(.5, 1.5, (2, n))
    bar = MeanDilatation(op, volume)
    assert isinstance(bar.average, CellPatchAverage)
    # a cell's average reaches the nodes of its neighbours (measured 16
    # DOFs a cell at the most in 2D, 64 in 3D, against the cell's 8 and 24)
    assert bar.average.B.getnnz(axis=1).max() > dim * 2 ** dim
    u = rng.normal(size=op.N)
    for A in (rng.normal(size=(3, 3, 3, 3, n)),
              np.broadcast_to(rng.normal(size=(3, 3, 3, 3, 1)),
                              (3, 3, 3, 3, n))):
        f = bar.force(np.einsum("abcdp,cdp->abp", A, bar.gradients(u)), w)
        K = bar.stiffness(A, w)
        assert np.abs(K @ u - f).max() < 1e-13 * np.abs(f).max()
    div = np.einsum("aap->p", op.gradients(u))
    cell = op.point_elements
    theta = np.bincount(cell, volume * div) / np.maximum(
        np.bincount(cell, volume), 1e-300)
    assert np.abs(bar.average.at_points(u) - theta[cell]).max() < 1e-14 \
        * np.abs(theta).max()
    H = rng.normal(size=(dim, dim))
    linear = (H @ mesh.p).T.ravel()
    g = bar.gradients(linear)
    assert np.abs(g[:dim, :dim] - H[:, :, None]).max() < 1e-14 * np.abs(
        H).max()
    scale = np.abs(H).max()
    assert np.abs(g[dim:]).max(initial=0.) < 1e-14 * scale   # out of plane
    assert np.abs(g[:, dim:]).max(initial=0.) < 1e-14 * scale


def block(method, antilocking, kinematics="small"):
    """A 2 x 1 block on a grid of h = 0.5 under gravity, clamped at its
    base, 2x2 points per cell seeded on the grid: every GIMP domain lies
    in its cell."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 3, 7), np.linspace(0, 2, 5))
    points = seed_points(mesh, 2, region=lambda x: (x[0] < 2) & (x[1] < 1))
    assert not crossing(mesh, points)
    return simulate(mesh, ElementQuad1(), points, LinearElastic(1e3, .45),
                    lambda b: b.get_dofs(lambda x: x[1] == 0),
                    body_force=[0., -10.], method=method,
                    kinematics=kinematics,
                    options=options(antilocking)).points


@pytest.mark.parametrize("method", ["ugimp", "cpgimp"])
def test_cell_patch_is_the_element_average_where_domains_stay_in_cells(
        method):
    """Where every domain lies inside its cell a GIMP point's weights and
    gradients are those of standard MPM at its centre, and the cell patch
    holds the element's points: with mean dilatation GIMP then gives
    standard MPM's answer (one small-strain step, to 1e-12 of the
    displacement; measured 1.4e-15), two forms of one average, which
    acts (14% of the displacement)."""
    gimp, mpm = block(method, True), block("mpm", True)
    scale = np.abs(mpm.displacement).max()
    assert np.abs(gimp.displacement - mpm.displacement).max() < 1e-12 * scale
    assert np.abs(gimp.displacement - block(method, False).displacement
                  ).max() > 1e-3 * scale           # the average does act


@pytest.mark.parametrize("method", ["ugimp", "cpgimp"])
@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_gimp_patch_test_with_mean_dilatation(method, kinematics):
    """A block filling a 2 x 1 grid of h = 0.25, its points seeded 2x2 in
    cells of 1/3 (domains tile the block and cross grid lines), stretched
    and sheared homogeneously by its boundary nodes (``u = H x``): the
    solution is homogeneous with and without mean dilatation, displacement
    ``H x0`` to 1e-15 (measured 1e-17), stresses uniform and equal to
    1e-12 of their size (measured 7e-15 to 1.7e-14).  (Standard MPM with
    these points, which are no quadrature of the cells, fails it: its
    stresses vary by 65% of their size.)"""
    grid = MeshQuad.init_tensor(np.linspace(0, 2, 9), np.linspace(0, 1, 5))
    body = MeshQuad.init_tensor(np.linspace(0, 2, 7), np.linspace(0, 1, 4))
    points = seed_points(body, 2)
    assert crossing(grid, points)
    H = np.array([[.01, .004], [-.002, -.006]])
    boundary = grid.nodes_satisfying(lambda x: (x[0] == 0) | (x[0] == 2)
                                     | (x[1] == 0) | (x[1] == 1))

    def prescribed(basis, f_old, f_new):
        dofs = basis.nodal_dofs[:, boundary]
        return dofs.T.ravel(), ((f_new - f_old) * H @ grid.p[:, boundary]
                                ).T.ravel()
    runs = [simulate(grid, ElementQuad1(), points, LinearElastic(1e3, .45),
                     np.array([], dtype=np.int64), prescribed=prescribed,
                     method=method, kinematics=kinematics,
                     options=options(a)).points for a in (False, True)]
    scale = np.abs(runs[0].stress).max()
    assert scale > 1.
    for run in runs:
        assert np.abs(run.displacement - H @ run.x0).max() < 1e-15
        assert np.ptp(run.stress, axis=-1).max() < 1e-12 * scale
    assert np.abs(runs[0].stress - runs[1].stress).max() < 1e-12 * scale


def beam(L, h, per_cell, load, room, shift=.3):
    """A beam L x 1 clamped at x = 0: a body-fitted mesh of h, its points
    (``per_cell`` per cell and axis) with the downward ``load`` shared by
    the points at the tip (returned), and a grid of h whose lines lie
    ``shift`` h off the beam's faces (GIMP domains cross them), ``room``
    cells beyond the tip and below the beam."""
    body = MeshQuad.init_tensor(np.arange(0, L + h / 2, h),
                                np.arange(-.5, .5 + h / 2, h))
    grid = MeshQuad.init_tensor(np.arange(0, L + (room + .5) * h, h),
                                np.arange(-.5 - (room + shift) * h,
                                          .5 + 2 * h - shift * h, h))
    points = seed_points(body, per_cell)
    assert crossing(grid, points)
    tip = np.flatnonzero(np.isclose(points.x[0], points.x[0].max()))
    points.force[1, tip] = -load / tip.size
    return body, grid, points, tip


def cantilever(method, antilocking, kinematics, L=10.):
    """A plane-strain cantilever L x 1 (nu = 0.499, :func:`beam` with h =
    0.25 and 3x3 points per cell) under a tip load P; ``fem`` runs on the
    body-fitted mesh, the other methods on the grid.  Returns the tip
    deflection over the beam answer with shear,
    ``P L^3 / (3 E' I) + P L / (k G A)``."""
    E, P, nu = 1e3, 1e-2, .499
    body, grid, points, tip = beam(L, .25, 3, P, room=1)
    res = simulate(body if method == "fem" else grid, ElementQuad1(), points,
                   LinearElastic(E, nu),
                   lambda b: b.get_dofs(lambda x: x[0] == 0), method=method,
                   kinematics=kinematics, options=options(antilocking, 1e-8))
    assert res.history[-1].residual <= 1e-8
    answer = P * L ** 3 / (3 * E / (1 - nu ** 2) / 12) \
        + P * L / (5 / 6 * E / (2 * (1 + nu)))
    return -res.points.displacement[1, tip].mean() / answer


@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_nearly_incompressible_cantilever_with_cpgimp(kinematics):
    """The cantilever at nu = 0.499 with domains crossing grid lines:
    cpGIMP with mean dilatation within 2% of standard MPM with it (same
    grid and points; measured 0.998) and of finite elements with B-bar
    (body-fitted; measured 0.992), in both kinematics (0.987 of the beam
    answer, FE 0.995); without it cpGIMP locks (measured 0.18 of the
    deflection with it: below 0.8), as MPM does (0.15 of its
    deflection)."""
    gimp = cantilever("cpgimp", True, kinematics)
    mpm = cantilever("mpm", True, kinematics)
    fem = cantilever("fem", True, kinematics)
    locked = cantilever("cpgimp", False, kinematics)
    assert abs(gimp / mpm - 1) < .02
    assert abs(gimp / fem - 1) < .02
    assert abs(fem - 1) < .02                     # B-bar FE: the beam
    assert locked < .8 * gimp


@pytest.mark.parametrize("method", ["ugimp", "cpgimp"])
def test_newton_stays_quadratic_with_plasticity_finite_strain_and_gimp(
        method):
    """A von Mises cantilever 4 x 1 (E = 1e3, nu = 0.3, yield stress 20)
    with domains crossing grid lines, under a tip load of 1.6 in six
    finite-deformation steps, mean dilatation and no ghost penalty: its
    root yields (measured 11 and 40 points in the last two steps), the tip
    moves 0.53, and Newton converges quadratically: every pair of
    residuals (r_k, r_k+1) with r_k < 1e-2 above the round-off floor
    (1e-11) has ``r_k+1 <= 10 r_k^2`` and ``log r_k+1 / log r_k >= 1.8``
    (measured at most 3.3 r_k^2 and at least 1.90; the last step:
    0.72, 1.7, 1.2, 0.53, 0.13, 4.6e-3, 1.5e-5, 6.4e-11)."""
    _, grid, points, tip = beam(4., .25, 2, 1.6, room=3)
    res = simulate(grid, ElementQuad1(), points, VonMises(1e3, .3, 20.),
                   lambda b: b.get_dofs(lambda x: x[0] == 0), method=method,
                   kinematics="finite", nsteps=6,
                   options=Options(newton=NewtonOptions(tol=1e-10),
                                   stabilisation=Stabilisation(
                                       ghost=0., antilocking=True)))
    assert res.counters["stabilised_solves"] == 0
    assert len(res.history) == 6                  # no step was cut back
    assert res.history[-1].n_yielded > 20
    assert -res.points.displacement[1, tip].mean() > .4
    pairs = [(a, b) for r in res.history
             for a, b in zip(r.newton_residuals[:-1], r.newton_residuals[1:])
             if a < 1e-2 and b > 1e-11]
    assert len(pairs) >= 6
    assert all(b <= 10 * a ** 2 for a, b in pairs), pairs
    assert min(np.log(b) / np.log(a) for a, b in pairs) >= 1.8


def plane_and_layer(method, kinematics, antilocking):
    """A cantilever 3 x 1 under its weight (nu = 0.45) on a grid of h = 0.5
    whose lines lie 0.15 off its faces (2x2 points per cell of a
    body-fitted mesh: domains cross them), in plane strain and as one
    layer of hexahedra 1 thick with every ``u_z`` held and one point
    through the thickness (its domain the layer): the points of both."""
    xs, ys = np.linspace(0, 3, 7), np.linspace(-1, 1, 5) + .15
    body = MeshQuad.init_tensor(xs, np.linspace(-.5, .5, 3))
    points = seed_points(body, 2)
    points3 = MaterialPoints(
        x=np.vstack((points.x, np.full(points.n, .5))),
        volume=points.volume.copy(),
        domain=np.vstack((points.domain, np.full(points.n, .5))))
    plane = MeshQuad.init_tensor(xs, ys)
    assert crossing(plane, points)

    def clamped(b):
        return b.get_dofs(lambda x: x[0] == 0)

    def clamped_flat(b):
        return np.concatenate((clamped(b).all(), b.get_dofs().nodal["u^3"]))
    return [simulate(mesh, elem, pts, LinearElastic(1e3, .45), supports,
                     body_force=g, nsteps=2, method=method,
                     kinematics=kinematics, options=options(antilocking)
                     ).points
            for mesh, elem, pts, supports, g in (
                (plane, ElementQuad1(), points, clamped, [0., -3.]),
                (MeshHex.init_tensor(xs, ys, np.array([0., 1.])),
                 ElementHex1(), points3, clamped_flat, [0., -3., 0.]))]


@pytest.mark.parametrize("method", ["ugimp", "cpgimp"])
@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_plane_strain_gimp_mean_dilatation_is_3d_with_uz_held(method,
                                                              kinematics):
    """GIMP with mean dilatation in plane strain equals one layer of
    hexahedra with ``u_z`` held: displacements and 3x3 stresses to 1e-10
    of the largest (measured 4e-16 to 2e-14), as without it; the average
    acts (the tip moves 1.15 times as far: more than 1.1)."""
    tip = {}
    for antilocking in (False, True):
        plane, layer = plane_and_layer(method, kinematics, antilocking)
        u = plane.displacement
        assert np.abs(u - layer.displacement[:2]).max() < 1e-10 * np.abs(
            u).max()
        assert np.abs(plane.stress - layer.stress).max() < 1e-10 * np.abs(
            plane.stress).max()
        tip[antilocking] = -u[1].min()
    assert tip[True] > 1.1 * tip[False]
