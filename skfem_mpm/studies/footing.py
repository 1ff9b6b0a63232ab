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

from ..scenes.footing import footing_pressure, soil_strength

__all__ = ["bearing_capacity_factor", "footing_error"]


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


def limit_pressure(scene) -> float:
    """``N_c c`` of a footing scene's soil (its first deformable body)."""
    soil = next(b for b in scene.bodies if b.rigid is None).material
    c, phi = soil_strength(soil)
    return bearing_capacity_factor(phi) * c


def footing_error(scene, forces: ndarray) -> float:
    """Relative error of the peak footing pressure against ``N_c c``."""
    pressure = footing_pressure(scene, forces)
    if pressure.size == 0:
        return float("nan")
    return float(abs(pressure.max() / limit_pressure(scene) - 1))
