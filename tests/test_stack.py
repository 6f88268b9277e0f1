"""Bonded ply stacks (jr.Stack): the compliance against the composed high-precision expm of
[ZG] eq. 22 (the oracle), its limits, a published two-layer elastic kernel, gradients, and the
methods on stacks against the single layer they must reproduce."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jr
from jaxroll.engines.layer import surface_compliance
from jaxroll.engines.stack import stack_compliance

from _oracles import transfer_expm_stack

M1 = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=1.0)
M2 = jr.StandardLinearSolid(G0=3e7, tau=0.01, f=0.5)
M3 = jr.StandardLinearSolid(G0=1.5e6, tau=1.0, f=3.0)


def _gm(material, qx, V):
    """The mode modulus G_m = conj(G*(q_x V)) the oracle takes."""
    return complex(np.conj(complex(jr.complex_modulus(material, qx * V))))


# one compile per stack structure, reused across cases; Python-float rho = 0 stays static
# (the quasi-static plies' real propagators), as in the front doors
_T = eqx.filter_jit(stack_compliance)


# --------------------------------------------------------------------------------------
# the compliance against the oracle

# three plies (incompressible with inertia, compressible, incompressible with inertia) on a
# compressible half-space; (qx, qy, V) from long to short waves, q sum(H) from 0.3 to ~300
STACK3 = jr.Stack([jr.Ply(M1, H=0.004, rho=1100.0), jr.Ply(M2, H=0.002, nu=0.45), jr.Ply(M3, H=0.003, rho=900.0)],
                  base=jr.HalfSpace(M2, nu=0.3))
CASES3 = [(30.0, 0.0, 20.0), (300.0, 100.0, 20.0), (3000.0, -500.0, 5.0), (2.0e4, 1.0e4, 35.0), (0.5, 0.2, 1.0)]


@pytest.mark.parametrize("qx,qy,V", CASES3)
def test_three_plies_on_half_space_match_composed_expm(qx, qy, V):
    plies = [(0.004, _gm(M1, qx, V), 1100.0, 0.5), (0.002, _gm(M2, qx, V), 0.0, 0.45),
             (0.003, _gm(M3, qx, V), 900.0, 0.5)]
    ref = transfer_expm_stack(qx, qy, plies, V, base=(_gm(M2, qx, V), 0.0, 0.3))
    val = complex(_T(STACK3, qx, qy, V))
    # float64 recursion (measured <= 3e-14); the oracle's half-space is a q H = 60 ply (e^{-120})
    assert abs(val - ref) <= 1e-12 * abs(ref)


STACK2 = jr.Stack([jr.Ply(M3, H=0.001), jr.Ply(M1, H=0.006)])


@pytest.mark.parametrize("q", [1e-1, 10.0, 300.0, 4e4])
def test_two_quasistatic_plies_on_rigid_base_match_composed_expm(q):
    V = 0.5
    ref = transfer_expm_stack(q, 0.0, [(0.001, _gm(M3, q, V), 0.0, 0.5), (0.006, _gm(M1, q, V), 0.0, 0.5)], V)
    val = complex(_T(STACK2, q, 0.0, V))
    assert abs(val - ref) <= 1e-12 * abs(ref)


# --------------------------------------------------------------------------------------
# limits

QH = np.logspace(-3, 4, 29)
FORMS = [dict(), dict(rho=1100.0), dict(nu=0.35)]  # quasi-static, with inertia, compressible


@pytest.mark.parametrize("kw", FORMS, ids=["static", "inertia", "compressible"])
def test_identical_plies_equal_the_single_layer(kw):
    """Two plies of one material = the layer of the summed thickness (q H from 1e-3 to 1e4;
    V = 30 m/s: |eps| up to 0.33 with inertia)."""
    H, V = 0.006, 30.0
    q = jnp.asarray(QH / H)
    ref = np.asarray(surface_compliance(jr.Layer(H, **kw), M1, q, 0.0, V))
    st = jr.Stack([jr.Ply(M1, H=h, **kw) for h in (0.002, 0.004)])
    val = np.asarray(_T(st, q, 0.0, V))
    # both sides float64 (the single layer ~1e-13 against the oracle); measured <= 1e-13
    assert np.max(np.abs(val - ref) / np.abs(ref)) <= 1e-12
    # a ply on a half-space of its own material is the half-space
    ref = np.asarray(surface_compliance(jr.Layer(jnp.inf, **kw), M1, q, 0.0, V))
    val = np.asarray(_T(jr.Stack([jr.Ply(M1, H=H, **kw)], base=jr.HalfSpace(M1, **kw)), q, 0.0, V))
    assert np.max(np.abs(val - ref) / np.abs(ref)) <= 1e-12


def test_stiff_bottom_ply_and_stiff_base_are_the_rigid_base():
    """A bottom ply or half-space G_b = r G times stiffer than the top ply: T -> the layer on a
    rigid base like 1/r. Bound: the base's own compliance 1/(2 G_b q) relative to the layer's
    F(qH)/(2 G q) (it dominates the incompressible layer's q^3 H^3 at long waves), plus the
    ply's thickness ratio (measured: 42/r at q H -> 0)."""
    H, V = 0.004, 0.3
    q = jnp.asarray(QH / H)
    ref = np.asarray(surface_compliance(jr.Layer(H), M1, q, 0.0, V))
    F = np.asarray(jr.engines.layer.static_compliance(jr.Layer(H), q)) * 2.0 * np.asarray(q)
    for ratio in (1e6, 1e9):
        hard = jr.StandardLinearSolid(G0=3e6 * ratio, tau=0.25, f=1.0)
        for st in (jr.Stack([jr.Ply(M1, H=H), jr.Ply(hard, H=0.01)]),
                   jr.Stack([jr.Ply(M1, H=H)], base=jr.HalfSpace(hard))):
            err = np.abs(np.asarray(_T(st, q, 0.0, V)) - ref) / np.abs(ref)
            assert np.all(err <= (2.0 / F + 50.0) / ratio + 1e-12)


def test_vanishing_soft_top_ply_leaves_the_rest():
    """A top ply 100 times softer and h thick: T changes by O(q h G/G_soft) (measured at most
    0.0124 q h G/G_soft, linear in h) and vanishes with h."""
    soft = jr.StandardLinearSolid(G0=3e4, tau=0.25, f=1.0)
    H, V = 0.004, 0.3
    q = jnp.asarray(QH[QH <= 1e3] / H)
    rest = jr.Stack([jr.Ply(M1, H=H)], base=jr.HalfSpace(M2))
    ref = np.asarray(_T(rest, q, 0.0, V))
    for h in (1e-9, 1e-12):
        val = np.asarray(_T(jr.Stack([jr.Ply(soft, H=h), jr.Ply(M1, H=H)], base=jr.HalfSpace(M2)), q, 0.0, V))
        bound = 0.05 * np.asarray(q) * h * 100.0 + 1e-13
        assert np.all(np.abs(val - ref) / np.abs(ref) <= bound)


def _perriot_barthel(t, mu1, mu0, nu1, nu0):
    """Surface compliance factor of an elastic layer (mu1, nu1, thickness h) perfectly bonded
    to an elastic half-space (mu0, nu0), the Burmister-type two-layer system: Perriot & Barthel,
    J. Mater. Res. 19 (2004) 600, u(k) = 2(1-nu1^2)/E1 C(kh) p(k)/k with
    C = [1 + 4 b t e^{-2t} - a b e^{-4t}]/[1 - (a + b + 4 b t^2) e^{-2t} + a b e^{-4t}],
    a = (alpha g0 - g1)/(1 + alpha g0), b = (alpha - 1)/(alpha + g1), alpha = mu1/mu0,
    g = 3 - 4 nu. This closed form was written from the literature without the paper at hand: it
    reduces exactly to the layer on a rigid base (mu0 -> inf, alpha -> 0) and to the homogeneous
    half-space (alpha = 1), and is independent of the library's transfer-matrix code; check it
    against the paper's equation before quoting the citation further."""
    g1, g0 = 3 - 4 * nu1, 3 - 4 * nu0
    al = mu1 / mu0
    a, b = (al * g0 - g1) / (1 + al * g0), (al - 1) / (al + g1)
    e2 = np.exp(-2 * t)
    return (1 + 4 * b * t * e2 - a * b * e2**2) / (1 - (a + b + 4 * b * t * t) * e2 + a * b * e2**2)


@pytest.mark.parametrize("mu1,mu0,nu1,nu0", [(1e6, 1e8, 0.5, 0.5), (1e7, 1e6, 0.5, 0.5), (2e6, 5e6, 0.3, 0.45)])
def test_elastic_layer_on_half_space_matches_the_published_two_layer_kernel(mu1, mu0, nu1, nu0):
    H = 0.003
    q = np.logspace(-3, 3, 25) / H
    elastic = lambda mu: jr.StandardLinearSolid(G0=mu, tau=1.0, f=1.0)  # noqa: E731 (V = 0: G = G0)
    st = jr.Stack([jr.Ply(elastic(mu1), H=H, nu=nu1)], base=jr.HalfSpace(elastic(mu0), nu=nu0))
    val = np.asarray(_T(st, jnp.asarray(q), 0.0, 0.0))
    ref = (1 - nu1) / (mu1 * q) * _perriot_barthel(q * H, mu1, mu0, nu1, nu0)
    # closed form in float64 (cancellation-free for these ratios); measured <= 1.3e-13
    assert np.max(np.abs(val - ref) / np.abs(ref)) <= 1e-12


def test_no_overflow_at_large_qh():
    """q H up to 1e6 (the gradient test below covers the derivatives of the same branches)."""
    st = jr.Stack([jr.Ply(M1, H=0.004, rho=1100.0), jr.Ply(M2, H=0.01)], base=jr.HalfSpace(M3))
    q = jnp.logspace(-2, 8, 21)
    t = np.asarray(_T(st, q, 0.0, 10.0))
    assert np.all(np.isfinite(t)) and np.all(t.real > 0) and np.all(t.imag > 0)


def _fd(f, x, h):
    return (f(x + h) - f(x - h)) / (2 * h)


def test_gradients_match_central_differences():
    """d Re/Im T / d(each ply's H, G0, tau, rho) against central differences (h ~ 1e-5 relative:
    truncation ~1e-10, round-off ~1e-11)."""
    qs, V = jnp.asarray([150.0, 900.0, 4000.0]), 12.0

    def T(p):
        st = jr.Stack([jr.Ply(jr.StandardLinearSolid(G0=p[0], tau=p[1], f=1.0), H=p[2], rho=p[3]),
                       jr.Ply(jr.StandardLinearSolid(G0=p[4], tau=0.01, f=0.5), H=p[5], nu=0.45)],
                      base=jr.HalfSpace(M3))
        t = stack_compliance(st, qs, 0.0, V)
        return jnp.concatenate([jnp.real(t), jnp.imag(t)]) * 1e9

    p0 = np.array([3e6, 0.25, 0.004, 1100.0, 3e7, 0.002])
    jac = np.asarray(jax.jit(jax.jacrev(T))(jnp.asarray(p0)))  # reverse mode, as jax.grad
    Tj = jax.jit(T)
    for i in range(p0.size):
        e = np.zeros_like(p0)
        e[i] = 1.0
        h = 1e-5 * p0[i]
        fd = np.asarray(_fd(lambda x: Tj(jnp.asarray(p0 + x * e)), 0.0, h))
        scale = np.max(np.abs(fd)) + 1e-30
        assert np.max(np.abs(jac[:, i] - fd)) <= 1e-6 * scale, i


def test_bad_stacks_are_rejected():
    with pytest.raises(ValueError, match="non-empty"):
        jr.Stack([])
    with pytest.raises(ValueError, match="rigid"):
        jr.Stack([jr.Ply(M1, H=0.01)], base="elastic")
    with pytest.raises(ValueError, match="finite"):
        jr.Ply(M1, H=np.inf)
    with pytest.raises(ValueError, match="H must be"):
        jr.Ply(M1, H=-1.0)
    with pytest.raises(ValueError, match="quasi-static"):
        jr.Ply(M1, H=0.01, nu=0.4, rho=1000.0)
    with pytest.raises(ValueError, match="material"):
        jr.Ply(3e6, H=0.01)
    st = jr.Stack([jr.Ply(M1, H=0.01)])
    with pytest.raises(ValueError, match="alone"):  # a material other than the stack's own
        jr.rolling_resistance(M2, st, radius=0.02, load=100.0, speed=1.0)
    with pytest.raises(ValueError, match="Stack alone"):
        jr.rolling_resistance(M1, radius=0.02, load=100.0, speed=1.0)


# --------------------------------------------------------------------------------------
# the methods on a stack: two identical plies must reproduce the single layer's R_r

H_SPLIT = (0.002, 0.003)  # plies of one material summing to the layer's H = 5 mm
SPHERE_GRID = jr.FixedGrid(6e-4, 17, period=0.08, n_terms=80)
LINE_GRID = jr.FixedGrid(2e-4, 80, period=0.1)
METHODS = {  # name: (method, geometry, load); the default copies run always, the rest under -m slow
    "default-cylinder": (None, "cylinder", 5000.0),  # method not named: the full 2D model, AutoGrid
    "default-sphere": (None, "sphere", 150.0),
    "full2d": (jr.Full(grid=jr.FixedGrid(2e-4, 80)), "cylinder", 5000.0),
    "direct-cylinder": (jr.Direct(), "cylinder", 5000.0),
    "full2d-periodic": (jr.Full(grid=LINE_GRID), "cylinder", 5000.0),
    "full3d": (jr.Full(grid=jr.FixedGrid(6e-4, 17)), "sphere", 150.0),
    "full3d-periodic": (jr.Full(grid=SPHERE_GRID), "sphere", 150.0),
    "direct-sphere": (jr.Direct(), "sphere", 150.0),
    "direct-periodic": (jr.Direct(period=0.08, n_terms=60), "sphere", 150.0),
    "direct-cylinder-periodic": (jr.Direct(period=0.1, n_terms=200), "cylinder", 5000.0),
    "SP": (jr.Slices(algorithm="SP", grid=LINE_GRID), "sphere", 150.0),
    "PD": (jr.Slices(algorithm="PD", grid=LINE_GRID), "sphere", 150.0),
    "PP": (jr.Slices(algorithm="PP", grid=LINE_GRID), "sphere", 150.0),
}
FAST = ("default-cylinder", "direct-cylinder")


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # flags compared below, not asserted
@pytest.mark.parametrize("name", [n if n in FAST else pytest.param(n, marks=pytest.mark.slow) for n in METHODS])
def test_identical_plies_give_the_single_layer_rolling_resistance(name):
    method, geometry, load = METHODS[name]
    kw = dict(radius=0.02, load=load, speed=0.01, geometry=geometry, method=method, throw=False)
    ref = jr.rolling_resistance(M1, jr.Layer(sum(H_SPLIT)), **kw)
    val = jr.rolling_resistance(jr.Stack([jr.Ply(M1, H=h) for h in H_SPLIT]), **kw)
    # the compliances agree to ~1e-14 (above); every other input is the same layer's
    assert abs(float(val.value) - float(ref.value)) <= 1e-10 * abs(float(ref.value))
    assert int(val.result) == int(ref.result)


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # a derivative check, not a validity one
@pytest.mark.parametrize("method", [jr.Direct(), pytest.param(jr.Full(grid=jr.FixedGrid(2e-4, 80)),
                                                              marks=pytest.mark.slow)], ids=["direct", "full2d"])
def test_rolling_resistance_gradient_in_ply_thickness_matches_central_differences(method):
    """d R_r/d H_cover of a cover on a carcass (cylinder) under jax.grad, against a central
    difference (h = 1e-6 relative: the full model's contact tolerance 1e-10 sets ~1e-4, the
    direct method's quadrature less)."""

    def rr(h):
        st = jr.Stack([jr.Ply(M1, H=h), jr.Ply(M2, H=0.002, nu=0.45)])
        return jr.rolling_resistance(st, radius=0.02, load=5000.0, speed=0.01, geometry="cylinder",
                                     method=method, throw=False).value

    h0 = 0.004
    g = float(jax.grad(rr)(h0))
    fd = (float(rr(h0 * (1 + 1e-6))) - float(rr(h0 * (1 - 1e-6)))) / (2e-6 * h0)
    assert abs(g - fd) <= 1e-4 * abs(fd)
