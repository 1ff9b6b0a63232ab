"""The normal of a node where two bodies in contact meet along level faces
(:meth:`skfem_mpm.solve.contact_pairs.PairFinder.level`): a block's edge
lifted or sunk a fraction of a cell on a slab body."""
import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (Contact, Dynamics, LinearElastic, NewtonOptions,
                       Obstacle, Traction, seed_points, side_points,
                       simulate)
from skfem_mpm.quadrature.points import concatenate_points
from skfem_mpm.solve.contact_pairs import AXIS, PairFinder

LEVEL = .1

G = 9.81
H = .1


def finder():
    mesh = MeshQuad.init_tensor(np.arange(0, 2 + H / 2, H),
                                np.arange(-.3, .4, H))
    return PairFinder([], None, mesh, mesh.p.shape[1], H)


def corners(xs, ys):
    """(node, corner, position) entries of corners on a grid, all at the
    first node."""
    X = np.array(np.meshgrid(xs, ys)).reshape(2, -1)
    return np.zeros(X.shape[1], dtype=int), np.arange(X.shape[1]), X


@pytest.mark.parametrize("bottom", [.012, -.02])
def test_a_block_s_edge_lifted_or_sunk_on_a_slab_takes_the_vertical(bottom):
    """The node (1.3, 0) beyond a block's right edge (x = 1.235), its
    corners one domain across, the slab's (domains 0.05 apart, its top
    at 0) spanning three cells: the block lifted 0.12 cells (bouncing,
    a user trial's drop) or sunk 0.2 cells.  Both faces are level: the
    normal is the vertical, smooth and with friction.  Before, the
    block's direction from its centroid to the node, leaning (-0.89,
    0.46), showed the bodies farther apart (to the slab's corner at
    x = 1.25 beside the edge) than the vertical, and a smooth contact
    pushed the block sideways."""
    slab = corners(1.15 + .05 * np.arange(7), [-.15, -.1, -.05, 0.])
    block = corners([1.185, 1.235], bottom + np.array([0., .05, .1]))
    # the block's direction from its centroid (its points' there, 0.035
    # above its bottom) to the node leans, and along it the block's
    # corner (1.235, bottom) lies farther from the slab's corner at 1.25
    # than along the vertical from the slab's top, by more than the grid
    # axes' preference (the separating axis without level faces)
    centres = [np.array([[1.3], [-.0375]]),
               np.array([[1.21], [bottom + .035]])]
    node = np.array([[1.3], [0.]])
    n = (centres[1] - node)[:, 0] / np.linalg.norm(centres[1] - node)
    assert n[0] < -.85
    lean = n @ (np.array([1.235, bottom]) - np.array([1.25, 0.]))
    assert lean > bottom + AXIS * H
    pf = finder()
    for smooth in (True, False):
        slot, normal = pf.separating_normal(
            [slab, block], centres, node, smooth)
        assert slot.tolist() == [0]
        assert normal[:, 0].tolist() == [0., 1.]
    assert pf.level([slab, block], np.array([[0.], [1.]])).tolist() \
        == [True]


@pytest.mark.parametrize("slab_x, dent, block_x, bottom, centres, node", [
    # the block's edge at x = 1.2 in line with the slab's domains at the
    # node: the corners meet edge to edge, x and the vertical alike
    (1.2 + .1 * np.arange(5), 0., [1.1, 1.2], -.05,
     [[1.4, .4, -.1], [1.15, .4, .028]], [1.4, .4, .1])])
def test_a_block_s_edge_on_a_slab_in_3d_takes_the_vertical(
        slab_x, dent, block_x, bottom, centres, node):
    """3D, h = 0.2, domains 0.1 (a user trial's drop, cpGIMP): a block
    on a slab (its top at z = -0.05), the node beyond or behind its edge.
    The normal is the vertical alone, smooth and with friction.  Before,
    in line (the corners meeting edge to edge, x and the vertical alike)
    the line between the centroids took x, and a smooth contact pushed
    the block back with 5.4 times the normal force in one step (1 m/s
    became 0.46)."""
    from skfem import MeshHex
    h = .2
    grid = np.arange(-.4, 2. + h / 2, h)
    mesh = MeshHex.init_tensor(grid, grid, grid)
    pf = PairFinder([], None, mesh, mesh.p.shape[1], h)

    def corners3(xs, ys, zs):
        X = np.array(np.meshgrid(xs, ys, zs)).reshape(3, -1)
        return np.zeros(X.shape[1], dtype=int), np.arange(X.shape[1]), X

    ys = .2 + .1 * np.arange(5)
    slab = corners3(slab_x, ys, [-.25, -.15, -.05])
    slab[2][2] -= dent * (slab[2][0] > .55)
    block = corners3(block_x, ys, bottom + np.array([0., .1, .2]))
    centres = [np.array(c)[:, None] for c in centres]
    for smooth in (True, False):
        slot, normal = pf.separating_normal(
            [slab, block], centres, np.array(node)[:, None], smooth)
        assert slot.tolist() == [0]
        assert normal[:, 0].tolist() == [0., 0., 1.]


def raised(entries, rise):
    """``entries`` with each corner raised by ``rise(x)``."""
    node, corner, X = entries
    return node, corner, X + np.array([[0.], [1.]]) * rise(X[0])


XS = 1.15 + .05 * np.arange(7)


@pytest.mark.parametrize("slab, block", [
    # a block's corner in a notch of the slab (a pile's tip): the slab
    # beside it rises above its top under it
    (tuple(np.r_[a, b] if a.ndim == 1 else np.c_[a, b] for a, b in zip(
        corners(XS, [-.1, -.05]), corners([1.15, 1.2, 1.4, 1.45], [0.]))),
     corners([1.25, 1.3, 1.35], [-.05, 0.])),
    # an inclined slab (its corners' staircase rising by 0.24 cells, more
    # than LEVEL, across the node's support) under a block parallel to it
    (raised(corners(XS, [-.1, -.05, 0.]), lambda x: .08 * (x - 1.3)),
     raised(corners(XS, [0., .05]), lambda x: .08 * (x - 1.3))),
    # a block's bottom with a step of twice LEVEL cells
    (corners(XS, [-.05, 0.]),
     raised(corners(XS, [0., .05]), lambda x: (x > 1.3) * 2 * LEVEL * H))])
def test_notches_inclines_and_steps_are_not_level(slab, block):
    """Where the surfaces lean (an incline's staircase), or a body's
    corner lies in a notch of the other, or a face has a step, the
    vertical is not a level face: the separating axis decides."""
    assert finder().level([slab, block], np.array([[0.], [1.]])).tolist() \
        == [False]


@pytest.mark.slow
@pytest.mark.parametrize("method", ["ugimp", "cpgimp"])
def test_a_block_dropped_on_a_slab_body_keeps_its_speed(method):
    """A user trial: a block (0.4 x 0.2, E = 1e6) thrown at 1 m/s and
    dropped 0.2 onto an elastic slab body (E = 5e6, on a rough floor),
    smooth contact, gravity, finite deformation, dynamics at dt = 0.005
    (h = 0.1, 2 x 2 points), to its second landing.  Nothing acts on it
    along the slab: every step's contact force is vertical, and its
    speed stays 1 within what Newton's tolerance lets the out-of-balance
    force change it (as for the gliding block).  Before, bouncing, its
    edge lifted 0.12 cells and the node beyond it took a leaning normal:
    at t = 0.41 a sideways force 2.3 times the normal one, and it moved
    at -0.56 at t = 0.5."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(-.3, 1., 14))
    parts = [seed_points(mesh, 2, region=lambda x: (x[1] > -.25)
                         & (x[1] < 0.)),
             seed_points(mesh, 2, region=lambda x: (x[0] > .6)
                         & (x[0] < 1.) & (x[1] > .2) & (x[1] < .4))]
    parts[1].body[:] = 1
    pts = concatenate_points(parts)
    block = pts.body == 1
    pts.velocity = np.zeros((2, pts.n))
    pts.velocity[0, block] = 1.
    rho, duration, tol = 1e3, .45, NewtonOptions().tol
    floor = Obstacle(box=[[-1., 3.], [-1., -.25]], friction="rough")
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(5e6, .3), LinearElastic(1e6, .25)], [],
                   body_force=[0., -G * rho], kinematics="finite",
                   method=method, obstacles=[floor],
                   contacts=[Contact(0, 1)],
                   dynamics=Dynamics(time_step=.005, duration=duration,
                                     density=rho))
    force = np.array([r.contact_forces[0] for r in res.history])
    landed = np.flatnonzero(force[:, 1] > 0)
    # it lands twice (at 0.205 and, bouncing, at 0.41)
    assert landed.size and res.history[landed[-1]].time > .4
    assert np.abs(force[:, 0]).max() <= 1e-12 * force[:, 1].max()
    mass = rho * res.points.volume0
    slack = duration * tol * G * mass.sum() / mass[block].sum()
    speed = mass[block] @ res.points.velocity[0, block] / mass[block].sum()
    assert abs(speed - 1.) <= slack


@pytest.mark.parametrize("method", ["ugimp", "cpgimp"])
def test_a_footing_sunk_into_its_soil_takes_no_sideways_force(method):
    """A footing body four cells wide (E = 1e6) on an elastic soil
    body (E = 1e4) across a smooth level contact, small strain, held
    along x at its top's middle, pressed in 2 steps: the contact's force
    has no x component (to 1e-10 of its y one) at every step.  Before,
    at step 2 the footing had sunk 0.02 cells below the soil beside it,
    a node beside its edge took x as its normal, and its edge corner was
    paired along x with the corner of the soil domain beside it, moved
    by its point's gradient 0.003 cells past the footing's side and
    2e-4 cells above its bottom: the soil sliding under the smooth
    footing read as a penetration across x (Fx/Fy 1.8e-2 with cpGIMP; a
    user trial's footing 1.4-2.1% from step 3 of 4)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 17),
                                np.linspace(0, 1.25, 11))
    parts = []
    for k, region in enumerate([
            lambda x: x[1] < 1.,
            lambda x: (np.abs(x[0] - .75) < .25) & (x[1] > 1.)]):
        p = seed_points(mesh, 2, region=region)
        p.body[:] = k
        parts.append(p)
    pts = concatenate_points(parts)
    top = side_points(pts, "top", select=pts.body == 1)
    node = np.flatnonzero(np.isclose(mesh.p[0], .75)
                          & np.isclose(mesh.p[1], 1.25))

    def supports(basis):
        return np.union1d(np.union1d(
            basis.get_dofs(lambda x: x[1] == 0).all(),
            basis.get_dofs(lambda x: (x[0] == 0) | (x[0] == 2))
            .nodal["u^1"]), basis.nodal_dofs[0, node])

    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(1e4, .3), LinearElastic(1e6, .2)],
                   supports, loads=[Traction(top, "top", [0., -50.])],
                   nsteps=2, method=method, contacts=[Contact(0, 1)])
    forces = np.array([rec.contact_forces[0] for rec in res.history])
    assert np.allclose(forces[:, 1], [12.5, 25.], rtol=1e-9)
    assert np.abs(forces[:, 0]).max() < 1e-10 * 25.
    assert 1.8e-3 < -res.points.displacement[1, res.points.body == 1] \
        .mean() < 2.6e-3


@pytest.mark.slow
def test_a_pile_with_a_cap_warns_of_pairs_that_start_deep(caplog):
    """Not fixed (``docs/contact.md``, not yet good enough): a pile two
    cells wide with a glued cap a cell above elastic soil, smooth, small
    strain, cpGIMP, 2 load steps.  After step 1 the cap reaches a sliver
    into the supports of the soil's surface nodes beside the pile, the
    bodies read as overlapping there along every candidate, and a pair
    along the leaning centroid line starts 0.45 cells deep: it is told
    (a warning, once a run), and the settlement, 1.4164 mm, is 7% below
    that in one step (1.5227; standard MPM 1.5196 in two; in 5 steps the
    pair starts deep in each from the second)."""
    h = .125
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 17),
                                np.linspace(0, 1.5, 13))

    def pile(x):
        return (np.abs(x[0] - 1.) < h) & (x[1] > .5) & (x[1] < 1.125)

    parts = []
    for k, region in enumerate([
            lambda x: (x[1] < 1.) & ~pile(x), pile,
            lambda x: (np.abs(x[0] - 1.) < 2 * h) & (x[1] > 1.125)
            & (x[1] < 1.25)]):
        p = seed_points(mesh, 2, region=region)
        p.body[:] = k
        parts.append(p)
    pts = concatenate_points(parts)
    top = side_points(pts, "top", select=pts.body == 2)

    def supports(basis):
        return np.union1d(
            basis.get_dofs(lambda x: x[1] == 0).all(),
            basis.get_dofs(lambda x: (x[0] == 0) | (x[0] == 2))
            .nodal["u^1"])

    def settled(nsteps):
        caplog.clear()
        with caplog.at_level("WARNING",
                             logger="skfem_mpm.solve.body_contact"):
            res = simulate(mesh, ElementQuad1(), pts.copy(),
                           [LinearElastic(1e4, .3), LinearElastic(1e7, .2),
                            LinearElastic(1e7, .2)], supports,
                           loads=[Traction(top, "top", [0., -40.])],
                           nsteps=nsteps, method="cpgimp",
                           contacts=[Contact(0, 1), Contact(0, 2)])
        told = [r.getMessage() for r in caplog.records
                if "cells deep" in r.getMessage()]
        return -res.points.displacement[1, res.points.body == 2].mean(), \
            told
    once, quiet = settled(1)
    twice, told = settled(5)
    assert not quiet
    # told once a run (the review: every step from the second, 4 of 5)
    assert len(told) == 1 and told[0].startswith("step 2:")
    assert "0.45 cells deep" in told[0]
    # what the warning is about: the two steps' settlement off the one's
    assert abs(twice / once - 1.) > .05


@pytest.mark.parametrize("dim", [2, 3])
def test_projections_are_the_gathered_sums_to_the_bit(dim):
    """``contact_pairs.projection``, the corners' positions along their
    nodes' directions a component at a time, is the gathered product
    summed over the components, bit for bit (the search for pairs it
    serves keeps its answers)."""
    from skfem_mpm.solve.contact_pairs import projection
    rng = np.random.default_rng(3)
    direction = rng.standard_normal((dim, 500))
    direction[:, ::7] = -0.                      # signed zeros too
    node = rng.integers(0, 500, 20000)
    X = rng.standard_normal((dim, 20000)) * 10. ** rng.integers(
        -8, 8, 20000)
    gathered = (direction[:, node] * X).sum(axis=0)
    assert projection(direction, node, X).tobytes() == gathered.tobytes()
