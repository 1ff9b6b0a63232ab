"""The pairs of corners at which two bodies in contact meet
(:mod:`skfem_mpm.solve.body_contact`).

At every grid node where both bodies' fields have material, a normal
from the first body to the second is chosen among candidates (the line
between the two bodies' centroids near the node, each body's direction
from its centroid to the node, and the grid axes) as the one along which
the bodies' domain corners near the node lie farthest apart, counting
only the first body's corners that face the second's across it
(:meth:`PairFinder.separating_normal`, :meth:`PairFinder.facing`), or
a grid axis across which both bodies' corners there are level faces
(:meth:`PairFinder.level`), and every other grid axis along which the
bodies touch there too (a body's corner in a notch of the other: a
pile's tip); per normal the second
body's surface corner nearest the node and the first body's corner
nearest that one, facing it or under it where the first body reaches on
beyond the second as a surface, make the node's pair
(:meth:`PairFinder.extreme`, :meth:`PairFinder.facing`; with B-splines,
where a body ends within a cell of the node, or within half a cell past
it, every surface corner within half a cell: :meth:`PairFinder.surface`),
one per place of the second body's corner and normal, and at a place of the first body's those
nearest each other (two tip corners facing one corner are both kept);
after the run's start a pair deeper than :data:`DEEPEST` cells is none
(the first body on both sides of the second at the node), as is, smooth,
one whose first body's corner penetrates along its normal by more than
the contact's tolerance while it lies within the tolerance of the second
body's face across it (:meth:`PairFinder.poking`), and a corner
pressed along its normal at the last step's end takes the nearest
corner within that depth instead.
"""
from weakref import ref

import numpy as np
from numpy import ndarray
from scipy.spatial import cKDTree

__all__ = ["PairFinder", "tangents", "overlapping", "ACROSS", "AXIS",
           "FACING"]

#: the weight of the distance across the normal against the position
#: along it in choosing a pair's corners (:meth:`PairFinder.extreme`)
ACROSS = .5

#: the cells of gap a grid axis is preferred by among the candidate
#: normals of a node (a body's edge shows a small positive gap along a
#: leaning direction to the other body's surface just beyond it)
AXIS = .05

#: corners closer than this many cells across a normal are level (the
#: soil's side and a pile's tip stay so as both deform)
FACING = 1e-2

#: the cells the two bodies' corners must overlap by across a normal for
#: it to be preferred among those alike in gap, and across a grid axis
#: for it to be a second face of a node, beside its best normal (a body's
#: corner in a notch of the other, a pile's tip: a cell; the staircase of
#: domain corners along a deformed flat interface: a few thousandths)
SPAN = .1

#: the cells the first body beyond an end of the second's range may rise
#: along a normal, and still be a floor the second's end rests on
#: (:meth:`PairFinder.facing`: the soil beside a sinking footing, a
#: hundredth of a cell; the soil round a pile's tip, cells)
FLOOR = .1

#: the cells along a grid axis within which a body's corners at a node
#: are level, a face across the axis (:meth:`PairFinder.level`: a block's
#: bottom and the slab under it; a slab dented by a landing block)
LEVEL = .1

#: a pair deeper than this many cells after the run's start is not a
#: contact (the first body on both sides of the second at its node)
DEEPEST = .5

#: the cosine to the centroids' line the last grid axis (the vertical) is
#: preferred by among candidates alike in gap (about 3 degrees)
LAST = .05

#: the cosine to the direction a node was pressed along at the last
#: step's end above which a candidate keeps it (with friction)
HELD = .9

#: the pressures summed at a node, relative to their sizes summed, below
#: which they cancel and hold the node along no direction
CANCELLED = 1e-6

#: candidate normals alike in gap whose cosines to the centroids' line
#: differ by less than this are tied (with friction the first is taken)
TIED = 1e-9


def overlapping(x: ndarray, half: ndarray, inner: ndarray,
                outer: ndarray, depth: float) -> ndarray:
    """Which of the points ``inner`` (indices) have a box domain that
    overlaps one of the points ``outer``'s by more than ``depth`` along
    every axis: positions ``x`` (dim, n), half-lengths ``half`` (dim, n).
    The points of each farther than twice the reach of two domains from
    the other's box are left out of the search (two bodies stacked at
    1e5 points: a tree of each whole body took 17 ms at a run's start,
    40 times what the rows along their interface take).

    >>> x = np.array([[0., .9, 2.], [0., .1, 0.]])
    >>> overlapping(x, np.full((2, 3), .5), np.array([1, 2]),
    ...             np.array([0]), .05).tolist()
    [True, False]
    """
    out = np.zeros(inner.size, dtype=bool)
    if not (inner.size and outer.size):
        return out
    reach = float(half.take(outer, axis=1).max()
                  + half.take(inner, axis=1).max())
    a, b = x.take(inner, axis=1), x.take(outer, axis=1)
    near_a, near_b = (np.all((c >= d.min(axis=1)[:, None] - 2 * reach)
                             & (c <= d.max(axis=1)[:, None] + 2 * reach),
                             axis=0) for c, d in ((a, b), (b, a)))
    if not (near_a.any() and near_b.any()):
        return out
    near_a, near_b = np.flatnonzero(near_a), np.flatnonzero(near_b)
    inner, outer = inner[near_a], outer[near_b]
    near = cKDTree(b[:, near_b].T, balanced_tree=False).sparse_distance_matrix(
        cKDTree(a[:, near_a].T, balanced_tree=False), reach, p=np.inf,
        output_type="ndarray")
    o, i = outer[near["i"]], inner[near["j"]]
    hit = (np.abs(x[:, i] - x[:, o]) < half[:, i] + half[:, o]
           - depth).all(axis=0)
    out[near_a[near["j"][hit]]] = True
    return out


def projection(direction: ndarray, node: ndarray, X: ndarray) -> ndarray:
    """Per entry, its position ``X`` (dim, k) along the ``direction``
    (dim, m) of its node (``node``, k): ``(direction[:, node] *
    X).sum(axis=0)`` to the bit, a component at a time (the gathered
    product, laid out entry by entry as numpy's fancy indexing gives it,
    and its sum over the short axis took 0.15 ms a call at 2e4 entries,
    3.7 ms of a search for pairs at 1e5 points; a tenth of that so).

    >>> d = np.array([[1., 0.], [0., 1.]])          # x at node 0, y at 1
    >>> projection(d, np.array([0, 1, 1]), np.array([[2., 3., 4.],
    ...                                               [5., 6., 7.]])).tolist()
    [2.0, 6.0, 7.0]
    """
    out = direction[0].take(node) * X[0]
    out += 0.           # numpy's sum starts from +0 (a lone -0 is +0 there)
    for a in range(1, len(direction)):
        out += direction[a].take(node) * X[a]
    return out


def tangents(normal: ndarray) -> list:
    """Unit tangents (dim - 1 of them, each (dim, m)) orthogonal to the
    unit ``normal`` (dim, m) and to each other."""
    if normal.shape[0] == 1:
        return []
    if normal.shape[0] == 2:
        return [np.stack([-normal[1], normal[0]])]
    a = np.zeros_like(normal)
    a[np.where(np.abs(normal[0]) < .9, 0, 1), np.arange(normal.shape[1])] = 1.
    t = a - (a * normal).sum(axis=0) * normal
    t /= np.sqrt((t ** 2).sum(axis=0))
    return [t, np.cross(normal, t, axis=0)]


class PairFinder:
    """Finds the pairs of every contact of a run.

    Parameters
    ----------
    contacts
        ``(first, second, Contact)`` of the run.
    field
        The field of each body.
    mesh
        The extended mesh of the run's fields.
    vertices
        The vertices of one field (the grid's).
    cell_size
        The grid's cell size.
    columns
        B-splines: where a body ends within a cell of a node, every
        surface corner within half a cell of it makes a pair
        (:meth:`surface`), not only the nearest.
    """

    def __init__(self, contacts, field: ndarray, mesh, vertices: int,
                 cell_size: float, columns: bool = False):
        self.contacts, self.field, self.mesh = contacts, field, mesh
        self.nv, self.h, self.dim = vertices, cell_size, mesh.dim()
        self.columns = columns
        self._shared = None         # :meth:`shared_nodes`, the last

    def shared_nodes(self, support, weight) -> list:
        """Per contact, what a search for pairs reads of the grid nodes'
        supports ``support`` (points, nodes of every field) and the
        points' volumes ``weight`` alone: the nodes where both bodies'
        fields have material (``shared``), and per body (first, second)
        the positive supports of its field's copies of those nodes
        (points, shared), its volume on them and the (node, corner)
        entries of its corners there (:meth:`corner_entries`).  Kept for
        the last ``support`` and ``weight`` (the same objects: a step's
        searches read the same, 2 ms of each at 1e5 points)."""
        kept = self._shared
        if kept is not None and kept[0]() is support \
                and kept[1]() is weight:
            return kept[2]
        nv, out = self.nv, []
        for a, b, _ in self.contacts:
            blocks = [support[:, self.field[k] * nv:(self.field[k] + 1) * nv]
                      .tocsr() for k in (a, b)]
            blocks = [Sk.multiply(Sk > 0).tocsr() for Sk in blocks]
            mass = [Sk.T @ weight for Sk in blocks]
            shared = np.flatnonzero((mass[0] > 0) & (mass[1] > 0))
            near = [Sk[:, shared] for Sk in blocks]
            out.append((shared, near, [m[shared] for m in mass],
                        [self.corner_entries(Sk, 2 ** self.dim)
                         for Sk in near]))
        self._shared = (ref(support), ref(weight), out)
        return out

    def find_pairs(self, support, x, weight, X, start: bool = False,
                   pressed=None) -> list:
        """The pairs ``(B, A, n, g)`` of every contact for points at ``x``
        (dim, n) of volumes ``weight``, their domains' corners at ``X``
        (dim, corners, n), the grid nodes' supports ``support`` (points,
        nodes of every field); pairs deeper than :data:`DEEPEST` cells are
        left out, except at the run's ``start`` (where they are bodies
        that overlap, which the caller refuses).  ``pressed(k, corner)``
        gives contact ``k``'s pressure vectors ``p n`` (dim, m) at the
        second body's corners ``c n + p`` where the last step ended (a
        node with friction keeps the normal it was pressed along:
        :meth:`separating_normal`)."""
        dim = self.dim
        out = []
        for k, ((a, b, contact), (shared, near, mass, nodes)) in enumerate(
                zip(self.contacts, self.shared_nodes(support, weight))):
            smooth = contact.friction == 0.
            if shared.size == 0:          # the bodies are cells apart
                none = np.zeros(0, dtype=np.int64)
                out.append((none, none, np.zeros((dim, 0)), np.zeros(0)))
                continue
            centre = [(Sk.T @ (weight * x).T).T / m
                      for Sk, m in zip(near, mass)]
            node_x = self.mesh.p[:, shared]
            entries = [(node, corner, X.reshape(dim, -1).take(corner, axis=1))
                       for node, corner in nodes]
            held = None
            if pressed is not None and not smooth:
                held = np.zeros((dim, shared.size))
                push = pressed(k, entries[1][1])
                np.add.at(held.T, entries[1][0], push.T)
                # pushes that cancel (a pile one cell wide: its two
                # sides' corners at one node) hold no direction: their
                # round-off's direction took x at one side's node and the
                # tip's vertical at the other's, and a symmetric pile
                # pulled with friction 0.3 took a sideways force of 41%
                # of its pull
                total = np.zeros(shared.size)
                np.add.at(total, entries[1][0],
                          np.sqrt((push ** 2).sum(axis=0)))
                held[:, np.sqrt((held ** 2).sum(axis=0))
                     <= CANCELLED * total] = 0.
            slot, normal = self.separating_normal(entries, centre, node_x,
                                                  smooth, held)
            node_x = node_x[:, slot]
            entries = [self.spread(e, slot, shared.size) for e in entries]
            faces, _, under = self.facing(entries, normal,
                                          x[:, entries[0][1] % x.shape[1]])
            wide = tuple(e[..., faces | under] for e in entries[0])
            entries[0] = tuple(e[..., faces] for e in entries[0])
            if self.columns:
                slot, B = self.surface(entries, normal, node_x)
                # the entries' nodes are the normals' so far (a node with
                # no pair after surface() left the count short: two free
                # B-spline blocks colliding failed with an IndexError)
                entries[0] = self.spread(entries[0], slot, normal.shape[1])
                wide = self.spread(wide, slot, normal.shape[1])
                normal = normal[:, slot]
            else:
                B = self.extreme(entries[1], normal, node_x, True)
            XB = X.reshape(dim, -1)[:, B]
            # the first body's corner: of those facing the second's, and
            # those at an end of the range they share where the first body
            # reaches on beyond it as a surface (:meth:`facing`,
            # ``under``), the nearest.  A stiff block's edge on a soft one
            # whose Poisson expansion carried the soft block's edge corner
            # past it took a corner a domain inside, and the stress in
            # its corner reached 2.54 p from the seventh of 10 steps; a
            # rough pile one cell wide, its sides inside cells, resting on
            # a surface on a grid line, kept one pair in all (the base's
            # outer corners found the soil's corner under its middle).
            # Not where the first body rises beyond, a notch round the
            # second's corner (a pile's tip in a hole): paired there, tip
            # corners inside cells made a pile 10-21% stiffer than on
            # finer grids
            A = self.extreme(wide, normal, XB, False)
            # a corner pressed along its normal (within HELD in cosine) at
            # the last step's end takes its partner among the first
            # body's corners at most DEEPEST cells beyond it along the
            # normal, where the nearest lies deeper (dropped below): a
            # soil point the tip of a pile had passed, wrapped round the
            # tip's corner, put the corner its downward candidates chose
            # 0.5-0.8 cells above the tip (0.58 in trial 53), the tip's
            # pressed corner kept only a sideways pair, and a pile driven
            # by a rough cap stopped at every cut-back
            if pressed is not None and not start:
                push = pressed(k, B)
                size = np.sqrt((push ** 2).sum(axis=0))
                held = ((normal * push).sum(axis=0) > HELD * size) \
                    & (size > 0.)
                if held.any():
                    on = held[wide[0]]
                    A[held] = self.extreme(
                        tuple(e[..., on] for e in wide), normal, XB, False,
                        DEEPEST * self.h)
            XA = X.reshape(dim, -1)[:, A]
            gap = (normal * (XB - XA)).sum(axis=0)
            # a node with the first body on both sides of the second (a
            # GIMP support two cells wide across a pile two cells wide)
            # pairs one side of the second with the far side of the
            # first, cells deep: no contact (kept, such a pair took the
            # place of the side's own pair below, and a symmetric pile
            # moved sideways by 6% of its settlement)
            real = np.ones(gap.size, dtype=bool) if start else \
                gap > -DEEPEST * self.h
            if smooth and not self.columns:
                real &= ~self.poking(entries[1], normal, XA, gap,
                                     contact.tolerance * self.h)
            # one pair per place of the second body's corner, then of the
            # first body's (and, smooth, normal): corners that
            # neighbouring domains share, each moved by its own point's
            # cell, would be two constraints on one place that disagree
            # by round-off and lock the augmented Lagrangian; of pairs at
            # one place the one whose corners lie nearest each other (a
            # GIMP pile's tip off grid lines: its corner's pair, facing
            # the soil's corner next to the hole's, took that corner from
            # the pair right above it, whose multiplier then settled by
            # 13% a round, and the first step was cut back 7 times).
            # With friction a pair holds its corners in every direction,
            # and two at one place, holding it to two corners of the
            # other body, did not settle (a GIMP pile at a tolerance of
            # 1e-5: 30 rounds).  Pairs as near as the nearest at a first
            # body's place are kept with it: a pile's two tip corners, one
            # cell apart, both face the soil's corner under the pile's
            # middle, and the one kept by the order alone left the other
            # unheld (the symmetric pile turned about it: cpGIMP's failed
            # at step 3, or, its tip on a grid line, drifted sideways by
            # 12% of its settlement)
            # with friction a corner pressed at the last step's end keeps
            # a pair along the direction it was pressed, where it has one,
            # before nearer ones: a pile one cell wide, its tip inside a
            # cell, its tip corners pressed down, found the soil's side
            # corner above them a 500th of a cell nearer than the soil's
            # corner under the tip, paired sideways, and hung on its
            # sides' friction (cpGIMP, friction 0.3: failed at step 2)
            along = None
            if pressed is not None and contact.friction != "rough" \
                    and not smooth:
                push = pressed(k, B)
                size = np.sqrt((push ** 2).sum(axis=0))
                along = (normal * push).sum(axis=0) > HELD * size
            kept = self.one_per_place(XB, XA, normal, np.flatnonzero(real),
                                      smooth, along)
            out.append((B[kept], A[kept], normal[:, kept], gap[kept]))
        return out

    @staticmethod
    def poking(entries, normal, XA, gap, tol) -> ndarray:
        """Which pairs (m,) penetrate along their ``normal`` (dim, m),
        by their ``gap`` (m,), more than ``tol``, while their first
        body's corner ``XA`` (dim, m) lies inside the range of the second
        body's corners at the pair's node (``entries``, node the pair's
        index) across it by less than ``tol``: a corner at the second
        body's face across the normal (within the tolerance, a contact
        there) that pokes past its edge, whose penetration along the
        normal is the bodies' sliding along that face (a soil domain's
        corner beside a footing's edge, moved by its point's gradient,
        2e-4 cells above the footing's bottom and 3e-3 cells past its
        side: paired along x at a node beside the footing, the soil
        sliding under a smooth footing read as a penetration across x,
        and the footing took a sideways force of 1.4-2.1% of its load
        from step 3 of 4, cpGIMP).  Smooth contacts only: with friction
        a pair holds its corners in every direction (tried, with a rule
        that missed the tolerance across, a block pushed past Coulomb's
        force on a base body lost its pairs)."""
        node, _, Xc = entries
        m = normal.shape[1]
        out = np.zeros(m, dtype=bool)
        for t in tangents(normal):
            s = projection(t, node, Xc)
            lo, hi = np.full(m, np.inf), np.full(m, -np.inf)
            np.minimum.at(lo, node, s)
            np.maximum.at(hi, node, s)
            sa = (t * XA).sum(axis=0)
            inside = np.minimum(sa - lo, hi - sa)
            out |= (inside >= 0.) & (inside < tol) & (-gap > tol)
        return out

    def pair_places(self, corner: ndarray, normal: ndarray, smooth: bool):
        """The places (rows, m; integers) that one pair each may hold:
        of ``corner`` (dim, m), and, ``smooth``, with its ``normal``."""
        return self.place(np.vstack([corner, self.h * normal]) if smooth
                          else corner)

    def one_per_place(self, XB, XA, normal, first, smooth: bool,
                      along=None):
        """Of the pairs ``first`` (indices of their corners' positions
        ``XB`` and ``XA``, dim x m), one per place of the second body's
        corner, then of the first body's (and, ``smooth``, normal), those
        whose corners lie nearest each other (those ``along``, where
        given, before the others; of pairs of the same corners, the one
        whose normal lies nearest the last grid axis, the vertical, then
        the one before it), and at a first body's place every pair as
        near as the nearest.  Pairs of the same two corners from
        different nodes are equally near, and the order of the nodes took
        a rough footing's left bottom corner along x, the right one's
        along y: from that step (at 0.07 of its width in von Mises soil,
        cpGIMP) the footing took a sideways force of 4.2-4.7% of its
        load (pushed in 40 to 10 steps)."""
        distance = np.sqrt(((XB - XA) ** 2).sum(axis=0))
        keys = tuple(-np.abs(normal[:, first])) + (distance[first],)
        if along is not None:
            keys += (~along[first],)
        first = first[np.lexsort(keys)]
        for corner, ties in ((XB, False), (XA, True)):
            places = self.pair_places(corner, normal, smooth)[:, first]
            index, group = np.unique(places, axis=1, return_index=True,
                                     return_inverse=True)[1:]
            keep = np.zeros(first.size, dtype=bool)
            keep[index] = True
            if ties:
                near = distance[first]
                keep |= near <= near[index][group.ravel()] \
                    + FACING * self.h
            first = first[keep]
        return first

    def place(self, x: ndarray) -> ndarray:
        """Positions ``x`` (rows, m) in units of :data:`FACING` cells,
        rounded: equal where they are one place."""
        return np.round(x / (FACING * self.h)).astype(np.int64)

    def separating_normal(self, entries, centre, node_x, sides: bool,
                          held=None):
        """The normals of the nodes' pairs: the nodes (m,), indices of
        ``node_x``, and the normals (dim, m).  Per node, the direction
        along which the two bodies' domain corners in its support are
        farthest apart (the separating axis of the two local sets), among
        candidates that point from the first body to the second: the line
        between their centroids, each body's outward direction from its
        centroid to the node, their sum, and the grid axes; only the
        first body's corners that face the second's count
        (:meth:`facing`), and a node where none do along any candidate
        has no pair.  A grid axis is preferred by :data:`AXIS` cells of
        gap, and of gaps within :data:`FACING` cells those along which
        the bodies' corners overlap by :data:`SPAN` cells across (where
        any does), and of those the one nearest the centroids' line, the
        last axis (the vertical) by :data:`LAST` in cosine.  A body's edge
        or the grid's edge makes the centroids' directions lean sideways
        and shows a gap of about zero sideways where both bodies end; the
        separating axis with these preferences stays across the surface.
        Where both bodies' corners are level faces across a grid axis
        (:meth:`level`) that meet or overlap across it, that axis is the
        normal whatever the other candidates' gaps (of several, those
        across which they overlap by :data:`SPAN` cells, where any do, of
        those the largest gap, of those alike the vertical): beyond a
        block's edge lifted or sunk a fraction of a cell off a level
        slab, the leaning directions show the bodies farther apart, to
        the slab's corners beside the edge, and where its edge is in line
        with the slab's domains the corners meet edge to edge, x (or y)
        and the vertical alike.
        Where the best is a grid axis and ``sides`` (a smooth contact,
        whose pairs hold only along their normals), every other axis
        alike with it or along which the
        bodies touch (within :data:`FACING` cells), across which their
        corners overlap by more than :data:`SPAN` cells, is the normal
        of a pair of the node too:
        a body's corner in a notch of the other (a pile's tip) touches
        both faces, and one normal per node, taken by the gaps or the
        order of the candidates, left a pile's tip unheld where its
        corners took the side's (it stopped at 0.8 of its load) and a
        square pile in 3D drifting sideways (8.7% of its settlement)
        where its vertical edges took the x or y normal by the order.
        With friction, a node whose second body's corners were pressed
        at the last step's end (``held``, their pressure vectors summed
        per node, dim x m) keeps the candidate nearest that direction
        (within :data:`HELD` in cosine) where it is alike with the best,
        no worse a separating axis (its gap within :data:`FACING` cells
        of the best's, or larger), or the best shows the bodies apart
        while they touch along it (a gap up to :data:`FACING` cells):
        at a heavily loaded pile's tip
        corners, in a notch of the soil, the candidates alike were
        decided by the line between the centroids, which leaned sideways
        as the soil yielded, and with friction 0.3 the pile settled 66%
        more than without (a user trial); at a pile's tip the soil
        beside it, its facing corners parted by a settlement of a
        hundredth of a cell, showed half a cell of gap sideways, the
        tip's nodes took the side's normal, and the pile, its tip unheld,
        sank through the soil at 0.7 of its load with friction 0.3; a
        square pile's tip edge corner in 3D, pressed down with two thirds
        of the tip's force, found at the notch's node the soil's corners
        level faces across x, overlapping the pile's by half a domain,
        and the level face's preference took x over the vertical (a gap
        of -1.5e-3 cells): the tip sank through the soil, and the cap's
        force fell from 13.4 to 5.8, below the smooth pile's 13.9 (trial
        76)."""
        dim = self.dim
        candidates = [centre[1] - centre[0], node_x - centre[0],
                      centre[1] - node_x]
        candidates = [c / np.maximum(np.sqrt((c ** 2).sum(axis=0)), 1e-300)
                      for c in candidates]
        candidates.append(candidates[1] + candidates[2])
        for axis in range(dim):
            for sign in (1., -1.):
                e = np.zeros_like(node_x)
                e[axis] = sign
                candidates.append(e)
        candidates = np.array([c / np.maximum(np.sqrt((c ** 2).sum(
            axis=0)), 1e-300) for c in candidates])           # (k, dim, m)
        gaps, spans = [], []
        for n in candidates:
            faces, span = self.facing(entries, n)
            spans.append(span)
            gaps.append(self.reach(entries[1][0], entries[1][2], n, True)
                        + self.reach(entries[0][0][faces],
                                     entries[0][2][:, faces], n, False))
        gaps = np.array(gaps)
        line = centre[1] - centre[0]
        towards = np.einsum("kam,am->km", candidates, line)
        gaps[(towards <= 1e-9 * self.h) | np.isinf(gaps)] = -np.inf
        # gaps within FACING cells are alike (bodies that touch show a gap
        # of about zero along their surface's normal and along a face
        # they share at an edge): a grid axis is preferred (a surface
        # seeded on a tensor grid), and of those the nearest to the line
        # between the centroids; of axes alike in both (a convex corner
        # of the second body in a notch of the first, its sides equally
        # far), the last, the vertical, mirror-symmetric (by round-off,
        # or a penetration within the tolerance, one of a pile's tip
        # corners took a side's normal, the other the tip's: it tilted)
        axis = np.arange(len(candidates)) >= 4
        last = np.arange(len(candidates)) >= len(candidates) - 2
        cos = towards / np.maximum(np.sqrt((line ** 2).sum(axis=0)), 1e-300)
        score = gaps + self.h * AXIS * axis[:, None]
        alike = score >= score.max(axis=0) - FACING * self.h
        # of those alike, the faces the bodies share by SPAN cells across
        # (where any is): a footing sunk a thirtieth of a cell into its
        # soil touches the soil beside it along x over that depth, and
        # by the centroids' line, which leans beside a footing's edge,
        # the edge's node took x (B-splines, smooth: a sideways force of
        # 13% of the load in one step)
        wide = alike & (np.array(spans) > SPAN * self.h)
        alike &= wide | ~wide.any(axis=0)
        value = np.where(alike, cos + LAST * last[:, None], -np.inf)
        best = np.argmax(value, axis=0)
        # where both bodies' corners are level faces across a grid axis
        # (by LEVEL cells) that meet or overlap across it, that axis: of
        # several, those across which they overlap by SPAN cells (where
        # any do; in 3D, at a node behind a landing block's edge, its
        # side and the slab's top, overlapping by the penetration, 0.016
        # cells, showed 0.15 cells of gap along x), of those the largest
        # gap (the least penetration), of those alike the vertical.
        # A block's edge lifted a fifth of a cell off a slab
        # body (bouncing) showed a larger gap, 0.20 cells against 0.11,
        # along the block's direction from its centroid there to the
        # node beyond its edge, to a slab corner beside the edge, and a
        # smooth contact pushed it sideways (Ft/Fn -2.3; 1 m/s reversed
        # to -0.56); in 3D, the block's edge in line with the slab's
        # domains at a node (the bodies' corners there meeting edge to
        # edge), x and the vertical alike, the centroids' line took x
        # (Ft/Fn 5.4; 0.46)
        spans = np.array(spans)
        flat = np.array([self.level(entries, n) if a else
                         np.zeros(node_x.shape[1], dtype=bool)
                         for n, a in zip(candidates, axis)])
        flat &= np.isfinite(gaps) & (spans > -FACING * self.h)
        on = flat.any(axis=0)
        flat_wide = flat & (spans > SPAN * self.h)
        flat &= flat_wide | ~flat_wide.any(axis=0)
        flat &= score >= np.where(flat, score, -np.inf).max(axis=0) \
            - FACING * self.h
        best = np.where(on, np.argmax(np.where(
            flat, cos + 2. * last[:, None], -np.inf), axis=0), best)
        # and the candidates alike with it are those level axes (a second
        # face of such a node, below, is one along which the bodies touch)
        alike = np.where(on, flat, alike)
        if not sides:
            # with friction a node has one normal: of candidates alike
            # to TIED (a square pile's vertical edge in a notch of the
            # soil: x and y), the first, the same at every such node (by
            # round-off some edges took x, others y, and the pile drifted
            # sideways by 0.12% of its settlement with MPM, 2.0% with
            # cpGIMP; their mean, tried, is no separating axis of a
            # corner in a notch: the bodies overlapped along it)
            best = np.where(on, best, np.argmax(
                value >= value.max(axis=0) - TIED, axis=0))
            if held is not None:
                size = np.sqrt((held ** 2).sum(axis=0))
                cos_held = np.einsum("kam,am->km", candidates, held) \
                    / np.maximum(size, 1e-300)
                cos_held[~np.isfinite(gaps) | (gaps > FACING * self.h)] \
                    = -np.inf
                pick = np.argmax(cos_held, axis=0)
                at = np.arange(pick.size)
                # kept where alike with the best, no worse a separating
                # axis (a level face's preference does not take a pressed
                # corner off its face), or the best apart
                keep = (cos_held[pick, at] > HELD) & (
                    alike[pick, at] | (gaps[best, at] > FACING * self.h)
                    | (gaps[pick, at] >= gaps[best, at] - FACING * self.h))
                best = np.where(keep, pick, best)
        normal = candidates[best, :, np.arange(best.size)].T
        node = np.flatnonzero(~np.isinf(gaps.max(axis=0)))
        more = sides & (alike | (np.abs(gaps) <= FACING * self.h)) \
            & np.isfinite(gaps) & (np.array(spans) > SPAN * self.h) \
            & axis[:, None] & axis[best][None, :] \
            & (np.arange(len(candidates))[:, None] != best[None, :])
        k, extra = np.nonzero(more)
        return np.r_[node, extra], np.c_[normal[:, node],
                                         candidates[k, :, extra].T]

    def level(self, entries, normal) -> ndarray:
        """Per node (m,), whether both bodies' corners there are level
        faces across its ``normal`` (dim, m), the first body's facing the
        second's: each body's corners within :data:`LEVEL` cells of its
        extreme along the normal towards the other (the first body's
        highest, the second's lowest) reach both ends of its corners'
        range across it, and none of its corners beyond the other body's
        range across (by :data:`FACING` cells) lies past that extreme by
        more than :data:`LEVEL` cells (a notch round a pile's tip, a
        step beside a block, an inclined surface's staircase of corners,
        a bump: not level)."""
        m, eps, tol = normal.shape[1], FACING * self.h, LEVEL * self.h
        out = np.ones(m, dtype=bool)
        ts = tangents(normal)
        for own, other, sign in ((0, 1, 1.), (1, 0, -1.)):
            node, _, Xc = entries[own]
            along = sign * projection(normal, node, Xc)
            top = np.full(m, -np.inf)
            np.maximum.at(top, node, along)
            band = along >= top[node] - tol
            shadow = np.ones(node.size, dtype=bool)
            for t in ts:
                s = projection(t, node, Xc)
                s_o = projection(t, entries[other][0], entries[other][2])
                ranges = []
                for at, values in ((node, s), (node[band], s[band]),
                                   (entries[other][0], s_o)):
                    lo, hi = np.full(m, np.inf), np.full(m, -np.inf)
                    np.minimum.at(lo, at, values)
                    np.maximum.at(hi, at, values)
                    ranges.append((lo, hi))
                (lo, hi), (lo_band, hi_band), (lo_o, hi_o) = ranges
                out &= (lo_band <= lo + eps) & (hi_band >= hi - eps)
                shadow &= (s >= lo_o[node] - eps) & (s <= hi_o[node] + eps)
            top_in = np.full(m, -np.inf)
            np.maximum.at(top_in, node[shadow], along[shadow])
            out &= top <= top_in + tol
        return out

    @staticmethod
    def spread(entries, slot, m: int):
        """The (node, corner, position) ``entries`` of ``m`` nodes for
        the pairs' ``slot`` (the node of each pair): each entry once per
        pair of its node, its node the pair's index."""
        node, corner, Xc = entries
        order = np.argsort(slot, kind="stable")
        count = np.bincount(slot, minlength=m)
        start = np.cumsum(count) - count
        rep = count[node]
        e = np.repeat(np.arange(node.size), rep)
        offset = np.arange(e.size) - np.repeat(np.cumsum(rep) - rep, rep)
        return order[start[node[e]] + offset], corner[e], Xc.take(e, axis=1)

    def facing(self, entries, normal, centres=None) -> tuple:
        """Which corners of the first body face the second's at their
        node: across the node's ``normal`` (per tangent direction) within
        the range both bodies' corners there span, its ends included
        where they are the first body's own edge, left out where the
        first body reaches beyond the second (its corners there lie on a
        face along the normal, beside the second body, not across); ends
        within :data:`FACING` cells are one.  At a node where that leaves
        no corner facing (the second body's corners one domain across, in
        line with the first body's), the ends where the first body there
        and beyond is level with the second's lowest, within
        :data:`FACING` cells, face it (a floor, not a notch).  Also, per
        node, the least width of the range over the tangents (m,).
        Given the ``centres`` of the first body's corners' points (dim,
        entries) (the pairs' corners, not the nodes' normals), an end
        where the first body reaches on beyond as a floor level with the
        second's lowest along the normal (within :data:`FLOOR` cells) is
        its own too, and also which corners not facing are *under* the
        second body: of a domain whose centre lies within the second
        body's range across the normal, at an end where the first body
        beyond it does not rise past the second body's lowest along the
        normal (a surface the second body rests on reaches on beyond it;
        round a pile's tip the soil beside rises: a notch)."""
        (node_a, _, Xa), (node_b, _, Xb) = entries
        m, eps = normal.shape[1], FACING * self.h
        inside = np.ones(node_a.size, dtype=bool)
        span = np.full(m, np.inf)
        under = np.zeros(node_a.size, dtype=bool) if centres is None \
            else np.ones(node_a.size, dtype=bool)
        along = projection(normal, node_a, Xa)
        level = (self.reach(node_b, Xb, normal, True) + eps)[node_a]
        # an end of the first body level with the second's lowest, a floor
        # it reaches on beyond as a surface: in the pairs by FLOOR cells,
        # in the nodes' normals by FACING cells (and only at nodes that
        # face nothing without it, below)
        floor = level - eps + FLOOR * self.h if centres is not None \
            else level
        flat = along <= floor
        on_floor = np.ones(node_a.size, dtype=bool)
        for t in tangents(normal):
            ranges = []
            for node, Xc in ((node_a, Xa), (node_b, Xb)):
                s = projection(t, node, Xc)
                lo, hi = np.full(m, np.inf), np.full(m, -np.inf)
                np.minimum.at(lo, node, s)
                np.maximum.at(hi, node, s)
                ranges.append((s, lo, hi))
            (sa, lo_a, hi_a), (_, lo_b, hi_b) = ranges
            low, high = np.maximum(lo_a, lo_b), np.minimum(hi_a, hi_b)
            span = np.minimum(span, high - low)
            low, high = low[node_a], high[node_a]
            own_low = (lo_a >= lo_b - eps)[node_a]
            own_high = (hi_a <= hi_b + eps)[node_a]
            rises = []          # per end, how far the first body beyond it
            for beyond in (sa < lo_b[node_a] - eps,             # rises
                           sa > hi_b[node_a] + eps):
                rise = np.full(m, -np.inf)
                np.maximum.at(rise, node_a[beyond], along[beyond])
                rises.append(rise[node_a])
            if centres is None:
                on_floor &= ((sa > low + eps) | (
                    (own_low | (flat & (rises[0] <= floor)))
                    & (sa >= low - eps))) & ((sa < high - eps) | (
                        (own_high | (flat & (rises[1] <= floor)))
                        & (sa <= high + eps)))
            else:
                c = projection(t, node_a, centres)
                under &= (c > lo_b[node_a] + eps) & (c < hi_b[node_a] - eps)
                # an end where the first body beyond the second rises past
                # the second's lowest is a notch round it, not a surface
                under &= (~(sa <= lo_b[node_a] + eps) | (rises[0] <= level)) \
                    & (~(sa >= hi_b[node_a] - eps) | (rises[1] <= level))
                # an end where it reaches on as a floor level with the
                # second's lowest (by FLOOR cells) is its own: a footing's
                # edge on its soil, the soil beside a hundredth of a cell
                # above its bottom, faces the soil's corner under it (left
                # out, the edge's pair took a corner a domain inside, and
                # a stiff footing's settlement in 10 load steps came out
                # 22% above that in one).  Not in the nodes' normals
                # (``centres`` None): there it let a block pushed over a
                # base body with friction 0.3 carry 1.25 mu N
                own_low |= flat & (rises[0] <= floor)
                own_high |= flat & (rises[1] <= floor)
            inside &= ((sa > low + eps) | (own_low & (sa >= low - eps))) \
                & ((sa < high - eps) | (own_high & (sa <= high + eps)))
        if centres is None:
            # a node where the second body's corners span one domain
            # across, its ends at the first body's corners (domains of
            # both bodies in line), and the first body reaches beyond both
            # ends (at one a sliver of its domain in the node's support),
            # has no corner between the ends: its floor's ends face it
            # (without, the node's grid axis saw nothing facing, a
            # leaning normal was taken, and a block gliding on a slab
            # body with GIMP was braked by a smooth contact: vx 1 to
            # 0.456 in 0.5 s, sideways 0.91 of the normal force)
            none = np.bincount(node_a[inside], minlength=m) == 0
            inside |= on_floor & none[node_a]
        return (inside, span) if centres is None else \
            (inside, span, under & ~inside)

    @staticmethod
    def corner_entries(Sk, corners: int):
        """The (node, corner) of each of the ``corners`` corners of the
        points (rows of ``Sk``) in the nodes' supports (its columns):
        corner ``c n + p`` of point ``p``."""
        coo = Sk.tocoo()
        corner = (np.arange(corners)[:, None] * Sk.shape[0]
                  + coo.row[None, :]).ravel()
        return np.tile(coo.col, corners), corner

    @staticmethod
    def reach(node, Xc, normal, lowest: bool) -> ndarray:
        """Per node, the lowest position along its normal of its corners
        (``lowest``), or minus the highest (``inf`` where it has none)."""
        along = projection(normal, node, Xc)
        along = along if lowest else -along
        out = np.full(normal.shape[1], np.inf)
        np.minimum.at(out, node, along)
        return out

    def surface(self, entries, normal, node_x):
        """The second body's corners of the nodes' pairs: per node its
        surface corner nearest (:meth:`extreme`), and at a node where
        either body ends across the normal (its outermost corner in the
        node's support at most half a hundredth of a cell past it to one
        side), or the second body within half a cell past it, every
        surface corner within half a cell
        across (per column of corners, their places across the normal,
        the lowest along it); such a node with none within half a cell
        keeps its nearest.  A body ending a quarter of a cell past a
        node: the spline of the node beyond reaches its last sliver, and
        that node took no pair (two blocks pressed together carried
        0.97-1.01 of the load at their edge, ``"bspline-gimp"``
        0.72-1.28), or, given the end corner, one that balances a
        uniform stress only pulling; the node before pairs all four.  With
        B-splines a surface ending on a grid line is made of the splines
        of one more node beyond each end than its nodes' pairs hold (a
        pile's tip, two cells wide on grid lines: five control values,
        three pairs; its corners between the pairs sank and the pile
        settled 55% more than a rigid obstacle in the same hole needed);
        corners every half a cell everywhere held more places than the
        splines have values (four cells: nine for seven), which the
        augmented Lagrangian with friction did not settle.  The end is
        the outermost corner, not a window half a cell wide (none between
        half a cell and one): corners stretched along a surface more
        than half a cell apart missed it at nodes inside, which paired
        every corner (two blocks pressed with nu = 0.45 in finite strain
        did not settle).  Returns the
        node of each pair (k,) and its corner of the second body."""
        node, corner, Xc = entries[1]
        m = normal.shape[1]
        eps = FACING * self.h
        end = np.zeros(m, dtype=bool)
        low, high = self.mesh.p.min(axis=1), self.mesh.p.max(axis=1)
        places = {}
        for i, k in enumerate(map(tuple, self.place(node_x).T)):
            places.setdefault(k, []).append(i)
        for t in tangents(normal):
            for side in (-1., 1.):
                # beyond the grid's edge the splines are folded: no end
                probe = node_x + side * self.h * t
                inside = ((probe >= low[:, None] - eps)
                          & (probe <= high[:, None] + eps)).all(axis=0)
                # the second body's surface ending within half a cell
                # past the node too (not the first's facing corners,
                # which end where the second's do: a block four cells
                # long gliding on a slab made every corner a pair, nine
                # for seven splines, and its contact did not settle)
                # not where the node beyond pairs along this tangent, a
                # face turning there (a pile's tip in its hole: its pairs
                # hold the splines below the side's end; with the window
                # a pile whose tip lies inside a cell settled 5.05 cm
                # against cpGIMP's 4.90, before 4.87)
                turns = np.array([any(
                    abs(normal[:, j] @ t[:, i]) > .5
                    for j in places.get(k, ())) for i, k in enumerate(
                        map(tuple, self.place(probe).T))], dtype=bool)
                window = np.where(turns, 0., .5 * self.h)
                # the body's real end on this side: its outermost corner
                # in the node's support (a window (h/2, h] found none at
                # nodes inside a surface stretched along its length, its
                # corners more than h/2 apart: two blocks pressed with
                # nu = 0.45 in finite strain paired every corner there
                # and did not settle)
                for n_k, _, X_k in entries:
                    across = side * (t[:, n_k] * (X_k - node_x[:, n_k])
                                     ).sum(axis=0)
                    reach = np.full(m, -np.inf)
                    np.maximum.at(reach, n_k, across)
                    past = window if n_k is node else 0.
                    end |= inside & (reach <= past + eps)
        nearest = self.extreme(entries[1], normal, node_x, True)
        at = end[node]
        node, corner, Xc = node[at], corner[at], Xc[:, at]
        along = (normal[:, node] * Xc).sum(axis=0)
        key = [node]
        for t in tangents(normal):
            across = np.abs((t[:, node] * (Xc - node_x[:, node])).sum(
                axis=0))
            at = across <= .5 * self.h + eps
            key = [k[at] for k in key]
            node, corner, along, Xc = node[at], corner[at], along[at], \
                Xc[:, at]
            key.append(self.place((t[:, node] * Xc).sum(axis=0)))
        key = np.array(key)
        order = np.lexsort((along,) + tuple(key[::-1]))
        key = key[:, order]
        head = np.ones(order.size, dtype=bool)   # a column's lowest
        head[1:] = (key[:, 1:] != key[:, :-1]).any(axis=0)
        node, corner = node[order][head], corner[order][head]
        inner = np.flatnonzero(~end | ~np.isin(np.arange(m), node))
        return np.r_[inner, node], np.r_[nearest[inner], corner]

    @staticmethod
    def extreme(entries, normal, near, lowest: bool,
                deepest: float = np.inf) -> ndarray:
        """Per node (every node has ``entries``), the surface corner
        lowest (or highest) along its normal near ``near`` (dim, m): the
        least ``along + ACROSS * across``, ``across`` the distance from
        ``near`` across the normal, so that of a surface's corners the
        one nearest wins, and of a corner and one a domain deeper right
        above it the surface one; corners beyond ``near`` along the
        normal by more than ``deepest`` only where a node has no other:
        indices ``c n + p``."""
        node, corner, Xc = entries
        along = projection(normal, node, Xc)
        along = along if lowest else -along
        offset = Xc - near[:, node]
        beyond = projection(normal, node, offset)
        across = np.sqrt(np.maximum(
            (offset ** 2).sum(axis=0) - beyond ** 2, 0.))
        key = along + ACROSS * across
        key[(beyond if lowest else -beyond) < -deepest] = np.inf
        order = np.lexsort((key, node))
        head = np.r_[True, node[order][1:] != node[order][:-1]]
        return corner[order[head]]
