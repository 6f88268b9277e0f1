r"""Stationary contact-pressure models of [ZG] section 4: contact radius and Fourier transform.

The direct method ([ZG] eqs. 26, 29) assumes the contact pressure keeps the *stationary
elastic* profile of a rigid sphere (or cylinder) pressed on the layer. Each model gives

* the contact radius ``r_c`` (sphere) or half-width ``a`` (cylinder) [m] from the load, and
* the normalised Fourier transform of the pressure, ``S(x)``, ``x = q r_c``, ``S(0) = 1``:
  the pressure mode amplitude is ``P S(q r_c)`` (sphere, load ``P`` [N]) or ``P' S(q a)``
  (cylinder, load per unit length ``P'`` [N/m]) with the transform convention
  ``p_hat(q) = int p(x) e^{-i q.x} dA``.

Models (``model`` argument; docs/conventions.md sec. 5):

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

Contact radii (the ``r_c``/``a`` column above, Jaffar's law, the moduli they use) live in
:mod:`jaxroll.contact_size`; ``contact_radius`` is re-exported here. The radius uses the
**static** modulus by default (``E = 2 G'(0)(1+nu)``, ``= 3 G0`` at ``nu = 0.5``): this
reproduces the radii [ZG] states (H = 5 mm, P = 120 N: 4.87 mm; H = 10 um, R = 2000 m,
P = 0.2..2 kN: 3.33..4.88 mm).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import scipy.special

from ._numerics import as_float, where_safe
from .contact_size import GEOMETRIES, check_geometry, contact_radius, jaffar_coefficients  # noqa: F401 (re-exported)
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

_GEOMETRIES = GEOMETRIES


def _check_model(model: str, geometry: str) -> None:
    if model not in PRESSURE_MODELS:
        raise ValueError(f"unknown pressure model {model!r}; choose from {tuple(PRESSURE_MODELS)}")
    check_geometry(geometry)


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
