"""Kinematics: how a displacement increment on the grid becomes stresses
and tangents at the points, whatever the material.

Two pieces share one interface, so the load-step core never asks which is
present.  ``kinematics.response(op, du, points)`` evaluates the trial state
of a grid displacement increment ``du`` (gradients through the step's point
operator ``op``) and returns a :class:`Response` with

- ``P`` (dim, dim, n) and ``w`` (n,): the internal force is
  ``op.force(P, w)``;
- ``tangent()`` (dim, dim, dim, dim, n): the consistent tangent, assembled
  as ``op.stiffness(tangent, w)`` (finite deformation: also
  ``tangent_of(idx)`` for the points ``idx``, which operators with
  ``tangent_blocks`` call block by block of elements);
- ``commit(points)``: the points' new stress, strain, deformation and
  internal variables once the step has converged (positions are the
  core's business).

An operator with ``components = 3`` in plane strain or 1D (mean
dilatation, :mod:`skfem_mpm.stabilisation.volumetric`) has gradients with
out-of-plane diagonal components: ``P`` is then (3, 3, n) and the tangent
(3, 3, 3, 3, n), the strain increment and ``dF`` keep those components,
so plane strain is computed as 3D with ``u_z = 0``.

:class:`SmallStrain` is the seed's incremental small-strain scheme (points'
volumes fixed, ``eps += sym(grad du)``; an elastic body takes Hooke's law
and its constant tangent, a plastic one the return map on principal values
with the consistent tangent).  :class:`FiniteStrain` is the updated
Lagrangian multiplicative scheme with Hencky strains
(:mod:`skfem_mpm.mechanics.hencky`); with an operator that stays in the
initial configuration (``method = "fem"``) it is the total Lagrangian
scheme of finite elements: the increment's gradient is mapped through the
start-of-step deformation gradient, and an operator with mean dilatation
is put in that configuration first (``op.in_configuration(F_n, F_n^-1)``:
the average taken of the spatial divergence,
:meth:`~skfem_mpm.stabilisation.volumetric.MeanDilatation.
in_configuration`).

"""
import copy
from typing import Callable, Optional

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError, InversionError
from .forms import full_tensor
from .hencky import (SpectralParts, hencky_elastic_state, hencky_stress,
                     inverse_and_det, isotropic_derivative, principal_frame,
                     pull_back, spatial_tangent)
from .compiled import compiled_path, identity_out_of_plane
from .materials import (PointMaterials, elastic_stress, elastic_tensor,
                        is_plastic, update)

__all__ = ["SmallStrain", "FiniteStrain", "Response", "KINEMATICS",
           "point_blocks"]

KINEMATICS = ("small", "finite")
#: points per block of the constitutive update: large enough that numpy's
#: per-call cost fades (2048 was 15-20% slower in 2D and 3D), small enough
#: that the block's temporaries stay a few tens of MB
POINT_BLOCK = 8192


def point_blocks(n: int, size: int = POINT_BLOCK):
    """Slices covering n points in blocks of ``size``."""
    return [slice(s, min(s + size, n)) for s in range(0, n, size)]


def material_block(material, block: slice):
    """The material(s) of a block of points."""
    if isinstance(material, PointMaterials):
        return material.take(block)
    return material


def state_block(state: dict, block: slice) -> dict:
    return {name: value[block] for name, value in state.items()}


def components(op, dim: int) -> int:
    """The components of the gradients, stresses and tangents the point
    operator ``op`` exchanges: ``dim``, or 3 where its gradients have
    out-of-plane components (mean dilatation)."""
    return getattr(op, "components", dim)


class Response:
    """The trial state of one displacement increment.

    Attributes
    ----------
    P, w
        Stress measure and weights of the internal force (a compiled
        response, whose force the pass sums, forms ``P`` when it is read:
        from its trial's arrays, while it is the latest and not
        committed; a compiled finite-deformation commit writes the new
        state into those arrays, and ``P``, the tangent and the
        stiffness are refused after it: ``InvalidInputError``).
    yielded
        Points on the yield surface (n,).
    deformation
        Finite deformation: ``deformation(idx)``, the trial deformation
        gradient (3, 3, m) of points ``idx`` (follower loads); ``None`` in
        small strain.
    tangent_of
        ``tangent_of(idx)``: the consistent tangent (dim, dim, dim, dim,
        m) of points ``idx`` alone, for operators that assemble it block by
        block (``op.tangent_blocks``); ``None`` where it is formed whole.
    force, stiffness
        Where the compiled passes computed the response
        (:mod:`skfem_mpm.mechanics.compiled`): ``force()``, the internal
        force ``op.force(P, w)`` summed in the same pass, and
        ``stiffness()``, ``op.stiffness(tangent, w)`` formed point by
        point; ``None`` on the numpy path.

    """

    def __init__(self, P, w: ndarray, yielded: ndarray,
                 tangent: Callable[[], ndarray], commit: Callable,
                 deformation: Optional[Callable] = None,
                 tangent_of: Optional[Callable] = None,
                 force: Optional[Callable] = None,
                 stiffness: Optional[Callable] = None):
        self._P, self.w, self.yielded = P, w, yielded
        self._tangent, self._commit = tangent, commit
        self.deformation = deformation
        self.tangent_of = tangent_of
        self.force, self.stiffness = force, stiffness

    @property
    def P(self) -> ndarray:
        """The stress measure of the internal force (k, k, n)."""
        return self._P() if callable(self._P) else self._P

    def tangent(self) -> ndarray:
        """The consistent tangent (dim, dim, dim, dim, n)."""
        return self._tangent()

    def commit(self, points):
        """A new state: ``points`` with the converged stress, strain,
        deformation and internal variables (positions unchanged)."""
        return self._commit(points)


class SmallStrain:
    """Small strain: ``eps_n+1 = eps_n + sym(grad du)``, weights the fixed
    point volumes.

    Parameters
    ----------
    material
        A material (protocol of :mod:`skfem_mpm.mechanics.materials`), or
        :class:`~skfem_mpm.mechanics.materials.PointMaterials`.
    dim
        Dimension of the grid.
    counters
        The run's counters (``return_maps`` counts plastic updates).
    kernels
        ``"auto"``, ``"numpy"`` or ``"compiled"``
        (:mod:`skfem_mpm.kernels`; :func:`~skfem_mpm.mechanics.compiled.
        compiled_path`).

    """

    def __init__(self, material, dim: int, counters: dict,
                 kernels: str = "auto"):
        self.material, self.dim, self.counters = material, dim, counters
        self.plastic = is_plastic(material)
        self._elastic = None
        self.compiled = compiled_path(kernels, material, dim)

    def elastic_tangent(self, n: int, k: Optional[int] = None) -> ndarray:
        """Hooke's tensor of every point (a broadcast when uniform), in
        ``k`` components (default ``dim``)."""
        k = k or self.dim
        if self._elastic is None or self._elastic.shape[-1] != n \
                or self._elastic.shape[0] != k:
            self._elastic = elastic_tensor(self.material, n, k)
        return self._elastic

    def response(self, op, du: ndarray, points) -> Response:
        if self.compiled is not None and self.compiled.serves(op, points):
            return self.compiled.small_response(self, op, du, points)
        grad = op.gradients(du)
        deps = full_tensor(.5 * (grad + grad.transpose(1, 0, 2)))
        k = components(op, self.dim)   # of P and the tangent
        if not self.plastic:
            return self.elastic_response(
                points, points.stress + elastic_stress(self.material,
                                                       deps),
                points.strain + deps, k)
        self.counters["return_maps"] += 1
        x, vecs = principal_frame(points.strain + deps, self.dim)
        sig, eps_e, D, yielded, state = update(self.material, x,
                                               points.state)
        stress = np.einsum("Ap,aAp,bAp->abp", sig, vecs, vecs)
        strain = np.einsum("Ap,aAp,bAp->abp", eps_e, vecs, vecs)
        return self.plastic_response(points, (x[:k], sig[:k], D[:k, :k],
                                              vecs[:k, :k]), stress, strain,
                                     yielded, state, k)

    def elastic_response(self, points, stress: ndarray, strain: ndarray,
                         k: int, **fused) -> Response:
        """The response of an elastic trial of ``stress`` and ``strain``
        (3, 3, n) in ``k`` components; ``fused``: the compiled ``force``
        and ``stiffness``."""
        def commit(old):
            new = copy.copy(old)
            new.stress, new.strain = stress, strain
            return new
        return Response(stress[:k, :k], points.volume,
                        np.zeros(points.n, dtype=bool),
                        lambda: self.elastic_tangent(points.n, k), commit,
                        **fused)

    def plastic_response(self, points, principal, stress: ndarray,
                         strain: ndarray, yielded: ndarray, state: dict,
                         k: int, **fused) -> Response:
        """The response of a return-mapped trial: ``principal = (x, sig,
        D, vecs)``, the principal strains, stresses, tangent and frame in
        the ``k`` components of the tangent; ``fused``: the compiled
        ``force`` and ``stiffness``."""
        def tangent():
            return isotropic_derivative(*principal)

        def commit(old):
            new = copy.copy(old)
            new.stress, new.strain = stress, strain
            new.state = {**old.state, **state}    # variables of no model kept
            return new
        return Response(stress[:k, :k], points.volume, yielded, tangent,
                        commit, **fused)


def deformation_increment(grad_du: ndarray) -> ndarray:
    """``dF = I + grad(du)`` as (3, 3, n) from in-plane (dim, dim, n)."""
    dim, n = grad_du.shape[0], grad_du.shape[-1]
    dF = np.repeat(np.eye(3)[:, :, None], n, axis=2)
    dF[:dim, :dim] += grad_du
    return dF


class FiniteStrain:
    """Finite deformation: ``dF = I + grad_n(du)``, ``b_tr = dF b_n dF^T``,
    Hencky stress update, weights the initial volumes (Kirchhoff stress).

    Parameters
    ----------
    material, dim, counters
        As in :class:`SmallStrain`.
    total_lagrangian
        The point operator stays in the initial configuration (finite
        elements): gradients of the increment are mapped through the
        start-of-step ``F``.
    kernels
        As in :class:`SmallStrain`.

    """

    def __init__(self, material, dim: int, counters: dict,
                 total_lagrangian: bool = False, kernels: str = "auto"):
        self.material, self.dim, self.counters = material, dim, counters
        self.plastic = is_plastic(material)
        self.total_lagrangian = total_lagrangian
        self.compiled = compiled_path(kernels, material, dim,
                                      total_lagrangian)
        self._buffers = None
        self._start = (None, None)
        self._start_inverse = (None, None)

    def workspace(self, n: int, k: int, deviation: bool = True):
        """Arrays reused by every Newton iteration (memory): ``b_tr - I``
        (with ``deviation``: the numpy path's; the compiled passes keep
        none), tau, the yielded flags and the
        :class:`~skfem_mpm.mechanics.hencky.SpectralParts` of the points;
        tau and the spectral parts are the compiled path's where there is
        one (:meth:`~skfem_mpm.mechanics.compiled.CompiledPasses.
        workspace`: the spectral parts points first in memory), so that
        the passes and every reader of the workspace, the numpy tangent
        among them, share them.
        The tangent is not among them: it lives only while the stiffness
        is assembled, so that the factorisation (the peak of an iteration)
        runs without it (648 bytes a point in 3D).  The frames' out of
        plane part is the identity (that of every 2D frame, which the
        compiled 2D pass then leaves)."""
        if self._buffers is None or self._buffers[2].shape[0] != n \
                or self._buffers[3].tau.shape[0] != k:
            tau, parts = (numpy_workspace if self.compiled is None
                          else self.compiled.workspace)(n, k)
            self._buffers = (None, tau, np.empty(n, dtype=bool), parts)
        elif self._buffers[1] is None:   # a state's stress now: a new one
            self._buffers = (self._buffers[0], np.empty((3, 3, n))) \
                + self._buffers[2:]
        if deviation and self._buffers[0] is None:
            self._buffers = (np.empty((3, 3, n)),) + self._buffers[1:]
        return self._buffers

    def hand_over_stress(self, tau: ndarray) -> None:
        """Forget the workspace's Kirchhoff stress where it is ``tau``,
        which a compiled commit divides in place into the new state's
        Cauchy stress: the next response gets a new one
        (:meth:`workspace`)."""
        if self._buffers is not None and self._buffers[1] is tau:
            self._buffers = (self._buffers[0], None) + self._buffers[2:]

    def start_deviation(self, points) -> ndarray:
        """``b_n - I = sum_A expm1(2 eps_A) e_A e_A`` from the points'
        elastic logarithmic strain, without the cancellation of
        ``b_n - I`` (computed once per step)."""
        strain, value = self._start
        if strain is not points.strain:
            eps, vecs = principal_frame(points.strain, self.dim)
            value = np.einsum("Ap,aAp,bAp->abp", np.expm1(2. * eps), vecs,
                              vecs)
            self._start = (points.strain, value)
        return value

    def response(self, op, du: ndarray, points) -> Response:
        if self.compiled is not None and self.compiled.serves(op, points):
            return self.compiled.finite_response(self, op, du, points)
        # dim: the grid's; k: the components of gradients, P and tangent
        dim, k = self.dim, components(op, self.dim)
        F_inv = None
        if self.total_lagrangian:         # grad_X(du) F_n^-1 = grad_xn(du)
            if self._start_inverse[0] is not points.F:      # once per step
                self._start_inverse = (points.F, inverse_and_det(
                    points.F, dim)[0])
            F_inv = self._start_inverse[1]
            # mean dilatation averages the spatial divergence
            getattr(op, "in_configuration", lambda *_: None)(points.F,
                                                            F_inv)
            F_inv = F_inv[:k, :k]
            grad = np.einsum("abp,bcp->acp", op.gradients(du), F_inv)
        else:
            grad = op.gradients(du)
        dF = deformation_increment(grad)
        with np.errstate(over="ignore", invalid="ignore"):  # refused below
            dF_inv, detdF = inverse_and_det(dF, dim)
        # an overflowing trial's det may be +inf: refused as NaN is
        bad = np.flatnonzero(~(np.isfinite(detdF) & (detdF > 0)))
        if bad.size:       # the most inverted first (a NaN's at the end)
            bad = bad[np.argsort(detdF[bad], kind="stable")]
            raise InversionError(
                "{} point(s) invert (det dF <= 0), the most {} at x = {} "
                "(det dF {:.3g}{})".format(
                    bad.size, bad[:5].tolist(), points.x[:, bad[0]].tolist(),
                    detdF[bad[0]], "" if np.isfinite(detdF[bad[0]]) else
                    ": not finite, the trial's largest grid displacement "
                    "increment {:.3g}".format(np.abs(du).max())))
        if F_inv is not None:             # gradients live at X, not x_n
            dF_inv = dF_inv.copy()
            dF_inv[:k, :k] = np.einsum("abp,bcp->acp", F_inv,
                                       dF_inv[:k, :k])
        b_dev, tau, yielded, spectral = self.workspace(points.n, k)
        start = self.start_deviation(points)
        state = {}
        for block in point_blocks(points.n):
            # b_tr - I = dF (b_n - I) dF^T + G + G^T + G G^T with the
            # in-plane G = dF - I (no cancellation at small strains)
            G = grad[..., block]
            b_dev[..., block] = np.einsum(
                "abp,bcp,dcp->adp", dF[..., block], start[..., block],
                dF[..., block])
            b_dev[:k, :k, block] += G + G.transpose(1, 0, 2) \
                + np.einsum("abp,cbp->acp", G, G)
            tau[..., block], parts, yielded[block], new = hencky_stress(
                material_block(self.material, block), b_dev[..., block],
                dim, state_block(points.state, block), k, block.start)
            for kept, value in zip(spectral, parts):
                kept[..., block] = value
            for name, value in new.items():
                state.setdefault(name, np.empty(points.n))[block] = value
        self.counters["return_maps"] += self.plastic
        P = np.einsum("abp,ebp->aep", tau[:k, :k], dF_inv[:k, :k])
        return self.trial_response(points, dF, dF_inv, P, state, k, b_dev)

    def trial_response(self, points, dF: ndarray, dF_inv: ndarray,
                       P, state: dict, k: int,
                       b_dev: Optional[ndarray] = None,
                       converged: Optional[Callable] = None,
                       **fused) -> Response:
        """The response of a trial whose Kirchhoff stress, yield flags and
        spectral parts are in the workspace, with ``dF``, its inverse
        (3, 3, n), ``P`` (k, k, n) and the new internal variables
        ``state`` (``P`` a function forming it, for a compiled response);
        ``b_dev``: ``b_tr - I`` (3, 3, n), or ``None`` (compiled) where
        the tangent forms it from the spectral parts; ``converged(old)``:
        the compiled ``(F, det F, b_e, eps_e, sigma, volume)`` of the
        commit, written into the trial's arrays (its stress measure,
        tangents and commit are refused after it, :data:`SPENT`);
        ``fused``: the compiled ``force`` and ``stiffness``."""
        dim = self.dim
        tau, yielded, spectral = self.workspace(points.n, k, False)[1:]
        # a compiled commit writes the new state into the trial's arrays
        # (the stress, dF^-1): what reads them is refused after it
        handed = []

        def unspent(f):          # f, refused once the commit is made
            if f is None or converged is None:
                return f

            def read(*args):
                if handed:
                    raise InvalidInputError(SPENT)
                return f(*args)
            return read

        def tangent_of(idx):
            """Formed from the spectral parts of points ``idx`` (only for
            the iterations that need it), pulled back to the operator's
            configuration."""
            def at(field):        # points last in shape (einsum)
                return field[..., idx] if isinstance(idx, slice) \
                    else np.take(field, idx, axis=-1)
            t, parts = at(tau), SpectralParts(*map(at, spectral))
            b = np.einsum("Ap,aAp,bAp->abp", parts.d, parts.vecs,
                          parts.vecs) if b_dev is None else at(b_dev)
            b = b + np.eye(3)[:, :, None]
            A = spatial_tangent(parts.derivative(), b, t)
            return pull_back(t, A, at(dF_inv), k)[1]

        def tangent():
            """All points' tangent (it lives only while the stiffness is
            assembled)."""
            dtau_db = np.empty((k,) * 4 + (points.n,))
            for block in point_blocks(points.n):
                dtau_db[..., block] = tangent_of(block)
            return dtau_db

        def commit(old):
            new = copy.copy(old)
            if converged is None:
                new.F = np.einsum("abp,bcp->acp", dF, old.F)
                J = inverse_and_det(new.F, dim)[1]
            else:   # compiled: F, J, the elastic state, stress, volume
                handed.append(True)
                new.F, J, be, strain, stress, volume = converged(old)
            if not (J > 0).all():
                raise InversionError("det F <= 0 at {} point(s)".format(
                    int((J <= 0).sum())))
            if converged is None:
                new.be, new.strain = self.elastic_state(spectral, old.state)
                new.stress, new.volume = tau / J, J * old.volume0
            else:
                new.be, new.strain = be, strain
                new.stress, new.volume = stress, volume
                self.counters["return_maps"] += self.plastic
            new.state = {**old.state, **state}    # variables of no model kept
            return new
        def deformation(idx):
            return np.einsum("abp,bcp->acp", dF[..., idx], points.F[..., idx])
        if converged is not None:
            fused["stiffness"] = unspent(fused.get("stiffness"))
        return Response(unspent(P), points.volume0, yielded.copy(),
                        unspent(tangent), unspent(commit), deformation,
                        unspent(tangent_of), **fused)

    def elastic_state(self, spectral: SpectralParts, state: dict):
        """Elastic left Cauchy-Green tensor and logarithmic strain of the
        converged trial from its spectral parts (not kept during the
        iterations: memory)."""
        n = spectral.d.shape[-1]
        b_e, strain = np.empty((3, 3, n)), np.empty((3, 3, n))
        for block in point_blocks(n):
            b_e[..., block], strain[..., block] = hencky_elastic_state(
                material_block(self.material, block),
                SpectralParts(*(part[..., block] for part in spectral)),
                state_block(state, block), block.start)
        self.counters["return_maps"] += self.plastic
        return b_e, strain


#: what a compiled response says when read after its commit
SPENT = ("a compiled finite-deformation response was read after its "
         "commit, which wrote the new state into its arrays (the stress, "
         "dF^-1): read its stress measure, tangent or stiffness before "
         "the commit, or the committed state (its force and deformation "
         "stay)")


def numpy_workspace(n: int, k: int):
    """The numpy path's tau (3, 3, n) and spectral parts of ``n`` points
    with ``k`` components (:meth:`FiniteStrain.workspace`), points last."""
    return np.empty((3, 3, n)), SpectralParts(
        np.empty((3, n)), identity_out_of_plane(n), np.empty((k, n)),
        np.empty((k, k, n)))


def make_kinematics(name: str, material, dim: int, counters: dict,
                    total_lagrangian: bool = False, kernels: str = "auto"):
    """The kinematics piece called ``name`` (``"small"`` or ``"finite"``)
    with ``kernels`` (:mod:`skfem_mpm.kernels`; the compiled passes find
    mean dilatation on each operator:
    :meth:`~skfem_mpm.mechanics.compiled.CompiledPasses.serves`)."""
    if name == "small":
        return SmallStrain(material, dim, counters, kernels)
    return FiniteStrain(material, dim, counters, total_lagrangian, kernels)
