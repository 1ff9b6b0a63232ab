"""Initial stress: the elastic state that holds a given stress.

A run reads a point's stress from its elastic strain ``strain`` where
the stress is not the state itself: a plastic material in small strain,
every material in finite deformation (the logarithmic strain of the
Kirchhoff stress ``det(F) stress``; ``be`` is its exponential).  A stress
set by hand (carried over from
another code, or from finite elements, :func:`~skfem_mpm.solve_fe`)
needs that state too: :func:`initial_stress` gives it, through the
material's inverse elastic law, and refuses a stress the material's yield
surface does not hold.  :func:`~skfem_mpm.simulate` calls it on points
whose stress was set alone (their ``strain`` zero and ``be`` the
identity), so such a stress is never dropped.
"""
import logging
from typing import Optional

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError
from ..quadrature.points import MaterialPoints
from .materials import (PointMaterials, at_points, initial_state,
                        inverse_elastic_law, is_plastic, update)

__all__ = ["initial_stress"]

logger = logging.getLogger(__name__)


def initial_stress(points: MaterialPoints, material,
                   stress: Optional[ndarray] = None,
                   kinematics: str = "small") -> MaterialPoints:
    """The points with the Cauchy stress ``stress`` (3, 3, n; default
    their own ``stress``) and the elastic state that holds it, by the
    material's inverse elastic law: the elastic strain ``strain`` and
    ``be`` of the stress (small strain), or of the Kirchhoff stress
    ``det(F) stress`` (finite deformation; the same where ``F`` is the
    identity).

    Parameters
    ----------
    points
        The material points (copied, not modified); their internal
        variables (``state``, the material's initial values where absent)
        place the yield surface.
    material
        The material, or one per body (the points' ``body``).
    stress
        Symmetric (3, 3, n) stresses, compression negative; ``None``: the
        points' own.
    kinematics
        The run's to come, ``"small"`` or ``"finite"``: which elastic
        strain holds the stress where ``F`` is not the identity (points of
        an earlier finite stage: a review's, ``det F = 1.1``, read back
        -110 for -100 in small strain from the Kirchhoff stress's).

    Returns
    -------
    MaterialPoints
        With ``stress``, ``strain`` and ``be``; all else unchanged.

    Raises
    ------
    InvalidInputError
        A stress of the wrong shape, not symmetric or not finite, or one
        outside the material's yield surface (the message names the count
        and the first point).
    InvalidMaterialError
        A stress with no elastic state in the material (Cam clay at a mean
        pressure that is not compressive).

    Examples
    --------
    A stress from elsewhere on a Mohr-Coulomb soil, which reads its
    stress from the elastic strain:

    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import MohrCoulomb, initial_stress, seed_points
    >>> pts = seed_points(MeshQuad(), 1)
    >>> soil = MohrCoulomb(1e4, .25, cohesion=5., friction_angle=30.)
    >>> given = np.diag([-50., -100., -50.])[:, :, None]
    >>> pts = initial_stress(pts, soil, given)
    >>> np.round(pts.strain[1, 1] * 1e4, 6).tolist()
    [-75.0]

    """
    n = points.n
    sigma = np.array(points.stress if stress is None else stress,
                     dtype=np.float64)
    if sigma.shape != (3, 3, n) or not np.isfinite(sigma).all():
        raise InvalidInputError(
            "initial_stress: stress must be (3, 3, {}) finite numbers, got "
            "{}".format(n, sigma.shape))
    scale = np.abs(sigma).max(initial=0.)
    if np.abs(sigma - sigma.transpose(1, 0, 2)).max(initial=0.) > \
            1e-12 * scale:
        raise InvalidInputError("initial_stress: the stress must be "
                                "symmetric (sigma_ij = sigma_ji)")
    if kinematics not in ("small", "finite"):
        raise InvalidInputError("initial_stress: kinematics must be "
                                "'small' or 'finite', got {!r}".format(
                                    kinematics))
    out = points.copy()
    strain, be = elastic_state(at_points(material, points), sigma, out,
                               np.arange(n), "initial_stress",
                               finite=kinematics == "finite")
    out.stress, out.strain, out.be = sigma, strain, be
    return out


def elastic_state(materials, sigma: ndarray, points: MaterialPoints,
                  idx: ndarray, who: str, advice: str = "",
                  finite: bool = False) -> tuple:
    """``(strain, be)`` (3, 3, m) of the Cauchy stresses ``sigma`` (3, 3,
    m) of the points ``idx`` (their ``F`` and ``state``) by the inverse
    elastic law of ``materials`` (at those points): of the stress itself,
    or (``finite``) of the Kirchhoff stress ``det(F) sigma``, which finite
    deformation reads; a stress outside the yield surface is refused, the
    error starting with ``who`` and ending with ``advice`` (what may
    fit)."""
    n = idx.size
    J = np.linalg.det(points.F[:, :, idx].transpose(2, 0, 1)) if finite \
        else np.ones(n)
    # the Kirchhoff stress J sigma has the same axes
    values, vectors = principal_axes(sigma)
    principal = inverse_elastic_law(materials, values * J)
    if is_plastic(materials):
        state = initial_state(materials, n)
        state.update({k: v[idx] for k, v in (points.state or {}).items()})
        yielded = update(materials, principal, state, idx)[3]
        if yielded.any():
            k = int(np.flatnonzero(yielded)[0])
            i = int(idx[k])
            model = materials.materials[points.body[i]] if isinstance(
                materials, PointMaterials) else materials
            raise InvalidInputError(
                "{}: the stress lies outside the yield surface at {} "
                "point(s), first {} (body {}) at {} (principal stresses "
                "{}): the material cannot hold it elastically; {}{}".format(
                    who, int(yielded.sum()), i, int(points.body[i]),
                    points.x[:, i].tolist(),
                    np.round(values[:, k], 6).tolist(),
                    advice + " or " if advice else "",
                    "a larger preconsolidation_pressure (or each point's "
                    "plastic_volumetric_strain)" if hasattr(
                        model, "preconsolidation") else
                    "a stronger material"))
    strain = np.einsum("ap,bap,cap->bcp", principal, vectors, vectors)
    be = np.einsum("ap,bap,cap->bcp", np.exp(2 * principal), vectors,
                   vectors)
    return strain, be


def principal_axes(sigma: ndarray) -> tuple:
    """Principal values (3, n) and axes (3, 3, n; axis ``A`` in column
    ``[:, A]``) of symmetric tensors (3, 3, n); exact where they are
    diagonal."""
    n = sigma.shape[-1]
    if not np.any(sigma - np.einsum("aap->ap", sigma)[:, None, :]
                  * np.eye(3)[:, :, None]):
        return np.einsum("aap->ap", sigma), np.repeat(
            np.eye(3)[:, :, None], n, axis=2)
    values, vectors = np.linalg.eigh(sigma.transpose(2, 0, 1))
    return values.T, vectors.transpose(1, 2, 0)


def derive_elastic_state(points: MaterialPoints, material,
                         finite: bool) -> None:
    """Give the points whose stress was set alone (a stress, the elastic
    strain zero and ``be`` the identity) the elastic state that holds it
    (:func:`elastic_state`; of the Kirchhoff stress where ``finite``), in
    place, saying so at INFO: a run reads a
    plastic material's stress in small strain and every material's in
    finite deformation from that state, and dropped a stress set by hand
    without a word (user trials: a Mohr-Coulomb soil's -200 became 0,
    Cam clay's went back to its reference pressure, and finite
    deformation unloaded a column carried over from finite elements)."""
    alone = np.any(points.stress.reshape(9, -1), axis=0) & ~np.any(
        points.strain.reshape(9, -1), axis=0) & ~np.any(
        (points.be - np.eye(3)[:, :, None]).reshape(9, -1), axis=0)
    if not alone.any():
        return
    idx = np.flatnonzero(alone)
    materials = at_points(material, points)
    if isinstance(materials, PointMaterials):   # these points' materials
        materials = materials.take(idx)
    strain, be = elastic_state(materials, points.stress[:, :, idx], points,
                               idx, "the points' stress (set without its "
                               "elastic strain)", finite=finite)
    points.strain[:, :, idx], points.be[:, :, idx] = strain, be
    logger.info("%d of %d points have a stress set without its elastic "
                "strain: their strain and be are the stress's by the "
                "material's inverse elastic law (initial_stress)",
                idx.size, points.n)


def warn_carried_from_finite(points: MaterialPoints, material) -> None:
    """A warning where a small-strain run starts from points of an earlier
    finite-deformation stage (``det F`` not 1) whose material reads its
    stress from the elastic strain (a plastic one): that strain holds
    their Kirchhoff stress ``det(F) stress``, which small strain takes for
    the stress (a user trial's Mohr-Coulomb column, carried over at
    ``det F = 0.934``, started 6.6% off its load and moved 2.9e-2 where
    the stress's own strain moved 1.1e-2, unsaid).  An elastic body's
    small strain adds its increments to the stress itself: not warned."""
    materials = at_points(material, points)
    plastic = np.array([is_plastic(m) for m in materials.materials])[
        materials.body] if isinstance(materials, PointMaterials) else \
        np.full(points.n, is_plastic(materials))
    if not plastic.any():
        return
    J = np.linalg.det(points.F.transpose(2, 0, 1))
    carried = np.flatnonzero(plastic & (np.abs(J - 1.) > 1e-9) & np.any(
        points.strain.reshape(9, -1), axis=0))
    if not carried.size:
        return
    # not where the strain is already the stress's (initial_stress(...,
    # "small"), or a small-strain stage of its own)
    if isinstance(materials, PointMaterials):
        materials = materials.take(carried)
    values, vectors = principal_axes(points.stress[:, :, carried])
    own = np.einsum("ap,bap,cap->bcp", inverse_elastic_law(
        materials, values), vectors, vectors)
    gap = np.abs(own - points.strain[:, :, carried]).max(axis=(0, 1))
    carried = carried[gap > 1e-8 * np.abs(own).max(axis=(0, 1))]
    if not carried.size:
        return
    off = np.abs(J[carried] - 1.).max()
    logger.warning(
        "%d of %d points come from finite deformation (det F from %.4g to "
        "%.4g) into small strain, which reads their stress from their "
        "elastic strain: it holds their Kirchhoff stress det(F) stress, "
        "up to %.3g%% off their stress; give them the strain of their "
        "stress with initial_stress(points, material, points.stress, "
        "'small'), or continue in finite deformation",
        carried.size, points.n, J[carried].min(), J[carried].max(),
        100. * off)

