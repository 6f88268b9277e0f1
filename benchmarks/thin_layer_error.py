"""Error of the full models' reported value on layers thinner than the half-space tables'
calibration (contact size over thickness ``a/H`` = 0.2..15): the calibration of
:data:`jaxroll.grids.THIN_ERROR` and :data:`jaxroll.grids.THIN_BROAD_ERROR`.

The half-space tables of :mod:`jaxroll.grids` (``LINE_ERROR``, ``SPHERE_ERROR``) were measured on
half-spaces (``benchmarks/resistance_forms.py``). On a finite layer the pressure near the contact
edges changes shape (on a thin incompressible layer it falls to zero with zero slope, and the
compliance kernel is only ~H wide), and the error of a grid counted in cells per estimated
contact size changes with it. Modes:

* ``--study [--geometry cylinder|sphere] [--out FILE] [--validation] [--zetas Z,..] [--ratios T,..]``:
  both forms of R_r (moment M, dissipation D) at fixed cells per estimated contact size
  (cylinder 12..400 and 800, 1600 for the reference; sphere 12..48 and 64, 96) on layers of
  ``a/H`` = :data:`THICKNESS_RATIOS` (``a`` the estimate
  :func:`jaxroll.engines.contact_size.estimate_contact_size`, the size the grid rules count cells
  on; ``H`` solved for it), at the regimes :data:`ZETAS` (``V tau/a`` for the standard linear
  solids: cylinder f = 0.3, 1, 3, 10, sphere f = 1, 3; and for the cylinder a 20-decade Prony
  series at 1e-6..1e3 m/s). CSV lines ``geometry,material,ratio,zeta_or_-speed,speed,H,load,
  radius,nu,cells,M,D,result,contact,estimate,seconds``. The validation set: f = 0.5 and 2,
  ratios and regimes between the calibration's, a compressible layer (nu = 0.4), and the
  conveyor idler of docs/conveyor.md (R = 94 mm, H = 1.05 mm, f = 0.5..5).
* ``--analyse FILE [FILE...] [--record]``: the error [%] of the reported value at every grid
  against the reference (D extrapolated to zero cell size, a fit ``D + C c^-p`` over the finer
  grids), the envelope by ratio, regime and cells (printed as the tables' literal), and at the
  default grid (``jr.Full()``) the error with its ``truncation``; a file whose name contains
  "validation" is the validation set. ``--record`` stores the tables and a summary by
  thickness band in benchmarks/numbers.json (docs/validation.md's thin-layer table;
  tests/test_docs_numbers.py checks that :mod:`jaxroll.grids` holds the recorded tables).

Cylinder R = 2 cm, P = 10 kN/m; sphere R = 2 cm, P = 100 N; G0 = 3 MPa, tau = 0.25 s.
The data of the recorded run: benchmarks/thin_layer_error_study.csv and
benchmarks/thin_layer_error_validation.csv.
"""

import argparse
import csv
import math
import os
import sys
import time
import warnings

import jaxroll as jr  # noqa: I001 (first: it quiets XLA's false SIGILL lines before JAX loads)
import numpy as np
from jaxroll import grids
from jaxroll.engines.contact_size import estimate_contact_size

import _numbers

#: the roller of each geometry: radius [m], load [N, or N/m]
ROLLER = {"cylinder": (0.02, 1e4), "sphere": (0.02, 100.0)}
_K = np.arange(-10, 11.0)
MATERIALS = {f"s{f:g}": jr.StandardLinearSolid(G0=3e6, tau=0.25, f=f) for f in (0.3, 0.5, 1.0, 2.0, 3.0, 10.0)}
MATERIALS["pr"] = jr.GeneralizedMaxwell(G_inf=3e6, G=1.5e6 * 10 ** (-0.1 * _K), tau=10.0 ** _K)
#: the conveyor idler of docs/conveyor.md's example: a cover of 1.05 mm, G0 = 3.15 MPa, tau = 29.5 s
IDLER = {"radius": 0.094, "H": 1.05e-3}
THICKNESS_RATIOS = {"cylinder": [0.2, 0.35, 0.5, 1.0, 2.0, 3.5, 6.0, 10.0, 15.0], "sphere": [0.2, 0.5, 1.0, 2.0, 3.5, 6.0, 10.0]}
ZETAS = {"cylinder": [1e-3, 3e-3, 1e-2, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 100.0, 1000.0],
         "sphere": [0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 100.0]}
PRONY_SPEEDS = [1e-6, 1e-3, 1.0, 1e3]
#: the study's grids (cells per estimated contact size), the tables' columns
CELLS = {"cylinder": [12, 25, 50, 100, 200, 400], "sphere": [12, 16, 20, 24, 32, 48]}
#: the finer grids of the reference, and the coarsest grid its extrapolation fits
REFERENCE_CELLS = {"cylinder": [800, 1600], "sphere": [64, 96]}
EXTRAPOLATION_CELLS = {"cylinder": 100, "sphere": 20}
#: result codes of a solve that did not converge (its value is not the grid's answer; the study's
#: other codes are the current error estimate's flags, which the study re-calibrates)
SOLVER_FAILURES = {jr.RESULTS.max_steps_reached, jr.RESULTS.linear_solve_failed, jr.RESULTS.window_too_small,
                   jr.RESULTS.nonfinite}


def thickness_for(material, ratio, geometry, radius, load, nu=0.5):
    """The thickness H [m] at which the estimated contact size over H is ``ratio`` (bisection in
    log H: the ratio falls as H grows)."""
    lo, hi = math.log(1e-7), math.log(10.0)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        H = math.exp(mid)
        a = float(estimate_contact_size(material, jr.Layer(H=H, nu=nu), radius, load, geometry))
        lo, hi = (mid, hi) if a / H > ratio else (lo, mid)
    return math.exp(0.5 * (lo + hi))


def speed_of(material, layer, zeta, geometry, radius, load):
    """``zeta > 0``: the speed at which ``V tau/a`` is ``zeta`` (``a`` the estimate, tau = 0.25 s);
    ``zeta < 0``: the speed -zeta [m/s]."""
    if zeta < 0:
        return -zeta
    return zeta * float(estimate_contact_size(material, layer, radius, load, geometry)) / 0.25


def study_rows(geometry, validation=False, zetas=None, ratios=None):
    """(material tag, ratio, zeta or -speed, cells, nu, radius, load, H or None) of the study or of
    its validation set (``zetas``, ``ratios``: these regimes and thickness ratios instead of the
    study's)."""
    cells = CELLS[geometry] + REFERENCE_CELLS[geometry]
    R, P = ROLLER[geometry]
    out = []
    if validation and geometry == "sphere":
        cases = [(tag, t, z, 0.5) for tag in ("s0.5", "s2") for t in (0.7, 2.5) for z in (0.05, 0.5, 5.0)]
        return [(tag, t, z, c, nu, R, P, None) for tag, t, z, nu in cases for c in cells]
    if validation:
        cases = [(tag, t, z, 0.5) for tag in ("s0.5", "s2") for t in (0.7, 2.5, 8.0) for z in (3e-3, 0.05, 0.5, 5.0, 300.0)]
        cases += [("s1", t, z, 0.4) for t in (0.5, 2.0, 6.0) for z in (1e-2, 0.3, 3.0, 100.0)]
        out += [(tag, t, z, c, nu, R, P, None) for tag, t, z, nu in cases for c in cells]
        for tag in ("s0.5", "s1", "s2", "s5"):
            for load in (50.0, 200.0, 600.0):
                for V in (1e-4, 1e-3, 1e-2, 1e-1):
                    out += [("idler-" + tag, None, -V, c, 0.5, IDLER["radius"], load, IDLER["H"]) for c in cells]
        return out
    tags = ("s0.3", "s1", "s3", "s10") if geometry == "cylinder" else ("s1", "s3")
    ratios = ratios or THICKNESS_RATIOS[geometry]
    cases = [(tag, t, z) for tag in tags for t in ratios for z in zetas or ZETAS[geometry]]
    if geometry == "cylinder" and zetas is None:
        cases += [("pr", t, -v) for t in ratios for v in PRONY_SPEEDS]
    return [(tag, t, z, c, 0.5, R, P, None) for tag, t, z in cases for c in cells]


def material_of(tag):
    if tag.startswith("idler-"):
        return jr.StandardLinearSolid(3.15e6, 29.5, float(tag[len("idler-s"):]))
    return MATERIALS[tag]


def study(out, geometry, validation=False, only=None, zetas=None, ratios=None):
    rows = study_rows(geometry, validation, zetas, ratios)
    layers = {}
    with open(out, "a") as fh:
        for i, (tag, t, z, c, nu, radius, load, H) in enumerate(rows):
            if only is not None and i % only[1] != only[0]:
                continue
            m = material_of(tag)
            if H is None:
                key = (tag, t, nu, radius, load)
                if key not in layers:
                    layers[key] = thickness_for(m, t, geometry, radius, load, nu)
                H = layers[key]
            layer = jr.Layer(H=H, nu=nu)
            V = speed_of(m, layer, z, geometry, radius, load)
            est = float(estimate_contact_size(m, layer, radius, load, geometry))
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # coarse grids are flagged by their own estimate
                r = jr.rolling_resistance(m, layer, radius=radius, load=load, speed=V, geometry=geometry,
                                          method=jr.Full(grid=jr.AutoGrid(cells_per_radius=c)), throw=False)
            fh.write(f"{geometry},{tag},{t if t is not None else est / H!r},{z!r},{V!r},{H!r},{load!r},{radius!r},{nu!r},{c},"
                     f"{float(r.solution.resistance_moment)!r},{float(r.value)!r},{int(r.result)},"
                     f"{float(r.contact_radius)!r},{est!r},{time.perf_counter() - t0:.2f}\n")
            fh.flush()


def extrapolated(cells, D, geometry):
    """``D_inf`` of the fit ``D(c) = D_inf + C c^-p`` (0.5 <= p <= 4) over the grids of at least
    :data:`EXTRAPOLATION_CELLS` cells."""
    from scipy.optimize import least_squares

    cells, D = np.asarray(cells, float), np.asarray(D, float)
    sel = cells >= EXTRAPOLATION_CELLS[geometry]
    fit = least_squares(lambda q: (q[0] + q[1] * cells[sel] ** -q[2] - D[sel]) / D[-1], [D[-1], 0.0, 1.5],
                        bounds=([0, -np.inf, 0.5], [np.inf, np.inf, 4.0]))
    return fit.x[0]


def read(paths):
    """``{(geometry, tag, ratio, zeta, H, load, radius, nu): {cells: (M, D, code, contact,
    estimate, V)}}``."""
    table = {}
    for path in paths:
        for row in csv.reader(open(path)):
            g, tag, t, z, V, H, load, radius, nu, c, M, D, code, contact, est = row[:15]
            key = (g, tag, float(t), float(z), float(H), float(load), float(radius), float(nu))
            table.setdefault(key, {})[int(c)] = (float(M), float(D), int(code), float(contact), float(est), float(V))
    return table


def analyse_rows(paths, validation=False):
    """For every point: the reference (D extrapolated), the error [%] of D at every grid, the
    regime, and the default grid's cells with the error [%] of the reported value and its
    ``truncation`` [%] (the study's run at the default's cells, where the study has it)."""
    out = []
    for key, d in sorted(read(paths).items(), key=lambda kv: (kv[0][:3], abs(kv[0][3]))):
        g, tag, t, z, H, load, radius, nu = key
        cs = sorted(d)
        ref_cells = [c for c in cs if c >= EXTRAPOLATION_CELLS[g]]
        if any(d[c][2] in SOLVER_FAILURES for c in ref_cells) or cs[-1] < max(REFERENCE_CELLS[g]):
            print(f"skipped (a reference grid failed or is missing): {key}", file=sys.stderr)
            continue
        ref = extrapolated(cs, [d[c][1] for c in cs], g)
        m = material_of(tag)
        layer = jr.Layer(H=H, nu=nu)
        V = d[cs[-1]][5]
        size = float(grids.counting_size(m, layer, radius, load, V, g))
        zeta, breadth = (float(x) for x in grids.regime(m, V, size))
        cells, _, _ = jr.AutoGrid().point_cells(m, layer, radius, [load], [V], g)
        c = int(cells[0])
        default = None
        if c in d:
            M, D, code, contact, est, _ = d[c]
            default = {"cells": c, "failed": code in SOLVER_FAILURES,
                       "error": 100 * (float(grids.full_model_value(M, D, zeta)) / ref - 1),
                       "truncation": 100 * float(grids.full_model_error(M, D, zeta, c, g, contact / size, breadth,
                                                                        size / H)),
                       "gap": 100 * abs(M - D) / abs(D)}
        out.append({"geometry": g, "material": tag, "ratio": t, "zeta": z, "H": H, "load": load, "radius": radius,
                    "validation": validation,
                    "nu": nu, "zeta_regime": zeta, "breadth": breadth, "counting_ratio": size / H,
                    "finest_vs_reference": 100 * (d[cs[-1]][1] / ref - 1),
                    # the reported value: the dissipation form, blended toward the midpoint of both
                    # forms below zeta = 5e-3 (jaxroll.grids.full_model_value)
                    "errors": {str(k): 100 * (float(grids.full_model_value(d[k][0], d[k][1], zeta)) / ref - 1)
                               for k in cs if k in CELLS[g]},
                    "failed": {str(k): d[k][2] in SOLVER_FAILURES for k in cs if k in CELLS[g]},
                    "default": default})
    return out


def envelope(rows, geometry):
    """Largest |error| [%] of the reported value by thickness ratio (the nearest of
    :data:`THICKNESS_RATIOS`), regime zeta (the nearest node of
    :data:`jaxroll.grids.ERROR_LOG_ZETA`) and cells (:data:`CELLS`), of the study's rows
    (incompressible layers) of the standard linear solids; ``nan`` where the study has no point.
    And the broad spectrum's own envelope (the Prony series, regime zeta 0.9-1.1) by ratio and
    cells, divided by its breadth (the tables' ``THIN_BROAD_ERROR``: a broad spectrum near the
    peak errs several times more than a single Debye peak on thin layers)."""
    ratios, nodes, cells = THICKNESS_RATIOS[geometry], np.asarray(grids.ERROR_LOG_ZETA), CELLS[geometry]
    env = np.full((len(ratios), len(nodes), len(cells)), np.nan)
    broad = np.full((len(ratios), len(cells)), np.nan)
    for r in rows:
        i = int(np.argmin([abs(math.log(r["counting_ratio"] / t)) for t in ratios]))
        k = int(np.argmin(np.abs(nodes - math.log10(r["zeta_regime"]))))
        for j, c in enumerate(cells):
            e = r["errors"].get(str(c))
            if e is None or r["failed"][str(c)]:
                continue
            if r["material"] == "pr":
                broad[i, j] = np.fmax(broad[i, j], abs(e) / max(r["breadth"], 1e-3))
            else:
                env[i, k, j] = np.fmax(env[i, k, j], abs(e))
    return env, broad


def table_values(env):
    """The envelope as the thin-layer tables of :mod:`jaxroll.grids` hold it: made non-increasing
    in the cells (each entry the largest error at that grid or any finer one: the error is not
    monotone in the cells at low zeta, and the tables are interpolated between their columns),
    rounded up to two significant digits, at least 0.01 %; a bin without a converged reference
    point (the finest grids failed) as 100 % (the point is then never valid). Nested lists."""
    def up(x):
        if not np.isfinite(x):
            return 100.0
        x = max(x, 0.01)
        k = 10.0 ** (math.floor(math.log10(x)) - 1)
        return round(math.ceil(x / k - 1e-9) * k, 6)

    env = np.fmax.accumulate(np.where(np.isfinite(env), env, np.inf)[..., ::-1], axis=-1)[..., ::-1]
    return np.vectorize(up)(env).tolist()


def table_literal(env):
    """:func:`table_values` as the Python literal of :mod:`jaxroll.grids`."""
    vals = table_values(env)
    return "(\n" + "".join("    (\n" + "".join("        (" + ", ".join(f"{x:g}" for x in row) + "),\n"
                                                  for row in block) + "    ),\n" for block in vals) + ")"


def analyse(paths, record=False):
    rows = []
    for path in paths:  # a file whose name contains "validation" is the validation set
        rows += analyse_rows([path], "validation" in os.path.basename(path))
    for g in ("cylinder", "sphere"):
        sel = [r for r in rows if r["geometry"] == g]
        if not sel:
            continue
        print(f"\n{g}: error [%] of D at cells " + ", ".join(map(str, CELLS[g])) + "; default: cells, error, truncation, gap")
        for r in sel:
            z = r["zeta"]
            label = f"{z:g}" if z > 0 else f"V={-z:g}"
            errs = " ".join(f"{r['errors'].get(str(c), float('nan')):+7.3f}" for c in CELLS[g])
            d = r["default"]
            dflt = "-" if d is None else f"{d['cells']:4d} {d['error']:+7.3f} tr {d['truncation']:6.2f} gap {d['gap']:6.2f}"
            bad = "" if d is None or abs(d["error"]) <= d["truncation"] else "  UNBOUNDED"
            print(f"{r['material']:9s} t={r['counting_ratio']:6.2f} nu={r['nu']} {label:9s} zr={r['zeta_regime']:8.3g} "
                  f"fin {r['finest_vs_reference']:+.4f} | {errs} | {dflt}{bad}")
        env, broad = envelope([r for r in sel if r["nu"] == 0.5 and not r["validation"]], g)
        print(f"\n{g}: envelope |error| [%] by a/H (blocks), regime log10 zeta (rows) and cells (columns):")
        for t, block in zip(THICKNESS_RATIOS[g], env):
            print(f"a/H = {t:g}")
            for z, e in zip(grids.ERROR_LOG_ZETA, block):
                print(f"  {z:5.1f}: " + " ".join(f"{x:7.3f}" for x in e))
        print(table_literal(env))
        if np.isfinite(broad).any():
            print(f"\n{g}: broad spectrum, |error| / breadth [%] by a/H (rows) and cells (columns):")
            print(table_literal(broad[None])[2:-2].replace("    (\n", "(\n"))
        dd = [r["default"] for r in sel if r["default"] is not None]
        if dd:
            print(f"\n{g} default grid: {len(dd)} points, worst |error| {max(abs(x['error']) for x in dd):.3f} %, "
                  f"unbounded {sum(abs(x['error']) > x['truncation'] for x in dd)}, "
                  f"truncation > 5 %: {sum(x['truncation'] > 5 for x in dd)}")
    if record:
        tables = {}
        for g in ("cylinder", "sphere"):
            env, broad = envelope([r for r in rows if r["geometry"] == g and r["nu"] == 0.5 and not r["validation"]], g)
            tables[g] = {"thin_error": table_values(env)}
            if np.isfinite(broad).any():
                tables[g]["thin_broad_error"] = table_values(broad[None])[0]
        _numbers.record("thin_layer_error", {
            "command": "python benchmarks/thin_layer_error.py --analyse " + " ".join(
                f"benchmarks/{os.path.basename(p)}" for p in paths) + " --record",
            "tables": tables, "summary": summary(rows)})


def summary(rows):
    """The default grid's points by geometry, calibration or validation, and thickness band:
    how many, how many valid (solved, ``truncation`` <= 5 %), the worst |error| [%] of the valid
    ones, and how many errors the truncation bounds."""
    bands = [(0.0, 0.3), (0.3, 1.5), (1.5, 5.0), (5.0, 100.0)]
    out = []
    for g in ("cylinder", "sphere"):
        for validation in (False, True):
            for lo, hi in bands:
                sel = [r["default"] for r in rows if r["geometry"] == g and r["validation"] == validation
                       and lo <= r["counting_ratio"] < hi and r["default"] is not None]
                if not sel:
                    continue
                valid = [d for d in sel if not d["failed"] and d["truncation"] <= 5.0]
                out.append({"geometry": g, "validation": validation, "ratios": [lo, hi], "points": len(sel),
                            "valid": len(valid), "worst_valid_error": float(max((abs(d["error"]) for d in valid), default=0.0)),
                            "cells": [int(min(d["cells"] for d in sel)), int(max(d["cells"] for d in sel))],
                            "bounded": int(sum(abs(d["error"]) <= d["truncation"] for d in sel))})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--study", action="store_true")
    ap.add_argument("--geometry", default="cylinder", choices=["cylinder", "sphere"], help="--study: the model")
    ap.add_argument("--zetas", default=None, help="--study: comma-separated regimes (default: all)")
    ap.add_argument("--ratios", default=None, help="--study: comma-separated thickness ratios (default: all)")
    ap.add_argument("--validation", action="store_true", help="--study: the validation set")
    ap.add_argument("--out", default="thin_layer_error.csv")
    ap.add_argument("--part", default=None, help="--study: 'k/n', every n-th row from the k-th (parallel runs)")
    ap.add_argument("--analyse", nargs="+", default=None, metavar="FILE")
    ap.add_argument("--record", action="store_true")
    a = ap.parse_args()
    if a.study:
        only = None if a.part is None else tuple(int(x) for x in a.part.split("/"))
        zetas = None if a.zetas is None else [float(z) for z in a.zetas.split(",")]
        ratios = None if a.ratios is None else [float(t) for t in a.ratios.split(",")]
        study(a.out, a.geometry, a.validation, only, zetas, ratios)
    if a.analyse:
        analyse(a.analyse, a.record)


if __name__ == "__main__":
    main()
