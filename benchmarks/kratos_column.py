"""The seed's column in skfem-mpm and in Kratos MPMApplication, side by
side: the answers (displacements and stresses of the points, digits of
agreement) and the time per point per Newton iteration, one thread each,
the two codes alternating in the same process hour (issue 32).

The column: 50 high, standard MPM on a Q1 (2D, one cell wide, plane
strain) or hexahedral (3D, ``n x n`` cells across) grid that the column
fills, 2 points per cell and direction at the centres of equal sub-cells,
the base held, rollers on the sides (the normal displacement held on
every side face), ``E = 1e6``, ``nu = 0.3``, its weight (800 per unit
volume) ramped in 20 load steps, finite deformation: Hencky elasticity
in the updated Lagrangian frame (skfem-mpm's ``LinearElastic`` with
``kinematics="finite"``; Kratos's ``HenckyMCPlastic`` law with a
cohesion that never yields).  Kratos's material points come from a body
mesh of the sub-cells, one point per element at its centre, so both codes
start from the same points with the same volumes.

skfem-mpm runs with the defaults of the README's install (``simulate``
with no options: ``kernels="auto"``, the compiled passes, the default
solver); Kratos with its static MPM solver, Newton-Raphson on the
residual (relative tolerance 1e-9, ours 1e-9 too) and a direct solver
(``--kratos-solver``: ``sparse_lu``, Eigen's, from
LinearSolversApplication; ``amgcl``: the MPM solver's default, CG
with AMG at 1e-7; both by default).  Time per Newton iteration: the
solution loop's wall time over the run's Newton iterations (Kratos: the
loop of its analysis stage, less the time this script's Python spends
setting the points' gravity each step, and without its set-up;
skfem-mpm: the whole call of ``simulate``, its set-up included, and the
sum of the phases in ``result.timings()``).

Kratos is not a dependency of this project: install it in a venv of its
own and name its interpreter, e.g.::

    python3 -m venv /tmp/kratos-venv
    /tmp/kratos-venv/bin/pip install KratosMultiphysics==10.4.4 \\
        KratosMPMApplication==10.4.4 KratosLinearSolversApplication==10.4.4
    OMP_NUM_THREADS=1 python benchmarks/kratos_column.py \\
        --kratos-python /tmp/kratos-venv/bin/python [--reps 3]
        [--cases 2:1:256 2:1:1024 3:2:125 3:8:64]

A case ``dim:across:tall`` is the column of ``across`` cells across
(2D: 1) and ``tall`` cells high: by default 1e3 and 4e3 points in 2D,
4e3 and 3.3e4 in 3D (``3:8:64``, a column 8 cells across: Kratos
10.4.4's generation of material points ends in a segmentation fault on
3D columns 4 cells across from about 240 cells high, 3e4 points, and
not on wider ones).  Without an interpreter that imports Kratos the
script says so and stops (exit status 0).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
             "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

HEIGHT, LOAD, E, NU, NSTEPS = 50., 800., 1e6, .3, 20
#: Kratos's residual over its first residual of the step (3D stalls
#: between 1e-8 and 1e-9); ours is 1e-9 of the external force
KRATOS_TOL = 1e-7
CASES = ("2:1:256", "2:1:1024", "3:2:125", "3:8:64")


def axes(dim: int, across: int, tall: int):
    """The grid's lines per axis: ``across`` cells of the vertical cell
    size across, ``tall`` cells over the height."""
    h = HEIGHT / tall
    side = np.linspace(0., across * h, across + 1)
    return [side] * (dim - 1) + [np.linspace(0., HEIGHT, tall + 1)]


# ---------------------------------------------------------------- ours
def ours(dim: int, across: int, tall: int) -> dict:
    """The column in skfem-mpm with the defaults: answers and times."""
    from skfem import ElementHex1, ElementQuad1, MeshHex, MeshQuad
    from skfem_mpm import LinearElastic, seed_points, simulate
    mesh = (MeshQuad if dim == 2 else MeshHex).init_tensor(
        *axes(dim, across, tall))
    elem = ElementQuad1() if dim == 2 else ElementHex1()
    points = seed_points(mesh, 2)
    top = mesh.p.max(axis=1)

    def supports(basis):
        held = [basis.get_dofs(lambda x: np.isclose(x[-1], 0.)).all()]
        for axis in range(dim - 1):
            held.append(basis.get_dofs(lambda x, a=axis: np.isclose(
                x[a], 0.) | np.isclose(x[a], top[a])).all()[axis::dim])
        return np.unique(np.concatenate(held))

    body_force = np.zeros(dim)
    body_force[-1] = -LOAD
    x0 = points.x.copy()
    tic = time.perf_counter()
    result = simulate(mesh, elem, points, LinearElastic(E, NU), supports,
                      body_force=body_force, nsteps=NSTEPS, method="mpm",
                      kinematics="finite")
    wall = time.perf_counter() - tic
    its = result.counters["newton_iterations"]
    timings = result.timings()
    pts = result.points
    d = dim - 1
    return {"x0": x0.tolist(), "u": (pts.x - x0).tolist(),
            "syy": pts.stress[d, d].tolist(), "its": int(its),
            "wall": wall, "phases": sum(timings.values()),
            "solve": timings["solve"], "n": int(points.n)}


# -------------------------------------------------------------- Kratos
def mdpa(path: str, nodes, elements, name: str, parts: dict,
         with_elements: bool = False):
    """Write a Kratos model part file: nodes (n, 3), elements (m, k)
    (0-based), sub-model parts ``{name: node indices}`` (0-based), each
    with every element where ``with_elements``."""
    with open(path, "w") as f:
        f.write("Begin Properties 0\nEnd Properties\n"
                "Begin Properties 1\nEnd Properties\nBegin Nodes\n")
        for i, x in enumerate(nodes, 1):
            f.write("{} {!r} {!r} {!r}\n".format(i, *map(float, x)))
        f.write("End Nodes\nBegin Elements {}\n".format(name))
        for i, conn in enumerate(elements, 1):
            f.write("{} 1 {}\n".format(i, " ".join(str(c + 1)
                                                    for c in conn)))
        f.write("End Elements\n")
        for part, ids in parts.items():
            f.write("Begin SubModelPart {}\n Begin SubModelPartNodes\n"
                    .format(part))
            f.write("".join("  {}\n".format(i + 1) for i in ids))
            f.write(" End SubModelPartNodes\n Begin SubModelPartElements\n")
            if with_elements:
                f.write("".join("  {}\n".format(i) for i in
                                range(1, len(elements) + 1)))
            f.write(" End SubModelPartElements\nEnd SubModelPart\n")


def tensor(lines):
    """Nodes and cells (Kratos's order: counterclockwise, the bottom face
    first in 3D) of a tensor-product grid with the given lines."""
    dim = len(lines)
    grids = np.meshgrid(*lines, indexing="ij")
    nodes = np.zeros((grids[0].size, 3))
    for a in range(dim):
        nodes[:, a] = grids[a].ravel()
    shape = [len(v) for v in lines]
    index = np.arange(nodes.shape[0]).reshape(shape)
    if dim == 2:
        corner = [index[:-1, :-1], index[1:, :-1], index[1:, 1:],
                  index[:-1, 1:]]
    else:
        corner = [index[:-1, :-1, :-1], index[1:, :-1, :-1],
                  index[1:, 1:, :-1], index[:-1, 1:, :-1],
                  index[:-1, :-1, 1:], index[1:, :-1, 1:],
                  index[1:, 1:, 1:], index[:-1, 1:, 1:]]
    return nodes, np.stack([c.ravel() for c in corner], 1)


def kratos_files(folder: str, dim: int, across: int, tall: int,
                 solver: str) -> str:
    """The grid, the body (one element per sub-cell), the material and
    the project parameters; returns the parameters' path."""
    lines = axes(dim, across, tall)
    nodes, cells = tensor(lines)
    top = nodes.max(axis=0)
    parts = {"Base": np.flatnonzero(np.isclose(nodes[:, dim - 1], 0.))}
    for axis in range(dim - 1):
        parts["Side{}".format(axis)] = np.flatnonzero(
            np.isclose(nodes[:, axis], 0.)
            | np.isclose(nodes[:, axis], top[axis]))
    mdpa(os.path.join(folder, "Grid.mdpa"), nodes, cells,
         "Element{}D{}N".format(dim, 2 ** dim), parts)
    fine = [np.linspace(v[0], v[-1], 2 * (len(v) - 1) + 1) for v in lines]
    nodes, cells = tensor(fine)
    mdpa(os.path.join(folder, "Body.mdpa"), nodes, cells,
         "MPMUpdatedLagrangian{}D{}N".format(dim, 2 ** dim),
         {"Body": np.arange(len(nodes))}, with_elements=True)
    law = ("HenckyMCPlasticPlaneStrain2DLaw" if dim == 2
           else "HenckyMCPlastic3DLaw")
    materials = {"properties": [{
        "model_part_name": "Initial_MPM_Material.Body", "properties_id": 1,
        "Material": {"constitutive_law": {"name": law}, "Variables": {
            "THICKNESS": 1.0, "MATERIAL_POINTS_PER_ELEMENT": 1,
            "DENSITY": 1.0, "YOUNG_MODULUS": E, "POISSON_RATIO": NU,
            "COHESION": 1e30, "INTERNAL_FRICTION_ANGLE": 0.0,
            "INTERNAL_DILATANCY_ANGLE": 0.0}, "Tables": {}}}]}
    with open(os.path.join(folder, "materials.json"), "w") as f:
        json.dump(materials, f)
    linear = {"sparse_lu": {"solver_type": "sparse_lu"},
              "amgcl": {"solver_type": "amgcl"}}[solver]
    constraints = [{
        "python_module": "assign_vector_variable_process",
        "kratos_module": "KratosMultiphysics",
        "Parameters": {"model_part_name": "Background_Grid.Base",
                       "variable_name": "DISPLACEMENT",
                       "constrained": [True, True, True],
                       "value": [0.0, 0.0, 0.0],
                       "interval": [0.0, "End"]}}]
    for axis in range(dim - 1):
        held = [False, False, False]
        held[axis] = True
        constraints.append({
            "python_module": "assign_vector_variable_process",
            "kratos_module": "KratosMultiphysics",
            "Parameters": {
                "model_part_name": "Background_Grid.Side{}".format(axis),
                "variable_name": "DISPLACEMENT", "constrained": held,
                "value": [0.0, 0.0, 0.0],
                "interval": [0.0, "End"]}})
    project = {
        "problem_data": {"problem_name": "column", "parallel_type": "OpenMP",
                         "start_time": 0.0, "end_time": 1.0,
                         "echo_level": 0},
        "solver_settings": {
            "solver_type": "Static", "model_part_name": "MPM_Material",
            "domain_size": dim, "echo_level": 0,
            "analysis_type": "non_linear",
            "time_stepping": {"time_step": 1.0 / NSTEPS},
            "model_import_settings": {
                "input_type": "mdpa",
                "input_filename": os.path.join(folder, "Body")},
            "grid_model_import_settings": {
                "input_type": "mdpa",
                "input_filename": os.path.join(folder, "Grid")},
            "material_import_settings": {"materials_filename": os.path.join(
                folder, "materials.json")},
            "convergence_criterion": "residual_criterion",
            "residual_relative_tolerance": KRATOS_TOL,
            "residual_absolute_tolerance": 1e-14,
            "max_iteration": 25,
            "problem_domain_sub_model_part_list": ["Body"],
            "processes_sub_model_part_list": list(parts),
            "linear_solver_settings": linear},
        "processes": {"constraints_process_list": constraints},
        "output_processes": {}}
    path = os.path.join(folder, "parameters.json")
    with open(path, "w") as f:
        json.dump(project, f)
    return path


def kratos(dim: int, across: int, tall: int, solver: str) -> dict:
    """The column in Kratos (run in Kratos's interpreter)."""
    import KratosMultiphysics as KM
    import KratosMultiphysics.MPMApplication as MPM
    from KratosMultiphysics.MPMApplication.mpm_analysis import MpmAnalysis
    KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)
    if solver == "sparse_lu":
        import KratosMultiphysics.LinearSolversApplication  # noqa: F401

    class Column(MpmAnalysis):
        """The static MPM analysis with the weight ramped over the steps
        and the Newton iterations counted."""
        iterations, gravity_time = 0, 0.

        def ApplyBoundaryConditions(self):
            super().ApplyBoundaryConditions()
            tic = time.perf_counter()
            mp = self._GetSolver().GetComputingModelPart()
            g = [0., 0., 0.]
            g[dim - 1] = -LOAD * mp.ProcessInfo[KM.STEP] / NSTEPS
            for element in mp.Elements:
                element.SetValuesOnIntegrationPoints(
                    MPM.MP_VOLUME_ACCELERATION, [g], mp.ProcessInfo)
            self.gravity_time += time.perf_counter() - tic

        def SolveSolutionStep(self):
            converged = super().SolveSolutionStep()
            if not converged:
                raise RuntimeError("Kratos: a step did not converge")
            self.iterations += self._GetSolver().GetComputingModelPart(
                ).ProcessInfo[KM.NL_ITERATION_NUMBER]
            return converged

    with tempfile.TemporaryDirectory() as folder:
        path = kratos_files(folder, dim, across, tall, solver)
        with open(path) as f:
            parameters = KM.Parameters(f.read())
        model = KM.Model()
        analysis = Column(model, parameters)
        tic = time.perf_counter()
        analysis.Initialize()
        setup = time.perf_counter() - tic
        mp = analysis._GetSolver().GetComputingModelPart()

        def values(variable):
            return np.array([e.CalculateOnIntegrationPoints(
                variable, mp.ProcessInfo)[0] for e in mp.Elements])
        x0 = values(MPM.MP_COORD)
        tic = time.perf_counter()
        analysis.RunSolutionLoop()
        wall = time.perf_counter() - tic
        u = values(MPM.MP_COORD) - x0
        stress = values(MPM.MP_CAUCHY_STRESS_VECTOR)
        analysis.Finalize()
    return {"x0": x0[:, :dim].T.tolist(), "u": u[:, :dim].T.tolist(),
            "syy": stress[:, dim - 1].tolist(), "its": analysis.iterations,
            "wall": wall - analysis.gravity_time, "setup": setup,
            "gravity": analysis.gravity_time, "n": len(x0)}


def run_kratos(python: str, case: str, solver: str) -> dict:
    """One Kratos run in its interpreter, one thread."""
    with tempfile.NamedTemporaryFile(suffix=".json") as out:
        env = dict(os.environ, OMP_NUM_THREADS="1")
        subprocess.run([python, os.path.abspath(__file__), "--side",
                        "kratos", "--cases", case, "--kratos-solver", solver,
                        "--out", out.name], env=env, check=True,
                       stdout=subprocess.DEVNULL)
        with open(out.name) as f:
            return json.load(f)


def digits(a: dict, b: dict) -> tuple:
    """The points matched by their initial position; the digits to which
    the vertical displacements and stresses agree (-log10 of the largest
    difference over the largest value)."""
    def order(r):
        x0 = np.round(np.array(r["x0"]), 9)
        return np.lexsort(x0[::-1])
    ia, ib = order(a), order(b)
    xa, xb = np.array(a["x0"])[:, ia], np.array(b["x0"])[:, ib]
    if xa.shape != xb.shape or not np.allclose(xa, xb, atol=1e-9):
        raise RuntimeError("the two codes' points differ")
    out = []
    for key, pick in (("u", lambda v: np.array(v)[-1]),
                      ("syy", np.array)):
        va, vb = pick(a[key])[ia], pick(b[key])[ib]
        err = np.abs(va - vb).max() / np.abs(va).max()
        out.append(-np.log10(max(err, 1e-16)))
    return tuple(out)


def importable(python: str) -> bool:
    code = "import KratosMultiphysics.MPMApplication"
    try:
        return subprocess.run([python, "-c", code], capture_output=True,
                              env=dict(os.environ, OMP_NUM_THREADS="1")
                              ).returncode == 0
    except OSError:
        return False


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kratos-python", default=sys.executable)
    parser.add_argument("--cases", nargs="+", default=list(CASES))
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--kratos-solver", nargs="+",
                        default=["sparse_lu", "amgcl"],
                        choices=("sparse_lu", "amgcl"))
    parser.add_argument("--side", choices=("both", "kratos"),
                        default="both")
    parser.add_argument("--out")
    args = parser.parse_args()
    if args.side == "kratos":
        dim, across, tall = map(int, args.cases[0].split(":"))
        with open(args.out, "w") as f:
            json.dump(kratos(dim, across, tall, args.kratos_solver[0]), f)
        return
    if not importable(args.kratos_python):
        print("Kratos MPMApplication is not importable by {}: skipped (give "
              "--kratos-python, the interpreter of a venv with "
              "KratosMultiphysics and KratosMPMApplication)".format(
                  args.kratos_python))
        return
    ours(2, 1, 4)   # untimed: numba's cached kernels load
    print("the seed's column, finite deformation, 20 steps, one thread; "
          "best of {}; ms per Newton iteration (us per point)".format(
              args.reps))
    print("{:>10} {:>6} | {:>17} {:>17} {:>4} | {:>10} {:>17} {:>4} | "
          "{:>6} {:>6} | {:>5} {:>5}".format(
              "case", "points", "ours: wall", "phases (solve)", "its",
              "Kratos", "wall", "its", "ratio", "phases", "u", "syy"))
    for case in args.cases:
        dim, across, tall = map(int, case.split(":"))
        best = {}
        for _ in range(args.reps):
            runs = {"ours": ours(dim, across, tall)}
            for solver in args.kratos_solver:
                runs[solver] = run_kratos(args.kratos_python, case, solver)
            for key, r in runs.items():
                if key not in best or r["wall"] < best[key]["wall"]:
                    best[key] = r
        a = best["ours"]
        n, its = a["n"], a["its"]
        t_ours, t_phases = a["wall"] / its, a["phases"] / its
        for solver in args.kratos_solver:
            k = best[solver]
            t_k = k["wall"] / k["its"]
            du, ds = digits(a, k)
            print("{:>10} {:>6} | {:>7.3f} ({:>6.3f}) {:>7.3f} ({:>6.3f}) "
                  "{:>4} | {:>10} {:>7.3f} ({:>6.3f}) {:>4} | {:>6.3f} "
                  "{:>6.3f} | {:>5.1f} {:>5.1f}".format(
                      case, n, t_ours * 1e3, t_ours * 1e6 / n,
                      t_phases * 1e3, a["solve"] / its * 1e3, its, solver,
                      t_k * 1e3, t_k * 1e6 / n, k["its"], t_ours / t_k,
                      t_phases / t_k, du, ds), flush=True)


if __name__ == "__main__":
    main()
