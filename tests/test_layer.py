"""Layer transfer functions against a 6x6 high-precision expm of [ZG] eq. 22 (the oracle),
their limits, isotropy, stability and gradients."""

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jr
from jaxroll.engines.layer import transfer_compressible, transfer_incompressible

from _oracles import transfer_expm_compressible, transfer_expm_incompressible

MAT = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=1.0)

# (qH, rho V^2/|G|, phase of G_m [rad], qy/qx). |eps| = rho V^2 qx^2/(|G| q^2) spans 0..0.9.
QH = [1e-3, 1e-2, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 100.0, 1e3]
EPS = [0.0, 1e-10, 1e-6, 1e-3, 0.05, 0.3, 0.9]
PHASE = [0.0, -0.3, -1.0]  # G_m = conj(G*): Im G_m <= 0 for q_x V > 0
TABLE = [(qh, e, ph) for qh, e, ph in itertools.product(QH, EPS, PHASE)]


def _case(qh, eps_mag, phase, qy_over_qx=0.0, H=0.01):
    """Physical inputs reproducing (qH, |eps|, arg G_m)."""
    q = qh / H
    qx = q / np.hypot(1.0, qy_over_qx)
    qy = qx * qy_over_qx
    G = 2.5e6 * np.exp(1j * phase)
    rho = 1000.0
    # eps = rho V^2 qx^2/(G q^2): |eps| = eps_mag when qy = 0
    V = np.sqrt(eps_mag * abs(G) / rho) * q / qx
    eps = rho * V * V * qx * qx / (G * q * q)
    return q, qx, qy, H, G, rho, V, eps


@pytest.mark.parametrize("qh,eps_mag,phase", TABLE)
def test_incompressible_closed_form_matches_expm(qh, eps_mag, phase):
    q, qx, qy, H, G, rho, V, eps = _case(qh, eps_mag, phase)
    ref = transfer_expm_incompressible(qx, qy, H, G, rho, V)
    val = complex(transfer_incompressible(jnp.asarray(q), jnp.asarray(H), jnp.asarray(G), jnp.asarray(eps)))
    # error budget: float64 rearrangement, worst ~4e-14 (0/0 removed analytically)
    assert abs(val - ref) <= 1e-12 * abs(ref)


@pytest.mark.parametrize("eps_mag,phase", [(0.0, 0.0), pytest.param(0.3, -0.3, marks=pytest.mark.slow),
                                           pytest.param(0.9, -1.0, marks=pytest.mark.slow)])  # 8700-digit expm: 14 s each
# (suite time: the elastic case runs by default; the two viscoelastic phases under -m slow)
def test_incompressible_qh_1e4_matches_expm(eps_mag, phase):
    # qH = 1e4 needs a ~8700-digit expm (a few seconds per point)
    q, qx, qy, H, G, rho, V, eps = _case(1e4, eps_mag, phase)
    ref = transfer_expm_incompressible(qx, qy, H, G, rho, V)
    val = complex(transfer_incompressible(jnp.asarray(q), jnp.asarray(H), jnp.asarray(G), jnp.asarray(eps)))
    assert abs(val - ref) <= 1e-12 * abs(ref)


@pytest.mark.parametrize("qh,eps_mag,ratio", [(0.7, 0.5, 0.75), (3.0, 0.2, 2.0), (20.0, 0.8, 0.3)])
def test_3d_mode_equals_plane_strain_at_same_q_and_eps(qh, eps_mag, ratio):
    """Isotropy: the 3D T_mn (qx, qy) from the 6x6 oracle equals the plane-strain oracle at
    wavenumber q with the same eps, and the library's T at (q, eps)."""
    q, qx, qy, H, G, rho, V, eps = _case(qh, eps_mag, -0.4, qy_over_qx=ratio)
    t3d = transfer_expm_incompressible(qx, qy, H, G, rho, V)
    # plane strain at q: choose V2 with rho V2^2 q^2 = rho V^2 qx^2 (same eps)
    t2d = transfer_expm_incompressible(q, 0.0, H, G, rho, V * qx / q)
    assert abs(t3d - t2d) <= 1e-13 * abs(t3d)
    val = complex(transfer_incompressible(jnp.asarray(q), jnp.asarray(H), jnp.asarray(G), jnp.asarray(eps)))
    assert abs(val - t3d) <= 1e-12 * abs(t3d)


def test_surface_compliance_public_api_matches_oracle_with_mode_modulus():
    """End to end: the public function uses G_m = conj(G*(qx V)) and eps = rho V^2 qx^2/(G_m q^2)."""
    layer = jr.Layer(H=0.005, rho=1100.0)
    V = 20.0  # large speed so that inertia matters (c_s = 52 m/s)
    for qx, qy in [(300.0, 0.0), (300.0, 400.0), (2000.0, -1500.0), (-300.0, 100.0)]:
        G = complex(np.conj(complex(jr.complex_modulus(MAT, qx * V))))
        ref = transfer_expm_incompressible(qx, qy, 0.005, G, 1100.0, V)
        val = complex(jr.engines.layer.surface_compliance(layer, MAT, qx, qy, V))
        assert abs(val - ref) <= 1e-12 * abs(ref)
        assert val.real > 0
        # dissipation sign: Im T > 0 when qx V > 0, < 0 when qx V < 0
        assert np.sign(val.imag) == np.sign(qx * V)


@pytest.mark.parametrize("nu", [0.0, 0.25, 0.4, 0.49, 0.499])
@pytest.mark.parametrize("qh", [1e-3, 0.1, 1.0, 5.0, 30.0])
def test_compressible_closed_form_matches_expm(nu, qh):
    H = 0.01
    q = qh / H
    G = 2e6 * np.exp(-0.2j)
    ref = transfer_expm_compressible(0.6 * q, 0.8 * q, H, G, nu)
    val = complex(transfer_compressible(jnp.asarray(q), jnp.asarray(H), jnp.asarray(G), nu))
    assert abs(val - ref) <= 1e-12 * abs(ref)


def test_compressible_is_continuous_at_incompressible_limit():
    H, G = 0.01, jnp.asarray(2e6 + 0j)
    q = jnp.logspace(-1, 5, 61)
    t_inc = transfer_incompressible(q, H, G, jnp.zeros(q.shape, jnp.complex128))
    t_c = transfer_compressible(q, H, G, 0.5 - 1e-9)
    # first-order in (0.5 - nu) at qH -> 0 (oedometric term H(1-2nu)/(2(1-nu)G)), else ~1e-9
    np.testing.assert_allclose(t_c, t_inc, rtol=1e-7, atol=2e-9 * H / 2e6)
    t_c05 = transfer_compressible(q, H, G, 0.5)
    np.testing.assert_allclose(t_c05, t_inc, rtol=1e-13)


def test_limits():
    G = jnp.asarray(3e6 + 0j)
    H = 0.004
    # q -> 0: q^2 H^3/(3 G)
    q = jnp.asarray([1e-6, 1e-4, 1e-3])
    # next term of the expansion is O((qH)^2) ~ 2e-11 relative at qH = 4e-6
    np.testing.assert_allclose(transfer_incompressible(q, H, G, jnp.zeros(q.shape, jnp.complex128)), q**2 * H**3 / (3 * 3e6), rtol=1e-9)
    # H -> inf: 1/(2 G q), and the half-space with inertia
    q = jnp.asarray([10.0, 100.0, 1e4])
    np.testing.assert_allclose(transfer_incompressible(q, jnp.inf, G, jnp.zeros(q.shape, jnp.complex128)), 1 / (2 * 3e6 * q), rtol=1e-15)
    np.testing.assert_allclose(transfer_incompressible(q, 1e3, G, jnp.zeros(q.shape, jnp.complex128)), 1 / (2 * 3e6 * q), rtol=1e-15)
    eps = jnp.asarray(0.4 + 0.1j)
    s = np.sqrt(1 - (0.4 + 0.1j))
    hs = (1 + s) / ((4 * s + (s - 1) * (1 + s) ** 2) * 3e6 * np.asarray(q))
    np.testing.assert_allclose(transfer_incompressible(q, jnp.inf, G, jnp.broadcast_to(eps, q.shape)), hs, rtol=1e-15)
    np.testing.assert_allclose(transfer_incompressible(q, 10.0, G, jnp.broadcast_to(eps, q.shape)), hs, rtol=1e-14)
    # rho -> 0 is the quasi-static form F(qH)/(2 G q)
    a = np.asarray([0.05, 0.5, 2.0, 8.0])
    F = (np.sinh(2 * a) - 2 * a) / (np.cosh(2 * a) + 2 * a**2 + 1)
    # eps = 1e-14 perturbs T by O(1e-14) relative
    np.testing.assert_allclose(transfer_incompressible(jnp.asarray(a / H), H, G, jnp.full(a.shape, 1e-14, dtype=jnp.complex128)), F / (2 * 3e6 * a / H), rtol=1e-12)
    # compressible half-space (1 - nu)/(G q) and q -> 0 oedometric H (1 - 2 nu)/(2 (1 - nu) G)
    np.testing.assert_allclose(transfer_compressible(q, jnp.inf, G, 0.3), 0.7 / (3e6 * q), rtol=1e-15)
    np.testing.assert_allclose(transfer_compressible(jnp.asarray(1e-9), H, G, 0.3), H * 0.4 / (1.4 * 3e6), rtol=1e-9)


def test_zero_mode_and_halfspace_are_finite_with_finite_gradients():
    mat = MAT
    for layer in [jr.Layer(H=0.01, rho=1000.0), jr.Layer(H=jnp.inf, rho=1000.0), jr.Layer(H=0.01, nu=0.3),
                  jr.Layer(H=jnp.inf, nu=0.3)]:
        t = jr.engines.layer.surface_compliance(layer, mat, 0.0, 0.0, 1.0)
        assert t == 0 or layer.nu < 0.5 and jnp.isfinite(t)

        def f(params):
            G0, tau, f_, V = params
            m = jr.StandardLinearSolid(G0, tau, f_)
            qx = jnp.asarray([0.0, 0.0, 1e-3, 50.0, 1e5])
            qy = jnp.asarray([0.0, 1.0, 0.0, 20.0, 0.0])
            T = jr.engines.layer.surface_compliance(layer, m, qx, qy, V)
            return jnp.sum(jnp.real(T) * 1e9 + jnp.imag(T) * 1e9)

        g = jax.grad(f)((3e6, 0.25, 1.0, 1.0))
        assert all(np.isfinite(np.asarray(x)) for x in g)


def test_no_nan_or_inf_over_the_whole_range():
    """Values and gradients finite for qH in [0, 1e4], |eps| <= 0.9, complex moduli."""
    qh = jnp.concatenate([jnp.zeros(1), jnp.logspace(-6, 4, 60)])
    eps = jnp.asarray([0.0, 1e-12, 1e-6, 0.01, 0.2, 0.5, 0.9], dtype=jnp.complex128) * jnp.exp(1j * 0.4)
    QH_, E_ = jnp.meshgrid(qh, eps)
    G = jnp.asarray(3e6 * jnp.exp(-0.5j))

    def total(H):
        t = transfer_incompressible(QH_ / 0.01, H, G, E_)
        return jnp.sum(jnp.abs(t)), t

    (val, t), g = jax.value_and_grad(total, has_aux=True)(jnp.asarray(0.01))
    assert np.all(np.isfinite(np.asarray(t))) and np.isfinite(g)
    assert np.all(np.real(np.asarray(t))[:, 1:] > 0)
    g_inf = jax.grad(lambda H: total(H)[0])(jnp.asarray(jnp.inf))
    assert np.isfinite(g_inf)


def _fd(f, x, h):
    return (f(x + h) - f(x - h)) / (2 * h)


@pytest.mark.parametrize("layer_kw", [dict(rho=1100.0), dict(rho=0.0), dict(nu=0.3)])
def test_gradients_match_central_differences(layer_kw):
    qx = jnp.asarray([30.0, 400.0, 3000.0])
    qy = jnp.asarray([0.0, 300.0, 1000.0])

    def T(H, G0, tau, f, V):
        return jr.engines.layer.surface_compliance(jr.Layer(H=H, **layer_kw), jr.StandardLinearSolid(G0, tau, f), qx, qy, V)

    x0 = dict(H=0.004, G0=3e6, tau=0.02, f=1.0, V=5.0)
    for name in x0:
        for part in (jnp.real, jnp.imag):
            def g(v, name=name, part=part):
                kw = dict(x0)
                kw[name] = v
                return part(T(**kw))

            jac = jax.jacfwd(g)(jnp.asarray(x0[name]))
            h = 1e-5 * abs(x0[name])
            fd = _fd(g, x0[name], h)
            # central differences: truncation O(h^2) ~1e-10 relative; rounding
            # ~eps_machine |T| / h, which dominates where T depends weakly on the parameter
            rounding = 10 * 2.2e-16 * float(jnp.max(jnp.abs(g(x0[name])))) / h
            np.testing.assert_allclose(jac, fd, rtol=1e-7, atol=rounding)
            rev = jax.grad(lambda v: jnp.sum(g(v)))(jnp.asarray(x0[name]))
            np.testing.assert_allclose(rev, jnp.sum(jac), rtol=1e-12, atol=1e-30)


def test_vmap_over_mode_grid_and_batches():
    layer = jr.Layer(H=0.005, rho=1000.0)
    m = jnp.arange(-20.0, 21.0)
    qx, qy = jnp.meshgrid(2 * jnp.pi * m / 0.2, 2 * jnp.pi * m / 0.2, indexing="ij")
    speeds = jnp.asarray([1e-3, 0.1, 1.0])
    batched = jax.vmap(lambda V: jr.engines.layer.surface_compliance(layer, MAT, qx, qy, V))(speeds)
    looped = jnp.stack([jr.engines.layer.surface_compliance(layer, MAT, qx, qy, V) for V in speeds])
    np.testing.assert_array_equal(batched, looped)
    thick = jnp.asarray([0.002, 0.005, 0.03])
    by_h = jax.vmap(lambda H: jr.engines.layer.surface_compliance(jr.Layer(H=H, rho=1000.0), MAT, qx, qy, 0.1))(thick)
    assert by_h.shape == (3, 41, 41)
    np.testing.assert_array_equal(by_h[1], batched[1])
    mats = jax.vmap(lambda G0: jr.engines.layer.surface_compliance(layer, jr.StandardLinearSolid(G0, 0.25, 1.0), 100.0, 0.0, 0.1))(
        jnp.asarray([1e6, 3e6])
    )
    assert mats.shape == (2,)
    # quasi-static, sign: Im T > 0 for qx V > 0 and Im T(-qx) = -Im T(qx)
    t = jr.engines.layer.surface_compliance(layer, MAT, qx, qy, 0.1)
    np.testing.assert_allclose(t[::-1, :], jnp.conj(t), rtol=1e-14)


def test_supersonic_speed_is_rejected():
    layer = jr.Layer(H=0.005, rho=1000.0)
    c_s = float(jr.engines.layer.shear_wave_speed(layer, MAT))
    assert c_s == pytest.approx(np.sqrt(3e6 / 1000.0), rel=1e-15)
    with pytest.raises(Exception, match="shear-wave speed"):
        jr.engines.layer.surface_compliance(layer, MAT, 100.0, 0.0, 1.01 * c_s)
    with pytest.raises(Exception, match="shear-wave speed"):
        jax.jit(lambda V: jr.engines.layer.surface_compliance(layer, MAT, 100.0, 0.0, V))(c_s)


def test_bad_layers_are_rejected():
    with pytest.raises(ValueError, match="H must be"):
        jr.Layer(H=-0.01)
    with pytest.raises(ValueError, match="H must be"):
        jr.Layer(H=0.0)
    with pytest.raises(ValueError, match="rho"):
        jr.Layer(H=0.01, rho=-1.0)
    with pytest.raises(ValueError, match="nu"):
        jr.Layer(H=0.01, nu=0.6)
    with pytest.raises(ValueError, match="quasi-static"):
        jr.Layer(H=0.01, nu=0.3, rho=1000.0)
    assert jr.Layer(H=jnp.inf).H == jnp.inf


def test_float32_inputs_are_computed_in_float64():
    layer = jr.Layer(H=0.005, rho=1000.0)
    t32 = jr.engines.layer.surface_compliance(layer, MAT, jnp.asarray(123.4, dtype=jnp.float32), 0.0, jnp.asarray(0.3, jnp.float32))
    t64 = jr.engines.layer.surface_compliance(layer, MAT, float(np.float32(123.4)), 0.0, float(np.float32(0.3)))
    assert t32.dtype == jnp.complex128
    assert t32 == t64


@pytest.mark.parametrize("nu", [0.5, 0.3])
def test_static_factorisation_equals_general_path(nu):
    """Without inertia T = T_1(|q|)/G_m exactly: the factorised path (taken for rho = 0) agrees
    with the general closed form evaluated at eps = 0."""
    q = jnp.concatenate([jnp.zeros(1), jnp.logspace(-3, 7, 101)])
    G = jnp.asarray(2.7e6 * np.exp(-0.6j))
    for H in (0.004, jnp.inf):
        t1 = jr.engines.layer.static_compliance(jr.Layer(H=H, nu=nu), q)
        if nu == 0.5:
            ref = transfer_incompressible(q, H, G, jnp.zeros(q.shape, jnp.complex128))
        else:
            ref = transfer_compressible(q, H, G, nu)
        np.testing.assert_allclose(t1.astype(jnp.complex128) / G, ref, rtol=1e-14, atol=0)
    # and the public function with a traced density (general path) equals the static path
    layer = jr.Layer(H=0.004)
    qx, qy = jnp.asarray([0.0, 10.0, 1e3, 1e5]), jnp.asarray([0.0, 5.0, 0.0, 3e4])
    static = jr.engines.layer.surface_compliance(layer, MAT, qx, qy, 0.2)
    general = jax.jit(lambda rho: jr.engines.layer.surface_compliance(jr.Layer(H=0.004, rho=rho), MAT, qx, qy, 0.2))(0.0)
    np.testing.assert_allclose(static, general, rtol=1e-14, atol=0)


def test_layer_built_under_jit_keeps_its_literal_density():
    """A ``Layer(H)`` constructed inside traced code must still know that ``rho = 0`` at trace
    time (otherwise every compliance call silently takes the ~5x slower inertia path; measured:
    a jitted 3D solve 37 -> 11 ms, its value_and_grad 146 -> 17 ms). Values are identical either
    way (the general path with rho = 0 is checked against the factorised one elsewhere)."""
    from jaxroll.engines.layer import is_quasistatic

    seen = []

    @jax.jit
    def f(H):
        layer = jr.Layer(H)
        seen.append(is_quasistatic(layer))
        traced_rho = jr.Layer(H, rho=H * 0.0)  # a genuinely traced density stays traced
        seen.append(is_quasistatic(traced_rho))
        return layer.H

    f(5e-3)
    assert seen == [True, False]
    with pytest.raises(ValueError, match="non-negative density"):
        jr.Layer(5e-3, rho=-1.0)


@pytest.mark.parametrize("nu", [0.5, 0.3, 0.0])
def test_static_compliance_is_the_halfspace_beyond_the_asymptote_cut(nu):
    """The 3D infinite-layer factor drops the layer's correction where ``qH >= HALFSPACE_QH``
    (:func:`jaxroll.engines.layer.halfspace_asymptote`). There the exact ``T_1`` is the
    half-space's ``(1 - nu)/q`` to < 1e-14 relative: the 50-digit closed form ``F(a)`` for
    ``nu = 0.5``, the 6x6 expm of the compressible layer otherwise (independent oracles); and so
    is the closed form in float64 up to rounding (a few 1e-16) from the cut to ``qH = 2e4``."""
    import mpmath as mp

    from _oracles import transfer_expm_compressible

    H = 0.01
    t_inf, q_cut = jr.engines.layer.halfspace_asymptote(jr.Layer(H, nu=nu))
    assert t_inf == 1.0 - nu and float(q_cut) == jr.engines.layer.HALFSPACE_QH / H
    a = jr.engines.layer.HALFSPACE_QH
    if nu == 0.5:
        with mp.workdps(50):
            exact = float((mp.sinh(2 * a) - 2 * a) / (mp.cosh(2 * a) + 2 * a * a + 1))  # F(a) = T_1 2q
    else:
        G = 2e6 * np.exp(-0.2j)
        exact = (transfer_expm_compressible(0.6 * a / H, 0.8 * a / H, H, G, nu) * G * (a / H) / t_inf).real
    assert abs(exact - 1.0) < 1e-14
    q = float(q_cut) * jnp.logspace(0, 3, 31)
    t1 = jr.engines.layer.static_compliance(jr.Layer(H, nu=nu), q)
    np.testing.assert_allclose(np.asarray(t1 * q / t_inf), 1.0, rtol=0, atol=1e-14)
    # a half-space: no cut (its T_1 is the asymptote at every q)
    assert float(jr.engines.layer.halfspace_asymptote(jr.Layer(jnp.inf, nu=nu))[1]) == 0.0
