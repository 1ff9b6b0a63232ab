"""Units of a scene's numbers: the one table output labels ask.

The solver takes the numbers of any consistent system and converts
nothing; a scene names the system its numbers are in (scene file:
top-level ``units``, :attr:`Scene.units <skfem_mpm.scenes.scene.Scene>`)
and every label of its output follows it: figure axes and colour bars,
``summary.json``'s ``units`` and its quantities' ``unit``, the report
printed, a study's tables.

========  ======  =====  ======  ===========  =======  ====  ======  ====
system    length  force  stress  unit weight  density  mass  energy  time
========  ======  =====  ======  ===========  =======  ====  ======  ====
``SI``    m       N      Pa      N/m^3        kg/m^3   kg    J       s
``kN-m``  m       kN     kPa     kN/m^3       t/m^3    t     kJ      s
========  ======  =====  ======  ===========  =======  ====  ======  ====

In 2D forces and energies are per metre of thickness (``N/m``, ``kJ/m``),
in 1D per square metre.  A ``kN-m`` scene gives E, cohesion, tractions
and stresses in kPa, ``gravity.body_force`` in kN/m^3, ``density`` in
t/m^3 (with ``acceleration`` in m/s^2).

>>> from skfem_mpm.scenes.units import unit
>>> unit("stress", "kN-m"), unit("force", "kN-m", dim=2)
('kPa', 'kN/m')
>>> unit("energy", "SI", dim=1)
'J/m^2'
"""
from ..errors import check_choice

__all__ = ["UNITS", "SYSTEMS", "SHARED", "unit", "shared_unit",
           "check_units"]

#: per system, the unit of each kind of quantity (forces and energies
#: of a 3D scene; :func:`unit` gives those of 1D and 2D)
UNITS = {
    "SI": {"length": "m", "time": "s", "force": "N", "stress": "Pa",
           "unit_weight": "N/m^3", "density": "kg/m^3", "mass": "kg",
           "energy": "J", "velocity": "m/s", "acceleration": "m/s^2",
           "angle": "rad", "dimensionless": "-"},
    "kN-m": {"length": "m", "time": "s", "force": "kN", "stress": "kPa",
             "unit_weight": "kN/m^3", "density": "t/m^3", "mass": "t",
             "energy": "kJ", "velocity": "m/s", "acceleration": "m/s^2",
             "angle": "rad", "dimensionless": "-"},
}
#: the systems a scene may name; the first is the default
SYSTEMS = tuple(UNITS)
#: the kinds every system gives in the same unit: labels of only these
#: (a figure's axes in m) need no system
SHARED = tuple(k for k in UNITS["SI"]
               if len({u[k] for u in UNITS.values()}) == 1)
#: kinds that a 2D scene gives per metre of thickness, a 1D per m^2
PER_THICKNESS = ("force", "energy")


def check_units(system: str) -> str:
    """``system`` if it names one of :data:`SYSTEMS`, else raise
    :class:`~skfem_mpm.errors.InvalidInputError`.

    >>> from skfem_mpm.scenes.units import check_units
    >>> check_units("kPa")
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: units must be one of \
('SI', 'kN-m'), got 'kPa'
    """
    check_choice("units", system, SYSTEMS)
    return system


def unit(kind: str, system: str = "SI", dim: int = 3) -> str:
    """The unit of a ``kind`` of quantity (a key of :data:`UNITS`) in the
    units ``system`` and a scene of dimension ``dim``.

    Parameters
    ----------
    kind
        ``"length"``, ``"force"``, ``"stress"``, ``"energy"``, ...
    system
        One of :data:`SYSTEMS`.
    dim
        The scene's dimension: forces and energies of a 2D scene are
        per metre of thickness, of a 1D scene per square metre.
    """
    text = UNITS[check_units(system)][kind]
    if kind in PER_THICKNESS and dim < 3:
        text += {1: "/m^2", 2: "/m"}[dim]
    return text


def shared_unit(kind: str) -> str:
    """The unit of a ``kind`` of quantity that every system gives alike
    (one of :data:`SHARED`: a label that needs no system), else raise
    :class:`ValueError`.

    >>> from skfem_mpm.scenes.units import shared_unit
    >>> shared_unit("length")
    'm'
    >>> shared_unit("stress")
    Traceback (most recent call last):
    ...
    ValueError: 'stress' differs between unit systems
    """
    if kind not in SHARED:
        raise ValueError("{!r} differs between unit systems".format(kind))
    return UNITS["SI"][kind]
