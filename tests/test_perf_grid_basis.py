"""The run's grid basis forms no fields (issue 32): scikit-fem's
``CellBasis`` formed them for each of an element's functions when made
(0.6 ms of a one-step run's 6 at 56 points), and no run reads them."""
import numpy as np
import pytest
from skfem import Basis, ElementQuad1, ElementVector, MeshQuad
from skfem.quadrature import get_quadrature

from skfem_mpm import LinearElastic, seed_points, simulate
from skfem_mpm.quadrature.grid import GridBasis


def test_a_run_never_forms_the_grid_basis_fields(monkeypatch):
    def refuse(self):
        raise AssertionError("the grid basis's fields were formed")
    monkeypatch.setattr(GridBasis, "_formed", refuse)
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    res = simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
                   LinearElastic(1e3, .3),
                   lambda b: b.get_dofs(lambda x: x[1] == 0),
                   body_force=[0., -1.], kinematics="finite")
    assert res.history[-1].load_factor == 1.


@pytest.mark.parametrize("mesh", [MeshQuad().refined(1),
                                  MeshQuad().refined(1).to_meshtri()])
def test_the_grid_basis_is_the_one_element_cell_basis(mesh):
    """Its DOF locations, and its fields when asked for, are those of
    scikit-fem's basis of element 0 at its centroid, to the bit."""
    elem = ElementVector(mesh.elem())
    X, W = get_quadrature(mesh.refdom, 0)
    expected = Basis(mesh, elem, elements=np.array([0]), quadrature=(
        X @ W[:, None] / W.sum(), np.array([W.sum()])))
    grid = GridBasis(mesh, elem)
    assert np.array_equal(grid.doflocs, expected.doflocs)
    assert np.array_equal(grid.dx, expected.dx)
    for (a,), (b,) in zip(grid.basis, expected.basis, strict=True):
        assert np.array_equal(a, b) and np.array_equal(a.grad, b.grad)
