"""Benchmark: time per point of a 2-ply stack against the single layer, in each method.

Single layer: SLS G0 = 3 MPa, tau = 0.25 s, f = 1, H = 5 mm on a rigid base (quasi-static).
Stack: the same 5 mm cover on a 2 mm carcass (SLS G0 = 30 MPa, tau = 0.01 s, f = 0.5, nu = 0.45),
rigid base. R = 2 cm; sphere P = 150 N, cylinder P' = 5 kN/m; V = 0.01 m/s (a new speed each
call). Each method is resolved once from the single layer's inputs, so the layer and the stack
run on the same grid. Times the front door ``jr.rolling_resistance``: compile apart (first
call minus the warm median), then the median of warm calls (``block_until_ready``).
Also the compliance alone on 2e5 wavenumbers (``surface_compliance`` vs ``stack_compliance``).

Usage: python benchmarks/bench_stack.py [--quick] [--repeats 5] [--methods full3d,full2d,...]
"""

import argparse
import os
import platform
import statistics

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from _timing import timed, summary

COVER = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=1.0)
CARCASS = jr.StandardLinearSolid(G0=3e7, tau=0.01, f=0.5)
LAYER = jr.Layer(H=0.005)
STACK = jr.Stack([jr.Ply(COVER, H=0.005), jr.Ply(CARCASS, H=0.002, nu=0.45)], base="rigid")
R = 0.02
CASES = {  # name: (method, geometry, load)
    "full3d": (jr.Full(), "sphere", 150.0),
    "full3d-periodic": (jr.Full(grid=jr.FixedGrid(6e-4, 17, period=0.08, n_terms=80)), "sphere", 150.0),
    "full2d": (jr.Full(), "cylinder", 5000.0),
    "full2d-periodic": (jr.Full(grid=jr.FixedGrid(2e-4, 80, period=0.1)), "cylinder", 5000.0),
    "direct-sphere": (jr.Direct(), "sphere", 150.0),
    "direct-cylinder": (jr.Direct(), "cylinder", 5000.0),
    "direct-periodic": (jr.Direct(period=0.08, n_terms=100), "sphere", 150.0),
    "SP": (jr.Slices(algorithm="SP"), "sphere", 150.0),
}


def per_point(method, geometry, load, repeats):
    """Compile (first call minus the warm median) and warm median of the layer and of the stack,
    their warm calls interleaved (the machine's load drifts alike for both)."""
    speeds = iter(np.geomspace(0.01, 0.02, 4 * repeats + 8))
    out = {}
    calls = {}
    for model, args in (("layer", (COVER, LAYER)), ("stack", (STACK, None))):
        def call(args=args):
            return jr.rolling_resistance(*args, radius=R, load=load, speed=next(speeds), geometry=geometry,
                                         method=method, throw=False).value
        calls[model] = call
        out[model] = [timed(call, repeat=1)[0]]  # first call: compile + run
    runs = {"layer": [], "stack": []}
    for _ in range(repeats):
        for model in ("layer", "stack"):
            _, times, value = timed(calls[model], repeat=1, all_runs=True)
            runs[model] += times
            out[model + "_value"] = float(value)
    res = {}
    for model in ("layer", "stack"):
        median = statistics.median(runs[model])
        res[model] = (out[model][0] - median, median, out[model + "_value"])
    return res


def compliance(repeats):
    q = jnp.linspace(1.0, 1e5, 200_000)
    out = {}
    for name, fn in [("layer", eqx.filter_jit(lambda V: jr.engines.layer.surface_compliance(LAYER, COVER, q, 0.0, V))),
                     ("stack", eqx.filter_jit(lambda V: jr.engines.stack.stack_compliance(STACK, q, 0.0, V)))]:
        speeds = iter(np.geomspace(0.01, 0.02, 2 * repeats + 4))
        first, median, _ = timed(lambda: fn(next(speeds)), repeat=repeats)
        out[name] = (first - median, median)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="2 repeats")
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--methods", default=",".join(CASES))
    args = ap.parse_args()
    repeats = 2 if args.quick else args.repeats
    print(f"# jax {jax.__version__}, {repeats} interleaved warm calls per model")
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()}")
    c = compliance(repeats)
    ratio = c["stack"][1] / c["layer"][1]
    print(f"compliance 2e5 q: layer {c['layer'][1] * 1e3:.2f} ms, stack {c['stack'][1] * 1e3:.2f} ms, "
          f"ratio {ratio:.2f}; compile {c['layer'][0]:.1f} / {c['stack'][0]:.1f} s")
    print("| method | layer [s/point] | 2-ply stack [s/point] | ratio | compile layer / stack [s] | R_r layer / stack |")
    print("|---|---|---|---|---|---|")
    for name in args.methods.split(","):
        method, geometry, load = CASES[name]
        method = jr.methods.as_method(method).resolve(COVER, LAYER, radius=R, loads=[load], speeds=[0.01, 0.02],
                                                      geometry=geometry)
        r = per_point(method, geometry, load, repeats)
        (cl, ml, vl), (cs, ms, vs) = r["layer"], r["stack"]
        print(f"| {name} | {ml:.4f} | {ms:.4f} | {ms / ml:.2f} | {cl:.1f} / {cs:.1f} | {vl:.4g} / {vs:.4g} |",
              flush=True)
        summary(f"bench_stack {name}", ms, cs, baseline=ml, ratio=ms / ml)
    print(f"# load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
