"""The seed's numerical example: a column compressed by its own weight.

Height ``L0 = 50``, ``E = 1e6``, ``nu = 0``, body force ramped to
``rho0 b = 800`` per unit volume (40000 in all, shortening the column by
about 1), fixed at the base (seed 2.2.3, Figure 2.8: Charlton 2018, PhD
thesis, Durham University, Chapter 2; ``docs/references.md``).  In 1D the column is a
line of elements; in 2D a plane-strain strip one element wide on rollers,
which gives the same answer.

"""

import numpy as np
from numpy import ndarray
from skfem import ElementLineP1, ElementQuad1, MeshLine, MeshQuad

from ..errors import InvalidInputError
from ..mechanics.materials import LinearElastic
from ..quadrature.points import MaterialPoints, seed_points
from ..scenes.regions import region_shape
from ..solve.results import Result
from ..solve.small import solve_mpm

__all__ = ["SOURCE", "HEIGHT", "LOAD", "MATERIAL", "column_grid", "run_column",
           "column_error", "column_extent", "analytical_stress",
           "analytical_stress_current", "vertical_stress"]

#: how figures and messages cite the source of the column, its closed
#: forms (2.27) and its error measure (2.28): the seed, Chapter 2 of
#: Charlton's thesis (full citation in ``docs/references.md``)
SOURCE = "Charlton (2018)"
HEIGHT = 50.
LOAD = 800.
MATERIAL = LinearElastic(E=1e6, nu=0.)


def column_grid(nelems: int, dim: int = 1):
    """Background grid and element of a column of ``nelems`` elements."""
    y = np.linspace(0., HEIGHT, nelems + 1)
    if dim == 1:
        return MeshLine(y), ElementLineP1()
    if dim == 2:
        h = HEIGHT / nelems
        return MeshQuad.init_tensor(np.array([0., h]), y), ElementQuad1()
    raise ValueError("the column is defined in 1D and 2D, not {}D".format(dim))


def column_supports(dim: int):
    """Fixed base; in 2D, rollers on both sides (no horizontal motion)."""
    def supports(basis):
        base = basis.get_dofs(lambda x: np.isclose(x[-1], 0.)).all()
        if dim == 1:
            return base
        return np.concatenate((base, basis.nodal_dofs[0]))
    return supports


def vertical_stress(points: MaterialPoints) -> ndarray:
    """The vertical normal stress of every point."""
    d = points.dim - 1
    return points.stress[d, d]


def analytical_stress(Y: ndarray, load: float = LOAD,
                      height: float = HEIGHT) -> ndarray:
    """``sigma = -rho0 b (L0 - Y)`` at initial heights Y: the linear
    solution, and the exact Cauchy stress of any elastic law for a column
    on rollers (the weight above a point over an unchanged area)."""
    return -load * (height - Y)


def analytical_stress_current(z: ndarray, top: float) -> ndarray:
    """Seed (2.27): the stress at current height z of a column of current
    height ``top`` (compression negative),
    ``E (sqrt(2 rho0 b / E (top - z) + 1) - 1)`` with the body force
    ``rho0 b = -LOAD`` pointing down: at the base of the column of current
    height ``L0 - LOAD L0^2 / (2 E)`` (49 of 50) it carries the weight
    ``-LOAD L0``.

    It is exact for the law ``sigma = E (F - 1)`` (Cauchy stress linear
    in the stretch): the small-strain solution's displacement field,
    ``u(Y) = -rho0 b (L0 Y - Y^2 / 2) / E``, written in current
    coordinates ``z = Y + u``.  The chapter takes it from its reference
    [15] without naming a law.  It is *not* the exact solution of this
    package's finite-deformation kinematics (Hencky: Kirchhoff stress
    ``E ln F``, Cauchy ``E ln F / F`` in 1D), whose column's top lies at
    ``(E / rho0 b) (w + w^2 / 2)``, ``w = W(rho0 b L0 / E)`` (Lambert's
    W), 49.0380 of 50 (a shortening of 0.9620, not 1; finite-deformation
    runs reproduce it, ``tests/test_finite.py``).  The two laws' stresses
    at one current height differ at second order in the strain (here by
    up to 30, near the top, against the base's 40000).

    >>> from skfem_mpm.studies.column import analytical_stress_current
    >>> round(float(analytical_stress_current(0., 49.)), 6)
    -40000.0
    """
    E = MATERIAL.E
    return E * (np.sqrt(1 - 2 * LOAD / E * (top - z)) - 1)


def column_error(points: MaterialPoints, load: float = LOAD,
                 height: float = HEIGHT, base: float = 0.) -> float:
    """The error measure (2.28) of Charlton (2018): ``sum_p |sigma_a(Y_p) - sigma_p| V_p / (W L0)``.

    Normalised by the weight ``W = rho0 b L0 V0 / L0`` and the height: the
    sum is divided by ``rho0 b L0 V0`` with ``V0`` the total initial volume,
    which in 1D is the seed's ``W L0``.  ``V_p`` are the current volumes
    (fixed in small strain).  ``height`` is the column's length ``L0``
    (finite and positive), ``base`` the initial height of its base.

    The closed form is taken at the points' *initial* heights ``Y_p``
    (:func:`analytical_stress`), where the seed writes ``sigma(Z_p)`` of
    (2.27) at their current positions: on a column on rollers the Cauchy
    stress at a material point is the weight above it over an unchanged
    area for any elastic law, while (2.27) is that stress in current
    coordinates for one law (``sigma = E (F - 1)``, not the Hencky law
    of finite deformation: :func:`analytical_stress_current`) and needs
    the run's current height.  So the
    measure holds for every law and kinematics, and sees the stresses
    only, not where the points went: a small-strain run at 20% strain
    (body force 8000, 32 elements, one step) reads 7.8e-3 with its top
    at -9.998, finite deformation's at -7.333 (a trial's).  Measure a
    displacement to judge kinematics (``docs/accuracy_vs_time.md``,
    section 1).

    """
    if not (np.isfinite(height) and height > 0 and np.isfinite(base)):
        raise InvalidInputError(
            "the column's error measure (2.28) of " + SOURCE + " needs a "
            "finite height > 0 and a "
            "finite base, got height {!r}, base {!r}".format(height, base))
    Y = points.x0[-1] - base
    diff = np.abs(analytical_stress(Y, load, height) - vertical_stress(points))
    return float(diff @ points.volume / (load * height
                                         * points.volume0.sum()))


def column_extent(scene) -> tuple:
    """``(load, base, height)`` of a scene whose ``reference`` is
    ``"column"``: the magnitude of its gravity along the last axis, the
    bottom of its first body and the body's height, its box clipped to
    the grid (an axis left out of a scene file's region is the whole
    grid's, ``[-inf, inf]`` before clipping).

    Raises
    ------
    InvalidInputError
        When the closed form does not apply: no gravity along the last
        axis, a body region given as a function, or a body of no height.

    Examples
    --------
    >>> from skfem_mpm.scenes.scene_file import EMBEDDED, load_scene
    >>> column_extent(load_scene(EMBEDDED))
    (800.0, 0.0, 50.0)
    """
    weights = scene.body_forces()
    gravity = None if weights is None else weights[0]
    if gravity is None or not gravity.size or gravity[-1] == 0 or \
            not np.isfinite(gravity[-1]):
        raise InvalidInputError(
            "reference 'column' measures the stress of a column under its "
            "own weight: the scene needs gravity along its last axis, got "
            "{}".format(None if gravity is None else gravity.tolist()))
    body = scene.bodies[0]
    if callable(body.region):
        raise InvalidInputError(
            "reference 'column': body {!r} needs a box region, region = "
            "{{ y = [lo, hi] }} (its height is the closed form's L0), not "
            "a {}".format(body.name, region_shape(body.region)))
    if scene.grid.mesh is not None:
        grid = scene.grid.mesh.p[-1]
        grid_lo, grid_hi = float(grid.min()), float(grid.max())
    else:
        grid_lo, grid_hi = (float(v) for v in scene.grid.axes[-1][:2])
    lo, hi = (float(v) for v in body.region[-1])
    base, top = max(lo, grid_lo), min(hi, grid_hi)
    if not top > base:
        raise InvalidInputError(
            "reference 'column': body {!r} has no height within the grid "
            "(from {} to {} along the last axis)".format(body.name, base,
                                                         top))
    return float(abs(gravity[-1])), base, top - base


def run_column(nelems: int, ppc: int = 2, nsteps: int = 1, dim: int = 1,
               **kwargs) -> Result:
    """Run the column with ``ppc`` points per element and direction.

    Extra keyword arguments go to :func:`~skfem_mpm.solve_mpm`.

    Examples
    --------
    >>> from skfem_mpm.studies.column import run_column, column_error
    >>> res = run_column(4, ppc=2, nsteps=1)
    >>> round(column_error(res.points), 6)   # h / (4 L0)
    0.0625

    """
    mesh, elem = column_grid(nelems, dim)
    points = seed_points(mesh, ppc)
    body_force = np.zeros(dim)
    body_force[-1] = -LOAD
    return solve_mpm(mesh, elem, points, MATERIAL, column_supports(dim),
                     body_force=body_force, nsteps=nsteps, **kwargs)
