"""F-bar on each load step's increment (``Stabilisation(antilocking=
"fbar")``): mean dilatation in finite deformation for the methods whose
points move (standard MPM, GIMP, B-splines; updated Lagrangian).

The additive mean dilatation of :mod:`.volumetric`, ``dF = I + g +
(theta_c - tr g) I / 3``, averages the *linearised* volume change of the
increment: each point's ``det dF`` still differs from its cell's by terms
of second order in ``g``, which the bulk modulus turns into pressures that
oscillate inside a cell (a Cook's membrane at nu = 0.4999, ``K / mu =
5000``: point pressures up to 94 against a von Mises stress of 2-6) and
that Newton cannot remove (the average does not see them).  Here the
increment is scaled multiplicatively (de Souza Neto et al. 1996, on the
increment as in Coombs et al. 2018),

    dF_bar = (J_c / J)^(1/3) dF,   dF = I + g,   J = det dF,
    J_c = sum_(p in c) v_p J_p / sum_(p in c) v_p,

with ``v_p`` the points' volumes at the step's start: every point of a
cell changes its volume by exactly its cell's ratio ``J_c``, whatever the
size of the increment.  Plane strain is 3D with ``u_z = 0``, so
``dF_bar`` has the out-of-plane stretch ``(J_c / J)^(1/3)``.

The internal force is ``sum_p w_p P_p : d dF_bar_p / du`` with

    d dF_bar = xi [dg + (theta_c(du) - R : dg) Q / 3],
    xi = (J_c / J)^(1/3), Q = dF, R = dF^-T,

where ``theta_c`` is the average of the spatial divergence ``R : dg``
weighted by the current volumes ``v J`` (the first variation of ``log
J_c``): the framed mean dilatation of :class:`.volumetric.MeanDilatation`
with frame ``(dF, dF^-T)``, the spatial average, and the weights ``w
xi``.  The tangent is its derivative: the framed material part with
weights ``w xi^2`` and a geometric part (the derivatives of ``xi``, of
``R`` and of ``theta_c``), so Newton keeps its quadratic rate (tested
against finite differences of the force).

The operator keeps the linearisation of the last increment whose
gradients it formed (the kinematics form the force and the tangent of
the latest trial, as their work arrays do).  The compiled passes
(:mod:`skfem_mpm.kernels.fbar`) form the same force and tangent point by
point and cell by cell (:meth:`IncrementFbar.cell_layout`), equal to
this numpy path to round-off; it stays the reference, and serves a
user's material.
"""
from functools import cached_property

import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix

from ..mechanics.hencky import inverse_and_det
from .volumetric import CellPatchAverage, ElementAverage, MeanDilatation

__all__ = ["IncrementFbar"]


class SpatialPatchAverage(CellPatchAverage):
    """:class:`.volumetric.CellPatchAverage` of the spatial divergence
    ``R : grad(u)`` (``R`` (dim, dim, n), the in-plane ``dF^-T``)."""

    def __init__(self, op, volume: ndarray, R: ndarray):
        super().__init__(op, volume)
        self._R = R

    @cached_property
    def B(self) -> csr_matrix:
        n = self.op.S.shape[0]
        average = csr_matrix((self._weight, (self.cell, np.arange(n))),
                             shape=(self.ncells, n))
        return (average @ self._contracted(self._R)).tocsr()

    def cell_sum(self, s: ndarray) -> ndarray:
        """Each point's cell's sum of point values ``s``, (n,)."""
        return np.bincount(self.cell, s, self.ncells)[self.cell]


class SpatialElementAverage(ElementAverage):
    """:class:`.volumetric.ElementAverage` of the spatial divergence."""

    def __init__(self, op, volume: ndarray, R: ndarray):
        super().__init__(op, volume, R.transpose(1, 0, 2))

    def cell_sum(self, s: ndarray) -> ndarray:
        basis = self.op.basis
        total = basis.quadrature_field(s).sum(axis=1)
        return basis.point_values(np.broadcast_to(
            total[:, None], basis.point_index.shape))


class IncrementFbar(MeanDilatation):
    """F-bar on the increment of one step's point operator (updated
    Lagrangian): ``gradients(u)`` is ``dF_bar - I`` (3, 3, n), ``force``
    and ``stiffness`` those of :class:`.volumetric.MeanDilatation` at the
    linearisation of the last ``gradients``, with the geometric part of
    the tangent.

    Parameters
    ----------
    op, volume
        As :class:`.volumetric.MeanDilatation`: the step's point operator
        and the points' volumes at the step's start.

    """

    def __init__(self, op, volume: ndarray):
        super().__init__(op, volume)
        self._cells = self.average      # of the volumes at the step's start
        self._spatial = SpatialElementAverage \
            if isinstance(self.average, ElementAverage) \
            else SpatialPatchAverage
        self._state = self._P = None

    def cell_layout(self):
        """The :class:`~skfem_mpm.stabilisation.volumetric.CellLayout` of
        the compiled passes (:mod:`skfem_mpm.kernels.fbar`): the cells,
        patches and pattern of the additive average (whose rows ``b``
        they do not read: they sum the spatial average's each
        iteration)."""
        return self._cells.kernel_layout()

    def gradients(self, u: ndarray) -> ndarray:
        """``dF_bar - I`` (3, 3, n) of the increment ``u``; keeps its
        linearisation for :meth:`force` and :meth:`stiffness`."""
        dim = self.dim
        g = self.op.gradients(u)
        G = np.zeros((3, 3, g.shape[-1]))
        G[:dim, :dim] = g
        dF = G + np.eye(3)[:, :, None]
        # an inverted point or an overflowing trial (a diverging Newton
        # direction) makes these NaN: the kinematics' InversionError
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            xi_m1 = self._linearise(G, dF)
        return G * (1 + xi_m1) + np.eye(3)[:, :, None] * xi_m1

    def _linearise(self, G: ndarray, dF: ndarray):
        """The average, frame and ``(dF^-1, omega, xi)`` of the increment
        ``dF = I + G`` (3, 3, n); returns ``xi - 1``."""
        dim = self.dim
        Fi = inverse_and_det(dF, dim)[0]
        # J - 1 = I1 + I2 + I3 of g, and xi - 1, without the cancellation
        # of det dF - 1 and xi dF - I at small increments
        trace = np.einsum("aap->p", G)
        Jm1 = trace + (trace ** 2 - np.einsum("abp,bap->p", G, G)) / 2 \
            + np.linalg.det(np.moveaxis(G, -1, 0))
        R = Fi.transpose(1, 0, 2)
        vJ = self.volume * (1 + Jm1)
        average = self._spatial(self.op, vJ, np.ascontiguousarray(
            R[:dim, :dim]))
        Jc_m1 = average.cell_sum(self.volume * Jm1) \
            / average.cell_sum(self.volume)
        xi_m1 = np.expm1(np.log1p((Jc_m1 - Jm1) / (1 + Jm1)) / 3)
        self.average, self.frame = average, (dF, R)
        self._state = (Fi, vJ / average.cell_sum(vJ), 1 + xi_m1)
        return xi_m1

    def force(self, P: ndarray, w: ndarray) -> ndarray:
        """``sum_p w_p P_p : d dF_bar_p / du`` at the last linearisation
        (``P`` kept for the geometric part of :meth:`stiffness`)."""
        self._P = P
        return super().force(P, w * self._state[2])

    def stiffness(self, A: ndarray, w: ndarray):
        """The derivative of :meth:`force`: the framed material part
        (:meth:`.volumetric.MeanDilatation._framed_stiffness`, weights
        ``w xi^2``) and the geometric part of the stress of the last
        :meth:`force` at the last linearisation."""
        xi = self._state[2]
        return self._framed_stiffness(A, w * xi ** 2) \
            + self.geometric(self._P, w)

    def geometric(self, P: ndarray, w: ndarray):
        """``sum_p w_p P_p : d^2 dF_bar_p / du^2``: with ``a(u) =
        theta_c(u) - R : g(u)``, ``m = P : Q / 3`` and ``M_c = sum_(p in
        c) w xi m``, the point terms ``w xi [a(v) P : g(u) + a(u) P :
        g(v) + m a(v) a(u)] / 3 + w xi m T(u, v)`` and the cell's ``M_c
        (theta_c)'(u, v)``, ``T(u, v) = tr(dF^-1 g(u) dF^-1 g(v))``."""
        p = slice(0, self.dim)
        Fi, omega, xi = self._state
        dF, R = self.frame
        wx = w * xi
        m = np.einsum("abp,abp->p", P, dF) / 3
        M = self.average.cell_sum(wx * m)
        RR = np.einsum("abp,cdp->abcdp", R[p, p], R[p, p])
        T = np.einsum("bcp,dap->abcdp", Fi[p, p], Fi[p, p])
        PR = np.einsum("abp,cdp->abcdp", P[p, p], R[p, p])
        B = wx * (m / 3 * RR + m * T - (PR + PR.transpose(2, 3, 0, 1, 4))
                  / 3) + omega * M * (RR - T)
        row = wx * (P[p, p] - m * R[p, p]) / 3
        bulk = 3 * wx * m - 9 * omega * M
        return self.op.stiffness(B, np.ones_like(w)) \
            + self.average.couplings(row, row, bulk)
