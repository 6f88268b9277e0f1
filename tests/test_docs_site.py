"""The documentation site (mkdocs.yml) cannot go stale silently.

The site itself is built with warnings as errors by ``.ci/run`` (``mkdocs build --strict``,
extra ``docs``); these checks need no MkDocs:

- every page of docs/ and every notebook is in the site's navigation;
- every API reference entry (``::: name``) names an object that imports;
- the rendered notebooks (docs/notebooks/, executed by docs/execute_notebooks.py) have the same
  cells as their sources in notebooks/, ran without an error, and show their figures.
"""

import importlib
import re
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
SOURCES = sorted((REPO / "notebooks").glob("*.ipynb"))
MKDOCS = (REPO / "mkdocs.yml").read_text()


def test_every_page_and_notebook_is_in_the_navigation():
    pages = [p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")]
    pages += [f"notebooks/{p.name}" for p in SOURCES]
    missing = [p for p in pages if f": {p}\n" not in MKDOCS]
    assert not missing, f"pages missing from mkdocs.yml's nav: {missing}"


def _resolve(name):
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ModuleNotFoundError:
            continue
        for attr in parts[k:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(name)


def test_api_reference_entries_import():
    names = [m for page in (DOCS / "reference").glob("*.md")
             for m in re.findall(r"^::: ([\w.]+)", page.read_text(), re.M)]
    assert len(names) > 50
    for name in names:
        assert _resolve(name) is not None, name


def test_public_names_are_in_the_api_reference():
    import jaxroll

    listed = {m for page in (DOCS / "reference").glob("*.md")
              for m in re.findall(r"^::: jaxroll\.(\w+)", page.read_text(), re.M)}
    missing = [n for n in jaxroll.__all__ if n not in listed and not hasattr(getattr(jaxroll, n), "__path__")]
    assert not missing, f"public names without an API reference entry: {missing}"


def _cells(nb):
    return [(c.cell_type, c.source) for c in nb.cells]


@pytest.mark.parametrize("source", SOURCES, ids=[p.stem for p in SOURCES])
def test_rendered_notebook_matches_its_source(source):
    rendered = DOCS / "notebooks" / source.name
    assert rendered.exists(), f"run: python docs/execute_notebooks.py {source.name[:2]}"
    nb, src = nbformat.read(rendered, as_version=4), nbformat.read(source, as_version=4)
    assert _cells(nb) == _cells(src), f"{source.name} changed since it was rendered: run docs/execute_notebooks.py"
    assert nb.metadata["jaxroll_run"]["quick"] is True
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code), "not every cell ran"
    assert not [o for c in code for o in c.outputs if o.output_type == "error"]
    xla_log = re.compile(r"^[IWEF]\d{4} \d\d:\d\d:\d\d", re.M)  # XLA's C++ logging, not the notebook's output
    assert not [o for c in code for o in c.outputs if o.output_type == "stream" and xla_log.search(o.text)]
    draws = re.compile(r"\bplot\.plot_|plt\.(subplots|figure)\(")
    for cell in code:
        if draws.search(cell.source):
            assert any("image/png" in o.get("data", {}) for o in cell.outputs), cell.source[:60]
