"""What a footing scene (``reference = "bearing_capacity"``) must be for
its collapse load to be ``N_c c``, checked with the scene before any work.

A rigid strip footing pushed into a weightless, cohesive-frictional soil
of associated flow, in plane strain: the closed form ``N_c`` and the error
against it are in :mod:`skfem_mpm.studies.footing`; here are the checks
and the soil's strength ``(c, phi)`` they and the closed form read.

"""
import numpy as np

from ..errors import InvalidInputError
from ..mechanics.materials import VonMises
from ..mechanics.soils import DruckerPrager, MohrCoulomb
from .regions import region_shape

__all__ = ["soil_strength", "check_footing_scene"]


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


def check_footing_scene(scene):
    """Refuse a scene whose bearing capacity is not ``N_c c``: it needs a
    2D grid, no gravity (weightless soil), one rigid body pushed down
    (along -y) whose box region's edges across the motion are grid lines
    inside the grid (the body drives whole cells: its contact width is
    that of its cells), and the other bodies of one soil with ``c > 0``."""
    if scene.grid.dim != 2:
        raise InvalidInputError("reference 'bearing_capacity' is for 2D "
                                "(plane-strain) scenes")
    weights = scene.body_forces()
    if weights is not None and weights.any():
        raise InvalidInputError(
            "reference 'bearing_capacity' is for weightless soil: the "
            "gravity adds the soil weight's share (N_gamma) to N_c c")
    rigid = [b for b in scene.bodies if b.rigid is not None]
    if len(rigid) != 1 or rigid[0].rigid[0] != 0. or rigid[0].rigid[1] >= 0:
        raise InvalidInputError(
            "reference 'bearing_capacity' needs one rigid body (the footing) "
            "pushed down, displacement [0, -s]")
    footing = rigid[0]
    if callable(footing.region):
        raise InvalidInputError(
            "reference 'bearing_capacity' needs the footing's region as a "
            "box, region = {{ x = [lo, hi], y = [lo, hi] }} (its width is "
            "the pressure's denominator), not a {}".format(
                region_shape(footing.region)))
    mesh, _ = scene.grid.build()
    lines = np.unique(mesh.p[0])
    for edge in footing.region[0]:
        if np.abs(lines - edge).min() > 1e-9 * (1 + np.abs(lines).max()):
            raise InvalidInputError(
                "reference 'bearing_capacity': the footing {!r} has its edge "
                "x = {} between grid lines (x from {} to {}): it drives the "
                "whole cells its points are in, so its width would not be "
                "its region's; put its edges on grid lines".format(
                    footing.name, edge, lines.min(), lines.max()))
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
