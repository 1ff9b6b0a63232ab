"""Every example is a test: import it and assert its numbers."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / (name +
                                                                     ".py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def column():
    return load("column")


def test_column_figure_2_10(column):
    for ppc in (2, 3, 4, 5):
        # one load step: FE convergence, rate 1
        assert abs(column.rates[1, ppc] - 1.) < .1
        # 20 load steps: the grid-crossing plateau
        assert column.rates[20, ppc] < .3
        err20 = column.errors[20, ppc]
        assert (err20[column.nelems >= 16] > 1e-2).all()
        # on coarse grids (no crossing) the step count hardly matters
        np.testing.assert_allclose(err20[:3], column.errors[1, ppc][:3],
                                   rtol=.1)


def test_column_figure_2_9_and_dimensions(column):
    # 10 elements: 20 steps give about the one-step profile; 100 do not
    from skfem_mpm.column import column_error
    coarse = [column_error(column.profiles[10, n].points) for n in (1, 20)]
    fine = [column_error(column.profiles[100, n].points) for n in (1, 20)]
    assert coarse[1] < 1.1 * coarse[0]
    assert fine[1] > 10 * fine[0]
    assert column.dim_difference < 1e-9


def test_column_figures_are_written(column, tmp_path):
    column.visualize(tmp_path)
    for name in ("column_stress_profiles.png", "column_convergence.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    assert not list(tmp_path.glob(".*"))      # no temporary file left
