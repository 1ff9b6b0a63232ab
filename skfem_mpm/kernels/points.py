"""Compiled per-point pieces of the points-first passes
(:mod:`skfem_mpm.kernels.passes`), inlined into them: a group's
increments and forces, a point's gradient, its part of the internal force,
its consistent tangent and its part of a local stiffness, the place of a
node pair in a CSR pattern and the scatter of a local stiffness; with mean
dilatation (:mod:`skfem_mpm.kernels.dilatation`) the volumetric shift of
a gradient, the deviatoric part of a tangent and a point's rows of its
cell's couplings; with F-bar on the increment (:mod:`skfem_mpm.kernels.
fbar`) the scaled increment, the force's split in the frame ``(dF,
dF^-T)`` and a point's rows of its cell's spatial average.

A point's shape gradients are the rows ``q0 .. q0 + nloc`` of the
layout's ``G`` (entries, k).  The constitutive update itself is written
in the passes (inlined from a function with the return map's calls in it,
the elastic small-strain pass ran three times slower); nothing here is
compiled on its own, so the passes' cache covers it
(:data:`skfem_mpm.kernels.passes.SOURCES`).
"""
import numpy as np
from numba import njit

from . import BISECTION, PER_NODE_PAIR
from .constitutive import frame_terms, outer_sum

#: the first 16 hex digits of the sha256 of the kernel files whose code
#: this module compiles in (as :data:`skfem_mpm.kernels.passes.SOURCES`)
SOURCES = "1c8924e30315527a"
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
    (2 dtau/db . b_tr - delta_bc tau_ad) dF^-1_fd``; ``work``:
    :func:`tangent_work`."""
    point_frame(kind, p, k, x, y, dy_dx, vecs, dF_inv, work, k)
    outer_sum(work[9], work[10], k, A)


@njit(cache=True, error_model="numpy", inline="always")
def point_frame(kind, p, k, x, y, dy_dx, vecs, dF_inv, work, coupled):
    """The terms ``L``, ``R`` (``work[9]``, ``work[10]``) of the tangent
    of point ``p`` (:func:`point_tangent`; those of the pairs of the first
    ``coupled`` eigenpairs, :func:`~skfem_mpm.kernels.constitutive.
    frame_terms`)."""
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
    frame_terms(k, xp, yp, dp, vp, Z, kind == FINITE_TANGENT, work[5:],
                coupled)


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


@njit(cache=True, error_model="numpy", inline="always")
def scatter_stiffness(Ke, nodes, n0, nloc, k, mode, elements, r, first,
                      length, graph_indptr, graph_indices, data):
    """``data`` += the local matrix ``Ke`` of group ``r``, the ``nloc``
    nodes from ``nodes[n0]``, at its places in the CSR data of a pattern,
    and ``Ke`` zeroed: with ``mode`` :data:`~skfem_mpm.kernels.PER_ENTRY`
    or :data:`~skfem_mpm.kernels.PER_NODE_PAIR` at the places
    ``first[elements[r]]`` of the element pattern (one per entry, or one per
    node pair whose components' places are offset by ``length``, the
    lengths of the node's rows), with :data:`~skfem_mpm.kernels.
    BISECTION` at the places of the node graph ``(graph_indptr,
    graph_indices)`` (the nodes ascending)."""
    if mode == BISECTION:
        for i in range(nloc):
            lo, hi = graph_indptr[nodes[n0 + i]], \
                graph_indptr[nodes[n0 + i] + 1]
            at = lo
            for j in range(nloc):
                at = place_in_row(graph_indices, at, hi, nodes[n0 + j])
                place = k * k * lo + k * (at - lo)
                for a in range(k):
                    for c in range(k):
                        data[place + a * k * (hi - lo) + c] += \
                            Ke[i * k + a, j * k + c]
                        Ke[i * k + a, j * k + c] = 0.
    else:
        element, nd = elements[r], nloc * k
        for i in range(nloc):
            for a in range(k):
                for j in range(nloc):
                    for c in range(k):
                        if mode == PER_NODE_PAIR:
                            place = first[element, i * nloc + j] \
                                + a * length[element, i] + c
                        else:
                            place = first[element, (i * k + a) * nd
                                          + j * k + c]
                        data[place] += Ke[i * k + a, j * k + c]
                        Ke[i * k + a, j * k + c] = 0.


@njit(cache=True, error_model="numpy", inline="always")
def shift_volume(g, theta, k, m):
    """Mean dilatation: the gradient ``g`` (k in-plane components, ``m``
    in all) with its divergence replaced by the cell's ``theta``, ``g +
    (theta - tr g) I / 3`` (out of plane the shift alone)."""
    trace = 0.
    for a in range(k):
        trace += g[a, a]
    shift = (theta - trace) / 3
    for a in range(m):
        g[a, a] = (g[a, a] if a < k else 0.) + shift


@njit(cache=True, error_model="numpy", inline="always")
def split_mean(P, k, wp, c, pressure):
    """Mean dilatation: the stress measure ``P`` (3, 3) made deviatoric
    in its in-plane block (against the 3x3 mean), the mean weighted by
    ``wp`` added to ``pressure[c]``, of the point's cell ``c``."""
    mean = (P[0, 0] + P[1, 1] + P[2, 2]) / 3
    for a in range(k):
        P[a, a] -= mean
    pressure[c] += wp * mean


@njit(cache=True, error_model="numpy", inline="always")
def deviatoric_tangent(A, k, deviatoric, row, column, traces):
    """Mean dilatation's parts of the tangent ``A`` (3, 3, 3, 3), as
    :meth:`~skfem_mpm.stabilisation.volumetric.MeanDilatation.stiffness`
    forms them (:func:`split_volumetric`) from its in-plane block and its
    traces ``tr1_cd = A_aacd``, ``tr2_ab = A_abcc``, ``tr12 = A_aacc``;
    returns ``tr12``.  ``traces``: work (2, 3, 3)."""
    for a in range(3):
        for b in range(3):
            s1 = 0.
            s2 = 0.
            for c in range(3):
                s1 += A[c, c, a, b]
                s2 += A[a, b, c, c]
            traces[0, a, b] = s1
            traces[1, a, b] = s2
    for a in range(k):
        for b in range(k):
            for c in range(k):
                for d in range(k):
                    deviatoric[a, b, c, d] = A[a, b, c, d]
    tr12 = traces[0, 0, 0] + traces[0, 1, 1] + traces[0, 2, 2]
    split_volumetric(k, tr12, deviatoric, row, column, traces)
    return tr12


@njit(cache=True, error_model="numpy", inline="always")
def frame_deviatoric(L, R, count, k, deviatoric, row, column, traces,
                     term_traces):
    """:func:`deviatoric_tangent` of the tangent ``sum_t L_t (x) R_t``
    of ``count`` 3-component terms (:func:`point_frame`), without the
    tangent: its in-plane block and traces summed term by term (in plane
    strain the out-of-plane components enter only through the traces);
    ``traces``: work (2, 3, 3), ``term_traces``: work (2, 9)."""
    tr12 = 0.
    for t in range(count):
        term_traces[0, t] = L[t, 0, 0] + L[t, 1, 1] + L[t, 2, 2]
        term_traces[1, t] = R[t, 0, 0] + R[t, 1, 1] + R[t, 2, 2]
        tr12 += term_traces[0, t] * term_traces[1, t]
    for a in range(k):
        for b in range(k):
            s1 = 0.
            s2 = 0.
            for t in range(count):
                s1 += term_traces[0, t] * R[t, a, b]
                s2 += L[t, a, b] * term_traces[1, t]
            traces[0, a, b] = s1
            traces[1, a, b] = s2
            for c in range(k):
                for d in range(k):
                    s = 0.
                    for t in range(count):
                        s += L[t, a, b] * R[t, c, d]
                    deviatoric[a, b, c, d] = s
    split_volumetric(k, tr12, deviatoric, row, column, traces)
    return tr12


@njit(cache=True, error_model="numpy", inline="always")
def split_volumetric(k, tr12, deviatoric, row, column, traces):
    """From a tangent's in-plane block (in ``deviatoric``) and traces
    (``traces[0]``: ``tr1``, ``traces[1]``: ``tr2``, in-plane entries;
    ``tr12``): in place its ``deviatoric`` part against the gradients,
    ``A - (I (x) tr1 + tr2 (x) I) / 3 + I (x) I tr12 / 9``, and the
    ``row`` and ``column`` (k, k) against the cell's average, ``(tr1 - I
    tr12 / 3) / 3`` and ``(tr2 - I tr12 / 3) / 3`` (the entries off both
    diagonals as they are: the terms there are zeros)."""
    for a in range(k):
        for b in range(k):
            dab = 1. if a == b else 0.
            row[a, b] = (traces[0, a, b] - dab * tr12 / 3) / 3
            column[a, b] = (traces[1, a, b] - dab * tr12 / 3) / 3
            for c in range(k):
                for d in range(k):
                    dcd = 1. if c == d else 0.
                    if a == b or c == d:
                        deviatoric[a, b, c, d] = deviatoric[a, b, c, d] - (
                            dab * traces[0, c, d] + traces[1, a, b] * dcd
                        ) / 3 + dab * dcd * tr12 / 9


@njit(cache=True, error_model="numpy", inline="always")
def add_patch_rows(G, q0, nloc, k, patch, row, column, wp, h_row, h_col):
    """A point's part of its cell's couplings: ``h_row[patch[q], c] +=
    sum_d wp row_cd G[q, d]`` and ``h_col[patch[q], a] += sum_b wp
    column_ab G[q, b]`` over its entries ``q = q0 .. q0 + nloc``
    (``patch[q]``: the patch entry of the entry's node in the point's
    cell)."""
    for i in range(nloc):
        q = q0 + i
        at = patch[q]
        for a in range(k):
            s1 = 0.
            s2 = 0.
            for b in range(k):
                s1 += (row[a, b] * wp) * G[q, b]
                s2 += (column[a, b] * wp) * G[q, b]
            h_row[at, a] += s1
            h_col[at, a] += s2


@njit(cache=True, error_model="numpy", inline="always")
def scale_increment(g, xi_m1, k, Q):
    """F-bar on the increment: ``Q = dF = I + g`` (3, 3) of the gradient
    ``g`` (its ``k`` in-plane components; out of plane zero), and ``g``
    made ``dF_bar - I = xi g + (xi - 1) I`` (3, 3), ``xi - 1 = xi_m1``,
    as :meth:`~skfem_mpm.stabilisation.fbar.IncrementFbar.gradients`."""
    for a in range(3):
        for c in range(3):
            gac = g[a, c] if a < k and c < k else 0.
            Q[a, c] = (1. if a == c else 0.) + gac
            g[a, c] = gac * (1. + xi_m1) + (xi_m1 if a == c else 0.)


@njit(cache=True, error_model="numpy", inline="always")
def framed_mean(P, Q):
    """``P : Q / 3`` of two (3, 3) tensors: the mean of the stress
    measure ``P`` in the frame of ``Q = dF`` (F-bar)."""
    s = 0.
    for a in range(3):
        for b in range(3):
            s += P[a, b] * Q[a, b]
    return s / 3


@njit(cache=True, error_model="numpy", inline="always")
def split_framed(P, Q, Fi, xi, k, wp, c, pressure):
    """F-bar: the stress measure ``P`` (3, 3) split in the frame ``(Q,
    R)``, ``Q = dF``, ``R = dF^-T = xi dF_bar^-T`` (``Fi``: ``dF_bar^-1``):
    its mean ``m = P : Q / 3``, times ``wp xi`` added to ``pressure[c]``,
    and in-plane ``P`` made ``xi (P - R m)`` (the force's weights ``wp
    xi``: :meth:`~skfem_mpm.stabilisation.fbar.IncrementFbar.force`)."""
    mean = framed_mean(P, Q)
    for a in range(k):
        for b in range(k):
            P[a, b] = (P[a, b] - xi * Fi[b, a] * mean) * xi
    pressure[c] += wp * xi * mean


@njit(cache=True, error_model="numpy", inline="always")
def add_spatial_rows(G, q0, nloc, k, patch, Fi, scale, b):
    """F-bar: a point's part of its cell's spatial average ``theta_c(u) =
    sum_p omega_p R_p : grad(u)_p``: ``b[patch[q], a] += scale sum_d
    Fi[d, a] G[q, d]`` over its entries (``scale = omega xi``, ``R = xi
    Fi^T``)."""
    for i in range(nloc):
        q = q0 + i
        at = patch[q]
        for a in range(k):
            s = 0.
            for d in range(k):
                s += Fi[d, a] * G[q, d]
            b[at, a] += scale * s
