"""A large run's set-up (trial 111, item 9): its stages said on stderr,
counted in the progress's elapsed time, and a polygon region asked
without its distances (a 1e6-point slope's first line came 28 s after
its launch, its bar said 0:36 at step 1, 60 s after)."""
import io
import re
from types import SimpleNamespace

import numpy as np

from skfem_mpm.cli import Progress, SetUp, main
from skfem_mpm.scenes.regions import Polygon
from test_cli_trial53 import PRESSED


def test_the_elapsed_time_counts_the_set_up_the_pace_does_not():
    """Set-up from t = 0 to 20 s, then half the load in 10 s: elapsed
    0:30, left 0:10 (from the steps' pace)."""
    now = [0.]
    setup = SetUp(True, stream=io.StringIO(), timer=lambda: now[0])
    now[0] = 20.
    stream = io.StringIO()
    bar = Progress(4, "always", stream=stream, timer=lambda: now[0],
                   started=setup.started)
    now[0] = 30.
    bar(SimpleNamespace(step=2, load_factor=.5, newton_iterations=1,
                        residual=1e-12))
    assert stream.getvalue().endswith("elapsed 0:30 left 0:10")


def test_a_set_up_says_its_stages_once_long_or_large():
    now = [0.]
    stream = io.StringIO()
    setup = SetUp(True, stream=stream, timer=lambda: now[0])
    setup("reading")                      # short and small: nothing
    assert stream.getvalue() == ""
    now[0] = 2.5
    setup("seeding")
    assert stream.getvalue() == "set-up: seeding, elapsed 0:02\n"
    quiet = SetUp(False, stream=stream, timer=lambda: now[0])
    quiet.large = True
    quiet("anything")                    # --no-progress: nothing
    assert stream.getvalue().count("\n") == 1


def test_a_large_run_says_its_set_up(tmp_path, monkeypatch, capsys):
    """The CLI with the threshold below the scene's sub-cells: the
    seeding (bodies, cells, sub-cells), the check (points) and the
    solver's set-up are said before the first step's progress."""
    import skfem_mpm.cli as cli
    monkeypatch.setattr(cli, "plot_outputs", lambda *args, **kwargs: None)
    monkeypatch.setattr(cli, "LARGE_SETUP", 1)
    scene = tmp_path / "pressed.toml"
    scene.write_text(PRESSED)
    assert main(["run", str(scene), "--out", str(tmp_path / "out"),
                 "--no-series", "--max-steps", "1"]) == 0
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("set-up")]
    assert [re.sub(r"\d+", "N", line) for line in lines] == [
        "set-up: seeding N body on N cells (N sub-cells to sample), "
        "elapsed N:N",
        "set-up: checking the N points, elapsed N:N",
        "set-up: setting up the solver (the grid's operators, supports, "
        "contact) and step N, elapsed N:N"]
    assert err.index(lines[-1]) < err.index("step    1/")
    monkeypatch.setattr(cli, "LARGE_SETUP", 10 ** 9)     # small and short
    assert main(["run", str(scene), "--out", str(tmp_path / "small"),
                 "--no-series", "--max-steps", "1"]) == 0
    assert "set-up" not in capsys.readouterr().err


def test_a_polygon_region_answers_as_its_distance_does():
    """Inside: distance < 0; on a side or a vertex: outside, as before
    the region was asked edge by edge."""
    slope = Polygon([[0., 0.], [4., 0.], [4., 1.], [2., 1.], [1., .5],
                     [0., .5]])
    rng = np.random.default_rng(3)
    x = np.hstack([rng.uniform(-.5, 4.5, (2, 5000)),
                   np.mgrid[0:4:41j, 0:1.1:23j].reshape(2, -1),
                   slope.vertices, [[1.5], [.75]]])      # on the slope
    inside = slope(x)
    np.testing.assert_array_equal(inside, slope.distance(x) < 0.)
    assert not inside[-1] and inside.any() and not inside.all()
