"""Implicit quasi-static load stepping, small strain: seed Algorithm 2.1.

Each load step reads like the algorithm: locate the points, activate the
elements and DOFs that hold them, map external forces, assemble the
stiffness from the points, solve, update strains and stresses at the points,
check equilibrium, move the points.

The solve of each step is the seed's (2.22) with the out-of-balance force
as right-hand side, ``K du = f_ext(n+1) - f_int(sigma_n)``, the internal
force being assembled at the points' current positions.  In the first step
(zero initial stress) this is ``K du = f_ext``, the finite element solve.

"""
import logging
import time
from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np
from numpy import ndarray
from skfem import Basis
from skfem.assembly import Dofs
from skfem.quadrature import get_quadrature
from skfem.element import Element, ElementVector
from skfem.mesh import Mesh

from ..quadrature.basis import MaterialPointBasis
from ..errors import InvalidInputError, PointsOutsideGridError, \
    SingularSystemError
from ..mechanics.forms import as_body_force, full_tensor, in_plane
from .linear import (check_rigid_body_modes, free_dofs, solve_active,
                       support_dofs)
from ..quadrature.locate import Locator, point_locator
from ..mechanics.materials import LinearElastic, at_points, elastic_tensor
from ..methods.assembly import ElementPattern
from ..methods.operators import PointOperator
from ..stabilisation.ghost import ghost_penalty
from ..stabilisation.volumetric import MeanDilatation
from ..quadrature.points import MaterialPoints
from .backends import get_solver

logger = logging.getLogger(__name__)

__all__ = ["solve_mpm", "Result", "StepRecord"]

PHASES = ("locate", "assemble", "solve", "update", "check")


@dataclass
class StepRecord:
    """What one load step did.

    Attributes
    ----------
    step, load_factor
        Step number (from 1) and the load factor reached (``step/nsteps``).
    residual
        Equilibrium check: ``|f_ext - f_int|`` over the free DOFs after the
        stress update, relative to ``|f_ext|``.
    n_active_elements, n_free_dofs
        Size of the active grid.
    timings
        Seconds per phase: locate, assemble, solve, update, check.
    u
        Grid displacement increment of the step (``None`` unless
        snapshots are kept).
    x, displacement, stress
        Point positions (after the update), accumulated displacements and
        stresses at the end of the step (``None`` unless kept).
    newton_residuals
        Finite deformation: the residual of every Newton iteration.
    n_yielded
        Finite deformation: points on the yield surface.
    elements
        The active elements of the step (kept with the snapshots).

    """
    step: int
    load_factor: float
    residual: float
    n_active_elements: int
    n_free_dofs: int
    timings: dict
    u: Optional[ndarray] = None
    x: Optional[ndarray] = None
    displacement: Optional[ndarray] = None
    stress: Optional[ndarray] = None
    newton_residuals: Optional[List[float]] = None
    n_yielded: int = 0
    elements: Optional[ndarray] = None


@dataclass
class Result:
    """The outcome of :func:`solve_mpm`.

    Attributes
    ----------
    points
        Final material-point state.
    history
        One :class:`StepRecord` per load step.
    basis
        The material-point basis (scalar element) of the last step, before
        the final position update; vector DOF ``dim * k + a`` of the grid
        solution is component a at its DOF k.
    counters
        How often each kind of work was done: ``locate`` (point location),
        ``body_force`` (body-force assemblies), ``linear_solves``,
        ``return_maps`` (stress updates with a return map),
        ``newton_iterations``, ``stabilised_solves`` (Newton solves that
        needed the stabilised tangent: zero-energy modes).

    """
    points: MaterialPoints
    history: List[StepRecord] = field(default_factory=list)
    basis: Optional[MaterialPointBasis] = None
    counters: dict = field(default_factory=lambda: dict.fromkeys(
        ("locate", "body_force", "linear_solves", "return_maps",
         "newton_iterations", "stabilised_solves"), 0))

    def timings(self) -> dict:
        """Total seconds per phase over all steps."""
        return {p: sum(r.timings[p] for r in self.history) for p in PHASES}


def grid_parts(mesh: Mesh, elem: Element):
    """What a run keeps of the grid: the scalar element, the vector grid
    basis (supports, DOF locations), the scalar ``Dofs`` for the
    material-point bases and the vector stiffness pattern."""
    scalar = elem.elem if isinstance(elem, ElementVector) else elem
    # the grid basis serves DOFs, DOF locations and facets (all elements);
    # the basis functions it evaluates are never used, so it evaluates them
    # at one point (the centroid) of one element
    X, W = get_quadrature(mesh.refdom, 0)
    grid = Basis(mesh, vector_element(elem), elements=np.array([0]),
                 quadrature=(X @ W[:, None] / W.sum(), np.array([W.sum()])))
    return (scalar, grid, Dofs(mesh, scalar),
            ElementPattern(grid.dofs.element_dofs, grid.N))


def vector_element(elem: Element) -> Element:
    """``elem`` as a vector element (displacements have dim components)."""
    return elem if isinstance(elem, ElementVector) else ElementVector(elem)


def check_run_input(mesh: Mesh, points: MaterialPoints, nsteps: int):
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` for a step count
    that is not a positive integer or points of another dimension."""
    if int(nsteps) != nsteps or nsteps < 1:
        raise InvalidInputError(
            "nsteps must be a positive integer, got {}".format(nsteps))
    if points.dim != mesh.dim():
        raise InvalidInputError(
            "points are {}D but the mesh is {}D".format(points.dim, mesh.dim()))


def point_loads(points: MaterialPoints, gravity: Optional[ndarray],
                counters: dict) -> Optional[ndarray]:
    """Point forces (2.18) plus the body force on the point volumes (2.19)
    at full load, (dim, n), or ``None`` when the scene has neither; the body
    force only when the scene has gravity."""
    load = points.force if points.force.any() else None
    if gravity is not None:
        counters["body_force"] += 1
        weight = gravity[:, None] * points.volume0
        load = weight if load is None else load + weight
    return load


def solve_mpm(mesh: Mesh, elem: Element, points: MaterialPoints,
              material: LinearElastic, supports, body_force=None,
              nsteps: int = 1, locator: Optional[Locator] = None,
              solver: Optional[Callable] = None, keep_snapshots: bool = True,
              update_positions: bool = True, first_step: int = 1,
              callback: Optional[Callable] = None,
              prescribed: Optional[Callable] = None,
              antilocking: bool = False, ghost: float = 0.) -> Result:
    """Run the implicit MPM of seed Algorithm 2.1 (small strain).

    Parameters
    ----------
    mesh
        Background grid, any scikit-fem mesh.
    elem
        scikit-fem element (``ElementQuad1()`` or its ``ElementVector``).
    points
        Initial material points; copied, not modified.
    material
        :class:`~skfem_mpm.mechanics.materials.LinearElastic`.
    supports
        Fixed (zero) grid DOFs: DOF indices, a ``DofsView`` or a callable
        taking the grid's vector ``Basis`` (its DOFs and facets cover the
        whole grid), e.g.
        ``lambda b: b.get_dofs(lambda x: x[0] == 0)``.
    body_force
        Body force per unit volume at full load, shape (dim,); ``None``: no
        body force is assembled.
    nsteps
        Number of load steps; loads are ramped linearly.
    locator
        Optional :func:`~skfem_mpm.point_locator` of ``mesh`` to reuse.
    solver
        Linear solver: a scikit-fem solver ``f(A, b) -> x`` or a name from
        :mod:`skfem_mpm.solve.backends` (``"scipy"``, ``"pypardiso"``,
        ``"pyamg"``, ``"auto"``); default scipy's SuperLU.
    keep_snapshots
        Keep per-step grid displacements, point positions, displacements
        and stresses in the history.
    update_positions
        Move the points at the end of each step (MPM).  ``False`` keeps
        them fixed: a finite element analysis with the points as quadrature.
    material
        One material, or a list with one per body (``points.body``).
    first_step
        Resume: ``points`` is the state after step ``first_step - 1``.
    callback
        Called as ``callback(record, points)`` after every step.
    prescribed
        Optional ``prescribed(grid_basis, f_old, f_new) -> (dofs,
        increments)``: grid displacement increments imposed over a step
        (as in :func:`~skfem_mpm.solve_finite`).
    antilocking
        Mean dilatation on the points (:mod:`skfem_mpm.stabilisation.volumetric`, a
        B-bar method) against volumetric locking as nu approaches 0.5.
    ghost
        Ghost-penalty factor for partially filled cells
        (:mod:`skfem_mpm.stabilisation.ghost`, e.g. 0.1); 0: none.

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
    check_run_input(mesh, points, nsteps)
    solver = get_solver(solver)      # one instance: it may keep state
    gravity = as_body_force(body_force, mesh.dim())
    scalar, grid, scalar_dofs, pattern = grid_parts(mesh, elem)
    pattern.structure()                  # set-up, shared by every step
    D = support_dofs(supports, grid)
    dim = mesh.dim()
    cell_volume = Basis(mesh, scalar).dx.sum(axis=1) if ghost else None
    locate = point_locator(mesh) if locator is None else locator
    points = points.copy()
    material = at_points(material, points)
    result = Result(points=points)
    counters = result.counters
    location = None
    for step in range(int(first_step), int(nsteps) + 1):
        factor = step / nsteps
        t = dict.fromkeys(PHASES, 0.)
        tic = time.perf_counter()
        if location is None or update_positions:
            counters["locate"] += 1
            try:
                location = locate(points.x)
            except PointsOutsideGridError as err:
                err.step, err.state = step, points
                raise
        t["locate"] = time.perf_counter() - tic

        tic = time.perf_counter()
        basis = MaterialPointBasis(mesh, scalar, points, location,
                                   dofs=scalar_dofs)
        op = PointOperator(basis, pattern)
        fixed, x = D, None
        if prescribed is not None:
            dofs, values = prescribed(grid, (step - 1) / nsteps, factor)
            x = np.zeros(op.N)
            x[np.asarray(dofs, dtype=np.int64)] = values
            fixed = np.union1d(D, dofs)
        check_rigid_body_modes(op.adjacency(), grid.doflocs[:, ::dim],
                               op.active_dofs, fixed, dim, step)
        free = free_dofs(op.active_dofs, fixed)
        load = point_loads(points, gravity, counters)
        f_ext = np.zeros(op.N) if load is None else \
            op.point_force(factor * load)
        f_int = op.force(in_plane(points.stress, dim), points.volume) \
            if points.stress.any() else np.zeros(op.N)
        if antilocking:
            dilatation = MeanDilatation(op, material.lam, points.volume)
            K = op.stiffness(elastic_tensor(material, points.n, dim,
                                            lam=0.), points.volume) \
                + dilatation.stiffness()
        else:
            K = op.stiffness(elastic_tensor(material, points.n, dim),
                             points.volume)
        G = None
        if ghost:
            fill = np.bincount(location[0], points.volume,
                               mesh.nelements) / cell_volume
            mu = np.bincount(location[0], points.volume * np.broadcast_to(
                material.mu, (points.n,)), mesh.nelements) \
                / np.maximum(fill * cell_volume, np.finfo(float).tiny)
            G = ghost_penalty(mesh, grid.elem, fill, mu, ghost)
            if G is not None:
                K = K + G
        t["assemble"] = time.perf_counter() - tic

        tic = time.perf_counter()
        try:
            du = solve_active(K, f_ext - f_int, free, solver=solver, x=x,
                              doflocs=grid.doflocs)
            counters["linear_solves"] += 1
        except SingularSystemError as err:
            raise SingularSystemError("step {}: {}".format(step, err)) from err
        t["solve"] = time.perf_counter() - tic

        tic = time.perf_counter()
        grad = op.gradients(du)
        deps = full_tensor(.5 * (grad + grad.transpose(1, 0, 2)))
        points.strain += deps
        if antilocking:
            points.stress += 2 * material.mu * deps
            for i in range(3):
                points.stress[i, i] += dilatation.lam_at_points() \
                    * dilatation.theta(du)
        else:
            points.stress += material.stress(deps)
        t["update"] = time.perf_counter() - tic

        tic = time.perf_counter()
        r = f_ext - op.force(in_plane(points.stress, dim), points.volume)
        if G is not None:                     # the ghost forces balance too
            r -= G @ du
        r = r[free]
        residual = np.linalg.norm(r) / max(np.linalg.norm(f_ext[free]),
                                          np.finfo(float).tiny)
        t["check"] = time.perf_counter() - tic

        tic = time.perf_counter()
        dup = op.values(du)
        points.displacement += dup
        if update_positions:
            points.x += dup
        t["update"] += time.perf_counter() - tic

        record = StepRecord(step, factor, residual, basis.nelems, free.size, t)
        if keep_snapshots:
            record.elements = basis.tind
            record.u = du
            record.x = points.x.copy()
            record.displacement = points.displacement.copy()
            record.stress = points.stress.copy()
        result.history.append(record)
        result.basis = basis
        if callback is not None:
            callback(record, points)
        logger.info("step %d/%d: %d active elements, %d free DOFs, "
                    "residual %.2e, %.3f s", step, nsteps, basis.nelems,
                    free.size, residual, sum(t.values()))
    return result
