"""``jaxroll`` command line. Units are SI throughout (m, N, Pa, s, kg/m^3)."""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import equinox as eqx
import numpy as np

from .io import write_table
from .methods import METHOD_NAMES

__all__ = ["main"]


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``PROG: error: MESSAGE (see PROG --help)``, exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _number(kind, *, zero_ok=False):
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


def _positive(kind):
    return _number(kind)


def _period(text):
    """``--period``: ``auto`` or a positive length [m]."""
    if text.strip().lower() == "auto":
        return "auto"
    return _positive("--period [m]")(text)


def _nonnegative(kind):
    return _number(kind, zero_ok=True)


def _progress_args(p, default):
    """``--progress`` / ``--quiet``: progress lines on stderr (default: ``default``)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--progress", dest="progress", action="store_true", default=default,
                   help="progress lines on stderr (default: "
                   + {True: "on", False: "off", None: "on for the grid methods"}[default] + ")")
    g.add_argument("--quiet", dest="progress", action="store_false", help="no progress lines")


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
    cols = {"q": q}
    for name, lay in layers.items():
        c = np.asarray(jr.surface_compliance(lay, mat, q, 0.0, args.speed))
        cols.update({f"ReT {name}": c.real, f"ImT {name}": c.imag})
    write_table(out / "compliance.csv", cols, ["rad/m", *["m/Pa"] * (2 * len(layers))], formats=".6e")
    print(f"material: G0 = {args.G0:g} Pa, tau = {args.tau:g} s, f = {args.f:g};"
          f" layers H = 2, 5, 30 mm and half-space, rho = {args.rho:g} kg/m^3, V = {args.speed:g} m/s")
    print(f"wrote {out / 'master_curves.png'}, {out / 'compliance.png'}, {out / 'compliance.csv'}"
          f"  ({time.perf_counter() - t0:.1f} s)")
    return 0


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


def _method_args(p, *, fit=False, default=None):
    """The method and its configuration as options (SI units); ``default``: the help's words for
    a subcommand's own default (which it sets with ``set_defaults(method=...)``)."""
    g = p.add_argument_group("method", "the rolling-resistance method and its configuration (jaxroll.Direct, "
                             "jaxroll.Full, jaxroll.Slices)")
    default = default or ("direct (the fit varies the material, so a grid method needs a fixed grid)" if fit else
                          "SP for spheres, full for cylinders (the most accurate under 1 s per point)")
    g.add_argument("--method", choices=list(METHOD_NAMES), default=None,
                   help=f"direct (stationary pressure, [ZG] sec. 4; fast, 15-40 %% low near the R_r peak), full "
                   f"(the full 2D/3D contact model), PD | PP | SP (sphere from cylinder slices, [ZG] sec. 3); "
                   f"default {default}")
    g.add_argument("--pressure", choices=["auto", "thick", "thin", "thin-compressible", "elastic"], default="auto",
                   help="stationary pressure model of --method direct (auto)")
    g.add_argument("--spacing", type=_positive("--spacing [m]"), default=None,
                   help="fixed grid (full, slices, direct --pressure elastic): cell size [m], with --window")
    g.add_argument("--window", type=_count("--window"), default=None,
                   help="fixed grid: cells per side of the pressure window, with --spacing")
    g.add_argument("--period", type=_period, default=None,
                   help="period of the surface [m] (the paper: 0.2), or 'auto' (long enough for the layer to "
                        "recover); default: an infinite layer (a single roller)")
    g.add_argument("--n-terms", dest="n_terms", type=_count("--n-terms"), default=None,
                   help="Fourier cut-off of the periodic 3D compliance (paper: 500); default the period cells")
    g.add_argument("--cells-per-radius", dest="cells_per_radius", type=_count("--cells-per-radius"), default=None,
                   help="automatic grid: cells per contact radius (default: sphere 12, lines 25-128 by speed)")
    g.add_argument("--edge-smoothing", dest="edge_smoothing", type=_positive("--edge-smoothing"), default=None,
                   help="--method full: smoothed contact edge kappa (0.25 on the paper's grid; for fits)")
    g.add_argument("--n-slices", dest="n_slices", type=_count("--n-slices"), default=21,
                   help="PD | PP | SP: odd number of slices (21)")


def _method_name(args, *, fit=False):
    """``--method``, or the default: the front door's for the geometry (fits: direct)."""
    if args.method is not None:
        return args.method
    return "direct" if fit else {"sphere": "SP", "cylinder": "full"}[args.geometry]


def _method_from_args(args, *, fit=False):
    """The method object the options describe."""
    import jaxroll as jr

    name = _method_name(args, fit=fit)

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
        return jr.DirectElastic(grid=grid) if args.pressure == "elastic" else jr.Direct(pressure=args.pressure)
    if name == "full":
        return jr.Full(grid=grid, edge_smoothing=args.edge_smoothing)
    return jr.Slices(algorithm=name, n_slices=args.n_slices, grid=grid)


def _fit(args) -> int:
    import json

    import jax.numpy as jnp

    import jaxroll as jr
    from jaxroll import fit as jfit
    from jaxroll import plot

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
    method = _method_from_args(args, fit=True)
    if data is not None and method.needs_resolution(args.geometry):
        raise ValueError(f"--method {_method_name(args, fit=True)} computes on a grid, which a fit must keep fixed while the material "
                         f"varies: give --spacing and --window (and --period), e.g. --spacing 2.5e-4 --window 55 "
                         f"--period 0.2")
    fit = jfit.fit_material(data, dma, initial=jr.StandardLinearSolid(**init), layer=layer, radius=args.radius,
                            geometry=args.geometry, method=method, free=free, shift=shift,
                            n_starts=args.starts, seed=args.seed, solver=args.solver,
                            progress=args.progress or (args.progress is None and _method_name(args, fit=True) != "direct"))
    report = fit.report()
    (out / "fit_report.txt").write_text(report + "\n")
    params = {
        n: {"value": np.ravel(fit.params[n]).tolist(), "stderr": np.ravel(fit.stderr[n]).tolist(),
            "ci95": [np.ravel(fit.ci95[n][0]).tolist(), np.ravel(fit.ci95[n][1]).tolist()]}
        for n in fit.params
    }
    payload = {"parameters": params, "names": fit.names, "correlation": np.asarray(fit.correlation).tolist(),
               "converged": fit.converged, "cost": fit.cost, "reduced_chi2": fit.reduced_chi2,
               "warnings": fit.warnings, "method": repr(method),
               "units": {"G0": "Pa", "tau": "s", "f": "-", "H": "m"}}
    (out / "fit_params.json").write_text(json.dumps(payload, indent=2) + "\n")
    written = ["fit_report.txt", "fit_params.json"]
    if data is not None:
        unit = "N" if args.geometry == "sphere" else "N/m"
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


def _floats(kind):
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


def _model_args(p):
    p.add_argument("--G0", type=_positive("G0 [Pa]"), default=3e6, help="relaxed shear modulus [Pa] (3e6)")
    p.add_argument("--tau", type=_positive("tau [s]"), default=0.25, help="retardation time [s] (0.25)")
    p.add_argument("--f", type=_nonnegative("f [-]"), default=1.0, help="relaxation strength G'(inf)/G'(0) - 1 [-] (1)")
    p.add_argument("--H", default="0.03", help="layer thickness [m] or 'inf' (0.03)")
    p.add_argument("--rho", type=_nonnegative("rho [kg/m^3]"), default=1000.0, help="layer density [kg/m^3] (1000)")
    p.add_argument("--radius", type=_positive("radius [m]"), default=0.02, help="roller radius [m] (0.02)")
    p.add_argument("--geometry", choices=["sphere", "cylinder"], default="sphere")
    _method_args(p)


def _thickness(text):
    import jax.numpy as jnp

    if text == "inf":
        return jnp.inf
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"--H: expected a thickness in m or 'inf', got {text!r}") from None


def _curve(args) -> int:
    import jaxroll as jr
    from jaxroll import plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    mat = jr.StandardLinearSolid(args.G0, args.tau, args.f)
    layer = jr.Layer(H=_thickness(args.H), rho=args.rho)
    speeds = np.logspace(np.log10(args.vmin), np.log10(args.vmax), args.n)
    loads = np.sort(np.asarray(args.loads))
    if args.progress:
        print(f"curve: {len(speeds)} speeds x {len(loads)} loads, method {_method_name(args)} (one compiled "
              f"program: grid sizing, compilation, then every point)", file=sys.stderr, flush=True)
    with warnings.catch_warnings():  # reported below, per reason, in CLI terms
        warnings.simplefilter("ignore", jr.ValidityWarning)
        res = jr.rolling_resistance_grid(mat, layer, radius=args.radius, loads=loads, speeds=speeds,
                                         geometry=args.geometry, method=_method_from_args(args), throw=False)
    values, codes = np.asarray(res.value).T, np.asarray(res.result).T  # (loads, speeds)
    unit = "N" if args.geometry == "sphere" else "N/m"
    P_, V_ = (a.ravel() for a in np.meshgrid(loads, speeds, indexing="ij"))
    write_table(out / "curve.csv", {"speed": V_, "load": P_, "rolling_resistance": values.ravel(),
                                    "valid": (codes.ravel() == 0).astype(int),
                                    "result": [jr.RESULTS.names[int(c)] for c in codes.ravel()]},
                ["m/s", unit, unit, "-", "-"], formats=".8g")
    _warn_invalid(codes, "curve")
    plot.plot_rolling_curves(speeds, loads, values, unit=unit, valid=codes == 0,
                             title=f"{args.geometry}, method {_method_name(args)}, H = {args.H} m", path=out / "curve.png")
    print(f"wrote {out / 'curve.csv'}, {out / 'curve.png'}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def _sweep_cmd(args) -> int:
    import itertools

    import jaxroll as jr
    from jaxroll.grids import union

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    axes = dict(args.vary)
    base = {"V": 0.01, "P": 100.0, "H": _thickness(args.H), "G0": args.G0, "tau": args.tau, "f": args.f, "R": args.radius}

    def models(v):
        return jr.StandardLinearSolid(v["G0"], v["tau"], v["f"]), jr.Layer(H=v["H"], rho=args.rho)

    method = _method_from_args(args)
    if method.needs_resolution(args.geometry):
        # one grid for the whole sweep: the union of the grids of the corners of the other axes
        corners = [axes.get(k, [base[k]]) for k in ("H", "G0", "tau", "f", "R")]
        loads, speeds = axes.get("P", [base["P"]]), axes.get("V", [base["V"]])
        grids = []
        for H, G0, tau, f, R in itertools.product(*[(min(c), max(c)) for c in corners]):
            mat, lay = models({"H": H, "G0": G0, "tau": tau, "f": f})
            grids.append(method.resolve(mat, lay, radius=R, loads=loads, speeds=speeds, geometry=args.geometry).grid)
        method = eqx.tree_at(lambda m: m.grid, method, union(grids))

    def one(p):
        v = {k: getattr(p, k) if k in axes else base[k] for k in base}
        mat, lay = models(v)
        r = jr.rolling_resistance(mat, lay, radius=v["R"], load=v["P"], speed=v["V"], geometry=args.geometry,
                                  method=method, throw=False)
        return r.value, r.result

    values, codes = (np.asarray(a) for a in jr.sweep(one, jr.Grid(**axes), progress=args.progress))
    names = list(axes)
    mesh = np.meshgrid(*[np.asarray(axes[n]) for n in names], indexing="ij")
    cols = {n: m.ravel() for n, m in zip(names, mesh)}
    cols.update(rolling_resistance=values.ravel(), valid=(codes.ravel() == 0).astype(int),
                result=[jr.RESULTS.names[int(c)] for c in codes.ravel()])
    write_table(out / "sweep.csv", cols, [_SWEEP_NAMES[n].split("[")[1].rstrip("]") for n in names]
                + ["N" if args.geometry == "sphere" else "N/m", "-", "-"], formats=".8g")
    _warn_invalid(codes, "sweep")
    print(f"{values.size} points; wrote {out / 'sweep.csv'}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def _poisson(kind, *, incompressible=True):
    """argparse type: a Poisson's ratio in [0, 0.5] (or [0, 0.5) without ``incompressible``)."""
    nonnegative = _nonnegative(kind)

    def parse(text):
        v = nonnegative(text)
        if v > 0.5 or (v == 0.5 and not incompressible):
            raise argparse.ArgumentTypeError(f"{kind}: must be in [0, 0.5{']' if incompressible else ')'}, got {text}")
        return v

    return parse


def _say(on):
    """A progress printer: lines on stderr when ``on``."""
    def say(message):
        if on:
            print(message, file=sys.stderr, flush=True)

    return say


def _material_cmd(args) -> int:
    import jaxroll as jr
    from jaxroll import plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    say = _say(args.progress)
    say(f"material: reading {args.dma}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", jr.DataWarning)
        sw = jr.read_dma_sweeps(args.dma, poisson=args.poisson)
    for w in caught:
        print(f"jaxroll material: warning: {w.message}", file=sys.stderr)
    say(f"material: shift factors of {sw.n_sets} temperature sets ({args.shift_moduli} moduli), WLF and Arrhenius fits")
    sh = jr.fit_shift_factors(sw, T_ref=args.T_ref, moduli=args.shift_moduli)
    wlf, arr = jr.fit_wlf(sh), jr.fit_arrhenius(sh)
    master = jr.master_curve(sw, sh)
    artifacts = jr.loss_artifacts(master)
    weights = np.ones((len(master.omega), 2))
    if args.drop_loss_artifacts:
        weights[artifacts, 1] = 0.0
    say(f"material: Prony fit to {len(master.omega)} master-curve points")
    pf = jr.fit_prony(master, n_terms=args.prony_terms, weights=weights)
    mat = pf.material
    rms_s, rms_l = (float(np.sqrt(np.mean(pf.residuals[weights[:, k] > 0, k] ** 2))) for k in (0, 1))
    hz = ", ".join(f"{f:.4g}" for f in np.unique(np.round(master.frequency[artifacts] / (2 * np.pi), 6)))
    found = (f"loss artifacts: {int(artifacts.sum())} loss values at {hz} Hz turn up in most sets ("
             + ("left out of the Prony fit)" if args.drop_loss_artifacts else
                "kept in the Prony fit; --drop-loss-artifacts leaves them out)")) if artifacts.any() else \
        "loss artifacts: none found"
    G0 = float(mat.glassy_modulus())
    (c1_lo, c1_hi), (c2_lo, c2_hi) = wlf.ci95["C1"], wlf.ci95["C2"]
    ea_lo, ea_hi = arr.ci95["activation_energy"]
    report = [
        f"DMA: {args.dma}: {len(sw.omega)} points in {sw.n_sets} temperature sets, {sw.set_temperature[0]:.2f}.."
        f"{sw.set_temperature[-1]:.2f} K ({sw.source})",
        f"shift factors: T_ref = {sh.T_ref:.2f} K (set {sh.reference}); log10 a_T {sh.log10_aT[0]:+.2f} at "
        f"{sh.temperature[0]:.2f} K .. {sh.log10_aT[-1]:+.2f} at {sh.temperature[-1]:.2f} K; master curve "
        f"{np.log10(master.omega[0]):.1f}..{np.log10(master.omega[-1]):.1f} decades of reduced omega [rad/s]",
        f"WLF: C1 = {wlf.params['C1']:.4g} (95 % [{c1_lo:.4g}, {c1_hi:.4g}]), C2 = {wlf.params['C2']:.4g} K "
        f"(95 % [{c2_lo:.4g}, {c2_hi:.4g}]); rms {wlf.rms:.3f} decades (the law written with the material)",
        f"Arrhenius: E_a = {arr.params['activation_energy']:.4g} J/mol (95 % [{ea_lo:.4g}, {ea_hi:.4g}]); "
        f"rms {arr.rms:.3f} decades",
        found,
        f"Prony: {pf.n_terms} terms, tau {float(np.min(mat.tau)):.3g}..{float(np.max(mat.tau)):.3g} s; rms log "
        f"residual {pf.rms:.4f} of the values fitted (storage {rms_s:.4f}, loss {rms_l:.4f}); G_inf = {float(mat.G_inf):.4g} Pa, "
        f"G_0 = {G0:.4g} Pa (shear)",
    ]
    info = {"source": str(args.dma), "moduli": sw.source, "temperature_range": [float(sw.set_temperature[0]),
            float(sw.set_temperature[-1])], "T_ref": sh.T_ref,
            "WLF": {"C1": wlf.params["C1"], "C2": wlf.params["C2"], "ci95": wlf.ci95, "rms_decades": wlf.rms},
            "Arrhenius": {"activation_energy": arr.params["activation_energy"],
                          "ci95": arr.ci95["activation_energy"], "rms_decades": arr.rms},
            "prony": {"n_terms": pf.n_terms, "rms_log": pf.rms, "rms_log_storage": rms_s, "rms_log_loss": rms_l,
                      "loss_artifacts_hz": sorted({round(float(f) / (2 * np.pi), 6)
                                                   for f in master.frequency[artifacts]}),
                      "loss_artifacts_left_out": bool(args.drop_loss_artifacts and artifacts.any())}}
    jr.save_material(out / "material.json", mat, wlf.shift, info=info)
    jr.save_material(out / "material.csv", mat, wlf.shift)
    jr.write_abaqus(mat, out / "material_abaqus.inp", shift=wlf.shift, poisson=args.fe_poisson)
    jr.write_ansys(mat, out / "material_ansys.mac", shift=wlf.shift, poisson=args.fe_poisson)
    laws = [np.asarray(f.shift.log_shift(sh.temperature)) / np.log(10.0) for f in (wlf, arr)]
    write_table(out / "shift_factors.csv", {"temperature": sh.temperature, "log10_aT": sh.log10_aT, "sigma": sh.sigma,
                                            "step_sigma": sh.step_sigma, "wlf_log10_aT": laws[0],
                                            "arrhenius_log10_aT": laws[1],
                                            "reference": (np.arange(len(sh.temperature)) == sh.reference).astype(int)},
                ["K", "-", "-", "-", "-", "-", "-"], formats=".8g")
    fitted = np.asarray(jr.complex_modulus(mat, master.omega))
    write_table(out / "master_curve.csv", {"reduced_omega": master.omega, "storage": master.storage, "loss": master.loss,
                                           "temperature": sw.set_temperature[master.set], "set": master.set,
                                           "prony_storage": fitted.real, "prony_loss": fitted.imag},
                ["rad/s", "Pa", "Pa", "K", "-", "Pa", "Pa"],
                formats={**dict.fromkeys(("reduced_omega", "storage", "loss", "prony_storage", "prony_loss"), ".8g"),
                         "temperature": ".6g"})
    plot.close(plot.plot_master_fit(master, pf, path=out / "master_curve.png"))
    plot.close(plot.plot_shift_factors(sh, {"WLF": wlf, "Arrhenius": arr}, path=out / "shift_factors.png"))
    (out / "material_report.txt").write_text("\n".join(report) + "\n")
    written = ["material.json", "material.csv", "material_abaqus.inp", "material_ansys.mac", "shift_factors.csv",
               "master_curve.csv", "master_curve.png", "shift_factors.png", "material_report.txt"]
    print("\n".join(report))
    print(f"wrote {', '.join(str(out / w) for w in written)}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def _material_info(path):
    """The ``info`` of a material JSON (``{}`` for a CSV or a file without it)."""
    import json

    path = Path(path)
    return json.loads(path.read_text()).get("info") or {} if path.suffix.lower() == ".json" else {}


def _map_cmd(args) -> int:
    import jaxroll as jr
    from jaxroll import plot
    from jaxroll.grids import union

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    mat, shift = jr.load_material(args.material)
    if shift is None:
        raise ValueError(f"--material {args.material}: no shift law (WLF or Arrhenius) in the file; a map over "
                         f"temperature needs one (jaxroll material writes the fitted WLF law)")
    measured = _material_info(args.material).get("temperature_range")
    T_ref = float(shift.T_ref)
    tmin = args.tmin if args.tmin is not None else (measured[0] if measured else T_ref - 40.0)
    tmax = args.tmax if args.tmax is not None else (measured[1] if measured else T_ref + 60.0)
    if not tmin < tmax:
        raise ValueError(f"--tmin ({tmin:g} K) must be below --tmax ({tmax:g} K)")
    unit = "N" if args.geometry == "sphere" else "N/m"
    load = args.load if args.load is not None else {"sphere": 10.0, "cylinder": 1e4}[args.geometry]
    temperatures = np.linspace(tmin, tmax, args.n_temperatures)
    speeds = np.logspace(np.log10(args.vmin), np.log10(args.vmax), args.n_speeds)
    layer = jr.Layer(H=args.H, rho=args.rho, nu=args.nu)
    name = _method_name(args)
    method = _method_from_args(args)
    if method.needs_resolution(args.geometry):  # one grid for the map: the union of the coldest and hottest
        method = eqx.tree_at(lambda m: m.grid, method, union([
            method.resolve(jr.at_temperature(mat, shift, T), layer, radius=args.radius, loads=[load], speeds=speeds,
                           geometry=args.geometry).grid for T in (tmin, tmax)]))
    _say(args.progress or (args.progress is None and name != "direct"))(
        f"map: {len(temperatures)} temperatures x {len(speeds)} speeds, {args.geometry}, method {name} (one "
        f"compiled program: compilation, then every point with dR/dT and dR/dH)")
    with warnings.catch_warnings():  # reported below, per reason, in CLI terms
        warnings.simplefilter("ignore", jr.ValidityWarning)
        m = jr.resistance_map(mat, shift, layer, radius=args.radius, load=load, temperatures=temperatures,
                              speeds=speeds, geometry=args.geometry, method=method)
    m.write_csv(out / "map.csv", unit=unit)
    _warn_invalid(m.result, "map")
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


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    p = _Parser(
        prog="jaxroll",
        description="Viscoelastic rolling resistance of rigid spheres and cylinders on layers. "
        "All quantities in SI units: lengths m, loads N (sphere) or N/m (cylinder), moduli Pa, "
        "times s, speeds m/s, densities kg/m^3.",
    )
    p.add_argument("--version", action="version", version=f"jaxroll {__version__}")
    p.add_argument("--debug", action="store_true", help="show the Python traceback of an error")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="evaluate the paper's example material and layers, write plots")
    d.add_argument("--out", default="jaxroll-out", help="output folder (default: jaxroll-out)")
    d.add_argument("--G0", type=_positive("G0 [Pa]"), default=3e6, help="relaxed shear modulus [Pa] (3e6)")
    d.add_argument("--tau", type=_positive("tau [s]"), default=0.25, help="retardation time [s] (0.25)")
    d.add_argument("--f", type=_nonnegative("f [-]"), default=1.0, help="relaxation strength G'(inf)/G'(0) - 1 [-] (1)")
    d.add_argument("--rho", type=_nonnegative("rho [kg/m^3]"), default=1000.0, help="layer density [kg/m^3] (1000)")
    d.add_argument("--speed", type=_positive("speed [m/s]"), default=0.1, help="rolling speed [m/s] (0.1)")
    d.set_defaults(func=_demo)

    c = sub.add_parser("curve", help="R_r against speed for one or more loads (CSV and PNG)")
    _model_args(c)
    c.add_argument("--loads", type=_floats("--loads"), default=[50.0, 100.0, 150.0],
                   help="loads, comma separated [N, or N/m for cylinders] (50,100,150)")
    c.add_argument("--vmin", type=_positive("--vmin [m/s]"), default=1e-4, help="lowest speed [m/s] (1e-4)")
    c.add_argument("--vmax", type=_positive("--vmax [m/s]"), default=1.0, help="highest speed [m/s] (1)")
    c.add_argument("--n", type=_count("--n"), default=23, help="number of log-spaced speeds (23)")
    _progress_args(c, False)
    c.add_argument("--out", default="jaxroll-curve", help="output folder (jaxroll-curve)")
    c.set_defaults(func=_curve)

    s_ = sub.add_parser("sweep", help="R_r over a grid of any parameters (V, P, H, G0, tau, f, R), CSV out",
                        description="Each --vary NAME=lo:hi:n[:log] or NAME=v1,v2,... adds a grid axis; the other "
                        "parameters keep their values (V = 0.01 m/s, P = 100 N unless varied).")
    _model_args(s_)
    s_.add_argument("--vary", type=_axis, action="append", required=True, help="grid axis, e.g. V=1e-4:1:23:log")
    _progress_args(s_, True)
    s_.add_argument("--out", default="jaxroll-sweep", help="output folder (jaxroll-sweep)")
    s_.set_defaults(func=_sweep_cmd)

    f = sub.add_parser("fit", help="identify G0, tau, f (and optionally H) from rolling-resistance and/or DMA data",
                       description="Fit a standard linear solid to rolling-resistance data (CSV: columns speed, load, "
                       "rolling_resistance[, sigma]; second row units, e.g. m/s,N,N) and/or DMA data (CSV: frequency, "
                       "storage_modulus, loss_modulus[, temperature]; units Hz|rad/s, Pa|kPa|MPa|GPa, K|degC).")
    f.add_argument("data", nargs="?", help="rolling-resistance CSV")
    f.add_argument("--dma", help="DMA CSV (fitted jointly)")
    f.add_argument("--radius", type=_positive("radius [m]"), help="roller radius [m]")
    f.add_argument("--H", default="inf", help="layer thickness [m] or 'inf' (default inf)")
    f.add_argument("--rho", type=_nonnegative("rho [kg/m^3]"), default=0.0, help="layer density [kg/m^3] (default 0: no inertia)")
    f.add_argument("--nu", type=_nonnegative("nu [-]"), default=0.5, help="Poisson's ratio (default 0.5)")
    f.add_argument("--geometry", choices=["sphere", "cylinder"], default="sphere")
    _method_args(f, fit=True)
    f.add_argument("--free", default="G0,tau,f", help="free parameters, comma separated (G0,tau,f[,H])")
    f.add_argument("--initial", type=_parse_initial, help="initial values, e.g. G0=1e6,tau=0.1,f=0.5 (SI)")
    f.add_argument("--wlf", help="WLF shift C1,C2[K],T_ref[K] for DMA at several temperatures, e.g. 8.86,101.6,293.15 "
                   "(add C1,C2 to --free to fit them)")
    f.add_argument("--starts", type=_count("--starts"), default=5, help="number of starts spread over two decades (5)")
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--solver", choices=["trf", "lm"], default="trf",
                   help="scipy least_squares method: trust-region reflective (default) or MINPACK Levenberg-Marquardt")
    _progress_args(f, None)
    f.add_argument("--out", default="jaxroll-fit", help="output folder (default jaxroll-fit)")
    f.set_defaults(func=_fit)

    mt = sub.add_parser(
        "material", help="raw multi-temperature DMA -> shift factors, WLF, master curve, Prony series, exports",
        description="Read frequency sweeps at several temperatures (CSV: a header row of names, e.g. f, E_stor, "
        "E_loss, T[, Set] or f, G_stor, G_loss, T, then a units row or units in the names: Hz|rad/s, "
        "Pa|kPa|MPa|GPa, C|K), fit the shift factors, WLF and Arrhenius laws (95 %% intervals), build the master "
        "curve at the reference temperature and fit a Prony series to it. Writes material.json and material.csv "
        "(for jaxroll map), material_abaqus.inp (*VISCOELASTIC, TIME=PRONY; *TRS WLF), material_ansys.mac "
        "(TB,PRONY; TB,SHIFT WLF), shift_factors.csv, master_curve.csv, master_curve.png, shift_factors.png and "
        "material_report.txt into --out. Units SI (Pa, s, K).")
    mt.add_argument("dma", help="DMA CSV (frequency sweeps at several temperatures)")
    mt.add_argument("--poisson", type=_poisson("--poisson"), default=0.5,
                    help="Poisson's ratio converting tensile moduli E to shear, G = E / (2 (1 + nu)); unused for "
                    "shear data (0.5)")
    mt.add_argument("--T-ref", dest="T_ref", type=_positive("--T-ref [K]"), default=None,
                    help="reference temperature [K]: the set nearest to it is the reference (default: the set "
                    "nearest the middle of the measured range)")
    mt.add_argument("--shift-moduli", dest="shift_moduli", choices=["storage", "loss", "both"], default="storage",
                    help="moduli compared when shifting the sets (storage: robust to loss artifacts such as an "
                    "upturn at the top frequency)")
    mt.add_argument("--prony-terms", dest="prony_terms", type=_count("--prony-terms"), default=None,
                    help="relaxation times before pruning (default: one per decade of the master curve, plus one)")
    mt.add_argument("--drop-loss-artifacts", dest="drop_loss_artifacts", action="store_true",
                    help="leave out of the Prony fit the loss values at a measured frequency where the loss turns "
                    "up in most sets (jaxroll.loss_artifacts: its second difference along each sweep above 4 robust "
                    "standard deviations in >= 3/4 of the sets; the shipped file's 100 Hz); always reported")
    mt.add_argument("--fe-poisson", dest="fe_poisson", type=_poisson("--fe-poisson", incompressible=False),
                    default=0.49, help="instantaneous Poisson's ratio written to the Abaqus/ANSYS files (< 0.5; 0.49)")
    _progress_args(mt, False)
    mt.add_argument("--out", default="jaxroll-material", help="output folder (jaxroll-material)")
    mt.set_defaults(func=_material_cmd)

    mp = sub.add_parser(
        "map", help="R_r over temperature x speed for a fitted material, with dR/dT and dR/dH (CSV and heat maps)",
        description="Rolling resistance of a rigid sphere or cylinder on a layer of a material written by "
        "jaxroll material (its Prony series and shift law), over temperature x speed, with dR_r/dT and dR_r/dH "
        "from jax.grad, all points in one compiled program. Writes map.csv (temperature, speed, "
        "rolling_resistance, dR_dT, dR_dH, valid, result) and map.png (heat maps with contours) into --out. "
        "Units SI (m, N or N/m, K, m/s).")
    mp.add_argument("--material", required=True, help="material.json (or material.csv) written by jaxroll material")
    mp.add_argument("--geometry", choices=["sphere", "cylinder"], default="sphere")
    mp.add_argument("--radius", type=_positive("--radius [m]"), default=0.01, help="roller radius [m] (0.01)")
    mp.add_argument("--load", type=_positive("--load [N or N/m]"), default=None,
                    help="load [N; N/m for cylinders] (default 10 N for a sphere, 1e4 N/m for a cylinder)")
    mp.add_argument("--H", type=_positive("--H [m]"), default=0.01, help="layer thickness [m] (0.01)")
    mp.add_argument("--rho", type=_nonnegative("--rho [kg/m^3]"), default=0.0,
                    help="layer density [kg/m^3] (default 0: no inertia)")
    mp.add_argument("--nu", type=_poisson("--nu"), default=0.5,
                    help="layer Poisson's ratio (0.5; below 0.5 the quasi-static compressible layer, --rho 0)")
    mp.add_argument("--tmin", type=_positive("--tmin [K]"), default=None,
                    help="lowest temperature [K] (default: the material's lowest measured temperature)")
    mp.add_argument("--tmax", type=_positive("--tmax [K]"), default=None,
                    help="highest temperature [K] (default: the material's highest measured temperature)")
    mp.add_argument("--n-temperatures", dest="n_temperatures", type=_count("--n-temperatures"), default=25,
                    help="number of temperatures (25)")
    mp.add_argument("--vmin", type=_positive("--vmin [m/s]"), default=1e-3, help="lowest speed [m/s] (1e-3)")
    mp.add_argument("--vmax", type=_positive("--vmax [m/s]"), default=10.0, help="highest speed [m/s] (10)")
    mp.add_argument("--n-speeds", dest="n_speeds", type=_count("--n-speeds"), default=25,
                    help="number of log-spaced speeds (25)")
    _method_args(mp, default="direct: milliseconds per point with both gradients for a measured Prony spectrum; "
                 "the full and slice models take it too, on an infinite layer, at 10-100 ms per point")
    mp.set_defaults(method="direct")
    _progress_args(mp, None)
    mp.add_argument("--out", default="jaxroll-map", help="output folder (jaxroll-map)")
    mp.set_defaults(func=_map_cmd)

    from .reproduce import ALL_METHODS, CASES

    r = sub.add_parser(
        "reproduce", help="the paper's examples: PD / PP / SP / direct against the full 3D model, timing table",
        description="Reproduce [ZG]'s examples (sphere R = 2 cm on H = 2, 5, 30 mm; R = 2000 m on H = 10 um; "
        "G0 = 3 MPa, tau = 0.25 s, f = 1; 23 speeds 1e-4..1 m/s x 15 loads 10..150 N, 0.2..2 kN for 10 um): "
        "R_r against V per load for each method against the full 3D model (period 0.2 m, 0.25 mm cells, "
        "500 terms), the relative error against V and P, and a timing table in the form of the paper's "
        "Table 1 measured on this machine (compile time apart). Writes PNG figures, report.md, results.csv "
        "and timing.csv into --out. Units SI (m, N, Pa, s). The full run is the paper's resolution (its "
        "measured time on 2 CPU cores is in benchmarks/README.md); --quick is a reduced run for a first look.")
    r.add_argument("--quick", action="store_true",
                   help="reduced run: 7 speeds x 3 loads, 3D cells 0.5 mm / 250 terms, slices on 512 cells")
    r.add_argument("--out", default="jaxroll-reproduce", help="output folder (jaxroll-reproduce)")
    r.add_argument("--cases", type=_choices("--cases", tuple(CASES)), default=None,
                   help=f"comma-separated subset of {','.join(CASES)} (default: all)")
    r.add_argument("--methods", type=_choices("--methods", ALL_METHODS), default=None,
                   help=f"comma-separated subset of {','.join(ALL_METHODS)} (default: all; the full 3D "
                   "reference always runs)")
    r.add_argument("--speeds", type=_count("--speeds"), default=None, help="number of log-spaced speeds (23; quick 7)")
    r.add_argument("--loads", type=_count("--loads"), default=None, help="number of loads per case (15; quick 3)")
    _progress_args(r, True)
    r.set_defaults(func=_reproduce)
    return p


def _choices(kind, allowed):
    def parse(text):
        vals = tuple(x.strip() for x in text.split(",") if x.strip())
        bad = [v for v in vals if v not in allowed]
        if bad or not vals:
            raise argparse.ArgumentTypeError(f"{kind}: unknown {bad or text!r}; choose from {','.join(allowed)}")
        return vals

    return parse


def _count(kind):
    def parse(text):
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{kind}: expected a whole number, got {text!r}")
        if n < 1:
            raise argparse.ArgumentTypeError(f"{kind}: must be >= 1, got {n}")
        return n

    return parse


def _reproduce(args) -> int:
    from . import reproduce as rp

    over = {}
    if args.speeds is not None:
        over["n_speeds"] = args.speeds
    if args.loads is not None:
        over["n_loads"] = args.loads
    settings = rp.settings_for(args.quick, cases=args.cases, methods=args.methods, **over)
    if over or args.cases or args.methods:
        settings = rp.dataclasses.replace(settings, label=settings.label + " (with command-line selections)")
    t0 = time.perf_counter()
    rep = rp.reproduce(settings, args.out, progress=sys.stderr if args.progress else None)
    print(rp.timing_table(rep))
    print()
    print(rp.accuracy_table(rep))
    print(f"\nwrote {Path(args.out) / 'report.md'} and figures, results.csv, timing.csv "
          f"(wall time {time.perf_counter() - t0:.1f} s)")
    return 0


def _runtime_message(err) -> str:
    """The message of a check that failed inside a compiled program (``eqx.error_if`` surfaces
    as a ``JaxRuntimeError`` wrapping a callback traceback): its first line, or the error's."""
    import re

    m = re.search(r"EquinoxRuntimeError: ([^\n]+)", str(err))
    return m.group(1).strip() if m else str(err).strip().splitlines()[0]


def _cli_terms(message: str) -> str:
    """A library message with its API names replaced by the command-line options."""
    return message.replace("jr.DirectElastic", "--pressure elastic").replace("the full model", "--method full")


def _warn_invalid(codes, where) -> None:
    """One stderr line per reason with the count of points outside their validity."""
    import jaxroll as jr

    codes = np.asarray(codes)
    bad = codes[codes != jr.RESULTS.successful]
    for c in np.unique(bad):
        print(f"jaxroll {where}: warning: {int(np.sum(bad == c))} of {codes.size} points not valid ({jr.RESULTS.names[c]}): "
              f"{_cli_terms(jr.RESULTS.message(c))}; they are marked valid=0 in the CSV", file=sys.stderr)


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
    import jax

    import jaxroll as jr

    try:
        return args.func(args)
    except (ValueError, OSError, jr.SolverError, jax.errors.JaxRuntimeError, eqx.EquinoxRuntimeError) as err:
        if args.debug:
            raise
        if isinstance(err, OSError):  # missing or unreadable input file, unwritable --out
            msg = f"{err.strerror or err}: {err.filename or ''}".rstrip(": ")
        elif isinstance(err, (jax.errors.JaxRuntimeError, eqx.EquinoxRuntimeError)):  # a check inside a compiled program
            msg = _runtime_message(err)
        else:  # bad physical input: one clear line, no traceback
            msg = str(err)
        print(f"jaxroll {args.command}: error: {msg} (--debug for the traceback)", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
