"""Batched full models (``Full.evaluate_points``, and ``jr.resistance_map`` through it): points
solved one after the other in a ``lax.scan``, each warm-started from the previous point, must
give the numbers of the per-point eager front door to the solver tolerance, and implicit
per-point derivatives that match central finite differences.

Oracle: ``jr.rolling_resistance`` at each point alone (the solver's own start). The contact
problem has one solution per point; a warm start changes only the iterations, so the values
agree to the solver tolerance (``tol = 1e-10`` on the scaled residual, linear solves to
``1e-13``): asserted 1e-10 relative.
"""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jr

from _cases import PAPER, RADIUS, central_difference
from _cases import compilations as _compilations

from jaxroll.rolling import _validated

#: Coarse infinite-layer grids: sphere 0.5 mm cells, 29-cell window (~6-12 cells per contact
#: radius at 20..150 N); cylinder 0.1 mm cells, 96-cell window (~10-30 cells per half-width).
SPHERE = jr.Full(grid=jr.FixedGrid(5e-4, 29))
CYLINDER = jr.Full(grid=jr.FixedGrid(1e-4, 96))
CASES = {"sphere": (SPHERE, np.array([20.0, 150.0, 60.0, 100.0, 40.0, 150.0])),
         "cylinder": (CYLINDER, np.array([2e3, 1e4, 5e3, 8e3, 3e3, 1e4]))}
#: Points whose speed, load and layer thickness all vary, in an order with unlike neighbours
#: (a speed jump of four decades, the load falling and rising).
SPEEDS = np.array([1e-2, 1e-4, 1.0, 3e-2, 1e-3, 1e-2])
THICKNESSES = np.array([0.005, 0.03, 0.01, 0.005, 0.02, 0.03])


@functools.partial(jax.jit, static_argnames=("geometry", "sorted_by_speed"))
def _points(material, H, P, V, *, geometry, sorted_by_speed):
    method = CASES[geometry][0]
    order = jnp.argsort(V) if sorted_by_speed else None
    out = method.evaluate_points(material, jr.Layer(H), RADIUS, P, V, geometry,
                                 axes=(None, 0, None, 0, 0), order=order)
    # evaluate_points is an engine call, like evaluate: the front door's shared checks (error
    # bound, contact size, sign) are applied per point here, as jr.rolling_resistance applies them
    checked = jax.vmap(lambda res, h, p, v: _validated(method, material, jr.Layer(h), res, RADIUS, p, v, geometry))(
        out, H, P, V)
    return out.value, checked.result, out.solution.iterations


def _eager(material, H, P, V, geometry):
    return jr.rolling_resistance(material, jr.Layer(H), radius=RADIUS, load=P, speed=V, geometry=geometry,
                                 method=CASES[geometry][0], throw=False)


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
@pytest.mark.parametrize("sorted_by_speed", [False, True], ids=["given-order", "sorted"])
@pytest.mark.parametrize("geometry", ["sphere", "cylinder"])
def test_points_equal_eager_single_points(geometry, sorted_by_speed):
    loads = CASES[geometry][1]
    value, result, _ = _points(PAPER, THICKNESSES, loads, SPEEDS, geometry=geometry,
                                        sorted_by_speed=sorted_by_speed)
    for i, (H, P, V) in enumerate(zip(THICKNESSES, loads, SPEEDS)):
        one = _eager(PAPER, H, P, V, geometry)
        assert abs(float(value[i]) / float(one.value) - 1) < 1e-10, (i, float(value[i]), float(one.value))
        assert int(result[i]) == int(one.result), i


@functools.partial(jax.jit, static_argnames=("geometry", "with_grad"))
def _vmapped_front_door(G0, H, P, V, *, geometry, with_grad):
    """``jax.vmap`` of the front door over (H, P, V): the full models' batching rule
    (``Full.evaluate``) solves the lanes one after the other, warm-started, not in lockstep."""
    def one(G0, h, p, v):
        mat = jr.StandardLinearSolid(G0, PAPER.tau, PAPER.f)
        return jr.rolling_resistance(mat, jr.Layer(h), radius=RADIUS, load=p, speed=v, geometry=geometry,
                                     method=CASES[geometry][0], throw=False)
    res = jax.vmap(one, in_axes=(None, 0, 0, 0))(G0, H, P, V)
    if not with_grad:
        return res.value, res.result, None
    total = lambda g: jnp.sum(jax.vmap(one, in_axes=(None, 0, 0, 0))(g, H, P, V).value)  # noqa: E731
    return res.value, res.result, jax.grad(total)(G0)


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
@pytest.mark.parametrize("geometry", ["sphere", "cylinder"])
def test_vmap_of_the_front_door_equals_eager_single_points(geometry):
    """``jax.jit(jax.vmap(jr.rolling_resistance))`` of the full models over points with unlike
    neighbours: each lane the eager point's value and code (1e-10: the solver tolerance, as
    above), and ``jax.grad`` of the sum over the lanes w.r.t. the shared G0 the sum of the
    single points' gradients (the cylinder's first three points; 1e-8: each is an implicit
    derivative of a solution converged to 1e-10; the single-point gradient is checked against
    central differences in test_points_gradients_are_implicit_per_point)."""
    loads = CASES[geometry][1]
    value, result, _ = _vmapped_front_door(jnp.asarray(PAPER.G0), THICKNESSES, loads, SPEEDS, geometry=geometry,
                                           with_grad=False)
    for i, (H, P, V) in enumerate(zip(THICKNESSES, loads, SPEEDS)):
        one = _eager(PAPER, H, P, V, geometry)
        assert abs(float(value[i]) / float(one.value) - 1) < 1e-10, (i, float(value[i]), float(one.value))
        assert int(result[i]) == int(one.result), i

    def single_grad(H, P, V):
        return jax.grad(lambda g: _eager(jr.StandardLinearSolid(g, PAPER.tau, PAPER.f), H, P, V, geometry).value)(
            jnp.asarray(PAPER.G0))

    if geometry == "sphere":
        return
    H, P, V = THICKNESSES[:3], loads[:3], SPEEDS[:3]
    grad = _vmapped_front_door(jnp.asarray(PAPER.G0), H, P, V, geometry=geometry, with_grad=True)[2]
    expected = sum(float(single_grad(*x)) for x in zip(H, P, V))
    np.testing.assert_allclose(float(grad), expected, rtol=1e-8)


# the coarse sphere grid's error bound flags a low-zeta point (truncation_too_large): the
# gradient comparison is about the discrete model, whatever its resolution
@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
@pytest.mark.parametrize("geometry", ["sphere", "cylinder"])
def test_points_gradients_are_implicit_per_point(geometry):
    """d(sum of values)/dG0 (shared) and /dH_i (per point) through the scan against central
    differences of the eager front door (step 1e-5 relative: truncation ~1e-10, solver noise
    ~1e-10/1e-5; the contact set does not change over the step), 1e-5 relative."""
    loads = CASES[geometry][1][:3]
    V, H = SPEEDS[:3], THICKNESSES[:3]

    def total(G0, H):
        mat = jr.StandardLinearSolid(G0, PAPER.tau, PAPER.f)
        return jnp.sum(_points(mat, H, loads, V, geometry=geometry, sorted_by_speed=True)[0])

    g_G, g_H = jax.grad(total, argnums=(0, 1))(jnp.asarray(PAPER.G0), jnp.asarray(H))

    def eager_sum(p):
        mat = jr.StandardLinearSolid(p["G0"], PAPER.tau, PAPER.f)
        return sum(float(_eager(mat, h, P, v, geometry).value) for h, P, v in zip(H, loads, V))

    fd = central_difference(eager_sum, {"G0": float(PAPER.G0)}, "G0")
    np.testing.assert_allclose(float(g_G), fd, rtol=1e-5)
    # point 0, not 1: point 1 (V tau/a ~ 4e-3) lies in the band where the value blends the two
    # forms of R_r by the regime, whose slope d ln J''/d ln omega loses ~1e-9 to cancellation
    # there, so a 1e-5 step's central difference of the value is off by ~1e-3 (measured; the
    # forward-mode derivative agrees with steps of 1e-3..1e-4 to 5e-5)
    i = 0
    fd_H = central_difference(lambda p: float(_eager(PAPER, p["H"], loads[i], V[i], geometry).value),
                              {"H": float(H[i])}, "H")
    np.testing.assert_allclose(float(g_H[i]), fd_H, rtol=1e-5)


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
def test_map_of_the_full_model_equals_the_front_door():
    """A 3 x 3 map of the full 2D model (points warm-started in the order of V a_T): each value is
    the front door's at that temperature and speed (1e-10), dR/dT a central difference of it
    (step 0.01 K: truncation ~1e-9 relative)."""
    mat, wlf = PAPER.to_prony(), jr.WLF(8.86, 101.6, 293.15)
    Ts, Vs = np.array([283.15, 293.15, 303.15]), np.array([1e-3, 1e-2, 1e-1])
    m = jr.resistance_map(mat, wlf, jr.Layer(0.01), radius=0.01, load=500.0, temperatures=Ts, speeds=Vs,
                          geometry="cylinder", method=jr.Full(grid=jr.FixedGrid(4e-5, 64)))

    def rr(T, V):
        return float(jr.rolling_resistance(jr.at_temperature(mat, wlf, T), jr.Layer(0.01), radius=0.01, load=500.0,
                                           speed=V, geometry="cylinder", method=jr.Full(grid=jr.FixedGrid(4e-5, 64)),
                                           throw=False).value)

    for i, T in enumerate(Ts):
        for j, V in enumerate(Vs):
            assert abs(m.value[i, j] / rr(T, V) - 1) < 1e-10, (T, V)
    fd = (rr(Ts[1] + 0.01, Vs[1]) - rr(Ts[1] - 0.01, Vs[1])) / 0.02
    np.testing.assert_allclose(m.dR_dT[1, 1], fd, rtol=1e-5)


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
def test_map_derivatives_by_the_adjoint_match_central_differences():
    """The map's derivatives come from one adjoint solve per point shared by every direction
    (``evaluate_points(adjoint=True)``): dR/dT, dR/dH and the derivative along a material
    direction (the Prony moduli G_i up 10 %) at the middle of three points of the full 2D model,
    each against a central difference of the front door (relative step 1e-5 or 0.01 K:
    truncation ~1e-9, solver noise ~tol/step = 1e-5 of the derivative's scale at worst; 1e-5
    asserted, as the map test above)."""
    from jaxroll.maps import map_points

    mat, wlf, method = PAPER.to_prony(), jr.WLF(8.86, 101.6, 293.15), jr.Full(grid=jr.FixedGrid(4e-5, 64))
    direction = jax.tree_util.tree_map(lambda x: 0.0 * x, mat)
    direction = eqx.tree_at(lambda m: m.G, direction, 0.1 * mat.G)
    T, V = np.full(3, 293.15), np.array([1e-3, 1e-2, 1e-1])
    out = map_points(mat, wlf, jr.Layer(0.01), radius=0.01, loads=np.full(3, 500.0), temperatures=T, speeds=V,
                     geometry="cylinder", method=method, directions=(direction,))

    def rr(T=293.15, H=0.01, s=0.0):
        m = eqx.tree_at(lambda m: m.G, mat, mat.G * (1 + 0.1 * s))
        return float(jr.rolling_resistance(jr.at_temperature(m, wlf, T), jr.Layer(H), radius=0.01, load=500.0,
                                           speed=V[1], geometry="cylinder", method=method, throw=False).value)

    np.testing.assert_allclose(out.dR_dT[1], (rr(T=293.16) - rr(T=293.14)) / 0.02, rtol=1e-5)
    np.testing.assert_allclose(out.dR_dH[1], (rr(H=0.01 + 1e-7) - rr(H=0.01 - 1e-7)) / 2e-7, rtol=1e-5)
    np.testing.assert_allclose(out.dR_ddirection[0, 1], (rr(s=1e-5) - rr(s=-1e-5)) / 2e-5, rtol=1e-5)


def test_fit_central_difference_jacobian_runs_the_tables_one_after_the_other():
    """The fit's central-difference Jacobian of a full model (its 2k + 1 warm-started tables in a
    lax.map) against its forward-mode Jacobian (implicit per point): step 1e-4 in the
    log-parameters, truncation ~1e-8 relative, solver noise ~tol/step = 1e-6; 1e-5 asserted."""
    from jaxroll.identify.fit import RollingData, _data_arrays, _Params, _Problem, _residuals_and_jacobian_jit

    method = jr.Full(grid=jr.FixedGrid(5e-4, 29), edge_smoothing=0.5)
    V, P = (a.ravel() for a in np.meshgrid([1e-3, 1e-2, 1e-1], [60.0, 120.0]))
    data = _data_arrays(RollingData(V, P, np.ones(V.size)), None, method)
    model = (PAPER, jr.Layer(0.03), None)
    params = _Params.of(model, ("G0", "tau", "f"), None)
    logp = jnp.log(jnp.asarray([3.3e6, 0.2, 1.2]))
    _, J_ad = _residuals_and_jacobian_jit(logp, model, data, _Problem(params, RADIUS, "sphere", method, None))
    _, J_fd = _residuals_and_jacobian_jit(logp, model, data, _Problem(params, RADIUS, "sphere", method, 1e-4))
    np.testing.assert_allclose(np.asarray(J_fd), np.asarray(J_ad), rtol=1e-5, atol=1e-5 * float(jnp.max(jnp.abs(J_ad))))


def test_points_need_one_batch_length():
    """axes other than 0/None, or batched arguments of different lengths, raise before tracing."""
    with pytest.raises(ValueError, match="0 \\(batched\\) or None"):
        SPHERE.evaluate_points(PAPER, jr.Layer(0.03), RADIUS, jnp.ones(3), jnp.ones(3), "sphere",
                               axes=(None, None, None, 1, 0))
    with pytest.raises(ValueError, match="one common leading length"):
        SPHERE.evaluate_points(PAPER, jr.Layer(0.03), RADIUS, jnp.ones(3), jnp.ones(4), "sphere",
                               axes=(None, None, None, 0, 0))




@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")
def test_map_per_regime_buckets_equal_the_front_door_and_reuse_their_programs(caplog):
    """A 2 x 2 map of the full 2D model with the automatic grid whose points ask for two grid
    classes (12 and 25 cells per half-width: zeta >= 0.1 and 0.01-0.1): each class is solved on
    its own grid, so each value is the per-point front door's (1e-10, the solver tolerance).
    A map of a material 2 % stiffer (every grid re-sized: new cell sizes, same classes and
    windows) compiles nothing, nor does the front door re-sized the same way."""
    from jaxroll.buckets import _PROGRAMS

    wlf = jr.WLF(8.86, 101.6, 293.15)
    Ts, Vs = np.array([263.15, 293.15]), np.array([1e-4, 1e-2])  # classes 12, 12 / 25, 12
    layer, kw = jr.Layer(0.01), dict(radius=0.01, load=500.0)

    def the_map(G0):
        mat = jr.StandardLinearSolid(G0, PAPER.tau, PAPER.f).to_prony()
        return jr.resistance_map(mat, wlf, layer, temperatures=Ts, speeds=Vs, geometry="cylinder", **kw)

    def front_door(G0, T, V):
        mat = jr.at_temperature(jr.StandardLinearSolid(G0, PAPER.tau, PAPER.f).to_prony(), wlf, T)
        return jr.rolling_resistance(mat, layer, speed=V, geometry="cylinder", throw=False, **kw)

    # an earlier test of this worker (another file's cylinder map) may have compiled a program of
    # the same class and shape: start from an empty cache, so the count is this map's own
    _PROGRAMS.clear()
    n_programs = len(_PROGRAMS)
    m = the_map(PAPER.G0)
    assert len(_PROGRAMS) - n_programs == 2  # two classes, one program each
    for i, T in enumerate(Ts):
        for j, V in enumerate(Vs):
            one = front_door(PAPER.G0, T, V)
            assert abs(m.value[i, j] / float(one.value) - 1) < 1e-10, (T, V)
            assert m.result[i, j] == int(one.result) == 0
    stiffer = float(1.02 * PAPER.G0)
    assert _compilations(caplog, lambda: the_map(stiffer)) == 0
    assert _compilations(caplog, lambda: front_door(stiffer, Ts[0], Vs[0])) == 0


def test_buckets_are_the_per_point_grids_of_the_quick_reference():
    """The grid of each bucket is the one the front door's rule resolves for each of its points
    alone (``Full().resolve`` on that load and speed: the independent path through
    ``AutoGrid.sphere``), for the quick reproduction's H = 5 mm case (7 speeds x 3 loads); and the
    quick reference falls back to its fixed grid where the rule's windows exceed
    ``MAX_RULE_WINDOW`` (H = 10 um), before solving anything."""
    from jaxroll.apps import reproduce as rp

    s, case = rp.QUICK, rp.CASES["H5mm"]
    speeds = np.geomspace(*s.speed_range, s.n_speeds)
    P, V = (a.ravel() for a in np.meshgrid(np.linspace(*case.loads, s.n_loads), speeds, indexing="ij"))
    layer = jr.Layer(case.H)
    buckets = jr.Full().grid.buckets(rp._material(), layer, case.R, P, V, "sphere")
    assert sorted(np.concatenate([i for _, i in buckets]).tolist()) == list(range(P.size))
    assert len({g.window for g, _ in buckets}) >= 2  # several classes over four decades of speed
    for grid, idx in buckets:
        for i in idx:
            own = jr.Full().resolve(rp._material(), layer, radius=case.R, loads=[P[i]], speeds=[V[i]]).grid
            assert own.window == grid.window and abs(own.spacing / grid.spacing - 1) < 1e-12, (P[i], V[i])
    tiny = rp.CASES["H10um"]
    assert rp._run_rule_reference(tiny, np.linspace(*tiny.loads, 2), speeds[:2]) is None
