"""Scenes: what is in a simulation, and only the effects it calls for.

A :class:`Scene` names a background grid, bodies of material points with
their materials, supports, loads and the method.  :func:`run_scene` builds
the solver from exactly those parts: no body-force assembly without
gravity, one linear solve per step (no Newton loop; another where
round-off leaves the residual above the tolerance) for small-strain
elasticity, no return map for elastic bodies, no point relocation in FE
mode, no domain update for standard MPM.

"""
import logging
from dataclasses import dataclass, field
from typing import (TYPE_CHECKING, Callable, List, Optional, Sequence, Tuple,
                    Union)

import numpy as np
from numpy import ndarray
from skfem import ElementHex1, ElementLineP1, ElementQuad1, ElementQuad2, \
    MeshHex, MeshLine, MeshQuad

from ..errors import InvalidInputError, check_choice
from ..kernels import check_kernels
from ..mechanics.geostatic import k0_state
from ..mechanics.kinematics import KINEMATICS
from ..mechanics.materials import is_plastic
from ..memory import (GRID_BYTES_PER_CELL, RUN_BYTES_PER_POINT,
                      SEED_BYTES_PER_POINT, STEP_RECORD_BYTES,
                      refuse_beyond_memory)
from ..methods.method import METHODS
from ..quadrature.points import (MaterialPoints, box_region,
                                  concatenate_points, in_box, seed_points)
from ..solve.core import (cell_size, check_combination, contact_named,
                          grid_parts, simulate)
from ..solve.dynamics import Dynamics, GeneralizedAlpha, Newmark
from ..solve.loads import (Pressure, Traction as SurfaceTraction,
                           in_full_words, side_axis, side_points)
from ..solve.newton import NewtonOptions
from ..solve.options import BodyForce, Options, Prescribed, Resume
from ..solve.results import Result
from ..solve.body_contact import Contact, check_contacts
from ..solve.obstacles import Obstacle
from ..solve.rigid import RigidBody, beyond_cell_words
from ..stabilisation.settings import Stabilisation
from .footing import check_footing_scene
from .regions import Ball, Polygon, bounding_box, check_shape, closed_region
from .units import check_units, unit

logger = logging.getLogger(__name__)

if TYPE_CHECKING:         # quantities.py imports this module
    from .quantities import Quantity

__all__ = ["Grid", "Body", "Support", "PointLoad", "Traction", "Scene",
           "TimeIntegration",
           "build_points", "surface_loads", "support_names", "scene_support_dofs",
           "reaction_resultants",
           "run_scene", "point_bound", "METHODS", "KINEMATICS"]

AXES = "xyz"
#: time-integration schemes of a scene's dynamics (``[dynamics] scheme``)
SCHEMES = ("auto", "newmark", "generalized_alpha")


@dataclass
class Grid:
    """An axis-aligned background grid: ``axes[d] = (lo, hi, cells)``.

    ``element`` is ``"Q1"`` (line, quadrilateral or hexahedron by
    dimension) or ``"Q2"`` (2D).  A ready scikit-fem ``mesh`` and ``elem``
    may be given instead (Python API only).
    """
    axes: Sequence[Tuple[float, float, int]] = ()
    element: str = "Q1"
    mesh: object = None
    elem: object = None

    @property
    def dim(self) -> int:
        """Space dimension."""
        return self.mesh.dim() if self.mesh is not None else len(self.axes)

    @property
    def cells(self) -> float:
        """Number of cells."""
        if self.mesh is not None:
            return float(self.mesh.nelements)
        return float(np.prod([float(n) for _, _, n in self.axes]))

    def build(self):
        if self.mesh is not None:
            return self.mesh, self.elem
        nodes = [np.linspace(lo, hi, int(n) + 1) for lo, hi, n in self.axes]
        dim = len(nodes)
        mesh = {1: lambda: MeshLine(nodes[0]),
                2: lambda: MeshQuad.init_tensor(*nodes),
                3: lambda: MeshHex.init_tensor(*nodes)}[dim]()
        if self.element == "Q2" and dim == 2:
            return mesh, ElementQuad2()
        return mesh, {1: ElementLineP1, 2: ElementQuad1,
                      3: ElementHex1}[dim]()


@dataclass
class Body:
    """Material points filling ``region`` (``[(lo, hi), ...]`` per axis, a
    :class:`~skfem_mpm.scenes.regions.Polygon` (2D), a
    :class:`~skfem_mpm.scenes.regions.Ball` (a disc in 2D) or another
    callable on coordinates), ``points_per_cell`` per axis.  With ``K0``
    the body starts from the geostatic stress of the scene's gravity, and
    the gravity then acts on it in full from the first step
    (:func:`~skfem_mpm.mechanics.geostatic.geostatic_stress`): by default
    it carries the weight of the bodies with ``K0`` above it (horizontal
    layers; others are refused), the uppermost under the top of its
    material (its points' domains); a ``surface`` (ground height) starts
    the body alone from it, its own weight up to there.  With
    ``rigid`` (its displacement at full load, ramped over the steps) the
    body is a rigid body pushed through the grid, ``rough`` or smooth
    (:class:`~skfem_mpm.RigidBody`): a footing, a pile, an indenter.
    ``density`` (mass per unit initial volume) and ``initial_velocity``
    are for scenes with :attr:`Scene.dynamics`.  Regions of two bodies
    may not overlap (each is seeded in full: the overlap would carry both
    bodies' mass and stiffness), unless one ``replaces`` the other (the
    names of the bodies whose points inside this body's region are not
    seeded: a pile in the soil)."""
    name: str
    region: Union[Sequence[Tuple[float, float]], Callable]
    material: object
    points_per_cell: int = 2
    K0: Optional[float] = None
    surface: Optional[float] = None
    rigid: Optional[Sequence[float]] = None
    rough: bool = True
    density: Optional[float] = None
    initial_velocity: Optional[Sequence[float]] = None
    replaces: Sequence[str] = ()

    def contains(self, x: ndarray) -> ndarray:
        if callable(self.region):
            return np.asarray(self.region(x), dtype=bool)
        return in_box(x, self.region)


@dataclass
class Support:
    """Supported grid DOFs: on a named ``boundary`` of the grid (or a
    sequence of names: their union), at the grid node ``at``
    (coordinates), on the nodes in the closed box ``region`` (``[(lo,
    hi)]`` per axis; ``lo = hi``: a grid line) or in a
    :class:`~skfem_mpm.scenes.regions.Polygon` or
    :class:`~skfem_mpm.scenes.regions.Ball` ``region``, sides included,
    or on the nodes where ``where(x)`` holds;
    ``components`` among ``"x", "y", "z"``; ``value`` (one per component)
    the displacement reached at full load, ramped over the steps (default:
    fixed).  ``name`` labels its reaction forces in ``summary.json``
    (default ``support-N``, N counting from 1).  ``bodies``, with a
    ``value`` in a scene with contacts: the names of the bodies whose
    grid field it moves (:class:`~skfem_mpm.Prescribed`'s ``bodies``;
    every moving support names the same)."""
    boundary: Union[None, str, Sequence[str]] = None
    where: Optional[Callable] = None
    components: Sequence[str] = ("x", "y", "z")
    at: Optional[Sequence[float]] = None
    value: Optional[Sequence[float]] = None
    name: Optional[str] = None
    region: Union[None, Sequence[Sequence[float]], Polygon, Ball] = None
    bodies: Optional[Sequence[str]] = None


@dataclass
class PointLoad:
    """A force shared by the ``count`` points nearest ``at`` (initially),
    or by the points where ``where(x)`` holds."""
    at: Optional[Sequence[float]] = None
    force: Sequence[float] = ()
    count: int = 1
    where: Optional[Callable] = None


@dataclass
class Traction:
    """A traction (force per initial area, fixed direction) or a
    ``pressure`` (positive pushes in; follows the surface in finite
    deformation) on one ``side`` of a body: the faces of its outermost
    layer of points there (:class:`skfem_mpm.Traction`,
    :class:`skfem_mpm.Pressure`).  Give exactly one of ``traction`` and
    ``pressure``; ``ramp``: it grows with the load factor (default) or
    (``False``) acts in full from the first step (a confining pressure
    the body's initial stress balances)."""
    body: str
    side: str
    traction: Optional[Sequence[float]] = None
    pressure: Optional[float] = None
    ramp: bool = True


@dataclass
class TimeIntegration:
    """A scene's implicit dynamics (:class:`~skfem_mpm.Dynamics`, the
    densities from its bodies): ``scheme`` ``"auto"`` (Newmark's average
    acceleration, with obstacles or contacts the generalised-alpha scheme
    with ``rho_inf = 0``: :func:`~skfem_mpm.solve.dynamics.scheme_for`),
    ``"newmark"`` (``beta``, ``gamma``) or ``"generalized_alpha"``
    (``rho_inf``); ``load_ramp``: the
    time over which loads and prescribed motion rise linearly to full
    (0: in full from the start); ``target_iterations``: the adaptive time
    step's Newton effort (``None``: fixed steps)."""
    time_step: float
    duration: float
    scheme: str = "auto"
    beta: float = .25
    gamma: float = .5
    rho_inf: float = .8
    mass: str = "lumped"
    flip: float = .95
    load_ramp: float = 0.
    target_iterations: Optional[int] = None

    def dynamics(self, densities: Sequence[float]) -> Dynamics:
        check_choice("dynamics scheme", self.scheme, SCHEMES)
        for name, owner, default in (("beta", "newmark", .25),
                                     ("gamma", "newmark", .5),
                                     ("rho_inf", "generalized_alpha", .8)):
            if self.scheme != owner and getattr(self, name) != default:
                raise InvalidInputError(
                    "dynamics {} = {!r} belongs to scheme {!r}, not {!r}: it "
                    "would be ignored (set scheme = {!r})".format(
                        name, getattr(self, name), owner, self.scheme,
                        owner))
        scheme = None if self.scheme == "auto" else Newmark(
            self.beta, self.gamma) if self.scheme == "newmark" \
            else GeneralizedAlpha(self.rho_inf)
        ramp = float(self.load_ramp)
        if not (np.isfinite(ramp) and ramp >= 0):
            raise InvalidInputError("dynamics load_ramp must be a time >= 0, "
                                    "got {!r}".format(self.load_ramp))
        return Dynamics(self.time_step, self.duration, list(densities),
                        scheme=scheme, mass=self.mass, flip=self.flip,
                        target_iterations=self.target_iterations,
                        load=None if ramp == 0 else
                        (lambda t: min(t / ramp, 1.)))


@dataclass
class Scene:
    """A whole simulation.

    Parameters
    ----------
    grid, bodies, supports
        Background grid, bodies, supports.
    gravity
        Body force per unit (initial) volume, ``None`` for none; ramped
        over the steps, or in full from the first step where a body starts
        from a geostatic stress (``Body.K0``).  The same for every body:
        bodies of different densities fall differently under it in
        dynamics (warned); give ``acceleration`` instead.
    point_loads, tractions
        Loads at full load factor, ramped over the steps (a traction or
        pressure with ``ramp=False``: in full from the first step).
    method
        ``"fem"`` (points fixed: finite elements with the points as
        quadrature), ``"mpm"``, ``"ugimp"``, ``"cpgimp"``, ``"bspline"``
        (quadratic B-splines), ``"bspline-gimp"`` (averaged over the
        points' domains), ``"bspline3"`` or ``"bspline3-gimp"`` (cubic).
    kinematics
        ``"small"`` (the seed's incremental small-strain scheme: one linear
        solve per step for elastic bodies, Newton for plastic ones) or
        ``"finite"`` (Newton per step).  Every method works with both.
    nsteps
        Load steps (default 1; :attr:`step_count` is the count a run
        takes); ``None`` with dynamics.
    newton
        :class:`~skfem_mpm.NewtonOptions`: tolerance, iterations, line
        search, full or modified Newton, ``rhs``, ``grow_back`` (scene
        keys ``solver.tolerance``, ``max_iterations``, ``line_search``,
        ``newton``, ``rhs``, ``grow_back``).
    stabilisation
        :class:`~skfem_mpm.Stabilisation`: ghost penalty, mean
        dilatation and extended B-splines (``solver.ghost``,
        ``solver.antilocking``, ``solver.extended_splines``).
    solver
        The linear solver: ``"scipy"``, ``"pypardiso"``, ``"pyamg"`` or
        ``"auto"`` (the default: the fastest installed for each system's
        size, :mod:`skfem_mpm.solve.backends`; scene key
        ``solver.linear``).
    kernels
        The per-point work of a Newton iteration (``Options.kernels``,
        :mod:`skfem_mpm.kernels`): ``"auto"`` (the default: the compiled
        passes where they serve the scene, the numpy path otherwise),
        ``"numpy"`` or ``"compiled"`` (a scene they cannot serve refused
        when its run is set up); scene key ``solver.kernels``.
    reference
        What the run's error is measured against: ``"column"`` (error
        measure (2.28) of Charlton 2018), ``"elastica"`` (end-loaded cantilever) or
        ``"bearing_capacity"`` (peak pressure of a footing, a rigid body
        or a box obstacle, on weightless soil against ``N_c c``,
        :mod:`skfem_mpm.studies.footing`).
    dynamics
        ``None`` (quasi-static load steps) or a :class:`TimeIntegration`:
        time steps with inertia; every body then needs a ``density``, and
        ``nsteps`` is not used (``None``).
    outputs
        Quantities of interest
        (:class:`~skfem_mpm.scenes.quantities.Quantity`): reported by a
        run, measured by a study.
    obstacles
        Rigid :class:`~skfem_mpm.Obstacle` s the material cannot enter
        (scene tables ``[[obstacles]]``).
    contacts
        :class:`~skfem_mpm.Contact` s between bodies, named by the bodies'
        names (scene tables ``[[contacts]]``).
    acceleration
        Gravitational acceleration instead of ``gravity``: each body's
        body force is its ``density`` times it (every body then needs a
        density, quasi-static scenes too; a rigid body without one is
        weightless).
    gravity_ramp
        ``True`` (the default): the gravity of the bodies without
        ``K0`` grows with the load factor, together with the other loads
        and an obstacle's, rigid body's or support's displacement (a
        footing pushed at step 1 into soil of 1/steps of its weight:
        warned); ``False``: in full from the first step, the first step
        carrying the whole weight (scene files: ``[gravity] ramp``).
    units
        The units system the scene's numbers are in, ``"SI"`` (the
        default) or ``"kN-m"`` (kN, kPa, kN/m^3, t): labels only, its
        output's (:mod:`~skfem_mpm.scenes.units`); nothing is converted.
    """
    grid: Grid
    bodies: List[Body]
    supports: List[Support] = field(default_factory=list)
    gravity: Optional[Sequence[float]] = None
    point_loads: List[PointLoad] = field(default_factory=list)
    tractions: List[Traction] = field(default_factory=list)
    method: str = "mpm"
    kinematics: str = "small"
    nsteps: Optional[int] = None
    newton: NewtonOptions = field(default_factory=NewtonOptions)
    stabilisation: Stabilisation = field(default_factory=Stabilisation)
    name: str = "scene"
    reference: Optional[str] = None
    solver: str = "auto"
    kernels: str = "auto"
    dynamics: Optional[TimeIntegration] = None
    outputs: List["Quantity"] = field(default_factory=list)
    obstacles: List[Obstacle] = field(default_factory=list)
    contacts: List[Contact] = field(default_factory=list)
    acceleration: Optional[Sequence[float]] = None
    units: str = "SI"
    gravity_ramp: bool = True

    def body_forces(self) -> Optional[ndarray]:
        """Each body's body force per unit initial volume (bodies, dim):
        :attr:`gravity` for every body, or the body's density times
        :attr:`acceleration`; ``None`` without either."""
        if self.acceleration is not None:
            # a rigid body without a density: driven, weightless
            return np.array([(b.density or 0.) * np.asarray(
                self.acceleration, float) for b in self.bodies])
        if self.gravity is None:
            return None
        return np.tile(np.asarray(self.gravity, float), (len(self.bodies), 1))

    @property
    def step_count(self) -> int:
        """The steps a run takes, ``nsteps`` (default 1), or ``duration /
        time_step`` with dynamics."""
        if self.dynamics is not None:
            return self.dynamics.dynamics([1.]).nsteps
        return 1 if self.nsteps is None else int(self.nsteps)

    def check(self):
        """Raise :class:`~skfem_mpm.errors.InvalidInputError` for
        combinations no solver offers."""
        check_choice("method", self.method, METHODS)
        check_choice("kinematics", self.kinematics, KINEMATICS)
        check_kernels(self.kernels)
        check_units(self.units)
        for name, kind in (("newton", NewtonOptions),
                           ("stabilisation", Stabilisation)):
            if not isinstance(getattr(self, name), kind):
                raise InvalidInputError(
                    "Scene.{} must be a {}(...), got {!r}".format(
                        name, kind.__name__, getattr(self, name)))
        if not self.bodies:
            raise InvalidInputError("a scene needs at least one body")
        if self.acceleration is not None:
            if self.gravity is not None:
                raise InvalidInputError(
                    "gravity is a body force per unit volume or an "
                    "acceleration (times each body's density), not both")
            try:
                g = np.asarray(self.acceleration, dtype=float)
            except (TypeError, ValueError):
                g = None
            if g is None or g.shape != (self.grid.dim,) or \
                    not np.isfinite(g).all():
                raise InvalidInputError(
                    "acceleration must be {} finite numbers, got {!r}".format(
                        self.grid.dim, self.acceleration))
            unweighed = [b.name for b in self.bodies
                         if b.density is None and b.rigid is None]
            if unweighed:
                raise InvalidInputError(
                    "a gravitational acceleration needs a density on every "
                    "body that is not rigid; {} have none".format(unweighed))
            bad = [(b.name, b.density) for b in self.bodies
                   if b.density is not None and not (
                       isinstance(b.density, (int, float, np.integer,
                                              np.floating))
                       and 0 < b.density < np.inf)]
            if bad:
                raise InvalidInputError(
                    "densities must be finite and positive, got {}".format(
                        bad))
        moving = [b.name for b in self.bodies if b.initial_velocity is not None
                  or b.density is not None and self.acceleration is None]
        if self.dynamics is None and moving:
            raise InvalidInputError(
                "bodies {} have a density or initial velocity but the scene "
                "is quasi-static (no dynamics) and its gravity no "
                "acceleration: they would be ignored".format(moving))
        if self.dynamics is not None:
            massless = [b.name for b in self.bodies if b.density is None]
            if massless:
                raise InvalidInputError(
                    "dynamics needs a density on every body; {} have "
                    "none".format(massless))
            if self.nsteps is not None:
                raise InvalidInputError(
                    "a dynamic scene takes its steps from the time step "
                    "(duration / time_step); steps = {} would be ignored"
                    .format(self.nsteps))
        bodies = [b.name for b in self.bodies]
        if len(set(bodies)) < len(bodies):
            raise InvalidInputError("body names must differ, got {}".format(
                bodies))
        for b in self.bodies:
            if isinstance(b.replaces, str) or any(
                    name not in bodies or name == b.name
                    for name in b.replaces):
                raise InvalidInputError(
                    "body {!r}: replaces must list other bodies' names "
                    "(of {}), got {!r}".format(b.name, bodies, b.replaces))
        rigid = [b.name for b in self.bodies if b.rigid is not None]
        if rigid and self.method not in ("mpm", "fem"):
            raise InvalidInputError(
                "rigid bodies ({}) need method 'mpm' or 'fem', not {!r}: {} "
                "nodes of the cells beside its own, which the rigid "
                "body does not drive".format(
                    ", ".join(rigid), self.method,
                    beyond_cell_words(self.method)))
        if rigid and len(rigid) == len(self.bodies):
            raise InvalidInputError("every body is rigid: nothing deforms")
        moving = any(s.value is not None for s in self.supports)
        check_combination(
            self.method, self.kinematics, any(is_plastic(b.material)
                                              for b in self.bodies),
            self.newton, self.stabilisation, None if self.dynamics is None
            else self.dynamics.dynamics([b.density for b in self.bodies]),
            full_body_force=self.body_forces() is not None and (any(
                b.K0 is not None for b in self.bodies)
                or not self.gravity_ramp) or in_full_words(
                    [t.traction is None for t in self.tractions
                     if not t.ramp]),
            driven=bool(rigid) or moving,
            contact=contact_named(self.obstacles, self.contacts))
        check_contacts(self.contacts, len(self.bodies),
                       [b.name for b in self.bodies])
        if self.reference == "bearing_capacity":
            check_footing_scene(self)
        names = support_names(self)
        if len(set(names)) < len(names):
            raise InvalidInputError("support names must differ, got {}"
                                    .format(names))
        self.check_size()
        bodies = [b.name for b in self.bodies]
        for t in self.tractions:
            if t.body not in bodies:
                raise InvalidInputError(
                    "traction on unknown body {!r}".format(t.body))
            if (t.traction is None) == (t.pressure is None):
                raise InvalidInputError(
                    "a traction on body {!r} needs exactly one of traction "
                    "and pressure".format(t.body))


    def check_size(self):
        """Refuse a scene this machine's memory cannot hold: the grid, an
        upper bound of the points (every cell its bodies' boxes reach
        seeded) and the step history."""
        dim, cells = self.grid.dim, self.grid.cells
        points = point_bound(self)
        refuse_beyond_memory(
            "{:.3g} cells with up to {:.3g} points over {} steps".format(
                cells, points, self.step_count),
            cells * GRID_BYTES_PER_CELL[dim] + points * (
                SEED_BYTES_PER_POINT + RUN_BYTES_PER_POINT[dim])
            + float(self.step_count) * STEP_RECORD_BYTES,
            "use fewer cells, points per cell or steps")


def point_bound(scene: Scene) -> float:
    """An upper bound of the points the scene seeds, without seeding them:
    every cell a body's box (a polygon's or ball's bounding box) reaches
    (every cell for another callable region or a ready mesh) filled with
    its points per cell."""
    dim, cells = scene.grid.dim, scene.grid.cells
    points = 0.
    for body in scene.bodies:
        reached = cells
        box = bounding_box(body.region)
        if box is not None and scene.grid.mesh is None:
            reached = float(np.prod([
                min(n, np.ceil((min(hi, b_hi) - max(lo, b_lo))
                               / (hi - lo) * n) + 1)
                for (lo, hi, n), (b_lo, b_hi) in zip(scene.grid.axes,
                                                     box)]))
        points += max(reached, 0.) * float(body.points_per_cell) ** dim
    return points


def support_names(scene: Scene) -> List[str]:
    """The supports' names (``support-N`` where none is given)."""
    return [s.name or "support-{}".format(k + 1)
            for k, s in enumerate(scene.supports)]


def reaction_resultants(scene):
    """The names of the supports, the rigid bodies and the obstacles, and
    ``resultant(record) -> (supports + rigid bodies + obstacles, dim)``:
    per support, the resultant reaction force of a step (zero in
    unsupported components), then per rigid body the force that moves it
    (:attr:`~skfem_mpm.StepRecord.rigid_forces`), then per obstacle the
    force the material exerts on it
    (:attr:`~skfem_mpm.StepRecord.obstacle_forces`), then per contact
    between bodies the force of its first body on its second
    (:attr:`~skfem_mpm.StepRecord.contact_forces`).  A grid DOF held by
    several supports counts for one of them only, so that the resultants
    add up to the total reaction: a support that moves (a ``value``) if
    one holds it, since the DOF moves with it, else the last one listed (a
    later, more particular support refines an earlier one: a wall's corner
    node belongs to the wall listed after the base)."""
    mesh, elem = scene.grid.build()
    grid, dim = grid_parts(mesh, elem)[1], mesh.dim()
    held = [scene_support_dofs(s, grid, dim) for s in scene.supports]
    first = sorted(range(len(held)), key=lambda k: (
        scene.supports[k].value is None, -k))       # moving, then last
    claimed = np.zeros(grid.N, dtype=bool)
    mine = [None] * len(held)
    for k in first:
        mine[k] = ~claimed[held[k]]
        claimed[held[k]] = True
    parts = []
    for support, dofs, own in zip(scene.supports, held, mine):
        axes = [AXES.index(c) for c in support.components
                if AXES.index(c) < dim]
        parts.append((axes, dofs, own))

    def resultant(record) -> np.ndarray:
        reactions = record.reactions
        out = np.zeros((len(parts), dim))
        for k, (axes, dofs, first) in enumerate(parts):
            out[k, axes] = (reactions[dofs] * first).sum(axis=1)
        return np.vstack([out] + [f[None] for f in record.rigid_forces]
                         + ([] if record.obstacle_forces is None
                            else [record.obstacle_forces])
                         + ([] if record.contact_forces is None
                            else [record.contact_forces]))
    return support_names(scene) + [b.name for b in scene.bodies
                                   if b.rigid is not None] + [
        o.name for o in obstacle_list(scene)] + [
        c.name for c in scene.contacts], resultant


def scene_contacts(scene: Scene) -> list:
    """The scene's contacts with their bodies as indices (named
    ``<first>-<second>`` by the bodies' names where no name is given)."""
    names = [b.name for b in scene.bodies]
    return [Contact(names.index(c.first), names.index(c.second),
                    friction=c.friction, name=c.name, penalty=c.penalty,
                    tolerance=c.tolerance) for c in scene.contacts]


def obstacle_list(scene: Scene) -> list:
    """The scene's obstacles, named as a run names them
    (``obstacle<i>`` where a name is not given)."""
    return [o if o.name is not None else o.named("obstacle{}".format(i))
            for i, o in enumerate(scene.obstacles)]


def load_scale(scene: Scene, factors: ndarray) -> ndarray:
    """The loads' scale at the load factors ``factors``: the factor in
    quasi-static scenes, the dynamics' load ramp at ``factor * duration``
    in dynamic ones (what a rigid body's or an obstacle's displacement is
    multiplied by)."""
    if scene.dynamics is None:
        return np.asarray(factors, dtype=float)
    dynamics = scene.dynamics.dynamics([b.density for b in scene.bodies])
    return np.array([dynamics.scale(f * dynamics.duration)
                     for f in factors])


def build_points(scene: Scene, mesh) -> MaterialPoints:
    """Seed every body (``points.body`` = body index) and attach the point
    loads."""
    parts = []
    for k, body in enumerate(scene.bodies):
        try:
            # a box, polygon or ball is checked against the grid (refused
            # where it reaches outside: its points there would be dropped
            # without a word)
            check_shape(body.region, mesh)
            pts = seed_points(mesh, body.points_per_cell,
                              region=body_region(scene.bodies, k, mesh))
        except InvalidInputError as err:
            raise InvalidInputError("body {!r}: {}".format(body.name, err))
        pts.body[:] = k
        parts.append(pts)
    check_overlaps(scene.bodies, parts)
    # one body: its points as seeded (joining one copied 1e6 points)
    points = parts[0] if len(parts) == 1 else concatenate_points(parts)
    weights = scene.body_forces()
    geostatic = [k for k, b in enumerate(scene.bodies) if b.K0 is not None]
    if geostatic and weights is None:
        raise InvalidInputError("body {!r}: a geostatic stress (K0) needs "
                                "gravity".format(
                                    scene.bodies[geostatic[0]].name))
    if geostatic:                 # the layers together: each continues
        sel = np.flatnonzero(np.isin(points.body, geostatic))   # the above
        try:
            start = k0_state(
                MaterialPoints(x=points.x[:, sel], volume=points.volume[sel],
                               domain=points.domain[:, sel],
                               body=points.body[sel]),
                [b.material for b in scene.bodies[:max(geostatic) + 1]],
                weights,
                [b.surface for b in scene.bodies],
                [1. if b.K0 is None else b.K0 for b in scene.bodies])
        except InvalidInputError as err:
            raise InvalidInputError("geostatic start: {} (bodies {})".format(
                err, ", ".join("{} {!r}".format(k, scene.bodies[k].name)
                               for k in geostatic)))
        for name in ("stress", "strain", "be"):
            getattr(points, name)[..., sel] = getattr(start, name)
    for k, body in enumerate(scene.bodies):
        if body.initial_velocity is not None:
            v = np.asarray(body.initial_velocity, float)
            if v.shape != (points.dim,) or not np.isfinite(v).all():
                raise InvalidInputError(
                    "body {!r}: initial_velocity must be {} finite numbers, "
                    "got {!r}".format(body.name, points.dim,
                                      body.initial_velocity))
            if points.velocity is None:
                points.velocity = np.zeros_like(points.x)
            points.velocity[:, points.body == k] = v[:, None]
    for k, load in enumerate(scene.point_loads):
        if load.where is not None:
            chosen = np.flatnonzero(load.where(points.x))
            if chosen.size == 0:
                raise InvalidInputError("a point load selects no point")
        else:
            distance = np.linalg.norm(points.x - np.asarray(
                load.at, float)[:, None], axis=0)
            chosen = np.argsort(distance, kind="stable")[:load.count]
            check_point_load(k, load, mesh, points, chosen[0])
        points.force[:, chosen] += np.asarray(load.force, float)[:, None] \
            / chosen.size
    return points


def check_point_load(k: int, load: PointLoad, mesh,
                     points: MaterialPoints, nearest: int):
    """Refuse point load ``k`` (``point_loads[k]``) at a position outside
    the grid, or farther than the grid's widest cell from the nearest
    material point (``nearest``): the force would go to the nearest
    points, wherever they are (a load at x = 50 on a 12 m grid, and one
    4.5 m above the soil, were applied to the nearest points without a
    word; a user trial)."""
    at = np.asarray(load.at, float)
    low, high = mesh.p.min(axis=1), mesh.p.max(axis=1)
    tol = 1e-9 * (high - low)
    out = [d for d in range(at.size)
           if not low[d] - tol[d] <= at[d] <= high[d] + tol[d]]
    name = "point_loads[{}] at {}".format(k, at.tolist())
    if out:
        raise InvalidInputError(
            "{} lies outside the grid ({}): move the load onto the "
            "material or extend the grid".format(name, ", ".join(
                "{} from {:g} to {:g}".format("xyz"[d], low[d], high[d])
                for d in range(at.size))))
    corners = mesh.p[:, mesh.t]
    cell = float((corners.max(axis=1) - corners.min(axis=1)).max())
    gap = float(np.linalg.norm(points.x[:, nearest] - at))
    if gap > cell:
        raise InvalidInputError(
            "{} is {:.4g} from the nearest material point (point {} at {}), "
            "more than a cell ({:.4g}): its force would act there; move "
            "the load onto the material".format(
                name, gap, nearest,
                np.round(points.x[:, nearest], 6).tolist(), cell))


def body_region(bodies: Sequence[Body], k: int, mesh):
    """The region seeded for body ``k``: its own, less the regions of the
    bodies that replace it (:attr:`Body.replaces`)."""
    body = bodies[k]
    replacing = [b for b in bodies if body.name in b.replaces]
    if not replacing:
        return body.region
    own = body.region if callable(body.region) else box_region(
        mesh, body.region)          # (a box checked against the grid)
    return lambda x: np.asarray(own(x), dtype=bool) & ~np.any(
        [b.contains(x) for b in replacing], axis=0)


def check_overlaps(bodies: Sequence[Body], parts: list):
    """Refuse bodies whose seeded points ``parts`` lie in each other's
    regions, and a body left without points by those that replace it (a
    pile's region inside the soil's was seeded twice: its weight and
    stiffness counted twice without a word; a user trial)."""
    for i, first in enumerate(bodies):
        for j in range(i + 1, len(bodies)):
            second = bodies[j]
            # the points of one in the other's region, where it does not
            # replace the other
            inside = [0 if a.name in bodies[b].replaces else
                      int(np.count_nonzero(a.contains(parts[b].x)))
                      for a, b in ((first, j), (second, i))]
            if any(inside):
                raise InvalidInputError(
                    "bodies {!r} and {!r} overlap: {} points of {!r} lie in "
                    "the region of {!r} and {} of {!r} in that of {!r} "
                    "(each region is seeded in full: the overlap would "
                    "carry both bodies' mass and stiffness); let the inner "
                    "body replace the outer one (replaces = [{!r}]) or "
                    "separate the regions".format(
                        first.name, second.name, inside[0], second.name,
                        first.name, inside[1], first.name, second.name,
                        first.name if inside[0] >= inside[1]
                        else second.name))
    for body, part in zip(bodies, parts):
        replacing = [b.name for b in bodies if body.name in b.replaces]
        if part.n == 0 and replacing:
            raise InvalidInputError(
                "body {!r}: no point is left where {} replace it".format(
                    body.name, replacing))


def surface_loads(scene: Scene, points: MaterialPoints) -> list:
    """The scene's tractions and pressures as loads on the outermost layer
    of their body's points (``points``: the initial ones)."""
    loads = []
    names = [b.name for b in scene.bodies]
    for t in scene.tractions:
        layer = side_points(points, t.side,
                            points.body == names.index(t.body))
        loads.append(Pressure(layer, t.side, t.pressure, t.ramp)
                     if t.traction is None else
                     SurfaceTraction(layer, t.side, t.traction, t.ramp))
    return loads


def dof_places(basis, dim: int) -> ndarray:
    """The first component's DOF at each place of the vector ``basis``
    (the vertices, and with a higher-order element its edge, face and
    cell DOFs too): the other components' at a place follow it, ``dof +
    c`` (scikit-fem numbers a vector element's components together)."""
    component = np.zeros(basis.N, dtype=np.int64)
    for dofs in (basis.nodal_dofs, basis.facet_dofs, basis.edge_dofs,
                 basis.interior_dofs):
        for row in range(dofs.shape[0] if dofs.size else 0):
            component[dofs[row]] = row % dim
    return np.flatnonzero(component == 0)


def scene_support_dofs(s: Support, basis, dim: int) -> ndarray:
    """The DOFs of one support, (components, places): every DOF at a
    place it holds, the vertices' and (a higher-order element, ``Q2``)
    the edges', faces' and cells' (a ``Q2`` grid's supports held the
    vertices alone: a clamped cantilever sagged 13% too far, its
    reactions balanced)."""
    comps = [AXES.index(c) for c in s.components if AXES.index(c) < dim]
    first = dof_places(basis, dim)
    p = basis.doflocs[:, first]
    if s.boundary is not None:
        sides = [s.boundary] if isinstance(s.boundary, str) \
            else list(s.boundary)
        if not sides:
            raise InvalidInputError("support {}: boundary names no side"
                                    .format(s.name or ""))
        held = np.zeros(p.shape[1], dtype=bool)
        for side in sides:            # a list: the union of its sides
            axis, sign = side_axis(side, dim)
            value = p[axis].max() if sign > 0 else p[axis].min()
            held |= np.isclose(p[axis], value)
        nodes = np.flatnonzero(held)
    elif s.at is not None:
        distance = np.linalg.norm(p - np.asarray(s.at, float)[:, None], axis=0)
        nodes = np.flatnonzero(distance <= 1e-9 * (1 + np.abs(p).max()))
        if nodes.size == 0:
            raise InvalidInputError(
                "support at {}: no grid node there (nearest is {})".format(
                    list(s.at), p[:, distance.argmin()].tolist()))
    elif s.region is not None:
        if isinstance(s.region, (Polygon, Ball)):
            if s.region.dim != dim:
                raise InvalidInputError(
                    "support {}: a {}D region {!r} on a {}D grid".format(
                        s.name or "", s.region.dim, s.region, dim))
            region = s.region
        else:
            region = np.asarray(s.region, float)
            if region.shape != (dim, 2) or \
                    not (region[:, 0] <= region[:, 1]).all():
                raise InvalidInputError(
                    "support {}: region must be one [lo, hi] with lo <= hi "
                    "per axis ({} rows; +-inf for a whole axis), a Polygon "
                    "or a Ball, got {}".format(s.name or "", dim, np.asarray(
                        s.region).tolist()))
        tol = 1e-9 * (1 + np.abs(p).max())
        nodes = np.flatnonzero(closed_region(region, p, tol))
        if nodes.size == 0:
            box = isinstance(region, np.ndarray)
            raise InvalidInputError(
                "support {}in region {}: no grid node there{}".format(
                    "{!r} ".format(s.name) if s.name else "",
                    region.tolist() if box else region,
                    off_grid_lines(region, [np.unique(p[d]) for d in range(
                        dim)], tol) if box else ""))
    else:
        nodes = np.flatnonzero(s.where(p))
    return first[nodes] + np.array(comps, dtype=np.int64)[:, None]


def off_grid_lines(box, lines, tol: float) -> str:
    """Where a support's ``box`` (``[lo, hi]`` per axis) misses the
    grid: for each axis with no grid line (of ``lines``, per axis) in
    ``[lo, hi]`` (to ``tol``), the nearest lines on either side, in the
    words of the ``at`` form's "nearest is" (a trial's region at x = 2.1
    was refused with no line named); ``""`` where every axis has one."""
    words = []
    for d, (lo, hi) in enumerate(np.asarray(box, float)):
        axis = np.asarray(lines[d], float)
        if ((axis >= lo - tol) & (axis <= hi + tol)).any():
            continue
        near = [axis[axis < lo].max()] if (axis < lo).any() else []
        near += [axis[axis > hi].min()] if (axis > hi).any() else []
        words.append("{} = {!r} lies {} {}".format(
            "xyz"[d], float(lo) if lo == hi else [float(lo), float(hi)],
            "between the grid lines" if len(near) == 2 else
            "beyond the grid, whose nearest line is", " and ".join(
                "{} = {!r}".format("xyz"[d], float(v)) for v in near)))
    return " ({})".format("; ".join(words)) if words else ""


#: how far, in cells, a method's shape functions reach a node from the
#: material (standard MPM and GIMP: the cells the domains meet; the
#: B-splines: their support), past which a support holds nothing
SUPPORT_REACH = {"bspline": 2, "bspline-gimp": 2, "bspline3": 2,
                 "bspline3-gimp": 2}


def warn_unreached_supports(scene: Scene, mesh, elem,
                            points: MaterialPoints):
    """Log a warning per support whose every node lies farther from the
    material at the start (its points' domains) than the method's shape
    functions reach (:data:`SUPPORT_REACH`, else one cell, in the grid's
    cell size): it holds nothing.  A trial's far roller on a grid line
    half a metre (two cells) beyond the soil's end left the soil's face
    free: Newton failed at the first step with nothing said, and with
    elastic soil the wall pushing it met no resistance."""
    from scipy.spatial import cKDTree
    dim = mesh.dim()
    grid = grid_parts(mesh, elem)[1]
    h = cell_size(mesh)
    # (points without domains, seeded on triangles: their own places)
    reach = SUPPORT_REACH.get(scene.method, 1) + (0. if points.domain is None
                                                   else np.abs(points.domain)
                                                   .max(initial=0.) / h)
    tree = cKDTree((points.x / h).T)
    for name, support in zip(support_names(scene), scene.supports):
        dofs = scene_support_dofs(support, grid, dim)
        if not dofs.size:
            continue
        distance = tree.query((grid.doflocs[:, dofs[0]] / h).T,
                              p=np.inf)[0]
        if distance.min() > reach:
            logger.warning(
                "support %r holds no node the material reaches at the start "
                "(its nearest node is %.3g cells from the nearest point, "
                "%s reaches %.3g): it holds nothing, and nothing there "
                "resists (move it to the material, or extend the material "
                "to it)", name, distance.min(), scene.method, reach)


def warn_strength_above_stiffness(scene: Scene):
    """Log a warning for each body whose material's strength (a soil's
    ``cohesion``, a metal's ``yield_stress``) exceeds its Young's modulus
    ``E``: a soil's or a metal's strength is some 1e-4 to 1e-2 of its
    stiffness, and one above it is a unit slipped (a trial's clay took its
    cohesion in Pa, 20000, in a scene in kPa, E = 1e4: it never yielded, its
    footing pressure 0.4% of N_c c, and nothing said so)."""
    stress = unit("stress", scene.units)
    for body in scene.bodies:
        material, E = body.material, getattr(body.material, "E", None)
        for name in ("cohesion", "yield_stress"):
            strength = getattr(material, name, None)
            if E is None or strength is None or strength <= E:
                continue
            logger.warning(
                "body %r: its %s %g %s exceeds its Young's modulus E = %g "
                "%s (a soil's or a metal's strength is some 1e-4 to 1e-2 "
                "of its stiffness): a unit slipped? Every stress of the "
                "scene is in %s (units = %r)", body.name, name, strength,
                stress, E, stress, stress, scene.units)


def warn_ramped_gravity(scene: Scene):
    """Log a warning where the gravity of bodies without ``K0`` grows with
    the load factor while an obstacle, a rigid body or a moving support
    pushes by its displacement at full load: at step ``k`` of ``n`` the
    push meets soil of ``k / n`` of its weight.  Trial 79's smooth
    footing, 20 steps: 179 kPa at 0.012 m against 200 from a geostatic
    start, and nothing said so."""
    if scene.dynamics is not None or not scene.gravity_ramp or \
            scene.body_forces() is None:
        return
    ramped = [b.name for b in scene.bodies
              if b.K0 is None and b.rigid is None]
    pushes = ["obstacle {!r}".format(o.name or k + 1)
              for k, o in enumerate(scene.obstacles)
              if np.any(np.asarray(o.displacement, float) != 0)] + [
        "rigid body {!r}".format(b.name) for b in scene.bodies
        if b.rigid is not None] + [
        "support {!r}".format(n) for s, n in zip(scene.supports,
                                                  support_names(scene))
        if s.value is not None and np.any(np.asarray(s.value) != 0)]
    if ramped and pushes:
        n = scene.step_count
        logger.warning(
            "the gravity on %s grows with the load factor while %s "
            "pushes: the push at step k of %d meets them at k/%d of their "
            "weight (1/%d at step 1), not the full weight; start a soil "
            "from its weight with geostatic = { } in its [[bodies]] (K0 "
            "by default Jaky's 1 - sin(phi) of a mohr_coulomb or "
            "drucker_prager soil; Python: geostatic_stress), or put it on "
            "in full with [gravity] ramp = false (Python: BodyForce(..., "
            "ramp=False); the first step carries the whole weight)",
            ", ".join(ramped), ", ".join(pushes), n, n, n)


def warn_held_tractions(scene: Scene, mesh, elem, points: MaterialPoints):
    """Log a warning per traction or pressure and direction whose force
    goes, half or more of it, to grid DOFs the supports hold in that
    direction (its faces' centres mapped with the grid's shape
    functions, ``points``: the initial ones): that part goes into the
    supports' reaction and loads nothing.  A trial's traction [10, 0] on
    the soil's left side, held in x by rollers on the grid's left side,
    changed nothing and was not told."""
    if not scene.tractions or not scene.supports:
        return
    from skfem import Basis
    dim = mesh.dim()
    scalar, grid = grid_parts(mesh, elem)[:2]
    basis = Basis(mesh, scalar)
    names = support_names(scene)
    held = []                 # per support, per component: places held
    for support in scene.supports:
        dofs = scene_support_dofs(support, grid, dim).ravel()
        held.append([dofs[dofs % dim == c] // dim for c in range(dim)])
    bodies = [b.name for b in scene.bodies]
    for k, t in enumerate(scene.tractions):
        axis, sign = side_axis(t.side, dim)
        layer = side_points(points, t.side,
                            points.body == bodies.index(t.body))
        centre = points.x[:, layer].copy()
        centre[axis] += sign * points.domain[axis, layer]
        area = np.prod(np.delete(2 * points.domain[:, layer], axis, 0),
                       axis=0)
        force = basis.probes(centre).T @ area       # per unit traction
        if t.traction is None:
            value = np.zeros(dim)
            value[axis] = -sign * float(t.pressure)
        else:
            value = np.asarray(t.traction, float)
        for c in np.flatnonzero(value):
            shares = []
            for name, places in zip(names, held):
                if places[c].size:
                    shares.append((force[places[c]].sum() / force.sum(),
                                   name, places[c]))
            if not shares:
                continue
            every = np.unique(np.concatenate([p for *_, p in shares]))
            share = force[every].sum() / force.sum()
            if share < .5:
                continue
            holding = [name for part, name, _ in sorted(
                shares, key=lambda item: -item[0]) if part > 0]
            logger.warning(
                "tractions[%d] (%s on body %r, side %r): %.0f%% of its %s "
                "force acts on grid nodes that support%s %s hold%s in %s: "
                "it goes into %s reaction and loads nothing (load a side "
                "the supports leave free in %s, or hold that side "
                "otherwise)", k, "traction" if t.pressure is None
                else "pressure", t.body, t.side, 100 * share, "xyz"[c],
                "s" if len(holding) > 1 else "",
                ", ".join(repr(n) for n in holding),
                "" if len(holding) > 1 else "s", "xyz"[c],
                "their" if len(holding) > 1 else "its", "xyz"[c])


def scene_supports(scene: Scene, dim: int):
    """The fixed supports as a callable on the grid basis."""
    def supports(basis):
        dofs = [scene_support_dofs(s, basis, dim).ravel() for s in scene.supports
                if s.value is None]
        return np.concatenate(dofs) if dofs else np.array([], dtype=np.int64)
    return supports


def moved_bodies(scene: Scene):
    """The body numbers the moving supports name (``None``: none names
    any), checked: every moving support names the same bodies, and they
    exist."""
    named = {tuple(s.bodies) if s.bodies is not None else None
             for s in scene.supports if s.value is not None}
    if named == {None} or not named:
        return None
    if len(named) > 1:
        raise InvalidInputError(
            "the moving supports name different bodies ({}): one motion "
            "moves the same bodies' fields; name the same in each".format(
                ", ".join(map(str, sorted(named, key=str)))))
    names = [b.name for b in scene.bodies]
    bodies = named.pop()
    for name in bodies:
        if name not in names:
            raise InvalidInputError(
                "a moving support's bodies name {!r}, which is no body "
                "(the scene has {})".format(name, names))
    return [names.index(name) for name in bodies]


def scene_prescribed(scene: Scene, dim: int):
    """Supports with values as ``prescribed(basis, f_old, f_new)``, or
    ``None``."""
    moving = [s for s in scene.supports if s.value is not None]
    if not moving:
        return None

    def prescribed(basis, f_old, f_new):
        dofs, values = [], []
        for s in moving:
            d = scene_support_dofs(s, basis, dim)
            dofs.append(d.ravel())
            values.append((np.asarray(s.value, float)[:, None]
                           * (f_new - f_old) * np.ones(d.shape)).ravel())
        return np.concatenate(dofs), np.concatenate(values)
    return prescribed


def run_scene(scene: Scene, points: Optional[MaterialPoints] = None,
              resume: Optional[Resume] = None,
              callback: Optional[Callable] = None,
              initial: Optional[MaterialPoints] = None) -> Result:
    """Run a scene from its start, or (``resume``, a
    :class:`~skfem_mpm.Resume`) from ``points``, the state after step
    ``resume.first_step - 1``; ``callback(record, points)`` after every
    step.  ``initial``: the scene's points at its start
    (:func:`build_points`) where the caller has seeded them already (not
    seeded again: the command line's runs said each seeding warning
    twice).

    Examples
    --------
    >>> from skfem_mpm.scenes.scene import Body, Grid, Scene, Support, run_scene
    >>> from skfem_mpm import LinearElastic
    >>> scene = Scene(grid=Grid([(0., 50., 10)]),
    ...               bodies=[Body("column", [(0., 50.)],
    ...                            LinearElastic(1e6, 0.))],
    ...               supports=[Support(boundary="left")], gravity=[-800.])
    >>> result = run_scene(scene)
    >>> result.counters["linear_solves"], result.counters["return_maps"]
    (1, 0)

    """
    scene.check()
    mesh, elem = scene.grid.build()
    if initial is None:
        initial = build_points(scene, mesh)
    if points is None:
        points = initial
    if resume is None or resume.first_step == 1:      # from the start
        warn_unreached_supports(scene, mesh, elem, points)
        warn_held_tractions(scene, mesh, elem, initial)
        warn_ramped_gravity(scene)
        warn_strength_above_stiffness(scene)
    materials = [b.material for b in scene.bodies]
    material = materials[0] if len(materials) == 1 else materials
    supports = scene_supports(scene, mesh.dim())
    prescribed = scene_prescribed(scene, mesh.dim())
    rigid_bodies = [RigidBody(k, b.rigid, rough=b.rough)
                    for k, b in enumerate(scene.bodies) if b.rigid is not None]
    dynamics = None if scene.dynamics is None else \
        scene.dynamics.dynamics([b.density for b in scene.bodies])
    loads = surface_loads(scene, initial) + rigid_bodies
    if prescribed is not None:
        loads.append(Prescribed(prescribed, bodies=moved_bodies(scene)))
    weights = scene.body_forces()
    body_force = None if weights is None else BodyForce(
        weights if scene.acceleration is not None else scene.gravity,
        [b.K0 is None and scene.gravity_ramp for b in scene.bodies])
    return simulate(mesh, elem, points, material, supports, body_force,
                    loads, None if dynamics else scene.step_count,
                    method=scene.method, kinematics=scene.kinematics,
                    dynamics=dynamics, obstacles=scene.obstacles,
                    contacts=scene_contacts(scene),
                    options=Options(
                        newton=scene.newton,
                        stabilisation=scene.stabilisation,
                        solver=scene.solver, kernels=scene.kernels,
                        resume=resume, callback=callback))
