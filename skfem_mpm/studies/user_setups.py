"""Set-ups as a new user writes them, nothing tuned: a grid of spacing
``h`` around the body, ``per_cell`` points per cell and axis, the method's
defaults.  They measure robustness off the shipped benchmarks
(``benchmarks/user_matrix.py``, the table of ``docs/robustness.md``, and a
subset in the tests); the cantilever is
:func:`~skfem_mpm.studies.elastica.untuned_cantilever`.

Each returns the :class:`~skfem_mpm.Result` and the set-up's quantity of
interest.
"""
from typing import Optional

import numpy as np
from skfem import ElementQuad1, MeshQuad

from ..mechanics.materials import LinearElastic, VonMises
from ..quadrature.points import seed_points
from ..solve.core import simulate
from ..solve.loads import Traction, side_points
from ..solve.options import Options, Prescribed

__all__ = ["block", "footing", "slope"]


def grid(x, y, h):
    """A tensor grid of spacing ``h`` (about) over ``x`` by ``y``."""
    return MeshQuad.init_tensor(np.arange(x[0], x[1] + 1e-9, h),
                                np.arange(y[0], y[1] + 1e-9, h))


def base_and_rollers(width: float):
    """The supports of soil over ``0 <= x <= width`` on a grid from
    ``y = 0``: the base fixed, both sides on rollers (``u^1`` fixed).

    Examples
    --------
    >>> from skfem import Basis, ElementQuad1, ElementVector
    >>> from skfem_mpm.studies.user_setups import base_and_rollers, grid
    >>> basis = Basis(grid((0., 1.), (0., 1.), .5),
    ...               ElementVector(ElementQuad1()))
    >>> fixed = np.unique(base_and_rollers(1.)(basis))
    >>> fixed.size        # 3 base nodes x 2, 2 more nodes x 1 a side
    10
    """
    def supports(b):
        return np.concatenate([
            b.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
            b.get_dofs(lambda x: np.isclose(x[0], 0.)
                       | np.isclose(x[0], width)).all("u^1")])
    return supports


def block(h: float, per_cell: int, method: str, traction,
          options: Optional[Options] = None):
    """A soft block (1 x 1, E = 1e3, nu = 0.3) on a clamped base, loaded
    by a ``traction`` on its top in 10 steps, finite deformation: returns
    the result and the mean displacement of the top points."""
    mesh = grid((-.5, 2.), (0., 1.5), h)
    points = seed_points(mesh, per_cell, region=lambda x: (x[0] > 0)
                         & (x[0] < 1) & (x[1] < 1))
    top = side_points(points, "top")
    res = simulate(mesh, ElementQuad1(), points, LinearElastic(1e3, .3),
                   lambda b: b.get_dofs(lambda x: x[1] == 0),
                   loads=[Traction(top, "top", traction)], nsteps=10,
                   method=method, kinematics="finite", options=options)
    return res, res.points.displacement[:, top].mean(axis=1)


def footing(h: float, per_cell: int, method: str, settlement: float = .02,
            options: Optional[Options] = None):
    """A smooth strip footing (half-width 0.25, on the symmetry line x = 0)
    pushed into undrained soil (2 wide, 1 deep, von Mises with
    ``yield_stress`` 100, so ``c_u = 100 / sqrt 3``, E = 1e4, nu = 0.3) by
    ``settlement`` in 10 steps of prescribed displacement of the grid nodes
    under it, finite deformation; base fixed, sides on rollers.  Returns
    the result and the footing pressure at the end in units of ``c_u``
    (measured 4.07 at h = 1/32, 5.52 at h = 0.25, on the way to Prandtl's
    collapse pressure ``2 + pi``).

    The footing is the grid nodes under it: a settlement of more than a cell
    leaves them without material (refused, a
    :class:`~skfem_mpm.errors.PrescribedMotionError`), and one of a good part
    of a cell leaves them weakly supported; the default stays below the
    finest spacing of the benchmark (1/32)."""
    half, depth, cu = .25, 1., 100. / np.sqrt(3.)
    mesh = grid((0., 2.), (0., depth + .5), h)
    points = seed_points(mesh, per_cell, region=lambda x: x[1] < depth)
    under = np.flatnonzero(np.isclose(mesh.p[1], depth)
                           & (mesh.p[0] <= half + 1e-9))

    def pushed(b, f_old, f_new):
        return b.nodal_dofs[1, under], np.full(under.size, -settlement * (
            f_new - f_old))
    res = simulate(mesh, ElementQuad1(), points,
                   VonMises(1e4, .3, yield_stress=100.),
                   base_and_rollers(2.), loads=[Prescribed(pushed)],
                   nsteps=10, method=method, kinematics="finite",
                   options=options)
    force = res.history[-1].reactions[2 * under + 1].sum()   # y at nodes
    return res, abs(force) / half / cu


def slope(h: float, per_cell: int, method: str,
          options: Optional[Options] = None):
    """A 45 degree slope of height 1 on a base layer 1 deep (crest at
    x = 1, toe at x = 2, the ground 4 long) under its own weight (20 per
    unit volume) in 10 steps, undrained von Mises soil with ``c_u = 6``
    (``gamma H / c_u = 3.3``, stable: Taylor's stability number at 45
    degrees is about 5.5), E = 1e4, nu = 0.3, finite deformation; base
    fixed, sides on rollers.  Returns the result and the mean displacement
    of the points within 0.25 of the crest."""
    mesh = grid((0., 4.), (0., 2.5), h)
    points = seed_points(mesh, per_cell, region=lambda x: x[1] < 1. + np.clip(
        2. - x[0], 0., 1.))
    crest = np.flatnonzero(np.hypot(points.x[0] - 1., points.x[1] - 2.)
                           < .25)
    res = simulate(mesh, ElementQuad1(), points,
                   VonMises(1e4, .3, yield_stress=6. * np.sqrt(3.)),
                   base_and_rollers(4.), body_force=[0., -20.], nsteps=10,
                   method=method, kinematics="finite", options=options)
    return res, res.points.displacement[:, crest].mean(axis=1)
