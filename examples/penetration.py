"""Large-deformation penetration of a smooth rigid strip footing into
weightless undrained clay, to one footing width.

The problem MPM exists for: a finite-element mesh that follows the soil
tangles at the footing's corners long before the footing has sunk by its
width.  The right half of the problem (symmetry on x = 0): a footing of
width B = 0.5 on von Mises soil (``yield_stress`` 100, so
``c_u = 100 / sqrt(3)``; E = 1e5, nu = 0.3; the mean dilatation against
volumetric locking) 3 B wide and 2.5 B deep, smooth sides on rollers,
base rough, finite deformation (Hencky), standard MPM, 2 x 2 points per
cell.

**The grid moves with the footing.**  A footing made of material points
pushes the grid nodes of the cells it occupies, so its contact with the
soil sits up to a cell below its base and jumps a cell each time its base
crosses a grid line (the pressure jumps by 15% there).  MPM codes for
penetration move the grid with the footing instead (the moving-mesh
concept of Beuth, PhD thesis, Stuttgart 2012, used in Anura3D for piles
and footings; Phuong et al., *Int. J. Numer. Anal. Methods Geomech.* 40,
2016): the footing's base and side are then always grid lines.  Here the
whole grid moves with the footing, a change of frame that a weightless,
quasi-static problem does not notice: the footing's base nodes are held
vertically (smooth: they slide sideways) and its side nodes horizontally,
and the soil is pushed up against it by a rough rigid base (a
:class:`~skfem_mpm.RigidBody` of points under the soil) by one footing
width.  The pressure on the footing is the reaction at its base nodes,
which the base's force balances (weightless soil, smooth sides).

The load-penetration curve rises from Prandtl's ``(2 + pi) c_u`` of the
surface footing as heave builds up beside the footing and the failure
mechanism deepens, as large-deformation analyses of this problem report
(e.g. Wang, Bienen and Nazem, *Comput. Geotech.* 65, 2015).  Measured:
at h = B/4 in 128 steps (the test, 17 s), 5.5 c_u at the first step and
8.4 over the last tenth of B; at h = B/8 in 256 steps (``python
examples/penetration.py``, 84 s), 5.5 c_u over the first 5% of B and 7.9
over the last tenth (table in docs/geomechanics.md).

**Or the footing is an obstacle on a fixed grid**
(:func:`penetrate_with_obstacle`): an :class:`~skfem_mpm.Obstacle` box
pushed down by one width acts at the soil's surface wherever it is
between grid lines (``docs/contact.md``), which a user can set up around
a pile or two footings where no grid can follow every body.  Its curve,
beside the moving grid's: 5.5 c_u at the first step and 8.5 over the last
tenth at h = B/4 in 137 steps for 128 (12 s; the moving grid 5.5 and
8.4), but with dips of up to a quarter where soil under the footing's
edge flows past a grid line.  At h = B/8 in 256 steps (the script's
default) 6.5 c_u against the moving grid's 7.8 over the last tenth (18%
lower), in 301 steps (cut-backs where plastic flow under the footing's
edge stalls Newton; the moving grid 265).

Run ``python examples/penetration.py [OUTDIR] [CELLS_PER_WIDTH] [STEPS]``
for the curves and the deformed soil with its plastic zone.
"""
import logging

import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (LinearElastic, NewtonOptions, Obstacle, Options,
                       RigidBody, Stabilisation, VonMises, seed_points,
                       simulate)
from skfem_mpm.quadrature.points import concatenate_points

logger = logging.getLogger(__name__)

half, width, depth = .25, 1.5, 1.25     # footing half-width, soil size
soil = VonMises(E=1e5, nu=.3, yield_stress=100.)
cu = soil.yield_stress / np.sqrt(3.)
penetration = 2 * half                  # one footing width


def penetrate(cells_per_width: int = 4, nsteps: int = 128):
    """The footing pushed into the soil by one width on a grid of
    ``h = B / cells_per_width``: returns ``(result, depths, pressures,
    base_forces)``, the penetration / B, the footing pressure / c_u and
    the rigid base's force over the footing's half-width / c_u (the same,
    by equilibrium) at every step, from 0."""
    h = 2 * half / cells_per_width
    # the grid in the footing's frame: its base on y = depth, room above
    # for the soil that rises by the penetration and heaves
    mesh = MeshQuad.init_tensor(
        np.arange(0., width + 1e-9, h),
        np.arange(-h, depth + 2 * penetration + 1e-9, h))
    ground = seed_points(mesh, 2, region=lambda x: (x[1] > 0.)
                         & (x[1] < depth))
    base = seed_points(mesh, 2, region=lambda x: x[1] < 0.)
    base.body[:] = 1
    points = concatenate_points([ground, base])

    def footing_base(x):
        return np.isclose(x[1], depth) & (x[0] <= half + 1e-9)

    def supports(basis):
        return np.concatenate([
            basis.get_dofs(footing_base).all("u^2"),
            basis.get_dofs(lambda x: np.isclose(x[0], half)
                           & (x[1] >= depth - 1e-9)).all("u^1"),
            basis.get_dofs(lambda x: np.isclose(x[0], 0.)
                           | np.isclose(x[0], width)).all("u^1")])

    result = simulate(mesh, ElementQuad1(), points,
                      [soil, LinearElastic(E=1e2, nu=.3)], supports,
                      loads=[RigidBody(1, [0., penetration])],
                      nsteps=nsteps, kinematics="finite", options=Options(
                          NewtonOptions(line_search="armijo"),
                          Stabilisation(antilocking=True)))
    under = 2 * np.flatnonzero(footing_base(mesh.p)) + 1
    depths = np.array([0.] + [r.load_factor for r in result.history]) \
        * penetration / (2 * half)
    pressures = np.array([0.] + [-r.reactions[under].sum()
                                 for r in result.history]) / half / cu
    base_forces = np.array([0.] + [r.rigid_forces[0][1]
                                   for r in result.history]) / half / cu
    return result, depths, pressures, base_forces


def penetrate_with_obstacle(cells_per_width: int = 4, nsteps: int = 128):
    """The footing as an :class:`~skfem_mpm.Obstacle` pushed one width
    into the soil on a fixed grid of ``h = B / cells_per_width`` (the same
    soil, base and sides): returns ``(result, depths, pressures)``, the
    penetration / B and the footing pressure / c_u at every step, from
    0."""
    h = 2 * half / cells_per_width
    mesh = MeshQuad.init_tensor(np.arange(0., width + 1e-9, h),
                                np.arange(0., depth + penetration + 1e-9, h))
    ground = seed_points(mesh, 2, region=lambda x: x[1] < depth)

    def supports(basis):
        return np.concatenate([
            basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
            basis.get_dofs(lambda x: np.isclose(x[0], 0.)
                           | np.isclose(x[0], width)).all("u^1")])
    footing = Obstacle(box=[[-1., half], [depth, depth + penetration + 1.]],
                       displacement=[0., -penetration], name="footing")
    result = simulate(mesh, ElementQuad1(), ground, soil, supports,
                      nsteps=nsteps, kinematics="finite",
                      obstacles=[footing], options=Options(
                          NewtonOptions(line_search="armijo"),
                          Stabilisation(antilocking=True)))
    depths = np.array([0.] + [r.load_factor for r in result.history]) \
        * penetration / (2 * half)
    pressures = np.array([0.] + [r.obstacle_forces[0, 1]
                                 for r in result.history]) / half / cu
    return result, depths, pressures


def visualize(result, depths, pressures, outdir=".", label="",
              obstacle=None):
    """``penetration.png``: the load-penetration curve (with
    ``obstacle``, ``(depths, pressures)`` of
    :func:`penetrate_with_obstacle`, beside it) and the soil with its
    plastic zone at a penetration of one width."""
    import copy
    from pathlib import Path
    from skfem_mpm.scenes.plot import (draw_footing_curve,
                                       draw_plastic_zone, pyplot,
                                       save_figure)
    fig, (curve, zone) = pyplot().subplots(1, 2, figsize=(11, 5))
    draw_footing_curve(curve, depths, pressures, "skfem-mpm" + label,
                       2 + np.pi, "Prandtl, surface footing: (2 + pi) c_u",
                       "Load-penetration curve of a smooth strip footing",
                       motion="penetration")
    if obstacle is not None:
        curve.plot(*obstacle, "s-", ms=2, lw=.8,
                   label="obstacle on a fixed grid" + label)
        curve.legend(loc="lower right")
    # back to the ground's frame: the soil moved up by the penetration
    ground = copy.copy(result.points)
    ground.x = ground.x - np.array([[0.], [penetration]])
    draw_plastic_zone(fig, zone, ground, "Soil and plastic zone at a "
                      "penetration of one width\n(rigid base in black)",
                      rigid=ground.body == 1)
    top = depth - penetration
    zone.fill([0., half, half, 0.], [top, top, depth + .2, depth + .2],
              color="k", label="footing")
    zone.set_ylim(-2 * half / 4, depth + .2)
    zone.legend(loc="lower right")
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "penetration.png")


if __name__ == "__main__":
    import sys
    logging.basicConfig(format="%(message)s")
    logging.getLogger("skfem_mpm").setLevel(logging.INFO)
    outdir = sys.argv[1] if len(sys.argv) > 1 else "."
    cells = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    steps = int(sys.argv[3]) if len(sys.argv) > 3 else 256
    result, depths, pressures, _ = penetrate(cells, steps)
    fixed = penetrate_with_obstacle(cells, steps)[1:]
    for d, p in zip(depths[::max(1, steps // 16)],
                    pressures[::max(1, steps // 16)]):
        print("penetration / B {:.3f}: pressure / c_u {:.2f}".format(d, p))
    for name, (d, p) in (("moving grid", (depths, pressures)),
                         ("obstacle, fixed grid", fixed)):
        print("{}: {} steps, first {:.2f} c_u, last tenth {:.2f} c_u"
              .format(name, len(d) - 1, p[1], p[d >= .9].mean()))
    visualize(result, depths, pressures, outdir,
              ", h = B/{}".format(cells), obstacle=fixed)
