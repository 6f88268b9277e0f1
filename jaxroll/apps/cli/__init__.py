"""``jaxroll`` command line: one module per command (``demo``, ``curve``, ``sweep``, ``fit``,
``material``, ``map``, ``conveyor``, ``reproduce``, ``datasets``), each with ``add_parser(sub)`` and ``run(args)``; shared option
types in :mod:`~jaxroll.apps.cli.options`. Units are SI throughout (m, N, Pa, s, kg/m^3)."""

from __future__ import annotations

import argparse
import sys
import warnings

import equinox as eqx

from . import conveyor, curve, datasets, demo, fit, map, material, reproduce, sweep
from .options import Parser, runtime_message

__all__ = ["build_parser", "main"]

COMMANDS = (demo, curve, sweep, fit, material, map, conveyor, reproduce, datasets)


def build_parser() -> argparse.ArgumentParser:
    from ... import __version__

    p = Parser(
        prog="jaxroll",
        description="Viscoelastic rolling resistance of rigid spheres and cylinders on layers. "
        "All quantities in SI units: lengths m, loads N (sphere) or N/m (cylinder), moduli Pa, "
        "times s, speeds m/s, densities kg/m^3.",
    )
    p.add_argument("--version", action="version", version=f"jaxroll {__version__}")
    p.add_argument("--debug", action="store_true", help="show the Python traceback of an error")
    sub = p.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.add_parser(sub)
    return p


def _print_warnings_once(command, categories) -> None:
    """Within the caller's ``warnings.catch_warnings()``: every warning prints as one stderr line
    ``jaxroll COMMAND: warning: MESSAGE`` (no file name, no source line), each text once; the
    library's own ``categories`` always reach that printer (the others follow the filters)."""
    seen = set()

    def show(message, category, filename, lineno, file=None, line=None):
        text = f"jaxroll {command}: warning: {' '.join(str(message).split())}"
        if text not in seen:
            seen.add(text)
            print(text, file=sys.stderr, flush=True)

    for category in categories:
        warnings.simplefilter("always", category)
    warnings.showwarning = show


def main(argv=None) -> int:
    import matplotlib

    matplotlib.use("Agg")  # the command line writes figures to files only
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "fit":
        if not args.data and not args.dma:
            parser.error("fit: give a rolling-resistance CSV and/or --dma")
        if args.data and args.radius is None:
            parser.error("fit: rolling-resistance data need --radius [m]")
    if args.command in ("curve", "map") and not args.vmin < args.vmax:
        parser.error(f"{args.command}: --vmin ({args.vmin:g} m/s) must be below --vmax ({args.vmax:g} m/s)")
    if args.command == "map" and None not in (args.tmin, args.tmax) and not args.tmin < args.tmax:
        parser.error(f"map: --tmin ({args.tmin:g} K) must be below --tmax ({args.tmax:g} K)")
    if args.command == "sweep":
        names = [name for name, _ in args.vary]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:  # (a dict of the axes kept only the last)
            parser.error(f"sweep: --vary {', '.join(twice)} given more than once (one axis per name)")
    import jax

    import jaxroll as jr

    try:
        with warnings.catch_warnings():
            _print_warnings_once(args.command, (jr.PlausibilityWarning, jr.ValidityWarning, jr.DataWarning,
                                                jr.IdentifiabilityWarning, jr.MisfitWarning))
            return args.func(args)
    except (ValueError, OSError, jr.SolverError, jax.errors.JaxRuntimeError, eqx.EquinoxRuntimeError) as err:
        if args.debug:
            raise
        if isinstance(err, OSError):  # missing or unreadable input file, unwritable --out
            msg = f"{err.strerror or err}: {err.filename or ''}".rstrip(": ")
        elif isinstance(err, (jax.errors.JaxRuntimeError, eqx.EquinoxRuntimeError)):  # a check inside a compiled program
            msg = runtime_message(err)
        else:  # bad physical input: one clear line, no traceback
            msg = str(err)
        print(f"jaxroll {args.command}: error: {msg} (--debug for the traceback)", file=sys.stderr)
        return 2
