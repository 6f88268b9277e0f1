"""jaxroll.engines.special against scipy.special and mpmath (independent oracles), derivatives against
the recurrence identities and central finite differences."""

import jax
import jax.numpy as jnp
import mpmath
import numpy as np
import pytest
import scipy.special as sp

from jaxroll.engines import special

JN = [special.j0, special.j1, special.j2, special.j3]


def _envelope(x):
    """``min(1, sqrt(2/(pi x)))``: the size of |J_n| for large x. XLA reduces cos/sin arguments
    exactly, so the absolute error shrinks with this envelope (measured < 3e-16 of it)."""
    return np.minimum(1.0, np.sqrt(2.0 / (np.pi * np.maximum(np.abs(x), 1e-300))))


def _dense_grid():
    # every branch (series < 2 <= Miller < 25 <= Hankel), the branch edges, and far out
    return np.concatenate([
        np.linspace(0.0, 40.0, 40001),
        np.geomspace(1e-12, 2e4, 4001),
        np.array([2.0 - 1e-12, 2.0, 2.0 + 1e-12, 25.0 - 1e-12, 25.0, 25.0 + 1e-12]),
    ])


@pytest.mark.parametrize("n", [0, 1, 2, 3])
def test_jn_values_vs_scipy_dense(n):
    x = _dense_grid()
    got = np.asarray(jax.jit(JN[n])(x))
    ref = sp.jv(n, x)
    # error source: float64 rounding in the recurrence/expansion (~1e-16) plus scipy's own
    # error (~1e-16), both proportional to the envelope (measured max 4.7e-16 at x ~ 20)
    np.testing.assert_array_less(np.abs(got - ref), 5e-15 * _envelope(x))
    # relative accuracy where |J| is not near a zero
    away = np.abs(ref) > 1e-2 / np.sqrt(np.maximum(x, 1.0))
    np.testing.assert_allclose(got[away], ref[away], rtol=1e-12, atol=0)


@pytest.mark.parametrize("n", [0, 1, 2, 3])
def test_jn_vs_mpmath_including_zeros_and_large_x(n):
    mpmath.mp.dps = 30
    zeros = [float(mpmath.besseljzero(n, k)) for k in (1, 2, 10, 100, 3000)]
    x = np.array(zeros + [1e-6, 0.5, 1.9999, 2.0001, 7.3, 19.0, 24.9999, 25.0001, 99.5, 1234.5, 1e4 + 0.3, 1e5 + 0.7, 1e8 + 0.5, 1e15])
    got = np.asarray(special.jn(n, x))
    ref = np.array([float(mpmath.besselj(n, xi)) for xi in x])
    # absolute, at the (float-rounded) zeros too, where mpmath gives the tiny true value
    # J_n'(z)(x - z): error source is rounding, ~1e-16 times the envelope
    np.testing.assert_array_less(np.abs(got - ref), 3e-15 * _envelope(x))


def test_jn_parity_zero_and_small_x():
    x = np.linspace(-30.0, 30.0, 601)
    for n in range(4):
        np.testing.assert_allclose(special.jn(n, x), sp.jv(n, x), rtol=0, atol=5e-15)  # rounding
    # exact values at 0 and the leading power law (series of J_n, exact to 1e-16 relative)
    np.testing.assert_array_equal(np.asarray([special.jn(n, 0.0) for n in range(4)]), [1.0, 0.0, 0.0, 0.0])
    x = 1e-5
    np.testing.assert_allclose(special.j3(x), x**3 / 48.0 * (1 - x * x / 16.0), rtol=1e-15)


@pytest.mark.parametrize("n", [0, 1, 2, 3])
def test_jn_derivatives_vs_identities_and_scipy(n):
    x = np.concatenate([np.linspace(0.0, 40.0, 4001), np.geomspace(40.0, 1e4, 300)])
    d1 = np.asarray(jax.jit(jax.vmap(jax.grad(lambda t: special.jn(n, t))))(x))
    d2 = np.asarray(jax.jit(jax.vmap(jax.grad(jax.grad(lambda t: special.jn(n, t)))))(x))
    env = _envelope(x)
    # scipy.special.jvp evaluates the same identities with scipy's own J_n (independent code);
    # error source: rounding of J values, ~1e-16 * envelope
    np.testing.assert_array_less(np.abs(d1 - sp.jvp(n, x, 1)), 5e-15 * env)
    np.testing.assert_array_less(np.abs(d2 - sp.jvp(n, x, 2)), 5e-15 * env)
    # Bessel's equation x^2 J'' + x J' + (x^2 - n^2) J = 0 (independent of the jvp rule's form)
    j = sp.jv(n, x)
    resid = x * x * d2 + x * d1 + (x * x - n * n) * j
    np.testing.assert_array_less(np.abs(resid), 1e-14 * (1.0 + x * x) * env)


def test_jn_gradient_at_zero_and_finite_differences():
    g = jax.grad
    # exact derivatives at 0: J0' = 0, J0'' = -1/2, J1' = 1/2, J2'' = 1/4, J3'' = 0
    assert float(g(special.j0)(0.0)) == 0.0
    assert float(g(g(special.j0))(0.0)) == -0.5
    assert float(g(special.j1)(0.0)) == 0.5
    assert float(g(g(special.j2))(0.0)) == 0.25
    assert float(g(g(special.j3))(0.0)) == 0.0
    # central finite differences (step 1e-6: truncation ~1e-12, rounding ~1e-10)
    x0 = jnp.array([0.3, 2.0, 11.7, 25.0, 300.2])
    for n, f in enumerate(JN):
        fd = (f(x0 + 1e-6) - f(x0 - 1e-6)) / 2e-6
        np.testing.assert_array_less(np.abs(jax.vmap(g(f))(x0) - fd), 2e-9)
    assert jnp.all(jnp.isfinite(jax.vmap(g(special.j2))(jnp.array([0.0, -1.0, 1e6]))))


def test_jn_shapes_jit_vmap_and_errors():
    x = jnp.linspace(0.0, 50.0, 24).reshape(2, 3, 4)
    y = special.j1(x)
    assert y.shape == (2, 3, 4) and y.dtype == jnp.float64
    # vmap/jit may fuse differently: agreement to rounding (1e-15)
    np.testing.assert_allclose(jax.vmap(special.j1)(x.reshape(-1)), y.reshape(-1), rtol=0, atol=1e-15)
    np.testing.assert_allclose(jax.jit(special.j1)(x), y, rtol=0, atol=1e-15)
    with pytest.raises(ValueError):
        special.jn(9, 1.0)
    with pytest.raises(ValueError):
        special.jn(-1, 1.0)


def _mp(fun, x, scale):
    mpmath.mp.dps = 30
    return np.array([float(fun(mpmath.mpf(xi)) * scale(mpmath.mpf(xi))) for xi in x])


def test_modified_bessel_vs_mpmath():
    x = np.geomspace(1e-6, 1e3, 241)
    # scipy uses the same Cephes tables for k0e/k1e, so the oracle is mpmath (30 digits).
    # Error source: Cephes Chebyshev truncation + rounding, documented 1.4e-15 peak.
    cases = [
        (special.k0e, lambda t: mpmath.besselk(0, t), mpmath.exp),
        (special.k1e, lambda t: mpmath.besselk(1, t), mpmath.exp),
        (special.i0e, lambda t: mpmath.besseli(0, t), lambda t: mpmath.exp(-t)),
        (special.i1e, lambda t: mpmath.besseli(1, t), lambda t: mpmath.exp(-t)),
        (special.i2e, lambda t: mpmath.besseli(2, t), lambda t: mpmath.exp(-t)),
    ]
    for fun, ref, scale in cases:
        got = np.asarray(jax.jit(fun)(x))
        # i2e: the recurrence I0 - 2 I1/x loses a factor ~3 near x = 2 (cancellation)
        np.testing.assert_allclose(got, _mp(ref, x, scale), rtol=1e-14, atol=0)
    np.testing.assert_allclose(special.i2e(-3.0), sp.ive(2, 3.0), rtol=1e-14)  # even function
    assert float(special.k0e(0.0)) == np.inf


def test_modified_bessel_derivatives():
    x = np.geomspace(1e-3, 1e3, 61)
    mpmath.mp.dps = 30
    K0 = _mp(lambda t: mpmath.besselk(0, t), x, mpmath.exp)
    K1 = _mp(lambda t: mpmath.besselk(1, t), x, mpmath.exp)
    dk0 = np.asarray(jax.vmap(jax.grad(special.k0e))(x))
    dk1 = np.asarray(jax.vmap(jax.grad(special.k1e))(x))
    # d/dx (e^x K0) = e^x (K0 - K1); d/dx (e^x K1) = e^x (K1 - K0 - K1/x), mpmath values;
    # K0 - K1 cancels for large x (|k0e - k1e| ~ k0e/(2x)) -> absolute tolerance on k1e scale
    np.testing.assert_array_less(np.abs(dk0 - (K0 - K1)), 1e-14 * K1)
    np.testing.assert_array_less(np.abs(dk1 - (K1 - K0 - K1 / x)), 1e-14 * K1 * (1.0 + 1.0 / x))
    # central finite differences (relative step 1e-6: error ~1e-11 relative)
    x0 = jnp.array([0.01, 1.5, 2.0, 3.0, 40.0])
    h = 1e-6 * x0
    for f in (special.k0e, special.k1e, special.i2e):
        fd = (f(x0 + h) - f(x0 - h)) / (2 * h)
        np.testing.assert_allclose(jax.vmap(jax.grad(f))(x0), fd, rtol=1e-7, atol=1e-12)
    # second derivative through the custom JVP, by finite differences of the first
    g = jax.grad(special.k0e)
    x0 = jnp.array([0.5, 5.0])
    h = 1e-4 * x0
    fd = (jax.vmap(g)(x0 + h) - jax.vmap(g)(x0 - h)) / (2 * h)
    np.testing.assert_allclose(jax.vmap(jax.grad(g))(x0), fd, rtol=1e-6)  # FD truncation ~1e-8


def test_k_functions_reject_negative_arguments():
    with pytest.raises(Exception, match="defined for x >= 0"):
        jax.block_until_ready(special.k0e(jnp.array([1.0, -1.0])))
    with pytest.raises(Exception, match="defined for x >= 0"):
        jax.block_until_ready(special.k1e(-2.0))
