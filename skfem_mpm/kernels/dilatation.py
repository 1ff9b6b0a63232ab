"""Compiled passes of mean dilatation, the B-bar cell average of
:mod:`skfem_mpm.stabilisation.volumetric`: the passes of
:mod:`skfem_mpm.kernels.passes` with every point's divergence replaced by
its cell's average, and the average's parts of the force and stiffness
cell by cell.

A cell's average ``theta_c(u) = sum_(I, a) b[I, a] u[I, a]`` runs over
its *patch*, the union of the supports of the points whose centre lies
in it (an element's nodes in standard MPM).  The cells' layout
(:meth:`~skfem_mpm.stabilisation.volumetric.ElementAverage.kernel_layout`,
trailing arguments of every pass): the cell of each point ``cell``, the
patches' nodes ``patch_nodes`` (cell c's from ``patch_start[c]``,
ascending) and their rows of the average ``b`` (patch entries, k), and
for each entry of the shape gradients ``G`` the patch entry of its node
in its point's cell, ``patch``.  The passes:

- ``finite_residual_2d``, ``_3d``, ``small_residual_2d``, ``_3d``: the
  cells' ``theta``, then the residual pass with 3x3 gradients
  ``grad + (theta - div) I / 3`` (in plane strain the out-of-plane
  component the shift alone), the force of the stresses' deviatoric part
  against the gradients, then that of their means against the averages;
- ``stiffness_2d``, ``_3d``: each point's 3-component tangent split into
  its deviatoric part against the gradients (the support's group matrix,
  as without the average) and its rows of the cell's couplings, then each
  cell's couplings ``b (x) h_row + h_col (x) b + bulk / 9 b (x) b`` over
  its patch, scattered into the same pattern (the grid's element pattern,
  or the node graph of the patches, which holds that of the supports).
"""
import numpy as np
from numba import literally, njit

from .passes import _finite_residual, _small_residual, _stiffness, widest
from .points import scatter_stiffness

__all__ = ["passes_of", "SOURCES"]

#: the first 16 hex digits of the sha256 of the kernel files whose code
#: this module compiles in (as :data:`skfem_mpm.kernels.passes.SOURCES`)
SOURCES = "8762136cc307a70d"


@njit(cache=True, error_model="numpy", inline="always")
def cell_dilatation(patch_start, patch_nodes, b, du, k):
    """``theta_c = sum_(I, a) b[I, a] du[k node_I + a]`` of every cell."""
    theta = np.empty(len(patch_start) - 1)
    for c in range(len(theta)):
        s = 0.
        for e in range(patch_start[c], patch_start[c + 1]):
            for a in range(k):
                s += b[e, a] * du[k * patch_nodes[e] + a]
        theta[c] = s
    return theta


@njit(cache=True, error_model="numpy", inline="always")
def add_cell_force(patch_start, patch_nodes, b, pressure, k, f):
    """``f[k node_I + a] += b[I, a] pressure_c`` over every cell's patch:
    the force of the stresses' weighted means summed per cell."""
    for c in range(len(patch_start) - 1):
        for e in range(patch_start[c], patch_start[c + 1]):
            for a in range(k):
                f[k * patch_nodes[e] + a] += b[e, a] * pressure[c]


@njit(cache=True, error_model="numpy", inline="always")
def add_cell_couplings(patch_start, patch_nodes, b, h_row, h_col, bulk, k,
                       mode, elements, first, length, graph_indptr,
                       graph_indices, data):
    """Each cell's couplings ``K_(Ia)(Jc) = b_Ia h_row_Jc + h_col_Ia b_Jc +
    bulk / 9 b_Ia b_Jc`` over its patch, added to the CSR ``data`` at the
    places of cell c's element (``elements[c]``: standard MPM, whose cells
    are its groups) or by bisection of the node graph."""
    count = np.diff(patch_start)
    nmax = widest(count)
    Ke = np.zeros((nmax * k, nmax * k))
    for c in range(len(count)):
        e0, nu = patch_start[c], count[c]
        vol = bulk[c] / 9
        for i in range(nu):
            for a in range(k):
                bi, hi = b[e0 + i, a], h_col[e0 + i, a]
                for j in range(nu):
                    for d in range(k):
                        Ke[i * k + a, j * k + d] = bi * h_row[e0 + j, d] \
                            + hi * b[e0 + j, d] + vol * bi * b[e0 + j, d]
        scatter_stiffness(Ke, patch_nodes, e0, nu, k, mode, elements, c,
                          first, length, graph_indptr, graph_indices, data)


@njit(cache=True, error_model="numpy")
def _finite_residual_bar(G, nodes, node_start, node_count, runs, order,
                         qstart, w, du, start, params, body, eq0, f, dF,
                         dF_inv, tau, d, vecs, y, dy_dx, yielded, eq, cell,
                         patch, patch_start, patch_nodes, b, k):
    """The finite-deformation pass with mean dilatation on a grid of
    ``k`` dimensions."""
    literally(k)
    theta = cell_dilatation(patch_start, patch_nodes, b, du, k)
    pressure = np.zeros(len(theta))
    status = _finite_residual(G, nodes, node_start, node_count, runs, order,
                              qstart, w, du, start, params, body, eq0, f, dF,
                              dF_inv, tau, d, vecs, y, dy_dx, yielded,
                              eq, cell, theta, pressure, None, k)
    add_cell_force(patch_start, patch_nodes, b, pressure, k, f)
    return status


@njit(cache=True, error_model="numpy")
def _small_residual_bar(G, nodes, node_start, node_count, runs, order, qstart,
                        w, du, stress0, strain0, params, body, eq0, f, stress,
                        strain, x, vecs, y, dy_dx, yielded, eq, cell, patch,
                        patch_start, patch_nodes, b, k):
    """The small-strain pass with mean dilatation on a grid of ``k``
    dimensions."""
    literally(k)
    theta = cell_dilatation(patch_start, patch_nodes, b, du, k)
    pressure = np.zeros(len(theta))
    _small_residual(G, nodes, node_start, node_count, runs, order, qstart, w,
                    du, stress0, strain0, params, body, eq0, f, stress, strain,
                    x, vecs, y, dy_dx, yielded, eq, cell, theta, pressure, k)
    add_cell_force(patch_start, patch_nodes, b, pressure, k, f)


@njit(cache=True, error_model="numpy")
def _stiffness_bar(G, nodes, node_start, node_count, runs, order, qstart,
                   mode, elements, first, length, graph_indptr,
                   graph_indices, w, kind, C, body, x, y, dy_dx, vecs, dF_inv,
                   data, cell, patch, patch_start, patch_nodes, b, k):
    """The stiffness pass with mean dilatation on a grid of ``k``
    dimensions (``C``: the elastic tangent in 3 components)."""
    literally(k)
    h_row, h_col = np.zeros((len(patch_nodes), k)), \
        np.zeros((len(patch_nodes), k))
    bulk = np.zeros(len(patch_start) - 1)
    _stiffness(G, nodes, node_start, node_count, runs, order, qstart, mode,
               elements, first, length, graph_indptr, graph_indices, w, kind,
               C, body, x, y, dy_dx, vecs, dF_inv, data, cell, patch, h_row,
               h_col, bulk, k)
    add_cell_couplings(patch_start, patch_nodes, b, h_row, h_col, bulk, k,
                       mode, elements, first, length, graph_indptr,
                       graph_indices, data)


@njit(cache=True, error_model="numpy")
def finite_residual_2d(G, nodes, node_start, node_count, runs, order, qstart,
                       w, du, start, params, body, eq0, f, dF, dF_inv, tau,
                       d, vecs, y, dy_dx, yielded, eq, cell, patch,
                       patch_start, patch_nodes, b):
    """``_finite_residual_bar`` on a 2D grid."""
    return _finite_residual_bar(G, nodes, node_start, node_count, runs, order,
                                qstart, w, du, start, params, body, eq0, f, dF,
                                dF_inv, tau, d, vecs, y, dy_dx, yielded,
                                eq, cell, patch, patch_start, patch_nodes, b,
                                2)


@njit(cache=True, error_model="numpy")
def finite_residual_3d(G, nodes, node_start, node_count, runs, order, qstart,
                       w, du, start, params, body, eq0, f, dF, dF_inv, tau,
                       d, vecs, y, dy_dx, yielded, eq, cell, patch,
                       patch_start, patch_nodes, b):
    """``_finite_residual_bar`` on a 3D grid."""
    return _finite_residual_bar(G, nodes, node_start, node_count, runs, order,
                                qstart, w, du, start, params, body, eq0, f, dF,
                                dF_inv, tau, d, vecs, y, dy_dx, yielded,
                                eq, cell, patch, patch_start, patch_nodes, b,
                                3)


@njit(cache=True, error_model="numpy")
def small_residual_2d(G, nodes, node_start, node_count, runs, order, qstart, w,
                      du, stress0, strain0, params, body, eq0, f, stress,
                      strain, x, vecs, y, dy_dx, yielded, eq, cell, patch,
                      patch_start, patch_nodes, b):
    """``_small_residual_bar`` on a 2D grid."""
    _small_residual_bar(G, nodes, node_start, node_count, runs, order, qstart,
                        w, du, stress0, strain0, params, body, eq0, f, stress,
                        strain, x, vecs, y, dy_dx, yielded, eq, cell, patch,
                        patch_start, patch_nodes, b, 2)


@njit(cache=True, error_model="numpy")
def small_residual_3d(G, nodes, node_start, node_count, runs, order, qstart, w,
                      du, stress0, strain0, params, body, eq0, f, stress,
                      strain, x, vecs, y, dy_dx, yielded, eq, cell, patch,
                      patch_start, patch_nodes, b):
    """``_small_residual_bar`` on a 3D grid."""
    _small_residual_bar(G, nodes, node_start, node_count, runs, order, qstart,
                        w, du, stress0, strain0, params, body, eq0, f, stress,
                        strain, x, vecs, y, dy_dx, yielded, eq, cell, patch,
                        patch_start, patch_nodes, b, 3)


@njit(cache=True, error_model="numpy")
def stiffness_2d(G, nodes, node_start, node_count, runs, order, qstart, mode,
                 elements, first, length, graph_indptr, graph_indices, w, kind,
                 C, body, x, y, dy_dx, vecs, dF_inv, data, cell, patch,
                 patch_start, patch_nodes, b):
    """``_stiffness_bar`` on a 2D grid."""
    _stiffness_bar(G, nodes, node_start, node_count, runs, order, qstart, mode,
                   elements, first, length, graph_indptr, graph_indices, w,
                   kind, C, body, x, y, dy_dx, vecs, dF_inv, data, cell, patch,
                   patch_start, patch_nodes, b, 2)


@njit(cache=True, error_model="numpy")
def stiffness_3d(G, nodes, node_start, node_count, runs, order, qstart, mode,
                 elements, first, length, graph_indptr, graph_indices, w, kind,
                 C, body, x, y, dy_dx, vecs, dF_inv, data, cell, patch,
                 patch_start, patch_nodes, b):
    """``_stiffness_bar`` on a 3D grid."""
    _stiffness_bar(G, nodes, node_start, node_count, runs, order, qstart, mode,
                   elements, first, length, graph_indptr, graph_indices, w,
                   kind, C, body, x, y, dy_dx, vecs, dF_inv, data, cell, patch,
                   patch_start, patch_nodes, b, 3)


def passes_of(dim: int):
    """``(finite_residual, small_residual, stiffness)`` with mean
    dilatation, compiled for ``dim`` (2 or 3) when first called; their
    arguments those of :func:`skfem_mpm.kernels.passes.passes_of`'s, then
    the cells' layout ``(cell, patch, patch_start, patch_nodes, b)``."""
    if dim == 2:
        return finite_residual_2d, small_residual_2d, stiffness_2d
    return finite_residual_3d, small_residual_3d, stiffness_3d
