"""Benchmark of the full 3D rolling sphere (``jr.Full``, geometry "sphere"): the paper's reference case.

Run:  python benchmarks/bench_sphere3d.py [--quick] [--H 0.03] [--repeat 3] [--period 0.2 | none] [--grad]
      [--restart N] [--programs] [--count]

Reference case ([ZG] Table 1 / docs/design.md sec. 3): 23 log-spaced speeds 1e-4..1 m/s x 15
loads 10..150 N, R = 2 cm, SLS G0 = 3 MPa, tau = 0.25 s, f = 1, H = 30 mm, at the paper's
resolution: ``jr.Full(grid=jr.FixedGrid(2.5e-4, window, period=0.2, n_terms=500))`` with the
window of 41 cells of the paper, enlarged to fit the largest contact. Paper: 54 min per reference
case. Timed through ``jr.rolling_resistance_grid`` compiled ahead of time (material and layer
parameters as arguments, as in ``jaxroll.apps.reproduce``, with jaxroll's XLA options as there:
``jaxroll._xla_options``; ``JAXROLL_XLA_OPTIONS=0``: XLA's defaults): compile apart, median of
repeats.

Reports the device, resolution, the points that are not valid (``RollingResult.result``), the
active-set iterations and the compiled working memory. ``--quick``: 6 speeds x 4 loads, cells
0.5 mm, 250 terms, one repeat. ``--programs``: also the size of each program (StableHLO text, its
while loops, FFTs and the compiled program's fusions) and its compile time in process CPU seconds
(steadier than wall time on a shared machine), lowered and compiled again apart from the timed
runs; with ``--grad`` also the gradient's forward pass (``jax.vjp``) and backward pass apart.
``--count``: also the active-set steps and the circulant applications per solve (``C``: the
compliance, i.e. the Krylov operator plus the residual checks, the displacement and the
dissipation; ``M``: the preconditioner), counted with the debug callback of
``contact_iterations.py`` in one more run of a separately compiled table (the callbacks cost
time, so never in the timed runs).
"""

from __future__ import annotations

import argparse
import math
import os
import re
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from _timing import aot, summary
from jaxroll._xla_options import compiler_options

G0, TAU, F, R = 3e6, 0.25, 1.0, 0.02
PAPER_S = 54 * 60.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--H", type=float, default=0.03)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tol", type=float, default=1e-10, help="contact solver tolerance (scaled residual)")
    ap.add_argument("--restart", type=int, default=None,
                    help="GMRES Krylov basis size (default: jr.contact.GMRES's own)")
    ap.add_argument("--grad", action="store_true", help="also time the gradient of the table w.r.t. G0, tau, f, H")
    ap.add_argument("--period", default="0.2", help="period [m] (the paper's 0.2) or 'none' (an infinite layer)")
    ap.add_argument("--programs", action="store_true",
                    help="also print each program's size (StableHLO, while loops, FFTs) and compile CPU seconds")
    ap.add_argument("--count", action="store_true",
                    help="also count the active-set steps and operator applications per solve (one more run)")
    args = ap.parse_args()
    if args.quick:
        speeds, loads, spacing, n_terms, repeat = np.logspace(-4, 0, 6), np.linspace(10, 150, 4), 5e-4, 250, 1
    else:
        speeds, loads, spacing, n_terms, repeat = (np.logspace(-4, 0, 23), np.linspace(10, 150, 15), 2.5e-4, 500,
                                                   args.repeat)
    period = None if args.period.lower() == "none" else float(args.period)
    if period is None:
        n_terms = None
    mat = jr.StandardLinearSolid(G0, TAU, F)
    r_max = float(jr.engines.contact_size.estimate_contact_size(mat, jr.Layer(args.H), R, float(loads.max())))
    window = max(41 if not args.quick else 21, 2 * math.ceil(1.15 * r_max / spacing) + 1)
    method = jr.Full(grid=jr.FixedGrid(spacing, window, period=period, n_terms=n_terms), tol=args.tol,
                     linear_solver=jr.contact.GMRES(restart=args.restart))

    def table(G, tau, f, H, loads, speeds):
        out = jr.rolling_resistance_grid(jr.StandardLinearSolid(G, tau, f), jr.Layer(H), radius=R, loads=loads,
                                         speeds=speeds, method=method)
        return out.value, out.result, out.solution.iterations

    theta = (G0, TAU, F, args.H, jnp.asarray(loads), jnp.asarray(speeds))
    print(f"device: {jax.devices()[0].device_kind} x {len(jax.devices())}; cpu count {os.cpu_count()}; "
          f"load avg {os.getloadavg()[0]:.1f} (shared machine); XLA options {compiler_options()}")
    cells = "infinite layer" if period is None else f"{round(period / spacing)}^2 cells"
    print(f"resolution: L = {period} m, a = {spacing * 1e3} mm ({cells}), "
          f"window {window}^2, n_terms {n_terms}, tol {args.tol:g}; {len(speeds)} speeds x {len(loads)} loads; "
          f"H = {args.H} m")
    comp, med, (v, st, it), compiled = aot(table, *theta, repeat=repeat, options=compiler_options())
    v, st, it = np.asarray(v), np.asarray(st), np.asarray(it)
    per_case = med * 345 / v.size
    print(f"compile {comp:.1f} s; run median {med:.2f} s for {v.size} points ({per_case:.1f} s scaled to the 345 "
          f"points of the reference case); paper 54 min -> ratio {PAPER_S / per_case:.0f}x")
    print(f"not valid: {int(np.sum(st != 0))} (codes {sorted(set(st.ravel().tolist()))}); iterations max "
          f"{int(np.max(it))}")
    print(f"R_r range {v.min():.4g} .. {v.max():.4g} N; peak at V = {speeds[np.argmax(v[:, -1])]:.3g} m/s "
          f"(P = {loads[-1]:.0f} N)")
    try:
        print(f"compiled temp memory: {compiled.memory_analysis().temp_size_in_bytes / 2**20:.0f} MiB")
    except Exception:  # noqa: BLE001 (not every backend reports it)
        pass
    if args.programs:
        program_report("table", table, theta)
    if args.count:
        count_report(table, theta)
    grad_note = ""
    if args.grad:
        def objective(G, tau, f, H, loads, speeds):
            value, result, _ = table(G, tau, f, H, loads, speeds)
            return jnp.sum(jnp.where(result == 0, value, 0.0))

        gcomp, gmed, g, _ = aot(jax.grad(objective, argnums=(0, 1, 2, 3)), *theta, repeat=repeat,
                                options=compiler_options())
        print(f"gradient d(sum R_r)/d(G0, tau, f, H): compile {gcomp:.1f} s; run median {gmed:.2f} s "
              f"({gmed / med:.2f}x the forward table); {[float(x) for x in g]}")
        grad_note = f"; gradient (G0, tau, f, H) {gmed:.2f} s = {gmed / med:.2f}x, compile {gcomp:.1f} s"
        if args.programs:
            program_report("gradient", jax.grad(objective, argnums=(0, 1, 2, 3)), theta)
            gradient_split(objective, theta)
    size = f"{len(speeds)}x{len(loads)}, a = {spacing * 1e3:g} mm, H = {args.H * 1e3:g} mm, " + (
        "infinite layer" if period is None else f"L = {period} m, {n_terms} terms")
    summary("bench_sphere3d.py" + (" --quick" if args.quick else "") + f" --H {args.H} --period {args.period}",
            per_case, comp,
            "paper full 3D: 54 min per reference case", f"{PAPER_S / per_case:.0f}x",
            f"{size}; run {med:.2f} s scaled x{345 / v.size:.1f} to 345 points{grad_note}")


def count_report(table, theta):
    """Print the active-set steps and the circulant applications (compliance ``C``,
    preconditioner ``M``) per solve of one run of ``table``, counted by debug callbacks."""
    from contact_iterations import COUNT, _counting
    from jaxroll.contact import operator as op, precondition as pc

    apply = op.circulant_window_apply
    op.circulant_window_apply, pc.circulant_window_apply = _counting("C", apply), _counting("M", apply)
    jax.clear_caches()  # trace anew (the library's inner jits would reuse the uncounted programs)
    try:
        COUNT.update(C=0, M=0)
        _, _, it = jax.block_until_ready(jax.jit(table)(*theta))
    finally:
        op.circulant_window_apply = pc.circulant_window_apply = apply
        jax.clear_caches()
    n = np.asarray(it).size
    print(f"per solve: {float(np.mean(it)):.2f} active-set steps (max {int(np.max(it))}), "
          f"{COUNT['C'] / n:.1f} compliance and {COUNT['M'] / n:.1f} preconditioner applications")


def gradient_split(objective, theta):
    """The gradient's program in two parts (:func:`program_report` of each): the forward pass that
    keeps what reverse mode needs (``jax.vjp``) and the backward pass alone (the ``vjp`` function
    applied to a unit cotangent)."""
    def forward(*th):
        return jax.vjp(lambda *p: objective(*p, *th[4:]), *th[:4])

    program_report("gradient's forward pass", forward, theta)
    _, vjp = jax.jit(forward)(*theta)
    program_report("gradient's backward pass", lambda v, c: v(c), (vjp, jnp.ones(())))


def program_report(name, fn, args):
    """Print the size of ``jax.jit(fn)``'s program at ``args`` (StableHLO, while loops, FFTs; the
    compiled program's fusions, i.e. its kernels) and its compile time in CPU seconds."""
    jax.clear_caches()  # compile anew: neither the timed runs' program nor the persistent cache's
    cached = jax.config.jax_enable_compilation_cache
    jax.config.update("jax_enable_compilation_cache", False)
    try:
        lowered = jax.jit(fn).lower(*args)
        text = lowered.as_text()
        cpu, wall = time.process_time(), time.perf_counter()
        compiled = lowered.compile(compiler_options())
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    finally:
        jax.config.update("jax_enable_compilation_cache", cached)
    print(f"program {name}: StableHLO {len(text) / 1e6:.2f} MB, {len(re.findall(r'stablehlo.while', text))} while "
          f"loops, {len(re.findall(r'stablehlo.fft', text))} FFTs, {compiled.as_text().count(' fusion(')} fusions; "
          f"compile {cpu:.1f} s CPU ({wall:.1f} s wall, "
          f"load avg {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
