import numpy as np
import pytest
from skfem import MeshHex, MeshQuad, MeshTri

from skfem_mpm import (InvalidInputError, MaterialPoints, UnsupportedElementError,
                       seed_gauss_points, seed_points)
from skfem.mesh import MeshTet


def test_subcell_seeding_fills_elements_with_equal_volumes():
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 3), np.linspace(0, 1, 3))
    mp = seed_points(mesh, 3)
    assert mp.n == 4 * 9
    np.testing.assert_allclose(mp.volume, 0.5 / 9, rtol=1e-14)
    assert abs(mp.volume.sum() - 2.) < 1e-13
    # sub-cell centres of the first cell [0, 1] x [0, 0.5]
    xs = np.sort(np.unique(np.round(mp.x[0][mp.x[0] < 1], 12)))
    np.testing.assert_allclose(xs, [1 / 6, 1 / 2, 5 / 6])


@pytest.mark.parametrize("mesh", [MeshTri().refined(1), MeshHex().refined(1)])
def test_seeding_volume_equals_mesh_volume(mesh):
    for mp in (seed_points(mesh, 2), seed_gauss_points(mesh, 2)):
        assert abs(mp.volume.sum() - 1.) < 1e-13
    tri = seed_points(MeshTri(), 3)
    assert tri.n == 2 * 9 and np.allclose(tri.volume, .5 / 9)


def test_region_restricts_points():
    mesh = MeshQuad().refined(2)
    mp = seed_points(mesh, 2, region=lambda x: x[1] < .5)
    assert mp.n == 32 and (mp.x[1] < .5).all()
    assert abs(mp.volume.sum() - .5) < 1e-14
    mp = seed_gauss_points(mesh, 2, elements=np.array([0, 1]))
    assert mp.n == 8
    with pytest.raises(InvalidInputError, match="no material point"):
        seed_points(mesh, 2, region=lambda x: x[0] > 5)


def test_tet_subcell_seeding_is_refused_with_a_pointer():
    with pytest.raises(UnsupportedElementError, match="seed_gauss_points"):
        seed_points(MeshTet(), 2)


@pytest.mark.parametrize("kwargs, match", [
    (dict(x=[[0., np.nan]], volume=[1., 1.]), "x holds 1 non-finite"),
    (dict(x=[[0., 1.]], volume=[1., np.inf]), "volume holds 1 non-finite"),
    (dict(x=[[0., 1.]], volume=[1., 0.]), "point 1 has volume 0"),
    (dict(x=[[0., 1.]], volume=[-1., 1.]), "volume must be positive"),
    (dict(x=[[0., 1.]], volume=[1.]), r"volume must have shape \(2,\)"),
    (dict(x=[0., 1.], volume=[1., 1.]), r"shape \(dim, n\)"),
    (dict(x=[[0., 1.]], volume=[1., 1.], force=[[1.]]), "force must have"),
])
def test_bad_point_input_is_named(kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        MaterialPoints(**kwargs)


def test_copy_is_deep():
    mp = seed_points(MeshQuad(), 2)
    cp = mp.copy()
    cp.x[0, 0] += 1.
    cp.stress[0, 0, 0] = 5.
    assert mp.x[0, 0] != cp.x[0, 0] and mp.stress[0, 0, 0] == 0.


def test_a_box_region_reaching_outside_the_grid_is_refused():
    """Issue 30: a box region larger than the grid was clipped without a
    word (the points beyond it silently dropped).  A box inside the grid
    seeds what the equivalent callable seeds; one reaching outside is
    refused naming the axis, the box and the grid's extent; a callable
    cannot be checked and keeps its meaning."""
    mesh = MeshQuad.init_tensor(np.linspace(0., 2., 5), np.linspace(0., 1., 3))
    inside = seed_points(mesh, 2, region=[(0., 1.), (0., 1.)])
    same = seed_points(mesh, 2, region=lambda x: (x[0] > 0.) & (x[0] < 1.)
                       & (x[1] > 0.) & (x[1] < 1.))
    assert inside.n == 16 and np.array_equal(inside.x, same.x)
    assert np.array_equal(inside.domain, same.domain)
    with pytest.raises(InvalidInputError, match=r"region y = \[0.0, 1.5\] "
                       r"reaches outside the grid's y extent \[0.0, 1.0\]"):
        seed_points(mesh, 2, region=[(0., 1.), (0., 1.5)])
    with pytest.raises(InvalidInputError, match=r"region x = \[-0.5, 1.0\]"):
        seed_points(mesh, 2, region=[(-.5, 1.), (0., 1.)])
    with pytest.raises(InvalidInputError, match="one \\[lo, hi\\] with lo < "
                       "hi per axis"):
        seed_points(mesh, 2, region=[(0., 1.)])
    # an unbounded axis (a scene file's axis left out) is the whole axis
    assert seed_points(mesh, 2, region=[(0., 1.), (-np.inf, np.inf)]).n == 16
    assert seed_points(mesh, 2, region=lambda x: x[1] < 5.).n == 32


def test_a_boundary_through_a_column_of_points_keeps_it_in_every_row(
        caplog):
    """A user trial's pile, ``.9 < x < 1.1`` on a grid of h = 2/15 with
    2 x 2 points per cell: the points at x = 0.9 came out of the mapping
    0.9 in some rows and 0.9 + 1 ulp in others, so the pile's side was a
    column of teeth in the soil's (their contact then failed).  Every row
    keeps the same columns now, and the 28 points on the boundary (a
    column of 14 on each side) are named; a region clear of the points
    says nothing.  3D alike."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 16), np.linspace(0, 1, 8))
    region = lambda x: (x[0] > .9) & (x[0] < 1.1)
    with caplog.at_level("WARNING", "skfem_mpm.quadrature.points"):
        mp = seed_points(mesh, 2, region=region)
    assert mp.n == np.unique(mp.x[0].round(9)).size * 7 * 2
    assert "28 point(s) lie on the region's boundary" in caplog.text
    assert "across x: " in caplog.text and "across y" not in caplog.text
    # every point kept satisfies the region at its own position (a
    # review: x > 0.7 on 5 cells kept the column at 0.7, and 5 of its
    # points, their x an ulp from where the region was asked, did not)
    assert region(mp.x).all()
    coarse = MeshQuad.init_tensor(np.linspace(0, 2, 6), np.linspace(0, 1, 8))
    right = seed_points(coarse, 2, region=lambda x: x[0] > .7)
    assert right.n % 14 == 0 and (right.x[0] > .7).all()
    hex_mesh = MeshHex.init_tensor(np.linspace(0, 2, 16), [0., .5, 1.],
                                   [0., .5, 1.])
    cube = seed_points(hex_mesh, 2, region=region)
    assert cube.n == np.unique(cube.x[0].round(9)).size * 4 * 4
    caplog.clear()
    with caplog.at_level("WARNING", "skfem_mpm.quadrature.points"):
        seed_points(mesh, 3, region=region)
    assert "boundary" not in caplog.text


@pytest.mark.parametrize("top, warned", [
    (2., False), (2.04, True), (2.03, True), (1.99, False)])
def test_a_region_whose_side_cuts_sub_cells_is_warned(top, warned, caplog):
    """A column meant ``top`` high on a grid of h = 0.125 with 2 x 2
    points per cell (sub-cells 0.0625): its points fill whole sub-cells,
    so it is seeded 2.0625 high under 2.04 (a user's column came out
    3.1% high without a word) and 2.0 under 2.03.  A region whose volume
    differs from the points' by more than 1% is warned, with the region's
    volume found to a sixteenth of a sub-cell; one whose side lies on the
    sub-cells' faces, or within 1%, is not."""
    import logging
    import re
    from skfem_mpm.quadrature.points import REGION_VOLUME_WARNING
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 9),
                                np.linspace(0, 3, 25))
    with caplog.at_level(logging.WARNING):
        mp = seed_points(mesh, 2, region=lambda x: x[1] < top)
    seeded = float(mp.volume.sum())
    assert seeded == np.ceil(top / .0625 - .5) * .0625
    said = [r.getMessage() for r in caplog.records
            if "the region about" in r.getMessage()]
    assert len(said) == int(warned)
    assert warned == (abs(top / seeded - 1) > REGION_VOLUME_WARNING)
    if warned:
        region = float(re.search(r"the region about ([\d.]+)",
                                 said[0]).group(1))
        assert region == pytest.approx(top, abs=.0625 / 16)


def test_a_disc_seeded_on_a_coarse_lattice_is_warned_with_its_volume(
        caplog):
    """A disc of radius 0.4 on 16 x 16 sub-cells across it loses 3.6% of
    its area to the staircase of sub-cells: warned, the disc's area
    (pi r^2) estimated to 0.5%; an inclined side averages out (1.35
    seeded as 1.3477: not warned)."""
    import logging
    import re
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 9),
                                np.linspace(0, 3, 25))
    with caplog.at_level(logging.WARNING):
        seed_points(mesh, 2, region=lambda x: (x[0] - .5) ** 2
                    + (x[1] - 1.5) ** 2 < .4 ** 2)
        seed_points(mesh, 2, region=lambda x: x[1] < 1 + .7 * x[0])
    said = [r.getMessage() for r in caplog.records
            if "the region about" in r.getMessage()]
    assert len(said) == 1
    region = float(re.search(r"the region about ([\d.]+)",
                             said[0]).group(1))
    assert region == pytest.approx(np.pi * .4 ** 2, rel=5e-3)
