"""The ``kernels`` option reaches GIMP's sub-point basis and the surface
loads' face basis, as it reaches standard MPM's (issue 32): ``"numpy"``
takes scikit-fem's slots under any environment, ``"compiled"`` the
compiled ones under ``SKFEM_MPM_KERNELS=numpy``; both give the same
operator and load."""
import numpy as np
import pytest
from skfem import ElementQuad1, ElementQuad2, MeshQuad

from skfem_mpm import (MaterialPointBasis, Traction, locate_points,
                       point_locator, seed_points)
from skfem_mpm.methods.gimp import initial_domains, subpoint_gimp_operator
from skfem_mpm.methods.operators import PointOperator
from skfem_mpm.solve.core import grid_parts
from skfem_mpm.solve.loads import ExternalLoads

pytest.importorskip("numba")


class Called(Exception):
    """The compiled slots were asked for."""


@pytest.fixture
def refused(monkeypatch):
    """The compiled slots of the material-point basis replaced by a pass
    that raises :class:`Called`."""
    from skfem_mpm.kernels import basis

    def refuse(*args, **kwargs):
        raise Called
    monkeypatch.setattr(basis, "point_slots", refuse)
    return monkeypatch


def block():
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 5), np.linspace(0, 2, 5))
    return mesh, seed_points(mesh, 2, region=lambda x: x[1] < 1.)


def gimp(kernels):
    mesh, points = block()
    return subpoint_gimp_operator(
        mesh, ElementQuad2(), points.x,
        initial_domains(mesh, points, 2) * .9,
        point_locator(mesh), kernels=kernels)


def top_load(kernels):
    """The external load of a traction on the block's top points."""
    mesh, points = block()
    scalar, grid, _, _ = grid_parts(mesh, ElementQuad1())
    top = np.flatnonzero(points.x[1] > .8)
    loads = ExternalLoads(mesh, scalar, grid, None,
                          [Traction(top, "top", [1., -2.])], points.domain,
                          {"body_force": 0}, points.n, kernels=kernels)
    op = PointOperator(MaterialPointBasis(mesh, scalar, points,
                                          kernels="numpy"))
    op.point_elements = locate_points(mesh, points.x)[0]
    return loads.external(op, points, 1.)


@pytest.mark.parametrize("build", [gimp, top_load])
def test_the_option_chooses_the_slots_under_any_environment(refused,
                                                             build):
    refused.setenv("SKFEM_MPM_KERNELS", "auto")
    build("numpy")                          # scikit-fem's: not refused
    with pytest.raises(Called):
        build("auto")
    refused.setenv("SKFEM_MPM_KERNELS", "numpy")
    with pytest.raises(Called):
        build("compiled")
    build("auto")


@pytest.mark.slow
def test_both_slots_give_the_same_operator_and_load():
    a, b = gimp("numpy"), gimp("compiled")
    assert abs(a.S - b.S).max() == 0
    assert all(abs(g - h).max() == 0 for g, h in zip(a.G, b.G))
    f = top_load("numpy")
    assert np.abs(f).sum() > 0 and np.array_equal(f, top_load("compiled"))


@pytest.mark.parametrize("method", ["cpgimp", "ugimp"])
def test_simulate_hands_the_kernels_option_to_gimp_and_the_loads(refused,
                                                                 method):
    """``simulate(..., options=Options(kernels="numpy"))`` with GIMP on
    quadratic elements and a traction builds the sub-point basis and the
    face basis with scikit-fem's slots under ``SKFEM_MPM_KERNELS=auto``
    (the option stopped at the method piece, and the compiled slots
    ran); with ``"auto"`` they run (the fixture refuses them)."""
    from skfem_mpm import LinearElastic, Options, simulate
    refused.setenv("SKFEM_MPM_KERNELS", "auto")
    mesh, points = block()
    top = np.flatnonzero(points.x[1] > .8)

    def run(kernels):
        return simulate(mesh, ElementQuad2(), points, LinearElastic(1e3, .3),
                        lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
                        loads=[Traction(top, "top", [0., -1.])],
                        method=method, options=Options(kernels=kernels))
    assert run("numpy").history[-1].load_factor == 1.
    with pytest.raises(Exception) as caught:
        run("auto")
    assert isinstance(caught.value, Called) or isinstance(
        caught.value.__cause__, Called)
