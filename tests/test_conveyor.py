"""The conveyor front end (jaxroll.conveyor): idler loads, the bookkeeping per idler and per
flight, the thin-cover limit against the classical viscoelastic Winkler model, scaling laws,
and the map's derivatives against central differences.

Compilation is most of the cost: every full-model evaluation here goes through one program,
``rolling_resistance_grid`` with 2 speeds x 2 loads on one :data:`GRID` (window static, cell size
traced) with the material ``jr.at_temperature(SLS, WLF, T)`` on a compressible cover, so the
module compiles it once (plus the map program once).
"""

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import quad

import jaxroll as jr
from _oracles import winkler_sls
from jaxroll import conveyor

# ------------------------------------------------------------------ shared cases

#: a thin compressible cover: 1 mm, nu = 0.3, under a large roll (R = 0.5 m) loaded so that the
#: relaxed Winkler half-width is a0 = 15 H (the regime where the layer is a Winkler bed)
R, H, NU, G0, TAU, F = 0.5, 1e-3, 0.3, 2e6, 0.01, 1.0
WLF = jr.WLF(C1=8.86, C2=101.6, T_ref=293.15)
K0 = 2 * G0 * (1 - NU) / ((1 - 2 * NU) * H)
A0 = 15 * H
P0 = 2 / 3 * K0 * A0**3 / R          # Winkler: P = (2/3) k a^3 / R
#: 30 cells per relaxed half-width, a window of 6.4 a0 (the default grid's choice here: a0/30, 6 a0)
GRID = jr.Full(grid=jr.FixedGrid(A0 / 30, 192))
COVER = jr.Layer(H, nu=NU)


def full(speeds, loads, *, f=F, tau=TAU, G=G0, T=293.15, layer=COVER, result=False):
    """F_ir' [N/m] of the full 2D model on the shared program (2 speeds x 2 loads) (``result``:
    the table). Every solve converges; the grid (30 cells per half-width, fixed) is coarser than
    the default's here, and its error estimate, calibrated on incompressible layers (at a/H = 15
    near the peak 1-6 % at 25-30 cells), may flag a point that this compressible cover resolves
    well: the checks below compare values with their oracles instead."""
    mat = jr.at_temperature(jr.StandardLinearSolid(G, tau, f), WLF, T)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.ValidityWarning)
        res = jr.rolling_resistance_grid(mat, layer, radius=R, loads=loads, speeds=speeds, geometry="cylinder",
                                         method=GRID, throw=False)
    codes = np.asarray(res.result)
    assert np.all((codes == jr.RESULTS.successful) | (codes == jr.RESULTS.truncation_too_large)), res.reasons()
    return res if result else np.asarray(res.value)


# ------------------------------------------------------------------ (i) bookkeeping


def test_trough_loads_follow_the_iso_cross_section_and_balance_the_weight():
    """The three-roll trough: vertical equilibrium (center + 2 wings x cos lambda = weight, exact)
    and the center roll's bulk share against an independent quadrature of the ISO 5048 / DIN
    22101 cross-section (trapezoid + parabolic surcharge), whose total area is the standard's
    formula A1 + A2 (quadrature error ~1e-12)."""
    B, l, lam, th = 1.2, 0.465, math.radians(35), math.radians(20)
    mB, mG, s, g = 20.0, 150.0, 1.2, conveyor.G_STANDARD
    L = conveyor.trough_loads(belt_width=B, belt_mass=mB, bulk_mass=mG, spacing=s, roll_length=l, trough_angle=lam,
                              surcharge_angle=th)
    W = (mB + mG) * g * s
    assert L.weight == pytest.approx(W, rel=1e-14)
    assert L.normal_force[0] + 2 * L.normal_force[1] * math.cos(lam) == pytest.approx(W, rel=1e-12)
    np.testing.assert_allclose(L.line_load, L.normal_force / L.contact_length, rtol=1e-14)
    assert L.contact_length[1] == pytest.approx(min(l, (B - l) / 2), rel=1e-14)
    b = 0.9 * B - 0.05
    w = l + (b - l) * math.cos(lam)
    A1 = w * w * math.tan(th) / 6                                    # ISO 5048 surcharge area
    A2 = (l + (b - l) / 2 * math.cos(lam)) * (b - l) / 2 * math.sin(lam)  # trapezoid
    h = (b - l) / 2 * math.sin(lam)

    def depth(x):  # bulk depth above the trough bottom: the trapezoid's bottom + the parabola
        bottom = 0.0 if abs(x) <= l / 2 else (abs(x) - l / 2) * math.tan(lam)
        return max(h - bottom, 0.0) + max(w * math.tan(th) / 4 * (1 - (2 * x / w) ** 2), 0.0)

    pts = [-l / 2, l / 2]
    total = quad(depth, -w / 2, w / 2, points=pts, epsabs=0, epsrel=1e-13, limit=200)[0]
    center = quad(depth, -l / 2, l / 2, epsabs=0, epsrel=1e-13)[0]
    assert total == pytest.approx(A1 + A2, rel=1e-10)
    assert L.center_share == pytest.approx(center / total, rel=1e-10)
    flat = conveyor.trough_loads(belt_width=B, belt_mass=mB, bulk_mass=mG, spacing=s)
    assert flat.rolls == ("flat",) and flat.line_load[0] == pytest.approx(W / B, rel=1e-14)


def test_per_idler_set_and_flight_power_are_the_per_width_resistance_times_length():
    """F_ir per roll = F_ir' x contact length, set = sum over rolls, power = n F_ir V, the
    coefficient F_ir'/F_z'; the point front door and the set's table agree (the direct method:
    the bookkeeping, not the method, is under test; agreement to rounding)."""
    mat, layer, D, V = jr.StandardLinearSolid(3e6, 2e-5, 1.0), jr.Layer(0.006), 0.159, 4.0  # direct: valid here
    L = conveyor.trough_loads(belt_width=1.0, belt_mass=15.0, bulk_mass=100.0, spacing=1.5, roll_length=0.38,
                              trough_angle=math.radians(30))
    s = conveyor.idler_set_resistance(mat, layer, diameter=D, loads=L, speed=V, method="direct")
    total = 0.0
    for k in range(2):
        r = conveyor.indentation_resistance(mat, layer, diameter=D, line_load=float(L.line_load[k]), speed=V,
                                            contact_length=float(L.contact_length[k]), method="direct")
        assert float(r.per_width) == pytest.approx(s.per_width[k], rel=1e-12)
        assert float(r.per_idler) == pytest.approx(float(r.per_width) * L.contact_length[k], rel=1e-14)
        assert float(r.coefficient) == pytest.approx(float(r.per_width) / L.line_load[k], rel=1e-14)
        total += L.count[k] * float(r.per_idler)
    assert s.force == pytest.approx(total, rel=1e-12) and s.valid
    assert s.coefficient == pytest.approx(total / L.weight, rel=1e-14)
    assert s.power == pytest.approx(total * V, rel=1e-14)
    assert conveyor.flight_power(s.force, 500, V) == pytest.approx(500 * total * V, rel=1e-14)


# ------------------------------------------------------------------ (ii) the Winkler limit


def test_thin_compressible_cover_is_the_viscoelastic_winkler_foundation():
    """A thin compressible cover (nu = 0.3, relaxed half-width a0 = 15 H) against the
    Winkler-SLS closed form, across the resistance peak (V tau / a = 0.2 .. 2.3).
    Error sources: the Winkler bed neglects the shear coupling of neighbouring columns, a
    relative O((H/a)^2) ~ 0.4 % correction at a = 15 H; the full model's grid (30 cells per
    half-width) ~0.1 %. Measured: |deviation| <= 0.07 %. Tolerance 0.5 %. The model's own error
    estimate (``truncation``) bounds the deviation beyond the oracle's 0.4 % (it is calibrated on
    incompressible layers, which err more: conservative here)."""
    speeds = np.array([0.3, 1.0]), np.array([3.0, 2.0])
    loads = np.array([P0, 1.5 * P0])
    for Vs in speeds:
        res = full(Vs, loads, result=True)
        got, bound = np.asarray(res.value), np.asarray(res.truncation)
        for i, V in enumerate(Vs):
            for j, P in enumerate(loads):
                exact = winkler_sls(P, R, H, G0, TAU, F, NU, V)
                assert got[i, j] == pytest.approx(exact, rel=5e-3), (V, P)
                assert abs(got[i, j] / exact - 1) <= bound[i, j] + 4e-3, (V, P)


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # the under-resolved points are flagged: the point
# the oracle's quadrature (relative tolerance 1e-13) reports round-off at these slow speeds; its value
# is still far inside the 1 % scale asserted here
@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_slow_rolling_on_a_thin_cover_is_bounded_by_its_truncation():
    """Slow rolling on the thin cover (V tau/a0 = 0.01, 0.02) is under-resolved at 30 cells per
    half-width: the dissipation form errs +9.4 / +2.6 % against the Winkler closed form (measured;
    the Winkler model's own error is ~0.4 %, see above). The layer is thinner than the error
    tables' calibration (a/H = 15), so the truncation takes the moment-dissipation gap, which
    brackets the truth there: it bounds each error, and at 0.01 (bound > 5 %) the point is not
    valid."""
    Vs, loads = np.array([0.01, 0.02]) * A0 / TAU, np.array([P0, 1.5 * P0])
    res = jr.rolling_resistance_grid(jr.StandardLinearSolid(G0, TAU, F), COVER, radius=R, loads=loads, speeds=Vs,
                                     geometry="cylinder", method=GRID, throw=False)
    got, bound = np.asarray(res.value), np.asarray(res.truncation)
    for i, V in enumerate(Vs):
        for j, P in enumerate(loads):
            err = abs(got[i, j] / winkler_sls(P, R, H, G0, TAU, F, NU, V) - 1)
            assert err > 0.01 and bound[i, j] > err + 4e-3, (V, P, err, bound[i, j])  # + the oracle's own 0.4 %
    assert not np.any(np.asarray(res.valid)[0])


# ------------------------------------------------------------------ (iii) scaling laws


def test_low_speed_law_low_loss_and_high_speed_scaling():
    """Scaling in the limits, on the thin cover:
    - slow rolling (V tau << a): the Winkler expansion to first order in V gives
      F_ir'/F_z' = V tau f/((1+f) R), independent of the load and the thickness (Rudolphi and
      Reicks: the normalised indentation resistance of the Winkler model does not depend on the
      load per width, the idler diameter and the cover thickness). The ratio to the law is
      1 + O(V tau/a) (-11 % at V tau/a0 = 0.1): at V tau/a0 = 0.05 and 0.1 its linear
      extrapolation to V = 0 leaves O((V tau/a)^2) (the Winkler oracle: 0.05 %), plus the
      Winkler error (<= 0.1 %, above); tolerance 0.5 %. (Slower points need a finer grid than
      this one's a0/30: at V tau/a0 = 0.01 it is 9 % above the Winkler value, a0/100 0.3 %.)
    - low loss: F_ir' proportional to f/(1+f) as f -> 0 (error O(f) = 1e-3); tolerance 3e-3;
    - fast rolling (V tau >> a, the glassy limit): F_ir' ~ 1/V, error O(a/(V tau)): the Winkler
      oracle gives F_ir' V 0.7 % apart at V tau/a0 = 50 and 100; tolerance 2 %."""
    V = np.array([0.05, 0.1]) * A0 / TAU
    loads = np.array([P0, 2 * P0])
    ratio = full(V, loads) / (V[:, None] * TAU * F / ((1 + F) * R) * loads[None, :])
    np.testing.assert_allclose(2 * ratio[0] - ratio[1], 1.0, rtol=5e-3)
    lossy = np.array([1e-3, 2e-3])
    low = [full(np.array([0.5, 1.0]), loads, f=fk) for fk in lossy]
    np.testing.assert_allclose(low[1] / low[0], (lossy[1] / (1 + lossy[1])) / (lossy[0] / (1 + lossy[0])), rtol=3e-3)
    fast = full(np.array([50.0, 100.0]) * A0 / 1.0, loads, tau=1.0)   # V tau / a0 = 50, 100
    np.testing.assert_allclose(fast[1] / fast[0], 0.5, rtol=2e-2)


# ------------------------------------------------------------------ (iv) the map's derivatives


def _check_map(method, evaluate, rtol_value, rtol_fd):
    """conveyor_map (one program, forward-mode tangents) against ``evaluate`` (the front door at
    the same points), and dF/dT, dF/dH, dF/dlnG, dF/dlntau, dF/df against central differences of
    the front door (relative step 1e-4: truncation ~1e-8); the identity
    dF/dT = dF/dlntau x dln a_T/dT (temperature enters only through a_T)."""
    T, Vs, loads = 283.15, np.array([0.3, 1.0]), np.array([P0, 1.5 * P0])
    mat = jr.StandardLinearSolid(G0, TAU, F)
    m = conveyor.conveyor_map(mat, WLF, COVER, diameter=2 * R, line_loads=loads, temperatures=[T], speeds=Vs,
                              contact_length=0.4, method=method)
    assert m.per_width.shape == (1, 2, 2)
    np.testing.assert_allclose(m.per_width[0], evaluate(Vs, loads, T=T), rtol=rtol_value)
    np.testing.assert_allclose(m.per_idler, 0.4 * m.per_width, rtol=1e-14)
    np.testing.assert_allclose(m.coefficient, m.per_width / loads, rtol=1e-14)
    r = 1e-4

    def fd(**kw):
        (name, (lo, hi)), = kw.items()
        at = lambda v: evaluate(Vs, loads, **{"T": T, name: v})  # noqa: E731
        return at(hi) - at(lo)

    ref = {"T": fd(T=(T * (1 - r), T * (1 + r))) / (2 * r * T),
           "H": fd(layer=(jr.Layer(H * (1 - r), nu=NU), jr.Layer(H * (1 + r), nu=NU))) / (2 * r * H),
           "lnG": fd(G=(G0 * (1 - r), G0 * (1 + r))) / (2 * r),
           "lntau": fd(tau=(TAU * (1 - r), TAU * (1 + r))) / (2 * r),
           "f": fd(f=(F * (1 - r), F * (1 + r))) / (2 * r * F)}
    got = {"T": m.dF_dT[0], "H": m.dF_dH[0], **{k: v[0] for k, v in m.dF_dmaterial.items()}}
    for name in ref:
        np.testing.assert_allclose(got[name], ref[name], rtol=rtol_fd, err_msg=name)
    dlnaT = (float(WLF.log_shift(T * (1 + r))) - float(WLF.log_shift(T * (1 - r)))) / (2 * r * T)  # WLF: to 1e-8
    np.testing.assert_allclose(m.dF_dT[0], m.dF_dmaterial["lntau"][0] * dlnaT, rtol=1e-6)
    return m


def direct(speeds, loads, *, f=F, tau=TAU, G=G0, T=293.15, layer=COVER):
    """F_ir' [N/m] of the direct method (validity not asked: the map's plumbing is under test)."""
    mat = jr.at_temperature(jr.StandardLinearSolid(G, tau, f), WLF, T)
    with warnings.catch_warnings():  # direct may flag these points; the values are what is compared
        warnings.simplefilter("ignore", jr.ValidityWarning)
        res = jr.rolling_resistance_grid(mat, layer, radius=R, loads=loads, speeds=speeds, geometry="cylinder",
                                         method="direct", throw=False)
    return np.asarray(res.value)


def test_map_derivatives_against_central_differences_reduced():
    """The map's plumbing (points, tangents, material directions) with the direct method:
    values equal the front door to rounding; derivatives central differences to 1e-4 (measured
    1.1e-5 at worst: the method's quadrature and series truncation, ~1e-9 relative, over the
    relative step 1e-4)."""
    _check_map("direct", direct, 1e-12, 1e-4)


@pytest.mark.slow
def test_map_values_and_design_derivatives_against_central_differences():
    """As the reduced copy, with the full 2D model on :data:`GRID`: values equal the front door to
    the solver tolerance (warm starts; 1e-6), derivatives central differences to 1e-4 (the
    solver tolerance 1e-10 over the step 1e-4, and the implicit derivative of the contact set)."""
    m = _check_map(GRID, full, 1e-6, 1e-4)
    assert m.valid.all()


def test_carcass_plies_pass_through_as_a_stack():
    """Carcass plies: a belt_stack whose carcass ply is the cover compound equals the single cover
    of the summed thickness (the stack's identity, 1e-10 in R_r; the direct method: plumbing),
    and a stiff carcass lowers the resistance."""
    cover, D, V, q = jr.StandardLinearSolid(3e6, 2e-5, 1.0), 0.159, 4.0, 2e3
    kw = dict(diameter=D, line_load=q, speed=V, contact_length=0.5, method="direct")
    single = conveyor.indentation_resistance(cover, jr.Layer(0.008), **kw)
    split = conveyor.indentation_resistance(conveyor.belt_stack(cover, 0.005, [jr.Ply(cover, 0.003)]), **kw)
    assert float(split.per_idler) == pytest.approx(float(single.per_idler), rel=1e-10)
    stiff = jr.StandardLinearSolid(3e8, 2e-5, 0.01)
    on_carcass = conveyor.indentation_resistance(conveyor.belt_stack(cover, 0.005, [jr.Ply(stiff, 0.003)]), **kw)
    assert float(on_carcass.per_width) < float(single.per_width)
