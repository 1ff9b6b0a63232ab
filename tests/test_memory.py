"""Memory stays flat over many load steps: no cache grows with the moving
points (scikit-fem's isoparametric Jacobian cache is keyed on the
quadrature, which changes every step)."""
import gc
import tracemalloc

import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import LinearElastic, seed_points, solve_finite, solve_mpm


def growth_per_step(run, first=20, last=None):
    """Traced memory growth per step between step ``first`` and the end,
    with the per-step record (kept in the history) subtracted."""
    marks = {}

    def callback(record, points):
        if record.step in (first, last):
            # retained memory only: a full collection empties the
            # interpreter's free lists, 0.1 to 0.4 MB here and a different
            # amount at each mark (finding no unreachable objects)
            gc.collect()
            marks[record.step] = tracemalloc.get_traced_memory()[0]

    tracemalloc.start()
    try:
        result = run(callback)
    finally:
        tracemalloc.stop()
    return (marks[last] - marks[first]) / (last - first), result


@pytest.mark.slow
def test_small_strain_memory_is_flat_over_1000_steps():
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 9), np.linspace(0, 2, 17))
    points = seed_points(mesh, 2, region=lambda x: x[1] < 1)     # 256 points

    def run(callback):
        return solve_mpm(mesh, ElementQuad1(), points, LinearElastic(1e6, .3),
                         lambda b: b.get_dofs(lambda x: x[1] == 0),
                         body_force=[0., -1e3], nsteps=1000,
                         keep_snapshots=False, callback=callback)

    per_step, result = growth_per_step(run, last=1000)
    # a Jacobian cache would add ~10 kB per step here; a history record
    # (a few scalars, the phase timings and the run's counters) is under 2 kB
    assert per_step < 2000
    # the mesh's own mapping holds only the grid basis' fixed Jacobians
    assert len(getattr(mesh._cached_mapping, "_cache", {})) <= 4
    assert np.isfinite(result.points.stress).all()


@pytest.mark.slow
def test_finite_deformation_memory_is_flat():
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 9), np.linspace(0, 2, 17))
    points = seed_points(mesh, 2, region=lambda x: x[1] < 1)

    def run(callback):
        return solve_finite(mesh, ElementQuad1(), points,
                            LinearElastic(1e6, .3),
                            lambda b: b.get_dofs(lambda x: x[1] == 0),
                            body_force=[0., -1e3], nsteps=200,
                            keep_snapshots=False, callback=callback)

    per_step, _ = growth_per_step(run, last=200)
    assert per_step < 2500      # record plus its Newton residual list
