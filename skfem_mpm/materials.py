"""Constitutive models.

Stresses and strains are full symmetric 3x3 tensors, shape (3, 3, ...):
plane strain is the 3D law with ``eps_zz = eps_xz = eps_yz = 0`` and 1D is
uniaxial strain (all lateral strains zero), so one law serves every
dimension.

"""
from dataclasses import dataclass

import numpy as np
from numpy import ndarray
from skfem.assembly import BilinearForm
from skfem.models.elasticity import linear_elasticity

from .errors import InvalidMaterialError

__all__ = ["LinearElastic"]


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
    >>> from skfem_mpm.materials import LinearElastic
    >>> mat = LinearElastic(E=1e6, nu=0.)
    >>> eps = np.zeros((3, 3, 1)); eps[0, 0] = 1e-3
    >>> float(mat.stress(eps)[0, 0, 0])
    1000.0

    """
    E: float
    nu: float

    def __post_init__(self):
        E, nu = float(self.E), float(self.nu)
        if not np.isfinite(E) or E <= 0:
            raise InvalidMaterialError(
                "Young's modulus E must be positive and finite, got {}"
                .format(self.E))
        if not np.isfinite(nu) or not -1. < nu < .5:
            raise InvalidMaterialError(
                "Poisson's ratio nu must lie in (-1, 0.5), got {}"
                .format(self.nu))

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

    def stiffness_form(self) -> BilinearForm:
        """The tangent stiffness as a scikit-fem form, seed (2.20)."""
        return linear_elasticity(self.lam, self.mu)
