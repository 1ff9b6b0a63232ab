"""What a user trial (103) found: a disc body over a floor box refused
after the set-up in the old words, a 3D deformed shape's exaggeration
off the README's rule, and the points-per-cell warnings' words."""
import numpy as np
import pytest

from skfem_mpm.errors import SceneError

DISC = """\
name = "disc"
[grid]
x = [0.0, 4.0, 16]
y = [-1.0, 3.0, 16]
[[bodies]]
name = "disc"
region = {{ centre = [2.0, 0.5], radius = 0.5 }}
material = {{ model = "linear_elastic", E = 1e6, nu = 0.3 }}
[gravity]
body_force = [0.0, -800.0]
[[obstacles]]
name = "floor"
box = {{ x = [-1.0, 5.0], y = [-1.0, {top!r}] }}
{extra}
"""


def test_a_disc_over_a_floor_is_refused_before_work(tmp_path):
    """A disc reaching 0.25 into a floor box was refused after the
    set-up ("the domain corner of point 10 ... is 0.25 inside", no file,
    no table, no unit): the scene file refuses it, naming them."""
    from skfem_mpm.scenes.scene_file import load_scene
    path = tmp_path / "disc.toml"
    path.write_text(DISC.format(top=0.25, extra=""))
    with pytest.raises(SceneError) as err:
        load_scene(path)
    text = str(err.value)
    assert "disc.toml: 1 problem(s):\nobstacles[0].box: obstacle 'floor' " \
        "overlaps body 'disc' at the start: its disc reaches about" in text
    assert " m into it" in text
    # a tied floor may hold material inside it, as the run allows
    path.write_text(DISC.format(top=0.25, extra='friction = "tied"'))
    assert load_scene(path).obstacles[0].friction == "tied"


def test_the_scene_file_refuses_no_disc_the_run_takes(tmp_path):
    """Over floors rising through the disc's bottom, whatever the scene
    file refuses has a seeded point's domain corner deeper inside the
    floor than its tolerance (the run's refusal; a shallow overlap is
    left to it); the deep ones are refused."""
    from skfem_mpm.scenes.scene_file import load_scene
    from skfem_mpm.scenes.scene import build_points
    path = tmp_path / "disc.toml"
    refused = []
    for top in np.linspace(0., 0.5, 21):
        path.write_text(DISC.format(top=float(top), extra=""))
        try:
            load_scene(path)
        except SceneError:
            refused.append(top)
    # the deep ones, not the shallow ones (left to the run)
    assert 0.1 < min(refused) <= 0.25
    for top in refused:
        path.write_text(DISC.format(top=float(top), extra='friction = '
                                    '"tied"'))
        scene = load_scene(path)
        points = build_points(scene, scene.grid.build()[0])
        corners = points.x[1] - points.domain[1]
        tol = scene.obstacles[0].tolerance * 0.25
        assert (corners < top - tol).any(), top


CUBE = """\
name = "cube"
[grid]
{grid}
[[bodies]]
name = "soil"
region = {{ {region} }}
material = {{ model = "linear_elastic", E = 1e5, nu = 0.3 }}
[[supports]]
boundary = "{bottom}"
"""


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("share", [.0094, .0047])
def test_a_deformed_shape_follows_the_readme_rule(tmp_path, monkeypatch,
                                                  dim, share):
    """A 1 m cube (square) on 4 cells, 2 points per cell: its side was
    measured between its points' centres (0.875 m), so a largest
    displacement of 0.94% of its side was drawn at true scale, 0.47% x 5
    (4.7% drawn at x 10).  The README: under 1% of the body's longer
    side, exaggerated by the largest 1, 2 or 5 x 10^k drawing it at most
    5% of it."""
    from pathlib import Path
    from skfem_mpm.cli import plot_deformed_shape
    from skfem_mpm.scenes import plot
    from skfem_mpm.scenes.scene import build_points
    from skfem_mpm.scenes.scene_file import load_scene
    axes = "xyz"[:dim]
    path = tmp_path / "cube.toml"
    path.write_text(CUBE.format(
        grid="\n".join("{} = [0.0, 1.0, 4]".format(a) for a in axes),
        region=", ".join("{} = [0.0, 1.0]".format(a) for a in axes),
        bottom=axes[-1] + "-"))
    scene = load_scene(path)
    mesh, _ = scene.grid.build()
    pts = build_points(scene, mesh)
    side = float(np.max(pts.x0 + pts.domain) - np.min(pts.x0 - pts.domain))
    pts.displacement[dim - 1] = -share * side * pts.x0[dim - 1] / np.max(
        pts.x0[dim - 1])
    largest = np.abs(pts.displacement).max()
    assert largest < .01 * side
    wanted = .05 * side / largest
    power = 10. ** np.floor(np.log10(wanted))
    factor = max(m * power for m in (1, 2, 5, 10) if m * power <= wanted)
    kept = {}
    monkeypatch.setattr(plot, "save_figure",
                        lambda fig, path, **kw: kept.update(fig=fig))
    for half in (pts.domain.copy(), None):   # without: from the volumes
        plot_deformed_shape(scene, pts, "", half, Path("no.png"), 1.)
        title = kept["fig"].axes[0].get_title()
        assert "(displacements x {:g}, the".format(factor) in title, title


def test_the_basis_warning_says_what_seed_points_takes():
    """The basis warning said "seed at least 2 points per cell" (Q1) and
    "3" (P2) where ``seed_points(mesh, n)`` takes n per cell and axis:
    it says the count in a cell and the n that seeds it, and that n's
    points are enough."""
    from skfem import (ElementHex1, ElementQuad1, ElementTriP2, MeshHex,
                       MeshQuad, MeshTri)
    from skfem_mpm import seed_points
    from skfem_mpm.quadrature.basis import thin_cells
    for elem, mesh in ((ElementQuad1(), MeshQuad()),
                       (ElementTriP2(), MeshTri()),
                       (ElementHex1(), MeshHex())):
        message = thin_cells(elem, 1)
        dim = mesh.dim()
        least = -(-(elem.doflocs.shape[0] - 1) // dim)
        n = int(message.split("seed_points(mesh, ")[1].split(")")[0])
        assert n ** dim >= least and (n - 1) ** dim < least
        assert "seed at least {} points in every cell (seed_points(mesh, " \
            "{}) seeds {} a cell".format(least, n, n ** dim) in message
        most = seed_points(mesh, n).n // mesh.nelements
        assert most == n ** dim and thin_cells(elem, most) == ""


def test_fem_with_one_point_a_linear_cell_is_warned():
    """``method="fem"`` on Q1 cells with 1 point each has the hourglass
    modes "mpm" is warned of (a point's 3 strain states of a cell's 8
    DOFs less 3): warned too, naming seed_gauss_points; the Gauss points
    of rules exact for the element (order 2 for Q1, 4 for Q2) are not."""
    from skfem import ElementQuad1, ElementQuad2, MeshQuad
    from skfem_mpm import seed_gauss_points, seed_points
    from skfem_mpm.solve.core import underintegrated_cells
    axis = np.linspace(0., 1., 3)
    mesh = MeshQuad.init_tensor(axis, axis)
    one = seed_points(mesh, 1)
    mpm = underintegrated_cells("mpm", mesh, ElementQuad1(), one)
    fem = underintegrated_cells("fem", mesh, ElementQuad1(), one)
    assert mpm and fem.startswith(mpm)
    assert fem.endswith("seed 2 points per cell and axis (seed_points("
                        "mesh, 2), or seed_gauss_points(mesh, 2): 2 Gauss "
                        "points a cell and axis)")
    assert underintegrated_cells("fem", mesh, ElementQuad1(),
                                 seed_gauss_points(mesh, 2)) == ""
    assert underintegrated_cells("fem", mesh, ElementQuad2(),
                                 seed_gauss_points(mesh, 4)) == ""
    assert "seed_gauss_points(mesh, 4)" in underintegrated_cells(
        "fem", mesh, ElementQuad2(), seed_gauss_points(mesh, 2))
