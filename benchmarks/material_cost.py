"""Cost of each material model: the return map alone, and a load step of
the core per point and Newton iteration.

1. ``principal_update`` on 1e5 trial states, half of them yielding (best of
   5): microseconds per point.
2. A block of 1e5 points (2D plane strain, 2x2 points per cell) in
   simple shear (u_x = 0.004 y on its boundary nodes, u_y = 0) under its
   weight, past yield in 2 load steps, small strain and finite deformation, standard MPM, SuperLU: microseconds per
   point and Newton iteration outside the linear solve (stress update,
   assembly, checks), and the Newton iterations.  Not for the
   non-associated models (no dilation): in this isochoric shear already at
   1600 points Newton fails after every cut-back (Drucker-Prager at 24% of
   the shear, Mohr-Coulomb at 15%; the associated ones take 9 iterations a
   step): an open problem of the soil models.

Run: ``python benchmarks/material_cost.py`` (a few minutes on 2 cores).
"""
import time

import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (DruckerPrager, LinearElastic, MohrCoulomb, VonMises,
                       seed_points, simulate)

E, NU, SHEAR = 1e4, .3, .004     # the shear stays below a cell at 1e5 points
MODELS = {
    "linear elastic": LinearElastic(E, NU),
    "von Mises": VonMises(E, NU, yield_stress=5.),
    "Drucker-Prager": DruckerPrager(E, NU, cohesion=2., friction_angle=30.,
                                    dilation_angle=30.),
    "DP non-assoc.": DruckerPrager(E, NU, cohesion=2., friction_angle=30.),
    "Mohr-Coulomb": MohrCoulomb(E, NU, cohesion=2., friction_angle=30.,
                                dilation_angle=30.),
    "MC non-assoc.": MohrCoulomb(E, NU, cohesion=2., friction_angle=30.),
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
    """The sheared block: (points, non-solve us/point/iteration, mean
    Newton iterations per step, s per step)."""
    h = 1. / cells
    axis = np.linspace(-2 * h, 1. + 2 * h, cells + 5)
    mesh = MeshQuad.init_tensor(axis, axis)
    points = seed_points(mesh, 2, region=lambda x: (x[0] > 0) & (x[0] < 1)
                         & (x[1] > 0) & (x[1] < 1))
    x, y = mesh.p
    inside = (x > -1e-9) & (x < 1 + 1e-9) & (y > -1e-9) & (y < 1 + 1e-9)
    edge = np.flatnonzero(inside & (np.isclose(x, 0.) | np.isclose(x, 1.)
                                    | np.isclose(y, 0.) | np.isclose(y, 1.)))

    def shear(b, f_old, f_new):           # simple shear of the boundary
        dofs = b.nodal_dofs[:, edge]
        return dofs.ravel(), np.concatenate([
            SHEAR * y[edge] * (f_new - f_old), np.zeros(edge.size)])
    tic = time.perf_counter()
    res = simulate(mesh, ElementQuad1(), points, model, [],
                   body_force=[0., -20.], prescribed=shear, nsteps=2,
                   kinematics=kinematics, keep_snapshots=False)
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
    for name, model in MODELS.items():
        per_point, share = return_map_cost(model)
        if "non-assoc." in name:        # the step: see the module docstring
            print("{:>16} {:>12.3f} {:>8.0%} |".format(name, per_point,
                                                       share), flush=True)
            continue
        for kinematics in ("small", "finite"):
            n, outside, iterations, seconds = step_cost(model, kinematics)
            print("{:>16} {:>12.3f} {:>8.0%} | {:>9} {:>14.2f} {:>8.1f} "
                  "{:>8.2f}".format(name, per_point, share, kinematics,
                                    outside, iterations, seconds), flush=True)
    print("points per block:", n)


if __name__ == "__main__":
    main()
