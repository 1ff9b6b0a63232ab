"""The pictures a user trial judged (trial 87): the colour bar of a
safety run's mechanism as high as the slope, ``compare``'s two panels of
one size, each with its numbers, small displacements exaggerated in the
deformed shape (the factor in the title), dense points drawn without
gaps between them, an obstacle near the body inside the picture, and a
contact force's peak marked as its magnitude beside its components'
final values."""
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from skfem_mpm import MaterialPoints
from skfem_mpm.cli import main, plot_contact_forces
from skfem_mpm.scenes import plot
from skfem_mpm.scenes.layout import panel_problems

# trial 87's embankment: a 1:1 slope 4 m high on a 2 m foundation, c-phi
# soil under its weight, 1 cm of settlement on a section 16 m wide
SLOPE = """
name = "embankment"
units = "kN-m"
[grid]
x = [0.0, 16.0, 32]
y = [0.0, 7.0, 14]
[[bodies]]
name = "foundation"
region = { x = [0.0, 16.0], y = [0.0, 2.0] }
points_per_cell = 2
material = { model = "mohr_coulomb", E = 3e4, nu = 0.3, cohesion = 15.0, \
friction_angle = 28.0 }
[[bodies]]
name = "embankment"
region = { polygon = [[0.0, 2.0], [10.0, 2.0], [6.0, 6.0], [0.0, 6.0]] }
points_per_cell = 2
material = { model = "mohr_coulomb", E = 2e4, nu = 0.3, cohesion = 8.0, \
friction_angle = 25.0 }
[gravity]
body_force = [0.0, -19.0]
[[supports]]
name = "base"
boundary = "bottom"
[[supports]]
name = "sides"
boundary = ["left", "right"]
components = ["x"]
[solver]
method = "mpm"
steps = 2
"""


@pytest.fixture
def figures(monkeypatch):
    """The figures the CLI writes, by file name, laid out as saved
    (conftest checks them before)."""
    kept, save = {}, plot.save_figure

    def keep(fig, path, *args, **kwargs):
        plot.settle_layout(fig)
        fig.draw_without_rendering()
        fig.kept_renderer = fig.canvas.get_renderer()
        kept[Path(path).name] = fig
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", keep)
    return kept


def heights(fig, axes):
    renderer = getattr(fig, "kept_renderer", None) or \
        fig.canvas.get_renderer()
    return [a.get_window_extent(renderer).height for a in axes]


def test_the_mechanisms_colour_bar_is_as_high_as_the_slope(tmp_path,
                                                          figures):
    """Trial 87: the bar beside the plastic zone of a low, wide slope
    (drawn at equal aspect) was about twice the plot's height."""
    scene = tmp_path / "slope.toml"
    scene.write_text(SLOPE)
    assert main(["safety", str(scene), "--out", str(tmp_path / "f"),
                 "--no-progress"]) == 0
    fig = figures["mechanism.png"]
    ax = fig.axes[0]
    bar = ax.collections[0].colorbar.ax
    slope, tall = heights(fig, [ax, bar])
    assert tall == pytest.approx(slope, abs=2.)
    assert not panel_problems(fig, fig.kept_renderer)


def test_compares_panels_have_one_size_and_their_own_numbers(tmp_path,
                                                             figures):
    """Trial 87: the panel with the colour bar was smaller than the other
    (its title lower), and it kept "y (m)" without tick labels."""
    scene = tmp_path / "slope.toml"
    scene.write_text(SLOPE)
    assert main(["compare", str(scene), "--out", str(tmp_path / "c")]) == 0
    fig = figures["compare.png"]
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert len(panels) == 2
    first, second = heights(fig, panels)
    assert first == pytest.approx(second, abs=1.)
    renderer = fig.kept_renderer
    titles = [ax.title.get_window_extent(renderer).y0 for ax in panels]
    assert titles[0] == pytest.approx(titles[1], abs=1.)
    for ax in panels:
        assert ax.get_ylabel() == "y (m)"
        assert [t for t in ax.get_yticklabels()
                if t.get_visible() and t.get_text()]
    assert not panel_problems(fig, renderer)


def block(nx: int, ny: int, width: float = 2.) -> MaterialPoints:
    """A block ``width`` x ``width / 2`` of ``nx`` x ``ny`` points."""
    h = width / nx
    x = np.mgrid[h / 2:width:h, h / 2:width / 2:h].reshape(2, -1)
    return MaterialPoints(x=x, volume=np.full(x.shape[1], h * h))


def test_small_displacements_are_exaggerated_and_said(tmp_path, figures):
    """The slope's 1 cm on 16 m: drawn times the largest 1-2-5 number
    that makes it at most 5% of the longer side, the factor in the
    title; true scale at 1% and beyond."""
    scene = tmp_path / "slope.toml"
    scene.write_text(SLOPE)
    out = tmp_path / "s"
    assert main(["run", str(scene), "--out", str(out),
                 "--no-progress"]) == 0
    fig = figures["deformed_shape.png"]
    ax = fig.axes[0]
    import meshio
    last = meshio.read(out / "points_0002.vtu")
    u = last.point_data["displacement"][:, :2].T
    x = last.points[:, :2].T
    x0 = x - u
    largest = np.sqrt((u ** 2).sum(axis=0)).max()
    size = np.ptp(x0, axis=1).max()
    assert largest < .01 * size          # invisible at true scale
    wanted = .05 * size / largest
    power = 10. ** np.floor(np.log10(wanted))
    factor = max(m * power for m in (1, 2, 5, 10) if m * power <= wanted)
    assert factor == plot.displacement_scale(x0, u)
    assert "(displacements x {:g}, the undeformed body dashed)".format(
        factor) in ax.get_title()
    drawn = ax.collections[1].get_offsets().T    # after the outline
    assert np.allclose(np.sort(drawn[1]), np.sort(x0[1] + factor * u[1]),
                       atol=1e-9)
    pts = block(8, 4)
    pts.displacement[1] = -.01 * 2 * pts.x[0] / 2        # 1% of 2 m
    assert plot.displacement_scale(pts.x0, pts.displacement) == 1.
    assert plot.scale_note(1.) == "true scale"


def test_dense_points_overlap_without_white_lines():
    """Trial 87: 96 x 48 points on a footing 3 m wide were drawn 0.8 of
    their spacing wide, their spacing underestimated, and white lines a
    pixel wide ran between the rows (a moire); dense points now overlap,
    sparse ones stay dots."""
    for n, overlap in ((96, True), (8, False)):
        pts = block(n, n // 2, 3.)
        fig, ax = plot.pyplot().subplots(figsize=plot.body_figure_size(
            pts.x))
        plot.draw_deformed_shape(fig, ax, pts, "a block")
        fig.tight_layout()
        fig.draw_without_rendering()
        points = ax.collections[1]
        diameter = np.sqrt(points.get_sizes()[0])            # points
        box = ax.get_window_extent()
        spacing = 3. / n * box.width / np.ptp(ax.get_xlim()) \
            * 72. / fig.dpi
        assert (diameter >= spacing) == overlap, (diameter, spacing)
        plot.pyplot().close(fig)


def test_an_obstacle_by_the_body_is_drawn_whole():
    """Trial 87: a footing's box 0.5 m high on soil 1.5 m high was cut at
    the top of the picture; a floor far wider than the body is still cut
    at the picture's edge."""
    pts = block(24, 12, 3.)
    box = np.array([[-.5, 1.45], [.5, 1.45], [.5, 1.95], [-.5, 1.95]])
    floor = np.array([[-10., -5.], [10., -5.], [10., 0.], [-10., 0.]])
    fig, ax = plot.pyplot().subplots()
    plot.draw_deformed_shape(fig, ax, pts, "a footing", obstacles=[
        ("footing", box), ("floor", floor)])
    (left, right), (bottom, top) = ax.get_xlim(), ax.get_ylim()
    assert top >= 1.95 and left <= -.5
    assert right < 10. and bottom > -5.
    plot.pyplot().close(fig)


def test_the_peak_marked_is_the_magnitude_and_the_components_say_theirs(
        tmp_path, monkeypatch):
    """Trial 87: "peak 180.5, final 180.5" beside a footing's force whose
    y component the terminal gave as 179.369 (20 kN/m sideways)."""
    kept = {}
    monkeypatch.setattr(plot, "save_figure",
                        lambda fig, path, **kw: kept.update(fig=fig))
    force = [[-2., 31.], [10., 120.], [19.99, 179.369]]
    curves = {"footing": {"force": force, "displacement": [
        [0., -.01], [0., -.02], [0., -.05]], "load_factor": [.2, .4, 1.]}}
    scene = SimpleNamespace(name="footing", units="kN-m", dynamics=None,
                            grid=SimpleNamespace(dim=2))
    plot_contact_forces(scene, curves, {"footing": np.array([0., -.05])},
                        "obstacles", tmp_path / "o.png")
    labels = [t.get_text() for t in kept["fig"].axes[0].get_legend()
              .get_texts()]
    magnitude = np.linalg.norm(force, axis=1)
    assert "magnitude: peak {}, final {}".format(
        plot.significant(magnitude.max()),
        plot.significant(magnitude[-1])) in labels
    assert "footing, y: final {}".format(plot.significant(179.369)) in \
        labels
    assert "footing, x: final {}".format(plot.significant(19.99)) in labels
    plot.pyplot().close(kept["fig"])


def test_tractions_and_point_loads_are_drawn_as_arrows(tmp_path, figures):
    """Trial 87: the deformed shape drew no load.  A traction on a block's
    left side and a point load on its top right: arrows onto the loaded
    points, each named in the legend with its value and unit."""
    scene = tmp_path / "block.toml"
    scene.write_text("""
name = "pushed"
units = "kN-m"
[grid]
x = [0.0, 2.0, 8]
y = [0.0, 1.0, 4]
[[bodies]]
name = "block"
region = { x = [0.5, 1.5], y = [0.0, 0.75] }
points_per_cell = 2
material = { model = "linear_elastic", E = 1e4, nu = 0.3 }
[[tractions]]
body = "block"
side = "left"
traction = [8.0, 0.0]
[[point_loads]]
at = [1.4, 0.7]
force = [0.0, -3.0]
[[supports]]
name = "base"
boundary = "bottom"
[solver]
method = "mpm"
steps = 1
""")
    assert main(["run", str(scene), "--out", str(tmp_path / "o"),
                 "--no-progress", "--no-series"]) == 0
    fig = figures["deformed_shape.png"]
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "traction (8, 0) kPa on block (left)" in labels
    assert "point loads, (0, -3) in all (kN/m)" in labels
    from matplotlib.quiver import Quiver
    arrows = [c for c in ax.collections if isinstance(c, Quiver)]
    assert len(arrows) == 2
    left, load = arrows
    # the left side's layer: 0.75 high at 8 points per metre, pushed +x
    assert left.N == round(.75 * 8) and np.all(left.U > 0)
    assert np.all(left.V == 0)
    assert load.N == 1 and load.U[0] == 0 and load.V[0] < 0


def test_compare_panels_share_one_view_under_their_title(tmp_path,
                                                         figures):
    """A lecturer's trial: compare.png's panels had each its own limits
    and a large empty band above them; its title named a stress
    component, not which stress."""
    scene = tmp_path / "slope.toml"
    scene.write_text(SLOPE)
    assert main(["compare", str(scene), "--out", str(tmp_path / "c")]) == 0
    fig = figures["compare.png"]
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert panels[0].get_xlim() == panels[1].get_xlim()
    assert panels[0].get_ylim() == panels[1].get_ylim()
    renderer = fig.kept_renderer
    title = fig.get_suptitle()
    assert "Cauchy, tension positive" in title
    top = max(ax.get_tightbbox(renderer).y1 for ax in panels)
    below = [t for t in fig.texts if t.get_text() == title][0] \
        .get_window_extent(renderer).y0
    assert 0. <= below - top < .03 * fig.bbox.height


def test_the_column_s_stress_pictures_say_which_stress(tmp_path, figures):
    """A lecturer's trial: the 1D column's column_stress.png said
    sigma_yy where its final_stress.png and VTU say sigma_xx (the field
    is stress[0, 0]), its title claimed a closed form of the seed it
    does not draw (the linear solution) and gave no error; no stress
    picture said Cauchy, tension positive."""
    from skfem_mpm.scenes.scene_file import EMBEDDED
    out = tmp_path / "col"
    assert main(["run", str(EMBEDDED), "--out", str(out),
                 "--no-progress", "--no-series"]) == 0
    import json
    error = json.loads((out / "summary.json").read_text())["error"]
    ax = figures["column_stress.png"].axes[0]
    assert "sigma_{xx}" in ax.get_xlabel()
    assert "Cauchy" in ax.get_xlabel()
    assert "closed form" not in ax.get_title()
    assert "linear solution" in ax.get_title()
    assert "{:.3g}".format(error) in ax.get_title()
    assert all(t.get_fontsize() >= 8
               for t in ax.get_legend().get_texts())
    stress = figures["final_stress.png"].axes[0].get_title()
    assert "sigma_xx" in stress and "Cauchy, tension positive" in stress


def test_deformed_shape_s_legend_is_readable_and_says_what_it_marks(
        tmp_path, figures):
    """A lecturer's trial: legends at 5-7 pt, and a support marker below
    a bent beam's root read as holding no material (it marks a node of a
    cell that holds some)."""
    scene = tmp_path / "slope.toml"
    scene.write_text(SLOPE)
    assert main(["run", str(scene), "--out", str(tmp_path / "s"),
                 "--no-progress", "--no-series"]) == 0
    legend = figures["deformed_shape.png"].axes[0].get_legend()
    assert "grid nodes of cells with material" in legend.get_title() \
        .get_text()
    assert all(t.get_fontsize() >= 8 for t in legend.get_texts())
