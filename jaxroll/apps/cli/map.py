"""``jaxroll map``: R_r over temperature x speed for a fitted material, with dR/dT and dR/dH."""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

from ...geometry import Geometry
from .options import count, geometry_arg, method_args, method_from_args, method_name, nonnegative, poisson, positive, progress_args, say, warn_invalid


def _material_info(path):
    """The ``info`` of a material JSON (``{}`` for a CSV or a file without it)."""
    import json

    path = Path(path)
    return json.loads(path.read_text()).get("info") or {} if path.suffix.lower() == ".json" else {}


def shifted_material(path):
    """``(material, shift, info)`` of a material file for a map over temperature: ``ValueError``
    when the file has no shift law."""
    import jaxroll as jr

    mat, shift = jr.load_material(path)
    if shift is None:
        raise ValueError(f"--material {path}: no shift law (WLF or Arrhenius) in the file; a map over "
                         f"temperature needs one (jaxroll material writes the fitted WLF law)")
    return mat, shift, _material_info(path)


def run(args) -> int:
    import jaxroll as jr
    from jaxroll.apps import plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    mat, shift, info = shifted_material(args.material)
    measured, measured_w = info.get("temperature_range"), info.get("reduced_frequency_range")
    T_ref = float(shift.T_ref)
    tmin = args.tmin if args.tmin is not None else (measured[0] if measured else T_ref - 40.0)
    tmax = args.tmax if args.tmax is not None else (measured[1] if measured else T_ref + 60.0)
    if not tmin < tmax:
        raise ValueError(f"--tmin ({tmin:g} K) must be below --tmax ({tmax:g} K)")
    unit = Geometry(args.geometry).load_unit
    load = args.load if args.load is not None else {"sphere": 10.0, "cylinder": 1e4}[args.geometry]
    temperatures = np.linspace(tmin, tmax, args.n_temperatures)
    speeds = np.logspace(np.log10(args.vmin), np.log10(args.vmax), args.n_speeds)
    layer = jr.Layer(H=args.H, rho=args.rho, nu=args.nu)
    name = method_name(args)
    method = method_from_args(args)
    say(args.progress)(
        f"map: {len(temperatures)} temperatures x {len(speeds)} speeds, {args.geometry}, method {name} (one "
        f"compiled program: compilation, then every point with dR/dT and dR/dH)")
    with warnings.catch_warnings():  # reported below, per reason, in CLI terms
        warnings.simplefilter("ignore", jr.ValidityWarning)
        m = jr.resistance_map(mat, shift, layer, radius=args.radius, load=load, temperatures=temperatures,
                              speeds=speeds, geometry=args.geometry, method=method, measured_temperatures=measured,
                              measured_frequencies=measured_w)
    m.write_csv(out / "map.csv", unit=unit)
    warn_invalid(m.result, "map")
    H = f"{args.H * 1e3:g} mm"
    plot.close(plot.plot_resistance_map(m, unit=unit, title=f"{args.geometry}, R = {args.radius:g} m, {load:g} {unit}, "
                                        f"H = {H}, method {name}", path=out / "map.png"))
    ok = m.valid
    span = f"R_r {np.min(m.value[ok]):.4g}..{np.max(m.value[ok]):.4g} {unit}" if ok.any() else "no valid point"
    print(f"material: {args.material} ({len(np.atleast_1d(mat.tau))} Prony terms, {type(shift).__name__} T_ref = "
          f"{T_ref:.2f} K); {args.geometry} R = {args.radius:g} m, load {load:g} {unit}, layer H = {H}")
    print(f"map: {m.value.size} points ({len(temperatures)} temperatures {tmin:.2f}..{tmax:.2f} K x {len(speeds)} "
          f"speeds {args.vmin:g}..{args.vmax:g} m/s), {ok.mean() * 100:.0f} % valid; {span}; method {name}, {m.seconds * 1e3:.3g} ms per point (value, dR/dT, dR/dH; "
          f"compiled)")
    print(f"wrote {out / 'map.csv'}, {out / 'map.png'}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub) -> None:
    """The ``map`` subcommand on ``sub`` (argparse subparsers)."""
    mp = sub.add_parser(
        "map", help="R_r over temperature x speed for a fitted material, with dR/dT and dR/dH (CSV and heat maps)",
        description="Rolling resistance of a rigid sphere or cylinder on a layer of a material written by "
        "jaxroll material (its Prony series and shift law), over temperature x speed, with dR_r/dT and dR_r/dH "
        "from jax.grad, all points in one compiled program. Writes map.csv (temperature, speed, "
        "rolling_resistance, dR_dT, dR_dH, valid, result) and map.png (heat maps with contours) into --out. "
        "Units SI (m, N or N/m, K, m/s).")
    mp.add_argument("--material", required=True, help="material.json (or material.csv) written by jaxroll material")
    geometry_arg(mp)
    mp.add_argument("--radius", type=positive("--radius [m]"), default=0.01, help="roller radius [m] (0.01)")
    mp.add_argument("--load", type=positive("--load [N or N/m]"), default=None,
                    help="load [N; N/m for cylinders] (default 10 N for a sphere, 1e4 N/m for a cylinder)")
    mp.add_argument("--H", type=positive("--H [m]"), default=0.01, help="layer thickness [m] (0.01)")
    mp.add_argument("--rho", type=nonnegative("--rho [kg/m^3]"), default=0.0,
                    help="layer density [kg/m^3] (default 0: no inertia)")
    mp.add_argument("--nu", type=poisson("--nu"), default=0.5,
                    help="layer Poisson's ratio (0.5; below 0.5 the quasi-static compressible layer, --rho 0)")
    mp.add_argument("--tmin", type=positive("--tmin [K]"), default=None,
                    help="lowest temperature [K] (default: the material's lowest measured temperature; points "
                    "outside the measured range are computed but not valid)")
    mp.add_argument("--tmax", type=positive("--tmax [K]"), default=None,
                    help="highest temperature [K] (default: the material's highest measured temperature)")
    mp.add_argument("--n-temperatures", dest="n_temperatures", type=count("--n-temperatures"), default=25,
                    help="number of temperatures (25)")
    mp.add_argument("--vmin", type=positive("--vmin [m/s]"), default=1e-3, help="lowest speed [m/s] (1e-3)")
    mp.add_argument("--vmax", type=positive("--vmax [m/s]"), default=10.0, help="highest speed [m/s] (10)")
    mp.add_argument("--n-speeds", dest="n_speeds", type=count("--n-speeds"), default=25,
                    help="number of log-spaced speeds (25)")
    method_args(mp)
    progress_args(mp)
    mp.add_argument("--out", default="jaxroll-map", help="output folder (jaxroll-map)")
    mp.set_defaults(func=run)
