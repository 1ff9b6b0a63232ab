"""The seed's column under self weight with standard implicit MPM.

A column of height 50 (E = 1e6, nu = 0) is loaded by its own weight, ramped
to 800 per unit volume, and shortens by about 1.  With one load step MPM is
the finite element method with the material points as quadrature, and the
error measure (2.28) of Charlton (2018) falls at rate 1 as the grid is
refined.  With more load steps the points move, and the error stops
falling near 6.3e-3 (256 elements, 20 steps): the plateau of Figures 2.9
and 2.10 of Charlton (2018), Chapter 2 (the seed; docs/references.md),
which the seed puts down to grid crossing.  Its level is mostly not
grid crossing but the model: small strain with moving points and fixed
volumes is geometrically nonlinear (each step's strain is taken on the
moved points), so it converges to another column than the linear one
that (2.28) compares with: with this scheme ``sigma = -E ln(1 + rho0 b
(L0 - Y) / E)``, whose (2.28) is 6.5e-3.  uGIMP, which has no
grid-crossing oscillation, stops at 6.2e-3, MPM at 6.3e-3 (256
elements, 20 steps).  Grid crossing is what MPM adds to that: the
oscillating stress profile of Figure 2.9 (100 elements, 20 steps), and
with the default scheme below an error 2.6 times uGIMP's that grows
with the number of steps (3.1e-2 in 20 steps, 4.7e-2 in 80; uGIMP
1.22e-2 and 1.26e-2, towards that scheme's model, 1.28e-2;
docs/accuracy_vs_time.md).  (2.28) is read at the points' initial
heights (``column_error``).

Every step is solved as the seed's Algorithm 2.1 does, with the load
increment (``NewtonOptions(rhs="increment")``), not with the default
out-of-balance force (``rhs="residual"``), whose plateau lies 5 times
higher (3.1e-2 against 6.3e-3 at 256 elements, 20 steps: its model's
floor twice as high, MPM's grid crossing on top;
docs/accuracy_vs_time.md).  That scheme never corrects the out-of-balance
force, which grows with refinement: the points' stresses, which (2.28)
measures, are the scheme's, the grid's nodal forces are not in balance.
Its warning of that is printed once here, not for every run.

A rate is given only where the errors fall at every refinement and do not
level off (the study's judgement, ``not_falling`` and ``levelling_off``):
a slope fitted across the plateau is the rate of nothing.

Run ``python examples/column.py [OUTDIR]`` to write both figures as PNG.
"""
import logging

import numpy as np

from skfem_mpm import NewtonOptions, Options
from skfem_mpm.studies.column import column_error, run_column, vertical_stress
from skfem_mpm.studies.study import fitted_rate, levelling_off, not_falling

#: the seed's Algorithm 2.1: each step solves with the load increment
SEED_SCHEME = Options(keep_snapshots=False,
                      newton=NewtonOptions(rhs="increment"))


class _Imbalance(logging.Filter):
    """Keeps the out-of-balance warning of the increment scheme from the
    log (said once, below) and counts it."""
    count = 0

    def filter(self, record):
        if record.getMessage().startswith("rhs = 'increment'"):
            self.count += 1
            return False
        return True


def seed_run(nel, ppc, nsteps, dim=1):
    return run_column(nel, ppc, nsteps, dim=dim, options=SEED_SCHEME)


_core = logging.getLogger("skfem_mpm.solve.core")
_quiet = _Imbalance()
_core.addFilter(_quiet)
try:
    # Figure 2.9: stress profiles, 2 points per element
    profiles = {(nel, nsteps): seed_run(nel, 2, nsteps)
                for nel in (10, 100) for nsteps in (1, 2, 20)}

    # Figure 2.10: error against number of elements, 2-5 points per element
    nelems = 2 ** np.arange(0, 10)
    runs = {(nsteps, ppc): [seed_run(nel, ppc, nsteps) for nel in nelems]
            for nsteps in (1, 2, 20) for ppc in (2, 3, 4, 5)}

    # the same column as a 2D plane-strain strip one element wide
    one_d, two_d = seed_run(16, 2, 20), seed_run(16, 2, 20, dim=2)
finally:
    _core.removeFilter(_quiet)
errors = {key: np.array([column_error(r.points) for r in rs])
          for key, rs in runs.items()}
#: the largest out-of-balance force a run ended with, x the external force
imbalance = max(r.history[-1].residual for rs in runs.values() for r in rs)
left = two_d.points.x0[0] < two_d.points.x0[0].mean()
dim_difference = np.abs(
    np.sort(vertical_stress(one_d.points))
    - np.sort(vertical_stress(two_d.points)[left])).max()


def judge(nel, err):
    """The rate of the errors ``err`` at ``nel`` elements, ``nan`` where
    it is none, and why, in words."""
    rising = not_falling(nel, err)
    if rising:
        return float("nan"), "no rate: the errors do not fall at every " \
            "refinement"
    rate = fitted_rate(nel, err)
    floor = levelling_off(nel, err, rate)
    if floor:
        last = np.log(err[-2] / err[-1]) / np.log(nel[-1] / nel[-2])
        return float("nan"), "no rate: the errors level off at " \
            "{:.1e} (local rate {:.2f})".format(err[-1], last)
    return rate, "rate {:.2f}".format(rate)


fit = (nelems >= 4) & (nelems <= 256)
verdicts = {key: judge(nelems[fit], err[fit]) for key, err in errors.items()}
#: the fitted rate where the errors converge, ``nan`` where they do not
rates = {key: rate for key, (rate, _) in verdicts.items()}


def visualize(outdir="."):
    from pathlib import Path
    from skfem_mpm.scenes.plot import pyplot, save_figure
    from skfem_mpm.studies.column import SOURCE
    from skfem_mpm.studies.figures import draw_column_stress, draw_convergence
    plt = pyplot()
    fig, axes = plt.subplots(3, 2, figsize=(8, 10), sharey=True)
    for j, nel in enumerate((10, 100)):
        for i, nsteps in enumerate((1, 2, 20)):
            draw_column_stress(
                axes[i, j], [profiles[nel, nsteps]], ["MPM"],
                "{} elements, 2 MPs, {} load step{}".format(
                    nel, nsteps, "s" if nsteps > 1 else ""))
    fig.suptitle("The column under its own weight: vertical stress against "
                 "initial height,\nstandard MPM, the seed's increment "
                 "scheme (after Figure 2.9 of {})".format(SOURCE))
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "column_stress_profiles.png")

    fig, axes = plt.subplots(1, 3, figsize=(15, 6))
    for ax, nsteps in zip(axes, (1, 2, 20)):
        draw_convergence(
            ax, nelems,
            {"{} MPs".format(ppc): errors[nsteps, ppc] for ppc in (2, 3, 4, 5)},
            {"{} MPs".format(ppc): verdicts[nsteps, ppc][1]
             for ppc in (2, 3, 4, 5)},
            "{} load step{}".format(nsteps, "s" if nsteps > 1 else ""))
    fig.suptitle("The column's error measure (2.28) against the number of "
                 "elements, standard MPM, the seed's increment scheme\n"
                 "(after Figure 2.10 of {}; a rate only where the errors "
                 "fall and do not level off)".format(SOURCE))
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "column_convergence.png")


if __name__ == "__main__":
    import sys
    for (nsteps, ppc), (rate, words) in verdicts.items():
        print("{:2d} load steps, {} points/element: error at 256 elements "
              "{:.2e}, {}".format(
                  nsteps, ppc, errors[nsteps, ppc][nelems == 256][0], words))
    print("the seed's increment scheme: {} runs ended out of balance, by "
          "up to {:.3g} times the external force (the finest grids; the "
          "default rhs='residual' restores it)".format(_quiet.count,
                                                       imbalance))
    print("1D vs 2D plane strain, max stress difference: {:.1e}".format(
        dim_difference))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
