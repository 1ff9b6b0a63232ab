"""The package's layers import one way.

Walks every module of ``skfem_mpm`` with :mod:`ast` (imports at module
level and inside functions, relative and absolute) and builds the graph of
its parts: each subpackage is a node, and so is each top-level module
(``errors``, ``memory``, ``graph``, ``cli``, ...); the package's own
``__init__`` is the node ``skfem_mpm``.  From the bottom up::

    errors, memory, graph
    quadrature
    mechanics, methods        (methods may use mechanics)
    stabilisation
    solve
    scenes
    studies                   (studies may use scenes, never the reverse)
    cli, skfem_mpm/__init__   (may import anything)
"""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "skfem_mpm"
NAME = PACKAGE.name

#: the low layers, with the parts each must not import
FORBIDDEN = {
    "quadrature": {"methods", "mechanics", "stabilisation"},
    "methods": {"stabilisation"},
    "mechanics": {"stabilisation"},
    "stabilisation": set(),
}
HIGH = {"solve", "scenes", "studies", "cli"}
#: top-level modules the others build on: they import only each other
BASE = {"errors", "memory", "graph"}


def module_name(path):
    """The dotted name of the module in ``path``."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(source, name, package=False):
    """The absolute names of the modules that module ``name`` (dotted; a
    package's ``__init__`` when ``package``) with text ``source`` imports:
    every import statement, at module level or inside a function; ``from
    package import name`` gives ``package.name``, as ``name`` may be a
    module."""
    here = name if package else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(source, name)):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here.split(".")
                base = base[:len(base) - node.level + 1]
                source_module = ".".join(base + ([node.module] if node.module
                                                 else []))
            else:
                source_module = node.module
            found += [source_module + "." + alias.name
                      for alias in node.names]
    return found


def part(module):
    """The node of the graph that module ``module`` (dotted) belongs to, or
    None outside the package."""
    parts = module.split(".")
    if parts[0] != NAME:
        return None
    if len(parts) == 1:
        return NAME
    if (PACKAGE / parts[1]).is_dir() or \
            (PACKAGE / (parts[1] + ".py")).exists():
        return parts[1]
    return NAME  # a name the package's __init__ defines (__version__)


def import_graph():
    """``{part: {imported part: [(module, imported module), ...]}}``."""
    graph = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        source = module_name(path)
        here = part(source)
        edges = graph.setdefault(here, {})
        for target in imported_modules(path.read_text(), source,
                                       path.name == "__init__.py"):
            there = part(target)
            if there is not None and there != here:
                edges.setdefault(there, []).append((source, target))
    return graph


GRAPH = import_graph()


def test_the_walk_sees_local_and_relative_imports():
    source = (
        "import numpy\n"
        "from ..errors import InvalidInputError\n"
        "from . import plot\n"
        "def f():\n"
        "    from ..studies.study import study\n"
        "    import skfem_mpm.memory\n"
        "    from .. import __version__\n")
    found = imported_modules(source, NAME + ".scenes.anything")
    assert sorted(found) == sorted([
        "numpy", NAME + ".errors.InvalidInputError", NAME + ".scenes.plot",
        NAME + ".studies.study.study", NAME + ".memory",
        NAME + ".__version__"])
    assert [part(m) for m in sorted(found)] == [
        None, NAME, "errors", "memory", "scenes", "studies"]
    assert imported_modules("from .basis import X", NAME + ".quadrature",
                            package=True) == [NAME + ".quadrature.basis.X"]
    assert "studies" in GRAPH and "scenes" in GRAPH["studies"]


@pytest.mark.parametrize("low", sorted(FORBIDDEN))
def test_low_layers_import_no_higher_one(low):
    wrong = {there: edges for there, edges in GRAPH.get(low, {}).items()
             if there in HIGH | FORBIDDEN[low] | {NAME}}
    assert not wrong, f"{low} imports from higher layers: {wrong}"


def test_base_modules_import_only_each_other():
    for base in sorted(BASE & set(GRAPH)):
        wrong = {there: edges for there, edges in GRAPH[base].items()
                 if there not in BASE}
        assert not wrong, f"{base} imports {wrong}"


def test_scenes_do_not_import_studies():
    wrong = GRAPH["scenes"].get("studies", [])
    assert not wrong, f"scenes import studies: {wrong}"


def test_no_cycle_between_parts():
    """Depth-first search for a cycle; the one found is reported."""
    done, path = set(), []

    def visit(node):
        if node in path:
            cycle = path[path.index(node):] + [node]
            steps = [GRAPH[a][b][0] for a, b in zip(cycle, cycle[1:])]
            pytest.fail("import cycle {}: {}".format(" -> ".join(cycle),
                                                      steps))
        if node in done:
            return
        path.append(node)
        for there in sorted(GRAPH.get(node, {})):
            visit(there)
        path.pop()
        done.add(node)

    for node in sorted(GRAPH):
        visit(node)
