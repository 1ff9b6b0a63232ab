"""Cost of each material model: the return map alone, and a load step of
the core per point and Newton iteration.

1. ``principal_update`` on 1e5 trial states, half of them yielding (best of
   5): microseconds per point.
2. A block of 1e5 points (2D plane strain, 2x2 points per cell) in an
   oedometer (rollers on the base and the sides) under a weight of 200 per
   unit volume in 2 load steps: most points yield (the deviatoric stress
   of confined compression passes the strengths), small strain and finite
   deformation, standard MPM, SuperLU: microseconds per point and Newton
   iteration outside the linear solve (stress update, assembly, checks),
   and the Newton iterations per step.  Modified Cam clay starts at its
   reference pressure (its stress at zero strain), which a free surface
   cannot carry: its block, normally consolidated, is closed by a lid of
   grid nodes pushed down by 0.4 of a cell instead of the weight (grid
   nodes are refused beyond a cell).

Run: ``python benchmarks/material_cost.py`` (a few minutes on 2 cores).
"""
import time

import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (DruckerPrager, LinearElastic, ModifiedCamClay,
                       MohrCoulomb, Options, Prescribed, VonMises,
                       seed_points, simulate)

E, NU, WEIGHT = 1e4, .3, 200.
MODELS = {
    "linear elastic": LinearElastic(E, NU),
    "von Mises": VonMises(E, NU, yield_stress=5.),
    "Drucker-Prager": DruckerPrager(E, NU, cohesion=2., friction_angle=10.,
                                    dilation_angle=10.),
    "DP non-assoc.": DruckerPrager(E, NU, cohesion=2., friction_angle=10.),
    "Mohr-Coulomb": MohrCoulomb(E, NU, cohesion=2., friction_angle=10.,
                                dilation_angle=10.),
    "MC non-assoc.": MohrCoulomb(E, NU, cohesion=2., friction_angle=10.),
    "Cam clay (lid)": ModifiedCamClay(
        kappa=.02, lambda_=.2, M=1.2, shear_modulus=2e3,
        reference_pressure=100., preconsolidation_pressure=100.),
}


def return_map_cost(model, n=100_000):
    """Best of 5 of one ``principal_update`` on n trial states: us/point
    and the share that yielded."""
    rng = np.random.default_rng(0)
    eps = rng.normal(0., 2e-3, (3, n)) - 1e-3
    state = {name: np.zeros(n) for name in model.state_variables}
    best = np.inf
    for _ in range(5):
        tic = time.perf_counter()
        yielded = model.principal_update(eps, state)[3]
        best = min(best, time.perf_counter() - tic)
    return best / n * 1e6, yielded.mean()


def step_cost(model, kinematics, cells=158):
    """The confined block under its weight: (points, non-solve
    us/point/iteration, mean Newton iterations per step, s per step)."""
    mesh = MeshQuad.init_tensor(np.linspace(0., 1., cells + 1),
                                np.linspace(0., 1. + 2. / cells, cells + 3))
    points = seed_points(mesh, 2, region=lambda x: x[1] < 1.)

    def supports(b):                       # rollers: an oedometer
        return np.concatenate([
            b.get_dofs(lambda x: x[1] == 0).all("u^2"),
            b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 1)).all("u^1")])
    load = dict(body_force=[0., -WEIGHT])
    if isinstance(model, ModifiedCamClay):    # a lid pushed 0.4 cell down
        lid = np.flatnonzero(np.isclose(mesh.p[1], 1.))
        load = dict(loads=[Prescribed(lambda b, f_old, f_new: (
            b.nodal_dofs[1, lid],
            np.full(lid.size, -.4 / cells * (f_new - f_old))))])
    tic = time.perf_counter()
    res = simulate(mesh, ElementQuad1(), points, model, supports, nsteps=2,
                   kinematics=kinematics,
                   options=Options(keep_snapshots=False), **load)
    seconds = time.perf_counter() - tic
    timings = res.timings()
    iterations = max(res.counters["newton_iterations"],
                     res.counters["linear_solves"])
    outside = sum(timings.values()) - timings["solve"]
    return (points.n, outside / points.n / iterations * 1e6,
            iterations / len(res.history), seconds / len(res.history))


def main():
    print("{:>16} {:>12} {:>8} | {:>9} {:>14} {:>8} {:>8}".format(
        "model", "map us/pt", "yielded", "kinematics", "non-solve us/pt/it",
        "iters", "s/step"))
    import sys
    chosen = sys.argv[1:] or list(MODELS)   # model names to run
    for name in chosen:
        model = MODELS[name]
        per_point, share = return_map_cost(model)
        for kinematics in ("small", "finite"):
            n, outside, iterations, seconds = step_cost(model, kinematics)
            print("{:>16} {:>12.3f} {:>8.0%} | {:>9} {:>14.2f} {:>8.1f} "
                  "{:>8.2f}".format(name, per_point, share, kinematics,
                                    outside, iterations, seconds), flush=True)
    print("points per block:", n)


if __name__ == "__main__":
    main()
