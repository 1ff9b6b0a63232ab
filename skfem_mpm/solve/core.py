"""The load-step core: one loop for every method, kinematics, material,
stabilisation and load.

A load step reads like the seed's Algorithm 2.1 and its finite-deformation
extension::

    locate the points, build the step's point operator      (method)
    supports, prescribed motion and free DOFs               (supports)
    map the external forces                                 (loads)
    iterate:
        stresses and tangent of the increment               (kinematics,
                                                             material)
        internal force, out-of-balance force                (+ stabilisation)
        converged?  else assemble the tangent, solve
    update the points: state, positions, domains            (kinematics,
                                                             method)

The pieces are objects the loop calls and never inspects: a method
(:mod:`skfem_mpm.methods.method`), a kinematics
(:mod:`skfem_mpm.mechanics.kinematics`) with its material
(:mod:`skfem_mpm.mechanics.materials`), stabilisations (the mean
dilatation wraps the point operator; the ghost penalty adds a matrix) and
the loads (:mod:`skfem_mpm.solve.loads`).

A linear step (small strain, elastic) takes exactly one linear solve: the
iteration's first residual is the out-of-balance force
``f_ext(n+1) - f_int(sigma_n)`` (``rhs="residual"``) or, the seed's literal
scheme, the load increment ``f_ext(n+1) - f_ext(n)`` (``rhs="increment"``,
which leaves the out-of-balance force of earlier steps uncorrected: its
residual is reported, not enforced).  A nonlinear step iterates
Newton-Raphson with the consistent tangent, its full steps shortened where
one would invert a point (:mod:`skfem_mpm.solve.newton`); a step whose
Newton loop fails is retried at the same load increment with the ghost
penalty (``ghost="auto"``), with Armijo backtracking, with a stabilised
tangent (also with backtracking), and only then cut back.

"""
import logging
import time
from contextlib import contextmanager
from typing import Callable, NamedTuple, Optional, Sequence

import numpy as np
from numpy import ndarray
from scipy.linalg.blas import dnrm2
from skfem import Basis
from skfem.assembly import Dofs
from skfem.element import Element, ElementVector
from skfem.mesh import Mesh
from skfem.quadrature import get_quadrature

from ..errors import (InvalidInputError, InversionError,
                      MPMError, NewtonDivergenceError, NumericalError,
                      PrescribedMotionError, SingularSystemError,
                      SingularTangentError,
                      StepFailedError)
from ..mechanics.forms import as_body_force
from ..mechanics.kinematics import KINEMATICS, make_kinematics
from ..mechanics.materials import at_points, initial_state, is_plastic
from ..memory import (GRID_BYTES_PER_CELL, RUN_BYTES_PER_POINT,
                      STEP_RECORD_BYTES, refuse_beyond_memory)
from ..methods.assembly import ElementPattern
from ..methods.method import METHODS, make_method
from ..quadrature.locate import Locator, point_locator
from ..quadrature.points import MaterialPoints
from ..stabilisation.ghost import GhostStabilisation
from ..stabilisation.volumetric import MeanDilatation
from .backends import get_solver
from .dynamics import Dynamics, Inertia
from .linear import Condensation, check_rigid_body_modes, \
    factorise_active, free_dofs, solve_active, support_dofs
from .loads import ExternalLoads
from .newton import FullStep, make_line_search, trial_state
from .results import PHASES, Result, StepRecord
from .rigid import check_rigid_bodies, warn_stiff_smooth_bodies

logger = logging.getLogger(__name__)

__all__ = ["simulate", "RHS", "STABILISATION", "DEFAULT_GHOST"]

#: the right-hand sides of a linear step (``rhs=``): the out-of-balance
#: force, or the seed's literal load increment
RHS = ("residual", "increment")
# failures of a step that a retry or a smaller load increment may cure
STEP_FAILURES = (NewtonDivergenceError, InversionError, NumericalError,
                 SingularTangentError)
#: modified Newton (``newton="modified"``) refactorises the tangent when an
#: iteration with the factorised one reduced the residual by less than this
#: factor (a linear rate of 0.25 reaches a tolerance of 1e-9 in 15
#: iterations)
MODIFIED_RATE = .25
#: the fraction of its diagonal added to a tangent refused as singular, or
#: when a failed step is retried (see ``solve_step``)
STABILISATION = 1e-7
#: Newton's tangent: refactorised every iteration, or kept over a step
NEWTON = ("full", "modified")
ADAPTIVE_MODIFIED = (
    "newton='modified' with an adaptive time step (target_iterations): the "
    "time step adapts to the Newton iterations, which modified Newton's "
    "linear convergence multiplies, so it would keep halving (measured: 34 "
    "steps instead of 10, and a different answer); use newton='full' or a "
    "fixed time step")
#: the ghost penalty that ``ghost="auto"`` switches on when a
#: finite-deformation step of moving points fails
DEFAULT_GHOST = .1


def vector_element(elem: Element) -> Element:
    """``elem`` as a vector element (displacements have dim components)."""
    return elem if isinstance(elem, ElementVector) else ElementVector(elem)


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


def check_run_input(mesh: Mesh, points: MaterialPoints, nsteps: int,
                    keep_snapshots: bool = False):
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` for a step count
    that is not a positive integer, points of another dimension, or a run
    this machine's memory cannot hold (the grid, the points and the
    history of ``nsteps`` steps)."""
    if isinstance(nsteps, bool) or not isinstance(
            nsteps, (int, np.integer)) or nsteps < 1:
        raise InvalidInputError(
            "nsteps must be a positive integer, got {!r}".format(nsteps))
    dim = mesh.dim()
    if points.dim != dim:
        raise InvalidInputError(
            "points are {}D but the mesh is {}D".format(points.dim, dim))
    snapshot = 8. * (dim * mesh.nvertices + (2 * dim + 9) * points.n)
    refuse_beyond_memory(
        "{} load steps of {} points on {} cells".format(
            nsteps, points.n, mesh.nelements),
        float(nsteps) * (STEP_RECORD_BYTES + keep_snapshots * snapshot)
        + points.n * RUN_BYTES_PER_POINT[dim]
        + mesh.nelements * GRID_BYTES_PER_CELL[dim],
        "use fewer load steps{}, fewer points or a coarser grid".format(
            ", keep_snapshots=False" if keep_snapshots else ""))


def check_resume(first_step, nsteps: int, load_factor, increment):
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` for a resume
    state no run can be in."""
    if isinstance(first_step, bool) or not isinstance(
            first_step, (int, np.integer)) or first_step < 1:
        raise InvalidInputError("first_step must be a positive integer, got "
                                "{!r}".format(first_step))
    for name, value, low, high in (("load_factor", load_factor, 0., 1.),
                                   ("increment", increment, 0., 1. / nsteps)):
        if value is not None and not (
                isinstance(value, (int, float, np.number))
                and not isinstance(value, bool)
                and (low <= value < high if name == "load_factor"
                     else low < value <= high * (1 + 1e-12))):
            raise InvalidInputError(
                "{} must lie in {}{}, {}{}, got {!r}".format(
                    name, "[" if name == "load_factor" else "(", low, high,
                    ")" if name == "load_factor" else "]", value))


class Trial(NamedTuple):
    """The out-of-balance state of one trial grid increment: the
    kinematics' response, the out-of-balance force ``r`` (grid vector), its
    norm over the free DOFs (``merit``) and that norm relative to the
    external force (``residual``, the convergence measure)."""
    response: object
    r: ndarray
    merit: float
    residual: float


class Run:
    """What stays fixed over a run: the grid, the pieces and the settings."""

    def __init__(self, **kwargs):
        self.__dict__.update(kwargs)


def prescribed_increments(run: Run, f_old: float, f_new: float,
                          step: int):
    """The prescribed grid DOFs and their increments over a step, checked:
    integer DOFs of the grid, one finite value each."""
    dofs, values = run.prescribed(run.grid, f_old, f_new)
    dofs, values = np.asarray(dofs), np.asarray(values, dtype=np.float64)
    if dofs.size == 0:
        dofs = dofs.astype(np.int64)
    N = run.grid.N
    if dofs.dtype.kind not in "iu" or dofs.ndim != 1 \
            or values.shape != dofs.shape or not np.isfinite(values).all() \
            or (dofs.size and (dofs.min() < 0 or dofs.max() >= N)):
        raise InvalidInputError(
            "step {}: prescribed(basis, f_old, f_new) must return integer "
            "grid DOFs in [0, {}) and one finite increment each, got DOFs of "
            "dtype {} and shape {}, increments of shape {}".format(
                step, N, dofs.dtype, dofs.shape, values.shape))
    return dofs.astype(np.int64), values


def check_prescribed_motion(run: Run, op, dofs: ndarray, values: ndarray,
                            step: int):
    """Prescribed motion must act on the material it acted on.  A grid DOF
    with a non-zero prescribed increment that carried material at the start
    (a node of a cell holding a point's initial position) but is supported
    by no point in this step has lost its material.  When some of the
    material that started in its cells now sits in a cell with no moving
    prescribed DOF, the body has moved away from the prescribed nodes (a
    surface pushed down by more than a cell below the nodes that push it)
    and the motion would no longer be followed, silently: refused.
    (Material that moved on to other prescribed nodes, as a corner of a
    sheared block or a body whose whole grid motion is prescribed, is still
    driven; increments on nodes the body never reached do no harm.)"""
    moving = dofs[values != 0.]
    on = np.zeros(op.N, dtype=bool)
    on[op.active_dofs] = True
    lost = moving[~on[moving] & run.initially_supported[moving]]
    if not lost.size:
        return
    element_dofs = run.grid.dofs.element_dofs
    lost_mask = np.zeros(op.N, dtype=bool)
    lost_mask[lost] = True
    touching = lost_mask[element_dofs].any(axis=0)         # per cell
    carried = touching[run.initial_cells]                  # per point
    driven = np.zeros(op.N, dtype=bool)
    driven[moving] = True
    if driven[element_dofs[:, op.point_elements[carried]]].any(axis=0).all():
        return
    raise PrescribedMotionError(
        "step {}: the prescribed motion acts on {} grid DOF(s) that carried "
        "material at the start but that no material point supports any "
        "more, e.g. at {}, while that material has moved into cells no "
        "prescribed motion reaches: the grid nodes stay where they are, the "
        "material has moved away from them by more than a cell, and their "
        "motion would not be followed; move the loading body as material "
        "points (a stiff body) instead of grid nodes, or prescribe less "
        "motion than a cell".format(step, lost.size, run.grid.doflocs[
            :, lost[:3]].T.tolist()))


def safe_norm(v: ndarray) -> float:
    """The 2-norm of ``v`` without underflow or overflow of its squares
    (forces of 1e-300 or 1e+200 N): numpy's where that is safe, BLAS's
    scaled ``dnrm2`` otherwise."""
    with np.errstate(over="ignore", under="ignore"):
        norm = np.linalg.norm(v)
    if v.size == 0 or np.finfo(float).tiny < norm < 1e150:
        return float(norm)
    return float(dnrm2(np.ascontiguousarray(v, dtype=np.float64)))


def load_step(run: Run, points: MaterialPoints, f_old: float, f_new: float,
              step: int, stabilise: bool = False, strategy=None):
    """One load step from the converged state ``points``, from load factor
    ``f_old`` to ``f_new`` (Newton steps by ``strategy``, default
    ``run.newton``): returns the new state and the step's record."""
    t = dict.fromkeys(PHASES, 0.)
    # what a back end keeps from earlier steps' matrices (an AMG
    # hierarchy) goes: a step computes the same from a checkpoint
    getattr(run.solver, "forget", lambda: None)()
    op = run.method.operator(points, step, t)
    tic = time.perf_counter()
    if run.antilocking:
        op = MeanDilatation(op, points.volume)
    fixed, du = run.D, np.zeros(op.N)
    driven = np.zeros(0, dtype=np.int64)
    s_old, s_new = run.scale(f_old), run.scale(f_new)  # the loads' scale
    if run.prescribed is not None:
        dofs, values = prescribed_increments(run, s_old, s_new, step)
        du[dofs] = values
        fixed = np.union1d(fixed, dofs)
        driven = dofs[values != 0.]
        check_prescribed_motion(run, op, dofs, values, step)
    rigid_dofs = []
    for k, rigid in enumerate(run.rigid_bodies):
        dofs = rigid.dofs(run.grid.dofs.element_dofs, op.point_elements,
                          points)
        values = rigid.increment(s_old, s_new)[dofs % run.dim]
        clash = np.isin(dofs, fixed) & (du[dofs] != values)
        if clash.any():
            raise PrescribedMotionError(
                "step {}: rigid_bodies[{}] (body {}) drives {} grid DOF(s) "
                "that a support or another prescribed motion holds "
                "otherwise, e.g. component {} at {}".format(
                    step, k, rigid.body, int(clash.sum()),
                    int(dofs[clash][0] % run.dim),
                    run.grid.doflocs[:, dofs[clash][0]].tolist()))
        du[dofs] = values
        fixed = np.union1d(fixed, dofs)
        driven = np.union1d(driven, dofs[values != 0.])
        rigid_dofs.append(dofs)
    if run.dynamics is None:                  # the mass holds a free body
        # checked again only when the active cells or the held DOFs change
        held = (op.elements.tobytes(), fixed.tobytes()) if \
            op.connectivity_from_elements else None
        if held is None or held != run.held:
            check_rigid_body_modes(op.adjacency(),
                                   run.grid.doflocs[:, ::run.dim],
                                   op.active_dofs, fixed, run.dim, step)
            run.held = held
    free = free_dofs(op.active_dofs, fixed)
    f_dead = run.loads.external(op, points, s_new)
    G = None if run.ghost is None else run.ghost.matrix(op, points)
    inertia, follows = None, 1.       # follows: the follower load's weight
    if run.dynamics is not None:
        inertia, f_dead, f_int0, f_ext0 = step_inertia(
            run, op, points, f_old, f_new, s_old, f_dead, free, fixed, du)
        follows = 1 - inertia.alpha_f
    t["assemble"] += time.perf_counter() - tic

    def tangent(response):
        """The step's tangent at a trial: stiffness, ghost, inertia."""
        blocks = response.tangent_of is not None and getattr(
            op, "tangent_blocks", False)       # no tangent of all points
        K = op.stiffness(response.tangent_of if blocks
                         else response.tangent(), response.w)
        if G is not None:
            K = K + G
        if inertia is not None:
            K = (1 - inertia.alpha_f) * K + inertia.c * inertia.M
        return K

    def evaluate(du: ndarray) -> Trial:
        """The out-of-balance state of the grid increment ``du``."""
        tic = time.perf_counter()
        response = run.kinematics.response(op, du, points)
        t["update"] += time.perf_counter() - tic
        tic = time.perf_counter()
        f_ext = f_dead
        if run.loads.follows:                   # pressure on the trial surface
            f_ext = f_dead + follows * run.loads.follower_force(
                op, points, s_new, response.deformation)
        f_int = op.force(response.P, response.w)
        if G is not None:                       # the ghost forces balance too
            f_int += G @ du
        # relative to the larger of the loads and the forces that drive the
        # prescribed motion: a step driven by prescribed motion under a
        # small weight is measured against the forces it drives (and in
        # dynamics against the inertia force: a free vibration)
        scale = max(safe_norm(f_ext), safe_norm(f_int[driven]))
        if inertia is not None:     # at n+1-alpha_f, and the inertia force
            f_int = (1 - inertia.alpha_f) * f_int + inertia.alpha_f * f_int0
            moving = inertia.force(du)
            f_int += moving
            scale = max(scale, safe_norm(moving))
        r = f_ext - f_int
        if scale == 0.:               # nothing loads or drives: the stresses
            scale = max(safe_norm(f_int), np.finfo(float).tiny)
        merit = safe_norm(r[free])
        t["check"] += time.perf_counter() - tic
        return Trial(response, r, merit, merit / scale)

    def converged(trial: Trial) -> bool:
        return trial.residual <= run.tol

    # a nonlinear step driven by prescribed motion takes its first Newton
    # step with the tangent of the step's start, the prescribed increments
    # as loads (the predictor of nonlinear FE codes): the tangent at the
    # first trial, where only the driven nodes have moved, sees a band of
    # spurious yielding along them (a whole soil layer behind a moved base)
    # and sends Newton astray
    predictor = None
    if not run.linear and driven.size:
        start = evaluate(np.zeros(op.N))
        tic = time.perf_counter()
        K_start = tangent(start.response)
        predictor = K_start, start.r - K_start @ du
        del K_start
        t["assemble"] += time.perf_counter() - tic
    try:
        current = evaluate(du)
    except InversionError as err:
        raise InversionError("step {}: {}".format(step, err)) from err
    residuals = []
    search = (run.newton if strategy is None else strategy).start()
    # modified Newton on a step's first attempt (its retries: full Newton)
    modified = run.modified and strategy is None and not stabilise
    frozen = None
    run.reused = False        # whether a factorisation served again
    for it in range(run.max_iter + 1):
        residuals.append(float(current.residual))
        logger.debug("step %d iteration %d: residual %.3e", step, it,
                     residuals[-1])
        if converged(current) or free.size == 0 or (
                run.rhs == "increment" and it == 1):
            break
        if it == run.max_iter or not np.isfinite(residuals[-1]):
            raise NewtonDivergenceError(
                "step {}: {} did not converge in {} iterations (residual "
                "{:.1e}, smallest {:.1e}, last {:.1e})".format(
                    step, "the equilibrium iteration" if run.linear
                    else "Newton-Raphson", it, residuals[0], min(residuals),
                    residuals[-1]))
        if it == 0 and predictor is not None:
            tic = time.perf_counter()
            d = solve_step(run, *predictor, free, step, stabilise)[0]
            predictor = None              # memory: freed before the tangent
            t["solve"] += time.perf_counter() - tic
            trial, merit = trial_state(evaluate, du + d)
            if trial is not None and merit < current.merit:
                du, current = du + d, trial
                continue
            # the predictor did not lower the residual (an over-driven
            # cell can lead it to another branch of the equilibrium):
            # Newton from the first trial instead, evaluated again (the
            # predictor's trial overwrote the kinematics' work arrays)
            logger.debug("step %d: the predictor raised the residual to "
                         "%.3e; Newton from the first trial", step,
                         merit / max(current.merit, 1e-300)
                         * current.residual)
            current = evaluate(du)
            run.counters["line_search_trials"] += 2
        r = current.r
        if run.rhs == "increment":
            r = f_dead - run.loads.external(op, points, f_old)
        d = None
        if frozen is not None and residuals[-1] <= MODIFIED_RATE * \
                residuals[-2]:      # modified Newton: the step's tangent
            tic = time.perf_counter()
            try:
                d = frozen(r)
            except SingularSystemError as err:
                # a pivot check that this right-hand side set off: the
                # current tangent decides (stabilised where it must be)
                logger.debug("step %d: %s; refactorising", step, err)
            else:
                run.counters["newton_iterations"] += 1
                run.counters["linear_solves"] += 1
                # a solver function without factorise(A) factorises anew
                run.counters["factorisations"] += not hasattr(
                    run.solver, "factorise")
                run.reused = True
            t["solve"] += time.perf_counter() - tic
        if d is None:
            tic = time.perf_counter()
            K = tangent(current.response)
            t["assemble"] += time.perf_counter() - tic
            tic = time.perf_counter()
            d, solve = solve_step(run, K, r, free, step, stabilise)
            t["solve"] += time.perf_counter() - tic
            if modified:
                frozen = solve
            # memory: the next tangent is assembled and factorised with
            # neither this one nor (full Newton) its factorisation alive
            del K, solve
        try:
            du, current, extra = search(evaluate, du, d, current,
                                        converged)
        except InversionError as err:
            raise InversionError("step {}: {}".format(step, err)) from err
        run.counters["line_search_trials"] += extra
    response, r = current.response, current.r
    tic = time.perf_counter()
    new = response.commit(points)
    dx = op.values(du)
    new.displacement = points.displacement + dx
    if run.method.moves:
        new.x = points.x + dx
        domains = run.method.domains(run.domain0, new.F)
        if domains is not None:
            new.domain = domains
    held = fixed[np.isin(fixed, op.active_dofs)]
    energy = None
    if inertia is not None:
        energy = commit_motion(run, op, inertia, points, new, response, du,
                               G, f_int0, f_ext0, f_dead, s_new)
    t["update"] += time.perf_counter() - tic
    if run.method.moves:     # inside the grid (the location serves the next
        run.method.locate(new.x, step, t, points)               # step)
    record = StepRecord(step, f_new, residuals[-1], op.nelems, free.size, t,
                        reaction_dofs=held, reaction_values=-r[held],
                        n_dofs=op.N)
    if energy is not None:
        record.time = f_new * run.dynamics.duration
        record.time_step = (f_new - f_old) * run.dynamics.duration
        record.energy = energy
    for dofs in rigid_dofs:       # a support's DOFs keep their reactions
        dofs = dofs[~np.isin(dofs, run.D)]
        force = np.zeros(run.dim)
        np.add.at(force, dofs % run.dim, -r[dofs])
        record.rigid_forces.append(force)
    if not run.linear:
        record.newton_residuals = residuals
        record.n_yielded = int(response.yielded.sum())
    if run.keep_snapshots:
        record.elements = op.elements
        record.u, record.x = du, new.x.copy()
        record.displacement = new.displacement.copy()
        record.stress = new.stress.copy()
    return new, record, op


def step_inertia(run: Run, op, points: MaterialPoints, f_old: float,
                 f_new: float, s_old: float, f_dead: ndarray,
                 free: ndarray, fixed: ndarray, du: ndarray):
    """The inertia of a time step from ``f_old`` to ``f_new`` (fractions
    of the duration), the external force at ``n+1-alpha_f``, and the
    internal and external forces at the step's start.  The first step of a
    run without accelerations takes them from the balance at its start.
    Grid DOFs whose motion is held (supports, prescribed motion, rigid
    bodies: ``fixed``, their increments in ``du``) move at their prescribed
    rate over the step, without acceleration, not at the velocity projected
    from the points near them."""
    dynamics = run.dynamics
    inertia = Inertia(dynamics, op, points, run.masses,
                      (f_new - f_old) * dynamics.duration)
    inertia.kinetic_start = .5 * float(run.masses @ (
        points.velocity ** 2).sum(0))
    start = run.kinematics.response(op, np.zeros(op.N), points)
    f_int0 = op.force(start.P, start.w)
    f_ext0 = run.loads.external(op, points, s_old)
    if run.loads.follows:             # pressure on the start's surface
        f_ext0 = f_ext0 + run.loads.follower_force(op, points, s_old,
                                                   start.deformation)
    if inertia.a is None:
        a = solve_active(inertia.M.tocsr(), f_ext0 - f_int0, free,
                         solver=run.solver, doflocs=run.grid.doflocs)
        inertia.a = a
        run.counters["linear_solves"] += 1
        run.counters["factorisations"] += 1
    inertia.v[fixed] = du[fixed] / inertia.dt
    inertia.a[fixed] = 0.
    alpha = inertia.alpha_f
    return inertia, (1 - alpha) * f_dead + alpha * f_ext0, f_int0, f_ext0


def commit_motion(run: Run, op, inertia: Inertia, points: MaterialPoints,
                  new: MaterialPoints, response, du: ndarray, G,
                  f_int0: ndarray, f_ext0: ndarray, f_dead: ndarray,
                  s_new: float) -> dict:
    """The points' new velocity (FLIP / PIC blend) and acceleration from
    the grid's (``points``: the state at the step's start); returns the step's energies: kinetic at its start and end,
    and the work of the internal and external forces over it (trapezoidal
    rule)."""
    a = inertia.acceleration(du)
    v = inertia.velocity(a)
    flip = run.dynamics.flip
    new.velocity = op.values(v) if flip == 0 else \
        flip * (new.velocity + op.values(v - inertia.v)) \
        + (1 - flip) * op.values(v)
    new.acceleration = op.values(a)
    f_int = op.force(response.P, response.w)
    if G is not None:
        f_int += G @ du
    alpha = inertia.alpha_f          # f_dead is the load at n+1-alpha_f
    f_ext1 = f_dead if alpha == 0 else (f_dead - alpha * f_ext0) / (1 - alpha)
    if run.loads.follows:             # pressure on the step's end surface
        f_ext1 = f_ext1 + run.loads.follower_force(op, points, s_new,
                                                   response.deformation)
    return {"kinetic_start": inertia.kinetic_start,
            "kinetic": .5 * float(run.masses @ (new.velocity ** 2).sum(0)),
            "internal_work": .5 * float((f_int0 + f_int) @ du),
            "external_work": .5 * float((f_ext0 + f_ext1) @ du)}


def solve_step(run: Run, K, r: ndarray, free: ndarray, step: int,
               stabilise: bool):
    """Newton's increment with the exact tangent; in nonlinear steps with a
    stabilised one where points leave zero-energy modes on weakly supported
    nodes (a cell entered by one point): when the step is retried so
    (``stabilise``), or when the exact tangent is refused as singular.
    Those modes carry no residual, so the stabilisation, ``STABILISATION``
    times the diagonal added to the tangent only, does not change the
    converged state; it is used only when needed because it slows Newton to
    a linear rate of about ``STABILISATION`` times the tangent's condition
    number.  A linear step solves once, exactly, or raises.  Returns the
    increment and the factorised solve, ``solve(r) -> d``, that modified
    Newton reuses."""
    counters = run.counters
    if not run.linear:
        counters["newton_iterations"] += 1
    if not (run.condensation is not None and run.condensation.fits(K, free)) \
            and getattr(K, "has_canonical_format", False):
        run.condensation = Condensation(K, free)    # new step: new map
    # (GIMP's sparse products are not canonical: scikit-fem's condense)

    def factorise_and_solve():
        counters["linear_solves"] += 1
        counters["factorisations"] += 1
        solve = factorise_active(K, free, solver=run.solver,
                                 doflocs=run.grid.doflocs,
                                 condensation=run.condensation)
        return solve(r), solve
    if not stabilise:
        try:
            return factorise_and_solve()
        except SingularSystemError as err:
            if run.linear:
                raise SingularSystemError("step {}: {}".format(step, err)) \
                    from err
            logger.debug("step %d: %s; solving again with the tangent "
                         "stabilised by %.0e of its diagonal", step, err,
                         STABILISATION)
    K.setdiag(K.diagonal() * (1. + STABILISATION))           # in place
    counters["stabilised_solves"] += 1
    try:
        return factorise_and_solve()
    except SingularSystemError as err:
        # a nonlinear step's trial tangent (the supports were checked
        # before the step): a failed step, retried and cut back
        raise (SingularSystemError if run.linear else SingularTangentError)(
            "step {}: {}".format(step, err)) from err


def attempt(run: Run, points: MaterialPoints, f_old: float, f_new: float,
            step: int):
    """A load step with the exact tangent.  When Newton fails in a
    nonlinear step, it is retried at the same increment, one log line per
    failed attempt: with full Newton where the attempt was modified Newton,
    with the ghost penalty switched on for the rest of the
    run if ``ghost="auto"`` holds it in reserve (points giving nodes a
    sliver of support make Newton cycle: the commonest failure), then with
    the line search (:mod:`skfem_mpm.solve.newton`; the equilibrium it
    converges to is the step's, though a run's path of cut-backs, and so
    its answer, can differ), then once with the stabilised tangent
    (zero-energy modes not refused as singular), again with the line
    search."""
    try:
        with numerical_failures(step):
            return load_step(run, points, f_old, f_new, step)
    except STEP_FAILURES as err:
        if run.linear:
            raise
        failure = err
    def retry(what, strategy):
        """The step again with ``strategy``: ``(its result, None)``, or
        ``(None, the failure)``."""
        logger.warning("%s; retrying with %s", failure, what)
        try:
            with numerical_failures(step):
                return load_step(run, points, f_old, f_new, step,
                                 strategy=strategy), None
        except STEP_FAILURES as err:
            return None, err
    if run.reused:      # else the attempt was full Newton's already
        done, failure = retry("full Newton", run.newton)
        if done:
            return done
    if run.ghost is None and run.ghost_reserve is not None:
        run.ghost = run.ghost_reserve
        run.counters["ghost_from_step"] = step
        logger.warning("%s; switching the ghost penalty on (gamma %g) for "
                       "the rest of the run", failure, run.ghost.gamma)
        return attempt(run, points, f_old, f_new, step)
    if run.line_search is not None:
        done, failure = retry("the line search", run.line_search)
        if done:
            return done
    logger.warning("%s; retrying with the tangent stabilised by %.0e of its "
                   "diagonal", failure, STABILISATION)
    with numerical_failures(step):
        return load_step(run, points, f_old, f_new, step, stabilise=True,
                         strategy=run.line_search)


@contextmanager
def numerical_failures(step: int):
    """numpy's and Python's arithmetic failures in a step (a singular 3x3
    inverse of a squashed point, an overflow) as a
    :class:`~skfem_mpm.errors.NumericalError`: a failed step like any
    other, retried and cut back."""
    try:
        yield
    except (ArithmeticError, np.linalg.LinAlgError) as err:
        raise NumericalError("step {}: {}: {}".format(
            step, type(err).__name__, err)) from err


def simulate(mesh: Mesh, elem: Element, points: MaterialPoints, material,
             supports, body_force=None, loads: Sequence = (),
             prescribed: Optional[Callable] = None,
             nsteps: Optional[int] = None,
             method: str = "mpm", kinematics: str = "small",
             rhs: str = "residual", antilocking: bool = False,
             ghost="auto", line_search="backtracking", tol: float = 1e-9,
             max_iter: int = 25,
             max_cutbacks: int = 8, solver=None,
             locator: Optional[Locator] = None, keep_snapshots: bool = True,
             first_step: int = 1, domain0: Optional[ndarray] = None,
             load_factor: Optional[float] = None,
             increment: Optional[float] = None,
             counters: Optional[dict] = None,
             callback: Optional[Callable] = None,
             ramp_body_force=True, rigid_bodies: Sequence = (),
             dynamics: Optional[Dynamics] = None,
             newton: str = "full") -> Result:
    """Implicit MPM, GIMP or FE, quasi-static or dynamic: any method with
    any kinematics, material, stabilisation and loads.

    Parameters
    ----------
    mesh, elem
        Background grid (any scikit-fem mesh; GIMP needs an axis-aligned
        tensor-product grid) and its scikit-fem element (scalar or
        ``ElementVector``).
    points
        Initial :class:`~skfem_mpm.MaterialPoints`; copied, not modified.
    material
        A material (:class:`~skfem_mpm.LinearElastic`,
        :class:`~skfem_mpm.VonMises` or any object following the protocol
        of :mod:`skfem_mpm.mechanics.materials`), or a list with one per
        body (``points.body``).
    supports
        Fixed (zero) grid DOFs: DOF indices, a ``DofsView`` or a callable
        taking the grid's vector ``Basis``, e.g.
        ``lambda b: b.get_dofs(lambda x: x[0] == 0)``.
    body_force
        Body force per unit *initial* volume at full load, shape (dim,);
        ``None``: none is assembled.  Point forces at full load are
        ``points.force``.
    ramp_body_force
        ``True`` (default): the body force grows with the load factor like
        every load; ``False``: it acts in full from the first step, as where
        the points start from a geostatic stress that balances it
        (:func:`~skfem_mpm.mechanics.geostatic.geostatic_stress`); or one
        bool per body.  What it leaves out of balance at the start (a body
        not in a geostatic state, a sloping surface) must be carried by the
        first step whole: a cut-back does not reduce it.
    loads
        Further loads at full load (:mod:`skfem_mpm.solve.loads`):
        :class:`~skfem_mpm.Traction`, :class:`~skfem_mpm.Pressure` on a side
        of a body, :class:`~skfem_mpm.GridLoad` (a scikit-fem
        ``LinearForm``).
    prescribed
        Optional ``prescribed(grid_basis, f_old, f_new) -> (dofs,
        increments)``: grid displacement increments imposed over a step
        from load factor ``f_old`` to ``f_new``.
    nsteps
        Load steps; every load is ramped linearly.  A nonlinear step may be
        cut back (bisected) down to ``2**-max_cutbacks`` of a step.
    method
        ``"fem"`` (points fixed: finite elements with the points as
        quadrature), ``"mpm"``, ``"ugimp"`` or ``"cpgimp"``.
    kinematics
        ``"small"`` (incremental small strain) or ``"finite"`` (updated
        Lagrangian Hencky; total Lagrangian with ``"fem"``).
    rhs
        Right-hand side of a linear step's solve: ``"residual"`` (the
        out-of-balance force) or ``"increment"`` (the seed's load
        increment; linear steps only).
    antilocking
        Mean dilatation (B-bar, :mod:`skfem_mpm.stabilisation.volumetric`)
        against volumetric locking; ``"mpm"`` and ``"fem"``.
    ghost
        Ghost-penalty factor for partially filled cells
        (:mod:`skfem_mpm.stabilisation.ghost`, e.g. 0.1); 0: none;
        ``"auto"`` (default): none, but where points move in finite
        deformation a load step whose Newton loop fails switches
        :data:`DEFAULT_GHOST` on for the rest of the run (a bending body
        leaves nodes a sliver of support and Newton cycles without it; runs
        that converge without it are not changed), and
        ``counters["ghost_from_step"]`` says from which step.
    line_search
        Globalisation of Newton's method (:mod:`skfem_mpm.solve.newton`):
        ``"backtracking"`` (default): Newton's full steps, shortened only
        where one inverts a point or fails in arithmetic (plain Newton's
        path wherever it converges), and a load step that fails so is
        retried with Armijo backtracking on the residual (after the ghost
        penalty of ``ghost="auto"``, before the stabilised tangent and any
        cut-back); ``"armijo"``: the Armijo search from the first attempt
        on (where full steps fail most steps anyway, as for a footing
        sunk into perfectly plastic soil); ``"none"`` or ``FullStep()``:
        plain Newton; a
        :class:`~skfem_mpm.solve.newton.Backtracking` of one's own runs
        from the first attempt (e.g. ``Backtracking(watchdog=0)``, Armijo
        on every step).  Linear steps solve once and take the whole step.
        ``counters["line_search_trials"]`` counts the residual evaluations
        the line search added beyond one per Newton iteration (and the two
        of a predictor step that was rejected for raising the residual).
    newton
        ``"full"`` (default): Newton-Raphson, the consistent tangent
        assembled and factorised in every iteration (quadratic
        convergence).  ``"modified"``: the tangent of a load step's first
        iteration and its factorisation serve the following iterations,
        each then costing a residual and a back substitution, and the
        tangent is refactorised where an iteration reduced the residual by
        less than :data:`MODIFIED_RATE`; the convergence is linear, the
        converged state the same to the tolerance.  A step whose modified
        iterations fail is retried with full Newton (before the line
        search and the other retries).  Linear steps solve once either
        way.  Where a step fails with one and converges with the other
        (a retry, ``ghost="auto"`` switching the ghost penalty on), the
        two runs part ways.  Refused with an adaptive time step
        (``Dynamics(target_iterations=...)``, which counts iterations).  A
        solver function of one's own, without ``factorise(A)``, is called
        for every iteration (the tangent is kept, not its factorisation).
        ``counters["factorisations"]`` counts the matrices factorised.
    tol, max_iter
        Tolerance on the out-of-balance force over the free DOFs relative
        to the larger of the external force and the internal force on the
        DOFs whose motion is prescribed (the forces that drive it: a shear
        box under a small weight is measured against its shear force), and
        iterations per attempt.
    solver
        Linear solver: a scikit-fem solver ``f(A, b) -> x`` or a name
        (``"scipy"``, ``"pypardiso"``, ``"pyamg"``, ``"auto"``); default
        ``"auto"``, the back end measured fastest for each system's size
        among those installed, logged
        (:func:`~skfem_mpm.solve.backends.solver_auto`: SuperLU for small
        systems and where nothing else is installed).
    locator, keep_snapshots, callback
        A :func:`~skfem_mpm.point_locator` of ``mesh`` to reuse; keep
        per-step grid increments, positions, displacements and stresses in
        the history; ``callback(record, points)`` after every step.
    first_step, domain0, load_factor, increment, counters
        Resume: ``points`` is the state after step ``first_step - 1``, at
        ``load_factor`` (default ``(first_step - 1) / nsteps``), the next
        load increment is ``increment`` (default ``1 / nsteps``; less after
        a cut-back), ``domain0`` the initial GIMP domains (default
        ``points.domain``) and ``counters`` those of the run so far (a
        ghost penalty switched on stays on).  ``StepRecord.load_factor``,
        ``.increment`` and ``.counters`` of the last converged step are
        what a resume needs: it then continues bit-identically.
    rigid_bodies
        :class:`~skfem_mpm.RigidBody` objects (or one): bodies of points
        pushed by prescribed displacement through the grid nodes of the
        cells they occupy (standard MPM or FE), which change as they move
        (a footing that sinks by many cells); the force each needs per step
        (supported DOFs left to their supports) is in
        ``StepRecord.rigid_forces``.
    dynamics
        ``None`` (default): quasi-static load steps, no mass, no velocity.
        A :class:`~skfem_mpm.Dynamics`: time steps with inertia
        (:mod:`skfem_mpm.solve.dynamics`); the load factor is then the
        fraction of the duration, loads and prescribed motion follow
        ``Dynamics.load(t)``, ``nsteps`` is set by the time step (giving it
        too is refused), every record carries ``time`` and ``energy`` and
        the points ``velocity`` and ``acceleration``.

    Returns
    -------
    Result

    Raises
    ------
    NewtonDivergenceError, InversionError, SingularTangentError
        When a step fails at the smallest increment; ``err.state`` is the
        last converged state, ``err.load_factor`` its load factor.
    SingularSystemError
        Missing supports (rigid-body modes of the active grid), refused
        before a step's iterations.

    Examples
    --------
    Small-strain plasticity with standard MPM (Newton with the consistent
    tangent, return maps only because the body is plastic):

    >>> import numpy as np
    >>> from skfem import MeshQuad, ElementQuad1
    >>> from skfem_mpm import VonMises, seed_points, simulate
    >>> mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 2, 5))
    >>> res = simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
    ...                VonMises(1e4, .3, yield_stress=5.),
    ...                lambda b: b.get_dofs(lambda x: x[1] == 0),
    ...                body_force=[0., -10.], nsteps=2, kinematics="small")
    >>> res.counters["return_maps"] > 0, bool(res.history[-1].residual < 1e-9)
    (True, True)

    """
    if kinematics not in KINEMATICS:
        raise InvalidInputError("kinematics must be one of {}, got {!r}"
                                .format(KINEMATICS, kinematics))
    if method not in METHODS:
        raise InvalidInputError("method must be one of {}, got {!r}".format(
            METHODS, method))
    if rhs not in RHS:
        raise InvalidInputError("rhs must be one of {}, got {!r}".format(
            RHS, rhs))
    if dynamics is not None:
        if not isinstance(dynamics, Dynamics):
            raise InvalidInputError("dynamics must be None or Dynamics(...), "
                                    "got {!r}".format(dynamics))
        if nsteps is not None:
            raise InvalidInputError(
                "nsteps and dynamics both given: a dynamic run takes "
                "duration / time_step = {} steps".format(dynamics.nsteps))
        if rhs == "increment":
            raise InvalidInputError(
                "rhs = 'increment' maps load increments of quasi-static steps;"
                " dynamics needs the out-of-balance force (rhs = 'residual')")
        nsteps = dynamics.nsteps
        if dynamics.mass == "consistent" and method != "fem":
            raise InvalidInputError(
                "mass = 'consistent' needs points that stay in their cells "
                "(method = 'fem'): with moving points its projection is "
                "ill-conditioned where a point barely reaches a node, and a "
                "run was measured to create energy 1000-fold as points "
                "crossed cells; use mass = 'lumped'")
    elif nsteps is None:
        nsteps = 1
    check_run_input(mesh, points, nsteps, keep_snapshots)
    reserve = isinstance(ghost, str) and ghost == "auto" and \
        kinematics == "finite" and method != "fem"
    if isinstance(ghost, str) and ghost == "auto":
        ghost = 0.
    if isinstance(ghost, bool) or not (
            isinstance(ghost, (int, float, np.number)) and ghost >= 0
            and np.isfinite(ghost)):
        raise InvalidInputError("ghost must be 'auto' or a finite number >= "
                                "0, got {!r}".format(ghost))
    ramp = np.atleast_1d(np.asarray(ramp_body_force, dtype=object))
    if ramp.ndim != 1 or not all(isinstance(r, (bool, np.bool_))
                                 for r in ramp) \
            or ramp.size not in (1, int(points.body.max()) + 1):
        raise InvalidInputError(
            "ramp_body_force must be True, False or one bool per body ({}), "
            "got {!r}".format(int(points.body.max()) + 1, ramp_body_force))
    ramp = ramp.astype(bool)
    if rhs == "increment" and not ramp.all() and body_force is not None:
        raise InvalidInputError(
            "rhs = 'increment' maps only load increments: a body force in "
            "full from the first step (ramp_body_force) would be dropped; "
            "use rhs = 'residual'")
    if not isinstance(antilocking, (bool, np.bool_)):
        raise InvalidInputError("antilocking must be True or False, got "
                                "{!r}".format(antilocking))
    if antilocking and method in ("ugimp", "cpgimp"):
        raise InvalidInputError(
            "antilocking (mean dilatation) averages over the points of each "
            "grid cell: it needs method 'mpm' or 'fem', not {!r} (GIMP points "
            "span several cells)".format(method))
    if method in ("ugimp", "cpgimp") and points.domain is None:
        raise InvalidInputError(
            "method {!r} needs point domains (MaterialPoints.domain); "
            "seed_points sets them on tensor-product grids".format(method))
    material = at_points(material, points)
    linear = kinematics == "small" and not is_plastic(material)
    if rhs == "increment" and not linear:
        raise InvalidInputError(
            "rhs = 'increment' (the seed's one-solve scheme) is for linear "
            "steps (small strain, elastic); {} needs the out-of-balance "
            "force (rhs = 'residual')".format(
                "finite deformation" if kinematics == "finite"
                else "plasticity"))
    rigid_bodies = check_rigid_bodies(rigid_bodies, points, mesh.dim(),
                                      method)
    warn_stiff_smooth_bodies(rigid_bodies, material, points)
    if rhs == "increment" and (prescribed is not None or rigid_bodies):
        raise InvalidInputError(
            "rhs = 'increment' maps only the load increment: prescribed "
            "displacements would not enter the solve; use rhs = 'residual'")
    if not (isinstance(tol, (int, float, np.number)) and 0 < tol < 1):
        raise InvalidInputError("tol must lie in (0, 1), got {!r}".format(tol))
    for name, value, low in (("max_iter", max_iter, 1),
                             ("max_cutbacks", max_cutbacks, 0)):
        if isinstance(value, bool) or not isinstance(
                value, (int, np.integer)) or not low <= value <= 60:
            raise InvalidInputError("{} must be an integer in [{}, 60], got "
                                    "{!r}".format(name, low, value))
    check_resume(first_step, nsteps, load_factor, increment)
    if not isinstance(newton, str) or newton not in NEWTON:
        raise InvalidInputError("newton must be one of {}, got {!r}".format(
            NEWTON, newton))
    if newton == "modified" and dynamics is not None and \
            dynamics.target_iterations is not None:
        raise InvalidInputError(ADAPTIVE_MODIFIED)
    line_search = make_line_search(line_search)
    if locator is not None and getattr(locator, "mesh", None) is not mesh:
        raise InvalidInputError(
            "locator must be point_locator(mesh) of the mesh solved on; this "
            "one {}".format("locates on another mesh" if hasattr(
                locator, "mesh") else "is not a point_locator"))
    scalar, grid, scalar_dofs, pattern = grid_parts(mesh, elem)
    result = Result(points=points.copy())
    points = result.points
    masses = None
    if dynamics is not None:
        masses = dynamics.masses(points)
        if points.velocity is None:
            points.velocity = np.zeros_like(points.x)
    elif points.velocity is not None or points.acceleration is not None:
        raise InvalidInputError(
            "the points carry a velocity or acceleration but the run is "
            "quasi-static (dynamics=None), which would drop them; pass "
            "dynamics=Dynamics(...) or clear them")
    for name, value in initial_state(material, points.n).items():
        points.state.setdefault(name, value)
    resumed_counters, counters = dict(counters or {}), result.counters
    domain0 = points.domain if domain0 is None else domain0
    external = ExternalLoads(mesh, scalar, grid,
                             as_body_force(body_force, mesh.dim()), loads,
                             domain0, counters, points.n,
                             follow=kinematics == "finite",
                             moves=method != "fem",
                             ramp_gravity=ramp)
    locate = point_locator(mesh) if locator is None else locator
    piece = make_method(method, mesh, scalar, scalar_dofs, pattern, locate,
                        counters)
    if method in ("fem", "mpm"):
        pattern.structure()              # set-up, shared by every step
    run = Run(
        condensation=None,           # the free-free gather of a step's K
        held=None,                   # active cells and held DOFs checked
        mesh=mesh, dim=mesh.dim(), grid=grid, method=piece, linear=linear,
        kinematics=make_kinematics(kinematics, material, mesh.dim(), counters,
                                   total_lagrangian=method == "fem"),
        loads=external,
        ghost=GhostStabilisation(mesh, grid.elem, ghost, material)
        if ghost else None, ghost_reserve=GhostStabilisation(
            mesh, grid.elem, DEFAULT_GHOST, material) if reserve else None,
        antilocking=bool(antilocking), D=support_dofs(supports, grid),
        prescribed=prescribed, rigid_bodies=rigid_bodies, rhs=rhs, tol=tol,
        max_iter=max_iter,
        newton=FullStep() if linear else line_search[0],
        modified=newton == "modified" and not linear, reused=False,
        line_search=None if linear else line_search[1],
        solver=get_solver(solver, mesh.dim()), counters=counters,
        keep_snapshots=keep_snapshots, domain0=domain0,
        dynamics=dynamics, masses=masses,
        scale=(lambda f: f) if dynamics is None
        else (lambda f: dynamics.scale(f * dynamics.duration)),
        initial_cells=None if prescribed is None
        else locate(points.x0)[0])
    logger.info("linear solver: %s", solver if isinstance(solver, str) else
                "auto" if solver is None else
                getattr(solver, "__qualname__", repr(solver)))
    if prescribed is not None:           # grid DOFs that carried material
        run.initially_supported = np.zeros(grid.N, dtype=bool)
        run.initially_supported[grid.dofs.element_dofs[
            :, np.unique(run.initial_cells)]] = True
    step = int(first_step) - 1
    factor = step / nsteps if load_factor is None else float(load_factor)
    increment = 1. / nsteps if increment is None else float(increment)
    smallest = 1. / nsteps / 2 ** max_cutbacks
    if resumed_counters:
        counters.update(resumed_counters)
        if counters["ghost_from_step"] and run.ghost_reserve is not None:
            run.ghost = run.ghost_reserve
    while factor < 1. - 1e-12:
        boundary = (np.floor(factor * nsteps + 1e-9) + 1) / nsteps
        target = min(factor + increment, boundary)
        if target > boundary - 1e-12:
            target = boundary
        try:
            points, record, op = attempt(run, points, factor, target,
                                         step + 1)
        except STEP_FAILURES as err:
            if run.linear or (target - factor) / 2 < smallest * (1 - 1e-9):
                raise type(err)(
                    "{}; no convergence down to a load increment of {:.2e}: "
                    "the last converged state (load factor {:.4f}) is "
                    "attached".format(err, target - factor, factor),
                    state=points, load_factor=factor,
                    history=result.history) from err
            increment = (target - factor) / 2
            logger.warning("step %d: cutting the load increment back to "
                           "%.3e", step + 1, increment)
            continue
        except MPMError as err:              # what a cut-back cannot cure
            err.state, err.load_factor = points, factor
            err.history = result.history
            raise
        except Exception as err:             # a user's material or form
            raise StepFailedError(
                "step {}: {}: {} (the last converged state, load factor "
                "{:.4f}, is attached)".format(step + 1, type(err).__name__,
                                              err, factor),
                state=points, load_factor=factor,
                history=result.history) from err
        step += 1
        factor = target
        if dynamics is not None and dynamics.target_iterations and \
                record.newton_residuals is not None:
            increment = dynamics.adapt(increment, 1. / nsteps, smallest,
                                       len(record.newton_residuals) - 1)
        elif abs(factor - boundary) < 1e-12:
            increment = 1. / nsteps
        record.increment, record.counters = increment, dict(counters)
        result.history.append(record)
        result.points = points
        result.basis = getattr(op, "basis", None)
        if callback is not None:
            callback(record, points)
        logger.info("step %d: load factor %.4f, %s, residual %.2e", step,
                    factor, "{} Newton iterations".format(
                        len(record.newton_residuals) - 1) if not run.linear
                    else "{} free DOFs".format(record.n_free_dofs),
                    record.residual)
    return result
