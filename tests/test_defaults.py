"""The full models are the defaults wherever a user gets a number without naming a method: the
front doors, maps, fits and every command of the command line; and the default's numbers agree
with independent anchors (the exact 2D half-space solution, Persson's small-f limit, Hertz)."""

import math
import warnings

import jax
import numpy as np
import pytest

import jaxroll as jr
from jaxroll.apps.cli import build_parser
from jaxroll.apps.cli.options import method_from_args
from jaxroll.identify.fit import MAX_REFITS, REGRID_FACTOR, IdentifiabilityWarning, RollingData, fit_material
from jaxroll.methods import FIT_EDGE_SMOOTHING, default_method

SLS = jr.StandardLinearSolid(3e6, 0.25, 1.0)
HALF = jr.Layer(np.inf)


@pytest.mark.parametrize("geometry", ["sphere", "cylinder"])
def test_default_is_the_full_model_on_an_infinite_layer(geometry):
    m = default_method(geometry)
    assert m == jr.Full() and isinstance(m.grid, jr.AutoGrid) and m.grid.period is None
    assert m.edge_smoothing is None
    assert default_method(geometry, fit=True) == jr.Full(edge_smoothing=FIT_EDGE_SMOOTHING, edge_extrapolation=True)
    with pytest.raises(ValueError):
        default_method("cube")


def test_default_cylinder_point_and_table_are_the_full_model_and_match_the_exact_solution():
    """rolling_resistance and rolling_resistance_grid without a method: bitwise the full 2D
    model's numbers, and within 1.5 % of the exact half-space solution near the R_r peak
    (zeta = 1.09; the default line grid's discretisation error, 0.8 % in docs/methods.md)."""
    R, P = 0.02, 5e3
    a0 = math.sqrt(P * R / (math.pi * 3e6))
    V = 1.087 * a0 / 0.25
    got = jr.rolling_resistance(SLS, HALF, radius=R, load=P, speed=V, geometry="cylinder")
    full = jr.rolling_resistance(SLS, HALF, radius=R, load=P, speed=V, geometry="cylinder", method=jr.Full())
    assert float(got.value) == float(full.value)
    exact = float(jr.reference.exact_cylinder_halfspace(SLS, R, P, V).rolling_resistance)
    assert abs(float(got.value) / exact - 1) < 0.015, (float(got.value), exact)
    table = jr.rolling_resistance_grid(SLS, HALF, radius=R, loads=[P], speeds=[V], geometry="cylinder")
    # the table's warm-started solve equals the single solve to the contact solver's tolerance
    assert float(table.value[0, 0]) == pytest.approx(float(full.value), rel=1e-8)


@pytest.mark.parametrize(("geometry", "loads"), [("sphere", [80.4, 110.4]), ("cylinder", [4e3, 6e3])])
def test_default_table_grid_is_the_finest_its_points_ask_for(geometry, loads):
    """A table's automatic grid has the finest cell any of its points asks for alone,
    ``min(size/cells)``, and a window no wider than the widest of theirs (to a cell's rounding).
    Before, the largest cell count went on the smallest size: over 2.6e-4..7.4 m/s of a
    loss-dominated solid (SLS f = 157, tau = 13.9 ms, 335 mm layer, R = 2 cm) the sphere's table
    got cells 2.6x finer than any point's (0.038 mm against 0.099 mm) and a 347-cell window
    against 121-135, and did not finish in 400 s (now 16 s for 11 speeds x 2 loads). Oracle:
    each point's own resolved grid."""
    mat, layer = jr.StandardLinearSolid(2.78e6, 0.0139, 157.0), jr.Layer(0.335)
    speeds = [2.6e-4, 1.09e-3, 1.621e-2, 0.143, 1.006, 7.436]

    def grid(P, V):
        return jr.Full().resolve(mat, layer, radius=0.02, loads=P, speeds=V, geometry=geometry).grid

    table = grid(loads, speeds)
    own = [grid([P], [V]) for P in loads for V in speeds]
    assert table.spacing == pytest.approx(min(g.spacing for g in own), rel=1e-12)
    widest = max(g.spacing * g.window for g in own)
    assert table.spacing * table.window <= widest + 3 * table.spacing  # (2 ceil(x) + 1 cells)


def test_default_sphere_matches_persson_and_hertz_at_small_f():
    """A sphere without a method is the full 3D model: at small f (0.02) on a half-space its
    pressure stays Hertzian and R_r tends to Persson's stationary-pressure integral, which is
    first order in f (the stationary approximation errs by O(f), ~1 %); measured at zeta = 1:
    default grid +1.6 %, 24 cells per radius +0.4 %, so the grid error dominates. The slices
    (the former default) are not used: their value differs."""
    R, P = 0.02, 100.0
    mat = jr.StandardLinearSolid(3e6, 0.25, 0.02)
    a0 = (3 * P * R / (16 * 3e6)) ** (1 / 3)  # Hertz, E* = 4 G0
    V = a0 / 0.25  # zeta = 1, the R_r peak
    got = jr.rolling_resistance(mat, HALF, radius=R, load=P, speed=V)
    persson = jr.reference.persson_sphere_halfspace(mat, R, P, V)
    assert abs(float(got.value) / persson - 1) < 0.025, (float(got.value), persson)
    # the penetration lies between the relaxed and glassy Hertz values, 1.3 % apart at f = 0.02
    assert got.solution is not None  # a solved pressure: a full model, not a stationary one
    assert a0**2 / R * (1.02) ** (-2 / 3) * 0.995 < float(got.solution.penetration) < a0**2 / R * 1.005


def test_a_traced_sweep_needs_the_default_resolved():
    """Under jax.vmap/jit (jr.sweep) the default's automatic grid cannot be sized: the error says
    how to resolve it, and the resolved default gives the eager values."""
    R, loads = 0.02, np.array([2e3, 5e3])

    def rr(P, method=None):
        return jr.rolling_resistance(SLS, HALF, radius=R, load=P, speed=0.01, geometry="cylinder", method=method).value

    with pytest.raises(ValueError, match="Resolve the grid once"):
        jr.sweep(rr, loads)
    method = default_method("cylinder").resolve(SLS, HALF, radius=R, loads=loads, speeds=[0.01], geometry="cylinder")
    swept = np.asarray(jr.sweep(lambda P: rr(P, method), loads))
    eager = [float(rr(P, method)) for P in loads]
    np.testing.assert_allclose(swept, eager, rtol=1e-10)


def test_resistance_map_default_is_the_full_model():
    """A 1 x 1 map without a method: the full model's value at that temperature and speed (the
    map's one grid is the front door's grid for one point)."""
    mat, wlf = SLS.to_prony(), jr.WLF(8.86, 101.6, 293.15)
    m = jr.resistance_map(mat, wlf, jr.Layer(0.01), radius=0.01, load=500.0, temperatures=[293.15], speeds=[1e-2],
                          geometry="cylinder")
    ref = jr.rolling_resistance(jr.at_temperature(mat, wlf, 293.15), jr.Layer(0.01), radius=0.01, load=500.0,
                                speed=1e-2, geometry="cylinder", method=jr.Full())
    assert m.valid.all() and float(m.value[0, 0]) == pytest.approx(float(ref.value), rel=1e-8)
    direct = jr.resistance_map(mat, wlf, jr.Layer(0.01), radius=0.01, load=500.0, temperatures=[293.15],
                               speeds=[1e-2], geometry="cylinder", method="direct")
    assert abs(float(direct.value[0, 0]) / float(m.value[0, 0]) - 1) > 1e-3  # another method, another number


@pytest.mark.run_bound  # its fits run long: 117 s of CPU without LLVM's passes, 23 s with them
def test_fit_material_default_resolves_its_grid_and_regrids_once():
    """Without a method a rolling fit uses the smoothed full model on a grid it resolves from the
    data at the initial guess; starting at half the true G0 the contact half-width at the fitted
    point is ~1.4x smaller, beyond REGRID_FACTOR, so the grid is resolved again and the fit
    restarts there (two or more entries in ``starts``). Data: the exact 2D half-space solution at 6
    speeds around the peak and 2 loads, 1 % noise; the fitted G0 and tau are within 10 % (the
    extrapolated smoothed edge is within 0.05 % of the exact contact, but the default grid's own
    error, up to ~0.4 % against the exact solution, is amplified along the G0-tau valley)."""
    R, loads, speeds = 0.02, np.array([2e3, 5e3]), np.logspace(-3, -1, 6)
    V, P = (a.ravel() for a in np.meshgrid(speeds, loads))
    exact = np.asarray(jax.vmap(lambda v, p: jr.reference.exact_cylinder_halfspace(SLS, R, p, v).rolling_resistance)(
        V, P))
    y = exact * (1 + 0.01 * np.random.default_rng(3).standard_normal(exact.size))
    start = jr.StandardLinearSolid(1.5e6, 0.25, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)  # G0-tau correlation (expected)
        # the grid logic under test; linearised intervals (the profiles are test_fit_unbiased.py's)
        fit = fit_material(RollingData(V, P, y), initial=start, layer=HALF, radius=R, geometry="cylinder",
                           free=("G0", "tau"), intervals="linear")
    assert isinstance(fit.method, jr.Full) and fit.method.edge_smoothing == FIT_EDGE_SMOOTHING
    assert fit.method.edge_extrapolation
    assert isinstance(fit.method.grid, jr.FixedGrid)
    assert 2 <= len(fit.starts) <= 1 + MAX_REFITS  # the first fit, refits on grids resolved at its results
    final = default_method("cylinder", fit=True).resolve(fit.material, HALF, radius=R, loads=P, speeds=V,
                                                         geometry="cylinder")
    # the fit ended on a grid within REGRID_FACTOR of the one its own result needs
    assert max(float(fit.method.grid.spacing) / float(final.grid.spacing),
               float(final.grid.spacing) / float(fit.method.grid.spacing)) < REGRID_FACTOR
    first = default_method("cylinder", fit=True).resolve(start, HALF, radius=R, loads=P, speeds=V, geometry="cylinder")
    assert float(first.grid.spacing) / float(final.grid.spacing) > REGRID_FACTOR
    assert fit.converged
    assert abs(float(fit.params["G0"]) / 3e6 - 1) < 0.1 and abs(float(fit.params["tau"]) / 0.25 - 1) < 0.1, fit.params


@pytest.mark.parametrize("command, fit", [(["curve"], False), (["sweep", "--vary", "V=0.1,1"], False),
                                          (["map", "--material", "m.json"], False),
                                          (["fit", "d.csv", "--radius", "0.02"], True)])
@pytest.mark.parametrize("geometry", ["sphere", "cylinder"])
def test_every_cli_command_defaults_to_the_full_model(command, fit, geometry):
    args = build_parser().parse_args([*command, "--geometry", geometry])
    assert method_from_args(args, fit=fit) == default_method(geometry, fit=fit)
    named = build_parser().parse_args([*command, "--geometry", geometry, "--method", "full"])
    assert method_from_args(named, fit=fit) == jr.Full()  # named: exactly what its options say


def test_cli_modulus_configures_the_direct_method():
    parse = build_parser().parse_args
    base = ["map", "--material", "m.json", "--method", "direct"]
    assert method_from_args(parse(base)) == jr.Direct(modulus="static")
    assert method_from_args(parse([*base, "--modulus", "relaxed"])) == jr.Direct(modulus="static")
    assert method_from_args(parse([*base, "--modulus", "dynamic"])) == jr.Direct(modulus="dynamic")
    assert method_from_args(parse([*base, "--modulus", "glassy"])) == jr.Direct(modulus="glassy")


@pytest.fixture(scope="module")
def shipped_material():
    data = jr.datasets.path("pyvisco_freq_user_raw.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.DataWarning)
        sw = jr.read_dma_sweeps(data)
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    return jr.fit_prony(jr.master_curve(sw, sh)).material, jr.fit_wlf(sh).shift


def test_direct_contact_modulus_on_the_shipped_material(shipped_material):
    """On the shipped measured material (Prony, 54x between relaxed and glassy modulus) at 298 K,
    1 mm/s (sphere R = 1 cm, 10 N, H = 10 mm: the defaults of ``jaxroll map``), the relaxed
    modulus sizes the direct method's contact at 0.63 mm against the full model's 0.22 mm and
    its R_r is ~88 % low; the modulus at the rolling frequency (``dynamic``) gives the full
    model's contact size and R_r within 10 % (measured -3.4 %: the stationary-pressure error of
    a broad spectrum), the glassy modulus errs the other way but less (measured +58 %)."""
    mat, shift = shipped_material
    m = jr.at_temperature(mat, shift, 298.15)
    kw = dict(radius=0.01, load=10.0, speed=1e-3)
    layer = jr.Layer(H=0.01)
    full = jr.rolling_resistance(m, layer, **kw)  # the default: the full 3D model
    with warnings.catch_warnings():  # the relaxed and glassy contacts are flagged (tests/test_approximation.py)
        warnings.simplefilter("ignore", jr.ValidityWarning)
        err = {mod: float(jr.rolling_resistance(m, layer, method=jr.Direct(modulus=mod), throw=False, **kw).value)
               / float(full.value) - 1 for mod in ("static", "dynamic", "glassy")}
    assert err["static"] < -0.5, err  # the relaxed contact: far too large, R_r far too low
    assert abs(err["dynamic"]) < 0.1, err
    assert abs(err["glassy"]) < abs(err["static"]), err
    r_dyn = float(jr.rolling_resistance(m, layer, method=jr.Direct(modulus="dynamic"), **kw).contact_radius)
    assert abs(r_dyn / float(full.contact_radius) - 1) < 0.1  # measured 0.215 mm vs 0.220 mm
