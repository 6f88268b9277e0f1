"""What a new user waits for: ``jaxroll reproduce --quick`` and the README's test command, timed
as a new user runs them, stored in benchmarks/numbers.json (section ``first_use``) for the README.

    python benchmarks/first_use.py [--reproduce] [--suite] [--record]

``--reproduce``: ``jaxroll reproduce --quick`` in an empty temporary folder with an empty
compilation cache (a first run). ``--suite``: a clean ``git clone`` of this checkout's HEAD into a
temporary folder, then ``.ci/run`` there (a fresh virtual environment, ``pip install ".[test]"``,
``python -m pytest``: what CI runs); the wall time and pytest's closing counts are recorded. The
load average before and after is stored with each figure: quote them only from an idle machine.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _numbers

ROOT = Path(__file__).resolve().parent.parent


def time_reproduce() -> dict:
    with tempfile.TemporaryDirectory() as work, tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, JAXROLL_COMPILATION_CACHE=cache,
                   PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "jaxroll.apps.cli", "reproduce", "--quick", "--quiet"], cwd=work,
                       env=env, check=True, capture_output=True)
        seconds = time.perf_counter() - t0
    return {"seconds": round(seconds, 1), "load_before": round(load0, 1), "load_after": round(os.getloadavg()[0], 1)}


def pytest_counts(text: str) -> dict:
    """pytest's closing line, e.g. ``842 passed, 4 skipped, 63 deselected in 1236.43s``."""
    lines = [ln for ln in text.splitlines() if re.search(r"\d+ passed", ln) and " in " in ln]
    if not lines:
        raise ValueError("no pytest closing line in the output")
    counts = {k: int(n) for n, k in re.findall(r"(\d+) (passed|failed|skipped|deselected|errors?)", lines[-1])}
    counts["pytest_s"] = float(re.search(r" in ([\d.]+)s", lines[-1]).group(1))
    return counts


def slowest_tests(text: str) -> list:
    """pytest's ``slowest N durations`` block (``--durations=25`` in pyproject's addopts) as
    ``[seconds, phase, test]`` rows, slowest first."""
    block = re.search(r"=+ slowest \d+ durations =+\n(.*?)(?:\n=|\Z)", text, re.S)
    rows = re.findall(r"^([\d.]+)s (setup|call|teardown)\s+(\S.*)$", block.group(1), re.M) if block else []
    return [[float(s), phase, name.strip()] for s, phase, name in rows]


def time_suite() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        clone = Path(tmp) / "clone"
        subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        proc = subprocess.run(["bash", ".ci/run"], cwd=clone, capture_output=True, text=True,
                              env={k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")})
        seconds = time.perf_counter() - t0
    log = Path(tempfile.gettempdir()) / "jaxroll-first-use-ci-run.log"
    log.write_text(proc.stdout + proc.stderr)
    print(f".ci/run's output: {log}", flush=True)
    out = {"ci_run_s": round(seconds, 1), "exit": proc.returncode, "load_before": round(load0, 1),
           "load_after": round(os.getloadavg()[0], 1), **pytest_counts(proc.stdout + proc.stderr),
           "slowest": slowest_tests(proc.stdout + proc.stderr)}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--reproduce", action="store_true")
    ap.add_argument("--suite", action="store_true")
    ap.add_argument("--record", action="store_true", help="store the figures in benchmarks/numbers.json")
    args = ap.parse_args()
    data = dict(_numbers.load().get("first_use", {}))
    data.pop("measured", None)
    if args.reproduce:
        data["reproduce_quick"] = time_reproduce()
        print("reproduce --quick:", data["reproduce_quick"], flush=True)
    if args.suite:
        data["suite"] = time_suite()
        print("suite:", data["suite"], flush=True)
    if args.record:
        _numbers.record("first_use", data)


if __name__ == "__main__":
    main()
