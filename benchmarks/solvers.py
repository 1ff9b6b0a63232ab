"""Linear solver back ends against the number of DOFs.

The condensed small-strain stiffness of a block of material points (2D
plane strain Q1 with 2x2 points per cell; 3D hexahedra with 2x2x2 points
per cell), solved by every installed back end of :mod:`skfem_mpm.solve.backends`:
seconds, AMG iterations, and the relative residual.

    python benchmarks/solvers.py [--max-dofs 5e5] [--3d-points 5e5]
"""
import argparse
import time

import numpy as np
from skfem import ElementHex1, ElementQuad1, ElementVector, MeshHex, MeshQuad

from skfem_mpm import LinearElastic, MaterialPointBasis, seed_points
from skfem_mpm.solve.linear import solve_active
from skfem_mpm.mechanics.materials import elastic_tensor
from skfem_mpm.methods.operators import AsmOperator
from skfem_mpm.solve.backends import available_solvers, solver_pyamg


def system(mesh, elem):
    points = seed_points(mesh, 2)
    basis = MaterialPointBasis(mesh, ElementVector(elem), points)
    op = AsmOperator(basis)
    K = op.stiffness(elastic_tensor(LinearElastic(1e6, .3), points.n,
                                    mesh.dim()), points.volume)
    body = np.zeros((mesh.dim(), points.n))
    body[-1] = -1e3 * points.volume
    f = op.point_force(body)
    fixed = basis.get_dofs(lambda x: x[-1] == 0).all()
    free = np.setdiff1d(basis.active_dofs, fixed)
    return points.n, K, f, free, basis.doflocs


def measure(name, K, f, free, doflocs):
    solver = solver_pyamg() if name == "pyamg" else name
    tic = time.perf_counter()
    try:
        u = solve_active(K, f, free, solver=solver, doflocs=doflocs)
    except MemoryError:
        return "out of memory", ""
    seconds = time.perf_counter() - tic
    r = np.linalg.norm((K @ u - f)[free]) / np.linalg.norm(f[free])
    extra = "{} it".format(solver.iterations[-1]) if name == "pyamg" else ""
    return "{:.2f} s".format(seconds), "{} res {:.0e}".format(extra, r)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-dofs", type=float, default=5e5)
    parser.add_argument("--3d-points", dest="points3d", type=float,
                        default=5e5)
    args = parser.parse_args()
    names = available_solvers()
    print("back ends installed: {}".format(", ".join(names)))
    print("{:>4} {:>8} {:>8} | {}".format("dim", "points", "dofs", " | ".join(
        "{:>24}".format(n) for n in names)))
    cases = [(2, n) for n in (50, 100, 200, 350, 500)] + \
        [(3, n) for n in (10, 20, 32, 39)]
    for dim, n in cases:
        if dim == 2:
            if 2 * (n + 1) ** 2 > args.max_dofs * 1.01:
                continue
            mesh = MeshQuad.init_tensor(*[np.linspace(0, 1, n + 1)] * 2)
            elem = ElementQuad1()
        else:
            if 8 * n ** 3 > args.points3d * 1.01:
                continue
            mesh = MeshHex.init_tensor(*[np.linspace(0, 1, n + 1)] * 3)
            elem = ElementHex1()
        npts, K, f, free, doflocs = system(mesh, elem)
        cells = []
        for name in names:
            if dim == 3 and name == "scipy" and free.size > 1.6e5:
                cells.append("{:>24}".format("skipped (fill-in)"))
                continue
            t, extra = measure(name, K, f, free, doflocs)
            cells.append("{:>24}".format(t + " " + extra))
        print("{:>4} {:>8} {:>8} | {}".format(dim, npts, free.size,
                                              " | ".join(cells)), flush=True)


if __name__ == "__main__":
    main()
