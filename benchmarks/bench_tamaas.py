"""jaxroll against a real peer, tamaas (C++ FFT contact, optional extra ``peer``), side by side.

The same problem in both codes: a rigid sphere (R = 2 cm, P = 100 N) pressed on an elastic,
incompressible half-space (G = 3 MPa, so E* = 4 G = 12 MPa), periodic in x and y with period L,
square cells of 0.25 mm (the paper's), solved to a relative tolerance of 1e-10 (jaxroll's default;
tamaas: Polonsky-Keer-Rey, 1e-10 on its residual). jaxroll solves the pressure on a window of
cells around the contact (the periodic compliance restricted to the window); tamaas solves on the
whole period grid. Growing the period at a fixed cell size shows how each scales.

Reported per period: median run time of each code after a warm-up call (jaxroll: the public
front door ``jr.rolling_resistance`` with ``jr.Full(grid=jr.FixedGrid(...))``, compile apart),
the contact area and peak pressure of each, and both against Hertz (the half-space closed form;
both codes are periodic, so both sit slightly stiffer than Hertz as the period shrinks).

    python benchmarks/bench_tamaas.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

import jaxroll as jr
from _timing import summary, timed

R, P, G = 0.02, 100.0, 3e6
E_STAR = 4 * G
CELL = 2.5e-4
TOL = 1e-10


def hertz():
    a = (3 * P * R / (4 * E_STAR)) ** (1 / 3)
    return math.pi * a * a, 3 * P / (2 * math.pi * a * a)


def run_tamaas(L, repeat):
    import tamaas as tm

    tm.set_log_level(tm.LogLevel.warning)
    N = int(round(L / CELL))
    x = (np.arange(N) + 0.5) * CELL - L / 2  # cell centres, contact at the centre
    X, Y = np.meshgrid(x, x, indexing="ij")
    surface = -(X * X + Y * Y) / (2 * R)
    times = []
    for _ in range(repeat + 1):  # the first call is the warm-up
        # a fresh model and solver each time: a solver re-run on its own model starts from the
        # converged pressure (0 iterations), which jaxroll's front door does not do either
        model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [L, L], [N, N])
        model.E, model.nu = 3 * G, 0.5  # plane-strain modulus E/(1 - nu^2) = 4 G
        solver = tm.PolonskyKeerRey(model, surface, TOL)
        t = time.perf_counter()
        solver.solve(P / (L * L))
        times.append(time.perf_counter() - t)
    p = np.array(model.traction, copy=True).reshape(N, N)
    return statistics.median(times[1:]), float(np.sum(p > 0) * CELL * CELL), float(p.max())


def run_jaxroll(L, repeat):
    mat, layer = jr.StandardLinearSolid(G, 1.0, 0.0), jr.Layer(np.inf)  # f = 0: elastic
    a = (3 * P * R / (4 * E_STAR)) ** (1 / 3)
    window = 2 * int(math.ceil(1.25 * a / CELL)) + 1
    method = jr.Full(grid=jr.FixedGrid(CELL, window, period=L), tol=TOL)

    def call():
        return jr.rolling_resistance(mat, layer, radius=R, load=P, speed=0.0, method=method, throw=False)

    first, run, res = timed(call, repeat=repeat)
    p = np.asarray(res.solution.pressure)
    # not valid below L = 20 r_c (0.114 m here): the rolling period rule; irrelevant to this static test
    return run, first - run, float(np.sum(p > 0) * CELL * CELL), float(p.max()), str(res.reasons())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="periods 0.05 and 0.1 m only, 3 repeats")
    args = ap.parse_args()
    periods = [0.05, 0.1] if args.quick else [0.05, 0.1, 0.2, 0.4]
    repeat = 3 if args.quick else 5
    area_h, p0_h = hertz()
    print(f"Hertz: contact area {area_h * 1e6:.3f} mm^2, peak pressure {p0_h / 1e6:.4f} MPa; cell {CELL * 1e3} mm")
    print("| period [m] | cells | tamaas run | jaxroll run (compile) | ratio tamaas/jaxroll | area tamaas / jaxroll "
          "vs Hertz | peak tamaas / jaxroll vs Hertz | area jaxroll/tamaas - 1 |")
    print("|---|---|---|---|---|---|---|---|")
    for L in periods:
        t_tm, area_tm, p_tm = run_tamaas(L, repeat)
        t_jr, compile_jr, area_jr, p_jr, reason = run_jaxroll(L, repeat)
        n = int(round(L / CELL))
        print(f"| {L:g} | {n} x {n} | {t_tm * 1e3:.1f} ms | {t_jr * 1e3:.1f} ms ({compile_jr:.1f} s) | "
              f"{t_tm / t_jr:.2f} | {area_tm / area_h - 1:+.2%} / {area_jr / area_h - 1:+.2%} | "
              f"{p_tm / p0_h - 1:+.2%} / {p_jr / p0_h - 1:+.2%} | {area_jr / area_tm - 1:+.2%} |"
              + ("" if reason == "successful" else f" (jaxroll flag: {reason.split(':')[0]})"), flush=True)
        summary(f"bench_tamaas.py, elastic sphere, L = {L:g} m ({n}^2 cells)", t_jr, compile_jr,
                baseline=f"tamaas {t_tm * 1e3:.1f} ms", ratio=f"{t_tm / t_jr:.1f}x",
                note=f"contact area {area_jr / area_tm - 1:+.2%} vs tamaas")


if __name__ == "__main__":
    main()
