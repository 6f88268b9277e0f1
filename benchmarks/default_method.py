"""Every method against the full model (the default wherever no method is named): accuracy and
cost per point; the screening methods' measured errors quoted in the docs come from here.

For the paper's material (SLS G0 = 3 MPa, tau = 0.25 s, f = 1), R = 2 cm, P = 100 N, sphere on
H = 5 and 30 mm, and a cylinder (P = 5000 N/m) on the same layers, at speeds 1e-3..1 m/s, each
method is called as a user calls it: ``jr.rolling_resistance(...)`` with its default
(automatic) grid, one point at a time. Reported per point: the first call (grid sizing +
compilation + run) and the median of 3 further calls with the same point (run only), the value
and its deviation from the full model. A point whose grid does not fit in ``--max-gib`` of
memory is skipped (estimated before building it).

    python benchmarks/default_method.py [--quick] [--speeds 1e-3,1e-2,0.1,1] [--max-gib 4] [--record]

``--record`` stores the rows in benchmarks/numbers.json (section ``default_method``), from which
``benchmarks/render_docs.py`` writes the methods tables of README.md and benchmarks/README.md.

``--quick``: one speed (1e-2 m/s) and grids up to 1 GiB. On the shared 2-core machine the
timings are noisy (medians of 3).
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

import jaxroll as jr
from jaxroll import RESULTS
import _numbers
from _timing import summary, timed

MAT = jr.StandardLinearSolid(3e6, 0.25, 1.0)
R = 0.02


def grid_gib(method, layer, P, V, geometry):
    """Rough working memory of the method's resolved grid [GiB]: complex kernel of
    n_terms^2 (3D) or period cells (2D) plus ~10 work arrays of the period cell count."""
    m = method.resolve(MAT, layer, radius=R, loads=[P], speeds=[V], geometry=geometry)
    grid = getattr(m, "grid", None)
    if not isinstance(grid, jr.FixedGrid) or grid.period is None:
        return 0.0
    cells = int(np.prod(grid.n_cells)) if geometry == "sphere" and not isinstance(m, jr.Slices) else grid.n_cells[0]
    terms = grid.terms() ** 2 if geometry == "sphere" and isinstance(m, jr.Full) else cells
    return (16 * terms + 10 * 8 * cells) / 2**30


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--speeds", default="1e-3,1e-2,0.1,1")
    ap.add_argument("--max-gib", type=float, default=4.0)
    ap.add_argument("--quick", action="store_true", help="one speed (1e-2 m/s), grids up to 1 GiB")
    ap.add_argument("--record", action="store_true", help="store the rows in benchmarks/numbers.json")
    args = ap.parse_args()
    if args.quick:
        args.speeds, args.max_gib = "1e-2", min(args.max_gib, 1.0)
    speeds = [float(v) for v in args.speeds.split(",")]
    cases = [("sphere", 100.0, ["full", "SP", "PP", "PD", "direct"]), ("cylinder", 5000.0, ["full", "direct"])]
    print("geometry | H [mm] | V [m/s] | method | first call [s] | run [s] | R_r | vs full")
    rows = []
    for geometry, P, names in cases:
        for H in (0.005, 0.03):
            layer = jr.Layer(H)
            for V in speeds:
                ref = ref_run = None
                for name in names:
                    method = jr.methods.as_method(name)
                    gib = grid_gib(method, layer, P, V, geometry)
                    if gib > args.max_gib:
                        print(f"{geometry} | {H * 1e3:g} | {V:g} | {name} | skipped: grid ~{gib:.1f} GiB | | |")
                        continue
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", jr.ValidityWarning)
                        fn = lambda: jr.rolling_resistance(MAT, layer, radius=R, load=P, speed=V,  # noqa: E731
                                                           geometry=geometry, method=method, throw=False)
                        first, run, out = timed(fn, repeat=3)
                    value = float(out.value)
                    if name == "full":
                        ref, ref_run = value, run
                    dev = f"{value / ref - 1:+.1%}" if ref else ""
                    flag = "" if bool(out.valid) else f" (not valid: {out.reasons()})"
                    print(f"{geometry} | {H * 1e3:g} | {V:g} | {name} | {first:.2f} | {run:.4f} | "
                          f"{value:.4g}{flag} | {dev}", flush=True)
                    rows.append(dict(geometry=geometry, H=H, V=V, method=name, first_s=first, run_s=run, value=value,
                                     valid=bool(out.valid), reasons="" if bool(out.valid) else RESULTS.names[int(out.result)],
                                     deviation=value / ref - 1 if ref else None))
                    if name != "full" and ref_run:
                        summary(f"default_method.py{' --quick' if args.quick else ''} ({geometry}, H = {H * 1e3:g} mm, "
                                f"V = {V:g}, {name})", run, max(first - run, 0.0), f"full {ref_run:.4f} s per point",
                                f"{ref_run / run:.0f}x", f"one point, automatic grid; deviation from full {dev}")
    if args.record:
        _numbers.record("default_method", {"command": "python benchmarks/default_method.py"
                                           + (" --quick" if args.quick else ""), "rows": rows})


if __name__ == "__main__":
    main()
