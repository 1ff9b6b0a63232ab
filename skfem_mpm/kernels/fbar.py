"""Compiled passes of F-bar on the increment
(:mod:`skfem_mpm.stabilisation.fbar`): the finite-deformation pass of
:mod:`skfem_mpm.kernels.passes` on the scaled increments ``dF_bar = xi
dF``, ``xi = (J_c / J)^(1/3)``, and the consistent tangent of its force,
point by point and cell by cell over the cells' patches of
:mod:`skfem_mpm.kernels.dilatation` (the cells' layout of the additive
mean dilatation, :class:`~skfem_mpm.stabilisation.volumetric.
CellLayout`: its ``cell``, ``patch``, ``patch_start``, ``patch_nodes``):

- ``finite_residual_2d``, ``_3d``: each point's ``J - 1`` of its
  increment and its cell's volume-weighted ``J_c`` (the points' volumes
  ``v`` at the step's start), so ``xi - 1`` and the spatial weights
  ``omega = v J / sum_(p in c) v J``; then the finite pass with every
  gradient scaled, whose force takes the stress measure's part in the
  frame ``(dF, dF^-T)`` against the gradients (weights ``w xi``), sums
  the weighted means ``M_c`` per cell and the spatial average's rows
  ``b`` (``omega R : grad``) over the patches, then adds ``M_c b``;
- ``stiffness_2d``, ``_3d``: each point's framed material part (weights
  ``w xi^2``) and geometric part against the gradients, its rows of the
  cell's couplings and their bulk, then each cell's couplings over its
  patch with the spatial ``b``, scattered into the patches' pattern.

The sums are those of :class:`~skfem_mpm.stabilisation.fbar.
IncrementFbar` (the numpy path, the reference the passes are tested
equal to).
"""
import math

import numpy as np
from numba import literally, njit

from .dilatation import add_cell_couplings, add_cell_force
from .passes import _finite_residual, widest
from .points import (FINITE_TANGENT, add_patch_rows, add_point_stiffness,
                     framed_mean, gather, point_frame, point_gradient,
                     scatter_stiffness, tangent_work)

__all__ = ["passes_of", "SOURCES"]

#: the first 16 hex digits of the sha256 of the kernel files whose code
#: this module compiles in (as :data:`skfem_mpm.kernels.passes.SOURCES`)
SOURCES = "3d6bbd023fe1e5ce"


@njit(cache=True, error_model="numpy", inline="always")
def cell_ratios(G, nodes, node_start, node_count, runs, order, qstart, v,
                du, cell, ncells, k, xi_m1, omega):
    """Every point's ``xi - 1`` and spatial weight ``omega`` from its
    increment's ``J - 1 = I1 + I2 + I3`` of the gradient (no cancellation
    of ``det dF - 1``) and its cell's ``J_c - 1 = sum v (J - 1) / sum
    v``: ``xi - 1 = expm1(log1p((J_c - J) / J) / 3)``."""
    nmax = widest(node_count)
    U = np.empty((nmax, k))
    g = np.empty((k, k))
    Jm1 = np.empty(len(v))
    sums = np.zeros((3, ncells))          # v, v (J - 1), v J
    for r in range(len(runs) - 1):
        n0, nloc = node_start[r], node_count[r]
        gather(du, nodes, n0, nloc, k, U)
        for s in range(runs[r], runs[r + 1]):
            p = order[s]
            point_gradient(G, qstart[s], U, nloc, k, g)
            trace = 0.
            gg = 0.
            for a in range(k):
                trace += g[a, a]
                for b in range(k):
                    gg += g[a, b] * g[b, a]
            det = 0.
            if k == 3:
                det = g[0, 0] * (g[1, 1] * g[2, 2] - g[1, 2] * g[2, 1]) \
                    + g[0, 1] * (g[1, 2] * g[2, 0] - g[1, 0] * g[2, 2]) \
                    + g[0, 2] * (g[1, 0] * g[2, 1] - g[1, 1] * g[2, 0])
            Jm1[p] = trace + (trace ** 2 - gg) / 2 + det
            c = cell[p]
            sums[0, c] += v[p]
            sums[1, c] += v[p] * Jm1[p]
            sums[2, c] += v[p] * (1. + Jm1[p])
    for p in range(len(v)):
        c = cell[p]
        Jc_m1 = sums[1, c] / sums[0, c]
        xi_m1[p] = math.expm1(math.log1p((Jc_m1 - Jm1[p]) / (1. + Jm1[p]))
                              / 3)
        omega[p] = v[p] * (1. + Jm1[p]) / sums[2, c]


@njit(cache=True, error_model="numpy")
def _finite_residual_fbar(G, nodes, node_start, node_count, runs, order,
                          qstart, w, du, start, params, body, eq0, f, dF,
                          dF_inv, tau, d, vecs, y, dy_dx, yielded, eq, cell,
                          patch, patch_start, patch_nodes, v, xi_m1, omega,
                          b, pressure, k):
    """The finite-deformation pass with F-bar on the increment on a grid
    of ``k`` dimensions: ``xi - 1``, ``omega`` (:func:`cell_ratios`), the
    cells' spatial rows ``b`` and weighted means ``pressure`` (zeros on
    entry) filled for the stiffness."""
    literally(k)
    cell_ratios(G, nodes, node_start, node_count, runs, order, qstart, v,
                du, cell, len(patch_start) - 1, k, xi_m1, omega)
    status = _finite_residual(G, nodes, node_start, node_count, runs, order,
                              qstart, w, du, start, params, body, eq0, f, dF,
                              dF_inv, tau, d, vecs, y, dy_dx, yielded,
                              eq, cell, np.empty(0), pressure,
                              (xi_m1, omega, patch, b), k)
    add_cell_force(patch_start, patch_nodes, b, pressure, k, f)
    return status


@njit(cache=True, error_model="numpy", inline="always")
def framed_parts(L, Rt, count, k, Q, R, Fi, P, wA, wx, wM, D, row, column,
                 frame, QA, AQ):
    """A point's part of the F-bar stiffness against the gradients, ``D``
    (k, k, k, k), and its ``row`` and ``column`` (k, k) of the cell's
    couplings, already weighted; returns its bulk.  The material part of
    the tangent ``A = sum_t L_t (x) Rt_t`` in the frame ``(Q, R)``,
    weights ``wA = w xi^2`` (:meth:`~skfem_mpm.stabilisation.volumetric.
    MeanDilatation._framed_stiffness`), and the geometric part of the
    stress measure ``P`` (:meth:`~skfem_mpm.stabilisation.fbar.
    IncrementFbar.geometric`; ``wx = w xi``, ``wM = omega M_c``, ``Fi =
    dF^-1``).  ``frame``: work (2, 9); ``QA``, ``AQ``: work (k, k)."""
    QAQ = 0.
    for t in range(count):
        s1 = 0.
        s2 = 0.
        for a in range(3):
            for b in range(3):
                s1 += Q[a, b] * L[t, a, b]
                s2 += Rt[t, a, b] * Q[a, b]
        frame[0, t] = s1
        frame[1, t] = s2
        QAQ += s1 * s2
    m = framed_mean(P, Q)
    for a in range(k):
        for b in range(k):
            s1 = 0.
            s2 = 0.
            for t in range(count):
                s1 += frame[0, t] * Rt[t, a, b]
                s2 += L[t, a, b] * frame[1, t]
            QA[a, b], AQ[a, b] = s1, s2
            geometric = wx * (P[a, b] - m * R[a, b]) / 3
            row[a, b] = wA * (s1 - R[a, b] * QAQ / 3) / 3 + geometric
            column[a, b] = wA * (s2 - R[a, b] * QAQ / 3) / 3 + geometric
    for a in range(k):
        for b in range(k):
            for c in range(k):
                for e in range(k):
                    A = 0.
                    for t in range(count):
                        A += L[t, a, b] * Rt[t, c, e]
                    RR = R[a, b] * R[c, e]
                    T = Fi[b, c] * Fi[e, a]
                    D[a, b, c, e] = wA * (
                        A - (R[a, b] * QA[c, e] + AQ[a, b] * R[c, e]) / 3
                        + RR * QAQ / 9) + wx * (
                        m / 3 * RR + m * T
                        - (P[a, b] * R[c, e] + R[a, b] * P[c, e]) / 3) \
                        + wM * (RR - T)
    return wA * QAQ + 3 * wx * m - 9 * wM


@njit(cache=True, error_model="numpy")
def _stiffness_fbar(G, nodes, node_start, node_count, runs, order, qstart,
                    mode, elements, first, length, graph_indptr,
                    graph_indices, w, x, y, dy_dx, vecs, dF_inv, dF, tau,
                    data, cell, patch, patch_start, patch_nodes, xi_m1,
                    omega, b, pressure, k):
    """The stiffness pass with F-bar on the increment on a grid of ``k``
    dimensions, from what its residual pass kept (the spectral parts,
    ``dF_bar`` and its inverse, the Kirchhoff stress ``tau``, ``xi - 1``,
    ``omega``, the spatial rows ``b`` and the cells' ``pressure``,
    ``M_c``)."""
    literally(k)
    nmax = widest(node_count)
    Ke = np.zeros((nmax * k, nmax * k))
    H = np.empty((k, k, nmax * k))
    work = tangent_work(3)
    D = np.empty((k, k, k, k))
    row, column = np.empty((k, k)), np.empty((k, k))
    frame, QA, AQ = np.empty((2, 9)), np.empty((k, k)), np.empty((k, k))
    Q, R, Fi, P = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), \
        np.empty((3, 3))
    h_row, h_col = np.zeros((len(patch_nodes), k)), \
        np.zeros((len(patch_nodes), k))
    bulk = np.zeros(len(patch_start) - 1)
    count = 3 + k * (k - 1)
    for r in range(len(runs) - 1):
        n0, nloc = node_start[r], node_count[r]
        for s in range(runs[r], runs[r + 1]):
            p = order[s]
            xi = 1. + xi_m1[p]
            point_frame(FINITE_TANGENT, p, 3, x, y, dy_dx, vecs, dF_inv,
                        work, k)
            for a in range(3):
                for c in range(3):
                    Q[a, c] = dF[a, c, p] / xi
                    Fi[a, c] = xi * dF_inv[a, c, p]
                    R[c, a] = Fi[a, c]
                    t = 0.
                    for e in range(3):
                        t += tau[a, e, p] * dF_inv[c, e, p]
                    P[a, c] = t
            bulk[cell[p]] += framed_parts(
                work[9], work[10], count, k, Q, R, Fi, P, w[p] * xi * xi,
                w[p] * xi, omega[p] * pressure[cell[p]], D, row, column,
                frame, QA, AQ)
            add_point_stiffness(G, qstart[s], D, 1., nloc, k, H, Ke)
            add_patch_rows(G, qstart[s], nloc, k, patch, row, column, 1.,
                           h_row, h_col)
        scatter_stiffness(Ke, nodes, n0, nloc, k, mode, elements, r, first,
                          length, graph_indptr, graph_indices, data)
    add_cell_couplings(patch_start, patch_nodes, b, h_row, h_col, bulk, k,
                       mode, elements, first, length, graph_indptr,
                       graph_indices, data)


@njit(cache=True, error_model="numpy")
def finite_residual_2d(G, nodes, node_start, node_count, runs, order, qstart,
                       w, du, start, params, body, eq0, f, dF, dF_inv, tau,
                       d, vecs, y, dy_dx, yielded, eq, cell, patch,
                       patch_start, patch_nodes, v, xi_m1, omega, b,
                       pressure):
    """``_finite_residual_fbar`` on a 2D grid."""
    return _finite_residual_fbar(
        G, nodes, node_start, node_count, runs, order, qstart, w, du, start,
        params, body, eq0, f, dF, dF_inv, tau, d, vecs, y, dy_dx, yielded,
        eq, cell, patch, patch_start, patch_nodes, v, xi_m1, omega, b,
        pressure, 2)


@njit(cache=True, error_model="numpy")
def finite_residual_3d(G, nodes, node_start, node_count, runs, order, qstart,
                       w, du, start, params, body, eq0, f, dF, dF_inv, tau,
                       d, vecs, y, dy_dx, yielded, eq, cell, patch,
                       patch_start, patch_nodes, v, xi_m1, omega, b,
                       pressure):
    """``_finite_residual_fbar`` on a 3D grid."""
    return _finite_residual_fbar(
        G, nodes, node_start, node_count, runs, order, qstart, w, du, start,
        params, body, eq0, f, dF, dF_inv, tau, d, vecs, y, dy_dx, yielded,
        eq, cell, patch, patch_start, patch_nodes, v, xi_m1, omega, b,
        pressure, 3)


@njit(cache=True, error_model="numpy")
def stiffness_2d(G, nodes, node_start, node_count, runs, order, qstart, mode,
                 elements, first, length, graph_indptr, graph_indices, w, x,
                 y, dy_dx, vecs, dF_inv, dF, tau, data, cell, patch,
                 patch_start, patch_nodes, xi_m1, omega, b, pressure):
    """``_stiffness_fbar`` on a 2D grid."""
    _stiffness_fbar(G, nodes, node_start, node_count, runs, order, qstart,
                    mode, elements, first, length, graph_indptr,
                    graph_indices, w, x, y, dy_dx, vecs, dF_inv, dF, tau,
                    data, cell, patch, patch_start, patch_nodes, xi_m1,
                    omega, b, pressure, 2)


@njit(cache=True, error_model="numpy")
def stiffness_3d(G, nodes, node_start, node_count, runs, order, qstart, mode,
                 elements, first, length, graph_indptr, graph_indices, w, x,
                 y, dy_dx, vecs, dF_inv, dF, tau, data, cell, patch,
                 patch_start, patch_nodes, xi_m1, omega, b, pressure):
    """``_stiffness_fbar`` on a 3D grid."""
    _stiffness_fbar(G, nodes, node_start, node_count, runs, order, qstart,
                    mode, elements, first, length, graph_indptr,
                    graph_indices, w, x, y, dy_dx, vecs, dF_inv, dF, tau,
                    data, cell, patch, patch_start, patch_nodes, xi_m1,
                    omega, b, pressure, 3)


def passes_of(dim: int):
    """``(finite_residual, stiffness)`` with F-bar on the increment,
    compiled for ``dim`` (2 or 3) when first called: the arguments of
    :func:`skfem_mpm.kernels.passes.passes_of`'s finite pass, then
    ``(cell, patch, patch_start, patch_nodes)`` of the cells' layout, the
    volumes ``v`` of the averages and the arrays ``(xi - 1, omega, b,
    M_c)`` the residual fills and the stiffness reads (after the
    spectral parts, ``dF_inv``, ``dF`` and ``tau``)."""
    if dim == 2:
        return finite_residual_2d, stiffness_2d
    return finite_residual_3d, stiffness_3d
