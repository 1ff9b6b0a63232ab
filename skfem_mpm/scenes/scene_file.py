"""Scene files: a :class:`~skfem_mpm.scenes.scene.Scene` in TOML.

Every problem in a file is reported, one line each, naming the key and the
offending value (unknown keys, wrong types, impossible values), in a
:class:`~skfem_mpm.errors.SceneError`.  The format, with every key::

    name = "column"
    units = "SI"                    # optional: what the numbers are in,
                                    # for the output's labels only: "SI"
                                    # (m, N, Pa, kg, s) or "kN-m" (m, kN,
                                    # kPa, kN/m^3, t, s); nothing converted
    reference = "column"            # optional: "column" ((2.28) of
                                    # Charlton 2018),
                                    # "elastica" (end-loaded cantilever) or
                                    # "bearing_capacity" (a footing, rigid
                                    # body or box obstacle, on weightless
                                    # soil against N_c c)
    [grid]
    x = [0.0, 1.0, 1]               # lo, hi, cells (y, z likewise)
    y = [0.0, 50.0, 20]             # (`skfem-mpm study` scales every
                                    # axis's cells in proportion: its
                                    # elements must keep whole cells, the
                                    # multiples of max(cells) / gcd(cells))
    element = "Q1"                  # or "Q2" (2D)
    [[bodies]]
    name = "column"
    region = { x = [0.0, 1.0], y = [0.0, 50.0] }   # inside the grid (an
                                    # axis left out: all of it); a region
                                    # reaching outside the grid is refused
    # or region = { polygon = [[0.0, 0.0], [1.0, 0.0], [0.5, 2.0]] } (2D;
    #    3 or more vertices, either orientation, not crossing itself)
    # or region = { centre = [0.5, 25.0], radius = 0.5 } (a disc in 2D, a
    #    ball in 3D); either is seeded as a callable region (the points
    #    whose sub-cells' centres lie inside; their volume differing from
    #    the shape's by more than 1% is warned)
    points_per_cell = 2
    geostatic = { K0 = 0.5, surface = 50.0 }   # optional: start from the
                                    # K0 stress of the gravity (K0 left
                                    # out: Jaky's 1 - sin(phi) of a
                                    # mohr_coulomb or drucker_prager
                                    # soil, required of others); by default
                                    # under the geostatic bodies above it
                                    # (horizontal layers), or the top of
                                    # its material; surface: a ground
                                    # height, this body's weight alone up
                                    # to it; its gravity then acts in full
                                    # from the first step
    rigid = { displacement = [0.0, -0.01], rough = true }   # optional: a
                                    # rigid body pushed through the grid
                                    # (a footing; rough = false: smooth),
                                    # displacement at full load
    replaces = ["soil"]             # optional: this body's region is cut
                                    # out of those bodies' (a pile in the
                                    # soil); regions may not overlap else
    material = { model = "linear_elastic", E = 1e6, nu = 0.0 }
    # or { model = "von_mises", E = .., nu = .., yield_stress = .. }
    # or { model = "drucker_prager", E = .., nu = .., cohesion = ..,
    #      friction_angle = .., dilation_angle = 0.0 (degrees),
    #      hardening = 0.0, fit = "outer" | "inner" | "plane_strain" }
    # or { model = "mohr_coulomb", E = .., nu = .., cohesion = ..,
    #      friction_angle = .., dilation_angle = 0.0 (degrees) }
    # or { model = "cam_clay", kappa = .., lambda = .., M = ..,
    #      shear_modulus = .., reference_pressure = ..,
    #      preconsolidation_pressure = .. (default: reference_pressure) }
    [[supports]]                    # a grid DOF held by several supports
                                    # reacts in a moving one's resultant,
                                    # else in the last one's
    name = "base"                   # optional: labels its reactions in
                                    # summary.json (default "support-N")
    boundary = "bottom"             # x- x+ y- y+ z- z+ by axis; left
                                    # right (x) and, in 2D, bottom top (y)
    # boundary = ["left", "right"]  # or a list: their union, one support
                                    # (one reaction resultant)
    components = ["x", "y"]         # default: all
    value = [0.0, -0.1]             # optional: displacement at full load
    # bodies = ["block"]            # with value and [[contacts]]: the
                                    # bodies whose field it moves (every
                                    # moving support the same; default:
                                    # the body nearest each node, warned)
    [[supports]]
    at = [0.0, 0.5]                 # or one grid node by its coordinates
    [[supports]]
    region = { x = [0.0, 0.25], y = [1.25, 1.25] }   # or the grid nodes in
                                    # a closed box (lo = hi: a grid line),
                                    # a polygon or a disc, sides included
                                    # (the bodies' region keys)
    [gravity]
    body_force = [0.0, -800.0]      # per unit (initial) volume, every body
    # or acceleration = [0.0, -9.81]: times each body's density (bodies
    # of different densities; every body then needs density = ..)
    ramp = true                     # optional: on bodies without
                                    # geostatic the gravity grows with the
                                    # load factor, together with the other
                                    # loads and the obstacles', rigid
                                    # bodies' and supports' displacements
                                    # (a footing pushed at step 1 into soil
                                    # of 1/steps of its weight: warned);
                                    # false: in full from the first step
    [[point_loads]]
    at = [10.0, 0.5]
    force = [0.0, -1e5]
    points = 2                      # shared by the nearest points
                                    # (at: on the grid, within a cell
                                    # of a material point)
    [[tractions]]
    body = "column"
    side = "top"
    traction = [0.0, -100.0]        # per initial area, fixed direction
    # or pressure = 100.0           # pushes in, follows the surface in
                                    # finite deformation
    # ramp = false                  # in full from the first step (a
                                    # confining pressure the body's
                                    # initial stress balances); default
                                    # true: grows with the load factor
    [[outputs]]                     # optional: quantities of interest,
                                    # in summary.json and measured by
                                    # `skfem-mpm study` (default there:
                                    # the largest point displacement; a
                                    # footing scene's peak footing
                                    # pressure); summary.json's
                                    # outputs[name]: value, unit and
                                    # history, columns {step: [...],
                                    # load_factor: [...], value: [...]}
                                    # (time: [...] too in dynamics)
    name = "top settlement"         # optional label
    quantity = "displacement"       # or "stress", "reaction" (support =
                                    # its name), "rigid_force" (body = ..)
                                    # or "obstacle_force" (obstacle = ..)
                                    # or "contact_force" (contact = ..)
                                    # or "footing_pressure" (component
                                    # "peak"; reference
                                    # "bearing_capacity")
    component = "y"                 # x y z magnitude; stress: xx yy zz xy
                                    # xz yz mises pressure
    at = [0.5, 50.0]                # initial position (a linear fit to
                                    # the nearest points, extrapolated
                                    # beyond them, e.g. on a surface), or
    # region = { y = [45.0, 50.0] } # points starting in a box (or a
                                    # polygon or disc), sides included
    # reduce = "max"                # reduced by mean (volume-weighted, the
                                    # default) max min max_abs; neither at
                                    # nor region: all points, reduced
    # body = "column"               # optional: only this body's points
    [[obstacles]]                   # optional: rigid obstacles the
                                    # material cannot enter, in contact
                                    # at its surface (docs/contact.md)
    name = "floor"
    box = { x = [-1.0, 2.0], y = [-1.0, 0.0] }   # or polygon (2D) =
                                    # [[x, y], ...]
    displacement = [0.0, 0.0]       # at full load (ramped; in dynamics
                                    # with the load's ramp)
    friction = 0.0                  # smooth; a Coulomb coefficient,
                                    # "rough" (no slip) or "tied" (bonded)
    # penalty = 10.0; tolerance = 1e-3 (penetration, cells)
    [[contacts]]                    # optional: bodies that may slide and
                                    # separate (each pair on its own grid
                                    # field; others stay glued)
    first = "soil"                  # body names
    second = "pile"
    friction = 0.3                  # 0.0 smooth (default), a Coulomb
                                    # coefficient or "rough" (no slip)
    # name = "shaft"; penalty = 10.0; tolerance = 1e-3
    [dynamics]                      # optional: implicit dynamics
    time_step = 0.01                # s (the longest; equal steps)
    duration = 1.0                  # s
    scheme = "auto"                 # "newmark", with obstacles or contacts
                                    # "generalized_alpha" with rho_inf = 0;
                                    # or "newmark", "generalized_alpha"
    # beta = 0.25, gamma = 0.5 (newmark); rho_inf = 0.8; mass = "lumped"
    # or "consistent" (method fem); flip = 0.95; load_ramp = 0.0 (s over
    # which loads rise to full); target_iterations = 6 (adaptive steps;
    # bodies then need density = .. and may have initial_velocity = [..];
    # [solver] steps is not used)
    [solver]
    method = "mpm"                  # fem mpm ugimp cpgimp bspline
                                    # bspline-gimp bspline3 bspline3-gimp
    kinematics = "small"            # small finite
    steps = 20
    tolerance = 1e-9
    max_iterations = 25
    linear = "auto"                 # fastest installed; scipy pypardiso pyamg
    kernels = "auto"                # the per-point work: compiled passes
                                    # where they serve the scene (numba
                                    # installed), else numpy; "numpy" (the
                                    # reference); "compiled" (a scene they
                                    # cannot serve is refused)
    antilocking = false             # mean dilatation, B-bar (any method);
                                    # "fbar": F-bar on each increment
                                    # (finite, moving points; nu ~ 0.5)
    extended_splines = false        # extended B-splines (bspline methods)
    ghost = "auto"                  # ghost penalty for cut cells: "auto"
                                    # (on where slivers of material hold
                                    # nodes), or a factor (0: never)
    line_search = "backtracking"    # or "armijo" (from the first
                                    # attempt on), "none": plain Newton
    newton = "full"                 # or "modified": a step's first
                                    # tangent factorised once
    rhs = "residual"                # or "increment": the seed's literal
                                    # scheme (small-strain elastic scenes)
    grow_back = false               # true: a cut-back's increment doubles
                                    # after two easy sub-steps (fewer
                                    # sub-steps; its path may fail where
                                    # the default's completes:
                                    # NewtonOptions)

"""
import math
from pathlib import Path

import numpy as np

try:
    import tomllib
except ImportError:                       # Python 3.10
    import tomli as tomllib

from ..errors import InvalidInputError, InvalidMaterialError, SceneError
from ..kernels import KERNELS
from ..mechanics.cam_clay import ModifiedCamClay
from ..mechanics.materials import LinearElastic, VonMises
from ..mechanics.soils import DP_FITS, DruckerPrager, MohrCoulomb
from ..solve.backends import FACTORIES, solver_choices, solver_meant
from ..solve.dynamics import MASSES
from ..solve.newton import LINE_SEARCHES, NEWTON, RHS, NewtonOptions
from ..solve.body_contact import Contact
from ..solve.obstacles import Obstacle, check_obstacles
from ..solve.loads import WORDS_OF_2D, side_axis, side_names
from ..spelling import PARAMETER_KEYS, did_you_mean
from ..stabilisation.settings import Stabilisation
from .quantities import Quantity, check_quantities
from .regions import Ball, Polygon, outside_grid, region_shape
from .units import SYSTEMS, unit
from .scene import (KINEMATICS, SCHEMES, METHODS, Body, Grid, PointLoad,
                    Scene, Support, Traction, TimeIntegration,
                    off_grid_lines)

__all__ = ["load_scene", "parse_scene", "parse_quantity", "REFERENCES"]

REFERENCES = ("column", "elastica", "bearing_capacity")
AXES = ("x", "y", "z")
# the scene shipped with the package: the seed's column, which
# `skfem-mpm run` runs when given no scene
EMBEDDED = Path(__file__).resolve().parent / "column.toml"


class _Checker:
    """Collects problems while reading a TOML tree."""

    def __init__(self):
        self.problems = []

    def bad(self, key, message, value):
        self.problems.append("{}: {}, got {!r}".format(key, message, value))

    def table(self, data, key, allowed, required=()):
        if not isinstance(data, dict):
            self.bad(key, "must be a table", data)
            return {}
        for k in data:
            if k not in allowed:
                self.problems.append("{}: unknown key (allowed: {}), got "
                                     "{!r}{}".format(
                                         "{}.{}".format(key, k) if key else k,
                                         ", ".join(allowed), data[k],
                                         did_you_mean(k, allowed)))
        for k in required:
            if k not in data:
                self.problems.append("{}: missing".format(
                    "{}.{}".format(key, k) if key else k))
        return data

    def number(self, data, key, name, default=None, low=None, high=None,
               open_low=True, integer=False):
        path = "{}.{}".format(key, name) if key else name
        if name not in data:
            return default
        value = data[name]
        kind = int if integer else (int, float)
        if isinstance(value, bool) or not isinstance(value, kind) or (
                not integer and not math.isfinite(value)):
            self.bad(path, "must be {}".format(
                "an integer" if integer else "a finite number"), value)
            return default
        if low is not None and (value <= low if open_low else value < low):
            self.bad(path, "must be {} {}".format(">" if open_low else ">=",
                                                  low), value)
            return default
        if high is not None and value >= high:
            self.bad(path, "must be < {}".format(high), value)
            return default
        return value

    def option(self, kind, key, fields):
        """``kind(**values)`` of ``fields``, ``(field, file key, value)``
        triples: each value checked by the option object itself, its
        problems named by the file's key; a field with a problem keeps the
        option's default."""
        kept = {}
        for name, file_key, value in fields:
            try:
                kind(**{name: value})
            except InvalidInputError as err:
                message = str(err)       # named by the file's key
                if message.startswith(name + " "):
                    message = message[len(name) + 1:]
                self.problems.append("{}.{}: {}".format(key, file_key,
                                                        message))
            else:
                kept[name] = value
        try:
            return kind(**kept)
        except InvalidInputError as err:          # values that clash
            self.problems.append("{}: {}".format(key, err))
            return kind()

    def choice(self, data, key, name, choices, default=None):
        path = "{}.{}".format(key, name) if key else name
        value = data.get(name, default)
        if value not in choices:
            self.bad(path, "must be one of {}".format(", ".join(
                v for v in choices if v is not None)), value)
            self.problems[-1] += did_you_mean(value, choices)
            return default
        return value

    def side(self, data, key, name, dim):
        """A side of the grid or a body (:func:`~skfem_mpm.solve.loads.
        side_names`), ``"x-"`` where it is wrong."""
        value = data.get(name, "x-")
        if dim == 3 and value in WORDS_OF_2D:
            try:
                side_axis(value, dim)              # a 3D word: the reason
            except InvalidInputError as err:
                self.bad("{}.{}".format(key, name), str(err), value)
                return "x-"
        return self.choice(data, key, name, side_names(dim), "x-")

    def antilocking(self, solver):
        value = solver.get("antilocking", False)
        if not isinstance(value, bool) and value != "fbar":
            self.bad("solver.antilocking", 'must be true, false or "fbar"',
                     value)
            return False
        return value

    def boolean(self, data, key, name, default=False):
        value = data.get(name, default)
        if not isinstance(value, bool):
            self.bad("{}.{}".format(key, name), "must be true or false",
                     value)
            return default
        return value

    def vector(self, data, key, name, length, default=None, why=""):
        """``data[name]``, a list of ``length`` finite numbers (``why``:
        what sets the length, for the message), else ``default``."""
        path = "{}.{}".format(key, name) if key else name
        if name not in data:
            return default
        value = data[name]
        if not isinstance(value, list) or len(value) != length or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool)
                and math.isfinite(v) for v in value):
            self.bad(path, "must be a list of {} finite numbers{}".format(
                length, why), value)
            return default
        return [float(v) for v in value]

    def array(self, data, name):
        value = data.get(name, [])
        if not isinstance(value, list) or not all(isinstance(v, dict)
                                                  for v in value):
            self.bad(name, "must be an array of tables ([[{}]])".format(name),
                     value)
            return []
        return value


def _grid(c, data):
    data = c.table(data, "grid", AXES + ("element",))
    axes = []
    for name in AXES:
        if name not in data:
            break
        v = data[name]
        if not (isinstance(v, list) and len(v) == 3 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool)
                for x in v) and isinstance(v[2], int) and v[2] >= 1
                and v[1] > v[0]):
            c.bad("grid." + name, "must be [lo, hi, cells] with lo < hi and "
                  "cells a positive integer", v)
            axes.append((0., 1., 1))
        else:
            axes.append((float(v[0]), float(v[1]), int(v[2])))
    if not axes:
        c.problems.append("grid.x: missing")
        axes = [(0., 1., 1)]
    element = c.choice(data, "grid", "element", ("Q1", "Q2"), "Q1")
    if element == "Q2" and len(axes) != 2:
        c.bad("grid.element", "Q2 is offered on 2D grids", element)
    return Grid(axes=axes, element=element)


ELASTIC = ("E", "nu")
CAM_CLAY = ("kappa", "lambda", "M", "shear_modulus", "reference_pressure",
            "preconsolidation_pressure")
MODELS = {"linear_elastic": ELASTIC, "von_mises": ELASTIC + ("yield_stress",),
          "drucker_prager": ELASTIC + ("cohesion", "friction_angle",
                                       "dilation_angle", "hardening", "fit"),
          "mohr_coulomb": ELASTIC + ("cohesion", "friction_angle",
                                     "dilation_angle"),
          "cam_clay": CAM_CLAY}
REQUIRED = {"linear_elastic": ELASTIC, "von_mises": MODELS["von_mises"][:3],
            "drucker_prager": ELASTIC + ("cohesion", "friction_angle"),
            "mohr_coulomb": ELASTIC + ("cohesion", "friction_angle"),
            "cam_clay": CAM_CLAY[:5]}


def _material(c, data, key):
    model = data.get("model") if isinstance(data, dict) else None
    if not isinstance(model, str) or model not in MODELS:
        # which keys a material takes depends on its model: of a model
        # left out or misspelt, that alone
        if not isinstance(data, dict):
            c.bad(key, "must be a table", data)
        elif "model" not in data:
            c.problems.append("{}.model: missing (one of {})".format(
                key, ", ".join(MODELS)))
        else:
            c.choice(data, key, "model", tuple(MODELS))
        return LinearElastic(1., 0.)
    allowed = ("model",) + MODELS[model]
    others = {k for extra in MODELS.values() for k in extra} - set(allowed)
    for name in data:
        if name in others:
            c.bad(key + "." + name, "not a parameter of model = {!r} (its "
                  "keys: {})".format(model, ", ".join(allowed)), data[name])
    c.table({k: v for k, v in data.items() if k not in others}, key,
            allowed)
    known = len(c.problems)
    for name in REQUIRED[model]:
        if name not in data:
            c.problems.append("{}.{}: missing ({})".format(key, name, model))
    if model == "cam_clay":
        python = {k: name for name, k in PARAMETER_KEYS.items()}
        # (without a preconsolidation pressure: the model's default,
        # normally consolidated at the reference pressure)
        kwargs = {python.get(name, name): c.number(data, key, name, 1.,
                                                   low=0.)
                  for name in CAM_CLAY if name in REQUIRED[model]
                  or name in data}
        build = ModifiedCamClay
    else:
        kwargs = dict(E=c.number(data, key, "E", 1., low=0.),
                      nu=c.number(data, key, "nu", 0., low=-1., high=.5))
        build = LinearElastic
    if model == "von_mises":
        kwargs.update(yield_stress=c.number(data, key, "yield_stress", 1.,
                                            low=0.))
        build = VonMises
    if model in ("drucker_prager", "mohr_coulomb"):
        kwargs.update(
            cohesion=c.number(data, key, "cohesion", 1., low=0.,
                              open_low=False),
            friction_angle=c.number(data, key, "friction_angle", 0., low=0.,
                                    high=90., open_low=False),
            dilation_angle=c.number(data, key, "dilation_angle", 0., low=0.,
                                    open_low=False))
        build = MohrCoulomb
    if model == "drucker_prager":
        kwargs.update(hardening=c.number(data, key, "hardening", 0.),
                      fit=c.choice(data, key, "fit", DP_FITS, "outer"))
        build = DruckerPrager
    if len(c.problems) > known:     # no second message about a default
        return LinearElastic(1., 0.)
    try:
        return build(**kwargs)
    except InvalidMaterialError as err:
        c.problems.append("{}: {}".format(key, err))
        return LinearElastic(1., 0.)


def _box(c, data, key: str, dim: int, closed: bool = False):
    """``[(lo, hi)] * dim`` of a region table (an axis left out: all of
    it); ``lo < hi``, or ``lo <= hi`` when ``closed`` (a grid line)."""
    region = c.table(data, key, AXES[:dim])
    box = []
    for d in range(dim):
        v = region.get(AXES[d], [-math.inf, math.inf])
        if not (isinstance(v, list) and len(v) == 2 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool)
                for x in v) and (v[0] <= v[1] if closed else v[0] < v[1])):
            c.bad("{}.{}".format(key, AXES[d]), "must be [lo, hi] with lo "
                  "{} hi".format("<=" if closed else "<"), v)
            v = [0., 1.]
        box.append((float(v[0]), float(v[1])))
    return box


def _contact(c, data, key: str, bodies: list):
    """A :class:`~skfem_mpm.Contact` of a ``[[contacts]]`` table (body
    names), or ``None`` after a problem."""
    data = c.table(data, key, ("first", "second", "friction", "name",
                               "penalty", "tolerance"), ("first", "second"))
    if "first" not in data or "second" not in data:
        return None
    names = [b.name for b in bodies if b is not None]
    for which in ("first", "second"):
        if data[which] not in names:
            c.bad(key + "." + which, "must name a body ({})".format(
                ", ".join(names)), data[which])
            return None
    friction = data.get("friction", 0.)
    if not isinstance(friction, str):
        friction = c.number(data, key, "friction", 0., low=0.,
                            open_low=False)
    kwargs = {name: c.number(data, key, name, 1., low=0.)
              for name in ("penalty", "tolerance") if name in data}
    try:
        return Contact(data["first"], data["second"], friction=friction,
                       name=data.get("name"), **kwargs)
    except InvalidInputError as err:
        c.problems.append(keyed(key, "Contact", err, data))
        return None


def keyed(key: str, kind: str, err, data: dict) -> str:
    """The problem of the table ``key`` whose class ``kind`` refused it
    with ``err``, "``kind`` FIELD must ...": named by its key where FIELD
    is one of ``data``'s (a trial read ``obstacles[0]: Obstacle friction
    must be ...``).

    >>> from skfem_mpm.scenes.scene_file import keyed
    >>> keyed("obstacles[0]", "Obstacle", "Obstacle friction must be "
    ...       "'rough' or 'tied', got 'rogh'", {"friction": "rogh"})
    "obstacles[0].friction: must be 'rough' or 'tied', got 'rogh'"
    """
    words = str(err).split(" ", 2)
    if len(words) == 3 and words[0] == kind and words[1] in data:
        return "{}.{}: {}".format(key, words[1], words[2])
    return "{}: {}".format(key, err)


def _obstacle(c, data, key: str, dim: int):
    """An :class:`~skfem_mpm.Obstacle` of an ``[[obstacles]]`` table, or
    ``None`` after a problem."""
    data = c.table(data, key, ("name", "box", "polygon", "displacement",
                               "friction", "penalty", "tolerance"))
    found = len(c.problems)
    if ("box" in data) == ("polygon" in data):
        c.bad(key, "needs exactly one of box = { x = [lo, hi], ... } and "
              "polygon = [[x, y], ...]", data)
        return None
    kwargs = {}
    if "box" in data:
        box = _box(c, data["box"], key + ".box", dim)
        if any(math.isinf(lo) or math.isinf(hi) for lo, hi in box):
            c.bad(key + ".box", "must bound every axis ({})".format(
                ", ".join(AXES[:dim])), data["box"])
            return None
        kwargs["box"] = box
    else:
        kwargs["polygon"] = data["polygon"]
    if "displacement" in data:
        kwargs["displacement"] = c.vector(data, key, "displacement", dim)
    friction = data.get("friction", 0.)
    if not isinstance(friction, str):
        friction = c.number(data, key, "friction", 0., low=0.,
                            open_low=False)
    for name in ("penalty", "tolerance"):
        if name in data:
            kwargs[name] = c.number(data, key, name, 1., low=0.)
    if len(c.problems) > found:       # named once, not again with defaults
        return None
    try:
        return Obstacle(friction=friction, name=data.get("name"), **kwargs)
    except InvalidInputError as err:
        c.problems.append(keyed(key, "Obstacle", err, data))
        return None


def parse_quantity(table: dict, dim: int,
                   key: str = "outputs") -> Quantity:
    """A :class:`~skfem_mpm.scenes.quantities.Quantity` from a scene
    file's ``[[outputs]]`` table or a study's ``--measure`` (keys as the
    fields; ``region`` as a box table ``{ x = [lo, hi], ... }``, an axis
    left out: all of it, or a polygon or disc as a body's)."""
    allowed = ("quantity", "component", "at", "region", "reduce", "support",
               "body", "obstacle", "contact", "name")
    if not isinstance(table, dict):
        raise InvalidInputError("{}: must be a table, got {!r}".format(
            key, table))
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise InvalidInputError("{}: unknown key {} (allowed: {})".format(
            key, ", ".join(unknown), ", ".join(allowed)))
    if "quantity" not in table or "component" not in table:
        raise InvalidInputError("{}: needs quantity and component".format(
            key))
    kwargs = dict(table)
    if "at" in kwargs:
        at = kwargs["at"]
        if not (isinstance(at, list) and len(at) == dim and all(
                isinstance(v, (int, float)) and not isinstance(v, bool)
                for v in at)):
            raise InvalidInputError("{}.at: must be {} numbers, got {!r}"
                                    .format(key, dim, at))
        kwargs["at"] = tuple(float(v) for v in at)
    if "region" in kwargs:
        kwargs["region"] = _region(kwargs["region"], dim, key + ".region")
    try:
        return Quantity(**kwargs)
    except (InvalidInputError, TypeError) as err:
        raise InvalidInputError("{}: {}".format(key, err))


def _region(table, dim: int, key: str):
    """A quantity's region table: a closed box, a polygon or a disc (a
    ball), checked as the regions of scene files are."""
    checker = _Checker()
    region = _body_region(checker, table, key, dim, closed=True)
    if checker.problems:
        raise InvalidInputError("; ".join(checker.problems))
    return tuple(region) if isinstance(region, list) else region


def _body(c, data, k, dim):
    key = "bodies[{}]".format(k)
    data = c.table(data, key, ("name", "region", "points_per_cell",
                               "material", "geostatic", "rigid", "density",
                               "initial_velocity", "replaces"),
                   ("region", "material"))
    name = data.get("name", "body{}".format(k))
    if not isinstance(name, str):
        c.bad(key + ".name", "must be a string", name)
        name = "body{}".format(k)
    box = _body_region(c, data.get("region", {}), key + ".region", dim)
    ppc = c.number(data, key, "points_per_cell", 2, low=1, open_low=False,
                   integer=True)
    material = _material(c, data.get("material", {}), key + ".material")
    K0 = surface = None
    if "geostatic" in data:
        geo = c.table(data["geostatic"], key + ".geostatic",
                      ("K0", "surface"))
        K0 = c.number(geo, key + ".geostatic", "K0", 1., low=0.)
        surface = c.number(geo, key + ".geostatic", "surface")
        if "K0" not in geo and isinstance(geo, dict):
            K0 = _jaky(c, data.get("material"), material,
                       key + ".geostatic.K0")
    rigid, rough = None, True
    if "rigid" in data:
        table = c.table(data["rigid"], key + ".rigid",
                        ("displacement", "rough"), ("displacement",))
        rigid = c.vector(table, key + ".rigid", "displacement", dim)
        if rigid is not None and not any(rigid):
            c.bad(key + ".rigid.displacement", "must not be zero", rigid)
        rough = c.boolean(table, key + ".rigid", "rough", True)
    replaces = data.get("replaces", [])
    if not (isinstance(replaces, list)
            and all(isinstance(r, str) for r in replaces)):
        c.bad(key + ".replaces", "must be a list of body names", replaces)
        replaces = []
    return Body(name=name, region=box, material=material, points_per_cell=ppc,
                K0=K0, surface=surface, rigid=rigid, rough=rough,
                density=c.number(data, key, "density", low=0.),
                initial_velocity=c.vector(data, key, "initial_velocity", dim),
                replaces=tuple(replaces))


def _jaky(c, table, material, key: str) -> float:
    """A geostatic body's ``K0`` left out: Jaky's ``1 - sin(phi)`` of a
    Mohr-Coulomb or Drucker-Prager soil's friction angle (a normally
    consolidated soil's), else refused with the reason."""
    model = table.get("model") if isinstance(table, dict) else None
    model = model if isinstance(model, str) else None
    if model in ("mohr_coulomb", "drucker_prager"):
        phi = getattr(material, "friction_angle", 0.)  # 0: refused anyway
        return 1. - math.sin(math.radians(phi))
    if model in MODELS:         # (a model misspelt or left out is said)
        c.problems.append(
            "{}: missing: Jaky's 1 - sin(phi), the default of mohr_coulomb "
            "and drucker_prager soils, needs a friction angle, which model "
            "= {!r} has not{}".format(key, model, "" if model == "cam_clay"
                                      else "; an elastic layer under "
                                      "uniaxial strain has nu / (1 - nu)"))
    return 1.


def _support_sides(c, s: dict, key: str, dim: int):
    """A support's ``boundary``: one side's name, or a list of them (the
    union of those sides, each checked as one name is; a side named twice,
    in either spelling, refused).  A trial's ``boundary = ["left",
    "right"]`` was refused as not a side's name."""
    names = s["boundary"]
    if not isinstance(names, list):
        return c.side(s, key, "boundary", dim)
    if not names:
        c.bad(key + ".boundary", "names no side: give a side's name or a "
              "list of them", names)
        return "x-"
    sides = [c.side({"boundary[{}]".format(k): name}, key,
                    "boundary[{}]".format(k), dim)
             for k, name in enumerate(names)]
    if len(sides) == len(names) and all(
            a == b for a, b in zip(sides, names)):    # each one valid
        places = [side_axis(name, dim) for name in sides]
        twice = [(places.index(p), k) for k, p in enumerate(places)
                 if places.index(p) < k]
        if twice:
            first, again = twice[0]
            c.bad(key + ".boundary", "names a side twice ({}): list each "
                  "side once (the support holds their union)".format(
                      "{!r}".format(sides[first]) if sides[first]
                      == sides[again] else "{!r} and {!r}".format(
                          sides[first], sides[again])), names)
            return sides[0]
    return sides if len(sides) > 1 else sides[0]


def _body_region(c, data, key: str, dim: int, closed: bool = False):
    """A region table: a box ``{ x = [lo, hi], ... }`` (an axis left out:
    all of it; ``lo <= hi`` when ``closed``, as a support's and an
    output's), ``{ polygon = [[x, y], ...] }`` (2D) or ``{ centre = [..],
    radius = r }`` (a disc in 2D, a ball in 3D)."""
    if not isinstance(data, dict) or not (
            {"polygon", "centre", "radius"} & set(data)):
        return _box(c, data, key, dim, closed)
    c.table(data, key, AXES[:dim] + ("polygon", "centre", "radius"))
    shapes = [words for words, keys in (
        ("a box (x, y, z)", set(AXES) & set(data)),
        ("a polygon", {"polygon"} & set(data)),
        ("a disc or ball (centre, radius)", {"centre", "radius"}
         & set(data))) if keys]
    if len(shapes) > 1:
        c.bad(key, "must be one shape, got the keys of {}".format(
            " and ".join(shapes)), sorted(data))
        return NO_REGION * dim
    found = len(c.problems)
    try:
        if "polygon" in data:
            if dim != 2:
                c.bad(key + ".polygon", "is a 2D region, the grid is {}D "
                      "(give a box or centre and radius)".format(dim),
                      data["polygon"])
            else:
                return Polygon(data["polygon"], key + ".polygon")
        else:
            centre = c.vector(data, key, "centre", dim)
            radius = c.number(data, key, "radius", low=0.)
            for name in ("centre", "radius"):
                if name not in data:
                    c.problems.append("{}.{}: missing (a {} needs centre "
                                      "and radius)".format(
                                          key, name, "disc" if dim == 2
                                          else "ball"))
            if len(c.problems) == found:
                return Ball(centre, radius, key)
    except InvalidInputError as err:
        c.problems.append(str(err))
    return NO_REGION * dim


#: a refused shape's stand-in: the whole grid, which no later check of the
#: scene refuses again (a reviewer: every bad disc also "reached outside
#: the grid" as the box [0, 1] it was replaced by)
NO_REGION = [(-math.inf, math.inf)]


def _inside_grid(c, bodies, grid):
    """A body's region reaching outside the grid is refused: the material
    there would be dropped without a word (an axis left out, all of the
    grid, reaches nowhere beyond; a polygon or disc by its bounding
    box)."""
    low, high = ([a[i] for a in grid.axes] for i in (0, 1))
    for k, body in enumerate(bodies):
        shape = region_shape(body.region)
        what = "" if shape == "box" else " (a {})".format(shape)
        for d, lo, hi in outside_grid(body.region, low, high):
            c.bad("bodies[{}].region{}".format(
                k, "." + AXES[d] if shape == "box" else ""),
                "body {!r}{} reaches outside the grid, whose {} extent "
                "is [{!r}, {!r}]: the material beyond it would be "
                "dropped; shrink the region or extend the grid".format(
                    body.name, what,
                    AXES[d], low[d], high[d]),
                [lo, hi] if shape == "box" else {AXES[d]: [lo, hi]})



def _dynamics(c, data) -> TimeIntegration:
    """The ``[dynamics]`` table."""
    key = "dynamics"
    d = c.table(data, key, ("scheme", "time_step", "duration", "beta",
                            "gamma", "rho_inf", "mass", "flip", "load_ramp",
                            "target_iterations"),
                ("time_step", "duration"))
    scheme = c.choice(d, key, "scheme", SCHEMES, "auto")
    for name, owner in (("beta", "newmark"), ("gamma", "newmark"),
                        ("rho_inf", "generalized_alpha")):
        if name in d and scheme != owner:
            c.bad("{}.{}".format(key, name), "belongs to scheme {!r}, not "
                  "{!r}: it would be ignored (set scheme = {!r})".format(
                      owner, scheme, owner), d[name])
    return TimeIntegration(
        time_step=c.number(d, key, "time_step", 1., low=0.),
        duration=c.number(d, key, "duration", 1., low=0.),
        scheme=scheme, beta=c.number(d, key, "beta", .25, low=0.),
        gamma=c.number(d, key, "gamma", .5, low=0.),
        rho_inf=c.number(d, key, "rho_inf", .8, low=0., open_low=False),
        mass=c.choice(d, key, "mass", MASSES, "lumped"),
        flip=c.number(d, key, "flip", .95, low=0., open_low=False),
        load_ramp=c.number(d, key, "load_ramp", 0., low=0.,
                           open_low=False),
        target_iterations=c.number(d, key, "target_iterations", None, low=2,
                                   open_low=False, integer=True))


def linear_solver(c, solver) -> str:
    """``[solver] linear``: a solver name, the message saying what each
    is and which one a back end's name means (``"superlu"``: 'scipy')."""
    value = solver.get("linear", "auto")
    if value not in FACTORIES:
        c.bad("solver.linear", "must be one of {}".format(solver_choices()),
              value)
        c.problems[-1] += solver_meant(value)
        return "auto"
    return value


def _name(c, data):
    name = data.get("name", "scene")
    if not isinstance(name, str):
        c.bad("name", "must be a string", name)
        return "scene"
    return name


def grid_lines(grid) -> list:
    """Per axis, the coordinates of the grid's node lines (a ``Q2``
    grid's: the cells' edges and middles)."""
    per = 2 if grid.element == "Q2" else 1
    return [np.linspace(lo, hi, per * n + 1) for lo, hi, n in grid.axes]


def _supports_on_grid(c, supports, grid):
    """A support ``at`` a place or in a box holding no grid node is
    refused before any work, naming its table and the nearest grid lines
    (a trial's region at x = 2.1 was refused at the run's set-up with
    neither)."""
    lines = grid_lines(grid)
    tol = 1e-9 * (1 + max(max(abs(lo), abs(hi)) for lo, hi, _ in
                          grid.axes))
    for k, s in enumerate(supports):
        key = "supports[{}]".format(k)
        if s.at is not None:
            nearest = [float(axis[np.abs(axis - x).argmin()])
                       for axis, x in zip(lines, s.at)]
            if any(abs(a - x) > tol for a, x in zip(nearest, s.at)):
                c.bad(key + ".at", "support {}has no grid node there "
                      "(nearest is {})".format(
                          "{!r} ".format(s.name) if s.name else "",
                          nearest), list(s.at))
        elif s.region is not None and not isinstance(s.region,
                                                     (Polygon, Ball)):
            words = off_grid_lines(s.region, lines, tol)
            if words:
                c.bad(key + ".region", "support {}holds no grid node{}"
                      .format("{!r} ".format(s.name) if s.name else "",
                              words), [list(b) for b in s.region])


def _region_inside(region, box, need: float, spacing: float):
    """The deepest a polygon's or ball's region reaches into the box
    ``[lo, hi]`` (dim, 2), and where, at positions of a lattice of the
    given spacing (at most about 10^5 of them): over every position inside
    the region, and over those whose axis-aligned cube of half-width
    ``need`` lies inside it (``(0, None)`` where none)."""
    dim = box.shape[0]
    bounds = region.bounds()
    low = np.maximum(bounds[:, 0], box[:, 0])
    high = np.minimum(bounds[:, 1], box[:, 1])
    if (high <= low).any():
        return (0., None), (0., None)
    spacing = max(spacing, float(np.prod(high - low) / 1e5) ** (1. / dim))
    axes = [np.linspace(lo, hi, max(int(np.ceil((hi - lo) / spacing)), 1)
                        + 1) for lo, hi in zip(low, high)]
    y = np.stack([a.ravel() for a in np.meshgrid(*axes, indexing="ij")])
    # a cube of half-width r lies inside a ball of radius r sqrt(dim)
    inner = -region.distance(y) / math.sqrt(dim)
    depth = np.min(np.minimum(y - box[:, :1], box[:, 1:] - y), axis=0)
    found = []
    for keep in (inner > 0., inner >= need):
        if not keep.any():
            found.append((0., None))
            continue
        k = np.flatnonzero(keep)[np.argmax(depth[keep])]
        found.append((float(depth[k]), y[:, k]))
    return found


def _obstacles_placed(c, obstacles, bodies, grid, static: bool,
                      system: str):
    """An obstacle that never reaches the grid, and (a static scene) a
    box obstacle, not a tied one, overlapping a body at the start by
    more than its tolerance, are refused before any work, naming the
    table and the overlap in the scene's length unit (a trial's was
    refused after the set-up, "0.5 inside" and no unit; the run refuses
    no tied obstacle for lying inside a body).  A polygon's or ball's
    body is refused where its seeded points must have a domain corner
    deeper inside than the tolerance (a trial's disc was refused after
    the set-up, in the old words)."""
    length = unit("length", system, len(grid.axes))
    bounds = np.array([[lo, hi] for lo, hi, _ in grid.axes])
    widths = [(hi - lo) / n for lo, hi, n in grid.axes]
    cells = np.prod(widths) ** (1. / len(grid.axes))
    for k, ob in enumerate(obstacles):
        if ob is None:
            continue
        key = "obstacles[{}]".format(k)
        try:
            check_obstacles([ob], len(grid.axes), bounds)
        except InvalidInputError as err:
            c.problems.append("{}: {} (lengths in {})".format(
                key, err, length))
            continue
        if not static or getattr(ob, "box", None) is None \
                or ob.friction == "tied":
            continue    # (in dynamics it may start displaced; a tied one
            #              may hold material inside it, as the run allows)
        shown = {AXES[d]: list(b) for d, b in enumerate(ob.box.tolist())}
        for body in bodies:
            if body is None or region_shape(body.region) == "function":
                continue
            if region_shape(body.region) != "box":
                # a point is seeded at each sub-cell centre inside the
                # region, its domain corners within a sub-cell of it
                # (its sub-cell's, or a cube of its volume's side): a
                # position whose cube of half a sub-cell lies in the
                # region has a point within half a sub-cell, its corners
                # within one sub-cell, so deeper than a sub-cell and the
                # tolerance inside the box, the run refuses it
                sub = max(widths) / body.points_per_cell
                (reach, where), (deep, _) = _region_inside(
                    body.region, ob.box, sub / 2, sub / 8)
                if deep > sub + ob.tolerance * max(widths):
                    c.bad(key + ".box", "obstacle {!r} overlaps body {!r} "
                          "at the start: its {} reaches about {:.2g} {} into "
                          "it "
                          "(at [{}]): it would hold material inside it; "
                          "move the obstacle or shrink the body".format(
                              ob.name or "", body.name,
                              region_shape(body.region), reach, length,
                              ", ".join("{:.4g}".format(v) for v in where)),
                          shown)
                continue
            box = np.array(body.region, float)
            low = np.maximum(box[:, 0], ob.box[:, 0])
            high = np.minimum(box[:, 1], ob.box[:, 1])
            # the overlap's middle lies half its least extent inside the
            # obstacle (the run refuses a point's domain corner deeper
            # than the tolerance; this, twice that, only the clear cases)
            across = float(np.min(high - low))
            if across > 2 * ob.tolerance * cells:
                c.bad(key + ".box", "obstacle {!r} overlaps body {!r} "
                      "at the start, {:.3g} {} across (where {}): it would "
                      "hold material inside it; move the obstacle or "
                      "shrink the body".format(
                          ob.name or "", body.name, across, length,
                          ", ".join("{} in [{!r}, {!r}]".format(
                              AXES[d], float(lo), float(hi)) for d, (lo, hi)
                              in enumerate(zip(low, high)))), shown)


def parse_scene(data: dict, source: str = "") -> Scene:
    """Build a :class:`~skfem_mpm.scenes.scene.Scene` from a parsed TOML tree.

    Raises
    ------
    SceneError
        Listing every problem found.
    """
    c = _Checker()
    c.table(data, "", ("name", "units", "reference", "grid", "bodies",
                       "supports", "gravity", "point_loads", "tractions",
                       "solver", "dynamics", "outputs", "obstacles",
                       "contacts"),
            ("grid", "bodies"))
    grid = _grid(c, data.get("grid", {}))
    grid_read = not c.problems
    dim = len(grid.axes)
    bodies = [_body(c, b, k, dim) for k, b in
              enumerate(c.array(data, "bodies"))]
    if grid_read:
        _inside_grid(c, bodies, grid)
    if "bodies" in data and not bodies:
        c.problems.append("bodies: at least one [[bodies]] table is needed")
    supports = []
    for k, s in enumerate(c.array(data, "supports")):
        key = "supports[{}]".format(k)
        s = c.table(s, key, ("boundary", "at", "region", "components",
                             "value", "name", "bodies"))
        at = boundary = box = None
        if sum(k in s for k in ("boundary", "at", "region")) != 1:
            c.bad(key, "needs exactly one of boundary, at, region", s)
        elif "at" in s:
            at = c.vector(s, key, "at", dim, [0.] * dim)
        elif "region" in s:
            box = _body_region(c, s["region"], key + ".region", dim,
                               closed=True)
            if isinstance(s["region"], dict) and not s["region"]:
                c.bad(key + ".region", "names no axis: it would hold every "
                      "grid node", s["region"])
        else:
            boundary = _support_sides(c, s, key, dim)
        comps = s.get("components", list(AXES[:dim]))
        if not isinstance(comps, list) or not comps or not all(
                x in AXES[:dim] for x in comps):
            c.bad(key + ".components", "must be a list of {}".format(
                ", ".join(AXES[:dim])), comps)
            comps = list(AXES[:dim])
        value = c.vector(s, key, "value", len(comps), why=", one per "
                         "component held ({})".format(", ".join(comps)))
        name = s.get("name")
        if name is not None and (not isinstance(name, str) or not name):
            c.bad(key + ".name", "must be a non-empty string", name)
            name = None
        elif name is not None and name in [x.name for x in supports]:
            c.bad(key + ".name", "names another support too", name)
        moved = s.get("bodies")
        if moved is not None and (not isinstance(moved, list) or not moved
                                  or not all(isinstance(b, str)
                                             for b in moved)):
            c.bad(key + ".bodies", "must be a list of body names (the "
                  "bodies a moving support moves)", moved)
            moved = None
        elif moved is not None and "value" not in s:
            c.bad(key + ".bodies", "needs a value: the bodies a moving "
                  "support moves", moved)
            moved = None
        elif value is None:   # a value refused above: said once (a trial
            moved = None      # read a follow-on error about its bodies)
        supports.append(Support(boundary=boundary, at=at, region=box,
                                components=comps, value=value, name=name,
                                bodies=moved))
    gravity = acceleration = None
    gravity_ramp = True
    if "gravity" in data:
        g = c.table(data["gravity"], "gravity",
                    ("body_force", "acceleration", "ramp"), ())
        gravity_ramp = c.boolean(g, "gravity", "ramp", True)
        if not gravity_ramp and "dynamics" in data:
            c.bad("gravity.ramp", "a dynamic scene's loads follow "
                  "[dynamics] load_ramp", False)
        if ("body_force" in g) == ("acceleration" in g):
            c.bad("gravity", "needs body_force (per unit volume) or "
                  "acceleration (times each body's density), one of them",
                  sorted(g))
        elif "body_force" in g:
            gravity = c.vector(g, "gravity", "body_force", dim)
        else:
            acceleration = c.vector(g, "gravity", "acceleration", dim)
    loads = []
    for k, p in enumerate(c.array(data, "point_loads")):
        key = "point_loads[{}]".format(k)
        p = c.table(p, key, ("at", "force", "points"), ("at", "force"))
        loads.append(PointLoad(
            at=c.vector(p, key, "at", dim, [0.] * dim),
            force=c.vector(p, key, "force", dim, [0.] * dim),
            count=c.number(p, key, "points", 1, low=1, open_low=False,
                           integer=True)))
    tractions = []
    names = [b.name for b in bodies]
    for k, t in enumerate(c.array(data, "tractions")):
        key = "tractions[{}]".format(k)
        t = c.table(t, key, ("body", "side", "traction", "pressure",
                             "ramp"), ("body", "side"))
        if ("traction" in t) == ("pressure" in t):
            c.bad(key, "needs exactly one of traction, pressure", t)
        body = t.get("body")
        if body is not None and body not in names:
            c.bad(key + ".body", "must name a body ({})".format(
                ", ".join(names)), body)
        tractions.append(Traction(
            body=body, side=c.side(t, key, "side", dim),
            traction=c.vector(t, key, "traction", dim) if "traction" in t
            else None,
            pressure=c.number(t, key, "pressure", 0.) if "pressure" in t
            else None, ramp=c.boolean(t, key, "ramp", True)))
    obstacles = [_obstacle(c, o, "obstacles[{}]".format(k), dim)
                 for k, o in enumerate(c.array(data, "obstacles"))]
    contacts = [_contact(c, t, "contacts[{}]".format(k), bodies)
                for k, t in enumerate(c.array(data, "contacts"))]
    outputs = []
    for k, q in enumerate(c.array(data, "outputs")):
        try:
            outputs.append(parse_quantity(q, dim, "outputs[{}]".format(k)))
        except InvalidInputError as err:
            c.problems.append(str(err))
    solver = c.table(data.get("solver", {}), "solver",
                     ("method", "kinematics", "steps", "tolerance",
                      "max_iterations", "linear", "kernels", "antilocking",
                      "extended_splines", "ghost", "rhs", "line_search",
                      "newton", "grow_back"))
    method = c.choice(solver, "solver", "method", METHODS, "mpm")
    dynamics = _dynamics(c, data["dynamics"]) if "dynamics" in data else None
    if dynamics is not None and "steps" in solver:
        c.bad("solver.steps", "a dynamic scene takes its steps from "
              "[dynamics] (duration / time_step): it would be ignored",
              solver["steps"])
    kinematics = c.choice(solver, "solver", "kinematics", KINEMATICS, "small")
    steps = None if dynamics is not None else c.number(
        solver, "solver", "steps", None, low=1, open_low=False, integer=True)
    newton = c.option(NewtonOptions, "solver", (
        ("tol", "tolerance", c.number(solver, "solver", "tolerance", 1e-9,
                                      low=0.)),
        ("max_iter", "max_iterations", c.number(
            solver, "solver", "max_iterations", 25, low=1, open_low=False,
            integer=True)),
        ("rhs", "rhs", c.choice(solver, "solver", "rhs", RHS, "residual")),
        ("line_search", "line_search", c.choice(
            solver, "solver", "line_search", LINE_SEARCHES, "backtracking")),
        ("newton", "newton", c.choice(solver, "solver", "newton", NEWTON,
                                      "full")),
        ("grow_back", "grow_back", c.boolean(solver, "solver",
                                             "grow_back"))))
    stabilisation = c.option(Stabilisation, "solver", (
        ("antilocking", "antilocking", c.antilocking(solver)),
        ("extended_splines", "extended_splines", c.boolean(
            solver, "solver", "extended_splines")),
        ("ghost", "ghost", "auto" if solver.get("ghost", "auto") == "auto"
         else c.number(solver, "solver", "ghost", "auto", low=0.,
                       open_low=False))))
    scene = Scene(
        grid=grid, bodies=bodies, supports=supports, gravity=gravity,
        acceleration=acceleration,
        point_loads=loads, tractions=tractions, method=method,
        kinematics=kinematics, nsteps=steps, dynamics=dynamics,
        newton=newton, stabilisation=stabilisation, name=_name(c, data),
        reference=c.choice(data, "", "reference", REFERENCES + (None,)),
        solver=linear_solver(c, solver),
        kernels=c.choice(solver, "solver", "kernels", KERNELS, "auto"),
        outputs=outputs, obstacles=[o for o in obstacles if o is not None],
        contacts=[t for t in contacts if t is not None],
        units=c.choice(data, "", "units", SYSTEMS, "SI"),
        gravity_ramp=gravity_ramp)
    if not c.problems:
        try:
            scene.check()
        except Exception as err:
            c.problems.append("scene: {}".format(err))
    if not c.problems:
        _supports_on_grid(c, supports, grid)
        _obstacles_placed(c, obstacles, bodies, grid, dynamics is None,
                          scene.units)
    if outputs and not c.problems:
        try:
            check_quantities(scene, outputs, key="outputs")
        except SceneError as err:
            c.problems.extend(err.problems)
        except InvalidInputError as err:
            c.problems.append(str(err))
    if not (supports or obstacles) and dynamics is None and \
            not c.problems:
        c.problems.append("supports: missing: without supports or "
                          "obstacles every body can move freely")
    if c.problems:
        raise SceneError(c.problems, source)
    return scene


#: larger files are refused unread (a scene file is a few kB)
MAX_SCENE_BYTES = 1 << 20


def load_scene(path) -> Scene:
    """Read and validate a scene file.

    Examples
    --------
    >>> from pathlib import Path
    >>> import skfem_mpm
    >>> from skfem_mpm.scenes.scene_file import load_scene
    >>> scene = load_scene(Path(skfem_mpm.__file__).parent / "scenes" / "column.toml")
    >>> scene.nsteps, scene.method
    (20, 'mpm')

    """
    path = Path(path)
    try:
        if not path.is_file():       # a FIFO would block, /dev/zero not end
            raise SceneError(["{}: not a regular file".format(path)])
        if path.stat().st_size > MAX_SCENE_BYTES:
            raise SceneError(["{}: {} bytes, more than a scene file's {}"
                              .format(path, path.stat().st_size,
                                      MAX_SCENE_BYTES)])
        raw = path.read_bytes()
    except OSError as err:
        raise SceneError(["{}: cannot be read ({})".format(path, err)])
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SceneError(["{}: not UTF-8 text as TOML requires ({}); save it "
                          "as UTF-8".format(path, err)])
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(["{}: not valid TOML: {}".format(path, err)])
    except RecursionError:
        raise SceneError(["{}: nested too deeply to be a scene".format(path)])
    return parse_scene(data, str(path))
