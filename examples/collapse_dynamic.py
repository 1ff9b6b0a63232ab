"""Dynamic collapse of a clay column released under gravity, to rest.

Implicit dynamics (:class:`~skfem_mpm.Dynamics`): a column 2 m high and
2 m wide (the right half, 1 m, by symmetry on x = 0) of undrained clay
(von Mises, ``c_u = rho g H / 8``: a vertical cut stands to about
``4 c_u / (rho g) = H / 2``, so the column cannot), E = 1e7,
nu = 0.3, density 2000, stands on a rough base.  Gravity is switched on
at t = 0; the column slumps and spreads until plastic work has taken the
energy gravity released.  Standard MPM in finite deformation, a grid of
h = 0.25 with 2 x 2 points per cell, the generalised-alpha scheme
(``rho_inf = 0.5``) with time steps of 0.02 s over 2.5 s, lumped mass,
the default FLIP/PIC blend.

Measured (2026-11-30, the numba and the numpy kernels alike): the toe
runs out from 1.0 to 1.320 m, the crest drops from 2.0 to 1.559 m, the
kinetic energy peaks near t = 0.28 s and is 3.4e-6 of its peak at the
end; of the work of gravity (8.37 kJ per m), plastic and elastic work
take 95%, the scheme's and the mapping's numerical dissipation the rest
(5%).  About 5 s once the kernels are compiled.

Run ``python examples/collapse_dynamic.py [OUTDIR]`` for the run-out and
the energy plot.
"""
import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (Dynamics, GeneralizedAlpha, VonMises, seed_points,
                       simulate)

rho, g, height, half_width, h = 2000., 9.81, 2., 1., .25
cu = rho * g * height / 8
soil = VonMises(E=1e7, nu=.3, yield_stress=np.sqrt(3.) * cu)
mesh = MeshQuad.init_tensor(np.arange(0., 6. + 1e-9, h),
                            np.arange(0., 2.5 + 1e-9, h))
points = seed_points(mesh, 2, region=lambda x: (x[0] < half_width)
                     & (x[1] < height))


def supports(basis):
    return np.concatenate([
        basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),    # rough
        basis.get_dofs(lambda x: np.isclose(x[0], 0.)).all("u^1")])


result = simulate(mesh, ElementQuad1(), points, soil, supports,
                  body_force=[0., -rho * g], kinematics="finite",
                  dynamics=Dynamics(.02, 2.5, rho,
                                    scheme=GeneralizedAlpha(.5)))
energies = result.energies()
toe = result.points.x[0].max()
crest = result.points.x[1].max()


def visualize(outdir="."):
    from pathlib import Path
    from skfem_mpm.scenes.plot import (draw_energies, draw_plastic_zone,
                                       pyplot, save_figure)
    fig, (shape, energy) = pyplot().subplots(1, 2, figsize=(12, 4.5))
    draw_plastic_zone(fig, shape, result.points,
                      "Column at rest after its collapse (t = {:.1f} s)"
                      .format(energies["time"][-1]))
    shape.plot([0., half_width, half_width], [height, height, 0.], "k--",
               label="column at t = 0")
    shape.set_xlim(0., 2.)
    shape.set_ylim(0., 2.2)
    shape.legend(loc="upper right")
    draw_energies(energy, energies, "Energies of the collapse: gravity's "
                  "work taken by plastic work", unit="kJ per m thickness",
                  scale=1e3)
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "collapse_dynamic.png")


if __name__ == "__main__":
    import sys
    print("toe {:.3f} m, crest {:.3f} m, kinetic energy at the end {:.1e} "
          "of its peak".format(toe, crest, energies["kinetic"][-1]
                               / energies["kinetic"].max()))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
