"""What a user trial (89) found in words and pictures: a slit grid's
refusal said a vertex "lies where one of its own does"; the rigid
bodies' force label said the weight of the points was taken off on a
scene without gravity; the pressure's arrows on a side came in close
pairs."""
import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import LinearElastic, seed_points, simulate
from skfem_mpm.errors import InvalidInputError
from skfem_mpm.scenes import plot
from skfem_mpm.scenes.scene import Body, Grid, Scene


def slit_grid():
    """2 x 2 of cells 0.5 wide, the cells right of x = 1 on their own
    nodes below y = 1: a slit from y = 0 to y = 1."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 5), np.linspace(0, 2, 5))
    p, t = mesh.p.copy(), mesh.t.copy()
    ids = np.flatnonzero(np.isclose(p[0], 1.) & (p[1] < 1 - 1e-9))
    twin = {i: p.shape[1] + k for k, i in enumerate(ids)}
    p = np.hstack([p, p[:, ids]])
    for c in np.flatnonzero(p[0, t].mean(axis=0) > 1):
        t[:, c] = [twin.get(v, v) for v in t[:, c]]
    return MeshQuad(p, t), twin


def test_a_slit_is_said_to_need_two_bodies():
    """The refusal names the vertex the duplicate coincides with (one of
    the facet's, listed with it) and says one grid cannot model a slit,
    two bodies in contact can."""
    mesh, twin = slit_grid()
    with pytest.raises(InvalidInputError) as refused:
        simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
                 LinearElastic(1e4, .3),
                 lambda b: b.get_dofs(lambda x: np.isclose(x[0], 0.)).all(),
                 body_force=[10., 0.])
    words = str(refused.value)
    found = [(a, b) for a, b in twin.items()
             if "vertex {} at".format(b) in words]
    assert found, words
    a, b = found[0]
    assert "coincides with vertex {} of the facet".format(a) in words
    assert "vertices {} at {}".format(a, mesh.p[:, a].tolist()) in \
        words or ", {} at {}".format(a, mesh.p[:, a].tolist()) in words
    assert "one grid cannot model a slit: two bodies in contact can " \
        "(docs/contact.md" in words
    assert "lies where one of its own" not in words


@pytest.mark.parametrize("gravity", [None, [0., -10.]])
def test_the_weight_is_said_taken_off_only_under_a_body_force(
        tmp_path, monkeypatch, gravity):
    from skfem_mpm import cli
    figures = []
    monkeypatch.setattr(plot, "save_figure",
                        lambda fig, path, **kw: figures.append(fig))
    soil = Body(name="soil", region=[[0., 1.], [0., .5]],
                material=LinearElastic(1e4, .3))
    scene = Scene(grid=Grid(axes=[(0., 1., 2), (0., 1., 2)]),
                  bodies=[soil], gravity=gravity, name="punch")
    curves = {"footing": {"displacement": [[0., -.1], [0., -.2]],
                          "force": [[0., -5.], [0., -8.]]}}
    cli.plot_rigid_bodies(scene, curves, tmp_path / "rigid_bodies.png")
    label = figures[0].axes[0].get_ylabel()
    assert label.startswith("force along the motion")
    assert ("taken off" in label) == (gravity is not None)


def test_a_side_s_arrows_are_evenly_spaced():
    """The trial's left side pressed by a pressure: 20 points every
    0.125 m, their x moved by the load by up to 1e-3; at most 12 arrows
    were chosen by rounding fractional indices of the points sorted by x
    (close pairs); now every other point, 0.25 apart."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot
    spacing = .125
    y = spacing * (np.arange(20) + .5)
    x = spacing / 2 + 1e-3 * np.sin(7 * y)
    mark = plot.LoadMarks("pressure", np.vstack([x, y]),
                          np.tile([[20.], [0.]], (1, y.size)))
    fig, ax = pyplot.subplots()
    tails = plot.draw_loads(ax, [mark], (0, 1), .2, [], most=12)
    pyplot.close(fig)
    drawn = np.sort(tails[1])
    stride = -(-y.size // 12)
    assert drawn.size == -(-y.size // stride)
    assert np.allclose(np.diff(drawn), stride * spacing, rtol=1e-12)
