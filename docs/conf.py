"""Sphinx configuration of the skfem-mpm documentation.

Build (warnings are errors, as in CI)::

    .venv/bin/pip install ".[docs]"
    .venv/bin/python -m sphinx -W --keep-going -b html docs docs/_build/html

The build runs no example: the gallery's figures are committed, written by
``docs/make_gallery.py``.
"""
import ast
import importlib
import sys
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive, directives
from docutils.statemachine import StringList
from sphinx.util.nodes import nested_parse_with_titles

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
# document the checkout, not whatever copy of the package is installed
sys.path.insert(0, str(ROOT))

import skfem_mpm  # noqa: E402

project = "skfem-mpm"
author = "The skfem-mpm developers"
copyright = "the skfem-mpm developers (BSD-3-Clause)"
release = version = skfem_mpm.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "myst_parser",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build"]

# numpy-style docstrings (napoleon); types as written, no :rtype: field
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_param = True

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_description_target = "documented"
autodoc_default_options = {"members": True, "show-inheritance": True}
autosummary_generate = False          # tables only, no generated stub files
python_use_unqualified_type_names = True
add_module_names = False              # each module has a section of its own
toc_object_entries = False            # the sidebar: pages and modules

myst_heading_anchors = 3

html_theme = "alabaster"
html_title = "skfem-mpm {}".format(release)
html_theme_options = {
    "description": "The implicit Material Point Method as a scikit-fem "
                   "plugin",
    "fixed_sidebar": True,
    "page_width": "1200px",
    "sidebar_width": "290px",
}


# The few directives below keep the pages free of lists that go stale:
# the API pages read the package's ``__all__`` and module files, the
# gallery pages read each example's docstring from its file.

# the subpackages in the order of the API reference, with the heading of
# their public names in its tables (api.rst)
SUBPACKAGES = {
    "quadrature": "Material points and their basis",
    "methods": "Methods",
    "mechanics": "Materials and initial stress",
    "stabilisation": "Stabilisation",
    "solve": "Solving, loads, results, dynamics",
    "scenes": "Scenes",
    "studies": "Studies",
    "errors": "Errors",
    "memory": "Memory limits",
}


def parse(directive, lines, source):
    """reStructuredText ``lines``, parsed where ``directive`` stands."""
    container = nodes.container()
    nested_parse_with_titles(directive.state, StringList(lines, source),
                             container)
    return container.children


def autosummary(names):
    """An autosummary table of full names, shown by their last part."""
    return [".. autosummary::", ""] + ["   ~" + n for n in names] + [""]


class PublicNames(Directive):
    """``.. public-names::``: the names of ``skfem_mpm.__all__``, grouped
    by the subpackage that defines them (in the order of their modules),
    as autosummary tables: one-line summaries linking to the module
    pages.  Read from the package, so a name added to ``__all__`` is
    listed without editing the page."""

    def run(self):
        def module(name):
            return getattr(skfem_mpm, name).__module__
        groups = {}
        for name in sorted(skfem_mpm.__all__, key=lambda n: (
                module(n), skfem_mpm.__all__.index(n))):
            groups.setdefault(module(name).split(".")[1], []).append(name)
        lines = []
        for where in list(SUBPACKAGES) + sorted(set(groups)
                                                - set(SUBPACKAGES)):
            if where in groups:
                lines += [".. rubric:: " + SUBPACKAGES.get(where, where), ""]
                lines += autosummary("skfem_mpm." + n for n in groups[where])
        return parse(self, lines, "<public-names>")


class Modules(Directive):
    """``.. modules:: skfem_mpm.solve``: the subpackage's public names
    (its ``__all__``, if it has one) as an autosummary table, then a
    section with the ``automodule`` (with members) of each of its modules,
    in alphabetical order, so that a new module is documented without
    editing the page; ``:exclude:`` names modules documented elsewhere.  For ``skfem_mpm``
    itself: the modules at its top level."""

    required_arguments = 1
    option_spec = {"exclude": directives.unchanged}

    def run(self):
        package = importlib.import_module(self.arguments[0])
        excluded = set(self.options.get("exclude", "").split())
        lines = []
        if package is not skfem_mpm and getattr(package, "__all__", None):
            lines += ["Imported from ``{}``:".format(package.__name__), ""]
            lines += autosummary(package.__name__ + "." + n
                                 for n in package.__all__)
        for path in sorted(Path(package.__file__).parent.glob("*.py")):
            if path.stem == "__init__" or path.stem in excluded:
                continue
            self.state.document.settings.env.note_dependency(str(path))
            title = "``{}.{}``".format(package.__name__, path.stem)
            lines += [title, "-" * len(title), "",
                      ".. automodule:: {}.{}".format(package.__name__,
                                                     path.stem), ""]
        return parse(self, lines, "<modules {}>".format(package.__name__))


class ExampleDocstring(Directive):
    """``.. example-docstring:: ../../examples/NAME.py``: the docstring of
    an example script, parsed as reStructuredText, without importing (and
    so running) the script."""

    required_arguments = 1

    def run(self):
        env = self.state.document.settings.env
        _, path = env.relfn2path(self.arguments[0])
        env.note_dependency(path)
        text = ast.get_docstring(ast.parse(Path(path).read_text()))
        if not text:
            raise self.error("{} has no docstring".format(path))
        return parse(self, text.splitlines(), path)


def public_name(app, env, node, contnode):
    """Resolve a name as it is imported (``skfem_mpm.Dynamics``,
    ``skfem_mpm.quadrature.MaterialPointBasis``, as docstrings and the
    tables write them) to the module page that documents the object
    (``skfem_mpm.solve.dynamics.Dynamics``); a bare public name too
    (``side_points``, as a docstring of its own module writes it, shown
    in the tables of api.rst)."""
    target = node.get("reftarget", "")
    if node.get("refdomain") != "py":
        return None
    if target in skfem_mpm.__all__:
        target = "skfem_mpm." + target
    if not target.startswith("skfem_mpm."):
        return None
    parts = target.split(".")
    for i in range(len(parts) - 1, 0, -1):
        module = sys.modules.get(".".join(parts[:i]))
        if module is None:
            continue
        where = getattr(getattr(module, parts[i], None), "__module__", None)
        if not where or where == module.__name__ \
                or not where.startswith("skfem_mpm."):
            return None
        node = node.deepcopy()
        node["reftarget"] = ".".join([where] + parts[i:])
        return env.get_domain("py").resolve_xref(
            env, node["refdoc"], app.builder, node["reftype"],
            node["reftarget"], node, contnode)
    return None


def setup(app):
    app.add_directive("public-names", PublicNames)
    app.add_directive("modules", Modules)
    app.add_directive("example-docstring", ExampleDocstring)
    app.connect("missing-reference", public_name)
