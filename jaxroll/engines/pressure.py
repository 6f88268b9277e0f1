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
:mod:`jaxroll.engines.contact_size`; ``contact_radius`` is re-exported here. The radius uses the
**static** modulus by default (``E = 2 G'(0)(1+nu)``, ``= 3 G0`` at ``nu = 0.5``): this
reproduces the radii [ZG] states (H = 5 mm, P = 120 N: 4.87 mm; H = 10 um, R = 2000 m,
P = 0.2..2 kN: 3.33..4.88 mm).
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .._numerics import as_float, where_safe
from ..geometry import check_geometry
from .contact_size import contact_radius, jaffar_coefficients  # noqa: F401 (re-exported)
from ..result import REGIMES
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

#: Pressure-model names and their ``RollingResult.regime`` codes (:data:`jaxroll.result.REGIMES`).
PRESSURE_MODELS = {r.label: int(r) for r in (REGIMES.thick, REGIMES.thin, REGIMES.thin_compressible)}

#: Jaffar's thick-layer (Hertz-shape) model is valid for ``gamma = r_c/H <= 0.9`` ([ZG] 4.3).
THICK_MAX_GAMMA = 0.9

#: The thin-layer asymptotics (Jaffar 1997) are taken as valid for ``gamma >= 10``. Their
#: leading corrections are O(1/gamma) (edge zones of width ~H); 10 keeps them ~10 %. The
#: paper's thin example has gamma = 333..488. Between 0.9 and 10 no model of [ZG] applies
#: (its section 4.5): results there are flagged ``valid = False``.
THIN_MIN_GAMMA = 10.0

def _check_model(model: str, geometry: str) -> None:
    if model not in PRESSURE_MODELS:
        raise ValueError(f"unknown pressure model {model!r}; choose from {tuple(PRESSURE_MODELS)}")
    check_geometry(geometry)


# --------------------------------------------------------------------------------------
# the models, one table


def _hertz_sphere_closed(x, xp, jn):
    return 3.0 * (xp.sin(x) - x * xp.cos(x)) / x**3


def _thin_cylinder_closed(x, xp, jn):
    return 15.0 * ((3.0 - x * x) * xp.sin(x) - 3.0 * x * xp.cos(x)) / x**5


class _Shape(NamedTuple):
    """One stationary pressure shape: its transform, profile and large-``x`` envelope.

    * ``closed(x, xp, jn)``: ``S(x)`` with the array module ``xp`` (``jnp`` or ``np``) and the
      Bessel function ``jn(n, x)``;
    * ``series``: Taylor coefficients of ``S`` in ``x^2`` (``S(0) = 1``), used below ``threshold``;
    * ``envelope(x, jn2)``: the mean of ``S(x)^2`` over its oscillation (``jn2(n)`` the mean of
      ``J_n^2``), and its leading law ``envelope_law = (C, p)``: ``C x^(-p)``;
    * ``profile = (c, e)``: ``p(r) = c P / (pi a^d) (1 - r^2/a^2)^e`` (``d = 2`` sphere, 1
      cylinder; the cylinder's ``pi`` is folded into ``c``).
    """

    closed: Callable
    series: tuple
    threshold: float
    envelope: Callable
    envelope_law: tuple
    profile: tuple


_HERTZ_SPHERE_SERIES = (1.0, -1 / 10.0, 1 / 280.0, -1 / 15120.0, 1 / 1330560.0)
_HERTZ_SPHERE_ENVELOPE = (lambda x, jn2: 9.0 * (1.0 + x * x) / (2.0 * x**6))

#: The stationary pressure models of [ZG] sec. 4, keyed by ``(geometry, model)`` (see the module
#: docstring): the one place their transforms, profiles and envelopes are written.
_SHAPES = {
    ("sphere", "thick"): _Shape(_hertz_sphere_closed, _HERTZ_SPHERE_SERIES, 0.05, _HERTZ_SPHERE_ENVELOPE,
                                (4.5, 4.0), (1.5, 0.5)),
    ("sphere", "thin"): _Shape(lambda x, xp, jn: 48.0 * jn(3, x) / x**3,
                               (1.0, -1 / 16.0, 1 / 640.0, -1 / 46080.0, 1 / 5160960.0), 0.05,
                               lambda x, jn2: 2304.0 * jn2(3) / x**6, (2304.0 / math.pi, 7.0), (3.0, 2.0)),
    ("sphere", "thin-compressible"): _Shape(lambda x, xp, jn: 8.0 * jn(2, x) / x**2,
                                            (1.0, -1 / 12.0, 1 / 384.0, -1 / 23040.0, 1 / 2211840.0), 0.05,
                                            lambda x, jn2: 64.0 * jn2(2) / x**4, (64.0 / math.pi, 5.0), (2.0, 1.0)),
    ("cylinder", "thick"): _Shape(lambda x, xp, jn: 2.0 * jn(1, x) / x,
                                  (1.0, -1 / 8.0, 1 / 192.0, -1 / 9216.0, 1 / 737280.0), 0.05,
                                  lambda x, jn2: 4.0 * jn2(1) / x**2, (4.0 / math.pi, 3.0), (2.0, 0.5)),
    ("cylinder", "thin"): _Shape(_thin_cylinder_closed,
                                 (1.0, -1 / 14.0, 1 / 504.0, -1 / 33264.0, 1 / 3459456.0, -1 / 518918400.0), 0.5,
                                 lambda x, jn2: 225.0 * ((3.0 - x * x) ** 2 + 9.0 * x * x) / (2.0 * x**10),
                                 (112.5, 6.0), (15.0 * math.pi / 16.0, 2.0)),
    ("cylinder", "thin-compressible"): _Shape(_hertz_sphere_closed, _HERTZ_SPHERE_SERIES, 0.05,
                                              _HERTZ_SPHERE_ENVELOPE, (4.5, 4.0), (0.75 * math.pi, 1.0)),
}

#: Large-x envelope of S(x)^2 (mean over an oscillation): ``C x^(-p)``.
_ENVELOPE = {key: shape.envelope_law for key, shape in _SHAPES.items()}

_JN = {1: j1, 2: j2, 3: j3}


def _series(coefficients, x2):
    return sum(c * x2**k for k, c in enumerate(coefficients))


def _shape(model, geometry) -> _Shape:
    _check_model(model, geometry)
    return _SHAPES[(geometry, model)]


def pressure_transform(x, *, model="thick", geometry="sphere") -> jax.Array:
    """Normalised Fourier transform ``S(x)`` of a stationary pressure model, ``S(0) = 1``.

    ``x = q r_c`` (``q = |q|`` [rad/m]); the pressure mode amplitude is ``P S(q r_c)``.
    Sphere: [ZG] eqs. 36, 41, 46; cylinder: see the module docstring. Small ``x`` use Taylor
    series (double-where guarded), so values and derivatives are finite at ``x = 0``.
    """
    shape = _shape(model, geometry)
    x = as_float(x)
    small = jnp.abs(x) < shape.threshold
    xl, xs = where_safe(small, 1.0, x), where_safe(small, x, 0.0)
    return jnp.where(small, _series(shape.series, xs * xs), shape.closed(xl, jnp, lambda n, v: _JN[n](v)))


def _transform_np(x, model, geometry):
    """NumPy (scipy Bessel) twin of :func:`pressure_transform`, for quadrature weights."""
    import scipy.special  # here, not at import: a program loaded from the cache needs no SciPy

    shape = _shape(model, geometry)
    x = np.asarray(x, dtype=np.float64)
    with np.errstate(all="ignore"):
        v = shape.closed(x, np, scipy.special.jv)
    return np.where(np.abs(x) < shape.threshold, _series(shape.series, x * x), v)


def _envelope_np(x, model, geometry):
    """Mean of ``S(x)^2`` over its oscillation (NumPy), for large ``x`` (relative error of the
    integrals it replaces ~1/x): exact for the elementary transforms, the Bessel modulus
    ``J_n^2 ~ (1 + (4 n^2 - 1)/(8 x^2))/(pi x)`` otherwise."""
    x = np.asarray(x, dtype=np.float64)

    def jn2(n):
        return (1.0 + (4.0 * n * n - 1.0) / (8.0 * x * x)) / (math.pi * x)

    return _shape(model, geometry).envelope(x, jn2)


def pressure_profile(r, contact_radius, load, *, model="thick", geometry="sphere") -> jax.Array:
    """Stationary contact pressure [Pa] at distance ``r`` [m] from the centre (sphere) or at
    abscissa ``x = r`` (cylinder; ``load`` per unit length). [ZG] eqs. 31, 39, 44; zero outside
    the contact."""
    c, e = _shape(model, geometry).profile
    r, a, P = as_float(r), as_float(contact_radius), as_float(load)
    t = jnp.clip(1.0 - (r / a) ** 2, 0.0, None)
    shape = jnp.sqrt(t) if e == 0.5 else t ** int(e)
    return c * P / (math.pi * a ** (2 if geometry == "sphere" else 1)) * shape
