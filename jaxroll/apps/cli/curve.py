"""``jaxroll curve``: R_r against speed for one or more loads (CSV and PNG)."""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

from ...geometry import Geometry
from ...io import write_table
from .options import count, floats, method_from_args, method_name, model_args, positive, progress_args, thickness, warn_invalid


def run(args) -> int:
    import jaxroll as jr
    from jaxroll.apps import plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    mat = jr.StandardLinearSolid(args.G0, args.tau, args.f)
    layer = jr.Layer(H=thickness(args.H), rho=args.rho)
    speeds = np.logspace(np.log10(args.vmin), np.log10(args.vmax), args.n)
    loads = np.sort(np.asarray(args.loads))
    method = method_from_args(args)
    # a full model's table reports per block of speeds (a loss-dominated material on its grid takes
    # minutes); the approximations take about a second and run in one piece
    blocks = args.progress and isinstance(method, jr.Full)
    if args.progress:
        print(f"curve: {len(speeds)} speeds x {len(loads)} loads, method {method_name(args)} (one compiled "
              f"program: grid sizing, compilation, then every point{', per block of speeds' if blocks else ''})",
              file=sys.stderr, flush=True)
    with warnings.catch_warnings():  # reported below, per reason, in CLI terms
        warnings.simplefilter("ignore", jr.ValidityWarning)
        res = jr.rolling_resistance_grid(mat, layer, radius=args.radius, loads=loads, speeds=speeds,
                                         geometry=args.geometry, method=method, throw=False, progress=blocks)
    values, codes = np.asarray(res.value).T, np.asarray(res.result).T  # (loads, speeds)
    unit = Geometry(args.geometry).load_unit
    P_, V_ = (a.ravel() for a in np.meshgrid(loads, speeds, indexing="ij"))
    write_table(out / "curve.csv", {"speed": V_, "load": P_, "rolling_resistance": values.ravel(),
                                    "valid": (codes.ravel() == 0).astype(int),
                                    "result": [jr.RESULTS.names[int(c)] for c in codes.ravel()]},
                ["m/s", unit, unit, "-", "-"], formats=".8g")
    warn_invalid(codes, "curve")
    plot.plot_rolling_curves(speeds, loads, values, unit=unit, valid=codes == 0,
                             title=f"{args.geometry}, method {method_name(args)}, H = {args.H} m", path=out / "curve.png")
    print(f"wrote {out / 'curve.csv'}, {out / 'curve.png'}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub) -> None:
    """The ``curve`` subcommand on ``sub`` (argparse subparsers)."""
    c = sub.add_parser("curve", help="R_r against speed for one or more loads (CSV and PNG)")
    model_args(c)
    c.add_argument("--loads", type=floats("--loads"), default=[50.0, 100.0, 150.0],
                   help="loads, comma separated [N, or N/m for cylinders] (50,100,150)")
    c.add_argument("--vmin", type=positive("--vmin [m/s]"), default=1e-4, help="lowest speed [m/s] (1e-4)")
    c.add_argument("--vmax", type=positive("--vmax [m/s]"), default=1.0, help="highest speed [m/s] (1)")
    c.add_argument("--n", type=count("--n"), default=23, help="number of log-spaced speeds (23)")
    progress_args(c)
    c.add_argument("--out", default="jaxroll-curve", help="output folder (jaxroll-curve)")
    c.set_defaults(func=run)
