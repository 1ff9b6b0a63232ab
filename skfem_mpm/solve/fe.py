"""The same problem solved by plain finite elements, for comparison.

Gauss-point quadrature, no position update, one linear solve: what MPM
reduces to with one load step and points at the Gauss points.

"""
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np
from numpy import ndarray
from skfem import Basis
from skfem.element import Element
from skfem.mesh import Mesh

from ..mechanics.forms import as_body_force, assemble_body_force, full_tensor
from ..methods.assembly import assembled_in_pattern
from .linear import free_dofs, solve_active, support_dofs
from ..mechanics.materials import LinearElastic
from .core import vector_element

__all__ = ["FEResult", "solve_fe"]


@dataclass
class FEResult:
    """Finite element solution.

    Attributes
    ----------
    basis
        The scikit-fem ``Basis`` (Gauss quadrature).
    u
        Grid displacements (zero on inactive DOFs).
    stress
        Stress at the Gauss points, shape (3, 3, nelems, nqp).
    x
        Gauss point coordinates, shape (dim, nelems, nqp).

    """
    basis: Basis
    u: ndarray
    stress: ndarray
    x: ndarray


def solve_fe(mesh: Mesh, elem: Element, material: LinearElastic, supports,
             body_force=None, intorder: Optional[int] = None,
             elements: Optional[ndarray] = None,
             solver: Optional[Callable] = None) -> FEResult:
    """Solve linear elasticity by finite elements on ``mesh``.

    Parameters
    ----------
    mesh, elem, material, supports, body_force, solver
        As in :func:`~skfem_mpm.solve_mpm`.
    intorder
        Quadrature order (scikit-fem's default when ``None``).
    elements
        Elements occupied by the body (default: all).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshLine, ElementLineP1
    >>> from skfem_mpm import LinearElastic, solve_fe
    >>> fe = solve_fe(MeshLine(np.linspace(0., 50., 11)), ElementLineP1(),
    ...               LinearElastic(1e6, 0.), lambda b: b.get_dofs(
    ...                   lambda x: x[0] == 0), body_force=[-800.])
    >>> round(float(fe.u.min()), 6)   # nodal values are exact in 1D
    -1.0

    """
    elem = vector_element(elem)
    if elements is not None:
        elements = np.asarray(elements, dtype=np.int64)
    basis = Basis(mesh, elem, intorder=intorder, elements=elements)
    D = support_dofs(supports, basis)
    b = as_body_force(body_force, mesh.dim())
    f = np.zeros(basis.N) if b is None else assemble_body_force(basis, b)
    K = assembled_in_pattern(material.stiffness_form(), basis)
    free = free_dofs(np.unique(basis.element_dofs), D)
    u = solve_active(K, f, free, solver=solver, doflocs=basis.doflocs)
    grad = basis.interpolate(u).grad
    strain = full_tensor(.5 * (grad + grad.transpose(1, 0, 2, 3)))
    return FEResult(basis, u, material.stress(strain),
                    np.asarray(basis.global_coordinates()))
