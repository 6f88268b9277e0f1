"""Rolling resistance of a rigid sphere from 2D cylinder slices: algorithms PD, PP, SP ([ZG] sec. 3).

The sphere (radius ``R``) is cut, across the rolling direction, into an odd number ``n`` of
slices of equal thickness ``dy = 2 r_c / n`` covering the contact width ``[-r_c, r_c]``; slice
``k`` is centred at ``y_k = k dy`` (``k = -(n-1)/2 .. (n-1)/2``, one slice centred at ``y = 0``).
Each slice is a 2D rolling cylinder in plane strain (the full model of
:mod:`jaxroll.cylinder`) of radius ``R_c(y) = sqrt(R^2 - y^2)`` -- the radius of the sphere's
cross-section in the plane ``y = const``, so the slice profile ``x^2/(2 R_c)`` is the exact
curvature of the sphere along ``x`` at that ``y``. The sphere's rolling resistance is the sum of
the slices' resistances per unit length (pressure moment ``(1/R_c) int p x dx``) times ``dy``,
evaluated on the slices with ``y_k >= 0`` and doubled by symmetry.

Common core of PD and PP ([ZG] eqs. 2-8). The state variable is the penetration ``d_o`` of the
middle slice; the contact half-width is ``r_c = sqrt(d_o (2R - d_o))`` (eq. 2) and the marginal
load is quadratic, ``p_c(y) = (r_c^2 - y^2)/(2 R_p)`` with ``r_c^3 = 3 P R_p/2`` (eqs. 3-5), so
the middle slice carries ``p_c(0) = 3P/(4 r_c)`` (eq. 6). ``d_o`` solves eq. 7,
``p_c^alg(d_o) = 3P/(4 r_c(d_o))``, where ``p_c^alg(d)`` is the load per unit length of the 2D
cylinder of radius ``R`` pressed to penetration ``d`` (a penetration-controlled contact solve,
below). Initial guess: the Hertz radius ``r_c^H = (3 P R/(16 G'(2 pi V/L)))^(1/3)`` (eq. 8),
``L`` the period, converted to ``d_o`` by inverting eq. 2.

* **PD** (eq. 9): slice ``y`` is pressed to ``d_c(y) = d_o - R + sqrt(R^2 - y^2)`` (geometric
  consistency; the total load ``sum p_c^alg dy`` is only approximately ``P``).
* **PP** (eq. 10): slice ``y`` carries ``p_c(y) = (3P/4)(r_c^2 - y^2)/r_c^3`` (load equilibrium).
  Each slice's load is the exact integral of eq. 10 over the slice divided by ``dy``
  (``p_c(y_k) - (3P/4) dy^2/(12 r_c^3)``), so the slice loads sum to ``P`` exactly.
* **SP** (eq. 11): ``d_o`` solves ``sum_k p_c^alg(d_c(y_k)) dy = P`` with ``d_c`` of eq. 9 and
  ``dy = 2 r_c(d_o)/n``, started from the core's ``d_o``: both geometry and load hold.

Numerics. All slices share one grid and one compliance kernel (the kernel depends on the
material, layer, speed and period only, not on the slice radius or load), chosen for the middle
slice like :func:`jaxroll.cylinder.solve_cylinder` chooses it; the outer slices, which carry
narrower contacts, are therefore resolved more coarsely (their share of ``R_r`` is small; the
slice-count and resolution convergence is tested). The slices are solved together with
``jax.vmap``.

Contact solves (default ``linear_solver="interval"``). The window operator is Toeplitz,
``C[i, j] = c[(i - j) mod N]``, and the slice contact set is one interval of cells, so the
contact block is the same leading block ``T_n`` wherever the interval lies, and the parabolic
profile on it is a combination of ``1, j, j^2``: one Levinson recursion per speed tabulates
``T_n^{-1} [1, j, j^2]`` for every ``n`` (:func:`toeplitz_nested_solve`,
:class:`IntervalOperator`), after which every penetration- or load-controlled slice solve of
every load at that speed is a primal-dual active-set iteration on the interval whose steps cost
one table row and the gaps next to the interval, no factorisation (:func:`solve_interval`; the
full complementarity is checked at the end). The
``"dense"`` (LU, :func:`solve_dense`) and ``"gmres"`` (FFT operator,
:func:`jaxroll.contact.solve_contact`, whose penetration mode :func:`solve_penetration` wraps)
solvers solve the same discrete problem in general form (agreement to rounding is tested).
:func:`rolling_resistance_slices_grid` evaluates a speeds x loads grid (the paper's reference
case) with the compliance and tables built once per speed.

Derivatives. The scalar root finds (eqs. 7 and 11) are a bracketed, safeguarded Newton
iteration in ``log d_o`` inside :func:`jax.lax.custom_root`, so derivatives come from the
implicit function theorem (never from unrolling). The contact solves are differentiated on the
converged contact set with the set held fixed: implicitly (``custom_linear_solve``) for GMRES,
through the direct solve (LU, or the Levinson recursion, a finite direct method whose autodiff
derivative is exact) otherwise.
"""

from __future__ import annotations


import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import contact as _contact
from ._numerics import as_float, roller_inputs
from .cylinder import line_grid
from .layer import Layer, surface_compliance
from .material import relaxed_modulus, storage_modulus
from .result import RollingResult, full_model_result

__all__ = [
    "ALGORITHMS",
    "IntervalOperator",
    "LINEAR_SOLVERS",
    "SliceSolution",
    "dense_window_matrix",
    "interval_operator",
    "rolling_resistance_slices",
    "rolling_resistance_slices_grid",
    "slice_result",
    "solve_dense",
    "solve_interval",
    "solve_penetration",
    "solve_slices",
    "toeplitz_nested_solve",
]

#: The three algorithms of [ZG] sec. 3.
ALGORITHMS = ("PD", "PP", "SP")

class SliceSolution(eqx.Module):
    """Solution of a slice algorithm (slices with ``y_k >= 0`` only; the rest by symmetry).

    Attributes:
        resistance: sphere rolling resistance ``R_r`` [N] (pressure moments).
        resistance_dissipation: the same from the slices' dissipated power [N].
        load: total load carried by the slices ``sum p_c dy`` [N] (``= P`` for PP and SP).
        middle_penetration: ``d_o`` [m].
        contact_radius: ``r_c`` of [ZG] eq. 2 [m].
        y: slice centres ``y_k >= 0`` [m], shape ``(m,)``, ``m = (n+1)/2``.
        dy: slice thickness [m].
        slice_radius: ``R_c(y_k)`` [m].
        slice_load: load per unit length of each slice [N/m].
        slice_penetration: penetration of each slice [m].
        slice_resistance: rolling resistance per unit length of each slice [N/m].
        pressure: slice pressures [Pa], shape ``(m, W)``; ``x`` their cell centres [m].
        status: 0 converged; otherwise the largest contact status of the slices
            (:data:`jaxroll.contact.CONTACT_STATUS`), or 5 if a root find did not converge.
        iterations: Newton iterations of the root finds (core + SP).
        residual: final relative residual of the last root find.
        period_ok: whether the period is at least ``period_factor * max(a_est, V tau)``.
    """

    resistance: jax.Array
    resistance_dissipation: jax.Array
    load: jax.Array
    middle_penetration: jax.Array
    contact_radius: jax.Array
    y: jax.Array
    dy: jax.Array
    slice_radius: jax.Array
    slice_load: jax.Array
    slice_penetration: jax.Array
    slice_resistance: jax.Array
    pressure: jax.Array
    x: jax.Array
    status: jax.Array
    iterations: jax.Array
    residual: jax.Array
    period_ok: jax.Array


# ---------------------------------------------------------------------------------------------
# Penetration-controlled 2D contact on a WindowedCompliance
# ---------------------------------------------------------------------------------------------


def solve_penetration(compliance, profile, penetration, *, tol=1e-10, max_steps=50,
                      linear_restart=80, linear_maxiter=20):
    """Frictionless rolling contact at a prescribed rigid-body penetration (any dimension).

    Find ``p >= 0`` [Pa] with ``g = h - d + C p >= 0`` and ``p g = 0`` for a fixed ``d`` [m]
    (the load follows as ``sum(p) dA``): :func:`jaxroll.contact.solve_contact` in its
    penetration mode, started from the geometric overlap ``{h < d}``, never raising (failures
    are reported in ``status``). The pressure is differentiable (implicit function theorem on
    the converged contact set) w.r.t. the compliance, ``h`` and ``d``. ``d <= 0`` gives
    ``p = 0``.

    Returns:
        :class:`jaxroll.contact.ContactSolution` (``pressure``, ``contact``, ``status`` with the
        codes of :data:`jaxroll.contact.CONTACT_STATUS`, 0 = converged, ``iterations``, ...).
    """
    return _contact.solve_contact(compliance, profile, penetration=penetration, tol=tol,
                                  max_steps=max_steps, linear_restart=linear_restart,
                                  linear_maxiter=linear_maxiter, throw=False)


def dense_window_matrix(compliance):
    """Dense ``(W, W)`` matrix of a 1D :class:`~jaxroll.contact.WindowedCompliance` [m/Pa]:
    ``C[i, j] = c[(i - j) mod N]`` (the Toeplitz operator the FFT applies)."""
    if compliance.ndim != 1:
        raise ValueError("dense_window_matrix is for 1D windows")
    (W,) = compliance.shape
    N = compliance.column.shape[0]
    i = jnp.arange(W)
    return compliance.column[jnp.mod(i[:, None] - i[None, :], N)]


def solve_dense(matrix, profile, value, cell_size, *, mode="penetration", initial_contact=None,
                max_steps=50):
    """Frictionless rolling contact on a small 1D window with a dense compliance matrix.

    Same primal-dual active-set method as :func:`solve_penetration` /
    :func:`jaxroll.contact.solve_contact`, with the equality system of each contact set
    solved by LU (``jnp.linalg.solve``) instead of GMRES: exact to rounding and much faster for
    windows of a few hundred cells (the slices). The active-set iterations run on
    ``stop_gradient`` inputs; the returned solution is one more solve on the converged set,
    differentiated by JAX's linear-solve rule (implicit function theorem).

    Args:
        matrix: dense window compliance ``(W, W)`` [m/Pa] (:func:`dense_window_matrix`).
        profile: ``h`` [m], shape ``(W,)``.
        value: penetration ``d`` [m] (``mode="penetration"``) or load per unit length ``P'``
            [N/m] (``mode="load"``).
        cell_size: ``dx`` [m].
        mode: static, ``"penetration"`` or ``"load"``.
        initial_contact: boolean ``(W,)``; default the geometric overlap ``h < d``
            (penetration) or the lowest 10 % of ``h`` (load).
        max_steps: static active-set iteration limit.

    Returns:
        ``(pressure [Pa], penetration [m], status, iterations)``; ``status`` follows
        :data:`jaxroll.contact.CONTACT_STATUS` (0 converged, 1 not converged, 3 contact at the
        window edge, 4 non-finite).
    """
    if mode not in ("penetration", "load"):
        raise ValueError(f"mode must be 'penetration' or 'load'; got {mode!r}")
    sg = jax.lax.stop_gradient
    Cm = jnp.asarray(matrix)
    h = jnp.asarray(profile, dtype=float)
    v = jnp.asarray(value, dtype=float)
    W = h.shape[0]
    c0 = sg(jnp.abs(Cm[0, 0]))
    if initial_contact is None:
        if mode == "penetration":
            initial_contact = h < sg(v)
        else:
            hmin, hmax = jnp.min(h), jnp.max(h)
            initial_contact = h <= hmin + 0.1 * (hmax - hmin)
    mask0 = jnp.asarray(initial_contact, bool)

    if mode == "penetration":
        g_s = sg(jnp.maximum(jnp.abs(v), 1e-300))

        def system(Cmat, hh, vv, mask):
            mf = mask.astype(float)
            A = (mf[:, None] * mf[None, :]) * Cmat / c0 + jnp.diag(1.0 - mf)
            return A, mf * (vv - hh) / g_s

        def unpack(x, hh, vv):
            return x * (g_s / c0), vv
    else:
        n0 = jnp.maximum(jnp.sum(mask0), 1).astype(float)
        p_s = sg(v / (cell_size * n0))
        g_s = p_s * c0

        def system(Cmat, hh, vv, mask):
            mf = mask.astype(float)
            A = (mf[:, None] * mf[None, :]) * Cmat / c0 + jnp.diag(1.0 - mf)
            A = jnp.concatenate([A, -mf[:, None]], axis=1)
            last = jnp.concatenate([mf / n0, jnp.zeros(1)])[None, :]
            A = jnp.concatenate([A, last], axis=0)
            b = jnp.concatenate([-mf * hh / g_s, (vv * sg(1.0 / v))[None]])
            return A, b

        def unpack(x, hh, vv):
            return x[:-1] * p_s, x[-1] * g_s

    C_ng, h_ng, v_ng = sg(Cm), sg(h), sg(v)
    eps = 1e-12

    def body(state):
        mask, _, it, _ = state
        A, b = system(C_ng, h_ng, v_ng, mask)
        x = jnp.linalg.solve(A, b)
        p, d = unpack(x, h_ng, v_ng)
        gt = (h_ng - d + C_ng @ p) / g_s
        new = jnp.where(mask, p / (g_s / c0) > -eps, gt < -eps)
        done = jnp.all(new == mask) | ~jnp.all(jnp.isfinite(x))
        new = jnp.where(done, mask, new)
        return new, x, it + 1, done

    def cond(state):
        return (~state[3]) & (state[2] < max_steps)

    nx = W if mode == "penetration" else W + 1
    mask, _, iters, done = jax.lax.while_loop(
        cond, body, (mask0, jnp.zeros(nx), jnp.asarray(0), jnp.asarray(False)))
    mask = sg(mask)
    A, b = system(Cm, h, v, mask)
    p, d = unpack(jnp.linalg.solve(A, b), h, v)
    p = jnp.where(mask, p, 0.0)
    finite = jnp.all(jnp.isfinite(p)) & jnp.isfinite(d)
    status = jnp.where(~finite, 4, jnp.where(mask[0] | mask[-1], 3, jnp.where(done, 0, 1)))
    return p, d, status, iters


# ---------------------------------------------------------------------------------------------
# Interval contact solver on the Toeplitz window operator (the fast path of the slices)
# ---------------------------------------------------------------------------------------------


class IntervalOperator(eqx.Module):
    """Everything the interval solver needs about one compliance (one speed), built once and
    shared by every slice and every load of that speed.

    The window operator is Toeplitz, ``C[i, j] = c[(i - j) mod N]``, so its restriction to any
    contact interval of ``n`` consecutive cells is the same ``n x n`` leading block ``T_n``
    whatever the interval's position. On the interval ``[l, l + n)`` the profile is
    ``x_{l+j}^2 = x_l^2 + 2 x_l dx j + dx^2 j^2``, hence every contact solution of every slice
    is a combination of the three nested solutions ``T_n^{-1} [1, j, j^2]``, tabulated for all
    ``n`` by one Levinson recursion (``O(W^2)`` in all).

    Attributes:
        tables: ``(W, W, 3)``: row ``n - 1`` holds ``T_n^{-1} [1, j, j^2]`` [Pa/m], zero-padded.
        matrix: dense window matrix ``(W, W)`` [m/Pa] (:func:`dense_window_matrix`).
        band_left, band_right: ``(B, W)`` influence coefficients of the ``B`` cells left of an
            interval (``c[-s - j]``) and right of it (``c[s + r]``, ``r`` counted from its right
            end), ``s = 1..B`` [m/Pa]: the gaps that steer the iteration.
        x: cell centres ``(W,)`` [m]; dx: cell width [m].
    """

    tables: jax.Array
    matrix: jax.Array
    band_left: jax.Array
    band_right: jax.Array
    x: jax.Array
    dx: jax.Array


def toeplitz_nested_solve(column, size, rhs):
    """Solutions of ``T_n x_n = rhs[:n]`` for every leading block ``T_n`` (``n = 1 .. size``) of
    the Toeplitz matrix ``T[i, j] = column[(i - j) mod N]`` (non-symmetric allowed), by the
    Levinson recursion (forward/backward vectors), ``O(size^2)`` per right-hand side.

    Requires non-singular leading blocks (true for a dissipative compliance, whose symmetric part
    is positive definite). A direct method: differentiable by ordinary autodiff (exact).

    Args:
        column: periodic influence coefficients ``(N,)``; size: static block size ``W <= N``;
        rhs: ``(W, m)``.

    Returns:
        ``(W, W, m)``; entry ``[n - 1, :n]`` is ``x_n``, the rest zero.
    """
    N = column.shape[0]
    W = int(size)
    idx = np.arange(W)
    t_up = column[np.mod(-1 - idx, N)]  # T[0, j + 1] = t_{-1-j}
    t0 = column[0]
    f0 = jnp.zeros(W, column.dtype).at[0].set(1.0 / t0)
    x0 = jnp.zeros((W, rhs.shape[1]), column.dtype).at[0].set(rhs[0] / t0)

    def step(carry, n):  # sizes n -> n + 1
        f, b, xs = carry
        t_row = column[jnp.mod(n - idx, N)]  # T[n, j] = t_{n-j}
        ef, eb, ex = t_row @ f, t_up @ b, t_row @ xs
        den = 1.0 - ef * eb
        bs = jnp.roll(b, 1)  # [0; b]
        f_new = (f - ef * bs) / den
        b_new = (bs - eb * f) / den
        xs = xs + b_new[:, None] * (rhs[n] - ex)[None, :]
        return (f_new, b_new, xs), xs

    _, out = jax.lax.scan(step, (f0, f0, x0), jnp.arange(1, W))
    return jnp.concatenate([x0[None], out], axis=0)


def interval_operator(compliance, x, dx, band_cells=8) -> IntervalOperator:
    """:class:`IntervalOperator` of a 1D :class:`~jaxroll.contact.WindowedCompliance` on the
    window cell centres ``x`` [m] (uniform, spacing ``dx``); ``band_cells`` static (see
    :func:`solve_interval`)."""
    (W,) = compliance.shape
    N = compliance.column.shape[0]
    s = np.arange(1, int(band_cells) + 1)[:, None]
    jj = np.arange(W)[None, :]
    band_left = compliance.column[np.mod(-s - jj, N)]
    band_right = compliance.column[np.mod(s + jj, N)]
    j = jnp.arange(W, dtype=float)
    rhs = jnp.stack([jnp.ones(W), j, j * j], axis=1)
    tables = toeplitz_nested_solve(compliance.column, W, rhs)
    return IntervalOperator(tables=tables, matrix=dense_window_matrix(compliance), band_left=band_left,
                            band_right=band_right, x=x, dx=dx)


def _interval_pressure(op, l, n, radius, value, mode):
    """Reduced pressure ``q = 2 R p`` on the interval ``[l, l + n)`` (zero elsewhere) and the
    reduced penetration ``e = 2 R d`` (``mode="load"``: from the load equation)."""
    W = op.x.shape[0]
    x_l = op.x[l]
    dx = op.dx
    row = op.tables[jnp.maximum(n, 1) - 1]
    a, b, c = row[:, 0], row[:, 1], row[:, 2]
    lin = -2.0 * x_l * dx * b - dx * dx * c  # q = (e - x_l^2) a + lin
    if mode == "load":
        # sum(q) dx = 2 R P'  ->  e
        e = x_l * x_l + (2.0 * radius * value / dx - jnp.sum(lin)) / jnp.sum(a)
    else:
        e = 2.0 * radius * value
    q_rel = jnp.where(n > 0, (e - x_l * x_l) * a + lin, 0.0)
    idx = jnp.arange(W)
    q = jnp.where((idx >= l) & (idx < l + n), jnp.roll(q_rel, l), 0.0)
    return q, e


def solve_interval(op: IntervalOperator, radius, value, *, mode="penetration", initial=None,
                   max_steps=60, check=True):
    """Frictionless rolling contact of a parabolic profile ``h = x^2/(2 R)`` on a 1D window whose
    contact set is one interval of cells, from the Levinson tables of an
    :class:`IntervalOperator`.

    Same primal-dual active-set iteration as :func:`solve_penetration` (new set = contact cells
    with ``p > 0`` plus free cells with ``g < 0``), with the set replaced by its hull
    ``[l, l + n)``; each iteration costs one table row and the gaps on the operator's
    ``band_cells`` cells either side of the interval (``O(band_cells W)``), no factorisation.
    On convergence the full complementarity is checked once (one dense matvec): a set that is
    not one interval, or a negative gap anywhere outside it, gives ``status = 1``. The returned
    pressure is the tables' closed form on the converged interval, differentiable
    (exactly: direct Levinson solve, contact set fixed) w.r.t. the compliance, ``R`` and the
    prescribed value.

    Args:
        op: :class:`IntervalOperator`.
        radius: profile radius ``R`` [m].
        value: penetration ``d`` [m] (``mode="penetration"``; ``d <= 0`` gives ``p = 0``) or
            load per unit length ``P'`` [N/m] (``mode="load"``).
        mode: static, ``"penetration"`` or ``"load"``.
        initial: ``(l, n)`` initial interval (default: the geometric overlap, or the middle
            cells with ``mode="load"``, which should pass a better guess).
        max_steps: static iteration limit.
        check: static; ``False`` skips the final full complementarity check (one dense matvec;
            used inside the root finds, whose final solves are checked).

    Returns:
        ``(pressure [Pa], penetration [m], status, iterations, (l, n))``; ``status`` codes of
        :data:`jaxroll.contact.CONTACT_STATUS` (0 converged, 1 not converged or not an interval,
        3 contact at the window edge, 4 non-finite).
    """
    if mode not in ("penetration", "load"):
        raise ValueError(f"mode must be 'penetration' or 'load'; got {mode!r}")
    sg = jax.lax.stop_gradient
    W = op.x.shape[0]
    idx = jnp.arange(W)
    op_ng = jax.tree_util.tree_map(sg, op)
    R_ng, v_ng = sg(jnp.asarray(radius, float)), sg(jnp.asarray(value, float))
    x2 = op_ng.x * op_ng.x
    mid = W // 2 - 1

    def hull(mask, empty_n):
        anyc = jnp.any(mask)
        first = jnp.argmax(mask)
        last = W - 1 - jnp.argmax(mask[::-1])
        return jnp.where(anyc, first, mid), jnp.where(anyc, last - first + 1, empty_n)

    if initial is None:
        if mode == "penetration":
            l0, n0 = hull(x2 < 2.0 * R_ng * v_ng, 0)
        else:
            l0, n0 = jnp.asarray(mid), jnp.asarray(2)
    else:
        l0, n0 = (jnp.asarray(v, int) for v in initial)
    empty_n = 0 if mode == "penetration" else 2

    band = jnp.arange(1, op_ng.band_left.shape[0] + 1)

    def evaluate(l, n):
        # gaps only on the band cells either side of the interval (the full check follows)
        q, e = _interval_pressure(op_ng, l, n, R_ng, v_ng, mode)
        q_rel = jnp.roll(q, -l)  # q_rel[j] = q[l + j], zero for j >= n
        q_rev = jnp.roll(q_rel[::-1], n - W)  # q_rev[r] = q[l + n - 1 - r], zero for r >= n
        g_l = op_ng.band_left @ q_rel  # cells l - s
        g_r = op_ng.band_right @ q_rev  # cells l + n - 1 + s
        i_l, i_r = l - band, l + n - 1 + band
        gs = jnp.abs(e) + op_ng.dx ** 2
        viol_l = (x2[jnp.clip(i_l, 0, W - 1)] - e + g_l < -1e-12 * gs) & (i_l >= 0)
        viol_r = (x2[jnp.clip(i_r, 0, W - 1)] - e + g_r < -1e-12 * gs) & (i_r < W)
        inside = (idx >= l) & (idx < l + n)
        qs = jnp.max(jnp.abs(q)) + 1e-300
        new = inside & (q > -1e-12 * qs)
        new = new.at[i_l].max(viol_l, mode="drop").at[i_r].max(viol_r, mode="drop")
        return new, q

    def body(state):
        l, n, it, _, _ = state
        new, q = evaluate(l, n)
        ln, nn = hull(new, empty_n)
        ok = jnp.all(jnp.isfinite(q))
        done = ((ln == l) & (nn == n)) | ~ok
        contiguous = jnp.all(new == ((idx >= ln) & (idx < ln + nn)))
        return jnp.where(done, l, ln), jnp.where(done, n, nn), it + 1, done, contiguous

    def cond(state):
        return (~state[3]) & (state[2] < max_steps)

    l, n, iters, done, contiguous = jax.lax.while_loop(
        cond, body, (l0, n0, jnp.asarray(0), jnp.asarray(False), jnp.asarray(True)))
    if check:  # full complementarity on the converged interval (no gap < 0 anywhere outside)
        q_c, e_c = _interval_pressure(op_ng, l, n, R_ng, v_ng, mode)
        g_c = x2 - e_c + op_ng.matrix @ q_c
        outside = (idx < l) | (idx >= l + n)
        contiguous = contiguous & ~jnp.any(outside & (g_c < -1e-9 * (jnp.abs(e_c) + op_ng.dx ** 2)))
    l, n = sg(l), sg(n)
    q, e = _interval_pressure(op, l, n, radius, value, mode)
    p = q / (2.0 * radius)
    d = e / (2.0 * radius)
    finite = jnp.all(jnp.isfinite(p)) & jnp.isfinite(d)
    edge = (n > 0) & ((l == 0) | (l + n == W))
    status = jnp.where(~finite, 4, jnp.where(edge, 3, jnp.where(done & contiguous, 0, 1)))
    return p, d, status, iters, (l, n)


# ---------------------------------------------------------------------------------------------
# Safeguarded Newton root find with implicit differentiation
# ---------------------------------------------------------------------------------------------


def _root(fun, y0, *, tol=1e-10, max_steps=40, max_step=1.0):
    """Root of a scalar increasing function ``fun`` (traced closure allowed) from ``y0``.

    Newton steps (derivative by ``jax.jvp``) clipped to ``max_step``, kept inside the bracket
    ``[lo, hi]`` given by the residual signs seen so far (bisection otherwise). Differentiated
    by :func:`jax.lax.custom_root` (implicit function theorem). Returns ``(y, info)`` with
    ``info = (iterations, residual, converged)`` (no gradient).
    """

    def solve(f, y_init):
        def body(c):
            y, lo, hi, it, _, _ = c
            r, dr = jax.jvp(f, (y,), (jnp.ones_like(y),))
            lo = jnp.where(r < 0, y, lo)
            hi = jnp.where(r >= 0, y, hi)
            ok = (dr > 0) & jnp.isfinite(dr) & jnp.isfinite(r)
            step = jnp.where(ok, -r / jnp.where(ok, dr, 1.0), jnp.where(r < 0, max_step, -max_step))
            step = jnp.clip(step, -max_step, max_step)
            y_new = y + step
            bracketed = jnp.isfinite(lo) & jnp.isfinite(hi)
            outside = (y_new <= lo) | (y_new >= hi)
            y_new = jnp.where(bracketed & outside, 0.5 * (lo + hi), y_new)
            conv = (jnp.abs(y_new - y) < tol) | (jnp.abs(r) < 1e-13)
            return y_new, lo, hi, it + 1, conv, r

        def cond(c):
            return (~c[4]) & (c[3] < max_steps)

        inf = jnp.asarray(jnp.inf)
        out = jax.lax.while_loop(
            cond, body, (y_init, -inf, inf, jnp.asarray(0), jnp.asarray(False), inf)
        )
        # aux as floats (custom_root differentiates its outputs; ints/bools would need float0)
        return out[0], (out[3].astype(float), jnp.abs(out[5]), out[4].astype(float))

    def tangent_solve(g, y):
        return y / g(jnp.ones_like(y))

    y, info = jax.lax.custom_root(fun, y0, solve, tangent_solve, has_aux=True)
    it, res, conv = jax.tree_util.tree_map(jax.lax.stop_gradient, info)
    return y, (it.astype(int), res, conv > 0.5)


# ---------------------------------------------------------------------------------------------
# Grid and algorithms
# ---------------------------------------------------------------------------------------------


LINEAR_SOLVERS = ("interval", "dense", "gmres")


def _grid(material, layer, R, P, V, period, n_cells, cells_per_radius, window, period_factor):
    """Shared slice grid: the 2D cylinder's grid (:func:`jaxroll.cylinder.line_grid`) for the
    middle slice's estimated load per unit length (eq. 6 with the relaxed Hertz radius, eq. 8
    at omega = 0)."""
    G0 = relaxed_modulus(material)
    r_h0 = (3.0 * P * R / (16.0 * G0)) ** (1.0 / 3.0)
    P0 = 3.0 * P / (4.0 * r_h0)
    dx, L, N, W, period_ok, _, _ = line_grid(material, layer, R, P0, V, period=period, n_cells=n_cells,
                                             cells_per_radius=cells_per_radius, window=window,
                                             period_factor=period_factor)
    return dx, L, N, W, period_ok


def _grid_estimate(material, layer, R, P):
    """Estimated half-width ``a_est`` [m] of the middle slice, as :func:`_grid` uses it (the
    formula of :func:`jaxroll.cylinder.line_grid` at the load per unit length of eq. 6)."""
    G0 = relaxed_modulus(material)
    r_h0 = (3.0 * P * R / (16.0 * G0)) ** (1.0 / 3.0)
    P0 = 3.0 * P / (4.0 * r_h0)
    H = layer.H
    finite_H = jnp.isfinite(H)
    H_safe = jnp.where(finite_H, H, 1.0)
    a_thin = jnp.where(finite_H, (15.0 * P0 * R * H_safe**3 / (2.0 * G0)) ** 0.2, jnp.inf)
    return jnp.minimum(jnp.sqrt(P0 * R / (jnp.pi * G0)), a_thin)


class _Prepared(eqx.Module):
    """Per-speed data shared by all slices and loads: compliance, dissipation kernel, grid."""

    compliance: _contact.WindowedCompliance
    kernel2: jax.Array
    op: IntervalOperator | None
    dense: jax.Array | None
    x: jax.Array
    dx: jax.Array
    period: jax.Array
    n_cells: int = eqx.field(static=True)


def _prepare(material, layer, V, dx, L, N, W, images, linear_solver) -> _Prepared:
    def T(q):
        return surface_compliance(layer, material, q, 0.0, V)

    K, K2 = _contact.periodic_kernel(T, (L,), (N,), images=images, dissipation=True)
    C = _contact.windowed_compliance(K, (N,), (W,))
    x = (jnp.arange(W, dtype=float) - 0.5 * (W - 1)) * dx
    op = interval_operator(C, x, dx) if linear_solver == "interval" else None
    Cd = dense_window_matrix(C) if linear_solver == "dense" else None
    return _Prepared(compliance=C, kernel2=K2, op=op, dense=Cd, x=x, dx=dx, period=L, n_cells=N)


def _solve_case(prep: _Prepared, material, layer, R, P, V, *, algorithm, n_slices, linear_solver, tol,
                max_steps, root_tol, root_max_steps, period_ok) -> SliceSolution:
    """One sphere (load ``P``, speed ``V``) on prepared per-speed data; never raises."""
    x, dx, L, N = prep.x, prep.dx, prep.period, prep.n_cells
    m = (n_slices + 1) // 2
    k = jnp.arange(m, dtype=float)
    weights = jnp.where(k > 0, 2.0, 1.0)  # symmetry: slices +-y_k

    def contact_radius(d_o):  # eq. 2
        return jnp.sqrt(d_o * (2.0 * R - d_o))

    def pen_slice(Rc, d, check=True):
        """Pressure [Pa] and status of a slice of radius Rc pressed to penetration d."""
        if linear_solver == "interval":
            p, _, st, _, _ = solve_interval(prep.op, Rc, d, mode="penetration", max_steps=max_steps,
                                            check=check)
            return p, st
        pos = d > 0.0
        d_safe = jnp.where(pos, d, 1.0)  # double-where: d <= 0 carries nothing
        hh = x * x / (2.0 * Rc)
        if linear_solver == "dense":
            p, _, st, _ = solve_dense(prep.dense, hh, d_safe, dx, mode="penetration", max_steps=max_steps)
        else:
            s = solve_penetration(prep.compliance, hh, d_safe, tol=tol, max_steps=max_steps)
            p, st = s.pressure, s.status
        return jnp.where(pos, p, 0.0), jnp.where(pos, st, 0)

    def slice_outputs(Rc, p):
        Pc = jnp.sum(p) * dx
        Rr = jnp.sum(p * x) * dx / Rc
        Rr_d = _contact.dissipation_resistance(prep.kernel2, p, (N,), (L,))
        return Pc, Rr, Rr_d

    def middle_load(d_o):
        p, _ = pen_slice(R, d_o, check=False)  # the final solves are checked
        return jnp.sum(p) * dx

    # ---- common core (eqs. 6-8): eq. 7 on the middle slice, unknown y = log(d_o / d_H) ----
    omega = 2.0 * jnp.pi * V / L
    r_h = (3.0 * P * R / (16.0 * storage_modulus(material, omega))) ** (1.0 / 3.0)  # eq. 8
    r_h = jnp.minimum(r_h, 0.5 * R)
    d_h = jax.lax.stop_gradient(R - jnp.sqrt(R * R - r_h * r_h))  # eq. 2 inverted

    def core_residual(y):
        d_o = d_h * jnp.exp(y)
        p_alg = middle_load(d_o)
        target = 3.0 * P / (4.0 * contact_radius(d_o))  # eq. 6
        pos = p_alg > 0.0
        return jnp.where(pos, jnp.log(jnp.where(pos, p_alg, 1.0) / target), -1e3)

    y_core, (it_core, res_core, conv_core) = _root(core_residual, jnp.asarray(0.0),
                                                   tol=root_tol, max_steps=root_max_steps)
    it_total, res_last, conv = it_core, res_core, conv_core

    def slice_geometry(d_o):
        r_c = contact_radius(d_o)
        dy = 2.0 * r_c / n_slices
        y = k * dy
        Rc = jnp.sqrt(R * R - y * y)
        d_c = d_o - R + Rc  # eq. 9
        return r_c, dy, y, Rc, d_c

    if algorithm == "SP":
        def total_load(d_o):
            r_c, dy, y, Rc, d_c = slice_geometry(d_o)
            p, _ = jax.vmap(lambda a, b: pen_slice(a, b, check=False))(Rc, d_c)
            return jnp.sum(weights * jnp.sum(p, axis=1)) * dx * dy

        def sp_residual(yy):
            Pc = total_load(d_h * jnp.exp(yy))
            pos = Pc > 0.0
            return jnp.where(pos, jnp.log(jnp.where(pos, Pc, 1.0) / P), -1e3)

        y_sp, (it_sp, res_sp, conv_sp) = _root(sp_residual, jax.lax.stop_gradient(y_core),
                                               tol=root_tol, max_steps=root_max_steps)
        it_total, res_last, conv = it_core + it_sp, res_sp, conv_core & conv_sp
        d_o = d_h * jnp.exp(y_sp)
    else:
        d_o = d_h * jnp.exp(y_core)

    r_c, dy, y, Rc, d_c = slice_geometry(d_o)
    if algorithm == "PP":
        # eq. 10 integrated over each slice / dy: sums to P exactly
        r2 = r_c * r_c
        loads = 0.75 * P * (r2 - y * y - dy * dy / 12.0) / (r2 * r_c)

        G0 = relaxed_modulus(material)
        H = layer.H
        finite_H = jnp.isfinite(H)
        H_safe = jnp.where(finite_H, H, 1.0)

        def load_slice(Rc_k, P_k):
            # initial contact set: 2D Hertz / thin-layer half-width of the slice (as the cylinder)
            a_k = jnp.sqrt(P_k * Rc_k / (jnp.pi * G0))
            a_k = jnp.minimum(a_k, jnp.where(
                finite_H, (15.0 * P_k * Rc_k * H_safe**3 / (2.0 * G0)) ** 0.2, jnp.inf))
            hh = x * x / (2.0 * Rc_k)
            init = jnp.abs(x) < jnp.maximum(a_k, dx)
            if linear_solver == "interval":
                first = jnp.argmax(init)
                n0 = jnp.sum(init.astype(int))
                p_k, d_k, st_k, _, _ = solve_interval(prep.op, Rc_k, P_k, mode="load", initial=(first, n0),
                                                      max_steps=max_steps)
                return p_k, st_k, d_k
            if linear_solver == "dense":
                p_k, d_k, st_k, _ = solve_dense(prep.dense, hh, P_k, dx, mode="load", initial_contact=init,
                                                max_steps=max_steps)
                return p_k, st_k, d_k
            s = _contact.solve_contact(prep.compliance, hh, P_k, dx, initial_contact=init, tol=tol,
                                       max_steps=max_steps, throw=False)
            return s.pressure, s.status, s.penetration

        p, st, pen = jax.vmap(load_slice)(Rc, loads)
    else:
        p, st = jax.vmap(pen_slice)(Rc, d_c)
        pen = d_c
    Pc, Rr, Rr_d = jax.vmap(slice_outputs)(Rc, p)
    status = jnp.max(st)
    status = jnp.where(conv, status, jnp.maximum(status, 5))
    return SliceSolution(
        resistance=jnp.sum(weights * Rr) * dy,
        resistance_dissipation=jnp.sum(weights * Rr_d) * dy,
        load=jnp.sum(weights * Pc) * dy,
        middle_penetration=d_o,
        contact_radius=r_c,
        y=y,
        dy=dy,
        slice_radius=Rc,
        slice_load=Pc,
        slice_penetration=pen,
        slice_resistance=Rr,
        pressure=p,
        x=x,
        status=status,
        iterations=it_total,
        residual=res_last,
        period_ok=period_ok,
    )


def _check_options(algorithm, n_slices, linear_solver):
    if linear_solver not in LINEAR_SOLVERS:
        raise ValueError(f"linear_solver must be one of {LINEAR_SOLVERS}; got {linear_solver!r}")
    if algorithm not in ALGORITHMS:
        raise ValueError(f"algorithm must be one of {ALGORITHMS}; got {algorithm!r}")
    n_slices = int(n_slices)
    if n_slices < 1 or n_slices % 2 == 0:
        raise ValueError(f"n_slices must be a positive odd integer; got {n_slices}")
    return n_slices


def solve_slices(
    material,
    layer: Layer,
    radius,
    load,
    speed,
    *,
    algorithm: str = "PD",
    n_slices: int = 21,
    period=None,
    n_cells: int | None = None,
    cells_per_radius: int | None = None,
    window: float = 3.0,
    period_factor: float = 20.0,
    images: int = 4,
    tol: float = 1e-10,
    max_steps: int = 60,
    root_tol: float = 1e-10,
    root_max_steps: int = 40,
    linear_solver: str = "interval",
    window_cells: int | None = None,
    throw: bool = True,
) -> SliceSolution:
    """Solve a slice algorithm of [ZG] sec. 3 (PD, PP or SP) for a rigid sphere.

    Args:
        material: material of :mod:`jaxroll.material`.
        layer: :class:`jaxroll.layer.Layer`.
        radius: sphere radius ``R`` [m].
        load: vertical load ``P`` [N], positive.
        speed: rolling speed ``V`` [m/s], >= 0.
        algorithm: static, ``"PD"`` (eq. 9), ``"PP"`` (eq. 10) or ``"SP"`` (eq. 11).
        n_slices: static odd number of slices across ``[-r_c, r_c]`` (paper: 21).
        period, n_cells, cells_per_radius, window, period_factor, images: resolution of the 2D
            slices, as in :func:`jaxroll.cylinder.solve_cylinder`, chosen for the middle slice
            (estimated load ``3P/(4 r_c^H)`` with the relaxed modulus) and shared by all slices.
            The paper used ``period = 0.2`` m and 0.25 mm cells.
        tol, max_steps: contact solver tolerance (GMRES only) and active-set iteration limit.
        linear_solver: static, ``"interval"`` (default: :func:`solve_interval`, the contact set
            is one interval of cells and every solve is a closed form from Levinson tables of
            the Toeplitz window operator built once; fastest), ``"dense"`` (LU on the dense
            window matrix, :func:`solve_dense`) or ``"gmres"`` (matrix-free FFT operator:
            :func:`solve_penetration` and :func:`jaxroll.contact.solve_contact`). All three
            solve the same discrete problem (checked to rounding in the tests).
        window_cells: static even number of window cells, overriding the automatic window
            (needed with a fixed ``period`` under ``jit``/``vmap``, where the automatic window
            is the whole period).
        root_tol, root_max_steps: tolerance on ``log d_o`` and iteration limit of the root finds.
        throw: raise (``eqx.error_if``) on failure; otherwise report it in ``status``.

    Returns:
        :class:`SliceSolution`.
    """
    n_slices = _check_options(algorithm, n_slices, linear_solver)
    R, P, V = roller_inputs(radius, load, speed)
    dx, L, N, W, period_ok = _grid(material, layer, R, P, V, period, n_cells, cells_per_radius,
                                   window, period_factor)
    if window_cells is not None:
        W = int(window_cells)
        if W % 2 or not 2 <= W <= N:
            raise ValueError(f"window_cells must be even and in [2, n_cells = {N}]; got {W}")
    prep = _prepare(material, layer, V, dx, L, N, W, images, linear_solver)
    s = _solve_case(prep, material, layer, R, P, V, algorithm=algorithm, n_slices=n_slices,
                    linear_solver=linear_solver, tol=tol, max_steps=max_steps, root_tol=root_tol,
                    root_max_steps=root_max_steps, period_ok=period_ok)
    if throw:
        Rr = eqx.error_if(s.resistance, s.status != 0,
                          "slice algorithm failed: a contact solve or the root find did not converge "
                          "(status codes: jaxroll.contact.CONTACT_STATUS, 5 = root find)")
        s = eqx.tree_at(lambda t: t.resistance, s, Rr)
    return s


def rolling_resistance_slices_grid(
    material,
    layer: Layer,
    radius,
    loads,
    speeds,
    *,
    algorithm: str = "PD",
    n_slices: int = 21,
    period=0.2,
    n_cells: int = 2**10,
    window: float = 3.0,
    window_cells: int | None = None,
    period_factor: float = 20.0,
    images: int = 4,
    tol: float = 1e-10,
    max_steps: int = 60,
    root_tol: float = 1e-10,
    root_max_steps: int = 40,
    linear_solver: str = "interval",
    speed_batch: int = 1,
):
    """Slice-algorithm ``R_r`` [N] on the grid ``speeds x loads`` (the paper's reference case)
    at one fixed resolution, in one traced program.

    The compliance (and the Levinson tables of :func:`solve_interval`) depend on the speed only:
    they are built once per speed (``lax.map`` over speeds, ``speed_batch`` at a time) and
    shared by all slices of all loads of that speed (``vmap`` over loads). Each point equals
    :func:`solve_slices` at the same ``period``, ``n_cells`` and ``window_cells``. Never raises
    on a failed point: see ``status``.

    Args:
        material, layer, radius: as :func:`solve_slices`.
        loads: 1D array of loads [N]; speeds: 1D array of speeds [m/s].
        algorithm, n_slices, images, tol, max_steps, root_tol, root_max_steps, linear_solver:
            as :func:`solve_slices`.
        period: period ``L`` [m] (default the paper's 0.2 m); n_cells: static cells per period
            (default 1024: 0.195 mm cells).
        window, window_cells: static window cells (default ``2 ceil(window a_est/dx)`` for the
            largest load, ``a_est`` as in :func:`solve_slices`); concrete ``loads`` are needed
            for the automatic window.
        period_factor: the period is flagged (``period_ok``) below
            ``period_factor max(4 a_est, V tau)``.

    Returns:
        dict of ``(n_speeds, n_loads)`` arrays: ``value`` (moment form [N]), ``dissipation``
        [N], ``load`` (sum of the slice loads [N]), ``contact_radius`` (``r_c`` [m]),
        ``penetration`` (``d_o`` [m]), ``status``, ``iterations``, ``period_ok``.
    """
    n_slices = _check_options(algorithm, n_slices, linear_solver)
    R = as_float(radius)
    loads_in = loads
    loads, speeds = as_float(loads), as_float(speeds)
    if loads.ndim != 1 or speeds.ndim != 1:
        raise ValueError("loads and speeds must be 1D arrays")
    N = int(n_cells)
    if window_cells is None:
        try:
            with jax.ensure_compile_time_eval():  # concrete inputs stay concrete under jit
                p_max = float(np.max(np.asarray(loads_in)))
                a_est = float(_grid_estimate(material, layer, radius, p_max))
                dx_c = float(period) / N
        except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError, TypeError):
            raise ValueError("with traced loads, material, layer, radius or period, pass window_cells "
                             "(static)") from None
        W = min(N, 2 * int(np.ceil(window * a_est / dx_c)))
    else:
        W = int(window_cells)
    if W % 2 or not 2 <= W <= N:
        raise ValueError(f"window_cells must be even and in [2, n_cells = {N}]; got {W}")
    L = as_float(period)
    dx = L / N

    def one_speed(V):
        prep = _prepare(material, layer, V, dx, L, N, W, images, linear_solver)

        def one_load(P):
            *_, ok = _grid(material, layer, R, P, V, L, N, None, window, period_factor)
            s = _solve_case(prep, material, layer, R, P, V, algorithm=algorithm, n_slices=n_slices,
                            linear_solver=linear_solver, tol=tol, max_steps=max_steps, root_tol=root_tol,
                            root_max_steps=root_max_steps, period_ok=ok)
            return dict(value=s.resistance, dissipation=s.resistance_dissipation, load=s.load,
                        contact_radius=s.contact_radius, penetration=s.middle_penetration,
                        status=s.status, iterations=s.iterations, period_ok=s.period_ok)

        return jax.vmap(one_load)(loads)

    return jax.lax.map(one_speed, speeds, batch_size=int(speed_batch))


def rolling_resistance_slices(material, layer, radius, load, speed, *, algorithm: str = "PD",
                              n_slices: int = 21, **cylinder_options) -> RollingResult:
    """Rolling resistance [N] of a rigid sphere from 2D cylinder slices ([ZG] sec. 3).

    ``R_r = sum_k R_r,c(y_k) dy`` over ``n_slices`` plane-strain cylinder slices, with the
    algorithm ``"PD"`` (geometric consistency, eq. 9), ``"PP"`` (load equilibrium, eq. 10) or
    ``"SP"`` (both, eq. 11); see :func:`solve_slices` and the module docstring.

    Args:
        material, layer: material and :class:`jaxroll.layer.Layer`.
        radius: sphere radius ``R`` [m]; load: ``P`` [N]; speed: ``V`` [m/s].
        algorithm: ``"PD"``, ``"PP"`` or ``"SP"``.
        n_slices: odd number of slices (paper: 21).
        **cylinder_options: ``period``, ``n_cells``, ``cells_per_radius``, ``window``,
            ``period_factor``, ``images``, ``tol``, ``max_steps``, ``root_tol``,
            ``root_max_steps``, ``linear_solver``, ``window_cells``, ``throw`` (see :func:`solve_slices`).

    Returns:
        :class:`jaxroll.result.RollingResult` with ``regime = 4`` ("full": built on the full 2D
        contact model), ``contact_radius`` = ``r_c`` of eq. 2, ``penetration`` = ``d_o`` (middle
        slice), ``truncation`` = relative difference of the moment and dissipation forms (a
        discretisation-error estimate), ``pressure`` = slice pressures ``(m, W)`` on
        ``grid = (x, y_k)``, ``status``, ``iterations`` (Newton), ``residual`` (root find).
    """
    s = solve_slices(material, layer, radius, load, speed, algorithm=algorithm, n_slices=n_slices,
                     **cylinder_options)
    return slice_result(s, layer)


def slice_result(s: SliceSolution, layer: Layer) -> RollingResult:
    """:class:`jaxroll.result.RollingResult` of a :class:`SliceSolution` (see
    :func:`rolling_resistance_slices` for the fields)."""
    return full_model_result(
        s.resistance, s.resistance_dissipation, s.contact_radius, layer.H, ok=(s.status == 0) & s.period_ok,
        penetration=s.middle_penetration, pressure=s.pressure, grid=(s.x, s.y), status=s.status,
        iterations=s.iterations, residual=s.residual,
    )
