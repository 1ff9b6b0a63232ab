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

A linear step (small strain, elastic) takes one linear solve (more where
the residual is still above the tolerance, until it meets the round-off
of the arithmetic, :data:`~skfem_mpm.solve.newton.CORRECTION_ROUNDOFF`,
warned): the iteration's first residual is the out-of-balance force
``f_ext(n+1) - f_int(sigma_n)`` (``rhs="residual"``) or, the seed's literal
scheme, the load increment ``f_ext(n+1) - f_ext(n)`` (``rhs="increment"``,
which leaves the out-of-balance force of earlier steps uncorrected: its
residual is reported, not enforced).  A nonlinear step iterates
Newton-Raphson with the consistent tangent, its full steps shortened where
one would invert a point (:mod:`skfem_mpm.solve.newton`); a step whose
Newton loop fails walks :data:`RETRY_LADDER` at the same load increment
(full Newton after modified Newton, Armijo backtracking, the ghost penalty
of ``ghost="auto"`` (first where grid nodes held by slivers moved
absurdly), a stabilised tangent) and only then is cut back.

"""
import logging
import re
from contextlib import contextmanager
from typing import Callable, NamedTuple, Optional, Sequence

import numpy as np
from numpy import ndarray
from skfem.assembly import Dofs
from skfem.element import Element, ElementVector
from skfem.mesh import Mesh
from skfem.quadrature import get_quadrature

from ..kernels import run_clock
from ..errors import (ContactError, GridMotionError, HeldSupportError,
                      InvalidInputError, InversionError,
                      PointsOutsideGridError, UnsupportedElementError,
                      MPMError, NewtonDivergenceError,
                      NonFiniteGridTermError, NonFiniteMaterialError,
                      NumericalError,
                      SingularSystemError, SingularTangentError,
                      StepFailedError,
                      StepTooLongError, UnsettledContactError,
                      check_choice, check_int)
from ..mechanics.forms import as_body_force
from ..mechanics.initial_stress import (derive_elastic_state,
                                        warn_carried_from_finite)
from ..mechanics.kinematics import KINEMATICS, make_kinematics
from ..mechanics.materials import (at_points, bodies_words,
                                   initial_state, is_plastic,
                                   warn_empty_bodies)
from ..memory import (GRID_BYTES_PER_CELL, RUN_BYTES_PER_POINT,
                      STEP_RECORD_BYTES, refuse_beyond_memory)
from ..methods.assembly import ElementPattern
from ..methods.bspline import (check_uniform_axes, on_the_knots,
                               single_point_splines,
                               warn_loaded_point_splines)
from ..methods.method import (DOMAIN_METHODS, METHODS, PointMethod,
                             make_method)
from ..protocols import GridTerm, of_package
from ..methods.gimp import single_point_domains
from ..methods.fields import FieldLocator, Fields, extended_mesh, tile_dofs
from ..quadrature.grid import GridBasis
from ..quadrature.locate import point_locator, tensor_grid, using_kernels
from ..quadrature.mapping import fresh_mapping
from ..quadrature.points import MaterialPoints
from ..spelling import setting
from ..stabilisation.ghost import GhostStabilisation
from ..stabilisation.settings import Stabilisation, warn_volumetric_locking
from ..stabilisation.fbar import IncrementFbar
from ..stabilisation.volumetric import (MeanDilatation, per_axis_words,
                                       points_per_cell_axis,
                                       warn_sparse_spline_points)
from .backends import get_solver
from .body_contact import BodyContact, check_contacts
from .contact import CellValues, contact_term, linear_gimp
from .dynamics import Dynamics, InertiaTerm, scheme_for
from .grid_checks import check_grid
from .linear import support_dofs, warn_interior_supports
from .loads import (ExternalLoads, FollowerPressure, GridLoad, Pressure,
                    Traction, check_exposed, check_load_ramp, in_full_words)
from .newton import (CORRECTION_ROUNDOFF, FullStep, NewtonOptions,
                     newton as newton_driver)
from .options import (BodyForce, Options, Prescribed, Resume, check_ramp,
                      translate_aliases)
from .obstacles import check_obstacles
from .problem import STABILISATION, STABILISATION_FLOOR, StepProblem
from .motion import held_motion
from .results import PHASES, Result, StepRecord
from .rigid import (RigidBody, check_rigid_bodies, warn_rigid_cells,
                    warn_stiff_smooth_bodies)
from .rotation import SmallStrainRange
from .fixed_domains import FixedDomainsRange

logger = logging.getLogger(__name__)

__all__ = ["simulate", "STABILISATION", "DEFAULT_GHOST",
           "SMALL_STRAIN_GHOST", "GRID_TERMS", "RETRY_LADDER"]

#: the factor within which the stalled residuals of a step's attempts at
#: an increment and at half of it count as one floor (:func:`stall_floor`)
STALL_CHANGE = 1.5

# failures of a step that a retry or a smaller load increment may cure
STEP_FAILURES = (NewtonDivergenceError, InversionError, NumericalError,
                 SingularTangentError, ContactError)
ADAPTIVE_MODIFIED = (
    "newton='modified' with an adaptive time step (target_iterations): the "
    "time step adapts to the Newton iterations, which modified Newton's "
    "linear convergence multiplies, so it would keep halving; use "
    "newton='full' or a fixed time step")
#: Newton solves of one load step at the most while grid terms settle
#: their constraints (:meth:`~skfem_mpm.protocols.GridTerm.settle`)
SETTLE_ROUNDS = 30
#: the relative residual at which a step's first Newton solve stops where
#: grid terms may move their constraints after it (contact's
#: augmented-Lagrangian rounds); the solves after it go on to the
#: tolerance
SETTLE_RESIDUAL = 1e-3
#: the distance from settling (a term's
#: :attr:`~skfem_mpm.protocols.GridTerm.off_by`, in its tolerances) from
#: which a solve after an augmented-Lagrangian update (or after contact
#: pairs joined, their penetration all on the penalty) also stops at
#: :data:`SETTLE_RESIDUAL`: the update after it is certain, and the
#: solve's error in the penetration, about the loose residual times the
#: penalty's penetration under the whole load, is a hundredth of the
#: update's (two bodies in contact: the first update 1e3 tolerances off,
#: the second 5.4; 4 Newton iterations instead of 5)
FAR_OFF = 100.
#: the halvings of a step's increment after which a step that failed at
#: each with its contact unsettled by an obstacle pushing into held nodes
#: (:class:`~skfem_mpm.errors.HeldSupportError`) stops the run: the share
#: on held nodes is the geometry's, unchanged by a cut-back (88% at every
#: increment of a wall against a block on a base held in every component,
#: trial 63), which only halves the penetration the rounds must close; a
#: run cut back past it ran 135 steps of 2e-3 in 3D and failed after 557 s,
#: its 2D analogue 159 steps to a wall force 12 times the sliding base's
#: (the block of trial 60 converges after 3)
HELD_HALVINGS = 4
#: the methods whose ghost penalty ``ghost="auto"`` switches on from the
#: start with contacts between bodies: their domains, or the cubic
#: splines' two rows of nodes, reach beyond a body's surface onto nodes of
#: its field barely held (two stacked blocks with the cubic splines at the
#: points: stresses 35% off, 1.5% with it; a pile of the averaged ones
#: failed at 2.5% of its load, 3.91 mm with it against the quadratic
#: splines' 3.98)
SLIVER_METHODS = ("ugimp", "cpgimp", "bspline3", "bspline3-gimp")
#: the methods whose ghost penalty ``ghost="auto"`` (at
#: :data:`DEFAULT_GHOST`) switches on at the first step where bodies in
#: contact meet inside a grid cell (one holds points of both): two
#: stacked blocks with the quadratic splines at the points, 3 a cell, the
#: interface a third of a cell above a grid line, had the upper block's
#: second row in tension, 1.52 rho g H off (0.16 with it); on from the
#: start, a pile in soil whose sides lie on grid lines settled 10% less
#: than half a cell off them (0.01% without, 0.5% off the lines)
INTERFACE_METHODS = ("bspline",)
#: with ``NewtonOptions(grow_back=True)`` a cut-back's increment grows
#: back (:func:`grown_increment`) by ``GROWTH`` after ``EASY_STEPS``
#: sub-steps in a row that each converged in at most ``EASY_SHARE`` of
#: ``max_iter`` Newton iterations (:func:`easy_sub_step`).  Doubling
#: undoes a halving: the increments stay a whole step's halvings, the
#: sizes a cut-back had tried.  Two
#: sub-steps, not one (Abaqus's rule too): a grown increment that fails
#: costs the retry ladder's rungs and a cut-back, several times
#: ``max_iter`` iterations.  Half of ``max_iter``, as the adaptive time
#: step doubles after at most half its ``target_iterations``
#: (:meth:`~skfem_mpm.Dynamics.adapt`): a trial's footing on Mohr-Coulomb
#: soil (``max_iter`` 25) took 12 to 29 iterations at its hard sub-steps
#: and whole steps, 7 to 12 at the 128 sub-steps of 3.9e-4 it crawled
#: after 7 cut-backs (Abaqus's fixed 5 would never have grown them).
#: Without it, a run's first ``EASY_STEPS`` such sub-steps in a row are
#: logged once with the option's name (its path may fail where the
#: crawl completes: that footing, later, at 0.86)
EASY_STEPS = 2
EASY_SHARE = .5
GROWTH = 2.
#: the counter of a run's easy sub-steps in a row at a cut-back's increment
#: (:func:`grown_increment`), there from its first cut-back with
#: ``grow_back`` (never without): the counters carry it through a resume
EASY = "easy_sub_steps"
#: seconds: the steps left of a run that would take longer, at the pace of
#: its fastest step so far, are announced by a warning (once)
LONG_RUN = 600.
#: how many times as far per load increment as its stiffest step before
#: the last converged step of a failed load-controlled plastic run moved
#: the body for the error to call it a collapse (:func:`collapse_hint`)
COLLAPSE_SOFTENING = 5.
#: the ghost penalty that ``ghost="auto"`` switches on when a
#: finite-deformation step of moving points fails
DEFAULT_GHOST = .1
#: the ghost penalty that ``ghost="auto"`` switches on in small strain
#: (absurd grid motion, domains past a support): there it only has to tie
#: nodes that slivers hold, and it acts on each step's increment, so its
#: force grows with the step: a GIMP footing's pressure over Prandtl's
#: was +18% and +13.6% with 0.1 switched on at step 2 of 10 and of 40
#: steps, +9.1% and +8.8% with 1e-3 (+5.4% where it never switched on)
SMALL_STRAIN_GHOST = 1e-3


def vector_element(elem: Element) -> Element:
    """``elem`` as a vector element (displacements have dim components)."""
    return elem if isinstance(elem, ElementVector) else ElementVector(elem)


def cell_size(mesh: Mesh) -> float:
    """The grid's representative cell size, ``(V / N)^(1/d)`` of its
    bounding box."""
    extent = np.ptp(mesh.p, axis=1)
    return float(np.prod(extent) / mesh.nelements) ** (1. / mesh.dim())


def grid_parts(mesh: Mesh, elem: Element, copies: int = 1):
    """What a run keeps of the grid: the scalar element, the vector grid
    basis (supports, DOF locations), the scalar ``Dofs`` for the
    material-point bases and the vector stiffness pattern (of ``copies``
    copies of a grid: :func:`~skfem_mpm.methods.fields.extended_mesh`)."""
    scalar = elem.elem if isinstance(elem, ElementVector) else elem
    try:
        grid = GridBasis(mesh, vector_element(elem))
    except ValueError as err:             # another reference domain
        raise UnsupportedElementError(
            "the element {} does not fit the mesh {} ({})".format(
                type(scalar).__name__, type(mesh).__name__, err)) from err
    return (scalar, grid, Dofs(mesh, scalar),
            ElementPattern(grid.dofs.element_dofs, grid.N, copies))


def grid_fields(mesh: Mesh, elem: Element, field: ndarray, locate) -> Fields:
    """The run's :class:`~skfem_mpm.methods.fields.Fields`: copies of the
    grid, one per field (``field``: the field of each point)."""
    big = extended_mesh(mesh, int(field.max()) + 1)
    scalar, grid, dofs, pattern = grid_parts(big, elem,
                                             int(field.max()) + 1)
    if dofs.N != big.nvertices:
        raise UnsupportedElementError(
            "contacts between bodies need an element with DOFs at the "
            "vertices only (linear), got {}".format(type(scalar).__name__))
    return Fields(big, dofs, pattern,
                  FieldLocator(locate, field, mesh.nelements), field,
                  mesh.nvertices, mesh.nelements, grid)


def check_run_input(mesh: Mesh, points: MaterialPoints, nsteps: int,
                    keep_snapshots: bool = False):
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` for a step count
    that is not a positive integer, points of another dimension, or a run
    this machine's memory cannot hold (the grid, the points and the
    history of ``nsteps`` steps)."""
    check_int("nsteps", nsteps, 1)
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


class RunCache:
    """What a run keeps from step to step to save work, never state: the
    free-free gather map of a step's tangent (``condensation``) and the
    active cells and held DOFs last checked for rigid-body modes
    (``held``)."""

    def __init__(self):
        self.condensation, self.held = None, None


class Run:
    """A run's grid, pieces, grid terms (``terms``) and settings (keyword
    attributes), fixed once built, and what changes over the run: the
    counters (``counters``), the terms' own state (the ghost penalty held
    in reserve, switched on by the retry ladder), :class:`RunCache`
    (``cache``) and the warnings given once a run (``warned``, their
    keys)."""

    def __init__(self, **kwargs):
        self.__dict__.update(kwargs)
        self.cache = RunCache()
        self.warned = set()
        #: the seconds per phase of failed attempts not yet recorded
        #: (:func:`book_failed_attempt`)
        self.failed_attempts = {}


def ghost_term(run: Run) -> Optional[GridTerm]:
    """The ghost penalty of ``ghost=gamma``, or the one ``ghost="auto"``
    holds in reserve: :data:`DEFAULT_GHOST`, or :data:`SMALL_STRAIN_GHOST`
    in small strain where no contact between bodies of the methods below
    is declared.  With contacts between bodies it is on from the start
    for GIMP and the cubic splines (:data:`SLIVER_METHODS`): each body's
    domains reach a sliver of the cells across an interface on a grid
    line, on its own field, and the nodes there, barely held, drew 9% of
    the stress of two pressed blocks after the first step (0.2% after 6
    steps with it); for the quadratic splines at the points
    (:data:`INTERFACE_METHODS`) it goes on at the first step where a cell
    holds points of two bodies (stacked blocks, the interface inside a
    cell: 1.5 rho g H off without it)."""
    # with contacts between bodies a cell that only domains reach takes the
    # stiffest point of its own field's body, not of every body
    field_cells = run.user_grid.mesh.nelements if run.contacts else None
    if run.ghost:
        return GhostStabilisation(run.mesh, run.grid.elem, run.ghost,
                                  run.material, field_cells=field_cells)
    if run.ghost_reserve:
        slivers = bool(run.contacts) and run.method.name in SLIVER_METHODS
        if slivers:
            run.counters["ghost_from_step"] = 1
            logger.info("contact between bodies with %s: the ghost penalty "
                        "on from the start (gamma %g)", run.method.name,
                        DEFAULT_GHOST)
        shared = bool(run.contacts) and \
            run.method.name in INTERFACE_METHODS
        gamma = DEFAULT_GHOST if run.finite or slivers or shared else \
            SMALL_STRAIN_GHOST
        return GhostStabilisation(
            run.mesh, run.grid.elem, gamma, run.material, active=slivers,
            obstacles=run.obstacles if run.method.name in (
                "ugimp", "cpgimp") else (), field_cells=field_cells,
            shared_cells=shared)
    return None


def follower_term(run: Run) -> Optional[GridTerm]:
    """Pressures on the trial surface (finite deformation)."""
    return FollowerPressure(run.loads) if run.loads.follows else None


def body_contact_term(run: Run) -> Optional[GridTerm]:
    """Contact between bodies on their fields (``contacts=``)."""
    if not run.contacts:
        return None
    return BodyContact(run.contacts, run.body_field, run.mesh,
                       run.grid.elem.elem, run.user_grid.mesh.nvertices,
                       run.cell_size, run.material, run.domain0, run.finite,
                       run.counters,
                       weights=getattr(run.method, "weights_at", None),
                       cells=run.user_grid.mesh.nelements,
                       gimp=linear_gimp(run.method), locate=run.grid_locate)


def obstacle_term(run: Run) -> Optional[GridTerm]:
    """Contact with rigid obstacles (``obstacles=``)."""
    if not run.obstacles:
        return None
    return contact_term(run.obstacles, run.cell_size, run.material,
                        run.domain0, total_lagrangian=not run.method.moves,
                        moves=run.method.moves,
                        finite=run.finite, counters=run.counters,
                        initial_scale=run.scale(0.),
                        cell_values=CellValues(run.mesh,
                                               run.grid.elem.elem),
                        resumed=run.resumed)


def inertia_term(run: Run) -> Optional[GridTerm]:
    """Implicit time integration (``dynamics=``)."""
    return None if run.dynamics is None else InertiaTerm(run.dynamics,
                                                         run.masses)


def rotation_term(run: Run) -> Optional[GridTerm]:
    """The points' rotation kept, and warned when large, and their strain
    warned when large, in small strain (:mod:`skfem_mpm.solve.rotation`;
    in 1D the strain alone)."""
    return None if run.finite else SmallStrainRange(run.dim)


def fixed_domains_term(run: Run) -> Optional[GridTerm]:
    """uGIMP's fixed domains warned when the points' volumes have left
    them, in finite deformation (:mod:`skfem_mpm.solve.fixed_domains`)."""
    piece = getattr(run.method, "piece", run.method)
    return FixedDomainsRange() if run.finite and piece.name == "ugimp" \
        else None


#: the built-in grid terms, each ``factory(run) -> GridTerm or None``, in
#: the order their contributions are summed (a user's terms, items of
#: ``loads``, follow; terms that weigh the balance in time come last)
GRID_TERMS = (ghost_term, follower_term, obstacle_term, body_contact_term,
              rotation_term, fixed_domains_term, inertia_term)


def mean_dilatation(op, points):
    """The step's point operator with mean dilatation (B-bar)."""
    return MeanDilatation(op, points.volume)


def increment_fbar(op, points):
    """The step's point operator with F-bar on the increment (finite
    deformation, points that move: :mod:`skfem_mpm.stabilisation.fbar`)."""
    return IncrementFbar(op, points.volume)


class Attempt(NamedTuple):
    """One way of trying a load step: with the run's first line search
    (``"first"``) or its retry search (``"retry"``), modified Newton
    allowed, the tangent stabilised, its diagonal floored
    (:data:`~skfem_mpm.solve.problem.STABILISATION_FLOOR`)."""
    search: str
    modified: bool
    stabilise: bool
    floored: bool = False


FIRST = Attempt("first", True, False)
#: the retry with the line search (which, once it has carried a step,
#: starts the later ones: no rung then tries it again)
LINE_SEARCH = Attempt("retry", False, False)


def load_step(run: Run, points: MaterialPoints, f_old: float, f_new: float,
              step: int, how: Attempt = FIRST, report: dict = None):
    """One load step from the converged state ``points``, from load factor
    ``f_old`` to ``f_new``, tried ``how``: build the step problem, drive
    Newton until the terms' constraints settle (:data:`SETTLE_ROUNDS` at
    the most: contact's augmented-Lagrangian updates), commit.  Returns the
    new state, the step's record and its point operator; ``report``
    receives what the Newton driver reports."""
    problem = StepProblem(run, points, f_old, f_new, step)
    run.loads.check_held_share(problem.op, points, problem.fixed, step,
                               run.warned)
    if report is not None:      # its seconds, should it fail
        report["timings"] = problem.t
    problem.floored = how.floored
    searches = how.search == "retry" or bool(
        run.counters["line_search_from_step"])
    strategy = (run.line_search or run.newton) if searches else run.newton
    (du, response), seed, before = problem.start(how.stabilise), None, []
    iterations = 0
    # a term that may move its constraint after Newton (contact's
    # augmented Lagrangian) has the step solved again from the last
    # increment, and the kinematics' response to it; the first round
    # stops at SETTLE_RESIDUAL (the constraint may move after it anyway),
    # and so does each round after it while a term is FAR_OFF its
    # constraints; the rounds after those go on to the tolerance (a
    # floor's step at 1e5 points: 4 iterations and 5 material updates
    # instead of 5 and 7)
    keep = how.modified and not how.stabilise and problem.settles
    loose = problem.settles and SETTLE_RESIDUAL > run.tol
    try:
        for rounds in range(SETTLE_ROUNDS):
            found = newton_driver(
                problem, du, strategy.start(), max_iter=run.max_iter,
                modified=run.modified and how.modified and not how.stabilise,
                stabilise=how.stabilise, single_solve=run.rhs == "increment",
                report=report, predict=rounds == 0, keep=keep, seed=seed,
                tol=SETTLE_RESIDUAL if loose else None,
                relative=rounds > 0, response=response)
            iterations += len(found.residuals) - 1
            settled = problem.settled(found.trial, found.du)
            if settled and (not loose or problem.converged(found.trial)):
                break
            # the loose round settled: on to the tolerance by Newton's own
            # iterations (quadratic from a small residual); it did not: the
            # round after the update takes its first direction by the kept
            # tangent (the constraint moved a little), unless a term changed
            # its constraints (two bodies' pairs joined at a step's end: the
            # kept tangent, blind to them, sent the residual from 9 to 937
            # and the step took 25 iterations where it takes 9)
            aged = seed is not None and len(found.residuals) <= 2
            du, seed = found.du, None if settled or problem.reshaped \
                or aged else found.factorised
            response = found.trial.response
            loose = loose and not settled and max(
                getattr(term, "off_by", 0.)
                for term in problem.unsettled) >= FAR_OFF
            # the step's record shows every round's residuals in order; a
            # solve that settled at the loose residual and goes on is one
            # solve (its last residual is where the next one starts)
            before = before + (found.residuals[:-1] if settled
                               else found.residuals)
            found = None
        else:
            words = unsettled_words(problem)
            raise (HeldSupportError if any(
                getattr(term, "held_cause", False)
                for term in problem.unsettled) else UnsettledContactError)(
                "step {}: contact did not settle within the contacts' "
                "tolerances in {} augmented-Lagrangian rounds{}".format(
                    step, SETTLE_ROUNDS, words))
    except STEP_FAILURES:
        if report is not None:      # for the retry ladder
            # the exact tangent refused as singular (not asked for)
            report["stabilised"] = problem.stabilised and not how.stabilise
            report["collapsed"] = problem.collapsed
        raise
    if (not run.linear or run.rhs == "residual") and \
            not problem.converged(found.trial):
        warn_round_off(run, step, found.trial.residual)
    # memory: no factorisation alive in the commit
    seed, found = None, found._replace(factorised=None)
    new, record = problem.commit(found.trial, found.du,
                                 before + found.residuals)
    if record.newton_residuals is not None:
        record.newton_iterations = iterations
    record.timings = {phase: seconds + run.failed_attempts.get(phase, 0.)
                      for phase, seconds in record.timings.items()}
    run.failed_attempts = {}
    return new, record, problem.op


def book_failed_attempt(run: Run, timings: dict) -> None:
    """Keep a failed attempt's seconds per phase (``timings``) for the
    record of the step that next converges, its retry or a cut-back's
    sub-step: a trial's step cut back took 48.8 s of wall time and
    recorded 5.08, and 25% of a 3D run showed as "set-up and output"
    where its first step's failed attempt had spent 7 s."""
    for phase, seconds in timings.items():
        run.failed_attempts[phase] = run.failed_attempts.get(phase, 0.) \
            + seconds


def unsettled_words(problem) -> str:
    """Why a step's contact did not settle: the causes its unsettled
    terms name (:meth:`~skfem_mpm.protocols.GridTerm.unsettled_hint`),
    and, where one of them names none, the penalty's advice (an obstacle
    pushing held DOFs named its cause, and a contact between bodies
    failing in the same step was left without a word)."""
    hints = [term.unsettled_hint() for term in problem.unsettled]
    return "".join(hints) + (
        "" if hints and all(hints) else
        "{}each round closes the penetration by about the body's "
        "stiffness over the penalty's; raise the penalty (Obstacle("
        "penalty=...), Contact(penalty=...); 100 took a tolerance of 1e-5 "
        "in 9 rounds where 10 took more than 30) or loosen the tolerance"
        .format("; elsewhere " if any(hints) else ": "))


def warn_round_off(run: Run, step: int, residual: float):
    """Say (a warning once a run, then in the log) that a step ended at
    the round-off of its residual, above the tolerance
    (:data:`~skfem_mpm.solve.newton.ROUNDOFF_LIMIT`,
    :data:`~skfem_mpm.solve.newton.CORRECTION_ROUNDOFF`)."""
    first = "round_off" not in run.warned
    run.warned.add("round_off")
    logger.log(logging.WARNING if first else logging.INFO,
               "step %d: the residual %.1e stays above the tolerance %.0e "
               "at the round-off of its arithmetic (the last iteration did "
               "not halve it, and Newton's correction fell below %.0e of "
               "the increment; e.g. a nearly incompressible body): the step "
               "ends there%s", step, residual, run.tol,
               CORRECTION_ROUNDOFF, "; said once a run" if first else "")


#: an ``rhs="increment"`` run ending with an out-of-balance force above
#: this many times the external force is warned about
IMBALANCE = 1.


def warn_imbalance(run: Run, result: Result) -> None:
    """Log a warning where a run of the seed's one-solve scheme
    (``rhs="increment"``) ends with an out-of-balance force above
    :data:`IMBALANCE` times the external force (the last step's
    ``residual``): the scheme never corrects it, and it grows with
    refinement (a trial's 1D column in 20 steps: 1.0 times the load at
    16 elements, 5.9 at 64, 22.9 at 256, without a word)."""
    if run.rhs != "increment" or not result.history:
        return
    residual = result.history[-1].residual
    if not residual > IMBALANCE:
        return
    logger.warning(
        "rhs = 'increment' (the seed's one-solve scheme): the run ends "
        "with an out-of-balance force %.3g times the external force "
        "(StepRecord.residual of step %d), never corrected and growing "
        "with refinement: the points' stresses are the scheme's, but the "
        "grid's nodal forces, reactions and equilibrium are not; "
        "NewtonOptions(rhs='residual'), the default, restores equilibrium "
        "at every step", residual, result.history[-1].step)


class Rung(NamedTuple):
    """A rung of the retry ladder: where it ``applies(run, failure,
    report)`` (what the failed attempt reported: ``"reused"``, its
    factorisation served again, modified Newton; ``"stabilised"``, a solve
    used the stabilised tangent), try the step again ``how``, or (``how=None``)
    ``change(run, step, failure)`` the run and walk the ladder again from
    the first attempt; ``linear``: the rung serves linear steps too."""
    what: str
    applies: Callable
    how: Optional[Attempt]
    change: Optional[Callable] = None
    linear: bool = False


#: what the log says when the retry ladder switches the ghost penalty on
GHOST_CHANGES = ": it stiffens the cut cells"
#: and what it adds for plastic bodies
GHOST_CHANGES_PLASTIC = (", and a plastic limit load can come out 8-13% "
                         "higher with it (2D footings, gamma 0.1; a 3D "
                         "square footing with mean dilatation, its edge "
                         "inside a cell, jumped by 40% at the step it went "
                         "on; docs/robustness.md)")
#: and what it adds for B-splines where the extended splines serve (they
#: are refused with contacts between bodies)
EXTENDED_INSTEAD = "; B-splines need none with " + setting(
    "extended_splines", True) + ", and without it the stresses " \
    "of nodes so barely held go wrong (a block compressed 10% in 20 " \
    "steps, its top inside a cell, switched on at step 17: -2.0 p to " \
    "+0.6 p where -0.96 p is uniform; extended within 1.2%)"


def switch_ghost_on(run: Run, step: int, failure):
    """The reserve ghost penalty on for the rest of the run."""
    instead = EXTENDED_INSTEAD if run.method.name.startswith("bspline") \
        and not run.contacts else ""
    changes = GHOST_CHANGES + (GHOST_CHANGES_PLASTIC
                               if is_plastic(run.material) else "")
    for term in run.terms:
        if isinstance(term, GhostStabilisation) and not term.active:
            term.switch_on()
            run.counters["ghost_from_step"] = step
            logger.warning("%s; switching the ghost penalty on (gamma %g) "
                           "for the rest of the run%s%s", failure,
                           term.gamma, changes, instead)


def line_search_from_now_on(run: Run, step: int):
    """After the line search (alone, or with the stabilised tangent)
    carried a step whose full Newton steps failed, the later steps start
    with it: such a step's neighbours fail the same way (perfectly plastic
    flow under a footing: full steps failed every one of 40 steps, each
    after 25 iterations; a cantilever's sparsely filled cells fail full
    steps again after the stabilised tangent carried one)."""
    run.counters["line_search_from_step"] = step
    logger.info("step %d: the line search carried the step where Newton's "
                "full steps failed; the later steps start with it", step)


def ghost_reserve_held(run: Run) -> bool:
    """Whether the run holds a ghost penalty in reserve (``ghost="auto"``,
    not yet switched on)."""
    return any(isinstance(term, GhostStabilisation) and not term.active
               for term in run.terms)


def ghost_for_slivers(run: Run, failure, report: dict) -> bool:
    """The reserve ghost penalty first where the failure is diagnosed as
    grid nodes held by slivers of material (absurd grid motion,
    :class:`~skfem_mpm.errors.GridMotionError`), or where a linear step
    after the first met a singular stiffness (its supports checked before
    the solve: a user trial's elastic cantilever of standard MPM in small
    strain at P L^2 / E I = 1 ended so at step 5)."""
    return (isinstance(failure, GridMotionError) or run.linear and
            isinstance(failure, SingularTangentError)) \
        and ghost_reserve_held(run)


def ghost_in_reserve(run: Run, failure, report: dict) -> bool:
    """The reserve ghost penalty for any failed step in finite deformation
    or with contacts between bodies on B-splines, once the line search
    (which keeps the step's equations) has failed too.  The splines reach
    a row of nodes beyond a body's surface that its material barely
    holds: a user trial's pile with friction 0.3 (3 x 3 points per cell,
    small strain) failed at every cut-back of its second step, and runs
    with the small-strain penalty (:data:`SMALL_STRAIN_GHOST`)."""
    return (run.finite or bool(run.contacts)
            and run.method.name.startswith("bspline")) \
        and ghost_reserve_held(run)


#: a Newton iteration that came within this many tolerances of
#: equilibrium and failed has stalled (:func:`ghost_for_slivers_held`)
STALLED = 1e3


def ghost_for_slivers_held(run: Run, failure, report: dict) -> bool:
    """The reserve ghost penalty, once the stabilised tangent has failed
    too, where the step met zero-energy modes (its tangent refused as
    singular, also stabilised; or the exact one refused in an attempt
    that did not ask for the stabilisation, ``report["zero_energy"]``,
    and Newton stalled within :data:`STALLED` tolerances of equilibrium
    on the stabilisation's linear rate, ``report["smallest"]``: a
    footing's plastic flow meets such modes too, and its cut-backs carry
    it, 9.8% closer to Prandtl's than with the penalty) or where a term
    ties slivers to a stiff constraint
    (:attr:`~skfem_mpm.protocols.GridTerm.ties_slivers`).  A 3D cpGIMP
    cantilever clamped by a tied obstacle mid-cell failed at every
    cut-back of its second step, and ran with ``ghost=0.1``; a
    bspline-gimp one (2 x 2 points per cell) stalled at 1.1e-8 there on
    the stabilised tangent's linear rate; a 3D cpGIMP block on a Coulomb
    floor mid-cell, slipping at its edges, failed at every cut-back of its
    second step and takes 6 iterations with it (user trial 52).  Also
    where the floored tangent failed with nodes whose stiffness collapsed
    within the step (``report["collapsed"]``, :attr:`~skfem_mpm.solve.
    problem.StepProblem.collapsed`: held by points gone to a plastic
    apex alone): B-splines' row of nodes beyond a body's surface, held by
    its outermost points alone, moved freely where those points sat at
    Mohr-Coulomb's apex (cohesionless soil hung on a wall), and the
    points went back and forth between the apex and the cone with them;
    a cohesionless load scales its answer, so every cut-back failed
    alike (trial 54).  B-splines only: with standard MPM a node of a
    plastic footing's soil collapses alike, and the penalty switched on
    there raised a coarse Prandtl footing's force by 4.9% (a reviewer's;
    it completed without, in cut-backs)."""
    stalled = report.get("zero_energy", False) and report.get(
        "smallest", np.inf) <= STALLED * run.tol
    collapsed = report.get("collapsed", 0) > 0 and \
        run.method.name.startswith("bspline")
    return (isinstance(failure, SingularTangentError) or stalled
            or collapsed or any(term.ties_slivers for term in run.terms)) \
        and ghost_reserve_held(run)


#: what a failed nonlinear step tries next at the same load increment, in
#: order, each rung logged: full Newton where modified Newton's factorisation
#: had served again; the ghost penalty of ``ghost="auto"`` for the rest of the
#: run where grid nodes held by slivers moved absurdly; the line search
#: (:mod:`skfem_mpm.solve.newton`; the equilibrium it converges to is the
#: step's, though a run's path of cut-backs, and so its answer, can differ); in
#: finite deformation, or with contacts between bodies on B-splines, the ghost
#: penalty for the rest of the run (points giving nodes a sliver of support
#: make Newton cycle: a bending beam's commonest failure); the tangent
#: stabilised (zero-energy modes not refused as singular), with the line
#: search; the ghost penalty for the rest of the run where the step met
#: zero-energy modes or a term ties slivers (:func:`ghost_for_slivers_held`).
#: After the last, the load increment is cut back.  The rungs that keep the
#: step's equations come before the one that changes them: with the ghost
#: penalty before the line search, a perfectly plastic footing pushed in finite
#: deformation (B = 16 h) had the penalty on from its first step, where the
#: line search alone carries it, and its pressure rose to 17% above Prandtl's
#: where it stays within 9% (``docs/robustness.md``).
RETRY_LADDER = (
    Rung("full Newton", lambda run, failure, report:
         report.get("reused", False),
         Attempt("first", False, False)),
    Rung("the ghost penalty", ghost_for_slivers, None, switch_ghost_on,
         linear=True),
    Rung("the line search", lambda run, failure, report:
         run.line_search is not None
         and not run.counters["line_search_from_step"], LINE_SEARCH),
    Rung("the ghost penalty", ghost_in_reserve, None, switch_ghost_on),
    Rung("the tangent stabilised by {:.0e} of its diagonal".format(
        STABILISATION), lambda run, failure, report: True,
        Attempt("retry", False, True)),
    Rung("the stabilised tangent's diagonal floored at {:.0e} of its "
         "median".format(STABILISATION_FLOOR),
         lambda run, failure, report: is_plastic(run.material),
         Attempt("retry", False, True, True)),
    Rung("the ghost penalty", ghost_for_slivers_held, None,
         switch_ghost_on),
)


def attempt(run: Run, points: MaterialPoints, f_old: float, f_new: float,
            step: int):
    """A load step, retried along :data:`RETRY_LADDER` when Newton fails
    in a nonlinear step; the last rung's failure is raised.  Contact that
    did not settle (:class:`~skfem_mpm.errors.UnsettledContactError`)
    takes only the rungs that change the step's equations (the ghost
    penalty): the others solve each of its rounds to the same
    equilibrium.  A material's NaN or inf
    (:class:`~skfem_mpm.errors.NonFiniteMaterialError`) takes only the
    rungs that keep them: the ghost penalty cannot mend a model's
    arithmetic (trial 103's NaN switched it on, with its limit-load
    caution).  A failure said before in the step (its
    :func:`failure_key` among the run's ``warned``: a model's
    deterministic NaN, 3 identical warnings at each of 8 cut-backs) is
    logged again at INFO."""
    how, rungs = FIRST, iter(RETRY_LADDER)
    zero_energy = False         # an attempt met zero-energy modes
    stalls = []     # each failed attempt's stalled residual (or None)
    linear = ""     # an attempt's words of a linear rate (newton's report)
    while True:
        report = {"linear": linear}
        try:
            with numerical_failures(step):
                done = load_step(run, points, f_old, f_new, step, how,
                                 report)
            if how.search == "retry" and run.line_search is not None \
                    and not run.counters["line_search_from_step"]:
                line_search_from_now_on(run, step)
            return done
        except STEP_FAILURES as failure:
            book_failed_attempt(run, report.get("timings", {}))
            if isinstance(failure, StepTooLongError) or getattr(
                    failure, "at_start", False):
                raise       # only a shorter step helps; or none does
            zero_energy |= report.get("stabilised", False)
            report["zero_energy"] = zero_energy
            stalls.append(getattr(failure, "stalled", None))
            failure.stalls = list(stalls)
            linear = report.get("linear", "")
            for rung in rungs:
                if (rung.linear or not run.linear) and (
                        rung.how is None or not isinstance(
                            failure, UnsettledContactError)) and (
                        rung.how is not None or not isinstance(
                            failure, (NonFiniteMaterialError,
                                      NonFiniteGridTermError))) and \
                        rung.applies(run, failure, report):
                    break
            else:
                if isinstance(failure, UnsettledContactError):
                    logger.warning("%s; not retried at this increment "
                                   "(the retry ladder's other rungs solve "
                                   "each round to the same equilibrium): "
                                   "cut back while it can be", failure)
                raise
            if rung.how is None:
                rung.change(run, step, failure)
                how, rungs = FIRST, iter(RETRY_LADDER)
            else:
                key = ("retried", step) + failure_key(failure)
                logger.log(logging.INFO if key in run.warned
                           else logging.WARNING,
                           "%s; retrying with %s%s", failure, rung.what,
                           onset_words(run, points, f_old)
                           if rung.how is LINE_SEARCH else "")
                run.warned.add(key)
                how = rung.how


def failure_key(failure: Exception) -> tuple:
    """What makes a failed attempt's warning one said before in its step
    (:func:`attempt`): a material's NaN or inf in the same variable of the
    same method, at whatever points; otherwise the same message."""
    if isinstance(failure, NonFiniteGridTermError):
        return (NonFiniteGridTermError, failure.term, failure.method)
    if isinstance(failure, NonFiniteMaterialError):
        return (NonFiniteMaterialError, failure.material, failure.method,
                failure.variable)
    return (str(failure),)


def onset_words(run: Run, points: MaterialPoints, f_old: float) -> str:
    """What the run's grid terms say of a failed first step from the
    run's start (``f_old`` 0) that the line search retries
    (:meth:`~skfem_mpm.solve.contact.ObstacleContact.onset_hint`:
    material resting on a Coulomb floor, expected), else ``""``."""
    if f_old != 0.:
        return ""
    return "".join(term.onset_hint(points) for term in run.terms
                   if hasattr(term, "onset_hint"))


def stall_floor(stalls, before, increment: float) -> str:
    """Words for a step whose attempts (``stalls``: each one's stalled
    residual, or ``None``) stalled where they stalled at the longer
    increment of ``before`` (``(increment, stalls)`` of the failure
    before it, cut back to this ``increment``), the same attempts, within
    a factor
    :data:`STALL_CHANGE`: a floor of
    the residual that a shorter step does not lower, so not cut back
    again (with ``ghost="auto"`` the reserve penalty is switched on for
    the step instead: it ties thinly held nodes to their neighbours); else
    ``""``.  A trial's c-phi footing stalled at 1.53e-6-1.59e-6 (tolerance
    1e-9) with increments from 3.3e-2 down to 1.3e-4, 8 cut-backs and 3
    minutes, then said "did not converge": its residual sat at two nodes
    one heaved point held beside the footing; with ``ghost=0.1`` it ran
    past that step.

    >>> stall_floor([None, 9.5e-6], (.02, [None, 9.46e-6]), .01)[:40]
    'not cut back further: the attempts stall'
    >>> stall_floor([1.59e-6, None], (.02, [1.58e-6, 9.46e-6]), .01)
    ''
    >>> stall_floor([1e-7, 9.5e-6], (.02, [1.58e-6, 9.46e-6]), .01)
    ''
    """
    if not stalls or before is None or not before[1] or \
            not before[0] > increment or [
            level is None for level in stalls] != [
                level is None for level in before[1]]:
        return ""
    pairs = [(a, b) for a, b in zip(stalls, before[1]) if a is not None]
    if not pairs or not all(max(a, b) <= STALL_CHANGE * min(a, b)
                            for a, b in pairs):
        return ""
    return ("not cut back further: the attempts stalled at the same "
            "residuals (smallest {:.3g}) at increments {:.3g} and {:.3g}: a "
            "floor of the residual that a shorter step does not lower, not "
            "a divergence.  Its likely cause is a force the tangent cannot "
            "balance at round-off of the step's forces or at nodes that "
            "points at a yield surface's apex or corner hold alone (their "
            "stress fixed whatever the nodes do); remedies: a tolerance "
            "above the floor (tol), the ghost penalty (ghost) on thinly "
            "held nodes, or a finer seeding".format(
                min(a for a, _ in pairs), before[0], increment))


def iterations_words(record) -> str:
    """The Newton iterations of a step's ``record`` in words; with the
    rounds of a term's update (contact's augmented Lagrangian), those and
    the residuals too: each round's start with its own first one, no
    iteration, so a step of 9 iterations in 2 rounds records 11 residuals
    (a trial read 10 iterations off them where the log said 9).

    >>> from types import SimpleNamespace as S
    >>> iterations_words(S(newton_iterations=9, newton_residuals=[1.] * 11))
    '9 Newton iterations in 2 rounds, 11 residuals'
    >>> iterations_words(S(newton_iterations=7, newton_residuals=[1.] * 8))
    '7 Newton iterations'
    """
    words = "{} Newton iterations".format(record.newton_iterations)
    residuals = record.newton_residuals
    if residuals is None or record.newton_iterations is None:
        return words
    rounds = len(residuals) - record.newton_iterations
    if rounds <= 1:
        return words
    return words + " in {} rounds, {} residuals".format(rounds,
                                                         len(residuals))


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


def too_soft(run: Run, points: MaterialPoints) -> str:
    """A sentence for a failed run whose body force strains its body by
    more than half elastically, ``|b| H / E`` with ``H`` the body's extent
    along ``b`` and ``E`` the softest point's Young's modulus (units that
    do not match: E in Pa against a weight in kN/m^3), or ``""``."""
    gravity = run.loads.gravity
    if gravity is None or not np.any(gravity):
        return ""
    if gravity.ndim == 2:                       # per body: the heaviest
        gravity = gravity[np.argmax(np.linalg.norm(gravity, axis=1))]
    n = points.n
    mu = np.broadcast_to(np.asarray(run.material.mu, float), (n,))
    lam = np.broadcast_to(np.asarray(run.material.lam, float), (n,))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        young = mu * (3 * lam + 2 * mu) / (lam + mu)
    young = young[np.isfinite(young) & (young > 0)]
    if not young.size:
        return ""
    young = young.min()
    along = gravity / np.linalg.norm(gravity)
    height = np.ptp(along @ points.x0)
    strain = np.linalg.norm(gravity) * height / young
    if not strain > .5:
        return ""
    return ("; the body force strains the body by about {:.3g} elastically "
            "(|b| H / E = {:.3g} x {:.3g} / {:.3g}): a body far too soft "
            "for its load: are the units consistent (E and the body force "
            "in the same system: Pa with N/m^3, kPa with kN/m^3)?".format(
                strain, np.linalg.norm(gravity), height, young))


def largest_displacement(points: MaterialPoints) -> float:
    """The largest of the points' accumulated displacements' lengths."""
    return float(np.sqrt((points.displacement ** 2).sum(axis=0)).max(
        initial=0.))


def may_collapse(run: Run) -> bool:
    """Whether a failure of ``run`` may be a collapse that
    :func:`collapse_hint` names: a quasi-static run of a plastic body
    whose loads are forces, not prescribed displacements."""
    driven = run.prescribed is not None or bool(run.rigid_bodies) or any(
        np.any(ob.displacement) for ob in run.obstacles or ())
    return run.dynamics is None and is_plastic(run.material) and not driven


def call_back(callback: Callable, record: StepRecord,
              points: MaterialPoints, result: Result):
    """``callback(record, points)`` after a converged step.  What it
    raises propagates unchanged, a user's own type to catch as such, with
    the run's state attached as the package's convergence errors carry
    it: ``state`` (the step's points), ``load_factor`` and ``history``
    (each where the exception has no attribute of that name; it came out
    bare, and a trial resuming after an exception of its own had to keep
    the points itself)."""
    try:
        callback(record, points)
    except Exception as err:
        for name, value in (("state", points),
                            ("load_factor", record.load_factor),
                            ("history", result.history)):
            if getattr(err, name, None) is None:
                try:
                    setattr(err, name, value)
                except AttributeError:        # slots, read-only names
                    pass
        if hasattr(err, "add_note"):                 # Python >= 3.11
            err.add_note("raised by Options.callback after step {} (load "
                         "factor {:.6g}); the step's points are attached "
                         "as .state, with .load_factor and "
                         ".history".format(record.step,
                                           record.load_factor))
        raise


def collapse_hint(run: Run, reach: list) -> str:
    """A sentence for a failed quasi-static run of a plastic body whose
    loads are forces, not displacements, where the last converged step
    moved the body :data:`COLLAPSE_SOFTENING` times or more as far per
    load increment as its stiffest step before did (``reach``: the load
    factor and the points' largest displacement after each converged
    step, from the call's start; the stiffest, not the first: a body
    force in full from the first step moves the body in it), or ``""``:
    the body may be yielding towards a collapse, past whose limit load
    no equilibrium exists (a hardening material softens so too, with no
    limit load: hence "may"; a user's footing loaded past Prandtl's load
    ended with "no convergence" and no more).  The last converged load
    factor is what the discretisation carried, no bound of the body's
    limit load: coarse grids overestimate it (a trial's 6 m vertical cut
    converged to 0.5437 of its weight, where the upper bound 4c/gamma
    tan(45 + phi/2) of its height allows 0.476; the words said "at least
    load factor 0.5437").  Where no step converged
    from the run's start and the material has no cohesion, the body may
    have no equilibrium at any load factor (a free column of cohesionless
    soil failed its first step at every cut-back with no word of why, a
    user trial; not said of soil with cohesion: a staged run's second
    stage, out of balance at its start on a grid of its own, was told
    so, untrue)."""
    if not may_collapse(run):
        return ""
    cohesion = getattr(run.material, "cohesion", None)
    if len(reach) == 1 and reach[0][0] == 0. and cohesion == 0:
        return ("; no load step converged from the start, and its "
                "cohesion is 0: soil without cohesion loaded by forces may "
                "have no equilibrium at any load factor, a limit load of "
                "zero (a face steeper than its friction angle, a body its "
                "supports do not hold): support or strengthen it, or "
                "follow the collapse in dynamics (Dynamics)")
    if len(reach) < 3:
        return ""
    f, u = np.array(reach).T
    rates = np.diff(u) / np.diff(f)
    stiffest = rates[:-1][rates[:-1] > 0].min(initial=np.inf)
    if not rates[-1] >= COLLAPSE_SOFTENING * stiffest:
        return ""
    return ("; the last converged step moved the body {:.3g} times as far "
            "per load increment as the stiffest step before (the points' "
            "largest displacement): it may be yielding towards a "
            "collapse: this discretisation carried load factor {:.4g}; "
            "the body's limit load, which coarse grids overestimate, may "
            "be lower (a finer grid tells), and past it no equilibrium "
            "exists: a run to a smaller load, or one with a displacement "
            "prescribed instead (an Obstacle, a rigid body), follows the "
            "collapse".format(
                rates[-1] / stiffest, f[-1]))


#: the share of a step's first out-of-balance force its start must hold
#: (:func:`start_hint`) for a shorter step to be said not to help
START_SHARE = .5


def start_hint(starts: list) -> str:
    """A sentence for a step cut back to the end whose first residual did
    not fall with its increment (``starts``: each failed increment and
    the first residual of its attempts), or ``""``: what unbalances the
    step is not its load increment but its start, a state out of balance
    on the grid (standard MPM: every step starts out of balance by the
    points' last move within their cells) or loads in full from the first
    step.  A trial's new stage from a collapsed footing's ``err.state``
    (standard MPM, Mohr-Coulomb, 380 kPa, mean dilatation) started at
    0.0742 at every cut-back, holding the load or unloading by up to
    2.5% in its first step; unloading by 5% or more in one step
    converged (5 iterations), and reloading after it in steps too, the
    settlement at the collapse load 0.020 then 0.032 m; cpGIMP's stage
    started at 8.5e-4 and held the load (5 iterations).

    >>> start_hint([(.25, .0909), (.125, .0818), (.0625, .0778)])[:44]
    "; the step's first residual stayed at 0.0778"
    >>> start_hint([(.25, .4), (.125, .21), (.0625, .1)])
    ''

    Each entry may carry a third, the share of the attempt's first
    out-of-balance force that the step's start holds (newton's
    :func:`~skfem_mpm.solve.newton.start_share`): a run's first step
    from rest (trial 103: a spring bed's wrong matrix) starts with the
    residual 1 at every cut-back, all of it the load increment's, and
    was told its start was out of balance.

    >>> start_hint([(.25, 1., 0.), (.125, 1., 0.), (.0625, 1., 0.)])
    ''
    >>> start_hint([(.25, .0909, .9), (.125, .0818, .95),
    ...             (.0625, .0778, .97)])[:44]
    "; the step's first residual stayed at 0.0778"
    """
    if len(starts) < 3 or any(entry[1] is None for entry in starts):
        return ""
    (longest, r0), (shortest, r1) = starts[0][:2], starts[-1][:2]
    if not (r1 >= .5 * r0 and shortest <= longest / 4 * (1 + 1e-9)):
        return ""
    share = starts[-1][2] if len(starts[-1]) > 2 else None
    if share is not None and share < START_SHARE:
        return ""
    return ("; the step's first residual stayed at {:.3g} ({:.3g} at the "
            "first attempt) while the increment was cut {:.0f}-fold: the "
            "step's start is out of balance, not its load increment (the "
            "possible causes: loads in full from the first step, as "
            "ramp=False applies them; with standard MPM every step starts "
            "out of balance by the points' last move within their cells), "
            "so a shorter step cannot help.  To go on from "
            "the attached state: a step changing the load by more than "
            "that imbalance at once (a collapsed footing's stage held its "
            "load in vain at every cut-back and converged unloaded by 5% "
            "in one step, not by 2.5%; reloaded in steps after it), or "
            "cpGIMP, whose points start nearly in balance (that stage "
            "started at 8.5e-4 and held the load); docs/geomechanics.md, "
            "'Continuing after a collapse'".format(
                r1, r0, longest / shortest))


def left_grid_cause(run: Run, points: MaterialPoints,
                    increment: float) -> str:
    """The cause, besides a tight grid, of points leaving the grid in a
    step of ``increment`` (a share of the run): quasi-static, a load past
    what the body can carry; in dynamics the points' motion in a time
    step, their velocity times it (trial 78: a thrown elastic block was
    told of limit loads and supports)."""
    dynamics = run.dynamics
    if dynamics is None or points.velocity is None:
        return ("a load past what the body can carry (a plastic body "
                "beyond its limit load, a body its supports do not hold)")
    dt = increment * dynamics.duration
    speed = float(np.sqrt((points.velocity ** 2).sum(axis=0)).max(
        initial=0.))
    return ("the body's motion carrying it off: a point moves its velocity "
            "times the time step ({:.3g} m/s x {:.3g} s = {:.3g} cells a "
            "step at the fastest where the step started): the grid must "
            "cover where the body goes (a thrown or falling body, a "
            "rebound)".format(speed, dt, speed * dt / run.cell_size))


def no_equilibrium(run: Run, points: MaterialPoints) -> bool:
    """Whether a failed step of ``run`` from the converged state
    ``points`` is one that no shorter step can take: quasi-static, loads
    that keep their direction at every load factor
    (:meth:`~skfem_mpm.solve.loads.ExternalLoads.proportional`, no term's
    load that follows the trial) and a term that sees the load unbalanced
    at every load factor (:meth:`~skfem_mpm.protocols.GridTerm.
    no_equilibrium`; a block on a Coulomb slope past mu cut its first
    step back 9 times in vain, 2.3 s where it now stops in 0.6 s, a user
    trial).  Not with grid terms of a user's (``loads``), which
    may hold the material or load it in ways the built-in terms cannot
    judge."""
    return run.dynamics is None and not run.linear and \
        not run.user_terms and run.loads.proportional(points) and all(
            type(term).load is GridTerm.load for term in run.terms) and \
        any(term.no_equilibrium(points) for term in run.terms)


def easy_sub_step(iterations: Optional[int], max_iter: int) -> bool:
    """Whether a converged sub-step of ``iterations`` Newton iterations
    (``None``: a linear step) converged easily enough to count towards
    growing a cut-back's increment back: in at most :data:`EASY_SHARE` of
    ``max_iter``.

    >>> easy_sub_step(12, 25), easy_sub_step(13, 25), easy_sub_step(2, 3)
    (True, False, False)
    """
    return iterations is not None and iterations <= EASY_SHARE * max_iter


def grown_increment(increment: float, whole: float, easy: int) -> tuple:
    """The next sub-step's increment after ``easy`` sub-steps in a row
    that converged easily (:func:`easy_sub_step`) at a cut-back's
    ``increment``, and the count to go on with: grown by :data:`GROWTH`
    (never past ``whole``, a whole step's) after :data:`EASY_STEPS` of
    them, the count starting again; as it was otherwise.  The sub-step
    itself never passes its load step's end (:func:`advance`).

    >>> grown_increment(1 / 64, 1 / 4, 1)
    (0.015625, 1)
    >>> grown_increment(1 / 64, 1 / 4, 2)
    (0.03125, 0)
    >>> grown_increment(1 / 8, 1 / 4, 2), grown_increment(.2, .25, 2)
    ((0.25, 0), (0.25, 0))
    """
    if easy < EASY_STEPS or increment >= whole:
        return increment, easy
    return min(GROWTH * increment, whole), 0


def steps_left(factor: float, increment: float, nsteps: int,
               adaptive: bool) -> int:
    """The steps a run at load factor ``factor`` (or fraction of its
    duration) has left: to the next of its ``nsteps`` steps' ends at the
    current ``increment`` (a cut-back's lasts to the step's end), after
    it at a whole step's (a trial's run cut back to a 64th was announced
    to take 1275 steps and 1.13 h where 30 were left), or, ``adaptive``
    (the time step chosen by Newton's iterations), all at ``increment``.
    With ``NewtonOptions(grow_back=True)`` an upper bound after a
    cut-back: its increment grows back after easy sub-steps
    (:func:`grown_increment`) and no guess is made of when.

    >>> steps_left(.25, 1 / 64, 4, False)      # 16 to 0.5, then 2
    18
    >>> steps_left(.25, 1 / 64, 4, True)
    48
    >>> steps_left(.5, .25, 4, False)
    2
    """
    if adaptive:
        return int(np.ceil((1. - factor) / increment - 1e-9))
    boundary = (np.floor(factor * nsteps + 1e-9) + 1) / nsteps
    return int(np.ceil((boundary - factor) / increment - 1e-9)) + \
        int(round((1. - boundary) * nsteps))


def warn_long_run(step: int, left: int, seconds: float) -> bool:
    """Log a warning (and return ``True``) when the ``left`` steps
    (:func:`steps_left`) take more than :data:`LONG_RUN` seconds at
    ``seconds`` a step: a run asked for a million time steps went on
    without a word."""
    if left < 2 or seconds * left <= LONG_RUN:
        return False
    logger.warning(
        "step %d: at %.3g s a step the %d steps left take about %.3g h: "
        "longer steps or fewer points shorten it (the scene files' runner "
        "writes checkpoints to stop and resume)", step, seconds, left,
        seconds * left / 3600.)
    return True


def ghost_hint(run: Run) -> str:
    """A remedy for a failed run with contacts between bodies on
    B-splines whose ghost penalty was never on: a square pile with
    friction 0.3 in 3D failed at every cut-back of its first step with
    the penalty held in reserve, and converged with ``ghost=0.1``."""
    if not (run.contacts and run.method.name.startswith("bspline")
            and not run.ghost and not run.counters["ghost_from_step"]):
        return ""
    return ("; with contacts between bodies on B-splines the nodes a "
            "body's splines reach beyond its surface are barely held: "
            "{} holds them (a square pile with friction in 3D failed "
            "so, and converged with it)".format(setting("ghost", 0.1)))


def check_higher_order_antilocking(method: str, elem: Element, mesh: Mesh,
                                   material, antilocking) -> None:
    """Refuse mean dilatation (or F-bar) on higher-order Lagrange cells
    (Q2: 9 nodes) with points that move and a plastic material, and warn
    of it (logged) on such cells otherwise (finite elements, elastic
    bodies: off alike, by the cause below): a user
    trial's smooth strip footing on weightless von Mises soil (B/h = 6,
    3 x 3 points a cell, small strain) carried 17% below Prandtl's
    ``(2 + pi) c`` at its peak and fell to 26% below, the tangent
    singular in 19 solves; finite elements on the same grid 4.6% below,
    standard MPM on Q2 without it 6.9% above, on Q1 with it 8.7% above.
    Elastic bodies are not refused (a press within 0.2%, its strain
    uniform).

    The cause is the method, not its code (the average's weights, the
    patch test and ``K u = force`` hold to 1e-15 on moved Q2 points):
    one constraint (the cell mean) against the 8 DOFs a 9-node cell
    adds (constraint ratio 8, 2 being ideal in 2D; Q1's is 2) leaves
    the pointwise divergence free wherever its cell mean is zero, so a
    collapse mechanism need not be isochoric and can dissipate less
    than an admissible one.  The footing's last increment had a divergence
    of 0.70 (FE) and 0.95 (MPM) of its deviatoric rate at the yielding
    points, its cell means 0.001 (Q1 with it: 0.25).  Finite elements converge
    from below at first order (B/h = 4, 6, 8, 12: -6.5, -4.7, -3.6,
    -2.5%); the points, moving with those modes at fixed volumes, took
    up to 16% pointwise volume change at a settlement of 0.015 B (cell
    means 0.3%), and MPM went further below on finer grids (peaks -10,
    -13, -17, -22%).  Projecting the divergence on linear functions per
    cell (3 constraints, as the 9/3 element; a numpy-only trial, not
    offered) gave +0.4% (FE) and +1.0% (MPM) at B/h = 6, flat.  The
    same relaxation shows elastically where the strain varies across a
    cell: pure bending's volumetric strain, linear across the depth, is
    free, so a beam one Q2 cell deep bends with the shear modulus
    instead of ``E / (1 - nu^2)``, ``2 / (1 - nu)`` times too flexible
    (a cantilever under its weight, L = 10 D, 3 x 3 points: 2.83 at
    nu = 0.3 against 2.86; 2 cells deep +17%, 4 cells +4%)."""
    scalar, nodes = cell_nodes(elem, mesh)
    if not antilocking or nodes <= mesh.t.shape[0]:
        return
    if method != "fem" and is_plastic(material):
        raise InvalidInputError(
            "antilocking on {} cells ({} nodes) with method {!r} and a "
            "plastic material is refused: a smooth strip footing on von "
            "Mises soil came out 17-26% below Prandtl's limit load and "
            "softened (finite elements 4.6% below): take bilinear cells "
            "(Q1) with antilocking, or these cells without it".format(
                type(scalar).__name__, nodes, method))
    # the cases not refused are warned of (a reviewer's trace of the
    # refusal found them silently off alike)
    logger.warning(
        "antilocking on %s cells (%d nodes): one mean-dilatation "
        "constraint a cell leaves the volume change within a cell free: "
        "where the strain varies across a cell the body is too flexible "
        "(a cantilever one cell deep 2 / (1 - nu) times, two cells deep "
        "+17%%) and a plastic limit load comes out below the collapse load "
        "(finite elements' footing 4.7%% below Prandtl's at B/h = 6, from "
        "below at first order); these cells lock little without it (a "
        "cantilever at nu = 0.4999 within 3-5%% of beam theory), or take "
        "bilinear cells (Q1) with it", type(scalar).__name__, nodes)


def cause_first(err, hint: str) -> str:
    """A failed step's error ``err`` led by the grid terms' ``hint``
    (:func:`terms_hint`, ``"; ..."``) where they see why no load factor
    has an equilibrium: a user trial's block on a slab past mu read
    Newton's words first and "1.554 times mu" last.

    >>> cause_first(ValueError("step 3: Newton did not converge"),
    ...             "; the load slides the block")
    'step 3: the load slides the block; Newton did not converge'
    """
    text = str(err)
    step = re.match(r"step \d+: ", text)
    lead = step.group(0) if step else ""
    return "{}{}; {}".format(lead, hint[2:], text[len(lead):])


def terms_hint(run: Run, points) -> str:
    """What the run's grid terms see of a failure at the last converged
    state ``points`` (:meth:`~skfem_mpm.protocols.GridTerm.failure_hint`),
    for a failed run's error."""
    return "".join(term.failure_hint(points, run.dynamics is None)
                   for term in run.terms)


def warn_resumed_terms(run: Run, resume: Resume) -> None:
    """A resumed run with grid terms of the user's own that do not say
    they keep nothing over the steps (:attr:`~skfem_mpm.GridTerm.
    stateless`) is warned, naming them: what such a term keeps (a
    spring bed's total displacement) is in neither the points nor the
    checkpoints, and ``begin_run`` has just started it afresh (trial
    97's spring bed, resumed with a fresh term after 2 of 4 steps,
    settled -2.16e-3 against -1.44e-3 uninterrupted, +50%, silently)."""
    if not run.resumed:
        return
    own = sorted({type(term).__name__ for term in run.user_terms
                  if not of_package(term) and not term.stateless
                  and not getattr(term, "restores_state", False)})
    if own:
        logger.warning(
            "resumed at step %d with grid terms of your own (%s): what "
            "they keep over the steps (a total displacement, a history) "
            "is in neither the points nor the checkpoints, and begin_run "
            "started it afresh; restore it in the term (a spring bed "
            "resumed fresh settled 50%% more) and set restores_state = "
            "True on it, or set stateless = True on a term that keeps "
            "nothing", resume.first_step,
            ", ".join(own))


def own_terms_hint(run: Run, err: Exception) -> str:
    """The run's grid terms of the user's own (``loads=[...]``, classes
    defined outside the package) named for a failed run's error ``err``:
    a singular system says what ``holds_free_body`` does, a Newton loop
    at a linear rate, or a linear run's that did not converge, that a
    term's matrix must be its force's derivative; ``""`` without such
    terms (trial 97's spring bed ended in "add supports", its matrix left
    out in "missing supports", its matrix doubled in a linear rate, the
    term never named; trial 103's, its matrix 0.3 of the derivative in a
    linear run, diverged unnamed)."""
    own = [term for term in getattr(run, "user_terms", ())
           if not of_package(term)]
    if not own:
        return ""
    names = ", ".join(sorted({type(term).__name__ for term in own}))
    holding = [term for term in own if term.holds_free_body]
    if "begin_step returned None" in str(err):   # (the step named them)
        return ""
    if isinstance(err, SingularSystemError):
        if not holding:
            return ("; the run's grid terms of your own ({}) do not set "
                    "holds_free_body = True: a term whose matrix holds "
                    "the body in every rigid-body motion (an elastic "
                    "foundation, a mass) sets it, and the check of the "
                    "supports is left out (docs/architecture.md, Grid "
                    "terms)".format(names))
        return ("; the run's grid terms of your own ({}) set "
                "holds_free_body = True, which leaves the check of the "
                "supports out: their matrix(response) must then hold the "
                "body in every rigid-body motion (a term returning None "
                "adds nothing to the stiffness)".format(names))
    if "a linear rate" in str(err):
        return ("; the run's grid terms of your own ({}) take part: a "
                "term's matrix(response) must be the derivative of its "
                "force(du, response), or Newton converges linearly"
                .format(names))
    if isinstance(err, NewtonDivergenceError) and getattr(run, "linear",
                                                          False):
        return ("; the run's grid terms of your own ({}) take part: a "
                "term's matrix(response) must be the derivative of its "
                "force(du, response), with which a linear step converges "
                "at its first solve".format(names))
    return ""


def seeded_hint(run: Run) -> str:
    """The run's start's :func:`underintegrated_cells` sentence for a
    failed run's error, or ``""``."""
    return "; the run started so: " + run.underintegrated \
        if run.underintegrated else ""


def progress(run: Run, factor: float) -> str:
    """Where a run stands at ``factor`` for its messages: the load factor,
    or in dynamics the time (``factor`` the fraction of the duration: a
    user's dynamic run that left the grid was said to have done so at
    "load factor 0.1055").

    >>> from types import SimpleNamespace
    >>> progress(SimpleNamespace(dynamics=None), .25)
    'load factor 0.25'
    >>> progress(SimpleNamespace(dynamics=SimpleNamespace(duration=2.)), .25)
    'time 0.5'
    """
    if run.dynamics is None:
        return "load factor {:.4g}".format(factor)
    return "time {:.4g}".format(factor * run.dynamics.duration)


def span(run: Run, increment: float) -> str:
    """A load increment, or in dynamics the time step, of ``increment``
    (a fraction of the load or of the duration) for a run's messages."""
    if run.dynamics is None:
        return "a load increment of {:.2e}".format(increment)
    return "a time step of {:.2e}".format(increment * run.dynamics.duration)


def advance(run: Run, result: Result, nsteps: int, step: int, factor: float,
            increment: float, smallest: float,
            callback: Optional[Callable]) -> Result:
    """The load steps of ``run`` from ``step`` (done) at load factor
    ``factor`` to the end, each of ``increment`` where it converges, cut
    back (halved) down to ``smallest`` where it does not; the history,
    points and basis into ``result``.  A failure raises with the last
    converged state attached.  Once, a warning where the steps left would
    take more than :data:`LONG_RUN` seconds at the fastest step's pace
    (:func:`warn_long_run`), the first step of the call left out: it
    carries the set-up (compiling the kernels, the solver's first
    analysis), and a trial's dynamic run of 69 s was announced at step 1
    to take 0.846 h."""
    points, dynamics = result.points, run.dynamics
    adaptive = dynamics is not None and bool(dynamics.target_iterations)
    fastest, warned, timed = np.inf, False, False
    started = begun = run_clock()
    first = factor              # the call's start (the pace's)
    held = 0            # the step's failed attempts, all HeldSupportError
    watch = may_collapse(run)               # (collapse_hint)
    easy_iterations = int(EASY_SHARE * run.max_iter)
    easy = 0            # easy sub-steps in a row, grow_back off (the hint)
    reach = [(factor, largest_displacement(points))] if watch else []
    stalled_at = None   # the last failed increment and its attempts' stalls
    starts = []         # the step's failed increments, first residuals
    while factor < 1. - 1e-12:
        boundary = (np.floor(factor * nsteps + 1e-9) + 1) / nsteps
        target = min(factor + increment, boundary)
        if target > boundary - 1e-12:
            target = boundary
        try:
            points, record, op = attempt(run, points, factor, target,
                                         step + 1)
        except STEP_FAILURES as err:
            held = held + 1 if isinstance(err, HeldSupportError) else 0
            starts.append((target - factor,
                           getattr(err, "first_residual", None),
                           getattr(err, "start_share", None)))
            unbalanced = no_equilibrium(run, points)
            floor = stall_floor(getattr(err, "stalls", None), stalled_at,
                                target - factor)
            stalled_at = (target - factor, getattr(err, "stalls", None))
            if floor and ghost_reserve_held(run) and not unbalanced:
                # the floor at thinly held nodes: the ghost penalty ties
                # them to their neighbours (the step again, as long)
                switch_ghost_on(run, step + 1, "{}; {}".format(
                    err, floor.split(".  ")[0]))
                stalled_at = None
                continue
            # a linear quasi-static step cut back solves the same
            # equations, scaled; a time step's change with it
            unscaled = run.linear and dynamics is None
            at_start = getattr(err, "at_start", False)
            if unscaled or (target - factor) / 2 < smallest * (1 - 1e-9) \
                    or held > HELD_HALVINGS or unbalanced or floor \
                    or at_start:
                hint = terms_hint(run, points)
                raise type(err)(
                    "{}; {}: the last converged state ({}) is attached"
                    "{}{}{}".format(
                        cause_first(err, hint) if unbalanced and hint
                        else err, "not cut back: the loads keep their "
                        "direction "
                        "at every load factor, so a shorter step has no "
                        "equilibrium either"
                        if unbalanced else floor if floor else
                        "not cut back: raised where the step starts"
                        if at_start else
                        "not cut back: a linear step's shorter one solves "
                        "the same equations, scaled" if unscaled else
                        "no convergence down to {}".format(span(
                            run, target - factor)) if held <= HELD_HALVINGS
                        else "failed so at {} halvings of the step, down "
                        "to {}: a shorter step does not remove the "
                        "cause".format(
                            HELD_HALVINGS, span(run, target - factor)),
                        progress(run, factor), too_soft(run, points)
                        + (collapse_hint(run, reach) + start_hint(starts)
                           if isinstance(err, NewtonDivergenceError)
                           else ""),
                        ghost_hint(run) + seeded_hint(run) + (
                            "".join(term.unheld_hint() for term in run.terms)
                            if isinstance(err, SingularSystemError) else "")
                        + own_terms_hint(run, err),
                        "" if unbalanced else hint),
                    state=points, load_factor=factor,
                    history=result.history) from err
            increment, easy = (target - factor) / 2, 0
            if run.grow_back and not adaptive:
                run.counters[EASY] = 0
            logger.warning("step %d: cutting the %s back to %.3e",
                           step + 1, "load increment" if dynamics is None
                           else "time step", increment if dynamics is None
                           else increment * dynamics.duration)
            continue
        except MPMError as err:              # what a cut-back cannot cure
            err.state, err.load_factor = points, factor
            err.history = result.history
            if isinstance(err, PointsOutsideGridError) and err.at_start:
                err.args = (err.args[0] + "; they lie outside it where "
                            "the step starts{}: seed the points inside the "
                            "grid, or make the grid cover them".format(
                                ", as given to the run" if step == 0
                                and factor == 0. else ""),)
            elif isinstance(err, SingularSystemError):
                err.args = (err.args[0] + "".join(
                    term.unheld_hint() for term in run.terms)
                    + own_terms_hint(run, err),) + err.args[1:]
            elif isinstance(err, PointsOutsideGridError):
                crossed = "".join(
                    term.crossed_hint(points, err.indices, getattr(
                        err, "positions", None)) for term in run.terms
                    if hasattr(term, "crossed_hint"))
                err.args = (err.args[0] + too_soft(run, points) + (
                    "; they left it in step {} ({} to {}){}{}".format(
                        step + 1, progress(run, factor),
                        progress(run, target).split()[-1], crossed or
                        ": a grid too tight around the body's motion, or "
                        + left_grid_cause(run, points, target - factor),
                        terms_hint(run, points))),)
            if err.args and isinstance(err.args[0], str):
                # a singular stiffness of cells seeded too thinly blamed
                # nodes held by too few points (small strain, Q2 2 x 2)
                err.args = (err.args[0] + seeded_hint(run),) + err.args[1:]
            raise
        except Exception as err:             # a user's material or form
            raise StepFailedError(
                "step {}: {}: {} (the last converged state, {}, is "
                "attached)".format(step + 1, type(err).__name__, err,
                                   progress(run, factor)),
                state=points, load_factor=factor,
                history=result.history) from err
        step += 1
        factor, held, starts = target, 0, []
        if adaptive and record.newton_iterations is not None:
            increment = dynamics.adapt(increment, 1. / nsteps, smallest,
                                       record.newton_iterations)
        elif abs(factor - boundary) < 1e-12:
            increment, easy = 1. / nsteps, 0
            if EASY in run.counters:
                run.counters[EASY] = 0
        elif increment < (1. - 1e-9) / nsteps and not run.grow_back:
            easy = easy + 1 if easy_sub_step(record.newton_iterations,
                                             run.max_iter) else 0
            if easy >= EASY_STEPS and EASY not in run.warned:
                run.warned.add(EASY)
                logger.info(
                    "step %d: the %s stays cut back to %.3e to the load "
                    "step's end, though %d sub-steps in a row converged "
                    "in at most %d Newton iterations; to double it after "
                    "two such sub-steps: %s (fewer sub-steps where the "
                    "rest of a step is easy, a trial's 128 took 13, but "
                    "the changed load path can fail where this one "
                    "completes: two of the package's test runs did)",
                    step, "load increment"
                    if dynamics is None else "time step", increment
                    if dynamics is None else increment * dynamics.duration,
                    easy, easy_iterations, setting("grow_back", True))
        elif increment < (1. - 1e-9) / nsteps:   # a cut-back's: grows back
            easy = run.counters.get(EASY, 0) + 1 if easy_sub_step(
                record.newton_iterations, run.max_iter) else 0
            grown, run.counters[EASY] = grown_increment(
                increment, 1. / nsteps, easy)
            if grown != increment:
                logger.info("step %d: growing the %s back to %.3e (%d "
                            "sub-steps in a row converged in at most %d "
                            "Newton iterations)", step, "load increment"
                            if dynamics is None else "time step", grown
                            if dynamics is None else grown
                            * dynamics.duration, easy, easy_iterations)
            increment = grown
        record.increment, record.counters = increment, dict(run.counters)
        result.history.append(record)
        stalled_at, starts = None, []
        result.points = points
        if watch:
            reach.append((factor, largest_displacement(points)))
        result.basis = getattr(op, "basis", None)
        if callback is not None:
            call_back(callback, record, points, result)
        now = run_clock()
        left = steps_left(factor, increment, nsteps, adaptive)
        if timed:       # the invocation's first step carries its set-up
            fastest = min(fastest, now - started)
        logger.info("step %d: %s, %s, residual %.2e, %.3g s; %d step(s) "
                    "left%s", step, progress(run, factor),
                    iterations_words(record) if not run.linear else
                    "{} free DOFs".format(record.n_free_dofs),
                    record.residual, now - started,
                    left, "" if not left else ", about {:.3g} s at the "
                    "pace so far".format((now - begun) * (1. - factor)
                                         / (factor - first)))
        if timed:
            warned = warned or warn_long_run(step, left, fastest)
        started, timed = now, True
    warn_imbalance(run, result)
    return result


def simulate(mesh: Mesh, elem: Element, points: MaterialPoints, material,
             supports, body_force=None, loads: Sequence = (),
             nsteps: Optional[int] = None, method: str = "mpm",
             kinematics: str = "small", dynamics: Optional[Dynamics] = None,
             options: Optional[Options] = None, obstacles: Sequence = (),
             contacts: Sequence = (), **aliases) -> Result:
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
        ``lambda b: b.get_dofs(lambda x: x[0] == 0)``; one component:
        ``.all("u^1")`` (x), ``"u^2"``, ``"u^3"``, scikit-fem's names,
        counted from 1.  A callable's ``get_dofs`` that selects no DOF,
        and its ``.all(name)`` that keeps none, are warned (that part of
        the supports holds nothing); DOF indices computed otherwise, an
        empty array among others, cannot be told from intended ones and
        are not.  With contacts between bodies a support holds each
        body's copy of a node only where that body lies on it
        (:meth:`~skfem_mpm.solve.body_contact.BodyContact.held_supports`).
    body_force
        Body force per unit *initial* volume at full load, shape (dim,), or
        one row per body (bodies, dim) (gravity on bodies of different
        densities: density x g each; one vector for such bodies in
        dynamics is warned), growing with the load factor like every load,
        or a :class:`~skfem_mpm.BodyForce` that says otherwise (in full
        from the first step, per body); ``None``: none is assembled.  Point
        forces at full load are ``points.force``.
    loads
        Further loads at full load and what else drives the body, in any
        order: :class:`~skfem_mpm.Traction`, :class:`~skfem_mpm.Pressure`
        (a follower load in finite deformation) on a side of a body,
        :class:`~skfem_mpm.GridLoad` (a scikit-fem ``LinearForm``),
        :class:`~skfem_mpm.Prescribed` grid displacement increments,
        :class:`~skfem_mpm.RigidBody` bodies of points pushed by prescribed
        displacement through the grid nodes of the cells they occupy
        (standard MPM or FE; the force each needs per step is in
        ``StepRecord.rigid_forces``), and grid terms of one's own
        (:class:`~skfem_mpm.GridTerm`: forces and matrices added to every
        step's balance after the built-in ones, :data:`GRID_TERMS`).
    nsteps
        Load steps (default 1); every load is ramped linearly.  A nonlinear
        step may be cut back (bisected) down to ``2**-max_cutbacks`` of a
        step (:class:`~skfem_mpm.NewtonOptions`).
    method
        ``"fem"`` (points fixed: finite elements with the points as
        quadrature), ``"mpm"``, ``"ugimp"``, ``"cpgimp"``, ``"bspline"``
        (quadratic B-spline MPM, uniform tensor grids of linear elements,
        :mod:`skfem_mpm.methods.bspline`), ``"bspline-gimp"`` (the
        splines averaged over the points' domains), ``"bspline3"`` or
        ``"bspline3-gimp"`` (the same with cubic splines).
    kinematics
        ``"small"`` (incremental small strain) or ``"finite"`` (updated
        Lagrangian Hencky; total Lagrangian with ``"fem"``).
    dynamics
        ``None`` (default): quasi-static load steps, no mass, no velocity.
        A :class:`~skfem_mpm.Dynamics`: time steps with inertia
        (:mod:`skfem_mpm.solve.dynamics`); the load factor is then the
        fraction of the duration, loads and prescribed motion follow
        ``Dynamics.load(t)``, ``nsteps`` is set by the time step (giving it
        too is refused), every record carries ``time`` and ``energy`` and
        the points ``velocity`` and ``acceleration``.
    options
        :class:`~skfem_mpm.Options`: Newton's settings
        (:class:`~skfem_mpm.NewtonOptions`: tolerance, iterations,
        cut-backs, line search, full or modified Newton, ``rhs``), the
        stabilisation (:class:`~skfem_mpm.Stabilisation`: ghost penalty,
        mean dilatation), the linear solver, a
        :class:`~skfem_mpm.Resume`, what the run keeps and a callback.
    obstacles
        Rigid :class:`~skfem_mpm.Obstacle` s (boxes, polygons) the
        material cannot enter, in contact at the material's surface
        (:mod:`skfem_mpm.solve.contact`): smooth, Coulomb, rough or tied;
        the force on each per step is ``StepRecord.obstacle_forces``.  A
        run with obstacles is nonlinear (Newton, even small strain and
        elastic).
    contacts
        :class:`~skfem_mpm.Contact` s between bodies (``points.body``
        indices): each pair of bodies in contact moves on separate grid
        fields, coupled where their surfaces meet
        (:mod:`skfem_mpm.solve.body_contact`): smooth, Coulomb or rough;
        the force of each contact's first body on its second per step is
        ``StepRecord.contact_forces``.  Bodies without a contact stay
        glued where they meet.  Every method whose points move
        (every method but ``"fem"``; with GIMP and the cubic splines the
        ghost penalty is on from the start, :data:`SLIVER_METHODS`), on
        affine or tensor-product grids of linear elements.
    **aliases
        The keyword arguments these objects replaced (``tol``, ``ghost``,
        ``antilocking``, ``line_search``, ``newton``, ``rhs``,
        ``max_iter``, ``max_cutbacks``, ``solver``, ``keep_snapshots``,
        ``callback``, ``locator``, ``first_step``, ``load_factor``,
        ``increment``, ``domain0``, ``counters``, ``prescribed``,
        ``rigid_bodies``, ``terms``, ``ramp_body_force``): deprecated,
        with a :class:`DeprecationWarning`.

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

    Notes
    -----
    Progress: the run logs a line a step at INFO (load factor, Newton
    iterations, residual, time, the time left at the pace so far) on the
    ``skfem_mpm`` loggers, silent by default; show them with
    ``logging.basicConfig(format="%(message)s")`` and
    ``logging.getLogger("skfem_mpm").setLevel(logging.INFO)``, or pass
    ``Options(callback=f)``, called ``f(record, points)`` after every
    step.  Only the command line (``skfem-mpm run``) draws a progress
    bar.  Warnings reach stderr without any set-up.

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

    Options as objects:

    >>> from skfem_mpm import NewtonOptions, Options, Stabilisation
    >>> res = simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
    ...                VonMises(1e4, .3, yield_stress=5.),
    ...                lambda b: b.get_dofs(lambda x: x[1] == 0),
    ...                body_force=[0., -10.], nsteps=2, kinematics="finite",
    ...                options=Options(NewtonOptions(tol=1e-11),
    ...                                Stabilisation(ghost=.1)))
    >>> bool(res.history[-1].residual < 1e-11)
    True

    """
    options, body_force, loads = translate_aliases(
        "simulate", options, body_force, loads, aliases)
    dynamics = scheme_for(dynamics, bool(obstacles) or bool(contacts))
    case = check_case(mesh, points, material, body_force, loads, nsteps,
                      method, kinematics, dynamics, options, obstacles,
                      contacts)
    check_grid(mesh, elem)
    check_higher_order_antilocking(method, elem, mesh, case.material,
                                   options.stabilisation.antilocking)
    warn_volumetric_locking(
        getattr(case.material, "materials", [case.material]),
        options.stabilisation.antilocking, kinematics, method, mesh.dim(),
        higher_order=cell_nodes(elem, mesh)[1] > mesh.t.shape[0])
    underintegrated = underintegrated_cells(method, mesh, elem, points,
                                            case.location)
    if method in ("ugimp", "cpgimp"):
        underintegrated = single_point_domains(
            method, points_per_cell_axis(mesh, points), case.nsteps)
    if method.startswith("bspline"):
        underintegrated = spline_zero_energy(method, mesh, points, case)
    if underintegrated:
        logger.warning(underintegrated)
    run, result = build_run(mesh, elem, points, supports, case, method,
                            kinematics, dynamics, options)
    run.underintegrated = underintegrated
    resume = options.resume or Resume()
    nsteps = case.nsteps
    step = resume.first_step - 1
    factor = step / nsteps if resume.load_factor is None \
        else float(resume.load_factor)
    increment = 1. / nsteps if resume.increment is None \
        else float(resume.increment)
    smallest = 1. / nsteps / 2 ** options.newton.max_cutbacks
    if step == 0:
        check_first_supports(run, result.points, factor + increment)
    if resume.counters:
        if run.counters["ghost_from_step"]:
            for term in run.terms:          # a switched-on ghost stays on
                if isinstance(term, GhostStabilisation):
                    term.switch_on()
    return advance(run, result, nsteps, step, factor, increment, smallest,
                   options.callback)


def check_first_supports(run: Run, points: MaterialPoints, f_new: float):
    """The method's check of the supports
    (:meth:`~skfem_mpm.methods.method.BSplineMethod.check_supports`: a
    B-spline's held nodes inside the grid) on the first step's points and
    held DOFs, before any work: it had refused at step 1, the run's
    state attached and no step done (a user trial).  A method that checks
    nothing builds no operator here; the later steps are checked as they
    come (the points move to other nodes)."""
    method = getattr(run.method, "piece", run.method)
    if type(method).check_supports is PointMethod.check_supports:
        return
    op = run.method.operator(points, 1, dict.fromkeys(PHASES, 0.))
    fixed = held_motion(run, op, points, run.scale(0.), run.scale(f_new),
                        1).fixed
    run.method.check_supports(op, fixed, run.grid.nodal_dofs, 1)


class Case(NamedTuple):
    """A run's input, checked: the step count, the material at the points,
    whether steps are linear, the body force and its ramp, the loads by
    kind."""
    nsteps: int
    material: object
    linear: bool
    gravity: Optional[ndarray]
    ramp: ndarray
    forces: list
    prescribed: Optional[Callable]
    rigid_bodies: tuple
    terms: list
    obstacles: tuple = ()
    contacts: tuple = ()
    body_field: Optional[ndarray] = None
    prescribed_bodies: Optional[tuple] = None
    #: the run's point locator, built once, and the points' location at
    #: the start (``None``: outside the grid)
    locate: Optional[Callable] = None
    location: Optional[tuple] = None


def split_loads(loads) -> tuple:
    """``loads`` by kind: forces (Traction, Pressure, GridLoad), the
    prescribed motion (one :class:`~skfem_mpm.Prescribed` at most, or
    ``None``), rigid
    bodies and grid terms."""
    loads = [loads] if not isinstance(loads, (list, tuple)) else list(loads)
    prescribed = [item for item in loads if isinstance(item, Prescribed)]
    if len(prescribed) > 1:
        raise InvalidInputError("loads hold {} Prescribed items; give one "
                                "function for all prescribed DOFs".format(
                                    len(prescribed)))
    rigid = [item for item in loads if isinstance(item, RigidBody)]
    terms = [item for item in loads if isinstance(item, GridTerm)]
    forces = [item for item in loads if not isinstance(
        item, (Prescribed, RigidBody, GridTerm))]
    return (forces, prescribed[0] if prescribed else None, rigid, terms)


def check_steps(nsteps, dynamics: Optional[Dynamics], method: str) -> int:
    """The run's step count: ``nsteps`` (default 1), or the time steps of
    ``dynamics``, whose mass is checked."""
    if dynamics is None:
        return 1 if nsteps is None else nsteps
    if not isinstance(dynamics, Dynamics):
        raise InvalidInputError("dynamics must be None or Dynamics(...), "
                                "got {!r}".format(dynamics))
    if nsteps is not None:
        raise InvalidInputError(
            "nsteps and dynamics both given: a dynamic run takes "
            "duration / time_step = {} steps".format(dynamics.nsteps))
    if dynamics.mass == "consistent" and method != "fem":
        raise InvalidInputError(
            "mass = 'consistent' needs points that stay in their cells "
            "(method = 'fem'): with moving points its projection is "
            "ill-conditioned where a point barely reaches a node, and "
            "creates energy as points cross cells; use mass = 'lumped'")
    return dynamics.nsteps


#: how the rules name a run's contact: with obstacles, between bodies, both
CONTACT_NAMES = ("contact with obstacles", "contact between bodies",
                 "contact with obstacles and between bodies")
#: what a body leaves in each of them
CONTACT_PARTNERS = ("an obstacle", "another body",
                    "an obstacle or another body")


def contact_named(obstacles, contacts) -> str:
    """The name of a run's contact (:data:`CONTACT_NAMES`), ``""`` for
    none.

    >>> contact_named([], [object()])
    'contact between bodies'
    """
    if not obstacles and not contacts:
        return ""
    return CONTACT_NAMES[2 if obstacles and contacts else 1 if contacts
                         else 0]


def check_combination(method: str, kinematics: str, plastic: bool,
                      newton: NewtonOptions, stabilisation: Stabilisation,
                      dynamics: Optional[Dynamics], full_body_force: bool,
                      driven: bool, contact: str = ""):
    """The rules that tie a run's choices together (each option checked
    itself on creation), for :func:`simulate` and a scene's check: the
    seed's one-solve scheme (``rhs="increment"``) needs linear
    quasi-static steps driven by ramped loads alone; modified Newton does
    not go with an adaptive time step.  ``contact``: the run's contact,
    as :func:`contact_named` names it (``""``: none)."""
    if stabilisation.antilocking == "fbar" and (
            kinematics != "finite" or method == "fem"):
        raise InvalidInputError(
            "antilocking='fbar' (F-bar on each step's increment) is for "
            "finite deformation with points that move, not {}; "
            "mean dilatation ({}) is for every method and "
            "kinematics{}".format(
                "finite elements" if method == "fem" else "small strain",
                setting("antilocking", True),
                " (near nu = 0.5 in finite deformation its answer stiffens "
                "with the step size: take more, smaller steps)"
                if method == "fem" else ""))
    if newton.rhs == "increment":
        if contact:
            raise InvalidInputError(
                "rhs = 'increment' (the seed's one-solve scheme) is for "
                "linear steps; {} needs the out-of-balance force (rhs = "
                "'residual')".format(contact))
        if dynamics is not None:
            raise InvalidInputError(
                "rhs = 'increment' maps load increments of quasi-static "
                "steps; dynamics needs the out-of-balance force (rhs = "
                "'residual')")
        if kinematics == "finite" or plastic:
            raise InvalidInputError(
                "rhs = 'increment' (the seed's one-solve scheme) is for "
                "linear steps (small strain, elastic); {} needs the "
                "out-of-balance force (rhs = 'residual')".format(
                    "finite deformation" if kinematics == "finite"
                    else "plasticity"))
        if full_body_force:
            raise InvalidInputError(
                "rhs = 'increment' maps only load increments: {} in full "
                "from the first step ({}) would be dropped; use rhs = "
                "'residual'".format(*(
                    ("a body force", "ramp_body_force, a geostatic body")
                    if full_body_force is True else
                    (full_body_force, "ramp=False"))))
        if driven:
            raise InvalidInputError(
                "rhs = 'increment' maps only the load increment: prescribed "
                "displacements and rigid bodies would not enter the solve; "
                "use rhs = 'residual'")
    if contact and dynamics is not None and dynamics.scheme is not None \
            and dynamics.scheme.alpha_f > 0:
        raise InvalidInputError(
            "{} in dynamics needs forces at the step's end: the "
            "generalised-alpha scheme with rho_inf = {} weighs them at "
            "n+1-alpha_f (alpha_f = {:.3g}), so a body that has left {} is "
            "still pushed by it (a block at rest on a floor rose 17 mm); "
            "leave the scheme to its default with contact, "
            "GeneralizedAlpha(0.) (scene files: scheme = \"auto\")".format(
                contact, dynamics.scheme.rho_inf, dynamics.scheme.alpha_f,
                CONTACT_PARTNERS[CONTACT_NAMES.index(contact)]))
    if newton.newton == "modified" and dynamics is not None and \
            dynamics.target_iterations is not None:
        raise InvalidInputError(ADAPTIVE_MODIFIED)
    if stabilisation.extended_splines and not method.startswith("bspline"):
        raise InvalidInputError(
            "extended_splines extends B-splines (methods 'bspline', "
            "'bspline-gimp', 'bspline3', 'bspline3-gimp'); method {!r} has "
            "none".format(method))
    if stabilisation.extended_splines and stabilisation.ghost_factor() > 0:
        raise InvalidInputError(
            "extended_splines with a ghost penalty (ghost={}) is refused: "
            "the penalty is assembled on the grid's nodes, which the "
            "extension folds into others (a falling block's points moved "
            "apart by 5e-4 of its fall); the extension holds the nodes the "
            "penalty would, leave ghost at 'auto' or 0".format(
                stabilisation.ghost))


def check_positions(mesh: Mesh, points: MaterialPoints, method: str):
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` where the
    points' positions do not follow from their initial ones and their
    displacement (``x = x0 + displacement``; FE: ``x = x0``) beyond
    round-off: points moved after seeding through ``x`` alone.  The
    obstacles' check at the start, a tied obstacle's reach and the
    error measure read ``x0``: a user trial's block moved into a floor
    that way was not refused, and the floor threw it out of the grid."""
    expected = points.x0 if method == "fem" else \
        points.x0 + points.displacement
    gap = np.abs(points.x - expected).max(axis=0)
    off = gap > 1e-9 * np.ptp(mesh.p, axis=1).max()
    if off.any():
        worst = int(np.argmax(gap))
        raise InvalidInputError(
            "point {} is at {} where its initial position and displacement "
            "put it at {} ({} points off): points moved after seeding "
            "need x0 moved alike (points.x0 = points.x.copy() for points "
            "not yet displaced)".format(
                worst, points.x[:, worst].tolist(),
                expected[:, worst].tolist(), int(off.sum())))


def check_body_force(body_force, points: MaterialPoints, dim: int,
                     dynamics: Optional[Dynamics] = None):
    """The body force, one vector (dim,) for every body or one per body
    (bodies, dim), or ``None``, and its ramp per body.  One vector for
    bodies of different densities in dynamics is warned: a force per unit
    volume accelerates them differently."""
    ramp = True
    if isinstance(body_force, BodyForce):
        body_force, ramp = body_force.value, body_force.ramp
    ramp = check_ramp(ramp)
    bodies = int(points.body.max()) + 1
    if ramp.size not in (1, bodies):
        raise InvalidInputError(
            "BodyForce.ramp (ramp_body_force) must be True, False or one "
            "bool per body ({}), got {!r}".format(bodies, ramp.tolist()))
    if body_force is None or not any(
            np.ndim(row) for row in np.atleast_1d(np.asarray(
                body_force, dtype=object))):
        gravity = as_body_force(body_force, dim)
        if gravity is not None and dynamics is not None and bodies > 1:
            warn_one_body_force(gravity, dynamics.density)
        return gravity, ramp
    if len(body_force) != bodies:
        raise InvalidInputError(
            "body_force per body needs one row per body ({}), got {} "
            "({})".format(bodies, len(body_force),
                          bodies_words(points.body)))
    return np.stack([as_body_force(row, dim) for row in body_force]), ramp


def warn_one_body_force(gravity: ndarray, density):
    """Warn where one body force per unit volume acts on bodies of
    different densities (a dynamic run's gravity)."""
    rho = np.ravel(np.asarray(density, dtype=float))
    if not np.any(gravity) or rho.size < 2 or np.ptp(rho) == 0.:
        return
    logger.warning(
        "one body_force %s per unit volume on bodies of densities %s: "
        "their accelerations differ (%s); for gravity give one row per body, "
        "density x g (a scene's [gravity] acceleration)",
        np.array2string(gravity, precision=4),
        np.array2string(rho, precision=4),
        np.array2string(np.linalg.norm(gravity) / rho, precision=4))


def check_prescribed_bodies(prescribed, points: MaterialPoints,
                            contacts) -> Optional[tuple]:
    """The bodies a :class:`~skfem_mpm.Prescribed` motion names, checked
    against the points' bodies and the contacts (``None``: not named)."""
    if prescribed is None or prescribed.bodies is None:
        return None
    present = np.unique(points.body)
    missing = [b for b in prescribed.bodies if b not in present]
    if missing:
        raise InvalidInputError(
            "Prescribed(bodies={}) names body {} that no point belongs to "
            "(the points' bodies: {})".format(list(prescribed.bodies),
                                              missing[0], present.tolist()))
    if not contacts:
        raise InvalidInputError(
            "Prescribed(bodies=...) chooses among the grid fields of bodies "
            "in contact, and this run has no contacts (its bodies share one "
            "field: the motion moves them all); leave bodies out")
    return prescribed.bodies


def check_body_contacts(contacts, mesh: Mesh, points: MaterialPoints,
                        method: str, forces: list):
    """The contacts between bodies checked (:func:`check_contacts`) and
    the field of each body, or ``((), None)``; what they do not work with
    yet is refused."""
    if not contacts:
        return (), None
    contacts, field = check_contacts(contacts, int(points.body.max()) + 1)
    if method == "fem":
        raise InvalidInputError(
            "contacts between bodies need points that move with the "
            "material (method 'mpm', 'ugimp', 'cpgimp' or a B-spline "
            "method); 'fem' keeps them where they started")
    if not (mesh.affine or tensor_grid(mesh) is not None):
        raise InvalidInputError(
            "contacts between bodies need an affine or axis-aligned "
            "tensor-product grid (the surfaces' corners extrapolate the "
            "cells' shape functions), got a {} with curved cells".format(
                type(mesh).__name__))
    if any(isinstance(load, GridLoad) for load in forces):
        raise InvalidInputError(
            "a GridLoad acts on grid nodes, which bodies in contact do not "
            "share (each has its own field): load the bodies with "
            "tractions, pressures or point forces")
    return contacts, field


def cell_nodes(elem: Element, mesh: Mesh) -> tuple:
    """The scalar element of ``elem`` and its number of nodes a cell (0
    where it does not say)."""
    scalar = elem.elem if isinstance(elem, ElementVector) else elem
    return scalar, getattr(scalar, "doflocs",
                           np.zeros((0, mesh.dim()))).shape[0]


def plural(count: str) -> str:
    """``count`` points in words.

    >>> plural("1"), plural("2.5")
    ('1 point', '2.5 points')
    """
    return count + (" point" if count == "1" else " points")


def counted_per_axis(mesh: Mesh, points: MaterialPoints,
                     estimate: float, cells: Optional[ndarray] = None
                     ) -> float:
    """The points per cell and axis counted: the median count of the cells
    holding points, to the power ``1 / dim`` (``estimate``, from the
    volumes, for points outside the grid).  The volumes' estimate
    (:func:`points_per_cell_axis`) is cheap but blamed the count for
    volumes given twice over: "1.4 points per cell and axis ... seed 2"
    where every cell held 2 x 2 (a ported model).  ``cells``: each
    point's, where the run located them (located here without)."""
    try:
        if cells is None:
            cells = point_locator(mesh, kernels="numpy")(points.x)[0]
    except PointsOutsideGridError:
        return estimate
    counts = np.bincount(cells)
    return float(np.median(counts[counts > 0]) ** (1. / mesh.dim()))


def underintegrated_cells(method: str, mesh: Mesh, elem: Element,
                          points: MaterialPoints,
                          location: Optional[tuple] = None) -> str:
    """Where standard MPM's points, seeded on a tensor grid of
    higher-order Lagrange cells (Q2: 9 nodes), are too few per cell to
    give each cell's DOFs, less its rigid-body modes, as many strain
    states, a sentence saying so, else ``""``: the stiffness then has
    zero-energy modes; in small strain the run ended in a singular matrix
    whose message blamed nodes held by too few points, in finite
    deformation Newton failed down to the smallest increment with no word
    of the cause (Q2 with 2 x 2 points: 12 of the 15 needed; user
    trials).  Q1 cells with 1 point per cell and axis in 2D and 3D alike
    (a point's 3 or 6 strain states of a cell's 5 or 18; 1D's one is
    enough): a 3D block of 2 x 2 x 2 cells on a tied floor (small
    strain) stalled Newton at 2.5e-7 of its load in its second step,
    named "a floor of the residual" with no word of the cause (a user
    trial).  ``method="fem"`` alike: its points are the quadrature, and
    one a Q1 cell (a one-point Gauss rule) has the same hourglass modes
    (trial 103: warned for "mpm" only); the Gauss points of a rule exact
    for the element (``seed_gauss_points``, order 2 for Q1, 4 for Q2:
    2 or 3 a cell and axis) are enough, and not warned.  Logged as a
    warning at the run's start and added to a failed run's error.
    ``location``: the points' where the run located them (located here
    without)."""
    dim = mesh.dim()
    scalar, nodes = cell_nodes(elem, mesh)
    if method not in ("mpm", "fem") or mesh.t.shape[0] != 2 ** dim:
        return ""
    per_axis = points_per_cell_axis(mesh, points)
    strains = dim * (dim + 1) // 2
    needed = dim * nodes - strains      # less the rigid-body modes
    have = int(round(per_axis)) ** dim * strains
    if have < needed:       # estimated from volumes: the points counted
        per_axis = counted_per_axis(mesh, points, per_axis, None if
                                    location is None else location[0])
        have = int(round(per_axis)) ** dim * strains
    if have >= needed:
        return ""
    wanted = int(np.ceil((needed / strains) ** (1. / dim) - 1e-9))
    return (
        "element {} with {} per cell and axis: {} {} "
        "a cell of {} nodes {} of the {} strain states its DOFs need "
        "(points counted: the median of the cells holding them), so "
        "the stiffness has zero-energy modes (a singular matrix, or "
        "Newton stalled at a floor of the residual); seed "
        "{} points per cell and axis{}".format(
            type(scalar).__name__, plural(per_axis_words(per_axis)),
            plural(str(int(round(per_axis)) ** dim)),
            "gives" if round(per_axis) == 1 else "give", nodes, have, needed,
            wanted, " (seed_points(mesh, {0}), or seed_gauss_points(mesh, "
            "{1}): {0} Gauss points a cell and axis)".format(
                wanted, 2 * (wanted - 1)) if method == "fem" else ""))


def spline_zero_energy(method: str, mesh: Mesh, points: MaterialPoints,
                       case) -> str:
    """The run's start's :func:`~skfem_mpm.methods.bspline.
    single_point_splines` sentence for B-spline ``method`` (the points
    per cell and axis counted where the volumes' estimate says 1)."""
    per_axis = points_per_cell_axis(mesh, points)
    if per_axis < 1.5:
        per_axis = counted_per_axis(mesh, points, per_axis, None if
                                    case.location is None
                                    else case.location[0])
    return single_point_splines(method, per_axis, case.nsteps,
                                on_the_knots(mesh, points.x))


def surface_in_full(forces) -> str:
    """The tractions and pressures among ``forces`` that act in full from
    the first step (``ramp=False``, checked), in words (``""``: none)."""
    return in_full_words([isinstance(load, Pressure) for load in forces
                          if isinstance(load, (Traction, Pressure))
                          and not check_load_ramp(load)])


def refuse_duplicate_points(points: MaterialPoints,
                            body_field: Optional[ndarray] = None) -> None:
    """Raise :class:`~skfem_mpm.errors.InvalidInputError` where two points
    share their coordinates exactly, naming the first pairs, their bodies
    and positions: a ported model's 5 points given twice ran silently with
    their mass added (a slope's settlement -0.022077 for -0.022339).
    Points of two glued bodies at one position are refused alike (the
    bodies overlap); those of two bodies in contact (on the fields
    ``body_field`` tells apart) are left to the contact's check of
    their overlap, which measures it.  Sorted, not looped: O(n log n);
    by position, then field, so that a field's points at one position
    are neighbours however many other fields' sit there (points of
    fields 0, 1, 0 at one position passed, compared neighbour to
    neighbour only)."""
    x = points.x
    fields = None if body_field is None else body_field[points.body]
    order = np.lexsort(x[::-1] if fields is None else
                       np.vstack([fields, x[::-1]]))
    same = (x[:, order[1:]] == x[:, order[:-1]]).all(axis=0)
    if fields is not None:
        same &= fields[order[1:]] == fields[order[:-1]]
    if not same.any():
        return
    first, second = order[:-1][same], order[1:][same]
    first, second = np.minimum(first, second), np.maximum(first, second)
    shown = np.argsort(first, kind="stable")[:3]
    body = points.body
    raise InvalidInputError(
        "{} point(s) repeat another's coordinates exactly, a point's mass "
        "counted twice: {}{}; give each point once{}".format(
            int(same.sum()), "; ".join(
                "points {} and {} at {}{}".format(
                    first[k], second[k], x[:, first[k]].tolist(),
                    "" if body[first[k]] == body[second[k]] else
                    " (bodies {} and {} overlap)".format(
                        body[first[k]], body[second[k]]))
                for k in shown), "; ..." if same.sum() > 3 else "",
            " (np.unique(points.x, axis=1, return_index=True) finds them)"))


def cell_volumes(mesh: Mesh, cells: ndarray) -> ndarray:
    """The volumes of the grid's ``cells``: an axis-aligned tensor grid's
    from their extents, any other's by Gauss quadrature of the map's
    Jacobian (one point on affine cells; exact for bi- and trilinear
    ones)."""
    if tensor_grid(mesh) is not None:
        return np.prod(np.ptp(mesh.p[:, mesh.t[:, cells]], axis=1), axis=0)
    X, W = get_quadrature(mesh.refdom, 0 if mesh.affine else 4)
    detJ = fresh_mapping(mesh).detDF(X, tind=cells)
    return np.abs(detJ) @ W


def filled_cells(mesh: Mesh, points: MaterialPoints,
                 cells: Optional[ndarray]) -> Optional[tuple]:
    """The points' volumes summed in each cell they occupy (``cells``,
    each point's, as the run locates them): those cells' names, their
    volumes (:func:`cell_volumes`) and the volumes in them.  ``None``
    where ``cells`` is (points outside the grid: the first step names
    them)."""
    if cells is None:
        return None
    filled = np.bincount(cells, weights=points.volume)
    held = np.flatnonzero(filled)
    return (lambda k: "cell {}".format(held[k]), cell_volumes(mesh, held),
            filled[held])


#: a run's start warns where the points' volumes in the cells they occupy
#: sum to more than this share of those cells' volume, or to less than
#: :data:`FILL_LOW`: seeded points (seed_points 1-4 a cell and axis,
#: whole or a disc, quadrilaterals, skewed ones, triangles, graded axes,
#: 1D, 3D; Gauss points) gave 0.65-1 (1 to round-off where whole, a
#: disc's cut cells less), a block collapsed in finite deformation (its
#: toe moved 8 cells; mpm, cpgimp) 0.87-0.99 at every stage, and its
#: points given to another run alike (its single cells up to 1.9)
FILL_HIGH = 1.5
FILL_LOW = 0.1


def warn_volumes_vs_cells(mesh: Mesh, points: MaterialPoints,
                          cells: Optional[ndarray]) -> None:
    """Log a warning where the points' volumes sum to more than
    :data:`FILL_HIGH` of the volume of the cells they occupy
    (:func:`filled_cells`), or to less than :data:`FILL_LOW` of it,
    naming the fullest (emptiest) cells and their shares: a ported
    model's volumes given twice over (239 m2 of points on 120 m2 of
    cells) ran with their weight doubled and a warning of too few points
    per cell where every cell held 2 x 2; a hundredth of them,
    silently."""
    found = filled_cells(mesh, points, cells)
    if found is None:
        return
    name, volume, filled = found
    total = filled.sum() / volume.sum()
    if FILL_LOW <= total <= FILL_HIGH:
        return
    high = total > FILL_HIGH
    share = filled / volume
    worst = np.argsort(-share if high else share, kind="stable")[:3]
    logger.warning(
        "the points' volumes sum to %.3g of the volume of the %d cells they "
        "occupy (%.4g of %.4g)%s; %s: %s; points stand for their share of "
        "the body (in the grid's units; seed_points gives each cell's "
        "volume shared among its points)",
        total, filled.size, filled.sum(), volume.sum(),
        " (volumes too large, or points given twice?)" if high else
        " (volumes too small, or a body thinner than a cell?)",
        "fullest" if high else "emptiest",
        ", ".join("{} {:.3g}".format(name(k), share[k]) for k in worst))


def check_case(mesh: Mesh, points: MaterialPoints, material, body_force,
               loads, nsteps, method: str, kinematics: str, dynamics,
               options: Options, obstacles: Sequence = (),
               contacts: Sequence = ()) -> Case:
    """Every choice of a run checked together, before any work; returns
    the checked :class:`Case`."""
    check_choice("kinematics", kinematics, KINEMATICS)
    check_choice("method", method, METHODS)
    newton, stabilisation = options.newton, options.stabilisation
    nsteps = check_steps(nsteps, dynamics, method)
    check_run_input(mesh, points, nsteps, options.keep_snapshots)
    check_positions(mesh, points, method)
    gravity, ramp = check_body_force(body_force, points, mesh.dim(),
                                     dynamics)
    forces, prescribed, rigid_bodies, terms = split_loads(loads)
    if method not in ("fem", "mpm") and tensor_grid(mesh) is None:
        raise UnsupportedElementError(
            "method {!r} needs an axis-aligned tensor-product grid "
            "(MeshLine, or MeshQuad/MeshHex from init_tensor), got a "
            "general {}: GIMP's and the B-splines' weights are written per "
            "grid axis; triangles, tetrahedra and quadrilaterals off a "
            "grid take method 'mpm' or 'fem'".format(
                method, type(mesh).__name__))
    if method.startswith("bspline"):
        check_uniform_axes(method, tensor_grid(mesh)[0])
    if method in DOMAIN_METHODS and points.domain is None:
        raise InvalidInputError(
            "method {!r} needs point domains (MaterialPoints.domain); "
            "seed_points sets them on tensor-product grids; points of "
            "one's own take half-lengths per axis, shape (dim, n): "
            "np.tile(volume ** (1 / {}) / 2, ({}, 1)) for square domains"
            "{}".format(
                method, mesh.dim(), mesh.dim(),
                "; {!r} (the splines at the points) needs none"
                .format(method[:-5]) if method.startswith("bspline")
                else ""))
    material = at_points(material, points)
    obstacles = check_obstacles(obstacles, mesh.dim(), np.stack(
        [mesh.p.min(axis=1), mesh.p.max(axis=1)], axis=1))
    contacts, body_field = check_body_contacts(contacts, mesh, points,
                                               method, forces)
    moved_bodies = check_prescribed_bodies(prescribed, points, contacts)
    if contacts and stabilisation.extended_splines:
        raise InvalidInputError(
            "extended_splines with contacts between bodies is not "
            "implemented (each body's field would need its own extension); "
            "use the splines without it (the ghost penalty holds nodes "
            "held by slivers)")
    linear = kinematics == "small" and not is_plastic(material) \
        and not obstacles and not contacts
    rigid_bodies = check_rigid_bodies(rigid_bodies, points, mesh.dim(),
                                      method)
    check_combination(method, kinematics, is_plastic(material), newton,
                      stabilisation, dynamics, full_body_force=gravity is not
                      None and not ramp.all() or surface_in_full(forces),
                      driven=prescribed is not None
                      or bool(rigid_bodies),
                      contact=contact_named(obstacles, contacts))
    warn_stiff_smooth_bodies(rigid_bodies, material, points)
    warn_sparse_spline_points(method, mesh, points, is_plastic(material),
                              stabilisation.antilocking,
                              stabilisation.extended_splines)
    if any(isinstance(load, (Traction, Pressure)) for load in forces):
        warn_loaded_point_splines(method, stabilisation.extended_splines)
    if options.resume is not None:
        options.resume.check(nsteps, method)
    locator = options.locator
    if locator is not None and getattr(locator, "mesh", None) is not mesh:
        raise InvalidInputError(
            "locator must be point_locator(mesh) of the mesh solved on; this "
            "one {}".format("locates on another mesh" if hasattr(
                locator, "mesh") else "is not a point_locator"))
    locate = point_locator(mesh) if locator is None else locator
    if dynamics is None and (points.velocity is not None
                             or points.acceleration is not None):
        raise InvalidInputError(
            "the points carry a velocity or acceleration but the run is "
            "quasi-static (dynamics=None), which would drop them; pass "
            "dynamics=Dynamics(...) or clear them")
    refuse_duplicate_points(points, body_field)
    warn_empty_bodies(points)
    location = start_location(locate, points, options.kernels)
    warn_rigid_cells(rigid_bodies, mesh, points, locate if location is None
                     else lambda x: location)
    warn_volumes_vs_cells(mesh, points,
                          None if location is None else location[0])
    return Case(nsteps, material, linear, gravity, ramp, forces,
                None if prescribed is None else prescribed.function,
                rigid_bodies, terms, obstacles, tuple(contacts), body_field,
                moved_bodies, locate, location)


def start_location(locate, points: MaterialPoints, kernels: str):
    """The points located at the run's start by its locator ``locate``
    (with the run's ``kernels``, as its first step locates them), for
    the start's checks of the cells and for the first step, which
    reuses it (:func:`reuse_location`); ``None`` for points outside the
    grid (the first step names them)."""
    try:
        return using_kernels(locate, kernels)(points.x)
    except PointsOutsideGridError:
        return None


def reuse_location(piece, x: ndarray, location: tuple,
                   fields: Optional[Fields]) -> None:
    """Give ``piece``, the run's method, the location of its points at
    ``x`` that the run's start made (:func:`start_location`): its
    locator answers its first call, for those points (the same array),
    with it, and locates every other (5e5 points on triangles: 0.6 s
    saved; counted by the step, as before, where a resumed run's
    counters include it)."""
    grid_piece = getattr(piece, "piece", piece)       # a FieldMethod's
    if not isinstance(grid_piece, PointMethod):
        return
    tind, X = location
    if grid_piece is piece and fields is not None:    # the fields' cells
        tind = tind + fields.locate.offset
    later, start = grid_piece._locate, [(x, (tind, X))]

    def locate(y: ndarray) -> tuple:
        first = start.pop() if start else None
        return first[1] if first is not None and first[0] is y \
            else later(y)
    grid_piece._locate = locate


def initial_domains(piece, points: MaterialPoints):
    """The domains (dim, n) that the points' deformation stretches into
    theirs with ``piece``'s method (cpGIMP, averaged splines: by the
    stretch of ``F``): theirs unstretched, those of the points' initial
    state for points an earlier run deformed (a staged cpGIMP run in
    finite deformation stretched them twice: a pushed plate's force 2.2%
    low, 6.9% in plasticity, a user trial); their domains where the
    method keeps them, ``None`` without."""
    if points.domain is None:
        return None
    stretch = piece.domains(np.ones_like(points.domain), points.F)
    return points.domain if stretch is None else points.domain / stretch


def build_run(mesh: Mesh, elem: Element, points: MaterialPoints, supports,
              case: Case, method: str, kinematics: str, dynamics,
              options: Options):
    """The run's grid, pieces and terms, and its :class:`Result` holding
    a copy of the points (with their material's state and, in dynamics,
    velocities)."""
    result = Result(points=points.copy())
    points, counters = result.points, result.counters
    locate = point_locator(mesh) if case.locate is None else case.locate
    scalar, user_grid, scalar_dofs, pattern = grid_parts(mesh, elem)
    grid, fields, run_locate = user_grid, None, locate
    if case.contacts:             # a grid copy per field, supports on each
        fields = grid_fields(mesh, elem, case.body_field[points.body],
                             locate)
        grid, run_locate = fields.grid, fields.locate
    masses = None
    if dynamics is not None:
        masses = dynamics.masses(points)
        if points.velocity is None:
            points.velocity = np.zeros_like(points.x)
    for name, value in initial_state(case.material, points.n).items():
        points.state.setdefault(name, value)
    derive_elastic_state(points, case.material, kinematics == "finite")
    if kinematics == "small":
        warn_carried_from_finite(points, case.material)
    resume = options.resume or Resume()
    held = support_dofs(supports, user_grid)
    if case.location is not None:
        warn_interior_supports(mesh, user_grid.nodal_dofs, held,
                               case.location[0])
    piece = make_method(method, mesh, scalar, scalar_dofs, pattern, locate,
                        counters, fields,
                        extended=options.stabilisation.extended_splines,
                        held=np.isin(user_grid.nodal_dofs, held).any(axis=0),
                        kernels=options.kernels)
    if case.location is not None:
        reuse_location(piece, points.x, case.location, fields)
    domain0 = resume.domain0 if resume.domain0 is not None else \
        initial_domains(piece, points)
    result.domain0 = domain0
    run_mesh = mesh if fields is None else fields.mesh
    external = ExternalLoads(run_mesh, scalar, grid, case.gravity,
                             case.forces,
                             domain0, counters, points.n,
                             follow=kinematics == "finite",
                             moves=method != "fem", ramp_gravity=case.ramp,
                             weights=getattr(piece, "face_weights", None),
                             kernels=options.kernels)
    check_exposed(case.forces, points)     # the loads' indices checked
    if method in ("fem", "mpm"):
        piece.pattern.structure()        # set-up, shared by every step
    newton, stabilisation = options.newton, options.stabilisation
    first, retry = newton.strategies
    linear = case.linear
    run = Run(
        mesh=run_mesh, dim=mesh.dim(), grid=grid, method=piece,
        linear=linear, user_grid=user_grid,
        nfields=1 if fields is None else fields.count,
        contacts=case.contacts, body_field=case.body_field,
        finite=kinematics == "finite", cell_size=cell_size(mesh),
        kinematics=make_kinematics(kinematics, case.material, mesh.dim(),
                                   counters, total_lagrangian=method == "fem",
                                   kernels=options.kernels),
        loads=external, material=case.material,
        ghost=stabilisation.ghost_factor(),
        ghost_reserve=stabilisation.ghost_in_reserve(method),
        operator_wrappers=(
            increment_fbar if stabilisation.antilocking == "fbar"
            else mean_dilatation,) if stabilisation.antilocking else (),
        D=tile_dofs(held, user_grid.N, 1 if fields is None
                    else fields.count),
        prescribed=case.prescribed, rigid_bodies=case.rigid_bodies,
        prescribed_fields=None if case.prescribed_bodies is None
        else np.unique(case.body_field[list(case.prescribed_bodies)]),
        obstacles=case.obstacles, user_terms=tuple(case.terms),
        rhs=newton.rhs, tol=newton.tol, max_iter=newton.max_iter,
        grow_back=newton.grow_back,
        newton=FullStep() if linear else first,
        modified=newton.newton == "modified" and not linear,
        line_search=None if linear else retry,
        solver=get_solver(options.solver, mesh.dim()), counters=counters,
        keep_snapshots=options.keep_snapshots, domain0=domain0,
        resumed=resume.first_step > 1 or resume.load_factor is not None,
        dynamics=dynamics, masses=masses,
        scale=(lambda f: f) if dynamics is None
        else (lambda f: dynamics.scale(f * dynamics.duration)),
        initial_cells=None if case.prescribed is None
        else run_locate(points.x0)[0],
        # the grid's locator with point_locator's defaults (not a user's)
        grid_locate=locate if options.locator is None else None)
    terms = [term for term in (
        factory(run) for factory in GRID_TERMS) if term is not None]
    # those that weigh the balance in time after all others (stable)
    run.terms = sorted(terms + case.terms, key=lambda term: term.weighs)
    if resume.counters:
        # before the terms start: a resumed obstacle's penalty grown
        # before the resume (contact_penalty_growths) is grown again
        counters.update(resume.counters)
    for term in run.terms:
        term.begin_run(points)
    warn_resumed_terms(run, resume)
    if resume.end_force is not None:
        inertia = [term for term in run.terms
                   if isinstance(term, InertiaTerm)]
        if not inertia:
            raise InvalidInputError(
                "Resume.end_force is given to a quasi-static run: it is "
                "the contact's force where a dynamic run's step ended")
        inertia[0].resume(resume.end_force)
    solver = options.solver
    logger.info("linear solver: %s", solver if isinstance(solver, str) else
                "auto" if solver is None else
                getattr(solver, "__qualname__", repr(solver)))
    if case.prescribed is not None:       # grid DOFs that carried material
        run.initially_supported = np.zeros(grid.N, dtype=bool)
        run.initially_supported[grid.dofs.element_dofs[
            :, np.unique(run.initial_cells)]] = True
    return run, result
