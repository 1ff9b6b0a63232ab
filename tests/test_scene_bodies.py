"""Bodies of a scene file whose regions overlap: refused, or one replaces
the other (a pile in the soil)."""
import numpy as np
import pytest

from skfem_mpm.errors import InvalidInputError
from skfem_mpm.scenes.scene import reaction_resultants, run_scene
from skfem_mpm.scenes.scene_file import parse_scene, tomllib

SCENE = """
name = "pile in soil"
[grid]
x = [0.0, 1.0, 4]
y = [0.0, 1.5, 6]
[[bodies]]
name = "soil"
region = { x = [0.0, 1.0], y = [0.0, 1.0] }
material = { model = "linear_elastic", E = 1e6, nu = 0.3 }
[[bodies]]
name = "pile"
region = { x = [0.25, 0.75], y = [0.5, 1.25] }
material = { model = "linear_elastic", E = 1e8, nu = 0.3 }
REPLACES
[[supports]]
name = "base"
boundary = "bottom"
[gravity]
body_force = [0.0, -10000.0]
[solver]
steps = 1
"""


def scene(replaces: str = ""):
    return parse_scene(tomllib.loads(SCENE.replace("REPLACES", replaces)))


def test_overlapping_bodies_are_refused():
    """A pile's region inside the soil's: each was seeded in full, the
    overlap's weight and stiffness counted twice without a word (a user
    trial: a base reaction of 13750 where the geometry weighs 11250)."""
    with pytest.raises(InvalidInputError, match="bodies 'soil' and 'pile' "
                       "overlap: 16 points of 'pile' lie in the region of "
                       "'soil' and 16 of 'soil' in that of 'pile'.*"
                       r"replaces = \['soil'\]"):
        run_scene(scene())


def test_a_body_replaces_another_where_their_regions_overlap():
    """With ``replaces = ["soil"]`` the pile's region is cut out of the
    soil's: each place holds one body's points, and the base carries the
    weight of the geometry as written, 10000 (1.0 + 0.5 x 0.25)."""
    pile = scene('replaces = ["soil"]')
    res = run_scene(pile)
    assert np.bincount(res.points.body).tolist() == [48, 24]
    names, resultant = reaction_resultants(pile)
    base = resultant(res.history[-1])[names.index("base")]
    weight = 1e4 * (1. * 1. + .5 * .25)
    assert base[1] == pytest.approx(weight, rel=1e-12)


@pytest.mark.parametrize("replaces, match", [
    ('replaces = ["rock"]', "replaces must list other bodies' names"),
    ('replaces = ["pile"]', "replaces must list other bodies' names"),
    ('replaces = "soil"', "must be a list of body names")])
def test_replaces_names_other_bodies(replaces, match):
    with pytest.raises(InvalidInputError, match=match):
        run_scene(scene(replaces))
