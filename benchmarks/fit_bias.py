"""Diagnosis of the default fit's interval coverage, without fitting: the model error at the truth
projected on the parameters.

For the shipped benchmark set (jaxroll/datasets/fit_<geometry>.csv, noise-free values
``sigma / 0.02``) and a fit model on the grid resolved at the TRUE parameters: the weighted model
error ``e = (R_model(truth) - R_clean)/sigma`` and the Jacobian ``J`` (log-parameters). A fit of
noisy data lands, to first order, at ``dp = -(J^T J)^-1 J^T (e + noise)``: the noise gives the
intervals' spread ``sd = sqrt(diag (J^T J)^-1)``, the model error a bias ``b = -(J^T J)^-1 J^T e``.
Honest 95 % intervals then hold the truth with probability ``Phi(1.96 - b/sd) - Phi(-1.96 - b/sd)``.

The model error is also compared with the method's own bound ``truncation`` (relative) and, for the
cylinder, the data with the exact 2D solution.

Run: ``python benchmarks/fit_bias.py [--geometry cylinder|sphere] [--cells 12 25 50]``
(``--cells 0``: the default rule's grid).
"""

import argparse
import time

import jax.numpy as jnp
import numpy as np
from scipy.stats import norm

import jaxroll as jr
from jaxroll.identify.fit import (_data_arrays, _on_ladder, _Params, _Problem, _residuals_and_jacobian_jit,
                                  _resolve_for_fit, read_rolling_csv, RollingData)
from jaxroll.methods import FIT_EDGE_SMOOTHING, default_method

TRUE = {"G0": 3e6, "tau": 0.25, "f": 1.0}
HALF = jr.Layer(H=float("inf"))
R = 0.02


def method_for(cells, geometry, mat, data):
    if cells == 0:
        return _resolve_for_fit(default_method(geometry, fit=True), mat, HALF, R, data, geometry, dense_lines=True)[0]
    auto = jr.Full(grid=jr.AutoGrid(cells_per_radius=cells), edge_smoothing=FIT_EDGE_SMOOTHING,
                   edge_extrapolation=True)
    return _resolve_for_fit(auto, mat, HALF, R, data, geometry, dense_lines=True)[0]


def analyse(geometry, cells):
    data = read_rolling_csv(jr.datasets.path(f"fit_{geometry}.csv"))
    clean = np.asarray(data.sigma) / 0.02
    data = RollingData(data.speed, data.load, clean, data.sigma)
    mat = jr.StandardLinearSolid(**TRUE)
    model = (mat, HALF, None)
    method = method_for(cells, geometry, mat, data)
    params = _Params.of(model, tuple(TRUE), None)
    problem = _Problem.of(params, R, geometry, method, None)
    t = time.process_time()
    r, J = (np.asarray(a) for a in _residuals_and_jacobian_jit(jnp.asarray(params.logp0(model)), model,
                                                                _data_arrays(data, None, method), problem))
    cpu = time.process_time() - t
    cov = np.linalg.inv(J.T @ J)
    sd = np.sqrt(np.diag(cov))
    b = -cov @ J.T @ r
    z = b / sd
    cover = norm.cdf(1.96 - z) - norm.cdf(-1.96 - z)
    proj = float(r @ J @ cov @ J.T @ r)  # chi^2 of the model error that the parameters can absorb
    g = method.grid
    out = jr.rolling_resistance_grid(mat, HALF, radius=R, loads=jnp.unique(jnp.asarray(data.load)),
                                     speeds=jnp.unique(jnp.asarray(data.speed)), geometry=geometry, method=method)
    trunc = np.asarray(out.truncation)
    print(f"{geometry}, grid {'rule' if cells == 0 else cells} cells: spacing {float(g.spacing) * 1e3:.4g} mm, window "
          f"{g.window}; {cpu:.1f} s CPU for r and J")
    print(f"  model error at the truth: rms {np.sqrt(np.mean(r**2)) * 2:.3f} %, max {np.max(np.abs(r)) * 2:.3f} % "
          f"(truncation bound {100 * trunc.min():.2f}..{100 * trunc.max():.2f} %); chi^2 {r @ r:.2f}, "
          f"of it along the parameters {proj:.2f}")
    for n, zi, si, ci in zip(TRUE, z, sd, cover):
        print(f"  {n:>4}: sd {100 * si:.2f} %, bias {100 * zi * si:+.2f} % = {zi:+.2f} sd -> coverage of honest 95 % "
              f"intervals {100 * ci:.0f} %")
    return r, J


def exact_check(geometry):
    if geometry != "cylinder":
        return
    data = read_rolling_csv(jr.datasets.path("fit_cylinder.csv"))
    clean = np.asarray(data.sigma) / 0.02
    ref = np.array([float(jr.reference.exact_cylinder_halfspace(jr.StandardLinearSolid(**TRUE), R, p, v)
                          .rolling_resistance) for v, p in zip(data.speed, data.load)])
    d = clean / ref - 1
    print(f"data (exact contact, 50 cells) against the exact 2D solution: rms {100 * np.sqrt(np.mean(d**2)):.3f} %, "
          f"max {100 * np.max(np.abs(d)):.3f} %")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--geometry", default="cylinder", choices=["sphere", "cylinder"])
    ap.add_argument("--cells", type=int, nargs="*", default=[0])
    args = ap.parse_args()
    exact_check(args.geometry)
    for c in args.cells:
        analyse(args.geometry, c)


if __name__ == "__main__":
    main()
