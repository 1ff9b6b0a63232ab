"""External loads of a load step, at a load factor: body force and point
forces (seed (2.18), (2.19)), tractions and pressure on a body's surface,
and user ``LinearForm`` s on the grid.

Every load is given at full load and ramped linearly by the load factor,
except a body force (``BodyForce(..., ramp=False)``) and a traction or
pressure (``ramp=False``) that act in full from the first step: the loads
a body starting from a stress in equilibrium with them carries (a
geostatic stress under its weight, a sample at its confining pressure).

- Body force per unit *initial* volume and point forces are mapped with
  the step's point operator (standard MPM, FE or GIMP weights).
- :class:`Traction` and :class:`Pressure` act on one side of a body: each
  point of the outermost layer on that side carries the face of its domain
  (``MaterialPoints.domain``), whose centre ``x + F (d0 n0)`` is the load's
  point of application.  Standard MPM maps it with the shape functions of
  the cell that holds the point (with two points per cell along the side,
  this integrates a uniform traction exactly, as finite elements do); a
  face centre that has left the point's cell takes that cell's shape
  functions extrapolated: the force goes to nodes the step's points
  support (a cell without points has no stiffness to carry it) and keeps
  its resultant and its point of application, which the internal force
  of the points' stress needs (clamped onto the cell, a one-cell drained
  triaxial test's cell pressure of 100 was carried as 89.95 once the
  sample had grown 11.7% sideways past its cell).  GIMP loads the face of
  the point's domain in the step's
  operator (its centre ``x +- domain`` along the side's axis) by GIMP's
  weights averaged over it, the nodes the domain's internal force
  reaches (a domain past a grid line included).  B-splines take the
  splines at the face's centre (``"bspline"``) or averaged over the face
  (``"bspline-gimp"``; with the splines at the points a uniform traction
  gives a uniform stress only at 2 or 4 points a cell, whose rule
  integrates the splines' gradients exactly: ``docs/bspline.md``).  A
  traction is a dead load per initial area; a pressure follows the
  surface in finite deformation: its force ``-p J F^-T N A0``
  (Nanson's formula) is evaluated at every iteration's trial
  deformation, so the converged state carries the pressure on the
  deformed surface.  Its load stiffness is not in the tangent (which stays
  symmetric, for every linear solver): Newton then contracts at a linear
  rate that grows with the pressure over the stiffness, and not with the
  step (a cut-back does not help; ``docs/robustness.md`` has the rates
  measured): for pressures of a fraction of a percent of ``E`` (soils,
  fluids on solids) the extra iterations are one or two.  Small strain
  is in equilibrium on the reference configuration: standard MPM puts a
  face along its axis where it was (``x0 + d0``; across the axis where
  its point is), since the grid element's derivative along an axis does
  not depend on the position along it and the points' volumes are
  kept (a face moved with its point put ``u / h`` of its force on the
  grid line below: an oedometer's top cell was under-stressed, an
  isotropic test on one cell reached 387.33 for 400).  GIMP and
  B-splines keep the faces where their points' domains and splines
  are (their internal forces depend on those positions: the reference
  faces were worse there); a face moved into a cell whose far nodes
  are held puts a share of its force straight into the supports
  (:meth:`ExternalLoads.check_held_share` warns past
  :data:`HELD_SHARE`, and in every kinematics of a load on a support,
  more than :data:`ON_SUPPORT` of its force on held DOFs).
- :class:`GridLoad`: any scikit-fem ``LinearForm`` assembled on the whole
  grid with Gaussian quadrature (a load fixed in space).

"""
import logging
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix

from ..errors import InvalidInputError, check_finite
from ..kernels import check_kernels
from ..mechanics.hencky import inverse_and_det
from ..methods.operators import PointOperator
from ..quadrature.basis import MaterialPointBasis
from ..quadrature.locate import cell_coordinates
from ..quadrature.points import MaterialPoints
from ..protocols import GridTerm

logger = logging.getLogger(__name__)

#: a surface load with more than this share of its force on held DOFs
#: across the body (:meth:`ExternalLoads.check_held_share`) is warned about
HELD_SHARE = .01
#: a surface load with more than this share of its force on held DOFs
#: (a load on a support: :meth:`ExternalLoads.check_held_share`) is
#: warned about, in every kinematics
ON_SUPPORT = .5

__all__ = ["Traction", "Pressure", "GridLoad", "SIDES", "side_points",
           "side_axis", "side_names", "ExternalLoads", "check_exposed"]

#: the sides of a body or grid: ``name: (axis, sign)``; by the axis and
#: the sign (``"x-"`` ... ``"z+"``) in every dimension, or by the words of
#: a 2D picture
SIDES = {"left": (0, -1), "right": (0, 1), "bottom": (1, -1),
         "top": (1, 1), "back": (2, -1), "front": (2, 1),
         "x-": (0, -1), "x+": (0, 1), "y-": (1, -1), "y+": (1, 1),
         "z-": (2, -1), "z+": (2, 1)}
#: the words refused in 3D: which face is the top there depends on the axis
#: a user takes as up (y, as in 2D, or z, as in this package's 3D examples)
WORDS_OF_2D = ("bottom", "top", "back", "front")
#: ``(axis, sign): name`` by the axis and the sign
SIDES_NAME = {value: name for name, value in SIDES.items()
              if name[0] in "xyz"}


def side_names(dim: int) -> list:
    """The side names of a ``dim``-dimensional grid.

    >>> side_names(3)
    ['left', 'right', 'x-', 'x+', 'y-', 'y+', 'z-', 'z+']
    """
    return [s for s, (axis, _) in SIDES.items() if axis < dim
            and not (dim == 3 and s in WORDS_OF_2D)]


def side_axis(side: str, dim: int) -> tuple:
    """``(axis, sign)`` of the side named ``side`` in ``dim`` dimensions,
    refused where it does not exist or (in 3D, ``"top"`` and the other
    words of a 2D picture) could mean two faces.

    >>> side_axis("top", 2), side_axis("z+", 3)
    ((1, 1), (2, 1))
    >>> side_axis("top", 3)
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: in 3D the side 'top' would depend on which axis is up: name the face by its axis, 'y+' (as in 2D) or 'z+'
    """
    if dim == 3 and side in WORDS_OF_2D:
        axis, sign = SIDES[side]
        end = "+" if sign > 0 else "-"
        raise InvalidInputError(
            "in 3D the side {!r} would depend on which axis is up: name the "
            "face by its axis, {!r} ({}) or {!r}".format(
                side, "xyz"[axis] + end, "as in 2D" if axis == 1 else
                "its meaning here until now", "zy"[axis - 1] + end))
    if side not in side_names(dim):
        raise InvalidInputError("side must be one of {}, got {!r}".format(
            side_names(dim), side))
    return SIDES[side]


def side_points(points: MaterialPoints, side: str,
                select: Optional[ndarray] = None) -> ndarray:
    """The outermost layer of points on ``side`` (:func:`side_names`:
    ``"x-"`` to ``"z+"``; in 2D also ``"left"``, ``"right"``, ``"bottom"``,
    ``"top"``, in 3D ``"left"`` and ``"right"``): those whose domain
    reaches the extreme coordinate of the selected points (``select``: a
    boolean mask or indices, default all) to within half its own width
    along the side's axis: deformed points (a stage's, whose top row
    differs in height by a fraction of a cell) keep their whole layer,
    and the next layer's domains end a whole width short.  A side that
    slopes by more than that takes its highest part only.

    Examples
    --------
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import seed_points
    >>> from skfem_mpm.solve.loads import side_points
    >>> pts = seed_points(MeshQuad().refined(1), 2)
    >>> side_points(pts, "top").size
    4

    """
    axis, sign = side_axis(side, points.dim)
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
    width = points.domain[axis, mine]
    face = points.x[axis, mine] + sign * width
    edge = face.max() if sign > 0 else face.min()
    tol = 1e-9 * (1 + np.abs(edge))
    return mine[np.abs(face - edge) <= tol + .5 * width]


def check_exposed(loads, points: MaterialPoints) -> None:
    """Refuse a :class:`Traction` or :class:`Pressure` on points whose
    face on its side lies inside their body: another point of the same
    body sits right beyond it (a domain's width along the side's axis, to
    a quarter of the domain).  Top points loaded on their ``"left"`` side
    were taken without a word (a user trial)."""
    surface = [load for load in loads if isinstance(load, (Traction,
                                                           Pressure))]
    if not surface or points.domain is None:
        return
    from scipy.spatial import cKDTree
    tree = cKDTree(points.x.T)
    for load in surface:
        axis, sign = side_axis(load.side, points.dim)
        idx = np.asarray(load.points, dtype=np.int64).ravel()
        beyond = points.x[:, idx].copy()
        beyond[axis] += sign * 2 * points.domain[axis, idx]
        distance, nearest = tree.query(beyond.T, p=np.inf)
        inside = idx[(distance <= .25 * points.domain[:, idx].min(axis=0))
                     & (points.body[nearest] == points.body[idx])]
        if inside.size:
            raise InvalidInputError(
                "{} on side {!r}: {} of its {} points have a point of their "
                "body right beyond that face (the first, point {} at {}): "
                "their {!r} faces lie inside the body; load "
                "side_points(points, {!r}) or check the side".format(
                    type(load).__name__, load.side, inside.size, idx.size,
                    inside[0], np.round(points.x[:, inside[0]], 6).tolist(),
                    load.side, load.side))



def check_load_ramp(load) -> bool:
    """A :class:`Traction`'s or :class:`Pressure`'s ``ramp`` as a bool, or
    :class:`~skfem_mpm.errors.InvalidInputError`."""
    if not isinstance(load.ramp, (bool, np.bool_)):
        raise InvalidInputError(
            "{}.ramp must be True (grows with the load factor) or False "
            "(in full from the first step), got {!r}".format(
                type(load).__name__, load.ramp))
    return bool(load.ramp)


def in_full_words(pressures: Sequence[bool]) -> str:
    """The surface loads acting in full from the first step, one flag per
    load (``True``: a pressure, ``False``: a traction), in words (``""``:
    none).

    >>> in_full_words([False, True, False])
    'a traction and a pressure'
    """
    return " and ".join("a " + kind for kind in sorted(
        {"pressure" if p else "traction" for p in pressures}, reverse=True))


def supported_share(S: csr_matrix, supported: ndarray) -> csr_matrix:
    """The rows of the weights ``S`` (faces x nodes) on the ``supported``
    nodes only, each scaled to its whole sum: a face's force goes to the
    nodes that carry stiffness.  The splines at a face's centre reach a
    node further than at its point, and a node no point reaches is no DOF
    of the step: a B-spline pile's head traction lost 1.3% of itself
    there once the pile had sunk (a user trial; its contact and the
    supports carried 8011 of the 8120 applied, silently).

    >>> S = csr_matrix(np.array([[.5, .3, .2], [0., .4, .6]]))
    >>> supported_share(S, np.array([0, 1])).toarray().round(3).tolist()
    [[0.625, 0.375, 0.0], [0.0, 1.0, 0.0]]
    """
    S = S.tocsr()
    whole = np.asarray(S.sum(axis=1)).ravel()
    keep = np.zeros(S.shape[1], dtype=bool)
    keep[supported] = True
    if keep[S.indices].all():
        return S
    S = S.copy()
    S.data[~keep[S.indices]] = 0.
    S.eliminate_zeros()
    kept = np.asarray(S.sum(axis=1)).ravel()
    scale = np.divide(whole, kept, out=np.zeros_like(whole), where=kept > 0)
    return csr_matrix(S.multiply(scale[:, None]))


@dataclass

class Traction:
    """A traction (force per initial area, fixed direction) at full load
    on ``side`` of the points ``points`` (indices, e.g. from
    :func:`side_points`); it grows with the load factor (``ramp=True``,
    the default) or acts in full from the first step (``False``: where
    the points start from a stress that balances it, e.g. a confining
    pressure).  In dynamics the load factor is ``Dynamics.load(t)``,
    1 by default: both act in full from ``t = 0`` unless a ``load(t)`` is
    given, which ``ramp=False`` does not follow."""
    points: ndarray
    side: str
    traction: Sequence[float]
    ramp: bool = True


@dataclass
class Pressure:
    """A pressure at full load (positive pushes into the body) on ``side``
    of the points ``points``; it follows the surface in finite
    deformation.  It grows with the load factor (``ramp=True``, the
    default) or acts in full from the first step (``False``: a confining
    pressure the points' initial stress balances, as in a triaxial
    test's cell); in dynamics as a :class:`Traction`'s.

    >>> import numpy as np
    >>> from skfem_mpm import Pressure
    >>> Pressure(np.arange(4), "right", 100., ramp=False).ramp
    False
    """
    points: ndarray
    side: str
    pressure: float
    ramp: bool = True


@dataclass
class GridLoad:
    """A scikit-fem ``LinearForm`` on the grid's vector basis (full load),
    with its keyword fields; assembled once with Gaussian quadrature, over
    the grid's cells, or with ``facets`` over those facets (a
    ``FacetBasis``: a traction on a side of the grid; anything scikit-fem's
    ``Mesh.normalize_facets`` takes: indices, a boundary's name, a
    function of the facets' midpoints).  A dead load: it stays where it
    was assembled, in finite deformation too.

    A traction on the right side of a conforming mesh, as on finite
    elements:

    >>> from skfem import LinearForm, MeshQuad
    >>> from skfem_mpm import GridLoad
    >>> shear = GridLoad(LinearForm(lambda v, w: v[1]),
    ...                  facets=lambda x: x[0] == 1.)
    """
    form: object
    fields: Optional[dict] = None
    facets: object = None


def grid_load_basis(mesh, elem, facets):
    """The basis a :class:`GridLoad` is assembled on: the grid's cells
    (``facets`` ``None``) or the facets ``facets`` selects, refused where
    it selects none or is not a selection of facets."""
    from skfem import Basis, FacetBasis
    if facets is None:
        return Basis(mesh, elem)
    try:
        basis = FacetBasis(mesh, elem, facets=facets)
    except (ValueError, TypeError, IndexError, KeyError) as err:
        raise InvalidInputError(
            "GridLoad: facets must select facets of the grid (indices, a "
            "boundary's name, a function of the facets' midpoints), got "
            "{!r}: {}: {}".format(facets, type(err).__name__, err)) from err
    if basis.find.size == 0:
        raise InvalidInputError(
            "GridLoad: facets {!r} select no facet of the grid".format(
                facets))
    return basis


class ExternalLoads:
    """All the loads of a run: ``external(op, points, factor)`` is the grid
    force vector at load factor ``factor``.

    Parameters
    ----------
    mesh, elem, grid
        The grid, its scalar element and vector grid basis.
    gravity
        Body force per unit initial volume, (dim,) or one row per body
        (bodies, dim), or ``None``.
    loads
        :class:`Traction`, :class:`Pressure` and :class:`GridLoad` items.
    domain0
        Initial domain half-lengths of the points (surface loads).
    counters
        The run's counters (``body_force`` counts body-force assemblies).
    n_points
        Number of points (checks the surface loads' indices).
    follow
        Pressures follow the surface (finite deformation): ``follows`` is
        then true when there is a pressure, and the run's
        :class:`FollowerPressure` term adds :meth:`follower_force` at
        every iteration's trial deformation.
    moves
        The points move (not finite elements): surface loads act at the
        faces' current centres, otherwise at their reference ones.
    ramp_gravity
        Per body (or one for all): the body force grows with the load
        factor (default), or (``False``) acts in full from the first step
        (a geostatic initial stress balances it).
    weights
        ``weights(x, idx, axis, sign) -> operator``: the method's own
        weights of grid nodes on the faces normal to ``axis`` on the side
        ``sign`` (+1 or -1) of points ``idx``, whose material's centres are
        ``x`` (dim, m), for surface loads, where the method's displacement
        field is not the grid element's (B-spline MPM: at ``x``) or the
        points' domains reach past their cells (GIMP: the faces of the
        domains); ``None``: the grid element's shape functions in the
        points' cells (standard MPM).
    kernels
        The run's ``kernels`` option (:class:`~skfem_mpm.solve.options.
        Options`): whether the faces' material-point basis takes compiled
        passes (:func:`~skfem_mpm.quadrature.basis.compiled_kernels`).

    """

    def __init__(self, mesh, elem, grid, gravity, loads, domain0, counters,
                 n_points: int, follow: bool = False, moves: bool = True,
                 ramp_gravity=True, weights=None, kernels: str = "auto"):
        self.mesh, self.elem, self.dim = mesh, elem, mesh.dim()
        self.weights, self.kernels = weights, check_kernels(kernels)
        self.ramp_gravity = np.atleast_1d(np.asarray(ramp_gravity, bool))
        self.gravity, self.counters, self.domain0 = gravity, counters, domain0
        self.surface, self.grid_vector, self.cell_local = [], None, None
        self.cell_clip = None
        self.surface_ramp = []       # per surface load: grows with factor
        self.surface_sides = []      # per surface load: its side, as named
        self._faces = (None, [])
        self.grid, self.doflocs = grid, None
        for load in loads:
            if isinstance(load, (Traction, Pressure)):
                self.surface.append(self._surface(load, n_points))
                self.surface_ramp.append(check_load_ramp(load))
                self.surface_sides.append(load.side)
                if self.cell_local is None:
                    self.cell_local = cell_coordinates(mesh, clip=False)
            elif isinstance(load, GridLoad):
                from skfem import asm
                basis = grid_load_basis(mesh, grid.elem, load.facets)
                try:
                    f = asm(load.form, basis, **(load.fields or {}))
                except (ValueError, TypeError, IndexError) as err:
                    raise InvalidInputError(
                        "GridLoad: the form does not assemble on the grid's "
                        "vector basis ({} components per node; a load on "
                        "displacements returns e.g. dot(f, v) or v[1], not "
                        "a scalar v): {}: {}".format(
                            self.dim, type(err).__name__, err)) from err
                check_finite("GridLoad", f)
                self.grid_vector = f if self.grid_vector is None \
                    else self.grid_vector + f
            else:
                raise InvalidInputError(
                    "loads must be Traction, Pressure, GridLoad, Prescribed, "
                    "RigidBody or GridTerm items, got {}".format(
                        type(load).__name__))
        self.moves, self.finite = moves, follow
        self.follows = follow and any(item[-1] for item in self.surface)

    def _surface(self, load, n_points: int):
        axis, sign = side_axis(load.side, self.dim)
        if self.domain0 is None:
            raise InvalidInputError(
                "{} needs point domains (MaterialPoints.domain): "
                "half-lengths per axis, shape (dim, n), set by seed_points; "
                "for points of one's own np.tile(volume ** (1 / dim) / 2, "
                "(dim, 1)) (square domains)".format(type(load).__name__))
        name = type(load).__name__
        raw = np.asarray(load.points)
        if raw.dtype.kind not in "iu":
            raise InvalidInputError("{}.points must be integer indices (e.g. "
                                    "from side_points), got dtype {}".format(
                                        name, raw.dtype))
        idx = raw.astype(np.int64).ravel()
        if idx.size == 0 or idx.min() < 0 or idx.max() >= n_points:
            raise InvalidInputError(
                "{}.points must be indices of points in [0, {}), got {}"
                .format(type(load).__name__, n_points, idx[:5].tolist()))
        field, shape = ("traction", (self.dim,)) if isinstance(
            load, Traction) else ("pressure", ())
        try:
            value = np.asarray(getattr(load, field), dtype=np.float64)
        except (TypeError, ValueError):
            value = None
        if value is None or value.shape != shape:
            raise InvalidInputError(
                "{}.{} must be {}, got {!r}".format(
                    name, field, "one number" if not shape else
                    "{} numbers".format(self.dim), getattr(load, field)))
        check_finite(type(load).__name__, value)
        return idx, axis, sign, value, isinstance(load, Pressure)

    def external(self, op, points: MaterialPoints, factor: float) -> ndarray:
        """Grid force vector of the loads that do not depend on the step's
        displacement, at load factor ``factor`` (once per step; the
        pressures that follow the surface are :meth:`follower_force`)."""
        f = np.zeros(op.N)
        load = points.force if points.force.any() else None
        scaled = None if load is None else factor * load
        if self.gravity is not None:
            self.counters["body_force"] += 1
            weight = (self.gravity[:, None] if self.gravity.ndim == 1
                      else self.gravity[points.body].T) * points.volume0
            load = weight if load is None else load + weight
            ramp = self.ramp_gravity
            # one ramp for all: the same products by a number (no mask)
            weight = weight * (np.where(ramp[points.body], factor, 1.)
                               if ramp.size > 1 else
                               factor if ramp[0] else 1.)
            scaled = weight if scaled is None else scaled + weight
        if scaled is not None:
            f += op.point_force(scaled)
        for face, (idx, axis, sign, value, pressure), ramp in zip(
                self._faces_of(op, points), self.surface, self.surface_ramp):
            scale = factor if ramp else 1.
            if not pressure:
                f += scale * face.point_force(value[:, None] * face.area)[
                    :op.N]
            elif not self.follows:
                f += scale * self._pressure(face, points.F[:, :, idx], axis,
                                            sign, value, op.N)
        if self.grid_vector is not None:
            self._check_supported(op)
            f += factor * self.grid_vector
        self._check_representable(f, load, factor)
        return f

    @property
    def all_ramped(self) -> bool:
        """Whether every load grows with the load factor from nothing (no
        body force, traction or pressure in full from the first step)."""
        return bool((self.gravity is None or self.ramp_gravity.all())
                    and all(self.surface_ramp))

    def proportional(self, points: MaterialPoints) -> bool:
        """Whether :meth:`external` from the state ``points`` is one
        vector scaled by a number at every load factor: every load grows
        with the load factor, or every load acts in full from the first
        step (a body force, tractions, pressures: then a shorter step
        bears all of it).  Loads that follow the surface are left to
        their term, but their share in full or ramped counts."""
        ramps = list(self.surface_ramp)
        if self.gravity is not None:
            ramps += self.ramp_gravity.tolist()
        if all(ramps):
            return True
        return not (any(ramps) or self.grid_vector is not None
                    or points.force.any())

    def _check_representable(self, f: ndarray, load, factor: float):
        """Loads whose grid forces underflow to zero or to subnormal numbers
        would let a zero solution pass the relative equilibrium check
        (nothing happening is not a result): refused, with the units'
        rescaling as the cure."""
        largest = np.abs(f).max(initial=0.)
        if largest >= np.finfo(float).tiny:
            return
        given = (load is not None and load.any()) or any(
            value.any() and not (pressure and self.follows)
            for _, _, _, value, pressure in self.surface) or (
            self.grid_vector is not None and self.grid_vector.any())
        if not given or factor == 0.:
            return
        raise InvalidInputError(
            "the loads {} on the grid (largest force {:.1e} at load factor "
            "{:.3g}, below the smallest normal number {:.1e}): their "
            "equilibrium cannot be measured; rescale the units (e.g. kN, "
            "MPa, mm)".format("vanish" if largest == 0. else
                              "are subnormal", largest, factor,
                              np.finfo(float).tiny))

    def follower_force(self, op, points: MaterialPoints, factor: float,
                       deformation) -> ndarray:
        """Grid force vector of the pressures that follow the surface, on
        the trial deformation: ``deformation(idx)`` is the deformation
        gradient (3, 3, m) of points ``idx`` (every iteration)."""
        f = np.zeros(op.N)
        for face, (idx, axis, sign, value, pressure), ramp in zip(
                self._faces_of(op, points), self.surface, self.surface_ramp):
            if pressure:
                f += (factor if ramp else 1.) * self._pressure(
                    face, deformation(idx), axis, sign, value, op.N)
        return f

    def surface_resultants(self, points: MaterialPoints, factor: float,
                           bodies: int) -> ndarray:
        """Per body (bodies, dim), the resultant of the surface loads at
        load factor ``factor``: tractions on their faces' initial areas,
        pressures on the faces the points' deformation gradients give
        (Nanson's formula, as :meth:`_pressure`), whether they follow the
        surface or not."""
        out = np.zeros((bodies, self.dim))
        for (idx, axis, sign, value, pressure), ramp in zip(
                self.surface, self.surface_ramp):
            area = points.volume0[idx] / (2 * self.domain0[axis, idx])
            if pressure:
                F_inv, J = inverse_and_det(points.F[:, :, idx], self.dim)
                force = -value * sign * J * F_inv[axis, :self.dim] * area
            else:
                force = value[:, None] * area
            out += (factor if ramp else 1.) * np.stack(
                [np.bincount(points.body[idx], row, bodies)
                 for row in force], axis=1)
        return out

    def held_shares(self, op, points: MaterialPoints,
                    held: ndarray) -> list:
        """Per surface load, ``(moved, dofs, support, on)``: ``moved`` the
        share of its force (projected on its resultant) that its faces'
        weights put on the ``held`` DOFs ``dofs`` of nodes across the
        body (behind its faces by more than the points' width along the
        side's axis) beyond what the same faces put there at their
        reference positions (``x0 + d0``; the points' quadrature matches
        those: a traction's share on a held base next to it, or the
        splines' reach through a body thinner than they are, is the
        method's own and not missed); ``support`` the share on all held
        DOFs ``on`` by the grid element's shape functions at the faces'
        centres, in their points' cells (one measure for every method:
        B-splines' and GIMP's weights reach held nodes through the body,
        as the points' own do).  The moved share goes straight into the
        supports' reactions and the material's stress misses it: a
        one-cell square in small strain with cpGIMP, pressed to 400 on
        two sides against rollers on the others, reached 390.15 (its
        points moved, their domains' faces with them, 2.5% into the cell,
        whose far nodes are the rollers'; standard MPM's faces stay at
        the reference).  Pressures on the start-of-step deformation."""
        shares = []
        N, dim = op.N, self.dim
        if self.doflocs is None:
            self.doflocs = self.grid.doflocs
        n = min(N, self.doflocs.shape[1])
        mask = np.zeros(n, dtype=bool)
        held = np.asarray(held, dtype=np.int64)
        mask[held[held < n]] = True
        moving = self.moves and not self.finite
        for face, (idx, axis, sign, value, pressure) in zip(
                self._faces_of(op, points), self.surface):
            if pressure:
                F_inv, J = inverse_and_det(points.F[:, :, idx], self.dim)
                load = -value * sign * J * F_inv[axis, :self.dim] * face.area
            else:
                load = value[:, None] * face.area
            f = face.point_force(load)[:N][:n]
            resultant = f[:n - n % dim].reshape(-1, dim).sum(axis=0)
            size = resultant @ resultant
            if self.cell_clip is None:
                self.cell_clip = cell_coordinates(self.mesh)
            cells = op.point_elements[idx]
            on_grid = PointOperator(MaterialPointBasis(
                self.mesh, self.elem, MaterialPoints(
                    x=face.centre, volume=face.area),
                (cells, self.cell_clip(face.centre, cells)),
                kernels=self.kernels)).point_force(load)[:N][:n]
            on = np.flatnonzero(mask & (on_grid != 0.))
            if size == 0.:
                shares.append((0., on[:0], 0., on))
                continue
            support = float(on_grid[on] @ resultant[on % dim] / size)
            dofs, moved = on[:0], 0.
            if moving:
                still = self._reference_face(op, points, idx, axis, sign
                                             ).point_force(load)[:N][:n]
                plane = np.median(face.centre[axis])
                depth = 2 * np.abs(face.offset[axis]).max()
                across = mask & (sign * (self.doflocs[axis, :n] - plane)
                                 < -depth)
                dofs = np.flatnonzero(across & ((f != 0.) | (still != 0.)))
                moved = float((f - still)[dofs] @ resultant[dofs % dim]
                              / size)
            shares.append((moved, dofs, support, on))
        return shares

    def _reference_face(self, op, points, idx, axis, sign):
        """The faces of points ``idx`` at their reference positions
        (``x0 + d0`` along the side's axis, ``x0`` across it) in the
        method's weights (GIMP: the faces of the initial domains)."""
        d0 = self.domain0[axis, idx]
        centre = points.x0[:, idx].copy()
        centre[axis] += sign * d0
        owner = getattr(self.weights, "__self__", None)
        if self.weights is None:
            cells = op.point_elements[idx]
            return PointOperator(MaterialPointBasis(
                self.mesh, self.elem, MaterialPoints(x=centre, volume=d0),
                (cells, self.cell_local(centre, cells)),
                kernels=self.kernels))
        if hasattr(owner, "gimp"):
            box = self.domain0[:, idx].copy()
            box[axis] = 0.
            face = owner.gimp(centre, box)
        else:
            face = self.weights(centre, idx, axis, sign)
        face.S = supported_share(face.S, op.active_dofs[::self.dim]
                                 // self.dim)
        return face

    def check_held_share(self, op, points: MaterialPoints, held: ndarray,
                         step: int, warned: set) -> None:
        """Warn (once a run per side; ``warned`` keeps the sides said) of
        a surface load with more than :data:`ON_SUPPORT` of its force on
        held DOFs (a load on a support: it goes into the reactions and
        does nothing to the body), and, in small strain where the points
        (and GIMP's and B-splines' faces) move and their volumes do not,
        of one whose faces moved more than :data:`HELD_SHARE` of its
        force onto held DOFs across the body (:meth:`held_shares`),
        naming the load, the share and the cures.  In finite deformation
        such a share is the force's point of application kept (a face
        past its cell: negative there; a face moved into it: the volume
        shrank with it) and the stress is exact."""
        if not self.surface:
            return
        for k, (moved, dofs, support, on) in enumerate(
                self.held_shares(op, points, held)):
            idx, axis, sign = self.surface[k][:3]
            kind = "pressure" if self.surface[k][4] else "traction"
            side = self.surface_sides[k]
            if support > ON_SUPPORT + 1e-9 and ("on_support", axis, sign) \
                    not in warned:
                warned.add(("on_support", axis, sign))
                logger.warning(
                    "step %d: the %s on side %r (of %d points) puts %.1f%% "
                    "of its force on held DOFs (%d, e.g. at %s; by the grid "
                    "element's shape functions at its faces): a load on a "
                    "support goes into the reactions and does nothing to "
                    "the body; load a free side, or release the support "
                    "there", step, kind, side, idx.size, 100 * support,
                    on.size, np.round(self.doflocs[:, on[0]], 6).tolist())
            if moved <= HELD_SHARE or ("held_share", axis, sign) in warned:
                continue
            warned.add(("held_share", axis, sign))
            logger.warning(
                "step %d: the %s on side %r (of %d points) has moved %.1f%% "
                "of its force onto held DOFs across the body (%d, e.g. at "
                "%s) since its faces' reference positions: that share goes "
                "straight into the supports' reactions and the material's "
                "stress misses it (small strain moves the points and their "
                "faces into the cells whose far nodes are held, and keeps "
                "their volumes: a body one cell across).  Take "
                "kinematics='finite' (faces and volumes move together: "
                "exact), method='mpm' (its faces stay at the reference), "
                "or prescribe the face's motion instead; more cells across "
                "move the shortfall into the stress field, they do not "
                "remove it (docs/robustness.md)",
                step, kind, side, idx.size, 100 * moved, dofs.size,
                np.round(self.doflocs[:, dofs[0]], 6).tolist())

    def _pressure(self, face, F, axis, sign, value, N) -> ndarray:
        """``-p J F^-T N A0`` (Nanson's formula) on the faces."""
        F_inv, J = inverse_and_det(F, self.dim)
        return face.point_force(-value * sign * J * F_inv[axis, :self.dim]
                                * face.area)[:N]

    def _faces_of(self, op, points) -> list:
        """The face operators of the surface loads, built once per step
        (per position of the points: once for a run whose points do not
        move)."""
        if self._faces[0] is not points.x:
            self._faces = (points.x, [self._face_operator(op, points, *item)
                                      for item in self.surface])
        return self._faces[1]

    def _check_supported(self, op):
        """A grid load on nodes no point supports in this step would be
        lost (those DOFs have no stiffness): refused, naming the nodes."""
        off = np.ones(op.N, dtype=bool)
        off[op.active_dofs] = False
        lost = np.flatnonzero(off[:self.grid_vector.size]
                              & (self.grid_vector != 0.))
        if lost.size:
            nodes = np.unique(lost // self.dim)
            if self.doflocs is None:
                self.doflocs = self.grid.doflocs
            raise InvalidInputError(
                "a GridLoad acts on {} grid node(s) that no material point "
                "supports in this step, e.g. at {}: its force there would be "
                "lost; restrict the form to the body".format(
                    nodes.size, self.doflocs[:, lost[:3]].T.tolist()))

    def _face_operator(self, op, points, idx, axis, sign, value, pressure):
        """The faces of points ``idx`` as a point operator at the faces'
        centres (the method's weights there: B-splines', GIMP's of the
        domains' faces; or standard MPM's, the grid element's in the
        cells holding the points, extrapolated past them), with the
        faces' initial areas as ``area``: at the start of the step
        ``x + F d0 N`` when the points move, in the reference
        configuration ``X + d0 N`` when they do not (finite elements,
        total Lagrangian); standard MPM in small strain along the axis
        at the reference (:meth:`_reference_faces`)."""
        d0 = self.domain0[axis, idx]
        area = points.volume0[idx] / (2 * d0)              # initial area
        if self.moves:
            offset = points.F[:self.dim, axis, idx] * d0
        else:
            offset = np.zeros((self.dim, idx.size))
            offset[axis] = d0
        centre = points.x[:, idx] + sign * offset
        if self.weights is not None:     # the method's field, not the grid's
            face = self.weights(centre, idx, axis, sign)
            face.S = supported_share(face.S, op.active_dofs[::self.dim]
                                     // self.dim)
            face.area, face.centre, face.offset = area, centre, offset
            return face
        cells = op.point_elements[idx]
        local = self.cell_local(centre, cells)
        if self.moves and not self.finite:
            centre, local = self._reference_faces(points, idx, axis, sign,
                                                  centre, local, cells)
        if self.weights is not None:     # the method's field, not the grid's
            face = self.weights(centre, idx, axis, sign)
            face.S = supported_share(face.S, op.active_dofs[::self.dim]
                                     // self.dim)
            face.area, face.centre, face.offset = area, centre, offset
            return face
        face = PointOperator(MaterialPointBasis(
            self.mesh, self.elem, MaterialPoints(x=centre, volume=area),
            (cells, local), kernels=self.kernels))
        face.area, face.centre, face.offset = area, centre, offset
        return face

    def _reference_faces(self, points, idx, axis, sign, centre, local,
                         cells):
        """Standard MPM in small strain: the faces along their axis where
        they were in the reference configuration (``x0 + d0``), across it
        where their points are, in the cells of the points.  The grid
        element's derivative along an axis does not depend on the
        position along it, so the points' internal force in a cell is
        that of their reference positions along the axis (their volumes
        kept), and a face moved with its point put ``u / h`` of its force
        on the grid line below: an oedometer's top cell under 100 carried
        -98.61 after two steps, -97.58 after eight.  A face whose
        reference position lies further outside its point's cell than
        its current one (a body moved across cells) keeps the current
        one."""
        moved = centre.copy()
        moved[axis] = points.x0[axis, idx] + sign * self.domain0[axis, idx]
        there = self.cell_local(moved, cells)
        keep = outside(there) <= outside(local) + 1e-9
        centre = np.where(keep, moved, centre)
        local = np.where(keep, there, local)
        return centre, local


def outside(local: ndarray) -> ndarray:
    """How far local coordinates (dim, n) lie outside the unit cell."""
    return np.maximum(-local, local - 1.).max(axis=0).clip(0.)


class FollowerPressure(GridTerm):
    """The pressures that follow the surface (finite deformation) as a
    grid term: their load on each trial's deformation
    (:meth:`ExternalLoads.follower_force`; its derivative is left out of
    the tangent)."""

    def __init__(self, loads: ExternalLoads):
        self.loads = loads

    def begin_step(self, problem):
        self.op, self.points = problem.op, problem.points
        return self

    def load(self, response, scale: float) -> ndarray:
        return self.loads.follower_force(self.op, self.points, scale,
                                         response.deformation)
