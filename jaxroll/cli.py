"""``jaxroll`` command line. Units are SI throughout (m, N, Pa, s, kg/m^3)."""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

__all__ = ["main"]


def _positive(kind):
    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{kind}: expected a number, got {text!r}")
        if not v > 0:
            raise argparse.ArgumentTypeError(f"{kind}: must be positive, got {v}")
        return v

    return parse


def _demo(args) -> int:
    import jaxroll as jr
    from jaxroll import plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    mat = jr.StandardLinearSolid(G0=args.G0, tau=args.tau, f=args.f)
    layers = {f"H = {h * 1e3:g} mm": jr.Layer(H=h, rho=args.rho) for h in (0.002, 0.005, 0.03)}
    layers["half-space"] = jr.Layer(H=np.inf, rho=args.rho)
    plot.plot_master_curves({"[ZG] example": mat}, path=out / "master_curves.png")
    plot.plot_compliance(mat, layers, args.speed, path=out / "compliance.png")
    q = np.logspace(0, 5, 101)
    with open(out / "compliance.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["q", *[f"{p} {name}" for name in layers for p in ("ReT", "ImT")]])
        w.writerow(["rad/m", *["m/Pa"] * (2 * len(layers))])
        cols = [np.asarray(jr.surface_compliance(lay, mat, q, 0.0, args.speed)) for lay in layers.values()]
        for i, qi in enumerate(q):
            w.writerow([f"{qi:.6e}", *[f"{v:.6e}" for c in cols for v in (c[i].real, c[i].imag)]])
    print(f"material: G0 = {args.G0:g} Pa, tau = {args.tau:g} s, f = {args.f:g};"
          f" layers H = 2, 5, 30 mm and half-space, rho = {args.rho:g} kg/m^3, V = {args.speed:g} m/s")
    print(f"wrote {out / 'master_curves.png'}, {out / 'compliance.png'}, {out / 'compliance.csv'}"
          f"  ({time.perf_counter() - t0:.1f} s)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="jaxroll",
        description="Viscoelastic rolling resistance of rigid spheres and cylinders on layers. "
        "All quantities in SI units: lengths m, loads N (sphere) or N/m (cylinder), moduli Pa, "
        "times s, speeds m/s, densities kg/m^3.",
    )
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="evaluate the paper's example material and layers, write plots")
    d.add_argument("--out", default="jaxroll-out", help="output folder (default: jaxroll-out)")
    d.add_argument("--G0", type=_positive("G0 [Pa]"), default=3e6, help="relaxed shear modulus [Pa] (3e6)")
    d.add_argument("--tau", type=_positive("tau [s]"), default=0.25, help="retardation time [s] (0.25)")
    d.add_argument("--f", type=float, default=1.0, help="relaxation strength G'(inf)/G'(0) - 1 [-] (1)")
    d.add_argument("--rho", type=float, default=1000.0, help="layer density [kg/m^3] (1000)")
    d.add_argument("--speed", type=_positive("speed [m/s]"), default=0.1, help="rolling speed [m/s] (0.1)")
    d.set_defaults(func=_demo)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ValueError as err:  # bad physical input: one clear line, no traceback
        print(f"jaxroll {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
