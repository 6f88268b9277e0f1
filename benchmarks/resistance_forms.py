"""Convergence of the two forms of R_r of the full models over the regime zeta = 1e-3..1e3, the
default grid's accuracy and its cost.

The full models report the dissipation form ``-int p du/dx`` as ``value`` (also
``solution.resistance_dissipation``) and keep the pressure-moment form ``(1/R) int p x dA`` as
``solution.resistance_moment``; in the continuum they are equal. Modes:

* ``--study [--out FILE]``: both forms at fixed cells per contact radius (sphere 12..64,
  cylinder 12..400), CSV lines ``geometry,material,zeta_or_-speed,speed,cells,M,D,result,
  contact_radius,seconds``. Materials: standard linear solids G0 = 3 MPa, tau = 0.25 s, f = 1
  (``s1``) and 3 (``s3``) at zeta = V tau/a0, and a 21-term Prony series (``pr``, G_inf = 3 MPa,
  G_i = 1.5 MPa 10^(-k/10), tau_i = 10^k s, k = -10..10: 20 decades) at 1e-6..1e3 m/s;
  and f = 0.1 and 0.3 (``s01``, ``s03``) at zeta = 0.05..1. The
  tables of :mod:`jaxroll.grids` (``SPHERE_ERROR``, ``LINE_ERROR``) are this study's envelope.
* ``--analyse FILE [FILE...] [--record]``: the study's errors [%] M / D, against the exact solution (cylinder, SLS)
  or against the dissipation form extrapolated to zero cell size from >= 20 cells (a fit
  ``D + C c^-p``; sphere, and the cylinder's Prony series against its finest grid).
* ``--defaults``: the default grid (``jr.Full()``) at each regime: cells per radius, value error
  and ``truncation`` (cylinder against the exact solution; sphere against the dissipation form
  at 64 cells, zeta <= 0.01, or 48 cells).
* ``--timing``: seconds per default sphere point (after warm-up, ``block_until_ready``), the
  default grid against 12 cells per radius (the earlier default).

Sphere R = 2 cm, P = 100 N; cylinder R = 2 cm, P = 10 kN/m; half-spaces (infinite layer).
"""

import argparse
import csv
import os
import sys
import time
import warnings

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr

import _numbers

HALF = jr.Layer(H=jnp.inf)
S1 = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=1.0)
S3 = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=3.0)
_K = np.arange(-10, 11.0)
PRONY = jr.GeneralizedMaxwell(G_inf=3e6, G=1.5e6 * 10 ** (-0.1 * _K), tau=10.0 ** _K)
_K2 = np.arange(-8, 5.0)
#: off the calibration (the validation set): f = 0.5 and 2, a 12-decade Prony series
STEEP = jr.GeneralizedMaxwell(G_inf=2e6, G=4e6 * 10 ** (-0.15 * (_K2 + 8)), tau=10.0 ** _K2)
MATERIALS = {"s1": S1, "s3": S3, "pr": PRONY, "s05": jr.StandardLinearSolid(G0=3e6, tau=0.25, f=0.5),
             "s2": jr.StandardLinearSolid(G0=3e6, tau=0.25, f=2.0), "st": STEEP,
             "s01": jr.StandardLinearSolid(G0=3e6, tau=0.25, f=0.1), "s03": jr.StandardLinearSolid(G0=3e6, tau=0.25, f=0.3),
             "s10": jr.StandardLinearSolid(G0=3e6, tau=0.25, f=10.0)}
#: a strongly dispersive solid (f = 10, cylinder only): it errs most at zeta = 0.3-0.5 on coarse grids
#: (-0.84 / -0.69 % at 12 cells against -0.3 % for f = 1)
HIGH_F_ZETAS = [1e-3, 1e-2, 0.1, 0.3, 0.5, 1.0, 10.0, 100.0]
#: weakly dispersive solids (f = 0.1, 0.3) err most just below the loss peak
LOW_F_ZETAS = [0.05, 0.1, 0.17, 0.3, 0.5, 1.0]
LOAD = {"sphere": 100.0, "cylinder": 1e4}
ZETAS = [1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0, 10.0, 100.0, 1000.0]
PRONY_SPEEDS = [1e-6, 1e-3, 1.0, 1e3]


def relaxed_size(geometry, P=None):
    """Relaxed Hertz contact radius / half-width [m] of the benchmark's roller (G0 = 3 MPa)."""
    P = LOAD[geometry] if P is None else P
    if geometry == "sphere":
        return float(jr.reference.hertz_sphere(P, 0.02, 3e6).contact_radius)
    return float(jr.reference.hertz_cylinder(P, 0.02, 3e6))


def speed_of(geometry, zeta, P=None):
    """``zeta > 0``: V tau/a0 of the SLS (tau = 0.25 s); ``zeta < 0``: the speed -zeta [m/s]."""
    return -zeta if zeta < 0 else zeta * relaxed_size(geometry, P) / 0.25


def evaluate(geometry, tag, zeta, method, P=None):
    P = LOAD[geometry] if P is None else P
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # coarse grids are flagged by their own estimate
        return jr.rolling_resistance(MATERIALS[tag], HALF, radius=0.02, load=P, speed=speed_of(geometry, zeta, P),
                                     geometry=geometry, method=method, throw=False)


def study_rows(validation=False):
    """(geometry, material tag, zeta or -speed, cells, load) of the study (calibration of the
    error tables) or of its validation set (other f, regimes between the tables' rows, another
    load and another Prony spectrum)."""
    out = []
    for geometry, cells in [("sphere", [12, 16, 20, 24, 32, 48]), ("cylinder", [12, 25, 50, 100, 200, 400])]:
        if validation:
            cases = [("s05", z) for z in [5e-3, 0.05, 0.5, 3.0, 30.0]] + [("s2", z) for z in [2e-3, 0.02, 0.2, 2.0, 300.0]]
            cases += [("st", -v) for v in [1e-4, 1e-2, 1.0, 100.0]]
            cells = [12, 16, 20, 24, 32, 48] if geometry == "sphere" else [12, 25, 50, 100, 400, 800]
        else:
            cases = [("s1", z) for z in ZETAS] + [("s3", z) for z in [1e-3, 1e-2, 0.1, 1.0, 100.0]]
            cases += [("pr", -v) for v in PRONY_SPEEDS]
            cases += [(tag, z) for tag in ("s01", "s03") for z in LOW_F_ZETAS]
            if geometry == "cylinder":
                cases += [("s10", z) for z in HIGH_F_ZETAS]
        for tag, z in cases:
            extra = [64] if geometry == "sphere" and 0 < z <= 2e-2 else []
            out += [(geometry, tag, z, c, LOAD[geometry]) for c in cells + extra]
    if validation:
        out += [("sphere", "s1", z, c, 30.0) for z in [0.15, 5.0] for c in [12, 16, 20, 24, 32, 48]]
    return out


def study(out, only=None, validation=False):
    rows = study_rows(validation)
    with open(out, "a") as fh:
        for i, (geometry, tag, z, c, P) in enumerate(rows):
            if only is not None and i not in only:
                continue
            t = time.perf_counter()
            r = evaluate(geometry, tag, z, jr.Full(grid=jr.AutoGrid(cells_per_radius=c)), P)
            fh.write(f"{geometry},{tag},{z!r},{speed_of(geometry, z, P)!r},{c},{float(r.solution.resistance_moment)!r},"
                     f"{float(r.value)!r},{int(r.result)},{float(r.contact_radius)!r},{time.perf_counter() - t:.1f},{P}\n")
            fh.flush()


def exact(tag, zeta):
    V = speed_of("cylinder", zeta)
    return float(jr.reference.exact_cylinder_halfspace(MATERIALS[tag], radius=0.02, load=LOAD["cylinder"],
                                                       speed=V).rolling_resistance)


def extrapolated(cells, D):
    """``D_inf`` of the fit ``D(c) = D_inf + C c^-p`` (0.5 <= p <= 4) over the grids >= 20 cells."""
    from scipy.optimize import least_squares

    cells, D = np.asarray(cells, float), np.asarray(D, float)
    sel = cells >= 20
    fit = least_squares(lambda q: (q[0] + q[1] * cells[sel] ** -q[2] - D[sel]) / D[-1], [D[-1], 0.0, 1.5],
                        bounds=([0, -np.inf, 0.5], [np.inf, np.inf, 4.0]))
    return fit.x[0]


def _default_point(g, tag, z, P, d):
    """The default grid at this point: its counting size ``r`` [m] (:func:`jaxroll.grids.counting_size`
    as the rules round it), regime, cells per ``r``, and the study's run to compare with: the
    finest of the study's grids (cells per relaxed radius ``a_rel``) that is not finer than the
    default's (``cells a_rel / r`` per relaxed radius; the default is at most 9 % finer where
    ``r`` is ``a_rel`` rounded down onto the rules' ladder), as ``(cells, (M, D, code, contact))``
    or ``None``."""
    from jaxroll import grids

    m, V = MATERIALS[tag], speed_of(g, z, P)
    a_rel = float(jr.engines.contact_size.estimate_contact_size(m, HALF, 0.02, P, g))
    cells, r, _ = jr.AutoGrid().point_cells(m, HALF, 0.02, [P], [V], g)
    c, r = int(cells[0]), float(r[0])
    zeta, breadth = (float(x) for x in grids.regime(m, V, r))
    coarser = [k for k in d if k <= c * a_rel / r * (1 + 1e-9)]
    run = (max(coarser), d[max(coarser)]) if coarser else None
    return r, zeta, breadth, c, run


def analyse_rows(path, validation=False):
    """The rows of a study file: for every point (geometry, material, zeta or -speed, load) its
    reference, the errors [%] of M and D at every grid of the study (and whether the method
    flagged them), and at the default grid (the rule's cells) the error [%] of the reported value
    (D, blended toward (M + D)/2 below zeta = 5e-3) with its ``truncation`` [%]."""
    from jaxroll import grids

    table = {}
    for row in csv.reader(open(path)):
        g, tag, z, _, c, M, D, res, a = row[:9]
        P = float(row[10]) if len(row) > 10 else LOAD[g]
        table.setdefault((g, tag, float(z), P), {})[int(c)] = (float(M), float(D), int(res), float(a))
    out = []
    for (g, tag, z, P), d in sorted(table.items(), key=lambda kv: (kv[0][0], kv[0][1], kv[0][3], abs(kv[0][2]))):
        cs = sorted(d)
        if g == "cylinder" and tag not in ("pr", "st"):
            ref = float(jr.reference.exact_cylinder_halfspace(MATERIALS[tag], radius=0.02, load=P,
                                                              speed=speed_of(g, z, P)).rolling_resistance)
            src = "exact"
        elif g == "cylinder":
            ref, src = d[cs[-1]][1], f"D{cs[-1]}"
        else:
            ref, src = extrapolated(cs, [d[c][1] for c in cs]), "D extrapolated"
        r, zeta, breadth, c, run = _default_point(g, tag, z, P, d)
        default = None
        if run is not None:
            study_cells, (M, D, _, solved) = run
            ratio = solved / r if np.isfinite(solved) else 1.0  # the validation file has no contact radius
            default = {"cells": c, "study_cells": study_cells,
                       "counting_ratio": r / float(jr.engines.contact_size.estimate_contact_size(
                           MATERIALS[tag], HALF, 0.02, P, g)),
                       "error": 100 * (float(grids.full_model_value(M, D, zeta)) / ref - 1),
                       "truncation": 100 * float(grids.full_model_error(M, D, zeta, c, g, ratio, breadth))}
        out.append({"geometry": g, "material": tag, "zeta": z, "load": P, "zeta_regime": zeta, "reference": src,
                    "validation": validation, "default": default,
                    "grids": {str(k): [100 * (d[k][0] / ref - 1), 100 * (d[k][1] / ref - 1), bool(d[k][2])]
                              for k in cs}})
    return out


def analyse(paths, record=False):
    """Print :func:`analyse_rows` of the study files ``paths`` (a file whose name contains
    "validation" is the validation set); ``record``: store them in benchmarks/numbers.json
    (section ``resistance_forms``), from which ``render_docs.py`` writes the tables of
    docs/validation.md."""
    print("error [%] of the moment / dissipation form; * = flagged by the method's own estimate;")
    print("default: the rule's cells per estimated radius, the error of D [%] and its truncation [%]")
    rows = []
    for path in paths:
        rows += analyse_rows(path, validation="validation" in path)
    for r in rows:
        z = r["zeta"]
        label = f"{z:g}" if z > 0 else f"V={-z:g} m/s"
        cols = "  ".join(f"{c}: {m:+.2f}/{d:+.2f}{'*' if flagged else ''}" for c, (m, d, flagged) in r["grids"].items())
        dflt = r["default"]
        dflt = ("not in the study" if dflt is None else
                f"{dflt['cells']} cells (study run: {dflt['study_cells']}): {dflt['error']:+.2f} "
                f"(truncation {dflt['truncation']:.2f})")
        print(f"{r['geometry']:8s} {r['material']:3s} P={r['load']:g} {label:12s} zeta_regime={r['zeta_regime']:.3g} "
              f"({r['reference']}) {cols}\n    default {dflt}")
    if record:
        _numbers.record("resistance_forms", {
            "command": "python benchmarks/resistance_forms.py --analyse " + " ".join(
                f"benchmarks/{os.path.basename(p)}" for p in paths) + " --record",
            "rows": rows})


def defaults():
    print("default grid: geometry material zeta | cells per radius | value error [%] | truncation [%] | valid")
    for geometry in ["cylinder", "sphere"]:
        for tag, z in [("s1", z) for z in ZETAS] + [("pr", -v) for v in PRONY_SPEEDS]:
            r = evaluate(geometry, tag, z, jr.Full())
            m = jr.Full().resolve(MATERIALS[tag], HALF, radius=0.02, loads=LOAD[geometry],
                                  speeds=speed_of(geometry, z), geometry=geometry)
            cells = float(jr.engines.contact_size.estimate_contact_size(
                MATERIALS[tag], HALF, 0.02, LOAD[geometry], geometry)) / float(m.grid.spacing)
            if geometry == "cylinder" and tag != "pr":
                ref = exact(tag, z)
            else:
                fine = 400 if geometry == "cylinder" else (64 if 0 < z <= 1e-2 else 48)
                ref = float(evaluate(geometry, tag, z, jr.Full(grid=jr.AutoGrid(cells_per_radius=fine))).value)
            print(f"{geometry:8s} {tag} {z:<8g} {cells:5.1f} {100 * (float(r.value) / ref - 1):+7.2f} "
                  f"{100 * float(r.truncation):6.2f} {bool(r.valid)}", flush=True)


def timing(zetas):
    print("sphere, seconds per point after warm-up (block_until_ready), min of 5: default grid / 12 cells")
    for z in zetas:
        V = speed_of("sphere", z)
        times = []
        for method in [jr.Full(), jr.Full(grid=jr.AutoGrid(cells_per_radius=12))]:
            m = method.resolve(S1, HALF, radius=0.02, loads=LOAD["sphere"], speeds=V, geometry="sphere")
            f = jax.jit(lambda V, m=m: jr.rolling_resistance(S1, HALF, radius=0.02, load=LOAD["sphere"], speed=V,
                                                             method=m, throw=False).value)
            jax.block_until_ready(f(V * 0.99))
            best = np.inf
            for k in range(5):
                t = time.perf_counter()
                jax.block_until_ready(f(V * (1 + 1e-3 * k)))
                best = min(best, time.perf_counter() - t)
            times.append((m.grid.window, best))
        (w, t), (w12, t12) = times
        print(f"zeta {z:<7g} window {w:3d}: {t:7.3f} s   12 cells, window {w12}: {t12:7.3f} s   ratio {t / t12:5.2f}",
              flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", action="store_true")
    ap.add_argument("--out", default="resistance_forms.csv")
    ap.add_argument("--rows", default=None, help="comma-separated indices of the study's rows (parallel runs)")
    ap.add_argument("--validation", action="store_true", help="--study: the validation set instead")
    ap.add_argument("--analyse", nargs="+", default=None, metavar="FILE", help="study files to analyse")
    ap.add_argument("--record", action="store_true", help="--analyse: store the rows in benchmarks/numbers.json")
    ap.add_argument("--defaults", action="store_true")
    ap.add_argument("--timing", action="store_true")
    ap.add_argument("--zetas", default=None, help="comma-separated regimes of --timing (default: all)")
    args = ap.parse_args()
    if args.study:
        study(args.out, None if args.rows is None else {int(i) for i in args.rows.split(",")}, args.validation)
    if args.analyse:
        analyse(args.analyse, args.record)
    if args.defaults:
        defaults()
    if args.timing:
        timing(ZETAS if args.zetas is None else [float(z) for z in args.zetas.split(",")])
    if not (args.study or args.analyse or args.defaults or args.timing):
        print(__doc__)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
