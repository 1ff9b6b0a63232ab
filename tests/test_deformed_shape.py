"""The deformed-shape picture of a run (issue 30, item 3): the points at
their final positions over the undeformed outline, with the supports, the
rigid bodies and any obstacles drawn and named in a legend."""
import json

import numpy as np
import pytest

from skfem_mpm import MaterialPoints
from skfem_mpm.cli import main
from skfem_mpm.scenes import plot
from test_footing import FOOTING

# the coarse footing of test_footing (a smooth rigid footing on von Mises
# clay, base fixed, sides on rollers) in 2 steps, its left support named
FOOTING = FOOTING.replace("steps = 6", "steps = 2").replace(
    '[[supports]]\nboundary = "left"', '[[supports]]\nname = "axis"\n'
    'boundary = "left"')


@pytest.fixture
def figures(monkeypatch):
    """The figures the command writes, by file name (checked by
    conftest's figure_problems before they are saved)."""
    kept, save = {}, plot.save_figure

    def keep(fig, path, *args, **kwargs):
        kept[path.name] = fig
        legend = [ax.get_legend() for ax in fig.axes]
        kept[path.name + ":legend"] = [t.get_text() for g in legend if g
                                       for t in g.get_texts()]
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", keep)
    return kept


def test_a_run_draws_its_deformed_shape_with_supports_and_rigid_bodies(
        tmp_path, figures):
    scene = tmp_path / "footing.toml"
    scene.write_text(FOOTING)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--no-progress",
                 "--no-series"]) == 0
    assert (out / "deformed_shape.png").stat().st_size > 10_000
    # a later run in the folder removes it with the run's other files
    from fnmatch import fnmatch

    from skfem_mpm.scenes.io import RUN_OUTPUTS
    assert [p.name for p in out.iterdir() if p.name != "scene.toml" and
            not any(fnmatch(p.name, g) for g in RUN_OUTPUTS)] == []
    fig = figures["deformed_shape.png"]
    ax, bar = fig.axes
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (m)", "y (m)")
    assert ax.get_title().startswith("coarse-footing: deformed shape at "
                                     "load factor 1")
    assert bar.get_ylabel() == "displacement magnitude |u| (m)"
    legend = figures["deformed_shape.png:legend"]
    assert legend == [
        "undeformed body (outline)",
        "material points, deformed (colour: |u|)", "rigid body: footing",
        "support-1 (bottom): x, y fixed", "axis (left): x fixed",
        "support-3 (right): x fixed"]
    # the supports at their grid nodes that carry material: 9 along the
    # bottom, 6 up the left side (the footing's points by its top node),
    # 5 up the right, the soil's 0.5 m (its top node, 0.125 above the
    # soil, holds nothing: a trial's rollers were drawn up the grid's
    # whole side)
    marks = [line for line in ax.lines if line.get_marker() in ("s", ">")]
    bottom, left, right = (np.array(m.get_data()) for m in marks)
    assert np.allclose(bottom, [np.linspace(0., 1., 9), np.zeros(9)])
    assert np.allclose(left, [np.zeros(6), np.linspace(0., .625, 6)])
    assert np.allclose(right, [np.ones(5), np.linspace(0., .5, 5)])
    # the footing's points in black, moved down by its 0.03 at full load
    # (0.5 to 0.625 high, 2 x 2 points in each of its two cells)
    footing = [c for c in ax.collections if c.get_offsets().shape[0] == 8
               and c.get_array() is None]
    assert len(footing) == 1
    assert np.allclose(np.sort(np.unique(footing[0].get_offsets()[:, 1])),
                       [.53125 - .03, .59375 - .03])


@pytest.mark.slow
def test_a_failed_run_draws_its_last_converged_state(tmp_path, figures):
    """The picture of what failed: a run that stops at a step that does
    not converge draws the state of its last converged step."""
    scene = tmp_path / "footing.toml"
    scene.write_text(FOOTING.replace("steps = 2", "steps = 6\n"
                                     "max_iterations = 2"))
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--no-progress",
                 "--no-series"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed"
    title = figures["deformed_shape.png"].axes[0].get_title()
    assert "the last converged state" in title and "failed" in title
    # the footing moved by 0.03 times the load factor of that state
    factor = summary["rigid_bodies"]["footing"]["displacement"][-1][1] / -.03
    assert 0 < factor < 1
    assert "at load factor {:.4g},".format(factor) in title


def test_obstacles_are_drawn_as_named_outlines_and_plain_points():
    """The drawing takes rigid obstacles as named polygons (k, 2), e.g.
    the boxes and polygons of geometric obstacles; points plain
    (coloured=False) get no colour bar."""
    x = np.mgrid[.25:2:.5, .25:1:.5].reshape(2, -1)
    points = MaterialPoints(x=x, volume=np.full(x.shape[1], .25))
    points.displacement[1] = -.1 * x[0]
    wall = np.array([[2.2, -.5], [2.5, -.5], [2.5, 1.], [2.2, 1.]])
    floor = np.array([[-.5, -.6], [3., -.6], [3., -.4]])
    # an Obstacle's own outline, moved by its displacement at full load
    from skfem_mpm import Obstacle
    lid = Obstacle(box=[[0., 2.], [1.1, 1.3]], displacement=[0., -.05],
                   name="lid")
    fig, ax = plot.pyplot().subplots()
    plot.draw_deformed_shape(fig, ax, points, "a bent block", obstacles=[
        ("wall", wall), ("floor", floor),
        (lid.name, lid.outline(np.array([0., -.05])))], coloured=False,
        supports=[plot.SupportMarks("clamp", np.array([[0., 0.], [0., 1.]]),
                                    (0, 1))])
    assert fig.axes == [ax]                     # no colour bar
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "undeformed body (outline)", "material points, deformed", "wall",
        "floor", "lid", "clamp"]
    drawn = [p.get_xy()[:-1] for p in ax.patches]   # closed: first again
    assert np.allclose(drawn[0], wall) and np.allclose(drawn[1], floor)
    assert np.allclose(drawn[2], [[0., 1.05], [2., 1.05], [2., 1.25],
                                  [0., 1.25]])
    assert not plot.figure_problems(fig)
    plot.pyplot().close(fig)


@pytest.mark.parametrize("level, drawn", [(0., False), (.25, True)])
def test_a_3d_slice_draws_only_the_supports_in_it(level, drawn):
    """A 3D picture's slice (its layer of points at z = 0.25, spaced
    0.1) draws a support whose nodes lie in its plane, and names one at
    the base z = 0, farther than the points' spacing, as not in the slice
    (a user trial's picture drew it as if in it)."""
    nodes = np.array([[0., 1., 2.], [0., 0., 0.], [level] * 3])
    fig, ax = plot.pyplot().subplots()
    handles = []
    slab = np.mgrid[.05:2:.1, .05:1:.1, .25:.3:.1].reshape(3, -1)
    plot.draw_supports(ax, [plot.SupportMarks("base", nodes, (0, 1, 2))],
                       (0, 1), slab, handles, 3)
    assert (handles[0].get_label() == "base") == drawn
    assert (len(ax.lines[0].get_xdata()) == 3) == drawn
    plot.pyplot().close(fig)


def test_a_3d_slice_through_a_deformed_block_draws_the_faces_it_crosses():
    """A face support crosses every slice: drawn in one of deformed points
    (their coordinates a round-off apart made the spacing test read
    "not in this slice" for the faces of a user trial's block)."""
    rng = np.random.default_rng(0)
    slab = np.mgrid[.05:1:.1, .05:.5:.1, .45:.5:.1].reshape(3, -1)
    slab = slab + 1e-9 * rng.standard_normal(slab.shape)
    y, z = np.mgrid[0:1.01:.25, 0:.51:.25].reshape(2, -1)
    left = np.vstack([np.zeros_like(y), y, z])        # the x- face
    fig, ax = plot.pyplot().subplots()
    handles = []
    plot.draw_supports(ax, [plot.SupportMarks("left", left, (0,))],
                       (0, 1), slab, handles, 3)
    assert handles[0].get_label() == "left"
    assert len(ax.lines[0].get_xdata()) == 5            # y = 0 .. 1
    plot.pyplot().close(fig)


def test_a_3d_picture_slices_through_the_obstacles():
    """The trial's block (1 x 1 x 0.5 m, base and faces x-, y- held) under
    a punch (x, y in [0.3, 0.7]) and beside a wall pushing in -x: the
    picture is the vertical slice across y through the punch's middle
    (a horizontal one at z = 0.27 missed it), the punch's and the wall's
    sections drawn, the x- face drawn, the y- face not in the slice."""
    x = np.mgrid[.0625:1:.125, .0625:1:.125, .0625:.5:.125].reshape(3, -1)
    points = MaterialPoints(x=x, volume=np.full(x.shape[1], .125 ** 3))
    punch = np.array([[.3, .7], [.3, .7], [.5, .7]])
    wall = np.array([[1., 1.3], [-.1, 1.1], [-.1, .8]])
    plane = plot.slice_plane(x, [punch, wall], [[0., 0., -.03],
                                                 [-.02, 0., 0.]])
    assert plane == (1, .5)
    y, z = np.mgrid[0:1.01:.25, 0:.51:.25].reshape(2, -1)
    x_, z_ = np.mgrid[0:1.01:.25, 0:.51:.25].reshape(2, -1)
    supports = [plot.SupportMarks("left", np.vstack([0 * y, y, z]), (0,)),
                plot.SupportMarks("front", np.vstack([x_, 0 * x_, z_]),
                                  (1,))]
    fig, ax = plot.pyplot().subplots()
    plot.draw_deformed_shape(
        fig, ax, points, "punch", supports=supports, plane=plane,
        obstacles=[(name, plot.box_section(box, plane, (0, 2)))
                   for name, box in (("punch", punch), ("wall", wall))])
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "z (m)"
    assert "slice y = 0.438 m" in ax.get_title()   # the layer nearest
    assert np.allclose(ax.patches[0].get_xy()[:-1],
                       [[.3, .5], [.7, .5], [.7, .7], [.3, .7]])
    assert [t.get_text() for t in ax.get_legend().get_texts()][2:] == [
        "punch", "wall", "left", "front (not in this slice)"]
    plot.pyplot().close(fig)


# a tall, thin bar (0.1 x 1 m) under a step traction, 10 time steps: its
# deformed shape's displacements below 1e-4 m (a colour bar's "1e-5"
# factor over the title), a stress picture 0.1 m wide (x ticks 0.04, 0.06
# overlapping)
BAR = """
name = "bar step load"
[grid]
x = [0.0, 0.1, 1]
y = [0.0, 1.2, 48]
[[bodies]]
name = "bar"
region = { y = [0.0, 1.0] }
points_per_cell = 2
density = 1000.0
material = { model = "linear_elastic", E = 1e6, nu = 0.0 }
[[supports]]
name = "base"
boundary = "bottom"
[[tractions]]
body = "bar"
side = "top"
traction = [0.0, -40.0]
[dynamics]
time_step = 0.0012649
duration = 0.012649
[solver]
method = "cpgimp"
"""


def test_a_tall_thin_bodys_figures_keep_their_text_inside(tmp_path,
                                                          figures):
    """Every figure of the bar keeps its titles, labels, legends and tick
    labels inside and apart (conftest's layout_problems, before each is
    saved; the trial's bar lost both sides of its title and legend, drew
    "1e-5" over the title and overlapped 0.04 and 0.06)."""
    scene = tmp_path / "bar.toml"
    scene.write_text(BAR)
    assert main(["run", str(scene), "--out", str(tmp_path / "out"),
                 "--no-progress", "--no-series"]) == 0
    fig = figures["deformed_shape.png"]
    bar = fig.axes[1]
    assert not bar.yaxis.get_offset_text().get_text()
    assert any("e-05" in t.get_text() for t in bar.get_yticklabels())


def test_a_figure_is_laid_out_without_drawing_and_saved_in_one_draw(
        tmp_path):
    """``save_figure`` settles a figure's layout by measuring its text,
    not by drawing it (the layout of 8ff829d drew a figure whole for each
    tick-thinning try and for each check of its titles and size: 3 to 9
    draws a figure), and saves it in one draw (a ``tight_layout`` left a
    place-holder layout engine for which ``savefig`` drew it twice)."""
    from matplotlib.ticker import MaxNLocator
    fig, ax = plot.pyplot().subplots(figsize=(1.5, 3.))
    ax.plot([0., .1], [0., 1.])
    ax.xaxis.set_major_locator(MaxNLocator(nbins=10))  # 0.00 0.01 ...
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("a title wider than the figure of one and a half inches")
    fig.tight_layout()
    drawn = []
    fig.canvas.mpl_connect("draw_event", lambda event: drawn.append(1))
    assert plot.layout_problems(fig) and len(drawn) == 1
    plot.settle_layout(fig)
    assert len(drawn) == 1                      # laid out, not drawn
    assert fig.get_size_inches()[0] > 1.5 and \
        ax.xaxis.get_major_locator()._nbins <= 4  # grown, ticks thinned
    plot.save_figure(fig, tmp_path / "thin.png")
    assert len(drawn) == 2                      # saved in one draw


def test_tick_labels_touching_at_one_resolution_are_thinned(tmp_path):
    """A resumed run's load-displacement curve (x from -0.064 to 0.138):
    its ten x labels "-0.075" .. "0.150" touched at the figure's own
    resolution, where the layout measured them apart, and overlapped once
    saved at 120 dpi (conftest's check of the saved draw).  Labels within
    a pixel of each other are thinned."""
    fig, ax = plot.pyplot().subplots(figsize=(5, 4))
    factor = [0., .5833, .6667, .75]
    ax.plot([0., .09461, .11120, .12897], factor, "o-", ms=3, label="x")
    ax.plot([0., -.04266, -.04875, -.05497], factor, "o-", ms=3, label="y")
    ax.set_xlabel("mean displacement of the loaded points (m)")
    ax.set_ylabel("load factor (-)")
    ax.set_title("cut-back block: load against displacement\nof the loaded "
                 "material points")
    ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 3))
    ax.legend(title="component")
    fig.tight_layout()
    fig.get_tightbbox(fig.canvas.get_renderer())
    assert len(ax.get_xticklabels()) == 10      # "-0.075" .. "0.150"
    plot.save_figure(fig, tmp_path / "load_displacement.png")  # checked
    assert len([t for t in ax.get_xticks()
                if -.0642 <= t <= .1382]) < 8
