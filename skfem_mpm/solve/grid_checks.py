"""The grid and its element checked before a run's work: an element that
is no displacement element or does not fit the mesh, and a grid that is
not conforming (hanging nodes), are refused with the reason.

"""
import weakref

import numpy as np
from numpy import ndarray
from scipy.spatial import cKDTree
from skfem import Element, ElementVector
from skfem.element import ElementHcurl, ElementHdiv
from skfem.mesh import Mesh

from ..errors import InvalidInputError, UnsupportedElementError
from ..quadrature.locate import (_affine_local, _margin, _newton_local,
                                 tensor_grid)

__all__ = ["check_grid", "check_displacement_element", "check_conforming"]

#: a probe's step off a boundary facet, in facet diameters
PROBE_STEP = 1e-3
#: cells of nearest centroids searched for each probe, per 2 ** dim
PROBE_CELLS = 4
#: the grids found conforming, by ``id`` (each entry dropped with its
#: grid): a strength reduction's trials and a study's cases check their
#: grid once (a review: 1.7 s a run for 64,000 distorted hexahedra)
_CONFORMING = {}


def check_grid(mesh: Mesh, elem: Element) -> None:
    """:func:`check_displacement_element`, then :func:`check_conforming`."""
    check_displacement_element(mesh, elem)
    check_conforming(mesh)


def check_displacement_element(mesh: Mesh, elem: Element) -> None:
    """Refuse an H(div) or H(curl) element (its DOFs are normal or
    tangential components on facets, not displacements at nodes) and an
    element of another reference cell than the mesh's, before any warning
    of the run's (a user trial: ``ElementHex1`` on a ``MeshQuad`` was
    warned of as a hexahedron with zero-energy modes, then refused).

    Examples
    --------
    >>> from skfem import ElementQuadRT0, MeshQuad
    >>> mesh, elem = MeshQuad(), ElementQuadRT0()
    >>> check_displacement_element(mesh, elem)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.UnsupportedElementError: the element ElementQuadRT1 \
is an H(div) element ...

    """
    scalar = elem.elem if isinstance(elem, ElementVector) else elem
    name = type(scalar).__name__
    for space, kind, what in ((ElementHdiv, "H(div)", "normal"),
                              (ElementHcurl, "H(curl)", "tangential")):
        if isinstance(scalar, space):
            raise UnsupportedElementError(
                "the element {} is an {} element (its DOFs are {} "
                "components on the facets), not a displacement element; "
                "use a nodal (H1) element of the mesh's cells, e.g. {}"
                .format(name, kind, what, nodal_example(mesh)))
    if scalar.refdom is not mesh.refdom:
        raise UnsupportedElementError(
            "the element {} does not fit the mesh {}: its reference cell "
            "is {}, the mesh's {}; use an element of the mesh's cells, "
            "e.g. {}".format(name, type(mesh).__name__,
                             scalar.refdom.__name__, mesh.refdom.__name__,
                             nodal_example(mesh)))


def nodal_example(mesh: Mesh) -> str:
    """A linear nodal element of ``mesh``'s cells, by name."""
    return {"RefLine": "ElementLineP1()", "RefTri": "ElementTriP1()",
            "RefQuad": "ElementQuad1()", "RefTet": "ElementTetP1()",
            "RefHex": "ElementHex1()"}.get(mesh.refdom.__name__,
                                           "a Lagrange element")


def check_conforming(mesh: Mesh) -> None:
    """Refuse a grid that is not conforming: a facet of one cell that
    another cell's facets split (a hanging vertex inside it) is no facet
    shared by two cells, so scikit-fem counts it and its pieces as the
    boundary, and the field is not continuous across them (a user trial:
    one coarse cell beside four fine ones ran without a word).

    Each boundary facet is probed a thousandth of its size outside,
    along its normal, off its centre (where a split facet's pieces
    meet): a probe that lands in a cell (among those of the
    nearest centroids) shows a facet inside the domain.  Tensor-product
    grids and 1D meshes are conforming by construction and not probed;
    holes and re-entrant corners leave the probes outside.  The cost is
    a KD-tree of the cells' centroids and a search per boundary facet.

    Examples
    --------
    >>> import numpy as np
    >>> from skfem import MeshQuad
    >>> p = np.array([[0, 1, 1, 0, 1.5, 2, 2, 1.5, 1, 2, 1.5],
    ...               [0, 0, 1, 1, 0, 0, .5, .5, .5, 1, 1]])
    >>> t = np.array([[0, 1, 2, 3], [1, 4, 7, 8], [4, 5, 6, 7],
    ...               [8, 7, 10, 2], [7, 6, 9, 10]]).T
    >>> check_conforming(MeshQuad(p, t))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    skfem_mpm.errors.InvalidInputError: the grid is not conforming: ...

    """
    dim = mesh.dim()
    kept = _CONFORMING.get(id(mesh))
    if dim == 1 or (kept is not None and kept() is mesh) or \
            tensor_grid(mesh) is not None:
        return
    facets = mesh.boundary_facets()
    if facets.size == 0:
        return
    own = mesh.f2t[0, facets]
    corners = mesh.p[:, mesh.facets[:, facets]]        # (dim, nv, nf)
    centre = corners.mean(axis=1)
    normal = facet_normals(corners)
    inward = mesh.p[:, mesh.t[:, own]].mean(axis=1) - centre
    normal *= np.where((normal * inward).sum(axis=0) > 0., -1., 1.)
    size = np.abs(corners - centre[:, None, :]).max(axis=(0, 1))
    # off the facet's centre, where a split facet's pieces meet
    weight = 1. + np.sqrt(2.) / 10. * np.arange(corners.shape[1]) ** 2
    inside = (corners * (weight / weight.sum())[:, None]).sum(axis=1)
    probe = inside + PROBE_STEP * size * normal
    found = cells_holding(mesh, probe, own)
    bad = np.flatnonzero(found >= 0)
    if bad.size:
        raise InvalidInputError(nonconforming_words(
            mesh, facets[bad], own[bad], found[bad], size[bad]))
    _CONFORMING[id(mesh)] = weakref.ref(mesh)
    weakref.finalize(mesh, _CONFORMING.pop, id(mesh), None)


def facet_normals(corners: ndarray) -> ndarray:
    """Unit normals (dim, nf) of facets of corners (dim, nv, nf), 2D or
    3D (the plane of a facet's first three corners)."""
    if corners.shape[0] == 2:
        d = corners[:, 1] - corners[:, 0]
        n = np.stack([d[1], -d[0]])
    else:
        n = np.cross(corners[:, 1] - corners[:, 0],
                     corners[:, 2] - corners[:, 0], axis=0)
    return n / np.maximum(np.linalg.norm(n, axis=0), 1e-300)


def cells_holding(mesh: Mesh, x: ndarray, other_than: ndarray) -> ndarray:
    """The cell strictly holding each point of ``x`` (dim, n) other than
    ``other_than`` (n,), among the cells of nearest centroids, else -1."""
    dim, n = mesh.dim(), x.shape[1]
    local = _affine_local(mesh) if mesh.affine else _newton_local(mesh)
    centroids = mesh.p[:, mesh.t].mean(axis=1)
    k = min(mesh.nelements, PROBE_CELLS * 2 ** dim)
    _, cand = cKDTree(centroids.T).query(x.T, k=k)
    cand = np.asarray(cand, dtype=np.int64).reshape(n, k)
    with np.errstate(all="ignore"):
        margin = _margin(mesh.refdom, local(x, cand))
    inside = (margin > 1e-6) & (cand != other_than[:, None])
    first = inside.argmax(axis=1)
    return np.where(inside.any(axis=1), cand[np.arange(n), first], -1)


def nonconforming_words(mesh: Mesh, facets: ndarray, own: ndarray,
                        found: ndarray, size: ndarray) -> str:
    """The refusal of a non-conforming grid: the largest of the boundary
    facets inside the domain, the cells either side, and the hanging
    vertex on it (another of those facets' vertices that lies on it)."""
    big = int(np.argmax(size))
    facet = facets[big]
    ends = mesh.facets[:, facet]
    corners = mesh.p[:, ends]
    centre = corners.mean(axis=1)
    others = np.setdiff1d(mesh.facets[:, facets].ravel(), ends)
    hanging = ""
    if others.size:
        normal = facet_normals(corners[:, :, None])[:, 0]
        rel = mesh.p[:, others] - centre[:, None]
        lo, hi = corners.min(axis=1), corners.max(axis=1)
        tol = 1e-8 * size[big]
        # a vertex at one of the facet's own: the cells meet there without
        # sharing a node (a slit; a review's grid was told it "hangs")
        twin = np.linalg.norm(mesh.p[:, others][:, :, None]
                              - corners[:, None, :], axis=0).min(axis=1) \
            <= tol
        on = (np.abs(normal @ rel) <= tol) & ~twin & \
            (mesh.p[:, others] >= lo[:, None] - tol).all(axis=0) & \
            (mesh.p[:, others] <= hi[:, None] + tol).all(axis=0)
        if on.any():
            v = others[on][np.argmin(np.linalg.norm(rel[:, on], axis=0))]
            hanging = "; vertex {} at {} hangs on it (a vertex of the " \
                "cells beside it that is none of its own)".format(
                    int(v), np.round(mesh.p[:, v], 12).tolist())
        elif twin.any():
            v = others[twin][0]
            mate = ends[np.argmin(np.linalg.norm(
                corners - mesh.p[:, v][:, None], axis=0))]
            hanging = "; vertex {} at {} coincides with vertex {} of the " \
                "facet: the cells meet there without sharing a node " \
                "(duplicated nodes, a slit)".format(
                    int(v), np.round(mesh.p[:, v], 12).tolist(), int(mate))
    slit = "; one grid cannot model a slit: two bodies in contact can " \
        "(docs/contact.md, Contact between bodies)" if hanging.endswith(
            "a slit)") else ""
    return (
        "the grid is not conforming: {} boundary facet(s) lie inside the "
        "domain, e.g. the facet of cell {} with vertices {}, beside "
        "cell {}{}: the cells do not share that facet, so the displacement "
        "is not continuous across it{}; use a conforming grid, one node "
        "where cells meet (scikit-fem's refined() of the whole grid, or "
        "MeshTri's refined(marked), keep it so)".format(
            facets.size, int(own[big]),
            ", ".join("{} at {}".format(int(k), np.round(c, 12).tolist())
                      for k, c in zip(ends, corners.T)),
            int(found[big]), hanging, slit))
