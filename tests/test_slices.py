"""Tests of the sphere-from-cylinder-slices algorithms PD, PP, SP (jaxroll.engines.slices, [ZG] sec. 3).

Oracles: the algorithms' defining equations evaluated independently (eq. 2, 6-7, 9, 10 and the
load sum of eq. 11; eq. 10 integrated by scipy quadrature); the load-controlled 2D cylinder of
jaxroll.engines.cylinder (second method for the penetration- and load-controlled slice solves, GMRES, LU
and the default Levinson/interval solver); LU for the Levinson tables; convergence in the slice
count and the 2D resolution ([ZG] sec. 3.4: within 0.5 %); central finite differences for the
gradients; the full 3D model (jaxroll.engines.sphere3d) for the paper's accuracy findings.
Default-suite cases share one compiled function per algorithm at reduced resolution.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import integrate

import jaxroll as jr
from jaxroll.engines import cylinder as cy
from jaxroll.engines import slices as sl

G0, TAU, F, R = 3e6, 0.25, 1.0, 0.02
H, P, V = 5e-3, 100.0, 0.01  # V tau / a ~ 0.5: near the R_r peak


def _grid(H_=H, cpr=20, n_cells=2**10):
    """Reduced resolution: ``cpr`` cells per estimated half-width of the middle slice at P, a
    window of 3 half-widths each side, ``n_cells`` period cells (period ~0.19 m >= 20 a, 20 V tau)."""
    mat, layer = jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H_)
    a = float(jr.engines.contact_size.estimate_contact_size(mat, layer, R, sl.middle_slice_load(mat, layer, R, P), "cylinder"))
    dx = a / cpr
    return jr.FixedGrid(dx, 2 * int(np.ceil(3.0 * cpr)), period=n_cells * dx)


GRID = _grid()


@functools.partial(jax.jit, static_argnames=("algorithm", "n_slices"))
def _solve_on(theta, V, load, algorithm, grid, n_slices=21):
    G, tau, f, H_ = theta
    return sl.solve(jr.StandardLinearSolid(G, tau, f), jr.Layer(H_), R, load, V, grid, algorithm=algorithm,
                    n_slices=n_slices, root_tol=1e-12)


def _solve(theta, V, load, algorithm, n_slices=21, grid=GRID):
    """One compiled solve per algorithm, slice count and grid shape (cell size and period traced)."""
    return _solve_on(theta, V, load, algorithm, grid.dynamic(), n_slices=n_slices)


THETA = jnp.array([G0, TAU, F, H])


@functools.lru_cache(maxsize=None)
def _case(algorithm):
    s = _solve(THETA, V, P, algorithm)
    assert int(s.result) == 0
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
    """The penetration-controlled slice solves (GMRES, LU, interval) at the cylinder's penetration
    return the load-controlled cylinder's load and pressure (same kernel: the slices' 4 images)."""
    from jaxroll import contact as ct

    mat = jr.StandardLinearSolid(G0, TAU, F)
    layer = jr.Layer(H)
    Pl = 8e3
    a = float(jr.engines.contact_size.estimate_contact_size(mat, layer, R, Pl, "cylinder"))
    grid = jr.FixedGrid(a / 20, 120, period=2**10 * a / 20)
    kernel = cy.kernel_builder(mat, layer, grid, images=sl.IMAGES)(V)
    c = jax.jit(lambda: cy.solve(kernel, grid, R, Pl, a))()
    C, x, dx = kernel.compliance, c.x, c.dx
    assert int(c.contact.result) == 0
    for solver in (ct.GMRES(), ct.Dense()):
        s = jax.jit(lambda d, solver=solver: ct.solve_contact(C, x**2 / (2 * R), penetration=d,
                                                               linear_solver=solver))(c.contact.penetration)
        assert int(s.result) == 0
        # both solve the same discrete LCP (linear-solve tolerance 1e-13; LU: rounding)
        np.testing.assert_allclose(float(jnp.sum(s.pressure) * dx), Pl, rtol=1e-8)
        np.testing.assert_allclose(np.asarray(s.pressure), np.asarray(c.contact.pressure), rtol=0,
                                   atol=1e-8 * float(jnp.max(c.contact.pressure)))
    s = ct.solve_contact(C, x**2 / (2 * R), Pl, dx, linear_solver=ct.Dense())
    np.testing.assert_allclose(float(s.penetration), float(c.contact.penetration), rtol=1e-9)
    # interval solver (Levinson tables, the default of the slices), both modes: same discrete LCP
    op = sl.interval_operator(C, x, dx)
    solve_iv = jax.jit(sl.solve_interval, static_argnames="mode")
    p, d, st, _, (l, n) = solve_iv(op, R, c.contact.penetration)
    assert int(st) == 0 and int(n) == int(jnp.sum(c.contact.contact))
    np.testing.assert_allclose(np.asarray(p), np.asarray(c.contact.pressure), rtol=0,
                               atol=1e-8 * float(jnp.max(c.contact.pressure)))
    p, d, st, _, _ = solve_iv(op, R, Pl, mode="load")
    assert int(st) == 0
    np.testing.assert_allclose(float(d), float(c.contact.penetration), rtol=1e-9)
    np.testing.assert_allclose(np.asarray(p), np.asarray(c.contact.pressure), rtol=0,
                               atol=1e-8 * float(jnp.max(c.contact.pressure)))


def test_toeplitz_nested_solve_matches_lu():
    """Levinson tables vs LU on each leading block of a non-symmetric Toeplitz matrix."""
    rng = np.random.default_rng(0)
    W = 24
    # diagonally dominant, non-symmetric coefficients t_k, k = -(W-1)..W-1: all leading blocks
    # well conditioned
    k = np.arange(-(W - 1), W)
    offsets = 0.3 * rng.standard_normal(2 * W - 1) / (1.0 + np.abs(k))
    offsets[W - 1] = 2.0
    rhs = rng.standard_normal((W, 3))
    out = np.asarray(sl.toeplitz_nested_solve(jnp.asarray(offsets), jnp.asarray(rhs)))
    i = np.arange(W)
    T = offsets[i[:, None] - i[None, :] + W - 1]
    for n in (1, 2, 7, W):
        # rounding of an O(n^2) recursion on a well-conditioned matrix
        np.testing.assert_allclose(out[n - 1, :n], np.linalg.solve(T[:n, :n], rhs[:n]), rtol=1e-12, atol=1e-13)
        assert np.all(out[n - 1, n:] == 0.0)


def test_zero_penetration_carries_nothing():
    mat = jr.StandardLinearSolid(G0, TAU, F)
    from jaxroll import contact as ct

    K = ct.periodic_kernel(lambda q: jr.engines.layer.surface_compliance(jr.Layer(H), mat, q, 0.0, V), (0.1,), (512,))
    C = ct.windowed_compliance(K, (512,), (64,))
    x = (jnp.arange(64.0) - 31.5) * (0.1 / 512)

    def load(d):
        return jnp.sum(ct.solve_contact(C, x * x / (2 * R), penetration=d).pressure)

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
    with pytest.raises(ValueError, match="algorithm"):
        jr.Slices(algorithm="XX")
    with pytest.raises(ValueError, match="odd"):
        jr.Slices(n_slices=20)
    with pytest.raises(ValueError, match="linear_solver"):
        jr.Slices(linear_solver="lu")
    with pytest.raises(ValueError, match="even number of cells"):
        jr.rolling_resistance(jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H), radius=R, load=P, speed=V,
                              method=jr.Slices(grid=jr.FixedGrid(1e-4, 101, period=0.1)))


@pytest.mark.filterwarnings("ignore:.*the approximate method's estimated error:jaxroll.ValidityWarning")  # PD, flagged
def test_rolling_result_fields():
    s = _case("PD")
    r = jr.rolling_resistance(jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H), radius=R, load=P, speed=V,
                              method=jr.Slices(algorithm="PD", grid=GRID, root_tol=1e-12), throw=False)
    np.testing.assert_allclose(float(r.value), float(s.resistance), rtol=1e-12)
    np.testing.assert_allclose(float(r.contact_radius), float(s.contact_radius), rtol=1e-12)
    np.testing.assert_allclose(float(r.gamma), float(s.contact_radius) / H, rtol=1e-12)
    # truncation = relative gap between moment and dissipation forms (checked above to 5e-3)
    assert 0 <= float(r.truncation) < 5e-3
    assert int(r.regime) == 4
    # the reduced grid's period (~51 estimated half-widths, and > 20 V tau) meets the 2D
    # cylinder's measured rule L >= 20 max(a_est, V tau): no solver or period code; PD on this
    # 5 mm layer is -15 % against the full 3D model (benchmarks/approx_validity.py; it carries
    # ~15 % less than P), so its estimated error flags it
    assert int(r.result) == jr.RESULTS.approximation_error and float(r.approximation) > 0.1


@pytest.mark.slow
@pytest.mark.parametrize("algorithm", sl.ALGORITHMS)
def test_convergence_slices_and_resolution(algorithm):
    """[ZG] sec. 3.4: 21 vs 201 slices and doubled 2D resolution within 0.5 %."""
    base = float(_case(algorithm).resistance)
    fine_slices = float(_solve(THETA, V, P, algorithm, n_slices=201).resistance)
    fine_grid = float(_solve(THETA, V, P, algorithm, grid=_grid(cpr=40, n_cells=2**11)).resistance)
    assert abs(fine_slices / base - 1) < 5e-3
    assert abs(fine_grid / base - 1) < 5e-3


def test_grid_entry_matches_single_solves():
    """rolling_resistance_grid (kernel shared per speed, loads vmapped) reproduces the
    single-case solver on the same grid."""
    mat = jr.StandardLinearSolid(G0, TAU, F)
    out = jax.jit(lambda: sl.rolling_resistance_grid(mat, jr.Layer(H), R, jnp.array([P, 30.0]), jnp.array([V, 0.1]),
                                                     GRID, algorithm="SP", root_tol=1e-12))()
    # the reduced grid's period meets the 2D rule at V (see test_rolling_result_fields), not at
    # 0.1 m/s, where 20 V tau exceeds it
    np.testing.assert_array_equal(np.asarray(out.result), [[0, 0], [jr.RESULTS.period_too_short] * 2])
    s = _case("SP")
    # same discrete problem and iterations: rounding only
    np.testing.assert_allclose(float(out.value[0, 0]), float(s.resistance), rtol=1e-12)
    np.testing.assert_allclose(float(out.solution.penetration[0, 0]), float(s.middle_penetration), rtol=1e-12)


def test_convergence_slices_reduced():
    """Reduced copy of the convergence check: PD with 21 vs 61 slices within 0.5 %."""
    base = float(_case("PD").resistance)
    fine = float(_solve(THETA, V, P, "PD", n_slices=61).resistance)
    assert abs(fine / base - 1) < 5e-3


# ----------------------------------------------------------------------------------------------
# Against the full 3D model (jaxroll.engines.sphere3d)
# ----------------------------------------------------------------------------------------------

# Reduced copy: 3 speeds x 2 loads (V tau/a from ~0.1 to ~10, across the R_r peak), 3D model at
# twice the paper's cell (0.5 mm) and half its period (0.1 m), one compile for all H (traced);
# the slices reuse the compiled reduced-resolution cases of the tests above.
SPEEDS_REDUCED = np.array([1e-3, 1e-2, 1e-1])
LOADS_REDUCED = np.array([30.0, 120.0])


@functools.lru_cache(maxsize=None)
def _sweep3d_coarse():
    grid = jr.FixedGrid(5e-4, 27, period=0.1)

    @jax.jit
    def run(H_):
        out = jr.Full(grid=grid).evaluate_grid(jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H_), R,
                                               jnp.asarray(LOADS_REDUCED), jnp.asarray(SPEEDS_REDUCED), "sphere")
        return out.value, out.result

    return run


def _errors_reduced(H_):
    """Relative errors (slices/3D - 1), shape (speeds, loads), per algorithm."""
    ref, st = _sweep3d_coarse()(H_)
    # converged everywhere (the 0.1 m period is below 20 r_c at the largest loads: flagged only)
    assert np.all((np.asarray(st) == 0) | (np.asarray(st) == jr.RESULTS.period_too_short))
    theta = THETA.at[3].set(H_)
    grid = _grid(H_)
    err = {}
    for alg in sl.ALGORITHMS:
        # python floats: the same jit signature as the cases above (no recompilation)
        est = np.array([[float(_solve(theta, float(v), float(p), alg, grid=grid).resistance) for p in LOADS_REDUCED]
                        for v in SPEEDS_REDUCED])
        err[alg] = est / np.asarray(ref) - 1.0
    return err


def test_against_full_3d_reduced():
    """[ZG] sec. 3.4 findings at reduced resolution: PD far below the 3D model on thin and
    intermediate layers (errors negative), SP at least as close as PP there, PD best at 30 mm.

    Error sources of the reduced comparison: the coarse 3D grid (0.5 mm cells, 6-12 per contact
    radius: a few % in R_r, mostly at high speed) and the different periods of the two models
    (3D 0.1 m, slices ~51 a_est) at V = 0.1 m/s; the algorithmic errors compared here are
    10-25 % (PD, H <= 5 mm) and 5-20 % (PP/SP, 30 mm). The full-resolution table is the slow
    test below.
    """
    for H_ in (2e-3, 5e-3):
        err = _errors_reduced(H_)
        mean = {a: float(np.mean(e)) for a, e in err.items()}
        # PD: geometric consistency loses 15-25 % of R_r on thin/intermediate layers (full table)
        assert mean["PD"] < -0.1 and np.all(err["PD"] < 0), mean
        # SP carries more load on the outer slices than PP: closer to the 3D model; 0.5 %
        # allowance for the coarse 3D grid
        assert abs(mean["SP"]) <= abs(mean["PP"]) + 5e-3, mean
        # errors mostly negative (the full table: 59-100 % of the points); PP/SP within 10 %
        assert all(m < 0.01 for m in mean.values()), mean
        assert abs(mean["SP"]) < 0.1, mean
    err = _errors_reduced(30e-3)
    mean = {a: float(np.mean(e)) for a, e in err.items()}
    # thick layer: PD best (full table: mean error of PD a few %, PP/SP ~ +10 %)
    assert abs(mean["PD"]) < min(abs(mean["PP"]), abs(mean["SP"])), mean
    assert abs(mean["PD"]) < 0.05, mean


# full reference case: 23 speeds x 15 loads at the paper's resolution (3D: L = 0.2 m, a = 0.25 mm,
# 500 terms, window >= 41; slices: L = 0.2 m, 2^10 cells = 0.195 mm)
SPEEDS_REF = np.geomspace(1e-4, 1.0, 23)
LOADS_REF = np.linspace(10.0, 150.0, 15)


def reference_errors(H_):
    """Relative errors (slices/3D - 1) over the reference case, shape (23, 15), per algorithm."""
    import math

    mat = jr.StandardLinearSolid(G0, TAU, F)
    layer = jr.Layer(H_)
    r_max = float(jr.engines.contact_size.estimate_contact_size(mat, layer, R, float(LOADS_REF.max())))
    window = max(41, 2 * math.ceil(1.15 * r_max / 2.5e-4) + 1)
    converged = (0, jr.RESULTS.period_too_short)  # the paper's 0.2 m period is short at high speed
    ref = jr.rolling_resistance_grid(mat, layer, radius=R, loads=LOADS_REF, speeds=SPEEDS_REF, method=jr.Full(
        grid=jr.FixedGrid(2.5e-4, window, period=0.2, n_terms=500)))
    assert np.all(np.isin(np.asarray(ref.result), converged))
    err = {}
    for alg in sl.ALGORITHMS:
        a = float(jr.engines.contact_size.estimate_contact_size(mat, layer, R, sl.middle_slice_load(mat, layer, R, LOADS_REF.max()),
                                           "cylinder"))
        window = 2 * math.ceil(3.0 * a / (0.2 / 2**10))
        out = jr.rolling_resistance_grid(mat, layer, radius=R, loads=LOADS_REF, speeds=SPEEDS_REF, method=jr.Slices(
            algorithm=alg, grid=jr.FixedGrid(0.2 / 2**10, window, period=0.2)))
        assert np.all(np.isin(np.asarray(out.result), converged))
        err[alg] = np.asarray(out.value) / np.asarray(ref.value) - 1.0
    return err


@pytest.mark.slow
@pytest.mark.parametrize("H_", [2e-3, 5e-3, 30e-3])
def test_against_full_3d_reference_case(H_):
    """[ZG] sec. 3.4 findings on the full reference grid: SP best for H = 2 and 5 mm with
    errors mostly negative, PD best for 30 mm."""
    err = reference_errors(H_)
    mean = {a: float(np.mean(e)) for a, e in err.items()}
    print(f"H = {H_ * 1e3:g} mm: mean relative error " + ", ".join(f"{a} {m:+.4f}" for a, m in mean.items()))
    best = min(mean, key=lambda a: abs(mean[a]))
    if H_ < 10e-3:
        assert best == "SP", mean
        for a, e in err.items():
            assert np.mean(e < 0) > 0.5, (a, np.mean(e < 0))  # mostly negative
    else:
        assert best == "PD", mean
    # engineering accuracy of the best algorithm (3D discretisation error ~1 %)
    assert abs(mean[best]) < 0.1, mean
