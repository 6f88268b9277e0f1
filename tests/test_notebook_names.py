"""Every notebook's code names only what jaxroll has: a check that needs no kernel.

The default suite executes the quickstart notebook; the others run whole under ``-m slow``
(tests/test_notebooks.py: each starts a fresh kernel that compiles everything). This check runs
for all of them in milliseconds: every code cell compiles, every ``from jaxroll... import name``
imports, and every attribute chain rooted at an imported jaxroll module resolves as far as it
runs through modules and its first non-module name (``jr.conveyor.trough_loads``, ``jr.Full``;
the fields of an object, ``jr.RESULTS.successful``, are the object's own business). A renamed
or removed function, class or module that a notebook still uses fails here, in the default
suite, before the slow run would.
"""

import ast
import importlib
import json
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


def _code(path):
    cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
    return ["".join(c["source"]) for c in cells if c["cell_type"] == "code"]


def _chain(node):
    """``jr.a.b`` -> ("jr", ["a", "b"]); None if the chain is not rooted at a name."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    return (node.id, parts[::-1]) if isinstance(node, ast.Name) else None


def _check(tree, modules):
    """Resolve imports of jaxroll and attribute chains on the names bound to its modules."""
    missing = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "jaxroll":
                    modules[alias.asname or alias.name.split(".")[0]] = importlib.import_module(
                        alias.name if alias.asname else "jaxroll")
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "jaxroll":
            module = importlib.import_module(node.module)
            for alias in node.names:
                if not hasattr(module, alias.name):
                    try:
                        importlib.import_module(f"{node.module}.{alias.name}")
                    except ImportError:
                        missing.append(f"{node.module}.{alias.name}")
                        continue
                obj = getattr(module, alias.name)
                if isinstance(obj, type(importlib)):
                    modules[alias.asname or alias.name] = obj
    for node in ast.walk(tree):
        chain = _chain(node) if isinstance(node, ast.Attribute) else None
        if chain and chain[0] in modules:
            obj = modules[chain[0]]
            for i, name in enumerate(chain[1]):
                if not hasattr(obj, name):
                    missing.append(".".join([chain[0], *chain[1][:i + 1]]))
                    break
                obj = getattr(obj, name)
                if not isinstance(obj, type(importlib)) and i < len(chain[1]) - 1:
                    break  # an attribute of an object (a method, a field): the object's own business
    return missing


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_code_names_only_what_jaxroll_has(path):
    modules, missing = {}, []
    cells = _code(path)
    assert cells, path.name
    for i, source in enumerate(cells):
        tree = compile(source, f"{path.name}[{i}]", "exec", ast.PyCF_ONLY_AST)  # a syntax error fails here
        missing += [f"cell {i}: {name}" for name in _check(tree, modules)]
    assert "jr" in modules or any(m.__name__.startswith("jaxroll") for m in modules.values()), path.name
    assert not missing, f"{path.name} uses names jaxroll does not have: {missing}"


def test_the_check_catches_a_missing_name():
    tree = ast.parse("import jaxroll as jr\nfrom jaxroll import conveyor\njr.Full()\njr.conveyor.no_such_thing\n"
                     "conveyor.trough_loads\njr.NoSuchClass(1)")
    assert _check(tree, {}) == ["jr.conveyor.no_such_thing", "jr.NoSuchClass"]
