r"""Contact-size estimates: the one home of the Hertz, Jaffar and thin-layer radius formulas.

Every user of a contact radius (sphere) or half-width (cylinder) calls this module: the
stationary pressure models of the direct method (:mod:`jaxroll.engines.pressure`), the grid rules of the
full and slice models (:mod:`jaxroll.methods`), the slice algorithms' initial contact sets.

Formulas (shear modulus ``G`` [Pa], ``E = 2 G (1 + nu)``, ``E* = 2 G/(1 - nu)``, radius ``R``
[m], load ``P`` [N] for a sphere or ``P'`` [N/m] for a cylinder, thickness ``H`` [m]):

=====================  ===========================================  ==========================================
model                  sphere ``r_c``                               cylinder ``a``
=====================  ===========================================  ==========================================
``"thick"``            Jaffar's bonded-layer law, eqs. 32-35        Hertz ``sqrt(4 P' R/(pi E*))``
                       (Hertz ``(3 P R/(4 E*))^(1/3)`` for
                       ``H = inf``)
``"thin"``             eq. 40: ``(96 P R H^3/(pi E))^(1/6)``        ``(15 P' R H^3/(2 G))^(1/5)``
``"thin-compressible"`` eq. 45 (corrected):                          ``(3 P' R H (1-2nu)/(4 G (1-nu)))^(1/3)``
                       ``(4 P R H (1+nu)(1-2nu)/((1-nu) pi E))^(1/4)``
=====================  ===========================================  ==========================================

The Hertz radii and the incompressible thin-layer cylinder are the exact solutions of
:mod:`jaxroll.reference` (one formula each). The cylinder's thin radii follow from the
thin-layer laws ``u = -(H^3/(3G)) p''`` (incompressible) and ``u = H(1-2nu) p/(2G(1-nu))``
(compressible); they are not in [ZG].

Jaffar's law ``P = 4 pi E r_c^3/(R D (1-nu^2))``, ``D = 3 pi + 8 gamma^3 (b1 + 2/5 b2 gamma^2)``,
``gamma = r_c/H``; ``b1, b2`` by quadrature of eq. 34 for the layer's ``nu``; ``r_c`` by the
safeguarded Newton root find :func:`jaxroll._numerics.newton_root` (implicit derivatives).
``P(r_c)`` increases only up to ``gamma_max`` (1.2 at ``nu = 0.5``): beyond, no solution exists
(``exists = False``, ``r_c = gamma_max H``).

Deviation from paper: eq. 45 lacks ``P``; footnote 3 should cite eq. 40.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from .._numerics import as_float, newton_root, where_safe
from ..geometry import check_geometry  # noqa: F401 (re-exported)
from ..reference import hertz_cylinder, hertz_sphere, thin_layer_cylinder

__all__ = [
    "MODELS",
    "contact_radius",
    "dynamic_contact_size",
    "estimate_contact_size",
    "jaffar_coefficients",
    "radius_of_model",
    "shear_modulus_for",
]

MODELS = ("thick", "thin", "thin-compressible")


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
    import scipy.integrate  # here, not at import: a program loaded from the cache needs no SciPy

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
    """Largest ``gamma`` up to which ``P(r_c)`` of eqs. 32-33 increases: the root of
    ``3 D(gamma) - gamma D'(gamma) = 9 pi - (32/5) b2 gamma^5`` (the ``b1`` terms cancel)."""
    _, b2 = jaffar_coefficients(nu)
    return float((9.0 * math.pi / (6.4 * b2)) ** 0.2) if b2 > 0 else math.inf


def _jaffar_z(gamma0, nu: float):
    """Solve ``3 pi z^3 = D(gamma0 z)`` for ``z = r_c / r_Hertz`` (eqs. 32-33), differentiable
    in ``gamma0`` (implicit function theorem). Returns ``(z, exists)``."""
    b1, b2 = jaffar_coefficients(nu)
    g_max = _jaffar_gamma_max(nu)

    def h(z):
        g = gamma0 * z
        return 3.0 * math.pi * z**3 - (3.0 * math.pi + 8.0 * g**3 * (b1 + 0.4 * b2 * g**2))

    # upper bracket: z at gamma_max (or a generous bound for thin gamma0 -> 0); h(0.5) < 0
    g0_pos = gamma0 > 0
    z_hi = jnp.minimum(jnp.where(g0_pos, g_max / where_safe(g0_pos, gamma0, 1.0), 10.0), 10.0)
    exists = h(z_hi) >= 0.0
    z0 = jnp.clip(jnp.ones_like(gamma0), 0.5, z_hi)
    z, _ = newton_root(h, z0, lower=0.5, upper=jax.lax.stop_gradient(z_hi), tol=1e-14, max_steps=60)
    return jnp.where(exists, z, jax.lax.stop_gradient(z_hi)), exists


# --------------------------------------------------------------------------------------
# radius of a model


def shear_modulus_for(material, modulus, V=None, radius_static=None):
    """The shear modulus [Pa] a radius formula uses: ``"static"`` (``G'(0)``), ``"glassy"``
    (``G'(inf)``), ``"dynamic"`` (``G'(V / r_static)``) or a number in Pa."""
    if isinstance(modulus, str):
        if modulus == "static":
            return material.relaxed_modulus()
        if modulus == "glassy":
            return material.glassy_modulus()
        if modulus == "dynamic":
            if V is None:
                raise ValueError('modulus="dynamic" needs the rolling speed V')
            return jnp.real(material.complex_modulus(V / radius_static))
        raise ValueError(f'unknown modulus {modulus!r}; use "static", "glassy", "dynamic" or a value in Pa')
    return as_float(modulus)


def radius_of_model(model, geometry, G, nu, H, R, P):
    """Contact radius (sphere) or half-width (cylinder) [m] of one model at shear modulus ``G``
    [Pa], and whether the model has a solution (Jaffar's law only can fail). ``nu`` is a
    Python float; ``H = inf`` is allowed for ``"thick"`` only."""
    if model not in MODELS:
        raise ValueError(f"unknown pressure model {model!r}; choose from {MODELS}")
    check_geometry(geometry)
    E = 2.0 * G * (1.0 + nu)
    inf_H = jnp.isinf(H)
    Hf = where_safe(inf_H, 1.0, H)
    always = jnp.ones(jnp.shape(P * G * H), dtype=bool)
    if geometry == "sphere":
        if model == "thick":
            r_hertz = hertz_sphere(P, R, G, nu).contact_radius
            gamma0 = jnp.where(inf_H, 0.0, r_hertz / Hf)
            z, exists = _jaffar_z(gamma0, float(nu))
            return r_hertz * z, exists
        if model == "thin":
            return (96.0 * P * R * Hf**3 / (math.pi * E)) ** (1.0 / 6.0), always
        c = 4.0 * (1.0 + nu) * (1.0 - 2.0 * nu) / ((1.0 - nu) * math.pi)
        return (c * P * R * Hf / E) ** 0.25, always
    if model == "thick":
        return hertz_cylinder(P, R, G, nu), always
    if model == "thin":
        return thin_layer_cylinder(P, R, Hf, G), always
    return (3.0 * P * R * Hf * (1.0 - 2.0 * nu) / (4.0 * G * (1.0 - nu))) ** (1.0 / 3.0), always


def contact_radius(material, layer, radius, load, *, model="thick", geometry="sphere", modulus="static",
                   speed=None):
    """Stationary contact radius (sphere) or half-width (cylinder) of a pressure model [m].

    Args:
        material: a material (only its modulus is used).
        layer: :class:`jaxroll.engines.layer.Layer` (``H`` [m], ``nu``).
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
    nu = float(layer.nu)
    if model == "thin-compressible" and nu >= 0.5:
        raise ValueError('pressure model "thin-compressible" needs a compressible layer (nu < 0.5)')
    R, P, H = as_float(radius), as_float(load), as_float(layer.H)
    if model != "thick" and not isinstance(H, jax.core.Tracer) and bool(jnp.any(jnp.isinf(H))):
        raise ValueError(f"pressure model {model!r} needs a finite layer thickness H")
    G = shear_modulus_for(material, modulus if modulus != "dynamic" else "static")
    if isinstance(modulus, str) and modulus == "dynamic":
        r_s, _ = radius_of_model(model, geometry, G, nu, H, R, P)
        G = shear_modulus_for(material, modulus, as_float(speed), r_s)
    return radius_of_model(model, geometry, G, nu, H, R, P)


def thin_model(layer) -> str:
    """The thin-layer model of a layer: ``"thin"`` (incompressible) or ``"thin-compressible"``."""
    return "thin" if layer.nu >= 0.5 else "thin-compressible"


def estimate_contact_size(material, layer, radius, load, geometry="sphere", *, modulus=None):
    """Stationary contact radius (sphere) or half-width (cylinder) [m] with the relaxed modulus
    (or the shear modulus ``modulus`` [Pa]), the estimate every grid rule and initial contact set
    uses.

    Sphere: Jaffar's thick-layer radius where his law has a solution (always on a half-space),
    else the smaller of the thin-layer and Hertz radii. Cylinder: the smaller of the Hertz and
    thin-layer half-widths. (A layer bonded to a rigid base is stiffer than the half-space, so
    its contact is never wider than Hertz's; the thin-layer laws overshoot it between the
    thick and thin ranges, e.g. 6.6 mm against Hertz's 5.7 mm at H = 2 mm, 150 N, R = 2 cm.)
    Smooth in every input except at Jaffar's ``gamma_max`` (sphere).
    """
    check_geometry(geometry)
    R, P, H = as_float(radius), as_float(load), as_float(layer.H)
    nu = float(layer.nu)
    G = material.relaxed_modulus() if modulus is None else as_float(modulus)
    inf_H = jnp.isinf(H)
    Hf = where_safe(inf_H, 1.0, H)
    r_k, exists = radius_of_model("thick", geometry, G, nu, H, R, P)
    r_t, _ = radius_of_model(thin_model(layer), geometry, G, nu, Hf, R, P)
    if geometry == "sphere":
        return jnp.where(exists | inf_H, r_k, jnp.minimum(r_t, hertz_sphere(P, R, G, nu).contact_radius))
    return jnp.where(inf_H, r_k, jnp.minimum(r_k, r_t))


#: Fixed-point steps of :func:`dynamic_contact_size`: each contracts the error by at least the
#: factor 1/3 (sphere) or 1/2 (cylinder), so 12 steps leave < 2.5e-4 relative.
DYNAMIC_SIZE_STEPS = 12


def dynamic_contact_size(material, layer, radius, load, speed, geometry="sphere"):
    """Contact radius (sphere) or half-width (cylinder) [m] of :func:`estimate_contact_size` with
    the dynamic modulus ``|G*(omega)|`` at the rolling frequency ``omega = V/a`` of that same size
    ``a``: the fixed point ``a = size(|G*(V/a)|)``, iterated from the relaxed size (its upper
    bound: ``|G*|`` grows with ``omega``).

    The solved rolling contact lies between the glassy and the relaxed sizes; this estimate
    follows it where the material stiffens at the rolling frequency (cold or fast), e.g. a broad
    Prony spectrum near its glassy end, where the relaxed size overestimates the contact several
    times. The map ``a -> size(|G*(V/a)|)`` increases with ``a`` with slope
    ``(1/3) d ln|G*|/d ln omega`` (Hertz sphere; 1/2 for the cylinder), below 1/3 (1/2) for a
    material whose modulus grows less than linearly with the frequency, so the iteration
    decreases monotonically to the fixed point (:data:`DYNAMIC_SIZE_STEPS` steps). ``V = 0``:
    the relaxed size. Jittable, differentiable (through the unrolled steps)."""
    a = estimate_contact_size(material, layer, radius, load, geometry)
    w_per_a = as_float(speed)

    def step(_, a):
        G = jnp.abs(material.complex_modulus(w_per_a / a))
        return estimate_contact_size(material, layer, radius, load, geometry, modulus=G)

    # each step rematerialised in reverse mode: one saved size per step, not every intermediate
    return jax.lax.fori_loop(0, DYNAMIC_SIZE_STEPS, jax.checkpoint(step, prevent_cse=False), a)
