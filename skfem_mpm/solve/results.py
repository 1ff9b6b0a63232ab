"""What a run returns: the final points, a record per load step, and
counters of the work done."""
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError
from ..quadrature.basis import MaterialPointBasis
from ..quadrature.points import MaterialPoints

__all__ = ["Result", "StepRecord", "PHASES"]

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
        stress update, relative to the larger of ``|f_ext|`` and the
        internal force on the DOFs whose motion is prescribed; in
        dynamics also of the inertia force, and of ``ROUNDOFF / tol``
        (``ROUNDOFF = 1e-12``) times the forces of the step's start its
        balance sums (the momentum's rate ``M v / (beta dt)``, the terms
        of ``M a``, the internal force): a residual at their round-off is
        converged (a body in free flight, with no load).
    n_active_elements, n_free_dofs
        Size of the active grid.
    timings
        Seconds per phase: locate, assemble, solve, update, check (the
        balance, and the grid terms' settle checks: contact's rounds),
        with those of the failed attempts before it (the retry ladder's,
        and a cut-back's before its sub-step).
    u
        Grid displacement increment of the step (``None`` unless
        snapshots are kept).
    x, displacement, stress
        Point positions (after the update), accumulated displacements and
        stresses at the end of the step (``None`` unless kept).
    newton_residuals
        Nonlinear steps (finite deformation, plasticity or contact): the
        residual of every Newton iteration, with contact of every
        augmented-Lagrangian round in order (a round after an update of
        the multipliers starts from a larger residual, its own first
        entry); ``None`` for a linear step.
    newton_iterations
        Nonlinear steps: the Newton iterations of the step (of all its
        rounds; ``len(newton_residuals) - 1`` without contact rounds);
        ``None`` for a linear step.
    n_yielded
        Nonlinear steps: points on the yield surface.
    elements
        The active elements of the step (kept with the snapshots).
    reaction_dofs, reaction_values
        The supported and prescribed active grid DOFs and the reaction
        forces there at the end of the step (internal minus external
        force); :attr:`reactions` expands them into a grid vector.
    n_dofs
        Number of grid DOFs (the length of ``u`` and ``reactions``).
    rigid_forces
        One (dim,) force per rigid body (``simulate(loads=[RigidBody(...)])``):
        the sum of the reactions at the DOFs it drives, the force that
        holds its motion (a footing's load).
    increment, counters
        The load increment the next step starts with (``1 / nsteps``, or
        less after a cut-back) and the run's counters after this step: with
        ``load_factor``, what a resume needs.
    obstacle_forces
        Runs with obstacles (``simulate(obstacles=...)``): the force
        (obstacles x dim) the material exerts on each obstacle at the end
        of the step; ``None`` without obstacles.
    contact_pressure, contact_area
        Runs with obstacles: the contact pressure at the end of the step
        and the surface it acts on, per obstacle and point (sparse,
        ``scipy.sparse`` csr, obstacles x points; ``.toarray()`` gives
        them in full, zero where a point does not press): a point's
        pressure is the normal force its domain's pressed corners
        transmit over their share of the surface (its area), so that
        ``contact_pressure.multiply(contact_area).sum(axis=1)`` is each
        obstacle's normal force, on a flat face its ``obstacle_forces``
        along the face's normal to round-off (friction's part of the
        force is the rest; docs/contact.md, "Contact pressure").  ``None``
        without obstacles; tied obstacles have none.
    contact_forces
        Runs with contacts between bodies (``simulate(contacts=...)``):
        the force (contacts x dim) the first body of each contact exerts
        on the second at the end of the step; ``None`` without contacts.
    time, time_step, energy
        Dynamic runs (``simulate(dynamics=...)``): the time at the end of
        the step, its length, and ``{"kinetic_start": ..., "kinetic": ...,
        "internal_work": ..., "external_work": ..., "contact_work":
        ...}``: the kinetic energy at its start and end, the work of the
        points' internal forces (their stresses' divergence: the change
        of the stored elastic energy plus the plastic work; with the
        forces of the grid terms that are not contacts, the ghost
        penalty's, a term of one's own), of the external forces (loads;
        not the reactions of supports or prescribed motion) and of the
        contact forces (with obstacles, friction included, and between
        bodies: the grid terms that set
        :attr:`~skfem_mpm.protocols.GridTerm.contact`) over the step,
        trapezoidal on the grid from the forces at its start and end;
        ``None`` in quasi-static runs.  :meth:`Result.energies` sums
        them.  The contact work is what the trapezoid books of forces
        that a fixed smooth obstacle exerts without doing work, and a
        landing within a step leaves it behind: a 64 kg block dropped 0.4
        m on a smooth floor keeps 71.55 J of it in flight after its
        bounce, where its internal work is its strain energy, under 1e-3
        J (75.03 J at half the time step, 16.18 J at a quarter;
        docs/dynamics.md).  (Before ``contact_work`` was kept apart, the
        internal work held it.)
    end_force
        Dynamic runs with contact between bodies: the contact's force
        (a sparse 1 x N row of the step's grid DOFs) where the step
        ended, which the next step books the contact's work from; what
        a resume needs too (:meth:`~skfem_mpm.Resume.after`).  ``None``
        otherwise.

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
    newton_iterations: Optional[int] = None
    n_yielded: int = 0
    elements: Optional[ndarray] = None
    reaction_dofs: Optional[ndarray] = None
    reaction_values: Optional[ndarray] = None
    n_dofs: int = 0
    increment: float = 0.
    counters: Optional[dict] = None
    rigid_forces: List[ndarray] = field(default_factory=list)
    obstacle_forces: Optional[ndarray] = None
    contact_pressure: Optional[object] = None
    contact_area: Optional[object] = None
    contact_forces: Optional[ndarray] = None
    time: Optional[float] = None
    time_step: Optional[float] = None
    energy: Optional[dict] = None
    end_force: Optional[object] = None

    @property
    def reactions(self) -> ndarray:
        """Reaction forces as a grid vector like ``u``, zero off the
        supported and prescribed DOFs (vector DOF ``dim * k + a`` is
        component a at node k)."""
        out = np.zeros(self.n_dofs)
        if self.reaction_dofs is not None:
            out[self.reaction_dofs] = self.reaction_values
        return out


@dataclass
class Result:
    """The outcome of a run (:func:`~skfem_mpm.simulate`,
    :func:`~skfem_mpm.solve_mpm`, :func:`~skfem_mpm.solve_finite`).

    Attributes
    ----------
    points
        Final material-point state.
    history
        One :class:`StepRecord` per load step.
    basis
        The material-point basis (scalar element) of the last step, before
        the final position update; vector DOF ``dim * k + a`` of the grid
        solution is component a at its DOF k.  Methods ``"mpm"`` and
        ``"fem"`` only: ``None`` for GIMP and the B-splines (``"ugimp"``,
        ``"cpgimp"``, ``"bspline"`` and the rest: their weights are no
        scikit-fem basis).  The step's
        equilibrium holds on these positions, not on :attr:`points`'
        (moved after it): a basis of one's own for such a run is built on
        them (``x0`` after one step).
    counters
        How often each kind of work was done: ``locate`` (point location),
        ``body_force`` (body-force assemblies), ``linear_solves``,
        ``return_maps`` (stress updates with a return map),
        ``newton_iterations``, ``line_search_trials`` (shortened Newton
        steps evaluated by the line search, and a rejected predictor's
        two evaluations), ``stabilised_solves`` (Newton
        solves that needed the stabilised tangent: zero-energy modes), and
        ``ghost_from_step`` (0, or the step from which ``ghost="auto"``
        switched the ghost penalty on), ``line_search_from_step`` (0, or
        the step from which ``line_search="backtracking"`` starts every
        step with the line search), ``factorisations`` (stiffness
        matrices factorised: one per linear solve of a load step, fewer
        with ``newton="modified"``); with obstacles ``contact_updates``
        (augmented-Lagrangian updates of contact: each solves a step
        again), from a smooth obstacle's penalty's first growth
        ``contact_penalty_growths`` (the run's growths) and
        ``contact<k>_penalty_growths`` (obstacle ``k``'s: a resume grows
        it again); with ``NewtonOptions(grow_back=True)``, after a
        cut-back, ``easy_sub_steps`` (the sub-steps in a row that
        converged easily at the cut-back's increment, which grows back
        after two: :func:`~skfem_mpm.solve.core.grown_increment`; a
        resume goes on from it).
    domain0
        GIMP and averaged splines: the domains' half-lengths (dim, n) the
        run's deformation stretches (cpGIMP) from, the initial ones, also
        for a run from points an earlier run deformed (recovered from
        their domains and ``F``): what :meth:`~skfem_mpm.Resume.after`
        takes to resume it; ``None`` without domains.

    """
    points: MaterialPoints
    history: List[StepRecord] = field(default_factory=list)
    basis: Optional[MaterialPointBasis] = None
    domain0: Optional[ndarray] = None
    counters: dict = field(default_factory=lambda: dict.fromkeys(
        ("locate", "body_force", "linear_solves", "return_maps",
         "newton_iterations", "line_search_trials", "stabilised_solves",
         "ghost_from_step", "line_search_from_step", "factorisations"), 0))

    def timings(self) -> dict:
        """Total seconds per phase over all steps."""
        return {p: sum(r.timings[p] for r in self.history) for p in PHASES}

    def energies(self) -> dict:
        """Dynamic runs: arrays over time, at the start and after every
        step, of ``time``, ``kinetic`` energy, the accumulated
        ``internal_work`` (of the points' stresses: stored elastic energy
        plus plastic work), ``external_work`` (of the loads) and
        ``contact_work`` (of the contact forces: with obstacles,
        friction included, and between bodies; zero without contact;
        :attr:`StepRecord.energy`), all zero at the start,
        and ``balance = kinetic + internal_work + contact_work -
        external_work`` (constant, the initial kinetic energy, where
        nothing dissipates and supports do no work: its fall from
        ``kinetic[0]`` is what the scheme and impacts dissipated).  On a
        friction floor that fall is large, and no missing friction
        work: a granular column's came to 8-26% of gravity's work (17.7%
        with Newmark's rule, which damps nothing), a third of it in the
        one step where the floor's force came on (docs/dynamics.md).  A
        run that created energy (from unstressed points: a kinetic
        energy beyond its start's and the external work since) is
        warned, naming the step: its fall of the balance is no loss
        (:class:`~skfem_mpm.solve.dynamics.CreatedEnergy`)."""
        if not self.history or self.history[0].energy is None:
            raise InvalidInputError("energies: only a dynamic run's result "
                                    "(simulate(dynamics=...)) has them")
        steps, first = self.history, self.history[0]
        out = {"time": np.array([first.time - first.time_step]
                                + [r.time for r in steps]),
               "kinetic": np.array([first.energy["kinetic_start"]]
                                   + [r.energy["kinetic"] for r in steps])}
        for name in ("internal_work", "external_work", "contact_work"):
            out[name] = np.concatenate([[0.], np.cumsum(
                [r.energy.get(name, 0.) for r in steps])])
        out["balance"] = out["kinetic"] + out["internal_work"] \
            + out["contact_work"] - out["external_work"]
        return out
