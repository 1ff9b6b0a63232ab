"""Point location: the element holding each material point and its local
coordinates in that element (seed 2.2.2, "Particle element locations" and
"Local coordinate identification").

Two paths give the same answer:

- a tensor-grid path for axis-aligned tensor-product grids (``MeshLine``,
  ``MeshQuad``/``MeshHex`` made by ``init_tensor``), O(1) per point on
  uniformly spaced axes and O(log n) per point on graded ones;
- a general path for any scikit-fem mesh (triangles, tetrahedra, distorted
  quadrilaterals and hexahedra): nearest element centroids from a k-d tree,
  then local coordinates by the inverse affine map or by Newton iteration on
  the isoparametric map.

Points on element boundaries are assigned deterministically: a point within
``tol`` (relative to the element size) of a face belongs to every element
sharing that face, and the one whose centroid has the largest coordinate
sum wins (ties: lowest element index).  On a tensor grid that is the cell
above the point along every axis, except on the grid's upper boundary.

"""
import logging
from typing import Callable, Tuple

import numpy as np
from numpy import ndarray
from scipy.sparse import coo_matrix
from scipy.spatial import cKDTree
from skfem.mesh import Mesh
from skfem.refdom import RefHex, RefLine, RefQuad, RefTet, RefTri

from ..errors import (InvalidInputError, NumericalError,
                     PointsOutsideGridError, UnsupportedElementError,
                     check_finite, check_real)
from ..kernels import check_kernels
from .mapping import fresh_mapping

logger = logging.getLogger(__name__)

__all__ = ["point_locator", "locate_points", "cell_coordinates"]

Locator = Callable[[ndarray], Tuple[ndarray, ndarray]]

CHUNK = 100_000

#: the round-off of positions, in units of their size, within which the
#: inverse map's Newton steps count as converged (many ulps: the residual
#: sums a cell's nodes times their shape values)
RESOLUTION = 64 * np.finfo(float).eps


def point_locator(mesh: Mesh, method: str = "auto",
                  tol: float = 1e-12, kernels: str = "auto") -> Locator:
    """Build a locator for ``mesh``, once per grid.

    Parameters
    ----------
    mesh
        Any scikit-fem mesh.
    method
        ``"auto"`` (tensor-grid path when the mesh is an axis-aligned
        tensor-product grid, general path otherwise), ``"tensor"`` or
        ``"general"``.
    tol
        Relative tolerance within which a point on an element face belongs
        to that element, in [0, 1e-6] (a larger one would accept points
        outside the grid and extrapolate the shape functions to them).

    Returns
    -------
    locate
        ``locate(x) -> (tind, X)`` for positions ``x`` of shape (dim, n):
        element indices (n,) and local coordinates (dim, n); its ``mesh``
        attribute is the mesh it locates on, ``locate.using(kernels)`` the
        same locator with another ``kernels`` (:func:`using_kernels`).  Raises
        :class:`~skfem_mpm.errors.PointsOutsideGridError` for points outside
        the mesh.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import point_locator
    >>> locate = point_locator(MeshQuad.init_tensor([0., 1., 2.], [0., 1.]))
    >>> tind, X = locate(np.array([[0.5, 1.5], [0.25, 0.75]]))
    >>> tind.tolist()
    [0, 1]

    """
    if method not in ("auto", "tensor", "general"):
        raise InvalidInputError(
            "method must be 'auto', 'tensor' or 'general', got {!r}"
            .format(method))
    if mesh.refdom not in (RefLine, RefQuad, RefHex, RefTri, RefTet):
        raise UnsupportedElementError(
            "cannot locate points on a {} mesh".format(type(mesh).__name__))
    if check_real("tol", tol) != tol or not 0. <= tol <= 1e-6:
        raise InvalidInputError("tol must lie in [0, 1e-6], got {!r}"
                                .format(tol))
    grid = None if method == "general" else tensor_grid(mesh)
    if method == "tensor" and grid is None:
        raise UnsupportedElementError(
            "{} is not an axis-aligned tensor-product grid; use method="
            "'general'".format(type(mesh).__name__))
    if grid is not None:
        find = _tensor_finder(mesh, grid, tol)
    elif mesh.affine:
        find = _general_finder(mesh, tol, _affine_local(mesh))
    else:
        find = _general_finder(mesh, tol, _newton_local(mesh))
    return _locator(mesh, find, check_kernels(kernels))


def _locator(mesh: Mesh, find, kernels: str) -> Locator:
    """:func:`point_locator`'s ``locate`` of the finder ``find``, by its
    compiled pass where it has one (``find.compiled``) and ``kernels``
    takes it."""
    dim = mesh.dim()
    compiled = getattr(find, "compiled", None)

    def locate(x: ndarray) -> Tuple[ndarray, ndarray]:
        x = np.asarray(x, dtype=np.float64)
        if x.ndim != 2 or x.shape[0] != dim:
            raise InvalidInputError(
                "positions must have shape ({}, n) for a {}D mesh, got {}"
                .format(dim, dim, x.shape))
        found = None if compiled is None else compiled(x, kernels)
        if found is None:
            check_finite("x", x)
            tind, X = find(x)
            outside = None
        else:
            tind, X, outside = found
        if outside is None or outside:
            missing = np.flatnonzero(tind < 0)
            if missing.size:
                raise PointsOutsideGridError(
                    "{} material point(s) lie outside the grid, indices {}{} "
                    "at x = {}".format(missing.size, missing[:10].tolist(),
                                       "..." if missing.size > 10 else "",
                                       x[:, missing[:3]].T.tolist()),
                    indices=missing)
        return tind, X

    locate.mesh = mesh
    locate.using = lambda other: _locator(mesh, find, check_kernels(other))
    return locate


def using_kernels(locate: Locator, kernels: str) -> Locator:
    """``locate`` with the run's ``kernels`` option where it is a
    :func:`point_locator` (``locate.using``), else ``locate`` itself."""
    using = getattr(locate, "using", None)
    return locate if using is None or kernels == "auto" else using(kernels)


def locate_points(mesh: Mesh, x: ndarray, **kwargs) -> Tuple[ndarray, ndarray]:
    """Locate points once: ``point_locator(mesh, **kwargs)(x)``.

    Build the locator with :func:`point_locator` when locating repeatedly on
    the same grid.

    """
    return point_locator(mesh, **kwargs)(x)


def cell_coordinates(mesh: Mesh, clip: bool = True
                     ) -> Callable[[ndarray, ndarray], ndarray]:
    """Build ``local(x, tind) -> X``: local coordinates (dim, n) of positions
    ``x`` (dim, n) in *given* elements ``tind`` (n,), clipped into the
    reference element (a position outside its element is moved to the
    nearest point of it, on tensor grids; simplices scale back onto the
    face ``sum X = 1``), or with ``clip=False`` beyond it (where the
    element's shape functions extrapolate; on other grids by Newton on
    the extrapolated map, refused with a
    :class:`~skfem_mpm.errors.NumericalError` where it does not invert:
    it was clamped to ``[-2, 3]``, and a face 4 cells from its cell's
    centre took -2.0 for -3.41, its force's moment wrong, silently).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm.quadrature.locate import cell_coordinates
    >>> local = cell_coordinates(MeshQuad.init_tensor([0., 1., 2.], [0., 1.]))
    >>> X = local(np.array([[0.5, 2.5], [0.25, 0.5]]), np.array([0, 1]))
    >>> X.T.tolist()    # init_tensor: reference axis 0 runs along y
    [[0.25, 0.5], [0.5, 1.0]]

    """
    if tensor_grid(mesh) is not None or mesh.affine:
        origin, Ainv = _element_affine_maps(mesh)

        def raw(x, tind):
            return np.einsum("ijn,jn->in", Ainv[:, :, tind],
                             x - origin[:, tind])
    else:
        newton = _newton_local(mesh, clamp=clip)

        def raw(x, tind):
            X = newton(x, tind[:, None])[:, :, 0]
            lost = np.flatnonzero(np.isnan(X).any(axis=0))
            if lost.size and not clip:
                raise NumericalError(
                    "{} position(s) cannot be mapped into their elements' "
                    "coordinates (the element's map extrapolated that far "
                    "does not invert), e.g. {} in element {}".format(
                        lost.size, x[:, lost[0]].tolist(),
                        int(tind[lost[0]])))
            return X

    simplex = mesh.refdom in (RefTri, RefTet)

    if not clip:
        return raw

    def local(x: ndarray, tind: ndarray) -> ndarray:
        X = np.clip(np.nan_to_num(raw(x, tind), nan=.5), 0., 1.)
        if simplex:
            X /= np.maximum(X.sum(axis=0), 1.)
        return X

    return local


def _element_affine_maps(mesh: Mesh) -> Tuple[ndarray, ndarray]:
    """x = origin + A X per element; returns origin (dim, nel), A^-1."""
    mapping = fresh_mapping(mesh)
    X0 = np.zeros((mesh.dim(), 1))
    origin = mapping.F(X0)[:, :, 0]
    A = mapping.DF(X0)[:, :, :, 0]
    Ainv = np.linalg.inv(np.moveaxis(A, -1, 0))
    return origin, np.moveaxis(Ainv, 0, -1)


def tensor_grid(mesh: Mesh):
    """(axes, shape, cell_to_elem) if mesh is an axis-aligned grid, else None."""
    dim = mesh.dim()
    if mesh.refdom not in (RefLine, RefQuad, RefHex) \
            or mesh.t.shape[0] != 2 ** dim:
        return None
    axes = [np.unique(mesh.p[d]) for d in range(dim)]
    shape = tuple(len(a) - 1 for a in axes)
    if min(shape) < 1 or np.prod(shape) != mesh.nelements \
            or np.prod([len(a) for a in axes]) != mesh.nvertices:
        return None
    idx = np.array([np.searchsorted(a, mesh.p[d]) for d, a in enumerate(axes)])
    ti = idx[:, mesh.t]                       # (dim, corners, nel)
    lo = ti.min(axis=1)
    off = ti - lo[:, None, :]
    if off.max() > 1:
        return None
    code = sum(off[d] << d for d in range(dim))
    if not (np.sort(code, axis=0) == np.arange(2 ** dim)[:, None]).all():
        return None
    cell = np.ravel_multi_index(tuple(lo), shape)
    cell_to_elem = np.full(np.prod(shape), -1, dtype=np.int64)
    cell_to_elem[cell] = np.arange(mesh.nelements)
    if (cell_to_elem < 0).any():
        return None
    return axes, shape, cell_to_elem


def _axis_cells(a: ndarray, tol: float) -> Callable[[ndarray], ndarray]:
    """``cells(x)``: the cell index of positions x along one axis with
    nodes a, -1 outside; whether the axis is uniformly spaced is decided
    once, here (it cost half of a small block's location, every step):
    ``cells.uniform`` is ``(first node, spacing)``, or ``None``.
    Clipped by ``np.maximum`` and ``np.minimum``, ``np.clip``'s numbers
    without its checks (8 us a call, half of a small block's location)."""
    n = len(a) - 1
    h = np.diff(a)
    if np.allclose(h, h[0], rtol=1e-12, atol=0.):
        origin, step = a[0], h[0]

        def cells(x: ndarray) -> ndarray:
            s = (x - origin) / step
            i = np.minimum(np.maximum(s, -1.), n + 1.)
            i += tol
            i = np.floor(i, out=i).astype(np.int64)
            np.minimum(np.maximum(i, 0, out=i), n - 1, out=i)
            i[(s < -tol) | (s > n + tol)] = -1
            return i
        cells.uniform = origin, step
    else:
        inner = a[1:-1] - tol * h[:-1]
        low, high = a[0] - tol * h[0], a[-1] + tol * h[-1]

        def cells(x: ndarray) -> ndarray:
            i = np.searchsorted(inner, x, side="right")
            np.minimum(np.maximum(i, 0, out=i), n - 1, out=i)
            i[(x < low) | (x > high)] = -1
            return i
        cells.uniform = None
    return cells


#: points a tensor-grid location treats at a time: its temporaries (about
#: 110 bytes a point in 3D) for all points at once were the peak of a 3D
#: run's heap after a step (the location for the next one)
LOCATE_BLOCK = 1 << 14


def _tensor_finder(mesh: Mesh, grid, tol: float):
    axes, shape, cell_to_elem = grid
    origin, Ainv = _element_affine_maps(mesh)
    # rows contiguous: np.take of a row along its elements copied a strided
    # one whole at every call (of every block of points)
    Ainv = np.ascontiguousarray(Ainv)
    along = [_axis_cells(a, tol) for a in axes]
    # the cell of index (i_0, .., i_d) is cell_to_elem[sum i_k stride_k]
    strides = np.cumprod((1,) + shape[:0:-1])[::-1]

    def find_block(x, X):
        """The elements of the positions ``x`` (-1 outside), their local
        coordinates written to ``X``."""
        cell = np.zeros(x.shape[1], dtype=np.int64)
        outside = np.zeros(x.shape[1], dtype=bool)
        for d, cells in enumerate(along):
            i = cells(x[d])
            outside |= i < 0
            i *= strides[d]
            cell += i
        cell[outside] = 0
        tind = cell_to_elem[cell]
        del cell
        # X = Ainv (x - origin), a row of Ainv at a time: the products
        # summed in einsum's order, without Ainv at every point (72 bytes
        # a point in 3D)
        v = x - origin[:, tind]
        for i in range(len(v)):
            row = np.take(Ainv[i], tind, axis=1)
            row *= v
            np.add.reduce(row, axis=0, out=X[i])
        tind[outside] = -1
        return tind

    def find(x):
        X = np.empty(x.shape)
        n = x.shape[1]
        if n <= LOCATE_BLOCK:
            return find_block(x, X), X
        tind = np.empty(n, dtype=cell_to_elem.dtype)
        for s in range(0, n, LOCATE_BLOCK):
            tind[s:s + LOCATE_BLOCK] = find_block(
                x[:, s:s + LOCATE_BLOCK], X[:, s:s + LOCATE_BLOCK])
        return tind, X

    uniform = [cells.uniform for cells in along]
    if all(axis is not None for axis in uniform):
        first = np.array([axis[0] for axis in uniform], dtype=np.float64)
        step = np.array([axis[1] for axis in uniform], dtype=np.float64)
        ncells = np.array(shape, dtype=np.int64)
        strides = np.asarray(strides, dtype=np.int64)
        origin = np.ascontiguousarray(origin, dtype=np.float64)

        def compiled(x, kernels):
            """``(tind, X, outside)`` by the compiled pass where
            ``kernels`` takes it, else (or at a non-finite position, which
            the numpy path names) ``None``."""
            passes = _compiled_locate(kernels)
            if passes is None:
                return None
            x = np.ascontiguousarray(x)
            tind = np.empty(x.shape[1], dtype=cell_to_elem.dtype)
            X = np.empty(x.shape)
            outside, bad = passes.tensor_locate(
                x, first, step, ncells, strides, tol, cell_to_elem, origin,
                Ainv, tind, X)
            return None if bad else (tind, X, outside)
        find.compiled = compiled
    return find


_LOCATE_PASSES = []     # the compiled_kernels function, imported late


def _compiled_locate(kernels: str):
    """:mod:`skfem_mpm.kernels.locate` where ``kernels`` takes compiled
    passes (:func:`~skfem_mpm.quadrature.basis.compiled_kernels`), else
    ``None``."""
    if not _LOCATE_PASSES:             # (basis imports this module)
        from .basis import compiled_kernels
        _LOCATE_PASSES.append(compiled_kernels)
    return _LOCATE_PASSES[0]("locate", kernels)


def _margin(refdom, X: ndarray) -> ndarray:
    """Smallest distance to the reference element's faces (< 0: outside)."""
    if refdom in (RefTri, RefTet):
        return np.minimum(X.min(axis=0), 1. - X.sum(axis=0))
    return np.minimum(X.min(axis=0), (1. - X).min(axis=0))


def _affine_local(mesh: Mesh):
    origin, Ainv = _element_affine_maps(mesh)

    def local(x, cand):
        """x (dim, m), cand (m, k) -> X (dim, m, k)."""
        return np.einsum("ijmk,jmk->imk", Ainv[:, :, cand],
                         x[:, :, None] - origin[:, cand])

    return local


def _newton_local(mesh: Mesh, maxiter: int = 30, clamp: bool = True):
    """Inverse isoparametric map by Newton iteration (no mapping caches),
    in coordinates relative to each element's first node, so that cells
    small against their coordinates (1 m cells at x = 5e5) are inverted
    to the round-off of their own size, not of the coordinates'.  With
    ``clamp`` the iterates stay in ``[-2, 3]`` (a finder's candidates:
    a position further out is not in that cell); without it they go
    where the extrapolated map takes them (``NaN`` where Newton does not
    converge)."""
    elem = mesh.elem()
    p, t = mesh.doflocs, mesh.dofs.element_dofs
    dim = mesh.dim()

    def local(x, cand):
        m, k = cand.shape
        tind = cand.ravel()
        offset = np.repeat(x, k, axis=1) - p[:, t[0, tind]]
        X = np.full((dim, m * k), .5)
        active = np.arange(m * k)
        for _ in range(maxiter):
            Xa, ta = X[:, active], tind[active]
            F = np.zeros(Xa.shape)
            DF = np.zeros((dim,) + Xa.shape)
            for i in range(t.shape[0]):
                phi, dphi = elem.lbasis(Xa, i)
                node = p[:, t[i, ta]] - p[:, t[0, ta]]     # (dim, pairs)
                F += node * phi
                DF += node[:, None] * dphi[None]
            inverse = np.linalg.inv(np.moveaxis(DF, (0, 1), (-2, -1)))
            dX = np.einsum("mij,jm->im", inverse, offset[:, active] - F)
            Xnew = np.clip(Xa + dX, -2., 3.) if clamp else Xa + dX
            # converged where the step is within what round-off in the
            # offsets moves the local coordinates by (a fixed 1e-14 was
            # below it where positions lie cells beyond their element:
            # a contact's domain corners)
            floor = RESOLUTION * np.abs(offset[:, active]).max(axis=0) \
                * np.abs(inverse).sum(axis=2).max(axis=1)
            moved = np.abs(Xnew - Xa).max(axis=0) > np.maximum(1e-14, floor)
            X[:, active] = Xnew
            active = active[moved]
            if active.size == 0:
                break
        X[:, active] = np.nan      # not converged: not inside
        return X.reshape(dim, m, k)

    return local


def _vertex_neighbours(mesh: Mesh) -> ndarray:
    """(nel, max_neighbours) elements sharing a vertex with each element,
    the element itself included; rows padded with the element itself."""
    nel, nv = mesh.nelements, mesh.t.shape[0]
    incidence = coo_matrix((np.ones(mesh.t.size), (np.repeat(
        np.arange(nel), nv), mesh.t.T.ravel())), shape=(nel, mesh.nvertices))
    adjacency = (incidence.tocsr() @ incidence.T.tocsr()).tocsr()
    counts = np.diff(adjacency.indptr)
    out = np.repeat(np.arange(nel)[:, None], counts.max(), axis=1)
    rows = np.repeat(np.arange(nel), counts)
    cols = np.arange(adjacency.nnz) - np.repeat(adjacency.indptr[:-1], counts)
    out[rows, cols] = adjacency.indices
    return out


def _general_finder(mesh: Mesh, tol: float, local):
    centroids = mesh.p[:, mesh.t].mean(axis=1)
    csum = centroids.sum(axis=0)
    tree = cKDTree(centroids.T)
    neighbours = _vertex_neighbours(mesh)
    nel = mesh.nelements
    k0 = min(nel, 2 ** mesh.dim())
    kmax = min(nel, 512)

    def choose(x, cand):
        """Among candidates (m, k) holding x (dim, m), the deciding one:
        largest centroid coordinate sum, then lowest index."""
        Xc = local(x, cand)
        margin = _margin(mesh.refdom, Xc)
        score = np.where(margin >= -tol, csum[cand], -np.inf)
        best = score.max(axis=1)
        pick = np.where(score == best[:, None], cand, nel).argmin(axis=1)
        rows = np.arange(cand.shape[0])
        return (np.isfinite(best), cand[rows, pick], Xc[:, rows, pick],
                margin[rows, pick])

    def find_chunk(x):
        n = x.shape[1]
        tind = np.full(n, -1, dtype=np.int64)
        X = np.zeros_like(x)
        margin = np.zeros(n)
        todo = np.arange(n)
        k = k0
        while todo.size:
            _, cand = tree.query(x[:, todo].T, k=k)
            found, t, Xt, mt = choose(x[:, todo], cand.reshape(todo.size, k))
            hit = todo[found]
            tind[hit], X[:, hit], margin[hit] = t[found], Xt[:, found], \
                mt[found]
            todo = todo[~found]
            if k >= kmax:
                break
            k = min(kmax, 4 * k)
        # near a face, every element sharing a vertex may hold the point
        near = np.flatnonzero((tind >= 0) & (margin <= tol))
        if near.size:
            _, t, Xt, _ = choose(x[:, near], neighbours[tind[near]])
            tind[near], X[:, near] = t, Xt
        return tind, X

    def find(x):
        parts = [find_chunk(x[:, s:s + CHUNK])
                 for s in range(0, x.shape[1], CHUNK)]
        return (np.concatenate([p[0] for p in parts]),
                np.hstack([p[1] for p in parts]))

    return find
