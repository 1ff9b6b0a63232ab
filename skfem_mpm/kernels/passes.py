"""Compiled points-first passes of a Newton iteration.

Each pass walks the point operator's *groups*, points of one support (an
element's points in standard MPM; a run of consecutive points of one row
pattern in a sparse operator, GIMP and B-splines: the points of a cell
whose domains lie inside it), and in each its points, so that a point's
gradient, deformation, stress and tangent live in a few registers and
small work arrays, and a group's increments are gathered and its force
or stiffness summed over its points before one scatter:

- ``finite_residual_2d``, ``_3d``: gradients of the grid increment,
  ``dF``, its inverse, ``b_tr - I``, the principal frame, the return map,
  the Kirchhoff stress, and the internal force from the pulled-back
  stress ``P`` (not kept: the response forms it when read), in one pass;
- ``small_residual_2d``, ``_3d``: the same in small strain (Hooke's law,
  or the return map on principal strains);
- ``stiffness_2d``, ``_3d``: the consistent tangent of each point from
  what the residual pass kept (elastic, small-strain return map, or finite
  deformation with its geometric term and pull-back), the group's local
  stiffness, and its scatter straight into the CSR data of the operator's
  pattern: through the places of the grid's
  :class:`~skfem_mpm.methods.assembly.ElementPattern` (standard MPM), or
  by bisection of the node's row of the supports' node graph
  (:class:`~skfem_mpm.methods.assembly.GraphPattern`, sparse operators).

The layout (:class:`~skfem_mpm.methods.assembly.KernelLayout`, leading
arguments of every pass): shape gradients points first, ``G[q, d]``
(entry, axis; a point's ``nloc`` entries from ``q0``), the group nodes
``nodes`` (``node_count[r]`` of group r from ``node_start[r]``), the
groups' first positions ``runs`` (then the number of positions), and per
position the point ``order[s]`` and its first entry ``qstart[s]``.
Points are on the last axis of the arrays kept (the layout of the numpy
path, whose commit and output read them).  The material: ``params``,
one row a body (:func:`~skfem_mpm.mechanics.compiled.
material_parameters`; one row for a run of one material), and ``body``,
each point's row (a point follows its body's return map, and an elastic
stiffness its body's Hooke tensor, ``C[body[p]]``).  The finite pass
returns a nonzero status where a point inverts, and the caller then lets
the numpy path raise its error with its message.
"""
import math

import numpy as np
from numba import literally, njit

from .constitutive import principal_frame, principal_update
from .points import (ELASTIC_TANGENT, FINITE_TANGENT, RETURN_MAP_TANGENT,
                     add_force, add_patch_rows, add_point_stiffness,
                     add_spatial_rows, deviatoric_tangent, frame_deviatoric,
                     gather, point_frame, point_gradient, point_tangent,
                     scale_increment, scatter_force, scatter_stiffness,
                     set_uniform_tangent, shift_volume, split_framed,
                     split_mean, tangent_work)

#: what the callers read here (the tangents from
#: :mod:`skfem_mpm.kernels.points`)
__all__ = ["passes_of", "finite_commit", "start_deviation", "unstrained",
           "ELASTIC_TANGENT", "RETURN_MAP_TANGENT", "FINITE_TANGENT",
           "SOURCES"]

#: the first 16 hex digits of the sha256 of the kernel files whose code
#: and constants the passes compile in (those they import from, and
#: theirs, in the order of their names): numba's cache keys a cached
#: function on its own file alone, so a change there must change this
#: file too, or the passes would run the cached old code
#: (``tests/test_compiled.py`` checks it)
SOURCES = "46c0695137346007"


@njit(cache=True, error_model="numpy", inline="always")
def widest(node_count):
    """The most nodes of a group."""
    m = 0
    for r in range(len(node_count)):
        m = max(m, node_count[r])
    return m


@njit(cache=True, error_model="numpy")
def _finite_residual(G, nodes, node_start, node_count, runs, order, qstart, w,
                     du, start, params, body, eq0, f, dF, dF_inv, tau, d, vecs,
                     y, dy_dx, yielded, eq, cell, theta, pressure, fbar,
                     k):
    """Finite deformation (updated Lagrangian, Hencky) on a grid of ``k``
    dimensions: from the grid increment
    ``du`` and ``start = b_n - I`` (3, 3, n), every point's ``dF``,
    ``dF^-1``, Kirchhoff stress ``tau`` (3, 3, n), spectral parts of
    ``b_tr - I`` (``d``, ``vecs``; not kept itself) and of the stress
    (``y = tau_A``, ``dy_dx = dtau_A / dx_B``); of ``dF``, ``dF^-1`` and
    ``vecs`` only the in-plane blocks in 2D without mean dilatation (the
    identity out of plane is the caller's); yield flags and equivalent
    plastic strain ``eq``, and the internal force ``f`` from ``P = tau
    dF^-T`` (not kept); each point's material ``params[body[p]]``.
    With mean dilatation (``cell`` an array, else ``None``; ``m = 3``
    components, else ``m = k``) the gradients' divergence is the
    ``theta`` of the point's ``cell``, and the force takes the
    deviatoric part of ``P`` against the gradients, its mean, weighted,
    summed per cell into ``pressure`` (the caller adds it against the
    cell averages).  F-bar on the increment (``fbar`` a tuple
    ``(xi - 1, omega, patch, b)``, else ``None``; with ``cell``): each
    point's increment scaled by its ``xi`` (``scale_increment``), the
    force split in its frame ``(dF, dF^-T)`` and the spatial average's
    rows summed into ``b`` (``split_framed``, ``add_spatial_rows``).
    Returns 0, or 1 where ``det dF <= 0`` (at some point), 2 where
    ``b_tr`` is not positive definite: then the arrays hold no answer."""
    literally(k)
    m = k if cell is None else 3
    nmax = widest(node_count)
    # a run of one material reads no body, and takes no view of params a
    # point (as before the passes took bodies: benchmarks/README.md, the
    # nineteenth round)
    several, mine = len(params) > 1, params[0]
    U = np.empty((nmax, k))
    fe = np.zeros((nmax, k))
    g = np.zeros((m, m))
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
    P = np.empty((m, m))
    Q = np.empty((3, 3))            # F-bar: the unscaled dF
    # a point that inverts sets the status, and the pass runs on (its
    # loops run faster without an early return)
    status = 0
    for r in range(len(runs) - 1):
        n0, nloc = node_start[r], node_count[r]
        gather(du, nodes, n0, nloc, k, U)
        for s in range(runs[r], runs[r + 1]):
            p, q0 = order[s], qstart[s]
            point_gradient(G, q0, U, nloc, k, g)
            if fbar is not None:
                scale_increment(g, fbar[0][p], k, Q)
            elif cell is not None:
                shift_volume(g, theta[cell[p]], k, m)
            for a in range(3):
                for c in range(3):
                    F[a, c] = (1. if a == c else 0.) + (
                        g[a, c] if a < m and c < m else 0.)
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
                    if a < m and c < m:
                        gg = 0.
                        for j in range(m):
                            gg += g[a, j] * g[c, j]
                        s += (g[a, c] + g[c, a]) + gg
                    b[a, c] = s
            principal_frame(b, k, x, v)
            if not (x[0] > -1 and x[1] > -1 and x[2] > -1):
                status = 2
            for a in range(3):
                eps[a] = .5 * math.log1p(x[a])
            if several:
                mine = params[body[p]]
            yielded[p], eq[0, p], eq[1, p] = principal_update(
                mine, eps, eq0[0, p], eq0[1, p], tp, eps_e, D)
            for a in range(3):
                for c in range(3):
                    s = 0.
                    for A in range(3):
                        s += tp[A] * v[a, A] * v[c, A]
                    t[a, c] = s
                    tau[a, c, p] = s
                d[a, p] = x[a]
            # dF, dF^-1 and the frame: in 2D without mean dilatation only
            # their in-plane blocks (the caller's arrays hold I out of
            # plane: 12 strided stores a point, not 27)
            e = 2 if k == 2 and cell is None else 3
            for a in range(e):
                for c in range(e):
                    dF[a, c, p] = F[a, c]
                    dF_inv[a, c, p] = Fi[a, c]
                    vecs[a, c, p] = v[a, c]
            for A in range(m):
                y[A, p] = tp[A]
                for B in range(m):
                    dy_dx[A, B, p] = D[A, B] / (2. * (1. + x[B]))
            for a in range(m):
                for c in range(m):
                    s = 0.
                    for j in range(m):
                        s += t[a, j] * Fi[c, j]
                    P[a, c] = s
            if fbar is not None:
                split_framed(P, Q, Fi, 1. + fbar[0][p], k, w[p], cell[p],
                             pressure)
                add_spatial_rows(G, q0, nloc, k, fbar[2], Fi,
                                 (1. + fbar[0][p]) * fbar[1][p], fbar[3])
            elif cell is not None:
                split_mean(P, k, w[p], cell[p], pressure)
            add_force(G, q0, P, w[p], nloc, k, fe)
        scatter_force(f, fe, nodes, n0, nloc, k)
    return status


@njit(cache=True, error_model="numpy")
def _small_residual(G, nodes, node_start, node_count, runs, order, qstart, w,
                    du, stress0, strain0, params, body, eq0, f, stress, strain,
                    x_all, vecs, y, dy_dx, yielded, eq, cell, theta, pressure,
                    k):
    """Small strain: ``eps = eps_n + sym(grad du)``; Hooke's law added to
    the stress where every body is elastic (``params[:, 0] == ELASTIC``:
    the spectral arrays untouched), the return map on principal strains
    otherwise, also on an elastic body's points (principal strains
    ``x_all``, frames ``vecs``, ``y = sigma_A``, ``dy_dx = D``, in ``m``
    components); the internal force ``f``; mean dilatation (``cell`` an
    array) as in ``_finite_residual``."""
    literally(k)
    m = k if cell is None else 3
    nmax = widest(node_count)
    plastic = False
    for row in range(len(params)):      # any body's
        plastic = plastic or params[row, 0] != 0.
    several, mine = len(params) > 1, params[0]     # as _finite_residual
    lam, mu = params[0, 1], params[0, 2]
    U = np.empty((nmax, k))
    fe = np.zeros((nmax, k))
    g = np.zeros((m, m))
    de = np.zeros((3, 3))
    e3 = np.empty((3, 3))
    x = np.empty(3)
    v = np.empty((3, 3))
    sig = np.empty(3)
    eps_e = np.empty(3)
    D = np.empty((3, 3))
    P = np.empty((m, m))
    for r in range(len(runs) - 1):
        n0, nloc = node_start[r], node_count[r]
        gather(du, nodes, n0, nloc, k, U)
        for s in range(runs[r], runs[r + 1]):
            p, q0 = order[s], qstart[s]
            point_gradient(G, q0, U, nloc, k, g)
            if cell is not None:
                shift_volume(g, theta[cell[p]], k, m)
            for a in range(m):
                for c in range(m):
                    de[a, c] = .5 * (g[a, c] + g[c, a])
            if not plastic:
                if several:
                    lam, mu = params[body[p], 1], params[body[p], 2]
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
                if several:
                    mine = params[body[p]]
                yielded[p], eq[0, p], eq[1, p] = principal_update(
                    mine, x, eq0[0, p], eq0[1, p], sig, eps_e, D)
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
                for A in range(m):
                    y[A, p] = sig[A]
                    for B in range(m):
                        dy_dx[A, B, p] = D[A, B]
            for a in range(m):
                for c in range(m):
                    P[a, c] = stress[a, c, p]
            if cell is not None:
                split_mean(P, k, w[p], cell[p], pressure)
            add_force(G, q0, P, w[p], nloc, k, fe)
        scatter_force(f, fe, nodes, n0, nloc, k)


@njit(cache=True, error_model="numpy")
def _stiffness(G, nodes, node_start, node_count, runs, order, qstart, mode,
               elements, first, length, graph_indptr, graph_indices, w, kind,
               C, body, x, y, dy_dx, vecs, dF_inv, data, cell, patch, h_row,
               h_col, bulk, k):
    """``K_(ia)(jc) = sum_p w_p A_abcd G_bi G_dj`` group by group with the
    tangent ``kind`` of each point (elastic: ``C[body[p]]``, set where
    the body changes), each group's matrix added to the CSR
    ``data`` of the pattern (``scatter_stiffness``: by the element
    pattern's places, or by bisection of the node graph).  With mean
    dilatation (``cell`` an array, else ``None``) the tangent has 3
    components whatever ``k``, the matrix takes its deviatoric part
    (``frame_deviatoric``, ``deviatoric_tangent``), and
    each point adds its rows of the cell's couplings to ``h_row``,
    ``h_col`` at its entries' ``patch`` places and ``tr12 w`` to the
    ``bulk`` of its ``cell`` (the caller forms the couplings)."""
    literally(k)
    m = k if cell is None else 3
    nmax = widest(node_count)
    Ke = np.zeros((nmax * k, nmax * k))
    H = np.empty((k, k, nmax * k))
    A = np.empty((m, m, m, m))
    work = tangent_work(m)
    deviatoric = np.empty((k, k, k, k))
    row, column = np.empty((k, k)), np.empty((k, k))
    traces, term_traces = np.empty((2, 3, 3)), np.empty((2, 9))
    tr12 = 0.
    current = -1                    # the body whose elastic tangent A is
    several = len(C) > 1
    for r in range(len(runs) - 1):
        n0, nloc = node_start[r], node_count[r]
        for s in range(runs[r], runs[r + 1]):
            p = order[s]
            if kind == ELASTIC_TANGENT and (
                    current < 0 or several and body[p] != current):
                # one for all points of a body: set where the body changes
                current = body[p] if several else 0
                set_uniform_tangent(kind, C[current], m, A)
                if cell is not None:
                    tr12 = deviatoric_tangent(A, k, deviatoric, row, column,
                                              traces)
            if cell is None:
                if kind != ELASTIC_TANGENT:  # (no early return: 2x faster)
                    point_tangent(kind, p, k, x, y, dy_dx, vecs, dF_inv, A,
                                  work)
                add_point_stiffness(G, qstart[s], A, w[p], nloc, k, H, Ke)
            else:
                if kind != ELASTIC_TANGENT:
                    point_frame(kind, p, m, x, y, dy_dx, vecs, dF_inv, work,
                                k)
                    tr12 = frame_deviatoric(
                        work[9], work[10], m + k * (k - 1), k, deviatoric,
                        row, column, traces, term_traces)
                add_point_stiffness(G, qstart[s], deviatoric, w[p], nloc, k,
                                    H, Ke)
                add_patch_rows(G, qstart[s], nloc, k, patch, row, column,
                               w[p], h_row, h_col)
                bulk[cell[p]] += tr12 * w[p]
        scatter_stiffness(Ke, nodes, n0, nloc, k, mode, elements, r, first,
                          length, graph_indptr, graph_indices, data)


@njit(cache=True, error_model="numpy")
def finite_residual_2d(G, nodes, node_start, node_count, runs, order, qstart,
                       w, du, start, params, body, eq0, f, dF, dF_inv, tau, d,
                       vecs, y, dy_dx, yielded, eq):
    """The finite-deformation pass on a 2D grid (``_finite_residual``)."""
    return _finite_residual(G, nodes, node_start, node_count, runs, order,
                            qstart, w, du, start, params, body, eq0, f, dF,
                            dF_inv, tau, d, vecs, y, dy_dx, yielded, eq,
                            None, None, None, None, 2)


@njit(cache=True, error_model="numpy")
def finite_residual_3d(G, nodes, node_start, node_count, runs, order, qstart,
                       w, du, start, params, body, eq0, f, dF, dF_inv, tau, d,
                       vecs, y, dy_dx, yielded, eq):
    """The finite-deformation pass on a 3D grid (``_finite_residual``)."""
    return _finite_residual(G, nodes, node_start, node_count, runs, order,
                            qstart, w, du, start, params, body, eq0, f, dF,
                            dF_inv, tau, d, vecs, y, dy_dx, yielded, eq,
                            None, None, None, None, 3)


@njit(cache=True, error_model="numpy")
def small_residual_2d(G, nodes, node_start, node_count, runs, order, qstart,
                      w, du, stress0, strain0, params, body, eq0, f, stress,
                      strain, x, vecs, y, dy_dx, yielded, eq):
    """The small-strain pass on a 2D grid (``_small_residual``)."""
    _small_residual(G, nodes, node_start, node_count, runs, order, qstart, w,
                    du, stress0, strain0, params, body, eq0, f, stress, strain,
                    x, vecs, y, dy_dx, yielded, eq, None, None, None, 2)


@njit(cache=True, error_model="numpy")
def small_residual_3d(G, nodes, node_start, node_count, runs, order, qstart,
                      w, du, stress0, strain0, params, body, eq0, f, stress,
                      strain, x, vecs, y, dy_dx, yielded, eq):
    """The small-strain pass on a 3D grid (``_small_residual``)."""
    _small_residual(G, nodes, node_start, node_count, runs, order, qstart, w,
                    du, stress0, strain0, params, body, eq0, f, stress, strain,
                    x, vecs, y, dy_dx, yielded, eq, None, None, None, 3)


@njit(cache=True, error_model="numpy")
def stiffness_2d(G, nodes, node_start, node_count, runs, order, qstart, mode,
                 elements, first, length, graph_indptr, graph_indices, w,
                 kind, C, body, x, y, dy_dx, vecs, dF_inv, data):
    """The stiffness pass on a 2D grid (``_stiffness``)."""
    _stiffness(G, nodes, node_start, node_count, runs, order, qstart, mode,
               elements, first, length, graph_indptr, graph_indices, w, kind,
               C, body, x, y, dy_dx, vecs, dF_inv, data, None, None, None,
               None, None, 2)


@njit(cache=True, error_model="numpy")
def stiffness_3d(G, nodes, node_start, node_count, runs, order, qstart, mode,
                 elements, first, length, graph_indptr, graph_indices, w,
                 kind, C, body, x, y, dy_dx, vecs, dF_inv, data):
    """The stiffness pass on a 3D grid (``_stiffness``)."""
    _stiffness(G, nodes, node_start, node_count, runs, order, qstart, mode,
               elements, first, length, graph_indptr, graph_indices, w, kind,
               C, body, x, y, dy_dx, vecs, dF_inv, data, None, None, None,
               None, None, 3)


@njit(cache=True, error_model="numpy")
def finite_commit(dim, params, body, d, vecs, eq0, dF, F0, F, J, b_e,
                  strain):
    """The converged state of a finite-deformation trial, point by point:
    ``F = dF F_n``, its determinant ``J`` (in-plane block times the
    out-of-plane diagonal below 3D, as
    :func:`~skfem_mpm.mechanics.hencky.inverse_and_det`), and from the
    trial's principal frame (``d = eig(b_tr) - 1``, ``vecs``) and the
    return map from ``eq0`` (``params[body[p]]``) the elastic ``b_e =
    sum exp(2 eps_A) e_A e_A`` and strain ``sum eps_A e_A e_A``."""
    eps = np.empty(3)
    tp = np.empty(3)
    eps_e = np.empty(3)
    D = np.empty((3, 3))
    several, mine = len(params) > 1, params[0]     # as _finite_residual
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
        if several:
            mine = params[body[p]]
        principal_update(mine, eps, eq0[0, p], eq0[1, p], tp, eps_e, D)
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


@njit(cache=True, error_model="numpy")
def _start_deviation(strain, out, k):
    """``b_n - I`` of every point on a grid of ``k`` dimensions
    (``start_deviation``)."""
    literally(k)
    b = np.empty((3, 3))
    x = np.empty(3)
    v = np.empty((3, 3))
    e = np.empty(3)
    for p in range(strain.shape[2]):
        for a in range(3):
            for c in range(3):
                b[a, c] = strain[a, c, p]
        principal_frame(b, k, x, v)
        for a in range(3):
            e[a] = math.expm1(2. * x[a])
        for a in range(3):
            for c in range(3):
                s = 0.
                for A in range(3):
                    s += e[A] * v[a, A] * v[c, A]
                out[a, c, p] = s


@njit(cache=True, error_model="numpy")
def start_deviation(dim, strain, out):
    """A load step's ``b_n - I = sum_A expm1(2 eps_A) e_A e_A`` (3, 3, n)
    into ``out`` from the points' elastic logarithmic strain (3, 3, n), as
    :meth:`~skfem_mpm.mechanics.kinematics.FiniteStrain.start_deviation`
    (no cancellation of ``b_n - I``), point by point in the residual
    pass's principal frame: 0.85 us a point in numpy in 3D."""
    if dim == 2:
        _start_deviation(strain, out, 2)
    else:
        _start_deviation(strain, out, 3)


@njit(cache=True, error_model="numpy")
def unstrained(strain):
    """Whether every entry of the points' strain (3, 3, n), C-contiguous,
    is zero (``-0.`` too), looked at until the first that is not (a
    strained step's first point, at once): :func:`start_deviation` then
    writes ``+0.`` everywhere (``expm1`` of a zero principal strain
    times its frame, summed from ``+0.``), and a step's caller may take
    zeros it never writes (a first step from unstrained points)."""
    flat = strain.ravel()
    for i in range(flat.size):
        if flat[i] != 0.:
            return False
    return True


def passes_of(dim: int):
    """``(finite_residual, small_residual, stiffness)`` compiled for
    ``dim`` components (2 or 3, known to the compiler, which unrolls the
    loops over components: four times faster than loops of any length;
    the nodes of a group, any number, are not), for every layout; each is
    compiled when first called."""
    if dim == 2:
        return finite_residual_2d, small_residual_2d, stiffness_2d
    return finite_residual_3d, small_residual_3d, stiffness_3d
