"""The documentation's sources are complete: every example has a gallery
page, every page is in a toctree, every subpackage has an API page, every
figure shown exists.  Reads the sources only (the build itself, with
warnings as errors, is in .ci/run)."""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
GALLERY = DOCS / "gallery"
EXAMPLES = ROOT / "examples"


def sources():
    """Every page of the documentation, as its name (``gallery/column``)."""
    return {str(path.relative_to(DOCS).with_suffix("")): path
            for suffix in ("*.rst", "*.md") for path in DOCS.rglob(suffix)
            if "_build" not in path.parts}


def toctree_entries(path):
    """The documents a page's toctrees list, as names from the docs root."""
    text = path.read_text()
    if path.suffix == ".md":
        blocks = re.findall(r"```\{toctree\}\n(.*?)```", text, re.S)
    else:
        blocks = re.findall(r"^\.\. toctree::\n((?:[ \t]+.*\n|\n)*)", text,
                            re.M)
    entries = [line.strip() for block in blocks
               for line in block.splitlines()
               if line.strip() and not line.strip().startswith(":")]
    folder = path.parent.relative_to(DOCS)
    return {str(folder / entry) if str(folder) != "." else entry
            for entry in entries}


def test_every_page_is_in_a_toctree():
    pages = sources()
    listed = set().union(*(toctree_entries(p) for p in pages.values()))
    assert listed <= set(pages), listed - set(pages)
    orphans = set(pages) - listed - {"index"}
    assert not orphans, "pages in no toctree: {}".format(sorted(orphans))
    # the markdown guides in particular
    for md in DOCS.glob("*.md"):
        assert md.stem == "index" or md.stem in listed, md


def test_every_example_has_a_gallery_page():
    listed = toctree_entries(GALLERY / "index.rst")
    for script in sorted(EXAMPLES.glob("*.py")):
        page = GALLERY / (script.stem + ".rst")
        assert page.exists(), "no gallery page for {}".format(script.name)
        text = page.read_text()
        for directive in ("example-docstring", "literalinclude"):
            assert ".. {}:: ../../examples/{}".format(
                directive, script.name) in text, (page.name, directive)
        assert "gallery/" + script.stem in listed, page.name


def test_every_scene_file_is_shown():
    shown = "".join(p.read_text() for p in GALLERY.glob("*.rst"))
    for scene in sorted(EXAMPLES.glob("*.toml")):
        assert ".. literalinclude:: ../../examples/{}".format(
            scene.name) in shown, "{} is on no gallery page".format(
                scene.name)


def test_gallery_figures_exist_and_are_shown():
    """Every figure a page shows exists (docs/make_gallery.py writes them),
    every figure committed is shown, and every script's page shows one."""
    shown = set()
    for page in GALLERY.glob("*.rst"):
        figures = re.findall(r"^\.\. (?:figure|image):: (\S+)",
                             page.read_text(), re.M)
        for figure in figures:
            assert (GALLERY / figure).exists(), (page.name, figure)
        shown |= set(figures)
        if (EXAMPLES / (page.stem + ".py")).exists():
            assert figures, "{} shows no figure".format(page.name)
    committed = {p.name for p in GALLERY.glob("*.png")}
    assert committed <= shown, committed - shown


def test_every_subpackage_has_an_api_page():
    documented = set()
    for page in DOCS.glob("api*.rst"):
        documented |= set(re.findall(r"^\.\. modules:: (\S+)",
                                     page.read_text(), re.M))
    packages = {"skfem_mpm"} | {
        "skfem_mpm." + p.parent.name
        for p in (ROOT / "skfem_mpm").glob("*/__init__.py")}
    assert packages <= documented, packages - documented


def test_public_names_have_docstrings():
    """autodoc leaves out a member without a docstring: the API tables'
    link to it would lead nowhere."""
    import importlib

    import skfem_mpm
    modules = [skfem_mpm] + [
        importlib.import_module("skfem_mpm." + p.parent.name)
        for p in sorted((ROOT / "skfem_mpm").glob("*/__init__.py"))]
    for module in modules:
        for name in getattr(module, "__all__", []):
            assert getattr(module, name).__doc__, "{}.{}".format(
                module.__name__, name)


def test_every_test_a_page_cites_exists():
    """A page's `test_file.py::test_name` (and a `::test_name` after it,
    of the same file) names a test of that file: robustness.md cited
    test_bspline_support_inside_the_grid_is_refused, renamed since."""
    missing = []
    for page in sorted(DOCS.glob("*.md")) + [ROOT / "README.md"]:
        current = None
        for match in re.finditer(r"`(?:tests/)?(test_\w+\.py)?::(test_\w+)",
                                 page.read_text()):
            current = match.group(1) or current
            path = ROOT / "tests" / str(current)
            if current is None or not path.exists() or not re.search(
                    r"^def {}\(".format(match.group(2)), path.read_text(),
                    re.M):
                missing.append("{}: {}::{}".format(page.name, current,
                                                   match.group(2)))
    assert not missing, missing
