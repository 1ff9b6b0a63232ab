"""Compiled points-first passes of a Newton iteration of standard MPM.

Each pass walks the active elements and, in each, its points (the slots of
the material-point basis), so that a point's gradient, deformation,
stress and tangent live in a few registers and small work arrays, and an
element's force or stiffness is summed over its points before one scatter:

- ``finite_residual_2d``, ``_3d``: gradients of the grid increment,
  ``dF``, its inverse, ``b_tr - I``, the principal frame, the return map,
  the Kirchhoff stress and the pulled-back stress ``P``, and the internal
  force, in one pass;
- ``small_residual_2d``, ``_3d``: the same in small strain (Hooke's law,
  or the return map on principal strains);
- ``stiffness_2d``, ``_3d``: the consistent tangent of each point from
  what the residual pass kept (elastic, small-strain return map, or finite
  deformation with its geometric term and pull-back), the element
  stiffness, and its scatter straight into the CSR data of the grid's
  :class:`~skfem_mpm.methods.assembly.ElementPattern`.

Points are on the last axis of the arrays kept (the layout of the numpy
path, whose commit and output read them); the shape gradients come points
first, ``G[e, m, i, d]`` (element, slot, node, axis).  The finite pass
returns a nonzero status where a point inverts, and the caller then lets
the numpy path raise its error with its message.
"""
import math

import numpy as np
from numba import literally, njit

from .constitutive import frame_tangent, principal_frame, principal_update

#: tangents the stiffness pass forms
ELASTIC_TANGENT, RETURN_MAP_TANGENT, FINITE_TANGENT = 0, 1, 2
#: the first 16 hex digits of the sha256 of ``kernels/__init__.py`` and
#: ``kernels/constitutive.py``, whose code and constants the passes compile
#: in: numba's cache keys a cached function on its own file alone, so a
#: change there must change this file too, or the passes would run the
#: cached old code (``tests/test_compiled.py`` checks it)
SOURCES = "c6d75f725dce285d"


@njit(cache=True, error_model="numpy", inline="always")
def point_gradient(G, e, m, U, nloc, k, grad):
    """``grad[a, b] = sum_i U[i, a] G[e, m, i, b]`` of the element's
    nodal increments ``U`` (nloc, k)."""
    for a in range(k):
        for b in range(k):
            t = 0.
            for i in range(nloc):
                t += G[e, m, i, b] * U[i, a]
            grad[a, b] = t


@njit(cache=True, error_model="numpy", inline="always")
def element_increments(du, dofs, e, nloc, k, U):
    for i in range(nloc):
        for a in range(k):
            U[i, a] = du[k * dofs[e, i] + a]


@njit(cache=True, error_model="numpy", inline="always")
def add_force(G, e, m, P, w, nloc, k, fe):
    """``fe[i, a] += sum_b w P[a, b] G[e, m, i, b]``."""
    for i in range(nloc):
        for a in range(k):
            t = 0.
            for b in range(k):
                t += (P[a, b] * w) * G[e, m, i, b]
            fe[i, a] += t


@njit(cache=True, error_model="numpy", inline="always")
def scatter_force(f, fe, dofs, e, nloc, k):
    for i in range(nloc):
        for a in range(k):
            f[k * dofs[e, i] + a] += fe[i, a]
            fe[i, a] = 0.


@njit(cache=True, error_model="numpy")
def _finite_residual(G, slots, dofs, w, du, start, params, eq0, f, P, dF,
                     dF_inv, b_dev, tau, d, vecs, y, dy_dx, yielded, eq, k,
                     nloc):
    """Finite deformation (updated Lagrangian, Hencky), for ``k``
    components and ``nloc`` nodes an element: from the grid increment
    ``du`` and ``start = b_n - I`` (3, 3, n), every point's ``dF``,
    ``dF^-1``, ``b_tr - I``, Kirchhoff stress ``tau`` (3, 3, n), spectral
    parts (``d``, ``vecs``, ``y = tau_A``, ``dy_dx = dtau_A / dx_B``),
    ``P = tau dF^-T`` (k, k, n), yield flags and equivalent plastic strain
    ``eq``, and the internal force ``f``.  Returns 0, or 1 where ``det dF
    <= 0`` (at some point), 2 where ``b_tr`` is not positive definite:
    then the arrays hold no answer."""
    literally(k)
    nel, nslots = slots.shape
    U = np.empty((nloc, k))
    fe = np.zeros((nloc, k))
    g = np.empty((k, k))
    F = np.empty((3, 3))
    Fi = np.empty((3, 3))
    FS = np.empty((3, 3))
    b = np.empty((3, 3))
    x = np.empty(3)
    v = np.empty((3, 3))
    eps = np.empty(3)
    tp = np.empty(3)
    eps_e = np.empty(3)
    D = np.empty((3, 3))
    t = np.empty((3, 3))
    Pp = np.empty((k, k))
    # a point that inverts sets the status, and the pass runs on (its
    # loops run faster without an early return)
    status = 0
    for e in range(nel):
        element_increments(du, dofs, e, nloc, k, U)
        for m in range(nslots):
            p = slots[e, m]
            if p < 0:
                continue
            point_gradient(G, e, m, U, nloc, k, g)
            for a in range(3):
                for c in range(3):
                    F[a, c] = (1. if a == c else 0.) + (
                        g[a, c] if a < k and c < k else 0.)
            if k == 2:
                det = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
                for a in range(3):
                    for c in range(3):
                        Fi[a, c] = 0.
                Fi[0, 0], Fi[1, 1] = F[1, 1] / det, F[0, 0] / det
                Fi[0, 1], Fi[1, 0] = -F[0, 1] / det, -F[1, 0] / det
                Fi[2, 2] = 1. / F[2, 2]
                det = det * F[2, 2]
            else:
                for j in range(3):
                    j1, j2 = (j + 1) % 3, (j + 2) % 3
                    for i in range(3):
                        i1, i2 = (i + 1) % 3, (i + 2) % 3
                        Fi[i, j] = F[j1, i1] * F[j2, i2] \
                            - F[j1, i2] * F[j2, i1]
                det = F[0, 0] * Fi[0, 0] + F[0, 1] * Fi[1, 0] \
                    + F[0, 2] * Fi[2, 0]
                for i in range(3):
                    for j in range(3):
                        Fi[i, j] /= det
            if not det > 0:
                status = 1
            # b_tr - I = dF (b_n - I) dF^T + g + g^T + g g^T
            for a in range(3):
                for j in range(3):
                    s = 0.
                    for i in range(3):
                        s += F[a, i] * start[i, j, p]
                    FS[a, j] = s
            for a in range(3):
                for c in range(3):
                    s = 0.
                    for j in range(3):
                        s += FS[a, j] * F[c, j]
                    if a < k and c < k:
                        gg = 0.
                        for j in range(k):
                            gg += g[a, j] * g[c, j]
                        s += (g[a, c] + g[c, a]) + gg
                    b[a, c] = s
            principal_frame(b, k, x, v)
            if not (x[0] > -1 and x[1] > -1 and x[2] > -1):
                status = 2
            for a in range(3):
                eps[a] = .5 * math.log1p(x[a])
            yielded[p], eq[p] = principal_update(params, eps, eq0[p], tp,
                                                 eps_e, D)
            for a in range(3):
                for c in range(3):
                    s = 0.
                    for A in range(3):
                        s += tp[A] * v[a, A] * v[c, A]
                    t[a, c] = s
                    tau[a, c, p] = s
                    b_dev[a, c, p] = b[a, c]
                    dF[a, c, p] = F[a, c]
                    dF_inv[a, c, p] = Fi[a, c]
                    vecs[a, c, p] = v[a, c]
                d[a, p] = x[a]
            for A in range(k):
                y[A, p] = tp[A]
                for B in range(k):
                    dy_dx[A, B, p] = D[A, B] / (2. * (1. + x[B]))
            for a in range(k):
                for c in range(k):
                    s = 0.
                    for j in range(k):
                        s += t[a, j] * Fi[c, j]
                    P[a, c, p] = s
                    Pp[a, c] = s
            add_force(G, e, m, Pp, w[p], nloc, k, fe)
        scatter_force(f, fe, dofs, e, nloc, k)
    return status


@njit(cache=True, error_model="numpy")
def _small_residual(G, slots, dofs, w, du, stress0, strain0, params, eq0,
                    f, stress, strain, x_all, vecs, y, dy_dx, yielded, eq, k,
                    nloc):
    """Small strain: ``eps = eps_n + sym(grad du)``; Hooke's law added to
    the stress of an elastic material (``params[0] == ELASTIC``: the
    spectral arrays untouched), the return map on principal strains
    otherwise (principal strains ``x_all``, frames ``vecs``, ``y =
    sigma_A``, ``dy_dx = D``); the internal force ``f``."""
    literally(k)
    nel, nslots = slots.shape
    plastic = params[0] != 0.
    lam, mu = params[1], params[2]
    U = np.empty((nloc, k))
    fe = np.zeros((nloc, k))
    g = np.empty((k, k))
    de = np.zeros((3, 3))
    e3 = np.empty((3, 3))
    x = np.empty(3)
    v = np.empty((3, 3))
    sig = np.empty(3)
    eps_e = np.empty(3)
    D = np.empty((3, 3))
    P = np.empty((k, k))
    for e in range(nel):
        element_increments(du, dofs, e, nloc, k, U)
        for m in range(nslots):
            p = slots[e, m]
            if p < 0:
                continue
            point_gradient(G, e, m, U, nloc, k, g)
            for a in range(k):
                for c in range(k):
                    de[a, c] = .5 * (g[a, c] + g[c, a])
            if not plastic:
                trace = de[0, 0] + de[1, 1] + de[2, 2]
                for a in range(3):
                    for c in range(3):
                        s = 2 * mu * de[a, c]
                        if a == c:
                            s += lam * trace
                        stress[a, c, p] = stress0[a, c, p] + s
                        strain[a, c, p] = strain0[a, c, p] + de[a, c]
            else:
                for a in range(3):
                    for c in range(3):
                        e3[a, c] = strain0[a, c, p] + de[a, c]
                principal_frame(e3, k, x, v)
                yielded[p], eq[p] = principal_update(params, x, eq0[p], sig,
                                                     eps_e, D)
                for a in range(3):
                    for c in range(3):
                        s = 0.
                        r = 0.
                        for A in range(3):
                            s += sig[A] * v[a, A] * v[c, A]
                            r += eps_e[A] * v[a, A] * v[c, A]
                        stress[a, c, p] = s
                        strain[a, c, p] = r
                        vecs[a, c, p] = v[a, c]
                    x_all[a, p] = x[a]
                for A in range(k):
                    y[A, p] = sig[A]
                    for B in range(k):
                        dy_dx[A, B, p] = D[A, B]
            for a in range(k):
                for c in range(k):
                    P[a, c] = stress[a, c, p]
            add_force(G, e, m, P, w[p], nloc, k, fe)
        scatter_force(f, fe, dofs, e, nloc, k)


@njit(cache=True, error_model="numpy")
def finite_commit(dim, params, d, vecs, eq0, dF, F0, F, J, b_e, strain):
    """The converged state of a finite-deformation trial, point by point:
    ``F = dF F_n``, its determinant ``J`` (in-plane block times the
    out-of-plane diagonal below 3D, as
    :func:`~skfem_mpm.mechanics.hencky.inverse_and_det`), and from the
    trial's principal frame (``d = eig(b_tr) - 1``, ``vecs``) and the
    return map from ``eq0`` the elastic ``b_e = sum exp(2 eps_A) e_A e_A``
    and strain ``sum eps_A e_A e_A``."""
    eps = np.empty(3)
    tp = np.empty(3)
    eps_e = np.empty(3)
    D = np.empty((3, 3))
    for p in range(d.shape[1]):
        for a in range(3):
            for c in range(3):
                s = 0.
                for b in range(3):
                    s += dF[a, b, p] * F0[b, c, p]
                F[a, c, p] = s
        if dim == 3:
            J[p] = F[0, 0, p] * (F[1, 1, p] * F[2, 2, p]
                                 - F[1, 2, p] * F[2, 1, p]) \
                + F[0, 1, p] * (F[1, 2, p] * F[2, 0, p]
                                - F[1, 0, p] * F[2, 2, p]) \
                + F[0, 2, p] * (F[1, 0, p] * F[2, 1, p]
                                - F[1, 1, p] * F[2, 0, p])
        else:
            J[p] = (F[0, 0, p] * F[1, 1, p] - F[0, 1, p] * F[1, 0, p]) \
                * F[2, 2, p]
        for a in range(3):
            eps[a] = .5 * math.log1p(d[a, p])
        principal_update(params, eps, eq0[p], tp, eps_e, D)
        for A in range(3):
            tp[A] = math.exp(2. * eps_e[A])
        for a in range(3):
            for c in range(3):
                s = 0.
                r = 0.
                for A in range(3):
                    e = vecs[a, A, p] * vecs[c, A, p]
                    s += tp[A] * e
                    r += eps_e[A] * e
                b_e[a, c, p] = s
                strain[a, c, p] = r


@njit(cache=True, error_model="numpy", inline="always")
def point_tangent(kind, p, k, x, y, dy_dx, vecs, dF_inv, A, work):
    """The tangent ``A`` (k, k, k, k) of point ``p`` that the stiffness
    pulls against the gradients at the step's start: the isotropic
    derivative of the return map, or in finite deformation ``dF^-1_eb
    (2 dtau/db . b_tr - delta_bc tau_ad) dF^-1_fd``
    (:func:`~skfem_mpm.kernels.constitutive.frame_tangent`; ``work``:
    its work arrays)."""
    xp, yp, dp, vp, Z = work[:5]
    for a in range(k):
        xp[a] = x[a, p]
        yp[a] = y[a, p]
        for b in range(k):
            dp[a, b] = dy_dx[a, b, p]
            vp[a, b] = vecs[a, b, p]
    for e in range(k):
        for B in range(k):
            if kind == FINITE_TANGENT:
                t = 0.
                for b in range(k):
                    t += dF_inv[e, b, p] * vp[b, B]
                Z[e, B] = t
            else:
                Z[e, B] = vp[e, B]
    frame_tangent(k, xp, yp, dp, vp, Z, kind == FINITE_TANGENT, A, work[5:])


@njit(cache=True, error_model="numpy")
def _stiffness(G, slots, w, elements, first, length, per_node, kind, C, x,
               y, dy_dx, vecs, dF_inv, data, k, nloc):
    """``K_(ia)(jc) = sum_p w_p A_abcd G_bi G_dj`` element by element,
    each element's matrix added to the CSR ``data`` of the pattern whose
    places are ``first[elements[e]]`` (one per entry; ``per_node``: one
    per node pair, the components' places offset by ``length``, the
    lengths of the node's rows), with the tangent ``kind`` of each
    point."""
    literally(k)
    nel, nslots = slots.shape
    nd = nloc * k
    Ke = np.zeros((nd, nd))
    H = np.empty((k, k, nd))
    A = np.empty((k, k, k, k))
    work = (np.empty(k), np.empty(k), np.empty((k, k)), np.empty((k, k)),
            np.empty((k, k)), np.empty((k, k)), np.empty((k, k)),
            np.empty((k, k)), np.empty((k, k, k, k)),
            np.empty((k * k, k, k)), np.empty((k * k, k, k)))
    if kind == ELASTIC_TANGENT:                     # one for all points
        for a in range(k):
            for b in range(k):
                for c in range(k):
                    for d in range(k):
                        A[a, b, c, d] = C[a, b, c, d]
    for e in range(nel):
        for m in range(nslots):
            p = slots[e, m]
            if p < 0:
                continue
            if kind != ELASTIC_TANGENT:    # (no early return: 2x faster)
                point_tangent(kind, p, k, x, y, dy_dx, vecs, dF_inv, A,
                              work)
            wp = w[p]
            # H_(ab)(jc) = w sum_d A_abcd G_jd, then K_(ia)(jc) += sum_b
            # G_ib H_(ab)(jc): rows of H into a row of the element matrix,
            # the sum over b written out (one load and store of the row a
            # term: twice as fast in 3D as a loop over b)
            for a in range(k):
                for b in range(k):
                    for j in range(nloc):
                        g0, g1, g2 = G[e, m, j, 0], G[e, m, j, 1], \
                            G[e, m, j, k - 1]
                        for c in range(k):
                            if k == 3:
                                s = A[a, b, c, 0] * g0 + A[a, b, c, 1] * g1 \
                                    + A[a, b, c, 2] * g2
                            else:
                                s = A[a, b, c, 0] * g0 + A[a, b, c, 1] * g1
                            H[a, b, j * k + c] = wp * s
            for i in range(nloc):
                g0, g1, g2 = G[e, m, i, 0], G[e, m, i, 1], G[e, m, i, k - 1]
                for a in range(k):
                    row = i * k + a
                    for jc in range(nd):
                        if k == 3:
                            Ke[row, jc] += g0 * H[a, 0, jc] + g1 * H[a, 1, jc] \
                                + g2 * H[a, 2, jc]
                        else:
                            Ke[row, jc] += g0 * H[a, 0, jc] + g1 * H[a, 1, jc]
        el = elements[e]
        for i in range(nloc):
            for a in range(k):
                for j in range(nloc):
                    for c in range(k):
                        if per_node:
                            place = first[el, i * nloc + j] \
                                + a * length[el, i] + c
                        else:
                            place = first[el, (i * k + a) * nd + j * k + c]
                        data[place] += Ke[i * k + a, j * k + c]
                        Ke[i * k + a, j * k + c] = 0.


@njit(cache=True, error_model="numpy")
def finite_residual_2d(G, slots, dofs, w, du, start, params, eq0, f, P, dF,
                       dF_inv, b_dev, tau, d, vecs, y, dy_dx, yielded, eq):
    """The finite-deformation pass on a 2D grid (``_finite_residual``)."""
    return _finite_residual(G, slots, dofs, w, du, start, params, eq0, f, P,
                            dF, dF_inv, b_dev, tau, d, vecs, y, dy_dx,
                            yielded, eq, 2, G.shape[2])


@njit(cache=True, error_model="numpy")
def finite_residual_3d(G, slots, dofs, w, du, start, params, eq0, f, P, dF,
                       dF_inv, b_dev, tau, d, vecs, y, dy_dx, yielded, eq):
    """The finite-deformation pass on a 3D grid (``_finite_residual``)."""
    return _finite_residual(G, slots, dofs, w, du, start, params, eq0, f, P,
                            dF, dF_inv, b_dev, tau, d, vecs, y, dy_dx,
                            yielded, eq, 3, G.shape[2])


@njit(cache=True, error_model="numpy")
def small_residual_2d(G, slots, dofs, w, du, stress0, strain0, params, eq0,
                      f, stress, strain, x, vecs, y, dy_dx, yielded, eq):
    """The small-strain pass on a 2D grid (``_small_residual``)."""
    _small_residual(G, slots, dofs, w, du, stress0, strain0, params, eq0, f,
                    stress, strain, x, vecs, y, dy_dx, yielded, eq, 2,
                    G.shape[2])


@njit(cache=True, error_model="numpy")
def small_residual_3d(G, slots, dofs, w, du, stress0, strain0, params, eq0,
                      f, stress, strain, x, vecs, y, dy_dx, yielded, eq):
    """The small-strain pass on a 3D grid (``_small_residual``)."""
    _small_residual(G, slots, dofs, w, du, stress0, strain0, params, eq0, f,
                    stress, strain, x, vecs, y, dy_dx, yielded, eq, 3,
                    G.shape[2])


@njit(cache=True, error_model="numpy")
def stiffness_2d(G, slots, w, elements, first, length, per_node, kind, C, x,
                 y, dy_dx, vecs, dF_inv, data):
    """The stiffness pass on a 2D grid (``_stiffness``)."""
    _stiffness(G, slots, w, elements, first, length, per_node, kind, C, x, y,
               dy_dx, vecs, dF_inv, data, 2, G.shape[2])


@njit(cache=True, error_model="numpy")
def stiffness_3d(G, slots, w, elements, first, length, per_node, kind, C, x,
                 y, dy_dx, vecs, dF_inv, data):
    """The stiffness pass on a 3D grid (``_stiffness``)."""
    _stiffness(G, slots, w, elements, first, length, per_node, kind, C, x, y,
               dy_dx, vecs, dF_inv, data, 3, G.shape[2])


def passes_of(dim: int):
    """``(finite_residual, small_residual, stiffness)`` compiled for
    ``dim`` components (2 or 3, known to the compiler, which unrolls the
    loops over components: four times faster than loops of any length;
    the nodes of an element, any number, are not); each is compiled when
    first called."""
    if dim == 2:
        return finite_residual_2d, small_residual_2d, stiffness_2d
    return finite_residual_3d, small_residual_3d, stiffness_3d
