"""One load or time step as a problem for a Newton driver.

A :class:`StepProblem` is built from the converged state at the step's
start: it locates the points and builds the step's point operator
(the method), finds the supported, prescribed and free DOFs
(:mod:`skfem_mpm.solve.motion`), maps the loads that do not depend on the
trial (:mod:`skfem_mpm.solve.loads`) and begins the run's grid terms
(:class:`~skfem_mpm.protocols.GridTerm`).  It then offers what a Newton
driver (:func:`skfem_mpm.solve.newton.newton`) asks for and nothing more:

- :meth:`StepProblem.start` ``() -> (du, response)``: where Newton
  starts (a term's predictor of a constraint's motion);
- :meth:`StepProblem.residual` ``(du) -> Trial``: the kinematics'
  response to a trial grid increment and its out-of-balance force;
- :meth:`StepProblem.tangent` ``(trial) -> K``;
- :meth:`StepProblem.solve` ``(K, r) -> (d, factorised solve)`` on the
  free DOFs;
- :meth:`StepProblem.commit` ``(trial, du) -> (new state, record)``.

The problem never names a particular term, kinematics or method.
"""
import logging
import math
import weakref
from typing import NamedTuple, Optional

import numpy as np
from numpy import ndarray
from scipy.linalg.blas import dnrm2
from scipy.sparse import issparse

from ..kernels import run_clock
from ..errors import GridMotionError, GridTermProtocolError, \
    MaterialRaisedError, NonFiniteGridTermError, NonFiniteMaterialError, \
    PointsOutsideGridError, SingularSystemError, SingularTangentError
from ..mechanics.materials import is_plastic
from ..stabilisation.volumetric import points_per_cell_axis
from ..protocols import Balance, of_package
from ..spelling import setting
from .backends import TINY
from .linear import Condensation, condensed, factorise_condensed, \
    free_dofs
from .motion import check_held, held_motion, unheld_rigid_modes
from .newton import trial_state
from .results import PHASES, StepRecord

logger = logging.getLogger(__name__)

#: a static run's first step from stressed points whose start is out of
#: balance by more than this share of the larger of the points' internal
#: force and the loads is warned about (:meth:`StepProblem.warn_start`)
#: where the method balances a balanced stress exactly: FE, and the
#: methods of linear cells from points that have not moved (a level
#: geostatic stress starts at round-off)
START_IMBALANCE = 1e-3
#: the share warned above where the discretisation leaves one of its
#: own: points that moved (a stage after a run that moved them: their
#: stresses, in balance where they were, are weighed where they are;
#: measured 0.0015-0.037, standard MPM 0.013-0.024, and 0.12 once, uGIMP
#: with Modified Cam-Clay near its limit) and B-splines (a geostatic
#: stress, :data:`B_SPLINE_START`: up to 0.046 at 2 points per cell);
#: the real causes measured start from 0.077 (a side left free under a
#: K0 stress), a Poisson's ratio changed 0.19, the weight ramped 1
START_INEXACT = .05
#: what the warning adds for points that moved (:data:`START_INEXACT`)
MOVED_START = (
    "; %s: a stage of points a run moved starts out of balance by their "
    "last move within their cells, their stresses, in balance where the "
    "points were, weighed where they are (standard MPM 0.013-0.024 "
    "measured, cpGIMP 0.0015-0.0041; not warned below %.2g), and the "
    "first step settles it")
#: what the warning adds for B-splines: their points' rule leaves a
#: geostatic stress out of balance at the surface's nodes (measured on a
#: Mohr-Coulomb layer under a level surface, docs/geomechanics.md)
B_SPLINE_START = (
    "; with B-splines a geostatic stress itself starts out of balance at "
    "the surface's nodes, the points' rule being inexact there: about "
    "0.023 at 2 points per cell along the vertical, 0.0057 at 4 (as 1 / "
    "n^2), round-off at an odd count with 'bspline' (a point on every "
    "knot, the cells' midpoints), 0.015 at 2 to 0.0017 at 6 with "
    "'bspline-gimp'; the first step settles it")


def is_bspline(method) -> bool:
    """Whether a run's method (or its piece: fields) is a B-spline's."""
    from ..methods.method import BSplineMethod
    return isinstance(getattr(method, "piece", method), BSplineMethod)


def spline_start_inexact(method, mesh, points) -> bool:
    """Whether a B-spline method leaves a level geostatic stress out of
    balance by its points' rule (:data:`B_SPLINE_START`): every one but
    the quadratic splines at the points (``"bspline"``) seeded an odd
    count a cell and axis, a point on every knot, which balance it to
    round-off (a review: the weight 5% off was left unwarned under the
    splines' own limit there, standard MPM warned at 1.6%)."""
    if not is_bspline(method):
        return False
    if getattr(getattr(method, "piece", method), "name", "") != "bspline":
        return True
    per_axis = points_per_cell_axis(mesh, points)
    return not (abs(per_axis - round(per_axis)) < 1e-6
                and round(per_axis) % 2 == 1)

__all__ = ["StepProblem", "Trial", "STABILISATION", "STABILISATION_FLOOR"]

#: the round-off floor of a static step's residual, as a share of the
#: points' stresses' force at its first trial (its norm over every DOF,
#: supports' and driven ones too) where no term sets one (dynamics:
#: :data:`~skfem_mpm.solve.dynamics.ROUNDOFF`, its value): a residual
#: norm at or below it is converged whatever the tolerance.  A step whose
#: loads and driven forces are nothing but round-off has no other force
#: to be measured against: a rough pile pulled out of weightless clay,
#: all its pairs let go, took the round-off of its own stress as the
#: driven force, 5e-12 (3e-13 of the soil's forces, growing with the
#: pile's stiffness), its first residual was 1.9e12 and the step failed.
#: Not the trial's forces, nor the contacts' (a pile's obstacle pushed
#: 0.01 into weightless soil at the first trial, a trial's stresses 1e3
#: times the yield stress: measured against them, its Newton took
#: another path, 53 iterations for 202, its force 2.5% off)
STATIC_ROUNDOFF = 1e-12
#: the fraction of its diagonal added to a tangent refused as singular, or
#: when a failed step is retried so (:meth:`StepProblem.solve`)
STABILISATION = 1e-7
#: and the least diagonal of such a tangent where the exact one was
#: refused as singular in a plastic run, or a step is retried with it
#: floored (:attr:`StepProblem.floored`), a fraction of the median of
#: its diagonal's sizes: points at a perfectly plastic apex keep 1e-8 of
#: their elastic stiffness, and a share of the diagonal adds nothing to
#: the nodes they alone hold (cohesionless soil beside a rough wall, its
#: top at Mohr-Coulomb's apex, failed at every cut-back; a user trial's
#: Mohr-Coulomb footing with standard MPM stopped at half its push).
#: Not in the retry that stabilises every solve: B-splines' edge nodes
#: hold diagonals down to 1e-9 of the median, and floored they slowed a
#: retry that converged in 2 iterations past its 25 (a reviewer's slope)
STABILISATION_FLOOR = 1e-3
#: a converged step whose free grid nodes moved more than this many times
#: the largest motion of a point (and more than a millionth of a cell)
#: failed (:class:`~skfem_mpm.errors.GridMotionError`): well-posed steps
#: stay below 1e3 (GIMP's barely supported corner nodes), a node supported
#: by a sliver of material reached 1e7
ABSURD_GRID_MOTION = 1e5
#: grid nodes whose support holds less material than this many cells'
#: volume are slivers, and a converged step whose slivers alone move a
#: point by more than :data:`THROWN` cells failed
#: (:meth:`StepProblem.check_thrown`)
SLIVER_SUPPORT = 1e-3
#: the cells a point may be moved by sliver nodes alone
THROWN = 1.
#: grid nodes whose support holds less material than this many cells'
#: volume are light: a converged step whose light nodes move a point by
#: more than :data:`THROWN` cells beyond its other nodes' motion failed
#: (:meth:`StepProblem.check_thrown`): a user trial's upper body of two
#: in rough contact (uGIMP, small strain, ``ghost=0``) had its corner
#: point thrown 3 cells through the lower body by nodes holding 0.016
#: and 0.047 cells (moved 35 and 17 cells) where its other nodes moved
#: 0.02 cells, every node above the slivers' 1e-3
LIGHT_SUPPORT = .1
#: the displacement gradient a small-strain step may give a point through
#: sliver nodes alone, and its ratio to the median point's gradient
#: (:meth:`StepProblem.check_thrown`): small strain is void beyond it, and
#: a user trial's cpGIMP cantilever (elastic, one linear solve a step) had
#: its tip corner's point turned by 100 degrees in a step by a node beyond
#: the tip its domain barely reached (a gradient of 1.7 by that node, the
#: median point's 0.016; at a third of that load 0.10 and 0.45 in two
#: steps, the median 0.005, the corner turned 24 degrees where the beam
#: turned 3)
THROWN_GRADIENT, THROWN_GRADIENT_RATIO = .1, 10.


class Trial(NamedTuple):
    """The out-of-balance state of one trial grid increment: the
    kinematics' response, the out-of-balance force ``r`` (grid vector), its
    norm over the free DOFs (``merit``) and that norm relative to the
    external force (``residual``, the convergence measure)."""
    response: object
    r: ndarray
    merit: float
    residual: float


def safe_norm(v: ndarray) -> float:
    """The 2-norm of ``v`` without underflow or overflow of its squares
    (forces of 1e-300 or 1e+200 N): ``sqrt(v . v)`` where that is safe
    (numpy's ``norm`` to the bit, without its dispatch: 3.6 -> 2.8 us a
    call at 112 entries), BLAS's scaled ``dnrm2`` otherwise."""
    if v.size == 0:
        return 0.
    x = np.asarray(v, dtype=np.float64).ravel(order="K")
    with np.errstate(over="ignore", under="ignore"):
        norm = math.sqrt(x.dot(x))
    if TINY < norm < 1e150:
        return norm
    return float(dnrm2(np.ascontiguousarray(v, dtype=np.float64)))


def entries_among(K, G) -> tuple:
    """Where the entries of ``G`` lie among those of ``K`` (csr, both
    canonical), ``G``'s rows alone searched (a contact's few: the keys
    of all of ``K`` took 0.09 s a tangent at 1e5 points):
    ``(below, pos, at, found)``, per entry of ``G`` its row, and per
    entry of ``K`` in those rows its place in ``K`` (``pos``), where each
    of ``G``'s entries would go among them in order of (row, column)
    (``at``), and whether ``K`` has it (``found``; then at ``pos[at]``).

    >>> from scipy.sparse import csr_matrix
    >>> K = csr_matrix(np.array([[1., 0.], [0., 2.]]))
    >>> G = csr_matrix(np.array([[0., 3.], [0., 4.]]))
    >>> [a.tolist() for a in entries_among(K, G)]
    [[0, 1], [0, 1], [1, 1], [False, True]]
    """
    nrows, ncols = K.shape[0], np.int64(K.shape[1])
    below = np.repeat(np.arange(nrows, dtype=np.int64), np.diff(G.indptr))
    wanted = below * ncols + G.indices
    rows = np.unique(below)
    counts = np.diff(K.indptr)[rows]
    pos = np.repeat(K.indptr[rows] - np.cumsum(counts) + counts,
                    counts) + np.arange(counts.sum())
    keys = np.repeat(rows, counts) * ncols + K.indices[pos]
    at = np.searchsorted(keys, wanted)
    found = at < keys.size
    found[found] = keys[at[found]] == wanted[found]
    return below, pos, at, found


def union_places(K, G, among: Optional[tuple] = None) -> tuple:
    """The union of the patterns of ``K`` and ``G`` (csr, both
    canonical, ``G``'s rows few; ``among``: :func:`entries_among` of
    them, if at hand): ``(indices, indptr, old, added, at_G)``, the
    union's column indices and row pointers, which of its entries are
    ``K``'s (a mask: ``K``'s in order), the places of ``G``'s entries
    outside ``K``'s pattern, and the place of each of ``G``'s entries
    in the union.  At 1e5 points (1.9e6 entries in ``K``, 5.9e3 in
    ``G``) 2 ms where marking both patterns in a sum took 9-130 ms.

    >>> from scipy.sparse import csr_matrix
    >>> K = csr_matrix(np.array([[1., 0.], [0., 2.]]))
    >>> G = csr_matrix(np.array([[0., 3.], [0., 4.]]))
    >>> indices, indptr, old, added, at_G = union_places(K, G)
    >>> indices.tolist(), indptr.tolist(), old.tolist(), added.tolist()
    ([0, 1, 1], [0, 2, 3], [True, False, True], [1])
    >>> at_G.tolist()
    [1, 2]
    """
    below, pos, at, found = entries_among(K, G) if among is None \
        else among
    new = ~found
    # a new entry goes after its row's entries of smaller columns: the
    # row's start in K plus those (``at`` less the row's first in ``pos``)
    inserted = K.indptr[below[new]] + at[new] - np.searchsorted(
        pos, K.indptr[below[new]])
    added = inserted + np.arange(inserted.size)   # past the new before
    old = np.ones(K.nnz + added.size, dtype=bool)
    old[added] = False
    indices = np.empty(old.size, dtype=K.indices.dtype)
    indices[old] = K.indices
    indices[added] = G.indices[new]
    indptr = K.indptr.astype(np.int64)
    indptr[1:] += np.cumsum(np.bincount(below[new], minlength=K.shape[0]))
    at_G = np.empty(G.nnz, dtype=np.int64)
    kept = pos[at[found]]       # K's entry j moves by the inserts <= j
    at_G[found] = kept + np.searchsorted(inserted, kept, side="right")
    at_G[new] = added
    return indices, indptr.astype(indices.dtype), old, added, at_G


def add_union(K, G, kept: Optional[dict] = None,
              among: Optional[tuple] = None):
    """``K + G`` (csr, both canonical, ``G``'s rows few) on the union of
    their patterns, every explicit zero of both kept (scipy's sum drops
    them): the sum's pattern is the same at rest as later, so a direct
    solver analyses it once (contact between bodies at 1e5 points: two
    Pardiso analyses a step, 0.2 s).  Each entry's sum is scipy's
    (``K_ij + G_ij``).  The union's places (:func:`union_places`, from
    ``among`` if at hand) are kept in ``kept`` (a step's, whose tangents
    share them) for the last pair of patterns; ``K``'s entries are laid
    into the union by its kept mask of them (``np.insert`` makes one at
    every call: 25 ms a tangent against 15 on average over 45 tangents of
    contact between bodies at 1e5 points, where fresh memory's first
    touch takes most of either; 1 ms warm).

    >>> from scipy.sparse import csr_matrix
    >>> K = csr_matrix((np.array([1., 0., 2.]), np.array([0, 1, 1]),
    ...                 np.array([0, 2, 3])))
    >>> G = csr_matrix((np.array([0., 1.]), np.array([0, 0]),
    ...                 np.array([0, 1, 2])), shape=(2, 2))
    >>> S = add_union(K, G)
    >>> S.nnz, S.toarray().tolist()
    (4, [[1.0, 0.0], [1.0, 2.0]])
    """
    kept = {} if kept is None else kept
    last = kept.get("union")
    if last is None or last[0]() is not K.indptr or \
            last[1]() is not K.indices or not (
                np.array_equal(last[2], G.indptr)
                and np.array_equal(last[3], G.indices)):
        last = (weakref.ref(K.indptr), weakref.ref(K.indices),
                G.indptr.copy(), G.indices.copy()) + union_places(
                    K, G, among)
        kept["union"] = last
    indices, indptr, old, added, at_G = last[4:]
    data = np.empty(old.size)
    data[old] = K.data
    data[added] = 0.
    data[at_G] += G.data
    return type(K)((data, indices, indptr), shape=K.shape)


def add_within(K, G, kept: Optional[dict] = None):
    """``K + G`` (csr) on ``K``'s pattern where ``G``'s entries lie in it,
    ``K``'s explicit zeros kept (scipy's sum drops them, and a direct
    solver that saw the pattern with them analyses it again: a step with
    a floor obstacle at 1e5 points paid a second Pardiso analysis, 0.13-
    0.3 s, because the first tangent's zeros at rest were dropped);
    on the union of both patterns where they do not (:func:`add_union`;
    contact between bodies couples nodes of two fields).

    >>> from scipy.sparse import csr_matrix
    >>> K = csr_matrix((np.array([1., 0., 2.]), np.array([0, 1, 1]),
    ...                 np.array([0, 2, 3])))
    >>> S = add_within(K, csr_matrix(np.array([[1., 0.], [0., 1.]])))
    >>> S.nnz, S.toarray().tolist()
    (3, [[2.0, 0.0], [0.0, 3.0]])
    """
    K = K.tocsr()
    G = G.tocsr()
    if not K.has_sorted_indices:
        K = K.sorted_indices()
    G.sum_duplicates()
    if K.shape != G.shape:
        return (K + G).tocsr()
    below, pos, at, found = among = entries_among(K, G)
    if not found.all():
        return add_union(K, G, kept, among)
    data = K.data.copy()
    data[pos[at]] += G.data
    return type(K)((data, K.indices, K.indptr), shape=K.shape)


def step_words(step) -> str:
    """``"step 3: "`` for an error's words, ``""`` without a step."""
    return "" if step is None else "step {}: ".format(step)


def term_vector(term, method: str, f, N: int, step: int = None):
    """``f``, what ``term.method`` returned, checked where the term is a
    user's (:func:`~skfem_mpm.protocols.of_package`): ``None`` or a grid
    vector of shape ``(N,)`` (:class:`~skfem_mpm.errors.
    GridTermProtocolError` naming the term, the method, the expected and
    the given shape; a shape a sum would broadcast or refuse said
    "operands could not be broadcast", trial 116).  Finiteness is not
    checked here, only where the residual is not finite
    (:meth:`StepProblem.non_finite_term`).

    >>> class Short:
    ...     pass
    >>> Short.__module__ = "my_terms"          # (a doctest's is ours)
    >>> term_vector(Short(), "force", np.zeros(3), 4)
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.GridTermProtocolError: Short.force returned an array of shape (3,) where a grid vector of shape (4,) is expected (op.N, the step's grid DOFs: problem.op.N in begin_step)
    """
    if f is None or of_package(term) or np.shape(f) == (N,):
        return f
    name = type(term).__name__
    given = "an array of shape {}".format(np.shape(f)) if isinstance(
        f, np.ndarray) else "a {} of shape {}".format(type(f).__name__,
                                                      np.shape(f))
    raise GridTermProtocolError(
        "{}{}.{} returned {} where a grid vector of shape ({},) is "
        "expected (op.N, the step's grid DOFs: problem.op.N in "
        "begin_step)".format(step_words(step), name, method, given, N),
        term=name, method=method)


def term_matrix(term, G, N: int, finite: bool, step: int = None):
    """``G``, what ``term.matrix`` returned, checked where the term is a
    user's: ``None`` or a scipy sparse matrix of shape ``(N, N)``
    (:class:`~skfem_mpm.errors.GridTermProtocolError`: a dense array had
    ended in "'numpy.ndarray' object has no attribute 'tocsr'", a
    smaller matrix in "inconsistent shapes", trial 116); with ``finite``
    (a step's first tangent) its entries finite too
    (:class:`~skfem_mpm.errors.NonFiniteGridTermError`: NaN had been
    called a singular stiffness).

    >>> from scipy.sparse import identity
    >>> class Dense:
    ...     pass
    >>> Dense.__module__ = "my_terms"          # (a doctest's is ours)
    >>> term_matrix(Dense(), np.eye(2), 2, False)
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.GridTermProtocolError: Dense.matrix returned a dense ndarray of shape (2, 2) where a scipy.sparse matrix of shape (2, 2) is expected (op.N, the step's grid DOFs: problem.op.N in begin_step; scipy.sparse.csr_matrix(...))
    >>> term_matrix(Dense(), identity(3), 2, False)
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.GridTermProtocolError: Dense.matrix returned a sparse matrix of shape (3, 3) where a scipy.sparse matrix of shape (2, 2) is expected (op.N, the step's grid DOFs: problem.op.N in begin_step; scipy.sparse.csr_matrix(...))
    """
    if G is None or of_package(term):
        return G
    name = type(term).__name__
    sparse = issparse(G)
    if not sparse or G.shape != (N, N):
        raise GridTermProtocolError(
            "{}{}.matrix returned {} of shape {} where a scipy.sparse "
            "matrix of shape ({}, {}) is expected (op.N, the step's grid "
            "DOFs: problem.op.N in begin_step; scipy.sparse.csr_matrix("
            "...))".format(step_words(step), name, "a sparse matrix"
                           if sparse else "a dense {}".format(
                               type(G).__name__), np.shape(G), N, N),
            term=name, method="matrix")
    if finite:
        bad = ~np.isfinite(G.data if G.format in ("csr", "csc", "coo",
                                                  "bsr")
                           else G.tocoo().data)
        if bad.any():
            raise NonFiniteGridTermError(
                "{}{}.matrix returned NaN or inf in {} of its {} stored "
                "entries".format(step_words(step), name, int(bad.sum()),
                                 bad.size),
                term=name, method="matrix")
    return G


class StepProblem:
    """The load (or time) step of ``run`` from load factor ``f_old`` to
    ``f_new`` starting from the converged state ``points``.

    Attributes
    ----------
    op
        The step's point operator (the method's, wrapped by the run's
        operator stabilisations).
    method_op
        The method's point operator, not wrapped: the displacement and
        its plain gradient at the points.
    fixed, free, driven, du0
        Held, free and moving grid DOFs; the prescribed start increment.
    f_dead
        The external force that does not depend on the trial (at the
        loads' scale ``s_new``; a time integrator may weigh it in
        :meth:`~skfem_mpm.protocols.GridTerm.begin_step`).
    load_weight
        Weight of the trial-dependent loads (1; a generalised-alpha
        integrator sets ``1 - alpha_f``).
    terms
        The grid terms' contributions to this step.
    t
        Seconds per phase (:data:`~skfem_mpm.solve.results.PHASES`).
    """

    def __init__(self, run, points, f_old: float, f_new: float, step: int):
        self.run, self.points, self.step = run, points, step
        self.f_old, self.f_new = f_old, f_new
        self.counters, self.grid = run.counters, run.grid
        self.t = t = dict.fromkeys(PHASES, 0.)
        # what a back end keeps from earlier steps' matrices (an AMG
        # hierarchy) goes: a step computes the same from a checkpoint
        getattr(run.solver, "forget", lambda: None)()
        op = run.method.operator(points, step, t)
        self.method_op = op
        tic = run_clock()
        for wrap in run.operator_wrappers:
            op = wrap(op, points)
        self.op = op
        self.s_old, self.s_new = run.scale(f_old), run.scale(f_new)
        held = held_motion(run, op, points, self.s_old, self.s_new, step)
        self.fixed, self.du0, self.driven, self.rigid_dofs = held
        run.method.check_supports(op, self.fixed, self.grid.nodal_dofs, step)
        held_by_terms = [h for h in (
            term.held_dofs(self.method_op, points, self.s_old)
            for term in run.terms) if h is not None]
        #: the DOFs the terms hold as supports would at the step's start
        #: (an obstacle's, a contact's pairs' rows): :meth:`start_share`
        self.held_by_terms = np.unique(np.concatenate(held_by_terms)) \
            if held_by_terms else np.zeros(0, dtype=int)
        held = np.union1d(self.fixed, self.held_by_terms).astype(
            self.fixed.dtype) if held_by_terms else self.fixed
        check_held(run, op, held, step, bool(held_by_terms))
        self.free = free_dofs(op.active_dofs, self.fixed)
        self.f_dead = run.loads.external(op, points, self.s_new)
        self._kept_norm = None          # f_dead's norm (_dead_norm)
        #: the internal force's norm at the step's first trial (its start,
        #: :attr:`du0`): the scale of a step that nothing loads or drives
        self.start_force = None
        #: and its points' stresses' part (:data:`STATIC_ROUNDOFF`)
        self.start_stresses = None
        self.load_weight = 1.
        self.stabilised = False        # a solve used the stabilised tangent
        #: the stabilised tangent's diagonal floored at
        #: :data:`STABILISATION_FLOOR` of its median size (a retry's)
        self.floored = False
        #: how many free DOFs a floored solve raised to the floor that the
        #: step's first tangent held above it: nodes whose points went to
        #: a plastic apex within the step (the retry ladder's ghost rung)
        self.collapsed = 0
        self.unsettled = []     # (settled) the terms that did not settle
        self.reshaped = False   # (settled) and changed their constraints
        self._first_diagonal = None     # of the step's first tangent
        self._own = None    # the last tangent made of arrays of its own
        self._gradients = None  # (du, its gradients): increment_gradients
        self._supports = None   # the grid nodes' material: slivers
        self._union = {}        # add_within's places of a pattern union
        #: the user's terms' matrices checked finite (a step's first
        #: tangent: :func:`term_matrix`)
        self._matrices_checked = False
        self.terms = []
        absent = []     # user's terms that hold a free body, not in it
        for term in run.terms:             # in order: a term may use those
            begun = term.begin_step(self)  # before it (their loads)
            if begun is not None:
                self.terms.append(begun)
            elif term.holds_free_body and not of_package(term):
                absent.append(type(term).__name__)
        if absent:
            self.check_held_without(held, absent)
        self.settles = any(getattr(term, "settles", False)
                           for term in self.terms)
        t["assemble"] += run_clock() - tic

    def check_held_without(self, held: ndarray, absent: list) -> None:
        """The check of the supports that a user's term setting
        ``holds_free_body`` left out (:func:`~skfem_mpm.solve.motion.
        check_held`), made where its ``begin_step`` returned ``None``
        (``absent``: their class names) and no other term of the step
        holds a free body: a :class:`~skfem_mpm.errors.
        SingularSystemError` naming them where the supports leave a
        rigid-body mode (trial 116's spring bed whose ``begin_step``
        returned ``None`` ended in "Newton made no progress" after 8
        cut-backs, the term unnamed)."""
        if any(getattr(term, "holds_free_body", False)
               for term in self.terms):
            return
        err = unheld_rigid_modes(self.run, self.op, held, self.step)
        if err is not None:
            names = ", ".join(sorted(set(absent)))
            raise SingularSystemError(
                "{}; {}.begin_step returned None in this step (the term "
                "adds nothing to it) though the term sets holds_free_body "
                "= True, which left this check of the supports out: "
                "return the term (self) from begin_step where it holds "
                "the body".format(err, names)) from err

    @property
    def linear(self) -> bool:
        """One exact solve makes the step (small strain, elastic)."""
        return self.run.linear

    @property
    def keeps_factorisations(self) -> bool:
        """The linear solver factorises once for many right-hand sides
        (``factorise(A)``); a solver function without it factorises at
        every call."""
        return hasattr(self.run.solver, "factorise")

    def internal_force(self, du: ndarray, response,
                       start: bool = False, parts: bool = False):
        """The static internal force of a trial: the points' stresses and
        the terms' forces; with ``start`` (``du`` zero) the force where the
        step starts, each term's :meth:`~skfem_mpm.protocols.GridTerm.
        start_force`.  With ``parts`` ``(f_int, internal, contact)``: the
        sum as without, the points' stresses' part with the forces of the
        terms that are not contacts, and the sum of the forces of those
        that are (:attr:`~skfem_mpm.protocols.GridTerm.contact`; ``None``
        where none exerts one), which dynamics books the work of apart
        (``internal_work``, ``contact_work``)."""
        f_int = self.op.force(response.P, response.w) \
            if response.force is None else response.force()
        points = f_int.copy() if parts else None
        terms = None
        for term in self.terms:
            f = term_vector(term, "start_force", term.start_force(
                du, response), f_int.shape[0], self.step) if start else \
                term_vector(term, "force", term.force(du, response),
                            f_int.shape[0], self.step)
            if f is None:
                continue
            f_int += f
            if parts and getattr(term, "contact", False):
                terms = f.copy() if terms is None else terms + f
            elif parts:
                points += f
        return (f_int, points, terms) if parts else f_int

    def trial_loads(self, response, scale: float):
        """The sum of the terms' trial-dependent loads at the loads' scale
        ``scale``, or ``None``."""
        total = None
        for term in self.terms:
            f = term_vector(term, "load", term.load(response, scale),
                            self.op.N, self.step)
            if f is not None:
                total = f if total is None else total + f
        return total

    def start(self, stabilise: bool = False):
        """Where Newton starts: ``(du, response)``, the increment and the
        kinematics' response to it (or ``None``).  :attr:`du0`, or where
        a term's constraint moves off material it held at the step's
        start (an obstacle moving away), ``du0`` plus the term's
        predictor of that motion
        (:meth:`~skfem_mpm.protocols.GridTerm.predictor`, solved with the
        tangent stabilised where ``stabilise``) where that lowers the
        residual.  A step that drives prescribed motion takes the Newton
        driver's own predictor instead."""
        self.warn_start()
        du = self.du0
        if self.driven.size:
            return du, None
        for term in self.terms:
            # (an object of a term's interface from before it had one)
            predictor = getattr(term, "predictor", None)
            found = None if predictor is None else predictor(self, du)
            if found is None:
                continue
            try:
                d = self.solve(*found, stabilise)[0]
            except SingularSystemError as err:
                logger.debug("step %d: no predictor: %s", self.step, err)
                break
            before = self.residual(du).merit
            trial, merit = trial_state(self.residual, du + d)
            logger.debug("step %d: the predictor of %s moves the grid up "
                         "to %.3g, residual %.3g of the start's", self.step,
                         type(term).__name__, float(np.abs(d).max()),
                         merit / max(before, TINY))
            if merit < before:
                return du + d, trial.response
            break
        return du, None

    def residual(self, du: ndarray, response=None) -> Trial:
        """The out-of-balance state of the grid increment ``du``; with the
        kinematics' ``response`` to it where that is at hand (the last
        trial's, whose work arrays nothing has overwritten since: a step
        solved again after a term moved its constraint)."""
        if response is None:
            tic = run_clock()
            try:
                response = self.run.kinematics.response(self.op, du,
                                                        self.points)
            except (MaterialRaisedError, NonFiniteMaterialError) as err:
                # where the step starts (no increment) a shorter step
                # calls the material alike: not retried (core.attempt;
                # a model returning NaN there was cut back 8 times for
                # nothing, trial 119)
                err.at_start = not np.any(du)
                err.args = ("step {}: {}{}".format(
                    self.step, err.args[0], " where the step starts (no "
                    "increment: every shorter step evaluates that state "
                    "again)" if err.at_start else ""),) + err.args[1:]
                raise
            self.t["update"] += run_clock() - tic
        tic = run_clock()
        f_ext = self.f_dead
        follower = self.trial_loads(response, self.s_new)
        if follower is not None:         # a pressure on the trial surface
            f_ext = f_ext + self.load_weight * follower
        if self.start_stresses is None:
            f_int, stresses, _ = self.internal_force(du, response,
                                                     parts=True)
            self.start_stresses = safe_norm(stresses)
        else:
            f_int = self.internal_force(du, response)
        # relative to the larger of the loads and the forces that drive the
        # prescribed motion: a step driven by prescribed motion under a
        # small weight is measured against the forces it drives (and in
        # dynamics against the inertia force: a free vibration)
        balance = Balance(f_int, f_ext, max(
            safe_norm(f_ext) if follower is not None else self._dead_norm(),
            safe_norm(f_int[self.driven]) if self.driven.size else 0.))
        for term in self.terms:
            term.weigh(balance, du)
        r = balance.f_ext - balance.f_int
        if self.start_force is None:
            self.start_force = safe_norm(balance.f_int)
        scale, floor = balance.scale, balance.floor
        if floor == 0. and scale > 0.:  # (none: measured as below)
            floor = STATIC_ROUNDOFF * self.start_stresses
        if floor > 0.:                # a residual at the round-off of the
            # forces the balance sums is converged (a body in free flight,
            # a driven body that carries nothing)
            scale = max(scale, floor / self.run.tol)
        if scale == 0.:               # nothing loads or drives: the stresses
            # at the step's start and now (an initial stress unloaded to
            # none: measured against its own vanishing forces, the round-
            # off of a converged step was 0.93 of them, a user trial)
            scale = max(safe_norm(balance.f_int), self.start_force, TINY)
        merit = safe_norm(r[self.free])
        self.t["check"] += run_clock() - tic
        if not np.isfinite(merit):
            self.non_finite_term(du, response)
        return Trial(response, r, merit, merit / scale)

    def non_finite_term(self, du: ndarray, response) -> None:
        """Where a trial's residual is not finite: raise
        :class:`~skfem_mpm.errors.NonFiniteGridTermError` naming the
        first grid term of the user's own whose force or load there is
        not (each asked again: the check costs nothing in a step whose
        residual is finite; trial 116's NaN in a spring bed's force was
        "Newton-Raphson did not converge in 0 iterations (residual first
        nan)" after 8 cut-backs, the term never named)."""
        for term in self.terms:
            if of_package(term):
                continue
            for method, f in (("force", lambda: term.force(du, response)),
                              ("load", lambda: term.load(response,
                                                         self.s_new))):
                value = f()
                if value is None:
                    continue
                bad = ~np.isfinite(np.asarray(value, dtype=float))
                if bad.any():
                    name = type(term).__name__
                    raise NonFiniteGridTermError(
                        "step {}: {}.{} returned NaN or inf at {} of its {} "
                        "grid DOFs, the first {}".format(
                            self.step, name, method, int(bad.sum()),
                            bad.size, np.flatnonzero(bad)[:5].tolist()),
                        term=name, method=method)

    def start_imbalance(self, like: ndarray) -> Optional[float]:
        """The out-of-balance force's norm over the free DOFs at the step's
        start: no increment (``like``'s zeros), the loads at the start's
        scale; ``None`` in dynamics (its integrator weighs the loads).
        What no cut-back of the step shrinks (:func:`~skfem_mpm.solve.
        core.start_hint`); a trial's state, evaluated on a failure."""
        if self.run.dynamics is not None:
            return None
        found = self.start_forces(like)
        return None if found is None else safe_norm(found[0][self.free])

    def start_forces(self, like: ndarray, end: bool = False
                     ) -> Optional[tuple]:
        """The step's start (see :meth:`start_imbalance`): the
        out-of-balance force, the internal and the external force
        (each of ``like``'s shape); ``None`` in dynamics.  With ``end``
        the points unmoved under the step's end: the loads at its end
        and each term's force there."""
        if self.run.dynamics is not None:
            return None
        scale = self.s_new if end else self.s_old
        zero = np.zeros_like(like)
        response = self.run.kinematics.response(self.op, zero, self.points)
        f_ext = self.run.loads.external(self.op, self.points, scale)
        follower = self.trial_loads(response, scale)
        if follower is not None:
            f_ext = f_ext + self.load_weight * follower
        # each term's force where the step starts (an obstacle where the
        # last step left it: with its force at the step's end, a block at
        # rest pushed by an obstacle read the push as its start's)
        f_int = self.internal_force(zero, response, start=not end)
        return f_ext - f_int, f_int, f_ext

    def start_share(self, end: bool = False) -> Optional[float]:
        """The out-of-balance force at the step's start (see
        :meth:`start_imbalance`) over the larger of the points' internal
        force and the loads there (norms over the free DOFs but those the
        terms hold as supports would, :attr:`held_by_terms`: a contact's
        force balances them as a support's reaction does, and in a run's
        first step starts from none, its multipliers yet to come, where
        the layer on an obstacle floor was out of balance by its whole
        weight, share 1, a fuzzer's trial); ``None`` in dynamics, 0 where
        neither acts.  With ``end`` the points' start under the step's
        end (:meth:`start_forces`)."""
        found = self.start_forces(self.du0, end)
        if found is None:
            return None
        kept = np.setdiff1d(self.free, self.held_by_terms,
                            assume_unique=True)
        r, f_int, f_ext = (safe_norm(f[kept]) for f in found)
        size = max(f_int, f_ext)
        return r / size if size > 0. else 0.

    def warn_start(self) -> None:
        """A warning, once a run, where a static run's first step starts
        from points that carry a stress out of balance (its
        :meth:`start_share` above :data:`START_IMBALANCE`, or above
        :data:`START_INEXACT` with B-splines (:func:`spline_start_inexact`)
        and from points that moved,
        whose discretisation leaves a share of its own): the step
        carries it at once, and no cut-back or ``nsteps`` spreads it.
        Not where the start balances the step's end loads and the step
        ends the run (``nsteps=1``: no state between is computed).
        Unstressed points are not checked (nothing to compute), nor
        dynamics, where an unbalanced start is an initial value (a
        release: the body accelerates) that the inertia term weighs."""
        run = self.run
        warned = getattr(run, "warned", None)
        if self.step != 1 or warned is None or "start" in warned \
                or getattr(run, "resumed", False) or run.dynamics is not None \
                or not np.any(self.points.stress):
            return
        warned.add("start")
        share = self.start_share()
        moves = getattr(run.method, "moves", True)
        moved = moves and bool(np.any(self.points.displacement))
        spline = spline_start_inexact(run.method, run.mesh, self.points)
        limit = START_INEXACT if moved or spline else START_IMBALANCE
        if share is None or not share > limit:
            return
        if self.f_new >= 1. - 1e-9 and not np.any(self.du0) \
                and self.start_share(end=True) <= limit:
            # the run's one step, whose end the start balances: no state
            # between them is computed (a geostatic start under a weight
            # ramped in one step was warned at share 1, a user trial)
            return
        logger.warning(
            "step 1 starts from stressed points out of balance: the "
            "out-of-balance force at the start (no increment, the loads "
            "at load factor %.3g) is %.2g of the larger of the points' "
            "internal force and the loads, and the step carries it at "
            "once (no cut-back or nsteps spreads it).  Usual causes: the "
            "body force ramped up (BodyForce(..., ramp=True), the "
            "default) under a stress that holds the weight already "
            "(ramp=False); a stress of the wrong sign (tension is "
            "positive, compression negative); a material or stiffness "
            "other than the one the stress was made with (the points' "
            "elastic strain is read with the new one); a grid other than "
            "the stress's; a geostatic stress under a surface other "
            "than the material's top (geostatic_stress's surface=; "
            "points without domains are taken for squares of their "
            "volumes there, Gauss points need it given); by design, an "
            "excavation's stage (the removed "
            "points' force acts in full in step 1)%s%s", self.f_old, share,
            B_SPLINE_START + " (not warned below %.2g)" % START_INEXACT
            if spline else "",
            MOVED_START % (
                "the points moved in an earlier run" if moved else
                "if the points moved in an earlier run (a stage whose "
                "displacement was started from zero)", START_INEXACT)
            if moved or moves and not spline and share <= START_INEXACT
            else "")

    def _dead_norm(self) -> float:
        """The norm of :attr:`f_dead`, found once for each array a step
        holds there (a term replaces it, never writes it: a time
        integrator's weighing in ``begin_step``)."""
        kept = self._kept_norm
        if kept is None or kept[0] is not self.f_dead:
            kept = self._kept_norm = (self.f_dead, safe_norm(self.f_dead))
        return kept[1]

    def converged(self, trial: Trial) -> bool:
        return trial.residual <= self.run.tol

    def settled(self, trial: Trial, du: ndarray) -> bool:
        """After Newton converged to ``trial`` (increment ``du``): whether
        every term's constraints hold (each term asked, so each may update
        itself for the next solve; those that weigh the balance in time
        once the others hold); :attr:`unsettled` keeps the terms
        whose constraints did not (for the step's error).  Timed as
        ``check`` (a 3D contact run's 736 rounds of pair searches and
        settle checks were in no phase: its time line said 81% "set-up
        and output")."""
        tic = run_clock()
        # the terms that weigh the balance in time (inertia) check a step
        # the others have settled, not one of a round's
        weighs = [getattr(term, "weighs", False) for term in self.terms]
        self.unsettled = [term for term, last in zip(self.terms, weighs)
                          if not last and not term.settle(self, trial, du)]
        if not self.unsettled:
            self.unsettled = [term for term, last in zip(self.terms, weighs)
                              if last and not term.settle(self, trial, du)]
        self.t["check"] += run_clock() - tic
        self.reshaped = any(getattr(term, "reshaped", False)
                            for term in self.unsettled)
        return not self.unsettled

    def tangent(self, trial: Trial):
        """The step's tangent at a trial: the stiffness of the points and
        the terms' matrices, weighed by the terms."""
        tic = run_clock()
        response, op = trial.response, self.op
        blocks = response.tangent_of is not None and getattr(
            op, "tangent_blocks", False)       # no tangent of all points
        # whether K is a matrix of its own, which no one else reads: the
        # compiled pass's and add_within's are, an operator's or a term's
        # weighing of it might not be
        own = response.stiffness is not None
        if own:                                # compiled, point by point
            K = response.stiffness()
        else:
            K = op.stiffness(response.tangent_of if blocks
                             else response.tangent(), response.w)
        first = not self._matrices_checked      # a step's first tangent
        self._matrices_checked = True
        for term in self.terms:
            G = term_matrix(term, term.matrix(response), K.shape[0], first,
                            self.step)
            if G is not None:
                K = add_within(K, G, self._union)
                own = True
        for term in self.terms:
            weighed = term.weigh_matrix(K)
            own = own and weighed is K
            K = weighed
        self._own = weakref.ref(K) if own else None
        self.t["assemble"] += run_clock() - tic
        return K

    def rhs(self, trial: Trial) -> ndarray:
        """The right-hand side of Newton's solve at ``trial``: its
        out-of-balance force, or with ``rhs="increment"`` (the seed's
        literal scheme) the step's load increment."""
        if self.run.rhs == "increment":
            return self.f_dead - self.run.loads.external(
                self.op, self.points, self.f_old)
        return trial.r

    def solve(self, K, r: ndarray, stabilise: bool = False):
        """Newton's increment with the exact tangent; in nonlinear steps
        with a stabilised one where points leave zero-energy modes on
        weakly supported nodes (a cell entered by one point): when the step
        is retried so (``stabilise``), or when the exact tangent is refused
        as singular.  Those modes carry no residual, so the stabilisation,
        :data:`STABILISATION` times the diagonal added to the tangent only
        (and where the exact one was refused in a plastic run or the step
        is retried :attr:`floored`, a diagonal entry below
        :data:`STABILISATION_FLOOR` of the median size raised to it: nodes
        held by points at a plastic apex alone), does not change
        the converged state; it is used only when needed because it slows
        Newton to a linear rate of about
        ``STABILISATION`` times the tangent's condition number.  A linear
        step's solve is exact (solved again only where round-off leaves
        its residual above the tolerance), or raises.  Returns the
        increment and the factorised solve, ``solve(r) -> d``, that
        modified Newton reuses.

        ``K`` is condensed onto the free DOFs first, and the whole grid's
        matrix released (where the caller holds no reference to it: the
        Newton driver hands the tangent over) before the condensed one is
        factorised: 408 bytes a point less at the peak of a 3D run's heap.
        The last tangent this problem made from arrays of its own (the
        compiled pass's) is condensed within its data (``consume``,
        :meth:`~skfem_mpm.solve.linear.Condensation.__call__`): the Newton
        driver does not read it again."""
        tic = run_clock()
        try:
            n = K.shape[0]
            A = self.condensed(K)
            del K           # memory: not alive while A is factorised
            return self._solve(A, n, r, stabilise)
        finally:
            self.t["solve"] += run_clock() - tic

    def condensed(self, K):
        """The free-free block of the tangent ``K`` (canonical CSR), by the
        run's :class:`~skfem_mpm.solve.linear.Condensation` of the step's
        pattern and free DOFs (an earlier step's where they are alike),
        made for new ones."""
        cache, free = self.run.cache, self.free
        if not (cache.condensation is not None
                and cache.condensation.fits(K, free)) \
                and getattr(K, "has_canonical_format", False):
            cache.condensation = Condensation(       # a new map, of the
                K, free, getattr(self.run.method, "kernels", "auto"))
        consume = self._own is not None and self._own() is K
        self._own = None
        # (GIMP's sparse products are not canonical: scikit-fem's condense)
        return condensed(K, free, cache.condensation, consume)

    def _solve(self, A, n: int, r: ndarray, stabilise: bool):
        """:meth:`solve` of the condensed tangent ``A`` (of a matrix of
        size ``n``)."""
        run, counters, free = self.run, self.counters, self.free
        if not self.linear:
            counters["newton_iterations"] += 1

        # the grid's positions serve the rigid-body modes of an iterative
        # back end; a solver that says it solves this system directly
        # needs none (forming them cost 0.11 ms an iteration at 512 free
        # DOFs, 0.24 at 2048)
        takes_modes = getattr(run.solver, "takes_modes", None)
        doflocs = self.grid.doflocs if takes_modes is None or takes_modes(
            free.size) else None

        def factorise_and_solve():
            counters["linear_solves"] += 1
            counters["factorisations"] += 1
            solve = factorise_condensed(A, free, n, solver=run.solver,
                                        doflocs=doflocs)
            return solve(r), solve
        if self._first_diagonal is None and not self.linear:
            self._first_diagonal = np.abs(A.diagonal())
        if not stabilise:
            try:
                return factorise_and_solve()
            except SingularSystemError as err:
                # a linear step's supports were checked before the solve:
                # after the first step, a failed step (the moved points
                # left nodes a sliver of support; a cut-back cannot cure
                # it, the reserve ghost penalty can)
                if self.linear:
                    raise (SingularTangentError if self.step > 1
                           else SingularSystemError)("step {}: {}".format(
                               self.step, err)) from err
                logger.debug("step %d: %s; solving again with the tangent "
                             "stabilised by %.0e of its diagonal", self.step,
                             err, STABILISATION)
        d = A.diagonal() * (1. + STABILISATION)
        # or refused as singular in a plastic run: an elastic cpGIMP
        # cantilever's sliver nodes, floored, stalled at 1.4e-6
        if self.floored or (not stabilise and is_plastic(run.material)):
            floor = STABILISATION_FLOOR * np.median(np.abs(d))
            low = np.abs(d) < floor
            d[low] = floor
            if self._first_diagonal is not None:
                self.collapsed = max(self.collapsed, int(np.count_nonzero(
                    low & (self._first_diagonal >= floor))))
        A.setdiag(d)                                             # in place
        counters["stabilised_solves"] += 1
        self.stabilised = True
        try:
            return factorise_and_solve()
        except SingularSystemError as err:
            # a nonlinear step's trial tangent (the supports were checked
            # before the step): a failed step, retried and cut back
            raise (SingularSystemError if self.linear
                   else SingularTangentError)(
                "step {}: {}".format(self.step, err)) from err

    def check_grid_motion(self, du: ndarray, dx: ndarray):
        """Refuse a converged grid increment ``du`` whose free nodes moved
        :data:`ABSURD_GRID_MOTION` times more than any point did (``dx``,
        the points' increments) and more than a millionth of a cell: the
        equilibrium holds, but only through nodes a sliver of material
        supports, whose values are absurd.  A step solved with the
        stabilised tangent is not checked: its motion along zero-energy
        modes is arbitrary by design (``docs/robustness.md``)."""
        if self.stabilised:     # zero-energy modes: arbitrary by design
            return
        grid = np.abs(du[self.free]).max(initial=0.)
        moved = np.abs(dx).max(initial=0.)
        if grid <= ABSURD_GRID_MOTION * moved or \
                grid <= 1e-6 * self.run.cell_size:
            return
        node = self.free[np.argmax(np.abs(du[self.free]))]
        raise GridMotionError(
            "step {}: the grid moved {:.1e} at a free node ({}) while no "
            "point moved more than {:.1e}: nodes supported by a sliver of "
            "material (a body edge or GIMP domain barely past a grid line) "
            "carry absurd values; the ghost penalty ties them to their "
            "neighbours (ghost='auto', the default, switches it on; or "
            "{})".format(
                self.step, grid, self.grid.doflocs[:, node].tolist(),
                moved, self.ghost_setting()))

    def ghost_setting(self) -> str:
        """The ghost penalty a run would switch on, as an option to set:
        finite deformation's, or small strain's (which ``ghost="auto"``
        holds in reserve there)."""
        from .core import DEFAULT_GHOST, SMALL_STRAIN_GHOST  # (imports this)
        return setting("ghost", DEFAULT_GHOST if self.run.finite
                       else SMALL_STRAIN_GHOST)

    def increment_gradients(self, du: ndarray) -> ndarray:
        """The points' gradients of the converged increment ``du``, found
        once for the step's checks and terms (the small-strain checks of
        slivers and the rotation's term read the same)."""
        kept = self._gradients
        if kept is None or kept[0] is not du:
            kept = self._gradients = (du, self.op.gradients(du))
        return kept[1]

    def check_thrown(self, du: ndarray, dx: ndarray):
        """Refuse a converged grid increment ``du`` that moved a point
        by more than :data:`THROWN` cells, or in small strain changed its
        displacement gradient by more than :data:`THROWN_GRADIENT`, through
        nodes whose support holds less than :data:`SLIVER_SUPPORT` cells
        of material (``dx``, the points' increments; looked for where a
        point moved more than :data:`THROWN` cells, or a gradient changed
        by more than :data:`THROWN_GRADIENT` and
        :data:`THROWN_GRADIENT_RATIO` times the median point's).  A
        small-strain uGIMP cantilever pushed far beyond its range (a user
        trial, P L^2 / E I = 3) converged a step to 1e-12 that threw a
        point 52 cells by a node of 5e-4 cells of support: the absurd
        grid motion was not caught, as a point had moved as far, and the
        run ended with the point outside the grid, or a step later, by its
        position, as a body held by no support.  Elastic and in small
        strain (one linear solve a step, no Newton iteration to fail) a
        cpGIMP cantilever's tip corner turned by 100 and then 187 degrees
        where the beam turned by 5, its stress wrong by 170%, until a
        step's stiffness was singular (the gradients are not checked once
        a term holds the slivers: the ghost penalty switched on).  Unlike
        :meth:`check_grid_motion`, a step solved with the stabilised
        tangent is checked too: its zero-energy modes move nodes
        arbitrarily, but no point by cells.  A point moved more than
        :data:`THROWN` cells that the slivers alone do not explain is
        looked at through its light nodes (:meth:`check_light`)."""
        run = self.run
        h = run.cell_size
        if not run.method.moves:
            return
        far = np.abs(dx).max(initial=0.) > THROWN * h
        limit = np.inf      # the gradient refused (small strain)
        if not run.finite and self.points.n and not any(
                term.holds_slivers for term in run.terms):
            turned = np.sqrt((self.increment_gradients(du) ** 2).sum(
                axis=(0, 1)))
            median = float(np.median(turned))
            if turned.max() > max(THROWN_GRADIENT,
                                  THROWN_GRADIENT_RATIO * median):
                limit = max(THROWN_GRADIENT, THROWN_GRADIENT_RATIO * median)
        if not far and limit == np.inf:
            return
        dim = self.points.dim
        sliver = self.slivers(SLIVER_SUPPORT * h ** dim)
        if not sliver.size:
            if far:
                self.check_light(du, dx)
            return
        # the points' motion by the slivers' free values alone (at 1e6
        # points the value matrix and its columns took 0.17 s a step; a
        # rigid body's prescribed nodes are not absurd however little
        # material they hold)
        alone = np.zeros_like(du).reshape(-1, dim)
        alone[sliver] = du.reshape(-1, dim)[sliver]
        alone = alone.ravel()
        held = np.ones(du.size, dtype=bool)
        held[self.free] = False
        alone[held] = 0.
        moved = np.sqrt((self.op.values(alone) ** 2).sum(axis=0)) / h \
            if far else np.zeros(0)
        gradient = np.zeros(0)
        if limit < np.inf:
            # the slivers' share of the gradient relative to the point's
            # own motion, sum_i grad N_i (du_i - dx_p): a point that
            # translates beside a sliver node is not turned (without it,
            # a stiff block sliding past a grid line by 3e-4 cells had a
            # "gradient" of its motion over h there, 0.25)
            ones = np.zeros_like(du).reshape(-1, dim)
            ones[sliver] = 1.
            ones = ones.ravel()
            ones[held] = 0.
            # (an operator of mean dilatation gives 3 x 3 gradients)
            share = self.op.gradients(alone)[:dim, :dim] \
                - dx[:, None] * self.op.gradients(ones)[:dim, :dim]
            gradient = np.sqrt((share ** 2).sum(axis=(0, 1)))
        if moved.max(initial=0.) > THROWN:
            p = int(np.argmax(moved))
            what = "moved {:.3g} cells".format(moved[p])
        elif gradient.max(initial=0.) > limit:
            p = int(np.argmax(gradient))
            what = ("had its displacement gradient changed by {:.3g} in "
                    "small strain (the median point's by {:.2g})".format(
                        gradient[p], median))
        else:
            if far:         # the slivers alone did not move it: nor more?
                self.check_light(du, dx)
            return
        self.thrown(p, what, SLIVER_SUPPORT)

    def slivers(self, least: float) -> ndarray:
        """The scalar grid DOFs of the step's operator whose support holds
        less than ``least`` of material (:func:`~skfem_mpm.solve.dynamics.
        operator_slivers`), the supports summed once a step: the checks of
        thrown points ask twice (slivers, then light nodes) in a step
        whose points moved more than a cell, 0.03-0.05 s and 80-150 MB of
        new pages each at 1e6 points."""
        if self._supports is None:
            from .dynamics import operator_supports  # (imports this)
            self._supports = operator_supports(self.op, self.points.volume)
        return np.flatnonzero(self._supports < least)

    def thrown(self, p: int, what: str, support: float):
        """Refuse the step: point ``p`` ``what`` (moved, turned) through
        grid nodes holding less than ``support`` cells of material."""
        raise GridMotionError(
            "step {}: point {} at {} {} through grid nodes "
            "holding less than {:g} cells of material (slivers: a body edge "
            "or GIMP domain barely past a grid line); the ghost penalty "
            "ties them to their neighbours (ghost='auto', the default, "
            "switches it on; or {})".format(
                self.step, p, self.points.x[:, p].tolist(), what,
                support, self.ghost_setting()))

    def check_light(self, du: ndarray, dx: ndarray):
        """:meth:`check_thrown` where a point moved more than
        :data:`THROWN` cells: refuse a converged increment ``du`` whose
        free light nodes (support below :data:`LIGHT_SUPPORT` cells of
        material) move a point more than :data:`THROWN` cells beyond the
        mean motion of its other nodes (held nodes, and nodes holding
        more; a point with none of them is not looked at: nothing says
        where it should be).  A body moving as one, however far, moves
        its light nodes with the rest; nodes a cell apart that differ by
        cells are no deformation small strain or a step can carry (see
        :data:`LIGHT_SUPPORT` for the trial that needed it)."""
        h, dim = self.run.cell_size, self.points.dim
        light = np.zeros(du.size // dim, dtype=bool)
        light[self.slivers(LIGHT_SUPPORT * h ** dim)] = True
        light = np.repeat(light, dim)
        held = np.ones(du.size, dtype=bool)
        held[self.free] = False
        light &= ~held
        if not light.any():
            return
        values = self.op.values
        heavy = values(np.where(light, 0., 1.))        # the others' share
        seen = np.all(heavy > 1e-6, axis=0)
        mean = values(np.where(light, 0., du)) / np.where(seen, heavy, 1.)
        moved = values(np.where(light, du, 0.)) \
            - values(light.astype(float)) * mean
        moved = np.where(seen, np.sqrt((moved ** 2).sum(axis=0)) / h, 0.)
        if moved.max(initial=0.) > THROWN:
            p = int(np.argmax(moved))
            self.thrown(p, "moved {:.3g} cells (its other nodes' mean "
                        "{:.2g})".format(moved[p], np.sqrt(
                            (mean[:, p] ** 2).sum()) / h), LIGHT_SUPPORT)

    def commit(self, trial: Trial, du: ndarray, residuals: list):
        """The converged state of ``trial`` (the grid increment ``du``) and
        the step's record: the points' state, positions and domains, the
        terms' commits, the reactions of held DOFs, the rigid bodies'
        forces; the points located for the next step."""
        run, op, points, t = self.run, self.op, self.points, self.t
        response, r = trial.response, trial.r
        tic = run_clock()
        dx = op.values(du)
        self.check_grid_motion(du, dx)
        self.check_thrown(du, dx)
        new = response.commit(points)
        new.displacement = points.displacement + dx
        if run.method.moves:
            new.x = points.x + dx
            domains = run.method.domains(run.domain0, new.F)
            if domains is not None:
                new.domain = domains
        active = np.zeros(op.N, dtype=bool)       # a mask: np.isin sorts
        active[op.active_dofs] = True
        held = self.fixed[active[self.fixed]]
        record = StepRecord(self.step, self.f_new, residuals[-1], op.nelems,
                            self.free.size, t, reaction_dofs=held,
                            reaction_values=-r[held], n_dofs=op.N)
        if run.keep_snapshots:        # before the terms, which may add
            record.elements = op.elements
            record.u, record.x = du, new.x.copy()
            record.displacement = new.displacement.copy()
            record.stress = new.stress.copy()
        for term in self.terms:     # what a term reads before any commits
            # (the time integrator's end forces: a term's own may change;
            # an object of a term's interface from before it had one)
            before = getattr(term, "before_commit", None)
            if before is not None:
                before(self, trial, du)
        for term in self.terms:
            term.commit(self, trial, du, new, record)
        for term in self.terms:
            term.finish(self, new, record)
        t["update"] += run_clock() - tic
        if run.method.moves:   # inside the grid (the location serves the
            try:                                            # next step)
                run.method.locate(new.x, self.step, t, points)
            except PointsOutsideGridError as err:
                # where they went (an obstacle's face they crossed)
                if err.indices is not None:
                    err.positions = new.x[:, err.indices]
                raise
        for dofs in self.rigid_dofs:  # a support's DOFs keep their reactions
            dofs = dofs[~np.isin(dofs, run.D)]
            force = np.zeros(run.dim)
            np.add.at(force, dofs % run.dim, -r[dofs])
            record.rigid_forces.append(force)
        if not self.linear:
            record.newton_residuals = residuals
            record.n_yielded = int(response.yielded.sum())
        return new, record
