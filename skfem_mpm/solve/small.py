"""The seed's Algorithm 2.1: implicit quasi-static MPM in small strain.

The solve of each step is the seed's (2.22) with the out-of-balance force
as right-hand side, ``K du = f_ext(n+1) - f_int(sigma_n)``, the internal
force being assembled at the points' current positions (in the first step,
from zero initial stress, this is ``K du = f_ext``, the finite element
solve); ``rhs="increment"`` solves with the load increment instead, the
seed's literal scheme.  The loop itself is :mod:`skfem_mpm.solve.core`.

"""
from typing import Optional

from skfem.element import Element
from skfem.mesh import Mesh

from ..quadrature.points import MaterialPoints
from .core import simulate
from .options import Options, translate_aliases
from .results import Result

__all__ = ["solve_mpm"]


def solve_mpm(mesh: Mesh, elem: Element, points: MaterialPoints,
              material, supports, body_force=None, nsteps: int = 1, *,
              loads=(), update_positions: bool = True,
              options: Optional[Options] = None, **aliases) -> Result:
    """Run the implicit MPM of seed Algorithm 2.1 (small strain): the
    small-strain standard-MPM case of :func:`~skfem_mpm.simulate`.

    Material points are located, the step's stiffness is assembled from
    them, one linear solve per load step for an elastic body (Newton for a
    plastic one), then the points move.

    Parameters
    ----------
    mesh
        Background grid, any scikit-fem mesh.
    elem
        scikit-fem element (``ElementQuad1()`` or its ``ElementVector``).
    points
        Initial material points; copied, not modified.
    material
        :class:`~skfem_mpm.LinearElastic` (one linear solve per step),
        :class:`~skfem_mpm.VonMises` or any model of the protocol of
        :mod:`skfem_mpm.mechanics.materials` (Newton-Raphson), or a list
        with one per body.
    supports
        Fixed (zero) grid DOFs: DOF indices, a ``DofsView`` or a callable
        taking the grid's vector ``Basis`` (its DOFs and facets cover the
        whole grid), e.g.
        ``lambda b: b.get_dofs(lambda x: x[0] == 0)``.
    body_force
        Body force per unit volume at full load, shape (dim,) or one row
        per body (bodies, dim); ``None``: no body force is assembled.
    loads
        As in :func:`~skfem_mpm.simulate`: tractions, pressures, grid
        loads, prescribed motion, rigid bodies, grid terms.
    nsteps
        Number of load steps; loads are ramped linearly.
    update_positions
        Move the points at the end of each step (MPM).  ``False`` keeps
        them fixed: a finite element analysis with the points as quadrature
        (``method="fem"``).
    options
        :class:`~skfem_mpm.Options` as in :func:`~skfem_mpm.simulate`
        (``NewtonOptions(rhs="increment")``: the seed's literal
        load-increment right-hand side; the line search acts in the Newton
        iterations of plastic bodies only, as ``newton``).
    **aliases
        Deprecated keyword arguments, as in :func:`~skfem_mpm.simulate`.

    Returns
    -------
    Result

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshLine, ElementLineP1
    >>> from skfem_mpm import seed_points, solve_mpm, LinearElastic
    >>> mesh = MeshLine(np.linspace(0., 50., 11))
    >>> res = solve_mpm(mesh, ElementLineP1(), seed_points(mesh, 2),
    ...                 LinearElastic(1e6, 0.), lambda b: b.get_dofs(lambda x: x[0] == 0),
    ...                 body_force=[-800.], nsteps=1)
    >>> round(float(res.points.displacement[0].min()), 4)
    -0.9975

    """
    options, body_force, loads = translate_aliases(
        "solve_mpm", options, body_force, loads, aliases)
    return simulate(mesh, elem, points, material, supports, body_force,
                    loads, nsteps, method="mpm" if update_positions else "fem",
                    kinematics="small", options=options)
