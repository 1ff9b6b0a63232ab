"""What the Newton driver's strategy costs on nonlinear problems users run.

Each case runs with the defaults a user gets (``NewtonOptions()``), and
prints the wall time, the load steps taken (more than asked: cut-backs),
the Newton iterations of all attempts (``counters["newton_iterations"]``),
the line-search trials, the step from which later steps started with the
line search (``counters["line_search_from_step"]``, where it exists) and
the answer the case is about, so two source trees can be compared on the
same machine and hour (``PYTHONPATH=<tree> python
benchmarks/line_search_cost.py``):

- ``footing obstacle``: Prandtl's smooth strip footing as a box
  ``Obstacle`` (``examples/obstacles.py``' set-up: weightless von Mises
  soil, B/h = 8, 3 x 3 points per cell, mean dilatation, small strain,
  standard MPM) pushed 2 cells in 40 steps: the pressure at the end over
  ``c_u``;
- ``footing nodes``: the same soil with finite elements (3 x 3 points),
  the footing the grid nodes under it, pushed 2 cells in 40 steps;
- ``user footing``, ``user slope``: :mod:`skfem_mpm.studies.user_setups`
  (finite deformation, 10 steps, h = 1/8, cpGIMP);
- ``cantilever``: the user cantilever of the methods study (P L^2/EI = 3,
  20 steps, h = 0.5, standard MPM and cpGIMP): tip deflection over L;
- ``crushed column``: a column crushed to a tenth of its height by its
  weight (b = E, cpGIMP, 2 steps), whose full Newton steps fail.

    python benchmarks/line_search_cost.py [--cases footing_obstacle,...]
"""
import argparse
import platform
import time

import numpy as np
from skfem import ElementQuad1

from skfem_mpm import (LinearElastic, Obstacle, Options, Prescribed,
                       Stabilisation, VonMises, seed_points, simulate)
from skfem_mpm.studies import user_setups
from skfem_mpm.studies.column import column_grid, column_supports
from skfem_mpm.studies.user_setups import base_and_rollers, grid
from skfem_mpm.studies.methods import cantilever

SOIL = VonMises(E=1e5, nu=.3, yield_stress=100.)
CU = 100. / np.sqrt(3.)


def prandtl_ground(per_cell: int, B: float = 1., ratio: int = 8):
    """The footing's grid (half of it, the symmetry line at x = 0), soil
    points, supports, cell size and soil depth."""
    h, width, depth = B / ratio, 2.5 * B, 1.5 * B
    mesh = grid((0., width), (0., depth + 3 * h), h)
    points = seed_points(mesh, per_cell, region=lambda x: x[1] < depth)
    return mesh, points, base_and_rollers(width), h, depth


def footing_obstacle():
    mesh, points, supports, h, depth = prandtl_ground(3)
    res = simulate(mesh, ElementQuad1(), points, SOIL, supports, nsteps=40,
                   obstacles=[Obstacle(box=[[-1., .5], [depth, depth + 2 * h]],
                                       displacement=[0., -2 * h])],
                   options=Options(stabilisation=Stabilisation(
                       antilocking=True)))
    return res, res.history[-1].obstacle_forces[0, 1] / .5 / CU


def footing_nodes():
    mesh, points, supports, h, depth = prandtl_ground(3)
    under = np.flatnonzero(np.isclose(mesh.p[1], depth) & (mesh.p[0] <= .5))

    def pushed(b, f_old, f_new):
        return b.nodal_dofs[1, under], np.full(under.size,
                                               -2 * h * (f_new - f_old))
    res = simulate(mesh, ElementQuad1(), points, SOIL, supports, nsteps=40,
                   method="fem", loads=[Prescribed(pushed)],
                   options=Options(stabilisation=Stabilisation(
                       antilocking=True)))
    force = res.history[-1].reactions[2 * under + 1].sum()
    return res, abs(force) / .5 / CU


def crushed_column():
    mesh, elem = column_grid(4, dim=2)
    points = seed_points(mesh, 2)
    res = simulate(mesh, elem, points, LinearElastic(1e3, 0.),
                   column_supports(2), body_force=[0., -1e3], nsteps=2,
                   method="cpgimp", kinematics="finite")
    return res, float(res.points.x[1].max())


CASES = {
    "footing_obstacle": footing_obstacle,
    "footing_nodes": footing_nodes,
    "user_footing": lambda: user_setups.footing(1 / 8, 2, "cpgimp"),
    "user_slope": lambda: user_setups.slope(1 / 8, 2, "cpgimp"),
    "cantilever_mpm": lambda: cantilever(.5, "mpm"),
    "cantilever_cpgimp": lambda: cantilever(.5, "cpgimp"),
    "crushed_column": crushed_column,
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", default=",".join(CASES))
    args = parser.parse_args()
    print(platform.processor() or platform.machine(), platform.python_version())
    print("| case | s | steps | Newton iterations | line-search trials "
          "| line search from step | answer |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name in args.cases.split(","):
        tic = time.perf_counter()
        res, answer = CASES[name]()
        seconds = time.perf_counter() - tic
        answer = np.atleast_1d(answer)
        print("| {} | {:.1f} | {} | {} | {} | {} | {} |".format(
            name, seconds, len(res.history),
            res.counters["newton_iterations"],
            res.counters["line_search_trials"],
            res.counters.get("line_search_from_step", "-"),
            " ".join("{:.6g}".format(a) for a in answer)), flush=True)


if __name__ == "__main__":
    main()
