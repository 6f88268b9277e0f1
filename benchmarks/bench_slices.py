"""Benchmark of the sphere-from-cylinder-slices algorithms PD, PP, SP (jaxroll.slices, [ZG] sec. 3).

Run:  python benchmarks/bench_slices.py [--quick] [--H 0.005] [--linear-solver interval|dense|gmres]
      [--repeat 5] [--no-3d]

Reports (CPU, float64), compile time apart from run time, medians of repeated runs:
* single run of each algorithm (R = 2 cm, G0 = 3 MPa, tau = 0.25 s, f = 1, H = 5 mm,
  P = 100 N, V = 0.01 m/s), 21 slices, the paper's period L = 0.2 m with 2^10 cells
  (dx = 0.195 mm; the paper used 0.25 mm);
* the reference case, 23 log-spaced speeds 1e-4..1 m/s x 15 loads 10..150 N, with
  :func:`jaxroll.slices.rolling_resistance_slices_grid` (compliance and Levinson tables built
  once per speed, loads vmapped; ``--quick``: 5 x 3 cases, time scaled to 345 cases);
* the full 3D model on the same reference case (:func:`jaxroll.sphere3d.rolling_resistance_sweep`
  at the paper's resolution: L = 0.2 m, a = 0.25 mm, 500 terms, window >= 41; ``--quick``:
  a = 0.5 mm, 250 terms, 5 x 3 cases), one timed run, and the speed factors 3D / algorithm
  (paper: PD 153, PP 161, SP 30);
* the mean relative error of each algorithm against the 3D model on these cases.
Targets ([ZG] Table 1 is 21 / 20 / 107 s): PD and PP <= 0.5 s, SP <= 1 s per reference case on
2 cores. The machine load (``os.getloadavg``) is printed: on a shared machine the figures are
noisy, compare medians.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from jaxroll import slices as sl

G0, TAU, F, R = 3e6, 0.25, 1.0, 0.02
PERIOD, N_CELLS = 0.2, 2**10


def timed(fn, *args, repeat=3):
    """(compile seconds, median run seconds, all runs, output) of a jitted function."""
    t = time.perf_counter()
    compiled = fn.lower(*args).compile()
    comp = time.perf_counter() - t
    runs, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = jax.block_until_ready(compiled(*args))
        runs.append(time.perf_counter() - t)
    return comp, statistics.median(runs), runs, out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="5 x 3 cases (time scaled to 345), coarse 3D")
    ap.add_argument("--H", type=float, default=5e-3, help="layer thickness [m]")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--linear-solver", default="interval", choices=list(sl.LINEAR_SOLVERS))
    ap.add_argument("--no-3d", action="store_true", help="skip the full 3D model")
    args = ap.parse_args()
    speeds = np.geomspace(1e-4, 1.0, 5 if args.quick else 23)
    loads = np.linspace(10.0, 150.0, 3 if args.quick else 15)
    n = speeds.size * loads.size
    scale = 345.0 / n
    mat = jr.StandardLinearSolid(G0, TAU, F)
    layer = jr.Layer(args.H)
    print(f"jax {jax.__version__}, {jax.devices()[0].platform}, cores {os.cpu_count()}, "
          f"load average {os.getloadavg()[0]:.1f}; H = {args.H * 1e3:g} mm; linear solver "
          f"{args.linear_solver}; {n} cases (x{scale:.0f} to the 345-case reference); medians of "
          f"{args.repeat} runs")
    results = {}
    for alg in sl.ALGORITHMS:
        single = jax.jit(lambda V, P, alg=alg: sl.solve_slices(
            mat, layer, R, P, V, algorithm=alg, throw=False, linear_solver=args.linear_solver,
            period=PERIOD, n_cells=N_CELLS, window_cells=160).resistance)
        c1, t1, _, out1 = timed(single, 0.01, 100.0, repeat=args.repeat)
        grid = jax.jit(lambda alg=alg: sl.rolling_resistance_slices_grid(
            mat, layer, R, loads, speeds, algorithm=alg, period=PERIOD, n_cells=N_CELLS,
            linear_solver=args.linear_solver))
        c2, t2, runs, out = timed(grid, repeat=args.repeat)
        st = np.asarray(out["status"])
        results[alg] = (t2 * scale, np.asarray(out["value"]))
        print(f"{alg}: single run {t1 * 1e3:.1f} ms (compile {c1:.1f} s), R_r = {float(out1):.4g} N; "
              f"reference case {t2 * scale:.3f} s (measured {t2:.3f} s for {n}, runs "
              f"{[round(r, 3) for r in runs]}; compile {c2:.1f} s), {int(np.sum(st == 0))}/{n} converged, "
              f"mean Newton it. {float(np.mean(np.asarray(out['iterations']))):.1f}")
    if args.no_3d:
        return
    from jaxroll import sphere3d

    spacing, n_terms = (5e-4, 250) if args.quick else (2.5e-4, 500)
    r_max = float(sphere3d.estimate_contact_radius(mat, layer, R, float(loads.max())))
    window = max(41, 2 * math.ceil(1.15 * r_max / spacing) + 1)
    f3 = jax.jit(lambda: sphere3d.rolling_resistance_sweep(
        mat, layer, R, jnp.asarray(loads), jnp.asarray(speeds), period=PERIOD, spacing=spacing,
        window=window, n_terms=n_terms))
    c3, t3, _, out3 = timed(f3, repeat=1)
    ref_time = t3 * scale
    st3 = np.asarray(out3["status"])
    print(f"3D (a = {spacing * 1e3:g} mm, window {window}, {n_terms} terms): reference case "
          f"{ref_time:.1f} s (measured {t3:.1f} s for {n}; compile {c3:.1f} s), "
          f"{int(np.sum(st3 == 0))}/{n} converged; load average {os.getloadavg()[0]:.1f}")
    v3 = np.asarray(out3["value"])
    for alg, (t, v) in results.items():
        err = v / v3 - 1.0
        print(f"{alg}: speed factor {ref_time / t:.0f} (paper: PD 153, PP 161, SP 30); mean relative "
              f"error vs 3D {np.mean(err):+.4f} (mean |err| {np.mean(np.abs(err)):.4f})")


if __name__ == "__main__":
    main()
