"""The default grid of the full models has a stated accuracy, and ``truncation`` bounds the real
error of the reported value (the dissipation form of R_r).

Oracles: the exact viscoelastic cylinder on a half-space (standard linear solid,
``jr.reference.exact_cylinder_halfspace``) for the 2D model; a convergence study (the same
model on a finer grid) for the 3D model. Materials and regimes are chosen off the calibration
points of the error tables in :mod:`jaxroll.grids` (f = 1 and 3 at zeta = 1e-3, 3e-3, 0.01, ..;
one 21-term Prony series): other f, zetas between the table's rows, other loads, another
Prony spectrum.
"""

import math

import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jr
from jaxroll import grids

R = 0.02
HALF = jr.Layer(H=jnp.inf)


def sls(f):
    return jr.StandardLinearSolid(G0=3e6, tau=0.25, f=f)


def steep_prony():
    """A Prony series unlike the calibration one: 13 terms over 1e-8..1e4 s, moduli falling
    with the time (glassy/relaxed = 71)."""
    k = np.arange(-8, 5.0)
    return jr.GeneralizedMaxwell(G_inf=2e6, G=4e6 * 10 ** (-0.15 * (k + 8)), tau=10.0 ** k)


def test_regime_zeta_is_v_tau_over_a_for_the_standard_linear_solid():
    # oracle: the SLS's loss compliance is a Debye peak at omega tau = 1, so the definition
    # gives V tau/a; error source: the central difference in log omega (step 0.05), O(h^2) ~ 1e-3
    for f in (0.3, 1.0, 5.0):
        for zeta in (1e-4, 1e-2, 0.3, 1.0, 7.0, 1e3):
            a = 4e-3
            got = float(grids.regime_zeta(sls(f), zeta * a / 0.25, a))
            assert got == pytest.approx(zeta, rel=2e-3), (f, zeta, got)
    # no loss: elastic material, V = 0
    assert float(grids.regime_zeta(sls(0.0), 1.0, 1e-3)) == 1.0
    assert float(grids.regime_zeta(sls(1.0), 0.0, 1e-3)) == 1.0


def test_broad_spectra_sit_near_the_peak():
    # a loss spread over 12 decades has d ln J''/d ln omega ~ 0 and no curvature at any speed;
    # the standard linear solid's single Debye peak has breadth 0 (error: the O(h^2) differences)
    for V in (1e-6, 1e-2, 1e2):
        z, b = (float(x) for x in grids.regime(steep_prony(), V, 3e-3))
        assert 0.2 < z < 5.0 and b > 0.8, (V, z, b)
    for zeta in (0.1, 1.0, 10.0):
        assert float(grids.regime(sls(1.0), zeta * 4e-3 / 0.25, 4e-3)[1]) < 2e-3


def test_rules_meet_the_target_on_their_table():
    """Each rule's cells give an estimated error <= 0.5 % wherever the table allows it (sphere:
    zeta >= 0.01; below, the rule stops at 48 cells); the sphere needs 12 cells from zeta = 0.3 up
    (16 for a broad spectrum at the peak) and the most at low zeta."""
    for z in np.logspace(-3, 3, 61):
        c = grids.sphere_cells_per_radius(float(z))
        e = float(grids.dissipation_error(z, c, "sphere"))
        assert e <= grids.TARGET_ERROR or (c == grids.MAX_SPHERE_RULE_CELLS and z < 1e-2), (z, c, e)
        c2 = grids.cylinder_cells_per_radius(float(z))
        assert float(grids.dissipation_error(z, c2, "cylinder")) <= grids.TARGET_ERROR, (z, c2)
    assert grids.sphere_cells_per_radius(100.0) == 12 and grids.sphere_cells_per_radius(1.0) == 12
    assert grids.sphere_cells_per_radius(1.0, breadth=1.0) == 16  # a broad spectrum at the peak
    assert grids.sphere_cells_per_radius(1e-3) == grids.MAX_SPHERE_RULE_CELLS


def test_the_autogrid_sizes_by_the_regime():
    a0 = float(jr.reference.hertz_sphere(100.0, R, 3e6).contact_radius)
    for zeta, cells in [(100.0, 12), (1.0, 12), (0.15, 20), (0.015, 32)]:  # grids.SPHERE_ERROR's rule
        m = jr.Full().resolve(sls(1.0), HALF, radius=R, loads=100.0, speeds=zeta * a0 / 0.25, geometry="sphere")
        assert a0 / float(m.grid.spacing) == pytest.approx(cells, rel=1e-9)
    # an envelope takes the finest need of its points
    m = jr.Full().resolve(sls(1.0), HALF, radius=R, loads=100.0, speeds=np.array([0.015, 100.0]) * a0 / 0.25,
                          geometry="sphere")
    assert a0 / float(m.grid.spacing) == pytest.approx(32, rel=1e-9)
    # a broad spectrum near the peak: 16 cells per radius
    r = float(jr.engines.contact_size.estimate_contact_size(steep_prony(), HALF, R, 100.0, "sphere"))
    m = jr.Full().resolve(steep_prony(), HALF, radius=R, loads=100.0, speeds=0.01, geometry="sphere")
    assert r / float(m.grid.spacing) == pytest.approx(16, rel=1e-9)
    # the static pressure of DirectElastic keeps 12 cells
    m = jr.DirectElastic().resolve(sls(1.0), HALF, radius=R, loads=100.0, speeds=0.015 * a0 / 0.25)
    assert a0 / float(m.grid.spacing) == pytest.approx(12, rel=1e-2)


def _cylinder(material, zeta, P=1e4, method=None):
    a0 = float(jr.reference.hertz_cylinder(P, R, float(material.G0)))
    V = zeta * a0 / float(material.tau)
    res = jr.rolling_resistance(material, HALF, radius=R, load=P, speed=V, geometry="cylinder",
                                method=method or jr.Full(), throw=False)
    exact = float(jr.reference.exact_cylinder_halfspace(material, radius=R, load=P, speed=V).rolling_resistance)
    return abs(float(res.value) / exact - 1), float(res.truncation), res


@pytest.mark.parametrize("f, zeta, P", [(0.5, 0.02, 1e4), (1.5, 0.7, 3e3), (2.0, 30.0, 1e4), (0.5, 3e-3, 1e4)])
def test_cylinder_default_is_within_half_a_percent_and_truncation_bounds_it(f, zeta, P):
    # oracle: the exact half-space solution; the default grid's error (measured <= 0.34 %) and
    # its estimate
    err, trunc, res = _cylinder(sls(f), zeta, P)
    assert bool(res.valid)
    assert err <= 5e-3, (err, trunc)
    assert err <= trunc, (err, trunc)


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # coarse grids may be flagged
@pytest.mark.parametrize("cells", [12, 40])
def test_cylinder_truncation_bounds_the_error_on_coarse_grids(cells):
    # fixed cells per half-width (not the rule's): the estimate still bounds the exact error
    method = jr.Full(grid=jr.AutoGrid(cells_per_radius=cells))
    for f, zeta in [(1.5, 0.05), (1.5, 3.0), (0.7, 300.0)]:
        err, trunc, _ = _cylinder(sls(f), zeta, method=method)
        assert err <= trunc, (cells, f, zeta, err, trunc)


def _sphere(material, V, cells=None, P=100.0):
    method = jr.Full() if cells is None else jr.Full(grid=jr.AutoGrid(cells_per_radius=cells))
    return jr.rolling_resistance(material, HALF, radius=R, load=P, speed=V, method=method, throw=False)


def _sphere_cases(fine):
    a0 = float(jr.reference.hertz_sphere(100.0, R, 3e6).contact_radius)
    return [(sls(2.0), 0.05 * a0 / 0.25, fine), (sls(2.0), 3.0 * a0 / 0.25, fine),
            (steep_prony(), 0.01, fine)]


def _check_sphere(material, V, fine):
    coarse = _sphere(material, V)
    ref = _sphere(material, V, cells=fine)
    assert bool(coarse.valid) and bool(ref.valid)
    err = abs(float(coarse.value) / float(ref.value) - 1)
    # the reference's own error is bounded by its estimate (< 0.2 % at >= 32 cells), so the
    # default's error against the converged value is consistent with its bound when
    # |D - D_ref| <= truncation + truncation_ref
    t, t_ref = float(coarse.truncation), float(ref.truncation)
    assert err <= t + t_ref, (err, t, t_ref)
    # the default grid is sized for a measured error <= 0.5 %; its bound carries the safety factor 2
    assert err <= grids.TARGET_ERROR + t_ref and t <= grids.ERROR_SAFETY * grids.TARGET_ERROR


@pytest.mark.parametrize("case", range(3))
def test_sphere_truncation_bounds_a_convergence_study(case):
    """3D: the default grid against the same model at 32 cells per radius (reduced; 48 under
    ``-m slow``), off the table's calibration points (f = 2, zeta = 0.05 and 3; another Prony
    spectrum)."""
    _check_sphere(*_sphere_cases(32)[case])


@pytest.mark.slow
@pytest.mark.parametrize("case", range(3))
def test_sphere_truncation_bounds_a_fine_convergence_study(case):
    _check_sphere(*_sphere_cases(48)[case])


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # the coarse point is flagged on purpose
def test_full_flags_an_estimated_error_above_its_threshold():
    # 8 cells per radius at zeta = 3e-3: the moment and dissipation forms are ~10 % apart
    a0 = float(jr.reference.hertz_sphere(100.0, R, 3e6).contact_radius)
    res = _sphere(sls(1.0), 3e-3 * a0 / 0.25, cells=8)
    assert float(res.truncation) > jr.Full.max_truncation
    assert int(res.result) == jr.RESULTS.truncation_too_large
    assert math.isfinite(float(res.value))


def test_blended_value_is_differentiable_in_the_blend_band():
    # zeta = 2e-3 lies inside the blend toward the midpoint of the two forms: d R_r / d tau (which
    # moves zeta, hence the weight) against central differences on the same resolved grid;
    # tolerance: step 1e-5 relative (truncation ~1e-10, solver noise tol/h ~1e-5)
    import jax

    a0 = float(jr.reference.hertz_cylinder(1e4, R, 3e6))
    V = 2e-3 * a0 / 0.25
    method = jr.Full().resolve(sls(1.0), HALF, radius=R, loads=1e4, speeds=V, geometry="cylinder")

    def rr(tau):
        mat = jr.StandardLinearSolid(G0=3e6, tau=tau, f=1.0)
        return jr.rolling_resistance(mat, HALF, radius=R, load=1e4, speed=V, geometry="cylinder", method=method).value

    g = float(jax.jit(jax.grad(rr))(0.25))
    f = jax.jit(rr)
    h = 0.25 * 1e-5
    fd = (float(f(0.25 + h)) - float(f(0.25 - h))) / (2 * h)
    assert g == pytest.approx(fd, rel=1e-4), (g, fd)


# ------------------------------------------------------------------ thin layers


def test_thin_layer_envelope_joins_the_half_space_and_the_rules_meet_the_target():
    """On a finite layer the envelope is the larger of the half-space table and the thin-layer
    table (grids.THIN_ERROR): it never falls below the half-space table, and below the first block
    (a/H = 0.2) it moves from it toward that block's. Each rule's cells meet the 0.5 % target, or
    stop at its cap (cylinder 400 cells, sphere 48)."""
    error = grids._dissipation_error_jit  # the rules' compiled program (eager, every operation compiles)
    Z, T = np.meshgrid(np.logspace(-3, 3, 25), [0.05, 0.2, 0.35, 0.7, 1.5, 3.0, 8.0, 15.0, 30.0])
    z, t = Z.ravel(), T.ravel()
    for geometry, cap in [("cylinder", 400), ("sphere", grids.MAX_SPHERE_RULE_CELLS)]:
        r0 = grids.THIN_RATIOS[geometry][0]
        for c in (12.0, 24.0, 50.0, 400.0):
            half = np.asarray(error(z, c, geometry, 0.0, 0.0))
            assert np.all(np.asarray(error(z, c, geometry, 0.0, t)) >= half), (geometry, c)
            # log-linear in the ratio below the first block: at half of it, the geometric mean
            first = np.asarray(error(z, c, geometry, 0.0, r0 * (1 - 1e-12)))
            mid = np.asarray(error(z, c, geometry, 0.0, 0.5 * r0))
            np.testing.assert_allclose(mid, np.maximum(half, np.sqrt(half * first)), rtol=1e-9)
        cells = grids._rule_cells_array(z, np.zeros_like(z), geometry, t)
        err = np.asarray(error(z, cells.astype(float), geometry, 0.0, t))
        assert np.all((err <= grids.TARGET_ERROR) | (cells == cap)), (geometry, z[err > grids.TARGET_ERROR])


#: the conveyor idler of docs/conveyor.md: R = 94 mm on a 1.05 mm cover, G0 = 3.15 MPa, tau = 29.5 s
IDLER_R, IDLER_COVER = 0.094, jr.Layer(H=1.05e-3)
#: (f, line load [N/m], speed [m/s]): contact half-width 0.5-2.3 H, zeta = V tau/a = 2..6e3
IDLER_POINTS = [(f, P, V) for f in (0.5, 1.0, 2.0, 5.0) for P in (50.0, 200.0, 600.0) for V in (1e-4, 1e-3, 1e-2, 0.1)]
#: the reduced copy: the points the error estimate of the previous release got wrong (f = 1: -1.15 %
#: against a bound of 0.59 %; f = 0.5 and 2: flagged at 6-13 % while within 0.6 %), and one at a/H = 0.45
IDLER_REDUCED = [(1.0, 600.0, 1e-3), (0.5, 600.0, 1e-3), (2.0, 200.0, 1e-2), (5.0, 50.0, 0.1)]


def _check_idler(points):
    # oracle: the same model at 800 cells per half-width (a convergence study: measured within
    # 0.002 % of the value extrapolated to zero cell size from 100..1600 cells at these points,
    # benchmarks/thin_layer_error.py --validation; its own truncation <= 0.02 %)
    fine = jr.Full(grid=jr.AutoGrid(cells_per_radius=800))
    for f, P, V in points:
        mat = jr.StandardLinearSolid(G0=3.15e6, tau=29.5, f=f)
        # the front door raises if the result is not valid
        res = jr.rolling_resistance(mat, IDLER_COVER, radius=IDLER_R, load=P, speed=V, geometry="cylinder")
        ref = jr.rolling_resistance(mat, IDLER_COVER, radius=IDLER_R, load=P, speed=V, geometry="cylinder", method=fine)
        err, t, t_ref = abs(float(res.value) / float(ref.value) - 1), float(res.truncation), float(ref.truncation)
        assert err <= t + t_ref, (f, P, V, err, t, t_ref)
        # the default grid is sized for an error <= 0.5 % on its calibration (f <= 3 is the
        # tables'; this cover's f = 5 is not: 0.54 % measured at 200 N/m, 0.01 m/s), and its bound
        # is twice the envelope: the error stays within that factor of the target
        assert err <= grids.ERROR_SAFETY * grids.TARGET_ERROR, (f, P, V, err)


def test_cylinder_default_on_a_conveyor_cover_is_valid_and_bounded():
    """The default 2D model on a thin cover (a/H = 0.45-2.3, a regime the half-space tables do not
    cover): valid, within 0.5 % of a converged grid (0.54 % at one f = 5 point, off the tables'
    calibration), and its truncation bounds that (reduced: 4 of the 48 points of the slow copy)."""
    _check_idler(IDLER_REDUCED)


@pytest.mark.slow
def test_cylinder_default_on_a_conveyor_cover_is_valid_and_bounded_everywhere():
    _check_idler(IDLER_POINTS)


def _thin_sphere_cases(slow):
    """(material, layer, load, speed): the paper's 2 mm layer at 150 N (a/H ~ 2; zeta = 1, 0.1)
    and a 1.4 mm layer (a/H ~ 3.5, zeta = 1): at 12 cells per radius -0.9..-1.8 % off, which the
    half-space tables' bound (0.90 %) and the moment-dissipation gap (0.18-1.6 %) did not bound."""
    mat = sls(1.0)
    cases = []
    for H, zeta in [(2e-3, 1.0), (2e-3, 0.1), (1.4e-3, 1.0)][: 3 if slow else 1]:
        layer = jr.Layer(H=H)
        a = float(jr.engines.contact_size.estimate_contact_size(mat, layer, R, 150.0, "sphere"))
        cases.append((mat, layer, 150.0, zeta * a / 0.25))
    return cases


def _check_thin_sphere(cases, fine):
    for mat, layer, P, V in cases:
        res = jr.rolling_resistance(mat, layer, radius=R, load=P, speed=V)  # raises if not valid
        ref = jr.rolling_resistance(mat, layer, radius=R, load=P, speed=V,
                                    method=jr.Full(grid=jr.AutoGrid(cells_per_radius=fine)))
        err, t, t_ref = abs(float(res.value) / float(ref.value) - 1), float(res.truncation), float(ref.truncation)
        # the reference's own error is bounded by its estimate (0.3 % at 48 cells, 0.2 % at 64 here)
        assert err <= t + t_ref, (float(layer.H), V, err, t, t_ref)
        assert t <= grids.ERROR_SAFETY * grids.TARGET_ERROR, t


def test_sphere_default_on_a_thin_layer_is_bounded_by_a_convergence_study():
    """3D on a layer thinner than the contact (a/H ~ 2): the default grid (32 cells per radius
    here, 12 before the thin-layer tables) against 48 cells (64 under ``-m slow``, with two
    more points)."""
    _check_thin_sphere(_thin_sphere_cases(False), 48)


@pytest.mark.slow
def test_sphere_default_on_thin_layers_is_bounded_by_a_fine_convergence_study():
    _check_thin_sphere(_thin_sphere_cases(True), 64)


def test_cylinder_default_bounds_a_broad_spectrum_on_a_thin_layer():
    """A Prony series (21 terms over 20 decades, moduli scaled by 0.58) on a layer of a/H = 3.4 at
    its loss peak (regime zeta 1.0, breadth 0.61): an independent property run found the default
    1.03 % off with a bound of 0.95 %, the thin-layer broad-spectrum envelope having been scaled
    down by the breadth (grids.THIN_BROAD_FULL). Oracle: 800 cells per half-width (1600 agree to
    6e-6)."""
    k, s = np.arange(-10, 11.0), 0.5804873760031759
    mat = jr.GeneralizedMaxwell(G_inf=3e6 * s, G=1.5e6 * s * 10 ** (-0.1 * k), tau=10.0 ** k)
    layer, R, P, V = jr.Layer(H=1.1942898275123057e-4), 0.016721825656231537, 91.13115999278037, 3.088520136676127e-3
    res = jr.rolling_resistance(mat, layer, radius=R, load=P, speed=V, geometry="cylinder")  # raises if not valid
    ref = jr.rolling_resistance(mat, layer, radius=R, load=P, speed=V, geometry="cylinder",
                                method=jr.Full(grid=jr.AutoGrid(cells_per_radius=800)))
    err = abs(float(res.value) / float(ref.value) - 1)
    assert err <= float(res.truncation) + float(ref.truncation), (err, float(res.truncation))
