"""F-bar on the increment (:mod:`skfem_mpm.stabilisation.fbar`): mean
dilatation in finite deformation for the methods whose points move.  The
additive mean dilatation averaged the increment's linearised volume
change, and each point's ``det dF`` kept second-order terms of its own,
which a nearly incompressible body turns into pressures that oscillate
inside a cell; now every point of a cell changes its volume by its
cell's ratio, and the tangent is the derivative of the force."""
import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from collections import Counter

from skfem_mpm import (LinearElastic, NewtonOptions, Options, Stabilisation,
                       VonMises, seed_gauss_points, seed_points, simulate)
from skfem_mpm.errors import InvalidInputError
from skfem_mpm.mechanics.kinematics import FiniteStrain
from skfem_mpm.stabilisation.fbar import IncrementFbar

from test_compiled import block, operator


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("method", ["mpm", "gimp"])
def test_fbar_tangent_is_the_derivative_of_its_force(dim, method):
    """A nonlinear stress ``P = C : g + (g : g) g`` of the F-bar gradients
    ``g = dF_bar - I`` of a random increment (volume ratios 0.3 to 1.6):
    the stiffness times a direction is the central difference of the
    force to ``1e-6`` at ``h = 1e-5`` (the difference's own error,
    measured 3e-9 to 3e-8, falling as h^2); every point of a cell has
    its cell's ``det dF_bar = J_c`` (to 1e-12)."""
    mesh, points = block(dim)
    op = operator(method, mesh, points, dim)
    rng = np.random.default_rng(1)
    C = rng.normal(size=(3, 3, 3, 3))
    C = C + C.transpose(2, 3, 0, 1)
    volume = points.volume * rng.uniform(.5, 1.5, points.n)
    w = rng.uniform(.5, 1.5, points.n)
    bar = IncrementFbar(op, volume)

    def P_of(g):
        return np.einsum("abcd,cdp->abp", C, g) \
            + np.einsum("cdp,cdp->p", g, g) * g

    def A_of(g):
        A = np.broadcast_to(C[..., None], C.shape + g.shape[-1:]).copy()
        A += np.einsum("ac,bd,p->abcdp", np.eye(3), np.eye(3),
                       np.einsum("cdp,cdp->p", g, g))
        return A + 2 * np.einsum("abp,cdp->abcdp", g, g)

    def force(u):
        g = bar.gradients(u)
        return bar.force(P_of(g), w), g

    u = .05 * rng.normal(size=op.N)
    _, g = force(u)
    K = bar.stiffness(A_of(g), w)
    dF = np.moveaxis(g + np.eye(3)[:, :, None], -1, 0)
    J = np.linalg.det(dF)
    located = getattr(op, "point_elements", None)
    if located is None:
        located = mesh.element_finder()(*points.x)
    cell = np.unique(located, return_inverse=True)[1]
    Jp = np.linalg.det(np.moveaxis(op.gradients(u), -1, 0)
                       + np.eye(dim))
    Jc = np.bincount(cell, volume * Jp) / np.bincount(cell, volume)
    assert np.abs(J - Jc[cell]).max() < 1e-12
    assert np.ptp(Jc) > .3                       # large increments
    d = rng.normal(size=op.N)
    h = 1e-5
    fd = (force(u + h * d)[0] - force(u - h * d)[0]) / (2 * h)
    assert np.abs(K @ d - fd).max() < 1e-6 * np.abs(fd).max()


def cook(method, n, nsteps, antilocking="fbar"):
    """A user's Cook's membrane (plane strain, E = 250, nu = 0.4999, a
    total shear of 100 on the right edge, clamped on the left, finite
    deformation, ``antilocking``): finite elements on an n x n conforming
    mesh, or ``method`` on a grid of square cells 48 / n reaching y = 72
    (the tip rises about 7), 2 x 2 points a cell in the trapezoid.
    Returns the result and the point nearest the tip (48, 60)."""
    if method == "fem":
        from meshes import cooks_membrane
        mesh = cooks_membrane(n)
        points = seed_gauss_points(mesh, 2)
        edge = np.argsort(points.x[0])[::-1][:2 * n]
    else:
        mesh = MeshQuad.init_tensor(np.linspace(0, 48, n + 1),
                                    np.linspace(0, 72, 3 * n // 2 + 1))
        points = seed_points(mesh, 2, region=lambda x: (
            x[1] >= 44. / 48 * x[0]) & (x[1] <= 44 + x[0] / 3))
        edge = np.flatnonzero(np.isclose(points.x[0], points.x[0].max()))
    points.force[1, edge] = 100. / edge.size
    tip = np.argmin((points.x[0] - 48) ** 2 + (points.x[1] - 60) ** 2)
    options = Options(newton=NewtonOptions(tol=1e-9),
                      stabilisation=Stabilisation(antilocking=antilocking))
    return simulate(mesh, ElementQuad1(), points, LinearElastic(250., .4999),
                    lambda b: b.get_dofs(lambda x: np.isclose(x[0], 0.)),
                    nsteps=nsteps, method=method, kinematics="finite",
                    options=options), tip


@pytest.mark.slow
def test_mpm_cooks_membrane_at_nu_04999_in_finite_deformation():
    """Standard MPM, 16 cells across, 10 steps: with the additive mean
    dilatation (``antilocking=True``) its steps began at residuals of
    3.5-5.8 (pressures oscillating in the cells), 5 steps were cut back
    (14 steps, 528 iterations, 100 with the tangent stabilised, tip 6.54);
    with ``antilocking="fbar"`` every step starts near 1, none is cut
    back, none is stabilised (111 iterations), and the tip's vertical
    displacement is within 8% of finite elements' (the additive average)
    on a 16 x 16 conforming mesh computed here (measured 6.66 against
    6.25, at points a quarter cell from the corner; MPM on 32 cells
    6.78)."""
    res, tip = cook("mpm", 16, 10)
    assert len(res.history) == 10
    assert res.counters["stabilised_solves"] == 0
    assert max(r.newton_residuals[0] for r in res.history) < 2.
    fe, fe_tip = cook("fem", 16, 10, antilocking=True)
    mpm = res.history[-1].displacement[1, tip]
    assert mpm == pytest.approx(fe.history[-1].displacement[1, fe_tip],
                                rel=.08)


@pytest.mark.parametrize("method", ["mpm", "gimp"])
@pytest.mark.parametrize("material, yielded", [
    (LinearElastic(1e3, .4999), 0), (VonMises(1e3, .3, 12.), 49)])
def test_fbar_stiffness_is_the_derivative_of_the_hencky_force(
        method, material, yielded):
    """Through the finite-deformation kinematics (Hencky, numpy path) from
    a start with elastic strains (3e-3) and plastic strain (1e-2), an
    increment of 3e-3: the stiffness times a direction is the central
    difference of the internal force to 1e-7 at h = 1e-6 (measured 3e-8
    plastic, 1e-10 elastic: the difference's own error, falling as h^2;
    the yield set unchanged within it), at nu = 0.4999 and with von
    Mises yielding at 49 of 64 points or more."""
    mesh, points = block(2)
    op = operator(method, mesh, points, 2)
    rng = np.random.default_rng(1)
    points.state = {"equivalent_plastic_strain": np.full(points.n, .01)}
    S = rng.normal(size=(3, 3, points.n)) * .003
    S[2, :2] = S[:2, 2] = 0
    points.strain = S + S.transpose(1, 0, 2)
    kin = FiniteStrain(material, 2, Counter(), kernels="numpy")
    bar = IncrementFbar(op, points.volume)

    def force(u):
        r = kin.response(bar, u, points)
        return bar.force(r.P, r.w), r

    u = .003 * rng.normal(size=op.N)
    _, r = force(u)
    assert r.yielded.sum() >= yielded
    K = bar.stiffness(r.tangent(), r.w)
    d = rng.normal(size=op.N)
    h = 1e-6
    (fp, rp), (fm, rm) = force(u + h * d), force(u - h * d)
    assert (rp.yielded == r.yielded).all() and (rm.yielded == r.yielded).all()
    fd = (fp - fm) / (2 * h)
    assert np.abs(K @ d - fd).max() < 1e-7 * np.abs(fd).max()


def test_fbar_is_refused_where_points_do_not_move_or_strains_are_small():
    """``antilocking="fbar"`` in small strain or with finite elements:
    refused before any work, naming ``antilocking=True``; any other
    string refused by ``Stabilisation``."""
    mesh, points = block(2)
    for method, kinematics in (("mpm", "small"), ("fem", "finite")):
        with pytest.raises(InvalidInputError, match="antilocking=True"):
            simulate(mesh, ElementQuad1(), points, LinearElastic(1., .3),
                     lambda b: b.get_dofs(lambda x: x[1] < 0.), method=method,
                     kinematics=kinematics, options=Options(
                         stabilisation=Stabilisation(antilocking="fbar")))
    with pytest.raises(InvalidInputError, match="True, False or 'fbar'"):
        Stabilisation(antilocking="bbar")


def test_an_inverted_increment_is_an_inversion_error():
    """An increment that turns a point inside out (``det dF = 0`` exactly
    and below 0) raises the kinematics' :class:`InversionError`, not a
    NaN stress or numpy's error."""
    from skfem_mpm.errors import InversionError
    mesh, points = block(2)
    op = operator("mpm", mesh, points, 2)
    kin = FiniteStrain(LinearElastic(1e3, .3), 2, Counter(), kernels="numpy")
    bar = IncrementFbar(op, points.volume)
    X = mesh.p[:, :, None] * np.ones(1)
    for s in (-1., -1.5):                  # u_x = s x: det dF = 1 + s
        u = np.zeros((mesh.p.shape[1], 2))
        u[:, 0] = s * X[0, :, 0]
        with pytest.raises(InversionError):
            kin.response(bar, u.ravel(), points)


@pytest.mark.parametrize("fbar, random", [(False, True), (True, True),
                                           (False, False)])
def test_an_overflowing_increment_is_an_inversion_error_saying_so(fbar,
                                                                  random):
    """A diverging Newton trial (grid displacements of 1e200: its
    gradients overflow) raises the kinematics' :class:`InversionError`
    naming the trial's largest displacement, without numpy's overflow
    warnings (trial 58: 17 of them, and "det dF nan" unexplained)."""
    import warnings
    from skfem_mpm.errors import InversionError
    mesh, points = block(2)
    op = operator("mpm", mesh, points, 2)
    kin = FiniteStrain(LinearElastic(1e3, .3), 2, Counter(), kernels="numpy")
    # random, or a uniform expansion whose det dF overflows to +inf
    u = 1e200 * np.random.default_rng(2).uniform(-1, 1, op.N) if random \
        else 1e160 * np.asarray(mesh.p).T.ravel()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InversionError) as err:
            kin.response(IncrementFbar(op, points.volume) if fbar else op,
                         u, points)
    assert "not finite, the trial's largest grid displacement increment " \
        "{:.3g}".format(np.abs(u).max()) in str(err.value)


def test_fbar_force_has_the_round_off_of_the_additive_average():
    """At increments of 1e-4 (nu = 0.499: pressures 400 times the
    deviatoric stresses) the force's departure from its linearisation
    over 1e-12 of a direction, relative to the force, is round-off: below
    2e-15 as the additive average's (measured 5e-16 and 3e-16).  Formed
    as ``xi dF - I`` and ``det dF - 1`` it was 1.6e-13 (the cancellation
    of I), and the residual of a nu = 0.499 cantilever under a small load
    stalled at 1.1e-8 of it, above the tolerance of 1e-8."""
    from skfem_mpm.stabilisation.volumetric import MeanDilatation
    mesh, points = block(2)
    op = operator("mpm", mesh, points, 2)
    rng = np.random.default_rng(1)
    u, d = 1e-4 * rng.normal(size=(2, op.N))
    for kind in (MeanDilatation, IncrementFbar):
        kin = FiniteStrain(LinearElastic(1e3, .499), 2, Counter(),
                           kernels="numpy")
        bar = kind(op, points.volume)

        def force(u):
            r = kin.response(bar, u, points)
            return bar.force(r.P, r.w), r
        f0, r = force(u)
        K = bar.stiffness(r.tangent(), r.w)
        f1 = force(u + 1e-12 * d)[0]
        assert np.abs(f1 - f0 - 1e-12 * (K @ d)).max() \
            < 2e-15 * np.abs(f0).max(), kind.__name__
