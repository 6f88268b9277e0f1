"""Option types and shared option groups of the ``jaxroll`` command line (SI units throughout),
and the one-line reporting of invalid points and errors."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ...methods import METHOD_NAMES


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``PROG: error: MESSAGE (see PROG --help)``, exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def number(kind, *, zero_ok=False):
    """argparse type: a finite number, positive (or ``>= 0`` with ``zero_ok``)."""
    rule = ">= 0" if zero_ok else "positive"

    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{kind}: expected a number, got {text!r}")
        if not (np.isfinite(v) and (v >= 0 if zero_ok else v > 0)):
            raise argparse.ArgumentTypeError(f"{kind}: must be finite and {rule}, got {text}")
        return v

    return parse


def positive(kind):
    return number(kind)


def period(text):
    """``--period``: ``auto`` or a positive length [m]."""
    if text.strip().lower() == "auto":
        return "auto"
    return positive("--period [m]")(text)


def nonnegative(kind):
    return number(kind, zero_ok=True)


def progress_args(p):
    """``--progress`` / ``--quiet``: progress lines on stderr, on by default (every command that
    takes them may run for more than a few seconds: compilation alone takes seconds)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--progress", dest="progress", action="store_true", default=True,
                   help="progress lines on stderr (the default)")
    g.add_argument("--quiet", dest="progress", action="store_false", help="no progress lines")


#: ``--modulus``: the CLI word for each contact-size modulus of :class:`jaxroll.Direct`.
MODULI = {"relaxed": "static", "dynamic": "dynamic", "glassy": "glassy"}


def method_args(p, *, fit=False, default=None):
    """The method and its configuration as options (SI units); ``default``: the help's words for
    the default (:func:`jaxroll.methods.default_method`)."""
    g = p.add_argument_group("method", "the rolling-resistance method and its configuration (jaxroll.Direct, "
                             "jaxroll.Full, jaxroll.Slices)")
    default = default or ("full, with the smoothed contact edge extrapolated to kappa -> 0, on a grid the fit "
                          "resolves from the data (jaxroll.methods.default_method(geometry, fit=True))" if fit else
                          "full (the full 3D model for spheres, 2D for cylinders, on an infinite layer)")
    g.add_argument("--method", choices=list(METHOD_NAMES), default=None,
                   help=f"full (the full 2D/3D contact model), direct (stationary pressure, [ZG] sec. 4; a "
                   f"screening choice: fast, 15-40 %% low near the R_r peak on an SLS layer, up to 95 %% low on a "
                   f"measured broad spectrum with --modulus relaxed), PD | PP | SP (sphere from cylinder slices, "
                   f"[ZG] sec. 3; screening: up to +183 %% at 10 m/s on a half-space); default {default}")
    g.add_argument("--modulus", choices=list(MODULI), default="relaxed",
                   help="--method direct: the modulus that sizes the stationary contact: relaxed (G'(0), the "
                        "paper's radii), dynamic (G' at the rolling frequency V/r) or glassy (G'(inf)) (relaxed)")
    g.add_argument("--pressure", choices=["auto", "thick", "thin", "thin-compressible", "elastic"], default="auto",
                   help="stationary pressure model of --method direct (auto)")
    g.add_argument("--spacing", type=positive("--spacing [m]"), default=None,
                   help="fixed grid (full, slices, direct --pressure elastic): cell size [m], with --window")
    g.add_argument("--window", type=count("--window"), default=None,
                   help="fixed grid: cells per side of the pressure window, with --spacing")
    g.add_argument("--period", type=period, default=None,
                   help="period of the surface [m] (the paper: 0.2), or 'auto' (long enough for the layer to "
                        "recover); default: an infinite layer (a single roller)")
    g.add_argument("--n-terms", dest="n_terms", type=count("--n-terms"), default=None,
                   help="Fourier cut-off of the periodic 3D compliance (paper: 500); default the period cells")
    g.add_argument("--cells-per-radius", dest="cells_per_radius", type=count("--cells-per-radius"), default=None,
                   help="automatic grid: cells per contact radius (default by the regime: full 3D 12-48, full 2D "
                        "12-400, slices 25-192)")
    g.add_argument("--edge-smoothing", dest="edge_smoothing", type=positive("--edge-smoothing"), default=None,
                   help="--method full: smoothed contact edge kappa, not extrapolated (a fit without --method: "
                        "extrapolated from 0.125)")
    g.add_argument("--n-slices", dest="n_slices", type=count("--n-slices"), default=21,
                   help="PD | PP | SP: odd number of slices (21)")


def method_name(args):
    """``--method``, or ``"full"``: the word for :func:`jaxroll.methods.default_method`."""
    return "full" if args.method is None else args.method


def method_from_args(args, *, fit=False):
    """The method object the options describe."""
    import jaxroll as jr

    name = method_name(args)

    if (args.spacing is None) != (args.window is None):
        raise ValueError("--spacing and --window describe a fixed grid together: give both (or neither, for the "
                         "automatic grid)")
    if args.spacing is not None:
        if args.cells_per_radius is not None:
            raise ValueError("--cells-per-radius sizes the automatic grid; it does not go with --spacing/--window")
        grid = jr.FixedGrid(args.spacing, args.window, period=args.period, n_terms=args.n_terms)
    else:
        period = args.period
        if period is None and name == "direct":
            period = "auto"  # --pressure elastic evaluates the periodic [ZG] eq. 26
        grid = jr.AutoGrid(cells_per_radius=args.cells_per_radius, period=period, n_terms=args.n_terms)
    if name == "direct":
        if args.pressure == "elastic":
            return jr.DirectElastic(grid=grid)
        return jr.Direct(pressure=args.pressure, modulus=MODULI[args.modulus])
    if name == "full":  # no --method: the default's edge smoothing (a fit's smoothed edge) unless given
        default = jr.methods.default_method(args.geometry, fit=fit) if args.method is None else jr.Full()
        if args.edge_smoothing is not None:  # an explicit kappa: that smoothing, not extrapolated
            return jr.Full(grid=grid, edge_smoothing=args.edge_smoothing)
        return jr.Full(grid=grid, edge_smoothing=default.edge_smoothing, edge_extrapolation=default.edge_extrapolation)
    return jr.Slices(algorithm=name, n_slices=args.n_slices, grid=grid)


def floats(kind):
    def parse(text):
        try:
            vals = [float(x) for x in text.split(",") if x.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}")
        if not vals:
            raise argparse.ArgumentTypeError("no values given")
        if not all(np.isfinite(v) and v > 0 for v in vals):
            raise argparse.ArgumentTypeError(f"values must be finite and positive, got {text}")
        return vals

    return parse


def model_args(p):
    p.add_argument("--G0", type=positive("G0 [Pa]"), default=3e6, help="relaxed shear modulus [Pa] (3e6)")
    p.add_argument("--tau", type=positive("tau [s]"), default=0.25, help="retardation time [s] (0.25)")
    p.add_argument("--f", type=nonnegative("f [-]"), default=1.0, help="relaxation strength G'(inf)/G'(0) - 1 [-] (1)")
    p.add_argument("--H", default="0.03", help="layer thickness [m] or 'inf' (0.03)")
    p.add_argument("--rho", type=nonnegative("rho [kg/m^3]"), default=1000.0, help="layer density [kg/m^3] (1000)")
    p.add_argument("--radius", type=positive("radius [m]"), default=0.02, help="roller radius [m] (0.02)")
    geometry_arg(p)
    method_args(p)


def geometry_arg(p):
    """``--geometry``: the roller's shape, which sets the load's unit."""
    p.add_argument("--geometry", choices=["sphere", "cylinder"], default="sphere",
                   help="rigid roller: a sphere (load in N) or a cylinder (plane strain, load in N/m) (sphere)")


def thickness(text):
    import jax.numpy as jnp

    if text == "inf":
        return jnp.inf
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"--H: expected a thickness in m or 'inf', got {text!r}") from None


def poisson(kind, *, incompressible=True):
    """argparse type: a Poisson's ratio in [0, 0.5] (or [0, 0.5) without ``incompressible``)."""
    at_least_zero = nonnegative(kind)

    def parse(text):
        v = at_least_zero(text)
        if v > 0.5 or (v == 0.5 and not incompressible):
            raise argparse.ArgumentTypeError(f"{kind}: must be in [0, 0.5{']' if incompressible else ')'}, got {text}")
        return v

    return parse


def say(on):
    """A progress printer: lines on stderr when ``on``."""
    def say(message):
        if on:
            print(message, file=sys.stderr, flush=True)

    return say


def choices(kind, allowed):
    def parse(text):
        vals = tuple(x.strip() for x in text.split(",") if x.strip())
        bad = [v for v in vals if v not in allowed]
        if bad or not vals:
            raise argparse.ArgumentTypeError(f"{kind}: unknown {bad or text!r}; choose from {','.join(allowed)}")
        return vals

    return parse


def count(kind):
    def parse(text):
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{kind}: expected a whole number, got {text!r}")
        if n < 1:
            raise argparse.ArgumentTypeError(f"{kind}: must be >= 1, got {n}")
        return n

    return parse


def runtime_message(err) -> str:
    """The message of a check that failed inside a compiled program (``eqx.error_if`` surfaces
    as a ``JaxRuntimeError`` wrapping a callback traceback): its first line, or the error's."""
    import re

    m = re.search(r"EquinoxRuntimeError: ([^\n]+)", str(err))
    return m.group(1).strip() if m else str(err).strip().splitlines()[0]


def cli_terms(message: str) -> str:
    """A library message with its API names replaced by the command-line options."""
    return message.replace("jr.DirectElastic", "--pressure elastic").replace("the full model", "--method full")


def warn_invalid(codes, where) -> None:
    """One stderr line per reason with the count of points outside their validity."""
    import jaxroll as jr

    codes = np.asarray(codes)
    bad = codes[codes != jr.RESULTS.successful]
    for c in np.unique(bad):
        print(f"jaxroll {where}: warning: {int(np.sum(bad == c))} of {codes.size} points not valid ({jr.RESULTS.names[c]}): "
              f"{cli_terms(jr.RESULTS.message(c))}; they are marked valid=0 in the CSV", file=sys.stderr)
