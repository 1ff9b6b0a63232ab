"""Ghost-penalty stabilisation of partially filled cells (small cuts).

A body whose boundary leaves a grid node supported only by a sliver of
material makes the stiffness badly conditioned (a node's stiffness scales
with the sliver's volume).  The ghost penalty adds, on every interior face
between two active cells of which at least one is partially filled,

    gamma * mu * h * int_F [[dn u]] . [[dn v]] ds,

the jump of the normal derivative across the face, scaled to the material
(shear modulus mu of the stiffer neighbour) and the cell size h.  It
vanishes for linear fields, so patch tests still pass, and it ties a
sliver's nodes to their neighbours: the condition number stays bounded
whatever the sliver's size.  Facet terms are assembled by scikit-fem on
``InteriorFacetBasis`` pairs.

"""
from typing import Optional

import numpy as np
from numpy import ndarray
from skfem import BilinearForm, InteriorFacetBasis, asm
from skfem.helpers import dot, grad, mul

__all__ = ["ghost_penalty", "cut_cells", "GhostStabilisation"]


@BilinearForm
def normal_derivative_jump(u, v, w):
    """``[[dn u]] . [[dn v]]`` for one pair of sides, weighted."""
    return w.weight * dot(mul(grad(u), w.n), mul(grad(v), w.n))


def cut_cells(fill: ndarray, tol: float = 1e-9) -> ndarray:
    """Active cells whose points fill less than the cell (0 < fill < 1)."""
    return (fill > 0) & (fill < 1 - tol)


def ghost_penalty(mesh, elem, fill: ndarray, mu: ndarray,
                  gamma: float) -> Optional[object]:
    """The ghost-penalty matrix, or ``None`` when no face needs one.

    Parameters
    ----------
    mesh, elem
        The grid and its vector element.
    fill
        Volume of points over cell volume, per element (0 for empty cells).
    mu
        Shear modulus per element (of the points in it).
    gamma
        Penalty factor (dimensionless, e.g. 0.1).

    """
    left, right = mesh.f2t
    interior = right >= 0
    active = fill > 0
    cut = cut_cells(fill)
    facets = np.flatnonzero(interior & active[left] & active[np.maximum(
        right, 0)] & (cut[left] | cut[np.maximum(right, 0)]))
    if facets.size == 0:
        return None
    sides = [InteriorFacetBasis(mesh, elem, facets=facets, side=i)
             for i in (0, 1)]
    h = np.abs(sides[0].mesh_parameters())           # cell size per facet
    stiffer = np.maximum(mu[left[facets]], mu[right[facets]])
    weight = gamma * stiffer[:, None] * h
    return sum((-1) ** (i + j) * asm(normal_derivative_jump, sides[j],
                                     sides[i], weight=weight)
               for i in (0, 1) for j in (0, 1))


class GhostStabilisation:
    """The ghost penalty as a piece of the load step: ``matrix(op,
    points)`` is the step's penalty ``G`` (or ``None``), which the core adds
    to the tangent and, times the displacement increment, to the internal
    force, in any kinematics (``G`` is constant over a step: Newton keeps
    its rate).

    Parameters
    ----------
    mesh, elem
        The grid and its vector element.
    gamma
        Penalty factor (dimensionless, e.g. 0.1); positive.
    material
        The points' material(s): ``mu`` per point scales the penalty.

    """

    def __init__(self, mesh, elem, gamma: float, material):
        from skfem import Basis
        self.mesh, self.elem, self.gamma = mesh, elem, gamma
        self.material = material
        self.cell_volume = Basis(mesh, elem.elem if hasattr(elem, "elem")
                                 else elem).dx.sum(axis=1)

    def matrix(self, op, points):
        cells = op.point_elements
        n = self.mesh.nelements
        filled = np.bincount(cells, points.volume, n)
        mu = np.bincount(cells, points.volume * np.broadcast_to(
            self.material.mu, (points.n,)), n) / np.maximum(
                filled, np.finfo(float).tiny)
        return ghost_penalty(self.mesh, self.elem, filled / self.cell_volume,
                             mu, self.gamma)
