"""Peer check against ``tamaas`` (PyPI, C++ FFT contact; optional extra ``peer``: skipped when
absent), the code the speed benchmark ``benchmarks/bench_tamaas.py`` times against.

Same problem in both: a rigid paraboloid (R = 2 cm, P = 100 N) on an elastic incompressible
half-space (G = 3 MPa, E* = 12 MPa), periodic with period L = 0.1 m, square cells of 0.5 mm
(200 x 200), tolerance 1e-10. tamaas: Polonsky-Keer-Rey on the whole period grid with nodal
pressures; jaxroll: ``jr.Full`` at V = 0 (f = 0: elastic) on a window around the contact with
piecewise-constant cells. Both are second-order discretisations of the same contact, so their
difference is the discretisation error (measured at this grid: contact radii 0.09 cell apart, peak
pressures within 0.2 %, both within 2 % of Hertz in area and 0.2 % in peak pressure).
"""

import numpy as np
import pytest

tm = pytest.importorskip("tamaas")

import jaxroll as jr  # noqa: E402

R, P, G, L, CELL = 0.02, 100.0, 3e6, 0.1, 5e-4


def test_static_sphere_vs_tamaas():
    tm.set_log_level(tm.LogLevel.warning)
    N = int(round(L / CELL))
    x = (np.arange(N) + 0.5) * CELL - L / 2
    X, Y = np.meshgrid(x, x, indexing="ij")
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [L, L], [N, N])
    model.E, model.nu = 3 * G, 0.5
    tm.PolonskyKeerRey(model, -(X * X + Y * Y) / (2 * R), 1e-10).solve(P / (L * L))
    p_tm = np.array(model.traction, copy=True).reshape(N, N)
    assert np.sum(p_tm) * CELL * CELL == pytest.approx(P, rel=1e-8)

    a = (3 * P * R / (16 * G)) ** (1 / 3)  # Hertz, E* = 4 G
    method = jr.Full(grid=jr.FixedGrid(CELL, 2 * int(np.ceil(1.25 * a / CELL)) + 1, period=L))
    with pytest.warns(jr.ValidityWarning, match="period is shorter"):  # L < 20 a: the rolling rule
        res = jr.rolling_resistance(jr.StandardLinearSolid(G, 1.0, 0.0), jr.Layer(np.inf), radius=R, load=P,
                                    speed=0.0, method=method, throw=False)
    p_jr = np.asarray(res.solution.pressure)
    assert np.sum(p_jr) * CELL * CELL == pytest.approx(P, rel=1e-8)
    r_tm, r_jr = (np.sqrt(np.sum(p > 0) / np.pi) for p in (p_tm, p_jr))  # contact radius [cells]
    # contact sets: cell-quantised (one boundary ring is 2/6.8 = 30 % of the area at 6.8 cells
    # per radius), so compare radii: within a quarter cell (measured 0.09 cell)
    assert abs(r_jr - r_tm) < 0.25
    assert p_jr.max() / p_tm.max() == pytest.approx(1.0, abs=0.01)
    p0 = 3 * P / (2 * np.pi * a * a)
    assert p_jr.max() / p0 == pytest.approx(1.0, abs=0.01) and p_tm.max() / p0 == pytest.approx(1.0, abs=0.01)
