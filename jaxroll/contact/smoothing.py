"""Smoothed contact edge (``smoothing=eps`` of :func:`jaxroll.contact.solve_contact`).

Because the contact set changes by whole cells, any functional of the exact discrete solution
(e.g. the rolling resistance) is only piecewise smooth: it wiggles around its continuum value
with a kink at every contact-set change (0.2-0.3 % for a 3D sphere at 9-23 cells per contact
radius). Least-squares fits along nearly degenerate parameter valleys stall on such wiggles.
With ``smoothing`` the complementarity ``min(c0 p, g) = 0`` becomes the log-sum-exp soft
minimum ``exp(-c0 p/eps) + exp(-g/eps) = 1``: a cell enters the contact gradually, the solution
is C-infinity in the parameters, and it is found by damped Newton (Armijo on the residual) from
the exact active-set solution, each step a GMRES solve on the whole window with the soft-min
weights (the active-set system is the special case of 0/1 weights). Derivatives: the converged
iterate is returned as the root of the smoothed equations through :func:`jax.lax.custom_root`
(implicit function theorem: one linear solve per tangent, none in the forward pass). The price is a bias: the soft
edge lets cells with a small gap carry load; the 3D rolling resistance falls by ~1 % on
average at the smoothing used for fits (see :func:`jaxroll.engines.sphere3d.solve_sphere`,
``edge_smoothing``), and the bias vanishes with ``eps``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from .precondition import CirculantPreconditioner
from .system import ContactSystem

__all__ = ["continuation_solve", "edge_gap_scale", "extrapolated_solve", "smoothed_solve"]

#: Step lengths tried by the damped Newton iteration (Armijo backtracking); NumPy, so that importing
#: the package compiles nothing.
_ALPHAS = 0.5 ** np.arange(10.0)

#: Largest relative residual of a damped Newton step's linear solve (:func:`smoothed_solve`): the
#: forcing term is ``min(max |F|, this)``, ``F`` the scaled soft-min residual.
NEWTON_FORCING_MAX = 1e-2

#: Relative residual of the derivatives' linear solves (tangent, or adjoint in reverse mode) of
#: :func:`smoothed_solve`. A derivative's relative error is of this order times the system's
#: conditioning: on the 60-point sphere fit benchmark (65-cell windows, kappa and 2 kappa) its
#: Jacobian moved by 4e-9 relative against solves at 1e-13 (the former ``1e-3 tol``), and one
#: residual-and-Jacobian evaluation took 9 % less time (1e-6: 3e-7 and 12 % less;
#: benchmarks/LOG.md, "The sphere fit's evaluation count").
TANGENT_RTOL = 1e-8

#: Tolerance of the partner solve of :func:`extrapolated_solve` (the smoothed solution at
#: ``2 eps``) as a multiple of ``tol``. The partner only estimates the smoothing's bias, which the
#: extrapolation removes: its error enters the result times ``1/(2^q - 1)`` and as a share of that
#: bias (~1 % of ``R_r``), and its damped Newton iteration, quadratic by then, stops a step earlier.
#: On the 60-point sphere fit benchmark (65-cell windows, ``tol`` 1e-10) the residuals moved by
#: 1.1e-6 of a standard deviation (2e-8 of ``R_r``), chi^2 by 1e-6 and the Jacobian by 1e-7
#: relative, and one warm-started evaluation took 0.81x the time (1e4: 0.88x, 4e-7 and 3e-8;
#: benchmarks/LOG.md, "The partner solve of the extrapolated edge"). At most
#: :data:`PARTNER_TOL_MAX`.
PARTNER_TOL_FACTOR = 1e5

#: Largest tolerance of that partner solve (the value at the default ``tol`` of 1e-10): with a
#: loose ``tol`` (1e-6) the factor alone would stop the partner after one Newton step and leave
#: 4e-4 of the peak pressure in the extrapolated solution (1 % of the bias it removes).
PARTNER_TOL_MAX = 1e-5


#: Gap scales of :func:`continuation_solve`'s levels, in units of the system's gap scale ``g_s``
#: (the gap that the mean pressure of the initial contact set closes over one cell), a factor 4
#: apart where no level fails (a failed one is retried nearer the one before). At the first the soft
#: minimum blurs the edge over several cells and the damped Newton iteration converges from a smooth
#: start; each later level starts from the one before; at the last the cells where the gap condition
#: dominates are the exact contact set to within a few cells. Loss-dominated contact (SLS G0 = 3
#: MPa, tau = 0.25 s, f = 1000, half-space, R = 2 cm, 100 N, 10 mm/s, 32 cells per radius;
#: benchmarks/LOG.md 2026-12-08): 35 Newton steps over the six levels, then 3 active-set steps, 1.1
#: s, where the active-set search alone took 162 steps and 86-91 s (the same R_r to 1e-13). (From
#: the search's first solve, as first built, starting at 1 g_s instead of 16 the first level took 51
#: Newton steps; at 4, 37.)
CONTINUATION_LEVELS = 16.0 * 0.25 ** np.arange(6.0)
#: Scaled residual at which a level of :func:`continuation_solve` passes to the next (the exact
#: search that follows decides the set to ``tol``).
CONTINUATION_TOL = 1e-4
#: Most damped Newton steps at one level of :func:`continuation_solve` after the first (which has
#: no converged level to fall back on and iterates on): a level that has not converged by then is
#: tried again at half its step from the last converged one. Levels that converge took 3-7 steps
#: (once 12 and once 17) in the cases of benchmarks/LOG.md 2026-12-08; those that did not, on
#: warm-started table points with fixed levels a factor 4 apart, ran their 20 steps at max |F|
#: 26-30 and every level after them failed too (150-200 steps in all, one 179 where the halved
#: step takes 58).
CONTINUATION_LEVEL_STEPS = 12
#: Most damped Newton steps of one :func:`continuation_solve` (six levels of 20 as first built;
#: the search that follows starts from the last converged level).
CONTINUATION_MAX_STEPS = 120


def _residual(system: ContactSystem, x, c0_ratio, eps):
    """Soft-min residual ``-eps log(exp(-a/eps) + exp(-g/eps))`` (``a = c0 p / g_s``) with the last
    row, and the soft-min arguments ``(a, g~)``."""
    pt = x[:-1].reshape(system.shape)
    gt = system.gap(pt, x[-1])
    a = c0_ratio * pt
    F = -eps * jnp.logaddexp(-a / eps, -gt / eps)
    return jnp.concatenate([F.ravel(), (system.last_row(pt, x[-1]) - system.target)[None]]), a, gt


def _trial(system: ContactSystem, x, a, gt, step, d_gap, alpha, eps):
    """:func:`_residual` at ``x + alpha step`` (``c0_ratio`` 1) from the iterate's soft-min
    arguments ``(a, g~)`` and the step's gap change ``d_gap`` (the gap is affine in ``x``), without
    an operator application."""
    pt = x[:-1].reshape(system.shape) + alpha * step[:-1].reshape(system.shape)
    a_t, gt_t = a + alpha * step[:-1].reshape(system.shape), gt + alpha * d_gap
    F = -eps * jnp.logaddexp(-a_t / eps, -gt_t / eps)
    last = system.last_row(pt, x[-1] + alpha * step[-1]) - system.target
    return jnp.concatenate([F.ravel(), last[None]]), a_t, gt_t


def _jacobian(system: ContactSystem, a, gt, eps, precond: CirculantPreconditioner | None):
    """``(matvec, preconditioner)`` of the soft-min residual's Jacobian at ``(a, g~)``:
    ``preconditioner(transpose)`` is the pair ``(M_cheap, M_whole)`` (or their transposes) of
    :meth:`~jaxroll.contact.precondition.CirculantPreconditioner.block`, ``None`` without a
    preconditioner."""
    w_a = jax.nn.sigmoid((gt - a) / eps)  # d smin / d a; d smin / d g = 1 - w_a
    ratio = system.p_s / system.g_s

    def matvec(v):
        vp = v[:-1].reshape(system.shape)
        rows = w_a * vp + (1.0 - w_a) * (system.compliance(vp) * ratio - v[-1])
        return jnp.concatenate([rows.ravel(), system.last_row(vp, v[-1])[None]])

    def preconditioner(transpose):
        if precond is None:
            return None
        in_set = w_a < 0.5  # gap-dominated rows (the contact): ~ (1 - w_a) C
        v, c = system.border(jnp.ones(system.shape))
        return precond.block(in_set, 1.0 - w_a, w_a, -(1.0 - w_a), v, c, transpose)

    return matvec, preconditioner


def _newton_step(fixed: ContactSystem, x, res, eps_t, solver, precond, tol, robust):
    """One damped Newton step on the soft-min residual at the scaled gap scale ``eps_t``:
    ``(x, (F, a, g~)) -> (x', (F', a', g~'))``, the iterate carrying its residual and soft-min
    arguments. The gap is affine in ``x``, so the trial steps' gaps are ``g~ + alpha C(step)``: one
    operator application per Newton step for all the Armijo trials (the accepted trial's values
    become the next iterate's)."""
    F, a, gt = res
    mv, M = _jacobian(fixed, a, gt, eps_t, precond)
    # inexact Newton: the step's relative residual min(|F|, 1e-2) (Eisenstat-Walker's forcing
    # term |F|) keeps the convergence quadratic at a fraction of the Krylov iterations of a
    # solve at 1e-3 tol; the stopping tests are on the residual F itself
    rtol = jnp.clip(jnp.max(jnp.abs(F)), tol * 1e-3, NEWTON_FORCING_MAX)
    step = solver.solve_tracked(mv, -F, None, M(False), rtol, robust)[0]
    s_p = step[:-1].reshape(fixed.shape)
    d_gap = fixed.compliance(s_p) * (fixed.p_s / fixed.g_s) - step[-1]  # the gap's change per unit step
    trials = jax.vmap(lambda al: _trial(fixed, x, a, gt, step, d_gap, al, eps_t))(jnp.asarray(_ALPHAS))
    merit = jnp.sum(trials[0] ** 2, axis=1)
    ok = merit <= (1.0 - 1e-4 * _ALPHAS) * jnp.sum(F * F)  # Armijo on |F|^2
    k = jnp.where(jnp.any(ok), jnp.argmax(ok), _ALPHAS.size - 1)
    return x + jnp.asarray(_ALPHAS)[k] * step, jax.tree_util.tree_map(lambda t: t[k], trials)


def smoothed_solve(system: ContactSystem, x_exact, eps, solver, precond, *, tol, max_steps, robust=None):
    """Damped Newton on ``smin_eps(c0 p, g) = 0`` from the exact solution ``x_exact``.

    Args:
        system: the differentiable system (its stopped copy drives the iterations).
        x_exact: the exact (active-set) scaled solution, ``stop_gradient``.
        eps: gap scale [m] (traced allowed).
        solver, precond: linear solver and preconditioner (or ``None``); robust: whether the
            active set's solves needed the robust level of the preconditioner pair (then every
            solve here starts with it; :meth:`~jaxroll.contact.linear.AbstractLinearSolver.solve_tracked`).

    Returns:
        ``(x, contact, iterations, converged, residual)``: ``x`` the converged iterate (to ``tol``),
        differentiable as the root of the smoothed equations (``dx = -J^{-1} dF``, one linear
        solve per tangent); ``contact`` the cells where the gap condition dominates (``c0 p > g``).
    """
    sg = jax.lax.stop_gradient
    fixed = system.stopped()
    eps_t = sg(eps / system.g_s)
    c0 = jnp.abs(fixed.compliance.self_compliance)

    def newton(state):
        x, res, it, _ = state
        x, res = _newton_step(fixed, x, res, eps_t, solver, precond, tol, robust)
        done = (jnp.max(jnp.abs(res[0])) <= tol) | ~jnp.all(jnp.isfinite(x))
        return x, res, it + 1, done

    x_s, (F_s, a_s, gt_s), n_it, n_done = jax.lax.while_loop(
        lambda s: (~s[3]) & (s[2] < max_steps), newton,
        (x_exact, _residual(fixed, x_exact, 1.0, eps_t), jnp.asarray(0), jnp.asarray(False)),
    )
    x_s, F_s, a_s, gt_s = sg(x_s), sg(F_s), sg(a_s), sg(gt_s)
    # x_s is returned as the root of the smoothed equations (custom_root: the forward pass costs
    # no further solve); the derivatives solve J dx = -dF once per tangent. The derivative of c0
    # enters through c0_ratio = c0(theta)/c0 (value 1)
    c0_ratio = jnp.abs(system.compliance.self_compliance) / c0
    mv, M = _jacobian(fixed, a_s, gt_s, eps_t, precond)

    def tangent_solve(g, y):
        return jax.lax.custom_linear_solve(
            mv, y,
            solve=lambda f, bb: solver.solve_derivative(f, bb, M(False), TANGENT_RTOL),
            transpose_solve=lambda f, bb: solver.solve_derivative(f, bb, M(True), TANGENT_RTOL),
        )

    x = jax.lax.custom_root(lambda v: _residual(system, v, c0_ratio, eps / system.g_s)[0], x_s,
                            lambda f, x0: x0, tangent_solve)
    return x, sg(gt_s < a_s), n_it, n_done, jnp.max(jnp.abs(F_s))


def extrapolated_solve(system: ContactSystem, x_exact, eps, solver, precond, *, order, tol, max_steps, robust=None):
    """Richardson extrapolation of the smoothed solution to ``eps -> 0``: the smoothed solutions
    at ``eps`` and ``2 eps`` combined as ``x_eps + (x_eps - x_2eps)/(2^order - 1)``, which cancels
    a bias ``~ c eps^order``. Each solution is C-infinity in the parameters, so the combination is
    too; the second solve starts from the first (a few Newton steps) and stops at
    :data:`PARTNER_TOL_FACTOR` times ``tol`` (at most :data:`PARTNER_TOL_MAX`). Arguments and
    returns as :func:`smoothed_solve` (the contact set is the one at ``eps``; iterations add up;
    the residual is the larger of the two solves' residuals, each over its own tolerance, times
    ``tol``)."""
    def one(start, e_and_tol):  # one program for both solves (a scan of two steps): half the compilation
        e, t = e_and_tol
        x, contact, n, ok, r = smoothed_solve(system, start, e, solver, precond, tol=t, max_steps=max_steps,
                                              robust=robust)
        return jax.lax.stop_gradient(x), (x, contact, n, ok, r)

    tols = np.asarray([tol, min(PARTNER_TOL_FACTOR * tol, PARTNER_TOL_MAX)])  # the partner to its own
    _, (x, contact, n, ok, r) = jax.lax.scan(one, x_exact, (jnp.stack([eps, 2.0 * eps]), jnp.asarray(tols)))
    w = 1.0 / (2.0 ** order - 1.0)
    # the residual in units of the first solve's tolerance (each solve against its own)
    return x[0] + w * (x[0] - x[1]), contact[0], jnp.sum(n), jnp.all(ok), jnp.max(r * (tol / tols))


def continuation_solve(fixed: ContactSystem, x0, solver, precond, *, active, robust=None):
    """The smoothed edge continued from a wide soft minimum to a narrow one: the start of an exact
    search where the active-set iteration does not contract
    (:func:`~jaxroll.contact.active_set.find_contact_set` gives up).

    One ``while_loop`` over damped Newton steps (:func:`_newton_step`) on a gap scale that
    narrows from the first of :data:`CONTINUATION_LEVELS` to the last, a factor 4 per level. A
    level that reaches :data:`CONTINUATION_TOL` passes its iterate to the next; one that has not
    within :data:`CONTINUATION_LEVEL_STEPS` steps is tried again from the last converged iterate
    at half the step in log scale (the first level, which has none, iterates on), and the step
    grows back (to a factor 4) after each converged level. A new level's residual comes from the
    same soft-min arguments (no operator application). At most :data:`CONTINUATION_MAX_STEPS`
    steps.

    Args:
        fixed: the stopped system; x0: the start (scaled unknowns: a warm start's solution, or
            :meth:`~jaxroll.contact.system.ContactSystem.elliptic_start` on the initial set; negative
            pressures are clipped to 0). active: traced bool; where false, no
            step is taken (a batch's lanes that need no continuation cost an operator application
            here and one for the start).
        solver, precond: as :func:`smoothed_solve`.

    Returns:
        ``(x, contact, steps, converged)`` on ``stop_gradient`` data: the last converged level's
        iterate (the start if none converged), its cells where the gap condition dominates, the
        Newton steps taken, and whether any level converged.
    """
    log_first, log_last = np.log(CONTINUATION_LEVELS[0]), np.log(CONTINUATION_LEVELS[-1])
    log_ratio = np.log(CONTINUATION_LEVELS[1] / CONTINUATION_LEVELS[0])  # < 0
    pt0 = jnp.maximum(x0[:-1], 0.0)
    x0 = jnp.concatenate([pt0, x0[-1:]])

    def at(a, gt, F_last, log_e):
        e = jnp.exp(log_e)
        return jnp.concatenate([(-e * jnp.logaddexp(-a / e, -gt / e)).ravel(), F_last[None]])

    def body(state):
        x, (F, a, gt), log_e, at_level, fallback, log_step, steps, _ = state
        x, (F, a, gt) = _newton_step(fixed, x, (F, a, gt), jnp.exp(log_e), solver, precond, CONTINUATION_TOL, robust)
        passed = jnp.max(jnp.abs(F)) <= CONTINUATION_TOL
        x_ok, soft_ok, log_ok, any_ok = fallback
        # the first level has no fallback: it iterates until it converges
        failed = ~passed & (at_level + 1 >= CONTINUATION_LEVEL_STEPS) & any_ok
        done = passed & (log_e == log_last)
        # a converged level becomes the fallback, and the scale narrows by a step that grows back;
        # a failed one is tried again from the fallback at half the step it took (so every scale
        # lies between the fallback's and the last level's)
        log_step = jnp.where(passed, jnp.maximum(2.0 * log_step, log_ratio),
                             jnp.where(failed, 0.5 * (log_e - log_ok), log_step))
        fallback = jax.tree_util.tree_map(lambda new, old: jnp.where(passed, new, old),
                                          (x, (a, gt, F[-1]), log_e, jnp.asarray(True)), fallback)
        x = jnp.where(failed, x_ok, x)
        a, gt, last = jax.tree_util.tree_map(lambda n, o: jnp.where(failed, o, n), (a, gt, F[-1]), soft_ok)
        log_e = jnp.where(passed, jnp.maximum(log_e + log_step, log_last), jnp.where(failed, log_ok + log_step, log_e))
        F = jnp.where(passed | failed, at(a, gt, last, log_e), F)
        at_level = jnp.where(passed | failed, 0, at_level + 1)
        return x, (F, a, gt), log_e, at_level, fallback, log_step, steps + 1, done

    def cond(state):
        x, *_, steps, done = state
        return active & ~done & (steps < CONTINUATION_MAX_STEPS) & jnp.all(jnp.isfinite(x))

    F0, a0, gt0 = _residual(fixed, x0, 1.0, CONTINUATION_LEVELS[0])
    fallback = (x0, (a0, gt0, F0[-1]), jnp.asarray(log_first), jnp.asarray(False))  # no level converged yet
    init = (x0, (F0, a0, gt0), jnp.asarray(log_first), jnp.asarray(0), fallback, jnp.asarray(log_ratio),
            jnp.asarray(0), jnp.asarray(False))
    _, _, _, _, (x, (a, gt, _), _, converged), _, steps, _ = jax.lax.while_loop(cond, body, init)
    sg = jax.lax.stop_gradient
    return sg(x), sg(gt < a), steps, converged


def edge_gap_scale(kappa, cell_size, contact_radius, radius):
    """Gap scale ``eps`` [m] for ``smoothing`` of :func:`jaxroll.contact.solve_contact`:
    ``kappa a^{3/2} c^{1/2} / R``.

    Near the edge of a Hertz contact (sphere or cylinder) of radius/half-width ``c`` and
    penetration ``~ c^2/R`` the gap grows like ``(c^2/R) (s/c)^{3/2}`` with the distance ``s``
    outside the edge, so this is (up to an O(1) factor) the gap one cell of size ``a`` outside
    the edge, and ``kappa`` measures the smoothing in cells. Give a smooth estimate of ``c``
    (e.g. the Hertz/Jaffar radius), never the discrete contact size, or the smoothed solution
    stops being smooth in the parameters. ``kappa = None`` returns ``None`` (no smoothing).
    """
    if kappa is None:
        return None
    return kappa * cell_size * jnp.sqrt(cell_size * contact_radius) / radius
