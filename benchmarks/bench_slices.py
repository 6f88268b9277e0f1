"""Benchmark of the sphere-from-cylinder-slices algorithms PD, PP, SP (``jr.Slices``, [ZG] sec. 3).

Run:  python benchmarks/bench_slices.py [--quick] [--H 0.005] [--linear-solver interval|dense|gmres]
      [--repeat 5] [--no-3d]

Reports (CPU, float64), compile time apart from run time (ahead of time), medians of repeated runs:
* single point of each algorithm through ``jr.rolling_resistance`` (R = 2 cm, G0 = 3 MPa,
  tau = 0.25 s, f = 1, H = 5 mm, P = 100 N, V = 0.01 m/s), 21 slices, the paper's period
  L = 0.2 m with 2^10 cells (``jr.FixedGrid(0.2 / 1024, 160, period=0.2)``; dx = 0.195 mm, the
  paper used 0.25 mm);
* the reference case, 23 log-spaced speeds 1e-4..1 m/s x 15 loads 10..150 N, through
  ``jr.rolling_resistance_grid`` (compliance and Levinson tables built once per speed, loads
  vmapped; ``--quick``: 5 x 3 points, 11 slices, time scaled to 345 points);
* the full 3D model on the same points (``jr.Full`` on ``jr.FixedGrid(2.5e-4, window,
  period=0.2, n_terms=500)``, window >= 41; ``--quick``: 0.5 mm, 250 terms), one timed run,
  and the speed factors 3D / algorithm (paper: PD 153, PP 161, SP 30);
* the mean relative error of each algorithm against the 3D model on these points.
Paper ([ZG] Table 1): 21 / 20 / 107 s per reference case. The machine load
(``os.getloadavg``) is printed: on a shared machine the figures are noisy, compare medians.
"""

from __future__ import annotations

import argparse
import math
import os

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from _timing import aot, summary

G0, TAU, F, R = 3e6, 0.25, 1.0, 0.02
PERIOD, N_CELLS, WINDOW = 0.2, 2**10, 160
PAPER_S = {"PD": 21.0, "PP": 20.0, "SP": 107.0}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="5 x 3 points (time scaled to 345), 11 slices, coarse 3D")
    ap.add_argument("--H", type=float, default=5e-3, help="layer thickness [m]")
    ap.add_argument("--repeat", type=int, default=5)
    solvers = {c.__name__.lower(): c for c in jr.engines.slices.LINEAR_SOLVERS}
    ap.add_argument("--linear-solver", default="interval", choices=list(solvers))
    ap.add_argument("--no-3d", action="store_true", help="skip the full 3D model")
    args = ap.parse_args()
    speeds = jnp.asarray(np.geomspace(1e-4, 1.0, 5 if args.quick else 23))
    loads = jnp.asarray(np.linspace(10.0, 150.0, 3 if args.quick else 15))
    n_slices = 11 if args.quick else 21
    repeat = 3 if args.quick else args.repeat
    n = speeds.size * loads.size
    scale = 345.0 / n
    mat = jr.StandardLinearSolid(G0, TAU, F)
    grid = jr.FixedGrid(PERIOD / N_CELLS, WINDOW, period=PERIOD)
    print(f"jax {jax.__version__}, {jax.devices()[0].platform}, cores {os.cpu_count()}, "
          f"load average {os.getloadavg()[0]:.1f} (shared machine); H = {args.H * 1e3:g} mm; linear solver "
          f"{args.linear_solver}; {n_slices} slices; {n} points (x{scale:.0f} to the 345-point reference); "
          f"medians of {repeat} runs")
    cmd = "bench_slices.py" + (" --quick" if args.quick else "")
    results = {}
    for alg in jr.engines.slices.ALGORITHMS:
        method = jr.Slices(algorithm=alg, n_slices=n_slices, grid=grid, linear_solver=solvers[args.linear_solver]())

        def single(H, P, V, method=method):
            return jr.rolling_resistance(mat, jr.Layer(H), radius=R, load=P, speed=V, method=method,
                                         throw=False).value

        def table(H, loads, speeds, method=method):
            out = jr.rolling_resistance_grid(mat, jr.Layer(H), radius=R, loads=loads, speeds=speeds, method=method)
            return out.value, out.result, out.solution.iterations

        c1, t1, out1, _ = aot(single, args.H, 100.0, 0.01, repeat=repeat)
        c2, t2, (v, st, it), _ = aot(table, args.H, loads, speeds, repeat=repeat)
        st = np.asarray(st)
        results[alg] = (t2 * scale, np.asarray(v))
        print(f"{alg}: single point {t1 * 1e3:.1f} ms (compile {c1:.1f} s), R_r = {float(out1):.4g} N; "
              f"reference case {t2 * scale:.3f} s (measured {t2:.3f} s for {n}; compile {c2:.1f} s), "
              f"{int(np.sum(st == 0))}/{n} valid, mean iterations {float(np.mean(np.asarray(it))):.1f}", flush=True)
        summary(f"{cmd} ({alg}, reference case)", t2 * scale, c2, f"paper {alg} {PAPER_S[alg]:g} s",
                f"{PAPER_S[alg] / (t2 * scale):.0f}x", f"{speeds.size}x{loads.size} points scaled x{scale:.0f}, "
                f"{n_slices} slices, 1024 cells, H = {args.H * 1e3:g} mm")
    if args.no_3d:
        return
    spacing, n_terms = (5e-4, 250) if args.quick else (2.5e-4, 500)
    r_max = float(jr.engines.contact_size.estimate_contact_size(mat, jr.Layer(args.H), R, float(loads.max())))
    window = max(41 if not args.quick else 21, 2 * math.ceil(1.15 * r_max / spacing) + 1)
    full = jr.Full(grid=jr.FixedGrid(spacing, window, period=PERIOD, n_terms=n_terms))

    def table3(H, loads, speeds):
        out = jr.rolling_resistance_grid(mat, jr.Layer(H), radius=R, loads=loads, speeds=speeds, method=full)
        return out.value, out.result

    c3, t3, (v3, st3), _ = aot(table3, args.H, loads, speeds, repeat=1)
    ref_time = t3 * scale
    st3 = np.asarray(st3)
    print(f"3D (a = {spacing * 1e3:g} mm, window {window}, {n_terms} terms): reference case "
          f"{ref_time:.1f} s (measured {t3:.1f} s for {n}; compile {c3:.1f} s), "
          f"{int(np.sum(st3 == 0))}/{n} valid (codes {sorted(set(st3.ravel().tolist()))}); "
          f"load average {os.getloadavg()[0]:.1f}")
    v3 = np.asarray(v3)
    for alg, (t, v) in results.items():
        err = v / v3 - 1.0
        print(f"{alg}: speed factor {ref_time / t:.0f} (paper: PD 153, PP 161, SP 30); mean relative "
              f"error vs 3D {np.mean(err):+.4f} (mean |err| {np.mean(np.abs(err)):.4f})")


if __name__ == "__main__":
    main()
