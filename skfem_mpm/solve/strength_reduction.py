"""The factor of safety of a slope (or any body under its loads) by
strength reduction.

The strength is divided by a trial factor ``F`` (the cohesion ``c``, the
friction ``tan(phi)``; the yield stress of von Mises) and the problem is
run; the factor of safety is the ``F`` at which the run stops converging:
no equilibrium exists with the reduced strength (Zienkiewicz, Humpheson
and Lewis, *Geotechnique* 25, 1975; Griffiths and Lane, *Geotechnique*
49, 1999).  The factor is bracketed and bisected: each trial is a whole
run, so its cost is that of a run times ``log2(bracket / tolerance)``.

Non-convergence is the criterion: the runs must be set up so that a
converging problem does converge (enough load steps, ``max_cutbacks``), and
the answer depends on them to the tolerance of the bisection.

"""
import logging
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..errors import ConvergenceError, InvalidInputError, \
    PointsOutsideGridError, PrescribedMotionError, SingularSystemError
from .results import Result

logger = logging.getLogger(__name__)

__all__ = ["reduce_strength", "strength_reduction", "SafetyFactor"]


def reduce_strength(material, factor: float):
    """The material with its strength divided by ``factor``: cohesion over
    ``factor`` and ``tan(phi)`` over ``factor`` for Mohr-Coulomb and
    Drucker-Prager (the dilation angle reduced likewise, so associated flow
    stays associated), the yield stress over ``factor`` for von Mises.

    Examples
    --------
    >>> from skfem_mpm import MohrCoulomb
    >>> soil = MohrCoulomb(1e4, .3, cohesion=10., friction_angle=30.,
    ...                    dilation_angle=30.)
    >>> weak = reduce_strength(soil, 2.)
    >>> weak.cohesion, round(float(np.tan(np.radians(weak.friction_angle))
    ...                           / np.tan(np.radians(30.))), 12)
    (5.0, 0.5)

    """
    from ..mechanics.materials import VonMises
    from ..mechanics.soils import DruckerPrager, MohrCoulomb
    if not (np.isfinite(factor) and factor > 0):
        raise InvalidInputError("the strength reduction factor must be "
                                "positive, got {!r}".format(factor))
    if isinstance(material, VonMises):           # perfectly plastic
        return replace(material, yield_stress=material.yield_stress / factor)
    if isinstance(material, (MohrCoulomb, DruckerPrager)):
        if isinstance(material, DruckerPrager) and material.hardening:
            raise InvalidInputError(
                "strength reduction of a hardening Drucker-Prager material "
                "is not offered (which cohesion would it reduce?)")

        def reduced(angle):
            return float(np.degrees(np.arctan(np.tan(np.radians(angle))
                                              / factor)))
        return replace(material, cohesion=material.cohesion / factor,
                       friction_angle=reduced(material.friction_angle),
                       dilation_angle=reduced(material.dilation_angle),
                       radians_refused=False)
    raise InvalidInputError(
        "strength reduction is offered for von Mises, Mohr-Coulomb and "
        "Drucker-Prager materials, got {}".format(type(material).__name__))


@dataclass
class SafetyFactor:
    """The factor of safety, bracketed.

    Attributes
    ----------
    factor
        The middle of the bracket.
    converged, failed
        The largest factor whose run converged and the smallest whose run
        did not.
    trials
        ``(factor, converged)`` of every run, in order.
    result
        The run at ``converged`` (its displacements show the mechanism
        about to form).
    """
    factor: float
    converged: float
    failed: float
    trials: list
    result: Result


def strength_reduction(run: Callable, low: float = 1., high: float = 2.,
                       tolerance: float = .01) -> SafetyFactor:
    """Bracket and bisect the factor of safety.

    Parameters
    ----------
    run
        ``run(factor) -> Result``: the problem with its strength divided by
        ``factor`` (e.g. with :func:`reduce_strength`).  A run that does not
        converge (:class:`~skfem_mpm.errors.ConvergenceError` other than a
        prescribed-motion error), whose stiffness is singular (a mechanism)
        or whose points slide out of the grid is a failure at that factor;
        any other error is the caller's and propagates.
    low, high
        The first bracket: ``low`` must converge; ``high`` is doubled (up
        to five times) until its run fails.
    tolerance
        Relative width of the final bracket.

    Raises
    ------
    InvalidInputError
        If the run at ``low`` already fails (the factor of safety is below
        ``low``: the message says so, with the failure) or none up to
        ``high * 32`` does.
    """
    if not (0 < low < high) or not (0 < tolerance < 1):
        raise InvalidInputError(
            "strength_reduction needs 0 < low < high and 0 < tolerance < 1, "
            "got low {!r}, high {!r}, tolerance {!r}".format(low, high,
                                                             tolerance))
    trials = []

    def attempt(factor):
        try:
            result = run(factor)
        except PrescribedMotionError:
            raise
        except (ConvergenceError, SingularSystemError,
                PointsOutsideGridError) as err:
            logger.info("strength reduction factor %.4f: fails (%s)",
                        factor, type(err).__name__)
            trials.append((factor, False))
            return None, err
        logger.info("strength reduction factor %.4f: converges", factor)
        trials.append((factor, True))
        return result, None

    result, err = attempt(low)
    if result is None:
        raise InvalidInputError(
            "the run fails already at the strength reduction factor {}: the "
            "factor of safety is below it (or the run cannot converge: {}: "
            "{})".format(low, type(err).__name__, err)) from err
    for _ in range(6):
        trial, _ = attempt(high)
        if trial is None:
            break
        low, result, high = high, trial, 2 * high
    else:
        raise InvalidInputError("no run failed up to the strength reduction "
                                "factor {}: nothing collapses".format(low))
    while high - low > tolerance * low:
        middle = .5 * (low + high)
        trial, _ = attempt(middle)
        if trial is None:
            high = middle
        else:
            low, result = middle, trial
    return SafetyFactor(.5 * (low + high), low, high, trials, result)
