"""Modified Cam clay: critical-state plasticity with pressure-dependent
elasticity.

The hyperelastic form of Borja and Tamagnini (Cam-Clay plasticity, part
III, *Comput. Methods Appl. Mech. Engrg.* 155, 1998, with their coupling
constant alpha = 0), on principal values of the material protocol of
:mod:`skfem_mpm.mechanics.materials`, so the same return map runs in small
strain (infinitesimal strains, Cauchy stresses) and in finite deformation
(logarithmic strains, Kirchhoff stresses).  Soil mechanics' signs inside:
the effective mean pressure ``p = -tr(tau) / 3`` and the volumetric strain
``ev = -tr(eps)`` are positive in compression, ``q = sqrt(3 J2)``.

- Elasticity: ``p = p_r exp(ev_e / kappa)`` (a bulk modulus ``p / kappa``
  that grows with the pressure: ``ln p`` linear in the elastic volume, the
  unloading line of the ``e - ln p`` plane with ``kappa`` the modified
  swelling index), deviatoric stress ``2 G`` times the elastic deviatoric
  strain with a constant shear modulus ``G``.  ``p_r`` is the pressure at
  zero elastic strain: a body of this soil whose points start without
  strain carries ``p_r`` all round (there is no stress-free state; give
  boundary pressures that act in full from the first step,
  ``Pressure(..., ramp=False)``, or start from
  :func:`~skfem_mpm.geostatic_stress`).
- Yield surface, the ellipse ``f = q^2 / M^2 + p (p - p_c)``, associated
  flow; ``M`` the slope of the critical state line.
- Hardening: ``p_c = p_c0 exp(ev_p / (lambda_ - kappa))`` with the plastic
  volumetric strain ``ev_p`` (compression positive): compaction hardens,
  dilation on the dry side (``p < p_c / 2``) softens, and at the critical
  state (``q = M p``, ``p = p_c / 2``) the soil shears at constant volume.

Internal variables: ``plastic_volumetric_strain`` (``ev_p``, from which
``p_c`` follows) and ``equivalent_plastic_strain`` (``sqrt(2/3) |e_p|`` of
the deviatoric plastic strain accumulated).  The return map solves the two
equations of the plastic volume and the yield condition for the elastic
volumetric strain and the plastic multiplier by Newton's method, vectorised
over the points, and its consistent tangent follows from their implicit
derivative.

The slopes are those of volumetric strains; a laboratory's void-ratio
parameters (``lambda``, ``kappa`` of the ``e - ln p`` plane, ``e0``, and
``p_c0`` or ``N``) give the model through
:meth:`ModifiedCamClay.from_void_ratio`.
"""
from dataclasses import dataclass
from typing import Optional

import numpy as np
from numpy import ndarray

from ..errors import InvalidMaterialError, check_real
from ..spelling import parameter
from .materials import check_moduli

__all__ = ["ModifiedCamClay"]

DEVIATOR = np.eye(3) - np.ones((3, 3)) / 3
# Newton's method of the return map: relative tolerance, iterations, and
# the largest change of the elastic volumetric strain per iteration in
# units of kappa (the pressure changes at most by e per iteration)
RETURN_TOL = 1e-14
RETURN_MAX_ITER = 60


def bracketed_newton(fun, lo: ndarray, hi: ndarray, x: ndarray, tol,
                     max_iter: int = 200):
    """Roots of ``fun`` (values and derivatives of arrays) with
    ``fun(lo) > 0 > fun(hi)``, elementwise: Newton's steps, bisection where
    a step leaves the bracket.  Returns the roots and where neither
    ``|fun| <= tol`` nor ``|fun| <= RETURN_TOL |fun' x|`` was reached:
    where the slope is steep, a few tens of ulps of ``x`` move ``fun`` by
    more than ``tol``, and whether a root passed the absolute test
    hung on the last bits of the strains (the compiled path's eigenvalues
    4e-16 from numpy's gave a failed return, NaN, at three points of a
    3D Cam clay run where numpy's converged)."""
    for _ in range(max_iter):
        value, derivative = fun(x)
        done = (np.abs(value) <= tol) | (
            np.abs(value) <= RETURN_TOL * np.abs(derivative * x))
        if done.all():
            break
        lo = np.where(value > 0, x, lo)
        hi = np.where(value < 0, x, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = x - value / derivative
        step = np.where((step > lo) & (step < hi), step, .5 * (lo + hi))
        x = np.where(done, x, step)
    return x, ~done


def check_slopes(values: dict, positive, kappa: str, lambda_: str):
    """The ``positive`` entries of ``values`` positive and finite, the
    slope ``values[lambda_]`` of the normal compression line above that of
    the unloading line ``values[kappa]``, or an
    :class:`InvalidMaterialError`."""
    for name in positive:
        if not (np.isfinite(values[name]) and values[name] > 0):
            raise InvalidMaterialError("{} must be positive and finite, "
                                       "got {}".format(name, values[name]))
    if not (np.isfinite(values[lambda_]) and values[lambda_] > values[kappa]):
        raise InvalidMaterialError(
            "{} must exceed {} = {} (the normal compression line is steeper "
            "than the unloading line), got {}".format(
                parameter(lambda_), kappa, values[kappa], values[lambda_]))


@dataclass(frozen=True)
class ModifiedCamClay:
    """Modified Cam clay (Roscoe and Burland 1968) in the hyperelastic
    form of Borja and Tamagnini (1998).

    Parameters
    ----------
    kappa
        Slope of the unloading line in ``ln p`` against the logarithmic
        (or small) volumetric strain, > 0 (the modified swelling index
        ``kappa / (1 + e)`` of the ``e - ln p`` plane).
    lambda_
        Slope of the normal compression line, > ``kappa``.
    M
        Slope of the critical state line ``q = M p``, in (0, 3) (from a
        critical state friction angle: ``M = 6 sin(phi) / (3 - sin(phi))``,
        3 at 90 degrees).
    shear_modulus
        Constant shear modulus ``G`` > 0.
    reference_pressure
        Effective mean pressure ``p_r`` > 0 at zero elastic strain.
    preconsolidation_pressure
        Initial ``p_c0`` >= ``reference_pressure``: the largest pressure
        the soil has carried (``p_c0 = p_r``, the default: normally
        consolidated at ``p_r``, as scene files take it; the ratio is the
        isotropic overconsolidation ratio).

    Examples
    --------
    Isotropic compression beyond the preconsolidation pressure follows the
    normal compression line: the volume shrinks by ``lambda_ ln(p / p_c0)``.

    >>> import numpy as np
    >>> from skfem_mpm import ModifiedCamClay
    >>> clay = ModifiedCamClay(kappa=.01, lambda_=.1, M=1., shear_modulus=1e3,
    ...                        reference_pressure=100.,
    ...                        preconsolidation_pressure=100.)
    >>> ev = .1 * np.log(2.)                     # the volume for p = 200
    >>> tau, _, _, yielded, state = clay.principal_update(
    ...     np.full((3, 1), -ev / 3), {"plastic_volumetric_strain": np.zeros(1),
    ...                                "equivalent_plastic_strain": np.zeros(1)})
    >>> bool(yielded[0]), np.round(-tau[:, 0], 9).tolist()
    (True, [200.0, 200.0, 200.0])

    """
    kappa: float
    lambda_: float
    M: float
    shear_modulus: float
    reference_pressure: float
    preconsolidation_pressure: Optional[float] = None

    plastic = True
    state_variables = {"plastic_volumetric_strain": 0.,
                       "equivalent_plastic_strain": 0.}

    def __post_init__(self):
        if self.preconsolidation_pressure is None:    # normally consolidated
            object.__setattr__(self, "preconsolidation_pressure",
                               self.reference_pressure)
        values = {name: check_real(name, getattr(self, name),
                                   InvalidMaterialError)
                  for name in ("kappa", "lambda_", "M", "shear_modulus",
                               "reference_pressure",
                               "preconsolidation_pressure")}
        check_slopes(values, ("kappa", "M", "shear_modulus",
                              "reference_pressure"), "kappa", "lambda_")
        if values["M"] >= 3.:
            raise InvalidMaterialError(
                "M must be < 3, got {}: M = 6 sin(phi) / (3 - sin(phi)) of "
                "the critical state friction angle phi (q = sqrt(3 J2)) is "
                "3 at phi = 90 degrees; with M >= 3 a drained triaxial "
                "compression (q = 3 p) never reaches the critical state "
                "and hardens without limit (a user trial: M = 3.5, q up "
                "to 881)".format(values["M"]))
        if not (np.isfinite(values["preconsolidation_pressure"])
                and values["preconsolidation_pressure"]
                >= values["reference_pressure"]):
            raise InvalidMaterialError(
                "preconsolidation_pressure must be >= reference_pressure = "
                "{} (the state at zero strain lies within the yield "
                "surface), got {}".format(self.reference_pressure,
                                          self.preconsolidation_pressure))
        with np.errstate(over="ignore"):
            check_moduli([
                ("shear_modulus", values["shear_modulus"]),
                ("the bulk modulus p_c0 / kappa at the preconsolidation "
                 "pressure (p_c0 = {:.6g}, kappa = {!r})".format(
                     values["preconsolidation_pressure"], values["kappa"]),
                 values["preconsolidation_pressure"] / values["kappa"])])

    @classmethod
    def from_void_ratio(cls, lambda_e: float, kappa_e: float, e0: float,
                        M: float, reference_pressure: float, *,
                        preconsolidation_pressure: Optional[float] = None,
                        N: Optional[float] = None,
                        shear_modulus: Optional[float] = None,
                        nu: Optional[float] = None) -> "ModifiedCamClay":
        """The model from the parameters of the ``e - ln p`` plane, as a
        laboratory reports them: the slopes ``lambda_e`` of the normal
        compression line and ``kappa_e`` of the unloading line in void ratio
        against ``ln p`` (``C_c / ln 10`` and ``C_s / ln 10``), the void
        ratio ``e0`` at the initial effective pressure
        ``reference_pressure``, and where the soil sits: its
        ``preconsolidation_pressure`` or ``N``, the specific volume
        ``1 + e`` of the normal compression line at ``p = 1`` (in the
        units of the pressures), from which
        ``ln p_c0 = (N - (1 + e0) - kappa_e ln p_r) / (lambda_e - kappa_e)``
        (the initial state on the unloading line through ``p_c0``).

        The model speaks volumetric strains, ``ev = -de / (1 + e0)`` (small
        strain: exactly; finite deformation: to first order in the change
        of ``e``), so ``lambda_ = lambda_e / (1 + e0)`` and
        ``kappa = kappa_e / (1 + e0)``.  The shear modulus is given, or
        follows from Poisson's ratio ``nu`` and the bulk modulus at the
        initial pressure ``K = p_r (1 + e0) / kappa_e``:
        ``G = 3 K (1 - 2 nu) / (2 (1 + nu))``.

        Examples
        --------
        >>> from skfem_mpm import ModifiedCamClay
        >>> clay = ModifiedCamClay.from_void_ratio(
        ...     lambda_e=.25, kappa_e=.05, e0=1.5, M=1.2,
        ...     reference_pressure=100., preconsolidation_pressure=150.,
        ...     nu=.25)
        >>> round(clay.lambda_, 12), round(clay.kappa, 12)
        (0.1, 0.02)
        >>> round(clay.shear_modulus, 6)      # 3 K (1 - 2 nu) / (2 (1 + nu))
        3000.0
        """
        values = {name: check_real(name, value, InvalidMaterialError)
                  for name, value in (("lambda_e", lambda_e),
                                      ("kappa_e", kappa_e), ("e0", e0),
                                      ("reference_pressure",
                                       reference_pressure))}
        check_slopes(values, ("e0", "kappa_e", "reference_pressure"),
                     "kappa_e", "lambda_e")
        if (preconsolidation_pressure is None) == (N is None):
            raise InvalidMaterialError(
                "give one of preconsolidation_pressure and N (where the "
                "soil sits against its normal compression line), got {}"
                .format("both" if N is not None else "neither"))
        if (shear_modulus is None) == (nu is None):
            raise InvalidMaterialError(
                "give one of shear_modulus and nu, got {}".format(
                    "both" if nu is not None else "neither"))
        v0, p_r = 1 + values["e0"], values["reference_pressure"]
        lam_e, kap_e = values["lambda_e"], values["kappa_e"]
        if N is not None:
            N = check_real("N", N, InvalidMaterialError)
            with np.errstate(over="ignore"):
                preconsolidation_pressure = float(np.exp(
                    (N - v0 - kap_e * np.log(p_r)) / (lam_e - kap_e)))
            if not preconsolidation_pressure >= p_r:
                raise InvalidMaterialError(
                    "N = {} puts the initial state (e0 = {}, p = {}) above "
                    "the normal compression line (1 + e = {:.6g} there), "
                    "looser than normally consolidated: p_c0 = {:.6g} < p "
                    "(raise N or lower e0)".format(
                        N, e0, p_r, N - lam_e * np.log(p_r),
                        preconsolidation_pressure))
        if nu is not None:
            nu = check_real("nu", nu, InvalidMaterialError)
            if not (np.isfinite(nu) and -1. < nu < .5):
                raise InvalidMaterialError(
                    "Poisson's ratio nu must lie in (-1, 0.5), got {}"
                    .format(nu))
            bulk = p_r * v0 / kap_e
            shear_modulus = 3 * bulk * (1 - 2 * nu) / (2 * (1 + nu))
        return cls(kappa=kap_e / v0, lambda_=lam_e / v0, M=M,
                   shear_modulus=shear_modulus, reference_pressure=p_r,
                   preconsolidation_pressure=preconsolidation_pressure)

    @property
    def mu(self) -> float:
        """Shear modulus."""
        return float(self.shear_modulus)

    @property
    def lam(self) -> float:
        """First Lame parameter of the elastic tangent at the reference
        pressure, ``p_r / kappa - 2 G / 3`` (it scales stabilisation
        terms; the tangent itself follows the pressure)."""
        return self.reference_pressure / self.kappa - 2 * self.mu / 3

    def elastic_strain(self, tau: ndarray) -> ndarray:
        """Principal elastic strains (3, n) of principal stresses (3, n),
        the inverse of the elastic law; every mean pressure must be
        positive (compression).

        Raises
        ------
        InvalidMaterialError
            A principal state without compression (``p <= 0``): Cam clay
            has no elastic state there.
        """
        tau = np.asarray(tau, dtype=float)
        p = -tau.mean(axis=0)
        if not (p > 0).all():
            raise InvalidMaterialError(
                "Cam clay needs a compressive mean stress: {} of {} state(s) "
                "have p = -tr(sigma)/3 <= 0 (first {!r})".format(
                    int((~(p > 0)).sum()), p.size,
                    float(p[~(p > 0)][0])))
        ev = self.kappa * np.log(p / self.reference_pressure)
        return (tau + p) / (2 * self.mu) - ev / 3

    def preconsolidation(self, state) -> ndarray:
        """``p_c`` of the internal variables."""
        return self.preconsolidation_pressure * np.exp(
            state["plastic_volumetric_strain"] / (self.lambda_ - self.kappa))

    def _bracketed_return(self, a: ndarray, b: ndarray, pcn: ndarray):
        """The elastic volume ``x``, multiplier ``g`` and the points that
        failed, by nested bracketed Newton: for a multiplier ``g`` the
        plastic volume ``a - x = g (2 p - p_c)`` has one root ``x`` (its
        left side less the right is decreasing in ``x`` with slope <= -1,
        which brackets it), and the yield function of that state changes
        sign between ``g = 0`` (the trial state) and a ``g`` found by
        quadrupling."""
        kappa, M2, soft = self.kappa, self.M ** 2, self.lambda_ - self.kappa
        c, pr = 6 * self.mu / M2, self.reference_pressure

        def volume(g):
            def plastic_volume(x):
                p, pc = pr * np.exp(x / kappa), pcn * np.exp((a - x) / soft)
                return ((a - x) - g * (2 * p - pc),
                        -1 - g * (2 * p / kappa + pc / soft))
            v0 = plastic_volume(a)[0]
            return bracketed_newton(
                plastic_volume, np.where(v0 < 0, a + v0, a),
                np.where(v0 < 0, a, a + v0), a.copy(),
                RETURN_TOL * np.maximum(1., np.abs(a)))

        def yield_function(g):
            x, failed = volume(g)
            p, pc = pr * np.exp(x / kappa), pcn * np.exp((a - x) / soft)
            q = b / (1 + c * g)
            dx_dg = (2 * p - pc) / (-1 - g * (2 * p / kappa + pc / soft))
            df = -2 * q * q * c / (M2 * (1 + c * g)) + (
                (2 * p - pc) * p / kappa + p * pc / soft) * dx_dg
            return (q * q / M2 + p * (p - pc)) / pc ** 2, df / pc ** 2

        hi = np.full(a.shape, 1. / c)
        for _ in range(RETURN_MAX_ITER):
            below = yield_function(hi)[0] < 0
            if below.all():
                break
            hi = np.where(below, hi, 4 * hi)
        g, failed = bracketed_newton(yield_function, np.zeros_like(a), hi,
                                     np.zeros_like(a), RETURN_TOL)
        x, failed_x = volume(g)
        return x, g, failed | failed_x | ~below

    def principal_update(self, eps: ndarray, state):
        """The return map to the hardening ellipse from the elastic trial
        of principal elastic strains ``eps`` (3, n): ``(tau, eps_e, D,
        yielded, state)`` with the consistent tangent and the updated
        ``plastic_volumetric_strain`` and ``equivalent_plastic_strain``
        of ``state``."""
        kappa, M2, G = self.kappa, self.M ** 2, self.mu
        soft = self.lambda_ - self.kappa
        ev_tr = -eps.sum(axis=0)
        e_tr = eps + ev_tr / 3                    # deviatoric part
        norm_e = np.linalg.norm(e_tr, axis=0)
        n = e_tr / np.where(norm_e > 0, norm_e, 1.)
        q_tr = np.sqrt(6.) * G * norm_e
        p_tr = self.reference_pressure * np.exp(ev_tr / kappa)
        ev_p = state["plastic_volumetric_strain"]
        eq = state["equivalent_plastic_strain"]
        pc_n = self.preconsolidation(state)
        f = q_tr ** 2 / M2 + p_tr * (p_tr - pc_n)
        yielded = f > 1e-12 * np.maximum(p_tr, pc_n) ** 2
        one = np.ones(3)
        tau = -p_tr + np.sqrt(2. / 3) * q_tr * n
        D = (p_tr / kappa) * np.ones((3, 3, 1)) + 2 * G * DEVIATOR[:, :, None]
        if not yielded.any():
            return tau, eps, D, yielded, {"plastic_volumetric_strain": ev_p,
                                          "equivalent_plastic_strain": eq}
        idx = np.flatnonzero(yielded)
        a, b, pcn = ev_tr[idx], q_tr[idx], pc_n[idx]
        # start from the elastic volume of an isotropic state on the normal
        # compression line (p = p_c) of the trial volume, where that is below
        # the trial one (far compressed trial states: exp overflows there)
        ln_ncl = (a + kappa * np.log(self.reference_pressure)
                  + soft * np.log(pcn)) / self.lambda_
        x = np.minimum(a, kappa * (ln_ncl - np.log(self.reference_pressure)))
        g = np.zeros(idx.size)                  # the plastic multiplier
        c = 6 * G / M2
        active = np.ones(idx.size, dtype=bool)
        for _ in range(RETURN_MAX_ITER):
            p = self.reference_pressure * np.exp(x / kappa)
            pc = pcn * np.exp((a - x) / soft)
            q = b / (1 + c * g)
            r1 = (a - x) - g * (2 * p - pc)
            r2 = (q * q / M2 + p * (p - pc)) / (pc * pc)
            j11 = -1 - g * (2 * p / kappa + pc / soft)
            j12 = -(2 * p - pc)
            j21 = ((2 * p - pc) * p / kappa + p * pc / soft) / (pc * pc) \
                + 2 * (q * q / M2 + p * (p - pc)) / (pc * pc) / soft
            j22 = -2 * q * q * c / (M2 * (1 + c * g)) / (pc * pc)
            det = j11 * j22 - j12 * j21
            dx = (-r1 * j22 + r2 * j12) / det
            dg = (-r2 * j11 + r1 * j21) / det
            dx = np.clip(dx, -kappa, kappa)
            active = ~((np.abs(r1) <= RETURN_TOL * np.fmax(   # NaN-blind,
                np.maximum(1., np.abs(a)), np.abs(j11 * x)))   # as max()
                       & (np.abs(r2) <= RETURN_TOL))
            if not active.any():
                break
            x = np.where(active, x + dx, x)
            g = np.where(active, np.maximum(g + dg, 0.), g)
        slow = active | ~np.isfinite(x + g)
        if slow.any():
            # far trial states where Newton's path leaves g >= 0: the
            # bracketed solve of the nested scalar equations
            x[slow], g[slow], failed = self._bracketed_return(
                a[slow], b[slow], pcn[slow])
            slow[slow] = failed
        p = self.reference_pressure * np.exp(x / kappa)
        pc = pcn * np.exp((a - x) / soft)
        q = b / (1 + c * g)
        # failed returns (no solution reached) leave NaN: the load step
        # treats the trial as not evaluable and shortens it
        p[slow] = np.nan
        # consistent tangent from R(x, g; a, b) = 0, a = ev_tr, b = q_tr:
        # d(x, g) = -J^-1 (dR/da da + dR/db db)
        j11 = -1 - g * (2 * p / kappa + pc / soft)
        j12 = -(2 * p - pc)
        j21 = (2 * p - pc) * p / kappa + p * pc / soft
        j22 = -2 * q * q * c / (M2 * (1 + c * g))
        r1a, r2a = 1 + g * pc / soft, -p * pc / soft
        r2b = 2 * q / (M2 * (1 + c * g))
        det = j11 * j22 - j12 * j21
        # solutions for da = 1 and for db = 1
        xa, ga = (-r1a * j22 + r2a * j12) / det, (-r2a * j11 + r1a * j21) / det
        xb, gb = (r2b * j12) / det, (-r2b * j11) / det
        dp_da, dp_db = p / kappa * xa, p / kappa * xb
        dq_da = -b * c / (1 + c * g) ** 2 * ga
        dq_db = 1 / (1 + c * g) - b * c / (1 + c * g) ** 2 * gb
        nn = n[:, idx]
        da = -one[:, None]                          # d ev_tr / d eps
        db = np.sqrt(6.) * G * nn                   # d q_tr / d eps
        dp = dp_da * da + dp_db * db
        dq = dq_da * da + dq_db * db
        radial = 2 * G / (1 + c * g)       # sqrt(2/3) q / |e_tr|, also at 0
        D_plastic = (-one[:, None, None] * dp[None]
                     + np.sqrt(2. / 3) * np.einsum("ap,bp->abp", nn, dq)
                     + radial * (DEVIATOR[:, :, None]
                                 - np.einsum("ap,bp->abp", nn, nn)))
        tau[:, idx] = -p + np.sqrt(2. / 3) * q * nn
        D[:, :, idx] = D_plastic
        eps_e = eps.copy()
        eps_e[:, idx] = (np.sqrt(2. / 3) * q * nn) / (2 * G) - x / 3
        ev_p = ev_p.copy()
        ev_p[idx] = ev_p[idx] + (a - x)
        eq = eq.copy()
        eq[idx] = eq[idx] + 2 * g * q / M2
        return tau, eps_e, D, yielded, {"plastic_volumetric_strain": ev_p,
                                        "equivalent_plastic_strain": eq}
