"""Quantities of interest: the numbers a run is judged by.

A :class:`Quantity` names one number of a finished run: a point
displacement or stress at a place, its mean or extreme over a box of
material points, the reaction of a named support, the force that moves
a rigid body, the force of the material on an obstacle, the force
between the bodies of a contact, or a footing scene's peak bearing
pressure (``footing_pressure``, ``"peak"``: the largest over the run of
the soil's push on the footing over its width, what the reference
``"bearing_capacity"`` judges; a study of such a scene measures it by
default).  Scene files list them as
``[[outputs]]``; ``skfem-mpm study`` measures them in every case and
``skfem-mpm run`` reports them in ``summary.json``.  Places and boxes refer to the points' *initial*
positions, so a quantity follows the same material through the
deformation and across refinements.

Values are in the scene's consistent units (:mod:`~skfem_mpm.scenes.units`;
SI by default): displacements in m, stresses in Pa, forces in N (per m of
thickness in 2D, per m^2 in 1D); with ``units = "kN-m"`` in kPa and kN.

"""
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Optional, Sequence, Tuple, Union

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError, SceneError, check_choice
from .regions import Ball, Polygon, closed_region
from .scene import obstacle_list, reaction_resultants, support_names
from .units import unit

__all__ = ["Quantity", "QUANTITIES", "COMPONENTS", "REDUCTIONS",
           "POINTWISE", "quantity_unit", "check_quantities"]

#: what a quantity can measure
QUANTITIES = ("displacement", "stress", "reaction", "rigid_force",
              "obstacle_force", "contact_force", "footing_pressure")
#: the quantities that are forces of a support, a rigid body, an
#: obstacle or a contact between bodies, and the field naming which (in
#: the order of :func:`~skfem_mpm.scenes.scene.reaction_resultants`)
FORCES = {"reaction": "support", "rigid_force": "body",
          "obstacle_force": "obstacle", "contact_force": "contact"}
#: the quantities of the material points (the others, forces and a
#: footing's pressure, are the steps' reactions')
POINTWISE = ("displacement", "stress")
#: the components of each kind of quantity
COMPONENTS = {"displacement": ("x", "y", "z", "magnitude"),
              "stress": ("xx", "yy", "zz", "xy", "xz", "yz", "mises",
                         "pressure"),
              "reaction": ("x", "y", "z", "magnitude"),
              "rigid_force": ("x", "y", "z", "magnitude"),
              "obstacle_force": ("x", "y", "z", "magnitude"),
              "contact_force": ("x", "y", "z", "magnitude"),
              "footing_pressure": ("peak",)}
#: the dimensions a component needs: the rest exist from 1D on
NEEDS = {"y": 2, "xy": 2, "yy": 2, "z": 3, "zz": 3, "xz": 3, "yz": 3}
#: how the points of a box (or all points) give one number
REDUCTIONS = ("mean", "max", "min", "max_abs")
#: nearest points a value ``at`` a place is fitted to, per dimension
FIT_POINTS = {1: 3, 2: 8, 3: 16}


@dataclass(frozen=True)
class Quantity:
    """One number of a finished run.

    Parameters
    ----------
    quantity
        ``"displacement"`` or ``"stress"`` of material points,
        ``"reaction"`` (resultant of a support, ``support`` names it),
        ``"rigid_force"`` (the force moving a rigid body, ``body``) or
        ``"obstacle_force"`` (the force the material exerts on an
        obstacle, ``obstacle``) or ``"contact_force"`` (the force the
        first body of a contact between bodies exerts on the second,
        ``contact``; :attr:`~skfem_mpm.StepRecord.contact_forces`), or
        ``"footing_pressure"`` (a bearing-capacity scene's footing,
        :func:`~skfem_mpm.scenes.footing.scene_footing`: the soil's push
        on it over its width, positive pushing down).
    component
        ``"x"``, ``"y"``, ``"z"`` or ``"magnitude"``; for stress ``"xx"``,
        ``"yy"``, ``"zz"``, ``"xy"``, ``"xz"``, ``"yz"``, ``"mises"`` (von
        Mises equivalent) or ``"pressure"`` (mean pressure, positive in
        compression); for ``footing_pressure`` ``"peak"`` (the
        largest of the run's steps).
    at
        For point quantities: a place (initial coordinates); the value
        there is fitted linearly by least squares to the nearest points
        (3, 8, 16 in 1D, 2D, 3D), so it converges like the field itself;
        a place beyond the points (on the body's surface: the points lie
        inside it) is extrapolated, so a beam's tip deflection ``at`` its
        end face exceeds every point's.
    region
        For point quantities, instead of ``at``: ``[(lo, hi)] * dim``, a
        :class:`~skfem_mpm.scenes.regions.Polygon` (2D) or a
        :class:`~skfem_mpm.scenes.regions.Ball`; the points whose initial
        position lies in it (sides included), reduced by ``reduce``.
        Neither ``at`` nor ``region``: all points.
    reduce
        Over a region or all points: ``"mean"`` (volume-weighted, the
        default), ``"max"``, ``"min"`` or ``"max_abs"`` (the value of
        largest magnitude, sign kept); refused with ``at`` and for forces.
    support
        The support's name (``support-N`` where unnamed).
    obstacle
        For an ``obstacle_force``, the obstacle's name
        (``obstacle<i>`` where unnamed, ``i`` counting from 0 in the
        order of ``[[obstacles]]``).
    contact
        For a ``contact_force``, the contact's name (``FIRST-SECOND``,
        its bodies' names, where unnamed).
    body
        For a ``rigid_force``, the rigid body's name; for point
        quantities, optionally the body whose points count (default: all
        bodies), so that a value ``at`` an interface is one body's.
    name
        A label for tables and plots; default from the fields.

    Examples
    --------
    >>> from skfem_mpm.scenes.quantities import Quantity
    >>> top = Quantity("displacement", "x", at=(50.,))
    >>> top.label, top.unit(1)
    ('displacement x at (50)', 'm')

    """
    quantity: str
    component: str
    at: Optional[Tuple[float, ...]] = None
    region: Union[None, Tuple[Tuple[float, float], ...], Polygon,
                  Ball] = None
    reduce: Optional[str] = None
    support: Optional[str] = None
    body: Optional[str] = None
    name: str = ""
    obstacle: Optional[str] = None
    contact: Optional[str] = None

    def __post_init__(self):
        check_choice("quantity", self.quantity, QUANTITIES)
        if self.component not in COMPONENTS[self.quantity]:
            raise InvalidInputError("{} has the components {}, got {!r}"
                                    .format(article(self.quantity),
                                            components(self.quantity),
                                            self.component))
        if self.reduce is not None:
            check_choice("reduce", self.reduce, REDUCTIONS)
        pointwise = self.quantity in ("displacement", "stress")
        wanted = {"at": pointwise, "region": pointwise,
                  "support": self.quantity == "reaction",
                  "body": self.quantity in ("displacement", "stress",
                                            "rigid_force"),
                  "obstacle": self.quantity == "obstacle_force",
                  "contact": self.quantity == "contact_force",
                  "reduce": pointwise}
        for key, allowed in wanted.items():
            if getattr(self, key) is not None and not allowed:
                raise InvalidInputError("a {} quantity takes no {!r}".format(
                    self.quantity, key))
        if self.at is not None and self.region is not None:
            raise InvalidInputError("a quantity is taken at a place or "
                                    "over a region, not both")
        if self.at is not None and self.reduce is not None:
            raise InvalidInputError("a value at a place has nothing to "
                                    "reduce: drop 'reduce' or give a region")
        if self.quantity == "reaction" and self.support is None:
            raise InvalidInputError("a reaction needs the support's name")
        if self.quantity == "rigid_force" and self.body is None:
            raise InvalidInputError("a rigid_force needs the body's name")
        if self.quantity == "obstacle_force" and self.obstacle is None:
            raise InvalidInputError("an obstacle_force needs the obstacle's "
                                    "name")
        if self.quantity == "contact_force" and self.contact is None:
            raise InvalidInputError("a contact_force needs the contact's "
                                    "name")

    @property
    def label(self) -> str:
        """``name``, or a description built from the fields."""
        if self.name:
            return self.name
        text = "{} {}".format(self.quantity.replace("_", " "),
                              self.component)
        if self.support is not None:
            return text + " of " + self.support
        if self.quantity in ("rigid_force", "obstacle_force",
                             "contact_force"):
            return text + " of " + (self.body or self.obstacle
                                    or self.contact)
        if self.quantity == "footing_pressure":
            return "peak footing pressure"
        of = "" if self.body is None else " of " + self.body
        if self.at is not None:
            return text + of + " at ({})".format(", ".join(
                "{:g}".format(v) for v in self.at))
        if isinstance(self.region, (Polygon, Ball)):
            return "{} {}{} over {!r}".format(self.reduce or "mean", text,
                                              of, self.region)
        if self.region is not None:
            return "{} {}{} over [{}]".format(
                self.reduce or "mean", text, of, ", ".join(
                    "{:g}..{:g}".format(lo, hi) for lo, hi in self.region))
        return "{} {} of {}".format(self.reduce or "mean", text,
                                    "all points" if self.body is None
                                    else self.body)

    def unit(self, dim: int, system: str = "SI") -> str:
        """The quantity's unit in a scene of dimension ``dim`` whose
        numbers are in the units ``system``
        (:data:`~skfem_mpm.scenes.units.SYSTEMS`)."""
        return quantity_unit(self.quantity, dim, system)

    def check(self, scene, points=None):
        """Refuse, before any work, a quantity the scene cannot give: a
        component, support or body the scene does not have, and with the
        scene's initial :class:`~skfem_mpm.MaterialPoints`, a place
        outside the (body's) points' extent, or a box holding none of
        them."""
        dim = len(scene.grid.axes)
        if NEEDS.get(self.component, 1) > dim:
            raise InvalidInputError("{}: a {}D scene has no {!r} component "
                                    "(it has {})".format(
                                        self.label, dim, self.component,
                                        components(self.quantity, dim)))
        for where in (self.at, self.region):
            axes = getattr(where, "dim", None) or (where is not None
                                                   and len(where))
            if where is not None and axes != dim:
                raise InvalidInputError("{}: {} axes given, the scene has {}"
                                        .format(self.label, axes, dim))
        if self.support is not None and \
                self.support not in support_names(scene):
            raise InvalidInputError("{}: no support {!r} (the scene has {})"
                                    .format(self.label, self.support,
                                            support_names(scene)))
        if self.obstacle is not None and self.obstacle not in [
                o.name for o in obstacle_list(scene)]:
            raise InvalidInputError("{}: no obstacle {!r} (the scene has {})"
                                    .format(self.label, self.obstacle, [
                                        o.name for o in obstacle_list(
                                            scene)]))
        contacts = [c.name for c in scene.contacts]
        if self.contact is not None and self.contact not in contacts:
            raise InvalidInputError("{}: no contact {!r} (the scene has {})"
                                    .format(self.label, self.contact,
                                            contacts))
        bodies = [b.name for b in scene.bodies if b.rigid is not None
                  or self.quantity != "rigid_force"]
        if self.body is not None and self.body not in bodies:
            raise InvalidInputError("{}: no {}body {!r} (the scene has {})"
                                    .format(self.label, "rigid " if
                                            self.quantity == "rigid_force"
                                            else "", self.body, bodies))
        if self.quantity == "footing_pressure":
            from .footing import scene_footing
            try:
                scene_footing(scene)
            except InvalidInputError as err:
                raise InvalidInputError("{}: a footing scene's: {}".format(
                    self.label, err)) from err
        if points is None or self.quantity not in ("displacement", "stress"):
            return
        chosen = self._chosen(scene, points)
        if not chosen.any():
            raise InvalidInputError("{}: no material point starts in the "
                                    "region".format(self.label))
        if self.at is not None:
            x0 = points.x0[:, chosen]
            spacing = np.median(points.volume[chosen]) ** (1. / dim)
            at = np.asarray(self.at, float)
            if (at < x0.min(axis=1) - spacing).any() or \
                    (at > x0.max(axis=1) + spacing).any():
                raise InvalidInputError(
                    "{}: {} lies outside the {} (initial positions {} to {})"
                    .format(self.label, list(self.at), "points" if
                            self.body is None else "points of " + self.body,
                            x0.min(axis=1).round(6).tolist(),
                            x0.max(axis=1).round(6).tolist()))

    def _chosen(self, scene, points) -> ndarray:
        """Which points count: those of ``body`` (all without), starting
        in ``region`` (anywhere without)."""
        chosen = np.ones(points.n, dtype=bool)
        if self.body is not None:
            names = [b.name for b in scene.bodies]
            chosen &= points.body == names.index(self.body)
        if self.region is not None:
            chosen &= closed_region(self.region, points.x0)
        return chosen

    def extreme_point(self, scene, result) -> Optional[ndarray]:
        """The initial position (dim,) of the point whose value
        ``reduce="max"``, ``"min"`` or ``"max_abs"`` takes, or ``None``
        (a mean, a place ``at``, a force): a study's grids hold
        different points, and where the extreme moves from one point to
        another its value converges with where the points lie (first
        order in the cell size: a beam's largest displacement at its
        tip's corner point, 1e-2 apart at h = 0.5)."""
        if self.quantity not in ("displacement", "stress") or \
                self.at is not None \
                or (self.reduce or "mean") == "mean":
            return None
        pts = result.points
        chosen = np.flatnonzero(self._chosen(scene, pts))
        if not chosen.size:
            return None
        values = point_values(pts, self.quantity, self.component)[chosen]
        pick = {"max": np.argmax, "min": np.argmin}.get(
            self.reduce, lambda v: np.argmax(np.abs(v)))(values)
        return pts.x0[:, chosen[pick]].copy()

    def extreme_component(self, scene, result) -> Optional[str]:
        """The component to measure ``at`` the extreme's point
        (:meth:`extreme_point`), or ``None`` where it has none: this
        quantity's own component, and for the magnitude of the
        displacement the axis of that point's largest displacement
        component (a column's vertical one, not a sideways one its
        rollers hold at zero)."""
        at = self.extreme_point(scene, result)
        if at is None:
            return None
        if self.quantity != "displacement" or \
                self.component != "magnitude":
            return self.component
        pts = result.points
        chosen = np.flatnonzero(self._chosen(scene, pts))
        point = chosen[np.argmin(((pts.x0[:, chosen] - at[:, None]) ** 2)
                                 .sum(axis=0))]
        return "xyz"[int(np.argmax(np.abs(pts.displacement[:, point])))]

    def scale(self, scene, result) -> Optional[float]:
        """The size of this kind of quantity in the run, against which a
        value of it is round-off: the largest displacement (magnitude)
        or stress component of any point; ``None`` for a force."""
        if self.quantity not in ("displacement", "stress"):
            return None
        pts = result.points
        if self.quantity == "displacement":
            return float(np.sqrt((pts.displacement ** 2).sum(axis=0))
                         .max(initial=0.))
        return float(np.abs(pts.stress).max(initial=0.))

    def history(self, scene, result) -> dict:
        """The quantity at every step of ``result.history`` that kept its
        points' snapshots (a scene's run keeps them): ``{"step": [...],
        "load_factor": [...], "value": [...]}``, with ``"time"`` in
        dynamics; its last value is :meth:`measure`'s.  A mean over
        points weighs them by their final volumes (the steps' own in
        small strain: ``skfem-mpm run`` measures each step's points as
        the step ends instead, :func:`~skfem_mpm.cli.output_summaries`,
        so that a resumed run's history is an uninterrupted one's);
        ``footing_pressure`` gives the pressure of each
        step (its ``value`` is the largest).  Steps of the points' values
        are measured together (one fit for a place ``at``), not point by
        point."""
        records = list(result.history)
        if self.quantity in ("displacement", "stress"):
            records = [r for r in records if r.displacement is not None
                       and r.stress is not None]
        out = {"step": [int(r.step) for r in records],
               "load_factor": [float(r.load_factor) for r in records]}
        if any(getattr(r, "time", None) is not None for r in records):
            out["time"] = [float(r.time) for r in records]
        if not records:
            out["value"] = []
        elif self.quantity == "footing_pressure":
            from .footing import footing_forces, footing_pressure
            out["value"] = footing_pressure(scene, footing_forces(
                scene, records)).tolist()
        elif self.quantity in FORCES:
            out["value"] = [self.measure(scene, SimpleNamespace(
                history=[r], points=result.points)) for r in records]
        else:
            out["value"] = self._point_history(scene, result, records)
        return out

    def _point_history(self, scene, result, records) -> list:
        """:meth:`history`'s values of a displacement or stress."""
        pts = result.points
        chosen = self._chosen(scene, pts)
        if not chosen.any():
            return [float("nan")] * len(records)
        values = np.stack([point_values(SimpleNamespace(
            displacement=r.displacement, stress=r.stress), self.quantity,
            self.component)[chosen] for r in records], axis=1)
        if self.at is not None:
            return fitted_value(pts.x0[:, chosen], values,
                                np.asarray(self.at, float)).tolist()
        volume = pts.volume[chosen]
        reduce = self.reduce or "mean"
        if reduce == "mean":
            return (volume @ values / volume.sum()).tolist()
        if reduce == "max_abs":
            return values[np.argmax(np.abs(values), axis=0),
                          np.arange(values.shape[1])].tolist()
        return getattr(values, reduce)(axis=0).tolist()

    def of_forces(self, scene, reactions: ndarray) -> ndarray:
        """A force quantity or ``footing_pressure`` at every step, (steps,),
        from the steps' ``reactions`` (steps, rows, dim): per step the
        rows of :func:`~skfem_mpm.scenes.scene.reaction_resultants`
        (supports, rigid bodies, obstacles, contacts), as a checkpoint
        keeps them, so that a resumed run has the whole run's; a
        ``footing_pressure`` gives each step's pressure (:meth:`measure`
        its largest)."""
        reactions = np.asarray(reactions, dtype=float)
        if self.quantity == "footing_pressure":
            from .footing import footing_pressure, scene_footing
            return footing_pressure(scene, reactions[
                :, scene_footing(scene).column])
        if self.quantity not in FORCES:
            raise InvalidInputError("{}: a point quantity is not one of "
                                    "the forces".format(self.label))
        names = reaction_resultants(scene)[0]
        # supports, rigid bodies, obstacles and contacts in that order:
        # the name is looked up among its own kind (with the contacts'
        # names last, the obstacles were looked up among the wrong names,
        # and a finished run ended in a ValueError)
        ends = np.cumsum([len(scene.supports), len(names) - len(
            scene.supports) - len(scene.obstacles) - len(scene.contacts),
            len(scene.obstacles), len(scene.contacts)])
        kinds = [names[a:b] for a, b in zip(np.r_[0, ends[:-1]], ends)]
        kind = list(FORCES).index(self.quantity)
        start = sum(len(k) for k in kinds[:kind])
        force = reactions[:, start + kinds[kind].index(
            getattr(self, FORCES[self.quantity]))]
        if self.component == "magnitude":
            return np.linalg.norm(force, axis=1)
        return force[:, "xyz".index(self.component)].copy()

    def measure(self, scene, result) -> float:
        """The quantity of a finished run (``result`` of
        :func:`~skfem_mpm.scenes.scene.run_scene` on ``scene``); a box
        that holds no point of this run (a coarse grid of a study) raises
        :class:`~skfem_mpm.errors.InvalidInputError`."""
        if self.quantity == "footing_pressure":
            from .footing import footing_forces, footing_pressure
            pressure = footing_pressure(scene, footing_forces(
                scene, result.history))
            return float(pressure.max()) if pressure.size else float("nan")
        if self.quantity in FORCES:
            resultant = reaction_resultants(scene)[1]
            # + 0.: an obstacle never touched has -0.0, not "-0 N"
            return float(self.of_forces(scene, resultant(
                result.history[-1])[None])[0]) + 0.
        pts = result.points
        chosen = self._chosen(scene, pts)
        if not chosen.any():
            raise InvalidInputError(
                "{}: no material point of this run starts in the region "
                "(the grid's points are too far apart for it)".format(
                    self.label))
        values = point_values(pts, self.quantity, self.component)[chosen]
        if self.at is not None:
            return fitted_value(pts.x0[:, chosen], values,
                                np.asarray(self.at, float))
        volume = pts.volume[chosen]
        reduce = self.reduce or "mean"
        if reduce == "mean":
            return float(values @ volume / volume.sum())
        if reduce == "max_abs":
            return float(values[np.argmax(np.abs(values))])
        return float(getattr(values, reduce)())


def article(quantity: str) -> str:
    """A kind of quantity with its indefinite article.

    >>> from skfem_mpm.scenes.quantities import article
    >>> article("obstacle_force"), article("stress")
    ('an obstacle_force', 'a stress')
    """
    return ("an " if quantity[0] in "aeiou" else "a ") + quantity


def components(quantity: str, dim: int = None) -> str:
    """The components of a kind of quantity in words: those of a scene of
    dimension ``dim``, or (``None``) all, with the dimensions the others
    need.

    >>> from skfem_mpm.scenes.quantities import components
    >>> components("obstacle_force", 2)
    'x, y, magnitude'
    >>> components("obstacle_force")
    'x, y (2D, 3D), z (3D only), magnitude'
    """
    names = COMPONENTS[quantity]
    if dim is not None:
        return ", ".join(c for c in names if NEEDS.get(c, 1) <= dim)
    return ", ".join(c + {1: "", 2: " (2D, 3D)", 3: " (3D only)"}[
        NEEDS.get(c, 1)] for c in names)


def quantity_unit(quantity: str, dim: int, system: str = "SI") -> str:
    """The unit of a kind of quantity in a scene of dimension ``dim``
    whose numbers are in the units ``system``.

    >>> from skfem_mpm.scenes.quantities import quantity_unit
    >>> quantity_unit("reaction", 2), quantity_unit("stress", 2, "kN-m")
    ('N/m', 'kPa')
    """
    kind = {"displacement": "length", "stress": "stress",
            "footing_pressure": "stress"}.get(quantity, "force")
    return unit(kind, system, dim)


def point_values(points, quantity: str, component: str) -> ndarray:
    """One component of the points' displacement or stress, (n,)."""
    if quantity == "displacement":
        u = points.displacement
        return np.sqrt((u ** 2).sum(axis=0)) if component == "magnitude" \
            else u["xyz".index(component)].copy()
    s = points.stress
    if component == "pressure":
        return -np.trace(s) / 3.
    if component == "mises":
        dev = s - np.trace(s) / 3. * np.eye(3)[:, :, None]
        return np.sqrt(1.5 * (dev ** 2).sum(axis=(0, 1)))
    i, j = ("xyz".index(c) for c in component)
    return s[i, j].copy()


def fitted_value(x0: ndarray, values: ndarray, at: ndarray):
    """The value at ``at`` of the linear least-squares fit of ``values``
    over the nearest points (by initial position ``x0``); ``values`` (n,)
    gives a float, (n, m) the m fits' (m,) values."""
    dim = x0.shape[0]
    k = min(FIT_POINTS[dim], x0.shape[1])
    offset = x0 - at[:, None]
    near = np.argsort((offset ** 2).sum(axis=0), kind="stable")[:k]
    A = np.column_stack([np.ones(k), offset[:, near].T])
    coef = np.linalg.lstsq(A, values[near], rcond=None)[0]
    return float(coef[0]) if np.ndim(values) == 1 else coef[0]


def check_quantities(scene, quantities: Sequence[Quantity], points=None,
                     key: Optional[str] = None):
    """:meth:`Quantity.check` every quantity (on the scene's initial
    ``points`` when given), and refuse two with one label (tables and
    plots tell them apart by it).  ``key``: the scene file's table the
    quantities are (``"outputs"``): each refusal names its entry,
    ``outputs[K]``, all of them in one
    :class:`~skfem_mpm.errors.SceneError` (a trial's place outside the
    points was refused without it, where every other problem of a scene
    file is named so)."""
    labels = [q.label for q in quantities]
    twice = sorted({a for a in labels if labels.count(a) > 1})
    if twice:
        raise InvalidInputError("{}quantities named twice: {}; give them "
                                "distinct names".format(
                                    "" if key is None else key + ": ",
                                    ", ".join(twice)))
    problems = []
    for k, q in enumerate(quantities):
        try:
            q.check(scene, points)
        except InvalidInputError as err:
            if key is None:
                raise
            problems.append("{}[{}]: {}".format(key, k, err))
    if problems:
        raise SceneError(problems)
