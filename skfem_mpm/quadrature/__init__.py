"""quadrature: material points, their location on the grid and the
material-point bases."""
from .basis import MaterialPointBasis, material_point_bases

__all__ = ["MaterialPointBasis", "material_point_bases"]
