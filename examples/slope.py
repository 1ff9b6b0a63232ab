"""The factor of safety of a clay slope by strength reduction, against the
limit-equilibrium slip circle.

A 45-degree slope 10 m high (toe at x = 10 m, crest at x = 20 m) on a firm
base, ground level behind the crest to x = 35 m: undrained clay
(von Mises with ``c_u = yield_stress / sqrt(3)`` = 50 kPa, E = 20 MPa,
nu = 0.3, the mean dilatation against volumetric locking), unit weight
20 kN/m^3, base clamped, far side on rollers.  Grid h = H/16, 2 x 2 points
per cell, gravity in 8 load steps with up to 4 cut-backs (the recommended
setting), standard MPM in small strain.  The strength is divided by a
trial factor until the gravity can no longer be carried
(:func:`~skfem_mpm.solve.strength_reduction.strength_reduction`: a trial
collapses when its run fails or when it moves more than 5 times the run at
F = 1, a slope that slumped and found equilibrium again): the factor of
safety is 1.570 (bracket [1.5625, 1.578]), the same with 16 load steps
(judged by convergence alone: 1.602); the critical slip circle of limit
equilibrium (Fellenius' moment equilibrium, exact for phi = 0, searched
over centres and radii) gives 1.519 (+3.4%; h = H/8: 1.617,
docs/geomechanics.md).

Run ``python examples/slope.py [OUTDIR]`` for the mechanism.
"""
import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (NewtonOptions, Options, Stabilisation, VonMises,
                       seed_points, simulate)
from skfem_mpm.solve.strength_reduction import (reduce_strength,
                                                strength_reduction)

height, toe, length, unit_weight = 10., 10., 35., 20.
h = height / 16
mesh = MeshQuad.init_tensor(np.arange(0., length + 1e-9, h),
                            np.arange(0., 1.25 * height + 1e-9, h))


def ground(x):
    """Height of the ground surface (0 left of the toe)."""
    return np.clip(x - toe, 0., height)


points = seed_points(mesh, 2, region=lambda x: x[1] < ground(x[0]))
clay = VonMises(E=2e4, nu=.3, yield_stress=50. * np.sqrt(3.))


def supports(basis):
    return np.concatenate([
        basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
        basis.get_dofs(lambda x: np.isclose(x[0], length)).all("u^1")])


def run(factor):
    """Gravity on the slope with the strength divided by ``factor``, in 8
    load steps with up to 4 cut-backs: enough that a slope that stands
    converges (with 4 steps and none, the run at F = 1.55 failed though
    the slope stands up to 1.56)."""
    return simulate(mesh, ElementQuad1(), points,
                    reduce_strength(clay, factor), supports,
                    body_force=[0., -unit_weight], nsteps=8,
                    options=Options(NewtonOptions(max_cutbacks=4),
                                    Stabilisation(antilocking=True)))


safety = strength_reduction(run, low=1., high=2., tolerance=.01)


def visualize(outdir="."):
    from pathlib import Path
    from skfem_mpm.scenes.plot import (draw_plastic_zone, pyplot,
                                       save_figure)
    fig, ax = pyplot().subplots(figsize=(9, 3.8))
    draw_plastic_zone(fig, ax, safety.result.points, "Slope with its "
                      "strength divided by {:.3f} (factor of safety {:.3f}):"
                      "\nthe slip zone about to form".format(
                          safety.converged, safety.factor), size=3.)
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "slope.png")


if __name__ == "__main__":
    import sys
    print("factor of safety {:.4f} (bracket {:.4f} .. {:.4f}, {} runs)".format(
        safety.factor, safety.converged, safety.failed, len(safety.trials)))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
