"""Compiled point location on a tensor grid of uniformly spaced axes
(:func:`skfem_mpm.quadrature.locate.point_locator`): the cell of each
point and its local coordinates in one pass, the numpy path's numbers
operation for operation (``_axis_cells``'s scaled position, clamp, floor
and bounds; ``find_block``'s ``Ainv (x - origin)`` summed over the axes
in order from numpy's ``+0.``, the identity its reduction starts at: a
position on its element's origin has ``+0.``, not ``-0.``): equal to
the bit (``tests/test_compiled.py``).  A one-step run at 56 points in 2D
located its points twice, 60-90 us each, some 20 numpy calls a
location; the pass takes 4-6 us."""
import numpy as np
from numba import njit

__all__ = ["tensor_locate"]


@njit(cache=True, error_model="numpy")
def tensor_locate(x, first, step, ncells, strides, tol, cell_to_elem,
                  origin, Ainv, tind, X):
    """The elements ``tind`` (n,) of the positions ``x`` (dim, n) and
    their local coordinates ``X`` (dim, n), written; -1 outside the grid
    (and the local coordinates in the grid's first cell's element, as the
    numpy path's).  Axis ``d`` has ``ncells[d]`` cells of ``step[d]``
    from ``first[d]``; the cell of indices ``i_d`` is ``cell_to_elem[sum
    i_d strides[d]]``; element ``e`` maps ``X`` to ``origin[:, e] +
    A_e X`` (``Ainv`` (dim, dim, nel)).  Returns ``(outside, bad)``: the
    points outside the grid and the non-finite coordinates (then nothing
    is located: the caller's numpy path names them)."""
    dim, n = x.shape
    bad = 0
    for d in range(dim):
        for p in range(n):
            if not np.isfinite(x[d, p]):
                bad += 1
    if bad:
        return 0, bad
    outside = 0
    # two loops: the elements first, then the local coordinates, whose
    # reads of the elements' maps are then independent of one another
    # (one loop waited on each point's element before its maps: points
    # in random order over a 1e6-point grid took twice numpy's time)
    for p in range(n):
        cell = 0
        out = False
        for d in range(dim):
            m = ncells[d]
            s = (x[d, p] - first[d]) / step[d]
            c = min(max(s, -1.), m + 1.)
            c += tol
            i = np.int64(np.floor(c))
            i = min(max(i, 0), m - 1)
            if s < -tol or s > m + tol:
                out = True
            else:
                cell += i * strides[d]
        if out:
            tind[p] = -1 - cell_to_elem[0]        # (its element, coded)
            outside += 1
        else:
            tind[p] = cell_to_elem[cell]
    for p in range(n):
        e = tind[p]
        if e < 0:
            e = -1 - e
        for i in range(dim):
            acc = 0.           # numpy's reduction starts at its identity
            for j in range(dim):
                acc += Ainv[i, j, e] * (x[j, p] - origin[j, e])
            X[i, p] = acc
    if outside:
        for p in range(n):
            if tind[p] < 0:
                tind[p] = -1
    return outside, 0
