"""Contact between deformable bodies: a grid term on separate fields.

A :class:`Contact` puts its two bodies on separate velocity fields
(:mod:`skfem_mpm.methods.fields`), so they no longer share the grid's
nodes; this term couples the fields where the materials' surfaces meet.

Where both fields are present (a grid node supported by points of both
bodies), the node's normal ``n`` is the direction along which the two
bodies' domain corners near the node lie farthest apart (the separating
axis), among the line between the centroids of their points near the
node (weighted by their shape values), each body's direction from its
centroid to the node, and the grid axes, oriented from the first body to
the second; only the first body's corners that face the second's across
``n`` count (not those on a face along ``n`` beside it, as soil beside a
pile's tip).  Where the bodies touch along another grid axis too (a
body's corner in a notch of the other: a pile's tip), the node has a
normal per face.
The second body's surface there is its corner lowest along ``n``
nearest the node, the first body's the facing corner highest along
``n`` nearest that one.  The two corners make a *pair* (one per place
of either corner and normal) with the gap

    g = n . (x_B - x_A),

positive while the surfaces are apart, so bodies in one cell do not
interact until their domains meet.  The corners move with their fields,
``x + N(x) du`` with the grid element's shape functions of the cell a
corner lies in where its point's domain holds material there (a sliver
past a grid line), else of the cell holding the point (exact for any
linear field, and reaching the nodes the domains' internal force
reaches), so a uniform stress crosses the interface exactly; with GIMP
on linear cells at a smooth contact, a corner on its domain's side
facing the other body across a grid axis moves with GIMP's weights of
that side (:meth:`BodyContact.rows`).
Pressure and friction per pair are those
of :mod:`skfem_mpm.solve.contact` (the pressure of an augmented
Lagrangian ``p = max(0, lambda - kappa g)``, a Coulomb return map on the
relative tangential increment ``s``, ``"rough"``: no slip) with the
consistent tangent; the first body receives ``-(p n + tau)``.  After
Newton converges, :meth:`StepBodyContact.settle` looks for pairs the
bodies, moved by the converged increment, form beyond the step's and
penetrate (they join), checks each pair's penetration, the gap of a
pair pressed while apart, and a sticking pair's slip against the
tolerance and, where larger, updates the multipliers (augmented
Lagrangian) and solves again: the converged state has no penetration, no
pressure across a gap and no stick slip beyond the tolerance, and the
penalty's force on the penetration is within the tolerance of the
largest pair's.  A pair pressed at the last step's end starts from the
pressure, gap and friction traction it ended with at the second body's
corner (point state ``contact_body<k>_p<a><c>``, ``_g<a><c>`` and
``_t<a><c>``: contact k, component a, corner c; the vectors ``p n``,
``g n`` and the traction summed over the pairs at the corner's place,
each pair taking its own normal's part), so a sticking interface keeps
its shear, and its pressure ahead by the rate it rose at in the last
step (``_r<a><c>``, per unit of the load factor; zero after a step
whose pairs changed, and not in a run's first step), a Coulomb pair's
friction traction scaled alike; a node's pair on another corner than
the last step's (a body sliding along the other past the grid) starts
from the state its node's last pair left, at its own gap
(:meth:`StepBodyContact.heirs`); any other pair that penetrates at a
step's start is closed there (the corners of deformed domains, moved
through each point's own gradient, are not quite where the grid field
moved the last step's pairs).  The penalty ``kappa``
is the contact's ``penalty`` times the softer body's P-wave modulus.
In small strain the domains follow the displacement gradient the term
keeps (point state ``contact_body_grad<a><b>``); with B-splines each
domain corner is moved by the splines' field there, as the pairs move it
(``contact_body_corner<a><c>``); checkpoints carry all of this state.
"""
import logging
from typing import Optional
from weakref import WeakKeyDictionary, ref

import numpy as np
from numpy import ndarray
from scipy.sparse import csr_matrix, diags, identity, kron, vstack
from scipy.spatial import cKDTree

from ..errors import (InvalidInputError, PointsOutsideGridError,
                      StepTooLongError, check_real)
from ..methods.fields import body_fields
from ..protocols import GridTerm
from ..quadrature.locate import point_locator
from .contact import (CellValues, block_diagonal, check_carried_corners,
                      corner_signs, coulomb, friction_hint, rough_apart_join,
                      side_rows, spline_rows)
from .contact_pairs import FACING, HELD, PairFinder, overlapping
from .dynamics import operator_slivers, value_matrix
from .problem import SLIVER_SUPPORT

logger = logging.getLogger(__name__)

#: the cells deep a pair may start before it is warned of as a misread
#: (:meth:`StepBodyContact.add`)
MISREAD = .25

__all__ = ["Contact", "check_contacts", "contact_interfaces",
           "interface_count", "swapped_interfaces", "BodyContact",
           "body_contact_state_names"]


class Contact:
    """An interface between two bodies that may slide, separate and
    touch again (bodies without one are glued where they meet).

    Bodies glued to each other share a grid field, and a contact is
    between the two groups its bodies lie in: they are apart where
    every pair of their bodies has a contact (undeclared pairs are
    glued, whether they meet or not), and meet at one interface, whose
    contacts must have the same friction, tolerance and penalty (else
    refused).  A pile (body 1) with a cap (body 2) glued to it above
    soil (body 0): ``Contact(0, 1, friction=f)`` and ``Contact(0, 2,
    friction=f)``, though the cap never reaches the soil.  Each contact
    reports the force of the interface's pairs, each pair's shared by
    the bodies that touch the other group nearest its corners (two
    blocks glued side by side on a third each report the load on their
    own top, a cap above the soil nothing;
    :meth:`BodyContact.declared_forces`, ``docs/contact.md``).

    Parameters
    ----------
    first, second
        The bodies: indices of ``MaterialPoints.body``, or names of a
        scene's bodies (resolved by the scene), in either order: the
        interface pairs the corners of its smaller side (by the points'
        initial volumes) with the other's facing corners
        (:func:`smaller_second`); the reported force is the first's on
        the second.
    friction
        ``0.`` (smooth, the default), a Coulomb coefficient, or
        ``"rough"`` (no slip while in contact, free to separate).
    name
        The contact's name in outputs (``"<first>-<second>"`` by default).
    penalty
        The stiffness of a pair of corners, in units of the softer
        body's P-wave modulus (its largest ``lam + 2 mu``; times the cell
        size in 3D; default 10): it sets how many augmented-Lagrangian
        rounds a step takes, not the converged answer (within the
        tolerance).  Unlike an obstacle's it is not divided by the cell
        size, and it follows the softer body: the stiffer body's made a
        pile 80 times stiffer than its soil a constraint whose pairs
        opened and closed in turn without end.
    tolerance
        Three limits at a converged step (default 1e-3): the penetration
        of every pair (and the gap of a pair still pressed) and the slip
        of every sticking pair, in cells; and the penalty's pressure on
        the deepest penetration, relative to the largest pair's pressure
        (the multipliers settled; where a round no longer closes the
        penetration, the grid's forces of the penalty's pressures
        relative to the pairs': :func:`unsettled`).

    Examples
    --------
    >>> from skfem_mpm import Contact
    >>> Contact(0, 1, friction=.3)
    Contact(0, 1, friction=0.3)

    """

    def __init__(self, first, second, friction=0., name: Optional[str] = None,
                 penalty: float = 10., tolerance: float = 1e-3):
        for which, body in (("first", first), ("second", second)):
            if not isinstance(body, (str, int, np.integer)) or \
                    isinstance(body, bool) or \
                    not isinstance(body, str) and body < 0:
                # (a negative index was named '0--1' before it was
                # refused as a body that does not exist: a user trial)
                raise InvalidInputError(
                    "Contact {} body must be a body index (>= 0) or "
                    "name, got {!r}".format(which, int(body) if isinstance(
                        body, np.integer) else body))
        self.first, self.second = first, second
        if isinstance(friction, str):
            if friction != "rough":
                raise InvalidInputError(
                    "Contact friction must be a coefficient >= 0 or "
                    "'rough'{}, got {!r}".format(
                        " (bodies that stay tied are glued: declare no "
                        "contact)" if friction == "tied" else "", friction))
            self.friction = friction
        else:
            self.friction = check_real("Contact friction", friction)
            if not 0 <= self.friction < np.inf:
                raise InvalidInputError("Contact friction must be finite "
                                        "and >= 0, got {}".format(friction))
        self.penalty = check_real("Contact penalty", penalty)
        self.tolerance = check_real("Contact tolerance", tolerance)
        if not (0 < self.penalty < np.inf and 0 < self.tolerance < 1):
            raise InvalidInputError(
                "Contact penalty must be > 0 and tolerance in (0, 1) cells, "
                "got {} and {}".format(penalty, tolerance))
        self.name = name if name is not None else "{}-{}".format(first,
                                                                 second)

    def __repr__(self):
        return "Contact({!r}, {!r}, friction={!r})".format(
            self.first, self.second, self.friction)


def check_contacts(contacts, nbodies: int, names=None):
    """The contacts with their bodies as indices, and the field of each
    body; refused before any work: a contact of bodies that do not exist,
    of a body with itself, a pair declared twice, two names alike, a
    pair that cannot be apart (glued through a third body), or two
    contacts between the same two groups of glued bodies (one interface:
    :func:`contact_interfaces`) whose friction, tolerance or penalty
    differ (compared at single precision: a friction of 0.3 given as a
    ``numpy.float32`` on one contact and a float on the other was refused
    as two, a user trial), and ``contacts`` not a list of them.

    >>> check_contacts(Contact(0, 1), 2)    # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: contacts must be a list ... pass...
    """
    if isinstance(contacts, Contact):
        raise InvalidInputError(
            "contacts must be a list of Contact items, got one Contact: "
            "pass contacts=[{!r}]".format(contacts))
    try:
        contacts = list(contacts)
    except TypeError:
        raise InvalidInputError(
            "contacts must be a list of Contact items, got {}".format(
                type(contacts).__name__)) from None
    checked = []
    for contact in contacts:
        if not isinstance(contact, Contact):
            raise InvalidInputError("contacts must be Contact items, got "
                                    "{}".format(type(contact).__name__))
        bodies = []
        for body in (contact.first, contact.second):
            if isinstance(body, str):
                if names is None or body not in names:
                    raise InvalidInputError(
                        "contact {!r}: no body named {!r}{}".format(
                            contact.name, body, "; bodies: {}".format(
                                list(names)) if names else " (name bodies "
                            "in a scene file, or give body indices)"))
                body = list(names).index(body)
            if not 0 <= body < nbodies:
                raise InvalidInputError(
                    "contact {!r}: body {} does not exist (the points hold "
                    "bodies 0 to {})".format(contact.name, body, nbodies - 1))
            bodies.append(int(body))
        if bodies[0] == bodies[1]:
            raise InvalidInputError("contact {!r}: a body cannot be in "
                                    "contact with itself".format(contact.name))
        checked.append((bodies[0], bodies[1], contact))
    pairs = [frozenset(c[:2]) for c in checked]
    for j, pair in enumerate(pairs):
        if pair in pairs[:j]:
            i = pairs.index(pair)
            raise InvalidInputError(
                "contacts {!r} and {!r} are both between bodies {} and {}: "
                "a pair of bodies has one contact".format(
                    checked[i][2].name, checked[j][2].name,
                    *sorted(pair)))
    given = [c[2].name for c in checked]
    if len(set(given)) < len(given):
        raise InvalidInputError("contact names must differ, got {}".format(
            given))
    field = body_fields([c[:2] for c in checked], nbodies)
    between = {}
    for a, b, contact in checked:
        key = frozenset((int(field[a]), int(field[b])))
        if key not in between:
            between[key] = contact
            continue
        other = between[key]
        differ = [(what, getattr(other, what), getattr(contact, what))
                  for what in ("friction", "tolerance", "penalty")
                  if not same_setting(getattr(other, what),
                                      getattr(contact, what))]
        if differ:
            groups = [np.flatnonzero(field == f).tolist() for f in
                      sorted(key)]
            raise InvalidInputError(
                "contacts {!r} and {!r} join the same two groups of glued "
                "bodies ({} and {}) with different {}: the bodies of a "
                "group share one grid field, so the two groups meet at one "
                "interface, and it has one friction, tolerance and "
                "penalty; give the contacts the same ones (a pile and its "
                "cap, glued, on the soil: the same friction), or declare a "
                "contact between the bodies of a group too where they must "
                "not be glued".format(
                    other.name, contact.name, groups[0], groups[1],
                    ", ".join("{} ({!r} and {!r})".format(*d)
                              for d in differ)))
    return checked, field


def same_setting(a, b) -> bool:
    """Whether two contacts' friction, tolerance or penalty ``a`` and
    ``b`` are the same: equal strings, or numbers equal at single
    precision (what a ``numpy.float32`` holds).

    >>> same_setting(float(np.float32(.3)), .3), same_setting(.3, .30001)
    (True, False)
    >>> same_setting("rough", .3)
    False
    """
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    return bool(np.float32(a) == np.float32(b))


def contact_interfaces(checked, field: ndarray) -> tuple:
    """The interfaces of the contacts ``checked`` (``(first, second,
    Contact)``, bodies as indices; :func:`check_contacts`) between the
    fields ``field`` of the bodies: one per pair of fields, as
    ``(first, second, Contact)`` (the first of its contacts; where it
    has several, one named by theirs joined with ``+``, their friction,
    tolerance and penalty), and per interface its contacts as ``(index,
    first, second, sign)``: ``sign`` -1 where the contact's first body
    lies on the interface's second field.

    >>> import numpy as np
    >>> from skfem_mpm import Contact
    >>> found, members = contact_interfaces(
    ...     [(0, 1, Contact(0, 1)), (2, 0, Contact(2, 0))],
    ...     np.array([0, 1, 1]))
    >>> found
    [(0, 1, Contact(0, 1, friction=0.0))]
    >>> found[0][2].name, members
    ('0-1+2-0', [[(0, 0, 1, 1), (1, 2, 0, -1)]])
    """
    keys, found, members = [], [], []
    for j, (a, b, contact) in enumerate(checked):
        key = frozenset((int(field[a]), int(field[b])))
        if key not in keys:
            keys.append(key)
            found.append((a, b, contact))
            members.append([])
        k = keys.index(key)
        first = found[k][0]
        members[k].append((j, a, b, 1 if field[a] == field[first] else -1))
    for k, (a, b, contact) in enumerate(found):
        if len(members[k]) > 1:
            found[k] = (a, b, Contact(
                a, b, friction=contact.friction, name="+".join(
                    checked[j][2].name for j, *_ in members[k]),
                penalty=contact.penalty, tolerance=contact.tolerance))
    return found, members


def smaller_second(found: list, members: list, field: ndarray,
                   volume: ndarray) -> None:
    """Orders each interface of ``found`` and ``members``
    (:func:`contact_interfaces`), in place, so that its second field
    is the one of smaller volume (``volume``: per field, the points'
    initial volumes summed; alike, the declared order): the pairs are
    the second body's corners, each with the first body's corner facing
    it, and a body's corners in a notch of the other (a pile's tip)
    are held only as the second.  Declared with the soil second, a
    smooth pile (E = 1e8, 2 cells wide on grid lines, its tip at y =
    0.5 in soil of E = 1e6, h = 0.125, 2 x 2 points, a traction on its
    cap) kept one pair under its tip, which passed 6 mm into the soil,
    and settled 14.10 mm (uGIMP; MPM 16.72) where with the pile second
    it settled 7.76 (7.88).  The signs of ``members`` follow, so each
    contact's force stays that of its declared first body on its
    second.

    >>> import numpy as np
    >>> from skfem_mpm import Contact
    >>> found, members = contact_interfaces([(1, 0, Contact(1, 0))],
    ...                                     np.array([0, 1]))
    >>> smaller_second(found, members, np.array([0, 1]),
    ...                np.array([4., 1.]))
    >>> found, members
    ([(0, 1, Contact(0, 1, friction=0.0))], [[(0, 1, 0, -1)]])
    >>> found[0][2].name
    '1-0'
    """
    for k, (a, b, contact) in enumerate(found):
        if volume[field[a]] < volume[field[b]] * (1 - 1e-9):
            found[k] = (b, a, Contact(    # a scene's names kept
                contact.second, contact.first, friction=contact.friction,
                name=contact.name,
                penalty=contact.penalty, tolerance=contact.tolerance))
            members[k] = [(j, c, d, -sign)
                          for j, c, d, sign in members[k]]


def swapped_interfaces(contacts, nbodies: int, names, body: ndarray,
                       volume: ndarray) -> list:
    """The names of the interfaces of ``contacts`` (bodies ``names``, or
    indices of ``nbodies``) that a run pairs the other way round than
    declared (:func:`smaller_second`: their declared second side holds
    more of the points' initial ``volume``, ``body`` their bodies): a
    contact's point state lies on the other side's points than before
    2026-11-30, when the declared second was paired.

    >>> import numpy as np
    >>> from skfem_mpm import Contact
    >>> body, volume = np.array([0, 1, 1]), np.ones(3)
    >>> swapped_interfaces([Contact(0, 1)], 2, None, body, volume)
    ['0-1']
    >>> swapped_interfaces([Contact(1, 0)], 2, None, body, volume)
    []
    """
    checked, field = check_contacts(contacts, nbodies, names)
    found, members = contact_interfaces(checked, field)
    declared = [a for a, _, _ in found]
    summed = np.zeros(field.max() + 1)
    np.add.at(summed, field[body], volume)
    smaller_second(found, members, field, summed)
    return [contact.name for (a, _, contact), first in zip(found, declared)
            if a != first]


def interface_count(contacts, nbodies: int, names=None) -> int:
    """The interfaces of ``contacts`` (:func:`contact_interfaces`), whose
    point state a run keeps (:func:`body_contact_state_names`)."""
    if not contacts:
        return 0
    return len(contact_interfaces(*check_contacts(contacts, nbodies,
                                                  names))[0])


def gradient_state(dim: int) -> list:
    """Small strain: the point-state names of the displacement gradient
    the contact keeps, ``[[name_ab]]``."""
    return [["contact_body_grad{}{}".format(a, b) for b in range(dim)]
            for a in range(dim)]


def corner_state(dim: int) -> list:
    """B-splines: the point-state names of the domain corners' offsets
    from their point the contact keeps, per component a per corner c,
    ``[[contact_body_corner<a><c>]]``."""
    return [["contact_body_corner{}{}".format(a, c) for c in range(2 ** dim)]
            for a in range(dim)]


def traction_state(k: int, dim: int) -> list:
    """The point-state names of interface ``k``'s state
    (:func:`contact_interfaces`; one per contact where no two join the
    same groups of glued bodies) at the second body's domain corners,
    per component a per corner c, summed over the pairs at the corner's
    place (a body's corner in a notch of the other
    has a pair per face, each along its own normal): the pressure vector
    ``p n`` (``contact_body<k>_p<a><c>``), the gap vector ``g n`` where
    pressed (``_g<a><c>``), the friction traction (``_t<a><c>``) and the
    pressure's rate over the step, its change per unit of the load
    factor (or of ``t / duration`` in dynamics) along the normal
    (``_r<a><c>``)."""
    return [["contact_body{}_{}{}{}".format(k, q, a, c)
             for c in range(2 ** dim)] for q in "pgtr" for a in range(dim)]


def carried(state: dict, k: int, corner: ndarray, normal: ndarray,
            n: int, place: ndarray):
    """What contact ``k``'s pairs at the second body's corners
    ``corner`` (``c n + p``) with normals ``normal`` (dim, m) start
    from, the state the last step ended with there: the pressure, the
    gap and the pressure's rate along each normal (m,), and the friction
    traction (dim, m) in each pair's tangent plane, the corner's shared
    among the pairs at one ``place`` (dim, m; integers) by the
    components their tangent planes hold (a square pile's vertical edge
    in 3D: its x and y faces' pairs start from half its vertical
    friction each)."""
    dim = normal.shape[0]
    rows = np.array([corner_values(state, row, corner, n)
                     for row in traction_state(k, dim)])
    P, G, T, R = (rows[q * dim:(q + 1) * dim] for q in range(4))
    group = np.unique(place, axis=1, return_inverse=True)[1].ravel()
    holds = 1. - normal ** 2
    total = np.zeros((dim, group.max(initial=-1) + 1))
    np.add.at(total.T, group, holds.T)
    tau = T * holds / np.maximum(total[:, group], 1e-300)
    return ((normal * P).sum(axis=0), (normal * G).sum(axis=0),
            tau - (normal * tau).sum(axis=0) * normal,
            (normal * R).sum(axis=0))


def corner_values(state: dict, row: list, corner: ndarray,
                  n: int) -> ndarray:
    """The values at the corners ``c n + p`` (``corner``) of the point
    state named per corner c in ``row``, read corner by corner (not a
    copy of every point's)."""
    out = np.empty(corner.size)
    c, p = np.divmod(corner, n)
    for k, name in enumerate(row):
        at = c == k
        out[at] = state[name][p[at]]
    return out


def body_contact_state_names(contacts: int, dim: int, finite: bool,
                             splines: bool = False) -> list:
    """The point-state names a run with ``contacts`` interfaces between
    bodies keeps (:func:`interface_count`: contacts between the same two
    groups of glued bodies make one), for a checkpoint's check
    (``splines``: the method's weights are B-splines)."""
    names = [name for k in range(contacts) for rows in traction_state(k, dim)
             for name in rows]
    if contacts and splines:
        names += [name for row in corner_state(dim) for name in row]
    elif contacts and not finite:
        names += [name for row in gradient_state(dim) for name in row]
    return names


def facing(x: ndarray, half: ndarray, d: int, sign: int, other: ndarray,
           extent: float, tree: Optional[cKDTree] = None) -> ndarray:
    """Which of the domains centred at ``x`` (dim, m), of half-widths
    ``half`` (dim,), face a point of ``other`` (dim, q) across their side
    ``sign`` along axis ``d``: a centre of ``other`` beyond the side
    (within ``extent``), inside the side's extent across ``d``.  ``tree``:
    :func:`facing_tree` of ``other`` for ``half``, ``d`` and ``extent``
    (both signs search it; else built here).

    >>> import numpy as np
    >>> x = np.array([[.5, 1.5], [.5, .5]])        # two domains in a row
    >>> other = np.array([[.5, 3.], [-1., .5]])     # below one, and right
    >>> facing(x, np.array([.5, .5]), 1, -1, other, 10.).tolist()
    [True, False]
    >>> facing(x, np.array([.5, .5]), 0, 1, other, 10.).tolist()
    [True, True]
    >>> facing(x, np.array([.5, .5]), 1, 1, other, 10.).tolist()
    [False, False]
    """
    if not x.shape[1] or not other.shape[1]:
        return np.zeros(x.shape[1], dtype=bool)
    scale = np.array(half, dtype=float)
    scale[d] = extent / 2       # along d: the centre's distance beyond
    centre = x.copy()
    centre[d] += sign * (half[d] + extent / 2)
    if tree is None:
        tree = facing_tree(half, d, other, extent)
    return tree.query_ball_point((centre / scale[:, None]).T,
                                 1. + 1e-9, p=np.inf,
                                 return_length=True) > 0


def facing_tree(half: ndarray, d: int, other: ndarray,
                extent: float) -> cKDTree:
    """The tree of the points ``other`` that :func:`facing` searches
    along axis ``d`` (both signs alike: a body's sides took a tree each,
    0.1 s of a run's start at 1e5 points), split at the midpoints of its
    boxes (medians, of a lattice's many equal coordinates: 1.7 times
    longer to build)."""
    scale = np.array(half, dtype=float)
    scale[d] = extent / 2
    return cKDTree((other / scale[:, None]).T, balanced_tree=False)


def near_box(other: ndarray, x: ndarray, margin: ndarray) -> ndarray:
    """Which of the points ``other`` (dim, q) lie within ``margin``
    (dim,; ``inf`` along an axis: any) of the box of the points ``x``
    (dim, m) along every axis (none where ``x`` has none).

    >>> x = np.array([[0., 1.], [0., 0.]])
    >>> other = np.array([[-.5, 1.5, .5], [0., 0., 2.]])
    >>> near_box(other, x, np.array([.5, 1.])).tolist()
    [True, True, False]
    """
    if not x.shape[1]:
        return np.zeros(other.shape[1], dtype=bool)
    return np.all((other >= (x.min(axis=1) - margin)[:, None])
                  & (other <= (x.max(axis=1) + margin)[:, None]), axis=0)


class BodyContact(GridTerm):
    """Contact between the run's bodies (a grid term).

    Parameters
    ----------
    contacts
        ``(first, second, Contact)`` from :func:`check_contacts`: the
        term acts per interface between two fields
        (:func:`contact_interfaces`, :attr:`contacts`), and reports the
        force per contact (:attr:`members`).
    field
        The field of each body.
    mesh, elem
        The extended mesh of the run's fields and the scalar element.
    vertices
        The vertices of one field (the grid's).
    cell_size
        The grid's cell size.
    material
        The run's material at the points (``lam`` and ``mu`` per point or
        one), whose P-wave modulus scales each contact's penalty.
    domain0
        The points' initial domain half-lengths (dim, n), or ``None``.
    finite
        Finite deformation (the domains follow ``F``).
    counters
        ``contact_updates`` counts the augmented-Lagrangian updates.
    weights
        ``weights(x, idx) -> operator``: the method's weights on the
        fields at the domain corners ``x`` of points ``idx`` (B-splines),
        or ``None``: the grid element's.
    cells
        The cells of one field (the grid's).
    gimp
        GIMP's closed-form weights on one field's grid (linear elements;
        :func:`~skfem_mpm.solve.contact.linear_gimp`): the corners of a
        pair along a grid axis on the side of their domain facing the
        other body move with them (:meth:`rows`); or ``None``: with the
        grid element's shape functions.
    locate
        :func:`~skfem_mpm.quadrature.locate.point_locator` of one field's
        grid with its defaults (the run's own: a second took 20 ms of a
        run's start at 1e5 points), or ``None``: built at the corners'
        first location (:meth:`corner_cells`).
    """

    def __init__(self, contacts, field: ndarray, mesh, elem, vertices: int,
                 cell_size: float, material, domain0, finite: bool,
                 counters: dict, weights=None, cells: int = 0, gimp=None,
                 locate=None):
        #: the interfaces (one per pair of fields) and each one's contacts
        self.contacts, self.members = contact_interfaces(contacts, field)
        self.declared = contacts
        self.field = field
        self.nv = vertices
        self.dim = mesh.dim()
        self.h, self.domain0, self.finite = cell_size, domain0, finite
        self.material = material
        self.tol = [c.tolerance * cell_size for _, _, c in self.contacts]
        self.cell_values = CellValues(mesh, elem)
        self.weights = weights
        self.cells = cells
        self.gimp = gimp if gimp is not None and gimp.N == vertices \
            else None
        self.geometry, self.supports = WeakKeyDictionary(), \
            WeakKeyDictionary()
        self.kept_corners = None     # :meth:`corners`, the last
        self.grid_locate = locate    # :meth:`corner_cells`
        self.interfaces = WeakKeyDictionary()    # :meth:`interface`
        self.node_tree = None        # the grid's nodes: StepBodyContact.heirs
        self.finder = PairFinder(self.contacts, field, mesh, vertices,
                                 cell_size,
                                 columns=weights is not None)
        counters.setdefault("contact_updates", 0)
        if weights is not None:
            counters.setdefault("contact_corners_reset", 0)
        #: the grid's lines per axis (:meth:`warn_sides_inside_cells`)
        self.lines = [np.unique(mesh.p[d]) for d in range(self.dim)]
        #: per body, the resultant of its body force, point forces and
        #: surface loads at the last step tried (:meth:`sliding_load_hint`), and whether
        #: its contact alone may hold it (:meth:`held_by_contact_alone`)
        self.loads, self.alone = None, None
        #: the contacts whose pairs were told to start deep
        #: (:meth:`StepBodyContact.add`: once a run, not every step)
        self.told_deep = set()

    def warn_sides_inside_cells(self, points, half: ndarray) -> None:
        """A warning where a body in contact touches a body it is in
        contact with on both its sides across an axis (faces of its
        points' domains, ``half`` their half-widths, with no domain of the
        body beside them), one of them inside a grid cell: such bodies
        may lean and settle by the grid.
        Judged on the points' initial positions, so a run resumed where
        its bodies have moved says what its first invocation said (a user
        trial's resumed run warned where the first had not).  Given on
        every contact run, it told a user whose bodies' sides all
        lay on grid lines the same; given for every side inside a cell,
        it told a user whose block lay on a slab of the grid's width, its
        sides inside cells facing nothing (user trials); given for any
        side inside a cell that faced the other body, it told users whose
        bodies met on a flat interface inside a cell, or lay apart, the
        same: only the sides of a body held between the other's across
        an axis, both touching it (a pile in its soil), count, and both
        the same group of glued bodies (one field: a block between two
        others, on flat interfaces inside cells, was warned)."""
        dim, inside = self.dim, 0
        stairs = []               # (body, partner bodies, axis, levels)
        partners = {}
        for a, b, _ in self.declared:
            partners.setdefault(a, set()).add(b)
            partners.setdefault(b, set()).add(a)
        for k, others in partners.items():
            sel = np.flatnonzero(points.body == k)
            x, w = points.x0.take(sel, axis=1), half.take(sel, axis=1)
            if not np.allclose(w, w[:, :1]):    # not one lattice: say so
                inside = 1
                break
            step = 2 * w[:, :1]
            q = np.rint((x - x.min(axis=1, keepdims=True)) / step).astype(
                np.int64) + 1
            shape = tuple(q.max(axis=1) + 2)
            keys = np.ravel_multi_index(tuple(q), shape)
            on = np.isin(points.body, list(others))
            partner = points.x0.compress(on, axis=1)
            fields = self.field[points.body]
            groups = {f: points.x0.compress(on & (fields == f), axis=1)
                      for f in np.unique(self.field[list(others)])}
            for d in range(dim):
                lines = self.lines[d]
                sides = []
                for sign in (-1, 1):
                    moved = q.copy()
                    moved[d] += sign
                    sides.append(~np.isin(np.ravel_multi_index(
                        tuple(moved), shape), keys))
                # the trees of the partners' points that may face the
                # sides, of those in a box round the sides' domains, twice
                # the width facing() looks within (along the sides of a
                # stack a row: trees of the whole partners took 30 ms of a
                # run's start at 1e5 points, twelve of them 0.1 s)
                margin = 2 * w[:, 0]
                margin[d] = np.inf
                across = partner.compress(near_box(
                    partner, x[:, sides[0] | sides[1]], margin), axis=1)
                tree = facing_tree(w[:, 0], d, across, lines[-1] - lines[0]) \
                    if across.shape[1] else None
                # the sides that touch a partner (its domains' centres
                # within their half-width of the face), per sign: a body
                # held between the other's across the axis (a pile in its
                # soil) leans and settles by the grid where one of them
                # lies inside a cell; a flat interface inside a cell, or
                # bodies apart, do not (cpGIMP, a block on a slab, its
                # bottom inside a cell: settled within 1% of the refined
                # grid's, glued 5%; user trials)
                reach = half[d, on].max(initial=0.) + FACING * self.h
                margin[d] = w[d, 0] + 2 * reach
                # per group of glued partners (one field): a body between
                # two others, flat interfaces inside cells, leans on none
                # (the review: three stacked blocks were warned)
                touch = {f: [False, False] for f in groups}
                off_lines = dict.fromkeys(groups, 0)
                for sign, side in zip((-1, 1), sides):
                    face = x[d, side] + sign * w[d, side]
                    faces = facing(x[:, side], w[:, 0], d, sign, across,
                                   lines[-1] - lines[0], tree)
                    levels = np.unique(np.rint(face[faces] / step[d]))
                    # consecutive levels, one domain apart: a staircase,
                    # not footings at several depths (the review)
                    steps = np.flatnonzero(np.diff(np.r_[0, np.diff(
                        levels) == 1, 0].astype(int)))
                    flight = int((steps[1::2] - steps[::2]).max(
                        initial=0)) + 1
                    if flight >= STAIRS:
                        stairs.append((k, sorted(others), d, flight))
                    at = np.clip(np.searchsorted(lines, face), 1,
                                 lines.size - 1)
                    off = np.minimum(np.abs(face - lines[at - 1]),
                                     np.abs(face - lines[at]))
                    for f, group in groups.items():
                        meets = facing(x[:, side], w[:, 0], d, sign,
                                       group.compress(near_box(
                                           group, x[:, side], margin),
                                           axis=1), reach)
                        touch[f][sign > 0] = bool(meets.any())
                        off_lines[f] += int(np.count_nonzero(
                            meets & (off > 1e-9 * self.h)))
                inside += sum(off_lines[f] for f in groups
                              if all(touch[f]))
        for k, others, d, levels in stairs[:1]:
            logger.warning(
                "contact between bodies: body %d's surface facing body %s "
                "is a staircase across axis %d (its domains' faces at %d "
                "consecutive levels: an inclined or curved surface seeded on "
                "the points' lattice): contact acts on the steps' faces, so "
                "the bodies do not slide along the slope (a frictionless "
                "block on a body's 20 degree slope slid 3%% of g sin(theta) "
                "t^2 / 2) and the pressure follows the steps; for sliding, "
                "tilt gravity so that the interface lies along grid lines, or "
                "make the inclined body an Obstacle polygon "
                "(docs/contact.md)", k, ", ".join(map(str, others)), d,
                levels)
        if inside:
            logger.warning(
                "contact between bodies: a body whose sides meet the other "
                "inside grid cells may lean and settle by the grid (a pile "
                "with one side on a grid line and the other inside a cell, "
                "any method: sideways by up to 73% of its settlement; GIMP "
                "piles half a cell off grid lines: up to 7%), and landings "
                "on surfaces seeded in polygons are not yet reliable; see "
                "docs/contact.md (Contact between bodies, not yet good "
                "enough) for these and the cases refused")

    def begin_run(self, points) -> None:
        dim = self.dim
        # the smaller field of each interface second (its corners held)
        volume = np.zeros(self.field.max() + 1)
        np.add.at(volume, self.field[points.body], points.volume0)
        smaller_second(self.contacts, self.members, self.field, volume)
        modulus = np.broadcast_to(np.asarray(self.material.lam, float)
                                  + 2 * np.asarray(self.material.mu, float),
                                  (points.n,))
        # per field: the softer side of an interface (a pile glued to its
        # cap on the soil: the soil's)
        stiffest = np.full(self.field.max() + 1, -np.inf)
        np.maximum.at(stiffest, self.field[points.body], modulus)
        self.kappa = [c.penalty * min(stiffest[self.field[a]],
                                      stiffest[self.field[b]])
                      * self.h ** (dim - 2) for a, b, c in self.contacts]
        half = self.domain0 if self.domain0 is not None else np.repeat(
            (points.volume0 ** (1. / dim) / 2)[None], dim, axis=0)
        self.half = half
        self.warn_sides_inside_cells(points, half)
        self.R = corner_signs(dim)[:, :, None] * half[:, None, :]
        self.point_field = self.field[points.body]
        names = [name for k in range(len(self.contacts))
                 for rows in traction_state(k, dim) for name in rows]
        if not self.finite and self.weights is None:
            names += [name for row in gradient_state(dim) for name in row]
        for name in names:
            points.state.setdefault(name, np.zeros(points.n))
        if self.weights is not None:
            # the domains as the points' deformation left them (a staged
            # run's points come deformed)
            for row, offsets in zip(corner_state(dim),
                                    self.domain_offsets(points)):
                for name, offset in zip(row, offsets):
                    points.state.setdefault(name, offset.copy())

    def failure_hint(self, points, quasi_static: bool) -> str:
        """Friction mobilised in full between two bodies at the last
        converged state ``points`` of a quasi-static run
        (:func:`~skfem_mpm.solve.contact.friction_hint`)."""
        if not quasi_static:
            return ""
        out, dim = [], self.dim
        for k, (_, _, contact) in enumerate(self.contacts):
            rows = traction_state(k, dim)
            if not all(name in points.state for row in rows for name in row):
                continue
            P, _, T = (np.sqrt(sum(np.array([points.state[name]
                                             for name in row]) ** 2
                                   for row in rows[q * dim:(q + 1) * dim]))
                       for q in range(3))
            out.append(friction_hint("contact {!r}".format(contact.name),
                                     contact.friction, P, T)
                       or self.sliding_load_hint(k))
        return "".join(out)

    def sliding_load_hint(self, k: int) -> str:
        """Where every pair of contact ``k`` at the last step tried had
        one normal (a flat interface), a hint when the load on one of its
        bodies (its body force, point forces and surface loads,
        :attr:`loads`) pushes it
        along the interface more than mu times it presses it on the
        other: held by that contact alone, it has no quasi-static
        equilibrium.  :func:`~skfem_mpm.solve.contact.friction_hint`
        needs a committed step; a block on a slab under gravity tilted
        past mu failed its first step with neither (a user trial)."""
        found = self.sliding_body(k)
        if found is None:
            return ""
        named, ratio = found[3:]
        return ("; the load on body {!r} pushes it along its contact {!r} "
                "with body {!r} with {:.3f} times mu times the force "
                "pressing it on the interface: held by that contact alone "
                "it has no quasi-static equilibrium past mu, it slides "
                "(dynamics follows the slide; or prescribe its "
                "motion)".format(named[0], self.contacts[k][2].name,
                                 named[1], ratio))

    def sliding_body(self, k: int) -> Optional[tuple]:
        """The body of contact ``k`` its load slides along the interface
        (:meth:`sliding_load_hint`), nothing else holding it
        (:meth:`held_by_contact_alone`): ``(body, the other body, the
        interface's normal towards the body, (its name, the other's), the
        load's ratio to mu times the force pressing it)``, or ``None`` (a
        block also held by a support was told it had no equilibrium, a
        review)."""
        a, b, contact = self.contacts[k]
        found = [pairs[k][2] for pairs in self.geometry.values()]
        if self.loads is None or not found or isinstance(
                contact.friction, str) or not contact.friction > 0.:
            return None
        normal = found[-1]
        if not normal.size or np.ptp(normal, axis=1).max() > 1e-9:
            return None
        n = normal[:, 0]                    # from the first to the second
        for body, other, towards, named in (
                (b, a, n, (contact.second, contact.first)),
                (a, b, -n, (contact.first, contact.second))):
            if not self.alone[body]:
                continue
            load = self.loads[body]
            pressing = -float(load @ towards)
            along = float(np.linalg.norm(load + pressing * towards))
            if pressing > 0 and along > contact.friction * pressing * (
                    1 + 1e-9):
                return (body, other, towards, named,
                        along / (contact.friction * pressing))
        return None

    def no_equilibrium(self, points) -> bool:
        """Whether the load of the last step tried slides a body along
        its contact that nothing else holds (:meth:`sliding_body`), the
        other body lying wholly on its side of the interface's plane (no
        lip or wall of it that the sliding body may meet), ``points``
        the last converged state."""
        for k in range(len(self.contacts)):
            found = self.sliding_body(k)
            if found is None:
                continue
            body, other, towards = found[:3]
            level = np.einsum("d,dcn->cn", towards, self.corners(points))
            on = self.field[points.body]
            if level[:, on == self.field[other]].max() <= \
                    level[:, points.body == body].min() + self.tol[k]:
                return True
        return False

    def held_by_contact_alone(self, problem) -> ndarray:
        """Per body, whether one contact alone can hold it in the step of
        ``problem``: the body is in one contact, alone on its field, whose
        copy of the grid holds no support where material is, in a run with
        no prescribed motion, rigid body, obstacle, term that holds a free
        body or of a user's, and no grid load (:attr:`loads` has the body
        forces, point forces and surface loads alone)."""
        run, op = problem.run, problem.op
        bodies = self.field.size
        if run.prescribed is not None or run.rigid_bodies or \
                run.obstacles or any(term.holds_free_body
                                     for term in run.terms) or \
                run.user_terms or run.loads.grid_vector is not None:
            # (a grid load belongs to no body: not in :attr:`loads`)
            return np.zeros(bodies, dtype=bool)
        active = np.zeros(op.N, dtype=bool)
        active[op.active_dofs] = True
        fixed = problem.fixed[active[problem.fixed]]
        fields = int(self.field.max()) + 1
        held = np.zeros(fields, dtype=bool)
        held[fixed // (op.N // fields)] = True
        contacts = np.bincount([body for a, b, _ in self.contacts
                                for body in (a, b)], minlength=bodies)
        return (contacts == 1) & ~held[self.field] & (
            np.bincount(self.field, minlength=fields)[self.field] == 1)

    def declared_forces(self, parts, ev, points, among) -> ndarray:
        """The force (contacts x dim) the first body of each contact
        exerts on the second, from its interface's pairs' tractions on
        the interface's second field (``ev``, of
        :meth:`StepBodyContact.evaluate`), each pair's split among the
        bodies of its two fields (every pair of an interface's fields'
        bodies has a contact, else they would be glued): a contact takes
        the share of its first body on one side times its second's on
        the other, a side's shares those of its bodies that touch the
        other field (:meth:`touching`; all where none does) whose
        material lies nearest the pair's corner on the other side
        (:meth:`nearest_bodies`), ``points`` the state the step ended
        at, ``among`` the points searched (the step's interface).  By
        the bodies of the corners at each corner's own place, a user
        trial's cap glued to its pile 0.7 cells above Tresca soil
        reported 1.39 of the load of 20, and 0.30 of 7.06 in finite
        strain 0.3 cells above it: pairs of the cap's corners and the
        soil's corners beside the pile's head along inclined normals;
        now nothing.  A pair on the line where two glued bodies meet is
        shared by both (taken whole by the body of the corner the pairs'
        search found, the load ``p`` on two blocks side by side, each
        half the width, on a third, was 3.75 and 6.25 for 5 and 5)."""
        out = np.zeros((len(self.declared), self.dim))
        X = touch = None
        for part, e, members in zip(parts, ev, self.members):
            if len(members) == 1:
                j, _, _, sign = members[0]
                out[j] = sign * e[0].sum(axis=1)
                continue
            if X is None:
                X = self.corners(points).reshape(self.dim, -1)
                touch = self.touching(points, among)
            # per side (0: the second field's, 1: the first's), pair and
            # body: the shares of the pairs that carry a force
            loaded = np.flatnonzero(np.abs(e[0]).max(axis=0) > 0.)
            B, A = np.divmod(part["keys"][loaded], X.shape[1])
            first, second = self.field[list(
                self.contacts[part["contact"]][:2])]
            share = [self.nearest_bodies(
                points, X[:, at], among, field,
                touch[:, self.field == other].any(axis=1))
                for at, field, other in ((A, second, first),
                                         (B, first, second))]
            for j, a, b, sign in members:
                mine = share[1][:, a] * share[0][:, b] \
                    + share[1][:, b] * share[0][:, a]
                out[j] = sign * (e[0][:, loaded] @ mine)
        return out

    def touching(self, points, among) -> ndarray:
        """Per two bodies (bodies x bodies), whether their domains (as
        :meth:`corners` has them) among the points ``among`` lie within
        :data:`TOUCHING` cells of each other, in the maximum norm."""
        out = np.zeros((self.field.size,) * 2, dtype=bool)
        X = self.corners(points)[:, :, among]
        lo, hi = X.min(axis=1), X.max(axis=1)
        centre, half = (lo + hi) / 2, (hi - lo) / 2
        reach = TOUCHING * self.h
        i, j = cKDTree(centre.T).query_pairs(
            2 * half.max(initial=0.) + reach, p=np.inf,
            output_type="ndarray").T
        body = points.body[among]
        i, j = i[body[i] != body[j]], j[body[i] != body[j]]
        apart = np.maximum(np.abs(centre[:, i] - centre[:, j]) - half[:, i]
                           - half[:, j], 0.).max(axis=0, initial=0.)
        close = apart <= reach
        out[body[i[close]], body[j[close]]] = True
        return out | out.T

    def nearest_bodies(self, points, at: ndarray, among: ndarray,
                       field: int, allowed: ndarray) -> ndarray:
        """Per position ``at`` (dim, m), the shares (m, bodies) of the
        bodies on ``field`` (of those ``allowed``, a mask of the bodies,
        where any is) whose domains (as :meth:`corners` has them) among
        the points ``among`` lie nearest it, in the maximum norm, alike
        within :data:`~skfem_mpm.solve.contact_pairs.FACING` cells
        (shared equally)."""
        out = np.zeros((at.shape[1], self.field.size))
        on = among[self.point_field[among] == field]
        if allowed[points.body[on]].any():
            on = on[allowed[points.body[on]]]
        if not at.shape[1] or not on.size:
            return out
        X = self.corners(points)[:, :, on]
        lo, hi = X.min(axis=1), X.max(axis=1)
        centre, half = (lo + hi) / 2, (hi - lo) / 2
        tie = FACING * self.h
        tree = cKDTree(centre.T)
        # the nearest centre bounds the nearest domain
        bound = tree.query(at.T, p=np.inf)[0] + tie + half.max()
        found = tree.query_ball_point(at.T, bound, p=np.inf)
        pair = np.repeat(np.arange(at.shape[1]), [len(f) for f in found])
        near = np.concatenate(found).astype(np.int64)
        apart = np.maximum(np.abs(at[:, pair] - centre[:, near])
                           - half[:, near], 0.).max(axis=0)
        least = np.full(at.shape[1], np.inf)
        np.minimum.at(least, pair, apart)
        keep = apart <= least[pair] + tie
        out[pair[keep], points.body[on[near[keep]]]] = 1.
        return out / np.maximum(out.sum(axis=1, keepdims=True), 1.)

    def domain_offsets(self, points) -> ndarray:
        """The corners' offsets from their points (dim, corners, n) where
        the points' deformation puts them (finite deformation), or their
        domains' (small strain)."""
        return np.einsum("abp,bcp->acp", points.F[:self.dim, :self.dim],
                         self.R) if self.finite else self.R

    def corners(self, points) -> ndarray:
        """The corners of the points' domains (dim, corners, n), moved by
        the points' deformation gradient (in small strain ``I`` plus the
        displacement gradient the term keeps, ``contact_body_grad<a><b>``:
        a domain that did not shrink with its material would overlap the
        other body by the strain times its size).  With B-splines each
        corner is moved in every step by the splines' field there, as the
        pairs move it (point state ``contact_body_corner<a><c>``, its
        offset from its point): moved through the point's gradient, the
        soil's corners under a pile's edge, where the field bends, lay a
        tenth of a cell off where the last step's pairs had held them,
        each step's start forgave that as penetration, and the pile sank
        through the soil's corners there (two cells wide, its tip inside
        a cell: refused at step 8 or 10 as not held along y).  With the
        grid element's polynomial per point's cell instead, corners that
        neighbouring domains share move by two cells' polynomials, and
        which of them a pair takes is decided by round-off: symmetric
        piles leaned (tried).  Kept per state ``points`` (read-only): a
        step read them 18 times, 0.24 s at 1e5 points."""
        key = (points.x, points.F, points.state)
        kept = self.kept_corners
        if kept is not None and kept[0]() is points and all(
                a is b for a, b in zip(kept[1], key)):
            return kept[2]
        X = self.new_corners(points)
        X.flags.writeable = False
        self.kept_corners = (ref(points), key, X)
        return X

    def new_corners(self, points) -> ndarray:
        """The corners of :meth:`corners`, computed."""
        dim = self.dim
        if self.weights is not None:
            return points.x[:, None, :] + np.array(
                [[points.state[name] for name in row]
                 for row in corner_state(dim)])
        if self.finite:
            F = points.F[:dim, :dim]
        else:
            F = np.eye(dim)[:, :, None] + np.array(
                [[points.state[name] for name in row]
                 for row in gradient_state(dim)])
        return points.x[:, None, :] + np.einsum("abp,bcp->acp", F, self.R)

    def pressed(self, points):
        """``pressed(k, corner)``: contact ``k``'s pressure vectors
        (dim, m) at the second body's corners ``c n + p`` where the last
        step ended (:meth:`~skfem_mpm.solve.contact_pairs.PairFinder.
        find_pairs`)."""
        rows = [traction_state(k, self.dim)[:self.dim]
                for k in range(len(self.contacts))]
        return lambda k, corner: np.array([corner_values(
            points.state, row, corner, points.n) for row in rows[k]])

    def place(self, points, corner: ndarray) -> ndarray:
        """The places (dim, m; integers) of the corners ``c n + p``:
        their positions in units of :data:`FACING` cells."""
        return self.finder.place(self.corners(points).reshape(
            self.dim, -1)[:, corner])

    def support(self, op, points):
        """The grid nodes' supports of the step of ``op`` (points, nodes of
        every field), kept per operator: the method's, or with B-splines
        (``weights``) the grid element's at the points, standard MPM's.
        The splines of a point reach the nodes a row beyond its cell's,
        where a node's corners of both bodies span the far side of the
        other body (a pile two cells wide: its soil on both sides, read
        as bodies overlapping at the start) and lean the centroids'
        normals; the pairs' rows are the splines' all the same."""
        if op not in self.supports:
            self.supports[op] = (value_matrix(op) if self.weights is None
                                 else self.cell_values(
                                     points.x, op.point_elements,
                                     op.N // self.dim)).tocsc()
        return self.supports[op]

    def interface(self, op, points):
        """The points that reach a node of two fields (where bodies may
        meet in the step of ``op``) and their supports alone (points,
        nodes of every field; the others' rows empty): every support of
        a node of two fields, all that a search for pairs reads (0.1 s a
        search at 1e5 points with every point's); kept per operator."""
        if op not in self.interfaces:
            support = self.support(op, points)
            fields = [support[:, k * self.nv:(k + 1) * self.nv] != 0
                      for k in range(int(self.field.max()) + 1)]
            reached = sum((f.sum(axis=0).A1 > 0).astype(int)
                          for f in fields)
            rows = np.unique(np.concatenate([
                f[:, reached > 1].tocoo().row for f in fields]))
            on = np.zeros(points.n)
            on[rows] = 1.
            near = (diags(on) @ support).tocsc()
            near.eliminate_zeros()
            self.interfaces[op] = rows, near
        return self.interfaces[op]

    def pairs(self, op, points):
        """Per contact, the pairs of surface corners at the step's start:
        ``(B, A, n, g0)`` (corner indices ``c n + p`` of the second and
        first body, normals (dim, m), gaps (m,)); kept per operator;
        bodies that overlap at the run's start are refused."""
        if op in self.geometry:
            return self.geometry[op]
        # bodies whose domains overlap at the run's start are refused;
        # the pairs alone, formed across a cell, read bodies that only
        # touch, their sides inside cells, as overlapping by half a cell
        # (a user trial's pile, h = 2/15, its sides a third of a cell off
        # grid lines: refused by every method)
        on = self.field[points.body]
        start = not points.displacement.any() and any(
            overlapping(points.x, self.half,
                        np.flatnonzero(on == self.field[b]),
                        np.flatnonzero(on == self.field[a]), tol).any()
            for (a, b, _), tol in zip(self.contacts, self.tol))
        out = self.finder.find_pairs(self.interface(op, points)[1],
                                     points.x,
                                     points.volume, self.corners(points),
                                     start, self.pressed(points))
        for (_, _, contact), tol, (B, A, normal, gap) in zip(
                self.contacts, self.tol, out):
            if start and (gap < -tol).any():
                i = int(np.argmin(gap))           # at the run's start
                raise InvalidInputError(
                    "contact {!r}: the bodies overlap at the start by {:.3g} "
                    "(tolerance {:.3g}) at {}; place them apart or "
                    "touching".format(contact.name, float(-gap[i]), tol,
                                      self.corners(points).reshape(
                                          self.dim, -1)[:, B[i]].tolist()))
        self.geometry[op] = out
        return out

    def corner_motion(self, op, points, du: ndarray) -> ndarray:
        """B-splines: the motion of every domain corner relative to its
        point in the step of ``du`` (dim, corners, n), the splines
        evaluated at :data:`CORNER_BLOCK` points' corners at a time (all
        at once, as vector rows, took 650 MB at 2e4 points in 3D)."""
        dim, n = self.dim, points.n
        nc = 2 ** dim
        X = self.corners(points)
        u = du.reshape(-1, dim)                  # (scalar DOFs, dim)
        out = np.empty((dim, nc, n))
        for start in range(0, n, CORNER_BLOCK):
            p = np.arange(start, min(n, start + CORNER_BLOCK))
            S = spline_rows(self.weights, op,
                            X[:, :, p].reshape(dim, -1), np.tile(p, nc))
            out[:, :, p] = (S @ u).T.reshape(dim, nc, p.size)
        return out - op.values(du)[:, None, :]

    def rows(self, op, points, corner: ndarray, normal: ndarray = None):
        """The vector rows ``J`` (dim m, N) of the corners ``c n + p``:
        the method's weights there (B-splines), or the grid element's
        shape functions at the corner of the cell of
        :meth:`corner_cells`; with GIMP on linear elements (:attr:`gimp`)
        a corner on its domain's side that faces the other body across
        ``normal`` (dim, m; the other body's face's, towards the corner),
        a grid axis, by GIMP's weights of that side
        (:func:`~skfem_mpm.solve.contact.side_rows`).

        In small strain GIMP's domains keep their size while the pairs'
        corners follow the displacement gradient (:meth:`corners`): the
        grid element's shape functions at the corner of a body's domain
        that reached a sliver into the cell row below the interface
        (about 0.11 of a cell there, 6 steps) gave the node below it
        the weight of the corner's sliver, 3% less than the sliver of
        the domain the internal force integrates over; two blocks
        pressed across a smooth contact with uGIMP or cpGIMP (strain
        1.9e-2) were 2.4e-2 off in 6 steps against 1.7e-2 glued, 2.7e-2
        without the ghost penalty (``docs/contact.md``)."""
        dim, n = self.dim, points.n
        p = corner % n
        X = self.corners(points).reshape(dim, -1)[:, corner]
        if not corner.size:             # no pairs (bodies cells apart)
            return csr_matrix((0, op.N))
        if self.weights is not None:
            return kron(spline_rows(self.weights, op, X, p),
                        identity(dim), format="csr")
        S = self.cell_values(X, self.corner_cells(op, points, X, p),
                             op.N // dim)
        if normal is not None and self.gimp is not None \
                and points.domain is not None:
            S = self.face_rows(points, S, corner, normal)
        return kron(S, identity(dim), format="csr")

    def face_rows(self, points, S, corner: ndarray, normal: ndarray):
        """The scalar rows ``S`` (m, N / dim) of the corners ``c n + p``,
        those on their domain's side facing ``normal`` (:meth:`rows`)
        by GIMP's weights of the side, on their point's field."""
        n = points.n
        p = corner % n
        facing, face = side_rows(self.gimp, points.x[:, p],
                                 points.domain[:, p],
                                 corner_signs(self.dim)[:, corner // n],
                                 normal)
        if not facing.size:
            return S
        face = face.tocoo()
        shift = self.point_field[p[facing]] * self.nv
        face = csr_matrix((face.data, (facing[face.row],
                                       face.col + shift[face.row])),
                          shape=S.shape)
        keep = np.ones(corner.size)
        keep[facing] = 0.
        S = (diags(keep) @ S + face).tocsr()
        S.eliminate_zeros()
        return S

    def corner_cells(self, op, points, X: ndarray, p: ndarray) -> ndarray:
        """The cells (of the extended mesh) whose polynomials move the
        corners ``X`` (dim, m) of the points ``p`` (m,): the cell on the
        point's field that a corner lies in, where the point's weights
        reach all its nodes (its domain holds material there, if only a
        sliver), else the point's own (extrapolated: a corner beyond the
        material the point's domain holds); a corner within :data:`PULL`
        of its distance to the point from a cell's face is the point's
        side of it, and one beyond the grid's bounding box is moved onto
        it (the domains are clipped to the grid: a side's corners on
        the polynomial of the cell below the grid line, as the others').

        cpGIMP's internal force of a uniform stress on a field's node is
        the stress on the node's shape function along the surface of its
        points' domains, as the cells the surface lies in have it; the
        contact's force on a body's corner must reach the nodes alike.
        With the point's cell's polynomial extrapolated to a corner in
        the cell below (a body pressed onto another, its domains a
        sliver past a grid line: 0.014 of a cell), the pressure went to
        the nodes above, the internal force to those below, which
        nothing else held: a uniform compression across a smooth
        contact, exact in one step, was 32% off in three (the ghost
        penalty's default), 100% without the ghost penalty.
        """
        cells = op.point_elements[p]
        if self.grid_locate is None:
            # (contiguous copies: scikit-fem warns of the slices' layout
            # beyond 1000 vertices, a user trial's 3D run at every start)
            grid = type(self.cell_values.mesh)(
                np.ascontiguousarray(self.cell_values.mesh.p[:, :self.nv]),
                np.ascontiguousarray(self.cell_values.mesh.t[:, :self.cells]),
                sort_t=False)
            self.grid_locate = point_locator(grid)
        mesh = self.grid_locate.mesh
        inward = np.clip(X + PULL * (points.x[:, p] - X),
                         mesh.p.min(axis=1)[:, None],
                         mesh.p.max(axis=1)[:, None])
        found = np.full(p.size, -1, dtype=np.int64)
        inside = np.ones(p.size, dtype=bool)
        while inside.any():
            try:
                found[inside] = self.grid_locate(inward[:, inside])[0]
                break
            except PointsOutsideGridError as error:   # keep the point's
                if error.indices is None:
                    break
                inside[np.flatnonzero(inside)[error.indices]] = False
        other = np.flatnonzero((found >= 0) & (
            found + self.point_field[p] * self.cells != cells))
        if not other.size:
            return cells
        moved = found[other] + self.point_field[p[other]] * self.cells
        dofs = self.cell_values.dofs[:, moved]          # (nodes, m)
        reach = self.support(op, points)[
            np.broadcast_to(p[other], dofs.shape).ravel(), dofs.ravel()]
        held = (np.asarray(reach).reshape(dofs.shape) != 0).all(axis=0)
        cells = cells.copy()
        cells[other[held]] = moved[held]
        return cells

    def companions(self, points, corner: ndarray, among: ndarray):
        """The corners of the points ``among`` (of the corners' body) at
        the place of each of the corners ``c n + p`` (within half of
        :data:`~skfem_mpm.solve.contact_pairs.FACING` cells), itself
        among them: (i, j), corner ``corner[i]`` has ``j`` (``c n + p``)
        at its place."""
        dim, n = self.dim, points.n
        X = self.corners(points).reshape(dim, -1)
        nc = X.shape[1] // n
        pool = np.union1d(corner, (np.arange(nc)[:, None] * n
                                   + among[None, :]).ravel())
        near = cKDTree(X[:, corner].T).sparse_distance_matrix(
            cKDTree(X[:, pool].T), .5 * FACING * self.h, p=np.inf,
            output_type="ndarray")
        return near["i"], pool[near["j"]]

    def shared_rows(self, op, points, corner: ndarray, near,
                    normal: ndarray = None):
        """The vector rows (dim m, N) of the corners ``c n + p``, each
        averaged over the corners at its place (``near``, of
        :meth:`companions`).  Neighbouring domains share corners, and
        each moves with its own point's cell: one of them, taken for a
        pair by the order, made a mirror-symmetric block landing on a
        slab turn (its tangent held the slab's corner on the middle line
        by the right cell's nodes, not the left's: 3.5e-8 asymmetric at
        the landing, 9e-3 of its motion after the bounce, the same in the
        mirrored model).  The pair's gap stays its own corners' (the
        step's joins and checks read single corners; the mean's, tried,
        took a frictional punch on a plastic stack 670 Newton iterations
        for 416).  ``normal``: :meth:`rows`' per corner."""
        i, j = near
        count = np.bincount(i, minlength=corner.size)
        mean = csr_matrix((1. / count[i], (i, np.arange(i.size))),
                          shape=(corner.size, i.size))
        return kron(mean, identity(self.dim), format="csr") \
            @ self.rows(op, points, j,
                        None if normal is None else normal[:, i])

    def held_dofs(self, op, points, scale: float):
        """The DOFs of both bodies at pairs touching at the step's start
        (within the tolerance, or 1e-3 of a cell where that is tighter:
        pairs that a step held to 1e-10 of a cell start the next up to
        6e-9 apart, where the corners of its start are), or pressed at the
        last step's end (they start with its pressure): along the normal
        where it is a grid axis and the contact smooth, else every
        component."""
        held, n = [], points.n
        for k, ((a, b, contact), (B, A, normal, gap), tol) in enumerate(zip(
                self.contacts, self.pairs(op, points), self.tol)):
            pressed = carried(points.state, k, B, normal, n,
                              self.place(points, B))[0]
            touching = (gap <= max(tol, 1e-3 * self.h)) | (pressed > 0)
            if not touching.any():
                continue
            aligned = np.abs(normal[:, touching]) > 1 - 1e-9
            comps = aligned | ~aligned.any(axis=0) \
                if contact.friction == 0. else np.ones_like(aligned)
            for corner in (B[touching], A[touching]):
                J = self.rows(op, points, corner).tocoo()
                row_comp = J.row % self.dim
                pair = J.row // self.dim
                on = comps[row_comp, pair] & (J.data != 0)
                held.append(np.unique(J.col[on]))
        return np.unique(np.concatenate(held)) if held else None

    def held_supports(self, points, dofs: ndarray, where: ndarray,
                      N: int, active: ndarray,
                      within: float = None) -> ndarray:
        """The supports' DOFs ``dofs`` (of every field's copy of the grid,
        ``N`` DOFs in all; at the positions ``where``, dim x m) that hold:
        a field's copy of a node only where its bodies' material (the
        points' domains, as :meth:`corners` has them) lies on the support
        next to the node, within ``within`` cells (default
        :data:`SUPPORT_NEAREST`; prescribed motion's
        :data:`~skfem_mpm.solve.motion.MOVED_NEAREST`) as near as
        the nearest material of any field there, where that lies within
        :data:`SUPPORT_NEAREST` cells of it (else every copy holds, as
        the glued fields would; the distance, along the
        farthest axis, to the node or to a grid edge from it to a node
        held in the same component: a body whose side lies on a held
        wall from half a cell above a node is held there, as glued).  A
        support is the boundary of the material on it: a block sliding
        on a slab one cell thick that the supports held underneath got
        its own copy of their nodes once its domains reached the slab's
        cells (a penetration within the tolerance; B-splines from the
        start), and was held there: smooth contact, its vx fell from 1
        to 0 in 0.5 s.  With B-splines a copy the points carry weight on
        (``active``, a mask of the DOFs) beside a held one of its field
        is held too, in turn (the splines' control points hold a body
        only along a whole edge)."""
        if not dofs.size:
            return dofs
        dim = self.dim
        fields = int(self.field.max()) + 1
        field, component = dofs // (N // fields), dofs % dim
        X = self.corners(points)
        lo, hi = X.min(axis=1), X.max(axis=1)
        held = np.zeros(dofs.size, dtype=bool)
        for c in range(dim):
            on = np.flatnonzero(component == c)
            if not on.size:
                continue
            nodes, node = np.unique(where[:, on], axis=1,
                                    return_inverse=True)
            node = node.ravel()
            distance = self.support_distances(nodes, lo, hi, fields)
            nearest = distance.min(axis=0)[node]
            held[on] = (nearest > SUPPORT_NEAREST * self.h) | (
                distance[field[on], node] <= nearest + self.h * (
                    SUPPORT_NEAREST if within is None else within))
        if self.weights is not None and not held.all():
            # grid neighbours of one field and component
            i, j = cKDTree(where.T).query_pairs(
                self.h * (1 + 1e-6), output_type="ndarray").T
            same = (field[i] == field[j]) & (component[i] == component[j])
            i, j = np.r_[i[same], j[same]], np.r_[j[same], i[same]]
            while True:
                more = ~held[i] & held[j] & active[dofs[i]]
                if not more.any():
                    break
                held[i[more]] = True
        return dofs[held]

    def support_distances(self, nodes: ndarray, lo: ndarray, hi: ndarray,
                          fields: int) -> ndarray:
        """Per field, the distance (along the farthest axis) from the
        held ``nodes`` (dim, m) and the grid edges between two of them to
        the nearest domain ``[lo, hi]`` (dim, n) of a point of the field's
        bodies, per node the least of its own and its edges' (fields, m;
        ``inf`` where no domain lies within twice :data:`SUPPORT_NEAREST`
        cells, all that :meth:`held_supports` reads)."""
        m, h = nodes.shape[1], self.h
        i, j = cKDTree(nodes.T).query_pairs(h * (1 + 1e-6),
                                            output_type="ndarray").T
        edge = (np.abs(nodes[:, i] - nodes[:, j]) > 1e-9 * h).sum(
            axis=0) == 1
        i, j = i[edge], j[edge]
        low = np.hstack([nodes, np.minimum(nodes[:, i], nodes[:, j])])
        high = np.hstack([nodes, np.maximum(nodes[:, i], nodes[:, j])])
        ends = [np.r_[np.arange(m), i], np.r_[np.arange(m), j]]
        at, size = (low + high) / 2, (high - low) / 2
        centre, half = (lo + hi) / 2, (hi - lo) / 2
        tree = cKDTree(at.T)
        distance = np.full((fields, m), np.inf)
        for k in range(fields):
            sel = np.flatnonzero(self.point_field == k)
            if not sel.size:
                continue
            reach = half.take(sel, axis=1).max() + size.max() \
                + 2 * SUPPORT_NEAREST * h
            # the points near a support (a tree of those, not of the
            # field's every point: 0.15 s a step at 1e5 points), of those
            # in the supports' bins (each point searched: 25 ms a step)
            sel = sel[near_sites(centre.take(sel, axis=1), at, reach)]
            sel = sel[tree.query(centre[:, sel].T, p=np.inf,
                                 distance_upper_bound=reach)[0] <= reach]
            near = cKDTree(centre[:, sel].T).sparse_distance_matrix(
                tree, reach, p=np.inf, output_type="ndarray")
            p, f = sel[near["i"]], near["j"]
            apart = np.maximum(np.abs(at[:, f] - centre[:, p]) - half[:, p]
                               - size[:, f], 0.).max(axis=0)
            facet = np.full(at.shape[1], np.inf)
            np.minimum.at(facet, f, apart)
            for end in ends:
                np.minimum.at(distance[k], end, facet)
        return distance

    def begin_step(self, problem):
        self.loads = body_loads(problem)
        self.alone = self.held_by_contact_alone(problem)
        return StepBodyContact(self, problem)


def body_loads(problem) -> ndarray:
    """Per body (bodies, dim), the resultant of its body force, point
    forces and surface loads at the end of ``problem``'s step (a
    traction that shears a block along its slab past mu named no
    friction: a user trial)."""
    points, loads, factor = problem.points, problem.run.loads, problem.s_new
    bodies = int(points.body.max()) + 1
    out = factor * np.stack([np.bincount(points.body, force, bodies)
                             for force in points.force], axis=1)
    gravity = loads.gravity
    if gravity is not None:
        ramp = np.broadcast_to(loads.ramp_gravity, (bodies,))
        volume = np.bincount(points.body, points.volume0, bodies)
        rows = np.broadcast_to(gravity, (bodies, points.dim))
        out += np.where(ramp, factor, 1.)[:, None] * volume[:, None] * rows
    if loads.surface:
        out += loads.surface_resultants(points, factor, bodies)
    return out


#: the consecutive levels (one domain apart) of a body's faces towards a
#: body it is in contact with, across one axis, from which its surface is
#: a staircase (an incline or a curve seeded on the points' lattice, not a
#: step, nor footings at several depths):
#: :meth:`BodyContact.warn_sides_inside_cells`
STAIRS = 3

#: the cells a body's material may lie farther from a support's node than
#: the nearest material there and still be held by it
#: (:meth:`BodyContact.held_supports`)
SUPPORT_NEAREST = .25

#: the motion in cells up to which :meth:`StepBodyContact.check_passing`
#: looks only at the points near the other body at the step's start (a
#: step moving points farther looks at every point)
PASSING_NEAR = 2.

#: the fraction of its distance to its point by which a domain corner is
#: moved towards it to find the cell it lies in (a corner on a grid line
#: lies in its point's cell): :meth:`BodyContact.corner_cells`; an
#: obstacle's corners that hold are found alike
#: (:meth:`~skfem_mpm.solve.contact.ObstacleContact.corner_cells`)
PULL = 1e-6

#: the most bins of :func:`near_sites`' raster of sites
SITE_BINS = 1 << 20

#: the cells within which two bodies' domains touch, for the force each
#: contact of an interface reports (:meth:`BodyContact.declared_forces`):
#: a cap glued to its pile 0.3 cells above the soil (a user trial) does
#: not
TOUCHING = .1

#: the points whose corners' splines are evaluated at once
#: (:meth:`BodyContact.corner_motion`)
CORNER_BLOCK = 1 << 13

#: the most an augmented-Lagrangian update is stretched by
#: (:func:`accelerated`)
STRETCH = 20.

#: the share of the last augmented-Lagrangian round's penetration a
#: round that closes no more leaves, from which :func:`unsettled` judges
#: the multipliers by the grid's forces
STALLED_ROUND = .99

#: the cosine between two rounds' updates above which they are one mode
ALIGNED = .99

#: the least rate of two rounds' updates that is extrapolated: rounds
#: that close half of the rest or more settle without it
SLOW = .5


def nearest_within(x: ndarray, these: ndarray, those: ndarray,
                   bound: float) -> ndarray:
    """Per point of ``these`` (indices of ``x``, dim x n), its distance
    in the maximum norm to the nearest of ``those``, ``inf`` beyond
    ``bound``: only the points of each within ``bound`` of the other's
    box are searched (two bodies stacked at 1e5 points: a tree of each
    whole body, 0.27 s a step).  The points are gathered row by row
    (``take``): the boxes of ``x[:, these]``, laid out point by point,
    took 5 ms a call there, 20 ms of a step's start.

    >>> import numpy as np
    >>> x = np.array([[0., 1., 5., 1.5], [0., 0., 0., 0.]])
    >>> nearest_within(x, np.array([0, 1, 2]), np.array([3]), 1.).tolist()
    [inf, 0.5, inf]
    """
    out = np.full(these.size, np.inf)
    if not (these.size and those.size):
        return out
    a, b = x.take(these, axis=1), x.take(those, axis=1)
    near_a = np.all((a >= b.min(axis=1)[:, None] - bound)
                    & (a <= b.max(axis=1)[:, None] + bound), axis=0)
    a = a.compress(near_a, axis=1)
    near_b = np.all((b >= a.min(axis=1, initial=np.inf)[:, None] - bound)
                    & (b <= a.max(axis=1, initial=-np.inf)[:, None]
                       + bound), axis=0)
    if near_a.any() and near_b.any():
        out[near_a] = cKDTree(b.compress(near_b, axis=1).T,
                              balanced_tree=False).query(
            a.T, p=np.inf, distance_upper_bound=bound)[0]
    return out


def near_sites(x: ndarray, sites: ndarray, reach: float) -> ndarray:
    """Which of the points ``x`` (dim, n) may lie within ``reach`` of
    one of the ``sites`` (dim, m; m > 0) along every axis: every one that
    does, and others in the bins next to a site's, of bins at least
    ``2 reach`` wide over the sites' box (at most :data:`SITE_BINS` of
    them): a point within reach of a site, round-off and all, lies in the
    site's bin or the next along each axis.  A cheap sieve before an
    exact search (:meth:`BodyContact.support_distances`).

    >>> x = np.array([[0., 1., 3., 9.], [0., 0., 0., 0.]])
    >>> near_sites(x, np.array([[1.], [0.]]), .5).tolist()
    [True, True, False, False]
    """
    dim, lo = x.shape[0], sites.min(axis=1)[:, None]
    width = np.maximum((sites.max(axis=1)[:, None] - lo)
                       / int(SITE_BINS ** (1. / dim)), 2. * reach)
    at = np.floor((sites - lo) / width).astype(np.int64) + 1
    shape = at.max(axis=1) + 2                  # a bin more either side
    raster = np.zeros(tuple(shape), dtype=bool)
    raster[tuple(at)] = True
    for d in range(dim):            # each site's bin and the next ones
        line = np.moveaxis(raster, d, 0)
        line[1:] |= line[:-1]
        line[:-1] |= line[1:]
    # clipped beyond the raster (far points: no integer overflow)
    bins = np.clip(np.floor((x - lo) / width) + 1, -1,
                   shape[:, None]).astype(np.int64)
    inside = np.all((bins >= 0) & (bins < shape[:, None]), axis=0)
    out = np.zeros(x.shape[1], dtype=bool)
    out[inside] = raster[tuple(b[inside] for b in bins)]
    return out


def unsettled(part: dict, e: tuple, kappa: float, tol: float,
              tolerance: float) -> float:
    """How far the multipliers of a contact's pairs ``part`` are from
    settled after a round that ended at ``e`` (of
    :meth:`StepBodyContact.evaluate`), in units of the contact's
    ``tolerance``: the penalty ``kappa``'s force on the deepest
    penetration (or gap of a pressed pair) relative to the largest
    pair's force (a floor of 1e-6 of the tolerance in length, ``tol``,
    for bodies that touch and do not press); where the round left that
    penetration as it was (within :data:`STALLED_ROUND` of the last
    round's), the grid's forces of the penalty on every pressed pair's
    penetration relative to those of the pairs' pressures: what a
    further round would change.  Pairs more than the splines' motions
    can close apart (a block on a slab with the quadratic B-splines, two
    points per cell: eight pairs along four cells, whose relative
    normal motions span six) keep a penetration no round closes while
    the multipliers drift along the mode: a block sliding at 25 degrees
    (mu = 0.3, dynamics) kept 1.9e-9 in every round (the penalty's force
    on it 1.2 times the tolerance of the largest pair's), with the
    penalty 100 times the default too, and failed after 30 rounds at
    every cut-back; its grid forces were 3e-4 to 0.03 of the
    tolerance."""
    depth = e[2]
    out = kappa * depth / max(tolerance * e[4].max(initial=0.),
                              1e-6 * kappa * tol)
    last, part["depth"] = part.get("depth"), depth
    if out <= 1. or last is None or depth < STALLED_ROUND * last:
        return out
    p, n, D = e[4], part["n"], part["D"]
    push = D.T @ (np.where(p > 0., kappa * e[6], 0.) * n).T.ravel()
    held = D.T @ (p * n).T.ravel()
    return float(np.abs(push).max(initial=0.) / max(
        tolerance * np.abs(held).max(initial=0.), 1e-6 * kappa * tol))


def accelerated(part: dict, p: ndarray) -> ndarray:
    """The multipliers of a contact's pairs ``part`` after a round of the
    augmented Lagrangian that ended at pressures ``p``: ``p`` itself, or,
    where this round's update ``p - lam`` and the last's point the same
    way (cosine above :data:`ALIGNED`) over the same pressed pairs and
    shrink by a steady rate ``r`` between :data:`SLOW` and 1, the sum of
    the rounds to come, ``lam + (p - lam) / (1 - r)`` (Aitken's
    extrapolation, stretched by at most :data:`STRETCH`); updates that
    do not shrink are not extrapolated.  A pile 100 times stiffer than
    its soil, pressing the soil at its tip, resists the pairs' moving
    apart much more than the penalty (from the softer body) pulls them:
    each round closed 7% of the rest, and the step ended after 30 rounds
    with :class:`~skfem_mpm.errors.ContactError` at every cut-back.
    Rounds that closed 60% of the rest, stretched by 1.7, sent a block
    landing on a staircase (dynamics, friction 0.3) on another path, in
    314 Newton iterations where it took 179 (128 now).

    >>> part = {"lam": np.array([0., 0.])}
    >>> for _ in range(3):       # rounds that close 10% of the rest each
    ...     p = part["lam"] + .1 * (np.array([10., 5.]) - part["lam"])
    ...     part["lam"] = accelerated(part, p)
    >>> part["lam"].round(12).tolist()
    [10.0, 5.0]
    """
    update, active = p - part["lam"], p > 0.
    last, was = part.get("update"), part.get("active")
    part["update"], part["active"] = update, active
    if last is None or last.shape != update.shape or \
            not np.array_equal(active, was):
        return p
    along = float(update @ last)
    norms = float(np.sqrt((update @ update) * (last @ last)))
    if not along > ALIGNED * norms:
        return p
    rate = along / float(last @ last)
    if not SLOW <= rate < 1.:
        return p
    rate = min(rate, 1. - 1. / STRETCH)
    return np.maximum(part["lam"] + update / (1. - rate), 0.)


class StepBodyContact(GridTerm):
    """One step's contact between bodies (built by
    :meth:`BodyContact.begin_step`)."""

    contact = True
    settles = True
    works_from_last_end = True

    def __init__(self, term: BodyContact, problem):
        self.term, self.problem = term, problem
        op, points = problem.method_op, problem.points
        self.dim = term.dim
        self.interface, self.interface_support = term.interface(op, points)
        self.interface_rows = None      # :meth:`join`'s, once a step
        self.apart = None    # check_passing's points apart at the start
        self.parts = []
        for k, ((B, A, normal, gap), tol) in enumerate(zip(
                term.pairs(op, points), term.tol)):
            self.parts.append({"contact": k})
            self.add(self.parts[-1], op, points, B, A, normal, gap, tol,
                     self.heirs(k, B, normal))
        self.evaluations = WeakKeyDictionary()

    def evaluate(self, du: ndarray, response):
        """Per contact, the pairs' tractions on the second body (dim, m),
        the derivative blocks (dim, dim, m), the largest penetration (or
        gap of a pressed pair), the largest stick slip, the pressures
        (m,), the friction tractions (dim, m) and the gaps (m,), cached
        for the trial's ``response``."""
        if response in self.evaluations:
            return self.evaluations[response]
        dim, term = self.dim, self.term
        eye = np.eye(dim)[:, :, None]
        start = not du.any()
        ev = []
        for (a, b, contact), part, kappa, tol in zip(
                term.contacts, self.parts, term.kappa, term.tol):
            n = part["n"]
            w = (part["D"] @ du).reshape(-1, dim).T        # relative motion
            gap = part["gap"] + (n * w).sum(axis=0)
            p = np.maximum(0., part["lam"] - kappa * gap)
            active = p > 0
            nn = np.einsum("as,bs->abs", n, n)
            C = np.where(active, kappa * nn, 0.)
            if start:       # touching pairs hold the step's first tangent
                touching = ~active & (part["lam"] - kappa * gap
                                      >= -kappa * tol)
                hold = nn if contact.friction == 0. else \
                    np.broadcast_to(eye, nn.shape)
                C[:, :, touching] = (kappa * hold)[:, :, touching]
            tau = np.zeros_like(w)
            slip_left = 0.
            if contact.friction != 0.:
                tau, C_t, stick = coulomb(
                    contact.friction, kappa, p, n, part["tau"], w,
                    part["held"] if contact.friction == "rough" else None)
                C += C_t
                slip = w - (n * w).sum(axis=0) * n
                slip_left = float(np.sqrt((slip[:, stick] ** 2).sum(
                    axis=0)).max(initial=0.))
            T = p * n + tau
            # the penetration, and the gap of a pair pressed while apart
            # (a pressure carried from the last step as surfaces part)
            violation = max(np.max(-gap, initial=0.),
                            np.max(gap[active], initial=0.))
            ev.append((T, C, float(violation), slip_left,
                       p, tau, gap))
        self.evaluations[response] = ev
        return ev

    def force(self, du: ndarray, response):
        ev = self.evaluate(du, response)
        return -sum(part["D"].T @ e[0].T.ravel()
                    for part, e in zip(self.parts, ev))

    def matrix(self, response):
        if response not in self.evaluations:
            raise RuntimeError("body contact: the tangent of a trial whose "
                               "force was not evaluated")
        return sum((part["D"].T @ (block_diagonal(e[1]) @ part["D"])).tocsr()
                   for part, e in zip(self.parts, self.evaluations[response]))

    def join(self, du: ndarray) -> bool:
        """Whether the bodies, their corners near a node of two fields
        moved by the converged ``du`` as the pairs' are, meet at pairs the
        step does not hold by more than the tolerance: those join the
        step's pairs (their rows and gaps from the step's start)."""
        term, problem, dim = self.term, self.problem, self.dim
        points, op = problem.points, problem.method_op
        self.check_passing(op.values(du))
        X0 = term.corners(points)
        X = X0.copy()
        corner = (np.arange(X.shape[1])[:, None] * points.n
                  + self.interface[None, :]).ravel()
        if self.interface_rows is None:
            self.interface_rows = term.rows(op, points, corner)
        X.reshape(dim, -1)[:, corner] += (self.interface_rows
                                          @ du).reshape(-1, dim).T
        found = term.finder.find_pairs(self.interface_support,
                                       points.x + op.values(du),
                                       points.volume, X,
                                       pressed=term.pressed(points))
        X0 = X0.reshape(dim, -1)
        joined = False
        for part, (B, A, normal, gap), tol in zip(self.parts, found,
                                                  term.tol):
            # a place where the step holds a corner already along the
            # same normal (the same corner of a neighbouring domain, or
            # this one with another partner) is not joined again; along
            # another normal it is (a pile's tip corner held by a side's
            # normal sank through the soil's along the vertical unjoined:
            # with friction 0.3 the pile settled 42 mm, now 6.5)
            new = gap < -tol
            held = part["keys"] // X0.shape[1]
            if new.any() and held.size:
                apart = cKDTree(np.vstack([X0[:, held], term.h * part["n"]])
                                .T).query(np.vstack(
                                    [X0[:, B[new]], term.h * normal[:, new]])
                                    .T)[0]
                new[new] = apart > FACING * term.h
            if not new.any():
                continue
            B, A, normal = B[new], A[new], normal[:, new]
            start = (normal * (X0[:, B] - X0[:, A])).sum(axis=0)
            self.add(part, op, points, B, A, normal, start, tol)
            joined = True
        if joined:
            self.evaluations = WeakKeyDictionary()
        return joined

    def check_passing(self, u: ndarray) -> None:
        """Refuse a step that carried bodies into each other where its
        pairs do not look (:class:`~skfem_mpm.errors.StepTooLongError`,
        cut back): a point off the step's interface (the points that
        reach a node of two fields at its start, where the pairs are)
        whose domain overlaps the other body's domains by more than the
        contact's tolerance at the step's end (moved by ``u``, dim x n),
        not at its start (domains of their initial size).  A block
        dropped 6 cells in one time step sank through a slab with no
        contact force; one that reached a slab from a cell above in one
        step ended 0.05 cells inside it, unpushed.  Looked for where a
        point moved more than the tolerance."""
        term, points = self.term, self.problem.points
        moved = np.abs(u).max(initial=0.)
        if not moved > min(term.tol):
            return
        end = points.x + u
        if self.apart is None:          # the step's start, found once
            self.apart = self.apart_at_start()
        for a, b, tol, outer, inner, reach in self.apart:
            # only points within 2 |u|_max (the bodies move towards each
            # other) of their overlap's reach at the start can overlap at
            # the end: a tree of these, not of both bodies, each check
            # (at 1e5 points, 60 ms a check of two 5e4-point trees)
            # (beyond PASSING_NEAR cells of motion: every point)
            near = [d < reach + 2 * moved if moved < PASSING_NEAR * term.h
                    else np.ones(d.size, dtype=bool) for _, d in (outer,
                                                                  inner)]
            entered = np.zeros(inner[0].size, dtype=bool)
            entered[near[1]] = overlapping(end, term.half, inner[0][near[1]],
                                           outer[0][near[0]], tol)
            inner = inner[0]
            if entered.any():
                raise StepTooLongError(
                    "step {}: bodies {} and {} went into each other where "
                    "the step's contact pairs do not look ({} points of body "
                    "{} overlap the other's domains at its end, not at its "
                    "start; it moved points by up to {:.3g} cells): cut "
                    "back".format(self.problem.step, a, b,
                                  int(entered.sum()), points.body[inner[0]],
                                  float(np.sqrt((u ** 2).sum(axis=0)).max()
                                        / term.h)))

    def apart_at_start(self) -> list:
        """For each contact and each of its bodies (``inner``) against
        the other (``outer``): the points of ``inner`` off the step's
        interface whose domains do not overlap ``outer``'s at the step's
        start, what :meth:`check_passing` looks at, as ``(a, b, tol,
        (outer, d), (inner, d), reach)``: each point with its distance
        (the largest over the axes) to the other's nearest point at the
        start (``inf`` beyond :data:`PASSING_NEAR` cells and ``reach``),
        and ``reach`` the distance within which two domains overlap."""
        term, points = self.term, self.problem.points
        off = np.ones(points.n, dtype=bool)
        off[self.interface] = False
        apart = []
        for (a, b, _), tol in zip(term.contacts, term.tol):
            first, second = (np.flatnonzero(term.point_field
                                            == term.field[k])
                             for k in (a, b))
            for inner, outer in ((second, first), (first, second)):
                inner = inner[off[inner]]
                if not (inner.size and outer.size):
                    continue
                reach = float(term.half.take(outer, axis=1).max()
                              + term.half.take(inner, axis=1).max())
                # looked for within PASSING_NEAR cells of motion (a
                # search without bound took 3 s at 1e5 points): beyond,
                # infinite
                d_in, d_out = (nearest_within(points.x, k, other, reach
                                              + 2 * PASSING_NEAR * term.h)
                               for k, other in ((inner, outer),
                                                (outer, inner)))
                close = d_in < reach
                keep = np.ones(inner.size, dtype=bool)
                keep[close] = ~overlapping(points.x, term.half, inner[close],
                                           outer[d_out < reach], tol)
                apart.append((a, b, tol, (outer, d_out),
                              (inner[keep], d_in[keep]), reach))
        return apart

    def heirs(self, k: int, B: ndarray, normal: ndarray) -> ndarray:
        """The second body's corners (``c n + p``) whose state the last
        step ended with contact ``k``'s pairs at the corners ``B`` start
        from (:meth:`add`), with normals ``normal`` (dim, m): each its
        own, but a pair whose place holds no pressure takes the state
        left at a place no pair of the step holds (the last step's pair
        of its node, which now pairs another corner): within a cell of
        it, pressed along its normal (within
        :data:`~skfem_mpm.solve.contact_pairs.HELD` in cosine), nearest
        the same grid node or one beyond it along the normal; of several,
        the nearest.  A node's pair is the second body's corner nearest
        it, and a body sliding along the other by a quarter of a cell
        past the grid pairs its nodes with the neighbouring corners, a
        corner spacing (half a cell with 2 x 2 points) from the last
        step's, as far as the next node's: the upper of two blocks
        stacked on a grid line, spreading over the lower under its
        weight (h = 1/158, benchmarks/contact_cost.py), started 8 pairs
        of 160 by its edge from nothing in its fourth step, their load
        all on the penalty (775 times the tolerance off), and the step
        took 11 Newton iterations in 6 solves where it takes 6 in 4."""
        term, points, dim = self.term, self.problem.points, self.dim
        pressed = term.pressed(points)
        own = np.flatnonzero(~pressed(k, B).any(axis=0))
        if not own.size:
            return B
        b = term.field[term.contacts[k][1]]
        mine = (np.arange(2 ** dim)[:, None] * points.n + self.interface[
            term.point_field[self.interface] == b][None, :]).ravel()
        push = pressed(k, mine)
        X = term.corners(points).reshape(dim, -1)
        which = np.unique(term.finder.place(np.hstack([X[:, B], X[:, mine]])),
                          axis=1, return_inverse=True)[1].ravel()
        left = push.any(axis=0) & ~np.isin(which[B.size:], which[:B.size])
        if not left.any():
            return B
        mine, push, which = mine[left], push[:, left], which[B.size:][left]
        near = cKDTree(X[:, mine].T).sparse_distance_matrix(
            cKDTree(X[:, B[own]].T), term.h, output_type="coo_matrix")
        o, r = near.row, own[near.col]
        if term.node_tree is None:
            term.node_tree = cKDTree(term.finder.mesh.p[:, :term.nv].T)
        node = term.node_tree.data.T[:, term.node_tree.query(
            np.hstack([X[:, mine[o]], X[:, B[r]]]).T)[1]]
        apart = node[:, :o.size] - node[:, o.size:]
        takes = (np.abs((normal[:, r] * apart).sum(axis=0))
                 >= HELD * np.sqrt((apart ** 2).sum(axis=0))) & (
            (normal[:, r] * push[:, o]).sum(axis=0)
            > HELD * np.sqrt((push[:, o] ** 2).sum(axis=0)))
        # nearest first, each receiver and each place left once
        order = np.argsort(near.data[takes], kind="stable")
        r, o = r[takes][order], o[takes][order]
        first = np.sort(np.unique(r, return_index=True)[1])
        r, o = r[first], o[first]
        first = np.unique(which[o], return_index=True)[1]
        out = B.copy()
        out[r[first]] = mine[o[first]]
        return out

    def add(self, part, op, points, B, A, normal, gap, tol, source=None):
        """Pairs ``(B, A)`` with their normals and gaps at the step's
        start joined to a contact's ``part`` (empty at first), each
        starting from the state the last step ended with at the second
        body's corner ``source`` (:meth:`heirs`; ``B`` where not given)."""
        term = self.term
        first, second = term.field[list(term.contacts[part["contact"]][:2])]
        field = term.point_field[self.interface]
        nearB = term.companions(points, B, self.interface[field == second])
        nearA = term.companions(points, A, self.interface[field == first])
        # with friction a pair's stick is carried per corner (its
        # traction, point state at its place): the mean's rows, tried
        # there, moved a rough pile's settlement in 20 steps by 4.6%
        # smooth: each corner on its side facing the other body by GIMP's
        # weights of the side (B's faces A's face, whose normal is n, A's
        # B's, -n); with friction, tried, a square pile in 3D with cpGIMP
        # leant (sideways 1.8% of its settlement, mu = 0.3; 1.3% loaded
        # heavily)
        D = term.shared_rows(op, points, B, nearB, normal) \
            - term.shared_rows(op, points, A, nearA, -normal) \
            if term.contacts[part["contact"]][2].friction == 0. \
            else term.rows(op, points, B) - term.rows(op, points, A)
        before = part["n"].shape[1] if "n" in part else 0
        onB = np.stack([nearB[0] + before, nearB[1] % points.n])
        onA = np.stack([nearA[0] + before, nearA[1] % points.n])
        # a penetration at the step's start is closed: the corners of
        # deformed domains, moved through each point's own gradient, are
        # not quite where the grid field moved the last step's pairs
        # (whose penetration the last step held within the tolerance),
        # and the penalty would read the difference as a push (1e3 times
        # the load at a pile's tip; a block landing on a slab seeded in a
        # polygon, a staircase of domains, was thrown off with 12 times
        # the kinetic energy it fell with)
        deep = gap < -tol
        if deep.any():
            logger.debug("step %d: %d pairs start %.3g deep (tolerance "
                         "%.3g), closed", self.problem.step,
                         int(deep.sum()), float(-gap.min()), tol)
        # the state the last step ended with at the second body's corners,
        # so a step starts from it: a pair pressed then starts at its
        # pressure and penetration, with its friction traction (from
        # zero, and closed, a pair forgave the penetration, and a sticking
        # one the slip, the tolerance allows in every step: a pile's
        # settlement was 40% off after 10 steps with a soft penalty)
        # a pair that takes the state of its node's last pair, another
        # corner (:meth:`heirs`), starts at its own gap, closed as a new
        # pair's: that pair's gap was its own corners' (inherited, a pile
        # driven through von Mises soil, test_a_pile_driven_by_a_rough_
        # cap_passes_its_soil_s_top_row, went another path from its
        # sixth step and ended at a tip resistance of 4.4 c_u where 8.2)
        n = points.n
        heir = np.zeros(B.size, dtype=bool) if source is None \
            else source != B
        p, g, tau, rate = carried(points.state, part["contact"],
                                  B if source is None else source,
                                  normal, n, term.place(points, B))
        pressed = p > 0
        # a pair that starts a quarter of a cell deep is a misread, not
        # a penetration (a pressed pair's corners stay within about the
        # tolerance of where the last step held them): a pile
        # whose glued cap had settled a sliver into the supports of the
        # soil's surface nodes beside it took a leaning normal there
        # (every candidate showing the bodies overlapping) and a pair of
        # a side corner with the soil's top corner a cell above it, 0.45
        # cells deep, closed, held the pile like friction (cpGIMP, smooth:
        # 7-9% less settlement in 2 or 10 steps than in 1; not fixed,
        # docs/contact.md)
        misread = gap < -MISREAD * term.h
        name = term.contacts[part["contact"]][2].name
        if misread.any() and name not in term.told_deep:
            term.told_deep.add(name)
            logger.warning(
                "step %d: contact %r: %d pairs start "
                "%.2g cells deep (bodies wrapped round each "
                "other at a node: the answer may depend on the number of "
                "steps; docs/contact.md, 'not yet good enough'; said once "
                "a run)", self.problem.step, name, int(misread.sum()),
                float(-gap[misread].min() / term.h))
        gap = np.where(pressed & ~heir, g, np.maximum(gap, 0.))
        start = np.where(pressed, p, 0.)
        # the pressure the step is expected to end at, by the last step's
        # rate (zero after a step whose pairs changed): from the last
        # step's pressure, the step's added pressure was all on the
        # penalty, and its first round ended 500 times the tolerance off
        # (a round more in every step of two elastic blocks); a pile
        # driven through its soil, whose pairs join and start deep in
        # most steps, went a path 30% stiffer with a rate everywhere
        # (not in a run's first step: a rate carried in a staged run's
        # points is another run's); a Coulomb pair's friction traction
        # scaled alike (kept as it was over a pressure predicted to fall,
        # it lay outside the cone, and Newton cycled between stick and
        # slip: a sideways load easing off in dynamics was cut back)
        problem = self.problem
        ahead = start if problem.f_old <= 0. else np.maximum(
            start + np.where(deep, 0., rate) * (problem.f_new
                                                - problem.f_old), 0.)
        friction = term.contacts[part["contact"]][2].friction
        if friction != "rough":
            tau = tau * np.where(start > 0, ahead / np.maximum(start, 1e-300),
                                 1.)
        lam = np.where(pressed, ahead + term.kappa[part["contact"]]
                       * np.where(heir, 0., g), 0.)
        part["steady"] = part.get("steady", True) and not deep.any() \
            and before == 0
        corners = term.corners(points)[0].size
        # rough: the pairs that stick through the step's Newton iterations
        # are those pressed or touching at its start (:meth:`rough_changes`
        # after Newton); a pair sticking wherever a trial pressed it made
        # Newton cycle between two states (a rough square pile in 3D with
        # B-splines, residuals 0.39 and 0.15 in turn, at every cut-back)
        held = pressed | (gap <= tol)
        for key, value in (("D", D), ("n", normal), ("gap", gap),
                           ("lam", lam), ("tau", tau), ("held", held),
                           ("start", start),
                           ("changed", np.zeros_like(held)),
                           ("keys", B * corners + A),
                           ("sides", np.hstack([onB, onA])),
                           ("side", np.repeat([0, 1], [onB.shape[1],
                                                        onA.shape[1]]))):
            if key not in part:
                part[key] = value
            elif key == "D":
                part[key] = vstack([part[key], value]).tocsr()
            else:
                part[key] = np.concatenate([part[key], value], axis=-1)

    def settle(self, problem, trial, du: ndarray) -> bool:
        """After Newton: ``True`` when the bodies meet nowhere else than at
        the step's pairs (:meth:`join`), every pair's penetration (and a
        pressed pair's gap) and every sticking pair's slip is within the
        contact's tolerance in cells, and the penalty's force on the
        deepest penetration within the tolerance of the largest pair's
        force (the multipliers have settled: :func:`unsettled`, by the
        grid's forces where a round closed no more); else the
        multipliers take
        the converged tractions (augmented Lagrangian), or the new pairs
        join, or rough pairs let go or join (:meth:`rough_changes`), and
        the step is solved again (from a fresh tangent where pairs joined
        or changed: :attr:`reshaped`; after a join, :attr:`off_by` is
        how far the joined pairs, at no pressure yet, leave it)."""
        self.reshaped, self.off_by = True, 0.
        if self.join(du):
            # as far off as the joined pairs, at no pressure yet, make it
            # (their penetration beyond the tolerance all on the penalty:
            # the update after the next solve is as certain as after a
            # step's first)
            self.off_by = self.worst(self.evaluate(du, trial.response),
                                     rounds=False)
            self.evaluations = WeakKeyDictionary()
            logger.debug("step %d: bodies met beyond the step's pairs; "
                         "solving again (%.2g of the tolerance)",
                         problem.step, self.off_by)
            return False
        ev = self.evaluate(du, trial.response)
        if self.rough_changes(ev, du):
            self.evaluations = WeakKeyDictionary()
            return False
        worst = self.worst(ev)
        if worst <= 1.:
            return True
        self.reshaped, self.off_by = False, worst
        for part, e in zip(self.parts, ev):
            part["lam"], part["tau"] = accelerated(part, e[4]), e[5]
        self.evaluations = WeakKeyDictionary()
        problem.counters["contact_updates"] += 1
        logger.debug("step %d: body contact %.2g of the tolerance; "
                     "augmented-Lagrangian update", problem.step, worst)
        return False

    def worst(self, ev, rounds: bool = True) -> float:
        """How far the pairs of :meth:`evaluate`'s ``ev`` are from
        settling, in their tolerances (:meth:`settle`: 1 or less holds):
        the largest penetration (or gap of a pressed pair) and stick slip
        in cells, and how far the multipliers are from settled
        (:func:`unsettled`); ``rounds``: ``ev`` ends an augmented-
        Lagrangian round, whose penetration the next round's judgement
        of a stalled round reads (not after pairs joined: a state no
        round ended at)."""
        # in cells, and relative to the largest pair's force: with a
        # penalty from the softer body, a penetration of the tolerance in
        # cells was a quarter of a soft block's compression; a floor of
        # 1e-6 of the tolerance for bodies that touch and do not press
        return max((max(max(e[2], e[3]) / tol, unsettled(
            part if rounds else dict(part, depth=None), e, kappa, tol,
            c.tolerance))
            for part, e, tol, kappa, (_, _, c) in zip(
                self.parts, ev, self.term.tol, self.term.kappa,
                self.term.contacts)),
            default=0.)

    def rough_changes(self, ev, du: ndarray) -> bool:
        """After Newton, rough contacts: a pair that stuck but was found
        apart (unpressed, its gap beyond the tolerance) lets go; one
        pressed that did not stick joins, sticking
        from where its corners met within the step (their relative motion
        scaled by the start gap over its closing: the multiplier ``kappa
        P`` of that motion); each pair changes once a step, so the rounds
        end.  ``True`` when any changed (the step is solved again)."""
        dim, changes = self.dim, 0
        for (_, _, contact), part, e, kappa, tol in zip(
                self.term.contacts, self.parts, ev, self.term.kappa,
                self.term.tol):
            if contact.friction != "rough":
                continue
            p, gap, n = e[4], e[6], part["n"]
            # apart: unpressed and open beyond the tolerance, as a pair
            # is held at the start; a pair touching unpressed (p = 0,
            # its gap within the tolerance) let go, and a block in simple
            # shear beside a rough slab carried 0.75 of the shear.  Not
            # with B-splines, whose touching pairs let go unpressed as
            # before: held, a rough spline pile 1.5 cells wide in elastic
            # soil (tests' trial_pile) did not settle in 30 rounds at step
            # 1, at every cut-back
            apart, join = rough_apart_join(
                part["held"], part["changed"], p,
                gap if self.term.weights is None else np.full_like(
                    gap, np.inf), tol)
            part["steady"] &= not (apart.any() or join.any())
            part["tau"][:, apart] = 0.
            if join.any():
                w = (part["D"] @ du).reshape(-1, dim).T[:, join]
                g0 = part["gap"][join]
                met = np.clip(g0 / np.maximum(g0 - gap[join], 1e-300),
                              0., 1.)
                n = n[:, join]
                motion = w * met
                part["tau"][:, join] = kappa * (
                    motion - (motion * n).sum(axis=0) * n)
            part["held"] = (part["held"] & ~apart) | join
            part["changed"] |= apart | join
            if (apart | join).any():    # another problem: not extrapolated
                part.pop("update", None)
            changes += int(apart.sum() + join.sum())
        if changes:
            logger.debug("step %d: %d rough pairs came apart or joined; "
                         "solving again", self.problem.step, changes)
        return bool(changes)

    def check_slivers(self, problem, du: ndarray) -> None:
        """B-splines: refuse a converged increment ``du`` that moved a
        pair's corner by more than :data:`~skfem_mpm.solve.contact.CARRIED`
        cells through grid nodes whose support holds less than
        :data:`~skfem_mpm.solve.problem.SLIVER_SUPPORT` cells of material
        (:func:`~skfem_mpm.solve.contact.check_carried_corners`: the ghost
        penalty of ``ghost="auto"`` ties them).  The splines of the soil's
        corners under a pile's tip reach nodes inside the pile's hole
        that the soil barely holds: with 3 x 3 points per cell (h = 0.054,
        a user trial) those nodes carried the corners down with the pile,
        0.27 cells in a step, and the pile sank through the soil, its cap
        pushing with 0.02 where 11 a step was due, every step converged."""
        term = self.term
        if term.weights is None or not any(
                part["keys"].size for part in self.parts):
            return
        points, dim, h = problem.points, self.dim, term.h
        sliver = operator_slivers(problem.op, points.volume,
                                  SLIVER_SUPPORT * h ** dim)
        if not sliver.size:
            return
        X = term.corners(points).reshape(dim, -1)
        corner = np.unique(np.concatenate([
            np.divmod(part["keys"], X.shape[1]) for part in self.parts],
            axis=None))
        moved = spline_rows(term.weights, problem.method_op, X[:, corner],
                            corner % points.n).tocsc()[:, sliver] \
            @ du.reshape(-1, dim)[sliver]
        check_carried_corners(np.sqrt((moved ** 2).sum(axis=1)),
                              X[:, corner], h, problem.step,
                              "B-splines reaching past a body's surface")

    def commit(self, problem, trial, du: ndarray, new, record) -> None:
        """The force of each contact on its second body; the record on
        the grid: the reactions of the fields' copies of a held DOF summed
        on the grid's DOF, the active cells of every field, a node's
        increment that of the lowest-numbered field with material there
        (the fields' copies differ where bodies slide)."""
        self.check_slivers(problem, du)
        ev = self.evaluate(du, trial.response)
        self.committed = ev
        new.state = dict(new.state)
        n = problem.points.n
        X = self.term.corners(problem.points).reshape(self.dim, -1)
        for part, e in zip(self.parts, ev):
            # every corner of the second body at a pair's place (corners
            # that neighbouring domains share): the next step may pair
            # another of them there
            B = part["keys"] // X.shape[1]
            b = self.term.field[self.term.contacts[part["contact"]][1]]
            own = np.flatnonzero(self.term.point_field[
                self.interface] == b)
            mine = (np.arange(2 ** self.dim)[:, None] * n
                    + self.interface[own][None, :]).ravel()
            near = cKDTree(X[:, B].T).sparse_distance_matrix(
                cKDTree(X[:, mine].T), FACING * self.term.h,
                output_type="coo_matrix")
            m = B.size
            to, frm = np.divmod(np.unique(np.r_[B, mine[near.col]] * m
                                          + np.r_[np.arange(m), near.row]),
                                m)
            step = problem.f_new - problem.f_old
            # of the pairs pressed at the step's start, or of every pair in
            # a quasi-static run's first step under loads all ramped (from
            # nothing, in proportion): a pair an impact pressed within the
            # step would be predicted at twice the impact's pressure
            counted = (part["start"] > 0) | (
                problem.f_old <= 0. and problem.run.dynamics is None
                and problem.run.loads.all_ramped)
            rate = np.where(counted, e[4] - part["start"], 0.) / step \
                if step > 0 and part["steady"] else np.zeros_like(e[4])
            values = np.vstack([e[4] * part["n"],
                                np.where(e[4] > 0, e[6], 0.) * part["n"],
                                e[5], np.where(e[4] > 0, rate, 0.)
                                * part["n"]])
            for row, value in zip(traction_state(part["contact"], self.dim),
                                  values):
                # summed per corner c n + p, the table's flat index (on
                # its two indices np.add.at took three times longer)
                table = np.zeros(len(row) * n)
                np.add.at(table, to, value[frm])
                table = table.reshape(-1, n)
                for name, column in zip(row, table):
                    new.state[name] = column
        op, dim = problem.method_op, self.dim
        if self.term.weights is not None:
            offset = np.array([[new.state[name] for name in row]
                               for row in corner_state(dim)]) \
                + self.term.corner_motion(op, problem.points, du)
            # a corner moved a cell from where its domain's is goes back
            # there: the splines of a pile head's corner reach nodes above
            # it that its points barely hold, and a step moved it 66 cells
            # (no pair, no force), out of the grid, where no node carries
            # it (the next step failed)
            domain = self.term.domain_offsets(new)
            apart = np.sqrt(((offset - domain) ** 2).sum(axis=0)).max(
                axis=0) > self.term.h
            if apart.any():
                logger.debug("step %d: the corners of %d points drifted a "
                             "cell from their domains; back on them",
                             problem.step, int(apart.sum()))
                offset[:, :, apart] = domain[:, :, apart]
                problem.counters["contact_corners_reset"] += int(apart.sum())
            for a, row in enumerate(corner_state(dim)):
                for c, name in enumerate(row):
                    new.state[name] = offset[a, c]
        elif not self.term.finite:
            H = op.gradients(du)
            for a, row in enumerate(gradient_state(dim)):
                for b, name in enumerate(row):
                    new.state[name] = new.state[name] + H[a, b]
        record.contact_forces = self.term.declared_forces(
            self.parts, ev, new, self.interface)
        N = record.n_dofs // int(self.term.field.max() + 1)
        dofs = record.reaction_dofs % N
        record.reaction_dofs = np.unique(dofs)
        record.reaction_values = np.bincount(
            np.searchsorted(record.reaction_dofs, dofs),
            weights=record.reaction_values,
            minlength=record.reaction_dofs.size)
        record.n_dofs = N
        if record.elements is not None:
            record.elements = np.unique(record.elements % self.term.cells)
            fields = du.reshape(-1, N)                 # (fields, N)
            active = np.zeros(du.size, dtype=bool)
            active[problem.op.active_dofs] = True
            first = np.argmax(active.reshape(-1, N), axis=0)
            record.u = fields[first, np.arange(N)]

    def finish(self, problem, new, record) -> None:
        """In dynamics, an impact is plastic along the normal: per
        pressed pair, the points of each side's corners at its place
        (:meth:`BodyContact.companions`) lose the relative normal
        velocity and acceleration between the two sides' mass averages,
        momentum kept: the reduced mass's impulse, divided by the most
        pairs any of those points is in (a point of several pairs takes a
        share from each: along a flat face the whole), each side's points
        changed alike.  Without this a body set down on another
        rebounds, and the contact chatters; with the points of one corner
        taken per pair, in the pairs' order, a symmetric landing turned."""
        if new.velocity is None:
            return
        masses = problem.run.masses
        v, a = new.velocity.copy(), new.acceleration.copy()
        for part, e in zip(self.parts, self.committed):
            pressed = e[4] > 0
            pair, point = part["sides"]
            on = pressed[pair]
            pair, point, side = pair[on], point[on], part["side"][on]
            count = np.bincount(point, minlength=masses.size)
            most = np.zeros(pressed.size)
            np.maximum.at(most, pair, count[point])
            mass = np.zeros((2, pressed.size))
            np.add.at(mass, (side, pair), masses[point])
            n = part["n"]
            reduced = np.prod(mass, axis=0) / np.maximum(
                mass.sum(axis=0), 1e-300) / np.maximum(most, 1.)
            sign = np.where(side == 0, -1., 1.)
            for field in (v, a):
                mean = np.zeros((2, pressed.size))
                np.add.at(mean, (side, pair), masses[point]
                          * (n[:, pair] * field[:, point]).sum(axis=0))
                w = (mean[0] / np.maximum(mass[0], 1e-300)
                     - mean[1] / np.maximum(mass[1], 1e-300))
                kick = sign * (reduced * w)[pair] / mass[side, pair]
                np.add.at(field.T, point, (kick * n[:, pair]).T)
        new.velocity, new.acceleration = v, a
        if record.energy is not None:
            record.energy["kinetic"] = .5 * float(masses @ (v ** 2).sum(0))
