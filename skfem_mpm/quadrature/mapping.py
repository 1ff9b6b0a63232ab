"""Reference mappings that do not outlive the points they map."""
from skfem.mapping import Mapping, MappingIsoparametric
from skfem.mesh import Mesh


class PointMapping(MappingIsoparametric):
    """An isoparametric mapping that caches its Jacobian and inverse by the
    identity of the quadrature arrays, one entry per quantity.

    scikit-fem's mapping keys its cache on a hash of the arrays' bytes:
    hashing a million points' coordinates for every component and basis
    function costs about as much as the Jacobian itself, and the cache grows
    with every new set of points.  Here a basis's repeated evaluations at
    one set of points (every basis function asks for ``invDF``) are
    computed once, and new points replace the entry.

    """

    def __init__(self, mesh: Mesh):
        super().__init__(mesh, mesh.elem(), mesh.bndelem)
        self._entries = {}

    def _cached(self, key, X, tind, compute):
        entry = self._entries.get(key)
        if entry is None or entry[0] is not X or entry[1] is not tind:
            entry = (X, tind, compute())
            self._entries[key] = entry
        return entry[2]

    def J(self, i, j, X, tind=None):
        return self._cached(("J", i, j), X, tind,
                            lambda: self._J(i, j, X, tind))

    def invDF(self, X, tind=None):
        return self._cached("invDF", X, tind,
                            lambda: super(PointMapping, self).invDF(X, tind))


def fresh_mapping(mesh: Mesh) -> Mapping:
    """Return a reference mapping for ``mesh`` that owns its own caches.

    Affine meshes have no cache and share the mesh's mapping; isoparametric
    meshes get a :class:`PointMapping`, whose bounded cache is dropped with
    it.

    """
    if mesh.affine:
        return mesh._mapping()
    return PointMapping(mesh)
