"""The code blocks of README.md and fitting/README.md run as written.

Python blocks run whole in a fresh interpreter from the repository root (the files they read
are the shipped examples). Shell blocks: every ``jaxroll`` command parses with the CLI's own
parser (a misspelt option or a removed one fails here), and the commands that finish in
seconds run for real; the slow ones (the full-model fit, the paper-resolution reproduce,
regenerating the synthetic data) run under ``-m slow``.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from jaxroll.apps.cli import build_parser

REPO = Path(__file__).resolve().parents[1]
DOCS = ["README.md", "fitting/README.md"]


def _blocks(lang):
    out = []
    for doc in DOCS:
        text = (REPO / doc).read_text()
        for i, m in enumerate(re.finditer(rf"```{lang}\n(.*?)```", text, re.S)):
            out.append(pytest.param(m.group(1), id=f"{doc}:{lang}{i}"))
    return out


def _shell_commands():
    """(doc, command) for every command line of the shell blocks (continuations joined)."""
    out = []
    for doc in DOCS:
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


def _env():
    """The test session's environment (its compile flags and cache, see conftest.py) without a
    forced host device count that another test may have set."""
    env = dict(os.environ)
    env["XLA_FLAGS"] = " ".join(f for f in env.get("XLA_FLAGS", "").split() if "device_count" not in f)
    return env


@pytest.mark.parametrize("code", _blocks("python"))
def test_python_blocks_run(code):
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=600,
                          env=_env(), check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]


def test_every_shell_command_parses():
    parser = build_parser()
    seen = 0
    for doc, line in _shell_commands():
        for part in line.split("&&"):
            words = shlex.split(part)
            if words and words[0] == "jaxroll":
                parser.parse_args(words[1:])  # exits (SystemExit) on an unknown or malformed option
                seen += 1
    assert seen >= 4  # README: reproduce; fitting/README.md: three fits


def _runnable():
    out = []
    for doc, line in _shell_commands():
        if not (line.startswith("jaxroll ") or line.startswith("python fitting/")):
            continue  # venv / pip lines: CI itself runs those
        marks = [pytest.mark.slow] if any(s in line for s in SLOW) else []
        out.append(pytest.param(line, marks=marks, id=f"{doc}:{line[:60]}"))
    return out


@pytest.mark.parametrize("line", _runnable())
def test_shell_commands_run(line, tmp_path):
    words = shlex.split(line)
    if words[0] == "jaxroll":
        words = [sys.executable, "-m", "jaxroll.apps.cli", *words[1:]]
    else:  # python fitting/...: would rewrite the shipped data; run a copy of the script elsewhere
        words = [sys.executable, str(REPO / words[1]), *words[2:], "--out", str(tmp_path)]
    # --out paths of the examples land in tmp_path; data paths are relative to the repository
    words = [str(tmp_path / w) if i > 0 and words[i - 1] == "--out" and not w.startswith("/") else w
             for i, w in enumerate(words)]
    proc = subprocess.run(words, cwd=REPO, capture_output=True, text=True, timeout=1800, env=_env(), check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
