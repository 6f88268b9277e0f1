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

__all__ = ["active_set_loop", "find_contact_set", "LOOSE_LINEAR_RTOL"]

#: Relative residual of the linear solves while the contact set is searched (the final set is
#: confirmed and solved at ``1e-3 tol``; see :func:`find_contact_set`).
LOOSE_LINEAR_RTOL = 1e-6


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


def find_contact_set(system: ContactSystem, mask0, x0, solver, precond, *, tol, max_steps):
    """The converged contact set of ``system`` (on ``stop_gradient`` data) and its solution.

    Two phases in one loop: the set is found with loose linear solves (relative residual
    :data:`LOOSE_LINEAR_RTOL`, set decisions beyond 100x that: they need the pressure's sign, not
    13 digits); once the set repeats (or after ``max_steps`` loose steps) the phase turns strict
    and the same iteration confirms the set with solves at ``1e-3 tol``, warm started (usually one
    step, which also catches a set decided wrongly by a loose solve). The state compared for
    convergence is (set, phase): it repeats only when a strict step keeps the set. One loop body
    (one GMRES in the program, not one per phase) keeps the compile time down.

    Args:
        system: the stopped system (:meth:`ContactSystem.stopped`).
        mask0: initial contact set; ``x0``: initial scaled unknowns.
        solver: an :class:`~jaxroll.contact.linear.AbstractLinearSolver`.
        precond: ``mask -> M`` or a pair ``(M_cheap, M_whole)`` (or ``None``-returning) for the
            active-set systems.

    Returns:
        ``(mask, x, iterations, converged, robust)``; ``robust``: whether a linear solve needed
        the robust level of the preconditioner pair (from then on the steps use it from the
        start, :meth:`~jaxroll.contact.linear.AbstractLinearSolver.solve_tracked`).
    """
    strict = tol * 1e-3
    loose = max(strict, LOOSE_LINEAR_RTOL)
    eps = 1e-12

    def step(state, aux):
        mask, is_strict = state
        x, k, robust = aux
        rtol = jnp.where(is_strict, strict, loose)
        margin = jnp.where(is_strict, eps, 100.0 * loose)
        # the gap from the product that checked the solve's residual (no extra application)
        x, robust, gap = solver.solve_tracked(system.matvec(mask, with_gap=True), system.rhs(mask), x,
                                              precond(mask), rtol, robust, has_aux=True)
        pt = x[:-1].reshape(system.shape)
        new = jnp.where(mask, pt > -margin, gap < -margin)
        turn = jnp.all(new == mask) | (k + 1 >= max_steps)
        return (new, is_strict | turn), (x, k + 1, robust)

    (mask, _), (x, _, robust), iters, done = active_set_loop(
        step, (mask0, jnp.asarray(loose <= strict)), (x0, jnp.asarray(0), jnp.asarray(False)), 2 * max_steps)
    return jax.lax.stop_gradient(mask), jax.lax.stop_gradient(x), iters, done, robust
