"""Figures of many points (trial 111, item 10): a picture draws at most
``plot.DRAWN_MOST`` points, one per square of a regular grid over the
body, says so in its title, and still covers the whole body (a million
points took 66 to 78 s to draw, 30 s the deformed shape alone)."""
import numpy as np
import pytest

from skfem_mpm import MaterialPoints
from skfem_mpm.scenes import plot

MOST = 2000


@pytest.fixture
def points(monkeypatch):
    """A slope of 120 x 60 lattice points (7200 > MOST), its right part
    higher, plastic at its toe, its last column a rigid plate."""
    monkeypatch.setattr(plot, "DRAWN_MOST", MOST)
    h = 1. / 30
    x = np.mgrid[h / 2:4:h, h / 2:2:h].reshape(2, -1)
    x = x[:, x[1] < 1. + .25 * x[0]]
    pts = MaterialPoints(x=x.copy(), volume=np.full(x.shape[1], h * h))
    pts.displacement[1] = -1e-3 * x[1]
    pts.stress[1, 1] = -x[1]
    pts.state["equivalent_plastic_strain"] = np.maximum(0., 1. - x[0])
    return pts


def drawn(ax):
    """The places of the points every scatter of ``ax`` draws."""
    return [c.get_offsets() for c in ax.collections
            if len(c.get_offsets()) and c.get_rasterized()]


def covers(pts, places, part: float = .25):
    """Whether every square of side ``part`` (m) holding points holds a
    drawn one."""
    key = {tuple(k) for k in np.floor(pts.x.T / part).astype(int)}
    return key == {tuple(k) for k in np.floor(places / part).astype(int)}


def test_draw_points_draws_at_most_the_limit_and_says_so(points):
    fig, ax = plot.pyplot().subplots()
    plot.draw_points(fig, ax, points, points.stress[1, 1], "s (Pa)",
                     "stress")
    places, = drawn(ax)
    assert len(places) <= MOST
    assert covers(points, places)
    assert "{} of {} points drawn".format(len(places), points.n) in \
        ax.get_title().replace("\n", " ")
    # the colour scale is the one of every point, drawn or not
    assert ax.collections[0].norm.vmin == pytest.approx(
        points.stress[1, 1].min())
    # the same points each time
    fig2, ax2 = plot.pyplot().subplots()
    plot.draw_points(fig2, ax2, points, points.stress[1, 1], "s (Pa)",
                     "stress")
    np.testing.assert_array_equal(drawn(ax2)[0], places)
    plot.pyplot().close(fig)
    plot.pyplot().close(fig2)


def test_few_points_are_all_drawn_without_a_note(points, monkeypatch):
    monkeypatch.setattr(plot, "DRAWN_MOST", points.n)
    fig, ax = plot.pyplot().subplots()
    plot.draw_points(fig, ax, points, points.stress[1, 1], "s (Pa)",
                     "stress")
    assert len(drawn(ax)[0]) == points.n
    assert ax.get_title() == "stress"
    plot.pyplot().close(fig)


def test_deformed_shape_and_plastic_zone_draw_at_most_the_limit(points):
    rigid = points.x[0] > 4. - 1. / 30
    fig, ax = plot.pyplot().subplots()
    plot.draw_deformed_shape(fig, ax, points, "deformed",
                             rigid={"plate": rigid})
    soil, plate = drawn(ax)
    assert len(soil) <= MOST and covers(points, np.vstack([soil, plate]))
    assert len(plate) == rigid.sum()             # few: all drawn
    assert "{} of {} points drawn".format(len(soil), (~rigid).sum()) in \
        ax.get_title().replace("\n", " ")
    fig2, ax2 = plot.pyplot().subplots()
    plot.draw_plastic_zone(fig2, ax2, points, "zone")
    zone, = drawn(ax2)
    assert len(zone) <= MOST and covers(points, zone)
    assert "{} of {} points drawn".format(len(zone), points.n) in \
        ax2.get_title().replace("\n", " ")
    for f in (fig, fig2):
        plot.pyplot().close(f)
