"""Ghost-penalty stabilisation of partially filled cells (small cuts).

A body whose boundary leaves a grid node supported only by a sliver of
material makes the stiffness badly conditioned (a node's stiffness scales
with the sliver's volume).  The ghost penalty adds, on every interior face
between two active cells of which at least one is filled to less than
``CUT_FILL`` (by the points' current volumes),

    gamma * mu * h * int_F [[dn u]] . [[dn v]] ds,

the jump of the normal derivative across the face, scaled to the material
(shear modulus mu of the stiffer neighbour) and the cell size h.  It
vanishes for linear fields, so patch tests still pass, and it ties a
sliver's nodes to their neighbours: the condition number stays bounded
whatever the sliver's size.  Facet terms are assembled by scikit-fem on
``InteriorFacetBasis`` pairs.  The ghost penalty is Burman's (*C. R.
Acad. Sci. Paris, Ser. I* 348, 2010).

"""
import logging
from typing import Optional

import numpy as np
from numpy import ndarray
from skfem import BilinearForm, InteriorFacetBasis, asm
from skfem.helpers import dot, grad, mul

from ..errors import UnsupportedElementError
from ..protocols import GridTerm
from ..spelling import setting

__all__ = ["ghost_penalty", "cut_cells", "faces_crossed_past_supports",
           "cells_of_two_fields", "GhostStabilisation", "CUT_FILL"]

logger = logging.getLogger(__name__)


@BilinearForm
def normal_derivative_jump(u, v, w):
    """``[[dn u]] . [[dn v]]`` for one pair of sides, weighted."""
    return w.weight * dot(mul(grad(u), w.n), mul(grad(v), w.n))


CUT_FILL = .5

#: fills and distances within this fraction of their scale are equal (a
#: cell its points fill to exactly ``CUT_FILL``, a cell centre on an
#: obstacle's surface), so round-off does not decide them
TIE = 1e-9


def cells_of_two_fields(point_cells: ndarray, field_cells: int) -> ndarray:
    """The grid's cells that hold points of more than one field (cells
    ``point_cells`` of the fields' copies of a grid of ``field_cells``
    cells: :func:`~skfem_mpm.methods.fields.extended_mesh`).

    >>> import numpy as np
    >>> cells_of_two_fields(np.array([0, 1, 5, 7]), 4)     # 1 and 5
    array([1])
    """
    cells = np.unique(point_cells)
    return np.flatnonzero(np.bincount(cells % field_cells) > 1)


def cut_cells(fill: ndarray, full: float = CUT_FILL) -> ndarray:
    """Active cells that their points fill to less than ``full`` of the
    cell: the cells whose nodes may lack support.  A fuller cell supports
    its nodes, and penalising it would only perturb the answer (the
    points' current volumes fill a compressed cell to less than 1).  A
    cell filled to ``full`` within :data:`TIE` is full: a body's face
    half-way across cells of 2 x 2 points fills them to one half, and
    round-off in the points' volumes cut them or not by where the model
    sat (a cantilever's tip deflection moved by 4% when it was shifted by
    one length unit, with ``ghost=0.1``).

    >>> cut_cells(np.array([0., .25, .5 - 1e-15, .5, .75])).tolist()
    [False, True, False, False, False]
    """
    return (fill > 0) & (fill < full * (1. - TIE))


def ghost_penalty(mesh, elem, fill: ndarray, mu: ndarray,
                  gamma: float) -> Optional[object]:
    """The ghost-penalty matrix, or ``None`` when no face needs one.

    Parameters
    ----------
    mesh, elem
        The grid and its vector element.
    fill
        Volume of points over cell volume, per element (0 for empty cells).
    mu
        Shear modulus per element (of the points in it).
    gamma
        Penalty factor (dimensionless, e.g. 0.1).

    """
    left, right = mesh.f2t
    interior = right >= 0
    active = fill > 0
    cut = cut_cells(fill)
    facets = np.flatnonzero(interior & active[left] & active[np.maximum(
        right, 0)] & (cut[left] | cut[np.maximum(right, 0)]))
    if facets.size == 0:
        return None
    try:
        sides = [InteriorFacetBasis(mesh, elem, facets=facets, side=i)
                 for i in (0, 1)]
    except Exception as err:         # scikit-fem's inverse mapping
        extent = np.ptp(mesh.p, axis=1).max()
        cell = np.ptp(mesh.p[:, mesh.t[:, 0]], axis=1).min()
        raise UnsupportedElementError(
            "the ghost penalty's faces: scikit-fem could not map their "
            "quadrature into the cells beside them ({}) on a grid {:.0f} "
            "cells long, whose positions carry more round-off than its "
            "mapping's absolute tolerance; use fewer cells along the "
            "grid, or no ghost penalty ({}; with B-splines "
            "extended_splines = true)".format(
                err, extent / cell, setting("ghost", 0.))) from err
    h = np.abs(sides[0].mesh_parameters())           # cell size per facet
    stiffer = np.maximum(mu[left[facets]], mu[right[facets]])
    weight = gamma * stiffer[:, None] * h
    return sum((-1) ** (i + j) * asm(normal_derivative_jump, sides[j],
                                     sides[i], weight=weight)
               for i in (0, 1) for j in (0, 1))


def faces_crossed_past_supports(mesh, nodal_dofs: ndarray, fixed: ndarray,
                                point_cells: ndarray,
                                active_cells: ndarray,
                                blocked=None) -> ndarray:
    """Faces across which points' domains reach past a support: a face of
    an axis-aligned grid between a cell that holds points and a cell that
    only their domains reach (no point in it), every node of the face held
    along the face's normal, or the cell beyond inside an obstacle
    (``blocked``).

    Material pressed against a held grid line moves towards it while a
    GIMP domain keeps its size (uGIMP; cpGIMP in small strain), so the
    domain crosses the line by a sliver.  The nodes beyond, free and held
    by the sliver alone, make the stress of the points touching them
    vanish along the normal: a block pressed against a held line had a
    column of points at zero stress beside one at 1.66 times the load.
    The ghost penalty ties those nodes to the cells inside.

    Parameters
    ----------
    mesh
        The grid.
    nodal_dofs
        The grid's vector DOF at each node, (dim, nvertices).
    fixed
        Held DOFs.
    point_cells
        The cell holding each point.
    active_cells
        The cells the points' operator reaches.
    blocked
        ``blocked(cells) -> bool array``: which cells lie inside an
        obstacle (material pressed on a smooth obstacle wall on a grid
        line holds no DOF there: the points by it were at 0.48 and 1.43
        times the stress, the wall's force 3.4% low), or ``None``.

    Returns
    -------
    ndarray
        The faces' indices.

    Examples
    --------
    A point in the left cell of two whose domain reaches past the middle
    line, held along x (and not, when held along y):

    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> mesh = MeshQuad.init_tensor(np.array([0., 1., 2.]), np.array([0., 1.]))
    >>> dofs = np.arange(2 * mesh.nvertices).reshape(-1, 2).T
    >>> middle = np.flatnonzero(mesh.p[0] == 1.)
    >>> faces = faces_crossed_past_supports(mesh, dofs, dofs[0, middle],
    ...                                     np.array([0]), np.array([0, 1]))
    >>> mesh.p[0, mesh.facets[:, faces]].ravel()      # the middle line
    array([1., 1.])
    >>> faces_crossed_past_supports(mesh, dofs, dofs[1, middle],
    ...                             np.array([0]), np.array([0, 1])).size
    0
    """
    nel = mesh.nelements
    holds = np.bincount(point_cells, minlength=nel) > 0
    reached = np.zeros(nel, dtype=bool)
    reached[active_cells] = True
    reached &= ~holds
    if not reached.any():   # standard MPM's cells: those holding points
        return np.flatnonzero(reached)
    left, right = mesh.f2t
    inner = np.maximum(right, 0)
    faces = np.flatnonzero((right >= 0) & (
        (holds[left] & reached[inner]) | (reached[left] & holds[inner])))
    if faces.size == 0:
        return faces
    nodes = mesh.facets[:, faces]
    normal = np.argmin(np.ptp(mesh.p[:, nodes], axis=1), axis=0)
    held = np.zeros(nodal_dofs.max() + 1, dtype=bool)
    held[fixed] = True
    past = held[nodal_dofs[normal, nodes]].all(axis=0)
    if blocked is not None:
        beyond = np.where(holds[left[faces]], inner[faces], left[faces])
        past |= blocked(beyond)
    return faces[past]


class GhostStabilisation(GridTerm):
    """The ghost penalty as a grid term of the load step
    (:class:`~skfem_mpm.protocols.GridTerm`): the step's penalty ``G``
    (:meth:`penalty`, constant over a step, so Newton keeps its rate) is
    added to the tangent and, times the displacement increment, to the
    internal force, in any kinematics.

    Parameters
    ----------
    mesh, elem
        The grid and its vector element.
    gamma
        Penalty factor (dimensionless, e.g. 0.1); positive.
    material
        The points' material(s): ``mu`` per point scales the penalty.
    active
        ``False``: held in reserve, contributing nothing until
        :meth:`switch_on` (``ghost="auto"``: the retry ladder of a failed
        step switches it on for the rest of the run, and so does a step
        whose points' domains reach past a support,
        :func:`faces_crossed_past_supports`).
    obstacles
        The run's obstacles, where a step whose points' domains reach
        into a cell inside one switches the penalty on (GIMP's domains;
        a B-spline's support reaches the cells beside its body anyway).
    field_cells
        With contacts between bodies, the cells of each body's field (the
        grid's): a cell that only domains reach takes the modulus of the
        stiffest point of its own field, not of every body (GIMP's pile,
        80 times stiffer than its von Mises soil, settled 2.44 mm where
        MPM's settles 7.7 and a rigid obstacle needs 7.4: the soil's
        field's penalty had the pile's modulus; now 7.75 mm).
    shared_cells
        With ``field_cells``: in reserve, switched on at a step where a
        grid cell holds points of two fields (bodies in contact meeting
        inside a cell).
    """

    @property
    def holds_slivers(self) -> bool:
        """On, the penalty ties the slivers' nodes to their neighbours."""
        return self.active

    def __init__(self, mesh, elem, gamma: float, material,
                 active: bool = True, obstacles=(), field_cells=None,
                 shared_cells: bool = False):
        self.mesh, self.elem, self.gamma = mesh, elem, gamma
        self.material, self.active = material, active
        self.field_cells = field_cells
        self.shared_cells = shared_cells and field_cells is not None
        self.obstacles = obstacles
        self._cell_volume = None
        self._faces_mesh = None
        self.G = None

    def switch_on(self):
        """Contribute from the next step attempt on."""
        self.active = True

    def begin_step(self, problem):
        """The step's penalty; ``None`` (no contribution) while in reserve
        or where no face needs one.  In reserve, switched on for the rest
        of the run at a step whose points' domains reach past a support
        or into a cell inside an obstacle, or (:attr:`shared_cells`)
        whose cells hold points of two bodies (never searched for an
        operator whose active cells are those of its points,
        ``connectivity_from_elements``: standard MPM's)."""
        if not self.active and self.shared_cells:
            shared = cells_of_two_fields(problem.op.point_elements,
                                         self.field_cells)
            if shared.size:
                self.switch_on()
                problem.counters["ghost_from_step"] = problem.step
                logger.info(
                    "step %d: %d grid cells hold points of two bodies in "
                    "contact (the first, cell %d): the ghost penalty on "
                    "(gamma %g) for the rest of the run", problem.step,
                    shared.size, shared[0], self.gamma)
        if not self.active:
            op = problem.op
            if getattr(op, "connectivity_from_elements", False):
                # standard MPM's operators: the active cells are those
                # that hold points, no domain reaches a cell past them
                # (the faces' search: 12-16 us a step at 56 points)
                return None
            crossed = faces_crossed_past_supports(
                self.mesh, problem.grid.nodal_dofs, problem.fixed,
                op.point_elements, op.elements,
                self.obstacle_cells(problem))
            if crossed.size == 0:
                return None
            self.switch_on()
            problem.counters["ghost_from_step"] = problem.step
            logger.info(
                "step %d: points' domains reach past a support or into a "
                "cell an obstacle covers at %d grid "
                "faces (the first at %s): the ghost penalty on (gamma %g) "
                "for the rest of the run", problem.step, crossed.size,
                np.round(self.mesh.p[:, self.mesh.facets[:, crossed[0]]].mean(
                    axis=1), 6).tolist(), self.gamma)
        self.G = self.penalty(problem.op, problem.points)
        return None if self.G is None else self

    def obstacle_cells(self, problem):
        """``cells -> bool``: whether each cell's centre lies inside one of
        :attr:`obstacles` where the step starts or where it ends (by more
        than :data:`TIE` of the cell's size: a centre on an obstacle's
        surface, a floor's top half-way up a row of cells, was inside or
        not by round-off, and a GIMP block resting on it switched the
        penalty on or not by where the model sat: 16% in its stresses);
        ``None`` without them.  Where it ends too: a plate pushed onto a
        cpGIMP disc (R/h = 40) covered such a cell within its second step,
        whose corners pressed the node beyond, held by a sliver (Newton's
        first direction moved it 2.0, the disc's size, then 1.4e5); the
        step cycled at a residual of 1.0 through 25 iterations and the
        line search's 30 (60 s, where MPM takes 7), and the penalty came
        on at step 4 (now at step 2: 30 iterations, 1.5 s)."""
        obstacles = self.obstacles
        if not obstacles:
            return None

        def blocked(cells):
            corners = self.mesh.p[:, self.mesh.t[:, cells]]
            centre = corners.mean(axis=1)
            size = np.ptp(corners, axis=1).max(axis=0)
            return np.any([ob.signed_distance(
                centre, s * ob.displacement)[0] < -TIE * size
                for ob in obstacles
                for s in {problem.s_old, problem.s_new}], axis=0)
        return blocked

    def force(self, du, response):
        return self.G @ du

    def matrix(self, response):
        return self.G

    @property
    def cell_volume(self):
        """The volume of every grid cell, computed on first use: the
        reserve that ``ghost="auto"`` holds is seldom used, and the
        grid-wide basis costs 0.1-0.3 s on a grid of 1e5 cells."""
        if self._cell_volume is None:
            from skfem import Basis
            self._cell_volume = Basis(self.mesh, self.elem.elem if hasattr(
                self.elem, "elem") else self.elem).dx.sum(axis=1)
        return self._cell_volume

    def penalty(self, op, points):
        """The penalty matrix of the step of ``op`` (or ``None``): fill
        and stiffness of each cell from the points it holds; a cell that
        the step's operator makes active without holding a point (a GIMP
        domain reaching into it) counts as cut, with the largest stiffness
        of the points (of its field's points, :attr:`field_cells`)."""
        cells = op.point_elements
        n = self.mesh.nelements
        filled = np.bincount(cells, points.volume, n)
        mu_points = np.broadcast_to(self.material.mu, (points.n,))
        mu = np.bincount(cells, points.volume * mu_points, n) / np.maximum(
            filled, np.finfo(float).tiny)
        fill = filled / self.cell_volume
        reached = np.zeros(n, dtype=bool)
        reached[op.elements] = True
        reached &= fill == 0
        fill[reached] = np.finfo(float).eps        # active, nearly empty
        if self.field_cells is None:
            mu[reached] = mu_points.max()
        else:                 # the stiffest point of the cell's own field
            stiffest = np.zeros(n // self.field_cells)
            np.maximum.at(stiffest, cells // self.field_cells, mu_points)
            mu[reached] = stiffest[np.flatnonzero(reached)
                                   // self.field_cells]
        return ghost_penalty(self.faces_mesh, self.elem, fill, mu,
                             self.gamma)

    @property
    def faces_mesh(self):
        """The grid moved to start at the origin, where the faces'
        quadrature is mapped into their cells: scikit-fem inverts that
        mapping to an absolute 1e-12, which coordinates of 1e4 and more
        (a site's) do not reach by round-off (a GIMP pile at x + 1e4
        failed at step 2 with the mapping's exception)."""
        if self._faces_mesh is None:
            self._faces_mesh = self.mesh.translated(-self.mesh.p.min(axis=1))
        return self._faces_mesh
