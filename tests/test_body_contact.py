"""Contact between deformable bodies on separate fields
(:mod:`skfem_mpm.solve.body_contact`, :mod:`skfem_mpm.methods.fields`)."""
import logging
import re

import numpy as np
import pytest
from scipy.spatial import cKDTree
from skfem import ElementQuad1, ElementQuad2, MeshQuad

from skfem_mpm import (BodyForce, Contact, Dynamics, GridLoad, MPMError,
                       InvalidInputError, LinearElastic, Newmark,
                       NewtonOptions, Options, Pressure, Resume,
                       Stabilisation, Traction,
                       UnsupportedElementError, VonMises, seed_points,
                       simulate)
import skfem_mpm.solve.core as core
from skfem_mpm.methods.fields import body_fields
from skfem_mpm.quadrature.points import concatenate_points
from skfem_mpm.solve.loads import side_points

G = 9.81


def bodies(mesh, n, boxes):
    """Points of the boxes ``boxes`` (one body each, in order)."""
    parts = []
    for body, box in enumerate(boxes):
        part = seed_points(mesh, n, region=box)
        part.body[:] = body
        parts.append(part)
    return concatenate_points(parts)


def roller_base_and_left_wall(b):
    return np.union1d(b.get_dofs(lambda x: x[1] == 0).nodal["u^2"],
                      b.get_dofs(lambda x: x[0] == 0).nodal["u^1"])


def stack(interface, E_top, kinematics="small", p=10., method="mpm",
          nsteps=1):
    """Two blocks, the lower on rollers, the upper pressed by ``p`` on its
    top in ``nsteps`` steps, frictionless between them."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2.5, 11))
    pts = bodies(mesh, 2, [[(0, 1), (0, interface)],
                           [(0, 1), (interface, 2.)]])
    top = side_points(pts, "top")
    return simulate(mesh, ElementQuad1(), pts,
                    [LinearElastic(1e4, .3), LinearElastic(E_top, .3)],
                    roller_base_and_left_wall, kinematics=kinematics,
                    method=method, nsteps=nsteps,
                    loads=[Traction(top, "top", [0., -p])],
                    contacts=[Contact(0, 1, tolerance=1e-9)],
                    options=Options(NewtonOptions(tol=1e-10)))


@pytest.mark.parametrize("method, interface, E_top", [
    ("mpm", 1., 1e4),            # on a grid line, one material
    ("mpm", 1.125, 1e4),         # inside a cell
    ("mpm", 1.125, 1e7),         # stiffness contrast 1e3
    ("mpm", 1., 1e2),            # 1e-2
    ("ugimp", 1.125, 1e7),
    ("cpgimp", 1., 1e2),
    ("bspline", 1., 1e2),
    ("bspline", 1.125, 1e7),
    ("bspline-gimp", 1., 1e4),
    ("bspline-gimp", 1.125, 1e2),
])
def test_a_frictionless_interface_carries_a_uniform_stress(method, interface,
                                                           E_top):
    """Two blocks pressed together: every point of both bodies carries
    sigma_yy = -p and nothing else to 1e-6 of p (the interface through
    its pairs of corners transmits the consistent nodal forces), and the
    contact force is the load; every method."""
    p = 10.
    res = stack(interface, E_top, p=p, method=method)
    s = res.points.stress
    assert np.abs(s[1, 1] + p).max() < 1e-6 * p
    assert np.abs(s[0, 0]).max() < 1e-6 * p
    assert np.abs(s[0, 1]).max() < 1e-6 * p
    assert np.allclose(res.history[-1].contact_forces[0], [0., p * 1.],
                       rtol=1e-9, atol=1e-6 * p)
    # the supports carry the load, summed over the fields' copies
    assert np.isclose(res.history[-1].reactions[1::2].sum(), p, rtol=1e-9)


@pytest.mark.parametrize("method, n", [("bspline", 4),
                                       ("bspline-gimp", 4),
                                       ("bspline-gimp", 3)])
def test_blocks_ending_inside_a_cell_carry_a_uniform_stress(method, n):
    """The pressed stack on a grid wider than the blocks, their right
    sides a quarter (a third) of a cell past a grid line: the spline of
    the node beyond reaches the blocks there, and its node took no pair
    (its share of the interface's force had nowhere to go) or the end
    corner's alone, which balances a uniform stress only pulling (a user
    trial: sigma_yy 0.97-1.01 of the load, bspline-gimp 0.72-1.28, at
    the blocks' edge).  The node before it pairs every corner within
    half a cell: uniform to 1e-6 of p."""
    h, p = .25, 10.
    right, interface = 1. + h / n, 1. + h * (n // 2) / n
    mesh = MeshQuad.init_tensor(np.linspace(0, 1.5, 7),
                                np.linspace(0, 2.5, 11))
    pts = bodies(mesh, n, [[(0, right), (0, interface)],
                           [(0, right), (interface, 2.)]])
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e4, .3), LinearElastic(1e5, .2)],
                   roller_base_and_left_wall, method=method,
                   loads=[Traction(side_points(pts, "top"), "top",
                                   [0., -p])],
                   contacts=[Contact(0, 1, tolerance=1e-9)],
                   options=Options(NewtonOptions(tol=1e-10)))
    s = res.points.stress
    assert np.abs(s[1, 1] + p).max() < 1e-6 * p
    assert np.abs(s[0, 0]).max() < 1e-6 * p
    assert np.allclose(res.history[-1].contact_forces[0], [0., p * right],
                       rtol=1e-9, atol=1e-6 * p)


def test_a_stretched_surface_ends_only_at_its_end():
    """Two bodies' faces at y = 1 (B-spline pairs, h = 0.25), their
    corners two a cell stretched along the face by 10% (0.1375 apart, a
    block 3 wide now 3.3): a node is a surface's end only where the
    second body's outermost corner lies within half a cell past it.
    Before, a node was an end where no corner lay between half a cell
    and a cell past it, a window half a cell wide that corners more than
    half a cell apart can miss: the nodes at 1.25 and 1.5 paired every
    corner within half a cell (two blocks pressed in finite strain,
    nu = 0.45, over-paired there and did not settle)."""
    from skfem_mpm.solve.contact_pairs import FACING, PairFinder
    h, stretch, domains = .25, 1.1, 24
    mesh = MeshQuad.init_tensor(np.arange(0, 4 + h / 2, h),
                                np.arange(0, 2.5 + h / 2, h))
    finder = PairFinder([], None, mesh, mesh.p.shape[1], h, columns=True)
    spacing = stretch * h / 2
    end = spacing * domains
    xs = np.arange(0, end + 1.5 * h, h)
    node_x = np.array([xs, np.ones(xs.size)])

    def corners(ys):
        X = np.array(np.meshgrid(spacing * np.arange(domains + 1), ys))
        X = X.reshape(2, -1)
        # the corners in each node's support (B-splines of degree 2)
        node, corner = np.nonzero(np.abs(X[0] - xs[:, None]) < 1.75 * h)
        return node, corner, X[:, corner]

    entries = [corners([1. - h / 2, 1.]), corners([1., 1. + h / 2])]
    normal = np.zeros((2, xs.size))
    normal[1] = 1.
    slot, _ = finder.surface(entries, normal, node_x)
    node, count = np.unique(slot, return_counts=True)
    ends = xs[node[count > 1]]
    assert ends.size > 0
    assert (ends >= end - h / 2 - FACING * h).all()


@pytest.mark.slow
def test_stretched_blocks_pair_every_corner_only_at_their_ends(monkeypatch):
    """Two blocks 3 wide (bspline-gimp, h = 0.25, 2 x 2 points a cell),
    finite strain, nu = 0.45, pressed on top by 1500 in 4 steps to the
    tolerance 1e-6: their Poisson expansion stretches the interface's
    corners more than half a cell apart.  Nodes pair every corner within
    half a cell only within half a cell of the blocks' ends (which only
    move outward), and the run completes with sigma_yy uniform to 2% of
    p.  Before, the end test's window (h/2, h] found no corner at nodes
    inside (x = 2.25): UnsettledContactError at step 5; with the default
    tolerance the node at x = 2.75 over-paired."""
    from skfem_mpm.solve.contact_pairs import PairFinder
    h, p, width = .25, 1500., 3.
    several = []
    surface = PairFinder.surface

    def spy(self, entries, normal, node_x):
        out = surface(self, entries, normal, node_x)
        node, count = np.unique(out[0], return_counts=True)
        several.extend(node_x[0, node[count > 1]])
        return out

    monkeypatch.setattr(PairFinder, "surface", spy)
    mesh = MeshQuad.init_tensor(np.arange(0, 4 + h / 2, h),
                                np.arange(0, 2.5 + h / 2, h))
    pts = bodies(mesh, 2, [[(0, width), (0, 1.)], [(0, width), (1., 2.)]])
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e4, .45)] * 2, roller_base_and_left_wall,
                   method="bspline-gimp", kinematics="finite", nsteps=4,
                   loads=[Traction(side_points(pts, "top"), "top",
                                   [0., -p])],
                   contacts=[Contact(0, 1, tolerance=1e-6)])
    s = res.points.stress[1, 1]
    assert s.max() - s.min() < .02 * p
    assert several and min(several) >= width - h / 2


@pytest.mark.parametrize("method", ("ugimp", "cpgimp"))
def test_a_tight_tolerance_holds_over_steps(method):
    """The pressed stack (stiffness contrast 100) in three steps with the
    tolerance 1e-9: the pairs a step held start the next apart by up to
    6e-9, which the check for missing supports took for no contact (a
    false 'add supports'); each step's force is the load so far."""
    p = 10.
    res = stack(1.125, 1e6, p=p, method=method, nsteps=3)
    for r in res.history:
        assert r.contact_forces[0, 1] == pytest.approx(p * r.load_factor,
                                                       rel=1e-6)


@pytest.mark.parametrize("ghost", ("auto", 0.))
def test_cpgimp_domains_past_a_grid_line_keep_a_stress_uniform(ghost):
    """Two blocks pressed together across a smooth contact on a grid line
    with cpGIMP in three steps (strain 2e-2): after the first, the upper
    body's lowest domains reach a sliver (0.014 cells) of the cell row
    below on its own field.  The stress stays -p to twice the strain,
    ghost penalty or not (measured 0.018 and 0.027, the blocks glued
    0.017), the contact force the load.  The pairs' corners moved with
    their points' cell's polynomial, extrapolated there, pushed the
    nodes above the grid line while the domains' internal force reached
    those below: 0.31 of p off, 1.0 without the ghost penalty."""
    h, E, nu, p = .125, 2e6, .25, 4e4
    mesh = MeshQuad.init_tensor(np.linspace(0, 2 * h, 3),
                                np.linspace(0, 12 * h, 13))
    pts = bodies(mesh, 3, [[(0, 2 * h), (0, 6 * h)],
                           [(0, 2 * h), (6 * h, 10 * h)]])
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(E, nu),
                   roller_base_and_left_wall, nsteps=3, method="cpgimp",
                   loads=[Traction(side_points(pts, "top"), "top",
                                   [0., -p])],
                   contacts=[Contact(0, 1)],
                   options=Options(stabilisation=Stabilisation(ghost=ghost)))
    strain = p * (1 - nu ** 2) / E                  # plane strain
    s = res.points.stress
    upper = res.points.body == 1
    # the upper body's lowest domains past the grid line y = 6 h
    reach = res.points.x[1, upper] - res.points.domain[1, upper]
    assert 6 * h - reach.min() > .05 * h
    assert np.abs(s[1, 1] / p + 1).max() < 2 * strain
    assert np.abs(s[0, 0] / p).max() < strain
    assert np.allclose(res.history[-1].contact_forces[0], [0., 2 * h * p],
                       rtol=1e-6)


@pytest.mark.parametrize("ghost", ("auto", 0.))
@pytest.mark.parametrize("method", ("ugimp", "cpgimp"))
def test_gimp_domains_past_a_grid_line_in_small_strain_as_glued(method,
                                                                ghost):
    """The blocks of the test above 7/3 cells wide on a grid of 4 (free
    sides inside cells), small strain, 6 steps: the stress is that of
    the blocks glued (no contact: 0.0173 off -p), without the ghost
    penalty within 1.25 times that (0.0206).  GIMP's domains keep their
    size in small strain, the pairs' corners follow the displacement
    gradient: the upper body's lowest corners, 0.11 cells into the row
    below, moved with the shape functions there gave the nodes below
    the weight of a sliver 3% thinner than the domains' the internal
    force integrates over, and that row was 0.0237 off (0.0273 without
    the ghost penalty); its side's GIMP weights move them now."""
    h, E, nu, p = .125, 2e6, .3, 4e4
    mesh = MeshQuad.init_tensor(np.linspace(0, 4 * h, 5),
                                np.linspace(0, 12 * h, 13))
    width = 7 / 3 * h
    pts = bodies(mesh, 3, [[(0, width), (0, 6 * h)],
                           [(0, width), (6 * h, 10 * h)]])
    err = []
    for contacts in ([Contact(0, 1)], []):
        res = simulate(mesh, ElementQuad1(), pts, LinearElastic(E, nu),
                       roller_base_and_left_wall, nsteps=6, method=method,
                       loads=[Traction(side_points(pts, "top"), "top",
                                       [0., -p])],
                       contacts=contacts, options=Options(
                           stabilisation=Stabilisation(ghost=ghost)))
        err.append(np.abs(res.points.stress[1, 1] / p + 1).max())
        if contacts:
            upper = res.points.body == 1
            reach = res.points.x[1, upper] - res.points.domain[1, upper]
            assert 6 * h - reach.min() > .1 * h
            assert np.allclose(res.history[-1].contact_forces[0],
                               [0., width * p], rtol=1e-6)
    assert err[1] == pytest.approx(.0173, abs=1e-4)
    assert err[0] < (err[1] + 1e-4 if ghost == "auto" else 1.25 * err[1])


@pytest.mark.parametrize("method", ("mpm", "bspline", "bspline-gimp"))
def test_finite_deformation_stack(method):
    """Finite deformation, the lower block ten times softer: each block's
    Cauchy stress is the load over its current width (the blocks spread
    by different amounts, sliding on the smooth interface)."""
    p = 200.              # 2% strain of the softer block
    res = stack(1.125, 1e5, kinematics="finite", p=p, method=method)
    x, body = res.points.x + res.points.domain, res.points.body
    for b in (0, 1):
        width = x[0, body == b].max()
        assert np.allclose(res.points.stress[1, 1, body == b], -p / width,
                           rtol=1e-3)
    assert x[0, body == 0].max() > x[0, body == 1].max() + 1e-3
    # quadratic Newton once the pressed pairs are settled (the consistent
    # tangent): the last iteration of every step (down to round-off)
    for record in res.history:
        r = record.newton_residuals
        assert r[-2] < 1e-2 and r[-1] < max(10 * r[-2] ** 1.8, 1e-13) \
            and r[-1] < 1e-10


@pytest.mark.parametrize("method", (
    "mpm", "bspline", pytest.param("bspline-gimp", marks=pytest.mark.slow)))
def test_bodies_apart_inside_a_cell_do_not_interact(method):
    """A block a quarter cell above another, in the cell the lower one
    reaches (and with B-splines, whose supports reach a row of nodes
    further, in the nodes both reach): in free fall (dynamics) it falls
    at g exactly while the gap closes, no contact force; glued (no
    contact) the shared nodes hold it."""
    h = .25
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5),
                                np.arange(0, 2 + h / 2, h))
    pts = bodies(mesh, 4, [[(0, 1), (0, 1.)], [(.25, .75), (1. + h / 4, 1.5)]])
    dt, T = .01, .1                         # the gap closes at 0.113 s
    args = (mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
            lambda b: b.get_dofs(lambda x: x[1] == 0).all())
    kwargs = dict(body_force=BodyForce([0., -G * 1e3], ramp=False),
                  dynamics=Dynamics(time_step=dt, duration=T, density=1e3),
                  method=method)
    res = simulate(*args, contacts=[Contact(0, 1)], **kwargs)
    upper = res.points.body == 1
    v = res.points.velocity[1, upper]
    assert np.allclose(v, -G * T, rtol=1e-9)
    assert all(not r.contact_forces.any() for r in res.history)
    glued = simulate(*args, **kwargs)
    assert np.abs(glued.points.velocity[1, upper]).mean() < .5 * G * T


@pytest.mark.slow
@pytest.mark.parametrize("method", ["mpm", "bspline", "bspline-gimp"])
def test_a_block_slides_on_a_body_by_coulomb(method):
    """A block on an elastic slab, gravity tilted by theta (the inclined
    plane turned level), mu = 0.3 between them: it slides with
    g (sin theta - mu cos theta) (dynamics) within 2% (0.05% measured
    with each method), the slab's friction force mu times its normal
    force."""
    rho, mu = 1e3, .3
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(-.2, .6, 9))
    pts = bodies(mesh, 2, [lambda x: x[1] < 0.,
                           lambda x: (x[0] > .2) & (x[0] < .6) & (x[1] > 0.)
                           & (x[1] < .2)])
    theta, T = np.arctan(mu) + .15, .3
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e7, .3),
                   lambda b: b.get_dofs(lambda x: x[1] < -.19).all(),
                   body_force=BodyForce(G * rho * np.array(
                       [np.sin(theta), -np.cos(theta)]), ramp=False),
                   kinematics="finite", method=method,
                   dynamics=Dynamics(time_step=.01, duration=T, density=rho),
                   contacts=[Contact(0, 1, friction=mu)])
    block = res.points.body == 1
    x = res.points.displacement[0, block].mean()
    expected = G * (np.sin(theta) - mu * np.cos(theta))
    assert abs(x / (.5 * expected * T ** 2) - 1) < .02
    force = np.array([r.contact_forces[0] for r in res.history])
    pressed = force[:, 1] > 0
    # (to 1e-3: the normals of the pairs at the block's edges lean)
    assert np.allclose(force[pressed, 0], -mu * force[pressed, 1], rtol=2e-3)


@pytest.mark.slow
def test_a_spline_block_sliding_at_25_degrees_settles_its_rounds():
    """A user trial: the block of the test above, its sides inside cells
    (x from 0.35 to 0.75, h = 0.1), on the slab at 25 degrees, mu = 0.3,
    the quadratic B-splines: its eight pairs along four cells are more
    than the splines' relative normal motions (six) can close, a
    penetration of 1.9e-9 stayed in every round while the multipliers
    drifted, and the run failed at step 5 (``UnsettledContactError``
    after 30 rounds at every cut-back; the penalty 100 times the default
    ran).  It slides as Coulomb's block to 0.054% in 0.3 s, in 39
    rounds over the 30 steps."""
    rho, mu = 1e3, .3
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(-.2, .6, 9))
    pts = bodies(mesh, 2, [lambda x: x[1] < 0.,
                           lambda x: (x[0] > .35) & (x[0] < .75)
                           & (x[1] > 0.) & (x[1] < .2)])
    theta, T = np.radians(25.), .3
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e7, .3),
                   lambda b: b.get_dofs(lambda x: x[1] < -.19).all(),
                   body_force=BodyForce(G * rho * np.array(
                       [np.sin(theta), -np.cos(theta)]), ramp=False),
                   kinematics="finite", method="bspline",
                   dynamics=Dynamics(time_step=.01, duration=T, density=rho),
                   contacts=[Contact(0, 1, friction=mu)])
    x = res.points.displacement[0, res.points.body == 1].mean()
    expected = .5 * G * (np.sin(theta) - mu * np.cos(theta)) * T ** 2
    assert abs(x / expected - 1) < 1e-3
    assert len(res.history) == 30 and res.counters["contact_updates"] < 60


@pytest.mark.slow
@pytest.mark.parametrize("degrees, sticks", [(12., True), (25., False)])
def test_friction_between_bodies_holds_a_block_quasi_statically(degrees,
                                                                sticks):
    """Gravity tilted on a block resting on a slab, mu = 0.3, the block
    held by the contact alone: below arctan(mu) it sticks, the contact
    force is its weight; above it no equilibrium exists and the run says
    so (an MPMError carrying the last converged state)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9), np.linspace(0, 1, 5))
    pts = bodies(mesh, 2, [[(0, 2), (0, .5)], [(.5, 1.), (.5, .75)]])
    theta, rho = np.radians(degrees), 2e3
    weight = G * rho * np.array([np.sin(theta), -np.cos(theta)])
    run = dict(args=(mesh, ElementQuad1(), pts, LinearElastic(5e6, .3),
                     lambda b: b.get_dofs(lambda x: x[1] == 0).all()),
               kwargs=dict(body_force=weight, nsteps=2,
                           contacts=[Contact(0, 1, friction=.3)],
                           options=Options(NewtonOptions(max_cutbacks=2))))
    if not sticks:
        from skfem_mpm.errors import MPMError
        with pytest.raises(MPMError) as err:
            simulate(*run["args"], **run["kwargs"])
        assert err.value.state is not None
        return
    res = simulate(*run["args"], **run["kwargs"])
    block = res.points.body == 1
    total = weight * res.points.volume0[block].sum()
    # the slab pushes the block up and back: the force of body 0 on body 1
    assert np.allclose(res.history[-1].contact_forces[0], -total, rtol=1e-6)
    assert np.abs(res.points.displacement[0, block]).max() < 1e-3


def tilted_block_on_slab(caplog, held: bool):
    """The error and logged cut-backs of the block on a slab (mu = 0.3)
    under gravity tilted 25 degrees, quasi-static; ``held``: the block's
    left side also on a support in x, in finite deformation with Newton
    given one iteration a solve and a tolerance that asks two in the
    last, so that the step fails all the same."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9), np.linspace(0, 1, 5))
    pts = bodies(mesh, 2, [[(0, 2), (0, .5)], [(.5, 1.), (.5, .75)]])
    theta, rho = np.radians(25.), 2e3
    weight = G * rho * np.array([np.sin(theta), -np.cos(theta)])

    def supports(b):
        base = b.get_dofs(lambda x: x[1] == 0).all()
        side = b.get_dofs(lambda x: (x[0] == .5) & (x[1] > .6)).all("u^1")
        return np.concatenate([base, side]) if held else base
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="skfem_mpm.solve.core"):
        with pytest.raises(MPMError) as failed:
            simulate(mesh, ElementQuad1(), pts, LinearElastic(5e6, .3),
                     supports, body_force=weight, nsteps=2,
                     kinematics="finite" if held else "small",
                     contacts=[Contact(0, 1, friction=.3)],
                     options=Options(NewtonOptions(
                         max_iter=1 if held else 25,
                         tol=1e-13 if held else 1e-9,
                         max_cutbacks=1 if held else 8)))
    return str(failed.value), [r.getMessage() for r in caplog.records
                               if "cutting the" in r.getMessage()]


def test_a_block_held_by_a_contact_alone_past_mu_is_not_cut_back(caplog):
    """The block on a slab under gravity tilted past mu (tan 25 degrees
    = 1.554 mu), held by the contact alone: no load factor has an
    equilibrium, and the run stops at its first failure where it cut the
    step back 8 times in vain (2.1 s, now 0.5 s; trial 64's obstacle
    case alike).  Held also by a support (failing by a Newton limit), it
    is cut back as before, and not said to have no equilibrium.  The
    error opens with the cause (a user trial's read Newton's words first
    and the ratio last)."""
    message, cut_backs = tilted_block_on_slab(caplog, held=False)
    assert not cut_backs
    assert "not cut back: the loads keep their direction" in message
    assert message.startswith(
        "step 1: the load on body 1 pushes it along its contact '0-1' with "
        "body 0 with {:.3f} times mu".format(np.tan(np.radians(25.)) / .3))
    assert message.index("it slides") < message.index("Newton-Raphson")
    message, cut_backs = tilted_block_on_slab(caplog, held=True)
    assert len(cut_backs) == 1 and "not cut back" not in message
    assert "pushes it along" not in message


@pytest.mark.parametrize("finite", [False, True])
@pytest.mark.parametrize("load", [Traction, Pressure])
def test_a_surface_load_shearing_a_block_past_mu_names_its_ratio(load,
                                                                 finite):
    """The block (0.5 x 0.25) on a slab (mu = 0.3) under its weight, its
    left side pushed along the slab by a traction or a pressure of 5 kPa:
    the load's ratio to mu times the weight is 5e3 x 0.25 / (0.3 x 2e3 g
    x 0.125) = 1.70 and no step has an equilibrium.  The error said
    nothing of friction after 8 cut-backs (a user trial: the hint summed
    body forces and point forces alone); now it names the ratio, and the
    step is not cut back (but for a pressure that follows the surface:
    its direction may change with the load factor)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9), np.linspace(0, 1, 5))
    pts = bodies(mesh, 2, [[(0, 2), (0, .5)], [(.5, 1.), (.5, .75)]])
    rho, mu, push = 2e3, .3, 5e3
    left = side_points(pts, "left", pts.body == 1)
    with pytest.raises(MPMError) as failed:
        simulate(mesh, ElementQuad1(), pts, LinearElastic(5e6, .3),
                 lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
                 body_force=[0., -G * rho], nsteps=2,
                 kinematics="finite" if finite else "small",
                 loads=[load(left, "left", [push, 0.] if load is Traction
                             else push)],
                 contacts=[Contact(0, 1, friction=mu)])
    ratio = push * .25 / (mu * rho * G * .5 * .25)
    assert ("not cut back: the loads keep their direction" in
            str(failed.value)) is not (finite and load is Pressure)
    assert "the load on body 1 pushes it along its contact '0-1' with " \
        "body 0 with {:.3f} times mu".format(ratio) in str(failed.value)


def test_a_block_past_mu_towards_a_lip_of_its_slab_is_cut_back():
    """The block on a slab at 25 degrees, the slab rising in a lip 0.3
    downhill of it (beyond the interface's pairs, which are flat): the
    block may slide onto the lip and rest, so a failed step (Newton
    limited to 6 iterations) is cut back, not stopped as having no
    equilibrium (a review's set-up)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 17), np.linspace(0, 1, 9))
    pts = bodies(mesh, 2, [
        lambda x: (x[1] < .5) | ((x[0] > 1.3) & (x[0] < 1.5)
                                 & (x[1] < .75)),
        [(.5, 1.), (.5, .75)]])
    theta = np.radians(25.)
    weight = G * 2e3 * np.array([np.sin(theta), -np.cos(theta)])
    with pytest.raises(MPMError) as failed:
        simulate(mesh, ElementQuad1(), pts, LinearElastic(5e6, .3),
                 lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
                 body_force=weight, contacts=[Contact(0, 1, friction=.3)],
                 options=Options(NewtonOptions(max_iter=6, max_cutbacks=1)))
    assert "not cut back" not in str(failed.value)
    assert "no convergence down to" in str(failed.value)


def test_a_block_past_mu_a_traction_holds_back_is_cut_back():
    """The block on a slab at 25 degrees (1.554 mu) held back by a
    traction on its downhill side (ramped, 2000 N/m: the load along the
    interface 0.80 mu of the force pressing it), finite deformation,
    Newton limited to two iterations: the contact's load leaves surface
    loads out, so such a body is not judged, and its failed step is cut
    back and converges (a review: the run stopped, "no equilibrium")."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9), np.linspace(0, 1, 5))
    pts = bodies(mesh, 2, [[(0, 2), (0, .5)], [(.5, 1.), (.5, .75)]])
    theta = np.radians(25.)
    weight = G * 2e3 * np.array([np.sin(theta), -np.cos(theta)])
    right = side_points(pts, "right", pts.body == 1)
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(7e4, .3),
                   lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
                   body_force=weight, kinematics="finite",
                   loads=[Traction(right, "right", [-2e3, 0.])],
                   contacts=[Contact(0, 1, friction=.3)],
                   options=Options(NewtonOptions(max_iter=2)))
    assert res.history[-1].load_factor == 1.
    assert len(res.history) > 1         # cut back: the one step asked split


def test_three_stacked_bodies_in_contact():
    """Three blocks, each pair in contact (three fields): the stress is
    uniform, each interface carries the load."""
    assert body_fields([(0, 1), (1, 2), (0, 2)], 3).tolist() == [0, 1, 2]
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2.5, 11))
    pts = bodies(mesh, 2, [[(0, 1), (0, 1.)], [(0, 1), (1., 1.5)],
                           [(0, 1), (1.5, 2.)]])
    top = side_points(pts, "top")
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e4, .3),
                   roller_base_and_left_wall,
                   loads=[Traction(top, "top", [0., -10.])],
                   contacts=[Contact(0, 1, tolerance=1e-9),
                             Contact(1, 2, tolerance=1e-9),
                             Contact(0, 2, tolerance=1e-9)],
                   options=Options(NewtonOptions(tol=1e-10)))
    assert np.abs(res.points.stress[1, 1] + 10.).max() < 1e-6 * 10.
    forces = res.history[-1].contact_forces[:, 1]
    assert np.allclose(forces, [10., 10., 0.], atol=1e-8)


def test_two_contacts_between_the_same_fields_act_as_one_interface():
    """Bodies 1 and 2 glued (no contact between them), each in contact
    with body 0 (the upper, 2, never touching it): one interface between
    fields {0} and {1, 2}, as bodies 1 and 2 made one (refused before:
    "join the same two groups").  Contacts that disagree are refused,
    saying which value differs."""
    assert body_fields([(0, 1), (0, 2)], 3).tolist() == [0, 1, 1]
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2.5, 11))
    pts = bodies(mesh, 2, [[(0, 1), (0, 1.)], [(0, 1), (1., 1.5)],
                           [(0, 1), (1.5, 2.)]])
    top = side_points(pts, "top")
    p = 10.
    one = pts.copy()
    one.body[one.body == 2] = 1

    def run(points, contacts):
        return simulate(mesh, ElementQuad1(), points,
                        LinearElastic(1e4, .3), roller_base_and_left_wall,
                        loads=[Traction(top, "top", [0., -p])],
                        contacts=contacts,
                        options=Options(NewtonOptions(tol=1e-10)))
    two = run(pts, [Contact(0, 1, tolerance=1e-9),
                    Contact(2, 0, tolerance=1e-9)])
    glued = run(one, [Contact(0, 1, tolerance=1e-9)])
    assert np.abs(two.points.stress[1, 1] + p).max() < 1e-6 * p
    # the force of each contact's first body on its second: 0 on 1 holds
    # the load p (the width is 1); 2 never touches 0
    width = 1.
    assert np.allclose(two.history[-1].contact_forces,
                       [[0., p * width], [0., 0.]], atol=1e-8)
    assert np.allclose(two.points.displacement, glued.points.displacement,
                       rtol=0., atol=1e-12)
    with pytest.raises(InvalidInputError, match=re.escape(
            "contacts '0-1' and '2-0' join the same two groups of glued "
            "bodies ([0] and [1, 2]) with different friction (0.0 and "
            "0.3)")):
        run(pts, [Contact(0, 1), Contact(2, 0, friction=.3)])
    with pytest.raises(InvalidInputError, match=r"tolerance \(0.001 and "
                       r"0.01\), penalty \(10.0 and 20.0\)"):
        run(pts, [Contact(0, 1), Contact(2, 0, tolerance=1e-2,
                                         penalty=20.)])


def test_a_pile_glued_to_its_cap_carries_the_cap_s_load_into_the_soil():
    """A user trial's pile (body 1, elastic, its sides on grid lines) in
    elastic soil (body 0), with a wider cap (body 2) glued to its head
    half a metre above the soil, rough contacts of the soil with both:
    refused before (with the pile's contact alone, "glued through body
    2"; with both, "join the same two groups").  The cap driven down as
    a rigid body: the soil's force on the pile is the cap's force to
    round-off, the cap's contact carries nothing.  The cap pushed by
    point forces: the pile settles as the pile and cap made one body."""
    from skfem_mpm import RigidBody
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9),
                                np.linspace(0, 2.25, 10))
    surface, head = 1.25, 1.75

    def pile(x):
        return (np.abs(x[0] - 1.) < .25) & (x[1] > .5) & (x[1] < head)
    pts = bodies(mesh, 2, [lambda x: (x[1] < surface) & ~pile(x), pile,
                           lambda x: (np.abs(x[0] - 1.) < .5)
                           & (x[1] > head) & (x[1] < head + .25)])
    cap = pts.body == 2
    assert (pts.x[1] - pts.domain[1])[cap].min() - surface == .5

    def fixed(b):
        return np.union1d(b.get_dofs(lambda x: x[1] == 0).all(),
                          b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 2))
                          .nodal["u^1"])
    soil, stiff = LinearElastic(1e4, .3), LinearElastic(1e7, .2)
    rough = [Contact(0, 1, friction="rough"),
             Contact(0, 2, friction="rough")]
    with pytest.raises(InvalidInputError, match="glued through body 2.*"
                       "Contact\\(0, 2\\) too"):
        simulate(mesh, ElementQuad1(), pts, [soil, stiff, stiff], fixed,
                 loads=[RigidBody(2, [0., -.01])], contacts=rough[:1])
    res = simulate(mesh, ElementQuad1(), pts, [soil, stiff, stiff], fixed,
                   nsteps=2, loads=[RigidBody(2, [0., -.01])],
                   contacts=rough)
    for record in res.history:
        soil_on_pile, soil_on_cap = record.contact_forces
        push = record.rigid_forces[0]
        assert soil_on_pile[1] > 0. and (soil_on_cap == 0.).all()
        assert np.abs(soil_on_pile + push).max() < 1e-12 * soil_on_pile[1]
    load = 100.
    on_top = cap & (pts.x[1] > head + .125)
    pts.force[1, on_top] = -load / on_top.sum()
    two = simulate(mesh, ElementQuad1(), pts, [soil, stiff, stiff], fixed,
                   nsteps=2, contacts=rough)
    one = pts.copy()
    one.body[cap] = 1
    glued = simulate(mesh, ElementQuad1(), one, [soil, stiff], fixed,
                     nsteps=2, contacts=rough[:1])
    for a, b in zip(two.history, glued.history):
        assert np.allclose(a.contact_forces[0], b.contact_forces[0],
                           rtol=1e-12, atol=1e-12 * load)
        assert np.allclose(a.contact_forces[0],
                           [0., a.load_factor * load], atol=1e-9 * load)
    scale = np.abs(two.points.displacement).max()
    assert scale > 0. and np.abs(two.points.displacement
                                 - glued.points.displacement).max() \
        < 1e-12 * scale


def test_a_footing_of_two_materials_on_soil_shares_its_load():
    """A footing of two glued bodies side by side (1 stiff, 2 softer) on
    soil (body 0), rough contacts with both, the second declared the
    other way round: the two contacts' forces add up to the load on the
    footing (the second's the soil's on body 2, so of opposite sign),
    and equal the same footing made one body."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9),
                                np.linspace(0, 1.5, 7))
    pts = bodies(mesh, 2, [[(0, 2), (0, 1.)], [(.5, 1.), (1., 1.25)],
                           [(1., 1.5), (1., 1.25)]])
    top = side_points(pts, "top")
    top = top[pts.body[top] > 0]
    q, width = 20., 1.

    def run(points, materials, contacts):
        return simulate(mesh, ElementQuad1(), points, materials,
                        roller_base_and_left_wall, nsteps=1,
                        loads=[Traction(top, "top", [0., -q])],
                        contacts=contacts,
                        options=Options(NewtonOptions(tol=1e-10)))
    soil = LinearElastic(1e4, .3)
    rough = [Contact(0, 1, friction="rough"),
             Contact(2, 0, friction="rough")]
    two = run(pts, [soil, LinearElastic(1e6, .2), LinearElastic(1e5, .2)],
              rough)
    forces = two.history[-1].contact_forces
    assert forces[0, 1] > 0. and forces[1, 1] < 0.
    assert abs(forces[0, 1] - forces[1, 1] - q * width) < 1e-8 * q
    one = pts.copy()
    one.body[one.body == 2] = 1
    same = run(one, [soil, LinearElastic(1e6, .2)], rough[:1])
    mixed = run(pts, [soil, LinearElastic(1e6, .2), LinearElastic(1e6, .2)],
                rough)
    total = mixed.history[-1].contact_forces[0] \
        - mixed.history[-1].contact_forces[1]
    assert np.allclose(total, same.history[-1].contact_forces[0],
                       rtol=1e-12, atol=1e-12 * q)
    assert np.allclose(mixed.points.displacement, same.points.displacement,
                       rtol=0., atol=1e-12)


def test_glued_blocks_side_by_side_each_report_their_own_load():
    """Two blocks glued side by side (1 left, 2 right, meeting at
    ``x = s``) on a third (body 0), pressed by ``p``, the second
    contact declared the other way round: each contact's force is the
    load on its own block, ``p s`` and ``p (1 - s)`` (the stress is
    uniform), and the two add up to the load.  With the blocks meeting
    on a grid node (s = 0.5) the pair there went whole to the second
    block: 3.75 and 6.25 for 5 and 5 (mpm and cpGIMP)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2.5, 11))
    p = 10.
    for s, method in ((.5, "mpm"), (.5, "cpgimp"), (.375, "mpm")):
        pts = bodies(mesh, 2, [[(0, 1), (0, 1.)], [(0, s), (1., 2.)],
                               [(s, 1), (1., 2.)]])
        top = side_points(pts, "top")
        res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e4, .3),
                       roller_base_and_left_wall, method=method,
                       loads=[Traction(top, "top", [0., -p])],
                       contacts=[Contact(0, 1, tolerance=1e-9),
                                 Contact(2, 0, tolerance=1e-9)],
                       options=Options(NewtonOptions(tol=1e-10)))
        assert np.abs(res.points.stress[1, 1] + p).max() < 1e-6 * p
        forces = res.history[-1].contact_forces
        assert np.allclose(forces, [[0., p * s], [0., -p * (1. - s)]],
                           rtol=0., atol=1e-6 * p), (s, method, forces)
        assert abs(forces[0, 1] - forces[1, 1] - p) < 1e-12 * p


@pytest.mark.slow
def test_a_cap_glued_to_its_pile_above_the_soil_reports_no_force():
    """A user trial's pile (body 1, two cells wide, on grid lines) in
    Tresca soil (body 0) with a wider cap (body 2) glued to its head, a
    cell above the soil, cpGIMP, 8 steps of a traction of 40 on the cap
    (20 in all): the soil yields, and at step 8 pairs of the cap's far
    corners and the soil's corners beside the pile's head along inclined
    normals carried 1.39 of the 20, reported as the soil's force on the
    cap, 0.7 cells above it.  The cap's contact reports nothing at every
    step, the pile's the whole load."""
    from skfem_mpm import MohrCoulomb
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 17),
                                np.linspace(0, 1.5, 13))

    def pile(x):
        return (np.abs(x[0] - 1.) < .125) & (x[1] > .5) & (x[1] < 1.125)
    pts = bodies(mesh, 2, [lambda x: (x[1] < 1.) & ~pile(x), pile,
                           lambda x: (np.abs(x[0] - 1.) < .25)
                           & (x[1] > 1.125) & (x[1] < 1.25)])
    top = side_points(pts, "top", select=pts.body == 2)
    stiff = LinearElastic(1e7, .2)
    res = simulate(mesh, ElementQuad1(), pts,
                   [MohrCoulomb(1e4, .3, cohesion=3., friction_angle=0.),
                    stiff, stiff],
                   lambda b: np.union1d(
                       b.get_dofs(lambda x: x[1] == 0).all(),
                       b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 2))
                       .nodal["u^1"]),
                   loads=[Traction(top, "top", [0., -40.])], nsteps=8,
                   method="cpgimp",
                   contacts=[Contact(0, 1), Contact(0, 2)])
    cap = res.points.body == 2
    above = (res.points.x[1] - res.points.domain[1])[cap].min() - 1.
    assert above > .08                       # 0.7 cells (h = 0.125)
    for record in res.history:
        on_pile, on_cap = record.contact_forces
        assert np.abs(on_cap).max() < 1e-12 * 20.
        assert on_pile == pytest.approx([0., 20. * record.load_factor],
                                        rel=1e-9, abs=1e-9)


def full_and_resumed(args, kwargs, after):
    """The run of ``simulate(*args, **kwargs)`` whole, and resumed after
    step ``after`` from its points and record there."""
    kept = {}

    def keep(record, points):
        if record.step == after:
            kept["record"], kept["points"] = record, points.copy()
    full = simulate(*args, options=Options(callback=keep), **kwargs)
    resumed = simulate(*args[:2], kept["points"], *args[3:],
                       options=Options(resume=Resume.after(
                           kept["record"], args[2].domain)), **kwargs)
    return full, resumed


@pytest.mark.parametrize("method", [
    "mpm", pytest.param("bspline", marks=pytest.mark.slow)])
def test_resume_is_bit_identical(method):
    """Resumed after step 2 of 4 from the points and the record, the run
    ends where the whole run does, to the bit (with B-splines the domain
    corners' offsets the contact moves come back with the points)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2.5, 11))
    pts = bodies(mesh, 2, [[(0, 1), (0, 1.)], [(0, 1), (1., 2.)]])
    top = side_points(pts, "top")
    args = (mesh, ElementQuad1(), pts,
            [VonMises(1e4, .3, 40.), LinearElastic(1e4, .3)],
            roller_base_and_left_wall)
    kwargs = dict(loads=[Traction(top, "top", [0., -50.])], nsteps=4,
                  kinematics="finite", method=method,
                  contacts=[Contact(0, 1, friction=.2)])
    full, resumed = full_and_resumed(args, kwargs, 2)
    assert np.array_equal(full.points.x, resumed.points.x)
    assert np.array_equal(full.points.stress, resumed.points.stress)
    assert np.array_equal(full.history[-1].contact_forces,
                          resumed.history[-1].contact_forces)


def two_blocks():
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2, 9))
    return mesh, bodies(mesh, 2, [[(0, 1), (0, 1.)], [(0, 1), (1., 1.5)]])


@pytest.mark.parametrize("contacts, kwargs, words", [
    ([Contact(0, 2)], {}, "body 2 does not exist"),
    ([Contact(1, 1)], {}, "with itself"),
    ([Contact(0, 1), Contact(1, 0)], {}, re.escape(
        "contacts '0-1' and '1-0' are both between bodies 0 and 1: a pair "
        "of bodies has one contact")),
    ([Contact("soil", 1)], {}, "no body named 'soil'"),
    ([Contact(0, 1)], {"method": "fem"}, "'fem' keeps them"),
    (["0-1"], {}, "Contact items"),
    (Contact(0, 1), {}, re.escape(
        "contacts must be a list of Contact items, got one Contact: pass "
        "contacts=[Contact(0, 1, friction=0.0)]")),
    (5, {}, "contacts must be a list of Contact items, got int"),
])
def test_mistakes_are_refused(contacts, kwargs, words):
    """A user trial: the pair declared twice was not named, and one
    Contact not in a list ended in a TypeError."""
    mesh, pts = two_blocks()
    with pytest.raises(InvalidInputError, match=words):
        simulate(mesh, ElementQuad1(), pts, LinearElastic(1e4, .3),
                 lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
                 body_force=[0., -1.], contacts=contacts, **kwargs)


@pytest.mark.parametrize("make, words", [
    (lambda: Contact(0, 1, friction="tied"), "glued: declare no contact"),
    (lambda: Contact(0, 1, friction=-1.), "finite and >= 0"),
    (lambda: Contact(0, 1, tolerance=2.), "tolerance in"),
    (lambda: Contact(0., 1), "body index"),
    (lambda: Contact(0, -1), re.escape(
        "Contact second body must be a body index (>= 0) or name, got -1")),
    (lambda: Contact(np.int64(-2), 1), "got -2"),
])
def test_bad_contacts_are_refused(make, words):
    """A negative body index is refused where it is given (a user trial's
    contact was named '0--1' and refused as a body that does not
    exist)."""
    with pytest.raises(InvalidInputError, match=words):
        make()


def test_contacts_of_one_interface_alike_at_single_precision_are_one():
    """A user trial: a pile's and its glued cap's contacts with the soil
    (one interface), friction 0.3 given as ``numpy.float32`` on one and
    a float on the other, were refused as two frictions; they are alike
    at single precision, and differ beyond it."""
    from skfem_mpm.solve.body_contact import check_contacts
    field = check_contacts([Contact(0, 1, friction=np.float32(.3)),
                            Contact(0, 2, friction=.3)], 3)[1]
    assert field.tolist() == [0, 1, 1]
    with pytest.raises(InvalidInputError, match=re.escape(
            "different friction (0.3 and 0.3001)")):
        check_contacts([Contact(0, 1, friction=.3),
                        Contact(0, 2, friction=.3001)], 3)


def test_a_pair_glued_through_a_third_body_is_refused():
    with pytest.raises(InvalidInputError, match="glued through body 2"):
        body_fields([(0, 1)], 3)


def test_overlapping_bodies_and_grid_loads_are_refused():
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2, 9))
    pts = bodies(mesh, 2, [[(0, 1), (0, 1.)], [(0, 1), (.75, 1.5)]])
    fixed = (lambda b: b.get_dofs(lambda x: x[1] == 0).all())
    with pytest.raises(InvalidInputError, match="overlap at the start by "
                       "0.25"):
        simulate(mesh, ElementQuad1(), pts, LinearElastic(1e4, .3), fixed,
                 body_force=[0., -1.], contacts=[Contact(0, 1)])
    mesh, pts = two_blocks()
    from skfem import LinearForm
    load = GridLoad(LinearForm(lambda v, w: v[1]))
    with pytest.raises(InvalidInputError, match="GridLoad"):
        simulate(mesh, ElementQuad1(), pts, LinearElastic(1e4, .3), fixed,
                 loads=[load], contacts=[Contact(0, 1)])
    with pytest.raises(UnsupportedElementError, match="vertices only"):
        simulate(mesh, ElementQuad2(), pts, LinearElastic(1e4, .3), fixed,
                 body_force=[0., -1.], contacts=[Contact(0, 1)])


@pytest.mark.parametrize("method", ("mpm", "cpgimp", "bspline",
                                    "bspline-gimp"))
def test_uniform_stress_across_an_interface_in_3d(method):
    from skfem import ElementHex1, MeshHex
    mesh = MeshHex.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3),
                               np.linspace(0, 2.5, 6))
    pts = bodies(mesh, 2, [[(0, 1), (0, 1), (0, 1.)],
                           [(0, 1), (0, 1), (1., 2.)]])
    top = side_points(pts, "z+")

    def rollers(b):
        return np.concatenate([b.get_dofs(lambda x: x[a] == 0).nodal[
            "u^{}".format(a + 1)] for a in range(3)])
    res = simulate(mesh, ElementHex1(), pts,
                   [LinearElastic(1e4, .3), LinearElastic(1e6, .3)], rollers,
                   method=method,
                   loads=[Traction(top, "z+", [0., 0., -10.])],
                   contacts=[Contact(0, 1, tolerance=1e-9)],
                   options=Options(NewtonOptions(tol=1e-10)))
    s = res.points.stress
    assert np.abs(s[2, 2] + 10.).max() < 1e-6 * 10.
    assert np.abs(s[:2, :2]).max() < 1e-6 * 10.
    assert np.allclose(res.history[-1].contact_forces[0], [0., 0., 10.],
                       atol=1e-8)


STACK_SCENE = """
name = "two blocks pressed together"
[grid]
x = [0.0, 1.0, 4]
y = [0.0, 2.5, 10]
[[bodies]]
name = "base"
region = {{ x = [0.0, 1.0], y = [0.0, 1.0] }}
material = {{ model = "linear_elastic", E = 1e4, nu = 0.3 }}
[[bodies]]
name = "block"
region = {{ x = [0.0, 1.0], y = [1.0, 2.0] }}
material = {{ model = "linear_elastic", E = 1e6, nu = 0.3 }}
[[supports]]
boundary = "bottom"
components = ["y"]
[[supports]]
boundary = "left"
components = ["x"]
[[tractions]]
body = "block"
side = "top"
traction = [0.0, -10.0]
[[contacts]]
{contact}
[solver]
steps = 2
"""


@pytest.mark.slow
def test_a_scene_with_a_contact(tmp_path):
    """``[[contacts]]`` between named bodies: the force between them per
    step in summary.json (the load at each step) and its picture; a name
    the scene lacks is named."""
    import json

    from skfem_mpm.cli import main
    from skfem_mpm.errors import SceneError
    from skfem_mpm.scenes.scene_file import load_scene
    path = tmp_path / "stack.toml"
    path.write_text(STACK_SCENE.format(
        contact='first = "base"\nsecond = "block"\ntolerance = 1e-9'))
    assert main(["run", str(path), "--out", str(tmp_path / "out"),
                 "--no-progress"]) == 0       # the grid series on one grid
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    force = np.array(summary["contacts"]["base-block"]["force"])
    assert np.allclose(force, [[0., 5.], [0., 10.]], atol=1e-8)
    # a contact has no displacement of its own (its entries were zeros)
    assert "displacement" not in summary["contacts"]["base-block"]
    assert (tmp_path / "out" / "contacts.png").stat().st_size > 0
    # interrupted after a step and resumed from its checkpoint (the small
    # strain gradient the contact keeps comes back): the same forces
    split = tmp_path / "split"
    assert main(["run", str(path), "--out", str(split), "--no-progress",
                 "--checkpoint-every", "1", "--max-steps", "1"]) == 0
    assert main(["run", "--resume", str(split), "--no-progress"]) == 0
    resumed = json.loads((split / "summary.json").read_text())
    assert resumed["contacts"]["base-block"]["force"] == force.tolist()
    path.write_text(STACK_SCENE.format(
        contact='first = "base"\nsecond = "pile"'))
    with pytest.raises(SceneError, match=r"contacts\[0\].second: must name "
                       "a body \\(base, block\\)"):
        load_scene(path)


@pytest.mark.parametrize("interface", (
    .9, pytest.param(1., marks=pytest.mark.slow)))
@pytest.mark.parametrize("method", ("mpm", "cpgimp"))
def test_load_steps_do_not_change_a_linear_answer(method, interface):
    """Two blocks squeezed by a ram (a prescribed displacement of the top
    nodes), small strain, linear elastic, the interface inside a cell or
    on a grid line: one step or three give the glued blocks' stress to
    2e-4 (measured 6.8e-5; with cpGIMP on a grid line, whose domains
    reach a sliver of the cells across it on their own field, 8.9e-4
    and 9% without the ghost penalty while the pairs' corners moved
    with their points' cells there, extrapolated; domains that did not
    follow the strain drifted by 2-6%)."""
    from skfem_mpm import Prescribed

    def ram(b, f_old, f_new):
        d = b.get_dofs(lambda x: x[1] == 2).nodal["u^2"]
        return d, np.full(d.size, -.01 * (f_new - f_old))
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2, 9))
    pts = bodies(mesh, 2, [[(0, 1), (0, interface)],
                           [(0, 1), (interface, 2)]])
    mean = {}
    for steps in (1, 3):
        for contacts in ((), (Contact(0, 1, tolerance=1e-9),)):
            res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e4, .3),
                           roller_base_and_left_wall, nsteps=steps,
                           loads=[Prescribed(ram)], method=method,
                           contacts=list(contacts))
            mean[steps, bool(contacts)] = res.points.stress[1, 1].mean()
    glued = mean[1, False]
    for key, value in mean.items():
        assert abs(value / glued - 1) < 2e-4, key


@pytest.mark.slow
def test_a_block_given_a_speed_slides_to_coulombs_stop():
    """A block given 1 m/s on a slab, mu = 0.3 (dynamics): it slides
    v0^2 / (2 mu g) = 0.17 m and stops at v0 / (mu g) = 0.34 s, to 2%
    (measured 0.1699, Coulomb's to 1e-4), as its edges cross grid nodes (a
    pair with a leaning normal at an edge once stopped it 12% short)."""
    v0, mu, rho = 1., .3, 1e3
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(-.2, .6, 9))
    pts = bodies(mesh, 2, [[(0, 2), (-.2, 0)], [(.2, .6), (0, .2)]])
    pts.velocity = np.zeros((2, pts.n))
    pts.velocity[0, pts.body == 1] = v0
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e7, .3),
                   lambda b: b.get_dofs(lambda x: x[1] < -.19).all(),
                   body_force=BodyForce([0, -G * rho], ramp=False),
                   kinematics="finite",
                   dynamics=Dynamics(time_step=.02, duration=.4, density=rho),
                   contacts=[Contact(0, 1, friction=mu)])
    block = res.points.body == 1
    slid = res.points.displacement[0, block].mean()
    assert slid == pytest.approx(v0 ** 2 / (2 * mu * G), rel=.02)
    assert np.abs(res.points.velocity[:, block]).max() < .02 * v0


def slide_balance(dt):
    """A block 0.4 x 0.2 given 1 m/s on a slab, mu = 0.3, till it rests
    (dynamics, time steps ``dt``): the balance's loss over the run and
    over its steps from 0.1 s on, relative to the kinetic energy at the
    start (40)."""
    v0, mu, rho = 1., .3, 1e3
    mesh = MeshQuad.init_tensor(np.arange(0, 1.65, .1),
                                np.arange(-.2, .55, .1))
    pts = bodies(mesh, 2, [[(0, 1.6), (-.2, 0)], [(.2, .6), (0, .2)]])
    pts.velocity = np.zeros((2, pts.n))
    pts.velocity[0, pts.body == 1] = v0
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e7, .3),
                   lambda b: b.get_dofs(lambda x: x[1] < -.19).all(),
                   body_force=[0, -G * rho], kinematics="finite",
                   dynamics=Dynamics(time_step=dt, duration=.4, density=rho),
                   contacts=[Contact(0, 1, friction=mu)])
    E = res.energies()
    later = np.searchsorted(E["time"], .1 - 1e-9)
    return ((E["kinetic"][0] - E["balance"][-1]) / E["kinetic"][0],
            (E["balance"][later] - E["balance"][-1]) / E["kinetic"][0])


def test_a_sliding_block_books_the_work_of_friction():
    """A block sliding to rest on a slab (Coulomb, mu = 0.3): the
    contact's work is booked from the force each step ended with, so the
    energy balance closes: the loss over the run 0.67% at dt = 0.02 and
    0.26% at 0.01, all in the first steps, where the block settles on
    the slab (the scheme's own error at the contact's onset, first order
    in dt), and 2e-4 and 5e-5 after them (from 0.1 s).  Booked from each
    step's start force, the pressures of Newton's predictor and of pairs
    made anew without theirs, it lost 10.9% and 3.7% (5.1% and 0.8% from
    0.1 s; a user trial)."""
    coarse, coarse_later = slide_balance(.02)
    fine, fine_later = slide_balance(.01)
    assert 0 < coarse < .01 and 0 < fine < .5 * coarse
    assert abs(coarse_later) < 1e-3 and abs(fine_later) < 1e-3


def colliding_blocks():
    """Two blocks 0.2 wide, 0.02 apart, the left one at 2 m/s (a
    reviewer's case): the mesh, the points and the run's keywords."""
    mesh = MeshQuad.init_tensor(np.arange(0, 1.2 + 1e-9, .05),
                                np.arange(0, .4 + 1e-9, .05))
    pts = bodies(mesh, 2, [[(.1, .3), (.1, .3)], [(.32, .52), (.1, .3)]])
    pts.velocity = np.zeros((2, pts.n))
    pts.velocity[0, pts.body == 0] = 2.
    return mesh, pts, dict(
        material=LinearElastic(1e6, .3), supports=[],
        kinematics="finite", contacts=[Contact(0, 1)],
        dynamics=Dynamics(time_step=.002, duration=.03, density=1000.))


def test_a_resumed_collision_books_the_contact_s_work_as_its_run():
    """Two blocks colliding, resumed with ``Resume.after(record)`` after
    steps in contact: every energy of every step after, and the points,
    are the straight run's to the bit.  The contact's force where the
    last step ended, which the next books its work from, lived only in
    the run: the resumed first step booked it from its start force
    (internal work 6.6264 for 6.6571 after step 8)."""
    mesh, pts, kw = colliding_blocks()
    kept = {}

    def keep(record, points):
        kept[record.step] = (points.copy(), record)
    straight = simulate(mesh, ElementQuad1(), pts.copy(),
                        options=Options(callback=keep), **kw)
    for k in (8, 11):
        points, record = kept[k]
        assert record.end_force is not None       # in contact
        resumed = simulate(mesh, ElementQuad1(), points.copy(),
                           options=Options(resume=Resume.after(record)),
                           **kw)
        assert [r.energy for r in resumed.history] == \
            [r.energy for r in straight.history[k:]]
        assert np.array_equal(resumed.points.x, straight.points.x)
        assert np.array_equal(resumed.points.stress, straight.points.stress)
    with pytest.raises(InvalidInputError, match="end_force holds 3 "
                       "entries"):
        simulate(mesh, ElementQuad1(), points.copy(), options=Options(
            resume=Resume(first_step=12, load_factor=record.load_factor,
                          end_force=np.zeros(3))), **kw)
    with pytest.raises(InvalidInputError, match="finite 1D float array"):
        Resume(first_step=2, end_force=np.array([np.nan]))


@pytest.mark.slow
def test_a_block_landing_on_a_staircase_gains_no_energy():
    """A tilted block dropped 0.05 onto a slab inclined at 12 degrees,
    both seeded in polygons (staircases of domains), mu = 0.3, dynamics:
    the kinetic energy never exceeds the work of gravity on the block
    (the slab barely moves).  A pair whose corners a leaning normal read
    as 0.13 cells deep at a step's start, where the last step had found
    none, threw the block off with 12 times the energy it fell with; such
    a start penetration is closed now."""
    from matplotlib.path import Path
    theta, rho, h = np.radians(12.), 1e3, .1
    t = np.tan(theta)
    along = np.array([np.cos(theta), np.sin(theta)])
    up = np.array([-np.sin(theta), np.cos(theta)])
    mesh = MeshQuad.init_tensor(np.arange(0, 2 + 1e-9, h),
                                np.arange(0, 1.6 + 1e-9, h))
    corner = np.array([.8, .2 + .8 * t + .05])
    shapes = [[(0, 0), (2, 0), (2, .2 + 2 * t), (0, .2)],
              [corner, corner + .4 * along, corner + .4 * along + .2 * up,
               corner + .2 * up]]
    parts = [seed_points(mesh, 2, region=lambda x, p=Path(shape):
                         p.contains_points(x.T)) for shape in shapes]
    for k, part in enumerate(parts):
        part.body[:] = k
    pts = concatenate_points(parts)
    block = pts.body == 1
    mass = rho * pts.volume[block]
    # per step: the block's drop (its centre of mass) and kinetic energy
    drop, kinetic = [], []

    def watch(record, points):
        drop.append(pts.x[1, block] @ mass - points.x[1, block] @ mass)
        kinetic.append(.5 * mass @ (points.velocity[:, block] ** 2).sum(0))
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e7, .3),
                   lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
                   body_force=BodyForce([0, -G * rho], ramp=False),
                   kinematics="finite",
                   dynamics=Dynamics(time_step=.01, duration=.15,
                                     density=rho),
                   contacts=[Contact(0, 1, friction=.3)],
                   options=Options(callback=watch))
    assert any((r.contact_forces != 0).any() for r in res.history)
    work = G * np.array(drop)            # gravity's work on the block
    assert (np.array(kinetic) <= 1.05 * work + 1e-3).all(), (kinetic, work)


@pytest.mark.slow
def test_a_rough_punch_on_a_plastic_stack_runs_to_its_limit_load():
    """A rough box obstacle (half-width 0.5 on the symmetry line) pushed
    0.05 in 10 steps into two von Mises layers 0.5 thick (c_u = 20 /
    sqrt 3) in Coulomb contact (0.3), standard MPM: full Newton steps fail
    once the layers yield, and the Armijo search that carries the step
    then starts the later ones (before: 25 failed iterations at every
    step, and the run ended at a sixth of the push after cutting back to
    4e-4 of a step).  The punch reaches a limit load: its last three
    forces within 5% of each other, 1-1.5 times Prandtl's (2 + pi) c_u B/2
    on a half-space (measured 1.26: a rough punch on a finite layer)."""
    from skfem_mpm import Obstacle
    from skfem_mpm.studies.user_setups import base_and_rollers
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 17), np.linspace(0, 1.5, 13))
    layers = [seed_points(mesh, 2, region=lambda x, low=low: (x[1] > low)
                          & (x[1] < low + .5)) for low in (0., .5)]
    layers[1].body[:] = 1
    res = simulate(mesh, ElementQuad1(), concatenate_points(layers),
                   VonMises(1e4, .3, 20.), base_and_rollers(2.), nsteps=10,
                   contacts=[Contact(0, 1, friction=.3)],
                   obstacles=[Obstacle(box=[[-1, .5], [1., 1.3]],
                                       displacement=[0, -.05],
                                       friction="rough")])
    assert len(res.history) <= 12
    assert res.counters["line_search_from_step"] > 0
    force = np.array([r.obstacle_forces[0, 1] for r in res.history[-3:]])
    assert np.ptp(force) < .05 * force.mean()
    prandtl = (2 + np.pi) * 20 / np.sqrt(3) * .5
    assert prandtl < force.mean() < 1.5 * prandtl


def hole_in_soil(offset=0.):
    """The grid (h = 0.1), the points of soil 1 deep with a hole two
    cells wide from 0.6 down (its sides and bottom on grid lines, or
    ``offset`` off them, the grid as much wider, so the set-up stays
    mirror-symmetric), the hole's test and the soil's supports."""
    width = 1.4 + 2 * offset
    mesh = MeshQuad.init_tensor(np.linspace(0, width, 15 + (offset > 0)),
                                np.linspace(0, 1.4, 15))

    def hole(x):
        return (x[0] > .6 + offset) & (x[0] < .8 + offset) \
            & (x[1] > .6 + offset)

    def supports(b):
        return np.union1d(b.get_dofs(lambda x: x[1] == 0).all(),
                          b.get_dofs(lambda x: (x[0] == 0) | (x[0] == width))
                          .nodal["u^1"])
    soil = seed_points(mesh, 2, region=lambda x: (x[1] < 1.) & ~hole(x))
    return mesh, soil, hole, supports


def pile_in_soil(friction, penalty=10., tolerance=1e-3, nsteps=2,
                 method="mpm", soil=None, offset=0., load=100., tip=0.):
    """An elastic pile in the hole of :func:`hole_in_soil` (its tip
    ``tip`` above the hole's bottom), 80 times stiffer than the soil it
    stands in (``soil``, linear elastic by default), its own weight 20,
    pushed by ``load`` on its top; returns the mean displacement (dim,)
    of its top's points."""
    mesh, soil_points, hole, supports = hole_in_soil(offset)
    pts = concatenate_points([soil_points, bodies(mesh, 2, [
        lambda x: hole(x) & (x[1] > .6 + offset + tip)
        & (x[1] < 1.2 + offset)])])
    pts.body[soil_points.n:] = 1
    top = np.flatnonzero((pts.body == 1) & (pts.x[1] > 1.15 + offset))

    contacts = [] if friction is None else [
        Contact(0, 1, friction=friction, penalty=penalty,
                tolerance=tolerance)]
    result = simulate(mesh, ElementQuad1(), pts,
                      [soil or LinearElastic(1e4, .3),
                       LinearElastic(1e6, .2)],
                      supports, body_force=[0., -20.], nsteps=nsteps,
                      loads=[Traction(top, "top", [0., -load])],
                      contacts=contacts, method=method)
    return result.points.displacement[:, top].mean(axis=1)


def test_a_pile_one_cell_wide_pulled_with_friction_stays_symmetric():
    """A pile one cell wide (so a node's support holds both its sides'
    corners), mirror-symmetric in soil at rest (K0 = 0.5), pulled up with
    friction 0.3: no sideways force.  A node kept the direction its pile
    corners were pressed along at the last step's end, the sum of the two
    sides' pressures, which cancel to round-off: that direction took x at
    one side's node and the tip's vertical at the other's (here a
    sideways force of 1e-6 to 2e-5 of the pull; the trial's pile, h = 0.28,
    41%)."""
    from skfem_mpm import RigidBody, geostatic_stress, select_points
    h = .25
    mesh = MeshQuad.init_tensor(np.linspace(0, 7 * h, 8),
                                np.linspace(0, 8 * h, 9))
    soil = LinearElastic(1e4, .3)

    def pile(x):
        return (x[0] > 3 * h) & (x[0] < 4 * h) & (x[1] > 3 * h)

    ground = geostatic_stress(seed_points(mesh, 2,
                                          region=lambda x: x[1] < 6 * h),
                              soil, [0., -18.], None, .5)
    ground = select_points(ground, ~pile(ground.x))
    body = seed_points(mesh, 2, region=lambda x: pile(x) & (x[1] < 7 * h))
    body.body[:] = 1

    def supports(basis):
        sides = basis.get_dofs(lambda x: (x[0] == 0) | (x[0] == 7 * h))
        return np.union1d(sides.nodal["u^1"],
                          basis.get_dofs(lambda x: x[1] == 0).all())

    res = simulate(mesh, ElementQuad1(), concatenate_points([ground, body]),
                   [soil, LinearElastic(1e7, .2)], supports,
                   body_force=BodyForce([[0., -18.], [0., 0.]], ramp=False),
                   nsteps=4, loads=[RigidBody(1, [0., .02])],
                   contacts=[Contact(0, 1, friction=.3)])
    for record in res.history:
        force = record.rigid_forces[0]
        assert force[1] > 0.
        assert abs(force[0]) < 1e-9 * force[1]


def test_a_rough_interface_touching_unpressed_holds_in_simple_shear():
    """A rigid slab dragged up along an elastic block in simple shear
    (its far side held, its top and bottom on rollers across),
    weightless: the interface touches and nothing presses it, and the
    rough contact carries the shear ``G d H / L`` as the glued bodies
    do.  Its pairs, touching within the tolerance with no pressure, let
    go after every Newton solve: it carried 0.75 and 0.86 of it in two
    steps and pressed the slab sideways (a rough pile in weightless clay
    carried nothing)."""
    from skfem_mpm import RigidBody
    mesh = MeshQuad.init_tensor(np.linspace(0, 1.5, 7), np.linspace(0, 1, 5))
    points = seed_points(mesh, 2)
    points.body[:] = points.x[0] > 1.

    def supports(basis):
        ends = basis.get_dofs(lambda x: ((x[1] == 0) | (x[1] == 1))
                              & (x[0] <= 1.)).nodal["u^1"]
        return np.union1d(basis.get_dofs(lambda x: x[0] == 0).all(), ends)

    E, nu, drag = 1e4, .3, 1e-3
    res = simulate(mesh, ElementQuad1(), points,
                   [LinearElastic(E, nu), LinearElastic(1e7, .2)], supports,
                   nsteps=2, loads=[RigidBody(1, [0., drag])],
                   contacts=[Contact(0, 1, friction="rough")])
    shear = E / 2 / (1 + nu) * drag * 1. / 1.      # G d H / L
    for record in res.history:
        force = record.rigid_forces[0]
        assert force[1] == pytest.approx(record.load_factor * shear,
                                         rel=1e-3)
        assert abs(force[0]) < 1e-4 * force[1]


@pytest.mark.parametrize("method", [
    "mpm", pytest.param("cpgimp", marks=pytest.mark.slow)])
def test_a_pile_with_friction_on_grid_lines_is_pushed_in(method):
    """A pile with Coulomb friction whose sides lie on grid lines (the
    penalty of the stiffer body made its pairs open and close in turn:
    the run failed at step 1); it does not tilt (the tip's corners took
    different normals by round-off: the top moved sideways by a third of
    its settlement; with cpGIMP, a node inside the pile paired one side
    of it with the soil beyond the other and took the side's own pair's
    place); the answer does not depend on the penalty, lies between a
    frictionless pile's and one with friction 5, and that one is near the
    glued pile's (the glued bodies share the grid's nodes)."""
    u = pile_in_soil(.3, tolerance=1e-5, method=method)
    assert abs(u[0]) < 1e-3 * -u[1]     # the tolerance: 2e-4 of it
    # (GIMP with penalty 1 or 3 takes hundreds of rounds at 1e-5, cuts
    # the step back and ends 2.5% off: its rounds converge slowly)
    for penalty in (1., 100.) if method == "mpm" else (100.,):
        other = pile_in_soil(.3, penalty, tolerance=1e-5, method=method)
        assert abs(other[1] / u[1] - 1) < 2e-3
    glued, smooth, rough = (pile_in_soil(friction, method=method)[1]
                            for friction in (None, 0., 5.))
    assert smooth < u[1] < rough
    assert abs(rough / glued - 1) < .05    # 3.4% (MPM), 0.7% (cpGIMP)


@pytest.mark.slow
@pytest.mark.parametrize("method, offset", [("mpm", 0.), ("mpm", .05),
                                            ("cpgimp", 0.)])
def test_a_pile_in_plastic_soil_settles_as_a_rigid_obstacle(method, offset):
    """A frictionless pile in von Mises soil, 10 steps, its sides on grid
    lines or half a cell off them: it reaches the load (it stopped at 0.8
    and at 0.5 of it with a SingularSystemError: at a step's start the
    pairs under its tip's corners took a side's normal, one pair per node,
    so nothing held it up), symmetric to round-off, and settles as much
    as a rigid smooth obstacle in the same hole needs to carry the pile's
    load and weight, to 5% (MPM 7.7 and 7.4 mm on grid lines, 15.5 and
    15.5 off them; cpGIMP 7.75 mm: it settled 2.44 mm while the ghost
    penalty gave the cells the soil's domains reach the pile's modulus)."""
    from skfem_mpm import Obstacle
    soil = VonMises(1e4, .3, 20.)
    pile = pile_in_soil(0., nsteps=10, soil=soil, offset=offset,
                        method=method)
    assert abs(pile[0]) < 1e-9 * -pile[1]
    mesh, points, _, supports = hole_in_soil(offset)
    push = .02
    res = simulate(mesh, ElementQuad1(), points, soil, supports,
                   body_force=[0., -20.], nsteps=20,
                   obstacles=[Obstacle(box=[[.6 + offset, .8 + offset],
                                            [.6 + offset, 1.3]],
                                       displacement=[0., -push])])
    force = [r.obstacle_forces[0, 1] for r in res.history]
    weight = 20. * .2 * .6
    settles = np.interp(100. * .2 + weight, force,
                        [r.load_factor * push for r in res.history])
    assert -pile[1] == pytest.approx(settles, rel=.05)


@pytest.mark.slow
def test_a_pile_with_friction_in_plastic_soil_settles_less():
    """The pile in von Mises soil on grid lines with friction 0.3 (MPM):
    it settles less than the frictionless pile and more than the glued
    one (6.5 mm between 7.7 and 2.9; it settled 42 mm, its tip bearing on
    the two pairs at its corners)."""
    soil = VonMises(1e4, .3, 20.)
    glued, rough, smooth = (pile_in_soil(friction, nsteps=10, soil=soil)[1]
                            for friction in (None, .3, 0.))
    assert glued > rough > smooth


@pytest.mark.parametrize("method", [
    "bspline", pytest.param("bspline-gimp", marks=pytest.mark.slow)])
def test_a_spline_pile_on_grid_lines_settles_as_off_them(method):
    """The elastic pile with B-splines, its sides and tip on grid lines:
    it stays symmetric to round-off and settles as the pile half a cell
    off the lines to 1.5% (measured 0.5% and 1.0%: off them the soil
    and the pile share cells, which switch ``"bspline"``'s ghost penalty
    on, 0.01% without it; on from the start, 10%); with friction 0.3 it
    settles less, glued less again.  A surface ending on a grid line is
    made of one more spline per end than its nodes' pairs hold: with a
    pair per node the tip's corners between them sank, the pile settled
    3.86 mm against 2.83 off the lines and tilted by 5e-6 of its
    settlement; with the splines' own supports (a row of nodes further)
    the soil on both sides of the pile met at a node, refused as bodies
    overlapping at the start."""
    on = pile_in_soil(0., method=method)
    assert abs(on[0]) < 1e-12 * -on[1]
    off = pile_in_soil(0., method=method, offset=.05)
    assert on[1] == pytest.approx(off[1], rel=.015)
    rough, glued = (pile_in_soil(friction, method=method)[1]
                    for friction in (.3, None))
    assert on[1] < rough < glued < 0.


def standing_pile(friction, method="mpm", obstacle=False):
    """A new user's pile (h = 0.125): 2 cells wide, its sides half a
    cell and its tip 0.4 of a cell off grid lines, standing 0.7 deep in
    von Mises soil (yield stress 30, weight 20) and 0.3 above it, pushed
    by a traction of 100 on its top in 10 steps; or (``obstacle``) a
    rigid obstacle of its shape, with the same friction, pushed 0.03
    down in 30 steps through the same soil.  Returns the run's
    :class:`Result`, the pile's top points (or ``None``) and the load
    the soil carries (the push and the pile's weight)."""
    from skfem_mpm import Obstacle
    h, width = .125, 2.125
    mesh = MeshQuad.init_tensor(np.linspace(0, width, 18),
                                np.arange(0, 2. + 1e-9, h))
    c = width / 2

    def inside(x):
        return (np.abs(x[0] - c) < h) & (x[1] > .8) & (x[1] < 1.8)

    soil = seed_points(mesh, 2, region=lambda x: (x[1] < 1.5) & ~inside(x))
    pile = seed_points(mesh, 2, region=inside)
    load = 100. * 2 * h + 20. * pile.volume.sum()

    def supports(b):
        return np.union1d(b.get_dofs(lambda x: x[1] == 0).all(),
                          b.get_dofs(lambda x: (x[0] == 0) | (x[0] == width))
                          .nodal["u^1"])
    material = VonMises(1e4, .3, yield_stress=30.)
    if obstacle:
        bottom = pile.x[1].min() - h / 4              # its domains' edge
        return simulate(mesh, ElementQuad1(), soil, material, supports,
                        body_force=[0., -20.], nsteps=30, method=method,
                        obstacles=[Obstacle(box=[[c - h, c + h],
                                                 [bottom, 1.8]],
                                            displacement=[0., -.03],
                                            friction=friction,
                                            tolerance=1e-4)]), None, load
    pts = concatenate_points([soil, pile])
    pts.body[soil.n:] = 1
    top = np.flatnonzero((pts.body == 1) & (pts.x[1] > pile.x[1].max()
                                            - 1e-9))
    return simulate(mesh, ElementQuad1(), pts,
                    [material, LinearElastic(1e6, .3)], supports,
                    body_force=[0., -20.], nsteps=10, method=method,
                    loads=[Traction(top, "top", [0., -100.])],
                    contacts=[Contact(0, 1, friction=friction)]), top, load


@pytest.mark.slow
def test_a_pile_with_coulomb_friction_carries_its_whole_load():
    """The new user's pile with friction 0.3 (it stopped at 0.7 of its
    load with a singular tangent, and with friction 0.1 and 0.6 at 0.6
    and 0.8: the nodes under its tip, their soil beside the tip parted
    from its side by a settlement of a hundredth of a cell, took the
    side's normal, one normal a node with friction, and nothing held the
    tip up): the contact carries the push and the pile's weight, and the
    pile stays upright."""
    result, top, load = standing_pile(.3)
    assert result.history[-1].load_factor == 1.
    force = result.history[-1].contact_forces[0]
    assert force[1] == pytest.approx(load, rel=1e-9)
    assert abs(force[0]) < 1e-9 * load
    u = result.points.displacement[:, top].mean(axis=1)
    assert abs(u[0]) < 1e-9 * -u[1]


@pytest.mark.slow
@pytest.mark.parametrize("method", ("mpm", "cpgimp", "bspline"))
def test_the_standing_pile_settles_less_the_rougher_its_sides(method):
    """The new user's pile settles less as its friction grows, smooth
    to 0.1, 0.3, 0.6 and rough (MPM 11.2, 10.3, 8.4, 5.8 and 3.6 mm;
    with 0.1, 0.3 and 0.6 it stopped at 0.6, 0.7 and 0.8 of its load);
    with friction 0.3, standard MPM's settles as a rigid obstacle of its
    shape with that friction needs to carry the load, to 5% (8.40
    against 8.80 mm, the obstacle's penetration held to 1e-4 of a cell,
    where its default 1e-3 moves it by 0.06 mm with its penalty;
    cpGIMP and B-splines 12-16% less than their obstacles)."""
    settled = []
    for friction in (0., .1, .3, .6, "rough"):
        result, top, load = standing_pile(friction, method)
        assert result.history[-1].load_factor == 1.
        settled.append(-result.points.displacement[1, top].mean())
    assert all(np.diff(settled) < 0)
    if method == "mpm":
        result, _, load = standing_pile(.3, obstacle=True)
        force = [r.obstacle_forces[0, 1] for r in result.history]
        push = [.03 * r.load_factor for r in result.history]
        assert settled[2] == pytest.approx(np.interp(load, force, push),
                                           rel=.05)


def trial_pile(cells, soil, friction, nsteps, method="mpm", half=.1):
    """A user trial's pile (issue 29's fourth round): soil 1 deep on a
    grid 2 wide of ``cells`` across (square cells), a hole ``2 half``
    wide from 0.6 down in its middle, a pile 100 times stiffer than the
    soil's
    E = 1e5 standing in it up to 1.3, a traction of 2e4 on its head and
    weight 2e3 (``soil``: the soil's material; ``nsteps`` steps; glued
    where ``friction`` is None).
    Returns the run, its points and the pile's load (the head's
    traction over its width and its weight)."""
    h = 2. / cells
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, cells + 1),
                                np.arange(0, 1.5 + h / 2, h))

    def inside(x):
        return (x[0] > 1. - half) & (x[0] < 1. + half) & (x[1] > .6)
    ground = seed_points(mesh, 2, region=lambda x: (x[1] < 1.) & ~inside(x))
    pile = seed_points(mesh, 2, region=lambda x: inside(x) & (x[1] < 1.3))
    pts = concatenate_points([ground, pile])
    pts.body[ground.n:] = 1
    top = side_points(pts, "top", select=pts.body == 1)
    res = simulate(mesh, ElementQuad1(), pts,
                   [soil, LinearElastic(1e7, .2)],
                   lambda b: np.union1d(
                       b.get_dofs(lambda x: x[1] == 0).all(),
                       b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 2))
                       .nodal["u^1"]),
                   body_force=[0., -2e3], nsteps=nsteps,
                   loads=[Traction(top, "top", [0., -2e4])], method=method,
                   contacts=[] if friction is None else [
                       Contact(0, 1, friction=friction)])
    return res, pts, (2e4 * 2 * pts.domain[0, top].sum()
                      + 2e3 * pile.volume.sum())


@pytest.mark.slow
def test_a_heavily_loaded_pile_with_friction_settles_less_than_smooth():
    """A user trial's pile on grid lines (h = 0.1, 2 x 2 points, von Mises
    soil E = 1e5, yield stress 1e4, the pile 100 times stiffer, a
    traction of 2e4 on its head and weight 2e3, 10 steps): with friction
    0.3 it settled 8.09 cm against 4.87 smooth and drifted sideways by
    1e-4: at step 6 the nodes at its tip's corners, in a notch of the
    soil, took the side's normal, their candidates alike and the line
    between the bodies' centroids leaning sideways.  Now a node keeps the
    normal it was pressed along among candidates alike: 4.63 cm, upright
    to 1e-16 (MPM)."""
    settled = []
    for friction in (0., .3):
        res, pts, _ = trial_pile(20, VonMises(1e5, .3, 1e4), friction, 10)
        u = res.points.displacement[:, pts.body == 1].mean(axis=1)
        assert abs(u[0]) < 1e-9 * -u[1]
        settled.append(-u[1])
    assert settled[1] < settled[0]


@pytest.mark.slow
def test_a_heavily_loaded_square_pile_with_friction_in_3d():
    """A user trial's square pile in 3D (h = 0.2, two cells wide on grid
    lines, 2 x 2 x 2 points, von Mises soil E = 1e5, yield stress 1e4,
    the pile 100 times stiffer, a traction of 2e4 on its head and weight
    2e3, 5 steps, cpGIMP): with friction 0.3 it settled 0.120 against
    0.035 smooth and drifted sideways by 3% of that (27 s), its edges'
    nodes taking the side's normals where the tip's were alike; now
    0.034, upright to 1e-5 of the settlement (the contact's tolerance,
    1e-3 of a cell, is 6e-3 of it), in 62 Newton iterations (6 s).  The
    drift left is round-off's: 2.5e-8 on the compiled path, 1.0e-7 on
    numpy's since the head's traction loads its domains' faces (the
    edges' pairs with friction take x before y, one normal a node)."""
    from skfem import ElementHex1, MeshHex
    t = np.linspace(0, 1.2, 7)
    mesh = MeshHex.init_tensor(t, t, t)

    def inside(x):
        return (np.abs(x[0] - .6) < .2) & (np.abs(x[1] - .6) < .2)
    soil = seed_points(mesh, 2, region=lambda x: (x[2] < .8)
                       & ~(inside(x) & (x[2] > .4)))
    pile = seed_points(mesh, 2, region=lambda x: inside(x) & (x[2] > .4)
                       & (x[2] < 1.))
    pts = concatenate_points([soil, pile])
    pts.body[soil.n:] = 1

    def supports(b):
        return np.concatenate([b.get_dofs(lambda x: x[2] == 0).all()] + [
            b.get_dofs(lambda x, a=a: (x[a] == 0) | (x[a] == 1.2)).nodal[
                "u^{}".format(a + 1)] for a in (0, 1)])
    settled = []
    for friction in (0., .3):
        res = simulate(mesh, ElementHex1(), pts,
                       [VonMises(1e5, .3, 1e4), LinearElastic(1e7, .2)],
                       supports, body_force=[0., 0., -2e3], nsteps=5,
                       loads=[Traction(side_points(pts, "z+",
                                                   select=pts.body == 1),
                                       "z+", [0., 0., -2e4])],
                       method="cpgimp",
                       contacts=[Contact(0, 1, friction=friction)])
        u = res.points.displacement[:, pts.body == 1].mean(axis=1)
        assert np.abs(u[:2]).max() < 1e-5 * -u[2]
        settled.append(-u[2])
    assert settled[1] < settled[0]


def quarter_pile_pushed(friction, nsteps, push):
    """A user trial's square pile in 3D (trial 76: a quarter model, h =
    0.125, the pile two cells wide and 1 long, stiff, in K0 = 0.5 Tresca
    soil, c_u = 20, unit weight 18), pushed by ``push`` down in
    ``nsteps`` steps by a rough cap obstacle: the cap's force per step."""
    from skfem import ElementHex1, MeshHex
    from skfem_mpm import Obstacle, geostatic_stress
    h, W, H, a, L = .125, 1.25, 1.5, .25, 1.
    x = np.arange(0, W + 1e-9, h)
    mesh = MeshHex.init_tensor(x, x, np.arange(0, H + 4 * h + 1e-9, h))

    def inside(p):
        return (p[0] < a) & (p[1] < a)
    soil = VonMises(1e4, 1 / 3, np.sqrt(3) * 20.)
    ground = seed_points(mesh, 2, region=lambda p: (p[2] < H)
                         & ~(inside(p) & (p[2] > H - L)))
    ground = geostatic_stress(ground, soil, [0., 0., -18.], H, .5)
    pile = seed_points(mesh, 2, region=lambda p: inside(p)
                       & (p[2] > H - L) & (p[2] < H + 2 * h))
    pile.body[:] = 1
    pts = concatenate_points([ground, pile])

    def supports(b):
        return np.concatenate([b.get_dofs(lambda p: p[2] == 0).all()] + [
            b.get_dofs(lambda p, d=d: np.isclose(p[d], 0.)
                       | np.isclose(p[d], W)).all("u^{}".format(d + 1))
            for d in (0, 1)])
    res = simulate(mesh, ElementHex1(), pts, [soil, LinearElastic(1e6, .2)],
                   supports, body_force=BodyForce([[0., 0., -18.],
                                                   [0., 0., 0.]],
                                                  ramp=False),
                   nsteps=nsteps, contacts=[Contact(0, 1, friction=friction)],
                   options=Options(stabilisation=Stabilisation(
                       antilocking=True)),
                   obstacles=[Obstacle(box=[[-1., a], [-1., a],
                                            [H + 2 * h, H + 3 * h]],
                                       displacement=[0., 0., -push],
                                       friction="rough")])
    return np.array([r.obstacle_forces[0][2] for r in res.history])


@pytest.mark.slow
def test_a_square_pile_with_friction_keeps_its_tip_held():
    """The trial's pile with friction 0.3 pushed 5 mm a step: its cap's
    force fell from 13.4 to 5.8 at step 3, below the smooth pile's 13.9
    (a pile with friction cannot carry less): its tip's edge corner,
    pressed down with two thirds of the tip's force, took at the node of
    the soil's notch the side's normal (the soil's corners there level
    faces across x, overlapping the pile's by half a domain, against a
    gap of -1.5e-3 cells down), paired sideways with a soil corner under
    the tip, and the tip sank through the soil unheld.  Now it keeps the
    normal it was pressed along, no worse a separating axis: 14.4 against
    13.9, the difference about mu times the sides' normal force
    (0.3 x 1.6 = 0.49)."""
    smooth = quarter_pile_pushed(0., 3, .015)
    rough = quarter_pile_pushed(.3, 3, .015)
    assert smooth[-1] < rough[-1] < smooth[-1] + .3 * (.5 * 18. * .5) \
        * 2 * .25, (rough, smooth)      # mu K0 gamma z at L / 2, 2 a L


def test_a_pile_seeded_to_a_quarter_cell_is_pushed_to_its_load():
    """A user trial's pile on a grid of h = 2/15, its region's sides
    (0.9, 1.1) through columns of points: seeded with teeth (the rows
    rounding differently), it was refused as overlapping; seeded straight
    (:func:`~skfem_mpm.quadrature.points.in_region`) on grid lines, one
    cell wide, its tip inside a cell, the augmented Lagrangian closed 7%
    of the rest a round (the pile 100 times stiffer than the penalty's
    soil) and the run ended with ``ContactError`` at step 7 of 10.  The
    rounds are extrapolated now (``accelerated``): the contact carries
    the head's traction and the pile's weight at the full load (MPM,
    elastic soil), and the symmetric pile stays upright to round-off (it
    moved sideways by 3e-3 of its settlement while its two tip corners'
    pairs, facing one soil corner, kept one of them: ``find_pairs``)."""
    res, pts, load = trial_pile(15, LinearElastic(1e5, .3), 0., 10)
    assert res.history[-1].load_factor == 1.
    force = res.history[-1].contact_forces[0]
    assert force[1] == pytest.approx(load, rel=1e-9)
    u = res.points.displacement[:, pts.body == 1].mean(axis=1)
    assert abs(u[0]) < 1e-12 * -u[1]


@pytest.mark.slow
@pytest.mark.parametrize("method, friction, soil", [
    ("cpgimp", 0., LinearElastic(1e5, .3)),
    ("cpgimp", "rough", LinearElastic(1e5, .3)),
    ("mpm", .3, VonMises(1e5, .3, 1e4)),
    ("bspline", 0., LinearElastic(1e5, .3)),
    ("bspline", .3, VonMises(1e5, .3, 1e4))])
def test_a_pile_one_cell_wide_stays_upright(method, friction, soil):
    """The trial's pile seeded straight, one cell wide, its tip inside a
    cell: its two tip corners face one soil corner under its middle, and
    one pair per first body's place kept the left one's alone.  cpGIMP's
    pile then turned about it (smooth: ``NewtonDivergenceError`` at step
    3, Newton's direction turning the pile's field by tens of radians;
    rough: at step 4), MPM's with friction 0.3 leaned by 2e-4 of its
    settlement in 122 iterations.  Pairs as near as the nearest at that
    place are kept now: each reaches its load upright to round-off.  The
    B-spline pile failed at every cut-back of its first step with the
    ghost penalty held in reserve; the retry ladder now switches it on
    there (small strain: gamma 1e-3)."""
    res, pts, load = trial_pile(15, soil, friction, 10, method)
    assert res.history[-1].contact_forces[0, 1] == pytest.approx(
        load, rel=1e-9)
    u = res.points.displacement[:, pts.body == 1].mean(axis=1)
    assert abs(u[0]) < 1e-12 * -u[1]


@pytest.mark.slow
def test_a_spline_pile_s_head_corners_stay_on_their_domains(monkeypatch):
    """The trial's rough pile 1.5 cells wide with the quadratic
    B-splines, elastic soil: the splines of its head's corners reach
    nodes above it that its points barely hold, and step 9 moved a
    corner 66 cells (no pair, no force), out of the grid; step 10 failed
    at every cut-back (``ContactError``: a corner that reaches no grid
    node carrying material).  A corner moved a cell from its domain's
    goes back there (counted): the pile reaches its load upright.  In
    small strain the check of the slivers' share of a point's gradient
    (0.85 at the head's corner point in step 9) now switches the ghost
    penalty on there first; the corners' reset, which stands alone in
    finite deformation, is exercised with that check off.  The penalty's
    switch where two bodies share a cell (``INTERFACE_METHODS``, which
    turns it on from the first step here, the pile's cells holding soil:
    no corner is then reset) is off, so that these mechanisms are still
    exercised."""
    from skfem_mpm.solve import core, problem
    monkeypatch.setattr(core, "INTERFACE_METHODS", ())
    for gradient_checked in (True, False):
        if not gradient_checked:
            monkeypatch.setattr(problem, "THROWN_GRADIENT", np.inf)
        res, pts, load = trial_pile(15, LinearElastic(1e5, .3), "rough",
                                    10, "bspline", half=.15)
        assert len(res.history) == 10
        assert res.history[-1].contact_forces[0, 1] == pytest.approx(
            load, rel=1e-9)
        u = res.points.displacement[:, pts.body == 1].mean(axis=1)
        assert abs(u[0]) < 1e-12 * -u[1]
        assert res.counters["ghost_from_step"] == (9 if gradient_checked
                                                   else 0)
        assert (res.counters["contact_corners_reset"] > 0) \
            == (not gradient_checked)


@pytest.mark.slow
def test_a_gimp_pile_one_cell_wide_with_friction_keeps_its_tip_pairs():
    """The same pile with cpGIMP, friction 0.3, von Mises soil: at step
    2 its tip corners, pressed down at step 1's end, found the soil's
    side corner above them a 500th of a cell nearer than the soil's
    corner under the tip, paired sideways only, and the pile hung on its
    sides' friction (``NewtonDivergenceError`` at step 2 down to an
    increment of 4e-4, in elastic soil too).  A corner pressed at the
    last step's end keeps a pair along the direction it was pressed: it
    reaches its load upright, settling as MPM's to 1% (2.570 against
    2.575 cm) and less than without friction (2.630)."""
    soil = VonMises(1e5, .3, 1e4)
    settled = {}
    for method, friction in (("cpgimp", .3), ("mpm", .3), ("cpgimp", 0.)):
        res, pts, load = trial_pile(15, soil, friction, 10, method)
        assert res.history[-1].contact_forces[0, 1] == pytest.approx(
            load, rel=1e-9)
        u = res.points.displacement[:, pts.body == 1].mean(axis=1)
        assert abs(u[0]) < 1e-12 * -u[1]
        settled[method, friction] = -u[1]
    assert settled["cpgimp", .3] == pytest.approx(settled["mpm", .3],
                                                  rel=.01)
    assert settled["cpgimp", .3] < settled["cpgimp", 0.]


@pytest.mark.slow
def test_a_spline_pile_with_its_tip_inside_a_cell_reaches_its_load(
        monkeypatch):
    """The trial's pile two cells wide (h = 1/8, its sides on grid
    lines, its tip inside a cell) with the quadratic B-splines, elastic
    soil: its tip's pairs held it to step 7, then it sank through the
    soil's corners under its edges and was refused at step 10 as not
    held along y (step 8 on older code).  The corners there, moved
    through their points' gradients, lay a tenth of a cell off where the
    last step's pairs had held them; moved by the splines' field as the
    pairs move them, the pile reaches its load upright, settling 4.87 cm
    against cpGIMP's 4.84 (MPM 5.0-5.8); with the ghost penalty's switch
    where two bodies share a cell (``INTERFACE_METHODS``, off here to
    exercise the pairs: with it the penalty is on from the first step)
    it settles 4.71 against cpGIMP's 4.90."""
    from skfem_mpm.solve import core
    monkeypatch.setattr(core, "INTERFACE_METHODS", ())
    soil = LinearElastic(1e5, .3)
    settled = {}
    for method in ("bspline", "cpgimp"):
        res, pts, load = trial_pile(16, soil, 0., 10, method, half=.125)
        assert res.history[-1].load_factor == 1.
        assert res.history[-1].contact_forces[0, 1] == pytest.approx(
            load, rel=1e-9)
        u = res.points.displacement[:, pts.body == 1].mean(axis=1)
        assert abs(u[0]) < 1e-9 * -u[1]
        settled[method] = -u[1]
    assert settled["bspline"] == pytest.approx(settled["cpgimp"], rel=.02)


@pytest.mark.slow
def test_a_rough_pile_settles_alike_in_20_and_40_steps():
    """The trial's rough pile on grid lines (h = 0.1, elastic soil, MPM):
    in 20 and 40 steps it ended with ``ContactError`` at load factor 0.73
    (the augmented Lagrangian's rounds closing a few percent of the rest
    each, 30 rounds at every cut-back); with the rounds extrapolated it
    reaches its load in the steps asked, and the settlement of 20 steps
    is within 2% of that of 40 (a rough interface's answer depends on the
    path: 10 steps give 3.63 cm, 20 3.64, 40 3.59; 3.57, 3.68 and 3.70
    before the first body's corners under the second's surface reaching
    on beyond it joined its pairs' choice)."""
    settled = []
    for nsteps in (20, 40):
        res, pts, load = trial_pile(20, LinearElastic(1e5, .3), "rough",
                                    nsteps)
        assert len(res.history) == nsteps
        assert res.history[-1].contact_forces[0, 1] == pytest.approx(
            load, rel=1e-9)
        settled.append(-res.points.displacement[1, pts.body == 1].mean())
    assert settled[0] == pytest.approx(settled[1], rel=2e-2)


def test_a_spline_traction_beyond_the_points_support_is_not_lost():
    """The trial's pile glued in its soil with B-splines (no contact):
    the splines at its head's face centres reach the nodes a row above
    its points', which its points no longer reach once it has sunk (10
    of 470 DOFs gone at the last step), and the traction's share there
    was lost: the supports carried 8011 of the 8120 applied.  The
    face's force now goes to the nodes that carry stiffness, and the
    supports carry the whole load."""
    res, pts, _ = trial_pile(20, LinearElastic(1e5, .3), None, 10,
                             "bspline")
    applied = 2e3 * pts.volume.sum() + 2e4 * .2
    carried = res.history[-1].reactions.reshape(-1, 2).sum(axis=0)
    assert carried[1] == pytest.approx(applied, rel=1e-9)


def test_a_spline_pile_s_contact_force_is_its_load():
    """A weightless pile loaded on its head, its sides and tip inside
    cells (a user trial's, nx = 27): the splines at its domains' corners
    reach nodes a quarter cell beyond its points', which no point
    supports, and the pairs' force there held the pile like a support:
    the contact force, and the soil's supports' reactions, came out
    1.0006 times the load at the third step (1.0068 in von Mises soil on
    a finer grid).  The corners' weights now go to the nodes that carry
    material, and the contact passes the whole load."""
    nx = 27
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, nx + 1),
                                np.linspace(0, 1.4, 21))
    pile = [(.9, 1.1), (.6, 1.2)]
    soil = seed_points(mesh, 2, region=lambda x: (x[1] < 1.) & ~(
        (np.abs(x[0] - 1.) < .1) & (x[1] > .6)))
    pts = concatenate_points([soil, bodies(mesh, 2, [pile])])
    pts.body[soil.n:] = 1
    head = side_points(pts, "top", select=np.flatnonzero(pts.body == 1))
    load = 200. * 2 * pts.domain[0, head].sum()
    res = simulate(
        mesh, ElementQuad1(), pts,
        [LinearElastic(1e4, .3), LinearElastic(1e6, .2)],
        lambda b: np.union1d(
            b.get_dofs(lambda x: x[1] == 0.).all(),
            b.get_dofs(lambda x: (x[0] == 0.) | (x[0] == 2.)).all("u^1")),
        loads=[Traction(head, "top", [0., -200.])], nsteps=3,
        method="bspline", contacts=[Contact(0, 1)])
    for record in res.history:
        assert record.contact_forces[0, 1] == pytest.approx(
            load * record.load_factor, rel=1e-9)
    assert res.history[-1].reactions[1::2].sum() == pytest.approx(
        load, rel=1e-9)


def test_a_pile_that_nothing_holds_up_fails_clearly():
    """A frictionless pile hanging in its hole, its tip half a cell above
    the hole's bottom (a user's mistake): its smooth sides hold it only
    sideways, and the first step fails as a singular system that names
    the contact, with the state it started from attached.  (The pile
    that stood on the bottom, pushed into von Mises soil with MPM, ended
    so at 0.8 of its load: its tip's pairs took a side's normal.)"""
    from skfem_mpm import SingularSystemError
    with pytest.raises(SingularSystemError,
                       match="parted from what held it") as err:
        pile_in_soil(0., tip=.05)
    assert err.value.state is not None


@pytest.mark.slow
@pytest.mark.parametrize("friction", (0., .3, "rough"))
@pytest.mark.parametrize("method", ("mpm", "cpgimp", "bspline"))
def test_a_square_pile_in_3d_stays_symmetric(method, friction):
    """A square pile two cells wide in 3D, its sides on grid lines, in
    elastic soil, pushed in 2 steps: frictionless its top moves sideways
    by less than 1e-7 of its settlement (MPM 5e-16, cpGIMP 3e-9), with
    friction 0.3 by less than 1e-6 (MPM 6e-9, cpGIMP 4e-7).  The x and y
    normals tied at its vertical edges were taken by the order of the
    candidates: frictionless, with cpGIMP it drifted by 8.7% of its
    settlement, with MPM its points left the grid in the second step;
    with friction (one normal per node) by round-off, some edges x,
    others y: it drifted by 0.12% (MPM) and 2.0% (cpGIMP).  With
    B-splines and the ghost penalty that a failure's message names
    (``ghost=0.1``; held in reserve, the run with friction failed at
    every cut-back of its first step): 2e-12, 1.19 mm against MPM's
    1.27.  Rough, by less than 1e-6 too (MPM 2e-7, cpGIMP 2e-7,
    B-splines 1e-7; 0.901, 0.889 and 0.905 mm): with B-splines it failed
    at every cut-back of its first step, the pairs sticking wherever a
    trial pressed them and Newton cycling between two states."""
    from skfem import ElementHex1, MeshHex
    g = np.linspace(0, .8, 9)
    mesh = MeshHex.init_tensor(g, g, np.linspace(0, 1., 11))

    def hole(x):
        return (np.abs(x[0] - .4) < .1) & (np.abs(x[1] - .4) < .1) \
            & (x[2] > .4)
    soil = seed_points(mesh, 2, region=lambda x: (x[2] < .7) & ~hole(x))
    pts = concatenate_points([soil, bodies(mesh, 2, [
        lambda x: hole(x) & (x[2] < .9)])])
    pts.body[soil.n:] = 1
    top = np.flatnonzero((pts.body == 1) & (pts.x[2] > .85))

    def supports(b):
        return np.concatenate([b.get_dofs(lambda x: x[2] == 0).all()] + [
            b.get_dofs(lambda x, a=a: (x[a] == 0) | (x[a] == .8)).nodal[
                "u^{}".format(a + 1)] for a in (0, 1)])
    res = simulate(mesh, ElementHex1(), pts,
                   [LinearElastic(1e4, .3), LinearElastic(1e6, .2)],
                   supports, body_force=[0., 0., -20.], nsteps=2,
                   loads=[Traction(top, "z+", [0., 0., -100.])],
                   method=method, contacts=[Contact(0, 1, friction=friction)],
                   options=Options(stabilisation=Stabilisation(
                       ghost=.1 if method == "bspline" else "auto")))
    u = res.points.displacement[:, top].mean(axis=1)
    assert u[2] < -5e-4
    assert np.abs(u[:2]).max() < (1e-6 if friction else 1e-7) * -u[2]


def test_blocks_side_by_side_and_the_contact_tolerance():
    """Two blocks standing side by side on a held base under their weight,
    the right one a hundred times stiffer: with nu = 0 nothing presses
    them together and the step settles at once (a check of the penalty's
    force against the largest pair's, with no floor, failed such a step
    after 30 rounds); with nu = 0.3 they press each other, and the
    contact's tolerance sets the rounds (3, 7, 15 at 1e-1, 1e-3, 1e-6)
    and how near the force comes (1e-1 within 1e-3 of 1e-6's: 3.2e-4)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1.6, 17),
                                np.linspace(0, .8, 9))
    pts = bodies(mesh, 2, [[(.2, .8), (0., .5)], [(.8, 1.4), (0., .5)]])

    def run(nu, tolerance):
        return simulate(mesh, ElementQuad1(), pts.copy(),
                        [LinearElastic(1e4, nu), LinearElastic(1e6, nu)],
                        lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
                        body_force=[0., -10.], nsteps=3,
                        contacts=[Contact(0, 1, tolerance=tolerance)])
    free = run(0., 1e-3)
    assert free.counters["contact_updates"] == 0
    assert np.abs(free.history[-1].contact_forces).max() < 1e-12
    loose, tight = run(.3, 1e-1), run(.3, 1e-6)
    assert loose.counters["contact_updates"] < \
        tight.counters["contact_updates"]
    force = tight.history[-1].contact_forces[0, 0]
    assert force > .2
    assert loose.history[-1].contact_forces[0, 0] == pytest.approx(
        force, rel=1e-3)


def test_a_block_dropped_on_a_slab_body_keeps_its_energy_by_default():
    """A block dropped 0.5 on an elastic slab, a second body in contact
    with it, in time steps of 0.04: with the default scheme (the
    generalised-alpha scheme with rho_inf = 0 where a run has contact)
    its energy, kinetic and potential, never exceeds the start's by more
    than 2e-3 of the drop's (1.3e-3 measured over 0.8 s); with Newmark's
    average acceleration rule the landing returns several times the
    drop's energy (5.1 measured over 0.8 s)."""
    g, rho = 9.81, 1e3
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 11),
                                np.linspace(-.2, 2.2, 25))
    pts = bodies(mesh, 2, [[(0, 1), (-.2, 0.)], [(.3, .7), (.5, .7)]])
    m = rho * pts.volume
    block = pts.body == 1
    drop = g * m[block] @ (pts.x[1, block] - .1)   # to rest on the slab

    def gained(scheme):
        energy = []

        def watch(record, points):
            energy.append(.5 * m @ (points.velocity ** 2).sum(0)
                          + g * m @ points.x[1])
        simulate(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
                 lambda b: b.get_dofs(lambda x: x[1] < -.19).all(),
                 body_force=[0, -g * rho], kinematics="finite",
                 dynamics=Dynamics(time_step=.04, duration=.48, density=rho,
                                   scheme=scheme),
                 contacts=[Contact(0, 1)], options=Options(callback=watch))
        return (max(energy) - g * m @ pts.x[1]) / drop
    assert gained(None) < 2e-3
    assert gained(Newmark()) > 1.


def test_a_symmetric_landing_on_a_slab_body_stays_symmetric():
    """A block dropped on an elastic slab body, both mirror-symmetric
    about x = 0.5 with their faces inside cells (MPM, finite deformation,
    dynamics, smooth contact): the motion stays mirror-symmetric to
    round-off through the landing and the bounce.  A pair took one of the
    coincident corners of neighbouring domains by the order, for its
    tangent and for the impact's velocity correction: the landing step
    ended 3.5e-8 asymmetric, and after the bounce the block turned by
    9e-3 of its motion (a user trial; the mirrored model the same)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 11),
                                np.linspace(0, 1, 11))
    pts = bodies(mesh, 2, [lambda x: x[1] < .25, lambda x: (x[0] > .3)
                           & (x[0] < .7) & (x[1] > .35) & (x[1] < .55)])
    rho = 1e3
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
                   lambda b: b.get_dofs(lambda x: np.abs(x[1]) < 1e-9).all(),
                   body_force=[0., -rho * 9.81], kinematics="finite",
                   contacts=[Contact(0, 1)],
                   dynamics=Dynamics(.02, .3, rho))
    mirror = pts.x.copy()
    mirror[0] = 1. - mirror[0]
    j = cKDTree(pts.x.T).query(mirror.T)[1]
    u = res.points.displacement
    assert np.abs(res.history[7].contact_forces[0, 1]) > 0.   # landed
    assert np.abs(res.history[9].contact_forces[0, 1]) == 0.  # bounced
    asymmetry = max(np.abs(u[0] + u[0, j]).max(),
                    np.abs(u[1] - u[1, j]).max())
    assert asymmetry < 1e-12 * np.abs(u).max()


def test_a_block_dropped_in_long_time_steps_does_not_pass_through_a_slab():
    """A block dropped 0.5 on a slab body in time steps of 0.2 moves 6
    cells in the step that reaches the slab, farther than the step's pairs
    look (those of nodes both bodies reach at its start): that step is
    refused (``StepTooLongError``) and cut back, and the block lands on
    the slab, never deeper in it than a tenth of a cell (before, it sank
    2.8 cells into the slab with no contact force and fell out of the
    grid)."""
    g, rho, h = 9.81, 1e3, .1
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 11),
                                np.linspace(-.4, 1.2, 17))
    pts = bodies(mesh, 2, [[(0, 1), (-.4, 0.)], [(.3, .7), (.5, .7)]])
    lowest = []

    def watch(record, points):
        block = points.body == 1
        lowest.append((points.x[1, block] - pts.domain[1, block]
                       * points.F[1, 1, block]).min())
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
                   lambda b: b.get_dofs(lambda x: x[1] < -.39).all(),
                   body_force=[0, -g * rho], kinematics="finite",
                   dynamics=Dynamics(time_step=.2, duration=.6, density=rho),
                   contacts=[Contact(0, 1)], options=Options(callback=watch))
    assert len(res.history) > 3                  # a step was cut back
    assert min(lowest) > -.1 * h
    assert res.history[-1].time == pytest.approx(.6)


@pytest.mark.slow
def test_a_block_bouncing_on_a_slab_never_sinks_into_it_unpushed():
    """A block dropped on a slab body (time steps of 0.04, h = 0.07)
    bounces and lands again; on the second landing it came from a cell
    above the slab, where no node was reached by both bodies at the
    step's start, and ended 0.05 cells inside the slab with no contact
    force.  Such a step is now cut back: the block's domains never
    overlap the slab's by more than a hundredth of a cell."""
    g, rho, h = 9.81, 800., .07
    mesh = MeshQuad.init_tensor(np.arange(-.05, 1.2 + 1e-9, h),
                                np.arange(-.31, 1.3 + 1e-9, h))
    pts = bodies(mesh, 2, [[(.33, .71), (.565, .735)],
                           [(-.05, 1.14), (.04, .18)]])
    half = pts.domain.copy()
    deepest = []

    def watch(record, points):
        # the slab's top and the block's bottom, domain by domain, at the
        # block's points across
        def face(body, sign):
            k = np.flatnonzero(points.body == body)
            return points.x[0, k], points.x[1, k] + sign * half[1, k] \
                * points.F[1, 1, k]
        xs, top = face(1, 1.)
        row = np.flatnonzero(top > top.max() - .02)
        xb, low = face(0, -1.)
        order = np.argsort(xs[row])
        deepest.append((np.interp(xb, xs[row][order], top[row][order])
                        - low).max())
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(5e5, .28), LinearElastic(1.5e6, .3)],
                   lambda b: b.get_dofs(lambda x: np.isclose(x[1], .04)).all(),
                   body_force=[0, -g * rho], kinematics="finite",
                   dynamics=Dynamics(.04, .8, rho), contacts=[Contact(0, 1)],
                   options=Options(callback=watch))
    assert res.history[-1].time == pytest.approx(.8)
    assert max(deepest) < .01 * h


def test_a_failure_with_b_spline_contacts_names_the_ghost_penalty():
    """A run with contacts between bodies on B-splines that fails with the
    ghost penalty never on names ``Stabilisation(ghost=0.1)`` (the square
    pile with friction in 3D failed so without a hint); not with standard
    MPM, nor once the penalty is on."""
    from types import SimpleNamespace
    from skfem_mpm.solve.core import ghost_hint

    def run(method, ghost=0., since=0, contacts=(Contact(0, 1),)):
        return SimpleNamespace(contacts=contacts, ghost=ghost,
                               method=SimpleNamespace(name=method),
                               counters={"ghost_from_step": since})
    assert "Stabilisation(ghost=0.1)" in ghost_hint(run("bspline"))
    assert "Stabilisation(ghost=0.1)" in ghost_hint(run("bspline-gimp"))
    for quiet in (run("mpm"), run("bspline", ghost=.1),
                  run("bspline", since=2), run("bspline", contacts=())):
        assert ghost_hint(quiet) == ""


@pytest.mark.parametrize("friction", ["rough", .3])
def test_a_pile_inside_cells_on_a_surface_on_a_grid_line_is_held(friction):
    """A stiff pile one cell wide, its sides half a cell off grid lines,
    resting on the soil's surface, which lies on a grid line (h = 0.2),
    pushed by a traction on its head: it carries the load upright.  Its
    base's outer corners, facing the soil's corners at the ends of the
    range both bodies share (where the soil reaches beyond the pile, as
    beside a pile's tip), found the soil's corner under the pile's middle
    instead and lost it to the middle corner's pair: one pair in all,
    and the run was refused as not held against rotation.  Such a corner
    is now paired with the soil's corner under it where the soil beyond
    does not rise past the pile's base (a surface, not the notch round
    a tip).  It settles 2.01e-4 against 2.72-2.76e-4 on h = 0.1 and 0.05
    (its sides on grid lines there): the coarse grid's stiffness."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 11),
                                np.linspace(0, 1.6, 9))
    pts = bodies(mesh, 2, [lambda x: x[1] < 1., lambda x: (x[0] > .9)
                           & (x[0] < 1.1) & (x[1] > 1.) & (x[1] < 1.3)])
    head = side_points(pts, "top", select=pts.body == 1)

    def supports(b):
        return np.union1d(b.get_dofs(lambda x: x[1] == 0).all(),
                          b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 2))
                          .nodal["u^1"])
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e5, .3), LinearElastic(1e7, .3)],
                   supports, loads=[Traction(head, "top", [0., -100.])],
                   nsteps=1, contacts=[Contact(0, 1, friction=friction)])
    load = 100. * .2
    force = res.history[-1].contact_forces[0]
    assert force[1] == pytest.approx(load, rel=1e-9)
    u = res.points.displacement[:, head].mean(axis=1)
    assert abs(u[0]) < 1e-9 * -u[1]
    assert -u[1] == pytest.approx(2.0e-4, rel=.02)


def gimp_pile_at(c):
    """The pile in soil (h = 0.1, cpGIMP, friction 0.3, 2 steps) with the
    whole set-up moved by ``c``: the head's mean settlement."""
    def local(x):
        return x[0] - c[0], x[1] - c[1]

    mesh = MeshQuad.init_tensor(np.linspace(0, 1.4, 15) + c[0],
                                np.linspace(0, 1.4, 15) + c[1])

    def hole(x):
        return (local(x)[0] > .6) & (local(x)[0] < .8) & (local(x)[1] > .6)
    pts = bodies(mesh, 2, [lambda x: (local(x)[1] < 1.) & ~hole(x),
                           lambda x: hole(x) & (local(x)[1] < 1.2)])
    top = side_points(pts, "top", pts.body == 1)

    def supports(b):
        def at(x, a, v):
            return np.abs(local(x)[a] - v) < 1e-6
        return np.union1d(
            b.get_dofs(lambda x: at(x, 1, 0.)).all(),
            b.get_dofs(lambda x: at(x, 0, 0.) | at(x, 0, 1.4)).nodal["u^1"])
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e4, .3), LinearElastic(1e6, .2)],
                   supports, body_force=[0., -20.], nsteps=2,
                   method="cpgimp", loads=[Traction(top, "top", [0., -100.])],
                   contacts=[Contact(0, 1, friction=.3)])
    return -res.points.displacement[1, top].mean()


@pytest.mark.slow
def test_a_gimp_pile_settles_alike_at_a_sites_coordinates():
    """The GIMP pile moved to a site's coordinates (x + 1e4; x + 5e5,
    y + 1e3) settles as at the origin, to 1e-8.  The ghost penalty, on
    from the start with GIMP contacts, mapped its faces' quadrature with
    scikit-fem's inverse mapping, which stops at an absolute 1e-12 (at
    x + 1e4 the run failed at step 2 with its exception), and a domain's
    end on a grid line at x = 5e5, 1e-10 off it by round-off, was a
    sliver of material (16% more settlement, Newton struggling)."""
    here = gimp_pile_at((0., 0.))
    for c in ((1e4, 0.), (5e5, 1e3)):
        assert gimp_pile_at(c) == pytest.approx(here, rel=1e-8)


@pytest.mark.slow
@pytest.mark.parametrize("method, kept", [("mpm", 1e-12), ("bspline", 1e-4)])
def test_two_free_blocks_colliding_sideways_keep_their_momentum(method,
                                                                kept):
    """A block thrown sideways (1 m/s, and 0.3 up) at a free block, both
    under gravity, no supports, a smooth contact: the horizontal momentum
    is kept through the collision (measured 5e-12 of it with MPM, 4e-5
    with the B-splines), and the vertical one changes by gravity's
    impulse.  With the B-splines the pairs' search failed at the
    collision with an IndexError (a review found it)."""
    rho, g = 1e3, 9.81
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21), np.linspace(0, 1, 11))
    pts = bodies(mesh, 2, [lambda x: (x[0] > .3) & (x[0] < .8)
                           & (x[1] > .3) & (x[1] < .7),
                           lambda x: (x[0] > .9) & (x[0] < 1.3)
                           & (x[1] > .2) & (x[1] < .6)])
    v0 = np.zeros((2, pts.n))
    v0[:, pts.body == 1] = [[-1.], [.3]]
    pts.velocity = v0
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e6, .3), LinearElastic(3e6, .3)], [],
                   body_force=[0., -g * rho], kinematics="finite",
                   contacts=[Contact(0, 1)], method=method,
                   dynamics=Dynamics(.02, .2, rho))
    m = rho * pts.volume0
    assert any(r.contact_forces[0, 0] > 0 for r in res.history)  # met
    momentum = res.points.velocity @ m
    assert abs(momentum[0] - v0[0] @ m) < kept * abs(v0[0] @ m)
    assert momentum[1] == pytest.approx(v0[1] @ m - g * m.sum() * .2,
                                        rel=1e-9)


@pytest.mark.slow
def test_a_spline_pile_pushed_by_a_cap_does_not_sink_through_its_soil():
    """A user trial's pile (B-splines, 3 x 3 points per cell, h = 0.054,
    its sides and tip inside cells, elastic soil, smooth contact) pushed
    5 mm in 5 steps by a cap obstacle: the cap's force grows linearly
    (measured 11.20, 22.06, 32.99, 43.96, 55.00; standard MPM 54.60).
    The splines of the soil's corners under the tip reach nodes inside
    the hole the soil barely holds, which carried those corners down
    with the pile from step 2 (0.27 cells a step): the cap pushed with
    0.02 to 0.08, every step converged.  Such a step failed and the
    ghost penalty came on at step 2; now it is on from the first step,
    the pile's cells holding soil too (``INTERFACE_METHODS``; the force
    11.11, 22.55, 33.77, 44.98, 56.19)."""
    from skfem_mpm import Obstacle
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 38),
                                np.linspace(0, 1.4, 28))

    def hole(x):
        return (x[0] > .9) & (x[0] < 1.1) & (x[1] > .6) & (x[1] < 1.2)
    pts = bodies(mesh, 3, [lambda x: (x[1] < 1.) & ~hole(x), hole])
    top = float((pts.x[1] + pts.domain[1])[pts.body == 1].max())
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e4, .3), LinearElastic(1e6, .2)],
                   lambda b: np.concatenate([
                       b.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
                       b.get_dofs(lambda x: np.isclose(x[0], 0.)
                                  | np.isclose(x[0], 2.)).all("u^1")]),
                   nsteps=5, method="bspline", contacts=[Contact(0, 1)],
                   obstacles=[Obstacle(box=[[.7, 1.3], [top, top + .1]],
                                       displacement=[0., -.005])])
    force = np.array([r.obstacle_forces[0, 1] for r in res.history])
    assert np.allclose(force / force[0], np.arange(1, 6), rtol=.03)
    assert res.counters["ghost_from_step"] == 1


@pytest.mark.slow
def test_a_pile_driven_by_a_rough_cap_passes_its_soil_s_top_row():
    """Trial 53's pile rebuilt: two cells wide (h = B/2) in a hole of
    von Mises soil (c_u = 10 kPa, E = 100 c_u, unit weight 20 kN/m3),
    its tip 4 B deep, smooth contact, finite deformation, standard MPM,
    driven 2 B by a rough cap in 10 steps.  The tip passes the top row of
    soil points under its outer quarters, one is wrapped round its
    corner, and the corner the tip's pressed corners' downward
    candidates chose lay 0.5-0.8 cells above the tip: past the pairs'
    half-cell depth, dropped, the tip held by sideways pairs; the run
    stopped at a load factor of 0.6 at every cut-back.  Such a corner
    takes the nearest partner within that depth now: the cap drives the
    pile 2 B, and the tip's resistance net of the overburden stays
    near the deep tip's ``N_c c_u`` (Skempton's strip 7.5, Meyerhof's 9)
    past a settlement of B: measured 5.6-14.8 c_u, mean 11.8 (one step
    dips where the tip nears a grid line)."""
    from skfem_mpm import Obstacle
    B, cu, gamma = .25, 1e4, 2e4
    surface, tip, c = 7.5 * B, 3.5 * B, 5 * B      # h = B / 2
    mesh = MeshQuad.init_tensor(np.linspace(0, 10 * B, 21),
                                np.linspace(0, 11.5 * B, 24))

    def hole(x):
        return (np.abs(x[0] - c) < B / 2) & (x[1] > tip)
    pts = bodies(mesh, 2, [lambda x: (x[1] < surface) & ~hole(x),
                           lambda x: hole(x) & (x[1] < surface + 2.5 * B)])
    head = float((pts.x[1] + pts.domain[1])[pts.body == 1].max())
    res = simulate(mesh, ElementQuad1(), pts,
                   [VonMises(100 * cu, .3, np.sqrt(3) * cu),
                    LinearElastic(1e8, .2)],
                   lambda b: np.union1d(
                       b.get_dofs(lambda x: np.isclose(x[1], 0)).all(),
                       b.get_dofs(lambda x: np.isclose(x[0], 0)
                                  | np.isclose(x[0], 10 * B))
                       .nodal["u^1"]),
                   body_force=[0., -gamma], kinematics="finite",
                   nsteps=10, contacts=[Contact(0, 1)],
                   obstacles=[Obstacle(box=[[c - B, c + B],
                                            [head, head + B]],
                                       displacement=[0., -2 * B],
                                       friction="rough")])
    assert res.history[-1].load_factor == 1.
    weight = gamma * pts.volume[pts.body == 1].sum()
    settled = np.array([r.load_factor * 2 * B for r in res.history])
    q = np.array([r.obstacle_forces[0, 1] + weight for r in res.history]) \
        / B - gamma * (surface - tip + settled)
    half = settled >= B
    assert 7.5 * cu < q[half].mean() < 1.5 * 9 * cu
    assert (q[half] > .5 * 9 * cu).all()


@pytest.mark.slow
def test_a_rough_footing_body_stays_symmetric_as_its_soil_yields():
    """A user trial's stiff strip footing, a body in rough contact with
    von Mises soil, pushed by a rough box (cpGIMP, mean dilatation, a
    grid symmetric about the footing's middle, its sides on grid lines):
    the pairs of its bottom corners, found alike from two nodes with two
    normals, took x on one side and y on the other by the nodes' order,
    and from a settlement of 0.07 B the footing took a sideways force of
    up to 4.4% of its load (the load cut back three times).  Now the
    vertical is taken on both sides: the sideways force stays at
    round-off, and at most one step is cut back (the sixth, where pairs
    the soil formed beyond the step's join and Newton's second solve
    meets the yielding soil's singular tangents; none before the box's
    corners read the grid's field where they are, by the path alone:
    the forces before it agree to 6 digits)."""
    from skfem_mpm import Obstacle
    mesh = MeshQuad.init_tensor(np.linspace(-2.5, 2.5, 38),
                                np.linspace(0, 1.9, 16))
    pts = bodies(mesh, 2, [lambda x: x[1] < 1.5,
                           [(-.5, .5), (1.5, 1.8)]])
    top = float((pts.x[1] + pts.domain[1]).max())
    res = simulate(
        mesh, ElementQuad1(), pts,
        [VonMises(1e5, .3, yield_stress=100.), LinearElastic(1e7, .2)],
        lambda b: np.union1d(
            b.get_dofs(lambda x: x[1] == 0.).all(),
            b.get_dofs(lambda x: np.abs(x[0]) == 2.5).all("u^1")),
        nsteps=10, method="cpgimp",
        contacts=[Contact(0, 1, friction="rough")],
        obstacles=[Obstacle(box=[[-1.5, 1.5], [top, top + .3]],
                            displacement=[0., -.08], friction="rough")],
        options=Options(stabilisation=Stabilisation(antilocking=True)))
    assert len(res.history) <= 11
    force = np.array([r.contact_forces[0] for r in res.history])
    assert np.abs(force[:, 0]).max() < 1e-9 * force[:, 1].max()
    assert res.history[-1].n_yielded > 0


def block_on_a_base():
    """A user trial's direct shear: a block (body 1) on a base body (2 x
    2 points per cell, its sides inside cells): the grid, the points,
    the block's mask and the points' domains' low and high corners."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 3, 16), np.linspace(0, 1.3, 8))
    pts = bodies(mesh, 2, [lambda x: x[1] < .53,
                           lambda x: (x[1] > .53) & (x[1] < .93)
                           & (x[0] > .83) & (x[0] < 1.95)])
    return mesh, pts, pts.body == 1, pts.x - pts.domain, pts.x + pts.domain


@pytest.mark.slow
def test_a_block_pushed_past_coulomb_s_force_on_a_body_names_friction():
    """A user trial's block on a base body (friction 0.3, its weight in
    full from the start) pushed by a traction ramped to 0.4 of its
    weight: past 0.75 of the load no static equilibrium exists.  The run
    fails there, and its error names the contact's friction, mobilised
    in full (it named neither)."""
    from skfem_mpm import ConvergenceError
    mesh, pts, block, low, high = block_on_a_base()
    push = .4 * 1e4 * pts.volume[block].sum() / (
        high[1, block].max() - low[1, block].min())
    with pytest.raises(ConvergenceError, match="the friction of contact "
                       "'0-1' is mobilised in full") as failed:
        simulate(mesh, ElementQuad1(), pts,
                 [LinearElastic(1e5, .3), LinearElastic(1e6, .3)],
                 lambda b: b.get_dofs(lambda x: x[1] == 0),
                 body_force=BodyForce([0., -1e4], ramp=False), nsteps=4,
                 loads=[Traction(side_points(pts, "left", select=block),
                                 "left", [push, 0.])],
                 contacts=[Contact(0, 1, friction=.3)])
    assert failed.value.load_factor == pytest.approx(.75, abs=1e-3)


def test_a_stiff_block_on_a_soft_one_with_free_sides_stays_uniform():
    """A user trial's stack: a block 1e3 times stiffer on a soft one,
    sides free (inside a cell), a smooth interface, 10 load steps.  The
    soft block's Poisson expansion carries its edge corner past the stiff
    block's; that corner was left out of the stiff edge's pair (beyond
    the range the two bodies share), which took a corner a domain inside,
    and from step 7 the stress in the stiff block's corner reached
    2.54 p.  The corners of the first body's surface reaching on at an
    end now pair with it: within 13% of -p (the moving points' own error:
    the same blocks glued, of one material, 8%; one step: 3e-5)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1.5, 8),
                                np.linspace(0, 2.1, 12))
    pts = bodies(mesh, 3, [[(0, 1), (0, .9)], [(0, 1), (.9, 1.7)]])
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e4, .3), LinearElastic(1e7, .3)],
                   roller_base_and_left_wall, nsteps=10,
                   loads=[Traction(side_points(pts, "top"), "top",
                                   [0., -100.])],
                   contacts=[Contact(0, 1)])
    assert np.abs(res.points.stress[1, 1] / -100. - 1).max() < .13


@pytest.mark.parametrize("method, n, tol", [
    ("mpm", 3, 5e-3), ("cpgimp", 2, 5e-3),
    pytest.param("bspline", 2, 1e-2, marks=pytest.mark.slow)])
def test_a_stiff_footing_body_settles_alike_in_1_and_10_steps(method, n,
                                                               tol):
    """A user trial's stiff footing body (half of it, E 1e3 times its
    soil's) on elastic soil, smooth, on an untuned grid: a linear problem
    whose settlement (3.5% of a cell) must not depend on the load steps.
    Once the soil beside the footing stood a hundredth of a cell above
    its bottom, the soil's corner under its edge counted as beside it, the
    edge's pair took a corner a domain inside, and 10 steps settled 22%
    (MPM) and 30% (cpGIMP) more than one.  Now within 0.5% (B-splines:
    1%), with no sideways force on the smooth interface.  With B-splines
    the footing's sinking by a thirtieth of a cell let the soil beside it
    touch its side, and the edge's node took that side's normal: a
    sideways force of 13% of the load after one step."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 3, 15), np.linspace(0, 2, 11))
    pts = bodies(mesh, n, [lambda x: x[1] < 1.23,
                           [(0, .52), (1.23, 1.55)]])
    settled = []
    for nsteps in (1, 10):
        res = simulate(
            mesh, ElementQuad1(), pts,
            [LinearElastic(1e4, .3), LinearElastic(1e7, .3)],
            lambda b: np.union1d(
                b.get_dofs(lambda x: x[1] == 0).all(),
                b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 3)).nodal["u^1"]),
            loads=[Traction(side_points(pts, "top", select=pts.body == 1),
                            "top", [0., -100.])],
            nsteps=nsteps, method=method, contacts=[Contact(0, 1)])
        force = res.history[-1].contact_forces[0]
        assert abs(force[0]) < 1e-9 * force[1]
        settled.append(-res.points.displacement[1, pts.body == 1].mean())
    assert settled[1] == pytest.approx(settled[0], rel=tol)


@pytest.mark.parametrize("method", ("mpm", pytest.param(
    "cpgimp", marks=pytest.mark.slow), pytest.param(
    "bspline", marks=pytest.mark.slow)))
def test_a_block_pushed_over_a_base_body_slides_at_coulomb_s_force(
        method, caplog):
    """A user trial's direct shear: a block on a base body (friction
    0.3, its weight in full from the start) pushed sideways by a smooth
    ram through 0.1 in 10 steps: it carries no more than mu N in any step,
    and exactly mu N once sliding.  (A floor's end counted as the first
    body's own in the pairs' normals, tried, let steps 2 and 3 carry 1.12
    and 1.25 mu N, with cut-backs.)  With B-splines the base beside the
    block touched its side over the depth it had sunk, the node beside
    its edge took that side's normal, and the block carried up to 1.29 mu
    N (2.2 in finite strain).  The log names no remedy refused with
    contacts between bodies (extended splines)."""
    from skfem_mpm import Obstacle
    mesh, pts, block, low, high = block_on_a_base()
    left, bottom = low[0, block].min(), low[1, block].min()
    weight = 1e4 * pts.volume[block].sum()
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e5, .3), LinearElastic(1e6, .3)],
                   lambda b: b.get_dofs(lambda x: x[1] == 0),
                   body_force=BodyForce([0., -1e4], ramp=False), nsteps=10,
                   method=method, contacts=[Contact(0, 1, friction=.3)],
                   obstacles=[Obstacle(box=[[left - .5, left],
                                            [bottom + .05,
                                             high[1, block].max() + .2]],
                                       displacement=[.1, 0.])])
    assert len(res.history) == 10
    force = np.array([r.contact_forces[0] for r in res.history])
    assert np.allclose(force[:, 1], weight, rtol=1e-9)
    assert (-force[:, 0] <= .3 * weight * (1 + 1e-9)).all()
    assert -force[-1, 0] == pytest.approx(.3 * weight, rel=1e-9)
    assert "extended_splines" not in caplog.text


def in_a_hole(sides, tip):
    """The soil below 1.5 with a hole from ``sides`` down to ``tip``."""
    return lambda x: (x[1] < 1.5) & ~((x[0] > sides[0]) & (x[0] < sides[1])
                                      & (x[1] > tip))


@pytest.mark.parametrize("lower, upper, warned", [
    ([(0, 2), (0, 1)], [(.3, 1.3), (1, 1.5)], False),     # sides face none
    ([(0, 2), (0, 1.1)], [(.3, 1.3), (1.1, 1.6)], False),  # bottom in a cell
    ([(0, .6), (0, 2)], [(.6, 1.5), (0, 1)], False),       # side in a cell
    (in_a_hole((.8, 1.2), .5), [(.8, 1.2), (.5, 1.75)], True),  # a pile
    (in_a_hole((.8, 1.5), .5), [(.8, 1.5), (.5, 1.75)], True),  # one side
    (in_a_hole((.5, 1.5), .5), [(.5, 1.5), (.5, 1.75)], False),  # on lines
    (in_a_hole((.7, 1.2), .5), [(.8, 1.2), (.5, 1.75)], False)])  # apart
def test_lean_warning_only_where_a_side_in_a_cell_faces_the_other_body(
        lower, upper, warned, caplog):
    """A user trial: the warning that bodies meeting inside grid cells may
    lean was given for a block lying on a slab as wide as the grid, its
    bottom on a grid line, its sides inside cells and facing nothing;
    another's: for a block whose bottom on a slab lies inside a cell (a
    flat interface: cpGIMP, its settlement within 1% of the refined
    grid's, glued 5%), a block beside a wall body meeting it inside a
    cell, and a pile apart from its hole's side.  It is given where a body
    touches the other on both its sides across an axis, one of them
    inside a cell: a pile in its soil (h = 0.25) with its sides at 0.8
    and 1.2, or 0.8 and 1.5, not 0.5 and 1.5."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9), np.linspace(0, 2, 9))
    pts = bodies(mesh, 4, [lower, upper])
    simulate(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
             lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
             body_force=[0., -1e3], contacts=[Contact(0, 1, "rough")])
    assert ("may lean" in caplog.text) == warned


@pytest.mark.parametrize("contacts, warned", [
    ([(0, 1), (1, 2)], True),       # 0 and 2 glued: one body round 1
    ([(0, 1), (1, 2), (0, 2)], False)])     # three bodies
def test_lean_warning_counts_sides_touching_one_group_of_glued_bodies(
        contacts, warned, caplog):
    """The review: a block between two others, its flat interfaces
    inside cells (y = 1.125 and 2.125, h = 0.25), was warned as held
    between the other's, a pile in its soil, where its two sides touch
    two bodies apart; the sides count where they touch one group of
    glued bodies (one field), as the lower and upper block are where no
    contact parts them."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1.5, 7), np.linspace(0, 3, 13))
    pts = bodies(mesh, 2, [[(0, 1), (0, 1.125)], [(0, 1), (1.125, 2.125)],
                           [(0, 1), (2.125, 2.5)]])
    caplog.set_level("WARNING")
    simulate(mesh, ElementQuad1(), pts, LinearElastic(1e4, .3),
             roller_base_and_left_wall, method="cpgimp", nsteps=1,
             body_force=[0., -1e3],
             contacts=[Contact(a, b) for a, b in contacts])
    assert ("may lean" in caplog.text) == warned


@pytest.mark.parametrize("slope, warned", [(np.tan(np.radians(20.)), True),
                                           (0., False)])
def test_a_body_s_inclined_surface_is_warned_as_a_staircase(slope, warned,
                                                             caplog):
    """A user trial: a block seeded on a slab body's 20 degree slope did
    not slide, without friction (3% of g sin(theta) t^2 / 2): both
    surfaces are staircases of the points' domains, and contact acts on
    the steps' faces.  That is warned, naming the bodies and the levels
    (at least ``STAIRS``); a block on a level slab, a step and a pile are
    not (the warnings of the tests above and below)."""
    from skfem_mpm.solve.body_contact import STAIRS
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21), np.linspace(0, 1.4,
                                                                   15))
    slab = seed_points(mesh, 3, region=lambda x: x[1] < .2 + slope * x[0])
    o = np.array([.5, .2 + slope * .5])
    along = np.array([1., slope]) / np.hypot(1., slope)
    normal = np.array([-along[1], along[0]])

    def block(x):
        s, m = along @ (x - o[:, None]), normal @ (x - o[:, None])
        return (m > 0) & (m < .2) & (s > 0) & (s < .4)
    upper = seed_points(mesh, 3, region=block)
    upper.body[:] = 1
    simulate(mesh, ElementQuad1(), concatenate_points([slab, upper]),
             LinearElastic(1e7, .3),
             lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
             body_force=[0., -2e4], contacts=[Contact(0, 1)],
             dynamics=Dynamics(.01, .01, 2e3))
    found = re.search(r"staircase across axis \d \(its domains' faces at "
                      r"(\d+) consecutive levels", caplog.text)
    assert bool(found) == warned
    if warned:
        assert int(found.group(1)) >= STAIRS


def test_a_node_beyond_a_block_s_edge_in_line_with_its_floor_is_level():
    """The node beyond a block's edge on a slab (GIMP supports, h = 0.1):
    the block's corners there span one domain across, its ends at the
    slab's corners, and the slab reaches beyond both ends (at the left a
    sliver of its domain in the node's support).  Its normal is the
    vertical, smooth and with friction: the slab's corners at the ends
    are a floor under the block, not a side beside it.  Before, no corner
    lay between the ends, the vertical faced nothing, and the node took
    a leaning normal (-0.45, 0.89) (a user trial's block gliding on a
    slab body)."""
    from skfem_mpm.solve.contact_pairs import PairFinder
    h = .1
    mesh = MeshQuad.init_tensor(np.arange(0, 2 + h / 2, h),
                                np.arange(-.3, .4, h))
    finder = PairFinder([], None, mesh, mesh.p.shape[1], h)

    def corners(xs, ys):
        X = np.array(np.meshgrid(xs, ys)).reshape(2, -1)
        return np.zeros(X.shape[1], dtype=int), np.arange(X.shape[1]), X

    entries = [corners(1.05 + .05 * np.arange(6), [-.1, -.05, 0.]),
               corners([1.1, 1.15], [0., .05, .1])]
    centre = [np.array([[1.175], [-.05]]), np.array([[1.125], [.05]])]
    for smooth in (True, False):
        slot, normal = finder.separating_normal(
            entries, centre, np.array([[1.2], [0.]]), smooth)
        assert slot.tolist() == [0]
        assert normal[:, 0].tolist() == [0., 1.]


@pytest.mark.parametrize("method", ("ugimp", pytest.param(
    "cpgimp", marks=pytest.mark.slow)))
def test_a_block_gliding_on_a_slab_body_keeps_its_speed(method):
    """A user trial: a block (0.4 x 0.2, E = 1e6) given 1 m/s on a level
    elastic slab body (E = 5e6, held on its bottom), smooth contact,
    gravity, finite deformation, dynamics (h = 0.1, 2 x 2 points).
    Nothing acts on it along the slab: every step's contact force is
    vertical, and its momentum's speed stays 1 within what Newton's
    tolerance lets the out-of-balance force (at most ``tol`` times the
    weights) change it.  Before, with GIMP, once its edge had moved a
    cell and a half (in line with the slab's domains) the node beyond it
    took a leaning normal: a sideways force of 0.91 of the normal one at
    t = 0.15, the speed 0.66 (cpGIMP 0.76) at t = 0.16."""
    mesh = MeshQuad.init_tensor(np.linspace(.4, 1.6, 13),
                                np.linspace(-.2, .3, 6))
    pts = bodies(mesh, 2, [[(.4, 1.6), (-.2, 0.)], [(.6, 1.), (0., .2)]])
    block = pts.body == 1
    pts.velocity = np.zeros((2, pts.n))
    pts.velocity[0, block] = 1.
    rho, duration, tol = 1e3, .16, NewtonOptions().tol
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(5e6, .3), LinearElastic(1e6, .25)],
                   lambda b: b.get_dofs(lambda x: x[1] == -.2).all(),
                   body_force=[0., -G * rho], kinematics="finite",
                   method=method, contacts=[Contact(0, 1)],
                   dynamics=Dynamics(time_step=.01, duration=duration,
                                     density=rho))
    force = np.array([r.contact_forces[0] for r in res.history])
    assert (force[:, 1] > 0).all()
    assert np.abs(force[:, 0]).max() <= 1e-12 * force[:, 1].max()
    mass = rho * res.points.volume0
    slack = duration * tol * G * mass.sum() / mass[block].sum()
    speed = mass[block] @ res.points.velocity[0, block] / mass[block].sum()
    assert abs(speed - 1.) <= slack


@pytest.mark.slow
def test_a_block_gliding_on_a_slab_body_in_3d_keeps_its_speed():
    """The gliding block in 3D (0.4 x 0.4 x 0.2 on a slab two cells
    thick, h = 0.2, cpGIMP, 0.5 s): no sideways force, and its speed
    stays 1 along x (and 0 across) within Newton's tolerance as above.
    Before, it moved at 0.371 at the end, the sideways force up to 0.98
    of the largest normal one."""
    from skfem import ElementHex1, MeshHex
    mesh = MeshHex.init_tensor(np.linspace(0, 1.6, 9),
                               np.linspace(0, .8, 5),
                               np.linspace(-.4, .4, 5))
    pts = bodies(mesh, 2, [lambda x: x[2] < 0., lambda x: (x[0] > .4)
                           & (x[0] < .8) & (x[1] > .2) & (x[1] < .6)
                           & (x[2] > 0.) & (x[2] < .2)])
    block = pts.body == 1
    pts.velocity = np.zeros((3, pts.n))
    pts.velocity[0, block] = 1.
    rho, duration, tol = 1e3, .5, NewtonOptions().tol
    res = simulate(mesh, ElementHex1(), pts,
                   [LinearElastic(5e6, .3), LinearElastic(1e6, .25)],
                   lambda b: b.get_dofs(lambda x: x[2] == -.4).all(),
                   body_force=[0., 0., -G * rho], kinematics="finite",
                   method="cpgimp", contacts=[Contact(0, 1)],
                   dynamics=Dynamics(time_step=.01, duration=duration,
                                     density=rho))
    force = np.array([r.contact_forces[0] for r in res.history])
    assert np.abs(force[:, :2]).max() <= 1e-12 * force[:, 2].max()
    mass = rho * res.points.volume0
    slack = duration * tol * G * mass.sum() / mass[block].sum()
    speed = res.points.velocity[:2, block] @ mass[block] / mass[block].sum()
    assert np.abs(speed - [1., 0.]).max() <= slack


@pytest.mark.slow
def test_a_block_tilted_past_coulomb_from_the_start_names_its_load():
    """The block on a base body (:func:`block_on_a_base`) under its
    weight tilted past friction's angle
    (tan theta = 1.2 mu) from the first step: no step converges, so no
    friction is mobilised at a converged state, and the error named
    neither friction nor the contact (a user trial's block on a slab).
    Now it names the load's ratio to mu times its pressing force,
    tan theta / mu."""
    from skfem_mpm import ConvergenceError
    mesh, pts, block, low, high = block_on_a_base()
    mu, theta = .3, np.arctan(1.2 * .3)
    with pytest.raises(ConvergenceError, match="the load on body 1 pushes "
                       "it along its contact '0-1' with body 0 with "
                       "{:.3f} times mu".format(np.tan(theta) / mu)):
        simulate(mesh, ElementQuad1(), pts,
                 [LinearElastic(1e5, .3), LinearElastic(1e6, .3)],
                 lambda b: b.get_dofs(lambda x: x[1] == 0),
                 body_force=1e4 * np.array([np.sin(theta), -np.cos(theta)]),
                 nsteps=2, contacts=[Contact(0, 1, friction=mu)])


def stacked_halves(h=.125, weight=2e4, nsteps=1,
                   material=LinearElastic(1e6, .3), **kwargs):
    """benchmarks/contact_cost.py's ``--bodies`` scene, 8 x 8 cells: a
    unit square cut at y = 0.5 into two bodies in smooth contact, the
    lower held by the grid nodes of y = 0, one load step (``nsteps``) of
    finite deformation under its ``weight`` per unit volume (the bodies
    of ``material``, or of a material each)."""
    mesh = MeshQuad.init_tensor(np.arange(0., 1. + 2.5 * h, h),
                                np.arange(-h, 1. + 2.5 * h, h))
    pts = seed_points(mesh, 2, region=lambda x: (x[0] < 1.) & (x[1] > 0)
                      & (x[1] < 1.))
    pts.body[:] = pts.x[1] > .5

    def supports(b):
        return np.concatenate([b.get_dofs(lambda x: x[0] == 0).all("u^1"),
                               b.get_dofs(lambda x: np.isclose(x[1], 0.))
                               .all()])
    kwargs.setdefault("body_force", [0., -weight])
    kwargs.setdefault("contacts", [Contact(0, 1)])
    return simulate(mesh, ElementQuad1(), pts, material, supports,
                    nsteps=nsteps, kinematics="finite", **kwargs)


def test_a_step_of_bodies_in_contact_keeps_one_tangent_pattern():
    """The contact's matrix couples two fields' nodes, beyond the
    stiffness's pattern: the sum is on the union of both patterns with
    every explicit zero kept, so each tangent of the step has one
    pattern and a direct solver analyses it once (scipy's sum dropped
    the first tangent's zeros at rest: Pardiso analysed the step twice,
    0.2 s at 1e5 points); the upper body's weight crosses the interface
    whole."""
    from scipy.sparse.linalg import spsolve
    patterns = []

    def solver(A, b):
        A = A.tocsr()
        patterns.append((A.nnz, hash(A.indices.tobytes())))
        return spsolve(A, b)
    res = stacked_halves(options=Options(solver=solver, stabilisation=(
        Stabilisation(ghost=0.))))
    assert res.counters["contact_updates"] >= 1
    assert len(patterns) >= 3 and len(set(patterns)) == 1
    weight = 2e4 * .5                    # the upper half, 1 x 0.5
    assert np.allclose(res.history[-1].contact_forces, [[0., weight]],
                       rtol=1e-10)


def test_pairs_joined_after_newton_start_the_next_solve_afresh(caplog):
    """Pairs that join after a converged solve (the bodies met beyond the
    step's pairs: the upper half's lower corners at its free edge, the
    halves squeezed 20% under their weight) change the constraints: the
    next solve's first direction is the new tangent's.  By the kept
    tangent, blind to the new pairs, its residual rose from 12 to 14 and
    the step took 47 Newton iterations where it took 28 (at 1e5 points
    and a tenth of the weight, 25 where 9).  The joined pairs start
    unpressed, their penetration all on the penalty, hundreds of
    tolerances off: the next solve stops at the loose residual, as a
    step's first does (another update follows it anyway), and the step
    takes 20 iterations where it took 24 solving to the tolerance."""
    with caplog.at_level("DEBUG", logger="skfem_mpm"):
        res = stacked_halves(h=1 / 24, weight=2e5, nsteps=4,
                             options=Options(stabilisation=Stabilisation(
                                 ghost=0.)))
    records = [(r.name, r.getMessage()) for r in caplog.records]
    joins = [k for k, (_, line) in enumerate(records)
             if "bodies met beyond the step's pairs" in line]
    assert len(joins) >= 2
    for k in joins:
        after = []                      # the next solve's residuals
        for name, line in records[k + 1:]:
            if not name.endswith(".newton") or (
                    after and " iteration 0:" in line):
                break
            if " iteration " in line:
                after.append(float(line.split("residual ")[1]))
        # Newton from the new tangent: the residual falls at once, to
        # the loose residual (1e-3 of the solve's first), not the
        # tolerance
        assert len(after) >= 2 and after[1] < after[0]
        assert 1e-9 < after[-1] <= 1e-3 * after[0]
    assert res.history[2].newton_iterations <= 21


def test_a_contact_step_computes_the_domains_corners_once():
    """The corners of the points' domains, read by the pairs' search, the
    held DOFs, each join and the commit, are computed once per state
    (18 times a step at 1e5 points, 0.24 s)."""
    from skfem_mpm.solve.body_contact import BodyContact
    seen = []
    corners = BodyContact.corners

    def counted(self, points):
        X = corners(self, points)
        if not any(X is Y for Y in seen):
            seen.append(X)
        return X
    BodyContact.corners = counted
    try:
        stacked_halves(options=Options(stabilisation=Stabilisation(
            ghost=0.)))
    finally:
        BodyContact.corners = corners
    assert len(seen) == 1


def test_a_pressed_pair_starts_its_step_at_the_pressure_it_is_rising_to():
    """A step starts a pressed pair's multiplier ahead, by the rate its
    pressure rose at in the last step: from the last step's pressure the
    step's added pressure was all on the penalty, and each step took two
    augmented-Lagrangian updates (its first round 500 times the
    tolerance off).  Four steps of the halves' weight (elastic, finite
    strain): one update a step after the first, and the end where the
    same weight in one step puts it (a hyperelastic body's path does not
    matter), within the contact's tolerance."""
    opts = Options(stabilisation=Stabilisation(ghost=0.))
    res = stacked_halves(nsteps=4, options=opts)
    updates = np.diff([0] + [r.counters["contact_updates"]
                             for r in res.history])
    assert updates[0] == 2 and (updates[1:] <= 1).all()
    one = stacked_halves(options=opts)
    h = .125
    assert np.abs(res.points.displacement
                  - one.points.displacement).max() < 1e-3 * h
    assert np.allclose(res.history[-1].contact_forces, [[0., 2e4 * .5]],
                       rtol=1e-10)


def test_a_node_s_pair_on_another_corner_starts_from_its_last_pressure():
    """A node's pair is the second body's corner nearest it: the upper
    half ten times softer than the lower spreads over it under its
    weight (h = 1/16, 8 steps), and from step 7 two nodes by its edge
    pair the corners beside their last ones.  Those pairs started from
    nothing, their share of the weight all on the penalty, and each of
    the two steps took 3 augmented-Lagrangian updates and 12 Newton
    iterations; each now starts from its node's last pressure (and
    rate): every pair starts pressed, 2 updates and 10 iterations (7
    where the solve after pairs joined stops at the loose residual), the
    displacements within 2.7e-6 cells of the old (the tolerance 1e-3);
    the upper half's weight crosses the interface whole."""
    from skfem_mpm.solve.body_contact import StepBodyContact
    unpressed, add = [], StepBodyContact.add

    def counted(self, part, *args, **kwargs):
        add(self, part, *args, **kwargs)
        if self.problem.f_old > 0. and "keys" in part and \
                part["keys"].size == args[2].size:     # the step's start
            unpressed.append(int((part["start"] == 0.).sum()))
    h = 1 / 16
    kwargs = dict(h=h, material=[LinearElastic(1e6, .3),
                                 LinearElastic(1e5, .3)],
                  options=Options(stabilisation=Stabilisation(ghost=0.)))
    StepBodyContact.add = counted
    try:
        res = stacked_halves(nsteps=8, **kwargs)
    finally:
        StepBodyContact.add = add
    assert unpressed == [0] * 7
    updates = np.diff([0] + [r.counters["contact_updates"]
                             for r in res.history])
    assert (updates[1:] <= 2).all()
    assert sum(r.newton_iterations for r in res.history[6:]) <= 14
    assert np.allclose(res.history[-1].contact_forces, [[0., 2e4 * .5]],
                       rtol=1e-10)


def test_a_coulomb_pair_s_traction_follows_its_predicted_pressure(caplog):
    """A reviewer's: the halves in contact with friction 0.3, the upper
    pulled sideways by a fifth of its weight, in dynamics under a load
    sin(pi t) + 0.05 that rises and eases off.  A pair's friction
    traction starts scaled with its predicted pressure: kept as it was,
    it lay outside the cone where the pressure was predicted to fall,
    Newton cycled between stick and slip (residuals 1.269 and 1.273 for
    25 iterations), and the last step was retried twice and cut back
    (11 steps, 196 Newton iterations, the normal force 497.6 for
    502.0).  Now 10 steps, none retried, and the contact carries the
    upper half's weight times the load's scale."""
    from skfem_mpm import Dynamics
    weight = 2e4
    load = lambda t: np.sin(np.pi * t) + .05                 # noqa: E731
    with caplog.at_level("WARNING", logger="skfem_mpm"):
        res = stacked_halves(
            body_force=[[0., -weight], [-weight / 5, -weight]],
            contacts=[Contact(0, 1, friction=.3)], nsteps=None,
            dynamics=Dynamics(time_step=.1, duration=1., density=1000.,
                              load=load),
            options=Options(stabilisation=Stabilisation(ghost=0.)))
    assert len(res.history) == 10
    assert not [r for r in caplog.records if "retrying" in r.getMessage()
                or "cutting" in r.getMessage()]
    assert res.counters["newton_iterations"] <= 50


def test_a_large_grid_of_bodies_in_contact_gives_no_layout_warning(caplog):
    """The pairs' grid locator was built from slices of the fields' mesh,
    which scikit-fem warns of beyond 1000 vertices ("Transforming over
    1000 vertices to C_CONTIGUOUS", a user trial's 3D runs and the
    benchmark's at their start); the stacked halves on 1225 vertices:
    none, the contact force the upper half's weight."""
    import logging
    with caplog.at_level(logging.WARNING):
        res = stacked_halves(h=1. / 32)
    assert "C_CONTIGUOUS" not in caplog.text
    weight = 2e4 * .5
    assert res.history[-1].contact_forces[0, 1] == pytest.approx(
        weight, rel=1e-6)


def test_rounds_far_from_settling_stop_at_the_loose_residual(monkeypatch):
    """Two bodies of one square under their weight (the scene of
    ``benchmarks/contact_cost.py --bodies``), one step from rest: the
    first round ends 1e3 of the tolerance off (no pressure to start
    from), so the solve after its update also stops at the loose
    residual (``FAR_OFF``), and the next one starts from a fresh tangent
    (the kept one is two rounds old): 4 Newton iterations where 5, as
    many factorisations as the glued step takes, displacements within
    1e-7 of the largest (1.7e-9 measured)."""
    cells = 16
    h = 1. / cells
    mesh = MeshQuad.init_tensor(np.linspace(0., 1. + 2 * h, cells + 3),
                                np.linspace(-h, 1. + 2 * h, cells + 4))
    pts = seed_points(mesh, 2, region=lambda x: (x[0] < 1.) & (x[1] > 0.)
                      & (x[1] < 1.))
    pts.body[:] = pts.x[1] > .5

    def supports(b):
        return np.concatenate([
            b.get_dofs(lambda x: x[0] == 0).all("u^1"),
            b.get_dofs(lambda x: np.isclose(x[1], 0.)).all()])

    def run(contacts):
        return simulate(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
                        supports, body_force=[0., -2e4], nsteps=1,
                        kinematics="finite", contacts=contacts,
                        options=Options(stabilisation=Stabilisation(
                            ghost=0.)))
    glued = run([])
    far = run([Contact(0, 1)])
    monkeypatch.setattr(core, "FAR_OFF", np.inf)
    near = run([Contact(0, 1)])
    assert near.counters["newton_iterations"] == 5
    assert far.counters["newton_iterations"] == 4
    assert far.counters["factorisations"] == \
        glued.counters["factorisations"]
    u = far.history[-1].displacement
    assert np.abs(u - near.history[-1].displacement).max() <= \
        1e-7 * np.abs(u).max()


@pytest.mark.parametrize("method", ["ugimp", "mpm"])
def test_a_smooth_pile_settles_alike_with_its_contact_declared_reversed(
        method):
    """A trial's smooth pile (E = 1e8, two cells wide on grid lines, its
    tip at y = 0.5) with a wider cap, one body, in soil (E = 1e6), a
    traction on the cap: declared Contact(1, 0) its tip kept one pair
    and passed into the soil, and it settled 14.10 mm against 7.76 with
    Contact(0, 1) (uGIMP; MPM 16.72 and 7.88).  Now the smaller body's
    corners are paired either way: the same settlement, the force of
    each contact's first body on its second opposite, the load."""
    h, p = .125, 2e4
    mesh = MeshQuad.init_tensor(np.arange(0, 2 + 1e-9, h),
                                np.arange(0, 1.75 + 1e-9, h))

    def pile(x):
        return (np.abs(x[0] - 1.) < .125) & (x[1] > .5) & (x[1] < 1.25)

    def cap(x):
        return (np.abs(x[0] - 1.) < .25) & (x[1] > 1.25) & (x[1] < 1.5)
    pts = bodies(mesh, 2, [lambda x: (x[1] < 1.) & ~pile(x)
                           & ~((np.abs(x[0] - 1.) < .125) & (x[1] > .5)),
                           lambda x: pile(x) | cap(x)])
    top = side_points(pts, "top", select=pts.body == 1)

    def fixed(b):
        return np.union1d(b.get_dofs(lambda x: x[1] == 0).all(),
                          b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 2))
                          .nodal["u^1"])
    runs = [simulate(mesh, ElementQuad1(), pts,
                     [LinearElastic(1e6, .3), LinearElastic(1e8, .3)],
                     fixed, loads=[Traction(top, "top", [0., -p])],
                     nsteps=2, method=method, contacts=[contact])
            for contact in (Contact(0, 1), Contact(1, 0))]
    tip = [(r.points.x[1] - pts.x[1])[pts.body == 1].min() for r in runs]
    assert tip[0] < -5e-3
    assert abs(tip[0] - tip[1]) < 1e-3 * h
    forces = [r.history[-1].contact_forces[0] for r in runs]
    assert np.allclose(forces[0], -forces[1], rtol=0., atol=1e-9 * p)
    assert np.allclose(forces[0], [0., p * .5], rtol=1e-6, atol=1e-6 * p)
