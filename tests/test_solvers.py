"""Linear solver back ends give the same answer."""
import numpy as np
import pytest
from skfem import ElementHex1, ElementQuad1, MeshHex, MeshQuad

from skfem_mpm import (InvalidInputError, LinearElastic, Options, seed_points,
                       solve_finite, solve_mpm)
from skfem_mpm.solve.backends import available_solvers, get_solver, solver_pyamg


def block(mesh, elem, solver):
    pts = seed_points(mesh, 2)
    res = solve_mpm(mesh, elem, pts, LinearElastic(1e4, .3),
                    lambda b: b.get_dofs(lambda x: x[-1] == 0),
                    body_force=np.r_[np.zeros(mesh.dim() - 1), -10.],
                    solver=solver, keep_snapshots=True)
    return res.history[0].u


@pytest.mark.parametrize("name", ["scipy", "pypardiso", "pyamg", "auto"])
def test_back_ends_agree(name):
    assert name in available_solvers() + ["auto"]     # the test extra
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 21), np.linspace(0, 1, 11))
    reference = block(mesh, ElementQuad1(), "scipy")
    u = block(mesh, ElementQuad1(), name)
    assert np.abs(u - reference).max() < 1e-8 * np.abs(reference).max()


def test_amg_uses_rigid_body_modes_in_3d():
    mesh = MeshHex.init_tensor(*[np.linspace(0, 1, 7)] * 3)
    reference = block(mesh, ElementHex1(), "scipy")
    amg = solver_pyamg()
    u = block(mesh, ElementHex1(), amg)
    assert np.abs(u - reference).max() < 1e-7 * np.abs(reference).max()
    with_modes = amg.iterations[-1]

    def without_modes(A, b, **kwargs):          # hide the modes
        return plain(A, b)
    plain = solver_pyamg()
    block(mesh, ElementHex1(), without_modes)
    assert with_modes < plain.iterations[-1]


def test_unknown_solver_name():
    with pytest.raises(InvalidInputError, match="linear solver must be one"):
        get_solver("cholmod")
    # Options check the name on creation, as they do their other fields
    # (a trial's "umfpack" was refused only when the run started)
    from skfem_mpm import Options
    with pytest.raises(InvalidInputError, match="got 'umfpack'"):
        Options(solver="umfpack")
    assert Options(solver="pyamg").solver == "pyamg"


def test_pardiso_reuses_its_analysis_over_newton_iterations():
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 2, 9))
    pts = seed_points(mesh, 2, region=lambda x: x[1] < 1.)
    run = dict(body_force=[0., -2e3], nsteps=2, keep_snapshots=False)
    args = (mesh, ElementQuad1(), pts, LinearElastic(1e4, .3),
            lambda b: b.get_dofs(lambda x: x[1] == 0))
    pardiso = get_solver("pypardiso")
    res = solve_finite(*args, solver=pardiso, **run)
    reference = solve_finite(*args, solver="scipy", **run)
    solves = res.counters["linear_solves"]
    assert solves >= 6                  # several Newton iterations a step
    assert pardiso.analyses == 1        # one pattern for the whole run
    assert np.abs(res.points.x - reference.points.x).max() < 1e-12


def test_pardiso_solves_indefinite_and_refuses_empty_rows():
    """A symmetric indefinite matrix (a plastic or compressed tangent) is
    factorised as a general one, not refused; an empty row is a
    SingularSystemError."""
    from scipy.sparse import csr_matrix
    from skfem_mpm import SingularSystemError
    indefinite = csr_matrix(np.array([[1., 2.], [2., 1.]]))
    x = get_solver("pypardiso")(indefinite, np.ones(2))
    assert np.allclose(x, [1 / 3, 1 / 3], rtol=1e-14)
    with pytest.raises(SingularSystemError, match="empty row"):
        get_solver("pypardiso")(csr_matrix(np.array([[1., 0.], [0., 0.]])),
                                np.ones(2))


def test_pardiso_memory_goes_with_the_solver():
    import gc
    from scipy.sparse import identity
    pardiso = get_solver("pypardiso")
    pardiso(identity(3, format="csr"), np.ones(3))
    release = pardiso.release
    assert release.alive
    del pardiso
    gc.collect()
    assert not release.alive


def test_pardiso_keeps_the_library_pypardiso_loaded(monkeypatch):
    """The MKL library pypardiso's import found is handed to every
    solver (``PYPARDISO_MKL_RT``: each creation searched the
    installation again, 0.42 s a process); a pypardiso that no longer
    names it there still gives working solvers, searching as before."""
    import os
    import pypardiso
    from scipy.sparse import identity
    from skfem_mpm.solve.backends import pardiso_solver
    monkeypatch.delenv("PYPARDISO_MKL_RT", raising=False)
    pardiso_solver(11)
    assert os.environ["PYPARDISO_MKL_RT"] == pypardiso.ps.libmkl._name
    monkeypatch.delenv("PYPARDISO_MKL_RT")
    monkeypatch.setattr(pypardiso, "ps", None)       # a later release
    x = get_solver("pypardiso")(identity(3, format="csr"), np.ones(3))
    assert np.array_equal(x, np.ones(3))
    assert "PYPARDISO_MKL_RT" not in os.environ


@pytest.mark.parametrize("name", ["pypardiso", "pyamg"])
def test_non_symmetric_tangents_are_solved_as_such(name):
    """A non-associated Drucker-Prager block (its tangent is not
    symmetric) gives the same answer with each back end as with SuperLU
    (Pardiso's positive definite mode would use the upper triangle only,
    conjugate gradients need symmetry: both switch by themselves)."""
    assert name in available_solvers()               # the test extra
    from skfem_mpm import DruckerPrager, simulate
    from skfem_mpm.solve.backends import is_symmetric
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 9), np.linspace(0, 1, 5))
    points = seed_points(mesh, 2)
    top = np.flatnonzero(np.isclose(mesh.p[1], 1.))

    def shear(b, f_old, f_new):
        return b.nodal_dofs[0, top], np.full(top.size, .01 * (f_new - f_old))
    material = DruckerPrager(1e4, .3, cohesion=10., friction_angle=30.,
                             dilation_angle=5.)
    runs = {solver: simulate(mesh, ElementQuad1(), points, material,
                             lambda b: b.get_dofs(lambda x: x[1] == 0),
                             body_force=[0., -20.], prescribed=shear,
                             nsteps=2, method="fem", solver=solver)
            for solver in ("scipy", name)}
    assert runs["scipy"].counters["return_maps"] > 0
    assert np.abs(runs[name].points.stress - runs["scipy"].points.stress
                  ).max() < 1e-6 * np.abs(runs["scipy"].points.stress).max()
    A = np.array([[2., 1.], [0., 3.]])
    from scipy.sparse import csr_matrix
    assert not is_symmetric(csr_matrix(A))
    assert is_symmetric(csr_matrix(A + A.T))


@pytest.mark.parametrize("method, kernels", [
    ("mpm", "auto"), ("mpm", "numpy"), ("cpgimp", "auto"),
    ("cpgimp", "numpy")])
def test_condensation_is_built_once_per_step_and_equals_condense(
        monkeypatch, method, kernels):
    """Newton's iterations of a load step gather the free-free block from
    one stored index map, built again only where the pattern or the free
    DOFs change from the step before: the maps built equal those changes
    (2 in 3 steps of 3-4 iterations with MPM, whose free DOFs change once;
    3 with cpGIMP's compiled stiffness on the pattern of the step's
    supports), every gathered block equals scikit-fem's ``condense``
    exactly (the compiled path's within the tangent's own data; a map kept
    past a change would not), the maps are of the run's kernel path
    (``kernels="numpy"``: the numpy path's), and the run's answer is
    bit-identical to the one condensed by scikit-fem every iteration."""
    from skfem import condense
    import skfem_mpm.solve.problem as problem
    from skfem_mpm.solve import linear
    from skfem_mpm.solve.linear import Condensation
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 9), np.linspace(0, 1.2, 11))
    builds, gathers, consumed, systems = [], [], [], []
    original_call = Condensation.__call__
    original_condensed = problem.StepProblem.condensed

    def condensed(self, K):             # the step's own free DOFs
        systems.append((K.indptr.tobytes(), K.indices.tobytes(),
                        self.free.tobytes()))
        expected = condense(K, I=self.free, expand=False)  # before: consumed
        A = original_condensed(self, K)
        gathers.append((A != expected).nnz)
        return A

    def gather(self, K, consume=False):
        owner = linear.whole_array(K.data)
        A = original_call(self, K, consume)
        consumed.append(consume and linear.whole_array(A.data) is owner)
        return A
    monkeypatch.setattr(Condensation, "__call__", gather)
    monkeypatch.setattr(problem.StepProblem, "condensed", condensed)
    # gathered within the tangent's data from 7 entries, 7 at a time
    monkeypatch.setattr(linear, "GATHER_BLOCK", 7)
    made = []

    def build(K, free, kernels):
        made.append(Condensation(K, free, kernels))
        builds.append(free.size)
        return made[-1]
    monkeypatch.setattr(problem, "Condensation", build)

    def run():
        pts = seed_points(mesh, 2, region=lambda x: x[1] < 1.)
        return solve_finite(mesh, ElementQuad1(), pts, LinearElastic(1e5, .3),
                            lambda b: b.get_dofs(lambda x: x[1] == 0),
                            body_force=[0., -2e4], nsteps=3, method=method,
                            options=Options(kernels=kernels))
    stored = run()
    iterations = stored.counters["newton_iterations"]
    assert iterations >= 9
    # the numpy path's GIMP stiffness, sparse products, is not canonical
    # (and drops exact zeros, so its pattern may change between
    # iterations): condensed by scikit-fem's condense, no map built
    # ("auto" is the numpy path under SKFEM_MPM_KERNELS=numpy)
    from skfem_mpm.kernels import auto_kernels
    mapped = method == "mpm" or (kernels == "auto"
                                 and auto_kernels() == "auto")
    changes = sum(a != b for a, b in zip([None] + systems, systems))
    assert len(builds) == (changes if mapped else 0)
    assert not mapped or changes == (2 if method == "mpm" else 3)
    assert len(consumed) == (iterations if mapped else 0)
    assert len(gathers) == iterations
    assert all(mismatch == 0 for mismatch in gathers)
    # the maps of the run's kernel path (compiled where numba imports)
    compiled = kernels == "auto" and auto_kernels() == "auto"
    assert all((c.graph is not None) == compiled for c in made)
    # the compiled pass's tangents, which nothing reads after, are
    # gathered within their own data
    assert all(consumed) if mapped and compiled else not any(consumed)
    monkeypatch.setattr(Condensation, "fits", lambda self, K, free: False)
    again = run()
    assert np.array_equal(again.points.x, stored.points.x)
    assert np.array_equal(again.points.stress, stored.points.stress)
    # a matrix sharing the index array but not the row pointers is not it
    from scipy.sparse import csr_matrix
    indices = np.array([0, 1, 1, 2], np.int32)
    K1 = csr_matrix((np.ones(4), indices, np.array([0, 2, 4, 4], np.int32)),
                    shape=(3, 3))
    K2 = csr_matrix((np.ones(4), indices, np.array([0, 1, 2, 4], np.int32)),
                    shape=(3, 3))
    K2.indices = K1.indices
    free = np.arange(3)
    assert not Condensation(K1, free).fits(K2, free)


def test_rigid_body_check_runs_when_cells_or_supports_change(monkeypatch):
    """The rigid-body check of the active grid runs at the first step and
    again only when the active cells or the held DOFs change: once in 4
    steps where MPM's points stay in their cells, every step for GIMP
    (whose connectivity follows the points' supports)."""
    import skfem_mpm.solve.motion as motion
    from skfem_mpm import simulate
    calls = []
    check = motion.check_rigid_body_modes
    monkeypatch.setattr(motion, "check_rigid_body_modes", lambda *args: (
        calls.append(args[-1]), check(*args)))
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 1.5, 7))
    for method, expected in (("mpm", [1]), ("cpgimp", [1, 2, 3, 4])):
        calls.clear()
        simulate(mesh, ElementQuad1(), seed_points(
            mesh, 2, region=lambda x: x[1] < 1.), LinearElastic(1e6, .3),
            lambda b: b.get_dofs(lambda x: x[1] == 0), body_force=[0., -1e3],
            nsteps=4, method=method, kinematics="finite")
        assert calls == expected, method


@pytest.mark.slow
def test_pypardiso_gives_identical_runs():
    """MKL's threads round differently from run to run unless asked for
    reproducible results: solver_pypardiso asks (MKL_CBWR=AUTO,STRICT),
    so two identical elasto-plastic cpGIMP runs in one fresh process agree
    bit for bit (without it they differed by 1e-16 here).  The process
    also tells MKL's threads to sleep as soon as a solve ends
    (KMP_BLOCKTIME=0: spinning, they slowed the point updates sharing
    the cores by 15%)."""
    import os
    import subprocess
    import sys
    script = """
import numpy as np
from skfem import ElementQuad1, MeshQuad
from skfem_mpm import VonMises, seed_points, simulate
mesh = MeshQuad.init_tensor(np.linspace(-.1, 1.1, 49), np.linspace(0, 1.2, 49))
runs = [simulate(mesh, ElementQuad1(), seed_points(
    mesh, 2, region=lambda x: (x[1] < 1.) & (x[0] > 0.) & (x[0] < 1.)),
    VonMises(1e6, .3, 8e3), lambda b: b.get_dofs(lambda x: x[1] == 0),
    body_force=[0., -1e4], nsteps=3, method="cpgimp", kinematics="finite",
    solver="pypardiso").points.x for _ in range(3)]
print(all(np.array_equal(runs[0], x) for x in runs[1:]))
import os
print(os.environ["MKL_CBWR"], os.environ["KMP_BLOCKTIME"])
"""
    env = {k: v for k, v in os.environ.items()
           if k not in ("MKL_CBWR", "KMP_BLOCKTIME")}
    out = subprocess.run([sys.executable, "-c", script], capture_output=True,
                         text=True, timeout=300, env=env)
    # and MKL's threads sleep between solves (KMP_BLOCKTIME=0)
    assert out.stdout.split() == ["True", "AUTO,STRICT", "0"], \
        out.stderr[-2000:]


def test_auto_logs_the_back_end_it_chooses(caplog):
    """``solver="auto"`` (the default) names the back end it picked for
    the run's systems, once per run: SuperLU for a small block, where it
    is the faster."""
    import logging
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 5), np.linspace(0, 1, 5))
    with caplog.at_level(logging.INFO, logger="skfem_mpm"):
        block(mesh, ElementQuad1(), "auto")
        block(mesh, ElementQuad1(), None)
    chosen = [r.getMessage() for r in caplog.records
              if r.getMessage().startswith("auto: ")]
    assert chosen == ["auto: scipy (SuperLU) for 40 free DOFs"] * 2


@pytest.mark.parametrize("dim", [2, 3])
def test_auto_takes_each_back_end_from_its_size(monkeypatch, dim):
    """With the test extra installed: SuperLU below AUTO_PARDISO_FROM free
    DOFs, Pardiso from there, AMG-CG from AUTO_AMG_FROM (sizes lowered
    here to the test's systems, and no system counted as banded); every
    answer equal to SuperLU's."""
    from scipy.sparse import diags
    from skfem_mpm.solve import backends
    monkeypatch.setitem(backends.AUTO_PARDISO_FROM, dim, 20)
    monkeypatch.setitem(backends.AUTO_SUPERLU_BANDED, dim, (0, 0))
    monkeypatch.setitem(backends.AUTO_AMG_FROM["pypardiso"], dim, 60)
    solver = backends.solver_auto(dim)
    for n in (10, 30, 80):
        A = diags([-1., 2.5, -1.], [-1, 0, 1], shape=(n, n)).tocsr()
        b = np.linspace(1., 2., n)
        reference = backends.solver_direct_checked()(A.tocsc(), b)
        assert np.abs(solver(A, b) - reference).max() < 1e-9
    assert solver.chosen == ["scipy (SuperLU)", "pypardiso", "pyamg"]
    with pytest.raises(InvalidInputError, match="dim must be 1, 2 or 3"):
        backends.solver_auto(4)


def test_auto_solves_directly_what_amg_does_not_converge_on(monkeypatch):
    """A tangent far from positive definite (CG diverges): the system goes
    to the direct back end, which solves it (``test_solver_choice.py``:
    its log line)."""
    from scipy.sparse import csr_matrix
    from skfem_mpm.solve import backends
    monkeypatch.setitem(backends.AUTO_AMG_FROM["pypardiso"], 2, 2)
    solver = backends.solver_auto(2)
    A = csr_matrix(np.array([[1., 3., 0.], [3., 1., 0.], [0., 0., -2.]]))
    x = solver(A, np.ones(3))
    assert np.allclose(A @ x, np.ones(3), rtol=1e-13, atol=0)
    assert solver.chosen == ["pyamg", "scipy (SuperLU)"]


def lone_point_run(solver, force):
    """A block on its held base and a lone point in the air above it, its
    nodes held by that point alone (a zero-energy mode along it), under
    the body force ``force``, solved with ``solver``."""
    from skfem_mpm import MaterialPoints
    from skfem_mpm.quadrature.points import concatenate_points
    mesh = MeshQuad.init_tensor(np.linspace(0, 2, 3), np.linspace(0, 2, 3))
    body = seed_points(mesh, 2, region=lambda x: x[1] < 1)
    lone = MaterialPoints(x=[[.3], [1.6]], volume=[.25], domain=[[.25],
                                                                 [.25]])
    return solve_mpm(mesh, ElementQuad1(), concatenate_points([body, lone]),
                     LinearElastic(1e3, .3),
                     lambda b: b.get_dofs(lambda x: x[1] == 0),
                     body_force=force, solver=solver)

def test_pardiso_hands_singular_systems_to_the_checked_superlu():
    """A lone point in a cell leaves a zero-energy mode.  Pardiso either
    perturbs the zero pivot or keeps one at round-off (which, depends on
    the last bits of the stiffness and MKL's build: the numpy path's
    stiffness on an AVX-512 Xeon keeps it, the compiled path's has it
    perturbed) and answers with garbage along the mode; the back end sees
    the perturbed pivot or the solution's growth and hands the system to
    SuperLU's pivot check: a load along the mode is refused.  Gravity
    (orthogonal to the mode) is solved: by SuperLU, its answer to the
    bit, where Pardiso perturbed the pivot; by Pardiso where it kept a
    pivot at round-off, its answer SuperLU's but along the mode, which
    only the lone point's displacement sees (1.7e-3 apart there, the
    body's points and every stress equal to round-off)."""
    from skfem_mpm import SingularSystemError
    run = lone_point_run
    pardiso = get_solver("pypardiso")
    with pytest.raises(SingularSystemError, match="zero-energy mode"):
        run(pardiso, [.5, -1.])
    assert pardiso.handed_over == 1
    got = run(pardiso, [0., -1.]).points
    reference = run("scipy", [0., -1.]).points
    if pardiso.handed_over == 2:
        assert np.array_equal(got.displacement, reference.displacement)
    assert pardiso.handed_over in (1, 2)
    body_part = slice(got.n - 1)                   # the lone point last
    assert np.abs(got.displacement[:, body_part] - reference.displacement[
        :, body_part]).max() <= 1e-12 * np.abs(reference.displacement).max()
    assert np.abs(got.stress - reference.stress).max() <= \
        1e-12 * np.abs(reference.stress).max()


@pytest.mark.parametrize("solver", ["pypardiso", "auto"])
def test_pardiso_refuses_a_zero_energy_mode_it_factorises_as_definite(
        solver):
    """The same lone point on a 32 x 36 grid (2116 free DOFs: "auto" takes
    Pardiso).  Factorised as positive definite, no pivot is perturbed (one
    is at round-off) and the solution grows to 1e13; the growth sends the
    system to SuperLU's pivot check, which refuses it, as "scipy" does."""
    from skfem_mpm import MaterialPoints, SingularSystemError
    from skfem_mpm.quadrature.points import concatenate_points
    n = 32
    mesh = MeshQuad.init_tensor(np.linspace(0, n, n + 1),
                                np.linspace(0, n + 4, n + 5))
    body = seed_points(mesh, 2, region=lambda x: x[1] < n)
    lone = MaterialPoints(x=[[n // 2 + .3], [n + .6]], volume=[.25],
                          domain=[[.25], [.25]])
    points = concatenate_points([body, lone])
    with pytest.raises(SingularSystemError, match="zero-energy mode"):
        solve_mpm(mesh, ElementQuad1(), points, LinearElastic(1e5, .3),
                  lambda b: b.get_dofs(lambda x: x[1] == 0),
                  body_force=[300., -100.], solver=solver)


def test_amg_keeps_its_hierarchy_while_the_pattern_lasts():
    """A 3D block under its weight in two finite-deformation steps: every
    Newton iteration's tangent has one pattern, so one hierarchy serves
    the solves of a step (measured: 13-14 CG iterations each, as with a
    fresh hierarchy; solve time 2.38 -> 1.45 s on a larger block), and the
    answer is SuperLU's.  A step starts with a new one (a resumed run
    computes the same), built from a fixed seed: two runs agree bit for
    bit, and numpy's global generator is left where it was."""
    mesh = MeshHex.init_tensor(*[np.linspace(0, 1, 6)] * 2,
                               np.linspace(0, 1.2, 7))
    points = seed_points(mesh, 2, region=lambda x: x[2] < 1.)
    args = (mesh, ElementHex1(), points, LinearElastic(1e6, .3),
            lambda b: b.get_dofs(lambda x: x[-1] == 0))
    run = dict(body_force=[0., 0., -1e4], nsteps=2, keep_snapshots=False)
    amg = solver_pyamg()
    result = solve_finite(*args, solver=amg, **run)
    reference = solve_finite(*args, solver="scipy", **run)
    assert len(amg.iterations) == result.counters["linear_solves"] >= 4
    assert amg.hierarchies == 2
    assert max(amg.iterations) <= 2 * amg.iterations[0]
    scale = np.abs(reference.points.displacement).max()
    assert np.abs(result.points.x - reference.points.x).max() < 1e-9 * scale
    state = np.random.get_state()[1].copy()
    again = solve_finite(*args, solver=solver_pyamg(), **run)
    assert np.array_equal(again.points.x, result.points.x)
    assert np.array_equal(np.random.get_state()[1], state)


@pytest.mark.slow
def test_amg_judges_its_solutions_by_their_true_residual():
    """A non-associated Mohr-Coulomb block crushed in 3D: at step 3, GMRES
    (left preconditioned) reports convergence where |b - A x| is still
    |b|.  The back end measures the true residual, iterates on, and says
    that pyamg did not converge (where the backward-error check had
    blamed missing supports).  (By default such a system is then solved
    directly: ``test_solver_choice.py``.)"""
    from skfem_mpm import MohrCoulomb, SingularSystemError, simulate
    mesh = MeshHex.init_tensor(np.linspace(-.25, 1.25, 9),
                               np.linspace(-.25, 1.25, 9),
                               np.linspace(0, 1.5, 9))
    points = seed_points(mesh, 2, region=lambda x: (x[2] < 1.) & np.all(
        (x[:2] > 0) & (x[:2] < 1), axis=0))

    def run(solver):
        return simulate(mesh, ElementHex1(), points, MohrCoulomb(
            1e6, .3, cohesion=2e4, friction_angle=30., dilation_angle=5.),
            lambda b: b.get_dofs(lambda x: x[-1] == 0),
            body_force=[3e4, 0., -6e4], kinematics="finite", nsteps=3,
            solver=solver, keep_snapshots=False)
    with pytest.raises(SingularSystemError, match="pyamg did not converge"):
        run(solver_pyamg(fallback=False))


def test_a_system_without_free_dofs_is_refused():
    from scipy.sparse import diags
    from skfem_mpm import SingularSystemError
    from skfem_mpm.solve.linear import factorise_active, solve_active
    K, none = diags([2.] * 4).tocsr(), np.array([], dtype=np.int64)
    with pytest.raises(SingularSystemError, match="no free degree"):
        solve_active(K, np.ones(4), none)
    with pytest.raises(SingularSystemError, match="no free degree"):
        factorise_active(K, none)


def test_mirrored_blocks_and_the_symmetry_check_without_kept_mirrors(
        monkeypatch):
    """The mirror positions found for rows of about 7 entries at a time:
    each entry's mirror from the dense matrix of entry numbers, every
    entry once; a None pair last for an asymmetric pattern whose rows and
    columns are as full (a cycle) and for one with an entry's mirror
    missing; the symmetry check of a pattern above ``MIRRORS_KEPT``
    entries against the dense transpose, nothing kept."""
    from scipy.sparse import csr_matrix
    import skfem_mpm.solve.backends as backends
    monkeypatch.setattr(backends, "MIRROR_BLOCK", 7)
    rng = np.random.default_rng(5)
    S = rng.random((30, 30)) * (rng.random((30, 30)) < .3)
    S = csr_matrix(S + S.T + np.eye(30))
    numbers = np.zeros(S.shape, dtype=np.int64)
    rows = np.repeat(np.arange(30), np.diff(S.indptr))
    numbers[rows, S.indices] = np.arange(S.nnz)
    pairs = list(backends.mirrored_blocks(S))
    assert len(pairs) > 1
    entries, mirrors = map(np.concatenate, zip(*pairs))
    np.testing.assert_array_equal(np.sort(entries), np.arange(S.nnz))
    np.testing.assert_array_equal(mirrors, numbers[S.indices, rows][entries])
    cycle = csr_matrix(np.roll(np.eye(30), 1, axis=1) + np.eye(30))
    lopsided = S.tolil()
    lopsided[2, 29], lopsided[29, 2] = 1., 0.
    lopsided = csr_matrix(lopsided)
    lopsided.eliminate_zeros()
    for A in (cycle, lopsided):
        assert list(backends.mirrored_blocks(A))[-1] is None
    monkeypatch.setattr(backends, "MIRRORS_KEPT", 7)
    backends.MIRRORS.clear()
    dense = S.toarray()
    for A in (S, csr_matrix(dense + 1e-9 * np.tril(dense)), lopsided,
              cycle):
        D = A.toarray()
        assert backends.is_symmetric(A) == bool(
            np.abs(D - D.T).max() <= 1e-12 * np.abs(D).max())
    assert not backends.MIRRORS


def test_is_symmetric_agrees_with_the_dense_transpose():
    """The in-place mirror comparison (kept per pattern) against the dense
    ``A == A.T`` to the tolerance: symmetric and asymmetric values on a
    symmetric pattern, an asymmetric pattern, a non-canonical matrix and a
    new pattern after a cached one."""
    from scipy.sparse import coo_matrix, csr_matrix
    from skfem_mpm.solve.backends import is_symmetric, mirror_positions
    rng = np.random.default_rng(3)

    def dense_verdict(A, rtol=1e-12):
        D = A.toarray()
        return np.abs(D - D.T).max() <= rtol * np.abs(D).max()
    S = rng.random((40, 40)) * (rng.random((40, 40)) < .2)
    S = csr_matrix(S + S.T)
    kept = mirror_positions(S)
    assert kept is not None
    # kept for matrices on the same index memory (scipy makes views of it)
    again = csr_matrix((2. * S.data, S.indices, S.indptr), shape=S.shape)
    assert again.indices is not S.indices and mirror_positions(again) is kept
    other = csr_matrix(S.toarray())
    assert mirror_positions(other) is not kept
    np.testing.assert_array_equal(mirror_positions(other), kept)
    for scale in (0., 1e-14, 1e-10, 1.):
        A = S.copy()
        A.indices, A.indptr = S.indices, S.indptr       # one kept pattern
        A.data = A.data + scale * rng.random(A.nnz)
        assert is_symmetric(A) == dense_verdict(A)
    assert not is_symmetric(S[:, :39].tocsr())          # not square
    U = csr_matrix(np.triu(S.toarray()) + np.eye(40))
    assert mirror_positions(U) is None
    assert not is_symmetric(U) and not dense_verdict(U)
    coo = coo_matrix(S)
    twice = csr_matrix((np.r_[coo.data, coo.data] / 2.,
                        (np.r_[coo.row, coo.row], np.r_[coo.col, coo.col])),
                       shape=S.shape)                   # duplicates
    assert is_symmetric(twice)
    # an entry left at round-off where its mirror was dropped (sums of
    # sparse products prune exact zeros): the pattern is not symmetric,
    # the matrix is to the tolerance
    lopsided = S.tolil()
    lopsided[3, 30], lopsided[30, 3] = 1e-20, 0.
    lopsided = csr_matrix(lopsided)
    lopsided.eliminate_zeros()
    assert mirror_positions(lopsided) is None
    assert is_symmetric(lopsided) and dense_verdict(lopsided)
    lopsided[3, 30] = 1.
    assert not is_symmetric(lopsided) and not dense_verdict(lopsided)
    # unsorted indices: compared in a sorted copy, the matrix (whose index
    # arrays another matrix may share) left as it is
    reversed_rows = csr_matrix((np.concatenate([
        S.data[a:b][::-1] for a, b in zip(S.indptr[:-1], S.indptr[1:])]),
        np.concatenate([S.indices[a:b][::-1] for a, b in zip(
            S.indptr[:-1], S.indptr[1:])]), S.indptr), shape=S.shape)
    assert not reversed_rows.has_sorted_indices
    indices = reversed_rows.indices.copy()
    assert is_symmetric(reversed_rows)
    np.testing.assert_array_equal(reversed_rows.indices, indices)


def test_upper_triangle_and_row_sums_match_scipy(monkeypatch):
    """The masked upper triangle equals scipy's ``triu`` (canonical CSR, a
    non-square one and COO input), its rows found a block of entries at a
    time (of one, seven and the default); the row sums by ``reduceat``
    equal the dense ones with empty rows first, inside and last."""
    from scipy.sparse import csr_matrix, triu
    from skfem_mpm.solve import backends
    from skfem_mpm.solve.backends import upper_triangle
    from skfem_mpm.solve.linear import row_sums
    rng = np.random.default_rng(5)
    D = rng.standard_normal((30, 30)) * (rng.random((30, 30)) < .3)
    D[[0, 11, 29]] = 0.
    for block in (1, 7, backends.TRIANGLE_BLOCK):
        monkeypatch.setattr(backends, "TRIANGLE_BLOCK", block)
        for A in (csr_matrix(D), csr_matrix(D[:, :20]),
                  csr_matrix(D).tocoo()):
            upper = upper_triangle(A)
            assert upper.format == "csr" and upper.has_sorted_indices
            assert np.array_equal(upper.toarray(), triu(A).toarray())
            assert upper.nnz == triu(A).nnz
    assert np.allclose(row_sums(csr_matrix(D)), np.abs(D).sum(axis=1),
                       rtol=1e-15, atol=0.)
    # in blocks of rows (of one and of seven entries): the same sums, to
    # the bit (each row reduced whole)
    for block in (1, 7):
        assert np.array_equal(row_sums(csr_matrix(D), block=block),
                              row_sums(csr_matrix(D)))


@pytest.mark.parametrize("block", [1, 5, 1 << 20])
def test_condensation_map_equals_scipy_indexing(block, monkeypatch):
    """The condensation's map, formed from masks a block of entries at a
    time, gathers what scipy's ``K[free][:, free]`` (sorted) holds, entry
    for entry and with its index arrays, for sorted and unsorted free
    DOFs, empty rows and no free DOF at all."""
    from scipy.sparse import csr_matrix
    from skfem_mpm.solve import linear
    monkeypatch.setattr(linear, "TAKE_BLOCK", block)
    rng = np.random.default_rng(3)
    D = rng.standard_normal((25, 25)) * (rng.random((25, 25)) < .3)
    D[[0, 12, 24]] = 0.
    K = csr_matrix(D)
    for free in (np.arange(0, 25, 2), rng.permutation(25)[:15],
                 np.array([], dtype=np.int64)):
        condensed = linear.Condensation(K, free)(K)
        expected = K[free][:, free]
        expected.sort_indices()
        assert condensed.has_canonical_format
        for name in ("data", "indices", "indptr"):
            assert np.array_equal(getattr(condensed, name),
                                  getattr(expected, name))


@pytest.mark.parametrize("name", ["scipy", "pypardiso", "pyamg"])
def test_condensation_with_unsorted_free_dofs_stays_exact(name):
    """Condensed matrices share their index arrays over a step's
    iterations: with free DOFs in any order they are canonical, so no back
    end's sorting can pair the kept gather map with moved indices (the
    second iteration's matrix was wrong by 1.2 before)."""
    assert name in available_solvers()
    from scipy.sparse import identity, random as sparse_random
    from skfem_mpm.solve.linear import Condensation, factorise_active
    K = sparse_random(30, 30, density=.3, format="csr", random_state=2)
    K = (K + K.T + 30. * identity(30)).tocsr()
    K.sort_indices()
    free = np.random.default_rng(0).permutation(30)[:20]
    condensation = Condensation(K, free)
    b = np.linspace(1., 2., 30)
    for _ in range(3):
        K.data *= 1.1                       # the next iteration's tangent
        A = condensation(K)
        assert A.has_canonical_format
        assert abs(A - K[free][:, free]).max() == 0.
        u = factorise_active(K, free, solver=name,
                             condensation=condensation)(b)
        assert np.abs(K[free][:, free] @ u[free] - b[free]).max() \
            < 1e-8 * np.abs(b).max()


def test_pattern_matrices_follow_their_index_arrays():
    """A matrix of the kept pattern's index arrays takes the first one's
    checked attributes with its own entries; other index arrays (a new
    step's pattern, equal in size), a new shape or another dtype of entries
    are built and checked anew: each equals scipy's constructor, entry for
    entry, and says whether it is canonical as scipy finds it (a stale
    pattern would give the first matrix's columns, or call an unsorted one
    canonical)."""
    from scipy.sparse import csc_matrix, csr_matrix
    from skfem_mpm.methods.assembly import PatternMatrices
    for cls in (csr_matrix, csc_matrix):
        make = PatternMatrices(cls)
        indptr = np.array([0, 2, 3, 4])
        other = (3, 4) if cls is csr_matrix else (4, 3)
        sorted_, unsorted = np.array([0, 2, 1, 2]), np.array([2, 0, 1, 2])
        cases = [(np.arange(1., 5.), sorted_, (3, 3)),
                 (np.arange(5., 9.), sorted_, (3, 3)),    # kept attributes
                 (np.arange(1., 5.), unsorted, (3, 3)),   # other indices
                 (np.arange(2., 6.), unsorted, (3, 3)),
                 (np.arange(2., 6.), unsorted, other),    # another shape
                 (np.arange(2, 6), unsorted, other)]      # integer entries
        for data, indices, shape in cases:
            M = make(data, indices, indptr, shape)
            expected = cls((data, indices, indptr), shape=shape)
            assert type(M) is cls and M.shape == shape
            assert np.array_equal(M.data, data)
            assert M.dtype == expected.dtype
            assert np.array_equal(M.indices, indices)
            assert M.has_canonical_format == (indices is sorted_)
            assert (M != expected).nnz == 0


def test_csc_copies_give_the_diagonal_of_their_own_pattern():
    """The diagonal of a CSC copy is read at places kept for its pattern
    where the whole diagonal is in it, scipy's otherwise: equal to
    scipy's for each matrix of two patterns in turn (a stale pattern's
    places would read the other's entries) and for one without a full
    diagonal; the row sums of a matrix without empty rows equal those
    formed row block by row block."""
    from scipy.sparse import csr_matrix
    from skfem_mpm.solve.backends import csc_converter
    from skfem_mpm.solve.linear import row_sums
    rng = np.random.default_rng(5)
    to_csc = csc_converter()
    dense = [rng.standard_normal((6, 6)) * (rng.random((6, 6)) < .5)
             + np.diag(np.arange(1., 7.)) * k for k in (1., 2., 0.)]
    dense[2][0, 0] = 0.                           # not all of it stored
    for D in dense + dense[::-1]:
        A = csr_matrix(D)
        for _ in range(2):
            A.data *= 1.5                         # the next iteration
            C = to_csc(A)
            assert np.array_equal(to_csc.diagonal(C), A.diagonal())
            assert (C != A.tocsc()).nnz == 0
            if np.diff(A.indptr).all():
                assert np.array_equal(row_sums(A), row_sums(A, block=1))
    first, second = (to_csc(csr_matrix(D)) for D in dense[:2])
    assert np.array_equal(to_csc.diagonal(first), first.diagonal())


@pytest.mark.slow
def test_compiled_component_labels_are_scipys(monkeypatch):
    """The compiled components of a node graph (``kernels="auto"``) are
    scipy's labels, numbering included, on random graphs with isolated
    nodes, explicit zeros (edges as scipy reads them), repeated and
    one-way edges; and the supports' check refuses the same free body."""
    pytest.importorskip("numba")
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components
    from skfem_mpm.errors import SingularSystemError
    from skfem_mpm.graph import edge_graph
    from skfem_mpm.solve.linear import check_rigid_body_modes, \
        component_labels
    monkeypatch.setenv("SKFEM_MPM_KERNELS", "auto")
    rng = np.random.default_rng(2)
    for n, edges in ((1, 0), (30, 10), (60, 45), (200, 150)):
        rows, cols = rng.integers(0, n, (2, edges))
        graphs = [edge_graph(rows, cols, n)]
        zeros = csr_matrix((np.zeros(edges), (rows, cols)), shape=(n, n))
        zeros.data[:] = 0.                   # kept as stored entries
        graphs.append(zeros)
        for graph in graphs:
            assert np.array_equal(
                component_labels(graph),
                connected_components(graph, directed=False)[1])
    # two bars of 3 nodes, the second unsupported: refused by either
    graph = edge_graph(np.array([0, 1, 3, 4]), np.array([1, 2, 4, 5]), 6)
    doflocs = np.array([[0., 1., 2., 0., 1., 2.], [0., 0., 0., 1., 1., 1.]])
    for kernels in ("auto", "numpy"):
        monkeypatch.setenv("SKFEM_MPM_KERNELS", kernels)
        with pytest.raises(SingularSystemError, match="on 3 grid nodes"):
            check_rigid_body_modes(graph, doflocs, np.arange(12),
                                   np.arange(6), 2)


def grid_tangent(m: int, box: int):
    """A 3D grid's tangent pattern (``m`` nodes a side, 27 neighbours of 3
    DOFs a node; random entries) and its free DOFs: the nodes of a box of
    ``box`` a side, the bottom ones held."""
    from scipy.sparse import diags, kron
    T = diags([1., 1., 1.], [-1, 0, 1], shape=(m, m))
    K = kron(kron(kron(T, T), T), np.ones((3, 3))).tocsr()
    K.sort_indices()
    K.data = np.random.default_rng(5).standard_normal(K.nnz)
    z, y, x = np.unravel_index(np.arange(m ** 3), (m, m, m))
    nodes = np.flatnonzero((z > 0) & (z < box) & (y < box) & (x < box))
    return K, (3 * nodes[:, None] + np.arange(3)).ravel()


@pytest.mark.parametrize("consume", [False, True])
def test_condensation_map_is_kept_as_runs(consume, monkeypatch):
    """The condensation's map of a 3D grid's pattern (27 neighbours of 3
    DOFs a node; the bottom nodes held, the nodes beyond a box inactive)
    is kept as runs of consecutive entries, not as a position an entry (4
    bytes a kept entry: 121 bytes a point at the peak of a 3D run's heap),
    and is built without a mask of all the pattern's entries (1 byte an
    entry, 59 bytes a point there): the map holds under half a byte a kept
    entry, the build's temporaries stay within its blocks' (under 48 bytes
    an entry of a block), and the block gathered is scipy's, entry for
    entry, copied or within the tangent's data."""
    import tracemalloc
    from skfem_mpm.solve import linear
    block = 1 << 12
    monkeypatch.setattr(linear, "TAKE_BLOCK", block)
    K, free = grid_tangent(12, 9)
    expected = K[free][:, free]
    expected.sort_indices()
    kept = expected.nnz
    assert kept > linear.GATHER_BLOCK        # the map kept as runs only
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    tracemalloc.reset_peak()
    condensation = linear.Condensation(K, free)
    held, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    columns, indptr = condensation.block
    kept_arrays = columns.nbytes + indptr.nbytes
    map_bytes = held - before - kept_arrays
    assert map_bytes <= kept / 2
    assert peak - held <= 48 * block
    assert condensation.take is None
    assert sum(a.nbytes for a in condensation.runs) <= kept / 2
    condensed = condensation(K.copy() if consume else K, consume)
    for name in ("data", "indices", "indptr"):
        assert np.array_equal(getattr(condensed, name),
                              getattr(expected, name))


def condensation_cases():
    """``(K, free)`` for :class:`Condensation`: a 3D grid's box (maps
    of many runs, ascending), its free DOFs shuffled, a short map (one
    node), no free DOF, every DOF free, and a random pattern."""
    from scipy.sparse import random
    K, free = grid_tangent(7, 5)
    shuffled = np.random.default_rng(3).permutation(free)
    R = random(40, 40, density=.3, format="csr", random_state=1)
    R.sort_indices()
    return [(K, free), (K, shuffled), (K, free[:3]),
            (K, np.zeros(0, dtype=free.dtype)), (K, np.arange(K.shape[0])),
            (R, np.array([0, 3, 4, 5, 9, 20, 21, 39]))]


@pytest.mark.parametrize("gather_block", [1, 1 << 14])
@pytest.mark.parametrize("case", range(6))
def test_compiled_condensation_is_the_numpy_paths(case, gather_block,
                                                  monkeypatch):
    """The compiled condensation (its map built in one pass over the rows,
    gathered a run at a time: :func:`~skfem_mpm.kernels.graph.
    condensation_runs`, :func:`~skfem_mpm.kernels.graph.gather_runs`)
    gives the numpy path's map and blocks, bit for bit, copied and
    within the tangent's data, and scipy's block: grids, shuffled free
    DOFs, short and empty maps (every map gathered by its runs where
    ``GATHER_BLOCK`` is 1)."""
    pytest.importorskip("numba")
    from skfem_mpm.solve import linear
    monkeypatch.setattr(linear, "GATHER_BLOCK", gather_block)
    K, free = condensation_cases()[case]
    expected = K[free][:, free]
    expected.sort_indices()
    made = [linear.Condensation(K, free, kernels)
            for kernels in ("numpy", "compiled")]
    assert made[0].graph is None and made[1].graph is not None
    for a, b in zip(*(c.runs + c.block for c in made)):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    assert (made[0].take is None) == (made[1].take is None) \
        == (expected.nnz >= gather_block)
    if expected.nnz == 0:                  # no runs: nothing gathered
        out = np.full(1, np.pi)
        made[1].graph.gather_runs(*made[1].runs, K.data, out)
        assert made[1].runs[1].size == 0 and out[0] == np.pi
    for consume in (False, True):
        for condensation in made:
            condensed = condensation(K.copy(), consume)
            for name in ("data", "indices", "indptr"):
                assert np.array_equal(getattr(condensed, name),
                                      getattr(expected, name))


@pytest.mark.parametrize("consume", [False, True])
def test_compiled_gather_forms_no_positions(consume):
    """The compiled gather copies a run at a time: beyond the block's
    entries it allocates under 4 kB (the numpy path's 2^14 positions
    expanded from the runs, 128 kB and their copies, were 4 ms a gather of
    5.3e5 kept entries against 1.6-2.1 for positions kept whole), copied
    or within the tangent's data (then its entries' new array where numpy
    shortens it), and the block is the numpy path's."""
    pytest.importorskip("numba")
    import tracemalloc
    from skfem_mpm.solve import linear
    K, free = grid_tangent(12, 6)  # 3e4 kept entries: 240 kB, as 2 blocks
    want = linear.Condensation(K, free, "numpy")(K)
    condensation = linear.Condensation(K, free, "compiled")
    condensation(K.copy(), consume)                 # compiled, warm
    tangent = K.copy()
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    tracemalloc.reset_peak()
    condensed = condensation(tangent if consume else K, consume)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert condensation.take is None and want.nnz > linear.GATHER_BLOCK
    # (shortened within the tangent's data, numpy's realloc is traced as
    # the entries' new array)
    assert peak - before - condensed.data.nbytes < 4096
    assert np.array_equal(condensed.data, want.data)


def test_pardiso_beyond_the_hand_over_fill_refines_and_says_so(caplog):
    """A perturbed factorisation whose factor is beyond ``handover_fill``
    nonzeros is not handed to SuperLU (whose pivoting took 56-79 s a
    factorisation on a 3D footing's collapsing tangent of 12152 DOFs, at
    DEBUG only): Pardiso solves it with iterative refinement and refuses a
    solution that grows; each kind of hand-over is said once at INFO."""
    import logging
    from skfem_mpm import SingularSystemError
    from skfem_mpm.solve.backends import solver_pypardiso
    run = lone_point_run
    refined = solver_pypardiso(handover_fill=0)
    with caplog.at_level(logging.INFO, logger="skfem_mpm.solve.backends"):
        for _ in range(2):
            with pytest.raises(SingularSystemError, match="zero-energy"):
                run(refined, [.5, -1.])
    # each a perturbed pivot's factorisation (the grown solution of one
    # that perturbed none is refused unhanded beyond the fill)
    assert refined.handed_over == refined.refined == 2
    said = [r for r in caplog.records if r.levelno == logging.INFO
            and "Pardiso" in r.getMessage()]
    assert len(said) == 1                   # once, then at DEBUG
    assert "iterative refinement" in said[0].getMessage()
    caplog.clear()
    superlu = get_solver("pypardiso")
    with caplog.at_level(logging.INFO, logger="skfem_mpm.solve.backends"):
        with pytest.raises(SingularSystemError, match="zero-energy"):
            run(superlu, [.5, -1.])
    assert superlu.refined == 0
    assert any("checked SuperLU" in r.getMessage() and r.levelno ==
               logging.INFO for r in caplog.records)


@pytest.mark.parametrize("name,meant", [("superlu", "scipy"),
                                        ("SuperLU", "scipy"),
                                        ("pardiso", "pypardiso"),
                                        ("Pardiso", "pypardiso"),
                                        ("amg", "pyamg")])
def test_a_back_ends_name_is_told_the_solver_name_it_means(
        name, meant, tmp_path):
    """Trial 111: "superlu", "SuperLU" and "pardiso", the names the logs
    and the README give the back ends, were refused with the solver
    names alone.  The message says which back end each name is and the
    name meant, in Python and in a scene file."""
    from skfem_mpm.scenes.scene_file import load_scene
    from skfem_mpm.solve.backends import SOLVER_WORDS
    with pytest.raises(InvalidInputError) as err:
        get_solver(name)
    text = str(err.value)
    for solver, words in SOLVER_WORDS.items():
        assert "{!r} ({})".format(solver, words) in text
    assert "SuperLU" in SOLVER_WORDS["scipy"]
    assert "Pardiso" in SOLVER_WORDS["pypardiso"]
    assert text.endswith("got {!r}; did you mean {!r}?".format(name, meant))
    scene = tmp_path / "s.toml"
    scene.write_text('[grid]\nx = [0.0, 1.0, 2]\ny = [0.0, 1.0, 2]\n\n'
                     '[[bodies]]\nregion = "all"\nmaterial = {{ E = 1e6, '
                     'nu = 0.3 }}\n\n[solver]\nlinear = "{}"\n'.format(name))
    with pytest.raises(InvalidInputError) as err:
        load_scene(scene)
    assert "solver.linear: must be one of 'scipy' ({})".format(
        SOLVER_WORDS["scipy"]) in str(err.value)
    assert "got {!r}; did you mean {!r}?".format(name, meant) in \
        str(err.value)
