"""Elasto-plastic collapse of a block under its own weight (GIMP, finite
deformation, von Mises plasticity).

An 8 x 8 block, the right half of a 16-wide block (symmetry on the left),
stands on a frictionless base (rollers on the base and the left edge) in a
16 x 8 grid of unit cells, 6 x 6 points per filled cell.  Von Mises yield
stress 20e3, E = 1e6, nu = 0.3.  The body force is ramped to 10e3 over 40
load steps: the block barely moves until the base yields through, then
spreads sideways.

Run ``python examples/collapse.py [OUTDIR]`` for the final shape plot.
"""
import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import VonMises, seed_points, solve_finite

mesh = MeshQuad.init_tensor(np.linspace(0., 16., 17), np.linspace(0., 8., 9))
points = seed_points(mesh, 6, region=lambda x: x[0] < 8.)
material = VonMises(E=1e6, nu=.3, yield_stress=20e3)


def supports(basis):
    base = basis.get_dofs(lambda x: np.isclose(x[1], 0.)).nodal["u^2"]
    left = basis.get_dofs(lambda x: np.isclose(x[0], 0.)).nodal["u^1"]
    return np.concatenate((base, left))


result = solve_finite(mesh, ElementQuad1(), points, material, supports,
                      body_force=[0., -10e3], nsteps=40, method="cpgimp")
load = np.array([r.load_factor for r in result.history])
# spreading: horizontal displacement of the block's toe (bottom right)
toe = np.argmax(points.x[0] - points.x[1])
spread = np.array([r.displacement[0, toe] for r in result.history])
mass_error = abs(result.points.volume0.sum() - points.volume.sum())
iterations = [len(r.newton_residuals) - 1 for r in result.history]


def visualize(outdir="."):
    from pathlib import Path
    from skfem_mpm.scenes.plot import draw_points, pyplot, save_figure
    from skfem_mpm.scenes.quantities import point_values
    fig, (ax, ay) = pyplot().subplots(1, 2, figsize=(11, 3.5))
    pts = result.points
    draw_points(fig, ax, pts, point_values(pts, "stress", "mises") / 1e3,
                "von Mises stress (kPa)", "final shape", size=1)
    ax.set_xlim(0, 16)
    ax.set_ylim(0, 8)
    ay.plot(load * 10e3, spread, "o-", ms=3)
    ay.set_xlabel("body force (N/m^3)")
    ay.set_ylabel("toe displacement (m)")
    ay.set_title("spreading of the block's toe under its rising weight")
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "collapse.png")


if __name__ == "__main__":
    import sys
    print("toe displacement at 40%, 50%, 100% load: {:.3f}, {:.3f}, {:.3f}"
          .format(*np.interp([.4, .5, 1.], load, spread)))
    print("Newton iterations per step: max {}, total {}".format(
        max(iterations), sum(iterations)))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
