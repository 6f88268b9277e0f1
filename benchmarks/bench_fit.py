"""Benchmark: identification of (G0, tau, f) from 345 rolling-resistance points (23 speeds
1e-4..1 m/s x 15 loads 10..150 N, sphere R = 2 cm on H = 30 mm, direct method, 2 % noise).

Reports, apart: the first fit (compile + run), the compile time alone (first minus the median
warm fit: the compiled residual/Jacobian is cached per static configuration, so later fits of
data of the same shape do not recompile), and the median warm fit from other starts (run
only), with the number of residual+Jacobian evaluations, and the recovered parameters.
``--full``: also one fit with the full 3D model (jaxroll.sphere3d sweep) of the 60-point
shipped synthetic set at the resolution given by ``--spacing`` (first = compile + run, then a
warm repeat).

Usage: python benchmarks/bench_fit.py [--repeats 3] [--full] [--spacing 5e-4]
"""

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import jax
import numpy as np

import jaxroll as jr
import jaxroll.fit as jfit


def _counting():
    """Count residual+Jacobian evaluations of the LM driver (host loop)."""
    calls = [0]
    orig = jfit._levenberg_marquardt

    def lm(evaluate, *a, **k):
        def ev(u):
            calls[0] += 1
            return evaluate(u)

        return orig(ev, *a, **k)

    jfit._levenberg_marquardt = lm
    return calls


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--spacing", type=float, default=5e-4, help="full model cell size [m] for --full")
    args = ap.parse_args()
    true = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    layer = jr.Layer(H=0.03)
    V, P = [a.ravel() for a in np.meshgrid(np.logspace(-4, 0, 23), np.linspace(10.0, 150.0, 15))]
    clean = np.asarray(jax.jit(jax.vmap(lambda v, p: jr.rolling_resistance(true, layer, radius=0.02, load=p, speed=v).value))(V, P))
    rng = np.random.default_rng(0)
    meas = clean * (1 + 0.02 * rng.standard_normal(clean.size))
    starts = [jr.StandardLinearSolid(1e6, 0.05, 0.3), jr.StandardLinearSolid(1e7, 1.0, 3.0),
              jr.StandardLinearSolid(2e6, 0.5, 0.5), jr.StandardLinearSolid(5e6, 0.1, 2.0)]
    warnings.simplefilter("ignore", jr.IdentifiabilityWarning)
    calls = _counting()
    print(f"# fit benchmark: 345 points, direct method, LM in log-parameters, {jax.devices()[0].platform}, "
          f"cpu count {os.cpu_count()}, load avg {os.getloadavg()[0]:.1f}")
    jfit.clear_cache()
    t0 = time.perf_counter()
    fit = jr.fit_material(V, P, meas, initial=starts[0], layer=layer, radius=0.02)
    first = time.perf_counter() - t0
    n_first = calls[0]
    times, evals = [], []
    for s in starts[1 : 1 + args.repeats]:
        calls[0] = 0
        t0 = time.perf_counter()
        f2 = jr.fit_material(V, P, meas, initial=s, layer=layer, radius=0.02)
        times.append(time.perf_counter() - t0)
        evals.append(calls[0])
        assert abs(float(f2.params["tau"]) / float(fit.params["tau"]) - 1) < 1e-4
    # the same start again: identical work to the first fit, without compilation
    calls[0] = 0
    t0 = time.perf_counter()
    jr.fit_material(V, P, meas, initial=starts[0], layer=layer, radius=0.02)
    warm_same = time.perf_counter() - t0
    print(f"first fit (compile + run)     : {first:.2f} s ({n_first} residual+Jacobian evaluations)")
    print(f"same fit again (warm, cached) : {warm_same:.2f} s -> compile ~ {first - warm_same:.2f} s")
    print(f"fits from other starts (warm) : median {np.median(times):.2f} s  (min {min(times):.2f}, "
          f"max {max(times):.2f}, n = {len(times)}; evaluations {evals})")
    print(fit.report())

    if args.full:
        sys.path.insert(0, str(Path(__file__).parent.parent / "fitting"))
        import make_synthetic as ms

        data = jfit.read_rolling_csv(Path(__file__).parent.parent / "fitting" / "data" / "synthetic_sphere.csv")
        res = ms.full_resolution(args.spacing)
        print(f"\n# full 3D fit of the shipped 60-point set, resolution {res}")
        for label in ("first (compile + run)", "warm repeat"):
            calls[0] = 0
            t0 = time.perf_counter()
            ff = jr.fit_material(data.speed, data.load, data.value, sigma=data.sigma, absolute_sigma=True,
                                 initial=jr.StandardLinearSolid(2e6, 0.35, 0.7), layer=layer, radius=0.02,
                                 method="full", rr_options=res)
            print(f"{label}: {time.perf_counter() - t0:.1f} s ({calls[0]} evaluations)")
        print(ff.report())


if __name__ == "__main__":
    main()
