import numpy as np
import pytest
from skfem import MeshHex, MeshLine, MeshQuad, MeshTet, MeshTri

from skfem_mpm import (InvalidInputError, PointsOutsideGridError,
                       UnsupportedElementError, point_locator)
from skfem_mpm.quadrature.locate import cell_coordinates
from skfem_mpm.quadrature.mapping import fresh_mapping

from meshes import distorted_quads

TENSOR_GRIDS = {
    "line": MeshLine(np.array([0., .3, .5, 1.2, 2.])),
    "quad-uniform": MeshQuad.init_tensor(np.linspace(0, 3, 31),
                                         np.linspace(-1, 1, 21)),
    "quad-graded": MeshQuad.init_tensor(np.array([0., .1, .3, .7, 1.5]),
                                        np.array([0., .5, .6, 2.])),
    "hex": MeshHex.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2, 4),
                               np.array([0., .2, 1.])),
}


def maps_back(mesh, tind, X, x):
    """Global coordinates of (tind, X) equal x."""
    y = fresh_mapping(mesh).F(X[:, :, None], tind=tind)[:, :, 0]
    return np.abs(y - x).max()


def random_points(mesh, n, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = mesh.p.min(axis=1), mesh.p.max(axis=1)
    return lo[:, None] + (hi - lo)[:, None] * rng.random((mesh.dim(), n))


@pytest.mark.parametrize("name", list(TENSOR_GRIDS))
def test_tensor_and_general_paths_agree(name):
    mesh = TENSOR_GRIDS[name]
    x = random_points(mesh, 20000)
    # points exactly on every node and on the outer boundary, plus
    # perturbations of 1e-14 around them
    nodes = mesh.p
    x = np.hstack((x, nodes, nodes + 1e-14, nodes - 1e-14))
    lo, hi = mesh.p.min(axis=1)[:, None], mesh.p.max(axis=1)[:, None]
    x = np.clip(x, lo, hi)
    t1, X1 = point_locator(mesh, method="tensor")(x)
    t2, X2 = point_locator(mesh, method="general")(x)
    np.testing.assert_array_equal(t1, t2)
    assert np.abs(X1 - X2).max() < 1e-12
    assert maps_back(mesh, t1, X1, x) < 1e-12
    # the tensor path's local coordinates, a row of the inverse maps at a
    # time, are those of all of them at once to the bit
    from skfem_mpm.quadrature.locate import _element_affine_maps
    origin, Ainv = _element_affine_maps(mesh)
    np.testing.assert_array_equal(X1, np.einsum(
        "ijn,jn->in", Ainv[:, :, t1], x - origin[:, t1]))


def test_points_on_grid_lines_go_to_the_upper_cell():
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 3), np.linspace(0, 2, 3))
    locate = point_locator(mesh)
    x = np.array([[1., 1., 2., 0., 1.],
                  [1., .5, 2., 0., 2.]])
    tind, X = locate(x)
    centroids = mesh.p[:, mesh.t].mean(axis=1)[:, tind]
    np.testing.assert_allclose(centroids, [[1.5, 1.5, 1.5, .5, 1.5],
                                           [1.5, .5, 1.5, .5, 1.5]])
    # a perturbation of 1e-14 does not change the assignment
    for shift in (1e-14, -1e-14):
        t2, X2 = locate(np.clip(x + shift, 0, 2))
        np.testing.assert_array_equal(t2, tind)
        assert np.abs(X2 - X).max() < 1e-13


@pytest.mark.parametrize("mesh", [MeshTri().refined(3), MeshTet().refined(2),
                                  distorted_quads(),
                                  MeshHex().refined(1).with_defaults()])
def test_general_path_on_unstructured_and_distorted_meshes(mesh):
    if isinstance(mesh, MeshHex):   # make it non-affine
        p = mesh.p.copy()
        inner = (p > 0).all(axis=0) & (p < 1).all(axis=0)
        p[:, inner] += .1
        mesh = MeshHex(p, mesh.t)
    x = random_points(mesh, 5000, seed=1)
    locate = point_locator(mesh)
    tind, X = locate(x)
    assert maps_back(mesh, tind, X, x) < 1e-10
    # every local coordinate inside the reference element
    assert X.min() > -1e-10 and X.max() < 1 + 1e-10


def test_million_points_on_a_tensor_grid():
    mesh = MeshQuad.init_tensor(np.linspace(0, 10, 201), np.linspace(0, 5, 101))
    x = random_points(mesh, 1_000_000, seed=2)
    tind, X = point_locator(mesh)(x)
    # cell index from the coordinates directly
    ix = np.minimum((x[0] / .05).astype(int), 199)
    iy = np.minimum((x[1] / .05).astype(int), 99)
    centroids = mesh.p[:, mesh.t].mean(axis=1)
    assert np.abs(centroids[0, tind] - (ix + .5) * .05).max() < 1e-12
    assert np.abs(centroids[1, tind] - (iy + .5) * .05).max() < 1e-12
    assert X.min() >= -1e-12 and X.max() <= 1 + 1e-12


def test_outside_points_are_named():
    mesh = MeshQuad().refined(1)
    x = np.array([[.5, 1.5, .2, -.1], [.5, .5, .2, .3]])
    for method in ("tensor", "general"):
        with pytest.raises(PointsOutsideGridError,
                           match=r"2 material point\(s\).*indices \[1, 3\]") \
                as err:
            point_locator(mesh, method=method)(x)
        np.testing.assert_array_equal(err.value.indices, [1, 3])
    tri = MeshTri()
    with pytest.raises(PointsOutsideGridError, match=r"indices \[0\]"):
        point_locator(tri)(np.array([[.9], [.9001]]) + np.array([[0], [.2]]))


def test_tensor_location_in_blocks_of_points(monkeypatch):
    """Points located a block at a time (3 here) get the elements and
    local coordinates of all at once, to the bit; outside ones in a later
    block are named by their index among all."""
    import skfem_mpm.quadrature.locate as module
    mesh = MeshHex.init_tensor(*[np.linspace(0., 1., 4)] * 3)
    x = random_points(mesh, 10, seed=3)
    whole = point_locator(mesh, method="tensor")(x)
    monkeypatch.setattr(module, "LOCATE_BLOCK", 3)
    blocks = point_locator(mesh, method="tensor")(x)
    for a, b in zip(whole, blocks):
        np.testing.assert_array_equal(a, b)
    x[:, [4, 8]] += 2.
    with pytest.raises(PointsOutsideGridError, match=r"indices \[4, 8\]"):
        point_locator(mesh, method="tensor")(x)


def test_bad_locator_input():
    mesh = MeshQuad()
    locate = point_locator(mesh)
    with pytest.raises(InvalidInputError, match="non-finite"):
        locate(np.array([[.5, np.nan], [.5, .5]]))
    with pytest.raises(InvalidInputError, match=r"shape \(2, n\)"):
        locate(np.zeros((3, 4)))
    with pytest.raises(UnsupportedElementError, match="not an axis-aligned"):
        point_locator(MeshTri(), method="tensor")
    with pytest.raises(InvalidInputError, match="method"):
        point_locator(mesh, method="fast")


@pytest.mark.parametrize("origin, h", [(5e5, 1.), (1e3, 1e-3)])
def test_general_path_on_small_cells_far_from_the_origin(origin, h):
    """A distorted quad grid of cells small against their coordinates (a
    site in projected coordinates, x = 5e5 m, 1 m cells): every point
    inside a cell, on a node or on a face is found and maps back to the
    round-off of its coordinates, also beyond its cell.  Newton's inverse
    map, in global coordinates and stopped at a fixed local step of 1e-14
    (below what round-off in x moves the local coordinates by at 5e5 m:
    2e-10), took 21 of 100 points inside cells as outside the grid; with
    the step's floor at that round-off, 39 of the 341 on nodes and faces
    (their local coordinates 1e-10 outside every element).  Beyond a cell
    the stall gave the corners of a contact's domains NaN shape values: a
    pile on a grid of h = 0.025 failed with a residual of NaN."""
    mesh = MeshQuad.init_tensor(origin + h * np.arange(11.),
                                h * np.arange(11.))
    p = mesh.p.copy()
    inner = (p[0] > origin) & (p[0] < origin + 10 * h) & (p[1] > 0) \
        & (p[1] < 10 * h)
    p[:, inner] += .1 * h * np.random.default_rng(0).uniform(
        -1, 1, (2, inner.sum()))
    mesh = MeshQuad(p, mesh.t)
    x = np.hstack([mesh.p[:, mesh.t].mean(axis=1) + .2 * h, mesh.p,
                   mesh.p[:, mesh.facets].mean(axis=1)])
    tind, X = point_locator(mesh)(x)      # inside, on nodes and faces
    assert (tind >= 0).all()
    assert maps_back(mesh, tind, X, x) < 1e-13 * (origin + 10 * h)
    beyond = x + .6 * h          # extrapolated: a domain's corner
    X = cell_coordinates(mesh, clip=False)(beyond, tind)
    assert maps_back(mesh, tind, X, beyond) < 1e-13 * (origin + 10 * h)


def test_the_kernels_option_is_checked_and_reaches_the_locator():
    """``point_locator(kernels=)`` takes the run's option (checked), and
    ``locate.using(kernels)`` is the same locator with another one: on
    the numpy path the same numbers (the compiled pass's are those to
    the bit, ``tests/test_compiled.py``)."""
    from skfem_mpm.quadrature.locate import using_kernels
    mesh = TENSOR_GRIDS["quad-uniform"]
    with pytest.raises(InvalidInputError, match="kernels must be one of"):
        point_locator(mesh, kernels="fast")
    locate = point_locator(mesh)
    with pytest.raises(InvalidInputError, match="kernels must be one of"):
        locate.using("fast")
    x = random_points(mesh, 300)
    numpy_path = locate.using("numpy")
    assert numpy_path.mesh is mesh
    assert using_kernels(locate, "auto") is locate
    for got, want in zip(using_kernels(locate, "numpy")(x), locate(x)):
        assert np.array_equal(got, want)
    assert all(np.array_equal(a, b) for a, b in zip(numpy_path(x),
                                                     locate(x)))


@pytest.mark.parametrize("reach", [1., 4., 8.])
def test_extrapolated_local_coordinates_on_a_distorted_grid(reach):
    """``cell_coordinates(clip=False)`` on a grid that is not affine: a
    position ``reach`` cells from its element's centre maps back onto
    itself by the element's shape functions (Newton's iterates were
    clamped to [-2, 3]: 4 cells out it gave -2.0 for -3.41, a face's
    force there kept its resultant and lost its moment)."""
    from skfem import ElementQuad1
    grid = MeshQuad.init_tensor(*(np.linspace(0., 1., 3),) * 2)
    p = grid.p.copy()
    p[0] += .15 * p[1] ** 2 * p[0]
    p[1] += .1 * p[0] ** 2
    grid = MeshQuad(p, grid.t)
    x = np.array([[.25 - reach * .5], [.25]])
    X = cell_coordinates(grid, clip=False)(x, np.array([0]))
    elem = ElementQuad1()
    back = sum(grid.p[:, grid.t[i, 0]][:, None] * elem.lbasis(X, i)[0]
               for i in range(4))
    np.testing.assert_allclose(back, x, atol=1e-12)
