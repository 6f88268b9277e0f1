"""Differentiable steady-state rolling contact: the front door :func:`solve_contact`.

Contact problem and solver
--------------------------
Unknowns: pressure ``p >= 0`` on the window cells, penetration ``d``. Gap
``g = h - d + C p >= 0``, ``p g = 0``, ``sum(p) dA = P`` (``h`` = height of the rigid profile
above its lowest point, ``dA`` = cell area). That is the load-controlled problem; in the
penetration-controlled one ``d`` is given and the last equation is ``d = d_given`` instead (same
unknowns, same solver; the load is ``sum(p) dA`` afterwards). ``C`` is not symmetric for a
viscoelastic layer, so the Polonsky-Keer CG is not used: the solver is a primal-dual
active-set method (semismooth Newton on ``min(p, g) = 0``). Each step solves the
equality-constrained system on the current contact set ``A`` (``g_A = 0``, ``p`` off ``A`` = 0,
load or penetration), then updates ``A = {p > 0 on A} U {g < 0 off A}``; it stops when ``A``
repeats. Each step's linear system is solved by a :mod:`~jaxroll.contact.linear` solver object
(:class:`~jaxroll.contact.linear.GMRES` by default, right-preconditioned on 2D windows by
:class:`~jaxroll.contact.precondition.CirculantPreconditioner`); the iteration is
:func:`~jaxroll.contact.active_set.find_contact_set`.

Speed (``benchmarks/bench_sphere3d.py``, the paper's reference case of 345 solves): each solve
takes ~3 active-set steps and ~25 operator applications; an operator application is one FFT
pair pruned to the window (:func:`~jaxroll.contact.operator.circulant_window_apply`), a
preconditioner application one FFT pair of the folded period (about a quarter of the points; of
the same embedding where a solve stagnated, :mod:`~jaxroll.contact.precondition`), and the Krylov bookkeeping
(:func:`jaxroll._numerics.gmres`, most steps in a basis of 13 vectors) costs less than either.

Differentiation
---------------
On the converged contact set the solution is the solution of a linear system whose matrix
depends on ``T`` (material, layer, speed) and whose right-hand side depends on ``h`` and ``P``
(or the prescribed ``d``).
The converged unknowns are returned as the root of that system through
:func:`jax.lax.custom_root` (the forward pass costs no extra solve), so derivatives of any functional of the solution follow from the implicit function
theorem (one adjoint GMRES solve, from zero to the relative residual ``tol``, on the
preconditioner level the forward solves of the same contact ended with (the folded one unless
they needed the whole embedding's; :meth:`~jaxroll.contact.linear.GMRES.solve_derivative`):
derivatives to ~``tol`` relative, measured 2e-11 on the reference table's gradient against
solves at ``1e-3 tol`` and 3e-11 between the two levels), never from unrolling the active-set iterations (which run
on ``stop_gradient`` inputs). The contact set is piecewise constant in the parameters; at a
contact-edge event the derivative is the finite one-sided derivative of the discrete problem.

With ``smoothing=eps`` the contact edge is smoothed instead (:mod:`jaxroll.contact.smoothing`).
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.ad_checkpoint import checkpoint_name

from .._numerics import check_input
from ..result import RESULTS, first_failure
from .active_set import find_contact_set
from .linear import GMRES, AbstractLinearSolver, Dense, check_linear_solver
from .operator import WindowedCompliance
from .precondition import CirculantPreconditioner
from .smoothing import continuation_solve, extrapolated_solve, smoothed_solve
from .system import ContactSystem, flat

__all__ = ["ContactSolution", "WarmStart", "solve_contact", "SAVED_FOR_DERIVATIVES"]

#: Name (``jax.ad_checkpoint.checkpoint_name``) of what the active-set iteration returns: the
#: converged contact set, the scaled solution and the iteration's counters.
SOLUTION_NAME = "jaxroll_contact_solution"
#: ``jax.checkpoint`` policy for a loop body that solves contacts (e.g. a ``lax.scan`` over loads):
#: reverse mode keeps only each solve's converged set and solution and recomputes the rest of the
#: body (never the active-set iteration), instead of stacking every intermediate of the body:
#: fewer arrays carried from the forward to the backward pass, and a shorter compile.
SAVED_FOR_DERIVATIVES = jax.checkpoint_policies.save_only_these_names(SOLUTION_NAME)


class ContactSolution(eqx.Module):
    """Solution of the rolling contact problem on the window grid.

    Attributes:
        pressure: contact pressure [Pa] on the window cells.
        penetration: rigid-body penetration ``d`` [m] (the given one in penetration mode).
        contact: boolean contact set (cells with ``g = 0``; with ``smoothing``, the cells
            where ``c0 p > g``).
        gap: gap ``h - d + C p`` [m] (0 on the contact set).
        displacement: surface displacement ``C p`` [m] (zero-mean periodic part).
        iterations: active-set iterations.
        residual: final scaled residual, ``max |min(p/p_s, g/g_s)|`` with the load (or
            penetration) equation and the linear residual (scales: load mode, ``p_s`` = mean
            contact pressure of the initial set and ``g_s = c0 p_s``; penetration mode,
            ``g_s = |d|`` and ``p_s = g_s/c0``; ``c0`` = self compliance). With ``smoothing``, the
            soft-min residual; with ``smoothing_order``, the larger of the two smoothed solves'
            residuals, each over its own tolerance, times ``tol`` (the ``2 eps`` partner stops at
            :data:`~jaxroll.contact.smoothing.PARTNER_TOL_FACTOR` times ``tol``).
        result: :data:`jaxroll.result.RESULTS` code (``successful``, ``max_steps_reached``,
            ``linear_solve_failed``, ``window_too_small``, ``nonfinite``).
    """

    pressure: jax.Array
    penetration: jax.Array
    contact: jax.Array
    gap: jax.Array
    displacement: jax.Array
    iterations: jax.Array
    residual: jax.Array
    result: jax.Array


class WarmStart(eqx.Module):
    """A start for :func:`solve_contact` from a solved neighbour (another load or speed): the
    contact set, pressure [Pa] and penetration [m] to begin from. ``valid`` is False where there is
    no usable neighbour (the solver's own start is used then). ``smoothed`` (with ``smoothing``):
    the start is a smoothed-edge solution of the same contact at nearby parameters (e.g. the
    previous evaluation of a fit): the damped Newton iteration of the smoothed edge starts from it
    directly and the exact (active-set) solve is skipped."""

    contact: jax.Array
    pressure: jax.Array
    penetration: jax.Array
    valid: jax.Array
    smoothed: jax.Array = False

    @classmethod
    def none(cls, shape) -> "WarmStart":
        """No neighbour: the solver's own start."""
        return cls(jnp.zeros(shape, bool), jnp.zeros(shape), jnp.asarray(0.0), jnp.asarray(False), jnp.asarray(False))

    @classmethod
    def of(cls, solution: "ContactSolution", smoothed=False) -> "WarmStart":
        """The start at ``solution`` itself (e.g. for the same load at a neighbouring speed);
        ``smoothed``: ``solution`` is a smoothed-edge solution (see the class)."""
        sg = jax.lax.stop_gradient
        p, mask, d = sg(solution.pressure), sg(solution.contact), sg(solution.penetration)
        ok = jnp.any(mask) & (jnp.sum(p) > 0) & jnp.all(jnp.isfinite(p)) & jnp.isfinite(d)
        return cls(mask & ok, jnp.where(ok, p, 0.0), jnp.where(ok, d, 0.0), ok, jnp.asarray(smoothed) & ok)

    @classmethod
    def stretched(cls, solution: "ContactSolution", stretch, load_ratio) -> "WarmStart":
        """The start for the same contact at ``load_ratio`` times the load of ``solution``,
        whose contact size is expected to be ``stretch`` times as large (:meth:`stretch`).

        From the previous load of the paper's reference case (``stretch`` from the stationary
        radius estimates) the stretched set is 20-70 cells off a ~1000-cell contact and the
        solve needs ~15 % fewer operator applications than from the previous set as it was.
        Data only (``stop_gradient``): a start changes the iterations, never the solution."""
        return cls.of(solution).stretch(stretch, load_ratio)

    @classmethod
    def extrapolated(cls, start: "WarmStart", solution: "ContactSolution", stretch, load_ratio,
                     use=True) -> "WarmStart":
        """The start for the next load of a sequence (as :meth:`stretched`) from ``solution`` and
        the ``start`` it was solved from, that load's own start stretched from the load before
        (``use``: whether it was; traced bool): the start's miss is added once more, i.e. the
        pressure and penetration extrapolated linearly in the stretched coordinates,
        ``2 p - p_start`` and ``2 d - d_start``, and stretched (:meth:`stretch`) with the set taken
        from the stretched extrapolated pressure (where it is positive). Without a usable
        ``start``, ``solution`` stretched with the set taken from its pressure.

        Paper's reference case (345 warm-started solves): active-set steps per solve 3.82 -> 3.49,
        operator applications 32.7 -> 30.1, against :meth:`stretched`. Data only
        (``stop_gradient``): a start changes the iterations, never the solution."""
        here, sg = cls.of(solution), jax.lax.stop_gradient
        ok = here.valid & start.valid & jnp.asarray(use)
        p = jnp.where(ok, 2.0 * here.pressure - sg(start.pressure), here.pressure)
        d = jnp.where(ok, 2.0 * here.penetration - sg(start.penetration), here.penetration)
        return cls(here.contact, p, d, here.valid, here.smoothed).stretch(stretch, load_ratio, set_from_pressure=True)

    def stretch(self, stretch, load_ratio, set_from_pressure=False) -> "WarmStart":
        """This start for ``load_ratio`` times its load and a contact ``stretch`` times as large:
        the pressure and contact set stretched about the centre of pressure (bilinear and nearest
        cell; ``set_from_pressure``: the set where the bilinearly stretched indicator of a
        positive pressure exceeds 1/2), the pressure scaled to the new load, the penetration by
        ``stretch^2`` (Hertz: ``d ~ a^2/R``)."""
        s, ratio = (jax.lax.stop_gradient(jnp.asarray(v, float)) for v in (stretch, load_ratio))
        ok = self.valid & (s > 0) & jnp.isfinite(s) & (ratio > 0) & jnp.isfinite(ratio)
        ok = ok & (jnp.sum(jnp.maximum(self.pressure, 0.0)) > 0)  # no positive pressure: no centre
        s, ratio = jnp.where(ok, s, 1.0), jnp.where(ok, ratio, 1.0)
        p = jnp.where(ok, self.pressure, 0.0)
        positive = jnp.maximum(p, 0.0)
        total = jnp.where(ok, jnp.sum(positive), 1.0)
        new_p, new_mask = p, (p > 0 if set_from_pressure else self.contact).astype(float)
        for axis, n in enumerate(p.shape):
            # target cell i takes the data at c + (i - c)/s (c: centre of pressure on this axis):
            # interpolation matrices, linear for the pressure, nearest cell (or linear) for the set
            k = jnp.arange(n, dtype=float)
            c = jnp.sum(jnp.moveaxis(positive, axis, -1) * k) / total
            src = c + (k - c) / s
            linear = jnp.maximum(0.0, 1.0 - jnp.abs(src[:, None] - k[None, :]))
            nearest = linear if set_from_pressure else (jnp.round(src)[:, None] == k[None, :]).astype(float)
            new_p = jnp.moveaxis(jnp.tensordot(linear, new_p, axes=(1, axis)), 0, axis)
            new_mask = jnp.moveaxis(jnp.tensordot(nearest, new_mask, axes=(1, axis)), 0, axis)
        new_mask = new_mask > 0.5
        new_p = jnp.where(new_mask, jnp.maximum(new_p, 0.0), 0.0) * ratio / s ** p.ndim
        return WarmStart(new_mask & ok, new_p, jnp.where(ok, self.penetration * s * s, 0.0), ok, self.smoothed & ok)


def solve_contact(
    compliance: "WindowedCompliance",
    profile,
    load=None,
    cell_area=None,
    *,
    penetration=None,
    initial_contact=None,
    warm_start: "WarmStart | None" = None,
    tol: float = 1e-10,
    max_steps: int = 50,
    linear_solver: AbstractLinearSolver = GMRES(),
    smoothing=None,
    smoothing_order: float | None = None,
    continuation: bool = False,
) -> "ContactSolution":
    """Solve frictionless steady-state rolling contact of a rigid profile (any dimension).

    Load-controlled (``load``): find ``p >= 0``, ``d`` with ``g = h - d + C p >= 0``,
    ``p g = 0``, ``sum(p) dA = P``. Penetration-controlled (``penetration=d``): the same with
    ``d`` given and no load equation (the load is ``sum(p) dA``). Give exactly one of the two.

    Args:
        compliance: :class:`WindowedCompliance` (non-symmetric allowed).
        profile: ``h`` [m], height of the rigid surface above its lowest point, on the window
            grid (shape ``compliance.shape``).
        load: total load ``P`` [N per unit length in 1D, N in 2D], positive (load mode).
        cell_area: cell size ``dA`` [m in 1D, m^2 in 2D]; required in load mode, not used in
            penetration mode.
        penetration: prescribed rigid-body penetration ``d`` [m] (penetration mode; keyword
            only). ``d <= 0`` gives ``p = 0``.
        initial_contact: boolean initial guess of the contact set (default: load mode, the
            cells where ``h`` lies in the lowest 10 % of its range; penetration mode, the
            geometric overlap ``h < d``).
        warm_start: optional :class:`WarmStart` (a solved neighbour's contact set, pressure and
            penetration; :meth:`WarmStart.stretched`): where valid, it replaces
            ``initial_contact`` and the uniform initial pressure; with ``smoothing``, a start
            flagged ``smoothed`` (a smoothed solution at nearby parameters) starts the damped
            Newton iteration itself, without the exact solve. It changes the number of
            iterations, not the solution (to the tolerance).
        tol: tolerance on the scaled residual (the linear solves use ``1e-3 tol``, the implicit
            derivatives' tangent or adjoint solve ``tol``).
        max_steps: static maximum number of active-set iterations per phase (the loose search,
            then the strict confirmation; see the module docstring).
        linear_solver: the linear solver of each contact-set system (static configuration):
            :class:`~jaxroll.contact.linear.GMRES` (default; matrix-free restarted GMRES on the
            FFT operator, preconditioned on 2D windows) or :class:`~jaxroll.contact.linear.Dense`
            (LU on the explicit ``(n + 1) x (n + 1)`` system: exact to rounding and faster for
            1D windows of a few hundred cells). The converged solution and its derivatives do
            not depend on the choice (to the tolerance); only the cost does.
        smoothing: ``None`` (default: the exact complementarity above) or a gap scale
            ``eps`` [m] > 0 (traced allowed) for the *smoothed contact edge*: the condition
            ``min(c0 p, g) = 0`` (``c0`` = self compliance, so ``c0 p`` is the gap the cell's
            own pressure closes) is replaced by ``exp(-c0 p/eps) + exp(-g/eps) = 1``, i.e.
            ``smin_eps(c0 p, g) = 0`` with the log-sum-exp soft minimum. Cells whose gap or
            ``c0 p`` is below ~``eps`` share the load partially, so a cell enters the contact
            gradually as the parameters change: the solution is then a smooth (C-infinity)
            function of the compliance, profile and load (or penetration) instead of a
            piecewise smooth one with a kink at every contact-set change (what makes
            least-squares fits on the discrete model stall). Outside the contact the pressure
            decays like ``(eps/c0) exp(-g/eps)``. The exact solution is recovered as ``eps -> 0`` (the
            smoothed and exact problems differ by ``O(eps)`` in ``d`` and at the edge cells).
            Solved by damped Newton on the smoothed equations, started from the exact
            (active-set) solution.
        smoothing_order: ``None`` (default) or the order ``q`` of the smoothing's bias
            (``~ eps^q``): the smoothed solutions at ``eps`` and ``2 eps`` are combined by
            Richardson extrapolation to ``eps -> 0``
            (:func:`~jaxroll.contact.smoothing.extrapolated_solve`), still C-infinity; needs
            ``smoothing``. The ``2 eps`` solve, which only estimates the bias, stops at
            :data:`~jaxroll.contact.smoothing.PARTNER_TOL_FACTOR` times ``tol`` (at most
            :data:`~jaxroll.contact.smoothing.PARTNER_TOL_MAX`; ``R_r`` moves by ~2e-8 relative).
        continuation: static; on a preconditioned 2D window, where the active-set search gives up
            (after :data:`~jaxroll.contact.active_set.CONTINUE_AFTER` steps, or at a fragmented
            set: a loss-dominated contact, on which the primal-dual update does not contract), the
            search starts again from the smoothed edge's continuation
            (:func:`~jaxroll.contact.smoothing.continuation_solve`) and confirms its set. The same
            solution (to the tolerance), in a fraction of the steps there (SLS f = 1000 on a
            half-space, 32 cells per radius: 1.1 s instead of 86-91 s); a larger program (about 3 s
            more to compile, measured on the default sphere point), so off by default.
    Never raises on a failed solve: the reason is in ``ContactSolution.result``.

    Returns:
        :class:`ContactSolution`; ``pressure`` and ``penetration`` are differentiable
        (implicit function theorem on the converged contact set) w.r.t. the compliance, the
        profile and the load or the prescribed penetration.
    """
    if (load is None) == (penetration is None):
        raise ValueError("give exactly one of load (load-controlled) and penetration "
                         "(penetration-controlled)")
    if penetration is None and cell_area is None:
        raise ValueError("cell_area is required with a load")
    penetration_mode = penetration is not None
    h = jnp.asarray(profile, dtype=float)
    if h.shape != compliance.shape:
        raise ValueError(f"profile shape {h.shape} does not match the window shape {compliance.shape}")
    value = jnp.asarray(penetration if penetration_mode else load, dtype=float)
    if value.shape != ():
        raise ValueError(f"{'penetration' if penetration_mode else 'load'} must be a scalar; "
                         f"got shape {value.shape}")
    initial_contact, warm = _start(h, value, penetration_mode, initial_contact, warm_start)
    solver = check_linear_solver(linear_solver, (GMRES, Dense)).resolve(h.ndim)
    if smoothing is not None:
        smoothing = check_input(jnp.asarray(smoothing, dtype=float), ~(jnp.asarray(smoothing) > 0),
                                "smoothing must be a positive gap scale [m] (or None)")
    if smoothing_order is not None and (smoothing is None or not smoothing_order > 0):
        raise ValueError(f"smoothing_order needs smoothing and must be positive; got {smoothing_order!r}")
    if not penetration_mode:
        value = check_input(value, ~(value > 0), "the load must be positive")
    return _solve_contact(compliance, h, value, None if penetration_mode else jnp.asarray(cell_area, dtype=float),
                          initial_contact, warm, smoothing, penetration_mode=penetration_mode, tol=tol,
                          max_steps=max_steps, solver=solver, order=smoothing_order, continuation=continuation)


def _start(h, value, penetration_mode, initial_contact, warm_start):
    """The initial contact set (checked, or the default guess; a valid warm start replaces it)
    and the warm start itself (or ``None``)."""
    if initial_contact is None:
        if penetration_mode:
            initial_contact = h < jax.lax.stop_gradient(value)
        else:
            hmin, hmax = jnp.min(h), jnp.max(h)
            initial_contact = h <= hmin + 0.1 * (hmax - hmin)
    initial_contact = jnp.asarray(initial_contact, bool)
    if initial_contact.shape != h.shape:
        raise ValueError("initial_contact must have the window shape")
    if warm_start is None:
        return initial_contact, None
    if warm_start.pressure.shape != h.shape or warm_start.contact.shape != h.shape:
        raise ValueError("warm_start must have the window shape")
    return jnp.where(warm_start.valid, warm_start.contact, initial_contact), warm_start

@eqx.filter_jit
def _solve_contact(compliance: WindowedCompliance, h, value, cell_area, mask0, warm, smoothing, *,
                   penetration_mode: bool, tol: float, max_steps: int,
                   solver: AbstractLinearSolver, order: float | None = None,
                   continuation: bool = False) -> ContactSolution:
    system = ContactSystem.build(compliance, h, value, cell_area, mask0, penetration_mode)
    fixed = system.stopped()
    precond = CirculantPreconditioner.build(compliance, fixed) if solver.preconditioned else None

    def active_set_precond(mask, transpose=False):
        return None if precond is None else precond.active_set(fixed, mask, transpose)

    x_init = flat(mask0.astype(float), jnp.asarray(0.0))  # uniform pressure on the initial set
    if warm is not None:
        sg = jax.lax.stop_gradient
        x_init = jnp.where(warm.valid, sg(flat(jnp.where(mask0, warm.pressure, 0.0) / fixed.p_s,
                                               warm.penetration / fixed.g_s)), x_init)
    def exact(_):
        search = functools.partial(find_contact_set, fixed, solver=solver, precond=active_set_precond, tol=tol,
                                   max_steps=max_steps)
        if not continuation or precond is None or len(fixed.shape) != 2:
            return search(mask0, x_init)[:6]

        # where the search gives up (a loss-dominated contact), it starts again from the smoothed
        # edge's continuation. Two phases of one scan: one copy of the search in the program (half
        # the compile of a second); a phase (or a batch's lane) with nothing to do takes no step.
        # The continuation's start: a warm start's solution, else a Hertz-shaped pressure on the
        # initial set (not the search's last solve: on a loss-dominated contact its first solve
        # peaks at 280 times the mean pressure, and from there no level converged in its 20 steps
        # at 30-100 mm/s; benchmarks/LOG.md 2026-12-08, "The continuation's start")
        x_cont = fixed.elliptic_start(mask0)
        if warm is not None:
            x_cont = jnp.where(warm.valid, x_init, x_cont)

        def phase(carry, again):
            mask, x, iters, _, robust, _, gave_up = carry
            # where no level of the continuation converged (or it ended non-finite) the search goes
            # on from where it gave up (or from the start, if that was non-finite)
            x_c, contact, n_c, converged = continuation_solve(fixed, x_cont, solver, precond,
                                                              active=again & gave_up, robust=robust)
            ok = again & converged & jnp.all(jnp.isfinite(x_c))
            resume = again & ~ok & jnp.all(jnp.isfinite(x))
            start = (jnp.where(ok, contact, jnp.where(resume, mask, mask0)),
                     jnp.where(ok, jnp.where(flat(contact, jnp.asarray(True)), x_c, 0.0),
                               jnp.where(resume, x, x_init)))
            out = search(*start, give_up=~again, active=~again | gave_up, robust=again & robust)
            out = (*out[:2], iters + n_c + out[2], *out[3:6], out[6] & ~again)
            return jax.tree_util.tree_map(lambda a, b: jnp.where(~again | gave_up, a, b), out, carry), None

        false = jnp.asarray(False)
        init = (mask0, x_init, jnp.asarray(0), false, false, jnp.zeros(fixed.shape), false)
        return jax.lax.scan(phase, init, jnp.asarray([False, True]))[0][:6]

    if smoothing is not None and warm is not None:
        # a smoothed start (WarmStart.smoothed) begins the damped Newton iteration itself: no exact solve
        kinds = jax.eval_shape(exact, None)

        def from_start(_):  # (set, x, iterations, converged, robust, gap) as find_contact_set returns them
            return jax.tree_util.tree_map(lambda k, v: jnp.broadcast_to(jnp.asarray(v, k.dtype), k.shape), kinds,
                                          (mask0, x_init, 0, True, False, 0.0))

        mask, x_exact, iters, done, robust, gap = jax.lax.cond(warm.valid & warm.smoothed, from_start, exact, None)
    else:
        mask, x_exact, iters, done, robust, gap = exact(None)
    mask, x_exact, iters, done, robust = checkpoint_name((mask, x_exact, iters, done, robust), SOLUTION_NAME)
    if smoothing is None:
        # x_exact already solves the system on the converged set to 1e-3 tol: it is returned as
        # the root of F(x) = A(theta) x - b(theta), and only the derivatives solve again
        # (custom_root: dx = -A^-1 dF, the tangent solve a custom_linear_solve so that reverse mode
        # runs the transposed solve). The forward pass costs no extra solve.
        mv, b = system.matvec(mask), system.rhs(mask)

        def tangent_solve(g, y):
            return jax.lax.custom_linear_solve(
                g, y,
                solve=lambda f, bb: solver.solve_derivative(f, bb, active_set_precond(mask), tol, robust),
                transpose_solve=lambda f, bb: solver.solve_derivative(f, bb, active_set_precond(mask, True),
                                                                      tol, robust),
            )

        x = jax.lax.custom_root(lambda x: mv(x) - b, x_exact, lambda f, x0: x0, tangent_solve)
        residual = _exact_residual(system, x, mask, gap)
    else:
        smooth = smoothed_solve if order is None else functools.partial(extrapolated_solve, order=order)
        x, mask, n_it, n_done, residual = smooth(system, x_exact, smoothing, solver, precond,
                                                 tol=tol, max_steps=max_steps, robust=robust)
        iters, done = iters + n_it, done & n_done
    return _solution(system, x, mask, value, iters, done, residual, tol)


def _exact_residual(system: ContactSystem, x, mask, gap):
    """Scaled residual ``max |min(p~, g~)|`` with the linear system's residual from the same
    scaled gap ``g~`` (:func:`~jaxroll.contact.active_set.find_contact_set`'s, from the product
    that checked the last solve: no application of ``C`` here): ``g~`` on the set, ``p~`` off
    it, the load (or penetration) row (the off-set ``p`` enters ``g~`` only at the solve's own
    tolerance)."""
    sg = jax.lax.stop_gradient
    pt, dt, gs = sg(x[:-1].reshape(system.shape)), sg(x[-1]), sg(gap)
    comp = jnp.max(jnp.abs(jnp.minimum(pt, gs)))
    lin_res = jnp.maximum(jnp.max(jnp.abs(jnp.where(mask, gs, pt))),
                          jnp.abs(sg(system.last_row(jnp.where(mask, pt, 0.0), dt) - system.target)))
    return jnp.maximum(comp, lin_res)


def _solution(system: ContactSystem, x, mask, value, iters, done, residual, tol) -> ContactSolution:
    """The :class:`ContactSolution` of the scaled unknowns ``x``, with its result code from
    ``residual`` (scaled)."""
    p, d = system.unscale(x)
    if system.penetration_mode:
        d = value  # the given d exactly (x[-1] g_s = d to tol)
    u = system.compliance(p)  # (where no output needs it, the compiled program leaves it out)
    touches = jnp.any(mask & _edge_mask(system.shape))
    finite = jnp.all(jnp.isfinite(p)) & jnp.isfinite(d)
    result = first_failure((~finite, RESULTS.nonfinite), (touches, RESULTS.window_too_small),
                           (~done, RESULTS.max_steps_reached), (residual > tol * 1e3, RESULTS.linear_solve_failed))
    return ContactSolution(pressure=p, penetration=d, contact=mask, gap=system.profile - d + u, displacement=u,
                           iterations=iters, residual=residual, result=result)


def _edge_mask(shape):
    """Boolean array, True on the outer cells of the window."""
    m = np.zeros(shape, bool)
    for k in range(len(shape)):
        sl = [slice(None)] * len(shape)
        sl[k] = 0
        m[tuple(sl)] = True
        sl[k] = -1
        m[tuple(sl)] = True
    return jnp.asarray(m)
