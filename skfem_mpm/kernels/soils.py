"""Compiled return maps of the frictional soil models of
:mod:`skfem_mpm.mechanics.soils`, on one point's principal values.

Each takes the elastic trial (principal stresses ``tau`` and tangent
``D`` of Hooke's law, written by
:func:`~skfem_mpm.kernels.constitutive.principal_update`) and the
hardening variable, and writes the returned stresses, elastic strains and
consistent tangent in place, following the numpy formulas operation by
operation so that the compiled passes equal the numpy path to round-off.
The parameter vector (:func:`~skfem_mpm.mechanics.compiled.
material_parameters`): ``(kind, lam, mu, E, nu, -, ...)``, then for
Drucker-Prager ``(cohesion, eta, xi, eta_bar, hardening, apex
stiffness)``, for Mohr-Coulomb ``(k, m, sigma_c, -, -, apex stiffness)``.
"""
import math

from numba import njit

#: the smallest positive normal float64 (numpy's ``finfo(float).tiny``)
TINY = 2.2250738585072014e-308


@njit(cache=True, error_model="numpy", inline="always")
def elastic_strains(lam, mu, tau, eps_e):
    """``eps_e`` (3,): the principal elastic strains of the principal
    stresses ``tau`` by Hooke's inverse law."""
    trace_tau = tau[0] + tau[1] + tau[2]
    for a in range(3):
        eps_e[a] = (tau[a] - lam / (3 * lam + 2 * mu) * trace_tau) / (2 * mu)


@njit(cache=True, error_model="numpy", inline="always")
def drucker_prager(params, tau, eps_e, D, alpha):
    """The return map of :class:`~skfem_mpm.mechanics.soils.
    DruckerPrager` (to the cone, or to its apex) from the elastic trial
    ``tau`` and ``D``, in place as :func:`~skfem_mpm.kernels.
    constitutive.principal_update`; ``params``:
    ``(kind, lam, mu, E, nu, -, cohesion, eta, xi, eta_bar, hardening,
    apex stiffness)``."""
    lam, mu, E, nu = params[1], params[2], params[3], params[4]
    c0, eta, xi, eta_bar, H = params[6], params[7], params[8], params[9], \
        params[10]
    G, K = mu, E / (3 * (1 - 2 * nu))
    p = (tau[0] + tau[1] + tau[2]) / 3
    s = (tau[0] - p, tau[1] - p, tau[2] - p)
    norm_s = math.sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2])
    cohesion = c0 + H * alpha
    f = norm_s / math.sqrt(2) + eta * p - xi * cohesion
    scale = max(xi * abs(cohesion), abs(eta * p)) + norm_s + TINY
    yielded = f > 1e-12 * scale
    if yielded:
        A = G + K * eta * eta_bar + xi * xi * H
        dgamma = f / A
        if norm_s / math.sqrt(2) - G * dgamma >= 0:           # the cone
            length = norm_s if norm_s > 0 else 1.
            n = (s[0] / length, s[1] / length, s[2] / length)
            new_p = p - K * eta_bar * dgamma
            for a in range(3):
                tau[a] = (s[a] - math.sqrt(2) * G * dgamma * n[a]) + new_p
            for a in range(3):
                for b in range(3):
                    dev = (1. if a == b else 0.) - 1. / 3
                    d_b = (math.sqrt(2) * G * n[b] + eta * K) / A
                    dn = 2 * G * (dev - n[a] * n[b]) / length
                    D[a, b] = (2 * G * dev - math.sqrt(2) * G * (
                        n[a] * d_b + dgamma * dn)) + (K - K * eta_bar * d_b)
            alpha = alpha + xi * dgamma
        else:                                               # the apex
            beta = xi / max(eta, TINY)
            growth = xi / eta_bar if eta_bar > 0 else beta
            dev = (p - beta * cohesion) / (K + beta * growth * H)
            for a in range(3):
                tau[a] = 0. + (p - K * dev)
            k_apex = K * (1 - K / (K + beta * growth * H))
            for a in range(3):
                for b in range(3):
                    D[a, b] = k_apex + params[11] * (
                        lam + (2 * mu if a == b else 0.))
            alpha = alpha + growth * dev
        elastic_strains(lam, mu, tau, eps_e)
    return yielded, alpha


@njit(cache=True, error_model="numpy", inline="always")
def descending(x):
    """The order ``(i, j, l)`` of the values ``x`` (3,) from the largest,
    equal values in their order (numpy's sort of three values is
    stable)."""
    i, j, l = 0, 1, 2
    if x[j] > x[i]:
        i, j = j, i
    if x[l] > x[j]:
        j, l = l, j
        if x[j] > x[i]:
            i, j = j, i
    return i, j, l


@njit(cache=True, error_model="numpy", inline="always")
def row_times(r, Y):
    """The row ``r`` (3,) times the 3x3 ``Y`` (tuples)."""
    return (r[0] * Y[0][0] + r[1] * Y[1][0] + r[2] * Y[2][0],
            r[0] * Y[0][1] + r[1] * Y[1][1] + r[2] * Y[2][1],
            r[0] * Y[0][2] + r[1] * Y[1][2] + r[2] * Y[2][2])


@njit(cache=True, error_model="numpy", inline="always")
def minus_outer(C, u, v, d):
    """``C - outer(u, v) / d`` of the 3x3 ``C`` (tuples)."""
    return ((C[0][0] - u[0] * v[0] / d, C[0][1] - u[0] * v[1] / d,
             C[0][2] - u[0] * v[2] / d),
            (C[1][0] - u[1] * v[0] / d, C[1][1] - u[1] * v[1] / d,
             C[1][2] - u[1] * v[2] / d),
            (C[2][0] - u[2] * v[0] / d, C[2][1] - u[2] * v[1] / d,
             C[2][2] - u[2] * v[2] / d))


@njit(cache=True, error_model="numpy", inline="always")
def mohr_coulomb(params, eps, tau, eps_e, D, alpha):
    """The multi-surface return map of :class:`~skfem_mpm.mechanics.soils.
    MohrCoulomb` in principal stress space (to the plane ``k s1 - s3 =
    sigma_c``, to one of its edges with a neighbouring plane, or to the
    apex), on the principal strains ``eps`` ordered ``s1 >= s2 >= s3``,
    in place as :func:`~skfem_mpm.kernels.constitutive.principal_update`
    (``tau`` and ``D`` hold the elastic trial on entry).  Returns
    ``(yielded, alpha)``.  ``k > 1`` (a friction angle; numpy refuses an
    apex return without one)."""
    lam, mu, E, nu = params[1], params[2], params[3], params[4]
    k, m, sigma_c = params[6], params[7], params[8]
    o = descending(eps)
    C = ((lam + 2 * mu, lam, lam), (lam, lam + 2 * mu, lam),
         (lam, lam, lam + 2 * mu))
    t = row_times((eps[o[0]], eps[o[1]], eps[o[2]]), C)   # C symmetric
    f = (k * t[0] + 0. * t[1] - t[2]) - sigma_c
    scale = max(abs(t[0]), abs(t[1]), abs(t[2])) + sigma_c + TINY
    yielded = f > 1e-12 * scale
    if not yielded:
        return yielded, alpha
    # the plane: flow (m, 0, -1), D b, a . D b
    Db = row_times((m, 0., -1.), C)
    aDb = k * Db[0] + 0. * Db[1] - Db[2]
    dl = f / aDb
    ts = (t[0] - Db[0] * dl, t[1] - Db[1] * dl, t[2] - Db[2] * dl)
    Ds = minus_outer(C, Db, row_times((k, 0., -1.), C), aDb)
    if not (ts[0] >= ts[1] - 1e-12 * scale
            and ts[1] >= ts[2] - 1e-12 * scale):
        # an edge: s1 = s2 (compression: the planes (k, 0, -1) and (0, k,
        # -1)) or s2 = s3 (extension: (k, 0, -1) and (k, -1, 0)), flows
        # b1, b2 alike with m
        if ts[0] < ts[1]:
            a2, b2 = (0., k, -1.), (0., m, -1.)
        else:
            a2, b2 = (k, -1., 0.), (m, -1., 0.)
        a1 = (k, 0., -1.)
        d1, d2 = row_times((m, 0., -1.), C), row_times(b2, C)
        M11 = a1[0] * d1[0] + a1[1] * d1[1] + a1[2] * d1[2]
        M12 = a1[0] * d2[0] + a1[1] * d2[1] + a1[2] * d2[2]
        M21 = a2[0] * d1[0] + a2[1] * d1[1] + a2[2] * d1[2]
        M22 = a2[0] * d2[0] + a2[1] * d2[1] + a2[2] * d2[2]
        det = M11 * M22 - M12 * M21
        i11, i12, i21, i22 = M22 / det, -M12 / det, -M21 / det, M11 / det
        r1 = a1[0] * t[0] + a1[1] * t[1] + a1[2] * t[2] - sigma_c
        r2 = a2[0] * t[0] + a2[1] * t[1] + a2[2] * t[2] - sigma_c
        g1, g2 = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        es = (t[0] - (d1[0] * g1 + d2[0] * g2),
              t[1] - (d1[1] * g1 + d2[1] * g2),
              t[2] - (d1[2] * g1 + d2[2] * g2))
        largest = max(abs(g1), abs(g2))
        if g1 >= -1e-12 * largest and g2 >= -1e-12 * largest and \
                es[0] >= es[2] - 1e-12 * scale:
            # D = C - ((D B Mi) A) C: the rows of D B Mi, times A, times C
            ts = es
            Ds = (edge_row(C, d1[0] * i11 + d2[0] * i21,
                           d1[0] * i12 + d2[0] * i22, a1, a2, 0),
                  edge_row(C, d1[1] * i11 + d2[1] * i21,
                           d1[1] * i12 + d2[1] * i22, a1, a2, 1),
                  edge_row(C, d1[2] * i11 + d2[2] * i21,
                           d1[2] * i12 + d2[2] * i22, a1, a2, 2))
            alpha = alpha + (g1 + g2)
        else:                                               # the apex
            apex = sigma_c / (k - 1)
            ts = (apex, apex, apex)
            c = params[11]
            Ds = ((c * C[0][0], c * C[0][1], c * C[0][2]),
                  (c * C[1][0], c * C[1][1], c * C[1][2]),
                  (c * C[2][0], c * C[2][1], c * C[2][2]))
            alpha = alpha + ((t[0] + t[1] + t[2]) / 3 - apex) / (
                E / (3 * (1 - 2 * nu)))
    else:
        alpha = alpha + dl
    for a in range(3):
        tau[o[a]] = ts[a]
        for b in range(3):
            D[o[a], o[b]] = Ds[a][b]
    elastic_strains(lam, mu, tau, eps_e)
    return yielded, alpha


@njit(cache=True, error_model="numpy", inline="always")
def edge_row(C, q1, q2, a1, a2, a):
    """Row ``a`` of ``C - ((D B Mi) A) C``, ``(q1, q2)`` row ``a`` of ``D
    B Mi`` and ``a1``, ``a2`` the rows of ``A``."""
    x = (q1 * a1[0] + q2 * a2[0], q1 * a1[1] + q2 * a2[1],
         q1 * a1[2] + q2 * a2[2])
    y = row_times(x, C)
    return (C[a][0] - y[0], C[a][1] - y[1], C[a][2] - y[2])
