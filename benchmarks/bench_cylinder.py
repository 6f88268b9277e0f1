"""Benchmark of the full 2D rolling cylinder (jaxroll.cylinder) against a dense NumPy baseline.

Run:  python benchmarks/bench_cylinder.py [--quick]

Reports (CPU, float64): compile time apart from run time, medians of repeated runs,
* one solve at the default resolution (SLS G0 = 3 MPa, tau = 0.25 s, f = 1, R = 2 cm,
  P' = 5 kN/m, H = 5 mm, V tau/a0 = 1), error against the exact half-space solution for a
  half-space solve;
* the 23 x 15 reference sweep (23 log-spaced speeds 1e-4..1 m/s, 15 loads 1e3..1e4 N/m) with
  lax.map, static resolution (25 cells per half-width, 2^17 cells per period);
* value_and_grad vs value (target <= 3x);
  (the layer is built inside jit; its literal density rho = 0 stays a trace-time constant, so
  jaxroll.cylinder.compliance_function takes the quasi-static factorised path);
* a plain NumPy/SciPy baseline on the same grid: the dense window compliance matrix built from
  the same exact kernel (NumPy FFT) and a dense primal-dual active-set solver
  (numpy.linalg.solve), and the speed-up ratio.
"""

from __future__ import annotations

import argparse
import statistics
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from jaxroll import cylinder as cy
from jaxroll import reference as ref

from _timing import timed

G0, TAU, F, R, H = 3e6, 0.25, 1.0, 0.02, 5e-3
N_SWEEP, CPR = 2**17, 25


def rr(theta, V, n_cells=N_SWEEP):
    G, tau, f, H_, radius, load = theta
    s = cy.solve_cylinder(jr.StandardLinearSolid(G, tau, f), jr.Layer(H_), radius, load, V,
                          n_cells=n_cells, cells_per_radius=CPR, throw=False)
    return s.resistance, (s.contact.status, s.contact.iterations)


# ------------------------------------------------------------------------------ NumPy baseline


def numpy_T(q, V, G=G0, tau=TAU, f=F, H_=H):
    """Quasi-static incompressible layer T = F(qH)/(2 G_m |q|) (DESIGN section 2), NumPy."""
    qa = np.abs(q)
    w = q * V * tau
    Gm = np.conj(G * (1 + 1j * w) / (1 + 1j * w / (1 + f)))
    y = np.minimum(qa * H_, 30.0)
    Fy = (np.sinh(2 * y) - 2 * y) / (np.cosh(2 * y) + 2 * y * y + 1) if np.isfinite(H_) else 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        T = np.where(qa > 0, Fy / (2 * Gm * np.where(qa > 0, qa, 1.0)), 0.0)
    return T


def numpy_solve(V, load, n_cells=N_SWEEP, cpr=CPR, window=3.0, images=4):
    """Dense baseline on the same grid: exact alias-summed kernel (plain image sum, 2M images),
    dense Toeplitz window matrix, primal-dual active set with numpy.linalg.solve."""
    a0 = np.sqrt(load * R / (np.pi * G0))
    a_thin = (15 * load * R * H**3 / (2 * G0)) ** 0.2
    a = min(a0, a_thin)
    dx = a / cpr
    N = n_cells
    W = 2 * int(np.ceil(window * cpr))
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
    ap.add_argument("--quick", action="store_true", help="sweep on a 5 x 3 subset")
    args = ap.parse_args()
    print(f"jax {jax.__version__}, devices {jax.devices()}, float64 {jax.config.read('jax_enable_x64')}")

    # ---- one solve, default (automatic) resolution ----
    P1, zeta = 5e3, 1.0
    a0 = np.sqrt(P1 * R / (np.pi * G0))
    V1 = zeta * a0 / TAU
    mat = jr.StandardLinearSolid(G0, TAU, F)
    t = time.perf_counter()
    res = cy.rolling_resistance_full(mat, jr.Layer(jnp.inf), R, P1, V1)
    jax.block_until_ready(res.value)
    t_eager = time.perf_counter() - t
    ex = float(ref.exact_cylinder_halfspace(mat, R, P1, V1).rolling_resistance)
    print(f"\none solve (half-space, V tau/a0 = 1, automatic resolution, eager incl. compile): "
          f"{t_eager:.2f} s, R_r = {float(res.value):.5g} N/m, exact {ex:.5g}, "
          f"err {float(res.value) / ex - 1:+.2e}, iterations {int(res.iterations)}")

    theta = jnp.asarray([G0, TAU, F, H, R, P1])
    f_val = jax.jit(lambda th, v: rr(th, v)[0])
    f_vg = jax.jit(jax.value_and_grad(lambda th, v: rr(th, v)[0], argnums=(0, 1)))
    c_val, t_val, v = timed(f_val, theta, V1)
    c_vg, t_vg, _ = timed(f_vg, theta, V1)
    pairs = []  # value and value_and_grad interleaved (shared machine), median of the ratios
    for _ in range(7):
        t = time.perf_counter()
        jax.block_until_ready(f_val(theta, V1))
        t1 = time.perf_counter() - t
        t = time.perf_counter()
        jax.block_until_ready(f_vg(theta, V1))
        pairs.append((time.perf_counter() - t) / t1)
    print(f"one solve, H = 5 mm, jit, N = {N_SWEEP}, 25 cells/half-width: compile+first {c_val:.2f} s, "
          f"run {1e3 * t_val:.1f} ms (R_r = {float(v):.5g} N/m)")
    print(f"value_and_grad (7 gradients): compile+first {c_vg:.2f} s, run {1e3 * t_vg:.1f} ms, "
          f"ratio to value {t_vg / t_val:.2f}x (interleaved pairs: median {statistics.median(pairs):.2f}x)")

    # interleaved runs (the machine is shared: the load changes between blocks of runs), the
    # ratio is the median of the per-pair ratios
    t_np_runs, t_jx_runs = [], []
    for _ in range(7):
        t = time.perf_counter()
        nb, nb_it = numpy_solve(V1, P1)
        t_np_runs.append(time.perf_counter() - t)
        t = time.perf_counter()
        jax.block_until_ready(f_val(theta, V1))
        t_jx_runs.append(time.perf_counter() - t)
    t_np1 = statistics.median(t_np_runs)
    ratio = statistics.median([a / b for a, b in zip(t_np_runs, t_jx_runs)])
    print(f"NumPy dense baseline, same grid (interleaved with jaxroll, medians of 7): {1e3 * t_np1:.1f} ms vs "
          f"{1e3 * statistics.median(t_jx_runs):.1f} ms, R_r = {nb:.5g} N/m (rel. diff to jaxroll "
          f"{nb / float(v) - 1:+.1e}), {nb_it} iterations; ratio {ratio:.2f}x")

    # ---- reference sweep 23 x 15 ----
    speeds = np.logspace(-4, 0, 23)
    loads = np.linspace(1e3, 1e4, 15)
    if args.quick:
        speeds, loads = speeds[::5], loads[::7]
    VV, PP = np.meshgrid(speeds, loads, indexing="ij")
    thetas = jnp.stack([jnp.asarray([G0, TAU, F, H, R, p]) for p in PP.ravel()])
    Vs = jnp.asarray(VV.ravel())

    @jax.jit
    def sweep(thetas, Vs):
        return jax.lax.map(lambda a: rr(*a), (thetas, Vs), batch_size=1)

    c_sw, t_sw, (vals, (status, iters)) = timed(sweep, thetas, Vs, repeat=1)
    n = len(Vs)
    print(f"\nreference sweep {len(speeds)} x {len(loads)} = {n} solves (lax.map, batch 1): "
          f"compile+first {c_sw:.1f} s, run {t_sw:.2f} s ({1e3 * t_sw / n:.1f} ms/solve); "
          f"failures {int(np.sum(np.asarray(status) != 0))}, iterations "
          f"min/median/max {int(iters.min())}/{int(np.median(iters))}/{int(iters.max())}")

    @jax.jit
    def sweep_grad(thetas, Vs):
        g = jax.value_and_grad(lambda th, v: rr(th, v)[0], argnums=(0, 1))
        return jax.lax.map(lambda a: g(*a), (thetas, Vs), batch_size=1)

    sub = slice(None, None, 23) if not args.quick else slice(None, None, 3)  # a subset of the cases
    c_sg, t_sg, _ = timed(sweep_grad, thetas[sub], Vs[sub], repeat=3)
    _, t_sv, _ = timed(sweep, thetas[sub], Vs[sub], repeat=3)
    print(f"sweep value_and_grad on {len(Vs[sub])} of the cases: compile+first {c_sg:.1f} s, run {t_sg:.2f} s, "
          f"ratio to value on the same cases {t_sg / t_sv:.2f}x")

    t = time.perf_counter()
    nvals = np.array([numpy_solve(float(v), float(p))[0] for v, p in zip(VV.ravel(), PP.ravel())])
    t_np = time.perf_counter() - t
    rel = np.max(np.abs(nvals / np.asarray(vals) - 1))
    print(f"NumPy dense baseline sweep: {t_np:.2f} s ({1e3 * t_np / n:.1f} ms/solve), "
          f"max rel. diff to jaxroll {rel:.1e}; speed-up jaxroll/NumPy {t_np / t_sw:.2f}x")
    print("\n(2-core machine shared with other jobs: timings are noisy, medians of repeated runs)")
    print("(paper, full 3D model, 2010 laptop: 1.33 s per solve, 54 min per reference case)")


if __name__ == "__main__":
    main()
