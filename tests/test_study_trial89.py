"""What a user trial (89) found in studies: ``--vary elements`` kept the
column (1 x 20 cells) one cell wide where the help said every axis
scales in proportion; its cell size, ``(V / N)^(1/d)`` over both axes,
shrank as the square root of the cells along it (orders fitted twice the
order in the cells' length); a grid of one cell was never refined; and
``study.json``'s ``cell_sizes`` came in the order the cases finished."""
from dataclasses import replace

import numpy as np
import pytest

from skfem_mpm.cli import build_parser
from skfem_mpm.scenes.quantities import Quantity
from skfem_mpm.scenes.scene import Grid, Scene
from skfem_mpm.scenes.scene_file import EMBEDDED, load_scene
from skfem_mpm.studies.study import analyse, cell_size, refine

STRIP = Grid(axes=[(0., 2.5, 1), (0., 50., 20)])


def counts(scene):
    return [n for _, _, n in scene.grid.axes]


def test_an_axis_of_one_cell_stays_one_and_the_help_says_so(capsys):
    """The strip stays one cell wide (1 x 160 at 160 elements), its cell
    size the cells' length along y; a 4 x 3 L-shape's axes both scale;
    a grid of one cell scales every axis; ``study --help`` says it."""
    strip = Scene(grid=STRIP, bodies=[])
    assert counts(refine(strip, 160)) == [1, 160]
    for elements in (20, 40, 160):
        assert cell_size(strip, elements) == pytest.approx(
            50. / elements, rel=1e-14)
    ell = Scene(grid=Grid(axes=[(0., 4., 4), (0., 3., 3)]), bodies=[])
    assert counts(refine(ell, 8)) == [8, 6]
    assert cell_size(ell, 8) == pytest.approx(
        np.sqrt(4. / 8 * 3. / 6), rel=1e-14)
    one = Scene(grid=Grid(axes=[(0., 1., 1), (0., 2., 1)]), bodies=[])
    assert counts(refine(one, 8)) == [8, 8]
    assert cell_size(one, 8) == pytest.approx(
        np.sqrt(1. / 8 * 2. / 8), rel=1e-14)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["study", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "an axis of one cell stays one cell where another has more" \
        in text


def test_cell_sizes_run_coarse_to_fine():
    """Cases in the order they finished (8, 64, 16, 32 elements) give
    ``cell_sizes`` and ``values`` sorted together, coarse to fine."""
    scene = replace(load_scene(EMBEDDED), reference=None)
    q = Quantity("displacement", "x", at=(50.,), name="settlement")
    order = [8, 64, 16, 32]
    value = {e: 1. + 0.3 / e ** 2 for e in order}
    rows = [dict(elements=e, ppc=2, failure="", values={q.label: value[e]},
                 points=2 * e, wall_seconds=1e-3 * e, cpu_seconds=1e-3 * e,
                 steps_run=1, newton_iterations=1, factorisations=1)
            for e in order]
    found = analyse(scene, rows, [q])["convergence"][0]
    ascending = sorted(order)
    assert found["cell_sizes"] == [cell_size(scene, e) for e in ascending]
    assert found["values"] == [value[e] for e in ascending]
    assert found["order"] == pytest.approx(2., abs=1e-6)
