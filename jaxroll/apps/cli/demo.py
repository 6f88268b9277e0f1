"""``jaxroll demo``: the paper's example material and layers: master curves, compliance plots and CSV."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ...io import write_table
from .options import nonnegative, positive


def run(args) -> int:
    import jaxroll as jr
    from jaxroll.apps import plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    mat = jr.StandardLinearSolid(G0=args.G0, tau=args.tau, f=args.f)
    layers = {f"H = {h * 1e3:g} mm": jr.Layer(H=h, rho=args.rho) for h in (0.002, 0.005, 0.03)}
    layers["half-space"] = jr.Layer(H=np.inf, rho=args.rho)
    plot.plot_master_curves({"[ZG] example": mat}, path=out / "master_curves.png")
    plot.plot_compliance(mat, layers, args.speed, path=out / "compliance.png")
    q = np.logspace(0, 5, 101)
    cols = {"q": q}
    for name, lay in layers.items():
        c = np.asarray(jr.engines.layer.surface_compliance(lay, mat, q, 0.0, args.speed))
        cols.update({f"ReT {name}": c.real, f"ImT {name}": c.imag})
    write_table(out / "compliance.csv", cols, ["rad/m", *["m/Pa"] * (2 * len(layers))], formats=".6e")
    print(f"material: G0 = {args.G0:g} Pa, tau = {args.tau:g} s, f = {args.f:g};"
          f" layers H = 2, 5, 30 mm and half-space, rho = {args.rho:g} kg/m^3, V = {args.speed:g} m/s")
    print(f"wrote {out / 'master_curves.png'}, {out / 'compliance.png'}, {out / 'compliance.csv'}"
          f"  ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub) -> None:
    """The ``demo`` subcommand on ``sub`` (argparse subparsers)."""
    d = sub.add_parser("demo", help="evaluate the paper's example material and layers, write plots")
    d.add_argument("--out", default="jaxroll-out", help="output folder (default: jaxroll-out)")
    d.add_argument("--G0", type=positive("G0 [Pa]"), default=3e6, help="relaxed shear modulus [Pa] (3e6)")
    d.add_argument("--tau", type=positive("tau [s]"), default=0.25, help="retardation time [s] (0.25)")
    d.add_argument("--f", type=nonnegative("f [-]"), default=1.0, help="relaxation strength G'(inf)/G'(0) - 1 [-] (1)")
    d.add_argument("--rho", type=nonnegative("rho [kg/m^3]"), default=1000.0, help="layer density [kg/m^3] (1000)")
    d.add_argument("--speed", type=positive("speed [m/s]"), default=0.1, help="rolling speed [m/s] (0.1)")
    d.set_defaults(func=run)
