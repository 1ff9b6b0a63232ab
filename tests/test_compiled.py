"""The compiled points-first passes (``kernels="compiled"``) equal the
numpy path, the reference, to round-off: a response's stress measure,
internal force, stiffness (the CSR data of one pattern) and committed state
with standard MPM's and GIMP's operators, with and without mean
dilatation, in 2D and 3D, small and finite deformation, every material of
the passes, also one a body (``PointMaterials``), at the start and after a
step; whole runs alike (MPM, uGIMP, cpGIMP, B-splines; with mean
dilatation also a footing pushed by an obstacle; soil and a stiffer
inclusion; bodies in contact); a resumed compiled run is bit-identical to
the uninterrupted one.  The choice is
checked: an unknown name refused, a run the passes cannot serve refused
when they are asked for, served by numpy (logged once) otherwise, and the
package works where numba does not import."""
import dataclasses
import functools
import json
import logging
import sys
from pathlib import Path

import numpy as np
import pytest
from skfem import (ElementHex1, ElementQuad1, ElementQuad2, ElementTriP1,
                   ElementVector, MeshHex, MeshQuad, MeshTri)

from skfem_mpm import (Contact, DruckerPrager, LinearElastic,
                       ModifiedCamClay, MohrCoulomb, NewtonOptions, Options,
                       Prescribed, Resume, Stabilisation, Traction, VonMises,
                       point_locator, seed_points, simulate)
from skfem_mpm import kernels
from skfem_mpm.errors import (InvalidInputError, InversionError,
                              PointsOutsideGridError)
from skfem_mpm.mechanics.kinematics import make_kinematics
from skfem_mpm.mechanics.materials import PointMaterials, initial_state
from skfem_mpm.methods.gimp_linear import LinearGimp
from skfem_mpm.methods.operators import AsmOperator, PointOperator
from skfem_mpm.quadrature.basis import MaterialPointBasis
from skfem_mpm.quadrature.points import concatenate_points
from skfem_mpm.solve.loads import side_points
from skfem_mpm.stabilisation.fbar import IncrementFbar
from skfem_mpm.stabilisation.volumetric import MeanDilatation
from digest_cases import CASES, fingerprint

pytest.importorskip("numba")
#: the passes compile once per installation (about 90 s): these tests run
#: with the slow ones, and the others on the numpy path (tests/conftest.py)
pytestmark = pytest.mark.slow

DIGESTS = json.loads((Path(__file__).parent / "data"
                      / "core_digests.json").read_text())

#: round-off: the paths sum in different orders, and in 3D the principal
#: frames come from Jacobi rotations against LAPACK's
TOL = 1e-12
#: the grid displacements' round-off (:func:`check_runs_equal`): GIMP's
#: grid nodes that the points' domains barely reach are determined to
#: the condition number times round-off
GRID_TOL = 1e-10
MATERIALS = {"elastic": LinearElastic(1e6, .3),
             "von_mises": VonMises(1e6, .3, 2e3),
             "drucker_prager": DruckerPrager(
                 1e6, .3, cohesion=1e3, friction_angle=30.,
                 dilation_angle=10., hardening=1e4),
             "mohr_coulomb": MohrCoulomb(1e6, .3, cohesion=1e3,
                                         friction_angle=30.,
                                         dilation_angle=10.),
             "cam_clay": ModifiedCamClay(
                 kappa=.02, lambda_=.2, M=1.2, shear_modulus=2e3,
                 reference_pressure=100., preconsolidation_pressure=105.)}
GRIDS = {2: (MeshQuad, ElementQuad1), 3: (MeshHex, ElementHex1)}
#: one material a body (body 0, body 1): two elastic ones, a plastic soil
#: and a stiff elastic pile, and two plastic kinds of other internal
#: variables (Cam clay's two, von Mises' one)
PILE = LinearElastic(3e7, .2)
BODIES = {"elastic+elastic": (MATERIALS["elastic"], LinearElastic(4e6, .1)),
          "von_mises+elastic": (MATERIALS["von_mises"], PILE),
          "mohr_coulomb+elastic": (MATERIALS["mohr_coulomb"], PILE),
          "cam_clay+von_mises": (MATERIALS["cam_clay"],
                                 MATERIALS["von_mises"])}


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


def operator(method, mesh, points, dim):
    """Standard MPM's operator of ``points``, or GIMP's with the points of
    the lower half moved by up to a fifth of a cell and their domains
    grown by up to a quarter, so that their supports differ in size and
    nodes (4 to 9 nodes in 2D, 8 to 27 in 3D) while the upper half's
    cells hold points of one support each (and a cell's points, those
    whose centre lies in it, several supports)."""
    elem = GRIDS[dim][1]()
    if method == "mpm":
        return PointOperator(MaterialPointBasis(mesh, elem, points))
    rng = np.random.default_rng(dim)
    moved = points.x[-1] < .5
    x, domain = points.x.copy(), points.domain.copy()
    x[:, moved] += .05 * rng.uniform(-1, 1, (dim, moved.sum()))
    domain[:, moved] *= rng.uniform(1., 1.25, (dim, moved.sum()))
    op = LinearGimp(mesh, elem)(x, domain)
    op.point_elements = point_locator(mesh)(x)[0]
    groups = op.kernel_layout().groups
    counts, runs = groups[3], groups[4]
    assert counts.min() == 2 ** dim and counts.max() == 3 ** dim
    assert len(runs) - 1 < .8 * points.n     # groups of several points
    return op


def evaluate(kinematics, op, du, points, before=None):
    """``(response, force, K, new state, P)``: the stress measure read
    before the commit, which a compiled one's refuses after it (as what
    ``before(response)`` reads)."""
    response = kinematics.response(op, du, points)
    force = op.force(response.P, response.w) if response.force is None \
        else response.force()
    K = op.stiffness(response.tangent(), response.w) \
        if response.stiffness is None else response.stiffness()
    P = response.P
    if before is not None:
        before(response)
    return response, force, K, response.commit(points), P


def check_equal(numpy_path, compiled_path, finite):
    (r0, f0, K0, new0, P0), (r1, f1, K1, new1, P1) = numpy_path, \
        compiled_path
    assert r1.force is not None and r0.force is None
    assert relative(P1, P0) < TOL
    assert relative(f1, f0) < TOL
    # the numpy path's entries on the compiled pattern (GIMP's sparse
    # products come in a pattern of their own: unsorted, exact zeros out)
    rows = np.repeat(np.arange(K1.shape[0]), np.diff(K1.indptr))
    on = type(K1)((np.asarray(K0[rows, K1.indices]).ravel(), K1.indices,
                   K1.indptr), shape=K1.shape)
    assert K1.has_canonical_format and abs(K0 - on).max() == 0
    assert relative(K1.data, on.data) < TOL
    assert np.array_equal(r1.yielded, r0.yielded)
    for name in ("stress", "strain") + (("F", "be", "volume") if finite
                                        else ()):
        assert relative(getattr(new1, name), getattr(new0, name)) < TOL, name
    assert new1.state.keys() == new0.state.keys()
    for name in new0.state:
        assert np.abs(new1.state[name] - new0.state[name]).max() <= \
            TOL * max(np.abs(new0.state[name]).max(), 1e-30), name


@pytest.mark.parametrize("method", ["mpm", "gimp"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("name", sorted(MATERIALS) + sorted(BODIES))
@pytest.mark.parametrize("kind, antilocking", [
    ("small", False), ("finite", False), ("small", True), ("finite", True),
    ("finite", "fbar")])
def test_a_response_equals_the_numpy_path(dim, kind, name, method,
                                          antilocking):
    """Two trials in a row: from the initial state, and from the state
    the first committed (a start with stress, elastic strain, ``F`` and
    plastic strain); the plastic increments yield most points of a
    plastic material, an elastic one's none.  With mean dilatation
    (``antilocking``) the operator is wrapped in the cell averages of each
    trial's start, as a step wraps it; with F-bar on the increment
    (``"fbar"``, finite deformation: :class:`~skfem_mpm.stabilisation.
    fbar.IncrementFbar`, the passes of :mod:`skfem_mpm.kernels.fbar`;
    before, the numpy path served it, no compiled force) in its scaled
    increments, the force and the stiffness's framed material part and
    geometric part.  One material a body
    (``PointMaterials``, ``BODIES``): every third point of body 1, so that
    a group's points change body from one to the next, and a body's
    internal variables stay put on the other body's points."""
    mesh, points = block(dim)
    materials = BODIES.get(name, (MATERIALS.get(name),))
    if name in BODIES:
        points.body = (np.arange(points.n) % 3 == 0).astype(np.int64)
    material = PointMaterials(materials, points.body) if name in BODIES \
        else materials[0]
    points.state.update(initial_state(material, points.n))
    op = operator(method, mesh, points, dim)
    rng = np.random.default_rng(dim)
    counters = {"return_maps": 0}
    paths = {k: make_kinematics(kind, material, dim, counters, kernels=k)
             for k in ("numpy", "compiled")}
    start = points
    for trial in range(2):
        du = 2e-3 * rng.standard_normal(op.N)
        wrapped = IncrementFbar(op, start.volume) if antilocking == "fbar" \
            else MeanDilatation(op, start.volume) if antilocking else op
        results = [evaluate(paths[k], wrapped, du, start)
                   for k in ("numpy", "compiled")]
        check_equal(*results, finite=kind == "finite")
        yielded, new = results[1][0].yielded, results[1][3]
        for b, each in enumerate(materials):
            mine = points.body == b
            assert yielded[mine].mean() > .5 if each.plastic \
                else not yielded[mine].any()
            for other in set(new.state) - set(each.state_variables):
                assert np.array_equal(new.state[other][mine],
                                      start.state[other][mine]), other
        start = results[0][3]


def test_hookes_tensor_is_formed_once_for_each_number_of_components(
        monkeypatch):
    """A compiled small-strain elastic kinematics forms Hooke's tensor of
    the stiffness pass once for each number of components (33 us at
    every response before, at 56 points), and its stiffness stays the
    numpy path's: responses without and with mean dilatation (3
    components) in turn."""
    from skfem_mpm.mechanics import compiled as module
    formed, original = [], module.elastic_tensor

    def counted(material, n, k):
        formed.append(k)
        return original(material, n, k)
    monkeypatch.setattr(module, "elastic_tensor", counted)
    material = MATERIALS["elastic"]
    mesh, points = block(2)
    op = operator("mpm", mesh, points, 2)
    rng = np.random.default_rng(7)
    compiled = make_kinematics("small", material, 2, {"return_maps": 0},
                               kernels="compiled")
    reference = make_kinematics("small", material, 2, {"return_maps": 0},
                                kernels="numpy")
    for antilocking in (False, True, False, True):
        du = 2e-3 * rng.standard_normal(op.N)
        wrapped = MeanDilatation(op, points.volume) if antilocking else op
        check_equal(*(evaluate(kinematics, wrapped, du, points)
                      for kinematics in (reference, compiled)), False)
    assert formed == [2, 3]


def test_the_reused_increments_follow_the_operator():
    """A compiled finite kinematics reuses its ``dF``, ``dF^-1`` and
    frames, whose 2D pass without mean dilatation stores the in-plane
    blocks only: responses with and without mean dilatation (whose
    ``dF_33`` is not 1) in turn, on the same points, each equal to the
    numpy path's, its commit too, and its numpy tangent (formed from the
    spectral parts: the passes keep no ``b_tr - I``)."""
    material = MATERIALS["von_mises"]
    mesh, points = block(2)
    points.state.update(initial_state(material, points.n))
    op = operator("mpm", mesh, points, 2)
    rng = np.random.default_rng(5)
    compiled = make_kinematics("finite", material, 2, {"return_maps": 0},
                               kernels="compiled")
    for antilocking in (False, True, False):
        du = 2e-3 * rng.standard_normal(op.N)
        wrapped = MeanDilatation(op, points.volume) if antilocking else op
        reference = make_kinematics("finite", material, 2,
                                    {"return_maps": 0}, kernels="numpy")
        tangents = []
        results = [evaluate(kinematics, wrapped, du, points,
                            lambda r: tangents.append(r.tangent()))
                   for kinematics in (reference, compiled)]
        check_equal(*results, finite=True)
        assert relative(tangents[1], tangents[0]) < TOL


def test_the_passes_keep_points_first():
    """What only the passes write and read between a finite trial and its
    stiffness and commit, the spectral parts, ``dF``, ``dF^-1`` and
    ``b_n - I``, lies points first in memory (a point's entries side by
    side: the strides of an (n, ...) array), points last in its shape as
    the numpy path reads it; the kinematics' workspace has it so from the
    compiled path (one workspace, no one re-seeds it); the Kirchhoff
    stress, which the commit divides into the points' stress, and the
    points' stress, strain and ``F``, which the commit hands on, stay
    points last in memory."""
    material = MATERIALS["von_mises"]
    mesh, points = block(2)
    points.state.update(initial_state(material, points.n))
    op = operator("mpm", mesh, points, 2)
    kinematics = make_kinematics("finite", material, 2, {"return_maps": 0},
                                 kernels="compiled")
    du = 2e-3 * np.random.default_rng(2).standard_normal(op.N)
    new = evaluate(kinematics, op, du, points)[3]
    compiled = kinematics.compiled
    workspace = kinematics.workspace(points.n, 2, False)
    assert workspace is kinematics.workspace(points.n, 2, False)
    kept = (tuple(workspace[3])
            + compiled._increment_arrays(points.n, 2)
            + (compiled._start_deviation(points),))
    for a in kept:
        assert a.shape[-1] == points.n
        assert a.strides[-1] == a[..., 0].size * 8, a.strides
    assert all((new.stress.flags.c_contiguous, new.strain.flags.c_contiguous,
               new.F.flags.c_contiguous, workspace[1].flags.c_contiguous))


@pytest.mark.parametrize("chunks", [False, True])
def test_a_commit_writes_the_state_into_the_trials_arrays(chunks,
                                                          monkeypatch):
    """A compiled finite commit writes the new state's ``F`` into the
    trial's ``dF^-1``, ``b_e`` into the step's ``b_n - I`` and the stress
    into the Kirchhoff stress (divided in place), which the step reads no
    more (at 1e6 points in 2D, 216 MB of new pages less at the commit);
    the kinematics and passes make new ones for the next response, whose
    trial and commit equal a fresh kinematics' to the bit; the committed
    response's stress measure, tangent, stiffness and commit are refused
    (``InvalidInputError``), its force and deformation stay.  Serial and
    in chunks of points (a 2D block in chunks of 8 points)."""
    from skfem_mpm.methods import assembly
    if chunks:
        monkeypatch.setattr(assembly, "CHUNK_POINTS", 8)
    material = MATERIALS["von_mises"]
    mesh, points = block(2)
    points.state.update(initial_state(material, points.n))
    op = operator("mpm", mesh, points, 2)
    assert (op.kernel_layout().chunks is not None) == chunks

    def kinematics():
        return make_kinematics("finite", material, 2, {"return_maps": 0},
                               kernels="compiled")
    mine = kinematics()
    rng = np.random.default_rng(7)
    du = 2e-3 * rng.standard_normal(op.N)
    response = mine.response(op, du, points)
    tau = mine.workspace(points.n, 2, False)[1]
    dF, dF_inv = mine.compiled._increment_arrays(points.n, 2)
    start = mine.compiled._start_deviation(points)
    force = response.force()
    new = response.commit(points)
    for state, trial in ((new.F, dF_inv), (new.be, start),
                         (new.stress, tau)):
        assert np.shares_memory(state, trial)
        assert state.flags.c_contiguous and state.shape == (3, 3, points.n)
    for read in (lambda: response.P, response.tangent,
                 lambda: response.tangent_of(slice(None)),
                 response.stiffness, lambda: response.commit(points)):
        with pytest.raises(InvalidInputError, match="after its commit"):
            read()
    assert np.array_equal(response.force(), force)
    assert response.deformation(slice(None)).shape == (3, 3, points.n)
    assert mine.workspace(points.n, 2, False)[1] is not tau
    assert not np.shares_memory(
        mine.compiled._increment_arrays(points.n, 2)[1], dF_inv)
    # the next step's trial on the committed state, against a fresh one
    du = 2e-3 * rng.standard_normal(op.N)
    results = []
    for each in (mine, kinematics()):
        response = each.response(op, du, new)
        P, K = response.P, response.stiffness()
        results.append((P, K.data, response.force(), response.commit(new)))
    (P0, K0, f0, new0), (P1, K1, f1, new1) = results
    assert all(np.array_equal(a, b) for a, b in ((P0, P1), (K0, K1),
                                                  (f0, f1)))
    for name in ("F", "be", "strain", "stress", "volume"):
        assert np.array_equal(getattr(new0, name), getattr(new1, name)), \
            name


def test_unstrained_points_start_from_zeros(monkeypatch):
    """A finite step from unstrained points (a first step from rest) takes
    ``b_n - I`` as new zeros, what the pass writes there (``+0.``, also
    from ``-0.`` strains), without the pass (at 1e6 points in 2D 0.10-0.18
    s and 72 MB of new pages of the step's first residual); a strained
    state takes the pass."""
    from skfem_mpm.kernels import parallel, passes
    from skfem_mpm.mechanics.compiled import points_first
    strain = np.zeros((3, 3, 4))
    strain[0, 1, 1] = strain[1, 0, 1] = strain[2, 2, 3] = -0.
    assert passes.unstrained(strain)
    for dim in (2, 3):
        out = points_first(4, 3, 3)
        passes.start_deviation(dim, strain, out)
        assert not np.any(out) and not np.signbit(out).any()
    strain[1, 1, 3] = 1e-300
    assert not passes.unstrained(strain)
    material = MATERIALS["elastic"]
    mesh, points = block(2)
    kinematics = make_kinematics("finite", material, 2, {"return_maps": 0},
                                 kernels="compiled")

    def refused(*args):
        raise AssertionError("the pass ran")
    monkeypatch.setattr(passes, "start_deviation", refused)
    monkeypatch.setattr(parallel, "start_deviation_in_chunks", refused)
    start = kinematics.compiled._start_deviation(points)
    assert start.shape == (3, 3, points.n) and not np.any(start)
    monkeypatch.undo()
    points.strain = points.strain.copy()
    points.strain[0, 0] = 1e-3
    assert np.any(kinematics.compiled._start_deviation(points))


def test_the_mohr_coulomb_return_equals_numpy_on_every_branch():
    """The compiled return map on principal strains, point by point,
    against :meth:`MohrCoulomb.principal_update` on all points at once:
    stresses, elastic strains, the tangent and the hardening variable to
    round-off, with states returned to the plane, to both edges and to the
    apex among them (from the returned stresses' coincident values)."""
    from skfem_mpm.kernels.constitutive import principal_update
    from skfem_mpm.mechanics.compiled import material_parameters
    material = MohrCoulomb(1e4, .3, cohesion=10., friction_angle=30.,
                           dilation_angle=10.)
    rng = np.random.default_rng(0)
    eps = np.hstack((3e-3 * rng.standard_normal((3, 200)), np.array([
        [.002, .002, -.01], [.01, -.002, -.002], [.02, .02, .02],
        [.001, -.001, 0.], [0., 0., 0.]]).T))
    alpha = rng.uniform(0, 1e-3, eps.shape[1])
    tau, eps_e, D, yielded, state = material.principal_update(
        eps, {"equivalent_plastic_strain": alpha})
    params = material_parameters(material)
    out = [np.empty(3), np.empty(3), np.empty((3, 3))]
    for p in range(eps.shape[1]):
        assert principal_update(params, eps[:, p].copy(), alpha[p], 0.,
                                *out) == (yielded[p], pytest.approx(
                                    state["equivalent_plastic_strain"][p],
                                    rel=TOL, abs=1e-20), 0.)
        for mine, theirs in zip(out, (tau, eps_e, D)):
            assert np.abs(mine - theirs[..., p]).max() <= \
                TOL * np.abs(theirs).max()
    s = -np.sort(-tau, axis=0)
    close = np.abs(np.diff(s, axis=0)) < 1e-9 * np.abs(s).max()
    apex = close.all(axis=0) & yielded
    branches = (~close.any(axis=0) & yielded, close[0] & ~apex,
                close[1] & ~apex, apex)
    assert [int(b.sum()) > 5 for b in branches] == [True] * 4
    assert (~yielded).sum() > 5


def test_the_cam_clay_return_equals_numpy_with_its_fallback(monkeypatch):
    """The compiled Cam clay return point by point against
    :meth:`ModifiedCamClay.principal_update` on trial states about the
    reference pressure and far ones (strains to -0.5, overconsolidation
    20), some of which leave Newton's path for the bracketed solve:
    stresses, elastic strains, tangent and both internal variables to
    round-off; the iteration constants are the numpy path's."""
    from skfem_mpm.kernels import cam_clay as compiled
    from skfem_mpm.kernels.constitutive import principal_update
    from skfem_mpm.mechanics import cam_clay
    from skfem_mpm.mechanics.compiled import material_parameters
    assert (compiled.RETURN_TOL, compiled.RETURN_MAX_ITER) == (
        cam_clay.RETURN_TOL, cam_clay.RETURN_MAX_ITER)
    bracketed = []
    original = ModifiedCamClay._bracketed_return
    monkeypatch.setattr(ModifiedCamClay, "_bracketed_return", lambda *args: (
        bracketed.append(args[1].size) or original(*args)))
    material = ModifiedCamClay(kappa=.02, lambda_=.2, M=1.2,
                               shear_modulus=2e3, reference_pressure=100.,
                               preconsolidation_pressure=2e3)
    rng = np.random.default_rng(3)
    eps = np.hstack((rng.normal(0., .02, (3, 100)) - .01,
                     rng.uniform(-.5, .2, (3, 100))))
    state = {"plastic_volumetric_strain": rng.normal(0., .05, 200),
             "equivalent_plastic_strain": np.abs(rng.normal(0., .01, 200))}
    tau, eps_e, D, yielded, new = material.principal_update(eps, state)
    assert sum(bracketed) > 0 and 0 < yielded.mean() < 1
    params = material_parameters(material)
    out = [np.empty(3), np.empty(3), np.empty((3, 3))]
    for p in range(eps.shape[1]):
        flag, eq, ev = principal_update(
            params, eps[:, p].copy(), state["equivalent_plastic_strain"][p],
            state["plastic_volumetric_strain"][p], *out)
        assert flag == yielded[p]
        assert eq == pytest.approx(new["equivalent_plastic_strain"][p],
                                   rel=TOL, abs=1e-20)
        assert ev == pytest.approx(new["plastic_volumetric_strain"][p],
                                   rel=TOL, abs=1e-20)
        for mine, theirs in zip(out, (tau, eps_e, D)):
            assert np.abs(mine - theirs[..., p]).max() <= \
                TOL * np.abs(theirs).max()


def column(dim):
    """The grid and points of :func:`column_run`."""
    mesh = GRIDS[dim][0].init_tensor(*[np.linspace(0, 3, 4)] * (dim - 1),
                                     np.linspace(0, 5, 6))
    return mesh, seed_points(mesh, 2, region=lambda x: (x[-1] < 4) & np.all(
        x[:-1] < 2, axis=0))


def column_run(dim, kinematics, material, kernels_used, nsteps=3,
               points=None, method="mpm", **kwargs):
    """A column (2 cells wide, 4 high, 2^dim points a cell) under its
    weight, its base fixed, on rollers at x = 0 (and y = 0), free on the
    other sides (the bottom corners yield), with ``kernels_used``
    (``Options.kernels``)."""
    kwargs["options"] = dataclasses.replace(
        kwargs.get("options", Options()), kernels=kernels_used)
    mesh, seeded = column(dim)
    points = seeded if points is None else points

    def supports(basis):
        return np.concatenate(
            [basis.get_dofs(lambda x: x[-1] == 0).all()]
            + [basis.get_dofs(lambda x, a=a: x[a] == 0).nodal["u^{}".format(
                a + 1)] for a in range(dim - 1)])
    return simulate(mesh, GRIDS[dim][1](), points, material, supports,
                    body_force=np.r_[np.zeros(dim - 1), -1.5e3],
                    nsteps=nsteps, method=method, kinematics=kinematics,
                    **kwargs)


#: the runs' materials: those of the responses, and von Mises nearly
#: incompressible (where mean dilatation matters)
RUN_MATERIALS = {**MATERIALS, "incompressible": VonMises(1e6, .49, 3e3)}


@pytest.mark.parametrize("dim, kinematics, name, method, antilocking", [
    (2, "finite", "von_mises", "mpm", False),
    (2, "small", "von_mises", "mpm", False),
    (3, "finite", "elastic", "mpm", False),
    (2, "finite", "von_mises", "cpgimp", False),
    (2, "small", "drucker_prager", "ugimp", False),
    (3, "finite", "elastic", "cpgimp", False),
    (3, "small", "von_mises", "ugimp", False),
    (2, "finite", "von_mises", "ugimp", False),
    (2, "small", "elastic", "cpgimp", False),
    (2, "finite", "von_mises", "bspline", False),
    (2, "finite", "mohr_coulomb", "cpgimp", False),
    (3, "small", "mohr_coulomb", "mpm", False),
    (2, "small", "incompressible", "mpm", True),
    (2, "finite", "mohr_coulomb", "mpm", True),
    (3, "small", "mohr_coulomb", "mpm", True),
    (3, "finite", "von_mises", "mpm", True),
    (2, "small", "mohr_coulomb", "cpgimp", True),
    (2, "finite", "von_mises", "ugimp", True),
    (2, "finite", "incompressible", "cpgimp", True),
    (2, "small", "elastic", "cpgimp", True),
    (3, "finite", "elastic", "cpgimp", True),
    (3, "small", "mohr_coulomb", "ugimp", True),
    (2, "finite", "von_mises", "bspline", True),
    (2, "small", "elastic+elastic", "mpm", False),
    (2, "finite", "von_mises+elastic", "mpm", False),
    (2, "small", "mohr_coulomb+elastic", "ugimp", False),
    (2, "finite", "von_mises+elastic", "cpgimp", True),
    (2, "small", "elastic+elastic", "cpgimp", True),
    (3, "finite", "von_mises+elastic", "mpm", False),
    (3, "small", "mohr_coulomb+elastic", "mpm", True)])
def test_runs_equal_the_numpy_path(dim, kinematics, name, method,
                                   antilocking, monkeypatch, caplog):
    """Whole runs (GIMP in 3D: 2 steps, the second switches the ghost
    penalty on), with and without mean dilatation, on ``kernels="auto"``:
    every operator and material served by the passes (no line that the
    numpy path serves), also soil and a stiffer inclusion (one material a
    body, ``BODIES``, :func:`inclusion`); the plastic ones yield."""
    material = list(BODIES[name]) if name in BODIES else RUN_MATERIALS[name]
    nsteps = 2 if dim == 3 and method != "mpm" else 3
    monkeypatch.setenv(kernels.AUTO_VARIABLE, "auto")   # the tests' numpy
    monkeypatch.setattr(kernels, "_LOGGED", set())
    with caplog.at_level(logging.INFO, logger="skfem_mpm.kernels"):
        runs = [column_run(dim, kinematics, material, k, method=method,
                           nsteps=nsteps, points=inclusion(dim)
                           if name in BODIES else None, options=Options(
                               stabilisation=Stabilisation(
                                   antilocking=antilocking)))
                for k in ("numpy", "auto")]
    assert not [r for r in caplog.records if r.name == "skfem_mpm.kernels"]
    check_runs_equal(runs)
    assert (runs[0].history[-1].n_yielded > 0) == (
        name not in ("elastic", "elastic+elastic"))


def check_runs_equal(runs):
    """The numpy path's run ``runs[0]`` and the compiled one: as many
    steps and Newton iterations, every step's grid displacement (and
    contact forces) and the points' positions, stresses and strains at the
    end equal to round-off.

    The grid displacements to ``GRID_TOL``, 1e-10 of the largest: that is
    a grid node GIMP's domains barely reach, free beside the column, 0.1
    to 0.17 where the points move 1e-3, its stiffness such that the
    tangents' condition numbers are 2.5e8-1.7e9 on 28 free DOFs.  The
    paths' tangents differ by 2e-16-6.5e-16 of their largest entry (the
    sums' order), which such a system may amplify up to 3.7e-7 (the
    bound); uGIMP with Drucker-Prager and cpGIMP elastic with mean
    dilatation (small strain) came out 1.4e-12 and 2.3e-12 apart there on
    an AVX-512 Xeon (SuperLU; 7e-15 and 4e-14 with ``spsolve``), their
    points' positions, stresses and strains 1e-14 apart: 1e-10 is 40
    times that."""
    assert [len(r.history) for r in runs[0:1]] == [len(runs[1].history)]
    for a, b in zip(runs[0].history, runs[1].history):
        assert len(a.newton_residuals or ()) == len(b.newton_residuals or ())
        assert relative(b.u, a.u) < GRID_TOL
        if a.contact_forces is not None and a.contact_forces.any():
            assert relative(b.contact_forces, a.contact_forces) < TOL
    for field in ("x", "stress", "strain"):
        assert relative(getattr(runs[1].points, field),
                        getattr(runs[0].points, field)) < TOL


def inclusion(dim):
    """:func:`column`'s points, those of the upper half of its outer
    quarter (x > 1.5, height > 2) body 1: a stiff inclusion bonded to the
    soil around it (one field), whose weight yields the soil below."""
    points = column(dim)[1]
    points.body = ((points.x[0] > 1.5) & (points.x[-1] > 2)).astype(
        np.int64)
    return points


@pytest.mark.parametrize("kinematics", ["small", "finite"])
def test_bodies_in_contact_equal_the_numpy_path(kinematics):
    """An elastic block ten times stiffer pressed onto Mohr-Coulomb soil
    (confined between walls, so that it yields), a frictionless
    ``Contact`` between them (a field each): the runs on both paths are
    equal, the contact forces of every step too.  (A block 3000 times
    stiffer, ``PILE``: its stresses, its modulus times strains that are
    differences of the soil's displacements, 1.5e-12 apart, though every
    step's displacement is within 1e-15.)"""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2.5, 11))
    parts = [seed_points(mesh, 2, region=lambda x, lo=lo, hi=hi: (
        x[1] > lo) & (x[1] < hi)) for lo, hi in ((0., 1.125), (1.125, 2.))]
    parts[1].body[:] = 1
    points = concatenate_points(parts)
    top = side_points(points, "top")
    soil = MohrCoulomb(1e4, .3, cohesion=1., friction_angle=10.,
                       dilation_angle=2.)

    def walls(b):
        return np.union1d(b.get_dofs(lambda x: x[1] == 0).nodal["u^2"],
                          b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 1))
                          .nodal["u^1"])
    block = LinearElastic(1e5, .2)
    runs = [simulate(mesh, ElementQuad1(), points, [soil, block], walls,
                     kinematics=kinematics, nsteps=2,
                     loads=[Traction(top, "top", [0., -10.])],
                     contacts=[Contact(0, 1)],
                     options=Options(NewtonOptions(tol=1e-10), kernels=k))
            for k in ("numpy", "compiled")]
    check_runs_equal(runs)
    assert runs[0].history[-1].contact_forces.any()
    assert runs[0].history[-1].n_yielded > 0


@pytest.mark.parametrize("kinematics, method", [("small", "mpm"),
                                               ("finite", "cpgimp")])
def test_a_cam_clay_run_equals_the_numpy_path(kinematics, method):
    """A Cam clay block confined on rollers (its reference pressure in
    equilibrium) under its weight, its lid pushed down past the
    preconsolidation pressure (``test_cam_clay.py``'s oedometer): both
    internal variables, the stresses and every step's grid displacement
    equal the numpy path's to round-off."""
    from test_cam_clay import oedometric_block
    material = MATERIALS["cam_clay"]
    mesh, points, supports, push = oedometric_block(.1)
    runs = [simulate(mesh, ElementQuad1(), points, material, supports,
                     loads=[Prescribed(push)], nsteps=4, kinematics=kinematics,
                     method=method, body_force=[0., -20.],
                     options=Options(kernels=k))
            for k in ("numpy", "compiled")]
    for a, b in zip(*(r.history for r in runs)):
        assert len(a.newton_residuals) == len(b.newton_residuals) > 2
        assert relative(b.u, a.u) < TOL
    assert runs[0].history[-1].n_yielded == runs[0].points.n
    for name in ("plastic_volumetric_strain", "equivalent_plastic_strain"):
        assert relative(runs[1].points.state[name],
                        runs[0].points.state[name]) < TOL, name
    assert relative(runs[1].points.stress, runs[0].points.stress) < TOL


@pytest.mark.parametrize("method", [
    "mpm", pytest.param("cpgimp", marks=pytest.mark.slow)])   # 2.1 s
def test_a_footing_with_mean_dilatation_equals_the_numpy_path(
        method, monkeypatch):
    """The methods study's footing (von Mises soil, small strain, mean
    dilatation, a smooth obstacle pushed into it in 20 steps; B / h = 4),
    as the footing examples run: the obstacle's force at every step and
    the stresses at the end equal the numpy path's to round-off."""
    from skfem_mpm.studies import methods
    results = []
    for k in ("numpy", "compiled"):
        monkeypatch.setattr(methods, "Options",
                            functools.partial(Options, kernels=k))
        results.append(methods.footing(.25, method))
    (numpy_run, q0, _), (compiled_run, q1, _) = results
    assert q0 > 4. and abs(q1 / q0 - 1.) < TOL
    for a, b in zip(numpy_run.history, compiled_run.history):
        assert relative(b.obstacle_forces, a.obstacle_forces) < TOL
    assert relative(compiled_run.points.stress,
                    numpy_run.points.stress) < TOL


@pytest.mark.parametrize("method, antilocking, bodies", [
    ("mpm", False, 1), ("mpm", True, 1), ("cpgimp", False, 1),
    ("cpgimp", True, 1), ("mpm", False, 2), ("cpgimp", True, 2),
    ("mpm", "fbar", 1), ("cpgimp", "fbar", 2), ("bspline", "fbar", 1)])
def test_a_resumed_compiled_run_is_bit_identical(method, antilocking,
                                                 bodies):
    """Resumed after step 2 of 4 from the state a callback saw, the
    compiled run ends where the whole compiled run does, bit for bit
    (cpGIMP: the domains stretched from the initial ones as well), with
    and without mean dilatation (additive, or F-bar on the increment,
    ``"fbar"``, which ``kernels="compiled"`` refused before), of one
    material or of von Mises soil and an elastic inclusion
    (:func:`inclusion`)."""
    saved = {}

    def keep(record, state):
        if record.step == 2:
            saved.update(record=record, state=state)
    material = MATERIALS["von_mises"] if bodies == 1 \
        else list(BODIES["von_mises+elastic"])
    stabilisation = Stabilisation(antilocking=antilocking)
    whole = column_run(2, "finite", material, "compiled", nsteps=4,
                       method=method,
                       points=inclusion(2) if bodies == 2 else None,
                       options=Options(
                           callback=keep, stabilisation=stabilisation))
    rest = column_run(2, "finite", material, "compiled", nsteps=4,
                      method=method, points=saved["state"], options=Options(
                          stabilisation=stabilisation,
                          resume=Resume.after(saved["record"],
                                              domain0=column(2)[1].domain)))
    # (F-bar cut a step of the von Mises column back before the retry's
    # search on the energy's slope; docs/robustness.md)
    assert [r.step for r in rest.history] == [
        r.step for r in whole.history[2:]] == [3, 4]
    assert whole.history[-1].n_yielded > 0
    for name in ("x", "stress", "strain", "F", "volume", "domain"):
        assert np.array_equal(getattr(rest.points, name),
                              getattr(whole.points, name)), name


def confined_block(dim, lid):
    """:func:`test_cam_clay.oedometric_block` in ``dim`` dimensions, its
    grid the block (1 x 1, 2 x 2 cells, 2^dim points a cell: B-splines
    hold and push whole edges of the grid), on rollers at its sides and
    base, its lid nodes pushed down by ``lid`` over a run."""
    mesh = GRIDS[dim][0].init_tensor(*[np.linspace(0., 1., 3)] * dim)
    points = seed_points(mesh, 2)
    top = np.flatnonzero(np.isclose(mesh.p[-1], 1.))

    def supports(b):
        return np.concatenate([b.get_dofs(lambda x: x[-1] == 0).all(
            "u^{}".format(dim))] + [b.get_dofs(
                lambda x, a=a: np.isclose(x[a], 0.) | np.isclose(x[a], 1.)
            ).all("u^{}".format(a + 1)) for a in range(dim - 1)])

    def push(b, f_old, f_new):
        return b.nodal_dofs[dim - 1, top], np.full(top.size,
                                                   -lid * (f_new - f_old))
    return mesh, points, supports, push


#: the F-bar runs' materials: Drucker-Prager's cohesion 0.3 of the
#: responses' (with 1e3 the 2D column stays elastic)
FBAR_RUN_MATERIALS = {**MATERIALS, "drucker_prager": DruckerPrager(
    1e6, .3, cohesion=300., friction_angle=30., dilation_angle=10.,
    hardening=1e4)}


@pytest.mark.parametrize("method", ["mpm", "ugimp", "cpgimp", "bspline"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("name", sorted(MATERIALS))
def test_fbar_runs_equal_the_numpy_path(dim, name, method, monkeypatch,
                                        caplog):
    """Whole runs with F-bar on the increment on ``kernels="auto"``, every
    method, dimension and material of the passes: served by them (no
    line that the numpy path serves; before, ``IncrementFbar`` was
    logged as having no compiled pass), equal to the numpy path's (every
    step's Newton iterations and grid displacement, the points at the
    end).  The column of :func:`column_run` (3 steps; GIMP and B-splines
    in 3D, 2), the plastic ones yielding; Cam clay, too soft for the
    column's weight, a confined block (:func:`confined_block`) pushed
    past its preconsolidation pressure under its weight."""
    stabilisation = Stabilisation(antilocking="fbar")
    monkeypatch.setenv(kernels.AUTO_VARIABLE, "auto")   # the tests' numpy
    monkeypatch.setattr(kernels, "_LOGGED", set())
    material = FBAR_RUN_MATERIALS[name]
    with caplog.at_level(logging.INFO, logger="skfem_mpm.kernels"):
        if name == "cam_clay":
            mesh, points, supports, push = confined_block(dim, .1)
            runs = [simulate(mesh, GRIDS[dim][1](), points, material,
                             supports, loads=[Prescribed(push)], nsteps=3,
                             kinematics="finite", method=method,
                             body_force=np.r_[np.zeros(dim - 1), -20.],
                             options=Options(kernels=k,
                                             stabilisation=stabilisation))
                    for k in ("numpy", "auto")]
        else:
            nsteps = 2 if dim == 3 and method != "mpm" else 3
            runs = [column_run(dim, "finite", material, k, method=method,
                               nsteps=nsteps, options=Options(
                                   stabilisation=stabilisation))
                    for k in ("numpy", "auto")]
    assert not [r for r in caplog.records if r.name == "skfem_mpm.kernels"]
    check_runs_equal(runs)
    assert (runs[0].history[-1].n_yielded > 0) == (name != "elastic")


def test_an_inverted_fbar_increment_is_an_inversion_error():
    """An increment that turns points inside out under F-bar on the
    compiled path: the pass's status hands it to the numpy path, which
    raises :class:`~skfem_mpm.errors.InversionError` (as it does
    alone, ``test_fbar.py``), not NaN stresses."""
    mesh, points = block(2)
    op = operator("mpm", mesh, points, 2)
    kin = make_kinematics("finite", MATERIALS["elastic"], 2,
                          {"return_maps": 0}, kernels="compiled")
    u = np.zeros((mesh.p.shape[1], 2))
    for s in (-1., -1.5):                  # u_x = s x: det dF = 1 + s
        u[:, 0] = s * mesh.p[0]
        with pytest.raises(InversionError):
            kin.response(IncrementFbar(op, points.volume), u.ravel(),
                         points)
    u[:, 0] = -.5 * mesh.p[0]
    assert kin.response(IncrementFbar(op, points.volume), u.ravel(),
                        points).force is not None


def test_fbar_in_small_strain_is_refused_by_the_passes():
    """F-bar on the increment in small strain, past the run's check (a
    kinematics piece called directly): the compiled small-strain pass
    refuses it, naming finite deformation (before, the numpy path ran
    it: F-bar's ``dF_bar - I`` taken as a small strain)."""
    mesh, points = block(2)
    op = operator("mpm", mesh, points, 2)
    kin = make_kinematics("small", MATERIALS["elastic"], 2,
                          {"return_maps": 0}, kernels="compiled")
    with pytest.raises(InvalidInputError, match="finite deformation"):
        kin.response(IncrementFbar(op, points.volume), np.zeros(op.N),
                     points)


class UserElastic(LinearElastic):
    """A user's material (a subclass may change the law: not compiled)."""


def test_the_choice_is_checked(monkeypatch, caplog):
    with pytest.raises(InvalidInputError, match="kernels must be one of"):
        Options(kernels="fast")
    assert Options(kernels="numpy").kernels == "numpy"
    monkeypatch.setenv(kernels.AUTO_VARIABLE, "auto")   # the tests' numpy
    monkeypatch.setattr(kernels, "_LOGGED", set())
    for material, dim, scheme, why in (
            (UserElastic(1e6, .3), 2, False, "the material UserElastic"),
            (PointMaterials([LinearElastic(1e6, .3), UserElastic(1e6, .3)],
                            [0, 1, 1]), 2, False,
             "the material UserElastic of body 1"),
            (MohrCoulomb(1e6, .3, 1e3, 0.), 2, False,
             "the material MohrCoulomb without friction"),
            (LinearElastic(1e6, .3), 1, False, "1D grids"),
            (LinearElastic(1e6, .3), 2, True, "total Lagrangian")):
        with pytest.raises(InvalidInputError, match=why):
            make_kinematics("finite", material, dim, {}, scheme,
                            kernels="compiled")
        with caplog.at_level(logging.INFO, logger="skfem_mpm.kernels"):
            for _ in range(2):
                assert make_kinematics("finite", material, dim, {}, scheme
                                       ).compiled is None
        assert sum(why in r.getMessage() for r in caplog.records) == 1
    for kind in ("small", "finite"):
        assert make_kinematics(kind, LinearElastic(1e6, .3), 3, {},
                               kernels="compiled").compiled is not None


def test_a_run_the_passes_cannot_serve_is_refused_before_any_work():
    """A user's material with ``kernels="compiled"``: refused when the
    run is set up, no step taken; ``"auto"`` runs it on the numpy path."""
    steps = []
    material = UserElastic(1e6, .3)
    with pytest.raises(InvalidInputError, match="UserElastic"):
        column_run(2, "small", material, "compiled", nsteps=1,
                   method="cpgimp", options=Options(
                       stabilisation=Stabilisation(antilocking=True),
                       callback=lambda record, state: steps.append(record)))
    assert steps == []
    runs = [column_run(2, "small", material, k, nsteps=1,
                       method="cpgimp", options=Options(
                           stabilisation=Stabilisation(antilocking=True)))
            for k in ("auto", "numpy")]
    assert np.array_equal(runs[0].points.stress, runs[1].points.stress)


def test_an_operator_without_passes_runs_on_numpy_logged_once(
        monkeypatch, caplog):
    """scikit-fem's ``asm`` on a material-point basis (a user's operator)
    has no compiled pass: asked for explicitly, one warning, and the
    numpy path's answer."""
    monkeypatch.setattr(kernels, "_LOGGED", set())
    mesh, points = block(2)
    op = AsmOperator(MaterialPointBasis(mesh, ElementVector(ElementQuad1()),
                                        points))
    du = 1e-3 * np.random.default_rng(0).standard_normal(op.N)
    material = MATERIALS["von_mises"]
    points.state.update(initial_state(material, points.n))
    with caplog.at_level(logging.INFO, logger="skfem_mpm.kernels"):
        responses = [make_kinematics("finite", material, 2, {
            "return_maps": 0}, kernels=k).response(op, du, points)
            for k in ("compiled", "compiled", "numpy")]
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "AsmOperator" in warnings[0].getMessage()
    assert responses[0].force is None
    assert np.array_equal(responses[0].P, responses[2].P)


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
    monkeypatch.setenv(kernels.AUTO_VARIABLE, "auto")   # the tests' numpy
    monkeypatch.setattr(kernels, "_LOGGED", set())
    monkeypatch.setitem(sys.modules, "numba", None)
    # the grid's kernels another test imported, dropped too (this test
    # failed after one that had: their numba cache's loader imports numba)
    from skfem_mpm.quadrature import basis
    monkeypatch.setattr(basis, "_KERNELS", {})
    for name in ("skfem_mpm.kernels.passes",
                 "skfem_mpm.kernels.constitutive",
                 "skfem_mpm.kernels.basis", "skfem_mpm.kernels.locate",
                 "skfem_mpm.kernels.graph"):
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


def kernel_sources(root, name, seen=None):
    """The kernel files module ``name`` imports from, and theirs."""
    seen = set() if seen is None else seen
    text = (root / name).read_text()
    for line in text.splitlines():
        words = line.split()
        if len(words) > 1 and words[0] == "from" and words[1].startswith(
                ".") and not words[1].startswith(".."):
            dep = (words[1][1:] or "__init__") + ".py"
            if dep not in seen:
                seen.add(dep)
                kernel_sources(root, dep, seen)
    return seen


def test_the_passes_change_with_what_they_compile_in():
    """numba's cache keys each function on its own file: a kernel module
    that compiles in code or constants of others carries the hash of
    their files (``SOURCES``), so that a change there invalidates its
    cached code."""
    import hashlib
    import importlib
    from skfem_mpm.kernels import passes
    root = Path(passes.__file__).parent
    checked = []
    for path in sorted(root.glob("*.py")):
        deps = sorted(kernel_sources(root, path.name) - {path.name})
        if path.name == "__init__.py" or not deps:
            continue
        module = importlib.import_module("skfem_mpm.kernels." + path.stem)
        digest = hashlib.sha256(b"".join(
            (root / dep).read_bytes() for dep in deps)).hexdigest()[:16]
        assert module.SOURCES == digest, (
            "{} changed: set {}.SOURCES = {!r}".format(
                ", ".join(deps), path.stem, digest))
        checked.append(path.stem)
    assert "passes" in checked


@pytest.mark.parametrize("name", ["line", "quad", "hex", "quad-graded"])
def test_the_compiled_location_equals_the_numpy_path_to_the_bit(name):
    """``point_locator(kernels="compiled")`` on a tensor grid of uniformly
    spaced axes gives the numpy path's elements and local coordinates to
    the bit, signs of zeros included (a position on its element's origin:
    ``+0.``, numpy's reduction starting at its identity), at random
    points, on every node and within 1e-14 of one, and outside the grid
    (the raw finder: -1 and the first cell's element's coordinates); the
    same error for points outside and for non-finite positions; a graded
    axis keeps the numpy path (no compiled finder)."""
    from skfem import MeshLine
    rng = np.random.default_rng(3)
    axes = {"line": [np.linspace(-1., 2., 8)],
            "quad": [np.linspace(-1., 2., 7), np.linspace(0., 1.2, 9)],
            "hex": [np.linspace(-1., 2., 5), np.linspace(0., 1., 4),
                    np.linspace(-.5, .5, 6)],
            "quad-graded": [np.array([0., .1, .3, .7, 1.5]),
                            np.linspace(0., 1., 5)]}[name]
    dim = len(axes)
    mesh = MeshLine(axes[0]) if dim == 1 else GRIDS[dim][0].init_tensor(
        *axes)
    compiled = point_locator(mesh, kernels="compiled")
    numpy_path = point_locator(mesh, kernels="numpy")
    lo, hi = mesh.p.min(axis=1)[:, None], mesh.p.max(axis=1)[:, None]
    nodes = mesh.p
    x = np.hstack((lo + (hi - lo) * rng.random((dim, 5000)), nodes,
                   np.clip(nodes + 1e-14, lo, hi),
                   np.clip(nodes - 1e-14, lo, hi)))
    got, want = compiled(x), numpy_path(x)
    assert got[0].dtype == want[0].dtype
    assert np.array_equal(got[0], want[0])
    assert np.array_equal(got[1], want[1])
    assert np.array_equal(np.signbit(got[1]), np.signbit(want[1]))
    # the raw finders, points outside included
    from skfem_mpm.quadrature.locate import _tensor_finder, tensor_grid
    find = _tensor_finder(mesh, tensor_grid(mesh), 1e-12)
    if name == "quad-graded":
        assert not hasattr(find, "compiled")
        return
    far = lo + (hi - lo) * (3. * rng.random((dim, 500)) - 1.)
    tind, X, outside = find.compiled(far, "compiled")
    expected = find(far)
    assert outside == (expected[0] < 0).sum() > 0
    assert np.array_equal(tind, expected[0])
    assert np.array_equal(X, expected[1])
    assert find.compiled(far, "numpy") is None
    messages = []
    for locate in (compiled, numpy_path):
        with pytest.raises(PointsOutsideGridError) as err:
            locate(far)
        messages.append(str(err.value))
        bad = x.copy()
        bad[0, 7] = np.nan
        with pytest.raises(InvalidInputError) as err:
            locate(bad)
        messages.append(str(err.value))
    assert messages[:2] == messages[2:]
