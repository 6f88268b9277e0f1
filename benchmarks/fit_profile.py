"""Profile one fit of the shipped identification benchmark (jaxroll/datasets/fit_<geometry>.csv)
with every default: CPU and wall seconds, model evaluations (residual and Jacobian together),
least-squares iterations, XLA compilations and their seconds, time per evaluation.

The evaluations are counted where the fit runs them (``jaxroll._compilation_cache.call`` of
``_residuals_and_jacobian_jit``), per window, in CPU seconds of the process (all its threads: a
program compiled ahead in a background thread counts in the evaluations it overlaps). JAX's
compile events are summed by kind, in wall seconds: tracing to a jaxpr (nested traces counted
again inside their parents: the largest entries are the programs), lowering to StableHLO, and
XLA's compilation.

Run: ``python benchmarks/fit_profile.py [--geometry cylinder|sphere] [--points every]``.
"""

import argparse
import os
import time
import warnings

import jax
import numpy as np

import jaxroll as jr
from jaxroll.identify import fit as fit_module
from jaxroll.identify.fit import IdentifiabilityWarning, RollingData, fit_material, read_rolling_csv

START = jr.StandardLinearSolid(G0=2e6, tau=0.35, f=0.7)
HALF = jr.Layer(H=float("inf"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--geometry", default="cylinder", choices=["sphere", "cylinder"])
    ap.add_argument("--every", type=int, default=1, help="keep every n-th point")
    args = ap.parse_args()
    data = read_rolling_csv(jr.datasets.path(f"fit_{args.geometry}.csv"))
    keep = np.arange(len(data.speed)) % args.every == 0
    data = RollingData(data.speed[keep], data.load[keep], data.value[keep], data.sigma[keep])

    # JAX's compile events, by kind: tracing to a jaxpr, lowering to MLIR, XLA's backend compile
    events = {"trace": "/jax/core/compile/jaxpr_trace_duration", "lower": "/jax/core/compile/jaxpr_to_mlir_module_duration",
              "compile": "/jax/core/compile/backend_compile_duration"}
    spent = {k: [] for k in events}
    jax.monitoring.register_event_duration_secs_listener(
        lambda name, secs, **kw: [spent[k].append(secs) for k, e in events.items() if e == name])
    evaluations, seconds, per_window = [0], [0.0], {}
    cache = fit_module._compilation_cache
    inner_call = cache.call

    def counted(fn, *args, **kw):  # the fit's evaluations run through the compilation cache's call
        if fn is not fit_module._residuals_and_jacobian_jit:
            return inner_call(fn, *args, **kw)
        t = time.process_time()
        out = jax.block_until_ready(inner_call(fn, *args, **kw))
        evaluations[0] += 1
        seconds[0] += time.process_time() - t
        row = per_window.setdefault(args[3].method.grid.window, [0, []])
        row[0] += 1
        row[1].append(time.process_time() - t)
        return out

    cache.call = counted
    iterations = []
    load = os.getloadavg()[0]
    t, c = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        res = fit_material(data, initial=START, layer=HALF, radius=0.02, geometry=args.geometry, absolute_sigma=True,
                           progress=lambda k, chi2, values, s: iterations.append((k, chi2, s)))
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    print(f"{args.geometry}, {int(keep.sum())} points: {wall:.1f} s wall, {cpu:.1f} s CPU (load {load:.1f} before, "
          f"{os.getloadavg()[0]:.1f} after)")
    print(f"  evaluations (r and J together): {evaluations[0]}, {seconds[0]:.1f} s CPU in them "
          f"({seconds[0] / max(evaluations[0], 1):.2f} s each incl. compiles); accepted points (Jacobian calls): "
          f"{len(iterations)}; runs (grids): {len(res.starts)}")
    for k, secs in spent.items():
        print(f"  {k} (wall): {len(secs)} programs, {sum(secs):.1f} s; largest {[round(x, 1) for x in sorted(secs)[-3:]]}")
    for window, (count, cpu) in per_window.items():
        print(f"  window {window} cells: {count} evaluations, CPU {sum(cpu):.1f} s (first {cpu[0]:.1f} s incl. "
              f"compile, then median {np.median(cpu[1:]) if len(cpu) > 1 else float('nan'):.2f} s)")
    print(f"  grid: {res.method.grid}")
    for n in res.params:
        print(f"  {n} {float(res.params[n]):.6g} [{float(res.ci95[n][0]):.6g}, {float(res.ci95[n][1]):.6g}]")
    print(f"  chi2/dof {res.reduced_chi2:.4f}; converged {res.converged}")


if __name__ == "__main__":
    main()
