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
