"""The compiled return map of :class:`~skfem_mpm.mechanics.cam_clay.
ModifiedCamClay` on one point's principal values.

It follows :meth:`~skfem_mpm.mechanics.cam_clay.ModifiedCamClay.
principal_update` operation by operation: the hyperelastic trial state,
Newton's method on the plastic volume and the yield condition for the
elastic volume ``x`` and the plastic multiplier ``g`` (each point's
iterations those of the vectorised loop, which freezes a point once it
has converged), the nested bracketed solve where Newton's path fails, and
the consistent tangent from the implicit derivative; a return that fails
leaves NaN, as the numpy path does.  Parameters (:func:`~skfem_mpm.
mechanics.compiled.material_parameters`): ``(kind, lam, mu, -, -, -,
kappa, lambda_, M, G, p_r, p_c0)``.
"""
import math

from numba import njit

#: Newton's method of the return map: relative tolerance and iterations
#: (:data:`skfem_mpm.mechanics.cam_clay.RETURN_TOL`, ``RETURN_MAX_ITER``;
#: ``tests/test_compiled.py`` checks that they agree)
RETURN_TOL = 1e-14
RETURN_MAX_ITER = 60
#: the iterations of a bracketed Newton solve
#: (:func:`skfem_mpm.mechanics.cam_clay.bracketed_newton`)
BRACKETED_MAX_ITER = 200


@njit(cache=True, error_model="numpy", inline="always")
def plastic_volume(x, a, g, pr, pcn, kappa, soft):
    """The plastic volume's residual ``(a - x) - g (2 p - p_c)`` at the
    elastic volume ``x``, and its derivative."""
    p, pc = pr * math.exp(x / kappa), pcn * math.exp((a - x) / soft)
    return (a - x) - g * (2 * p - pc), -1 - g * (2 * p / kappa + pc / soft)


@njit(cache=True, error_model="numpy", inline="always")
def bracketed_step(x, value, derivative, lo, hi):
    """One step of a bracketed Newton solve of a decreasing function (its
    root between ``lo`` and ``hi``): Newton's, or bisection where it
    leaves the bracket narrowed by ``x``.  Returns ``(x, lo, hi)``."""
    if value > 0:
        lo = x
    if value < 0:
        hi = x
    step = x - value / derivative
    return (step if lo < step < hi else .5 * (lo + hi)), lo, hi


@njit(cache=True, error_model="numpy")
def volume(a, g, pr, pcn, kappa, soft):
    """The root ``x`` of the plastic volume for the multiplier ``g`` by
    bracketed Newton (its residual decreases in ``x`` with slope <= -1),
    and whether it failed."""
    v0 = plastic_volume(a, a, g, pr, pcn, kappa, soft)[0]
    lo, hi = (a + v0, a) if v0 < 0 else (a, a + v0)
    tol = RETURN_TOL * max(1., abs(a))
    x, done = a, False
    for _ in range(BRACKETED_MAX_ITER):
        value, derivative = plastic_volume(x, a, g, pr, pcn, kappa, soft)
        done = abs(value) <= tol or abs(value) <= RETURN_TOL * abs(
            derivative * x)
        if done:
            break
        x, lo, hi = bracketed_step(x, value, derivative, lo, hi)
    return x, not done


@njit(cache=True, error_model="numpy")
def yield_function(g, a, b, pr, pcn, kappa, soft, M2, c):
    """The yield function, scaled by ``p_c^2``, of the state of the
    multiplier ``g`` and its derivative along ``g``; and whether the
    volume's solve failed."""
    x, failed = volume(a, g, pr, pcn, kappa, soft)
    p, pc = pr * math.exp(x / kappa), pcn * math.exp((a - x) / soft)
    q = b / (1 + c * g)
    dx_dg = (2 * p - pc) / (-1 - g * (2 * p / kappa + pc / soft))
    df = -2 * q * q * c / (M2 * (1 + c * g)) + (
        (2 * p - pc) * p / kappa + p * pc / soft) * dx_dg
    return (q * q / M2 + p * (p - pc)) / pc ** 2, df / pc ** 2, failed


@njit(cache=True, error_model="numpy")
def bracketed_return(a, b, pr, pcn, kappa, soft, M2, c):
    """``(x, g, failed)`` by the nested bracketed solve: the yield function
    changes sign between ``g = 0`` and a ``g`` found by quadrupling."""
    hi, below = 1. / c, False
    for _ in range(RETURN_MAX_ITER):
        below = yield_function(hi, a, b, pr, pcn, kappa, soft, M2, c)[0] < 0
        if below:
            break
        hi = 4 * hi
    lo, g, done = 0., 0., False
    for _ in range(BRACKETED_MAX_ITER):
        value, derivative = yield_function(g, a, b, pr, pcn, kappa, soft,
                                           M2, c)[:2]
        done = abs(value) <= RETURN_TOL or abs(value) <= RETURN_TOL * abs(
            derivative * g)
        if done:
            break
        g, lo, hi = bracketed_step(g, value, derivative, lo, hi)
    x, failed_x = volume(a, g, pr, pcn, kappa, soft)
    return x, g, (not done) or failed_x or not below


@njit(cache=True, error_model="numpy")
def cam_clay(params, eps, eq, ev, tau, eps_e, D):
    """The return map of modified Cam clay on principal strains ``eps``
    (3,) from the plastic volumetric strain ``ev`` and the equivalent
    plastic strain ``eq`` at the step's start: principal stresses
    ``tau``, elastic strains ``eps_e`` and the tangent ``D`` written in
    place; returns ``(yielded, eq, ev)``."""
    kappa, lambda_, M, G, pr, pc0 = params[6], params[7], params[8], \
        params[9], params[10], params[11]
    M2, soft = M ** 2, lambda_ - kappa
    ev_tr = -(eps[0] + eps[1] + eps[2])
    e = (eps[0] + ev_tr / 3, eps[1] + ev_tr / 3, eps[2] + ev_tr / 3)
    norm_e = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    length = norm_e if norm_e > 0 else 1.
    n = (e[0] / length, e[1] / length, e[2] / length)
    q_tr = math.sqrt(6.) * G * norm_e
    p_tr = pr * math.exp(ev_tr / kappa)
    pc_n = pc0 * math.exp(ev / soft)
    f = q_tr ** 2 / M2 + p_tr * (p_tr - pc_n)
    yielded = f > 1e-12 * max(p_tr, pc_n) ** 2
    for a in range(3):
        tau[a] = -p_tr + math.sqrt(2. / 3) * q_tr * n[a]
        eps_e[a] = eps[a]
        for b in range(3):
            D[a, b] = (p_tr / kappa) * 1. + 2 * G * (
                (1. if a == b else 0.) - 1. / 3)
    if not yielded:
        return yielded, eq, ev
    a, b = ev_tr, q_tr
    ln_ncl = (a + kappa * math.log(pr) + soft * math.log(pc_n)) / lambda_
    x = min(a, kappa * (ln_ncl - math.log(pr)))
    g, c, active = 0., 6 * G / M2, True
    for _ in range(RETURN_MAX_ITER):
        p = pr * math.exp(x / kappa)
        pc = pc_n * math.exp((a - x) / soft)
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
        dx = min(max(dx, -kappa), kappa)
        active = not (abs(r1) <= RETURN_TOL * max(1., abs(a), abs(j11 * x))
                      and abs(r2) <= RETURN_TOL)
        if not active:
            break
        x = x + dx
        g = max(g + dg, 0.)
    slow = active or not math.isfinite(x + g)
    if slow:
        # far trial states where Newton's path leaves g >= 0
        x, g, slow = bracketed_return(a, b, pr, pc_n, kappa, soft, M2, c)
    p = pr * math.exp(x / kappa)
    pc = pc_n * math.exp((a - x) / soft)
    q = b / (1 + c * g)
    if slow:                # no solution reached: the step shortens
        p = math.nan
    # consistent tangent from R(x, g; a, b) = 0: d(x, g) = -J^-1 (dR/da da
    # + dR/db db), a = ev_tr, b = q_tr
    j11 = -1 - g * (2 * p / kappa + pc / soft)
    j12 = -(2 * p - pc)
    j21 = (2 * p - pc) * p / kappa + p * pc / soft
    j22 = -2 * q * q * c / (M2 * (1 + c * g))
    r1a, r2a = 1 + g * pc / soft, -p * pc / soft
    r2b = 2 * q / (M2 * (1 + c * g))
    det = j11 * j22 - j12 * j21
    xa, ga = (-r1a * j22 + r2a * j12) / det, (-r2a * j11 + r1a * j21) / det
    xb, gb = (r2b * j12) / det, (-r2b * j11) / det
    dp_da, dp_db = p / kappa * xa, p / kappa * xb
    dq_da = -b * c / (1 + c * g) ** 2 * ga
    dq_db = 1 / (1 + c * g) - b * c / (1 + c * g) ** 2 * gb
    radial = 2 * G / (1 + c * g)
    for i in range(3):
        db = math.sqrt(6.) * G * n[i]               # d q_tr / d eps_i
        dp = dp_da * -1. + dp_db * db
        dq = dq_da * -1. + dq_db * db
        for j in range(3):
            D[j, i] = (-1. * dp + math.sqrt(2. / 3) * (n[j] * dq)) \
                + radial * (((1. if i == j else 0.) - 1. / 3) - n[j] * n[i])
    for i in range(3):
        tau[i] = -p + math.sqrt(2. / 3) * q * n[i]
        eps_e[i] = (math.sqrt(2. / 3) * q * n[i]) / (2 * G) - x / 3
    return yielded, eq + 2 * g * q / M2, ev + (a - x)
