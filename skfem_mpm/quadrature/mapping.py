"""Reference mappings that do not outlive the points they map."""
import numpy as np
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
        entry = self._entries.get(("J", i, j))
        if entry is None or entry[0] is not X or entry[1] is not tind:
            DF = self._jacobian(X, tind)
            for a in range(self.dim):
                for b in range(self.dim):
                    self._entries[("J", a, b)] = (X, tind, DF[a, b])
            entry = self._entries[("J", i, j)]
        return entry[2]

    def _jacobian(self, X, tind=None):
        """Every entry of the Jacobian (dim, dim, elements, points) in one
        pass over the element's nodes: scikit-fem's ``_J`` for all ``i,
        j`` at once, the same products summed in the same order (equal to
        the bit), in a third of the time (the basis of a load step's
        points asks for all of them)."""
        p, t = self.mesh.doflocs, self.mesh.dofs.element_dofs
        nodes = t if tind is None else t[:, tind]
        DF = np.zeros((self.dim, self.dim, nodes.shape[1], X.shape[-1]))
        for k in range(t.shape[0]):
            dphi = self.elem.lbasis(X, k)[1]
            node = p[:, nodes[k], None]
            for i in range(self.dim):       # (a 4D broadcast over the few
                for j in range(self.dim):   # slots: 3 times slower)
                    DF[i, j] += node[i] * dphi[j]
        return DF

    def invDF(self, X, tind=None):
        return self._cached("invDF", X, tind,
                            lambda: super(PointMapping, self).invDF(X, tind))

    def forget(self):
        """Drop the cached Jacobian and inverse: a material-point basis
        does so once its fields are formed, so that they do not live as
        long as the basis (144 bytes a point in 3D, at the heap's peak)."""
        self._entries.clear()


def fresh_mapping(mesh: Mesh) -> Mapping:
    """Return a reference mapping for ``mesh`` that owns its own caches.

    Affine meshes have no cache and share the mesh's mapping; isoparametric
    meshes get a :class:`PointMapping`, whose bounded cache is dropped with
    it.

    """
    if mesh.affine:
        return mesh._mapping()
    return PointMapping(mesh)
