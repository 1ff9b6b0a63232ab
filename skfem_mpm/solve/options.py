"""How a run is solved, resumed and recorded, as small validated objects,
and what a run's loads may hold besides forces.

:class:`Options` groups :class:`~skfem_mpm.solve.newton.NewtonOptions`,
:class:`~skfem_mpm.stabilisation.settings.Stabilisation`, the linear
solver, :class:`Resume` and what the run keeps.  :func:`~skfem_mpm.
simulate` takes it as ``options=``; the keyword arguments it replaced
(``tol=``, ``ghost=``, ``first_step=``, ...) are deprecated aliases
(:func:`translate_aliases`).
"""
import warnings
from dataclasses import dataclass, field, replace
from typing import Callable, Optional, Sequence, Union

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError, check_int
from ..kernels import check_kernels
from ..stabilisation.settings import Stabilisation
from .backends import check_solver
from .newton import NewtonOptions
from .rigid import RigidBody

__all__ = ["Options", "Resume", "Prescribed", "BodyForce",
           "resumed_counters", "translate_aliases"]


@dataclass(frozen=True)
class Resume:
    """Where a run starts again: ``points`` (given to
    :func:`~skfem_mpm.simulate`) are the state after step
    ``first_step - 1`` at ``load_factor`` (default
    ``(first_step - 1) / nsteps``); the next load increment is
    ``increment`` (default ``1 / nsteps``; less after a cut-back);
    ``domain0`` are the initial domains of the methods with domains
    (default: ``points.domain`` unstretched by their ``F``, as a staged
    run recovers them, to the last bit on most points, not on all:
    ``(d * s) / s`` misses ``d`` by a bit for 0.6% of stretches ``s``
    within 10% of 1; :attr:`~skfem_mpm.Result.domain0` of the run
    resumed, for a bit-identical run)
    and ``counters`` those the run goes on from (a ghost penalty switched
    on stays on): :func:`resumed_counters` of the step's; ``end_force``
    (dynamics with contact between bodies) the contact's force where
    that step ended, a dense grid vector, which the next step books the
    contact's work from (:attr:`~skfem_mpm.StepRecord.end_force`).
    :meth:`after` builds it from the last converged step's record and
    ``domain0`` if given: the run then continues bit-identically, its
    counters and energies too (a run with domains resumed without
    ``domain0`` was refused before 2026-11-29, untrue to the default
    above).  What grid terms of one's own keep over the steps (a spring
    bed's total displacement) is theirs to keep: it is not in the points
    or the checkpoints, ``begin_run`` starts it again, and a resumed run
    warns, naming them, unless a term sets ``stateless = True`` (it keeps
    nothing) or ``restores_state = True`` (it restores what it keeps in
    ``begin_run``; :class:`~skfem_mpm.GridTerm`).

    >>> from skfem_mpm import Resume
    >>> Resume(first_step=0)
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: first_step must be an integer >= 1, got 0
    """
    first_step: int = 1
    load_factor: Optional[float] = None
    increment: Optional[float] = None
    domain0: Optional[ndarray] = None
    counters: Optional[dict] = None
    end_force: Optional[ndarray] = None

    def __post_init__(self):
        check_int("first_step", self.first_step, 1)
        force = self.end_force
        if force is not None and not (
                isinstance(force, np.ndarray) and force.ndim == 1
                and force.dtype.kind == "f"
                and np.isfinite(force).all()):
            raise InvalidInputError(
                "Resume.end_force must be None or a finite 1D float array "
                "(a grid vector: Resume.after(record) gives it), got "
                "{!r}".format(force if not isinstance(force, np.ndarray)
                              else "an array of shape {} and dtype "
                              "{}".format(force.shape, force.dtype)))

    @classmethod
    def after(cls, record, domain0: Optional[ndarray] = None) -> "Resume":
        """Resume after the step of ``record`` (a
        :class:`~skfem_mpm.StepRecord`)."""
        return cls(first_step=record.step + 1,
                   load_factor=record.load_factor,
                   increment=record.increment,
                   domain0=domain0,
                   counters=resumed_counters(record.counters),
                   end_force=end_force_of(record))

    def check(self, nsteps: int, method: str):
        """Raise :class:`~skfem_mpm.errors.InvalidInputError` for a state
        no run of ``nsteps`` steps with ``method`` can be in."""
        if self.first_step > nsteps and self.load_factor is None:
            raise InvalidInputError(
                "Resume.first_step {} is beyond the run's {} steps and no "
                "load_factor says where it stands (a run with cut-backs "
                "takes more steps): nothing would be left to run".format(
                    self.first_step, nsteps))
        for name, value, low, high in (
                ("load_factor", self.load_factor, 0., 1.),
                ("increment", self.increment, 0., 1. / nsteps)):
            if value is not None and not (
                    isinstance(value, (int, float, np.number))
                    and not isinstance(value, bool)
                    and (low <= value < high if name == "load_factor"
                         else low < value <= high * (1 + 1e-12))):
                raise InvalidInputError(
                    "{} must lie in {}{}, {}{}, got {!r}".format(
                        name, "[" if name == "load_factor" else "(", low,
                        high, ")" if name == "load_factor" else "]", value))


def end_force_of(record) -> Optional[ndarray]:
    """A step record's :attr:`~skfem_mpm.StepRecord.end_force` as a dense
    grid vector (``None`` without one: a record of a run without
    contact between bodies in dynamics, or of before it was kept)."""
    force = getattr(record, "end_force", None)
    return None if force is None else \
        np.asarray(force.toarray(), dtype=np.float64).ravel()


def resumed_counters(counters: dict) -> dict:
    """The counters a run resumed after a step goes on from: the step's
    ``counters``, but for the location of its points, which the step
    counted (``locate``) and the resumed run repeats (it counted once more
    per resume, 14 instead of 13 in a 12-step run).  Counters count the
    run's work along its converged steps, work repeated on resume once.

    >>> resumed_counters({"locate": 3, "newton_iterations": 7})
    {'locate': 2, 'newton_iterations': 7}
    """
    kept = dict(counters)
    if kept.get("locate", 0) > 0:
        kept["locate"] -= 1
    return kept


@dataclass(frozen=True)
class Prescribed:
    """Grid displacement increments imposed over each step:
    ``function(grid_basis, f_old, f_new) -> (dofs, increments)``, with
    ``f_old``, ``f_new`` the loads' scale at the step's start and end (the
    load factor; the time function's value in dynamics), ``increments``
    one per DOF or one number for all.  An item of
    :func:`~skfem_mpm.simulate`'s ``loads``; a run reads the motion at
    full load once more (``function(grid_basis, 0, 1)``) to warn of grid
    nodes pushed off the material's face
    (:func:`~skfem_mpm.solve.motion.warn_faces_left`).

    ``bodies``: with contacts between bodies (a grid field per body), the
    bodies (the points' ``body`` numbers) whose copies of the nodes the
    motion moves, bodies glued to them with them; the others meet them
    through the contacts.  Without it, a body's copy of a node is moved
    where its material is nearest the node, with a warning where that
    chose between bodies whose material the node carries.  Refused in a
    run without contacts (one field: every body moves)."""
    function: Callable
    bodies: Optional[Sequence[int]] = None

    def __post_init__(self):
        if not callable(self.function):
            raise InvalidInputError(
                "Prescribed needs a function (basis, f_old, f_new) -> (dofs, "
                "increments), got {!r}".format(self.function))
        if self.bodies is not None:
            try:
                bodies = tuple(sorted({check_int("Prescribed bodies", b, 0)
                                       for b in self.bodies}))
            except TypeError:
                bodies = ()
            if not bodies:
                raise InvalidInputError(
                    "Prescribed bodies must be body numbers (>= 0), at "
                    "least one, got {!r}".format(self.bodies))
            object.__setattr__(self, "bodies", bodies)


@dataclass(frozen=True)
class BodyForce:
    """A body force per unit initial volume at full load, ``value`` of
    shape (dim,) or one row per body (bodies, dim) (gravity on bodies of
    different densities), and whether it grows with the load factor
    (``ramp=True``,
    the default) or acts in full from the first step (``False``: where the
    points start from a geostatic stress that balances it), or one bool
    per body (``value=None``: no body force).  In dynamics the load factor
    is ``Dynamics.load(t)``, 1 by default (gravity in full from ``t =
    0``, either way); ``ramp=False`` does not follow a ``load(t)``.
    What it leaves out of
    balance at the start must be carried by the first step whole: a
    cut-back does not reduce it."""
    value: Sequence[float]
    ramp: Union[bool, Sequence[bool]] = True

    def __post_init__(self):
        check_ramp(self.ramp)
        if self.value is None:                 # none assembled
            return
        try:
            value = np.asarray(self.value, dtype=np.float64)
        except (TypeError, ValueError):
            value = None
        if value is None or value.ndim not in (1, 2) or \
                not np.isfinite(value).all():
            raise InvalidInputError(
                "BodyForce.value must be finite numbers, one per dimension "
                "(or one row of them per body), got {!r}".format(self.value))


def check_ramp(ramp) -> ndarray:
    """``ramp`` (one bool, or one per body) as a bool array, or
    :class:`~skfem_mpm.errors.InvalidInputError`."""
    flags = np.atleast_1d(np.asarray(ramp, dtype=object))
    if flags.ndim != 1 or not flags.size or not all(
            isinstance(r, (bool, np.bool_)) for r in flags):
        raise InvalidInputError(
            "BodyForce.ramp (ramp_body_force) must be True, False or one "
            "bool per body, got {!r}".format(ramp))
    return flags.astype(bool)


@dataclass(frozen=True)
class Options:
    """How a run is solved and what it keeps.

    Parameters
    ----------
    newton
        :class:`~skfem_mpm.solve.newton.NewtonOptions`: tolerance,
        iterations, cut-backs, line search, full or modified Newton, the
        right-hand side of linear steps.
    stabilisation
        :class:`~skfem_mpm.stabilisation.settings.Stabilisation`: ghost
        penalty and mean dilatation.
    solver
        Linear solver: a scikit-fem solver ``f(A, b) -> x`` or a name
        (``"scipy"``: SciPy's SuperLU, ``"pypardiso"``: MKL's Pardiso,
        ``"pyamg"``: AMG-CG, ``"auto"``; a back end's name, "superlu",
        is refused naming the one meant); default
        ``"auto"``, the back end measured fastest for each system's size
        among those installed, logged
        (:func:`~skfem_mpm.solve.backends.solver_auto`); the name is
        checked on creation, the back end's package when the run starts.
    resume
        :class:`Resume`, or ``None``: from the start.
    keep_snapshots
        Keep per-step grid increments, positions, displacements and
        stresses in the history.
    callback
        ``callback(record, points)`` after every step.  An exception it
        raises ends the run and propagates unchanged (catch your own
        type), with the run's state attached where the exception has no
        attribute of the name: ``state`` (the step's points, to resume
        from with ``Resume.after(record)``), ``load_factor`` and
        ``history``, as on a :class:`~skfem_mpm.errors.ConvergenceError`.
    locator
        A :func:`~skfem_mpm.point_locator` of the mesh to reuse (checked
        against the mesh when the run starts).
    kernels
        ``"auto"`` (default): the compiled points-first passes of a Newton
        iteration where they cover the run (standard MPM, uGIMP, cpGIMP
        and B-splines in 2D and 3D, small and finite deformation,
        ``LinearElastic``, ``VonMises``, ``DruckerPrager``,
        ``MohrCoulomb`` and ``ModifiedCamClay``, with or without mean
        dilatation) and numba imports, the numpy path otherwise and
        under ``SKFEM_MPM_KERNELS=numpy`` (each logged once at INFO);
        ``"numpy"``: the numpy path, the tested reference;
        ``"compiled"``: the compiled passes, a run they cannot serve
        refused before any work (:mod:`skfem_mpm.kernels`).  The
        material-point basis of standard MPM and FE (its slots and, for
        ``ElementQuad1`` and ``ElementHex1``, its fields) and the supports'
        check follow this option too, with compiled passes equal to the
        numpy path's to the bit: ``"numpy"`` takes scikit-fem's and
        scipy's, ``"auto"`` the compiled ones where numba imports and
        ``SKFEM_MPM_KERNELS`` is not ``numpy``, ``"compiled"`` the
        compiled ones where numba imports (the method piece carries the
        option: :func:`~skfem_mpm.methods.method.make_method`).

    >>> from skfem_mpm import NewtonOptions, Options
    >>> Options(newton=NewtonOptions(tol=1e-10)).newton.tol
    1e-10
    >>> Options(newton={"tol": 1e-10})
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: Options.newton must be a NewtonOptions(...), got {'tol': 1e-10}
    """
    newton: NewtonOptions = field(default_factory=NewtonOptions)
    stabilisation: Stabilisation = field(default_factory=Stabilisation)
    solver: object = None
    resume: Optional[Resume] = None
    keep_snapshots: bool = True
    callback: Optional[Callable] = None
    locator: object = None
    kernels: str = "auto"

    def __post_init__(self):
        for name, kind in (("newton", NewtonOptions),
                           ("stabilisation", Stabilisation),
                           ("resume", Resume)):
            value = getattr(self, name)
            if not isinstance(value, kind) and not (
                    name == "resume" and value is None):
                raise InvalidInputError(
                    "Options.{} must be a {}(...), got {!r}".format(
                        name, kind.__name__, value))
        if not isinstance(self.keep_snapshots, (bool, np.bool_)):
            raise InvalidInputError("keep_snapshots must be True or False, "
                                    "got {!r}".format(self.keep_snapshots))
        if self.callback is not None and not callable(self.callback):
            raise InvalidInputError("callback must be callable, got "
                                    "{!r}".format(self.callback))
        check_kernels(self.kernels)
        check_solver(self.solver)


#: the keyword arguments :func:`~skfem_mpm.simulate` took before
#: :class:`Options`: where each now lives
ALIASES = {
    "tol": "newton", "max_iter": "newton", "max_cutbacks": "newton",
    "line_search": "newton", "newton": "newton", "rhs": "newton",
    "ghost": "stabilisation", "antilocking": "stabilisation",
    "solver": "options", "keep_snapshots": "options",
    "callback": "options", "locator": "options",
    "first_step": "resume", "load_factor": "resume", "increment": "resume",
    "domain0": "resume", "counters": "resume",
    "prescribed": "loads", "rigid_bodies": "loads", "terms": "loads",
    "ramp_body_force": "body_force",
}


#: the class of each group of :data:`ALIASES` an :class:`Options` field
GROUP_CLASSES = {"newton": "NewtonOptions", "stabilisation": "Stabilisation",
                 "resume": "Resume"}


def translate_aliases(function: str, options: Optional[Options],
                      body_force, loads, aliases: dict,
                      warn: bool = True):
    """``(options, body_force, loads)`` with the deprecated keyword
    arguments ``aliases`` of ``function`` moved where they now live (one
    :class:`DeprecationWarning` naming them); an unknown keyword, or one
    whose setting ``options`` also gives (not its default), is refused."""
    unknown = sorted(set(aliases) - set(ALIASES))
    if unknown:
        raise InvalidInputError("{}() got unexpected keyword argument(s) {}"
                                .format(function, ", ".join(unknown)))
    options = Options() if options is None else options
    if not isinstance(options, Options):
        raise InvalidInputError("options must be an Options(...), got "
                                "{!r}".format(options))
    if not aliases:
        return options, body_force, loads
    if warn:
        # each group's class and the fields given (a trial read "use
        # options=Options(newton=...)" for rhs= without the field's name)
        fields = {}
        for name in aliases:
            fields.setdefault(ALIASES[name], set()).add(name)
        warnings.warn(
            "{}({}=...) is deprecated: use {}".format(
                function, "=..., ".join(sorted(aliases)), ", ".join(sorted(
                    {"options=Options({}={}({}=...))".format(
                        group, GROUP_CLASSES[group],
                        "=..., ".join(sorted(names)))
                     if group in GROUP_CLASSES
                     else "options=Options({}=...)".format(
                         "=..., ".join(sorted(names))) if group ==
                     "options" else "loads=[...]" if group == "loads"
                     else "body_force=BodyForce(..., ramp=...)"
                     for group, names in fields.items()}))),
            DeprecationWarning, stacklevel=3)
    groups = {}
    for name, value in aliases.items():
        groups.setdefault(ALIASES[name], {})[name] = value
    newton = groups.get("newton", {})
    stabilisation = groups.get("stabilisation", {})
    resume = groups.get("resume", {})
    given = options
    twice = [name for name in newton if getattr(options.newton, name)
             != getattr(NewtonOptions(), name)] + \
        [name for name in stabilisation if getattr(options.stabilisation,
                                                   name)
         != getattr(Stabilisation(), name)] + \
        [name for name in groups.get("options", {})
         if getattr(options, name) != getattr(Options(), name)]
    if twice or (resume and given.resume is not None):
        raise InvalidInputError(
            "{}: {} given both in options and as keyword argument(s)".format(
                function, ", ".join(sorted(twice + list(resume)))))
    options = replace(
        options, newton=replace(options.newton, **newton),
        stabilisation=replace(options.stabilisation, **stabilisation),
        resume=Resume(**resume) if resume else options.resume,
        **groups.get("options", {}))
    extra = groups.get("loads", {})
    if extra:
        loads = list(_items(loads))
        if extra.get("prescribed") is not None:
            loads.append(Prescribed(extra["prescribed"]))
        rigid = _items(extra.get("rigid_bodies", ()))
        for k, body in enumerate(rigid):
            if not isinstance(body, RigidBody):
                raise InvalidInputError(
                    "rigid_bodies[{}] must be a RigidBody, got {!r}".format(
                        k, body))
        loads += rigid
        loads += _items(extra.get("terms", ()))
    if "ramp_body_force" in aliases:
        if isinstance(body_force, BodyForce):
            raise InvalidInputError("{}: both BodyForce(ramp=...) and "
                                    "ramp_body_force given".format(function))
        body_force = BodyForce(body_force, aliases["ramp_body_force"])
    return options, body_force, loads


def _items(items) -> list:
    """``items`` as a list (one item or a sequence)."""
    if items is None:
        return []
    if isinstance(items, (list, tuple)):
        return list(items)
    return [items]
