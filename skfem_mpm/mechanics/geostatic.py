"""Geostatic initial stress: a body that starts in equilibrium under its
own weight.

The K0 procedure of geotechnical analysis: at depth ``d`` below the ground
surface the vertical stress is ``sigma_v = -gamma d`` (compression
negative, ``gamma`` the unit weight, the body force per unit volume) and
every horizontal normal stress ``sigma_h = K0 sigma_v``; no shear.  Under a
level surface this state is in equilibrium with the full body force, so a
run that starts from it with the body force acting in full from the first
step (``simulate(..., body_force=BodyForce(g, ramp=False))``) has
nothing to do until
other loads come (an overburden as a traction the stress includes acts
in full too: ``Traction(..., ramp=False)``).  Under a sloping surface it
is not in equilibrium, and
the first step must carry the whole imbalance at once (no cut-back reduces
it): ramp the gravity up from a stress-free start there instead.
Layered ground (one body force and K0 per body): each body carries the
weight of the bodies above it in its column, exact for horizontal layers
under a level surface; layers that are not horizontal are refused.
The usual estimate for a normally consolidated soil is Jaky's
``K0 = 1 - sin(phi)``; an elastic layer under uniaxial strain has
``K0 = nu / (1 - nu)``.
"""
import logging
from typing import Callable, Sequence, Union

import numpy as np

from ..errors import InvalidInputError, check_real
from ..quadrature.points import MaterialPoints
from .initial_stress import elastic_state
from .materials import at_points, warn_empty_bodies

__all__ = ["geostatic_stress"]

logger = logging.getLogger(__name__)

ALONE = ("give every one of them a surface (each then starts alone, under "
         "its own weight) or start them without K0")
#: what the refusals of layers add for points without domains
SQUARES = (" (points without domains: each one's extent taken as a "
           "square's, volume ** (1 / dim) / 2 either side; Gauss points "
           "lie otherwise: give them a surface each)")


def extents(points: MaterialPoints) -> np.ndarray:
    """The points' half-lengths (dim, n): their domains, or for points
    without domains those of squares (cubes) of their volumes,
    ``volume ** (1 / dim) / 2`` (as :class:`~skfem_mpm.MaterialPoints`
    documents for points of one's own; exact for equal sub-cells)."""
    if points.domain is not None:
        return points.domain
    return np.tile(np.abs(points.volume) ** (1 / points.dim) / 2,
                   (points.dim, 1))


def geostatic_stress(points: MaterialPoints, material, body_force,
                     surface: Union[None, float, Callable, Sequence], K0
                     ) -> MaterialPoints:
    """The points with the geostatic stress of ``body_force`` under
    ``surface`` (a height, or a function of the positions (dim, n)
    returning the ground height above each point), reached elastically.

    Layered ground: with one row of ``body_force`` per body (the points'
    ``body``), each body's vertical stress continues the stress of the
    body above it in its column, ``sigma_v = -(gamma_k (top_k - y) +
    sum_above gamma_i t_i)``; ``surface`` is the ground over the bodies
    that have none above them.  Exact equilibrium for horizontal layers
    under a level surface; layers that are not horizontal (heights that
    interleave, a top or bottom that is not level, a body over part of
    another only, a gap) are refused, naming the bodies.

    Parameters
    ----------
    points
        The material points (copied, not modified).
    material
        The material (or one per body): its elastic law gives the elastic
        strains of the stresses; the state must lie within its yield
        surface.
    body_force
        Body force per unit volume, (dim,), along the last axis and
        pointing down (negative); or one row per body, (nbodies, dim),
        for layers.  Zero (a weightless body, so that one script runs a
        case without weight too): the stress is zero (``K0`` then acts on
        nothing), refused by a material with no stress-free state (Cam
        clay's elastic law at zero pressure).
    surface
        Ground height (a number or a callable); with layers also ``None``
        (the top of each uppermost body's material: its points' domains,
        or for points without domains squares of their volumes,
        ``volume ** (1 / dim) / 2`` above the highest point, exact for
        equal sub-cells; Gauss points, whose material reaches elsewhere,
        need their surface given: the top Gauss point was taken for the
        top, and points of one's own started a hold 0.11 out of balance,
        a user trial) or one entry per body: ``None`` continues the
        layers above (the default), a height starts that body alone from
        it (its own weight up to there, ignoring the bodies above).
    K0
        Ratio of horizontal to vertical stress (> 0), or one per body.

    Returns
    -------
    MaterialPoints
        With ``stress``, the elastic ``strain`` and ``be`` (finite
        deformation) of the geostatic state; positions, displacements and
        ``F`` unchanged.

    Raises
    ------
    InvalidInputError
        A body force not along the last axis, a point above the surface, a
        non-positive ``K0``, layers that are not horizontal, or a state
        outside the material's yield surface (the message names the count
        and the first point: a ``K0`` nearer 1 may fit).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import LinearElastic, geostatic_stress, seed_points
    >>> mesh = MeshQuad.init_tensor(np.linspace(0, 1, 2), np.linspace(0, 2, 3))
    >>> pts = geostatic_stress(seed_points(mesh, 1), LinearElastic(1e4, .25),
    ...                        [0., -20.], surface=2., K0=1 / 3)
    >>> pts.stress[1, 1].tolist(), np.round(pts.stress[0, 0], 6).tolist()
    ([-30.0, -10.0], [-10.0, -3.333333])

    Sand (18) 1 thick over clay (20): the clay continues the sand's 18.

    >>> pts = seed_points(mesh, 1)
    >>> pts.body[:] = [0, 1]
    >>> pts = geostatic_stress(pts, LinearElastic(1e4, .25),
    ...                        [[0., -20.], [0., -18.]], None, [.5, 1 / 3])
    >>> pts.stress[1, 1].tolist(), pts.stress[0, 0].tolist()
    ([-28.0, -9.0], [-14.0, -3.0])

    """
    # body ids from 1 with one material per id (body 0 a dummy): the
    # words of simulate's check (they passed here without one, a trial)
    warn_empty_bodies(points)
    return k0_state(points, material, body_force, surface, K0)


def k0_state(points: MaterialPoints, material, body_force, surface, K0
             ) -> MaterialPoints:
    """:func:`geostatic_stress` without its check of empty bodies: a scene
    file's geostatic bodies, a part of its bodies (their ids leave out the
    others')."""
    dim = points.dim
    b = np.asarray(body_force, dtype=float)
    layered = b.ndim == 2 or np.ndim(K0) == 1 or (
        surface is not None and not callable(surface)
        and np.ndim(surface) == 1) or surface is None
    body = np.zeros(points.n, dtype=int) if points.body is None \
        else np.asarray(points.body, dtype=int)
    nb = int(body.max()) + 1
    rows = b if b.ndim == 2 else np.broadcast_to(b, (nb,) + b.shape)
    present = np.unique(body)
    if rows.ndim != 2 or rows.shape[0] < nb or rows.shape[1] != dim \
            or not np.isfinite(rows[present]).all() \
            or (rows[present, -1] > 0).any() or rows[present, :-1].any():
        raise InvalidInputError(
            "body_force must be ({},) or one such row per body ({} bodies), "
            "along the last axis and pointing down (negative) or zero (a "
            "weightless body: no stress), got {!r}".format(
                dim, nb, body_force))
    ratios = np.array([check_real("K0", k) for k in np.ravel(K0)]) \
        if np.ndim(K0) == 1 else np.full(nb, check_real("K0", K0))
    if ratios.shape[0] < nb or not (np.isfinite(ratios[present])
                                    & (ratios[present] > 0)).all():
        raise InvalidInputError("K0 must be positive, one per body ({}), got "
                                "{!r}".format(nb, K0))
    if layered:
        vertical = layered_vertical(points, body, rows[:, -1], surface)
    else:
        top = surface(points.x) if callable(surface) else np.full(
            points.n, check_real("surface", surface))
        vertical = rows[0, -1] * ground_depth(points, top)
        warn_overburden(points, np.arange(points.n), top, -rows[0, -1],
                        "the bodies'")
    K0 = ratios[body]
    stress = np.zeros((3, 3, points.n))
    for axis in range(3):
        stress[axis, axis] = K0 * vertical
    stress[dim - 1, dim - 1] = vertical
    out = points.copy()
    strain, be = elastic_state(
        at_points(material, points), stress, out, np.arange(points.n),
        "the geostatic state (K0 = {})".format(
            np.unique(K0).tolist() if np.ptp(K0) else float(K0[0])),
        "choose K0 nearer 1" if np.any(K0 != 1.) else "")
    out.stress, out.strain, out.be = stress, strain, be
    return out


def ground_depth(points: MaterialPoints, top) -> np.ndarray:
    """Depth of every point below the ground heights ``top`` (n,), checked
    finite and not negative."""
    top = np.asarray(top, dtype=float)
    if top.shape != (points.n,) or not np.isfinite(top).all():
        raise InvalidInputError("surface must give one finite height per "
                                "point, got shape {}".format(top.shape))
    depth = top - points.x[-1]
    if (depth < 0).any():
        i = int(np.argmin(depth))
        raise InvalidInputError(
            "{} point(s) lie above the surface, first {} at {}".format(
                int((depth < 0).sum()), i, points.x[:, i].tolist()))
    return depth


def warn_overburden(points: MaterialPoints, idx: np.ndarray, top,
                    gamma: float, what: str) -> None:
    """A warning where the ground heights ``top`` of the points ``idx``
    lie above the top of their column's material (the points' domains):
    the stress there starts at the weight of soil that is not there, with
    no load to balance it.  A trial's surface given as the region's top,
    0.067 above the domains of an untuned grid, started 1.2 kPa out of
    balance and moved the soil 4.6e-4 m in the first step."""
    if gamma == 0. or points.domain is None:
        # weightless: no stress, nothing out of balance; points without
        # domains (Gauss points) do not say where their material ends (a
        # trial's top Gauss point, 0.106 below the body's top, was warned)
        return
    domain = points.domain
    x = points.x[:, idx]
    face = x[-1] + domain[-1, idx]
    size = np.ptp(points.x, axis=1).max() + 2 * np.abs(domain).max()
    tol = 1e-9 * max(size, 1e-300)
    _, where = np.unique(np.round(x[:-1] / tol), axis=1,
                         return_inverse=True)
    where = where.ravel()
    ends = np.full(where.max(initial=-1) + 1, -np.inf)
    np.maximum.at(ends, where, face)
    gap = np.asarray(top, dtype=float) - ends[where]
    i = int(np.argmax(gap)) if gap.size else 0
    if gap.size and gap[i] > 1e-6 * size:
        logger.warning(
            "geostatic start: the surface lies up to %.4g above the top of "
            "%s material (in the column at x = %s its points' domains end "
            "at %.6g), "
            "so the stress there starts at the weight of %.4g of soil that "
            "is not there (%.4g) with no load to balance it, and the first "
            "step moves the body; leave the surface out (None: the "
            "material's top) or apply that overburden as a surface "
            "traction", gap[i], what,
            "[{}]".format(", ".join("{:.4g}".format(c) for c in x[:-1, i])),
            ends[where[i]], gap[i],
            gamma * gap[i])


def layered_vertical(points: MaterialPoints, body, weights,
                     surface) -> np.ndarray:
    """Vertical stress of horizontal layers (the bodies, unit weights
    ``-weights``): each body continues the stress of the body directly
    above it at their interface; the bodies with none above start from
    ``surface`` (see :func:`geostatic_stress`)."""
    dim, n = points.x.shape
    domain = extents(points)
    alone = ALONE + ("" if points.domain is not None else SQUARES)
    present = np.unique(body)
    nb = int(body.max()) + 1
    if surface is not None and not callable(surface) \
            and np.ndim(surface) == 1:
        own = list(surface)
        if len(own) < nb:
            raise InvalidInputError("surface must give one entry per body "
                                    "({}), got {!r}".format(nb, surface))
        own = [None if h is None else check_real("surface", h) for h in own]
        ground = None
    else:
        own = [None] * nb
        ground = None if surface is None else surface(points.x) \
            if callable(surface) else np.full(n, check_real("surface",
                                                            surface))
    lo, hi = points.x - domain, points.x + domain
    box = {k: (lo[:, body == k].min(axis=1), hi[:, body == k].max(axis=1))
           for k in present}
    size = np.ptp(np.concatenate([lo, hi], axis=1), axis=1).max()
    tol = 1e-9 * size
    above = {}                        # body -> the body directly above it
    for k in present:
        for j in present:
            if j == k or own[k] is not None:      # k alone: nothing above
                continue
            (lk, hk), (lj, hj) = box[k], box[j]
            if ((lj[:-1] >= hk[:-1] - tol) | (lk[:-1] >= hj[:-1] - tol)).any():
                continue                               # side by side
            if lj[-1] < hk[-1] - tol:                  # j not above k
                if lk[-1] < hj[-1] - tol:
                    raise InvalidInputError(
                        "bodies {} and {} are not horizontal layers (their "
                        "heights interleave in the same columns): "
                        "{}".format(k, j, alone))
                continue
            if (lj[:-1] > lk[:-1] + tol).any() or \
                    (hj[:-1] < hk[:-1] - tol).any():
                raise InvalidInputError(
                    "body {} lies over part of body {} only: the layers "
                    "must cover each other (horizontal layers); "
                    "{}".format(j, k, alone))
            if k not in above or lj[-1] < box[above[k]][0][-1]:
                above[k] = j
    for k, j in above.items():                # level faces at interfaces
        if box[j][0][-1] > box[k][1][-1] + tol:
            raise InvalidInputError(
                "body {} lies above body {} with a gap ({:.6g} to {:.6g}): "
                "the layers must touch; {}".format(
                    j, k, box[k][1][-1], box[j][0][-1], alone))
        for face, sel, top in ((hi, body == k, True), (lo, body == j, False)):
            cols, where = np.unique(np.round(points.x[:-1, sel] / tol),
                                    axis=1, return_inverse=True)
            ends = np.full(cols.shape[1], -np.inf if top else np.inf)
            (np.maximum if top else np.minimum).at(
                ends, where.ravel(), face[-1, sel])
            if np.ptp(ends) > tol:
                raise InvalidInputError(
                    "the interface of bodies {} (above) and {} is not level "
                    "(heights {:.6g} to {:.6g}): horizontal layers only; "
                    "{}".format(j, k, ends.min(), ends.max(), alone))

    def at(k, idx, y):
        """Vertical stress of body ``k`` in the columns of the points
        ``idx`` at the heights ``y``."""
        if own[k] is not None:
            top = np.full(idx.size, own[k])
        elif k in above:
            j = above[k]
            return weights[k] * (box[k][1][-1] - y) + at(
                j, idx, np.full(idx.size, box[j][0][-1]))
        else:
            top = np.full(idx.size, box[k][1][-1]) if ground is None \
                else ground[idx]
        return weights[k] * ground_depth(MaterialPoints(
            x=np.vstack([points.x[:-1, idx], y]),
            volume=np.ones(idx.size)), top)

    vertical = np.zeros(n)
    for k in present:
        sel = np.flatnonzero(body == k)
        vertical[sel] = at(k, sel, points.x[-1, sel])
        if k not in above and (own[k] is not None or ground is not None):
            warn_overburden(points, sel, ground[sel] if own[k] is None
                            else own[k], -weights[k], "body {}'s".format(k))
    return vertical
