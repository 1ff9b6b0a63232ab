"""The compiled points-first passes (``kernels="compiled"``) equal the
numpy path, the reference, to round-off: a response's stress measure,
internal force, stiffness (the CSR data of one pattern) and committed state
in 2D and 3D, small and finite deformation, elastic, von Mises and
Drucker-Prager, at the start and after a step; whole runs alike; a resumed compiled run is
bit-identical to the uninterrupted one.  The choice is checked: an unknown
name refused, a run the passes cannot serve refused when they are asked
for, served by numpy (logged once) otherwise, and the package works where
numba does not import."""
import dataclasses
import json
import logging
import sys
from pathlib import Path

import numpy as np
import pytest
from skfem import (ElementHex1, ElementQuad1, ElementQuad2, ElementTriP1,
                   MeshHex, MeshQuad, MeshTri)

from skfem_mpm import (DruckerPrager, LinearElastic, MohrCoulomb, Options,
                       Resume, VonMises, seed_points, simulate)
from skfem_mpm import kernels
from skfem_mpm.errors import InvalidInputError
from skfem_mpm.mechanics.kinematics import make_kinematics
from skfem_mpm.mechanics.materials import initial_state
from skfem_mpm.methods.operators import PointOperator
from skfem_mpm.quadrature.basis import MaterialPointBasis
from digest_cases import CASES, fingerprint

pytest.importorskip("numba")

DIGESTS = json.loads((Path(__file__).parent / "data"
                      / "core_digests.json").read_text())

#: round-off: the paths sum in different orders, and in 3D the principal
#: frames come from Jacobi rotations against LAPACK's
TOL = 1e-12
MATERIALS = {"elastic": LinearElastic(1e6, .3),
             "von_mises": VonMises(1e6, .3, 2e3),
             "drucker_prager": DruckerPrager(
                 1e6, .3, cohesion=1e3, friction_angle=30.,
                 dilation_angle=10., hardening=1e4)}
GRIDS = {2: (MeshQuad, ElementQuad1), 3: (MeshHex, ElementHex1)}


def relative(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def block(dim, ncells=4):
    """A block of 2^dim points a cell inside a grid one cell wider."""
    h = 1. / ncells
    axis = np.linspace(-h, 1. + h, ncells + 3)
    mesh = GRIDS[dim][0].init_tensor(*[axis] * dim)
    points = seed_points(mesh, 2, region=lambda x: np.all(
        (x > 0) & (x < 1), axis=0))
    return mesh, points


def evaluate(kinematics, op, du, points):
    response = kinematics.response(op, du, points)
    force = op.force(response.P, response.w) if response.force is None \
        else response.force()
    K = op.stiffness(response.tangent(), response.w) \
        if response.stiffness is None else response.stiffness()
    return response, force, K, response.commit(points)


def check_equal(numpy_path, compiled_path, finite):
    (r0, f0, K0, new0), (r1, f1, K1, new1) = numpy_path, compiled_path
    assert r1.force is not None and r0.force is None
    assert relative(r1.P, r0.P) < TOL
    assert relative(f1, f0) < TOL
    assert np.array_equal(K1.indices, K0.indices)
    assert relative(K1.data, K0.data) < TOL
    assert np.array_equal(r1.yielded, r0.yielded)
    for name in ("stress", "strain") + (("F", "be", "volume") if finite
                                        else ()):
        assert relative(getattr(new1, name), getattr(new0, name)) < TOL, name
    assert new1.state.keys() == new0.state.keys()
    for name in new0.state:
        assert np.abs(new1.state[name] - new0.state[name]).max() <= \
            TOL * max(np.abs(new0.state[name]).max(), 1e-30), name


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kind", ["small", "finite"])
@pytest.mark.parametrize("name", sorted(MATERIALS))
def test_a_response_equals_the_numpy_path(dim, kind, name):
    """Two trials in a row: from the initial state, and from the state
    the first committed (a start with stress, elastic strain, ``F`` and
    plastic strain); the von Mises increments yield most points."""
    material = MATERIALS[name]
    mesh, points = block(dim)
    points.state.update(initial_state(material, points.n))
    op = PointOperator(MaterialPointBasis(mesh, GRIDS[dim][1](), points))
    rng = np.random.default_rng(dim)
    counters = {"return_maps": 0}
    paths = {k: make_kinematics(kind, material, dim, counters, kernels=k)
             for k in ("numpy", "compiled")}
    start = points
    for trial in range(2):
        du = 2e-3 * rng.standard_normal(op.N)
        results = [evaluate(paths[k], op, du, start)
                   for k in ("numpy", "compiled")]
        check_equal(*results, finite=kind == "finite")
        if name != "elastic":
            assert results[1][0].yielded.mean() > .5
        start = results[0][3]


def column_run(dim, kinematics, material, kernels_used, nsteps=3, points=None, method="mpm", **kwargs):
    """A column (2 cells wide, 4 high, 2^dim points a cell) under its
    weight, its base fixed, on rollers at x = 0 (and y = 0), free on the
    other sides (the bottom corners yield), with ``kernels_used``
    (``Options.kernels``)."""
    kwargs["options"] = dataclasses.replace(
        kwargs.get("options", Options()), kernels=kernels_used)
    mesh = GRIDS[dim][0].init_tensor(*[np.linspace(0, 3, 4)] * (dim - 1),
                                     np.linspace(0, 5, 6))
    if points is None:
        points = seed_points(mesh, 2, region=lambda x: (x[-1] < 4) & np.all(
            x[:-1] < 2, axis=0))

    def supports(basis):
        return np.concatenate(
            [basis.get_dofs(lambda x: x[-1] == 0).all()]
            + [basis.get_dofs(lambda x, a=a: x[a] == 0).nodal["u^{}".format(
                a + 1)] for a in range(dim - 1)])
    return simulate(mesh, GRIDS[dim][1](), points, material, supports,
                    body_force=np.r_[np.zeros(dim - 1), -1.5e3],
                    nsteps=nsteps, method=method, kinematics=kinematics,
                    **kwargs)


@pytest.mark.parametrize("dim, kinematics, name", [
    (2, "finite", "von_mises"), (2, "small", "von_mises"),
    (3, "finite", "elastic")])
def test_runs_equal_the_numpy_path(dim, kinematics, name):
    material = MATERIALS[name]
    runs = [column_run(dim, kinematics, material, k)
            for k in ("numpy", "compiled")]
    assert [len(r.history) for r in runs[0:1]] == [len(runs[1].history)]
    for a, b in zip(runs[0].history, runs[1].history):
        assert len(a.newton_residuals) == len(b.newton_residuals)
        assert relative(b.u, a.u) < TOL
    for field in ("x", "stress", "strain"):
        assert relative(getattr(runs[1].points, field),
                        getattr(runs[0].points, field)) < TOL
    if name == "von_mises":
        assert runs[0].history[-1].n_yielded > 0


def test_a_resumed_compiled_run_is_bit_identical():
    """Resumed after step 2 of 4 from the state a callback saw, the
    compiled run ends where the whole compiled run does, bit for bit."""
    saved = {}

    def keep(record, state):
        if record.step == 2:
            saved.update(record=record, state=state)
    material = MATERIALS["von_mises"]
    whole = column_run(2, "finite", material, "compiled", nsteps=4,
                       options=Options(callback=keep))
    rest = column_run(2, "finite", material, "compiled", nsteps=4,
                      points=saved["state"], options=Options(
                          resume=Resume.after(saved["record"])))
    assert [r.step for r in rest.history] == [3, 4]
    assert whole.history[-1].n_yielded > 0
    for name in ("x", "stress", "strain", "F", "volume"):
        assert np.array_equal(getattr(rest.points, name),
                              getattr(whole.points, name)), name


def test_the_choice_is_checked():
    with pytest.raises(InvalidInputError, match="kernels must be one of"):
        Options(kernels="fast")
    assert Options(kernels="numpy").kernels == "numpy"
    for material, dim, scheme, why in (
            (MohrCoulomb(1e6, .3, 1e3, 30.), 2, False,
             "the material MohrCoulomb"),
            (LinearElastic(1e6, .3), 1, False, "1D grids"),
            (LinearElastic(1e6, .3), 2, True, "total Lagrangian")):
        with pytest.raises(InvalidInputError, match=why):
            make_kinematics("finite", material, dim, {}, scheme,
                            kernels="compiled")
        assert make_kinematics("finite", material, dim, {}, scheme
                               ).compiled is None
    assert make_kinematics("small", LinearElastic(1e6, .3), 3, {}
                           ).compiled is not None


def test_an_operator_without_passes_runs_on_numpy_logged_once(
        monkeypatch, caplog):
    """cpGIMP's sparse operator has no compiled pass: asked for
    explicitly, one warning, and the numpy path's answer."""
    monkeypatch.setattr(kernels, "_LOGGED", set())
    with caplog.at_level(logging.INFO, logger="skfem_mpm.kernels"):
        result = column_run(2, "finite", MATERIALS["elastic"], "compiled",
                            nsteps=2, method="cpgimp")
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "SparseOperator" in \
        warnings[0].getMessage()
    reference = column_run(2, "finite", MATERIALS["elastic"], "numpy",
                           nsteps=2, method="cpgimp")
    assert np.array_equal(result.points.stress, reference.points.stress)


@pytest.mark.parametrize("elem", [ElementQuad2, ElementTriP1])
def test_other_elements_equal_the_numpy_path(elem):
    """The passes take any number of nodes an element: quadratic
    quadrilaterals, linear triangles."""
    material = MATERIALS["von_mises"]
    mesh = (MeshTri if elem is ElementTriP1 else MeshQuad).init_tensor(
        *[np.linspace(-.25, 1.25, 7)] * 2)
    points = seed_points(MeshQuad.init_tensor(*[np.linspace(0, 1, 5)] * 2),
                         2)
    points.state.update(initial_state(material, points.n))
    op = PointOperator(MaterialPointBasis(mesh, elem(), points))
    du = 2e-3 * np.random.default_rng(1).standard_normal(op.N)
    results = [evaluate(make_kinematics("finite", material, 2,
                                        {"return_maps": 0}, kernels=k),
                        op, du, points) for k in ("numpy", "compiled")]
    check_equal(*results, finite=True)


def test_without_numba_the_numpy_path_serves(monkeypatch, caplog):
    """numba made to fail on import: ``auto`` runs on numpy (logged once),
    ``compiled`` is refused before any work."""
    monkeypatch.setattr(kernels, "_PASSES", [])
    monkeypatch.setattr(kernels, "_LOGGED", set())
    monkeypatch.setitem(sys.modules, "numba", None)
    for name in ("skfem_mpm.kernels.passes",
                 "skfem_mpm.kernels.constitutive"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    monkeypatch.delattr(kernels, "passes", raising=False)
    monkeypatch.delattr(kernels, "constitutive", raising=False)
    with caplog.at_level(logging.INFO, logger="skfem_mpm.kernels"):
        for _ in range(2):
            assert make_kinematics("finite", MATERIALS["elastic"], 2,
                                   {}).compiled is None
    assert [r.getMessage() for r in caplog.records if "numba" in
            r.getMessage()] == ["numba does not import (import of numba "
                                "halted; None in sys.modules): the numpy "
                                "path serves every run"]
    with pytest.raises(InvalidInputError, match="without numba"):
        make_kinematics("small", MATERIALS["elastic"], 2, {},
                        kernels="compiled")
    result = column_run(2, "small", MATERIALS["elastic"], "auto",
                        nsteps=1)
    assert result.history[-1].residual < 1e-10


def test_numba_is_not_imported_with_the_package():
    import subprocess
    done = subprocess.run([sys.executable, "-c", (
        "import sys, skfem_mpm; print('numba' in sys.modules)")],
        capture_output=True, text=True, timeout=120)
    assert done.stdout.strip() == "False", done.stderr


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_core_digests_hold_to_round_off(name):
    """The runs through every piece of the core (``digest_cases.py``) with
    the default kernels, where the compiled passes serve MPM, end within
    1e-12 of the numpy path's fingerprints."""
    stored = DIGESTS["cases"][name]["sums"]
    now = fingerprint(CASES[name]())["sums"]
    assert sorted(now) == sorted(stored)
    for key, value in stored.items():
        assert now[key] == pytest.approx(value, rel=1e-12, abs=1e-300), key


def test_the_passes_change_with_what_they_compile_in():
    """numba's cache keys each function on its own file: the passes carry
    the hash of the files they compile in (``passes.SOURCES``), so that
    a change there invalidates their cached code."""
    import hashlib
    from skfem_mpm.kernels import passes
    root = Path(passes.__file__).parent
    digest = hashlib.sha256((root / "__init__.py").read_bytes() + (
        root / "constitutive.py").read_bytes()).hexdigest()[:16]
    assert passes.SOURCES == digest, (
        "kernels/__init__.py or constitutive.py changed: set "
        "passes.SOURCES = {!r}".format(digest))
