"""Linear solvers of the contact-set systems, as small objects (in the manner of lineax).

Each active-set step of :func:`jaxroll.contact.solve_contact` solves one equality-constrained
system ``A x = b`` on the current contact set, given as a matrix-free ``matvec``; the implicit
derivatives solve the same system (and its transpose) once more. A solver object carries the
static configuration (Krylov basis size, restarts, whether to precondition); its
:meth:`~AbstractLinearSolver.solve` takes the operator, the right-hand side, a start, an optional
preconditioner and the relative tolerance, which varies from step to step.

* :class:`GMRES` (default): restarted GMRES on the FFT operator
  (:func:`jaxroll._numerics.gmres`), right-preconditioned on 2D windows by the circulant
  approximation of :mod:`jaxroll.contact.precondition`.
* :class:`Dense`: LU on the explicit ``(n + 1) x (n + 1)`` system, built by applying the
  operator to the unit vectors; exact to rounding and faster for 1D windows of a few hundred
  cells.

The slice solvers add a third, :class:`jaxroll.engines.slices.Interval` (Levinson tables on a contact
interval), which replaces the whole contact solve rather than one linear system.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax
import jax.numpy as jnp

from .._numerics import gmres

__all__ = ["AbstractLinearSolver", "GMRES", "Dense", "Deferred"]

#: Default Krylov basis sizes of :class:`GMRES`: with the preconditioner (2D windows) and without.
#: Restarting throws the Krylov space away; near the resistance peak the preconditioned sphere
#: solves need ~20-35 iterations per active-set step, so a 12-vector basis restarted 3-10 times
#: and stagnated on fine grids. Operator applications per solve (half-space, SLS f = 1,
#: ``zeta = V tau/a0 = 1``, 12 cells per radius): GMRES(12) 576 with a preconditioner folded
#: onto one window and 239 with the whole embedding's, GMRES(32) 112 and 118; at 48 cells the
#: folded one needs 2879 with GMRES(32) and the embedding's 150 (:mod:`.precondition`).
RESTART_PRECONDITIONED = 32
RESTART_PLAIN = 80
#: Basis size of the fallback solve (:class:`GMRES` ``fallback_restart``), from where the first
#: stopped, when the first misses its tolerance (with GMRES(12) and a folded preconditioner it
#: rescued the 24-32 cells-per-radius solves that stagnated at a relative residual of 1e-2..1e-4
#: and made the active set cycle; GMRES(96) reached 1e-13 in one cycle); with a preconditioner
#: pair it also switches to the robust level.
FALLBACK_RESTART = 96
#: Restart cycles of the first solve (with the cheap, folded preconditioner of a pair) before it
#: hands over to the fallback (with the whole embedding's, then used from the start by the later
#: solves of the contact solve): 32 Krylov iterations, what an easy solve (off the resistance peak,
#: coarse grids) needs with the folded one, so the harder ones switch after one cycle.
FIRST_SOLVE_CYCLES = 1
#: Krylov iterations of a solve without fallback (restarts = this // restart), and of the fallback
#: solve (which follows at most ``FIRST_SOLVE_CYCLES`` cycles of the first).
MAX_KRYLOV_ITERATIONS = 1600
#: Basis size of an exact contact's derivative solve (:meth:`GMRES.solve_derivative` given the
#: forward's preconditioner level): one Arnoldi loop in one basis (no short-then-long basis as in
#: the forward solves), large enough for the ~11-13 Krylov steps such a solve takes from zero on
#: the paper's reference case.
DERIVATIVE_RESTART = 16


class Deferred:
    """A preconditioner ``v -> M v`` built where it is first applied: ``build()`` returns
    ``build_fn(*operands)``. The robust level of a preconditioner pair comes as one, so that its
    set-up (an FFT pair per contact set) runs inside the fallback branch of
    :meth:`GMRES.solve_tracked`, i.e. only where the cheap level did not converge.

    ``build(anchor)`` passes the operands through an optimisation barrier together with
    ``anchor``, a value of the loop that applies the preconditioner: the set-up then depends on
    the loop's state, and XLA cannot hoist it out of a loop that runs zero times (its
    loop-invariant code motion would otherwise run it at every call)."""

    def __init__(self, build_fn, *operands):
        self.build_fn = build_fn
        self.operands = operands

    def build(self, anchor=None):
        operands = self.operands
        if anchor is not None:
            operands, _ = jax.lax.optimization_barrier((operands, anchor))
        return self.build_fn(*operands)


def _built(precond, anchor=None):
    """``precond`` itself, or the preconditioner a :class:`Deferred` builds (tied to ``anchor``,
    see :meth:`Deferred.build`)."""
    return precond.build(anchor) if isinstance(precond, Deferred) else precond


class AbstractLinearSolver(eqx.Module):
    """A solver of the contact-set systems (static configuration only)."""

    def resolve(self, ndim: int) -> "AbstractLinearSolver":
        """This solver with its defaults filled in for a window of ``ndim`` axes."""
        return self

    @property
    def preconditioned(self) -> bool:
        """Whether :meth:`solve` uses the preconditioner it is given."""
        return False

    @abc.abstractmethod
    def solve(self, matvec, b, x0, precond, rtol) -> jax.Array:
        """``x`` with ``|b - A x| <= rtol |b|`` (an iterative solver) or exact to rounding.

        Args:
            matvec: ``v -> A v`` (linear).
            b: right-hand side, shape ``(n,)``.
            x0: start (``None``: zero); ignored by direct solvers.
            precond: ``v -> M v`` with ``M ~ A^-1``, or ``None``; or a pair ``(cheap, robust)``:
                :class:`GMRES` solves first with ``cheap`` and falls back to ``robust`` where
                that stagnates (:mod:`jaxroll.contact.precondition`).
            rtol: relative residual tolerance (traced allowed).
        """


    def solve_tracked(self, matvec, b, x0, precond, rtol, robust, has_aux=False) -> tuple:
        """``(x, robust)``: :meth:`solve`, for a sequence of related systems (the steps of one
        contact solve) that share what the solver learned: ``robust`` (traced bool) says that an
        earlier solve needed the robust level of a preconditioner pair, and comes back true once
        one did. Default: :meth:`solve`, ``robust`` unchanged. ``has_aux``: ``matvec(v)`` returns
        ``(A v, aux)``, and ``(x, robust, aux)`` comes back with ``aux`` at ``x`` (an iterative
        solver takes it from the product that checks the residual; here one more product)."""
        if has_aux:
            x, robust = self.solve_tracked(lambda v: matvec(v)[0], b, x0, precond, rtol, robust)
            return x, robust, matvec(x)[1]
        return self.solve(matvec, b, x0, precond, rtol), robust

    def solve_derivative(self, matvec, b, precond, rtol, robust=None) -> jax.Array:
        """``x`` with ``|b - A x| <= rtol |b|`` from a zero start, for the tangent and adjoint
        systems of the implicit derivatives (one solve each, on the converged contact set),
        in one solver (no cheap-first cycle and no fallback branch in the program). With a
        preconditioner pair: its robust level, or with ``robust`` (a traced bool: whether the
        forward solves of the same system ended on the robust level) the level the forward
        solves ended with. Default: :meth:`solve`."""
        robust = _built(precond[1] if isinstance(precond, tuple) else precond)
        return self.solve(matvec, b, None, robust, rtol)


class GMRES(AbstractLinearSolver):
    """Restarted GMRES with right preconditioning (:func:`jaxroll._numerics.gmres`).

    Attributes:
        restart: Krylov basis size (default :data:`RESTART_PRECONDITIONED` with the
            preconditioner, :data:`RESTART_PLAIN` without).
        max_restarts: restart cycles per solve (default ``MAX_KRYLOV_ITERATIONS // restart``; with a
            fallback, :data:`FIRST_SOLVE_CYCLES` before it takes over).
        fallback_restart: basis size of a second solve, from where the first stopped, run only
            when the first missed the tolerance, with the robust level of a preconditioner pair
            (the whole embedding's inverse; the first solve uses the cheap, folded one) (default
            :data:`FALLBACK_RESTART` with the preconditioner, none without; ``0``: none). It is
            skipped where the first solve converges (under ``vmap`` it runs for every lane once one lane needs it), and
            makes the solves robust at fine resolution, where a short basis stagnates. The
            implicit-derivative solves (:meth:`solve_derivative`) run one GMRES from zero: of an
            exact contact, GMRES(:data:`DERIVATIVE_RESTART`) on the level the forward solves
            ended with; of the smoothed edge, GMRES(``restart``) on the robust level.
        preconditioner: right-precondition with the circulant approximation of the compliance on
            the contact set (:mod:`jaxroll.contact.precondition`). Default ``None``: on for 2D
            windows (the 3D sphere: 4-15x fewer operator applications), off in 1D (the default
            cylinder solve gains only 1.1x, and at 100 cells per half-width the preconditioned
            GMRES stalled above the tolerance where the plain one converges). The converged
            solution and its derivatives do not depend on it (to the tolerance).
    """

    restart: int | None = eqx.field(static=True, default=None)
    max_restarts: int | None = eqx.field(static=True, default=None)
    preconditioner: bool | None = eqx.field(static=True, default=None)
    fallback_restart: int | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        for name in ("restart", "max_restarts"):
            v = getattr(self, name)
            if v is not None and (not isinstance(v, int) or v < 1):
                raise ValueError(f"GMRES {name} must be a positive integer or None; got {v!r}")
        v = self.fallback_restart
        if v is not None and (not isinstance(v, int) or v < 0):
            raise ValueError(f"GMRES fallback_restart must be a non-negative integer or None; got {v!r}")

    def resolve(self, ndim: int) -> "GMRES":
        pre = (ndim == 2) if self.preconditioner is None else bool(self.preconditioner)
        restart = self.restart or (RESTART_PRECONDITIONED if pre else RESTART_PLAIN)
        fallback = self.fallback_restart if self.fallback_restart is not None else (FALLBACK_RESTART if pre else 0)
        cycles = self.max_restarts or (FIRST_SOLVE_CYCLES if fallback else MAX_KRYLOV_ITERATIONS // restart)
        return GMRES(restart=restart, max_restarts=cycles, preconditioner=pre, fallback_restart=fallback)

    @property
    def preconditioned(self) -> bool:
        return bool(self.preconditioner)

    def solve(self, matvec, b, x0, precond, rtol):
        return self.solve_tracked(matvec, b, x0, precond, rtol, None)[0]

    def solve_derivative(self, matvec, b, precond, rtol, robust=None):
        # one GMRES loop: the derivative solves need no set decisions, and one Krylov solver in
        # the program instead of two keeps the gradient's compile short; from zero (the first
        # residual is b: no product). Without `robust`: GMRES(restart) with the robust level.
        # With it (an exact contact's solves): the level the forward solves ended with (the
        # transposed system has the same spectrum: the cheap one where it sufficed there), in one
        # basis of DERIVATIVE_RESTART rows (one Arnoldi loop instead of the short and long ones)
        atol = rtol * jnp.linalg.norm(b)
        if robust is None or not (self.preconditioned and isinstance(precond, tuple)):
            whole = _built(precond[1] if isinstance(precond, tuple) else precond)
            x, _ = gmres(matvec, b, None, atol=atol, precond=whole if self.preconditioned else None,
                         restart=self.restart, maxiter=max(1, MAX_KRYLOV_ITERATIONS // self.restart))
            return x
        cheap, whole = precond[0], _built(precond[1])
        x, _ = gmres(matvec, b, None, atol=atol, precond=lambda v: jax.lax.cond(robust, whole, cheap, v),
                     restart=DERIVATIVE_RESTART, maxiter=MAX_KRYLOV_ITERATIONS // DERIVATIVE_RESTART,
                     short_basis=False)
        return x

    def solve_tracked(self, matvec, b, x0, precond, rtol, robust, has_aux=False):
        # right preconditioning: the stopping test is on the true residual |b - A x| <= rtol |b|.
        # A pair (cheap, robust): the first solve with the cheap level, skipped (no cycle) once an
        # earlier solve of the sequence needed the robust one; the fallback with the robust level
        x0 = jnp.zeros_like(b) if x0 is None else x0
        atol = rtol * jnp.linalg.norm(b)
        first, second = precond if isinstance(precond, tuple) else (precond, precond)
        first, second = (_built(first), second) if self.preconditioned else (None, None)
        cycles = self.max_restarts
        if robust is not None and self.fallback_restart and isinstance(precond, tuple):
            cycles = jnp.where(robust, 0, cycles)
        x, res, *aux = gmres(matvec, b, x0, atol=atol, precond=first, restart=self.restart, maxiter=cycles,
                             has_aux=has_aux)
        if not self.fallback_restart:
            return (x, robust, *aux)  # (a single-level solver: a Deferred `second` is never built)

        def fallback(c):  # at most one pass, in a while loop so that it is skipped when not needed
            x = c[0]
            x, res, *aux = gmres(matvec, b, x, atol=atol, precond=_built(second, x), restart=self.fallback_restart,
                                 maxiter=max(1, MAX_KRYLOV_ITERATIONS // self.fallback_restart), has_aux=has_aux)
            return x, res, jnp.asarray(True), *aux

        x, _, fell_back, *aux = jax.lax.while_loop(lambda c: (c[1] > atol) & ~c[2], fallback,
                                                   (x, res, jnp.asarray(False), *aux))
        return (x, None if robust is None else robust | fell_back, *aux)


class Dense(AbstractLinearSolver):
    """LU on the explicit matrix of the operator (built column by column from ``matvec``)."""

    def solve(self, matvec, b, x0, precond, rtol):
        A = jax.vmap(matvec, out_axes=1)(jnp.eye(b.shape[0], dtype=b.dtype))
        return jnp.linalg.solve(A, b)


def check_linear_solver(solver, allowed=(GMRES, Dense), name="linear_solver"):
    """``solver`` if it is an instance of one of ``allowed``; else a ``ValueError`` naming them."""
    if not isinstance(solver, allowed):
        names = ", ".join(f"{c.__name__}()" for c in allowed)
        raise ValueError(f"{name} must be a linear solver object ({names}); got {solver!r}")
    return solver
