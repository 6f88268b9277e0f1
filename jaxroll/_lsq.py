"""The one nonlinear least-squares driver of jaxroll: :func:`scipy.optimize.least_squares` on
host callables (a compiled JAX residual and its compiled Jacobian, or plain NumPy).

Used by :func:`jaxroll.fit_material`, the Prony refinement of :func:`jaxroll.fit_prony` and
:func:`jaxroll.fit_wlf`, so that every fit shares one iteration, one stopping rule and one
meaning of "converged".
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["Solution", "Z95", "least_squares"]

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


def least_squares(residuals, jacobian, x0, *, method="trf", rtol=1e-10, max_evaluations=500, bounds=None,
                  x_scale=1.0) -> Solution:
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
    sol = scipy_least_squares(lambda d: np.asarray(residuals(x0 + d), float),
                              np.zeros_like(x0), jac=lambda d: np.asarray(jacobian(x0 + d), float),
                              bounds=(np.asarray(lo, float) - x0, np.asarray(hi, float) - x0), method=method,
                              ftol=rtol, xtol=rtol, gtol=rtol, max_nfev=int(max_evaluations), x_scale=x_scale)
    return Solution(x=x0 + sol.x, residuals=np.asarray(sol.fun), jacobian=np.asarray(sol.jac), cost=float(sol.cost),
                    converged=bool(sol.status > 0), evaluations=int(sol.nfev), message=str(sol.message))
