"""The start-of-run checks of the points (a review of session 83):
points outside a grid that is not a tensor grid, the volumes' check on
graded and skewed cells, the point locator built once and the points
located once, and duplicates among three points at one position."""
import logging

import numpy as np
import pytest
from skfem import (ElementHex1, ElementQuad1, ElementTriP1, MeshHex,
                   MeshQuad, MeshTri)

from skfem_mpm import (Contact, LinearElastic, MaterialPoints, Options,
                       point_locator, seed_points, simulate)
from skfem_mpm.errors import InvalidInputError, PointsOutsideGridError
from skfem_mpm.solve import core


def base(b):
    return b.get_dofs(lambda x: x[1] == 0.)


def run(mesh, elem, points, material=LinearElastic(1e9, .3), **kw):
    return simulate(mesh, elem, points, material, base,
                    body_force=[0., -10.] + [0.] * (mesh.dim() - 2),
                    nsteps=1, **kw)


def graded():
    """An axis fine near a footing, coarse far off (cells of 0.05 to
    about 8)."""
    return np.concatenate([np.linspace(0., 1., 21),
                           np.geomspace(1., 30., 15)[1:]])


def test_points_outside_a_general_grid_are_named_by_the_first_step():
    """On triangles the volumes' check put the points in boxes and
    raised numpy's "invalid entry in coordinates array" for a point
    below the grid's corner, before the first step's error."""
    mesh = MeshTri.init_tensor(np.linspace(0., 1., 5),
                               np.linspace(0., 1., 5))
    pts = seed_points(mesh, 1)
    pts.x[:, 0] = pts.x0[:, 0] = [-.1, .5]
    with pytest.raises(PointsOutsideGridError, match="as given to the run"):
        run(mesh, ElementTriP1(), pts)


@pytest.mark.parametrize("kind, per_axis", [
    ("tri", 1), ("tri", 2), ("tri", 3), ("skewed quad", 1),
    ("skewed quad", 2), ("skewed hex", 2)])
def test_seeded_points_fill_their_cells_on_any_grid(caplog, kind, per_axis):
    """Seeded points hold their cells' volumes (seed_points shares each
    cell's among its points): on a graded grid of triangles the check's
    boxes of twice the mean cell size gave 2.54, 1.27, 1.05 (1, 2, 3
    points a cell and axis), on skewed quadrilaterals 2.73 and 1.36, and
    a run warned "volumes too large"; they sum to their cells' volume,
    and doubled volumes to twice it."""
    x = graded()
    if kind == "tri":
        mesh, elem = MeshTri.init_tensor(x, x), ElementTriP1()
    elif kind == "skewed quad":
        mesh, elem = MeshQuad.init_tensor(x, x), ElementQuad1()
        mesh.p[0] += .05 * mesh.p[1]
    else:
        y = np.linspace(0., 1., 4)
        mesh, elem = MeshHex.init_tensor(y, y, y ** 1.5), ElementHex1()
        mesh.p[2] += .1 * mesh.p[0] * mesh.p[1]     # not even planar faces
    pts = seed_points(mesh, per_axis)
    for scale in (1., 2.):
        caplog.clear()
        points = MaterialPoints(x=pts.x, volume=scale * pts.volume)
        with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
            run(mesh, elem, points)
        found = [r.getMessage() for r in caplog.records
                 if "cells they occupy" in r.getMessage()]
        if scale == 1.:
            assert not found
        else:
            assert len(found) == 1
            assert "sum to {:.3g} of the volume of the {} cells".format(
                scale, mesh.nelements) in found[0]


@pytest.mark.parametrize("kind", ["tri", "quad", "quad given",
                                  "quad contact"])
def test_the_locator_is_built_once_and_the_points_located_once(
        monkeypatch, kind):
    """check_case built a point locator where the run was given none,
    unused on triangles (1.1 s on 5e5 of them), and build_run built its
    own; on a tensor grid the volumes' check located the points and the
    first step again.  One locator (none where one is given), one
    location of the points where they start (on the fields of bodies in
    contact too)."""
    n = np.linspace(0., 1., 5)
    mesh = MeshTri.init_tensor(n, n) if kind == "tri" \
        else MeshQuad.init_tensor(n, n)
    elem = ElementTriP1() if kind == "tri" else ElementQuad1()
    pts = seed_points(mesh, 2)
    kw = {}
    if kind == "quad contact":
        pts.body = (pts.x[1] > .5).astype(int)
        kw = {"material": [LinearElastic(1e9, .3)] * 2,
              "contacts": [Contact(0, 1, friction="rough")]}
    built, located = [], []
    build = point_locator

    def counting(mesh, *args, **kwargs):
        built.append(mesh)
        inner = build(mesh, *args, **kwargs)

        def locate(x):
            located.append(np.array_equal(x, pts.x))
            return inner(x)
        locate.mesh, locate.using = mesh, inner.using
        return locate

    monkeypatch.setattr(core, "point_locator", counting)
    given = counting(mesh) if kind == "quad given" else None
    built.clear()
    result = run(mesh, elem, pts, options=Options(locator=given), **kw)
    assert len(built) == (0 if given else 1)
    assert located.count(True) == 1
    assert result.counters["locate"] == 2       # the start, and the end


def test_a_fields_points_at_one_position_are_refused_among_others():
    """Three points at one position, of fields 0, 1, 0 (bodies in
    contact): compared with their sorted neighbours only, each pair
    beside another field's point, they passed though two of them are one
    field's (two glued bodies overlapping)."""
    pts = MaterialPoints(x=np.full((2, 3), .5), volume=np.ones(3),
                         body=np.array([0, 1, 2]))
    field = np.array([0, 1, 0])
    with pytest.raises(InvalidInputError, match=r"1 point\(s\) repeat .* "
                       r"points 0 and 2 at \[0.5, 0.5\] \(bodies 0 and 2 "
                       r"overlap\)"):
        core.refuse_duplicate_points(pts, field)
    core.refuse_duplicate_points(pts, np.array([0, 1, 2]))   # in contact
    mesh = MeshQuad.init_tensor(np.linspace(0., 2., 5),
                                np.linspace(0., 2., 5))
    seeded = seed_points(mesh, 1)           # at 0.25, 0.75, ...: not 0.5
    x = np.hstack([seeded.x, pts.x])
    body = np.r_[np.zeros(seeded.n, int), 0, 1, 0]
    with pytest.raises(InvalidInputError, match=r"points {} and {} at "
                       r"\[0.5, 0.5\]".format(seeded.n, seeded.n + 2)):
        simulate(mesh, ElementQuad1(),
                 MaterialPoints(x=x, volume=np.r_[seeded.volume, 1., 1., 1.],
                                body=body),
                 [LinearElastic(1e4, .3)] * 2, base, nsteps=1,
                 contacts=[Contact(0, 1)])
