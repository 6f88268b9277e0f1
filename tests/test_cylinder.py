"""Tests of the full 2D rolling cylinder (jaxroll.engines.cylinder).

Oracles: the exact SLS cylinder on a half-space (jaxroll.reference, docs/validation.md sec. 1), 2D
Hertz with the relaxed and glassy moduli, the thin incompressible layer closed form, the
direct Fourier-series method (f -> 0), central finite differences. Default-suite cases share
one compiled function at reduced resolution; full resolution is marked slow.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jr
import jaxroll.grids  # noqa: F401  (jr.grids.union)
from jaxroll.engines import cylinder as cy
from jaxroll.engines.direct import direct_rolling_resistance
from jaxroll import reference as ref

G0, TAU, F, R, P = 3e6, 0.25, 1.0, 0.02, 5e3
A0 = float(np.sqrt(P * R / (np.pi * G0)))
N_FIXED, CPR = 2**14, 25  # reduced resolution: 25 cells per half-width, period 655 a0


def _grid(n_cells=N_FIXED, cpr=CPR, a=A0, window=None):
    """A fixed grid of ``cpr`` cells per half-width ``a`` and ``n_cells`` period cells; window
    3 half-widths each side (the automatic grid's rule, at the nominal half-width)."""
    dx = a / cpr
    return jr.FixedGrid(dx, window or 2 * int(np.ceil(3.0 * cpr)), period=n_cells * dx)


@functools.partial(jax.jit, static_argnames=("n_cells", "cpr"))
def _solve(theta, V, n_cells=N_FIXED, cpr=CPR):
    G, tau, f, H, radius, load = theta
    mat, layer = jr.StandardLinearSolid(G, tau, f), jr.Layer(H)
    grid = _grid(n_cells, cpr)
    a_est = jr.engines.contact_size.estimate_contact_size(mat, layer, radius, load, "cylinder")
    s = cy.solve(cy.kernel_builder(mat, layer, grid)(V), grid, radius, load, a_est)
    return {
        "Rr": s.resistance,
        "Rr_diss": s.resistance_dissipation,
        "d": s.contact.penetration,
        "pmax": jnp.max(s.contact.pressure),
        "half_width": s.half_width,
        "lead": s.leading_edge,
        "trail": s.trailing_edge,
        "status": s.contact.result,
        "iterations": s.contact.iterations,
    }


@jax.jit
def _value_and_grads(theta, V):
    return jax.value_and_grad(lambda th, v: _solve(th, v)["Rr"], argnums=(0, 1))(theta, V)


def _theta(G=G0, tau=TAU, f=F, H=np.inf, radius=R, load=P):
    return jnp.asarray([G, tau, f, H, radius, load], dtype=float)


def _exact(zeta, f=F):
    V = zeta * A0 / TAU
    return float(ref.exact_cylinder_halfspace(jr.StandardLinearSolid(G0, TAU, f), R, P, V).rolling_resistance)


@pytest.mark.parametrize("zeta", [0.05, 0.3, 1.0, 3.0, 10.0])
def test_exact_halfspace_reduced_resolution(zeta):
    out = _solve(_theta(), zeta * A0 / TAU)
    assert int(out["status"]) == 0
    assert int(out["iterations"]) <= 12
    # tolerance: discretisation at 25 cells per half-width (measured <= 0.5 % on this range)
    assert float(out["Rr"]) == pytest.approx(_exact(zeta), rel=1e-2)


def _forms_gap(cpr, n_cells, zeta=1.0):
    out = _solve(_theta(), zeta * A0 / TAU, n_cells=n_cells, cpr=cpr)
    assert int(out["status"]) == 0
    return float(out["Rr_diss"]) / float(out["Rr"]) - 1.0, float(out["Rr"])


def test_resistance_forms_converge_at_second_order():
    # Moment (1/R) int p x dx and dissipation -int p u' dx (exact for the piecewise-constant
    # pressure, every alias mode) are equal in the continuum but NOT in the discrete problem:
    # the gap condition holds at cell centres only, so u' = -x/R is not imposed inside the cells
    # and the partly loaded edge cells contribute an O(dx^2) relative term (a dissipation form
    # that agrees exactly, e.g. with a derivative restricted to the contact set, is the moment
    # form rewritten, not an independent check). So the test proves the gap converges at the
    # measured order 2 (ratios 4.7, 5.3, 4.1 for cells per half-width 12 -> 25 -> 50 -> 100 at
    # V tau/a0 = 1, same period; the sign alternates as the edges cross cell centres).
    gaps = [abs(_forms_gap(cpr, n)[0]) for cpr, n in [(12, 2**13), (25, 2**14), (50, 2**15)]]
    assert gaps[1] < 3e-3  # 8.3e-4 measured at the default 25 cells per half-width
    # observed order >= 1.6 on each halving (2.2 and 2.4 measured)
    assert gaps[0] / gaps[1] > 3.0 and gaps[1] / gaps[2] > 3.0
    # and the finer moment is closer to the exact solution
    ex = _exact(1.0)
    assert abs(_forms_gap(50, 2**15)[1] / ex - 1) < abs(_forms_gap(25, 2**14)[1] / ex - 1)


@pytest.mark.slow
@pytest.mark.parametrize("zeta", [0.01, 1.0])
def test_resistance_forms_gap_order_fine(zeta):
    # least-squares order of |gap| over 12..100 cells per half-width (same period): measured
    # 2.2 at V tau/a0 = 1 (3.9e-3 -> 3.8e-5) and 2.9 at 0.01 (1.0e-1 -> 2.5e-4)
    cprs = np.array([12, 25, 50, 100])
    gaps = np.array([abs(_forms_gap(int(c), 2**13 * int(2 ** k), zeta)[0]) for k, c in enumerate(cprs)])
    order = -np.polyfit(np.log(cprs), np.log(gaps), 1)[0]
    assert order > 1.8
    assert gaps[-1] < 5e-4


def test_hertz_limits():
    # V -> 0: elastic contact with G0; V -> inf: with G0 (1+f) (every Fourier mode of the
    # period is glassy when V tau >> period). R_r -> 0 in both.
    for V, G in [(1e-5 * A0 / TAU, G0), (1e4 * A0 / TAU, G0 * (1 + F))]:
        out = _solve(_theta(), V)
        a = float(ref.hertz_cylinder(P, R, G))
        # tolerances: half-width quantised to a cell (1/25 of a0); cell peak vs continuum 0.5 %
        assert float(out["half_width"]) == pytest.approx(a, abs=A0 / CPR)
        assert float(out["pmax"]) == pytest.approx(2 * P / (np.pi * a), rel=5e-3)
        assert abs(float(out["Rr"])) * R / (P * A0) < 2e-4  # vs peak value 0.197


def _thin_layer_errors(ratio):
    """Relative errors of the full model's p(0) and d against the thin-layer closed form."""
    H = ratio * np.sqrt(15 * ratio**3 * P * R / (2 * G0))  # so that H/a = ratio exactly
    a = float(ref.thin_layer_cylinder(P, R, H, G0))
    assert H / a == pytest.approx(ratio, rel=1e-6)
    res = jr.rolling_resistance(jr.StandardLinearSolid(G0, TAU, 0.0), jr.Layer(H), radius=R, load=P, speed=0.0,
                                geometry="cylinder", method="full")
    assert int(res.result) == 0
    assert float(res.value) == 0.0 or abs(float(res.value)) * R / (P * a) < 1e-12  # elastic
    return (float(res.solution.pressure.max()) / (15 * P / (16 * a)) - 1,
            float(res.solution.penetration) / (a * a / (6 * R)) - 1)


def test_thin_layer_closed_form_error_is_second_order_in_H_over_a():
    # Elastic (f = 0) thin incompressible layer: a = (15 P R H^3/(2 G))^(1/5),
    # p(0) = 15 P/(16 a), d = a^2/(6 R), the leading term of an expansion in H/a whose first
    # correction is O((H/a)^2) relative. Measured at the default resolution (converged to
    # < 6e-4): d err -1.5e-3 / -4.4e-3 / -1.23e-2 / -4.4e-2 at H/a = 0.02 / 0.03 / 0.05 / 0.1
    # (p0: +1.2e-3 / +3.1e-3 / +8.9e-3 / +3.5e-2), i.e. order 2.0-2.3. So "0.5 % at H/a <= 0.05"
    # is unattainable physically; 0.5 % holds for H/a <= 0.03 (test_thin_layer_closed_form).
    e05, e10 = _thin_layer_errors(0.05), _thin_layer_errors(0.1)
    for k in range(2):
        order = np.log(abs(e10[k]) / abs(e05[k])) / np.log(2.0)
        assert 1.7 < order < 2.4, (k, order)  # 1.98 (p0), 1.85 (d) measured
        assert abs(e05[k]) < 1.5e-2  # the closed form's own O((H/a)^2) error at H/a = 0.05


@pytest.mark.parametrize("ratio", [0.02, 0.03])
def test_thin_layer_closed_form(ratio):
    # the closed form within 0.5 % where its O((H/a)^2) error allows (see above: 0.16 % and
    # 0.44 % measured for the worse of p0 and d)
    for err in _thin_layer_errors(ratio):
        assert abs(err) < 5e-3


def test_direct_method_agrees_as_f_to_zero():
    # Small f: the pressure is nearly the stationary Hertz one, so the direct series ([ZG]
    # eq. 29, aperiodic) and the full model agree to O(f) plus the discretisation.
    f = 0.01
    zeta = 1.0
    V = zeta * A0 / TAU
    mat = jr.StandardLinearSolid(G0, TAU, f)
    direct = direct_rolling_resistance(
        mat, jr.Layer(jnp.inf), radius=R, load=P, speed=V, geometry="cylinder", pressure="thick"
    )
    out = _solve(_theta(f=f), V)
    # tolerance: O(f) = 1 % model difference + 0.5 % discretisation
    assert float(out["Rr"]) == pytest.approx(float(direct.value), rel=2e-2)


@pytest.mark.parametrize("H, nu", [(2e-5, 0.5), (3 * A0, 0.3)])
def test_compliance_function_matches_layer_module(H, nu):
    # cylinder.compliance_function (factorised quasi-static form, custom forward-mode
    # derivative, half-space branch where all q H >= 40) against jaxroll.engines.layer.surface_compliance
    # and its plain reverse-mode gradient, under jit (rho traced: branch chosen by lax.cond) and
    # eagerly (rho concrete). q H spans 0..~1e4; the image-like call has all q H >= 40 unless
    # the layer is thin (H = 2e-5: the layer branch).
    q_base = jnp.asarray(np.concatenate([[0.0], np.geomspace(1.0, 3e6, 40)]) * np.sign(np.linspace(-1, 1, 41)))
    q_img = jnp.asarray(np.geomspace(2e5, 3e6, 9))

    def both(theta, q, k):
        G, tau, f, h, V = theta
        mat, layer = jr.StandardLinearSolid(G, tau, f), jr.Layer(h, nu=nu)
        if k == 0:
            return cy.compliance_function(mat, layer, V)(q)
        # oracle: the quasi-static path of jaxroll.engines.layer.surface_compliance (taken there for a
        # concrete rho = 0), differentiated by plain reverse mode
        G_m = jnp.conj(jr.complex_modulus(mat, q * V))
        return jr.engines.layer.static_compliance(layer, jnp.abs(q)).astype(complex) / G_m

    def scalar(theta, q, k):
        t = both(theta, q, k)
        w = jnp.cos(jnp.arange(q.shape[0], dtype=float))
        return (jnp.sum(w * jnp.real(t)) + jnp.sum(w * jnp.imag(t))) * G0 / A0

    vg = jax.jit(jax.value_and_grad(scalar), static_argnums=2)
    theta = jnp.asarray([G0, TAU, F, H, 0.01])
    for q in (q_base, q_img):
        (v_mine, g_mine), (v_oracle, g_oracle) = vg(theta, q, 0), vg(theta, q, 1)
        # tolerance: rounding (same closed forms; the half-space branch differs by e^{-80})
        assert float(v_mine) == pytest.approx(float(v_oracle), rel=1e-12)
        # tolerance: rounding of the two derivative formulas (dT/dH from T_1 = H psi(qH))
        np.testing.assert_allclose(np.asarray(g_mine), np.asarray(g_oracle), rtol=1e-9,
                                   atol=1e-12 * float(np.abs(g_oracle).max()))
    # eagerly (concrete rho: no lax.cond) against surface_compliance itself
    mat, layer = jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H, nu=nu)
    eager = np.asarray(cy.compliance_function(mat, layer, 0.01)(q_base))
    np.testing.assert_allclose(eager, np.asarray(jr.engines.layer.surface_compliance(layer, mat, q_base, 0.0, 0.01)), rtol=1e-12)


@pytest.mark.parametrize("zeta", [0.3, 1.0, 3.0])
def test_gradients_match_finite_differences(zeta):
    # implicit gradients w.r.t. (G0, tau, f, H, R, P) and V on a finite layer (H = 3 a0),
    # against central differences with relative step 1e-5 (truncation ~1e-10, round-off ~1e-8)
    theta = _theta(H=3 * A0)
    V = zeta * A0 / TAU

    def value(th, v):
        return _solve(th, v)["Rr"]

    _, (g_theta, g_V) = _value_and_grads(theta, V)
    for i in range(6):
        e = np.zeros(6)
        e[i] = 1e-5 * float(theta[i])
        fd = (float(value(theta + e, V)) - float(value(theta - e, V))) / (2 * e[i])
        assert float(g_theta[i]) == pytest.approx(fd, rel=1e-4), i
    fd_V = (float(value(theta, V * (1 + 1e-5))) - float(value(theta, V * (1 - 1e-5)))) / (2e-5 * V)
    assert float(g_V) == pytest.approx(fd_V, rel=1e-4)


def test_value_and_grad_finite_across_contact_edge_events():
    # sweep the load finely: the contact set changes between neighbours (cells enter the
    # contact); the implicit gradient stays finite and positive (R_r grows with the load)
    theta = _theta()
    widths, grads = [], []
    for load in np.linspace(0.9 * P, 1.1 * P, 6):
        _, (g, _) = _value_and_grads(theta.at[5].set(load), A0 / TAU)
        grads.append(float(g[5]))
        widths.append(float(_solve(theta.at[5].set(load), A0 / TAU)["half_width"]))
    assert len(set(widths)) > 1  # contact-edge events happened inside the sweep
    assert np.all(np.isfinite(grads)) and np.all(np.asarray(grads) > 0)


def _full(mat, layer, load, V, method="full", **kw):
    return jr.rolling_resistance(mat, layer, radius=R, load=load, speed=V, geometry="cylinder", method=method, **kw)


def test_public_result_and_bad_input():
    mat = jr.StandardLinearSolid(G0, TAU, F)
    half = jr.Layer(jnp.inf)
    res = _full(mat, half, P, A0 / TAU)
    assert isinstance(res, jr.RollingResult)
    assert int(res.regime) == 4 and bool(res.valid) and int(res.result) == 0
    assert float(res.value) == pytest.approx(_exact(1.0), rel=1e-2)
    # the default grid's error bound (twice the measured envelope, jr.grids.full_model_error): 0.56 % here
    assert float(res.truncation) < 6e-3
    # resolve: the eager grid as a FixedGrid, reusable under jit (traced inputs, layer built inside)
    method = jr.Full().resolve(mat, half, radius=R, loads=P, speeds=A0 / TAU, geometry="cylinder")
    # an infinite layer, 3 a0 each side, 12 cells per half-width at zeta = 1 (jr.grids.cylinder_cells_per_radius)
    assert method.grid.period is None and method.grid.window == 72
    assert float(method.grid.spacing) == pytest.approx(A0 / 12, rel=1e-12)
    # one compiled program (G, V and P traced) for the value and the error path below
    jitted = jax.jit(lambda G, v, p: _full(jr.StandardLinearSolid(G, TAU, F), half, p, v, method=method).value)
    # tolerance: rounding / solver tolerance (same grid, same contact set)
    assert float(jitted(G0, A0 / TAU, P)) == pytest.approx(float(res.value), rel=1e-9)
    with pytest.raises(ValueError, match=r"load P \[N, or N/m for cylinders\] must be positive"):  # eagerly, while sizing the grid
        _full(mat, half, -P, 0.01)
    with pytest.raises(Exception, match=r"load P \[N, or N/m for cylinders\] must be positive"):  # under jit, with a fixed grid
        jitted(G0, 0.01, -P)
    with pytest.raises(ValueError, match="scalar"):
        _full(mat, half, jnp.asarray([P, P]), 0.01)
    # a window wider than the period is refused when the grid is built
    with pytest.raises(ValueError, match="wider than the period"):
        _grid(n_cells=40)
    # the contact reaches the edge of a too-narrow window: a result code, or a raise with throw=True
    narrow = jr.Full(grid=_grid(window=30))
    with pytest.warns(jr.ValidityWarning, match="edge of the computational window"):
        bad = _full(mat, half, P, 0.01, method=narrow, throw=False)
    assert int(bad.result) == jr.RESULTS.window_too_small and not bool(bad.valid)
    with pytest.raises(jr.SolverError, match="edge of the computational window"):
        _full(mat, half, P, 0.01, method=narrow)
    # a converged periodic solution with a period far below 20 max(4 a, V tau) is flagged
    with pytest.warns(jr.ValidityWarning, match="period is shorter"):
        short = _full(mat, half, P, 0.01, method=jr.Full(grid=_grid(n_cells=126, window=76)), throw=False)
    assert int(short.result) == jr.RESULTS.period_too_short
    # non-convergence reported as a result code
    with pytest.warns(jr.ValidityWarning, match="did not converge"):
        nc = _full(mat, half, P, A0 / TAU, method=jr.Full(max_steps=1), throw=False)
    assert int(nc.result) == jr.RESULTS.max_steps_reached and not bool(nc.valid)


@pytest.mark.slow
@pytest.mark.parametrize("zeta", [1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1e3])
def test_exact_halfspace_default_resolution(zeta):
    mat = jr.StandardLinearSolid(G0, TAU, F)
    res = _full(mat, jr.Layer(jnp.inf), P, zeta * A0 / TAU)
    assert int(res.result) == 0
    # tolerance: 1 % at the default (automatic) resolution
    assert float(res.value) == pytest.approx(_exact(zeta), rel=1e-2)


@pytest.mark.slow
@pytest.mark.parametrize("zeta", [0.1, 1.0, 10.0])
def test_exact_halfspace_fine_resolution(zeta):
    mat = jr.StandardLinearSolid(G0, TAU, F)
    res = _full(mat, jr.Layer(jnp.inf), P, zeta * A0 / TAU, method=jr.Full(grid=jr.AutoGrid(cells_per_radius=100)))
    # tolerance: 0.1 % at 100 cells per half-width
    assert float(res.value) == pytest.approx(_exact(zeta), rel=1e-3)


# ------------------------------------------------------------------ smoothed contact edge
def _line_rr(kappa, V, n=21):
    """Full 2D R_r along a straight line in log-parameters (G0 -33 %, tau +10 %, f -18 %), traced
    inputs as in a fit, on one grid resolved over the line's ends (25 cells per half-width)."""
    s = np.linspace(0.0, 1.0, n)
    mats = jr.StandardLinearSolid(3e6 * np.exp(-0.4 * s), 0.25 * np.exp(0.1 * s), np.exp(-0.2 * s))
    layer = jr.Layer(H=0.005)
    ends = [jr.StandardLinearSolid(3e6 * np.exp(-0.4 * t), 0.25 * np.exp(0.1 * t), np.exp(-0.2 * t)) for t in (0, 1)]
    grid = jr.grids.union([jr.Full().resolve(m, layer, radius=0.02, loads=5000.0, speeds=V, geometry="cylinder").grid
                           for m in ends])
    method = jr.Full(grid=grid, edge_smoothing=kappa)
    run = jax.jit(jax.vmap(lambda m: jr.rolling_resistance(m, layer, radius=0.02, load=5000.0, speed=V,
                                                           geometry="cylinder", method=method).value))
    return s, np.asarray(run(mats))


def test_cylinder_edge_smoothing_removes_the_wiggle():
    """On a fixed grid (as in a fit) the exact discrete R_r wiggles at low speed as the contact
    edges cross the cells: rms 1.6e-3 about a quintic along this line (21 points, V = 1e-3 m/s);
    kappa = 0.25 leaves 5.5e-4 (mean bias -0.24 %, worst -0.5 %), kappa = 0.5 leaves 1.9e-4
    (mean bias -0.9 %, worst -1.2 %)."""
    out = {}
    for kappa in (None, 0.5):
        s, v = _line_rr(kappa, 1e-3)
        y = np.log(v)
        out[kappa] = (float(np.std(y - np.polyval(np.polyfit(s, y, 5), s))), v)
    assert out[None][0] > 5e-4, out[None][0]
    assert out[0.5][0] < out[None][0] / 5, (out[0.5][0], out[None][0])
    bias = out[0.5][1] / out[None][1] - 1
    # soft edge: less asymmetry on average; pointwise the difference also contains the exact
    # model's own wiggle (+-0.25 %), so only the mean has a sign
    assert np.mean(bias) < 0 and np.all(np.abs(bias) < 0.02), bias
