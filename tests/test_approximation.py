"""The approximate methods (direct, slices) are valid only where their own estimate of their
error against the full model, ``RollingResult.approximation``, is at most 10 %.

Checked against the full model (the reference): the cases the approximate methods used to call
valid although far off are flagged ``approximation_error``; where a method says valid it is
within 10 % of the full model plus the reference's own error; the estimate works under
jit/vmap/grad. The reference's error: the full model's ``truncation`` (the gap between the
moment and dissipation forms of R_r) bounds it on the measured sweep (benchmarks/approx_validity.py:
up to 9 % at V tau/a < 0.01, where its default grid under-resolves the contact edge, < 4 %
elsewhere), so a valid approximate value may differ from the reference by ``0.10 + truncation``
plus 2 % for what the gap misses. The default suite checks a few points; ``-m slow`` runs the
seeded random sweep over the envelope.
"""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jr
from _cases import HALF_SPACE, PAPER, RADIUS, THICK, central_difference, draw_loss_dominated

#: The slices on an aperiodic 1 mm grid with a 16-cell window (~5 cells per contact radius at
#: 100 N): the estimate does not depend on the grid (stationary pressures and the slices' load).
SLICE_GRID = jr.FixedGrid(1e-3, 16)
#: What a valid approximate value may differ from the reference by, beyond its truncation.
SLACK = 0.10 + 0.02


def _grid(material, layer, method, speeds, loads, radius=RADIUS, geometry="sphere"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.ValidityWarning)
        return jr.rolling_resistance_grid(material, layer, radius=radius, loads=np.asarray(loads, float),
                                          speeds=np.asarray(speeds, float), method=method, geometry=geometry)


@pytest.fixture(scope="module")
def shipped():
    """The shipped measured Prony material and its WLF shift (as docs/dma.md's example builds them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.DataWarning)
        sw = jr.read_dma_sweeps(jr.datasets.path("pyvisco_freq_user_raw.csv"))
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    return jr.fit_prony(jr.master_curve(sw, sh)).material, jr.fit_wlf(sh).shift


# --------------------------------------------------------------------- the cases


# PP's estimate is SP's (both carry the load: the load part is zero) on its own solver, whose
# numbers tests/test_slices.py checks: slow here (a slice table compiles for ~10 s); SP and PD
# (the load part) always run
@pytest.mark.parametrize("algorithm", ["SP", pytest.param("PP", marks=pytest.mark.slow), "PD"])
def test_slices_at_high_speed_on_thick_layers_are_flagged(algorithm):
    # measured against the full 3D model (benchmarks/approx_validity.py): SP +92 % / +186 % at
    # 1 / 10 m/s on a half-space (f = 1; +90 % / +177 % at f = 0.1), +48..57 % at H = 0.2 m;
    # PD and PP within 10 points of SP
    method = jr.Slices(algorithm, grid=SLICE_GRID)
    soft = jr.StandardLinearSolid(3e6, 0.25, 0.1)
    for material, layer in ((PAPER, HALF_SPACE), (soft, HALF_SPACE), (PAPER, jr.Layer(0.2))):
        res = _grid(material, layer, method, [1.0, 10.0], [100.0])  # one compiled program for all
        assert np.all(np.asarray(res.result) == jr.RESULTS.approximation_error), (layer.H, res.approximation)
        assert np.all(np.asarray(res.approximation) > 0.3)


def test_direct_with_the_relaxed_contact_is_flagged_above_the_peak():
    # the direct method as [ZG] define it (relaxed modulus): -13 % at the R_r peak (V = 1 cm/s)
    # and -22 % at 1 m/s against the full 3D model on a half-space (f = 1); at 1 mm/s -1 %
    res = _grid(PAPER, HALF_SPACE, jr.Direct(), [1e-3, 1e-2, 1.0], [100.0])
    np.testing.assert_array_equal(np.asarray(res.result)[:, 0], [0, jr.RESULTS.approximation_error,
                                                                 jr.RESULTS.approximation_error])
    # the plateau is the radius ratio (1+f)^(-1/3) - 1 = -20.6 %: the estimate sees it
    assert 0.2 < float(res.approximation[2, 0]) < 0.3


@pytest.mark.parametrize("modulus,fs", [("static", (1000.0,)),  # (the reduced copy; the full one is slow)
                                        pytest.param("static", (100.0, 1000.0), marks=pytest.mark.slow),
                                        pytest.param("dynamic", (100.0, 1000.0), marks=pytest.mark.slow)])
def test_direct_beyond_its_calibrated_loss_factor_is_flagged(modulus, fs):
    """A loss-dominated material (SLS f = 100 and 1000, as rubbers reach: tan delta up to 5.0 and
    15.8) at the R_r peak (10 mm/s, 30 mm layer, 100 N): the direct method's estimate was
    calibrated up to tan delta 1.51 (f = 10) and said 10 % / 3.8 % (relaxed contact) where the full
    model puts it 34 % / 35 % low. Flagged now (estimate inf), and the full model confirms that the
    flag is deserved; at 1 mm/s (tan delta <= 0.5 over the contact's frequencies) it stays valid and
    within the 10 % promise of the full model."""
    for f in fs:
        mat = jr.StandardLinearSolid(3e6, 0.25, f)
        direct = _grid(mat, THICK, jr.Direct(modulus=modulus), [1e-3, 1e-2], [100.0])
        # the reference point by point (the front door: each on its own grid, from a cold start)
        full = [jr.rolling_resistance(mat, THICK, radius=RADIUS, load=100.0, speed=V, throw=False) for V in (1e-3, 1e-2)]
        assert all(bool(r.valid) for r in full), f
        err = np.asarray(direct.value)[:, 0] / np.array([float(r.value) for r in full]) - 1
        assert np.asarray(direct.result)[:, 0].tolist() == [0, jr.RESULTS.approximation_error], (f, err)
        assert np.isinf(float(direct.approximation[1, 0]))
        assert abs(err[1]) > 0.10, (f, err)  # the flag is deserved: measured -34..-35 % (relaxed)
        assert abs(err[0]) <= SLACK + float(full[0].truncation), (f, err)  # measured -4.1 / -4.4 %


def test_direct_above_the_peak_of_a_loss_dominated_material_is_flagged():
    """SLS f = 146 (tan delta up to 6.0) on a 346 mm layer, R = 2 cm, 104 N, at 6.13 m/s, above the
    R_r peak: tan delta is 1.4 at the contact's frequency and 6.0 a decade lower, where the wake's
    long waves carry part of the loss. The direct method with the dynamic contact was valid with an
    estimate of 6.8 % where the full 3D model puts it 26.6 % low (a seeded f = 30..1000 sweep,
    ``benchmarks/loss_dominated.py approx``, case 4). Flagged now (the loss factor is read from a
    decade below the contact's frequency), and the full model confirms the flag. (Below the peak,
    3.83 mm/s, it stays valid: the slow loss-dominated sweep below.)"""
    mat, layer = jr.StandardLinearSolid(3.21e6, 0.0858, 146.0), jr.Layer(0.346)
    full = jr.rolling_resistance(mat, layer, radius=RADIUS, load=104.0, speed=6.13, throw=False)
    with pytest.warns(jr.ValidityWarning, match="approximate method's estimated error"):
        res = jr.rolling_resistance(mat, layer, radius=RADIUS, load=104.0, speed=6.13,
                                    method=jr.Direct(modulus="dynamic"), throw=False)
    assert bool(full.valid)
    err = float(res.value) / float(full.value) - 1
    assert err < -0.10, err  # measured -26.6 %
    assert int(res.result) == jr.RESULTS.approximation_error and np.isinf(float(res.approximation)), err


def test_the_loss_band_reaches_a_decade_below_the_contact_frequency():
    """The check of the case above on its own: the direct method's dynamic contact radius there is
    1.33 mm; over ``V/r .. 10 V/r`` the loss factor stays below 1.6 (1.4 at most), a decade lower
    it reaches 6.0. ``below`` is a static number >= 1."""
    mat, V, r = jr.StandardLinearSolid(3.21e6, 0.0858, 146.0), 6.13, 1.33e-3
    check = jr.grids.loss_beyond_calibration
    assert not bool(check(mat, V, r, r))
    assert bool(check(mat, V, r, r, below=jr.grids.APPROXIMATION_LONG_WAVES))
    tan_delta = [float(jnp.imag(g) / jnp.real(g)) for g in mat.complex_modulus(jnp.asarray([V / r, V / (10 * r)]))]
    assert tan_delta[0] < 1.6 < tan_delta[1], tan_delta
    with pytest.raises(ValueError, match="below"):
        check(mat, V, r, r, below=0.5)


def test_slices_beyond_their_calibrated_loss_factor_are_flagged():
    """A loss-dominated solid (SLS f = 33.8, tan delta up to 2.9; the slices' estimate is calibrated
    on f <= 10, tan delta <= 1.51) on a 7 mm layer at 1 and 2.47 m/s, 17.5 N: SP was valid with an
    estimate of 4.2 / 6.6 % where the full 3D model (the reference) puts it +9.7 / +16.3 % high.
    Now not valid there (``approximation_error``, as the direct method beyond the calibration);
    the full model confirms the flag at 2.47 m/s (more than 10 % off)."""
    mat, layer, speeds = jr.StandardLinearSolid(2.89e6, 0.0149, 33.8), jr.Layer(0.00697), [1.0, 2.47]
    full = _grid(mat, layer, jr.Full(), speeds, [17.5])
    res = _grid(mat, layer, jr.Slices("SP"), speeds, [17.5])
    assert np.all(np.asarray(full.valid))
    err = np.asarray(res.value)[:, 0] / np.asarray(full.value)[:, 0] - 1
    assert err[1] > 0.10, err
    np.testing.assert_array_equal(np.asarray(res.result)[:, 0], jr.RESULTS.approximation_error)
    assert np.all(np.isinf(np.asarray(res.approximation)))


def test_direct_on_the_shipped_measured_material(shipped):
    # R = 1 cm, 10 N, H = 10 mm, 1 mm/s at 298 K (the defaults of `jaxroll map`): the relaxed
    # contact is 0.63 mm against the full model's 0.22 mm, R_r 88 % low; the dynamic contact is
    # within 3.4 % (tests/test_defaults.py)
    m = jr.at_temperature(*shipped, 298.15)
    kw = dict(radius=0.01, load=10.0, speed=1e-3, throw=False)
    with pytest.warns(jr.ValidityWarning, match="use the full model"):
        relaxed = jr.rolling_resistance(m, jr.Layer(0.01), method=jr.Direct(), **kw)
    assert int(relaxed.result) == jr.RESULTS.approximation_error and float(relaxed.approximation) > 0.8  # -88 %
    dynamic = jr.rolling_resistance(m, jr.Layer(0.01), method=jr.Direct(modulus="dynamic"), **kw)
    assert bool(dynamic.valid) and float(dynamic.approximation) < 0.1
    with pytest.raises(jr.SolverError, match=r"approximation_error.*full model"):
        jr.rolling_resistance(m, jr.Layer(0.01), method=jr.Direct(), radius=0.01, load=10.0, speed=1e-3)


@pytest.mark.parametrize("modulus", ["static", "dynamic", "glassy"])
def test_direct_cylinder_against_the_exact_viscoelastic_cylinder(modulus):
    # an independent oracle: the exact SLS cylinder on a half-space (jr.reference, Hunter's
    # problem; its own error ~1e-6). Every valid direct value is within 10 %, and wherever the
    # direct method is more than 10 % off it says so. Measured: worst valid 7.4 % (glassy, f = 10)
    speeds = np.logspace(-4, 1, 11)
    for f in (0.3, 1.0, 3.0):
        mat = jr.StandardLinearSolid(3e6, 0.25, f)
        res = _grid(mat, HALF_SPACE, jr.Direct(modulus=modulus), speeds, [5000.0], geometry="cylinder")
        exact = np.array([float(jr.reference.exact_cylinder_halfspace(mat, RADIUS, 5000.0, V).rolling_resistance)
                          for V in speeds])
        err = np.abs(np.asarray(res.value)[:, 0] / exact - 1)
        ok = np.asarray(res.valid)[:, 0]
        assert np.all(err[ok] <= 0.10), (f, err, res.approximation)
        assert np.all(ok[err <= 0.05])  # and within 5 % it is valid: the estimate is not needlessly strict


# --------------------------------------------------------------------- layers with inertia

#: Density of the inertia cases [kg/m^3], and the speeds as fractions of the shear-wave speed
#: sqrt(G0/rho) of G0 = 3 MPa (54.8 m/s).
RHO = 1000.0
WAVE_FRACTIONS = np.array([0.1, 0.3, 0.6])


@pytest.mark.parametrize("tau", [1e-6, 0.25], ids=["relaxed", "glassy"])
@pytest.mark.parametrize("H", [jnp.inf, 0.03], ids=["half-space", "30mm"])
def test_direct_on_a_layer_with_inertia_against_the_full_model(tau, H):
    # Inertia softens the layer toward the shear-wave speed; the direct method's contact ignores
    # it (its value was marked valid while +40 % off at 0.6 c_s, +131 % at 0.8). The reference:
    # the full 2D model with inertia (default grid, its truncation <= 0.7 % here; it moves 0.1 %
    # at twice the cells). Measured (benchmarks/approx_validity.py inertia): relaxed contact
    # (tau = 1 us) +0.8 / +7.3 / +40 % at 0.1 / 0.3 / 0.6 c_s, estimate 0.040 / 0.129 / 0.593;
    # glassy (tau = 0.25 s, the dynamic modulus) +0.0 / +0.3 / +0.9 %, estimate 0.035 / 0.077 / 0.25.
    mat = jr.StandardLinearSolid(3e6, tau, 1.0 if tau > 1e-3 else 0.1)
    layer = jr.Layer(H, rho=RHO)
    speeds = WAVE_FRACTIONS * np.sqrt(3e6 / RHO)
    full = _grid(mat, layer, jr.Full(), speeds, [5000.0], geometry="cylinder")
    assert np.all(np.asarray(full.valid))
    for modulus in ("static", "dynamic"):
        res = _grid(mat, layer, jr.Direct(modulus=modulus), speeds, [5000.0], geometry="cylinder")
        err = np.abs(np.asarray(res.value)[:, 0] / np.asarray(full.value)[:, 0] - 1)
        trunc = np.asarray(full.truncation)[:, 0]
        ok = np.asarray(res.valid)[:, 0]
        # the estimate bounds the real error (up to the reference's own), so valid means within 10 %
        assert np.all(np.asarray(res.approximation)[:, 0] + trunc >= err), (modulus, err, res.approximation)
        assert np.all(err[ok] <= 0.10 + trunc[ok]), (modulus, err, res.approximation)
        if tau < 1e-3:  # the relaxed contact at 0.6 c_s (both moduli: G' ~ G0): 36-40 % off, flagged
            assert not ok[-1] and err[-1] > 0.3


@pytest.mark.slow  # (a full 3D table with inertia; the cylinder version above always runs)
def test_direct_and_slices_on_a_sphere_with_inertia_against_the_full_model():
    # the relaxed contact on a half-space (SLS 3 MPa, 1 us, f = 0.1; R = 2 cm, 100 N), the
    # reference the full 3D model (default grid, truncation 3.2 % at this low V tau/a). Measured:
    # direct +1.3 / +5.4 / +29 % at 0.1 / 0.3 / 0.6 c_s (estimates 0.040 / 0.129 / 0.59); SP
    # +2.0 / +3.4 / +13 % (its own estimate, without an inertia term: 0.033 / 0.060 / 0.198)
    mat, layer = jr.StandardLinearSolid(3e6, 1e-6, 0.1), jr.Layer(jnp.inf, rho=RHO)
    speeds = WAVE_FRACTIONS * np.sqrt(3e6 / RHO)
    full = _grid(mat, layer, jr.Full(), speeds, [100.0])
    assert np.all(np.asarray(full.valid))
    trunc = np.asarray(full.truncation)[:, 0]
    for method in (jr.Direct(), jr.Slices("SP")):
        res = _grid(mat, layer, method, speeds, [100.0])
        err = np.abs(np.asarray(res.value)[:, 0] / np.asarray(full.value)[:, 0] - 1)
        assert np.all(np.asarray(res.approximation)[:, 0] + trunc >= err), (method, err, res.approximation)
        ok = np.asarray(res.valid)[:, 0]
        assert np.all(err[ok] <= 0.10 + trunc[ok]) and not ok[-1], (method, err, res.approximation)


def test_inertia_error_vanishes_without_inertia_and_grows_toward_the_wave_speed():
    from jaxroll.engines.direct import inertia_error
    r = 1e-3
    assert float(inertia_error(PAPER, THICK, 10.0, r)) == 0.0
    c_s = np.sqrt(3e6 / RHO)
    est = [float(inertia_error(PAPER, jr.Layer(0.03, rho=RHO), x * c_s, r)) for x in (0.1, 0.5, 0.9)]
    assert 0 < est[0] < est[1] < est[2] < np.inf
    # at the contact's frequency V/r = 5.5e3..4.9e4 rad/s the SLS (tau = 0.25 s) is glassy,
    # G' -> 2 G0: m = x^2/2, the estimate m/(1 - m)
    np.testing.assert_allclose(est, [m / (1 - m) for m in (0.005, 0.125, 0.405)], rtol=1e-4)
    # in the front door under jit(vmap), as eager; the estimate is stop_gradient, so the value's
    # gradient is the method's own (central differences below, step 1e-5 relative: error ~1e-9)
    mat, layer = jr.StandardLinearSolid(3e6, 1e-6, 0.1), jr.Layer(0.03, rho=RHO)

    def point(V):
        return jr.rolling_resistance(mat, layer, radius=RADIUS, load=5000.0, speed=V, geometry="cylinder",
                                     method="direct", throw=False)

    speeds = WAVE_FRACTIONS * c_s
    batched = jax.jit(jax.vmap(point))(jnp.asarray(speeds))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.ValidityWarning)  # (the last two are flagged)
        eager = [point(float(V)) for V in speeds]
    np.testing.assert_allclose(batched.approximation, [float(r.approximation) for r in eager], rtol=1e-12)
    np.testing.assert_array_equal(batched.result, [int(r.result) for r in eager])
    V = float(speeds[0])  # (valid there: no warning)
    g = jax.grad(lambda G0: jr.rolling_resistance(jr.StandardLinearSolid(G0, 1e-6, 0.1), layer, radius=RADIUS,
                                                  load=5000.0, speed=V, geometry="cylinder", method="direct",
                                                  throw=False).value)(3e6)
    fd = central_difference(lambda p: jr.rolling_resistance(jr.StandardLinearSolid(p["G0"], 1e-6, 0.1), layer,
                                                            radius=RADIUS, load=5000.0, speed=V, geometry="cylinder",
                                                            method="direct", throw=False).value, {"G0": 3e6}, "G0")
    np.testing.assert_allclose(g, fd, rtol=1e-5)


# --------------------------------------------------------------------- valid means close to full

#: Speeds of the comparison below: below, at and above the R_r peak of the paper's material.
SPEEDS = np.array([1e-3, 1e-2, 0.3, 3.0])


@pytest.fixture(scope="module")
def reference():
    """The full 3D model (default grid) on the paper's case, 30 mm layer, 100 N."""
    return _grid(PAPER, THICK, jr.Full(), SPEEDS, [100.0])


@pytest.mark.parametrize("method", [jr.Direct(), jr.Direct(modulus="dynamic"), jr.Direct(modulus="glassy"),
                                    jr.Slices("SP"), jr.Slices("PD")], ids=lambda m: str(getattr(m, "modulus", "")) or m.algorithm)
def test_valid_approximate_results_are_within_10_percent_of_the_full_model(method, reference):
    res = _grid(PAPER, THICK, method, SPEEDS, [100.0])
    full, trunc = np.asarray(reference.value)[:, 0], np.asarray(reference.truncation)[:, 0]
    assert np.all(np.asarray(reference.valid))
    err = np.asarray(res.value)[:, 0] / full - 1
    ok = np.asarray(res.valid)[:, 0]
    assert ok.any() and not ok.all(), (err, res.approximation)  # each method is valid somewhere, not everywhere
    assert np.all(np.abs(err[ok]) <= SLACK + trunc[ok]), (err, res.approximation)
    # where flagged, the estimate is above 10 % (the only reason here)
    bad = np.asarray(res.result)[:, 0][~ok]
    assert np.all(bad == jr.RESULTS.approximation_error)


def test_the_estimate_under_jit_vmap_and_grad():
    # the estimate (stop_gradient) decides validity only: the value's gradient is the
    # method's own (central differences, step 1e-5 relative: error ~1e-9)
    def point(G0, V, modulus="static"):
        return jr.rolling_resistance(jr.StandardLinearSolid(G0, 0.25, 1.0), THICK, radius=RADIUS, load=100.0, speed=V,
                                     method=jr.Direct(modulus=modulus), throw=False)

    speeds = jnp.asarray([1e-3, 1e-2, 1.0])
    batched = jax.jit(jax.vmap(lambda V: point(3e6, V)))(speeds)
    eager = _grid(PAPER, THICK, jr.Direct(), speeds, [100.0])
    np.testing.assert_allclose(batched.approximation, np.asarray(eager.approximation)[:, 0], rtol=1e-10)
    np.testing.assert_array_equal(batched.result, np.asarray(eager.result)[:, 0])
    g = jax.grad(lambda G0: point(G0, 1e-3).value)(3e6)
    fd = central_difference(lambda p: point(p["G0"], 1e-3).value, {"G0": 3e6}, "G0")
    np.testing.assert_allclose(g, fd, rtol=1e-5)


# --------------------------------------------------------------------- the sweep (slow)


def _draw(rng, shipped):
    """One random case: material, layer, radius, 2 loads, 11 speeds (sorted), label."""
    speeds = np.sort(10 ** rng.uniform(-4, 1, 11))
    if rng.uniform() < 0.3:  # the measured Prony material, -25..75 degC
        T = rng.uniform(248.15, 348.15)
        mat, R = jr.at_temperature(*shipped, T), 0.01
        loads = np.sort(10 ** rng.uniform(np.log10(2), np.log10(20), 2))
        label = f"pyvisco T={T - 273.15:.0f} C"
    else:  # SLS f = 0.05..10, G0 1..10 MPa, tau 0.01..1 s
        G0, tau, f = 10 ** rng.uniform(6, 7), 10 ** rng.uniform(-2, 0), 10 ** rng.uniform(np.log10(0.05), 1)
        mat, R = jr.StandardLinearSolid(G0, tau, f), 0.02
        loads = np.sort(10 ** rng.uniform(1, np.log10(150), 2))
        label = f"SLS G0={G0:.3g} tau={tau:.3g} f={f:.3g}"
    r = float(jr.engines.contact_size.estimate_contact_size(mat, HALF_SPACE, R, loads[-1]))
    # a half-space, thick layers and layers down to a third of the relaxed contact radius
    H = np.inf if rng.uniform() < 0.25 else r * 10 ** rng.uniform(np.log10(0.3), 2)
    return mat, jr.Layer(H), R, loads, speeds, label


METHODS = {"direct-relaxed": jr.Direct(), "direct-dynamic": jr.Direct(modulus="dynamic"),
           "direct-glassy": jr.Direct(modulus="glassy"), "PD": jr.Slices("PD"), "PP": jr.Slices("PP"),
           "SP": jr.Slices("SP")}


#: The two envelopes of the sweep below: (seed, cases, draw). "calibrated": SLS f = 0.05..10 and
#: the measured Prony material; "loss-dominated": SLS f = 30..1000, the first five cases of
#: ``benchmarks/loss_dominated.py approx`` (measured there: 0 points valid and more than the
#: allowance off, after the fixes of 2026-11-29; the full tables take 8 s to 12 min each, case 3's
#: the longest).
ENVELOPES = {"calibrated": (2711, 16, _draw), "loss-dominated": (77, 5, lambda rng, shipped: draw_loss_dominated(rng))}


@pytest.mark.slow
@pytest.mark.parametrize("envelope", list(ENVELOPES))
def test_valid_means_within_10_percent_of_the_full_model_over_the_envelope(shipped, envelope):
    """Seeded random tables (material, layer, radius; 11 random speeds x 2 random loads each)
    against the full 3D model with its default grid; one line per case and a summary per method
    (``pytest -s``)."""
    seed, n_cases, draw = ENVELOPES[envelope]
    rng = np.random.default_rng(seed)
    stats = {k: [] for k in METHODS}
    for case in range(n_cases):
        mat, layer, R, loads, speeds, label = draw(rng, shipped)
        try:
            full = _grid(mat, layer, jr.Full(), speeds, loads, radius=R)
        except ValueError as err:  # a grid above the memory budget
            assert "memory" in str(err)
            continue
        ref_ok = np.asarray(full.valid)
        line = []
        for name, method in METHODS.items():
            res = _grid(mat, layer, method, speeds, loads, radius=R)
            err = (np.asarray(res.value) / np.asarray(full.value) - 1)[ref_ok]
            ok = np.asarray(res.valid)[ref_ok]
            est, trunc = np.asarray(res.approximation)[ref_ok], np.asarray(full.truncation)[ref_ok]
            stats[name] += list(zip(ok, err, est, trunc))
            line.append(f"{name} {ok.sum()}/{ok.size} valid, worst {np.max(np.abs(err[ok]), initial=0):.3f}")
            bad = ok & (np.abs(err) > SLACK + trunc)
            assert not bad.any(), (label, layer.H, name, err[bad], est[bad])
        print(f"\ncase {case} ({label}, H = {float(layer.H):.3g} m, R = {R} m): " + "; ".join(line), flush=True)
    for name, rows in stats.items():
        ok, err, est, trunc = (np.array(c) for c in zip(*rows))
        print(f"\n{name}: {len(rows)} points, {ok.sum()} valid, worst valid |error| "
              f"{np.max(np.abs(err[ok]), initial=0):.3f}, estimate >= |error| at {np.mean(est >= np.abs(err)):.0%}, "
              f"estimate + reference truncation >= |error| at {np.mean(est + trunc >= np.abs(err)):.0%}")
