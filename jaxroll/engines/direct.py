r"""Direct Fourier-series rolling resistance ([ZG] section 4): periodic series and aperiodic limit.

With a stationary pressure ``p`` (:mod:`jaxroll.engines.pressure`) whose transform is ``P S(q r_c)``,
and the layer compliance ``T(q_x, q_y)`` (:func:`jaxroll.engines.layer.surface_compliance`, displacement
into the layer per unit pressure of the mode ``e^{i(q_x x + q_y y)}``, with the mode-modulus
sign fix), the rolling resistance ``R_r = -int p du/dx dA`` is, by Parseval,

* **periodic** (period ``Lx x Ly``; [ZG] eqs. 26, 37, 42, 47)::

      R_r = (2 P^2 / (Lx Ly)) sum_{m >= 1} sum_{n = -N..N} q_x S(q r_c)^2 Im T(q_x, q_y),
      q_x = 2 pi m / Lx,  q_y = 2 pi n / Ly,  m = 1..N,

  which is eq. 26 with ``sigma_mn = P S / (Lx Ly)`` and equals eq. 37 (Hertz: ``S = 3(sin x -
  x cos x)/x^3``, so ``2 P^2 . 2 pi . 9 . 2 = 2 pi (6P)^2 . 2``: the ``n >= 1`` terms doubled,
  ``n = 0`` once), eq. 42 (``(96 P)^2``) and eq. 47 (``(16 P)^2``);
* **aperiodic** (``Lx, Ly -> inf``; the sums become integrals with ``dq_x dq_y = 4 pi^2 /
  (Lx Ly)``)::

      R_r = (P^2 / (2 pi^2)) int_{q_x > 0} q_x S(q r_c)^2 Im T(q, q_x) d^2 q
          = (P^2 / (pi^2 r_c^3)) int_0^inf x^2 S(x)^2 Phi(x / r_c) dx,
      Phi(q) = int_0^{pi/2} cos(theta) Im T(q cos theta, q sin theta) d theta;

* **cylinder** ([ZG] eq. 29, load ``P'`` per unit length, half-width ``a``)::

      periodic:  R_r = (2 P'^2 / L) sum_{m=1..N} q_m S(q_m a)^2 Im T(q_m, 0)
      aperiodic: R_r = (P'^2 / (pi a^2)) int_0^inf x S(x)^2 Im T(x/a, 0) dx.

The pressure model (:func:`select_pressure`): ``pressure="auto"`` takes Jaffar's thick model
for ``gamma = r_c/H <= 0.9``, the thin model beyond ``gamma_thick = 1.15``, and a smooth blend
of the two in between (one radius, one evaluation of ``T``; flagged ``outside_pressure_model``
like everything with ``0.9 < gamma < 10``), so the value is continuous and C1 in every input.

Periodic and aperiodic results are different physics at high speed: the periodic series is a
train of rollers a period apart, and when ``V tau > ~L`` the layer does not recover between
passes (-2 to -6 % at 1-10 m/s for L = 0.2 m, docs/conventions.md sec. 6). The aperiodic value is the
single roller on an infinite layer and is the default.

Quadrature of the aperiodic integrals (all static, vectorised; ~6600 ``G*`` values and ~130
layer closed-form values per sphere case at the default rtol 1e-4):

* ``x = q r_c``: Gauss-Legendre panels in ``ln x`` (one per decade, ``n`` nodes) from
  ``x_lo`` to ``x_hi``; the oscillating factor ``x^2 S(x)^2`` is integrated *into the weights*
  (product integration: weights ``int l_j(ln x) x^2 S^2 dx`` are precomputed once with NumPy on
  a fine grid; above ``x = 1e3`` with the oscillation-averaged ``S^2``), so only the smooth
  factor ``Phi`` is sampled. Below ``x_lo``: the integrand is taken as ``x^2 Phi(x_lo)``;
  above ``x_hi``: the envelope ``C x^{-p}`` of ``S^2`` times the local power law of ``Phi``
  (the analytic tail).
* angle: ``u = cos theta``, ``Phi = int_0^1 [Im T / u] u^2 / sqrt(1-u^2) du``, Gauss-Legendre
  panels in ``ln u`` from ``u_lo`` to 1 with product weights (the ``1/sqrt`` end singularity
  is in the weights).
* quasi-static layers (``rho = 0``) use the exact factorisation ``T = T_1(q)/G_m(q_x V)``
  (:func:`_im_t_fast`); layers with inertia call ``surface_compliance`` on the whole grid
  (about 50 times slower).
* truncation estimate: from the rules that drop the end nodes of every panel (``n - 2`` and
  ``n - 4`` interior nodes; ``err ~ d2^2/d4``), in both directions, plus both analytic end
  corrections. It is an order-of-magnitude indicator (tests/test_direct.py: it bounds the
  worst error of the validation set; single cases can be under-estimated ~3x).
* presets (:func:`settings_for_rtol`), worst measured error against a 1e-8 rule over
  H = 30 mm, 2 mm, 10 um and V = 1e-4..1 m/s: rtol 1e-3: 8e-4; 1e-4: 7e-6; 1e-6: 5e-8.

Error against the full model (:func:`approximation_error`, ``RollingResult.approximation``):
the stationary-pressure assumption and the contact size, estimated from the contact sizes at the
relaxed, rolling-frequency and glassy moduli and the material's stiffening across the contact's
frequencies; :func:`plane_strain_ratio` serves the slices' estimate.

Deviations from paper: the mode modulus is ``conj(G*(q_x V))`` (inside ``surface_compliance``);
eq. 19's cases are swapped (the nonzero case is ``m1 + m2 = 0`` and ``n1 + n2 = 0``);
eq. 47 uses the compressible ``T``.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._numerics import as_float, check_input, roller_inputs, where_safe
from .layer import Layer, inertia_ratio, single_layer, static_compliance, surface_compliance
from .stack import stack_compliance
from ..materials.material import complex_modulus, storage_modulus
from .pressure import (
    PRESSURE_MODELS,
    THICK_MAX_GAMMA,
    THIN_MIN_GAMMA,
    _ENVELOPE,
    _envelope_np,
    _transform_np,
    contact_radius,
    pressure_transform,
)
from ..result import RESULTS, RollingResult, first_failure
from ..grids import APPROXIMATION_LONG_WAVES, loss_beyond_calibration

__all__ = ["direct_rolling_resistance", "select_pressure", "QuadratureSettings"]


# --------------------------------------------------------------------------------------
# product-integration weights (NumPy, cached, static)

@dataclasses.dataclass(frozen=True)
class QuadratureSettings:
    """Static resolution of the aperiodic quadrature (see module docstring).

    Attributes:
        n: Gauss-Legendre nodes per panel in ``ln x`` (``x = q r_c``).
        n_u: Gauss-Legendre nodes per panel in ``ln u`` (``u = cos theta``; spheres only).
        x_lo, x_hi: range of ``x`` sampled; ``x_decades_per_panel``: panel width.
        u_lo: smallest ``u`` sampled; ``u_decades_per_panel``: panel width.
    """

    n: int = 12
    n_u: int = 10
    x_lo: float = 1e-5
    x_hi: float = 1e6
    x_decades_per_panel: float = 1.0
    u_lo: float = 1e-5
    u_decades_per_panel: float = 1.0


def settings_for_rtol(rtol: float) -> QuadratureSettings:
    """Resolution preset reaching relative accuracy ``rtol`` (measured on the validation
    cases of tests/test_direct.py: the worst error is 10-40 times below ``rtol``)."""
    rtol = float(rtol)
    if rtol >= 1e-3:
        return QuadratureSettings(n=8, n_u=8)
    if rtol >= 1e-4:
        return QuadratureSettings(n=12, n_u=10)
    if rtol >= 1e-6:
        return QuadratureSettings(n=16, n_u=14)
    return QuadratureSettings(n=16, n_u=16, x_decades_per_panel=0.5, u_decades_per_panel=0.5, x_lo=1e-7,
                              x_hi=1e8, u_lo=1e-8)


def _panels(lo, hi, decades_per_panel):
    if lo < _X_ENVELOPE < hi:  # a panel edge at _X_ENVELOPE
        return np.concatenate([_panels(lo, _X_ENVELOPE, decades_per_panel)[:-1],
                               _panels(_X_ENVELOPE, hi, decades_per_panel)])
    n_p = max(1, int(math.ceil((math.log10(hi) - math.log10(lo)) / decades_per_panel - 1e-9)))
    return np.linspace(math.log(lo), math.log(hi), n_p + 1)


def _lagrange_matrix(nodes, t):
    """``L[j, k] = l_j(t_k)`` for the Lagrange basis on ``nodes``."""
    L = np.ones((len(nodes), len(t)))
    for j, tj in enumerate(nodes):
        for k, tk in enumerate(nodes):
            if k != j:
                L[j] *= (t - tk) / (tj - tk)
    return L


def _product_weights(edges, n, sub_fn):
    """Nodes (in the log variable) and product weights on Gauss-Legendre panels.

    ``sub_fn(a, b)`` returns fine quadrature points ``t_k`` and weights ``w_k`` (including the
    Jacobian and the weight function) on the panel ``[a, b]``. Returns ``(t, W)`` with ``W`` of
    shape ``(3, n_nodes)``: the weights of the interpolant on all ``n`` nodes of each panel,
    and of the lower-degree interpolants on its ``n - 2`` and ``n - 4`` interior nodes (for
    the error estimate; zero weight on the dropped nodes).
    """
    g, _ = np.polynomial.legendre.leggauss(n)
    nodes, W = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        tn = 0.5 * (a + b) + 0.5 * (b - a) * g
        tk, wk = sub_fn(a, b)
        w3 = np.zeros((3, n))
        for drop in range(3):
            keep = slice(drop, n - drop)
            w3[drop, keep] = _lagrange_matrix(tn[keep], tk) @ wk
        nodes.append(tn)
        W.append(w3)
    return np.concatenate(nodes), np.concatenate(W, axis=1)


#: Above this ``x`` the product weights use the mean of ``S^2`` over its oscillation (the
#: neglected oscillating part contributes ~1/x of those panels, which carry < 1e-3 of R_r).
_X_ENVELOPE = 1e3


def _x_sub(model, geometry, power):
    """Fine quadrature of ``x^power S(x)^2 dx`` on a panel in ``ln x`` (sub-intervals of
    length <= 0.25 in ``x`` and <= 0.05 in ``ln x``, 16-point GL each; beyond ``_X_ENVELOPE``
    the oscillation-averaged ``S^2`` on 64 sub-intervals in ``ln x``)."""
    g, w = np.polynomial.legendre.leggauss(16)

    def sub(a, b):
        xa, xb = math.exp(a), math.exp(b)
        if xa >= _X_ENVELOPE * (1 - 1e-12):
            e = np.linspace(a, b, 65)
            t = (0.5 * (e[:-1] + e[1:])[:, None] + 0.5 * np.diff(e)[:, None] * g).ravel()
            wt = (0.5 * np.diff(e)[:, None] * w).ravel()
            x = np.exp(t)
            return t, wt * x ** (power + 1) * _envelope_np(x, model, geometry)
        m = max(4, int(math.ceil((xb - xa) / 0.25)), int(math.ceil((b - a) / 0.05)))
        # sub-intervals uniform in ln x below x ~ 1, uniform in x above
        if xb <= 1.0:
            e = np.linspace(a, b, m + 1)
            t = (0.5 * (e[:-1] + e[1:])[:, None] + 0.5 * np.diff(e)[:, None] * g).ravel()
            wt = (0.5 * np.diff(e)[:, None] * w).ravel()
            x = np.exp(t)
            return t, wt * x ** (power + 1) * _transform_np(x, model, geometry) ** 2
        e = np.linspace(xa, xb, m + 1)
        x = (0.5 * (e[:-1] + e[1:])[:, None] + 0.5 * np.diff(e)[:, None] * g).ravel()
        wx = (0.5 * np.diff(e)[:, None] * w).ravel()
        return np.log(x), wx * x**power * _transform_np(x, model, geometry) ** 2

    return sub


def _u_sub():
    """Fine quadrature of ``u^2/sqrt(1-u^2) du = cos^2(theta) d theta`` on a panel in ``ln u``."""
    g, w = np.polynomial.legendre.leggauss(64)

    def sub(a, b):
        th_a, th_b = math.acos(min(1.0, math.exp(b))), math.acos(math.exp(a))
        e = np.linspace(th_a, th_b, 9)
        th = (0.5 * (e[:-1] + e[1:])[:, None] + 0.5 * np.diff(e)[:, None] * g).ravel()
        wt = (0.5 * np.diff(e)[:, None] * w).ravel()
        u = np.cos(th)
        return np.log(u), wt * u * u

    return sub


@functools.lru_cache(maxsize=None)
def _x_rule(model, geometry, settings: QuadratureSettings):
    power = 2 if geometry == "sphere" else 1
    edges = _panels(settings.x_lo, settings.x_hi, settings.x_decades_per_panel)
    t, W = _product_weights(edges, settings.n, _x_sub(model, geometry, power))
    return np.exp(t), W


@functools.lru_cache(maxsize=None)
def _u_rule(settings: QuadratureSettings):
    edges = _panels(settings.u_lo, 1.0, settings.u_decades_per_panel)
    t, W = _product_weights(edges, settings.n_u, _u_sub())
    # below u_lo: Im T / u taken constant, int_0^{u_lo} u^2 du = u_lo^3 / 3 (on the first node)
    W[0, 0] += settings.u_lo**3 / 3.0
    W[1, 1] += settings.u_lo**3 / 3.0
    W[2, 2] += settings.u_lo**3 / 3.0
    return np.exp(t), W


# --------------------------------------------------------------------------------------
# pressure-model selection

#: The ``"auto"`` pressure blends Jaffar's thick model into the thin one while the thick
#: model's ``gamma`` rises from :data:`THICK_MAX_GAMMA` (0.9) to this value, below the largest
#: ``gamma`` of Jaffar's law (``gamma_max`` = 1.2035 at ``nu = 0.5``, more for ``nu < 0.5``).
BLEND_END_GAMMA = 1.15


def _thick_weight(g_k, exists):
    """Weight of the thick model in the ``"auto"`` blend: 1 for ``g_k <= 0.9``, 0 from
    ``BLEND_END_GAMMA`` on (and where Jaffar's law has no solution), the quintic smoothstep
    (C2) in between. ``g_k`` is the thick model's own ``gamma``, smooth in every input below
    ``gamma_max``, so the weight is too."""
    t = jnp.clip((g_k - THICK_MAX_GAMMA) / (BLEND_END_GAMMA - THICK_MAX_GAMMA), 0.0, 1.0)
    return jnp.where(exists, 1.0 - t * t * t * (10.0 - 15.0 * t + 6.0 * t * t), 0.0)


def _blend(w, a, b):
    """``w a + (1 - w) b``: the one place where the two models of ``"auto"`` are mixed
    (exactly ``a`` where ``w = 1`` and ``b`` where ``w = 0``, bit for bit)."""
    return jnp.where(w == 1.0, a, jnp.where(w == 0.0, b, w * a + (1.0 - w) * b))


def select_pressure(material, layer, radius, load, *, pressure="auto", geometry="sphere", modulus="static",
                    speed=None):
    """Pressure model(s), contact radius and validity for ``pressure`` (static string).

    ``"auto"``: Jaffar's thick model for ``gamma <= 0.9`` ([ZG] 4.3; always on a half-space),
    the thin model (``"thin"`` for ``nu = 0.5``, ``"thin-compressible"`` for ``nu < 0.5``)
    beyond the band below, both valid. ``valid`` is True for thick with ``gamma <= 0.9`` and
    thin with ``gamma >= 10`` (:data:`jaxroll.engines.pressure.THIN_MIN_GAMMA`); in between ([ZG] 4.5)
    no model applies and the result is flagged ``outside_pressure_model``.

    The blend: Jaffar's law has no solution beyond ``gamma_max`` (1.2 for spheres at
    ``nu = 0.5``), so a plain switch there made ``R_r`` jump by 20-80 % (docs/conventions.md
    sec. 5). Instead the thick model's weight ``w`` falls smoothly (C2) from 1 to 0 while its
    own ``gamma_thick`` rises from 0.9 to :data:`BLEND_END_GAMMA` (1.15, below ``gamma_max``
    for every ``nu``; the cylinder's Hertz model always exists): the contact radius is
    ``w r_thick + (1 - w) r_thin`` and the rolling resistance is ``w R_thick + (1 - w)
    R_thin``, both shapes taken at that one radius (one evaluation of the layer compliance).
    The value is continuous and C1 in every input (``modulus="dynamic"``: only continuous where
    the *static* Jaffar radius that sets its frequency does not exist; that radius is clamped);
    ``w = 0`` wherever the thick solution does not exist. ``regime`` names the thick model
    wherever ``w > 0``.

    Returns:
        ``(models, r_c, gamma, code, valid, weight)``: the tuple of static model names involved,
        contact radius [m], ``gamma = r_c/H``, regime code (:data:`jaxroll.result.REGIMES`),
        validity, and ``weight``, the weight of ``models[0]`` (``1 - weight`` that of
        ``models[1]``, if any).
    """
    R, P = as_float(radius), as_float(load)
    layer = single_layer(layer)  # a Stack: its equivalent layer (the pressure models are single-layer laws)
    H = as_float(layer.H)
    inf_H = jnp.isinf(H)
    Hf = where_safe(inf_H, 1.0, H)
    thin_name = "thin" if layer.nu >= 0.5 else "thin-compressible"
    kw = dict(geometry=geometry, modulus=modulus, speed=speed)

    def gamma_of(r):
        return jnp.where(inf_H, 0.0, r / Hf)

    if pressure == "auto":
        r_k, exists = contact_radius(material, layer, R, P, model="thick", **kw)
        g_k = gamma_of(r_k)  # 0 on a half-space: w = 1
        w = _thick_weight(g_k, exists)
        # the thin radius needs finite H
        layer_f = eqx.tree_at(lambda l: l.H, layer, Hf)
        r_t, _ = contact_radius(material, layer_f, R, P, model=thin_name, **kw)
        r_c = _blend(w, r_k, r_t)
        code = jnp.where(w > 0.0, PRESSURE_MODELS["thick"], PRESSURE_MODELS[thin_name])
        valid = jnp.where(w == 1.0, g_k <= THICK_MAX_GAMMA, (w == 0.0) & (gamma_of(r_t) >= THIN_MIN_GAMMA))
        return ("thick", thin_name), r_c, gamma_of(r_c), code, valid, w
    if pressure not in PRESSURE_MODELS:
        raise ValueError(f"unknown pressure {pressure!r}; choose from {('auto',) + tuple(PRESSURE_MODELS)}")
    r_c, exists = contact_radius(material, layer, R, P, model=pressure, **kw)
    gamma = gamma_of(r_c)
    if pressure == "thick":
        valid = exists & (gamma <= THICK_MAX_GAMMA)
    else:
        valid = gamma >= THIN_MIN_GAMMA
    code = jnp.full(jnp.shape(r_c), PRESSURE_MODELS[pressure])
    return (pressure,), r_c, gamma, code, valid, jnp.ones(jnp.shape(r_c))


def _mix(w, outs):
    """Blend per-model ``(value, err)`` pairs with the thick weight ``w`` (see :func:`_blend`)."""
    if len(outs) == 1:
        return outs[0]
    (va, ea), (vb, eb) = outs
    return _blend(w, va, vb), _blend(w, ea, eb)


# --------------------------------------------------------------------------------------
# the sums / integrals (scalar inputs; vmap for batches)

def _im_t(layer, material, qx, qy, V):
    return jnp.imag(surface_compliance(layer, material, qx, qy, V))


def _im_t_fast(layer, material, q, qx, qy, V):
    """``Im T(q_x, q_y)`` for broadcastable ``q = |(q_x, q_y)|``, ``q_x``, ``q_y``.

    Quasi-static layers (``rho = 0``; checked at run time if ``rho`` is traced) use the exact
    factorisation ``T(q, q_x) = T_1(q) / G_m(q_x V)``, ``T_1`` the compliance at unit modulus
    (:func:`jaxroll.engines.layer.static_compliance`): the layer closed
    form is evaluated on the shape of ``q`` only and ``G*`` on the shape of ``q_x`` only, so a
    tensor grid costs a product of two small evaluations. Otherwise
    :func:`jaxroll.engines.layer.surface_compliance` on the broadcast grid.
    """

    def factorised(_):
        t1 = static_compliance(layer, q)
        g = complex_modulus(material, qx * V)
        # Im(1/G_m) = Im(1/conj G*) = G''/|G*|^2 (no complex division)
        g_re, g_im = jnp.real(g), jnp.imag(g)
        return t1 * (g_im / (g_re * g_re + g_im * g_im))

    def general(_):
        shape = jnp.broadcast_shapes(jnp.shape(q), jnp.shape(qx), jnp.shape(qy))
        return _im_t(layer, material, jnp.broadcast_to(qx, shape), jnp.broadcast_to(qy, shape), V)

    if not isinstance(layer, Layer):  # a Stack: the plies' moduli do not factor out; its real
        # propagators are evaluated on the shape of q only
        return jnp.imag(stack_compliance(layer, qx, qy, V, q=q))
    rho = layer.rho
    if not isinstance(rho, jax.core.Tracer):
        return factorised(None) if bool(np.all(np.asarray(rho) == 0.0)) else general(None)
    # traced density (e.g. a Layer built inside jit): decide at run time
    return jax.lax.cond(jnp.all(rho == 0.0), factorised, general, None)


def _im_t_grid(layer, material, q, u, V):
    """``Im T(q u, q sqrt(1-u^2))`` on the tensor grid ``q[:, None]``, ``u[None, :]``."""
    qq = q[:, None]
    return _im_t_fast(layer, material, qq, qq * u[None, :], qq * jnp.sqrt(1.0 - u * u)[None, :], V)


def _richardson(values):
    """Error estimate from the values of the full rule and of the two lower-degree rules
    (geometric convergence: ``err ~ d2^2 / d4``, capped at ``d2``)."""
    d2 = jnp.abs(values[0] - values[1])
    d4 = jnp.abs(values[0] - values[2])
    ok = d4 > d2
    return jnp.where(ok, d2 * d2 / where_safe(ok, d4, 1.0), d2)


def _aperiodic_sphere(material, layer, V, P, r_c, models, weight, settings):
    x = _x_rule(models[0], "sphere", settings)[0]                     # the same nodes for every model
    u, Wu = _u_rule(settings)
    q = jnp.asarray(x) / r_c                                          # (Nx,)
    uu = jnp.asarray(u)                                               # (Nu,)
    h = _im_t_grid(layer, material, q, uu, V) / uu[None, :]           # Im T / u, (Nx, Nu)
    phi3 = h @ jnp.asarray(Wu).T                                       # (Nx, 3): Phi(q_i)
    phi = phi3[:, 0]
    lo = settings.x_lo**3 / 3.0 * phi[0]   # analytic low end in x
    scale = P * P / (math.pi**2 * r_c**3)

    def one(model):
        Wx = jnp.asarray(_x_rule(model, "sphere", settings)[1])      # (3, Nx)
        C, p = _ENVELOPE[("sphere", model)]
        tail = _power_tail(x[-2:], phi[-2:], C, p, 2.0, settings.x_hi)   # analytic high end
        core_x = Wx @ phi                      # full u rule, three x rules
        core_u = phi3.T @ Wx[0]                # full x rule, three u rules
        value = scale * (core_x[0] + lo + tail)
        err = scale * (_richardson(core_x) + _richardson(core_u) + jnp.abs(lo) + jnp.abs(tail))
        return value, err

    return _mix(weight, [one(m) for m in models])


def _power_tail(x2, g2, C, p, power, x_hi):
    """``int_{x_hi}^inf x^power C x^{-p} g(x) dx`` with ``g`` extrapolated as a power law
    through its last two samples (exponent clamped to [-4, 0.5])."""
    g_pos = (g2[0] > 0) & (g2[1] > 0)
    g0 = where_safe(g_pos, g2[0], 1.0)
    g1 = where_safe(g_pos, g2[1], 1.0)
    s = jnp.clip(jnp.log(g1 / g0) / math.log(x2[1] / x2[0]), -4.0, 0.5)
    e = power - p + s + 1.0          # exponent of x in the antiderivative, < 0
    val = C * g1 * x2[1] ** (-s) * x_hi**e / (-e)
    return jnp.where(g_pos, val, 0.0)


def _aperiodic_cylinder(material, layer, V, P, a, models, weight, settings):
    x = _x_rule(models[0], "cylinder", settings)[0]
    q = jnp.asarray(x) / a
    g = _im_t_fast(layer, material, q, q, jnp.zeros_like(q), V)
    lo, lo_err = _low_x_cylinder(material, layer, V, a, settings.x_lo)
    scale = P * P / (math.pi * a * a)

    def one(model):
        Wx = jnp.asarray(_x_rule(model, "cylinder", settings)[1])
        C, p = _ENVELOPE[("cylinder", model)]
        tail = _power_tail(x[-2:], g[-2:], C, p, 1.0, settings.x_hi)
        core = Wx @ g
        return scale * (core[0] + lo + tail), scale * (_richardson(core) + lo_err + jnp.abs(tail))

    return _mix(weight, [one(m) for m in models])


#: Gauss-Legendre nodes (in ln x) of the cylinder's low-wavenumber part, and the most decades
#: below ``x_lo`` it spans: it covers ``V t_max/a`` up to ``1e-3 x 10^9 / x_lo``, i.e. 1e11.
_LOW_X_NODES, LOW_X_DECADES = 64, 9.0


def _low_x_cylinder(material, layer, V, a, x_lo):
    """``int_0^{x_lo} x g(x/a) dx`` (``S = 1`` there) and an error estimate, for the cylinder.

    In 2D the dissipation of a slow retardation time ``lam`` peaks at ``q V lam ~ 1``, i.e.
    ``x = q a ~ a/(V lam)``: for ``V t_max/a > ~1e4`` that is below ``x_lo`` and the integrand
    is not constant there (a logarithmic contribution the panels never see). So ``[x_floor,
    x_lo]`` with ``x_floor = 1e-3 a/(V t_max)`` (where the slowest peak has passed; clipped to
    ``LOW_X_DECADES`` decades) is integrated by Gauss-Legendre in ``ln x``; below ``x_floor``
    the integrand is taken as ``x g(x_floor)``. Error estimate: the difference to the
    half-order rule plus the constant-extrapolation term.
    """
    t_max = material.longest_time()
    reach = V * t_max / a
    ln_lo = math.log(x_lo)
    ln_floor = jnp.clip(jnp.log(1e-3 / where_safe(reach > 0, reach, 1.0)), ln_lo - LOW_X_DECADES * math.log(10), ln_lo)
    ln_floor = jnp.where(reach > 0, ln_floor, ln_lo)
    half = 0.5 * (ln_lo - ln_floor)

    def rule(n):
        t, w = np.polynomial.legendre.leggauss(n)
        xs = jnp.exp(0.5 * (ln_lo + ln_floor) + half * jnp.asarray(t))
        q = xs / a
        gs = _im_t_fast(layer, material, q, q, jnp.zeros_like(q), V)
        return half * jnp.sum(jnp.asarray(w) * xs * xs * gs), gs

    full, _ = rule(_LOW_X_NODES)
    coarse, _ = rule(_LOW_X_NODES // 2)
    x_floor = jnp.exp(ln_floor)
    q_floor = jnp.reshape(x_floor / a, (1,))
    g_floor = _im_t_fast(layer, material, q_floor, q_floor, jnp.zeros_like(q_floor), V)[0]
    below = 0.5 * x_floor * x_floor * g_floor
    return full + below, jnp.abs(full - coarse) + jnp.abs(below)


def _periodic_sphere(material, layer, V, P, r_c, models, weight, Lx, Ly, N):
    m = jnp.arange(1, N + 1, dtype=jnp.float64)
    n = jnp.arange(0, N + 1, dtype=jnp.float64)
    qx = (2.0 * math.pi / Lx) * m[:, None]
    qy = (2.0 * math.pi / Ly) * n[None, :]
    q = jnp.sqrt(qx * qx + qy * qy)
    im_t = _im_t_fast(layer, material, q, qx, qy, V)
    wn = jnp.where(n == 0, 1.0, 2.0)[None, :]            # +-n folded (T depends on |q_y|)
    outer = jnp.maximum(m[:, None], n[None, :]) > 0.5 * N
    scale = 2.0 * P * P / (Lx * Ly)

    def one(model):
        S = pressure_transform(q * r_c, model=model, geometry="sphere")
        terms = qx * S * S * im_t * wn
        return scale * jnp.sum(terms), jnp.abs(scale * jnp.sum(jnp.where(outer, terms, 0.0)))

    return _mix(weight, [one(mod) for mod in models])


def _periodic_cylinder(material, layer, V, P, a, models, weight, L, N):
    m = jnp.arange(1, N + 1, dtype=jnp.float64)
    qx = (2.0 * math.pi / L) * m
    im_t = _im_t_fast(layer, material, qx, qx, jnp.zeros_like(qx), V)
    scale = 2.0 * P * P / L

    def one(model):
        S = pressure_transform(qx * a, model=model, geometry="cylinder")
        terms = qx * S * S * im_t
        return scale * jnp.sum(terms), jnp.abs(scale * jnp.sum(jnp.where(m > 0.5 * N, terms, 0.0)))

    return _mix(weight, [one(mod) for mod in models])


# --------------------------------------------------------------------------------------
# public

def direct_rolling_resistance(material, layer, *, radius, load, speed, geometry="sphere", pressure="auto",
                              period=None, n_terms=None, rtol=1e-4, modulus="static",
                              quadrature: QuadratureSettings | None = None) -> RollingResult:
    """Rolling resistance by the direct Fourier-series method of [ZG] section 4.

    Args:
        material: a material of :mod:`jaxroll.materials.material` (parameters are differentiable).
        layer: :class:`jaxroll.engines.layer.Layer` (``H`` [m], ``rho``, static ``nu``).
        radius: roller radius ``R`` [m] (scalar).
        load: ``P`` [N] for a sphere, ``P'`` [N/m] for a cylinder (scalar).
        speed: rolling speed ``V`` [m/s], ``>= 0`` (scalar).
        geometry: ``"sphere"`` or ``"cylinder"`` (static).
        pressure: ``"auto"``, ``"thick"``, ``"thin"`` or ``"thin-compressible"`` (static; see
            :func:`select_pressure`).
        period: ``None`` (default): the aperiodic limit (single roller, infinite layer).
            Otherwise the period [m]: ``(Lx, Ly)`` or a scalar (``Lx = Ly``) for spheres, a
            scalar ``L`` for cylinders; with ``n_terms``.
        n_terms: number of Fourier terms ``N`` per direction of the periodic series
            (``m = 1..N``, ``n = -N..N``; [ZG] eq. 37 with N terms). Static int.
        rtol: target relative accuracy of the aperiodic quadrature (static; selects
            :func:`settings_for_rtol` unless ``quadrature`` is given).
        modulus: modulus used for the contact radius (see :func:`jaxroll.engines.pressure.contact_radius`).
        quadrature: explicit :class:`QuadratureSettings` (static), overriding ``rtol``.

    Returns:
        :class:`jaxroll.result.RollingResult`: ``value`` [N or N/m], ``contact_radius`` [m],
        ``gamma``, ``regime`` (pressure-model code), ``result`` (``outside_pressure_model``
        outside the model's validity range; ``valid`` is ``result == 0``), ``truncation``
        (estimated relative error: quadrature
        estimate for the aperiodic limit; for the periodic series the share of the outer
        half-shell ``max(m, |n|) > N/2``, a rough measure of the terms left out),
        ``approximation`` (the estimated error against the full model,
        :func:`approximation_error`; the front doors flag a result above 10 %).
    """
    if geometry not in ("sphere", "cylinder"):
        raise ValueError(f"unknown geometry {geometry!r}; choose 'sphere' or 'cylinder'")
    R, P, V = roller_inputs(radius, load, speed)
    if isinstance(layer, Layer):  # (a Stack's plies are checked by Stack.checked)
        H = as_float(layer.H)
        H = check_input(H, ~(H > 0), "layer thickness H must be positive (jnp.inf for a half-space)")
        layer = eqx.tree_at(lambda l: l.H, layer, H)

    if period is None and n_terms is not None:
        raise ValueError("n_terms needs a period (the aperiodic limit is the default)")
    if period is not None and (n_terms is None or int(n_terms) < 1):
        raise ValueError("a periodic series needs n_terms >= 1")
    settings = quadrature if quadrature is not None else settings_for_rtol(rtol)
    run = functools.partial(_series_value, material, layer, R, P, V, geometry=geometry, pressure=pressure,
                            period=period, n_terms=n_terms, settings=settings)
    value, err, r_c, gamma, code, valid = run(modulus)
    approx = approximation_error(material, layer, V, value, r_c, gamma, run, modulus)

    pos = value > 0
    trunc = jnp.where(pos, err / where_safe(pos, value, 1.0), jnp.where(err > 0, jnp.inf, 0.0))
    return RollingResult(value=value, contact_radius=r_c, gamma=gamma, regime=code, truncation=trunc,
                         result=first_failure((~valid, RESULTS.outside_pressure_model)), approximation=approx)


def _series_value(material, layer, R, P, V, modulus, *, geometry, pressure, period, n_terms, settings):
    """``(value, err, r_c, gamma, code, valid)`` of the direct series or integral with the contact
    radius of ``modulus`` (see :func:`direct_rolling_resistance`)."""
    models, r_c, gamma, code, valid, weight = select_pressure(
        material, layer, R, P, pressure=pressure, geometry=geometry, modulus=modulus, speed=V
    )
    if period is None:
        if geometry == "sphere":
            value, err = _aperiodic_sphere(material, layer, V, P, r_c, models, weight, settings)
        else:
            value, err = _aperiodic_cylinder(material, layer, V, P, r_c, models, weight, settings)
        return value, err, r_c, gamma, code, valid
    N = int(n_terms)
    if geometry == "sphere":
        Lx, Ly = (period, period) if np.ndim(period) == 0 else tuple(period)
        Lx, Ly = as_float(Lx), as_float(Ly)
        Lmin = jnp.minimum(Lx, Ly)
    else:
        if np.ndim(period) != 0:
            raise ValueError("a cylinder's period is a scalar L [m]")
        Lx = Lmin = as_float(period)
    r_c = eqx.error_if(r_c, ~(2.0 * r_c < Lmin),
                       "contact radius larger than half the period: the contact does not fit the period")
    if geometry == "sphere":
        value, err = _periodic_sphere(material, layer, V, P, r_c, models, weight, Lx, Ly, N)
    else:
        value, err = _periodic_cylinder(material, layer, V, P, r_c, models, weight, Lx, N)
    return value, err, r_c, gamma, code, valid



# --------------------------------------------------------------------------------------
# the method's error against the full model

#: Calibration of :func:`approximation_error` (see its docstring for the data): the stationary-
#: pressure error is ``-(c_thick + (c_thin - c_thick) gamma/(1 + gamma)) ln(G'(k_hi w)/G'(w/k_lo))``
#: with ``w = V/r_dynamic``, plus a margin for what the model leaves out.
STATIONARY_THICK, STATIONARY_THIN = 0.3, 0.55
BAND_LOW, BAND_HIGH = 1.0, 10.0
DIRECT_MARGIN = 0.03


def stationary_pressure_error(material, V, r, gamma):
    """Estimated relative error [-] (negative: the direct method is low) of a stationary pressure
    against the rolling contact, at the contact radius ``r`` [m] and ``gamma = r/H``.

    Physics: the rolling pressure shifts and narrows where the material stiffens across the
    frequencies the contact excites, ``omega ~ q V`` for ``q r ~ 1..10``; the stationary pressure
    misses that. The error grows with the stiffening over that band, ``ln(G'(k_hi V/r) /
    G'(V/(k_lo r)))`` (for a standard linear solid at most ``ln(1 + f)``, reached near the
    ``R_r`` peak; it vanishes at low and high speed, where the contact is elastic), and is larger
    on thin layers, whose pressure is more sensitive to the modulus (``r ~ G^(-1/6)`` rather than
    ``G^(-1/3)``). Calibrated on the full 3D model (see :func:`approximation_error`)."""
    omega = V / r
    g_hi = storage_modulus(material, BAND_HIGH * omega)
    g_lo = storage_modulus(material, omega / BAND_LOW)
    stiffening = jnp.log(g_hi / g_lo)
    c = STATIONARY_THICK + (STATIONARY_THIN - STATIONARY_THICK) * gamma / (1.0 + gamma)
    return jnp.expm1(-c * stiffening)


#: Calibration of :func:`inertia_error` (see its docstring for the data).
INERTIA_WEIGHT = 1.0


def inertia_error(material, layer, V, r):
    """Estimated relative error [-] of the direct method, whose elastic contact radius ignores
    inertia, on a layer with inertia (``rho > 0``; a :class:`~jaxroll.engines.stack.Stack`: its
    slowest medium), at the contact size ``r`` [m]: ``INERTIA_WEIGHT m/(1 - m)``, ``m = rho V^2 /
    G'(V/r)`` (:func:`jaxroll.engines.layer.inertia_ratio`: the squared ratio of the speed to
    the shear-wave speed at the contact's frequency).

    Physics: inertia softens the layer at the contact's wavelengths (the compliance of a moving
    load grows with ``m``, singular at the Rayleigh speed, ``m`` ~ 0.91 on the relaxed
    incompressible half-space), so the rolling contact grows and its loss with it, while the
    direct method keeps the contact of the layer without inertia (its compliance integrals do
    include it); ``m/(1 - m)`` fits the measured error up to 0.8 ``c_s``. Measured against the
    full model (``benchmarks/approx_validity.py inertia``, SLS G0 = 3 MPa, ``rho`` = 1000 kg/m^3, ``V`` =
    0.05..0.8 of ``sqrt(G0/rho)``): where the contact is relaxed (tau = 1 us) the direct method
    is high by 0.70-0.80 ``m/(1 - m)`` on the cylinder and ~0.55 on the sphere (+40 % and +29 %
    at 0.6 ``c_s``); where it is glassy (tau = 0.25 s) by at most a fifth of ``m/(1 - m)`` at the
    glassy modulus, so the weight 1 is conservative there. Zero without inertia. Not
    differentiated. The slices' estimate has no such term: its plane-strain part grows with
    inertia and covered the measured errors."""
    V, r = jax.lax.stop_gradient((V, r))
    material, layer = jax.lax.stop_gradient((material, layer))
    moving = (V > 0) & (r > 0)
    m = jnp.where(moving, inertia_ratio(material, layer, V, where_safe(moving, V, 1.0) / where_safe(moving, r, 1.0)),
                  0.0)
    below = m < 1.0
    return jnp.where(below, INERTIA_WEIGHT * m / where_safe(below, 1.0 - m, 1.0), jnp.inf)


def approximation_error(material, layer, V, value, r_c, gamma, run, modulus):
    """Estimated relative error ``|R_r / R_r,full - 1|`` [-] of the direct method against the full
    rolling-contact model, from what the method has (no contact solve):

    * the contact size: the full model's contact has the size of the elastic contact at the
      modulus of the rolling frequency (relaxed at low speed, glassy at high speed), which
      ``modulus="dynamic"`` gives (``G'(V/r_static)``: within 1.5 % of the full model's ``R_r``
      above the peak). A value with another radius (``"static"``: the relaxed modulus, ``"glassy"``
      or a number) is compared with the dynamic one, ``run("dynamic")`` (a second evaluation of
      the same series or integral);
    * the stationary pressure (:func:`stationary_pressure_error`): the rolling pressure is not the
      elastic one where the material stiffens across the contact's frequencies;
    * on a layer with inertia, :func:`inertia_error` at the dynamic contact size;
    * a margin :data:`DIRECT_MARGIN` for the rest;
    * ``inf`` where the loss factor over the contact's frequencies, from a decade below
      (:data:`jaxroll.grids.APPROXIMATION_LONG_WAVES`: the wake's long waves), exceeds the
      calibration's (:func:`jaxroll.grids.loss_beyond_calibration`).

    Calibrated on the full 3D model with its default grid (``benchmarks/approx_validity.py
    errors``: standard linear solids G0 = 3 MPa, tau = 0.25 s, f = 0.1..10 on a half-space and
    H = 0.2 m..2 mm (R = 2 cm, 30 and 100 N) and H = 10 um (R = 2000 m, 200 and 2000 N), and the
    shipped measured Prony material at -25..75 degC, V = 1e-4..10 m/s). Not differentiated
    (``stop_gradient``): it decides validity only.
    """
    value, r_c, gamma = (jax.lax.stop_gradient(x) for x in (value, r_c, gamma))
    if isinstance(modulus, str) and modulus == "dynamic":
        ratio, r_dyn, gamma_dyn = jnp.ones_like(value), r_c, gamma
    else:
        v_dyn, _, r_dyn, gamma_dyn, _, _ = (jax.lax.stop_gradient(x) for x in run("dynamic"))
        pos = v_dyn > 0
        ratio = jnp.where(pos, value / where_safe(pos, v_dyn, 1.0), 1.0)
    material, V = jax.lax.stop_gradient((material, V))
    moving = V > 0
    stationary = jnp.where(moving, stationary_pressure_error(material, where_safe(moving, V, 1.0), r_dyn, gamma_dyn),
                           0.0)
    estimate = jnp.abs(ratio * (1.0 + stationary) - 1.0) + inertia_error(material, layer, V, r_dyn) + DIRECT_MARGIN
    # beyond the calibration's loss factor (a loss-dominated contact rolls on a pressure far from any
    # stationary one; SLS f = 100 / 1000 on a 30 mm layer at 10 mm/s: 34 / 35 % low where the
    # estimate said 10 / 3.8 %): not valid; read from a decade below the contact's frequency (f = 146
    # above the peak: 18.5 / 26.6 % low where the estimate said 4.7 / 6.8 %; APPROXIMATION_LONG_WAVES)
    outside = loss_beyond_calibration(material, V, jnp.minimum(r_c, r_dyn), jnp.maximum(r_c, r_dyn),
                                      below=APPROXIMATION_LONG_WAVES)
    return jnp.where(outside, jnp.inf, estimate)


#: Exponent ``m`` of the line load ``(1 - (y/r)^2)^m`` carried by the plane ``y`` under each
#: stationary sphere pressure, and ``int_{-1}^{1} (1 - s^2)^m ds``: the section of each sphere
#: pressure at ``y`` is the cylinder pressure of the same model with half-width
#: ``sqrt(r^2 - y^2)`` (Hertz: a semi-ellipse; thin: ``(1 - x^2/a^2)^2``; thin compressible: a
#: parabola).
_SECTION_LOAD = {"thick": (1.0, 4.0 / 3.0), "thin": (2.5, 5.0 * math.pi / 16.0),
                 "thin-compressible": (1.5, 3.0 * math.pi / 8.0)}

#: Quadrature of :func:`plane_strain_ratio` (its result is an error indicator: 1e-3 is ample).
_RATIO_SETTINGS = settings_for_rtol(1e-3)


def plane_strain_ratio(material, layer, R, P, V, n_slices, modulus="dynamic"):
    """``R_r`` of the stationary sphere pressure dissipating in ``n_slices`` plane-strain slices
    over its ``R_r`` in the 3D layer [-], at the contact radius of ``modulus`` (as
    :func:`select_pressure`; default: the dynamic one).

    The stationary sphere pressure of each model is exactly a stack of the cylinder pressures
    of the same model (section half-width ``a = sqrt(r^2 - y^2)``, line load
    ``P (1 - y^2/r^2)^m / (r c_m)``), so the ratio isolates the slices' geometric assumption:
    a slice sees the plane-strain compliance ``T(|q_x|)`` where the sphere sees ``T(|q|)``. It
    exceeds 1 most where long waves dissipate: at high speed (``V tau > r``) on thick layers and
    half-spaces, where the plane-strain compliance ``~ 1/q_x`` keeps growing while the 3D one
    is capped by the contact width (the 2D loss grows like ``ln(V tau/r)``), and it falls below
    its low-speed value on thin layers. The slices' midpoint rule (``y_k = k dy``,
    ``dy = 2 r/n_slices``) is the slices' own.
    """
    settings = _RATIO_SETTINGS
    models, r, _, _, _, weight = select_pressure(material, layer, R, P, modulus=modulus, speed=V)
    sphere, _ = _aperiodic_sphere(material, layer, V, P, r, models, weight, settings)
    dy = 2.0 * r / n_slices
    k = jnp.arange((n_slices + 1) // 2, dtype=jnp.float64)
    s = k * dy / r
    a = r * jnp.sqrt(1.0 - s * s)
    fold = jnp.where(k == 0, 1.0, 2.0)  # the slices y < 0 by symmetry

    def stack(model):
        m, c = _SECTION_LOAD[model]
        line_load = P * (1.0 - s * s) ** m / (r * c)
        per_slice = jax.vmap(lambda p_k, a_k: _aperiodic_cylinder(material, layer, V, p_k, a_k, (model,), 1.0,
                                                                  settings)[0])(line_load, a)
        return jnp.sum(fold * per_slice) * dy

    slices = _blend(weight, *[stack(mdl) for mdl in models]) if len(models) == 2 else stack(models[0])
    pos = sphere > 0
    return jnp.where(pos, slices / where_safe(pos, sphere, 1.0), 1.0)
