"""Shared numerical plumbing: float64 policy, input coercion and safe elementary functions.

float64 policy
--------------
``import jaxroll`` enables JAX's 64-bit mode (``jax_enable_x64``) process-wide, because every
physics function here needs float64 (layer compliances span 1e-20..1e-3 m/Pa, the contact
solvers need 1e-10 residuals). Public functions coerce their inputs with :func:`as_float`,
which raises if 64-bit mode has been switched off again afterwards, so a float32 input is
promoted, never computed in float32 silently.

Input checks
------------
A rule on an input value (``R > 0``, ``G0 > 0``, ``H > 0``, ...) is checked where the value is
known. Concrete values are checked on the host before anything is compiled (``ValueError``
naming the value); traced values (under a user's ``jax.jit``, ``jax.vmap``, ``jax.grad``) by
:func:`check_input` inside the compiled program (``equinox.error_if``, a host callback). The
front doors check concrete inputs on the host and trace their programs under
``input_checks(False)``, so those programs hold no callbacks: JAX's persistent compilation
cache only stores programs without host callbacks. Values the rules allow but that lie far
outside the physical range of rolling problems (:data:`PLAUSIBLE`: likely unit slips) give a
:class:`PlausibilityWarning` from :func:`check_plausible`, on the host only.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

__all__ = ["any_traced", "as_float", "check_input", "check_parameter_shapes", "check_plausible", "check_x64",
           "input_checks", "newton_root", "NewtonInfo",
           "PLAUSIBLE", "PlausibilityWarning", "roller_inputs",
           "to_complex", "where_safe"]


def check_x64() -> None:
    """Raise if JAX's 64-bit mode is off (it is switched on by ``import jaxroll``)."""
    if not jax.config.read("jax_enable_x64"):
        raise RuntimeError(
            "jaxroll needs float64: JAX's 64-bit mode was disabled after importing jaxroll. "
            "Re-enable it with jax.config.update('jax_enable_x64', True)."
        )


_INPUT_CHECKS = contextvars.ContextVar("jaxroll_input_checks", default=True)


@contextlib.contextmanager
def input_checks(enabled: bool):
    """Within the block, :func:`check_input` adds its checks to the programs being traced
    (``enabled=True``, the default everywhere) or leaves them out (``False``: the front doors,
    after checking the same rules on concrete inputs on the host). The choice must be part of
    the compilation key of the program traced under it (a static argument)."""
    token = _INPUT_CHECKS.set(bool(enabled))
    try:
        yield
    finally:
        _INPUT_CHECKS.reset(token)


def check_input(x, failed, message: str):
    """``x``, with a check inside the compiled program that raises ``message`` (one line)
    where ``failed`` (``equinox.error_if``: works under jit/vmap/grad), unless inputs were
    checked on the host (:func:`input_checks` ``(False)``): then ``x`` unchanged."""
    if not _INPUT_CHECKS.get():
        return x
    return eqx.error_if(x, failed, message)


def any_traced(*trees) -> bool:
    """Whether any leaf of ``trees`` is a JAX tracer (inside ``jit``/``vmap``/``grad``): the front
    doors check concrete values on the host and traced ones inside the compiled program."""
    return any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree_util.tree_leaves(trees))


def as_float(x) -> jax.Array:
    """Return ``x`` as a float64 JAX array (complex inputs become complex128).

    Integer and float32 inputs are promoted, so no public function ever computes in float32.
    """
    check_x64()
    if isinstance(x, (float, np.floating)) or (isinstance(x, np.ndarray) and x.dtype.kind == "f"):
        # a host float: widened on the host (exact), not by a small compiled program per process
        return jnp.asarray(np.asarray(x, np.float64))
    x = jnp.asarray(x)
    if jnp.issubdtype(x.dtype, jnp.complexfloating):
        return x.astype(jnp.complex128)
    return x.astype(jnp.float64)


def where_safe(cond, x, safe):
    """Replace ``x`` by ``safe`` where ``cond`` is False (first half of a "double where").

    Use it on the *input* of a function that is singular outside ``cond``, then select its
    output with ``jnp.where(cond, f(x_safe), other)``: the gradient of the branch not taken is
    then finite instead of NaN.
    """
    return jnp.where(cond, x, safe)


def to_complex(x) -> jax.Array:
    """Real -> complex128, explicitly (strict dtype promotion forbids mixing float64 and
    complex128 implicitly, and the test suite runs with it)."""
    return jnp.asarray(x).astype(jnp.complex128)


#: The rules on the roller inputs: (name, symbol, unit, test, rule), one place for eager and traced checks.
_ROLLER_RULES = (
    ("radius", "R", "m", lambda v: (v > 0) & (v < np.inf), "positive and finite"),
    ("load", "P", "N, or N/m for cylinders", lambda v: (v > 0) & (v < np.inf), "positive and finite"),
    ("speed", "V", "m/s", lambda v: (v >= 0) & (v < np.inf), ">= 0 and finite (the roller travels toward +x)"),
)


def _describe(v) -> str:
    v = np.asarray(v)
    return f"{float(v):g}" if v.ndim == 0 else np.array2string(v, precision=4, threshold=8)


def check_roller_values(radius, load, speed) -> None:
    """``ValueError`` naming the argument, its value and the rule, for every concrete (not
    traced) radius [m], load(s) [N or N/m] or speed(s) [m/s] that breaks it; traced values are
    checked inside the computation by :func:`roller_inputs`."""
    for (name, sym, unit, test, rule), x in zip(_ROLLER_RULES, (radius, load, speed)):
        if isinstance(x, jax.core.Tracer):
            continue
        v = np.asarray(x, dtype=float)
        bad = ~test(v)
        if np.any(bad):
            raise ValueError(f"{name} {sym} [{unit}] must be {rule}; got {_describe(v[bad] if v.ndim else v)}")


def check_parameter_shapes(model, name: str) -> None:
    """``ValueError`` naming the parameter (``material.G0``, ``layer.plies[1].H``) where an array
    field of ``model`` (a material, shift, layer or stack: any :class:`equinox.Module`, walked
    field by field) has the wrong number of dimensions: scalars everywhere except the fields a
    class lists in its ``_vectors`` (e.g. a Prony series' ``G`` and ``tau``, 1D). Shapes are
    static, so the check holds for traced values too (a user's ``jax.vmap`` hands each lane its
    scalars); batches of materials go through ``jax.vmap``, not through array parameters."""
    if isinstance(model, (tuple, list)):
        for i, m in enumerate(model):
            check_parameter_shapes(m, f"{name}[{i}]")
        return
    if not isinstance(model, eqx.Module):
        return
    vectors = getattr(type(model), "_vectors", ())
    for field in dataclasses.fields(model):
        if field.metadata.get("static", False):
            continue
        value = getattr(model, field.name)
        if isinstance(value, (eqx.Module, tuple, list)):
            check_parameter_shapes(value, f"{name}.{field.name}")
        elif hasattr(value, "shape") or isinstance(value, (int, float)):
            ndim, want = np.ndim(value), 1 if field.name in vectors else 0
            if ndim != want:
                kind = "a 1D array" if want else "a scalar (sweep materials and layers with jax.vmap)"
                raise ValueError(f"{name}.{field.name} ({type(model).__name__}) must be {kind}; "
                                 f"got shape {np.shape(value)}")


class PlausibilityWarning(UserWarning):
    """An input is allowed but far outside the physical range of rolling-resistance problems,
    most likely a unit slip (mm for m, MPa for Pa, mm/s for m/s): jaxroll works in SI units."""


#: Plausible ranges of concrete inputs (SI): (name, symbol, unit, lowest, highest, likely slip).
#: A value outside is computed as given, with a :class:`PlausibilityWarning`.
PLAUSIBLE = {
    "radius": ("radius", "R", "m", 1e-4, 5.0, "a length in mm?"),
    "H": ("layer thickness", "H", "m", 0.0, 1.0, "a length in mm?"),
    "G0": ("relaxed shear modulus", "G0", "Pa", 1e4, np.inf, "a modulus in MPa or kPa?"),
    "speed": ("speed", "V", "m/s", 0.0, 100.0, "a speed in mm/s or km/h?"),
}


def check_plausible(where: str, *, stacklevel: int = 3, **values) -> None:
    """One :class:`PlausibilityWarning` (one line) naming every concrete value outside its
    :data:`PLAUSIBLE` range; ``values``: ``radius`` [m], ``H`` [m], ``G0`` [Pa], ``speed``
    [m/s] (scalars or arrays; ``None`` and traced values are skipped; an infinite ``H`` is a
    half-space, not a slip). ``stacklevel``: of the warning, 3 points at the caller's caller.
    Host side only: never called inside a compiled program."""
    slips = []
    for key, x in values.items():
        if x is None or any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree_util.tree_leaves(x)):
            continue
        name, sym, unit, lo, hi, hint = PLAUSIBLE[key]
        v = np.asarray(x, dtype=float).ravel()
        v = v[np.isfinite(v)]
        bad = v[(v < lo) | (v > hi)] if lo > 0 else v[v > hi]
        if bad.size:
            side = f"above {hi:g}" if bad.max() > hi else f"below {lo:g}"
            slips.append(f"{name} {sym} = {_describe(bad[0] if bad.size == 1 else bad)} {unit} is {side} {unit} "
                         f"({hint} jaxroll works in SI units)")
    if slips:
        warnings.warn(f"{where}: " + "; ".join(slips), PlausibilityWarning, stacklevel=stacklevel)


def roller_inputs(radius, load, speed):
    """Radius ``R`` [m], load ``P`` [N, or N/m for cylinders] and speed ``V`` [m/s] as float64
    scalars, checked once for every method: ``ValueError`` for non-scalars (use ``jax.vmap``
    for sweeps), and :func:`check_input` (works under jit/vmap/grad) for ``R <= 0``, ``P <= 0``,
    ``V < 0``, infinities or NaN (concrete values: :func:`check_roller_values` on the host)."""
    check_roller_shapes(radius, load, speed)
    return tuple(check_input(v, ~test(v), f"{name} {sym} [{unit}] must be {rule}")
                 for (name, sym, unit, test, rule), v in zip(_ROLLER_RULES, map(as_float, (radius, load, speed))))


def check_roller_shapes(radius, load, speed) -> None:
    """``ValueError`` for a radius, load or speed that is not a scalar (use ``jax.vmap`` for
    sweeps); shapes are static, so this holds for traced values too."""
    for (name, *_), x in zip(_ROLLER_RULES, (radius, load, speed)):
        if np.shape(x) != ():
            raise ValueError(f"{name} must be a scalar (use jax.vmap for sweeps); got shape {np.shape(x)}")


class NewtonInfo(eqx.Module):
    """Diagnostics of :func:`newton_root` (no gradient): iterations, final ``|f|`` and whether
    the step or the residual fell below the tolerance."""

    iterations: jax.Array
    residual: jax.Array
    converged: jax.Array


def newton_root(fun, x0, *, lower=-jnp.inf, upper=jnp.inf, tol=1e-12, max_steps=60, max_step=jnp.inf):
    """Root of an increasing scalar function ``fun`` by safeguarded Newton, with implicit
    derivatives.

    Newton steps (derivative by ``jax.jvp``) clipped to ``max_step`` and kept inside the
    bracket ``[lo, hi]``: it starts at ``[lower, upper]`` (give them where the signs are known,
    ``fun(lower) < 0 <= fun(upper)``) and shrinks with the sign of every residual seen; a step
    that leaves a finite bracket is replaced by bisection, a non-finite or non-increasing
    derivative by a ``max_step`` step toward the root (or bisection). Stops when the step is
    below ``tol`` or ``|fun| < 1e-13``, or after ``max_steps``.

    ``fun`` may close over traced values: the root is differentiated by
    :func:`jax.lax.custom_root` (implicit function theorem), never by unrolling the loop.
    Works under ``jit``, ``vmap`` (the loop runs until every lane stops) and ``grad``.

    Returns:
        ``(x, NewtonInfo)``.
    """
    lower, upper = jnp.asarray(lower, float), jnp.asarray(upper, float)

    def solve(f, x_init):
        def body(c):
            x, lo, hi, it, _, _ = c
            r, dr = jax.jvp(f, (x,), (jnp.ones_like(x),))
            lo = jnp.where(r < 0, x, lo)
            hi = jnp.where(r >= 0, x, hi)
            ok = (dr > 0) & jnp.isfinite(dr) & jnp.isfinite(r)
            step = jnp.where(ok, -r / jnp.where(ok, dr, 1.0), jnp.where(r < 0, max_step, -max_step))
            x_new = x + jnp.clip(step, -max_step, max_step)
            bracketed = jnp.isfinite(lo) & jnp.isfinite(hi)
            outside = ~((x_new >= lo) & (x_new <= hi))
            x_new = jnp.where(bracketed & outside, 0.5 * (lo + hi), x_new)
            at_root = jnp.abs(r) < 1e-13  # x itself is the root: keep it (a bisection would leave it)
            x_new = jnp.where(at_root, x, x_new)
            conv = (jnp.abs(x_new - x) < tol) | at_root
            return x_new, lo, hi, it + 1, conv, r

        def cond(c):
            return (~c[4]) & (c[3] < max_steps)

        out = jax.lax.while_loop(cond, body, (x_init, lower + 0.0 * x_init, upper + 0.0 * x_init, jnp.asarray(0),
                                              jnp.asarray(False), jnp.full_like(x_init, jnp.inf)))
        # aux as floats (custom_root differentiates its outputs; ints/bools would need float0)
        return out[0], (out[3].astype(float), jnp.abs(out[5]), out[4].astype(float))

    def tangent_solve(g, y):
        return y / g(jnp.ones_like(y))

    x, (it, res, conv) = jax.lax.custom_root(fun, jnp.asarray(x0, float), solve, tangent_solve, has_aux=True)
    it, res, conv = (jax.lax.stop_gradient(v) for v in (it, res, conv))
    return x, NewtonInfo(iterations=it.astype(int), residual=res, converged=conv > 0.5)


def back_substitute(R, g, j):
    """``y`` with ``R[:j, :j] y[:j] = g[:j]`` and ``y[j:] = 0``, for an upper triangular ``R``
    (``m x m``, ``j <= m`` traced) with a nonzero diagonal on its first ``j`` rows.

    A ``fori_loop`` from row ``j - 1`` up, not ``jax.scipy.linalg.solve_triangular``: on CPU that
    lowers to LAPACK's ``trsm``, whose kernel a process must initialise from SciPy (0.2 s of a
    second process's first call, which loads stored programs and imports nothing else of SciPy).
    GMRES solves one such ``m <= 33`` system per cycle, beside ``m`` operator applications.
    """
    def row(k, y):
        i = j - 1 - k
        return y.at[i].set((g[i] - R[i] @ y) / R[i, i])

    return jax.lax.fori_loop(0, j, row, jnp.zeros_like(g))


#: Basis rows of the first Arnoldi steps of :func:`gmres` (see there).
SHORT_BASIS = 12


def gmres(matvec, b, x0, *, atol, precond=None, restart=20, maxiter=80, has_aux=False, short_basis=True):
    """Solve ``A x = b`` by restarted GMRES with right preconditioning, for real vectors.

    ``matvec(v) = A v``; ``precond(v) = M v`` with ``M ~ A^-1`` (``None``: the identity). Each
    cycle runs at most ``restart`` Arnoldi steps on ``A M`` from the residual ``r = b - A x``
    and updates ``x += M y``. It stops when the true residual ``|b - A x|_2 <= atol`` (checked at
    ``x0`` first, so a converged start costs one ``matvec``) or after ``maxiter`` cycles.

    Written for small Krylov bases on CPU, where ``jax.scipy.sparse.linalg.gmres`` spends as much
    time in its bookkeeping as in a windowed FFT operator: the basis is stored by rows,
    orthogonalised by classical Gram-Schmidt (a second pass only where the first lost more than
    half the norm: Daniel-Gragg-Kaufman-Stewart), the Hessenberg columns are reduced by Givens
    rotations as they come (their product kept as one small orthogonal matrix, applied to a new
    column in one product), and a start ``x0`` is used without an extra ``A`` application at zero.
    A cycle begins in a basis of :data:`SHORT_BASIS` + 1 rows and moves into one of ``restart``
    + 1 rows only if it needs more steps (the same iterates as one long basis: no restart): the
    warm-started solves of a table, which mostly stop within a few steps, then neither zero,
    orthogonalise against nor combine the rows of a long basis (the reference table 15 % faster
    with ``restart = 32``).

    ``short_basis=False``: every cycle in the whole basis from its first step (one Arnoldi loop
    in the program instead of two: a solve from zero that needs most of a cycle, such as a
    derivative solve, compiles to fewer kernels). ``x0=None``: start from zero (the residual is
    ``b``, no ``A`` application; not with ``has_aux``).

    ``has_aux``: ``matvec(v)`` returns ``(A v, aux)``; ``aux`` of the returned ``x`` (from the
    product that checks its residual, no extra application) is returned too.

    Returns:
        ``(x, residual_norm)``: the solution and ``|b - A x|_2`` (the true residual);
        ``(x, residual_norm, aux)`` with ``has_aux``.
    """
    M = (lambda v: v) if precond is None else precond
    product = matvec if has_aux else (lambda v: (matvec(v), None))
    matvec = (lambda v: product(v)[0]) if has_aux else matvec

    def residual(x):
        Ax, aux = product(x)
        r = b - Ax
        return r, jnp.linalg.norm(r), aux
    n = b.shape[0]
    dtype = b.dtype
    atol = jnp.asarray(atol, dtype)

    rows = jnp.arange(restart + 1)  # row numbers of the Hessenberg column, Q and g

    def arnoldi_step(c):
        # V: the basis so far (rows > j zero, so the products over all its rows are exact). Every
        # update below is a whole-array select or a slice update, not a scatter (`.at[].set`): one
        # fused kernel each, without the out-of-bounds guards of a scatter (j + 1 <= restart by
        # the loop condition)
        j, V, R, Q, g = c
        w = matvec(M(jax.lax.dynamic_index_in_dim(V, j, keepdims=False)))
        h = V @ w
        u = w - h @ V
        beta = jnp.linalg.norm(u)

        def reorthogonalise(_):
            h2 = V @ u
            u2 = u - h2 @ V
            return u2, h + h2, jnp.linalg.norm(u2)

        # a second Gram-Schmidt pass only where cancellation made the first one inaccurate (the
        # "twice is enough" test of Daniel, Gragg, Kaufman and Stewart, |u| < |w|/sqrt(2), with
        # |w|^2 = |h|^2 + |u|^2: no reduction over w)
        w, h, beta = jax.lax.cond(beta * beta < 0.5 * (h @ h + beta * beta), reorthogonalise,
                                  lambda _: (u, h, beta), None)
        V = jax.lax.dynamic_update_slice(V, (w / jnp.where(beta > 0, beta, 1.0))[None], (j + 1, 0))
        h = jnp.pad(h, (0, restart + 1 - V.shape[0]))
        h = Q @ jnp.where(rows == j + 1, beta, h)  # the earlier rotations
        a, e = h[j], h[j + 1]
        den = jnp.sqrt(a * a + e * e)  # Krylov entries are O(|A M|): no overflow to guard
        ok = den > 0
        c_j = jnp.where(ok, a / jnp.where(ok, den, 1.0), 1.0)
        s_j = jnp.where(ok, e / jnp.where(ok, den, 1.0), 0.0)
        h = jnp.where(rows == j, den, jnp.where(rows == j + 1, 0.0, h))
        q0 = jax.lax.dynamic_index_in_dim(Q, j)
        q1 = jax.lax.dynamic_index_in_dim(Q, j + 1)
        at = rows[:, None]
        Q = jnp.where(at == j, c_j * q0 + s_j * q1, jnp.where(at == j + 1, c_j * q1 - s_j * q0, Q))
        g = jnp.where(rows == j, c_j * g[j], jnp.where(rows == j + 1, -s_j * g[j], g))
        R = jnp.where(jnp.arange(restart) == j, h[:, None], R)
        return j + 1, V, R, Q, g

    def arnoldi(state, last):
        return jax.lax.while_loop(lambda s: (s[0] < last) & (jnp.abs(s[4][s[0]]) > atol), arnoldi_step, state)

    def correction(j, V, R, g):
        """``y @ V`` with the triangular ``R[:j, :j] y = g[:j]`` (``m = len(V) - 1`` columns), by
        back substitution over the first ``j`` rows (:func:`back_substitute`)."""
        m = V.shape[0] - 1
        return back_substitute(R[:m, :m], g[:m], j) @ V[:m]

    short = min(SHORT_BASIS, restart) if short_basis else restart

    def cycle(c):
        x, r, rnorm, k, _ = c
        R = jnp.zeros((restart + 1, restart), dtype)
        g = jnp.zeros(restart + 1, dtype).at[0].set(rnorm)
        V = jnp.zeros((short + 1, n), dtype).at[0].set(r / rnorm)
        state = arnoldi((jnp.asarray(0), V, R, jnp.eye(restart + 1, dtype=dtype), g), short)
        if short < restart:
            def extend(state):  # the same cycle goes on in the whole basis (no restart)
                j, V, R, Q, g = state
                V = jnp.zeros((restart + 1, n), dtype).at[:short + 1].set(V)
                j, V, R, _, g = arnoldi((j, V, R, Q, g), restart)
                return correction(j, V, R, g)

            j, g = state[0], state[4]
            dx = jax.lax.cond((j == short) & (jnp.abs(g[j]) > atol), extend,
                              lambda s: correction(s[0], s[1], s[2], s[4]), state)
        else:
            dx = correction(state[0], state[1], state[2], state[4])
        x = x + M(dx)
        r, rnorm, aux = residual(x)
        return x, r, rnorm, k + 1, aux

    if x0 is None:
        if has_aux:
            raise ValueError("gmres: x0=None (a start from zero) is not available with has_aux")
        x0, r0, rnorm0, aux0 = jnp.zeros_like(b), b, jnp.linalg.norm(b), None
    else:
        r0, rnorm0, aux0 = residual(x0)
    x, _, rnorm, _, aux = jax.lax.while_loop(lambda c: (c[2] > atol) & (c[3] < maxiter), cycle,
                                             (x0, r0, rnorm0, jnp.asarray(0), aux0))
    return (x, rnorm, aux) if has_aux else (x, rnorm)
