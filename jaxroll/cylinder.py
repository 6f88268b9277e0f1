"""Full 2D (plane strain) model of a rigid cylinder rolling on a viscoelastic layer.

The Qiu (2006)-type model of [ZG] sec. 3: the rolling contact problem of a rigid cylinder
(profile ``h = x^2/(2R)``) on a periodic viscoelastic layer, solved exactly on a grid by
:mod:`jaxroll.contact` with the layer's plane-strain surface compliance
``T(q) = surface_compliance(layer, material, q, 0, V)`` (inertia included through ``T``).

Rolling resistance per unit length, two ways (DESIGN section 2):

* pressure moment ``R_r = (1/R) int p x dx`` (the reported value);
* dissipation ``R_r = -int p du/dx dx``, evaluated exactly for the piecewise-constant pressure
  in Fourier space (:func:`jaxroll.contact.dissipation_resistance`).

In the continuum both are equal because ``du/dx = -x/R`` on the contact. The grid imposes the
contact condition at cell centres only, so in the discrete problem they differ by the
discretisation error: the partly loaded edge cells contribute a relative term of order
``dx^2`` (measured order 2.0-2.4 at V tau/a0 = 1, 2-4 at 0.01, refining 12 -> 100 cells per
half-width at a fixed period; relative difference at the default resolution 7e-4..1.3e-3 for
0.01 <= V tau/a0 <= 100, 3e-3 at 1e3, 1.3e-2 at 1e-3). No independent dissipation form agrees
exactly: a discrete derivative restricted to the contact set makes ``-sum p u' dx`` the moment
form rewritten. The difference is returned as ``truncation``. The moment form is the reported
value (the more accurate of the two against the exact half-space solution at low speed).

Speed: the compliance is evaluated by :func:`compliance_function` (quasi-static layers: the
factorised form ``T_1(|q|)/G_m(q V)`` with a forward-mode derivative rule and the half-space
form for the image wavenumbers when ``pi H/dx >= 40``), so the kernel costs about as much as
the solve and ``value_and_grad`` costs 2.6-3.4x ``value`` (benchmarks/bench_cylinder.py; was
~9.5x with the general layer path).
Under ``jit`` use :func:`static_resolution` to fix the automatic grid from nominal values.

Resolution (DESIGN section 3, refined by measurement): cell ``dx = a_est / cells_per_radius``
(``cells_per_radius`` automatic, see :func:`solve_cylinder`), with
``a_est = min(a0, a_thin)``, ``a0 = sqrt(P R/(pi G0))`` (relaxed Hertz half-width, plane strain
``E* = 4 G0``) and ``a_thin = (15 P R H^3/(2 G0))^(1/5)`` (thin incompressible layer); period
``L = N dx`` with ``N`` the smallest power of two giving ``L >= period_factor * max(4 a_est, V tau)``
(``tau`` = the material's slowest relaxation time, via its relaxed and glassy moduli);
pressure carried on a window of ``2 ceil(window * cells_per_radius)`` cells centred on the
cylinder.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import contact as _contact
from ._numerics import as_float, roller_inputs, to_complex
from .layer import Layer, is_quasistatic, static_compliance, surface_compliance
from .material import complex_modulus, glassy_modulus, relaxed_modulus
from .result import RollingResult, full_model_result

__all__ = ["CylinderSolution", "solve_cylinder", "rolling_resistance_full", "compliance_function", "static_resolution"]

#: Default number of period cells when the inputs are traced (jit/vmap/grad) and no
#: ``n_cells`` is given: with 25 cells per half-width it covers V tau / a0 <= 130. Prefer
#: :func:`static_resolution` (the grid an eager call would use) from nominal values.
DEFAULT_TRACED_CELLS = 2**16
MAX_AUTO_CELLS = 2**21


class CylinderSolution(eqx.Module):
    """Full solution of the rolling cylinder.

    Attributes:
        contact: :class:`jaxroll.contact.ContactSolution` on the window grid.
        x: cell centres of the window [m] (cylinder axis at ``x = 0``, rolling toward +x).
        dx: cell width [m].
        period: period ``L`` [m].
        resistance: ``R_r`` from the pressure moment [N/m].
        resistance_dissipation: ``R_r`` from the dissipated power [N/m].
        half_width: contact half-width from the contact set [m].
        leading_edge, trailing_edge: contact edges ``a`` (x > 0) and ``-b`` [m] (cell faces).
        a0: relaxed Hertz half-width [m].
        period_ok: whether ``L >= period_factor * max(4 a_est, V tau)``.
    """

    contact: _contact.ContactSolution
    x: jax.Array
    dx: jax.Array
    period: jax.Array
    resistance: jax.Array
    resistance_dissipation: jax.Array
    half_width: jax.Array
    leading_edge: jax.Array
    trailing_edge: jax.Array
    a0: jax.Array
    period_ok: jax.Array


def _concrete(*xs):
    """Python floats of ``xs`` if all are concrete, else None."""
    try:
        return [float(np.asarray(x)) for x in xs]
    except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError, TypeError):
        return None


def _retardation_time(material):
    """Slowest material time [s]: ``tau`` for a standard linear solid, the largest Prony time
    scaled by glassy/relaxed for a generalized Maxwell solid (its retardation time)."""
    if hasattr(material, "f") and hasattr(material, "tau"):
        return material.tau
    if hasattr(material, "tau"):
        return jnp.max(material.tau) * glassy_modulus(material) / relaxed_modulus(material)
    raise ValueError("cannot derive a relaxation time from this material; pass period=")


def _auto_cells_per_radius(zeta):
    """Cells per half-width giving <= 1 % error of the moment form against the exact half-space
    cylinder (measured, f = 1): 25 cells err <= 0.5 % for 0.03 <= V tau/a0 <= 30 (-2 % at 0.01,
    +1.5 % at 100); 128 cells: -0.7 % at 1e-3; 50 cells: -0.1 % at 100, +0.65 % at 1000;
    100 cells: +0.2 % at 1000."""
    if zeta < 0.03:
        return 128
    if zeta <= 30.0:
        return 25
    if zeta <= 300.0:
        return 50
    return 100


def compliance_function(material, layer: Layer, V):
    """Plane-strain surface compliance ``T(q)`` [m/Pa] of ``layer`` at speed ``V`` as a function
    of the wavenumber ``q`` [rad/m] (the input of :func:`jaxroll.contact.periodic_kernel`).

    Same values as ``surface_compliance(layer, material, q, 0, V)``. Without inertia
    (``rho = 0``) the compliance factorises exactly, ``T = T_1(|q|)/G_m(q V)``
    (:func:`jaxroll.layer.static_compliance`, with its forward-mode derivative rule); the
    kernel's image wavenumbers (all ``|q| >= pi/dx``) take the half-space ``T_1`` when every
    ``|q| H >= 40`` (the layer correction is ~e^{-2 q H}). With inertia (``rho > 0`` or a traced
    ``rho``) this is ``surface_compliance`` itself.
    """
    if not (layer.nu < 0.5 or is_quasistatic(layer)):  # compressible layers are quasi-static in jaxroll
        return lambda q: surface_compliance(layer, material, q, 0.0, V)
    H = as_float(layer.H)
    halfspace = Layer(jnp.inf, nu=layer.nu)

    def static(q):
        G = jnp.conj(complex_modulus(material, q * V))
        qa = jnp.abs(q)
        # lax.cond runs only the branch taken (both under a batched predicate in vmap)
        deep = ~jnp.isfinite(H) | (jnp.min(qa) * jnp.where(jnp.isfinite(H), H, 1.0) >= 40.0)
        t1 = jax.lax.cond(deep, lambda qq: static_compliance(halfspace, qq),
                          lambda qq: static_compliance(layer, qq), qa)
        return to_complex(t1) / G

    return static


def _next_pow2(n):
    return 1 << max(1, int(math.ceil(math.log2(max(n, 2)))))


def line_grid(material, layer, R, P, V, *, period=None, n_cells=None, cells_per_radius=None, window=3.0,
              period_factor=20.0):
    """Grid of a 2D rolling cylinder (shared by :mod:`jaxroll.slices`): cell width, period,
    cells per period, window cells, whether the period is long enough, the Hertz half-width
    ``a0`` with ``G0`` and the estimated half-width ``a_est`` (Hertz or thin-layer, the smaller).
    See :func:`solve_cylinder` for the options and the resolution rules."""
    G0 = relaxed_modulus(material)
    H = layer.H
    a0 = jnp.sqrt(P * R / (jnp.pi * G0))
    finite_H = jnp.isfinite(H)
    H_safe = jnp.where(finite_H, H, 1.0)
    a_thin = jnp.where(finite_H, (15.0 * P * R * H_safe**3 / (2.0 * G0)) ** 0.2, jnp.inf)
    a_est = jnp.minimum(a0, a_thin)
    c = V * _retardation_time(material)
    # 4 a_est: the elastic (log-kernel) interaction of the periodic images tilts the pressure:
    # at V tau = a0, L = 20 a0 gives -0.76 % in R_r, L = 80 a0 gives 0.0 % (measured)
    L_need = period_factor * jnp.maximum(4.0 * a_est, c)
    if cells_per_radius is None:
        vals = _concrete(c / a0, a_est / H)
        if vals is None:
            cells_per_radius = 25
        else:
            # thin layers: the kernel width is ~H, so cells must resolve H too (dx <= H/2)
            cells_per_radius = max(_auto_cells_per_radius(vals[0]), int(math.ceil(2.0 * vals[1])))

    if period is None:
        W = 2 * int(math.ceil(window * cells_per_radius))
        dx = a_est / cells_per_radius
        if n_cells is None:
            vals = _concrete(L_need, dx)
            if vals is None:
                N = DEFAULT_TRACED_CELLS
            else:
                N = min(_next_pow2(max(vals[0] / vals[1], 2 * W)), MAX_AUTO_CELLS)
        else:
            N = int(n_cells)
        L = N * dx
    else:
        L = as_float(period)
        L = eqx.error_if(L, ~(L > 0), "period must be positive")
        vals = _concrete(L, a_est)
        if n_cells is None:
            if vals is None:
                raise ValueError("with a traced period, pass n_cells (static)")
            N = _next_pow2(vals[0] / (vals[1] / cells_per_radius))
        else:
            N = int(n_cells)
        dx = L / N
        if vals is None:
            W = N
        else:
            W = min(N, 2 * int(math.ceil(window * vals[1] / (vals[0] / N))))
    if N % 2:
        raise ValueError(f"n_cells must be even; got {N}")
    if W > N:
        raise ValueError(
            f"the pressure window ({W} cells) is wider than the period ({N} cells): raise n_cells"
        )
    return dx, L, N, W, L >= L_need, a0, a_est


def static_resolution(material, layer: Layer, radius, load, speed, *, cells_per_radius=None, window=3.0,
                      period_factor=20.0) -> dict:
    """Static resolution options of :func:`solve_cylinder` from concrete nominal inputs.

    Under ``jit``/``grad``/``vmap`` the automatic grid cannot be chosen from traced values
    (``solve_cylinder`` then falls back to ``DEFAULT_TRACED_CELLS`` cells and 25 cells per
    half-width). Call this once with nominal concrete values and pass the result on, e.g.
    ``solve_cylinder(..., **static_resolution(mat, layer, R, P, V))``, to get the resolution the
    eager call would use (and to compare value and gradient on the same grid).

    Returns:
        ``{"n_cells": N, "cells_per_radius": c}`` (Python ints).
    """
    R, P, V = roller_inputs(radius, load, speed)
    if _concrete(R, P, V, relaxed_modulus(material), layer.H, _retardation_time(material)) is None:
        raise ValueError("static_resolution needs concrete (non-traced) inputs")
    if cells_per_radius is None:
        G0 = relaxed_modulus(material)
        a0 = float(jnp.sqrt(P * R / (jnp.pi * G0)))
        H = float(layer.H)
        a_thin = (15.0 * float(P) * float(R) * H**3 / (2.0 * float(G0))) ** 0.2 if math.isfinite(H) else math.inf
        a_est = min(a0, a_thin)
        zeta = float(V * _retardation_time(material)) / a0
        cells_per_radius = max(_auto_cells_per_radius(zeta), int(math.ceil(2.0 * a_est / H)))
    _, _, N, _, _, _, _ = line_grid(material, layer, R, P, V, cells_per_radius=int(cells_per_radius), window=window,
                                    period_factor=period_factor)
    return {"n_cells": int(N), "cells_per_radius": int(cells_per_radius)}


def solve_cylinder(
    material,
    layer: Layer,
    radius,
    load,
    speed,
    *,
    period=None,
    n_cells: int | None = None,
    cells_per_radius: int | None = None,
    window: float = 3.0,
    period_factor: float = 20.0,
    images: int = 1,
    tol: float = 1e-10,
    max_steps: int = 50,
    throw: bool = True,
    edge_smoothing: float | None = None,
) -> CylinderSolution:
    """Solve the rolling contact of a rigid cylinder on a viscoelastic layer (plane strain).

    Args:
        material: material of :mod:`jaxroll.material` (e.g. ``StandardLinearSolid(G0, tau, f)``).
        layer: :class:`jaxroll.layer.Layer` (``H = inf`` for a half-space).
        radius: cylinder radius ``R`` [m].
        load: load per unit length ``P'`` [N/m], positive.
        speed: rolling speed ``V`` [m/s] (>= 0; the cylinder travels toward +x).
        period: fixed period ``L`` [m] (like the paper's 0.2 m); default: automatic.
        n_cells: static number of cells per period; default automatic from concrete inputs
            (``DEFAULT_TRACED_CELLS`` when traced without ``period``; required with a traced
            ``period``).
        cells_per_radius: static, cells per estimated contact half-width; default from
            concrete inputs: 25 for ``0.03 <= V tau/a0 <= 30``, 128 below, 50 up to 300,
            100 above, and at least ``2 a_est/H`` (cells no wider than H/2: on thin layers the
            compliance kernel is only ~H wide); 25 when traced. See ``_auto_cells_per_radius``.
        window: static, half-width of the pressure window in estimated half-widths.
        period_factor: automatic period ``>= period_factor * max(4 a_est, V tau)``.
        images: static alias images per side in the compliance kernel (plus the analytic
            tail); 1 by default: ``R_r`` differs from 8 images by <= 1.1e-4 relative (2 images:
            1.5e-5; worst case V tau/a0 ~ 0.02 at 25 cells per half-width, < 1e-6 for
            V tau/a0 >= 1), well below the discretisation error; 1 image is ~25 % faster.
        tol, max_steps, throw: solver options, see :func:`jaxroll.contact.solve_contact`.
        edge_smoothing: ``None`` (exact discrete contact) or ``kappa > 0``: smoothed contact
            edge with ``eps = kappa a^{3/2} a_est^{1/2} / R`` (``smoothing`` of
            :func:`jaxroll.contact.solve_contact`, :func:`jaxroll.contact.edge_gap_scale`), which
            makes ``R_r`` smooth in the parameters for fits (the exact discrete one wiggles
            by ~1e-3 at low speed when the contact set changes by a cell); see
            ``tests/test_cylinder.py`` for wiggle and bias.

    Returns:
        :class:`CylinderSolution`.
    """
    R, P, V = roller_inputs(radius, load, speed)
    dx, L, N, W, period_ok, a0, a_est = line_grid(material, layer, R, P, V, period=period, n_cells=n_cells,
                                                  cells_per_radius=cells_per_radius, window=window,
                                                  period_factor=period_factor)

    T = compliance_function(material, layer, V)
    K, K2 = _contact.periodic_kernel(T, (L,), (N,), images=images, dissipation=True)
    C = _contact.windowed_compliance(K, (N,), (W,))
    x = (jnp.arange(W, dtype=float) - 0.5 * (W - 1)) * dx
    h = x * x / (2.0 * R)
    sol = _contact.solve_contact(
        C, h, P, dx, initial_contact=jnp.abs(x) < a_est, tol=tol, max_steps=max_steps, throw=throw,
        smoothing=_contact.edge_gap_scale(edge_smoothing, dx, a_est, R),
    )
    p = sol.pressure
    Rr_moment = jnp.sum(p * x) * dx / R
    Rr_diss = _contact.dissipation_resistance(K2, p, (N,), (L,))
    inside = sol.contact
    lead = jnp.max(jnp.where(inside, x, -jnp.inf)) + 0.5 * dx
    trail = jnp.min(jnp.where(inside, x, jnp.inf)) - 0.5 * dx
    half_width = 0.5 * jnp.sum(inside.astype(float)) * dx
    return CylinderSolution(
        contact=sol,
        x=x,
        dx=dx,
        period=L,
        resistance=Rr_moment,
        resistance_dissipation=Rr_diss,
        half_width=half_width,
        leading_edge=lead,
        trailing_edge=trail,
        a0=a0,
        period_ok=period_ok,
    )


def rolling_resistance_full(material, layer, radius, load, speed, **options) -> RollingResult:
    """Rolling resistance [N/m] of a rigid cylinder from the full 2D rolling contact model.

    ``R_r = (1/R) int p x dx`` from the exact (discretised) rolling contact solution; see
    :func:`solve_cylinder` for the options (``period``, ``n_cells``, ``cells_per_radius``,
    ``window``, ``period_factor``, ``images``, ``tol``, ``max_steps``, ``throw``,
    ``edge_smoothing``).

    Returns:
        :class:`jaxroll.result.RollingResult` with ``regime = 4`` ("full"),
        ``contact_radius`` = contact half-width [m], ``truncation`` = relative difference of the
        moment and dissipation forms (a discretisation-error estimate), ``valid`` = converged and
        period long enough, plus ``pressure``, ``grid``, ``penetration``, ``status``,
        ``iterations``, ``residual``.
    """
    s = solve_cylinder(material, layer, radius, load, speed, **options)
    return full_model_result(
        s.resistance, s.resistance_dissipation, s.half_width, layer.H, ok=(s.contact.status == 0) & s.period_ok,
        penetration=s.contact.penetration, pressure=s.contact.pressure, grid=s.x, status=s.contact.status,
        iterations=s.contact.iterations, residual=s.contact.residual,
    )
