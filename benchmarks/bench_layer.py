"""Benchmark: layer compliance T over a 1001 x 1001 Fourier mode grid for 23 speeds.

Paper set-up: L = 20 cm period, modes m, n in [-500, 500], H = 5 mm, rho = 1000 kg/m^3,
SLS G0 = 3 MPa, tau = 0.25 s, f = 1, 23 log-spaced speeds 1e-4..1 m/s.
The baseline is the same closed form (same three-branch stable evaluation) written plainly in
NumPy, run in the same process. Reports compile time apart, medians of repeated runs, the
ratio, and the max relative difference between the two.

Times the public ``jr.engines.layer.surface_compliance`` under ``jax.jit`` (``lax.map`` over speeds), compiled
ahead of time apart from the runs. ``--quick``: 201 x 201 modes, 2 repeats.

Usage: python benchmarks/bench_layer.py [--quick] [--modes 1001] [--repeats 3]
"""

import argparse
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from _timing import aot, summary


def numpy_compliance(qx, qy, V, H, rho, G0, tau, f):
    """Incompressible layer with inertia, the three-branch closed form of jaxroll.engines.layer, NumPy."""
    iwt = 1j * qx * V * tau
    G = np.conj(G0 * (1 + iwt) / (1 + iwt / (1 + f)))
    q2 = qx * qx + qy * qy
    q = np.sqrt(q2)
    with np.errstate(all="ignore"):
        eps = np.where(q2 > 0, rho * V * V * qx * qx / (G * np.where(q2 > 0, q2, 1.0)), 0.0)
        a = q * H
        s = np.sqrt(1 - eps)
        d = s - 1
        b = a * s
        far = b.real > 20
        y = a * d
        near = np.abs(y) < 3

        def smc(z):
            z = np.asarray(z, complex)
            small = np.abs(z) < 1
            zs = np.where(small, z, 0.5)
            z2 = zs * zs
            term = z2 / 6
            tot = term.copy()
            for k in range(2, 14):
                term = term * z2 / ((2 * k) * (2 * k + 1))
                tot = tot + term
            zl = np.where(small, 1.0, z)
            return np.where(small, tot, (np.sinh(zl) - zl) / zl)

        e1 = np.exp(-2 * a)
        sy = 1 + smc(np.where(near, y, 0))
        shh = 1 + smc(np.where(near, y, 0) / 2)
        sd = a * sy
        cd = 0.5 * a * a * shh**2
        sh2 = 0.25 * np.expm1(-2 * a) ** 2
        chsh = -0.25 * np.expm1(-4 * a)
        two_a = 2 * a
        sc2a = np.where(two_a < 1, np.exp(-two_a) * smc(two_a).real,
                        (-0.5 * np.expm1(-2 * two_a) - two_a * np.exp(-two_a)) / np.where(two_a > 0, two_a, 1))
        n1 = sc2a - smc(np.where(near, y, 0)) * e1 + d * sy * sh2 + d * d * 0.5 * a * shh**2 * chsh
        sc = sd * chsh
        c0 = -8 * cd * e1 - 4 * sh2 - 4 * e1
        c1 = -16 * cd * e1 - 4 * sc - 8 * sh2 - 8 * e1
        c2 = -4 * cd * sh2 - 16 * cd * e1 - 8 * sc - 4 * sh2 - 5 * e1
        c3 = -8 * cd * sh2 - 12 * cd * e1 - 4 * sc - sh2 - e1
        c4 = -4 * cd * sh2 - 5 * cd * e1 - sc
        c5 = -cd * sh2 - cd * e1
        d2 = c0 + d * (c1 + d * (c2 + d * (c3 + d * (c4 + d * c5))))
        phi_near = -(2 + d) * n1 / d2
        e2 = np.exp(-2 * b)
        num = s * (1 - e1) * (1 + e2) - (1 + e1) * (1 - e2)
        x_ = 4 * s * s + (1 + s * s) ** 2
        y_ = s * (4 + (1 + s * s) ** 2)
        den = 16 * s * (1 + s * s) * np.exp(-a - b) + x_ * (1 - e1) * (1 - e2) - y_ * (1 + e1) * (1 + e2)
        phi_far = eps * num / den / np.where(a > 0, a, 1)
        phi = np.where(near, phi_near, phi_far)
        t_layer = H * phi / G
        t_half = np.where(q > 0, (1 + s) / ((4 * s + (s - 1) * (1 + s) ** 2) * G * np.where(q > 0, q, 1)), 0)
        return np.where(far, t_half, t_layer)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", type=int, default=1001)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--numpy-speeds", type=int, default=23, help="speeds timed for the NumPy baseline")
    ap.add_argument("--quick", action="store_true", help="201 x 201 modes, 2 repeats")
    args = ap.parse_args()
    if args.quick:
        args.modes, args.repeats = 201, 2
    n = args.modes
    L, H, rho = 0.2, 0.005, 1000.0
    G0, tau, f = 3e6, 0.25, 1.0
    mat = jr.StandardLinearSolid(G0, tau, f)
    layer = jr.Layer(H=H, rho=rho)
    m = np.arange(n) - n // 2
    qx, qy = np.meshgrid(2 * np.pi * m / L, 2 * np.pi * m / L, indexing="ij")
    speeds = np.logspace(-4, 0, 23)
    qxj, qyj = jnp.asarray(qx), jnp.asarray(qy)

    def all_speeds(speeds):
        # one speed at a time keeps the working set at ~1001^2 complex temporaries
        return jax.lax.map(lambda V: jr.engines.layer.surface_compliance(layer, mat, qxj, qyj, V), speeds)

    compile_s, t_jax, out, _ = aot(all_speeds, jnp.asarray(speeds), repeat=args.repeats)

    ns = args.numpy_speeds
    times_np = []
    for _ in range(max(1, args.repeats // 2)):
        t0 = time.perf_counter()
        ref = [numpy_compliance(qx, qy, V, H, rho, G0, tau, f) for V in speeds[:ns]]
        times_np.append(time.perf_counter() - t0)
    t_np = float(np.median(times_np)) * len(speeds) / ns
    ref = np.stack(ref)
    got = np.asarray(out[:ns])
    mask = np.abs(ref) > 0
    rel = np.max(np.abs(got[mask] - ref[mask]) / np.abs(ref[mask]))

    print(f"# layer compliance benchmark  (shared 2-core machine; {platform.processor() or platform.machine()}, "
          f"{jax.devices()[0].platform}, {jax.device_count()} device(s), complex128)")
    print(f"grid {n} x {n} modes x {len(speeds)} speeds = {n * n * len(speeds):.3e} T evaluations")
    print(f"compile (ahead of time): {compile_s:8.3f} s")
    print(f"jaxroll (jit, median) : {t_jax:8.3f} s  ({n * n * len(speeds) / t_jax / 1e6:.1f} M evals/s)")
    print(f"NumPy  (median{'' if ns == len(speeds) else f', {ns} speeds scaled'}) : {t_np:8.3f} s")
    print(f"ratio NumPy / jaxroll : {t_np / t_jax:8.2f}")
    print(f"max rel. difference   : {rel:.2e}")
    summary("bench_layer.py" + (" --quick" if args.quick else f" --modes {n}"), t_jax, compile_s,
            f"same closed form in NumPy {t_np:.3f} s", f"{t_np / t_jax:.1f}x",
            f"{n} x {n} modes x {len(speeds)} speeds, with inertia")


if __name__ == "__main__":
    main()
