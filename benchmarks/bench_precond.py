"""Benchmark of the GMRES preconditioner of jaxroll.contact (circulant-embedding inverse) vs none.

Run:  python benchmarks/bench_precond.py [--quick] [--repeat 3] [--no-sweep] [--no-smooth] [--fit]

Cases (3D sphere at the paper's resolution: R = 2 cm, SLS G0 = 3 MPa, tau = 0.25 s, f = 1,
H = 30 mm, period 0.2 m, cell 0.25 mm, window 55, 500 Fourier terms):
* single solves (jitted solve_sphere) for P = 10, 150 N and V = 1e-3, 1e-2, 1e-1 m/s;
* rolling_resistance_sweep, 5 loads x 4 speeds (exact and with edge_smoothing = 0.25);
* with ``--fit``: one full-model fit evaluation (residual + jacfwd, 60 points, edge_smoothing 0.25);
* one 2D cylinder solve (bench_cylinder's default case).
Reports compile time apart, medians of ``--repeat`` runs after a warm-up, the count of compliance
applications per solve (~ GMRES iterations; counted in a separate run with a host callback),
the relative difference of the resistance values, and the speed ratios.
"""

from __future__ import annotations

import argparse
import functools
import os
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from jaxroll import contact as ct
from jaxroll import cylinder as cy
from jaxroll import sphere3d as s3
from _timing import timed

G0, TAU, F, R, H = 3e6, 0.25, 1.0, 0.02, 0.03
MAT = jr.StandardLinearSolid(G0, TAU, F)
_solve_contact_orig = ct.solve_contact
_COUNT = [0]
_call_orig = ct.WindowedCompliance.__call__


def _counting_call(self, p):
    jax.debug.callback(lambda: _COUNT.__setitem__(0, _COUNT[0] + 1))
    return _call_orig(self, p)


def with_precond(flag, fn):
    """``fn`` traced with ``solve_contact(..., linear_preconditioner=flag)`` (module patch)."""

    @functools.wraps(fn)
    def wrapped(*a):
        ct.solve_contact = functools.partial(_solve_contact_orig, linear_preconditioner=flag)
        try:
            return fn(*a)
        finally:
            ct.solve_contact = _solve_contact_orig

    return wrapped


def timeit(fn, args, repeat):
    """(compile seconds, median run seconds after a warm-up, output): ahead-of-time compilation
    timed alone, then :func:`_timing.timed` on the compiled function."""
    t = time.perf_counter()
    compiled = jax.jit(fn).lower(*args).compile()
    t_c = time.perf_counter() - t
    _, median, out = timed(compiled, *args, repeat=repeat)
    return t_c, median, out


def count_calls(fn, args):
    ct.WindowedCompliance.__call__ = _counting_call
    try:
        jax.clear_caches()  # the inner eqx.filter_jit traces are cached too
        _COUNT[0] = 0
        out = jax.block_until_ready(jax.jit(lambda *a: fn(*a))(*args))  # fresh trace (jit caches by function)
        jax.effects_barrier()
        n = _COUNT[0]
    finally:
        ct.WindowedCompliance.__call__ = _call_orig
    return n, out


def compare(name, fn, args, repeat, value=lambda o: o[0], count=True):
    res = {}
    for flag in (False, True):
        f = with_precond(flag, fn)
        t_c, t_run, out = timeit(f, args, repeat)
        n = count_calls(f, args)[0] if count else -1
        res[flag] = (t_c, t_run, out, n)
    v0, v1 = np.asarray(value(res[False][2])), np.asarray(value(res[True][2]))
    rel = np.max(np.abs(v1 - v0) / np.abs(v0))
    print(f"{name}: none {res[False][1]:.3f} s ({res[False][3]} C-apps), precond {res[True][1]:.3f} s "
          f"({res[True][3]} C-apps); ratio {res[False][1] / res[True][1]:.2f}x; max rel diff {rel:.1e}; "
          f"compile {res[False][0]:.1f}/{res[True][0]:.1f} s", flush=True)
    return res


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-sweep", action="store_true")
    ap.add_argument("--no-smooth", action="store_true")
    ap.add_argument("--no-single", action="store_true")
    ap.add_argument("--fit", action="store_true", help="also time one full-model fit evaluation")
    args = ap.parse_args()
    spacing, n_terms, window = (5e-4, 250, 29) if args.quick else (2.5e-4, 500, 55)
    print(f"device: {jax.devices()[0].device_kind}; cpu count {os.cpu_count()}; "
          f"load avg {os.getloadavg()}", flush=True)
    opts = dict(period=0.2, spacing=spacing, window=window, n_terms=n_terms)

    if not args.no_single:
        def single(P, V):
            s = s3.solve_sphere(MAT, jr.Layer(H=H), 0.02, P, V, throw=False, **opts)
            return s.resistance, s.contact.status, s.contact.iterations

        for P in (10.0, 150.0):
            for V in (1e-3, 1e-2, 1e-1):
                r = compare(f"single P={P:g} V={V:g}", single, (jnp.asarray(P), jnp.asarray(V)), args.repeat)
                st = [int(r[k][2][1]) for k in (False, True)]
                it = [int(r[k][2][2]) for k in (False, True)]
                print(f"    status {st}, active-set iterations {it}", flush=True)

    loads = jnp.linspace(10.0, 150.0, 5)
    speeds = jnp.asarray([1e-3, 1e-2, 1e-1, 1.0])
    if not args.no_sweep:
        kappas = (None,) if args.no_smooth else (None, 0.25)
        for kappa in kappas:
            def sweep(G):
                out = s3.rolling_resistance_sweep(jr.StandardLinearSolid(G, TAU, F), jr.Layer(H), R, loads, speeds,
                                                  edge_smoothing=kappa, **opts)
                return out["value"], out["status"]

            r = compare(f"sweep 5x4 edge_smoothing={kappa}", sweep, (jnp.asarray(G0),), args.repeat)
            print(f"    status nonzero: {[int(np.sum(np.asarray(r[k][2][1]) != 0)) for k in (False, True)]}",
                  flush=True)

    if args.fit:
        # one full-model fit evaluation (jaxroll.fit, method="full"): residual + Jacobian by
        # jax.jacfwd (3 forward tangents) of the sweep of the shipped 60-point set (12 speeds x
        # 5 loads, paper resolution, edge_smoothing = 0.25, window from fitting/make_synthetic.py)
        r_max = float(s3.estimate_contact_radius(MAT, jr.Layer(H), R, 150.0))
        w_fit = max(41, 2 * int(np.ceil(1.15 * r_max / spacing)) + 1)
        fit_opts = dict(opts, window=w_fit, edge_smoothing=0.25)
        fl, fs = jnp.linspace(10.0, 150.0, 5), jnp.logspace(-4, 0, 12)

        def fit_eval(th):
            def f(lp):
                G, tau, ff = jnp.exp(lp)
                out = s3.rolling_resistance_sweep(jr.StandardLinearSolid(G, tau, ff), jr.Layer(H), R, fl, fs,
                                                  **fit_opts)
                return out["value"].ravel(), out["value"].ravel()

            J, r = jax.jacfwd(f, has_aux=True)(th)
            return r, J

        r = compare(f"fit evaluation (60 points, residual + jacfwd 3 tangents, window {w_fit})", fit_eval,
                    (jnp.log(jnp.asarray([G0, TAU, F])),), args.repeat, count=not args.quick)
        J0, J1 = np.asarray(r[False][2][1]), np.asarray(r[True][2][1])
        print(f"    Jacobian max rel diff {np.max(np.abs(J1 - J0)) / np.max(np.abs(J0)):.1e} (relative to max |J|)",
              flush=True)

    def cyl(V):
        s = cy.solve_cylinder(MAT, jr.Layer(5e-3), R, 5e3, V, n_cells=2**17, cells_per_radius=25, throw=False)
        return s.resistance, s.contact.status

    compare("cylinder single (H = 5 mm, P' = 5 kN/m, 2^17 cells, 25 cells/half-width)", cyl,
            (jnp.asarray(0.1),), max(args.repeat, 5))
    print(f"load avg at end {os.getloadavg()}")


if __name__ == "__main__":
    main()
