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
other loads come.  Under a sloping surface it is not in equilibrium, and
the first step must carry the whole imbalance at once (no cut-back reduces
it): ramp the gravity up from a stress-free start there instead.
The usual estimate for a normally consolidated soil is Jaky's
``K0 = 1 - sin(phi)``; an elastic layer under uniaxial strain has
``K0 = nu / (1 - nu)``.
"""
from typing import Callable, Union

import numpy as np

from ..errors import InvalidInputError, check_real
from ..quadrature.points import MaterialPoints
from .materials import (at_points, initial_state, inverse_elastic_law,
                        is_plastic)

__all__ = ["geostatic_stress"]


def geostatic_stress(points: MaterialPoints, material, body_force,
                     surface: Union[float, Callable], K0: float
                     ) -> MaterialPoints:
    """The points with the geostatic stress of ``body_force`` under
    ``surface`` (a height, or a function of the positions (dim, n)
    returning the ground height above each point), reached elastically.

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
        pointing down (negative).
    surface, K0
        Ground height and the ratio of horizontal to vertical stress
        (> 0).

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
        non-positive ``K0``, or a state outside the material's yield
        surface (the message names the count and the first point: a ``K0``
        nearer 1 may fit).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import LinearElastic, seed_points
    >>> mesh = MeshQuad.init_tensor(np.linspace(0, 1, 2), np.linspace(0, 2, 3))
    >>> pts = geostatic_stress(seed_points(mesh, 1), LinearElastic(1e4, .25),
    ...                        [0., -20.], surface=2., K0=1 / 3)
    >>> pts.stress[1, 1].tolist(), np.round(pts.stress[0, 0], 6).tolist()
    ([-30.0, -10.0], [-10.0, -3.333333])

    """
    dim = points.dim
    b = np.asarray(body_force, dtype=float)
    if b.shape != (dim,) or not np.isfinite(b).all() or b[-1] >= 0 \
            or b[:-1].any():
        raise InvalidInputError(
            "body_force must be ({},) along the last axis and pointing down "
            "(negative), got {!r}".format(dim, body_force))
    K0 = check_real("K0", K0)
    if not (np.isfinite(K0) and K0 > 0):
        raise InvalidInputError("K0 must be positive, got {}".format(K0))
    top = surface(points.x) if callable(surface) else np.full(
        points.n, check_real("surface", surface))
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
    vertical = b[-1] * depth                      # compression negative
    stress = np.zeros((3, 3, points.n))
    for axis in range(3):
        stress[axis, axis] = K0 * vertical
    stress[dim - 1, dim - 1] = vertical
    out = points.copy()
    materials = at_points(material, points)
    # the stress axes are the coordinate axes: principal values on the
    # diagonal, their elastic strains by the inverse elastic law
    principal = inverse_elastic_law(materials, np.einsum("aap->ap", stress))
    strain = np.einsum("ap,ab->abp", principal, np.eye(3))
    # within the yield surface?
    yielded = np.zeros(points.n, dtype=bool)
    if is_plastic(materials):
        state = initial_state(materials, points.n)
        state.update(points.state or {})
        yielded = materials.principal_update(principal, state)[3]
    if yielded.any():
        i = int(np.flatnonzero(yielded)[0])
        raise InvalidInputError(
            "the geostatic state (K0 = {}) lies outside the yield surface at "
            "{} point(s), first {} at {} (vertical stress {:.4g}): the soil "
            "cannot stand so; choose K0 nearer 1 or a stronger "
            "material".format(K0, int(yielded.sum()), i,
                              points.x[:, i].tolist(), vertical[i]))
    out.stress, out.strain = stress, strain
    out.be = np.zeros((3, 3, points.n))
    for axis in range(3):
        out.be[axis, axis] = np.exp(2 * strain[axis, axis])
    return out
