"""``jaxroll conveyor``: the indentation rolling resistance of a conveyor belt over idlers, over
temperature x speed x load, with the design derivatives (d/dT, d/dH_cover, d/dln G, d/dln tau)."""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path

import numpy as np

from .map import shifted_material
from .options import count, floats, method_args, method_from_args, method_name, nonnegative, poisson, positive, progress_args, say, warn_invalid


def _loads(args):
    """``(line_loads [N/m], TroughLoads or None)`` from ``--line-load`` or the belt options."""
    import jaxroll as jr

    belt = (args.belt_width, args.belt_mass, args.bulk_mass, args.idler_spacing)
    if args.line_load is not None:
        if any(v is not None for v in belt):
            raise ValueError("give either --line-load or the belt (--belt-width, --belt-mass, --bulk-mass, "
                             "--idler-spacing), not both")
        return np.asarray(args.line_load, float), None
    if any(v is None for v in belt):
        raise ValueError("give --line-load [N/m], or the belt: --belt-width [m], --belt-mass [kg/m], --bulk-mass "
                         "[kg/m] and --idler-spacing [m] (with --roll-length and --trough-angle for a three-roll trough)")
    trough = jr.conveyor.trough_loads(belt_width=args.belt_width, belt_mass=args.belt_mass, bulk_mass=args.bulk_mass,
                                      spacing=args.idler_spacing, roll_length=args.roll_length,
                                      trough_angle=math.radians(args.trough_angle),
                                      surcharge_angle=math.radians(args.surcharge_angle))
    return np.asarray(trough.line_load, float), trough


def _report(m, trough, args):
    """One line per temperature and speed: F_ir per idler (set), the coefficient and the power
    over --n-idlers; a line with an invalid roll says so and is not summed into a range."""
    for i, T in enumerate(m.temperatures):
        for j, V in enumerate(m.speeds):
            ok = bool(np.all(m.valid[i, j]))
            if trough is None:
                F = m.per_width[i, j] * args.contact_length
                parts = ", ".join(f"{q:g} N/m: F_ir {f:.4g} N, F_ir/F_z {c:.3g}" for q, f, c in
                                  zip(m.line_loads, F, m.coefficient[i, j]))
            else:
                F = float(np.dot(trough.count, m.per_width[i, j] * trough.contact_length))
                P = F * V * args.n_idlers
                parts = (f"F_ir {F:.4g} N per idler set, F_ir/W {F / trough.weight:.3g}, {args.n_idlers} sets: "
                         f"{P / 1e3:.4g} kW")
            print(f"T {T:.2f} K, V {V:g} m/s: {parts}{'' if ok else '  [NOT VALID: see result in conveyor.csv]'}")


def run(args) -> int:
    import jaxroll as jr

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    mat, shift, info = shifted_material(args.material)
    loads, trough = _loads(args)
    temperatures = np.asarray(args.temperatures if args.temperatures else [float(shift.T_ref)], float)
    layer = jr.Layer(H=args.H, rho=args.rho, nu=args.nu)
    if trough is not None:
        print(f"trough: {', '.join(f'{n} roll F_z {f:.4g} N on {lc:g} m ({q:.4g} N/m)' for n, f, lc, q in zip(trough.rolls, trough.normal_force, trough.contact_length, trough.line_load))}; "
              f"bulk share of the center roll {trough.center_share:.3f}; weight per set {trough.weight:.4g} N")
    say(args.progress)(f"conveyor: {len(temperatures)} temperatures x {len(args.speeds)} speeds x {len(loads)} loads, "
                       f"method {method_name(args)} (one compiled program with every derivative)")
    with warnings.catch_warnings():  # reported below, per reason, in CLI terms
        warnings.simplefilter("ignore", jr.ValidityWarning)
        m = jr.conveyor.conveyor_map(mat, shift, layer, diameter=args.diameter, line_loads=loads,
                                     temperatures=temperatures, speeds=args.speeds,
                                     contact_length=args.contact_length, method=method_from_args(args),
                                     measured_temperatures=info.get("temperature_range"),
                                     measured_frequencies=info.get("reduced_frequency_range"))
    m.write_csv(out / "conveyor.csv")
    warn_invalid(m.result, "conveyor")
    _report(m, trough, args)
    print(f"{m.per_width.size} points, {m.valid.mean() * 100:.0f} % valid, {m.seconds * 1e3:.3g} ms per point "
          f"(value and derivatives, compiled); wrote {out / 'conveyor.csv'}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub) -> None:
    """The ``conveyor`` subcommand on ``sub`` (argparse subparsers)."""
    p = sub.add_parser(
        "conveyor", help="indentation rolling resistance of a conveyor belt over idlers (per idler, coefficient, "
        "power), over temperature x speed x load, with d/dT, d/dH and material derivatives",
        description="The idler is a rigid cylinder rolling on the belt's bottom cover (a viscoelastic layer of a "
        "material written by jaxroll material on a rigid carcass), by default with the full 2D model. Give the load "
        "per unit width (--line-load) or the belt: --belt-width, --belt-mass, --bulk-mass, --idler-spacing (and "
        "--roll-length, --trough-angle for a three-roll trough: ISO 5048 / DIN 22101 cross-section, each roll "
        "carries the bulk column above it). Writes conveyor.csv (one row per temperature, speed and line load: "
        "F_ir per width and per idler, F_ir/F_z, dF/dT, dF/dH, dF/dlnG, dF/dlntau, valid, result). Units SI "
        "(m, N, N/m, kg/m, m/s, K; angles in degrees).")
    p.add_argument("--material", required=True, help="material.json (or .csv) written by jaxroll material")
    p.add_argument("--H", type=positive("--H [m]"), default=0.006, help="bottom cover thickness [m] (0.006)")
    p.add_argument("--nu", type=poisson("--nu"), default=0.5, help="cover Poisson's ratio (0.5)")
    p.add_argument("--rho", type=nonnegative("--rho [kg/m^3]"), default=0.0,
                   help="cover density [kg/m^3] (default 0: no inertia)")
    p.add_argument("--diameter", type=positive("--diameter [m]"), default=0.159, help="idler diameter [m] (0.159)")
    p.add_argument("--line-load", dest="line_load", type=floats("--line-load [N/m]"), default=None,
                   help="load per unit contact width [N/m], comma-separated")
    p.add_argument("--contact-length", dest="contact_length", type=positive("--contact-length [m]"), default=1.0,
                   help="with --line-load: the belt's contact length on the idler [m] for F_ir per idler (1)")
    p.add_argument("--belt-width", dest="belt_width", type=positive("--belt-width [m]"), default=None,
                   help="belt width [m] (with --belt-mass, --bulk-mass, --idler-spacing: loads from the bulk)")
    p.add_argument("--belt-mass", dest="belt_mass", type=nonnegative("--belt-mass [kg/m]"),
                   default=None, help="belt mass per metre of belt [kg/m]")
    p.add_argument("--bulk-mass", dest="bulk_mass", type=nonnegative("--bulk-mass [kg/m]"),
                   default=None, help="bulk (conveyed material) mass per metre of belt [kg/m]")
    p.add_argument("--idler-spacing", dest="idler_spacing", type=positive("--idler-spacing [m]"), default=None,
                   help="spacing of the idler sets [m]")
    p.add_argument("--roll-length", dest="roll_length", type=positive("--roll-length [m]"), default=None,
                   help="length of each of three equal rolls [m] (a trough; default a flat idler)")
    p.add_argument("--trough-angle", dest="trough_angle", type=nonnegative("--trough-angle [deg]"), default=0.0,
                   help="trough angle of the wing rolls [deg] (0: flat)")
    p.add_argument("--surcharge-angle", dest="surcharge_angle", type=nonnegative("--surcharge-angle [deg]"),
                   default=20.0, help="surcharge angle of the bulk [deg] (20)")
    p.add_argument("--speeds", type=floats("--speeds [m/s]"), default=[5.0], help="belt speeds [m/s] (5)")
    p.add_argument("--temperatures", type=floats("--temperatures [K]"), default=None,
                   help="temperatures [K], comma-separated (default the material's T_ref)")
    p.add_argument("--n-idlers", dest="n_idlers", type=count("--n-idlers"), default=1,
                   help="idler sets in the flight, for the power n F_ir V (1)")
    method_args(p, default="full (the full 2D model on an infinite layer)")
    progress_args(p)
    p.add_argument("--out", default="jaxroll-conveyor", help="output folder (jaxroll-conveyor)")
    p.set_defaults(func=run, geometry="cylinder")
