"""skfem-mpm: the implicit Material Point Method as a scikit-fem plugin.

Material points replace Gauss points as a moving quadrature: scikit-fem
assembles forms on a :class:`MaterialPointBasis` and applies boundary
conditions; this package locates points, moves them and keeps their state.

The public names are imported when one of them is first used (PEP 562):
``import skfem_mpm`` itself imports neither numpy nor scikit-fem, so the
``skfem-mpm`` command (:mod:`skfem_mpm.__main__`) handles a Ctrl-C from
its first moment.

"""
import importlib.util

__version__ = "0.1.0"

__all__ = [
    "GridTerm", "Options", "NewtonOptions", "Stabilisation", "Resume",
    "Prescribed", "BodyForce",
    "MaterialPointBasis", "MaterialPoints", "seed_points", "seed_gauss_points",
    "concatenate_points", "select_points",
    "locate_points", "point_locator", "MPMError", "InvalidInputError",
    "InvalidMaterialError", "PointsOutsideGridError", "SingularSystemError", "SingularTangentError",
    "UnsupportedElementError", "LinearElastic", "solve_mpm", "Result",
    "StepRecord", "VonMises", "solve_finite", "ConvergenceError",
    "NewtonDivergenceError", "InversionError", "simulate", "solve_fe",
    "Traction", "Pressure", "GridLoad", "side_points", "NumericalError", "GridMotionError",
    "PrescribedMotionError", "StepFailedError", "DruckerPrager",
    "MohrCoulomb", "ModifiedCamClay", "geostatic_stress", "initial_stress",
    "RigidBody",
    "reduce_strength", "strength_reduction", "Dynamics", "Newmark",
    "GeneralizedAlpha", "material_point_bases", "Obstacle", "ContactError",
    "StepTooLongError", "HeldSupportError", "UnsettledContactError",
    "Contact", "MaterialOutputError", "MaterialProtocolError",
    "NonFiniteMaterialError", "MaterialRaisedError", "GridTermError",
    "GridTermProtocolError", "NonFiniteGridTermError",
]


def _public() -> dict:
    """The public names, imported."""
    from .quadrature.basis import MaterialPointBasis, material_point_bases
    from .errors import (ContactError, ConvergenceError, GridMotionError,
                         InvalidInputError, InvalidMaterialError,
                         InversionError, MPMError, NewtonDivergenceError,
                         MaterialOutputError, MaterialProtocolError,
                         NonFiniteMaterialError, MaterialRaisedError,
                         GridTermError, GridTermProtocolError,
                         NonFiniteGridTermError,
                         NumericalError, PointsOutsideGridError,
                         PrescribedMotionError, SingularSystemError,
                         SingularTangentError, StepFailedError,
                         StepTooLongError, HeldSupportError,
                         UnsettledContactError,
                         UnsupportedElementError)
    from .quadrature.locate import locate_points, point_locator

    from .mechanics.materials import LinearElastic, VonMises
    from .mechanics.soils import DruckerPrager, MohrCoulomb
    from .mechanics.cam_clay import ModifiedCamClay
    from .mechanics.geostatic import geostatic_stress
    from .mechanics.initial_stress import initial_stress
    from .quadrature.points import (MaterialPoints, concatenate_points,
                                    seed_gauss_points, seed_points,
                                    select_points)
    from .protocols import GridTerm
    from .solve.core import simulate
    from .solve.newton import NewtonOptions
    from .solve.options import BodyForce, Options, Prescribed, Resume
    from .stabilisation.settings import Stabilisation
    from .solve.dynamics import Dynamics, GeneralizedAlpha, Newmark
    from .solve.fe import solve_fe
    from .solve.finite import solve_finite
    from .solve.loads import GridLoad, Pressure, Traction, side_points
    from .solve.results import Result, StepRecord
    from .solve.obstacles import Obstacle
    from .solve.body_contact import Contact
    from .solve.rigid import RigidBody
    from .solve.small import solve_mpm
    from .solve.strength_reduction import reduce_strength, strength_reduction
    return {name: value for name, value in locals().items()
            if name in __all__}


def __getattr__(name: str):
    """A public name (all of them are imported at the first), or a
    subpackage or module of the package not imported yet."""
    if name in __all__:
        globals().update(_public())
        return globals()[name]
    if not name.startswith("_") and importlib.util.find_spec(
            "{}.{}".format(__name__, name)) is not None:
        return importlib.import_module("{}.{}".format(__name__, name))
    raise AttributeError("module {!r} has no attribute {!r}".format(
        __name__, name))


def __dir__() -> list:
    return sorted(set(globals()) | set(__all__))
