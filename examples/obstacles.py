"""Obstacles: a block dropped on a floor, a block on a Coulomb slope, and a
strip footing that is an obstacle on a fixed grid.

Three uses of :class:`~skfem_mpm.Obstacle` (``docs/contact.md``), each
against what it must give:

- **landing**: an elastic block (0.4 x 0.2, E = 1e6, rho = 1000) released
  0.5 above a floor obstacle (standard MPM, finite deformation, Newmark,
  time step 0.01 s).  Its lowest corner follows free fall, ``0.5 - g t^2 /
  2``, until it reaches the floor at ``sqrt(2 * 0.5 / g) = 0.319 s``
  (not a cell early, as grid-based contact would) and never goes through
  it; the contact force is zero before;
- **slope**: the block on a floor with Coulomb friction ``mu = 0.3`` under
  gravity tilted by theta (the inclined plane turned level): it sticks for
  ``tan(theta) < mu`` and slides ``g (sin theta - mu cos theta) t^2 / 2``
  otherwise;
- **footing** (:func:`footing_curves`, about 65 s): a smooth strip
  footing of width B = 8 h pushed 2 cells into weightless von Mises soil
  (the half model, standard MPM, 3 x 3 points per cell, mean dilatation),
  once as an obstacle on
  the fixed grid and once as a :class:`~skfem_mpm.RigidBody` of points,
  against Prandtl's ``(2 + pi) c_u``: the rigid body's contact sits in the
  cells its points occupy and jumps as it crosses grid lines; the
  obstacle's acts at the soil's surface.

Run ``python examples/obstacles.py [OUTDIR]`` for the numbers and the
figure (``obstacles.png``).
"""
import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (BodyForce, Dynamics, LinearElastic, Obstacle,
                       Options, RigidBody, Stabilisation, VonMises,
                       seed_points, simulate)
from skfem_mpm.quadrature.points import concatenate_points

g, rho, E = 9.81, 1e3, 1e6

# landing: the lowest domain corner of the block over time
mesh = MeshQuad.init_tensor(np.linspace(0, 1, 11), np.linspace(-.2, 1.2, 15))
block = seed_points(mesh, 2, region=lambda x: (x[0] > .3) & (x[0] < .7)
                    & (x[1] > .5) & (x[1] < .7))
floor = Obstacle(box=[[-1, 2], [-1, 0.]], name="floor")
landing_time = np.sqrt(2 * .5 / g)
times, lowest, floor_force = [0.], [.5], [0.]


def watch(record, points):
    half = block.domain[1] * points.F[1, 1]        # the domain, stretched
    times.append(record.time)
    lowest.append(float((points.x[1] - half).min()))
    floor_force.append(-record.obstacle_forces[0, 1])


simulate(mesh, ElementQuad1(), block, LinearElastic(E, .3), [],
         body_force=[0, -g * rho], method="mpm", kinematics="finite",
         dynamics=Dynamics(time_step=.01, duration=.7, density=rho),
         obstacles=[floor], options=Options(callback=watch))
times, lowest, floor_force = map(np.array, (times, lowest, floor_force))

# slope: the mean horizontal displacement over time, below and above
mu = .3
slope_mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                  np.linspace(-.2, .6, 9))
slope_block = seed_points(slope_mesh, 2, region=lambda x: (x[0] > .2)
                          & (x[0] < .6) & (x[1] > 0.) & (x[1] < .2))
angles = np.arctan(mu) + np.array([-.1, .15])
slides = {}
for theta in angles:
    result = simulate(
        slope_mesh, ElementQuad1(), slope_block, LinearElastic(1e7, .3), [],
        body_force=BodyForce(g * rho * np.array([np.sin(theta),
                                                 -np.cos(theta)]),
                             ramp=False),
        method="mpm", kinematics="finite",
        dynamics=Dynamics(time_step=.01, duration=.3, density=rho),
        obstacles=[Obstacle(box=[[-1, 3], [-1, 0.]], friction=mu)],
        options=Options(keep_snapshots=True))
    slides[theta] = (np.array([0.] + [r.time for r in result.history]),
                     np.array([0.] + [r.displacement[0].mean()
                                      for r in result.history]))


def sliding(theta, t):
    """Coulomb's answer: the distance slid in time ``t``."""
    return .5 * max(0., g * (np.sin(theta) - mu * np.cos(theta))) * t ** 2


def footing_curves(ratio: int = 8, steps: int = 40, per_cell: int = 3):
    """The smooth strip footing of width B = ``ratio`` cells pushed 2 cells
    in ``steps`` load steps, as an obstacle and as a rigid body, the soil
    seeded ``per_cell`` points per cell along each axis: per variant
    (settlement / B, pressure / c_u) at every step."""
    B, h = 1., 1. / ratio
    width, depth = 2.5 * B, 1.5 * B
    soil = VonMises(E=1e5, nu=.3, yield_stress=100.)
    cu = soil.yield_stress / np.sqrt(3.)
    grid = MeshQuad.init_tensor(np.arange(0., width + 1e-9, h),
                                np.arange(0., depth + 3 * h + 1e-9, h))
    ground = seed_points(grid, per_cell, region=lambda x: x[1] < depth)

    def supports(b):
        return np.concatenate([
            b.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
            b.get_dofs(lambda x: np.isclose(x[0], 0.)
                       | np.isclose(x[0], width)).all("u^1")])
    options = Options(stabilisation=Stabilisation(antilocking=True))
    push = [0., -2 * h]
    obstacle = simulate(grid, ElementQuad1(), ground, soil, supports,
                        nsteps=steps, options=options, obstacles=[Obstacle(
                            box=[[-1., B / 2], [depth, depth + 2 * h]],
                            displacement=push, name="footing")])
    body = seed_points(grid, 2, region=lambda x: (x[1] > depth)
                       & (x[1] < depth + h) & (x[0] < B / 2))
    body.body[:] = 1
    rigid = simulate(grid, ElementQuad1(), concatenate_points([ground, body]),
                     [soil, LinearElastic(1e2, .3)], supports, nsteps=steps,
                     loads=[RigidBody(1, push, rough=False)],
                     options=options)
    return {
        "obstacle": (np.array([r.load_factor for r in obstacle.history])
                     * 2 * h / B,
                     np.array([r.obstacle_forces[0, 1]
                               for r in obstacle.history]) / (B / 2) / cu),
        "rigid body": (np.array([r.load_factor for r in rigid.history])
                       * 2 * h / B,
                       np.array([-r.rigid_forces[0][1]
                                 for r in rigid.history]) / (B / 2) / cu)}


def visualize(outdir=".", footing=None):
    """``obstacles.png``: the landing, the slope and (``footing``, the
    output of :func:`footing_curves`) the footing curves."""
    from pathlib import Path
    from skfem_mpm.scenes.plot import pyplot, save_figure
    panels = 3 if footing is not None else 2
    fig, axes = pyplot().subplots(1, panels, figsize=(5 * panels, 4))
    ax = axes[0]
    t = np.linspace(0, times[-1], 200)
    ax.plot(t, np.maximum(.5 - .5 * g * t ** 2, 0.), "k--",
            label="free fall to the floor")
    ax.plot(times, lowest, "o-", ms=3, label="lowest corner (MPM)")
    ax.axvline(landing_time, color="grey", ls=":",
               label="landing, sqrt(2 * 0.5 / g)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("height of the block's lowest corner (m)")
    ax.set_title("A block dropped 0.5 m on a floor obstacle")
    ax.legend(loc="upper right", fontsize=8)
    ax = axes[1]
    for theta, (t, x) in slides.items():
        line, = ax.plot(t, x, "o", ms=3, label="theta = {:.1f} deg (MPM)"
                        .format(np.degrees(theta)))
        tt = np.linspace(0, t[-1], 100)
        ax.plot(tt, [sliding(theta, s) for s in tt], "--",
                color=line.get_color(), label="Coulomb, mu = {}".format(mu))
    ax.set_xlabel("time (s)")
    ax.set_ylabel("distance slid down the slope (m)")
    ax.set_title("A block on a Coulomb slope, tan(theta) vs mu")
    ax.legend(loc="upper left", fontsize=8)
    if footing is not None:
        ax = axes[2]
        for name, (s, q) in footing.items():
            ax.plot(s, q, "o-", ms=3, label=name)
        ax.axhline(2 + np.pi, color="k", ls="--",
                   label="Prandtl: (2 + pi) c_u")
        ax.set_xlabel("settlement / footing width B (-)")
        ax.set_ylabel("footing pressure / c_u (-)")
        ax.set_title("Smooth strip footing, B = 8 h, on a fixed grid")
        ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "obstacles.png")


if __name__ == "__main__":
    import sys
    print("landing: lowest corner {:.4f} m at the lowest (floor at 0)"
          .format(lowest.min()))
    for theta, (t, x) in slides.items():
        print("slope {:.1f} deg: slid {:.4f} m in {:.2f} s (Coulomb {:.4f})"
              .format(np.degrees(theta), x[-1], t[-1],
                      sliding(theta, t[-1])))
    curves = footing_curves()
    for name, (s, q) in curves.items():
        print("footing as {}: pressure / c_u highest {:.3f}, last {:.3f}, "
              "{} steps, largest change between steps {:.1%}".format(
                  name, q.max(), q[-1], len(q),
                  np.max(np.abs(np.diff(q[s > .02])) / q[s > .02][1:])))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".", curves)
