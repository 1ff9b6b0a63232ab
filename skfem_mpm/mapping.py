"""Reference mappings that do not outlive the points they map."""
from skfem.mapping import Mapping, MappingIsoparametric
from skfem.mesh import Mesh


def fresh_mapping(mesh: Mesh) -> Mapping:
    """Return a reference mapping for ``mesh`` that owns its own caches.

    scikit-fem's isoparametric mapping caches Jacobians keyed on the
    quadrature array, on an object cached on the mesh.  Material points move
    every step, so that cache would grow without bound.  Affine meshes have
    no such cache and share the mesh's mapping; isoparametric meshes get a
    new mapping whose cache is dropped with it.

    """
    if mesh.affine:
        return mesh._mapping()
    return MappingIsoparametric(mesh, mesh.elem(), mesh.bndelem)
