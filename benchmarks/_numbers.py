"""The machine-readable file of the numbers the docs quote: ``benchmarks/numbers.json``.

A benchmark run with ``--record`` stores its section here (with the date, the machine, the load
average and the commit it measured); ``benchmarks/render_docs.py`` writes the tables and sentences
of README.md and benchmarks/README.md from this file, and ``tests/test_docs_numbers.py`` fails
when the docs and this file disagree. Nothing in the docs is typed by hand where this file has it.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
from pathlib import Path

NUMBERS = Path(__file__).resolve().parent / "numbers.json"


def machine() -> dict:
    """Where and when a measurement ran: CPU model, cores, load average, jax and the commit."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=NUMBERS.parent).stdout.strip()
        # a tracked file changed since that commit (numbers.json itself aside): not what it measured
        changed = subprocess.run(["git", "status", "--porcelain", "-uno", "--", ".", ":!benchmarks/numbers.json"],
                                 capture_output=True, text=True, cwd=NUMBERS.parent.parent).stdout.strip()
        commit += "+dirty" if commit and changed else ""
    except OSError:
        commit = ""
    # a copy of the tree without its git folder (a remote GPU machine): the commit it was copied at
    commit = commit or os.environ.get("JAXROLL_COMMIT", "")
    import jax

    return {
        "date": datetime.date.today().isoformat(),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_average": [round(x, 1) for x in os.getloadavg()],
        "device": str(jax.devices()[0].device_kind),
        "jax": jax.__version__,
        "commit": commit,
    }


def load() -> dict:
    return json.loads(NUMBERS.read_text()) if NUMBERS.exists() else {}


def record(section: str, data: dict) -> None:
    """Store ``data`` (with :func:`machine`) as ``section`` of numbers.json, keeping the others."""
    numbers = load()
    numbers[section] = {"measured": machine(), **data}
    NUMBERS.write_text(json.dumps(numbers, indent=1, sort_keys=True) + "\n")
