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
    (:func:`skfem_mpm.scenes.plot.layout_problems`)."""
    from skfem_mpm.scenes import plot
    save = plot.save_figure

    def checked(fig, path, *args, **kwargs):
        problems = plot.figure_problems(fig)
        assert not problems, "{}: {}".format(path, problems)
        plot.settle_layout(fig)               # as save_figure does
        problems = plot.layout_problems(fig)
        assert not problems, "{}: {}".format(path, problems)
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", checked)
