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
loads of Mohr-Coulomb with its ``phi``.  What a footing scene must be for
this to hold, and the soil strength ``(c, phi)``, are checked with the
scene (:mod:`skfem_mpm.scenes.footing`).

"""
import numpy as np
from numpy import ndarray

from ..scenes.footing import scene_footing, soil_strength

__all__ = ["bearing_capacity_factor", "footing_pressure", "footing_forces",
           "footing_error"]


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


def footing_pressure(scene, forces: ndarray) -> ndarray:
    """The footing pressure per step (positive pushing down) from the
    footing's force per step ``forces`` (steps, 2; a rigid body's that
    holds its motion, or an obstacle's from the material,
    :func:`footing_forces`): the soil's push up on it over its width
    (:func:`~skfem_mpm.scenes.footing.scene_footing`)."""
    footing = scene_footing(scene)
    return footing.sign * np.asarray(forces)[:, 1] / footing.width


def footing_forces(scene, history) -> ndarray:
    """The footing's force per step of the records ``history`` (steps,
    2), as :func:`footing_pressure` reads it."""
    footing = scene_footing(scene)
    if footing.kind == "rigid_bodies":
        return np.array([r.rigid_forces[0] for r in history])
    k = footing.column - len(scene.supports) - sum(
        b.rigid is not None for b in scene.bodies)
    return np.array([r.obstacle_forces[k] for r in history])


def footing_error(scene, forces: ndarray) -> float:
    """Relative error of the peak footing pressure against ``N_c c``."""
    soil = next(b for b in scene.bodies if b.rigid is None).material
    c, phi = soil_strength(soil)
    pressure = footing_pressure(scene, forces)
    if pressure.size == 0:
        return float("nan")
    return float(abs(pressure.max() / (bearing_capacity_factor(phi) * c)
                     - 1))
