"""Compiled per-point pieces of the points-first passes
(:mod:`skfem_mpm.kernels.passes`), inlined into them: a group's
increments and forces, a point's gradient, its part of the internal force,
its consistent tangent and its part of a local stiffness, the place of a
node pair in a CSR pattern.

A point's shape gradients are the rows ``q0 .. q0 + nloc`` of the
layout's ``G`` (entries, k).  The constitutive update itself is written
in the passes (inlined from a function with the return map's calls in it,
the elastic small-strain pass ran three times slower); nothing here is
compiled on its own, so the passes' cache covers it
(:data:`skfem_mpm.kernels.passes.SOURCES`).
"""
import numpy as np
from numba import njit

from .constitutive import frame_tangent

#: the first 16 hex digits of the sha256 of the kernel files whose code
#: this module compiles in (as :data:`skfem_mpm.kernels.passes.SOURCES`)
SOURCES = "9934bcdf667b5cc5"
#: tangents the stiffness pass forms
ELASTIC_TANGENT, RETURN_MAP_TANGENT, FINITE_TANGENT = 0, 1, 2


@njit(cache=True, error_model="numpy", inline="always")
def gather(du, nodes, n0, nloc, k, U):
    """``U[i, a] = du[k nodes[n0 + i] + a]``: the increments of ``nloc``
    nodes."""
    for i in range(nloc):
        for a in range(k):
            U[i, a] = du[k * nodes[n0 + i] + a]


@njit(cache=True, error_model="numpy", inline="always")
def point_gradient(G, q0, U, nloc, k, grad):
    """``grad[a, b] = sum_i U[i, a] G[q0 + i, b]`` of a point's nodal
    increments ``U`` (nloc, k) and shape gradients ``G[q0:q0 + nloc]``."""
    for a in range(k):
        for b in range(k):
            t = 0.
            for i in range(nloc):
                t += G[q0 + i, b] * U[i, a]
            grad[a, b] = t


@njit(cache=True, error_model="numpy", inline="always")
def add_force(G, q0, P, w, nloc, k, fe):
    """``fe[i, a] += sum_b w P[a, b] G[q0 + i, b]``."""
    for i in range(nloc):
        for a in range(k):
            t = 0.
            for b in range(k):
                t += (P[a, b] * w) * G[q0 + i, b]
            fe[i, a] += t


@njit(cache=True, error_model="numpy", inline="always")
def scatter_force(f, fe, nodes, n0, nloc, k):
    """``f[k nodes[n0 + i] + a] += fe[i, a]``, and ``fe`` zeroed."""
    for i in range(nloc):
        for a in range(k):
            f[k * nodes[n0 + i] + a] += fe[i, a]
            fe[i, a] = 0.


@njit(cache=True, error_model="numpy", inline="always")
def tangent_work(k):
    """The work arrays of :func:`point_tangent`."""
    return (np.empty(k), np.empty(k), np.empty((k, k)), np.empty((k, k)),
            np.empty((k, k)), np.empty((k, k)), np.empty((k, k)),
            np.empty((k, k)), np.empty((k, k, k, k)),
            np.empty((k * k, k, k)), np.empty((k * k, k, k)))


@njit(cache=True, error_model="numpy", inline="always")
def point_tangent(kind, p, k, x, y, dy_dx, vecs, dF_inv, A, work):
    """The tangent ``A`` (k, k, k, k) of point ``p`` that the stiffness
    pulls against the gradients at the step's start: the isotropic
    derivative of the return map, or in finite deformation ``dF^-1_eb
    (2 dtau/db . b_tr - delta_bc tau_ad) dF^-1_fd``
    (:func:`~skfem_mpm.kernels.constitutive.frame_tangent`; ``work``:
    its work arrays, :func:`tangent_work`)."""
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


@njit(cache=True, error_model="numpy", inline="always")
def set_uniform_tangent(kind, C, k, A):
    """``A = C`` where the tangent is one for all points (elastic)."""
    if kind == ELASTIC_TANGENT:
        for a in range(k):
            for b in range(k):
                for c in range(k):
                    for d in range(k):
                        A[a, b, c, d] = C[a, b, c, d]


@njit(cache=True, error_model="numpy", inline="always")
def add_point_stiffness(G, q0, A, wp, nloc, k, H, Ke):
    """``Ke[(i a), (j c)] += wp sum_bd A_abcd G[q0 + i, b] G[q0 + j, d]``:
    rows of ``H_(ab)(jc) = wp sum_d A_abcd G[q0 + j, d]`` into rows of the
    local
    matrix, the sums over b and d written out (one load and store of a row
    a term: twice as fast in 3D as a loop)."""
    nd = nloc * k
    for a in range(k):
        for b in range(k):
            for j in range(nloc):
                g0, g1, g2 = G[q0 + j, 0], G[q0 + j, 1], \
                    G[q0 + j, k - 1]
                for c in range(k):
                    if k == 3:
                        s = A[a, b, c, 0] * g0 + A[a, b, c, 1] * g1 \
                            + A[a, b, c, 2] * g2
                    else:
                        s = A[a, b, c, 0] * g0 + A[a, b, c, 1] * g1
                    H[a, b, j * k + c] = wp * s
    for i in range(nloc):
        g0, g1, g2 = G[q0 + i, 0], G[q0 + i, 1], G[q0 + i, k - 1]
        for a in range(k):
            row = i * k + a
            for jc in range(nd):
                if k == 3:
                    Ke[row, jc] += g0 * H[a, 0, jc] + g1 * H[a, 1, jc] \
                        + g2 * H[a, 2, jc]
                else:
                    Ke[row, jc] += g0 * H[a, 0, jc] + g1 * H[a, 1, jc]


@njit(cache=True, error_model="numpy", inline="always")
def place_in_row(indices, lo, hi, j):
    """The place of column ``j`` among the ascending ``indices[lo:hi]``
    (bisection; ``hi`` where it is not there)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if indices[mid] < j:
            lo = mid + 1
        else:
            hi = mid
    return lo
