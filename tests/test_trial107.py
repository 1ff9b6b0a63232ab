"""What a user trial (107) found porting a model of its own points from
another code: volumes far from the cells' run silently (and blamed the
points per cell), duplicated points added mass, 1-based body ids were
blamed on the body force's rows, ``SeriesWriter.write`` with ``None``
elements failed, the points' fields and GIMP domains undocumented for
points of one's own, and a scene's outputs kept only their last value."""
import logging
from dataclasses import fields

import numpy as np
import pytest
from skfem import (ElementLineP1, ElementQuad1, ElementTriP1, MeshLine,
                   MeshQuad, MeshTri)

from skfem_mpm import LinearElastic, MaterialPoints, seed_points, simulate
from skfem_mpm.errors import InvalidInputError, InvalidMaterialError


def grid():
    return MeshQuad.init_tensor(np.linspace(0., 4., 9), np.linspace(0., 3., 7))


def base(b):
    return b.get_dofs(lambda x: x[1] == 0.)


def block(mesh, scale=1.):
    """A block 4 x 2 seeded 2 x 2 a cell, its volumes times ``scale``."""
    pts = seed_points(mesh, 2, region=lambda x: x[1] < 2.)
    return MaterialPoints(x=pts.x, volume=pts.volume * scale, body=pts.body)


def run(mesh, points, elem=ElementQuad1(), **kw):
    kw.setdefault("body_force", [0., -10.])
    return simulate(mesh, elem, points, kw.pop("material", LinearElastic(
        1e4, .3)), base, nsteps=1, **kw)


def warnings_of(caplog):
    return [r.getMessage() for r in caplog.records
            if r.levelno >= logging.WARNING]


@pytest.mark.parametrize("mesh, elem", [
    (grid(), ElementQuad1()),
    (MeshTri.init_tensor(np.linspace(0., 4., 9), np.linspace(0., 3., 7)),
     ElementTriP1())])
def test_volumes_far_from_the_cells_are_warned(caplog, mesh, elem):
    """Volumes twice the cells' (every cell holding 2 x 2 points) ran
    with a warning blaming the count ("1.4 points per cell and axis ...
    seed 2"), a hundredth of them silently: both are warned at the start
    with the share, seeded ones are not."""
    from skfem_mpm.quadrature.locate import point_locator
    from skfem_mpm.solve.core import filled_cells
    pts = block(mesh)
    name, volume, filled = filled_cells(mesh, pts, point_locator(mesh)(
        pts.x)[0])
    share = filled.sum() / volume.sum()     # 1: the cells'
    for scale, words in ((1., None), (2., "volumes too large"),
                         (.01, "volumes too small")):
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
            run(mesh, block(mesh, scale), elem)
        found = [m for m in warnings_of(caplog) if "cells they occupy" in m]
        assert not [m for m in warnings_of(caplog)
                    if "per cell and axis" in m]
        if words is None:
            assert not found
            continue
        assert len(found) == 1 and words in found[0]
        assert "sum to {:.3g} of the volume".format(
            scale * share) in found[0]


def test_points_per_cell_are_counted_not_estimated():
    """The under-integration warning counts the points in the cells that
    hold them: 2 x 2 points of doubled volumes are enough, 1 a cell is
    not (its words say they were counted)."""
    from skfem_mpm.solve.core import underintegrated_cells
    mesh = grid()
    assert underintegrated_cells("mpm", mesh, ElementQuad1(),
                                 block(mesh, 2.)) == ""
    one = seed_points(mesh, 1)
    message = underintegrated_cells("mpm", mesh, ElementQuad1(), one)
    assert "1 point per cell and axis" in message and "counted" in message


def test_seeded_and_deformed_points_fill_their_cells():
    """The threshold's margin: a block sheared and compressed by a
    third (its points in other cells than they were seeded in) fills its
    cells below FILL_HIGH, seeded ones to round-off."""
    from skfem_mpm.quadrature.locate import point_locator
    from skfem_mpm.solve.core import FILL_HIGH, FILL_LOW, filled_cells
    mesh = MeshQuad.init_tensor(np.linspace(0., 8., 17),
                                np.linspace(0., 4., 9))
    pts = seed_points(mesh, 2, region=lambda x: (x[0] < 4.) & (x[1] < 2.))
    name, volume, filled = filled_cells(mesh, pts,
                                        point_locator(mesh)(pts.x)[0])
    assert filled.sum() / volume.sum() == pytest.approx(1.)
    F = np.array([[1., .4], [0., 2. / 3.]])
    x = F @ pts.x + .3
    moved = MaterialPoints(x=x, volume=pts.volume * np.linalg.det(F))
    name, volume, filled = filled_cells(mesh, moved,
                                        point_locator(mesh)(moved.x)[0])
    assert FILL_LOW < filled.sum() / volume.sum() < FILL_HIGH / 1.3


def test_duplicated_points_are_refused():
    """Five points given twice ran with their mass added; refused naming
    the pairs and their positions, in 1D too, and two bodies' points at
    one position as overlapping bodies."""
    mesh = grid()
    pts = block(mesh)
    twice = MaterialPoints(x=np.hstack([pts.x, pts.x[:, :5]]),
                           volume=np.r_[pts.volume, pts.volume[:5]])
    with pytest.raises(InvalidInputError,
                       match=r"5 point\(s\) repeat .* points 0 and {} at "
                       r"\[0.125, 0.125\]".format(pts.n)):
        run(mesh, twice)
    both = MaterialPoints(x=np.hstack([pts.x, pts.x[:, :1]]),
                          volume=np.r_[pts.volume, pts.volume[:1]],
                          body=np.r_[np.zeros(pts.n, int), 1])
    with pytest.raises(InvalidInputError, match="bodies 0 and 1 overlap"):
        run(mesh, both, material=[LinearElastic(1e4, .3)] * 2)
    line = MeshLine(np.linspace(0., 1., 5))
    one = seed_points(line, 2)
    with pytest.raises(InvalidInputError, match="points 3 and 8 at"):
        simulate(line, ElementLineP1(),
                 MaterialPoints(x=np.hstack([one.x, one.x[:, 3:4]]),
                                volume=np.r_[one.volume, one.volume[3]]),
                 LinearElastic(1e4, 0.), lambda b: b.get_dofs(
                     lambda x: x[0] == 0.), body_force=[-1.], nsteps=1)


def test_body_ids_count_from_zero():
    """1-based ids {1, 2} with two materials were told "one row per body
    (3), got 2": the message says ids count from 0 and which the points
    hold; three materials with body 0 empty ran silently: warned."""
    mesh = grid()
    pts = block(mesh)
    ids = np.where(pts.x[1] < 1., 1, 2)
    own = MaterialPoints(x=pts.x, volume=pts.volume, body=ids)
    two = [LinearElastic(1e4, .3), LinearElastic(2e4, .3)]
    with pytest.raises(InvalidInputError, match=r"got 2 \(body ids count "
                       r"from 0 to 2; the points hold bodies \[1, 2\], "
                       r"body 0 none\)"):
        run(mesh, own, material=two, body_force=[[0., -10.]] * 2)
    with pytest.raises(InvalidMaterialError, match="body 0 none"):
        run(mesh, own, material=two)


def test_a_body_without_points_is_warned(caplog):
    mesh = grid()
    pts = block(mesh)
    own = MaterialPoints(x=pts.x, volume=pts.volume,
                         body=np.where(pts.x[1] < 1., 1, 2))
    with caplog.at_level(logging.WARNING, logger="skfem_mpm"):
        run(mesh, own, material=[LinearElastic(1e4, .3)] * 3)
    assert [m for m in warnings_of(caplog)
            if "a body holds no point" in m and "body 0 none" in m]


def test_series_writer_takes_none_for_every_cell(tmp_path):
    """``write(0, 0., points, None, None)`` as the docstring has it for
    step 0 raised a meshio WriteError (cells of shape (720, 1, 4))."""
    meshio = pytest.importorskip("meshio")
    from skfem_mpm.scenes.output import SeriesWriter
    mesh = grid()
    pts = block(mesh)
    writer = SeriesWriter(tmp_path, mesh, pts)
    writer.write(0, 0., pts, None, None)
    cells = meshio.read(tmp_path / "grid_0000.vtu").cells
    assert [c.data.shape for c in cells] == [(mesh.nelements, 4)]


def test_gimp_without_domains_says_what_to_give():
    mesh = grid()
    pts = block(mesh)
    with pytest.raises(InvalidInputError,
                       match=r"half-lengths per axis.*np.tile\(volume "
                       r"\*\* \(1 / 2\) / 2, \(2, 1\)\)"):
        run(mesh, MaterialPoints(x=pts.x, volume=pts.volume),
            method="cpgimp")
    seeded = seed_points(mesh, 2)
    half = np.tile(seeded.volume ** (1 / 2) / 2, (2, 1))
    assert np.allclose(half, seeded.domain)   # the advice is seed_points'


def test_material_points_document_every_field():
    doc = MaterialPoints.__doc__
    params = doc[doc.index("Parameters"):doc.index("Examples")]
    for f in fields(MaterialPoints):
        assert "\n    {}\n".format(f.name) in params or \
            "\n    {},".format(f.name) in params or \
            ", {}\n".format(f.name) in params, f.name
    assert "tension positive" in params


def test_scene_outputs_keep_their_history(tmp_path):
    """summary.json kept an output's last value only: its history per
    step, the last its value."""
    import json
    from skfem_mpm.cli import main
    scene = tmp_path / "s.toml"
    scene.write_text("""\
name = "s"
[grid]
x = [0.0, 2.0, 4]
y = [0.0, 2.0, 4]
[[bodies]]
name = "b"
region = { x = [0.0, 2.0], y = [0.0, 1.0] }
material = { model = "linear_elastic", E = 1e4, nu = 0.3 }
[[supports]]
name = "base"
boundary = "bottom"
[gravity]
body_force = [0.0, -10.0]
[[outputs]]
name = "settlement"
quantity = "displacement"
component = "y"
reduce = "min"
[[outputs]]
name = "base"
quantity = "reaction"
support = "base"
component = "y"
[solver]
steps = 3
""")
    assert main(["run", str(scene), "--out", str(tmp_path / "out"),
                 "--no-series", "--no-progress"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    for label in ("settlement", "base"):
        out = summary["outputs"][label]
        history = out["history"]
        assert history["step"] == [1, 2, 3]
        assert history["load_factor"] == pytest.approx([1 / 3, 2 / 3, 1.])
        assert history["value"][-1] == pytest.approx(out["value"])
        # linear elastic, the load ramped: each step's share of the last
        # (the points' update in small-strain MPM: within 1e-3)
        assert history["value"] == pytest.approx(
            [out["value"] * f for f in history["load_factor"]], rel=1e-3)
    weight = 10. * 2. * 1.         # body force x the body's area
    assert summary["outputs"]["base"]["history"]["value"] == pytest.approx(
        [weight * f for f in summary["outputs"]["base"]["history"][
            "load_factor"]])
