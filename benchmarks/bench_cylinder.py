"""Benchmark of the full 2D rolling cylinder (``jr.Full``, geometry "cylinder") against a dense NumPy baseline.

Run:  python benchmarks/bench_cylinder.py [--quick]

Reports (CPU, float64): compile time apart from run time (ahead of time), medians of repeated
runs, everything through ``jr.rolling_resistance`` / ``jr.rolling_resistance_grid``:
* one point with the automatic grid (``jr.Full()``, half-space, V tau/a0 = 1): error against the
  exact half-space solution (``jr.reference.exact_cylinder_halfspace``);
* one point on an explicit grid (SLS G0 = 3 MPa, tau = 0.25 s, f = 1, R = 2 cm, P' = 5 kN/m,
  H = 5 mm, V tau/a0 = 1): ``jr.FixedGrid(a/25, 150, period=2**17 a/25)`` (25 cells per
  estimated half-width ``a``, 2^17 cells per period, as the paper-era benchmark), and
  ``value_and_grad`` with respect to (G0, tau, f, H, R, P', V) vs value (target <= 3x);
* the 23 x 15 reference table (23 log-spaced speeds 1e-4..1 m/s, 15 loads 1e3..1e4 N/m) through
  ``jr.rolling_resistance_grid`` on one grid covering the envelope (25 cells per smallest
  half-width, window 3 largest half-widths each side, 2^17 cells per period); its gradient
  (``jax.grad`` of the sum with respect to G0, tau, f, H) on a subset;
* a plain NumPy/SciPy baseline on the same grids: the dense window compliance matrix built from
  the same exact kernel (NumPy FFT) and a dense primal-dual active-set solver
  (numpy.linalg.solve), and the speed-up ratio.
``--quick``: the table on a 5 x 3 subset.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from _timing import aot, summary, timed

G0, TAU, F, R, H = 3e6, 0.25, 1.0, 0.02, 5e-3
N_CELLS, CPR = 2**17, 25
MAT = jr.StandardLinearSolid(G0, TAU, F)


def line_grid(loads, H_=H):
    """The explicit grid of this benchmark: 25 cells per smallest estimated half-width, a window of
    3 largest half-widths each side, 2^17 cells per period."""
    a = np.asarray([float(jr.engines.contact_size.estimate_contact_size(MAT, jr.Layer(H_), R, float(P), "cylinder")) for P in loads])
    dx = a.min() / CPR
    return jr.FixedGrid(dx, 2 * math.ceil(3.0 * a.max() / dx), period=N_CELLS * dx), a


def rr(method):
    def fn(theta, V):
        G, tau, f, H_, radius, load = theta
        return jr.rolling_resistance(jr.StandardLinearSolid(G, tau, f), jr.Layer(H_), radius=radius, load=load,
                                     speed=V, geometry="cylinder", method=method, throw=False).value

    return fn


# ------------------------------------------------------------------------------ NumPy baseline


def numpy_T(q, V, G=G0, tau=TAU, f=F, H_=H):
    """Quasi-static incompressible layer T = F(qH)/(2 G_m |q|) (docs/conventions.md sec. 4), NumPy."""
    qa = np.abs(q)
    w = q * V * tau
    Gm = np.conj(G * (1 + 1j * w) / (1 + 1j * w / (1 + f)))
    y = np.minimum(qa * H_, 30.0)
    Fy = (np.sinh(2 * y) - 2 * y) / (np.cosh(2 * y) + 2 * y * y + 1) if np.isfinite(H_) else 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        T = np.where(qa > 0, Fy / (2 * Gm * np.where(qa > 0, qa, 1.0)), 0.0)
    return T


def numpy_solve(V, load, grid, a, images=4):
    """Dense baseline on the grid ``grid``: exact alias-summed kernel (plain image sum, 2M images),
    dense Toeplitz window matrix, primal-dual active set with numpy.linalg.solve."""
    dx, N, W = float(grid.spacing), grid.n_cells[0], grid.window
    z = np.arange(N // 2 + 1) / N
    w = z[:, None] + np.arange(-images, images)[None, :]
    q = 2 * np.pi * w / dx
    K = np.sum(numpy_T(q, V) * np.sinc(w), axis=1)
    col = np.fft.irfft(K, n=N)
    i = np.arange(W)
    A = col[np.mod(i[:, None] - i[None, :], N)]
    x = (i - 0.5 * (W - 1)) * dx
    h = x * x / (2 * R)
    mask = np.abs(x) < a
    for it in range(50):
        idx = np.flatnonzero(mask)
        m = len(idx)
        M = np.zeros((m + 1, m + 1))
        M[:m, :m] = A[np.ix_(idx, idx)]
        M[:m, m] = -1.0
        M[m, :m] = dx
        sol = np.linalg.solve(M, np.concatenate([-h[idx], [load]]))
        p = np.zeros(W)
        p[idx] = sol[:m]
        g = h - sol[m] + A @ p
        new = np.where(mask, p > 0, g < 0)
        if np.array_equal(new, mask):
            break
        mask = new
    return np.sum(p * x) * dx / R, it + 1


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="table on a 5 x 3 subset")
    args = ap.parse_args()
    cmd = "bench_cylinder.py" + (" --quick" if args.quick else "")
    print(f"jax {jax.__version__}, devices {jax.devices()}, float64 {jax.config.read('jax_enable_x64')} "
          f"(2-core machine shared with other jobs: medians of repeated runs)")

    # ---- one point, automatic grid, half-space vs exact ----
    P1, zeta = 5e3, 1.0
    a0 = np.sqrt(P1 * R / (np.pi * G0))
    V1 = zeta * a0 / TAU
    half = jr.Layer(jnp.inf)
    first, run, res = timed(lambda: jr.rolling_resistance(MAT, half, radius=R, load=P1, speed=V1,
                                                          geometry="cylinder", method=jr.Full()), repeat=3)
    ex = float(jr.reference.exact_cylinder_halfspace(MAT, R, P1, V1).rolling_resistance)
    print(f"\none point (half-space, V tau/a0 = 1, jr.Full() automatic grid, eager): first call {first:.2f} s, "
          f"warm {1e3 * run:.1f} ms, R_r = {float(res.value):.5g} N/m, exact {ex:.5g}, "
          f"err {float(res.value) / ex - 1:+.2e}, iterations {int(res.solution.iterations)}")

    # ---- one point, explicit grid ----
    grid1, a1 = line_grid([P1])
    method1 = jr.Full(grid=grid1)
    theta = jnp.asarray([G0, TAU, F, H, R, P1])
    c_val, t_val, v, f_val = aot(rr(method1), theta, V1, repeat=7)
    c_vg, t_vg, _, f_vg = aot(jax.value_and_grad(rr(method1), argnums=(0, 1)), theta, V1, repeat=7)
    pairs = []  # value and value_and_grad interleaved (shared machine), median of the ratios
    for _ in range(7):
        t = time.perf_counter()
        jax.block_until_ready(f_val(theta, V1))
        t1 = time.perf_counter() - t
        t = time.perf_counter()
        jax.block_until_ready(f_vg(theta, V1))
        pairs.append((time.perf_counter() - t) / t1)
    print(f"one point, H = 5 mm, N = {N_CELLS}, window {grid1.window}, 25 cells/half-width: compile {c_val:.2f} s, "
          f"run {1e3 * t_val:.1f} ms (R_r = {float(v):.5g} N/m)")
    print(f"value_and_grad (7 gradients): compile {c_vg:.2f} s, run {1e3 * t_vg:.1f} ms, "
          f"ratio to value {t_vg / t_val:.2f}x (interleaved pairs: median {statistics.median(pairs):.2f}x)")

    t_np_runs, t_jx_runs = [], []
    for _ in range(7):
        t = time.perf_counter()
        nb, nb_it = numpy_solve(V1, P1, grid1, a1[0])
        t_np_runs.append(time.perf_counter() - t)
        t = time.perf_counter()
        jax.block_until_ready(f_val(theta, V1))
        t_jx_runs.append(time.perf_counter() - t)
    t_np1 = statistics.median(t_np_runs)
    ratio1 = statistics.median([a / b for a, b in zip(t_np_runs, t_jx_runs)])
    print(f"NumPy dense baseline, same grid (interleaved with jaxroll, medians of 7): {1e3 * t_np1:.1f} ms vs "
          f"{1e3 * statistics.median(t_jx_runs):.1f} ms, R_r = {nb:.5g} N/m (rel. diff to jaxroll "
          f"{nb / float(v) - 1:+.1e}), {nb_it} iterations; ratio {ratio1:.2f}x")
    summary(cmd + " (one point, 2^17 cells)", t_val, c_val, f"NumPy dense active set {1e3 * t_np1:.1f} ms",
            f"{ratio1:.1f}x", "H = 5 mm, P' = 5 kN/m, V tau/a0 = 1")
    summary(cmd + " (value_and_grad / value)", t_vg, c_vg, f"value {1e3 * t_val:.1f} ms",
            f"{statistics.median(pairs):.2f}x (target 3x)", "7 gradients")

    # ---- reference table 23 x 15 ----
    speeds = np.logspace(-4, 0, 23)
    loads = np.linspace(1e3, 1e4, 15)
    if args.quick:
        speeds, loads = speeds[::5], loads[::7]
    grid, a = line_grid(loads)
    method = jr.Full(grid=grid)

    def table(th, loads, speeds):
        G, tau, f, H_ = th
        out = jr.rolling_resistance_grid(jr.StandardLinearSolid(G, tau, f), jr.Layer(H_), radius=R, loads=loads,
                                         speeds=speeds, geometry="cylinder", method=method)
        return out.value, out.result, out.solution.iterations

    th = jnp.asarray([G0, TAU, F, H])
    Ps, Vs = jnp.asarray(loads), jnp.asarray(speeds)
    c_sw, t_sw, (vals, status, iters), _ = aot(table, th, Ps, Vs, repeat=3)
    vals, iters = np.asarray(vals), np.asarray(iters)
    n = vals.size
    print(f"\nreference table {len(speeds)} x {len(loads)} = {n} points (window {grid.window}, dx "
          f"{float(grid.spacing) * 1e6:.0f} um, {N_CELLS} period cells): compile {c_sw:.1f} s, run {t_sw:.2f} s "
          f"({1e3 * t_sw / n:.1f} ms/point); not valid {int(np.sum(np.asarray(status) != 0))}, iterations "
          f"min/median/max {int(iters.min())}/{int(np.median(iters))}/{int(iters.max())}")

    sub = (slice(None, None, 11), slice(None, None, 7)) if not args.quick else (slice(None, 2), slice(None))
    Vsub, Psub = Vs[sub[0]], Ps[sub[1]]
    grad_fn = jax.value_and_grad(lambda th, P, V: jnp.sum(table(th, P, V)[0]))
    c_sg, t_sg, _, _ = aot(grad_fn, th, Psub, Vsub, repeat=3)
    _, t_sv, _, _ = aot(table, th, Psub, Vsub, repeat=3)
    print(f"table value_and_grad (d sum/d(G0, tau, f, H)) on {Vsub.size} x {Psub.size} points: compile {c_sg:.1f} s, "
          f"run {t_sg:.2f} s, ratio to value on the same points {t_sg / t_sv:.2f}x")

    VV, PP = np.meshgrid(speeds, loads, indexing="ij")
    t = time.perf_counter()
    nvals = np.array([numpy_solve(float(v_), float(p_), grid, a.min())[0] for v_, p_ in zip(VV.ravel(), PP.ravel())])
    t_np = time.perf_counter() - t
    rel = np.max(np.abs(nvals.reshape(vals.shape) / vals - 1))
    print(f"NumPy dense baseline table: {t_np:.2f} s ({1e3 * t_np / n:.1f} ms/point), "
          f"max rel. diff to jaxroll {rel:.1e}; speed-up jaxroll/NumPy {t_np / t_sw:.2f}x")
    summary(cmd + f" (table {len(speeds)}x{len(loads)})", t_sw, c_sw, f"NumPy dense {t_np:.2f} s",
            f"{t_np / t_sw:.1f}x", f"{n} points, one envelope grid, window {grid.window}")
    print("(paper, full 3D model, 2010 laptop: 1.33 s per solve, 54 min per reference case)")


if __name__ == "__main__":
    main()
