"""Every public docstring example runs as a user copies it: in a clean
namespace, with nothing but its own imports (trial 85: 35 of 149 examples
of the package's public names failed so, nearly all a NameError for the
name documented or for ``np``, while ``pytest --doctest-modules`` passed
them with the module's own names at hand)."""
import doctest

import pytest

import skfem_mpm

def doctests(name):
    """The docstring tests of a public name and of its methods, each to
    run in an empty namespace."""
    finder = doctest.DocTestFinder(recurse=True, exclude_empty=True)
    return [test for test in finder.find(getattr(skfem_mpm, name), name,
                                         globs={})
            if test.examples]


DOCUMENTED = [name for name in skfem_mpm.__all__ if doctests(name)]


def test_some_public_names_have_examples():
    assert len(DOCUMENTED) >= 20, DOCUMENTED


@pytest.mark.parametrize("name", DOCUMENTED)
def test_example_runs_in_a_clean_namespace(name):
    runner = doctest.DocTestRunner(
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    report = []
    for test in doctests(name):
        assert set(test.globs) <= {"__name__"}
        runner.run(test, out=report.append, clear_globs=True)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, "".join(report)


def test_every_module_s_examples_pass_plain_doctest():
    """``python -m doctest`` and ``doctest.testmod`` use no option flags:
    an expected traceback shortened with ``...`` needs its own
    ``# doctest: +ELLIPSIS`` (a lecturer's trial: check_conforming and
    check_displacement_element failed so)."""
    import importlib
    import pkgutil
    failed = []
    for info in pkgutil.walk_packages(skfem_mpm.__path__, "skfem_mpm."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        result = doctest.testmod(module, report=False, optionflags=0)
        if result.failed:
            failed.append(info.name)
    assert not failed
