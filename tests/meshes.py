"""Meshes shared by the tests."""
import numpy as np
from skfem import (ElementHex1, ElementLineP1, ElementQuad1, ElementQuad2,
                   ElementTetP1, ElementTriP1, ElementTriP2, MeshHex, MeshLine,
                   MeshQuad, MeshTet, MeshTri)


def cooks_membrane(n: int) -> MeshQuad:
    """Cook's membrane, the trapezoid (0, 0), (48, 44), (48, 60), (0, 44),
    as n x n quadrilaterals."""
    unit = MeshQuad.init_tensor(*2 * (np.linspace(0., 1., n + 1),))
    s, t = unit.p
    return MeshQuad(np.array([48 * s, 44 * s + t * (44 - 28 * s)]), unit.t)


def distorted_quads():
    """A quadrilateral mesh with non-parallelogram (bilinear) elements."""
    mesh = MeshQuad().refined(2)
    p = mesh.p.copy()
    interior = (p > 0).all(axis=0) & (p < 1).all(axis=0)
    rng = np.random.default_rng(0)
    p[:, interior] += rng.uniform(-.06, .06, size=(2, interior.sum()))
    return MeshQuad(p, mesh.t)


FAMILIES = {
    "line": (lambda: MeshLine(np.linspace(0., 2., 7)), ElementLineP1),
    "quad": (lambda: MeshQuad.init_tensor(np.linspace(0, 2, 5),
                                          np.linspace(0, 1, 4)), ElementQuad1),
    "quad-distorted": (distorted_quads, ElementQuad1),
    "tri": (lambda: MeshTri().refined(2), ElementTriP1),
    "hex": (lambda: MeshHex().refined(1), ElementHex1),
    "tet": (lambda: MeshTet().refined(1), ElementTetP1),
    "quad-Q2": (lambda: MeshQuad.init_tensor(np.linspace(0, 2, 4),
                                             np.linspace(0, 1, 3)),
                ElementQuad2),
    "tri-P2": (lambda: MeshTri().refined(1), ElementTriP2),
}


def sheared_block(displacement: float):
    """A 2 x 1 block of 2x2 points per cell on a grid of h = 0.25 with room
    around it, and ``prescribed(basis, f_old, f_new)`` moving its top nodes
    along x by ``displacement`` at full load; returns (mesh, points, top
    node indices, prescribed)."""
    from skfem_mpm import seed_points
    mesh = MeshQuad.init_tensor(np.linspace(-.5, 2.5, 13),
                                np.linspace(0., 1.5, 7))
    points = seed_points(mesh, 2, region=lambda x: (x[0] > 0) & (x[0] < 2)
                         & (x[1] < 1))
    top = np.flatnonzero(np.isclose(mesh.p[1], 1.) & (mesh.p[0] >= 0.)
                         & (mesh.p[0] <= 2.))

    def prescribed(b, f_old, f_new):
        return b.nodal_dofs[0, top], np.full(top.size,
                                             displacement * (f_new - f_old))
    return mesh, points, top, prescribed
