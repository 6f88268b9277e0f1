r"""Full 3D model of a rigid sphere rolling on a viscoelastic layer (the reference of [ZG] sec. 2).

The steady rolling contact of a rigid sphere (profile ``h = (x^2 + y^2)/(2R)``, travelling toward
+x) on a layer bonded to a rigid base, frictionless, solved on a periodic ``Lx x Ly`` surface
by :mod:`jaxroll.contact` (primal-dual active set, GMRES on the windowed FFT operator, implicit
differentiation). The pressure is piecewise constant on square cells of side ``a`` (the
paper's "load patches"); the displacement is collocated at the cell centres. The compliance is
the 3D ``T_mn = T(q_x, q_y)`` of :func:`jaxroll.layer.surface_compliance` (inertia and the
mode-modulus sign fix included) times the load-patch transform
``S = sinc(q_x a/2) sinc(q_y a/2)``, folded (aliased) onto the period grid (see the module
docstring of :mod:`jaxroll.contact`, eq. (1)) and applied by FFT: the dense compliance matrix of
[ZG] sec. 2 is never formed.

Fourier modes ``q = 2 pi (m_x/Lx, m_y/Ly)`` are kept for ``|m_x|, |m_y| <= n_terms``
("500 terms" of the paper = ``n_terms=500``). Default: ``n_terms`` = the number of cells per
period (the alias series is alternating in the image index, so its truncation error falls fast;
see the convergence table in ``tests/test_sphere3d.py``).

Rolling resistance, two ways (DESIGN section 2):

* pressure moment ``R_r = (1/R) sum p x dA`` (the reported ``value``);
* dissipation ``R_r = -int p du/dx dA``, exact for the piecewise-constant pressure
  (:func:`jaxroll.contact.dissipation_resistance`; the discrete [ZG] eq. 26 with the solved
  pressure). Both agree up to the discretisation error (the collocated gap vanishes only at
  cell centres, and the contact edge cuts cells): measured order 1.5-2.5 in the cell size, 1-2 %
  at 6-9 cells per contact radius (the paper's a = 0.25 mm at P = 10 N), 0.1 % at 32 (see
  ``test_moment_vs_dissipation_converges``); their relative difference is returned as
  ``truncation``.

Quasi-static layers (``rho = 0``) use the exact factorisation ``T = T_1(|q|)/G_m(q_x V)``
(``T_1`` = compliance at unit modulus): the layer closed form is evaluated once per grid (it
is speed independent) and only ``G*`` per speed, which is what makes the reference sweep
(:func:`rolling_resistance_sweep`) cheap.

Deviation from paper: none in the model; the mode modulus is ``conj(G*(q_x V))`` (inside
:func:`jaxroll.layer.surface_compliance`) and eq. 19's cases are swapped (DESIGN section 2).

Item 2 of the issue, the *direct method with the exact stationary pressure*:
:func:`static_pressure` solves the elastic (relaxed, ``V = 0``) contact on the same grid and
:func:`direct_elastic_rolling_resistance` evaluates the dissipation of that fixed pressure
under the rolling compliance (the periodic [ZG] eq. 26 with the grid pressure's exact
transform), which covers intermediate layer thickness where neither the Hertz/Jaffar nor the
thin-layer pressure shape applies ([ZG] footnote 4).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import contact as _contact
from ._numerics import as_float, roller_inputs, where_safe
from .layer import Layer, is_quasistatic, static_compliance, surface_compliance
from .material import complex_modulus, glassy_modulus, relaxed_modulus
from .pressure import contact_radius as _model_radius
from .result import RollingResult, full_model_result

__all__ = [
    "SphereSolution",
    "StaticContact",
    "solve_sphere",
    "rolling_resistance_full",
    "rolling_resistance_sweep",
    "static_pressure",
    "direct_elastic_rolling_resistance",
    "sphere_kernel",
    "estimate_contact_radius",
]

#: Cells per estimated contact radius when the inputs are concrete (automatic resolution).
DEFAULT_CELLS_PER_RADIUS = 12
#: Period cells per axis when the inputs are traced and neither ``period`` nor ``n_cells`` is
#: given (``Lx = Ly = 512 a``: long enough for ``V tau <= 25 r_c`` at 12 cells per radius).
DEFAULT_TRACED_CELLS = 512
#: Cap on the automatic period cell count along x (the roller direction).
MAX_AUTO_CELLS = 2**13


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------


def _concrete(*xs):
    """Python floats of ``xs`` if all are concrete, else None."""
    try:
        return [float(np.asarray(x)) for x in xs]
    except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError, TypeError):
        return None


def _retardation_time(material):
    """Slowest material time [s] (``tau`` of a standard linear solid; the largest Prony time
    scaled by glassy/relaxed for a generalized Maxwell solid)."""
    if hasattr(material, "f") and hasattr(material, "tau"):
        return material.tau
    if hasattr(material, "tau"):
        return jnp.max(material.tau) * glassy_modulus(material) / relaxed_modulus(material)
    raise ValueError("cannot derive a relaxation time from this material; pass period= and spacing=")


def _next_pow2(n):
    return 1 << max(1, int(math.ceil(math.log2(max(n, 2)))))


def estimate_contact_radius(material, layer, radius, load):
    """Stationary contact radius estimate [m] used to choose the resolution.

    Jaffar's thick-layer law ([ZG] eqs. 32-35, Hertz on a half-space) with the relaxed modulus
    where it has a solution, else the thin-layer radius ([ZG] eq. 40, or the corrected eq. 45
    for ``nu < 0.5``).
    """
    H = as_float(layer.H)
    inf_H = jnp.isinf(H)
    r_k, exists = _model_radius(material, layer, radius, load, model="thick")
    layer_f = eqx.tree_at(lambda l: l.H, layer, where_safe(inf_H, 1.0, H))
    thin = "thin" if layer.nu >= 0.5 else "thin-compressible"
    r_t, _ = _model_radius(material, layer_f, radius, load, model=thin)
    return jnp.where(exists | inf_H, r_k, r_t)


# ---------------------------------------------------------------------------------------------
# compliance kernel on the period grid (modes |m_k| <= n_terms, folded onto the DFT bins)
# ---------------------------------------------------------------------------------------------


def _axis_modes(n, n_terms, last):
    """Integer modes ``m = r + l n`` of one axis, shape ``(bins, images)``, and their mask
    ``|m| <= n_terms`` (bins ``0..n-1``, or ``0..n/2`` for the last, rfft, axis)."""
    r = np.arange(n // 2 + 1) if last else np.arange(n)
    lo, hi = int(math.floor(-n_terms / n)) - 1, int(math.floor(n_terms / n)) + 1
    ls = np.arange(lo, hi + 1)
    m = r[:, None] + n * ls[None, :]
    keep = np.abs(m) <= n_terms
    used = np.any(keep, axis=0)
    return m[:, used].astype(float), keep[:, used]


def _mode_grid(n_cells, period, n_terms):
    """Wavenumbers ``q_x, q_y`` [rad/m] of shape ``(Nx, 1, Ix, 1)`` / ``(1, Ny/2+1, 1, Iy)``,
    and the truncated load-patch factor ``S`` (0 outside ``|m| <= n_terms``)."""
    (Nx, Ny), (Lx, Ly) = n_cells, period
    mx, kx = _axis_modes(Nx, n_terms, last=False)
    my, ky = _axis_modes(Ny, n_terms, last=True)
    Sx = np.where(kx, np.sinc(mx / Nx), 0.0)
    Sy = np.where(ky, np.sinc(my / Ny), 0.0)
    qx = (2.0 * jnp.pi / Lx) * mx[:, None, :, None]
    qy = (2.0 * jnp.pi / Ly) * my[None, :, None, :]
    S = Sx[:, None, :, None] * Sy[None, :, None, :]
    return qx, qy, S


class _LayerFactor(eqx.Module):
    """Speed-independent part of the kernel of a quasi-static layer (see :func:`sphere_kernel`):
    ``A = T_1 S`` and ``B = q_x T_1 S^2`` on the mode grid, and ``q_x`` per x-bin/image."""

    A: jax.Array
    B: jax.Array
    qx: jax.Array


def _layer_factor(layer, n_cells, period, n_terms):
    qx, qy, S = _mode_grid(n_cells, period, n_terms)
    q2 = qx * qx + qy * qy
    pos = q2 > 0
    q = jnp.where(pos, jnp.sqrt(where_safe(pos, q2, 1.0)), 0.0)
    t1 = static_compliance(layer, q)
    return _LayerFactor(A=t1 * S, B=qx * t1 * S * S, qx=qx[:, 0, :, 0])


def _kernel_from_factor(factor: _LayerFactor, material, V):
    """``(K, K2)`` from the quasi-static factorisation ``T = T_1 / conj(G*(q_x V))``."""
    inv_g = 1.0 / jnp.conj(complex_modulus(material, factor.qx * V))  # (Nx, Ix)
    re, im = jnp.real(inv_g), jnp.imag(inv_g)
    K = jax.lax.complex(jnp.einsum("rsab,ra->rs", factor.A, re), jnp.einsum("rsab,ra->rs", factor.A, im))
    K2 = jnp.einsum("rsab,ra->rs", factor.B, im)
    return K, K2


def sphere_kernel(material, layer, speed, n_cells, period, n_terms):
    """Fourier multipliers ``(K, K2)`` of the 3D periodic compliance on the cell grid.

    ``K_r = sum_{m = r mod N, |m_k| <= n_terms} T(q_m) S(q_m)`` [m/Pa] (cell-to-centre
    compliance, ``rfftn`` layout, x = axis 0) and ``K2_r = sum q_x Im T(q_m) S(q_m)^2``
    [m/Pa per m] (dissipation), with ``T`` the 3D ``T_mn`` of
    :func:`jaxroll.layer.surface_compliance` and ``S = sinc(q_x dx/2) sinc(q_y dy/2)`` the
    load-patch transform. Same convention as :func:`jaxroll.contact.periodic_kernel`, but with
    a symmetric truncation ``|m_k| <= n_terms`` (the paper's number of terms) and, for
    quasi-static layers, the factorisation ``T = T_1(q)/G_m``.

    Args:
        material, layer: material and :class:`jaxroll.layer.Layer`.
        speed: rolling speed ``V`` [m/s].
        n_cells: static ``(Nx, Ny)`` (``Ny`` even).
        period: ``(Lx, Ly)`` [m].
        n_terms: static mode cut-off per axis.
    """
    n_cells = tuple(int(n) for n in n_cells)
    if n_cells[1] % 2:
        raise ValueError(f"the y cell count must be even; got {n_cells[1]}")
    if is_quasistatic(layer):
        return _kernel_from_factor(_layer_factor(layer, n_cells, period, n_terms), material, speed)
    qx, qy, S = _mode_grid(n_cells, period, n_terms)
    T = surface_compliance(layer, material, qx, qy, speed)
    K = jnp.sum(T * S.astype(complex), axis=(2, 3))
    K2 = jnp.sum(qx * jnp.imag(T) * S * S, axis=(2, 3))
    return K, K2


# ---------------------------------------------------------------------------------------------
# resolution
# ---------------------------------------------------------------------------------------------


class _Resolution(eqx.Module):
    dx: jax.Array
    period: tuple
    n_cells: tuple = eqx.field(static=True)
    window: int = eqx.field(static=True)
    n_terms: int = eqx.field(static=True)
    period_ok: jax.Array


def _resolution(material, layer, R, P, V, *, period, spacing, n_cells, window, n_terms, cells_per_radius,
                window_factor, period_factor):
    r_est = estimate_contact_radius(material, layer, R, P)
    H = as_float(layer.H)
    c = V * _retardation_time(material)
    if cells_per_radius is None:
        cells_per_radius = DEFAULT_CELLS_PER_RADIUS
        vals = _concrete(r_est, H)
        if vals is not None and math.isfinite(vals[1]):
            # thin layers: the kernel is only ~H wide, so cells must resolve H (a <= H/2)
            cells_per_radius = max(cells_per_radius, int(math.ceil(2.0 * vals[0] / vals[1])))
    cpr = int(cells_per_radius)

    # --- cell size ---
    if spacing is not None:
        dx = spacing
    elif period is not None and n_cells is not None:
        dx = period[0] if np.ndim(period) else period
        dx = dx / int(n_cells if np.ndim(n_cells) == 0 else n_cells[0])
    else:
        dx = r_est / cpr
    dx_raw = dx
    dx = eqx.error_if(as_float(dx), ~(as_float(dx) > 0), "spacing must be positive")

    # --- period cells ---
    if period is not None:
        Lx, Ly = (period, period) if np.ndim(period) == 0 else tuple(period)
        if n_cells is None:
            vals = _concrete(Lx, Ly, dx_raw)
            if vals is None:
                raise ValueError("with traced period/spacing, pass n_cells (static)")
            Nx, Ny = (int(round(vals[0] / vals[2])), int(round(vals[1] / vals[2])))
        else:
            Nx, Ny = (int(n_cells), int(n_cells)) if np.ndim(n_cells) == 0 else tuple(int(n) for n in n_cells)
        Nx, Ny = Nx + Nx % 2, Ny + Ny % 2
        Lx, Ly = as_float(Lx), as_float(Ly)
        dx = Lx / Nx  # exact cell size of the period grid (square cells: Ly/Ny equal up to rounding)
        Ly = Ny * dx
    else:
        if n_cells is None:
            vals = _concrete(period_factor * jnp.maximum(r_est, c) / dx_raw, period_factor * r_est / dx_raw)
            if vals is None:
                Nx = Ny = DEFAULT_TRACED_CELLS
            else:
                Nx = min(_next_pow2(vals[0]), MAX_AUTO_CELLS)
                Ny = min(_next_pow2(vals[1]), MAX_AUTO_CELLS)
        else:
            Nx, Ny = (int(n_cells), int(n_cells)) if np.ndim(n_cells) == 0 else tuple(int(n) for n in n_cells)
        Lx, Ly = Nx * dx, Ny * dx

    # --- window ---
    if window is None:
        vals = _concrete(r_est / dx_raw)
        ratio = cpr if vals is None else vals[0]
        W = 2 * int(math.ceil(window_factor * ratio)) + 1
    else:
        W = int(window)
    Wmax = min(Nx, Ny)
    if W > Wmax:
        raise ValueError(f"the pressure window ({W} cells) is wider than the period ({Wmax} cells)")
    Nx, Ny = max(Nx, 2), max(Ny, 2)
    nt = max(Nx, Ny) if n_terms is None else int(n_terms)
    if nt < 1:
        raise ValueError("n_terms must be >= 1")
    ok = (Lx >= period_factor * jnp.maximum(r_est, c)) & (Ly >= period_factor * r_est)
    return _Resolution(dx=dx, period=(Lx, Ly), n_cells=(Nx, Ny), window=W, n_terms=nt, period_ok=ok), r_est


# ---------------------------------------------------------------------------------------------
# solve
# ---------------------------------------------------------------------------------------------


class SphereSolution(eqx.Module):
    """Full solution of the rolling sphere.

    Attributes:
        contact: :class:`jaxroll.contact.ContactSolution` on the ``W x W`` window (axis 0 = x,
            the rolling direction; axis 1 = y).
        x, y: cell-centre coordinates of the window [m] (sphere centre above ``(0, 0)``).
        dx: cell size ``a`` [m] (square cells).
        period: ``(Lx, Ly)`` [m].
        resistance: ``R_r`` from the pressure moment [N].
        resistance_dissipation: ``R_r`` from the dissipated power [N].
        contact_radius: equivalent radius of the contact set ``sqrt(area/pi)`` [m] (cell
            quantised: biased by ~ +0.17 a at 8-16 cells per radius).
        moment_radius: radius of the Hertz-form pressure ``p0 sqrt(1 - r^2/r_c^2)`` with the same
            second moment, ``sqrt(5/2 sum p r^2 / sum p)`` [m] (a smooth functional, O(a^2); the
            contact radius when the pressure keeps Hertz's form, [ZG] sec. 4.3).
        estimated_radius: stationary estimate (Hertz/Jaffar/thin) used for the resolution [m].
        period_ok: whether ``Lx >= period_factor max(r, V tau)`` and ``Ly >= period_factor r``.
    """

    contact: _contact.ContactSolution
    x: jax.Array
    y: jax.Array
    dx: jax.Array
    period: tuple
    resistance: jax.Array
    resistance_dissipation: jax.Array
    contact_radius: jax.Array
    moment_radius: jax.Array
    estimated_radius: jax.Array
    period_ok: jax.Array




def _solve_on(K, K2, res: _Resolution, R, P, r_init, *, tol, max_steps, throw, est, init=None, edge_smoothing=None):
    W = res.window
    dx = res.dx
    C = _contact.windowed_compliance(K, res.n_cells, (W, W))
    x = (jnp.arange(W, dtype=float) - 0.5 * (W - 1)) * dx
    X, Y = x[:, None], x[None, :]
    h = (X * X + Y * Y) / (2.0 * R)
    guess = (X * X + Y * Y) < r_init * r_init
    if init is not None:  # warm start: a previous contact set where there is one
        guess = jnp.where(jnp.any(init), init, guess)
    sol = _contact.solve_contact(
        C, h, P, dx * dx, initial_contact=guess, tol=tol, max_steps=max_steps,
        smoothing=_contact.edge_gap_scale(edge_smoothing, dx, est, R), throw=throw,
    )
    p = sol.pressure
    moment = jnp.sum(p * X) * dx * dx / R
    diss = _contact.dissipation_resistance(K2, p, res.n_cells, res.period)
    area = jnp.sum(sol.contact.astype(float)) * dx * dx
    cx = jnp.sum(p * X) / jnp.sum(p)  # centre of pressure (shifted forward when rolling)
    r2 = jnp.sum(p * ((X - cx) ** 2 + Y * Y)) / jnp.sum(p)
    return SphereSolution(
        contact=sol, x=x, y=x, dx=dx, period=res.period, resistance=moment, resistance_dissipation=diss,
        contact_radius=jnp.sqrt(area / jnp.pi), moment_radius=jnp.sqrt(2.5 * r2), estimated_radius=est,
        period_ok=res.period_ok,
    )


def solve_sphere(
    material,
    layer: Layer,
    radius,
    load,
    speed,
    *,
    period=None,
    spacing=None,
    n_cells=None,
    window: int | None = None,
    n_terms: int | None = None,
    cells_per_radius: int | None = None,
    window_factor: float = 1.25,
    period_factor: float = 20.0,
    tol: float = 1e-10,
    max_steps: int = 50,
    throw: bool = True,
    edge_smoothing: float | None = None,
) -> SphereSolution:
    """Solve the steady rolling contact of a rigid sphere on a viscoelastic layer (3D).

    Args:
        material: material of :mod:`jaxroll.material` (e.g. ``StandardLinearSolid(G0, tau, f)``).
        layer: :class:`jaxroll.layer.Layer` (``H = inf`` for a half-space; ``rho`` for inertia).
        radius: sphere radius ``R`` [m].
        load: normal load ``P`` [N], positive.
        speed: rolling speed ``V`` [m/s], ``>= 0``, toward +x.
        period: period ``L`` [m] (scalar: ``Lx = Ly``) or ``(Lx, Ly)``; the paper uses 0.2 m.
            Default: ``Lx >= period_factor max(r, V tau)``, ``Ly >= period_factor r`` (powers
            of two cells; x capped at ``MAX_AUTO_CELLS``).
        spacing: cell size ``a`` [m] (paper: 0.25 mm). Default ``r/cells_per_radius``
            (``r`` from :func:`estimate_contact_radius`).
        n_cells: static cells per period (int or ``(Nx, Ny)``); required when ``period`` or
            ``spacing`` are traced; default ``DEFAULT_TRACED_CELLS`` when traced without them.
        window: static number ``W`` of cells per side of the square pressure window centred
            under the sphere (paper: 41). Default ``2 ceil(window_factor r/a) + 1``.
        n_terms: static Fourier cut-off ``|m_x|, |m_y| <= n_terms`` (paper: 500). Default: the
            larger period cell count.
        cells_per_radius: static; default 12 (and ``a <= H/2`` on thin layers).
        window_factor, period_factor: see above.
        tol, max_steps, throw: solver options of :func:`jaxroll.contact.solve_contact`.
        edge_smoothing: ``None`` (default: exact discrete complementarity) or ``kappa > 0``:
            smoothed contact edge (``smoothing`` of :func:`jaxroll.contact.solve_contact`) with
            the gap scale ``eps = kappa a^{3/2} r^{1/2} / R`` (``a`` = cell size, ``r`` = the
            estimated contact radius: the Hertz gap one cell outside the edge, up to an O(1)
            factor). With it ``R_r`` is a smooth function of every parameter instead of
            jumping in slope each time a cell joins the contact: use it for least-squares
            fits (fitting/README.md). Measured at the paper's resolution (R = 2 cm, 30 mm
            layer, 80-150 N, V = 1e-3 / 1e-2 / 1e-1 m/s), rms wiggle of ``log R_r(P)``:
            exact 1.8e-3 / 1.7e-4 / 5.1e-4; ``kappa = 0.25``: 1.6e-4 / 1.2e-5 / 4.0e-5
            (``R_r`` -0.7 % on average vs exact); ``kappa = 0.5``: 8.9e-6 / 4.8e-7 / 1.9e-6
            (-1.9 %). The bias grows where there are few cells per radius (-4.3 % at 10 N,
            9 cells, ``kappa = 0.25``) and vanishes as ``a -> 0`` (``eps/delta ~
            (a/r)^{3/2}``) or ``kappa -> 0``; see ``tests/test_sphere3d.py``.

    Returns:
        :class:`SphereSolution` (differentiable in the material, layer, ``R``, ``P``, ``V``).
    """
    R, P, V = roller_inputs(radius, load, speed)
    res, r_est = _resolution(
        material, layer, R, P, V, period=period, spacing=spacing, n_cells=n_cells, window=window,
        n_terms=n_terms, cells_per_radius=cells_per_radius, window_factor=window_factor,
        period_factor=period_factor,
    )
    K, K2 = sphere_kernel(material, layer, V, res.n_cells, res.period, res.n_terms)
    return _solve_on(K, K2, res, R, P, r_est, tol=tol, max_steps=max_steps, throw=throw, est=r_est,
                     edge_smoothing=edge_smoothing)


def _result(s: SphereSolution, layer) -> RollingResult:
    return full_model_result(
        s.resistance, s.resistance_dissipation, s.contact_radius, as_float(layer.H),
        ok=(s.contact.status == 0) & s.period_ok, penetration=s.contact.penetration, pressure=s.contact.pressure,
        grid=(s.x, s.y), status=s.contact.status, iterations=s.contact.iterations, residual=s.contact.residual,
    )


def rolling_resistance_full(material, layer, radius, load, speed, **options) -> RollingResult:
    """Rolling resistance ``R_r`` [N] of a rigid sphere from the full 3D rolling contact model.

    ``R_r = (1/R) sum p x dA`` of the solved pressure ([ZG] sec. 2); see :func:`solve_sphere`
    for the options (``period``, ``spacing``, ``n_cells``, ``window``, ``n_terms``,
    ``cells_per_radius``, ``window_factor``, ``period_factor``, ``tol``, ``max_steps``,
    ``throw``). The paper's resolution is ``period=0.2, spacing=2.5e-4, window=41,
    n_terms=500``.

    Returns:
        :class:`jaxroll.result.RollingResult`, ``regime = 4`` ("full"): ``contact_radius`` =
        ``sqrt(contact area/pi)`` [m], ``truncation`` = relative difference of the moment and
        dissipation forms (a discretisation-error estimate), ``valid`` = converged and period
        long enough, ``pressure`` (``W x W``, axis 0 = x) [Pa], ``grid = (x, y)`` [m],
        ``penetration`` [m], ``status``, ``iterations``, ``residual``.
    """
    return _result(solve_sphere(material, layer, radius, load, speed, **options), layer)


# ---------------------------------------------------------------------------------------------
# sweeps (the reference case): one kernel per speed, shared by all loads
# ---------------------------------------------------------------------------------------------


def rolling_resistance_sweep(
    material,
    layer: Layer,
    radius,
    loads,
    speeds,
    *,
    period,
    spacing,
    window: int,
    n_terms: int | None = None,
    tol: float = 1e-10,
    max_steps: int = 50,
    load_batch: int | None = None,
    edge_smoothing: float | None = None,
):
    """Full-model ``R_r`` [N] on the grid ``speeds x loads`` at a fixed resolution.

    The speed-independent layer factor is evaluated once, the kernel once per speed
    (``lax.map`` over speeds: memory bounded), and the loads of one speed share it: by default
    a ``lax.scan`` over the loads in the given order, each active-set iteration starting from
    the previous load's contact set (give loads sorted); with ``load_batch``, ``lax.map`` in
    batches (independent starts). Never raises on a failed point: see ``status``.

    Args:
        loads: 1D array of loads [N]; speeds: 1D array of speeds [m/s].
        period, spacing: concrete period [m] (scalar or pair) and cell size [m].
        window: static window cells per side (large enough for the largest load).
        n_terms: Fourier cut-off (default: cells per period).
        edge_smoothing: smoothed contact edge, see :func:`solve_sphere` (for fits).

    Returns:
        dict of ``(n_speeds, n_loads)`` arrays: ``value`` (moment form), ``dissipation``,
        ``contact_radius``, ``penetration``, ``status``, ``iterations``.
    """
    R = as_float(radius)
    loads, speeds = as_float(loads), as_float(speeds)
    if loads.ndim != 1 or speeds.ndim != 1:
        raise ValueError("loads and speeds must be 1D arrays")
    res, _ = _resolution(
        material, layer, R, loads[0], jnp.asarray(0.0), period=period, spacing=spacing, n_cells=None,
        window=window, n_terms=n_terms, cells_per_radius=None, window_factor=1.25, period_factor=20.0,
    )
    res = eqx.tree_at(lambda r: r.period_ok, res, jnp.asarray(True))
    r_est = jax.vmap(lambda P: estimate_contact_radius(material, layer, R, P))(loads)
    quasi = is_quasistatic(layer)
    factor = _layer_factor(layer, res.n_cells, res.period, res.n_terms) if quasi else None

    def one_speed(V):
        if quasi:
            K, K2 = _kernel_from_factor(factor, material, V)
        else:
            K, K2 = sphere_kernel(material, layer, V, res.n_cells, res.period, res.n_terms)

        def one_load(args, init=None):
            P, r0 = args
            s = _solve_on(K, K2, res, R, P, r0, tol=tol, max_steps=max_steps, throw=False, est=r0, init=init,
                          edge_smoothing=edge_smoothing)
            return s.contact.contact, dict(
                value=s.resistance, dissipation=s.resistance_dissipation, contact_radius=s.contact_radius,
                penetration=s.contact.penetration, status=s.contact.status, iterations=s.contact.iterations)

        if load_batch is None:
            # loads in the given order, each starting from the previous contact set (warm start)
            def step(prev, args):
                mask, out = one_load(args, init=prev)
                return mask, out

            first = jnp.zeros((res.window, res.window), bool)
            _, out = jax.lax.scan(step, first, (loads, r_est))
            return out
        return jax.lax.map(lambda a: one_load(a)[1], (loads, r_est), batch_size=int(load_batch))

    return jax.lax.map(one_speed, speeds)


# ---------------------------------------------------------------------------------------------
# static elastic pressure and the direct method with it (issue item 2)
# ---------------------------------------------------------------------------------------------


class StaticContact(eqx.Module):
    """Static elastic contact of a rigid sphere on the layer, on the grid of the full model.

    Attributes:
        pressure: pressure [Pa] on the ``W x W`` window (axis 0 = x).
        x, y: cell centres [m]; dx: cell size [m]; period: ``(Lx, Ly)`` [m].
        penetration: rigid-body penetration [m] (from the mean level of the periodic surface).
        contact_radius: ``sqrt(contact area/pi)`` [m].
        moment_radius: ``sqrt(5/2 sum p r^2/sum p)`` [m] (see :class:`SphereSolution`).
        peak_pressure: largest cell pressure [Pa].
        status: solver status (0 = converged).
    """

    pressure: jax.Array
    x: jax.Array
    y: jax.Array
    dx: jax.Array
    period: tuple
    penetration: jax.Array
    contact_radius: jax.Array
    moment_radius: jax.Array
    peak_pressure: jax.Array
    status: jax.Array


def _static_on(material, layer, R, P, modulus, res: _Resolution, r_est, tol, max_steps, throw):
    if modulus == "static":
        V0 = jnp.asarray(0.0)
        K, _ = sphere_kernel(material, layer, V0, res.n_cells, res.period, res.n_terms)
    elif modulus == "glassy":
        # T = T_1/G(inf): a quasi-static layer at the glassy modulus
        f = _layer_factor(layer, res.n_cells, res.period, res.n_terms)
        Kr = jnp.sum(f.A, axis=(2, 3)) / glassy_modulus(material)
        K = jax.lax.complex(Kr, jnp.zeros_like(Kr))
    else:
        raise ValueError(f'modulus must be "static" or "glassy"; got {modulus!r}')
    zero = jnp.zeros_like(jnp.real(K))
    s = _solve_on(K, zero, res, R, P, r_est, tol=tol, max_steps=max_steps, throw=throw, est=r_est)
    c = s.contact
    return StaticContact(pressure=c.pressure, x=s.x, y=s.y, dx=s.dx, period=s.period, penetration=c.penetration,
                         contact_radius=s.contact_radius, moment_radius=s.moment_radius, peak_pressure=jnp.max(c.pressure), status=c.status)


def static_pressure(material, layer: Layer, radius, load, *, modulus: str = "static", tol: float = 1e-10,
                    max_steps: int = 50, throw: bool = True, **options) -> StaticContact:
    """Static elastic contact pressure [Pa] of a rigid sphere on the layer (the full model at
    ``V = 0``), on the same periodic grid machinery as :func:`solve_sphere`.

    Args:
        material, layer, radius, load: as :func:`solve_sphere`.
        modulus: ``"static"`` (relaxed ``G'(0)``, default) or ``"glassy"`` (``G'(inf)``;
            quasi-static layers only, the ``V -> inf`` limit).
        options: resolution options of :func:`solve_sphere` (``period``, ``spacing``,
            ``n_cells``, ``window``, ``n_terms``, ``cells_per_radius``, ``window_factor``,
            ``period_factor``).

    Returns:
        :class:`StaticContact`.
    """
    R, P, _ = roller_inputs(radius, load, 0.0)
    options = dict(options)
    wf = options.pop("window_factor", 1.25)
    pf = options.pop("period_factor", 20.0)
    res, r_est = _resolution(material, layer, R, P, jnp.asarray(0.0), window_factor=wf, period_factor=pf,
                             **{k: options.pop(k, None) for k in ("period", "spacing", "n_cells", "window",
                                                                  "n_terms", "cells_per_radius")})
    if options:
        raise ValueError(f"unknown options {sorted(options)}")
    return _static_on(material, layer, R, P, modulus, res, r_est, tol, max_steps, throw)


def direct_elastic_rolling_resistance(material, layer: Layer, radius, load, speed, *, tol: float = 1e-10,
                                      max_steps: int = 50, throw: bool = True, **options) -> RollingResult:
    """Direct-method ``R_r`` [N] with the exact static elastic pressure (``pressure="elastic"``).

    ``R_r = (dA^2/(Lx Ly)) sum_r |DFT(p)_r|^2 K2_r`` = ``Lx Ly sum_m q_x Im T(q_m) |p_hat_m|^2``
    (the periodic [ZG] eq. 26, every Fourier term of the piecewise-constant grid pressure up to
    ``n_terms``) with the stationary pressure ``p`` of :func:`static_pressure` (relaxed modulus)
    instead of the Hertz/Jaffar or thin-layer shapes: valid for any layer thickness where the
    stationary-pressure assumption holds (small ``f``, or low/high speed).

    Args and options: as :func:`solve_sphere` (the resolution is chosen at ``V = 0`` unless
    given; pass ``period`` explicitly for high ``V tau``).

    Returns:
        :class:`jaxroll.result.RollingResult` with ``regime = 3`` ("elastic" pressure),
        ``contact_radius`` of the static contact, ``truncation`` = the share of the dissipation
        carried by the modes beyond the grid's Nyquist frequency (a truncation indicator),
        ``pressure``, ``grid``, ``penetration``, ``status``.
    """
    R, P, V = roller_inputs(radius, load, speed)
    options = dict(options)
    wf = options.pop("window_factor", 1.25)
    pf = options.pop("period_factor", 20.0)
    res, r_est = _resolution(material, layer, R, P, V, window_factor=wf, period_factor=pf,
                             **{k: options.pop(k, None) for k in ("period", "spacing", "n_cells", "window",
                                                                  "n_terms", "cells_per_radius")})
    if options:
        raise ValueError(f"unknown options {sorted(options)}")
    st = _static_on(material, layer, R, P, "static", res, r_est, tol, max_steps, throw)
    _, K2 = sphere_kernel(material, layer, V, res.n_cells, res.period, res.n_terms)
    value = _contact.dissipation_resistance(K2, st.pressure, res.n_cells, res.period)
    nyq = _contact.dissipation_resistance(
        sphere_kernel(material, layer, V, res.n_cells, res.period, min(res.n_cells) // 2)[1], st.pressure,
        res.n_cells, res.period,
    )
    H = as_float(layer.H)
    fin = jnp.isfinite(H)
    pos = value > 0
    trunc = jax.lax.stop_gradient(jnp.where(pos, jnp.abs(value - nyq) / where_safe(pos, value, 1.0), 0.0))
    return RollingResult(
        value=value,
        contact_radius=st.contact_radius,
        gamma=jnp.where(fin, st.contact_radius / where_safe(fin, H, 1.0), 0.0),
        regime=jnp.asarray(3),
        valid=(st.status == 0) & res.period_ok,
        truncation=trunc,
        penetration=st.penetration,
        pressure=st.pressure,
        grid=(st.x, st.y),
        status=st.status,
    )
