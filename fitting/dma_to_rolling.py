"""The shipped DMA file end to end: raw sweeps -> shift factors -> WLF -> master curve ->
Prony series -> Abaqus/ANSYS/JSON exports -> rolling-resistance maps (the full model by default;
``--method direct`` for screening: ~88 % below the full model on this material at 25 degC and
1 mm/s with the contact sized by the relaxed modulus, docs/dma.md).

    python fitting/dma_to_rolling.py [--out DIR] [--quick] [--method full|direct]

Case: a rigid steel ball (R = 1 cm, 10 N) and a steel cylinder (R = 1 cm, 10 kN/m) rolling on
a 10 mm cover of the shipped polymer, -20..100 degC x 1e-3..10 m/s (the steel is ~20 x stiffer
than the polymer's glassy shear modulus: rigid roller within a few per cent)."""

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # a script writing files (the library never selects a backend)
import numpy as np  # noqa: E402

import jaxroll as jr  # noqa: E402
from jaxroll.apps import plot  # noqa: E402

DATA = jr.datasets.path("pyvisco_freq_user_raw.csv")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="dma-to-rolling")
    ap.add_argument("--quick", action="store_true", help="coarse maps (7 x 7)")
    ap.add_argument("--method", choices=["full", "direct"], default="full",
                    help="full (the default model) or direct (screening)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sw = jr.read_dma_sweeps(DATA)
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    wlf, arr = jr.fit_wlf(sh), jr.materials.fit_arrhenius(sh)
    master = jr.master_curve(sw, sh)
    t0 = time.perf_counter()
    pf = jr.fit_prony(master)
    print(f"sets {sw.n_sets} ({sw.source}); T_ref = {sh.T_ref:.3f} K")
    print("log10 a_T:", np.array2string(sh.log10_aT, precision=2), "+-", np.array2string(sh.sigma, precision=2))
    for n in ("C1", "C2"):
        lo, hi = wlf.ci95[n]
        print(f"WLF {n} = {wlf.params[n]:.4g} (95 % [{lo:.4g}, {hi:.4g}])")
    print(f"WLF rms {wlf.rms:.3f} decades; Arrhenius E_a = {arr.params['activation_energy']:.4g} J/mol, rms {arr.rms:.3f}")
    print(f"Prony: {pf.n_terms} terms, rms log residual {pf.rms:.4f} (storage {np.sqrt(np.mean(pf.residuals[:, 0]**2)):.4f},"
          f" loss {np.sqrt(np.mean(pf.residuals[:, 1]**2)):.4f}); G_inf = {float(pf.material.G_inf):.4g} Pa, "
          f"G_0 = {float(pf.material.glassy_modulus()):.4g} Pa ({time.perf_counter() - t0:.1f} s)")
    jr.save_material(out / "material.json", pf.material, wlf.shift, info={"source": DATA.name})
    jr.save_material(out / "material.csv", pf.material, wlf.shift)
    jr.materials.write_abaqus(pf.material, out / "material_abaqus.inp", shift=wlf.shift)
    jr.materials.write_ansys(pf.material, out / "material_ansys.mac", shift=wlf.shift)
    plot.close(plot.plot_master_fit(master, pf, path=out / "master_curve.png"))
    n = 7 if args.quick else 25
    Ts, Vs = np.linspace(253.15, 373.15, n), np.logspace(-3, 1, n)
    layer = jr.Layer(H=0.01)
    for geometry, load, unit in (("sphere", 10.0, "N"), ("cylinder", 1e4, "N/m")):
        t0 = time.perf_counter()
        m = jr.resistance_map(pf.material, wlf.shift, layer, radius=0.01, load=load, temperatures=Ts, speeds=Vs,
                              geometry=geometry, method=args.method)
        m.write_csv(out / f"map_{geometry}.csv", unit=unit)
        plot.close(plot.plot_resistance_map(m, unit=unit, title=f"{geometry}, R = 1 cm, {load:g} {unit}, H = 10 mm, "
                                            f"method {args.method}", path=out / f"map_{geometry}.png"))
        print(f"{geometry}: {m.value.size} points, {m.valid.mean() * 100:.0f} % valid, R_r {np.nanmin(m.value):.3g}.."
              f"{np.nanmax(m.value):.3g} {unit}; {m.seconds * 1e3:.2f} ms per point (value + dR/dT + dR/dH, "
              f"compiled), {time.perf_counter() - t0:.1f} s with compilation")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
