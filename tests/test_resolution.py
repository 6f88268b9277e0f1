"""The full 3D model is robust when refined: the contact solve converges from 8 to 48 cells per
contact radius and the rolling resistance converges with the resolution.

Half-space (infinite layer ``H = inf``), rigid sphere R = 2 cm, P = 100 N, standard linear solid
G0 = 3 MPa, tau = 0.25 s; ``zeta = V tau / a0`` with the relaxed Hertz radius ``a0 = 5 mm``.
Before the Krylov basis of the contact solves grew (GMRES(12) stagnated at a relative residual
of ~1e-2 at 24-32 cells per radius), the active set cycled there and the points were flagged
``max_steps_reached`` with values up to 15 % off.
"""

import numpy as np
import pytest

import jaxroll as jr

G0, TAU, R, P = 3e6, 0.25, 0.02, 100.0
HALF_SPACE = jr.Layer(H=float("inf"))
A0 = float(jr.reference.hertz_sphere(P, R, G0).contact_radius)  # relaxed Hertz radius (E* = 4 G0): 5 mm


def _rr(cells_per_radius, zeta, f):
    method = jr.Full(grid=jr.AutoGrid(cells_per_radius=cells_per_radius))
    res = jr.rolling_resistance(jr.StandardLinearSolid(G0, TAU, f), HALF_SPACE, radius=R, load=P,
                                speed=zeta * A0 / TAU, method=method, throw=False)
    # the moment form, on which these tolerances were measured (the reported dissipation form is
    # checked against a convergence study in tests/test_grid_accuracy.py)
    return float(res.solution.resistance_moment), jr.RESULTS.names[int(res.result)]


def test_fine_grid_converges_at_the_peak():
    """zeta = 1 (the resistance peak), 12 and 24 cells per radius: both solves converge and agree
    to the discretisation error (measured 0.03 %; 0.2 % allowed). The 24-cell point failed
    before (max_steps_reached), as did 32 cells (window_too_small)."""
    coarse, code_c = _rr(12, 1.0, 1.0)
    fine, code_f = _rr(24, 1.0, 1.0)
    assert (code_c, code_f) == ("successful", "successful")
    assert fine == pytest.approx(coarse, rel=2e-3)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # the flagged 8-cell point is expected
@pytest.mark.parametrize("f", [1.0, 3.0])
def test_every_resolution_converges(f):
    """8..48 cells per radius over zeta = 0.01..100: every solve converges (8 cells may be
    flagged by its own error estimate, truncation_too_large: at zeta = 0.01, and at zeta = 100
    with f = 3, where its moment and dissipation forms differ by 8.0 % while the value is 0.7 %
    from 64 cells: the bound is conservative, the solve converged), and the values converge
    to the finest grid: within 2.5 % from 16 cells on for zeta >= 0.1 (measured <= 1.2 %, f = 1,
    the wake at zeta = 100); at zeta = 0.01 the contact edge limits the accuracy (measured
    -5.1 % at 12 cells, -1.5 % at 24) and the error must fall as the grid is refined."""
    zetas = [0.01, 0.1, 1.0, 10.0, 100.0]
    cprs = [8, 12, 16, 24, 32, 48]
    table = {(c, z): _rr(c, z, f) for c in cprs for z in zetas}
    for (c, z), (value, code) in table.items():
        allowed = ("successful", "truncation_too_large") if c == 8 else ("successful",)
        assert code in allowed, (c, z, code)
        assert np.isfinite(value) and value > 0
    for z in zetas:
        finest = table[(48, z)][0]
        errors = [abs(table[(c, z)][0] / finest - 1) for c in cprs[:-1]]
        if z >= 0.1:
            assert max(errors[2:]) < 0.025, (z, errors)
        else:
            assert errors[1] > errors[3] > errors[4], (z, errors)
