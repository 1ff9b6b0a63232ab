"""Implicit dynamics: inertia and time integration for the load-step core.

With ``simulate(..., dynamics=Dynamics(time_step, duration, density))`` a
load step is a time step: the same methods, kinematics, materials,
stabilisation and loads, and the inertia of the points' mass on the grid.
Schemes: Newmark (*J. Eng. Mech. Div. ASCE* 85, 1959) and the generalised-
alpha method of Chung and Hulbert (*J. Appl. Mech.* 60, 1993).

Mass
    Every point carries the mass ``m_p = density * V0_p`` of its body.  The
    grid's lumped mass ``m_I = sum_p m_p N_I(x_p)`` (default, the standard
    of MPM codes), or the consistent mass ``M_IJ = sum_p m_p N_I(x_p)
    N_J(x_p)`` (the mass form with the points as quadrature).

Mapping
    At the start of a step the grid velocity and acceleration are the
    mass-weighted projections of the points' (``M v = sum_p N_I m_p
    v_p``; lumped: the standard ``v_I = sum_p N_I m_p v_p / m_I``).  After
    the step the points' velocity changes by the grid's change at their
    positions, ``v_p += sum_I N_I (v_I^(n+1) - v_I^n)`` (FLIP: the update
    of the implicit MPM literature, ``v_p += dt sum_I N_I ((1 - gamma)
    a_I^n + gamma a_I^(n+1))``), blended with ``1 - flip`` of the PIC
    value ``sum_I N_I v_I^(n+1)``; their acceleration is the grid's.
    PIC alone (``flip=0``) smooths the velocity every step, by more the
    fewer cells a wavelength spans: a fixed-free bar's first mode at 100
    steps per period, 80 cells per wavelength (1D, 2 points a cell),
    keeps 0.79 of its amplitude from its first period to its fifth, 0.988
    with the default blend (0.95), 0.999 with pure FLIP; at 28 cells per
    wavelength 0.15, 0.90 and 0.995 (docs/dynamics.md).  Pure FLIP
    keeps velocities the grid cannot represent, which never decay: a
    collapsed column keeps 0.2% of its peak kinetic energy for good, where
    the default blend brings it to rest (1e-6 of the peak).  With the
    consistent mass a field the grid represents is recovered exactly, so
    where no point changes cell (``method="fem"``) the run is exactly the
    finite-element Newmark scheme and keeps its energy to round-off; but
    where points move, a node that a point barely reaches makes that projection
    ill-conditioned (a cantilever's kinetic energy grew 1000-fold as its
    points crossed cells), so the consistent mass is refused for methods
    other than ``"fem"``.  Grid DOFs whose motion is held (supports,
    prescribed motion, rigid bodies) move at their prescribed rate over a
    step, without acceleration.

Time integration
    Newmark (``beta``, ``gamma``; default the average acceleration 1/4,
    1/2: second order, no numerical dissipation) or the generalised-alpha
    scheme of Chung and Hulbert (*J. Appl. Mech.* 60, 1993) with the
    spectral radius ``rho_inf`` at infinite frequency (1: average
    acceleration; 0: annihilates the highest modes in one step), second
    order for every ``rho_inf``.  The balance of a step, with ``du`` the
    grid displacement increment,

        M a_(n+1-alpha_m) + f_int_(n+1-alpha_f) = f_ext(t_(n+1-alpha_f)),
        a_(n+1) = (du - dt v_n - dt^2 (1/2 - beta) a_n) / (beta dt^2),

    where ``x_(n+1-alpha) = (1 - alpha) x_(n+1) + alpha x_n`` (internal
    forces too: the generalised-alpha of nonlinear codes); its tangent is
    ``(1 - alpha_f) K + (1 - alpha_m) / (beta dt^2) M``.  A step that fails
    is cut back as a load step is (the time step halves).

Loads in time
    ``load(t)`` scales every load, the body force and prescribed motion at
    time ``t`` (default 1: in full from ``t = 0``, gravity switched on at
    the start).  Initial velocities are the points' ``velocity``; the
    initial acceleration solves the balance at ``t = 0``.

Energies
    Per step: the kinetic energy ``sum_p m_p |v_p|^2 / 2``, and the work of
    the internal and of the external forces (loads; not the reactions of
    supports or prescribed motion) summed by the trapezoidal rule on the
    grid (the
    stored elastic energy for an elastic body); a term that says so
    (contact between bodies) from its force where the last step ended,
    not its force at the step's start.  For the average
    acceleration scheme with the consistent mass and without cell crossing
    ``kinetic + internal - external`` is constant to round-off.

"""
import logging
from dataclasses import dataclass, replace
from typing import Callable, Optional, Sequence, Union

import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix, diags, kron, identity
from scipy.sparse.linalg import splu

from ..errors import (GridMotionError, InvalidInputError,
                      SingularSystemError, check_choice, check_real)
from ..protocols import GridTerm
from .linear import solve_active
from .problem import SLIVER_SUPPORT, add_within, safe_norm

logger = logging.getLogger(__name__)

__all__ = ["Newmark", "GeneralizedAlpha", "Dynamics", "MASSES",
           "InertiaTerm"]

MASSES = ("lumped", "consistent")
#: the round-off floor of a time step's residual, as a share of the
#: forces of the step's start its balance sums
#: (:meth:`Inertia.start_forces`): a residual norm at or below it is
#: converged whatever the tolerance.  About 4500 machine epsilons: the
#: balance of a DOF sums the momentum's rate of the points around it
#: and the Newmark terms, each rounded, and cancels them to what moves
#: the body (nothing in free flight, where they left 4.6e-16 of them:
#: thrown blocks, MPM and cpGIMP, every scheme), with room for meshes
#: and point counts many times larger.  It is a floor, not the scale
#: the tolerance multiplies: a block drifting at 300 m/s, dt = 1e-4, has
#: a momentum's rate 1e7 times its stress's force, and measured against
#: it a tolerance of 1e-9 stopped after one iteration with its stress
#: 7.5e-6 off
ROUNDOFF = 1e-12
#: a converged time step whose grid node moved more than this many cells
#: beyond every point its support holds failed (:meth:`StepInertia.
#: settle`)
NODE_AHEAD = 1.


@dataclass(frozen=True)
class Newmark:
    """Newmark's scheme; default the average acceleration (trapezoidal)
    rule, unconditionally stable and free of numerical dissipation.

    >>> from skfem_mpm import Newmark
    >>> Newmark().alpha_m, Newmark().alpha_f
    (0.0, 0.0)
    """
    beta: float = .25
    gamma: float = .5

    def __post_init__(self):
        beta = check_real("Newmark beta", self.beta)
        gamma = check_real("Newmark gamma", self.gamma)
        if not (0 < beta <= .5 and .5 <= gamma <= 1.):
            raise InvalidInputError(
                "Newmark needs 0 < beta <= 1/2 and 1/2 <= gamma <= 1 (implicit"
                ", not amplifying), got beta {!r}, gamma {!r}".format(
                    self.beta, self.gamma))
        if beta < gamma / 2:
            raise InvalidInputError(
                "Newmark with beta < gamma / 2 is only conditionally stable "
                "(beta {!r}, gamma {!r}); use beta >= gamma / 2, e.g. 1/4 "
                "and 1/2".format(self.beta, self.gamma))

    alpha_m = 0.
    alpha_f = 0.


@dataclass(frozen=True)
class GeneralizedAlpha:
    """The generalised-alpha scheme (Chung and Hulbert 1993) with spectral
    radius ``rho_inf`` at infinite frequency.

    >>> from skfem_mpm import GeneralizedAlpha
    >>> s = GeneralizedAlpha(.5)
    >>> round(s.alpha_m, 6), round(s.alpha_f, 6), round(s.gamma, 6)
    (0.0, 0.333333, 0.833333)
    """
    rho_inf: float = .8

    def __post_init__(self):
        rho = check_real("GeneralizedAlpha rho_inf", self.rho_inf)
        if not 0 <= rho <= 1:
            raise InvalidInputError(
                "GeneralizedAlpha needs 0 <= rho_inf <= 1, got {!r}".format(
                    self.rho_inf))

    @property
    def alpha_m(self) -> float:
        return (2 * self.rho_inf - 1) / (self.rho_inf + 1)

    @property
    def alpha_f(self) -> float:
        return self.rho_inf / (self.rho_inf + 1)

    @property
    def gamma(self) -> float:
        return .5 - self.alpha_m + self.alpha_f

    @property
    def beta(self) -> float:
        return .25 * (1 - self.alpha_m + self.alpha_f) ** 2


@dataclass(frozen=True)
class Dynamics:
    """Implicit dynamics for :func:`~skfem_mpm.simulate`.

    Parameters
    ----------
    time_step, duration
        The longest time step and the time simulated: ``ceil(duration /
        time_step)`` equal steps.  A ``time_step`` longer than the
        ``duration`` is refused (one step of the duration would be taken:
        a typo, most likely).
    density
        Mass per unit (initial) volume: one number, or one per body.
    scheme
        :class:`Newmark` or :class:`GeneralizedAlpha`; default
        (``None``): ``Newmark()``, the average acceleration rule, and
        ``GeneralizedAlpha(0.)`` in a run with obstacles or contacts
        between bodies (:func:`scheme_for`).
    mass
        ``"lumped"`` (default) or ``"consistent"`` (``method="fem"`` only;
        see the module notes).
    load
        ``load(t)``: the scale of loads and prescribed motion at time ``t``
        (default: 1, in full from the start): the load factor that a
        load's ``ramp=True`` (the default) follows and ``ramp=False``
        does not (in full from the start); without it the two are alike.
    flip
        The FLIP share of the points' velocity update, in [0, 1] (default
        0.95; see the module notes).  The rest, PIC, damps once a step:
        its damping grows as the time step shrinks (a bar lost 2.7% of
        its load's work at T/100, 8.2% at T/1600, docs/dynamics.md); take
        1.0 for a study of the time step.
    target_iterations
        ``None`` (default): every step ``time_step`` long, cut back only
        where Newton fails (with ``NewtonOptions(grow_back=True)``
        doubled back after two steps in a row that took at most half
        ``max_iter`` Newton iterations,
        :func:`~skfem_mpm.solve.core.grown_increment`), and back to
        ``time_step`` at the next multiple of it.  A number: the time
        step adapts to Newton's effort, halved after a step that took
        more iterations, doubled (up to ``time_step``) after one that took
        at most half as many; cut back where Newton fails, as always.
        Steps never straddle a multiple of ``time_step``, so the output
        keeps its times.

    Examples
    --------
    >>> from skfem_mpm import Dynamics
    >>> Dynamics(1e-3, 1e-2, 2000.).nsteps
    10
    """
    time_step: float
    duration: float
    density: Union[float, Sequence[float]]
    scheme: Optional[Union[Newmark, GeneralizedAlpha]] = None
    mass: str = "lumped"
    load: Optional[Callable[[float], float]] = None
    flip: float = .95
    target_iterations: Optional[int] = None

    def __post_init__(self):
        dt = check_real("Dynamics time_step", self.time_step)
        T = check_real("Dynamics duration", self.duration)
        if not (dt > 0 and T > 0 and np.isfinite(dt) and np.isfinite(T)):
            raise InvalidInputError(
                "Dynamics needs a positive time_step and duration, got {!r} "
                "and {!r}".format(self.time_step, self.duration))
        if dt > T * (1 + 1e-12):
            raise InvalidInputError(
                "Dynamics: time_step {!r} s is longer than the duration {!r} "
                "s: the run would take one step of {!r} s (ceil(duration / "
                "time_step) equal steps); give a time_step <= duration"
                .format(self.time_step, self.duration, self.duration))
        if T / dt > 1e7:
            raise InvalidInputError(
                "Dynamics: duration / time_step = {:.3g} steps; at most 1e7"
                .format(T / dt))
        rho = np.atleast_1d(np.asarray(
            [check_real("Dynamics density", r)
             for r in np.ravel(self.density)], dtype=float))
        if rho.size == 0 or not (np.isfinite(rho).all() and (rho > 0).all()):
            raise InvalidInputError(
                "Dynamics: density must be positive and finite (one number "
                "or one per body), got {!r}".format(self.density))
        if not (self.scheme is None or isinstance(
                self.scheme, (Newmark, GeneralizedAlpha))):
            raise InvalidInputError(
                "Dynamics: scheme must be Newmark(...), "
                "GeneralizedAlpha(...) or None (the default for the run), "
                "got {!r}".format(self.scheme))
        check_choice("Dynamics: mass", self.mass, MASSES)
        flip = check_real("Dynamics flip", self.flip)
        if not 0 <= flip <= 1:
            raise InvalidInputError("Dynamics: flip must lie in [0, 1], got "
                                    "{!r}".format(self.flip))
        if self.target_iterations is not None and (
                isinstance(self.target_iterations, bool) or not isinstance(
                    self.target_iterations, (int, np.integer))
                or not 2 <= self.target_iterations <= 50):
            raise InvalidInputError(
                "Dynamics: target_iterations must be None or an integer in "
                "[2, 50], got {!r}".format(self.target_iterations))
        if self.load is not None and not callable(self.load):
            raise InvalidInputError("Dynamics: load must be a function of "
                                    "time, got {!r}".format(self.load))

    @property
    def nsteps(self) -> int:
        return max(1, int(np.ceil(self.duration / self.time_step - 1e-9)))

    def adapt(self, increment: float, nominal: float, smallest: float,
              iterations: int) -> float:
        """The next step's increment (fraction of the duration) after one
        that took ``iterations`` Newton iterations."""
        if iterations > self.target_iterations:
            return max(increment / 2, smallest)
        if 2 * iterations <= self.target_iterations:
            return min(2 * increment, nominal)
        return increment

    def scale(self, t: float) -> float:
        """The loads' scale at time ``t``.  What ``load(t)`` raises stops
        the run at once, as :class:`~skfem_mpm.errors.InvalidInputError`
        naming the time and the exception: the user's function, not the
        step's numerics, and no shorter step avoids it (a step cut back
        still ends at the multiple of ``time_step`` it failed to reach,
        and evaluates ``load`` there; a trial's ``1 / 0`` beyond 0.02 s
        was taken for a failed step, cut back nine times and reported as
        a ``NumericalError``)."""
        if self.load is None:
            return 1.
        try:
            value = self.load(float(t))
        except Exception as err:
            raise InvalidInputError(
                "Dynamics: load(t) raised {} at t = {:.6g} s: {} (the "
                "user's function of time, not the step's numerics: a "
                "shorter step would still end at each multiple of "
                "time_step)".format(type(err).__name__, float(t), err)
            ) from err
        if isinstance(value, (bool, np.bool_)) or not isinstance(
                value, (int, float, np.integer, np.floating)) or \
                not np.isfinite(value):
            raise InvalidInputError("Dynamics: load({}) must be a finite "
                                    "number, got {!r}".format(t, value))
        return float(value)

    def masses(self, points) -> ndarray:
        """``m_p = density(body) * V0_p``."""
        rho = np.atleast_1d(np.asarray(self.density, dtype=float).ravel())
        nbodies = int(points.body.max()) + 1
        if rho.size not in (1, nbodies):
            raise InvalidInputError(
                "Dynamics: density needs one number or one per body ({}), "
                "got {}".format(nbodies, rho.size))
        return (rho if rho.size > 1 else np.repeat(rho, nbodies))[
            points.body] * points.volume0


def scheme_for(dynamics: Optional[Dynamics], contact: bool
               ) -> Optional[Dynamics]:
    """``dynamics`` with its scheme: the one asked for, or by default
    Newmark's average acceleration rule, and with ``contact`` (obstacles
    or contacts between bodies) the generalised-alpha scheme with
    ``rho_inf = 0``.

    The average acceleration rule credits a contact's force at a step's
    start over the whole step in which a body leaves it, so an impact can
    return more energy than the fall (a block dropped 0.5 onto a floor
    obstacle rebounded to 0.43 with time steps of 0.01, 1.04 with 0.02 and
    1.50 with 0.04, at 1.9 and 2.7 times its energy); the generalised-
    alpha scheme with ``rho_inf = 0`` weighs the forces at the step's end
    and damps what one step cannot resolve, and kept the same landings
    within their energy (rebounds of 0.06-0.08).  It damps the highest
    frequencies over the whole run, contact or not: a column vibrating
    at 20 steps per period, with an obstacle it never touched, kept 0.71
    of its amplitude over 5 periods (1.02 with Newmark's; at 40 steps
    per period 0.91 against 0.96).  Newmark asked for with contact is
    kept, with a warning.

    >>> scheme_for(Dynamics(.1, 1., 1e3), contact=True).scheme
    GeneralizedAlpha(rho_inf=0.0)
    >>> scheme_for(Dynamics(.1, 1., 1e3), contact=False).scheme
    Newmark(beta=0.25, gamma=0.5)
    """
    if dynamics is None:
        return None
    if dynamics.scheme is None:
        if contact:
            logger.info("dynamics with contact: the generalised-alpha "
                        "scheme with rho_inf = 0 (the default with obstacles "
                        "or contacts between bodies)")
        return replace(dynamics, scheme=GeneralizedAlpha(0.) if contact
                       else Newmark())
    if contact and isinstance(dynamics.scheme, Newmark):
        logger.warning(
            "Newmark's scheme with contact: an impact within a time step "
            "can return more energy than the fall (a block dropped 0.5 on "
            "a floor rebounded to twice its height with steps of 0.02); "
            "watch the kinetic energy less the external work "
            "(Result.energies(); the contact's work is its contact_work, "
            "apart from internal_work), or leave the scheme to its "
            "default with contact, "
            "GeneralizedAlpha(0.) (scene files: scheme = \"auto\")")
    return dynamics


def value_matrix(op) -> csr_matrix:
    """``S[p, k] = N_k(x_p)``, (points, scalar grid DOFs), of a step's point
    operator (standard MPM, GIMP, or their mean-dilatation twin)."""
    op = getattr(op, "op", op)
    if hasattr(op, "S"):
        return op.S
    basis = op.basis
    rows = np.broadcast_to(basis.point_index, op.shape_values.shape)
    keep = rows >= 0
    return csr_matrix((op.shape_values[keep], (rows[keep],
                                               op.scalar_dofs[:, :, None]
                                               .repeat(rows.shape[-1],
                                                       axis=2)[keep])),
                      shape=(basis.point_index.max() + 1, op.N // op.dim))


def sliver_nodes(S, volume: ndarray, least: float) -> ndarray:
    """The scalar grid DOFs whose support (the points' volumes ``volume``
    weighted by their values ``S``, :func:`value_matrix`) holds less than
    ``least`` of material (:func:`matrix_supports`)."""
    return np.flatnonzero(matrix_supports(S, volume) < least)


def matrix_supports(S, volume: ndarray) -> ndarray:
    """The material each scalar grid DOF's support holds: the points'
    volumes ``volume`` weighted by the sizes of their values ``S``
    (:func:`value_matrix`).  ``S`` is left as it is: ``abs(S)`` sums a
    sparse matrix's duplicate entries in place, and a GIMP operator's
    ``S`` shares its pattern with its gradients' (a contact's corner rows
    ``S + q G`` add their data): a 3D cpGIMP block on a floor took a
    first Newton step 160 times worse after it."""
    weights = type(S)((np.abs(S.data), S.indices, S.indptr), shape=S.shape)
    return weights.T @ volume


def operator_supports(op, volume: ndarray) -> ndarray:
    """:func:`matrix_supports` of a step's point operator: from its value
    matrix where it keeps one (GIMP, B-splines), else from its shape
    values and element DOFs without forming the matrix (standard MPM:
    at 1e6 points the matrix and its columns took 0.17 s of a step whose
    points moved a cell, the sums 0.03 s), the weights formed in place
    (one array of the shape values' size less: 32 MB at 1e6 points in
    2D), the same sums in the same order."""
    op = getattr(op, "op", op)
    if hasattr(op, "S"):
        return matrix_supports(op.S, volume)
    rows = op.basis.point_index
    weights = np.abs(op.shape_values)
    weights *= np.where(rows >= 0, volume[rows], 0.)[None]
    return np.bincount(np.broadcast_to(op.scalar_dofs[:, :, None],
                                       weights.shape).ravel(),
                       weights.ravel(), minlength=op.N // op.dim)


def operator_slivers(op, volume: ndarray, least: float) -> ndarray:
    """:func:`sliver_nodes` of a step's point operator
    (:func:`operator_supports`).

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> op = SimpleNamespace(
    ...     shape_values=np.array([[[.75, .25]], [[.25, -1e-9]]]),
    ...     scalar_dofs=np.array([[0], [1]]), N=3, dim=1,
    ...     basis=SimpleNamespace(point_index=np.array([[0, -1]])))
    >>> operator_slivers(op, np.array([2.]), 1e-3).tolist()
    [2]
    """
    return np.flatnonzero(operator_supports(op, volume) < least)


class Inertia:
    """The inertia of one time step on its grid: mass, the projected
    velocity and acceleration at its start, Newmark's relations."""

    def __init__(self, dynamics: Dynamics, op, points, masses: ndarray,
                 dt: float):
        s = dynamics.scheme
        self.dt, self.dim = dt, op.dim
        self.alpha_m, self.alpha_f = s.alpha_m, s.alpha_f
        self.beta, self.gamma = s.beta, s.gamma
        S = value_matrix(op)
        if S.shape[0] != points.n:
            raise InvalidInputError("inertia: the step's operator holds {} "
                                    "points, the state {}".format(
                                        S.shape[0], points.n))
        self.S = S
        lumped = S.T @ masses
        if dynamics.mass == "lumped":
            Ms = diags(lumped).tocsr()
        else:
            Ms = (S.T @ diags(masses) @ S).tocsr()
        self.M = kron(Ms, identity(self.dim), format="csr")
        active = np.flatnonzero(lumped > 0)
        self.v = self._project(Ms, lumped, active, masses, points.velocity,
                               dynamics.mass)
        self.a = None if points.acceleration is None else self._project(
            Ms, lumped, active, masses, points.acceleration, dynamics.mass)
        # tangent factor of the mass, and Newmark's prediction
        self.c = (1 - self.alpha_m) / (self.beta * dt * dt)

    def _project(self, Ms, lumped, active, masses, field, mass) -> ndarray:
        """Grid values (interleaved vector) of a point field (dim, n)."""
        rhs = (self.S.T @ (masses * field).T)             # (scalar, dim)
        out = np.zeros_like(rhs)
        if mass == "lumped":
            out[active] = rhs[active] / lumped[active, None]
        else:
            sub = Ms[active][:, active].tocsc()
            try:
                out[active] = splu(sub).solve(rhs[active])
            except RuntimeError as err:
                raise SingularSystemError(
                    "the consistent mass of {} grid nodes is singular ({}): "
                    "too few points in some cell; use more points per cell "
                    "or mass='lumped'".format(active.size, err)) from err
        return out.ravel()

    def acceleration(self, du: ndarray) -> ndarray:
        """``a_(n+1)`` of the increment ``du``."""
        dt, b = self.dt, self.beta
        return (du - dt * self.v - dt * dt * (.5 - b) * self.a) / (b * dt * dt)

    def velocity(self, a_new: ndarray) -> ndarray:
        return self.v + self.dt * ((1 - self.gamma) * self.a
                                   + self.gamma * a_new)

    def inertia_force(self, du: ndarray) -> ndarray:
        """``M a_(n+1-alpha_m)``."""
        a = (1 - self.alpha_m) * self.acceleration(du) + self.alpha_m * self.a
        return self.M @ a

    def start_forces(self, free: ndarray) -> float:
        """The largest of the forces of the step's start that its balance
        sums over the ``free`` DOFs: the momentum's rate ``(1 - alpha_m)
        M v_n / (beta dt)``, the start's acceleration's terms
        ``(1 - alpha_m) (1/2 - beta) / beta M a_n`` and ``alpha_m M a_n``,
        and the internal force :attr:`f_int0` (set before).  A body in
        free flight has no load and no acceleration: its residual is the
        round-off of these terms' cancellation, and measured against the
        inertia force alone (round-off itself) it stayed at 1.  They set
        the residual's round-off floor (:data:`ROUNDOFF` of them), not
        its scale."""
        dt, b, am = self.dt, self.beta, self.alpha_m
        weight = max(am, (1 - am) * abs(.5 - b) / b)
        return max((1 - am) / (b * dt) * safe_norm((self.M @ self.v)[free]),
                   weight * safe_norm((self.M @ self.a)[free]),
                   safe_norm(self.f_int0[free]))


class InertiaTerm(GridTerm):
    """Implicit time integration as a grid term: the inertia of the
    points' mass (``masses``, per point) in each time step, Newmark's or
    the generalised-alpha weights of the balance, and the points' new
    velocity, acceleration and the step's energies at its end.

    At a step's start (:meth:`begin_step`) the grid velocity and
    acceleration are projected from the points (the first step of a run
    without accelerations takes them from the balance at its start), the
    external force becomes the load at ``n+1-alpha_f``, and grid DOFs whose
    motion is held (supports, prescribed motion, rigid bodies) move at their
    prescribed rate over the step, without acceleration, not at the
    velocity projected from the points near them.
    """

    holds_free_body = True               # the mass holds a free body
    weighs = True

    def __init__(self, dynamics: Dynamics, masses: ndarray):
        self.dynamics, self.masses = dynamics, masses
        #: the force of the terms that book their work from the last
        #: step's end (:attr:`~skfem_mpm.protocols.GridTerm.
        #: works_from_last_end`) where the last step ended
        self.last_end = None
        self.resumed = False
        self.created = None

    def begin_run(self, points) -> None:
        self.last_end, self.resumed = None, False
        # a body that starts unstressed can give back at most the work
        # done on it: the run's internal work stays >= 0
        # (:meth:`check_created`); a prestressed start is not checked
        self.created = CreatedEnergy() if not np.any(points.stress) \
            else None

    def resume(self, end_force: Optional[ndarray]) -> None:
        """Go on from a step whose record's :attr:`~skfem_mpm.StepRecord.
        end_force` (dense) is ``end_force``: the work of the next step
        is booked as the run's own would have been (a run resumed without
        it booked its first step's from the start force: 6.626 for 6.657
        of internal work, two blocks in contact)."""
        self.last_end = end_force
        self.resumed = end_force is not None
        self.created = None      # the internal work before is not known

    def begin_step(self, problem):
        """The step's inertia, the internal and external forces at its
        start, and the external force weighed to ``n+1-alpha_f``."""
        run, op, points = problem.run, problem.op, problem.points
        dynamics, fixed, du = self.dynamics, problem.fixed, problem.du0
        step = StepInertia(dynamics, op, points, self.masses,
                           (problem.f_new - problem.f_old) * dynamics.duration)
        step.dynamics, step.masses = dynamics, self.masses
        step.kinetic_start = .5 * float(self.masses @ (
            points.velocity ** 2).sum(0))
        zero = np.zeros(op.N)
        start = run.kinematics.response(op, zero, points)
        step.f_int0, step.f_points0, terms0 = problem.internal_force(
            zero, start, start=True, parts=True)
        # the contact terms' force the step's contact work starts from
        # (the rest apart: internal_work): a contact's
        # force where the last step ended, not at the pairs the step
        # starts from (the pressures Newton's predictor, pairs made anew
        # without theirs: a block sliding to rest on a slab lost 11% of
        # its energy to the balance at dt = 0.02)
        step.owner, step.f_work0 = self, terms0
        ends = [term for term in problem.terms if getattr(
            term, "works_from_last_end", False) and getattr(
                term, "contact", False)]
        if self.resumed and self.last_end.size != zero.size:
            raise InvalidInputError(
                "Resume.end_force holds {} entries, the run's grid {} DOFs: "
                "it is not this run's (Resume.after(record) of its last "
                "step gives it)".format(self.last_end.size, zero.size))
        self.resumed = False
        if ends and self.last_end is not None \
                and self.last_end.size == zero.size:
            f = [term.start_force(zero, start) for term in ends]
            step.f_work0 = (0. if terms0 is None else terms0) \
                + self.last_end - sum(x for x in f if x is not None)
        f_ext0 = run.loads.external(op, points, problem.s_old)
        follower = problem.trial_loads(start, problem.s_old)
        if follower is not None:          # pressure on the start's surface
            f_ext0 = f_ext0 + follower
        step.f_ext0 = f_ext0
        if step.a is None:
            step.a = solve_active(step.M.tocsr(), f_ext0 - step.f_int0,
                                  problem.free, solver=run.solver,
                                  doflocs=problem.grid.doflocs)
            problem.counters["linear_solves"] += 1
            problem.counters["factorisations"] += 1
        step.v[fixed] = du[fixed] / step.dt
        step.a[fixed] = 0.
        step.reference = step.start_forces(problem.free)
        alpha = step.alpha_f
        problem.f_dead = (1 - alpha) * problem.f_dead + alpha * f_ext0
        problem.load_weight = 1 - alpha
        return step


class StepInertia(Inertia, GridTerm):
    """The inertia term of one time step (see :class:`InertiaTerm`)."""

    def weigh(self, balance, du: ndarray):
        """The internal force at ``n+1-alpha_f`` and the inertia force;
        the residual is measured against the inertia force too (a free
        vibration), and is converged at the round-off of the forces of
        the step's start that the balance sums, :data:`ROUNDOFF` of
        :meth:`start_forces`, whatever the tolerance (a body in free
        flight, whose loads and inertia force are zero)."""
        alpha = self.alpha_f
        balance.f_int = (1 - alpha) * balance.f_int + alpha * self.f_int0
        moving = self.inertia_force(du)
        balance.f_int += moving
        balance.scale = max(balance.scale, safe_norm(moving))
        balance.floor = max(balance.floor, ROUNDOFF * self.reference)

    def weigh_matrix(self, K):
        return add_within((1 - self.alpha_f) * K, self.c * self.M)

    def settle(self, problem, trial, du: ndarray) -> bool:
        """Refuse a converged step (its other terms settled:
        :meth:`~skfem_mpm.solve.problem.StepProblem.settled`) whose free
        grid node's motion differs by more than :data:`NODE_AHEAD` cells
        from that of every point its support holds
        (:class:`~skfem_mpm.errors.GridMotionError`, which the retry
        ladder answers with the ghost penalty's rung; not checked once
        the penalty holds the slivers).  A node's motion interpolates its
        points'; a cell's worth apart from all of them is a strain of
        order one in a time step, through a node that little material
        holds: trial 78's MPM block dropped on a 35 degree incline
        (friction 0.3, dt = 0.01) converged its impact step with a node
        holding 0.014 cells of material (0.08% of the block's mass) moved
        0.31 m (6 cells) while no point near it moved 0.05 m; the block
        rebounded at 0.85 m/s at that step (46 J of kinetic energy from
        10 J of gravity's work; 1.04 m/s and 60 J later).  The ghost
        penalty's retry landed it (rebound at most 0.16 m/s, kinetic
        energy at most 2.2 J by step 10).  Nodes holding less than
        :data:`~skfem_mpm.solve.problem.SLIVER_SUPPORT` cells of material
        are left to the checks of slivers, and nodes with a held or
        prescribed DOF are not checked (a rigid body's are not absurd)."""
        run = problem.run
        if not run.method.moves or any(term.holds_slivers
                                       for term in run.terms):
            return True
        dim, h = self.dim, run.cell_size
        nodes = du.reshape(-1, dim)
        if not np.sqrt((nodes ** 2).sum(axis=1)).max(initial=0.) \
                > NODE_AHEAD * h:
            return True         # no node moved a cell: none can be apart
        dx = problem.op.values(du)
        S = self.S.tocsc()
        support = abs(S).T @ problem.points.volume
        free = np.zeros(du.size, dtype=bool)
        free[problem.free] = True
        checked = free.reshape(-1, dim).all(axis=1) & (
            support >= SLIVER_SUPPORT * h ** dim)
        # each entry (point p, node i) of the step's values: |du_i - dx_p|
        # (slivers' values barely reach a point: :meth:`~skfem_mpm.solve.
        # problem.StepProblem.check_thrown` weighs them; a cpGIMP block's
        # node of 2.5e-9 cells moved 70 cells in trial 78's step)
        column = np.repeat(np.arange(S.shape[1]), np.diff(S.indptr))
        apart = np.sqrt(((nodes[column] - dx[:, S.indices].T) ** 2).sum(
            axis=1))
        ahead = np.zeros(S.shape[1])
        filled = np.flatnonzero(np.diff(S.indptr) > 0)
        ahead[filled] = np.minimum.reduceat(apart, S.indptr[filled])
        ahead[~checked] = 0.
        if not ahead.max(initial=0.) > NODE_AHEAD * h:
            return True
        node = int(np.argmax(ahead))
        raise GridMotionError(
            "step {}: a grid node at {} moved {:.3g} cells, {:.3g} cells "
            "apart from every point it holds (the material it holds: "
            "{:.3g} cells): a node barely supported carries an absurd "
            "value, and the step's energy with it; the ghost penalty ties "
            "it to its neighbours (ghost='auto', the default, switches it "
            "on; or a shorter time step)".format(
                problem.step, np.round(problem.grid.doflocs[
                    :, dim * node], 6).tolist(),
                np.sqrt((nodes[node] ** 2).sum()) / h, ahead[node] / h,
                support[node] / h ** dim))

    def before_commit(self, problem, trial, du: ndarray) -> None:
        """The forces where the step ends, before any term commits
        (:meth:`~skfem_mpm.solve.problem.StepProblem.commit`): a term that
        keeps its total in ``commit`` (a spring bed's ``u += du``, the
        documented way) exerts another force after it, and this commit,
        which runs after the terms' (it weighs the balance last), booked
        the spring's work with ``du`` counted twice: trial 103's block on
        a bed under every DOF gained 7.06 of 42.1 of gravity's work in
        0.05 s at dt = 0.01, 3.55 at 0.005."""
        response = trial.response
        self.end_forces = problem.internal_force(du, response, parts=True)
        ends = [term.force(du, response) for term in problem.terms
                if getattr(term, "works_from_last_end", False)
                and getattr(term, "contact", False)]
        self.ends = [f for f in ends if f is not None]

    def commit(self, problem, trial, du: ndarray, new, record):
        """The points' new velocity (FLIP / PIC blend) and acceleration
        from the grid's; the step's time and energies: kinetic at its start
        and end, and the work of the internal and external forces over it
        (trapezoidal rule), the forces at the end those of
        :meth:`before_commit`."""
        op, response = problem.op, trial.response
        a = self.acceleration(du)
        v = self.velocity(a)
        flip = self.dynamics.flip
        new.velocity = op.values(v) if flip == 0 else \
            flip * (new.velocity + op.values(v - self.v)) \
            + (1 - flip) * op.values(v)
        new.acceleration = op.values(a)
        f_int, f_points, f_terms = self.end_forces
        alpha, f_dead = self.alpha_f, problem.f_dead   # at n+1-alpha_f
        f_ext1 = f_dead if alpha == 0 else \
            (f_dead - alpha * self.f_ext0) / (1 - alpha)
        follower = problem.trial_loads(response, problem.s_new)
        if follower is not None:        # pressure on the step's end surface
            f_ext1 = f_ext1 + follower
        ends = self.ends
        self.owner.last_end = sum(ends) if ends else None
        # kept with the record (its nonzero entries: the contact's DOFs),
        # so that a run resumed after this step books as this one does
        record.end_force = None if not ends else \
            csr_matrix(self.owner.last_end[None])
        masses, duration = self.masses, self.dynamics.duration
        record.time = problem.f_new * duration
        record.time_step = (problem.f_new - problem.f_old) * duration
        record.energy = {
            "kinetic_start": self.kinetic_start,
            "kinetic": .5 * float(masses @ (new.velocity ** 2).sum(0)),
            "internal_work": .5 * float((self.f_points0 + f_points) @ du),
            "external_work": .5 * float((self.f_ext0 + f_ext1) @ du),
            "contact_work": contact_work(self.f_work0, f_terms, du)}
        # what the scheme's start may leave under the loads at the step's
        # end where the bodies' mass shares them, and no more than the
        # work those loads can do where the stiffness holds the step's
        # motion (CreatedEnergy)
        stiffness = float(du @ (f_int - self.f_int0))
        self.allowance = min(
            start_allowance(float(np.abs(f_ext1).sum()), record.time_step,
                            masses.sum(), self.alpha_f - self.alpha_m),
            held_work(float(f_ext1 @ du), stiffness))
        if problem.step == 1:
            warn_unresolved_period(record, stiffness,
                                   float(du @ (self.M @ du)),
                                   self.dynamics.scheme)


    def finish(self, problem, new, record) -> None:
        """The check that the run created no energy
        (:class:`CreatedEnergy`), once the kinetic energy is final: after
        every term's commit and finish, an obstacle's correcting the
        velocity of material pressed on it among them (the inertia
        finishes last: it weighs the balance)."""
        if self.owner.created is not None:
            self.owner.created.check(problem, record, self.allowance)


def contact_work(start: Optional[ndarray], end: Optional[ndarray],
                 du: ndarray) -> float:
    """The work over a step of increment ``du`` of the contact forces
    (with obstacles and between bodies: the grid terms that set
    :attr:`~skfem_mpm.protocols.GridTerm.contact`), trapezoidal from
    their sum ``start`` at the step's start to ``end`` at its end
    (``None``: none exerts one): a record's ``contact_work``, apart
    from ``internal_work``.

    >>> import numpy as np
    >>> contact_work(None, None, np.ones(2))
    0.0
    >>> contact_work(None, np.array([2., 4.]), np.array([1., .5]))
    2.0
    """
    if start is None and end is None:
        return 0.
    total = (0. if start is None else start) + (0. if end is None else end)
    return .5 * float(total @ du)


#: a run's first time step longer than this many periods of the motion it
#: excites is warned (:func:`warn_unresolved_period`): the shipped
#: examples' blocks landing on a slope take steps of 1.1-1.15 periods of
#: their elastic ringing, which their sliding does not need followed; a
#: user trial's bar loaded at once, at 1.7 periods, had its reactions
#: swing from -1.90 to -0.27 of the load (not warned)
PERIODS_PER_STEP = 2.


def warn_unresolved_period(record, stiffness: float, mass: float,
                           scheme=None) -> None:
    """Log a warning where the first time step (``record``) is longer than
    :data:`PERIODS_PER_STEP` periods of the motion it excites, that of
    Rayleigh's quotient of its displacement ``du``: ``2 pi sqrt(du M du /
    du (f_int(du) - f_int(0)))`` (``mass``, ``stiffness``; a rigid motion,
    no stiffness, has none).  The scheme does not follow that motion, and
    the trapezoidal rule, which damps none, swings about the static
    answer: a user trial's bar under an end load applied at once (its
    first period 0.127 s) came out twice the static answer in one step
    of 10 s, its reactions from -1.90 to -0.27 of the load in steps of
    0.2 s, without a word.  The words fit the ``scheme`` (a
    :class:`Newmark` or :class:`GeneralizedAlpha`; ``None``: Newmark's
    rule): the generalised-alpha scheme damps the swing, but its first
    steps overshoot (a bar loaded at once, steps of 2-10 first periods:
    1.5 times the static displacement in the second step at ``rho_inf =
    0``; 1.69 in the first at 0.5, then swings decaying over ten
    steps)."""
    if not (stiffness > 0 and mass > 0):
        return
    period = 2 * np.pi * np.sqrt(mass / stiffness)
    if record.time_step > PERIODS_PER_STEP * period:
        if isinstance(scheme, GeneralizedAlpha):
            swing = (
                "the generalised-alpha scheme (rho_inf = {:g}) damps it "
                "but overshoots the static answer in its first steps "
                "under a load applied at once (a bar: 1.5 times it in the "
                "second step at rho_inf = 0)".format(scheme.rho_inf))
        elif scheme is None or (scheme.beta, scheme.gamma) == (.25, .5):
            swing = (
                "without numerical damping (Newmark's trapezoidal rule) "
                "the answer swings about the static one, up to twice it "
                "under a load applied at once")
        else:
            swing = (
                "Newmark's scheme (beta = {:g}, gamma = {:g}) swings "
                "about the static answer, up to twice it under a load "
                "applied at once, damped by gamma > 1/2 alone".format(
                    scheme.beta, scheme.gamma))
        logger.warning(
            "step 1: the time step %.3g s is %.3g times the period of the "
            "motion it excites, about %.3g s (Rayleigh's quotient of its "
            "displacement): the scheme does not follow that motion, and "
            "%s; take a time step of a twentieth of the period or less to "
            "follow it, or run quasi-static (dynamics=None) for the "
            "static answer", record.time_step, record.time_step / period,
            period, swing)


def start_allowance(load: float, dt: float, mass: float,
                    delta: float) -> float:
    """The kinetic energy that the first step of a start out of balance
    (a load ``load`` applied at once) leaves where stiffness holds a body
    of ``mass`` whose mass shares the load: each part's acceleration
    ``a_0 = load / mass`` of the balance at the start, which the step
    turns into a velocity ``dt a_0 d^2 / (1 + d)^2`` (``d = delta =
    alpha_f - alpha_m``; the velocity of a single degree of freedom
    whose stiffness ``k`` goes to infinity), so ``(load dt)^2 / (2
    mass) (d / (1 + d))^4``: a sixteenth of the kinetic energy of one
    step of free flight at ``rho_inf = 0`` (``d = 1``), none with
    Newmark's rule (``d = 0``).

    >>> start_allowance(10., .1, 2., 1.) == (10 * .1) ** 2 / (32 * 2)
    True
    >>> start_allowance(10., .1, 2., 0.)
    0.0
    """
    return .5 * (load * dt) ** 2 / mass * (delta / (1 + delta)) ** 4


def held_work(load_work: float, stiffness: float) -> float:
    """The most work a load applied at once does on a linear elastic body
    that holds it, along a step's displacement ``du``: four times the
    energy it stores at rest, ``U = (f . du)^2 / (2 du . K du)``
    (``load_work``, ``stiffness``; the static displacement along ``du``
    is ``(f . du) / (du . K du)`` of it, the swing's reach twice that).
    It bounds the first step's overshoot (:func:`start_allowance`),
    which grows as ``dt^2`` and has no bound of its own: a bar loaded at
    once (rho_inf = 0, one step of 1.5 and of 10 first periods) gained
    1.1 and 44.8 J of kinetic energy against 0.30 and 0.31 J of the
    load's work, under ``(|f| dt)^2 / 32 m`` (1.04 and 46 J), unwarned;
    the step's elastic energy bounds them at 4 x 0.15 J.  A step without
    stiffness along ``du`` (a body in free flight) has no bound.

    >>> held_work(2., 4.) == 4 * 2. ** 2 / (2 * 4.)
    True
    >>> held_work(2., 0.)
    inf
    """
    if not stiffness > 0:
        return np.inf
    return 2 * load_work ** 2 / stiffness


#: the energy a run may create, as a share of the largest energy it
#: held or was given (:class:`CreatedEnergy`), before it is warned of
CREATED = .05


class CreatedEnergy:
    """The check that a run whose points start unstressed creates no
    energy: what its bodies hold, kinetic, stored and dissipated, is at
    most their kinetic energy at the start and the work done on them
    since, the external work (where no prescribed motion, rigid body or
    moving obstacle does work that it leaves out), so their kinetic
    energy is at most that.  Beyond it the run created energy, which the
    balance ``kinetic + internal + contact - external`` books as a loss
    (the internal and contact work of a step resolved so coarsely go
    below zero).  They bound no stored energy: a block landing on a
    floor in steps of 0.04 booked -54.8 J of the two (when they were
    kept together) and lost energy.  Measured: a 2D
    MPM block (E = 1e7) dropped on a 35 degree incline with friction
    0.3 at dt = 0.01, whose impact step converged through a node barely
    held (:meth:`StepInertia.settle`, now refused): kinetic energy 45.7
    J after 9.5 J of gravity's work; the internal work went to -130 J
    and the balance fell by 80 J.  A load applied at once creates
    energy too, on supports as on an obstacle: the generalised-alpha
    scheme (the default with contact) starts from the acceleration of
    the balance at ``t = 0``, and where the body's stiffness holds the
    load the first step leaves a velocity ``dt a_0 d^2 / (1 + d)^2``
    (``d = alpha_f - alpha_m``: ``dt a_0 / 4`` at ``rho_inf = 0``;
    none with Newmark's rule) that the next step damps: a block (E =
    1e4, 1 x 0.75, density 2) under a top traction of 100 at once and
    gravity, dt = 0.02 s, had 0.83 of kinetic energy after 0.57 of
    external work on a floor obstacle, 0.89 after 0.56 on grid-line
    supports (Newmark on either: 0.21 after 1.01).  Warned once, at the
    first step whose excess passes :data:`CREATED` of the largest
    kinetic energy and external work so far, and ``allowance``, what
    that start leaves where the bodies' mass shares the loads
    (:func:`start_allowance`, ``(|f| dt)^2 / 32 m`` at ``rho_inf = 0``,
    ``|f|`` the sum of the sizes of the loads' grid components at the
    step's end): a block released on a floor or a slope has its
    velocity into it (examples/obstacles.py: 0.012 J on the slope
    against 0.033 J), a top traction far more (0.254 above against
    0.141); bounded by the most work the loads can do where the
    stiffness holds the step's motion (:func:`held_work`; the allowance
    grows as ``dt^2``: a bar loaded at once gained 1.12 J against 0.30
    J of work in one step of 1.5 first periods, within 1.04 J of it; a
    block of E = 1e9 resting on a floor, 0.018 J against 0.024 J, at
    13.5 periods a step, is warned now).
    Until this allowance the scale held the loads' work over a cell
    (16.25 for the block above: 5% of it hid its excess of 0.254)."""

    def __init__(self):
        self.kinetic0, self.external, self.scale = None, 0., 0.
        self.told = False

    def check(self, problem, record, allowance: float = 0.) -> None:
        e = record.energy
        if self.kinetic0 is None:
            self.kinetic0 = e["kinetic_start"]
        self.external += e["external_work"]
        created = e["kinetic"] - self.kinetic0 - self.external
        self.scale = max(self.scale, e["kinetic"], e["kinetic_start"],
                         abs(self.external))
        if self.told or not created > max(CREATED * self.scale,
                                          allowance):
            return
        run = problem.run
        if run.prescribed is not None or run.rigid_bodies or any(
                np.any(ob.displacement) for ob in run.obstacles or ()):
            return
        self.told = True
        logger.warning(
            "step %d (time %.4g): the run created energy: its kinetic "
            "energy %.4g exceeds the start's and the external work since "
            "(%.4g) by %.3g; Result.energies()' balance books it as a "
            "loss. An impact or contact step resolved too coarsely, or a "
            "load applied at once (the generalised-alpha scheme's first "
            "step leaves a velocity where stiffness holds it), most "
            "likely: take a shorter time step (Dynamics(time_step=...)) "
            "or ramp the load in (Dynamics(load=...)) and compare",
            record.step, record.time, e["kinetic"],
            self.kinetic0 + self.external, created)
