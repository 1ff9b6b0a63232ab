"""External loads of a load step, at a load factor: body force and point
forces (seed (2.18), (2.19)), tractions and pressure on a body's surface,
and user ``LinearForm`` s on the grid.

Every load is given at full load and ramped linearly by the load factor.

- Body force per unit *initial* volume and point forces are mapped with
  the step's point operator (standard MPM, FE or GIMP weights).
- :class:`Traction` and :class:`Pressure` act on one side of a body: each
  point of the outermost layer on that side carries the face of its domain
  (``MaterialPoints.domain``), whose centre ``x + F (d0 n0)`` is the load's
  point of application, mapped with the grid's shape functions there (with
  two points per cell along the side, this integrates a uniform traction
  exactly, as finite elements do).  A traction is a dead load per initial
  area; a pressure follows the surface in finite deformation: its force
  ``-p J F^-T N A0`` (Nanson's formula) uses the surface as it is at the
  start of each load step.
- :class:`GridLoad`: any scikit-fem ``LinearForm`` assembled on the whole
  grid with Gaussian quadrature (a load fixed in space).

"""
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError, check_finite
from ..mechanics.hencky import inverse_and_det
from ..methods.operators import PointOperator
from ..quadrature.basis import MaterialPointBasis
from ..quadrature.points import MaterialPoints

__all__ = ["Traction", "Pressure", "GridLoad", "SIDES", "side_points",
           "ExternalLoads"]

SIDES = {"left": (0, -1), "right": (0, 1), "bottom": (1, -1),
         "top": (1, 1), "back": (2, -1), "front": (2, 1)}


def side_points(points: MaterialPoints, side: str,
                select: Optional[ndarray] = None) -> ndarray:
    """The outermost layer of points on ``side`` (``"left"``, ``"right"``,
    ``"bottom"``, ``"top"``, ``"back"``, ``"front"``): those whose domain
    reaches the extreme coordinate of the selected points (``select``: a
    boolean mask or indices, default all).

    Examples
    --------
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import seed_points
    >>> from skfem_mpm.solve.loads import side_points
    >>> pts = seed_points(MeshQuad().refined(1), 2)
    >>> side_points(pts, "top").size
    4

    """
    axis, sign = _side(side, points.dim)
    if points.domain is None:
        raise InvalidInputError(
            "loads on a side need point domains (MaterialPoints.domain; "
            "seed_points sets them on tensor-product grids)")
    if select is None:
        mine = np.arange(points.n)
    elif np.asarray(select).dtype == bool:
        mine = np.flatnonzero(select)
    else:
        mine = np.unique(np.asarray(select, dtype=np.int64))
    if mine.size == 0:
        raise InvalidInputError("no point selected for side {!r}".format(
            side))
    face = points.x[axis, mine] + sign * points.domain[axis, mine]
    edge = face.max() if sign > 0 else face.min()
    tol = 1e-9 * (1 + np.abs(edge))
    return mine[np.abs(face - edge) <= tol + 1e-6 * points.domain[axis, mine]]


def _side(side: str, dim: int):
    if side not in SIDES or SIDES[side][0] >= dim:
        raise InvalidInputError("side must be one of {}, got {!r}".format(
            [s for s, (a, _) in SIDES.items() if a < dim], side))
    return SIDES[side]


@dataclass
class Traction:
    """A traction (force per initial area, fixed direction) at full load
    on ``side`` of the points ``points`` (indices, e.g. from
    :func:`side_points`)."""
    points: ndarray
    side: str
    traction: Sequence[float]


@dataclass
class Pressure:
    """A pressure at full load (positive pushes into the body) on ``side``
    of the points ``points``; it follows the surface in finite
    deformation."""
    points: ndarray
    side: str
    pressure: float


@dataclass
class GridLoad:
    """A scikit-fem ``LinearForm`` on the grid's vector basis (full load),
    with its keyword fields; assembled once with Gaussian quadrature."""
    form: object
    fields: Optional[dict] = None


class ExternalLoads:
    """All the loads of a run: ``external(op, points, factor)`` is the grid
    force vector at load factor ``factor``.

    Parameters
    ----------
    mesh, elem, grid
        The grid, its scalar element and vector grid basis.
    gravity
        Body force per unit initial volume, (dim,), or ``None``.
    loads
        :class:`Traction`, :class:`Pressure` and :class:`GridLoad` items.
    domain0
        Initial domain half-lengths of the points (surface loads).
    counters
        The run's counters (``body_force`` counts body-force assemblies).

    """

    def __init__(self, mesh, elem, grid, gravity, loads, domain0, counters,
                 n_points: int):
        self.mesh, self.elem, self.dim = mesh, elem, mesh.dim()
        self.gravity, self.counters, self.domain0 = gravity, counters, domain0
        self.surface, self.grid_vector = [], None
        for load in loads:
            if isinstance(load, (Traction, Pressure)):
                self.surface.append(self._surface(load, n_points))
            elif isinstance(load, GridLoad):
                from skfem import Basis, asm
                f = asm(load.form, Basis(mesh, grid.elem),
                        **(load.fields or {}))
                check_finite("GridLoad", f)
                self.grid_vector = f if self.grid_vector is None \
                    else self.grid_vector + f
            else:
                raise InvalidInputError(
                    "loads must be Traction, Pressure or GridLoad items, got "
                    "{}".format(type(load).__name__))

    def _surface(self, load, n_points: int):
        axis, sign = _side(load.side, self.dim)
        if self.domain0 is None:
            raise InvalidInputError(
                "{} needs point domains (MaterialPoints.domain)".format(
                    type(load).__name__))
        idx = np.asarray(load.points, dtype=np.int64).ravel()
        if idx.size == 0 or idx.min() < 0 or idx.max() >= n_points:
            raise InvalidInputError(
                "{}.points must be indices of points in [0, {}), got {}"
                .format(type(load).__name__, n_points, idx[:5].tolist()))
        if isinstance(load, Traction):
            value = np.asarray(load.traction, dtype=np.float64).ravel()
            if value.shape != (self.dim,):
                raise InvalidInputError(
                    "Traction.traction must have {} components, got {}"
                    .format(self.dim, value.shape))
        else:
            value = np.asarray(float(load.pressure))
        check_finite(type(load).__name__, value)
        return idx, axis, sign, value, isinstance(load, Pressure)

    def has_loads(self, points) -> bool:
        return bool(self.gravity is not None or points.force.any()
                    or self.surface or self.grid_vector is not None)

    def external(self, op, points: MaterialPoints, factor: float) -> ndarray:
        """Grid force vector at load factor ``factor``."""
        f = np.zeros(op.N)
        load = points.force if points.force.any() else None
        if self.gravity is not None:
            self.counters["body_force"] += 1
            weight = self.gravity[:, None] * points.volume0
            load = weight if load is None else load + weight
        if load is not None:
            f += op.point_force(factor * load)
        for idx, axis, sign, value, follower in self.surface:
            f += factor * self._surface_force(points, idx, axis, sign, value,
                                              follower, op.N)
        if self.grid_vector is not None:
            f += factor * self.grid_vector
        return f

    def _surface_force(self, points, idx, axis, sign, value, follower, N):
        """Forces on the faces of points ``idx`` at the faces' centres."""
        dim = self.dim
        d0 = self.domain0[axis, idx]
        F = points.F[:dim, :dim, idx]
        area = points.volume0[idx] / (2 * d0)              # initial area
        centre = points.x[:, idx] + sign * F[:, axis] * d0
        if follower:        # -p J F^-T N A0 at the start of the step
            F_inv, J = inverse_and_det(points.F[:, :, idx], dim)
            force = -value * sign * J * F_inv[axis, :dim] * area
        else:
            force = value[:, None] * area
        faces = MaterialPoints(x=centre, volume=area)
        basis = MaterialPointBasis(self.mesh, self.elem, faces)
        return PointOperator(basis).point_force(force)[:N]
