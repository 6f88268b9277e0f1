"""Time-temperature superposition: shift factors of each temperature set, WLF / Arrhenius
laws with uncertainties, and the master curve.

:func:`fit_shift_factors` shifts each temperature set horizontally onto its already shifted
neighbour (nearer the reference), minimising the robust distance between the log-log curves
(``log G'`` and ``log G''``) over their overlap. :func:`fit_wlf` / :func:`fit_arrhenius` fit
``log10 a_T`` with covariances from the least-squares Jacobian.

Shift-factor convention (jaxroll's): the material at ``T`` behaves as the reference material at
``omega a_T``; ``log10 a_T > 0`` below the reference temperature.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from .._lsq import Z95, least_squares
from ..io import DataWarning
from .material import GAS_CONSTANT, WLF, Arrhenius
from .read import DMASweeps


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


def _huber_cost(r, c=2.5, axis=None):
    a = np.abs(r)
    return np.sum(np.where(a <= c, 0.5 * a**2, c * (a - 0.5 * c)), axis=axis)


#: The scan of :func:`_shift_onto` uses at most this many points per set (evenly spaced in the
#: set's frequency order; the refinement uses all): long sweeps cost no more to scan.
_SCAN_POINTS = 200


def _scan_costs(grid, xa, Ya, ca, xb, Yb, cb, noise, margin, min_weight):
    """The cost of :func:`_shift_onto` at every shift of ``grid`` at once (the same formula as
    :func:`_pair_residuals` and :func:`_huber_cost`, broadcast over the grid), on at most
    ``_SCAN_POINTS`` points of each set."""
    ia, ib = (np.unique(np.linspace(0, len(x) - 1, min(len(x), _SCAN_POINTS)).round().astype(int)) for x in (xa, xb))
    xa, Ya, wta, xb, Yb, wtb = xa[ia], Ya[ia], ca.weight[ia], xb[ib], Yb[ib], cb.weight[ib]
    D = grid[:, None]
    wb = _taper(xb[None, :] + D, ca.lo, ca.hi, margin)
    wa = _taper(xa[None, :] - D, cb.lo, cb.hi, margin)
    rb = (Yb[None] - ca(xb[None, :] + D)) / noise * np.sqrt(wb[..., None] * wtb[None])
    ra = (Ya[None] - cb(xa[None, :] - D)) / noise * np.sqrt(wa[..., None] * wta[None])
    hub = _huber_cost(rb, axis=(1, 2)) + _huber_cost(ra, axis=(1, 2))
    weight = wa.sum(axis=1) + wb.sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(weight >= min_weight, hub / weight, np.inf)


def _shift_onto(xa, Ya, ca, xb, Yb, cb, noise, margin=0.5, min_weight=3.0):
    """Shift ``d`` [decades] of set ``b`` onto placed set ``a`` and its standard error: a scan
    of the mean Huber distance over all admissible overlaps, then a local refinement."""
    lo, hi = ca.lo - cb.hi - margin, ca.hi - cb.lo + margin

    def cost(d):
        r, weight = _pair_residuals(d, xa, Ya, ca, xb, Yb, cb, noise, margin)
        return float(_huber_cost(r)) / weight if weight >= min_weight else np.inf

    grid = np.arange(lo, hi + 1e-9, 0.01)
    costs = _scan_costs(grid, xa, Ya, ca, xb, Yb, cb, noise, margin, min_weight)
    if not np.any(np.isfinite(costs)):
        raise ValueError("two neighbouring temperature sets are too short to be shifted onto each other (fewer "
                         "than 3 overlapping points even with half a decade of extrapolation)")
    from scipy.optimize import minimize_scalar

    k = int(np.nanargmin(costs))
    res = minimize_scalar(cost, bounds=(grid[max(k - 2, 0)], grid[min(k + 2, len(grid) - 1)]), method="bounded",
                          options={"xatol": 1e-6})
    at_k = costs[k] if max(len(xa), len(xb)) <= _SCAN_POINTS else cost(float(grid[k]))  # all points, as res.fun
    d = float(res.x) if res.fun <= at_k else float(grid[k])
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
        if len(np.unique(w)) < 3:
            raise ValueError(f"set {i} (T = {Ts[i]:.2f} K) has {len(np.unique(w))} distinct frequencies; at least 3 are "
                             "needed to shift it")
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


#: A WLF fit whose C1, C2 correlate beyond this is degenerate (only C1/C2 determined).
DEGENERATE_CORRELATION = 0.9999
#: ... as is one whose C2 exceeds this many times the largest ``|T - T_ref|`` measured (the law
#: is then a straight line in T over the data to ~5 %: only its slope C1/C2 is determined).
DEGENERATE_C2_SPAN = 20.0
#: Loose physical ranges of WLF constants: the universal values at T_g are C1 = 17.4,
#: C2 = 51.6 K; other reference temperatures move them, but never to C1 <= 0, C2 <= 0, or
#: beyond these bounds.
C1_RANGE, C2_RANGE = (0.0, 1e3), (0.0, 1e4)
#: The report warns when a law misses the shift factors by more than this rms [decades].
MAX_LAW_RMS = 0.5


@dataclasses.dataclass(frozen=True)
class ShiftFit:
    """A shift law fitted to shift factors (:func:`fit_wlf`, :func:`fit_arrhenius`).

    Attributes:
        shift: the :class:`jaxroll.WLF` or :class:`jaxroll.Arrhenius` with the fitted values.
        params: ``{name: value}`` (``C1`` [-], ``C2`` [K]; or ``activation_energy`` [J/mol]).
        stderr, ci95: standard errors and 95 % intervals (normal, ``value +- 1.96 stderr``);
            ``nan`` when the fit is exactly determined (as many shift factors as parameters: no
            residual to scale them); a parameter held fixed has stderr ``None`` and interval
            ``(nan, nan)``. :meth:`interval` says which, in words.
        covariance: covariance of the fitted parameters (``s^2 (J^T J)^-1``, ``s^2`` the residual
            variance of ``log10 a_T``), in ``params`` order (``nan`` when exactly determined).
        rms: rms residual of ``log10 a_T`` [decades].
        notes: what the numbers do not say by themselves, one sentence each: an exactly
            determined fit, a degenerate WLF fit (C1, C2 not separately determined) with its
            alternatives, constants outside their physical ranges, a law that misses the shift
            factors by more than :data:`MAX_LAW_RMS`.
        degenerate: C1 and C2 are not separately determined (see :data:`DEGENERATE_CORRELATION`).
    """

    shift: WLF | Arrhenius
    params: dict
    stderr: dict
    ci95: dict
    covariance: np.ndarray
    rms: float
    notes: tuple = ()
    degenerate: bool = False

    def interval(self, name, fmt=".4g") -> str:
        """``'95 % [a, b]'``, or why there is none: ``'no interval (exactly determined)'``,
        ``'held fixed'``."""
        if self.stderr[name] is None:
            return "held fixed"
        lo, hi = self.ci95[name]
        if math.isnan(lo):
            return "no interval (exactly determined)"
        return f"95 % [{lo:{fmt}}, {hi:{fmt}}]"


def _shift_fit(shift, names, values, J, r, fixed=None, notes=()):
    """The :class:`ShiftFit` of parameters ``names = values`` (Jacobian ``J`` of the residuals
    ``r``); ``fixed``: ``{name: value}`` held, reported without an interval."""
    dof = len(r) - len(values)
    rms = float(np.sqrt(np.mean(r**2))) if len(r) else 0.0
    notes = list(notes)
    if dof <= 0:
        cov = np.full((len(values), len(values)), np.nan)
        notes.append(f"no interval (exactly determined: {len(r)} shift factor(s) for {len(values)} parameter(s))")
    else:
        cov = np.linalg.pinv(J.T @ J) * (float(r @ r) / dof)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    params = dict(zip(names, map(float, values)))
    stderr = dict(zip(names, map(float, sd)))
    ci95 = {n: (float(v - Z95 * s), float(v + Z95 * s)) for n, v, s in zip(names, values, sd)}
    for n, v in (fixed or {}).items():
        params[n], stderr[n], ci95[n] = float(v), None, (math.nan, math.nan)
    if rms > MAX_LAW_RMS:
        notes.append(f"the {type(shift).__name__} law misses the shift factors by {rms:.2f} decade rms (more than "
                     f"{MAX_LAW_RMS}): the law is a poor summary of these data; compare the other law, or check the "
                     "shift factors")
    return ShiftFit(shift=shift, params=params, stderr=stderr, ci95=ci95, covariance=cov, rms=rms, notes=tuple(notes))


def _others(shifts: ShiftFactors):
    keep = np.arange(len(shifts.temperature)) != shifts.reference
    return shifts.temperature[keep], shifts.log10_aT[keep]


def fit_wlf(shifts: ShiftFactors, *, C2=None) -> ShiftFit:
    """WLF fit ``log10 a_T = -C1 (T - T_ref) / (C2 + T - T_ref)`` to the shift factors (least
    squares in ``log10 a_T``; ``T_ref`` the reference set's temperature, ``C2 > T_ref - T_min``
    so the law is defined at every measured temperature).

    The solution is found by variable projection (``C1`` is linear given ``C2``: a scan of
    ``C2``, then :func:`scipy.optimize.least_squares` on both); the covariance comes from the
    least-squares Jacobian at the optimum, scaled by the residual variance.

    Honest reporting (:attr:`ShiftFit.notes`; the first two also as :class:`jaxroll.DataWarning`):

    * a degenerate fit, where only ``C1/C2`` is determined (C1, C2 correlated beyond
      :data:`DEGENERATE_CORRELATION`, or ``C2`` above :data:`DEGENERATE_C2_SPAN` times the
      measured ``|T - T_ref|``: the shifts are linear in T), names the slope and the
      alternatives, a fixed ``C2`` (``C2=``) or :func:`fit_arrhenius`;
    * ``C1``, ``C2`` outside :data:`C1_RANGE`, :data:`C2_RANGE`;
    * an exactly determined fit (two shift factors besides the reference) has no interval;
    * a law that misses the shift factors by more than :data:`MAX_LAW_RMS` decades rms.

    Args:
        shifts: :class:`ShiftFactors`.
        C2: hold ``C2`` [K] at this value and fit ``C1`` alone (e.g. ``51.6 + T_ref - T_g``, the
            universal value moved to ``T_ref``), for data that determine only ``C1/C2``.
    """
    T, y = _others(shifts)
    dT = T - shifts.T_ref
    c2_min = max(-dT.min(), 0.0) + 1e-6
    if len(T) < 1:
        raise ValueError("a WLF fit needs at least one shift factor besides the reference set's")

    def c1_given(c2):
        g = -dT / (c2 + dT)
        return float(g @ y / (g @ g))

    def resid(p):
        return -p[0] * dT / (p[1] + dT) - y

    def jac(p):
        return np.stack([-dT / (p[1] + dT), p[0] * dT / (p[1] + dT) ** 2], axis=1)

    if C2 is not None:
        C2 = float(C2)
        if not C2 > c2_min:
            raise ValueError(f"C2 = {C2:g} K must exceed T_ref - T_min = {c2_min:.4g} K (the law diverges at T = T_ref - C2)")
        C1 = c1_given(C2)
        fit = _shift_fit(WLF(C1=C1, C2=C2, T_ref=shifts.T_ref), ("C1",), [C1], jac([C1, C2])[:, :1],
                         resid([C1, C2]), fixed={"C2": C2})
        return _checked_wlf(fit, dT)
    if len(T) < 2:
        raise ValueError("a WLF fit of C1 and C2 needs at least two shift factors besides the reference set's; hold "
                         "C2 (fit_wlf(shifts, C2=...)) or fit Arrhenius")
    grid = c2_min + np.logspace(-1, 4, 400)
    costs = [float(np.sum(resid([c1_given(c2), c2]) ** 2)) for c2 in grid]
    c2 = float(grid[int(np.argmin(costs))])
    sol = least_squares(resid, jac, [c1_given(c2), c2], bounds=([-np.inf, c2_min], [np.inf, np.inf]), x_scale="jac",
                        rtol=1e-14)
    C1, C2 = sol.x
    fit = _shift_fit(WLF(C1=C1, C2=C2, T_ref=shifts.T_ref), ("C1", "C2"), sol.x, sol.jacobian, sol.residuals)
    return _checked_wlf(fit, dT)


def _checked_wlf(fit: ShiftFit, dT) -> ShiftFit:
    """``fit`` with the degenerate-fit and physical-range notes (and their warnings)."""
    C1, C2 = fit.params["C1"], fit.params["C2"]
    span = float(np.max(np.abs(dT)))
    warn, degenerate = [], False
    if fit.stderr.get("C2") is not None and np.all(np.isfinite(fit.covariance)):
        c = fit.covariance
        corr = c[0, 1] / math.sqrt(max(c[0, 0] * c[1, 1], 1e-300))
        if abs(corr) > DEGENERATE_CORRELATION or C2 > DEGENERATE_C2_SPAN * span:
            degenerate = True
            warn.append(f"WLF C1 = {C1:.4g} and C2 = {C2:.4g} K are not separately determined (correlation "
                        f"{corr:.6f}; C2 is {C2 / span:.3g} times the measured |T - T_ref| <= {span:.3g} K): the shift "
                        f"factors are linear in T, and only the slope C1/C2 = {C1 / C2:.4g} 1/K is known. Hold C2 "
                        f"(fit_wlf(shifts, C2=...); universal: 51.6 K + T_ref - T_g) or fit Arrhenius")
    bad = [f"{n} = {v:.4g}{' K' if n == 'C2' else ''} outside ({lo:g}, {hi:g})"
           for n, v, (lo, hi) in (("C1", C1, C1_RANGE), ("C2", C2, C2_RANGE)) if not lo < v < hi]
    if bad:
        warn.append(f"WLF constants outside their physical ranges: {'; '.join(bad)} (universal at T_g: C1 = 17.4, C2 = "
                    "51.6 K): check the shift factors and the data warnings (units, swapped columns), or fit Arrhenius")
    for w in warn:
        warnings.warn(w, DataWarning, stacklevel=3)
    return dataclasses.replace(fit, notes=tuple(warn) + fit.notes, degenerate=degenerate)


def fit_arrhenius(shifts: ShiftFactors) -> ShiftFit:
    """Arrhenius fit ``ln a_T = (E_a / R) (1/T - 1/T_ref)`` to the shift factors (linear least
    squares in ``log10 a_T``; covariance from the Jacobian, scaled by the residual variance).
    Above the glass transition the WLF law usually fits far better (compare ``rms``); where a
    WLF fit is degenerate (shifts linear in T) Arrhenius determines its one constant."""
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
