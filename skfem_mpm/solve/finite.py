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
error carries the last converged state.

"""
import copy
import logging
import time
from typing import Callable, Optional

import numpy as np
from numpy import ndarray
from skfem.element import Element
from skfem.mesh import Mesh

from ..quadrature.basis import MaterialPointBasis
from ..errors import (InvalidInputError, InversionError, NewtonDivergenceError,
                     PointsOutsideGridError, SingularSystemError)
from ..mechanics.forms import as_body_force
from ..methods.gimp import gimp_operators, stretched_domains
from ..mechanics.hencky import (hencky_update, inverse_and_det, pull_back,
                         spatial_tangent)
from .linear import (check_rigid_body_modes, free_dofs, solve_active,
                       support_dofs)
from ..quadrature.locate import Locator, point_locator
from ..mechanics.materials import PointMaterials, at_points, is_plastic
from ..methods.operators import PointOperator
from ..quadrature.points import MaterialPoints
from .backends import get_solver
from .small import (PHASES, Result, StepRecord, check_run_input,
                     grid_parts, point_loads)

logger = logging.getLogger(__name__)

__all__ = ["solve_finite", "METHODS"]

METHODS = ("mpm", "ugimp", "cpgimp")
STABILISATION = 1e-7
POINT_BLOCK = 2048     # points per block of the constitutive update


def point_blocks(n: int, size: int = POINT_BLOCK):
    """Slices covering n points in blocks of ``size``."""
    return [slice(s, min(s + size, n)) for s in range(0, n, size)]


def material_block(material, block: slice):
    """The material(s) of a block of points."""
    if isinstance(material, PointMaterials):
        return material.take(block)
    return material


def deformation_increment(grad_du: ndarray) -> ndarray:
    """``dF = I + grad(du)`` as (3, 3, n) from in-plane (dim, dim, n)."""
    dim, n = grad_du.shape[0], grad_du.shape[-1]
    dF = np.repeat(np.eye(3)[:, :, None], n, axis=2)
    dF[:dim, :dim] += grad_du
    return dF


class _Step:
    """One load step from a converged state: operator, loads, Newton."""

    def __init__(self, ctx, points: MaterialPoints, f_old: float,
                 f_new: float, step: int, stabilise: bool = False):
        self.ctx, self.points, self.step = ctx, points, step
        self.f_old, self.f_new = f_old, f_new
        self.stabilise = stabilise
        self.t = dict.fromkeys(PHASES, 0.)
        self.buffers = None

    def operator(self):
        ctx, pts = self.ctx, self.points
        tic = time.perf_counter()
        ctx.counters["locate"] += 1
        try:
            location = ctx.locate(pts.x)
        except PointsOutsideGridError as err:
            err.step, err.state = self.step, pts
            raise
        self.t["locate"] += time.perf_counter() - tic
        tic = time.perf_counter()
        if ctx.method == "mpm":
            op = PointOperator(MaterialPointBasis(
                ctx.mesh, ctx.scalar, pts, location, dofs=ctx.scalar_dofs),
                ctx.pattern)
        else:
            op = ctx.gimp(pts.x, pts.domain)
        self.t["assemble"] += time.perf_counter() - tic
        return op

    def constitutive(self, op, du: ndarray):
        """Stress state of the displacement increment du, block by block
        of points (temporaries stay cache-sized whatever the run's size)."""
        tic = time.perf_counter()
        ctx, be = self.ctx, self.points.be
        dF = deformation_increment(op.gradients(du))
        dF_inv, detdF = inverse_and_det(dF, ctx.dim)
        bad = np.flatnonzero(~(detdF > 0))
        if bad.size:
            raise InversionError(
                "step {}: {} point(s) invert (det dF <= 0), first {} at x = {}"
                .format(self.step, bad.size, bad[:5].tolist(),
                        self.points.x[:, bad[0]].tolist()))
        n, dim = dF.shape[-1], ctx.dim
        if self.buffers is None:         # reused by every Newton iteration
            self.buffers = (np.empty_like(dF), np.empty_like(dF),
                            np.empty((dim,) * 4 + (n,)),
                            np.empty(n, dtype=bool))
        b_tr, tau, dtau_db, yielded = self.buffers
        for block in point_blocks(n):
            b_tr[..., block] = np.einsum("abp,bcp,dcp->adp", dF[..., block],
                                         be[..., block], dF[..., block])
            tau[..., block], _, _, dtau_db[..., block], yielded[block] = \
                hencky_update(material_block(ctx.material, block),
                              b_tr[..., block], dim)
        self.ctx.counters["return_maps"] += self.ctx.plastic
        self.t["update"] += time.perf_counter() - tic
        return dF, dF_inv, tau, dtau_db, yielded, b_tr

    def elastic_state(self, b_tr: ndarray):
        """Elastic left Cauchy-Green tensor and logarithmic strain of the
        converged trial state (not kept during the iterations: memory)."""
        b_e, strain = np.empty_like(b_tr), np.empty_like(b_tr)
        for block in point_blocks(b_tr.shape[-1]):
            _, b_e[..., block], strain[..., block], _, _ = hencky_update(
                material_block(self.ctx.material, block), b_tr[..., block],
                self.ctx.dim)
        self.ctx.counters["return_maps"] += self.ctx.plastic
        return b_e, strain

    def tangent(self, dtau_db, b_tr, tau, dF_inv) -> ndarray:
        """Consistent tangent pulled back to the start of the step,
        (dim, dim, dim, dim, n), block by block of points, written over
        ``dtau_db`` (not needed after)."""
        for block in point_blocks(dtau_db.shape[-1]):
            A = spatial_tangent(dtau_db[..., block], b_tr[..., block],
                                tau[..., block])
            dtau_db[..., block] = pull_back(tau[..., block], A,
                                            dF_inv[..., block],
                                            self.ctx.dim)[1]
        return dtau_db

    def run(self):
        ctx, pts = self.ctx, self.points
        op = self.operator()
        tic = time.perf_counter()
        D, du = ctx.D, np.zeros(op.N)
        if ctx.prescribed is not None:
            dofs, values = ctx.prescribed(ctx.grid, self.f_old, self.f_new)
            dofs = np.asarray(dofs, dtype=np.int64)
            du[dofs] = values
            D = np.union1d(D, dofs)
        check_rigid_body_modes(op.adjacency(), ctx.grid.doflocs[:, ::ctx.dim],
                               op.active_dofs, D, ctx.dim, self.step)
        free = free_dofs(op.active_dofs, D)
        f_ext = np.zeros(op.N)
        load = point_loads(pts, ctx.gravity, ctx.counters)
        if load is not None:
            f_ext = op.point_force(self.f_new * load)
        self.t["assemble"] += time.perf_counter() - tic
        residuals = []
        for it in range(ctx.max_iter + 1):
            dF, dF_inv, tau, dtau_db, yielded, b_tr = \
                self.constitutive(op, du)
            tic = time.perf_counter()
            P = np.einsum("abp,ebp->aep", tau[:ctx.dim, :ctx.dim],
                          dF_inv[:ctx.dim, :ctx.dim])
            f_int = op.force(P, pts.volume0)
            r = f_ext - f_int
            scale = np.linalg.norm(f_ext)
            if scale == 0.:                  # driven by prescribed motion
                scale = max(np.linalg.norm(f_int), np.finfo(float).tiny)
            residuals.append(float(np.linalg.norm(r[free]) / scale))
            self.t["check"] += time.perf_counter() - tic
            logger.debug("step %d iteration %d: residual %.3e", self.step,
                         it, residuals[-1])
            if residuals[-1] <= ctx.tol or free.size == 0:
                break
            if it == ctx.max_iter or not np.isfinite(residuals[-1]):
                raise NewtonDivergenceError(
                    "step {}: Newton-Raphson did not converge in {} "
                    "iterations (residuals {})".format(
                        self.step, ctx.max_iter,
                        ", ".join("{:.1e}".format(r) for r in residuals)))
            tic = time.perf_counter()
            K = op.stiffness(self.tangent(dtau_db, b_tr, tau, dF_inv),
                             pts.volume0)
            self.t["assemble"] += time.perf_counter() - tic
            tic = time.perf_counter()
            ctx.counters["newton_iterations"] += 1
            du = du + self.solve(K, r, free)
            self.t["solve"] += time.perf_counter() - tic
        return self.finish(op, du, dF, tau, b_tr, yielded, residuals, free)

    def solve(self, K, r: ndarray, free: ndarray) -> ndarray:
        """Newton's increment with the exact tangent; with a stabilised one
        where points leave zero-energy modes on weakly supported nodes (a
        cell entered by one point): when the step is retried so
        (``stabilise``), or when the exact tangent is refused as singular.
        Those modes carry no residual, so the stabilisation,
        ``STABILISATION`` times the diagonal added to the tangent only, does
        not change the converged state; it is used only when needed because
        it slows Newton to a linear rate of about ``STABILISATION`` times the
        tangent's condition number."""
        ctx = self.ctx
        if not self.stabilise:
            ctx.counters["linear_solves"] += 1
            try:
                return solve_active(K, r, free, solver=ctx.solver,
                                    doflocs=ctx.grid.doflocs)
            except SingularSystemError as err:
                logger.warning("step %d: %s; solving again with the tangent "
                               "stabilised by %.0e of its diagonal",
                               self.step, err, STABILISATION)
        K.setdiag(K.diagonal() * (1. + STABILISATION))       # in place
        ctx.counters["linear_solves"] += 1
        ctx.counters["stabilised_solves"] += 1
        try:
            return solve_active(K, r, free, solver=ctx.solver,
                                doflocs=ctx.grid.doflocs)
        except SingularSystemError as err:
            raise SingularSystemError("step {}: {}".format(self.step,
                                                           err)) from err

    def finish(self, op, du, dF, tau, b_tr, yielded, residuals, free):
        ctx, old = self.ctx, self.points
        tic = time.perf_counter()
        # the finite-deformation solver replaces a state's arrays and never
        # writes into them, so a new state shares the unchanged ones
        new = copy.copy(old)
        new.F = np.einsum("abp,bcp->acp", dF, old.F)
        J = inverse_and_det(new.F, ctx.dim)[1]
        if not (J > 0).all():
            raise InversionError("step {}: det F <= 0 at {} point(s)".format(
                self.step, int((J <= 0).sum())))
        new.be, new.strain = self.elastic_state(b_tr)
        new.stress = tau / J
        new.volume = J * old.volume0
        dx = op.values(du)
        new.x = old.x + dx
        new.displacement = old.displacement + dx
        if ctx.method == "cpgimp":
            new.domain = stretched_domains(ctx.domain0, new.F)
        self.t["update"] += time.perf_counter() - tic
        record = StepRecord(self.step, self.f_new, residuals[-1], op.nelems,
                            free.size, self.t)
        record.newton_residuals = residuals
        record.n_yielded = int(yielded.sum())
        if ctx.keep_snapshots:
            record.elements = op.elements
            record.u, record.x = du, new.x.copy()
            record.displacement = new.displacement.copy()
            record.stress = new.stress.copy()
        return new, record


def _attempt(ctx, points: MaterialPoints, f_old: float, f_new: float,
             step: int):
    """A load step with the exact tangent, retried once with the stabilised
    tangent if Newton fails (zero-energy modes not refused as singular can
    still derail it)."""
    try:
        return _Step(ctx, points, f_old, f_new, step).run()
    except (NewtonDivergenceError, InversionError) as err:
        logger.warning("%s: retrying the step with the tangent stabilised "
                       "by %.0e of its diagonal", err, STABILISATION)
    return _Step(ctx, points, f_old, f_new, step, stabilise=True).run()


class _Context:
    """What stays fixed over a run."""

    def __init__(self, **kwargs):
        self.__dict__.update(kwargs)



def solve_finite(mesh: Mesh, elem: Element, points: MaterialPoints, material,
                 supports, body_force=None, nsteps: int = 1,
                 method: str = "mpm", prescribed: Optional[Callable] = None,
                 tol: float = 1e-9, max_iter: int = 25, max_cutbacks: int = 8,
                 locator: Optional[Locator] = None,
                 solver: Optional[Callable] = None,
                 keep_snapshots: bool = True, first_step: int = 1,
                 domain0: Optional[ndarray] = None,
                 callback: Optional[Callable] = None) -> Result:
    """Finite-deformation implicit MPM or GIMP (updated Lagrangian,
    Hencky elasticity, optional von Mises plasticity).

    Parameters
    ----------
    mesh, elem, points, supports, locator, solver, keep_snapshots
        As in :func:`~skfem_mpm.solve_mpm`.
    material
        :class:`~skfem_mpm.LinearElastic` (Hencky hyperelasticity) or
        :class:`~skfem_mpm.VonMises`.
    body_force
        Body force per unit *initial* volume at full load (``rho0 g``), so
        the weight is conserved exactly; ``None``: none.
    nsteps
        Load steps (loads ramped linearly); a step may be cut back.
    method
        ``"mpm"``, ``"ugimp"`` or ``"cpgimp"`` (GIMP needs a tensor grid
        and point domains, set by :func:`~skfem_mpm.seed_points`).
    prescribed
        Optional ``prescribed(grid_basis, f_old, f_new) -> (dofs,
        increments)``: grid displacements imposed over a step from load
        factor ``f_old`` to ``f_new`` (the grid is reset every step, so these
        are increments).
    tol
        Newton tolerance on the out-of-balance force over the free DOFs,
        relative to the external force norm (to the internal force norm in
        steps driven by prescribed displacements only).
    max_iter, max_cutbacks
        Newton iterations per attempt, and how many times a load step may be
        halved before giving up.
    first_step, domain0
        Resume: ``points`` is the state after step ``first_step - 1``, and
        ``domain0`` the initial GIMP domains (default ``points.domain``).
    callback
        Called as ``callback(record, points)`` after every converged step.

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
    if method not in METHODS:
        raise InvalidInputError("method must be one of {}, got {!r}".format(
            METHODS, method))
    check_run_input(mesh, points, nsteps)
    solver = get_solver(solver)      # one instance: it may keep state
    if method != "mpm" and points.domain is None:
        raise InvalidInputError(
            "method {!r} needs point domains (MaterialPoints.domain); "
            "seed_points sets them on tensor-product grids".format(method))
    scalar, grid, scalar_dofs, pattern = grid_parts(mesh, elem)
    if method == "mpm":
        pattern.structure()              # set-up, shared by every step
    material = at_points(material, points)
    result = Result(points=points.copy())
    locator = point_locator(mesh) if locator is None else locator
    ctx = _Context(
        mesh=mesh, scalar=scalar, material=material,
        method=method, grid=grid, pattern=pattern, scalar_dofs=scalar_dofs,
        counters=result.counters, plastic=is_plastic(material),
        D=support_dofs(supports, grid), dim=mesh.dim(),
        gravity=as_body_force(body_force, mesh.dim()), prescribed=prescribed,
        locate=locator, gimp=None if method == "mpm" else gimp_operators(
            mesh, scalar, locator),
        tol=tol, max_iter=max_iter, solver=solver,
        keep_snapshots=keep_snapshots,
        domain0=points.domain if domain0 is None else domain0)
    points = result.points
    step = int(first_step) - 1
    factor, increment = step / nsteps, 1. / nsteps
    smallest = increment / 2 ** max_cutbacks
    while factor < 1. - 1e-12:
        boundary = (np.floor(factor * nsteps + 1e-9) + 1) / nsteps
        target = factor + increment
        if target > boundary - 1e-12:
            target = boundary
        try:
            points, record = _attempt(ctx, points, factor, target, step + 1)
        except (NewtonDivergenceError, InversionError) as err:
            if (target - factor) / 2 < smallest * (1 - 1e-9):
                raise type(err)(
                    "{}; no convergence down to a load increment of {:.2e}: "
                    "the last converged state (load factor {:.4f}) is "
                    "attached".format(err, smallest, factor),
                    state=points, load_factor=factor,
                    history=result.history) from err
            increment = (target - factor) / 2
            logger.warning("%s: cutting the load increment back to %.3e",
                           err, increment)
            continue
        step += 1
        factor = target
        if abs(factor - boundary) < 1e-12:
            increment = 1. / nsteps
        result.history.append(record)
        result.points = points
        if callback is not None:
            callback(record, points)
        logger.info("step %d: load factor %.4f, %d Newton iterations, "
                    "residual %.2e", step, factor,
                    len(record.newton_residuals) - 1, record.residual)
    return result
