"""Exact solutions and limits shared as oracles by the tests and by users.

All quantities in SI units: loads ``P`` [N] (sphere) or ``P'`` [N/m] (cylinder, per unit
length), radii and lengths [m], moduli [Pa], speeds [m/s], times [s]; rolling resistance
``R_r`` [N] (sphere) or [N/m] (cylinder). Frame and sign conventions follow docs/conventions.md sec. 3:
coordinates move with the roller, which travels toward ``+x``; ``x = 0`` lies below the
roller's centre; pressure ``p >= 0``; ``R_r > 0`` opposes the motion.

Contents
--------
- Elastic Hertz contacts: :func:`hertz_cylinder`, :func:`hertz_cylinder_pressure`
  (plane strain, ``E* = 2G/(1-nu)``), :func:`hertz_sphere`.
- Thin incompressible elastic layer under a cylinder (docs/validation.md sec. 1, [ZG] sec. 4.4):
  :func:`thin_layer_cylinder`, :func:`thin_layer_cylinder_pressure`.
- Exact rolling of a rigid cylinder on a frictionless standard-linear-solid half-space
  (Hunter's problem, re-derived; docs/validation.md sec. 1): :func:`exact_cylinder_halfspace` and its
  dimensionless core :func:`exact_cylinder_halfspace_dimensionless`.
- Persson-type half-space limits (aperiodic ``L -> inf`` limit of [ZG] eqs. 26/29 with the
  stationary Hertz pressure): :func:`persson_cylinder_halfspace` (closed form, JAX) and
  :func:`persson_sphere_halfspace` (1D quadrature, NumPy/SciPy, floats only).

Everything except :func:`persson_sphere_halfspace` is pure JAX: jittable, vmappable and
differentiable with respect to every physical input (including the material leaves).
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from ._numerics import as_float, where_safe
from .materials.material import StandardLinearSolid
from .engines.special import i0e, i1e, i2e, k0e, k1e

__all__ = [
    "hertz_cylinder",
    "hertz_cylinder_pressure",
    "hertz_sphere",
    "HertzSphere",
    "thin_layer_cylinder",
    "thin_layer_cylinder_pressure",
    "exact_cylinder_halfspace",
    "exact_cylinder_halfspace_dimensionless",
    "ExactCylinder",
    "persson_cylinder_halfspace",
    "persson_sphere_halfspace",
]


def _require_sls(material) -> StandardLinearSolid:
    if not isinstance(material, StandardLinearSolid):
        raise ValueError(
            "this exact solution is for a StandardLinearSolid(G0, tau, f) material; got "
            f"{type(material).__name__}"
        )
    return material


def _check_inputs(radius, load, speed):
    """float64 arrays; traced-value checks (``eqx.error_if``) for ``R > 0``, ``P' > 0``,
    ``V >= 0``."""
    radius, load, speed = as_float(radius), as_float(load), as_float(speed)
    radius = eqx.error_if(radius, radius <= 0.0, "radius must be positive [m]")
    load = eqx.error_if(load, load <= 0.0, "load must be positive [N/m]")
    speed = eqx.error_if(speed, speed < 0.0, "speed must be >= 0 [m/s]")
    return radius, load, speed


# --------------------------------------------------------------------------------------
# Elastic contacts
# --------------------------------------------------------------------------------------


def hertz_cylinder(load, radius, G, nu=0.5) -> jax.Array:
    """Hertz half-width ``a`` [m] of a rigid cylinder on an elastic half-space (plane strain).

    ``a = sqrt(4 P' R / (pi E*))`` with ``E* = 2 G/(1 - nu)`` (``= 4 G`` for ``nu = 0.5``, so
    ``a = sqrt(P' R/(pi G))``, docs/validation.md sec. 1).

    Args:
        load: ``P'`` [N/m], load per unit length. radius: ``R`` [m]. G: shear modulus [Pa].
        nu: Poisson's ratio [-].
    """
    load, radius, G, nu = (as_float(v) for v in (load, radius, G, nu))
    e_star = 2.0 * G / (1.0 - nu)
    return jnp.sqrt(4.0 * load * radius / (jnp.pi * e_star))


def hertz_cylinder_pressure(x, load, radius, G, nu=0.5) -> jax.Array:
    """Hertz contact pressure [Pa] under a rigid cylinder on an elastic half-space:
    ``p(x) = (2 P'/(pi a^2)) sqrt(a^2 - x^2)`` for ``|x| < a``, 0 outside (``a`` from
    :func:`hertz_cylinder`); integrates to ``P'``. ``x`` [m] of any shape."""
    x = as_float(x)
    a = hertz_cylinder(load, radius, G, nu)
    load = as_float(load)
    inside = jnp.abs(x) < a
    r2 = where_safe(inside, a * a - x * x, 1.0)
    return jnp.where(inside, 2.0 * load / (jnp.pi * a * a) * jnp.sqrt(r2), 0.0)


class HertzSphere(NamedTuple):
    """Hertz contact of a rigid sphere on an elastic half-space."""

    contact_radius: jax.Array  #: ``a = (3 P R/(4 E*))^(1/3)`` [m]
    penetration: jax.Array  #: ``d = a^2/R`` [m]
    peak_pressure: jax.Array  #: ``p0 = 3 P/(2 pi a^2)`` [Pa]


def hertz_sphere(load, radius, G, nu=0.5) -> HertzSphere:
    """Hertz contact of a rigid sphere (radius ``R`` [m], load ``P`` [N]) on an elastic
    half-space of shear modulus ``G`` [Pa] and Poisson's ratio ``nu``:
    ``E* = 2G/(1-nu)`` (``= E/(1-nu^2)``; ``4G = E/(1-nu^2)`` with ``E = 3G`` at ``nu = 0.5``),
    ``a = (3PR/(4E*))^(1/3)``, ``d = a^2/R``, ``p0 = 3P/(2 pi a^2)`` (pressure
    ``p0 sqrt(1 - r^2/a^2)``, [ZG] eq. 31)."""
    load, radius, G, nu = (as_float(v) for v in (load, radius, G, nu))
    e_star = 2.0 * G / (1.0 - nu)
    a = jnp.cbrt(3.0 * load * radius / (4.0 * e_star))
    return HertzSphere(a, a * a / radius, 3.0 * load / (2.0 * jnp.pi * a * a))


def thin_layer_cylinder(load, radius, H, G) -> jax.Array:
    """Contact half-width ``a`` [m] of a rigid cylinder on a thin incompressible elastic layer
    bonded to a rigid base (docs/validation.md sec. 1, [ZG] sec. 4.4 in 2D):
    ``a = (15 P' R H^3 / (2 G))^(1/5)``.

    Thin-layer law ``u = -(H^3/(3G)) p''`` (u into the layer) with
    ``u = d - x^2/(2R)`` in the contact gives the pressure of
    :func:`thin_layer_cylinder_pressure` and the penetration ``d = a^2/(6R)``.
    Valid for ``a >> H``.

    Args:
        load: ``P'`` [N/m]. radius: ``R`` [m]. H: layer thickness [m]. G: shear modulus [Pa].
    """
    load, radius, H, G = (as_float(v) for v in (load, radius, H, G))
    return (15.0 * load * radius * H**3 / (2.0 * G)) ** 0.2


def thin_layer_cylinder_pressure(x, load, radius, H, G) -> jax.Array:
    """Pressure [Pa] under a cylinder on a thin incompressible layer:
    ``p(x) = (15 P'/(16 a)) (1 - x^2/a^2)^2`` for ``|x| < a``, 0 outside (``a`` from
    :func:`thin_layer_cylinder`); integrates to ``P'``."""
    x = as_float(x)
    a = thin_layer_cylinder(load, radius, H, G)
    load = as_float(load)
    s = 1.0 - (x / a) ** 2
    return jnp.where(jnp.abs(x) < a, 15.0 * load / (16.0 * a) * s * s, 0.0)


# --------------------------------------------------------------------------------------
# Exact viscoelastic cylinder on a standard-linear-solid half-space
# --------------------------------------------------------------------------------------


class ExactCylinder(NamedTuple):
    """Exact steady rolling of a rigid cylinder on a frictionless SLS half-space."""

    rolling_resistance: jax.Array  #: ``R_r`` [N/m] (> 0)
    front: jax.Array  #: leading contact edge ``a`` [m] (contact is ``-b < x < a``)
    rear: jax.Array  #: trailing contact edge distance ``b`` [m] (edge at ``x = -b``)
    h: jax.Array  #: ``h = (a + b)/2`` [m], contact half-width
    m: jax.Array  #: ``m = (a - b)/2`` [m], forward shift of the contact centre
    a0: jax.Array  #: static Hertz half-width ``sqrt(P' R/(pi G0))`` [m]
    zeta: jax.Array  #: ``V tau / a0`` [-]


def _ratios(lam, f):
    """``rI = I1(kappa)/I0(kappa)``, ``rK = K1(lam)/K0(lam)``, ``I2(kappa)/I0(kappa)`` with
    ``kappa = (1+f) lam``, from the exponentially scaled functions (no overflow)."""
    kappa = (1.0 + f) * lam
    i0 = i0e(kappa)
    return i1e(kappa) / i0, k1e(lam) / k0e(lam), i2e(kappa) / i0


def _phi(lam, f):
    """``Phi(lam) = lam^2 + (2 f/(1+f)) lam rI rK/(rI + rK)``; the contact condition
    ``a0^2 = h^2 + 2 m h rK`` reads ``Phi(lam) = 1/zeta^2`` (``lam = h/(V tau)``)."""
    rI, rK, _ = _ratios(lam, f)
    return lam * lam + 2.0 * f / (1.0 + f) * lam * rI * rK / (rI + rK)


_BISECTION_STEPS = 64
_ZETA_FLOOR = 1e-100  # added to zeta: V = 0 is the static limit, R_r ~ 1e-100, finite gradient


def _solve_log_lambda(log_zeta, f):
    """``log lam`` solving ``log Phi(lam) + 2 log zeta = 0``: bisection on the bracket
    ``1/(zeta sqrt(1+f)) <= lam <= 1/zeta`` (i.e. ``a0/sqrt(1+f) <= h <= a0``, proved from
    ``I1(k)/I0(k) <= k/2``), a fixed number of steps, wrapped in ``lax.custom_root`` so
    derivatives come from the implicit function theorem (no unrolled loop is differentiated)."""

    def residual(t):
        return jnp.log(_phi(jnp.exp(t), f)) + 2.0 * log_zeta

    def solve(fun, t_hi):
        t_lo = t_hi - 0.5 * jnp.log1p(f)

        def body(_, bracket):
            lo, hi = bracket
            mid = 0.5 * (lo + hi)
            up = fun(mid) > 0.0
            return jnp.where(up, lo, mid), jnp.where(up, mid, hi)

        lo, hi = lax.fori_loop(0, _BISECTION_STEPS, body, (t_lo, t_hi))
        return 0.5 * (lo + hi)

    def tangent_solve(g, y):
        return y / g(1.0)

    return lax.custom_root(residual, -log_zeta, solve, tangent_solve)


@jax.jit
def exact_cylinder_halfspace_dimensionless(zeta, f):
    """Dimensionless exact SLS cylinder solution: ``(R_r R/(P' a0), h/a0, m/a0)`` as functions
    of ``zeta = V tau/a0 > 0`` and ``f`` only (see :func:`exact_cylinder_halfspace`).

    With ``lam = h/(V tau)``, ``kappa = (1+f) lam``, ``rI = I1/I0 (kappa)``,
    ``rK = K1/K0 (lam)``, ``w = rI/(rI + rK)``:
    ``m/a0 = zeta f/(1+f) w``; ``1 - (h/a0)^2 = 2 (m/a0)(h/a0) rK``;
    ``R_r R/(P' a0) = zeta f/(1+f) [w (1 - h^2/a0^2) + lam zeta^2 D]`` with
    ``D = lam I2(kappa)/I0(kappa) + 2 rI w/(1+f)``. This is docs/validation.md sec. 1's
    ``[(m - c/(1+f)) P' - pi G0 h^2 (m - c)/R]/R`` rearranged, using
    ``I0 - I2 = 2 I1/kappa``, into a sum of positive terms (no cancellation for
    ``zeta -> 0`` or ``zeta -> inf``). ``zeta = 0`` gives the static limit ``(~1e-100, 1, ~1e-100)``
    with the correct one-sided derivatives (``zeta`` is shifted by 1e-100).
    """
    zeta, f = as_float(zeta), as_float(f)
    # zeta + 1e-100: zeta = 0 gives the static limit with the correct one-sided derivative
    # (R_r R/(P' a0) = zeta f/(1+f) + O(zeta^2)) instead of a 0/0 in log(zeta)
    z = zeta + _ZETA_FLOOR
    lam = jnp.exp(_solve_log_lambda(jnp.log(z), f))
    rI, rK, r2 = _ratios(lam, f)
    w = rI / (rI + rK)
    eta = lam * z
    mu = z * f / (1.0 + f) * w
    s = 2.0 * mu * eta * rK  # 1 - eta^2
    D = lam * r2 + 2.0 * rI * w / (1.0 + f)
    rr = z * f / (1.0 + f) * (w * s + lam * z * z * D)
    return rr, eta, mu


@jax.jit
def exact_cylinder_halfspace(material, radius, load, speed) -> ExactCylinder:
    """Exact rolling resistance of a rigid cylinder on a frictionless standard-linear-solid
    half-space (plane strain, incompressible; Hunter's problem, re-derived; docs/validation.md sec. 1).

    With ``c = V tau``, ``a0 = sqrt(P' R/(pi G0))``, contact ``-b < x < a``,
    ``h = (a+b)/2``, ``m = (a-b)/2``, ``lam = h/c``, ``kappa = (1+f) lam``,
    ``rI = I1(kappa)/I0(kappa)``, ``rK = K1(lam)/K0(lam)``:

    ``m = c f/(1+f) rI/(rI + rK)``, ``a0^2 = h^2 + 2 m h rK`` (solved for ``h``),
    ``R_r = [(m - c/(1+f)) P' - pi G0 h^2 (m - c)/R] / R``.

    ``R_r R/(P' a0)`` depends only on ``zeta = V tau/a0`` and ``f`` (for ``f = 1`` its peak
    is 0.19729 at ``zeta = 1.087``). Limits: ``zeta -> 0``: ``h -> a0`` (Hertz with ``G0``),
    ``R_r ~ (f/(1+f)) P' V tau/R``; ``zeta -> inf``: ``h -> a0/sqrt(1+f)`` (Hertz with the
    glassy modulus ``G0 (1+f)``), ``R_r -> 0``. Accurate (1e-11 against a 30-digit solution)
    for ``zeta`` in ``[1e-4, 1e4]`` and usable far beyond (tested 1e-6 .. 1e8); ``speed = 0``
    gives the static Hertz contact (``R_r ~ 1e-100 P' a0/R``) with the correct derivative
    ``dR_r/dV = (f/(1+f)) P' tau/R``.

    The equation for ``h`` is solved by a fixed-step bisection inside ``lax.custom_root``:
    jittable, vmappable, and differentiable (implicit function theorem) with respect to
    ``G0, tau, f, radius, load, speed``.

    Args:
        material: :class:`~jaxroll.materials.material.StandardLinearSolid` ``(G0 [Pa], tau [s], f)``.
        radius: cylinder radius ``R`` [m].
        load: ``P'`` [N/m], load per unit length.
        speed: rolling speed ``V >= 0`` [m/s].

    Returns:
        :class:`ExactCylinder` (``rolling_resistance`` [N/m], ``front`` a, ``rear`` b, ``h``,
        ``m``, ``a0`` [m], ``zeta``).
    """
    mat = _require_sls(material)
    G0, tau, f = as_float(mat.G0), as_float(mat.tau), as_float(mat.f)
    radius, load, speed = _check_inputs(radius, load, speed)
    a0 = jnp.sqrt(load * radius / (jnp.pi * G0))
    zeta = speed * tau / a0
    rr, eta, mu = exact_cylinder_halfspace_dimensionless(zeta, f)
    h, m = eta * a0, mu * a0
    return ExactCylinder(rr * load * a0 / radius, h + m, h - m, h, m, a0, zeta)


# --------------------------------------------------------------------------------------
# Persson-type half-space limits ([ZG] eqs. 26/29 with L -> inf, Hertz pressure)
# --------------------------------------------------------------------------------------


def _compliance_jump(mat: StandardLinearSolid):
    """``dJ = 1/G0 - 1/(G0 (1+f))`` [1/Pa]; the SLS loss compliance is
    ``Im(1/conj G*(omega)) = dJ omega tau/(1 + omega^2 tau^2)``."""
    return mat.f / (mat.G0 * (1.0 + mat.f))


@jax.jit
def persson_cylinder_halfspace(material, radius, load, speed, half_width=None) -> jax.Array:
    """Rolling resistance [N/m] of a cylinder on an SLS half-space in the stationary-pressure
    (Persson-type) approximation: the aperiodic (``L -> inf``) limit of [ZG] eq. 29 with the
    Hertz pressure of half-width ``a``.

    From eq. 29 with ``sigma_m = (P'/L) S(q a)``, ``S(x) = 2 J1(x)/x``, ``q = 2 pi m/L`` and the
    half-space compliance ``T = 1/(2 G_m q)``, ``G_m = conj G*(q V)`` (docs/conventions.md sec. 3, mode modulus):
    ``R_r = (P'^2/pi) int_0^inf q S(qa)^2 Im T(q) dq`` whose closed form for the standard
    linear solid is
    ``R_r = (2 P'^2 dJ/(pi a)) beta [1/2 - I1(1/beta) K1(1/beta)]``, ``beta = V tau/a``,
    ``dJ = 1/G0 - 1/(G0 (1+f))``
    (using ``int_0^inf J1(x)^2/(x (1 + beta^2 x^2)) dx = 1/2 - I1(1/beta) K1(1/beta)``).
    Evaluated as ``1/2 - I1 K1 = I2/(2 I0) + I1^2 K0/I0`` (Wronskian ``I0 K1 + I1 K0 = 1/z``),
    a sum of positive terms: no cancellation as ``beta -> inf``.

    Half-width: by default the Hertz half-width with the **static** modulus,
    ``a = sqrt(P' R/(pi G0))``, the convention of the direct series (docs/conventions.md sec. 5,
    "the contact radius uses the static modulus"); with this ``a`` the formula equals the
    aperiodic direct integral exactly. Pass ``half_width`` [m] for another choice (e.g. the
    glassy-modulus half-width). This is *not* the exact solution
    (:func:`exact_cylinder_halfspace`): the pressure is kept stationary (Hertz, symmetric).

    Args:
        material: StandardLinearSolid. radius: ``R`` [m]. load: ``P'`` [N/m].
        speed: ``V >= 0`` [m/s]. half_width: optional ``a`` [m].
    """
    mat = _require_sls(material)
    radius, load, speed = _check_inputs(radius, load, speed)
    a = hertz_cylinder(load, radius, mat.G0) if half_width is None else as_float(half_width)
    # + 1e-100: V = 0 gives R_r ~ 1e-100 relative with the correct derivative (bracket -> 1/2)
    beta = speed * mat.tau / a + _ZETA_FLOOR
    z = 1.0 / beta
    i0 = i0e(z)
    bracket = 0.5 * i2e(z) / i0 + i1e(z) ** 2 * k0e(z) / i0  # 1/2 - I1(z) K1(z)
    return 2.0 * load**2 * _compliance_jump(mat) / (jnp.pi * a) * beta * bracket


def _hertz_sphere_integrand_np(x, beta):
    """NumPy: ``S(x)^2 (1 - 1/sqrt(1 + beta^2 x^2))``, ``S = 3 (sin x - x cos x)/x^3``."""
    x = np.asarray(x, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(
            x < 1e-2,
            1.0 - x**2 / 10.0 + x**4 / 280.0,
            3.0 * (np.sin(x) - x * np.cos(x)) / np.maximum(x, 1e-300) ** 3,
        )
    bx2 = (beta * x) ** 2
    root = np.sqrt(1.0 + bx2)
    return s * s * bx2 / (root * (root + 1.0))


def persson_sphere_halfspace(material, radius, load, speed, contact_radius=None) -> float:
    """Rolling resistance [N] of a sphere on an SLS half-space in the stationary-pressure
    (Persson-type) approximation: the aperiodic (``L -> inf``) limit of [ZG] eqs. 26/37 with
    the Hertz pressure of radius ``r_c`` ([ZG] eq. 31).

    **NumPy/SciPy oracle: takes and returns Python floats (not traceable by JAX).**

    Derivation: eq. 26 with ``sigma_mn = P S(q r_c)/(L_x L_y)``,
    ``S(x) = 3 (sin x - x cos x)/x^3`` (eq. 36), ``sum_{m,n} -> L_x L_y/(4 pi^2) int d^2q``:
    ``R_r = (P^2/(2 pi^2)) int_{q_x > 0} q_x S(q r_c)^2 Im T(q, q_x) d^2q``,
    ``T = 1/(2 G_m q)``, ``G_m = conj G*(q_x V)``. For the SLS,
    ``Im(1/conj G*(omega)) = dJ omega tau/(1 + omega^2 tau^2)``, and the angular integral
    ``int_{-pi/2}^{pi/2} u cos^2(phi)/(1 + u^2 cos^2 phi) dphi = (pi/u)(1 - 1/sqrt(1+u^2))``
    (``u = q V tau``) reduces it to
    ``R_r = P^2 dJ/(4 pi r_c^2 beta) int_0^inf S(x)^2 (1 - 1/sqrt(1 + beta^2 x^2)) dx``,
    ``beta = V tau/r_c``, evaluated by adaptive quadrature on ``[0, 40]`` (split at the
    multiples of pi) plus the tail ``[40, inf)`` written as a smooth part plus ``cos 2x`` and
    ``sin 2x`` parts integrated by QAWF (relative error ~1e-10).

    Contact radius: default Hertz with the static modulus ``E = 3 G0`` (``nu = 0.5``),
    ``r_c = (3 P R/(4 E*))^(1/3)``, ``E* = 4 G0`` (docs/conventions.md sec. 5). Pass ``contact_radius``
    [m] for another choice (e.g. Jaffar's thick-layer radius).

    Args:
        material: StandardLinearSolid (concrete floats). radius: ``R`` [m]. load: ``P`` [N].
        speed: ``V >= 0`` [m/s]. contact_radius: optional ``r_c`` [m].
    """
    from scipy import integrate

    mat = _require_sls(material)
    G0, tau, f = float(mat.G0), float(mat.tau), float(mat.f)
    P, R, V = float(load), float(radius), float(speed)
    if contact_radius is None:
        rc = (3.0 * P * R / (4.0 * 4.0 * G0)) ** (1.0 / 3.0)
    else:
        rc = float(contact_radius)
    if V == 0.0:
        return 0.0
    beta = V * tau / rc
    dJ = f / (G0 * (1.0 + f))
    x_split = 40.0
    breaks = np.arange(0.0, x_split, np.pi)
    head = 0.0
    for lo, hi in zip(breaks, np.append(breaks[1:], x_split)):
        val, _ = integrate.quad(_hertz_sphere_integrand_np, lo, hi, args=(beta,), epsabs=0.0, epsrel=1e-13)
        head += val

    # tail: S^2 = (9/(2 x^6)) [(1 + x^2) + (x^2 - 1) cos 2x - 2 x sin 2x]. The weight is
    # divided by beta^2/(1 + beta^2) (the integral is ~ beta^2 for small beta): QAWF honours only
    # an absolute tolerance (default 1.5e-8), which made the result 7.5e-5 too high for beta < 1e-3
    norm = beta * beta / (1.0 + beta * beta)

    def weight(x):
        bx2 = (beta * x) ** 2
        root = np.sqrt(1.0 + bx2)
        return bx2 / (root * (root + 1.0)) / norm

    def smooth_fn(x):
        return 4.5 * (1.0 + x * x) / x**6 * weight(x)

    # in ln x, with a break where the smooth part bends (x ~ 1/beta; one infinite-range quad
    # warned of roundoff at beta ~ 1e-6): it falls like x^-2 up to the bend and x^-4 beyond,
    # so 25 more e-folds leave e^-75 of it out
    t_bend = np.log(max(x_split, 1.0 / beta))
    smooth, _ = integrate.quad(lambda t: smooth_fn(np.exp(t)) * np.exp(t), np.log(x_split), t_bend + 25.0,
                               points=[t_bend], epsabs=0.0, epsrel=1e-13, limit=200)
    cos_part, _ = integrate.quad(lambda x: 4.5 * (x * x - 1.0) / x**6 * weight(x), x_split, np.inf, weight="cos", wvar=2.0,
                                 epsabs=1e-15)
    sin_part, _ = integrate.quad(lambda x: -9.0 / x**5 * weight(x), x_split, np.inf, weight="sin", wvar=2.0, epsabs=1e-15)
    integral = head + norm * (smooth + cos_part + sin_part)
    return P * P * dJ / (4.0 * np.pi * rc * rc * beta) * integral
