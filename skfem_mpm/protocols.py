"""The contracts between the pieces of the load-step core, declared once.

The step problem (:mod:`skfem_mpm.solve.problem`) calls these and never
asks which implementation it holds:

- a **point operator** (:class:`PointOperator`, built per step by a
  method, :mod:`skfem_mpm.methods`) maps grid and point quantities;
- a **kinematics** (:class:`Kinematics`, :mod:`skfem_mpm.mechanics.
  kinematics`) turns a trial grid increment into a :class:`Response`:
  stresses, weights, the consistent tangent and the converged state;
- a **material** (:class:`Material`, the protocol of
  :mod:`skfem_mpm.mechanics.materials`) is called by the kinematics;
- a **linear solver** is ``solve(A, b) -> x`` (scikit-fem's shape),
  optionally with ``factorise(A) -> solve(b)`` and ``forget()``;
- a **grid term** (:class:`GridTerm`) adds forces, loads and matrices to
  the step's balance: the ghost penalty, the follower pressure, inertia,
  or a term of one's own (an item of ``simulate(..., loads=[...])``).

A grid term's contribution to one step comes from
:meth:`GridTerm.begin_step`.  With ``du`` the grid increment and
``response`` the kinematics' response to it, the step problem forms::

    f_int = op.force(response) + sum(term.force(du, response))
    f_ext = f_dead + w * sum(term.load(response, s))     # w = 1 but in
                                                          # generalised-alpha
    K     = op.stiffness(response) + sum(term.matrix(response))

then lets each term weigh that balance in time (:meth:`GridTerm.weigh`,
:meth:`GridTerm.weigh_matrix`: a time integrator's inertia and its
generalised-alpha weights), once Newton has converged asks each whether
its constraints hold (:meth:`GridTerm.settle`: contact's augmented
Lagrangian solves the step again until they do), lets it commit
what it keeps (:meth:`GridTerm.commit`) and, once all have, correct the
new state's motion (:meth:`GridTerm.finish`).  A run begins its terms in
their order, those that weigh the balance in time (``weighs = True``)
after all others: an integrator's start-of-step balance sees every other
term.  ``matrix`` must be the derivative of ``force - load`` with respect
to ``du`` (or a good part of it: Newton's rate depends on it).
"""
from typing import Callable, Optional, Protocol, runtime_checkable

from numpy import ndarray

from .errors import InvalidMaterialError

__all__ = ["GridTerm", "Balance", "PointOperator", "Response", "Kinematics",
           "Material", "LinearSolver"]


def of_package(obj) -> bool:
    """Whether ``obj`` is of one of the package's own classes (defined in
    ``skfem_mpm`` or a module under it), not a user's (a subclass of a
    shipped class included): the one test of the material checks
    (:func:`~skfem_mpm.mechanics.materials.trusted`) and of the hints
    that name a user's terms and materials.

    >>> from skfem_mpm import LinearElastic
    >>> of_package(LinearElastic(1., 0.)), of_package(object())
    (True, False)
    """
    module = type(obj).__module__ or ""
    return module == "skfem_mpm" or module.startswith("skfem_mpm.")


def state_variables(materials) -> dict:
    """The internal variables ``{name: initial value}`` of several
    materials (their ``state_variables``, :class:`Material`); a name
    declared twice must have one initial value: the one rule of a run's
    materials (:mod:`skfem_mpm.mechanics.materials`) and of
    :func:`~skfem_mpm.quadrature.points.concatenate_points`.

    >>> from skfem_mpm import MohrCoulomb
    >>> state_variables([MohrCoulomb(1., .3, 1., 30.)])
    {'equivalent_plastic_strain': 0.0}
    """
    out = {}
    for material in materials:
        for name, value in getattr(material, "state_variables", {}).items():
            if name in out and out[name] != value:
                raise InvalidMaterialError(
                    "state variable {!r} has two initial values ({} and {})"
                    .format(name, out[name], value))
            out[name] = value
    return out


class Balance:
    """A trial's balance of forces on the grid while terms weigh it:
    internal and external force vectors, ``scale``, the force the
    residual is measured against, and ``floor``, the round-off of the
    forces the balance sums: a residual norm at or below it is converged
    whatever the tolerance (the residual is measured against the larger
    of ``scale`` and ``floor / tol``)."""

    __slots__ = ("f_int", "f_ext", "scale", "floor")

    def __init__(self, f_int: ndarray, f_ext: ndarray, scale: float,
                 floor: float = 0.):
        self.f_int, self.f_ext, self.scale = f_int, f_ext, scale
        self.floor = floor


class GridTerm:
    """A term of a load step's balance on the grid.

    Subclass it and override what the term contributes; the defaults
    contribute nothing.  ``problem`` is the
    :class:`~skfem_mpm.solve.problem.StepProblem` of the step: its
    ``op`` (the step's point operator, ``op.N`` grid DOFs), ``points``
    (the converged state at the step's start), ``free``, ``fixed`` and
    ``driven`` grid DOFs, ``du0`` (the prescribed increments), ``s_old``,
    ``s_new`` (the loads' scale at the step's start and end), ``f_dead``
    (the external force that does not depend on the trial), ``step``,
    ``counters``, ``grid`` (the grid's vector basis) and ``run``.

    In a run with contact between bodies (``contacts=``) the grid is the
    *extended* mesh of one copy per field (:mod:`skfem_mpm.methods.
    fields`): ``problem.grid`` and ``op.N`` span every copy, and DOFs
    picked by location (``problem.grid.get_dofs(...)``) are every copy's
    node there.  A term acting on one body picks its copy:
    ``problem.run.user_grid`` is one copy's vector basis (its ``N``
    DOFs), ``problem.run.body_field[b]`` the field of body ``b``
    (``None`` without such contacts), and field ``k``'s DOFs are one
    copy's plus ``k * user_grid.N``::

        run = problem.run
        dofs = run.user_grid.get_dofs(on_base).all("u^2")
        if run.body_field is not None:
            dofs = dofs + run.body_field[body] * run.user_grid.N

    Examples
    --------
    A linear spring of stiffness ``k`` holding grid DOF ``dof``:

    >>> import numpy as np
    >>> from scipy.sparse import csr_matrix
    >>> from skfem_mpm import GridTerm
    >>> class Spring(GridTerm):
    ...     def __init__(self, dof, k):
    ...         self.dof, self.k = dof, k
    ...     def begin_run(self, points):
    ...         self.u = 0.                # total displacement so far
    ...     def begin_step(self, problem):
    ...         self.N = problem.op.N
    ...         return self
    ...     def force(self, du, response):
    ...         f = np.zeros(self.N)
    ...         f[self.dof] = self.k * (self.u + du[self.dof])
    ...         return f
    ...     def matrix(self, response):
    ...         return csr_matrix(([self.k], ([self.dof], [self.dof])),
    ...                           shape=(self.N, self.N))
    ...     def commit(self, problem, trial, du, new, record):
    ...         self.u += du[self.dof]

    The displacement increment ``du`` is the step's (the grid is reset
    every step): the spring keeps the total in :meth:`commit`, valid while
    the material at its node stays in the node's cells.  That total is
    the term's own: a checkpoint does not hold it, and a resumed run
    starts it again in :meth:`begin_run` (and warns, unless the term
    sets :attr:`stateless` or :attr:`restores_state`); restore it there
    to resume such a run, and set :attr:`restores_state`.
    """

    #: the term's matrix holds every rigid-body motion of the grid (a mass,
    #: an elastic foundation): the check for missing supports before a
    #: step is left out
    holds_free_body = False
    #: the term keeps nothing over the steps (its force and matrix depend
    #: on the step's increment and the points alone): a resumed run does
    #: not warn of it.  What a term keeps (a spring's total displacement)
    #: is in neither the points nor the checkpoints, and :meth:`begin_run`
    #: starts it again on a resume: a resumed run with terms of one's own
    #: that set neither this nor :attr:`restores_state` warns, naming them
    stateless = False
    #: the term keeps state over the steps and restores it itself on a
    #: resume (in :meth:`begin_run`, from a store of its own, e.g. a
    #: total displacement handed to it before the resumed run): a resumed
    #: run does not warn of it, as of a :attr:`stateless` one
    restores_state = False
    #: the term's force is a contact's (with obstacles, between bodies): in
    #: dynamics its work is booked as ``contact_work`` of
    #: :attr:`~skfem_mpm.StepRecord.energy`; any other term's (the ghost
    #: penalty's, a term of one's own that does not set this) with the
    #: points' stresses' as ``internal_work``
    contact = False
    #: the term weighs the balance in time (:meth:`weigh`): begun after
    #: every other term of a run
    weighs = False
    #: the term's :meth:`settle` may have the step solved again (contact's
    #: augmented Lagrangian): Newton keeps its last factorised tangent for
    #: the first direction of the next solve
    settles = False
    #: read after a :meth:`settle` that returned ``False``, which sets it
    #: on that call: ``True`` where it changed the term's constraints, not
    #: only their multipliers (contact pairs joined, a rough pair let go),
    #: and the next solve starts from a fresh tangent, not the kept one
    reshaped = False
    #: read after a :meth:`settle` that returned ``False``, which sets it
    #: on that call: how far the term's constraints were from holding, in
    #: its tolerances (the deepest penetration over the contact's
    #: tolerance); where it is at least :data:`~skfem_mpm.solve.core.
    #: FAR_OFF`, the next solve stops at the loose residual
    #: :data:`~skfem_mpm.solve.core.SETTLE_RESIDUAL` as the step's first
    #: does (another update will follow it); 0 (the default): the next
    #: solve goes on to the tolerance
    off_by = 0.
    #: the term ties grid nodes that a sliver of material supports to a
    #: stiff constraint (an obstacle holding the material where its
    #: corners cut cells): a step that fails also with the stabilised
    #: tangent switches the ghost penalty held in reserve on
    #: (:data:`~skfem_mpm.solve.core.RETRY_LADDER`)
    ties_slivers = False
    #: the term ties grid nodes that a sliver of material supports to
    #: their neighbours (the ghost penalty): their values follow the
    #: material's, and a small-strain step's gradients through them are
    #: not checked (:meth:`~skfem_mpm.solve.problem.StepProblem.
    #: check_thrown`)
    holds_slivers = False
    #: in dynamics, the work of the term's force over a step is booked
    #: from the force the last step ended with, not the term's
    #: :meth:`start_force` (contact: the pairs' pressures the step starts
    #: from are Newton's predictor, and pairs made anew start without
    #: theirs; an obstacle's corner put back on its point can start
    #: inside it); that force is kept with the step's record and carried
    #: through a resume (:attr:`~skfem_mpm.StepRecord.end_force`); read of
    #: terms that set :attr:`contact` alone, whose work is ``contact_work``
    works_from_last_end = False

    def held_dofs(self, op, points, scale: float) -> Optional[ndarray]:
        """Grid DOFs the term holds as a support would, for the check of
        missing supports before a step (``op`` the step's method operator,
        ``points`` the state at its start, ``scale`` the loads' scale
        there), or ``None``."""
        return None

    def held_supports(self, points, dofs: ndarray, where: ndarray,
                      N: int, active: ndarray,
                      within: Optional[float] = None) -> ndarray:
        """Of the supports' DOFs ``dofs`` (at the positions ``where``, dim
        x m; ``N`` DOFs in all, ``active`` the mask of those the points
        reach), those that hold in the step from ``points``: all of them,
        unless the term puts bodies on fields of their own (a contact
        between bodies holds a body's copy of a node only where the body
        lies on the support, within ``within`` cells of the nearest
        material there: ``None`` the term's own margin for supports, a
        number for the nodes of prescribed motion)."""
        return dofs

    def begin_run(self, points) -> None:
        """Called once when a run starts, with its initial points: a term
        that keeps state over the steps (a history, a total displacement)
        starts it here, so the same term object serves run after run."""

    def begin_step(self, problem) -> Optional["GridTerm"]:
        """This term's contribution to the step of ``problem`` (``self``
        after computing the step's matrices, or another object with this
        interface), or ``None`` where it contributes nothing."""
        return self

    def force(self, du: ndarray, response) -> Optional[ndarray]:
        """Internal force (grid vector) of the trial increment ``du``.
        In dynamics its work over a step is booked as ``internal_work``
        of :attr:`~skfem_mpm.StepRecord.energy`, with the points'
        stresses', or as ``contact_work`` where the term sets
        :attr:`contact`."""
        return None

    def start_force(self, zero: ndarray, response) -> Optional[ndarray]:
        """Internal force (grid vector) at the step's start, ``zero`` the
        zero increment and ``response`` the kinematics' at it: by default
        :meth:`force` there; a term whose constraint moves over the step
        (an obstacle's prescribed motion) says what it exerted where the
        step starts."""
        return self.force(zero, response)

    def predictor(self, problem, zero: ndarray) -> Optional[tuple]:
        """Where the term's constraint moves over the step off material it
        held at the step's start (an obstacle moving away): ``(K, r)``,
        the tangent at the step's start, the constraint where the last
        step left it, and the out-of-balance force there with the
        constraint's motion as a load, the predictor the step's Newton
        iteration starts from (:meth:`~skfem_mpm.solve.problem.
        StepProblem.start`); ``zero`` the zero increment.  ``None``
        otherwise."""
        return None

    def load(self, response, scale: float) -> Optional[ndarray]:
        """External force (grid vector) that depends on the trial (a
        follower load) at the loads' scale ``scale``."""
        return None

    def matrix(self, response):
        """Addend of the step's tangent (sparse, ``N x N``) at the trial."""
        return None

    def weigh(self, balance: Balance, du: ndarray) -> None:
        """Weigh the trial's static balance in time (a time integrator:
        the generalised-alpha weights and the inertia force); may enlarge
        ``balance.scale`` (the inertia force; an obstacle's force, which
        may be all that drives a body) and ``balance.floor`` (the
        round-off of the momentum's rate that the balance sums)."""

    def weigh_matrix(self, K):
        """The tangent weighed as :meth:`weigh` weighs the forces."""
        return K

    def settle(self, problem, trial, du: ndarray) -> bool:
        """After Newton converged to ``trial`` (increment ``du``):
        ``True`` when the term's constraints hold; ``False`` after it
        updated itself (an augmented-Lagrangian multiplier, a contact
        set), and the step is solved again from ``du``."""
        return True

    def unsettled_hint(self) -> str:
        """Why the term's constraints did not settle in a step's rounds of
        :meth:`settle`, as the last solve saw it, as ``"; ..."``, or
        ``""`` (the step's error then advises a stiffer penalty).  A term
        may note that it said so, to keep it out of :meth:`failure_hint`
        (obstacles: the held-support words), and set ``held_cause`` to
        ``True`` where the cause is a support (the step's error is then
        a :class:`~skfem_mpm.errors.HeldSupportError`)."""
        return ""

    def before_commit(self, problem, trial, du: ndarray) -> None:
        """After convergence, before any term's :meth:`commit`: read what
        the commits may change (the time integrator: the forces where the
        step ends, whose work it books)."""

    def commit(self, problem, trial, du: ndarray, new, record) -> None:
        """After convergence: update the new state ``new`` (points) and
        the step's ``record`` with what the term keeps (a total
        displacement, ``u += du``: in dynamics the step's work is booked
        from the terms' forces read before any term commits)."""

    def finish(self, problem, new, record) -> None:
        """After every term's commit: correct the new state's motion
        (contact: the velocity of material in contact across the
        obstacle's surface, after the time integrator set it)."""

    def no_equilibrium(self, points) -> bool:
        """Whether the term sees, at a failed step of a quasi-static run
        from the converged state ``points``, a load that no load factor
        balances (contact: a body held by one Coulomb face alone, pushed
        along it past mu): a run whose loads keep their direction at
        every load factor then stops without cutting the step back, which
        cannot help, and :meth:`failure_hint` says why.  Say ``True`` only
        where nothing the term cannot see may hold the material."""
        return False

    def failure_hint(self, points, quasi_static: bool) -> str:
        """What a run's error adds from this term when its steps failed
        down to the smallest load increment, ``points`` the last
        converged state (``quasi_static``: a run without inertia): a
        cause the term can see there (contact: friction mobilised in
        full in a quasi-static run), as ``"; ..."``, or ``""``."""
        return ""

    def unheld_hint(self) -> str:
        """What a run's error adds from this term where a step's supports
        leave a body free (:class:`~skfem_mpm.errors.SingularSystemError`
        at its start): a cause the term can see (contact: the material
        starting short of a stationary obstacle that was to hold it), as
        ``"; ..."``, or ``""``."""
        return ""


@runtime_checkable
class Response(Protocol):
    """A kinematics' response to a trial grid increment."""
    P: ndarray              #: stress measure the operator's force takes
    w: ndarray              #: point weights (volumes) of the force
    yielded: ndarray        #: per point: flowed plastically in the trial
    tangent_of: Optional[Callable]   #: tangent by blocks of points, or None

    def tangent(self) -> ndarray: ...
    def deformation(self, idx: ndarray) -> ndarray: ...
    def commit(self, points): ...


@runtime_checkable
class Kinematics(Protocol):
    """Small strain or finite deformation (:mod:`skfem_mpm.mechanics.
    kinematics`)."""

    def response(self, op, du: ndarray, points) -> Response: ...


@runtime_checkable
class PointOperator(Protocol):
    """A method's operator of one step: grid <-> points."""
    N: int                  #: grid DOFs
    dim: int
    elements: ndarray       #: active cells
    active_dofs: ndarray    #: grid DOFs some point supports
    point_elements: ndarray  #: the cell of each point

    def force(self, P: ndarray, w: ndarray) -> ndarray: ...
    def stiffness(self, D, w: ndarray): ...
    def values(self, u: ndarray) -> ndarray: ...
    def point_force(self, f: ndarray) -> ndarray: ...


@runtime_checkable
class Material(Protocol):
    """A constitutive model (the protocol of :mod:`skfem_mpm.mechanics.
    materials`, which states each member's contract)."""
    lam: object             #: Lame's first parameter (per point or one)
    mu: object              #: shear modulus
    plastic: bool           #: an update may involve a return map
    state_variables: dict   #: ``{name: initial value}`` per point

    def principal_update(self, eps: ndarray, state: dict): ...


@runtime_checkable
class LinearSolver(Protocol):
    """``solve(A, b) -> x``; back ends may add ``factorise(A) ->
    solve(b)`` and ``forget()`` (:mod:`skfem_mpm.solve.backends`)."""

    def __call__(self, A, b, **kwargs) -> ndarray: ...
