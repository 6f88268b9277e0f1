"""Generate the identification benchmark sets of jaxroll.datasets (seeded, reproducible):
rolling resistance from the full model with the EXACT discrete contact at twice the default
cells per radius, for fits with the default (coarser, smoothed and extrapolated) model.

* fit_sphere.csv: rigid sphere R = 2 cm on a half-space, standard linear solid G0 = 3 MPa,
  tau = 0.25 s, f = 1; 12 speeds (log-spaced, zeta = V tau / a0 from ~0.3 to ~30, both sides of
  the resistance peak) x 5 loads (50..100 N) = 60 points; jr.Full with
  AutoGrid(cells_per_radius=24) (the default grid rule gives 12 here) and no edge smoothing.
* fit_cylinder.csv: the same for a cylinder (R = 2 cm, 5..10 kN/m) with the 2D full model at
  twice the default cells per half-width.

Noise: 2 % multiplicative Gaussian, numpy default_rng(SEED); ``sigma`` is 2 % of the noise-free
value, so the noise-free value is ``sigma / 0.02`` (benchmarks/fit_coverage.py redraws the noise
from it). The generating model, grid and truth are written as ``#`` lines at the top of each file.

Usage: python fitting/make_fit_benchmark.py [--geometry sphere|cylinder|both] [--out jaxroll/datasets]
"""

import argparse
import time
from pathlib import Path

import jax.numpy as jnp
import numpy as np

import jaxroll as jr

TRUE = dict(G0=3e6, tau=0.25, f=1.0)
R = 0.02
HALF = jr.Layer(H=jnp.inf)
SEED, NOISE = 2027, 0.02
#: loads [N or N/m] and speeds [m/s] of each design: zeta = V tau / a0 ~ 0.3..30 at the middle load
DESIGN = {
    "sphere": dict(loads=np.linspace(50.0, 100.0, 5), speeds=np.logspace(np.log10(6e-3), np.log10(0.6), 12)),
    "cylinder": dict(loads=np.linspace(5e3, 1e4, 5), speeds=np.logspace(np.log10(6e-3), np.log10(0.6), 12)),
}
#: the generating model's cells per radius (twice the default rule's at these zeta)
CELLS = {"sphere": 24, "cylinder": 50}


def generator(geometry):
    """The generating method: the exact discrete contact on the refined automatic grid."""
    return jr.Full(grid=jr.AutoGrid(cells_per_radius=CELLS[geometry]))


def clean_values(geometry):
    """(V, P, noise-free R_r, method) of the design: the table speeds x loads, flattened loads outer."""
    d = DESIGN[geometry]
    mat = jr.StandardLinearSolid(**TRUE)
    method = generator(geometry).resolve(mat, HALF, radius=R, loads=d["loads"], speeds=d["speeds"], geometry=geometry)
    out = jr.rolling_resistance_grid(mat, HALF, radius=R, loads=jnp.asarray(d["loads"]),
                                     speeds=jnp.asarray(d["speeds"]), geometry=geometry, method=method)
    if not np.all(np.asarray(out.result) == 0):
        raise RuntimeError(f"the generating model failed: {sorted(set(np.asarray(out.result).ravel().tolist()))}")
    V, P = (a.ravel() for a in np.meshgrid(d["speeds"], d["loads"]))
    return V, P, np.asarray(out.value).T.ravel(), method


def write(geometry, out):
    t = time.perf_counter()
    V, P, clean, method = clean_values(geometry)
    noisy = clean * (1 + NOISE * np.random.default_rng(SEED).standard_normal(clean.size))
    g = method.grid
    unit = "N" if geometry == "sphere" else "N/m"
    lines = [
        "identification benchmark, fitting/make_fit_benchmark.py",
        f"model: full {'3D' if geometry == 'sphere' else '2D'} model, exact discrete contact (no edge smoothing), "
        f"jr.AutoGrid(cells_per_radius={CELLS[geometry]}) resolved over the design: cell {g.spacing * 1e3:.6g} mm, "
        f"window {g.window} cells, infinite layer",
        f"{geometry} R = {R} m on a half-space, nu = 0.5, quasi-static; standard linear solid "
        f"G0 = {TRUE['G0']:g} Pa, tau = {TRUE['tau']:g} s, f = {TRUE['f']:g} (true values)",
        f"noise: {100 * NOISE:g} % multiplicative Gaussian, numpy default_rng({SEED}); sigma = {100 * NOISE:g} % of the "
        f"noise-free value (noise-free = sigma / {NOISE:g})",
    ]
    columns = {"speed": V.tolist(), "load": P.tolist(), "rolling_resistance": noisy.tolist(),
               "sigma": (NOISE * clean).tolist()}
    path = Path(out) / f"fit_{geometry}.csv"
    jr.io.write_table(path, columns, ["m/s", unit, unit, unit], formats=".10g", comments=lines)
    print(f"{path}: {len(V)} points, {time.perf_counter() - t:.1f} s", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--geometry", default="both", choices=["sphere", "cylinder", "both"])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "jaxroll" / "datasets"))
    args = ap.parse_args()
    for g in (("sphere", "cylinder") if args.geometry == "both" else (args.geometry,)):
        write(g, args.out)


if __name__ == "__main__":
    main()
