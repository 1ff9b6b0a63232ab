"""Element tests: one material point on a homogeneous small-strain path.

The laboratory tests of soil mechanics, driven through a material's
``principal_update`` (the protocol of :mod:`skfem_mpm.mechanics.materials`)
exactly as the load-step core drives it (principal frame, return map,
consistent tangent by :func:`~skfem_mpm.mechanics.hencky.isotropic_derivative`),
so a model can be checked against closed forms before it meets a grid.

:func:`mixed_path` is the general driver: per step, the strain components
it controls are incremented and the others are found by Newton's method so
that their stresses keep their targets.  :func:`triaxial` (drained),
:func:`undrained_triaxial`, :func:`oedometer` and :func:`simple_shear` set
it up; :func:`tangent_error` checks a model's tangent against finite
differences of its stress update.  Stresses are tension
positive; compression tests take positive confining and vertical
stresses and compress.
"""
from typing import NamedTuple, Optional

import numpy as np
from numpy import ndarray

from ..errors import ConvergenceError, InvalidInputError, check_int
from .hencky import isotropic_derivative, principal_frame
from .materials import LinearElastic, initial_state, inverse_elastic_law

__all__ = ["mixed_path", "triaxial", "undrained_triaxial", "oedometer",
           "simple_shear", "tangent_error", "Path", "UndrainedPath"]

#: the smallest tangent entry :func:`tangent_error` divides by
TINY = 1e-300


class Path(NamedTuple):
    """A path of ``nsteps + 1`` states (the initial one first): total
    strains (including the elastic strain of the initial stress) and
    stresses (3, 3, nsteps + 1), the internal variables
    ``{name: (nsteps + 1,)}`` and whether the point yielded in each step
    (the first entry False)."""
    strain: ndarray
    stress: ndarray
    state: dict
    yielded: ndarray

    @property
    def p(self) -> ndarray:
        """Mean stress ``tr(sigma) / 3`` (negative in compression)."""
        return np.einsum("iis->s", self.stress) / 3

    @property
    def q(self) -> ndarray:
        """Von Mises equivalent stress ``sqrt(3 J2)``."""
        s = self.stress - self.p * np.eye(3)[:, :, None]
        return np.sqrt(1.5 * np.einsum("ijs,ijs->s", s, s))


def update(material, eps_e: ndarray, state: dict):
    """Stress (3, 3), elastic strain (3, 3), tangent (3, 3, 3, 3), whether
    it yielded and the new state of one point at the trial elastic strain
    ``eps_e``."""
    x, vecs = principal_frame(eps_e[:, :, None], 3)
    sig, e, D, yielded, new = material.principal_update(
        x, {k: np.atleast_1d(v) for k, v in state.items()})
    stress = np.einsum("Ap,aAp,bAp->ab", sig, vecs, vecs)
    elastic = np.einsum("Ap,aAp,bAp->ab", e, vecs, vecs)
    tangent = isotropic_derivative(x, sig, D, vecs)[..., 0]
    return stress, elastic, tangent, bool(yielded[0]), new


def mixed_path(material, strain_increment: ndarray, controlled: ndarray,
               stress_target: ndarray, nsteps: int,
               initial_stress: ndarray = None, tol: float = 1e-10,
               max_iter: int = 30) -> Path:
    """Drive one point: in each of ``nsteps`` steps the strain components
    where ``controlled`` (3, 3, symmetric, bool) is True grow by
    ``strain_increment / nsteps``; the others are solved so that their
    stress equals ``stress_target`` (3, 3).

    Parameters
    ----------
    material
        A material of the protocol (the inverse of its elastic law gives
        the initial elastic strain of ``initial_stress``).
    initial_stress
        (3, 3) stress at the start, reached elastically (default: the
        material's stress at zero strain, zero for all but Cam clay).
    tol, max_iter
        Newton's tolerance on the stress-controlled components, relative to
        the largest stress, and its iterations per step.

    Raises
    ------
    ConvergenceError
        A step's Newton iteration does not converge (a target stress the
        material cannot carry: beyond its strength).
    """
    controlled = np.asarray(controlled, dtype=bool)
    if controlled.shape != (3, 3) or (controlled != controlled.T).any():
        raise InvalidInputError("controlled must be a symmetric (3, 3) "
                                "boolean mask")
    check_int("nsteps", nsteps, 1)
    unknown = [(i, j) for i in range(3) for j in range(i, 3)
               if not controlled[i, j]]
    state = {k: v[0] for k, v in initial_state(material, 1).items()}
    if initial_stress is None:     # the material at zero strain
        eps = np.zeros((3, 3))
        sigma0 = update(material, eps, state)[0]
    else:
        # the initial elastic strain of the initial stress, by the inverse
        # of the material's elastic law in the principal frame
        sigma0 = np.asarray(initial_stress, dtype=float)
        values, vectors = np.linalg.eigh(sigma0)
        strains = inverse_elastic_law(material, values[:, None])[:, 0]
        eps = np.einsum("A,aA,bA->ab", strains, vectors, vectors)
    eps_e = eps.copy()
    if update(material, eps_e, state)[3]:
        raise InvalidInputError(
            "the initial stress {} lies outside the material's yield "
            "surface".format(np.round(sigma0, 12).tolist()))
    out_strain, out_stress = [eps.copy()], [sigma0.copy()]
    out_state = {k: [v] for k, v in state.items()}
    out_yielded = [False]
    d_controlled = np.where(controlled, strain_increment, 0.) / nsteps
    target = np.asarray(stress_target, dtype=float)
    for step in range(nsteps):
        d = d_controlled.copy()
        for it in range(max_iter + 1):
            stress, elastic, T, yielded, new = update(material, eps_e + d,
                                                      state)
            r = np.array([stress[i, j] - target[i, j] for i, j in unknown])
            scale = max(np.abs(stress).max(), np.abs(target).max(), 1e-300)
            if not unknown or np.abs(r).max() <= tol * scale:
                break
            if it == max_iter:
                raise ConvergenceError(
                    "element test: step {} did not converge (stress error "
                    "{:.1e} of {:.1e})".format(step + 1, np.abs(r).max(),
                                               scale))
            J = np.array([[T[i, j, k, l] + (T[i, j, l, k] if k != l else 0.)
                           for k, l in unknown] for i, j in unknown])
            x = np.linalg.solve(J, -r)
            for (k, l), value in zip(unknown, x):
                d[k, l] += value
                if k != l:
                    d[l, k] += value
        eps = eps + d
        eps_e = elastic
        state = {k: float(np.ravel(v)[0]) for k, v in new.items()}
        out_strain.append(eps.copy())
        out_stress.append(stress)
        for k, v in state.items():
            out_state[k].append(v)
        out_yielded.append(yielded)
    return Path(np.stack(out_strain, axis=-1), np.stack(out_stress, axis=-1),
                {k: np.array(v) for k, v in out_state.items()},
                np.array(out_yielded))


def triaxial(material, confining: float, axial_strain: float,
             nsteps: int = 100) -> Path:
    """Drained triaxial compression: isotropic stress ``-confining`` at
    the start, then the axial (z) strain compressed by ``axial_strain``
    (> 0) while the radial stresses stay at ``-confining``.

    >>> from skfem_mpm import LinearElastic
    >>> path = triaxial(LinearElastic(1e4, .25), 100., 1e-3, nsteps=2)
    >>> round(float(path.q[-1]), 6)       # E times the axial strain
    10.0
    """
    if not (confining >= 0 and axial_strain >= 0):
        raise InvalidInputError(
            "triaxial compression takes confining >= 0 and axial_strain >= 0 "
            "(both compressive), got {!r} and {!r}".format(confining,
                                                          axial_strain))
    controlled = np.zeros((3, 3), dtype=bool)
    controlled[2, 2] = True
    controlled[[0, 0, 1, 1, 2, 2], [1, 2, 0, 2, 0, 1]] = True   # no shear
    increment = np.zeros((3, 3))
    increment[2, 2] = -axial_strain
    sigma0 = -confining * np.eye(3)
    return mixed_path(material, increment, controlled, sigma0, nsteps,
                      sigma0)


class UndrainedPath(NamedTuple):
    """An undrained triaxial path: the effective stress path ``path``
    (:class:`Path`; ``stress`` the effective stress) and the excess pore
    pressure ``pore_pressure`` (nsteps + 1,), positive in compression: the
    total mean pressure less the effective one, ``u = p - p'``, with the
    total radial stress held at the confining pressure."""
    path: Path
    pore_pressure: ndarray

    @property
    def p(self) -> ndarray:
        """Mean effective stress ``tr(sigma') / 3`` (negative in
        compression, as :attr:`Path.p`)."""
        return self.path.p

    @property
    def q(self) -> ndarray:
        """Deviatoric stress ``sqrt(3 J2)``."""
        return self.path.q


def undrained_triaxial(material, confining: float, axial_strain: float,
                       nsteps: int = 100) -> UndrainedPath:
    """Undrained (constant volume) triaxial compression of a saturated
    sample, pore water and grains incompressible: isotropic effective
    stress ``-confining`` at the start, then the axial (z) strain
    compressed by ``axial_strain`` (> 0) with the radial strains
    ``axial_strain / 2`` (no drainage: the total volumetric strain stays
    zero), every strain prescribed.  The cell pressure stays at
    ``confining``, so the excess pore pressure is what the radial effective
    stress has left, ``u = sigma'_r + confining``, which is
    ``confining + q / 3 - p'`` (total mean pressure less the effective one).

    >>> from skfem_mpm import LinearElastic
    >>> undrained = undrained_triaxial(LinearElastic(1e4, .25), 100., 1e-3,
    ...                                nsteps=2)
    >>> round(float(undrained.q[-1]), 6)     # 3 G times the axial strain
    12.0
    >>> round(float(undrained.pore_pressure[-1]), 6)   # q / 3: p' unchanged
    4.0
    """
    if not (confining >= 0 and axial_strain >= 0):
        raise InvalidInputError(
            "undrained triaxial compression takes confining >= 0 and "
            "axial_strain >= 0 (both compressive), got {!r} and {!r}".format(
                confining, axial_strain))
    increment = np.diag([axial_strain / 2, axial_strain / 2, -axial_strain])
    sigma0 = -confining * np.eye(3)
    path = mixed_path(material, increment, np.ones((3, 3), dtype=bool),
                      sigma0, nsteps, sigma0)
    radial = .5 * (path.stress[0, 0] + path.stress[1, 1])
    return UndrainedPath(path, radial + confining)


def oedometer(material, vertical_strain: float, nsteps: int = 100,
              initial_stress: ndarray = None) -> Path:
    """Oedometric (one-dimensional) compression: the vertical (z) strain
    compressed by ``vertical_strain`` (> 0), every other strain held."""
    increment = np.zeros((3, 3))
    increment[2, 2] = -vertical_strain
    return mixed_path(material, increment, np.ones((3, 3), dtype=bool),
                      np.zeros((3, 3)), nsteps, initial_stress)


def simple_shear(material, shear_strain: float, vertical_stress: float = 0.,
                 nsteps: int = 100) -> Path:
    """Simple shear in the x-y plane (y vertical) under a constant vertical
    stress ``-vertical_stress``, from the elastic oedometric state of that
    stress (``sigma_xx = sigma_zz = nu / (1 - nu) sigma_yy``, no lateral
    strain): the engineering shear strain ``gamma_xy`` grows to
    ``shear_strain``, ``eps_xx`` and every out-of-plane strain stay zero
    (plane strain), ``eps_yy`` follows from the vertical stress.
    ``Path.strain`` includes the elastic strain of the initial stress."""
    if not vertical_stress >= 0:
        raise InvalidInputError("vertical_stress must be >= 0 (compression), "
                                "got {!r}".format(vertical_stress))
    if hasattr(material, "elastic_strain") and not isinstance(
            material, LinearElastic):
        raise InvalidInputError(
            "simple_shear starts from the oedometric state of linear "
            "elasticity; {} has its own elastic law: drive it with "
            "mixed_path from its own initial stress".format(
                type(material).__name__))
    controlled = np.ones((3, 3), dtype=bool)
    controlled[1, 1] = False
    increment = np.zeros((3, 3))
    increment[0, 1] = increment[1, 0] = shear_strain / 2
    lam, mu = material.lam, material.mu
    sigma0 = -vertical_stress * np.diag([lam / (lam + 2 * mu), 1.,
                                         lam / (lam + 2 * mu)])
    return mixed_path(material, increment, controlled, sigma0, nsteps,
                      sigma0)


def tangent_error(material, eps: ndarray, state: Optional[dict] = None,
                  h: float = 1e-7) -> ndarray:
    """How far a material's algorithmic tangent is from the derivative of
    its stress update, per trial state: ``max |D - dtau/deps| / max |D|``
    of ``principal_update(eps, state)``'s ``D`` against central
    differences of its principal stresses ``tau`` (steps ``h`` of each
    trial principal strain); ``nan`` where the update is not smooth
    within ``h`` (the forward and backward differences differ by more
    than 1e-2 of ``max |D|``: a kink between regions of the return map).

    Newton's method converges quadratically only with the derivative: a
    tangent off by more than round-off (the shipped models: below 1e-6)
    slows it to a linear rate, and a failed load step whose residual fell
    linearly says so.

    Parameters
    ----------
    material
        A material of the protocol of :mod:`skfem_mpm.mechanics.materials`
        (``principal_update``).
    eps
        Trial elastic principal strains, (3, n) (or (3,)).
    state
        The internal variables at the start of the step, ``{name: (n,)}``
        (default: their initial values).
    h
        The finite-difference step of the strains.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm import VonMises
    >>> from skfem_mpm.mechanics.element_tests import tangent_error
    >>> eps = np.array([[1e-3, 4e-3], [-2e-3, -1e-3], [0., 0.]])
    >>> bool((tangent_error(VonMises(1e4, .3, yield_stress=20.), eps)
    ...       < 1e-6).all())
    True
    """
    eps = np.asarray(eps, dtype=float)
    eps = eps.reshape(3, -1)
    n = eps.shape[1]
    state = initial_state(material, n) if state is None else state
    tau, _, D = material.principal_update(eps, state)[:3]
    scale = np.maximum(np.abs(D).max(axis=(0, 1)), TINY)
    error = np.zeros(n)
    smooth = np.ones(n, dtype=bool)
    for j in range(3):
        step = np.zeros((3, 1))
        step[j] = h
        up = material.principal_update(eps + step, state)[0]
        down = material.principal_update(eps - step, state)[0]
        smooth &= np.abs((up - tau) - (tau - down)).max(axis=0) / h \
            <= 1e-2 * scale
        error = np.maximum(error, np.abs((up - down) / (2 * h)
                                         - D[:, j]).max(axis=0) / scale)
    return np.where(smooth, error, np.nan)
