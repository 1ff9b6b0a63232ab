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
