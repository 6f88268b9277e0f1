"""Benchmark of the direct Fourier-series method ([ZG] sec. 4, ``jr.Direct``) on the reference case.

Reference case: H = 30 mm, R = 2 cm, SLS G0 = 3 MPa, tau = 0.25 s, f = 1; 23 log-spaced speeds
1e-4..1 m/s x 15 loads 10..150 N (345 points), Hertz/Jaffar ("thick") pressure. Methods, each
timed through ``jr.rolling_resistance_grid`` compiled ahead of time (compile apart, medians of
repeats, ``block_until_ready``):

* periodic series, L = 0.2 m, ``jr.Direct(period=0.2, n_terms=50)`` (the paper's setting) and
  ``n_terms=500``;
* aperiodic limit, ``rtol`` 1e-4 (the default) and 1e-3;
* baseline: plain NumPy implementation of [ZG] eq. 37 (N = 50, same T closed form written in
  NumPy), vectorised over (m, n) and looped over the 345 cases.

Accuracy: against the converged value (aperiodic, ``rtol`` 1e-8; the periodic series converge to
the periodic value, which differs physically at high speed, so their error mixes truncation
and the periodic/aperiodic difference; see docs/conventions.md sec. 6).

Run: ``python benchmarks/bench_direct.py [--quick] [--repeats 5]`` (``--quick``: 3 repeats, no
N = 500 series). Paper: 23 s per reference case.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from _timing import aot, summary

G0, TAU, F = 3e6, 0.25, 1.0
R, H, L = 0.02, 30e-3, 0.2
MAT = jr.StandardLinearSolid(G0, TAU, F)
LAYER = jr.Layer(H)
SPEEDS = np.logspace(-4, 0, 23)
LOADS = np.linspace(10.0, 150.0, 15)
PAPER_S = 23.0


def table(method):
    """``R_r`` [N] on speeds x loads through the front door (material parameters traced)."""

    def fn(G, Ps, Vs):
        return jr.rolling_resistance_grid(jr.StandardLinearSolid(G, TAU, F), LAYER, radius=R, loads=Ps, speeds=Vs,
                                          method=method).value

    return fn


def numpy_eq37(N=50):
    """[ZG] eq. 37 in plain NumPy (Hertz, Jaffar radius from jaxroll), thick incompressible
    quasi-static T = F(qH)/(2 G_m q)."""
    m = np.arange(1, N + 1)[:, None]
    n = np.arange(0, N + 1)[None, :]
    qx, qy = 2 * np.pi * m / L, 2 * np.pi * n / L
    q = np.sqrt(qx**2 + qy**2)
    y = q * H
    Fq = (np.sinh(2 * y) - 2 * y) / (np.cosh(2 * y) + 2 * y * y + 1)
    radii = {float(P): float(jr.engines.contact_size.contact_radius(MAT, LAYER, R, P)[0]) for P in LOADS}

    def run():
        out = np.empty((len(SPEEDS), len(LOADS)))
        for i, V in enumerate(SPEEDS):
            w = qx * V
            G = G0 * (1 + 1j * w * TAU) / (1 + 1j * w * TAU / (1 + F))
            imT = np.imag(Fq / (2 * np.conj(G) * q))
            for j, P in enumerate(LOADS):
                x = q * radii[float(P)]
                I = (m / L) * (np.sin(x) - x * np.cos(x)) ** 2 / x**6 * imT  # noqa: E741
                out[i, j] = 2 * np.pi * (6 * P) ** 2 / L**2 * (I[:, 1:].sum() + 0.5 * I[:, 0].sum())
        return out

    return run


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="3 repeats, skip the N = 500 series")
    args = ap.parse_args()
    repeats = 3 if args.quick else args.repeats
    Vs, Ps = jnp.asarray(SPEEDS), jnp.asarray(LOADS)
    print(f"jax {jax.__version__}, {platform.processor() or platform.machine()}, "
          f"cpus available {len(os.sched_getaffinity(0))}, load avg {os.getloadavg()[0]:.1f} (shared machine), "
          f"device {jax.devices()[0]}, float64")

    ref = np.asarray(table(jr.Direct(pressure="thick", rtol=1e-8))(G0, Ps, Vs))

    np_run = numpy_eq37(50)
    np_out = np_run()
    np_times = []
    for _ in range(max(1, repeats // 2)):
        t0 = time.perf_counter()
        np_run()
        np_times.append(time.perf_counter() - t0)
    t_np = statistics.median(np_times)

    variants = [("periodic N=50", jr.Direct(pressure="thick", period=L, n_terms=50)),
                ("periodic N=500", jr.Direct(pressure="thick", period=L, n_terms=500)),
                ("aperiodic rtol 1e-4", jr.Direct(pressure="thick", rtol=1e-4)),
                ("aperiodic rtol 1e-3", jr.Direct(pressure="thick", rtol=1e-3))]
    if args.quick:
        variants = [v for v in variants if "500" not in v[0]]
    rows, outs = [], {}
    for name, method in variants:
        comp, med, out, _ = aot(table(method), G0, Ps, Vs, repeat=repeats if "500" not in name else 2)
        outs[name] = np.asarray(out)
        err = np.abs(outs[name] / ref - 1)
        rows.append((name, comp, med, float(err.max()), float(np.median(err)), t_np / med))
    err_np = np.abs(np_out / ref - 1)
    rows.append(("NumPy eq. 37, N=50", 0.0, t_np, float(err_np.max()), float(np.median(err_np)), 1.0))

    print(f"reference case: 23 speeds x 15 loads, H = {H*1e3:g} mm; converged = aperiodic rtol 1e-8")
    print(f"{'method':24s} {'compile [s]':>11s} {'run [s]':>9s} {'max err':>9s} {'median err':>10s} {'vs NumPy':>9s}")
    for name, comp, med, emax, emed, ratio in rows:
        print(f"{name:24s} {comp:11.2f} {med:9.4f} {emax:9.2e} {emed:10.2e} {ratio:8.1f}x")
    np.testing.assert_allclose(outs["periodic N=50"], np_out, rtol=1e-10)
    print("JAX periodic N=50 == NumPy eq. 37 to 1e-10: OK")
    cmd = "bench_direct.py" + (" --quick" if args.quick else "")
    by = {r[0]: r for r in rows}
    a = by["aperiodic rtol 1e-4"]
    summary(cmd + " (aperiodic rtol 1e-4)", a[2], a[1], f"NumPy eq. 37 N=50 {t_np:.4f} s; paper 23 s",
            f"{t_np / a[2]:.1f}x NumPy, {PAPER_S / a[2]:.0f}x paper", f"345 points, max err {a[3]:.1e}")
    p = by["periodic N=50"]
    summary(cmd + " (periodic N=50)", p[2], p[1], f"NumPy eq. 37 N=50 {t_np:.4f} s", f"{t_np / p[2]:.1f}x NumPy",
            "345 points")


if __name__ == "__main__":
    main()
