"""Benchmark of the direct Fourier-series method ([ZG] sec. 4) on the reference case.

Reference case: H = 30 mm, R = 2 cm, SLS G0 = 3 MPa, tau = 0.25 s, f = 1; 23 log-spaced speeds
1e-4..1 m/s x 15 loads 10..150 N (345 cases). Methods:

* periodic series, L = 0.2 m, N = 50 (the paper's setting) and N = 500;
* aperiodic limit, rtol 1e-4 (the default);
* baseline: plain NumPy implementation of [ZG] eq. 37 (N = 50, same T closed form written in
  NumPy), vectorised over (m, n) and looped over the 345 cases.

Accuracy: against the converged value (aperiodic rtol 1e-8; the periodic series converge to
the periodic value, which differs physically at high speed, so their error mixes truncation
and the periodic/aperiodic difference; see DESIGN section 2). Times: compile apart, medians
of repeats, ``block_until_ready``. Run: ``python benchmarks/bench_direct.py [--repeats 5]``.
Pin to 2 cores with ``taskset -c 0,1`` for the project's reference platform.
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
from jaxroll.direct import settings_for_rtol

from _timing import timed

G0, TAU, F = 3e6, 0.25, 1.0
R, H, L = 0.02, 30e-3, 0.2
MAT = jr.StandardLinearSolid(G0, TAU, F)
LAYER = jr.Layer(H)
SPEEDS = np.logspace(-4, 0, 23)
LOADS = np.linspace(10.0, 150.0, 15)


def jax_case(**kw):
    def one(V, P):
        return jr.rolling_resistance(MAT, LAYER, radius=R, load=P, speed=V, pressure="thick", **kw).value

    if kw.get("n_terms", 0) and kw["n_terms"] > 100:
        # big periodic grids: map over speeds (vmapped over loads) to bound memory
        inner = jax.vmap(one, (None, 0))
        return jax.jit(lambda Vs, Ps: jax.lax.map(lambda V: inner(V, Ps), Vs))
    return jax.jit(jax.vmap(jax.vmap(one, (None, 0)), (0, None)))


def numpy_eq37(N=50):
    """[ZG] eq. 37 in plain NumPy (Hertz, Jaffar radius from jaxroll), thick incompressible
    quasi-static T = F(qH)/(2 G_m q)."""
    m = np.arange(1, N + 1)[:, None]
    n = np.arange(0, N + 1)[None, :]
    qx, qy = 2 * np.pi * m / L, 2 * np.pi * n / L
    q = np.sqrt(qx**2 + qy**2)
    y = q * H
    Fq = (np.sinh(2 * y) - 2 * y) / (np.cosh(2 * y) + 2 * y * y + 1)
    radii = {float(P): float(jr.contact_radius(MAT, LAYER, R, P)[0]) for P in LOADS}

    def run():
        out = np.empty((len(SPEEDS), len(LOADS)))
        for i, V in enumerate(SPEEDS):
            w = qx * V
            G = G0 * (1 + 1j * w * TAU) / (1 + 1j * w * TAU / (1 + F))
            imT = np.imag(Fq / (2 * np.conj(G) * q))
            for j, P in enumerate(LOADS):
                x = q * radii[float(P)]
                I = (m / L) * (np.sin(x) - x * np.cos(x)) ** 2 / x**6 * imT
                out[i, j] = 2 * np.pi * (6 * P) ** 2 / L**2 * (I[:, 1:].sum() + 0.5 * I[:, 0].sum())
        return out

    return run


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    Vs, Ps = jnp.asarray(SPEEDS), jnp.asarray(LOADS)
    print(f"jax {jax.__version__}, {platform.processor() or platform.machine()}, "
          f"cpus available {len(os.sched_getaffinity(0))}, device {jax.devices()[0]}, float64")

    conv_fn = jax.jit(jax.vmap(jax.vmap(
        lambda V, P: jr.direct_rolling_resistance(MAT, LAYER, radius=R, load=P, speed=V, pressure="thick",
                                                  quadrature=settings_for_rtol(1e-8)).value, (None, 0)), (0, None)))
    ref = np.asarray(conv_fn(Vs, Ps))

    rows = []
    np_run = numpy_eq37(50)
    t0 = time.perf_counter()
    np_out = np_run()
    np_times = []
    for _ in range(max(1, args.repeats // 2)):
        t0 = time.perf_counter()
        np_run()
        np_times.append(time.perf_counter() - t0)
    t_np = statistics.median(np_times)

    for name, kw in [("periodic N=50", dict(period=L, n_terms=50)),
                     ("periodic N=500", dict(period=L, n_terms=500)),
                     ("aperiodic rtol 1e-4", dict(rtol=1e-4)),
                     ("aperiodic rtol 1e-3", dict(rtol=1e-3))]:
        fn = jax_case(**kw)
        first, med, out = timed(fn, Vs, Ps, repeat=args.repeats if "500" not in name else max(1, args.repeats // 2))
        err = np.abs(np.asarray(out) / ref - 1)
        rows.append((name, first - med, med, float(err.max()), float(np.median(err)), t_np / med))
    err_np = np.abs(np_out / ref - 1)
    rows.append(("NumPy eq. 37, N=50", 0.0, t_np, float(err_np.max()), float(np.median(err_np)), 1.0))

    print(f"reference case: 23 speeds x 15 loads, H = {H*1e3:g} mm; converged = aperiodic rtol 1e-8")
    print(f"{'method':24s} {'compile [s]':>11s} {'run [s]':>9s} {'max err':>9s} {'median err':>10s} {'vs NumPy':>9s}")
    for name, comp, med, emax, emed, ratio in rows:
        print(f"{name:24s} {comp:11.2f} {med:9.4f} {emax:9.2e} {emed:10.2e} {ratio:8.1f}x")
    np.testing.assert_allclose(np.asarray(jax_case(period=L, n_terms=50)(Vs, Ps)), np_out, rtol=1e-10)
    print("JAX periodic N=50 == NumPy eq. 37 to 1e-10: OK")


if __name__ == "__main__":
    main()
