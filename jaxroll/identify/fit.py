"""Material identification from measured rolling resistance and/or DMA data.

Weighted least squares in log-parameters (positivity built in), solved by
:func:`scipy.optimize.least_squares` on a compiled JAX residual and its AD Jacobian,
with multi-start, optional bounds and Gauss-Newton uncertainty (covariance, standard errors,
95 % intervals, correlations).

Residuals, stacked over the data sets supplied:

* rolling resistance: ``(R_model - R_meas)/sigma`` with ``R_model`` from
  :func:`jaxroll.rolling_resistance` (any method; the per-point model is vmapped);
  ``sigma`` defaults to ``|R_meas|`` (relative residuals);
* DMA: ``(G'_model - G'_meas)/sigma'`` and ``(G''_model - G''_meas)/sigma''`` at each frequency
  (and temperature, through a WLF/Arrhenius shift), relative by default.

Uncertainty: ``cov(log p) = s^2 (J^T J)^{-1}`` with ``J`` the Jacobian of the residuals with
respect to the log-parameters at the optimum, ``s^2 = chi^2/(n - k)`` unless
``absolute_sigma=True`` (``s = 1``); ``stderr(p) = p sqrt(cov_ii)`` (delta method). The 95 %
interval is either linearised, ``exp(log p +- 1.96 sqrt(cov_ii))`` (asymmetric, positive), or
the profile-likelihood interval: the values of ``p_i`` where the cost minimised over the other
parameters has risen by ``1.96^2 s^2 / 2`` (the likelihood-ratio test, chi^2 with one degree of
freedom). The profile follows a curved parameter valley where the linearisation does not: with
the default full model on rolling data alone (G0, tau and f correlated above 0.99 along a curved
valley) the linearised intervals held the truth in 74-78 % of seeded noise draws, the profiles
in the share that ``benchmarks/fit_coverage.py`` measures (fitting/README.md, "Coverage and
the intervals"). A profile that finds a lower cost than the fit's (a second minimum along the
valley) restarts the fit there.
"""

from __future__ import annotations

import dataclasses
import math
import os
import threading
import time
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _compilation_cache
from .._lsq import Z95, gauss_newton_distance, least_squares
from .._numerics import check_plausible, input_checks
from ..contact import WarmStart
from ..engines.layer import is_quasistatic
from ..engines.stack import Stack, cover_path, cover_thickness, with_cover_material
from ..io import UNITS, Column, DataWarning, read_table
from ..materials.material import GeneralizedMaxwell, StandardLinearSolid, at_temperature, complex_modulus
from ..result import RESULTS

__all__ = [
    "DMAData",
    "RollingData",
    "FitResult",
    "IdentifiabilityWarning",
    "fit_material",
    "read_dma_csv",
    "read_rolling_csv",
]

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
    shear moduli [Pa], optional temperature [K] (then a shift is needed to fit), optional
    standard deviations of the storage and loss moduli [Pa] (both or neither)."""

    omega: np.ndarray
    storage: np.ndarray
    loss: np.ndarray
    temperature: np.ndarray | None = None
    storage_sigma: np.ndarray | None = None
    loss_sigma: np.ndarray | None = None

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
        if (self.storage_sigma is None) != (self.loss_sigma is None):
            raise ValueError("DMAData: give both storage_sigma and loss_sigma, or neither")
        for name in ("storage_sigma", "loss_sigma"):
            if getattr(self, name) is not None:
                _check_array(name, getattr(self, name), positive=True)


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
        return cover_thickness(layer)
    if name in ("C1", "C2"):
        if shift is None:
            raise ValueError(f"free parameter {name!r} needs a WLF shift (shift=jr.WLF(...))")
        return getattr(shift, name)
    if not hasattr(material, name):
        fields = _DEFAULT_FREE.get(type(material), ())
        raise ValueError(f"free parameter {name!r} is not a field of {type(material).__name__}; its parameters are "
                         f"{', '.join(fields)} (plus H, and C1, C2 of a WLF shift)")
    return getattr(material, name)


def _where(name):
    if name == "H":  # a Stack: its top ply's thickness
        return lambda m: cover_path(m[1])(m[1])
    if name in ("C1", "C2"):
        return lambda m: getattr(m[2], name)
    return lambda m: getattr(m[0], name)


class _Params(eqx.Module):
    """Maps the free physical parameters to an unconstrained vector and back (static, hashable:
    part of the compiled residual's key).

    Unbounded: ``u = log p``. Bounded ``(lo, hi)``: ``log p = log lo + (log hi - log lo)
    sigmoid(u)``."""

    free: tuple = eqx.field(static=True)
    shapes: tuple = eqx.field(static=True)
    lo: tuple = eqx.field(static=True)
    hi: tuple = eqx.field(static=True)

    @classmethod
    def of(cls, model, free, bounds):
        free = tuple(free)
        shapes = tuple(tuple(jnp.shape(_get(model, n))) for n in free)
        bounds = dict(bounds or {})
        unknown = set(bounds) - set(free)
        if unknown:
            raise ValueError(f"bounds given for parameters that are not free: {sorted(unknown)}")
        lo, hi = [], []
        for n in free:
            b_lo, b_hi = bounds.get(n, (None, None))
            if b_lo is not None and not (0 < b_lo < b_hi):
                raise ValueError(f"bounds for {n!r} must satisfy 0 < lo < hi, got {(b_lo, b_hi)}")
            lo.append(None if b_lo is None else math.log(b_lo))
            hi.append(None if b_hi is None else math.log(b_hi))
            v = np.asarray(_get(model, n))
            if np.any(v <= 0):
                raise ValueError(f"initial value of {n!r} must be positive for a log-parameter fit, got {v}")
        return cls(free, shapes, tuple(lo), tuple(hi))

    @property
    def sizes(self):
        return [int(np.prod(s)) for s in self.shapes]

    @property
    def size(self):
        return sum(self.sizes)

    def split(self, vec):
        out, i = [], 0
        for shape, size in zip(self.shapes, self.sizes):
            out.append(vec[i : i + size].reshape(shape))
            i += size
        return out

    def u_from_logp(self, logp):
        """Host-side (numpy) unconstrained coordinates of ``log p``."""
        parts = []
        for piece, lo, hi in zip(self.split(np.asarray(logp, float)), self.lo, self.hi):
            if lo is None:
                parts.append(piece)
            else:
                t = np.clip((piece - lo) / (hi - lo), 1e-9, 1 - 1e-9)
                parts.append(np.log(t) - np.log1p(-t))
        return np.concatenate([np.ravel(p) for p in parts])

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

    def logp0(self, model):
        return np.concatenate([np.ravel(np.log(np.asarray(_get(model, n), float))) for n in self.free])

    def build(self, logp, model):
        """``model`` with the free parameters set to ``exp(logp)`` (jittable)."""
        for n, piece in zip(self.free, self.split(logp)):
            model = eqx.tree_at(_where(n), model, jnp.exp(piece))
        return model

    def names_flat(self):
        out = []
        for n, size, shape in zip(self.free, self.sizes, self.shapes):
            out += [n] if shape == () else [f"{n}[{i}]" for i in range(size)]
        return out


# ----------------------------------------------------------------------------------------
# result


#: SI units of the parameters a fit can free (flat names ``"G[0]"`` take the unit of ``"G"``).
PARAMETER_UNITS = {"G0": "Pa", "tau": "s", "f": "-", "G_inf": "Pa", "G": "Pa", "H": "m", "C1": "-", "C2": "K"}


@dataclasses.dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_material`.

    Attributes:
        material, layer, shift: fitted models (same types as the initial ones).
        params: ``{name: value}`` fitted physical values (arrays for Prony fields).
        stderr: ``{name: standard error}`` (delta method from the log-parameter covariance).
        ci95: ``{name: (low, high)}`` 95 % intervals: profile-likelihood (the default fit of
            rolling data, or ``intervals="profile"``) or linearised (log-normal, positive).
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
            (columns in ``names`` order; AD through the model: reverse mode per point for a
            full model's rolling data, forward mode otherwise).
        method: the rolling-resistance method of the fit, with the grid it ended on (``None``
            for a DMA-only fit).
        interval_method: how ``ci95`` was formed: ``"profile"`` (profile likelihood) or
            ``"linearised"`` (Gauss-Newton, log-normal).
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
    method: object = None
    interval_method: str = "linearised"

    def _rows(self):
        """(label, value, stderr, low, high, unit) per flat parameter, in ``params`` order."""
        out = []
        for n in self.params:
            v, s, (lo, hi) = self.params[n], self.stderr[n], self.ci95[n]
            for i, row in enumerate(zip(np.ravel(v), np.ravel(s), np.ravel(lo), np.ravel(hi))):
                out.append((n if np.ndim(v) == 0 else f"{n}[{i}]", *map(float, row), PARAMETER_UNITS.get(n, "")))
        return out

    def to_pandas(self):
        """The fitted parameters as a ``pandas.DataFrame`` indexed by ``parameter`` (flat names,
        ``"G[0]"`` for arrays) with columns ``value``, ``stderr``, ``ci95_low``, ``ci95_high``
        and ``unit`` (SI); the correlation of the log-parameters in ``attrs["correlation"]``.
        Needs pandas (an optional dependency)."""
        from .._labelled import _require

        pd = _require("pandas")
        rows = self._rows()
        df = pd.DataFrame(rows, columns=["parameter", "value", "stderr", "ci95_low", "ci95_high", "unit"])
        df = df.set_index("parameter")
        df.attrs.update(units={r[0]: r[5] for r in rows}, correlation=np.asarray(self.correlation).tolist(),
                        reduced_chi2=self.reduced_chi2, converged=self.converged, sigma_mode=self.sigma_mode,
                        interval_method=self.interval_method)
        return df

    def to_xarray(self):
        """The fitted parameters as an ``xarray.Dataset`` over the dimension ``parameter`` (flat
        names): ``value``, ``stderr``, ``ci95_low``, ``ci95_high`` (``attrs["units"]`` per
        parameter in ``unit``), and ``correlation`` over ``(parameter, parameter_2)`` (the
        log-parameters, ``names`` order). Needs xarray (an optional dependency)."""
        from .._labelled import _require

        xr = _require("xarray")
        rows = self._rows()
        names = [r[0] for r in rows]
        cols = {k: ("parameter", np.array([r[i] for r in rows])) for i, k in
                enumerate(["value", "stderr", "ci95_low", "ci95_high"], start=1)}
        ds = xr.Dataset({**cols, "unit": ("parameter", [r[5] for r in rows]),
                         "correlation": (("parameter", "parameter_2"), np.asarray(self.correlation))},
                        coords={"parameter": names, "parameter_2": list(self.names)},
                        attrs={"reduced_chi2": self.reduced_chi2, "converged": int(self.converged),
                               "sigma_mode": self.sigma_mode, "interval_method": self.interval_method})
        return ds

    def report(self) -> str:
        """A plain-text fit report."""
        kind = {"profile": "profile likelihood", "linearised": "linearised, log-normal"}[self.interval_method]
        lines = [f"parameter        value          std. error     95 % interval ({kind})"]
        for label, vi, si, li, hi_, _ in self._rows():
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
# the compiled model


class _Problem(eqx.Module):
    """The configuration of a fit: the free parameters, how the rolling resistance is computed
    and how the Jacobian is formed. Its static part keys the compiled residual and Jacobian;
    the method enters with its grid lengths as arrays (``method.dynamic()``: the cell size is a
    traced value, the window static), so fits that differ only in data values, initial values,
    fixed parameter values or the cell size of the grid reuse one compiled program."""

    params: _Params
    radius: float | None = eqx.field(static=True)
    geometry: str = eqx.field(static=True)
    method: object  # an AbstractMethod with traced grid lengths, or None for DMA-only fits
    jac_step: float | None = eqx.field(static=True)

    @classmethod
    def of(cls, params, radius, geometry, method, jac_step):
        return cls(params, None if radius is None else float(radius), geometry,
                   None if method is None else method.dynamic(), None if jac_step is None else float(jac_step))


def _predict_rolling(material, layer, data, problem):
    """``R_r`` at the data points ``data["V"], data["P"]``.

    A full model evaluates the table of the distinct speeds x distinct loads through
    :func:`jaxroll.rolling_resistance_grid` (one kernel per speed, warm-started loads) and picks
    the data points from it (``data["iv"], data["ip"]``); every other method vmaps
    :func:`jaxroll.rolling_resistance` over the points."""
    from ..rolling import rolling_resistance, rolling_resistance_grid  # the front doors

    material, layer = _with_cover(material, layer)
    kw = dict(radius=problem.radius, geometry=problem.geometry, method=problem.method, throw=False)
    if _use_table(problem.method):
        out = rolling_resistance_grid(material, layer, loads=data["Pu"], speeds=data["Vu"], **kw)
        return out.value[data["iv"], data["ip"]]
    return jax.vmap(lambda v, p: rolling_resistance(material, layer, load=p, speed=v, **kw).value)(data["V"], data["P"])


def _with_cover(material, layer):
    """``(material, layer)`` as the front doors take them: a :class:`jaxroll.Stack` gets
    ``material`` (the fitted one) in its top ply; its other plies and base stay fixed."""
    if isinstance(layer, Stack):
        layer = with_cover_material(layer, material)
        return layer.material, layer  # (the stack's own object: the front doors check its identity)
    return material, layer


def _use_table(method):
    from ..methods import Full

    return isinstance(method, Full)


def _residuals(logp, model, data, problem):
    """Weighted residuals, rolling resistance first, then DMA storage and loss."""
    material, layer, shift = problem.params.build(logp, model)
    parts = []
    if "rr" in data:
        parts.append((_predict_rolling(material, layer, data, problem) - data["rr"]) / data["rr_sig"])
    if "w" in data:
        mat_t = material if "T" not in data else at_temperature(material, shift, data["T"])
        g = complex_modulus(mat_t, data["w"])
        parts += [(jnp.real(g) - data["gs"]) / data["ss"], (jnp.imag(g) - data["gl"]) / data["sl"]]
    return jnp.concatenate(parts)


@eqx.filter_jit
def _residuals_and_jacobian_jit(logp, model, data, problem, starts=None):
    """``(r, dr/dlogp)``: per point in reverse mode for a full model's rolling data alone
    (:func:`_per_point_jacobian`), else forward mode (``k`` tangents for ``k`` free parameters),
    or central differences with step ``problem.jac_step`` in the log-parameters (``2k`` further
    evaluations: vmapped, or for the full models' warm-started tables one after the other).

    The input rules (:func:`jaxroll._numerics.check_input`) stay out of the program where they
    hold by construction: the data are checked on the host (:class:`RollingData`), the fitted
    parameters are positive (``exp`` of the log-parameters), and a :class:`jaxroll.Layer` without
    inertia has no supersonic speed. The program then holds no host callback, so JAX's persistent
    compilation cache keeps it (:mod:`jaxroll._compilation_cache`): a later process fitting data
    of the same shape on a grid of the same window loads it instead of compiling. With a layer
    with inertia or a :class:`jaxroll.Stack` (the supersonic rule depends on the fitted modulus),
    or with a time-temperature shift (its law's domain, e.g. WLF's ``C2 + T - T_ref > 0``, depends
    on the data's temperatures and on fitted shift parameters) the rules are checked inside.

    ``starts``: ``None``, or (per-point Jacobian only, :func:`_point_starts`) each point's start
    for its contact solves; then the return is ``(r, J, finals, failed)``, ``finals`` the starts
    at ``logp`` (the next evaluation's), ``failed`` where a point's solver did not converge."""
    with input_checks(not is_quasistatic(model[1]) or model[2] is not None):
        return _residuals_and_jacobian(logp, model, data, problem, starts)


def _residuals_and_jacobian(logp, model, data, problem, starts=None):
    """The body of :func:`_residuals_and_jacobian_jit`."""
    if problem.jac_step is None and _per_point(model, data, problem):
        return _per_point_jacobian(logp, model, data, problem, starts)
    if problem.jac_step is None:
        def f(lp):
            r = _residuals(lp, model, data, problem)
            return r, r

        J, r = jax.jacfwd(f, has_aux=True)(logp)
        return r, J
    k, step = logp.shape[0], problem.jac_step
    E = step * jnp.eye(k, dtype=logp.dtype)
    shifted = jnp.concatenate([logp[None, :], logp + E, logp - E])
    if _use_table(problem.method):
        # the full model's tables one after the other: under vmap the contact solves of all 2k + 1
        # tables would run in lockstep, each to the slowest lane's iteration count
        rs = jax.lax.map(lambda lp: _residuals(lp, model, data, problem), shifted)
    else:
        rs = jax.vmap(_residuals, in_axes=(0, None, None, None))(shifted, model, data, problem)
    return rs[0], ((rs[1 : k + 1] - rs[k + 1 :]) / (2.0 * step)).T


def _per_point(model, data, problem) -> bool:
    """Whether :func:`_per_point_jacobian` applies: a full model, rolling data alone, free
    parameters of the material only (a fixed :class:`jaxroll.Layer`, no shift), and the
    reverse pass's memory within the budget (:func:`_per_point_memory_fits`)."""
    material_only = all(n not in ("H", "C1", "C2") for n in problem.params.free)
    return (_use_table(problem.method) and "w" not in data and material_only and not isinstance(model[1], Stack)
            and _per_point_memory_fits(problem, data["V"].shape[0]))


def _per_point_memory_fits(problem, n: int) -> bool:
    """Whether ``n`` points' reverse-mode residuals fit :func:`jaxroll.grids.memory_budget`: the
    reverse pass keeps each point's solve (its kernel and contact solution) until the pullback,
    bounded by ``n`` times the grid's :meth:`~jaxroll.grids.FixedGrid.memory_estimate` of one
    evaluation. Above it (or where the grid gives no estimate), the Jacobian is forward mode,
    whose memory does not grow with ``n``. Decided when the fit's program is traced."""
    from ..grids import memory_budget

    try:
        need = n * problem.method.grid.memory_estimate(2 if problem.geometry == "sphere" else 1)
    except (AttributeError, TypeError, jax.errors.ConcretizationTypeError):
        return False
    return need <= memory_budget()


def _per_point_jacobian(logp, model, data, problem, starts=None):
    """``(r, dr/dlogp)`` of a full model's rolling residuals in one reverse-mode pass: each point
    gets its own copy of the log-parameters and is solved by :meth:`jaxroll.methods.Full.evaluate_points`
    (warm-started from the previous point, sorted by speed then load; the start is data only), so
    residual ``i`` depends on copy ``i`` alone and the pullback of a vector of ones is the
    Jacobian, row by row. Each contact solve's derivative is then one adjoint (transposed) solve,
    where forward mode solves once per free parameter; each point builds its own kernel. On the
    60-point sphere benchmark one evaluation took 5.8 s of CPU against 13.6-14.7 s in forward
    mode (benchmarks/LOG.md, "The sphere fit's evaluation").

    ``starts`` (:func:`_point_starts`): each point's contact solves start from its solution at
    the previous evaluation (``evaluate_points(starts=...)``; data only: the result is the
    same to the solver tolerance); then the return is ``(r, J, finals, failed)``, ``failed``
    where a point's contact solve did not converge (:data:`_SOLVER_FAILURES`)."""
    params, (_, layer, _) = problem.params, model
    n = data["V"].shape[0]

    def residuals(logp_points):
        material = jax.vmap(lambda lp: params.build(lp, model)[0])(logp_points)
        out = problem.method.evaluate_points(material, layer, jnp.asarray(problem.radius, float), data["P"],
                                             data["V"], problem.geometry, axes=(0, None, None, 0, 0),
                                             order=data["order"], starts=starts)
        out, finals = (out, None) if starts is None else out
        failed = jnp.isin(out.result, jnp.asarray(_SOLVER_FAILURES))
        return (out.value - data["rr"]) / data["rr_sig"], (finals, failed)

    r, pullback, (finals, failed) = jax.vjp(residuals, jnp.broadcast_to(logp, (n, logp.shape[0])), has_aux=True)
    J = pullback(jnp.ones_like(r))[0]
    return (r, J) if starts is None else (r, J, finals, failed)


#: Result codes of a contact solve that did not converge: an evaluation whose started points
#: (:func:`_point_starts`) end with one of them is evaluated again without the starts.
_SOLVER_FAILURES = (RESULTS.max_steps_reached, RESULTS.linear_solve_failed, RESULTS.nonfinite)


def _point_starts(problem, model, data):
    """No start yet (each point from its neighbour, as without starts), in the form that
    :func:`_per_point_jacobian` takes and returns, so that the first evaluation of a run and
    the later ones share one program; ``None`` where the Jacobian is not per point."""
    if problem.jac_step is not None or not _per_point(model, data, problem):
        return None
    n, grid = data["V"].shape[0], problem.method.grid
    shape = (grid.window,) * problem.method.grid_ndim(problem.geometry)
    # NumPy-built (no small XLA programs) with the strong dtypes that the program returns (weak
    # ones would key a second program); WarmStart.none per point
    flags = jnp.asarray(np.zeros(n, bool))
    none = WarmStart(jnp.asarray(np.zeros((n, *shape), bool)), jnp.asarray(np.zeros((n, *shape))),
                     jnp.asarray(np.zeros(n)), flags, flags)
    return none, jnp.asarray(np.ones(n))


def _carried_starts(finals, old, new):
    """Per-point starts (:func:`_point_starts`' form) ``finals``, solved on grid ``old``, for a
    run on grid ``new`` of the same window (``None`` otherwise): the same cells at another cell
    size ``h``. :meth:`jaxroll.contact.WarmStart.stretch` maps a start in cells by the ratio of
    the counting sizes [m]; with the sizes multiplied by ``q = h_new/h_old`` it maps them by the
    ratio in cells, and the pressure divided by ``q^d`` (``d`` the grid's dimension: the cell
    area) and the penetration multiplied by ``q^2`` keep the load and the penetration of the
    stretched start physical."""
    if finals is None or old is None or getattr(old, "window", None) != getattr(new, "window", None):
        return None
    (warm, sizes), q = finals, float(new.spacing) / float(old.spacing)
    d = warm.pressure.ndim - 1  # per point: (n, *window shape)
    warm = eqx.tree_at(lambda w: (w.pressure, w.penetration), warm, (warm.pressure / q**d, warm.penetration * q**2))
    return warm, sizes * q


def _data_arrays(rolling, dma, method):
    """The data as jit arguments (not closure constants, which XLA would constant-fold)."""
    data = {}
    if rolling is not None:
        data.update(V=jnp.asarray(rolling.speed), P=jnp.asarray(rolling.load), rr=jnp.asarray(rolling.value),
                    rr_sig=jnp.asarray(rolling.value if rolling.sigma is None else rolling.sigma))
        if _use_table(method):
            Vu, iv = np.unique(rolling.speed, return_inverse=True)
            Pu, ip = np.unique(rolling.load, return_inverse=True)  # sorted: warm-started load sweep
            data.update(Vu=jnp.asarray(Vu), Pu=jnp.asarray(Pu), iv=jnp.asarray(iv.ravel()), ip=jnp.asarray(ip.ravel()),
                        order=jnp.asarray(np.lexsort((rolling.load, rolling.speed))))  # by speed, then load
    if dma is not None:
        data.update(w=jnp.asarray(dma.omega), gs=jnp.asarray(dma.storage), gl=jnp.asarray(dma.loss))
        data.update(ss=jnp.asarray(dma.storage if dma.storage_sigma is None else dma.storage_sigma),
                    sl=jnp.asarray(dma.loss if dma.loss_sigma is None else dma.loss_sigma))
        if dma.temperature is not None:
            data["T"] = jnp.asarray(dma.temperature)
    return data


# ----------------------------------------------------------------------------------------
# the fit


def _check_problem(rolling, dma, initial, free, layer, radius, geometry, method, shift):
    """Validate the inputs of :func:`fit_material`; returns the method object (None without
    rolling data)."""
    if not isinstance(initial, (StandardLinearSolid, GeneralizedMaxwell)):
        raise ValueError("initial must be a StandardLinearSolid or GeneralizedMaxwell")
    if rolling is None and dma is None:
        raise ValueError("nothing to fit: give rolling-resistance data (RollingData) and/or dma (DMAData)")
    if rolling is not None and not isinstance(rolling, RollingData):
        raise ValueError(f"rolling data must be a RollingData (speed, load, value[, sigma]); got {type(rolling).__name__}")
    if dma is not None and not isinstance(dma, DMAData):
        raise ValueError(f"dma must be a DMAData (omega, storage, loss[, temperature]); got {type(dma).__name__}")
    if "H" in free and (layer is None or rolling is None):
        raise ValueError("'H' can only be fitted from rolling-resistance data with a layer")
    if dma is not None and dma.temperature is not None and shift is None:
        raise ValueError("DMA data at several temperatures need a shift (jr.WLF or jr.Arrhenius)")
    if dma is not None and dma.temperature is not None:
        shift.check_temperatures(dma.temperature)  # the initial law (a fitted one is checked inside)
    if rolling is None:
        return None
    if layer is None or radius is None:
        raise ValueError("rolling-resistance data need layer= and radius=")
    from ..methods import as_method, default_method

    method = as_method(default_method(geometry, fit=True) if method is None else method)
    method.check_geometry(geometry)
    return method


#: Default ``rtol`` of :func:`fit_material` with the default (full) model: on the 60-point cylinder
#: benchmark (benchmarks/fit_coverage.py) the cost reached 1e-5 of its final value in 12
#: evaluations, and at rtol 1e-10 the iteration spent 9 more on cost changes below 5e-6
#: (parameters moving < 0.1 %). A cost within ``rtol F`` of the minimum puts the parameters within
#: ``sqrt(2 rtol F)`` standard errors of it: 0.026 for F = 33 (60 points) at 1e-5, which moves a
#: 95 % interval's coverage by < 0.1 %. On the 60-point sphere benchmark 1e-5 instead of 1e-6 saved
#: the last 2 of 25 evaluations (5.4 s of CPU each) and moved G0 by 0.05 % (benchmarks/LOG.md).
FULL_MODEL_RTOL = 1e-5

#: Largest factor by which the grid resolved at the fitted parameters may differ from the grid
#: of the fit (cell size or window width, either way) before :func:`fit_material` re-resolves
#: the grid and refits from the fitted point. Tight, so that a fit ends on the grid its own result
#: asks for, whatever the start: the data hardly constrain the G0-tau-f valley, and a grid
#: 1.1-1.2x too coarse (the one resolved at a far start) moves the fit along it. It did not raise
#: the coverage of the 60-point cylinder benchmark's intervals (13 of 17 noise draws at 1.25, 20 of
#: 27 at 1.05; benchmarks/README.md). A re-resolved grid of the same class compiles nothing.
REGRID_FACTOR = 1.05

#: Most re-resolutions of the grid per fit (each a fit from the previous result).
MAX_REGRIDS = 3

#: A least-squares run on an automatic grid stops at an accepted point whose Gauss-Newton step is
#: within this many standard errors of the parameters (:func:`jaxroll._lsq.gauss_newton_distance`)
#: if the grid resolved there has moved by more than :data:`REGRID_FACTOR`: the run on that grid
#: takes over, so this one only had to bring the parameters into the envelope of the grid their
#: optimum needs, not to the optimum on its own grid (the sphere's cell size goes about as
#: G0^-1/3, and G0 has a standard error of ~25 % along the G0-tau-f valley of rolling data). On
#: the 60-point sphere benchmark 0.5 instead of 0.25 took 15 evaluations instead of 23, to a cost
#: 7e-5 lower (benchmarks/LOG.md, "The sphere fit's evaluation count").
REGRID_WITHIN = 0.5

#: Most programs per fit that :func:`fit_material` compiles ahead, in a background thread, for the
#: window of the grid resolved at the Gauss-Newton minimiser of an accepted point when that differs
#: from the run's (each window is a program of its own; on a machine with one processor none): the
#: compilation overlaps the run's remaining evaluations. On the 60-point sphere benchmark the
#: first evaluation at the start (window 41) already points to the final window (65) (benchmarks/LOG.md,
#: "The sphere fit's second program compiled ahead"). The window forecast's program
#: (:data:`FORECAST_WINDOW`) counts among them. ``0``: off (the forecast too).
COMPILE_AHEAD = 2

#: Whether a sphere's fit on an automatic grid forecasts, from its first moment, the window its
#: runs will need (:func:`_window_forecast`) and compiles that program ahead (counted in
#: :data:`COMPILE_AHEAD`; off with it).
FORECAST_WINDOW = True

#: Evaluations at most, and the tolerance, of the screening fit behind the window forecast
#: (:func:`_screening_fit`; tens of milliseconds each): the window needs the data's regime, not
#: the screening model's optimum (on the 60-point sphere benchmark 8 evaluations at 1e-3 against
#: 12 at 1e-6, the point within 1 %).
SCREENING_EVALUATIONS = 100
SCREENING_RTOL = 1e-3

#: Central-difference step [log-parameter units] of the screening fit's Jacobian: its program
#: compiles in less time than the forward-mode one (2.6 against 3.7 s of CPU for the 60-point
#: sphere benchmark, on the forecast's critical path), to the same point within 1e-5.
SCREENING_JAC_STEP = 1e-3


def _forecasts(auto, geometry) -> bool:
    """Whether :func:`fit_material` forecasts its window (:data:`FORECAST_WINDOW`): a sphere (its
    fit programs compile for 15-20 s each, a cylinder's for a few) on an automatic grid, with
    :data:`COMPILE_AHEAD` on and a processor free for the compilation (:func:`_free_processor`)."""
    from ..geometry import as_geometry

    return (FORECAST_WINDOW and COMPILE_AHEAD > 0 and auto is not None and as_geometry(geometry) == "sphere"
            and _free_processor())


def _processors() -> int:
    """Processors this process may run on (its affinity where the platform has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def _free_processor() -> bool:
    """Whether a second processor is free: at least two, and a load average (last minute) below
    their number less one half (where ``os.getloadavg`` is missing: the count alone). The
    forecast's screening fit and compilation pay only there: on 2 cores shared at load 4-5 the
    60-point sphere fit took 5-9 s more CPU with them and no consistent wall time less
    (benchmarks/LOG.md)."""
    n = _processors()
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):
        load = 0.0
    return n >= 2 and load < n - 0.5


def _window_forecast(work) -> threading.Thread:
    """Run ``work`` (the screening fit and the compilation it points to) in a background thread,
    beside the first run's own compilation; any error there is dropped (the forecast is an
    optimisation only: the fit compiles what it needs as usual). Not a daemon: an interpreter that
    ends while it compiles waits for it (a daemon thread stopped inside XLA aborts the process).

    Why a forecast works: the window of the full model's automatic grid is set by the cells per
    contact radius that the regime ``zeta = V tau / a`` of the slowest measured speeds asks for
    (:func:`jaxroll.grids.sphere_cells_per_radius`: 12 at zeta >= 0.32, 20 at 0.1-0.32) times the
    spread of contact sizes over the data, and any model that puts the rolling-resistance peak
    at the measured speeds puts the data's ``zeta`` where the full model does. On the 60-point
    sphere benchmark the start (2 MPa, 0.35 s, 0.7) has the smallest zeta 0.367 (a 41-cell
    window), the truth 0.300 and the fit's end 0.304 (65 cells); the direct method's fit lands at
    0.41 MPa, 0.49 s, 0.42, far along the G0-tau-f valley, at 0.305 (65 cells)
    (benchmarks/LOG.md, "The sphere fit's window forecast")."""
    def guarded():
        try:
            work()
        except Exception:  # noqa: BLE001  (a guess only: the fit compiles what it needs itself)
            pass

    thread = threading.Thread(target=guarded, name="jaxroll-window-forecast")
    thread.start()
    return thread


def _screening_fit(params, model, rolling, radius, geometry):
    """The unconstrained coordinates ``u`` of a least-squares fit of ``rolling`` by the direct
    method with the contact size of the dynamic modulus (:class:`jaxroll.Direct`, ``modulus=
    "dynamic"``: tens of milliseconds per evaluation) from ``model``: a point whose data regime is the
    full model's (:func:`_window_forecast`), not an estimate of the parameters (the direct method's
    fit is biased along the G0-tau-f valley)."""
    from ..methods import Direct

    problem = _Problem.of(params, radius, geometry, Direct(modulus="dynamic"), SCREENING_JAC_STEP)
    residuals, jacobian, _ = _host_functions(problem, model, _data_arrays(rolling, None, problem.method), False)
    return least_squares(residuals, jacobian, params.u_from_logp(params.logp0(model)), rtol=SCREENING_RTOL,
                         max_evaluations=SCREENING_EVALUATIONS).x


#: Rungs of the fit's window ladder per octave: the window's half-width in cells is rounded up to
#: ``ceil(2^(j/8))`` (at most 9 % wider), so that grids resolved at other parameters share the
#: window (a static shape) and differ only in the cell size (a traced value): one compiled program.
WINDOW_RUNGS_PER_OCTAVE = 8


def _window_rung(half: int) -> int:
    """The smallest rung ``ceil(2^(j/8)) >= half`` of the window ladder."""
    j = math.ceil(WINDOW_RUNGS_PER_OCTAVE * math.log2(max(half, 1)) - 1e-9)
    while math.ceil(2.0 ** ((j - 1) / WINDOW_RUNGS_PER_OCTAVE)) >= half and j > 0:
        j -= 1
    return math.ceil(2.0 ** (j / WINDOW_RUNGS_PER_OCTAVE))


def _on_ladder(method):
    """``method`` with the window of its (infinite-layer) grid widened to the next rung of the
    window ladder (same cell size and parity; a wider window changes no solution while the
    contact stays inside); periodic grids, whose window is bounded by the period, as given."""
    from ..grids import FixedGrid

    grid = method.grid
    if not isinstance(grid, FixedGrid) or grid.period is not None:
        return method
    window = 2 * _window_rung(grid.window // 2) + grid.window % 2
    return eqx.tree_at(lambda m: m.grid, method, FixedGrid(grid.spacing, window, n_terms=grid.n_terms))


#: Largest window [cells] of a line (cylinder) grid on which the default fit solves its contact
#: systems by LU (:class:`jaxroll.contact.Dense`) instead of GMRES: the same solution (the
#: 60-point cylinder benchmark, window 108: residuals and Jacobian equal to 5e-14), 3-4x less
#: time per evaluation there (0.12-0.17 s against 0.48 s of CPU) and a third less compilation. LU
#: grows like the window cubed: above this size GMRES is kept.
DENSE_MAX_WINDOW = 256


def _resolve_for_fit(method, material, layer, radius, rolling, geometry, dense_lines=False):
    """``(grid method, resolved grid)``: ``method`` with its :class:`~jaxroll.grids.AutoGrid`
    resolved over the data envelope (every measured speed and load) for ``material`` and
    ``layer`` (concrete values), its window on the ladder (:func:`_on_ladder`); and the grid as
    resolved (before the ladder), which :func:`_grid_moved` compares. ``dense_lines``: a line
    window of at most :data:`DENSE_MAX_WINDOW` cells gets the dense linear solver."""
    from ..contact import Dense

    # the distinct loads and speeds: the rule visits every load x speed pair of its envelope
    resolved = method.resolve(*_with_cover(material, layer), radius=radius, loads=np.unique(rolling.load),
                              speeds=np.unique(rolling.speed), geometry=geometry)
    out = _on_ladder(resolved)
    if dense_lines and geometry == "cylinder" and out.grid.window <= DENSE_MAX_WINDOW:
        out = eqx.tree_at(lambda m: m.linear_solver, out, Dense())
    return out, resolved.grid


def _grid_moved(old, new) -> bool:
    """Whether the cell size or the window width [m] of grid ``new`` differs from ``old`` by
    more than :data:`REGRID_FACTOR`."""
    ratios = (float(new.spacing) / float(old.spacing),
              float(new.spacing) * new.window / (float(old.spacing) * old.window))
    return any(max(r, 1 / r) > REGRID_FACTOR for r in ratios)


def _host_functions(problem, model, data, progress, ahead=None, carry=None):
    """Residual and Jacobian in the unconstrained coordinates ``u`` for the least-squares
    driver. Each point is evaluated once, residual and Jacobian together (scipy asks for the
    Jacobian at every accepted point right after its residual). The Jacobian call (made at
    accepted points) reports progress and passes ``(u, r, dr/du)`` to ``ahead`` (if given).
    ``carry``: a dict whose ``"starts"`` (if not ``None``) are the per-point starts of the first
    evaluation (:func:`_point_starts`' form, e.g. a previous run's on a grid of the same window),
    and into which each accepted point's own solutions are written as ``"finals"``."""
    params, names = problem.params, problem.params.names_flat()
    t_start, last, count = time.perf_counter(), {}, [0]
    # each evaluation's contact solves start from the solutions at the last accepted point (the
    # trust region's centre: every trial step starts from there), per point (:func:`_point_starts`)
    none = _point_starts(problem, model, data)
    carry = {} if carry is None else carry
    accepted = {"starts": none if none is None or carry.get("starts") is None else carry["starts"]}

    def evaluate(u):
        if "u" not in last or not np.array_equal(last["u"], u):
            logp, slope = params.logp_and_slope(u)
            starts = accepted["starts"]
            # (through the compilation cache's call: jaxroll's XLA options; not stored, its export costs more)
            out = _compilation_cache.call(_residuals_and_jacobian_jit, jnp.asarray(logp), model, data, problem, starts,
                                          store=False)
            if starts is not None and np.any(np.asarray(out[3]) & np.asarray(starts[0].valid)):
                # a solve from its own start did not converge: every point from its neighbour instead (a
                # point that fails without a start of its own fails cold too: no second evaluation for it)
                out = _compilation_cache.call(_residuals_and_jacobian_jit, jnp.asarray(logp), model, data, problem,
                                              none, store=False)
            finals = None if starts is None else out[2]
            r, Jl = (np.asarray(a) for a in out[:2])
            last.update(u=np.array(u), logp=logp, slope=slope, r=r, J_logp=Jl, finals=finals)
        return last

    def residuals(u):
        return evaluate(u)["r"]

    def jacobian(u):
        e = evaluate(u)
        if e["finals"] is not None and np.all(np.isfinite(e["r"])):
            accepted["starts"] = carry["finals"] = e["finals"]
        J = e["J_logp"] * e["slope"][None, :]
        if ahead is not None and np.all(np.isfinite(e["r"])) and np.all(np.isfinite(J)):
            ahead(u, e["r"], J)
        if progress:
            count[0] += 1
            values = dict(zip(names, np.exp(e["logp"]).tolist()))
            elapsed, chi2 = time.perf_counter() - t_start, float(e["r"] @ e["r"])
            if callable(progress):
                progress(count[0], chi2, values, elapsed)
            else:
                shown = "  ".join(f"{n}={v:.5g}" for n, v in values.items())
                print(f"fit: evaluation {count[0]:3d}  chi2 {chi2:.6g}  {shown}  ({elapsed:.1f} s)", flush=True)
        return J

    def at(u):
        """``(r, dr/dlogp)`` at ``u``."""
        e = evaluate(u)
        return e["r"], e["J_logp"]

    return residuals, jacobian, at


def _multistart(problem, model, data, *, solver, n_starts, spread_decades, seed, max_steps, rtol, progress,
                stop=None, ahead=None, carry=None):
    """Least squares from ``initial`` and ``n_starts - 1`` log-uniform draws around it; returns
    ``(u, converged, cost, r, dr/dlogp)`` of the best start and ``[(cost, converged), ...]``.
    ``stop``: the stopping rule ``(u, r, dr/du) -> bool`` of :func:`jaxroll._lsq.least_squares`."""
    params = problem.params
    residuals, jacobian, at = _host_functions(problem, model, data, progress, ahead, carry)
    rng = np.random.default_rng(seed)
    logp0 = params.logp0(model)
    starts, best = [], None
    for i in range(max(1, int(n_starts))):
        lp = logp0 if i == 0 else logp0 + rng.uniform(-0.5, 0.5, size=logp0.shape) * spread_decades * math.log(10)
        sol = least_squares(residuals, jacobian, params.u_from_logp(lp), method=solver, rtol=rtol,
                            max_evaluations=max_steps, stop=stop)
        ok = sol.converged and math.isfinite(sol.cost)
        starts.append((sol.cost, ok))
        if best is None or (math.isfinite(sol.cost) and sol.cost < best[0]):
            best = (sol.cost, ok, sol.x)
    cost, converged, u = best
    r, J = at(u)
    return u, converged, cost, r, J, starts


def _noise_scale(r, k, absolute_sigma):
    """``s^2``: 1 with absolute sigma, else the reduced chi^2 ``|r|^2/(n - k)``."""
    return 1.0 if absolute_sigma else float(np.sum(r**2)) / max(len(r) - k, 1)


def _uncertainty(params, logp, r, J, absolute_sigma, ends=None):
    """Gauss-Newton covariance of the log-parameters and the per-parameter values, standard
    errors (delta method) and 95 % intervals: log-normal, or from ``ends = (low, high)`` (the
    log-parameter endpoints of profile-likelihood intervals, :func:`_profile`)."""
    s2 = _noise_scale(r, params.size, absolute_sigma)
    cov = np.linalg.pinv(J.T @ J) * s2
    sd_log = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd_log, sd_log)
    low, high = (logp - Z95 * sd_log, logp + Z95 * sd_log) if ends is None else ends
    values, stderr, ci = {}, {}, {}
    i = 0
    for n, size, shape in zip(params.free, params.sizes, params.shapes):
        lp, sd = logp[i : i + size], sd_log[i : i + size]
        values[n] = np.exp(lp).reshape(shape)
        stderr[n] = (np.exp(lp) * sd).reshape(shape)
        with np.errstate(over="ignore"):
            ci[n] = (np.exp(low[i : i + size]).reshape(shape), np.exp(high[i : i + size]).reshape(shape))
        i += size
    return values, stderr, ci, cov, corr, sd_log


#: Profile-likelihood intervals (:func:`_profile`): an endpoint is accepted where the signed root
#: of the profiled chi^2 increase, ``sqrt(2 (C_profile - C_min)/s^2)``, is within this of
#: :data:`Z95` (an error of 0.05 in the root moves the coverage by < 0.3 %).
PROFILE_ROOT_TOL = 0.05

#: A bracket of an endpoint narrower than this [log-parameter units, 0.2 %] is settled (a steep
#: profile: the root tolerance would ask for more points that move the endpoint by less).
PROFILE_BRACKET = 2e-3

#: Most profile points (constrained fits) per interval endpoint (secant steps on the signed root).
PROFILE_STEPS = 8

#: Widest profile search [log-parameter units] on either side of the optimum: a profile that
#: stays below the threshold that far leaves its interval open (0 or infinity) on that side.
PROFILE_SPAN = 10.0

#: A point on a profile whose cost is lower than the fit's by more than this (0.5 chi^2 units)
#: is a lower minimum along the valley: the fit restarts from it (:func:`fit_material`).
LOWER_MINIMUM = 0.05

#: Most restarts from a lower point found by the profiles.
MAX_VALLEY_RESTARTS = 2

#: Most least-squares runs after the first start: up to :data:`MAX_REGRIDS` re-resolved grids
#: before and after each of up to :data:`MAX_VALLEY_RESTARTS` restarts (``FitResult.starts``
#: holds one entry per run).
MAX_REFITS = (1 + MAX_VALLEY_RESTARTS) * MAX_REGRIDS + MAX_VALLEY_RESTARTS


def _profile(residuals, jacobian, u, cost, cov_u, s2, *, rtol, max_evaluations):
    """Profile-likelihood 95 % intervals of the unconstrained coordinates ``u`` (Venzon and
    Moolgavkar's endpoints): for each coordinate ``j`` and side, the value where the minimum of
    the cost over the other coordinates, ``C_j``, has risen by ``Z95^2 s^2 / 2`` above the fit's
    ``cost`` (the likelihood-ratio test at 95 %, chi^2 with 1 dof). The endpoints are found by
    secant steps on the signed root ``sqrt(2 (C_j - cost)/s^2)`` (nearly linear in ``u_j``),
    starting from the linearised endpoint, each constrained fit warm-started along the profile.

    Returns ``(low, high, messages, lower)``: endpoint arrays (``-inf``/``inf`` where the profile
    stays below the threshold within :data:`PROFILE_SPAN`), notes on endpoints not settled, and
    ``(cost, u)`` of a point with a cost lower than the fit's by :data:`LOWER_MINIMUM` (then the
    endpoints are not computed: the fit is not at the valley's minimum)."""
    k = len(u)
    low, high, messages = np.full(k, -np.inf), np.full(k, np.inf), []
    for j in range(k):
        for side, ends in ((-1.0, low), (1.0, high)):
            end, settled, lower = _profile_side(residuals, jacobian, u, cost, cov_u, s2, j, side, rtol=rtol,
                                                max_evaluations=max_evaluations)
            if lower is not None:
                return low, high, messages, lower
            ends[j] = end
            if not settled:
                messages.append((j, side))
    return low, high, messages, None


def _profile_side(residuals, jacobian, u, cost, cov_u, s2, j, side, *, rtol, max_evaluations):
    """One endpoint of :func:`_profile`: ``(u_j endpoint, settled, lower point or None)``."""
    others = np.arange(len(u)) != j

    def full(d, v):
        x = u.copy()
        x[j], x[others] = u[j] + d, v
        return x

    def point(d, warm):  # the profile at u_j + d: the other coordinates fitted
        if not others.any():
            return warm, 0.5 * float(np.sum(np.asarray(residuals(full(d, warm))) ** 2))
        try:
            sol = least_squares(lambda v: residuals(full(d, v)), lambda v: jacobian(full(d, v))[:, others], warm,
                                rtol=rtol, max_evaluations=max_evaluations)
        except ValueError:  # scipy: residuals not finite at the start (the model failed there)
            return warm, math.inf
        return sol.x, sol.cost

    sd = math.sqrt(max(cov_u[j, j], 1e-300))
    slope = cov_u[others, j] / max(cov_u[j, j], 1e-300)  # the others' linearised response to u_j
    inside, last, outside = (0.0, 0.0, u[others]), None, None  # (d, root, v): root below / above Z95
    previous = inside
    d = side * Z95 * max(sd, 1e-3)  # the linearised endpoint (at least 0.2 % away)
    warm = u[others] + slope * d
    for _ in range(PROFILE_STEPS):
        v, c = point(d, warm)
        if c < cost - LOWER_MINIMUM:
            return None, False, (c, full(d, v))
        r = math.sqrt(max(2.0 * (c - cost) / s2, 0.0)) if math.isfinite(c) else math.inf  # a failed model: out
        if abs(r - Z95) <= PROFILE_ROOT_TOL:
            return u[j] + d, True, None
        if r < Z95:
            last, inside = inside, (d, r, v)
        else:
            outside = (d, r, v)
        if outside is None:  # not bracketed: outward along the secant of the last two inside points
            (d0, r0, v0), (d1, r1, v1) = last, inside
            t = (Z95 - r0) / (r1 - r0) if r1 > r0 else 4.0
            t = min(max(t, 1.25), 4.0 * abs(d1) / max(abs(d1 - d0), 1e-300))  # 1.25-4x further
        elif abs(outside[0] - inside[0]) <= PROFILE_BRACKET:  # bracketed closely enough
            t = (Z95 - inside[1]) / (outside[1] - inside[1])
            return u[j] + inside[0] + t * (outside[0] - inside[0]), True, None
        else:  # bracketed: the secant of the last two points, or regula falsi where it leaves the bracket
            (d0, r0, v0), (d1, r1, v1) = previous, (d, r, v)
            t = (Z95 - r0) / (r1 - r0) if r1 != r0 else np.inf
            if not min(inside[0], outside[0]) < d0 + t * (d1 - d0) < max(inside[0], outside[0]):
                (d0, r0, v0), (d1, r1, v1) = inside, outside
                t = (Z95 - r0) / (r1 - r0) if math.isfinite(r1) else 0.5  # bisect toward a failed point
        previous = (d, r, v)
        new = d0 + t * (d1 - d0)
        if abs(new) > PROFILE_SPAN:
            return side * np.inf, True, None
        d, warm = new, v0 + t * (v1 - v0)  # the others interpolated along the profile
    return u[j] + d, False, None


def _valley_fit(rolling, dma, method, geometry) -> bool:
    """Whether ``intervals="auto"`` profiles: rolling data alone (no DMA data to pin the moduli)
    of a cylinder fitted with the default fitting model (``method`` None or equal to
    ``default_method(geometry, fit=True)``), whose G0-tau-f valley was measured to be curved.
    Not the sphere: its profiles would cost about 5x its fit (157-173 s of CPU on 2 shared cores for
    the shipped 60 points, 44-144 s per noise draw compiled; benchmarks/LOG.md), and 17 seeded
    draws are too few to say its linearised intervals are too narrow (14 of 17 held the truth;
    ``intervals="profile"`` asks for profiles)."""
    from ..geometry import as_geometry
    from ..methods import default_method

    return (rolling is not None and dma is None and as_geometry(geometry) == "cylinder"
            and (method is None or method == default_method(geometry, fit=True)))


def _profile_intervals(params, problem, model, data, u, cost, r, J, absolute_sigma, *, rtol, max_steps, progress):
    """``(ends, messages, lower)``: the log-parameter endpoints ``(low, high)`` of the
    profile-likelihood 95 % intervals at the fit ``u`` (:func:`_profile` in the unconstrained
    coordinates, mapped through the bounds), notes on endpoints not settled, and a lower point
    ``(cost, u)`` if a profile found one (then ``ends`` is None)."""
    residuals, jacobian, _ = _host_functions(problem, model, data, progress)
    slope = params.logp_and_slope(u)[1]
    s2 = _noise_scale(r, params.size, absolute_sigma)
    cov_u = np.linalg.pinv(J.T @ J) * s2 / np.outer(slope, slope)
    low, high, unsettled, lower = _profile(residuals, jacobian, np.asarray(u, float), cost, cov_u, s2, rtol=rtol,
                                           max_evaluations=max_steps)
    if lower is not None:
        return None, [], lower

    def to_logp(j, end):
        x = np.array(u, float)
        x[j] = end
        return params.logp_and_slope(x)[0][j]

    ends = tuple(np.array([to_logp(j, e) for j, e in enumerate(side)]) for side in (low, high))
    names = params.names_flat()
    notes = [f"the profile-likelihood interval of {names[j]!r} did not settle on its {'low' if side < 0 else 'high'} "
             f"side in {PROFILE_STEPS} steps: that endpoint is approximate" for j, side in unsettled]
    return ends, notes, None


def _diagnostics(names, r, J, corr, sd_log, have_sigma):
    """Misfit and identifiability messages (a chi^2 test with measured sigma; rank deficiency;
    poorly constrained and almost fully correlated parameters)."""
    messages = []
    chi2, dof = float(np.sum(r**2)), max(len(r) - len(names), 1)
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
    for j, n in enumerate(names):
        if not np.isfinite(sd_log[j]) or sd_log[j] > 0.5:
            hint = (" (for rolling-resistance data: include speeds around the resistance peak, V ~ contact "
                    "radius/tau, or add DMA data)" if n in ("tau", "f") else "")
            messages.append(f"parameter {n!r} is poorly constrained: relative standard error "
                            f"{100 * sd_log[j]:.0f} %{hint}")
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            if np.isfinite(corr[a, b]) and abs(corr[a, b]) > 0.995:
                messages.append(f"parameters {names[a]!r} and {names[b]!r} are almost fully correlated "
                                f"({corr[a, b]:+.4f}): the data constrain only a combination of them")
    return messages


def fit_material(
    rolling: RollingData | None = None,
    dma: DMAData | None = None,
    *,
    initial,
    layer=None,
    radius=None,
    geometry="sphere",
    method=None,
    free=None,
    shift=None,
    bounds=None,
    solver="trf",
    n_starts=1,
    spread_decades=2.0,
    seed=0,
    absolute_sigma=False,
    max_steps=500,
    rtol=None,
    jac_step=None,
    intervals="auto",
    progress=False,
) -> FitResult:
    """Identify viscoelastic parameters from rolling resistance and/or DMA data.

    Args:
        rolling: :class:`RollingData` (speeds [m/s], loads [N or N/m], measured ``R_r`` [N or
            N/m], optional sigma), or ``None`` for a DMA-only fit.
        dma: :class:`DMAData` to fit jointly (or alone); its optional ``storage_sigma`` and
            ``loss_sigma`` weight the residuals (default relative).
        initial: initial material (:class:`StandardLinearSolid` or :class:`GeneralizedMaxwell`);
            the fitted material has the same type.
        layer: :class:`jaxroll.Layer` (required with rolling data; ``"H"`` may be free), or a
            :class:`jaxroll.Stack`: its top ply's material is the one fitted (``initial`` takes
            its place), the other plies and the base stay as given, and ``"H"`` is the top
            ply's thickness; ``FitResult.layer`` is the stack with the fitted material on top.
        radius: roller radius [m] (required with rolling data).
        geometry, method: passed to :func:`jaxroll.rolling_resistance` (a method object or a
            shortcut string). Default: ``jaxroll.methods.default_method(geometry, fit=True)``,
            the full model with the smoothed contact edge extrapolated to ``kappa -> 0``
            (``edge_extrapolation``: smooth in the parameters, the smoothing's bias mostly
            removed; the exact discrete R_r wiggles with the contact set and the iteration stalls
            on it: the study is in benchmarks/LOG.md). A method with an
            :class:`~jaxroll.grids.AutoGrid` is resolved here over the data envelope (every
            measured speed and load) at ``initial``; while the grid resolved at the fitted
            parameters differs by more than :data:`REGRID_FACTOR` in cell size or window width,
            it is resolved there and the fit restarts from the fitted point (at most
            :data:`MAX_REGRIDS` times; a run stops early, within :data:`REGRID_WITHIN` standard
            errors of its optimum, where the grid at its point has moved). A
            :class:`jaxroll.FixedGrid` is used as given. The full model is evaluated on the
            table of the distinct speeds x loads (:func:`jaxroll.rolling_resistance_grid`).
        free: names of the free parameters (material fields, ``"H"``, ``"C1"``/``"C2"``);
            default: the material's own parameters (``G0, tau, f`` for a standard linear solid,
            ``G_inf, G, tau`` for a generalized Maxwell material).
        shift: WLF/Arrhenius shift for DMA data at several temperatures.
        bounds: ``{name: (lo, hi)}`` physical bounds.
        solver: ``"trf"`` (trust-region reflective, default) or ``"lm"`` (MINPACK
            Levenberg-Marquardt), both :func:`scipy.optimize.least_squares` on the compiled
            residual and Jacobian.
        n_starts: number of starts; the first is ``initial``, the others are drawn
            log-uniformly within ``spread_decades`` decades around it (seeded by ``seed``).
        absolute_sigma: treat sigma as absolute (covariance not rescaled by chi^2).
        max_steps: cap on residual evaluations per start; rtol: relative tolerance on the
            cost reduction and the step, absolute on the gradient (``None``: 1e-10, or
            :data:`FULL_MODEL_RTOL` for rolling data with the default method, the full model,
            whose contact solver tolerance and grid ripple make smaller cost changes noise; the
            intervals are set by a chi^2 change of order 1, 1e6 times larger).
        jac_step: ``None`` (default): Jacobian by AD (:func:`_residuals_and_jacobian_jit`). A
            float ``h``: central differences in the log-parameters with step ``h``, e.g. for
            models that are only piecewise smooth at a fixed resolution (a full model without
            ``edge_smoothing``: the contact area changes in whole cells; benchmarks/LOG.md has
            the study of what this does and does not fix).
        intervals: ``"profile"``: the 95 % intervals from the profile likelihood (per parameter
            and side, a few fits of the other parameters with it held fixed: about 100 further
            evaluations for three parameters; a profile that finds a lower cost restarts the fit
            there, at most :data:`MAX_VALLEY_RESTARTS` times); ``"linear"``: from the
            Gauss-Newton covariance (no further evaluations); ``"auto"`` (default): profiles
            for a cylinder's rolling data alone fitted with the default method (also when named;
            not the sphere, whose profiles would cost ~5x its fit), whose
            G0-tau-f valley is curved (there the linearised intervals held the truth in 74-78 %
            of seeded noise draws and the fit could stop in a second minimum along the valley;
            benchmarks/LOG.md), linearised otherwise (DMA data pin the moduli; the other
            methods' intervals were measured honest). ``stderr`` and ``covariance`` are
            linearised either way.
        progress: print one line per residual+Jacobian evaluation (evaluation count, chi^2,
            parameters, elapsed time) for long fits (a full model: seconds per evaluation), or a
            callable ``progress(count, chi2, params_dict, seconds)``.

    The residual and Jacobian are compiled once per static configuration (free parameters,
    bounds, method, geometry, radius, data shapes, the grid's window): repeated fits of data of
    the same shape do not recompile, nor does a re-resolved grid of the same class (its cell size
    is a traced value, its window rounded up to a ladder of 2^(1/8) steps). The default method on a
    cylinder solves its contact systems by LU where the window has at most
    :data:`DENSE_MAX_WINDOW` cells (the same numbers, less time).

    Returns:
        :class:`FitResult`.
    """
    if solver not in ("trf", "lm"):
        raise ValueError(f"solver must be 'trf' or 'lm', got {solver!r}")
    free = _DEFAULT_FREE[type(initial)] if free is None and type(initial) in _DEFAULT_FREE else free
    if rtol is None:  # the default full model's tolerance; any named method keeps 1e-10
        rtol = FULL_MODEL_RTOL if method is None and rolling is not None else 1e-10
    dense_lines = method is None  # the default method: LU on small line windows (same numbers)
    if intervals not in ("auto", "profile", "linear"):
        raise ValueError(f"intervals must be 'auto', 'profile' or 'linear'; got {intervals!r}")
    profiled = intervals == "profile" or (intervals == "auto" and _valley_fit(rolling, dma, method, geometry))
    method = _check_problem(rolling, dma, initial, free or (), layer, radius, geometry, method, shift)
    check_plausible("fit_material", radius=radius, H=None if layer is None else layer.H,
                    speed=None if rolling is None else rolling.speed)
    model = (initial, layer, shift)  # arrays traced, Python floats (a static rho = 0) part of the key
    params = _Params.of(model, free, bounds)
    n_res = (0 if rolling is None else len(rolling.value)) + (0 if dma is None else 2 * len(dma.omega))
    if n_res < params.size:
        raise ValueError(f"{n_res} residuals cannot determine {params.size} parameters")
    auto = method if method is not None and method.needs_resolution(geometry) else None
    method, resolved = (method, None) if auto is None else _resolve_for_fit(auto, initial, layer, radius, rolling,
                                                                          geometry, dense_lines)

    noise = 1.0 if absolute_sigma else None

    def at(params, u, model):
        return params.build(jnp.asarray(params.logp_and_slope(u)[0]), model)

    def stopping(params, model, resolved):
        """The run's stopping rule besides rtol (an automatic grid): within REGRID_WITHIN standard
        errors of the optimum where the grid resolved at the point has moved (the run on the grid
        the point needs takes over)."""
        def stop(u, r, J):
            return gauss_newton_distance(r, J, noise) <= REGRID_WITHIN and _grid_moved(
                resolved, _resolve_for_fit(auto, *at(params, u, model)[:2], radius, rolling, geometry, dense_lines)[1])

        return None if auto is None else stop

    def setup(method, model):
        """``(params, problem, data)`` of a run on ``method``'s grid from ``model``."""
        params = _Params.of(model, free, bounds)
        problem = _Problem.of(params, None if rolling is None else radius, geometry, method, jac_step)
        return params, problem, _data_arrays(rolling, dma, method)

    ahead_windows, ahead_lock = set(), threading.Lock()

    def compile_window_of(target, window):
        """Where the grid resolved at the model ``target`` has a window other than ``window`` and
        those compiled ahead (a program of its own), that program compiles in a background thread
        (at most :data:`COMPILE_AHEAD` per fit)."""
        guess = _resolve_for_fit(auto, *target[:2], radius, rolling, geometry, dense_lines)[0]
        with ahead_lock:  # (the forecast's thread and the run's accepted points)
            if len(ahead_windows) >= COMPILE_AHEAD or guess.grid.window in ahead_windows | {window}:
                return
            ahead_windows.add(guess.grid.window)
        g_params, g_problem, g_data = setup(guess, target)
        _compilation_cache.compile_ahead(_residuals_and_jacobian_jit, jnp.asarray(g_params.logp0(target)),
                                         target, g_data, g_problem, _point_starts(g_problem, target, g_data))

    def compiling_ahead(params, model, method):
        """At an accepted point of a run on an automatic grid: where the grid resolved at the
        Gauss-Newton minimiser has another window, its program compiles ahead while the run goes on."""
        def ahead(u, r, J):
            try:  # a guess and an optimisation only: a minimiser the model or the grid rule rejects
                compile_window_of(at(params, u - np.linalg.lstsq(J, r, rcond=None)[0], model), method.grid.window)
            except (ValueError, FloatingPointError, np.linalg.LinAlgError):
                return

        return None if auto is None or _processors() < 2 else ahead

    if _forecasts(auto, geometry):  # the window the fit will need, compiled from the start (_window_forecast)
        def forecast(params=params, model=model, window=method.grid.window):  # (this run's, bound now)
            compile_window_of(at(params, _screening_fit(params, model, rolling, radius, geometry), model), window)

        _window_forecast(forecast)

    carried = {}  # the per-point solutions at the last accepted point and the grid they are on

    def run(method, model, n_starts, resolved, may_stop=True):
        """One least-squares run (``may_stop``: with the early stop of :data:`REGRID_WITHIN`, only
        where a regrid can still follow, so that the fit never ends on an early-stopped run); its
        first evaluation starts from the previous run's last accepted point where the window is the
        same (:func:`_carried_starts`)."""
        params, problem, data = setup(method, model)
        grid = getattr(method, "grid", None)  # (None: DMA data alone)
        box = {"starts": _carried_starts(carried.get("finals"), carried.get("grid"), grid)}
        out = _multistart(problem, model, data, solver=solver, n_starts=n_starts, spread_decades=spread_decades,
                          seed=seed, max_steps=max_steps, rtol=rtol, progress=progress,
                          stop=stopping(params, model, resolved) if may_stop else None,
                          ahead=compiling_ahead(params, model, method) if may_stop else None, carry=box)
        carried.update(finals=box.get("finals"), grid=grid)
        return params, problem, data, out

    params, problem, data, (u, converged, cost, r, J, starts) = run(method, model, n_starts, resolved,
                                                                    may_stop=MAX_REGRIDS > 0)
    ends, profile_notes = None, []
    for restart in range(MAX_VALLEY_RESTARTS + 1):
        for regrid in range(MAX_REGRIDS if auto is not None else 0):  # the fit left the grid's envelope: again
            again, again_resolved = _resolve_for_fit(auto, *at(params, u, model)[:2], radius, rolling, geometry,
                                                     dense_lines)
            if not _grid_moved(resolved, again_resolved):
                break
            method, model, resolved = again, at(params, u, model), again_resolved
            params, problem, data, (u, converged, cost, r, J, more) = run(method, model, 1, resolved,
                                                                          may_stop=regrid < MAX_REGRIDS - 1)
            starts = starts + more
        if not profiled:
            break
        ends, profile_notes, lower = _profile_intervals(params, problem, model, data, u, cost, r, J, absolute_sigma,
                                                        rtol=rtol, max_steps=max_steps, progress=progress)
        if lower is None:
            break
        if restart == MAX_VALLEY_RESTARTS:  # still not at the valley's minimum: linearised intervals
            profile_notes = [f"a profile found a lower cost ({lower[0]:.6g} < {cost:.6g}) after "
                             f"{MAX_VALLEY_RESTARTS} restarts; the intervals are linearised"]
            break
        model = at(params, lower[1], model)  # a lower point along the valley: fit again from it
        params, problem, data, (u, converged, cost, r, J, more) = run(method, model, 1, resolved)
        starts = starts + more
    logp = params.logp_and_slope(u)[0]
    values, stderr, ci, cov, corr, sd_log = _uncertainty(params, logp, r, J, absolute_sigma, ends)
    names = params.names_flat()
    have_sigma = ((rolling is None or rolling.sigma is not None)
                  and (dma is None or dma.storage_sigma is not None))
    messages = _diagnostics(names, r, J, corr, sd_log, have_sigma) + profile_notes
    for m in messages:
        warnings.warn(m, MisfitWarning if m.startswith("reduced chi^2") else IdentifiabilityWarning, stacklevel=2)
    material, lay, sh = params.build(jnp.asarray(logp), model)
    lay = lay if lay is None else _with_cover(material, lay)[1]
    check_plausible("fit_material: fitted", G0=material.relaxed_modulus(),
                    H=cover_thickness(lay) if lay is not None and "H" in names else None)
    dof = max(n_res - params.size, 1)
    return FitResult(material=material, layer=lay, shift=sh, params=values, stderr=stderr, ci95=ci, covariance=cov,
                     correlation=corr, names=names, converged=bool(converged), residuals=np.asarray(r),
                     cost=float(cost), reduced_chi2=float(np.sum(r**2)) / dof, starts=starts, warnings=messages,
                     jacobian=J, method=method, interval_method="linearised" if ends is None else "profile",
                     sigma_mode=("absolute" if absolute_sigma else "scaled") if have_sigma else "relative")
