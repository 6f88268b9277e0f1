"""``jaxroll sweep``: R_r over a grid of any parameters."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ...geometry import Geometry
from ...io import write_table
from .options import method_from_args, model_args, progress_args, thickness, warn_invalid


def _axis(text):
    """NAME=lo:hi:n[:log] or NAME=v1,v2,... -> (name, values)."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected NAME=lo:hi:n[:log] or NAME=v1,v2,..., got {text!r}")
    name, spec = text.split("=", 1)
    name = name.strip()
    if name not in _SWEEP_NAMES:
        raise argparse.ArgumentTypeError(f"unknown parameter {name!r}; choose from {sorted(_SWEEP_NAMES)}")
    try:
        if ":" in spec:
            parts = spec.split(":")
            if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] != "log"):
                raise ValueError
            lo, hi, n = float(parts[0]), float(parts[1]), int(parts[2])
            log = len(parts) == 4
        else:
            vals = np.array([float(x) for x in spec.split(",")])
    except (ValueError, IndexError):
        raise argparse.ArgumentTypeError(f"cannot parse {text!r}; use NAME=lo:hi:n[:log] or NAME=v1,v2")
    if ":" in spec:
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi and n >= 2):
            raise argparse.ArgumentTypeError(f"{name}: a range lo:hi:n needs finite lo < hi and n >= 2; "
                                             f"got {spec!r}")
        if log and lo <= 0:
            raise argparse.ArgumentTypeError(f"{name}: a log range needs lo > 0; got {spec!r}")
        vals = np.logspace(np.log10(lo), np.log10(hi), n) if log else np.linspace(lo, hi, n)
    low, rule = _SWEEP_RULES.get(name, (0.0, "positive"))
    if not np.all(np.isfinite(vals)) or np.any(vals < low) or (rule == "positive" and np.any(vals <= 0)):
        raise argparse.ArgumentTypeError(f"{name} ({_SWEEP_NAMES[name]}): values must be finite and {rule}; "
                                         f"got {spec!r}")
    return name, vals


#: Parameters that may be zero (lower bound, rule); the others must be positive.
_SWEEP_RULES = {"V": (0.0, ">= 0"), "f": (0.0, ">= 0")}


_SWEEP_NAMES = {"V": "speed [m/s]", "P": "load [N or N/m]", "H": "thickness [m]", "G0": "shear modulus [Pa]",
                "tau": "retardation time [s]", "f": "relaxation strength [-]", "R": "radius [m]"}


def run(args) -> int:
    import itertools

    import jaxroll as jr
    from jaxroll.grids import union

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    axes = dict(args.vary)
    base = {"V": 0.01, "P": 100.0, "H": thickness(args.H), "G0": args.G0, "tau": args.tau, "f": args.f, "R": args.radius}

    def models(v):
        return jr.StandardLinearSolid(v["G0"], v["tau"], v["f"]), jr.Layer(H=v["H"], rho=args.rho)

    method = method_from_args(args)
    if method.needs_resolution(args.geometry):
        # one grid for the whole sweep: the union of the grids of the corners of the other axes
        corners = [axes.get(k, [base[k]]) for k in ("H", "G0", "tau", "f", "R")]
        loads, speeds = axes.get("P", [base["P"]]), axes.get("V", [base["V"]])
        resolved = []
        for H, G0, tau, f, R in itertools.product(*[(min(c), max(c)) for c in corners]):
            mat, lay = models({"H": H, "G0": G0, "tau": tau, "f": f})
            resolved.append(method.resolve(mat, lay, radius=R, loads=loads, speeds=speeds, geometry=args.geometry))
        method = method.on_grid(union([r.grid for r in resolved]), resolved)

    def one(p):
        v = {k: getattr(p, k) if k in axes else base[k] for k in base}
        mat, lay = models(v)
        r = jr.rolling_resistance(mat, lay, radius=v["R"], load=v["P"], speed=v["V"], geometry=args.geometry,
                                  method=method, throw=False)
        return r.value, r.result

    # the full models' points one after the other (jax.vmap of Full now warm-starts its lanes in
    # one scan, docs/design.md sec. 4, but that path was not timed against this one on an idle
    # machine: benchmarks/LOG.md, "Batched full models")
    values, codes = (np.asarray(a) for a in jr.sweep(one, jr.Grid(**axes), progress=args.progress,
                                                     vectorize=not isinstance(method, jr.Full)))
    names = list(axes)
    mesh = np.meshgrid(*[np.asarray(axes[n]) for n in names], indexing="ij")
    cols = {n: m.ravel() for n, m in zip(names, mesh)}
    cols.update(rolling_resistance=values.ravel(), valid=(codes.ravel() == 0).astype(int),
                result=[jr.RESULTS.names[int(c)] for c in codes.ravel()])
    write_table(out / "sweep.csv", cols, [_SWEEP_NAMES[n].split("[")[1].rstrip("]") for n in names]
                + [Geometry(args.geometry).load_unit, "-", "-"], formats=".8g")
    warn_invalid(codes, "sweep")
    print(f"{values.size} points; wrote {out / 'sweep.csv'}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub) -> None:
    """The ``sweep`` subcommand on ``sub`` (argparse subparsers)."""
    s_ = sub.add_parser("sweep", help="R_r over a grid of any parameters (V, P, H, G0, tau, f, R), CSV out",
                        description="Each --vary NAME=lo:hi:n[:log] or NAME=v1,v2,... adds a grid axis; the other "
                        "parameters keep their values (V = 0.01 m/s, P = 100 N unless varied).")
    model_args(s_)
    s_.add_argument("--vary", type=_axis, action="append", required=True, help="grid axis, e.g. V=1e-4:1:23:log")
    progress_args(s_)
    s_.add_argument("--out", default="jaxroll-sweep", help="output folder (jaxroll-sweep)")
    s_.set_defaults(func=run)
