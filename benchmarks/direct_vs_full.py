"""Direct method vs the full 3D model over the reference case ([ZG] sec. 4.4, figs. 6-8).

Run:  python benchmarks/direct_vs_full.py [--quick] [--cases 30mm,5mm,10um]

For each case, the full 3D model (``jr.Full(grid=jr.FixedGrid(2.5e-4, window, period=0.2,
n_terms=500))`` through ``jr.rolling_resistance_grid``: the paper's resolution, window 41 cells
enlarged to fit the largest contact) over 23 log-spaced speeds 1e-4..1 m/s x 15 loads, SLS G0 = 3 MPa,
tau = 0.25 s, f = 1, frictionless:

* H = 30 mm and 5 mm: R = 2 cm, P = 10..150 N;
* H = 10 um: R = 2000 m, P = 0.2..2 kN (thin layer, gamma = 333..488),

against the direct series ([ZG] eq. 37/42, ``jr.Direct``) with the same period and number of
terms (L = 20 cm, 500 terms: the periodic train is the same physics as the full model's), with
the contact radius from the static modulus (default, E = 3 G0) and from
``modulus="dynamic"`` (G'(V/r_static)); the aperiodic direct value (single roller, the library
default) for reference; and the direct series with the exact static grid pressure
(``jr.DirectElastic(grid=<the full model's FixedGrid>)``: on the full model's own
grid, so that only the stationary-pressure assumption differs). Every method is run through
``jr.rolling_resistance_grid`` compiled ahead of time; compile and run times are printed apart.

Prints, per case and method, the relative error ``direct/full - 1`` (full = pressure-moment
form): its global mean, mean |.|, range, its mean below/above the R_r peak, its mean over loads
per speed and over speeds per load. (The old script also printed the full model's
moment-vs-dissipation spread; the public ``RollingResult`` carries no dissipation value.)
``--quick``: 6 speeds x 4 loads, a = 0.5 mm, 250 terms, window >= 21.

Result (old API, 2-core CPU, November 2026, full resolution; error = direct/full - 1, full =
moment form):

    case    static E (default)                  dynamic E          grid static pressure
            mean    low V  peak   plateau        mean   worst       mean
    30 mm   -13.5%  +0.8%  -18%   -23%           -3.2%  -13% (pk)   -13.7%
    5 mm    -19.9%  -1.6%  -25%   -33.5%         -5.6%  -19% (pk)   -17.4%
    10 um   -20.9%  +1.6%  -28%   -36%           -6.3%  -24% (pk)   -21.3%

The direct method (stationary pressure, static radius) UNDERESTIMATES the full model: ~0 at
1e-4 m/s, growing through the R_r peak to a plateau above it. That is the physics of the
assumption, not a discretisation artefact: on the same grid with the exact static pressure the
gap is the same, it is O(f) (tests/test_sphere3d.py::test_direct_vs_full_gap_vanishes_with_f),
and the exact 2D cylinder shows the same sign and size (-18.8 % at the peak, f = 1;
tests/test_direct.py::test_direct_error_vs_exact_cylinder). Above the peak the full contact
tends to the glassy elastic contact, whose radius is smaller; in 3D the direct R_r at high speed
is ~ P^2/(r V tau), so the static-radius value is low by r_glassy/r_static - 1 =
(1+f)^(-1/3) - 1 = -20.6 % (half-space; the aperiodic direct value at 1 m/s, H = 30 mm: -20.4 %).
``modulus="dynamic"`` (G'(V/r_static) for the radius) removes that plateau (+0.6..+1.2 % at
1 m/s) but not the error near the peak. The error is flat in the load on the thick (30 mm) and
thin (10 um) layers; on the 5 mm layer it grows with the load (-17 % at 10 N to -34 % at
150 N) as gamma -> 1 leaves the thick range.
"""

from __future__ import annotations

import argparse
import math

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from _timing import aot, summary

G0, TAU, F = 3e6, 0.25, 1.0
PERIOD = 0.2
CASES = {
    "30mm": dict(H=30e-3, R=0.02, loads=(10.0, 150.0)),
    "5mm": dict(H=5e-3, R=0.02, loads=(10.0, 150.0)),
    "10um": dict(H=10e-6, R=2000.0, loads=(200.0, 2000.0)),
}


def table(method, R):
    def fn(G, H, loads, speeds):
        out = jr.rolling_resistance_grid(jr.StandardLinearSolid(G, TAU, F), jr.Layer(H), radius=R, loads=loads,
                                         speeds=speeds, method=method)
        return out.value, out.result

    return fn


def run_case(name, quick):
    c = CASES[name]
    H, R = c["H"], c["R"]
    if quick:
        speeds, loads, spacing, n_terms = np.logspace(-4, 0, 6), np.linspace(*c["loads"], 4), 5e-4, 250
    else:
        speeds, loads, spacing, n_terms = np.logspace(-4, 0, 23), np.linspace(*c["loads"], 15), 2.5e-4, 500
    mat = jr.StandardLinearSolid(G0, TAU, F)
    r_max = float(jr.engines.contact_size.estimate_contact_size(mat, jr.Layer(H), R, float(loads.max())))
    window = max(41 if not quick else 21, 2 * math.ceil(1.15 * r_max / spacing) + 1)
    grid = jr.FixedGrid(spacing, window, period=PERIOD, n_terms=n_terms)
    args = (G0, H, jnp.asarray(loads), jnp.asarray(speeds))

    c_full, t_full, (v, st), _ = aot(table(jr.Full(grid=grid), R), *args, repeat=1)
    v, st = np.asarray(v), np.asarray(st)
    variants = {
        "direct (static E, L = 20 cm)": jr.Direct(period=PERIOD, n_terms=n_terms),
        "direct (dynamic E, L = 20 cm)": jr.Direct(modulus="dynamic", period=PERIOD, n_terms=n_terms),
        "direct (static E, aperiodic)": jr.Direct(),
        "direct (grid static pressure)": jr.DirectElastic(grid=grid),
    }
    methods, times = {}, {}
    for k, m in variants.items():
        comp, run, (val, status), _ = aot(table(m, R), *args, repeat=1)
        methods[k], times[k] = np.asarray(val), (comp, run)
        bad = np.asarray(status) != 0
        if bad.any():
            names = sorted({jr.RESULTS.names[int(x)] for x in np.asarray(status)[bad]})
            print(f"  {k}: {int(bad.sum())} points not valid ({', '.join(names)})")

    codes = sorted({jr.RESULTS.names[int(x)] for x in st[st != 0]})
    print(f"\n=== H = {H:g} m, R = {R:g} m, P = {loads[0]:g}..{loads[-1]:g} N, V = {speeds[0]:g}..{speeds[-1]:g} m/s "
          f"({len(speeds)} x {len(loads)}); a = {spacing * 1e3:g} mm, L = {PERIOD} m, {n_terms} terms, "
          f"window {window}; full model: run {t_full:.1f} s, compile {c_full:.1f} s; not valid {int(np.sum(st != 0))} "
          f"({', '.join(codes) or 'none'})")
    print("direct methods: " + "; ".join(f"{k.split('(')[1][:-1]}: run {r:.3f} s, compile {c:.1f} s"
                                       for k, (c, r) in times.items()))
    print(f"full model: R_r {v.min():.4g}..{v.max():.4g} N")
    peak = np.argmax(v, axis=0)  # speed index of the R_r peak per load
    above = np.arange(len(speeds))[:, None] > peak[None, :]
    print(f"{'method':32s} {'mean':>8s} {'mean|.|':>8s} {'min':>8s} {'max':>8s} {'below pk':>8s} {'above pk':>8s}")
    for k, m in methods.items():
        e = m / v - 1.0
        print(f"{k:32s} {e.mean():+8.2%} {np.abs(e).mean():8.2%} {e.min():+8.2%} {e.max():+8.2%} "
              f"{e[~above].mean():+8.2%} {e[above].mean():+8.2%}")
    for k, m in methods.items():
        e = m / v - 1.0
        print(f"{k}: mean error per speed [{', '.join(f'{x:+.1%}' for x in e.mean(axis=1))}]")
        print(f"{' ' * len(k)}  mean error per load  [{', '.join(f'{x:+.1%}' for x in e.mean(axis=0))}]")
    per = v.size
    c_d, t_d = times["direct (static E, aperiodic)"]
    summary(f"direct_vs_full.py{' --quick' if quick else ''} --cases {name}", t_d, c_d,
            f"full 3D {t_full:.2f} s on the same {per} points", f"{t_full / t_d:.0f}x",
            f"direct aperiodic mean error {np.mean(methods['direct (static E, aperiodic)'] / v - 1):+.1%}; "
            f"a = {spacing * 1e3:g} mm")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--cases", default="30mm,5mm,10um")
    args = ap.parse_args()
    print(f"device: {jax.devices()[0].device_kind} (shared 2-core machine); SLS G0 = {G0:g} Pa, tau = {TAU} s, "
          f"f = {F}")
    for name in args.cases.split(","):
        run_case(name, args.quick)


if __name__ == "__main__":
    main()
