"""What the default test suite costs, per file and per test, in CPU seconds (compile + run).

    python benchmarks/suite_cost.py [--record] [--from PREFIX] [-- PYTEST_ARGS...]

Runs ``python -m pytest`` (the README's test command: pyproject's addopts, pytest-xdist workers)
with ``JAXROLL_TEST_CPU_LOG`` set, so that tests/conftest.py logs every test's CPU time (user +
system of the test process and of the subprocesses it waited for) and wall time. On a machine
shared with other work the CPU time is the steady figure; the wall time is quoted with the load
average. ``--from PREFIX`` summarises the logs of an earlier run instead of running the suite.
``--record`` stores the totals, the per-file table and the 25 slowest tests in
benchmarks/numbers.json (section ``suite_cost``), which ``render_docs.py`` writes into
benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import glob
import os
import re
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import _numbers

ROOT = Path(__file__).resolve().parent.parent


def read_logs(prefix: str) -> tuple[list, float]:
    """(test nodeid, CPU s, wall s) rows of every worker's log, and the processes' total CPU s."""
    tests, total = [], 0.0
    for path in sorted(glob.glob(prefix + ".*")):
        if not re.fullmatch(r"gw\d+|main", path[len(prefix) + 1:]):
            continue  # PREFIX.<worker> only
        for line in Path(path).read_text().splitlines():
            name, cpu, wall, _load = line.split("\t")
            if name == "<process total>":
                total += float(cpu)
            else:
                tests.append((name, float(cpu), float(wall)))
    return tests, total


def summarise(tests: list, total: float) -> dict:
    files = defaultdict(lambda: [0, 0.0, 0.0])
    for name, cpu, wall in tests:
        f = files[name.split("::")[0]]
        f[0] += 1
        f[1] += cpu
        f[2] += wall
    per_file = sorted(([k, n, round(c, 1), round(w, 1)] for k, (n, c, w) in files.items()), key=lambda r: -r[2])
    slowest = sorted(tests, key=lambda t: -t[1])[:25]
    return {"tests": len(tests), "tests_cpu_s": round(sum(t[1] for t in tests), 1),
            "process_cpu_s": round(total, 1), "per_file": per_file,
            "slowest": [[n, round(c, 1), round(w, 1)] for n, c, w in slowest]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--record", action="store_true")
    ap.add_argument("--from", dest="prefix", help="summarise these logs (PREFIX.<worker>) instead of running")
    ap.add_argument("pytest_args", nargs="*")
    args = ap.parse_args()
    data = {}
    prefix = args.prefix
    if prefix is None:
        prefix = os.path.join(tempfile.mkdtemp(prefix="jaxroll-suite-cost-"), "cpu")
        env = dict(os.environ, JAXROLL_TEST_CPU_LOG=prefix,
                   PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "pytest", "-q", *args.pytest_args], cwd=ROOT, env=env,
                              capture_output=True, text=True)
        out = proc.stdout + proc.stderr
        (Path(prefix).parent / "pytest.log").write_text(out)
        closing = [ln for ln in out.splitlines() if re.search(r"\d+ (passed|failed)", ln) and " in " in ln]
        data = {"wall_s": round(time.perf_counter() - t0, 1), "exit": proc.returncode,
                "load_before": round(load0, 1), "load_after": round(os.getloadavg()[0], 1),
                "pytest": closing[-1].strip("= ") if closing else ""}
        print(f"logs: {prefix}.*, pytest output: {Path(prefix).parent / 'pytest.log'}")
    data.update(summarise(*read_logs(prefix)))
    for name, n, cpu, wall in data["per_file"]:
        print(f"{cpu:8.1f} s CPU {wall:8.1f} s wall {n:4d} tests  {name}")
    print(f"tests {data['tests']}: {data['tests_cpu_s']} s CPU in tests, {data['process_cpu_s']} s CPU in the "
          f"test processes; {data.get('pytest', '')}")
    for name, cpu, wall in data["slowest"]:
        print(f"{cpu:7.1f} s CPU {wall:7.1f} s wall  {name}")
    if args.record:
        _numbers.record("suite_cost", data)


if __name__ == "__main__":
    main()
