"""The one nonlinear least-squares driver of jaxroll: :func:`scipy.optimize.least_squares` on
host callables (a compiled JAX residual and its compiled Jacobian, or plain NumPy).

Used by :func:`jaxroll.fit_material`, the Prony refinement of :func:`jaxroll.fit_prony` and
:func:`jaxroll.fit_wlf`, so that every fit shares one iteration, one stopping rule and one
meaning of "converged".
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["Solution", "Z95", "gauss_newton_distance", "least_squares"]

Z95 = 1.959963984540054  # the two-sided 95 % quantile of the standard normal distribution


@dataclasses.dataclass(frozen=True)
class Solution:
    """Outcome of :func:`least_squares`.

    Attributes:
        x: the minimiser.
        residuals, jacobian: ``r(x)`` and ``dr/dx`` at ``x``.
        cost: ``0.5 |r(x)|^2``.
        converged: a stopping tolerance was met (not the evaluation cap, not a failure).
        evaluations: residual evaluations.
        message: scipy's reason for stopping.
    """

    x: np.ndarray
    residuals: np.ndarray
    jacobian: np.ndarray
    cost: float
    converged: bool
    evaluations: int
    message: str


class _Stop(Exception):
    """Raised inside the driver at a point where the caller's stopping rule holds."""

    def __init__(self, x, r, J):
        super().__init__()
        self.x, self.r, self.J = x, r, J


def gauss_newton_distance(r, J, noise=None) -> float:
    """Distance from ``x`` to the minimiser of the Gauss-Newton model of ``0.5 |r|^2`` at ``x``
    in standard errors of the parameters: ``sqrt(2 delta / s^2)``, ``delta = 0.5 |P_J r|^2`` the
    cost reduction of the full Gauss-Newton step (``P_J`` the projection onto the range of
    ``J``) and ``s^2`` the noise variance (``noise``; default the reduced chi^2
    ``|r|^2/(n - k)``). It is the step's length in the metric of the covariance
    ``s^2 (J^T J)^-1``, so it bounds every parameter's part of the step in its own standard
    errors. It is the linearised model's distance: along a curved, nearly flat valley the true
    distance to the optimum differed from it several-fold, either way (benchmarks/LOG.md, "The
    sphere fit's evaluation count")."""
    r, J = np.asarray(r, float), np.asarray(J, float)
    step = np.linalg.lstsq(J, r, rcond=None)[0]
    projected = J @ step
    s2 = float(r @ r) / max(r.size - J.shape[1], 1) if noise is None else float(noise)
    return float(np.sqrt(max(float(projected @ projected), 0.0) / max(s2, 1e-300)))


def least_squares(residuals, jacobian, x0, *, method="trf", rtol=1e-10, max_evaluations=500, bounds=None,
                  x_scale=1.0, stop=None) -> Solution:
    """Minimise ``0.5 |r(x)|^2`` from ``x0``.

    Args:
        residuals: ``x -> r`` (NumPy array in, array-like out).
        jacobian: ``x -> dr/dx``, shape ``(len(r), len(x))``.
        x0: starting point.
        method: ``"trf"`` (trust-region reflective, the default; bounds allowed) or ``"lm"``
            (MINPACK's Levenberg-Marquardt; no bounds).
        rtol: relative tolerance on the cost reduction and on the step (scipy's ``ftol`` and
            ``xtol``) and absolute tolerance on the gradient (``gtol``).
        max_evaluations: cap on residual evaluations (then ``converged`` is False).
        bounds: ``(lower, upper)`` arrays or scalars, or None.
        x_scale: characteristic scale of each variable, or ``"jac"`` (from the Jacobian's
            columns, updated during the iteration).
        stop: ``None`` or a stopping rule ``(x, r, J) -> bool`` checked at the start and at
            every accepted point (where the driver asks for the Jacobian): where it holds, the
            iteration ends there (``converged``), e.g. where a coarse answer is enough
            (:func:`jaxroll.fit_material` stops a run on a grid that its point has outgrown once
            :func:`gauss_newton_distance` is small).

    The iteration runs in the displacement ``x - x0``: scipy sizes its first trust region from
    the norm of the starting point, which would make the first step depend on the origin of
    the parameters (log-parameters of moduli are ~14); from ``x0 = 0`` the first region has
    radius 1 in the scaled variables (a factor ``e`` for a log-parameter).
    """
    from scipy.optimize import least_squares as scipy_least_squares

    if method not in ("trf", "lm"):
        raise ValueError(f"method must be 'trf' or 'lm'; got {method!r}")
    x0 = np.asarray(x0, float)
    lo, hi = (-np.inf, np.inf) if bounds is None else bounds
    latest, count = {}, [0]

    def fun(d):
        count[0] += 1
        latest.update(d=np.array(d), r=np.asarray(residuals(x0 + d), float))
        return latest["r"]

    def jac(d):  # scipy asks for the Jacobian at the start and at accepted points, after their residuals
        J = np.asarray(jacobian(x0 + d), float)
        if stop is not None and np.array_equal(latest.get("d"), d) and np.all(np.isfinite(latest["r"])):
            if stop(x0 + d, latest["r"], J):
                raise _Stop(x0 + d, latest["r"], J)
        return J

    try:
        sol = scipy_least_squares(fun, np.zeros_like(x0), jac=jac,
                                  bounds=(np.asarray(lo, float) - x0, np.asarray(hi, float) - x0), method=method,
                                  ftol=rtol, xtol=rtol, gtol=rtol, max_nfev=int(max_evaluations), x_scale=x_scale)
    except _Stop as end:
        return Solution(x=end.x, residuals=end.r, jacobian=end.J, cost=0.5 * float(end.r @ end.r), converged=True,
                        evaluations=count[0], message="the caller's stopping rule holds")
    return Solution(x=x0 + sol.x, residuals=np.asarray(sol.fun), jacobian=np.asarray(sol.jac), cost=float(sol.cost),
                    converged=bool(sol.status > 0), evaluations=int(sol.nfev), message=str(sol.message))
