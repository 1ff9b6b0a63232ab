"""``skfem-mpm safety``: the factor of safety by strength reduction from
the command line (a user trial rewrote c and tan(phi) per trial F and ran
the CLI by hand), on the Python ``strength_reduction``."""
import json

import numpy as np
import pytest

from skfem_mpm.cli import main

#: the 45-degree clay slope of examples/slope.py at h = H/4 (10 m high,
#: c_u = 86.6 / sqrt(3) = 50 kPa, 20 kN/m^3), its toe off the points'
#: sub-cell centres
SLOPE = """\
name = "clay-slope"
units = "kN-m"
[grid]
x = [0.0, 35.0, 14]
y = [0.0, 12.5, 5]
[[bodies]]
name = "clay"
region = { polygon = [[10.3, 0], [35, 0], [35, 10], [20.3, 10]] }
points_per_cell = 2
material = { model = "von_mises", E = 2e4, nu = 0.3, yield_stress = 86.6 }
[[supports]]
boundary = "bottom"
[[supports]]
boundary = "right"
components = ["x"]
[gravity]
body_force = [0.0, -20.0]
[solver]
steps = 8
antilocking = true
"""


def python_factor(high, tolerance):
    """The same slope through the Python API (``simulate`` on a seeded
    mesh, as examples/slope.py), its factor of safety."""
    from skfem import ElementQuad1, MeshQuad

    from skfem_mpm import (NewtonOptions, Options, Stabilisation, VonMises,
                           reduce_strength, seed_points, simulate,
                           strength_reduction)
    mesh = MeshQuad.init_tensor(np.linspace(0., 35., 15),
                                np.linspace(0., 12.5, 6))
    points = seed_points(mesh, 2, region=lambda x: x[1] < np.clip(
        x[0] - 10.3, 0., 10.))
    clay = VonMises(E=2e4, nu=.3, yield_stress=86.6)

    def supports(basis):
        return np.concatenate([
            basis.get_dofs(lambda x: np.isclose(x[1], 0.)).all(),
            basis.get_dofs(lambda x: np.isclose(x[0], 35.)).all("u^1")])

    def run(factor):
        return simulate(mesh, ElementQuad1(), points,
                        reduce_strength(clay, factor), supports,
                        body_force=[0., -20.], nsteps=8,
                        options=Options(NewtonOptions(),
                                        Stabilisation(antilocking=True)))
    return strength_reduction(run, 1., high, tolerance)


def test_the_command_finds_the_python_factor(tmp_path, capsys):
    """The CLI on the scene gives the factor of the Python
    ``strength_reduction`` on the same slope built in Python, to the
    bisection's tolerance; its summary holds every trial, in order, and
    the bracket; a line per trial is printed."""
    scene = tmp_path / "slope.toml"
    scene.write_text(SLOPE)
    out = tmp_path / "out"
    assert main(["safety", str(scene), "--out", str(out), "--high", "1.8",
                 "--tolerance", "0.05", "--no-progress"]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((out / "safety.json").read_text())
    found = python_factor(1.8, .05)
    assert abs(summary["factor_of_safety"] - found.factor) <= \
        .05 * found.converged, (summary["factor_of_safety"], found.factor)
    assert summary["bracket"][1] - summary["bracket"][0] <= \
        .05 * summary["bracket"][0]
    trials = summary["trials"]
    assert [t["factor"] for t in trials] == [f for f, _ in found.trials]
    assert [t["outcome"] == "stands" for t in trials] == \
        [s for _, s in found.trials]
    for t in trials:
        assert t["outcome"] in ("stands", "collapses", "fails")
        assert (t["largest_displacement"] is None) == (not t["converged"])
        assert t["seconds"] >= 0
        assert "F = {:.4f}: {}".format(t["factor"], "converged" if
                                       t["converged"] else "not converged"
                                       ) in printed
    assert summary["units"]["largest_displacement"] == "m"
    assert (out / "safety.png").stat().st_size > 0
    assert (out / "mechanism.png").stat().st_size > 0
    assert "factor of safety {:.3f}".format(
        summary["factor_of_safety"]) in printed


@pytest.mark.parametrize("option, words", [
    (["--low", "0"], "--low must be a number > 0"),
    (["--low", "abc"], "--low must be a number > 0"),
    (["--high", "0.5"], "--high must be > --low"),
    (["--tolerance", "1.5"], "--tolerance must be a number between 0 and 1"),
    (["--growth", "1"], "--growth must be a number > 1"),
    (["--growth", "nan"], "--growth must be a number > 1"),
    (["--steps", "0"], "--steps must be an integer >= 1"),
])
def test_bad_options_are_refused_before_any_work(tmp_path, capsys,
                                                 monkeypatch, option, words):
    """Each bad option gets a line naming it, status 2, no run, nothing
    written (the scene is not even read)."""
    import skfem_mpm.cli as cli

    def no_run(*args, **kwargs):
        raise AssertionError("ran")
    monkeypatch.setattr(cli, "run_scene", no_run)
    out = tmp_path / "out"
    assert main(["safety", str(tmp_path / "missing.toml"), "--out",
                 str(out)] + option) == 2
    assert words in capsys.readouterr().err
    assert not out.exists()


def test_a_scene_without_strength_to_reduce_is_refused(tmp_path, capsys,
                                                       monkeypatch):
    """A scene of linear elastic bodies alone, or with Cam clay, is
    refused before any run, naming the bodies; a dynamic one too."""
    import skfem_mpm.cli as cli

    def no_run(*args, **kwargs):
        raise AssertionError("ran")
    monkeypatch.setattr(cli, "run_scene", no_run)
    scene = tmp_path / "elastic.toml"
    scene.write_text(SLOPE.replace(
        'model = "von_mises"', 'model = "linear_elastic"').replace(
            ", yield_stress = 86.6", ""))
    assert main(["safety", str(scene), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "the scene has none (clay LinearElastic)" in err
    scene.write_text(SLOPE.replace(
        'model = "von_mises", E = 2e4, nu = 0.3, yield_stress = 86.6',
        'model = "cam_clay", kappa = 0.02, lambda = 0.1, M = 1.0, '
        'shear_modulus = 5e3, reference_pressure = 100.0'))
    assert main(["safety", str(scene), "--out", str(tmp_path / "o")]) == 2
    assert "{}: bodies[0] (clay): ".format(scene) in capsys.readouterr().err
    text = SLOPE.replace("[[bodies]]", "[[bodies]]\ndensity = 2.0").replace(
        "steps = 8\n", "")
    scene.write_text(text + "[dynamics]\ntime_step = 0.1\n"
                     "duration = 1.0\n")
    assert main(["safety", str(scene), "--out", str(tmp_path / "o")]) == 2
    assert "static scene" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def fake_runs(monkeypatch, limit=1.37, hole=(1.30, 1.33),
              far=(1.95, 2.05)):
    """``run_scene`` of the CLI replaced by a stand-in of SLOPE: it
    collapses beyond ``limit`` (its run fails), fails inside ``hole``
    with the scene's 8 load steps (a load step too large; more steps
    converge) and converges again, slumped 30 times as far, in ``far``
    (trial 98's path: 1.8281 failed, 1.8438 converged).  Returns the
    (factor, steps) of every run."""
    import skfem_mpm.cli as cli
    from types import SimpleNamespace

    from skfem_mpm import NewtonDivergenceError
    calls = []

    def run_scene(scene, initial=None, callback=None):
        factor = 86.6 / scene.bodies[0].material.yield_stress
        calls.append((factor, scene.step_count))
        if scene.step_count == 8 and hole[0] < factor < hole[1]:
            raise NewtonDivergenceError(
                "step 5 of 8: the residual grew (F = {:.6f})".format(factor))
        moved = .3 if far[0] < factor <= far[1] else .01
        if factor > limit and not far[0] < factor <= far[1]:
            raise NewtonDivergenceError("no equilibrium")
        x = np.array([[10.3, 35.], [0., 10.]])
        return SimpleNamespace(history=[None] * scene.step_count,
                               points=SimpleNamespace(
                                   x=x, dim=2, state={},
                                   displacement=np.array([[0., 0.],
                                                          [0., -moved]])))
    monkeypatch.setattr(cli, "run_scene", run_scene)
    return calls


def test_a_failure_below_a_slumped_run_is_retried_and_said_once(
        tmp_path, capsys, monkeypatch, caplog):
    """Trial 98: a run failed at a factor below one that converged, and
    the factor (1.820 or 1.896 by the search path) hid it.  The run
    that converged moved past --growth: a collapse, which the failures
    below it agree with, so without retries the trials look monotone:
    no WARNING, the span the bracket (an ordinary search past collapse
    was "uncertain").  With them (the default): the failed top of the
    bracket is run again with twice the load steps, the bisection goes
    on to the collapse, each retry a trial and a line, each warning
    printed with the summary and not logged to stderr as well."""
    import logging
    limit, hole, far = 1.37, (1.30, 1.33), (1.95, 2.05)
    calls = fake_runs(monkeypatch, limit, hole, far)
    scene = tmp_path / "slope.toml"
    scene.write_text(SLOPE)
    out = tmp_path / "plain"
    assert main(["safety", str(scene), "--out", str(out), "--no-progress",
                 "--no-retry"]) == 0
    printed = capsys.readouterr().out
    s = json.loads((out / "safety.json").read_text())
    low, high = s["bracket"]
    assert hole[0] <= high < hole[1] and all(n == 8 for _, n in calls)
    above = min(t["factor"] for t in s["trials"]
                if t["converged"] and t["factor"] > high)
    assert far[0] < above <= far[1]
    assert s["span"] == [low, high] and s["warnings"] == []
    top = [t for t in s["trials"] if t["factor"] == high][0]
    assert top["error"] == "NewtonDivergenceError: step 5 of 8: the " \
        "residual grew (F = {:.6f})".format(high)
    assert "WARNING" not in printed
    calls.clear()
    out = tmp_path / "retried"
    with caplog.at_level(logging.WARNING):
        caplog.clear()
        assert main(["safety", str(scene), "--out", str(out),
                     "--no-progress"]) == 0
    printed = capsys.readouterr().out
    s = json.loads((out / "safety.json").read_text())
    low, high = s["bracket"]
    assert low <= limit < high and s["span"] == [low, high]
    again = [t for t in s["trials"] if t["retry"]]
    assert 1 <= len(again) <= 3 and all(t["steps"] == 16 for t in again)
    assert [n for _, n in calls].count(16) == len(again)
    assert len(calls) == len(s["trials"])
    assert not any("WARNING" in line and "uncertain" in line
                   for line in printed.splitlines())
    assert "{} runs of which {} retr".format(len(calls), len(again)) \
        in printed
    for t in again:
        assert "F = {:.4f}: its run failed; retried with 16 load " \
            "steps".format(t["factor"]) in printed
    assert any("was numerical" in w for w in s["warnings"])
    logged = [r.getMessage() for r in caplog.records]
    for w in s["warnings"]:
        assert printed.count(w) == 1 and printed.count(
            "  WARNING: {}".format(w)) == 1
        assert not [m for m in logged if w in m]


def test_the_readme_names_every_file_safety_writes():
    """README's paragraph on ``skfem-mpm safety``: its ``--out ... gets``
    sentence names each file the command writes (its docstring's), and
    the span's hatching is said of safety.png alone (a sentence put in
    the middle of the list had taken mechanism.png out of it)."""
    import re
    from pathlib import Path

    from skfem_mpm.cli import run_safety
    written = set(re.findall(r"``(\w+\.(?:json|png))``", run_safety.__doc__))
    assert written == {"safety.json", "safety.png", "mechanism.png"}
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    paragraph = readme[readme.index("`skfem-mpm safety SCENE"):]
    paragraph = " ".join(paragraph[:paragraph.index("\n\n")].split())
    start = paragraph.index("`--out` (default")
    depth, end = 0, start
    while not (depth == 0 and paragraph.startswith(". ", end)):
        depth += {"(": 1, ")": -1}.get(paragraph[end], 0)
        end += 1
    gets = paragraph[start:end]
    outside = re.sub(r"\([^()]*(\([^()]*\)[^()]*)*\)", "", gets)
    assert set(re.findall(r"`(\w+\.(?:json|png))`", outside)) == written
    hatched = paragraph[paragraph.index("hatched on"):]
    hatched = hatched[:hatched.index(". ")]
    assert "mechanism.png" not in hatched
