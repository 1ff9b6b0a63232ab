"""A large-deflection cantilever with GIMP and finite deformation.

A plane-strain beam (length 10, depth 1, E = 12e6, nu = 0.2) hangs from a
root at x = 0 where the grid nodes are on rollers and the neutral-axis node
is pinned.  An end load, split over the two points nearest the neutral axis
at the tip, is ramped to P L^2 / (E I) = 10 over 50 load steps.  The tip
deflections follow the elastica (computed here from its equations) once the
beam is bent well beyond the small-deflection range: within 1.4%
(vertical) and 2.1% (horizontal) from P L^2 / (E I) = 4 on.  Below that
a grid two cells deep is stiff: at P L^2 / (E I) = 1 the tip's v/L is
0.2759 against the elastica's 0.2917 (-5.4%) and u/L 0.0465 against
0.0526 (-11.5%): there the beam bends more than it turns, and two
bilinear cells through its depth are stiff in bending.  Halving h
closes most of that gap (h = 0.25: -0.6% and -2.6% at 1, and +2.3% and
+1.1% at 10, where the continuum beam lies beyond the elastica:
docs/accuracy_vs_time.md, section 4a).

Run ``python examples/cantilever.py [OUTDIR]`` for the load-deflection plot.
"""
import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import LinearElastic, seed_points, solve_finite
from skfem_mpm.studies.elastica import elastica_tip

LENGTH, DEPTH, E, NU = 10., 1., 12e6, .2
ALPHA = 10.                                  # P L^2 / (E I) at full load
INERTIA = DEPTH ** 3 / 12
LOAD = ALPHA * E * INERTIA / LENGTH ** 2


def cantilever(h: float = .5, per_axis: int = 6, nsteps: int = 50,
               method: str = "cpgimp"):
    """Run the cantilever on a grid of spacing h; returns (alpha, v/L, u/L)
    per load step for the loaded points."""
    x = np.arange(0., LENGTH + 1. + h / 2, h)
    y = np.arange(-.8 * LENGTH - 1.5, DEPTH + 1. + h / 2, h)
    mesh = MeshQuad.init_tensor(x, y)
    points = seed_points(mesh, per_axis, region=lambda p: (p[0] < LENGTH)
                         & (p[1] > 0) & (p[1] < DEPTH))
    # the tip column (by tolerance: seeded coordinates differ by round-off)
    tip = np.isclose(points.x[0], points.x[0].max(), rtol=0.,
                     atol=1e-9 * LENGTH)
    loaded = np.flatnonzero(tip)[np.argsort(np.abs(
        points.x[1, tip] - DEPTH / 2), kind="stable")[:2]]
    points.force[1, loaded] = -LOAD / 2

    def supports(basis):
        root = basis.get_dofs(lambda p: np.isclose(p[0], 0.))
        pin = basis.mesh.nodes_satisfying(lambda p: np.isclose(p[0], 0.)
                                          & np.isclose(p[1], DEPTH / 2))
        return np.concatenate((root.nodal["u^1"],
                               basis.nodal_dofs[:, pin].ravel()))

    result = solve_finite(mesh, ElementQuad1(), points, LinearElastic(E, NU),
                          supports, nsteps=nsteps, method=method)
    alpha = ALPHA * np.array([r.load_factor for r in result.history])
    disp = np.array([r.displacement[:, loaded].mean(axis=1)
                     for r in result.history])
    return result, alpha, -disp[:, 1] / LENGTH, -disp[:, 0] / LENGTH


result, alpha, v, u = cantilever()
# the reference: elastica with the plane-strain bending stiffness
v_ref, u_ref = elastica_tip(alpha * (1 - NU ** 2))
large = alpha >= 4
v_error = np.abs(v[large] / v_ref[large] - 1).max()
u_error = np.abs(u[large] / u_ref[large] - 1).max()
newton_iterations = max(len(r.newton_residuals) - 1 for r in result.history)


def visualize(outdir="."):
    from pathlib import Path
    from skfem_mpm.scenes.plot import draw_points, pyplot, save_figure
    fig, (ax, ay) = pyplot().subplots(1, 2, figsize=(11, 4))
    ax.plot(alpha, v, "o", ms=3, label="GIMP, vertical")
    ax.plot(alpha, u, "s", ms=3, label="GIMP, horizontal")
    ax.plot(alpha, v_ref, "k-", lw=1, label="elastica, vertical")
    ax.plot(alpha, u_ref, "k--", lw=1, label="elastica, horizontal")
    ax.set_xlabel(r"load $P L^2 / (E I)$ (-)")
    ax.set_ylabel("tip deflection / L (-)")
    ax.set_title("tip deflection against the elastica")
    ax.legend(fontsize=8)
    pts = result.points
    draw_points(fig, ay, pts, pts.stress[0, 0] / 1e3, r"$\sigma_{xx}$ (kPa)",
                "final shape at P L^2 / (E I) = {:g}:\nsigma_xx (Cauchy, "
                "tension positive,\nglobal axes)".format(alpha[-1]), size=1)
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "cantilever.png")


if __name__ == "__main__":
    import sys
    print("tip deflection error for P L^2/(E I) >= 4: vertical {:.2%}, "
          "horizontal {:.2%}; at most {} Newton iterations per step".format(
              v_error, u_error, newton_iterations))
    for a in (1., 2., 4., 10.):
        k = np.argmin(np.abs(alpha - a))
        print("  alpha {:4.1f}: v/L {:.4f} (elastica {:.4f}), u/L {:.4f} "
              "(elastica {:.4f})".format(alpha[k], v[k], v_ref[k], u[k],
                                         u_ref[k]))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
