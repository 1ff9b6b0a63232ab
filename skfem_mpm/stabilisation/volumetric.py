"""Mean dilatation on the material points: an anti-locking option for
nearly incompressible small-strain elasticity (a B-bar method).

The volumetric strain of every point is replaced by the volume average of
its element, ``theta_e = sum_p V_p div(u)_p / sum_p V_p``, and the Lame
parameter lambda by its element average, so the lambda term of the
stiffness is ``lambda_e V_e b_e b_e^T`` with ``b_e`` the averaged
divergence operator: one volumetric constraint per element instead of one
per point, which removes volumetric locking of Q1 elements as nu -> 0.5.
The stress of a point is ``2 mu eps_p + lambda_e theta_e I`` and the
internal force ``sum_p V_p sigma_p : grad(v)`` stays consistent with the
stiffness.

"""
import numpy as np
from numpy import ndarray

from ..methods.operators import PointOperator

__all__ = ["MeanDilatation"]


class MeanDilatation:
    """Element averages of one step's point operator.

    Parameters
    ----------
    op
        The step's :class:`~skfem_mpm.methods.operators.PointOperator`.
    lam, volume
        Per-point lambda (or a scalar) and volumes.

    """

    def __init__(self, op: PointOperator, lam, volume: ndarray):
        self.op = op
        basis = op.basis
        W = basis.quadrature_field(volume)                  # (e, m)
        self.volume = W.sum(axis=1)                         # V_e
        self.lam = (basis.quadrature_field(np.broadcast_to(
            lam, volume.shape) * volume)).sum(axis=1) / self.volume
        # averaged divergence operator b_e: (e, nloc_nodes, dim)
        self.b = np.einsum("aiem,em->eia", op.shape_gradients, W) \
            / self.volume[:, None, None]

    def theta(self, u: ndarray) -> ndarray:
        """Mean volumetric strain of every point's element, (n,)."""
        U = u.reshape(-1, self.op.dim)[self.op.scalar_dofs]       # (nloc, e, dim)
        per_element = np.einsum("eia,iea->e", self.b, U)
        return self.op.basis.point_values(np.broadcast_to(
            per_element[:, None], self.op.basis.point_index.shape))

    def lam_at_points(self) -> ndarray:
        """Element-averaged lambda at every point, (n,)."""
        return self.op.basis.point_values(np.broadcast_to(
            self.lam[:, None], self.op.basis.point_index.shape))

    def stiffness(self):
        """``sum_e lambda_e V_e b_e b_e^T`` in the grid's pattern."""
        b = self.b.reshape(len(self.volume), -1)            # node-major
        local = (self.lam * self.volume)[:, None, None] * b[:, :, None] \
            * b[:, None, :]
        return self.op.pattern().matrix([(self.op.elements, local)])
