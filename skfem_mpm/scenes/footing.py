"""What a footing scene (``reference = "bearing_capacity"``) must be for
its collapse load to be ``N_c c``, checked with the scene before any work.

A rigid strip footing pushed into a weightless, cohesive-frictional soil
of associated flow, in plane strain: the closed form ``N_c`` and the error
against it are in :mod:`skfem_mpm.studies.footing`; here are the checks,
the footing (:func:`scene_footing`: a rigid body or a box obstacle) and
the soil's strength ``(c, phi)`` they and the closed form read.

"""
from typing import NamedTuple

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError
from ..mechanics.materials import VonMises
from ..mechanics.soils import DruckerPrager, MohrCoulomb
from .regions import bounding_box, region_shape

__all__ = ["soil_strength", "Footing", "scene_footing", "check_footing_scene",
           "footing_pressure", "footing_forces", "still_rising",
           "STILL_RISING"]

#: the rise of a footing's pressure over its last step, relative to it,
#: beyond which a peak at that step is no collapse load (a plateau's
#: steps rise by less: a trial's Tresca footing, its peak the last of 20
#: steps, still rose 0.8% a step; a soil that never failed, its
#: cohesion in Pa where the units were kPa, 5.3%, all 20 elastic)
STILL_RISING = 0.005


def soil_strength(material) -> tuple:
    """``(c, phi)`` (phi in degrees) of a material in plane-strain limit
    analysis: von Mises (``c_u = sigma_y / sqrt(3)``, ``phi = 0``),
    Mohr-Coulomb, or Drucker-Prager with ``fit = "plane_strain"``; any other
    material is refused (its collapse load has no closed form here)."""
    if isinstance(material, VonMises):         # perfectly plastic
        return material.yield_stress / np.sqrt(3.), 0.
    if isinstance(material, (MohrCoulomb, DruckerPrager)):
        if isinstance(material, DruckerPrager) and (
                material.fit != "plane_strain" or material.hardening != 0.):
            raise InvalidInputError(
                "a Drucker-Prager soil has the limit loads of Mohr-Coulomb "
                "only with fit = 'plane_strain' and no hardening, got fit "
                "{!r}, hardening {}".format(material.fit, material.hardening))
        if material.dilation_angle != material.friction_angle:
            raise InvalidInputError(
                "N_c is the limit load of associated flow: dilation_angle "
                "must equal friction_angle ({} and {})".format(
                    material.dilation_angle, material.friction_angle))
        return material.cohesion, material.friction_angle
    raise InvalidInputError(
        "the bearing capacity needs a von Mises, Mohr-Coulomb or "
        "plane-strain Drucker-Prager soil, got {}".format(
            type(material).__name__))


class Footing(NamedTuple):
    """The footing of a bearing-capacity scene (:func:`scene_footing`)."""
    #: ``"rigid_bodies"`` or ``"obstacles"`` (its ``summary.json`` key)
    kind: str
    #: its name there
    name: str
    #: its column among the reactions of
    #: :func:`~skfem_mpm.scenes.scene.reaction_resultants`
    column: int
    #: the pressure's denominator: a rigid body's region's width, a box
    #: obstacle's width over the soil (half the footing in a half model)
    width: float
    #: the soil's push on it is ``sign`` times its force there (a rigid
    #: body's holds its motion, down; an obstacle's is the material's)
    sign: float
    #: it reaches the soil's side (a half model: that side is the
    #: symmetry line of a footing twice as wide)
    half: bool = False

    @property
    def B(self) -> float:
        """The whole footing's width: twice :attr:`width` in a half
        model (an engineer's ``s / B``), else :attr:`width`."""
        return 2. * self.width if self.half else self.width


def scene_footing(scene) -> Footing:
    """The footing of a bearing-capacity scene: its one rigid body or
    moving obstacle, pushed down (``displacement = [0, -s]``).  A rigid
    body is a box region whose edges across the motion are grid lines
    inside the grid (it drives the whole cells its points are in: its
    contact width is that of its cells); an obstacle is a box, its width
    the part over the soil (the soil bodies' regions' x-extent, the
    grid's for a region that is a plain function: a half model's box may
    reach past the symmetry line), which must leave soil surface free
    beside it; anything else is refused.  A footing that reaches the
    soil's side is half of a symmetric one, that side its symmetry line
    (:attr:`Footing.half`: its ``B`` twice its width): ``N_c c`` is the
    collapse pressure of a footing on a half-space, not at its edge."""
    from .scene import obstacle_list
    rigid = [b for b in scene.bodies if b.rigid is not None]
    obstacles = [(k, o) for k, o in enumerate(obstacle_list(scene))
                 if np.any(o.displacement)]
    motions = [np.asarray(b.rigid, dtype=float) for b in rigid] + \
        [o.displacement for _, o in obstacles]
    if len(motions) != 1 or motions[0][0] != 0. or motions[0][1] >= 0:
        raise InvalidInputError(
            "reference 'bearing_capacity' needs one footing pushed down, "
            "displacement [0, -s]: one rigid body or one moving box "
            "obstacle, got {}".format(", ".join(
                ["rigid body {!r} {}".format(b.name, list(b.rigid))
                 for b in rigid] + ["obstacle {!r} {}".format(
                     o.name, o.displacement.tolist())
                     for _, o in obstacles]) or "none"))
    mesh, _ = scene.grid.build()
    lines = np.unique(mesh.p[0])
    first = len(scene.supports)
    if obstacles:
        k, obstacle = obstacles[0]
        if obstacle.box is None:
            raise InvalidInputError(
                "reference 'bearing_capacity' needs the footing obstacle "
                "{!r} as a box (its width is the pressure's denominator), "
                "not a polygon".format(obstacle.name))
        soil = soil_extent(scene, lines[0], lines[-1])
        lo, hi = np.clip(obstacle.box[0], *soil)
        if hi <= lo:
            raise InvalidInputError(
                "reference 'bearing_capacity': the footing obstacle {!r} "
                "(x from {} to {}) is over no soil (x from {} to {})"
                .format(obstacle.name, *obstacle.box[0], *soil))
        if obstacle.box[0][0] <= soil[0] and obstacle.box[0][1] >= soil[1]:
            raise InvalidInputError(
                "reference 'bearing_capacity': the footing obstacle {!r} "
                "(x from {} to {}) covers the soil's whole surface (x from "
                "{} to {}): no free surface beside it, so no collapse "
                "mechanism and no N_c c".format(
                    obstacle.name, *obstacle.box[0], *soil))
        return Footing("obstacles", obstacle.name,
                       first + len(rigid) + k, float(hi - lo), 1.,
                       bool(lo <= soil[0] or hi >= soil[1]))
    footing = rigid[0]
    if callable(footing.region):
        raise InvalidInputError(
            "reference 'bearing_capacity' needs the footing's region as a "
            "box, region = {{ x = [lo, hi], y = [lo, hi] }} (its width is "
            "the pressure's denominator), not a {}".format(
                region_shape(footing.region)))
    for edge in footing.region[0]:
        if np.abs(lines - edge).min() > 1e-9 * (1 + np.abs(lines).max()):
            raise InvalidInputError(
                "reference 'bearing_capacity': the footing {!r} has its edge "
                "x = {} between grid lines (x from {} to {}): it drives the "
                "whole cells its points are in, so its width would not be "
                "its region's; put its edges on grid lines".format(
                    footing.name, edge, lines.min(), lines.max()))
    lo, hi = footing.region[0]
    soil = soil_extent(scene, lines[0], lines[-1])
    return Footing("rigid_bodies", footing.name, first, float(hi - lo), -1.,
                   bool(lo <= soil[0] or hi >= soil[1]))


def soil_extent(scene, low: float, high: float) -> tuple:
    """The x-extent of a footing scene's soil (its bodies that are not
    rigid): the union of their regions' bounding boxes, within the grid's
    ``low`` to ``high`` (the grid's where a region is a plain function,
    whose extent is not known before seeding)."""
    boxes = [bounding_box(b.region) for b in scene.bodies
             if b.rigid is None]
    if any(box is None for box in boxes) or not boxes:
        return float(low), float(high)
    return (float(max(low, min(box[0][0] for box in boxes))),
            float(min(high, max(box[0][1] for box in boxes))))


def check_footing_scene(scene):
    """Refuse a scene whose bearing capacity is not ``N_c c``: it needs a
    2D grid, no gravity (weightless soil), one footing pushed down
    (:func:`scene_footing`), and the other bodies of one soil with
    ``c > 0``."""
    if scene.grid.dim != 2:
        raise InvalidInputError("reference 'bearing_capacity' is for 2D "
                                "(plane-strain) scenes")
    weights = scene.body_forces()
    if weights is not None and weights.any():
        raise InvalidInputError(
            "reference 'bearing_capacity' is for weightless soil: the "
            "gravity adds the soil weight's share (N_gamma) to N_c c")
    scene_footing(scene)
    strengths = {soil_strength(b.material) for b in scene.bodies
                 if b.rigid is None}
    if len(strengths) != 1:
        raise InvalidInputError(
            "reference 'bearing_capacity' needs one soil, got bodies of "
            "strengths (c, phi) {}".format(sorted(strengths)))
    if strengths.pop()[0] <= 0.:
        raise InvalidInputError(
            "reference 'bearing_capacity' measures the pressure in units of "
            "the cohesion: a soil without cohesion has no N_c c")


def footing_pressure(scene, forces: ndarray) -> ndarray:
    """The footing pressure per step (positive pushing down) from the
    footing's force per step ``forces`` (steps, 2; a rigid body's that
    holds its motion, or an obstacle's from the material,
    :func:`footing_forces`): the soil's push up on it over its width
    (:func:`~skfem_mpm.scenes.footing.scene_footing`)."""
    footing = scene_footing(scene)
    return footing.sign * np.asarray(forces)[:, 1] / footing.width


def still_rising(pressure: ndarray, unit: str = "") -> str:
    """``""``, or where a footing's pressure per step (``pressure``, from
    the first step; in ``unit``) peaks at its last step and that step
    raised it by more than :data:`STILL_RISING` of it, the words of a
    warning: that peak is no collapse load.

    >>> from skfem_mpm.scenes.footing import still_rising
    >>> still_rising([50., 100., 104.])[:59]
    'not a collapse load: the footing pressure peaks at the last'
    >>> still_rising([50., 100., 100.1]), still_rising([50., 104., 100.])
    ('', '')
    """
    pressure = np.asarray(pressure, dtype=float)
    if not pressure.size or int(np.argmax(pressure)) != pressure.size - 1 \
            or pressure[-1] <= 0:
        return ""
    before = pressure[-2] if pressure.size > 1 else 0.
    rise = (pressure[-1] - before) / pressure[-1]
    if rise <= STILL_RISING:
        return ""
    return ("not a collapse load: the footing pressure peaks at the last "
            "step, {:.6g}{}, and rose {:.2%} over that step (more than "
            "{:.1%}): it is still rising; push the footing further (a "
            "larger displacement) until the pressure levels off, in more "
            "steps if they fail".format(
                pressure[-1], " " + unit if unit else "", rise,
                STILL_RISING))


def footing_forces(scene, history) -> ndarray:
    """The footing's force per step of the records ``history`` (steps,
    2), as :func:`footing_pressure` reads it."""
    footing = scene_footing(scene)
    if footing.kind == "rigid_bodies":
        return np.array([r.rigid_forces[0] for r in history])
    k = footing.column - len(scene.supports) - sum(
        b.rigid is not None for b in scene.bodies)
    return np.array([r.obstacle_forces[k] for r in history])
