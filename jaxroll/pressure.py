r"""Stationary contact-pressure models of [ZG] section 4: contact radius and Fourier transform.

The direct method ([ZG] eqs. 26, 29) assumes the contact pressure keeps the *stationary
elastic* profile of a rigid sphere (or cylinder) pressed on the layer. Each model gives

* the contact radius ``r_c`` (sphere) or half-width ``a`` (cylinder) [m] from the load, and
* the normalised Fourier transform of the pressure, ``S(x)``, ``x = q r_c``, ``S(0) = 1``:
  the pressure mode amplitude is ``P S(q r_c)`` (sphere, load ``P`` [N]) or ``P' S(q a)``
  (cylinder, load per unit length ``P'`` [N/m]) with the transform convention
  ``p_hat(q) = int p(x) e^{-i q.x} dA``.

Models (``model`` argument; DESIGN section 2):

=====================  ===============================  ====================================
model                  sphere, ``S(x)``                 cylinder (plane strain), ``S(x)``
=====================  ===============================  ====================================
``"thick"``            Hertz, eq. 31/36:                Hertz ``2 J1(x)/x``,
                       ``3 (sin x - x cos x)/x^3``;     ``a = sqrt(4 P' R/(pi E*))``,
                       ``r_c`` from Jaffar's law         ``E* = 2 G/(1 - nu)`` (``= 4 G`` at
                       (eqs. 32-35)                      ``nu = 0.5``)
``"thin"``             eq. 39/41: ``48 J3(x)/x^3``;     ``15((3 - x^2) sin x - 3x cos x)/x^5``,
                       ``r_c`` eq. 40                    ``a = (15 P' R H^3/(2 G))^(1/5)``
``"thin-compressible"``  eq. 44/46: ``8 J2(x)/x^2``;     ``3 (sin x - x cos x)/x^3``,
                       ``r_c`` eq. 45 (corrected)        ``a = (3 P' R H (1-2nu)/(4G(1-nu)))^(1/3)``
=====================  ===============================  ====================================

Moduli. The contact radius uses the **static** modulus by default: ``G = G'(0)`` (``G0`` of a
standard linear solid) and ``E = 2 G (1 + nu)`` (``= 3 G0`` when ``nu = 0.5``); this reproduces
the radii [ZG] states (H = 5 mm, P = 120 N: 4.87 mm; H = 10 um, R = 2000 m, P = 0.2..2 kN:
3.33..4.88 mm). ``modulus="glassy"`` uses ``G'(inf)``; ``modulus="dynamic"`` uses
``G'(V / r_static)`` (the storage modulus at the frequency of the static contact radius);
a number is used as the shear modulus in Pa.

Deviations from paper: eq. 45 lacks ``P``; it is
``r_c = (4 P R H (1+nu)(1-2nu)/((1-nu) pi E))^(1/4)``. Footnote 3 should cite eq. 40 for
``r_c^{JN}``. The cylinder half-widths of the thin models are not in [ZG]; they follow from
the thin-layer laws ``u = -(H^3/(3G)) p''`` (incompressible) and ``u = H(1-2nu) p/(2G(1-nu))``
(compressible).

Jaffar's thick-layer law (eqs. 32-35) ``P = 4 pi E r_c^3/(R D (1-nu^2))``,
``D = 3 pi + 8 gamma^3 (b1 + 2/5 b2 gamma^2)``, ``gamma = r_c/H``: ``b1, b2`` by quadrature of
eq. 34 for the layer's ``nu``; ``r_c`` by a safeguarded Newton iteration wrapped in
``jax.lax.custom_root`` (implicit differentiation; the iteration is never differentiated).
``P(r_c)`` is monotonic only for ``gamma < gamma_max`` (1.2 at ``nu = 0.5``); loads beyond
return ``r_c = gamma_max H`` and ``valid = False``.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import scipy.integrate
import scipy.special

from ._numerics import as_float, where_safe
from .material import complex_modulus, glassy_modulus, relaxed_modulus
from .special import j1, j2, j3

__all__ = [
    "PRESSURE_MODELS",
    "THICK_MAX_GAMMA",
    "THIN_MIN_GAMMA",
    "jaffar_coefficients",
    "contact_radius",
    "pressure_transform",
    "pressure_profile",
]

#: Pressure-model names and their ``RollingResult.regime`` codes (see ``jaxroll.result``).
PRESSURE_MODELS = {"thick": 0, "thin": 1, "thin-compressible": 2}

#: Jaffar's thick-layer (Hertz-shape) model is valid for ``gamma = r_c/H <= 0.9`` ([ZG] 4.3).
THICK_MAX_GAMMA = 0.9

#: The thin-layer asymptotics (Jaffar 1997) are taken as valid for ``gamma >= 10``. Their
#: leading corrections are O(1/gamma) (edge zones of width ~H); 10 keeps them ~10 %. The
#: paper's thin example has gamma = 333..488. Between 0.9 and 10 no model of [ZG] applies
#: (its section 4.5): results there are flagged ``valid = False``.
THIN_MIN_GAMMA = 10.0

_GEOMETRIES = ("sphere", "cylinder")


def _check_model(model: str, geometry: str) -> None:
    if model not in PRESSURE_MODELS:
        raise ValueError(f"unknown pressure model {model!r}; choose from {tuple(PRESSURE_MODELS)}")
    if geometry not in _GEOMETRIES:
        raise ValueError(f"unknown geometry {geometry!r}; choose from {_GEOMETRIES}")


# --------------------------------------------------------------------------------------
# Jaffar's thick-layer law

def _one_minus_L(w, kappa):
    """``1 - L(w)`` of [ZG] eq. 35, numerically stable for large ``w`` (NumPy)."""
    e2 = np.exp(-2.0 * w)
    num = 2.0 * kappa * e2 * e2 + (4.0 * w * w + 4.0 * w + kappa * kappa + 1.0) * e2
    den = kappa * (1.0 + e2 * e2) + (4.0 * w * w + kappa * kappa + 1.0) * e2
    return num / den


@functools.lru_cache(maxsize=None)
def jaffar_coefficients(nu: float = 0.5) -> tuple[float, float]:
    """Jaffar's coefficients ``(b1, b2)`` of [ZG] eq. 34 for a bonded layer, by quadrature.

    ``b_m = (-1/4)^m int_0^inf (1 - L(w)) w^{2m} dw``, ``L`` of eq. 35, ``kappa = 3 - 4 nu``.
    ``nu = 0.5``: ``b1 = -0.957769288898079``, ``b2 = 1.749436123749906``.

    Args:
        nu: Poisson's ratio in ``[0, 0.5]`` (a Python float; static).
    """
    nu = float(nu)
    if not 0.0 <= nu <= 0.5:
        raise ValueError(f"nu must lie in [0, 0.5]; got {nu}")
    kappa = 3.0 - 4.0 * nu
    out = []
    for m in (1, 2):
        val, _ = scipy.integrate.quad(lambda w: _one_minus_L(w, kappa) * w ** (2 * m), 0.0, 80.0,
                                      epsabs=0.0, epsrel=1e-13, limit=200)
        out.append((-0.25) ** m * val)
    return float(out[0]), float(out[1])


@functools.lru_cache(maxsize=None)
def _jaffar_gamma_max(nu: float) -> float:
    """Largest ``gamma`` up to which ``P(r_c)`` of eqs. 32-33 increases: root of
    ``3 D(gamma) - gamma D'(gamma) = 9 pi + 8 gamma^3 (b1 ... )``, i.e.
    ``9 pi - (32/5) b2 gamma^5 = 0`` (the ``b1`` terms cancel)."""
    _, b2 = jaffar_coefficients(nu)
    return float((9.0 * math.pi / (6.4 * b2)) ** 0.2) if b2 > 0 else math.inf


def _jaffar_z(gamma0, nu: float):
    """Solve ``3 pi z^3 = D(gamma0 z)`` for ``z = r_c / r_Hertz`` (eqs. 32-33), differentiable
    in ``gamma0`` by the implicit function theorem. Returns ``(z, exists)``."""
    b1, b2 = jaffar_coefficients(nu)
    g_max = _jaffar_gamma_max(nu)

    def D(g):
        return 3.0 * math.pi + 8.0 * g**3 * (b1 + 0.4 * b2 * g**2)

    def h(z, g0):
        return 3.0 * math.pi * z**3 - D(g0 * z)

    # upper bracket: z at gamma_max (or a generous bound for thin gamma0 -> 0)
    g0_pos = gamma0 > 0
    z_hi = jnp.where(g0_pos, g_max / where_safe(g0_pos, gamma0, 1.0), 10.0)
    z_hi = jnp.minimum(z_hi, 10.0)
    exists = h(z_hi, gamma0) >= 0.0

    def solve(fun, z0):
        # safeguarded Newton on [lo, hi] with h(lo) < 0 <= h(hi); fixed iteration count
        lo = jnp.zeros_like(z0) + 0.5
        hi = z_hi

        def body(_, state):
            z, lo, hi = state
            fz = fun(z)
            lo = jnp.where(fz < 0, z, lo)
            hi = jnp.where(fz >= 0, z, hi)
            dfz = jax.grad(fun)(z)
            zn = z - fz / jnp.where(dfz > 0, dfz, 1.0)
            ok = (zn > lo) & (zn < hi) & (dfz > 0)
            z = jnp.where(ok, zn, 0.5 * (lo + hi))
            return z, lo, hi

        z, _, _ = jax.lax.fori_loop(0, 60, body, (z0, lo, hi))
        return z

    def tangent_solve(g, y):
        return y / g(1.0)

    def f(z):
        return h(z, gamma0)

    z0 = jnp.clip(jnp.ones_like(gamma0), 0.5, z_hi)
    z_root = jax.lax.custom_root(f, z0, solve, tangent_solve)
    return jnp.where(exists, z_root, jax.lax.stop_gradient(z_hi)), exists


# --------------------------------------------------------------------------------------
# contact radius

def _shear_modulus(material, modulus, V, radius_static):
    if isinstance(modulus, str):
        if modulus == "static":
            return relaxed_modulus(material)
        if modulus == "glassy":
            return glassy_modulus(material)
        if modulus == "dynamic":
            if V is None:
                raise ValueError('modulus="dynamic" needs the rolling speed V')
            return jnp.real(complex_modulus(material, V / radius_static))
        raise ValueError(f'unknown modulus {modulus!r}; use "static", "glassy", "dynamic" or a value in Pa')
    return as_float(modulus)


def _radius_for(model, geometry, G, nu, H, R, P):
    """Contact radius and its validity for one model, given the shear modulus ``G``."""
    E = 2.0 * G * (1.0 + nu)
    inf_H = jnp.isinf(H)
    Hf = where_safe(inf_H, 1.0, H)
    if geometry == "sphere":
        if model == "thick":
            r_hertz = (3.0 * P * R * (1.0 - nu * nu) / (4.0 * E)) ** (1.0 / 3.0)
            gamma0 = jnp.where(inf_H, 0.0, r_hertz / Hf)
            z, exists = _jaffar_z(gamma0, float(nu))
            return r_hertz * z, exists
        if model == "thin":
            return (96.0 * P * R * Hf**3 / (math.pi * E)) ** (1.0 / 6.0), jnp.ones_like(P, dtype=bool)
        c = 4.0 * (1.0 + nu) * (1.0 - 2.0 * nu) / ((1.0 - nu) * math.pi)
        return (c * P * R * Hf / E) ** 0.25, jnp.ones_like(P, dtype=bool)
    # cylinder, P is the load per unit length
    if model == "thick":
        return jnp.sqrt(2.0 * P * R * (1.0 - nu) / (math.pi * G)), jnp.ones_like(P, dtype=bool)
    if model == "thin":
        return (15.0 * P * R * Hf**3 / (2.0 * G)) ** 0.2, jnp.ones_like(P, dtype=bool)
    return (3.0 * P * R * Hf * (1.0 - 2.0 * nu) / (4.0 * G * (1.0 - nu))) ** (1.0 / 3.0), jnp.ones_like(
        P, dtype=bool
    )


def contact_radius(material, layer, radius, load, *, model="thick", geometry="sphere", modulus="static",
                   speed=None):
    """Stationary contact radius (sphere) or half-width (cylinder) of a pressure model [m].

    Args:
        material: a material of :mod:`jaxroll.material` (only its modulus is used).
        layer: :class:`jaxroll.layer.Layer` (``H`` [m], ``nu``).
        radius: roller radius ``R`` [m].
        load: ``P`` [N] (sphere) or ``P'`` [N/m] (cylinder).
        model: ``"thick"`` ([ZG] eqs. 32-35), ``"thin"`` (eq. 40) or ``"thin-compressible"``
            (corrected eq. 45); see the module docstring for cylinders.
        geometry: ``"sphere"`` or ``"cylinder"``.
        modulus: ``"static"`` (default, ``E = 2 G'(0)(1+nu)``), ``"glassy"``, ``"dynamic"``
            (``G'(V / r_static)``, needs ``speed``) or a shear modulus in Pa.
        speed: rolling speed [m/s], only for ``modulus="dynamic"``.

    Returns:
        ``(r_c, exists)``: radius [m] and a bool array, False where Jaffar's law has no
        solution (load beyond ``gamma_max``; ``r_c`` is then ``gamma_max H``).
    """
    _check_model(model, geometry)
    nu = float(layer.nu)
    if model == "thin-compressible" and nu >= 0.5:
        raise ValueError('pressure model "thin-compressible" needs a compressible layer (nu < 0.5)')
    R, P, H = as_float(radius), as_float(load), as_float(layer.H)
    if model != "thick" and not isinstance(H, jax.core.Tracer) and bool(jnp.any(jnp.isinf(H))):
        raise ValueError(f"pressure model {model!r} needs a finite layer thickness H")
    if isinstance(modulus, str) and modulus == "dynamic":
        G_s = relaxed_modulus(material)
        r_s, _ = _radius_for(model, geometry, G_s, nu, H, R, P)
        G = _shear_modulus(material, modulus, as_float(speed), r_s)
    else:
        G = _shear_modulus(material, modulus, None, None)
    return _radius_for(model, geometry, G, nu, H, R, P)


# --------------------------------------------------------------------------------------
# transforms

def _small(x, thr):
    s = jnp.abs(x) < thr
    return s, where_safe(s, 1.0, x), where_safe(s, x, 0.0)


def pressure_transform(x, *, model="thick", geometry="sphere") -> jax.Array:
    """Normalised Fourier transform ``S(x)`` of a stationary pressure model, ``S(0) = 1``.

    ``x = q r_c`` (``q = |q|`` [rad/m]); the pressure mode amplitude is ``P S(q r_c)``.
    Sphere: [ZG] eqs. 36, 41, 46; cylinder: see the module docstring. Small ``x`` use Taylor
    series (double-where guarded), so values and derivatives are finite at ``x = 0``.
    """
    _check_model(model, geometry)
    x = as_float(x)
    if geometry == "sphere" and model == "thick" or geometry == "cylinder" and model == "thin-compressible":
        s, xl, xs = _small(x, 0.05)
        x2 = xs * xs
        series = 1.0 - x2 / 10.0 + x2 * x2 / 280.0 - x2**3 / 15120.0 + x2**4 / 1330560.0
        return jnp.where(s, series, 3.0 * (jnp.sin(xl) - xl * jnp.cos(xl)) / xl**3)
    if geometry == "sphere" and model == "thin":
        s, xl, xs = _small(x, 0.05)
        x2 = xs * xs
        series = 1.0 - x2 / 16.0 + x2 * x2 / 640.0 - x2**3 / 46080.0 + x2**4 / 5160960.0
        return jnp.where(s, series, 48.0 * j3(xl) / xl**3)
    if geometry == "sphere":  # thin-compressible
        s, xl, xs = _small(x, 0.05)
        x2 = xs * xs
        series = 1.0 - x2 / 12.0 + x2 * x2 / 384.0 - x2**3 / 23040.0 + x2**4 / 2211840.0
        return jnp.where(s, series, 8.0 * j2(xl) / xl**2)
    if model == "thick":  # cylinder Hertz
        s, xl, xs = _small(x, 0.05)
        x2 = xs * xs
        series = 1.0 - x2 / 8.0 + x2 * x2 / 192.0 - x2**3 / 9216.0 + x2**4 / 737280.0
        return jnp.where(s, series, 2.0 * j1(xl) / xl)
    # cylinder thin incompressible
    s, xl, xs = _small(x, 0.5)
    x2 = xs * xs
    series = 1.0 - x2 / 14.0 + x2 * x2 / 504.0 - x2**3 / 33264.0 + x2**4 / 3459456.0 - x2**5 / 518918400.0
    return jnp.where(s, series, 15.0 * ((3.0 - xl * xl) * jnp.sin(xl) - 3.0 * xl * jnp.cos(xl)) / xl**5)


def _transform_np(x, model, geometry):
    """NumPy (scipy Bessel) twin of :func:`pressure_transform`, for quadrature weights."""
    x = np.asarray(x, dtype=np.float64)
    with np.errstate(all="ignore"):
        if geometry == "sphere" and model == "thick" or geometry == "cylinder" and model == "thin-compressible":
            v = 3.0 * (np.sin(x) - x * np.cos(x)) / x**3
            sm = 1.0 - x**2 / 10.0 + x**4 / 280.0 - x**6 / 15120.0 + x**8 / 1330560.0
            thr = 0.05
        elif geometry == "sphere" and model == "thin":
            v = 48.0 * scipy.special.jv(3, x) / x**3
            sm = 1.0 - x**2 / 16.0 + x**4 / 640.0 - x**6 / 46080.0 + x**8 / 5160960.0
            thr = 0.05
        elif geometry == "sphere":
            v = 8.0 * scipy.special.jv(2, x) / x**2
            sm = 1.0 - x**2 / 12.0 + x**4 / 384.0 - x**6 / 23040.0 + x**8 / 2211840.0
            thr = 0.05
        elif model == "thick":
            v = 2.0 * scipy.special.jv(1, x) / x
            sm = 1.0 - x**2 / 8.0 + x**4 / 192.0 - x**6 / 9216.0 + x**8 / 737280.0
            thr = 0.05
        else:
            v = 15.0 * ((3.0 - x * x) * np.sin(x) - 3.0 * x * np.cos(x)) / x**5
            sm = 1.0 - x**2 / 14.0 + x**4 / 504.0 - x**6 / 33264.0 + x**8 / 3459456.0 - x**10 / 518918400.0
            thr = 0.5
    return np.where(np.abs(x) < thr, sm, v)


#: Large-x envelope of S(x)^2 (mean over an oscillation): ``C x^(-p)``.
_ENVELOPE = {
    ("sphere", "thick"): (4.5, 4.0),
    ("sphere", "thin"): (2304.0 / math.pi, 7.0),
    ("sphere", "thin-compressible"): (64.0 / math.pi, 5.0),
    ("cylinder", "thick"): (4.0 / math.pi, 3.0),
    ("cylinder", "thin"): (112.5, 6.0),
    ("cylinder", "thin-compressible"): (4.5, 4.0),
}


def _envelope_np(x, model, geometry):
    """Mean of ``S(x)^2`` over its oscillation (NumPy), for large ``x`` (relative error of the
    integrals it replaces ~1/x): exact for the elementary transforms, the Bessel modulus
    ``J_n^2 ~ (1 + (4 n^2 - 1)/(8 x^2))/(pi x)`` otherwise."""
    x = np.asarray(x, dtype=np.float64)

    def jn2(n):
        return (1.0 + (4.0 * n * n - 1.0) / (8.0 * x * x)) / (math.pi * x)

    if geometry == "sphere" and model == "thick" or geometry == "cylinder" and model == "thin-compressible":
        return 9.0 * (1.0 + x * x) / (2.0 * x**6)
    if geometry == "sphere" and model == "thin":
        return 2304.0 * jn2(3) / x**6
    if geometry == "sphere":
        return 64.0 * jn2(2) / x**4
    if model == "thick":
        return 4.0 * jn2(1) / x**2
    return 225.0 * ((3.0 - x * x) ** 2 + 9.0 * x * x) / (2.0 * x**10)


def pressure_profile(r, contact_radius, load, *, model="thick", geometry="sphere") -> jax.Array:
    """Stationary contact pressure [Pa] at distance ``r`` [m] from the centre (sphere) or at
    abscissa ``x = r`` (cylinder; ``load`` per unit length). [ZG] eqs. 31, 39, 44; zero outside
    the contact."""
    _check_model(model, geometry)
    r, a, P = as_float(r), as_float(contact_radius), as_float(load)
    t = jnp.clip(1.0 - (r / a) ** 2, 0.0, None)
    if geometry == "sphere":
        if model == "thick":
            return 3.0 * P / (2.0 * math.pi * a * a) * jnp.sqrt(t)
        if model == "thin":
            return 3.0 * P / (math.pi * a * a) * t * t
        return 2.0 * P / (math.pi * a * a) * t
    if model == "thick":
        return 2.0 * P / (math.pi * a) * jnp.sqrt(t)
    if model == "thin":
        return 15.0 * P / (16.0 * a) * t * t
    return 3.0 * P / (4.0 * a) * t
