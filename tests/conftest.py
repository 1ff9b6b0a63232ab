import pytest

from meshes import FAMILIES


@pytest.fixture(params=list(FAMILIES))
def family(request):
    make_mesh, elem = FAMILIES[request.param]
    return request.param, make_mesh(), elem()


@pytest.fixture(autouse=True)
def figures_explain_themselves(monkeypatch):
    """Every figure the package, its CLI or an example writes during the
    tests is checked before it is saved: labelled axes, a title, labelled
    colour bars, signed colour maps centred on zero
    (:func:`skfem_mpm.scenes.plot.figure_problems`), and its text is
    readable as saved: inside the figure, tick labels apart
    (:func:`skfem_mpm.scenes.plot.layout_problems`, measured in the draw
    that saves it: no draw of its own, and the layout settled once, by
    ``save_figure``)."""
    from skfem_mpm.scenes import plot
    save = plot.save_figure

    def checked(fig, path, *args, **kwargs):
        problems = plot.figure_problems(fig)
        assert not problems, "{}: {}".format(path, problems)
        drawn = []                # the problems of each draw's layout
        watch = fig.canvas.mpl_connect("draw_event", lambda event: (
            drawn.append(plot.layout_problems(fig, event.renderer))))
        save(fig, path, *args, **kwargs)
        fig.canvas.mpl_disconnect(watch)
        assert drawn, "{}: not drawn when saved".format(path)
        assert not drawn[-1], "{}: {}".format(path, drawn[-1])
    monkeypatch.setattr(plot, "save_figure", checked)
