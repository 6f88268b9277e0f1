"""Benchmark of the full 3D rolling sphere (jaxroll.sphere3d): the paper's reference case.

Run:  python benchmarks/bench_sphere3d.py [--quick] [--H 0.03]

Reference case ([ZG] Table 1 / DESIGN section 5): 23 log-spaced speeds 1e-4..1 m/s x 15 loads
10..150 N, R = 2 cm, SLS G0 = 3 MPa, tau = 0.25 s, f = 1, H = 30 mm, at the paper's resolution
(period L = 20 cm, cell a = 0.25 mm, 500 Fourier terms per axis; the window is 41 x 41 cells as
in the paper, enlarged to fit the largest contact). Paper: 54 min per reference case.

Reports compile time apart from run time (median of repeats), device, resolution, the number of
non-converged points, the moment-vs-dissipation spread, and the peak working memory estimate.
``--quick``: 6 speeds x 4 loads, coarser grid (a = 0.5 mm), one repeat.
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
from _timing import timed
from jaxroll import sphere3d as s3

G0, TAU, F, R = 3e6, 0.25, 1.0, 0.02


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--H", type=float, default=0.03)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--load-batch", type=int, default=None,
                    help="lax.map batch over loads (default: scan over loads with warm-started contact sets)")
    ap.add_argument("--tol", type=float, default=1e-10, help="contact solver tolerance (scaled residual)")
    args = ap.parse_args()
    if args.quick:
        speeds, loads, spacing, n_terms, repeat = np.logspace(-4, 0, 6), np.linspace(10, 150, 4), 5e-4, 250, 1
    else:
        speeds, loads, spacing, n_terms, repeat = np.logspace(-4, 0, 23), np.linspace(10, 150, 15), 2.5e-4, 500, args.repeat
    period = 0.2
    mat = jr.StandardLinearSolid(G0, TAU, F)
    layer = jr.Layer(args.H)
    r_max = float(s3.estimate_contact_radius(mat, layer, R, float(loads.max())))
    window = max(41, 2 * math.ceil(1.15 * r_max / spacing) + 1)

    @jax.jit
    def sweep(G, tau, f, H):
        return s3.rolling_resistance_sweep(jr.StandardLinearSolid(G, tau, f), jr.Layer(H), R, jnp.asarray(loads),
                                           jnp.asarray(speeds), period=period, spacing=spacing, window=window,
                                           n_terms=n_terms, load_batch=args.load_batch, tol=args.tol)

    theta = (G0, TAU, F, args.H)
    print(f"device: {jax.devices()[0].device_kind} x {len(jax.devices())}; cpu count {os.cpu_count()}; "
          f"load avg {os.getloadavg()[0]:.1f}")
    print(f"resolution: L = {period} m, a = {spacing * 1e3} mm ({round(period / spacing)}^2 cells), "
          f"window {window}^2, n_terms {n_terms}, tol {args.tol:g}; cases {len(speeds)} x {len(loads)}; H = {args.H} m")
    t = time.perf_counter()
    lowered = sweep.lower(*theta)
    compiled = lowered.compile()
    t_compile = time.perf_counter() - t
    _, runs, out = timed(compiled, *theta, repeat=repeat, all_runs=True)
    v, d = np.asarray(out["value"]), np.asarray(out["dissipation"])
    st = np.asarray(out["status"])
    spread = np.max(np.abs(v - d) / np.abs(v))
    print(f"compile {t_compile:.1f} s; run median {statistics.median(runs):.2f} s (runs {[round(r, 2) for r in runs]}); "
          f"paper 54 min -> ratio {54 * 60 / statistics.median(runs):.0f}x")
    print(f"non-converged points: {int(np.sum(st != 0))} (codes {sorted(set(st.ravel().tolist()))}); "
          f"iterations max {int(np.max(out['iterations']))}; max |moment - dissipation|/moment {spread:.2e}")
    print(f"R_r range {v.min():.4g} .. {v.max():.4g} N; peak at V = {speeds[np.argmax(v[:, -1])]:.3g} m/s "
          f"(P = {loads[-1]:.0f} N)")
    try:
        mem = compiled.memory_analysis()
        print(f"compiled temp memory: {mem.temp_size_in_bytes / 2**20:.0f} MiB")
    except Exception:  # noqa: BLE001 (not every backend reports it)
        pass


if __name__ == "__main__":
    main()
