"""The patch test of a block pushed by its top grid nodes (trial 116):
GIMP's domains end at the material's face, which leaves the pushed grid
line after the first step; a method limit, warned, and a platen is
uniform."""
import logging

import numpy as np
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (LinearElastic, Obstacle, Prescribed, seed_points,
                       simulate)
from skfem_mpm.methods.gimp_linear import LinearGimp
from skfem_mpm.solve.motion import FACE_LEFT_DOMAINS

H = .25
PUSH = .02                  # at full load: 0.08 cells
WORDS = "whose points' domains end at the face"


def grid():
    return MeshQuad.init_tensor(np.linspace(0, 1.5, 7),
                                np.linspace(0, 1.5, 7))


def rollers(b):
    return np.concatenate([
        b.get_dofs(lambda x: np.isclose(x[0], 0.)).all("u^1"),
        b.get_dofs(lambda x: np.isclose(x[1], 0.)).all("u^2")])


def top(b, f0, f1):
    dofs = b.get_dofs(lambda x: np.isclose(x[1], 1.)).all("u^2")
    return dofs, np.full(dofs.size, -PUSH * (f1 - f0))


def run(caplog, method, nsteps, platen=False):
    mesh = grid()
    points = seed_points(mesh, 2, [(0., 1.), (0., 1.)])
    loads = [] if platen else [Prescribed(top)]
    obstacles = [Obstacle(box=[[-.5, 2.], [1., 1.5]],
                          displacement=[0., -PUSH])] if platen else []
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
        res = simulate(mesh, ElementQuad1(), points, LinearElastic(1e3, .3),
                       rollers, loads=loads, obstacles=obstacles,
                       nsteps=nsteps, method=method, kinematics="finite")
    words = [r.getMessage() for r in caplog.records
             if "the material's face leaves it" in r.getMessage()]
    syy = res.points.stress[1, 1]
    return np.ptp(syy) / abs(syy.mean()), words


def test_a_uniform_stress_below_a_pushed_line_is_out_of_balance():
    """The cause: a block whose top lies ``delta`` below the grid line
    y = 1, tiled by cpGIMP's domains, under a uniform ``sigma_yy``: the
    free nodes a cell below the line take ``sigma_yy * delta`` (the hat's
    value at the face, ``delta / h``, times a hat's integral across,
    ``h``), which no load balances; on the line the face's ``sigma_yy *
    h`` loses as much.  On the line (``delta = 0``) nothing is left."""
    mesh = grid()
    points = seed_points(mesh, 2, [(0., 1.), (0., 1.)])
    operator = LinearGimp(mesh, ElementQuad1())
    sigma = -20.
    below = np.flatnonzero(np.isclose(mesh.p[0], .5)
                           & np.isclose(mesh.p[1], 1. - H))[0]
    on = np.flatnonzero(np.isclose(mesh.p[0], .5)
                        & np.isclose(mesh.p[1], 1.))[0]
    for delta in (0., .005, .02):
        x = points.x0.copy()
        x[1] *= 1. - delta
        domain = np.vstack([np.full(points.n, H / 4),
                            np.full(points.n, H / 4 * (1. - delta))])
        volumes = 4. * domain.prod(axis=0)
        force = operator(x, domain).G[1].T @ (sigma * volumes)
        assert np.isclose(force[below], sigma * delta, rtol=1e-12,
                          atol=1e-14)
        assert np.isclose(force[on], sigma * (H - delta), rtol=1e-12)


def test_gimp_pushed_by_grid_nodes_is_warned_and_a_platen_is_uniform(
        caplog):
    """cpGIMP, finite strain, the top nodes pushed 0.08 cells in 4 steps:
    ``sigma_yy`` scatters by more than the face's gap at the last step's
    start in cells (0.06; measured 1.2 to 2.2 times it), warned once,
    naming the gap; in one step (the face on the line) and with standard
    MPM it is uniform and unsaid, and a rigid platen pushing the face
    (the warning's cure) is uniform with cpGIMP over the same 4 steps."""
    gap = PUSH * (1. - 1. / 4) / H
    assert gap > FACE_LEFT_DOMAINS
    spread, words = run(caplog, "cpgimp", 4)
    assert spread > gap and len(words) == 1
    assert "({:.2g} cells, {:.2g} cells more than the first step)".format(
        PUSH / H, gap) in words[0] and WORDS in words[0]
    assert "push with a rigid Obstacle" in words[0]
    spread, words = run(caplog, "cpgimp", 1)
    assert spread < 1e-12 and words == []
    spread, words = run(caplog, "mpm", 4)
    assert spread < 1e-12 and words == []
    spread, words = run(caplog, "cpgimp", 4, platen=True)
    assert spread < 1e-9 and words == []
