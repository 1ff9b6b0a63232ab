"""Milliseconds per Newton iteration and phase of one checkout, for A/B
comparisons of two commits on a machine whose speed drifts.

The block of ``step_cost.py`` (``(2 ncells)^2`` points, standard MPM,
finite deformation, 3 load steps of 3 Newton iterations), best of
``reps`` runs per phase.  Run it alternately on two checkouts (e.g. a
``git worktree`` of the older commit)::

    python benchmarks/iteration_ab.py ROOT NCELLS REPS [NSTEPS]

ROOT is the checkout whose ``skfem_mpm`` is imported; NSTEPS load steps
(3 by default; 1: a run's fixed costs, the supports' check among them,
fall on its 3 iterations).  The run is
written with the keyword arguments every checkout takes (``keep_snapshots=``,
a deprecated alias since ``Options``), so that any two commits compare.
"""
import sys

root, ncells, reps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
nsteps = int(sys.argv[4]) if len(sys.argv) > 4 else 3
sys.path.insert(0, root)
sys.path.insert(0, root + "/benchmarks")
from step_cost import block  # noqa: E402
from skfem import ElementQuad1  # noqa: E402
from skfem_mpm import LinearElastic, simulate  # noqa: E402
mesh, points = block(ncells)
best = {}
for _ in range(reps):
    r = simulate(mesh, ElementQuad1(), points.copy(), LinearElastic(1e6, .3),
                 lambda b: b.get_dofs(lambda x: x[-1] == 0), body_force=[0, -1e4],
                 nsteps=nsteps, method="mpm", kinematics="finite",
                 keep_snapshots=False)
    its = r.counters["newton_iterations"]
    t = r.timings(); t["total"] = sum(t.values())
    for k, v in t.items():
        best[k] = min(best.get(k, 1e9), v / its * 1e3)
print(points.n, " ".join("{} {:.3f}".format(k, v) for k, v in best.items()), "ms/iteration")
