"""Supports on the fields of bodies in contact: a support holds a body's
copy of a grid node only where the body's material lies on it
(:meth:`skfem_mpm.solve.body_contact.BodyContact.held_supports`)."""
import numpy as np
import pytest
from skfem import Basis, ElementQuad1, ElementVector, MeshQuad

from skfem_mpm import (Contact, Dynamics, LinearElastic, Options,
                       seed_points, simulate)
from skfem_mpm.quadrature.points import concatenate_points
from test_body_contact import full_and_resumed

GAMMA = 9810.          # weight per unit volume (density 1000, g 9.81)


def bodies(mesh, boxes):
    """2 x 2 points per cell in each box, one body per box in order."""
    parts = []
    for body, ((x0, x1), (y0, y1)) in enumerate(boxes):
        part = seed_points(mesh, 2, region=lambda x: (
            x[0] > x0) & (x[0] < x1) & (x[1] > y0) & (x[1] < y1))
        part.body[:] = body
        parts.append(part)
    return concatenate_points(parts)


def base(b):
    return b.get_dofs(lambda x: np.isclose(x[1], -.1)).all()


@pytest.mark.parametrize("method", [
    pytest.param("ugimp", marks=pytest.mark.slow),
    pytest.param("cpgimp", marks=pytest.mark.slow), "mpm",
    pytest.param("bspline", marks=pytest.mark.slow)])
def test_a_block_glides_on_a_held_slab(method):
    """An elastic block given vx = 1 on an elastic slab one cell thick
    whose base the supports hold, smooth contact, gravity, dynamics: the
    supports held the block's own copy of their nodes once its domains
    reached the slab's cells (B-splines: from the start), and braked it
    through them, the contact pushing nothing sideways: mean vx at 0.2 s
    0.043 (uGIMP), 0.053 (cpGIMP), -0.70 (B-splines); MPM's points do
    not reach the slab's nodes.  The block keeps vx = 1, the contact has
    no horizontal force, and the slab stays held."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(-.1, 1., 12))
    pts = bodies(mesh, [[(0., 2.), (-.1, 0.)], [(.6, 1.), (0., .2)]])
    block = pts.body == 1
    v = np.zeros((2, pts.n))
    v[0, block] = 1.
    pts.velocity = v
    T = .2
    res = simulate(mesh, ElementQuad1(), pts,
                   [LinearElastic(5e6, .3), LinearElastic(1e6, .25)], base,
                   body_force=[0., -GAMMA], kinematics="finite",
                   method=method, contacts=[Contact(0, 1)],
                   dynamics=Dynamics(time_step=.01, duration=T,
                                     density=1000.),
                   options=Options(keep_snapshots=True))
    # the block's momentum (points of equal mass), and where it went
    assert abs(res.points.velocity[0, block].mean() - 1.) < 1e-4
    assert abs(res.points.displacement[0, block].mean() - T) < 1e-4
    F = np.array([r.contact_forces[0] for r in res.history])
    assert np.abs(F[:, 0]).max() <= 1e-9 * np.abs(F[:, 1]).max()
    assert F[:, 1].max() > 0.           # the block presses the slab
    assert np.abs(res.points.displacement[:, ~block]).max() < 1e-4


@pytest.mark.parametrize("method", ("ugimp", "cpgimp", "mpm", "bspline"))
def test_bodies_on_the_supports_are_held(method):
    """Quasi-static, small strain: a slab and, two cells beside it, a
    block stand on the held base; a third body lies on the slab (rough).
    The base's nodes under the block carry the block's weight, those
    under the slab the slab's and the third body's, each to 1e-8: the
    third body's copies there are free, the others' held."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(-.1, 1., 12))
    pts = bodies(mesh, [[(0., .7), (-.1, 0.)], [(1., 1.4), (-.1, .2)],
                        [(.2, .5), (0., .1)]])
    res = simulate(mesh, ElementQuad1(), pts, LinearElastic(1e6, .3),
                   base, body_force=[0., -GAMMA], method=method,
                   contacts=[Contact(0, 1), Contact(0, 2, friction="rough"),
                             Contact(1, 2)])
    r = res.history[-1]
    x = Basis(mesh, ElementVector(ElementQuad1())).doflocs[
        :, r.reaction_dofs]
    up = r.reaction_dofs % 2 == 1
    weight = GAMMA * np.bincount(pts.body, pts.volume)
    under_block = up & (x[0] > .85)
    assert np.isclose(r.reaction_values[under_block].sum(), weight[1],
                      rtol=1e-8)
    assert np.isclose(r.reaction_values[up & ~under_block].sum(),
                      weight[0] + weight[2], rtol=1e-8)


@pytest.mark.parametrize("method", ("ugimp", "bspline"))
def test_resume_is_bit_identical(method):
    """The gliding block resumed after step 4 of 8 ends where the whole
    run does, to the bit: which copies a support holds is found from the
    points at each step's start (uGIMP: the block's domains reach the
    slab's cells from the first landing; B-splines: from the start)."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21),
                                np.linspace(-.1, 1., 12))
    pts = bodies(mesh, [[(0., 2.), (-.1, 0.)], [(.6, 1.), (0., .2)]])
    v = np.zeros((2, pts.n))
    v[0, pts.body == 1] = 1.
    pts.velocity = v
    args = (mesh, ElementQuad1(), pts,
            [LinearElastic(5e6, .3), LinearElastic(1e6, .25)], base)
    kwargs = dict(body_force=[0., -GAMMA], kinematics="finite",
                  method=method, contacts=[Contact(0, 1)],
                  dynamics=Dynamics(time_step=.01, duration=.08,
                                    density=1000.))
    full, resumed = full_and_resumed(args, kwargs, 4)
    assert np.array_equal(full.points.x, resumed.points.x)
    assert np.array_equal(full.points.velocity, resumed.points.velocity)
    assert np.array_equal(full.history[-1].contact_forces,
                          resumed.history[-1].contact_forces)


def test_the_supports_sieve_keeps_every_point_within_reach():
    """``near_sites`` sieves the points before the supports' bounded
    search (:meth:`BodyContact.support_distances`): every point within
    the reach of a site along every axis passes, round-off and the
    raster's edges too, so the held supports are the search's alone.
    Sites on a grid's boundary lines and points around them, at reaches
    from a hundredth of a cell to ten cells; points exactly at the reach
    (in 2D and 3D)."""
    from scipy.spatial import cKDTree

    from skfem_mpm.solve.body_contact import near_sites
    rng = np.random.default_rng(7)
    for dim in (2, 3):
        h = .1
        sites = np.array(np.meshgrid(*[np.arange(0., 1. + h / 2, h)] * dim)
                         ).reshape(dim, -1)
        sites = sites[:, (sites == 0.).any(axis=0)]      # boundary nodes
        for reach in (1e-3, .0125, .3, 1.):
            x = rng.uniform(-2 * reach, 1. + 2 * reach, (dim, 20000))
            at = sites[:, rng.integers(0, sites.shape[1], 2000)]
            x = np.hstack([x, at + rng.uniform(-reach, reach, at.shape),
                           # at the reach, to round-off
                           at + rng.choice([-reach, reach], at.shape)])
            # what the search finds: the sites within reach, inclusive
            within = cKDTree(sites.T).query_ball_point(
                x.T, reach, p=np.inf, return_length=True) > 0
            sieved = near_sites(x, sites, reach)
            assert within.sum() > 2000
            assert sieved[within].all()
            if reach < .1:          # bins narrower than the grid: a sieve
                assert sieved.sum() < .8 * x.shape[1]
