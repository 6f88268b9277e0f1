"""Every entry point with its default method (the full model): time per point and first call.

For each entry point called as a user calls it, without ``method=``:

* time per point: the median of 3 warm calls (after a warm-up, each ended by
  ``jax.block_until_ready``) divided by the number of points of the call;
* first call in a fresh process: ``import jaxroll`` + building the inputs + the first call,
  timed inside a new Python process, with JAX's persistent compilation cache off
  (``JAXROLL_COMPILATION_CACHE=0``) and on (a new cache folder, filled by one process and then
  read by a second: the second process's wall time is reported, and its CPU time, the steadier
  figure on a shared machine). With the cache on, the second process loads the lowered programs
  the first one stored (``jaxroll._compilation_cache.call``) and their compiled code.

Entry points (the paper's material SLS G0 = 3 MPa, tau = 0.25 s, f = 1; R = 2 cm; H = 30 mm,
rho = 1000 kg/m^3):

* ``point-sphere``: ``jr.rolling_resistance``, sphere, 100 N, 0.01 m/s;
* ``point-cylinder``: the same for a cylinder, 5000 N/m;
* ``table-sphere``: ``jr.rolling_resistance_grid``, sphere, 5 speeds 1e-3..1e-1 m/s x 3 loads
  50..150 N;
* ``map-sphere`` / ``map-cylinder``: ``jr.resistance_map`` of the SLS as a one-term Prony series
  with WLF (8.86, 101.6 K, 293.15 K), 3 x 3 points 283..303 K x 1e-3..1e-1 m/s, H = 10 mm,
  R = 1 cm, 10 N / 10 kN/m, value + dR/dT + dR/dH (per point: the map's own ``seconds``);
* ``fit-cylinder``: ``jr.fit_material`` of G0 and tau from 12 points of the exact 2D half-space
  solution (6 speeds x 2 loads, 1 % noise), start G0 = 1.5 MPa (one re-resolution of the grid);
  per point = time per fit / 12.

    python benchmarks/bench_defaults.py [--quick] [--entries point-sphere,...] [--no-first] [--record]

``--record`` stores the rows in benchmarks/numbers.json (section ``defaults``), from which
benchmarks/render_docs.py writes the first-call table of benchmarks/README.md.

``--quick``: the point entries only, first call with the cache off only.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ENTRIES = ("point-sphere", "point-cylinder", "table-sphere", "map-sphere", "map-cylinder", "fit-cylinder")


def build(entry):
    """``(call, n_points)`` of ``entry``: ``call()`` returns what the user gets (arrays ready)."""
    import warnings

    import jax
    import numpy as np

    import jaxroll as jr

    mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    layer = jr.Layer(0.03, rho=1000.0)
    if entry.startswith("point-"):
        geometry = entry.split("-")[1]
        P = 100.0 if geometry == "sphere" else 5000.0
        return (lambda: jr.rolling_resistance(mat, layer, radius=0.02, load=P, speed=0.01, geometry=geometry).value), 1
    if entry == "table-sphere":
        speeds, loads = np.logspace(-3, -1, 5), np.array([50.0, 100.0, 150.0])
        return (lambda: jr.rolling_resistance_grid(mat, layer, radius=0.02, loads=loads, speeds=speeds).value), 15
    if entry.startswith("map-"):
        geometry = entry.split("-")[1]
        load = 10.0 if geometry == "sphere" else 1e4
        wlf = jr.WLF(8.86, 101.6, 293.15)

        def call():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", jr.ValidityWarning)
                return jr.resistance_map(mat.to_prony(), wlf, jr.Layer(0.01), radius=0.01, load=load,
                                         temperatures=np.linspace(283.15, 303.15, 3), speeds=np.logspace(-3, -1, 3),
                                         geometry=geometry)

        return call, 9
    if entry == "fit-cylinder":
        from jaxroll.identify.fit import IdentifiabilityWarning, RollingData

        half, R = jr.Layer(np.inf), 0.02
        V, P = (a.ravel() for a in np.meshgrid(np.logspace(-3, -1, 6), [2e3, 5e3]))
        exact = np.asarray(jax.vmap(lambda v, p: jr.reference.exact_cylinder_halfspace(mat, R, p, v).rolling_resistance)(
            V, P))
        y = exact * (1 + 0.01 * np.random.default_rng(3).standard_normal(exact.size))

        def call():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", IdentifiabilityWarning)
                return jr.fit_material(RollingData(V, P, y), initial=jr.StandardLinearSolid(1.5e6, 0.25, 1.0),
                                       layer=half, radius=R, geometry="cylinder", free=("G0", "tau")).params

        return call, 12
    raise ValueError(f"unknown entry {entry!r}; one of {ENTRIES}")


def per_point(entry, repeat=3):
    """Seconds per point of ``entry`` after a warm-up (median of ``repeat`` calls)."""
    import statistics

    import jax

    call, n = build(entry)
    jax.block_until_ready(call())
    if entry.startswith("map-"):  # the map times its own compiled program (values and gradients)
        return statistics.median(call().seconds for _ in range(repeat))
    runs = []
    for _ in range(repeat):
        t = time.perf_counter()
        jax.block_until_ready(call())
        runs.append(time.perf_counter() - t)
    return statistics.median(runs) / n


def first_call_child(entry):
    """In a fresh process: import + inputs + first call, wall and CPU seconds, printed as JSON."""
    t, c = time.perf_counter(), time.process_time()
    import jax

    call, _ = build(entry)
    jax.block_until_ready(call() if not entry.startswith("map-") else call().value)
    print(json.dumps({"first": time.perf_counter() - t, "cpu": time.process_time() - c}))


def first_call(entry, cache, cpu=False):
    """First-call seconds of ``entry`` in a new process (``cpu``: ``(wall, CPU)``); ``cache``:
    ``"0"`` (off) or a folder."""
    env = dict(os.environ, JAXROLL_COMPILATION_CACHE=cache)
    out = subprocess.run([sys.executable, __file__, "--child", entry], env=env, capture_output=True, text=True,
                         check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    return (got["first"], got["cpu"]) if cpu else got["first"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--entries", default=",".join(ENTRIES))
    ap.add_argument("--quick", action="store_true", help="point entries; first call with the cache off only")
    ap.add_argument("--no-first", action="store_true", help="skip the fresh-process first calls")
    ap.add_argument("--record", action="store_true", help="store the rows in benchmarks/numbers.json (section defaults)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        return first_call_child(args.child)
    entries = [e for e in args.entries.split(",") if e]
    if args.quick:
        entries = [e for e in entries if e.startswith("point-")]
    from _timing import summary

    print("entry | per point [s] | first call, cache off [s] | first call, cache on (second process) [s] (its CPU [s])")
    load_start, rows = round(os.getloadavg()[0], 1), []
    for entry in entries:
        pp = per_point(entry)
        off = on = on_cpu = float("nan")
        if not args.no_first:
            off = first_call(entry, "0")
            if not args.quick:
                with tempfile.TemporaryDirectory() as cache:
                    first_call(entry, cache)  # fills the cache
                    on, on_cpu = first_call(entry, cache, cpu=True)
        print(f"{entry} | {pp:.4f} | {off:.1f} | {on:.1f} ({on_cpu:.1f})", flush=True)
        rows.append(dict(entry=entry, per_point_s=pp, first_cache_off_s=None if off != off else off,
                         first_cache_on_s=None if on != on else on, first_cache_on_cpu_s=None if on != on else on_cpu))
        summary(f"bench_defaults.py{' --quick' if args.quick else ''} ({entry})", pp, off, "", "",
                f"default method (full model), per point; first call cache off {off:.1f} s, on {on:.1f} s")
    if args.record:
        from _numbers import record

        record("defaults", {"command": " ".join(["python benchmarks/bench_defaults.py"] + [a for a in sys.argv[1:] if a != "--record"]),
                            "load_start": load_start, "load_end": round(os.getloadavg()[0], 1), "rows": rows})


if __name__ == "__main__":
    main()
