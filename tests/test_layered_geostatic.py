"""Layered geostatic start: each layer carries the layers above it."""
import numpy as np
import pytest

from skfem_mpm import (InvalidInputError, LinearElastic, MaterialPoints,
                       seed_points)
from skfem_mpm.mechanics.geostatic import geostatic_stress

# trial 59's two layers: sand (density 1.8, K0 0.47) 0.8 thick over clay
# (density 2.0, K0 0.6) 1.2 thick, gravity 10
LAYERS = """
name = "layers"
[grid]
x = [0.0, 3.0, 23]
y = [0.0, 2.4, 18]
[[bodies]]
name = "sand"
region = { x = [0.0, 3.0], y = [1.2, 2.0] }
points_per_cell = 2
density = 1.8
material = { model = "mohr_coulomb", E = 2e4, nu = 0.3, cohesion = 2.0, \
friction_angle = 32.0, dilation_angle = 0.0 }
geostatic = { K0 = 0.47 }
[[bodies]]
name = "clay"
region = { x = [0.0, 3.0], y = [0.0, 1.2] }
points_per_cell = 2
density = 2.0
material = { model = "mohr_coulomb", E = 1e4, nu = 0.35, cohesion = 15.0, \
friction_angle = 20.0 }
geostatic = { K0 = 0.6 }
[[supports]]
name = "base"
boundary = "bottom"
[[supports]]
name = "left"
boundary = "left"
components = ["x"]
[[supports]]
name = "right"
boundary = "right"
components = ["x"]
[gravity]
acceleration = [0.0, -10.0]
[solver]
method = "mpm"
kinematics = "small"
steps = 1
"""


def overburden(y, top, interface, gamma_sand, gamma_clay):
    """Vertical stress of the two layers at the heights ``y``."""
    return np.where(y > interface, -gamma_sand * (top - y),
                    -(gamma_sand * (top - interface)
                      + gamma_clay * (interface - y)))


@pytest.mark.parametrize("method", ["mpm", "fem", "cpgimp"])
def test_scene_clay_carries_the_sand(method):
    """The clay's top points start at -(18 x 0.8 + 20 d) = -15.07 (they
    started at -0.67, their own layer's weight only), every point at its
    overburden and K0 of its layer (1e-10); one step from it with the
    weight in full: residual and displacements at round-off."""
    from skfem_mpm.scenes.scene import build_points, run_scene
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    scene = parse_scene(tomllib.loads(LAYERS.replace(
        'method = "mpm"', 'method = "{}"'.format(method))))
    mesh, _ = scene.grid.build()
    points = build_points(scene, mesh)
    top, interface = (points.x[1] + points.domain[1]).max(), 1.2
    y = points.x[1]
    expected = overburden(y, top, interface, 18., 20.)
    clay = points.body == 1
    upper = clay & (y == y[clay].max())
    assert abs(top - 2.) < 1e-12
    assert np.abs(points.stress[1, 1, upper] - (
        -(18. * .8 + 20. * (1.2 - y[upper])))).max() < 1e-10 * 15.
    assert np.abs(points.stress[1, 1] - expected).max() \
        < 1e-10 * np.abs(expected).max()
    for k, K0 in enumerate((.47, .6)):
        on = points.body == k
        assert np.abs(points.stress[0, 0, on]
                      - K0 * points.stress[1, 1, on]).max() < 1e-10 * 40
    res = run_scene(scene)
    first = res.history[0].newton_residuals or [res.history[0].residual]
    assert first[0] < 1e-12
    assert np.abs(res.points.displacement).max() < 1e-12


def test_python_layers_match_the_overburden():
    """``geostatic_stress`` with one body-force row and K0 per body: the
    same overburden (1e-10); a ``None`` surface entry continues the
    layers, a height starts that body alone; layers not horizontal (a
    sloping interface, a body over part of another, a gap) refused."""
    from skfem import MeshQuad
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 5), np.linspace(0, 3, 7))
    points = seed_points(mesh, 2)
    points.body[:] = points.x[1] > 1.       # clay 0 below 1, sand 1 above
    materials = [LinearElastic(1e4, .35), LinearElastic(2e4, .3)]
    rows = [[0., -20.], [0., -18.]]
    out = geostatic_stress(points, materials, rows, None, [.6, .47])
    expected = overburden(points.x[1], 3., 1., 18., 20.)
    assert np.abs(out.stress[1, 1] - expected).max() < 1e-10 * 56.
    # sand under 0.5 of sand-weight surcharge (surface 3.5): clay follows
    out = geostatic_stress(points, materials, rows, 3.5, [.6, .47])
    assert np.abs(out.stress[1, 1] - overburden(
        points.x[1], 3.5, 1., 18., 20.)).max() < 1e-10 * 56.
    alone = geostatic_stress(points, materials, rows, [1.4, None],
                             [.6, .47])
    clay = points.body == 0
    assert np.abs(alone.stress[1, 1, clay]
                  + 20. * (1.4 - points.x[1, clay])).max() < 1e-10 * 28.
    # a sloping interface or a layer over part of another: refused
    points.body[:] = points.x[1] > 1. + .2 * points.x[0]
    with pytest.raises(InvalidInputError, match="not horizontal"):
        geostatic_stress(points, materials, rows, None, [.6, .47])
    points = seed_points(mesh, 2, region=lambda x: (x[1] < 1.)
                         | (x[0] < 1.))
    points.body[:] = points.x[1] > 1.
    with pytest.raises(InvalidInputError, match="over part"):
        geostatic_stress(points, materials, rows, None, [.6, .47])
    points = seed_points(mesh, 2, region=lambda x: (x[1] < 1.)
                         | (x[1] > 1.5))
    points.body[:] = points.x[1] > 1.
    with pytest.raises(InvalidInputError, match="gap"):
        geostatic_stress(points, materials, rows, None, [.6, .47])


def test_scene_pile_in_layers_is_refused_unless_each_starts_alone():
    """A pile with K0 cut into the layers: the soil under it would carry
    its weight, which no layer sum gives: refused naming the bodies; with
    a surface each (every body alone, as before) it starts."""
    from skfem_mpm.scenes.scene import build_points
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    pile = """[[bodies]]
name = "pile"
region = { x = [1.2, 1.6], y = [0.4, 2.0] }
replaces = ["sand", "clay"]
density = 2.4
material = { model = "linear_elastic", E = 1e6, nu = 0.2 }
geostatic = { K0 = 0.5 }
[[supports]]"""
    text = LAYERS.replace("[[supports]]", pile, 1)
    scene = parse_scene(tomllib.loads(text))
    with pytest.raises(InvalidInputError, match="interleave.*'pile'"):
        build_points(scene, scene.grid.build()[0])
    for k, height in enumerate((2., 1.2, 2.)):
        scene.bodies[k].surface = height
    points = build_points(scene, scene.grid.build()[0])
    clay = points.body == 1
    assert np.abs(points.stress[1, 1, clay]
                  + 20. * (1.2 - points.x[1, clay])).max() < 1e-10 * 24.


@pytest.mark.parametrize("surface", [7., [7.], lambda x: 7. + 0. * x[0]])
def test_a_surface_above_the_material_is_warned(surface, caplog):
    """Trial 59 gave the region's top, 7.0, as the surface where the
    points' domains of an untuned grid end below it: the start carried
    soil that is not there and the first step moved the body, without a
    word.  Warned now, naming the gap; none where the surface is the
    material's top (given or left out)."""
    from skfem import MeshQuad
    mesh = MeshQuad.init_tensor(np.linspace(0., 6., 12),
                                np.linspace(0., 8., 16))
    points = seed_points(mesh, 3, region=lambda x: x[1] < 7.)
    top = (points.x[1] + points.domain[1]).max()
    gap = 7. - top
    assert gap > 1e-2                  # the grid is untuned: a real gap
    material = LinearElastic(1e4, .3)
    with caplog.at_level("WARNING"):
        geostatic_stress(points, material, [0., -18.], surface, .5)
    assert "surface lies up to {:.4g} above".format(gap) in caplog.text
    assert "({:.4g}) with no load".format(18. * gap) in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING"):
        for level in (None, top, [top]):
            geostatic_stress(points, material, [0., -18.], level, .5)
    assert caplog.text == ""


def test_gauss_points_reaching_the_surface_are_not_warned(caplog):
    """Gauss points have no domains, so their material's top is not
    known: a body of height 2 with the surface at 2 was warned that the
    surface lay 0.106 above its material (the top Gauss point's height;
    a user trial)."""
    from skfem import MeshQuad
    from skfem_mpm import seed_gauss_points
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 5), np.linspace(0, 2, 5))
    points = seed_gauss_points(mesh, 2)
    assert 2. - points.x[1].max() > .1
    with caplog.at_level("WARNING"):
        start = geostatic_stress(points, LinearElastic(1e4, .3), [0., -10.],
                                 2., 3 / 7)
    assert caplog.text == ""
    assert np.allclose(start.stress[1, 1], -10. * (2. - points.x[1]))


def own_points(points):
    """The points as one's own: positions, volumes and bodies only."""
    return MaterialPoints(points.x.copy(), points.volume.copy(),
                          body=points.body.copy())


def test_points_without_domains_take_squares_of_their_volumes():
    """Points of one's own (positions and volumes, no domains) copied
    from a layer seeded to 3.0: the surface left out was their highest
    centre, 0.125 low, and the hold step of a user trial started 0.11 out
    of balance.  Their tops now are squares' of their volumes, exact for
    equal sub-cells; two layers of them, refused before for the gap
    between their centres, carry each other."""
    from skfem import MeshQuad
    mesh = MeshQuad.init_tensor(np.linspace(0, 4, 9), np.linspace(0, 4, 9))
    seeded = seed_points(mesh, 2, region=lambda x: x[1] < 3.)
    material = LinearElastic(1e4, .3)
    start = geostatic_stress(own_points(seeded), material, [0., -18.],
                             None, .5)
    assert np.abs(start.stress[1, 1] + 18. * (3. - seeded.x[1])).max() \
        < 1e-12 * 18. * 3.
    seeded.body[:] = seeded.x[1] < 1.
    rows = [[0., -18.], [0., -20.]]
    start = geostatic_stress(own_points(seeded), [material, material],
                             rows, None, [.5, .5])
    assert np.abs(start.stress[1, 1] - overburden(
        seeded.x[1], 3., 1., 18., 20.)).max() < 1e-12 * 58.


def test_gauss_points_in_layers_are_told_to_take_a_surface():
    """Gauss points do not fill squares of their volumes: layers of them
    are refused with words on points without domains."""
    from skfem import MeshQuad
    from skfem_mpm import seed_gauss_points
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 5), np.linspace(0, 2, 5))
    points = seed_gauss_points(mesh, 2)
    points.body[:] = points.x[1] < 1.
    with pytest.raises(InvalidInputError, match="without domains"):
        geostatic_stress(points, LinearElastic(1e4, .3),
                         [[0., -18.], [0., -20.]], None, [.5, .5])


def test_body_ids_from_1_are_warned_as_simulate_warns(caplog):
    """Ids from 1 with one material per id (body 0 a dummy) passed
    without a word where simulate warns; a scene file's geostatic body
    under a body without K0 (ids leaving it out) is not warned."""
    from skfem import MeshQuad
    from skfem_mpm.scenes.scene import build_points
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 5), np.linspace(0, 2, 5))
    points = seed_points(mesh, 2, region=lambda x: x[1] < 1.5)
    points.body[:] = 1
    material = LinearElastic(1e4, .3)
    with caplog.at_level("WARNING"):
        geostatic_stress(points, [material, material],
                         [[0., -18.], [0., -18.]], None, [.5, .5])
    assert "body ids count from 0 to 1" in caplog.text
    caplog.clear()
    text = LAYERS.replace("geostatic = { K0 = 0.47 }\n", "", 1)
    scene = parse_scene(tomllib.loads(text))
    with caplog.at_level("WARNING"):
        points = build_points(scene, scene.grid.build()[0])
    assert "holds no point" not in caplog.text
    assert points.stress[..., points.body == 1].any()
