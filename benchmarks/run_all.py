"""Run every benchmark's reduced-size configuration in turn and print one markdown table.

    python benchmarks/run_all.py [--only bench_direct,bench_fit] [--timeout 900] [--reference]

Each script prints ``SUMMARY {json}`` lines (``_timing.summary``: command, median, compile,
baseline, ratio, note); this collects them into one table, with a row per script that failed or
printed none. Run it on an idle machine for figures to quote: on a shared machine the medians are
noisy. Takes a few minutes on 2 CPU cores.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: (script, reduced-size arguments)
QUICK = [
    ("bench_layer.py", ["--quick"]),
    ("bench_direct.py", ["--quick"]),
    ("bench_fit.py", ["--quick"]),
    ("bench_sphere3d.py", ["--quick"]),
    ("bench_slices.py", ["--quick"]),
    ("bench_cylinder.py", ["--quick"]),
    ("bench_sweep.py", ["--quick", "--no-strategies"]),
    ("direct_vs_full.py", ["--quick", "--cases", "30mm"]),
    ("default_method.py", ["--quick"]),
    ("bench_defaults.py", ["--quick"]),
    ("bench_batched.py", ["--quick"]),
    ("multihost_example.py", ["--quick", "--launch-local", "2", "--model", "direct"]),
    ("bench_tamaas.py", ["--quick"]),  # needs the optional peer tamaas (pip install ".[peer]")
]

#: Full-size rows added by ``--reference``: the paper's reference case (23 x 15) in the full 3D
#: model at H = 2, 5, 30 mm on an infinite layer and on the paper's 0.2 m period (gradient at
#: 30 mm), the paper's sphere at 0.01..10 m/s on both surfaces, and tamaas at periods up to 0.4 m.
REFERENCE = [
    *[("bench_sphere3d.py", ["--H", H, "--period", p, "--repeat", "5"] + (["--grad"] if H == "0.03" and p == "none"
                                                                         else []))
      for H in ("0.002", "0.005", "0.03") for p in ("none", "0.2")],
    ("bench_aperiodic.py", []),
    ("bench_tamaas.py", []),  # periods 0.05..0.4 m (needs the optional peer tamaas)
]


def _fmt(x):
    if not isinstance(x, (int, float)) or x != x:
        return "" if x in (None, "") or x != x else str(x)
    return f"{x * 1e3:.1f} ms" if x < 1 else f"{x:.2f} s"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", default="", help="comma-separated script names (without .py)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per script")
    ap.add_argument("--reference", action="store_true", help="add the full-size reference-case rows (~10 min)")
    args = ap.parse_args()
    only = {s if s.endswith(".py") else s + ".py" for s in args.only.split(",") if s}
    env = dict(os.environ)
    root = str(HERE.parent)
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    rows = []
    for script, extra in QUICK + (REFERENCE if args.reference else []):
        if only and script not in only:
            continue
        cmd = [sys.executable, str(HERE / script), *extra]
        label = " ".join([script, *extra])
        print(f"running {label} ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, cwd=HERE, env=env, capture_output=True, text=True, timeout=args.timeout)
        except subprocess.TimeoutExpired:
            rows.append(dict(command=label, note=f"timed out after {args.timeout:.0f} s"))
            continue
        wall = time.perf_counter() - t0
        found = [json.loads(ln[len("SUMMARY "):]) for ln in proc.stdout.splitlines() if ln.startswith("SUMMARY ")]
        if proc.returncode:
            rows.append(dict(command=label, note=f"FAILED (exit {proc.returncode}): {proc.stderr.strip()[-300:]}"))
        elif not found:
            last = (proc.stdout.strip().splitlines() or [""])[-1]
            rows.append(dict(command=label, note=f"ran in {wall:.0f} s wall; {last[:200]}"))
        rows += found
        print(f"  done in {wall:.0f} s wall", file=sys.stderr, flush=True)
    import jax

    print(f"Reduced-size runs, {datetime.date.today()}, jax {jax.__version__}, {platform.machine()} CPU x "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end\n")
    print("| command | median | compile | baseline | ratio | note |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| `{r['command']}` | {_fmt(r.get('median_s'))} | {_fmt(r.get('compile_s'))} | {r.get('baseline', '')} | "
              f"{r.get('ratio', '')} | {r.get('note', '')} |")
    return int(any("FAILED" in r.get("note", "") or "timed out" in r.get("note", "") for r in rows))


if __name__ == "__main__":
    sys.exit(main())
