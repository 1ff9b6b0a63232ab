"""Supports that hold grid nodes inside a body are warned (trial 115: a
base support's tolerance about y = 0.1 also took the row of nodes at
y = 0.308 inside the backfill and ran silently to a wall force 20% off
Rankine's)."""
import logging

import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import LinearElastic, seed_points, simulate

N = 4          # cells a side of the unit square


def warned(caplog, height, supports):
    """The interior-support warnings of a one-step elastic run of a body
    filling the unit square's grid up to ``height`` under gravity."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, N + 1),
                                np.linspace(0, 1, N + 1))
    pts = seed_points(mesh, 2, region=lambda x: x[1] < height)
    with caplog.at_level("WARNING", logger="skfem_mpm.supports.interior"):
        simulate(mesh, ElementQuad1(), pts, LinearElastic(1e3, .3),
                 supports, body_force=[0., -1.], nsteps=1)
    return [r.getMessage() for r in caplog.records
            if r.name == "skfem_mpm.supports.interior"]


def test_a_row_of_nodes_inside_the_body_is_warned(caplog):
    """A tolerance that takes the base and the first row above it: the
    row's nodes off the grid's sides (N - 1 of them) are inside the body,
    named with their line and extent."""
    h = 1. / N
    found = warned(caplog, 1., lambda b: b.get_dofs(
        lambda x: np.abs(x[1] - .1) < .2).all())
    assert len(found) == 1
    assert found[0].startswith(
        "supports: {} grid node(s) held have material in every cell "
        "around them, inside a body, along y = {:.6g}, from ({:.6g}, "
        "{:.6g}) to ({:.6g}, {:.6g})".format(N - 1, h, h, h, 1. - h, h))
    assert "logging.getLogger('skfem_mpm.supports.interior')" in found[0]


@pytest.mark.parametrize("height, rows", [
    (1., (0.,)),               # the base alone: on the grid's boundary
    (.5, (0., .5)),            # and the body's top row: cells above empty
])
def test_supports_on_the_boundaries_are_not_warned(caplog, height, rows):
    """The base on the grid's edge, and nodes on a body's surface (the
    cells above hold no material), are not inside a body."""
    found = warned(caplog, height, lambda b: b.get_dofs(
        lambda x: np.isin(np.round(x[1], 9), rows)).all())
    assert found == []


def test_a_symmetry_line_through_a_body_is_not_warned(caplog):
    """One component held on a line through the body (a symmetry axis,
    the shipped cylinder's x on x = 0.5 through its disc) is a roller,
    not a support holding the inside: not warned (the review found the
    shipped example warned), while the same line holding both components
    is."""
    axis = [lambda b: np.concatenate([
        b.get_dofs(lambda x: x[1] == 0.).all(),
        b.get_dofs(lambda x: x[0] == .5).nodal["u^1"]]),
        lambda b: np.concatenate([
            b.get_dofs(lambda x: x[1] == 0.).all(),
            b.get_dofs(lambda x: x[0] == .5).all()])]
    assert warned(caplog, 1., axis[0]) == []
    caplog.clear()
    found = warned(caplog, 1., axis[1])
    assert len(found) == 1 and "along x = 0.5" in found[0]


def test_the_warning_is_silenced_by_its_logger(caplog):
    """Meant (an anchor held inside the body): its logger's level."""
    logging.getLogger("skfem_mpm.supports.interior").setLevel(
        logging.ERROR)
    try:
        mesh = MeshQuad.init_tensor(np.linspace(0, 1, N + 1),
                                    np.linspace(0, 1, N + 1))
        pts = seed_points(mesh, 2)
        with caplog.at_level("WARNING"):
            simulate(mesh, ElementQuad1(), pts, LinearElastic(1e3, .3),
                     lambda b: b.get_dofs(
                         lambda x: np.abs(x[1] - .1) < .2).all(),
                     body_force=[0., -1.], nsteps=1)
        assert "inside a body" not in caplog.text
    finally:
        logging.getLogger("skfem_mpm.supports.interior").setLevel(
            logging.NOTSET)
