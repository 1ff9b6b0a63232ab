"""Contact of the material's surface with rigid obstacles: a grid term.

The material's surface is sampled where it is, not at the grid: at the
corners of every point's domain (its GIMP domain, or a cube of the point's
volume).  A corner starts a step at

    x_c = x_p + F R_c + d_c,

``R_c`` its offset in the initial domain, ``F`` the point's deformation
gradient (in small strain, where the points carry none, ``I`` plus the
displacement gradient the term keeps as point state ``contact_grad<a><b>``)
and ``d_c`` the offset the term keeps for the corners it followed
(``contact_dx<a><c>``, zero for the others).  Within the step a corner
moves linearly in the grid increment, ``u_c = J_c du``:

- with Lagrange elements (MPM, FE) by the element polynomial of its
  point's cell, evaluated at the corner (at its initial place with FE,
  whose field lives in the initial configuration), so that the corners a
  neighbouring domain shares move alike in a cell, the surface stays
  flat under a flat punch, and the rows change continuously as the
  material moves; where the corner's next start, ``x_p + F R_c``, differs
  from where the field moved it, the difference is kept as ``d_c``, so a
  step starts where the last one ended (the point's own gradient, ``u_p +
  grad(u)_p q_c``, gave corners of neighbouring points that disagreed by
  the field's curvature, which a rigid punch met at a few of them, and
  rows that jumped as a point crossed a cell's side: a footing's
  pressure jumped by 10% and a rough footing's run failed);
- with GIMP's and B-splines' smooth weights by the point's operator and
  its gradient, ``u_c = u_p + grad(u)_p q_c`` (``q_c = F R_c`` in finite
  deformation, ``R_c`` in small strain and with FE), which is where the
  next step starts; but with GIMP on linear cells and one field, a
  corner on its domain's side facing a smooth axis-aligned face, of a
  domain that spans a grid line along the face's normal, by GIMP's
  weights of that side (:meth:`StepContact.face_rows`), followed as
  ``d_c`` where pressed;
- with those, for an obstacle that holds the material along its face
  (friction, rough, tied), by the grid's field where the corner is (kept
  as ``d_c`` too, where such an obstacle holds it): the element
  polynomial of the cell holding the corner (GIMP) or the splines there
  (B-splines: extended, or at a tied face),
  :meth:`ObstacleContact.field_rows`.  A domain's
  two corners on a face, moved by their point's value and gradient,
  held the point's gradient along the face as well: a tied clamp came
  out too stiff (3.3% at a tolerance of 1e-5), and a 3D tied floor took
  3528 Newton iterations.  Smooth faces keep the point's rows (read at
  the field, a uGIMP block pressed on a wall was 6.5% off its stress by
  the wall, where its point's rows hold it within 5%), and so do
  B-splines without the extension at a face that is not tied
  (warned).

Interior corners coincide with neighbours' and never reach an obstacle
while the surface corners are held, so every corner is a candidate and
none needs to be marked as surface.

At each corner the gap to an obstacle's surface gives, per unit area,
the pressure of an augmented Lagrangian

    p = max(0, lambda + kappa (-g)),

with ``g = n . (x_c - a)`` the gap from the plane of the obstacle's face
nearest to the corner at the step's start (outward normal ``n``), for
the corners over the face at the step's start, within the obstacle's
tolerance of its edges (contact with a face ends at its edges): smooth
in the trial, so Newton does not hop between faces
or across an edge at an obstacle's corner.  A corner found through
another face after Newton takes the face nearest to it and the step is
solved again.

and, with friction, the tangential traction of a penalty regularised
Coulomb law with a return map: the trial ``tau* = tau_n - kappa s_t``
(``s_t`` the step's tangential slip relative to the obstacle) kept while
``|tau*| <= mu p`` (stick), else ``mu p tau*/|tau*|`` (slip); ``"rough"``
keeps the trial at the corners in contact at the step's start (pressed,
or within the tolerance), whatever their pressure within Newton; one
found apart when Newton has converged lets go and the step is solved
again, one pressed that did not stick joins, sticking from where it
met the obstacle within the step (:meth:`StepContact.rough_changes`;
kept wherever a trial pressed, the traction of a
corner at a footing's edge jumped from nothing to the whole step's
stick as its pressure passed zero, and Newton cycled); ``"tied"`` holds
the corners that touched the obstacle at the start, ``t = lambda -
kappa (x_c - x_anchor)``, separation included.  The force on the
material is ``A_c (p n + tau)`` with ``A_c``
the corner's share of its domain's area facing the obstacle; the grid
force is ``J^T`` of it and the tangent ``J^T C J`` with ``C`` the
consistent derivative (the normal's rotation left out: exact on flat
faces), so Newton converges quadratically once the active set is fixed
(but along faces where every pressed corner slides: :data:`SLIDING`).

After Newton converges, :meth:`StepContact.settle` checks the penetration,
the gap of a corner still pressed (its multiplier left from a push the
obstacle draws back from) and a tied corner's mismatch against the
obstacle's tolerance; where one is larger the multipliers take the
converged tractions
(``lambda <- p``, the augmented-Lagrangian update) and the step is solved
again.  The multipliers (``lambda`` where pressed) and the friction
tractions are point state (``contact<i>_p<c>``, ``contact<i>_t<a><c>``:
obstacle i, corner c, component a), so checkpoints carry them and a step
starts from the last step's tractions: with the penetration it ended at,
``lambda - kappa g`` is the last step's pressure (the multipliers are
not the pressure: each step's record has that per point,
:meth:`StepContact.pressures`).  A tied corner keeps its traction, a
step's multiplier that traction with the penalty's of its mismatch at
the step's start, so a staged run, which ties its corners where the
earlier run left them, starts pulling with that run's force.  The
method follows the penalty contact at GIMP domain corners of Bird et
al. (2024) with the augmented-Lagrangian updates of Simo and Laursen
(1992); see ``docs/references.md``.
"""
import itertools
import logging
from weakref import WeakKeyDictionary
from typing import Optional, Sequence

import numpy as np
from numpy import ndarray
from scipy.sparse import (coo_matrix, csr_matrix, diags, identity, kron,
                          vstack)
from scipy.spatial import cKDTree

from ..errors import (ContactError, GridMotionError, InvalidInputError,
                      PointsOutsideGridError, StepTooLongError)
from ..methods.gimp_linear import LinearGimp, snap_to_lines
from ..quadrature.locate import (cell_coordinates, point_locator,
                                 using_kernels)
from ..protocols import GridTerm
from ..spelling import setting
from .loads import supported_share
from .motion import unheld_rigid_modes
from .obstacles import Obstacle
from .problem import SLIVER_SUPPORT, safe_norm

logger = logging.getLogger(__name__)

__all__ = ["ObstacleContact", "CellValues", "corner_signs", "point_rows",
           "contact_state_names"]

#: the share of the force of a penetration of the tolerance below which a
#: step's residual is not measured (:meth:`StepContact.weigh`): a
#: thousandth, below the loads of the tests' blocks on floors, where the
#: tolerance's force is 4 times the weight
RESOLVED = 1e-3

#: a corner further from every obstacle than this many cells at a step's
#: start is left out of the step's contact (checked again after Newton)
MARGIN_CELLS = 2.

#: the degrees from the grid's axes above which a polygon's face the
#: material meets at the start is warned as met by a staircase
#: (:meth:`ObstacleContact.warn_inclined_faces`), smooth
INCLINED = 10.

#: the same for a face that holds the body (friction, rough, tied): any
#: tilt above round-off (a block on a rough incline turned by the
#: incline's angle at 5, 0.6, 0.3 and 0.1 degrees alike)
INCLINED_HOLDING = 1e-6

#: what a step's motion farther than the grid spans says (a B-spline
#: disc's point under its loaded top, on a grid line, moved 597 cells
#: through the floor it stood on, and the error blamed the floor)
RUNAWAY = (", farther than the grid spans: grid nodes that carry almost "
           "no material ran away, the material with them (the ghost "
           "penalty holds them, {}; B-splines: {})".format(
               setting("ghost", 0.1), setting("extended_splines", True)))

#: the displacement gradient (Frobenius norm) in one step beyond which
#: material carried through an obstacle is a diverged solution, not a
#: step too long (:meth:`StepContact.check_passing`): trial 115's
#: passive wall (h = 0.14, 2 x 2 points a cell, anti-locking) at a load
#: increment of 1.3e-4 (the wall moved 3e-4 cells) moved corners 21
#: cells, its points' gradients up to 80, and was reported as material
#: gone through the wall
DIVERGED_GRADIENT = 1.

#: what :func:`contacts_remedy` measured (a user trial's block pushed 2
#: cells along a slab by a wall, mu = 0.3, 20 steps; the methods that
#: scatter less, each with its range)
CONTACTS_MEASURED = (
    "a block pushed 2 cells along a slab, mu = 0.3: sigma_yy from -2.40 p "
    "to +0.18 p with 'bspline' at 2 x 2 points a cell, -2.04 p to -0.58 p "
    "at 3 x 3, {}, where a beam's linear pressure gives -1.45 p to "
    "-0.55 p")
#: the methods that scatter less there, with their ranges
CONTACTS_SERVE = (("'bspline-gimp'", "-1.56 p to -0.45 p"),
                  ("cpGIMP", "-1.53 p to -0.72 p"),
                  ("standard MPM", "-1.59 p to -0.78 p"))


def faces_between_lines(obstacles, mesh) -> Optional[str]:
    """The name of the first obstacle with a face between the grid lines
    of the axis-aligned ``mesh`` and inside its bounds (a box's face off
    the lines; any polygon), or ``None``.

    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> from skfem_mpm import Obstacle
    >>> mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 1, 5))
    >>> faces_between_lines([Obstacle(box=[[-1, 2], [-1, .25]], name="b")],
    ...                     mesh)
    >>> faces_between_lines([Obstacle(box=[[-1, 2], [-1, .3]], name="a")],
    ...                     mesh)
    'a'
    """
    for ob in obstacles:
        if ob.box is None:
            return ob.name
        for axis, ends in enumerate(ob.box):
            lines = np.unique(mesh.p[axis])
            tie = 1e-9 * (lines[-1] - lines[0])
            inside = ends[(ends > lines[0] + tie) & (ends < lines[-1] - tie)]
            if np.any(np.abs(inside[:, None] - lines).min(axis=1) > tie):
                return ob.name
    return None


def contacts_remedy(method: str) -> str:
    """The remedy :meth:`ObstacleContact.warn_splines` names for the
    B-spline ``method`` where contacts between bodies refuse the extended
    splines: the methods of :data:`CONTACTS_SERVE` other than
    ``method``.

    >>> "with 'bspline-gimp'" in contacts_remedy("bspline")
    True
    >>> "'bspline-gimp'" in contacts_remedy("bspline-gimp")
    False
    """
    serve = [(name, span) for name, span in CONTACTS_SERVE
             if name.strip("'") != method]
    return ("; with contacts between bodies, which refuse the extended "
            "splines, {} scatter less ({})".format(
                ", ".join(n for n, _ in serve[:-1]) + " or " + serve[-1][0],
                CONTACTS_MEASURED.format(", ".join(
                    "{} with {}".format(span, name) for name, span in serve))))

#: the share of the material's extent along an obstacle's motion past
#: which a failed run's hint says it squeezes the material
#: (:meth:`ObstacleContact.squeeze_hint`)
SQUEEZED = .5

#: the share of an obstacle's force on the grid acting on DOFs a support
#: holds past which it is warned once a run (and named in a failure's
#: hint): it goes straight into the support's reaction
#: (:meth:`StepContact.held_shares`)
HELD_SHARE = .2

#: gaps within this many machine epsilons of the corners' largest
#: coordinate are round-off (:meth:`StepContact.evaluate`)
ROUNDOFF = 8 * np.finfo(float).eps

#: the share of the penalty sliding pairs keep along their tangent plane
#: in the tangent where none of their contact's pairs sticks
#: (:func:`coulomb`; the consistent derivative has none along the slip).
#: A body held along a face only by friction slipping its full limit on
#: every side (a symmetric pile's two base corners, its middle open) has
#: no stiffness along it, and Newton's step along it was round-off over a
#: round-off pivot: the pile's head moved 1.7e-6 sideways against a
#: settlement of 2.0e-4, 1.5e-15 with this share (the step nearest the
#: last iterate of the equilibria the slip allows).  Along the slip the
#: iterations then converge linearly, by about this share times the
#: penalty over the material's stiffness there: where a pair sticks it
#: is left out (a block on a Coulomb floor, three of 16 pairs sliding,
#: took 6 Newton iterations for 3 with it, a factor 2e-5 each)
SLIDING = 1e-6

#: the cells within which a corner touches a face for that warning
TOUCHING = .1

#: trial 115's strip footing (B = 1, half model, von Mises 0.5 m at
#: c = 30 over clay at c = 10, standard MPM, 3 x 3 points a cell, pushed
#: 0.1 m in 40 steps): its pressure (kPa) at 0.1 m with its edge inside
#: a cell (h = 0.09) and the answers with the edge on a grid line
#: (h = 0.1) and inside a cell of half the size (h = 0.045, 2 x 2)
LAYERED_EDGE = (70.97, (91.99, 88.18))

#: what that warning says of an edge inside a cell: the pressure off
#: both ways (a user trial found its footing below the answer where the
#: warning said above), and the jumps between steps
EDGE_MEASURED = (
    "a footing's edge inside a cell pressed 3-26% above Prandtl's "
    "pressure on clay, {:.0f}-{:.0f}% below the answer on a stiff layer "
    "over clay, and jumped by 6-105% between steps".format(
        *sorted(100. * (1. - LAYERED_EDGE[0] / np.array(LAYERED_EDGE[1])))))

#: that warning's advice where an earlier run moved the material there
#: (a staged run's start: a footing lifted from where a push left it)
STAGED_EDGE = ("an earlier run moved the material there, off the grid's "
               "lines: push the earlier run by whole cells, or refine its "
               "grid (a grid of this run's own puts the points' stresses "
               "out of balance on it: docs/contact.md)")

#: the cells a trial may move a contact's corner by grid nodes that
#: slivers of material hold (:func:`check_carried_corners`): beyond it
#: the contact's state there follows those nodes' absurd values
CARRIED = .1

#: a step's augmented-Lagrangian updates from which an update that left
#: more than :data:`GROW_SLOW` of the last's penetration multiplies the
#: unsettled obstacles' penalty by :data:`GROWTH` for the rest of the run
#: (:meth:`StepContact.grow_penalty`), :data:`GROWTHS` times at the
#: most: GIMP's corners sharing grid nodes at different heights (a
#: sphere's staircase on a floor) cannot all meet the face, and each
#: update moves the force from the higher to the lowest by the penalty
#: times their height difference, a fixed amount: trial 118's cpGIMP
#: hemisphere (Hertz radius 3.2 cells) took more than 30 updates at every
#: cut-back at penalty 10, its worst corner the same one, the updates'
#: cosine 0.99-1.0 and their rate 0.9-0.99; at 100 it settles in a few
GROW_AFTER = 4
#: see :data:`GROW_AFTER`
GROW_SLOW = .75
#: see :data:`GROW_AFTER`
GROWTH = 10.
#: see :data:`GROW_AFTER`
GROWTHS = 2
#: the run's counter of the penalty's growths (:data:`GROW_AFTER`), there
#: from the first; per obstacle :func:`grown_name`'s: a resume goes on
#: from them, its penalties grown as the run's
GROWN = "contact_penalty_growths"


def growth_reason(smooth: bool, curved: bool) -> str:
    """Why a step's augmented-Lagrangian updates settled slowly, as the
    warning of a penalty's growth says it (:data:`GROW_AFTER`): with
    GIMP's or B-splines' smooth weights (``smooth``) on a polygon
    obstacle (``curved``), the domains' staircase on the curved face;
    else corners at different heights by a face's edge (a trial's flat
    standard-MPM footing, told of GIMP's corners on a curved face: the
    worst corner 0.0035 from its edge pressed across a gap of 1.1
    tolerances, its cell's neighbours 0.36 into the face).

    >>> growth_reason(True, True)[:30]
    "GIMP's corners on a curved fac"
    >>> growth_reason(False, False)[:43]
    'corners sharing grid nodes at different hei'
    """
    if smooth and curved:
        return ("GIMP's corners on a curved face cannot all meet it, and "
                "each update moves their force by the penalty's times "
                "their heights' difference")
    return ("corners sharing grid nodes at different heights cannot all "
            "meet its face, as by a face's edge where the surface bends "
            "beside it, and each update moves their force by the "
            "penalty's times their heights' difference")


def grown_name(i: int) -> str:
    """The run's counter of obstacle ``i``'s penalty's growths
    (:data:`GROWN`).

    >>> grown_name(1)
    'contact1_penalty_growths'
    """
    return "contact{}_penalty_growths".format(i)

#: faces of an obstacle whose distances from a corner differ by less than
#: this many cells are alike: the material's side decides
#: (:meth:`~skfem_mpm.solve.obstacles.Obstacle.nearest_face`); corners
#: closer than it are at one place (:meth:`StepContact.material_side`)
ALIKE = 1e-2

#: a step's augmented-Lagrangian updates past which, where the last
#: cut the penetration by less than :data:`SLOW_UPDATE`, the run is
#: told once that its contact converges slowly and what takes fewer
#: (:meth:`StepContact.tell_slow_updates`)
SLOW_UPDATES = 8
#: the share of the penetration an update leaves that is slow
SLOW_UPDATE = .9
#: what a larger penalty did where the updates were slow (trial 72's
#: cpGIMP disc squeezed by a plate, R/h = 40)
SLOW_MEASURED = ("a cpGIMP disc squeezed by a plate, before a smooth "
                 "obstacle's penalty grew by itself: 61 updates and 102 "
                 "Newton iterations at the default penalty 10, 6 and 48 at "
                 "100, the force 1e-4 apart; but a block indented by a "
                 "polygon disc took 14 updates for 26 and 510 iterations "
                 "for 278 at 100, and failed at 1000: try 30-100 and "
                 "compare the time")

#: a face's normal within this of a grid axis is along it: the corners
#: facing it move with GIMP's weights of their domain's side
#: (:meth:`StepContact.face_rows`)
FACE_ALIGNED = 1e-9


def coulomb(friction, kappa: float, p: ndarray, n: ndarray, tau: ndarray,
            motion: ndarray, held: ndarray = None):
    """The tangential traction of a penalty regularised Coulomb law with
    a return map, per contact (columns): the trial ``tau* = P tau -
    kappa P motion`` (``P = I - n n``, ``tau`` the multiplier, ``motion``
    the step's relative motion) where pressed (``p > 0``), kept while
    ``|tau*| <= friction p`` (stick), else ``friction p tau*/|tau*|``
    (slip).  With ``"rough"`` the trial is kept where pressed, or, when
    ``held`` (m,) is given, where it says, whatever the pressure.
    Returns the traction (dim, m), its consistent derivative by
    ``motion`` (dim, dim, m: the normal's rotation left out) and the
    sticking columns."""
    dim = n.shape[0]
    eye = np.eye(dim)[:, :, None]
    Pt = eye - np.einsum("as,bs->abs", n, n)
    slip = np.einsum("abs,bs->as", Pt, motion)
    trial = np.einsum("abs,bs->as", Pt, tau) - kappa * slip
    out, C = np.zeros_like(trial), np.zeros(Pt.shape)
    stick = p > 0 if held is None else held.copy()
    if friction != "rough":
        size = np.sqrt((trial ** 2).sum(axis=0))
        limit = friction * p
        slide = stick & (size > limit)
        stick &= ~slide
        s = np.flatnonzero(slide)
        t_hat = trial[:, s] / size[s]
        out[:, s] = limit[s] * t_hat
        C[:, :, s] = friction * kappa * (
            np.einsum("as,bs->abs", t_hat, n[:, s])
            + p[s] / size[s] * np.einsum("abs,bcs->acs", eye - np.einsum(
                "as,bs->abs", t_hat, t_hat), Pt[:, :, s]))
        if not stick.any():         # nothing holds along the faces
            C[:, :, s] += SLIDING * kappa * Pt[:, :, s]
    out[:, stick] = trial[:, stick]
    C[:, :, stick] = kappa * Pt[:, :, stick]
    return out, C, stick


def rough_apart_join(held: ndarray, changed: ndarray, p: ndarray,
                     gap: ndarray, tol: float):
    """After Newton, a rough contact's corners or pairs that change, the
    ``(apart, join)`` masks: one that stuck (``held``) lets go when found
    unpressed (``p <= 0``) and open beyond the tolerance ``tol`` (its
    ``gap``), as it is held at the step's start; one pressed that did not
    stick joins; each changes once a step (not ``changed``), so the rounds
    end.  Obstacles and contacts between bodies alike: a corner touching
    unpressed let go, and a rough pile in weightless clay carried nothing
    between bodies; as an obstacle, 43 of the 46 corners that stuck at the
    first step let go."""
    free = ~changed
    return free & held & (p <= 0.) & (gap > tol), free & ~held & (p > 0.)


#: the share of Coulomb's limit at which a failed run's friction counts as
#: mobilised in full (:func:`friction_hint`)
MOBILISED = .99


def friction_hint(what: str, friction, normal: ndarray,
                  tangential: ndarray) -> str:
    """A failed run's hint where the Coulomb ``friction`` of ``what`` (a
    contact's description) is mobilised in full at the last converged
    state, ``normal`` and ``tangential`` the sizes of the tractions at
    its corners (any shape), else ``""``: a block pushed by a force past
    mu N ended in a Newton failure that named neither the contact nor
    friction (a user trial).

    >>> friction_hint("obstacle 'floor'", .3, np.array([1., 1.]),
    ...               np.array([.3, .3]))[:47]
    "; the friction of obstacle 'floor' is mobilised"
    >>> friction_hint("obstacle 'floor'", .3, np.ones(2), np.full(2, .2))
    ''
    """
    if isinstance(friction, str) or friction == 0.:
        return ""
    limit = friction * float(normal.sum())
    if not limit > 0 or float(tangential.sum()) < MOBILISED * limit:
        return ""
    return ("; the friction of {} is mobilised in full at the last "
            "converged state (its tangential force {:.3f} of mu times its "
            "normal one): past it a quasi-static load has no equilibrium, "
            "the body slides (dynamics follows the slide; or prescribe its "
            "motion)".format(what, float(tangential.sum()) / limit))


def block_diagonal(C: ndarray) -> csr_matrix:
    """The (dim m, dim m) matrix of the blocks ``C`` (dim, dim, m)."""
    dim, m = C.shape[1:]
    rows = (np.arange(m) * dim)[None, None, :] + np.arange(dim)[:, None, None]
    cols = (np.arange(m) * dim)[None, None, :] + np.arange(dim)[None, :, None]
    return coo_matrix((C.ravel(), (np.broadcast_to(rows, C.shape).ravel(),
                                   np.broadcast_to(cols, C.shape).ravel())),
                      shape=(dim * m, dim * m)).tocsr()


def corner_signs(dim: int) -> ndarray:
    """The (dim, 2**dim) signs of a box's corners, the last axis's
    alternating fastest (corner ``c``'s side along axis ``a`` is + where
    bit ``dim - 1 - a`` of ``c`` is set).

    >>> corner_signs(2)
    array([[-1., -1.,  1.,  1.],
           [-1.,  1., -1.,  1.]])
    """
    return np.array(list(itertools.product((-1., 1.), repeat=dim))).T


def linear_gimp(method):
    """The closed-form GIMP weights of a run's ``method`` (one grid;
    :class:`~skfem_mpm.methods.gimp_linear.LinearGimp`, linear
    elements), or ``None``."""
    gimp = getattr(getattr(method, "piece", method), "gimp", None)
    return gimp if isinstance(gimp, LinearGimp) else None


def side_rows(gimp: LinearGimp, x: ndarray, half: ndarray, sign: ndarray,
              normal: ndarray, spanning: bool = False):
    """GIMP's weights of the corners ``sign`` (dim, m; +-1 per axis) of
    the domains ``x``, ``half`` (dim, m) that lie on their domain's side
    facing an axis-aligned face of normal ``normal`` (dim, m; the face's,
    towards the domain), where ``spanning`` only of a domain that spans
    a grid line along that normal: ``(facing, rows)``, the indices of
    those corners and their scalar rows (facing, ``gimp.N``) on
    ``gimp``'s grid, the weights of that side as a box of zero
    thickness (the hat functions along the normal at the side, their
    average along it) and their gradient towards the corner (``rows``
    ``None`` where none faces).

    cpGIMP's internal force of a uniform stress on a node is the stress
    on the node's weight over the surface of its points' domains: a
    pressure on the side moved through these rows reaches the nodes
    alike (:meth:`StepContact.face_rows`,
    :meth:`~skfem_mpm.solve.body_contact.BodyContact.rows`)."""
    dim, m = x.shape
    k = np.abs(normal).argmax(axis=0)
    j = np.arange(m)
    facing = np.flatnonzero((np.abs(normal[k, j]) >= 1. - FACE_ALIGNED)
                            & (sign[k, j] * normal[k, j] < 0.))
    # an obstacle's: only domains that span a grid line along the face's
    # normal, one within a cell keeps its point's rows (a cpGIMP footing's
    # soil on a grid line: with the side's rows there too, its pressure
    # at B / h = 8 rose from 5.42 to 5.57 c, above the coarse grid's);
    # between bodies every one (both sides' rows alike: the lower block's
    # within its cells too, or pressed blocks are off the glued ones)
    spans = np.full(facing.size, not spanning)
    for d, a in enumerate(gimp.axes if spanning else ()):
        on = k[facing] == d
        c = facing[on]
        first, last = snap_to_lines(
            a, np.clip(x[d, c] - half[d, c], a[0], a[-1]),
            np.clip(x[d, c] + half[d, c], a[0], a[-1]))[2:]
        spans[on] = last > first
    facing = facing[spans]
    if not facing.size:
        return facing, None
    k, f = k[facing], np.arange(facing.size)
    half = half[:, facing].copy()
    side = x[:, facing].copy()
    side[k, f] += sign[k, facing] * half[k, f]
    q = sign[:, facing] * half          # the side's corner
    half[k, f] = 0.
    q[k, f] = 0.
    op = gimp(side, half)
    return facing, (op.S + sum(diags(q[b]) @ op.G[b]
                               for b in range(dim))).tocsr()


def pressure_names(i: int, dim: int):
    """The point-state names of obstacle ``i``: per corner the pressure
    multiplier, then per component per corner the traction."""
    nc = 2 ** dim
    return ([["contact{}_p{}".format(i, c) for c in range(nc)]]
            + [["contact{}_t{}{}".format(i, a, c) for c in range(nc)]
               for a in range(dim)])


def gradient_names(dim: int):
    """Small strain: the point-state names of the accumulated displacement
    gradient, ``[[name_ab]]``."""
    return [["contact_grad{}{}".format(a, b) for b in range(dim)]
            for a in range(dim)]


def offset_names(dim: int):
    """The point-state names of the corners' offsets from where the
    points' deformation puts them, ``[[name_ac]]`` (component a, corner
    c)."""
    return [["contact_dx{}{}".format(a, c) for c in range(2 ** dim)]
            for a in range(dim)]


def start_names(dim: int):
    """The point-state names of the corners' offsets at the run's start
    from where its points' initial positions put them, ``x0 + R``, which
    a staged run's start (its points loaded by an earlier run) and a run
    resumed within it read, ``[[name_ac]]``: zero where a run starts
    from the points' initial positions."""
    return [["contact_start_dx{}{}".format(a, c) for c in range(2 ** dim)]
            for a in range(dim)]


def contact_state_names(obstacles: int, dim: int, finite: bool) -> list:
    """Every point-state name the contact with ``obstacles`` obstacles
    keeps (what a checkpoint of such a run holds beside the materials'
    variables)."""
    names = [name for i in range(obstacles)
             for rows in pressure_names(i, dim) for name in rows]
    if obstacles:
        names += [name for rows in (offset_names(dim), start_names(dim))
                  for row in rows for name in row]
    if obstacles and not finite:
        names += [name for row in gradient_names(dim) for name in row]
    return names


def point_rows(op, idx: ndarray):
    """The shape values ``S`` (csr, len(idx) x scalar DOFs) and gradients
    ``G[b]`` (same pattern) of the step's point operator ``op`` at the
    points ``idx``."""
    if hasattr(op, "S"):                  # per-point sparse operators
        return op.S[idx], [g[idx] for g in op.G]
    basis = op.basis
    slots = basis.point_values(np.arange(basis.point_index.size).reshape(
        basis.point_index.shape))[idx]
    nloc = op.shape_values.shape[0]
    values = op.shape_values.reshape(nloc, -1)[:, slots]
    grads = op.shape_gradients.reshape(op.dim, nloc, -1)[:, :, slots]
    dofs = op.scalar_dofs[:, slots // basis.point_index.shape[1]]
    indptr = np.arange(0, nloc * len(idx) + 1, nloc)
    shape = (len(idx), op.N // op.dim)

    def rows(data):
        return csr_matrix((data.T.ravel(), dofs.T.ravel(), indptr),
                          shape=shape)
    return rows(values), [rows(g) for g in grads]


def held_words(name: str, share: float, where: ndarray,
               roller: bool = False) -> str:
    """An obstacle pushing ``share`` of its force on the grid into DOFs a
    support holds (the largest at the node ``where``, held in some
    components only where ``roller``), in words."""
    return ("obstacle {!r} pushes {:.0%} of its force on the grid into "
            "nodes a support holds (the most at the node {}{}): that force "
            "goes straight into the support's reaction, not through the "
            "material (a wall pushed 1e-3 against a block whose base was "
            "held in every component met 400 times the force it meets "
            "where the base slides; with standard MPM contact did not "
            "settle); end the obstacle a cell short of the support, or "
            "hold the support in the components the obstacle does not "
            "push{}".format(
                name, share, np.round(where, 12).tolist(),
                ", a roller" if roller else "", ROLLER_WORDS if roller
                else ""))


#: what :func:`held_words` adds where the node is a roller's
ROLLER_WORDS = (" (a roller, such as a symmetry plane's, is counted only "
                "for what the obstacle pushes along the component it "
                "holds: the friction it takes from an obstacle that does "
                "not move that way is the mirror half's; docs/contact.md, "
                "\"Half and quarter models\")")


def supported_rows(S: csr_matrix, op, X: ndarray, p: ndarray
                   ) -> csr_matrix:
    """The weights ``S`` (m, nodes) of the corners at ``X`` (dim, m) of
    points ``p`` on the nodes that carry material in the step of ``op``,
    each row scaled to its whole sum
    (:func:`~skfem_mpm.solve.loads.supported_share`, as a surface
    load's).  A node no point supports is no DOF of the step: a
    contact's force there is in no balance, and held the body like a
    support.  B-splines' at a corner reach nodes a quarter cell beyond
    its point's (a weightless B-spline pile's contact force, and the
    soil's supports' reactions, exceeded its load by up to 0.7%).  A
    GIMP corner pressed 1.5e-6 into the empty cell under a block, which
    its domain does not reach, put its depth over the cell's height of
    its force on that cell's lower nodes: a floor's recorded force
    exceeded the block's weight by 1.5e-7 of it, the step converged to
    4e-16."""
    dim = X.shape[0]
    S = supported_share(S, np.unique(op.active_dofs // dim))
    empty = np.flatnonzero(np.diff(S.indptr) == 0)
    if empty.size:        # its force would hold it to a fixed point
        raise ContactError(
            "a contact's corner at {} (of point {}) reaches no grid "
            "node that carries material in this step: the corner lies "
            "beyond the cells its body's points fill (a point's domain "
            "stretched ahead of its neighbours, as a lone point run "
            "ahead of a flow's front: docs/dynamics.md); more points "
            "per cell, a shorter time step, or in dynamics flip < 1 "
            "(the PIC share damps the velocity noise that sends points "
            "ahead) keep the corners among the material's "
            "cells".format(X[:, empty[0]].tolist(), int(p[empty[0]])))
    return S


def spline_rows(weights, op, X: ndarray, p: ndarray) -> csr_matrix:
    """B-splines: :func:`supported_rows` of the weights ``weights(X, p)``
    (m, nodes) of the corners at ``X`` (dim, m) of points ``p``."""
    return supported_rows(weights(X, p).S, op, X, p)


def check_carried_corners(moved: ndarray, where: ndarray, h: float,
                          step: int, slivers: str) -> None:
    """Refuse a trial that moved a contact's corner (distances ``moved``
    (m,), the corners at ``where`` (dim, m)) by more than :data:`CARRIED`
    cells (of size ``h``) through grid nodes that slivers of material
    hold (``slivers``: what they are) with
    :class:`~skfem_mpm.errors.GridMotionError`, which the retry ladder
    answers with the ghost penalty's rung.  Beyond
    :data:`DIVERGED_GRADIENT` cells (the nodes' motion over a cell a
    displacement gradient beyond it) the trial is a diverged iterate,
    not a motion, and the error says so (trial 118's 3D cpGIMP footing:
    "moved 1.49e+04 cells", a step of 0.005 of the footing's width)."""
    if not moved.max(initial=0.) > CARRIED * h:
        return
    k = int(np.argmax(moved))
    diverged = moved[k] > DIVERGED_GRADIENT * h
    raise GridMotionError(
        "step {}: a contact's corner at {} moved {:.3g} cells through grid "
        "nodes holding less than {:g} cells of material ({}): {}; the "
        "ghost penalty ties them (ghost='auto', the default, switches it "
        "on; or {})".format(
            step, np.round(where[:, k], 12).tolist(), moved[k] / h,
            SLIVER_SUPPORT, slivers,
            "a diverged Newton iterate (those nodes ran away), not a "
            "motion of the material" if diverged else
            "the contact does not hold there", setting("ghost", 0.1)))


class ObstacleContact(GridTerm):
    """Contact of the material with the run's obstacles (a grid term).

    Parameters
    ----------
    obstacles
        The run's :class:`~skfem_mpm.Obstacle` s, checked and named.
    cell_size
        The grid's cell size (penalty and tolerance are relative to it).
    modulus
        The materials' largest indentation modulus ``E / (1 - nu^2)``
        (:func:`contact_modulus`).
    domain0
        The points' initial domain half-lengths (dim, n), or ``None``
        (a cube of each point's initial volume).
    total_lagrangian
        The step's gradients refer to the initial configuration (FE).
    moves
        The points move with the grid (not FE).
    finite
        Finite deformation: the points carry ``F``; in small strain the
        term keeps the displacement gradient.
    counters
        The run's counters: ``contact_updates`` counts the
        augmented-Lagrangian updates.
    initial_scale
        The loads' scale at the run's start (1 in dynamics without a load
        ramp: an obstacle starts displaced in full).
    resumed
        The run resumes another (its points' corners at that run's start
        are theirs, :func:`start_names`); else it starts where its points
        are, loaded by an earlier run or not.
    cell_values
        The :class:`CellValues` of the grid (Lagrange elements: the
        corners move with their point's cell; with GIMP, where an
        obstacle holds the material, with their own).

    """

    def __init__(self, obstacles: Sequence[Obstacle], cell_size: float,
                 modulus: float, domain0, total_lagrangian: bool,
                 moves: bool, finite: bool, counters: dict,
                 initial_scale: float = 0., cell_values=None,
                 resumed: bool = False):
        self.obstacles = tuple(obstacles)
        self.resumed = resumed
        self.cell_values = cell_values
        self.locate = None      # the grid's locator (corner_cells)
        self.h, self.domain0 = cell_size, domain0
        self.kappa = [ob.penalty * modulus / cell_size for ob in obstacles]
        #: the penalties the run started with, and how many times
        #: :meth:`StepContact.grow_penalty` grew them (the counters keep
        #: it, :data:`GROWN`, and a resumed run grows them again in
        #: :meth:`begin_run`)
        self.kappa0, self.growths = list(self.kappa), 0
        self.counters = counters
        self.tol = [ob.tolerance * cell_size for ob in obstacles]
        self.total_lagrangian, self.moves = total_lagrangian, moves
        self.finite = finite
        #: per obstacle, its corners read the grid's field where they are
        #: (it holds the material along its face: friction, rough, tied;
        #: not with B-splines without the extension), else the point's
        #: value and gradient (:meth:`field_rows`)
        self.reads_field = None
        self.unheld = False         # (begin_step) for failure_hint
        self.obstacles_alone = False    # (begin_step) sliding_load_hint
        #: (begin_step) the material is held without Coulomb's tangential
        #: hold at the first step's start (:meth:`held_without_coulomb`)
        self.supported = False
        self.ties_slivers = False   # (begin_step)
        self.rigid_bodies = ()      # (begin_step) for prescribed_hint
        self.scale = 0.             # (begin_step) the loads' last scale
        self.ahead = []             # (begin_run) for squeeze_hint
        #: per obstacle, (share, where) of its force on held DOFs in the
        #: step's last solve (:meth:`StepContact.held_shares`)
        self.held_share = []
        self.held_told = False
        self.start_gaps = []        # (begin_run)
        #: the resultant of the last step's load where Coulomb faces alone
        #: may hold the material (:meth:`sliding_load_hint`), else None
        self.load = None
        self.start = [initial_scale * ob.displacement for ob in obstacles]
        counters.setdefault("contact_updates", 0)
        #: the last committed state and its obstacles' normal and
        #: tangential forces (:meth:`failure_hint`)
        self.mobilisation = (None, ())

    def deformation(self, points) -> ndarray:
        """The points' deformation gradient (dim, dim, n) at a step's
        start: theirs in finite deformation, ``I + grad(u)`` of the kept
        gradient in small strain."""
        dim = points.x.shape[0]
        if self.finite:
            return points.F[:dim, :dim]
        return np.eye(dim)[:, :, None] + np.array(
            [[points.state[name] for name in row]
             for row in gradient_names(dim)])

    def corners(self, points, x: ndarray = None, F: ndarray = None
                ) -> ndarray:
        """The corners (dim, nc, n) of the points' domains: where the
        points' position ``x`` and deformation ``F`` (theirs at a step's
        start by default) put them, moved by the offsets the term keeps
        for the corners it followed (:meth:`StepContact.commit`)."""
        dim = points.x.shape[0]
        if x is None:
            x = points.x if self.moves else points.x + points.displacement
        F = self.deformation(points) if F is None else F
        offset = np.array([[points.state[name] for name in row]
                           for row in offset_names(dim)])
        return x[:, None, :] + np.einsum("abp,bcp->acp", F, self.R) + offset

    def corner_cells(self, run, X: ndarray, x: ndarray, cells: ndarray
                     ) -> ndarray:
        """The cells (m,) holding the corners ``X`` (dim, m) of the points
        at ``x`` (dim, m) in ``cells`` (m,: the points', in their field's
        copy of the grid), in the copy of the point's: each corner taken
        a millionth of the way towards its point (a corner on a cell's
        side belongs to the cell its domain covers); a corner outside
        the grid takes its point's."""
        if self.locate is None:
            method = getattr(run.method, "piece", run.method)
            self.locate = using_kernels(point_locator(run.user_grid.mesh),
                                        method.kernels)
        count = run.user_grid.mesh.nelements
        inside = X - 1e-6 * (X - x)
        found = cells % count
        try:
            found = self.locate(inside)[0]
        except PointsOutsideGridError as err:
            keep = np.ones(X.shape[1], dtype=bool)
            keep[err.indices] = False
            found[keep] = self.locate(inside[:, keep])[0]
        return found + cells - cells % count

    @staticmethod
    def corner_distance(ob: Obstacle, X: ndarray, x: ndarray,
                        shift: ndarray, within: float) -> ndarray:
        """The signed distance (nc, n) of the corners ``X`` (dim, nc, n)
        of the points at ``x`` (dim, n) from obstacle ``ob`` shifted by
        ``shift``, where it may be below ``within``; elsewhere a lower
        bound above it (the distance of the point's bounding ball from
        the obstacle's bounding box: a step measures only the points
        near an obstacle, not the body)."""
        dim, nc, n = X.shape
        radius = np.sqrt(((X - x[:, None, :]) ** 2).sum(axis=0)).max(
            axis=0)
        bounds = ob.bounds(shift)
        outside = np.maximum(np.maximum(bounds[:, :1] - x,
                                        x - bounds[:, 1:]), 0.)
        bound = np.sqrt((outside ** 2).sum(axis=0)) - radius
        phi = np.repeat(bound[None], nc, axis=0)
        check = np.flatnonzero(bound < within)
        phi[:, check] = ob.signed_distance(
            X[:, :, check].reshape(dim, -1), shift)[0].reshape(nc, -1)
        return phi

    def held_dofs(self, op, points, scale: float,
                  coulomb_holds: bool = True):
        """The grid DOFs the obstacles hold at a step's start, for the
        check of missing supports: those of the points with a corner
        pressed on an obstacle (or within its tolerance at the run's
        start), along the face's axis where the face is axis-aligned and
        smooth (or has Coulomb friction and not ``coulomb_holds``), in
        every component where it is rough or tied, has friction or is
        oblique."""
        dim, n = points.x.shape
        X = self.corners(points)
        held = np.zeros((dim, n), dtype=bool)
        for i, ob in enumerate(self.obstacles):
            shift = scale * ob.displacement
            # a multiplier, or a penetration within the tolerance, presses
            x = points.x if self.moves else points.x + points.displacement
            pressed = self.near[i] | np.array(
                [points.state[name] > 0 for name in pressure_names(i, dim)[0]]
            ) | (self.corner_distance(ob, X, x, shift, 0.) < 0)
            c, p = np.nonzero(pressed)
            if isinstance(ob.friction, str) or (
                    ob.friction != 0. and coulomb_holds):
                held[:, p] = True
                continue
            Xc = X[:, c, p]
            normal = ob.face_gap(Xc, ob.nearest_face(Xc, shift), shift)[1]
            aligned = np.abs(normal) > 1 - 1e-9
            held[:, p] |= aligned | ~aligned.any(axis=0)
        dofs = [dim * np.unique(point_rows(op, np.flatnonzero(held[a]))[0]
                                .indices) + a for a in range(dim)]
        return np.concatenate(dofs)

    def begin_run(self, points) -> None:
        dim, n = points.x.shape
        self.mobilisation = (None, ())
        # the penalties grown before a resume (the counters resumed):
        # multiplied as the run did, bit for bit
        self.kappa = list(self.kappa0)
        self.growths = self.counters.get(GROWN, 0)
        for i in range(len(self.kappa)):
            for _ in range(self.counters.get(grown_name(i), 0)):
                self.kappa[i] *= GROWTH
        half = self.domain0 if self.domain0 is not None else np.repeat(
            (points.volume0 ** (1. / dim) / 2)[None], dim, axis=0)
        self.half = half
        self.R = corner_signs(dim)[:, :, None] * half[:, None, :]
        for row in offset_names(dim) + start_names(dim) + (
                [] if self.finite else gradient_names(dim)):
            for name in row:
                points.state.setdefault(name, np.zeros(n))
        if not self.resumed:
            # a staged run starts where an earlier run left its points
            # (it was refused by a corner's initial place inside the
            # obstacle it had pushed, and started its contact there: a
            # user trial); a run from the initial positions keeps zeros
            offset = self.corners(points) - (points.x0[:, None, :] + self.R)
            for a, row in enumerate(start_names(dim)):
                for c, name in enumerate(row):
                    points.state[name] = offset[a, c]
        X0 = self.start_corners(points)
        self.anchor, self.near = [], []
        #: a staged start's multipliers are less the penalty's force of
        #: the gaps closed at the start, in the run's first step
        #: (:meth:`StepContact.closed_gaps`)
        self.staged_start = not self.resumed
        #: per obstacle, the material's least distance from it at the start
        self.start_gaps = []
        for i, ob in enumerate(self.obstacles):
            for names in pressure_names(i, dim):
                for name in names:
                    points.state.setdefault(name, np.zeros(n))
            # where the run starts it: in dynamics without a load ramp an
            # obstacle is displaced in full from the start
            phi = ob.signed_distance(X0.reshape(dim, -1), self.start[i])[
                0].reshape(-1, n)
            near = phi <= self.tol[i]
            self.near.append(near)
            self.start_gaps.append(float(phi.min()))
            if (phi < -self.tol[i]).any():
                # a tied one too: it is bonded to the material touching
                # it, and one holding material inside it tied those
                # corners there and failed its first step's Newton (a
                # user trial's wall 0.094 into the soil: a residual
                # from 0.627 to 6.85e4, cut back to 1.95e-3)
                c, p = np.unravel_index(np.argmin(phi), phi.shape)
                # in dynamics without a load ramp the displacement
                # applies from t = 0: the box as written did not
                # overlap, and the message said neither (a user trial)
                moved = "" if not self.start[i].any() else (
                    " (it starts displaced by {}: in dynamics the "
                    "loads' scale at t = 0 moves it; a Dynamics(load="
                    "...) from 0 at t = 0, or the scene key [dynamics] "
                    "load_ramp, starts it where it is written)"
                    .format(self.start[i].tolist()))
                tied = "" if ob.friction != "tied" else (
                    "; a tied obstacle is bonded to the material touching "
                    "it, within the tolerance, not to material inside it")
                raise InvalidInputError(
                    "obstacle {!r} holds material at the start: the "
                    "domain corner of point {} at {} is {:.3g} inside "
                    "(tolerance {:.3g}){}{}; move the obstacle or the "
                    "points".format(ob.name, p, X0[:, c, p].tolist(),
                                    float(-phi[c, p]), self.tol[i],
                                    moved, tied))
            if ob.friction == "tied":
                if not near.any():
                    raise InvalidInputError(
                        "tied obstacle {!r} touches no material at the "
                        "start (nearest point domain corner {:.3g} away, "
                        "tolerance {:.3g}): nothing would be tied".format(
                            ob.name, float(phi.min()), self.tol[i]))
                self.anchor.append(near)
            else:
                self.anchor.append(None)
        # the corners an earlier run moved (a staged run's start)
        start = np.array([[points.state[name] for name in row]
                          for row in start_names(dim)])
        self.warn_edges_inside_cells(
            X0, np.sqrt((start ** 2).sum(axis=0)).ravel() > 1e-6 * self.h)
        self.tilts = self.tilts_met(X0)
        self.ahead = [self.material_ahead(ob, X0.reshape(dim, -1), start)
                      for ob, start in zip(self.obstacles, self.start)]
        self.warn_inclined_faces()

    def start_corners(self, points, idx=slice(None)) -> ndarray:
        """The corners (dim, nc, m) of the points ``idx`` at the run's
        start (at the start of the run a resumed run resumes), where the
        contact's gaps at the start were measured."""
        dim = points.x.shape[0]
        offset = np.array([[points.state[name][idx] for name in row]
                           for row in start_names(dim)])
        return points.x0[:, None, idx] + self.R[:, :, idx] + offset

    def tilts_met(self, X0: ndarray) -> list:
        """Per obstacle, the largest angle in degrees to the grid's axes of
        its polygon's faces that the material's domain corners ``X0``
        (dim, corners, n) touch at the run's start (within
        :data:`TOUCHING` cells; within a cell, a disc pressed on a flat
        block was warned by its faces beside the contact); 0 for boxes,
        in 3D and where none is touched."""
        tilts = [0.] * len(self.obstacles)
        if X0.shape[0] != 2:
            return tilts
        X0 = X0.reshape(2, -1)
        for i, ob in enumerate(self.obstacles):
            if ob.box is not None:
                continue
            near = np.abs(ob.signed_distance(X0, self.start[i])[0]) \
                < TOUCHING * self.h
            if near.any():
                face = ob.nearest_face(X0[:, near], self.start[i])
                normal = ob.faces()[1][:, np.unique(face)]
                tilts[i] = float(np.degrees(np.arcsin(
                    np.abs(normal).min(axis=0))).max())
        return tilts

    def warn_inclined_faces(self) -> None:
        """Log a warning for each polygon obstacle with a face inclined
        by more than :data:`INCLINED` degrees to the grid's axes (with
        friction, or tied: by any, :data:`INCLINED_HOLDING`) that the
        material touches at the run's start (:meth:`tilts_met`): the
        material's surface against it is a staircase of
        the points' axis-aligned domains, touching it at a few corners.  A
        block 0.4 x 0.2 seeded on a 30 degree incline (a user trial, h =
        0.14, MPM, dynamics) slid 17% faster than Coulomb's law gives with
        friction 0.3, and 0.063 with 0.7, where it sticks (rocking on the
        one corner that touched); 0.7% on h = 0.1, GIMP 2.7%.  A block 1 x
        0.5 resting on a rough 5 degree incline (another trial, h = 0.11,
        quasi-static) turned by the incline's angle on the one corner the
        rough face held, moved 400 times what FE gives, its stresses off
        by up to 1.1 rho g H, every step converged (at 0.6, 0.3 and 0.1
        degrees alike: turned by the angle, moved 41, 22 and 8 times as
        far as in FE); with friction 0.5 or tied it failed at its first
        step."""
        for ob, tilt in zip(self.obstacles, self.tilts):
            holding = ob.friction != 0.
            if tilt > (INCLINED_HOLDING if holding else INCLINED):
                logger.warning(
                    "obstacle %r: the material meets a face inclined by "
                    "%.3g degrees to the grid's axes: its surface there is "
                    "a staircase of the points' domains touching at a few "
                    "corners, %s; docs/contact.md): seed the body level "
                    "and tilt the body force, or refine", ob.name,
                    tilt, "and a face that holds it (friction "
                    "or tied) holds it at those corners: it can turn on "
                    "them, and its stresses there are a point support's (a "
                    "block on a rough 5 degree incline turned by 5 degrees "
                    "(at 0.1 degrees by 0.1), moved 400 times as far as in "
                    "FE (at 0.1 degrees 8 times), its stresses off by "
                    "up to 1.1 rho g H; with friction 0.5 or tied it did "
                    "not converge" if holding else "and sliding comes out "
                    "approximate (a block on a 30 degree incline, 2.8 "
                    "cells long, slid 17% too fast with MPM, 2.7% with "
                    "GIMP")

    def warn_splines(self, run) -> None:
        """Log a warning where B-splines without the extension meet an
        obstacle that moves, or one that holds the material along its
        face.  Where the material's surface leaves the support of a row
        of nodes, the nodes drop out of the step, and a moving obstacle's
        force jumps (a footing pushed into weightless von Mises soil, B =
        8 h: by up to 19% between steps; extended 3-8%) or stalls (a
        user's smooth punch at B = 16 h, 2 x 2 points per cell: at 0.66
        of Prandtl's pressure for 9 of its 20 steps, extended within
        6%).  The corners of a face that holds the material (friction,
        rough; a tied face reads the splines there) move by their
        point's value and gradient (the splines' field at the surface
        loses those nodes too: :meth:`field_rows`), and two corners of a
        domain on the face hold its point's gradient as well (a block on
        a rough floor between grid lines, 2 x 2 points, its stresses 9%
        high; a tied clamp was 3% too stiff at ``tolerance=1e-5``).  The
        remedy, ``Stabilisation(extended_splines=True)``, is named where
        it is not refused; with contacts between bodies, where it is,
        the methods that scatter less (:func:`contacts_remedy`).  So is
        a fixed smooth obstacle whose face lies between grid lines
        (:func:`faces_between_lines`): the splines reach the cells under
        it, whose nodes only its push on the material holds (a block
        under gravity on a floor 0.24 of a cell above a grid line, 2
        points a cell: 0.97 of rho g H off with ``"bspline"``, 0.63
        averaged, extended 0.38 and 0.19; 3 points, the floor 0.48 of a
        cell above: 0.22 and 0.76, extended 0.23 and 0.22; the cubic
        splines 0.31 and 0.30); warned whatever the other obstacles do
        (a press moving onto a block on such a floor, 3 points a cell,
        the floor a third of a cell above a grid line: 0.64-1.38 of the
        uniform stress with ``"bspline-gimp"``, was warned only for the
        press)."""
        piece = getattr(run.method, "piece", run.method)
        if getattr(piece, "spline", None) is None or piece.extended:
            return
        moves = any(ob.displacement.any() for ob in self.obstacles)
        # a tied face reads the field (:meth:`field_rows`)
        holds = any(ob.friction != 0. and ob.friction != "tied"
                    for ob in self.obstacles)
        # a fixed smooth face, whatever the others do: a press moving
        # onto a block on such a floor left it unwarned but for the press
        between = faces_between_lines(
            [ob for ob in self.obstacles
             if ob.friction == 0. and not ob.displacement.any()],
            run.user_grid.mesh)
        if between:
            logger.warning(
                "method %r meets obstacles without extended splines, and "
                "a face of %s lies between grid lines: the splines reach "
                "the cells beyond it, whose nodes only its push on the "
                "material holds, and the stresses by it go wrong (a block "
                "under gravity on a smooth floor 0.24 of a cell above a "
                "grid line, 2 points a cell: 0.97 of rho g H off with "
                "'bspline', 0.63 with 'bspline-gimp', 0.31 with the cubic "
                "splines; extended 0.19-0.23, 'bspline' at 2 points a "
                "cell 0.38; a block pressed 0.1%% onto such a floor a "
                "third of a cell above a grid line, 3 points a cell: "
                "0.64-1.38 of the uniform stress with 'bspline-gimp', "
                "extended 0.67-1.40, 'cpgimp' 1.0000) "
                "(docs/bspline.md)%s", piece.name, between,
                contacts_remedy(piece.name) if run.contacts else
                "; {} folds those nodes, or put the face on a grid "
                "line".format(setting("extended_splines", True)))
        if not (moves or holds):
            return
        logger.warning(
            "method %r meets obstacles without extended splines: %s "
            "(docs/bspline.md)%s", piece.name, "; ".join(
                ([] if not moves else [
                    "where the material's surface leaves the support of a "
                    "row of nodes they drop out, and a moving obstacle's "
                    "force jumps or stalls (a footing pushed into soil, B "
                    "= 8 h: by up to 19% between steps; a punch at B = 16 "
                    "h, 2 x 2 points per cell, stood at 0.66 of Prandtl's "
                    "pressure for 9 of 20 steps), and the stresses under it "
                    "scatter (a block pressed 0.5%, 2 x 2 points per cell: "
                    "-74 to -40 where -55 is uniform; extended 0.1%)"]) +
                ([] if not holds else [
                    "a face that holds the material (friction, rough) "
                    "holds its domains' gradient along it too (a block on "
                    "a rough floor between grid lines, 2 x 2 points, its "
                    "stresses 9% high)"])),
            contacts_remedy(piece.name) if run.contacts else
            "; {} folds those nodes and reads the field at the "
            "corners".format(setting("extended_splines", True)))

    def warn_edges_inside_cells(self, X0: ndarray,
                                moved: ndarray = None) -> None:
        """Log a warning for each box obstacle whose edge meets the
        material inside a grid cell: a corner of the box (clipped to the
        grid) within a cell of the material's domain corners ``X0`` (dim,
        corners, n) at the run's start, off the grid lines along the face
        that meets the material (the axes along which that material does
        not lie beyond the box), where a face with material beyond it
        touches it (within :data:`TOUCHING` cells once the obstacle has
        moved its displacement) and reaches past the edge along that
        face (by more than :data:`TOUCHING` cells).  The contact there is
        as good as the
        cell: a strip footing (B = 6.4 h and 6.8 h, weightless von Mises
        soil, 3 x 3 points a cell), its edge inside a cell, pressed 3-26%
        above Prandtl's pressure over the first 0.03 B (the cell's
        straight field carries soil beyond the edge down with it) and
        jumped by 6-105% between steps as rows of points crossed cells;
        with its edge on a grid line it changes by 2.9% at most.  It may
        come out below, too: on a stiff layer over clay
        (:data:`LAYERED_EDGE`) 20-23% below the answer.  Where
        ``moved`` (corners,) says an earlier run moved the material
        there (a staged run's start: its footing stands where a push
        left it, off the grid's lines), the advice is a grid of this
        run's own or a finer one: the grid line at the edge the warning
        asked for could not be had (a user trial)."""
        if self.cell_values is None:
            return
        from scipy.spatial import cKDTree
        dim = X0.shape[0]
        X0 = X0.reshape(dim, -1)
        p = self.cell_values.mesh.p
        low, high = p.min(axis=1), p.max(axis=1)
        eps = 1e-6 * self.h
        lines = [np.unique(np.round(row / eps)) * eps for row in p]
        material = cKDTree(X0.T)
        for i, ob in enumerate(self.obstacles):
            if ob.friction == "tied" or ob.box is None:
                continue
            box = ob.bounds(self.start[i])
            corners = np.clip(ob.corners(self.start[i]), low[:, None],
                              high[:, None])
            for corner, near in zip(corners.T, material.query_ball_point(
                    corners.T, self.h)):
                if not near:
                    continue
                m = X0[:, near]
                # within the tolerance inside: pressed on it (a staged
                # run's start was warned of the box's corner where it left
                # the grid, its face inside a cell, a user trial)
                inside = eps + self.tol[i]
                below = (m <= box[:, :1] + inside).all(axis=1)
                above = (m >= box[:, 1:] - inside).all(axis=1)
                beyond = below | above
                # a face with the material beyond it meets it where the
                # gap is within TOUCHING cells once the obstacle has moved
                # (a ram's bottom 0.25 cells above the base it slides
                # over, its far corner, was warned)
                closing = np.where(below, -1., 1.) * ob.displacement
                gap = np.where(below, box[:, 0] - m.max(axis=1),
                               m.min(axis=1) - box[:, 1])
                meets = beyond & (gap - np.maximum(closing, 0.)
                                  <= TOUCHING * self.h)
                if beyond.any() and not meets.any():
                    continue
                off = [np.abs(lines[a] - corner[a]).min() > eps
                       for a in range(dim)]
                # the material reaches past the edge, outside the box (a
                # press wider than the block, its edge 0.4 cells beyond
                # the block's side, was warned)
                past = [(m[a] < corner[a] - TOUCHING * self.h).any()
                        if corner[a] <= box[a, 0] + eps else
                        (m[a] > corner[a] + TOUCHING * self.h).any()
                        for a in range(dim)]
                if any(off[a] and past[a] and not beyond[a]
                       for a in range(dim)):
                    staged = moved is not None and moved[near].any()
                    logger.warning(
                        "obstacle %r: its edge at %s meets the material "
                        "inside a grid cell: the contact is resolved only "
                        "to the cell (%s; docs/contact.md); %s", ob.name,
                        np.round(corner, 12).tolist(), EDGE_MEASURED,
                        STAGED_EDGE if staged else "put a grid line at it, "
                        "or refine")
                    break

    def failure_hint(self, points, quasi_static: bool) -> str:
        """A quasi-static run's hint: a smooth obstacle's inclined face
        that the material met at the run's start, where nothing else
        holds the material (no supports, no prescribed motion, no other
        obstacle that holds it: a block on it has no equilibrium; a user
        trial's failure named neither), and friction
        mobilised in full on an obstacle at the last converged state
        ``points`` (:func:`friction_hint`), as the step that committed it
        measured it (the point state keeps the multipliers, not the
        pressures: a run resumed there whose first step fails gives no
        friction hint), and a stationary obstacle the material starts
        short of (:meth:`gap_hint`).  In any run, an obstacle whose front
        had moved at the failed step past :data:`SQUEEZED` of the material
        ahead of it (:meth:`squeeze_hint`)."""
        held = ("" if self.held_told else self.held_hint()) + \
            self.turning_hint()
        if not quasi_static:
            return self.squeeze_hint() + self.prescribed_hint(points) + held
        hint = self.squeeze_hint() + self.prescribed_hint(points) + \
            held + self.gap_hint() + "".join(
            "; obstacle {!r} is smooth and the material met its face "
            "inclined by {:.3g} degrees to the grid's axes: held along it "
            "by nothing else, a body on it has no quasi-static equilibrium "
            "(give the face friction, hold the body, or run dynamics)"
            .format(ob.name, tilt)
            for ob, tilt in zip(self.obstacles, self.tilts)
            if self.unheld and tilt > INCLINED_HOLDING)
        committed, parts = self.mobilisation
        if committed is not points:
            return hint + self.sliding_load_hint(points)
        return hint + "".join(friction_hint("obstacle {!r}".format(ob.name),
                                            ob.friction, *part)
                              for ob, part in zip(self.obstacles, parts))

    def onset_hint(self, points) -> str:
        """Words for a run's first step whose full Newton steps failed
        where material rests at the start on an obstacle with Coulomb
        friction, none of its corners pressed yet (``points``, the
        start): expected, and why; else ``""``.  Trial 102's granular
        columns on a floor of friction tan 30 degrees failed so every
        one, and the same column elastic alike, where a smooth or rough
        floor (or held nodes) took 3 iterations: the friction's stick
        and slip, set by a pressure that grows from zero within the
        step.  The line search takes the step, and starts the later
        ones."""
        dim = points.x.shape[0]
        for i, ob in enumerate(self.obstacles):
            if isinstance(ob.friction, str) or ob.friction <= 0. or \
                    not self.near[i].any():
                continue
            lam = np.array([points.state[name]
                            for name in pressure_names(i, dim)[0]])
            if (lam[self.near[i]] > 0).any():
                continue
            return (" (expected: the material starts resting on obstacle "
                    "{!r}, of Coulomb friction {:.3g}, with no pressure "
                    "yet; its stick and slip, set by a pressure that grows "
                    "from zero within the step, make Newton's full steps "
                    "cycle: a user trial's granular and elastic columns "
                    "alike, 3 iterations on a smooth or rough floor; the "
                    "line search takes the step and starts the later "
                    "ones)".format(ob.name, ob.friction))
        return ""

    def crossed_hint(self, points, indices, positions) -> str:
        """Words for points ``indices`` that left the grid at
        ``positions`` (dim, m) in a step from the converged ``points``,
        where their centres lie inside an obstacle: its name, how deep
        (in cells and in the contact's tolerance), how deep they were at
        the step's start, and the grid to extend; else ``""``.  The
        contact holds the domains' corners, not the points' centres: a
        user trial's granular column (cpGIMP, finite deformation) left a
        toe point's centre 0.0074 below a rough floor (6% of a cell, 59
        times the tolerance) with its corners on it, and with the floor
        on the grid's edge the run ended blaming a tight grid or the
        body's motion."""
        if indices is None or positions is None:
            return ""
        indices = np.asarray(indices)
        words = []
        for i, ob in enumerate(self.obstacles):
            shift = self.scale * ob.displacement
            phi = ob.signed_distance(positions, shift)[0]
            inside = phi < 0
            if not inside.any():
                continue
            depth = float(-phi.min())
            start = float(-ob.signed_distance(
                points.x[:, indices[inside]], shift)[0].min())
            words.append(
                "; {} of them left it through obstacle {!r}: their centres "
                "up to {:.3g} inside its face ({:.2g} cells, {:.3g} times "
                "the contact's tolerance {:.3g}; at the step's start {:.3g} "
                "{}){}; let the grid reach a cell or more beyond the "
                "obstacle's face".format(
                    int(inside.sum()), ob.name, depth, depth / self.h,
                    depth / self.tol[i], self.tol[i], abs(start),
                    "inside" if start > 0 else "outside",
                    ": the contact holds the points' domain corners, not "
                    "their centres, and a domain sheared along the face "
                    "keeps its corners on it with its centre past it "
                    "(docs/contact.md, \"A point's centre past a face\")"
                    if depth > self.tol[i] else ": the corners press in "
                    "up to the tolerance, the centres with them"))
        return "".join(words)

    def closing_rigid_bodies(self, points) -> list:
        """``(obstacle, rigid body, closing)`` per obstacle and rigid body
        (:attr:`rigid_bodies`) that touch at the run's start and whose
        prescribed displacements close on each other along the obstacle's
        face normal by ``closing`` (at full load, more than the
        obstacle's tolerance): the material between them cannot give way,
        and no penalty resolves the penetration they prescribe."""
        found = []
        X = self.start_corners(points)          # where near was found
        for i, ob in enumerate(self.obstacles):
            for rigid in self.rigid_bodies:
                mine = self.near[i] & (points.body == rigid.body)[None]
                if not mine.any():
                    continue
                Xc = X[:, mine]
                normal = ob.face_gap(Xc, ob.nearest_face(Xc, self.start[i]),
                                     self.start[i])[1]
                relative = np.asarray(rigid.displacement) - ob.displacement
                closing = -float((relative @ normal).min())
                if closing > self.tol[i]:
                    found.append((ob, rigid, closing))
        return found

    @staticmethod
    def closing_words(ob: Obstacle, rigid, closing: float) -> str:
        """What :meth:`closing_rigid_bodies` found, in words."""
        return ("obstacle {!r} and the rigid body of body {} touch at the "
                "start and their prescribed displacements close on each "
                "other by {:.3g} at full load: the material between them "
                "cannot give way, and no penalty resolves a penetration "
                "both prescribe (prescribe the motion of one of them)"
                .format(ob.name, rigid.body, closing))

    def prescribed_hint(self, points) -> str:
        """A failed run's hint per smooth rigid body (its motion is
        prescribed in its moving components only) that closes on an
        obstacle (:meth:`closing_rigid_bodies`; rough ones are refused
        at the run's start)."""
        return "".join("; " + self.closing_words(*found)
                       for found in self.closing_rigid_bodies(points))

    def held_hint(self) -> str:
        """Per obstacle that pushed, in the failed step's last solve, more
        than :data:`HELD_SHARE` of its force on the grid into DOFs a
        support holds, a hint: there the penetration cannot close (a
        wall pushed into soil down to a fully held base: "raise the
        penalty", and contact never settled)."""
        return "".join("; " + held_words(ob.name, *found)
                       for ob, found in zip(self.obstacles,
                                            self.held_share)
                       if found[0] > HELD_SHARE)

    def turning_hint(self) -> str:
        """Per obstacle that holds the material (friction, rough, tied) on a
        face inclined by more than :data:`INCLINED_HOLDING` that the
        material met at the run's start, a failed run's hint: the run's start
        warned of it (:meth:`warn_inclined_faces`), and the error did not
        say it (a block on one corner of a 25 degree incline, friction
        0.6, failed Newton at its first step in finite deformation)."""
        return "".join(
            "; obstacle {!r} holds the material at a few corners of its "
            "staircase on a face inclined by {:.3g} degrees, on which it "
            "can turn (seed the body level and tilt the body force, or "
            "refine)".format(ob.name, tilt)
            for ob, tilt in zip(self.obstacles, self.tilts)
            if ob.friction != 0. and tilt > INCLINED_HOLDING)

    def unheld_hint(self) -> str:
        """The material starting short of the nearest stationary obstacle
        by more than its tolerance, and by how much (a trial's block
        seeded 0.02 above the floor meant to hold it ended in "not held
        against translation along y", the obstacle unnamed; a cell and
        more above it, in "touches no supported node")."""
        short = [(gap, ob.name) for ob, gap, tol in zip(
            self.obstacles, self.start_gaps, self.tol)
            if not ob.displacement.any() and gap > tol]
        if not short:
            return ""
        gap, name = min(short)
        return ("; the material starts {:.3g} ({:.2g} cells) short of "
                "obstacle {!r}, the nearest stationary one: not touching "
                "it, held by nothing there (seeded points are whole: a "
                "region's edge inside a cell leaves a gap; move the "
                "obstacle's face to the material's surface)".format(
                    gap, gap / self.h, name))

    def gap_hint(self) -> str:
        """Per stationary obstacle that the material starts short of by
        more than its tolerance and less than a cell, a quasi-static
        run's hint: nothing holds the material there until it moves so
        far (cohesionless soil seeded beside a wall, the region's edge
        inside a cell: the points kept whole left a gap of a tenth of a
        cell, the soil's free face had no equilibrium, and the error said
        nothing of the wall)."""
        return "".join(
            "; the material starts {:.3g} ({:.2g} cells) short of "
            "obstacle {!r}: not touching it, held by nothing there until "
            "it moves so far (seeded points are whole: a region's edge "
            "inside a cell leaves a gap; move the obstacle's face to the "
            "material's surface)".format(gap, gap / self.h, ob.name)
            for ob, gap, tol in zip(self.obstacles, self.start_gaps,
                                    self.tol)
            if not ob.displacement.any() and tol < gap < self.h)

    @staticmethod
    def material_ahead(ob: Obstacle, corners: ndarray, start: ndarray):
        """Along the obstacle's motion, where its front is and where the
        material's corners (dim, m) begin and end, at the run's start:
        ``(front, near, far)``, or ``None`` where it does not move or the
        material does not lie wholly ahead of its front (an obstacle
        moving along its face or away from the material squeezes
        nothing)."""
        norm = float(np.linalg.norm(ob.displacement))
        if norm == 0.:
            return None
        d = ob.displacement / norm
        front = float((d @ ob.corners(start)).max())
        along = d @ corners
        if along.min() < front - 1e-9 * max(1., abs(front)):
            return None
        return front, float(along.min()), float(along.max())

    def squeeze_hint(self) -> str:
        """Per obstacle whose front had moved at the last step tried
        (:attr:`scale` of its displacement) past :data:`SQUEEZED` of the
        material ahead of it along its motion at the run's start, a hint:
        held behind, the material is squeezed thin, stiffer than the
        penalty, and contact cannot settle (a press displaced 40 where the
        block is 0.5 tall, a typo, failed with "raise the penalty" after
        the press had moved 0.43; a user trial)."""
        hint = ""
        for ob, ahead in zip(self.obstacles, self.ahead):
            if ahead is None:
                continue
            front, near, far = ahead
            moved = self.scale * float(np.linalg.norm(ob.displacement))
            depth = front + moved - near
            if far > near and depth > SQUEEZED * (far - near):
                hint += (
                    "; obstacle {!r} had moved {:.3g} at the failed step, "
                    "{:.0%} of the material's extent ahead of it along its "
                    "motion ({:.3g}) past its near side (its full "
                    "displacement {:.3g}): material held behind it is "
                    "squeezed thin, stiffer than the contact's penalty "
                    "(check its displacement, or load(t))".format(
                        ob.name, moved, depth / (far - near), far - near,
                        float(np.linalg.norm(ob.displacement))))
        return hint

    def no_equilibrium(self, points) -> bool:
        """Where nothing but one convex obstacle holds the material (no
        support, no prescribed motion, no rigid body, no other obstacle it
        may slide into: a wall 0.05 downhill of a block caught it, a
        review): whether the load of the last step tried slides it off
        its one Coulomb face (:meth:`sliding_load_hint`; the resultant of
        the whole body, so the balance of the material as one)."""
        return self.obstacles_alone and len(self.obstacles) == 1 and \
            self.obstacles[0].convex and bool(self.sliding_load_hint(points))

    def sliding_load_hint(self, points) -> str:
        """Where Coulomb faces alone hold the material and every corner
        that touched them at the run's start lies on one plane, a hint
        when the load of the last step tried (:attr:`load`, its
        resultant) pushes along that plane more than mu times it presses
        on it: no quasi-static equilibrium exists.  The hint of
        :func:`friction_hint` needs a committed step; a block on a floor
        under gravity tilted past mu from the start failed its first step
        with neither hint (a user trial)."""
        if self.load is None:
            return ""
        X = self.start_corners(points)          # where near was found
        touched, normals = [], []
        for i, ob in enumerate(self.obstacles):
            if not self.near[i].any():
                continue
            Xc = X[:, self.near[i]]
            normal = ob.face_gap(Xc, ob.nearest_face(Xc, self.start[i]),
                                 self.start[i])[1]
            touched.append(i)
            normals.append(normal)
        if len(touched) != 1 or np.ptp(normals[0], axis=1).max() > 1e-9:
            return ""
        ob, n = self.obstacles[touched[0]], normals[0][:, 0]
        if not ob.friction > 0.:        # a smooth face: no friction to name
            return ""
        pressing = -float(self.load @ n)
        along = float(np.linalg.norm(self.load + pressing * n))
        if not pressing > 0 or along <= ob.friction * pressing * (1 + 1e-9):
            return ""
        return ("; the load pushes the material along the face of obstacle "
                "{!r} with {:.3f} times mu times the force pressing it on "
                "the face: past mu a quasi-static load has no equilibrium, "
                "the body slides (dynamics follows the slide; or prescribe "
                "its motion)".format(ob.name, along / (ob.friction *
                                                        pressing)))

    def begin_step(self, problem):
        self.scale = problem.s_new      # (squeeze_hint)
        self.held_share = []            # (held_hint) this step's
        self.held_told = False          # (unsettled_hint) said so
        if self.reads_field is None:            # the run's first step
            run = problem.run
            self.reads_field = self.field_rows(run)
            # GIMP's and B-splines' corners reading the field where they
            # are tie the nodes of the cells they cut, some held by a
            # sliver of material (standard MPM's read their point's cell)
            self.ties_slivers = any(self.reads_field) and hasattr(
                problem.method_op, "S")
            self.warn_splines(run)
            self.supported = self.held_without_coulomb(problem)
            self.rigid_bodies = run.rigid_bodies
            for found in self.closing_rigid_bodies(problem.points):
                if found[1].rough:
                    # every component of its nodes prescribed: a rigid
                    # block pushed up into a press pushed down failed
                    # after every cut-back with "raise the penalty" (a
                    # user trial)
                    raise InvalidInputError(self.closing_words(*found))
            # nothing but obstacles holds the material (an oblique face's
            # normal counts as holding every component in ``supported``)
            self.obstacles_alone = not (
                np.size(run.D) or run.prescribed is not None
                or run.rigid_bodies
                or any(term.holds_free_body for term in run.terms))
            # nothing but smooth obstacles holds the material
            self.unheld = self.obstacles_alone and not any(
                ob.friction != 0. for ob in self.obstacles)
        if (not self.supported or self.obstacles_alone) and all(
                not isinstance(ob.friction, str) for ob in self.obstacles) \
                and any(ob.friction > 0. for ob in self.obstacles):
            # (sliding_load_hint) the load's resultant at the step's end
            dofs = problem.grid.nodal_dofs
            if dofs.size == problem.f_dead.size:
                self.load = problem.f_dead[dofs].sum(axis=1)
        return StepContact(self, problem)

    def held_without_coulomb(self, problem) -> bool:
        """Whether the material is held, every rigid-body mode of every
        piece of it, without the tangential hold of Coulomb faces at the
        first step's start: by supports, prescribed motion, rigid bodies,
        the other terms, the obstacles' normals and rough and tied faces
        (:func:`~skfem_mpm.solve.motion.unheld_rigid_modes`; a term's
        inertia holds it in dynamics).  A block on a Coulomb floor with
        supports elsewhere was held only along the floor's normal in the
        first solve, which was then singular (a reviewer's set-up)."""
        run, points, op = problem.run, problem.points, problem.method_op
        if any(term.holds_free_body for term in run.terms):
            return True
        held = [problem.fixed] + [h for h in (
            term.held_dofs(op, points, problem.s_old) for term in run.terms
            if term is not self) if h is not None]
        held.append(self.held_dofs(op, points, problem.s_old,
                                   coulomb_holds=False))
        fixed = np.unique(np.concatenate(held)).astype(problem.fixed.dtype)
        return unheld_rigid_modes(run, problem.op, fixed,
                                  problem.step) is None

    def field_rows(self, run) -> list:
        """Per obstacle, whether its corners read the grid's field where
        they are (GIMP's and extended B-splines' at an obstacle that
        holds the material), else their point's value and gradient
        (smooth faces; B-splines without the extension, whose field at
        the surface loses the nodes the surface leaves: a rough footing's
        pressure fell by 61% over two steps, and a 3D Coulomb floor on a
        grid plane slipped where it holds), except at a tied obstacle,
        whose material stays where it is bonded (read at the point, a
        half block under gravity on a tied floor between grid lines took
        a sideways force of -0.051 of its weight where its rough floor's
        and cpGIMP's are +0.106, in 3D -25.4 against +55.1; a tied clamp
        stiffened by 3.3% from the tolerance 1e-3 to 1e-5, MPM's by
        0.75%).  Chosen per obstacle: a frictional box far from the
        material changed a smooth plate's force by 3.9% while the choice
        was the run's."""
        piece = getattr(run.method, "piece", run.method)
        plain = getattr(piece, "spline", None) is not None and \
            not piece.extended
        return [ob.friction != 0. and (not plain or ob.friction == "tied")
                for ob in self.obstacles]


class StartOfStep:
    """The key of :meth:`StepContact.start_force`'s evaluation (a trial's
    response keys the others): held nowhere, so the evaluation's cache
    lets it go."""


class StepContact(GridTerm):
    """One step's contact with the obstacles (built by
    :meth:`ObstacleContact.begin_step`)."""

    contact = True
    settles = True
    # in dynamics the step's work starts from the force the last step
    # ended with: a corner that drifted a cell from its point goes back
    # on it at the step's end (:meth:`commit`), and there it can start
    # the next step inside the obstacle without a multiplier, a penalty
    # force never worked against; booked from it, the trapezoid's work
    # handed the penalty's energy back (a granular column: a corner put
    # 0.35 mm into the floor, 15 kN at the start, none at the end,
    # -2.70 J of internal work in one step)
    works_from_last_end = True

    def __init__(self, term: ObstacleContact, problem):
        self.term, self.problem = term, problem
        points = problem.points
        self.dim = dim = points.x.shape[0]
        self.op = problem.method_op
        x = points.x if term.moves else points.x + points.displacement
        F = term.deformation(points)
        self.r = r = np.einsum("abp,bcp->acp", F, term.R)  # (dim, nc, n)
        # the offset the step's gradient acts on: the initial one with FE
        # (gradients of the initial configuration) and in small strain
        # (whose kept gradient adds the increments: F = I + sum(grad du))
        self.q = term.R if term.total_lagrangian or not term.finite else r
        self.X = term.corners(points, x, F)
        # where the grid field is read for the corners: where they are,
        # or with FE (the field of the initial configuration) where they
        # were at the start
        self.where = self.X if term.moves else \
            points.x0[:, None, :] + term.R
        self.F = F
        self.shift = [problem.s_new * ob.displacement
                      for ob in term.obstacles]
        self.shift_old = [problem.s_old * ob.displacement
                          for ob in term.obstacles]
        self.moved = [(problem.s_new - problem.s_old) * ob.displacement
                      for ob in term.obstacles]
        self.state = points.state
        self.evaluations = WeakKeyDictionary()
        #: the worst penetration (in tolerances) at each of the step's
        #: augmented-Lagrangian updates
        self.updates = []
        n = points.n
        near = np.zeros(n, dtype=bool)
        # each point's least distance from an obstacle (at the step's end;
        # a lower bound beyond the margin)
        self.clearance = np.full(n, np.inf)
        for i, ob in enumerate(term.obstacles):
            phi = term.corner_distance(ob, self.X, x, self.shift[i],
                                       MARGIN_CELLS * term.h)
            near |= (phi < MARGIN_CELLS * term.h).any(axis=0)
            self.clearance = np.minimum(self.clearance, phi.min(axis=0))
            for names in pressure_names(i, dim):
                for name in names:
                    near |= points.state[name] != 0
            if term.anchor[i] is not None:
                near |= term.anchor[i].any(axis=0)
        self.select(np.flatnonzero(near))

    def select(self, idx: ndarray):
        """Build the step's corner operators for the points ``idx``."""
        term, dim = self.term, self.dim
        self.idx = idx
        # Lagrange elements have one kind of rows (the point's cell)
        keys = [field and hasattr(self.op, "S") for field in term.reads_field]
        #: the kinds of rows, the field's (True) and the points' (False)
        scalar = {key: self.corner_rows(idx, key) for key in set(keys)}
        self.rows = {key: kron(rows, identity(dim), format="csr")
                     for key, rows in scalar.items()}
        #: per obstacle, the corners' rows (vector, dim nc m x N): u_c = J du
        self.J = [self.rows[key] for key in keys]
        self.Xs = self.X[:, :, idx].reshape(dim, -1)      # (dim, nc m)
        #: the round-off of the corners' coordinates (and so of gaps)
        self.roundoff = ROUNDOFF * np.abs(self.Xs).max(initial=0.)
        self.area, self.lam, self.tau, self.anchor = [], [], [], []
        self.closed = []
        self.face = []
        # rough: the corners that stick in the step (in contact at its
        # start; after Newton, those found apart let go and those pressed
        # join, each once), their gaps at the start, which changed
        self.held, self.start_gap, self.changed = [], [], []
        #: per obstacle, the corners pressed at the step's start (by the
        #: last step's multipliers) and in the step's last trial, and how
        #: many changed between its trials (:meth:`engaging_words`)
        self.pressed_start, self.pressed_last, self.flips = [], [], []
        self.inward = self.material_side()
        for i, ob in enumerate(term.obstacles):
            names = pressure_names(i, dim)
            face = ob.nearest_face(self.Xs, self.shift_old[i], self.inward,
                                   ALIKE * term.h)
            # over the face within the tolerance of its edges: a rough
            # footing's edge on a grid line held its edge corners by a
            # penalty that lets them slip by 1e-6 of a cell, and beyond
            # a round-off's slack they let go, rose beside it and took
            # the force with them (a 3D footing: 10.35 to 1.06 c)
            _, normal, over = ob.face_gap(self.Xs, face, self.shift_old[i],
                                          term.tol[i])
            self.face.append((face, over))
            self.closed.append(self.closed_gaps(i, face))
            lam = np.concatenate([self.state[nm][idx] for nm in names[0]])
            if term.staged_start:
                # a staged start: a corner an earlier run left pressed
                # across a gap keeps its pressure, its multiplier less the
                # penalty's force of the gap now closed (a uGIMP footing's
                # next stage started pressing 5% harder, 91.7 for 87.3)
                lam = np.where(lam > 0, np.maximum(
                    lam - term.kappa[i] * self.closed[i], 0.), lam)
            self.lam.append(lam)
            self.pressed_start.append(lam > 0)
            self.pressed_last.append(None)
            self.flips.append(0)
            self.tau.append(np.array([np.concatenate(
                [self.state[nm][idx] for nm in comp])
                for comp in names[1:]]))
            self.area.append(self.corner_areas(normal, idx))
            if not term.reads_field[i] and self.J[i] is self.rows.get(False):
                face_rows = self.face_rows(idx, normal, scalar[False])
                if face_rows is not None:
                    self.J[i] = face_rows
            if ob.friction == "rough":
                gap = ob.face_gap(self.Xs, face, self.shift_old[i])[0] \
                    - self.closed[-1]
                self.held.append(over & ((self.lam[i] > 0)
                                         | (gap <= term.tol[i])))
                self.start_gap.append(gap)
                self.changed.append(np.zeros(gap.size, dtype=bool))
            else:
                self.held.append(None)
                self.start_gap.append(None)
                self.changed.append(None)
            if term.anchor[i] is None:
                self.anchor.append(None)
            else:
                tied = term.anchor[i][:, idx].ravel()
                X0 = term.start_corners(self.problem.points, idx).reshape(
                    dim, -1)
                self.anchor.append((tied, X0))
                # the point state keeps the traction (a staged run, its
                # anchors where the earlier run left the corners, starts
                # pulling with it: it started from the multiplier, the
                # penalty's share lost, a user trial's tied wall 29.73 to
                # 27.67); the multiplier is the traction with the
                # penalty's of the corners' mismatch at the step's start
                self.tau[i] = self.tau[i] + term.kappa[i] * self.mismatch(
                    i, np.zeros_like(self.Xs), self.shift_old[i])
        self.resolve()
        self.evaluations = WeakKeyDictionary()
        self.carriers = self.sliver_carriers()

    def resolve(self) -> None:
        """What the contact resolves (:meth:`weigh`): :data:`RESOLVED`
        of the force a penetration of the tolerance makes."""
        term = self.term
        self.resolution = RESOLVED * max(
            (kappa * tol * safe_norm(area) for kappa, tol, area in zip(
                term.kappa, term.tol, self.area)), default=0.)

    def closed_gaps(self, i: int, face: ndarray) -> ndarray:
        """The gaps (nc m,) closed for the run at obstacle ``i``: of the
        step's corners within its tolerance of it at the run's start
        (:meth:`ObstacleContact.begin_run`) the gap there from the plane
        of their ``face`` (m,), the gap the step measures, where positive
        (a floor placed with round-off, or a tolerance's width below the
        body); else zero.  The distance from the obstacle is not that
        gap past a face's edge: a corner a staged run started with
        beyond a wall's edge within the tolerance, pressed on its face,
        had that distance closed as well, and pressed 10 times harder
        (a user trial's hold started at a residual of 0.75)."""
        term, dim = self.term, self.dim
        near = term.near[i][:, self.idx].ravel()
        X0 = term.start_corners(self.problem.points, self.idx).reshape(
            dim, -1)
        gap = self.term.obstacles[i].face_gap(X0, face, term.start[i])[0]
        return np.where(near, np.clip(gap, 0., None), 0.)

    def sliver_carriers(self) -> list:
        """The field's rows (vector) of the step's corners where an
        obstacle reads the grid's field at its corners (GIMP's and
        extended B-splines' at obstacles that hold the material,
        :meth:`ObstacleContact.field_rows`; the rows of every corner of
        the step's points, those facing another, smooth obstacle too) on
        the grid DOFs of nodes that slivers of material hold (support
        below :data:`~skfem_mpm.solve.problem.SLIVER_SUPPORT` cells),
        where the run holds the ghost penalty in reserve
        (``ghost="auto"``, not yet on); else ``[]``:
        :meth:`check_carried`.  The points' rows (smooth faces) weigh
        those nodes as the material does: B-splines' material running
        away through a smooth floor, no obstacle holding, keeps its
        error (``StepTooLongError``, :data:`RUNAWAY`)."""
        from ..stabilisation.ghost import GhostStabilisation
        from .dynamics import sliver_nodes, value_matrix  # (imports this)
        run, dim = self.problem.run, self.dim
        field = self.rows.get(True)
        if field is None or not hasattr(self.op, "S") or not any(
                isinstance(t, GhostStabilisation) and not t.active
                for t in run.terms):
            return []
        sliver = sliver_nodes(value_matrix(self.op),
                              self.problem.points.volume,
                              SLIVER_SUPPORT * self.term.h ** dim)
        if not sliver.size:
            return []
        dofs = (dim * sliver[:, None] + np.arange(dim)).ravel()
        return [(field[:, dofs], dofs)]

    def check_carried(self, du: ndarray) -> None:
        """Refuse a trial increment ``du`` that moves a corner by more
        than :data:`CARRIED` cells through grid nodes that slivers of
        material hold (:meth:`sliver_carriers`; ``GridMotionError``: the
        ghost penalty of ``ghost="auto"`` ties them, the retry ladder's
        first rung after full Newton).  A 3D cpGIMP block on a Coulomb
        floor (h = 0.1, 2 x 2 x 2 points a cell) spread past its grid
        lines by 8e-5 in its first step: the nodes beyond, held by
        domains' slivers (the points' weights 2e-15, material stiffness
        1e-21 of the median), were read by the corners with the field's
        weight there (7e-9); a sliding corner's traction along its slip,
        which no stiffness balances there, moved them 8e6 in Newton's
        first direction, and corners by up to 13 cells (a pressed one
        0.5 cells through the floor); Newton cycled between stick-slip
        states, and the step took 113 iterations (line search, stabilised
        tangent) before the penalty's rung, which solved it in 2.  A
        rough floor converged with those nodes at 1.9e6 (refused after
        Newton, the same rung)."""
        for rows, dofs in self.carriers:
            moved = (rows @ du[dofs]).reshape(-1, self.dim)
            check_carried_corners(np.sqrt((moved ** 2).sum(axis=1)),
                                  self.Xs, self.term.h, self.problem.step,
                                  "a GIMP domain barely past a grid line")

    def corner_rows(self, idx: ndarray, field: bool) -> csr_matrix:
        """The scalar rows (nc m, N / dim) of the corners of the points
        ``idx`` (corner-major): the grid's field where they are
        (``field``) or, with GIMP and B-splines, their point's value and
        gradient."""
        term, dim, nc = self.term, self.dim, 2 ** self.dim
        where = self.where[:, :, idx].reshape(dim, -1)
        weights = getattr(self.problem.run.method, "weights_at", None)
        if hasattr(self.op, "S") and not field:
            # GIMP's and B-splines' smooth weights: the point's operator
            # and its gradient, u_c = (S + q . G) du
            S, G = point_rows(self.op, idx)
            counts = np.diff(S.indptr)
            return vstack([csr_matrix((S.data + sum(
                np.repeat(self.q[b, c, idx], counts) * G[b].data
                for b in range(dim)), S.indices, S.indptr), shape=S.shape)
                for c in range(nc)])
        if weights is not None:
            # extended B-splines, obstacles that hold: the splines there
            return spline_rows(weights, self.op, where, np.tile(idx, nc))
        # Lagrange elements: the polynomial of the point's cell (GIMP,
        # obstacles that hold: of the corner's, on its nodes that carry
        # material)
        cells = np.tile(self.op.point_elements[idx], nc)
        if not hasattr(self.op, "S"):
            return term.cell_values(where, cells, self.op.N // dim)
        cells = term.corner_cells(self.problem.run, where, np.tile(
            self.problem.points.x[:, idx], nc), cells)
        return supported_rows(term.cell_values(where, cells,
                                               self.op.N // dim),
                              self.op, where, np.tile(idx, nc))

    def face_rows(self, idx: ndarray, normal: ndarray,
                  point: csr_matrix):
        """GIMP (linear elements, one field), a smooth obstacle: the
        vector rows (dim nc m, N) of the corners of the points ``idx``,
        those on their domain's side facing an axis-aligned face of
        normal ``normal`` (dim, nc m), of a domain that spans a grid line
        along that normal, by GIMP's weights of that side of the domain,
        a box of zero thickness (the hat functions along the normal at
        the side, the average along it, and its gradient towards the
        corner), the others by their point's rows ``point`` (scalar, nc
        m x N / dim, :meth:`corner_rows`); ``None`` where no corner is
        such, or the method has no such weights.

        cpGIMP's internal force of a uniform stress on a node is the
        stress on the node's weight over the surface of its points'
        domains, the hat at the side along the normal; a pressure
        through rows that extrapolate the point's average weight by its
        average gradient, ``S + q G``, puts on a node below a grid line
        that a domain reaches by a sliver ``e`` the weight ``e / 2h``
        where the internal force has ``e / h``.  That node carries
        almost no material (stiffness of order ``(e/h)^2``): the
        mismatch moved it until the domains' stress was half off
        (0.51 of p without the ghost penalty, 0.03 to 0.06 with it;
        ``docs/contact.md``)."""
        dim, nc, m = self.dim, 2 ** self.dim, len(idx)
        gimp = linear_gimp(self.problem.run.method)
        if gimp is None or not hasattr(self.op, "S") \
                or self.op.N // dim != gimp.N:
            return None
        points = self.problem.points
        p = np.tile(idx, nc)
        facing, face = side_rows(gimp, points.x[:, p], points.domain[:, p],
                                 np.repeat(corner_signs(dim), m, axis=1),
                                 normal, spanning=True)
        if not facing.size:
            return None
        f = np.arange(facing.size)
        keep = np.ones(nc * m)
        keep[facing] = 0.
        scatter = csr_matrix((np.ones(facing.size), (facing, f)),
                             shape=(nc * m, facing.size))
        rows = (diags(keep) @ point + scatter @ face).tocsr()
        rows.eliminate_zeros()
        return kron(rows, identity(dim), format="csr")

    def motions(self, du: ndarray) -> list:
        """Per obstacle, the corners' motion (dim, nc m) by ``du``."""
        moved = {}
        for J in self.J:
            if id(J) not in moved:
                moved[id(J)] = (J @ du).reshape(-1, self.dim).T
        return [moved[id(J)] for J in self.J]

    def held_shares(self, ev) -> list:
        """Per obstacle, ``(share, where)``: the share of its force on the
        grid by the corner tractions of ``ev`` (:meth:`evaluate`; the
        sum of the nodal forces' sizes) that acts on DOFs the step holds
        (supports, prescribed motion, rigid bodies), and the node where
        the largest of those acts.

        A roller's DOF (a node held in some components only: a symmetry
        plane) counts the obstacle's normal push, not its friction where
        the obstacle does not move along it: there the friction is the
        mirror half's, which the roller stands for (a rough plate on a
        half block on a symmetry roller was told 24% of its force went
        into the support, and to end the plate a cell short of it)."""
        D = np.asarray(self.problem.fixed, dtype=np.int64)
        dim = self.dim
        found = []
        held = np.bincount(D // dim) if D.size else np.zeros(0, int)
        roller = held[D // dim] < dim if D.size else np.zeros(0, bool)
        for i, (ob, J, (T, _, _, part)) in enumerate(zip(
                self.term.obstacles, self.J, ev)):
            f = np.abs(J.T @ T.T.ravel())
            total = f.sum()
            if not D.size or total == 0.:
                found.append((0., None))
                continue
            on = f[D]
            if part is not None and ob.friction != 0.:
                # the normal push alone on a roller the obstacle does not
                # move along
                still = roller & (ob.displacement[D % dim] == 0.)
                normal = ob.face_gap(self.Xs, self.face[i][0],
                                     self.shift[i])[1]
                fn = np.abs(J.T @ (self.area[i] * part[0] * normal).T.ravel())
                on = np.where(still, fn[D], on)
            most = np.argmax(on)
            found.append((on.sum() / total, self.problem.grid.doflocs[
                :, D[most]], bool(roller[most])))
        return found

    def grid_force(self, ev) -> ndarray:
        """The obstacles' force on the grid of the corner tractions of
        ``ev`` (:meth:`evaluate`)."""
        return -sum(J.T @ T.T.ravel() for J, (T, *_) in zip(self.J, ev))

    def followed_motion(self, du: ndarray, ev) -> ndarray:
        """The corners' motion (dim, nc m) by ``du`` as they are followed
        into the next step: by the rows of the obstacle they meet where
        those are not the point's (an obstacle that reads the grid's
        field, or a smooth one's side rows, :meth:`face_rows`) and the
        corner is pressed (or tied), else by their point's."""
        motions = self.motions(du)
        base = self.rows.get(False, self.rows.get(True))
        motion = next((moved for J, moved in zip(self.J, motions)
                       if J is base), None)
        if motion is None:
            motion = (base @ du).reshape(-1, self.dim).T
        for i, (T, *_) in enumerate(ev):
            if self.J[i] is not base:
                held = (T != 0.).any(axis=0)
                if self.anchor[i] is not None:
                    held |= self.anchor[i][0]
                motion = np.where(held, motions[i], motion)
        return motion

    def material_side(self):
        """``inward(which)``: per corner ``which`` (indices of ``Xs``) the
        direction into the material there (dim, k), the sum of the
        offsets to their points from the corners at its place (within
        :data:`ALIKE` cells), of every domain with a corner there (the
        corner of two domains on a body's flat face points across it),
        and the offset to its own point (dim, k);
        asked only where faces of an obstacle are alike
        (:meth:`~skfem_mpm.solve.obstacles.Obstacle.nearest_face`; all
        of a step's corners against all cost 9 s a step at 1e5 points in
        3D)."""
        towards = -self.r[:, :, self.idx].reshape(self.dim, -1)
        tree = []

        def inward(which):
            if not tree:
                tree.append(cKDTree(self.Xs.T))
            near = cKDTree(self.Xs[:, which].T).sparse_distance_matrix(
                tree[0], ALIKE * self.term.h, p=np.inf,
                output_type="ndarray")
            out = np.zeros((self.dim, which.size))
            np.add.at(out.T, near["i"], towards[:, near["j"]].T)
            return out, towards[:, which]
        return inward

    def check_passing(self, u: ndarray, H: ndarray) -> None:
        """Refuse a step that carried material through an obstacle
        (:class:`~skfem_mpm.errors.StepTooLongError`, cut back): a corner
        whose path over the step, relative to the obstacle (the points'
        motion ``u`` (dim, n) and gradient ``H``, less the obstacle's),
        went deeper into it than its tolerance between ends that are not.
        A block dropped onto a floor 0.05 thick in time steps of 0.2 ended
        under it, and a blade pushed 0.6 in one load step through a plate
        0.1 thick left it undeformed, both with no force and no error.
        A pass with a displacement gradient beyond
        :data:`DIVERGED_GRADIENT` in the step is a diverged solution, not
        a step too long (:class:`~skfem_mpm.errors.GridMotionError`: the
        retry ladder, then cut back)."""
        term, dim = self.term, self.dim
        motion = u[:, None, :] + np.einsum("abp,bcp->acp", H, self.q)
        for i, ob in enumerate(term.obstacles):
            d = (motion - self.moved[i][:, None, None]).reshape(dim, -1)
            moving = np.flatnonzero((np.abs(d) > term.tol[i]).any(axis=0))
            passed = moving[ob.passed_through(
                self.X.reshape(dim, -1)[:, moving], d[:, moving],
                self.shift_old[i], term.tol[i])]
            if passed.size:
                far = np.sqrt((d[:, passed] ** 2).sum(axis=0)).max()
                span = np.ptp(self.problem.run.user_grid.mesh.p, axis=1)
                owners = np.unique(passed % self.X.shape[2])
                strain = np.sqrt((H[:, :, owners] ** 2).sum(
                    axis=(0, 1))).max()
                if strain > DIVERGED_GRADIENT and far <= span.max():
                    raise GridMotionError(
                        "step {}: the step's solution moved material "
                        "through obstacle {!r} ({} domain corners, the "
                        "first of point {}, up to {:.3g} cells relative to "
                        "it, while the obstacle moved {:.2g} cells), with "
                        "a displacement gradient up to {:.3g} in the step: "
                        "a diverged solution, not a motion of the "
                        "material (grid nodes that carry almost no "
                        "material running away: the ghost penalty holds "
                        "them, {}); retried, then cut back".format(
                            self.problem.step, ob.name, passed.size,
                            passed[0] % self.X.shape[2], far / term.h,
                            np.linalg.norm(self.moved[i]) / term.h, strain,
                            setting("ghost", 0.1)))
                raise StepTooLongError(
                    "step {}: material went through obstacle {!r} within "
                    "the step ({} domain corners, the first of point {}, "
                    "moved across it, up to {:.3g} cells relative to it{}): "
                    "cut back".format(
                        self.problem.step, ob.name, passed.size,
                        passed[0] % self.X.shape[2], far / term.h,
                        RUNAWAY if far > span.max() else ""))

    def mismatch(self, i: int, u: ndarray, shift: ndarray) -> ndarray:
        """The tied obstacle ``i``'s corners' mismatch (dim, nc m), their
        motion since the run's start, the step's ``u`` with it, less the
        obstacle's (at ``shift``); zero where a corner is not tied."""
        tied, X0 = self.anchor[i]
        return np.where(tied, (self.Xs - X0) + u - (
            shift - self.term.start[i])[:, None], 0.)

    def corner_areas(self, normal: ndarray, idx: ndarray) -> ndarray:
        """Each corner's share (nc m,) of its domain's area projected on
        the plane of ``normal`` (dim, nc m): in finite deformation Nanson's
        face areas ``det(F) F^-T N A0`` at the step's start, in small
        strain the initial ones (a block resting on a floor under a
        constant weight started each step 0.5% out of balance where the
        areas followed its lateral strain), a quarter (2D: half) of those
        facing the obstacle."""
        dim, nc = self.dim, 2 ** self.dim
        half = self.term.half[:, idx]
        faces = np.array([np.prod(np.delete(2 * half, k, axis=0), axis=0)
                          for k in range(dim)])            # (dim, m)
        F = self.F[:, :, idx].transpose(2, 0, 1) if self.term.finite \
            else np.broadcast_to(np.eye(dim), (len(idx), dim, dim))
        cof = np.linalg.det(F)[:, None, None] * np.linalg.inv(F).transpose(
            0, 2, 1)                                       # J F^-T
        vectors = cof * faces.T[:, None, :]                # (m, a, face k)
        n = normal.reshape(dim, nc, -1)
        projected = np.abs(np.einsum("acj,jak->ckj", n, vectors)).sum(
            axis=1)                                        # (nc, m)
        return (projected / 2 ** (dim - 1)).ravel()

    # the trial

    def evaluate(self, du: ndarray, response):
        """Corner tractions (force on the material) and their derivative
        blocks for the trial increment ``du``, per obstacle, cached for
        the trial's ``response``."""
        if response in self.evaluations:
            return self.evaluations[response]
        term, dim = self.term, self.dim
        start = not du.any()
        if not start:
            self.check_carried(du)
        ev = []
        eye = np.eye(dim)[:, :, None]
        for i, (ob, u) in enumerate(zip(term.obstacles, self.motions(du))):
            kappa, area = term.kappa[i], self.area[i]
            face, over = self.face[i]
            # the step's start's gap plus the increment's part: the gap of
            # the corners moved, a difference of coordinates, kept du to
            # the round-off of the coordinates (a press at y = 3e4 stalled
            # at a residual of 5e-7, at 5.5e6 of 1e-4)
            gap, n, _ = ob.face_gap(self.Xs, face, self.shift[i])
            gap = gap + (n * u).sum(axis=0) - self.closed[i]
            if start:
                # at the step's start a gap within the coordinates'
                # round-off touches: it presses by nothing (a 3D soil
                # touching a Coulomb wall pressed it by 1e-7 Pa of
                # round-off, stuck to it in the first solve, and hung on
                # it in tension); not later: a stiff block's penetration
                # is below that round-off far from the origin (at 5e5,
                # 5.5e6 m Newton cycled with its contact force dropped)
                gap[np.abs(gap) <= self.roundoff] = 0.
            C = np.zeros((dim, dim, u.shape[1]))
            if self.anchor[i] is not None:
                tied = self.anchor[i][0]
                mismatch = self.mismatch(i, u, self.shift[i])
                T = area * np.where(tied, self.tau[i] - kappa * mismatch, 0.)
                C[:, :, tied] = kappa * area[tied] * eye
                ev.append((T, C, np.abs(mismatch).max(initial=0.), None))
                continue
            p = np.where(over, np.maximum(0., self.lam[i] - kappa * gap), 0.)
            active = p > 0
            if not start:
                if self.pressed_last[i] is not None:
                    self.flips[i] += int(
                        (active != self.pressed_last[i]).sum())
                self.pressed_last[i] = active
            T = area * p * n
            nn = np.einsum("as,bs->abs", n, n)
            C[:, :, active] = (kappa * area * nn)[:, :, active]
            if start:       # corners touching (a gap within the tolerance)
                # stiffen the step's first tangent: a body resting on a
                # floor is held in the first solve, when no corner presses;
                # along the face too where it is rough, or has friction
                # and the material is not held without that hold
                # (:meth:`ObstacleContact.held_without_coulomb`; a block on
                # a floor: a singular first solve without).  Touching without
                # pressure a Coulomb face has no friction to give: soil
                # hung on a stationary wall by that hold came out of the
                # first solve in tension at the wall's top, at Mohr-
                # Coulomb's apex, and every cut-back failed (user trial)
                touching = over & (self.lam[i] - kappa * gap
                                   >= -kappa * term.tol[i]) & ~active
                hold = eye if ob.friction == "rough" or (
                    ob.friction != 0. and not term.supported) else nn
                C[:, :, touching] = (kappa * area * hold)[:, :, touching]
            tau = np.zeros_like(u)
            if ob.friction != 0.:
                tau, C_t, _ = coulomb(ob.friction, kappa, p, n, self.tau[i],
                                      u - self.moved[i][:, None],
                                      self.held[i])
                C += area * C_t
                T = T + area * tau
            # the penetration, or a gap a pressure holds across (a
            # multiplier kept from a push as the obstacle draws back: a
            # staged lift pressed with 2.4% of the push's force across a
            # gap of twice the tolerance)
            ev.append((T, C, float(np.max(np.where(
                p > 0, np.abs(gap), -gap)[over], initial=0.)),
                (p, tau, gap)))
        # kept while the trial lives: the tangent of an accepted trial
        # finds it however many trials a line search tried in between
        self.evaluations[response] = ev
        return ev

    def force(self, du: ndarray, response):
        self.pushing = self.grid_force(self.evaluate(du, response))
        return self.pushing

    def start_force(self, zero: ndarray, response):
        """The obstacles' force on the grid where the step starts: the
        corners there, the obstacles where the last step left them (not
        moved to the step's end: in dynamics the start's balance gives the
        first step's acceleration and its work's trapezoidal rule, and a
        wall starting to push a block at rest gave it an initial
        acceleration from the penalty of the whole step's push, 36 times
        the push's force, and 5.5 times the wall's speed)."""
        shift, moved = self.shift, self.moved
        self.shift = self.shift_old
        self.moved = [np.zeros_like(m) for m in moved]
        try:
            ev = self.evaluate(zero, StartOfStep())
        finally:
            self.shift, self.moved = shift, moved
        return self.grid_force(ev)

    def predictor(self, problem, zero: ndarray):
        """Where obstacles move off corners in contact at the step's start
        (pressed, or touching within the tolerance): the tangent at the
        step's start, the obstacles where the last step left them, and
        their motion through that contact as a load, ``J^T C m`` (the
        contact's traction follows the corners' motion relative to the
        obstacle: moved by ``m``, the traction changes by ``C m``); the
        predictor of nonlinear FE codes for prescribed motion
        (:meth:`~skfem_mpm.protocols.GridTerm.predictor`).  Newton's first
        trial, the obstacles at the step's end, finds those corners apart
        and the material free of them: Mohr-Coulomb backfill at its
        active limit state, held by a wall moving off it, sprang 3 times
        the wall's motion forward, into the wall and every point onto the
        yield surface, and the next direction moved it 1.7e3 m (user
        trial 53: the steps were cut back to 1/128 of the 30 asked)."""
        released = False
        for i, (ob, moved) in enumerate(zip(self.term.obstacles,
                                            self.moved)):
            if self.anchor[i] is not None or not moved.any():
                continue
            kappa, (face, over) = self.term.kappa[i], self.face[i]
            gap, n, _ = ob.face_gap(self.Xs, face, self.shift_old[i])
            touching = over & (self.lam[i] - kappa * (gap - self.closed[i])
                               >= -kappa * self.term.tol[i])
            released |= bool((touching & (moved @ n < 0)).any())
        if not released:
            return None
        shift, moved = self.shift, self.moved
        self.shift = self.shift_old
        self.moved = [np.zeros_like(m) for m in moved]
        try:
            trial = problem.residual(zero)
            ev = self.evaluate(zero, trial.response)
            K = problem.tangent(trial)
        finally:
            self.shift, self.moved = shift, moved
            self.evaluations = WeakKeyDictionary()
        load = sum(J.T @ np.einsum("abs,b->sa", C, m).ravel()
                   for J, (_, C, *_), m in zip(self.J, ev, moved))
        return K, trial.r + load

    def weigh(self, balance, du: ndarray):
        """The residual is measured against the obstacles' force on the
        grid too (the trial's, as :meth:`force` formed it), as against the
        forces that drive prescribed motion, and at least against
        :data:`RESOLVED` of the force a penetration of the tolerance makes
        at the step's corners (what the contact resolves): a body squeezed
        between obstacles
        with no load and no held DOF has nothing else to be measured
        against (every residual was 1.0, and the run failed), and a blade
        that just reaches a plate at a step's end, no force in the
        answer, had Newton cycle between a trial pressing by round-off and
        one not pressing (residuals 1.0 and 0.69 of forces of round-off's
        size)."""
        balance.scale = max(balance.scale, safe_norm(self.pushing),
                            self.resolution)

    def matrix(self, response):
        if response not in self.evaluations:
            raise RuntimeError("contact: the tangent of a trial whose force "
                               "was not evaluated")
        blocks = {}             # summed per kind of rows
        for J, (_, C, *_) in zip(self.J, self.evaluations[response]):
            blocks[id(J)] = (J, blocks.get(id(J), (J, 0.))[1] + C)
        return sum(J.T @ (block_diagonal(C) @ J)
                   for J, C in blocks.values()).tocsr()

    def engaging_words(self) -> str:
        """What a Newton loop that made no progress says of the contact
        where its pressed corners changed in the step (from those the
        last step left pressed, or between trials): the contact engaging
        (a first touch, a landing) or letting go, not a body collapsing;
        else ``""``.  Trial 93's block landing on an incline stalled in
        its first step, "the body collapsing?", and the retry with the
        line search solved it."""
        told = []
        for ob, start, last, flips in zip(self.term.obstacles,
                                          self.pressed_start,
                                          self.pressed_last, self.flips):
            if last is None:
                continue
            new, gone = int((last & ~start).sum()), int((start & ~last).sum())
            if new or gone or flips:
                told.append("{!r} (domain corners pressed: {} new since "
                            "the step's start, {} let go, {} changes "
                            "between trials)".format(ob.name, new, gone,
                                                     flips))
        if not told:
            return ""
        return ("the contact with obstacle {} engaging or letting go: its "
                "pressed corners changed within the step (a first touch, "
                "a landing; a retry takes it)".format(", ".join(told)))

    def unsettled_hint(self) -> str:
        """:meth:`ObstacleContact.held_hint`: where an obstacle pushes
        held DOFs its penetration cannot close, and no penalty helps (a
        failed run's error then does not repeat it)."""
        words = self.term.held_hint()
        self.term.held_told = bool(words)
        # the step failed by this cause: its error is a HeldSupportError
        self.held_cause = bool(words)
        return words

    def settle(self, problem, trial, du: ndarray) -> bool:
        """After Newton: ``True`` when every corner's penetration (the
        gap of one pressed, a tied corner's mismatch) is within its
        obstacle's tolerance; else
        the multipliers take the converged tractions (augmented
        Lagrangian), corners newly near an obstacle join, and the step is
        solved again."""
        term, dim = self.term, self.dim
        self.reshaped, self.off_by = True, 0.
        ev = self.evaluate(du, trial.response)
        # corners outside the step's selection that went through an
        # obstacle: of the points that moved as far as their clearance
        # (a distance changes no faster than the position)
        H, u = self.op.gradients(du), self.op.values(du)
        self.check_passing(u, H)
        reach = np.sqrt((u ** 2).sum(axis=0)) + np.sqrt(
            (H ** 2).sum(axis=(0, 1)) * (self.q ** 2).sum(axis=0).max(
                axis=0))
        outside = np.ones(self.X.shape[2], dtype=bool)
        outside[self.idx] = False
        check = np.flatnonzero(outside & (self.clearance - reach
                                          < max(term.tol)))
        X = (self.X[:, :, check] + u[:, None, check] + np.einsum(
            "abp,bcp->acp", H[:, :, check], self.q[:, :, check])).reshape(
                dim, -1)
        joined = np.zeros_like(outside)
        for i, ob in enumerate(term.obstacles if check.size else ()):
            phi = ob.signed_distance(X, self.shift[i])[0].reshape(
                -1, check.size)
            joined[check] |= (phi < term.tol[i]).any(axis=0)
        if joined.any():
            logger.debug("step %d: %d points reached an obstacle beyond the "
                         "step's selection; solving again", problem.step,
                         int(joined.sum()))
            self.select(np.union1d(self.idx, np.flatnonzero(joined)))
            return False
        # a corner through an obstacle by a face other than its own
        across = False
        for i, (ob, u) in enumerate(zip(term.obstacles, self.motions(du))):
            if self.anchor[i] is not None:
                continue
            Xs = self.Xs + u
            phi = ob.signed_distance(Xs, self.shift[i])[0]
            face, over = self.face[i]
            gap = ob.face_gap(Xs, face, self.shift[i])[0] - self.closed[i]
            wrong = (phi < -term.tol[i]) & ~(over & (gap < -term.tol[i]))
            if wrong.any():
                wrong = np.flatnonzero(wrong)
                face[wrong] = ob.nearest_face(
                    Xs[:, wrong], self.shift[i],
                    lambda which: self.inward(wrong[which]), ALIKE * term.h)
                over[wrong] = True
                self.closed[i] = self.closed_gaps(i, face)
                across = True
        if across:
            self.evaluations = WeakKeyDictionary()
            logger.debug("step %d: a corner went through another face of an "
                         "obstacle; solving again", problem.step)
            return False
        if self.rough_changes(ev, du):
            self.evaluations = WeakKeyDictionary()
            return False
        term.held_share = self.held_shares(ev)
        worst = [e[2] / tol for e, tol in zip(ev, term.tol)]
        if max(worst, default=0.) <= 1.:
            return True
        self.reshaped, self.off_by = False, max(worst)
        for i, (T, C, violation, normal_part) in enumerate(ev):
            if violation <= term.tol[i]:
                continue
            if normal_part is None:                 # tied
                self.tau[i] = np.divide(T, self.area[i], where=self.area[i]
                                        > 0, out=np.zeros_like(T))
            else:
                self.lam[i] = normal_part[0]
        self.evaluations = WeakKeyDictionary()
        problem.counters["contact_updates"] += 1
        logger.debug("step %d: penetration %.2g of the tolerance; "
                     "augmented-Lagrangian update", problem.step, max(worst))
        self.updates.append(max(worst))
        self.grow_penalty(worst)
        self.tell_slow_updates()
        return False

    def grow_penalty(self, worst) -> None:
        """From the step's :data:`GROW_AFTER`-th augmented-Lagrangian
        update, one that left more than :data:`GROW_SLOW` of the last's
        penetration multiplies the penalty of the obstacles not settled
        (``worst``: their penetrations in tolerances) by :data:`GROWTH`
        for the rest of the run, :data:`GROWTHS` times a run at the most
        (a user's penalty, the default's or not, is where a run starts);
        a smooth obstacle's only, not one's pushing more than
        :data:`HELD_SHARE` of its force into held DOFs.  The step's next
        solve takes it, the multipliers kept."""
        done, term = self.updates, self.term
        if len(done) < GROW_AFTER or done[-1] <= GROW_SLOW * done[-2] \
                or term.growths >= GROWTHS:
            return
        # a smooth obstacle's: one that holds the material along its face
        # (friction, rough, tied) holds it there by the penalty within a
        # step, and its answer follows the penalty (a half block on a
        # rough floor, B-splines: a sideways force of 0.106 of its
        # weight at the default penalty, 0.075 grown to 100); nor one
        # pushing held DOFs (no penalty closes that penetration:
        # :meth:`ObstacleContact.held_hint`)
        grown = [i for i, (ob, w) in enumerate(zip(term.obstacles, worst))
                 if w > 1. and ob.friction == 0.
                 and term.held_share[i][0] <= HELD_SHARE]
        if not grown:
            return
        term.growths += 1
        counters = term.counters
        counters[GROWN] = term.growths
        for i in grown:
            term.kappa[i] *= GROWTH
            counters[grown_name(i)] = counters.get(grown_name(i), 0) + 1
        self.resolve()
        self.updates = []
        logger.warning(
            "step %d: the contact's penetration still %.2g of the "
            "tolerance after %d augmented-Lagrangian updates, the last "
            "%s it by %.1f%%: the penalty grown %g times for the rest "
            "of the run, obstacle %s (%s)",
            self.problem.step, done[-1], len(done),
            "cutting" if done[-1] <= done[-2] else "raising",
            100 * abs(1 - done[-1] / done[-2]), GROWTH,
            ", ".join("{!r} to {:.3g}".format(
                term.obstacles[i].name, term.obstacles[i].penalty
                * term.kappa[i] / term.kappa0[i]) for i in grown),
            growth_reason(hasattr(self.op, "S"), any(
                term.obstacles[i].box is None for i in grown)))

    def tell_slow_updates(self) -> None:
        """Warn once a run where a step's augmented-Lagrangian updates
        pass :data:`SLOW_UPDATES` and the last left more than
        :data:`SLOW_UPDATE` of the penetration: the corners' penetration
        follows their neighbours' more than their own pressure (GIMP's
        corners on a curved face: each update raised a corner's
        multiplier by the penalty's force of a penetration that fell by
        1-4%; one pressing across a gap let go by as little), and each
        update takes a solve.  A larger penalty takes fewer
        (:data:`SLOW_MEASURED`); a smooth obstacle's grows by itself
        (:meth:`grow_penalty`), and the updates are counted again
        after it."""
        run, done = self.problem.run, self.updates
        if len(done) <= SLOW_UPDATES or done[-1] <= SLOW_UPDATE * done[-2] \
                or ("slow updates",) in run.warned:
            return
        run.warned.add(("slow updates",))
        logger.warning(
            "step %d: the contact's penetration still %.2g of the tolerance "
            "after %d augmented-Lagrangian updates, the last %s it by "
            "%.1f%%: its corners' gaps follow their neighbours' more than "
            "their own pressure, and each update takes a solve; a larger "
            "Obstacle penalty takes fewer (%s)", self.problem.step,
            done[-1], len(done), "cutting" if done[-1] <= done[-2] else
            "raising", 100 * abs(1 - done[-1] / done[-2]),
            SLOW_MEASURED)

    def rough_changes(self, ev, du: ndarray) -> bool:
        """After Newton, rough obstacles: a corner that stuck but was found
        apart (unpressed, its gap beyond the tolerance) lets go; one
        pressed that did not stick joins (:func:`rough_apart_join`),
        sticking from where it met the obstacle within the step (its
        relative motion
        scaled by its start gap over the gap's faster closing, by its own
        straight path or by the obstacle's approach: the multiplier
        ``kappa P`` of that motion); each corner changes once a step, so
        the rounds end.  ``True`` when any changed (the step is
        solved again).  Joined only at the next step, a corner touching
        within a step slid in it: a rough plate closing a gap in one step
        gave the smooth plate's answer."""
        term = self.term
        changes = 0
        for i, (ob, u) in enumerate(zip(term.obstacles, self.motions(du))):
            if self.held[i] is None:
                continue
            p, _, gap = ev[i][3]
            apart, join = rough_apart_join(self.held[i], self.changed[i], p,
                                           gap, term.tol[i])
            self.tau[i][:, apart] = 0.
            if join.any():
                face, _ = self.face[i]
                X = self.Xs[:, join] + u[:, join]
                gap, n, _ = ob.face_gap(X, face[join], self.shift[i])
                # the share of the step at contact: the start gap over
                # the faster of its closings, the corner's straight path
                # and the obstacle's own approach (a plate pushing a
                # block: the block's corner meets it where it stands)
                g0 = self.start_gap[i][join]
                closing = np.maximum(g0 - (gap - self.closed[i][join]),
                                     (self.moved[i][:, None] * n).sum(axis=0))
                met = np.clip(g0 / np.maximum(closing, 1e-300), 0., 1.)
                motion = (u[:, join] - self.moved[i][:, None]) * met
                self.tau[i][:, join] = term.kappa[i] * (
                    motion - (motion * n).sum(axis=0) * n)
            self.held[i] = (self.held[i] & ~apart) | join
            self.changed[i] |= apart | join
            changes += int(apart.sum() + join.sum())
        if changes:
            logger.debug("step %d: %d rough corners came apart or joined; "
                         "solving again", self.problem.step, changes)
        return bool(changes)

    def commit(self, problem, trial, du: ndarray, new, record) -> None:
        term, dim, idx = self.term, self.dim, self.idx
        ev = self.evaluate(du, trial.response)
        # the multipliers committed are the staged start's, its closed
        # gaps' force taken off (:meth:`select`)
        term.staged_start = False
        nc, m = 2 ** dim, len(idx)
        new.state = dict(new.state)
        if not term.finite:
            H = self.op.gradients(du)
            for a, row in enumerate(gradient_names(dim)):
                for b, name in enumerate(row):
                    new.state[name] = new.state[name] + H[a, b]
        # the corners followed: where the grid field moved them, kept as
        # offsets from where the points' deformation puts them; the others
        # go back there, and so do a point's corners once one has drifted
        # from its place there by a cell (in a strongly sheared cell the
        # two part; read far beyond its cell, a corner drifting further
        # moved faster, and a rough footing's run ended in overflow)
        for row in offset_names(dim):
            for name in row:
                new.state[name] = np.zeros(new.x.shape[1])
        followed = self.Xs + self.followed_motion(du, ev)
        offset = followed.reshape(dim, nc, m) - term.corners(new)[:, :, idx]
        drift = np.sqrt((offset ** 2).sum(axis=0)).max(axis=0)
        apart = drift > term.h
        if apart.any():
            logger.debug("step %d: the corners of %d points drifted from "
                         "their domains (up to %.3g); back on them",
                         problem.step, int(apart.sum()), float(drift.max()))
            offset[:, :, apart] = 0.
        for a, row in enumerate(offset_names(dim)):
            for c, name in enumerate(row):
                new.state[name][idx] = offset[a, c]
        forces = []
        for i, (T, C, violation, normal_part) in enumerate(ev):
            names = pressure_names(i, dim)
            if normal_part is None:         # tied: the traction
                p = np.zeros(nc * m)
                tau = self.tau[i] - term.kappa[i] * self.mismatch(
                    i, self.motions(du)[i], self.shift[i])
            else:
                # the multiplier, so that the next step starts from this
                # pressure with this penetration (the pressure would add
                # the penalty's force of the penetration a second time)
                p = np.where(normal_part[0] > 0, self.lam[i], 0.)
                tau = normal_part[1]
            values = [p] + list(tau)
            for comp, value in zip(names, values):
                value = value.reshape(nc, m)
                for c, name in enumerate(comp):
                    column = np.zeros(new.x.shape[1])
                    column[idx] = value[c]
                    new.state[name] = column
            forces.append(-T.sum(axis=1))
        record.obstacle_forces = np.array(forces)
        record.contact_pressure, record.contact_area = self.pressures(ev)
        self.committed = ev
        run = problem.run
        # (the last settle's, of this evaluation, where it ran)
        for ob, found in zip(term.obstacles,
                             term.held_share or self.held_shares(ev)):
            if found[0] > HELD_SHARE and ("held", ob.name) not in \
                    run.warned:
                run.warned.add(("held", ob.name))
                logger.warning("step %d: %s", problem.step,
                               held_words(ob.name, *found))
        # the normal and tangential forces' sizes, for a failure's hint
        term.mobilisation = (new, [
            (np.zeros(1), np.zeros(1)) if part is None else (
                np.array([(self.area[i] * part[0]).sum()]),
                np.array([(self.area[i] * np.sqrt((part[1] ** 2).sum(
                    axis=0))).sum()]))
            for i, (_, _, _, part) in enumerate(ev)])

    def pressures(self, ev):
        """The contact pressure and its area per obstacle and point
        (csr, obstacles x n), of the converged corner pressures ``p`` of
        ``ev`` (:meth:`evaluate`): a point's pressure is the normal force
        its pressed corners transmit, ``sum A_c p_c``, over their share
        ``sum A_c`` of the surface (its area), so that ``sum(pressure *
        area)`` over the points is the sum of the corners' normal forces,
        an obstacle's force normal to a flat face.  Tied obstacles: none
        (their force is the tractions')."""
        nc, m = 2 ** self.dim, len(self.idx)
        n = self.X.shape[2]
        rows, cols, pressure, area = [], [], [], []
        for i, (_, _, _, part) in enumerate(ev):
            if part is None:
                continue
            pressed = part[0] > 0
            a = np.where(pressed, self.area[i], 0.).reshape(nc, m).sum(0)
            f = (self.area[i] * part[0]).reshape(nc, m).sum(0)
            k = np.flatnonzero(a > 0)
            rows.append(np.full(k.size, i))
            cols.append(self.idx[k])
            pressure.append(f[k] / a[k])
            area.append(a[k])
        shape = (len(ev), n)

        def matrix(values):
            if not rows:
                return csr_matrix(shape)
            return coo_matrix((np.concatenate(values), (
                np.concatenate(rows), np.concatenate(cols))),
                shape=shape).tocsr()
        return matrix(pressure), matrix(area)

    def finish(self, problem, new, record) -> None:
        """In dynamics, an impact is perfectly plastic along the normal:
        a point with a corner pressed on an obstacle at the step's end
        moves with it across its surface (velocity and acceleration),
        tangentially as the integrator says; a tied point moves with it.
        Without this the trapezoidal rule returns the impulse of the step
        that stopped the material as a rebound larger than the fall (a
        dropped block rose 1.7 times higher).  The kinetic energy of the
        record is that of the corrected velocities (the loss shows in
        ``Result.energies()["balance"]``)."""
        if new.velocity is None:
            return
        dim, idx, nc = self.dim, self.idx, 2 ** self.dim
        m = len(idx)
        v, a = new.velocity[:, idx], new.acceleration[:, idx]
        for i, (T, C, violation, normal_part) in enumerate(self.committed):
            rate = self.moved[i] / record.time_step
            if normal_part is None:
                held = self.anchor[i][0].reshape(nc, m).any(axis=0)
                v[:, held], a[:, held] = rate[:, None], 0.
                continue
            pressed = normal_part[0] > 0                 # the normal part
            push = ((T - self.area[i] * normal_part[1]) * pressed).reshape(
                dim, nc, m).sum(1)
            size = np.sqrt((push ** 2).sum(axis=0))
            hit = size > 0
            n = push[:, hit] / size[hit]
            v[:, hit] -= ((v[:, hit] - rate[:, None]) * n).sum(0) * n
            a[:, hit] -= (a[:, hit] * n).sum(0) * n
        new.velocity, new.acceleration = new.velocity.copy(), \
            new.acceleration.copy()
        new.velocity[:, idx], new.acceleration[:, idx] = v, a
        if record.energy is not None:
            record.energy["kinetic"] = .5 * float(
                problem.run.masses @ (new.velocity ** 2).sum(0))


class CellValues:
    """The grid's displacement field near points: ``values(x, cells, N)``
    are the shape values (csr, m x ``N`` scalar DOFs) at positions ``x``
    (dim, m) of the element's polynomial on ``cells`` (m,), the cells of
    the points the positions belong to (a domain's corners), extrapolated
    where a position lies beyond its point's cell: ``u(x) = S du``, exact
    for any linear field.  The corners of one point move with one
    polynomial, and the field they read stays the one of the cell that
    carries their material (the cell a corner lies in may hold only a
    sliver of it, or none).

    Parameters
    ----------
    mesh
        The run's grid (with a copy per field where bodies are in contact).
    elem
        The grid's scalar element.
    """

    def __init__(self, mesh, elem):
        self.mesh, self.elem = mesh, elem
        self.local = cell_coordinates(mesh, clip=False)
        self._dofs = None

    @property
    def dofs(self) -> ndarray:
        """The scalar DOFs of each cell (local nodes, cells)."""
        if self._dofs is None:
            from skfem.assembly import Dofs
            self._dofs = Dofs(self.mesh, self.elem).element_dofs
        return self._dofs

    def __call__(self, x: ndarray, cells: ndarray, N: int) -> csr_matrix:
        dofs = self.dofs
        local = self.local(x, cells)
        nloc = dofs.shape[0]
        values = np.array([self.elem.lbasis(local, i)[0]
                           for i in range(nloc)])              # (nloc, m)
        m = x.shape[1]
        return coo_matrix((values.ravel(), (np.tile(np.arange(m), nloc),
                                            dofs[:, cells].ravel())),
                          shape=(m, N)).tocsr()


def contact_modulus(material) -> float:
    """The largest indentation modulus ``E / (1 - nu^2)`` of a run's
    materials, ``4 mu (lam + mu) / (lam + 2 mu)`` of their elastic
    constants ``lam`` and ``mu`` (a material without ``E`` and ``nu``,
    Cam clay, a user's: of its ``lam`` and ``mu``), the scale of the
    obstacles' penalties, in 2D (plane strain) and 3D alike: the
    modulus that sets a rigid punch's force on an elastic half space
    (a circular punch's stiffness is ``2 a E / (1 - nu^2)``), from 2
    to 4 ``mu`` as ``nu`` goes from 0 to 1/2.  The P-wave modulus
    ``lam + 2 mu`` it replaced grows without bound there (51 ``mu`` at
    ``nu = 0.49``, 13 times this): a rigid strip punched into such von
    Mises soil with GIMP had its pressed corners change from 31 to 15
    within a step, and Newton took 1177 iterations where it takes 251
    now (docs/robustness.md)."""
    lam = np.asarray(material.lam, dtype=float)
    mu = np.asarray(material.mu, dtype=float)
    return float(np.max(4 * mu * (lam + mu) / (lam + 2 * mu)))


def contact_term(obstacles, cell_size: float, material, domain0,
                 total_lagrangian: bool, moves: bool, finite: bool,
                 counters: dict, initial_scale: float = 0.,
                 cell_values=None, resumed: bool = False):
    """The contact term of a run's obstacles."""
    return ObstacleContact(obstacles, cell_size, contact_modulus(material),
                           domain0,
                           total_lagrangian, moves, finite, counters,
                           initial_scale, cell_values, resumed)
