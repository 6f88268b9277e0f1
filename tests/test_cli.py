"""Command line: each subcommand runs in-process on a small case, writes its files, and rejects
bad arguments with one clear message (exit status 2)."""

import csv
import json
import math
import warnings

import numpy as np
import pytest

import jaxroll as jr
from jaxroll.apps.cli import main


def _rows(path):
    with open(path) as fh:
        return list(csv.reader(fh))


def test_demo_writes_plots_and_csv(tmp_path):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    for name in ("master_curves.png", "compliance.png", "compliance.csv"):
        assert (tmp_path / name).stat().st_size > 0
    rows = _rows(tmp_path / "compliance.csv")
    assert rows[1][0] == "rad/m" and len(rows) == 2 + 101


@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # flags are compared row by row below
def test_curve_matches_library(tmp_path):
    # plumbing only: the cheap SP slices named explicitly (the default, the full model, is
    # checked in tests/test_defaults.py)
    assert main(["curve", "--loads", "50,100", "--n", "4", "--method", "SP", "--out", str(tmp_path)]) == 0
    rows = _rows(tmp_path / "curve.csv")
    assert rows[0] == ["speed", "load", "rolling_resistance", "valid", "result"]
    rows = rows[2:]
    assert len(rows) == 8
    # the SP slices on the grid the curve resolves over its whole envelope (the table front door,
    # as the command: its compiled program is reused, and the resolved grid must equal the CLI's)
    mat, layer = jr.StandardLinearSolid(3e6, 0.25, 1.0), jr.Layer(H=0.03, rho=1000.0)
    speeds = sorted({float(r[0]) for r in rows})
    method = jr.Slices("SP").resolve(mat, layer, radius=0.02, loads=[50.0, 100.0], speeds=speeds)
    ref = jr.rolling_resistance_grid(mat, layer, radius=0.02, loads=[50.0, 100.0], speeds=speeds, method=method)
    for row in rows:  # loads x speeds, 8 significant digits in the CSV
        V, P, val = (float(x) for x in row[:3])
        i, j = speeds.index(V), [50.0, 100.0].index(P)
        assert val == pytest.approx(float(ref.value[i, j]), rel=1e-7)
        assert row[3:] == [str(int(ref.valid[i, j])), jr.RESULTS.names[int(ref.result[i, j])]]


def test_sweep_grid_axes(tmp_path):
    # the axes only: the direct method named explicitly, on the V x H shape of the test below,
    # whose compiled program it shares (a grid method compiles its own for seconds)
    assert main(["sweep", "--vary", "V=1e-3:1e-1:3:log", "--vary", "H=0.005,0.03", "--method", "direct", "--quiet",
                 "--out", str(tmp_path)]) == 0
    rows = _rows(tmp_path / "sweep.csv")
    assert rows[0] == ["V", "H", "rolling_resistance", "valid", "result"] and rows[1] == ["m/s", "m", "N", "-", "-"]
    assert len(rows) == 2 + 6


def test_a_full_model_curve_reports_per_block_of_speeds(tmp_path, capsys):
    """``jaxroll curve`` with a full model (the default) runs its table in blocks of speeds and
    reports after each (``rolling_resistance_grid(progress=True)``): a line per block on stderr,
    and the values of the library's one-shot table (the full 2D cylinder: each block's first speed
    starts cold instead of from the previous speed, the same contact problems: equal to the
    solver's tolerance, 1e-9 allowed, and to the CSV's 8 digits). ``--quiet`` runs it in one piece."""
    argv = ["curve", "--geometry", "cylinder", "--loads", "2000,5000", "--vmin", "1e-3", "--n", "3"]
    assert main([*argv, "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "per block of speeds" in err and "3/3 speeds" in err, err
    mat, layer = jr.StandardLinearSolid(3e6, 0.25, 1.0), jr.Layer(H=0.03, rho=1000.0)
    speeds = np.logspace(-3.0, 0.0, 3)
    ref = jr.rolling_resistance_grid(mat, layer, radius=0.02, loads=[2e3, 5e3], speeds=speeds, geometry="cylinder")
    rows = _rows(tmp_path / "curve.csv")[2:]
    assert len(rows) == 6
    for row in rows:
        V, P, val = (float(x) for x in row[:3])
        i, j = int(np.argmin(abs(speeds - V))), [2e3, 5e3].index(P)
        assert val == pytest.approx(float(ref.value[i, j]), rel=1e-7)
        assert row[3] == "1"
    assert main([*argv, "--quiet", "--out", str(tmp_path / "quiet")]) == 0
    assert "speeds," not in capsys.readouterr().err


def test_sweep_outside_validity_writes_valid_0_and_warns(tmp_path, capsys):
    # docs/api.md's sweep example with the direct method: gamma = r_c/H = 3.1 and 0.91 at 100 N,
    # outside both pressure models, so every point is flagged (it used to be written silently)
    argv = ["sweep", "--vary", "V=1e-4:1:3:log", "--vary", "H=0.002,0.005", "--method", "direct", "--quiet"]
    assert main([*argv, "--out", str(tmp_path)]) == 0
    rows = _rows(tmp_path / "sweep.csv")[2:]
    assert {r[3] for r in rows} == {"0"} and {r[4] for r in rows} == {"outside_pressure_model"}
    err = capsys.readouterr().err
    assert "warning: 6 of 6 points not valid (outside_pressure_model)" in err and "--method full" in err


# G0 and tau of a sphere on a thick layer are ~99.9 % correlated in rolling-resistance data alone
# (the identifiability warning is the expected, physical outcome; see tests/test_fit.py)
@pytest.mark.filterwarnings("ignore::jaxroll.identify.fit.IdentifiabilityWarning")
@pytest.mark.filterwarnings("ignore::jaxroll.ValidityWarning")  # the direct data near the peak are flagged
def test_fit_from_csv(tmp_path):
    mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    layer = jr.Layer(H=0.03, rho=1000.0)
    V, P = [a.ravel() for a in np.meshgrid(np.logspace(-4, 0, 6), [20.0, 80.0, 150.0])]
    vals = [float(jr.rolling_resistance(mat, layer, radius=0.02, load=p, speed=v, method="direct", throw=False).value)
            for v, p in zip(V, P)]
    data = tmp_path / "rr.csv"
    with open(data, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["speed", "load", "rolling_resistance"])
        w.writerow(["m/s", "N", "N"])
        w.writerows(zip(V, P, vals))
    out = tmp_path / "fit"
    assert main(["fit", str(data), "--radius", "0.02", "--H", "0.03", "--rho", "1000", "--starts", "1",
                 "--method", "direct", "--initial", "G0=2e6,tau=0.1,f=0.6", "--out", str(out)]) == 0
    res = json.loads((out / "fit_params.json").read_text())
    # noise-free data generated by the same model: the fit must return the truth
    assert res["parameters"]["tau"]["value"][0] == pytest.approx(0.25, rel=1e-5)
    assert res["parameters"]["G0"]["value"][0] == pytest.approx(3e6, rel=1e-5)
    assert res["intervals"] == "linearised"  # the direct method's intervals are not profiled
    assert (out / "fit.png").exists() and (out / "fit_report.txt").exists()


@pytest.mark.parametrize(
    "argv,match",
    [
        (["curve", "--vmin", "-1"], "must be finite and positive"),
        (["sweep", "--vary", "X=1:2:3"], "unknown parameter 'X'"),
        # the same axis twice (before: the last one kept, silently)
        (["sweep", "--vary", "V=1e-3:1:3:log", "--vary", "V=1,2"], "--vary V given more than once"),
        (["fit", "nonexistent.csv"], "need --radius"),
        (["fit"], "give a rolling-resistance CSV"),
        (["curve", "--loads", "a,b"], "comma-separated numbers"),
        (["reproduce", "--cases", "H3mm"], "--cases: unknown ['H3mm']; choose from H2mm,H5mm,H30mm,H10um"),
        (["reproduce", "--methods", "PD,XX"], "--methods: unknown ['XX']"),
        (["reproduce", "--speeds", "0"], "--speeds: must be >= 1"),
        (["reproduce", "--loads", "two"], "--loads: expected a whole number"),
        (["reproduce", "--quik"], "unrecognized arguments: --quik"),
    ],
)
def test_bad_arguments_exit_2_with_message(argv, match, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert match in capsys.readouterr().err


def _exit_code(argv):
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


BAD_INPUTS = [  # (argv, the argument's name that the message must contain)
    (["demo", "--G0", "-3e6"], "--G0"), (["demo", "--tau", "0"], "--tau"), (["demo", "--f", "-0.5"], "--f"),
    (["demo", "--rho", "nan"], "--rho"), (["demo", "--speed", "inf"], "--speed"),
    (["curve", "--loads=-10,50"], "--loads"), (["curve", "--loads", "0"], "--loads"),
    (["curve", "--vmin", "1", "--vmax", "0.1"], "--vmin"), (["curve", "--vmax", "inf"], "--vmax"),
    (["curve", "--n", "0"], "--n"), (["curve", "--H", "-0.01"], "H"), (["curve", "--H", "-inf"], "H"),
    (["curve", "--H", "thick"], "--H"), (["curve", "--radius", "0"], "--radius"),
    (["curve", "--method", "exact"], "--method"), (["curve", "--geometry", "cube"], "--geometry"),
    (["sweep", "--vary", "V=1:-1:3:log"], "V"), (["sweep", "--vary", "V=1e-4:1:0:log"], "V"),
    (["sweep", "--vary", "f=-0.5,1"], "f"), (["sweep", "--vary", "H=0,0.01"], "H"),
    (["sweep", "--vary", "G0=nan,1e6"], "G0"), (["sweep", "--vary", "X=1,2"], "X"),
    (["sweep", "--vary", "P=1:2"], "P"), (["sweep", "--vary", "V=0.1,1", "--tau", "-1"], "--tau"),
    (["fit", "missing.csv", "--radius", "0.02"], "missing.csv"), (["fit", "--dma", "x.csv", "--starts", "0"], "--starts"),
    (["fit", "d.csv", "--radius", "-1"], "--radius"), (["fit", "d.csv", "--radius", "0.02", "--nu", "-0.1"], "--nu"),
    (["fit", "d.csv", "--radius", "0.02", "--initial", "G0=abc"], "--initial"),
    (["reproduce", "--cases", "H3mm"], "--cases"), (["reproduce", "--speeds", "-2"], "--speeds"),
    (["reproduce", "--methods", "XX"], "--methods"),
    (["material", "missing.csv"], "missing.csv"), (["material", "d.csv", "--poisson", "0.6"], "--poisson"),
    (["material", "d.csv", "--poisson", "-0.1"], "--poisson"), (["material", "d.csv", "--T-ref", "-5"], "--T-ref"),
    (["material", "d.csv", "--prony-terms", "0"], "--prony-terms"),
    (["material", "d.csv", "--fe-poisson", "0.5"], "--fe-poisson"),
    (["material", "d.csv", "--shift-moduli", "tan"], "--shift-moduli"), (["material"], "dma"),
    (["map"], "--material"), (["map", "--material", "missing.json"], "missing.json"),
    (["map", "--material", "m.json", "--H", "-0.01"], "--H"), (["map", "--material", "m.json", "--H", "inf"], "--H"),
    (["map", "--material", "m.json", "--load", "nan"], "--load"), (["map", "--material", "m.json", "--nu", "0.7"], "--nu"),
    (["map", "--material", "m.json", "--tmin", "300", "--tmax", "250"], "--tmin"),
    (["map", "--material", "m.json", "--tmin", "0"], "--tmin"), (["map", "--material", "m.json", "--vmin", "0"], "--vmin"),
    (["map", "--material", "m.json", "--vmin", "1", "--vmax", "0.1"], "--vmin"),
    (["map", "--material", "m.json", "--n-speeds", "0"], "--n-speeds"),
    (["map", "--material", "m.json", "--n-temperatures", "two"], "--n-temperatures"),
    (["map", "--material", "m.json", "--method", "exact"], "--method"),
    (["map", "--material", "m.json", "--geometry", "cube"], "--geometry"),
]


@pytest.mark.parametrize("argv,name", BAD_INPUTS, ids=[" ".join(a) for a, _ in BAD_INPUTS])
def test_every_subcommand_rejects_bad_input_in_one_line(argv, name, tmp_path, capsys):
    assert _exit_code([*argv, "--out", str(tmp_path)]) == 2
    # progress lines ("material: reading ...", on by default) may come first; the failure itself
    # is one line
    err = "\n".join(line for line in capsys.readouterr().err.strip().splitlines()
                    if not line.startswith(f"{argv[0]}: "))
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert name in err and "error:" in err


def test_checks_inside_compiled_programs_read_as_one_line():
    import jax

    from jaxroll.apps.cli.options import runtime_message

    m, layer = jr.StandardLinearSolid(3e6, 0.25, 1.0), jr.Layer(0.03)
    with pytest.raises(jax.errors.JaxRuntimeError) as exc:
        jax.jit(lambda P: jr.rolling_resistance(m, layer, radius=0.02, load=P, speed=0.01, method="direct").value)(-5.0)
    assert runtime_message(exc.value) == "load P [N, or N/m for cylinders] must be positive and finite"


def test_bad_physical_input_is_one_line_error(tmp_path, capsys):
    assert main(["curve", "--H", "-0.01", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "H must be a positive thickness" in err and "Traceback" not in err


def test_reproduce_passes_selection_and_prints_tables(tmp_path, monkeypatch, capsys):
    """The command builds the quick settings with the selections and prints both tables (the
    pipeline itself runs in tests/test_reproduce.py; here it is replaced by a stub that runs
    the real report writer on stub results)."""
    from jaxroll.apps import reproduce as rp

    seen = {}

    def fake(settings, out, **kw):
        seen["settings"], seen["out"] = settings, out
        loads, speeds = np.array([10.0, 150.0]), np.array([1e-3, 1e-1])
        ref = rp.MethodResult(np.array([[1.0, 2.0], [3.0, 4.0]]), np.zeros((2, 2), int), 1.0, 2.0)
        est = rp.MethodResult(np.array([[1.1, 2.0], [3.0, 3.6]]), np.zeros((2, 2), int), 0.5, 0.01)
        rep = rp.Reproduction(settings, [rp.CaseResult(rp.CASES["H5mm"], loads, speeds, ref, {"PP": est})], 3.0)
        rp.write_outputs(rep, out)
        return rep

    monkeypatch.setattr(rp, "reproduce", fake)
    assert main(["reproduce", "--quick", "--cases", "H5mm", "--methods", "PP", "--speeds", "2", "--loads", "2",
                 "--out", str(tmp_path)]) == 0
    s = seen["settings"]
    assert s.cases == ("H5mm",) and s.methods == ("PP",) and (s.n_speeds, s.n_loads) == (2, 2)
    assert s.spacing == rp.QUICK.spacing and "quick" in s.label
    out = capsys.readouterr().out
    # PP mean error (+10 % + 0 + 0 - 10 %)/4 = 0; mean |error| 5 %; speed factor = 2.0 s / 0.01 s = 200
    assert "| H = 5 mm, R = 2 cm | PP (slices) | 4 of 4 | +0.0 % | 5.0 % | 10.0 % |" in out  # all valid
    row = next(line for line in out.splitlines() if line.startswith("| PP (slices) |"))
    assert "| 200 |" in row and "20.0 s" in row and row.rstrip().endswith("| 161 |")
    assert (tmp_path / "report.md").exists() and (tmp_path / "rr_H5mm.png").exists()


# ------------------------------------------------------------------- method options


def _method(argv):
    from jaxroll.apps.cli import build_parser
    from jaxroll.apps.cli.options import method_from_args

    return method_from_args(build_parser().parse_args(["curve", *argv]))


def test_method_options_build_the_method_objects():
    assert _method(["--method", "direct", "--pressure", "thin"]) == jr.Direct(pressure="thin")
    assert _method(["--method", "full", "--spacing", "1e-3", "--window", "15", "--period", "0.05", "--n-terms",
                    "50", "--edge-smoothing", "0.5"]) == jr.Full(grid=jr.FixedGrid(1e-3, 15, period=0.05, n_terms=50),
                                                                 edge_smoothing=0.5)
    assert _method(["--method", "SP", "--cells-per-radius", "30", "--n-slices", "31"]) == jr.Slices(
        algorithm="SP", n_slices=31, grid=jr.AutoGrid(cells_per_radius=30))
    with pytest.raises(ValueError, match="--spacing and --window describe a fixed grid together"):
        _method(["--method", "full", "--spacing", "1e-3"])


@pytest.mark.parametrize(
    "argv,match",
    [
        (["--method", "exact"], "argument --method: invalid choice: 'exact'"),
        (["--spacing", "-1"], "--spacing [m]: must be finite and positive"),
        (["--window", "0"], "--window: must be >= 1"),
        (["--pressure", "medium"], "argument --pressure: invalid choice"),
    ],
)
def test_method_options_reject_bad_values(argv, match, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["curve", *argv])
    assert exc.value.code == 2
    assert match in capsys.readouterr().err


@pytest.mark.slow  # 15 s; the CLI fit path runs by default with the direct method named, full-model fits in test_fit.py
def test_fit_full_sphere_with_a_fixed_grid_recovers_tau(tmp_path, capsys):
    """``--method full`` with a fixed coarse grid given as options: the data come from
    :func:`jaxroll.rolling_resistance_grid` called directly on that grid (the oracle), so the
    fit returns the true tau only if every option reached the model; another n_terms gives
    another tau (the options are not ignored)."""
    grid = ["--spacing", "1e-3", "--window", "15", "--period", "0.05"]  # 4-6 cells per contact radius at 50-150 N
    layer = jr.Layer(H=0.03)
    speeds, loads = np.array([5e-3, 5e-2]), np.array([50.0, 150.0])  # around the peak, V ~ r_c/tau = 0.02 m/s
    method = jr.Full(grid=jr.FixedGrid(1e-3, 15, period=0.05, n_terms=50))
    with pytest.warns(jr.ValidityWarning, match="period is shorter"):
        out = jr.rolling_resistance_grid(jr.StandardLinearSolid(3e6, 0.25, 1.0), layer, radius=0.02, loads=loads,
                                         speeds=speeds, method=method)
    # the contact solves converged (this coarse grid's 0.05 m period is flagged as short)
    assert np.all(np.isin(np.asarray(out.result), [0, jr.RESULTS.period_too_short]))
    clean = np.asarray(out.value).ravel()  # speeds outer, loads inner
    V, P = (a.ravel() for a in np.meshgrid(speeds, loads, indexing="ij"))

    def run(name, values, sigma=None, n_terms=50):
        path = tmp_path / f"{name}.csv"
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["speed", "load", "rolling_resistance"] + ([] if sigma is None else ["sigma"]))
            w.writerow(["m/s", "N", "N"] + ([] if sigma is None else ["N"]))
            cols = [V, P, values] + ([] if sigma is None else [sigma])
            w.writerows([[repr(float(x)) for x in row] for row in zip(*cols)])  # full precision
        argv = ["fit", str(path), "--radius", "0.02", "--H", "0.03", "--method", "full", "--geometry", "sphere",
                "--free", "tau", "--initial", "G0=3e6,tau=0.4,f=1", "--starts", "1", *grid, "--n-terms", str(n_terms),
                "--out", str(tmp_path / name)]
        assert main(argv) == 0
        return json.loads((tmp_path / name / "fit_params.json").read_text())

    exact = run("exact", clean)
    assert "FixedGrid" in exact["method"] and "n_terms=50" in exact["method"]
    tau = exact["parameters"]["tau"]
    # noise-free data from the same discretised model: LM (rtol 1e-10 on the cost) and the
    # contact solve (tol 1e-10) leave ~1e-12; 1e-8 is far below the effect of any resolution
    # change (n_terms 50 -> 30 moves tau by 0.8 %, below)
    assert tau["value"][0] == pytest.approx(0.25, rel=1e-8)
    fitted = np.array([float(r[3]) for r in _rows(tmp_path / "exact" / "fitted.csv")[2:]])
    np.testing.assert_allclose(fitted, clean, rtol=1e-7)  # fitted.csv keeps 8 significant digits

    # 2 % noise (seed 0), sigma in the file: the 95 % interval, a few % wide, covers the truth
    # (z-interval with chi^2/3-dof scaling: coverage below 95 % with 4 points, e.g. seed 4 misses)
    noisy = run("noisy", clean * (1 + 0.02 * np.random.default_rng(0).standard_normal(clean.size)), 0.02 * clean)
    (lo,), (hi,) = noisy["parameters"]["tau"]["ci95"]
    assert lo <= 0.25 <= hi and 1e-3 < (hi - lo) / 0.25 < 0.2, (lo, hi)

    # the options are used: a coarser Fourier cut-off is another model, whose best tau is off
    other = run("other", clean, n_terms=30)
    assert "n_terms=30" in other["method"]
    assert abs(other["parameters"]["tau"]["value"][0] / 0.25 - 1) > 2e-3  # measured -0.8 %
    capsys.readouterr()



def test_fit_missing_data_file_is_one_line_error(tmp_path, capsys):
    missing = tmp_path / "nope.csv"
    assert main(["fit", str(missing), "--radius", "0.02", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxroll fit: error: ") and "nope.csv" in err and "Traceback" not in err


# ------------------------------------------------------------------- DMA -> material -> map

DMA_FILE = str(jr.datasets.path("pyvisco_freq_user_raw.csv"))


@pytest.fixture(scope="module")
def material_dir(tmp_path_factory):
    """``jaxroll material`` on the shipped DMA file (once for the tests below)."""
    out = tmp_path_factory.mktemp("material")
    data = DMA_FILE
    assert main(["material", str(data), "--T-ref", "298.15", "--out", str(out)]) == 0
    return data, out


def test_material_writes_the_library_fits_and_every_export(material_dir, capsys):
    """The files hold what the library functions return on the same file (the CLI only
    orchestrates and writes): Prony terms and WLF law in material.json / .csv, the shift
    factors, the master curve with the Prony values, FE decks with the instantaneous modulus."""
    data, out = material_dir
    sw = jr.read_dma_sweeps(data)
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    wlf = jr.fit_wlf(sh)
    pf = jr.fit_prony(jr.master_curve(sw, sh))
    for name in ("material.json", "material.csv"):
        mat, shift = jr.load_material(out / name)
        np.testing.assert_allclose(np.asarray(mat.tau), np.asarray(pf.material.tau), rtol=1e-12)
        np.testing.assert_allclose(np.asarray(mat.G), np.asarray(pf.material.G), rtol=1e-12)
        assert float(shift.C1) == pytest.approx(wlf.params["C1"], rel=1e-12)
        assert float(shift.T_ref) == pytest.approx(sh.T_ref, rel=1e-12)
    info = json.loads((out / "material.json").read_text())["info"]
    assert info["prony"]["n_terms"] == pf.n_terms and info["T_ref"] == pytest.approx(sh.T_ref)
    assert info["temperature_range"] == pytest.approx([sw.set_temperature[0], sw.set_temperature[-1]])
    w = jr.master_curve(sw, sh).omega
    assert info["reduced_frequency_range"] == pytest.approx([w.min(), w.max()], rel=1e-12)
    rows = _rows(out / "shift_factors.csv")
    assert rows[0][:3] == ["temperature", "log10_aT", "sigma"] and len(rows) == 2 + sw.n_sets
    np.testing.assert_allclose([float(r[1]) for r in rows[2:]], sh.log10_aT, rtol=1e-7)  # 8 digits
    assert [int(r[-1]) for r in rows[2:]].index(1) == sh.reference
    rows = _rows(out / "master_curve.csv")
    assert rows[1] == ["rad/s", "Pa", "Pa", "K", "-", "Pa", "Pa"] and len(rows) == 2 + len(sw.omega)
    w, gs = float(rows[5][0]), float(rows[5][5])
    assert gs == pytest.approx(float(jr.materials.storage_modulus(pf.material, w)), rel=1e-7)
    G0 = float(pf.material.glassy_modulus())
    abaqus = (out / "material_abaqus.inp").read_text().splitlines()
    assert abaqus[abaqus.index("*ELASTIC, MODULI=INSTANTANEOUS") + 1] == f"{2 * G0 * 1.49:.10g}, 0.49"
    assert "*TRS, DEFINITION=WLF" in abaqus
    assert f"TB,PRONY,1,,{pf.n_terms},SHEAR" in (out / "material_ansys.mac").read_text()
    for name in ("master_curve.png", "shift_factors.png"):
        assert (out / name).stat().st_size > 0
    report = (out / "material_report.txt").read_text()
    assert f"Prony: {pf.n_terms} terms" in report and "WLF: C1 = " in report
    # the error model the fit was weighed by, saved and reported (default: none, storage and loss alike)
    saved = (info["prony"]["phase_sigma"], info["prony"]["modulus_sigma"])
    assert saved == (pf.phase_sigma, pf.modulus_sigma) == (0.0, 0.01)
    assert "error model: storage and loss weighed alike (phase_sigma 0)" in report
    # the residual per decade of reduced omega (issue 28, item 5): the library fit's residuals, binned
    assert "Prony rms log residual per decade" in report
    decade = np.floor(np.log10(w_all := jr.master_curve(sw, sh).omega)).astype(int)
    per_decade = info["prony"]["rms_log_per_decade"]
    assert sorted(per_decade) == sorted(f"1e{d}" for d in np.unique(decade)) and w_all.size == pf.residuals.shape[0]
    for d in np.unique(decade):
        want = np.sqrt(np.mean(pf.residuals[decade == d] ** 2, axis=0))
        np.testing.assert_allclose(per_decade[f"1e{d}"], want, rtol=1e-9)


@pytest.mark.parametrize("geometry, load, unit", [("sphere", None, "N"), ("cylinder", 500.0, "N/m")])
def test_map_matches_resistance_map(material_dir, geometry, load, unit, tmp_path, capsys):
    """Every CSV row is jr.resistance_map's value, gradients and result on the same axes (the
    default temperatures: the material's measured range; the default load: 10 N for a sphere)."""
    _, mdir = material_dir
    # plumbing only: the direct method named explicitly on both sides (the default is checked in
    # tests/test_defaults.py)
    argv = ["map", "--material", str(mdir / "material.json"), "--geometry", geometry, "--n-temperatures", "3",
            "--n-speeds", "2", "--vmin", "1e-3", "--vmax", "1", "--method", "direct", "--quiet", "--out", str(tmp_path)]
    assert main(argv + (["--load", str(load)] if load else [])) == 0
    mat, shift = jr.load_material(mdir / "material.json")
    info = json.loads((mdir / "material.json").read_text())["info"]
    rng = info["temperature_range"]
    ref = jr.resistance_map(mat, shift, jr.Layer(H=0.01), radius=0.01, load=load or 10.0,
                            temperatures=np.linspace(*rng, 3), speeds=[1e-3, 1.0], geometry=geometry, method="direct",
                            measured_temperatures=rng, measured_frequencies=info["reduced_frequency_range"])
    rows = _rows(tmp_path / "map.csv")
    assert rows[0] == ["temperature", "speed", "rolling_resistance", "dR_dT", "dR_dH", "valid", "result"]
    assert rows[1] == ["K", "m/s", unit, f"{unit}/K", f"{unit}/m", "-", "-"]
    table = np.array([[float(x) for x in r[:5]] for r in rows[2:]])
    np.testing.assert_allclose(table[:, 2], ref.value.ravel(), rtol=1e-7)
    np.testing.assert_allclose(table[:, 3], ref.dR_dT.ravel(), rtol=1e-5)
    np.testing.assert_allclose(table[:, 4], ref.dR_dH.ravel(), rtol=1e-5)
    assert [r[5:] for r in rows[2:]] == [[str(int(v)), jr.RESULTS.names[c]]
                                         for v, c in zip(ref.valid.ravel(), ref.result.ravel())]
    assert (tmp_path / "map.png").stat().st_size > 0
    out = capsys.readouterr().out
    assert "6 points" in out and "method direct" in out and "map.csv" in out


def test_map_reports_invalid_points_in_one_line_per_reason(material_dir, tmp_path, capsys):
    """A 0.5 mm layer under a 1 cm ball: the contact is as wide as the layer is thick, outside
    both stationary pressure models of the direct method. The points are flagged, not an error:
    exit 0, one warning line per reason on stderr, valid=0 and the reason in the CSV, an empty
    heat map."""
    _, mdir = material_dir
    assert main(["map", "--material", str(mdir / "material.json"), "--H", "0.0005", "--n-temperatures", "2",
                 "--n-speeds", "2", "--method", "direct", "--quiet", "--out", str(tmp_path)]) == 0  # --quiet: warnings only
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("jaxroll map: warning: 4 of 4 points not valid (outside_pressure_model)")
    assert "--pressure elastic or --method full" in err[0]
    assert [r[5:] for r in _rows(tmp_path / "map.csv")[2:]] == [["0", "outside_pressure_model"]] * 4
    assert "0 % valid; no valid point" in captured.out and (tmp_path / "map.png").stat().st_size > 0


def test_map_needs_a_shift_law_and_material_a_readable_file(tmp_path, capsys):
    jr.save_material(tmp_path / "noshift.json", jr.StandardLinearSolid(3e6, 0.25, 1.0).to_prony())
    assert main(["map", "--material", str(tmp_path / "noshift.json"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxroll map: error: --material ") and "no shift law" in err and len(err.splitlines()) == 1
    bad = tmp_path / "bad.csv"
    bad.write_text("f,E_stor,T\nHz,MPa,C\n1,2,3\n")
    assert main(["material", str(bad), "--quiet", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxroll material: error: ") and "no column for ['loss']" in err
    assert len(err.splitlines()) == 1


def test_map_full_method_resolves_one_grid_over_the_temperatures(tmp_path, capsys):
    """``--method full`` (cylinder, narrow one-term spectrum): one grid, the union of the grids the
    coldest and hottest material need, for the whole map; each value agrees with the front
    door's own automatic grid for that point within 1 % (measured 0.3 %), and the progress line
    is on by default for a grid method."""
    mat, wlf = jr.StandardLinearSolid(3e6, 0.25, 1.0).to_prony(), jr.WLF(8.86, 101.6, 293.15)
    jr.save_material(tmp_path / "sls.json", mat, wlf)
    assert main(["map", "--material", str(tmp_path / "sls.json"), "--geometry", "cylinder", "--load", "500",
                 "--tmin", "283", "--tmax", "303", "--n-temperatures", "2", "--n-speeds", "2", "--vmin", "1e-3",
                 "--vmax", "3e-2", "--method", "full", "--out", str(tmp_path / "o")]) == 0
    assert capsys.readouterr().err.startswith("map: 2 temperatures x 2 speeds, cylinder, method full")
    for r in _rows(tmp_path / "o" / "map.csv")[2:]:
        T, V, value = (float(x) for x in r[:3])
        ref = jr.rolling_resistance(jr.at_temperature(mat, wlf, T), jr.Layer(H=0.01), radius=0.01, load=500.0,
                                    speed=V, geometry="cylinder", method="full")
        assert value == pytest.approx(float(ref.value), rel=0.01) and r[5:] == ["1", "successful"]


def test_material_reports_and_optionally_drops_the_loss_artifacts(material_dir, tmp_path, capsys):
    """The shipped file's 100 Hz loss values are reported either way; --drop-loss-artifacts
    leaves them out of the Prony fit (the library's fit with weight 0 on them)."""
    data, default = material_dir
    line = "loss artifacts: 21 loss values at 100 Hz turn up in most sets"
    assert line + " (kept in the Prony fit" in (default / "material_report.txt").read_text()
    assert main(["material", str(data), "--T-ref", "298.15", "--drop-loss-artifacts", "--out", str(tmp_path)]) == 0
    assert line + " (left out of the Prony fit)" in capsys.readouterr().out
    sw = jr.read_dma_sweeps(data)
    master = jr.master_curve(sw, jr.fit_shift_factors(sw, T_ref=298.15))
    weights = np.ones((len(master.omega), 2))
    weights[jr.materials.loss_artifacts(master), 1] = 0.0
    want = jr.fit_prony(master, weights=weights).material
    mat, _ = jr.load_material(tmp_path / "material.json")
    np.testing.assert_allclose(np.asarray(mat.G), np.asarray(want.G), rtol=1e-12)
    info = json.loads((tmp_path / "material.json").read_text())["info"]["prony"]
    assert info["loss_artifacts_hz"] == [100.0] and info["loss_artifacts_left_out"] is True


def test_datasets_lists_and_copies_the_shipped_files(tmp_path, capsys):
    """``jaxroll datasets`` lists every shipped file with its licence; with names it copies them
    byte for byte; an unknown name is a one-line error (exit 2)."""
    assert main(["datasets"]) == 0
    listing = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in listing] == list(jr.datasets.names())
    assert all("licence" in line for line in listing)
    assert main(["datasets", "rolling_example.csv", "LICENSE-pyvisco", "--out", str(tmp_path)]) == 0
    for name in ("rolling_example.csv", "LICENSE-pyvisco"):
        assert (tmp_path / name).read_bytes() == jr.datasets.path(name).read_bytes()
    capsys.readouterr()
    assert main(["datasets", "nonexistent.csv", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "unknown dataset 'nonexistent.csv'" in err and len(err.strip().splitlines()) == 1


def test_unit_slips_print_one_line_each_once(tmp_path, capsys):
    """The issue's slip: ``jaxroll fit ... --radius 20 --H 30`` (mm typed for m) fits a G0 of a few
    Pa. The command line prints each plausibility warning once, as one line without a source
    line: radius and H before the fit, the fitted G0 after it."""
    # the direct method: the warnings' plumbing, not the model, is under test (the default full
    # model would size a grid for a 20 m sphere)
    assert main(["fit", str(jr.datasets.path("synthetic_sphere.csv")), "--radius", "20", "--H", "30", "--starts", "1",
                 "--method", "direct", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err.splitlines()
    slips = [line for line in err if "PlausibilityWarning" in line or "SI units" in line]
    assert len(slips) == 2, err
    assert slips[0].startswith("jaxroll fit: warning: fit_material: radius R = 20 m is above 5 m")
    assert "layer thickness H = 30 m is above 1 m" in slips[0]
    assert slips[1].startswith("jaxroll fit: warning: fit_material: fitted: relaxed shear modulus G0 = ")
    assert not any("warnings.warn" in line or ".py:" in line for line in err)


def test_every_option_has_help_and_the_texts_render_cleanly():
    """Each option of each subcommand carries a help text, and no rendered help shows argparse's
    escape ``%%`` (a literal percent sign in a description is written ``%``)."""
    import argparse

    from jaxroll.apps.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sub.choices.items():
        missing = [a.option_strings or a.dest for a in p._actions if not a.help]
        assert not missing, (name, missing)
        assert "%%" not in p.format_help(), name
        assert p.get_default("progress") in (True, None), name  # progress on by default where offered


def test_material_prony_smoothness_is_the_library_fit(material_dir, tmp_path):
    """--prony-smoothness 1 --phase-sigma 0.2 --modulus-sigma 0.02 writes the library's smoothed
    fit (3 times per decade) under that instrument error model, the phase error given in degrees
    on the command line and in radians to the library (SI), and records and reports the model."""
    data, _ = material_dir
    assert main(["material", str(data), "--T-ref", "298.15", "--prony-smoothness", "1", "--phase-sigma", "0.2",
                 "--modulus-sigma", "0.02", "--out", str(tmp_path)]) == 0
    sw = jr.read_dma_sweeps(data)
    want = jr.fit_prony(jr.master_curve(sw, jr.fit_shift_factors(sw, T_ref=298.15)), smoothness=1.0,
                        phase_sigma=math.radians(0.2), modulus_sigma=0.02)
    assert (want.phase_sigma, want.modulus_sigma) == (math.radians(0.2), 0.02)  # the fit records its error model
    mat, _ = jr.load_material(tmp_path / "material.json")
    np.testing.assert_allclose(np.asarray(mat.G), np.asarray(want.material.G), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(mat.tau), np.asarray(want.material.tau), rtol=1e-12)
    prony = json.loads((tmp_path / "material.json").read_text())["info"]["prony"]
    assert (prony["smoothness"], prony["modulus_sigma"]) == (1.0, 0.02)
    assert prony["phase_sigma"] == pytest.approx(math.radians(0.2), rel=1e-15)  # SI in the file: rad
    assert prony["phase_sigma_deg"] == pytest.approx(0.2, rel=1e-15)
    report = (tmp_path / "material_report.txt").read_text()
    assert "error model: phase_sigma 0.2 deg (3.491 mrad), modulus_sigma 0.02" in report


def test_conveyor_trough_rows_match_the_library(material_dir, tmp_path, capsys):
    """``jaxroll conveyor`` with a three-roll trough: the CSV's line loads are those of
    jr.conveyor.trough_loads, each row's F_ir' is the front door's value at that point (the direct
    method named explicitly: plumbing, not the method, is under test) and the summary line per
    temperature and speed sums the rolls."""
    _, mdir = material_dir
    argv = ["conveyor", "--material", str(mdir / "material.json"), "--belt-width", "1.2", "--belt-mass", "20",
            "--bulk-mass", "150", "--idler-spacing", "1.2", "--roll-length", "0.465", "--trough-angle", "35",
            "--temperatures", "298.15", "--speeds", "2,5", "--n-idlers", "100", "--method", "direct", "--quiet",
            "--out", str(tmp_path)]
    assert main(argv) == 0
    L = jr.conveyor.trough_loads(belt_width=1.2, belt_mass=20.0, bulk_mass=150.0, spacing=1.2, roll_length=0.465,
                                 trough_angle=np.radians(35.0))
    rows = _rows(tmp_path / "conveyor.csv")
    assert rows[0][:6] == ["temperature", "speed", "line_load", "F_ir_per_width", "F_ir_per_idler", "coefficient"]
    assert rows[0][-2:] == ["valid", "result"] and len(rows) == 2 + 2 * 2
    table = np.array([[float(x) for x in r[:4]] for r in rows[2:]])
    np.testing.assert_allclose(table[:2, 2], L.line_load, rtol=1e-7)  # 8 digits in the CSV
    mat, shift = jr.load_material(mdir / "material.json")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.ValidityWarning)
        ref = jr.rolling_resistance_grid(jr.at_temperature(mat, shift, 298.15), jr.Layer(0.006), radius=0.0795,
                                         loads=np.sort(L.line_load), speeds=[2.0, 5.0], geometry="cylinder",
                                         method="direct")
    np.testing.assert_allclose(table[:, 3], np.asarray(ref.value)[:, ::-1].ravel(), rtol=1e-7)
    out = capsys.readouterr().out
    F = np.dot(L.count, table[2:, 3] * L.contact_length)
    assert "center roll F_z" in out and f"F_ir {F:.4g} N per idler set" in out and "100 sets" in out
