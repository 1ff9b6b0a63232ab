"""Frictional soil models: Drucker-Prager and Mohr-Coulomb.

Both follow the material protocol of :mod:`skfem_mpm.mechanics.materials`
(isotropic return maps on principal values, vectorised over points, with
the consistent tangent ``D = dtau/deps``), so they run in small strain and
in finite deformation (the Hencky framework: logarithmic principal strains,
Kirchhoff stresses) with every method.  Stresses are tension positive; the
mean stress ``p = tr(sigma) / 3`` is negative in compression.  Angles are in
degrees (one in (0, 1) is refused as radians).  Elasticity is linear
(:class:`~skfem_mpm.LinearElastic`).

Formulas follow de Souza Neto, Peric and Owen, *Computational Methods for
Plasticity*, Wiley 2008: Drucker-Prager section 8.3.3 (return to the cone
and to its apex, with linear cohesion hardening), Mohr-Coulomb section 8.2
(multi-surface return in principal stress space: to a plane, to one of the
two edges, to the apex); the cone fitted to Mohr-Coulomb in their
table 6.1 (outer and inner cones, plane strain).

At the apex of a perfectly plastic model the consistent tangent vanishes;
the tangent returned there keeps ``APEX_STIFFNESS`` (1e-8) of the elastic
one, so that a grid node touched only by such points (a tension cut-off at
a free surface) does not make the Newton matrix exactly singular.

Internal variable of both: ``equivalent_plastic_strain``, the hardening
variable ``alpha`` (``xi * dgamma`` accumulated on the Drucker-Prager cone,
``xi / eta_bar`` times the volumetric plastic strain at its apex; for
Mohr-Coulomb the sum of the plastic multipliers on planes and edges, and
the volumetric plastic strain at the apex).
"""
from dataclasses import dataclass, field

import numpy as np
from numpy import ndarray

from ..errors import InvalidMaterialError, check_real
from .materials import LinearElastic, check_moduli

__all__ = ["DruckerPrager", "MohrCoulomb", "DP_FITS"]

DP_FITS = ("outer", "inner", "plane_strain")
# the tangent at the apex of a perfectly plastic cone is zero: points there
# keep this fraction of the elastic stiffness in the tangent only (not in
# the stress), so that nodes touched only by such points leave the Newton
# matrix regular; the converged state does not change
APEX_STIFFNESS = 1e-8
DEVIATOR = np.eye(3) - np.ones((3, 3)) / 3


def check_degrees(name: str, angle: float):
    """Refuse an angle in (0, 1) degree, as given in radians (a friction
    angle of 0.52 taken as degrees is a soil without friction).  Zero stays
    allowed (no friction: Tresca-like; no dilation)."""
    if 0. < angle < 1.:
        raise InvalidMaterialError(
            "{0} is in degrees, got {1!r}: an angle in (0, 1) degree looks "
            "like radians ({1!r} rad = {2:.1f} degrees: give {0}={2:.1f}); "
            "0 stays allowed".format(name, angle, np.degrees(angle)))


def check_angles(friction_angle, dilation_angle, cohesion,
                 radians_refused: bool = True):
    """Friction angle in [0, 90), dilation angle in [0, friction angle],
    neither in (0, 1) degree (radians, most likely; unless
    ``radians_refused`` is false, as for the reduced angles of
    :func:`~skfem_mpm.reduce_strength`, ``tan(phi) / F`` with F up to 64),
    cohesion >= 0 (all finite), or an :class:`InvalidMaterialError`."""
    phi = check_real("friction_angle", friction_angle, InvalidMaterialError)
    psi = check_real("dilation_angle", dilation_angle, InvalidMaterialError)
    c = check_real("cohesion", cohesion, InvalidMaterialError)
    if not (np.isfinite(phi) and 0. <= phi < 90.):
        raise InvalidMaterialError("friction_angle must lie in [0, 90) "
                                   "degrees, got {}".format(friction_angle))
    if radians_refused:
        check_degrees("friction_angle", phi)
        check_degrees("dilation_angle", psi)
    if not (np.isfinite(psi) and 0. <= psi <= phi):
        raise InvalidMaterialError(
            "dilation_angle must lie in [0, friction_angle = {}] degrees, "
            "got {}".format(friction_angle, dilation_angle))
    if not (np.isfinite(c) and c >= 0.):
        raise InvalidMaterialError("cohesion must be >= 0 and finite, got "
                                   "{}".format(cohesion))
    if c == 0. and phi == 0.:
        raise InvalidMaterialError(
            "cohesion 0 with friction_angle 0 has no strength at all")


def drucker_prager_constants(angle: float, fit: str):
    """``(eta, xi)`` of the cone ``sqrt(J2) + eta p - xi c`` matched to
    Mohr-Coulomb with ``angle`` in degrees (de Souza Neto et al., table 6.1;
    tension-positive ``p``): ``"outer"`` through the compression corners,
    ``"inner"`` through the extension corners, ``"plane_strain"`` the same
    limit loads in plane strain with associated flow.

    >>> eta, xi = drucker_prager_constants(30., "outer")
    >>> round(float(eta), 6), round(float(xi), 6)
    (0.69282, 1.2)
    """
    s, t = np.sin(np.radians(angle)), np.tan(np.radians(angle))
    c = np.cos(np.radians(angle))
    if fit == "outer":
        return 6 * s / (np.sqrt(3) * (3 - s)), 6 * c / (np.sqrt(3) * (3 - s))
    if fit == "inner":
        return 6 * s / (np.sqrt(3) * (3 + s)), 6 * c / (np.sqrt(3) * (3 + s))
    root = np.sqrt(9 + 12 * t * t)
    return 3 * t / root, 3 / root


@dataclass(frozen=True)
class DruckerPrager(LinearElastic):
    """Drucker-Prager elasto-plasticity with linear cohesion hardening.

    Yield function ``f = sqrt(J2) + eta p - xi c(alpha)`` with
    ``c(alpha) = cohesion + hardening * alpha``, flow potential
    ``g = sqrt(J2) + eta_bar p`` (``eta_bar`` from the dilation angle:
    associated when it equals the friction angle).  The return to the cone
    is closed form; where it would carry the deviatoric stress through zero
    (``sqrt(J2_trial) < G dgamma``: tensile states the cone cannot hold)
    the state returns to the apex ``p = xi c / eta`` with a purely
    volumetric plastic strain, whatever the dilation angle (a tension
    cut-off at the apex); ``alpha`` grows there by ``xi / eta_bar`` times
    the volumetric plastic strain, as on the cone.

    Parameters
    ----------
    E, nu
        Elastic constants as in :class:`~skfem_mpm.LinearElastic`.
    cohesion
        Cohesion ``c`` at ``alpha = 0``, >= 0.
    friction_angle, dilation_angle
        In degrees: friction in [0, 90), dilation in [0, friction];
        neither in (0, 1), refused as radians.
    hardening
        ``dc / dalpha``; negative (softening) down to
        ``-K eta eta_bar / xi^2`` (so softening needs a dilation angle): the
        return is then unique.  The cohesion is not bounded below by zero:
        a softening model is for moderate plastic strains.
    fit
        How the cone matches Mohr-Coulomb: ``"outer"`` (default; equal
        strength in triaxial compression), ``"inner"`` (in triaxial
        extension) or ``"plane_strain"`` (equal limit loads in plane strain
        with associated flow: ``eta = 3 tan(phi) / sqrt(9 + 12 tan(phi)^2)``,
        ``xi = 3 / sqrt(9 + 12 tan(phi)^2)``).

    Examples
    --------
    A trial state far outside the cone lands on it:

    >>> import numpy as np
    >>> from skfem_mpm import DruckerPrager
    >>> dp = DruckerPrager(1e4, .3, cohesion=10., friction_angle=30.)
    >>> tau, _, _, yielded, _ = dp.principal_update(
    ...     np.array([[.002], [.002], [-.01]]),
    ...     {"equivalent_plastic_strain": np.zeros(1)})
    >>> s = tau - tau.mean(axis=0)
    >>> f = np.linalg.norm(s) / np.sqrt(2) + dp.eta * tau.mean() - dp.xi * 10
    >>> bool(yielded[0]), bool(abs(f) < 1e-10 * 10)
    (True, True)

    """
    cohesion: float = 0.
    friction_angle: float = 0.
    dilation_angle: float = 0.
    hardening: float = 0.
    fit: str = "outer"
    #: refuse angles in (0, 1) degree as radians (``False``: a reduced
    #: strength, :func:`~skfem_mpm.reduce_strength`)
    radians_refused: bool = field(default=True, repr=False, compare=False)

    plastic = True
    state_variables = {"equivalent_plastic_strain": 0.}

    def __post_init__(self):
        super().__post_init__()
        check_angles(self.friction_angle, self.dilation_angle, self.cohesion,
                     self.radians_refused)
        hardening = check_real("hardening", self.hardening,
                               InvalidMaterialError)
        if not np.isfinite(hardening):
            raise InvalidMaterialError("hardening must be finite, got "
                                       "{}".format(self.hardening))
        check_moduli([("the hardening modulus dc/dalpha", hardening)])
        if self.fit not in DP_FITS:
            raise InvalidMaterialError("fit must be one of {}, got {!r}"
                                       .format(DP_FITS, self.fit))
        eta, xi = drucker_prager_constants(self.friction_angle, self.fit)
        eta_bar = drucker_prager_constants(self.dilation_angle, self.fit)[0]
        K = self.E / (3 * (1 - 2 * self.nu))
        if xi * xi * hardening < -K * eta * eta_bar:
            raise InvalidMaterialError(
                "hardening {} softens faster than the return map admits: "
                "softening needs dilation, hardening >= -K eta eta_bar / xi^2 "
                "= {:.6g} (beyond it the return to the cone can carry the "
                "deviatoric stress through zero below the apex pressure, "
                "where no return exists)".format(
                    hardening, -K * eta * eta_bar / (xi * xi) + 0.))

    @property
    def isochoric_flow(self) -> bool:
        """Whether its plastic flow keeps the volume: no dilation."""
        return self.dilation_angle == 0

    @property
    def eta(self) -> float:
        """Friction coefficient of the cone."""
        return drucker_prager_constants(self.friction_angle, self.fit)[0]

    @property
    def xi(self) -> float:
        """Cohesion coefficient of the cone."""
        return drucker_prager_constants(self.friction_angle, self.fit)[1]

    @property
    def eta_bar(self) -> float:
        """Dilatancy coefficient of the flow potential."""
        return drucker_prager_constants(self.dilation_angle, self.fit)[0]

    def principal_update(self, eps: ndarray, state):
        """The return map (cone or apex) from the elastic trial of
        principal elastic strains ``eps`` (3, n): ``(tau, eps_e, D,
        yielded, state)`` with the consistent tangent and the updated
        ``equivalent_plastic_strain`` of ``state``."""
        tau, _, D, _, _ = LinearElastic.principal_update(self, eps)
        G, K = self.mu, self.E / (3 * (1 - 2 * self.nu))
        eta, xi, eta_bar, H = self.eta, self.xi, self.eta_bar, self.hardening
        alpha = state["equivalent_plastic_strain"]
        p = tau.mean(axis=0)
        s = tau - p
        norm_s = np.linalg.norm(s, axis=0)
        cohesion = self.cohesion + H * alpha
        f = norm_s / np.sqrt(2) + eta * p - xi * cohesion
        scale = np.maximum(xi * np.abs(cohesion), np.abs(eta * p)) \
            + norm_s + np.finfo(float).tiny
        yielded = f > 1e-12 * scale
        if not yielded.any():
            return tau, eps, D, yielded, {"equivalent_plastic_strain": alpha}
        # return to the cone: f is linear in dgamma
        A = G + K * eta * eta_bar + xi * xi * H
        dgamma = np.where(yielded, f, 0.) / A
        cone = yielded & (norm_s / np.sqrt(2) - G * dgamma >= 0)
        apex = yielded & ~cone
        n = s / np.where(norm_s > 0, norm_s, 1.)
        one = np.ones(3)
        # cone: s = s_tr - sqrt2 G dgamma n, p = p_tr - K eta_bar dgamma
        new_s = s - np.sqrt(2) * G * dgamma * n
        new_p = p - K * eta_bar * dgamma
        d_dgamma = (np.sqrt(2) * G * n + eta * K * one[:, None]) / A
        dn = 2 * G * (DEVIATOR[:, :, None] - np.einsum("ap,bp->abp", n, n)) \
            / np.where(norm_s > 0, norm_s, 1.)
        D_cone = (2 * G * DEVIATOR[:, :, None]
                  - np.sqrt(2) * G * (np.einsum("ap,bp->abp", n, d_dgamma)
                                      + dgamma * dn)
                  + one[:, None, None] * (K * one[:, None]
                                          - K * eta_bar * d_dgamma)[None])
        new_alpha = alpha + xi * dgamma
        if apex.any():
            # apex: s = 0, p = xi c(alpha) / eta, volumetric plastic strain
            # dev; alpha += (xi / eta_bar) dev as on the cone (where
            # alpha = xi dgamma, dev = eta_bar dgamma), xi / eta without
            # dilation (needs eta > 0: cohesive cones of zero friction have
            # no apex in reach of a finite p)
            beta = xi / max(eta, np.finfo(float).tiny)
            growth = xi / eta_bar if eta_bar > 0 else beta
            dev = (p - beta * cohesion) / (K + beta * growth * H)
            apex_p = p - K * dev
            new_s = np.where(apex, 0., new_s)
            new_p = np.where(apex, apex_p, new_p)
            new_alpha = np.where(apex, alpha + growth * dev, new_alpha)
            k_apex = K * (1 - K / (K + beta * growth * H))
            D_apex = k_apex * np.ones((3, 3, 1)) \
                + APEX_STIFFNESS * self.principal_stiffness()[:, :, None]
            D_cone = np.where(apex, D_apex, D_cone)
        tau = np.where(yielded, new_s + new_p, tau)
        eps_e = np.where(yielded, self.elastic_strain(tau), eps)
        D = np.where(yielded, D_cone, D)
        return tau, eps_e, D, yielded, {
            "equivalent_plastic_strain": np.where(yielded, new_alpha, alpha)}


@dataclass(frozen=True)
class MohrCoulomb(LinearElastic):
    """Mohr-Coulomb elasto-plasticity, perfectly plastic, with the
    multi-surface return in principal stress space.

    With principal stresses ordered ``s1 >= s2 >= s3`` (tension positive)
    the active yield plane is ``f = k s1 - s3 - sigma_c`` with
    ``k = (1 + sin phi) / (1 - sin phi)`` and the uniaxial compressive
    strength ``sigma_c = 2 c cos(phi) / (1 - sin phi)``; the flow potential
    ``g = m s1 - s3``, ``m`` from the dilation angle.  A trial state returns
    to that plane; where the return would break the ordering, to the edge
    ``s1 = s2`` (triaxial compression) or ``s2 = s3`` (triaxial extension),
    both planes active; where an edge return needs a negative multiplier or
    lands past the apex (``s1 < s3``), to the apex
    ``s1 = s2 = s3 = sigma_c / (k - 1)`` (tension cut-off).

    Parameters
    ----------
    E, nu
        Elastic constants as in :class:`~skfem_mpm.LinearElastic`.
    cohesion
        Cohesion ``c`` >= 0.
    friction_angle, dilation_angle
        In degrees: friction in [0, 90), dilation in [0, friction];
        neither in (0, 1), refused as radians.

    Examples
    --------
    A trial state of triaxial compression (``s1 = s2``) returns to the edge
    of the two planes that meet there, ``k s1 - s3 = sigma_c``:

    >>> import numpy as np
    >>> from skfem_mpm import MohrCoulomb
    >>> mc = MohrCoulomb(1e4, .3, cohesion=10., friction_angle=30.)
    >>> tau, _, _, yielded, _ = mc.principal_update(
    ...     np.array([[.002], [.002], [-.01]]),
    ...     {"equivalent_plastic_strain": np.zeros(1)})
    >>> s1, s3 = tau[0, 0], tau[2, 0]
    >>> bool(yielded[0]), bool(abs(mc.k * s1 - s3 - mc.sigma_c) < 1e-10 * 10)
    (True, True)

    """
    cohesion: float = 0.
    friction_angle: float = 0.
    dilation_angle: float = 0.
    #: refuse angles in (0, 1) degree as radians (``False``: a reduced
    #: strength, :func:`~skfem_mpm.reduce_strength`)
    radians_refused: bool = field(default=True, repr=False, compare=False)

    plastic = True
    state_variables = {"equivalent_plastic_strain": 0.}

    def __post_init__(self):
        super().__post_init__()
        check_angles(self.friction_angle, self.dilation_angle, self.cohesion,
                     self.radians_refused)

    @property
    def isochoric_flow(self) -> bool:
        """Whether its plastic flow keeps the volume: no dilation."""
        return self.dilation_angle == 0

    @property
    def k(self) -> float:
        s = np.sin(np.radians(self.friction_angle))
        return (1 + s) / (1 - s)

    @property
    def m(self) -> float:
        s = np.sin(np.radians(self.dilation_angle))
        return (1 + s) / (1 - s)

    @property
    def sigma_c(self) -> float:
        s = np.sin(np.radians(self.friction_angle))
        return 2 * self.cohesion * np.cos(np.radians(self.friction_angle)) \
            / (1 - s)

    def principal_update(self, eps: ndarray, state):
        """The multi-surface return map (plane, edges, apex) from the
        elastic trial of principal elastic strains ``eps`` (3, n): ``(tau,
        eps_e, D, yielded, state)`` with the consistent tangent and the
        updated ``equivalent_plastic_strain`` of ``state``."""
        n = eps.shape[1]
        order = np.argsort(-eps, axis=0)          # s1 >= s2 >= s3
        eps_sorted = np.take_along_axis(eps, order, axis=0)
        C = self.principal_stiffness()
        trial = C @ eps_sorted
        k, m, sigma_c = self.k, self.m, self.sigma_c
        a_main, b_main = np.array([k, 0., -1.]), np.array([m, 0., -1.])
        f = a_main @ trial - sigma_c
        scale = np.abs(trial).max(axis=0) + sigma_c + np.finfo(float).tiny
        yielded = f > 1e-12 * scale
        alpha = state["equivalent_plastic_strain"]
        D = np.broadcast_to(C[:, :, None], (3, 3, n)).copy()
        if not yielded.any():
            return C @ eps, eps, D, yielded, {
                "equivalent_plastic_strain": alpha}
        tau = trial.copy()
        new_alpha = alpha.copy()
        Db = C @ b_main
        # plane
        dl = f / (a_main @ Db)
        plane_tau = trial - np.outer(Db, dl)
        plane_ok = (plane_tau[0] >= plane_tau[1] - 1e-12 * scale) & (
            plane_tau[1] >= plane_tau[2] - 1e-12 * scale)
        D_plane = C - np.outer(Db, a_main @ C) / (a_main @ Db)
        # edges: s1 = s2 (compression, planes (k,0,-1), (0,k,-1)) or
        # s2 = s3 (extension, planes (k,0,-1), (k,-1,0))
        edges = {
            "compression": (np.array([[k, 0., -1.], [0., k, -1.]]),
                            np.array([[m, 0., -1.], [0., m, -1.]])),
            "extension": (np.array([[k, 0., -1.], [k, -1., 0.]]),
                          np.array([[m, 0., -1.], [m, -1., 0.]]))}
        which = np.where(plane_tau[0] < plane_tau[1], "compression",
                         "extension")
        edge_tau = np.empty_like(trial)
        edge_ok = np.zeros(n, dtype=bool)
        D_edge = np.empty((3, 3, n))
        dl_edge = np.zeros(n)
        for name, (A, B) in edges.items():
            sel = yielded & ~plane_ok & (which == name)
            if not sel.any():
                continue
            DB = C @ B.T                               # (3, 2)
            M = A @ DB                                 # (2, 2)
            Minv = np.linalg.inv(M)
            r = A @ trial[:, sel] - sigma_c            # (2, m)
            lam = Minv @ r
            edge_tau[:, sel] = trial[:, sel] - DB @ lam
            ordered = edge_tau[:, sel]
            edge_ok[sel] = (lam >= -1e-12 * np.abs(lam).max(axis=0)).all(
                axis=0) & (ordered[0] >= ordered[2] - 1e-12 * scale[sel])
            dl_edge[sel] = lam.sum(axis=0)
            D_edge[:, :, sel] = (C - DB @ Minv @ A @ C)[:, :, None]
        use_plane = yielded & plane_ok
        use_edge = yielded & ~plane_ok & edge_ok
        use_apex = yielded & ~plane_ok & ~edge_ok
        tau = np.where(use_plane, plane_tau, tau)
        tau = np.where(use_edge, edge_tau, tau)
        D = np.where(use_plane, D_plane[:, :, None], D)
        D = np.where(use_edge, D_edge, D)
        new_alpha = np.where(use_plane, alpha + dl, new_alpha)
        new_alpha = np.where(use_edge, alpha + dl_edge, new_alpha)
        if use_apex.any():
            if k == 1.:
                raise InvalidMaterialError(
                    "a Mohr-Coulomb state beyond every plane with zero "
                    "friction (Tresca has no apex)")
            apex = sigma_c / (k - 1)
            tau = np.where(use_apex, apex, tau)
            D = np.where(use_apex, APEX_STIFFNESS * C[:, :, None], D)
            bulk = self.E / (3 * (1 - 2 * self.nu))
            new_alpha = np.where(use_apex, alpha + (
                trial.mean(axis=0) - apex) / bulk, new_alpha)
        # back to the points' order of principal values
        inverse = np.argsort(order, axis=0)
        tau = np.take_along_axis(tau, inverse, axis=0)
        D = D[inverse[:, None, :], inverse[None, :, :], np.arange(n)]
        eps_e = np.where(yielded, self.elastic_strain(tau), eps)
        return tau, eps_e, D, yielded, {
            "equivalent_plastic_strain": new_alpha}
