"""The seed's column under self weight with standard implicit MPM.

A column of height 50 (E = 1e6, nu = 0) is loaded by its own weight, ramped
to 800 per unit volume, and shortens by about 1.  With one load step MPM is
the finite element method with the material points as quadrature, and the
error measure (2.28) of Charlton (2018) falls at rate 1 as the grid is
refined.  With more load steps the points cross element boundaries, and the
error stops falling: the grid-crossing plateau of Figures 2.9 and 2.10 of
Charlton (2018), Chapter 2 (the seed; docs/references.md).

Run ``python examples/column.py [OUTDIR]`` to write both figures as PNG.
"""
import numpy as np

from skfem_mpm import Options
from skfem_mpm.studies.column import column_error, run_column, vertical_stress

# Figure 2.9: stress profiles, 2 points per element
profiles = {(nel, nsteps): run_column(nel, ppc=2, nsteps=nsteps)
            for nel in (10, 100) for nsteps in (1, 2, 20)}

# Figure 2.10: error against number of elements, 2-5 points per element
nelems = 2 ** np.arange(0, 10)
errors = {
    (nsteps, ppc): np.array([
        column_error(run_column(nel, ppc, nsteps, options=Options(
            keep_snapshots=False)).points)
        for nel in nelems])
    for nsteps in (1, 2, 20) for ppc in (2, 3, 4, 5)
}
fit = (nelems >= 4) & (nelems <= 256)
rates = {key: np.polyfit(np.log(nelems[fit]), -np.log(err[fit]), 1)[0]
         for key, err in errors.items()}

# the same column as a 2D plane-strain strip one element wide
one_d, two_d = run_column(16, 2, 20), run_column(16, 2, 20, dim=2)
left = two_d.points.x0[0] < two_d.points.x0[0].mean()
dim_difference = np.abs(
    np.sort(vertical_stress(one_d.points))
    - np.sort(vertical_stress(two_d.points)[left])).max()


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
                 "height,\nstandard MPM (after Figure 2.9 of {})".format(
                     SOURCE))
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "column_stress_profiles.png")

    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for ax, nsteps in zip(axes, (1, 2, 20)):
        draw_convergence(
            ax, nelems,
            {"{} MPs".format(ppc): errors[nsteps, ppc] for ppc in (2, 3, 4, 5)},
            {"{} MPs".format(ppc): rates[nsteps, ppc] for ppc in (2, 3, 4, 5)},
            "{} load step{}".format(nsteps, "s" if nsteps > 1 else ""))
    fig.suptitle("The column's error measure (2.28) against the number of "
                 "elements, standard MPM (after Figure 2.10 of {})".format(
                     SOURCE))
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "column_convergence.png")


if __name__ == "__main__":
    import sys
    for (nsteps, ppc), rate in rates.items():
        print("{:2d} load steps, {} points/element: error at 256 elements "
              "{:.2e}, fitted rate {:.2f}".format(
                  nsteps, ppc, errors[nsteps, ppc][nelems == 256][0], rate))
    print("1D vs 2D plane strain, max stress difference: {:.1e}".format(
        dim_difference))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
