r"""Full 3D model of a rigid sphere rolling on a viscoelastic layer (the reference of [ZG] sec. 2).

The steady rolling contact of a rigid sphere (profile ``h = (x^2 + y^2)/(2R)``, travelling toward
+x) on a layer bonded to a rigid base, frictionless, solved on a periodic ``Lx x Ly`` surface
by :mod:`jaxroll.contact` (primal-dual active set, GMRES on the windowed FFT operator, implicit
differentiation). The pressure is piecewise constant on square cells of side ``a`` (the
paper's "load patches"); the displacement is collocated at the cell centres. The compliance is
the 3D ``T_mn = T(q_x, q_y)`` of :func:`jaxroll.engines.layer.surface_compliance` (inertia and the
mode-modulus sign fix included) times the load-patch transform
``S = sinc(q_x a/2) sinc(q_y a/2)``, folded (aliased) onto the period grid (see the module
docstring of :mod:`jaxroll.contact`, eq. (1)) and applied by FFT: the dense compliance matrix of
[ZG] sec. 2 is never formed.

Fourier modes ``q = 2 pi (m_x/Lx, m_y/Ly)`` are kept for ``|m_x| <= n_x``, ``|m_y| <= n_y``:
one cut-off wavelength ``max(Lx, Ly)/n_terms`` on both axes (``FixedGrid.axis_terms``), so on
the paper's square period ``|m_x|, |m_y| <= n_terms`` ("500 terms" = ``n_terms=500``), and on a
period stretched along x by the material's memory the mode count grows like ``Lx Ly``, not
``Lx^2``. Default ``n_terms``: the larger period cell count (the alias series is alternating in
the image index, so its truncation error falls fast).

Rolling resistance, two ways :

* pressure moment ``R_r = (1/R) sum p x dA`` (the reported ``value``);
* dissipation ``R_r = -int p du/dx dA``, exact for the piecewise-constant pressure
  (:meth:`jaxroll.contact.WindowKernel.resistance`; the discrete [ZG] eq. 26 with the solved
  pressure). Both agree up to the discretisation error (the collocated gap vanishes only at
  cell centres, and the contact edge cuts cells): measured order 1.5-2.5 in the cell size, 1-2 %
  at 6-9 cells per contact radius (the paper's a = 0.25 mm at P = 10 N), 0.1 % at 32; their
  relative difference is returned as ``truncation``.

Quasi-static layers (``rho = 0``) use the exact factorisation ``T = T_1(|q|)/G_m(q_x V)``
(``T_1`` = compliance at unit modulus): the layer closed form is evaluated once per grid (it
is speed independent) and only ``G*`` per speed, which is what makes the reference sweep
(:func:`jaxroll.rolling_resistance_grid`) cheap.

Deviation from paper: none in the model; the mode modulus is ``conj(G*(q_x V))`` (inside
:func:`jaxroll.engines.layer.surface_compliance`) and eq. 19's cases are swapped .

The *direct method with the exact stationary pressure* (``jr.DirectElastic()``):
:func:`static_pressure` solves the elastic (relaxed, ``V = 0``) contact on the same grid and
:func:`direct_elastic_rolling_resistance` evaluates the dissipation of that fixed pressure
under the rolling compliance (the periodic [ZG] eq. 26 with the grid pressure's exact
transform), which covers intermediate layer thickness where neither the Hertz/Jaffar nor the
thin-layer pressure shape applies ([ZG] footnote 4).

The grid (cell size, window, period, Fourier cut-off) is a :class:`jaxroll.grids.FixedGrid`;
the front doors :func:`jaxroll.rolling_resistance` / :func:`jaxroll.rolling_resistance_grid`
with ``jr.Full()`` size it (:class:`jaxroll.grids.AutoGrid`) and call this module.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import aperiodic as _aperiodic
from .. import contact as _contact
from .._numerics import as_float, where_safe
from .contact_size import estimate_contact_size
from ..grids import FixedGrid, full_model_error, full_model_value, loss_beyond_calibration, regime
from .layer import Layer, halfspace_asymptote, is_quasistatic, static_compliance, surface_compliance
from ..materials.material import complex_modulus, glassy_modulus
from ..result import REGIMES, RESULTS, GridSolution, RollingResult, first_failure, full_model_result, merge_results

__all__ = [
    "SphereSolution",
    "StaticContact",
    "kernel_builder",
    "solve",
    "result",
        "static_pressure",
    "direct_elastic_rolling_resistance",
    "sphere_kernel",
]


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


def _mode_grid(n_cells, period, terms):
    """Wavenumbers ``q_x, q_y`` [rad/m] of shape ``(Nx, 1, Ix, 1)`` / ``(1, Ny/2+1, 1, Iy)``,
    and the truncated load-patch factor ``S`` (0 outside ``|m_x| <= n_x``, ``|m_y| <= n_y``;
    ``terms = (n_x, n_y)``, see :meth:`jaxroll.grids.FixedGrid.axis_terms`)."""
    (Nx, Ny), (Lx, Ly), (tx, ty) = n_cells, period, terms
    mx, kx = _axis_modes(Nx, tx, last=False)
    my, ky = _axis_modes(Ny, ty, last=True)
    Sx = np.where(kx, np.sinc(mx / Nx), 0.0)
    Sy = np.where(ky, np.sinc(my / Ny), 0.0)
    qx = (2.0 * jnp.pi / Lx) * mx[:, None, :, None]
    qy = (2.0 * jnp.pi / Ly) * my[None, :, None, :]
    S = Sx[:, None, :, None] * Sy[None, :, None, :]
    return qx, qy, S


class _LayerFactor(eqx.Module):
    """Speed-independent part of the kernel of a quasi-static layer (see :func:`sphere_kernel`):
    ``A = T_1 S`` and ``B = q_x T_1 S^2`` on the mode grid with the ``y`` images summed (``G*``
    depends on ``q_x`` only), shape ``(Nx, Ny/2+1, Ix)``, and ``q_x`` per x-bin/image
    ``(Nx, Ix)``. ``B`` is ``None`` where only the compliance is needed."""

    A: jax.Array
    B: jax.Array | None
    qx: jax.Array

    def over_modulus(self, material, V):
        """``(sum_images A / conj(G*(q_x V)), 1/conj(G*(q_x V)))``: the compliance multiplier at
        speed ``V`` [m/s] and the inverse modulus on the ``q_x`` modes."""
        inv_g = 1.0 / jnp.conj(complex_modulus(material, self.qx * V))  # (Nx, Ix)
        re, im = jnp.real(inv_g), jnp.imag(inv_g)
        return jax.lax.complex(jnp.einsum("rsa,ra->rs", self.A, re), jnp.einsum("rsa,ra->rs", self.A, im)), inv_g


def _radial(fn):
    """``fn(|q|)`` of ``(q_x, q_y)``, safe at ``q = 0``."""
    def t(qx, qy):
        q2 = qx * qx + qy * qy
        pos = q2 > 0
        return fn(jnp.where(pos, jnp.sqrt(where_safe(pos, q2, 1.0)), 0.0))
    return t


def _layer_factor(layer, n_cells, period, terms, dissipation=True):
    qx, qy, S = _mode_grid(n_cells, period, terms)
    t1s = _radial(lambda q: static_compliance(layer, q))(qx, qy) * S
    return _LayerFactor(A=jnp.sum(t1s, axis=3), B=jnp.sum(qx * t1s * S, axis=3) if dissipation else None,
                        qx=qx[:, 0, :, 0])


def _kernel_from_factor(factor: _LayerFactor, material, V):
    """``(K, K2)`` from the quasi-static factorisation ``T = T_1 / conj(G*(q_x V))``."""
    K, inv_g = factor.over_modulus(material, V)
    return K, jnp.einsum("rsa,ra->rs", factor.B, jnp.imag(inv_g))


def sphere_kernel(material, layer, speed, n_cells, period, terms):
    """Fourier multipliers ``(K, K2)`` of the 3D periodic compliance on the cell grid.

    ``K_r = sum_{m = r mod N, |m_k| <= n_k} T(q_m) S(q_m)`` [m/Pa] (cell-to-centre
    compliance, ``rfftn`` layout, x = axis 0) and ``K2_r = sum q_x Im T(q_m) S(q_m)^2``
    [m/Pa per m] (dissipation), with ``T`` the 3D ``T_mn`` of
    :func:`jaxroll.engines.layer.surface_compliance` and ``S = sinc(q_x dx/2) sinc(q_y dy/2)`` the
    load-patch transform. Same convention as :func:`jaxroll.contact.periodic_kernel`, but with
    a truncation ``|m_k| <= n_k`` (the paper's number of terms on its square period) and, for
    quasi-static layers, the factorisation ``T = T_1(q)/G_m``.

    Args:
        material, layer: material and :class:`jaxroll.engines.layer.Layer`.
        speed: rolling speed ``V`` [m/s].
        n_cells: static ``(Nx, Ny)`` (``Ny`` even).
        period: ``(Lx, Ly)`` [m].
        terms: static mode cut-off per axis ``(n_x, n_y)``.
    """
    n_cells = tuple(int(n) for n in n_cells)
    if n_cells[1] % 2:
        raise ValueError(f"the y cell count must be even; got {n_cells[1]}")
    if is_quasistatic(layer):
        return _kernel_from_factor(_layer_factor(layer, n_cells, period, terms), material, speed)
    qx, qy, S = _mode_grid(n_cells, period, terms)
    T = surface_compliance(layer, material, qx, qy, speed)
    K = jnp.sum(T * S.astype(complex), axis=(2, 3))
    K2 = jnp.sum(qx * jnp.imag(T) * S * S, axis=(2, 3))
    return K, K2


def kernel_builder(material, layer, grid: FixedGrid, n_terms=None):
    """``V -> WindowKernel``: the 3D compliance and dissipation operators of ``grid``'s window
    at speed ``V`` [m/s] (Fourier cut-off ``n_terms``, default ``grid.terms()``). The
    speed-independent work (the layer factor ``T_1 S`` of a quasi-static layer on the mode grid)
    is done once, here; each call evaluates ``G*`` on the ``q_x`` modes only."""
    if grid.period is None:
        return _infinite_kernel_builder(material, layer, grid)
    n_cells, period = grid.n_cells, grid.period
    terms = grid.axis_terms(n_terms)
    window = (grid.window, grid.window)
    if n_cells[1] % 2:
        raise ValueError(f"the y cell count must be even; got {n_cells[1]}")
    if is_quasistatic(layer):
        factor = _layer_factor(layer, n_cells, period, terms)

        def build(V):
            K, K2 = _kernel_from_factor(factor, material, V)
            return _contact.periodic_window_kernel(K, K2, n_cells, period, window)
    else:
        def build(V):
            K, K2 = sphere_kernel(material, layer, V, n_cells, period, terms)
            return _contact.periodic_window_kernel(K, K2, n_cells, period, window)
    return _with_symbol(build, material, layer, grid)


def _infinite_layer_factor(layer, grid):
    """Speed-independent ``y`` integrals ``(A, B)`` of ``T_1 S_y`` and ``T_1 S_y^2`` on an infinite
    layer (:func:`jaxroll.engines.aperiodic.layer_factor_pair`: the half-space part a constant of the
    window, the layer's correction summed where ``qH < 20`` only)."""
    t_inf, q_cut = halfspace_asymptote(layer)
    return _aperiodic.layer_factor_pair(lambda q: static_compliance(layer, q), t_inf, q_cut, grid.spacing,
                                        grid.window)


def _infinite_kernel_builder(material, layer, grid: FixedGrid):
    """``V -> WindowKernel`` of an infinite layer (``grid.period = None``): the aperiodic influence
    coefficients of :mod:`jaxroll.engines.aperiodic`, with the layer's ``y`` integrals done once for a
    quasi-static layer and ``G*`` evaluated per speed on the ``q_x`` nodes only."""
    dx, W = grid.spacing, grid.window
    qx = (2.0 * jnp.pi / dx) * _aperiodic.fourier_rule(W, _aperiodic.W_CUT_SURFACE).w
    if is_quasistatic(layer):
        A, B = _infinite_layer_factor(layer, grid)

        def build(V):
            inv_g = 1.0 / jnp.conj(complex_modulus(material, qx * V))
            return _aperiodic.surface_window_kernel(A, B, inv_g, dx, W)
    else:
        def build(V):
            def t(qxx, qyy):
                return surface_compliance(layer, material, qxx, qyy, V)

            A, B = _aperiodic.surface_factor_pair(t, dx, W, imag_second=True)
            return _aperiodic.surface_window_kernel(A, B, None, dx, W)
    return _with_symbol(build, material, layer, grid)


#: Wavenumber cut-off of the preconditioner's alias sum (:func:`_with_symbol`), in cell
#: wavenumbers ``2 pi/dx``: the modes ``|m| < 2 E`` per axis (the load patch's first side lobe
#: each way). The symbol only has to be close to the operator.
SYMBOL_CUTOFF = 2


def _with_symbol(build, material, layer, grid: FixedGrid):
    """``build`` (``V -> WindowKernel``) with the compliance's preconditioner symbol
    (:attr:`jaxroll.contact.WindowedCompliance.symbol`): the alias sum of the layer's ``T S`` on
    the circulant embedding's period, ``E dx`` per axis (``E`` = the embedding's FFT size). The
    preconditioner then inverts the layer's own compliance instead of the embedded window
    coefficients, whose truncation at the window's offsets cuts a loss-dominated material's creep
    trail and leaves the embedding's multiplier with near-zero and negative-real modes
    (:mod:`jaxroll.contact.precondition`). For a quasi-static layer (``T = T_1/G*``) the
    speed-independent factor is formed here, once, and each speed costs ``G*`` on the ``q_x``
    modes; for a layer with inertia or a stack (``T`` does not factorise) each speed evaluates
    ``T`` on the modes, one image pair at a time (a loop in the program: one copy of the layer's
    code, one image's memory)."""
    E = _contact.embedding_size(grid.window)
    L = E * grid.spacing
    terms = (SYMBOL_CUTOFF * E - 1,) * 2
    if is_quasistatic(layer):
        factor = _layer_factor(layer, (E, E), (L, L), terms, dissipation=False)

        def symbol_at(V):  # (preconditioner data: no derivative, no tangents traced for it)
            return jax.lax.stop_gradient(factor).over_modulus(*jax.lax.stop_gradient((material, V)))[0]
    else:
        qx, qy, S = (jnp.asarray(a) for a in _mode_grid((E, E), (L, L), terms))
        images = [(i, j) for i in range(qx.shape[2]) for j in range(qy.shape[3])]
        ii, jj = (jnp.asarray(k) for k in zip(*images))

        def symbol_at(V):
            lay, mat, V = jax.lax.stop_gradient((layer, material, V))  # (as above)

            def image(acc, ij):
                i, j = ij
                T = surface_compliance(lay, mat, qx[:, :, i, 0], qy[:, :, 0, j], V)
                return acc + T * S[:, :, i, j].astype(T.dtype), None

            return jax.lax.scan(image, jnp.zeros(S.shape[:2], complex), (ii, jj))[0]

    def with_symbol(V):
        kernel = build(V)
        return _contact.WindowKernel(kernel.compliance.with_symbol(symbol_at(V)), kernel.dissipation)
    return with_symbol


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
        resistance: ``R_r`` from the pressure moment [N].
        resistance_dissipation: ``R_r`` from the dissipated power [N].
        contact_radius: equivalent radius of the contact set ``sqrt(area/pi)`` [m] (cell
            quantised: biased by ~ +0.17 a at 8-16 cells per radius).
        moment_radius: radius of the Hertz-form pressure ``p0 sqrt(1 - r^2/r_c^2)`` with the same
            second moment, ``sqrt(5/2 sum p r^2 / sum p)`` [m] (a smooth functional, O(a^2); the
            contact radius when the pressure keeps Hertz's form, [ZG] sec. 4.3).
        estimated_radius: stationary estimate (Hertz/Jaffar/thin) used for the initial contact
            set and the edge smoothing [m].
    """

    contact: _contact.ContactSolution
    x: jax.Array
    y: jax.Array
    dx: jax.Array
    resistance: jax.Array
    resistance_dissipation: jax.Array
    contact_radius: jax.Array
    moment_radius: jax.Array
    estimated_radius: jax.Array


def solve(kernel: _contact.WindowKernel, grid: FixedGrid, R, P, r_est, *, tol=1e-10, max_steps=50,
          edge_smoothing=None, edge_order=None, init=None,
          linear_solver=_contact.GMRES(), continuation=False) -> SphereSolution:
    """Solve the rolling contact of a rigid sphere (radius ``R`` [m], load ``P`` [N]) on the
    window of ``grid`` with the operators ``kernel`` (:func:`kernel_builder`); ``r_est`` [m] is
    the contact radius estimate the grid counts its cells on (:func:`jaxroll.grids.counting_size`;
    initial contact set, the edge smoothing's gap scale, the error estimate's regime and cells); ``init`` an optional :class:`jaxroll.contact.WarmStart` (a solved neighbour). Never raises: see
    ``contact.result``.

    ``edge_smoothing``: ``None`` (exact discrete complementarity) or ``kappa > 0``: the smoothed
    contact edge (``smoothing`` of :func:`jaxroll.contact.solve_contact`) with the gap scale
    ``eps = kappa a^{3/2} r^{1/2} / R`` (``a`` = cell size, ``r`` = the estimated contact radius:
    the Hertz gap one cell outside the edge, up to an O(1) factor), which makes ``R_r`` a smooth
    function of every parameter for least-squares fits, at the price of a bias that vanishes as
    ``a -> 0`` or ``kappa -> 0``. ``edge_order``: ``None`` or the order ``q`` of that bias
    (``~ kappa^q``): the smoothed solutions at ``kappa`` and ``2 kappa`` are combined by
    Richardson extrapolation (``smoothing_order`` of :func:`jaxroll.contact.solve_contact`),
    which removes most of the bias and stays smooth. ``continuation``: static, the contact search's
    fallback for loss-dominated contacts (``continuation`` of :func:`jaxroll.contact.solve_contact`).
    """
    W = grid.window
    dx = grid.spacing
    x = (jnp.arange(W, dtype=float) - 0.5 * (W - 1)) * dx
    X, Y = x[:, None], x[None, :]
    h = (X * X + Y * Y) / (2.0 * R)
    guess = (X * X + Y * Y) < r_est * r_est
    sol = _contact.solve_contact(
        kernel.compliance, h, P, dx * dx, initial_contact=guess, warm_start=init, tol=tol,
        max_steps=max_steps, linear_solver=linear_solver,
        smoothing=_contact.edge_gap_scale(edge_smoothing, dx, r_est, R),
        smoothing_order=edge_order, continuation=continuation,
    )
    p = sol.pressure
    moment = jnp.sum(p * X) * dx * dx / R
    diss = kernel.resistance(p, dx * dx)
    area = jnp.sum(sol.contact.astype(float)) * dx * dx
    total = jnp.sum(p)
    total_safe = jnp.where(total > 0, total, 1.0)
    cx = jnp.sum(p * X) / total_safe  # centre of pressure (shifted forward when rolling)
    r2 = jnp.sum(p * ((X - cx) ** 2 + Y * Y)) / total_safe
    return SphereSolution(
        contact=sol, x=x, y=x, dx=dx, resistance=moment, resistance_dissipation=diss,
        contact_radius=jnp.sqrt(area / jnp.pi), moment_radius=jnp.sqrt(2.5 * r2), estimated_radius=r_est,
    )


def result(s: SphereSolution, grid: FixedGrid, layer, V, material) -> RollingResult:
    """The :class:`~jaxroll.result.RollingResult`: the dissipation form of R_r with its error
    estimate (:func:`jaxroll.grids.full_model_error` at the regime of the counting size)."""
    a = s.estimated_radius
    zeta, breadth = regime(material, V, a)
    return full_model_result(
        s.resistance, s.resistance_dissipation, s.contact_radius, layer.H,
        result=merge_results(s.contact.result, first_failure(
            (~grid.period_ok(s.estimated_radius, V * material.longest_time(), 2), RESULTS.period_too_short))),
        penetration=s.contact.penetration, pressure=s.contact.pressure, grid=(s.x, s.y),
        iterations=s.contact.iterations, residual=s.contact.residual,
        error=full_model_error(s.resistance, s.resistance_dissipation, zeta, a / grid.spacing,
                               "sphere", s.contact_radius / a, breadth, a / layer.H,
                               loss_beyond_calibration(material, V, jnp.minimum(s.contact_radius, a),
                                                       jnp.maximum(s.contact_radius, a))),
        value=full_model_value(s.resistance, s.resistance_dissipation, zeta),
    )


# ---------------------------------------------------------------------------------------------
# static elastic pressure and the direct method with it
# ---------------------------------------------------------------------------------------------


class StaticContact(eqx.Module):
    """Static elastic contact of a rigid sphere on the layer, on the grid of the full model.

    Attributes:
        pressure: pressure [Pa] on the ``W x W`` window (axis 0 = x).
        x, y: cell centres [m]; dx: cell size [m].
        penetration: rigid-body penetration [m] (from the mean level of the periodic surface).
        contact_radius: ``sqrt(contact area/pi)`` [m].
        moment_radius: ``sqrt(5/2 sum p r^2/sum p)`` [m] (see :class:`SphereSolution`).
        peak_pressure: largest cell pressure [Pa].
        estimated_radius: the stationary estimate used to start the solve [m].
        result: :data:`jaxroll.result.RESULTS` code of the contact solve.
    """

    pressure: jax.Array
    x: jax.Array
    y: jax.Array
    dx: jax.Array
    penetration: jax.Array
    contact_radius: jax.Array
    moment_radius: jax.Array
    peak_pressure: jax.Array
    estimated_radius: jax.Array
    result: jax.Array


def static_pressure(material, layer: Layer, R, P, grid: FixedGrid, *, modulus: str = "static", tol: float = 1e-10,
                    max_steps: int = 50) -> StaticContact:
    """Static elastic contact pressure [Pa] of a rigid sphere (radius ``R`` [m], load ``P`` [N])
    on the layer: the full model at ``V = 0`` on ``grid``, with ``modulus="static"`` (relaxed
    ``G'(0)``, default) or ``"glassy"`` (``G'(inf)``; quasi-static layers only, the ``V -> inf``
    limit)."""
    R, P = as_float(R), as_float(P)
    if modulus == "static":
        kernel = kernel_builder(material, layer, grid)(jnp.asarray(0.0))
    elif modulus == "glassy":
        if not is_quasistatic(layer):
            raise ValueError('modulus="glassy" needs a quasi-static layer (rho = 0)')
        # T = T_1/G(inf): a quasi-static layer at the glassy modulus (a real, elastic kernel)
        if grid.period is None:
            A, B = _infinite_layer_factor(layer, grid)
            inv_g = jnp.full(A.shape[0], 1.0 / glassy_modulus(material)).astype(complex)
            kernel = _aperiodic.surface_window_kernel(A, B, inv_g, grid.spacing, grid.window)
        else:
            f = _layer_factor(layer, grid.n_cells, grid.period, grid.axis_terms(), dissipation=False)
            Kr = jnp.sum(f.A, axis=2) / glassy_modulus(material)
            K = jax.lax.complex(Kr, jnp.zeros_like(Kr))
            kernel = _contact.periodic_window_kernel(K, jnp.zeros_like(Kr), grid.n_cells, grid.period,
                                                     (grid.window, grid.window))
    else:
        raise ValueError(f'modulus must be "static" or "glassy"; got {modulus!r}')
    r_est = estimate_contact_size(material, layer, R, P, "sphere")
    s = solve(kernel, grid, R, P, r_est, tol=tol, max_steps=max_steps)
    c = s.contact
    return StaticContact(pressure=c.pressure, x=s.x, y=s.y, dx=s.dx, penetration=c.penetration,
                         contact_radius=s.contact_radius, moment_radius=s.moment_radius,
                         peak_pressure=jnp.max(c.pressure), estimated_radius=r_est, result=c.result)


def direct_elastic_rolling_resistance(material, layer: Layer, R, P, V, grid: FixedGrid, *, tol: float = 1e-10,
                                      max_steps: int = 50) -> RollingResult:
    """Direct-method ``R_r`` [N] with the exact static elastic pressure (:class:`jaxroll.DirectElastic`).

    ``R_r = dA^2 p . (D p)`` = ``Lx Ly sum_m q_x Im T(q_m) |p_hat_m|^2`` (the periodic [ZG]
    eq. 26, every Fourier term of the piecewise-constant grid pressure up to ``n_terms``) with
    the stationary pressure ``p`` of :func:`static_pressure` (relaxed modulus) instead of the
    Hertz/Jaffar or thin-layer shapes: valid for any layer thickness where the
    stationary-pressure assumption holds (small ``f``, or low/high speed).

    Returns:
        :class:`jaxroll.result.RollingResult` with ``regime = 3`` ("elastic" pressure),
        ``contact_radius`` of the static contact, ``truncation`` = the share of the dissipation
        carried by the modes beyond the grid's Nyquist frequency (a truncation indicator),
        ``pressure``, ``grid``, ``penetration``, ``result``.
    """
    if grid.period is None:
        raise ValueError("DirectElastic evaluates the periodic [ZG] eq. 26 on the grid's period: give "
                         "a periodic grid (jr.AutoGrid(period='auto') or a FixedGrid with a period)")
    st = static_pressure(material, layer, R, P, grid, tol=tol, max_steps=max_steps)
    dA = grid.spacing * grid.spacing
    value = kernel_builder(material, layer, grid)(V).resistance(st.pressure, dA)
    nyq = kernel_builder(material, layer, grid, n_terms=min(grid.n_cells) // 2)(V).resistance(st.pressure, dA)
    H = as_float(layer.H)
    fin = jnp.isfinite(H)
    pos = value > 0
    trunc = jax.lax.stop_gradient(jnp.where(pos, jnp.abs(value - nyq) / where_safe(pos, value, 1.0), 0.0))
    ok = grid.period_ok(st.estimated_radius, V * material.longest_time(), 2)
    return RollingResult(
        value=value,
        contact_radius=st.contact_radius,
        gamma=jnp.where(fin, st.contact_radius / where_safe(fin, H, 1.0), 0.0),
        regime=jnp.asarray(int(REGIMES.elastic)),
        truncation=trunc,
        result=merge_results(st.result, first_failure((~ok, RESULTS.period_too_short))),
        solution=GridSolution(penetration=st.penetration, pressure=st.pressure, grid=(st.x, st.y)),
    )
