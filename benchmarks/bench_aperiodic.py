"""The paper's sphere on a periodic surface (automatic period) and on an infinite layer.

Run:  python benchmarks/bench_aperiodic.py [--quick] [--speeds 0.01,0.1,1,10]

[ZG]'s example (SLS G0 = 3 MPa, tau = 0.25 s, f = 1; H = 30 mm; R = 2 cm; P = 100 N) through
``jr.rolling_resistance`` with ``jr.Full(grid=jr.AutoGrid(period=...))``: the periodic surface
whose period follows 20 V tau (``period="auto"``) against the infinite layer (``period=None``,
the default). Each configuration runs in a fresh process, so its peak resident memory
(``ru_maxrss``, the process baseline included: ~0.55 GB for jax and jaxroll) is its own;
first call (grid sizing + compile + run) and the median of warm calls are reported, with the
planned memory (``FixedGrid.memory_estimate``) and the value. ``--quick``: 0.01 and 1 m/s.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

CHILD = r"""
import json, resource, statistics, sys, time
import jax
import jaxroll as jr
period = None if sys.argv[1] == "none" else sys.argv[1]
V = float(sys.argv[2])
mat, lay = jr.StandardLinearSolid(3e6, 0.25, 1.0), jr.Layer(0.03)
method = jr.Full(grid=jr.AutoGrid(period=period))
t = time.perf_counter()
resolved = method.resolve(mat, lay, radius=0.02, loads=[100.0], speeds=[V])
need = resolved.grid.memory_estimate(2)
try:
    r = jr.rolling_resistance(mat, lay, radius=0.02, load=100.0, speed=V, method=resolved, throw=False)
    jax.block_until_ready(r.value)
    first = time.perf_counter() - t
    runs = []
    for k in range(3):
        t = time.perf_counter()
        r = jr.rolling_resistance(mat, lay, radius=0.02, load=100.0 + k, speed=V, method=resolved, throw=False)
        jax.block_until_ready(r.value)
        runs.append(time.perf_counter() - t)
    out = dict(value=float(r.value), valid=bool(r.valid), first=first, median=statistics.median(runs))
except ValueError as e:
    out = dict(error=str(e)[:120])
g = resolved.grid
out.update(need_mb=need / 2**20, rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
           grid=f"{float(g.spacing) * 1e3:.3f} mm, window {g.window}" + ("" if g.period is None else
                f", {g.n_cells[0]} x {g.n_cells[1]} cells, terms {g.axis_terms()}"))
print("RESULT " + json.dumps(out))
"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--speeds", default="0.01,0.1,1,10")
    args = ap.parse_args()
    speeds = [0.01, 1.0] if args.quick else [float(v) for v in args.speeds.split(",")]
    env = dict(os.environ)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    print("| V [m/s] | surface | grid | planned memory | peak RSS | first call | warm median | R_r [N] | valid |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = {}
    for V in speeds:
        for period in ("auto", "none"):
            proc = subprocess.run([sys.executable, "-c", CHILD, period, str(V)], env=env, capture_output=True, text=True,
                                  timeout=1200)
            line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
            if not line:
                print(f"| {V:g} | {period} | FAILED: {proc.stderr.strip()[-200:]} |")
                continue
            r = json.loads(line[0][7:])
            rows[(V, period)] = r
            label = "periodic (auto)" if period == "auto" else "infinite layer"
            if "error" in r:
                print(f"| {V:g} | {label} | {r['grid']} | {r['need_mb']:.0f} MB | {r['rss_mb']:.0f} MB | refused: "
                      f"{r['error']} | | | |")
                continue
            print(f"| {V:g} | {label} | {r['grid']} | {r['need_mb']:.0f} MB | {r['rss_mb']:.0f} MB | "
                  f"{r['first']:.2f} s | {r['median'] * 1e3:.0f} ms | {r['value']:.5g} | {r['valid']} |", flush=True)
    from _timing import summary

    for V in speeds:
        a, b = rows.get((V, "auto"), {}), rows.get((V, "none"), {})
        if "median" in a and "median" in b:
            summary(f"bench_aperiodic.py V={V:g}", b["median"], b["first"] - b["median"],
                    "periodic auto grid", f"{a['median'] / b['median']:.1f}x",
                    f"peak RSS {b['rss_mb']:.0f} vs {a['rss_mb']:.0f} MB; R_r {b['value']:.4g} vs {a['value']:.4g} N")


if __name__ == "__main__":
    main()
