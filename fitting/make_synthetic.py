"""Generate the example identification data sets in fitting/data/ (seeded, reproducible).

* synthetic_sphere.csv: rolling resistance of a steel sphere (R = 2 cm) on a 30 mm cover
  (G0 = 3 MPa, tau = 0.25 s, f = 1), 12 speeds x 5 loads, computed with the method given by
  --method (default "full": the full 3D model; "direct" is much faster), with 2 % multiplicative
  Gaussian noise (seed 2026).
* dma_example.csv + rolling_example.csv: a joint DMA + rolling example: DMA at 3 temperatures
  (WLF C1 = 8.86, C2 = 101.6 K, T_ref = 293.15 K) and rolling resistance at T_ref, 1 % noise.

Usage: python fitting/make_synthetic.py [--method full|direct] [--out fitting/data]
"""

import argparse
import csv
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr

TRUE = dict(G0=3e6, tau=0.25, f=1.0)
R, H, RHO = 0.02, 0.03, 1000.0


def _write(path, header, units, rows):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerow(units)
        for r in rows:
            w.writerow([f"{x:.8g}" for x in r])


def rolling_grid(method, speeds, loads):
    mat = jr.StandardLinearSolid(**TRUE)
    layer = jr.Layer(H=H, rho=RHO)
    V, P = np.meshgrid(speeds, loads)

    def one(v, p):
        return jr.rolling_resistance(mat, layer, radius=R, load=p, speed=v, geometry="sphere", method=method).value

    vals = jax.lax.map(lambda vp: one(vp[0], vp[1]), (jnp.asarray(V.ravel()), jnp.asarray(P.ravel())))
    return V.ravel(), P.ravel(), np.asarray(vals)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="full")
    ap.add_argument("--out", default=str(Path(__file__).parent / "data"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(2026)

    speeds = np.logspace(-4, 0, 12)
    loads = np.linspace(10.0, 150.0, 5)
    V, P, val = rolling_grid(args.method, speeds, loads)
    noisy = val * (1 + 0.02 * rng.standard_normal(val.size))
    _write(out / "synthetic_sphere.csv", ["speed", "load", "rolling_resistance", "sigma"], ["m/s", "N", "N", "N"],
           zip(V, P, noisy, 0.02 * val))

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
    speeds = np.logspace(-3, -1, 6)
    V, P, val = rolling_grid("direct", speeds, np.array([50.0, 100.0]))
    noisy = val * (1 + 0.01 * rng.standard_normal(val.size))
    _write(out / "rolling_example.csv", ["speed", "load", "rolling_resistance"], ["m/s", "N", "N"], zip(V, P, noisy))
    print(f"wrote {out}/synthetic_sphere.csv ({args.method}), dma_example.csv, rolling_example.csv")


if __name__ == "__main__":
    main()
