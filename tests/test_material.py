"""Material models: limits of [ZG] eq. 12, Prony equivalence, G(t) <-> G*(omega) through a
numerical Fourier transform, time-temperature shifts, pytree behaviour, gradients."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import integrate

import jaxroll as jr

SLS = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=1.0)
PRONY = jr.GeneralizedMaxwell(G_inf=1e6, G=[2e6, 5e5, 1e5], tau=[1e-3, 0.05, 2.0])


def test_sls_matches_paper_eq12_storage_and_loss():
    w = np.logspace(-4, 4, 41)
    G0, tau, f = 3e6, 0.25, 1.0
    # [ZG] eq. 12 written out (independent of the complex form)
    Gp = G0 * (1 + f) * ((1 + f) + w**2 * tau**2) / ((1 + f) ** 2 + w**2 * tau**2)
    Gpp = G0 * (1 + f) * f * w * tau / ((1 + f) ** 2 + w**2 * tau**2)
    np.testing.assert_allclose(jr.materials.storage_modulus(SLS, w), Gp, rtol=1e-14)
    np.testing.assert_allclose(jr.materials.loss_modulus(SLS, w), Gpp, rtol=1e-14)
    np.testing.assert_allclose(jr.materials.tan_delta(SLS, w), Gpp / Gp, rtol=1e-14)


@pytest.mark.parametrize("mat", [SLS, PRONY])
def test_limits_and_positive_loss(mat):
    relaxed, glassy = float(jr.materials.relaxed_modulus(mat)), float(jr.materials.glassy_modulus(mat))
    assert jr.materials.storage_modulus(mat, 1e-12) == pytest.approx(relaxed, rel=1e-12)
    assert jr.materials.storage_modulus(mat, 1e12) == pytest.approx(glassy, rel=1e-9)
    w = np.logspace(-6, 6, 200)
    assert np.all(np.asarray(jr.materials.loss_modulus(mat, w)) > 0)
    assert np.all(np.asarray(jr.materials.loss_modulus(mat, -w)) < 0)  # G*(-w) = conj G*(w)
    assert jr.materials.relaxation_modulus(mat, 0.0) == pytest.approx(glassy, rel=1e-14)
    assert jr.materials.relaxation_modulus(mat, 1e6) == pytest.approx(relaxed, rel=1e-14)


def test_sls_glassy_and_relaxed():
    assert float(jr.materials.relaxed_modulus(SLS)) == 3e6
    assert float(jr.materials.glassy_modulus(SLS)) == 6e6  # f = G'(inf)/G'(0) - 1 (eq. 12, not the text)


def test_sls_equals_one_term_prony():
    p = SLS.to_prony()
    w = np.logspace(-5, 5, 101)
    np.testing.assert_allclose(jr.complex_modulus(p, w), jr.complex_modulus(SLS, w), rtol=1e-14)
    t = np.logspace(-4, 2, 50)
    np.testing.assert_allclose(jr.materials.relaxation_modulus(p, t), jr.materials.relaxation_modulus(SLS, t), rtol=1e-14)


@pytest.mark.parametrize("mat", [SLS, PRONY])
def test_relaxation_and_complex_modulus_consistent_by_fourier_transform(mat):
    """G*(w) = G(inf) + i w int_0^inf (G(t) - G(inf)) e^{-i w t} dt, by quadrature."""
    g_inf = float(jr.materials.relaxed_modulus(mat))

    def dG(t):
        return float(jr.materials.relaxation_modulus(mat, t)) - g_inf

    t_max = 40.0 * float(jnp.max(jnp.atleast_1d(mat.tau)))  # dG(t_max) < 1e-17 dG(0)
    for w in [0.1, 3.0, 50.0, 700.0]:
        re = integrate.quad(dG, 0, t_max, weight="sin", wvar=w, limit=2000)[0]  # int dG sin
        im = integrate.quad(dG, 0, t_max, weight="cos", wvar=w, limit=2000)[0]  # int dG cos
        # i w (C - i S) = w S + i w C
        num = g_inf + w * re + 1j * w * im
        # QUADPACK's Fourier quadrature reaches ~1e-10 relative here
        assert complex(jr.complex_modulus(mat, w)) == pytest.approx(num, rel=1e-8)


def test_wlf_and_arrhenius_shift():
    wlf = jr.WLF(C1=8.86, C2=101.6, T_ref=300.0)
    assert float(jr.materials.shift_factor(wlf, 300.0)) == 1.0
    T = 320.0
    expected = 10 ** (-8.86 * 20.0 / (101.6 + 20.0))
    assert float(jr.materials.shift_factor(wlf, T)) == pytest.approx(expected, rel=1e-14)
    hot = jr.at_temperature(SLS, wlf, T)
    w = np.logspace(-2, 3, 11)
    np.testing.assert_allclose(jr.complex_modulus(hot, w), jr.complex_modulus(SLS, w * expected), rtol=1e-14)
    np.testing.assert_allclose(
        jr.materials.relaxation_modulus(hot, w), jr.materials.relaxation_modulus(SLS, w / expected), rtol=1e-14
    )
    arr = jr.Arrhenius(activation_energy=80e3, T_ref=300.0)
    a = float(jr.materials.shift_factor(arr, 280.0))
    assert a == pytest.approx(np.exp(80e3 / 8.314462618 * (1 / 280.0 - 1 / 300.0)), rel=1e-14)
    assert a > 1  # colder: slower, so the reference curve is read at a higher frequency
    with pytest.raises(Exception, match="WLF"):
        jr.materials.shift_factor(wlf, 300.0 - 101.6)
    with pytest.raises(Exception, match="kelvin"):
        jr.materials.shift_factor(arr, -5.0)


def test_pytree_roundtrip_grad_and_vmap():
    leaves, treedef = jax.tree_util.tree_flatten(SLS)
    assert len(leaves) == 3
    back = jax.tree_util.tree_unflatten(treedef, leaves)
    assert back == SLS or all(jnp.array_equal(a, b) for a, b in zip(jax.tree_util.tree_leaves(back), leaves))

    def loss(m):
        return jr.materials.loss_modulus(m, 4.0) / 1e6

    g = jax.grad(loss)(SLS)
    for name, h in [("G0", 30.0), ("tau", 1e-7), ("f", 1e-7)]:
        plus = jax.tree_util.tree_map(lambda x: x, SLS)
        plus = type(SLS)(**{k: getattr(SLS, k) + (h if k == name else 0.0) for k in ("G0", "tau", "f")})
        minus = type(SLS)(**{k: getattr(SLS, k) - (h if k == name else 0.0) for k in ("G0", "tau", "f")})
        fd = (loss(plus) - loss(minus)) / (2 * h)
        # central differences, truncation O(h^2), rounding ~1e-16/h relative
        assert float(getattr(g, name)) == pytest.approx(float(fd), rel=1e-7)

    G0s = jnp.asarray([1e6, 2e6, 3e6])
    batch = jax.vmap(lambda G0: jr.complex_modulus(jr.StandardLinearSolid(G0, 0.25, 1.0), 2.0))(G0s)
    loop = [jr.complex_modulus(jr.StandardLinearSolid(G0, 0.25, 1.0), 2.0) for G0 in G0s]
    np.testing.assert_array_equal(batch, jnp.stack(loop))
    pg = jax.grad(lambda m: jr.materials.storage_modulus(m, 10.0))(PRONY)
    assert pg.G.shape == (3,)


def test_float32_inputs_promoted():
    w32 = jnp.asarray([1.5, 20.0], dtype=jnp.float32)
    out = jr.complex_modulus(SLS, w32)
    assert out.dtype == jnp.complex128
    m32 = jr.StandardLinearSolid(np.float32(3e6), np.float32(0.25), np.float32(1.0))
    assert m32.G0.dtype == jnp.float64


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(G0=-1.0, tau=0.25, f=1.0), "G0"),
        (dict(G0=3e6, tau=0.0, f=1.0), "tau"),
        (dict(G0=3e6, tau=0.25, f=-0.5), "f must"),
        (dict(G0=float("nan"), tau=0.25, f=1.0), "G0"),
    ],
)
def test_bad_parameters_rejected(kw, match):
    with pytest.raises(ValueError, match=match):
        jr.StandardLinearSolid(**kw)


def test_bad_prony_rejected():
    with pytest.raises(ValueError, match="same shape"):
        jr.GeneralizedMaxwell(G_inf=1e6, G=[1e6, 2e6], tau=[1.0])
    with pytest.raises(ValueError, match="tau"):
        jr.GeneralizedMaxwell(G_inf=1e6, G=[1e6], tau=[-1.0])
