"""Strength reduction: the reduced materials and the bracketing of the
factor of safety (with stand-in runs whose collapse factor is known)."""
import numpy as np
import pytest

from skfem_mpm import (DruckerPrager, LinearElastic, MohrCoulomb,
                       NewtonDivergenceError, PointsOutsideGridError,
                       PrescribedMotionError,
                       SingularSystemError, VonMises)
from skfem_mpm.errors import InvalidInputError
from skfem_mpm.solve.strength_reduction import (reduce_strength,
                                                strength_reduction)


def test_reduced_strength():
    vm = reduce_strength(VonMises(1e4, .3, 120.), 1.5)
    assert vm.yield_stress == 80. and vm.E == 1e4
    for soil in (MohrCoulomb(1e4, .3, cohesion=9., friction_angle=35.,
                             dilation_angle=10.),
                 DruckerPrager(1e4, .3, cohesion=9., friction_angle=35.,
                               dilation_angle=35., fit="plane_strain")):
        weak = reduce_strength(soil, 1.8)
        assert weak.cohesion == pytest.approx(5., rel=1e-15)
        for name in ("friction_angle", "dilation_angle"):
            assert np.tan(np.radians(getattr(weak, name))) == pytest.approx(
                np.tan(np.radians(getattr(soil, name))) / 1.8, rel=1e-14)
        assert type(weak) is type(soil) and weak.E == soil.E
    # associated flow stays associated
    assert reduce_strength(MohrCoulomb(1e4, .3, cohesion=1., friction_angle=
                                       30., dilation_angle=30.), 2.) \
        .dilation_angle == reduce_strength(MohrCoulomb(
            1e4, .3, cohesion=1., friction_angle=30.), 2.).friction_angle
    for material, factor, words in [
            (LinearElastic(1e4, .3), 2., "von Mises, Mohr-Coulomb"),
            (VonMises(1e4, .3, 1.), 0., "positive"),
            (VonMises(1e4, .3, 1.), np.nan, "positive"),
            (DruckerPrager(1e4, .3, cohesion=1., friction_angle=20.,
                           dilation_angle=20., hardening=5.), 2.,
             "hardening")]:
        with pytest.raises(InvalidInputError, match=words):
            reduce_strength(material, factor)


def collapsing_at(limit, error=NewtonDivergenceError):
    def run(factor):
        if factor > limit:
            raise error("no equilibrium at {}".format(factor))
        return "result at {}".format(factor)
    return run


@pytest.mark.parametrize("limit", [1.0001, 1.37, 1.99, 3.3, 17.])
def test_bisection_brackets_the_collapse(limit):
    s = strength_reduction(collapsing_at(limit), tolerance=1e-3)
    assert s.converged <= limit < s.failed
    assert s.failed - s.converged <= 1e-3 * s.converged
    assert abs(s.factor - limit) <= 1e-3 * limit
    assert s.result == "result at {}".format(s.converged)
    assert all(ok == (f <= limit) for f, ok in s.trials)


@pytest.mark.parametrize("error", [SingularSystemError,
                                   PointsOutsideGridError])
def test_a_mechanism_or_a_slide_out_of_the_grid_is_collapse_too(error):
    s = strength_reduction(collapsing_at(1.5, error), 1., 2., 1e-2)
    assert s.converged <= 1.5 < s.failed


def test_refusals():
    with pytest.raises(InvalidInputError, match="below it"):
        strength_reduction(collapsing_at(.9))
    with pytest.raises(InvalidInputError, match="nothing collapses"):
        strength_reduction(collapsing_at(np.inf))
    with pytest.raises(PrescribedMotionError):       # the caller's error
        strength_reduction(collapsing_at(1.5, PrescribedMotionError))
    with pytest.raises(InvalidInputError, match="0 < low < high"):
        strength_reduction(collapsing_at(1.5), low=2., high=1.)


def test_reduced_angles_below_a_degree_are_not_taken_for_radians():
    """A friction angle of 0.52 given by a user is refused as radians; the
    same angle reached by strength reduction (30 degrees at a factor of 64:
    atan(tan 30 / 64) = 0.517 degrees) is not."""
    from skfem_mpm import InvalidMaterialError, MohrCoulomb, reduce_strength
    soil = MohrCoulomb(1e4, .3, cohesion=10., friction_angle=30.,
                       dilation_angle=30.)
    weak = reduce_strength(soil, 64.)
    expected = np.degrees(np.arctan(np.tan(np.radians(30.)) / 64.))
    assert weak.friction_angle == pytest.approx(expected, rel=1e-12)
    assert 0. < weak.friction_angle < 1.
    with pytest.raises(InvalidMaterialError, match="looks like radians"):
        MohrCoulomb(1e4, .3, cohesion=10., friction_angle=.52)
