"""Implicit MPM and GIMP with finite deformation: updated Lagrangian load
steps, each solved by Newton-Raphson with the consistent tangent, with
load-step cut-back.

Per load step: locate the points and build the step's point operator at
their start-of-step positions (standard MPM: the vectorised twin of
scikit-fem ``asm`` on a material-point basis; GIMP: averaged weights over
the points' domains), map the external forces, then iterate: increment of
the deformation gradient ``dF = I + grad(du)``, Hencky stress update (a
return map for plasticity), internal force, out-of-balance force, exact
tangent, solve.  At convergence the points move, ``F``, volumes
(``det(F) volume0``) and, for cpGIMP, domains are updated.  A step whose
Newton loop fails or that inverts a point (``det F <= 0``) is retried with
a stabilised tangent (zero-energy modes of weakly supported nodes), then
bisected and retried, down to ``2**-max_cutbacks`` of a load step; then the
error carries the last converged state.  The loop itself is
:mod:`skfem_mpm.solve.core`.

"""
from typing import Optional

from skfem.element import Element
from skfem.mesh import Mesh

from ..quadrature.points import MaterialPoints
from .core import STABILISATION, simulate
from .options import Options, translate_aliases
from .results import Result

__all__ = ["solve_finite", "STABILISATION"]


def solve_finite(mesh: Mesh, elem: Element, points: MaterialPoints, material,
                 supports, body_force=None, nsteps: int = 1,
                 method: str = "mpm", *, loads=(),
                 options: Optional[Options] = None, **aliases) -> Result:
    """Finite-deformation implicit MPM or GIMP (updated Lagrangian,
    Hencky elasticity, optional von Mises plasticity): the finite case of
    :func:`~skfem_mpm.simulate`.

    Parameters
    ----------
    mesh, elem, points, supports
        As in :func:`~skfem_mpm.solve_mpm`.
    material
        :class:`~skfem_mpm.LinearElastic` (Hencky hyperelasticity) or
        :class:`~skfem_mpm.VonMises`.
    body_force
        Body force per unit *initial* volume at full load (``rho0 g``), so
        the weight is conserved exactly; ``None``: none.
    loads, options
        As in :func:`~skfem_mpm.simulate` (the grid is reset every step, so
        prescribed displacements are increments).
    nsteps
        Load steps (loads ramped linearly); a step may be cut back.
    method
        ``"mpm"``, ``"ugimp"``, ``"cpgimp"`` (GIMP needs a tensor grid
        and point domains, set by :func:`~skfem_mpm.seed_points`),
        ``"bspline"`` (a uniform tensor grid), or
        ``"fem"`` (total Lagrangian finite elements with the points as
        quadrature).
    **aliases
        Deprecated keyword arguments, as in :func:`~skfem_mpm.simulate`.

    Returns
    -------
    Result
        ``history[k].newton_residuals`` holds every iteration's residual.

    Raises
    ------
    NewtonDivergenceError, InversionError
        When a step fails at the smallest increment; ``err.state`` is the
        last converged state, ``err.load_factor`` its load factor.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad, ElementQuad1
    >>> from skfem_mpm import LinearElastic, seed_points, solve_finite
    >>> mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 3, 7))
    >>> pts = seed_points(mesh, 2, region=lambda x: x[1] < 2)
    >>> res = solve_finite(mesh, ElementQuad1(), pts, LinearElastic(1e3, .3),
    ...                    lambda b: b.get_dofs(lambda x: x[1] == 0),
    ...                    body_force=[0., -100.], nsteps=2, method="cpgimp")
    >>> [len(r.newton_residuals) > 1 for r in res.history]
    [True, True]
    >>> bool(res.history[-1].residual < 1e-9)
    True

    """
    options, body_force, loads = translate_aliases(
        "solve_finite", options, body_force, loads, aliases)
    return simulate(mesh, elem, points, material, supports, body_force,
                    loads, nsteps, method=method, kinematics="finite",
                    options=options)
