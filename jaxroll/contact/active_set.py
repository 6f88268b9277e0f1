"""The primal-dual active-set iteration (semismooth Newton on ``min(p, g) = 0``).

The viscoelastic compliance is not symmetric, so the Polonsky-Keer CG (which stalls for
``0.01 < V tau/a < 3``, where the rolling resistance peaks) is not used. Each step solves the
equality-constrained system on the current contact set ``A`` (``g_A = 0``, ``p`` off ``A`` = 0,
load or penetration; :class:`~jaxroll.contact.system.ContactSystem`) and updates
``A = {p > 0 on A} U {g < 0 off A}``; it stops when ``A`` repeats. The iteration runs on
``stop_gradient`` data: the solvers differentiate the final solve on the converged set
(implicit function theorem), never the iteration.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from .system import ContactSystem

__all__ = ["active_set_loop", "find_contact_set", "LOOSE_LINEAR_RTOL", "FIRST_LINEAR_RTOL", "PLAIN_LINEAR_RTOL",
           "SET_MARGIN", "TURN_EDGE_FRACTION", "DAMPED_AFTER", "CONTINUE_AFTER", "FRAGMENTED_EDGE"]

#: Relative residual of the linear solves while the contact set is searched (the final set is
#: confirmed and solved at ``1e-3 tol``; see :func:`find_contact_set`), and of the first of them
#: (from the start, whose set is the furthest off), with a preconditioned solver. The set
#: decisions need the sign of the pressure and the gap beyond :data:`SET_MARGIN`, not many
#: digits, and with the preconditioner the solution's error stays near the residual's. Reference
#: table (paper grid, 345 warm-started solves), compliance applications per solve: first / later
#: 1e-6 / 1e-6 28.7, 1e-4 / 1e-6 27.8, 1e-3 / 1e-6 25.7, 1e-3 / 1e-4 25.0, 1e-3 / 1e-3 27.4,
#: 1e-2 / 1e-6 27.1. Without a preconditioner (1D windows) both are :data:`PLAIN_LINEAR_RTOL`:
#: the cylinder's table (1898-cell window) took 8.5 active-set steps per solve instead of 4.0
#: with 1e-3 / 1e-4.
LOOSE_LINEAR_RTOL = 1e-4
FIRST_LINEAR_RTOL = 1e-3
PLAIN_LINEAR_RTOL = 1e-6
#: Scaled pressure and gap beyond which a loose step moves a cell into or out of the set (the
#: strict steps decide at 1e-12): a margin that grew with a looser tolerance (100x) made wrong
#: decisions (1e-3 / 1e-6 above: 34.9 applications per solve instead of 25.7).
SET_MARGIN = 1e-4
#: The search turns strict once a loose step changes at most this fraction of the set's edge
#: cells (``floor``: in 1D, where the set has two edge cells, only when the set repeats), instead
#: of solving the nearly final set loosely once more before the strict step (which still confirms
#: it: the iteration ends only when a strict step repeats its set). Reference table: active-set
#: steps per solve 3.15 -> 2.90 with 1/8 (8 cells of a 1000-cell contact).
TURN_EDGE_FRACTION = 0.125
#: Active-set steps after which a 2D search releases before it adds: a step that finds cells of
#: negative pressure only removes them (the gap's cells wait until every pressure on the set is
#: positive), instead of the full primal-dual update. On a loss-dominated material near the R_r
#: peak (SLS f >= 100, tan delta up to 5-16) the full update drifts the set forward and collapses
#: it in cycles of ~20 steps (160 -> 330 -> 220 cells): the default sphere at f = 100 and 1000 on a
#: 30 mm layer and a half-space (R = 2 cm, 100 N, 30 and 100 mm/s) stopped at max_steps_reached
#: or window_too_small, values 3-40x off; damped, all 48 points of f = 10..1000 x 3 mm/s..1 m/s
#: converge (27-60 steps where they took more than this). Searches that converge before it (the
#: reference table: at most 4 steps) are unchanged. 1D windows keep the full update (there an edge
#: walks a cell per step on thin layers, 144 steps at 400 cells, which alternation would double).
#: These counts are the plain search's (``continuation=False``); a search that gives up
#: (:data:`CONTINUE_AFTER`) stops before this, and the damped update serves the search that follows
#: the continuation.
DAMPED_AFTER = 16
#: A 2D search with ``give_up`` stops (:func:`find_contact_set`) after :data:`CONTINUE_AFTER`
#: steps, or at a step whose set has more than :data:`FRAGMENTED_EDGE` times the edge cells of a
#: disc of its size; its caller then starts the exact search again from the smoothed edge's
#: continuation (:func:`jaxroll.contact.smoothing.continuation_solve`). On a loss-dominated
#: material (glassy Boussinesq plus a creep term of comparable size that accumulates along the
#: rolling direction) the primal-dual update is not a contraction: from the initial disc the first
#: step scatters cells of negative pressure over the set (edge ratio 2.8-4.7 at SLS f = 300-1000,
#: half-space, 10 mm/s, 8-32 cells per radius). Some searches recover (f = 1000 at 8 cells: the
#: ratio below 2 at the fourth step, converged in 8 steps, 0.03 s; given up, 0.09 s), most
#: fine ones do not (f = 1000 at 12 / 16 / 32 cells: 61 / 67 / 162 steps, the last 91 s), and
#: the fragmented steps are the expensive ones: at 32 cells, given up at the first step 1.1 s,
#: at the second 5.4 s, at the fourth 7.1 s (benchmarks/LOG.md, 2026-12-08). The reference
#: table's searches take at most 4 steps on compact sets (ratio ~1); a search that does not
#: fragment but still wanders gives up after :data:`CONTINUE_AFTER` loose steps. A search
#: continued this way counts its steps afresh: at most 16 search steps,
#: :data:`~jaxroll.contact.smoothing.CONTINUATION_MAX_STEPS` Newton steps, then ``2 max_steps``.
CONTINUE_AFTER = 16
FRAGMENTED_EDGE = 2.0


def active_set_loop(step, state0, aux0, max_steps):
    """The primal-dual active-set iteration shared by every contact solver of the library.

    ``step(state, aux) -> (new_state, aux)`` solves the equality-constrained problem on the
    contact set ``state`` (a boolean mask, or any pytree that describes the set, such as an
    interval ``(first, length)``) and returns the next set (cells in contact with ``p > 0``
    plus free cells with ``g < 0``) and any solution data ``aux`` (e.g. the Krylov warm start).
    The loop stops when the set repeats, when ``aux`` holds a non-finite value, or after
    ``max_steps`` steps; it runs on ``stop_gradient`` data (the solvers differentiate the final
    solve on the converged set, never the iteration).

    Returns:
        ``(state, aux, iterations, converged)``.
    """

    def same(a, b):
        return functools.reduce(jnp.logical_and, [jnp.all(x == y) for x, y in zip(
            jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b))], jnp.asarray(True))

    def finite(a):
        return functools.reduce(jnp.logical_and, [jnp.all(jnp.isfinite(x)) for x in jax.tree_util.tree_leaves(a)
                                                  if jnp.issubdtype(x.dtype, jnp.inexact)], jnp.asarray(True))

    def body(c):
        state, aux, it, _ = c
        new, aux = step(state, aux)
        done = same(new, state) | ~finite(aux)
        new = jax.tree_util.tree_map(lambda n, o: jnp.where(done, o, n), new, state)
        return new, aux, it + 1, done

    def cond(c):
        return (~c[3]) & (c[2] < max_steps)

    return jax.lax.while_loop(cond, body, (state0, aux0, jnp.asarray(0), jnp.asarray(False)))


def find_contact_set(system: ContactSystem, mask0, x0, solver, precond, *, tol, max_steps, give_up=False,
                     active=True, robust=False):
    """The converged contact set of ``system`` (on ``stop_gradient`` data) and its solution.

    Two phases in one loop: the set is found with loose linear solves (relative residual
    :data:`FIRST_LINEAR_RTOL` for the first, :data:`LOOSE_LINEAR_RTOL` after it, or
    :data:`PLAIN_LINEAR_RTOL` for both with a solver that does not precondition; set decisions
    beyond :data:`SET_MARGIN`: they need the pressure's sign, not 13 digits); once a loose step
    changes at most :data:`TURN_EDGE_FRACTION` of the set's edge cells (or after ``max_steps``
    loose steps) the phase turns strict and the same iteration confirms the set with solves at
    ``1e-3 tol``, warm started (usually one step, which also catches a set decided wrongly by a
    loose solve). The state compared for convergence is (set, phase): it repeats only when a
    strict step keeps the set. One loop body (one GMRES in the program, not one per phase) keeps
    the compile time down. On 2D windows, after :data:`DAMPED_AFTER` steps a step that finds
    cells of negative pressure only releases them (a damped search: the full update cycled on
    loss-dominated materials).

    Args:
        system: the stopped system (:meth:`ContactSystem.stopped`).
        mask0: initial contact set; ``x0``: initial scaled unknowns.
        solver: an :class:`~jaxroll.contact.linear.AbstractLinearSolver`.
        precond: ``mask -> M`` or a pair ``(M_cheap, M_whole)`` (or ``None``-returning) for the
            active-set systems.
        give_up: ``False`` (static), or a bool (traced allowed): where true, on a 2D window, stop
            after :data:`CONTINUE_AFTER` loose steps or at a fragmented set
            (:data:`FRAGMENTED_EDGE`), and say so (the caller continues the search another way).
            active: traced bool; where false, no step is taken (a batch's lanes).
            robust: traced bool, the start of the ``robust`` flag below (a search continued from an
            earlier one that needed the robust preconditioner starts with it).

    Returns:
        ``(mask, x, iterations, converged, robust, gap, gave_up)``; ``robust``: whether a linear solve needed
        the robust level of the preconditioner pair (from then on the steps use it from the
        start, :meth:`~jaxroll.contact.linear.AbstractLinearSolver.solve_tracked`); ``gap``: the
        scaled gap at ``x`` of the pressure on the set, from the product that checked the last
        solve's residual; ``gave_up``: the search stopped by ``give_up`` (``converged`` false).
    """
    check = give_up is not False and len(system.shape) == 2
    strict = tol * 1e-3
    loose, first = (LOOSE_LINEAR_RTOL, FIRST_LINEAR_RTOL) if solver.preconditioned else (PLAIN_LINEAR_RTOL,) * 2
    loose, first = max(strict, loose), max(strict, first)
    eps = 1e-12

    def step(state, aux):
        mask, is_strict = state
        x, k, robust, _, _ = aux
        rtol = jnp.where(is_strict, strict, jnp.where(k == 0, first, loose))
        margin = jnp.where(is_strict, eps, max(eps, SET_MARGIN))
        # the gap from the product that checked the solve's residual (no extra application)
        x, robust, gap = solver.solve_tracked(system.matvec(mask, with_gap=True), system.rhs(mask), x,
                                              precond(mask), rtol, robust, has_aux=True)
        pt = x[:-1].reshape(system.shape)
        new = jnp.where(mask, pt > -margin, gap < -margin)
        if len(system.shape) == 2:  # damped: release first (DAMPED_AFTER)
            release = mask & ~(pt > -margin)
            new = jnp.where((k >= DAMPED_AFTER) & jnp.any(release), mask & ~release, new)
        changed, edge = jnp.sum(new != mask, dtype=float), jnp.sum(_edge_cells(mask), dtype=float)
        turn = (changed <= jnp.floor(TURN_EDGE_FRACTION * edge)) | (k + 1 >= max_steps)
        stop = jnp.asarray(False)
        if check:  # the state unchanged ends the loop
            size = jnp.maximum(jnp.sum(new, dtype=float), 1.0)
            disc_edge = 2.0 * jnp.sqrt(jnp.pi * size)
            fragmented = jnp.sum(_edge_cells(new), dtype=float) > FRAGMENTED_EDGE * disc_edge
            stop = fragmented | ((k + 1 >= CONTINUE_AFTER) & ~is_strict)  # a strict step confirms: let it
            stop = stop & jnp.any(new != mask) & give_up
            new, turn = jnp.where(stop, mask, new), turn & ~stop
        return (new, is_strict | turn), (x, k + 1, robust, gap, stop)

    (mask, _), (x, _, robust, gap, stopped), iters, done = active_set_loop(
        step, (mask0, jnp.asarray(loose <= strict)),
        (x0, jnp.asarray(0), jnp.asarray(robust), jnp.zeros(system.shape), jnp.asarray(False)),
        jnp.where(active, 2 * max_steps, 0))
    sg = jax.lax.stop_gradient
    return sg(mask), sg(x), iters, done & ~stopped, robust, sg(gap), stopped


def _edge_cells(mask):
    """The cells of ``mask`` with a neighbour along an axis outside it (beyond the window's border
    counts as outside)."""
    padded = jnp.pad(mask, 1)
    inner = mask
    for axis in range(mask.ndim):
        for lo in (0, 2):
            inner = inner & padded[tuple(slice(lo, lo + m) if a == axis else slice(1, 1 + m)
                                         for a, m in enumerate(mask.shape))]
    return mask & ~inner
