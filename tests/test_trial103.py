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
