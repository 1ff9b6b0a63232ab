"""The motion a load step holds: supports, prescribed grid displacements
and rigid bodies of points, checked against the material they act on."""
import logging
from typing import NamedTuple

import numpy as np
from numpy import ndarray

from ..errors import (InvalidInputError, PrescribedMotionError,
                      SingularSystemError)
from ..methods.fields import tile_dofs
from ..methods.method import DOMAIN_METHODS
from ..protocols import GridTerm
from .linear import check_rigid_body_modes, component_labels, \
    element_labels

__all__ = ["HeldMotion", "held_motion"]

logger = logging.getLogger(__name__)

#: the cells a body's material may lie farther from a node that prescribed
#: motion moves than the nearest material there and still be moved by it
#: (the contacts' default tolerance: touching).  A block beside the
#: pushed one, 0.1 and 0.2 cells apart, was dragged by half the motion
#: within the supports' quarter cell
#: (:data:`~skfem_mpm.solve.body_contact.SUPPORT_NEAREST`)
MOVED_NEAREST = 1e-3


class HeldMotion(NamedTuple):
    """The grid DOFs a step holds (``fixed``: supports, prescribed motion,
    rigid bodies), the step's start increment ``du0`` (their increments,
    zero elsewhere), the DOFs that move (``driven``) and the DOFs of each
    rigid body (``rigid_dofs``)."""
    fixed: ndarray
    du0: ndarray
    driven: ndarray
    rigid_dofs: list


def prescribed_increments(run, s_old: float, s_new: float, step: int):
    """The prescribed grid DOFs and their increments over a step, checked:
    integer DOFs of the grid, one finite value each."""
    dofs, values = run.prescribed(run.user_grid, s_old, s_new)
    dofs, values = np.asarray(dofs), np.asarray(values, dtype=np.float64)
    if dofs.size == 0:
        dofs = dofs.astype(np.int64)
    if values.ndim == 0 and dofs.ndim == 1:      # one number for all
        values = np.full(dofs.shape, float(values))
    N = run.user_grid.N
    if dofs.dtype.kind not in "iu" or dofs.ndim != 1 \
            or values.shape != dofs.shape or not np.isfinite(values).all() \
            or (dofs.size and (dofs.min() < 0 or dofs.max() >= N)):
        raise InvalidInputError(
            "step {}: prescribed(basis, f_old, f_new) must return integer "
            "grid DOFs in [0, {}) and one finite increment each, got DOFs of "
            "dtype {} and shape {}, increments of shape {}".format(
                step, N, dofs.dtype, dofs.shape, values.shape))
    # the same motion on every field's copy (contacts between bodies), of
    # which :func:`held_motion` keeps those its bodies lie on
    return tile_dofs(dofs, N, run.nfields), np.tile(values, run.nfields)


def check_prescribed_motion(run, op, dofs: ndarray, values: ndarray,
                            step: int):
    """Prescribed motion must act on the material it acted on.  A grid DOF
    with a non-zero prescribed increment that carried material at the start
    (a node of a cell holding a point's initial position) but is supported
    by no point in this step has lost its material.  When some of the
    material that started in its cells now sits in a cell with no moving
    prescribed DOF, the body has moved away from the prescribed nodes (a
    surface pushed down by more than a cell below the nodes that push it)
    and the motion would no longer be followed, silently: refused.
    (Material that moved on to other prescribed nodes, as a corner of a
    sheared block or a body whose whole grid motion is prescribed, is still
    driven; increments on nodes the body never reached do no harm.)"""
    moving = dofs[values != 0.]
    on = np.zeros(op.N, dtype=bool)
    on[op.active_dofs] = True
    lost = moving[~on[moving] & run.initially_supported[moving]]
    if not lost.size:
        return
    element_dofs = run.grid.dofs.element_dofs
    lost_mask = np.zeros(op.N, dtype=bool)
    lost_mask[lost] = True
    touching = lost_mask[element_dofs].any(axis=0)         # per cell
    carried = touching[run.initial_cells]                  # per point
    driven = np.zeros(op.N, dtype=bool)
    driven[moving] = True
    if driven[element_dofs[:, op.point_elements[carried]]].any(axis=0).all():
        return
    raise PrescribedMotionError(
        "step {}: the prescribed motion acts on {} grid DOF(s) that carried "
        "material at the start but that no material point supports any "
        "more, e.g. at {}, while that material has moved into cells no "
        "prescribed motion reaches: the grid nodes stay where they are, the "
        "material has moved away from them by more than a cell, and their "
        "motion would not be followed; move the loading body as material "
        "points (a stiff body) instead of grid nodes, or prescribe less "
        "motion than a cell".format(step, lost.size, run.grid.doflocs[
            :, lost[:3]].T.tolist()))


#: the cells by which grid nodes that prescribed motion moves along the
#: normal of the plane they lie on may move before a run warns that the
#: material's face leaves them (:func:`warn_faces_left`)
FACE_LEFT = .25
#: the same for the methods whose points' domains end at the material's
#: face (:data:`~skfem_mpm.methods.method.DOMAIN_METHODS`), measured as
#: the face's distance from the nodes at the last step's start
FACE_LEFT_DOMAINS = .02


def warn_faces_left(run, step: int, s_old: float = 0.,
                    s_new: float = 1.) -> None:
    """A warning, once a run whose points move, where prescribed motion
    at full load moves grid nodes that lie on one plane normal to the
    motion (a sample's top pushed down, a footing's nodes) by more than
    :data:`FACE_LEFT` cells: the nodes stay on their grid line while the
    material's face leaves it, and their motion then reaches the
    material through the cell's shape functions, not as a platen on its
    face (a block's top pushed 0.15, 0.6 cells, by its grid nodes moved
    0.118 with standard MPM, 0.132 with cpGIMP, and its lateral stress
    scattered from -727 to 375 and -519 to 250 where it is 0, a user
    trial; pushed 0.12 cells, 0 and within 12; the
    error of :func:`check_prescribed_motion` comes only once the face
    has left the nodes' cells).  Motion along the plane (a shear box's
    top) keeps the face on the line and is not warned; nor are nodes
    moved along an axis that do not all lie on one plane across it (a
    sample pushed from both ends), nor motion that returns by full load
    (read from ``prescribed(basis, 0, 1)``, called once more for it).

    The methods whose domains end at the face (GIMP, the splines
    averaged over the domains) are warned from :data:`FACE_LEFT_DOMAINS`
    cells, the full load's motion less the first step's (``s_old`` to
    ``s_new``; the face's distance from the nodes at the last of equal
    steps' start): a step that starts with the face below the pushed
    line leaves on the free nodes a cell inside the force of the
    uniform stress times the gap over the cell size (a hat's value at
    the face), which no uniform state balances, where standard MPM's
    points integrate their cells as full.  Trial 116's patch test (a
    unit block on rollers, h = 0.125, 2 x 2 points per cell, its top
    nodes pushed 0.02 in 4 steps): ``sigma_yy`` from -25.3 to -21.4
    (cpGIMP, finite strain; -22.29 uniform with standard MPM), the
    spread 1.2 to 2.2 times the gap in cells (uGIMP 17.7-17.9%,
    ``"bspline-gimp"`` 22.6% against cpGIMP's 17.4%); one step, or a rigid
    ``Obstacle`` platen (cpGIMP, finite strain: to 2e-12), is uniform."""
    if "faces left" in run.warned or not run.method.moves:
        return
    run.warned.add("faces left")
    dofs, values = run.prescribed(run.user_grid, 0., 1.)
    dofs = np.asarray(dofs, dtype=np.int64)
    values = np.abs(np.broadcast_to(np.asarray(values, dtype=np.float64),
                                    dofs.shape))
    domains = run.method.name in DOMAIN_METHODS
    if domains:
        first = run.prescribed(run.user_grid, s_old, s_new)[1]
        first = np.abs(np.broadcast_to(
            np.asarray(first, dtype=np.float64), dofs.shape))
    places = run.user_grid.doflocs[:, dofs]
    dim, h = run.dim, run.cell_size
    for c in range(dim):
        along = (dofs % dim == c) & (values > 0.)
        if not along.any() or np.ptp(places[c, along]) > 1e-9 * h:
            continue
        moved = float(values[along].max())
        if domains:
            gap = float((values[along] - first[along]).max())
            if gap > FACE_LEFT_DOMAINS * h:
                logger.warning(
                    "step %d: prescribed motion at full load moves the "
                    "grid nodes on the plane %s = %.6g by up to %.3g "
                    "along %s (%.2g cells, %.2g cells more than the "
                    "first step): the nodes stay on their grid line "
                    "while the material's face leaves it, and method "
                    "%r, whose points' domains end at the face, then "
                    "leaves a step's uniform stress out of balance by "
                    "that gap over a cell (with cpGIMP the stress near "
                    "the face scatters by 1.2 to 2.2 times the gap in "
                    "cells; a patch test 0.12 cells off: by 17%%, by 18%% "
                    "with uGIMP, 23%% with bspline-gimp); beyond %g of "
                    "a cell push with a rigid Obstacle (docs/contact.md)"
                    " or a traction", step,
                    "xyz"[c], float(places[c, along][0]), moved,
                    "xyz"[c], moved / h, gap / h, run.method.name,
                    FACE_LEFT_DOMAINS)
        elif moved > FACE_LEFT * h:
            logger.warning(
                "step %d: prescribed motion at full load moves the grid "
                "nodes on the plane %s = %.6g by up to %.3g along %s "
                "(%.2g cells): the nodes stay on their grid line while "
                "the material's face leaves it, and their motion then "
                "reaches the material through the cells' shape "
                "functions, not as a platen on its face (the stress near "
                "it scatters); beyond %g of a cell push with a rigid "
                "Obstacle (docs/contact.md)", step, "xyz"[c],
                float(places[c, along][0]), moved, "xyz"[c], moved / h,
                FACE_LEFT)


def warn_chosen_copies(run, dofs: ndarray, values: ndarray, on: ndarray,
                       active: ndarray, step: int) -> None:
    """A warning, once a run, where prescribed motion moved one body's
    copy of a node and not another's that carries material there (the
    rule chose between bodies in contact by their distance to the node:
    a body beside the pushed one was dragged by 0.66 of the motion where
    the pushed one's top lay half a cell below the moved nodes, and a
    pushed body settling below them lost their motion)."""
    if "prescribed bodies" in run.warned:
        return
    nodes = dofs % run.user_grid.N
    dropped = ~on & active[dofs] & (values != 0.) & np.isin(nodes,
                                                            nodes[on])
    if not dropped.any():
        return
    run.warned.add("prescribed bodies")
    i = int(np.flatnonzero(dropped)[0])
    fields = np.unique(dofs[nodes == nodes[i]] // run.user_grid.N)
    bodies = [np.flatnonzero(np.isin(run.body_field, [k])).tolist()
              for k in fields]
    logger.warning(
        "step %d: prescribed motion moves grid nodes that carry the "
        "material of bodies in contact, e.g. at %s (the bodies %s, on "
        "fields of their own): it moves a body's copy of a node where the "
        "body's material is nearest the node, which can drag a body beside "
        "the pushed one or drop the motion of a pushed body that settles "
        "below the nodes; name the bodies it moves: Prescribed(..., "
        "bodies=[...])", step, run.user_grid.doflocs[:, nodes[i]].tolist(),
        " and ".join(map(str, bodies)))


def held_motion(run, op, points, s_old: float, s_new: float,
                step: int) -> HeldMotion:
    """The supports, prescribed increments and rigid bodies' motion of a
    step from load scale ``s_old`` to ``s_new``, checked (a term's
    ``held_supports`` chooses the supports' and the prescribed motion's
    DOFs that hold: a contact between bodies holds a field's copy of a
    node only where its bodies lie on the support or the moved nodes,
    :meth:`~skfem_mpm.solve.body_contact.BodyContact.held_supports`; a
    rigid body drives the nodes of its points' cells, on its own field
    only): prescribed motion
    that lost its material and rigid bodies driving held DOFs otherwise
    are refused (:class:`~skfem_mpm.errors.PrescribedMotionError`)."""
    du = np.zeros(op.N)
    # the terms that choose (the protocol's default keeps every DOF: no
    # mask and no positions built for it, 4 us of a one-step run's 9)
    choosing = [term for term in run.terms if type(term).held_supports
                is not GridTerm.held_supports]
    if choosing:
        active = np.zeros(op.N, dtype=bool)
        active[op.active_dofs] = True

    def held(dofs, **within):
        for term in choosing:
            dofs = term.held_supports(points, dofs,
                                      run.grid.doflocs[:, dofs], run.grid.N,
                                      active, **within)
        return dofs
    fixed = held(run.D)
    driven = np.zeros(0, dtype=np.int64)
    if run.prescribed is not None:
        dofs, values = prescribed_increments(run, s_old, s_new, step)
        if run.prescribed_fields is not None:      # the bodies named
            on = np.isin(dofs // run.user_grid.N, run.prescribed_fields)
        else:
            # a body's copy moved only where its material lies on the
            # nodes (the supports' rule, touching): not a body beside the
            # one pushed
            on = np.isin(dofs, held(dofs, within=MOVED_NEAREST))
            if choosing:
                warn_chosen_copies(run, dofs, values, on, active, step)
        dofs, values = dofs[on], values[on]
        du[dofs] = values
        fixed = np.union1d(fixed, dofs)
        driven = dofs[values != 0.]
        check_prescribed_motion(run, op, dofs, values, step)
        warn_faces_left(run, step, s_old, s_new)
    rigid_dofs = []
    for k, rigid in enumerate(run.rigid_bodies):
        dofs = rigid.dofs(run.grid.dofs.element_dofs, op.point_elements,
                          points)
        values = rigid.increment(s_old, s_new)[dofs % run.dim]
        clash = np.isin(dofs, fixed) & (du[dofs] != values)
        if clash.any():
            raise PrescribedMotionError(
                "step {}: rigid_bodies[{}] (body {}) drives {} grid DOF(s) "
                "that a support or another prescribed motion holds "
                "otherwise, e.g. component {} at {}".format(
                    step, k, rigid.body, int(clash.sum()),
                    int(dofs[clash][0] % run.dim),
                    run.grid.doflocs[:, dofs[clash][0]].tolist()))
        du[dofs] = values
        fixed = np.union1d(fixed, dofs)
        driven = np.union1d(driven, dofs[values != 0.])
        rigid_dofs.append(dofs)
    return HeldMotion(fixed, du, driven, rigid_dofs)


def unheld_rigid_modes(run, op, fixed: ndarray, step: int):
    """The :class:`~skfem_mpm.errors.SingularSystemError` naming a
    rigid-body mode of a connected piece of the active grid that the
    ``fixed`` DOFs leave free, or ``None``."""
    kernels = getattr(run.method, "kernels", "auto")
    # standard MPM's graph, the chains of the active elements' nodes: its
    # components without the graph where the compiled passes serve
    element_dofs = getattr(op, "element_dofs", None) \
        if op.connectivity_from_elements else None
    labels = None if element_dofs is None else element_labels(
        element_dofs, run.dim, op.N // run.dim, kernels)
    if labels is None:
        labels = component_labels(op.adjacency(), kernels)
    try:
        check_rigid_body_modes(labels, run.grid.doflocs[:, ::run.dim],
                               op.active_dofs, fixed, run.dim, kernels, step)
    except SingularSystemError as err:
        return err
    return None


def check_held(run, op, fixed: ndarray, step: int, by_terms: bool = False):
    """Missing supports (rigid-body modes of the active grid) refused,
    unless a term's inertia holds the free body; checked again only when
    the active cells or the held DOFs change (``run.cache.held``).
    ``by_terms``: some of ``fixed`` are a term's (a contact's pairs
    touching at the step's start), which the error then names."""
    if any(term.holds_free_body for term in run.terms):
        return
    held = (op.elements.tobytes(), fixed.tobytes()) if \
        op.connectivity_from_elements else None
    if held is None or held != run.cache.held:
        err = unheld_rigid_modes(run, op, fixed, step)
        if err is not None:
            if not by_terms:
                raise err
            raise SingularSystemError(
                "{}; contact (with an obstacle or between bodies) holds a "
                "body only where its pairs touch at the step's start, and a "
                "smooth one only along its normals: nothing may hold the "
                "body along that direction, or it has parted from what held "
                "it (a load beyond what the contact carries), or one pair "
                "per grid node did not follow both faces at a body's corner "
                "(docs/contact.md)".format(err)) from err
        run.cache.held = held
