"""What per-program XLA options cost and save on jaxroll's heavy programs: compile CPU seconds, run
seconds and the numbers' agreement, one process, option sets alternating.

    python benchmarks/compile_options.py [--programs reference reference-grad point point-grad map]
                                         [--rounds 2] [--repeat 3] [--sets base emitters ...]

Unlike ``XLA_FLAGS`` (process-wide, read when JAX starts: ``benchmarks/xla_flags.py``), these
options belong to one executable (``jax.jit(f).lower(...).compile(options)``): what
:mod:`jaxroll._xla_options` gives the library's own top-level programs. Each program is compiled
for every option set (the persistent compilation cache off) in ``--rounds`` rounds that alternate
the sets, lowered anew each time after ``jax.clear_caches()`` (JAX keeps compiled executables in
memory by program and options). Reported: the median compile CPU seconds (process user + system)
and wall seconds; the median run CPU (and wall) seconds of ``--repeat`` calls after a warm-up
(ratios of CPU seconds, steadier than wall time on a shared machine); the largest relative
difference of the outputs to those of XLA's defaults (0: bit for bit). Programs:

- ``reference`` / ``reference-grad``: the paper's reference case table (23 speeds x 15 loads, 0.25 mm
  cells, infinite 30 mm layer; ``bench_sphere3d.py --H 0.03 --period none``) and its gradient with
  respect to (G0, tau, f, H), jitted by the caller;
- ``point-rho``: the same point on a layer with inertia (rho = 1000 kg/m^3, the README's);
- ``point`` / ``point-grad``: one point of the default sphere method (``jaxroll.methods.default_method()``
  resolved for R = 2 cm, 100 N, 10 mm/s on a 30 mm layer) and its gradient;
- ``map``: the largest program of ``jr.resistance_map`` of the shipped measured Prony material
  (9 x 9 temperatures x speeds; ``bench_batched.py``'s map), captured from the library;
- ``fit``: the first evaluation (residuals and Jacobian) of ``jr.fit_material`` on the shipped
  sphere benchmark (every 4th point; ``fit_profile.py --geometry sphere``), captured from the
  library (the fit compiles it with jaxroll's options, through ``_compilation_cache.call``);
- ``--first-call``: instead, a new interpreter's first ``jr.rolling_resistance`` of the default
  sphere point (import, grid sizing and compiles, an empty compilation cache), options on and off;
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time
import warnings

os.environ.setdefault("JAXROLL_COMPILATION_CACHE", "0")  # compile every time (set before jaxroll starts the cache)

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxroll as jr  # noqa: E402

OPTION_SETS = {
    "base": {},
    "emitters": {"xla_cpu_use_fusion_emitters": False},
    "emitters+O2": {"xla_cpu_use_fusion_emitters": False, "xla_backend_optimization_level": 2},
    "emitters+O1": {"xla_cpu_use_fusion_emitters": False, "xla_backend_optimization_level": 1},
    "emitters+cheap": {"xla_cpu_use_fusion_emitters": False, "xla_llvm_disable_expensive_passes": True},
    "O1": {"xla_backend_optimization_level": 1},
    "O2": {"xla_backend_optimization_level": 2},
    "cheap": {"xla_llvm_disable_expensive_passes": True},
}

G0, TAU, F, R, H = 3e6, 0.25, 1.0, 0.02, 0.03


def reference_programs():
    speeds, loads, spacing = np.logspace(-4, 0, 23), np.linspace(10, 150, 15), 2.5e-4
    mat = jr.StandardLinearSolid(G0, TAU, F)
    r_max = float(jr.engines.contact_size.estimate_contact_size(mat, jr.Layer(H), R, float(loads.max())))
    window = max(41, 2 * math.ceil(1.15 * r_max / spacing) + 1)
    method = jr.Full(grid=jr.FixedGrid(spacing, window, period=None, n_terms=None), tol=1e-10)

    def table(G, tau, f, h, loads, speeds):
        out = jr.rolling_resistance_grid(jr.StandardLinearSolid(G, tau, f), jr.Layer(h), radius=R, loads=loads,
                                         speeds=speeds, method=method)
        return out.value, out.result

    def objective(*theta):
        value, result = table(*theta)
        return jnp.sum(jnp.where(result == 0, value, 0.0))

    args = (G0, TAU, F, H, jnp.asarray(loads), jnp.asarray(speeds))
    return {"reference": (table, args), "reference-grad": (jax.grad(objective, argnums=(0, 1, 2, 3)), args)}


def point_programs():
    mat, layer = jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H)
    method = jr.methods.default_method("sphere").resolve(mat, layer, radius=R, loads=100.0, speeds=0.01)

    def point(G, tau, f, h, P, V):
        return jr.rolling_resistance(jr.StandardLinearSolid(G, tau, f), jr.Layer(h), radius=R, load=P, speed=V,
                                     method=method, throw=False).value

    def point_rho(G, tau, f, h, P, V):  # a layer with inertia (rho = 1000 kg/m^3): its integrals per speed
        return jr.rolling_resistance(jr.StandardLinearSolid(G, tau, f), jr.Layer(h, rho=1000.0), radius=R, load=P,
                                     speed=V, method=method, throw=False).value

    args = (G0, TAU, F, H, 100.0, 0.01)
    return {"point": (point, args), "point-grad": (jax.grad(point, argnums=(0, 1, 2, 3)), args),
            "point-rho": (point_rho, args)}


def map_program():
    """The largest ``(fn, args, static)`` that ``jr.resistance_map`` compiles (captured)."""
    from jaxroll import buckets

    seen = []
    original = buckets.compiled

    def capture(fn, args, static):
        seen.append((fn, args, static))
        return original(fn, args, static)

    sw = jr.read_dma_sweeps(jr.datasets.path("pyvisco_freq_user_raw.csv"))
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    wlf, pf = jr.fit_wlf(sh), jr.fit_prony(jr.master_curve(sw, sh))
    buckets.compiled = capture
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", jr.ValidityWarning)
            jr.resistance_map(pf.material, wlf.shift, jr.Layer(0.01), radius=0.01, load=10.0,
                              temperatures=np.linspace(253.15, 373.15, 9), speeds=np.logspace(-3, 1, 9))
    finally:
        buckets.compiled = original
    fn, args, static = max(seen, key=lambda s: len(fn_text(*s)))
    return fn, args, static


def fit_program(every=4):
    """``(fn, args)`` of the first evaluation (residuals and Jacobian) of ``jr.fit_material`` on
    the shipped sphere benchmark (``fit_profile.py --geometry sphere``; every ``every``-th point),
    captured from the library: the fit is stopped there."""
    from jaxroll.identify import fit as fit_module

    data = fit_module.read_rolling_csv(jr.datasets.path("fit_sphere.csv"))
    keep = np.arange(len(data.speed)) % every == 0
    data = fit_module.RollingData(data.speed[keep], data.load[keep], data.value[keep], data.sigma[keep])
    from jaxroll import _compilation_cache

    inner, call, seen = fit_module._residuals_and_jacobian_jit, _compilation_cache.call, []

    class Captured(Exception):
        pass

    def capture(fn, *args, **kw):
        if fn is not inner:  # the grid rule's sizing programs go through call() too
            return call(fn, *args, **kw)
        seen.append(args)
        raise Captured

    _compilation_cache.call = capture
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit_module.fit_material(data, initial=jr.StandardLinearSolid(G0=2e6, tau=0.35, f=0.7),
                                    layer=jr.Layer(H=float("inf")), radius=0.02, geometry="sphere", absolute_sigma=True)
    except Captured:
        pass
    finally:
        _compilation_cache.call = call
    return inner, seen[0], {}


def fn_text(fn, args, static):
    return fn.lower(*args, **static).as_text()


def lowered_of(name, programs):
    """``(lower, run)``: a function that lowers the program anew (after ``jax.clear_caches``, so
    that no compilation is served from JAX's in-memory caches) and one that runs a compiled one."""
    if name in ("map", "fit"):
        fn, args, static = map_program() if name == "map" else fit_program()
        return (lambda: fn.lower(*args, **static)), (lambda c: c(*args, **static))
    fn, args = programs[name]
    return (lambda: jax.jit(fn).lower(*args)), (lambda c: c(*args))


def max_rel_diff(a, b) -> float:
    diffs = [0.0]
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        x, y = np.asarray(x, float), np.asarray(y, float)
        if x.size:  # relative to each entry (an exact zero: absolute)
            diffs.append(float(np.max(np.abs(x - y) / np.maximum(np.abs(x), 1e-300))))
    return max(diffs)


def measure(name, lower, run, sets, rounds, repeat):
    comp = {s: [] for s in sets}
    wall = {s: [] for s in sets}
    runs = {s: [] for s in sets}
    run_cpu = {s: [] for s in sets}
    outs = {}
    for r in range(rounds):
        for s in (sets if r % 2 == 0 else sets[::-1]):
            jax.clear_caches()
            lowered = lower()
            c0, w0 = time.process_time(), time.perf_counter()
            compiled = lowered.compile(dict(OPTION_SETS[s]))
            comp[s].append(time.process_time() - c0)
            wall[s].append(time.perf_counter() - w0)
            outs[s] = jax.block_until_ready(run(compiled))
            for _ in range(repeat):
                t, c0 = time.perf_counter(), time.process_time()
                jax.block_until_ready(run(compiled))
                runs[s].append(time.perf_counter() - t)
                run_cpu[s].append(time.process_time() - c0)
            del compiled
    base = sets[0]
    c_base, r_base = statistics.median(comp[base]), statistics.median(run_cpu[base])
    rows = []
    for s in sets:
        c, w = statistics.median(comp[s]), statistics.median(wall[s])
        t, tw = statistics.median(run_cpu[s]), statistics.median(runs[s])
        diff = max_rel_diff(outs[base], outs[s])
        print(f"{name:15s} {s:15s} compile {c:6.2f} s CPU ({w:6.2f} s wall) = {c / c_base:4.2f}x; run {t:7.4f} s "
              f"CPU ({tw:7.4f} s wall) = {t / r_base:4.2f}x; max rel diff {diff:.1e}; "
              f"load {os.getloadavg()[0]:.1f}", flush=True)
        rows.append(dict(program=name, set=s, compile_cpu_s=c, compile_wall_s=w, run_cpu_s=t, run_wall_s=tw,
                         max_rel_diff=diff))
    return rows


FIRST_CALL = r"""
import json, time
c0, w0 = time.process_time(), time.perf_counter()
import jaxroll as jr
r = jr.rolling_resistance(jr.StandardLinearSolid(3e6, 0.25, 1.0), jr.Layer(0.03), radius=0.02, load=100.0, speed=0.01)
print(json.dumps({"cpu": time.process_time() - c0, "wall": time.perf_counter() - w0, "value": float(r.value)}))
"""


def first_calls(rounds):
    """A new user's first call of the default sphere point in a new interpreter (import, grid
    sizing, compiles, storing the programs in an empty compilation cache; no ``XLA_FLAGS``), with
    jaxroll's options and without (``JAXROLL_XLA_OPTIONS=0``), alternating."""
    import json
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    root = str(Path(__file__).resolve().parent.parent)
    rows = []
    for _ in range(rounds):
        for switch in ("1", "0"):
            env = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", "JAX_COMPILATION_CACHE_DIR")}
            with tempfile.TemporaryDirectory(prefix="jaxroll-first-call-") as cache:
                env |= {"JAXROLL_COMPILATION_CACHE": cache, "JAXROLL_XLA_OPTIONS": switch,
                        "TF_CPP_MIN_LOG_LEVEL": "3",
                        "PYTHONPATH": os.pathsep.join(filter(None, [root, env.get("PYTHONPATH")]))}
                out = json.loads(subprocess.run([sys.executable, "-c", FIRST_CALL], env=env, capture_output=True,
                                                text=True, check=True).stdout.strip().splitlines()[-1])
            print(f"first call, {'jaxroll options' if switch == '1' else 'XLA defaults  '}: {out['cpu']:5.2f} s CPU "
                  f"({out['wall']:5.2f} s wall); R_r = {out['value']!r} N; load {os.getloadavg()[0]:.1f}", flush=True)
            rows.append(dict(options=switch == "1", cpu_s=out["cpu"], wall_s=out["wall"], value=out["value"]))
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--programs", nargs="+", default=["reference", "reference-grad", "point", "point-grad", "map"])
    ap.add_argument("--sets", nargs="+", default=["base", "O2", "emitters+O2"],
                    choices=list(OPTION_SETS))
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--first-call", action="store_true",
                    help="only a new interpreter's first call of the default sphere point, options on and off")
    ap.add_argument("--record", action="store_true",
                    help="store the rows in benchmarks/numbers.json (section compile_options, or "
                    "compile_options_first_call with --first-call; benchmarks/render_docs.py draws the table)")
    args = ap.parse_args()
    command = "python benchmarks/compile_options.py " + (
        f"--first-call --rounds {args.rounds}" if args.first_call else
        f"--programs {' '.join(args.programs)} --sets {' '.join(args.sets)} --rounds {args.rounds} "
        f"--repeat {args.repeat}")
    load_start = round(os.getloadavg()[0], 1)
    if args.first_call:
        rows = first_calls(args.rounds)
        if args.record:
            from _numbers import record

            record("compile_options_first_call", {"command": command, "load_start": load_start, "rows": rows})
        return
    sets = ["base"] + [s for s in args.sets if s != "base"]
    jax.config.update("jax_enable_compilation_cache", False)
    print(f"device: {jax.devices()[0].device_kind}; cpu count {os.cpu_count()}; load avg {os.getloadavg()[0]:.1f}")
    programs = {}
    if any(p.startswith("reference") for p in args.programs):
        programs.update(reference_programs())
    if any(p.startswith("point") for p in args.programs):
        programs.update(point_programs())
    rows = []
    for name in args.programs:
        lower, run = lowered_of(name, programs)
        rows += measure(name, lower, run, sets, args.rounds, args.repeat)
    if args.record:
        from _numbers import record

        record("compile_options", {"command": command, "load_start": load_start, "rows": rows,
                                   "options": {s: OPTION_SETS[s] for s in sets}})


if __name__ == "__main__":
    main()
