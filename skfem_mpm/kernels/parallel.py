"""The plain passes of :mod:`skfem_mpm.kernels.passes` on the machine's
cores.

A large operator's groups are cut into three *chunks* or more of
consecutive groups (:func:`~skfem_mpm.methods.assembly.phased_chunks`,
kept in its :class:`~skfem_mpm.methods.assembly.KernelLayout`); the even
chunks run side by side, then the odd ones.  Two chunks run at the same
time only where no grid node is in both, so their scatters of force and
stiffness never add into one entry at once, and every entry is summed in
an order that the chunks alone fix: an answer is the same to the bit on
one thread and on many.  (It is not the serial pass's to the bit: a
chunk's first groups add into a node it shares with the chunk before it
before that chunk does, where the odd chunk runs first: round-off.)  The
passes with mean dilatation or F-bar, which also sum into their cells'
arrays, stay serial.  The commit of a finite-deformation step and a
step's ``b_n - I``, point by point, run in chunks of points (as many as
the operator's chunks), to the bit the serial passes' answers (the
commit also divides the stress by ``J`` there: a 72-MB division at 1e6
points, and its new pages, on one core before).

The threads are numba's: as many as the machine's cores, or
``NUMBA_NUM_THREADS`` (``numba.set_num_threads`` in a process).  Its
threading layer is ``workqueue`` unless ``NUMBA_THREADING_LAYER`` names
another: always there, and safe in a process that forks after a run
(GNU OpenMP's is not); it does not allow two parallel calls at once, so
one runs at a time in a process (:data:`LOCK`; a second thread's call
waits).
"""
import os
import threading

import numba
import numpy as np
from numba import njit, prange

from .basis import hex1_range, quad1_range, values_range
from .passes import (_finite_residual, _small_residual, _stiffness,
                     finite_commit, start_deviation)

__all__ = ["passes_of", "commit_in_chunks",
           "start_deviation_in_chunks", "values_in_chunks",
           "fields_in_chunks", "split_count", "LOCK", "SOURCES"]

#: the first 16 hex digits of the sha256 of the kernel files whose code
#: this module compiles in (as :data:`skfem_mpm.kernels.passes.SOURCES`)
SOURCES = "b32b3d2f5db52a2b"
#: one parallel call at a time in a process
LOCK = threading.Lock()
#: the points (or elements) from which a pass point by point that no
#: layout cuts (a basis's fields, a vector's values at the points) runs in
#: chunks on the cores (:func:`split_count`): the passes' least
#: (:func:`~skfem_mpm.methods.assembly.phased_chunks`); a location, 0.02
#: s at 1e6 points in 2D, gained nothing in chunks
SPLIT = 3 * 8192
if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"



@njit(cache=True, error_model="numpy", parallel=True)
def _finite_chunks(chunks, G, nodes, node_start, node_count, runs, order,
                   qstart, w, du, start, params, body, eq0, f, dF, dF_inv,
                   tau, d, vecs, y, dy_dx, yielded, eq, k):
    status = np.zeros(len(chunks) - 1, dtype=np.int64)
    for phase in range(2):
        for c in prange((len(chunks) - phase) // 2):
            j = 2 * c + phase
            a, b = chunks[j], chunks[j + 1]
            status[j] = _finite_residual(
                G, nodes, node_start[a:b], node_count[a:b], runs[a:b + 1],
                order, qstart, w, du, start, params, body, eq0, f, dF,
                dF_inv, tau, d, vecs, y, dy_dx, yielded, eq, None, None,
                None, None, k)
    return status.max()


@njit(cache=True, error_model="numpy", parallel=True)
def _small_chunks(chunks, G, nodes, node_start, node_count, runs, order,
                  qstart, w, du, stress0, strain0, params, body, eq0, f,
                  stress, strain, x, vecs, y, dy_dx, yielded, eq, k):
    for phase in range(2):
        for c in prange((len(chunks) - phase) // 2):
            j = 2 * c + phase
            a, b = chunks[j], chunks[j + 1]
            _small_residual(
                G, nodes, node_start[a:b], node_count[a:b], runs[a:b + 1],
                order, qstart, w, du, stress0, strain0, params, body, eq0, f,
                stress, strain, x, vecs, y, dy_dx, yielded, eq, None, None,
                None, k)


@njit(cache=True, error_model="numpy", parallel=True)
def _stiffness_chunks(chunks, G, nodes, node_start, node_count, runs, order,
                      qstart, mode, elements, first, length, graph_indptr,
                      graph_indices, w, kind, C, body, x, y, dy_dx, vecs,
                      dF_inv, data, k):
    m = len(elements)           # none where the pattern is a node graph
    for phase in range(2):
        for c in prange((len(chunks) - phase) // 2):
            j = 2 * c + phase
            a, b = chunks[j], chunks[j + 1]
            _stiffness(G, nodes, node_start[a:b], node_count[a:b],
                       runs[a:b + 1], order, qstart, mode,
                       elements[min(a, m):min(b, m)], first, length,
                       graph_indptr, graph_indices, w, kind, C, body, x, y,
                       dy_dx, vecs, dF_inv, data, None, None, None, None,
                       None, k)


@njit(cache=True, error_model="numpy")
def finite_residual_2d(chunks, G, nodes, node_start, node_count, runs, order,
                       qstart, w, du, start, params, body, eq0, f, dF, dF_inv,
                       tau, d, vecs, y, dy_dx, yielded, eq):
    """The finite-deformation pass on a 2D grid in ``chunks``."""
    return _finite_chunks(chunks, G, nodes, node_start, node_count, runs,
                          order, qstart, w, du, start, params, body, eq0, f,
                          dF, dF_inv, tau, d, vecs, y, dy_dx, yielded, eq, 2)


@njit(cache=True, error_model="numpy")
def finite_residual_3d(chunks, G, nodes, node_start, node_count, runs, order,
                       qstart, w, du, start, params, body, eq0, f, dF, dF_inv,
                       tau, d, vecs, y, dy_dx, yielded, eq):
    """The finite-deformation pass on a 3D grid in ``chunks``."""
    return _finite_chunks(chunks, G, nodes, node_start, node_count, runs,
                          order, qstart, w, du, start, params, body, eq0, f,
                          dF, dF_inv, tau, d, vecs, y, dy_dx, yielded, eq, 3)


@njit(cache=True, error_model="numpy")
def small_residual_2d(chunks, G, nodes, node_start, node_count, runs, order,
                      qstart, w, du, stress0, strain0, params, body, eq0, f,
                      stress, strain, x, vecs, y, dy_dx, yielded, eq):
    """The small-strain pass on a 2D grid in ``chunks``."""
    _small_chunks(chunks, G, nodes, node_start, node_count, runs, order,
                  qstart, w, du, stress0, strain0, params, body, eq0, f,
                  stress, strain, x, vecs, y, dy_dx, yielded, eq, 2)


@njit(cache=True, error_model="numpy")
def small_residual_3d(chunks, G, nodes, node_start, node_count, runs, order,
                      qstart, w, du, stress0, strain0, params, body, eq0, f,
                      stress, strain, x, vecs, y, dy_dx, yielded, eq):
    """The small-strain pass on a 3D grid in ``chunks``."""
    _small_chunks(chunks, G, nodes, node_start, node_count, runs, order,
                  qstart, w, du, stress0, strain0, params, body, eq0, f,
                  stress, strain, x, vecs, y, dy_dx, yielded, eq, 3)


@njit(cache=True, error_model="numpy")
def stiffness_2d(chunks, G, nodes, node_start, node_count, runs, order,
                 qstart, mode, elements, first, length, graph_indptr,
                 graph_indices, w, kind, C, body, x, y, dy_dx, vecs, dF_inv,
                 data):
    """The stiffness pass on a 2D grid in ``chunks``."""
    _stiffness_chunks(chunks, G, nodes, node_start, node_count, runs, order,
                      qstart, mode, elements, first, length, graph_indptr,
                      graph_indices, w, kind, C, body, x, y, dy_dx, vecs,
                      dF_inv, data, 2)


@njit(cache=True, error_model="numpy")
def stiffness_3d(chunks, G, nodes, node_start, node_count, runs, order,
                 qstart, mode, elements, first, length, graph_indptr,
                 graph_indices, w, kind, C, body, x, y, dy_dx, vecs, dF_inv,
                 data):
    """The stiffness pass on a 3D grid in ``chunks``."""
    _stiffness_chunks(chunks, G, nodes, node_start, node_count, runs, order,
                      qstart, mode, elements, first, length, graph_indptr,
                      graph_indices, w, kind, C, body, x, y, dy_dx, vecs,
                      dF_inv, data, 3)


@njit(cache=True, error_model="numpy", parallel=True)
def commit_in_chunks(count, dim, params, body, d, vecs, eq0, dF, F0, F, J,
                     b_e, strain, tau, volume0, stress, volume):
    """:func:`~skfem_mpm.kernels.passes.finite_commit` in ``count`` chunks
    of points side by side (``body`` one entry a point), and of each
    chunk's points the Cauchy stress ``tau / J`` and the volume ``J
    volume0`` (as numpy's division and product, to the bit; ``stress``
    may be ``tau`` itself, each entry divided in place)."""
    n = d.shape[1]
    for c in prange(count):
        a, b = n * c // count, n * (c + 1) // count
        finite_commit(dim, params, body[a:b], d[:, a:b], vecs[:, :, a:b],
                      eq0[:, a:b], dF[:, :, a:b], F0[:, :, a:b],
                      F[:, :, a:b], J[a:b], b_e[:, :, a:b],
                      strain[:, :, a:b])
        for i in range(3):
            for j in range(3):
                for p in range(a, b):
                    stress[i, j, p] = tau[i, j, p] / J[p]
        for p in range(a, b):
            volume[p] = J[p] * volume0[p]


@njit(cache=True, error_model="numpy", parallel=True)
def start_deviation_in_chunks(count, dim, strain, out):
    """:func:`~skfem_mpm.kernels.passes.start_deviation` in ``count``
    chunks of points side by side."""
    n = strain.shape[2]
    for c in prange(count):
        a, b = n * c // count, n * (c + 1) // count
        start_deviation(dim, strain[:, :, a:b], out[:, :, a:b])


def split_count(n: int) -> int:
    """The chunks of a pass point by point over ``n`` points (or
    elements): numba's threads where there are several and ``n`` reaches
    :data:`SPLIT`, else 1 (serial)."""
    threads = numba.get_num_threads()
    return threads if threads > 1 and n >= SPLIT else 1


@njit(cache=True, error_model="numpy", parallel=True)
def values_in_chunks(count, N, dofs, u, k, slot_of_point, slots):
    """:func:`~skfem_mpm.kernels.basis.point_values` in ``count`` chunks
    of points side by side (the same answer to the bit)."""
    n = slot_of_point.size
    out = np.empty((k, n))
    for c in prange(count):
        values_range(N, dofs, u, k, slot_of_point, slots, out,
                     n * c // count, n * (c + 1) // count)
    return out


@njit(cache=True, error_model="numpy", parallel=True)
def fields_in_chunks(count, hexahedra, p, element_dofs, tind, X, values,
                     gradients):
    """:func:`~skfem_mpm.kernels.basis.quad1_fields` (or with
    ``hexahedra`` :func:`~skfem_mpm.kernels.basis.hex1_fields`) in
    ``count`` chunks of elements side by side; 1 where an element's
    Jacobian determinant is zero (the values then hold no answer), else
    0."""
    nel = X.shape[1]
    status = np.zeros(count, dtype=np.int64)
    for c in prange(count):
        lo, hi = nel * c // count, nel * (c + 1) // count
        status[c] = hex1_range(p, element_dofs, tind, X, values, gradients,
                               lo, hi) if hexahedra else quad1_range(
            p, element_dofs, tind, X, values, gradients, lo, hi)
    return status.max()


def passes_of(dim: int):
    """``(finite_residual, small_residual, stiffness)`` in chunks for
    ``dim`` components (as :func:`skfem_mpm.kernels.passes.passes_of`,
    the chunks' bounds their first argument)."""
    if dim == 2:
        return finite_residual_2d, small_residual_2d, stiffness_2d
    return finite_residual_3d, small_residual_3d, stiffness_3d
