"""Rolling resistance of a rigid sphere from 2D cylinder slices: algorithms PD, PP, SP ([ZG] sec. 3).

The sphere (radius ``R``) is cut, across the rolling direction, into an odd number ``n`` of
slices of equal thickness ``dy = 2 r_c / n`` covering the contact width ``[-r_c, r_c]``; slice
``k`` is centred at ``y_k = k dy`` (``k = -(n-1)/2 .. (n-1)/2``, one slice centred at ``y = 0``).
Each slice is a 2D rolling cylinder in plane strain (the full model of
:mod:`jaxroll.engines.cylinder`) of radius ``R_c(y) = sqrt(R^2 - y^2)`` -- the radius of the sphere's
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
material, layer, speed and period only, not on the slice radius or load), sized for the middle
slice's load per unit length by the line rule of :mod:`jaxroll.grids`; the outer slices, which
carry narrower contacts, are therefore resolved more coarsely (their share of ``R_r`` is small;
the slice-count and resolution convergence is tested). The slices are solved together with
``jax.vmap``.

Contact solves (default ``linear_solver=Interval()``). The window operator is Toeplitz,
``C[i, j] = c[(i - j) mod N]``, and the slice contact set is one interval of cells, so the
contact block is the same leading block ``T_n`` wherever the interval lies, and the parabolic
profile on it is a combination of ``1, j, j^2``: one Levinson recursion per speed tabulates
``T_n^{-1} [1, j, j^2]`` for every ``n`` (:func:`toeplitz_nested_solve`,
:class:`IntervalOperator`), after which every penetration- or load-controlled slice solve of
every load at that speed is a primal-dual active-set iteration (the library's one loop,
:func:`jaxroll.contact.active_set_loop`) on the interval whose steps cost one table row and the
gaps next to the interval, no factorisation (:func:`solve_interval`; the full complementarity is
checked at the end). The :class:`jaxroll.contact.Dense` (LU) and :class:`jaxroll.contact.GMRES`
(FFT operator) solvers of :func:`jaxroll.contact.solve_contact` solve the same discrete problem in general form (agreement
to rounding is tested). :func:`rolling_resistance_grid` evaluates a speeds x loads grid (the
paper's reference case) with the compliance and tables built once per speed.

Derivatives. The scalar root finds (eqs. 7 and 11) are the library's safeguarded Newton
iteration (:func:`jaxroll._numerics.newton_root`) in ``log d_o``, so derivatives come from the
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

from .. import contact as _contact
from ..contact.linear import check_linear_solver
from .._numerics import newton_root
from .contact_size import estimate_contact_size
from .cylinder import kernel_builder as line_kernel_builder
from .direct import plane_strain_ratio
from ..grids import APPROXIMATION_LONG_WAVES, FixedGrid, loss_beyond_calibration
from .layer import Layer
from ..materials.material import StandardLinearSolid, storage_modulus
from ..reference import hertz_sphere
from ..result import RESULTS, RollingResult, first_failure, full_model_result, merge_results

__all__ = [
    "Interval",
    "ALGORITHMS",
    "IntervalOperator",
    "LINEAR_SOLVERS",
    "SliceSolution",
    "interval_operator",
    "middle_slice_load",
    "prepare",
    "rolling_resistance",
    "rolling_resistance_grid",
    "solve",
    "solve_interval",
    "toeplitz_nested_solve",
]

#: The three algorithms of [ZG] sec. 3.
ALGORITHMS = ("PD", "PP", "SP")


class Interval(eqx.Module):
    """The slices' default contact solver: the active set on one contact interval with the
    Levinson tables of :class:`IntervalOperator` (:func:`solve_interval`), no factorisation. The
    alternatives are the general solvers :class:`jaxroll.contact.Dense` and
    :class:`jaxroll.contact.GMRES` in :func:`jaxroll.contact.solve_contact` (the same discrete
    problem; agreement to the solver tolerance)."""


#: Contact solvers of the slices: Levinson tables on the contact interval (fastest), LU or GMRES
#: in :func:`jaxroll.contact.solve_contact`.
LINEAR_SOLVERS = (Interval, _contact.Dense, _contact.GMRES)
#: Alias images per side of the slices' 1D periodic kernel (plus the analytic tail).
IMAGES = 4


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
        result: :data:`jaxroll.result.RESULTS` code: the worst contact result of the slices,
            else ``root_find_failed`` if a root find did not converge.
        iterations: Newton iterations of the root finds (core + SP).
        residual: final residual of the last root find.
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
    result: jax.Array
    iterations: jax.Array
    residual: jax.Array


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
        matrix: dense window matrix ``(W, W)`` [m/Pa]
            (:meth:`jaxroll.contact.WindowedCompliance.dense`).
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


def toeplitz_nested_solve(offsets, rhs):
    """Solutions of ``T_n x_n = rhs[:n]`` for every leading block ``T_n`` (``n = 1 .. W``) of
    the Toeplitz matrix ``T[i, j] = t_{i-j}`` with ``t_k = offsets[k + W - 1]``
    (``offsets`` of shape ``(2 W - 1,)``, non-symmetric allowed), by the Levinson recursion
    (forward/backward vectors), ``O(W^2)`` per right-hand side.

    Requires non-singular leading blocks (true for a dissipative compliance, whose symmetric part
    is positive definite). A direct method: differentiable by ordinary autodiff (exact).

    Args:
        offsets: ``(2 W - 1,)`` Toeplitz coefficients; rhs: ``(W, m)``.

    Returns:
        ``(W, W, m)``; entry ``[n - 1, :n]`` is ``x_n``, the rest zero.
    """
    W = (offsets.shape[0] + 1) // 2
    idx = np.arange(W)

    def t(k):  # t_k, clipped where the entry is never used
        return offsets[np.clip(np.asarray(k) + W - 1, 0, 2 * W - 2)]

    t_up = t(-1 - idx)  # T[0, j + 1] = t_{-1-j} (j <= W - 2 used)
    t0 = t(0)
    f0 = jnp.zeros(W, offsets.dtype).at[0].set(1.0 / t0)
    x0 = jnp.zeros((W, rhs.shape[1]), offsets.dtype).at[0].set(rhs[0] / t0)

    def step(carry, n):  # sizes n -> n + 1
        f, b, xs = carry
        t_row = offsets[jnp.clip(n - idx + W - 1, 0, 2 * W - 2)]  # T[n, j] = t_{n-j}
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
    c = compliance.offsets
    s = np.arange(1, int(band_cells) + 1)[:, None]
    jj = np.arange(W)[None, :]
    # entries with an offset beyond the window are never used (their cells lie outside it)
    band_left = c[np.clip(W - 1 - s - jj, 0, 2 * W - 2)]  # c_{-s-j}
    band_right = c[np.clip(W - 1 + s + jj, 0, 2 * W - 2)]  # c_{s+j}
    j = jnp.arange(W, dtype=float)
    rhs = jnp.stack([jnp.ones(W), j, j * j], axis=1)
    tables = toeplitz_nested_solve(c, rhs)
    return IntervalOperator(tables=tables, matrix=compliance.dense(), band_left=band_left,
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

    The library's primal-dual active-set iteration (:func:`jaxroll.contact.active_set_loop`: new
    set = contact cells with ``p > 0`` plus free cells with ``g < 0``), with the set replaced by its hull
    ``[l, l + n)``; each iteration costs one table row and the gaps on the operator's
    ``band_cells`` cells either side of the interval (``O(band_cells W)``), no factorisation.
    On convergence the full complementarity is checked once (one dense matvec): a set that is
    not one interval, or a negative gap anywhere outside it, gives ``RESULTS.max_steps_reached``. The returned
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
        ``(pressure [Pa], penetration [m], result, iterations, (l, n))``; ``result`` a
        :data:`jaxroll.result.RESULTS` code (``successful``; ``max_steps_reached``: not
        converged or not an interval; ``window_too_small``; ``nonfinite``).
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

    def step(interval, aux):
        l, n = interval
        new, q = evaluate(l, n)
        ln, nn = hull(new, empty_n)
        return (ln, nn), (q, jnp.all(new == ((idx >= ln) & (idx < ln + nn))))

    (l, n), (_, contiguous), iters, done = _contact.active_set_loop(
        step, (jnp.asarray(l0), jnp.asarray(n0)), (jnp.zeros(W), jnp.asarray(True)), max_steps)
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
    result = first_failure((~finite, RESULTS.nonfinite), (edge, RESULTS.window_too_small),
                           (~(done & contiguous), RESULTS.max_steps_reached))
    return p, d, result, iters, (l, n)




# ---------------------------------------------------------------------------------------------
# Per-speed preparation and the algorithms
# ---------------------------------------------------------------------------------------------


def middle_slice_load(material, layer, R, P):
    """Estimated load per unit length [N/m] of the middle slice, [ZG] eq. 6 with the relaxed
    Hertz radius (eq. 8 at ``omega = 0``): the load the slices' grid is sized for."""
    r_h0 = hertz_sphere(P, R, material.relaxed_modulus(), layer.nu).contact_radius
    return 3.0 * P / (4.0 * r_h0)


class _Prepared(eqx.Module):
    """Per-speed data shared by all slices and loads: the window kernel, interval tables, grid."""

    kernel: _contact.WindowKernel
    op: IntervalOperator | None
    x: jax.Array
    dx: jax.Array
    period: jax.Array | None


def prepare(material, layer, V, grid: FixedGrid, linear_solver=Interval()) -> _Prepared:
    """Everything the slices of one speed ``V`` [m/s] share (built once per speed)."""
    if grid.window % 2:
        raise ValueError(f"the slices' window must hold an even number of cells; got {grid.window}")
    kernel = line_kernel_builder(material, layer, grid, images=IMAGES)(V)
    W, dx = grid.window, grid.spacing
    x = (jnp.arange(W, dtype=float) - 0.5 * (W - 1)) * dx
    op = interval_operator(kernel.compliance, x, dx) if isinstance(linear_solver, Interval) else None
    return _Prepared(kernel=kernel, op=op, x=x, dx=dx, period=None if grid.period is None else grid.period[0])


class _Slicer(eqx.Module):
    """The 2D contact solves of one sphere's slices on prepared per-speed data (never raise)."""

    prep: _Prepared
    linear_solver: object = eqx.field(static=True)
    tol: float = eqx.field(static=True)
    max_steps: int = eqx.field(static=True)

    def pressed(self, Rc, d, check=True):
        """Pressure [Pa] and result code of a slice of radius ``Rc`` pressed to penetration ``d``."""
        if isinstance(self.linear_solver, Interval):
            p, _, st, _, _ = solve_interval(self.prep.op, Rc, d, mode="penetration", max_steps=self.max_steps,
                                            check=check)
            return p, st
        x = self.prep.x
        pos = d > 0.0
        d_safe = jnp.where(pos, d, 1.0)  # double-where: d <= 0 carries nothing
        s = _contact.solve_contact(self.prep.kernel.compliance, x * x / (2.0 * Rc), penetration=d_safe, tol=self.tol,
                                   max_steps=self.max_steps, linear_solver=self.linear_solver)
        return jnp.where(pos, s.pressure, 0.0), jnp.where(pos, s.result, RESULTS.successful)

    def loaded(self, Rc, P, material, layer):
        """Pressure, result code and penetration of a slice of radius ``Rc`` under load ``P``
        [N/m]; the initial contact set is the slice's stationary 2D half-width (as the cylinder)."""
        x, dx = self.prep.x, self.prep.dx
        a = estimate_contact_size(material, layer, Rc, P, "cylinder")
        init = jnp.abs(x) < jnp.maximum(a, dx)
        if isinstance(self.linear_solver, Interval):
            p, d, st, _, _ = solve_interval(self.prep.op, Rc, P, mode="load", initial=(jnp.argmax(init),
                                            jnp.sum(init.astype(int))), max_steps=self.max_steps)
            return p, st, d
        s = _contact.solve_contact(self.prep.kernel.compliance, x * x / (2.0 * Rc), P, dx, initial_contact=init,
                                   tol=self.tol, max_steps=self.max_steps, linear_solver=self.linear_solver)
        return s.pressure, s.result, s.penetration

    def outputs(self, Rc, p):
        """Load [N/m], moment-form and dissipation-form R_r [N/m] of one slice."""
        x, dx = self.prep.x, self.prep.dx
        return jnp.sum(p) * dx, jnp.sum(p * x) * dx / Rc, self.prep.kernel.resistance(p, dx)


def _log_ratio(value, target):
    """``log(value/target)`` for a positive value, a large negative number otherwise (the root
    finds' residual: a slice that carries nothing is far too shallow)."""
    pos = value > 0.0
    return jnp.where(pos, jnp.log(jnp.where(pos, value, 1.0) / target), -1e3)


def _slice_geometry(R, d_o, n_slices, k):
    """Eq. 2 and eq. 9: contact radius ``r_c``, slice width ``dy``, slice positions ``y``,
    slice radii ``Rc`` and penetrations ``d_c`` for the middle penetration ``d_o``."""
    r_c = jnp.sqrt(d_o * (2.0 * R - d_o))
    dy = 2.0 * r_c / n_slices
    y = k * dy
    Rc = jnp.sqrt(R * R - y * y)
    return r_c, dy, y, Rc, d_o - R + Rc


def _middle_penetration(slicer, material, layer, R, P, V, *, algorithm, n_slices, k, weights, root_tol,
                        root_max_steps):
    """The middle slice's penetration ``d_o``: eq. 7 on the middle slice (eqs. 6-8, the common
    core), then for SP the total load of all slices set to ``P``; with the root finds'
    iterations, last residual and convergence."""
    prep = slicer.prep
    omega = 2.0 * jnp.pi * V / prep.period if prep.period is not None else jnp.zeros_like(V)
    r_h = hertz_sphere(P, R, storage_modulus(material, omega), layer.nu).contact_radius  # eq. 8
    r_h = jnp.minimum(r_h, 0.5 * R)
    d_h = jax.lax.stop_gradient(R - jnp.sqrt(R * R - r_h * r_h))  # eq. 2 inverted

    def core_residual(y):  # unknown y = log(d_o / d_H)
        d_o = d_h * jnp.exp(y)
        p, _ = slicer.pressed(R, d_o, check=False)  # the final solves are checked
        return _log_ratio(jnp.sum(p) * prep.dx, 3.0 * P / (4.0 * jnp.sqrt(d_o * (2.0 * R - d_o))))  # eq. 6

    y_root, core = newton_root(core_residual, jnp.asarray(0.0), tol=root_tol, max_steps=root_max_steps, max_step=1.0)
    iterations, residual, converged = core.iterations, core.residual, core.converged
    if algorithm == "SP":
        def total_load_residual(yy):
            _, dy, _, Rc, d_c = _slice_geometry(R, d_h * jnp.exp(yy), n_slices, k)
            p, _ = jax.vmap(lambda a, b: slicer.pressed(a, b, check=False))(Rc, d_c)
            return _log_ratio(jnp.sum(weights * jnp.sum(p, axis=1)) * prep.dx * dy, P)

        y_root, sp = newton_root(total_load_residual, jax.lax.stop_gradient(y_root), tol=root_tol,
                                 max_steps=root_max_steps, max_step=1.0)
        iterations, residual, converged = iterations + sp.iterations, sp.residual, converged & sp.converged
    return d_h * jnp.exp(y_root), iterations, residual, converged


def _solve_case(prep: _Prepared, material, layer, R, P, V, *, algorithm, n_slices, linear_solver, tol=1e-10,
                max_steps=60, root_tol=1e-10, root_max_steps=40) -> SliceSolution:
    """One sphere (load ``P``, speed ``V``) on prepared per-speed data; never raises."""
    slicer = _Slicer(prep, linear_solver, tol, max_steps)
    m = (n_slices + 1) // 2
    k = jnp.arange(m, dtype=float)
    weights = jnp.where(k > 0, 2.0, 1.0)  # symmetry: slices +-y_k
    d_o, it_total, res_last, conv = _middle_penetration(
        slicer, material, layer, R, P, V, algorithm=algorithm, n_slices=n_slices, k=k, weights=weights,
        root_tol=root_tol, root_max_steps=root_max_steps)

    r_c, dy, y, Rc, d_c = _slice_geometry(R, d_o, n_slices, k)
    if algorithm == "PP":
        # eq. 10 integrated over each slice / dy: sums to P exactly
        r2 = r_c * r_c
        loads = 0.75 * P * (r2 - y * y - dy * dy / 12.0) / (r2 * r_c)
        p, st, pen = jax.vmap(lambda Rc_k, P_k: slicer.loaded(Rc_k, P_k, material, layer))(Rc, loads)
    else:
        p, st = jax.vmap(slicer.pressed)(Rc, d_c)
        pen = d_c
    Pc, Rr, Rr_d = jax.vmap(slicer.outputs)(Rc, p)
    result = merge_results(jnp.max(st), first_failure((~conv, RESULTS.root_find_failed)))
    x = prep.x
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
        result=result,
        iterations=it_total,
        residual=res_last,
    )




def check_options(algorithm, n_slices, linear_solver):
    """Validate the static options of a slice algorithm; returns ``n_slices`` as an int."""
    check_linear_solver(linear_solver, LINEAR_SOLVERS)
    if algorithm not in ALGORITHMS:
        raise ValueError(f"algorithm must be one of {ALGORITHMS}; got {algorithm!r}")
    if isinstance(n_slices, bool) or not isinstance(n_slices, (int, np.integer)) or n_slices < 1 or n_slices % 2 == 0:
        raise ValueError(f"n_slices must be a positive odd integer; got {n_slices!r}")
    return int(n_slices)


def solve(material, layer: Layer, R, P, V, grid: FixedGrid, *, algorithm="SP", n_slices=21, tol=1e-10,
          max_steps=60, root_tol=1e-10, root_max_steps=40, linear_solver=Interval()) -> SliceSolution:
    """Solve a slice algorithm of [ZG] sec. 3 (PD eq. 9, PP eq. 10, SP eq. 11) for a rigid sphere
    (radius ``R`` [m], load ``P`` [N], speed ``V`` [m/s]) on the 1D ``grid`` shared by its
    ``n_slices`` (odd; paper 21) plane-strain slices. ``tol``: contact tolerance (GMRES only);
    ``max_steps``: active-set iteration limit; ``root_tol``, ``root_max_steps``: tolerance on
    ``log d_o`` and iteration limit of the root finds; ``linear_solver``: :class:`Interval`
    (default; :func:`solve_interval`), :class:`jaxroll.contact.Dense` or
    :class:`jaxroll.contact.GMRES` (all solve the same discrete problem). Never raises: see ``result``."""
    n_slices = check_options(algorithm, n_slices, linear_solver)
    return _solve_case(prepare(material, layer, V, grid, linear_solver), material, layer, R, P, V,
                       algorithm=algorithm, n_slices=n_slices, linear_solver=linear_solver, tol=tol,
                       max_steps=max_steps, root_tol=root_tol, root_max_steps=root_max_steps)


#: Calibration of :func:`approximation_error` (see its docstring for the data): weights of the
#: plane-strain excess and of the load defect, and the margin.
SPEED_WEIGHT, LOAD_WEIGHT, SLICE_MARGIN = 0.8, 1.0, 0.03


def approximation_parts(s: SliceSolution, material, layer, R, P, V, n_slices, size=None):
    """``(plane_strain, load)``: the two error sources of :func:`approximation_error` [-];
    ``size``: the stationary contact radius [m] if the caller has it (else estimated here)."""
    # the same contact at low speed: a standard linear solid with the modulus of the rolling
    # frequency (the dynamic contact radius) at V tau/r = 1e-3, where every material's loss is
    # linear in the frequency, so the ratio depends on the shapes only
    r = estimate_contact_size(material, layer, R, P, "sphere") if size is None else size
    G = storage_modulus(material, V / r)
    slow = StandardLinearSolid(G, 1.0, 0.1)
    now = plane_strain_ratio(material, layer, R, P, V, n_slices)
    low = plane_strain_ratio(slow, layer, R, P, 1e-3 * r, n_slices, modulus=G)
    return now / low - 1.0, s.load / P - 1.0


def approximation_error(s: SliceSolution, material, layer, R, P, V, n_slices):
    """Estimated relative error ``|R_r / R_r,full - 1|`` [-] of a slice algorithm against the full
    3D model, from its solution and the stationary pressures of the direct method (no 3D solve).

    * **Plane strain.** A slice dissipates in the plane-strain compliance ``T(|q_x|)``, the sphere
      in ``T(|q|)``, ``|q| >= |q_y| ~ 1/r``. The slice solves make the two agree at low speed
      (the slices are within a few % there), but waves longer than the contact carry a growing
      share of the loss at high speed: the slices are high on thick layers and half-spaces
      (``~ ln(V tau/r)``: +90 % at ``V tau/r = 50``, +180 % at 500) and low on thin ones. The
      estimate is the change of :func:`jaxroll.engines.direct.plane_strain_ratio` (the stationary
      pressure's slice-over-sphere ratio) from low speed to ``V`` at the same contact size,
      weighted by :data:`SPEED_WEIGHT` (0.8: the solved slice contacts follow the long-wave
      compliance part of the way; the measured errors are 0.4-0.9 times the change).
    * **Load.** PD (eq. 9) does not carry ``P``: its total load ``sum p_c dy`` misses ``P`` on
      intermediate layers by up to ~20 %, and ``R_r`` scales about linearly with the load
      (:data:`LOAD_WEIGHT`). Zero for PP and SP.
    * a margin :data:`SLICE_MARGIN`.

    The two parts add with their signs (the plane-strain part and the load defect both scale
    ``R_r``); their sum correlates with the measured error at 0.95 (SP) and 0.97 (PD) over the
    calibration set below. ``inf`` where the loss factor over the frequencies of the stationary
    contact size ``r``, ``V/(10 r) .. 10 V/r`` (:data:`jaxroll.grids.APPROXIMATION_LONG_WAVES`),
    exceeds the calibration's (:func:`jaxroll.grids.loss_beyond_calibration`, as for the direct
    method).

    Calibrated on the full 3D model with its default grid (``benchmarks/approx_validity.py
    errors``: standard linear solids G0 = 3 MPa, tau = 0.25 s, f = 0.1..10 on a half-space and
    H = 0.2 m..2 mm, R = 2 cm, 30 and 100 N, and the shipped measured Prony material at
    -25..75 degC, V = 1e-4..10 m/s). Not differentiated: it decides validity only.
    """
    r = jax.lax.stop_gradient(estimate_contact_size(material, layer, R, P, "sphere"))
    plane_strain, load = jax.lax.stop_gradient(approximation_parts(s, material, layer, R, P, V, n_slices, size=r))
    estimate = jnp.abs(SPEED_WEIGHT * plane_strain + LOAD_WEIGHT * load) + SLICE_MARGIN
    # beyond the calibration's loss factor over the frequencies of the stationary contact size (the
    # direct method's rule): not valid. SLS G0 = 2.89 MPa, tau = 14.9 ms, f = 33.8 on a 7 mm layer
    # (R = 2 cm, 17.5 N): SP +16.3 % at 2.47 m/s where the estimate said 6.6 %, PD +12.6 % at 1 m/s
    # where it said 3.6 % (benchmarks/LOG.md, 2026-11-29)
    return jnp.where(loss_beyond_calibration(material, V, r, r, below=APPROXIMATION_LONG_WAVES), jnp.inf, estimate)


def _result(s: SliceSolution, grid: FixedGrid, material, layer, R, P, V, n_slices) -> RollingResult:
    a_est = estimate_contact_size(material, layer, R, middle_slice_load(material, layer, R, P), "cylinder")
    ok = grid.period_ok(a_est, V * material.longest_time(), 1)
    res = full_model_result(
        s.resistance, s.resistance_dissipation, s.contact_radius, layer.H,
        result=merge_results(s.result, first_failure((~ok, RESULTS.period_too_short))),
        penetration=s.middle_penetration, pressure=s.pressure, grid=(s.x, s.y),
        iterations=s.iterations, residual=s.residual,
    )
    approx = approximation_error(s, material, layer, R, P, V, n_slices)
    return eqx.tree_at(lambda r: r.approximation, res, approx, is_leaf=lambda x: x is None)


def rolling_resistance(material, layer: Layer, R, P, V, grid: FixedGrid, **options) -> RollingResult:
    """Rolling resistance [N] of a rigid sphere from 2D cylinder slices ([ZG] sec. 3),
    ``R_r = sum_k R_r,c(y_k) dy``; ``options`` as :func:`solve`.

    Returns:
        :class:`jaxroll.result.RollingResult` with ``regime = 4`` ("full": built on the full 2D
        contact model), ``contact_radius`` = ``r_c`` of eq. 2, ``penetration`` = ``d_o`` (middle
        slice), ``truncation`` = relative difference of the moment and dissipation forms (a
        discretisation-error estimate), ``pressure`` = slice pressures ``(m, W)`` on
        ``grid = (x, y_k)``, ``result``, ``iterations`` (Newton), ``residual`` (root find),
        ``approximation`` = the estimated error against the full 3D model
        (:func:`approximation_error`).
    """
    n_slices = options.get("n_slices", 21)
    return _result(solve(material, layer, R, P, V, grid, **options), grid, material, layer, R, P, V, n_slices)


def rolling_resistance_grid(material, layer: Layer, R, loads, speeds, grid: FixedGrid, *, algorithm="SP",
                            n_slices=21, linear_solver=Interval(), **options) -> RollingResult:
    """Slice-algorithm ``R_r`` [N] on ``speeds x loads`` (fields ``(n_speeds, n_loads)``), each
    point equal to :func:`rolling_resistance` on ``grid``. The compliance and the Levinson tables
    depend on the speed only: built once per speed (``lax.map``) and shared by all slices of all
    loads of that speed (``vmap`` over loads)."""
    n_slices = check_options(algorithm, n_slices, linear_solver)

    def one_speed(V):
        prep = prepare(material, layer, V, grid, linear_solver)

        def one_load(P):
            s = _solve_case(prep, material, layer, R, P, V, algorithm=algorithm, n_slices=n_slices,
                            linear_solver=linear_solver, **options)
            return _result(s, grid, material, layer, R, P, V, n_slices)

        return jax.vmap(one_load)(loads)

    return jax.lax.map(one_speed, speeds)
