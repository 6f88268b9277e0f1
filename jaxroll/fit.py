"""Material identification from measured rolling resistance and/or DMA data.

Weighted least squares in log-parameters (positivity built in), solved by a damped
Levenberg-Marquardt iteration in log-parameters (default, ``solver="lm"``) or optax L-BFGS, with multi-start, optional bounds and
Gauss-Newton uncertainty (covariance, standard errors, 95 % intervals, correlations).

Residuals, stacked over the data sets supplied:

* rolling resistance: ``(R_model - R_meas)/sigma`` with ``R_model`` from
  :func:`jaxroll.rolling_resistance` (any method; the per-point model is vmapped);
  ``sigma`` defaults to ``|R_meas|`` (relative residuals);
* DMA: ``(G'_model - G'_meas)/sigma'`` and ``(G''_model - G''_meas)/sigma''`` at each frequency
  (and temperature, through a WLF/Arrhenius shift), relative by default.

Uncertainty: ``cov(log p) = s^2 (J^T J)^{-1}`` with ``J`` the Jacobian of the residuals with
respect to the log-parameters at the optimum, ``s^2 = chi^2/(n - k)`` unless
``absolute_sigma=True`` (``s = 1``); ``stderr(p) = p sqrt(cov_ii)`` (delta method) and the 95 %
interval ``exp(log p +- 1.96 sqrt(cov_ii))`` (asymmetric, positive).
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._numerics import as_float
from .io import UNITS, Column, DataWarning, read_table
from .material import GeneralizedMaxwell, StandardLinearSolid, at_temperature, complex_modulus

__all__ = [
    "DMAData",
    "RollingData",
    "FitResult",
    "IdentifiabilityWarning",
    "clear_cache",
    "fit_material",
    "read_dma_csv",
    "read_rolling_csv",
]

Z95 = 1.959963984540054


class IdentifiabilityWarning(UserWarning):
    """The data do not constrain a parameter (large relative error or near-total correlation)."""


class MisfitWarning(UserWarning):
    """With measured sigma, the residuals are far larger than the errors: model error (or sigma
    too small)."""


# ----------------------------------------------------------------------------------------
# data


@dataclasses.dataclass(frozen=True)
class RollingData:
    """Rolling-resistance measurements, SI: speed [m/s], load [N or N/m], value [N or N/m],
    optional sigma (same unit as value)."""

    speed: np.ndarray
    load: np.ndarray
    value: np.ndarray
    sigma: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.speed)
        for name in ("load", "value"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"RollingData: {name} has {len(getattr(self, name))} entries, speed has {n}")
        _check_array("speed", self.speed, positive=True)
        _check_array("load", self.load, positive=True)
        _check_array("rolling resistance", self.value, positive=True)
        if self.sigma is not None:
            _check_array("sigma", self.sigma, positive=True)


@dataclasses.dataclass(frozen=True)
class DMAData:
    """Dynamic mechanical analysis data, SI: angular frequency omega [rad/s], storage and loss
    shear moduli [Pa], optional temperature [K] (then a shift is needed to fit)."""

    omega: np.ndarray
    storage: np.ndarray
    loss: np.ndarray
    temperature: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.omega)
        for name in ("storage", "loss"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"DMAData: {name} has {len(getattr(self, name))} entries, omega has {n}")
        _check_array("frequency", self.omega, positive=True)
        _check_array("storage modulus", self.storage, positive=True)
        _check_array("loss modulus", self.loss, positive=True)
        if self.temperature is not None:
            _check_array("temperature", self.temperature, positive=True)


def _check_array(name, x, positive):
    x = np.asarray(x, dtype=float)
    bad = ~np.isfinite(x) | ((x <= 0) if positive else False)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(f"{name}: entry {i} is {x[i]!r}; values must be finite" + (" and positive" if positive else ""))


def _rolling_columns():
    force = {**UNITS["force"], **UNITS["line_force"]}
    return [Column("speed", UNITS["speed"], positive=True), Column("load", force, positive=True),
            Column("rolling_resistance", force, positive=True), Column("sigma", force, required=False, positive=True)]


def _dma_columns():
    return [Column("frequency", UNITS["frequency"], positive=True),
            Column("storage_modulus", UNITS["modulus"], positive=True),
            Column("loss_modulus", UNITS["modulus"], positive=True),
            Column("temperature", UNITS["temperature"], required=False, positive=True)]


def read_rolling_csv(path) -> RollingData:
    """Read rolling-resistance data: columns ``speed``, ``load``, ``rolling_resistance``
    (optional ``sigma``); second row units (``m/s``/``mm/s``/``km/h``; ``N``/``kN``/``N/m``;
    ``N``/``mN``...)."""
    t = read_table(path, _rolling_columns(), kind="rolling-resistance")
    _warn_repeated(path, np.stack([t["speed"], t["load"]], axis=1), "(speed, load)")
    return RollingData(t["speed"], t["load"], t["rolling_resistance"], t.get("sigma"))


def _warn_repeated(path, keys, what):
    """Warn about repeated measurement points (fitted as independent measurements)."""
    _, counts = np.unique(keys, axis=0, return_counts=True)
    n = int(np.sum(counts[counts > 1]))
    if n:
        warnings.warn(f"{path}: {n} rows share their {what} with another row; they are fitted as independent "
                      f"measurements (average them, or give sigma, if they are repeats)", DataWarning, stacklevel=3)


def read_dma_csv(path) -> DMAData:
    """Read DMA data: columns ``frequency`` (``Hz`` or ``rad/s``), ``storage_modulus`` and
    ``loss_modulus`` (``Pa``/``kPa``/``MPa``/``GPa``), optional ``temperature`` (``K`` or
    ``degC``); second row units."""
    t = read_table(path, _dma_columns(), kind="DMA")
    keys = [t["frequency"]] + ([t["temperature"]] if "temperature" in t else [])
    _warn_repeated(path, np.stack(keys, axis=1), "(frequency, temperature)" if len(keys) > 1 else "frequency")
    return DMAData(t["frequency"], t["storage_modulus"], t["loss_modulus"], t.get("temperature"))


# ----------------------------------------------------------------------------------------
# parameters <-> log vector


#: The parameters of each material: the default free list of :func:`fit_material`.
_DEFAULT_FREE = {StandardLinearSolid: ("G0", "tau", "f"), GeneralizedMaxwell: ("G_inf", "G", "tau")}


def _get(model, name):
    material, layer, shift = model
    if name == "H":
        return layer.H
    if name in ("C1", "C2"):
        if shift is None:
            raise ValueError(f"free parameter {name!r} needs a WLF shift (shift=jr.WLF(...))")
        return getattr(shift, name)
    if not hasattr(material, name):
        fields = _DEFAULT_FREE.get(type(material), ())
        raise ValueError(f"free parameter {name!r} is not a field of {type(material).__name__}; its parameters are "
                         f"{', '.join(fields)} (plus H, and C1, C2 of a WLF shift)")
    return getattr(material, name)


def _where(model, name):
    if name == "H":
        return lambda m: m[1].H
    if name in ("C1", "C2"):
        return lambda m: getattr(m[2], name)
    return lambda m: getattr(m[0], name)


class _Params:
    """Maps the free physical parameters to an unconstrained vector and back.

    Unbounded: ``u = log p``. Bounded ``(lo, hi)``: ``log p = log lo + (log hi - log lo)
    sigmoid(u)``."""

    def __init__(self, model, free, bounds):
        self.model = model
        self.free = tuple(free)
        self.shapes = [jnp.shape(_get(model, n)) for n in self.free]
        self.sizes = [int(np.prod(s)) for s in self.shapes]
        bounds = dict(bounds or {})
        unknown = set(bounds) - set(self.free)
        if unknown:
            raise ValueError(f"bounds given for parameters that are not free: {sorted(unknown)}")
        self.lo = []
        self.hi = []
        for n, size in zip(self.free, self.sizes):
            lo, hi = bounds.get(n, (None, None))
            if lo is not None and not (0 < lo < hi):
                raise ValueError(f"bounds for {n!r} must satisfy 0 < lo < hi, got {(lo, hi)}")
            self.lo.append(None if lo is None else math.log(lo))
            self.hi.append(None if hi is None else math.log(hi))
        for n in self.free:
            v = np.asarray(_get(model, n))
            if np.any(v <= 0):
                raise ValueError(f"initial value of {n!r} must be positive for a log-parameter fit, got {v}")

    @property
    def size(self):
        return sum(self.sizes)

    def split(self, vec):
        out, i = [], 0
        for shape, size in zip(self.shapes, self.sizes):
            out.append(jnp.reshape(vec[i : i + size], shape))
            i += size
        return out

    def logp_from_u(self, u):
        parts = []
        for piece, lo, hi in zip(self.split(u), self.lo, self.hi):
            parts.append(piece if lo is None else lo + (hi - lo) * jax.nn.sigmoid(piece))
        return jnp.concatenate([jnp.ravel(p) for p in parts])

    def u_from_logp(self, logp):
        parts = []
        for piece, lo, hi in zip(self.split(logp), self.lo, self.hi):
            if lo is None:
                parts.append(piece)
            else:
                t = jnp.clip((piece - lo) / (hi - lo), 1e-9, 1 - 1e-9)
                parts.append(jnp.log(t) - jnp.log1p(-t))
        return jnp.concatenate([jnp.ravel(p) for p in parts])

    def logp_and_slope(self, u):
        """Host-side (numpy) ``log p(u)`` and the diagonal ``d log p / d u``."""
        u = np.asarray(u, float)
        logp, slope = u.copy(), np.ones_like(u)
        i = 0
        for size, lo, hi in zip(self.sizes, self.lo, self.hi):
            if lo is not None:
                s = 0.5 * (1.0 + np.tanh(0.5 * u[i : i + size]))  # sigmoid without overflow
                logp[i : i + size] = lo + (hi - lo) * s
                slope[i : i + size] = (hi - lo) * s * (1.0 - s)
            i += size
        return logp, slope

    def logp0(self):
        return jnp.concatenate([jnp.ravel(jnp.log(as_float(_get(self.model, n)))) for n in self.free])

    def build(self, logp, model=None):
        model = self.model if model is None else model
        for n, piece in zip(self.free, self.split(logp)):
            model = eqx.tree_at(_where(model, n), model, jnp.exp(piece))
        return model

    def names_flat(self):
        out = []
        for n, size, shape in zip(self.free, self.sizes, self.shapes):
            out += [n] if shape == () else [f"{n}[{i}]" for i in range(size)]
        return out


# ----------------------------------------------------------------------------------------
# result


@dataclasses.dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_material`.

    Attributes:
        material, layer, shift: fitted models (same types as the initial ones).
        params: ``{name: value}`` fitted physical values (arrays for Prony fields).
        stderr: ``{name: standard error}`` (delta method from the log-parameter covariance).
        ci95: ``{name: (low, high)}`` 95 % intervals (log-normal, positive).
        covariance: covariance of the log-parameters, rows/columns in ``names`` order.
        correlation: correlation matrix of the log-parameters.
        names: flat parameter names (``"G[0]"``, ... for arrays).
        converged: True if the best start converged.
        residuals: weighted residuals at the optimum (rolling data first, then DMA).
        cost: ``0.5 * sum(residuals**2)``.
        reduced_chi2: ``sum(residuals**2)/(n - k)``: a goodness-of-fit measure only when every
            residual is weighted by a measured sigma (``sigma_mode``).
        sigma_mode: ``"absolute"`` (sigma given, ``absolute_sigma=True``), ``"scaled"`` (sigma
            given; the covariance is rescaled by the reduced chi^2) or ``"relative"`` (no sigma:
            relative residuals, so the reduced chi^2 is the mean squared relative misfit, not
            a test of the model).
        starts: list of ``(cost, converged)`` for every start, in the order tried.
        warnings: identifiability messages (also issued as :class:`IdentifiabilityWarning`).
        jacobian: Jacobian of ``residuals`` with respect to the log-parameters at the optimum
            (columns in ``names`` order; forward-mode AD through the model).
    """

    material: object
    layer: object
    shift: object
    params: dict
    stderr: dict
    ci95: dict
    covariance: np.ndarray
    correlation: np.ndarray
    names: list
    converged: bool
    residuals: np.ndarray
    cost: float
    reduced_chi2: float
    starts: list
    warnings: list
    jacobian: np.ndarray | None = None
    sigma_mode: str = "relative"

    def report(self) -> str:
        """A plain-text fit report."""
        lines = ["parameter        value          std. error     95 % interval"]
        for n in self.params:
            v, s, (lo, hi) = self.params[n], self.stderr[n], self.ci95[n]
            for i, (vi, si, li, hi_) in enumerate(zip(np.ravel(v), np.ravel(s), np.ravel(lo), np.ravel(hi))):
                label = n if np.ndim(v) == 0 else f"{n}[{i}]"
                lines.append(f"{label:<16} {vi:<14.6g} {si:<14.4g} [{li:.6g}, {hi_:.6g}]")
        chi2_meaning = {"absolute": "residuals weighted by the given sigma; ~1 for a correct model",
                        "scaled": "residuals weighted by the given sigma; ~1 for a correct model; intervals "
                        "rescaled by it",
                        "relative": "no sigma given: mean squared relative residual, not a test of the model"}
        lines.append(f"converged: {self.converged}; cost {self.cost:.6g}; {len(self.residuals)} residuals; "
                     f"{sum(c for _, c in self.starts)}/{len(self.starts)} starts converged")
        lines.append(f"reduced chi^2 {self.reduced_chi2:.4g} ({chi2_meaning[self.sigma_mode]})")
        if len(self.names) > 1:
            lines.append("correlation (log-parameters):")
            lines.append("          " + " ".join(f"{n:>9}" for n in self.names))
            for n, row in zip(self.names, self.correlation):
                lines.append(f"{n:>9} " + " ".join(f"{x:9.3f}" for x in row))
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


# ----------------------------------------------------------------------------------------
# the fit


def _rolling_model(radius, geometry, method):
    """``predict(material, layer, data) -> R_r`` at the data points ``data["V"], data["P"]``.

    A full model evaluates the table of the distinct speeds x distinct loads through
    :func:`jaxroll.rolling_resistance_grid` (one kernel per speed, warm-started loads) and picks
    the data points from it (``data["iv"], data["ip"]``); every other method vmaps
    :func:`jaxroll.rolling_resistance` over the points."""
    from .rolling import rolling_resistance, rolling_resistance_grid  # the front doors

    if _use_table(method):
        def predict(material, layer, data):
            out = rolling_resistance_grid(material, layer, radius=radius, loads=data["Pu"], speeds=data["Vu"],
                                          geometry=geometry, method=method, throw=False)
            return out.value[data["iv"], data["ip"]]

        return predict

    def predict(material, layer, data):
        def one(v, p):
            return rolling_resistance(material, layer, radius=radius, load=p, speed=v, geometry=geometry,
                                      method=method, throw=False).value

        return jax.vmap(one)(data["V"], data["P"])

    return predict


def _use_table(method):
    from .methods import Full

    return isinstance(method, Full)


# Compiled residual/Jacobian (and L-BFGS loop) per static configuration: repeated fits with the
# same model structure, fixed parameters, options and data shapes (multi-start, noise seeds,
# bootstrap) reuse them instead of recompiling. Least recently used entries are dropped.
_CACHE: dict = {}
_CACHE_SIZE = 16


def _freeze(x):
    """A hashable, value-based key for option values and model leaves (raises TypeError if not possible)."""
    if isinstance(x, dict):
        return tuple(sorted((k, _freeze(v)) for k, v in x.items()))
    if isinstance(x, (list, tuple)):
        return tuple(_freeze(v) for v in x)
    if isinstance(x, (np.ndarray, jax.Array, np.generic)):
        a = np.asarray(x)
        return ("array", a.shape, str(a.dtype), a.tobytes())
    hash(x)
    return x


def clear_cache():
    """Drop the compiled fit functions kept by :func:`fit_material`."""
    _CACHE.clear()


class _Compiled:
    """Jitted functions of one static fit configuration.

    ``res_jac(logp, data) -> (r, J)``: weighted residuals and their Jacobian with respect to the
    log-parameters (forward mode: ``k`` tangents, ``k`` = number of free parameters; or central
    differences with step ``jac_step`` in the log-parameters).
    ``lbfgs(u0, data) -> (u, ok)``: the optax L-BFGS loop in the unconstrained coordinates."""

    def __init__(self, params, predict_rr, max_steps, rtol, jac_step=None):
        def residuals_logp(logp, data):
            material, lay, sh = params.build(logp)
            parts = []
            if predict_rr is not None:
                parts.append((predict_rr(material, lay, data) - data["rr"]) / data["rr_sig"])
            if "w" in data:
                mat_t = material if "T" not in data else at_temperature(material, sh, data["T"])
                g = complex_modulus(mat_t, data["w"])
                parts += [(jnp.real(g) - data["gs"]) / data["ss"], (jnp.imag(g) - data["gl"]) / data["sl"]]
            return jnp.concatenate(parts)

        def res_jac(logp, data):
            def f(lp):
                r = residuals_logp(lp, data)
                return r, r

            J, r = jax.jacfwd(f, has_aux=True)(logp)
            return r, J

        def res_jac_fd(logp, data, step):
            # central differences in the log-parameters: 2k + 1 model evaluations, batched
            k = logp.shape[0]
            E = step * jnp.eye(k, dtype=logp.dtype)
            lps = jnp.concatenate([logp[None, :], logp + E, logp - E])
            rs = jax.vmap(residuals_logp, in_axes=(0, None))(lps, data)
            return rs[0], ((rs[1 : k + 1] - rs[k + 1 :]) / (2.0 * step)).T

        self.res_jac = jax.jit(res_jac) if jac_step is None else jax.jit(lambda lp, d: res_jac_fd(lp, d, jac_step))
        self._lbfgs = None
        self._make_lbfgs = lambda: _lbfgs_solver(lambda u, data: residuals_logp(params.logp_from_u(u), data),
                                                 max_steps, rtol)

    @property
    def lbfgs(self):
        if self._lbfgs is None:
            self._lbfgs = self._make_lbfgs()
        return self._lbfgs


def _lbfgs_solver(residuals_u, max_steps, rtol):
    import optax

    opt = optax.lbfgs()

    @jax.jit
    def solve(u0, data):
        loss = lambda u: 0.5 * jnp.sum(residuals_u(u, data) ** 2)  # noqa: E731
        value_and_grad = optax.value_and_grad_from_state(loss)

        def step(carry):
            u, state, i, _ = carry
            value, grad = value_and_grad(u, state=state)
            updates, state = opt.update(grad, state, u, value=value, grad=grad, value_fn=loss)
            u = optax.apply_updates(u, updates)
            return u, state, i + 1, jnp.linalg.norm(grad)

        def cond(carry):
            _, _, i, gnorm = carry
            return (i < max_steps) & (gnorm > rtol)

        u, _, i, gnorm = jax.lax.while_loop(cond, step, (u0, opt.init(u0), 0, jnp.inf))
        g = jax.grad(loss)(u)
        return u, (i < max_steps) | (jnp.linalg.norm(g) <= 1e-6 * (1.0 + loss(u)))

    return solve


def _levenberg_marquardt(evaluate, u0, max_steps, rtol, max_log_step=1.0):
    """Levenberg-Marquardt (identity damping, Nielsen's damping update), driven from the
    host (one compiled residual+Jacobian call per trial point).

    ``evaluate(u) -> (r, J_u, J_logp)``. Converged when the Gauss-Newton decrement
    ``0.5 |J h_GN|^2`` (the reduction a full Gauss-Newton step would give) is below
    ``rtol * cost`` (scale free; a tiny absolute floor covers noise-free data). Returns
    ``(u, converged, r, J_logp, steps)``. Steps are capped at ``max_log_step`` per coordinate
    (a trust region in the log-parameters: it keeps the iteration out of the asymptotic valleys,
    e.g. ``f -> inf``, that a full first step from a poor start can reach)."""
    u = np.asarray(u0, float)
    r, J, Jl = evaluate(u)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
        return u, False, r, Jl, 0
    cost = 0.5 * float(r @ r)
    floor = 1e-28 * r.size
    mu, nu = None, 2.0
    for it in range(int(max_steps)):
        A, g = J.T @ J, J.T @ r
        h_gn = np.linalg.lstsq(J, -r, rcond=None)[0]
        if 0.5 * float(np.sum((J @ h_gn) ** 2)) <= rtol * cost + floor:
            return u, True, r, Jl, it
        # Levenberg damping (identity: a spherical trust region in the log-parameters, which
        # keeps insensitive directions such as f -> inf from taking huge steps)
        D = np.ones(len(u))
        if mu is None:
            mu = 1e-3 * max(float(np.max(np.diag(A))), 1e-300)
        while True:
            try:
                h = np.linalg.solve(A + mu * np.diag(D), -g)
            except np.linalg.LinAlgError:
                h = None
            if h is not None:
                big = float(np.max(np.abs(h)))
                if big > max_log_step:  # trust region in the log-parameters (a factor e^max_log_step per step)
                    h = h * (max_log_step / big)
                rn, Jn, Jln = evaluate(u + h)
                ok = np.all(np.isfinite(rn)) and np.all(np.isfinite(Jn))
                cost_n = 0.5 * float(rn @ rn) if ok else math.inf
                pred = -float(g @ h) - 0.5 * float(h @ A @ h)  # Gauss-Newton model reduction
                rho = (cost - cost_n) / pred if pred > 0 else -1.0
                if ok and rho > 0:
                    u, r, J, Jl, cost = u + h, rn, Jn, Jln, cost_n
                    mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                    nu = 2.0
                    break
            mu *= nu
            nu *= 2.0
            if mu > 1e16 * max(float(np.max(np.diag(A))), 1e-300):  # no descent possible at working precision: at the optimum or stuck
                h_gn = np.linalg.lstsq(J, -r, rcond=None)[0]
                return u, 0.5 * float(np.sum((J @ h_gn) ** 2)) <= 1e-6 * cost + floor, r, Jl, it
    return u, False, r, Jl, int(max_steps)


def fit_material(
    speeds=None,
    loads=None,
    measured=None,
    *,
    initial,
    layer=None,
    radius=None,
    geometry="sphere",
    method="direct",
    free=None,
    sigma=None,
    dma: DMAData | None = None,
    dma_sigma=None,
    shift=None,
    bounds=None,
    solver="lm",
    n_starts=1,
    spread_decades=2.0,
    seed=0,
    absolute_sigma=False,
    max_steps=500,
    rtol=1e-10,
    jac_step=None,
    progress=False,
) -> FitResult:
    """Identify viscoelastic parameters from rolling resistance and/or DMA data.

    Args:
        speeds, loads, measured: rolling-resistance data (SI: m/s, N or N/m, N or N/m), 1D
            arrays of equal length, or ``None`` for a DMA-only fit.
        initial: initial material (:class:`StandardLinearSolid` or :class:`GeneralizedMaxwell`);
            the fitted material has the same type.
        layer: :class:`jaxroll.Layer` (required with rolling data; ``"H"`` may be free).
        radius: roller radius [m] (required with rolling data).
        geometry, method: passed to :func:`jaxroll.rolling_resistance` (a method object or a
            shortcut string; default ``"direct"``). The material parameters are traced during
            the fit, so a method with a grid must be resolved first
            (``jr.Full().resolve(initial, layer, radius=..., loads=..., speeds=...)`` or a
            :class:`jaxroll.FixedGrid`); the full model is then evaluated on the table of the
            distinct speeds x loads (:func:`jaxroll.rolling_resistance_grid`). For
            multi-parameter full-model fits use ``jr.Full(grid, edge_smoothing=0.25)`` (0.25 at
            the paper's grid, 0.5 on coarser ones): the exact discrete R_r wiggles with the
            contact set and LM stalls on it (fitting/README.md).
        free: names of the free parameters (material fields, ``"H"``, ``"C1"``/``"C2"``);
            default: the material's own parameters (``G0, tau, f`` for a standard linear solid,
            ``G_inf, G, tau`` for a generalized Maxwell material).
        sigma: standard deviations of ``measured`` (default: ``|measured|``, i.e. relative).
        dma: :class:`DMAData` to fit jointly (or alone); ``dma_sigma``: ``(sigma', sigma'')``
            arrays (default relative).
        shift: WLF/Arrhenius shift for DMA data at several temperatures.
        bounds: ``{name: (lo, hi)}`` physical bounds.
        solver: ``"lm"`` (Levenberg-Marquardt on the compiled residual Jacobian) or
            ``"lbfgs"`` (optax).
        n_starts: number of starts; the first is ``initial``, the others are drawn
            log-uniformly within ``spread_decades`` decades around it (seeded by ``seed``).
        absolute_sigma: treat ``sigma`` as absolute (covariance not rescaled by chi^2).
        max_steps, rtol: iteration cap and relative tolerance (LM: Gauss-Newton decrement
            ``<= rtol * cost``; L-BFGS: gradient norm ``<= rtol``).
        jac_step: ``None`` (default): Jacobian by forward-mode AD. A float ``h``: central
            differences in the log-parameters with step ``h`` (LM and the covariance), e.g. for
            models that are only piecewise smooth at a fixed resolution (a full model without
            ``edge_smoothing``: the contact area changes in whole cells; see fitting/README.md
            for what this does and does not fix).
        progress: print one line per residual+Jacobian evaluation (evaluation count, chi^2,
            parameters, elapsed time) for long fits (a full model: seconds per evaluation), or a
            callable ``progress(count, chi2, params_dict, seconds)``.

    The compiled residual/Jacobian is cached per static configuration (everything except the
    initial values of the free parameters and the data values), so repeated fits of data of
    the same shape do not recompile (:func:`clear_cache` empties the cache).

    Returns:
        :class:`FitResult`.
    """
    if solver not in ("lm", "lbfgs"):
        raise ValueError(f"solver must be 'lm' or 'lbfgs', got {solver!r}")
    if not isinstance(initial, (StandardLinearSolid, GeneralizedMaxwell)):
        raise ValueError("initial must be a StandardLinearSolid or GeneralizedMaxwell")
    if free is None:
        free = _DEFAULT_FREE[type(initial)]
    have_rr = measured is not None
    if not have_rr and dma is None:
        raise ValueError("nothing to fit: give rolling-resistance data (speeds, loads, measured) and/or dma")
    rolling = None
    if have_rr:
        if layer is None or radius is None:
            raise ValueError("rolling-resistance data need layer= and radius=")
        rolling = RollingData(np.asarray(speeds, float), np.asarray(loads, float), np.asarray(measured, float),
                              None if sigma is None else np.asarray(sigma, float))
    if "H" in free and (layer is None or not have_rr):
        raise ValueError("'H' can only be fitted from rolling-resistance data with a layer")
    if dma is not None and dma.temperature is not None and shift is None:
        raise ValueError("DMA data at several temperatures need a shift (jr.WLF or jr.Arrhenius)")
    if have_rr:
        from .methods import as_method

        method = as_method(method)
        method.check_geometry(geometry)
        if method.needs_resolution(geometry):
            raise ValueError(f"{type(method).__name__} sizes its grid from the inputs, which a fit varies: resolve it "
                             f"once over the data, method = method.resolve(initial, layer, radius=..., "
                             f"loads=measured_loads, speeds=measured_speeds, geometry=...), or give a "
                             f"jr.FixedGrid")

    params = _Params((initial, layer, shift), free, bounds)

    # the data travel as jit arguments, not closure constants (XLA would constant-fold them)
    data = {}
    if rolling is not None:
        data.update(V=jnp.asarray(rolling.speed), P=jnp.asarray(rolling.load), rr=jnp.asarray(rolling.value),
                    rr_sig=jnp.asarray(rolling.value if rolling.sigma is None else rolling.sigma))
        if _use_table(method):
            Vu, iv = np.unique(rolling.speed, return_inverse=True)
            Pu, ip = np.unique(rolling.load, return_inverse=True)  # sorted: warm-started load sweep
            data.update(Vu=jnp.asarray(Vu), Pu=jnp.asarray(Pu), iv=jnp.asarray(iv.ravel()), ip=jnp.asarray(ip.ravel()))
    if dma is not None:
        data.update(w=jnp.asarray(dma.omega), gs=jnp.asarray(dma.storage), gl=jnp.asarray(dma.loss))
        data.update(ss=data["gs"] if dma_sigma is None else jnp.asarray(dma_sigma[0]),
                    sl=data["gl"] if dma_sigma is None else jnp.asarray(dma_sigma[1]))
        if dma.temperature is not None:
            data["T"] = jnp.asarray(dma.temperature)

    n_res = (0 if rolling is None else len(rolling.value)) + (0 if dma is None else 2 * len(dma.omega))
    k = params.size
    if n_res < k:
        raise ValueError(f"{n_res} residuals cannot determine {k} parameters")

    # the compiled functions close over a template model (free fields set to 1: their initial
    # values are not part of the static configuration)
    template = params.build(jnp.zeros(k))
    tparams = _Params(template, free, bounds)
    try:
        leaves, treedef = jax.tree_util.tree_flatten(template)
        key = (treedef, _freeze(leaves), tuple(free), tuple(map(tuple, tparams.shapes)), tuple(tparams.lo),
               tuple(tparams.hi), have_rr and (float(radius), geometry, method),
               int(max_steps), float(rtol), None if jac_step is None else float(jac_step))
        hash(key)
    except TypeError:
        key = None
    bundle = _CACHE.pop(key, None) if key is not None else None
    if bundle is None:
        predict_rr = _rolling_model(radius, geometry, method) if have_rr else None
        bundle = _Compiled(tparams, predict_rr, max_steps, rtol, None if jac_step is None else float(jac_step))
    if key is not None:
        _CACHE[key] = bundle
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))

    names = params.names_flat()
    t_start, count = time.perf_counter(), [0]

    def evaluate(u):
        logp, dl = params.logp_and_slope(u)
        r, Jl = bundle.res_jac(jnp.asarray(logp), data)
        r, Jl = np.asarray(r), np.asarray(Jl)
        if progress:
            count[0] += 1
            values = dict(zip(names, np.exp(np.asarray(logp)).tolist()))
            elapsed, chi2 = time.perf_counter() - t_start, float(r @ r)
            if callable(progress):
                progress(count[0], chi2, values, elapsed)
            else:
                shown = "  ".join(f"{n}={v:.5g}" for n, v in values.items())
                print(f"fit: evaluation {count[0]:3d}  chi2 {chi2:.6g}  {shown}  ({elapsed:.1f} s)", flush=True)
        return r, Jl * dl[None, :], Jl

    rng = np.random.default_rng(seed)
    logp0 = np.asarray(params.logp0())
    starts = []
    best = None
    for i in range(max(1, int(n_starts))):
        lp = logp0 if i == 0 else logp0 + rng.uniform(-0.5, 0.5, size=logp0.shape) * spread_decades * math.log(10)
        u0 = np.asarray(params.u_from_logp(jnp.asarray(lp)))
        if solver == "lm":
            u, ok, r_u, J_u, _ = _levenberg_marquardt(evaluate, u0, max_steps, rtol)
        else:
            # optax's L-BFGS mixes int32 and int64 internally: trace it with standard promotion
            with jax.numpy_dtype_promotion("standard"):
                u, ok = bundle.lbfgs(jnp.asarray(u0), data)
            u = np.asarray(u)
            r_u, _, J_u = evaluate(u)
        cost = 0.5 * float(r_u @ r_u)
        ok = bool(ok) and math.isfinite(cost)
        starts.append((cost, ok))
        if best is None or (math.isfinite(cost) and cost < best[0]):
            best = (cost, ok, u, r_u, J_u)
    cost, converged, u, r, J = best
    logp = jnp.asarray(params.logp_and_slope(u)[0])
    dof = max(n_res - k, 1)
    chi2 = float(np.sum(r**2))
    s2 = 1.0 if absolute_sigma else chi2 / dof
    JTJ = J.T @ J
    cov = np.linalg.pinv(JTJ) * s2
    sd_log = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd_log, sd_log)
    material, lay, sh = params.build(logp)

    flat_names = params.names_flat()
    p_flat = np.exp(np.asarray(logp))
    values, stderr, ci = {}, {}, {}
    i = 0
    for n, size, shape in zip(params.free, params.sizes, params.shapes):
        sl_ = slice(i, i + size)
        values[n] = p_flat[sl_].reshape(shape)
        stderr[n] = (p_flat[sl_] * sd_log[sl_]).reshape(shape)
        ci[n] = (np.exp(np.asarray(logp)[sl_] - Z95 * sd_log[sl_]).reshape(shape),
                 np.exp(np.asarray(logp)[sl_] + Z95 * sd_log[sl_]).reshape(shape))
        i += size

    messages = []
    have_sigma = (rolling is None or rolling.sigma is not None) and (dma is None or dma_sigma is not None)
    sigma_mode = ("absolute" if absolute_sigma else "scaled") if have_sigma else "relative"
    if have_sigma and dof > 0:
        from scipy.stats import chi2 as chi2_dist

        p_value = float(chi2_dist.sf(chi2, dof))
        if p_value < 1e-3:
            messages.append(f"reduced chi^2 = {chi2 / dof:.3g} with the given sigma (probability {p_value:.1g} for a "
                            f"correct model): the model does not describe the data within their errors (model "
                            f"error, e.g. the direct method's stationary pressure, or sigma too small); the "
                            f"parameters and intervals are those of the best approximation")
    sv = np.linalg.svd(J, compute_uv=False)
    if sv[-1] <= 1e-10 * sv[0]:
        messages.append("the Jacobian is (numerically) rank deficient: some parameter combination is not "
                        "determined by the data")
    for j, n in enumerate(flat_names):
        if not np.isfinite(sd_log[j]) or sd_log[j] > 0.5:
            hint = (" (for rolling-resistance data: include speeds around the resistance peak, V ~ contact "
                    "radius/tau, or add DMA data)" if n in ("tau", "f") else "")
            messages.append(f"parameter {n!r} is poorly constrained: relative standard error "
                            f"{100 * sd_log[j]:.0f} %{hint}")
    for a in range(len(flat_names)):
        for b in range(a + 1, len(flat_names)):
            if np.isfinite(corr[a, b]) and abs(corr[a, b]) > 0.995:
                messages.append(f"parameters {flat_names[a]!r} and {flat_names[b]!r} are almost fully correlated "
                                f"({corr[a, b]:+.4f}): the data constrain only a combination of them")
    for m in messages:
        warnings.warn(m, MisfitWarning if m.startswith("reduced chi^2") else IdentifiabilityWarning, stacklevel=2)

    return FitResult(
        material=material,
        layer=lay,
        shift=sh,
        params=values,
        stderr=stderr,
        ci95=ci,
        covariance=cov,
        correlation=corr,
        names=flat_names,
        converged=bool(converged),
        residuals=np.asarray(r),
        cost=float(cost),
        reduced_chi2=chi2 / dof,
        starts=starts,
        warnings=messages,
        jacobian=J,
        sigma_mode=sigma_mode,
    )
