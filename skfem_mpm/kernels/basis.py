"""Compiled fields of a material-point basis: the values and gradients of
scikit-fem's bilinear quadrilateral (``ElementQuad1``) and trilinear
hexahedron (``ElementHex1``) on their own isoparametric meshes, at each
point of each element, in one pass (:func:`skfem_mpm.quadrature.basis.
compiled_fields`).

Each point's numbers are scikit-fem's, operation for operation: the
Jacobian summed over the element's nodes from zero in node order (as
``PointMapping._jacobian``), the inverse as ``MappingIsoparametric.invDF``
forms it (the adjugate over the determinant), the shape functions'
values and reference gradients by ``lbasis``'s expressions, and the
gradients ``invDF^T dphi`` summed over the reference axes in order (as
``_h1_fields``): equal to the bit (``tests/test_basis.py``).  A zero
determinant returns 1 (the caller's numpy path raises scikit-fem's
error).

Beside them the basis's slot layout (:func:`point_slots`, the points
ordered by element by counting, :func:`by_element`) and a nodal vector's
values at the points (:func:`point_values`, what a standard MPM
operator's ``values`` forms), equal to the numpy path's to the bit, and
its transpose, the point forces' nodal loads (:func:`point_loads`, what
a standard MPM operator's ``point_force`` forms), in the order of
numpy's ``einsum`` on a two-lane build (:func:`slot_sums`).
"""
import numpy as np
from numba import njit

__all__ = ["quad1_fields", "hex1_fields", "point_slots",
           "point_values", "slot_sums", "point_loads", "quad1_range",
           "hex1_range", "values_range"]


@njit(cache=True, error_model="numpy", inline="always")
def quad1_basis(i, x, y):
    """``lbasis(X, i)`` of ``ElementQuad1`` at one point: ``(phi, dphi_x,
    dphi_y)``."""
    if i == 0:
        return (1. - x) * (1. - y), -1. + y, -1. + x
    if i == 1:
        return x * (1. - y), 1. - y, -x
    if i == 2:
        return x * y, y, x
    return (1. - x) * y, -y, 1. - x


@njit(cache=True, error_model="numpy")
def quad1_fields(p, element_dofs, tind, X, values, gradients):
    """Values (4, e, q) and gradients (4, 2, e, q) of ``ElementQuad1`` at
    the reference points ``X`` (2, e, q) of the elements ``tind`` (e,),
    whose nodes ``element_dofs[:, tind]`` (the mesh's (4, elements)) have
    the coordinates ``p`` (2, vertices); 1 at a zero Jacobian
    determinant, else 0."""
    return quad1_range(p, element_dofs, tind, X, values, gradients, 0,
                       X.shape[1])


@njit(cache=True, error_model="numpy", inline="always")
def quad1_range(p, element_dofs, tind, X, values, gradients, lo, hi):
    """:func:`quad1_fields` of the elements ``lo`` to ``hi``."""
    nq = X.shape[2]
    d0 = np.empty(4)
    d1 = np.empty(4)
    for e in range(lo, hi):
        for q in range(nq):
            x, y = X[0, e, q], X[1, e, q]
            J00 = J01 = J10 = J11 = 0.
            for k in range(4):
                phi, d0[k], d1[k] = quad1_basis(k, x, y)
                values[k, e, q] = phi
                node = element_dofs[k, tind[e]]
                px, py = p[0, node], p[1, node]
                J00 += px * d0[k]
                J01 += px * d1[k]
                J10 += py * d0[k]
                J11 += py * d1[k]
            det = J00 * J11 - J01 * J10
            if det == 0.:
                return 1
            i00, i01 = J11 / det, -J01 / det
            i10, i11 = -J10 / det, J00 / det
            for k in range(4):
                gradients[k, 0, e, q] = i00 * d0[k] + i10 * d1[k]
                gradients[k, 1, e, q] = i01 * d0[k] + i11 * d1[k]
    return 0


@njit(cache=True, error_model="numpy", inline="always")
def hex1_basis(i, x, y, z):
    """``lbasis(X, i)`` of ``ElementHex1`` at one point: ``(phi, dphi_x,
    dphi_y, dphi_z)``."""
    if i == 0:
        return x * y * z, y * z, x * z, x * y
    if i == 1:
        return x * y * (1 - z), y * (1 - z), x * (1 - z), -x * y
    if i == 2:
        return x * (1 - y) * z, (1 - y) * z, -x * z, x * (1 - y)
    if i == 3:
        return (1 - x) * y * z, -y * z, (1 - x) * z, (1 - x) * y
    if i == 4:
        return (x * (1 - y) * (1 - z), (1 - y) * (1 - z), -x * (1 - z),
                -x * (1 - y))
    if i == 5:
        return ((1 - x) * y * (1 - z), -y * (1 - z), (1 - x) * (1 - z),
                -(1 - x) * y)
    if i == 6:
        return ((1 - x) * (1 - y) * z, -(1 - y) * z, -(1 - x) * z,
                (1 - x) * (1 - y))
    return ((1 - x) * (1 - y) * (1 - z), -(1 - y) * (1 - z),
            -(1 - x) * (1 - z), -(1 - x) * (1 - y))


@njit(cache=True, error_model="numpy")
def hex1_fields(p, element_dofs, tind, X, values, gradients):
    """:func:`quad1_fields` of ``ElementHex1``: values (8, e, q) and
    gradients (8, 3, e, q) at ``X`` (3, e, q), the mesh's element nodes
    (8, elements), ``p`` (3, vertices)."""
    return hex1_range(p, element_dofs, tind, X, values, gradients, 0,
                      X.shape[1])


@njit(cache=True, error_model="numpy", inline="always")
def hex1_range(p, element_dofs, tind, X, values, gradients, lo, hi):
    """:func:`hex1_fields` of the elements ``lo`` to ``hi``."""
    nq = X.shape[2]
    d = np.empty((3, 8))
    J = np.empty((3, 3))
    inv = np.empty((3, 3))
    for e in range(lo, hi):
        for q in range(nq):
            x, y, z = X[0, e, q], X[1, e, q], X[2, e, q]
            J[:] = 0.
            for k in range(8):
                phi, d[0, k], d[1, k], d[2, k] = hex1_basis(k, x, y, z)
                values[k, e, q] = phi
                vertex = element_dofs[k, tind[e]]
                for a in range(3):
                    node = p[a, vertex]
                    for b in range(3):
                        J[a, b] += node * d[b, k]
            det = (J[0, 0] * (J[1, 1] * J[2, 2] - J[1, 2] * J[2, 1]) -
                   J[0, 1] * (J[1, 0] * J[2, 2] - J[1, 2] * J[2, 0]) +
                   J[0, 2] * (J[1, 0] * J[2, 1] - J[1, 1] * J[2, 0]))
            if det == 0.:
                return 1
            inv[0, 0] = -J[1, 2] * J[2, 1] + J[1, 1] * J[2, 2]
            inv[1, 0] = J[1, 2] * J[2, 0] - J[1, 0] * J[2, 2]
            inv[2, 0] = -J[1, 1] * J[2, 0] + J[1, 0] * J[2, 1]
            inv[0, 1] = J[0, 2] * J[2, 1] - J[0, 1] * J[2, 2]
            inv[1, 1] = -J[0, 2] * J[2, 0] + J[0, 0] * J[2, 2]
            inv[2, 1] = J[0, 1] * J[2, 0] - J[0, 0] * J[2, 1]
            inv[0, 2] = -J[0, 2] * J[1, 1] + J[0, 1] * J[1, 2]
            inv[1, 2] = J[0, 2] * J[1, 0] - J[0, 0] * J[1, 2]
            inv[2, 2] = -J[0, 1] * J[1, 0] + J[0, 0] * J[1, 1]
            for a in range(3):
                for b in range(3):
                    inv[a, b] = inv[a, b] / det
            for k in range(8):
                for a in range(3):
                    gradients[k, a, e, q] = (inv[0, a] * d[0, k]
                                             + inv[1, a] * d[1, k]) \
                        + inv[2, a] * d[2, k]
    return 0


@njit(cache=True, error_model="numpy")
def by_element(tind):
    """The stable order of the points by element, ``np.argsort(tind,
    kind="stable")`` (the one order a stable sort gives): by counting the
    points of each element, in one pass over them, not a merge sort (at
    99540 points in their seeding order 0.35 against 4.5 ms, at 1e6 2.6
    against 57); negative elements sorted as numpy does."""
    n = tind.size
    least, bins = 0, 0
    for j in range(n):
        least, bins = min(least, tind[j]), max(bins, tind[j] + 1)
    if least < 0:
        return np.argsort(tind, kind="mergesort")
    start = np.zeros(bins + 1, dtype=np.int64)
    for j in range(n):
        start[tind[j] + 1] += 1
    for e in range(bins):
        start[e + 1] += start[e]
    order = np.empty(n, dtype=np.int64)
    for j in range(n):
        order[start[tind[j]]] = j
        start[tind[j]] += 1
    return order


@njit(cache=True, error_model="numpy")
def point_slots(tind, X, volume):
    """The slot layout of a material-point basis over all its points
    (:class:`skfem_mpm.quadrature.basis.MaterialPointBasis`, the numpy
    path's arrays entry for entry): the points by element in a stable
    order, the active elements ascending, each element's points in its
    first slots and the padding slots at its first point's coordinates.
    Returns ``(elements, Xq, dx, point_index, slot_of_point, padding)``
    and the groups of :meth:`~skfem_mpm.quadrature.basis.
    MaterialPointBasis.groups`: ``(runs, in_slots, flat)``."""
    n, dim = tind.size, X.shape[0]
    order = by_element(tind)
    nel, run, slots = 0, 0, 0
    for j in range(n):
        if j == 0 or tind[order[j]] != tind[order[j - 1]]:
            nel += 1
            run = 0
        run += 1
        slots = max(slots, run)
    elements = np.empty(nel, dtype=tind.dtype)
    Xq = np.empty((dim, nel, slots))
    dx = np.zeros((nel, slots))
    point_index = np.full((nel, slots), -1, dtype=np.int64)
    slot_of_point = np.empty(n, dtype=np.int64)
    runs = np.zeros(nel + 1, dtype=np.int64)
    in_slots = np.empty(n, dtype=np.int64)
    flat = np.empty(n, dtype=np.int64)
    e, s = -1, 0
    for j in range(n):
        p = order[j]
        if j == 0 or tind[p] != tind[order[j - 1]]:
            e += 1
            s = 0
            elements[e] = tind[p]
            for a in range(dim):
                for k in range(slots):
                    Xq[a, e, k] = X[a, p]
        for a in range(dim):
            Xq[a, e, s] = X[a, p]
        dx[e, s] = volume[p]
        point_index[e, s] = p
        slot_of_point[p] = e * slots + s
        runs[e + 1] = j + 1
        in_slots[j] = p
        flat[j] = e * slots + s
        s += 1
    padding = np.flatnonzero(point_index.ravel() < 0)
    return (elements, Xq, dx, point_index, slot_of_point, padding,
            (runs, in_slots, flat))


@njit(cache=True, error_model="numpy")
def point_values(N, dofs, u, k, slot_of_point, slots):
    """``u``'s values at the points, (k, n): ``sum_i N[i, e, m] u[k
    dofs[i, e] + a]`` summed from zero in node order at each point's slot
    ``(e, m)`` (``slot_of_point``, ``slots`` a row), what
    :meth:`~skfem_mpm.methods.operators.PointOperator.values` forms by a
    gather, an ``einsum`` and a ``take`` (whose sum runs over the nodes as
    the outer loop of its iterator, from zero: the same operations, equal
    to the bit, ``tests/test_perf18_values.py``), in one pass."""
    out = np.empty((k, slot_of_point.size))
    values_range(N, dofs, u, k, slot_of_point, slots, out, 0,
                 slot_of_point.size)
    return out


@njit(cache=True, error_model="numpy", inline="always")
def values_range(N, dofs, u, k, slot_of_point, slots, out, lo, hi):
    """:func:`point_values` of the points ``lo`` to ``hi`` into ``out``."""
    nloc = N.shape[0]
    for p in range(lo, hi):
        e, m = slot_of_point[p] // slots, slot_of_point[p] % slots
        for a in range(k):
            s = 0.
            for i in range(nloc):
                s += N[i, e, m] * u[k * dofs[i, e] + a]
            out[a, p] = s


@njit(cache=True, error_model="numpy", inline="always")
def slot_sum(N, F, i, e, a, slots):
    """``sum_m N[i, e, m] F[a, e, m]`` in the order of numpy's ``einsum``
    over a contiguous axis into a stride-0 output on a build of two-lane
    vectors without fused multiply-add (``sum_of_products_contig_contig_
    outstride0_two`` on x86-64's baseline): two lane sums, of the even
    and the odd slots, each over blocks of eight slots taken last to
    first, then the rest in order, a lane past the end adding ``0 * 0``;
    the lanes' sum added to zero (signs of zeros included)."""
    even, odd = 0., 0.
    m = 0
    while slots - m >= 8:
        for j in range(3, -1, -1):
            k = m + 2 * j
            even = N[i, e, k] * F[a, e, k] + even
            odd = N[i, e, k + 1] * F[a, e, k + 1] + odd
        m += 8
    while m < slots:
        even = N[i, e, m] * F[a, e, m] + even
        odd = (N[i, e, m + 1] * F[a, e, m + 1] if m + 1 < slots
               else 0. * 0.) + odd
        m += 2
    return 0. + (even + odd)


@njit(cache=True, error_model="numpy")
def slot_sums(N, F):
    """``np.einsum("iem,aem->iae", N, F)`` of C-contiguous ``N`` (nloc,
    e, m) and ``F`` (k, e, m), summed as :func:`slot_sum`."""
    nloc, nel, slots = N.shape
    k = F.shape[0]
    out = np.empty((nloc, k, nel))
    for i in range(nloc):
        for a in range(k):
            for e in range(nel):
                out[i, a, e] = slot_sum(N, F, i, e, a, slots)
    return out


@njit(cache=True, error_model="numpy")
def point_loads(N, f, point_index, dofs, k, size):
    """The nodal loads (size,) of the point forces ``f`` (k, n): ``sum_p
    N_i(x_p) f_ap`` into DOF ``k dofs[i, e] + a``, what :meth:`~skfem_mpm.
    methods.operators.PointOperator.point_force` forms by a gather into
    the slots (``point_index``, -1 a padding slot: zero), an ``einsum``
    over each element's slots (:func:`slot_sum`'s order) and a
    ``bincount`` (the element vectors' rows ``k i + a`` in order, each
    over the elements, added to zero in turn), in one pass."""
    nloc, nel, slots = N.shape
    F = np.zeros((k, nel, slots))
    for e in range(nel):
        for m in range(slots):
            p = point_index[e, m]
            if p >= 0:
                for a in range(k):
                    F[a, e, m] = f[a, p]
    out = np.zeros(size)
    for i in range(nloc):
        for a in range(k):
            for e in range(nel):
                out[k * dofs[i, e] + a] += slot_sum(N, F, i, e, a, slots)
    return out
