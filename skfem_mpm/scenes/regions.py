"""Body regions other than boxes: a polygon (2D) and a ball (a disc in
2D).

Each is a callable on positions (dim, n), so that it seeds a body as any
callable region does (:func:`~skfem_mpm.quadrature.points.seed_points`:
the points whose sub-cell centres lie inside, each with its sub-cell's
volume, and a warning where their volume differs from the region's by
more than 1%), and it knows its bounding box, which the scene checks
against the grid.  Scene files write them ``region = { polygon = [[x, y],
...] }`` and ``region = { centre = [..], radius = r }``.

>>> disc = Ball([0.5, 0.25], 0.25)
>>> disc(np.array([[0.5, 0.5], [0.25, 0.6]])).tolist(), disc.bounds().tolist()
([True, False], [[0.25, 0.75], [0.0, 0.5]])
>>> slope = Polygon([[0, 0], [3, 0], [3, 1], [1, 1]])
>>> slope(np.array([[0.5, 2.], [0.75, 0.5]])).tolist(), slope.volume
([False, True], 2.5)
"""
import math
from typing import Sequence

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError
from ..solve.obstacles import by_blocks, checked_polygon, polygon_distance

__all__ = ["Polygon", "Ball", "region_shape", "bounding_box",
           "outside_grid", "check_shape", "closed_region"]


class Polygon:
    """A simple polygon (2D): at least 3 vertices ``[[x, y], ...]`` in
    either orientation, not crossing itself, not closed by repeating the
    first (checked as an obstacle's polygon is,
    :class:`~skfem_mpm.Obstacle`).  Its interior holds the body; a
    position on its sides is outside."""

    dim = 2

    def __init__(self, vertices, what: str = "polygon"):
        self.vertices = checked_polygon(vertices, what)   # (2, m), ccw

    def __call__(self, x: ndarray) -> ndarray:
        """Whether the positions ``x`` (2, n) lie inside: ``distance(x) <
        0`` (a position on a side, at distance 0, is outside), one edge
        at a time over all positions, without the distances and normals
        of :func:`~skfem_mpm.solve.obstacles.polygon_distance` (the
        seeding asks a region 10 times; a trial's 1.3e6 sub-cells took
        9 s of its 1e6-point slope's set-up)."""
        x = np.asarray(x, dtype=np.float64)
        v = self.vertices
        inside = np.zeros(x.shape[1], dtype=bool)
        touches = np.zeros(x.shape[1], dtype=bool)
        for a, b in zip(v.T, np.roll(v, -1, axis=1).T):
            # polygon_distance's formulas, edge by edge: the same values
            e = b - a
            r0, r1 = x[0] - a[0], x[1] - a[1]
            t = np.clip((r0 * e[0] + r1 * e[1]) / (e[0] * e[0]
                                                   + e[1] * e[1]), 0., 1.)
            touches |= (r0 - t * e[0]) ** 2 + (r1 - t * e[1]) ** 2 == 0.
            straddles = (a[1] > x[1]) != (b[1] > x[1])
            with np.errstate(divide="ignore", invalid="ignore"):
                inside ^= straddles & (x[0] < a[0] + (x[1] - a[1]) * e[0]
                                       / e[1])
        return inside & ~touches

    def distance(self, x: ndarray) -> ndarray:
        """The signed distance of the positions ``x`` (2, n) from the
        sides, negative inside."""
        x = np.asarray(x, dtype=np.float64)
        return by_blocks(lambda y: polygon_distance(self.vertices, y), x,
                         self.vertices.shape[1])[0]

    def bounds(self) -> ndarray:
        """The bounding box (2, 2): ``[lo, hi]`` per axis."""
        return np.stack([self.vertices.min(axis=1),
                         self.vertices.max(axis=1)], axis=1)

    @property
    def volume(self) -> float:
        """The area (the shoelace formula)."""
        x, y = self.vertices
        return float(.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))

    def __repr__(self):
        return "Polygon({})".format(self.vertices.T.tolist())


class Ball:
    """The positions nearer than ``radius`` to ``centre`` (dim,): a disc
    in 2D, a ball in 3D, an interval in 1D."""

    def __init__(self, centre: Sequence[float], radius: float,
                 what: str = "ball"):
        try:
            self.centre = np.array(centre, dtype=np.float64)
            self.radius = float(radius)
        except (TypeError, ValueError):
            self.centre, self.radius = np.zeros(0), math.nan
        if self.centre.ndim != 1 or not 1 <= self.centre.size <= 3 or \
                not np.isfinite(self.centre).all():
            raise InvalidInputError(
                "{} centre must be 1 to 3 finite coordinates, got {!r}"
                .format(what, centre))
        if not 0. < self.radius < math.inf:
            raise InvalidInputError(
                "{} radius must be a finite number > 0, got {!r}".format(
                    what, radius))
        self.dim = self.centre.size

    def __call__(self, x: ndarray) -> ndarray:
        d = np.asarray(x, dtype=np.float64) - self.centre[:, None]
        return np.einsum("am,am->m", d, d) < self.radius ** 2

    def distance(self, x: ndarray) -> ndarray:
        """The signed distance of the positions ``x`` (dim, n) from the
        sphere, negative inside."""
        d = np.asarray(x, dtype=np.float64) - self.centre[:, None]
        return np.sqrt(np.einsum("am,am->m", d, d)) - self.radius

    def bounds(self) -> ndarray:
        """The bounding box (dim, 2): ``[lo, hi]`` per axis."""
        return self.centre[:, None] + np.array([-1., 1.]) * self.radius

    @property
    def volume(self) -> float:
        """The length, area or volume: ``2 r``, ``pi r^2``, ``4/3 pi
        r^3``."""
        return {1: 2., 2: math.pi, 3: 4. * math.pi / 3.}[self.dim] \
            * self.radius ** self.dim

    def __repr__(self):
        return "Ball(centre={}, radius={!r})".format(self.centre.tolist(),
                                                     self.radius)


def region_shape(region) -> str:
    """What a body's region is, in a scene file's words: ``"box"``,
    ``"polygon"``, ``"disc"`` (a 2D ball), ``"ball"`` or ``"function"``
    (any other callable)."""
    if isinstance(region, Polygon):
        return "polygon"
    if isinstance(region, Ball):
        return "disc" if region.dim == 2 else "ball"
    return "function" if callable(region) else "box"


def bounding_box(region):
    """The box ``[(lo, hi)]`` per axis of a box region itself, of a
    :class:`Polygon` or :class:`Ball` its bounding box, ``None`` for any
    other callable."""
    if isinstance(region, (Polygon, Ball)):
        return [tuple(b) for b in region.bounds().tolist()]
    return None if callable(region) else region


def outside_grid(region, low: ndarray, high: ndarray) -> list:
    """The axes ``(d, lo, hi)`` along which a box (``[(lo, hi)]`` per axis;
    an infinite bound: the whole axis), a :class:`Polygon` or a
    :class:`Ball` reaches outside the grid's extent ``low``, ``high``
    (dim,), ``lo``, ``hi`` its bounds there (to the grid's extent times
    1e-12); nothing for any other callable (it cannot be checked so)."""
    box = bounding_box(region)
    if box is None:
        return []
    out = []
    for d, (lo, hi) in enumerate(box):
        slack = 1e-12 * (high[d] - low[d])
        if -math.inf < lo < low[d] - slack or math.inf > hi > high[d] + slack:
            out.append((d, float(lo), float(hi)))
    return out


def check_shape(region, mesh):
    """Refuse a :class:`Polygon` or :class:`Ball` of another dimension than
    ``mesh`` or reaching outside its extent (the material there would be
    dropped without a word); any other region passes (a box is checked
    when it is seeded, a callable cannot be)."""
    if not isinstance(region, (Polygon, Ball)):
        return
    shape = region_shape(region)
    if region.dim != mesh.dim():
        raise InvalidInputError(
            "a {} region is {}D, the grid {}D{}".format(
                shape, region.dim, mesh.dim(), "" if shape != "polygon"
                else ": a polygon is a 2D region"))
    low, high = mesh.p.min(axis=1), mesh.p.max(axis=1)
    for d, lo, hi in outside_grid(region, low, high):
        raise InvalidInputError(
            "the {} {!r} reaches outside the grid's {} extent [{!r}, "
            "{!r}] (its own is [{!r}, {!r}]): the material there would be "
            "dropped; shrink the region or extend the grid".format(
                shape, region, "xyz"[d], float(low[d]), float(high[d]),
                lo, hi))


def closed_region(region, x: ndarray, tol: float = 0.) -> ndarray:
    """Which of the positions ``x`` (dim, n) lie in ``region`` or on its
    boundary (within ``tol``): a box ``[(lo, hi)]`` per axis (``lo <=
    hi``), a :class:`Polygon` or a :class:`Ball`, as the grid nodes of a
    support's region and the points of an output's are chosen.

    >>> x = np.array([[0., 1., 2.], [0., 1., 0.]])
    >>> closed_region([(0., 1.), (0., 1.)], x).tolist()
    [True, True, False]
    >>> closed_region(Polygon([[0, 0], [2, 0], [0, 2]]), x).tolist()
    [True, True, True]
    """
    if isinstance(region, (Polygon, Ball)):
        return region.distance(x) <= tol
    return np.all([(x[d] >= lo - tol) & (x[d] <= hi + tol)
                   for d, (lo, hi) in enumerate(region)], axis=0)
