"""Material-point state and seeding helpers.

State is kept as a struct of arrays, points along the last axis:

- ``x`` (dim, n): current positions,
- ``x0`` (dim, n): initial positions (``Y`` in the seed's error measure),
- ``volume`` (n,): volumes, fixed in standard MPM,
- ``stress`` and ``strain`` (3, 3, n): full symmetric 3x3 tensors whatever
  the dimension of the grid, so that plane strain keeps ``sigma_zz`` and 1D
  keeps the lateral stresses,
- ``displacement`` (dim, n): accumulated displacement,
- ``force`` (dim, n): point forces at full load (ramped by the solver).

"""
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np
from numpy import ndarray
from skfem.mesh import Mesh
from skfem.quadrature import get_quadrature
from skfem.refdom import RefLine, RefQuad, RefHex, RefTri

from .errors import InvalidInputError, UnsupportedElementError
from .mapping import fresh_mapping

__all__ = ["MaterialPoints", "seed_points", "seed_gauss_points"]


def check_finite(name: str, a: ndarray):
    """Raise :class:`InvalidInputError` naming the first non-finite entry."""
    bad = ~np.isfinite(a)
    if bad.any():
        where = np.argwhere(bad)
        raise InvalidInputError(
            "{} holds {} non-finite value(s) (NaN or inf), first at index {}: {}"
            .format(name, int(bad.sum()), tuple(int(i) for i in where[0]),
                    a[tuple(where[0])]))


@dataclass
class MaterialPoints:
    """Material points: a moving quadrature carrying its own state.

    Parameters
    ----------
    x
        Positions, shape (dim, n).
    volume
        Volumes (length in 1D, area in 2D), shape (n,), all positive.
    force
        Optional point forces at full load, shape (dim, n).

    Examples
    --------
    >>> import numpy as np
    >>> from skfem_mpm import MaterialPoints
    >>> mp = MaterialPoints(x=np.array([[0.25, 0.75]]), volume=np.array([.5, .5]))
    >>> mp.dim, mp.n, mp.stress.shape
    (1, 2, (3, 3, 2))

    """
    x: ndarray
    volume: ndarray
    force: Optional[ndarray] = None
    x0: Optional[ndarray] = None
    stress: Optional[ndarray] = None
    strain: Optional[ndarray] = None
    displacement: Optional[ndarray] = None
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        self.x = np.array(self.x, dtype=np.float64)
        self.volume = np.array(self.volume, dtype=np.float64)
        if self.x.ndim != 2 or not 1 <= self.x.shape[0] <= 3:
            raise InvalidInputError(
                "x must have shape (dim, n) with dim 1, 2 or 3, got {}"
                .format(self.x.shape))
        dim, n = self.x.shape
        if n == 0:
            raise InvalidInputError("MaterialPoints needs at least one point")
        if self.volume.shape != (n,):
            raise InvalidInputError(
                "volume must have shape ({},) to match x {}, got {}"
                .format(n, self.x.shape, self.volume.shape))
        check_finite("x", self.x)
        check_finite("volume", self.volume)
        if (self.volume <= 0).any():
            i = int(np.argmax(self.volume <= 0))
            raise InvalidInputError(
                "volume must be positive: {} point(s) are not, first point {} "
                "has volume {}".format(int((self.volume <= 0).sum()), i,
                                       self.volume[i]))
        defaults = {
            "force": (dim, n), "x0": None, "stress": (3, 3, n),
            "strain": (3, 3, n), "displacement": (dim, n),
        }
        for name, shape in defaults.items():
            value = getattr(self, name)
            if value is None:
                value = self.x.copy() if name == "x0" else np.zeros(shape)
            value = np.array(value, dtype=np.float64)
            expected = self.x.shape if shape is None else shape
            if value.shape != expected:
                raise InvalidInputError("{} must have shape {}, got {}"
                                        .format(name, expected, value.shape))
            check_finite(name, value)
            setattr(self, name, value)

    @property
    def dim(self) -> int:
        return self.x.shape[0]

    @property
    def n(self) -> int:
        return self.x.shape[1]

    def copy(self) -> "MaterialPoints":
        """Return a deep copy of the state."""
        return MaterialPoints(
            x=self.x.copy(), volume=self.volume.copy(), force=self.force.copy(),
            x0=self.x0.copy(), stress=self.stress.copy(),
            strain=self.strain.copy(), displacement=self.displacement.copy(),
            extra={k: np.copy(v) for k, v in self.extra.items()})


def _subcell_centres(refdom, n: int) -> ndarray:
    """Local coordinates of the centres of n^d equal sub-cells, (dim, n^d)."""
    if refdom in (RefLine, RefQuad, RefHex):
        c = (2 * np.arange(n) + 1) / (2 * n)
        grids = np.meshgrid(*([c] * refdom.dim()), indexing="ij")
        return np.array([g.ravel() for g in grids])
    if refdom is RefTri:
        # uniform split into n^2 triangles: centroids of upward and downward
        i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        up = (i + j) <= n - 1
        down = (i + j) <= n - 2
        cu = np.array([(i[up] + 1 / 3), (j[up] + 1 / 3)]) / n
        cd = np.array([(i[down] + 2 / 3), (j[down] + 2 / 3)]) / n
        return np.hstack((cu, cd))
    raise UnsupportedElementError(
        "equal sub-cell seeding is defined for line, quadrilateral, hexahedral "
        "and triangular grids, not {}; use seed_gauss_points".format(
            refdom.__name__))


def _points_from_reference(mesh: Mesh, X: ndarray, w: ndarray,
                           region, elements) -> MaterialPoints:
    """Map reference points X with reference weights w into every element."""
    tind = (np.arange(mesh.nelements) if elements is None
            else np.asarray(elements, dtype=np.int64))
    mapping = fresh_mapping(mesh)
    x = mapping.F(X, tind=tind)                       # (dim, nel, nq)
    detJ = np.abs(mapping.detDF(X, tind=tind))        # (nel, nq)
    volume = (detJ * w).ravel()
    x = x.reshape(mesh.dim(), -1)
    if region is not None:
        keep = np.asarray(region(x), dtype=bool)
        if keep.shape != (x.shape[1],):
            raise InvalidInputError(
                "region must return one bool per point, shape ({},), got {}"
                .format(x.shape[1], keep.shape))
        x, volume = x[:, keep], volume[keep]
    if x.shape[1] == 0:
        raise InvalidInputError("the region holds no material point")
    return MaterialPoints(x=x, volume=volume)


def seed_points(mesh: Mesh, n: int, region: Optional[Callable] = None,
                elements: Optional[ndarray] = None) -> MaterialPoints:
    """Seed n^d points per element at the centres of equal sub-cells.

    Each point receives the volume of its sub-cell (seed Figure 2.4), so the
    points of an element add up to the element's volume.

    Parameters
    ----------
    mesh
        A scikit-fem mesh (line, quadrilateral, hexahedral or triangle).
    n
        Points per element and direction (n^d points per element; for
        triangles n^2 sub-triangles).
    region
        Optional callable ``region(x) -> bool array``: keep only the points
        whose coordinates (dim, npoints) satisfy it.
    elements
        Optional array of element indices to seed (default: all).

    Examples
    --------
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import seed_points
    >>> mp = seed_points(MeshQuad().refined(1), 2)
    >>> mp.n, float(mp.volume.sum())
    (16, 1.0)

    """
    if int(n) != n or n < 1:
        raise InvalidInputError("n must be a positive integer, got {}".format(n))
    X = _subcell_centres(mesh.refdom, int(n))
    w = np.full(X.shape[1], _reference_volume(mesh.refdom) / X.shape[1])
    return _points_from_reference(mesh, X, w, region, elements)


def _reference_volume(refdom) -> float:
    _, W = get_quadrature(refdom, 0)
    return float(W.sum())


def seed_gauss_points(mesh: Mesh, intorder: int = 2,
                      region: Optional[Callable] = None,
                      elements: Optional[ndarray] = None) -> MaterialPoints:
    """Seed points at the Gauss points of each element, volumes = weights.

    With these points a one-step MPM analysis is the finite element
    analysis with the same quadrature, to round-off.

    Parameters
    ----------
    mesh
        Any scikit-fem mesh.
    intorder
        Integration order of scikit-fem's quadrature rule (as ``Basis``).
    region, elements
        As in :func:`seed_points`.

    Examples
    --------
    >>> from skfem import MeshTri
    >>> from skfem_mpm import seed_gauss_points
    >>> mp = seed_gauss_points(MeshTri(), intorder=2)
    >>> mp.n, round(float(mp.volume.sum()), 12)
    (6, 1.0)

    """
    X, W = get_quadrature(mesh.refdom, intorder)
    return _points_from_reference(mesh, X, W, region, elements)
