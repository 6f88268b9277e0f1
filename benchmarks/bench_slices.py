"""Benchmark of the sphere-from-cylinder-slices algorithms PD, PP, SP (jaxroll.slices, [ZG] sec. 3).

Run:  python benchmarks/bench_slices.py [--quick] [--batch B] [--linear-solver gmres|dense]

Reports (CPU, float64), compile time apart from run time, medians of repeated runs:
* single run of each algorithm (R = 2 cm, G0 = 3 MPa, tau = 0.25 s, f = 1, H = 5 mm,
  P = 100 N, V = 0.01 m/s), 21 slices, the paper's period L = 0.2 m with 2^10 cells
  (dx = 0.195 mm; the paper used 0.25 mm), 160-cell window;
* the reference case, 23 log-spaced speeds 1e-4..1 m/s x 15 loads 10..150 N (``--quick``: 5 x 3,
  then the time is scaled to 345 cases), with ``lax.map`` over batches of ``B`` cases;
* the full 3D model (jaxroll.sphere3d) on the same cases when it exists, and the speed factors.
Targets ([ZG] Table 1 is 21 / 20 / 107 s): PD and PP <= 0.5 s, SP <= 1 s per reference case on
2 cores. Note the machine load (``os.getloadavg``) printed with the results.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from jaxroll import slices as sl

G0, TAU, F, R, H = 3e6, 0.25, 1.0, 0.02, 5e-3
OPTS = dict(period=0.2, n_cells=2**10, window_cells=160)


def timed(fn, *args, repeat=3):
    """(compile+first-run seconds, median run seconds, output)."""
    t = time.perf_counter()
    out = jax.block_until_ready(fn(*args))
    first = time.perf_counter() - t
    runs = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = jax.block_until_ready(fn(*args))
        runs.append(time.perf_counter() - t)
    return first, statistics.median(runs), out


def make_case(algorithm, linear_solver):
    def case(VP):
        V, P = VP[0], VP[1]
        s = sl.solve_slices(jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H), R, P, V,
                            algorithm=algorithm, throw=False, linear_solver=linear_solver, **OPTS)
        return s.resistance, s.status, s.iterations

    return case


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="5 x 3 cases, scaled to 345")
    ap.add_argument("--batch", type=int, default=1,
                    help="lax.map batch size (vmapped while loops run in lockstep: 1 is fastest)")
    ap.add_argument("--linear-solver", default="gmres", choices=["gmres", "dense"])
    args = ap.parse_args()
    speeds = np.geomspace(1e-4, 1.0, 5 if args.quick else 23)
    loads = np.linspace(10.0, 150.0, 3 if args.quick else 15)
    VP = jnp.asarray(np.stack(np.meshgrid(speeds, loads, indexing="ij"), -1).reshape(-1, 2))
    n = VP.shape[0]
    scale = 345.0 / n
    print(f"jax {jax.__version__}, {jax.devices()[0].platform}, cores {os.cpu_count()}, "
          f"load average {os.getloadavg()[0]:.1f}; linear solver {args.linear_solver}; "
          f"{n} cases (x{scale:.0f} to the 345-case reference)")
    results = {}
    for alg in sl.ALGORITHMS:
        case = make_case(alg, args.linear_solver)
        single = jax.jit(case)
        c1, t1, out1 = timed(single, jnp.array([0.01, 100.0]))
        sweep = jax.jit(lambda xs: jax.lax.map(case, xs, batch_size=args.batch))
        c2, t2, out = timed(sweep, VP, repeat=1)
        ok = int(np.sum(np.asarray(out[1]) == 0))
        results[alg] = (t2 * scale, np.asarray(out[0]))
        print(f"{alg}: single run {t1:.3f} s (compile {c1:.1f} s), R_r = {float(out1[0]):.4g} N, "
              f"{int(out1[2])} Newton it.; reference case {t2 * scale:.2f} s (measured {t2:.2f} s "
              f"for {n}; compile {c2:.1f} s), {ok}/{n} converged, "
              f"mean Newton it. {float(np.mean(np.asarray(out[2]))):.1f}")
    try:
        from jaxroll import sphere3d
    except ImportError:
        print("full 3D model (jaxroll.sphere3d) not available: no speed factors against it")
        return
    f3 = jax.jit(lambda VP: sphere3d.rolling_resistance_full(
        jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H), R, VP[1], VP[0], throw=False).value)
    c3, t3, _ = timed(f3, jnp.array([0.01, 100.0]), repeat=1)
    ref_time = t3 * 345
    print(f"3D: single run {t3:.3f} s (compile {c3:.1f} s), reference case ~{ref_time:.0f} s")
    for alg, (t, _) in results.items():
        print(f"speed factor {alg}: {ref_time / t:.0f} (paper: PD 153, PP 161, SP 30)")


if __name__ == "__main__":
    main()
