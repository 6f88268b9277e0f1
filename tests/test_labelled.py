"""Labelled outputs: grid results, resistance maps and fits as pandas / xarray tables with named
dimensions (order temperature, speed, load), coordinates and units; plot functions draw into a
caller's Axes. pandas and xarray are optional: their tests skip when absent."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import jaxroll as jr  # noqa: E402
from jaxroll.apps import plot  # noqa: E402
from jaxroll.identify.fit import FitResult  # noqa: E402

MAT, LAYER, R = jr.StandardLinearSolid(3e6, 0.25, 1.0), jr.Layer(0.03, rho=1000.0), 0.02
# not square: a swapped axis fails; below the R_r peak, where the direct method is valid (near it
# its estimated error against the full model flags it)
SPEEDS, LOADS = np.array([3e-4, 1e-3]), np.array([50.0, 100.0, 150.0])


@pytest.fixture(scope="module")
def grid():
    return jr.rolling_resistance_grid(MAT, LAYER, radius=R, loads=LOADS, speeds=SPEEDS, method="direct")


def test_grid_result_labels_each_value_with_its_own_speed_and_load(grid):
    """Oracle: the front door's single-point call at each (speed, load), an independent program."""
    xr = pytest.importorskip("xarray")
    ds = grid.to_xarray(SPEEDS, LOADS)
    assert isinstance(ds, xr.Dataset) and ds["rolling_resistance"].dims == ("speed", "load")
    assert ds["rolling_resistance"].attrs["units"] == "N" and ds["speed"].attrs["units"] == "m/s"
    assert ds["load"].attrs["units"] == "N" and ds["contact_radius"].attrs["units"] == "m"
    df = grid.to_pandas(SPEEDS, LOADS)
    assert list(df.index.names) == ["speed", "load"] and df.attrs["units"]["rolling_resistance"] == "N"
    for V in SPEEDS:
        for P in LOADS:
            point = float(jr.rolling_resistance(MAT, LAYER, radius=R, load=P, speed=V, method="direct").value)
            # one model, two compiled programs (vmapped grid vs single point): rounding only
            assert float(ds["rolling_resistance"].sel(speed=V, load=P)) == pytest.approx(point, rel=1e-12)
            assert df.loc[(V, P), "rolling_resistance"] == pytest.approx(point, rel=1e-12)
    assert bool(ds["valid"].all()) and ds["approximation"].attrs["units"] == "-"  # the direct method's estimate
    cyl = grid.to_xarray(SPEEDS, LOADS, geometry="cylinder")
    assert cyl["load"].attrs["units"] == "N/m" and cyl["rolling_resistance"].attrs["units"] == "N/m"
    with pytest.raises(ValueError, match="shape"):
        grid.to_xarray(LOADS, SPEEDS)  # axes swapped: refused, not mislabelled


def _map():
    T, V = np.array([273.15, 293.15, 313.15]), np.array([1e-3, 1e-1])
    value = T[:, None] * 1e-3 + V[None, :]  # each entry encodes its own (T, V)
    return jr.ResistanceMap(T, V, value, value > 0.3, -value, 2 * value, 1e-3, np.where(value > 0.3, 0, 5))


def test_resistance_map_tables_are_temperature_by_speed_with_units():
    xr = pytest.importorskip("xarray")
    m = _map()
    ds = m.to_xarray()
    assert isinstance(ds, xr.Dataset) and ds["rolling_resistance"].dims == ("temperature", "speed")
    assert {k: ds[k].attrs["units"] for k in ("temperature", "speed", "rolling_resistance", "dR_dT", "dR_dH")} == {
        "temperature": "K", "speed": "m/s", "rolling_resistance": "N", "dR_dT": "N/K", "dR_dH": "N/m"}
    for T in m.temperatures:
        for V in m.speeds:
            assert float(ds["rolling_resistance"].sel(temperature=T, speed=V)) == pytest.approx(T * 1e-3 + V, rel=1e-15)
    df = m.to_pandas(unit="N/m")
    assert list(df.index.names) == ["temperature", "speed"] and len(df) == 6
    assert df.loc[(313.15, 1e-1), "dR_dH"] == pytest.approx(2 * (0.31315 + 0.1), rel=1e-15)
    assert df.attrs["units"]["dR_dT"] == "N/m/K" and df["result"].tolist() == np.ravel(m.result).tolist()


def test_fit_result_tables_name_every_parameter_with_its_unit():
    pd = pytest.importorskip("pandas")
    pytest.importorskip("xarray")
    params = {"G0": 3e6, "tau": 0.25, "G": np.array([1e6, 2e6])}
    stderr = {"G0": 1e5, "tau": 0.01, "G": np.array([1e4, 2e4])}
    ci = {k: (np.asarray(v) * 0.9, np.asarray(v) * 1.1) for k, v in params.items()}
    names = ["G0", "tau", "G[0]", "G[1]"]
    corr = np.eye(4)
    fit = FitResult(material=None, layer=None, shift=None, params=params, stderr=stderr, ci95=ci, covariance=corr,
                    correlation=corr, names=names, converged=True, residuals=np.zeros(5), cost=0.0,
                    reduced_chi2=1.0, starts=[(0.0, True)], warnings=[])
    df = fit.to_pandas()
    assert isinstance(df, pd.DataFrame) and df.index.tolist() == names
    assert df["unit"].tolist() == ["Pa", "s", "Pa", "Pa"] and df.loc["G[1]", "value"] == 2e6
    assert df.loc["tau", "ci95_high"] == pytest.approx(0.275, rel=1e-15)
    ds = fit.to_xarray()
    assert ds["correlation"].dims == ("parameter", "parameter_2") and ds["value"].sel(parameter="G0") == 3e6


def test_plot_functions_draw_into_given_axes_and_return_their_figure():
    fig, (a, b) = plt.subplots(1, 2)
    values = np.array([[1.0, 2.0], [2.0, 3.0], [3.0, 4.0]])  # (loads, speeds), the plot's documented order
    assert plot.plot_rolling_curves(SPEEDS, LOADS, values, ax=b) is fig
    assert len(b.lines) == 3 and not a.lines
    fig2, axes = plt.subplots(1, 2)
    assert plot.plot_fit(SPEEDS, LOADS[:2], [1.0, 2.0], [1.1, 1.9], ax=axes) is fig2
    with pytest.raises(ValueError, match="needs 2 Axes"):
        plot.plot_fit(SPEEDS, LOADS[:2], [1.0, 2.0], [1.1, 1.9], ax=a)
    for f in (fig, fig2):
        plot.close(f)
