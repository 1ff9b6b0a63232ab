"""Generalised Interpolation Material Point (GIMP) operators on
axis-aligned tensor-product grids.

Each point carries a domain, a box of half-lengths ``domain`` (dim, n)
around it.  Its weight for a grid function is the average of the grid's
shape function over the domain, its gradient operator the averaged
gradient.  The domain is cut into pieces by the grid lines; every piece lies
in one element and is integrated exactly by a Gauss rule evaluated with the
scikit-fem element itself (a :class:`~skfem_mpm.MaterialPointBasis` on the
sub-points), so any tensor-product element family works; linear elements
take the closed form of :mod:`skfem_mpm.methods.gimp_linear` instead, equal to
round-off and without sub-points.  Domains are clipped to the grid.

Two domain updates: ``"ugimp"`` keeps domains fixed; ``"cpgimp"`` stretches
them with the diagonal of the right stretch tensor ``U`` of ``F = R U``, so
a rigid rotation leaves them unchanged.

GIMP: Bardenhagen and Kober, *Comput. Model. Eng. Sci.* 5, 2004; its
implicit, finite-deformation form (iGIMP): Charlton, Coombs and Augarde,
*Comput. Struct.* 190, 2017 (docs/references.md).

"""
import functools
import itertools
from typing import Callable

import numpy as np
from numpy import ndarray
from numpy.polynomial.legendre import leggauss
from scipy.sparse import coo_matrix
from skfem.element import Element, ElementVector
from skfem.mesh import Mesh

from ..quadrature.basis import MaterialPointBasis
from ..errors import UnsupportedElementError
from ..kernels import check_kernels
from .gimp_linear import LINEAR_ELEMENTS, LinearGimp
from .gimp_linear import sliver as sliver_of
from ..quadrature.locate import Locator, tensor_grid
from .operators import SparseOperator
from ..quadrature.points import MaterialPoints

__all__ = ["gimp_operator", "gimp_operators", "subpoint_gimp_operator",
           "initial_domains", "stretched_domains", "single_point_domains"]


def single_point_domains(method: str, per_axis: float, nsteps: int) -> str:
    """A sentence on a GIMP run (``"ugimp"``, ``"cpgimp"``) whose points
    are seeded one per cell and axis (``per_axis`` below 1.5) and move
    between its ``nsteps`` steps, else ``""``.  Each domain then spans a
    cell; once a point has moved across a grid node, its strain is the
    average of the two cells' it straddles, with weights ``t`` and
    ``1 - t``, and a grid displacement whose cell strains alternate in
    sign in the ratio ``(1 - t) / t`` strains no point: next to free of
    energy where ``t`` is near one half, held only at the body's ends.
    A lecturer's 1D column (64 cells, its top settling 1.3 cells, 20
    steps) came out zig-zag in finite deformation, its top points
    -1.167, -0.707, -1.318, -0.544, -1.576 against 2 points per cell's
    -0.962, with no word (cpGIMP; uGIMP alike), and in small strain its
    stiffness turned singular at step 11, the ghost penalty of cut cells
    no help; a 2D column of 2 x 32 cells, 1 x 1 points, from -0.933 to
    -0.991.  One step solves at the seeded points, where a domain fills
    its cell: exact.  Logged as a warning at the run's start and added
    to a failed run's error.

    >>> single_point_domains("cpgimp", 1., 20)[:46]
    "method 'cpgimp' with 1 point per cell and axis"
    >>> [single_point_domains("cpgimp", n, s) for n, s in ((2., 20),
    ...                                                    (1., 1))]
    ['', '']
    """
    if method not in ("ugimp", "cpgimp") or per_axis >= 1.5 or nsteps < 2:
        return ""
    return (
        "method {!r} with 1 point per cell and axis: each point's domain "
        "spans a cell, and once the points have moved across grid nodes "
        "each averages the strains of two cells, so a grid displacement "
        "of alternate nodes strains next to no point (a zero-energy mode: "
        "a 1D column settling 1.3 cells in 20 steps had its top points "
        "zig-zag, up to 64% too far, or in small strain a singular "
        "stiffness); "
        "seed 2 points per cell and axis".format(method))


def _grid_axes(mesh: Mesh):
    grid = tensor_grid(mesh)
    if grid is None:
        raise UnsupportedElementError(
            "GIMP needs an axis-aligned tensor-product grid (MeshLine, or "
            "MeshQuad/MeshHex from init_tensor), got a general {}"
            .format(type(mesh).__name__))
    return grid[0]


def initial_domains(mesh: Mesh, points: MaterialPoints,
                    per_axis: int) -> ndarray:
    """Half-lengths of points seeded ``per_axis`` per element and axis:
    half the sub-cell size along each axis, (dim, n)."""
    axes = _grid_axes(mesh)
    out = np.empty_like(points.x)
    for d, a in enumerate(axes):
        cell = np.clip(np.searchsorted(a, points.x[d], side="right") - 1, 0,
                       len(a) - 2)
        out[d] = np.diff(a)[cell] / (2 * per_axis)
    return out


def stretched_domains(domain0: ndarray, F: ndarray) -> ndarray:
    """cpGIMP: initial half-lengths scaled by the diagonal of the right
    stretch tensor ``U = sqrt(F^T F)``, (dim, n)."""
    dim = domain0.shape[0]
    C = np.einsum("kap,kbp->pab", F[:dim, :dim], F[:dim, :dim])
    w, v = np.linalg.eigh(C)
    U = np.einsum("pak,pk,pbk->pab", v, np.sqrt(w), v)
    return domain0 * np.einsum("paa->ap", U)


def _axis_pieces(a: ndarray, lo: ndarray, hi: ndarray):
    """Pieces of [lo, hi] cut by grid nodes a: lists of (start, end) arrays,
    zero length where a point has fewer pieces.  A domain edge within
    :func:`~skfem_mpm.methods.gimp_linear.sliver` of a grid line is on
    that line (no sliver pieces from round-off)."""
    n = len(a) - 1
    first = np.clip(np.searchsorted(a, lo, side="right") - 1, 0, n - 1)
    last = np.clip(np.searchsorted(a, hi, side="left") - 1, 0, n - 1)
    pieces = []
    for k in range(int((last - first).max()) + 1):
        cell = np.minimum(first + k, n - 1)
        start = np.maximum(lo, a[cell])
        end = np.where(first + k <= last, np.minimum(hi, a[cell + 1]), start)
        sliver = end - start <= sliver_of(a[cell + 1], a[cell + 1] - a[cell])
        pieces.append((start, np.where(sliver, start, end)))
    return pieces


def _subpoints(axes, x: ndarray, domain: ndarray, order: int):
    """Gauss sub-points of every domain piece: positions (dim, m), weights
    (m,) summing to one per point, and the parent point of each.  Along
    an axis where a half-length is zero (a face of a domain, where a
    surface load acts) the point itself, its weight whole."""
    dim, n = x.shape
    xi, wg = leggauss(order)
    per_axis = []
    for d, a in enumerate(axes):
        lo = np.clip(x[d] - domain[d], a[0], a[-1])
        hi = np.clip(x[d] + domain[d], a[0], a[-1])
        flat = domain[d] == 0
        # (faces all on grid lines have no piece: the point itself)
        pieces = _axis_pieces(a, lo, hi) or [(lo, hi)]
        per_axis.append([((s + e) / 2 + (e - s) / 2 * xi[:, None],
                          np.where(flat, float(k == 0), e - s)[None]
                          * wg[:, None] / 2)
                         for k, (s, e) in enumerate(pieces)])
    coords, weights, parent = [], [], []
    for combo in itertools.product(*per_axis):
        for gauss in itertools.product(range(order), repeat=dim):
            w = np.prod([combo[d][1][g] for d, g in enumerate(gauss)], axis=0)
            keep = np.flatnonzero(w > 0)
            coords.append(np.array([combo[d][0][g][keep]
                                    for d, g in enumerate(gauss)]))
            weights.append(w[keep])
            parent.append(keep)
    coords, weights = np.hstack(coords), np.concatenate(weights)
    parent = np.concatenate(parent)
    total = np.bincount(parent, weights, minlength=n)
    return coords, weights / total[parent], parent


def gimp_operators(mesh: Mesh, elem: Element, locate: Locator,
                   kernels: str = "auto") -> Callable[[ndarray, ndarray],
                                                      SparseOperator]:
    """``operator(x, domain)`` giving the GIMP operator of points on this
    grid: closed form for linear elements
    (:class:`~skfem_mpm.methods.gimp_linear.LinearGimp`), Gauss sub-points
    (:func:`subpoint_gimp_operator`, its basis by ``kernels``) otherwise.
    Set up once per run (node numbering), called every step."""
    scalar = elem.elem if isinstance(elem, ElementVector) else elem
    _grid_axes(mesh)
    if isinstance(scalar, LINEAR_ELEMENTS):
        return LinearGimp(mesh, scalar)
    return functools.partial(subpoint_gimp_operator, mesh, scalar,
                             locate=locate, kernels=check_kernels(kernels))


def gimp_operator(mesh: Mesh, elem: Element, x: ndarray, domain: ndarray,
                  locate: Locator, kernels: str = "auto") -> SparseOperator:
    """GIMP weights and gradients of points x with half-lengths ``domain``
    (parameters as in :func:`subpoint_gimp_operator`; see
    :func:`gimp_operators` to reuse the set-up over steps)."""
    return gimp_operators(mesh, elem, locate, kernels)(x, domain)


def subpoint_gimp_operator(mesh: Mesh, elem: Element, x: ndarray,
                           domain: ndarray, locate: Locator,
                           kernels: str = "auto") -> SparseOperator:
    """GIMP weights and gradients of points x with half-lengths ``domain``
    by Gauss sub-points on every domain piece (any tensor-product element).

    Parameters
    ----------
    mesh
        Axis-aligned tensor-product grid.
    elem
        The scikit-fem element (scalar or ``ElementVector``).
    x, domain
        Positions and domain half-lengths, (dim, n).
    locate
        The grid's :func:`~skfem_mpm.point_locator`.
    kernels
        The run's ``kernels`` option (:class:`~skfem_mpm.solve.options.
        Options`): whether the sub-points' material-point basis takes
        compiled passes (:func:`~skfem_mpm.quadrature.basis.
        compiled_kernels`).

    Returns
    -------
    SparseOperator

    """
    scalar = elem.elem if isinstance(elem, ElementVector) else elem
    axes = _grid_axes(mesh)
    order = scalar.maxdeg // 2 + 1       # exact for the element's degree
    sub_x, sub_w, parent = _subpoints(axes, x, domain, order)
    tind, X = locate(sub_x)
    basis = MaterialPointBasis(mesh, scalar,
                               MaterialPoints(x=sub_x, volume=sub_w),
                               location=(tind, X), kernels=kernels)
    rows, cols, vals = [], [], []
    grads = [[] for _ in range(mesh.dim())]
    dofs = basis.dofs.element_dofs
    for j in range(basis.Nbfun):
        field = basis.basis[j][0]
        rows.append(parent)
        cols.append(dofs[j, tind])
        vals.append(basis.point_values(np.asarray(field)) * sub_w)
        g = basis.point_values(field.grad)
        for d in range(mesh.dim()):
            grads[d].append(g[d] * sub_w)
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    shape = (x.shape[1], basis.dofs.N)

    def matrix(v):
        return coo_matrix((np.concatenate(v), (rows, cols)),
                          shape=shape).tocsr()

    return SparseOperator(matrix(vals), [matrix(g) for g in grads],
                          basis.tind)
