"""Batched full 3D model: cost per point of every batched entry point against the warm-started table.

    python benchmarks/bench_batched.py [--quick] [--repeat 5] [--only reference|map|vmap|fit]

Rows (the paper's sphere: SLS G0 = 3 MPa, tau = 0.25 s, f = 1, R = 2 cm, H = 30 mm, infinite
layer, cells 0.25 mm, window 55; ``--quick``: cells 0.5 mm, window 29):

* ``table``: ``jr.rolling_resistance_grid`` (``Full.evaluate_grid``: kernel once per speed, each
  load warm-started from the previous one), speeds 1e-4..1 m/s x loads 10..150 N; the baseline
  of every ratio;
* ``single``: ``jr.rolling_resistance``, one point per call (front door, compiled), 100 N, 0.01 m/s;
* ``points``: ``Full.evaluate_points`` on the table's points (one ``lax.scan``, warm starts
  along it, a kernel per point);
* ``vmap H x20``: ``jax.jit(jax.vmap(front door))`` over 20 thicknesses 5..50 mm (the batching
  rule of ``Full.evaluate``: one warm-started scan in the order of the counting sizes)
  and ``points H x20``: ``Full.evaluate_points`` with the layer batched;
* ``map``: ``jr.resistance_map`` of the shipped measured Prony material
  (``pyvisco_freq_user_raw.csv``: WLF, Prony fit) on a 10 mm layer, 10 N, R = 1 cm, 253..373 K x
  1e-3..10 m/s, values with dR/dT and dR/dH (automatic grid: each point on the grid the regime
  rule asks for, one warm-started scan per grid class), with its baseline: the tables of the
  same reduced speeds ``V a_T`` (one load) on the same grids, without derivatives, and the map's
  points without derivatives (``jaxroll.buckets.evaluate_buckets``: the map's grid classes, each one
  warm-started scan in the order of the reduced speed), which splits the map's cost into its values
  and its derivatives; ``--vmap-map`` adds the map's program before batching (``jax.vmap`` of
  ``value_and_grad`` of the front door);
* ``jr.sweep H x20``: the front door over the same 20 thicknesses through ``jr.sweep``, chunks
  vectorised (default) and ``vectorize=False`` (points one after the other);
* ``fit evaluation``: what ``jr.fit_material`` evaluates per least-squares step on the reference
  case's grid and points (the table's speeds x loads as data, free log(G0, tau, f)): its compiled
  residuals and per-point adjoint Jacobian (``jaxroll.identify.fit._residuals_and_jacobian_jit``:
  ``Full.evaluate_points`` with the fit's default model, the smoothed edge at kappa and 2 kappa
  extrapolated), cold (each point from its neighbour, a fit's first evaluation) and warm (each
  point from its own solution at parameters 1 % away, as a fit's later evaluations start).

Each program is compiled ahead of time (compile column), then the baseline and the entry are run
alternately ``--repeat`` times in the same process (the machine is shared: both see the same
load); medians. Prints the device, the load average and a markdown table.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without install

import equinox as eqx  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxroll as jr  # noqa: E402
from _timing import summary  # noqa: E402

R = 0.02
MAT = jr.StandardLinearSolid(3e6, 0.25, 1.0)


def _compile(fn, *args):
    t = time.perf_counter()
    compiled = jax.jit(fn).lower(*args).compile()
    return compiled, time.perf_counter() - t


def _alternate(pairs, repeat):
    """Median seconds of each ``(compiled, args)`` in ``pairs``, run alternately ``repeat`` times
    after one warm-up each."""
    for f, a in pairs:
        jax.block_until_ready(f(*a))
    runs = [[] for _ in pairs]
    for _ in range(repeat):
        for k, (f, a) in enumerate(pairs):
            t = time.perf_counter()
            jax.block_until_ready(f(*a))
            runs[k].append(time.perf_counter() - t)
    return [statistics.median(r) for r in runs]


def reference_rows(args, rows):
    cells, window = (5e-4, 29) if args.quick else (2.5e-4, 55)
    method = jr.Full(grid=jr.FixedGrid(cells, window))
    speeds = jnp.asarray(np.logspace(-4, 0, 6 if args.quick else 23))
    loads = jnp.asarray(np.linspace(10.0, 150.0, 15))
    n = speeds.size * loads.size

    def table(G0, H, P, V):
        return jr.rolling_resistance_grid(jr.StandardLinearSolid(G0, 0.25, 1.0), jr.Layer(H), radius=R, loads=P,
                                          speeds=V, method=method).value

    def single(G0, H, P, V):
        return jr.rolling_resistance(jr.StandardLinearSolid(G0, 0.25, 1.0), jr.Layer(H), radius=R, load=P, speed=V,
                                     method=method, throw=False).value

    def points(G0, H, P, V):
        return method.evaluate_points(jr.StandardLinearSolid(G0, 0.25, 1.0), jr.Layer(H), R, P, V, "sphere",
                                      axes=(None, None, None, 0, 0)).value

    Hs = jnp.asarray(np.linspace(0.005, 0.05, 20))

    def vmap_H(Hs):
        return jax.vmap(lambda H: single(3e6, H, 100.0, 0.01))(Hs)

    def points_H(Hs):
        return method.evaluate_points(MAT, jr.Layer(Hs), R, 100.0, 0.01, "sphere",
                                      axes=(None, 0, None, None, None)).value

    def sweep_H(Hs, vectorize):
        return jr.sweep(lambda H: single(3e6, H, 100.0, 0.01), Hs, vectorize=vectorize)

    VV, PP = (x.ravel() for x in jnp.meshgrid(speeds, loads, indexing="ij"))
    base = (3e6, 0.03, loads, speeds)
    if args.only == "vmap":
        return _vmap_rows(args, rows, n, (table, base), single, (vmap_H, points_H, Hs))
    t_c, c_table = _compile(table, *base)
    if args.only == "fit":
        return _fit_rows(args, rows, n, t_c, c_table, base, _fit_evaluation(method.grid, PP, VV, t_c(*base).ravel()))
    s_c, c_single = _compile(single, 3e6, 0.03, 100.0, 0.01)
    p_c, c_points = _compile(points, 3e6, 0.03, PP, VV)
    v_c, c_vmap = _compile(vmap_H, Hs)
    h_c, c_pH = _compile(points_H, Hs)
    sv_c, c_sv = _compile(lambda Hs: sweep_H(Hs, True), Hs)
    ss_c, c_ss = _compile(lambda Hs: sweep_H(Hs, False), Hs)
    fit_eval, c_fit = _fit_evaluation(method.grid, PP, VV, t_c(*base).ravel())
    rep = args.repeat
    t_table, t_single, t_points = _alternate([(t_c, base), (s_c, (3e6, 0.03, 100.0, 0.01)),
                                              (p_c, (3e6, 0.03, PP, VV))], rep)
    check = float(jnp.max(jnp.abs(p_c(3e6, 0.03, PP, VV) / t_c(*base).ravel() - 1)))
    t_table2, t_vmap, t_pH = _alternate([(t_c, base), (v_c, (Hs,)), (h_c, (Hs,))], rep)
    check_H = float(jnp.max(jnp.abs(h_c(Hs) / v_c(Hs) - 1)))
    t_table4, t_sv, t_ss = _alternate([(t_c, base), (sv_c, (Hs,)), (ss_c, (Hs,))], rep)
    per = lambda t, k: t / k  # noqa: E731
    ref = statistics.median([per(t_table, n), per(t_table2, n), per(t_table4, n)])
    size = f"{speeds.size}x{loads.size}, cells {cells * 1e3:g} mm, window {window}"
    rows += [
        ("table (warm-started, baseline)", per(t_table, n), c_table, 1.0, f"{size}; {n} points"),
        ("single point (front door)", per(t_single, 1), c_single, per(t_single, 1) / per(t_table, n),
         "100 N, 0.01 m/s, cold start"),
        ("points (Full.evaluate_points)", per(t_points, n), c_points, per(t_points, n) / per(t_table, n),
         f"the table's {n} points, kernel per point; max |rel diff| to the table {check:.1e}"),
        ("jit(vmap(front door)) H x20", per(t_vmap, 20), c_vmap, per(t_vmap, 20) / per(t_table2, n),
         f"20 thicknesses 5..50 mm, 100 N, 0.01 m/s: {t_vmap:.3f} s"),
        ("points, layer batched, H x20", per(t_pH, 20), c_pH, per(t_pH, 20) / per(t_table2, n),
         f"the same 20 points: {t_pH:.3f} s; max |rel diff| to the vmap {check_H:.1e}"),
        ("jr.sweep H x20 (vectorize=True, chunks of 16)", per(t_sv, 20), c_sv, per(t_sv, 20) / per(t_table4, n),
         f"front door per point: {t_sv:.3f} s"),
        ("jr.sweep H x20 (vectorize=False)", per(t_ss, 20), c_ss, per(t_ss, 20) / per(t_table4, n),
         f"front door per point, one after the other: {t_ss:.3f} s"),
    ]
    _fit_rows(args, rows, n, t_c, c_table, base, (fit_eval, c_fit), table_row=False)
    return ref


def _fit_rows(args, rows, n, t_c, c_table, base, fit, table_row=True):
    """The two fit-evaluation rows (``fit = (call, compile seconds)`` of :func:`_fit_evaluation`),
    each run alternating with the table ``t_c(*base)``; ``table_row``: the table's own row first
    (``--only fit``)."""
    fit_eval, c_fit = fit
    t_table, t_cold, t_warm = _alternate([(t_c, base), (fit_eval, (False,)), (fit_eval, (True,))], args.repeat)
    table = t_table / n
    rows += [("table (warm-started, baseline)", table, c_table, 1.0, f"{n} points")] if table_row else []
    rows += [
        ("fit evaluation, cold (r and per-point adjoint J, 3 params)", t_cold / n, c_fit, t_cold / n / table,
         f"the fit's program on the table's {n} points, smoothed edge at kappa and 2 kappa extrapolated; "
         f"{t_cold:.2f} s per evaluation"),
        ("fit evaluation, warm (each point from its solution 1 % away)", t_warm / n, 0.0, t_warm / n / table,
         f"the same program: {t_warm:.2f} s per evaluation; {fit_eval.check}"),
    ]
    return table


def _fit_evaluation(grid, P, V, values):
    """``(call, compile seconds)``: ``call(warm)`` runs the fit's compiled residual and Jacobian
    (:func:`jaxroll.identify.fit._residuals_and_jacobian_jit`, the fit's default model on
    ``grid``) at the paper's material with the points ``(P, V)`` as data (``values``, 2 %
    sigma), cold (no starts) or warm (each point from its solution at log-parameters 1 % away);
    ``call.check`` states how far the warm evaluation is from the cold one."""
    from jaxroll.identify.fit import (RollingData, _data_arrays, _Params, _point_starts, _Problem,
                                      _residuals_and_jacobian_jit)
    from jaxroll.methods import default_method

    method = eqx.tree_at(lambda m: m.grid, default_method("sphere", fit=True), grid)
    data = RollingData(np.asarray(V), np.asarray(P), np.asarray(values), 0.02 * np.asarray(values))
    model = (MAT, jr.Layer(0.03), None)
    params = _Params.of(model, ("G0", "tau", "f"), None)
    problem = _Problem.of(params, R, "sphere", method, None)
    arrays = _data_arrays(data, None, method)
    lp = jnp.asarray(params.logp0(model))
    none = _point_starts(problem, model, arrays)
    if none is None:  # the per-point reverse pass keeps every point's solve: over the budget, forward mode
        raise SystemExit(f"the fit's per-point Jacobian of {len(values)} points on this grid needs more than "
                         f"jr.grids.memory_budget() ({jr.grids.memory_budget() / 2**30:.1f} GiB here); try --quick")
    t = time.perf_counter()
    jax.block_until_ready(_residuals_and_jacobian_jit(lp, model, arrays, problem, none))
    comp = time.perf_counter() - t  # compile and one evaluation
    near = _residuals_and_jacobian_jit(lp + 0.01, model, arrays, problem, none)[2]

    def call(warm):
        return _residuals_and_jacobian_jit(lp, model, arrays, problem, near if warm else none)

    cold, warm = call(False), call(True)
    dr = float(jnp.max(jnp.abs(warm[0] - cold[0])))
    dJ = float(jnp.max(jnp.abs(warm[1] - cold[1])) / jnp.max(jnp.abs(cold[1])))
    call.check = f"max |r warm - r cold| {dr:.1e} sigma, max |J warm - J cold| {dJ:.1e} of max |J|"
    return call, comp


def map_rows(args, rows):
    from jaxroll.buckets import evaluate_buckets

    sw = jr.read_dma_sweeps(jr.datasets.path("pyvisco_freq_user_raw.csv"))
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    wlf, pf = jr.fit_wlf(sh), jr.fit_prony(jr.master_curve(sw, sh))
    k = 7 if args.quick else 25
    Ts, Vs = np.linspace(253.15, 373.15, k), np.logspace(-3, 1, k)
    layer, radius, load = jr.Layer(0.01), 0.01, 10.0

    def run_map():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", jr.ValidityWarning)
            return jr.resistance_map(pf.material, wlf.shift, layer, radius=radius, load=load, temperatures=Ts,
                                     speeds=Vs, geometry="sphere")

    t = time.perf_counter()
    m = run_map()
    first = time.perf_counter() - t
    # the baseline: the tables of the same reduced speeds V a_T (one load), one per grid class of
    # the map (jr.grids.AutoGrid.buckets: the grid each point asks for alone), one after the other
    aT = np.exp(np.asarray(wlf.shift.log_shift(jnp.asarray(Ts))))
    reduced_all = (aT[:, None] * Vs[None, :]).ravel()
    buckets = jr.Full().grid.buckets(pf.material, layer, radius, np.full(reduced_all.size, load), reduced_all,
                                     "sphere")
    tables, comp = [], 0.0
    for grid, idx in buckets:
        method = jr.Full(grid=grid)
        speeds = jnp.asarray(np.sort(reduced_all[idx]))

        def table(V, method=method):
            return jr.rolling_resistance_grid(pf.material, layer, radius=radius, loads=jnp.asarray([load]), speeds=V,
                                              method=method).value

        compiled, seconds = _compile(table, speeds)
        tables.append((compiled, speeds))
        comp += seconds

    def run_tables():
        return [f(V) for f, V in tables]

    jax.block_until_ready(run_tables())

    def run_values():  # the map's points without derivatives: each grid class one warm-started scan
        return evaluate_buckets(jr.Full(), pf.material, layer, radius, load, reduced_all, "sphere",
                                           buckets=buckets)

    values = run_values()
    vmapped = (_vmapped_map(pf, wlf, layer, radius, load, Ts, Vs, jr.Full(grid=jr.grids.union([g for g, _ in buckets])))
               if args.vmap_map else None)
    t_map, t_table, t_vmapped, c_map, c_table, t_values, c_values = [], [], [], [], [], [], []
    for _ in range(args.repeat):
        t, c = time.perf_counter(), time.process_time()
        jax.block_until_ready(run_tables())
        t_table.append(time.perf_counter() - t)
        c_table.append(time.process_time() - c)
        t, c = time.perf_counter(), time.process_time()
        run_map()
        t_map.append(time.perf_counter() - t)
        c_map.append(time.process_time() - c)
        t, c = time.perf_counter(), time.process_time()
        run_values()
        t_values.append(time.perf_counter() - t)
        c_values.append(time.process_time() - c)
        if vmapped is not None:
            t = time.perf_counter()
            out = jax.block_until_ready(vmapped[0]())
            t_vmapped.append(time.perf_counter() - t)
    n = k * k
    tm, tt = statistics.median(t_map), statistics.median(t_table)
    cm, ct = statistics.median(c_map), statistics.median(c_table)  # process CPU time: less load-dependent
    tv, cv = statistics.median(t_values), statistics.median(c_values)
    check = float(np.nanmax(np.abs(values[0].reshape(m.value.shape) / m.value - 1)))
    if vmapped is not None:
        tv = statistics.median(t_vmapped)
        diff = [float(np.nanmax(np.abs(a / np.asarray(b) - 1))) for a, b in
                zip((m.value, m.dR_dT, m.dR_dH), (out[0], out[2], out[3]))]
        rows.append((f"map {k}x{k} as before: jit(vmap(vmap(value_and_grad(front door))))", tv / n, vmapped[1], tv / tt,
                     f"{tv:.2f} s per run (the old resistance_map ran it twice per call); max rel. diff. to the new "
                     f"map: value {diff[0]:.1e}, dR/dT {diff[1]:.1e}, dR/dH {diff[2]:.1e}"))
    rows += [
        ("table of the map's reduced speeds (baseline)", tt / n, comp, 1.0,
         f"{n} speeds x 1 load, one table per grid class: "
         + ", ".join(f"window {g.window} x {len(i)}" for g, i in buckets)),
        (f"resistance_map {k}x{k} (values, dR/dT, dR/dH)", tm / n, first - tm, tm / tt,
         f"measured Prony ({pf.n_terms} terms) + WLF: {tm:.2f} s per map (call, incl. grid sizing); "
         f"{m.valid.mean() * 100:.0f} % valid; process CPU {cm:.2f} s per map, {ct:.2f} s per set of tables "
         f"({cm / ct:.2f}x)"),
        (f"map {k}x{k} values only (no derivatives)", tv / n, values[2], tv / tt,
         f"jaxroll.buckets.evaluate_buckets at the map's reduced speeds (the map's grid classes and order): {tv:.2f} s; "
         f"process CPU {cv:.2f} s ({cv / ct:.2f}x the tables'); max |rel diff| to the map's values {check:.1e}"),
    ]


def _vmapped_map(pf, wlf, layer, radius, load, Ts, Vs, method):
    """``(call, compile seconds)`` of the map program before batching: ``jax.value_and_grad`` of
    the front door w.r.t. (T, H), vmapped over both axes (what ``resistance_map`` compiled)."""
    def one(T, V, H):
        r = jr.rolling_resistance(jr.at_temperature(pf.material, wlf.shift, T), jr.Layer(H), radius=radius, load=load,
                                  speed=V, method=method, throw=False)
        return r.value, r.result

    def value_and_grads(T, V, H):
        (v, code), g = jax.value_and_grad(one, argnums=(0, 2), has_aux=True)(T, V, H)
        return v, code, g[0], g[1]

    grid = jax.vmap(jax.vmap(value_and_grads, (None, 0, None)), (0, None, None))
    args = (jnp.asarray(Ts), jnp.asarray(Vs), jnp.asarray(layer.H))
    compiled, comp = _compile(grid, *args)
    return (lambda: compiled(*args)), comp


def _vmap_rows(args, rows, n, table, single, batched):
    """``--only vmap``: the table, the single point and the two batched-thickness rows of
    :func:`reference_rows`, alternated in one loop."""
    (table, base), (vmap_H, points_H, Hs) = table, batched
    t_c, c_table = _compile(table, *base)
    s_c, c_single = _compile(single, 3e6, 0.03, 100.0, 0.01)
    v_c, c_vmap = _compile(vmap_H, Hs)
    h_c, c_pH = _compile(points_H, Hs)
    t_table, t_single, t_vmap, t_pH = _alternate([(t_c, base), (s_c, (3e6, 0.03, 100.0, 0.01)), (v_c, (Hs,)),
                                                  (h_c, (Hs,))], args.repeat)
    check_H = float(jnp.max(jnp.abs(h_c(Hs) / v_c(Hs) - 1)))
    rows += [
        ("table (warm-started, baseline)", t_table / n, c_table, 1.0, f"{n} points"),
        ("single point (front door)", t_single, c_single, t_single * n / t_table, "100 N, 0.01 m/s, cold start"),
        ("jit(vmap(front door)) H x20", t_vmap / 20, c_vmap, t_vmap / 20 * n / t_table,
         f"20 thicknesses 5..50 mm, 100 N, 0.01 m/s: {t_vmap:.3f} s"),
        ("points, layer batched, H x20", t_pH / 20, c_pH, t_pH / 20 * n / t_table,
         f"the same 20 points: {t_pH:.3f} s; max |rel diff| to the vmap {check_H:.1e}"),
    ]
    return t_table / n


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="coarse grid, 6x15 table, 7x7 map")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--only", choices=["reference", "map", "vmap", "fit"],
                    help="only the reference-case rows or the map rows; vmap: of the reference rows only the table, "
                    "the single point and the two rows over 20 thicknesses; fit: only the table and the two fit rows")
    ap.add_argument("--record", action="store_true",
                    help="store the rows in benchmarks/numbers.json (see --section)")
    ap.add_argument("--section", help="numbers.json section to record into (default: batched[_quick][_gpu]_"
                    "<only>, e.g. batched_map, batched_gpu_reference; benchmarks/render_docs.py draws the CPU and "
                    "the GPU table from them)")
    ap.add_argument("--vmap-map", action="store_true",
                    help="also time the map program before batching (vmapped value_and_grad of the front door)")
    args = ap.parse_args()
    dev = jax.devices()[0]
    print(f"device: {dev.platform} {dev.device_kind} x {len(jax.devices())}; cpu count {os.cpu_count()}; "
          f"load average {os.getloadavg()[0]:.1f} at the start", flush=True)
    load_start = round(os.getloadavg()[0], 1)
    rows = []
    if args.only in (None, "reference", "vmap", "fit"):
        reference_rows(args, rows)
    if args.only in (None, "map"):
        map_rows(args, rows)
    print(f"load average {os.getloadavg()[0]:.1f} at the end; medians of {args.repeat}, alternating with the "
          f"baseline\n")
    print("| entry | per point | compile | ratio to the table | note |")
    print("|---|---|---|---|---|")
    for name, pp, comp, ratio, note in rows:
        print(f"| {name} | {pp * 1e3:.2f} ms | {comp:.1f} s | {ratio:.2f}x | {note} |")
        summary(f"bench_batched.py{' --quick' if args.quick else ''} ({name})", pp, comp, "warm-started table",
                f"{ratio:.2f}x", note)
    if args.record:
        from _numbers import record

        command = "python benchmarks/bench_batched.py" + " ".join(
            [""] + (["--quick"] if args.quick else []) + ([f"--only {args.only}"] if args.only else [])
            + [f"--repeat {args.repeat}"])
        platform = "" if jax.devices()[0].platform == "cpu" else f"_{jax.devices()[0].platform}"
        section = f"batched{'_quick' if args.quick else ''}{platform}_{args.only or 'all'}"
        record(args.section or section, {
            "command": command, "load_start": load_start, "load_end": round(os.getloadavg()[0], 1),
            "rows": [dict(entry=name, per_point_s=pp, compile_s=comp, ratio=ratio, note=note)
                     for name, pp, comp, ratio, note in rows]})


if __name__ == "__main__":
    main()
