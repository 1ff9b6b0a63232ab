"""What a new user's trial (73) found in a scene's input and a run's
words: point loads off the grid or in the air applied to the nearest
points, a traction on a held side lost in the reaction without a word,
a collapse message claiming a bound the discretisation cannot give,
repeated warnings, and figures that misled."""
import logging

import numpy as np
import pytest

from skfem_mpm import LinearElastic, seed_points
from skfem_mpm.cli import main
from skfem_mpm.errors import InvalidInputError, NewtonDivergenceError
from skfem_mpm.scenes.scene import (Body, Grid, PointLoad, Scene, Support,
                                    Traction, build_points, run_scene)
from skfem_mpm.scenes.scene_file import load_scene
from test_cli_trial53 import PRESSED as PRESSED_RUN

# a 2 m x 1 m elastic block on a 4 m x 2 m grid of 0.5 m cells
GRID = Grid([(0., 4., 8), (0., 2., 4)])


def block(**kwargs):
    return Scene(grid=GRID,
                 bodies=[Body("block", [(0., 2.), (0., 1.)],
                              LinearElastic(1e4, .3))],
                 supports=[Support(name="base", boundary="bottom")],
                 **kwargs)


@pytest.mark.parametrize("at, words", [
    ([50., .5], "point_loads[1] at [50.0, 0.5] lies outside the grid "
                "(x from 0 to 4, y from 0 to 2)"),
    ([1., 1.8], "point_loads[1] at [1.0, 1.8] is 0.9334 from the nearest "
                "material point (point 15 at [0.875, 0.875]), more than "
                "a cell (0.5)")])
def test_a_point_load_off_the_grid_or_the_material_is_refused(at, words):
    """Both were applied to the nearest points (the trial's at [50, 6] on
    a 12 m grid changed the base reaction 1396.9 -> 1407.3; exit 0)."""
    scene = block(point_loads=[PointLoad(at=[2., 1.], force=[0., -1.]),
                               PointLoad(at=at, force=[0., -1.])])
    mesh, _ = scene.grid.build()
    with pytest.raises(InvalidInputError) as err:
        build_points(scene, mesh)
    assert words in str(err.value)
    # at the material's corner, on its surface or 0.3 above it (0.44
    # from the nearest point): taken
    for at in ([2., 1.], [1., 1.], [1., 1.3], [0., 0.]):
        scene.point_loads[1].at = at
        build_points(scene, mesh)


def test_a_traction_on_a_side_held_in_its_direction_is_told(caplog):
    """The trial's traction [10, 0] on the soil's left side, which rollers
    on the grid's left side hold in x, went into their reaction: the run
    changed by nothing and said nothing."""
    scene = block(nsteps=1)
    scene.supports.append(Support(name="sides", boundary="left",
                                  components=["x"]))
    scene.tractions = [Traction("block", "left", traction=[10., 0.]),
                       Traction("block", "left", traction=[0., 10.]),
                       Traction("block", "right", pressure=10.)]
    with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
        run_scene(scene)
    # the shear on the left side (its corner node held in y by the base)
    # and the pressure on the free right side: not told
    words = [r.getMessage() for r in caplog.records
             if "tractions[" in r.getMessage()]
    assert words == [
        "tractions[0] (traction on body 'block', side 'left'): 100% of its "
        "x force acts on grid nodes that supports 'sides', 'base' hold in "
        "x: it goes into their reaction and loads nothing (load a side the "
        "supports leave free in x, or hold that side otherwise)"]


# a von Mises block under its weight pressed by an obstacle, two Newton
# iterations a step: the first round of a step with contact (to the loose
# residual before the contact's update) fails, and the run cuts back
# until it stops
PRESSED = PRESSED_RUN.replace('method = "mpm"\nsteps = 4',
                              "steps = 4\nmax_iterations = 2")


def test_a_retry_says_which_tolerance_it_missed(tmp_path, caplog):
    """A trial's obstacle run logged "tolerance 0.001" where its scene's
    was 1e-9: the first round's (SETTLE_RESIDUAL), not said so."""
    from skfem_mpm.solve.core import SETTLE_RESIDUAL
    path = tmp_path / "pressed.toml"
    path.write_text(PRESSED)
    with caplog.at_level(logging.INFO, logger="skfem_mpm"), \
            pytest.raises(NewtonDivergenceError):
        run_scene(load_scene(path))
    retries = [r.getMessage() for r in caplog.records
               if "retrying" in r.getMessage()]
    assert retries and SETTLE_RESIDUAL == 1e-3
    assert "; tolerance 0.001 for the first round, before the contact's " \
        "update; the run's own is 1e-09)" in retries[0]


# a polygon whose slope (0, 0)-(1, 1) runs through the points of the
# cells it crosses (2 a cell and axis): the seeding warns of them
POLYGON = """
name = "wedge"
[grid]
x = [0.0, 4.0, 8]
y = [0.0, 2.0, 4]
[[bodies]]
name = "soil"
region = { polygon = [[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [1.0, 1.0]] }
material = { model = "linear_elastic", E = 1e4, nu = 0.3 }
[[supports]]
boundary = "bottom"
[gravity]
body_force = [0.0, -10.0]
[solver]
steps = 1
"""


def test_a_run_says_its_seeding_warning_once(tmp_path, caplog):
    """The command line seeded the scene twice, once to set up, once in
    run_scene: each seeding warning came twice."""
    path = tmp_path / "wedge.toml"
    path.write_text(POLYGON)
    with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
        assert main(["run", str(path), "--out", str(tmp_path / "out"),
                     "--no-progress", "--no-series"]) == 0
    seeding = [r.getMessage() for r in caplog.records
               if r.getMessage().startswith("seeding:")]
    # the points on the slope, and the volume it cuts: each once
    assert len(seeding) == 2 and len(set(seeding)) == 2
    assert "4 point(s) lie on the region's boundary" in seeding[0]


def test_a_strength_reduction_says_each_warning_once(caplog):
    """A trial's B-spline slope with 2 points per cell and axis heard the
    sparse-points warning once per trial (8 times, of "2.0 points per
    cell"): once a strength reduction now, of 2 points."""
    from types import SimpleNamespace
    from skfem import MeshQuad
    from skfem_mpm.solve.strength_reduction import strength_reduction
    from skfem_mpm.stabilisation.volumetric import warn_sparse_spline_points
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 1, 5))
    points = seed_points(mesh, 2, region=lambda x: x[1] < .5)

    def run(factor):          # warns as a B-spline run does at its start
        warn_sparse_spline_points("bspline", mesh, points, True, True)
        if factor > 1.37:
            raise NewtonDivergenceError("no equilibrium")
        return SimpleNamespace(points=SimpleNamespace(
            displacement=np.array([[0.], [-.1]])))

    with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
        safety = strength_reduction(run, tolerance=1e-3)
    assert len(safety.trials) > 8
    warned = [r.getMessage() for r in caplog.records]
    assert len(warned) == 1
    assert "mean dilatation and 2 points per cell and axis" in warned[0]
    # the filter is gone after the call: the next warning is said
    warn_sparse_spline_points("bspline", mesh, points, True, True)
    assert len(caplog.records) == 2


def test_the_deformed_shape_marks_supports_where_material_is(tmp_path,
                                                             monkeypatch):
    """The trial's rollers on the grid's sides were drawn up to the grid's
    top, 2 m above the soil: now at the nodes that carry material, the
    wedge's right side 0 to 1 m high (nodes 0, 0.5, 1; the points' top
    row at 0.875), not to the grid's 2 m."""
    from skfem_mpm.scenes import plot
    kept, save = {}, plot.save_figure

    def keep(fig, path, *args, **kwargs):
        kept[path.name] = fig
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", keep)
    path = tmp_path / "wedge.toml"
    path.write_text(POLYGON + '[[supports]]\nname = "wall"\n'
                    'boundary = "right"\ncomponents = ["x"]\n')
    assert main(["run", str(path), "--out", str(tmp_path / "out"),
                 "--no-progress", "--no-series"]) == 0
    ax = kept["deformed_shape.png"].axes[0]
    wall, = [line for line in ax.lines if line.get_marker() == ">"]
    assert np.allclose(np.array(wall.get_data()), [[4.] * 3, [0., .5, 1.]])
    base, = [line for line in ax.lines if line.get_marker() == "s"]
    assert np.allclose(base.get_xdata(), np.linspace(0., 4., 9))
    # the view: the material and its supports, not the grid's empty top
    assert ax.get_ylim()[1] < 1.6
