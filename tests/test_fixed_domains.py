"""uGIMP's fixed domains in finite deformation
(skfem_mpm/solve/fixed_domains.py): the warning when the points' volumes
have left them, as the change grows, and none where the domains follow
the material (cpGIMP) or nothing compresses."""
import numpy as np
import pytest
from skfem import ElementQuad1, MeshQuad

from skfem_mpm import (LinearElastic, Traction, seed_points, side_points,
                       simulate)
from skfem_mpm.solve.fixed_domains import VOLUME_WARNING, volume_ratio

E, H = 1e6, 10.


def compressed_column(method, stretch, nsteps=20):
    """A user trial's column 1 x 10 (nu = 0) on a grid 2 x 12 cells of 1
    reaching 2 above it, rollers on its sides and base, compressed in
    finite deformation to ``stretch`` of its height by a top traction
    (the Hencky stress ``E ln(stretch) / stretch``, uniform): the run and
    the traction."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 12, 13))
    points = seed_points(mesh, 2, region=lambda x: x[1] < H)
    t = -E * np.log(stretch) / stretch
    top = side_points(points, "top")
    res = simulate(mesh, ElementQuad1(), points, LinearElastic(E, 0.),
                   lambda b: np.concatenate([
                       b.get_dofs(lambda x: x[1] == 0).all(),
                       b.get_dofs(lambda x: (x[0] == 0) | (x[0] == 1))
                       .all("u^1")]),
                   loads=[Traction(top, "top", [0., -t])], nsteps=nsteps,
                   method=method, kinematics="finite")
    return res, t


def test_the_volume_ratio_is_det_f():
    rng = np.random.default_rng(3)
    F = np.eye(3)[:, :, None] + .3 * rng.standard_normal((3, 3, 5))
    assert np.allclose(volume_ratio(F),
                       np.linalg.det(np.moveaxis(F, -1, 0)), rtol=1e-13)


def test_ugimp_compressed_is_warned_as_its_domains_overlap(caplog):
    """Compressed by 30% in 20 steps: uGIMP's stress scatters from 0.83 to
    1.60 of the traction (cpGIMP: uniform to 1e-9); warned where a point's
    volume first shrinks by more than 10%, then 20%, naming the point and
    cpGIMP; cpGIMP is not warned."""
    res, t = compressed_column("ugimp", .7)
    ratio = res.points.stress[1, 1] / -t
    assert ratio.max() - ratio.min() > .5
    said = [r.message for r in caplog.records if "'ugimp' keeps" in r.message]
    assert len(said) == 2, said
    changes = [float(m.split("shrunk by ")[1].split("%")[0]) for m in said]
    assert 100 * VOLUME_WARNING < changes[0] < 200 * VOLUME_WARNING \
        < changes[1] < 400 * VOLUME_WARNING
    assert all("'cpgimp' stretches the domains" in m for m in said)
    caplog.clear()
    res, t = compressed_column("cpgimp", .7)
    assert np.abs(res.points.stress[1, 1] / -t - 1).max() < 1e-9
    assert "keeps the points' domains" not in caplog.text


@pytest.mark.parametrize("method", ["ugimp", "cpgimp"])
def test_a_slight_compression_is_not_warned(method, caplog):
    """5%: the domains barely overlap; no warning."""
    compressed_column(method, .95, nsteps=4)
    assert "keeps the points' domains" not in caplog.text

