"""Bearing capacity of a strip footing on weightless soil: the reference of
footing scenes (``reference = "bearing_capacity"``).

A rigid strip footing on a weightless, cohesive-frictional half-space
(Mohr-Coulomb, cohesion ``c``, friction angle ``phi``, associated flow)
collapses at the pressure ``N_c c`` with the Prandtl-Reissner factor

.. math::

    N_q = e^{\\pi \\tan\\phi} \\tan^2(45^\\circ + \\phi / 2), \\qquad
    N_c = (N_q - 1) \\cot\\phi,

which tends to ``2 + pi`` as ``phi -> 0`` (Prandtl 1920, Reissner 1924;
e.g. Terzaghi, *Theoretical Soil Mechanics*, 1943, ch. VIII).  The
undrained (Tresca) limit is ``phi = 0`` with ``c = c_u``; in plane strain
von Mises with yield stress ``sigma_y`` is Tresca with
``c_u = sigma_y / sqrt(3)``, and Drucker-Prager with the plane-strain fit
(:func:`~skfem_mpm.mechanics.soils.drucker_prager_constants`) has the limit
loads of Mohr-Coulomb with its ``phi``.

"""
import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError

__all__ = ["bearing_capacity_factor", "soil_strength", "footing_pressure",
           "check_footing_scene", "footing_error"]


def bearing_capacity_factor(friction_angle: float) -> float:
    """Prandtl-Reissner ``N_c`` for a friction angle in degrees.

    Examples
    --------
    >>> from skfem_mpm.studies.footing import bearing_capacity_factor
    >>> round(bearing_capacity_factor(20.), 2), round(
    ...     bearing_capacity_factor(0.), 4)
    (14.83, 5.1416)

    """
    phi = np.radians(friction_angle)
    if phi == 0.:                         # the limit phi -> 0
        return float(2 + np.pi)
    nq = np.exp(np.pi * np.tan(phi)) * np.tan(np.pi / 4 + phi / 2) ** 2
    return float((nq - 1) / np.tan(phi))


def soil_strength(material) -> tuple:
    """``(c, phi)`` (phi in degrees) of a material in plane-strain limit
    analysis: von Mises (``c_u = sigma_y / sqrt(3)``, ``phi = 0``),
    Mohr-Coulomb, or Drucker-Prager with ``fit = "plane_strain"``; any other
    material is refused (its collapse load has no closed form here)."""
    from ..mechanics.materials import VonMises
    from ..mechanics.soils import DruckerPrager, MohrCoulomb
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
    if scene.gravity is not None and any(scene.gravity):
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
            "box (its width is the pressure's denominator)")
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


def footing_pressure(scene, forces: ndarray) -> ndarray:
    """The footing pressure per step (positive pushing down) from the
    rigid body's force per step ``forces`` (steps, 2): the downward force
    over the width of its region."""
    body = next(b for b in scene.bodies if b.rigid is not None)
    lo, hi = body.region[0]
    return -np.asarray(forces)[:, 1] / (hi - lo)


def footing_error(scene, forces: ndarray) -> float:
    """Relative error of the peak footing pressure against ``N_c c``."""
    soil = next(b for b in scene.bodies if b.rigid is None).material
    c, phi = soil_strength(soil)
    pressure = footing_pressure(scene, forces)
    if pressure.size == 0:
        return float("nan")
    return float(abs(pressure.max() / (bearing_capacity_factor(phi) * c)
                     - 1))
