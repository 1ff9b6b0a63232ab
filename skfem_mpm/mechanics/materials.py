"""Constitutive models and the protocol they follow.

Stresses and strains are full symmetric 3x3 tensors, shape (3, 3, ...):
plane strain is the 3D law with ``eps_zz = eps_xz = eps_yz = 0`` and 1D is
uniaxial strain (all lateral strains zero), so one law serves every
dimension.

The material protocol
---------------------
A material is an object with

- ``lam``, ``mu``: elastic Lame parameters (they scale the ghost penalty
  and the mean dilatation, and give the elastic tangent);
- ``plastic``: ``True`` if an update may involve a return map (a purely
  elastic body never runs one);
- ``state_variables``: a dict ``{name: initial value}`` of the per-point
  internal variables the model carries (e.g. the equivalent plastic
  strain); the points carry them in ``MaterialPoints.state`` through steps,
  checkpoints and output without the solver knowing their meaning;
- ``principal_update(eps, state) -> (tau, eps_e, D, yielded, new_state)``:
  the isotropic return map on principal values, vectorised over points:
  trial elastic strains ``eps`` (3, n) (logarithmic in finite deformation,
  infinitesimal in small strain), the state at the start of the step
  (``{name: (n,) array}``, read-only) to principal stresses ``tau``
  (Kirchhoff in finite deformation, Cauchy in small strain), elastic
  strains ``eps_e`` (3, n), the algorithmic tangent ``D = dtau/deps``
  (3, 3, n), the points that yielded (n,) and the new state;
- ``stress(strain)`` for elastic materials: the linear law, which small
  strain uses without any return map;
- ``elastic_strain(tau)``: principal elastic strains (3, n) of principal
  stresses (3, n), the inverse of the elastic law (an initial stress,
  :func:`~skfem_mpm.geostatic_stress` and the element tests start from
  it); optional: without it the linear law of ``lam`` and ``mu`` is
  inverted (:func:`inverse_elastic_law`);
- ``isochoric_flow``: optional, ``True`` where the plastic flow keeps the
  volume (von Mises, a soil without dilation), for the warning of
  volumetric locking of a run without anti-locking.

The kinematics (:mod:`skfem_mpm.mechanics.kinematics`) turn principal
values into tensors and consistent tangents, so a model written once works
in small strain and in finite deformation.  What a model of the user's
own returns is checked (:func:`update`: shapes, names, finite values).
``docs/materials.md`` writes a
model of one's own (von Mises with linear isotropic hardening, run by
``tests/test_materials.py``).

"""
import logging
from dataclasses import dataclass

import numpy as np
from numpy import ndarray
from skfem.assembly import BilinearForm
from skfem.models.elasticity import linear_elasticity

from ..errors import (InvalidMaterialError, MaterialProtocolError,
                      MaterialRaisedError, NonFiniteMaterialError,
                      check_real)
from ..protocols import of_package, state_variables

logger = logging.getLogger(__name__)

__all__ = ["LinearElastic", "VonMises", "PointMaterials", "at_points",
           "is_plastic", "elastic_tensor", "state_variables",
           "initial_state", "inverse_elastic_law", "check_moduli",
           "MODULUS_LIMIT", "update", "elastic_stress", "trusted",
           "check_lame"]

#: the largest modulus (Young's, Lame's, shear, bulk or hardening) a
#: material accepts: eight orders below the float64 limit (1.8e308), room
#: for the sums and products that assemble the stiffness (E = 1e308 gave a
#: NaN pivot reported as missing supports; E = 1e300 still runs, its
#: answers scaled to round-off).  Steel is 2e11 Pa (2e14 in mPa): no unit
#: system brings a modulus near it
MODULUS_LIMIT = 1e300


def check_moduli(moduli) -> None:
    """Refuse moduli that float64 arithmetic cannot carry: every
    ``(name, value)`` of ``moduli`` finite and at most
    :data:`MODULUS_LIMIT` in size, or an :class:`InvalidMaterialError`
    naming the first that is not.

    >>> check_moduli([("Young's modulus E", 1e308)])
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidMaterialError: Young's modulus E = 1e+308 is beyond 1e+300, the largest modulus accepted: no unit system needs one so large, and near the float64 limit (1.8e+308) the stiffness assembled from it overflows; give the moduli in larger units (MPa or GPa instead of Pa)
    """
    for name, value in moduli:
        value = float(value)
        if not (np.isfinite(value) and abs(value) <= MODULUS_LIMIT):
            raise InvalidMaterialError(
                "{} = {:.6g} is beyond {:.0e}, the largest modulus accepted: "
                "no unit system needs one so large, and near the float64 "
                "limit ({:.2g}) the stiffness assembled from it overflows; "
                "give the moduli in larger units (MPa or GPa instead of "
                "Pa)".format(name, value, MODULUS_LIMIT, np.finfo(float).max))


@dataclass(frozen=True)
class LinearElastic:
    """Isotropic linear elasticity, seed (2.1) and (2.3).

    Parameters
    ----------
    E
        Young's modulus, positive.
    nu
        Poisson's ratio in (-1, 0.5).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm.mechanics.materials import LinearElastic
    >>> mat = LinearElastic(E=1e6, nu=0.)
    >>> eps = np.zeros((3, 3, 1)); eps[0, 0] = 1e-3
    >>> float(mat.stress(eps)[0, 0, 0])
    1000.0

    """
    E: float
    nu: float

    plastic = False
    state_variables = {}

    def __post_init__(self):
        E = check_real("Young's modulus E", self.E, InvalidMaterialError)
        nu = check_real("Poisson's ratio nu", self.nu, InvalidMaterialError)
        if not np.isfinite(E) or E <= 0:
            raise InvalidMaterialError(
                "Young's modulus E must be positive and finite, got {}"
                .format(self.E))
        if not np.isfinite(nu) or not -1. < nu < .5:
            raise InvalidMaterialError(
                "Poisson's ratio nu must lie in (-1, 0.5), got {}"
                .format(self.nu))
        with np.errstate(over="ignore", invalid="ignore"):
            check_moduli([
                ("Young's modulus E", E),
                ("the Lame parameter lam = E nu / ((1 + nu) (1 - 2 nu)) "
                 "(E = {:.6g}, nu = {!r})".format(E, nu), self.lam),
                ("the shear modulus mu (E = {:.6g})".format(E), self.mu)])

    @property
    def lam(self) -> float:
        """First Lame parameter."""
        return self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))

    @property
    def mu(self) -> float:
        """Shear modulus."""
        return self.E / (2 * (1 + self.nu))

    def stress(self, strain: ndarray) -> ndarray:
        """Stress of a (3, 3, ...) strain: ``2 mu eps + lam tr(eps) I``."""
        trace = np.einsum("ii...->...", strain)
        out = 2 * self.mu * strain
        for i in range(3):
            out[i, i] += self.lam * trace
        return out

    def principal_update(self, eps: ndarray, state=None):
        """Principal stresses of principal elastic strains (3, n): Hencky
        hyperelasticity in finite deformation, Hooke's law in small strain.
        Returns ``(tau, eps_e, D, yielded, state)`` with the tangent
        ``D = dtau/deps`` (3, 3, n) and an empty state: an elastic law
        has no internal variables."""
        tau = 2 * self.mu * eps + self.lam * eps.sum(axis=0)
        D = np.broadcast_to(self.principal_stiffness()[:, :, None],
                            (3, 3, eps.shape[1]))
        return tau, eps, D, np.zeros(eps.shape[1], dtype=bool), {}

    def principal_stiffness(self) -> ndarray:
        """``lam 1 (x) 1 + 2 mu I`` on principal values, (3, 3)."""
        return self.lam * np.ones((3, 3)) + 2 * self.mu * np.eye(3)

    def elastic_strain(self, tau: ndarray) -> ndarray:
        """Principal elastic strains (3, n) of principal stresses (3, n):
        the inverse of the elastic law."""
        return np.linalg.solve(self.principal_stiffness(), tau)

    def stiffness_form(self) -> BilinearForm:
        """The tangent stiffness as a scikit-fem form, seed (2.20)."""
        return linear_elasticity(self.lam, self.mu)


@dataclass(frozen=True)
class VonMises(LinearElastic):
    """Von Mises elasto-plasticity, linear elastic and perfectly plastic,
    with the radial return map in principal strains (logarithmic ones in
    finite deformation: the exponential map).  Internal variable:
    ``equivalent_plastic_strain``, ``sqrt(2/3) |eps_p|`` accumulated.

    Parameters
    ----------
    E, nu
        Elastic constants as in :class:`LinearElastic`.
    yield_stress
        Uniaxial yield stress (of the Kirchhoff stress), positive.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm.mechanics.materials import VonMises
    >>> mat = VonMises(E=1e6, nu=0.3, yield_stress=20e3)
    >>> eps = np.array([[0.05], [-0.05], [0.]])
    >>> tau, eps_e, D, yielded, state = mat.principal_update(
    ...     eps, {"equivalent_plastic_strain": np.zeros(1)})
    >>> bool(yielded[0]), round(float(np.sqrt(1.5) * np.linalg.norm(
    ...     tau[:, 0] - tau[:, 0].mean())), 6)
    (True, 20000.0)

    """
    yield_stress: float

    plastic = True
    #: its plastic flow keeps the volume (:func:`~skfem_mpm.stabilisation.
    #: settings.warn_volumetric_locking`)
    isochoric_flow = True
    state_variables = {"equivalent_plastic_strain": 0.}

    def __post_init__(self):
        super().__post_init__()
        yield_stress = check_real("yield_stress", self.yield_stress,
                                  InvalidMaterialError)
        if not yield_stress > 0 or not np.isfinite(yield_stress):
            raise InvalidMaterialError(
                "yield_stress must be positive, got {}".format(
                    self.yield_stress))

    def principal_update(self, eps: ndarray, state):
        """The radial return from the elastic trial of principal
        elastic strains ``eps`` (3, n): ``(tau, eps_e, D, yielded,
        state)`` with the consistent tangent and the updated
        ``equivalent_plastic_strain`` of ``state``."""
        tau, _, D, _, _ = LinearElastic.principal_update(self, eps)
        p = tau.mean(axis=0)
        s = tau - p
        norm_s = np.linalg.norm(s, axis=0)
        q = np.sqrt(1.5) * norm_s
        yielded = q > self.yield_stress * (1 + 1e-12)
        eq = state["equivalent_plastic_strain"]
        if not yielded.any():
            return tau, eps, D, yielded, {"equivalent_plastic_strain": eq}
        ratio = np.where(yielded, self.yield_stress / np.where(yielded, q, 1.),
                         1.)
        tau = p + ratio * s
        bulk = self.E / (3 * (1 - 2 * self.nu))
        eps_e = np.where(yielded, self.elastic_strain(tau), eps)
        n = s / np.where(norm_s > 0, norm_s, 1.)
        dev = np.eye(3) - np.ones((3, 3)) / 3
        Dp = bulk * np.ones((3, 3, 1)) + 2 * self.mu * ratio * (
            dev[:, :, None] - np.einsum("ap,bp->abp", n, n))
        D = np.where(yielded, Dp, D)
        # plastic multiplier: (q_trial - yield) / (3 mu) on the yielded points
        eq = eq + np.where(yielded, q - self.yield_stress, 0.) / (3 * self.mu)
        return tau, eps_e, D, yielded, {"equivalent_plastic_strain": eq}


class PointMaterials:
    """Several materials, one per body: point p follows
    ``materials[body[p]]``.

    Offers what the solvers use of a single material (``lam``, ``mu`` and
    ``stress`` per point, ``principal_update``) so that bodies of different
    materials share one grid.  The compiled passes serve it where they
    cover every body's material, each point taking its body's parameters
    (:func:`~skfem_mpm.mechanics.compiled.body_parameters`); this class is
    the numpy path, their reference.

    """

    def __init__(self, materials, body: ndarray):
        self.materials = list(materials)
        self.body = np.asarray(body)
        if self.body.max() >= len(self.materials):
            raise InvalidMaterialError(
                "points refer to body {} but only {} material(s) are given"
                .format(int(self.body.max()), len(self.materials)))
        self.lam = np.array([m.lam for m in self.materials])[self.body]
        self.mu = np.array([m.mu for m in self.materials])[self.body]
        self.plastic = any(m.plastic for m in self.materials)
        self.state_variables = state_variables(self.materials)

    def take(self, points) -> "PointMaterials":
        """The materials of a subset of the points (an index or slice)."""
        return PointMaterials(self.materials, self.body[points])

    def stress(self, strain: ndarray, where=0) -> ndarray:
        """``2 mu eps + lam tr(eps) I`` with per-point Lame parameters
        where every body's model is the package's own; else each body's
        ``stress`` on its points (through :func:`elastic_stress`,
        ``where`` as there), as a single material's is called."""
        if all(trusted(m) for m in self.materials):
            return LinearElastic.stress(self, strain)
        out = np.empty(np.shape(strain))
        for k, material in enumerate(self.materials):
            sel = np.flatnonzero(self.body == k)
            if sel.size:
                out[..., sel] = elastic_stress(material, strain[..., sel],
                                               run_indices(where, sel))
        return out

    def elastic_strain(self, tau: ndarray) -> ndarray:
        """Each body's inverse elastic law on its points."""
        out = np.empty_like(tau)
        for k, material in enumerate(self.materials):
            sel = np.flatnonzero(self.body == k)
            if sel.size:
                out[:, sel] = inverse_elastic_law(material, tau[:, sel])
        return out

    def principal_update(self, eps: ndarray, state, where=0):
        """Each body's model on its points (through :func:`update`,
        ``where`` as there); a body's internal variables stay unchanged
        on the points of other bodies."""
        tau, eps_e = np.empty_like(eps), np.empty_like(eps)
        D = np.empty((3, 3, eps.shape[1]))
        yielded = np.zeros(eps.shape[1], dtype=bool)
        new = {name: value.copy() for name, value in state.items()}
        for k, material in enumerate(self.materials):
            sel = np.flatnonzero(self.body == k)
            if sel.size:
                tau[:, sel], eps_e[:, sel], D[:, :, sel], yielded[sel], \
                    mine = update(
                        material, eps[:, sel],
                        {name: state[name][sel]
                         for name in getattr(material, "state_variables",
                                             {})},
                        run_indices(where, sel))
                for name, value in mine.items():
                    new[name][sel] = value
        return tau, eps_e, D, yielded, new


def at_points(material, points) -> object:
    """The material of every point: ``material`` itself, or a
    :class:`PointMaterials` when a list of materials (one per body) is
    given."""
    materials = list(material) if isinstance(material, (list, tuple)) \
        else [material]
    for k, m in enumerate(materials):
        missing = [name for name in ("lam", "mu", "principal_update")
                   if not hasattr(m, name)]
        if missing or not (is_plastic(m) or hasattr(m, "stress")):
            raise InvalidMaterialError(
                "material {}{} does not follow the material protocol (see "
                "skfem_mpm.mechanics.materials): it lacks {}".format(
                    "{} ".format(k) if len(materials) > 1 else "",
                    type(m).__name__,
                    ", ".join(missing or [
                        "stress (a material with plastic = False is "
                        "linear elastic and needs stress(strain), its "
                        "linear law; a nonlinear elastic model, e.g. a "
                        "hyperelastic one of its own, sets plastic = "
                        "True: its principal_update is then called in "
                        "small strain and finite deformation alike; "
                        "docs/materials.md)"])))
        if not trusted(m):
            check_lame(m, "material {}{}".format(
                "{} ".format(k) if len(materials) > 1 else "",
                type(m).__name__))
    if not isinstance(material, (list, tuple)):
        return material
    used = int(points.body.max()) + 1
    if len(materials) != used:
        raise InvalidMaterialError(
            "{} materials are given, one per body, but the points belong to "
            "{} bod{} ({}): the materials and the bodies must match".format(
                len(materials), used, "y" if used == 1 else "ies",
                bodies_words(points.body)))
    return PointMaterials(materials, points.body)


def warn_empty_bodies(points) -> None:
    """Log a warning where a body index from 0 to the largest holds no
    point: its material and body force act on nothing (a ported model's
    1-based ids 1 and 2 with three materials, body 0 a dummy, ran
    silently; an excavated body's stage, by design).  ``simulate`` and
    :func:`~skfem_mpm.geostatic_stress` say it."""
    if (np.bincount(points.body) == 0).any():
        logger.warning(
            "a body holds no point (%s): its material and body force act "
            "on nothing; ids of one's own counted from 1 need "
            "body - 1 (an excavated body's stage: by design)",
            bodies_words(points.body))


def bodies_words(body: ndarray) -> str:
    """The bodies the points' ``body`` indices hold, in words, and those
    from 0 up that hold none: body ids count from 0 (a ported model's ids
    1 and 2 asked for 3 materials and body forces, blamed on their
    count).

    >>> bodies_words(np.array([1, 2, 2]))
    'body ids count from 0 to 2; the points hold bodies [1, 2], body 0 none'
    >>> bodies_words(np.array([0, 1]))
    'body ids count from 0 to 1; the points hold bodies [0, 1]'
    """
    counts = np.bincount(body)
    held, empty = np.flatnonzero(counts), np.flatnonzero(counts == 0)
    return "body ids count from 0 to {}; the points hold bod{} {}{}".format(
        counts.size - 1, "y" if held.size == 1 else "ies", held.tolist(),
        "" if not empty.size else ", bod{} {} none".format(
            "y" if empty.size == 1 else "ies",
            empty[0] if empty.size == 1 else empty[:10].tolist()))


def check_lame(material, label: str) -> None:
    """Refuse a material of the user's own whose ``lam`` and ``mu`` are
    not real and finite, or give a shear modulus ``mu`` or a bulk modulus
    ``lam + 2 mu / 3`` that is not positive (the shipped models' ``E > 0``
    and ``-1 < nu < 0.5``): :class:`InvalidMaterialError` naming
    ``label`` and the values.  A negative modulus ran into
    PointsOutsideGridError after a warning of 394% strain.

    >>> class Soft:
    ...     lam, mu = 1e4, -3e3
    >>> check_lame(Soft(), "material Soft")
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidMaterialError: material Soft: its shear modulus mu = -3000 must be positive (the shipped models' E > 0, -1 < nu < 0.5)
    """
    try:
        lam = np.asarray(material.lam, dtype=float)
        mu = np.asarray(material.mu, dtype=float)
    except (TypeError, ValueError) as err:
        raise InvalidMaterialError("{}: lam and mu must be numbers, got {!r}"
                                   " and {!r} ({})".format(
                                       label, material.lam, material.mu,
                                       err)) from None
    with np.errstate(over="ignore", invalid="ignore"):
        bulk = lam + 2 * mu / 3
    for name, value in (("Lame parameter lam", lam), ("shear modulus mu", mu),
                        ("bulk modulus lam + 2 mu / 3", bulk)):
        bad = ~(np.isfinite(value) & (value > 0 if name != "Lame parameter "
                                      "lam" else True))
        if np.any(bad):
            raise InvalidMaterialError(
                "{}: its {} = {:.6g} must be {} (the shipped models' E > 0, "
                "-1 < nu < 0.5)".format(
                    label, name, np.ravel(value)[np.flatnonzero(bad)[0]],
                    "finite" if name.startswith("Lame") else "positive"))
    check_moduli([(label + "'s lam", np.max(np.abs(lam))),
                  (label + "'s mu", np.max(np.abs(mu)))])


def is_plastic(material) -> bool:
    """Whether a stress update may involve a return map."""
    return bool(getattr(material, "plastic", False))


def elastic_tensor(material, n: int, dim: int) -> ndarray:
    """``C_abcd = lam d_ab d_cd + mu (d_ac d_bd + d_ad d_bc)`` of every
    point, (dim, dim, dim, dim, n): the small-strain tangent (2.3) in the
    form the point operators assemble; a read-only broadcast of one tensor when the moduli are uniform."""
    eye = np.eye(dim)
    lam = material.lam
    mu = material.mu
    if np.ndim(lam) == 0 and np.ndim(mu) == 0:     # one tensor for all
        C = (lam * np.einsum("ab,cd->abcd", eye, eye)
             + mu * (np.einsum("ac,bd->abcd", eye, eye)
                     + np.einsum("ad,bc->abcd", eye, eye)))
        return np.broadcast_to(C[..., None], C.shape + (n,))
    lam = np.broadcast_to(lam, (n,))
    mu = np.broadcast_to(mu, (n,))
    return (np.einsum("ab,cd,p->abcdp", eye, eye, lam)
            + np.einsum("ac,bd,p->abcdp", eye, eye, mu)
            + np.einsum("ad,bc,p->abcdp", eye, eye, mu))


def inverse_elastic_law(material, tau: ndarray) -> ndarray:
    """Principal elastic strains (3, n) of principal stresses (3, n): the
    material's ``elastic_strain`` where it has one, else the inverse of
    the linear law of its ``lam`` and ``mu`` (scalars or one per point).

    >>> import numpy as np
    >>> inverse_elastic_law(LinearElastic(1e3, 0.), np.array([[1.], [0.], [0.]]))
    array([[0.001],
           [0.   ],
           [0.   ]])
    """
    if hasattr(material, "elastic_strain"):
        return material.elastic_strain(tau)
    lam, mu = material.lam, material.mu
    return (tau - lam / (3 * lam + 2 * mu) * tau.sum(axis=0)) / (2 * mu)


def initial_state(material, n: int) -> dict:
    """The internal variables of ``n`` points at their initial values."""
    return {name: np.full(n, float(value)) for name, value in
            getattr(material, "state_variables", {}).items()}


def trusted(material) -> bool:
    """Whether ``material`` is one of the package's own (its class defined
    in skfem_mpm, not a user's subclass: :func:`~skfem_mpm.protocols.
    of_package`): :func:`update` does not check what it returns (its
    tests do)."""
    return of_package(material)


def run_indices(where, local: ndarray) -> ndarray:
    """The run's indices of points ``local`` of a part of the run's
    points: ``where`` the index of the part's first point, or the run's
    index of each of its points."""
    return local + where if np.ndim(where) == 0 else np.asarray(where)[local]


def _fault(material, method, variable, text, indices=None,
           error=MaterialProtocolError):
    return error("{}.{} {}".format(type(material).__name__, method, text),
                 material=type(material).__name__, method=method,
                 variable=variable, indices=indices)


def _non_finite(material, method, variable, value, n, where):
    """The error for NaN or inf in ``value`` (..., n), or ``None``; a sum
    first (one pass; a finite sum is finite entries, an overflowing one
    goes on to the entries)."""
    with np.errstate(over="ignore", invalid="ignore"):
        if np.isfinite(np.sum(value)):
            return None
    bad = np.flatnonzero(~np.isfinite(np.reshape(value, (-1, n))).all(
        axis=0))
    if not bad.size:
        return None
    at = run_indices(where, bad)
    return _fault(material, method, variable,
                  "returned NaN or inf in {} at {} point(s), the first {} "
                  "(the run's point indices)".format(
                      variable, bad.size, at[:5].tolist()),
                  at[:5].tolist(), NonFiniteMaterialError)


def _written(material, eps, state) -> list:
    """The names of ``state`` that ``material.principal_update`` writes
    into (it raised on read-only views): a second call on copies, the
    arrays compared; ``None`` where that call fails too."""
    copies = {name: np.array(value) for name, value in state.items()}
    try:
        material.principal_update(eps, copies)
    except Exception:
        return None
    return [name for name, value in state.items() if not np.array_equal(
        value, copies[name], equal_nan=True)]


def update(material, eps: ndarray, state, where=0):
    """``material.principal_update(eps, state)`` of the load steps, with
    what a material of the user's own returns checked (``where``: the
    run's index of the first of these points, or of each; for the
    errors' words).  A user's model gets read-only views of the
    variables its ``state_variables`` declare, and only those (``state``
    may hold more: the run's own, a contact's, other bodies'), as
    :class:`PointMaterials` hands each body's model; a model writing into
    them, against the protocol, raises
    :class:`~skfem_mpm.errors.MaterialProtocolError` naming the
    variables; its return is checked, vectorised: ``tau`` and
    ``eps_e`` (3, n), ``D`` (3, 3, n), ``yielded`` a bool (n,), the new
    state exactly its ``state_variables`` each (n,)
    (:class:`~skfem_mpm.errors.MaterialProtocolError`), every value
    finite (:class:`~skfem_mpm.errors.NonFiniteMaterialError`, naming
    the points).  The package's own models (:func:`trusted`) are called
    as they are.

    >>> import numpy as np
    >>> class Leaky(LinearElastic):
    ...     def principal_update(self, eps, state):
    ...         return LinearElastic.principal_update(self, eps)[:4] + (
    ...             {"junk": eps[0]},)
    >>> Leaky.__module__ = "my_models"         # (a doctest's is ours)
    >>> update(Leaky(1e3, .3), np.zeros((3, 2)), {})
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.MaterialProtocolError: Leaky.principal_update returned a new_state with 'junk', which its state_variables ({}) do not declare (it would be carried into the output and checkpoints): return exactly the declared variables
    """
    if trusted(material):
        if isinstance(material, PointMaterials):
            return material.principal_update(eps, state, where)
        return material.principal_update(eps, state)
    method = "principal_update"
    declared = getattr(material, "state_variables", {})
    state = {} if state is None else {name: state[name] for name in
                                      declared}
    given = {}
    for name, value in state.items():
        given[name] = value.view()
        given[name].flags.writeable = False
    try:
        out = material.principal_update(eps, given)
    except (ArithmeticError, np.linalg.LinAlgError) as err:
        # named (it had been "NumericalError: step 1: LinAlgError:
        # Singular matrix" after 8 cut-backs, trial 116)
        raise _fault(material, method, None, "raised {}: {}".format(
            type(err).__name__, err), error=MaterialRaisedError) from err
    except ValueError as err:
        if "read-only" not in str(err):
            raise
        written = _written(material, eps, state)
        if written == []:       # it wrote its state's own values back
            written = list(state) or None
        if written is None:     # an array of its own, not the state given
            raise _fault(material, method, None,
                         "raised ValueError: {}, though not in writing into"
                         " its input state (a call on writable copies of "
                         "it raised too): an array it writes into is "
                         "read-only, e.g. a broadcast such as the D of "
                         "LinearElastic.principal_update; write into a "
                         "copy (np.array(D))".format(err)) from err
        raise _fault(material, method, "state[{!r}]".format(written[0]),
                     "wrote into its input state {} ({}: the state at the "
                     "start of the step is read-only, and a cut-back or a "
                     "later Newton iteration starts from it again): return "
                     "new arrays in new_state (state[{!r}] + 1, not "
                     "state[{!r}] += 1)".format(
                         ", ".join(map(repr, written)), err, written[0],
                         written[0])) from err
    n = eps.shape[1]
    if not isinstance(out, tuple) or len(out) != 5:
        raise _fault(material, method, "return",
                     "returned {} where (tau, eps_e, D, yielded, new_state) "
                     "is expected".format(type(out).__name__ if not
                                          isinstance(out, tuple) else
                                          "{} values".format(len(out))))
    tau, eps_e, D, yielded, new = out
    for variable, value, shape in (("tau", tau, (3, n)),
                                   ("eps_e", eps_e, (3, n)),
                                   ("D", D, (3, 3, n))):
        if np.shape(value) != shape:
            raise _fault(material, method, variable,
                         "returned {} of shape {} where {} is expected (n = "
                         "{} points)".format(variable, np.shape(value),
                                             shape, n))
    if np.shape(yielded) != (n,) or np.asarray(yielded).dtype != bool:
        raise _fault(material, method, "yielded",
                     "returned yielded as {} of shape {} where a bool array "
                     "of shape {} is expected (n = {} points)".format(
                         np.asarray(yielded).dtype, np.shape(yielded), (n,),
                         n))
    if not isinstance(new, dict):
        raise _fault(material, method, "new_state",
                     "returned new_state as {} where a dict of its "
                     "state_variables is expected".format(type(new).__name__))
    missing = [name for name in declared if name not in new]
    extra = [name for name in new if name not in declared]
    if missing or extra:
        raise _fault(material, method, "new_state", "returned a new_state {}"
                     ", which its state_variables ({}) {}: return exactly "
                     "the declared variables".format(
                         "without {}".format(", ".join(map(repr, missing)))
                         if missing else "with {}".format(
                             ", ".join(map(repr, extra))),
                         ", ".join(map(repr, declared)) or "{}",
                         "declare (it would keep its start value)"
                         if missing else "do not declare (it would be "
                         "carried into the output and checkpoints)"))
    new = dict(new)
    for name, value in new.items():
        variable = "new_state[{!r}]".format(name)
        if np.shape(value) != (n,):
            raise _fault(material, method, variable,
                         "returned {} of shape {} where {} is expected (n = "
                         "{} points)".format(variable, np.shape(value), (n,),
                                             n))
        if value is given.get(name):         # unchanged: the points' own
            new[name] = state[name]
        elif not isinstance(value, ndarray) or not value.flags.writeable:
            new[name] = np.array(value, dtype=float)
    for variable, value in (("tau", tau), ("eps_e", eps_e), ("D", D)) + \
            tuple(("new_state[{!r}]".format(name), value)
                  for name, value in new.items()):
        error = _non_finite(material, method, variable, value, n, where)
        if error is not None:
            raise error
    return tau, eps_e, D, yielded, new


def elastic_stress(material, strain: ndarray, where=0) -> ndarray:
    """``material.stress(strain)`` of an elastic body in small strain,
    checked as :func:`update` checks a return map: (3, 3, n), finite (of
    several bodies, each body's model on its points)."""
    if isinstance(material, PointMaterials):
        return material.stress(strain, where)
    stress = material.stress(strain)
    if trusted(material):
        return stress
    n = strain.shape[-1]
    if np.shape(stress) != (3, 3, n):
        raise _fault(material, "stress", "stress",
                     "returned a stress of shape {} where (3, 3, n) = {} is "
                     "expected".format(np.shape(stress), (3, 3, n)))
    error = _non_finite(material, "stress", "stress", stress, n, where)
    if error is not None:
        raise error
    return stress
