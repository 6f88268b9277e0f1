"""Benchmark of jaxroll.sweep: points per second against device count, and chunking strategies.

Usage::

    python benchmarks/bench_sweep.py                       # default workloads, 1/2/4/8 devices
    python benchmarks/bench_sweep.py --workloads series --points 20000 --devices 1,2
    python benchmarks/bench_sweep.py --workloads direct --points 1000000   # issue 9 target
    python benchmarks/bench_sweep.py --strategies-only
    python benchmarks/bench_sweep.py --quick               # reduced: 1,2 devices, small workloads

What it measures
----------------
1. Scaling: each device count runs in its own process (``XLA_FLAGS=
   --xla_force_host_platform_device_count=k`` must be set before jax is imported). For each
   workload, through the public ``jr.sweep``: the first call (trace + compile + run), then the
   median of ``--reps`` further calls, timed with ``block_until_ready``; compile = first minus
   median; points/s and the speed-up against 1 device; on GPU, the device memory high-water
   mark (``memory_stats()["peak_bytes_in_use"]``).
   **On CPU the forced host devices share the machine's cores** (2 here, shared with other
   jobs): they measure the sharding overhead and correctness, not real scaling. On a GPU host
   ``--devices`` is capped at the real device count and ``XLA_FLAGS`` is left alone.
2. Strategies (one device): ``sweep`` with several chunk sizes vs one ``jit(vmap)`` over all
   points vs ``lax.map(batch_size=...)`` vs a host loop over a jitted chunk; time, and the
   compiled working memory of the ``jit`` strategies (cf. docs/design.md sec. 4: chunks of 1 took 3.6 s / 7 MiB against a
   full vmap's 4.7-5.7 s / 2-5 GB for 345 cases x 5000 modes).

Workloads (see ``WORKLOADS``; the HOOK section is where the real models plug in):

* ``modulus``: tan delta of a standard linear solid at omega = V/a -- a few flops per point.
* ``series``: a stand-in for the direct method: periodic Hertz-sphere-like series over
  ``--modes`` Fourier modes on a half-space (``Im T = Im 1/(2 conj(G*(qV)) q)``) per point.
* ``direct``: ``jr.rolling_resistance(method=jr.Direct())`` (aperiodic, sphere, H = 5 mm);
  issue 9 asks for >= 1e6 points.
* ``full2d``: ``jr.rolling_resistance(geometry="cylinder", method=jr.Full(grid))`` with the grid
  resolved once over the envelope of the sweep (``method.resolve``); issue 9 asks for >= 1e4
  points.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without install


# ------------------------------------------------------------------------------------------
# workloads: each returns (fn, points_or_grid, description)
# ------------------------------------------------------------------------------------------


def _grid_2d(n, jnp, jr):
    """About n points: speeds x loads (log-spaced speeds 1e-4..1 m/s, loads 10..150 N)."""
    n_v = max(1, int(round((n * 23 / 15) ** 0.5)))
    n_p = max(1, int(round(n / n_v)))
    return jr.Grid(V=jnp.logspace(-4.0, 0.0, n_v), P=jnp.linspace(10.0, 150.0, n_p))


def workload_modulus(n, args):
    import jax.numpy as jnp

    import jaxroll as jr

    grid = _grid_2d(n, jnp, jr)
    mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    return (lambda p: jr.materials.tan_delta(mat, p.V / 1e-3)), grid, "tan delta at omega = V/1 mm"


def workload_series(n, args):
    import jax.numpy as jnp

    import jaxroll as jr

    grid = _grid_2d(n, jnp, jr)
    mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    R, L, M = 0.02, 0.2, args.modes
    q = 2 * jnp.pi * jnp.arange(1, M + 1) / L

    def fn(p):
        a = (3.0 * p.P * R / (4.0 * 4.0 * mat.G0)) ** (1.0 / 3.0)  # Hertz, E* = 4 G0
        x = q * a
        S = 3.0 * (jnp.sin(x) - x * jnp.cos(x)) / x**3
        G = jnp.conj(jr.complex_modulus(mat, q * p.V))
        imT = jnp.imag(1.0 / (2.0 * G * q))
        return 2.0 * p.P**2 / L * jnp.sum(q * S**2 * imT)

    return fn, grid, f"direct-series stand-in, {M} modes, half-space"


# ---- the real models -----------------------------------------------------------------------
# Each returns (fn, grid, description) with fn(point) -> scalar; a workload that raises is
# reported as "unavailable: <error>". Issue 9 targets: direct >= 1e6 points
# (--workloads direct --points 1000000: ~1 min per device count here), full 2D >= 1e4 points
# (--workloads full2d --points 10000).


def workload_direct(n, args):
    import jax.numpy as jnp

    import jaxroll as jr

    grid = _grid_2d(n, jnp, jr)
    mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    layer = jr.Layer(5e-3)
    method = jr.Direct()

    def fn(p):
        return jr.rolling_resistance(mat, layer, radius=0.02, load=p.P, speed=p.V, method=method, throw=False).value

    return fn, grid, "jr.rolling_resistance(method=jr.Direct()), sphere, H = 5 mm, aperiodic, rtol 1e-4"


def workload_full2d(n, args):
    import jax.numpy as jnp

    import jaxroll as jr

    # Inside a sweep the inputs are traced, so the grid is resolved once from the concrete
    # envelope of the sweep (25 cells per smallest half-width, automatic period), as a user does.
    n_v = max(1, n // 15 + (n % 15 > 0))
    grid = jr.Grid(V=jnp.logspace(-4.0, -1.0, n_v), P=jnp.linspace(1e3, 1e4, min(n, 15)))
    mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    layer = jr.Layer(5e-3)
    method = jr.Full(grid=jr.AutoGrid(cells_per_radius=25)).resolve(
        mat, layer, radius=0.02, loads=grid.axes["P"], speeds=grid.axes["V"], geometry="cylinder")

    def fn(p):
        return jr.rolling_resistance(mat, layer, radius=0.02, load=p.P, speed=p.V, geometry="cylinder",
                                     method=method, throw=False).value

    g = method.grid
    desc = (f"jr.rolling_resistance(geometry='cylinder', method=jr.Full(resolved grid)), H = 5 mm, P' 1-10 kN/m, "
            f"V 1e-4..0.1 m/s, {g.n_cells[0]} period cells, window {g.window}")
    return fn, grid, desc


# ---- end of HOOK --------------------------------------------------------------------------

WORKLOADS = {
    "modulus": (workload_modulus, 1_000_000),
    "series": (workload_series, 20_000),
    "direct": (workload_direct, 100_000),
    "full2d": (workload_full2d, 60),
}


# ------------------------------------------------------------------------------------------
# child: one device count
# ------------------------------------------------------------------------------------------


def _time(call, reps):
    t0 = time.perf_counter()
    call()
    first = time.perf_counter() - t0
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return first, statistics.median(times)


def run_child(args) -> None:
    import jax

    import jaxroll as jr

    n_dev = jax.device_count()
    rows = []
    for name in args.workloads:
        make, default_n = WORKLOADS[name]
        n = args.points or ((30 if name == "full2d" else 2000) if args.quick else default_n)
        try:
            fn, pts, desc = make(n, args)
            call = lambda: jax.block_until_ready(jr.sweep(fn, pts, chunk_size=args.chunk_size))
            first, med = _time(call, args.reps)
            compile_s = first - med  # jr.sweep compiles on its first call
            size = pts.size if isinstance(pts, jr.Grid) else len(jax.tree_util.tree_leaves(pts)[0])
            stats = [d.memory_stats() or {} for d in jax.local_devices()]  # None on CPU
            peak = max((st.get("peak_bytes_in_use", 0) for st in stats), default=0)
            rows.append(dict(workload=name, desc=desc, devices=n_dev, points=size, first_s=first, run_s=med,
                             compile_s=compile_s, points_per_s=size / med,
                             peak_mib=peak / 2**20 if peak else None))
        except Exception as e:  # noqa: BLE001  (a hook that is not ready yet)
            rows.append(dict(workload=name, devices=n_dev, error=f"{type(e).__name__}: {str(e)[:200]}"))
    print("JSON" + json.dumps(rows), flush=True)


def run_strategies(args) -> None:
    """One device: sweep chunk sizes vs jit(vmap) vs lax.map vs a host loop."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    import jaxroll as jr

    n = args.strategy_points
    fn, grid, desc = workload_series(n, argparse.Namespace(modes=args.strategy_modes))
    pts = grid.points()
    n = grid.size
    print(f"\nStrategies on 1 device: {desc}, {n} points, {jax.devices()[0].platform}, float64, "
          f"median of {args.reps}")
    print(f"{'strategy':<34}{'compile s':>10}{'run s':>9}{'points/s':>11}{'temp MiB':>10}")
    ref = np.asarray(jax.jit(jax.vmap(fn))(pts))

    def report(label, call, compiled=None):
        first, med = _time(call, args.reps)
        out = np.asarray(call())
        err = np.max(np.abs(out.ravel() - ref.ravel())) / np.max(np.abs(ref))
        mem = f"{compiled().memory_analysis().temp_size_in_bytes / 2**20:>10.1f}" if compiled else f"{'n/a':>10}"
        print(f"{label:<34}{first - med:>10.2f}{med:>9.3f}{n / med:>11.3g}{mem}   (rel. diff {err:.1e})")

    dev = jax.devices()[:1]
    for cs in args.strategy_chunks:
        report(f"sweep chunk_size={cs}", lambda cs=cs: jax.block_until_ready(jr.sweep(fn, grid, chunk_size=cs,
                                                                                      devices=dev)))
    full = jax.jit(jax.vmap(fn))
    report("jit(vmap(fn)) all points", lambda: jax.block_until_ready(full(pts)), lambda: full.lower(pts).compile())
    for bs in (1, 16):
        lm = jax.jit(lambda p, bs=bs: jax.lax.map(fn, p, batch_size=bs))
        report(f"jit(lax.map(batch_size={bs}))", lambda lm=lm: jax.block_until_ready(lm(pts)), lambda lm=lm: lm.lower(pts).compile())
    chunk = 256
    vm = jax.jit(jax.vmap(fn))

    def host_loop():
        outs = [vm(jax.tree.map(lambda x: x[i:i + chunk], pts)) for i in range(0, n - n % chunk, chunk)]
        if n % chunk:
            outs.append(vm(jax.tree.map(lambda x: x[n - n % chunk:], pts)))  # second compile
        return jax.block_until_ready(jnp.concatenate(outs))

    piece = jax.tree.map(lambda x: x[:chunk], pts)
    report(f"host loop over jit(vmap), chunk {chunk}", host_loop, lambda: vm.lower(piece).compile())

    # reverse mode: d/dG0 of the sum over the sweep, with and without jax.checkpoint per chunk
    R, L, M = 0.02, 0.2, args.strategy_modes
    q = 2 * jnp.pi * jnp.arange(1, M + 1) / L
    print("\nGradient d(sum R_r)/dG0 through sweep (chunk_size=16, 1 device), same workload")
    print(f"{'checkpoint':<34}{'compile s':>10}{'run s':>9}{'points/s':>11}{'temp MiB':>10}")
    for cp in (False, True):
        def loss(G0, cp=cp):
            mat = jr.StandardLinearSolid(G0, 0.25, 1.0)

            def fn(p):
                a = (3.0 * p.P * R / (16.0 * mat.G0)) ** (1.0 / 3.0)
                x = q * a
                S = 3.0 * (jnp.sin(x) - x * jnp.cos(x)) / x**3
                G = jnp.conj(jr.complex_modulus(mat, q * p.V))
                return 2.0 * p.P**2 / L * jnp.sum(q * S**2 * jnp.imag(1.0 / (2.0 * G * q)))

            return jnp.sum(jr.sweep(fn, grid, chunk_size=16, devices=dev, checkpoint=cp))

        g = jax.jit(jax.grad(loss))
        first, med = _time(lambda: jax.block_until_ready(g(3e6)), args.reps)
        mem = g.lower(3e6).compile().memory_analysis().temp_size_in_bytes / 2**20
        print(f"{str(cp):<34}{first - med:>10.2f}{med:>9.3f}{n / med:>11.3g}{mem:>10.1f}")


# ------------------------------------------------------------------------------------------
# parent
# ------------------------------------------------------------------------------------------


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workloads", default="modulus,series,direct,full2d")
    ap.add_argument("--devices", default="1,2,4,8")
    ap.add_argument("--points", type=int, default=None, help="points per workload (default: per workload)")
    ap.add_argument("--chunk-size", type=int, default=None)
    ap.add_argument("--modes", type=int, default=500)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--strategies-only", action="store_true")
    ap.add_argument("--no-strategies", action="store_true")
    ap.add_argument("--strategy-points", type=int, default=345, help="docs/design.md sec. 4 used 345 x 5000")
    ap.add_argument("--strategy-modes", type=int, default=5000)
    ap.add_argument("--strategy-chunks", default="1,8,64,256")
    ap.add_argument("--quick", action="store_true",
                    help="reduced: devices 1,2; 2000 points (full2d 30); strategies on 64 points x 500 modes")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.quick and not args.child:
        args.devices, args.strategy_points, args.strategy_modes, args.strategy_chunks = "1,2", 64, 500, "1,16"
        args.reps = min(args.reps, 2)
    args.workloads = [w for w in args.workloads.split(",") if w]
    args.strategy_chunks = [int(c) for c in args.strategy_chunks.split(",")]
    for w in args.workloads:
        if w not in WORKLOADS:
            ap.error(f"unknown workload {w!r}; choose from {sorted(WORKLOADS)}")
    if args.child:
        run_child(args)
        return 0

    if not args.strategies_only:
        gpu = _has_accelerator()
        rows = []
        for k in [int(d) for d in args.devices.split(",")]:
            env = dict(os.environ)
            if not gpu:
                env["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={k}"
                env["JAX_PLATFORMS"] = "cpu"
            cmd = [sys.executable, __file__, "--child", "--workloads", ",".join(args.workloads),
                   "--modes", str(args.modes), "--reps", str(args.reps)]
            if args.points:
                cmd += ["--points", str(args.points)]
            elif args.quick:
                cmd += ["--quick"]
            if args.chunk_size:
                cmd += ["--chunk-size", str(args.chunk_size)]
            if gpu:
                env["CUDA_VISIBLE_DEVICES"] = ",".join(str(i) for i in range(k))
            proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
            line = [ln for ln in proc.stdout.splitlines() if ln.startswith("JSON")]
            if proc.returncode or not line:
                print(f"devices={k}: child failed\n{proc.stderr[-2000:]}")
                continue
            rows += json.loads(line[-1][4:])
        _print_table(rows, gpu)
    if not args.no_strategies:
        run_strategies(args)
    return 0


def _has_accelerator() -> bool:
    out = subprocess.run([sys.executable, "-c", "import jax; print(jax.default_backend())"],
                         capture_output=True, text=True).stdout.strip()
    return out not in ("", "cpu")


def _print_table(rows, gpu) -> None:
    import platform

    where = "GPU" if gpu else f"CPU, forced host devices sharing {os.cpu_count()} cores"
    print(f"sweep throughput ({where}; {platform.node()}; float64; default chunk_size unless --chunk-size)")
    print(f"{'workload':<10}{'devices':>8}{'points':>10}{'compile s':>10}{'run s':>9}{'points/s':>11}"
          f"{'x vs 1':>8}{'peak MiB/dev':>13}")
    base = {}
    for r in rows:
        if "error" in r:
            print(f"{r['workload']:<10}{r['devices']:>8}   unavailable: {r['error']}")
            continue
        base.setdefault(r["workload"], r["points_per_s"])
        print(f"{r['workload']:<10}{r['devices']:>8}{r['points']:>10}{r['compile_s']:>10.2f}{r['run_s']:>9.3f}"
              f"{r['points_per_s']:>11.3g}{r['points_per_s'] / base[r['workload']]:>8.2f}"
              f"{(format(r['peak_mib'], '.1f') if r['peak_mib'] is not None else 'n/a (CPU)'):>13}")
    descs = {r["workload"]: r["desc"] for r in rows if "desc" in r}
    for k, v in descs.items():
        print(f"  {k}: {v}")
    from _timing import summary

    for r in rows:
        if "error" not in r:
            summary(f"bench_sweep.py {r['workload']} ({r['devices']} device(s))", r["run_s"], r["compile_s"],
                    "1 device" if r["devices"] > 1 else "", f"{r['points_per_s'] / base[r['workload']]:.2f}x",
                    f"{r['points']} points, {r['points_per_s']:.3g} points/s, forced host devices on 2 shared cores")


if __name__ == "__main__":
    sys.exit(main())
