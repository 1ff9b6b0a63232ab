"""What a method refused on its grid says (trial 80): the method asked
for, not another, and what to use instead."""
import numpy as np
import pytest
from skfem import ElementQuad1, ElementTriP1, MeshQuad, MeshTri

from skfem_mpm import LinearElastic, seed_points, simulate
from skfem_mpm.errors import UnsupportedElementError


def column(mesh, elem, method):
    points = seed_points(mesh, 2, region=lambda p: p[1] < 10.)
    return simulate(mesh, elem, points, LinearElastic(1e6, 0.),
                    lambda b: b.get_dofs(lambda p: p[1] == 0.).all(),
                    body_force=[0., -4000.], nsteps=1, method=method)


@pytest.mark.parametrize("method", ["bspline", "bspline-gimp", "bspline3",
                                    "bspline3-gimp"])
def test_graded_grid_names_the_method_and_what_takes_it(method, caplog):
    """``bspline-gimp`` on a graded grid was refused as 'bspline'; the
    refusal comes before the run's warnings (trial 81: the cubic splines
    with 2 points per cell were warned of it, then refused)."""
    y = np.concatenate((np.linspace(0., 5., 11), np.linspace(5., 12., 8)[1:]))
    mesh = MeshQuad.init_tensor(np.linspace(0., 1., 3), y)
    with pytest.raises(UnsupportedElementError) as err:
        column(mesh, ElementQuad1(), method)
    assert not [r for r in caplog.records if r.levelname == "WARNING"
                and r.name.startswith("skfem_mpm.")
                and "seeding" not in r.message]
    assert str(err.value) == (
        "method {!r} needs uniform spacing along each axis; axis 1 has "
        "spacings from 0.5 to 1: on a graded grid use 'cpgimp' or 'ugimp' "
        "(GIMP takes one), 'mpm' or 'fem'".format(method))


@pytest.mark.parametrize("method", ["ugimp", "cpgimp", "bspline",
                                    "bspline-gimp", "bspline3"])
def test_triangles_are_said_unsupported_for_gimp_and_splines(method):
    """On triangles uGIMP, cpGIMP and bspline-gimp were refused for want
    of point domains, never saying triangles do not take them."""
    mesh = MeshTri.init_tensor(np.linspace(0., 1., 3),
                               np.linspace(0., 12., 25))
    with pytest.raises(UnsupportedElementError) as err:
        column(mesh, ElementTriP1(), method)
    assert str(err.value) == (
        "method {!r} needs an axis-aligned tensor-product grid (MeshLine, "
        "or MeshQuad/MeshHex from init_tensor), got a general MeshTri1: "
        "GIMP's and the B-splines' weights are written per grid axis; "
        "triangles, tetrahedra and quadrilaterals off a grid take method "
        "'mpm' or 'fem'".format(method))
    column(mesh, ElementTriP1(), "mpm")            # what it says runs
