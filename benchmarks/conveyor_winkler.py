"""The conveyor front end against the viscoelastic Winkler foundation, and the cost of its map.

    python benchmarks/conveyor_winkler.py

1. A thin compressible cover (H = 1 mm, nu = 0.3, standard linear solid G0 = 2 MPa,
   tau = 0.01 s, f = 1) under a rigid roll (R = 0.5 m) at the line load that gives the relaxed
   Winkler half-width a0 = 15 H: the full 2D model (``jr.conveyor.indentation_resistance``) on its
   default grid and on 100 cells per a0, against the Winkler-SLS closed form
   (``tests/_oracles.py``, ``winkler_sls``), over V tau / a0 = 0.01 .. 2. Prints the deviations
   (docs/conveyor.md quotes them).
2. ``jr.conveyor.conveyor_map`` of the shipped DMA compound (``dma_example.csv``) on a 6 mm cover,
   159 mm idler, the two line loads of a 1.2 m three-roll trough, 5 temperatures x 2 speeds:
   compile time and time per point (value, dF/dT, dF/dH, dF/dlnG, dF/dlntau).
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))            # run from a checkout without install
sys.path.insert(0, str(ROOT / "tests"))  # the Winkler oracle

import numpy as np  # noqa: E402

import jaxroll as jr  # noqa: E402
from _oracles import winkler_sls  # noqa: E402

from _timing import summary  # noqa: E402


def winkler_table():
    R, H, nu, G0, tau, f = 0.5, 1e-3, 0.3, 2e6, 0.01, 1.0
    k0 = 2 * G0 * (1 - nu) / ((1 - 2 * nu) * H)
    a0 = 15 * H
    P = 2 / 3 * k0 * a0**3 / R
    mat, cover = jr.StandardLinearSolid(G0, tau, f), jr.Layer(H, nu=nu)
    fine = jr.Full(grid=jr.FixedGrid(a0 / 100, 640))
    print("V tau/a0   Winkler F' [N/m]   default grid: dev, valid   a0/100: dev, valid")
    for ca in (0.01, 0.02, 0.05, 0.1, 0.2, 0.67, 2.0):
        V = ca * a0 / tau
        w = winkler_sls(P, R, H, G0, tau, f, nu, V)
        row = []
        for method in (None, fine):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", jr.ValidityWarning)
                r = jr.conveyor.indentation_resistance(mat, cover, diameter=2 * R, line_load=P, speed=V, method=method,
                                                       throw=False)
            row.append(f"{float(r.per_width) / w - 1:+.4%}, {bool(r.valid)}")
        print(f"{ca:8.3g}   {w:16.6g}   {row[0]:>24s}   {row[1]:>18s}", flush=True)


def map_timing():
    sweeps = jr.read_dma_sweeps(jr.datasets.path("dma_example.csv"))
    shifts = jr.fit_shift_factors(sweeps, T_ref=293.15)
    wlf = jr.fit_wlf(shifts)
    cover = jr.fit_prony(jr.master_curve(sweeps, shifts)).material
    trough = jr.conveyor.trough_loads(belt_width=1.2, belt_mass=20.0, bulk_mass=150.0, spacing=1.2,
                                      roll_length=0.465, trough_angle=math.radians(35))
    t = time.perf_counter()
    m = jr.conveyor.conveyor_map(cover, wlf.shift, jr.Layer(0.006), diameter=0.159, line_loads=trough.line_load,
                                 temperatures=np.linspace(273.15, 313.15, 5), speeds=[2.0, 5.0])
    total = time.perf_counter() - t
    compile_s = total - m.seconds * m.per_width.size
    print(f"conveyor_map: {m.per_width.size} points, {m.valid.mean():.0%} valid, {m.seconds * 1e3:.1f} ms per point "
          f"(value and 4 derivatives), compile and set-up {compile_s:.1f} s")
    summary("conveyor_map dma_example 6 mm cover, 5 T x 2 V x 2 loads", m.seconds, compile_s,
            note="full 2D model, per point with dF/dT, dF/dH, dF/dlnG, dF/dlntau")


if __name__ == "__main__":
    import os

    import jax

    print(f"jax {jax.__version__}, {os.cpu_count()} cpus, load average "
          f"{os.getloadavg()[0]:.1f}")
    winkler_table()
    map_timing()
    print(f"load average after {os.getloadavg()[0]:.1f}")
