"""The code blocks of README.md, fitting/README.md and the guides' examples run as written.

Every block runs from an empty temporary folder, as after ``pip install .`` in a new project:
the files the examples read are the package's own (``jaxroll.datasets``). Python blocks run
whole in a fresh interpreter. Shell blocks: every ``jaxroll`` command parses with the CLI's own
parser (a misspelt option or a removed one fails here), and the commands that finish in
seconds run for real, after the ``jaxroll datasets`` lines that precede them in the same
document (they copy the example files into the folder); the slow ones (the default full-model
fits, the paper-resolution reproduce, regenerating the synthetic data) run under ``-m slow``, and
the cylinder's default fit also runs always on a third of its data (``-quick``).
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

import jaxroll
from _cases import default_xla_flags, light_xla_flags
from jaxroll.apps.cli import build_parser

REPO = Path(__file__).resolve().parents[1]
DOCS = ["README.md", "fitting/README.md"]
#: guides whose Python blocks run too (their shell lines need files of the reader's own: parsed only)
GUIDES = ["docs/dma.md", "docs/conveyor.md"]


def _blocks(lang):
    out = []
    for doc in DOCS + GUIDES:
        text = (REPO / doc).read_text()
        for i, m in enumerate(re.finditer(rf"```{lang}\n(.*?)```", text, re.S)):
            out.append(pytest.param(m.group(1), id=f"{doc}:{lang}{i}"))
    return out


def _shell_commands(docs=DOCS):
    """(doc, command) for every command line of the shell blocks of ``docs`` (continuations joined)."""
    out = []
    for doc in docs:
        text = (REPO / doc).read_text()
        for block in re.findall(r"```bash\n(.*?)```", text, re.S):
            joined = re.sub(r"\\\n\s*", " ", block)
            for line in joined.splitlines():
                line = line.split(" #")[0].strip()
                if line and not line.startswith("#"):
                    out.append((doc, line))
    return out


#: Commands that take more than ~20 s on 2 cores: run under -m slow.
SLOW = ("--method full", "make_synthetic.py", "reproduce")


def _default_fit(line: str) -> bool:
    """A fit of rolling data alone with the default method (the full model)."""
    return line.startswith("jaxroll fit") and "--method" not in line and "--dma" not in line


def _slow(line: str) -> bool:
    """A command of :data:`SLOW`, or a fit with the default method: the full 3D model (minutes), or
    the cylinder's (60 points with profile-likelihood intervals: 95 s of the default suite's 600 s
    on 2 cores; its reduced copy, :data:`QUICK_EVERY`, runs always)."""
    return _default_fit(line) or any(s in line for s in SLOW)


#: The reduced copy of the cylinder's default fit that the default suite runs: the same command on
#: every third speed of each load of its data file (20 of 60 points; the reduced fit of
#: tests/test_fit_unbiased.py takes the same subset).
QUICK_EVERY = 3


def _thin(path: Path, every: int):
    """Keep every ``every``-th speed of each load (12 speeds per load) of a rolling-data CSV in place."""
    lines = path.read_text().splitlines(keepends=True)
    head = next(i for i, ln in enumerate(lines) if not ln.startswith("#")) + 2  # comments, names, units
    rows = lines[head:]
    loads = [r.split(",")[1] for r in rows]  # (speed, load, ...): one load per block of 12 speeds
    assert len(rows) % 12 == 0 and all(len(set(loads[i:i + 12])) == 1 for i in range(0, len(rows), 12)), path
    path.write_text("".join(lines[:head] + [r for i, r in enumerate(rows) if i % 12 % every == 0]))


def _env(light=True):
    """The test session's environment (its compilation cache, see conftest.py), with XLA's light
    compile flags where ``light`` (tests/_xla.py: an interpreter that runs a few points per
    program is compile-bound; a fit is not, and keeps LLVM's passes) and without a forced host device count that another
    test may have set, importing the jaxroll under test (installed, or this checkout) from any
    folder."""
    env = dict(os.environ)
    env["XLA_FLAGS"] = (light_xla_flags if light else default_xla_flags)(env.get("XLA_FLAGS"))
    env["PYTHONPATH"] = os.pathsep.join([str(Path(jaxroll.__file__).parents[1]), *filter(None, [env.get("PYTHONPATH")])])
    return env


#: Top-level statements (by their first characters) that the default suite leaves out of a block,
#: because they compile for 10-30 s each while the library's own tests check the same call in the
#: test process, whose compiled programs other tests share: the gradient of the full 3D model
#: (tests/test_api.py, tests/test_batched.py), a jitted vmap of the resolved default
#: (tests/test_api.py's full-sphere case, tests/test_defaults.py's traced sweep) and the direct
#: rolling fit of the shipped example (tests/test_fit.py, and the fitting/README.md commands
#: below, which fit the same file). Under ``-m slow`` every block runs whole, as written.
QUICK_SKIP = {"README.md:python0": ("dRr_dH = jax.grad(", "rr = jax.vmap(", "fit = jr.fit_material(",
                                    "print(fit.params")}


def _without(code: str, prefixes) -> str:
    """``code`` without its top-level statements that start with one of ``prefixes`` (each must
    match one: a README edit must not leave a stale entry here)."""
    import ast

    lines = code.splitlines()
    keep, hit = [], set()
    for node in ast.parse(code).body:
        text = "\n".join(lines[node.lineno - 1:node.end_lineno])
        matched = [p for p in prefixes if text.startswith(p)]
        hit.update(matched)
        if not matched:
            keep.append(text)
    assert hit == set(prefixes), f"no statement starts with {set(prefixes) - hit}"
    return "\n".join(keep) + "\n"


def _python_cases():
    out = []
    for param in _blocks("python"):
        (code,), name = param.values, param.id
        if name in QUICK_SKIP:
            out.append(pytest.param(_without(code, QUICK_SKIP[name]), id=f"{name}-quick"))
            out.append(pytest.param(code, id=name, marks=pytest.mark.slow))
        else:
            out.append(param)
    return out


@pytest.mark.parametrize("code", _python_cases())
def test_python_blocks_run(code, tmp_path):
    # the timeout guards against a hang only: on 2 cores shared with other work this block took ~500 s
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=1800,
                          env=_env(), check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]


def test_the_wheel_ships_every_dataset():
    """Every file of jaxroll/datasets/ (data, provenance, licence) matches a package-data pattern
    of pyproject.toml, and ``jr.datasets`` names exactly those files."""
    import fnmatch
    import tomllib

    patterns = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["jaxroll"]
    folder = Path(jaxroll.datasets.__file__).parent
    files = sorted(p.name for p in folder.iterdir() if p.is_file() and p.suffix != ".py")
    assert sorted(jaxroll.datasets.names()) == files
    for name in files:
        assert any(fnmatch.fnmatch(f"datasets/{name}", pat) for pat in patterns), name
        assert jaxroll.datasets.path(name).is_file()
    assert "py.typed" in patterns and (folder.parent / "py.typed").is_file()


def test_every_shell_command_parses():
    parser = build_parser()
    seen = 0
    for doc, line in _shell_commands(DOCS + GUIDES):
        for part in line.split("&&"):
            words = shlex.split(part)
            if words and words[0] == "jaxroll":
                parser.parse_args(words[1:])  # exits (SystemExit) on an unknown or malformed option
                seen += 1
    assert seen >= 5  # README: reproduce; fitting/README.md: four fits


def _runnable():
    """(setup, line) for every runnable command; setup: the ``jaxroll datasets`` lines before it in
    its document."""
    out, setup = [], {}
    for doc, line in _shell_commands():
        if not (line.startswith("jaxroll ") or line.startswith("python fitting/")):
            continue  # venv / pip lines: CI itself runs those
        if line.startswith("jaxroll datasets"):
            setup.setdefault(doc, []).append(line)
        marks = [pytest.mark.slow] if _slow(line) else []
        out.append(pytest.param(tuple(setup.get(doc, [])), line, False, marks=marks, id=f"{doc}:{line[:60]}"))
        if _default_fit(line) and "--geometry cylinder" in line:
            out.append(pytest.param(tuple(setup.get(doc, [])), line, True, id=f"{doc}:{line[:60]}-quick"))
    return out


def _argv(line, tmp_path):
    words = shlex.split(line)
    if words[0] == "jaxroll":
        return [sys.executable, "-m", "jaxroll.apps.cli", *words[1:]]
    # python fitting/...: a script of the clone; --out keeps the shipped data untouched
    return [sys.executable, str(REPO / words[1]), *words[2:], "--out", str(tmp_path)]


@pytest.mark.parametrize(("setup", "line", "quick"), _runnable())
def test_shell_commands_run(setup, line, quick, tmp_path):
    for step in (*[s for s in setup if s != line], line):
        if quick and step == line:  # the reduced copy: the command's data file thinned
            _thin(tmp_path / shlex.split(line)[2], QUICK_EVERY)
        proc = subprocess.run(_argv(step, tmp_path), cwd=tmp_path, capture_output=True, text=True, timeout=1800,
                              env=_env(light=not step.startswith("jaxroll fit")), check=False)
        assert proc.returncode == 0, f"{step}: {proc.stderr[-3000:]}"
