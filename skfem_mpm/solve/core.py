"""The load-step core: one loop for every method, kinematics, material,
stabilisation, load and time integrator.

A load step reads like the seed's Algorithm 2.1 and its finite-deformation
extension, and like Tesserae.jl's implicit step::

    problem = StepProblem(run, points, ...)   locate the points, build the
                                              step's point operator, held
                                              and free DOFs, loads, terms
    newton(problem, ...)                      iterate to equilibrium
    problem.commit(...)                       update the points: state,
                                              positions, domains; record

The pieces are objects the loop calls and never inspects: a method
(:mod:`skfem_mpm.methods.method`), a kinematics
(:mod:`skfem_mpm.mechanics.kinematics`) with its material
(:mod:`skfem_mpm.mechanics.materials`), operator stabilisations (the mean
dilatation wraps the point operator), the loads
(:mod:`skfem_mpm.solve.loads`) and grid terms
(:class:`~skfem_mpm.protocols.GridTerm`: the ghost penalty, the follower
pressure, inertia, a user's), listed in :data:`GRID_TERMS`; the step
problem (:mod:`skfem_mpm.solve.problem`) and the Newton driver
(:func:`skfem_mpm.solve.newton.newton`) are described there.

A linear step (small strain, elastic) takes exactly one linear solve: the
iteration's first residual is the out-of-balance force
``f_ext(n+1) - f_int(sigma_n)`` (``rhs="residual"``) or, the seed's literal
scheme, the load increment ``f_ext(n+1) - f_ext(n)`` (``rhs="increment"``,
which leaves the out-of-balance force of earlier steps uncorrected: its
residual is reported, not enforced).  A nonlinear step iterates
Newton-Raphson with the consistent tangent, its full steps shortened where
one would invert a point (:mod:`skfem_mpm.solve.newton`); a step whose
Newton loop fails walks :data:`RETRY_LADDER` at the same load increment
(full Newton after modified Newton, the ghost penalty of ``ghost="auto"``,
Armijo backtracking, a stabilised tangent) and only then is cut back.

"""
import logging
from contextlib import contextmanager
from typing import Callable, NamedTuple, Optional, Sequence

import numpy as np
from numpy import ndarray
from skfem import Basis
from skfem.assembly import Dofs
from skfem.element import Element, ElementVector
from skfem.mesh import Mesh
from skfem.quadrature import get_quadrature

from ..errors import (InvalidInputError, InversionError,
                      MPMError, NewtonDivergenceError, NumericalError,
                      SingularTangentError, StepFailedError)
from ..mechanics.forms import as_body_force
from ..mechanics.kinematics import KINEMATICS, make_kinematics
from ..mechanics.materials import at_points, initial_state, is_plastic
from ..memory import (GRID_BYTES_PER_CELL, RUN_BYTES_PER_POINT,
                      STEP_RECORD_BYTES, refuse_beyond_memory)
from ..methods.assembly import ElementPattern
from ..methods.method import METHODS, make_method
from ..protocols import GridTerm
from ..quadrature.locate import Locator, point_locator
from ..quadrature.points import MaterialPoints
from ..stabilisation.ghost import GhostStabilisation
from ..stabilisation.volumetric import MeanDilatation
from .backends import get_solver
from .dynamics import Dynamics, InertiaTerm
from .linear import support_dofs
from .loads import ExternalLoads, FollowerPressure
from .newton import FullStep, make_line_search, newton as newton_driver
from .problem import STABILISATION, StepProblem
from .results import Result
from .rigid import check_rigid_bodies, warn_stiff_smooth_bodies

logger = logging.getLogger(__name__)

__all__ = ["simulate", "RHS", "STABILISATION", "DEFAULT_GHOST",
           "GRID_TERMS", "RETRY_LADDER"]

#: the right-hand sides of a linear step (``rhs=``): the out-of-balance
#: force, or the seed's literal load increment
RHS = ("residual", "increment")
# failures of a step that a retry or a smaller load increment may cure
STEP_FAILURES = (NewtonDivergenceError, InversionError, NumericalError,
                 SingularTangentError)
#: Newton's tangent: refactorised every iteration, or kept over a step
NEWTON = ("full", "modified")
ADAPTIVE_MODIFIED = (
    "newton='modified' with an adaptive time step (target_iterations): the "
    "time step adapts to the Newton iterations, which modified Newton's "
    "linear convergence multiplies, so it would keep halving; use "
    "newton='full' or a fixed time step")
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


class RunCache:
    """What a run keeps from step to step to save work, never state: the
    free-free gather map of a step's tangent (``condensation``) and the
    active cells and held DOFs last checked for rigid-body modes
    (``held``)."""

    def __init__(self):
        self.condensation, self.held = None, None


class Run:
    """What stays fixed over a run: the grid, the pieces, the grid terms
    and the settings (keyword attributes), and :class:`RunCache`
    (``cache``).  A term may change itself over a run (the ghost penalty
    held in reserve is switched on by the retry ladder); nothing else
    changes."""

    def __init__(self, **kwargs):
        self.__dict__.update(kwargs)
        self.cache = RunCache()


def ghost_term(run: Run) -> Optional[GridTerm]:
    """The ghost penalty of ``ghost=gamma``, or the one ``ghost="auto"``
    holds in reserve (:data:`DEFAULT_GHOST`)."""
    if run.ghost:
        return GhostStabilisation(run.mesh, run.grid.elem, run.ghost,
                                  run.material)
    if run.ghost_reserve:
        return GhostStabilisation(run.mesh, run.grid.elem, DEFAULT_GHOST,
                                  run.material, active=False)
    return None


def follower_term(run: Run) -> Optional[GridTerm]:
    """Pressures on the trial surface (finite deformation)."""
    return FollowerPressure(run.loads) if run.loads.follows else None


def inertia_term(run: Run) -> Optional[GridTerm]:
    """Implicit time integration (``dynamics=``)."""
    return None if run.dynamics is None else InertiaTerm(run.dynamics,
                                                         run.masses)


#: the built-in grid terms, each ``factory(run) -> GridTerm or None``, in
#: the order their contributions are summed (a user's ``terms=`` follow)
GRID_TERMS = (ghost_term, follower_term, inertia_term)


def mean_dilatation(op, points):
    """The step's point operator with mean dilatation (B-bar)."""
    return MeanDilatation(op, points.volume)


class Attempt(NamedTuple):
    """One way of trying a load step: with the run's first line search
    (``"first"``) or its retry search (``"retry"``), modified Newton
    allowed, the tangent stabilised."""
    search: str
    modified: bool
    stabilise: bool


FIRST = Attempt("first", True, False)


def load_step(run: Run, points: MaterialPoints, f_old: float, f_new: float,
              step: int, how: Attempt = FIRST, report: dict = None):
    """One load step from the converged state ``points``, from load factor
    ``f_old`` to ``f_new``, tried ``how``: build the step problem, drive
    Newton, commit.  Returns the new state, the step's record and its
    point operator; ``report`` receives what the Newton driver reports."""
    problem = StepProblem(run, points, f_old, f_new, step)
    strategy = run.newton if how.search == "first" else \
        run.line_search or run.newton
    found = newton_driver(
        problem, problem.du0, strategy.start(), max_iter=run.max_iter,
        modified=run.modified and how.modified and not how.stabilise,
        stabilise=how.stabilise, single_solve=run.rhs == "increment",
        report=report)
    new, record = problem.commit(found.trial, found.du, found.residuals)
    return new, record, problem.op


class Rung(NamedTuple):
    """A rung of the retry ladder: where it ``applies(run, reused)`` (the
    failed attempt's factorisation served again: modified Newton), try the
    step again ``how``, or (``how=None``) ``change(run, step, failure)``
    the run and walk the ladder again from the first attempt."""
    what: str
    applies: Callable
    how: Optional[Attempt]
    change: Optional[Callable] = None


def switch_ghost_on(run: Run, step: int, failure):
    """The reserve ghost penalty on for the rest of the run."""
    for term in run.terms:
        if isinstance(term, GhostStabilisation) and not term.active:
            term.switch_on()
            run.counters["ghost_from_step"] = step
            logger.warning("%s; switching the ghost penalty on (gamma %g) "
                           "for the rest of the run", failure, term.gamma)


def ghost_in_reserve(run: Run, reused: bool) -> bool:
    return any(isinstance(term, GhostStabilisation) and not term.active
               for term in run.terms)


#: what a failed nonlinear step tries next at the same load increment, in
#: order, each rung logged: full Newton where modified Newton's factorisation
#: had served again; the ghost penalty of ``ghost="auto"`` for the rest of
#: the run (points giving nodes a sliver of support make Newton cycle: the
#: commonest failure); the line search (:mod:`skfem_mpm.solve.newton`; the
#: equilibrium it converges to is the step's, though a run's path of
#: cut-backs, and so its answer, can differ); the tangent stabilised
#: (zero-energy modes not refused as singular), with the line search.
#: After the last, the load increment is cut back.
RETRY_LADDER = (
    Rung("full Newton", lambda run, reused: reused,
         Attempt("first", False, False)),
    Rung("the ghost penalty", ghost_in_reserve, None, switch_ghost_on),
    Rung("the line search", lambda run, reused: run.line_search is not None,
         Attempt("retry", False, False)),
    Rung("the tangent stabilised by {:.0e} of its diagonal".format(
        STABILISATION), lambda run, reused: True,
        Attempt("retry", False, True)),
)


def attempt(run: Run, points: MaterialPoints, f_old: float, f_new: float,
            step: int):
    """A load step, retried along :data:`RETRY_LADDER` when Newton fails
    in a nonlinear step; the last rung's failure is raised."""
    how, rungs = FIRST, iter(RETRY_LADDER)
    while True:
        report = {}
        try:
            with numerical_failures(step):
                return load_step(run, points, f_old, f_new, step, how,
                                 report)
        except STEP_FAILURES as failure:
            if run.linear:
                raise
            for rung in rungs:
                if rung.applies(run, report.get("reused", False)):
                    break
            else:
                raise
            if rung.how is None:
                rung.change(run, step, failure)
                how, rungs = FIRST, iter(RETRY_LADDER)
            else:
                logger.warning("%s; retrying with %s", failure, rung.what)
                how = rung.how


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


def check_terms(terms) -> list:
    """A user's grid terms: :class:`~skfem_mpm.protocols.GridTerm`
    objects (or one)."""
    terms = [terms] if isinstance(terms, GridTerm) else list(terms)
    for k, term in enumerate(terms):
        if not isinstance(term, GridTerm):
            raise InvalidInputError(
                "terms[{}] must be a GridTerm (skfem_mpm.protocols), got "
                "{!r}".format(k, term))
    return terms


def advance(run: Run, result: Result, nsteps: int, step: int, factor: float,
            increment: float, smallest: float,
            callback: Optional[Callable]) -> Result:
    """The load steps of ``run`` from ``step`` (done) at load factor
    ``factor`` to the end, each of ``increment`` where it converges, cut
    back (halved) down to ``smallest`` where it does not; the history,
    points and basis into ``result``.  A failure raises with the last
    converged state attached."""
    points, dynamics = result.points, run.dynamics
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
        record.increment, record.counters = increment, dict(run.counters)
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
             newton: str = "full", terms: Sequence = ()) -> Result:
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
    terms
        Grid terms of one's own (:class:`~skfem_mpm.protocols.GridTerm`,
        or one): forces, loads and matrices added to every step's balance
        after the built-in ones (:data:`GRID_TERMS`).

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
        mesh=mesh, dim=mesh.dim(), grid=grid, method=piece, linear=linear,
        kinematics=make_kinematics(kinematics, material, mesh.dim(), counters,
                                   total_lagrangian=method == "fem"),
        loads=external, material=material, ghost=ghost,
        ghost_reserve=reserve,
        operator_wrappers=(mean_dilatation,) if antilocking else (),
        D=support_dofs(supports, grid),
        prescribed=prescribed, rigid_bodies=rigid_bodies, rhs=rhs, tol=tol,
        max_iter=max_iter,
        newton=FullStep() if linear else line_search[0],
        modified=newton == "modified" and not linear,
        line_search=None if linear else line_search[1],
        solver=get_solver(solver, mesh.dim()), counters=counters,
        keep_snapshots=keep_snapshots, domain0=domain0,
        dynamics=dynamics, masses=masses,
        scale=(lambda f: f) if dynamics is None
        else (lambda f: dynamics.scale(f * dynamics.duration)),
        initial_cells=None if prescribed is None
        else locate(points.x0)[0])
    run.terms = [term for term in (
        factory(run) for factory in GRID_TERMS) if term is not None]
    run.terms += check_terms(terms)
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
        if counters["ghost_from_step"]:
            for term in run.terms:          # a switched-on ghost stays on
                if isinstance(term, GhostStabilisation):
                    term.switch_on()
    return advance(run, result, nsteps, step, factor, increment, smallest,
                   callback)
