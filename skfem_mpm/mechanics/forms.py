"""Load forms, seed (2.18) and (2.19), and tensor helpers.

Plain scikit-fem ``LinearForm`` s; point data reaches them as quadrature
fields (see
:meth:`~skfem_mpm.quadrature.basis.MaterialPointBasis.quadrature_field`).

"""
import numpy as np
from numpy import ndarray
from skfem.assembly import LinearForm, asm
from skfem.assembly.basis import AbstractBasis
from skfem.helpers import dot

from ..errors import InvalidInputError, check_finite

__all__ = ["body_force", "in_plane", "full_tensor", "as_body_force",
           "assemble_body_force"]


@LinearForm
def body_force(v, w):
    """``int N^T b dV``, seed (2.19), with ``b`` a (dim, ...) field or a
    constant vector.  Point forces, seed (2.18), use the same form with
    ``b = f_p / V_p`` at the points."""
    return dot(w.b, v)


def in_plane(tensor: ndarray, dim: int) -> ndarray:
    """The (dim, dim, ...) block of a (3, 3, ...) tensor."""
    return tensor[:dim, :dim]


def full_tensor(block: ndarray) -> ndarray:
    """Embed a (dim, dim, ...) block in a (3, 3, ...) tensor of zeros."""
    dim = block.shape[0]
    out = np.zeros((3, 3) + block.shape[2:])
    out[:dim, :dim] = block
    return out


def as_body_force(body_force, dim: int):
    """Validate a body force: ``None`` or a finite vector of ``dim``
    components."""
    if body_force is None:
        return None
    b = np.asarray(body_force, dtype=np.float64).ravel()
    if b.shape != (dim,):
        raise InvalidInputError("body_force must have {} components, got {}"
                                .format(dim, b.shape))
    check_finite("body_force", b)
    return b


def assemble_body_force(basis: AbstractBasis, b) -> ndarray:
    """Grid force vector of a constant body force ``b``, shape (dim,)."""
    b = np.asarray(b, dtype=np.float64).reshape(-1, 1, 1)
    return asm(body_force, basis, b=b)
