"""Loss-dominated materials (SLS f = 30..1000, tan delta up to 15.8) against the full model.

    python benchmarks/loss_dominated.py fine
    python benchmarks/loss_dominated.py approx [--seed 77] [--cases 8] [--start 0]

``fine``: the default full 3D model against ``AutoGrid(cells_per_radius=24 | 32)`` (SLS G0 = 3
MPa, tau = 0.25 s, f = 100, 1000; R = 2 cm, 100 N; 30 mm layer and half-space; 10-300 mm/s): the
difference, each truncation, the finer solve's active-set steps and wall time (a compile where its
grid's shape is new), and whether the difference lies within the sum of the two truncations
(benchmarks/LOG.md, 2026-11-29, "the 3D preconditioner inverts the layer's symbol").

``approx``: seeded random tables as ``tests/test_approximation.py``'s envelope sweep, with SLS
f log-uniform in 30..1000 (G0 1-10 MPa, tau 0.01-1 s, 11 speeds 1e-4..10 m/s x 2 loads, R = 2 cm,
half-space or a layer of 0.3..100 relaxed contact radii): per case and method (direct with the
three contact moduli, PD, SP), the points valid and the points valid but off the full model by more
than 10 % + its truncation + 2 % ("BAD", the allowance of the test).
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the seeded draws

import jaxroll as jr  # noqa: E402
from _cases import draw_loss_dominated  # noqa: E402

METHODS = {"direct-relaxed": jr.Direct(), "direct-dynamic": jr.Direct(modulus="dynamic"),
           "direct-glassy": jr.Direct(modulus="glassy"), "PD": jr.Slices("PD"), "SP": jr.Slices("SP")}
SLACK = 0.12


def _grid(material, layer, method, speeds, loads, radius):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.ValidityWarning)
        return jr.rolling_resistance_grid(material, layer, radius=radius, loads=np.asarray(loads, float),
                                          speeds=np.asarray(speeds, float), method=method)


def fine():
    G, R, P = 3e6, 0.02, 100.0
    print("| f | layer | V | default R (t) | 24 cells: d (t), steps, s | 32 cells: d (t), steps, s |")
    print("|---|---|---|---|---|---|")
    worst = 0.0
    for f in (100.0, 1000.0):
        for H in (0.03, np.inf):
            for V in (0.01, 0.03, 0.1, 0.3):
                mat, layer = jr.StandardLinearSolid(G, 0.25, f), jr.Layer(H)
                row = {}
                for c in (None, 24, 32):
                    m = jr.Full() if c is None else jr.Full(grid=jr.AutoGrid(cells_per_radius=c))
                    t = time.perf_counter()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", jr.ValidityWarning)
                        r = jr.rolling_resistance(mat, layer, radius=R, load=P, speed=V, method=m, throw=False)
                    row[c] = (float(r.value), float(r.truncation), jr.RESULTS.names[int(r.result)],
                              int(r.solution.iterations), time.perf_counter() - t)
                v0, t0, code0 = row[None][:3]
                cells = []
                for c in (24, 32):
                    v, t, code, it, s = row[c]
                    d = v0 / v - 1
                    worst = max(worst, abs(d) / (t0 + t))
                    flag = ("" if code == "successful" else code + " ") + ("" if abs(d) <= t0 + t else "OUT ")
                    cells.append(f"{d:+.2%} ({t:.2%}) {flag}{it} steps, {s:.1f} s")
                layer_name = "half-space" if H == np.inf else "30 mm"
                print(f"| {f:g} | {layer_name} | {V * 1000:g} mm/s | {v0:.4g} N ({t0:.2%}) "
                      f"{'' if code0 == 'successful' else code0}| {cells[0]} | {cells[1]} |", flush=True)
    print(f"worst |difference| / (sum of the truncations): {worst:.2f}")


def approx(seed, n_cases, start=0):
    rng = np.random.default_rng(seed)
    totals = {k: [0, 0] for k in METHODS}
    for case in range(n_cases):
        mat, layer, R, loads, speeds, label = draw_loss_dominated(rng)
        if case < start:  # drawn (the same cases for every start), not run
            continue
        t = time.perf_counter()
        full = _grid(mat, layer, jr.Full(), speeds, loads, R)
        ref_ok = np.asarray(full.valid)
        line = [f"full {ref_ok.sum()}/{ref_ok.size} valid ({time.perf_counter() - t:.0f} s)"]
        for name, m in METHODS.items():
            res = _grid(mat, layer, m, speeds, loads, R)
            err = (np.asarray(res.value) / np.asarray(full.value) - 1)[ref_ok]
            ok = np.asarray(res.valid)[ref_ok]
            bad = ok & (np.abs(err) > SLACK + np.asarray(full.truncation)[ref_ok])
            totals[name][0] += int(ok.sum())
            totals[name][1] += int(bad.sum())
            line.append(f"{name} {ok.sum()} valid, {bad.sum()} BAD" + (f" {err[bad].round(3)}" if bad.any() else ""))
        print(f"case {case} {label} H={float(layer.H):.3g} loads={loads.round(1)}: "
              + "; ".join(line), flush=True)
    print("valid / BAD per method:", totals)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("fine")
    a = sub.add_parser("approx")
    a.add_argument("--seed", type=int, default=77)
    a.add_argument("--cases", type=int, default=8)
    a.add_argument("--start", type=int, default=0, help="run cases start..cases-1 only (the same draws)")
    args = ap.parse_args(argv)
    if args.command == "fine":
        fine()
    else:
        approx(args.seed, args.cases, args.start)


if __name__ == "__main__":
    main()
