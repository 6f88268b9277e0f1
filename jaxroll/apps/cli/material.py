"""``jaxroll material``: raw multi-temperature DMA -> shift factors, WLF, master curve, Prony series, exports."""

from __future__ import annotations

import math
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ...io import write_table
from .options import count, nonnegative, poisson, positive, progress_args, say


def run(args) -> int:
    import jaxroll as jr
    from jaxroll.apps import plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:  # data warnings go to stderr and the report
        warnings.simplefilter("always", jr.DataWarning)
        f = _fit(args, say(args.progress))
    f.warned = _warnings(caught, f)
    report, info = _report(args, f)
    _write(out, args, f, info)
    plot.close(plot.plot_master_fit(f.master, f.prony, path=out / "master_curve.png"))
    plot.close(plot.plot_shift_factors(f.shifts, {"WLF": f.wlf, "Arrhenius": f.arrhenius},
                                       path=out / "shift_factors.png"))
    (out / "material_report.txt").write_text("\n".join(report) + "\n")
    written = ["material.json", "material.csv", "material_abaqus.inp", "material_ansys.mac", "shift_factors.csv",
               "master_curve.csv", "master_curve.png", "shift_factors.png", "material_report.txt"]
    print("\n".join(report))
    print(f"wrote {', '.join(str(out / w) for w in written)}  ({time.perf_counter() - t0:.1f} s)")
    return 0


def _fit(args, tell) -> SimpleNamespace:
    """Read the sweeps, fit the shift factors, WLF and Arrhenius, build the master curve and fit the
    Prony series (``--phase-sigma`` [deg] converted to the library's radians)."""
    import jaxroll as jr
    from jaxroll.materials import prony

    if args.prony_terms is not None and args.prony_smoothness is not None:
        raise ValueError("--prony-terms selects the fewest-terms fit and --prony-smoothness the smooth one: give one")
    tell(f"material: reading {args.dma}")
    f = SimpleNamespace(sweeps=jr.read_dma_sweeps(args.dma, poisson=args.poisson))
    tell(f"material: shift factors of {f.sweeps.n_sets} temperature sets ({args.shift_moduli} moduli), WLF and "
         "Arrhenius fits")
    f.shifts = jr.fit_shift_factors(f.sweeps, T_ref=args.T_ref, moduli=args.shift_moduli)
    f.wlf, f.arrhenius = jr.fit_wlf(f.shifts, C2=args.wlf_C2), jr.materials.fit_arrhenius(f.shifts)
    f.master = jr.master_curve(f.sweeps, f.shifts)
    f.artifacts = jr.materials.loss_artifacts(f.master)
    f.weights = np.ones((len(f.master.omega), 2))
    if args.drop_loss_artifacts:
        f.weights[f.artifacts, 1] = 0.0
    tell(f"material: Prony fit to {len(f.master.omega)} master-curve points")
    fewest = args.prony_terms is not None
    f.smoothness = None if fewest else args.prony_smoothness or prony.SMOOTHNESS
    sigmas = {"phase_sigma": prony.PHASE_SIGMA if args.phase_sigma is None else math.radians(args.phase_sigma),
              "modulus_sigma": prony.MODULUS_SIGMA if args.modulus_sigma is None else args.modulus_sigma}
    f.prony = jr.fit_prony(f.master, smoothness=f.smoothness, weights=f.weights, **sigmas,
                           **({"n_terms": args.prony_terms} if fewest else {}))
    return f


def _warnings(caught, f) -> list:
    """The data warnings and the shift fits' notes, printed once each to stderr; other warnings
    are issued again."""
    import jaxroll as jr

    warned = [str(w.message) for w in caught if issubclass(w.category, jr.DataWarning)]
    warned += [n if "Arrhenius" in n else f"Arrhenius: {n}" for n in f.arrhenius.notes]
    warned += [n if "WLF" in n else f"WLF: {n}" for n in f.wlf.notes if n not in warned]
    for w in caught:
        if not issubclass(w.category, jr.DataWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    for message in warned:
        print(f"jaxroll material: warning: {message}", file=sys.stderr)
    return warned


def _prony_summary(args, f):
    """``(report lines, info["prony"])`` of the Prony fit: the loss artifacts, the rms per modulus
    and per decade of reduced omega over the values fitted, the error model."""
    pf, master, weights, artifacts = f.prony, f.master, f.weights, f.artifacts
    mat = pf.material
    rms_s, rms_l = (float(np.sqrt(np.mean(pf.residuals[weights[:, k] > 0, k] ** 2))) for k in (0, 1))
    decade = np.floor(np.log10(master.omega)).astype(int)
    per_decade = {int(d): [float(np.sqrt(np.mean(pf.residuals[(decade == d) & (weights[:, k] > 0), k] ** 2)))
                           if np.any((decade == d) & (weights[:, k] > 0)) else None for k in (0, 1)]
                  for d in np.unique(decade)}
    model = ("storage and loss weighed alike (phase_sigma 0)" if pf.phase_sigma == 0 else
             f"phase_sigma {math.degrees(pf.phase_sigma):.4g} deg ({pf.phase_sigma * 1e3:.4g} mrad), modulus_sigma "
             f"{pf.modulus_sigma:.4g}")
    hz = sorted({round(float(w) / (2 * np.pi), 6) for w in master.frequency[artifacts]})
    found = (f"loss artifacts: {int(artifacts.sum())} loss values at {', '.join(f'{v:.4g}' for v in hz)} Hz turn up "
             "in most sets (" + ("left out of the Prony fit)" if args.drop_loss_artifacts else
                                 "kept in the Prony fit; --drop-loss-artifacts leaves them out)")) \
        if artifacts.any() else "loss artifacts: none found"
    lines = [
        found,
        f"Prony: {pf.n_terms} terms, tau {float(np.min(mat.tau)):.3g}..{float(np.max(mat.tau)):.3g} s; rms log "
        f"residual {pf.rms:.4f} of the values fitted (storage {rms_s:.4f}, loss {rms_l:.4f}); G_inf = "
        f"{float(mat.G_inf):.4g} Pa, G_0 = {float(mat.glassy_modulus()):.4g} Pa (shear); error model: {model}",
        "Prony rms log residual per decade of reduced omega [rad/s] (storage/loss): "
        + ", ".join(f"1e{d}: " + "/".join("-" if v is None else f"{v:.3f}" for v in sl) for d, sl in per_decade.items()),
    ]
    info = {"n_terms": pf.n_terms, "smoothness": f.smoothness, "phase_sigma_deg": math.degrees(pf.phase_sigma),
            "rms_log": pf.rms, "rms_log_storage": rms_s, "rms_log_loss": rms_l,
            "rms_log_per_decade": {f"1e{d}": sl for d, sl in per_decade.items()}, "loss_artifacts_hz": hz,
            "loss_artifacts_left_out": bool(args.drop_loss_artifacts and artifacts.any())}
    return lines, info


def _report(args, f):
    """``(report lines, material.json info)``."""
    sw, sh, wlf, arr, master = f.sweeps, f.shifts, f.wlf, f.arrhenius, f.master
    prony_lines, prony_info = _prony_summary(args, f)
    report = [
        f"DMA: {args.dma}: {len(sw.omega)} points in {sw.n_sets} temperature sets, {sw.set_temperature[0]:.2f}.."
        f"{sw.set_temperature[-1]:.2f} K ({sw.source})",
        f"shift factors: T_ref = {sh.T_ref:.2f} K (set {sh.reference}); log10 a_T {sh.log10_aT[0]:+.2f} at "
        f"{sh.temperature[0]:.2f} K .. {sh.log10_aT[-1]:+.2f} at {sh.temperature[-1]:.2f} K; master curve "
        f"{np.log10(master.omega[0]):.1f}..{np.log10(master.omega[-1]):.1f} decades of reduced omega [rad/s]",
        f"WLF: C1 = {wlf.params['C1']:.4g} ({wlf.interval('C1')}), C2 = {wlf.params['C2']:.4g} K "
        f"({wlf.interval('C2')}); rms {wlf.rms:.3f} decades (the law written with the material)",
        f"Arrhenius: E_a = {arr.params['activation_energy']:.4g} J/mol ({arr.interval('activation_energy')}); "
        f"rms {arr.rms:.3f} decades",
        *prony_lines,
    ] + [f"warning: {m}" for m in f.warned]
    info = {"source": str(args.dma), "moduli": sw.source, "temperature_range": [float(sw.set_temperature[0]),
            float(sw.set_temperature[-1])], "reduced_frequency_range": [float(master.omega[0]), float(master.omega[-1])],
            "T_ref": sh.T_ref,
            "WLF": {"C1": wlf.params["C1"], "C2": wlf.params["C2"], "ci95": _ci(wlf), "rms_decades": wlf.rms,
                    "degenerate": wlf.degenerate, "C2_fixed": args.wlf_C2 is not None},
            "Arrhenius": {"activation_energy": arr.params["activation_energy"],
                          "ci95": _ci(arr)["activation_energy"], "rms_decades": arr.rms},
            "warnings": f.warned, "prony": prony_info}
    return report, info


def _write(out, args, f, info) -> None:
    """material.json (with ``info`` and the Prony fit's error model), material.csv, the FE decks,
    shift_factors.csv and master_curve.csv into ``out``."""
    import jaxroll as jr

    mat, sh, sw, master = f.prony.material, f.shifts, f.sweeps, f.master
    jr.save_material(out / "material.json", f.prony, f.wlf.shift, info=info)
    jr.save_material(out / "material.csv", mat, f.wlf.shift)
    jr.materials.write_abaqus(mat, out / "material_abaqus.inp", shift=f.wlf.shift, poisson=args.fe_poisson)
    jr.materials.write_ansys(mat, out / "material_ansys.mac", shift=f.wlf.shift, poisson=args.fe_poisson)
    laws = [np.asarray(fit.shift.log_shift(sh.temperature)) / np.log(10.0) for fit in (f.wlf, f.arrhenius)]
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


def _ci(fit):
    """``{name: [lo, hi]}`` of a shift fit, ``None`` where there is no interval (JSON has no nan)."""
    return {n: None if np.isnan(lo) else [lo, hi] for n, (lo, hi) in fit.ci95.items()}


def add_parser(sub) -> None:
    """The ``material`` subcommand on ``sub`` (argparse subparsers)."""
    mt = sub.add_parser(
        "material", help="raw multi-temperature DMA -> shift factors, WLF, master curve, Prony series, exports",
        description="Read frequency sweeps at several temperatures (CSV: a header row of names, e.g. f, E_stor, "
        "E_loss, T[, Set] or f, G_stor, G_loss, T, then a units row or units in the names: Hz|rad/s, "
        "Pa|kPa|MPa|GPa, C|K; any of UTF-8/UTF-16/cp1252, comma/semicolon/tab, decimal comma; Eplexor, TA TRIOS "
        "and Anton Paar RheoCompass exports; .xls/.xlsx with jaxroll[excel]; see docs/dma.md), fit the shift factors, WLF and Arrhenius laws (95 % intervals), build the master "
        "curve at the reference temperature and fit a Prony series to it. Writes material.json and material.csv "
        "(for jaxroll map), material_abaqus.inp (*VISCOELASTIC, TIME=PRONY; *TRS WLF), material_ansys.mac "
        "(TB,PRONY; TB,SHIFT WLF), shift_factors.csv, master_curve.csv, master_curve.png, shift_factors.png and "
        "material_report.txt into --out. Units SI (Pa, s, K).")
    mt.add_argument("dma", help="DMA file (frequency sweeps at several temperatures)")
    mt.add_argument("--poisson", type=poisson("--poisson"), default=0.5,
                    help="Poisson's ratio converting tensile moduli E to shear, G = E / (2 (1 + nu)); unused for "
                    "shear data (0.5)")
    mt.add_argument("--T-ref", dest="T_ref", type=positive("--T-ref [K]"), default=None,
                    help="reference temperature [K]: the set nearest to it is the reference (default: the set "
                    "nearest the middle of the measured range)")
    mt.add_argument("--wlf-C2", dest="wlf_C2", type=positive("--wlf-C2 [K]"), default=None,
                    help="hold the WLF C2 [K] and fit C1 alone, for data that determine only C1/C2 (the report says "
                    "when: a degenerate fit); universal: 51.6 K + T_ref - T_g")
    mt.add_argument("--shift-moduli", dest="shift_moduli", choices=["storage", "loss", "both"], default="storage",
                    help="moduli compared when shifting the sets (storage: robust to loss artifacts such as an "
                    "upturn at the top frequency)")
    mt.add_argument("--prony-terms", dest="prony_terms", type=count("--prony-terms"), default=None,
                    help="the fewest-terms Prony fit (NNLS + refinement) from this many relaxation times before "
                    "pruning (e.g. one per decade of the master curve, plus one) instead of the smooth spectrum")
    mt.add_argument("--prony-smoothness", dest="prony_smoothness", type=positive("--prony-smoothness"),
                    default=None, help="weight of the smooth spectrum's curvature penalty (3 fixed relaxation times "
                    "per decade; default 3: the loss curve, and the rolling resistance in temperature, without "
                    "ripples from the term spacing)")
    mt.add_argument("--phase-sigma", dest="phase_sigma", type=nonnegative("--phase-sigma [deg]"),
                    default=None, help="absolute error of the instrument's phase angle [deg] "
                    "weighting the Prony fit's loss residuals by 1 / sqrt(modulus_sigma^2 + (phase_sigma / tan "
                    "delta)^2): the loss counts less where tan delta is small, on the glassy and rubbery plateaus "
                    "(default 0: storage and loss weighed alike; e.g. 0.1, an assumed instrument error; the "
                    "library's fit_prony takes radians; docs/dma.md, 'The glassy plateau')")
    mt.add_argument("--modulus-sigma", dest="modulus_sigma", type=positive("--modulus-sigma"),
                    default=None, help="relative error of the instrument's |E*| or |G*| (default 0.01)")
    mt.add_argument("--drop-loss-artifacts", dest="drop_loss_artifacts", action="store_true",
                    help="leave out of the Prony fit the loss values at a measured frequency where the loss turns "
                    "up in most sets (jaxroll.materials.loss_artifacts: its second difference along each sweep above 4 robust "
                    "standard deviations in >= 3/4 of the sets; the shipped file's 100 Hz); always reported")
    mt.add_argument("--fe-poisson", dest="fe_poisson", type=poisson("--fe-poisson", incompressible=False),
                    default=0.49, help="instantaneous Poisson's ratio written to the Abaqus/ANSYS files (< 0.5; 0.49)")
    progress_args(mt)
    mt.add_argument("--out", default="jaxroll-material", help="output folder (jaxroll-material)")
    mt.set_defaults(func=run)
