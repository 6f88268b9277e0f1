"""Stationary pressure models ([ZG] sec. 4): Jaffar coefficients, contact radii, transforms."""

import math

import jax
import jax.numpy as jnp
import mpmath as mp
import numpy as np
import pytest
import scipy.integrate as si

import jaxroll as jr
from jaxroll.engines.contact_size import _jaffar_gamma_max
from jaxroll.engines.pressure import _transform_np

MAT = jr.StandardLinearSolid(3e6, 0.25, 1.0)
G0 = 3e6


def test_jaffar_coefficients_incompressible():
    # oracle: docs/conventions.md sec. 5's 15-digit values; tolerance: scipy quad at epsrel 1e-13
    b1, b2 = jr.engines.contact_size.jaffar_coefficients(0.5)
    assert b1 == pytest.approx(-0.957769288898079, rel=1e-12)
    assert b2 == pytest.approx(1.749436123749906, rel=1e-12)


def test_jaffar_coefficients_compressible_vs_mpmath():
    # oracle: mpmath quad of eq. 34 with the unscaled eq. 35 at 30 digits; tolerance: quad 1e-13
    nu = 0.3
    kappa = 3 - 4 * nu
    with mp.workdps(30):
        L = lambda w: (2 * kappa * mp.sinh(2 * w) - 4 * w) / (2 * kappa * mp.cosh(2 * w) + 4 * w**2 + kappa**2 + 1)
        ref = [(-0.25) ** m * mp.quad(lambda w: (1 - L(w)) * w ** (2 * m), [0, 5, 20, 60]) for m in (1, 2)]
    b1, b2 = jr.engines.contact_size.jaffar_coefficients(nu)
    assert b1 == pytest.approx(float(ref[0]), rel=1e-11)
    assert b2 == pytest.approx(float(ref[1]), rel=1e-11)


def test_paper_radius_thick():
    # oracle: [ZG] 4.6 "for P <= 120 N the contact radius remains below 4.87 mm" (H = 5 mm)
    r, ok = jr.engines.contact_size.contact_radius(MAT, jr.Layer(5e-3), 0.02, 120.0, model="thick")
    assert bool(ok)
    assert float(r) * 1e3 == pytest.approx(4.87, abs=0.005)  # stated to 3 digits


def test_paper_radii_thin():
    # oracle: [ZG] 4.6 "3.33 <= r_c <= 4.88 mm" for H = 10 um, R = 2000 m, P = 0.2..2 kN
    lay = jr.Layer(10e-6)
    r_lo, _ = jr.engines.contact_size.contact_radius(MAT, lay, 2000.0, 200.0, model="thin")
    r_hi, _ = jr.engines.contact_size.contact_radius(MAT, lay, 2000.0, 2000.0, model="thin")
    assert float(r_lo) * 1e3 == pytest.approx(3.33, abs=0.005)
    assert float(r_hi) * 1e3 == pytest.approx(4.88, abs=0.005)


@pytest.mark.parametrize("H", [2e-3, 5e-3, 30e-3])
def test_jaffar_radius_solves_load_law(H):
    # oracle: eqs. 32-33 evaluated at the returned radius give back P (root-find tolerance)
    b1, b2 = jr.engines.contact_size.jaffar_coefficients(0.5)
    for P in (10.0, 80.0):
        r, ok = jr.engines.contact_size.contact_radius(MAT, jr.Layer(H), 0.02, P)
        r = float(r)
        g = r / H
        if not bool(ok):
            assert g == pytest.approx(_jaffar_gamma_max(0.5) * 1.0, rel=1e-12)
            continue
        D = 3 * math.pi + 8 * g**3 * (b1 + 0.4 * b2 * g**2)
        P_back = 4 * math.pi * (3 * G0) * r**3 / (0.02 * D * (1 - 0.25))
        assert P_back == pytest.approx(P, rel=1e-12)


def test_halfspace_radius_is_hertz():
    # oracle: Hertz r = (3 P R / (4 E*))^(1/3), E* = 4 G0 (reference.hertz_sphere's convention)
    r, _ = jr.engines.contact_size.contact_radius(MAT, jr.Layer(jnp.inf), 0.02, 50.0)
    assert float(r) == pytest.approx((3 * 50.0 * 0.02 / (16 * G0)) ** (1 / 3), rel=1e-13)


def test_thin_compressible_radius_from_oedometric_stiffness():
    # oracle: p = k (r_c^2 - r^2)/(2R) with k = 1/T(q->0) of the compressible layer
    # (layer.transfer_compressible, independent of pressure.py) => P = k pi r_c^4/(4R)
    nu, H, R, P = 0.3, 1e-4, 0.5, 20.0
    r, _ = jr.engines.contact_size.contact_radius(MAT, jr.Layer(H, nu=nu), R, P, model="thin-compressible")
    t0 = float(jnp.real(jr.engines.layer.transfer_compressible(jnp.asarray(1e-3), H, 1.0 * G0 + 0j, nu)))
    k = 1.0 / t0
    assert k * math.pi * float(r) ** 4 / (4 * R) == pytest.approx(P, rel=1e-6)  # q = 1e-3 vs q -> 0: (qH)^2


def test_cylinder_half_widths():
    # oracles: reference.hertz_cylinder (a = sqrt(P' R/(pi G0))) and docs/validation.md sec. 1's thin-layer law
    a, _ = jr.engines.contact_size.contact_radius(MAT, jr.Layer(jnp.inf), 0.02, 1000.0, geometry="cylinder")
    assert float(a) == pytest.approx(float(jr.reference.hertz_cylinder(1000.0, 0.02, G0)), rel=1e-13)
    a, _ = jr.engines.contact_size.contact_radius(MAT, jr.Layer(1e-4), 0.02, 1000.0, geometry="cylinder", model="thin")
    assert float(a) == pytest.approx((15 * 1000.0 * 0.02 * 1e-12 / (2 * G0)) ** 0.2, rel=1e-13)


def test_modulus_options():
    # glassy modulus: the Hertz radius scales as G^(-1/3) (exact on a half-space)
    lay = jr.Layer(jnp.inf)
    r_s, _ = jr.engines.contact_size.contact_radius(MAT, lay, 0.02, 50.0)
    r_g, _ = jr.engines.contact_size.contact_radius(MAT, lay, 0.02, 50.0, modulus="glassy")
    r_n, _ = jr.engines.contact_size.contact_radius(MAT, lay, 0.02, 50.0, modulus=6e6)
    assert float(r_g) == pytest.approx(float(r_s) * 2 ** (-1 / 3), rel=1e-13)
    assert float(r_n) == pytest.approx(float(r_g), rel=1e-13)
    # dynamic: G'(V/r_static) lies between G0 and G0 (1+f)
    r_d, _ = jr.engines.contact_size.contact_radius(MAT, lay, 0.02, 50.0, modulus="dynamic", speed=0.01)
    assert float(r_g) < float(r_d) < float(r_s)
    with pytest.raises(ValueError, match="unknown modulus"):
        jr.engines.contact_size.contact_radius(MAT, lay, 0.02, 50.0, modulus="bogus")


def test_jaffar_radius_gradient_implicit():
    # oracle: central finite differences (step 1e-5 relative: error ~1e-10); the root find is
    # differentiated implicitly (custom_root), so this also checks the implicit adjoint
    def r_of(P, H):
        return jr.engines.contact_size.contact_radius(MAT, jr.Layer(H), 0.02, P)[0]

    P, H = 80.0, 5e-3
    gP, gH = jax.grad(r_of, argnums=(0, 1))(P, H)
    hP, hH = 1e-5 * P, 1e-5 * H
    fdP = (r_of(P + hP, H) - r_of(P - hP, H)) / (2 * hP)
    fdH = (r_of(P, H + hH) - r_of(P, H - hH)) / (2 * hH)
    assert float(gP) == pytest.approx(float(fdP), rel=1e-6)
    assert float(gH) == pytest.approx(float(fdH), rel=1e-6)


def _disk_transform(profile, r_c, q):
    # direct 2D integration of p(r) e^{-i q x} over the disk, product Gauss-Legendre in
    # (r, theta) with the sqrt edge removed by r = r_c sin(s) (independent of the closed forms)
    gs, ws = np.polynomial.legendre.leggauss(200)
    s = 0.25 * math.pi * (gs + 1)
    w_s = 0.25 * math.pi * ws
    r = r_c * np.sin(s)
    dr = r_c * np.cos(s) * w_s
    th = math.pi * (gs + 1)
    w_th = math.pi * ws
    kern = np.cos(q * r[:, None] * np.cos(th)[None, :])
    return float(np.sum(profile(r)[:, None] * kern * (r * dr)[:, None] * w_th[None, :]))


@pytest.mark.parametrize("model", ["thick", "thin", "thin-compressible"])
def test_sphere_transforms_vs_2d_integration(model):
    # oracle: direct 2D numerical integration of the pressure profile; tolerance: 200x200 GL
    r_c, P = 4e-3, 50.0
    prof = lambda r: np.asarray(jr.engines.pressure.pressure_profile(r, r_c, P, model=model))
    for x in (0.0, 0.7, 3.0, 9.5, 25.0):
        ref = _disk_transform(prof, r_c, x / r_c) / P
        val = float(jr.engines.pressure.pressure_transform(x, model=model))
        assert val == pytest.approx(ref, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("model", ["thick", "thin", "thin-compressible"])
def test_cylinder_transforms_vs_integration(model):
    # oracle: scipy quad of int p(x) cos(q x) dx over the contact (weight='cos')
    a, P = 1e-3, 100.0
    for xq in (0.3, 2.0, 11.0, 40.0):
        q = xq / a
        ref = si.quad(lambda x: float(jr.engines.pressure.pressure_profile(x, a, P, model=model, geometry="cylinder")),
                      -a, a, weight="cos", wvar=q, epsabs=0, epsrel=1e-12)[0] / P
        val = float(jr.engines.pressure.pressure_transform(xq, model=model, geometry="cylinder"))
        assert val == pytest.approx(ref, rel=1e-8, abs=1e-12)


@pytest.mark.parametrize("geometry", ["sphere", "cylinder"])
@pytest.mark.parametrize("model", ["thick", "thin", "thin-compressible"])
def test_transform_small_x_and_gradient(model, geometry):
    # S(0) = 1 (normalisation) and continuity across the Taylor-series switch; jax vs the
    # scipy-Bessel twin used for the quadrature weights (1e-13: Bessel accuracy)
    x = jnp.array([0.0, 0.049, 0.051, 0.49, 0.51, 1.3, 17.0, 80.0])
    S = jr.engines.pressure.pressure_transform(x, model=model, geometry=geometry)
    assert float(S[0]) == 1.0
    ref = _transform_np(np.asarray(x), model, geometry)
    np.testing.assert_allclose(np.asarray(S), ref, rtol=1e-11, atol=1e-14)
    g = jax.vmap(jax.grad(lambda t: jr.engines.pressure.pressure_transform(t, model=model, geometry=geometry)))(x)
    assert np.all(np.isfinite(np.asarray(g)))
    assert float(g[0]) == 0.0
    # derivative oracle: mpmath differentiation of the closed form at 40 digits
    with mp.workdps(40):
        ref_d = [float(mp.diff(lambda t: _S_mp(t, model, geometry), mp.mpf(float(t)))) for t in x[1:]]
    np.testing.assert_allclose(np.asarray(g[1:]), ref_d, rtol=1e-9, atol=1e-14)


def _S_mp(x, model, geometry):
    if geometry == "sphere" and model == "thick" or geometry == "cylinder" and model == "thin-compressible":
        return 3 * (mp.sin(x) - x * mp.cos(x)) / x**3
    if geometry == "sphere" and model == "thin":
        return 48 * mp.besselj(3, x) / x**3
    if geometry == "sphere":
        return 8 * mp.besselj(2, x) / x**2
    if model == "thick":
        return 2 * mp.besselj(1, x) / x
    return 15 * ((3 - x * x) * mp.sin(x) - 3 * x * mp.cos(x)) / x**5


def test_bad_model_names():
    with pytest.raises(ValueError, match="unknown pressure model"):
        jr.engines.pressure.pressure_transform(1.0, model="medium")
    with pytest.raises(ValueError, match="compressible layer"):
        jr.engines.contact_size.contact_radius(MAT, jr.Layer(1e-3), 0.02, 10.0, model="thin-compressible")
    with pytest.raises(ValueError, match="finite layer thickness"):
        jr.engines.contact_size.contact_radius(MAT, jr.Layer(jnp.inf), 0.02, 10.0, model="thin")
