"""Material-point state and seeding helpers.

State is kept as a struct of arrays, points along the last axis:

- ``x`` (dim, n): current positions,
- ``x0`` (dim, n): initial positions (``Y`` in the seed's error measure;
  a tied obstacle's reach is measured from them): points moved after
  seeding (``points.x[1] += 0.3``) need ``x0`` moved alike,
- ``volume`` (n,): volumes, fixed in small-strain MPM, ``det(F) volume0``
  in finite deformation,
- ``volume0`` (n,): initial volumes,
- ``stress`` and ``strain`` (3, 3, n): full symmetric 3x3 tensors whatever
  the dimension of the grid, so that plane strain keeps ``sigma_zz`` and 1D
  keeps the lateral stresses,
- ``displacement`` (dim, n): accumulated displacement,
- ``force`` (dim, n): point forces at full load (ramped by the solver),
- ``F`` and ``be`` (3, 3, n): deformation gradient and elastic left
  Cauchy-Green tensor (finite deformation),
- ``domain`` (dim, n) or ``None``: GIMP domain half-lengths,
- ``velocity`` and ``acceleration`` (dim, n) or ``None``: carried by
  implicit dynamics (:class:`~skfem_mpm.Dynamics`; ``velocity`` given is
  the initial velocity), ``None`` in quasi-static runs,
- ``body`` (n,) integers: which body (and material) each point belongs to,
- ``state``: the materials' internal variables, ``{name: (n,) array}``
  (e.g. ``equivalent_plastic_strain``), set by the solvers from the
  materials' ``state_variables``.

``strain`` is the elastic strain: infinitesimal in small strain (equal to
the total strain of an elastic body), logarithmic in finite deformation.

"""
import itertools
import logging
import re
from dataclasses import dataclass, fields
from typing import Callable, Optional, Sequence, Union

import numpy as np
from numpy import ndarray
from skfem.mesh import Mesh
from skfem.quadrature import get_quadrature
from skfem.refdom import RefLine, RefQuad, RefHex, RefTri

from ..errors import (InvalidInputError, UnsupportedElementError,
                      check_finite, check_int)
from ..memory import SEED_BYTES_PER_POINT, refuse_beyond_memory
from ..protocols import state_variables
from .locate import tensor_grid
from .mapping import fresh_mapping

logger = logging.getLogger(__name__)

__all__ = ["MaterialPoints", "seed_points", "seed_gauss_points",
           "concatenate_points", "select_points"]


@dataclass
class MaterialPoints:
    """Material points: a moving quadrature carrying its own state.

    Points of one's own (another code's model) need ``x`` and ``volume``,
    and ``body`` for more than one material; every other field has a
    default.  Arrays hold points along their last axis.

    Parameters
    ----------
    x
        Positions, shape (dim, n).
    volume
        Volumes (length in 1D, area in 2D), shape (n,), all positive: the
        part of the body each point stands for (its cells' volumes shared
        among their points; a run warns of volumes far from the cells'
        they fill).
    force
        Point forces at full load, shape (dim, n) (default zero), ramped
        with the load factor.
    x0
        Initial positions, shape (dim, n) (default ``x``): the run refuses
        points whose ``x`` differs from ``x0 + displacement``.
    stress
        Cauchy stress, tension positive (compression negative), the full
        symmetric 3x3 tensor in any dimension, shape (3, 3, n) (default
        zero): an initial (geostatic) stress goes here, or through
        :func:`~skfem_mpm.initial_stress` which also sets the materials'
        state from it.
    strain
        Elastic strain, shape (3, 3, n) (default zero): infinitesimal in
        small strain, logarithmic in finite deformation.
    displacement
        Accumulated displacement, shape (dim, n) (default zero).
    volume0
        Initial volumes, shape (n,) (default ``volume``).
    F, be
        Deformation gradient and elastic left Cauchy-Green tensor, shape
        (3, 3, n) (default the identity; finite deformation).
    domain
        GIMP and averaged-spline domains: half-lengths per grid axis,
        shape (dim, n), or ``None`` (methods ``"mpm"``, ``"fem"``,
        ``"bspline"``).  :func:`seed_points` sets them; for points of
        one's own filling square (cubic) domains,
        ``np.tile(volume ** (1 / dim) / 2, (dim, 1))``.
    body
        Integer body (and material) index per point, shape (n,), counted
        from 0 (default all 0): ``material`` and a per-body
        ``body_force`` have one entry per index 0 .. ``body.max()``.
    state
        The materials' internal variables, ``{name: (n,) array}`` (e.g.
        ``equivalent_plastic_strain``); the run adds those it lacks.
    velocity, acceleration
        Shape (dim, n), or ``None``: carried by implicit dynamics
        (``velocity`` given is the initial velocity); a quasi-static run
        refuses them.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm import MaterialPoints
    >>> mp = MaterialPoints(x=np.array([[0.25, 0.75]]), volume=np.array([.5, .5]))
    >>> mp.dim, mp.n, mp.stress.shape
    (1, 2, (3, 3, 2))

    """
    x: ndarray
    volume: ndarray
    force: Optional[ndarray] = None
    x0: Optional[ndarray] = None
    stress: Optional[ndarray] = None
    strain: Optional[ndarray] = None
    displacement: Optional[ndarray] = None
    volume0: Optional[ndarray] = None
    F: Optional[ndarray] = None
    be: Optional[ndarray] = None
    domain: Optional[ndarray] = None
    body: Optional[ndarray] = None
    state: Optional[dict] = None
    velocity: Optional[ndarray] = None
    acceleration: Optional[ndarray] = None

    def __post_init__(self):
        self.x = np.array(self.x, dtype=np.float64)
        self.volume = np.array(self.volume, dtype=np.float64)
        if self.x.ndim != 2 or not 1 <= self.x.shape[0] <= 3:
            raise InvalidInputError(
                "x must have shape (dim, n) with dim 1, 2 or 3, got {}"
                .format(self.x.shape))
        dim, n = self.x.shape
        if n == 0:
            raise InvalidInputError("MaterialPoints needs at least one point")
        if self.volume.shape != (n,):
            raise InvalidInputError(
                "volume must have shape ({},) to match x {}, got {}"
                .format(n, self.x.shape, self.volume.shape))
        check_finite("x", self.x)
        check_finite("volume", self.volume)
        if (self.volume <= 0).any():
            i = int(np.argmax(self.volume <= 0))
            raise InvalidInputError(
                "volume must be positive: {} point(s) are not, first point {} "
                "has volume {}".format(int((self.volume <= 0).sum()), i,
                                       self.volume[i]))
        given = {"F": self.F is not None, "be": self.be is not None}
        identity = np.eye(3)[:, :, None]
        defaults = {       # made only where a value is missing
            "force": lambda: np.zeros((dim, n)), "x0": lambda: self.x,
            "stress": lambda: np.zeros((3, 3, n)),
            "strain": lambda: np.zeros((3, 3, n)),
            "displacement": lambda: np.zeros((dim, n)),
            "volume0": lambda: self.volume,
            "F": lambda: np.repeat(identity, n, axis=2),
            "be": lambda: np.repeat(identity, n, axis=2),
        }
        shapes = {"force": (dim, n), "x0": (dim, n), "displacement": (dim, n),
                  "volume0": (n,), "domain": (dim, n), "velocity": (dim, n),
                  "acceleration": (dim, n)}
        optional = ("domain", "velocity", "acceleration")
        for name in list(defaults) + list(optional):
            value = getattr(self, name)
            if value is None:
                if name in optional:
                    continue
                value = defaults[name]()
            value = np.array(value, dtype=np.float64)
            expected = shapes.get(name, (3, 3, n))
            if value.shape != expected:
                raise InvalidInputError("{} must have shape {}, got {}"
                                        .format(name, expected, value.shape))
            check_finite(name, value)
            setattr(self, name, value)
        self.body = np.zeros(n, dtype=np.int64) if self.body is None \
            else _body_indices(self.body, n)
        for name, value in (("volume0", self.volume0),):
            if (value <= 0).any():
                i = int(np.argmax(value <= 0))
                raise InvalidInputError(
                    "{} must be positive: {} point(s) are not, first point {} "
                    "has {}".format(name, int((value <= 0).sum()), i, value[i]))
        if given["F"] or given["be"]:      # the identity needs no check
            _check_deformation(self.F, self.be)
        if self.domain is not None and not (self.domain > 0).all():
            raise InvalidInputError("domain half-lengths must be positive")
        state = {} if self.state is None else self.state
        if not isinstance(state, dict):
            raise InvalidInputError("state must be a dict of per-point "
                                    "arrays, got {}".format(type(state)))
        self.state = {}
        names = {f.name for f in fields(self)}
        for name, value in state.items():
            if not isinstance(name, str) or not name.isidentifier() \
                    or name in names:
                raise InvalidInputError(
                    "state variable names must be identifiers other than "
                    "the point fields ({}), got {!r}".format(
                        ", ".join(sorted(names)), name))
            value = np.array(value, dtype=np.float64)
            if value.shape != (n,):
                raise InvalidInputError(
                    "state variable {!r} must have shape ({},), got {}"
                    .format(name, n, value.shape))
            check_finite("state variable " + name, value)
            self.state[name] = value

    @property
    def dim(self) -> int:
        return self.x.shape[0]

    @property
    def n(self) -> int:
        return self.x.shape[1]

    def copy(self) -> "MaterialPoints":
        """Return a deep copy of the state (the constructor copies every
        array once)."""
        return MaterialPoints(**{f.name: getattr(self, f.name)
                                 for f in fields(self)})


def _body_indices(body, n: int) -> ndarray:
    """``body`` as (n,) non-negative integers; fractional values, booleans
    and strings are refused rather than truncated."""
    body = np.asarray(body)
    if body.shape != (n,) or not (np.issubdtype(body.dtype, np.integer)
                                  or np.issubdtype(body.dtype, np.floating)):
        raise InvalidInputError(
            "body must hold one non-negative integer per point, shape ({},), "
            "got shape {} of {}".format(n, body.shape, body.dtype))
    if np.issubdtype(body.dtype, np.floating):
        check_finite("body", body)
        fractional = body != np.round(body)
        if fractional.any():
            i = int(np.argmax(fractional))
            raise InvalidInputError(
                "body indices must be integers: {} are not, first point {} "
                "has {}".format(int(fractional.sum()), i, body[i]))
    if (body < 0).any():
        i = int(np.argmax(body < 0))
        raise InvalidInputError(
            "body indices must be non-negative, point {} has {}".format(
                i, body[i]))
    return body.astype(np.int64)


def _check_deformation(F: ndarray, be: ndarray):
    """Refuse an inverted deformation gradient (det F <= 0) and an elastic
    left Cauchy-Green tensor that is not symmetric positive definite
    (Sylvester's criterion on its leading minors).  The identity (new
    points, and their copy at a run's start) passes at once: the two
    determinants took 0.86 us a point in 2D (86 ms a copy at 1e5
    points)."""
    identity = np.eye(3)[:, :, None]
    if (F == identity).all() and (be == identity).all():
        return
    det = np.linalg.det(np.moveaxis(F, -1, 0))
    if not (det > 0).all():
        i = int(np.argmax(~(det > 0)))
        raise InvalidInputError(
            "F must have a positive determinant: {} point(s) do not, first "
            "point {} has det F = {}".format(int((~(det > 0)).sum()), i,
                                             det[i]))
    scale = np.abs(be).max(axis=(0, 1))
    asymmetric = np.abs(be - be.transpose(1, 0, 2)).max(axis=(0, 1)) \
        > 1e-10 * scale
    minors = (be[0, 0], be[0, 0] * be[1, 1] - be[0, 1] * be[1, 0],
              np.linalg.det(np.moveaxis(be, -1, 0)))
    bad = asymmetric | ~((minors[0] > 0) & (minors[1] > 0) & (minors[2] > 0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidInputError(
            "be must be symmetric positive definite: {} point(s) are not, "
            "first point {} has be = {}".format(int(bad.sum()), i,
                                                be[:, :, i].tolist()))


def _subcell_centres(refdom, n: int) -> ndarray:
    """Local coordinates of the centres of n^d equal sub-cells, (dim, n^d)."""
    if refdom in (RefLine, RefQuad, RefHex):
        c = (2 * np.arange(n) + 1) / (2 * n)
        grids = np.meshgrid(*([c] * refdom.dim()), indexing="ij")
        return np.array([g.ravel() for g in grids])
    if refdom is RefTri:
        # uniform split into n^2 triangles: centroids of upward and downward
        i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        up = (i + j) <= n - 1
        down = (i + j) <= n - 2
        cu = np.array([(i[up] + 1 / 3), (j[up] + 1 / 3)]) / n
        cd = np.array([(i[down] + 2 / 3), (j[down] + 2 / 3)]) / n
        return np.hstack((cu, cd))
    raise UnsupportedElementError(
        "equal sub-cell seeding is defined for line, quadrilateral, hexahedral "
        "and triangular grids, not {}; use seed_gauss_points".format(
            refdom.__name__))


def _points_from_reference(mesh: Mesh, X: ndarray, w: ndarray, region,
                           elements, half=None) -> MaterialPoints:
    """Map reference points X with reference weights w into every element;
    ``half`` (dim, nelements): GIMP half-lengths of the points of each
    element."""
    tind = (np.arange(mesh.nelements) if elements is None
            else np.asarray(elements, dtype=np.int64))
    mapping = fresh_mapping(mesh)
    x = mapping.F(X, tind=tind)                       # (dim, nel, nq)
    detJ = np.abs(mapping.detDF(X, tind=tind))        # (nel, nq)
    volume = (detJ * w).ravel()
    x = x.reshape(mesh.dim(), -1)
    domain = None if half is None else np.repeat(half[:, tind], X.shape[1],
                                                 axis=1)
    if region is not None:
        keep, x = in_region(region, mesh, x, tind, X.shape[1])
        x, volume = x[:, keep], volume[keep]
        domain = None if domain is None else domain[:, keep]
        if domain is not None and x.shape[1]:
            warn_region_volume(region, x, domain, volume, np.stack(
                [mesh.p.min(axis=1), mesh.p.max(axis=1)], axis=1))
    if x.shape[1] == 0:
        raise InvalidInputError("the region holds no material point")
    return MaterialPoints(x=x, volume=volume, domain=domain)


#: the distance, relative to the grid's extent along each axis, within
#: which a point lies on a region's boundary (:func:`in_region`)
ON_BOUNDARY = 1e-9


def in_region(region: Callable, mesh: Mesh, x: ndarray, tind: ndarray,
              per_element: int):
    """Which of the points ``x`` (dim, n; ``per_element`` in each element
    of ``tind`` in turn) the callable ``region`` keeps (n,), and the
    points' positions (dim, n): ``x``, but for the points on the
    region's boundary, which take the positions the region was asked at,
    so that every point kept satisfies the region at its own position.
    The region is called ``1 + 2 dim`` times (and, on a tensor grid,
    by :func:`warn_region_volume`) and must depend on the positions
    alone.

    On an axis-aligned tensor grid of linear cells (:func:`~skfem_mpm.
    quadrature.locate.tensor_grid`) the region is asked at positions made
    from each element's extent and the point's place in it rounded to
    :data:`ON_BOUNDARY`, so points in one column of cells give one
    coordinate: the mapping's rounding differs from row to row by an ulp,
    and a boundary through a column of points (a pile's side at a quarter
    cell) kept it in every other row, a side of teeth that locked two
    bodies in contact.  Points that lie on the boundary (the region's
    answer changes within :data:`ON_BOUNDARY` of the grid's extent along
    an axis) are kept or dropped by that rounding alone: a warning names
    them.

    >>> from skfem import MeshQuad
    >>> mesh = MeshQuad.init_tensor(np.linspace(0, 2, 16),
    ...                             np.linspace(0, 1, 5))
    >>> mp = seed_points(mesh, 2, region=lambda x: x[0] > .9)
    >>> left = mp.x[0] < 1.
    >>> np.unique(mp.x[0, left].round(4)).tolist(), int(left.sum())
    ([0.9667], 8)
    >>> mp = seed_points(mesh, 2, region=lambda x: x[0] < .9)
    >>> bool((mp.x[0] < .9).all()), np.unique(mp.x[0]).size
    (True, 14)
    """
    dim = mesh.dim()
    extent = mesh.p.max(axis=1) - mesh.p.min(axis=1)
    at = x
    if tensor_grid(mesh) is not None:
        corners = mesh.p[:, mesh.t[:, tind]]          # (dim, corners, nel)
        low = np.repeat(corners.min(axis=1), per_element, axis=1)
        size = np.repeat(corners.max(axis=1), per_element, axis=1) - low
        share = np.round((x - low) / size / ON_BOUNDARY) * ON_BOUNDARY
        at = low + size * share
    keep = np.asarray(region(at), dtype=bool)
    if keep.shape != (x.shape[1],):
        raise InvalidInputError(
            "region must return one bool per point, shape ({},), got {}"
            .format(x.shape[1], keep.shape))
    tie = np.zeros((dim, keep.size), dtype=bool)
    for d in range(dim):
        for side in (-1., 1.):
            moved = at.copy()
            moved[d] += side * ON_BOUNDARY * extent[d]
            tie[d] |= np.asarray(region(moved), dtype=bool) != keep
    if tie.any():
        logger.warning(
            "seeding: %d point(s) lie on the region's boundary, kept or "
            "dropped by rounding alone (%s): the body's side there falls "
            "between the points' sub-cells either way; move the boundary "
            "off the points (onto grid lines or between points) to say "
            "which", tie.any(axis=0).sum(), "; ".join(
                "across {}: {} kept, {} dropped, the first at {} = {:.12g}"
                .format(AXES[d], (tie[d] & keep).sum(),
                        (tie[d] & ~keep).sum(), AXES[d],
                        at[d, np.argmax(tie[d])])
                for d in range(dim) if tie[d].any()))
    return keep, np.where(tie.any(axis=0), at, x)


AXES = "xyz"
#: a body seeded in a region whose volume differs from the points' by
#: more than this share is warned (:func:`warn_region_volume`)
REGION_VOLUME_WARNING = 1e-2
#: samples per axis, by the grid's dimension, of each sub-cell the
#: region's side may cut, which estimate the region's share of it
#: (:func:`warn_region_volume`; a side parallel to the sub-cells' faces is
#: placed to a sixteenth of a sub-cell in 2D, an eighth in 3D)
SIDE_SAMPLES = {1: 16, 2: 8, 3: 4}


def warn_region_volume(region: Callable, x: ndarray, half: ndarray,
                       volume: ndarray, box: ndarray):
    """Log a warning where the points seeded in ``region`` (at ``x``,
    (dim, n), their sub-cells of half-lengths ``half`` and volumes
    ``volume``; the grid's bounding ``box``, (dim, 2)) hold a volume that
    differs from the region's by more than
    :data:`REGION_VOLUME_WARNING`.  A body's side lies at its outermost
    sub-cells' faces, so a region whose side cuts sub-cells gains or
    loses up to half a sub-cell there (a user's column meant 2 high came
    out 2.0625 high, its top settlement 5.9% off the intended column's).
    The region's volume is its own where it knows it (a polygon's or a
    ball's ``volume`` within the grid, :func:`exact_volume`), else
    estimated on the sub-cells its side may cut:
    the points with a neighbour along an axis outside the region, and
    their neighbours (along the axes and diagonals, inside the grid's
    box) outside it, each sampled at :data:`SIDE_SAMPLES` places per
    axis; the sub-cells inside count in full.

    >>> from skfem import MeshQuad
    >>> mesh = MeshQuad.init_tensor(np.linspace(0, 1, 9),
    ...                             np.linspace(0, 3, 25))
    >>> mp = seed_points(mesh, 2, region=lambda x: x[1] < 2.)
    >>> round(float(mp.volume.sum()), 6)
    2.0
    """
    dim, total = x.shape[0], float(volume.sum())
    spacing = 2 * half
    edge = np.zeros(x.shape[1], dtype=bool)
    for d in range(dim):
        for sign in (-1., 1.):
            neighbour = x.copy()
            neighbour[d] += sign * spacing[d]
            edge |= ~np.asarray(region(neighbour), dtype=bool)
    if not edge.any():
        return
    at, size, share = x[:, edge], spacing[:, edge], volume[edge]
    steps = np.array(list(itertools.product((-1., 0., 1.), repeat=dim))).T
    steps = steps[:, np.any(steps != 0., axis=0)]             # (dim, k)
    near = (at[:, None] + steps[:, :, None] * size[:, None]).reshape(dim, -1)
    near_size = np.repeat(size[:, None], steps.shape[1], axis=1).reshape(
        dim, -1)
    near_share = np.repeat(share[None], steps.shape[1], axis=0).ravel()
    inside = np.all((near >= box[:, :1]) & (near <= box[:, 1:]), axis=0)
    inside &= ~np.asarray(region(near), dtype=bool)
    # one each: centres a sub-cell apart are two apart in half-cells
    _, first = np.unique(np.round(2 * near[:, inside] / near_size[:, inside]
                                  ).astype(np.int64), axis=1,
                         return_index=True)
    chosen = np.flatnonzero(inside)[first]
    lost = share @ (1. - region_share(region, at, size))
    gained = near_share[chosen] @ region_share(
        region, near[:, chosen], near_size[:, chosen])
    change, about = gained - lost, " about"
    exact = exact_volume(region, box)
    if exact is not None:         # a polygon's or a ball's, in the grid
        change, about = exact - total, ""
    if abs(change) > REGION_VOLUME_WARNING * total:
        logger.warning(
            "seeding: the points hold a volume of %.6g, %+.1f%% against "
            "the region's%s %.6g: a body's side lies at its outermost "
            "sub-cells' faces, and the region's sides cut the sub-cells; "
            "put the region's sides on the sub-cells' faces (multiples of "
            "the cell size over the points per cell) or seed more points "
            "per cell",
            total, -100 * change / (total + change), about,
            total + change)


def exact_volume(region, box: ndarray):
    """The volume of ``region`` where it knows it (a polygon's shoelace
    area, a ball's: their ``volume``) and lies within the grid's ``box``
    (dim, 2), else ``None`` (a polygon (0,2),(10,2),(6,6),(0,6) of area 32
    was warned as "about 31.9375", its sides sampled)."""
    volume, bounds = getattr(region, "volume", None), getattr(
        region, "bounds", None)
    if not isinstance(volume, float) or bounds is None:
        return None
    lo, hi = np.asarray(bounds(), dtype=np.float64).T
    inside = np.all(lo >= box[:, 0]) and np.all(hi <= box[:, 1])
    return volume if inside else None


def region_share(region: Callable, centre: ndarray, size: ndarray):
    """The share of each box of ``size`` (dim, m) around ``centre`` (dim,
    m) that ``region`` holds, sampled at the centres of
    :data:`SIDE_SAMPLES` equal parts per axis."""
    dim = centre.shape[0]
    count = SIDE_SAMPLES[dim]
    parts = (np.arange(count) + .5) / count - .5
    offsets = np.array(list(itertools.product(parts, repeat=dim))).T
    places = centre[:, None] + offsets[:, :, None] * size[:, None]
    held = np.asarray(region(places.reshape(dim, -1)), dtype=bool)
    return held.reshape(offsets.shape[1], -1).mean(axis=0)


def in_box(x: ndarray, box) -> ndarray:
    """Whether the points ``x`` (dim, n) lie inside the open box ``box``
    (``[(lo, hi)]`` per axis)."""
    return np.all([(x[d] > lo) & (x[d] < hi) for d, (lo, hi) in
                   enumerate(box)], axis=0)


def box_region(mesh: Mesh, box) -> Callable:
    """The test of the box ``box`` (``[(lo, hi)]`` per axis, ``lo < hi``;
    an infinite bound: the whole axis that way) after checking it against
    ``mesh``: a box reaching outside the grid's extent is refused (the
    points there would be dropped without a word)."""
    dim = mesh.dim()
    try:
        box = np.asarray(box, dtype=np.float64)
    except (TypeError, ValueError):
        box = None
    if box is None or box.shape != (dim, 2) or np.isnan(box).any() or not (
            box[:, 0] < box[:, 1]).all():
        raise InvalidInputError(
            "a box region must be one [lo, hi] with lo < hi per axis of "
            "the {}D grid, got {!r}".format(dim, box if box is None
                                            else box.tolist()))
    low, high = mesh.p.min(axis=1), mesh.p.max(axis=1)
    slack = 1e-12 * (high - low)
    for d, (lo, hi) in enumerate(box):
        if -np.inf < lo < low[d] - slack[d] or \
                np.inf > hi > high[d] + slack[d]:
            raise InvalidInputError(
                "region {} = [{!r}, {!r}] reaches outside the grid's {} "
                "extent [{!r}, {!r}]: the material there would be dropped; "
                "shrink the region or extend the grid".format(
                    AXES[d], float(lo), float(hi), AXES[d], float(low[d]),
                    float(high[d])))
    return lambda x: in_box(x, box)


def seed_points(mesh: Mesh, n: int,
                region: Optional[Union[Callable, Sequence]] = None,
                elements: Optional[ndarray] = None) -> MaterialPoints:
    """Seed n^d points per element at the centres of equal sub-cells.

    Each point receives the volume of its sub-cell (seed Figure 2.4), so the
    points of an element add up to the element's volume.  On axis-aligned
    tensor-product grids each point's GIMP ``domain`` is its sub-cell
    (``domain`` holds its half-lengths).

    As a quadrature the points integrate exactly only what is linear in
    a cell (the midpoint rule on each sub-cell): enough for linear
    elements, but quadratic ones (Q2, P2) lose an order of convergence
    on them whatever n.  Poisson's ``-lap u = 2 pi^2 sin(pi x) sin(pi
    y)`` on 64 x 64 cells, Q2 with n = 2, 3, 4: H1 errors 1.6e-2,
    5.9e-3, 3.2e-3 (as h; L2 as h^2) against Gauss quadrature's 2.0e-4
    (as h^2).  :func:`seed_gauss_points` (order 3 for Q2, 2 for P2)
    gives the Gauss answer.

    Parameters
    ----------
    mesh
        A scikit-fem mesh (line, quadrilateral, hexahedral or triangle).
    n
        Points per element and direction (n^d points per element; for
        triangles n^2 sub-triangles).
    region
        Optional callable ``region(x) -> bool array``: keep only the points
        whose coordinates (dim, npoints) satisfy it; or a box, ``[(lo,
        hi)]`` per axis (the points strictly inside it; an infinite bound:
        the whole axis that way), refused where it reaches outside the
        grid (``InvalidInputError`` naming the axis, the box and the
        grid's extent; a callable cannot be checked so).  On an
        axis-aligned grid of linear cells a boundary through a column of
        points keeps it in every row or in none, and points on a boundary
        are named in a warning (:func:`in_region`), and so is a region
        whose volume differs from the points' by more than 1% (its sides
        cut the sub-cells, :func:`warn_region_volume`); a callable is
        called several times and must depend on the positions alone
        (draw random voids first and look them up by position).
    elements
        Optional array of element indices to seed (default: all).

    Examples
    --------
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import seed_points
    >>> mp = seed_points(MeshQuad().refined(1), 2)
    >>> mp.n, float(mp.volume.sum())
    (16, 1.0)

    """
    check_int("n (points per cell and direction)", n, 1)
    if region is not None and not callable(region):
        region = box_region(mesh, region)
    nelements = mesh.nelements if elements is None else np.size(elements)
    refuse_beyond_memory(
        "seeding {} points per element and direction in {} elements".format(
            n, nelements),
        float(n) ** mesh.dim() * nelements * SEED_BYTES_PER_POINT,
        "seed fewer points per element, or only where the body is "
        "(elements=)")
    X = _subcell_centres(mesh.refdom, int(n))
    w = np.full(X.shape[1], _reference_volume(mesh.refdom) / X.shape[1])
    half = None
    if tensor_grid(mesh) is not None:
        half = (mesh.p[:, mesh.t].max(axis=1) - mesh.p[:, mesh.t].min(axis=1)
                ) / (2 * n)
    return _points_from_reference(mesh, X, w, region, elements, half)


def _reference_volume(refdom) -> float:
    _, W = get_quadrature(refdom, 0)
    return float(W.sum())


def seed_gauss_points(mesh: Mesh, intorder: int = 2,
                      region: Optional[Callable] = None,
                      elements: Optional[ndarray] = None) -> MaterialPoints:
    """Seed points at the Gauss points of each element, volumes = weights.

    With these points a one-step MPM analysis is the finite element
    analysis with the same quadrature, to round-off.

    Parameters
    ----------
    mesh
        Any scikit-fem mesh.
    intorder
        Integration order of scikit-fem's quadrature rule (as ``Basis``).
        Rules with a negative weight (triangles' orders 3 and 7,
        tetrahedra's 3, 4, 8 and 9) are refused, naming the nearest
        orders whose weights are all positive: a point's volume is its
        weight.
    region, elements
        As in :func:`seed_points`.

    Examples
    --------
    >>> from skfem import MeshTri
    >>> from skfem_mpm import seed_gauss_points
    >>> mp = seed_gauss_points(MeshTri(), intorder=2)
    >>> mp.n, round(float(mp.volume.sum()), 12)
    (6, 1.0)

    """
    X, W = get_quadrature(mesh.refdom, intorder)
    if not (W > 0).all():
        raise InvalidInputError(
            "seed_gauss_points: scikit-fem's rule of order {} on {} has "
            "negative weights ({} of its {}: {}), and a material point's "
            "volume is its weight; take order {}".format(
                intorder, mesh.refdom.__name__, int((W <= 0).sum()),
                W.size, ", ".join("{:.6g}".format(w) for w in W[W <= 0]),
                " or ".join(str(k) for k in positive_orders(
                    mesh.refdom, intorder))))
    return _points_from_reference(mesh, X, W, region, elements)


def positive_orders(refdom, intorder: int) -> list:
    """The nearest orders below and above ``intorder`` whose scikit-fem
    rules on ``refdom`` have only positive weights (those scikit-fem has).

    >>> from skfem.refdom import RefTri, RefTet
    >>> positive_orders(RefTri, 3), positive_orders(RefTet, 8)
    ([2, 4], [7])
    """
    found = []
    for orders in (range(intorder - 1, -1, -1),
                   range(intorder + 1, intorder + 31)):
        for order in orders:
            try:
                _, W = get_quadrature(refdom, order)
            except NotImplementedError:     # beyond scikit-fem's rules
                break
            if (W > 0).all():
                found.append(order)
                break
    return sorted(found)


def concatenate_points(parts, material=None) -> MaterialPoints:
    """Join point sets (e.g. bodies) into one, keeping every field.

    A part that lacks a state variable the others hold gets its initial
    value where it is known: the small-strain rotation (``rotation``;
    ``rotation_x``, ``rotation_y``, ``rotation_z`` in 3D, which a run
    adds) starts at zero, counted from the joining (a fresh layer placed
    on a stage's points has rotated nothing), and with ``material`` (a
    material, or one per body as :func:`~skfem_mpm.simulate` takes them)
    the materials' internal variables take their initial values
    (``state_variables``).  A contact's variables (a stage with an
    obstacle, or with contact between bodies, gives its points them)
    start at zero, in contact with nothing: :data:`FRESH_CONTACT`.  Any
    other variable a part lacks is refused.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import seed_points
    >>> from skfem_mpm.quadrature.points import concatenate_points
    >>> mesh = MeshQuad().refined(1)
    >>> a = seed_points(mesh, 1, region=lambda x: x[0] < .5)
    >>> b = seed_points(mesh, 1, region=lambda x: x[0] > .5)
    >>> b.body[:] = 1
    >>> concatenate_points([a, b]).body.tolist()
    [0, 0, 1, 1]

    A stage's points (a run gave them ``rotation``) and a fresh layer:

    >>> a.state["rotation"] = np.array([.01, .02])
    >>> concatenate_points([a, b]).state["rotation"].tolist()
    [0.01, 0.02, 0.0, 0.0]

    """
    parts = list(parts)
    kwargs = {}
    names = set().union(*(p.state for p in parts))
    known = known_initial_values(names, material)
    lacking = [(k, sorted(names - set(p.state) - set(known)))
               for k, p in enumerate(parts)
               if names - set(p.state) - set(known)]
    if lacking:
        k, missing = lacking[0]
        raise InvalidInputError(
            "cannot join point sets with different state variables: part "
            "{} lacks {} (the parts have {}), whose initial value is not "
            "known here (known: the rotation's and a contact's, zero, but "
            "the B-spline corners' between bodies, contact_body_corner*, "
            "and {}); {}give every part the same ones, e.g. "
            "parts[{}].state[{!r}] = np.zeros(parts[{}].n)".format(
                k, ", ".join(missing), [sorted(p.state) for p in parts],
                "the given materials' variables': it is none of theirs"
                if material is not None else "with the materials theirs",
                "" if material is not None else "if it is a material's, "
                "give the materials (concatenate_points(parts, material="
                "...): their variables take their initial values), or ",
                k, missing[0], k))
    kwargs["state"] = {name: np.concatenate([
        p.state[name] if name in p.state else np.full(p.n, known[name])
        for p in parts]) for name in names}
    for f in fields(MaterialPoints):
        if f.name == "state":
            continue
        values = [getattr(p, f.name) for p in parts]
        if any(v is None for v in values):
            if not all(v is None for v in values):
                raise InvalidInputError(
                    "cannot join point sets where only some have {}".format(
                        f.name))
            continue
        kwargs[f.name] = np.concatenate(values, axis=-1)
    return MaterialPoints(**kwargs)


def known_initial_values(names, material=None) -> dict:
    """The initial values of the state variables ``names`` that are known:
    the small-strain rotation's and the contact's of :data:`FRESH_CONTACT`
    (zero) and, with ``material`` (or a list, one per body), the
    materials' internal variables'
    (:func:`~skfem_mpm.protocols.state_variables`)."""
    known = {name: 0. for name in names
             if name == "rotation" or name in ROTATION_3D
             or FRESH_CONTACT.fullmatch(name)}
    if material is None:
        return known
    given = state_variables(material if isinstance(material, (list, tuple))
                            else [material])
    known.update((name, float(value)) for name, value in given.items()
                 if name in names)
    return known


#: the point state a run with contact keeps that is zero on points in
#: contact with nothing that no run has moved (a fresh layer): an
#: obstacle's multipliers and tractions (``contact<i>_p<c>``,
#: ``contact<i>_t<a><c>``), its corners' offsets from where the points'
#: deformation puts them and from the initial places at the run's start
#: (``contact_dx<a><c>``, ``contact_start_dx<a><c>``) and the small-strain
#: displacement gradient (``contact_grad<a><b>``,
#: :func:`~skfem_mpm.solve.contact.contact_state_names`); between bodies
#: the pressure, gap, friction traction and pressure rate
#: (``contact_body<k>_<p|g|t|r><a><c>``) and the gradient
#: (``contact_body_grad<a><b>``), not the B-spline corners' offsets from
#: their points (``contact_body_corner<a><c>``, the domain's half-widths:
#: :func:`~skfem_mpm.solve.body_contact.body_contact_state_names`)
FRESH_CONTACT = re.compile(r"contact\d+_[pt]\d+|contact_(start_)?dx\d+"
                           r"|contact_grad\d+|contact_body\d+_[pgtr]\d+"
                           r"|contact_body_grad\d+")


#: the names of the small-strain rotation kept in 3D
#: (:func:`~skfem_mpm.solve.rotation.rotation_names`)
ROTATION_3D = ("rotation_x", "rotation_y", "rotation_z")


def select_points(points: MaterialPoints, which) -> MaterialPoints:
    """The points ``which`` (a boolean mask of ``points.n``, or indices)
    keeps, with every field and state variable: an excavation's stage
    removes the others (``select_points(points, ~dug)``).  A copy.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import seed_points, select_points
    >>> points = seed_points(MeshQuad().refined(1), 1)
    >>> points.state["rotation"] = np.arange(4.)
    >>> kept = select_points(points, points.x[1] < .5)
    >>> kept.n, kept.x[1].tolist(), kept.state["rotation"].tolist()
    (2, [0.25, 0.25], [0.0, 1.0])

    """
    which = np.asarray(which)
    if which.dtype == bool:
        if which.shape != (points.n,):
            raise InvalidInputError(
                "a mask selecting points must have one entry per point "
                "({}), got shape {}".format(points.n, which.shape))
        which = np.flatnonzero(which)
    elif which.ndim != 1 or not np.issubdtype(which.dtype, np.integer) \
            and which.size:
        raise InvalidInputError(
            "points are selected by a boolean mask or integer indices, "
            "got {!r}".format(which.dtype))
    which = which.astype(int)
    if which.size and (which.min() < -points.n or which.max() >= points.n):
        raise InvalidInputError(
            "point indices must lie within 0..{}, got {} to {}".format(
                points.n - 1, int(which.min()), int(which.max())))
    kwargs = {"state": {name: np.array(value[..., which]) for name, value
                        in (points.state or {}).items()}}
    for f in fields(MaterialPoints):
        value = getattr(points, f.name)
        if f.name != "state" and value is not None:
            kwargs[f.name] = np.array(value[..., which])
    return MaterialPoints(**kwargs)
