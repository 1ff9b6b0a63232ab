"""Mean dilatation on the material points: the B-bar method (Hughes 1980)
against volumetric locking, in small strain and finite deformation.

The volumetric part of every point's displacement gradient is replaced by
the volume average over the points of its element,

    grad_bar(u) = grad(u) + (theta_e(u) - div(u)) I / 3,
    theta_e(u) = sum_p V_p div(u)_p / sum_p V_p,

one volumetric constraint per element instead of one per point, which
removes the locking of Q1 elements as nu -> 0.5.  The modified gradient is
linear in the displacement, so wrapping the step's point operator is all it
takes: stresses follow from ``grad_bar``, and internal force and tangent
use the same operator, so Newton keeps its quadratic rate.  Homogeneous
deformations are unchanged (``theta_e = div(u)``): the patch test still
passes.

The tensors are 3x3 whatever the grid's dimension: in plane strain (and
uniaxial strain in 1D) ``grad(u)`` is the 3x3 gradient whose out-of-plane
components are zero, and its volumetric part is replaced as in 3D, so
``grad_bar`` has the out-of-plane diagonal ``(theta_e - div) / 3``.  Plane
strain is then 3D with ``u_z = 0`` (equal to round-off, tested); the
earlier correction over the in-plane components alone (``I / 2`` on the
2x2 block) differed from it by 0.57% of a cantilever's tip deflection at
nu = 0.45.  The operator therefore exchanges (3, 3, n) gradients and
stresses and (3, 3, 3, 3, n) tangents (``components = 3``), whose
out-of-plane parts the kinematics supply.

In finite deformation the average acts on each load step's increment,
``dF = I + grad_bar(du)`` in the step's configuration (an incremental
mean dilatation, as material points change cells between steps), not on
the total deformation gradient as the F-bar method of de Souza Neto et al.
(1996) for finite elements: the answer then depends on the load path at
the order of the increment.  Measured on a block under gravity with
nu = 0.45 and 50% strain (finite elements, Hencky): 1 and 8 load steps
differ by 0.4% of the displacement (4e-14 without the average).

"""
import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError
from ..methods.operators import PointOperator

__all__ = ["MeanDilatation"]


def _traces(A: ndarray, dim: int):
    """``tr1_cd = A_aacd``, ``tr2_ab = A_abcc`` and ``tr12 = A_aacc``."""
    tr1 = np.einsum("aacdp->cdp", A)
    tr2 = np.einsum("abccp->abp", A)
    return tr1, tr2, np.einsum("aap->p", tr1)


class MeanDilatation:
    """The B-bar twin of one step's
    :class:`~skfem_mpm.methods.operators.PointOperator`: same interface,
    gradients ``grad_bar``, but with 3x3 tensors in every dimension:
    ``gradients(u)`` is (3, 3, n), ``force`` takes a (3, 3, n) stress and
    ``stiffness`` a (3, 3, 3, 3, n) tangent (``components``).

    Parameters
    ----------
    op
        The step's point operator (standard MPM or FE: GIMP points span
        several cells, which have no single average).
    volume
        Point volumes weighting the element averages, (n,).

    """

    #: the components of the gradients, stresses and tangents exchanged
    #: with the kinematics: the volumetric part of the 3x3 tensor is the one
    #: replaced, in plane strain as in 3D
    components = 3

    def __init__(self, op, volume: ndarray):
        if not isinstance(op, PointOperator):
            raise InvalidInputError(
                "antilocking (mean dilatation) averages over the points of "
                "each grid cell: it needs method 'mpm' or 'fem', not GIMP "
                "(whose points span several cells)")
        self.op, self.dim = op, op.dim
        for name in ("N", "nelems", "elements", "active_dofs", "values",
                     "point_force", "adjacency", "point_elements", "basis",
                     "connectivity_from_elements"):
            setattr(self, name, getattr(op, name))
        basis = op.basis
        W = basis.quadrature_field(volume)                   # (e, slots)
        # averaged gradient b_e: theta_e(u) = sum_ia b_e[i, a] u_ia
        self.b = np.einsum("aiem,em->eia", op.shape_gradients, W) \
            / W.sum(axis=1)[:, None, None]

    def _element_values(self, u: ndarray) -> ndarray:
        """theta_e(u) at every point, (n,)."""
        U = u.reshape(-1, self.dim)[self.op.scalar_dofs]     # (nloc, e, dim)
        theta = np.einsum("eia,iea->e", self.b, U)
        basis = self.op.basis
        return basis.point_values(np.broadcast_to(
            theta[:, None], basis.point_index.shape))

    def gradients(self, u: ndarray) -> ndarray:
        """``grad_bar(u)``, (3, 3, n): out of plane the volumetric shift
        alone."""
        g = self.op.gradients(u)
        shift = (self._element_values(u) - np.einsum("aap->p", g)) / 3
        if self.dim < 3:
            g = np.concatenate((g, np.zeros((3 - self.dim,) + g.shape[1:])))
            g = np.concatenate((g, np.zeros((3, 3 - self.dim, g.shape[-1]))),
                               axis=1)
        return g + np.eye(3)[:, :, None] * shift

    def _scatter_elements(self, local: ndarray) -> ndarray:
        """Element vectors (e, nloc, dim) onto the grid."""
        return np.bincount(self.op.element_dofs.ravel(),
                           weights=local.reshape(len(local), -1).T.ravel(),
                           minlength=self.N)

    def force(self, P: ndarray, w: ndarray) -> ndarray:
        """``sum_p w_p P_p : grad_bar(N)`` of a (3, 3, n) stress ``P``:
        its in-plane deviator (with respect to the 3x3 mean) against the
        gradients, its mean against the element averages."""
        dim = self.dim
        mean = np.einsum("aap->p", P) / 3
        s = self.op.basis.quadrature_field(w * mean).sum(axis=1)    # (e,)
        return self.op.force(P[:dim, :dim] - np.eye(dim)[:, :, None] * mean,
                             w) \
            + self._scatter_elements(self.b * s[:, None, None])

    def stiffness(self, A: ndarray, w: ndarray):
        """``sum_p w_p grad_bar(N) : A_p : grad_bar(N)`` of a (3, 3, 3, 3,
        n) tangent ``A``: traces over the three components, the in-plane
        block against the gradients."""
        dim = self.dim
        uniform = A.strides[-1] == 0
        An = A[..., :1] if uniform else A
        tr1, tr2, tr12 = _traces(An, 3)
        p = slice(0, dim)                                   # in-plane block
        An, tr1, tr2 = An[p, p, p, p], tr1[p, p], tr2[p, p]
        eye = np.eye(dim)
        dd = np.einsum("ab,cd->abcd", eye, eye)[..., None]
        deviatoric = An - (np.einsum("ab,cdp->abcdp", eye, tr1)
                           + np.einsum("abp,cd->abcdp", tr2, eye)) / 3 \
            + dd * tr12 / 9
        R = (tr1 - eye[:, :, None] * tr12 / 3) / 3          # row: theta_v
        L = (tr2 - eye[:, :, None] * tr12 / 3) / 3          # column: theta_u
        if uniform:
            n = A.shape[-1]
            deviatoric = np.broadcast_to(deviatoric, deviatoric.shape[:-1]
                                         + (n,))
            R, L, tr12 = (np.broadcast_to(a, a.shape[:-1] + (n,))
                          for a in (R, L, tr12))
        basis, G = self.op.basis, self.op.shape_gradients  # (dim, nloc, e, m)
        field = basis.quadrature_field
        h_row = np.einsum("cdem,djem->ejc", field(R * w), G)
        h_col = np.einsum("abem,biem->eia", field(L * w), G)
        vol = field(tr12 * w).sum(axis=1) / 9
        e = len(self.b)
        b = self.b.reshape(e, -1)
        local = b[:, :, None] * h_row.reshape(e, -1)[:, None, :] \
            + h_col.reshape(e, -1)[:, :, None] * b[:, None, :] \
            + vol[:, None, None] * b[:, :, None] * b[:, None, :]
        return self.op.stiffness(deviatoric, w) \
            + self.op.pattern().matrix([(self.elements, local)])
