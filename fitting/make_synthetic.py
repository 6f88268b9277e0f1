"""Generate the example identification data sets of jaxroll.datasets (jaxroll/datasets/; seeded, reproducible).

* synthetic_sphere.csv: rolling resistance of a rigid sphere (R = 2 cm) on a 30 mm quasi-static
  incompressible cover (rho = 0) of a standard linear solid (G0 = 3 MPa, tau = 0.25 s, f = 1),
  12 speeds (1e-4..1 m/s, log-spaced) x 5 loads (10..150 N) = 60 points, computed with the
  FULL 3D rolling-contact model (jr.Full through jr.rolling_resistance_grid) at the paper's
  resolution (period L = 0.2 m, cell a = 0.25 mm, 500 Fourier terms per axis, pressure window
  55 x 55 cells) with the smoothed contact edge (edge_smoothing = 0.25, so that a fit with the
  same model sees a smooth R_r; benchmarks/LOG.md, the fitting guide's history), with 2 %
  multiplicative Gaussian noise (numpy default_rng(2026)); the sigma
  column is 2 % of the noise-free value. ``--method direct`` writes the direct-method
  version instead (seconds; for comparison only).
* dma_example.csv + rolling_example.csv: a joint DMA + rolling example: DMA at 3 temperatures
  (WLF C1 = 8.86, C2 = 101.6 K, T_ref = 293.15 K) and rolling resistance at T_ref (direct
  method), 1 % noise.

The generating model, resolution, seed and true parameters are also written as ``#`` comment
lines at the top of synthetic_sphere.csv (jaxroll.identify.fit.read_rolling_csv skips them).

Usage: python fitting/make_synthetic.py [--method full|direct] [--spacing 2.5e-4] [--out jaxroll/datasets]
"""

import argparse
import math
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr

TRUE = dict(G0=3e6, tau=0.25, f=1.0)
R, H, RHO = 0.02, 0.03, 0.0
SPEEDS = np.logspace(-4, 0, 12)
LOADS = np.linspace(10.0, 150.0, 5)
SEED, NOISE = 2026, 0.02
#: the paper's resolution ([ZG] sec. 2 / docs/design.md sec. 3)
PERIOD, SPACING, N_TERMS = 0.2, 2.5e-4, 500
#: smoothed contact edge of the full model (``jr.Full(edge_smoothing=...)``): makes
#: R_r a smooth function of (G0, tau, f) so that least-squares fits with the same model converge
EDGE_SMOOTHING = 0.25


def full_method(spacing=SPACING, period=PERIOD, n_terms=None, edge_smoothing=EDGE_SMOOTHING):
    """The full 3D model used for the shipped set: a fixed grid with a window wide enough for the
    largest contact (radius estimate x 1.15, at least 41 cells as in the paper), and the smoothed
    contact edge."""
    mat = jr.StandardLinearSolid(**TRUE)
    r_max = float(jr.engines.contact_size.estimate_contact_size(mat, jr.Layer(H=H, rho=RHO), R, float(LOADS.max())))
    window = max(41 if spacing <= SPACING else 3, 2 * math.ceil(1.15 * r_max / spacing) + 1)
    n_terms = n_terms if n_terms is not None else (N_TERMS if spacing == SPACING else round(period / spacing) // 2 * 2)
    return jr.Full(grid=jr.FixedGrid(spacing, window, period=period, n_terms=n_terms), edge_smoothing=edge_smoothing)


def full_grid(material, layer, speeds, loads, method):
    """Full 3D R_r [N] on speeds x loads (one kernel per speed; loads warm-started)."""
    out = jr.rolling_resistance_grid(material, layer, radius=R, loads=jnp.asarray(loads), speeds=jnp.asarray(speeds),
                                     method=method)
    st = np.asarray(out.result)
    # the paper's 0.2 m period is short at the highest speeds (V tau > L/20): that is the model the
    # set is made with (flagged period_too_short); any other reason is a failure
    bad = (st != 0) & (st != jr.RESULTS.period_too_short)
    if np.any(bad):
        raise RuntimeError(f"full model failed at {int(np.sum(bad))} points "
                           f"({sorted({jr.RESULTS.names[int(c)] for c in st[bad]})})")
    return np.asarray(out.value)  # (n_speeds, n_loads)


def _write(path, header, units, rows, comments=()):
    """A CSV with LF line ends, 8 significant digits (jaxroll.io.write_table)."""
    columns = [list(c) for c in zip(*rows)]
    jr.io.write_table(path, dict(zip(header, columns)), units, formats=".8g", comments=comments)


def rolling_grid(method, speeds, loads, rho=RHO):
    mat = jr.StandardLinearSolid(**TRUE)
    layer = jr.Layer(H=H, rho=rho)
    V, P = np.meshgrid(speeds, loads)

    def one(v, p):
        return jr.rolling_resistance(mat, layer, radius=R, load=p, speed=v, geometry="sphere", method=method,
                                     throw=False).value

    vals = jax.lax.map(lambda vp: one(vp[0], vp[1]), (jnp.asarray(V.ravel()), jnp.asarray(P.ravel())))
    return V.ravel(), P.ravel(), np.asarray(vals)


def synthetic_sphere(method="full", spacing=SPACING, rng=None):
    """(V, P, noisy R_r, sigma, clean R_r, description lines) of the shipped synthetic set."""
    rng = np.random.default_rng(SEED) if rng is None else rng
    if method == "full":
        m = full_method(spacing)
        clean = full_grid(jr.StandardLinearSolid(**TRUE), jr.Layer(H=H, rho=RHO), SPEEDS, LOADS, m).T.ravel()
        V, P = (a.ravel() for a in np.meshgrid(SPEEDS, LOADS))
        how = (f"full 3D model (jr.Full through jr.rolling_resistance_grid), period {m.grid.period[0]:g} m, cell "
               f"{m.grid.spacing * 1e3:g} mm, {m.grid.terms()} Fourier terms, window {m.grid.window} cells, "
               f"edge_smoothing {m.edge_smoothing:g}")
    else:
        V, P, clean = rolling_grid(method, SPEEDS, LOADS)
        how = f"method={method!r} of jaxroll.rolling_resistance"
    noisy = clean * (1 + NOISE * rng.standard_normal(clean.size))
    lines = [
        "synthetic rolling resistance, fitting/make_synthetic.py",
        f"model: {how}",
        f"sphere R = {R} m on a layer H = {H} m, rho = {RHO:g}, nu = 0.5; standard linear solid "
        f"G0 = {TRUE['G0']:g} Pa, tau = {TRUE['tau']:g} s, f = {TRUE['f']:g} (true values)",
        f"noise: {100 * NOISE:g} % multiplicative Gaussian, numpy default_rng({SEED}); sigma = {100 * NOISE:g} % of the noise-free value",
    ]
    return V, P, noisy, NOISE * clean, clean, lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="full")
    ap.add_argument("--spacing", type=float, default=SPACING, help="full model cell size [m] (paper 2.5e-4)")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "jaxroll" / "datasets"),
                    help="output folder (default: the package's jaxroll/datasets/)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    t = time.perf_counter()
    rng = np.random.default_rng(SEED)
    V, P, noisy, sig, _, lines = synthetic_sphere(args.method, args.spacing, rng)
    _write(out / "synthetic_sphere.csv", ["speed", "load", "rolling_resistance", "sigma"], ["m/s", "N", "N", "N"],
           zip(V, P, noisy, sig), comments=lines)
    print(f"synthetic_sphere.csv ({args.method}): {time.perf_counter() - t:.1f} s")

    # joint DMA + rolling example (the same random stream, continued)
    wlf = jr.WLF(C1=8.86, C2=101.6, T_ref=293.15)
    mat = jr.StandardLinearSolid(**TRUE)
    w = np.logspace(-1, 2, 10) * 2 * np.pi
    rows = []
    for T in (273.15, 293.15, 313.15):
        g = np.asarray(jr.complex_modulus(jr.at_temperature(mat, wlf, T), w))
        for wi, gi in zip(w, g):
            rows.append((wi / (2 * np.pi), gi.real * (1 + 0.01 * rng.standard_normal()) / 1e6,
                         gi.imag * (1 + 0.01 * rng.standard_normal()) / 1e6, T - 273.15))
    _write(out / "dma_example.csv", ["frequency", "storage_modulus", "loss_modulus", "temperature"],
           ["Hz", "MPa", "MPa", "degC"], rows)
    V, P, val = rolling_grid("direct", np.logspace(-3, -1, 6), np.array([50.0, 100.0]), rho=1000.0)
    noisy = val * (1 + 0.01 * rng.standard_normal(val.size))
    _write(out / "rolling_example.csv", ["speed", "load", "rolling_resistance"], ["m/s", "N", "N"], zip(V, P, noisy))
    print(f"wrote {out}/synthetic_sphere.csv ({args.method}), dma_example.csv, rolling_example.csv")


if __name__ == "__main__":
    main()
