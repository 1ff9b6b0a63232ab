"""Rigid bodies pushed by prescribed displacement: footings, piles,
indenters that move with the material.

A rigid body is a body of material points (``points.body == body``) whose
motion is prescribed: in every load step the grid nodes of the cells that
hold its points follow its displacement increment.  Its points then move
rigidly, and so does the material of other bodies in those cells: contact
is smeared over a cell, no-slip (``rough``: its points move rigidly) or
free to slide across the motion (``smooth``: only the components along
which the body moves are prescribed, the others follow its stiffness).
Unlike prescribed grid nodes, the pushed nodes change with the body, so a
footing can sink through the grid by many cells (the rigid body of the MPM
codes Anura3D and Kratos works the same way).  Its contact then sits up
to a cell below its base and moves down a cell at a time: the force jumps
by about 15% as the base crosses a grid line (a footing of width 8 h).
For penetration by many cells, move the grid with the footing instead
(the moving-mesh concept of Beuth 2012 and Phuong et al., *Int. J.
Numer. Anal. Methods Geomech.* 40, 2016; ``examples/penetration.py``).
The contact is the faces of whole cells, so a body whose sides cut the
cells (a circular footing on a square grid) pushes more than its own
area, and its force is the push on those cells: the run's start warns
where the cells' volume differs from its points' by more than 5%
(:func:`warn_rigid_cells`).

The force that holds the motion is the sum of the reactions at the body's
prescribed DOFs other than supported ones (internal minus external force
there: the force applied to the grid to move it, downward when a footing
pushes down, plus upward the weight of the points in its cells), recorded
per step in :attr:`~skfem_mpm.StepRecord.rigid_forces`: the
load-displacement curve of a footing.  Standard MPM (and FE) only: a GIMP
point reaches nodes beyond its cell.
"""
import logging
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy import ndarray

from ..errors import InvalidInputError, check_real

logger = logging.getLogger(__name__)

__all__ = ["RigidBody"]


@dataclass(frozen=True)
class RigidBody:
    """A body moved rigidly by prescribed displacement.

    Parameters
    ----------
    body
        The index of the body (``points.body``) that is rigid.  Its points
        keep a material, which acts only where the body's nodes are free:
        nowhere for a rough body; across the motion for a smooth one, where
        it should be soft (an elastic modulus far below the soil's, e.g. a
        thousandth): a stiff material there holds the soil's nodes against
        sliding and the body is rough in effect.
    displacement
        Displacement (dim,) at full load, reached in proportion to the load
        factor.
    rough
        ``True`` (default): every component of the pushed nodes follows
        the body (no slip).  ``False``: only the components in which
        ``displacement`` is non-zero.

    Examples
    --------
    >>> from skfem_mpm import RigidBody
    >>> RigidBody(1, [0., -.1]).increment(.25, .5).tolist()
    [0.0, -0.025]
    """
    body: int
    displacement: Sequence[float]
    rough: bool = True

    def __post_init__(self):
        if isinstance(self.body, bool) or not isinstance(
                self.body, (int, np.integer)) or self.body < 0:
            raise InvalidInputError("RigidBody: body must be a body index "
                                    ">= 0, got {!r}".format(self.body))
        d = np.asarray([check_real("RigidBody displacement", v)
                        for v in np.ravel(self.displacement)])
        if d.ndim != 1 or d.size not in (1, 2, 3) or \
                not np.isfinite(d).all() or not d.any():
            raise InvalidInputError(
                "RigidBody: displacement must be a finite, non-zero vector "
                "of 1 to 3 components, got {!r}".format(self.displacement))
        if not isinstance(self.rough, (bool, np.bool_)):
            raise InvalidInputError("RigidBody: rough must be True or False, "
                                    "got {!r}".format(self.rough))
        object.__setattr__(self, "displacement", tuple(d.tolist()))

    def increment(self, f_old: float, f_new: float) -> ndarray:
        """The displacement increment from load factor ``f_old`` to
        ``f_new``."""
        return np.asarray(self.displacement) * (f_new - f_old)

    def dofs(self, element_dofs: ndarray, point_elements: ndarray,
             points) -> ndarray:
        """The grid DOFs it drives in a step: those of the cells its points
        sit in (``point_elements``, the cell of each point;
        ``element_dofs``, the vector DOFs of each cell, component
        ``dof % dim``), every component (rough) or the moving ones."""
        cells = np.unique(point_elements[points.body == self.body])
        dofs = np.unique(element_dofs[:, cells])
        if self.rough:
            return dofs
        return dofs[np.asarray(self.displacement)[dofs % points.dim] != 0]


def warn_stiff_smooth_bodies(rigid_bodies, material, points):
    """Log a warning for each smooth rigid body whose material is stiffer
    (shear modulus) than a tenth of the softest other body's: across its
    motion it holds the nodes it shares with them, so it is rough in
    effect.  ``material``: the run's materials per point
    (:class:`~skfem_mpm.mechanics.materials.PointMaterials`)."""
    materials = getattr(material, "materials", None)
    if materials is None:
        return                      # one material: nothing to compare
    rigid = {b.body for b in rigid_bodies}
    others = [materials[k].mu for k in np.unique(points.body)
              if k not in rigid and k < len(materials)]
    for b in rigid_bodies:
        if not b.rough and others and materials[b.body].mu > .1 * min(others):
            logger.warning(
                "smooth rigid body %d: its material (shear modulus %.3g) is "
                "not soft beside the other bodies' (least %.3g): across the "
                "motion it holds the nodes it shares with them and slides "
                "no more than a rough body; give it a modulus far below "
                "theirs", b.body, materials[b.body].mu, min(others))


#: the relative difference between the volume of the cells a rigid body
#: drives and that of its points beyond which the run is warned
CELLS_TOLERANCE = .05


def warn_rigid_cells(rigid_bodies, mesh, points, locate=None) -> None:
    """Log a warning, at the run's start, for each rigid body whose points
    sit in cells of a volume (area in 2D) that differs from the points'
    by more than :data:`CELLS_TOLERANCE`: the body drives those cells'
    nodes, so its contact is their faces, a staircase of whole cells,
    and its force (:attr:`~skfem_mpm.StepRecord.rigid_forces`) the push
    on them, not on its outline (a user trial's circular footing, a
    quarter circle of area 0.196 on cells of h = 0.25, 0.167 and 0.125,
    pushed cells of area 0.250, 0.222 and 0.234).  Only a body whose
    points are where they were seeded (``x == x0``): one that has sunk
    into the next row of cells (a resumed or staged push) straddles two
    rows by design.  ``locate``: the run's point locator (built here
    without one)."""
    if not rigid_bodies:
        return
    from skfem import Basis

    from ..quadrature.locate import point_locator
    locate = point_locator(mesh) if locate is None else locate
    cells = np.asarray(locate(points.x)[0])
    for rigid in rigid_bodies:
        mine = points.body == rigid.body
        if points.x0 is not None and not np.array_equal(
                points.x[:, mine], points.x0[:, mine]):
            continue
        held = np.unique(cells[mine])
        cells_volume = float(Basis(mesh, mesh.elem(), elements=held)
                             .dx.sum())
        volume = float(points.volume[mine].sum())
        if abs(cells_volume - volume) <= CELLS_TOLERANCE * volume:
            continue
        word = {1: "a length", 2: "an area"}.get(mesh.dim(), "a volume")
        logger.warning(
            "rigid body %d: its points hold %s of %.4g, the %d cells "
            "they sit in %.4g (%+.1f%%), and the body drives those cells' "
            "nodes: its contact is their faces (a staircase of whole "
            "cells, not its outline) and its force the push on them, so a "
            "pressure is the force over their area; for a body whose sides "
            "cut the cells (a circle on a square grid, a footing thinner "
            "than a cell) use an Obstacle of its shape, contact at the "
            "material's surface (a body moved by Prescribed motion with "
            "contacts between bodies), or a grid with cell faces on the "
            "body's sides", rigid.body, word, volume, held.size,
            cells_volume, 100. * (cells_volume / volume - 1.))


def beyond_cell_words(method: str) -> str:
    """What of a point of ``method`` (not ``"mpm"``, ``"fem"``) reaches
    beyond its cell, in words for a refusal (a trial's ``"bspline"`` run
    was told of "a GIMP point's domain").

    >>> beyond_cell_words("cpgimp"), beyond_cell_words("bspline3")
    ("a GIMP point's domain reaches", "a point's cubic B-splines reach")
    >>> beyond_cell_words("bspline-gimp")
    "a point's quadratic B-splines, averaged over its domain, reach"
    """
    if not method.startswith("bspline"):
        return "a GIMP point's domain reaches"
    return "a point's {} B-splines{} reach".format(
        "cubic" if method.startswith("bspline3") else "quadratic",
        ", averaged over its domain," if method.endswith("-gimp") else "")


def check_rigid_bodies(rigid_bodies, points, dim: int, method: str) -> tuple:
    """The rigid bodies as a tuple (one :class:`RigidBody` alone is
    welcome), checked against the points and the method: each a
    :class:`RigidBody` of an existing body with points, with ``dim``
    displacement components, each body rigid at most once; standard MPM
    or FE points (a GIMP point reaches nodes beyond its cell, which its
    rigid body would leave free)."""
    bodies = (rigid_bodies,) if isinstance(rigid_bodies, RigidBody) \
        else tuple(rigid_bodies or ())
    if bodies and method not in ("mpm", "fem"):
        raise InvalidInputError(
            "rigid_bodies need method 'mpm' or 'fem', not {!r}: {} "
            "nodes of the cells beside its own, which the rigid body does "
            "not drive, so it would not move rigidly".format(
                method, beyond_cell_words(method)))
    seen = set()
    for k, rigid in enumerate(bodies):
        if not isinstance(rigid, RigidBody):
            raise InvalidInputError(
                "rigid_bodies[{}] must be a RigidBody, got {!r}".format(
                    k, rigid))
        if len(rigid.displacement) != dim:
            raise InvalidInputError(
                "rigid_bodies[{}]: displacement has {} components, the grid "
                "{}".format(k, len(rigid.displacement), dim))
        if not (points.body == rigid.body).any():
            raise InvalidInputError(
                "rigid_bodies[{}]: body {} has no points (points.body runs "
                "from 0 to {})".format(k, rigid.body, int(points.body.max())))
        if rigid.body in seen:
            raise InvalidInputError("rigid_bodies[{}]: body {} is rigid "
                                    "twice".format(k, rigid.body))
        seen.add(rigid.body)
    if bodies and len(seen) == len(np.unique(points.body)):
        raise InvalidInputError(
            "every body is rigid: nothing deforms (a rigid body pushes "
            "another body)")
    return bodies
