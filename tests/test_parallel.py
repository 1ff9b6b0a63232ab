"""The plain compiled passes on the machine's cores
(:mod:`skfem_mpm.kernels.parallel`): an operator's groups cut into chunks
of which no two that run side by side share a grid node
(:func:`~skfem_mpm.methods.assembly.phased_chunks`); a run in chunks
equals the serial passes' and the numpy path's to round-off, is the same
to the bit on one thread and on two, and resumes bit-identically; the
commit and a step's ``b_n - I`` in chunks of points are the serial
passes' to the bit."""
import numpy as np
import pytest
from skfem import Dofs, ElementHex1, ElementQuad1, MeshHex, MeshQuad

from skfem_mpm import (LinearElastic, MohrCoulomb, Options, Resume,
                       VonMises, seed_points, simulate)
from skfem_mpm.methods import assembly, operators
from skfem_mpm.methods.assembly import phased_chunks
from skfem_mpm.methods.gimp_linear import LinearGimp
from skfem_mpm.methods.operators import PointOperator
from skfem_mpm.quadrature.basis import MaterialPointBasis

GRIDS = {2: (MeshQuad, ElementQuad1), 3: (MeshHex, ElementHex1)}
#: round-off: the chunks sum a node's contributions in another order
TOL = 1e-12


def block(dim, cells, width=1.):
    """A block ``width`` wide (along x) and 2 tall of 2^dim points a cell
    of size ``1 / cells``, in a grid as wide and a cell taller."""
    h = 1. / cells
    axes = [np.linspace(0., width, int(round(width * cells)) + 1)] + [
        np.linspace(0., 1., cells + 1)] * (dim - 2) + [
        np.linspace(0., 2. + h, 2 * cells + 2)]
    mesh = GRIDS[dim][0].init_tensor(*axes)
    points = seed_points(mesh, 2, region=lambda x: x[-1] < 2.)
    return mesh, points


def operator(method, mesh, points):
    """Standard MPM's operator of ``points``, or GIMP's."""
    elem = GRIDS[mesh.dim()][1]()
    if method == "mpm":
        return PointOperator(MaterialPointBasis(mesh, elem, points))
    return LinearGimp(mesh, elem)(points.x, points.domain)


def chunk_spread(layout, bounds):
    """The most chunks a node of ``layout`` lies in, minus 1 (the chunks'
    distance): each node's groups through their chunk."""
    nodes, start, count = layout.groups[1:4]
    chunk = np.searchsorted(bounds, np.arange(len(count)), side="right") - 1
    spread = {}
    for r in range(len(count)):
        for node in nodes[start[r]:start[r] + count[r]]:
            low, high = spread.get(node, (chunk[r], chunk[r]))
            spread[node] = (min(low, chunk[r]), max(high, chunk[r]))
    return max(high - low for low, high in spread.values())


@pytest.mark.parametrize("dim, method", [(2, "mpm"), (2, "gimp"),
                                         (3, "mpm"), (3, "gimp")])
def test_chunks_keep_nodes_to_neighbouring_chunks(dim, method, monkeypatch):
    """On operators of standard MPM and GIMP: three chunks or more,
    each of groups in order, their points balanced to a group's
    points, every node in one chunk or two neighbouring ones (checked node
    by node here); the groups shuffled, fewer chunks or none; an operator
    below twice ``CHUNK_POINTS`` none."""
    mesh, points = block(dim, 8 if dim == 2 else 4)
    layout = operator(method, mesh, points).kernel_layout()
    assert layout.chunks is None            # 512 points: serial
    monkeypatch.setattr(assembly, "CHUNK_POINTS", 32)
    runs = layout.groups[4]
    bounds = phased_chunks(*layout.groups[1:5])
    expected = min(assembly.MOST_CHUNKS, runs[-1] // 32)
    # as many as the points allow, halved until nodes keep them apart
    # (the grid's columns of elements come one after another: chunks of
    # half a column would put a node in chunks 0 and 2)
    assert len(bounds) - 1 in (expected, expected // 2) and \
        bounds[0] == 0 and bounds[-1] == len(runs) - 1 and \
        np.all(np.diff(bounds) > 0)
    share = np.diff(runs[bounds])
    assert share.max() - share.min() <= 2 * np.diff(runs).max()
    assert chunk_spread(layout, bounds) <= 1
    # the same groups in a random order: no chunks of this many keep
    # nodes apart
    order = np.random.default_rng(0).permutation(len(runs) - 1)
    nodes, start, count = layout.groups[1:4]
    shuffled = (np.concatenate([nodes[start[r]:start[r] + count[r]]
                                for r in order]),
                np.r_[0, np.cumsum(count[order])[:-1]], count[order],
                np.r_[0, np.cumsum(np.diff(runs)[order])])
    fewer = phased_chunks(*shuffled)
    assert fewer is None or len(fewer) - 1 < expected


def test_an_operator_s_layout_keeps_its_chunks(monkeypatch):
    """The layout of an operator of three times ``CHUNK_POINTS`` points
    or more carries its chunks, formed once; no points, no chunks."""
    monkeypatch.setattr(assembly, "CHUNK_POINTS", 64)
    calls = []

    def counted(*args):
        calls.append(True)
        return phased_chunks(*args)
    monkeypatch.setattr(operators, "phased_chunks", counted)
    mesh, points = block(2, 8)
    op = operator("mpm", mesh, points)
    assert op.kernel_layout() is op.kernel_layout() and len(calls) == 1
    assert len(op.kernel_layout().chunks) - 1 == 8
    empty = [np.zeros(0, dtype=np.int64)] * 2
    assert phased_chunks(*empty, np.zeros(4, dtype=np.int64),
                         np.arange(0, 40001, 10000)) is None


def run(dim, method, kinematics, material, path="compiled", nsteps=3,
        points=None, **options):
    """The block under its weight, confined (an oedometer), on the
    kernels ``path`` (from ``points`` where given); in 2D 3 wide (the
    groups of a sparse operator come in columns: chunks of a narrow block
    would be too narrow to keep a B-spline's supports apart)."""
    mesh, seeded = block(dim, 6, 3.) if dim == 2 else block(dim, 3)
    points = seeded if points is None else points
    ends = mesh.p.max(axis=1)

    def supports(b):            # base held, sides on rollers
        return np.concatenate([b.get_dofs(lambda x: x[-1] == 0).all()] + [
            b.get_dofs(lambda x, a=a: np.isclose(x[a], 0.)
                       | np.isclose(x[a], ends[a])).all(
                           "u^{}".format(a + 1))
            for a in range(dim - 1)])
    return simulate(mesh, GRIDS[dim][1](), points, material, supports,
                    body_force=np.r_[np.zeros(dim - 1), -1e4],
                    nsteps=nsteps, method=method, kinematics=kinematics,
                    options=Options(kernels=path, **options))


def numba_threads(count):
    """``numba.set_num_threads`` with ``count`` (at most the machine's)."""
    import numba
    numba.set_num_threads(min(count, numba.config.NUMBA_NUM_THREADS))


def relative(a, b):
    """``|a - b|`` over ``|b|``, the largest of each."""
    return np.abs(a - b).max() / np.abs(b).max()


CASES = [(2, "mpm", "finite", VonMises(1e6, .3, 3e3)),
         (2, "mpm", "small", MohrCoulomb(1e6, .1, cohesion=500.,
                                         friction_angle=30.)),
         (2, "cpgimp", "finite", LinearElastic(1e6, .3)),
         (2, "bspline", "small", VonMises(1e6, .3, 3e3)),
         (3, "mpm", "finite", LinearElastic(1e6, .3)),
         (3, "mpm", "small", VonMises(1e6, .3, 3e3))]


def chunked_runs(monkeypatch, *case, **options):
    """The run of ``case`` in chunks (``CHUNK_POINTS`` 96 in 3D, 192 in
    2D: 3 to 4 chunks, in 2D wide enough that a quadratic B-spline's
    supports keep chunks 0 and 2 apart; every operator runs in 3 or more,
    so that chunks run side by side), on one thread and on two:
    ``{threads: result}``."""
    monkeypatch.setattr(assembly, "CHUNK_POINTS", 192 if case[0] == 2
                        else 96)
    counts = []

    def counted(*args):
        chunks = phased_chunks(*args)
        counts.append(0 if chunks is None else len(chunks) - 1)
        return chunks
    monkeypatch.setattr(operators, "phased_chunks", counted)
    runs = {}
    try:
        for threads in (1, 2):
            numba_threads(threads)
            runs[threads] = run(*case, **options)
    finally:
        numba_threads(1 << 10)
    assert counts and min(counts) >= 3
    return runs


@pytest.mark.slow
@pytest.mark.parametrize("dim, method, kinematics, material", CASES)
def test_a_run_in_chunks_equals_the_serial_passes(dim, method, kinematics,
                                                  material, monkeypatch):
    """A run whose operators are cut into chunks and whose commits run in
    chunks of points: the serial compiled run's and the numpy path's
    positions, stresses, strains and grid displacements to round-off, as
    many Newton iterations; on one thread and on two the same to the bit
    (the chunks fix every sum's order); the plastic cases yield."""
    pytest.importorskip("numba")
    case = (dim, method, kinematics, material)
    serial, numpy_run = run(*case), run(*case, path="numpy")
    chunked = chunked_runs(monkeypatch, *case)
    for name in ("x", "stress", "strain", "F"):
        ours = getattr(chunked[1].points, name)
        for other in (serial, numpy_run):
            assert relative(ours, getattr(other.points, name)) < TOL, name
        assert np.array_equal(getattr(chunked[2].points, name), ours), name
    for a, b in zip(serial.history, chunked[1].history):
        assert a.newton_iterations == b.newton_iterations
        assert relative(b.u, a.u) < TOL
    assert (serial.history[-1].n_yielded > 0) == (
        type(material) is not LinearElastic)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["mpm", "cpgimp"])
def test_a_run_in_chunks_resumes_bit_identically(method, monkeypatch):
    """Resumed after step 2 of 4 from the state a callback saw, a run in
    chunks ends where the whole one does, bit for bit, on two threads."""
    pytest.importorskip("numba")
    saved = {}

    def keep(record, state):
        if record.step == 2:
            saved.update(record=record, state=state)
    case = (2, method, "finite", VonMises(1e6, .3, 3e3))
    whole = chunked_runs(monkeypatch, *case, nsteps=4, callback=keep)[2]
    domain0 = block(2, 6, 3.)[1].domain
    rest = chunked_runs(monkeypatch, *case, nsteps=4, points=saved["state"],
                        resume=Resume.after(saved["record"],
                                            domain0=domain0))[2]
    assert [r.step for r in rest.history] == [3, 4]
    for name in ("x", "stress", "strain", "F", "volume", "domain"):
        assert np.array_equal(getattr(rest.points, name),
                              getattr(whole.points, name)), name


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_point_passes_in_chunks_are_the_serial_ones(dim, monkeypatch):
    """A basis's fields and a vector's values at the points, in chunks of
    elements (or points) side by side (``split_count``: numba's threads
    from ``SPLIT`` points), are the serial passes' to the bit, on one
    thread and on two; below ``SPLIT`` they run serial."""
    pytest.importorskip("numba")
    from skfem_mpm.kernels import parallel
    mesh, points = block(dim, 8 if dim == 2 else 4)
    u = np.random.default_rng(dim).standard_normal(mesh.nvertices * dim)
    calls = []
    for name in ("values_in_chunks", "fields_in_chunks"):
        chunked = getattr(parallel, name)
        monkeypatch.setattr(parallel, name, lambda *a, f=chunked, n=name: (
            calls.append(n), f(*a))[1])

    def pieces():
        elem = GRIDS[dim][1]()          # the grid's DOFs, as a step's
        op = PointOperator(MaterialPointBasis(
            mesh, elem, points, dofs=Dofs(mesh, elem), kernels="compiled"))
        return op.shape_values, op.shape_gradients, op.values(u)
    serial = pieces()
    assert not calls and points.n < parallel.SPLIT
    monkeypatch.setattr(parallel, "SPLIT", 16)
    try:
        for threads in (1, 2):
            numba_threads(threads)
            calls.clear()
            chunked = pieces()
            assert sorted(calls) == ["fields_in_chunks",
                                     "values_in_chunks"] or threads == 1
            assert all(np.array_equal(a, b) and a.dtype == b.dtype
                       for a, b in zip(chunked, serial))
    finally:
        numba_threads(1 << 10)


def forked_run(queue):
    """A child's run of the first case in chunks, its positions put on
    ``queue`` (:func:`test_a_forked_process_runs_in_chunks`)."""
    queue.put(run(*CASES[0]).points.x)


@pytest.mark.slow
def test_a_forked_process_runs_in_chunks(monkeypatch):
    """A process that ran the passes in chunks and then forks (a
    ``multiprocessing`` pool's default start on Linux) has children that
    run them too, to the parent's answer: the threading layer is numba's
    ``workqueue``, which survives a fork (GNU OpenMP's terminates the
    child: "fork() called from a process already using GNU OpenMP", and
    a pool waits for it for ever)."""
    pytest.importorskip("numba")
    import multiprocessing
    monkeypatch.setattr(assembly, "CHUNK_POINTS", 192)
    numba_threads(2)
    parent = run(*CASES[0]).points.x
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=forked_run, args=(queue,))
    child.start()
    try:
        x = queue.get(timeout=60)
    finally:
        child.join(timeout=30)
        if child.is_alive():
            child.kill()
    assert child.exitcode == 0 and np.array_equal(x, parent)
