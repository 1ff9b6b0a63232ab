"""The choice of ``solver="auto"`` by a system's structure, and the direct
solve that takes over from AMG where its iterations stall."""
import logging

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from skfem import (Basis, ElementHex1, ElementQuad1, ElementVector, MeshHex,
                   MeshQuad, asm)
from skfem.models.elasticity import lame_parameters, linear_elasticity

from skfem_mpm import SingularSystemError
from skfem_mpm.solve import backends
from skfem_mpm.solve.backends import (available_solvers, get_solver,
                                      rcm_bandwidth, solver_auto,
                                      solver_direct_auto,
                                      solver_direct_checked, solver_pyamg)


def element_pattern(basis):
    """The pattern of every pair of DOFs of an element's nodes on
    ``basis`` (ones), as the points' assembly scatters into
    (:class:`skfem_mpm.methods.assembly.ElementPattern`)."""
    dofs = basis.element_dofs
    n = dofs.shape[0]
    return csr_matrix((np.ones(n * dofs.size), (
        np.repeat(dofs, n, axis=0).ravel(), np.tile(dofs, (n, 1)).ravel())),
        shape=(basis.N, basis.N))


def stiffness(cells, rollers=False, pattern=False):
    """The elastic stiffness of a grid of unit cells, its base fixed (and
    its sides on ``rollers``), on the free DOFs: ``(A, b)``, ``b`` the
    weight; with ``pattern``, ``(A, b, P)``, ``P`` the grid's element
    pattern on the free DOFs.  ``A`` holds the element pattern, explicit
    zeros kept, as the points' assembly does: scikit-fem's ``asm`` drops
    the element entries that come out exactly zero, and which of those
    that vanish in exact arithmetic do so depends on the CPU's vector
    loops (a 7 x 7 x 7 cube's bandwidth was 461 with them dropped on one
    machine, 383 with them kept on another)."""
    mesh_type, elem = (MeshQuad, ElementQuad1) if len(cells) == 2 else \
        (MeshHex, ElementHex1)
    mesh = mesh_type.init_tensor(*[np.linspace(0., n, n + 1)
                                   for n in cells])
    basis = Basis(mesh, ElementVector(elem()))
    K = asm(linear_elasticity(*lame_parameters(1e6, .3)), basis)
    P = element_pattern(basis)
    A = P.copy()
    A.data = np.asarray(K[P.nonzero()]).ravel()
    held = [basis.get_dofs(lambda x: x[-1] == 0).all()]
    for axis, n in enumerate(cells[:-1] if rollers else []):
        held.append(basis.get_dofs(lambda x: (x[axis] == 0) | (
            x[axis] == n)).nodal["u^{}".format(axis + 1)])
    free = basis.complement_dofs(np.concatenate(held))
    A = csr_matrix(A[free][:, free])
    A.sort_indices()
    b = np.zeros(basis.N)
    b[basis.nodal_dofs[-1]] = -1.
    return (A, b[free], P[free][:, free]) if pattern else (A, b[free])


@pytest.mark.parametrize("cells, rollers, chosen", [
    ((1, 600), False, "scipy (SuperLU)"),     # thin 2D columns: banded
    ((2, 400), False, "scipy (SuperLU)"),
    ((4, 300), False, "pypardiso"),           # four cells wide: not
    ((40, 40), False, "pypardiso"),           # a square: as before
    ((1, 1, 300), True, "scipy (SuperLU)"),   # a 3D column on rollers
    ((1, 1, 100), False, "pypardiso"),        # free: as before
    ((7, 7, 7), False, "pypardiso")])         # a cube: as before
def test_auto_chooses_by_the_bandwidth_beyond_the_size(cells, rollers,
                                                       chosen):
    """Beyond the size from which Pardiso is the faster on squares and
    cubes (2000 free DOFs in 2D, 1000 in 3D), a system whose bandwidth
    after a reverse Cuthill-McKee ordering is narrow (a 2D column up to
    three cells wide, a 3D column one cell across on rollers) stays with
    SuperLU (0.63-0.99 of Pardiso's solve time there, measured in
    benchmarks/README.md); squares, cubes and wider columns take Pardiso
    as before.  The bandwidth is the grid's element pattern's, whatever
    the entries' values (those that round to zero on one CPU and not on
    another included).  The answer is SuperLU's (to 1e-8: the slender
    free 3D column's condition number parts the two direct solvers by
    1.7e-9)."""
    assert "pypardiso" in available_solvers()        # the test extra
    A, b, P = stiffness(cells, rollers, pattern=True)
    dim = len(cells)
    assert backends.AUTO_PARDISO_FROM[dim] <= A.shape[0] < \
        backends.AUTO_SUPERLU_BANDED[dim][1]
    band = rcm_bandwidth(P)
    assert rcm_bandwidth(A) == band
    assert (band <= backends.AUTO_SUPERLU_BANDED[dim][0]) == (
        chosen == "scipy (SuperLU)")
    solver = solver_auto(dim)
    x = solver(A, b)
    assert solver.chosen == [chosen]
    reference = solver_direct_checked()(A, b)
    assert np.abs(x - reference).max() <= 1e-8 * np.abs(reference).max()


def test_small_systems_and_the_bandwidth_cache(monkeypatch):
    """Below the size the bandwidth is not computed (SuperLU whatever the
    structure); beyond it once per pattern: the tangents of a load step's
    Newton iterations share their index arrays."""
    import scipy.sparse.csgraph as csgraph
    calls = []
    rcm = csgraph.reverse_cuthill_mckee
    monkeypatch.setattr(csgraph, "reverse_cuthill_mckee",
                        lambda *args, **kw: calls.append(1) or rcm(*args,
                                                                   **kw))
    small, _ = stiffness((30, 30))           # 1860 free DOFs
    assert solver_direct_auto(2).choose(small) == "scipy (SuperLU)"
    assert calls == []
    A, _ = stiffness((40, 40))
    direct = solver_direct_auto(2)
    for scale in (1., 2., 3.):          # one pattern, new values
        again = csr_matrix((scale * A.data, A.indices, A.indptr),
                           shape=A.shape)
        assert direct.choose(again) == "pypardiso"
    assert calls == [1]
    assert direct.choose(A.copy()) == "pypardiso" and calls == [1, 1]


def forced_to_stall(monkeypatch, iterations=1):
    """pyamg's iterations cut to ``iterations``: they end far above the
    tolerance."""
    iterate = backends.amg_iterate
    monkeypatch.setattr(backends, "amg_iterate", lambda *args: iterate(
        *args[:-1], iterations))


def test_pyamg_by_name_falls_back_to_a_direct_solve_with_a_warning(
        monkeypatch, caplog):
    """AMG asked for by name whose iterations stall above the tolerance:
    the system is solved directly (the answer SuperLU's to 1e-10), with
    one warning naming the residual reached; the further systems of the
    pattern go to the direct solver at once, until ``forget()`` (the load
    step's end)."""
    forced_to_stall(monkeypatch)
    A, b = stiffness((12, 12))
    reference = solver_direct_checked()(A, b)
    amg = get_solver("pyamg", 2)
    with caplog.at_level(logging.INFO, logger="skfem_mpm"):
        x = amg(A, b)
        assert np.abs(x - reference).max() <= \
            1e-10 * np.abs(reference).max()
        warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
        assert len(warnings) == 1 and amg.fallbacks == 1
        message = warnings[0].getMessage()
        assert message.startswith("pyamg (asked for by name) did not "
                                  "converge on 312 free DOFs (relative "
                                  "residual ")
        reached = float(message.split("relative residual ")[1].split()[0])
        assert 1e-10 < reached < 1.
        assert "solved by scipy (SuperLU) instead" in message
        # the next Newton iteration's tangent: no iterations, no warning
        iterations = list(amg.iterations)
        again = csr_matrix((2. * A.data, A.indices, A.indptr), shape=A.shape)
        assert np.abs(amg(again, b) - reference / 2.).max() <= \
            1e-10 * np.abs(reference).max()
        assert amg.iterations == iterations and amg.fallbacks == 1
        amg.forget()                     # the next load step: AMG again
        amg(A, b)
        assert len(amg.iterations) == len(iterations) + 1
        assert amg.fallbacks == 2
    # without the fallback: refused, as before
    with pytest.raises(SingularSystemError, match="pyamg did not converge"):
        solver_pyamg(fallback=False)(A, b)


def test_auto_logs_amg_falling_back_at_info(monkeypatch, caplog):
    """Under ``"auto"`` (which took AMG) the fallback is one INFO line
    naming the residual reached and the direct back end."""
    forced_to_stall(monkeypatch)
    monkeypatch.setitem(backends.AUTO_AMG_FROM["pypardiso"], 2, 2)
    A, b = stiffness((12, 12))
    solver = solver_auto(2)
    with caplog.at_level(logging.INFO, logger="skfem_mpm"):
        x = solver(A, b)
    reference = solver_direct_checked()(A, b)
    assert np.abs(x - reference).max() <= 1e-10 * np.abs(reference).max()
    assert solver.chosen == ["pyamg", "scipy (SuperLU)"]
    lines = [r for r in caplog.records if "did not converge" in
             r.getMessage()]
    assert len(lines) == 1 and lines[0].levelno == logging.INFO
    assert lines[0].getMessage().startswith("auto: pyamg did not converge")


def test_a_run_is_the_same_whichever_back_end_solves_it(monkeypatch):
    """The seed's column one cell wide (2048 free DOFs, bandwidth 3: "auto"
    takes SuperLU where the size alone took Pardiso), 3 steps in finite
    deformation: the points' positions and stresses with SuperLU,
    Pardiso, "auto" and AMG forced to stall (so solved directly) agree to
    1e-10 of the displacement and the stress."""
    from skfem_mpm import Options, seed_points, simulate
    from skfem_mpm.studies.column import (LOAD, MATERIAL, column_grid,
                                          column_supports)
    mesh, elem = column_grid(1024, 2)
    runs = {}
    for name in ("scipy", "pypardiso", "auto", "pyamg"):
        if name == "pyamg":
            forced_to_stall(monkeypatch)
        solver = get_solver(name, 2)
        runs[name] = simulate(mesh, elem, seed_points(mesh, 2), MATERIAL,
                              column_supports(2), body_force=[0., -LOAD],
                              nsteps=3, kinematics="finite",
                              options=Options(solver=solver,
                                              keep_snapshots=False))
        if name == "auto":
            assert solver.chosen == ["scipy (SuperLU)"]
        if name == "pyamg":
            assert solver.fallbacks == 3           # once a step
    reference = runs["scipy"].points
    assert runs["scipy"].history[0].n_free_dofs == 2048
    moved = np.abs(reference.displacement).max()
    stress = np.abs(reference.stress).max()
    for name, result in runs.items():
        assert np.abs(result.points.x - reference.x).max() <= 1e-10 * moved
        assert np.abs(result.points.stress - reference.stress).max() <= \
            1e-10 * stress
