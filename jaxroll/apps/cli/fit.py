"""``jaxroll fit``: identify G0, tau, f (and optionally H) from rolling-resistance and/or DMA data."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ...geometry import Geometry
from ...io import write_table
from .options import count, geometry_arg, method_args, method_from_args, nonnegative, positive, progress_args


def _parse_initial(text):
    out = {}
    for item in text.split(","):
        if "=" not in item:
            raise argparse.ArgumentTypeError(f"--initial: expected NAME=VALUE pairs (G0=1e6,tau=0.1,f=0.5), got {item!r}")
        k, v = item.split("=", 1)
        try:
            out[k.strip()] = float(v)
        except ValueError:
            raise argparse.ArgumentTypeError(f"--initial: {k.strip()} = {v!r} is not a number")
    unknown = set(out) - {"G0", "tau", "f"}
    if unknown:
        raise argparse.ArgumentTypeError(f"--initial: unknown parameter(s) {sorted(unknown)}; use G0, tau, f")
    return out


def run(args) -> int:
    import json

    import jax.numpy as jnp

    import jaxroll as jr
    from jaxroll.identify import fit as jfit
    from jaxroll.apps import plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    data = jfit.read_rolling_csv(args.data) if args.data else None
    dma = jfit.read_dma_csv(args.dma) if args.dma else None
    init = {"G0": 1e6, "tau": 0.1, "f": 0.5}
    init.update(args.initial or {})
    layer = jr.Layer(H=jnp.inf if args.H == "inf" else float(args.H), rho=args.rho, nu=args.nu)
    free = tuple(x.strip() for x in args.free.split(",") if x.strip())
    shift = None
    if args.wlf:
        try:
            c1, c2, tref = (float(x) for x in args.wlf.split(","))
        except ValueError:
            raise ValueError(f"--wlf: expected three numbers C1,C2,T_ref, got {args.wlf!r}") from None
        shift = jr.WLF(C1=c1, C2=c2, T_ref=tref)
    method = method_from_args(args, fit=True)
    # the options name the default fitting model: leave the choice to fit_material, which pairs
    # its default model with the default's tolerance and contact solver (as the API's default)
    default = method == jr.methods.default_method(args.geometry, fit=True)
    fit = jfit.fit_material(data, dma, initial=jr.StandardLinearSolid(**init), layer=layer, radius=args.radius,
                            geometry=args.geometry, method=None if default else method, free=free, shift=shift,
                            n_starts=args.starts, seed=args.seed, solver=args.solver,
                            progress=args.progress)
    report = fit.report()
    (out / "fit_report.txt").write_text(report + "\n")
    params = {
        n: {"value": np.ravel(fit.params[n]).tolist(), "stderr": np.ravel(fit.stderr[n]).tolist(),
            "ci95": [np.ravel(fit.ci95[n][0]).tolist(), np.ravel(fit.ci95[n][1]).tolist()]}
        for n in fit.params
    }
    payload = {"parameters": params, "names": fit.names, "correlation": np.asarray(fit.correlation).tolist(),
               "intervals": fit.interval_method, "converged": fit.converged, "cost": fit.cost, "reduced_chi2": fit.reduced_chi2,
               "warnings": fit.warnings, "method": repr(method),
               "units": {n: jfit.PARAMETER_UNITS.get(n, "") for n in fit.params}}
    (out / "fit_params.json").write_text(json.dumps(payload, indent=2) + "\n")
    written = ["fit_report.txt", "fit_params.json"]
    if data is not None:
        unit = Geometry(args.geometry).load_unit
        n_rr = len(data.value)
        sig = data.value if data.sigma is None else data.sigma
        fitted = np.asarray(data.value) - np.asarray(fit.residuals[:n_rr]) * np.asarray(sig)
        plot.plot_fit(data.speed, data.load, data.value, fitted, unit=unit, path=out / "fit.png")
        write_table(out / "fitted.csv", {"speed": data.speed, "load": data.load, "measured": data.value, "fitted": fitted},
                    ["m/s", unit, unit, unit], formats=".8g")
        written += ["fit.png", "fitted.csv"]
    print(report)
    print(f"wrote {', '.join(str(out / w) for w in written)}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub) -> None:
    """The ``fit`` subcommand on ``sub`` (argparse subparsers)."""
    f = sub.add_parser("fit", help="identify G0, tau, f (and optionally H) from rolling-resistance and/or DMA data",
                       description="Fit a standard linear solid to rolling-resistance data (CSV: columns speed, load, "
                       "rolling_resistance[, sigma]; second row units, e.g. m/s,N,N) and/or DMA data (CSV: frequency, "
                       "storage_modulus, loss_modulus[, temperature]; units Hz|rad/s, Pa|kPa|MPa|GPa, K|degC).")
    f.add_argument("data", nargs="?", help="rolling-resistance CSV")
    f.add_argument("--dma", help="DMA CSV (fitted jointly)")
    f.add_argument("--radius", type=positive("radius [m]"), help="roller radius [m]")
    f.add_argument("--H", default="inf", help="layer thickness [m] or 'inf' (default inf)")
    f.add_argument("--rho", type=nonnegative("rho [kg/m^3]"), default=0.0, help="layer density [kg/m^3] (default 0: no inertia)")
    f.add_argument("--nu", type=nonnegative("nu [-]"), default=0.5, help="Poisson's ratio (default 0.5)")
    geometry_arg(f)
    method_args(f, fit=True)
    f.add_argument("--free", default="G0,tau,f", help="free parameters, comma separated (G0,tau,f[,H])")
    f.add_argument("--initial", type=_parse_initial, help="initial values, e.g. G0=1e6,tau=0.1,f=0.5 (SI)")
    f.add_argument("--wlf", help="WLF shift C1,C2[K],T_ref[K] for DMA at several temperatures, e.g. 8.86,101.6,293.15 "
                   "(add C1,C2 to --free to fit them)")
    f.add_argument("--starts", type=count("--starts"), default=5, help="number of starts spread over two decades (5)")
    f.add_argument("--seed", type=int, default=0, help="random seed of the spread starting points (0)")
    f.add_argument("--solver", choices=["trf", "lm"], default="trf",
                   help="scipy least_squares method: trust-region reflective (default) or MINPACK Levenberg-Marquardt")
    progress_args(f)
    f.add_argument("--out", default="jaxroll-fit", help="output folder (default jaxroll-fit)")
    f.set_defaults(func=run)
