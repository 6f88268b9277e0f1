"""Benchmark: identification of (G0, tau, f) with ``jr.fit_material`` from 345 rolling-resistance
points (23 speeds 1e-4..1 m/s x 15 loads 10..150 N, sphere R = 2 cm on H = 30 mm, direct method,
2 % noise).

Reports, apart: the first fit (compile + run), the compile time (first minus the same fit again,
warm: the compiled residual/Jacobian is keyed on the static configuration, so later fits of data
of the same shape do not recompile), and the median warm fit from other starts (run only), with
the number of residual+Jacobian evaluations (counted by ``fit_material``'s ``progress``
callback) and the recovered parameters. ``--quick``: 7 x 5 points, one other start.
``--full``: also one fit with the full 3D model (``jr.Full`` on the fixed grid and
``edge_smoothing`` of ``fitting/make_synthetic.py``) of the 60-point shipped synthetic set at
the cell size ``--spacing`` (first = compile + run, then a warm repeat).

Usage: python benchmarks/bench_fit.py [--quick] [--repeats 3] [--full] [--spacing 5e-4]
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
from _timing import summary


class Counter:
    """``progress`` callback of ``jr.fit_material``: counts residual+Jacobian evaluations."""

    def __init__(self):
        self.n = 0

    def __call__(self, count, chi2, params, seconds):
        self.n += 1


def fit(counter, *args, **kw):
    counter.n = 0
    t0 = time.perf_counter()
    out = jr.fit_material(*args, progress=counter, **kw)
    return out, time.perf_counter() - t0, counter.n


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="7 speeds x 5 loads, one other start")
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--spacing", type=float, default=5e-4, help="full model cell size [m] for --full")
    args = ap.parse_args()
    true = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    layer = jr.Layer(H=0.03)
    n_v, n_p = (7, 5) if args.quick else (23, 15)
    repeats = 1 if args.quick else args.repeats
    speeds, loads = np.logspace(-4, 0, n_v), np.linspace(10.0, 150.0, n_p)
    V, P = [a.ravel() for a in np.meshgrid(speeds, loads, indexing="ij")]
    clean = np.asarray(jr.rolling_resistance_grid(true, layer, radius=0.02, loads=loads, speeds=speeds,
                                                  method=jr.Direct()).value).ravel()
    rng = np.random.default_rng(0)
    meas = clean * (1 + 0.02 * rng.standard_normal(clean.size))
    starts = [jr.StandardLinearSolid(1e6, 0.05, 0.3), jr.StandardLinearSolid(1e7, 1.0, 3.0),
              jr.StandardLinearSolid(2e6, 0.5, 0.5), jr.StandardLinearSolid(5e6, 0.1, 2.0)]
    warnings.simplefilter("ignore", jr.IdentifiabilityWarning)
    counter = Counter()
    kw = dict(layer=layer, radius=0.02, method=jr.Direct())
    print(f"# fit benchmark: {V.size} points, direct method, least squares in log-parameters, {jax.devices()[0].platform}, "
          f"cpu count {os.cpu_count()}, load avg {os.getloadavg()[0]:.1f} (shared machine)")
    data = jr.RollingData(V, P, meas)
    res, first, n_first = fit(counter, data, initial=starts[0], **kw)
    times, evals = [], []
    for s in starts[1:1 + repeats]:
        f2, t, n = fit(counter, data, initial=s, **kw)
        times.append(t)
        evals.append(n)
        if abs(float(f2.params["tau"]) / float(res.params["tau"]) - 1) > 1e-4:
            print(f"  note: start {s} converged elsewhere (tau {float(f2.params['tau']):.4g})")
    _, warm_same, _ = fit(counter, data, initial=starts[0], **kw)
    print(f"first fit (compile + run)     : {first:.2f} s ({n_first} residual+Jacobian evaluations)")
    print(f"same fit again (warm, cached) : {warm_same:.2f} s -> compile ~ {first - warm_same:.2f} s")
    print(f"fits from other starts (warm) : median {np.median(times):.2f} s  (min {min(times):.2f}, "
          f"max {max(times):.2f}, n = {len(times)}; evaluations {evals})")
    print(res.report())
    cmd = "bench_fit.py" + (" --quick" if args.quick else "")
    summary(cmd, warm_same, first - warm_same, "target 10 s per fit", f"{10.0 / warm_same:.0f}x under target",
            f"{V.size} points, direct, {n_first} evaluations")

    if args.full:
        sys.path.insert(0, str(Path(__file__).parent.parent / "fitting"))
        import make_synthetic as ms

        data = jr.identify.read_rolling_csv(jr.datasets.path("synthetic_sphere.csv"))
        method = ms.full_method(args.spacing)
        print(f"\n# full 3D fit of the shipped 60-point set, method {method}")
        for label in ("first (compile + run)", "warm repeat"):
            ff, t, n = fit(counter, data, absolute_sigma=True,
                           initial=jr.StandardLinearSolid(2e6, 0.35, 0.7), layer=jr.Layer(H=ms.H, rho=ms.RHO),
                           radius=ms.R, method=method)
            print(f"{label}: {t:.1f} s ({n} evaluations)")
        print(ff.report())
        summary(f"bench_fit.py --full --spacing {args.spacing:g}", t, float("nan"),
                "old API, idle: 96 s (paper grid)", "", f"60 points, full 3D, {n} evaluations")


if __name__ == "__main__":
    main()
