"""The force curves of an obstacle moved away from the soil (a user
trial's active wall from a K0 start): one peak in summary.json and the
picture, drawn from the run's real start."""
from types import SimpleNamespace

import numpy as np

from skfem_mpm.cli import motion_curves, plot_contact_forces
from skfem_mpm.scenes import plot

#: the backfill's weight (kN/m^3), height (m) and friction angle (deg)
GAMMA, H, PHI = 18., 2.929, 30.


def active_wall():
    """An active wall's force per step, from the at-rest K0 = 0.5 thrust
    falling to Rankine's active one (a wall moving +x, away from the
    soil at its left, pushed +x by it)."""
    ka = np.tan(np.radians(45. - PHI / 2.)) ** 2
    thrust = np.linspace(ka * 1.02, ka, 5) * GAMMA * H ** 2 / 2.
    force = np.c_[thrust, 0. * thrust]
    factors = np.linspace(.2, 1., 5)
    return force, factors


def test_the_summary_and_the_picture_give_one_peak(tmp_path, monkeypatch):
    """summary.json's peak was the force at the largest displacement
    (the wall resists negatively: its largest resistance is the least
    push) while obstacles.png marked the largest magnitude, the first
    step's: both the least push now, the first step's force beside."""
    force, factors = active_wall()
    motion = np.array([.03, 0.])
    curve = motion_curves([("wall", motion, -1.)], factors, factors,
                          force[:, None, :])["wall"]
    assert curve["peak_force"] == force[-1].tolist()
    assert curve["first_force"] == force[0].tolist()
    kept = {}
    monkeypatch.setattr(plot, "save_figure",
                        lambda fig, path, **kw: kept.update(fig=fig))
    scene = SimpleNamespace(name="wall", units="kN-m", dynamics=None,
                            grid=SimpleNamespace(dim=2),
                            bodies=[SimpleNamespace(K0=.5)])
    plot_contact_forces(scene, {"wall": curve}, {"wall": motion},
                        "obstacles", tmp_path / "o.png")
    ax = kept["fig"].axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "magnitude: least push (peak resistance) {}, first {}, " \
        "final {}".format(*(plot.significant(f) for f in (
            force[-1, 0], force[0, 0], force[-1, 0]))) in labels
    # from the first step (the K0 start's force at step 0 is unknown),
    # not from a made-up 0 at displacement 0
    line = ax.get_lines()[0]
    assert np.allclose(line.get_xdata(), factors * motion[0])
    assert np.allclose(line.get_ydata(), force[:, 0])
    plot.pyplot().close(kept["fig"])


def test_a_start_at_rest_is_drawn_from_zero(tmp_path, monkeypatch):
    """Without a geostatic start the force is 0 at step 0: drawn."""
    force, factors = active_wall()
    motion = np.array([.03, 0.])
    curve = motion_curves([("wall", motion, -1.)], factors, factors,
                          force[:, None, :])["wall"]
    kept = {}
    monkeypatch.setattr(plot, "save_figure",
                        lambda fig, path, **kw: kept.update(fig=fig))
    scene = SimpleNamespace(name="wall", units="kN-m", dynamics=None,
                            grid=SimpleNamespace(dim=2),
                            bodies=[SimpleNamespace(K0=None)])
    plot_contact_forces(scene, {"wall": curve}, {"wall": motion},
                        "obstacles", tmp_path / "o.png")
    line = kept["fig"].axes[0].get_lines()[0]
    assert np.allclose(line.get_xdata(), np.r_[0., factors * motion[0]])
    assert np.allclose(line.get_ydata(), np.r_[0., force[:, 0]])
    plot.pyplot().close(kept["fig"])
