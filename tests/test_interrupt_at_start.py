"""Ctrl-C while the ``skfem-mpm`` command is starting (issue 30): in the
first half second, while numpy, scipy and scikit-fem load, a Ctrl-C
printed a raw ``KeyboardInterrupt`` traceback; it gets the one line and
exit status 130 of a Ctrl-C at any later moment.

The interrupt is not timed: a finder on ``sys.meta_path``, installed
before anything of the package is imported, sends the process SIGINT
when numpy is first imported, as a Ctrl-C half a second in would."""
import subprocess
import sys
from pathlib import Path

import pytest

from skfem_mpm.scenes.scene_file import tomllib

ROOT = Path(__file__).resolve().parent.parent

#: a Ctrl-C (SIGINT to the process itself) at the first import of numpy;
#: Python's handler is set first, as a terminal's process has it (a test
#: run started in the background of a script inherits SIGINT ignored)
INTERRUPT_AT_NUMPY = """\
import os, signal, sys
signal.signal(signal.SIGINT, signal.default_int_handler)

class InterruptAtNumpy:
    def find_spec(self, name, path=None, target=None):
        if name == "numpy":
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, InterruptAtNumpy())
"""


def console_script() -> str:
    """What pip writes for the ``skfem-mpm`` entry point of
    pyproject.toml (its ``module:function``)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    module, function = project["project"]["scripts"]["skfem-mpm"].split(":")
    return ("import re\nimport sys\nfrom {} import {}\nif __name__ == "
            "'__main__':\n    sys.argv[0] = re.sub(r'(-script\\.pyw|\\.exe)?$',"
            " '', sys.argv[0])\n    sys.exit({}())\n".format(
                module, function, function))


@pytest.mark.parametrize("how", ["console script", "python -m skfem_mpm"])
def test_ctrl_c_while_the_package_loads_gets_one_line(tmp_path, how):
    out = tmp_path / "out"
    start = console_script() if how == "console script" else \
        "import runpy\nrunpy.run_module('skfem_mpm', run_name='__main__', " \
        "alter_sys=True)\n"
    script = tmp_path / "skfem-mpm"
    script.write_text(INTERRUPT_AT_NUMPY + start)
    done = subprocess.run([sys.executable, str(script), "run", "--out",
                           str(out), "--no-progress"], capture_output=True,
                          text=True, timeout=120, cwd=tmp_path)
    err = done.stderr.strip().splitlines()
    assert done.returncode == 130, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr
    assert len(err) == 1 and err[0].startswith("skfem-mpm: interrupted"), err
    assert not out.exists()


def test_the_command_runs_from_its_entry_point(tmp_path):
    """Without the interrupt, the same entry point runs the command."""
    script = tmp_path / "skfem-mpm"
    script.write_text(console_script())
    done = subprocess.run([sys.executable, str(script), "--version"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().startswith("skfem-mpm ")
