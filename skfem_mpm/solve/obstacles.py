"""Obstacles: rigid geometric bodies the material cannot enter.

An :class:`Obstacle` is a box (axis-aligned, 1D to 3D) or a polygon (2D)
that moves by a prescribed displacement, ramped with the load factor (or
following ``Dynamics.load(t)``).  Unlike a support, it need not lie on grid
lines, and unlike a :class:`~skfem_mpm.RigidBody` of points it acts at the
material's surface, not at the grid nodes of the cells it occupies: the
contact term (:mod:`skfem_mpm.solve.contact`) measures the gap from the
obstacle's surface to the corners of each point's domain.

This module holds the geometry: the signed distance of positions to an
obstacle's surface and the outward normal of its closest boundary point,
vectorised over positions, and the checks of a set of obstacles.
"""
import copy
import itertools
from typing import Optional, Sequence

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError, check_real

__all__ = ["Obstacle", "FRICTION_KINDS"]

#: the frictions other than a Coulomb coefficient: no slip while in
#: contact, free to separate (``"rough"``); bonded, a support off the grid
#: lines (``"tied"``)
FRICTION_KINDS = ("rough", "tied")


class Obstacle:
    """A rigid obstacle: a box or a polygon, moved by a prescribed
    displacement.

    Parameters
    ----------
    box
        ``[[x0, x1], [y0, y1]]`` (one pair per dimension of the grid,
        ``x0 < x1``): an axis-aligned box.
    polygon
        ``[[x, y], ...]`` (2D): a simple polygon (at least 3 vertices, in
        either orientation, not closed by repeating the first vertex).
    displacement
        Displacement (dim,) at full load, reached in proportion to the load
        factor (in dynamics to ``Dynamics.load(t)``); default none.
    friction
        ``0.0`` (smooth, the default), a Coulomb coefficient ``mu > 0``,
        ``"rough"`` (no slip while in contact, free to separate; a part
        of the surface that touches it within a load or time step sticks
        from where the step's straight path met it) or
        ``"tied"`` (bonded to the material touching it at the start,
        within the tolerance: a support that need not lie on grid
        lines; material inside it beyond the tolerance is refused, as
        by the others).
    name
        The obstacle's name in records and output (default
        ``"obstacle<i>"`` by its position in the list).
    penalty
        The contact stiffness per unit area, in units of the material's
        largest indentation modulus ``E / (1 - nu^2)`` (of a material
        without ``E`` and ``nu``: ``4 mu (lam + mu) / (lam + 2 mu)`` of
        its elastic constants) over the cell size
        (default 10): the force that starts each augmented-Lagrangian
        solve; it changes how many augmentations a step takes and the
        answer within what the tolerance allows (a penetration up to the
        tolerance: a force error of the body's stiffness times it).  A
        smooth obstacle's grows 10 times for the rest of the run (twice
        at the most, warned) where a step's augmented-Lagrangian updates
        settle slowly: corners sharing grid nodes at different heights,
        GIMP's on a curved face or any by a face's edge
        (docs/contact.md); the run's counters keep the growths
        (``contact<k>_penalty_growths``), and a resumed run goes on at
        the grown penalty.
    tolerance
        The penetration (and for ``"tied"`` the mismatch) allowed at a
        converged step, as a fraction of the cell size (default 1e-3).
        Material within it of the obstacle at the start is in contact
        from the start (its gap is closed).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm import Obstacle
    >>> floor = Obstacle(box=[[-1., 2.], [-1., 0.]], name="floor")
    >>> floor.dim, floor.friction
    (2, 0.0)
    >>> ob = Obstacle(polygon=[[0, 0], [1, 0], [0, 1]], friction=.3)
    >>> ob.signed_distance(np.array([[.25, 1.], [.25, 1.]]))[0].round(3)
    array([-0.25 ,  0.707])
    """

    def __init__(self, box=None, polygon=None, displacement=None,
                 friction=0., name: Optional[str] = None,
                 penalty: float = 10., tolerance: float = 1e-3):
        if (box is None) == (polygon is None):
            raise InvalidInputError("an Obstacle needs exactly one of box = "
                                    "[[x0, x1], ...] and polygon = [[x, y], "
                                    "...]")
        if box is not None:
            self.box = np.array(box, dtype=np.float64)
            if self.box.ndim != 2 or self.box.shape[1] != 2 or \
                    not 1 <= self.box.shape[0] <= 3:
                raise InvalidInputError(
                    "Obstacle box must be [[x0, x1], ...] with one pair per "
                    "dimension (1 to 3), got shape {}".format(self.box.shape))
            if not np.isfinite(self.box).all() or \
                    (self.box[:, 0] >= self.box[:, 1]).any():
                raise InvalidInputError(
                    "Obstacle box must have finite bounds x0 < x1 in every "
                    "dimension, got {}".format(self.box.tolist()))
            self.dim, self.vertices = self.box.shape[0], None
        else:
            self.box, self.vertices = None, checked_polygon(
                polygon, alternative=BOX_3D)
            self.dim = 2
        self.displacement = np.zeros(self.dim) if displacement is None \
            else np.array(displacement, dtype=np.float64)
        if self.displacement.shape != (self.dim,) or \
                not np.isfinite(self.displacement).all():
            # the shape's dimension first: a 2D box on a 3D grid with a
            # 3D displacement blamed the displacement (a user trial)
            shape = "box is {}D ({} interval{})".format(
                self.dim, self.dim, "s" if self.dim > 1 else "") \
                if self.box is not None else "polygon is 2D"
            more = self.displacement.size > self.dim and self.dim < 3
            raise InvalidInputError(
                "Obstacle {}, so its displacement must be {} finite "
                "numbers, got {!r}{}".format(
                    shape, self.dim, displacement,
                    " (polygons are 2D only; {})".format(BOX_3D)
                    if more and self.box is None else
                    " ({})".format(BOX_3D) if more else ""))
        if isinstance(friction, str):
            if friction not in FRICTION_KINDS:
                raise InvalidInputError(
                    "Obstacle friction must be a coefficient >= 0, 'rough' "
                    "or 'tied', got {!r}".format(friction))
            self.friction = friction
        else:
            self.friction = check_real("Obstacle friction", friction)
            if not 0 <= self.friction < np.inf:
                raise InvalidInputError("Obstacle friction must be a finite "
                                        "number >= 0, got {}".format(
                                            self.friction))
        if name is not None and (not isinstance(name, str) or not name):
            raise InvalidInputError("Obstacle name must be a non-empty "
                                    "string, got {!r}".format(name))
        self.name = name
        self._faces = None
        self.penalty = check_real("Obstacle penalty", penalty)
        self.tolerance = check_real("Obstacle tolerance", tolerance)
        if not (self.penalty > 0 and 0 < self.tolerance < .5):
            raise InvalidInputError(
                "Obstacle penalty must be > 0 and tolerance in (0, 0.5) "
                "cells, got {} and {}".format(penalty, tolerance))

    def __repr__(self):
        shape = "box={}".format(self.box.tolist()) if self.box is not None \
            else "polygon={}".format(self.vertices.T.tolist())
        return "Obstacle({}, name={!r}, friction={!r})".format(
            shape, self.name, self.friction)

    def named(self, name: str) -> "Obstacle":
        """A copy of this obstacle called ``name``."""
        new = copy.copy(self)
        new.name = name
        return new

    def bounds(self, shift: ndarray) -> ndarray:
        """The bounding box (dim, 2) shifted by ``shift``."""
        if self.box is not None:
            return self.box + shift[:, None]
        return np.stack([self.vertices.min(axis=1),
                         self.vertices.max(axis=1)], axis=1) + shift[:, None]

    def corners(self, shift: ndarray) -> ndarray:
        """The corners (dim, k) of the obstacle shifted by ``shift``: a
        box's 2^dim, a polygon's vertices.

        >>> import numpy as np
        >>> from skfem_mpm import Obstacle
        >>> Obstacle(box=[[0., 1.], [2., 3.]]).corners(np.zeros(2)).T.tolist()
        [[0.0, 2.0], [0.0, 3.0], [1.0, 2.0], [1.0, 3.0]]
        """
        if self.box is None:
            return self.vertices + shift[:, None]
        pick = np.array(list(itertools.product((0, 1), repeat=self.dim))).T
        return np.take_along_axis(self.box, pick, axis=1) + shift[:, None]

    @property
    def convex(self) -> bool:
        """Whether the obstacle is convex (a box; a polygon turning one
        way at every vertex): material on one face cannot meet another.

        >>> from skfem_mpm import Obstacle
        >>> Obstacle(polygon=[[0, 0], [2, 0], [2, 1], [1, .2],
        ...                   [0, 1]]).convex
        False
        """
        if self.box is not None:
            return True
        edge = np.diff(self.vertices, axis=1, append=self.vertices[:, :1])
        turn = _cross(edge, np.roll(edge, -1, axis=1))
        return bool((turn >= 0).all() or (turn <= 0).all())

    def outline(self, shift: Optional[ndarray] = None) -> ndarray:
        """The outline (k, 2) of a 2D obstacle shifted by ``shift``, for
        pictures."""
        shift = np.zeros(self.dim) if shift is None else shift
        if self.dim != 2:
            raise InvalidInputError("only a 2D obstacle has an outline")
        if self.box is not None:
            (x0, x1), (y0, y1) = self.box + shift[:, None]
            return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        return (self.vertices + shift[:, None]).T

    def faces(self):
        """The faces as ``(a, n, lo, hi, axes)``: a point on each face's
        plane (dim, k), its outward unit normal (dim, k) and its extent
        in the plane's coordinates: for a box face ``lo``, ``hi`` (dim, k)
        bounds of the other axes (``-inf``, ``inf`` on its own); for a
        polygon edge the edge vector as ``hi`` (``lo`` None)."""
        if self._faces is not None:
            return self._faces
        if self.box is not None:
            dim = self.dim
            k = np.arange(2 * dim)
            axis, low = k % dim, k < dim
            n = np.zeros((dim, 2 * dim))
            n[axis, k] = np.where(low, -1., 1.)
            a = np.zeros((dim, 2 * dim))
            a[axis, k] = np.where(low, self.box[axis, 0], self.box[axis, 1])
            lo = np.repeat(self.box[:, :1], 2 * dim, axis=1)
            hi = np.repeat(self.box[:, 1:], 2 * dim, axis=1)
            lo[axis, k], hi[axis, k] = -np.inf, np.inf
            self._faces = (a, n, lo, hi)
        else:
            a = self.vertices
            e = np.roll(a, -1, axis=1) - a
            n = np.array([e[1], -e[0]]) / np.hypot(*e)
            self._faces = (a, n, None, e)
        return self._faces

    def nearest_face(self, x: ndarray, shift: ndarray,
                     inward=None, alike: float = 0.) -> ndarray:
        """The face (m,) of the obstacle shifted by ``shift`` nearest to
        each position ``x`` (dim, m): the face a point outside will touch
        first, or the face of least depth of a point inside.  Given
        ``inward``, a function of the indices of the positions with more
        than one face within ``alike`` of the nearest giving the
        direction into the material at each and the direction to each
        position's own point (two arrays dim x k), of those faces the
        one the material lies beyond (its outward normal nearest that
        direction; of those alike in it, the nearest; then the one
        facing the position's own point, :func:`_nearest`): a corner on a
        body's flat bottom right over a step's edge is as near the step's
        side as its top, and the side, taken by the order of the faces,
        pushed a block landing on a smooth step sideways (a user trial:
        0.39 m/s after a drop of 0.3, off the step)."""
        x = x - shift[:, None]
        a, n, lo, hi = self.faces()
        if lo is not None:
            normal = ((x[:, None, :] - a[:, :, None])
                      * n[:, :, None]).sum(axis=0)               # (k, m)
            off = np.maximum(lo[:, :, None] - x[:, None, :], 0.) \
                + np.maximum(x[:, None, :] - hi[:, :, None], 0.)
            d2 = normal ** 2 + (np.nan_to_num(off, posinf=0.) ** 2).sum(0)
            return _nearest(d2, n, inward, alike, np.arange(x.shape[1]))

        def nearest(y):         # the positions' indices in the last row
            rel = y[:-1, None, :] - a[:, :, None]
            t = np.clip((rel * hi[:, :, None]).sum(axis=0)
                        / (hi * hi).sum(axis=0)[:, None], 0., 1.)
            return (_nearest(((rel - t * hi[:, :, None]) ** 2).sum(axis=0),
                             n, inward, alike, y[-1].astype(np.int64)),)
        return by_blocks(nearest, np.vstack([x, np.arange(x.shape[1])]),
                          a.shape[1])[0]

    def face_gap(self, x: ndarray, face: ndarray, shift: ndarray,
                 slack: float = 0.):
        """The gap (m,) of each position ``x`` (dim, m) from the plane of
        its ``face`` (m,) of the obstacle shifted by ``shift`` (negative:
        through it), the face's outward normal (dim, m), and whether the
        position lies over the face (its projection within the face's
        extent, widened by ``slack`` and at least by the round-off of the
        obstacle's size): contact with a face ends at its edges."""
        x = x - shift[:, None]
        a, n, lo, hi = self.faces()
        af, nf = a[:, face], n[:, face]
        gap = ((x - af) * nf).sum(axis=0)
        slack = max(slack, 1e-9 * np.ptp(self.bounds(0 * shift),
                                          axis=1).max())
        if lo is not None:
            over = ((x >= lo[:, face] - slack)
                    & (x <= hi[:, face] + slack)).all(axis=0)
        else:
            e = hi[:, face]
            length = np.sqrt((e * e).sum(axis=0))
            t = ((x - af) * e).sum(axis=0) / length
            over = (t >= -slack) & (t <= length + slack)
        return gap, nf, over

    def passed_through(self, x: ndarray, d: ndarray, shift: ndarray,
                       depth: float) -> ndarray:
        """Whether each path ``x + t d``, ``t`` from 0 to 1 (positions
        ``x`` and motions ``d`` relative to the obstacle shifted by
        ``shift``, (dim, m)), goes deeper into the obstacle than ``depth``
        between its ends while neither end does, in through one face and
        out through one facing the other way: material carried through it
        within one step (a path around a corner of the obstacle, from one
        face to the next, cuts the corner and is not).  A box exactly (its
        slabs shrunk by ``depth``: in and out along one axis); a polygon
        exactly too (the first and the last edge the path crosses facing
        opposite ways, the path's middle between them deeper than
        ``depth``).

        Examples
        --------
        Through a plate, short of it, beside it, and around its corner
        (from under its bottom face to beside its right one):

        >>> import numpy as np
        >>> from skfem_mpm import Obstacle
        >>> plate = Obstacle(box=[[-1., 1.], [0., .05]])
        >>> x = np.array([[0., 0., 2., .95], [.3, .3, .3, -.01]])
        >>> d = np.array([[0., 0., 0., .1], [-.6, -.2, -.6, .04]])
        >>> plate.passed_through(x, d, np.zeros(2), 1e-3).tolist()
        [True, False, False, False]
        >>> Obstacle(polygon=plate.outline()).passed_through(
        ...     x, d, np.zeros(2), 1e-3).tolist()
        [True, False, False, False]
        """
        x = x - shift[:, None]
        bounds = self.bounds(np.zeros(self.dim))
        lo, hi = np.minimum(x, x + d), np.maximum(x, x + d)
        near = np.flatnonzero(((lo < bounds[:, 1:] - depth)
                               & (hi > bounds[:, :1] + depth)).all(axis=0))
        passed = np.zeros(x.shape[1], dtype=bool)
        if near.size == 0:
            return passed
        x, d = x[:, near], d[:, near]
        if self.box is not None:
            low, high = self.box[:, :1] + depth, self.box[:, 1:] - depth
            if (low >= high).any():
                return passed
            with np.errstate(divide="ignore", invalid="ignore"):
                t1, t2 = (low - x) / d, (high - x) / d
            still = d == 0.
            inside = (x > low) & (x < high)
            enter = np.where(still, np.where(inside, -np.inf, np.inf),
                             np.minimum(t1, t2))
            leave = np.where(still, np.where(inside, np.inf, -np.inf),
                             np.maximum(t1, t2))
            first, last = enter.max(axis=0), leave.min(axis=0)
            passed[near] = (first < last) & (first > 0.) & (last < 1.) & (
                enter.argmax(axis=0) == leave.argmin(axis=0))
            return passed
        first, last = by_blocks(lambda y: _edges_crossed(
            self.vertices, y[:2], y[2:]), np.vstack((x, d)),
            self.vertices.shape[1])
        a, n, _, _ = self.faces()
        crossed = np.flatnonzero(np.isfinite(first[0]))
        opposed = (n[:, first[1, crossed].astype(int)]
                   * n[:, last[1, crossed].astype(int)]).sum(axis=0) < -.5
        crossed = crossed[opposed]
        middle = x[:, crossed] + .5 * (first[0, crossed]
                                       + last[0, crossed]) * d[:, crossed]
        deep = self.signed_distance(middle)[0] < -depth
        ends = [self.signed_distance(x[:, crossed] + t * d[:, crossed])[0]
                < -depth for t in (0, 1)]
        passed[near[crossed[deep & ~ends[0] & ~ends[1]]]] = True
        return passed

    def signed_distance(self, x: ndarray, shift: Optional[ndarray] = None):
        """Signed distance ``phi`` (m,) of the positions ``x`` (dim, m) to
        the surface of the obstacle shifted by ``shift`` (negative inside:
        the penetration is ``-phi``) and the outward unit normal (dim, m)
        at the closest boundary point (for a position inside, the normal
        of the face it is closest to)."""
        x = x if shift is None else x - shift[:, None]
        if self.box is not None:
            return _box_distance(self.box, x)
        return by_blocks(lambda y: polygon_distance(self.vertices, y), x,
                          self.vertices.shape[1])


#: positions x faces per block of a polygon's distance computations
BLOCK = 1 << 21


def by_blocks(compute, x: ndarray, faces: int) -> tuple:
    """``compute(x)`` (a tuple of arrays over the positions' last axis) by
    blocks of positions, so that no block holds more than :data:`BLOCK`
    position-face pairs (a polygon of 256 vertices and 2e5 corners took
    3.3 GB at once)."""
    size = max(1, BLOCK // faces)
    if x.shape[1] <= size:
        return compute(x)
    parts = [compute(x[:, k:k + size]) for k in range(0, x.shape[1], size)]
    return tuple(np.concatenate(p, axis=-1) for p in zip(*parts))


#: what a 3D obstacle is (a polygon's or a 2D box's error says it)
BOX_3D = "a 3D obstacle is a box=[[x0, x1], [y0, y1], [z0, z1]]"


def checked_polygon(polygon, what: str = "Obstacle polygon",
                    alternative: str = "") -> ndarray:
    """The vertices (2, m) of a simple polygon, counter-clockwise; its
    problems named as ``what`` (a body's region uses it too); vertices of
    3 coordinates are told that polygons are 2D only, and
    ``alternative``, what to take in 3D."""
    try:
        v = np.array(polygon, dtype=np.float64)
    except (TypeError, ValueError):     # ragged, or not numbers
        v = np.zeros((0, 2))
    if v.ndim == 2 and v.shape[1] == 3:
        raise InvalidInputError(
            "{} vertices have 3 coordinates, but polygons are 2D only "
            "[[x, y], ...]{}; got {!r}".format(
                what, "; " + alternative if alternative else "", polygon))
    if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3 or \
            not np.isfinite(v).all():
        raise InvalidInputError("{} must be at least 3 finite [x, y] "
                                "vertices, got {!r}".format(what, polygon))
    v = v.T
    edges = np.roll(v, -1, axis=1) - v
    lengths = np.hypot(*edges)
    area = .5 * np.sum(v[0] * np.roll(v[1], -1) - np.roll(v[0], -1) * v[1])
    scale = np.ptp(v, axis=1).max()
    if (lengths <= 1e-12 * scale).any():
        raise InvalidInputError("{} has repeated vertices: {}".format(
            what, v.T.tolist()))
    a, b = v, np.roll(v, -1, axis=1)
    m = v.shape[1]
    i, j = np.triu_indices(m, 2)
    keep = (j - i) % m != m - 1          # neighbours share a vertex
    if _segments_cross(a[:, i[keep]], b[:, i[keep]], a[:, j[keep]],
                       b[:, j[keep]]).any():
        raise InvalidInputError("{} crosses itself: {}".format(
            what, v.T.tolist()))
    if abs(area) <= 1e-12 * scale ** 2:    # its vertices on one line
        raise InvalidInputError("{} has no area: {}".format(
            what, v.T.tolist()))
    return v if area > 0 else v[:, ::-1].copy()


def _cross(u: ndarray, w: ndarray) -> ndarray:
    return u[0] * w[1] - u[1] * w[0]


def _segments_cross(a, b, c, d) -> ndarray:
    """Whether segments ab and cd (columns) properly intersect."""
    d1, d2 = _cross(b - a, c - a), _cross(b - a, d - a)
    d3, d4 = _cross(d - c, a - c), _cross(d - c, b - c)
    return (d1 * d2 < 0) & (d3 * d4 < 0)


def _edges_crossed(v: ndarray, x: ndarray, d: ndarray):
    """For each path ``x + t d`` (t in [0, 1], columns) the first and the
    last crossing of the polygon's edges ``v`` (2, k): ``(t, edge)`` rows
    (2, m) each, ``inf`` / ``-inf`` where it crosses none."""
    a = v[:, :, None]                                   # (2, k, 1)
    e = np.roll(v, -1, axis=1)[:, :, None] - a
    r = d[:, None, :]                                   # (2, 1, m)
    rel = a - x[:, None, :]                             # (2, k, m)
    denominator = _cross(r, e)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = _cross(rel, e) / denominator
        u = _cross(rel, r) / denominator
    hit = (denominator != 0) & (t > 0) & (t < 1) & (u >= 0) & (u <= 1)
    t_in = np.where(hit, t, np.inf)
    t_out = np.where(hit, t, -np.inf)
    cols = np.arange(x.shape[1])
    into, out = np.argmin(t_in, axis=0), np.argmax(t_out, axis=0)
    return (np.array([t_in[into, cols], into]),
            np.array([t_out[out, cols], out]))


#: the cosine by which faces of an obstacle alike in distance from a
#: corner are alike in facing the material too (:func:`_nearest`): the
#: soil's surface under a wedge's apex, tilted a thousandth by the soil's
#: deformation, gave both corners there the face it tilted towards, and
#: a symmetric wedge a sideways force 1.7 times its vertical one
ACROSS_ALIKE = .05


def _nearest(d2: ndarray, n: ndarray, inward, alike: float,
             at: ndarray) -> ndarray:
    """Of the faces (k, m: squared distances ``d2``, outward normals ``n``,
    dim x k) the nearest to each position (``at``: their indices), or,
    given ``inward`` (:meth:`Obstacle.nearest_face`), where several lie
    within ``alike`` of the nearest, the one whose normal is nearest the
    direction into the material (within :data:`ACROSS_ALIKE`), then the
    nearest, then the one whose normal is nearest the direction to the
    position's own point (a corner of two domains right under a wedge's
    apex: each domain's corner takes the face on its side, where the
    order of the faces gave both the left one, and a symmetric wedge
    pushed into soil took a sideways force 1.7 times its vertical
    one)."""
    face = np.argmin(d2, axis=0)
    if inward is None:
        return face
    d = np.sqrt(d2)
    best = d.min(axis=0)
    near = d <= best + alike
    tied = np.flatnonzero(near.sum(axis=0) > 1)
    if tied.size:
        across, own = (w / np.maximum(np.sqrt((w ** 2).sum(axis=0)), 1e-300)
                       for w in inward(at[tied]))
        keys = [np.einsum("ak,am->km", n, across),
                -(d[:, tied] - best[tied]) / max(alike, 1e-300),
                np.einsum("ak,am->km", n, own)]
        keep = near[:, tied]
        # alike in the direction by :data:`ACROSS_ALIKE` in cosine, in the
        # distance by a tenth of ``alike`` (a corner pressed at a wedge's
        # apex, the soil's deformation moving it a millionth sideways)
        for key, within in zip(keys[:-1], (ACROSS_ALIKE, .1)):
            key = np.where(keep, key, -np.inf)
            keep &= key >= key.max(axis=0) - within
        face[tied] = np.argmax(np.where(keep, keys[-1], -np.inf), axis=0)
    return face


def _box_distance(box: ndarray, x: ndarray):
    # per axis the signed distance from the box's slab (> 0 outside it)
    d = np.maximum(box[:, :1] - x, x - box[:, 1:])
    out = np.maximum(d, 0.)
    dist = np.sqrt(np.einsum("am,am->m", out, out))
    outside = dist > 0
    phi = np.where(outside, dist, d.max(axis=0))
    # the outward normal: towards the position from its closest boundary
    # point outside; inside, that of the nearest face (of equally near
    # faces the lowest axis's, its high face where the position is nearer)
    side = np.where(x - box[:, :1] > box[:, 1:] - x, 1., -1.)
    with np.errstate(divide="ignore", invalid="ignore"):
        normal = np.where(outside, side * out / dist, 0.)
    inside = np.flatnonzero(~outside)
    axis = np.argmax(d[:, inside], axis=0)
    normal[axis, inside] = side[axis, inside]
    return phi, normal


def polygon_distance(v: ndarray, x: ndarray):
    """The signed distance of the positions ``x`` (2, m) from the simple
    polygon of counter-clockwise vertices ``v`` (2, k), negative inside,
    and the unit normals (2, m) pointing out of it."""
    a = v[:, :, None]                                   # (2, k, 1)
    e = np.roll(v, -1, axis=1)[:, :, None] - a
    rel = x[:, None, :] - a                             # (2, k, m)
    t = np.clip((rel * e).sum(axis=0) / (e * e).sum(axis=0), 0., 1.)
    gap = rel - t * e                                   # x - closest
    d2 = (gap ** 2).sum(axis=0)
    edge = np.argmin(d2, axis=0)
    cols = np.arange(x.shape[1])
    dist = np.sqrt(d2[edge, cols])
    # inside by crossing number along +x, each edge's end height the next
    # edge's start itself (``a + e`` differs from it by round-off, and a
    # point between the two at a vertex's height crossed twice or never:
    # a wedge's apex 3.5e-18 above the soil made every corner beside it
    # on the surface, metres away, "0.5 inside")
    y0, y1 = a[1], np.roll(v, -1, axis=1)[1][:, None]
    straddles = (y0 > x[1]) != (y1 > x[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = a[0] + (x[1] - y0) * e[0] / e[1]
    inside = (straddles & (x[0] < xc)).sum(axis=0) % 2 == 1
    ek = e[:, edge, 0]
    face = np.array([ek[1], -ek[0]]) / np.hypot(*ek)    # outward (ccw)
    direction = gap[:, edge, cols]
    tiny = dist <= 1e-12 * (np.ptp(v, axis=1).max())
    with np.errstate(divide="ignore", invalid="ignore"):
        normal = np.where(tiny, face, direction / dist)
    normal = np.where(inside & ~tiny, -normal, normal)
    return np.where(inside, -dist, dist), normal


def check_obstacles(obstacles: Sequence, dim: int, mesh_bounds: ndarray):
    """The obstacles of a run, checked and named: each a
    :class:`Obstacle` of the grid's dimension whose swept box reaches the
    grid, names distinct, no two overlapping at the start."""
    if obstacles is None:
        return ()
    if isinstance(obstacles, Obstacle):
        obstacles = [obstacles]
    obstacles = list(obstacles)
    for i, ob in enumerate(obstacles):
        if not isinstance(ob, Obstacle):
            raise InvalidInputError("obstacles must be Obstacle(...) items, "
                                    "item {} is {!r}".format(i, ob))
        if ob.dim != dim:
            raise InvalidInputError(
                "obstacle {!r} is {}D on a {}D grid".format(
                    ob.name or i, ob.dim, dim))
    named = [ob if ob.name is not None else ob.named("obstacle{}".format(i))
             for i, ob in enumerate(obstacles)]
    names = [ob.name for ob in named]
    if len(set(names)) != len(names):
        raise InvalidInputError("obstacle names must differ, got {}"
                                .format(names))
    for ob in named:
        swept = np.stack([np.minimum(ob.bounds(0 * ob.displacement)[:, 0],
                                     ob.bounds(ob.displacement)[:, 0]),
                          np.maximum(ob.bounds(0 * ob.displacement)[:, 1],
                                     ob.bounds(ob.displacement)[:, 1])], 1)
        if (swept[:, 1] < mesh_bounds[:, 0]).any() or \
                (swept[:, 0] > mesh_bounds[:, 1]).any():
            raise InvalidInputError(
                "obstacle {!r} (bounds {}, moving by {}) never reaches the "
                "grid (bounds {}): it could touch no material".format(
                    ob.name, ob.bounds(0 * ob.displacement).tolist(),
                    ob.displacement.tolist(), mesh_bounds.tolist()))
    for i in range(len(named)):
        for j in range(i + 1, len(named)):
            if _overlap(named[i], named[j]):
                raise InvalidInputError(
                    "obstacles {!r} and {!r} overlap at the start: contact "
                    "with each is measured alone, so material between them "
                    "would be pushed both ways".format(named[i].name,
                                                      named[j].name))
    return tuple(named)


def _overlap(a: Obstacle, b: Obstacle) -> bool:
    """Whether two obstacles share interior at the start."""
    ba, bb = a.bounds(0 * a.displacement), b.bounds(0 * b.displacement)
    if (np.minimum(ba[:, 1], bb[:, 1]) <= np.maximum(ba[:, 0], bb[:, 0])
            ).any():
        return False              # bounding boxes at most touch
    if a.box is not None and b.box is not None:
        return True
    pa, pb = a.outline(), b.outline()
    # vertices, and the centroids (equal or nested polygons), inside the
    # other
    inside_b = b.signed_distance(np.vstack([pa, pa.mean(0)]).T)[0] < -1e-12
    inside_a = a.signed_distance(np.vstack([pb, pb.mean(0)]).T)[0] < -1e-12
    if inside_a.any() or inside_b.any():
        return True
    ea, eb = np.roll(pa, -1, axis=0), np.roll(pb, -1, axis=0)
    i, j = np.meshgrid(np.arange(len(pa)), np.arange(len(pb)), indexing="ij")
    i, j = i.ravel(), j.ravel()
    return bool(_segments_cross(pa[i].T, ea[i].T, pb[j].T, eb[j].T).any())
