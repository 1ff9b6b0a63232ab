"""Prandtl's strip footing: a smooth rigid footing pushed into weightless
undrained soil, whose collapse pressure is ``(2 + pi) c_u``.

Prandtl (1920) for a rigid-plastic Tresca half-space; in plane strain von
Mises is Tresca with ``c_u = yield_stress / sqrt(3)``.  The right half of
the problem (symmetry on x = 0): a footing of half-width 0.25 (width
B = 0.5) on soil 1.25 wide and 0.75 deep (von Mises, ``yield_stress`` 100,
E = 1e5, nu = 0.3, the mean dilatation against volumetric locking), base
clamped, sides on rollers, a grid of spacing 1/32 with 2 x 2 points per
cell, standard MPM in small strain.  The footing is a body of points
(a :class:`~skfem_mpm.RigidBody`, soft: its material acts only across
the motion, where a smooth footing must not hold the soil) pushed down by 0.24 of a cell in 20 steps:
less than the quarter cell after which its points enter the soil's cells
and its contact moves down a cell.  Its force per step is the
load-displacement curve: elastic, then a plateau near ``5.14 c_u``
(5.24 at its highest, 5.15 at the end: within 1.9%; at h = 1/16 the
plateau peaks at 5.44, 5.9% high).

Run ``python examples/prandtl.py [OUTDIR]`` for the curve and the plastic
zone.
"""
import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (LinearElastic, Options, RigidBody, Stabilisation,
                       VonMises, seed_points, simulate)
from skfem_mpm.quadrature.points import concatenate_points

h, half, width, depth = 1 / 32, .25, 1.25, .75
soil = VonMises(E=1e5, nu=.3, yield_stress=100.)
cu = soil.yield_stress / np.sqrt(3.)
mesh = MeshQuad.init_tensor(np.arange(0., width + 1e-9, h),
                            np.arange(0., depth + 2 * h + 1e-9, h))
ground = seed_points(mesh, 2, region=lambda x: x[1] < depth)
footing = seed_points(mesh, 2, region=lambda x: (x[1] > depth)
                      & (x[1] < depth + h) & (x[0] < half))
footing.body[:] = 1
points = concatenate_points([ground, footing])
settlement = .24 * h


def supports(basis):
    return np.concatenate([
        basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
        basis.get_dofs(lambda x: np.isclose(x[0], 0.)
                       | np.isclose(x[0], width)).all("u^1")])


result = simulate(mesh, ElementQuad1(), points,
                  [soil, LinearElastic(E=1e2, nu=.3)], supports,
                  loads=[RigidBody(1, [0., -settlement], rough=False)],
                  nsteps=20, options=Options(
                      stabilisation=Stabilisation(antilocking=True)))
# settlement and footing pressure in units of c_u, step by step
settlements = np.array([0.] + [r.load_factor for r in result.history]) \
    * settlement
pressure = np.array([0.] + [-r.rigid_forces[0][1] for r in result.history]) \
    / half / cu


def visualize(outdir="."):
    from pathlib import Path
    from skfem_mpm.scenes.plot import (draw_footing_curve,
                                       draw_plastic_zone, pyplot,
                                       save_figure)
    fig, (curve, zone) = pyplot().subplots(1, 2, figsize=(11, 4))
    draw_footing_curve(curve, settlements / (2 * half), pressure,
                       "skfem-mpm, h = B/16", 2 + np.pi,
                       "Prandtl: (2 + pi) c_u",
                       "Load-settlement curve of a smooth strip footing")
    draw_plastic_zone(fig, zone, result.points, "Plastic zone at the end "
                      "(footing in black)", rigid=result.points.body == 1)
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "prandtl.png")


if __name__ == "__main__":
    import sys
    print("footing pressure / c_u: highest {:.3f}, last {:.3f} (Prandtl "
          "{:.3f})".format(pressure.max(), pressure[-1], 2 + np.pi))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
