"""Quadratic (and cubic) B-spline MPM on axis-aligned tensor-product grids.

The grid's nodes are the control points.  Along an axis of uniform
spacing ``h`` the function of node ``i`` is the uniform quadratic
B-spline centred on it (Steffen, Kirby and Berzins 2008), with
``xi = (x - x_i) / h``::

    N(xi) = 3/4 - xi^2              for |xi| <= 1/2,
    N(xi) = (3/2 - |xi|)^2 / 2      for 1/2 <= |xi| <= 3/2,

C1 across the grid lines (its knots are the cells' midpoints), so a point
crossing a grid line sees no jump in the gradient: no cell-crossing
error.  In 2D and 3D the functions are tensor products, 3^dim per point.

At the grid's edges the splines centred on the ghost nodes ``x_-1`` and
``x_n+1`` outside the grid are folded into their neighbours by linear
extrapolation of a ghost control value, ``u_-1 = 2 u_0 - u_1``::

    N_0' = N_0 + 2 N_-1,    N_1' = N_1 - N_-1      (and at x_n alike).

On ``[x_0, x_0 + h/2]`` this gives the hat functions ``N_0' = 1 - t``,
``N_1' = t`` (``t = (x - x_0) / h``), C1 at ``x_0 + h/2``, non-negative:
the basis keeps the partition of unity and linear completeness on
``[x_0, x_n]`` and interpolates at the edges (``N_0'(x_0) = 1``, every
other function 0 there), so supports on the grid's boundary lines hold
exactly what they hold in standard MPM.  An axis of one cell gets the
linear hats.  Bing et al. (2019) modify the splines at the boundary for
the same purpose; this construction is not claimed to be theirs
(``docs/references.md``).

With point domains (boxes of half-lengths ``domain``, as GIMP's) the
operator averages the splines over each domain instead (the splines'
counterpart of GIMP: weights ``(1/V_p) int N_i``, gradients ``(1/V_p) int
grad N_i``, exact for a stress constant over each domain, so the points'
rule stays second order once their spacing leaves the knots').  Along an
axis the average over ``[lo, hi]`` has the closed form ``(C(hi) -
C(lo)) / (hi - lo)`` with ``C`` the antiderivative of the folded spline,
and its gradient ``(N(hi) - N(lo)) / (hi - lo)``; a box's average is the
product of its axes'.  Domains are clipped to the grid, as GIMP's.  A
spline whose support meets a domain only by a sliver (a free surface
moved past a knot) is folded into its neighbours for that point
(:data:`SLIVER_SPLINE`): its stiffness would be below the others'
round-off.

The cubic splines (:class:`CubicBSpline`, ``method="bspline3"`` and
``"bspline3-gimp"``) are the same construction one degree up: knots at
the nodes, C2, 4^dim nodes a point, the ghosts folded alike (the spline
of ``x_-1`` reaches ``x_1``; none of ``x_-2`` enters the grid).

Uniform spacing per axis is required (axes may differ): a graded axis is
refused.  The grid element must be linear (``ElementLineP1``,
``ElementQuad1``, ``ElementHex1``): its nodes are the control points and
its DOF numbering the operator's.

"""
import logging

import numpy as np
from numpy import ndarray
from scipy.ndimage import maximum_filter
from scipy.sparse import coo_matrix, csr_matrix
from skfem.element import Element
from skfem.mesh import Mesh

from ..errors import UnsupportedElementError
from ..quadrature.locate import tensor_grid
from ..spelling import setting
from .gimp_linear import LINEAR_ELEMENTS, LinearGimp
from .operators import SparseOperator

__all__ = ["QuadraticBSpline", "CubicBSpline", "spline_1d",
           "spline_1d_integral", "sliver_limit", "UNIFORM", "FILLED_SPAN",
           "warn_loaded_point_splines", "check_uniform_axes",
           "single_point_splines", "on_the_knots"]

logger = logging.getLogger(__name__)

#: relative tolerance on the spacing of a uniform axis
UNIFORM = 1e-9
#: a domain shorter than this (in cell sizes, after clipping to the grid)
#: takes the splines at its centre: their average to ~1e-16 (the closed
#: form's cancellation would cost more)
POINT_LIKE = 1e-8
#: a spline whose support meets a domain by less than this (in cell sizes,
#: and by less than half the domain) is folded into its two neighbours
#: towards the point: its average over the sliver ``e`` would be ``e^3 /
#: 6`` of the others', its stiffness below their round-off (singular at
#: e = 1.9e-3 in ``tests/test_bspline.py``); at 0.005 the folds of the
#: column's top made a floor of 1e-6 (docs/bspline.md)
SLIVER_SPLINE = .0025
#: extended B-splines: a knot span (the dual cell ``[x_j - h/2, x_j + h/2]``
#: of a node, halved at the grid's ends) whose points' volumes fill at
#: least this share of it makes the splines over it inner (Höllig, Reif and
#: Wipper 2001: a spline with a filled span in its support)
FILLED_SPAN = .75
#: extended B-splines: the nearest array of inner nodes an outer one is
#: extrapolated from is looked for this many nodes around it, per axis
EXTENSION_REACH = 3


def check_uniform_axes(method: str, axes) -> None:
    """Refuse a grid whose ``axes`` (the node coordinates along each) are
    not uniformly spaced, for B-spline ``method``: before a run's
    warnings (a user trial's graded grid was warned of its surface load
    and its points per cell, then refused), and as the splines are
    built."""
    for d, a in enumerate(axes):
        h = np.diff(a)
        if not np.allclose(h, h[0], rtol=UNIFORM, atol=0.):
            raise UnsupportedElementError(
                "method {!r} needs uniform spacing along each axis; axis {} "
                "has spacings from {:.6g} to {:.6g}: on a graded grid use "
                "'cpgimp' or 'ugimp' (GIMP takes one), 'mpm' or "
                "'fem'".format(method, d, h.min(), h.max()))


def warn_loaded_point_splines(method: str, extended: bool) -> None:
    """Log a warning for a run of the splines at the points (``"bspline"``,
    ``"bspline3"``) not ``extended`` that carries a surface load (the
    caller's to know).  Where the loaded face moves inside a knot span, a
    node beyond it keeps a share of the load that its splines' integral
    over the points no longer matches (the points' midpoint rule across
    the kink of the spline at the knot), and the stresses near the face
    take the difference: a column compressed by 10% by a top traction
    (2 x 2 points per cell, finite deformation) had its stress from 0.35
    to 2.08 of the traction's, 45% of its points more than 5% off, and
    with the cubic splines (3 x 3 points per cell) from -2.7 to 4.4,
    tension in a compressed body, unsaid (a user trial's; docs/bspline.md);
    in small strain 0.49 to 1.53 at 10%, 0.90 to 1.05 at 1%, 0.998 to
    1.0004 at 0.1%: warned whatever the load, which the run cannot know
    before it moves the face.  Extended, 0.95 to 1.10 (cubic 1.04 with
    3 x 3 points per cell, 0.88 to 1.07 with 2 x 2); averaged
    (``"bspline-gimp"``) uniform to 1e-4."""
    if method not in ("bspline", "bspline3") or extended:
        return
    logger.warning(
        "method %r carries a surface load without extended splines: where "
        "the loaded face moves inside a knot span, the points no longer "
        "integrate the splines of the nodes beyond it, and the stresses "
        "near the face go wrong (a column compressed 10%% by a top "
        "traction: 0.35 to 2.08 of the traction's stress, with the cubic "
        "splines -2.7 to 4.4, tension where it is compressed; in small "
        "strain 0.49 to 1.53 at 10%%, 0.90 to 1.05 at 1%%, 0.998 to 1.0004 "
        "at 0.1%%); %s holds it within 10%% (the cubic splines with 3 "
        "points per cell and axis: with 2, 12%%), %r to 1e-4 "
        "(docs/bspline.md)", method,
        setting("extended_splines", True), method + "-gimp")


def on_the_knots(mesh: Mesh, x: ndarray) -> bool:
    """Whether every point (``x``, (dim, n)) lies at a centre of its
    cell along every axis of the tensor grid ``mesh`` (the quadratic
    splines' knots: where ``seed_points(mesh, 1)`` seeds); ``False`` on
    a grid that is not one."""
    grid = tensor_grid(mesh)
    if grid is None:
        return False
    for a, xd in zip(grid[0], x):
        t = (xd - a[0]) / (a[1] - a[0]) - .5
        if not np.allclose(t, np.round(t), rtol=0., atol=1e-9):
            return False
    return True


def single_point_splines(method: str, per_axis: float, nsteps: int,
                         knots: bool) -> str:
    """A sentence on a B-spline run whose points are seeded one per cell
    and axis (``per_axis`` below 1.5), else ``""``: the stiffness has
    zero-energy modes, displacements that strain no point, which
    neither supports nor obstacles hold.  Along a line of ``m`` cells the
    points sample ``m`` strains of a field of more nodes: ``m + 3``
    averaged over cell-wide domains (``"bspline-gimp"``: the average
    sees the field at the cell's grid lines only), ``m + 2`` of the
    quadratic splines at points off the knots, ``m + 3`` of the cubic
    ones; each node beyond ``m + 1`` is a mode (the constant is held by
    the supports).  A user trial's block, 6 x 4 cells, squeezed 0.1%
    between smooth obstacles (floor and press) in one step, moved its
    points by up to 0.9e-3 without a strain: every stress and both
    obstacles' forces 0 where ``E / (1 - nu^2) eps W = 13.19``, at a
    converged residual (``"bspline-gimp"``, ``"bspline3"``; the tangent
    had 17 zero eigenvalues; ``"bspline"`` with its points 0.1 h off the
    knots alike).  The quadratic splines at the points (``"bspline"``)
    are held while the points sit at the knots, the cells' centres, each
    line's ``m + 1`` nodes sampled by ``m`` strains (the block: 0.998):
    not said for a run of ``nsteps=1`` whose points (``knots``) do.
    Extended splines fold none of the modes' nodes (every knot span is
    filled); the modes lie along the body's surfaces (the averaged
    splines' recurrence ``c_-1 + 6 c_0 + c_1 = 0`` decays by ``3 - 2
    sqrt(2)`` a node inwards), where a ghost penalty ties them, but only
    as firmly as its ``gamma``: the block's force 0.38 of the plane
    strain value at 1e-3, 0.85 at 0.01, 0.98 at 0.1.  Logged as a
    warning at the run's start and added to a failed run's error.

    >>> single_point_splines("bspline-gimp", 1., 1, True)[:52]
    "method 'bspline-gimp' with 1 point per cell and axis"
    >>> [single_point_splines(m, n, 1, True) for m, n in (
    ...     ("bspline", 1.), ("bspline-gimp", 2.), ("mpm", 1.))]
    ['', '', '']
    """
    if not method.startswith("bspline") or per_axis >= 1.5 or (
            method == "bspline" and knots and nsteps <= 1):
        return ""
    return (
        "method {!r} with 1 point per cell and axis: the stiffness has "
        "zero-energy modes, displacements that strain no point, which "
        "supports and obstacles do not hold (along a line of m cells the "
        "points sample m strains of a field of {}); a block squeezed "
        "0.1% between smooth obstacles moved its points without a "
        "strain, every stress and the obstacles' forces 0 where "
        "E/(1-nu^2) eps W = 13.2, at a converged residual; extended "
        "splines do not fold them, a ghost penalty holds them only as "
        "far as its gamma (the block: 0.38 of that force at ghost=1e-3, "
        "0.98 at 0.1); seed {} points per cell and axis".format(
            method, "m + 3 nodes" if method != "bspline" else
            "m + 2 nodes where the points are off the knots, the cells' "
            "centres, as they are once they move",
            3 if method.startswith("bspline3") else 2))


def _spline(xi: ndarray, degree: int = 2):
    """The uniform B-spline of ``degree`` (2 or 3) centred at 0 and its
    derivative at ``xi``."""
    r = np.abs(xi)
    if degree == 3:
        inner = r <= 1.
        outer = (r > 1.) & (r < 2.)
        value = np.where(inner, 2. / 3. - r * r + r ** 3 / 2,
                         np.where(outer, (2. - r) ** 3 / 6, 0.))
        slope = np.where(inner, xi * (1.5 * r - 2.),
                         np.where(outer, -(2. - r) ** 2 / 2 * np.sign(xi),
                                  0.))
        return value, slope
    inner = r <= .5
    outer = (r > .5) & (r < 1.5)
    value = np.where(inner, .75 - r * r, np.where(outer, (1.5 - r) ** 2 / 2,
                                                  0.))
    slope = np.where(inner, -2 * xi,
                     np.where(outer, -(1.5 - r) * np.sign(xi), 0.))
    return value, slope


def _spline_integral(xi: ndarray, degree: int = 2) -> ndarray:
    """The antiderivative of the uniform B-spline of ``degree`` (2 or 3),
    0 below its support and 1 above."""
    if degree == 3:
        r = np.clip(xi, -2., 2.)
        return np.where(r <= -1., (r + 2.) ** 4 / 24,
                        np.where(r <= 1., .5 + 2. * r / 3. - r ** 3 / 3.
                                 + r ** 3 * np.abs(r) / 8.,
                                 1. - (2. - r) ** 4 / 24))
    r = np.clip(xi, -1.5, 1.5)
    return np.where(r <= -.5, (r + 1.5) ** 3 / 6,
                    np.where(r <= .5, .5 + .75 * r - r ** 3 / 3,
                             1. - (1.5 - r) ** 3 / 6))


def _folds(node: ndarray, n: int):
    """The weights of the ghost splines -1 and n + 1 folded into nodes
    ``node`` (``u_-1 = 2 u_0 - u_1``, and at x_n alike)."""
    return 2. * (node == 0) - (node == 1), 2. * (node == n) - (node == n - 1)


def spline_1d_integral(t: ndarray, node: ndarray, n: int,
                       degree: int = 2) -> ndarray:
    """Antiderivatives in ``t`` of the boundary-modified functions of
    :func:`spline_1d` (the same arguments): their difference over
    ``[lo, hi]`` is the integral of the function there.

    Examples
    --------
    >>> import numpy as np
    >>> node = np.array([[0], [1], [2]])
    >>> (spline_1d_integral(np.array([1.]), node, 4)
    ...  - spline_1d_integral(np.array([0.]), node, 4)).round(6).tolist()
    [[0.520833], [0.458333], [0.020833]]

    """
    low, high = _folds(node, n)
    return (_spline_integral(t - node, degree)
            + low * _spline_integral(t + 1., degree)
            + high * _spline_integral(t - (n + 1.), degree))


def spline_1d(t: ndarray, node: ndarray, n: int, degree: int = 2):
    """Boundary-modified functions of nodes ``node`` of an axis of ``n``
    cells at ``t = (x - x_0) / h`` in ``[0, n]``: values and derivatives
    with respect to ``t``, both of the shape of ``node``; quadratic
    splines, or cubic with ``degree=3`` (the ghosts folded alike: the
    cubic spline of ghost node -1 reaches ``x_1``, none of node -2 enters
    the grid).

    Examples
    --------
    >>> import numpy as np
    >>> v, d = spline_1d(np.array([0., 0.25, 1.]), np.array([[0], [1], [2]]), 4)
    >>> v.round(6).tolist()
    [[1.0, 0.75, 0.125], [0.0, 0.25, 0.75], [0.0, 0.0, 0.125]]
    >>> v, d = spline_1d(np.array([0., 1.]), np.array([[0], [1], [2]]), 4, 3)
    >>> v.round(6).tolist()
    [[1.0, 0.166667], [0.0, 0.666667], [0.0, 0.166667]]

    """
    value, slope = _spline(t - node, degree)
    low_v, low_s = _spline(t + 1., degree)         # ghost node -1
    high_v, high_s = _spline(t - (n + 1.), degree)  # ghost node n + 1
    low, high = _folds(node, n)
    return (value + low * low_v + high * high_v,
            slope + low * low_s + high * high_s)


def sliver_limit(degree: int) -> float:
    """The sliver (in cells) below which a spline of ``degree`` is folded
    for a point (:data:`SLIVER_SPLINE` for quadratic splines; for cubic
    the sliver ``e`` whose averaged gradient ``e^3 / 6`` equals the
    quadratic's ``e^2 / 2`` at :data:`SLIVER_SPLINE`)."""
    if degree == 3:
        return (3. * SLIVER_SPLINE ** 2) ** (1. / 3.)
    return SLIVER_SPLINE


def _fold_slivers(node: ndarray, value: ndarray, slope: ndarray,
                  lo: ndarray, hi: ndarray, degree: int = 2):
    """Fold in place the first or last spline of a point's stencil (m, n)
    whose support meets its domain ``[lo, hi]`` (in cells) by less than
    :func:`sliver_limit` and half the domain, by linear extrapolation
    towards the point, ``u_k = 2 u_(k-1) - u_(k-2)``, as the grid's edges
    fold the ghosts: the partition of unity and linear completeness hold
    as before, and a spline reached only by slivers leaves the step."""
    cols = np.arange(node.shape[1])
    limit = np.minimum(sliver_limit(degree), (hi - lo) / 2)
    w = (degree + 1) / 2                      # the support's half-width
    reach = (value != 0.) | (slope != 0.)
    last = node.shape[0] - 1 - np.argmax(reach[::-1], axis=0)
    first = np.argmax(reach, axis=0)
    span = last - first
    top = (hi - (node[last, cols] - w) < limit) & (span >= 2)
    bottom = (node[first, cols] + w - lo < limit) & (span >= 2) \
        & (~top | (span >= 4))
    for end, inward, sel in ((last, -1, np.flatnonzero(top)),
                             (first, 1, np.flatnonzero(bottom))):
        k = end[sel]
        for arr in (value, slope):
            w = arr[k, sel].copy()
            arr[k + inward, sel] += 2. * w
            arr[k + 2 * inward, sel] -= w
            arr[k, sel] = 0.


class QuadraticBSpline:
    """Quadratic B-spline operators of points on one grid.

    Parameters
    ----------
    mesh
        An axis-aligned tensor-product grid (``MeshLine``, or
        ``MeshQuad``/``MeshHex`` from ``init_tensor``), uniformly spaced
        along each axis.
    elem
        ``ElementLineP1``, ``ElementQuad1`` or ``ElementHex1`` (scalar).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshLine, ElementLineP1
    >>> spline = QuadraticBSpline(MeshLine(np.linspace(0., 4., 5)),
    ...                           ElementLineP1())
    >>> op = spline(np.array([[2.25]]))
    >>> op.S.toarray().round(6).tolist()
    [[0.0, 0.03125, 0.6875, 0.28125, 0.0]]

    """

    #: the splines' degree
    degree = 2
    #: the method whose operators these are, for messages
    method = "bspline"

    def __init__(self, mesh: Mesh, elem: Element, method: str = None):
        if method is not None:         # "bspline-gimp" says its own name
            self.method = method
        grid = tensor_grid(mesh)
        if grid is None:
            raise UnsupportedElementError(
                "method {!r} needs an axis-aligned tensor-product grid "
                "(MeshLine, or MeshQuad/MeshHex from init_tensor), got a "
                "general {}".format(self.method, type(mesh).__name__))
        if not isinstance(elem, LINEAR_ELEMENTS):
            raise UnsupportedElementError(
                "method {!r} takes the grid's nodes as the splines' "
                "control points and needs a linear element (ElementLineP1, "
                "ElementQuad1, ElementHex1), got {}".format(
                    self.method, type(elem).__name__))
        # the grid's axes, cells and node numbering: GIMP's closed form
        # reads the same grid (its elements below too)
        self.grid = LinearGimp(mesh, elem)
        self.axes, self.shape = grid[0], grid[1]
        check_uniform_axes(self.method, self.axes)
        self.dim = len(self.axes)
        self.h = np.array([(a[-1] - a[0]) / (len(a) - 1) for a in self.axes])
        self.nodes, self.node_dof = self.grid.nodes, self.grid.node_dof
        self.N = self.grid.N

    def _axis(self, d: int, x: ndarray, half: ndarray = None):
        """Stencil nodes (m, n), values, derivatives along axis d (per unit
        length) and the first and last node of every point's support: the
        splines at ``x``, or averaged over ``[x - half, x + half]``."""
        n, a0, h = self.shape[d], self.axes[d][0], self.h[d]
        if half is None:
            lo = hi = np.clip((x - a0) / h, 0., n)
        else:
            lo = np.clip((x - half - a0) / h, 0., n)
            hi = np.clip((x + half - a0) / h, 0., n)
        # nodes whose supports (i - w, i + w) meet [lo, hi]
        w, p = (self.degree + 1) / 2, self.degree
        first = np.floor(lo - w).astype(np.int64) + 1
        m = min(int((np.ceil(hi + w) - first).max()), n + 1)
        node = np.clip(first, 0, n + 1 - m)[None] + np.arange(m)[:, None]
        length = hi - lo
        wide = length > POINT_LIKE
        t = (lo + hi) / 2
        value, slope = spline_1d(t, node, n, p)
        if wide.any():
            span = np.where(wide, length, 1.)
            lo_v, _ = spline_1d(lo, node, n, p)
            hi_v, _ = spline_1d(hi, node, n, p)
            mean = (spline_1d_integral(hi, node, n, p)
                    - spline_1d_integral(lo, node, n, p)) / span
            value = np.where(wide, mean, value)
            slope = np.where(wide, (hi_v - lo_v) / span, slope)
            if m >= 3:
                _fold_slivers(node, value, slope, lo, hi, p)
        slope = slope / h
        reach = (value != 0.) | (slope != 0.)
        first = node[np.argmax(reach, axis=0), np.arange(len(x))]
        last = node[m - 1 - np.argmax(reach[::-1], axis=0), np.arange(len(x))]
        return node, value, slope, reach, first, last

    def __call__(self, x: ndarray, domain: ndarray = None) -> SparseOperator:
        """The operator of points x (dim, n): the splines at the points,
        or with ``domain`` (half-lengths, (dim, n)) averaged over their
        boxes.  Its ``elements`` are the cells spanned by the points'
        supports (the cells whose corners all carry a point's weight)."""
        n = x.shape[1]
        node = np.zeros((1, n), dtype=np.int64)
        S = np.ones((1, n))
        G = [np.ones((1, n)) for _ in range(self.dim)]
        keep = np.ones((1, n), dtype=bool)
        spans = []
        for d in range(self.dim):
            nd, value, slope, reach, first, last = self._axis(
                d, x[d], None if domain is None else domain[d])
            node = (node[:, None] * self.nodes[d] + nd[None]).reshape(-1, n)
            keep = (keep[:, None] & reach[None]).reshape(-1, n)
            S = (S[:, None] * value[None]).reshape(-1, n)
            for e in range(self.dim):
                factor = slope if e == d else value
                G[e] = (G[e][:, None] * factor[None]).reshape(-1, n)
            spans.append((first, np.maximum(last - 1, first)))
        indptr = np.concatenate(([0], np.cumsum(keep.sum(axis=0))))
        cols = self.node_dof[node.T[keep.T]]

        def matrix(values):
            return csr_matrix((values.T[keep.T], cols, indptr),
                              shape=(n, self.N))

        return SparseOperator(matrix(S), [matrix(g) for g in G],
                              self.grid._elements(spans))

    def extension(self, x: ndarray, volume: ndarray, touched: ndarray,
                  held: ndarray = None):
        """The extension of the splines (Höllig, Reif and Wipper 2001): the
        matrix ``E`` (N, N) with which ``S E`` is the operator of the
        extended B-splines, or ``None`` where every spline is inner.

        A node is inner when a knot span in its support (the 3^dim dual
        cells around it; of cubic splines, whose knots are the nodes, the
        4^dim cells of its support) is filled by points' volumes to at
        least :data:`FILLED_SPAN`.  Every other node that points carry
        weight on (``touched``, (N,) bool) is no degree of freedom but the
        bilinear (trilinear) extrapolation of the nearest 2^dim array of
        inner nodes, averaged over the arrays equally near (so a symmetric
        body folds symmetrically): partition of unity and linear
        completeness hold, and every spline that remains carries material
        over a filled span, so no node is held by a sliver (the ghost
        penalty's task) and none leaves the step when the material moves
        off its support.  A node at a grid's end along an axis is
        extrapolated from arrays on its end line where there are any (a
        roller's or a clamp's neighbours hold it as it was held); a
        ``held`` one only from those, else it stays a degree of freedom (a
        clamp whose end line has no inner node left as a beam bends).  Each
        point's volume fills the knot span its centre lies in (``np.rint``;
        cubic: the cell holding it; a point on a span's edge, the middle
        one of 3 a cell, falls on one side, and a symmetric body can fold
        asymmetrically; spreading the volume over the spans its box
        overlaps, tried, made Prandtl's footing's largest change between
        steps 4.8% and 4.4% for 3.0%).  An outer node with no inner array
        within :data:`EXTENSION_REACH` nodes stays a degree of freedom.

        Parameters
        ----------
        x
            The points' positions (dim, n).
        volume
            Their volumes (n,).
        touched
            Which scalar DOFs the points' splines carry weight on (N,).
        held
            Which scalar DOFs' nodes a support holds (N,), or ``None``.

        Examples
        --------
        Points filling [0, 2] of a line of 4 cells: node 3, half a cell
        beyond, is extrapolated from nodes 1 and 2 (``u_3 = 2 u_2 - u_1``).

        >>> import numpy as np
        >>> from skfem import MeshLine, ElementLineP1
        >>> spline = QuadraticBSpline(MeshLine(np.linspace(0., 4., 5)),
        ...                           ElementLineP1())
        >>> x = np.array([[.25, .75, 1.25, 1.75]])
        >>> touched = np.array([True, True, True, True, False])
        >>> spline.extension(x, np.full(4, .5), touched).toarray()[3]
        array([ 0., -1.,  2.,  0.,  0.])
        """
        dim, shape = self.dim, np.array(self.grid.nodes)
        cells = self.degree == 3   # the knot spans: cells, or dual cells
        span = np.array([np.clip((np.floor if cells else np.rint)(
            (x[d] - self.axes[d][0]) / self.h[d]), 0, shape[d] - 1 - cells)
            for d in range(dim)], dtype=np.int64)
        flat = np.ravel_multi_index(tuple(span), tuple(shape))
        fill = np.bincount(flat, volume, int(np.prod(shape))).reshape(shape)
        for d in range(dim):
            width = np.full(shape[d], self.h[d])
            if not cells:
                width[[0, -1]] /= 2
            fill /= width.reshape([-1 if e == d else 1 for e in range(dim)])
        # the spans of node i's support: i - 1 .. i + 1, cubic i - 2 .. i + 1
        inner = maximum_filter(fill >= FILLED_SPAN, size=self.degree + 1,
                               mode="constant")
        lattice = np.indices(tuple(shape)).reshape(dim, -1)
        outer = np.flatnonzero(touched[self.node_dof] & ~inner.ravel())
        if outer.size == 0:
            return None
        at = lattice[:, outer]
        corners = np.indices((2,) * dim).reshape(dim, -1)
        # the arrays of 2^dim inner nodes, by their first node
        whole = np.ones(tuple(shape - 1), dtype=bool)
        for c in corners.T:
            whole &= inner[tuple(slice(c[d], c[d] + shape[d] - 1)
                                 for d in range(dim))]
        end = (at == 0) | (at == shape[:, None] - 1)       # (dim, m)
        # each candidate array (its first node at an offset from the
        # outer node's), where it is whole, where it lies on the end lines
        # of a node at a grid end (preferred: a held node folds into held
        # ones), and its centre's distance
        candidates = []
        lined = np.zeros(outer.size, dtype=bool)   # an array on its lines
        for offset in (np.indices((2 * EXTENSION_REACH,) * dim).reshape(
                dim, -1) - EXTENSION_REACH).T:
            first = at + offset[:, None]
            ok = ((first >= 0) & (first < shape[:, None] - 1)).all(axis=0)
            ok[ok] = whole[tuple(first[:, ok])]
            on_lines = ok & (~end | ((offset[:, None] >= -1)
                                     & (offset[:, None] <= 0))).all(axis=0)
            lined |= on_lines
            if ok.any():
                candidates.append((first, ok, on_lines, (
                    (first + .5 - at) ** 2).sum(axis=0)))
        strict = end.any(axis=0) & (False if held is None
                                    else held[self.node_dof[outer]])
        candidates = [(first, np.where(lined | strict, on_lines, ok),
                       distance)
                      for first, ok, on_lines, distance in candidates]
        nearest = np.full(outer.size, np.inf)
        for first, ok, distance in candidates:
            nearest[ok] = np.minimum(nearest[ok], distance[ok])
        rows, cols, vals = [], [], []
        count = np.zeros(outer.size)
        for first, ok, distance in candidates:
            take = np.flatnonzero(ok & (distance <= nearest + 1e-12))
            count[take] += 1
            t = (at[:, take] - first[:, take]).astype(float)
            for c in corners.T:
                rows.append(take)
                cols.append(np.ravel_multi_index(
                    tuple(first[:, take] + c[:, None]), tuple(shape)))
                vals.append(np.prod(np.where(c[:, None] == 1, t, 1 - t),
                                    axis=0))
        if not rows:
            return None
        rows, cols, vals = (np.concatenate(a) for a in (rows, cols, vals))
        keep = np.ones(int(np.prod(shape)), dtype=bool)
        keep[outer[count > 0]] = False
        identity = np.flatnonzero(keep)
        dof = self.node_dof
        return coo_matrix((np.concatenate((np.ones(identity.size),
                                           vals / count[rows])),
                           (dof[np.concatenate((identity, outer[rows]))],
                            dof[np.concatenate((identity, cols))])),
                          shape=(self.N, self.N)).tocsr()


class CubicBSpline(QuadraticBSpline):
    """Cubic B-spline operators of points on one grid
    (``method="bspline3"``, ``"bspline3-gimp"``): the uniform cubic
    B-spline centred on each node, knots at the nodes, ``xi = (x - x_i) /
    h``::

        N(xi) = 2/3 - xi^2 + |xi|^3 / 2      for |xi| <= 1,
        N(xi) = (2 - |xi|)^3 / 6             for 1 <= |xi| <= 2,

    C2, 4^dim nodes a point (5^dim averaged over domains up to a cell
    long).  The ghost nodes ``x_-1``, ``x_n+1`` are folded as the
    quadratic splines' (``u_-1 = 2 u_0 - u_1``; the spline of ``x_-2``
    ends at ``x_0``): on ``[x_0, x_1]`` ``N_0' = 1 - t + t^3 / 6``, ``N_1'
    = 2/3 - s^2 + s^3 / 3`` with ``s = 1 - t``, non-negative, the edge
    interpolated (``N_0'(x_0) = 1``), the partition of unity and linear
    completeness kept; quadratics are reproduced beyond the first cell
    from each end.  The same grids as :class:`QuadraticBSpline`.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshLine, ElementLineP1
    >>> spline = CubicBSpline(MeshLine(np.linspace(0., 4., 5)),
    ...                       ElementLineP1())
    >>> op = spline(np.array([[2.]]))
    >>> (op.S.toarray() * 6).round(12).tolist()
    [[0.0, 1.0, 4.0, 1.0, 0.0]]

    """

    degree = 3
    method = "bspline3"
