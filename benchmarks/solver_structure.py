"""Linear solver back ends against the shape of the grid, not only its size.

Columns one or a few cells wide, squares and cubes of material points (Q1
cells with 2x2 points, hexahedra with 2x2x2; E = 1e6, nu = 0.3), the base
fixed and the sides on rollers as the seed's column.  Two tables:

- ``systems``: the condensed small-strain stiffness factorised and solved
  by SuperLU (the checked back end), Pardiso and AMG-CG (without its
  direct fallback): milliseconds of the first solve of a pattern
  (Pardiso's analysis, AMG's hierarchy included) and of a solve again on
  the same pattern (a later Newton iteration; SuperLU factorises in full
  each time), best of ``--repeat``; "step" is first + 2 again, SuperLU's
  over Pardiso's.  With them the structural measure ``"auto"`` chooses by
  and what it costs: the bandwidth after a reverse Cuthill-McKee ordering
  (``band``, DOFs; ``band ms`` computed anew, not from its cache).
- ``runs``: a finite-deformation run of 4 load steps under the body's
  weight (1% strain at the base; points cross cells, so each step has a
  new pattern): seconds of the whole run and of its solve phase
  (condensation, factorisation, substitution, checks) with SuperLU,
  Pardiso and ``"auto"``, best of ``--repeat``, and the back ends
  ``"auto"`` took.

    python benchmarks/solver_structure.py [--repeat 3] [--tables systems,runs]
        [--cases column,square,column3d,cube]
"""
import argparse
import re
import time

import numpy as np
from skfem import ElementHex1, ElementQuad1, ElementVector, MeshHex, MeshQuad

from skfem_mpm import (LinearElastic, MaterialPointBasis, Options,
                       SingularSystemError, seed_points, simulate)
from skfem_mpm.mechanics.materials import elastic_tensor
from skfem_mpm.methods.operators import AsmOperator
from skfem_mpm.solve import backends
from skfem_mpm.solve.backends import (available_solvers, get_solver,
                                      rcm_bandwidth, solver_direct_checked,
                                      solver_pyamg, solver_pypardiso)
from skfem_mpm.solve.linear import rigid_modes

#: cells per axis, the last axis the column's, per case
CASES = {
    "column": [(1, 512), (1, 1024), (1, 4096), (1, 16384), (1, 32768),
               (2, 512), (2, 1024), (2, 4096), (2, 8192), (2, 16384),
               (3, 1024), (3, 4096), (4, 1024), (4, 4096), (8, 1024),
               (16, 1024)],
    "square": [(32, 32), (45, 45), (64, 64), (128, 128), (256, 256)],
    "column3d": [(1, 1, 128), (1, 1, 256), (1, 1, 1024), (1, 1, 2048),
                 (1, 1, 4096), (1, 1, 8192), (1, 2, 1024), (2, 2, 256),
                 (2, 2, 1024), (4, 4, 256), (4, 4, 1024), (8, 8, 256)],
    "cube": [(6, 6, 6), (8, 8, 8), (10, 10, 10), (16, 16, 16),
             (24, 24, 24)],
}
#: the cases of the runs table (each run well under a minute)
RUNS = {
    "column": [(1, 1024), (1, 4096), (2, 1024), (2, 4096), (3, 2048),
               (4, 1024), (8, 1024)],
    "square": [(32, 32), (64, 64), (128, 128)],
    "column3d": [(1, 1, 256), (1, 1, 512), (1, 1, 1024), (1, 1, 4096),
                 (1, 2, 1024), (2, 2, 512), (4, 4, 256)],
    "cube": [(8, 8, 8), (12, 12, 12), (16, 16, 16)],
}
E = 1e6


def grid(cells):
    """The grid of ``cells`` (unit cells) and its element."""
    mesh_type, elem = (MeshQuad, ElementQuad1) if len(cells) == 2 else \
        (MeshHex, ElementHex1)
    return mesh_type.init_tensor(*[np.linspace(0, n, n + 1)
                                   for n in cells]), elem()


def supports(cells):
    """The base fixed, the sides on rollers (the seed's column; a 2D
    column one cell wide has only vertical DOFs free)."""
    def held(basis):
        dofs = [basis.get_dofs(lambda x: x[-1] == 0).all()]
        for axis, n in enumerate(cells[:-1]):
            dofs.append(basis.get_dofs(lambda x: np.isclose(
                x[axis], 0.) | np.isclose(x[axis], n)).nodal["u^{}".format(
                    axis + 1)])
        return np.unique(np.concatenate(dofs))
    return held


def system(cells):
    """The condensed stiffness of a grid of ``cells`` filled with points,
    held by :func:`supports`: ``(A, b, modes)``."""
    mesh, elem = grid(cells)
    points = seed_points(mesh, 2)
    basis = MaterialPointBasis(mesh, ElementVector(elem), points)
    op = AsmOperator(basis)
    dim = mesh.dim()
    K = op.stiffness(elastic_tensor(LinearElastic(E, .3), points.n, dim),
                     points.volume)
    body = np.zeros((dim, points.n))
    body[-1] = -1e3 * points.volume
    f = op.point_force(body)
    free = np.setdiff1d(basis.active_dofs, supports(cells)(basis))
    A = K.tocsr()[free][:, free].tocsr()
    A.sort_indices()
    modes = rigid_modes(basis.doflocs[:, free // dim * dim], dim)[
        np.arange(free.size), free % dim]
    return A, f[free], modes


def best(function, repeat):
    times = []
    for _ in range(repeat):
        tic = time.perf_counter()
        out = function()
        times.append(time.perf_counter() - tic)
    return min(times), out


def timings(name, A, b, modes, repeat):
    """``(first ms, again ms, remark)`` of back end ``name`` (the remark:
    AMG's iterations and relative residual); ``(None, None, remark)``
    where AMG (without its direct fallback) does not converge."""
    factories = {"scipy": solver_direct_checked,
                 "pypardiso": solver_pypardiso,
                 "pyamg": lambda: solver_pyamg(fallback=False)}
    kwargs = {"modes": modes} if name == "pyamg" else {}
    solvers = []

    def first():
        solvers.append(factories[name]())    # a new pattern each time
        return solvers[-1].factorise(A, **kwargs)(b)
    again = A.copy()
    again.data *= 1.01                # the next iteration: same pattern
    try:
        t_first, x = best(first, repeat)
        kept = solvers[-1]
        t_again, _ = best(lambda: kept.factorise(again, **kwargs)(b), repeat)
    except SingularSystemError as err:
        stalled = re.search(r"residual (\S+) after (\d+)", str(err))
        return None, None, "res {} after {} it{}".format(
            *stalled.groups(), "" if len(solvers) < repeat else
            " (again)") if stalled else "failed"
    residual = np.linalg.norm(b - A @ x) / np.linalg.norm(b)
    remark = "{} it, res {:.0e}".format(kept.iterations[0], residual) \
        if name == "pyamg" else ""
    return 1e3 * t_first, 1e3 * t_again, remark


def band_uncached(A):
    backends.BANDS.clear()
    return rcm_bandwidth(A)


def table_head(columns):
    print("| " + " | ".join(columns) + " |")
    print("|" + " --- |" * len(columns))


def systems_table(cases, names, repeat, max_dofs):
    print("\nsystems: ms, best of {}, first solve of a pattern / a solve "
          "again on it; step = (first + 2 again) of SuperLU over Pardiso's"
          .format(repeat))
    table_head(["cells", "DOFs", "band", "band ms"] + names +
               ["step LU / Pardiso"])
    for case in cases:
        for cells in CASES[case]:
            A, b, modes = system(cells)
            if A.shape[0] > max_dofs:
                continue
            t_band, band = best(lambda: band_uncached(A), repeat)
            out, step = [], {}
            for name in names:
                if name == "scipy" and len(cells) == 3 and A.shape[0] > 6e4 \
                        and min(cells) > 4:
                    out.append("skipped (fill-in)")
                    continue
                first, again, remark = timings(name, A, b, modes, repeat)
                if first is None:
                    out.append("fails: " + remark)
                    continue
                step[name] = first + 2 * again
                out.append("{:.1f} / {:.1f}{}".format(
                    first, again, " ({})".format(remark) if remark else ""))
            ratio = "{:.2f}".format(step["scipy"] / step["pypardiso"]) \
                if {"scipy", "pypardiso"} <= set(step) else ""
            print("| {} | {} | {} | {:.2f} | {} | {} |".format(
                "x".join(map(str, cells)), A.shape[0], band, 1e3 * t_band,
                " | ".join(out), ratio), flush=True)


def run(cells, solver):
    """A finite-deformation run of 4 load steps under the body's weight:
    ``(result, solver)``."""
    mesh, elem = grid(cells)
    dim = mesh.dim()
    used = get_solver(solver, dim)
    weight = np.zeros(dim)
    weight[-1] = -.01 * E / cells[-1]           # 1% strain at the base
    result = simulate(mesh, elem, seed_points(mesh, 2), LinearElastic(E, .3),
                      supports(cells), body_force=weight, nsteps=4,
                      kinematics="finite",
                      options=Options(solver=used, keep_snapshots=False))
    return result, used


def runs_table(cases, repeat):
    names = ["scipy", "pypardiso", "auto"]
    print("\nruns: seconds, best of {}, of the whole run / its solve phase"
          .format(repeat))
    table_head(["cells", "free DOFs", "solves"] + names +
               ["solve LU / Pardiso", "auto took"])
    for case in cases:
        for cells in RUNS.get(case, []):
            whole, solve = {}, {}
            for _ in range(repeat):          # interleaved: the same load
                for name in names:
                    tic = time.perf_counter()
                    result, used = run(cells, name)
                    seconds = time.perf_counter() - tic
                    whole[name] = min(whole.get(name, seconds), seconds)
                    solve[name] = min(solve.get(name, np.inf),
                                      result.timings()["solve"])
            print("| {} | {} | {} | {} | {:.2f} | {} |".format(
                "x".join(map(str, cells)), result.history[0].n_free_dofs,
                result.counters["linear_solves"], " | ".join(
                    "{:.2f} / {:.3f}".format(whole[n], solve[n])
                    for n in names), solve["scipy"] / solve["pypardiso"],
                ", ".join(used.chosen)), flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--tables", default="systems,runs")
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--max-dofs", type=float, default=1.5e5)
    args = parser.parse_args()
    names = available_solvers()
    # Pardiso's first creation in a process searches for MKL: not timed
    if "pypardiso" in names:
        from scipy.sparse import identity
        solver_pypardiso()(identity(3, format="csr"), np.ones(3))
    print("back ends: {}".format(", ".join(names)))
    cases = args.cases.split(",")
    if "systems" in args.tables:
        systems_table(cases, names, args.repeat, args.max_dofs)
    if "runs" in args.tables:
        runs_table(cases, args.repeat)


if __name__ == "__main__":
    main()
