"""Compiled per-point pieces of the constitutive update: the principal
frame of a symmetric tensor, the return maps of the built-in models on
principal values, and the derivative of an isotropic tensor function.

Each works on one point's small arrays, written to follow the numpy
formulas of :mod:`skfem_mpm.mechanics.hencky` and
:mod:`skfem_mpm.mechanics.materials` operation by operation, so that the
compiled passes (:mod:`skfem_mpm.kernels.passes`) equal the numpy path to
round-off.  The material is a parameter vector (its kind,
:data:`~skfem_mpm.kernels.ELASTIC`, :data:`~skfem_mpm.kernels.VON_MISES`,
:data:`~skfem_mpm.kernels.DRUCKER_PRAGER`,
:data:`~skfem_mpm.kernels.MOHR_COULOMB` or
:data:`~skfem_mpm.kernels.CAM_CLAY`, then ``lam, mu`` and the model's
constants: :func:`~skfem_mpm.mechanics.compiled.material_parameters`);
the soils' return maps are in :mod:`skfem_mpm.kernels.soils` and
:mod:`skfem_mpm.kernels.cam_clay`.
"""
import math

from numba import literally, njit

from . import CAM_CLAY, DRUCKER_PRAGER, MOHR_COULOMB, VON_MISES
from .cam_clay import cam_clay
from .soils import drucker_prager, elastic_strains, mohr_coulomb

#: the first 16 hex digits of the sha256 of the kernel files whose code
#: and constants this module compiles in (as
#: :data:`skfem_mpm.kernels.passes.SOURCES`)
SOURCES = "8ca9c32727d90f6f"


@njit(cache=True, error_model="numpy")
def principal_frame(b, dim, x, v):
    """Eigenvalues ``x`` (3,) and eigenvectors ``v[:, A]`` (3, 3) of the
    symmetric ``b`` (3, 3): the in-plane pair in closed form below 3D (the
    out-of-plane axes principal, as :func:`~skfem_mpm.mechanics.hencky.
    principal_frame`), cyclic Jacobi rotations in 3D; compiled for each
    ``dim`` (a literal)."""
    literally(dim)
    for a in range(3):
        x[a] = b[a, a]
        for c in range(3):
            v[a, c] = 1. if a == c else 0.
    if dim == 2:
        p, q, r = b[0, 0], b[1, 1], b[0, 1]
        half = (p - q) / 2
        mean, radius = (p + q) / 2, math.hypot(half, r)
        if half >= 0:
            c, s = half + radius, r
        else:
            c, s = r, radius - half
        length = math.hypot(c, s)
        if length == 0:                         # b = mean I: any frame
            length, c = 1., 1.
        sign = (-1. if c < 0 else 1.) / length
        c, s = c * sign, s * sign
        x[0], x[1] = mean + radius, mean - radius
        v[0, 0], v[1, 0], v[0, 1], v[1, 1] = c, s, -s, c
    elif dim == 3:
        jacobi(b, x, v)


@njit(cache=True, error_model="numpy", inline="always")
def rotate(app, aqq, apq, arp, arq, vp, vq):
    """One Jacobi rotation in the plane of axes p and q (r the third),
    zeroing ``apq`` (Numerical Recipes' form: ``t = tan``, the new ``app -
    t apq``, ``aqq + t apq``); ``vp``, ``vq``: the frame's columns p and
    q, tuples.  Returns the new ``(app, aqq, apq, arp, arq, vp, vq)``."""
    if apq != 0.:
        theta = (aqq - app) / (2. * apq)
        if abs(theta) > 1e150:
            t = 1. / (2. * theta)
        else:
            t = (1. if theta >= 0 else -1.) / (
                abs(theta) + math.sqrt(theta * theta + 1.))
        c = 1. / math.sqrt(t * t + 1.)
        s = t * c
        app, aqq, apq = app - t * apq, aqq + t * apq, 0.
        arp, arq = c * arp - s * arq, s * arp + c * arq
        vp, vq = ((c * vp[0] - s * vq[0], c * vp[1] - s * vq[1],
                   c * vp[2] - s * vq[2]),
                  (s * vp[0] + c * vq[0], s * vp[1] + c * vq[1],
                   s * vp[2] + c * vq[2]))
    return app, aqq, apq, arp, arq, vp, vq


@njit(cache=True, error_model="numpy")
def jacobi(b, x, v):
    """Eigenpairs of the symmetric 3x3 ``b`` by cyclic Jacobi rotations,
    to the last bit of the off-diagonal part, into ``x`` and ``v``; the
    entries in scalars (registers: faster than in an array)."""
    a00, a11, a22, a01, a02, a12 = b[0, 0], b[1, 1], b[2, 2], b[0, 1], \
        b[0, 2], b[1, 2]
    v0, v1, v2 = (1., 0., 0.), (0., 1., 0.), (0., 0., 1.)      # columns
    for _ in range(50):
        off = a01 * a01 + a02 * a02 + a12 * a12
        if off == 0. or off <= 1e-36 * (a00 * a00 + a11 * a11 + a22 * a22):
            break
        a00, a11, a01, a02, a12, v0, v1 = rotate(a00, a11, a01, a02, a12,
                                                 v0, v1)
        a00, a22, a02, a01, a12, v0, v2 = rotate(a00, a22, a02, a01, a12,
                                                 v0, v2)
        a11, a22, a12, a01, a02, v1, v2 = rotate(a11, a22, a12, a01, a02,
                                                 v1, v2)
    x[0], x[1], x[2] = a00, a11, a22
    for a in range(3):
        v[a, 0], v[a, 1], v[a, 2] = v0[a], v1[a], v2[a]


@njit(cache=True, error_model="numpy")
def principal_update(params, eps, eq, ev, tau, eps_e, D):
    """The return map of the material ``params`` on principal strains
    ``eps`` (3,) with the internal variables at the step's start, the
    equivalent plastic strain ``eq`` and (Cam clay) the plastic
    volumetric strain ``ev``: principal stresses ``tau``, elastic strains
    ``eps_e`` and the tangent ``D`` (3, 3) written in place; returns
    ``(yielded, eq, ev)``."""
    if params[0] == CAM_CLAY:
        return cam_clay(params, eps, eq, ev, tau, eps_e, D)
    lam, mu = params[1], params[2]
    trace = eps[0] + eps[1] + eps[2]
    for a in range(3):
        tau[a] = 2 * mu * eps[a] + lam * trace
        eps_e[a] = eps[a]
        for b in range(3):
            D[a, b] = lam + (2 * mu if a == b else 0.)
    yielded = False
    if params[0] == VON_MISES:
        E, nu, yield_stress = params[3], params[4], params[5]
        p = (tau[0] + tau[1] + tau[2]) / 3
        s0, s1, s2 = tau[0] - p, tau[1] - p, tau[2] - p
        norm_s = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        q = math.sqrt(1.5) * norm_s
        yielded = q > yield_stress * (1 + 1e-12)
        if yielded:
            ratio = yield_stress / q
            s = (s0, s1, s2)
            for a in range(3):
                tau[a] = p + ratio * s[a]
            elastic_strains(lam, mu, tau, eps_e)
            bulk = E / (3 * (1 - 2 * nu))
            for a in range(3):
                for b in range(3):
                    dev = (1. if a == b else 0.) - 1. / 3
                    D[a, b] = bulk + 2 * mu * ratio * (
                        dev - (s[a] / norm_s) * (s[b] / norm_s))
            eq = eq + (q - yield_stress) / (3 * mu)
    elif params[0] == DRUCKER_PRAGER:
        yielded, eq = drucker_prager(params, tau, eps_e, D, eq)
    elif params[0] == MOHR_COULOMB:
        yielded, eq = mohr_coulomb(params, eps, tau, eps_e, D, eq)
    return yielded, eq, ev


@njit(cache=True, error_model="numpy", inline="always")
def frame_terms(k, x, y, dy_dx, v, Z, finite, work, coupled):
    """The tangent ``A`` (k, k, k, k) of an isotropic update from its
    principal values as the sum ``A = sum_t L_t (x) R_t`` over ``k^2``
    terms (:func:`outer_sum`), formed in the principal frame (``k``
    eigenpairs):
    principal values ``x``, ``y`` and derivatives ``dy_dx[A, B] =
    dy_A/dx_B`` (repeated eigenvalues: the limit ``dy_A/dx_A - dy_A/dx_B``
    of ``(y_A - y_B) / (x_A - x_B)``), the frame ``v[:, A]`` and
    ``Z = F^-1 v`` (``v`` without a pull-back).

    In small strain (``finite`` false) ``A`` is the derivative of
    :func:`~skfem_mpm.mechanics.hencky.isotropic_derivative`; in finite
    deformation, with ``x = eig(b_tr) - 1`` and ``y`` the principal
    Kirchhoff stresses, the spatial tangent ``2 dtau/db . b - delta_bc
    tau_ad`` of :func:`~skfem_mpm.mechanics.hencky.spatial_tangent` pulled
    back with ``F^-1`` (:func:`~skfem_mpm.mechanics.hencky.pull_back`).
    In the frame it has the entries ``AACC`` (``a1``), ``ABAB`` (``a2``)
    and ``ABBA`` (``a3``), ``A != B``, each an outer product of the
    ``M[A, B, a, e] = v_aA Z_eB``.  ``work``: ``(a1, a2, a3, M, L, R)``,
    (k, k) three times, (k, k, k, k) and (k^2, k, k) twice; the terms
    into ``L`` and ``R``.

    The ``k`` diagonal terms come first, then those of the pairs of the
    first ``coupled`` eigenpairs alone (``coupled = k``: all pairs, ``k^2``
    terms; else ``k + coupled (coupled - 1)``): in plane strain with
    3 components and the out-of-plane axis the third (``coupled = 2``),
    a pair of it with an in-plane axis builds only the tangent's
    out-of-plane shear entries (``M`` of such a pair has no in-plane
    entry and no trace), which mean dilatation does not read
    (:func:`~skfem_mpm.kernels.points.frame_deviatoric`)."""
    a1, a2, a3, M, L, R = work
    largest = 0.
    for P in range(k):
        largest = max(largest, abs(x[P]))
    for P in range(k):
        for Q in range(k):
            if finite:
                a1[P, Q] = 2. * dy_dx[P, Q] * (1. + x[Q]) - (
                    y[P] if P == Q else 0.)
            else:
                a1[P, Q] = dy_dx[P, Q]
            if P != Q and (P >= coupled or Q >= coupled):
                continue
            diff = x[P] - x[Q]
            if P == Q:
                theta = 0.
            elif abs(diff) <= 1e-9 * largest:
                theta = dy_dx[P, P] - dy_dx[P, Q]
            else:
                theta = (y[P] - y[Q]) / diff
            if finite:
                a2[P, Q] = theta * (1. + x[Q])
                a3[P, Q] = theta * (1. + x[P]) - (y[P] if P != Q else 0.)
            else:
                a2[P, Q] = a3[P, Q] = .5 * theta
            for a in range(k):
                for e in range(k):
                    M[P, Q, a, e] = v[a, P] * Z[e, Q]
    # A = sum_t L_t (x) R_t over the terms t: for each C, L = sum_A a1_AC
    # M_AA, R = M_CC; for each pair P != Q, L = M_PQ, R = a2_PQ M_PQ +
    # a3_PQ M_QP
    t = k
    for P in range(k):
        for Q in range(k):
            if P != Q and (P >= coupled or Q >= coupled):
                continue
            for a in range(k):
                for e in range(k):
                    if P == Q:
                        s = 0.
                        for B in range(k):
                            s += a1[B, P] * M[B, B, a, e]
                        L[P, a, e] = s
                        R[P, a, e] = M[P, P, a, e]
                    else:
                        L[t, a, e] = M[P, Q, a, e]
                        R[t, a, e] = a2[P, Q] * M[P, Q, a, e] \
                            + a3[P, Q] * M[Q, P, a, e]
            if P != Q:
                t += 1


@njit(cache=True, error_model="numpy", inline="always")
def outer_sum(L, R, k, A):
    """``A = sum_t L_t (x) R_t`` (k, k, k, k) of the terms of
    :func:`frame_terms`."""
    for a in range(k):
        for e in range(k):
            for c in range(k):
                for f in range(k):
                    s = 0.
                    for t in range(k * k):
                        s += L[t, a, e] * R[t, c, f]
                    A[a, e, c, f] = s
