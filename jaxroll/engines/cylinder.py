"""Full 2D (plane strain) model of a rigid cylinder rolling on a viscoelastic layer.

The Qiu (2006)-type model of [ZG] sec. 3: the rolling contact problem of a rigid cylinder
(profile ``h = x^2/(2R)``) on a periodic viscoelastic layer, solved exactly on a grid by
:mod:`jaxroll.contact` with the layer's plane-strain surface compliance
``T(q) = surface_compliance(layer, material, q, 0, V)`` (inertia included through ``T``).

Rolling resistance per unit length, two ways :

* pressure moment ``R_r = (1/R) int p x dx`` (the reported value);
* dissipation ``R_r = -int p du/dx dx``, evaluated exactly for the piecewise-constant pressure
  in Fourier space (:meth:`jaxroll.contact.WindowKernel.resistance`).

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
the solve.

The grid (cell size, window, period) is a :class:`jaxroll.grids.FixedGrid`, sized by the rules
of :mod:`jaxroll.grids` when the front doors :func:`jaxroll.rolling_resistance` /
:func:`jaxroll.rolling_resistance_grid` are called with ``jr.Full()`` and ``geometry="cylinder"``.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from . import aperiodic as _aperiodic
from .. import contact as _contact
from .._numerics import as_float, to_complex
from ..grids import FixedGrid, full_model_error, full_model_value, loss_beyond_calibration, regime
from .layer import Layer, is_quasistatic, static_compliance, surface_compliance
from ..materials.material import complex_modulus
from ..result import RESULTS, RollingResult, first_failure, full_model_result, merge_results

__all__ = ["CylinderSolution", "compliance_function", "kernel_builder", "solve", "result"]

#: Alias images per side of the 1D periodic kernel (plus its analytic tail): ``R_r`` differs
#: from 8 images by <= 1.1e-4 relative (2 images: 1.5e-5; worst case V tau/a0 ~ 0.02 at 25
#: cells per half-width, < 1e-6 for V tau/a0 >= 1), well below the discretisation error.
IMAGES = 1


class CylinderSolution(eqx.Module):
    """Full solution of the rolling cylinder.

    Attributes:
        contact: :class:`jaxroll.contact.ContactSolution` on the window grid.
        x: cell centres of the window [m] (cylinder axis at ``x = 0``, rolling toward +x).
        dx: cell width [m].
        resistance: ``R_r`` from the pressure moment [N/m].
        resistance_dissipation: ``R_r`` from the dissipated power [N/m].
        half_width: contact half-width from the contact set [m].
        leading_edge, trailing_edge: contact edges ``a`` (x > 0) and ``-b`` [m] (cell faces).
        estimated_half_width: the stationary estimate (Hertz or thin layer, the smaller) used
            for the initial contact set and the edge smoothing [m].
    """

    contact: _contact.ContactSolution
    x: jax.Array
    dx: jax.Array
    resistance: jax.Array
    resistance_dissipation: jax.Array
    half_width: jax.Array
    leading_edge: jax.Array
    trailing_edge: jax.Array
    estimated_half_width: jax.Array


def compliance_function(material, layer: Layer, V):
    """Plane-strain surface compliance ``T(q)`` [m/Pa] of ``layer`` at speed ``V`` as a function
    of the wavenumber ``q`` [rad/m] (the input of :func:`jaxroll.contact.periodic_kernel`).

    Same values as ``surface_compliance(layer, material, q, 0, V)``. Without inertia
    (``rho = 0``) the compliance factorises exactly, ``T = T_1(|q|)/G_m(q V)``
    (:func:`jaxroll.engines.layer.static_compliance`, with its forward-mode derivative rule); the
    kernel's image wavenumbers (all ``|q| >= pi/dx``) take the half-space ``T_1`` when every
    ``|q| H >= 40`` (the layer correction is ~e^{-2 q H}). With inertia (``rho > 0`` or a traced
    ``rho``) this is ``surface_compliance`` itself.
    """
    if not (is_quasistatic(layer) or (isinstance(layer, Layer) and layer.nu < 0.5)):  # compressible: quasi-static
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


def kernel_builder(material, layer: Layer, grid: FixedGrid, images: int = IMAGES):
    """``V -> WindowKernel``: the plane-strain compliance and dissipation operators of ``grid``'s
    window at speed ``V`` [m/s] (periodic alias sum with ``images`` images per side and the
    analytic tail, :func:`jaxroll.contact.periodic_kernel`; on an infinite layer,
    ``grid.period = None``, the aperiodic influence coefficients of :mod:`jaxroll.engines.aperiodic`)."""
    if grid.period is None:
        halfspace = jnp.isinf(as_float(layer.H))

        def build_infinite(V):
            return _aperiodic.line_window_kernel(compliance_function(material, layer, V), grid.spacing, grid.window,
                                                 halfspace)

        return build_infinite
    L, N, W = grid.period[0], grid.n_cells[0], grid.window

    def build(V):
        K, K2 = _contact.periodic_kernel(compliance_function(material, layer, V), (L,), (N,), images=images,
                                         dissipation=True)
        return _contact.periodic_window_kernel(K, K2, (N,), (L,), (W,))

    return build


def solve(kernel: _contact.WindowKernel, grid: FixedGrid, R, P, a_est, *, tol=1e-10, max_steps=50,
          edge_smoothing=None, edge_order=None, init=None,
          linear_solver=_contact.GMRES()) -> CylinderSolution:
    """Solve the rolling contact of a rigid cylinder (radius ``R`` [m], load per unit length
    ``P'`` [N/m]) on the window of ``grid`` with the operators ``kernel``
    (:func:`kernel_builder`); ``a_est`` [m] is the half-width estimate the grid counts its cells on
    (:func:`jaxroll.grids.counting_size`; initial contact set, edge smoothing, error estimate); ``init`` an optional :class:`jaxroll.contact.WarmStart` (a solved neighbour).
    Never raises: see ``contact.result``.

    ``edge_smoothing``: ``None`` (exact discrete contact) or ``kappa > 0``: smoothed contact
    edge with ``eps = kappa a^{3/2} a_est^{1/2} / R`` (:func:`jaxroll.contact.edge_gap_scale`),
    which makes ``R_r`` smooth in the parameters for fits (the exact discrete one wiggles by
    ~1e-3 at low speed when the contact set changes by a cell). ``edge_order``: ``None`` or the
    order ``q`` of the smoothing's bias: Richardson extrapolation from ``kappa`` and ``2 kappa``
    (``smoothing_order`` of :func:`jaxroll.contact.solve_contact`).
    """
    W, dx = grid.window, grid.spacing
    x = (jnp.arange(W, dtype=float) - 0.5 * (W - 1)) * dx
    h = x * x / (2.0 * R)
    guess = jnp.abs(x) < a_est
    sol = _contact.solve_contact(
        kernel.compliance, h, P, dx, initial_contact=guess, warm_start=init, tol=tol,
        max_steps=max_steps, linear_solver=linear_solver,
        smoothing=_contact.edge_gap_scale(edge_smoothing, dx, a_est, R),
        smoothing_order=edge_order,
    )
    p = sol.pressure
    inside = sol.contact
    return CylinderSolution(
        contact=sol,
        x=x,
        dx=dx,
        resistance=jnp.sum(p * x) * dx / R,
        resistance_dissipation=kernel.resistance(p, dx),
        half_width=0.5 * jnp.sum(inside.astype(float)) * dx,
        leading_edge=jnp.max(jnp.where(inside, x, -jnp.inf)) + 0.5 * dx,
        trailing_edge=jnp.min(jnp.where(inside, x, jnp.inf)) - 0.5 * dx,
        estimated_half_width=a_est,
    )


def result(s: CylinderSolution, grid: FixedGrid, layer, V, material) -> RollingResult:
    """The :class:`~jaxroll.result.RollingResult`: the dissipation form of R_r with its error
    estimate (:func:`jaxroll.grids.full_model_error` at the regime of the counting size)."""
    a = s.estimated_half_width
    zeta, breadth = regime(material, V, a)
    ok = grid.period_ok(s.estimated_half_width, V * material.longest_time(), 1)
    return full_model_result(
        s.resistance, s.resistance_dissipation, s.half_width, layer.H,
        result=merge_results(s.contact.result, first_failure((~ok, RESULTS.period_too_short))),
        penetration=s.contact.penetration, pressure=s.contact.pressure, grid=s.x,
        iterations=s.contact.iterations, residual=s.contact.residual,
        error=full_model_error(s.resistance, s.resistance_dissipation, zeta, a / grid.spacing,
                               "cylinder", s.half_width / a, breadth, a / layer.H,
                               loss_beyond_calibration(material, V, jnp.minimum(s.half_width, a),
                                                       jnp.maximum(s.half_width, a))),
        value=full_model_value(s.resistance, s.resistance_dissipation, zeta),
    )


