"""The material protocol: a model written outside the package (von Mises
with linear isotropic hardening) runs through the core in small strain and
finite deformation, against the closed form; its internal variable is
carried through checkpoints (resume bit-identical) and into the VTU."""
import re
from dataclasses import dataclass

import meshio
import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import LinearElastic, seed_points, simulate
from skfem_mpm.scenes.checkpoint import (Checkpoint, history_rows,
                                         load_checkpoint, save_checkpoint)
from skfem_mpm.scenes.output import SeriesWriter


@dataclass(frozen=True)
class HardeningVonMises(LinearElastic):
    """Von Mises with linear isotropic hardening: yield stress
    ``yield_stress + H alpha`` with ``alpha`` the equivalent plastic strain
    (the radial return of Simo and Hughes, Computational Inelasticity,
    section 3.3.2, in principal values, with its consistent tangent)."""
    yield_stress: float = 1.
    H: float = 0.

    plastic = True
    state_variables = {"alpha": 0.}

    def principal_update(self, eps, state):
        tau, _, D, _, _ = LinearElastic.principal_update(self, eps)
        alpha = state["alpha"]
        p = tau.mean(axis=0)
        s = tau - p
        norm_s = np.linalg.norm(s, axis=0)
        q = np.sqrt(1.5) * norm_s
        f = q - (self.yield_stress + self.H * alpha)
        yielded = f > 1e-12 * self.yield_stress
        if not yielded.any():
            return tau, eps, D, yielded, {"alpha": alpha}
        mu, H = self.mu, self.H
        dgamma = np.where(yielded, f, 0.) / (3 * mu + H)
        ratio = 1 - 3 * mu * dgamma / np.where(yielded, q, 1.)
        tau = p + ratio * s
        eps_e = np.linalg.solve(self.principal_stiffness(), tau)
        n = s / np.where(norm_s > 0, norm_s, 1.)
        dev = np.eye(3) - np.ones((3, 3)) / 3
        bulk = self.E / (3 * (1 - 2 * self.nu))
        theta_bar = 3 * mu / (3 * mu + H) - (1 - ratio)
        Dp = bulk * np.ones((3, 3, 1)) + 2 * mu * (
            ratio * dev[:, :, None] - theta_bar * np.einsum("ap,bp->abp", n,
                                                            n))
        D = np.where(yielded, Dp, D)
        return tau, eps_e, D, yielded, {"alpha": alpha + dgamma}


MATERIAL = HardeningVonMises(1e4, .3, yield_stress=10., H=2e3)
GAMMA = 5e-3


def shear_run(nsteps, kinematics="small", points=None, material=MATERIAL,
              **kwargs):
    """A unit block on a 2 x 2 grid whose boundary follows the simple
    shear ``u_x = f gamma y`` at load factor f (from ``points``, default
    2 x 2 per cell; of ``material``)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))

    def prescribed(basis, f_old, f_new):
        nodes = mesh.boundary_nodes()
        du = np.zeros((2, nodes.size))
        du[0] = (f_new - f_old) * GAMMA * mesh.p[1, nodes]
        return basis.nodal_dofs[:, nodes].T.ravel(), du.T.ravel()
    if points is None:
        points = seed_points(mesh, 2)
    return simulate(mesh, ElementQuad1(), points, material,
                    np.array([], dtype=np.int64), prescribed=prescribed,
                    nsteps=nsteps, kinematics=kinematics, **kwargs)


def closed_form_shear(gamma):
    """``sigma_xy`` of monotonic simple shear with linear hardening:
    elastic ``mu gamma`` up to ``s_y / sqrt 3``, then
    ``(s_y / sqrt 3 + H gamma / 3) / (1 + H / (3 mu))``, and the
    equivalent plastic strain ``(gamma - sigma_xy / mu) / sqrt 3``."""
    mu, H, sy = MATERIAL.mu, MATERIAL.H, MATERIAL.yield_stress
    elastic = mu * gamma
    plastic = (sy / np.sqrt(3) + H * gamma / 3) / (1 + H / (3 * mu))
    sxy = np.where(elastic <= sy / np.sqrt(3), elastic, plastic)
    return sxy, (gamma - sxy / mu) / np.sqrt(3)


def test_user_hardening_model_matches_the_closed_form():
    res = shear_run(10)
    yielded = 0
    for r in res.history:
        sxy, _ = closed_form_shear(GAMMA * r.load_factor)
        assert np.abs(r.stress[0, 1] - sxy).max() < 1e-10 * MATERIAL.yield_stress
        yielded += r.n_yielded > 0
    assert yielded >= 5
    _, alpha = closed_form_shear(GAMMA)
    assert alpha > 0
    assert np.abs(res.points.state["alpha"] - alpha).max() < 1e-12
    # the predictor carries the boundary's motion into the block: a
    # homogeneous step converges in one Newton step
    assert all(len(r.newton_residuals) == 2 and r.residual < 1e-14
               for r in res.history)
    # the consistent tangent: Newton converges quadratically where it has
    # to iterate, as under the block's weight
    weighted = shear_run(10, body_force=[0., -100.])
    pairs = [(a, b) for r in weighted.history
             for a, b in zip(r.newton_residuals[:-1], r.newton_residuals[1:])
             if a < 1e-2 and b > 1e-13]
    assert pairs and min(np.log(b) / np.log(a) for a, b in pairs) >= 1.8


def test_user_model_in_finite_deformation():
    """At 0.5% shear the finite-deformation answer is the small-strain one
    to the order of the strain (relative difference below 1%)."""
    small = shear_run(10).points
    finite = shear_run(10, kinematics="finite").points
    assert np.abs(finite.state["alpha"] - small.state["alpha"]).max() < \
        1e-2 * small.state["alpha"].max()
    assert np.abs(finite.stress[0, 1] - small.stress[0, 1]).max() < \
        1e-2 * np.abs(small.stress[0, 1]).max()


@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_internal_variables_survive_checkpoint_and_resume(tmp_path,
                                                          kinematics):
    """Stop after 3 of 6 steps, save a checkpoint, load it, resume: the
    state, internal variables included, equals the uninterrupted run's
    bit for bit; the VTU of every step carries the variable."""
    whole = shear_run(6, kinematics).points

    class Stop(Exception):
        pass

    history = []
    writer = SeriesWriter(tmp_path, MeshQuad.init_tensor(
        np.linspace(0, 1, 3), np.linspace(0, 1, 3)))

    def stop_after_three(record, points):
        writer.write(record.step, record.load_factor, points,
                     record.elements, record.u)
        history.append(record)
        if record.step == 3:
            save_checkpoint(tmp_path, Checkpoint(
                step=3, nsteps=6, load_factor=record.load_factor,
                increment=record.increment, points=points,
                counters=record.counters, history=history_rows(history),
                reactions=np.zeros((3, 0, 2)), scene_sha256="",
                domain0=points.domain))
            raise Stop
    with pytest.raises(Stop):
        shear_run(6, kinematics, callback=stop_after_three)
    saved = load_checkpoint(tmp_path)
    assert (saved.step, saved.nsteps, saved.load_factor) == (3, 6, .5)
    points = saved.points
    assert points.state["alpha"].max() > 0
    resumed = shear_run(6, kinematics, points=points, first_step=4,
                        domain0=saved.domain0, load_factor=saved.load_factor,
                        increment=saved.increment,
                        counters=saved.counters).points
    for name in ("x", "stress", "strain", "F", "be", "volume",
                 "displacement"):
        assert np.array_equal(getattr(resumed, name), getattr(whole, name))
    assert np.array_equal(resumed.state["alpha"], whole.state["alpha"])
    vtu = meshio.read(tmp_path / "points_0003.vtu")
    assert np.array_equal(vtu.point_data["alpha"], points.state["alpha"])


@pytest.mark.parametrize("kind", ["elastic", "von_mises", "drucker_prager",
                                  "mohr_coulomb"])
def test_moduli_that_overflow_are_refused_by_name(kind):
    """E = 1e308 passed the checks and ended in "a pivot is nan ...
    missing supports" (issue 30): every material with Young's modulus
    refuses it, naming E and its value, as it refuses a Lame parameter
    that overflows (nu next to 0.5: lam = 3e305 for E = 1e290); E = 1e300
    (the limit) is accepted and a body of it runs (a test divides a load
    of 1e-300 by it)."""
    from skfem_mpm import DruckerPrager, InvalidMaterialError, MohrCoulomb
    from skfem_mpm.mechanics.materials import MODULUS_LIMIT, VonMises
    build = {"elastic": LinearElastic,
             "von_mises": lambda E, nu: VonMises(E, nu, 10.),
             "drucker_prager": lambda E, nu: DruckerPrager(
                 E, nu, cohesion=10., friction_angle=30.),
             "mohr_coulomb": lambda E, nu: MohrCoulomb(
                 E, nu, cohesion=10., friction_angle=30.)}[kind]
    assert MODULUS_LIMIT == 1e300
    with pytest.raises(InvalidMaterialError,
                       match=r"Young's modulus E = 1e\+308 is beyond 1e\+300"
                             r".*overflows"):
        build(1e308, .3)
    with pytest.raises(InvalidMaterialError,
                       match=r"Lame parameter lam .* = 3\.0024e\+305"):
        build(1e290, float(np.nextafter(.5, 0.)))
    assert build(1e300, .3).E == 1e300


@dataclass(frozen=True)
class ElasticTangentVonMises(HardeningVonMises):
    """The same stresses with the elastic tangent past yield: a tangent
    that is not their derivative (a user trial's mistake)."""

    def principal_update(self, eps, state):
        tau, eps_e, _, yielded, new = super().principal_update(eps, state)
        return tau, eps_e, np.broadcast_to(self.principal_stiffness()[
            :, :, None], (3, 3, eps.shape[1])).copy(), yielded, new


def test_tangent_error_tells_a_derivative_from_an_elastic_tangent():
    """``tangent_error``: the radial return's consistent tangent equals
    central differences of its stresses to 1e-6 at elastic and plastic
    trial states; the elastic tangent past yield is off by more than a
    tenth (the hardening modulus is a fifth of the shear modulus)."""
    from skfem_mpm.mechanics.element_tests import tangent_error
    rng = np.random.default_rng(0)
    eps = rng.uniform(-3e-3, 3e-3, (3, 400))
    state = {"alpha": rng.uniform(0., 1e-3, 400)}
    yielded = MATERIAL.principal_update(eps, state)[3]
    assert 100 < yielded.sum() < 390
    good = tangent_error(MATERIAL, eps, state)
    assert np.isfinite(good).mean() > .98
    assert np.nanmax(good) < 1e-6
    wrong = tangent_error(ElasticTangentVonMises(1e4, .3, yield_stress=10.,
                                                 H=2e3), eps, state)
    assert np.nanmax(wrong[~yielded]) < 1e-6
    assert np.nanmin(wrong[yielded]) > .1


def test_a_linear_rate_of_a_user_material_is_named_in_the_error():
    """Simple shear past yield with the elastic tangent: Newton converges
    linearly and fails its iterations; the error gives the rate and names
    the user's material and ``tangent_error`` (a trial's failed with "no
    convergence" and no more).  With the consistent tangent the steps
    converge in at most 5 iterations, at no linear rate."""
    from skfem_mpm import (NewtonDivergenceError, NewtonOptions, Options,
                           Prescribed)
    from skfem_mpm.solve.newton import LINEAR_RATES, linear_rate
    options = Options(newton=NewtonOptions(max_iter=12, max_cutbacks=0))
    wrong = ElasticTangentVonMises(1e4, .3, yield_stress=10., H=2e3)
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 1, 5))

    def prescribed(basis, f_old, f_new):     # the top slides, sides free
        nodes = np.flatnonzero((mesh.p[1] == 0.) | (mesh.p[1] == 1.))
        du = np.zeros((2, nodes.size))
        du[0] = (f_new - f_old) * GAMMA * mesh.p[1, nodes]
        return basis.nodal_dofs[:, nodes].T.ravel(), du.T.ravel()
    points = seed_points(mesh, 2)
    with pytest.raises(NewtonDivergenceError) as failed:
        simulate(mesh, ElementQuad1(), points.copy(), wrong,
                 np.array([], dtype=np.int64), loads=[Prescribed(prescribed)],
                 nsteps=2, options=options)
    found = re.search(r"fell by about ([\d.]+) an iteration over the last "
                      r"5: a linear rate", str(failed.value))
    assert found and LINEAR_RATES[0] < float(found.group(1)) \
        < LINEAR_RATES[1]
    assert "the tangent D of ElasticTangentVonMises's principal_update " \
        "may not be the derivative of its stress (check it with " \
        "skfem_mpm.mechanics.element_tests.tangent_error" \
        in str(failed.value)
    # the last attempt's tangent was stabilised; the rate is an earlier
    # one's (it said "the attempt with the exact tangent" of a wrong one)
    assert "exact tangent" not in str(failed.value)
    assert "this attempt's tangent was stabilised; an earlier attempt's, " \
        "with the tangent as assembled: the residual fell" \
        in str(failed.value)
    good = simulate(mesh, ElementQuad1(), points.copy(), MATERIAL,
                    np.array([], dtype=np.int64),
                    loads=[Prescribed(prescribed)], nsteps=2,
                    options=options)
    assert max(len(r.newton_residuals) - 1 for r in good.history) <= 5
    assert not any(linear_rate(r.newton_residuals) for r in good.history)
