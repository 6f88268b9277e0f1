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
``jax.vmap``. The penetration-controlled 2D problem (find ``p >= 0`` with
``g = h - d + C p >= 0``, ``p g = 0`` at fixed ``d``) is solved here with the same primal-dual
active-set / GMRES scheme as :func:`jaxroll.contact.solve_contact`, on its public
:class:`~jaxroll.contact.WindowedCompliance`; the load-controlled PP slices call
:func:`jaxroll.contact.solve_contact` itself. The scalar root finds (eqs. 7 and 11) are a
bracketed, safeguarded Newton iteration in ``log d_o`` inside :func:`jax.lax.custom_root`, so
derivatives come from the implicit function theorem (never from unrolling), and the contact
solves are differentiated implicitly as well.
"""

from __future__ import annotations


import equinox as eqx
import jax
import jax.numpy as jnp
from jax.scipy.sparse.linalg import gmres

from . import contact as _contact
from ._numerics import roller_inputs
from .cylinder import line_grid
from .layer import Layer, surface_compliance
from .material import relaxed_modulus, storage_modulus
from .result import RollingResult, full_model_result

__all__ = [
    "ALGORITHMS",
    "SliceSolution",
    "dense_window_matrix",
    "rolling_resistance_slices",
    "slice_result",
    "solve_dense",
    "solve_penetration",
    "solve_slices",
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


class _PenetrationSolution(eqx.Module):
    pressure: jax.Array
    contact: jax.Array
    status: jax.Array
    iterations: jax.Array


def solve_penetration(compliance, profile, penetration, *, tol=1e-10, max_steps=50,
                      linear_restart=80, linear_maxiter=20):
    """Frictionless rolling contact at a prescribed rigid-body penetration (any dimension).

    Find ``p >= 0`` [Pa] with ``g = h - d + C p >= 0`` and ``p g = 0`` for a fixed ``d`` [m]
    (the load follows as ``sum(p) dA``): the penetration-controlled twin of
    :func:`jaxroll.contact.solve_contact`, same primal-dual active-set method (semismooth
    Newton on ``min(p, g) = 0``, GMRES on the FFT-applied operator of the contact set), started
    from the geometric overlap ``{h < d}``. The pressure comes out of
    :func:`jax.lax.custom_linear_solve` on the converged contact set, so it is differentiable
    (implicit function theorem) w.r.t. the compliance, ``h`` and ``d``. ``d <= 0`` gives
    ``p = 0``.

    Returns a small module with ``pressure``, ``contact``, ``status`` (codes of
    :data:`jaxroll.contact.CONTACT_STATUS`, 0 = converged) and ``iterations``.
    """
    sg = jax.lax.stop_gradient
    h = jnp.asarray(profile, dtype=float)
    d = jnp.asarray(penetration, dtype=float)
    shape = compliance.shape
    c0 = sg(jnp.abs(compliance.self_compliance))
    g_s = sg(jnp.maximum(jnp.abs(d), 1e-300))

    def make_matvec(C, mask):
        maskf = mask.astype(float)

        def matvec(pt):
            return maskf * C(maskf * pt) / c0 + (1.0 - maskf) * pt

        return matvec

    def rhs(hh, dd, mask):
        return mask.astype(float) * (dd - hh) / g_s

    def lin_solve(mv, b, x0):
        x, _ = gmres(mv, b, x0=x0, tol=tol * 1e-3, atol=0.0, restart=linear_restart,
                     maxiter=linear_maxiter, solve_method="incremental")
        return x

    C_ng = jax.tree_util.tree_map(sg, compliance)
    h_ng, d_ng = sg(h), sg(d)
    mask0 = h_ng < d_ng
    eps = 1e-12

    def body(state):
        mask, x, it, _ = state
        x = lin_solve(make_matvec(C_ng, mask), rhs(h_ng, d_ng, mask), x)
        gt = (h_ng - d_ng) / g_s + C_ng(x) / c0
        new = jnp.where(mask, x > -eps, gt < -eps)
        done = jnp.all(new == mask) | ~jnp.all(jnp.isfinite(x))
        new = jnp.where(done, mask, new)
        return new, x, it + 1, done

    def cond(state):
        return (~state[3]) & (state[2] < max_steps)

    mask, x_ng, iters, done = jax.lax.while_loop(
        cond, body, (mask0, mask0.astype(float), jnp.asarray(0), jnp.asarray(False))
    )
    mask, x_ng = sg(mask), sg(x_ng)
    x = jax.lax.custom_linear_solve(
        make_matvec(compliance, mask),
        rhs(h, d, mask),
        solve=lambda f, b: lin_solve(f, b, x_ng),
        transpose_solve=lambda f, b: lin_solve(f, b, None),
    )
    p = x * (g_s / c0)
    finite = jnp.all(jnp.isfinite(p))
    edge = jnp.zeros(shape, bool).at[0].set(True).at[-1].set(True)
    status = jnp.where(~finite, 4, jnp.where(jnp.any(mask & edge), 3, jnp.where(done, 0, 1)))
    return _PenetrationSolution(pressure=p, contact=mask, status=status, iterations=iters)


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
    max_steps: int = 50,
    root_tol: float = 1e-10,
    root_max_steps: int = 40,
    linear_solver: str = "gmres",
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
        linear_solver: static, ``"gmres"`` (default; matrix-free FFT operator:
            :func:`solve_penetration` and :func:`jaxroll.contact.solve_contact`) or ``"dense"``
            (LU on the dense window matrix, :func:`solve_dense`; exact to rounding, fast only
            when BLAS is not oversubscribed: set ``OMP_NUM_THREADS=1`` on shared machines).
        window_cells: static even number of window cells, overriding the automatic window
            (needed with a fixed ``period`` under ``jit``/``vmap``, where the automatic window
            is the whole period).
        root_tol, root_max_steps: tolerance on ``log d_o`` and iteration limit of the root finds.
        throw: raise (``eqx.error_if``) on failure; otherwise report it in ``status``.

    Returns:
        :class:`SliceSolution`.
    """
    if linear_solver not in ("dense", "gmres"):
        raise ValueError(f"linear_solver must be 'dense' or 'gmres'; got {linear_solver!r}")
    if algorithm not in ALGORITHMS:
        raise ValueError(f"algorithm must be one of {ALGORITHMS}; got {algorithm!r}")
    n_slices = int(n_slices)
    if n_slices < 1 or n_slices % 2 == 0:
        raise ValueError(f"n_slices must be a positive odd integer; got {n_slices}")
    R, P, V = roller_inputs(radius, load, speed)

    dx, L, N, W, period_ok = _grid(material, layer, R, P, V, period, n_cells, cells_per_radius,
                                   window, period_factor)
    if window_cells is not None:
        W = int(window_cells)
        if W % 2 or not 2 <= W <= N:
            raise ValueError(f"window_cells must be even and in [2, n_cells = {N}]; got {W}")

    def T(q):
        return surface_compliance(layer, material, q, 0.0, V)

    K, K2 = _contact.periodic_kernel(T, (L,), (N,), images=images, dissipation=True)
    C = _contact.windowed_compliance(K, (N,), (W,))
    Cd = dense_window_matrix(C) if linear_solver == "dense" else None
    x = (jnp.arange(W, dtype=float) - 0.5 * (W - 1)) * dx
    m = (n_slices + 1) // 2
    k = jnp.arange(m, dtype=float)
    weights = jnp.where(k > 0, 2.0, 1.0)  # symmetry: slices +-y_k

    def contact_radius(d_o):  # eq. 2
        return jnp.sqrt(d_o * (2.0 * R - d_o))

    def pen_slice(Rc, d):
        """Load per unit length [N/m], R_r per unit length (moment, dissipation), p, status."""
        pos = d > 0.0
        d_safe = jnp.where(pos, d, 1.0)  # double-where: d <= 0 carries nothing
        hh = x * x / (2.0 * Rc)
        if linear_solver == "dense":
            p, _, st, _ = solve_dense(Cd, hh, d_safe, dx, mode="penetration", max_steps=max_steps)
        else:
            s = solve_penetration(C, hh, d_safe, tol=tol, max_steps=max_steps)
            p, st = s.pressure, s.status
        return jnp.where(pos, p, 0.0), jnp.where(pos, st, 0)

    def slice_outputs(Rc, p):
        Pc = jnp.sum(p) * dx
        Rr = jnp.sum(p * x) * dx / Rc
        Rr_d = _contact.dissipation_resistance(K2, p, (N,), (L,))
        return Pc, Rr, Rr_d

    def middle_load(d_o):
        p, _ = pen_slice(R, d_o)
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
            p, _ = jax.vmap(pen_slice)(Rc, d_c)
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
            if linear_solver == "dense":
                p_k, d_k, st_k, _ = solve_dense(Cd, hh, P_k, dx, mode="load", initial_contact=init,
                                                max_steps=max_steps)
                return p_k, st_k, d_k
            s = _contact.solve_contact(C, hh, P_k, dx, initial_contact=init, tol=tol,
                                       max_steps=max_steps, throw=False)
            return s.pressure, s.status, s.penetration

        p, st, pen = jax.vmap(load_slice)(Rc, loads)
    else:
        p, st = jax.vmap(pen_slice)(Rc, d_c)
        pen = d_c
    Pc, Rr, Rr_d = jax.vmap(slice_outputs)(Rc, p)
    status = jnp.max(st)
    status = jnp.where(conv, status, jnp.maximum(status, 5))
    if throw:
        Rr = eqx.error_if(Rr, status != 0,
                          "slice algorithm failed: a contact solve or the root find did not converge "
                          "(status codes: jaxroll.contact.CONTACT_STATUS, 5 = root find)")
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
