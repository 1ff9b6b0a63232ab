"""Exceptions raised by skfem-mpm.

Every error the library raises on purpose derives from :class:`MPMError`, so
a script can catch all of them at once, and each subclass names one kind of
problem.  Messages say what is wrong, where (point or node indices) and with
which value.

"""
import numpy as np


class MPMError(Exception):
    """Base class of every error raised on purpose by skfem-mpm."""


class InvalidInputError(MPMError, ValueError):
    """An input array has the wrong shape, or holds NaN, inf or an
    impossible value (e.g. a non-positive volume)."""


class InvalidMaterialError(MPMError, ValueError):
    """A material parameter is outside its admissible range
    (e.g. ``E <= 0`` or ``nu`` outside ``(-1, 0.5)``)."""


class UnsupportedElementError(MPMError, TypeError):
    """The element or mesh type is not supported by the requested path."""


class PointsOutsideGridError(MPMError):
    """Material points lie outside the background grid.

    Attributes
    ----------
    indices
        Indices of the points outside the grid.
    step
        The load step in which they left it, or at whose start they lay
        outside (:attr:`at_start`; ``None`` outside a run).
    state
        The last converged :class:`~skfem_mpm.MaterialPoints` (in a run).
    at_start
        Whether they lay outside the grid where the step started (in a
        run's first step: as given), not moved out by the step.

    """

    def __init__(self, message, indices=None, step=None, state=None):
        super().__init__(message)
        self.indices = indices
        self.step = step
        self.state = state
        self.at_start = False

    def __str__(self):
        text = super().__str__()
        return text if self.step is None else "step {}: {}".format(
            self.step, text)


class SingularSystemError(MPMError):
    """The stiffness matrix is singular: the active grid has rigid-body
    modes (missing or insufficient supports) or the factorisation failed."""


class ConvergenceError(MPMError):
    """A load step could not be completed even after cutting it back to the
    smallest allowed increment.

    Attributes
    ----------
    state
        The last converged :class:`~skfem_mpm.MaterialPoints` (nothing is
        lost).
    load_factor
        The load factor of that state.
    history
        The records of the converged steps.

    """

    def __init__(self, message, state=None, load_factor=None, history=None):
        super().__init__(message)
        self.state = state
        self.load_factor = load_factor
        self.history = history


class NewtonDivergenceError(ConvergenceError):
    """Newton-Raphson did not reach the tolerance within the allowed
    iterations (or produced non-finite values)."""


class InversionError(ConvergenceError):
    """A point's deformation gradient has ``det F <= 0`` (inverted
    material)."""


class NumericalError(ConvergenceError):
    """Arithmetic failed in a load step (a singular point-wise inverse, an
    overflow): the step is retried and cut back like a diverging one."""


class GridMotionError(NumericalError):
    """A converged step moved free grid nodes by orders of magnitude more
    than any material point: nodes that a sliver of material supports carry
    absurd values (the ghost penalty ties them to their neighbours).  A
    failed step: ``ghost="auto"`` switches the penalty on and retries."""


class PrescribedMotionError(ConvergenceError):
    """Prescribed grid motion no longer acts on the material (the body has
    moved away from the prescribed nodes): it would not be followed."""


class SingularTangentError(SingularSystemError, ConvergenceError):
    """The tangent at a trial state of a nonlinear step is singular even
    stabilised (a softening plastic zone, points leaving cells): the step
    failed, and is retried and cut back like a diverging one; or a linear
    step's stiffness after the first step is (points that moved left a
    node a sliver of support): retried with the ghost penalty of
    ``ghost="auto"``, not cut back.  Missing supports are refused before
    any iteration, as a :class:`SingularSystemError`."""


class ContactError(ConvergenceError):
    """Contact with an obstacle did not settle within its tolerance in a
    step (the augmented-Lagrangian updates ran out): a failed step, cut
    back like a Newton failure."""


class StepTooLongError(ContactError):
    """A load step moved bodies in contact into each other farther than
    its contact looks (pairs cells deep at its end that were apart at its
    start), or carried material through an obstacle: cut back, without
    the retry ladder's rungs (only a shorter step helps)."""


class UnsettledContactError(ContactError):
    """A step's contact did not settle: its augmented-Lagrangian rounds
    ran out, each round's Newton solve converged.  Cut back, past the
    retry ladder's rungs that change only how Newton solves a round (full
    Newton, the line search, the stabilised tangent): each converges to
    the rounds' same equilibria (over the contact tests, none of 79 such
    retries settled a step; a 3D wall's increment took four attempts)."""


class HeldSupportError(UnsettledContactError):
    """Contact with an obstacle did not settle in a step where the
    obstacle pushes more than a fifth of its force on the grid into
    nodes a support holds (:data:`~skfem_mpm.solve.contact.HELD_SHARE`;
    a wall pushed against a block down to a base held in every
    component): cut back like other contact failures, and the run stops
    once the step has failed at a few halvings of its increment, the
    cause unchanged (only the supports or the obstacle's extent remove
    it; :data:`~skfem_mpm.solve.core.HELD_HALVINGS`)."""


class StepFailedError(ConvergenceError):
    """A load step raised an error that is not the package's own (in a
    user's material, form or callback-free code path); the original is the
    ``__cause__``, the last converged state is attached."""


class MaterialOutputError(MPMError):
    """What a material of the user's own returned (or did) breaks the
    material protocol (:mod:`skfem_mpm.mechanics.materials`).

    Attributes
    ----------
    material
        The material's class name.
    method
        ``"principal_update"`` or ``"stress"``.
    variable
        What is wrong: ``"tau"``, ``"eps_e"``, ``"D"``, ``"yielded"``,
        ``"new_state"`` or ``"new_state['name']"``, ``"state['name']"``
        (written into), ``"stress"``; ``None`` where the model raised on
        writing into a read-only array of its own.
    indices
        The run's indices of the points concerned (the first few), or
        ``None`` where the fault is not a point's (a shape).

    In a run the last converged state is attached (``state``,
    ``load_factor``, ``history``); after cut-backs the error raised is a
    new one of the same type whose ``__cause__`` carries these
    attributes.

    """

    def __init__(self, message, material=None, method=None, variable=None,
                 indices=None, **kwargs):
        super().__init__(message, **kwargs)
        self.material, self.method = material, method
        self.variable, self.indices = variable, indices
        for name in ("state", "load_factor", "history"):
            if not hasattr(self, name):
                setattr(self, name, None)


class MaterialProtocolError(MaterialOutputError, InvalidMaterialError):
    """A material returned arrays of the wrong shape or type, a state
    without one of its ``state_variables`` or with a name it does not
    declare, or wrote into the state it was given: the run stops at
    once (a shorter step cannot cure it)."""


class NonFiniteMaterialError(MaterialOutputError, NumericalError):
    """A material returned NaN or inf (stress, elastic strain, tangent or
    a state variable) at some points: a failed step, cut back like a
    diverging one (a shorter step may avoid a trial state where the
    model's arithmetic overflows), unless returned where the step starts
    (no increment: ``at_start``), which every shorter step evaluates
    again: the run then stops at once."""

    at_start = False


class GridTermError(MPMError):
    """What a grid term of the user's own (an item of ``loads``, a
    :class:`~skfem_mpm.GridTerm`) returned breaks the grid-term protocol:
    a force of the wrong shape, a matrix that is not sparse ``N x N``,
    NaN or inf.

    Attributes
    ----------
    term
        The term's class name.
    method
        ``"force"``, ``"start_force"``, ``"load"``, ``"matrix"`` or
        ``"begin_step"``.

    In a run the last converged state is attached (``state``,
    ``load_factor``, ``history``)."""

    def __init__(self, message, term=None, method=None, **kwargs):
        super().__init__(message, **kwargs)
        self.term, self.method = term, method
        for name in ("state", "load_factor", "history"):
            if not hasattr(self, name):
                setattr(self, name, None)


class GridTermProtocolError(GridTermError, InvalidInputError):
    """A grid term returned a force or matrix of the wrong shape or type:
    the run stops at once (a shorter step cannot cure it)."""


class NonFiniteGridTermError(GridTermError, NumericalError):
    """A grid term returned NaN or inf in its force, load or matrix: a
    failed step, cut back as a material's NaN is
    (:class:`NonFiniteMaterialError`)."""


class MaterialRaisedError(MaterialOutputError, NumericalError):
    """A material of the user's own raised an arithmetic error
    (``ArithmeticError``, ``numpy.linalg.LinAlgError``) in its method,
    named with it: a failed step, retried and cut back (a shorter step
    may avoid the trial state), unless raised where the step starts (no
    increment: ``at_start``), which every shorter step evaluates again:
    the run then stops at once."""

    at_start = False


def check_finite(name: str, a: np.ndarray):
    """Raise :class:`InvalidInputError` naming the first non-finite entry."""
    bad = ~np.isfinite(a)
    if bad.any():
        where = np.argwhere(bad)
        raise InvalidInputError(
            "{} holds {} non-finite value(s) (NaN or inf), first at index {}: {}"
            .format(name, int(bad.sum()), tuple(int(i) for i in where[0]),
                    a[tuple(where[0])]))


def check_real(name: str, value, error=InvalidInputError) -> float:
    """Return ``value`` as a float; raise ``error`` unless it is a real
    number (a string such as ``"1e6"`` or a bool is not)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, float, np.integer, np.floating)):
        raise error("{} must be a number, got {!r} ({})".format(
            name, value, type(value).__name__))
    return float(value)


def check_int(name: str, value, low: int, high: int = None,
              error=InvalidInputError) -> int:
    """Return ``value`` as an int; raise ``error`` unless it is an integer
    (not a bool) in ``[low, high]`` (``high=None``: no upper bound).

    >>> check_int("max_iter", 25, 1, 60)
    25
    >>> check_int("max_iter", 0, 1, 60)
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: max_iter must be an integer in [1, 60], got 0
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, np.integer)) or value < low or (
                high is not None and value > high):
        raise error("{} must be an integer {}, got {!r}".format(
            name, "in [{}, {}]".format(low, high) if high is not None
            else ">= {}".format(low), value))
    return int(value)


def check_choice(name: str, value, choices, error=InvalidInputError):
    """Return ``value``; raise ``error`` unless it is one of ``choices``
    (strings).

    >>> check_choice("rhs", "residual", ("residual", "increment"))
    'residual'
    """
    if not isinstance(value, str) or value not in choices:
        raise error("{} must be one of {}, got {!r}".format(
            name, tuple(choices), value))
    return value


class SceneError(InvalidInputError):
    """A scene description has problems; ``problems`` lists one message per
    problem, each naming the key and the offending value."""

    def __init__(self, problems, source=""):
        self.problems = list(problems)
        self.source = source          # the file, where one was read
        super().__init__("{}{} problem(s):\n".format(
            source + ": " if source else "", len(self.problems))
            + "\n".join(self.problems))
