"""Bias of the smoothed contact edge (``jr.Full(edge_smoothing=kappa)``) and of its Richardson
extrapolation (``edge_extrapolation=True``, the fitting default) against the exact discrete
contact on the same default grid, over the regime zeta = V tau / a0.

Sphere (R = 2 cm, 100 N) and cylinder (R = 2 cm, 10 kN/m) on a half-space; standard linear solid
G0 = 3 MPa, tau = 0.25 s, f from ``--f`` (default 1), or ``--prony``: a 6-term Prony series
(G_inf = 1 MPa, G_i = 0.5 MPa, tau_i = 2.5e-3..250 s; speeds 1e-5..1 m/s labelled with
their regime zeta, ``jr.grids.regime``). The grid is the
default one of each point (``jr.Full().resolve``), shared by every model of the row. Prints the
relative difference [%] of the reported value (dissipation form) at kappa = K and 2K (``--kappa``,
default the fitting default 0.125) and of the extrapolated model, and for the cylinder's SLS rows
the errors of the exact discrete contact and of the extrapolated model against the exact 2D
solution (``jr.reference.exact_cylinder_halfspace``). ``--fine``: also the exact discrete contact
at 2x and 3x the default cells per radius (a convergence study; the column "extrap vs 3x" then
compares the extrapolated model at the default grid with the 3x grid).
``--record`` stores the rows in benchmarks/numbers.json (section ``edge_smoothing``, one run per
geometry and material, the others kept), from which ``benchmarks/render_docs.py`` writes the table
of docs/validation.md.
Run: ``python benchmarks/edge_smoothing_bias.py [--geometry sphere] [--f 1] [--prony] [--fine] [--record]``.
"""

import argparse
import sys
import warnings

import jax.numpy as jnp
import numpy as np

import _numbers
import jaxroll as jr
from jaxroll.methods import FIT_EDGE_SMOOTHING

HALF = jr.Layer(H=jnp.inf)
LOAD = {"sphere": 100.0, "cylinder": 1e4}
PRONY = jr.GeneralizedMaxwell(G_inf=1e6, G=np.full(6, 0.5e6), tau=2.5 * np.logspace(-3, 2, 6))


def value(mat, g, P, V, method):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.ValidityWarning)
        r = jr.rolling_resistance(mat, HALF, radius=0.02, load=P, speed=V, geometry=g, throw=False, method=method)
    return float(r.value), int(r.result)


def row(mat, g, P, V, kappa, fine, sls):
    base = jr.Full().resolve(mat, HALF, radius=0.02, loads=P, speeds=V, geometry=g)
    grid = base.grid
    a = jr.engines.contact_size.estimate_contact_size(mat, HALF, 0.02, P, g)
    cells = float(a) / float(grid.spacing)
    exact, code = value(mat, g, P, V, jr.Full(grid=grid))
    k1, _ = value(mat, g, P, V, jr.Full(grid=grid, edge_smoothing=kappa))
    k2, _ = value(mat, g, P, V, jr.Full(grid=grid, edge_smoothing=2 * kappa))
    ex, code_x = value(mat, g, P, V, jr.Full(grid=grid, edge_smoothing=kappa, edge_extrapolation=True))
    out = [cells, 100 * (k1 / exact - 1), 100 * (k2 / exact - 1), 100 * (ex / exact - 1)]
    if g == "cylinder" and sls:
        ref = float(jr.reference.exact_cylinder_halfspace(mat, 0.02, P, V).rolling_resistance)
        out += [100 * (exact / ref - 1), 100 * (ex / ref - 1)]
    if fine:
        for m in (2, 3):
            c = int(round(m * cells))
            f, _ = value(mat, g, P, V, jr.Full(grid=jr.AutoGrid(cells_per_radius=c)))
            out.append(100 * (f / exact - 1))
        out.append(100 * (ex / f - 1))
    return out, (code, code_x)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kappa", type=float, default=FIT_EDGE_SMOOTHING)
    ap.add_argument("--geometry", default="sphere", choices=["sphere", "cylinder"])
    ap.add_argument("--zetas", default="0.01,0.1,1,10,100")
    ap.add_argument("--f", type=float, default=1.0)
    ap.add_argument("--prony", action="store_true")
    ap.add_argument("--fine", action="store_true")
    ap.add_argument("--record", action="store_true", help="store the rows in benchmarks/numbers.json")
    args = ap.parse_args()
    g, P = args.geometry, LOAD[args.geometry]
    mat = PRONY if args.prony else jr.StandardLinearSolid(G0=3e6, tau=0.25, f=args.f)
    a0 = float(jr.engines.contact_size.estimate_contact_size(mat, HALF, 0.02, P, g))
    head = f"zeta  cells  k={args.kappa:g}  k={2 * args.kappa:g}  extrap"
    if g == "cylinder" and not args.prony:
        head += "  exact-vs-2D  extrap-vs-2D"
    if args.fine:
        head += "  2x  3x  extrap-vs-3x"
    print(f"{g}, {'Prony' if args.prony else f'SLS f = {args.f:g}'}: relative differences [%] against the exact "
          f"discrete contact on the default grid unless named\n{head}")
    # the Prony rows: speeds 1e-5..1 m/s, each labelled with its regime zeta (jr.grids.regime)
    speeds = (np.logspace(-5, 0, 6) if args.prony else [float(x) * a0 / 0.25 for x in args.zetas.split(",")])
    rows, exact_2d = [], g == "cylinder" and not args.prony
    for V in speeds:
        z = float(jr.grids.regime(mat, V, a0)[0])
        out, codes = row(mat, g, P, V, args.kappa, args.fine, not args.prony)
        print(f"{z:<6g} {out[0]:5.1f} " + " ".join(f"{x:+7.3f}" for x in out[1:]) +
              ("" if codes == (0, 0) else f"  (result codes {codes})"), flush=True)
        rows.append({"zeta": z, "V": float(V), "cells": out[0], "kappa": out[1], "kappa2": out[2], "extrapolated": out[3],
                     "exact_vs_2d": out[4] if exact_2d else None, "extrapolated_vs_2d": out[5] if exact_2d else None,
                     "valid": codes == (0, 0), "results": [jr.RESULTS.names[c] for c in codes]})
    if args.record:
        record_run(f"{g}-{'prony' if args.prony else f'f{args.f:g}'}", args, rows)


def record_run(key, args, rows):
    """Store this run under ``key`` in numbers.json's ``edge_smoothing`` section (other runs kept)."""
    runs = _numbers.load().get("edge_smoothing", {}).get("runs", {})
    runs[key] = {"measured": _numbers.machine(), "command": "python benchmarks/edge_smoothing_bias.py " + " ".join(sys.argv[1:]),
                 "kappa": args.kappa, "rows": rows}
    _numbers.record("edge_smoothing", {"runs": runs})


if __name__ == "__main__":
    main()
