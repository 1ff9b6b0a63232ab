"""Bodies in contact: a block landing on a slab, a block sliding on it, and
two blocks of different stiffness pressed together.

Bodies of one run share the grid's nodes, so where they meet they are
glued.  :class:`~skfem_mpm.Contact` puts two bodies on separate copies of
the grid, coupled only where their surfaces meet (``docs/contact.md``).
Each part runs with the contact and glued, against what it must give:

- **landing**: an elastic block (0.4 x 0.2, E = 1e6, rho = 1000) released
  0.5 above an elastic slab (standard MPM, finite deformation, Newmark,
  time step 0.01 s).  With the contact its lowest corner follows free
  fall, ``0.5 - g t^2 / 2``, until it reaches the slab at ``sqrt(2 * 0.5
  / g) = 0.319 s``; glued, it stops in the cell above the slab (the
  nodes it shares with the slab hold it), half a cell early;
- **sliding**: the block resting on the slab with friction ``mu = 0.3``
  under gravity tilted by theta (the inclined plane turned level),
  ``tan(theta) > mu``: it slides ``g (sin theta - mu cos theta) t^2 / 2``;
  glued, it stays;
- **pressed**: a block a hundred times stiffer pressed on a softer one
  (small strain, smooth contact): the stress is ``sigma_yy = -p`` with no
  horizontal stress in both; glued, the interface forces the soft block's
  lateral expansion onto the stiff one: horizontal stresses up to 0.8 p
  and a vertical stress from 0.78 to 1.63 p.

With the contact the landing block's lowest corner goes below the slab's
initial surface after the impact: the slab's surface gives way under it
(0.2 thick, E = 1e6), the penetration between them stays within the
contact's tolerance (1e-3 of a cell).

Run ``python examples/bodies_in_contact.py [OUTDIR]`` for the numbers and
the figure (``bodies_in_contact.png``).
"""
import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (BodyForce, Contact, Dynamics, LinearElastic,
                       Options, Traction, seed_points, simulate)
from skfem_mpm.quadrature.points import concatenate_points
from skfem_mpm.solve.loads import side_points

g, rho, mu = 9.81, 1e3, .3


def bodies(mesh, regions):
    """The points of the ``regions`` (2 per cell and direction), body k
    in region k."""
    parts = [seed_points(mesh, 2, region=region) for region in regions]
    for k, part in enumerate(parts):
        part.body[:] = k
    return concatenate_points(parts)


def slab_base(b):
    return b.get_dofs(lambda x: x[1] < -.19).all()


# landing: the lowest domain corner of the block over time
mesh = MeshQuad.init_tensor(np.linspace(0, 1, 11), np.linspace(-.2, 1.2, 15))
drop = bodies(mesh, [lambda x: x[1] < 0.,
                     lambda x: (x[0] > .3) & (x[0] < .7) & (x[1] > .5)
                     & (x[1] < .7)])
landing_time = np.sqrt(2 * .5 / g)
landings = {}
for name, contacts in (("contact", [Contact(0, 1)]), ("glued", [])):
    times, lowest = [0.], [.5]

    def watch(record, points, times=times, lowest=lowest):
        block = points.body == 1
        half = drop.domain[1, block] * points.F[1, 1, block]
        times.append(record.time)
        lowest.append(float((points.x[1, block] - half).min()))
    simulate(mesh, ElementQuad1(), drop, LinearElastic(1e6, .3), slab_base,
             body_force=[0, -g * rho], kinematics="finite",
             dynamics=Dynamics(time_step=.01, duration=.5, density=rho),
             contacts=contacts, options=Options(callback=watch))
    landings[name] = (np.array(times), np.array(lowest))

# sliding: the block's mean horizontal displacement over time
theta = np.arctan(mu) + .15
slide_mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                  np.linspace(-.2, .6, 9))
on_slab = bodies(slide_mesh, [lambda x: x[1] < 0.,
                              lambda x: (x[0] > .2) & (x[0] < .6)
                              & (x[1] > 0.) & (x[1] < .2)])
slides = {}
for name, contacts in (("contact", [Contact(0, 1, friction=mu)]),
                       ("glued", [])):
    result = simulate(
        slide_mesh, ElementQuad1(), on_slab, LinearElastic(1e7, .3),
        slab_base, body_force=BodyForce(g * rho * np.array(
            [np.sin(theta), -np.cos(theta)]), ramp=False),
        kinematics="finite",
        dynamics=Dynamics(time_step=.01, duration=.3, density=rho),
        contacts=contacts, options=Options(keep_snapshots=True))
    block = on_slab.body == 1
    slides[name] = (np.array([0.] + [r.time for r in result.history]),
                    np.array([0.] + [r.displacement[0, block].mean()
                                     for r in result.history]))


def sliding(t):
    """Coulomb's answer: the distance slid in time ``t``."""
    return .5 * g * (np.sin(theta) - mu * np.cos(theta)) * t ** 2


# pressed: the stresses of the points along the height
p = 10.
stack_mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5),
                                  np.linspace(0, 2.5, 11))
stack = bodies(stack_mesh, [[(0, 1), (0, 1.)], [(0, 1), (1., 2.)]])
pressed = {}
for name, contacts in (("contact", [Contact(0, 1)]), ("glued", [])):
    result = simulate(
        stack_mesh, ElementQuad1(), stack,
        [LinearElastic(1e4, .3), LinearElastic(1e6, .3)],
        lambda b: np.union1d(b.get_dofs(lambda x: x[1] == 0).nodal["u^2"],
                             b.get_dofs(lambda x: x[0] == 0).nodal["u^1"]),
        loads=[Traction(side_points(stack, "top"), "top", [0., -p])],
        contacts=contacts)
    pressed[name] = result.points.stress


def visualize(outdir="."):
    """``bodies_in_contact.png``: the landing, the sliding and the
    horizontal stress of the pressed blocks, with the contact and
    glued."""
    from pathlib import Path
    from skfem_mpm.scenes.plot import pyplot, save_figure
    fig, axes = pyplot().subplots(1, 3, figsize=(15, 4))
    ax = axes[0]
    t = np.linspace(0, landings["contact"][0][-1], 200)
    ax.plot(t, .5 - .5 * g * t ** 2, "k--", label="free fall")
    for name, (times, lowest) in landings.items():
        ax.plot(times, lowest, "o-", ms=3, label="MPM, {}".format(name))
    ax.axvline(landing_time, color="grey", ls=":",
               label="landing, sqrt(2 * 0.5 / g)")
    ax.axhline(0., color="k", lw=.8)
    ax.set_ylim(-.1, .55)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("height of the block's lowest corner (m)")
    ax.set_title("A block dropped 0.5 m on an elastic slab")
    ax.legend(loc="upper right", fontsize=8)
    ax = axes[1]
    for name, (times, x) in slides.items():
        ax.plot(times, x, "o", ms=3, label="MPM, {}".format(name))
    tt = np.linspace(0, slides["contact"][0][-1], 100)
    ax.plot(tt, sliding(tt), "k--", label="Coulomb, mu = {}".format(mu))
    ax.set_xlabel("time (s)")
    ax.set_ylabel("distance slid on the slab (m)")
    ax.set_title("A block on a slab, theta = {:.1f} deg > arctan(mu)"
                 .format(np.degrees(theta)))
    ax.legend(loc="upper left", fontsize=8)
    ax = axes[2]
    for name, stress in pressed.items():
        ax.plot(stress[0, 0] / p, stack.x[1], "o", ms=4,
                label="MPM, {}".format(name))
    ax.axhline(1., color="grey", ls=":", label="interface")
    ax.set_xlabel("horizontal stress sigma_xx / p (-)")
    ax.set_ylabel("height of the point (m)")
    ax.set_title("Stiff block (E x 100) pressed on a soft one")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    save_figure(fig, Path(outdir) / "bodies_in_contact.png")


if __name__ == "__main__":
    import sys
    for name, (times, lowest) in landings.items():
        falling = times < landing_time - .01
        print("landing, {}: lowest corner {:.4f} m at {:.2f} s (free fall "
              "reaches the slab at {:.3f} s), largest gap to free fall "
              "before {:.4f} m".format(
                  name, lowest.min(), times[np.argmin(lowest)],
                  landing_time, np.abs(lowest[falling] - (
                      .5 - .5 * g * times[falling] ** 2)).max()))
    for name, (times, x) in slides.items():
        print("sliding, {}: {:.4f} m in {:.2f} s (Coulomb {:.4f})".format(
            name, x[-1], times[-1], sliding(times[-1])))
    for name, stress in pressed.items():
        print("pressed, {}: |sigma_xx| / p at most {:.2e}, sigma_yy / p "
              "{:.6f} to {:.6f}".format(
                  name, np.abs(stress[0, 0]).max() / p,
                  stress[1, 1].min() / p, stress[1, 1].max() / p))
    visualize(sys.argv[1] if len(sys.argv) > 1 else ".")
