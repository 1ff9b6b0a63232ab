"""Exceptions raised by skfem-mpm.

Every error the library raises on purpose derives from :class:`MPMError`, so
a script can catch all of them at once, and each subclass names one kind of
problem.  Messages say what is wrong, where (point or node indices) and with
which value.

"""


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
        The load step in which they left it (``None`` outside a run).

    """

    def __init__(self, message, indices=None, step=None):
        super().__init__(message)
        self.indices = indices
        self.step = step


class SingularSystemError(MPMError):
    """The stiffness matrix is singular: the active grid has rigid-body
    modes (missing or insufficient supports) or the factorisation failed."""
