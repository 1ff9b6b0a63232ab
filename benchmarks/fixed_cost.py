"""The fixed cost of a load step, piece by piece, timed inside real runs.

The block of ``step_cost.py`` (standard MPM, finite deformation,
``LinearElastic(1e6, 0.3)``, one load step of 3 Newton iterations, the
default kernels), run ``REPS`` times after 5 warm-up runs; each piece's
microseconds a run (the sum of its calls), the least over the runs.  A
timer wraps each piece where it is looked up (the step problem's
module, the method's class, ...), so a piece is timed with the caches
and branch predictors of a real run, not of a loop of its own: at 56
points the pieces take 2-3 times longer in a run than in ``timeit``.
``phases-nonsolve`` is the run's own timings (locate, assemble, update
and check) for comparison with ``iteration_ab.py`` (divide by the 3
iterations).  Pieces nest: ``operator`` holds ``basis``,
``PointOperator`` and a ``locate``; ``StepProblem`` holds ``operator``,
``check_held``, ``external``; ``residual`` holds ``kin.response`` (which
holds the first step's ``kernel_layout``); ``commit`` holds ``op.values``
and the next step's ``locate``.

    python benchmarks/fixed_cost.py ROOT [NCELLS] [REPS] [KINEMATICS]

ROOT is the checkout whose ``skfem_mpm`` is imported (an A/B of two
commits: run it on each in turn).  A piece a checkout does not have is
left out.  KINEMATICS: ``finite`` (the default) or ``small`` (the
block's small-strain run, elastic as well).
"""
import collections
import sys
import time
import warnings

root = sys.argv[1]
ncells = int(sys.argv[2]) if len(sys.argv) > 2 else 4
reps = int(sys.argv[3]) if len(sys.argv) > 3 else 60
kin = sys.argv[4] if len(sys.argv) > 4 else "finite"
sys.path.insert(0, root)
sys.path.insert(0, root + "/benchmarks")
import numpy as np  # noqa: E402
from skfem import ElementQuad1  # noqa: E402
from step_cost import block  # noqa: E402
from skfem_mpm import LinearElastic, Options, simulate  # noqa: E402
from skfem_mpm.mechanics import kinematics  # noqa: E402
from skfem_mpm.methods import method, operators  # noqa: E402
from skfem_mpm.quadrature import basis  # noqa: E402
from skfem_mpm.solve import core, loads, problem  # noqa: E402
from skfem_mpm.stabilisation import ghost  # noqa: E402

SECONDS = collections.defaultdict(float)


def timed(owner, name: str, label: str):
    """``owner.name`` replaced by itself under a timer adding to
    ``SECONDS[label]``."""
    piece = getattr(owner, name, None)
    if piece is None:
        return

    def wrapped(*args, **kwargs):
        tic = time.perf_counter()
        try:
            return piece(*args, **kwargs)
        finally:
            SECONDS[label] += time.perf_counter() - tic
    setattr(owner, name, wrapped)


for owner, name, label in (
        (core, "build_run", "build_run"),
        (method.PointMethod, "operator", "operator"),
        (method.PointMethod, "locate", "locate"),
        (basis.MaterialPointBasis, "__init__", "basis"),
        (operators.PointOperator, "__init__", "PointOperator"),
        (problem, "held_motion", "held_motion"),
        (problem, "check_held", "check_held"),
        (problem, "free_dofs", "free_dofs"),
        (loads.ExternalLoads, "external", "external"),
        (ghost.GhostStabilisation, "begin_step", "ghost.begin_step"),
        (problem.StepProblem, "__init__", "StepProblem"),
        (operators.PointOperator, "kernel_layout", "kernel_layout"),
        (kinematics.FiniteStrain, "response", "kin.response"),
        (kinematics.SmallStrain, "response", "kin.response"),
        (problem.StepProblem, "residual", "residual"),
        (problem.StepProblem, "tangent", "tangent"),
        (problem.StepProblem, "solve", "solve"),
        (operators.PointOperator, "values", "op.values"),
        (problem.StepProblem, "commit", "commit")):
    timed(owner, name, label)

mesh, points = block(ncells)
runs = []
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    for r in range(reps + 5):
        SECONDS.clear()
        tic = time.perf_counter()
        res = simulate(mesh, ElementQuad1(), points.copy(),
                       LinearElastic(1e6, .3),
                       lambda b: b.get_dofs(lambda x: x[-1] == 0),
                       body_force=[0, -1e4], nsteps=1, method="mpm",
                       kinematics=kin,
                       options=Options(keep_snapshots=False))
        SECONDS["simulate"] = time.perf_counter() - tic
        SECONDS["phases-nonsolve"] = sum(
            v for k, v in res.timings().items() if k != "solve")
        if r >= 5:
            runs.append(dict(SECONDS))
print(points.n, "points, us a run (least of {}):".format(reps), " ".join(
    "{} {:.0f}".format(k, min(run.get(k, np.inf) for run in runs) * 1e6)
    for k in runs[0]))
