"""Prony series (generalized Maxwell) fitted to a master curve, storage and loss jointly.

Two fits (:func:`fit_prony`):

* the default, a smooth spectrum: :data:`SMOOTH_TERMS_PER_DECADE` fixed relaxation times per
  decade whose ``log G_i`` are fitted with a penalty on the spectrum's curvature
  (:data:`SMOOTHNESS`), so that the loss curve, and the rolling resistance against temperature,
  carry no ripples from the term spacing;
* ``smoothness=None``: the fewest terms, non-negative least squares on log-spaced relaxation
  times, optionally refined by least squares on ``log G_i, log tau_i``.

Residuals and Jacobians are jitted.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import jax
import jax.numpy as jnp
import numpy as np

from .._lsq import least_squares
from ..io import DataWarning
from .material import GeneralizedMaxwell
from .shift import MasterCurve


#: :func:`fit_prony` warns when its rms log residual exceeds this (a factor e^0.5 = 1.65 rms):
#: measured master curves that superpose leave 0.1-0.25 (the shipped file: docs/dma.md). The rms
#: is unweighted, over the values fitted (the caller's weight > 0), as the report prints it, not
#: the weighted rms the fit minimises: with the instrument error model a plateau's loss weighs
#: ~0.06, so a loss 20x off there (a unit slip) would pass under a weighted rms.
MAX_PRONY_RMS = 0.5


#: Above this many points :func:`fit_prony` fits bin means (``MAX_FIT_POINTS`` bins equally
#: spaced in ``log omega``): a 100k-point curve then costs what a 1000-point one does.
MAX_FIT_POINTS = 1000


def _binned(logw, log_gs, log_gl, wts, n_bins):
    """Bin means of a master curve: ``((log omega, log G', log G''), weights)`` per non-empty
    bin. Each column's mean is weighted by the squared residual weights and its weight is
    ``sqrt(sum w_i^2)``, so a bin's least-squares term equals that of its points at equal
    residuals."""
    edges = np.linspace(logw.min(), logw.max(), n_bins + 1)
    idx = np.clip(np.digitize(logw, edges) - 1, 0, n_bins - 1)
    count = np.bincount(idx, minlength=n_bins)
    out, wout = [np.bincount(idx, logw, n_bins) / np.maximum(count, 1)], []
    for k, y in enumerate((log_gs, log_gl)):
        w2 = np.bincount(idx, wts[:, k] ** 2, n_bins)
        out.append(np.bincount(idx, wts[:, k] ** 2 * y, n_bins) / np.where(w2 > 0, w2, 1.0))
        wout.append(np.sqrt(w2))
    keep = count > 0
    return tuple(o[keep] for o in out), np.stack(wout, axis=1)[keep]


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


@jax.jit
def _prony_jacobian(p, logw, log_gs, log_gl, log_tau_range, weight):
    """The Jacobian of :func:`_prony_residuals` in closed form (forward mode through the sum costs
    ``2n + 1`` passes; this one pass). With ``x = (omega tau_i)^2``:
    ``d G'/d log G_i = G_i x/(1+x)``, ``d G'/d log tau_i = 2 G_i x/(1+x)^2``,
    ``d G''/d log G_i = G_i sqrt(x)/(1+x)``, ``d G''/d log tau_i = G_i sqrt(x) (1-x)/(1+x)^2``,
    ``d log tau_i/d u_i = (hi - lo) s (1 - s)`` (``s`` the sigmoid of ``u_i``)."""
    n = (p.shape[0] - 1) // 2
    lo, hi = log_tau_range[0], log_tau_range[1]
    sig = jax.nn.sigmoid(p[n + 1 :])
    G_inf, G = jnp.exp(p[0]), jnp.exp(p[1 : n + 1])
    wt = jnp.exp(logw)[:, None] * jnp.exp(lo + (hi - lo) * sig)
    x = wt * wt
    den = 1.0 + x
    gs = G_inf + jnp.sum(G * x / den, axis=-1)
    gl = jnp.sum(G * wt / den, axis=-1)
    dtau = (hi - lo) * sig * (1.0 - sig)
    J_s = jnp.concatenate([(G_inf / gs)[:, None], G * x / den / gs[:, None],
                           G * 2.0 * x / den**2 * dtau / gs[:, None]], axis=1)
    J_l = jnp.concatenate([jnp.zeros((len(gl), 1)), G * wt / den / gl[:, None],
                           G * wt * (1.0 - x) / den**2 * dtau / gl[:, None]], axis=1)
    return jnp.concatenate([J_s, J_l], axis=0) * weight[:, None]


def _refine(p, args):
    """Levenberg-Marquardt from ``p`` (MINPACK, scaled by the Jacobian's columns: moduli and
    times differ in sensitivity by decades) on the jitted residual and its closed-form
    Jacobian. At most 300 evaluations: by then the cost is flat to ~1e-6 relative, and what
    remains moves terms that carry almost no modulus along a valley towards ``G_i -> 0``."""
    sol = least_squares(lambda x: _prony_residuals(jnp.asarray(x), *args),
                        lambda x: _prony_jacobian(jnp.asarray(x), *args), p, method="lm", rtol=1e-10,
                        max_evaluations=300, x_scale="jac")
    return sol.x


#: Relaxation times per decade of a smoothed fit (:func:`fit_prony` with ``smoothness``): at
#: one per decade the loss of a sum of Debye peaks ripples between the times.
SMOOTH_TERMS_PER_DECADE = 3

#: Default weight ``lambda`` of the smoothed fit's curvature penalty. Measured on the shipped
#: master curve (``benchmarks/prony_smoothness.py --rolling``, tables in docs/dma.md): the
#: rolling resistance of a 1 cm ball (10 N, H = 10 mm) from -40 to 100 degC turns in temperature
#: at its peak and a few times on the glassy side, where it is small and flat, at ``lambda = 3``;
#: more often at ``lambda = 1``, and with every term of the fewest-terms fit (one per decade).
SMOOTHNESS = 3.0

#: Relative error of the measured modulus ``|G*|`` [-] of the instrument error model: 1 %, an
#: assumption of the order of the "modulus precision" a DMA specification states (TA Instruments
#: Q800: +-1 %). Clamp and frame compliance bias a stiff (glassy) sample's ``|G*|`` low, which
#: this random error does not describe.
MODULUS_SIGMA = 0.01

#: An absolute error of the measured phase angle ``delta`` [rad] to pass as ``phase_sigma``:
#: 0.1 deg = 1.75 mrad, an assumption. Instrument sheets state a tan delta *sensitivity* (TA
#: Instruments Q800: 1e-4), a resolution, not the absolute phase accuracy, which clamp
#: compliance, inertia and calibration limit; we found no published absolute phase accuracy. At
#: 0.1 deg a loss factor of 0.02 carries +-9 %, 0.01 (a glassy plateau) +-17 %.
INSTRUMENT_PHASE_SIGMA = math.radians(0.1)

#: Default ``phase_sigma`` of :func:`fit_prony`: 0, storage and loss weighed alike. The
#: instrument error model (:data:`INSTRUMENT_PHASE_SIGMA`) lowers the shipped file's glassy
#: plateau bias but puts its loss low where tan delta is 0.02-0.1, by several times the loss
#: error that model itself assumes there, and lowers the rolling resistance near room
#: temperature (docs/dma.md, its generated tables): the data are not Kramers-Kronig-consistent
#: within the assumed errors, so the weights would choose the answer rather than describe the
#: instrument.
PHASE_SIGMA = 0.0


@dataclasses.dataclass(frozen=True)
class PronyFit:
    """A generalized Maxwell series fitted to a master curve (:func:`fit_prony`).

    Attributes:
        material: :class:`jaxroll.GeneralizedMaxwell` (``G_inf``, ``G_i`` [Pa], ``tau_i`` [s]).
        residuals: ``log(G'_fit / G'_meas)`` and ``log(G''_fit / G''_meas)`` at the master
            curve's points, shape ``(n_points, 2)`` (natural log: relative errors).
        rms: rms of ``residuals`` (storage and loss together) over the values fitted [-].
        n_terms: number of terms kept (non-zero moduli).
        weights: the caller's weights of the (storage, loss) residuals, ``(n_points, 2)`` (0: left
            out; the fit multiplies them by :func:`instrument_weights`).
        phase_sigma: the instrument error model the fit weighed its residuals with: absolute
            error of the phase angle [rad] (0: storage and loss weighed alike).
        modulus_sigma: relative error of ``|G*|`` [-] of that model.
    """

    material: GeneralizedMaxwell
    residuals: np.ndarray
    rms: float
    n_terms: int
    weights: np.ndarray | None = None
    phase_sigma: float = PHASE_SIGMA
    modulus_sigma: float = MODULUS_SIGMA

    def error_model(self) -> dict:
        """``{"phase_sigma": [rad], "modulus_sigma": [-]}``: the weights' error model, for a saved
        material's provenance (:func:`jaxroll.save_material` of a :class:`PronyFit`)."""
        return {"phase_sigma": self.phase_sigma, "modulus_sigma": self.modulus_sigma}


def instrument_weights(storage, loss, *, phase_sigma=INSTRUMENT_PHASE_SIGMA, modulus_sigma=MODULUS_SIGMA):
    """Weights ``(n, 2)`` of the log residuals of storage and loss for a DMA that errs by a
    relative ``modulus_sigma`` on ``|G*|`` and an absolute ``phase_sigma`` [rad] on ``delta``.

    From ``G' = |G*| cos delta``, ``G'' = |G*| sin delta``: ``d log G' = d log|G*| - tan(delta)
    d delta`` and ``d log G'' = d log|G*| + d delta / tan(delta)``, so the standard errors are
    ``sqrt(s_m^2 + tan^2(delta) s_p^2)`` and ``sqrt(s_m^2 + s_p^2 / tan^2(delta))``; the weights
    are ``s_m`` over these (1 where the phase error does not count; the two errors' correlation,
    ``s_m^2 - s_p^2``, is left out: correlation 0.94 at tan delta = 1, 0.06 at 0.01). The loss
    weight falls where tan delta is small, on the glassy and rubbery plateaus: a loss factor of
    0.01 measured to 1.75 mrad has the weight 0.06 of the storage's (0.003 of its influence on
    the squared residuals). ``phase_sigma=0`` weighs storage and loss alike (all ones)."""
    if not (math.isfinite(phase_sigma) and phase_sigma >= 0 and math.isfinite(modulus_sigma) and modulus_sigma > 0):
        raise ValueError(f"phase_sigma must be >= 0 and modulus_sigma > 0 (finite); got {phase_sigma}, {modulus_sigma}")
    if phase_sigma == 0:
        return np.ones((np.size(storage), 2))
    tan = np.asarray(loss, float) / np.asarray(storage, float)
    s_storage = np.hypot(modulus_sigma, tan * phase_sigma)
    s_loss = np.hypot(modulus_sigma, phase_sigma / tan)
    return modulus_sigma / np.stack([s_storage, s_loss], axis=1)


@jax.jit
def _smooth_residuals(p, log_wt, log_gs, log_gl, weight, smoothness):
    """Weighted log residuals of storage and loss of ``G_inf = e^p[0]``, ``G_i = e^p[1:]`` at
    fixed ``log(omega tau_i)`` (rows: points), then ``smoothness`` times the second differences
    of ``log G_i`` (the spectrum's curvature per term)."""
    gs, gl = _moduli_at(jnp.exp(p[0]), jnp.exp(p[1:]), log_wt)
    fit = jnp.concatenate([jnp.log(gs) - log_gs, jnp.log(gl) - log_gl]) * weight
    return jnp.concatenate([fit, smoothness * jnp.diff(p[1:], 2)])


def _moduli_at(G_inf, G, log_wt):
    """``G'``, ``G''`` of a generalized Maxwell series at ``omega tau_i = exp(log_wt)``."""
    wt = jnp.exp(log_wt)
    return G_inf + jnp.sum(G * wt**2 / (1 + wt**2), axis=-1), jnp.sum(G * wt / (1 + wt**2), axis=-1)


_smooth_jacobian = jax.jit(jax.jacfwd(_smooth_residuals))


def _smooth_fit(w, gs, gl, weight, lo, hi, smoothness) -> GeneralizedMaxwell:
    """Fixed times :data:`SMOOTH_TERMS_PER_DECADE` per decade over ``[lo - 0.5, hi + 0.5]``
    (decades of tau), moduli by Levenberg-Marquardt on the penalised log residuals
    (:func:`_smooth_residuals`), from an even spectrum at the curve's level."""
    logw, log_gs, log_gl = np.log(w), np.log(gs), np.log(gl)
    n = int(round((hi - lo + 1.0) * SMOOTH_TERMS_PER_DECADE)) + 1
    tau = np.logspace(lo - 0.5, hi + 0.5, n)
    log_wt = jnp.asarray(logw[:, None] + np.log(tau)[None, :])
    args = (log_wt, jnp.asarray(log_gs), jnp.asarray(log_gl), jnp.asarray(weight), float(smoothness))
    p0 = np.concatenate([[log_gs.min()], np.full(n, log_gs.max() + math.log(3.0 / n))])
    sol = least_squares(lambda x: _smooth_residuals(jnp.asarray(x), *args),
                        lambda x: _smooth_jacobian(jnp.asarray(x), *args), p0, method="lm", rtol=1e-10,
                        max_evaluations=2000, x_scale="jac")
    return GeneralizedMaxwell(G_inf=math.exp(sol.x[0]), G=np.exp(sol.x[1:]), tau=tau)


def _fewest_terms_fit(w, gs, gl, weight, lo, hi, n, refine) -> GeneralizedMaxwell:
    """``n`` log-spaced times over ``[lo, hi]`` (decades of tau), moduli ``>= 0`` by NNLS on the
    weighted relative residuals, terms NNLS sets to zero dropped; with ``refine``, the kept
    moduli and times by Levenberg-Marquardt on the log residuals (:func:`_refine`)."""
    from scipy.optimize import nnls

    tau = np.logspace(lo, hi, n) if n > 1 else np.array([10 ** (0.5 * (lo + hi))])
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
    tau = np.exp(lo_e + (hi_e - lo_e) / (1.0 + np.exp(-p[k + 1 :])))
    order = np.argsort(tau)
    return GeneralizedMaxwell(G_inf=math.exp(p[0]), G=np.exp(p[1 : k + 1])[order], tau=tau[order])


def _caller_weights(weights, n_points):
    """The caller's ``(n_points, 2)`` weights (all 1 by default), checked finite and ``>= 0``."""
    wts = np.ones((n_points, 2)) if weights is None else np.asarray(weights, float)
    if wts.shape != (n_points, 2) or not np.all(np.isfinite(wts) & (wts >= 0)):
        raise ValueError(f"weights must be finite, >= 0, of shape ({n_points}, 2) (storage, loss per point); got "
                         f"shape {wts.shape}")
    return wts


def _fitted_points(master, wts, phase_sigma, modulus_sigma):
    """``(omega, G', G'', weight)`` that the fit meets: the master curve's points, or above
    :data:`MAX_FIT_POINTS` the weighted bin means; ``weight`` (storage then loss) is the caller's
    times :func:`instrument_weights`."""
    w, gs, gl = master.omega, master.storage, master.loss
    wfit = wts * instrument_weights(gs, gl, phase_sigma=phase_sigma, modulus_sigma=modulus_sigma)
    if len(w) > MAX_FIT_POINTS:
        (lw, lgs, lgl), wfit = _binned(np.log(w), np.log(gs), np.log(gl), wfit, MAX_FIT_POINTS)
        w, gs, gl = np.exp(lw), np.exp(lgs), np.exp(lgl)
    return w, gs, gl, np.concatenate([wfit[:, 0], wfit[:, 1]])


def fit_prony(master: MasterCurve, *, smoothness=SMOOTHNESS, n_terms=None, refine=True, weights=None,
              phase_sigma=PHASE_SIGMA, modulus_sigma=MODULUS_SIGMA) -> PronyFit:
    """Fit a generalized Maxwell series (Prony series) to a master curve, storage and loss
    jointly.

    By default the spectrum is smooth: :data:`SMOOTH_TERMS_PER_DECADE` fixed relaxation times
    per decade (over the data's range, half a decade beyond each end) whose ``log G_i`` are fitted
    by Levenberg-Marquardt with the penalty ``lambda^2 sum (Delta^2 log G_i)^2`` added to the
    squared log residuals of storage and loss (``lambda = smoothness``, default
    :data:`SMOOTHNESS`): the loss curve has no ripples from the term spacing.

    Storage and loss are weighed alike by default. With ``phase_sigma > 0`` the residuals are
    weighted by an instrument error model (:func:`instrument_weights`): a relative error
    ``modulus_sigma`` on ``|G*|`` and an absolute error ``phase_sigma`` on the phase angle, so the
    loss counts less where tan delta is small. Where measured storage and loss are not
    Kramers-Kronig-consistent, the weights decide which one the fit follows (docs/dma.md, "The
    glassy plateau and the instrument's errors", measured by ``benchmarks/prony_smoothness.py``).

    With ``smoothness=None``, the fewest terms instead: relaxation times are log-spaced over the data's reduced-frequency range,
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
        smoothness: ``lambda > 0``, the weight of the curvature penalty of the smooth spectrum
            (default :data:`SMOOTHNESS`), or ``None``: the fewest terms (NNLS + refinement).
        n_terms: (``smoothness=None`` only) number of relaxation times before pruning (default:
            one per decade of the reduced-frequency range, plus one).
        refine: (``smoothness=None`` only) refine the NNLS solution (default True).
        weights: array ``(n_points, 2)`` of weights >= 0 of each point's (storage, loss)
            residual (default all 1); 0 leaves a value out of the fit (e.g. the instrument
            artifacts :func:`loss_artifacts` finds); every residual is still reported. Above
            :data:`MAX_FIT_POINTS` points the fit is made to weighted bin means. They multiply
            the instrument weights.
        phase_sigma: absolute error of the phase angle [rad] of the instrument error model
            (default 0: storage and loss alike; e.g. :data:`INSTRUMENT_PHASE_SIGMA`, 0.1 deg).
        modulus_sigma: relative error of ``|G*|`` [-] (default :data:`MODULUS_SIGMA`, 1 %; it
            matters only with ``phase_sigma > 0``).

    Returns:
        :class:`PronyFit`, with the error model it was weighed by; a :class:`jaxroll.DataWarning`
        when its rms log residual (unweighted: what the report prints) exceeds :data:`MAX_PRONY_RMS`.
    """
    w = master.omega
    lo, hi = -math.log10(w.max()), -math.log10(w.min())  # logs first: 1/omega overflows below 1e-308
    n = int(n_terms) if n_terms is not None else int(math.ceil(hi - lo)) + 1
    if n < 1:
        raise ValueError(f"n_terms must be >= 1; got {n_terms}")
    wts = _caller_weights(weights, len(w))
    if smoothness is not None:
        if not (math.isfinite(smoothness) and smoothness > 0):
            raise ValueError(f"smoothness must be finite and > 0 (or None); got {smoothness}")
        if n_terms is not None or refine is not True:
            raise ValueError("n_terms and refine belong to the fewest-terms fit: pass smoothness=None with them")
    points = _fitted_points(master, wts, phase_sigma, modulus_sigma)
    if smoothness is None:
        mat = _fewest_terms_fit(*points, lo, hi, n, refine)
    else:
        mat = _smooth_fit(*points, lo, hi, smoothness)
    return _result(mat, master, wts, phase_sigma, modulus_sigma)


def _result(mat, master, wts, phase_sigma, modulus_sigma):
    """The :class:`PronyFit` of ``mat`` with its log residuals at every point of ``master``; warns
    when their rms over the values fitted (caller's weight > 0) exceeds :data:`MAX_PRONY_RMS`."""
    gs, gl = prony_moduli(mat.G_inf, jnp.asarray(mat.G), jnp.asarray(mat.tau), jnp.asarray(master.omega))
    r = np.stack([np.log(np.asarray(gs)) - np.log(master.storage), np.log(np.asarray(gl)) - np.log(master.loss)],
                 axis=1)
    rms = float(np.sqrt(np.mean(r[wts > 0] ** 2)))
    if rms > MAX_PRONY_RMS:
        warnings.warn(f"the Prony fit misses the master curve by an rms log residual of {rms:.3g} (more than "
                      f"{MAX_PRONY_RMS}, a factor {math.exp(rms):.3g}): the sets do not superpose (check the data "
                      "warnings: units, swapped columns, shift factors) or the series needs more terms (n_terms)",
                      DataWarning, stacklevel=3)
    return PronyFit(material=mat, residuals=r, rms=rms, n_terms=len(np.atleast_1d(mat.tau)), weights=wts,
                    phase_sigma=float(phase_sigma), modulus_sigma=float(modulus_sigma))
