"""The ``kernels`` option chooses the material-point basis's passes,
the point location's and the supports' check's, not only the Newton
iteration's: ``"numpy"`` takes scikit-fem's, scipy's and numpy's under
any environment, ``"compiled"`` the compiled ones under
``SKFEM_MPM_KERNELS=numpy`` (issue 32)."""
import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import point_locator, seed_points
from skfem_mpm.methods.method import make_method
from skfem_mpm.solve.core import grid_parts
from skfem_mpm.solve.linear import check_rigid_body_modes

numba = pytest.importorskip("numba")


class Called(Exception):
    """A compiled pass was called."""


def refuse(*args, **kwargs):
    raise Called


@pytest.fixture
def refused(monkeypatch):
    """The compiled passes of the basis, of the graph and of the
    location replaced by one that raises :class:`Called`."""
    from skfem_mpm.kernels import basis, graph, locate
    for module, name in ((basis, "point_slots"), (basis, "quad1_fields"),
                         (graph, "component_labels"),
                         (graph, "element_labels"),
                         (graph, "clearly_held"),
                         (locate, "tensor_locate")):
        monkeypatch.setattr(module, name, refuse)
    return monkeypatch


def operator(kernels):
    """The step's point operator of standard MPM on a 2 x 2 grid."""
    mesh = MeshQuad().refined(1)
    scalar, _, dofs, pattern = grid_parts(mesh, ElementQuad1())
    piece = make_method("mpm", mesh, scalar, dofs, pattern,
                        point_locator(mesh), {"locate": 0},
                        kernels=kernels)
    points = seed_points(mesh, 2)
    return piece.operator(points, 1, {"locate": 0., "assemble": 0.}), mesh


@pytest.mark.parametrize("env", ["auto", "numpy"])
def test_kernels_numpy_takes_the_numpy_basis_and_check(refused, env):
    refused.setenv("SKFEM_MPM_KERNELS", env)
    op, mesh = operator("numpy")
    assert op.basis.dx.sum() == pytest.approx(1., rel=1e-14)
    held = np.arange(2 * 3)                  # the bottom row's nodes, x y
    check_rigid_body_modes(op.adjacency(), mesh.p, op.active_dofs, held,
                           2, kernels="numpy")


def test_kernels_compiled_takes_the_compiled_basis_under_numpy_env(
        refused):
    refused.setenv("SKFEM_MPM_KERNELS", "numpy")
    with pytest.raises(Called):
        operator("compiled")
    op, mesh = operator("numpy")
    with pytest.raises(Called):
        check_rigid_body_modes(op.adjacency(), mesh.p, op.active_dofs,
                               np.arange(6), 2, kernels="compiled")


def test_kernels_auto_follows_the_environment(refused):
    refused.setenv("SKFEM_MPM_KERNELS", "auto")
    with pytest.raises(Called):
        operator("auto")
    refused.setenv("SKFEM_MPM_KERNELS", "numpy")
    assert operator("auto")[0].basis.dx.size == 16


def test_simulate_hands_the_kernels_option_to_the_basis(refused):
    """``simulate(..., options=Options(kernels="numpy"))`` builds the
    material-point basis and checks the supports with scikit-fem's and
    scipy's passes under ``SKFEM_MPM_KERNELS=auto`` (it handed the
    method piece the default, and the compiled passes ran)."""
    from skfem_mpm import LinearElastic, Options, simulate
    refused.setenv("SKFEM_MPM_KERNELS", "auto")
    mesh = MeshQuad().refined(2)
    res = simulate(mesh, ElementQuad1(), seed_points(mesh, 2),
                   LinearElastic(1e3, .3),
                   lambda b: b.get_dofs(lambda x: x[1] == 0).all(),
                   body_force=[0., -1.], options=Options(kernels="numpy"))
    assert res.history[-1].load_factor == 1.


def test_tresca_on_the_numpy_path_is_a_warning(monkeypatch, caplog):
    """Mohr-Coulomb without friction (Tresca) falls back to the numpy path
    with ``kernels="auto"``, at about twice an iteration's cost (trial 94:
    0.225 s against von Mises' 0.128): said at WARNING, with the remedy;
    a dilating Mohr-Coulomb takes the passes, a subclass of von Mises (a
    user's law) falls back at INFO."""
    import logging
    from skfem_mpm import MohrCoulomb, VonMises
    from skfem_mpm import kernels
    from skfem_mpm.mechanics import compiled
    monkeypatch.setenv(kernels.AUTO_VARIABLE, "auto")
    monkeypatch.setattr(kernels, "_LOGGED", set())
    # no compilation here: a path the passes serve gets a stand-in
    monkeypatch.setattr(compiled, "compiled_passes", lambda: object())
    monkeypatch.setattr(compiled, "CompiledPasses", lambda *a: "served")

    class Mine(VonMises):
        pass
    cases = [(MohrCoulomb(1e4, .3, cohesion=10., friction_angle=0.),
              logging.WARNING),
             (Mine(1e4, .3, yield_stress=10.), logging.INFO),
             (MohrCoulomb(1e4, .3, cohesion=10., friction_angle=30.), None)]
    for material, level in cases:
        caplog.clear()
        with caplog.at_level(logging.INFO, logger="skfem_mpm.kernels"):
            path = compiled.compiled_path("auto", material, 3)
        said = [(r.levelno, r.getMessage()) for r in caplog.records]
        if level is None:
            assert path == "served" and said == []
            continue
        assert path is None and [lv for lv, _ in said] == [level]
        if level == logging.WARNING:
            assert "MohrCoulomb without friction" in said[0][1]
            assert "about twice" in said[0][1]
            assert "VonMises(yield_stress=sqrt(3) c)" in said[0][1]


def test_the_numpy_path_by_the_environment_is_logged(monkeypatch, caplog):
    """Trial 111: under ``SKFEM_MPM_KERNELS=numpy`` no line said the numpy
    path served (the docstrings said the choice was logged).  It is
    logged once at INFO, naming the variable; ``kernels="numpy"``, asked
    for, is not."""
    import logging
    from skfem_mpm import LinearElastic, kernels
    from skfem_mpm.mechanics.compiled import compiled_path
    monkeypatch.setattr(kernels, "_LOGGED", set())
    monkeypatch.setenv(kernels.AUTO_VARIABLE, "numpy")
    material = LinearElastic(1e6, .3)
    with caplog.at_level(logging.INFO, logger="skfem_mpm"):
        assert compiled_path("numpy", material, 2) is None
        assert "numpy path" not in caplog.text
        for _ in range(2):
            assert compiled_path("auto", material, 2) is None
    said = [r for r in caplog.records if "numpy path" in r.getMessage()]
    assert len(said) == 1 and said[0].levelno == logging.INFO
    assert "{}=numpy".format(kernels.AUTO_VARIABLE) in said[0].getMessage()
