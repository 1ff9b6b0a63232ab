"""The kinematics' responses from the compiled points-first passes.

:func:`compiled_path` decides, when a run's kinematics piece is made,
whether its responses may come from the compiled passes
(:mod:`skfem_mpm.kernels.passes`): they cover the point operators with
a ``kernel_layout`` over all points, standard MPM's (any element; also
``method="fem"`` in small strain) and the sparse operators of uGIMP,
cpGIMP and B-splines (also on the fields of bodies in contact), with or
without mean dilatation (the operators wrapped in
:class:`~skfem_mpm.stabilisation.volumetric.MeanDilatation`, whose cell
averages have a ``kernel_layout`` too: :mod:`skfem_mpm.kernels.
dilatation`; in finite deformation also F-bar on the increment,
:class:`~skfem_mpm.stabilisation.fbar.IncrementFbar`, whose cells'
layout is that of its additive average: :mod:`skfem_mpm.kernels.fbar`),
in 2D and 3D, small strain and finite deformation (updated
Lagrangian), :class:`~skfem_mpm.mechanics.materials.LinearElastic`,
:class:`~skfem_mpm.mechanics.materials.VonMises`,
:class:`~skfem_mpm.mechanics.soils.DruckerPrager`,
:class:`~skfem_mpm.mechanics.soils.MohrCoulomb` (with friction) and
:class:`~skfem_mpm.mechanics.cam_clay.ModifiedCamClay`, one for all
points or one per body (:class:`~skfem_mpm.mechanics.materials.
PointMaterials`, each body's any of these: the passes take each point's
parameters by its body, :func:`body_parameters`).  Everything else (the
total Lagrangian scheme of ``method="fem"`` in finite deformation, 1D, a
user's material, also as one body's) runs on the numpy path, the
reference the compiled passes are tested equal to.

A compiled response fills the arrays the numpy path fills (stress, the
spectral parts, ``dF`` ...), so the kinematics build it, its commit and its
tangent on demand with their own code; it adds the internal force, summed
in the same pass, and the stiffness, formed point by point from the kept
parts and scattered into the CSR data of the operator's pattern (the
grid's element pattern, or for a sparse operator the pattern of its
supports' node graph, formed once a step; with mean dilatation the
pattern of the cells' patches, which holds it).
"""
import logging
from typing import Optional

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError
from ..kernels import (AUTO_VARIABLE, CAM_CLAY, DRUCKER_PRAGER, ELASTIC,
                       MOHR_COULOMB, VON_MISES, auto_kernels, check_kernels,
                       compiled_passes, log_once)
from .hencky import SpectralParts
from .materials import (LinearElastic, PointMaterials, VonMises,
                        elastic_tensor)
from .cam_clay import ModifiedCamClay
from .soils import APEX_STIFFNESS, DruckerPrager, MohrCoulomb

__all__ = ["compiled_path", "CompiledPasses", "material_parameters",
           "body_parameters", "COVERAGE", "identity_out_of_plane"]

#: what the compiled passes serve (the refusal of ``kernels="compiled"``
#: says it)
COVERAGE = ("standard MPM, uGIMP, cpGIMP and B-splines in 2D and 3D, small "
            "and finite deformation, with or without mean dilatation "
            "(antilocking=True) or F-bar on the increment ('fbar'), "
            "LinearElastic, VonMises, DruckerPrager, MohrCoulomb of "
            "friction_angle > 0 and ModifiedCamClay (one for all points or "
            "one per body)")

#: what a run of Mohr-Coulomb without friction (Tresca) on the numpy path
#: is told, at WARNING (trial 94: it doubles an iteration's cost)
TRESCA_COST = (": an iteration costs about twice the compiled passes' "
               "(a 3D footing at B/h = 6: 0.225 s against VonMises' 0.128 "
               "s); in plane strain VonMises(yield_stress=sqrt(3) c) has "
               "Tresca's limit loads and runs compiled")


def material_parameters(material) -> Optional[ndarray]:
    """The parameter vector of the compiled return maps
    (:mod:`skfem_mpm.kernels.constitutive`, :mod:`skfem_mpm.kernels.
    soils`), or ``None`` for a material they do not cover (only the
    built-in classes themselves, not subclasses, which may change the law;
    not Mohr-Coulomb without friction, whose apex the numpy path refuses):
    ``(kind, lam, mu, E, nu)``, then von Mises' ``yield_stress``;
    Drucker-Prager's ``(-, cohesion, eta, xi, eta_bar, hardening, apex
    stiffness)``; Mohr-Coulomb's ``(-, k, m, sigma_c, -, -, apex
    stiffness)``; modified Cam clay's ``(kind, lam, mu, -, -, -, kappa,
    lambda_, M, G, p_r, p_c0)``.

    >>> from skfem_mpm import MohrCoulomb
    >>> mc = MohrCoulomb(1e4, .3, cohesion=10., friction_angle=30.,
    ...                  dilation_angle=10.)
    >>> material_parameters(mc)[[0, 6, 7, 8]].round(6).tolist()   # k, m
    [3.0, 3.0, 1.420277, 34.641016]
    """
    kind = {LinearElastic: ELASTIC, VonMises: VON_MISES,
            DruckerPrager: DRUCKER_PRAGER, MohrCoulomb: MOHR_COULOMB,
            ModifiedCamClay: CAM_CLAY}.get(type(material))
    if kind is None or kind == MOHR_COULOMB and not material.k > 1:
        return None
    params = np.zeros(12)
    if kind == CAM_CLAY:
        params[:3] = kind, material.lam, material.mu
        params[6:] = (material.kappa, material.lambda_, material.M,
                      material.mu, material.reference_pressure,
                      material.preconsolidation_pressure)
        return params
    params[:5] = kind, material.lam, material.mu, material.E, material.nu
    if kind == VON_MISES:
        params[5] = material.yield_stress
    if kind == DRUCKER_PRAGER:
        params[6:] = (material.cohesion, material.eta, material.xi,
                      material.eta_bar, material.hardening, APEX_STIFFNESS)
    if kind == MOHR_COULOMB:
        params[6:9] = material.k, material.m, material.sigma_c
        params[11] = APEX_STIFFNESS
    return params


def material_name(material) -> str:
    """The class name of ``material``, and why the passes leave it."""
    name = type(material).__name__
    return name + " without friction" if type(material) is MohrCoulomb \
        else name


def body_parameters(material):
    """``(params, body, reason)``: the parameter vectors of the passes,
    one row a body (:func:`material_parameters`), and each point's row
    (``None``: one material, every point row 0), or ``(None, None,
    reason)`` where the passes do not cover ``material`` (for
    :class:`~skfem_mpm.mechanics.materials.PointMaterials`, the first
    body's material they do not cover, by its class: the user's).

    >>> from skfem_mpm import LinearElastic, VonMises
    >>> from skfem_mpm.mechanics.materials import PointMaterials
    >>> params, body, _ = body_parameters(PointMaterials(
    ...     [VonMises(1e6, .3, 1e3), LinearElastic(1e8, .2)], [0, 1, 1, 0]))
    >>> params[:, 0].tolist(), body.tolist()                  # kinds
    ([1.0, 0.0], [0, 1, 1, 0])
    """
    if not isinstance(material, PointMaterials):
        params = material_parameters(material)
        return (None, None, "the material {}".format(
            material_name(material))) if params is None \
            else (params[None], None, None)
    rows = []
    for k, each in enumerate(material.materials):
        params = material_parameters(each)
        if params is None:
            return None, None, "the material {} of body {}".format(
                material_name(each), k)
        rows.append(params)
    return np.array(rows), np.ascontiguousarray(material.body,
                                                dtype=np.int64), None


def compiled_path(kernels: str, material, dim: int,
                  total_lagrangian: bool = False):
    """The :class:`CompiledPasses` of a kinematics piece, or ``None`` (the
    numpy path): with ``kernels="numpy"``, or ``"auto"`` under
    ``SKFEM_MPM_KERNELS=numpy`` (:func:`~skfem_mpm.kernels.auto_kernels`;
    logged once at INFO, naming the variable); with ``"auto"`` where the
    passes do not cover the material, dimension or scheme or numba does
    not import (logged once at INFO; at WARNING for Mohr-Coulomb without
    friction, Tresca, a built-in material whose iterations then cost
    about twice the compiled ones: :data:`TRESCA_COST`); with
    ``"compiled"`` those are refused
    (:class:`~skfem_mpm.errors.InvalidInputError`), before any work.
    Mean dilatation needs no say here: :meth:`CompiledPasses.serves`
    finds it on each operator.

    >>> from skfem_mpm import LinearElastic
    >>> compiled_path("compiled", LinearElastic(1e6, .3), 1)
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: kernels='compiled': the compiled \
passes do not serve 1D grids; ...
    """
    if check_kernels(kernels) == "numpy":
        return None
    if kernels == "auto" and auto_kernels() == "numpy":
        # said (trial 111: no line said which path a run took)
        log_once(logging.INFO, "kernels='auto': the numpy path serves "
                 "every run (the environment variable %s=numpy)",
                 AUTO_VARIABLE)
        return None
    params, body, reason = body_parameters(material)
    reason = ("{}D grids".format(dim) if dim not in (2, 3)
              else "the total Lagrangian scheme (method 'fem')"
              if total_lagrangian else reason)
    passes = None if reason else compiled_passes()
    if reason is None and passes is not None:
        return CompiledPasses(passes, material, params, dim,
                              kernels == "compiled", body)
    if kernels == "compiled":
        raise InvalidInputError(
            "kernels='compiled': the compiled passes do not serve {}; they "
            "cover {}, with numba: use kernels='auto' or 'numpy'".format(
                reason or "a run without numba (it does not import)",
                COVERAGE))
    if reason is None:                  # no numba: compiled_passes logged
        return None
    # Tresca, a built-in material, is warned of: its cost surprises
    tresca = reason.startswith("the material MohrCoulomb without friction")
    log_once(logging.WARNING if tresca else logging.INFO,
             "kernels='auto': the numpy path serves %s%s", reason,
             TRESCA_COST if tresca else "")
    return None


def identity_out_of_plane(n: int) -> ndarray:
    """A (3, 3, n) array of zeros but the entries (2, 2), ones: the out
    of plane part of a 2D point's ``dF``, ``dF^-1`` and principal frame,
    whose in-plane blocks the passes fill."""
    a = np.zeros((3, 3, n))
    a[2, 2] = 1.
    return a


def points_first(n: int, *shape: int) -> ndarray:
    """An uninitialised array of shape ``shape + (n,)`` (points last, as
    the numpy path reads it) whose points are first in memory: the view
    of a C-contiguous ``(n,) + shape`` array.  The passes read and write
    it through its strides, a point's entries side by side, where points
    last would put each entry on a stream of its own (some 35 streams in
    the finite pass): the 2D finite pass 15-20% faster at 1e5 points."""
    return np.empty((n,) + shape).transpose(
        tuple(range(1, len(shape) + 1)) + (0,))


def frame_out_of_plane(n: int) -> ndarray:
    """:func:`identity_out_of_plane`, its points first in memory
    (:func:`points_first`)."""
    a = np.zeros((n, 3, 3)).transpose(1, 2, 0)
    a[2, 2] = 1.
    return a


def points_last(a: ndarray) -> ndarray:
    """The memory of ``a`` (3, 3, n), points first (:func:`points_first`,
    :func:`frame_out_of_plane`), as a C-contiguous (3, 3, n) array, points
    last (a view: nothing copied), the layout of the points' state.

    >>> a = points_first(4, 3, 3)
    >>> b = points_last(a)
    >>> b.shape, b.flags.c_contiguous, np.shares_memory(a, b)
    ((3, 3, 4), True, True)
    """
    return a.transpose(2, 0, 1).reshape(a.shape)


def contiguous(a: ndarray) -> ndarray:
    """``a`` as C-contiguous float64 (a copy only where it is not): one
    compiled signature serves every call."""
    return np.ascontiguousarray(a, dtype=np.float64)


class CompiledPasses:
    """The compiled responses of one kinematics piece.

    Parameters
    ----------
    passes
        The module :mod:`skfem_mpm.kernels.passes`.
    material, params
        The material (or :class:`~skfem_mpm.mechanics.materials.
        PointMaterials`) and its parameter vectors, one row a body
        (:func:`body_parameters`).
    dim
        The grid's dimension.
    explicit
        ``kernels="compiled"`` was asked for: an operator the passes do
        not serve is logged as a warning (once), not as information.
    body
        Each point's row of ``params`` (int64), or ``None``: one material
        (row 0 for every point).

    """

    def __init__(self, passes, material, params: ndarray, dim: int,
                 explicit: bool, body: Optional[ndarray] = None):
        # numba: imported with passes
        from ..kernels import dilatation, fbar, parallel
        self.passes, self.material, self.params = passes, material, params
        self.parallel = parallel
        self.dim, self.explicit, self.body = dim, explicit, body
        kinds = params[:, 0]
        # any body's plastic: the small pass takes the return map at every
        # point (an elastic body's too), as the numpy path's PointMaterials
        self.plastic = bool((kinds != 0.).any())
        #: the internal variables the passes carry, rows of a (2, n) array
        self.variables = (("equivalent_plastic_strain",
                           "plastic_volumetric_strain")
                          if (kinds == CAM_CLAY).any() else
                          ("equivalent_plastic_strain",) if self.plastic
                          else ())
        self._row0 = np.zeros(0, dtype=np.int64)  # one material's body
        #: the passes without and with mean dilatation, each
        #: ``(finite_residual, small_residual, stiffness)``
        self.plain = passes.passes_of(dim)
        #: the plain passes in chunks on the machine's cores, the same
        #: three (:mod:`skfem_mpm.kernels.parallel`)
        self.chunked = parallel.passes_of(dim)
        self.averaged = dilatation.passes_of(dim)
        #: with F-bar on the increment, ``(finite_residual, stiffness)``
        self.fbar = fbar.passes_of(dim)
        self._start = (None, None)      # a step's strain and b_n - I
        self._increments = None         # dF and dF^-1, reused
        # the stiffness pass's C with m components (dim, or 3 with mean
        # dilatation), one a body, made once: zeros where it reads none,
        # and Hooke's tensors of elastic materials in small strain on first
        # use (33 us, once a response before)
        self._no_C = {m: np.zeros((1,) + (m,) * 4) for m in {dim, 3}}
        self._hooke = {}

    def serves(self, op, points) -> bool:
        """Whether the passes serve the point operator ``op``: standard
        MPM's, GIMP's or B-splines' (``op.kernel_layout``) over all
        points, or its mean dilatation (``op.op`` such an operator, the
        cell average ``op.average`` with a ``kernel_layout``); logged once
        where not."""
        average = getattr(op, "average", None)
        method_op = op if average is None else op.op
        if self.body is not None and self.body.size != points.n:
            return False    # bodies of other points: numpy's error
        if getattr(method_op, "kernel_layout", None) is not None and \
                method_op.n_points == points.n and (
                    average is None
                    or getattr(average, "kernel_layout", None) is not None):
            return True
        log_once(logging.WARNING if self.explicit else logging.INFO,
                 "kernels=%r: no compiled pass for the point operator %s; "
                 "its responses run on the numpy path",
                 "compiled" if self.explicit else "auto", type(op).__name__)
        return False

    def _bodies(self, n: int) -> ndarray:
        """Each of ``n`` points' row of ``params``: the bodies of
        :class:`~skfem_mpm.mechanics.materials.PointMaterials`, else
        zeros (made once for ``n``)."""
        if self.body is not None:
            return self.body
        if self._row0.size != n:
            self._row0 = np.zeros(n, dtype=np.int64)
        return self._row0

    def _run(self, which: int, serial, layout, plain: bool, *args):
        """``serial(*layout.groups, *args)``, one of the passes; a plain
        pass (not mean dilatation's, nor F-bar's) of a layout cut into
        chunks (``layout.chunks``) runs them on the machine's cores, the
        chunked pass ``which`` of :attr:`chunked` (0 finite residual,
        1 small residual, 2 stiffness)."""
        if not plain or layout.chunks is None:
            return serial(*layout.groups, *args)
        with self.parallel.LOCK:
            return self.chunked[which](layout.chunks, *layout.groups, *args)

    @staticmethod
    def _point_chunks(layout) -> int:
        """As many chunks of points for a pass point by point as the
        operator's ``layout`` has chunks of groups (1: serial)."""
        return 1 if layout.chunks is None else len(layout.chunks) - 1

    def _layout(self, op):
        """``(passes, layout, cells, m)`` of the served operator ``op``:
        the passes, the method operator's layout, the cells' arrays of its
        mean dilatation (none without), and the components of its
        stresses and tangents (3 with mean dilatation, as the numpy
        path's :class:`~skfem_mpm.stabilisation.volumetric.
        MeanDilatation`)."""
        average = getattr(op, "average", None)
        if average is None:
            return self.plain, op.kernel_layout(), None, self.dim
        return self.averaged, op.op.kernel_layout(), \
            average.kernel_layout(), 3

    def _start_deviation(self, points, count: int = 1) -> ndarray:
        """The compiled twin of :meth:`~skfem_mpm.mechanics.kinematics.
        FiniteStrain.start_deviation` (``b_n - I``), once a step: for the
        strain it was computed from; in ``count`` chunks of points on the
        machine's cores where more than one (the same answer to the
        bit).  Of unstrained points (a first step from rest) new zeros,
        what the pass writes there (:func:`~skfem_mpm.kernels.passes.
        unstrained`), pages the residual passes only read: at 1e6 points
        in 2D the pass and its 72 MB of new pages took 0.10-0.18 s of
        the step's first residual."""
        strain, value = self._start
        if strain is not points.strain:
            given = contiguous(points.strain)
            if self.passes.unstrained(given):
                value = np.zeros((points.n, 3, 3)).transpose(1, 2, 0)
                self._start = (points.strain, value)
                return value
            if value is None or value.shape[-1] != points.n:
                value = points_first(points.n, 3, 3)  # else the last step's
            args = (self.dim, given, value)
            if count == 1:
                self.passes.start_deviation(*args)
            else:
                with self.parallel.LOCK:
                    self.parallel.start_deviation_in_chunks(count, *args)
            self._start = (points.strain, value)
        return value

    def _increment_arrays(self, n: int, m: int):
        """``dF`` and ``dF^-1`` (3, 3, n) of the finite pass with ``m``
        components, reused by every response (the latest one's, as the
        kinematics' spectral parts), the identity out of plane set once:
        the 2D pass without mean dilatation stores the in-plane blocks
        only (with it, ``dF_33`` is not 1: new arrays when ``m``
        changes)."""
        if self._increments is None or self._increments[0] != (n, m):
            self._increments = ((n, m),) + tuple(frame_out_of_plane(n)
                                                 for _ in range(2))
        elif self._increments[2] is None:       # a commit's F: a new one
            self._increments = self._increments[:2] + (
                frame_out_of_plane(n),)
        return self._increments[1:]

    def _hand_over(self, dF_inv: ndarray, start: ndarray):
        """The memory of a committed trial's ``dF^-1`` and of its step's
        ``b_n - I`` (points first), which the step reads no more, as the
        (3, 3, n) arrays, points last, that the commit writes the new
        state's ``F`` and ``b_e`` into (:func:`points_last`); forgotten
        here, so that the next response and step make new ones.  At 1e6
        points in 2D the commit's new pages were 304 MB, 0.25-0.83 s of
        the step on this project's virtual machine against 0.06-0.10 s
        for the commit's pass in memory written before; the next step
        makes its arrays after the state before it was let go."""
        if self._increments is not None and \
                self._increments[2] is dF_inv:
            self._increments = self._increments[:2] + (None,)
        if self._start[1] is start:
            self._start = (None, None)
        return points_last(dF_inv), points_last(start)

    def workspace(self, n: int, m: int):
        """The kinematics' Kirchhoff stress ``tau`` (3, 3, n) and
        :class:`~skfem_mpm.mechanics.hencky.SpectralParts` with ``m``
        components, as :func:`~skfem_mpm.mechanics.kinematics.
        numpy_workspace` shapes them, the spectral parts points first in
        memory (:func:`points_first`): the kinematics' workspace asks for
        them (:meth:`~skfem_mpm.mechanics.kinematics.FiniteStrain.
        workspace`); the passes write a point's entries side by side,
        every other reader takes them through their shapes.  ``tau``
        stays points last: the commit divides it into the points' stress,
        points last for its readers (points first, the residual pass ran
        0.004 us a point faster at 1e5 points, but at 1e6 the strided
        division took 0.19 s in numpy, 0.05 points last, and in the
        commit's pass about 0.07 s more in a run)."""
        return np.empty((3, 3, n)), SpectralParts(
            points_first(n, 3), frame_out_of_plane(n), points_first(n, m),
            points_first(n, m, m))

    def _state(self, points) -> ndarray:
        """The internal variables of ``points``, (2, n)."""
        state = np.zeros((2, points.n))
        for row, name in enumerate(self.variables):
            state[row] = points.state[name]
        return state

    def _named(self, state: ndarray) -> dict:
        """The internal variables (2, n) by name."""
        return {name: state[row] for row, name in enumerate(self.variables)}

    def _stiffness(self, assemble, layout, cells, kind: int, w: ndarray,
                   C: ndarray, body: ndarray, parts) -> callable:
        """``stiffness()`` of a response: the compiled stiffness from the
        kept ``parts`` (x, y, dy_dx, vecs, dF_inv) into the CSR data of
        the operator's pattern (with mean dilatation, of its cells'); an
        elastic tangent the ``C[body[p]]`` of each point."""
        places, pattern, extra = (layout.places, layout.pattern, ()) \
            if cells is None else (cells.places, cells.pattern, cells.cells)

        def stiffness():
            data = np.zeros(pattern.nnz)
            self._run(2, assemble, layout, cells is None, *places,
                      contiguous(w), kind, C, body, *parts, data, *extra)
            return pattern.csr(data)
        return stiffness

    def _fbar_arrays(self, op, points):
        """F-bar on the increment (:mod:`skfem_mpm.kernels.fbar`): the
        passes, the method operator's layout, the cells' layout, and the
        trailing arguments of its residual pass: the cells' ``(cell,
        patch, patch_start, patch_nodes)``, the volumes of the averages
        and the arrays the residual fills for the stiffness, ``(xi - 1,
        omega, b, M_c)``."""
        layout, cells = op.op.kernel_layout(), op.cell_layout()
        cell, patch, patch_start, patch_nodes = cells.cells[:4]
        n = points.n
        kept = (np.empty(n), np.empty(n),
                np.zeros((len(patch_nodes), self.dim)),
                np.zeros(len(patch_start) - 1))
        return self.fbar, layout, cells, \
            cells.cells[:4] + (contiguous(op.volume),) + kept

    def finite_response(self, kinematics, op, du: ndarray, points):
        """The finite-deformation response (the numpy path's
        :meth:`~skfem_mpm.mechanics.kinematics.FiniteStrain.response`)."""
        fbar = getattr(op, "cell_layout", None) is not None
        if fbar:
            (finite, assemble), layout, cells, trailing = \
                self._fbar_arrays(op, points)
            m = 3
        else:
            (finite, _, assemble), layout, cells, m = self._layout(op)
            trailing = () if cells is None else cells.cells
        n, body = points.n, self._bodies(points.n)
        tau, yielded, spectral = kinematics.workspace(n, m, False)[1:]
        dF, dF_inv = self._increment_arrays(n, m)
        f, eq = np.zeros(op.N), np.empty((2, n))
        start = self._start_deviation(points, self._point_chunks(layout))
        status = self._run(
            0, finite, layout, not fbar and cells is None,
            contiguous(points.volume0), contiguous(du), start,
            self.params, body,
            self._state(points), f, dF, dF_inv, tau, spectral.d,
            spectral.vecs, spectral.tau, spectral.dtau_dx, yielded, eq,
            *trailing)
        if status:      # a point inverts: the numpy path's error
            compiled, kinematics.compiled = kinematics.compiled, None
            try:
                return kinematics.response(op, du, points)
            finally:
                kinematics.compiled = compiled
        kinematics.counters["return_maps"] += kinematics.plastic
        state = self._named(eq)

        def converged(old):
            """The new state's arrays, ``F``, ``b_e`` and the stress in
            the trial's (:meth:`_hand_over`; the stress is ``tau``
            divided in place, and the kinematics forget it): the
            response reads them no more (``trial_response`` refuses)."""
            F, b_e = self._hand_over(dF_inv, start)
            kinematics.hand_over_stress(tau)
            J, strain = np.empty(n), np.empty((3, 3, n))
            args = (self.dim, self.params, body, spectral.d, spectral.vecs,
                    self._state(old), dF, contiguous(old.F), F, J, b_e,
                    strain)
            count = self._point_chunks(layout)
            if count == 1:
                self.passes.finite_commit(*args)
                with np.errstate(divide="ignore", invalid="ignore"):
                    np.divide(tau, J, out=tau)  # J <= 0: the caller's error
                return F, J, b_e, strain, tau, J * old.volume0
            volume = np.empty(n)
            with self.parallel.LOCK:
                self.parallel.commit_in_chunks(
                    count, *args, tau, contiguous(old.volume0), tau, volume)
            return F, J, b_e, strain, tau, volume

        def P():            # read by no step: formed when asked for
            return np.einsum("abp,ebp->aep", tau[:m, :m], dF_inv[:m, :m])
        parts = (spectral.d, spectral.tau, spectral.dtau_dx, spectral.vecs,
                 dF_inv)
        if fbar:
            stiffness = self._fbar_stiffness(
                assemble, layout, cells, points.volume0,
                parts + (dF, tau), trailing[:4] + trailing[5:])
        else:
            stiffness = self._stiffness(
                assemble, layout, cells, self.passes.FINITE_TANGENT,
                points.volume0, self._no_C[m], body, parts)
        return kinematics.trial_response(
            points, dF, dF_inv, P, state, m, converged=converged,
            force=f.copy, stiffness=stiffness)

    @staticmethod
    def _fbar_stiffness(assemble, layout, cells, w: ndarray, parts,
                        trailing) -> callable:
        """``stiffness()`` of an F-bar response: the compiled stiffness
        (:mod:`skfem_mpm.kernels.fbar`) from the kept ``parts`` (x, y,
        dy_dx, vecs, dF_inv, dF, tau) and what its residual pass filled
        (``trailing``: the cells' arrays, then ``(xi - 1, omega, b,
        M_c)``), into the CSR data of the cells' pattern."""
        def stiffness():
            data = np.zeros(cells.pattern.nnz)
            assemble(*layout.groups, *cells.places, contiguous(w), *parts,
                     data, *trailing)
            return cells.pattern.csr(data)
        return stiffness

    def small_response(self, kinematics, op, du: ndarray, points):
        """The small-strain response (the numpy path's
        :meth:`~skfem_mpm.mechanics.kinematics.SmallStrain.response`)."""
        if getattr(op, "cell_layout", None) is not None:
            raise InvalidInputError(
                "F-bar on the increment (antilocking='fbar') is for finite "
                "deformation, not small strain")
        (_, small, assemble), layout, cells, m = self._layout(op)
        n, body = points.n, self._bodies(points.n)
        stress, strain = np.empty((3, 3, n)), np.empty((3, 3, n))
        x, vecs = points_first(n, 3), points_first(n, 3, 3)
        y, dy_dx = points_first(n, m), points_first(n, m, m)
        yielded, eq = np.zeros(n, dtype=bool), np.empty((2, n))
        f = np.zeros(op.N)
        self._run(
            1, small, layout, cells is None,
            contiguous(points.volume), contiguous(du),
            contiguous(points.stress), contiguous(points.strain), self.params,
            body, self._state(points),
            f, stress, strain, x, vecs, y, dy_dx, yielded, eq,
            *(() if cells is None else cells.cells))
        # the stiffness pass reads no dF^-1 in small strain: one of two
        # points, strided as the finite pass's, so that both call the
        # same compiled stiffness (a contiguous one, of another type, made
        # numba compile it again: 15 s for each of its four forms)
        empty = points_first(2, 3, 3)
        if not self.plastic:
            if m not in self._hooke:
                # one a body, (bodies, m, m, m, m) C-contiguous: the type
                # of every call's C is one
                self._hooke[m] = np.stack([
                    elastic_tensor(each, 1, m)[..., 0]
                    for each in getattr(self.material, "materials",
                                        [self.material])])
            return kinematics.elastic_response(
                points, stress, strain, m, force=f.copy,
                stiffness=self._stiffness(
                    assemble, layout, cells, self.passes.ELASTIC_TANGENT,
                    points.volume, self._hooke[m], body,
                    (x, y, dy_dx, vecs, empty)))
        kinematics.counters["return_maps"] += 1
        return kinematics.plastic_response(
            points, (x[:m], y, dy_dx, vecs[:m, :m]), stress, strain, yielded,
            self._named(eq), m, force=f.copy,
            stiffness=self._stiffness(
                assemble, layout, cells, self.passes.RETURN_MAP_TANGENT,
                points.volume, self._no_C[m], body,
                (x, y, dy_dx, vecs, empty)))
