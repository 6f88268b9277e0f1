"""The 3D infinite-layer factor of a quasi-static layer: the full ``K^2``-node quadrature against its
split into the half-space constant and the layer's correction (issue 31, the vmap over thicknesses).

    python benchmarks/bench_layer_factor.py [--repeat 5] [--no-front-door]

Both in one process, alternating (the machine is shared: both see the same load), medians of wall
and process CPU time:

* the factor alone (``jaxroll.engines.aperiodic.surface_factor_pair`` of ``T_1``, "full", against
  ``layer_factor_pair``, "split"), cells 0.25 mm, window 55: one thickness (5, 30 and 0.5 mm),
  20 thicknesses 5..50 mm in a ``lax.map`` (what the warm-started scan of ``Full.evaluate_points``
  does per point) and under ``jax.vmap`` (lockstep: every tile runs);
* the front door (the paper's sphere, SLS 3 MPa / 0.25 s / 1, R = 2 cm, 100 N, 0.01 m/s), with
  the full factor patched in for "full": ``jit(vmap)`` over the same 20 thicknesses (the row
  ``jit(vmap(front door)) H x20`` of ``bench_batched.py``) and one point at H = 30 mm.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without install

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxroll as jr  # noqa: E402
from jaxroll.engines import aperiodic, sphere3d  # noqa: E402
from jaxroll.engines.layer import halfspace_asymptote, static_compliance  # noqa: E402

DX, W = 2.5e-4, 55
HS = jnp.asarray(np.linspace(0.005, 0.05, 20))


def full_factor(layer, grid):
    """The quadrature on all ``K^2`` nodes (what ``sphere3d._infinite_layer_factor`` was)."""
    return aperiodic.surface_factor_pair(sphere3d._radial(lambda q: static_compliance(layer, q)), grid.spacing,
                                         grid.window)


SPLIT = sphere3d._infinite_layer_factor
FACTORS = {"full": full_factor, "split": SPLIT}


def _median(fn, args, repeat):
    """Median wall and CPU seconds of ``repeat`` calls after one warm-up."""
    jax.block_until_ready(fn(*args))
    wall, cpu = [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        jax.block_until_ready(fn(*args))
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return statistics.median(wall), statistics.median(cpu)


def _programs():
    """name -> {kind: (compiled, args)} for both factors."""
    grid = jr.FixedGrid(DX, W)
    method = jr.Full(grid=grid)

    def single(H):
        return jr.rolling_resistance(jr.StandardLinearSolid(3e6, 0.25, 1.0), jr.Layer(H), radius=0.02, load=100.0,
                                     speed=0.01, method=method, throw=False).value

    out = {}
    for name, factor in FACTORS.items():
        sphere3d._infinite_layer_factor = factor
        jax.clear_caches()  # the front door's trace holds the factor it was traced with

        def one(H, factor=factor):
            return factor(jr.Layer(H), grid)

        out[name] = {
            "factor, H 5 mm": (jax.jit(one).lower(0.005).compile(), (0.005,)),
            "factor, H 30 mm": (jax.jit(one).lower(0.03).compile(), (0.03,)),
            "factor, H 0.5 mm": (jax.jit(one).lower(0.0005).compile(), (0.0005,)),
            "factor, lax.map H x20": (jax.jit(lambda Hs, one=one: jax.lax.map(one, Hs)).lower(HS).compile(), (HS,)),
            "factor, vmap H x20": (jax.jit(jax.vmap(one)).lower(HS).compile(), (HS,)),
        }
        if ARGS.front_door:
            out[name]["jit(vmap(front door)) H x20"] = (jax.jit(jax.vmap(single)).lower(HS).compile(), (HS,))
            out[name]["front door, H 30 mm"] = (jax.jit(single).lower(0.03).compile(), (0.03,))
    sphere3d._infinite_layer_factor = SPLIT
    return out


def main():
    print(f"load average {os.getloadavg()[0]:.1f} at the start; cpu count {os.cpu_count()}", flush=True)
    progs = _programs()
    if ARGS.front_door:
        a, b = (np.asarray(progs[k]["jit(vmap(front door)) H x20"][0](HS)) for k in ("full", "split"))
        print(f"front door over 20 thicknesses: max |split/full - 1| = {np.max(np.abs(b / a - 1)):.1e}")
    times = {k: {name: [] for name in FACTORS} for k in progs["full"]}
    for k in times:
        for _ in range(ARGS.repeat):
            for name in FACTORS:
                times[k][name].append(_median(*progs[name][k], 1))
    print(f"load average {os.getloadavg()[0]:.1f} at the end; medians of {ARGS.repeat}, alternating\n")
    print("| program | full: wall / CPU | split: wall / CPU | ratio full/split (wall, CPU) |")
    print("|---|---|---|---|")
    for k, t in times.items():
        (fw, fc), (sw, sc) = ([statistics.median(x[i] for x in t[n]) for i in (0, 1)] for n in FACTORS)
        print(f"| {k} | {fw * 1e3:.1f} / {fc * 1e3:.1f} ms | {sw * 1e3:.1f} / {sc * 1e3:.1f} ms | "
              f"{fw / sw:.1f}x, {fc / sc:.1f}x |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-front-door", dest="front_door", action="store_false",
                    help="only the factor programs (seconds to compile instead of a minute)")
    ARGS = ap.parse_args()
    main()
