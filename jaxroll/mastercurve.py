"""Material identification from raw multi-temperature DMA: frequency sweeps at several
temperatures -> time-temperature superposition (shift factors, WLF / Arrhenius with
uncertainties) -> master curve -> Prony series (generalized Maxwell) -> exports for FE codes
and for jaxroll itself.

Pipeline (all SI: angular frequency [rad/s], shear moduli [Pa], temperatures [K], times [s]):

1. :func:`read_dma_sweeps`: an instrument-style CSV (pyvisco's layout ``f, E_stor, E_loss, T,
   Set`` with a units row, or units in the names ``E_stor [MPa]``; tension ``E``, or shear
   ``G``). Tensile moduli become shear moduli through ``G = E / (2 (1 + nu))`` (``nu = 0.5``:
   ``G = E/3``).
2. :func:`fit_shift_factors`: the horizontal shift of each temperature set onto its already
   shifted neighbour (nearer the reference), minimising the robust distance between the
   log-log curves (``log G'`` and ``log G''``) over their overlap; then :func:`fit_wlf` /
   :func:`fit_arrhenius` to ``log10 a_T`` with covariances from the least-squares Jacobian and
   :func:`master_curve`.
3. :func:`fit_prony`: non-negative least squares of a generalized Maxwell series on
   log-spaced relaxation times (storage and loss jointly, relative residuals), optionally
   refined in JAX (least squares on ``log G_i, log tau_i``, jitted residual and Jacobian).
4. :func:`write_abaqus`, :func:`write_ansys`, :func:`save_material` / :func:`load_material`.

Shift-factor convention (jaxroll's): the material at ``T`` behaves as the reference material
at ``omega a_T``; ``log10 a_T > 0`` below the reference temperature.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from ._lsq import least_squares
from .fit import Z95
from .io import UNITS, Column, read_table, write_table
from .material import GAS_CONSTANT, WLF, Arrhenius, GeneralizedMaxwell

__all__ = [
    "DMASweeps",
    "ShiftFactors",
    "ShiftFit",
    "MasterCurve",
    "PronyFit",
    "read_dma_sweeps",
    "fit_shift_factors",
    "fit_wlf",
    "fit_arrhenius",
    "master_curve",
    "loss_artifacts",
    "fit_prony",
    "prony_moduli",
    "write_abaqus",
    "write_ansys",
    "save_material",
    "load_material",
    "ResistanceMap",
    "resistance_map",
]

# ----------------------------------------------------------------------------------------
# reading


@dataclasses.dataclass(frozen=True)
class DMASweeps:
    """Frequency sweeps at several temperatures, in shear, SI.

    Attributes:
        omega: angular frequency [rad/s] per row.
        storage, loss: shear storage / loss modulus ``G'``, ``G''`` [Pa] per row.
        temperature: temperature [K] per row (the set's value where the file gives it per set).
        set: index of the temperature set of each row, ``0 .. n_sets-1`` in increasing
            temperature.
        set_temperature: mean temperature of each set [K], increasing.
        source: how the moduli were obtained (``"shear"`` or ``"tension, nu = 0.5"``).
    """

    omega: np.ndarray
    storage: np.ndarray
    loss: np.ndarray
    temperature: np.ndarray
    set: np.ndarray
    set_temperature: np.ndarray
    source: str = "shear"

    def __post_init__(self):
        n = len(self.omega)
        for name in ("storage", "loss", "temperature", "set"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"DMASweeps: {name} has {len(getattr(self, name))} entries, omega has {n}")
        for name in ("omega", "storage", "loss", "temperature", "set_temperature"):
            x = np.asarray(getattr(self, name), float)
            if not np.all(np.isfinite(x) & (x > 0)):
                raise ValueError(f"DMASweeps: {name} must be finite and positive")
        if np.any(np.diff(self.set_temperature) <= 0):
            raise ValueError("DMASweeps: set temperatures must increase with the set index")

    @property
    def n_sets(self) -> int:
        return len(self.set_temperature)

    def select(self, i):
        """``(omega, storage, loss)`` of set ``i``, sorted by frequency."""
        m = self.set == i
        order = np.argsort(self.omega[m])
        return self.omega[m][order], self.storage[m][order], self.loss[m][order]


def _sweep_columns():
    """The columns of a raw DMA file (names case-insensitive)."""
    mod, opt = UNITS["modulus"], dict(required=False, positive=True)
    return [
        Column("frequency", UNITS["frequency"], aliases=("f", "freq", "omega", "angular_frequency"), **opt),
        Column("E_storage", mod, aliases=("e_stor", "e'", "estor", "storage_modulus_e"), **opt),
        Column("E_loss", mod, aliases=("e_loss", "e''", "eloss", "loss_modulus_e"), **opt),
        Column("G_storage", mod, aliases=("g_stor", "g'", "gstor", "storage_modulus"), **opt),
        Column("G_loss", mod, aliases=("g_loss", "g''", "gloss", "loss_modulus"), **opt),
        Column("temperature", UNITS["temperature"], aliases=("t", "temp"), blank=True, **opt),
        Column("set", None, aliases=("set_id", "segment", "step"), required=False),
    ]


def _cluster_temperatures(T, tol=1.0):
    """Set index per row from temperatures alone: sorted values split at gaps > ``tol`` [K]."""
    order = np.argsort(T)
    labels = np.empty(len(T), int)
    labels[order] = np.concatenate([[0], np.cumsum(np.diff(T[order]) > tol)])
    return labels


def read_dma_sweeps(path, *, poisson=0.5) -> DMASweeps:
    """Read raw multi-temperature DMA (frequency sweeps at several temperatures).

    The file: a header row of names, then an optional row of units (or units in the names,
    ``E_stor [MPa]``), then data rows; blank lines and lines starting with ``#`` are skipped; a
    UTF-8 byte-order mark is accepted. Columns (case-insensitive):

    * frequency: ``f`` / ``freq`` / ``frequency`` / ``omega`` in ``Hz`` or ``rad/s``;
    * tension ``E_stor``, ``E_loss`` (or ``E'``, ``E''``) or shear ``G_stor``, ``G_loss`` (or
      ``G'``, ``G''``, ``storage_modulus``, ``loss_modulus``) in ``Pa``/``kPa``/``MPa``/``GPa``;
    * temperature: ``T`` / ``temp`` / ``temperature`` in ``C`` (``degC``, ``°C``) or ``K``, on
      every row, or per set (on at least one row of each set, the other cells empty);
    * optional ``Set``: the set (temperature step) of each row; without it rows are grouped by
      temperature (sets more than 1 K apart).

    Args:
        path: the CSV file.
        poisson: Poisson's ratio [-] that converts tensile moduli to shear,
            ``G = E / (2 (1 + nu))`` (default 0.5, incompressible: ``G = E/3``). Unused for
            shear data.

    Returns:
        :class:`DMASweeps` (shear moduli [Pa], omega [rad/s], temperatures [K]).

    Raises:
        ValueError: naming the line and column of what is wrong.
    """
    if not (0.0 <= poisson <= 0.5):
        raise ValueError(f"poisson must be in [0, 0.5]; got {poisson}")
    t = read_table(path, _sweep_columns(), units_row="optional", kind="DMA", case_sensitive=False)
    path = t.path
    tension = {m for m in ("E", "G") if f"{m}_storage" in t or f"{m}_loss" in t}
    if len(tension) > 1:
        raise ValueError(f"{path}: storage and loss moduli mix tension (E) and shear (G): "
                         f"{sorted(t.header.values())}")
    mode = tension.pop() if tension else "G"
    missing = [r for r, c in (("frequency", "frequency"), ("storage", f"{mode}_storage"), ("loss", f"{mode}_loss"),
                              ("temperature", "temperature")) if c not in t]
    if missing:
        raise ValueError(f"{path}: no column for {missing}; the header has {sorted(t.header.values()) + t.unused} "
                         f"(expected e.g. f, E_stor, E_loss, T[, Set] or f, G_stor, G_loss, T)")
    if "set" not in t and np.any(np.isnan(t["temperature"])):
        k = int(np.argmax(np.isnan(t["temperature"])))
        raise ValueError(f"{path}, line {t.lines[k]}: missing value in column {t.header['temperature']!r} (without a "
                         f"Set column every row needs its temperature)")
    omega = t["frequency"]
    factor = 1.0 / (2.0 * (1.0 + poisson)) if mode == "E" else 1.0
    storage = t[f"{mode}_storage"] * factor
    loss = t[f"{mode}_loss"] * factor
    T = t["temperature"].copy()
    lines = t.lines
    if "set" in t:
        raw_set = t["set"]
        labels = np.unique(raw_set, return_inverse=True)[1].ravel()
        for s in range(labels.max() + 1):  # temperature per set: fill the blanks
            m = labels == s
            if np.all(np.isnan(T[m])):
                raise ValueError(f"{path}, line {lines[m][0]}: set {raw_set[m][0]:g} has no temperature")
            T[m & np.isnan(T)] = np.nanmean(T[m])
    else:
        labels = _cluster_temperatures(T)
    set_T = np.array([T[labels == s].mean() for s in range(labels.max() + 1)])
    order = np.argsort(set_T)
    if np.any(np.diff(set_T[order]) <= 0):
        raise ValueError(f"{path}: two sets have the same mean temperature")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    source = f"tension, nu = {poisson:g}" if mode == "E" else "shear"
    return DMASweeps(omega, storage, loss, T, rank[labels], set_T[order], source)


# ----------------------------------------------------------------------------------------
# time-temperature superposition


@dataclasses.dataclass(frozen=True)
class ShiftFactors:
    """Horizontal shift factors of the temperature sets (:func:`fit_shift_factors`).

    Attributes:
        temperature: set temperatures [K], increasing.
        log10_aT: ``log10 a_T`` per set (0 at the reference set).
        sigma: standard error of ``log10 a_T`` (steps from the reference set accumulated as
            independent errors; 0 at the reference).
        step_sigma: standard error of each set's shift onto its neighbour.
        T_ref: reference temperature [K] (the reference set's mean temperature).
        reference: index of the reference set.
    """

    temperature: np.ndarray
    log10_aT: np.ndarray
    sigma: np.ndarray
    step_sigma: np.ndarray
    T_ref: float
    reference: int


def _robust_scale(r):
    """Standard deviation from the median absolute deviation (robust to outliers)."""
    return 1.4826 * float(np.median(np.abs(r - np.median(r))))


def _robust_polyfit(x, y, deg=2, c=2.5, iters=30):
    """Polynomial fit by iteratively reweighted least squares, Huber weights first, then
    Cauchy weights ``1 / (1 + (r / (c s))^2)`` (an outlier such as a sweep's low first point
    loses its pull). Returns (coefficients, residuals, final weights)."""
    deg = min(deg, len(x) - 1)
    w = np.ones_like(y)
    for it in range(iters):
        p = np.polyfit(x, y, deg, w=np.sqrt(w))
        r = y - np.polyval(p, x)
        s = max(_robust_scale(r), 1e-12)
        w = (np.minimum(1.0, c * s / np.maximum(np.abs(r), 1e-300)) if it < iters // 2
             else 1.0 / (1.0 + (r / (c * s)) ** 2))
    return p, r, w


class _SetCurve:
    """Smooth log-log curve of one set: a robust quadratic in ``x = log10 omega`` per column
    (``log10 G'``, ``log10 G''``), extended linearly beyond the set's range."""

    def __init__(self, x, Y):
        self.lo, self.hi, self.offset = float(x.min()), float(x.max()), 0.0
        fits = [_robust_polyfit(x, Y[:, k]) for k in range(Y.shape[1])]
        self.coef = [f[0] for f in fits]
        self.resid = np.stack([f[1] for f in fits], axis=1)
        self.weight = np.stack([f[2] for f in fits], axis=1)  # per point: ~0 for outliers

    def shifted(self, d):
        """The same curve moved by ``d`` decades along ``x``."""
        out = object.__new__(_SetCurve)
        out.__dict__.update(self.__dict__, lo=self.lo + d, hi=self.hi + d, offset=self.offset + d)
        return out

    def __call__(self, x):
        x = x - self.offset
        lo, hi = self.lo - self.offset, self.hi - self.offset
        xc = np.clip(x, lo, hi)
        out = []
        for p in self.coef:
            out.append(np.polyval(p, xc) + np.polyval(np.polyder(p), xc) * (x - xc))
        return np.stack(out, axis=-1)


def _taper(x, lo, hi, margin):
    """Weight 1 inside ``[lo, hi]``, falling linearly to 0 at ``margin`` outside."""
    return np.clip(1.0 - np.maximum(lo - x, x - hi) / margin, 0.0, 1.0)


def _pair_residuals(d, xa, Ya, ca, xb, Yb, cb, noise, margin):
    """Weighted residuals (in noise units) between set ``a`` (placed, curve ``ca`` in reduced
    coordinates) and set ``b`` shifted by ``d`` decades: ``b``'s points against ``a``'s curve
    and ``a``'s points against ``b``'s curve, over the overlap (tapered by ``margin``); each
    point keeps the robust weight of its own set's curve fit (outliers count ~0)."""
    wb = _taper(xb + d, ca.lo, ca.hi, margin)
    wa = _taper(xa - d, cb.lo, cb.hi, margin)
    rb = (Yb - ca(xb + d)) / noise * np.sqrt(wb[:, None] * cb.weight)
    ra = (Ya - cb(xa - d)) / noise * np.sqrt(wa[:, None] * ca.weight)
    return np.concatenate([rb.ravel(), ra.ravel()]), float(wa.sum() + wb.sum())


def _huber_cost(r, c=2.5):
    a = np.abs(r)
    return float(np.sum(np.where(a <= c, 0.5 * a**2, c * (a - 0.5 * c))))


def _shift_onto(xa, Ya, ca, xb, Yb, cb, noise, margin=0.5, min_weight=3.0):
    """Shift ``d`` [decades] of set ``b`` onto placed set ``a`` and its standard error: a scan
    of the mean Huber distance over all admissible overlaps, then a local refinement."""
    lo, hi = ca.lo - cb.hi - margin, ca.hi - cb.lo + margin

    def cost(d):
        r, weight = _pair_residuals(d, xa, Ya, ca, xb, Yb, cb, noise, margin)
        return _huber_cost(r) / weight if weight >= min_weight else np.inf

    grid = np.arange(lo, hi + 1e-9, 0.01)
    costs = np.array([cost(d) for d in grid])
    if not np.any(np.isfinite(costs)):
        raise ValueError("two neighbouring temperature sets are too short to be shifted onto each other (fewer "
                         "than 3 overlapping points even with half a decade of extrapolation)")
    from scipy.optimize import minimize_scalar

    k = int(np.nanargmin(costs))
    res = minimize_scalar(cost, bounds=(grid[max(k - 2, 0)], grid[min(k + 2, len(grid) - 1)]), method="bounded",
                          options={"xatol": 1e-6})
    d = float(res.x) if res.fun <= costs[k] else float(grid[k])
    # standard error: Gauss-Newton curvature of the residuals at the optimum, scaled by their scatter
    h = 1e-4
    r0, weight = _pair_residuals(d, xa, Ya, ca, xb, Yb, cb, noise, margin)
    J = (_pair_residuals(d + h, xa, Ya, ca, xb, Yb, cb, noise, margin)[0]
         - _pair_residuals(d - h, xa, Ya, ca, xb, Yb, cb, noise, margin)[0]) / (2 * h)
    n_eff = max(weight * Ya.shape[1] - 1.0, 1.0)
    s2 = float(r0 @ r0) / n_eff
    sigma = math.sqrt(s2 / max(float(J @ J), 1e-300))
    return d, sigma


def fit_shift_factors(sweeps: DMASweeps, *, T_ref=None, moduli="storage") -> ShiftFactors:
    """Shift factors of every temperature set from the data (time-temperature superposition).

    Starting from the reference set, each set in turn (outwards, colder and hotter) is shifted
    horizontally onto its already-placed neighbour: the shift ``d = log10 a_T(T_i) -
    log10 a_T(T_neighbour)`` minimises the mean Huber distance (robust to outlying points such
    as a sweep's noisy low-frequency start) between the log moduli of each set and a smooth
    robust quadratic through the other set, over their overlap. The curves are
    extended linearly up to half a decade beyond their data, so sets that barely overlap are
    still joined. Residuals are in units of each column's scatter about the per-set curves
    (pooled over the sets), so the noisier loss modulus weighs less where it is noisy.

    By default only ``log10 G'`` decides (``moduli="storage"``, as in pyvisco): the loss
    modulus of real sweeps often carries instrument artifacts at the same frequency in every
    set (the shipped file's ``G''`` turns up at its top frequency, 100 Hz, at every temperature),
    which pin the shift to zero in the glassy region where ``G'`` is nearly flat.
    ``moduli="both"`` adds ``log10 G''`` (weighted by its own scatter).

    Args:
        sweeps: :class:`DMASweeps` with at least two sets.
        T_ref: reference temperature [K]; the set nearest to it becomes the reference (its
            mean temperature is the ``T_ref`` of the result). Default: the set nearest to the
            middle of the measured range.
        moduli: ``"storage"`` (default), ``"loss"`` or ``"both"``: the curves compared.

    Returns:
        :class:`ShiftFactors`.
    """
    columns = {"storage": [0], "loss": [1], "both": [0, 1]}.get(moduli)
    if columns is None:
        raise ValueError(f"moduli must be 'storage', 'loss' or 'both'; got {moduli!r}")
    m = sweeps.n_sets
    if m < 2:
        raise ValueError("time-temperature superposition needs sweeps at two or more temperatures")
    Ts = sweeps.set_temperature
    target = 0.5 * (Ts[0] + Ts[-1]) if T_ref is None else float(T_ref)
    ref = int(np.argmin(np.abs(Ts - target)))
    data = []
    for i in range(m):
        w, gs, gl = sweeps.select(i)
        if len(w) < 3:
            raise ValueError(f"set {i} (T = {Ts[i]:.2f} K) has {len(w)} points; at least 3 are needed to shift it")
        x, Y = np.log10(w), np.log10(np.stack([gs, gl], axis=1)[:, columns])
        data.append((x, Y, _SetCurve(x, Y)))
    noise = np.array([max(_robust_scale(np.concatenate([c.resid[:, k] for _, _, c in data])), 1e-3)
                      for k in range(len(columns))])
    log_a = np.zeros(m)
    step = np.zeros(m)
    for order in (range(ref - 1, -1, -1), range(ref + 1, m)):
        for i in order:
            j = i + 1 if i < ref else i - 1  # the placed neighbour
            xa, Ya, ca = data[j]
            xb, Yb, cb = data[i]
            d, sd = _shift_onto(xa + log_a[j], Ya, ca.shifted(log_a[j]), xb, Yb, cb, noise)
            log_a[i], step[i] = d, sd
    sigma = np.zeros(m)
    for i in range(m):
        steps = range(i, ref) if i < ref else range(ref + 1, i + 1)
        sigma[i] = math.sqrt(sum(step[k] ** 2 for k in steps))
    return ShiftFactors(Ts.copy(), log_a, sigma, step, float(Ts[ref]), ref)


@dataclasses.dataclass(frozen=True)
class ShiftFit:
    """A shift law fitted to shift factors (:func:`fit_wlf`, :func:`fit_arrhenius`).

    Attributes:
        shift: the :class:`jaxroll.WLF` or :class:`jaxroll.Arrhenius` with the fitted values.
        params: ``{name: value}`` (``C1`` [-], ``C2`` [K]; or ``activation_energy`` [J/mol]).
        stderr, ci95: standard errors and 95 % intervals (normal, ``value +- 1.96 stderr``).
        covariance: covariance of the parameters (``s^2 (J^T J)^-1``, ``s^2`` the residual
            variance of ``log10 a_T``), in ``params`` order.
        rms: rms residual of ``log10 a_T`` [decades].
    """

    shift: WLF | Arrhenius
    params: dict
    stderr: dict
    ci95: dict
    covariance: np.ndarray
    rms: float


def _shift_fit(shift, names, values, J, r):
    dof = max(len(r) - len(values), 1)
    s2 = float(r @ r) / dof
    cov = np.linalg.pinv(J.T @ J) * s2
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    return ShiftFit(shift=shift, params=dict(zip(names, map(float, values))),
                    stderr=dict(zip(names, map(float, sd))),
                    ci95={n: (float(v - Z95 * s), float(v + Z95 * s)) for n, v, s in zip(names, values, sd)},
                    covariance=cov, rms=float(np.sqrt(np.mean(r**2))))


def _others(shifts: ShiftFactors):
    keep = np.arange(len(shifts.temperature)) != shifts.reference
    return shifts.temperature[keep], shifts.log10_aT[keep]


def fit_wlf(shifts: ShiftFactors) -> ShiftFit:
    """WLF fit ``log10 a_T = -C1 (T - T_ref) / (C2 + T - T_ref)`` to the shift factors (least
    squares in ``log10 a_T``; ``T_ref`` the reference set's temperature, ``C2 > T_ref - T_min``
    so the law is defined at every measured temperature).

    The solution is found by variable projection (``C1`` is linear given ``C2``: a scan of
    ``C2``, then :func:`scipy.optimize.least_squares` on both); the covariance comes from the
    least-squares Jacobian at the optimum, scaled by the residual variance.
    """
    T, y = _others(shifts)
    dT = T - shifts.T_ref
    c2_min = max(-dT.min(), 0.0) + 1e-6

    def c1_given(c2):
        g = -dT / (c2 + dT)
        return float(g @ y / (g @ g))

    def resid(p):
        return -p[0] * dT / (p[1] + dT) - y

    def jac(p):
        return np.stack([-dT / (p[1] + dT), p[0] * dT / (p[1] + dT) ** 2], axis=1)

    grid = c2_min + np.logspace(-1, 4, 400)
    costs = [float(np.sum(resid([c1_given(c2), c2]) ** 2)) for c2 in grid]
    c2 = float(grid[int(np.argmin(costs))])
    sol = least_squares(resid, jac, [c1_given(c2), c2], bounds=([-np.inf, c2_min], [np.inf, np.inf]), x_scale="jac",
                        rtol=1e-14)
    C1, C2 = sol.x
    return _shift_fit(WLF(C1=C1, C2=C2, T_ref=shifts.T_ref), ("C1", "C2"), sol.x, sol.jacobian, sol.residuals)


def fit_arrhenius(shifts: ShiftFactors) -> ShiftFit:
    """Arrhenius fit ``ln a_T = (E_a / R) (1/T - 1/T_ref)`` to the shift factors (linear least
    squares in ``log10 a_T``; covariance from the Jacobian, scaled by the residual variance).
    Above the glass transition the WLF law usually fits far better (compare ``rms``)."""
    T, y = _others(shifts)
    g = (1.0 / T - 1.0 / shifts.T_ref) / (GAS_CONSTANT * math.log(10.0))
    Ea = float(g @ y / (g @ g))
    return _shift_fit(Arrhenius(activation_energy=Ea, T_ref=shifts.T_ref), ("activation_energy",), [Ea], g[:, None],
                      Ea * g - y)


@dataclasses.dataclass(frozen=True)
class MasterCurve:
    """The master curve at ``T_ref``: every measured point at its reduced frequency, sorted.

    Attributes:
        omega: reduced angular frequency ``omega a_T`` [rad/s], increasing.
        storage, loss: ``G'``, ``G''`` [Pa].
        set: temperature set of each point. T_ref: [K].
        frequency: the measured (unshifted) angular frequency of each point [rad/s], or None.
    """

    omega: np.ndarray
    storage: np.ndarray
    loss: np.ndarray
    set: np.ndarray
    T_ref: float
    frequency: np.ndarray | None = None


def master_curve(sweeps: DMASweeps, shifts: ShiftFactors) -> MasterCurve:
    """Shift every point to its reduced frequency ``omega a_T`` (the shift factors of its
    set) and sort: the master curve at ``shifts.T_ref``."""
    w = sweeps.omega * 10.0 ** shifts.log10_aT[sweeps.set]
    order = np.argsort(w, kind="stable")
    return MasterCurve(w[order], sweeps.storage[order], sweeps.loss[order], sweeps.set[order], shifts.T_ref,
                       sweeps.omega[order])


def loss_artifacts(master: MasterCurve, *, n_sigma=4.0, min_decades=0.02, min_fraction=0.75):
    """The loss values of an instrument artifact at one measured frequency: points to leave out
    of :func:`fit_prony` (``weights[flagged, 1] = 0``).

    The rule: in every set, the loss at each measured frequency is compared with the straight
    line (in ``log omega``, ``log10 G''``) through the same set's two next-lower frequencies.
    A real loss curve bends smoothly, so these second differences scatter about zero; an
    artifact at one frequency (e.g. a loss that turns up at the top frequency of every sweep,
    as in the shipped file at 100 Hz) lifts them there in most sets. A measured frequency is
    flagged when its second differences have a median above ``n_sigma`` robust standard
    deviations of all of them (and above ``min_decades``) and are positive in at least
    ``min_fraction`` of the sets (at least 3 sets). Frequencies are matched across sets to
    0.01 decade; a set's two lowest frequencies cannot be tested. The storage modulus is not
    tested (it is smoother and carries the shift).

    Args:
        master: a :class:`MasterCurve` from :func:`master_curve` (it needs ``frequency``).

    Returns:
        boolean array ``(n_points,)``: the master-curve points whose loss is flagged.
    """
    if master.frequency is None:
        raise ValueError("loss_artifacts needs the measured frequency of each point (a MasterCurve from master_curve)")
    x_all, y_all = np.log10(master.frequency), np.log10(master.loss)
    d = np.full(len(x_all), np.nan)
    for s in np.unique(master.set):
        idx = np.flatnonzero(master.set == s)
        idx = idx[np.argsort(x_all[idx], kind="stable")]
        x, y = x_all[idx], y_all[idx]
        with np.errstate(divide="ignore", invalid="ignore"):
            d[idx[2:]] = y[2:] - y[1:-1] - (y[1:-1] - y[:-2]) / (x[1:-1] - x[:-2]) * (x[2:] - x[1:-1])
    ok = np.isfinite(d)
    flagged = np.zeros(len(x_all), bool)
    if not ok.any():
        return flagged
    limit = max(n_sigma * _robust_scale(d[ok]), min_decades)
    key = np.round(x_all, 2)
    for k in np.unique(key[ok]):
        m = ok & (key == k)
        if m.sum() >= 3 and np.median(d[m]) > limit and np.mean(d[m] > 0) >= min_fraction:
            flagged |= key == k
    return flagged


# ----------------------------------------------------------------------------------------
# Prony series


@dataclasses.dataclass(frozen=True)
class PronyFit:
    """A generalized Maxwell series fitted to a master curve (:func:`fit_prony`).

    Attributes:
        material: :class:`jaxroll.GeneralizedMaxwell` (``G_inf``, ``G_i`` [Pa], ``tau_i`` [s]).
        residuals: ``log(G'_fit / G'_meas)`` and ``log(G''_fit / G''_meas)`` at the master
            curve's points, shape ``(n_points, 2)`` (natural log: relative errors).
        rms: rms of ``residuals`` (storage and loss together) over the values fitted [-].
        n_terms: number of terms kept (non-zero moduli).
        weights: the weights of the (storage, loss) residuals, ``(n_points, 2)`` (0: left out).
    """

    material: GeneralizedMaxwell
    residuals: np.ndarray
    rms: float
    n_terms: int
    weights: np.ndarray | None = None


def prony_moduli(G_inf, G, tau, omega):
    """``(G'(omega), G''(omega))`` [Pa] of a generalized Maxwell series (``omega`` [rad/s], any
    shape); pure and jittable (the residual of :func:`fit_prony`'s refinement)."""
    wt = omega[..., None] * tau
    wt2 = wt * wt
    return G_inf + jnp.sum(G * wt2 / (1.0 + wt2), axis=-1), jnp.sum(G * wt / (1.0 + wt2), axis=-1)


@jax.jit
def _prony_residuals(p, logw, log_gs, log_gl, log_tau_range, weight):
    """Relative residuals ``log G'_fit - log G'_meas``, ``log G''_fit - log G''_meas`` for
    parameters ``p = [log G_inf, log G_1..n, u_1..n]``, times ``weight`` (per residual, storage
    then loss; 0 leaves one out); the times stay inside the data's
    range, ``log tau_i = lo + (hi - lo) sigmoid(u_i)`` (a term outside it would be fitted to
    the ends' noise, with no modulus there to bound it)."""
    n = (p.shape[0] - 1) // 2
    lo, hi = log_tau_range[0], log_tau_range[1]
    tau = jnp.exp(lo + (hi - lo) * jax.nn.sigmoid(p[n + 1 :]))
    gs, gl = prony_moduli(jnp.exp(p[0]), jnp.exp(p[1 : n + 1]), tau, jnp.exp(logw))
    return jnp.concatenate([jnp.log(gs) - log_gs, jnp.log(gl) - log_gl]) * weight


_prony_jacobian = jax.jit(jax.jacfwd(_prony_residuals))


def _refine(p, args):
    """Levenberg-Marquardt from ``p`` (MINPACK, scaled by the Jacobian's columns: moduli and
    times differ in sensitivity by decades) on the jitted residual and its forward-mode
    Jacobian. At most 300 evaluations: by then the cost is flat to ~1e-6 relative, and what
    remains moves terms that carry almost no modulus along a valley towards ``G_i -> 0``."""
    sol = least_squares(lambda x: _prony_residuals(jnp.asarray(x), *args),
                        lambda x: _prony_jacobian(jnp.asarray(x), *args), p, method="lm", rtol=1e-10,
                        max_evaluations=300, x_scale="jac")
    return sol.x


def fit_prony(master: MasterCurve, *, n_terms=None, refine=True, weights=None) -> PronyFit:
    """Fit a generalized Maxwell series (Prony series) to a master curve, storage and loss
    jointly.

    Relaxation times are log-spaced over the data's reduced-frequency range,
    ``tau in [1/omega_max, 1/omega_min]``; the moduli ``G_inf, G_i >= 0`` solve the
    non-negative least-squares problem (:func:`scipy.optimize.nnls`) of the relative residuals
    ``(G'_fit - G'_meas)/G'_meas`` and ``(G''_fit - G''_meas)/G''_meas`` (a log-weighted design:
    every decade of modulus counts alike). Terms NNLS sets to zero are dropped (the number of
    terms is minimised). With ``refine``, the kept terms' moduli and times are then refined
    together by least squares (:func:`scipy.optimize.least_squares`) on ``log G'``, ``log G''`` in ``log G_i`` and the times
    (positive by construction, kept within half a decade of the data's range: a term beyond it
    would be fitted to the noise at the curve's ends with nothing to bound its modulus, e.g. an
    unphysical glassy modulus); residual and Jacobian compiled with JAX.

    Args:
        master: :class:`MasterCurve`.
        n_terms: number of relaxation times before pruning (default: one per decade of the
            reduced-frequency range, plus one).
        refine: refine the NNLS solution (default True).
        weights: array ``(n_points, 2)`` of weights >= 0 of each point's (storage, loss)
            residual (default all 1); 0 leaves a value out of the fit (e.g. the instrument
            artifacts :func:`loss_artifacts` finds); every residual is still reported.

    Returns:
        :class:`PronyFit`.
    """
    from scipy.optimize import nnls

    w, gs, gl = master.omega, master.storage, master.loss
    lo, hi = math.log10(1.0 / w.max()), math.log10(1.0 / w.min())
    n = int(n_terms) if n_terms is not None else int(math.ceil(hi - lo)) + 1
    if n < 1:
        raise ValueError(f"n_terms must be >= 1; got {n_terms}")
    tau = np.logspace(lo, hi, n) if n > 1 else np.array([10 ** (0.5 * (lo + hi))])
    wts = np.ones((len(w), 2)) if weights is None else np.asarray(weights, float)
    if wts.shape != (len(w), 2) or not np.all(np.isfinite(wts) & (wts >= 0)):
        raise ValueError(f"weights must be finite, >= 0, of shape ({len(w)}, 2) (storage, loss per point); got "
                         f"shape {wts.shape}")
    keep_pt = wts > 0
    weight = np.concatenate([wts[:, 0], wts[:, 1]])
    wt = w[:, None] * tau
    A_s = np.hstack([np.ones((len(w), 1)), wt**2 / (1 + wt**2)]) / gs[:, None]
    A_l = np.hstack([np.zeros((len(w), 1)), wt / (1 + wt**2)]) / gl[:, None]
    x, _ = nnls(np.vstack([A_s, A_l]) * weight[:, None], weight, maxiter=50 * (n + 1))
    G_inf = max(float(x[0]), 1e-6 * float(np.min(gs)))
    keep = x[1:] > 1e-8 * float(np.sum(x[1:]))
    G, tau = x[1:][keep], tau[keep]
    # times as u = logit of their position in [lo - 0.5, hi + 0.5] decades (ln units below)
    lo_e, hi_e = (lo - 0.5) * math.log(10), (hi + 0.5) * math.log(10)
    args = (jnp.asarray(np.log(w)), jnp.asarray(np.log(gs)), jnp.asarray(np.log(gl)), jnp.asarray([lo_e, hi_e]),
            jnp.asarray(weight))
    t = (np.log(tau) - lo_e) / (hi_e - lo_e)
    p = np.concatenate([[math.log(G_inf)], np.log(G), np.log(t) - np.log1p(-t)])
    k = len(G)
    if refine and k:
        p = _refine(p, args)
    r = np.asarray(_prony_residuals(jnp.asarray(p), *args[:-1], jnp.ones_like(args[-1]))).reshape(2, -1).T
    tau = np.exp(lo_e + (hi_e - lo_e) / (1.0 + np.exp(-p[k + 1 :])))
    order = np.argsort(tau)
    mat = GeneralizedMaxwell(G_inf=math.exp(p[0]), G=np.exp(p[1 : k + 1])[order], tau=tau[order])
    return PronyFit(material=mat, residuals=r, rms=float(np.sqrt(np.mean(r[keep_pt] ** 2))), n_terms=k,
                    weights=wts)


# ----------------------------------------------------------------------------------------
# exports


def _terms(material: GeneralizedMaxwell):
    G0 = float(material.glassy_modulus())
    return G0, np.asarray(material.G) / G0, np.asarray(material.tau)


def write_abaqus(material: GeneralizedMaxwell, path, *, shift: WLF | None = None, poisson=0.49):
    """Write an Abaqus material block: ``*ELASTIC, MODULI=INSTANTANEOUS`` (``E_0 = 2 G_0 (1 +
    nu)``, ``G_0`` the instantaneous shear modulus), ``*VISCOELASTIC, TIME=PRONY`` with lines
    ``g_i, k_i, tau_i`` (``g_i = G_i / G_0``; ``k_i = 0``: the bulk modulus does not relax),
    and, with a WLF shift, ``*TRS, DEFINITION=WLF`` (``T_ref`` [K], ``C1``, ``C2`` [K]).
    ``poisson`` (default 0.49) is the instantaneous Poisson's ratio Abaqus needs (< 0.5).
    Units SI (Pa, s, K)."""
    G0, g, tau = _terms(material)
    lines = ["** jaxroll Prony series (shear), SI units: Pa, s, K",
             f"** G_0 = {G0:.10g} Pa (instantaneous shear), G_inf = {float(material.G_inf):.10g} Pa",
             "*ELASTIC, MODULI=INSTANTANEOUS", f"{2 * G0 * (1 + poisson):.10g}, {poisson:g}",
             "*VISCOELASTIC, TIME=PRONY"]
    lines += [f"{gi:.10g}, 0., {ti:.10g}" for gi, ti in zip(g, tau)]
    if shift is not None:
        lines += ["*TRS, DEFINITION=WLF", f"{float(shift.T_ref):.10g}, {float(shift.C1):.10g}, {float(shift.C2):.10g}"]
    Path(path).write_text("\n".join(lines) + "\n")


def write_ansys(material: GeneralizedMaxwell, path, *, shift: WLF | None = None, poisson=0.49, mat_id=1):
    """Write ANSYS APDL commands: ``MP,EX`` / ``MP,PRXY`` (instantaneous), ``TB,PRONY,,,n,SHEAR``
    with ``TBDATA`` pairs ``a_i, tau_i`` (``a_i = G_i / G_0``, six values per line) and, with a
    WLF shift, ``TB,SHIFT,,,3,WLF`` (``T_ref`` [K], ``C1``, ``C2`` [K]). Units SI."""
    G0, g, tau = _terms(material)
    flat = [v for pair in zip(g, tau) for v in pair]
    lines = ["! jaxroll Prony series (shear), SI units: Pa, s, K",
             f"MP,EX,{mat_id},{2 * G0 * (1 + poisson):.10g}", f"MP,PRXY,{mat_id},{poisson:g}",
             f"TB,PRONY,{mat_id},,{len(g)},SHEAR"]
    for i in range(0, len(flat), 6):
        lines.append(f"TBDATA,{i + 1}," + ",".join(f"{v:.10g}" for v in flat[i : i + 6]))
    if shift is not None:
        lines += [f"TB,SHIFT,{mat_id},,3,WLF",
                  f"TBDATA,1,{float(shift.T_ref):.10g},{float(shift.C1):.10g},{float(shift.C2):.10g}"]
    Path(path).write_text("\n".join(lines) + "\n")


def save_material(path, material: GeneralizedMaxwell, shift: WLF | Arrhenius | None = None, *, info=None):
    """Save a Prony series (and its shift law) for :func:`load_material`: ``.json`` (full
    precision, with ``info``: any JSON-serialisable provenance) or ``.csv`` (columns ``tau``
    [s], ``G`` [Pa], first data row ``inf, G_inf``; the shift law in a ``#`` comment line)."""
    path = Path(path)
    shift_d = None
    if isinstance(shift, WLF):
        shift_d = {"law": "WLF", "C1": float(shift.C1), "C2": float(shift.C2), "T_ref": float(shift.T_ref)}
    elif isinstance(shift, Arrhenius):
        shift_d = {"law": "Arrhenius", "activation_energy": float(shift.activation_energy),
                   "T_ref": float(shift.T_ref)}
    G, tau = np.asarray(material.G).tolist(), np.asarray(material.tau).tolist()
    if path.suffix.lower() == ".json":
        payload = {"material": "GeneralizedMaxwell", "G_inf": float(material.G_inf), "G": G, "tau": tau,
                   "shift": shift_d, "units": {"G_inf": "Pa", "G": "Pa", "tau": "s", "C2": "K", "T_ref": "K",
                                               "activation_energy": "J/mol"}, "info": info or {}}
        path.write_text(json.dumps(payload, indent=2) + "\n")
    elif path.suffix.lower() == ".csv":
        comments = ["jaxroll GeneralizedMaxwell (shear); row tau = inf holds G_inf"]
        comments += [] if shift_d is None else ["shift " + json.dumps(shift_d)]
        write_table(path, {"tau": [math.inf, *tau], "G": [float(material.G_inf), *G]}, ["s", "Pa"],
                    comments=comments)
    else:
        raise ValueError(f"save_material: {path.name}: use a .json or .csv file")


def load_material(path):
    """Load what :func:`save_material` wrote: ``(GeneralizedMaxwell, shift or None)``."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        d = json.loads(path.read_text())
        if d.get("material") != "GeneralizedMaxwell":
            raise ValueError(f"{path}: not a jaxroll material file (no 'material': 'GeneralizedMaxwell')")
        mat = GeneralizedMaxwell(G_inf=d["G_inf"], G=np.asarray(d["G"], float), tau=np.asarray(d["tau"], float))
        s = d.get("shift")
    elif path.suffix.lower() == ".csv":
        t = read_table(path, [Column("tau", UNITS["time"], positive=True, finite=False),
                              Column("G", UNITS["modulus"], positive=True)], kind="material")
        if not np.isinf(t["tau"][0]) or np.any(np.isinf(t["tau"][1:])):
            raise ValueError(f"{path}, line {t.lines[0]}: expected the row 'inf, G_inf' first, then finite tau")
        s = next((json.loads(c[len("shift "):]) for c in t.comments if c.startswith("shift ")), None)
        mat = GeneralizedMaxwell(G_inf=float(t["G"][0]), G=t["G"][1:], tau=t["tau"][1:])
    else:
        raise ValueError(f"load_material: {path.name}: use a .json or .csv file")
    shift = None
    if s is not None:
        shift = (WLF(C1=s["C1"], C2=s["C2"], T_ref=s["T_ref"]) if s["law"] == "WLF"
                 else Arrhenius(activation_energy=s["activation_energy"], T_ref=s["T_ref"]))
    return mat, shift


# ----------------------------------------------------------------------------------------
# rolling-resistance maps


@dataclasses.dataclass(frozen=True)
class ResistanceMap:
    """Rolling resistance over temperature x speed (:func:`resistance_map`).

    Attributes:
        temperatures [K], speeds [m/s]: the axes.
        value: ``R_r`` [N for a sphere, N/m for a cylinder], shape ``(n_T, n_V)``.
        valid: ``result == RESULTS.successful`` per point.
        dR_dT: ``dR_r/dT`` [N/K or N/(m K)] and dR_dH: ``dR_r/dH`` [N/m or N/m^2] (``jax.grad``).
        seconds: wall time of the compiled map (values and gradients, compilation excluded)
            divided by the number of points [s].
        result: the :data:`jaxroll.RESULTS` code per point (why a point is not valid).
    """

    temperatures: np.ndarray
    speeds: np.ndarray
    value: np.ndarray
    valid: np.ndarray
    dR_dT: np.ndarray
    dR_dH: np.ndarray
    seconds: float
    result: np.ndarray | None = None

    def write_csv(self, path, *, unit="N"):
        """One row per point: temperature [K], speed [m/s], R_r, dR/dT, dR/dH, valid and (when
        known) the name of the point's :data:`jaxroll.RESULTS` code."""
        from .result import RESULTS

        T, V = (a.ravel() for a in np.meshgrid(self.temperatures, self.speeds, indexing="ij"))
        cols = {"temperature": T, "speed": V, "rolling_resistance": np.ravel(self.value), "dR_dT": np.ravel(self.dR_dT),
                "dR_dH": np.ravel(self.dR_dH), "valid": np.ravel(self.valid).astype(int)}
        units = ["K", "m/s", unit, f"{unit}/K", f"{unit}/m", "-"]
        if self.result is not None:
            cols["result"] = [RESULTS.names[int(c)] for c in np.ravel(self.result)]
            units.append("-")
        write_table(path, cols, units, formats={"temperature": ".6g", "speed": ".6g", "rolling_resistance": ".8g",
                                                "dR_dT": ".6g", "dR_dH": ".6g"})


def resistance_map(material, shift, layer, *, radius, load, temperatures, speeds, geometry="sphere",
                   method="direct") -> ResistanceMap:
    """``R_r(T, V)`` of a rigid sphere or cylinder on a layer of a material characterised at
    ``shift.T_ref`` (``jr.at_temperature(material, shift, T)``), with ``dR_r/dT`` and
    ``dR_r/dH`` from ``jax.grad``, all points in one compiled, vmapped program.

    Args:
        material: e.g. the :class:`PronyFit`'s ``material``; shift: its WLF/Arrhenius law.
        layer: :class:`jaxroll.Layer` (its ``H`` [m] is the thickness differentiated).
        radius [m], load [N, or N/m for a cylinder]; temperatures [K], speeds [m/s]: 1D axes.
        geometry: ``"sphere"`` or ``"cylinder"``.
        method: ``"direct"`` (default: milliseconds per point with any Prony spectrum) or a
            method resolved over the whole map (``method.resolve(...)``; the periodic full
            models need periods of ~20 V tau_max, impractical for spectra of 20 decades).
    """
    import time

    from .layer import Layer
    from .material import at_temperature
    from .result import RESULTS
    from .rolling import rolling_resistance

    T = jnp.asarray(np.asarray(temperatures, float))
    V = jnp.asarray(np.asarray(speeds, float))

    def one(Ti, Vi, H):
        lay = Layer(H=H, rho=layer.rho, nu=layer.nu)
        r = rolling_resistance(at_temperature(material, shift, Ti), lay, radius=radius, load=load, speed=Vi,
                               geometry=geometry, method=method, throw=False)
        return r.value, r.result

    def value_and_grads(Ti, Vi, H):
        (v, code), g = jax.value_and_grad(one, argnums=(0, 2), has_aux=True)(Ti, Vi, H)
        return v, code, g[0], g[1]

    grid = jax.jit(jax.vmap(jax.vmap(value_and_grads, (None, 0, None)), (0, None, None)))
    H = jnp.asarray(layer.H)
    jax.block_until_ready(grid(T, V, H))  # compile
    t0 = time.perf_counter()
    v, code, dT, dH = (np.asarray(a) for a in jax.block_until_ready(grid(T, V, H)))
    seconds = (time.perf_counter() - t0) / v.size
    return ResistanceMap(np.asarray(T), np.asarray(V), v, code == RESULTS.successful, dT, dH, seconds, code.astype(int))
