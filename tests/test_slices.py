"""Tests of the sphere-from-cylinder-slices algorithms PD, PP, SP (jaxroll.slices, [ZG] sec. 3).

Oracles: the algorithms' defining equations evaluated independently (eq. 2, 6-7, 9, 10 and the
load sum of eq. 11; eq. 10 integrated by scipy quadrature); the load-controlled 2D cylinder of
jaxroll.cylinder (second method for the penetration-controlled slice solves); convergence in the
slice count and the 2D resolution ([ZG] sec. 3.4: within 0.5 %); central finite differences for
the gradients; the full 3D model (jaxroll.sphere3d, skipped until it exists).
Default-suite cases share one compiled function per algorithm at reduced resolution.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import integrate

import jaxroll as jr
from jaxroll import cylinder as cy
from jaxroll import slices as sl

G0, TAU, F, R = 3e6, 0.25, 1.0, 0.02
H, P, V = 5e-3, 100.0, 0.01  # V tau / a ~ 0.5: near the R_r peak
# reduced resolution: 20 cells per estimated half-width, 2^10 cells (period ~0.19 m >= 20 a, 20 V tau)
OPTS = (("n_cells", 2**10), ("cells_per_radius", 20))


@functools.partial(jax.jit, static_argnames=("algorithm", "n_slices", "opts"))
def _solve(theta, V, load, algorithm, n_slices=21, opts=OPTS):
    G, tau, f, H_ = theta
    s = sl.solve_slices(jr.StandardLinearSolid(G, tau, f), jr.Layer(H_), R, load, V,
                        algorithm=algorithm, n_slices=n_slices, throw=False, root_tol=1e-12,
                        **dict(opts))
    return s


THETA = jnp.array([G0, TAU, F, H])


@functools.lru_cache(maxsize=None)
def _case(algorithm):
    s = _solve(THETA, V, P, algorithm)
    assert int(s.status) == 0
    return s


def _check_core(s):
    """eq. 2 and eq. 7 (with eq. 6) on the middle slice, from the returned d_o."""
    d_o = float(s.middle_penetration)
    r_c = np.sqrt(d_o * (2 * R - d_o))
    # r_c is a closed form of d_o: rounding only
    np.testing.assert_allclose(float(s.contact_radius), r_c, rtol=1e-14)
    return d_o, r_c


def test_pd_geometry_and_core_equation():
    s = _case("PD")
    d_o, r_c = _check_core(s)
    y = np.asarray(s.y)
    n = 21
    np.testing.assert_allclose(float(s.dy), 2 * r_c / n, rtol=1e-14)
    np.testing.assert_allclose(y, np.arange(11) * 2 * r_c / n, rtol=1e-14, atol=0)
    np.testing.assert_allclose(np.asarray(s.slice_radius), np.sqrt(R**2 - y**2), rtol=1e-14)
    # eq. 9, geometric consistency: exact up to rounding
    np.testing.assert_allclose(np.asarray(s.slice_penetration), d_o - R + np.sqrt(R**2 - y**2),
                               rtol=1e-12, atol=1e-18)
    # eq. 7: middle slice load = 3P/(4 r_c) (eq. 6); root tolerance 1e-12 on log d_o
    np.testing.assert_allclose(float(s.slice_load[0]), 3 * P / (4 * r_c), rtol=1e-9)
    # the total load of PD is not P (geometry enforced instead); sum of slice loads as returned
    w = np.where(np.arange(11) > 0, 2.0, 1.0)
    np.testing.assert_allclose(float(s.load), np.sum(w * np.asarray(s.slice_load)) * float(s.dy),
                               rtol=1e-13)


def test_pp_load_equilibrium():
    s = _case("PP")
    d_o, r_c = _check_core(s)
    dy = float(s.dy)
    y = np.asarray(s.y)

    def eq10(t):
        return 0.75 * P * (d_o * (2 * R - d_o) - t * t) / (d_o * (2 * R - d_o)) ** 1.5

    # each slice carries eq. 10 integrated over its width (quadrature error ~1e-14)
    expect = [integrate.quad(eq10, yk - dy / 2, yk + dy / 2, epsabs=0, epsrel=1e-13)[0] / dy for yk in y]
    np.testing.assert_allclose(np.asarray(s.slice_load), expect, rtol=1e-11)
    # total load P exactly (rounding of the contact solves' load rows)
    np.testing.assert_allclose(float(s.load), P, rtol=1e-10)
    # middle slice follows eq. 10 at y = 0 up to its slice average (dy^2/12 term)
    np.testing.assert_allclose(float(s.slice_load[0]), eq10(0.0) - 0.75 * P * dy**2 / 12 / r_c**3,
                               rtol=1e-12)


def test_sp_load_and_geometry():
    s = _case("SP")
    d_o, r_c = _check_core(s)
    y = np.asarray(s.y)
    # eq. 11 solved to root tolerance 1e-12 on log d_o
    np.testing.assert_allclose(float(s.load), P, rtol=1e-9)
    np.testing.assert_allclose(np.asarray(s.slice_penetration), d_o - R + np.sqrt(R**2 - y**2),
                               rtol=1e-12, atol=1e-18)
    # SP starts from the core; the core's d_o differs (eq. 7 vs eq. 11)
    assert abs(d_o / float(_case("PD").middle_penetration) - 1) > 1e-6


def test_moment_equals_dissipation():
    # both R_r forms agree up to the 2D discretisation error (O(dx^2), ~1e-3 at 20 cells)
    for alg in sl.ALGORITHMS:
        s = _case(alg)
        np.testing.assert_allclose(float(s.resistance_dissipation), float(s.resistance), rtol=5e-3)


def test_penetration_solve_matches_load_controlled_cylinder():
    """solve_penetration at the cylinder's penetration returns the cylinder's load/pressure."""
    mat = jr.StandardLinearSolid(G0, TAU, F)
    layer = jr.Layer(H)
    Pl = 8e3
    N = 2**10
    c = jax.jit(lambda: cy.solve_cylinder(mat, layer, R, Pl, V, n_cells=N, cells_per_radius=20))()
    from jaxroll import contact as ct

    K = ct.periodic_kernel(lambda q: jr.surface_compliance(layer, mat, q, 0.0, V), (c.period,), (N,))
    W = c.x.shape[0]
    C = ct.windowed_compliance(K, (N,), (W,))
    s = jax.jit(sl.solve_penetration)(C, c.x**2 / (2 * R), c.contact.penetration)
    assert int(s.status) == 0
    # both solve the same discrete LCP (linear-solve tolerance 1e-13)
    np.testing.assert_allclose(float(jnp.sum(s.pressure) * c.dx), Pl, rtol=1e-8)
    np.testing.assert_allclose(np.asarray(s.pressure), np.asarray(c.contact.pressure), rtol=0,
                               atol=1e-8 * float(jnp.max(c.contact.pressure)))
    # dense LU variant: same discrete problem, rounding only
    Cd = sl.dense_window_matrix(C)
    p, _, st, _ = sl.solve_dense(Cd, c.x**2 / (2 * R), c.contact.penetration, c.dx)
    assert int(st) == 0
    np.testing.assert_allclose(np.asarray(p), np.asarray(c.contact.pressure), rtol=0,
                               atol=1e-8 * float(jnp.max(c.contact.pressure)))
    p, d, st, _ = sl.solve_dense(Cd, c.x**2 / (2 * R), Pl, c.dx, mode="load")
    np.testing.assert_allclose(float(d), float(c.contact.penetration), rtol=1e-9)


def test_zero_penetration_carries_nothing():
    mat = jr.StandardLinearSolid(G0, TAU, F)
    from jaxroll import contact as ct

    K = ct.periodic_kernel(lambda q: jr.surface_compliance(jr.Layer(H), mat, q, 0.0, V), (0.1,), (512,))
    C = ct.windowed_compliance(K, (512,), (64,))
    x = (jnp.arange(64.0) - 31.5) * (0.1 / 512)

    def load(d):
        return jnp.sum(sl.solve_penetration(C, x * x / (2 * R), d).pressure)

    val, g = jax.jit(jax.value_and_grad(load))(-1e-5)
    # no overlap: p = 0 exactly, finite zero gradient
    assert float(val) == 0.0
    assert np.isfinite(float(g)) and float(g) == 0.0


@pytest.mark.parametrize("algorithm", [pytest.param("PD", marks=pytest.mark.slow),
                                       pytest.param("PP", marks=pytest.mark.slow), "SP"])
def test_gradients_vs_finite_differences(algorithm):
    def rr(theta):
        return _solve(theta, V, P, algorithm).resistance

    g = np.asarray(jax.jit(jax.grad(rr))(THETA))
    for i in range(4):
        h = 1e-5 * float(THETA[i])
        e = jnp.zeros(4).at[i].set(h)
        fd = (float(rr(THETA + e)) - float(rr(THETA - e))) / (2 * h)
        # FD truncation O(h^2) ~1e-10; root tolerance 1e-12 / h ~1e-7; contact-set events
        # between the FD points (piecewise-smooth discrete problem) would show as O(1) jumps
        np.testing.assert_allclose(g[i], fd, rtol=2e-4, atol=1e-6 * abs(fd) + 1e-12)


def test_invalid_options():
    mat = jr.StandardLinearSolid(G0, TAU, F)
    with pytest.raises(ValueError, match="algorithm"):
        sl.solve_slices(mat, jr.Layer(H), R, P, V, algorithm="XX")
    with pytest.raises(ValueError, match="odd"):
        sl.solve_slices(mat, jr.Layer(H), R, P, V, n_slices=20)
    with pytest.raises(ValueError, match="linear_solver"):
        sl.solve_slices(mat, jr.Layer(H), R, P, V, linear_solver="lu")


def test_rolling_result_fields():
    s = _case("PD")
    r = sl.slice_result(s, jr.Layer(H))
    np.testing.assert_allclose(float(r.value), float(s.resistance), rtol=0)
    np.testing.assert_allclose(float(r.contact_radius), float(s.contact_radius), rtol=0)
    np.testing.assert_allclose(float(r.gamma), float(s.contact_radius) / H, rtol=1e-15)
    # truncation = relative gap between moment and dissipation forms (checked above to 5e-3)
    assert 0 <= float(r.truncation) < 5e-3
    assert int(r.regime) == 4 and int(r.status) == 0
    # the reduced grid's period (~51 estimated half-widths) is shorter than the 2D cylinder's
    # measured rule L >= 20 max(4 a_est, V tau): flagged, not silently valid
    assert not bool(s.period_ok) and not bool(r.valid)


@pytest.mark.slow
@pytest.mark.parametrize("algorithm", sl.ALGORITHMS)
def test_convergence_slices_and_resolution(algorithm):
    """[ZG] sec. 3.4: 21 vs 201 slices and doubled 2D resolution within 0.5 %."""
    base = float(_case(algorithm).resistance)
    fine_slices = float(_solve(THETA, V, P, algorithm, n_slices=201).resistance)
    fine_grid = float(_solve(THETA, V, P, algorithm, opts=(("n_cells", 2**11), ("cells_per_radius", 40))).resistance)
    assert abs(fine_slices / base - 1) < 5e-3
    assert abs(fine_grid / base - 1) < 5e-3


def test_convergence_slices_reduced():
    """Reduced copy of the convergence check: PD with 21 vs 61 slices within 0.5 %."""
    base = float(_case("PD").resistance)
    fine = float(_solve(THETA, V, P, "PD", n_slices=61).resistance)
    assert abs(fine / base - 1) < 5e-3


# ----------------------------------------------------------------------------------------------
# Against the full 3D model (jaxroll.sphere3d): skipped until it exists
# ----------------------------------------------------------------------------------------------

# reduced reference grid (the paper's is 23 speeds x 15 loads; too slow for a test)
SPEEDS_REDUCED = np.geomspace(1e-3, 0.1, 3)
LOADS_REDUCED = np.array([30.0, 120.0])


def _errors_vs_3d(sphere3d, H_, speeds, loads):
    """Mean relative error (estimate/3D - 1) of each algorithm over a speed x load grid."""
    mat = jr.StandardLinearSolid(G0, TAU, F)
    layer = jr.Layer(H_)
    out = {}
    ref = np.array([[float(sphere3d.rolling_resistance_full(mat, layer, R, p, v).value) for p in loads]
                    for v in speeds])
    for alg in sl.ALGORITHMS:
        est = np.array([[float(sl.rolling_resistance_slices(mat, layer, R, p, v, algorithm=alg).value)
                         for p in loads]
                        for v in speeds])
        out[alg] = est / ref - 1.0
    return out


@pytest.mark.slow
@pytest.mark.parametrize("H_", [2e-3, 5e-3, 30e-3])
def test_against_full_3d_reduced(H_):
    """[ZG] sec. 3.4 findings: SP best for H = 2, 5 mm (errors mostly negative), PD best at 30 mm."""
    sphere3d = pytest.importorskip("jaxroll.sphere3d", reason="full 3D model jaxroll.sphere3d not written yet")
    err = _errors_vs_3d(sphere3d, H_, SPEEDS_REDUCED, LOADS_REDUCED)
    mean = {a: float(np.mean(e)) for a, e in err.items()}
    best = min(mean, key=lambda a: abs(mean[a]))
    if H_ < 10e-3:
        assert best == "SP", mean
        assert mean["SP"] < 0 and mean["PP"] < 0, mean  # approached from below
    else:
        assert best == "PD", mean
    # engineering accuracy promised by the paper's figures: mean error within 20 %
    assert abs(mean[best]) < 0.2, mean
