"""Identification with the defaults: time of one fit of the shipped benchmark set and coverage of
the 95 % intervals over seeded noise draws.

Data: ``jaxroll/datasets/fit_<geometry>.csv`` (fitting/make_fit_benchmark.py: the full model with
the EXACT discrete contact at twice the default cells per radius, 60 points, 2 % noise; truth
G0 = 3 MPa, tau = 0.25 s, f = 1). Fit: ``jr.fit_material`` with every default (the method is
``default_method(geometry, fit=True)``: the smoothed edge extrapolated to kappa -> 0 on a grid
the fit resolves itself), sigma from the file, ``absolute_sigma=True``, start G0 = 2 MPa,
tau = 0.35 s, f = 0.7 (the intervals: profile likelihood, the default for rolling data alone).
``--draws N``: N further fits of the noise-free values (``sigma / 0.02``) with fresh noise (numpy
default_rng(1000 + i)); reports how many of the 3N intervals hold the truth, with the binomial
99 % acceptance range for honest 95 % intervals. ``--diagnose``: per draw, the cost at the fit and
at the truth on the fit's own grid, and the truth's distance in the linearised metric.

Run: ``python benchmarks/fit_coverage.py [--geometry sphere|cylinder] [--draws 30] [--jobs 2] [--diagnose]
[--record]``
(``--record`` stores the figures in benchmarks/numbers.json). Times: wall clock and the process's
CPU time (all threads; on a loaded machine the CPU time is the better measure of the work).
"""

import argparse
import os
import time
import warnings

import numpy as np
from scipy.stats import binom

import jaxroll as jr
from jaxroll.identify.fit import IdentifiabilityWarning, RollingData, fit_material, read_rolling_csv

TRUE = {"G0": 3e6, "tau": 0.25, "f": 1.0}
START = jr.StandardLinearSolid(G0=2e6, tau=0.35, f=0.7)
HALF = jr.Layer(H=float("inf"))
NOISE = 0.02


def fit(data, geometry, progress=False):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)  # the G0-tau-f valley (expected)
        return fit_material(data, initial=START, layer=HALF, radius=0.02, geometry=geometry, absolute_sigma=True,
                            progress=progress)


def cost_at(result, data, geometry, values):
    """``(cost, r)`` of ``values`` ({name: value}) on the grid the fit ended on (``result.method``):
    the fit's own objective, so that it compares with ``result.cost``."""
    import jax.numpy as jnp

    from jaxroll.identify.fit import _data_arrays, _Params, _Problem, _residuals_and_jacobian_jit

    model = (jr.StandardLinearSolid(**values), HALF, None)
    params = _Params.of(model, tuple(TRUE), None)
    problem = _Problem.of(params, 0.02, geometry, result.method, None)
    r, J = _residuals_and_jacobian_jit(jnp.asarray(params.logp0(model)), model,
                                       _data_arrays(data, None, result.method), problem)
    return 0.5 * float(np.sum(np.asarray(r) ** 2)), np.asarray(J)


def diagnose(tag, result, data, geometry):
    """One row of the per-draw diagnosis: the cost at the fit and at the truth on the fit's grid;
    ``2 dC = 2 (C_truth - C_fit)`` (chi^2 with 3 dof for an exact model and an exact optimum: the
    truth is inside every profile-likelihood 95 % interval when 2 dC <= 3.84) against the
    linearised prediction ``d^T J^T J d`` (d = log truth - log fit), and the truth's distance in
    linearised standard errors per parameter."""
    c_truth, _ = cost_at(result, data, geometry, TRUE)
    d = np.log([TRUE[n] for n in TRUE]) - np.log([float(result.params[n]) for n in TRUE])
    J = np.asarray(result.jacobian)
    lin = float(d @ J.T @ J @ d)
    z = d / np.sqrt(np.diag(result.covariance))
    print(f"{tag}: C_fit {result.cost:.3f} C_truth {c_truth:.3f} 2dC {2 * (c_truth - result.cost):+.3f} "
          f"linear {lin:.3f}; z " + " ".join(f"{n} {zi:+.2f}" for n, zi in zip(TRUE, z)) +
          f"; covered {sum(covered(result).values())}/3", flush=True)


def covered(result):
    return {n: bool(result.ci95[n][0] <= TRUE[n] <= result.ci95[n][1]) for n in TRUE}


def show(tag, result, seconds, cpu=None):
    cells = ", ".join(f"{n} {float(result.params[n]):.5g} [{float(result.ci95[n][0]):.4g}, "
                      f"{float(result.ci95[n][1]):.4g}]" for n in TRUE)
    print(f"{tag}: {cells}; chi2/dof {result.reduced_chi2:.3f}; converged {result.converged}; "
          f"{len(result.starts)} run(s); {seconds:.1f} s wall" + ("" if cpu is None else f", {cpu:.1f} s CPU") +
          f"; covered {covered(result)}", flush=True)


def _draw(geometry, i, diagnosis):
    """Fit noise draw ``i`` (numpy default_rng(1000 + i)) of the shipped set: ``(i, covered, lines)``."""
    import contextlib
    import io

    data = read_rolling_csv(jr.datasets.path(f"fit_{geometry}.csv"))
    clean = np.asarray(data.sigma) / NOISE
    y = clean * (1 + NOISE * np.random.default_rng(1000 + i).standard_normal(clean.size))
    noisy = RollingData(data.speed, data.load, y, data.sigma)
    t, c = time.perf_counter(), time.process_time()
    r = fit(noisy, geometry)
    seconds, cpu = time.perf_counter() - t, time.process_time() - c
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        show(f"draw {i}", r, seconds, cpu)
        if diagnosis:
            diagnose(f"diagnosis {i}", r, noisy, geometry)
    return i, covered(r), out.getvalue().rstrip().splitlines()


def _run_draws(geometry, draws, diagnosis, jobs):
    """The draws in this process (``jobs`` 1) or in ``jobs`` spawned worker processes (each compiles
    once), in the order they finish."""
    if jobs <= 1:
        for i in draws:
            yield _draw(geometry, i, diagnosis)
        return
    import concurrent.futures
    import multiprocessing

    with concurrent.futures.ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = [pool.submit(_draw, geometry, i, diagnosis) for i in draws]
        for f in concurrent.futures.as_completed(futures):
            yield f.result()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--geometry", default="sphere", choices=["sphere", "cylinder"])
    ap.add_argument("--draws", type=int, default=0)
    ap.add_argument("--first-draw", type=int, default=0, help="the first draw's index (to split the draws "
                    "over processes)")
    ap.add_argument("--draws-only", action="store_true", help="skip the two fits of the shipped set")
    ap.add_argument("--record", action="store_true")
    ap.add_argument("--diagnose", action="store_true", help="per draw: cost at the fit and at the truth on the "
                    "fit's grid, and the truth's distance in linearised standard errors")
    ap.add_argument("--progress", action="store_true", help="one line per evaluation of the first fit")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes for the draws (spawned; each compiles "
                    "the fit once)")
    args = ap.parse_args()
    g = args.geometry
    data = read_rolling_csv(jr.datasets.path(f"fit_{g}.csv"))
    load = os.getloadavg()[0]
    if not args.draws_only:
        t, c = time.perf_counter(), time.process_time()
        first = fit(data, g, args.progress)
        t_first, c_first = time.perf_counter() - t, time.process_time() - c
        show(f"shipped fit_{g}.csv (first fit, compile included; load average {load:.1f} before, "
             f"{os.getloadavg()[0]:.1f} after)", first, t_first, c_first)
        t, c = time.perf_counter(), time.process_time()
        again = fit(data, g)
        show("the same fit again (compiled)", again, time.perf_counter() - t, time.process_time() - c)
    if args.draws:
        hits, total, per = 0, 0, dict.fromkeys(TRUE, 0)
        t = time.perf_counter()
        for i, c, lines in _run_draws(g, range(args.first_draw, args.first_draw + args.draws), args.diagnose,
                                      args.jobs):
            for n in c:
                per[n] += c[n]
            hits, total = hits + sum(c.values()), total + len(c)
            print(f"[{time.perf_counter() - t:.0f} s] " + "\n".join(lines), flush=True)
        # the three parameters miss together (they lie along one valley): the draws are the
        # independent trials, so each parameter's count is compared with Binomial(draws, 0.95)
        lo, hi = binom.ppf(0.005, args.draws, 0.95), binom.ppf(0.995, args.draws, 0.95)
        print(f"coverage: {hits}/{total} = {hits / total:.3f} (per parameter {per} of {args.draws}); honest 95 % "
              f"intervals give {lo:.0f}..{hi:.0f} per parameter with 99 % probability; "
              f"{time.perf_counter() - t:.0f} s, load average "
              f"{os.getloadavg()[0]:.1f}")
    if args.record and not args.draws_only:
        from _numbers import record

        record(f"fit_{g}", {"first_fit_s": round(t_first, 1), "first_fit_cpu_s": round(c_first, 1),
                             "load_average": round(load, 1),
                             "params": {n: float(first.params[n]) for n in TRUE},
                             "ci95": {n: [float(x) for x in first.ci95[n]] for n in TRUE},
                             **({"coverage": [hits, total], "coverage_per_parameter": per, "draws": args.draws}
                                if args.draws else {})})


if __name__ == "__main__":
    main()
