"""The stabilisations a run asks for, as one validated object."""
import logging
from dataclasses import dataclass
from typing import Sequence, Union

import numpy as np

from ..errors import InvalidInputError
from ..spelling import setting

__all__ = ["Stabilisation", "warn_volumetric_locking"]

logger = logging.getLogger(__name__)

#: Poisson's ratio from which a body without anti-locking is warned of
#: volumetric locking (a plane-strain cantilever at 0.49: 0.43 of beam
#: theory with FE, MPM and cpGIMP; a von Mises punch 1.5 times Prandtl's)
LOCKING_NU = .49
#: Poisson's ratio from which the additive mean dilatation in finite
#: deformation is warned of its step-size dependence
ADDITIVE_NU = .499
#: the setting the locking warnings advise, for Python and scene files
ANTILOCKING = setting("antilocking", True)


@dataclass(frozen=True)
class Stabilisation:
    """Stabilisations of a run; validated on creation.

    Parameters
    ----------
    ghost
        Ghost-penalty factor for partially filled cells, those the
        points fill to less than half
        (:data:`~skfem_mpm.stabilisation.ghost.CUT_FILL`: a body whose
        cells are all at least half full gets no penalty, whatever the
        factor; trial 88's block with its top row exactly half full)
        (:mod:`skfem_mpm.stabilisation.ghost`, e.g. 0.1); 0: none;
        ``"auto"`` (default): none, but where points move a load step
        that fails in finite deformation, with contacts between bodies
        on B-splines, or with GIMP's or B-splines' obstacle corners that
        hold the material (friction, rough, tied), or on zero-energy modes
        that leave the tangent singular or stall Newton (each once the
        stabilised tangent has failed too), or that moves free grid nodes
        orders of magnitude more than any point in small strain (a node
        supported by a sliver of material,
        :class:`~skfem_mpm.errors.GridMotionError`), switches the default
        penalty (0.1; 1e-3 in small strain unless GIMP bodies are in
        contact:
        :data:`~skfem_mpm.solve.core.SMALL_STRAIN_GHOST`) on for the rest
        of the run (a bending body leaves
        nodes a sliver of support and Newton cycles without it; runs that
        converge without it are not changed); on from the start with
        uGIMP and cpGIMP where bodies are in contact (each body's domains
        reach a sliver of the cells across an interface, on its own
        field); on from a step whose points' domains reach past a
        support or into a cell inside an obstacle (material pressed
        against a held grid line or an obstacle wall, uGIMP and cpGIMP
        in small strain:
        :func:`~skfem_mpm.stabilisation.ghost.faces_crossed_past_supports`);
        ``counters["ghost_from_step"]`` says from which step.
    antilocking
        Mean dilatation (B-bar, :mod:`skfem_mpm.stabilisation.volumetric`)
        against volumetric locking, every method: the average over the
        points of each cell (with GIMP over those whose centre lies in it,
        Coombs et al. 2018), additive on the increment's gradient.
        ``"fbar"``: finite deformation with points that move (not
        ``"fem"``; refused otherwise) takes F-bar on each step's increment
        instead, every point of a cell changing its volume by the cell's
        ratio (:mod:`skfem_mpm.stabilisation.fbar`): for nu near 0.5,
        where the additive average leaves pressures oscillating inside
        cells (a Cook's membrane at nu = 0.4999: 10 steps uncut, 111
        iterations, against 5 cut back and 528); compiled passes too
        (:mod:`skfem_mpm.kernels.fbar`).
        Refused on higher-order Lagrange cells (Q2) with points that move
        and a plastic material (a footing came out 17-26% under Prandtl's
        limit load: :func:`~skfem_mpm.solve.core.
        check_higher_order_antilocking`).
    extended_splines
        Extended B-splines (the B-spline methods, quadratic and cubic;
        Höllig, Reif and Wipper 2001): a spline without a knot span filled
        by material in its support is no degree of freedom but the
        extrapolation of the nearest inner ones
        (:meth:`~skfem_mpm.methods.bspline.QuadraticBSpline.extension`), so
        no node is held by a sliver and none drops out of a step as the
        material moves off it: a bending beam converges without the ghost
        penalty, a footing's pressure has no jump where the surface leaves
        a row of nodes.  Refused with other methods, with contacts
        between bodies and with a ghost penalty (``ghost`` a number: it
        is assembled on the grid's nodes, which the extension folds, and
        moved a falling block's points apart); ``ghost="auto"`` then
        holds none in reserve.

    >>> from skfem_mpm import Stabilisation
    >>> Stabilisation(ghost=.1).antilocking
    False
    >>> Stabilisation(ghost=-1)
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: ghost must be 'auto' or a finite number >= 0, got -1
    """
    ghost: Union[str, float] = "auto"
    antilocking: Union[bool, str] = False
    extended_splines: bool = False

    def __post_init__(self):
        ghost = self.ghost
        if not (isinstance(ghost, str) and ghost == "auto") and (
                isinstance(ghost, (bool, np.bool_)) or not (
                    isinstance(ghost, (int, float, np.number)) and ghost >= 0
                    and np.isfinite(ghost))):
            raise InvalidInputError("ghost must be 'auto' or a finite number "
                                    ">= 0, got {!r}".format(ghost))
        if not (isinstance(self.antilocking, str)
                and self.antilocking == "fbar"
                or isinstance(self.antilocking, (bool, np.bool_))):
            raise InvalidInputError("antilocking must be True, False or "
                                    "'fbar', got {!r}".format(
                                        self.antilocking))
        for name in ("extended_splines",):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise InvalidInputError("{} must be True or False, got "
                                        "{!r}".format(name,
                                                      getattr(self, name)))

    def ghost_factor(self) -> float:
        """The penalty factor from the start (0 for ``"auto"``)."""
        return 0. if isinstance(self.ghost, str) else float(self.ghost)

    def ghost_in_reserve(self, method: str) -> bool:
        """``ghost="auto"`` holds the default penalty in reserve where
        points move (not ``"fem"``) and the splines are not extended (the
        extension holds what the penalty would): switched on for the rest
        of the run by a step that fails in finite deformation, or that
        moves grid nodes absurdly in small strain."""
        return isinstance(self.ghost, str) and method != "fem" \
            and not self.extended_splines


def warn_volumetric_locking(materials: Sequence, antilocking,
                            kinematics: str, method: str, dim: int,
                            higher_order: bool = False) -> None:
    """Log a warning where a body's Poisson's ratio (``nu`` of its
    material, where it has one) is near 0.5 or its plastic flow keeps the
    volume (``isochoric_flow``: von Mises, a soil without dilation; in 2D
    and 3D) on bilinear or trilinear cells (``higher_order`` ones lock
    little: a Q2 cantilever at nu = 0.4999 bent 0.95 and 0.97 of beam
    theory two and four cells deep, MPM's footing on Q2 came 6.9% above
    Prandtl's load; and they refuse anti-locking with plasticity) and
    the run's anti-locking leaves it stiff: none from
    :data:`LOCKING_NU` (a user trial's plane-strain cantilever at nu =
    0.4999 deflected 0.019 of beam theory, a strip punch reached 13 times
    Prandtl's load; a Tresca strip footing at nu = 0.3 carried 1.4 times
    it, 7.2 c where anti-locking stops at 5.2 c; each converged without a
    word), or the additive mean dilatation in finite deformation from
    :data:`ADDITIVE_NU`, whose answer depends on the step size there (the
    cantilever at nu = 0.4999, 10 steps: 0.91 of the elastica with FE and
    cpGIMP, 0.84 with B-splines; 40 steps: FE 0.997).

    The isochoric flow is warned of at the start, before anything yields,
    so for every such material, whatever the problem: its words say it
    is a caution for collapse loads, which a run that stays elastic (a
    level geostatic sand, trial 94) can pass by.  Warning only once the
    material flows would need the step loop and come mid-run, after the
    choice of stabilisation is made."""
    nus = [getattr(m, "nu", None) for m in materials]
    nu = max((float(v) for v in nus if v is not None), default=0.)
    isochoric = dim > 1 and any(
        getattr(m, "plastic", False) and getattr(m, "isochoric_flow", False)
        for m in materials)
    fbar = " (or 'fbar' in finite deformation)" if kinematics == "finite" and \
        method != "fem" else ""
    if antilocking is False and nu >= LOCKING_NU and not higher_order:
        logger.warning(
            "nu = %g without anti-locking: the cells lock, so displacements "
            "come out small and limit loads high, with every step converged "
            "(a cantilever at nu = 0.4999 bent 0.019 of beam theory); use "
            "mean dilatation%s: %s", nu, fbar, ANTILOCKING)
    elif antilocking is False and isochoric and not higher_order:
        logger.warning(
            "a plastic flow that keeps the volume (%s) without "
            "anti-locking, a caution for collapse: where the material "
            "flows the cells lock, so a limit load or a factor of safety "
            "comes out high, with every step converged (a Tresca strip "
            "footing carried 1.4 times Prandtl's load, 7.2 c); a run that "
            "stays elastic (a geostatic start) is not affected; for "
            "collapse use mean dilatation%s: %s",
            ", ".join(sorted({type(m).__name__ for m in materials if getattr(
                m, "isochoric_flow", False)})), fbar, ANTILOCKING)
    elif antilocking is True and kinematics == "finite" and \
            nu >= ADDITIVE_NU:
        logger.warning(
            "nu = %g with the additive mean dilatation in finite "
            "deformation: each step's second-order volume change is not "
            "averaged, so the answer stiffens with the step size (a "
            "cantilever at nu = 0.4999: 0.84-0.91 of the elastica in 10 "
            "steps, FE 0.997 in 40); %s", nu,
            "take more, smaller steps" if method == "fem" else
            "use F-bar on the increment: " + setting("antilocking",
                                                     "fbar"))
