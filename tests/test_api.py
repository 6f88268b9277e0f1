"""The front doors and method objects: the same numbers under jit / vmap / grad as an eager call,
no recompilation for new values, explicit grids, the material protocol, result codes.

Oracles: the eager call of the same resolved method (transformations must not change a number:
1e-10 relative, the contact solvers' tolerance is 1e-10 on scaled residuals and the warm starts
differ between a vmapped batch and single calls); central finite differences for the gradients;
jax's own compilation events for "compiles nothing".
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax import monitoring

import jaxroll as jr
from jaxroll._numerics import newton_root

SLS = jr.StandardLinearSolid(3e6, 0.25, 1.0)
PRONY5 = jr.GeneralizedMaxwell(G_inf=1e6, G=[2e6, 1e6, 5e5, 3e5, 2e5], tau=[1e-3, 1e-2, 0.1, 1.0, 10.0])
HOT = jr.at_temperature(SLS, jr.WLF(8.86, 101.6, 293.15), 303.15)
HOT_PRONY5 = jr.at_temperature(PRONY5, jr.WLF(8.86, 101.6, 293.15), 303.15)
R = 0.02

# coarse grids (the numbers compared are those of the same discrete model, so resolution does
# not enter the tolerances)
SPHERE_GRID = jr.FixedGrid(6e-4, 17, period=0.08, n_terms=80)
LINE_GRID = jr.FixedGrid(2e-4, 80, period=0.1)

CASES = {
    "direct-sphere": (jr.Direct(), "sphere", jr.Layer(0.03), (60.0, 100.0)),
    "direct-cylinder": (jr.Direct(), "cylinder", jr.Layer(0.03), (3e3, 5e3)),
    "full-sphere": (jr.Full(grid=SPHERE_GRID), "sphere", jr.Layer(0.03), (60.0, 100.0)),
    "full-cylinder": (jr.Full(grid=LINE_GRID), "cylinder", jr.Layer(0.03), (3e3, 5e3)),
    "PD": (jr.Slices(algorithm="PD", grid=LINE_GRID), "sphere", jr.Layer(0.005), (60.0, 100.0)),
    "PP": (jr.Slices(algorithm="PP", grid=LINE_GRID), "sphere", jr.Layer(0.005), (60.0, 100.0)),
    "SP": (jr.Slices(algorithm="SP", grid=LINE_GRID), "sphere", jr.Layer(0.005), (60.0, 100.0)),
}


def _rr(material, layer, method, geometry, P, V):
    return jr.rolling_resistance(material, layer, radius=R, load=P, speed=V, geometry=geometry, method=method,
                                 throw=False)


# PD and PP share SP's front door and slice plumbing, and their own gradients are checked in
# tests/test_slices.py (slow there too): slow here; SP, the slices' default, always runs
_SLICES_PLUMBING = ("PD", "PP")


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # coarse test grids: short periods are flagged
@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.slow) if c in _SLICES_PLUMBING else c
                                  for c in CASES])
def test_jit_vmap_grad_equal_eager(case):
    method, geometry, layer, loads = CASES[case]
    speeds = (3e-3, 3e-2)
    pts = [(P, V) for P in loads for V in speeds]
    eager = np.array([float(_rr(SLS, layer, method, geometry, P, V).value) for P, V in pts])
    assert np.all(eager > 0)
    # one jitted vmap over the points and over a batch of materials (the pytree leaves: a stiffer
    # material at the first point appended) equals the eager calls
    P, V = pts[0]
    eager_mat = [float(_rr(jr.StandardLinearSolid(4e6, 0.25, 1.0), layer, method, geometry, P, V).value)]
    G0s = jnp.asarray([3e6] * len(pts) + [4e6])
    mats = jr.StandardLinearSolid(G0s, jnp.full(G0s.shape, 0.25), jnp.ones(G0s.shape))
    Ps, Vs = (jnp.asarray([p[k] for p in pts] + [pts[0][k]]) for k in (0, 1))
    vm = jax.jit(jax.vmap(lambda m, P, V: _rr(m, layer, method, geometry, P, V).value))(mats, Ps, Vs)
    np.testing.assert_allclose(np.asarray(vm), [*eager, *eager_mat], rtol=1e-10)

    def value(G0, tau, V, P):
        return _rr(jr.StandardLinearSolid(G0, tau, 1.0), layer, method, geometry, P, V).value

    # one jitted program for the scalar value and its gradient (w.r.t. G0, tau and the speed):
    # its value equals the eager call at every point
    value_and_grads = jax.jit(jax.value_and_grad(value, argnums=(0, 1, 2)))
    jitted = [value_and_grads(3e6, 0.25, V, P) for P, V in pts]
    np.testing.assert_allclose([float(v) for v, _ in jitted], eager, rtol=1e-10)
    # the gradient at the first point against central differences of eager calls, step 1e-5
    # relative: truncation ~1e-10, solver tolerance / step ~1e-5 (no contact-set change inside)
    grads = jitted[0][1]
    for i, x in enumerate((3e6, 0.25, V)):
        h = 1e-5 * x
        up, dn = [list((3e6, 0.25, V)) for _ in range(2)]
        up[i] += h
        dn[i] -= h
        fd = (float(value(*up, P)) - float(value(*dn, P))) / (2 * h)
        assert float(grads[i]) == pytest.approx(fd, rel=2e-4), (case, i)


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
@pytest.mark.parametrize("material", [HOT_PRONY5, pytest.param(PRONY5, marks=pytest.mark.slow),
                                      pytest.param(HOT, marks=pytest.mark.slow)],
                         ids=["prony5-at-temperature", "prony5", "at-temperature"])
@pytest.mark.parametrize("case", ["direct-sphere", "full-cylinder", "full-sphere", "SP"])
def test_every_material_in_every_method(material, case):
    """A 5-term Prony series and a temperature-shifted material work in every method, and a
    vmapped batch over speed equals the eager calls. The default suite runs both at once (the
    5-term series shifted by WLF: one compile per method instead of two); each alone is slow."""
    method, geometry, layer, loads = CASES[case]
    speeds = jnp.asarray([1e-3, 1e-1])
    eager = np.array([float(_rr(material, layer, method, geometry, loads[0], float(v)).value) for v in speeds])
    assert np.all(np.isfinite(eager) & (eager > 0))
    vm = jax.vmap(lambda v: _rr(material, layer, method, geometry, loads[0], v).value)(speeds)
    np.testing.assert_allclose(np.asarray(vm), eager, rtol=1e-10)


def test_autogrid_under_a_transformation_raises_with_what_to_do():
    layer = jr.Layer(0.03)
    for method in ("full", "SP", jr.DirectElastic()):
        with pytest.raises(ValueError, match=r"method.resolve\(material, layer, radius=.*or give a jr.FixedGrid"):
            jax.jit(lambda V, m=method: jr.rolling_resistance(SLS, layer, radius=R, load=100.0, speed=V,
                                                              method=m).value)(0.01)
    with pytest.raises(ValueError, match="sizes its grid"):
        jax.grad(lambda G0: jr.rolling_resistance(jr.StandardLinearSolid(G0, 0.25, 1.0), layer, radius=R, load=100.0,
                                                  speed=0.01, method="full").value)(3e6)
    # the direct method has no grid: fine under a transformation (throw=False: at the R_r peak
    # its estimated error against the full model flags the point)
    jax.jit(lambda V: jr.rolling_resistance(SLS, layer, radius=R, load=100.0, speed=V, method="direct",
                                            throw=False).value)(0.01)


def test_resolve_covers_the_envelope_and_matches_eager_autogrid():
    layer = jr.Layer(0.03)
    m = jr.Full().resolve(SLS, layer, radius=R, loads=[100.0], speeds=[0.01])
    assert isinstance(m.grid, jr.FixedGrid) and m.resolve(SLS, layer, radius=R, loads=[1.0], speeds=[1.0]) is m
    # an eager call with the AutoGrid resolves the same grid for the same point: the same number
    a = jr.rolling_resistance(SLS, layer, radius=R, load=100.0, speed=0.01, method="full")
    b = jr.rolling_resistance(SLS, layer, radius=R, load=100.0, speed=0.01, method=m)
    assert float(a.value) == float(b.value)
    # over an envelope: the finest cell, a window for the largest contact, an infinite layer by
    # default (a period long enough for the slowest memory with period="auto")
    env = jr.Full().resolve(SLS, layer, radius=R, loads=[10.0, 150.0], speeds=[1e-4, 0.1])
    assert env.grid.period is None
    env = jr.Full(grid=jr.AutoGrid(period="auto")).resolve(SLS, layer, radius=R, loads=[10.0, 150.0],
                                                           speeds=[1e-4, 0.1])
    r10, r150 = (float(jr.engines.contact_size.estimate_contact_size(SLS, layer, R, P)) for P in (10.0, 150.0))
    # the cell: the finest any point asks for, radius over the cells per radius the regime rule
    # asks for there (the slow speed's low zeta: 32 cells at 10 N, 48 at 150 N; the largest count
    # is not put on the smallest radius)
    need = {(V, r): jr.grids.sphere_cells_per_radius(*(float(x) for x in jr.grids.regime(SLS, V, r)))
            for V in (1e-4, 0.1) for r in (r10, r150)}
    assert (need[(1e-4, r10)], need[(1e-4, r150)]) == (32, 48)
    assert float(env.grid.spacing) == pytest.approx(min(r / c for (_, r), c in need.items()), rel=1e-12)
    assert env.grid.window * float(env.grid.spacing) >= 2 * 1.25 * r150
    assert env.grid.period[0] >= 20 * max(r150, 0.1 * 0.25)
    # slices: the line rule at the middle slice's load; direct: no grid, itself
    s = jr.Slices().resolve(SLS, layer, radius=R, loads=[100.0], speeds=[0.01])
    assert isinstance(s.grid, jr.FixedGrid) and s.grid.window % 2 == 0
    d = jr.Direct()
    assert d.resolve(SLS, layer, radius=R, loads=[100.0], speeds=[0.01]) is d


_BACKEND_COMPILES = [0]


def _count_compiles(event, duration, **kw):
    if event == "/jax/core/compile/backend_compile_duration":
        _BACKEND_COMPILES[0] += 1


# registered once for the session (jax.monitoring has no public way to unregister); it only counts
monitoring.register_event_duration_secs_listener(_count_compiles)


def _compiles(fn):
    """Number of XLA backend compilations while running ``fn``."""
    before = _BACKEND_COMPILES[0]
    fn()
    return _BACKEND_COMPILES[0] - before


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
def test_second_grid_call_with_new_values_compiles_nothing():
    layer = jr.Layer(0.03)
    method = jr.Full(grid=SPHERE_GRID)
    speeds = np.array([1e-3, 1e-2])

    def run(loads, G0=3e6, grid=None):
        m = method if grid is None else jr.Full(grid=grid)
        out = jr.rolling_resistance_grid(jr.StandardLinearSolid(G0, 0.25, 1.0), layer, radius=R, loads=loads,
                                         speeds=speeds, method=m)
        jax.block_until_ready(out.value)

    assert _compiles(lambda: run(np.array([50.0, 100.0]))) > 0  # the first call compiles
    assert _compiles(lambda: run(np.array([60.0, 110.0]))) == 0  # new loads
    assert _compiles(lambda: run(np.array([60.0, 110.0]), G0=2.5e6)) == 0  # new material values
    # a new cell size and period of the same shapes is a traced value too
    other = jr.FixedGrid(5e-4, 17, period=134 * 5e-4, n_terms=80)
    assert other.n_cells == SPHERE_GRID.n_cells and other.window == SPHERE_GRID.window
    assert _compiles(lambda: run(np.array([60.0, 110.0]), grid=other)) == 0
    # a single point: the second call with new values compiles nothing either
    one = lambda P, V: jax.block_until_ready(  # noqa: E731
        jr.rolling_resistance(SLS, layer, radius=R, load=P, speed=V, method=method, throw=False).value)
    one(80.0, 1e-3)
    assert _compiles(lambda: one(90.0, 2e-3)) == 0


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
def test_automatic_grid_resized_for_new_values_compiles_nothing():
    # an AutoGrid re-sized for a new modulus keeps its window (cells per radius fixed, one
    # load): the new cell size is a traced value, so the program is reused; the window once
    # came out a cell wider from round-off in ceil(1.25 r / (r / 12)) (G0 = 3.1 MPa: 33
    # instead of 31 cells), which recompiled everything
    layer = jr.Layer(0.03)
    for geometry, load in (("sphere", 100.0), ("cylinder", 1e4)):
        windows = {jr.Full().resolve(jr.StandardLinearSolid(G0, 0.25, 1.0), layer, radius=R, loads=[load],
                                     speeds=[0.01], geometry=geometry).grid.window
                   for G0 in np.linspace(2e6, 4e6, 41)}
        assert len(windows) == 1, (geometry, windows)
    method = jr.Full(grid=jr.AutoGrid(cells_per_radius=4))

    def run(G0):
        jax.block_until_ready(jr.rolling_resistance(jr.StandardLinearSolid(G0, 0.25, 1.0), layer, radius=R,
                                                    load=100.0, speed=0.01, method=method, throw=False).value)

    run(3.0e6)
    assert _compiles(lambda: run(3.1e6)) == 0


def test_method_objects_are_static_hashable_configuration():
    a = jr.Full(grid=jr.FixedGrid(2.5e-4, 55, period=0.2, n_terms=500), edge_smoothing=0.25)
    b = jr.Full(grid=jr.FixedGrid(2.5e-4, 55, period=0.2, n_terms=500), edge_smoothing=0.25)
    assert a == b and hash(a) == hash(b)
    assert jax.tree_util.tree_leaves(jr.Direct()) == []  # no traced configuration
    assert jr.methods.as_method("SP") == jr.Slices(algorithm="SP")
    assert jr.methods.as_method("full") == jr.Full() and jr.methods.as_method("direct") == jr.Direct()
    with pytest.raises(ValueError, match="unknown method"):
        jr.methods.as_method("exact")
    with pytest.raises(ValueError, match="FixedGrid.spacing must be positive"):
        jr.FixedGrid(-1e-3, 10)
    with pytest.raises(ValueError, match="FixedGrid.window must be an integer"):
        jr.FixedGrid(1e-3, 10.5)
    with pytest.raises(ValueError, match="FixedGrid.spacing must be a number"):
        jr.FixedGrid("1e-3", 10)
    with pytest.raises(ValueError, match="Full.grid must be"):
        jr.Full(grid=0.001)
    g = jr.FixedGrid(1e-3, 10, period=(0.05, 0.03))
    assert g.n_cells == (50, 30) and g.period == pytest.approx((0.05, 0.03))


def test_material_protocol():
    with pytest.raises(TypeError):
        jr.materials.AbstractMaterial()

    class Elastic(jr.materials.AbstractMaterial):
        """A user's material: elastic, G* = G (no dissipation)."""

        G: float

        def complex_modulus(self, omega):
            return jnp.zeros_like(jnp.asarray(omega, float)).astype(complex) + self.G

        def relaxation_modulus(self, t):
            return jnp.zeros_like(jnp.asarray(t, float)) + self.G

        def relaxed_modulus(self):
            return jnp.asarray(self.G)

        def glassy_modulus(self):
            return jnp.asarray(self.G)

        def longest_time(self):
            return jnp.asarray(0.0)

    res = jr.rolling_resistance(Elastic(3e6), jr.Layer(0.03), radius=R, load=100.0, speed=0.01, method="full")
    assert abs(float(res.value)) < 1e-10 * 100.0  # elastic: no rolling resistance
    # the characteristic time that grid rules need: retardation time, shifted with temperature
    a_T = float(jr.materials.shift_factor(jr.WLF(8.86, 101.6, 293.15), 303.15))
    assert float(HOT.longest_time()) == pytest.approx(0.25 * a_T, rel=1e-14)
    assert float(SLS.to_prony().longest_time()) == pytest.approx(0.25, rel=1e-14)
    with pytest.raises(ValueError, match="must be a jaxroll material"):
        jr.rolling_resistance("rubber", jr.Layer(0.03), radius=R, load=100.0, speed=0.01)


def test_throw_raises_with_the_reason_and_result_codes_survive_vmap():
    layer = jr.Layer(0.005)  # gamma > 0.9 at 150 N: outside Jaffar's thick-layer model
    # 0.3 mm/s: far below the R_r peak, where the direct method is valid at 20 N (near the peak its
    # estimated error against the full model flags it, tests/test_approximation.py)
    with pytest.raises(Exception, match="outside the range of validity of the stationary pressure model"):
        jr.rolling_resistance(SLS, layer, radius=R, load=150.0, speed=3e-4, method="direct")
    codes = jax.vmap(lambda P: jr.rolling_resistance(SLS, layer, radius=R, load=P, speed=3e-4, method="direct",
                                                     throw=False).result)(jnp.asarray([20.0, 150.0]))
    np.testing.assert_array_equal(np.asarray(codes), [jr.RESULTS.successful, jr.RESULTS.outside_pressure_model])
    with pytest.warns(jr.ValidityWarning, match="1 of 2 result"):  # eager throw=False warns
        res = jr.rolling_resistance_grid(SLS, layer, radius=R, loads=[20.0, 150.0], speeds=[3e-4], method="direct")
    assert list(res.reasons()[0]) == ["successful", jr.RESULTS.message(jr.RESULTS.outside_pressure_model)]
    assert len(set(jr.RESULTS.messages())) == len(jr.RESULTS)


def test_newton_root_returns_the_root_it_reached():
    # a Newton step of ~1e-16 from the root must not be replaced by a bisection of the bracket
    b1, b2 = jr.engines.contact_size.jaffar_coefficients(0.5)
    g0 = 1.0626585691826114

    def h(z):
        g = g0 * z
        return 3 * np.pi * z**3 - (3 * np.pi + 8 * g**3 * (b1 + 0.4 * b2 * g**2))

    z, info = newton_root(h, 1.0, lower=0.5, upper=10.0, tol=1e-14)
    roots = np.roots([-8 * g0**5 * 0.4 * b2, 0, 3 * np.pi - 8 * g0**3 * b1, 0, 0, -3 * np.pi])
    root = min(r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0.5)
    assert float(z) == pytest.approx(root, rel=1e-13) and bool(info.converged)
    # implicit derivative: dz/dg0 = -h_g0/h_z
    dz = jax.grad(lambda g: newton_root(lambda z: 3 * np.pi * z**3 - (3 * np.pi + 8 * (g * z) ** 3
                                                                       * (b1 + 0.4 * b2 * (g * z) ** 2)),
                                        1.0, lower=0.5, upper=10.0, tol=1e-14)[0])(g0)
    eps = 1e-6
    fd = (root_of(g0 + eps, b1, b2) - root_of(g0 - eps, b1, b2)) / (2 * eps)
    assert float(dz) == pytest.approx(fd, rel=1e-7)


def root_of(g0, b1, b2):
    roots = np.roots([-8 * g0**5 * 0.4 * b2, 0, 3 * np.pi - 8 * g0**3 * b1, 0, 0, -3 * np.pi])
    return min(r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0.5)


def test_geometry_type_and_names():
    # the one place that knows the geometries: members equal their names (so strings work
    # everywhere), units follow the contact type, anything else fails in one line
    assert jr.Geometry("sphere") == "sphere" and jr.Geometry.cylinder == "cylinder"
    assert (jr.Geometry.sphere.load_unit, jr.Geometry.cylinder.load_unit) == ("N", "N/m")
    assert (jr.Geometry.sphere.surface_dims, jr.Geometry.cylinder.surface_dims) == (2, 1)
    with pytest.raises(ValueError, match=r"^unknown geometry 'cone'; choose from \('sphere', 'cylinder'\)$"):
        jr.rolling_resistance(SLS, jr.Layer(0.01), radius=0.02, load=10.0, speed=0.01, geometry="cone",
                              method=jr.Direct())


@pytest.mark.filterwarnings("ignore:.*the approximate method's estimated error:jaxroll.ValidityWarning")
def test_solution_part_only_on_grid_models():
    # the direct method has no grid solution; a full model's carries the pressure that balances
    # the load (sum p dx = P: an exact property of the solved contact, independent of the value)
    layer = jr.Layer(0.01)
    direct = jr.rolling_resistance(SLS, layer, radius=0.02, load=1e4, speed=0.01, geometry="cylinder",
                                   method=jr.Direct(), throw=False)  # flagged near the peak; its fields under test
    assert direct.solution is None and direct.approximation is not None
    full = jr.rolling_resistance(SLS, layer, radius=0.02, load=1e4, speed=0.01, geometry="cylinder",
                                 method=jr.Full())
    sol = full.solution
    assert isinstance(sol, jr.GridSolution)
    dx = float(sol.grid[1] - sol.grid[0])
    assert float(jnp.sum(sol.pressure)) * dx == pytest.approx(1e4, rel=1e-8)
    assert float(sol.penetration) > 0 and int(sol.iterations) >= 1


def test_a_long_table_reports_its_progress_and_keeps_its_values():
    """``rolling_resistance_grid(progress=...)`` solves the table in blocks of speeds and reports
    after each: the callable sees every block (done, total) up to the whole table, and the values
    are the one-shot table's (the full 2D cylinder: each block's first speed from a cold start
    instead of the previous speed's solution, the same contact problems: equal to the solver
    tolerance, 1e-9 allowed; the direct method: no iteration, equal to rounding). ``True`` writes
    a line on stderr; traced inputs and a bad value raise."""
    import contextlib
    import io
    import warnings

    warnings.simplefilter("ignore", jr.ValidityWarning)  # the direct cylinder is not valid here: only plumbing
    mat, layer = jr.StandardLinearSolid(3e6, 0.25, 1.0), jr.Layer(0.03)
    speeds, loads = np.geomspace(1e-3, 1.0, 13), np.array([2e3, 5e3])
    kw = dict(radius=0.02, loads=loads, speeds=speeds, geometry="cylinder")
    for method, rtol in ((jr.Full(), 1e-9), (jr.Direct(), 1e-13)):
        whole = jr.rolling_resistance_grid(mat, layer, method=method, **kw)
        seen = []
        blocks = jr.rolling_resistance_grid(mat, layer, method=method, progress=lambda d, t: seen.append((d, t)), **kw)
        assert seen == [(d, 13) for d in (2, 4, 6, 8, 10, 12, 13)], seen
        assert blocks.value.shape == whole.value.shape == (13, 2)
        np.testing.assert_allclose(np.asarray(blocks.value), np.asarray(whole.value), rtol=rtol)
        np.testing.assert_array_equal(np.asarray(blocks.result), np.asarray(whole.result))
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        jr.rolling_resistance_grid(mat, layer, method=jr.Direct(), progress=True, **kw)
    assert "13/13 speeds" in err.getvalue()
    with pytest.raises(ValueError, match="progress"):
        jr.rolling_resistance_grid(mat, layer, method=jr.Direct(), progress="yes", **kw)
    with pytest.raises(ValueError, match="concrete"):
        jax.jit(lambda G: jr.rolling_resistance_grid(jr.StandardLinearSolid(G, 0.25, 1.0), layer,
                                                     method=jr.Direct(), progress=True, **kw).value)(3e6)
