"""The twenty-second performance round (issue 32): the ghost penalty in
reserve (``ghost="auto"``) searches no faces past the supports for
standard MPM, whose active cells are those holding points (no domain
reaches past them), and still searches them for GIMP."""
import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import LinearElastic, seed_points, simulate
from skfem_mpm.stabilisation import ghost


@pytest.mark.parametrize("method, searches", [("mpm", 0), ("ugimp", 2)])
def test_reserve_searches_faces_only_where_domains_reach_past_cells(
        method, searches, monkeypatch):
    """Two load steps of a block on held ground: standard MPM's steps
    search no faces (the search would find none: its reached cells are
    its points' cells), uGIMP's search at each step; neither switches
    the penalty on, and standard MPM's answer is the one the search gave
    (the search's own answer, no face, for each of its operators)."""
    mesh = MeshQuad.init_tensor(np.linspace(0., 1., 5),
                                np.linspace(0., 1., 5))
    points = seed_points(mesh, 2, region=lambda x: x[1] < .5 + 1e-9)
    calls, found = [], []
    search = ghost.faces_crossed_past_supports

    def counted(mesh, nodal_dofs, fixed, point_cells, active_cells,
                blocked=None):
        calls.append(active_cells)
        faces = search(mesh, nodal_dofs, fixed, point_cells, active_cells,
                       blocked)
        found.append(faces.size)
        return faces
    monkeypatch.setattr(ghost, "faces_crossed_past_supports", counted)
    result = simulate(mesh, ElementQuad1(), points, LinearElastic(1e6, .3),
                      lambda b: b.get_dofs(lambda x: x[1] == 0.),
                      body_force=[0., -1e4], nsteps=2, method=method,
                      kinematics="small")
    assert len(calls) == searches
    assert found == [0] * searches
    assert result.counters["ghost_from_step"] == 0
    if method == "mpm":      # what the search answers for its operator
        cells = np.unique(mesh.element_finder()(*points.x))
        assert search(mesh, np.arange(2 * mesh.nvertices).reshape(-1, 2).T,
                      np.arange(2 * mesh.nvertices), cells, cells).size == 0
