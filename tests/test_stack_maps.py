"""Temperature x speed maps of bonded ply stacks (jr.resistance_map, maps.map_points and
jr.conveyor.conveyor_map with a jr.Stack): every ply of a temperature-shifted material, and the
base, shifted to the point's temperature by its own law.

Oracles: the single layer of the summed thickness (a stack of identical plies, 1e-10 in R_r),
the front door (jr.rolling_resistance) on the stack built by hand at the point's temperature
(1e-10), and central differences of the map in T and in the cover thickness.

Compilation is the cost: the default tests run the direct cylinder method on 2 x 2 maps of two
stack structures (one map program each, reused by every call of the same shapes; the central
differences are maps of the same shape), the full 2D model under ``-m slow``.
"""

import warnings

import equinox as eqx
import numpy as np
import pytest

import jaxroll as jr
from jaxroll import conveyor
from jaxroll.maps import map_points
from jaxroll.result import ValidityWarning

WLF = jr.WLF(C1=8.86, C2=101.6, T_ref=293.15)
#: the carcass's own law (a different compound): the map must shift it by this, not by WLF
ARR = jr.Arrhenius(activation_energy=1.2e5, T_ref=300.0)
COVER = jr.StandardLinearSolid(G0=3e6, tau=2e-3, f=1.0)
CARCASS = jr.StandardLinearSolid(G0=2e7, tau=5e-4, f=0.5)
BASE = jr.StandardLinearSolid(G0=1e8, tau=1e-4, f=0.2)
R, LOAD, H1, H2 = 0.08, 2e3, 0.005, 0.003
TEMPS, SPEEDS = np.array([283.15, 303.15]), np.array([0.1, 1.0])
KW = dict(radius=R, load=LOAD, geometry="cylinder", method="direct")


def _mixed(H=H1, base=False):
    """Cover (WLF) on a carcass of its own law (Arrhenius) stored at 250 K, on a rigid base or
    (``base``) on a viscoelastic half-space of a third compound of the cover's law stored at
    400 K: the map replaces the stored temperatures by its own. On a rigid base it has the tree
    structure of the identical-ply stack below, so the default tests share one map program."""
    plies = [jr.Ply(COVER, H), jr.Ply(jr.at_temperature(CARCASS, ARR, 250.0), H2)]
    return jr.Stack(plies, base=jr.HalfSpace(jr.at_temperature(BASE, WLF, 400.0)) if base else "rigid")


def _by_hand(T, H=H1, base=False):
    """The stack of :func:`_mixed` at temperature ``T``, built independently of the map code."""
    plies = [jr.Ply(jr.at_temperature(COVER, WLF, T), H), jr.Ply(jr.at_temperature(CARCASS, ARR, T), H2)]
    return jr.Stack(plies, base=jr.HalfSpace(jr.at_temperature(BASE, WLF, T)) if base else "rigid")


def _front_door(stack, V, **kw):
    with warnings.catch_warnings():  # points the direct method flags: compared all the same
        warnings.simplefilter("ignore", ValidityWarning)
        return jr.rolling_resistance(stack, speed=V, throw=False, **{**KW, **kw})


def test_identical_plies_map_equals_the_single_layer_of_summed_thickness():
    """Two plies of the cover compound (the lower one stored at another temperature) on a rigid
    base are the cover of thickness H1 + H2: values, dR/dT and dR/dH (the top ply's thickness
    moves the total) to 1e-10 (the stack's composition against the closed form, ~1e-13 in T)."""
    st = jr.Stack([jr.Ply(COVER, H1), jr.Ply(jr.at_temperature(COVER, WLF, 250.0), H2)])
    single = jr.resistance_map(COVER, WLF, jr.Layer(H1 + H2), temperatures=TEMPS, speeds=SPEEDS, **KW)
    two = jr.resistance_map(COVER, WLF, st, temperatures=TEMPS, speeds=SPEEDS, **KW)
    for a, b in ((two.value, single.value), (two.dR_dT, single.dR_dT), (two.dR_dH, single.dR_dH)):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=0)
    np.testing.assert_array_equal(two.result, single.result)


def _check_front_door(base, rtol, **kw):
    """Each point of a cover / own-law carcass map equals jr.rolling_resistance on the stack
    shifted by hand; the stack given alone (layer=None) is the same map; the carcass's own
    temperature matters (the map does not leave it as stored)."""
    m = jr.resistance_map(COVER, WLF, _mixed(base=base), temperatures=TEMPS, speeds=SPEEDS, **{**KW, **kw})
    alone = jr.resistance_map(_mixed(base=base), WLF, None, temperatures=TEMPS, speeds=SPEEDS, **{**KW, **kw})
    np.testing.assert_array_equal(alone.value, m.value)
    for i, T in enumerate(TEMPS):
        for j, V in enumerate(SPEEDS):
            ref = _front_door(_by_hand(T, base=base), V, **kw)
            assert m.value[i, j] == pytest.approx(float(ref.value), rel=rtol)
            assert m.result[i, j] == int(ref.result)
    stored = _mixed(base=base)
    stored = jr.Stack([jr.Ply(jr.at_temperature(COVER, WLF, TEMPS[0]), H1), *stored.plies[1:]], base=stored.base)
    assert abs(float(_front_door(stored, SPEEDS[0], **kw).value) / m.value[0, 0] - 1) > 1e-3


def test_stack_map_points_equal_the_front_door_at_their_temperature():
    """Direct method, rigid base: 1e-10 (one program against another on the same arithmetic)."""
    _check_front_door(False, 1e-10)


@pytest.mark.slow
def test_stack_map_on_a_viscoelastic_half_space_shifts_the_base():
    """As above on a viscoelastic half-space base of its own stored temperature (1e-10)."""
    _check_front_door(True, 1e-10)


def test_stack_map_derivatives_match_central_differences():
    """dR/dT (every ply and the base shifted) and dR/dH_cover against central differences of maps
    of the same shape (one program): T +- 0.01 K, H +- 1e-7 m; truncation O(h^2) and round-off
    ~1e-16/h of R_r: 1e-6 relative."""
    T0, V0 = 293.15, 0.3
    hT, hH = 0.01, 1e-7
    m = jr.resistance_map(COVER, WLF, _mixed(), temperatures=[T0, T0 + hT], speeds=[V0, 2 * V0], **KW)
    lo = jr.resistance_map(COVER, WLF, _mixed(), temperatures=[T0 - hT, T0 + 2 * hT], speeds=[V0, 2 * V0], **KW)
    fd_T = (m.value[1, 0] - lo.value[0, 0]) / (2 * hT)
    assert m.dR_dT[0, 0] == pytest.approx(fd_T, rel=1e-6)
    up = jr.resistance_map(COVER, WLF, _mixed(H1 + hH), temperatures=[T0, T0 + hT], speeds=[V0, 2 * V0], **KW)
    dn = jr.resistance_map(COVER, WLF, _mixed(H1 - hH), temperatures=[T0, T0 + hT], speeds=[V0, 2 * V0], **KW)
    fd_H = (up.value - dn.value) / (2 * hH)
    np.testing.assert_allclose(m.dR_dH, fd_H, rtol=1e-6)


def test_a_stack_whose_top_ply_is_another_compound_is_refused():
    from jaxroll.maps import _check_cover

    _check_cover(COVER, WLF, jr.Stack([jr.Ply(jr.at_temperature(COVER, WLF, 330.0), H1)]))  # any temperature
    with pytest.raises(ValueError, match="top ply's material"):  # another law
        _check_cover(COVER, ARR, jr.Stack([jr.Ply(jr.at_temperature(COVER, WLF, 330.0), H1)]))
    st = jr.Stack([jr.Ply(CARCASS, H1), jr.Ply(COVER, H2)])
    with pytest.raises(ValueError, match="top ply's material"):
        map_points(COVER, WLF, st, radius=R, loads=[LOAD], temperatures=[293.15], speeds=[0.1], geometry="cylinder",
                   method="direct")


# ---------------------------------------------------------------------------------- full model

GRID = jr.Full(grid=jr.FixedGrid(2.5e-4, 128))


@pytest.mark.slow
def test_full_model_stack_map_equals_single_layer_front_door_and_differences():
    """The full 2D model (the conveyor's default) on a fixed grid: identical plies = the single
    layer's map (both maps warm-start along the reduced speed: solver tolerance, 1e-8); a mixed
    stack's points = the front door (1e-8) and its derivatives = central differences (1e-4: the
    solver tolerance over the step and the implicit derivative of the contact set)."""
    kw = dict(KW, method=GRID)
    st = jr.Stack([jr.Ply(COVER, H1), jr.Ply(jr.at_temperature(COVER, WLF, 250.0), H2)])
    single = jr.resistance_map(COVER, WLF, jr.Layer(H1 + H2), temperatures=TEMPS, speeds=SPEEDS, **kw)
    two = jr.resistance_map(COVER, WLF, st, temperatures=TEMPS, speeds=SPEEDS, **kw)
    np.testing.assert_allclose(two.value, single.value, rtol=1e-8)
    np.testing.assert_allclose(two.dR_dT, single.dR_dT, rtol=1e-6)
    m = jr.resistance_map(COVER, WLF, _mixed(), temperatures=TEMPS, speeds=SPEEDS, **kw)
    for i, T in enumerate(TEMPS):
        for j, V in enumerate(SPEEDS):
            ref = _front_door(_by_hand(T), V, method=GRID)
            assert m.value[i, j] == pytest.approx(float(ref.value), rel=1e-8)
    hT, hH = 0.01, 1e-7
    up = jr.resistance_map(COVER, WLF, _mixed(), temperatures=TEMPS + hT, speeds=SPEEDS, **kw)
    dn = jr.resistance_map(COVER, WLF, _mixed(), temperatures=TEMPS - hT, speeds=SPEEDS, **kw)
    np.testing.assert_allclose(m.dR_dT, (up.value - dn.value) / (2 * hT), rtol=1e-4)
    up = jr.resistance_map(COVER, WLF, _mixed(H1 + hH), temperatures=TEMPS, speeds=SPEEDS, **kw)
    dn = jr.resistance_map(COVER, WLF, _mixed(H1 - hH), temperatures=TEMPS, speeds=SPEEDS, **kw)
    np.testing.assert_allclose(m.dR_dH, (up.value - dn.value) / (2 * hH), rtol=1e-4)


@pytest.mark.slow
def test_conveyor_map_of_a_belt_with_carcass_equals_indentation_resistance():
    """conveyor_map with a belt_stack (cover + own-law carcass): each point equals
    indentation_resistance on the stack at that temperature (1e-8, full 2D model, fixed grid)."""
    belt = conveyor.belt_stack(COVER, H1, [jr.Ply(jr.at_temperature(CARCASS, ARR, 250.0), H2, nu=0.45)])
    cm = conveyor.conveyor_map(COVER, WLF, belt, diameter=2 * R, line_loads=[LOAD], temperatures=TEMPS,
                               speeds=SPEEDS[:1], method=GRID)
    for i, T in enumerate(TEMPS):
        at_T = conveyor.belt_stack(jr.at_temperature(COVER, WLF, T), H1,
                                   [jr.Ply(jr.at_temperature(CARCASS, ARR, T), H2, nu=0.45)])
        with warnings.catch_warnings():  # validity is compared, not required
            warnings.simplefilter("ignore", ValidityWarning)
            ref = conveyor.indentation_resistance(at_T, diameter=2 * R, line_load=LOAD, speed=SPEEDS[0], method=GRID,
                                                  throw=False)
        assert cm.result[i, 0, 0] == int(ref.rolling.result)
        assert cm.per_width[i, 0, 0] == pytest.approx(float(ref.per_width), rel=1e-8)


# ------------------------------------------------------------------ host-side checks of a stack

def test_concrete_stack_checks_and_equivalent_thickness_on_the_host():
    """The front doors check a concrete stack on the host with NumPy only (no device work per
    call): a ply made invalid behind the constructor's back still raises; the equivalent
    thickness computed on the host equals the traced one (the same formula, float64)."""
    import jax
    import jax.numpy as jnp

    st = _mixed(base=True)
    assert st.checked() is st
    bad = eqx.tree_at(lambda s: s.plies[1].H, st, jnp.asarray(-1e-3))
    with pytest.raises(ValueError, match="Ply.H"):
        bad.checked()
    stiff = jr.Stack(st.plies, base=jr.HalfSpace(jr.StandardLinearSolid(G0=1e9, tau=1e-4, f=0.2)))
    for s in (st, stiff, _mixed()):
        traced = jax.jit(lambda s: s.H)(s)
        assert float(s.H) == pytest.approx(float(traced), rel=1e-15) or (np.isinf(s.H) and np.isinf(traced))


# ------------------------------------------------------------------ fitting the cover of a stack

def test_fit_parameters_of_a_stack_are_the_cover_ply():
    """Reduced copy of the fit below (no compilation): the free parameters of a fit with a stack
    are the top ply's material fields and thickness, set in place by the parameter map, and the
    front doors receive the stack with the fitted material on top."""
    from jaxroll.identify.fit import _Params, _with_cover

    start = jr.StandardLinearSolid(G0=2e6, tau=4e-3, f=0.7)
    st = jr.Stack([jr.Ply(COVER, H1), jr.Ply(CARCASS, H2)], base=jr.HalfSpace(BASE))
    params = _Params.of((start, st, None), ("G0", "H"), None)
    mat, lay, _ = params.build(np.log(np.array([5e6, 0.004])), (start, st, None))
    assert float(mat.G0) == pytest.approx(5e6, rel=1e-14) and float(lay.plies[0].H) == pytest.approx(0.004, rel=1e-14)
    assert float(lay.plies[1].H) == H2 and bool(eqx.tree_equal(lay.base, st.base))
    top, on = _with_cover(mat, lay)
    assert on.material is top and float(on.plies[0].material.G0) == pytest.approx(5e6, rel=1e-14)
    assert bool(eqx.tree_equal(on.plies[1], lay.plies[1]))


@pytest.mark.slow
def test_fit_material_recovers_the_cover_of_a_stack():
    """fit_material with a jr.Stack fits the top ply's material with the carcass fixed: noise-free
    rolling data of the direct cylinder method on cover / carcass / viscoelastic base come back
    to the truth (1e-6 relative: the least-squares tolerance on exact data of the same model),
    and FitResult.layer carries the fitted cover on top."""
    from jaxroll.identify.fit import RollingData, fit_material

    truth = jr.StandardLinearSolid(G0=3e6, tau=2e-3, f=1.0)
    carcass = jr.Ply(CARCASS, H2)
    st = jr.Stack([jr.Ply(truth, H1), carcass], base=jr.HalfSpace(BASE))
    V = np.geomspace(0.05, 5.0, 5)
    P = np.full(V.shape, LOAD)
    y = np.array([float(_front_door(st, v).value) for v in V])
    start = jr.StandardLinearSolid(G0=2e6, tau=4e-3, f=0.7)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # relative weights: no sigma (the fit's own note)
        fit = fit_material(RollingData(V, P, y), initial=start, layer=jr.Stack([jr.Ply(start, H1), carcass],
                                                                               base=jr.HalfSpace(BASE)),
                           radius=R, geometry="cylinder", method="direct")
    for name in ("G0", "tau", "f"):
        assert float(getattr(fit.material, name)) == pytest.approx(float(getattr(truth, name)), rel=1e-6)
    assert bool(eqx.tree_equal(fit.layer.plies[0].material, fit.material))
    assert bool(eqx.tree_equal(fit.layer.plies[1], carcass))
