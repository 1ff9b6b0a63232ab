"""The README's commands and example stay true."""
import doctest
import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()


def blocks(language):
    return re.findall(r"```{}\n(.*?)```".format(language), README, re.S)


def test_two_commands_and_ci_runs_the_test_command():
    commands = [b.strip() for b in blocks("bash")]
    assert len(commands) == 2
    main_job, tests = commands
    assert main_job.endswith("skfem-mpm run")
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert tests in ci


def test_readme_examples_run():
    """The README is a doctest (its ``>>>`` lines, all in the Python blocks
    of its Example section); then its numbers against their derivations."""
    assert README.count(">>>") == sum(
        code.count(">>>") for code in blocks("python")) > 0
    test = doctest.DocTestParser().get_doctest(README, {}, "README.md",
                                               str(ROOT / "README.md"), 0)
    runner = doctest.DocTestRunner(
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    report = []
    runner.run(test, out=report.append, clear_globs=False)
    assert runner.failures == 0, "".join(report)
    namespace = test.globs
    pts = namespace["pts"]
    # weak equilibrium with the test field v = (0, y), zero on the fixed
    # base: sum_p sigma_yy V_p = int y b_y dV = -800 * 4 * 10**2 / 2, exact
    # in one step; the 10 steps move the points by ~0.4%
    total = pts.stress[1, 1] @ pts.volume
    assert abs(total / -160000. - 1.) < 1e-2
    assert namespace["result"].history[-1].residual < 1e-10
    assert namespace["K"].shape == (130, 130)
    # the scikit-fem path: a finite solution; the top settles by the 1D
    # estimate b H^2 / (2 E / (1 - nu^2)) to within 3% (the fixed base
    # also holds the body sideways)
    u = namespace["u"]
    assert np.isfinite(u).all()
    assert abs(u.min() / (-800. * 10. ** 2 / 2 / (1e6 / (1 - .3 ** 2)))
               - 1.) < .03
    large = namespace["large"]
    assert len(large.history) == 10 and large.history[-1].load_factor == 1.
    assert max(r.residual for r in large.history) <= 1e-9
    # the reactions hold the weight (800 x 4 x 10) and the pressure on the
    # top (1e3 x 4 wide, vertical on the unrotated top) to the Newton
    # tolerance
    reaction = large.history[-1].reactions.reshape(-1, 2).sum(axis=0)
    weight = 800. * large.points.volume0.sum()
    assert abs(reaction[1] / (weight + 1e3 * 4.) - 1.) < 1e-2
    assert abs(reaction[0]) < 1e-2 * reaction[1]


def test_version_licence_and_citation_agree(capsys):
    """``skfem-mpm --version`` prints the package's version, which is
    pyproject's and CITATION.cff's; LICENSE is the declared BSD-3-Clause;
    py.typed ships with the package."""
    import skfem_mpm
    from skfem_mpm.cli import main
    from skfem_mpm.scenes.scene_file import tomllib
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == "skfem-mpm " + project[
        "version"] == "skfem-mpm " + skfem_mpm.__version__
    assert project["license"]["text"] == "BSD-3-Clause"
    assert (ROOT / "LICENSE").read_text().startswith("BSD 3-Clause License")
    citation = (ROOT / "CITATION.cff").read_text()
    assert "version: {}\n".format(project["version"]) in citation
    assert "license: BSD-3-Clause" in citation
    assert (ROOT / "skfem_mpm" / "py.typed").exists()


def test_the_readmes_progress_lines_show_a_line_a_step():
    """The README's two lines of logging set-up (its one Python block
    without ``>>>``) make a script's run say each step on stderr (trial
    94: a 3D run of 115 s was silent); the first doctest's column, 3
    steps, in a fresh interpreter (logging set-up is process-wide)."""
    import os
    import subprocess
    import sys
    setup = [code for code in blocks("python") if ">>>" not in code]
    assert len(setup) == 1 and "skfem_mpm" in setup[0]
    script = setup[0] + """
import numpy as np
from skfem import MeshQuad, ElementQuad1
from skfem_mpm import LinearElastic, seed_points, solve_mpm
mesh = MeshQuad.init_tensor(np.linspace(0, 4, 5), np.linspace(0, 12, 13))
solve_mpm(mesh, ElementQuad1(), seed_points(mesh, 2), LinearElastic(1e6, .3),
          supports=lambda b: b.get_dofs(lambda x: x[1] == 0),
          body_force=[0., -800.], nsteps=3)
"""
    env = dict(os.environ, SKFEM_MPM_KERNELS="numpy")
    run = subprocess.run([sys.executable, "-c", script], env=env,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    steps = [line for line in run.stderr.splitlines()
             if line.startswith("step ")]
    assert [line.split(":")[0] for line in steps] == [
        "step 1", "step 2", "step 3"], run.stderr
    assert "load factor 1," in steps[-1] and run.stdout == ""
