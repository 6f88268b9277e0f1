"""Raw multi-temperature DMA -> shift factors -> WLF -> master curve -> Prony series -> exports.

Oracles: the shipped file parsed independently (numpy), synthetic sweeps made from a KNOWN
Prony series and KNOWN WLF constants (the fit must recover them), exact round trips of the
exports, and pyvisco (the peer, skipped when not installed) on the shipped file."""

import math
import warnings

import numpy as np
import pytest

import jaxroll as jr
from jaxroll.identify.fit import DataWarning

DATA = jr.datasets.path("pyvisco_freq_user_raw.csv")

# a known broad spectrum (shear, Pa, s), G_i ~ tau_i^-0.2 one time per decade over 1e-13..1e4 s:
# log G' rises by ~0.2 per decade over the whole reduced range of the sweeps below
TRUE_MAT = jr.GeneralizedMaxwell(G_inf=1e6, G=2e5 * 10.0 ** (0.2 * np.arange(18))[::-1], tau=np.logspace(-13, 4, 18))
TRUE_WLF = jr.WLF(C1=8.86, C2=101.6, T_ref=293.15)
TEMPS = np.arange(243.15, 354.0, 10.0)  # -30..80 degC
FREQS_HZ = np.logspace(-1, 2, 10)


def _write_sweeps(path, *, noise=0.01, seed=0, outlier=True, upturn=1.0, material=TRUE_MAT,
                  header="f,G_stor,G_loss,T,Set\nHz,MPa,MPa,C,-\n"):
    """Sweeps of TRUE_MAT shifted by TRUE_WLF, 1 % multiplicative noise; the first
    (low-frequency) point of every third set 15 % low (a settling artifact); the loss at the
    top frequency of every set times ``upturn`` (an instrument artifact)."""
    rng = np.random.default_rng(seed)
    lines = [header]
    for s, T in enumerate(TEMPS):
        g = np.asarray(jr.complex_modulus(jr.at_temperature(material, TRUE_WLF, T), 2 * np.pi * FREQS_HZ))
        gs = g.real * (1 + noise * rng.standard_normal(g.size))
        gl = g.imag * (1 + noise * rng.standard_normal(g.size))
        if outlier and s % 3 == 0:
            gs[0] *= 0.85
        gl[-1] *= upturn
        for f, a, b in zip(FREQS_HZ, gs, gl):
            lines.append(f"{f:.8g},{a / 1e6:.8g},{b / 1e6:.8g},{T - 273.15 + 0.1 * rng.standard_normal():.4f},{s}\n")
    path.write_text("".join(lines))
    return path


# ---------------------------------------------------------------------------------------- reader


def test_reader_round_trips_the_shipped_file():
    raw = np.genfromtxt(DATA, delimiter=",", skip_header=2)  # independent parse: f, E', E'', T, Set
    sw = jr.read_dma_sweeps(DATA)
    assert sw.n_sets == 21 and len(sw.omega) == 210 and sw.source == "tension, nu = 0.5"
    np.testing.assert_allclose(sw.omega, 2 * np.pi * raw[:, 0], rtol=1e-15)
    np.testing.assert_allclose(sw.storage, raw[:, 1] * 1e6 / 3, rtol=1e-15)  # G = E / (2 (1 + 0.5))
    np.testing.assert_allclose(sw.loss, raw[:, 2] * 1e6 / 3, rtol=1e-15)
    np.testing.assert_allclose(sw.temperature, raw[:, 3] + 273.15, rtol=1e-15)
    np.testing.assert_array_equal(sw.set, raw[:, 4].astype(int))  # the file's sets are already in T order
    want = [raw[raw[:, 4] == s, 3].mean() + 273.15 for s in range(21)]
    np.testing.assert_allclose(sw.set_temperature, want, rtol=1e-14)
    np.testing.assert_allclose(jr.read_dma_sweeps(DATA, poisson=0.35).storage, raw[:, 1] * 1e6 / 2.7, rtol=1e-15)


def test_reader_variants(tmp_path):
    """Units in the names, shear data, temperature per set, no Set column: the same sweeps."""
    ref = jr.read_dma_sweeps(_write_sweeps(tmp_path / "a.csv"))
    assert ref.source == "shear"
    text = (tmp_path / "a.csv").read_text().splitlines()
    # units in the names, kPa, kelvin, no Set column (sets found from the temperatures)
    rows = ["freq [Hz],G' [kPa],G'' [kPa],temperature [K]"]
    for line in text[2:]:
        f, a, b, T, _ = line.split(",")
        rows.append(f"{f},{float(a) * 1e3!r},{float(b) * 1e3!r},{float(T) + 273.15!r}")
    (tmp_path / "b.csv").write_text("\n".join(rows) + "\n")
    b = jr.read_dma_sweeps(tmp_path / "b.csv")
    np.testing.assert_array_equal(b.set, ref.set)
    np.testing.assert_allclose(b.storage, ref.storage, rtol=1e-12)
    np.testing.assert_allclose(b.set_temperature, ref.set_temperature, rtol=1e-12)
    # temperature per set: only on the first row of each set
    rows = [text[0], text[1]]
    for k, line in enumerate(text[2:]):
        f, a, bb, T, s = line.split(",")
        rows.append(",".join([f, a, bb, f"{TEMPS[int(s)] - 273.15:.2f}" if k % 10 == 0 else "", s]))
    (tmp_path / "c.csv").write_text("\n".join(rows) + "\n")
    c = jr.read_dma_sweeps(tmp_path / "c.csv")
    np.testing.assert_allclose(c.set_temperature, TEMPS, atol=1e-9)
    np.testing.assert_allclose(c.loss, ref.loss, rtol=1e-12)


@pytest.mark.parametrize("content, match", [
    ("f,E_stor,E_loss,T\n0.1,1,1,20\n", "has no unit"),
    ("f,E_stor,E_loss,T\nHz,MPa,MPa,C\n0.1,1,x,20\n", "line 3: E_loss = 'x' is not a number"),
    ("f,E_stor,E_loss,T\nHz,MPa,MPa,C\n0.1,1,-2,20\n", "line 3: E_loss must be positive, got -2 MPa"),
    ("f,E_stor,G_loss,T\nHz,MPa,MPa,C\n0.1,1,1,20\n", "mix tension"),
    ("f,E_stor,E_loss\nHz,MPa,MPa\n0.1,1,1\n", r"no column for \['temperature'\]"),
    ("f,E_stor,E_loss,T\nHz,bar,MPa,C\n0.1,1,1,20\n", "unit 'bar' of column 'E_stor'"),
    ("f,E_stor,E_loss,T,Set\nHz,MPa,MPa,C,-\n0.1,1,1,,0\n", "line 3: set 0 has no temperature"),
])
def test_reader_errors_name_line_and_column(tmp_path, content, match):
    p = tmp_path / "bad.csv"
    p.write_text(content)
    with pytest.raises(ValueError, match=match):
        jr.read_dma_sweeps(p)


def test_reader_warns_about_unused_columns(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("f,E_stor,E_loss,T,tan_delta\nHz,MPa,MPa,C,-\n0.1,1,1,20,1\n1,2,1,20,0.5\n")
    with pytest.warns(DataWarning, match="tan_delta"):
        jr.read_dma_sweeps(p)


# ------------------------------------------------------------------------------ shift factors, WLF


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    sw = jr.read_dma_sweeps(_write_sweeps(tmp_path_factory.mktemp("dma") / "syn.csv"))
    sh = jr.fit_shift_factors(sw, T_ref=293.15)
    return sw, sh


def test_shift_factors_recover_known_wlf(synthetic):
    sw, sh = synthetic
    assert sh.reference == 5
    # the truth at each set's measured mean temperature, re-referenced to the reference set's
    true = np.log10(np.asarray(jr.materials.shift_factor(TRUE_WLF, sh.temperature)))
    true -= true[sh.reference]
    err = sh.log10_aT - true
    # 1 % noise and a 15 % low first point in every third set: each step within 0.1 decade
    # (typically 0.02; the worst is the coldest set, whose low first point is also the end of
    # the chain), the accumulated shift over 5 steps within 0.12 decade, within 3 stated sigmas
    assert np.max(np.abs(np.diff(err))) < 0.1, err
    assert np.max(np.abs(err)) < 0.12, err
    assert np.all(np.abs(err) <= 3 * sh.sigma + 1e-12), (err, sh.sigma)


def test_wlf_fit_recovers_constants_with_intervals(synthetic):
    _, sh = synthetic
    fit = jr.fit_wlf(sh)
    # T_ref is the reference set's mean temperature, a few 0.01 K off 293.15: re-reference
    # the truth (WLF at a new reference: C2' = C2 + dT, C1' = C1 C2 / C2')
    dT = sh.T_ref - 293.15
    C2 = TRUE_WLF.C2 + dT
    C1 = TRUE_WLF.C1 * TRUE_WLF.C2 / C2
    # within 2 % (seeds 0-2: C1 -1.3..+0.5 %, C2 -0.5..+0.3 %). The intervals are ordinary
    # least-squares ones: they ignore that the chained shift factors share their steps'
    # errors, so they are optimistic (seed 1's C1 interval misses the truth by 0.6 %)
    assert abs(fit.params["C1"] / C1 - 1) < 0.02 and abs(fit.params["C2"] / C2 - 1) < 0.02
    for name in ("C1", "C2"):
        lo, hi = fit.ci95[name]
        assert lo < fit.params[name] < hi and 0 < hi - lo < 0.1 * fit.params[name]
    assert fit.rms < 0.05
    assert isinstance(fit.shift, jr.WLF) and float(fit.shift.T_ref) == sh.T_ref
    # C1 and C2 of WLF are strongly correlated: the covariance says so
    corr = fit.covariance[0, 1] / math.sqrt(fit.covariance[0, 0] * fit.covariance[1, 1])
    assert corr > 0.9


def test_arrhenius_fit_recovers_activation_energy(tmp_path):
    """Noise-free data shifted by a known Arrhenius law: E_a back within 0.5 % (the residual
    error is the local quadratic curves' model error, not noise)."""
    true = jr.Arrhenius(activation_energy=2.0e5, T_ref=293.15)
    sw = jr.read_dma_sweeps(_write_sweeps(tmp_path / "a.csv"))
    # rebuild the sweeps with the Arrhenius shift instead of WLF (same noise-free material)
    g = np.asarray(jr.complex_modulus(jr.at_temperature(TRUE_MAT, true, sw.temperature), sw.omega))
    sw = jr.materials.DMASweeps(sw.omega, g.real, g.imag, sw.temperature, sw.set, sw.set_temperature)
    fit = jr.materials.fit_arrhenius(jr.fit_shift_factors(sw, T_ref=293.15))
    assert abs(fit.params["activation_energy"] / 2.0e5 - 1) < 0.005


def test_shift_needs_two_sets_and_valid_moduli_choice(synthetic):
    sw, _ = synthetic
    with pytest.raises(ValueError, match="moduli must be"):
        jr.fit_shift_factors(sw, moduli="tan")
    one = jr.materials.DMASweeps(sw.omega[:10], sw.storage[:10], sw.loss[:10], sw.temperature[:10], sw.set[:10],
                       sw.set_temperature[:1])
    with pytest.raises(ValueError, match="two or more temperatures"):
        jr.fit_shift_factors(one)


def test_shift_with_both_moduli_on_clean_data(synthetic):
    sw, sh = synthetic
    both = jr.fit_shift_factors(sw, T_ref=293.15, moduli="both")
    np.testing.assert_allclose(both.log10_aT, sh.log10_aT, atol=0.08)


# ---------------------------------------------------------------------------------------- Prony


def test_one_term_prony_recovered():
    true = jr.StandardLinearSolid(G0=1e6, tau=0.02, f=2.0).to_prony()
    w = np.logspace(-1, 5, 40)
    g = np.asarray(jr.complex_modulus(true, w))
    master = jr.materials.MasterCurve(w, g.real, g.imag, np.zeros(w.size, int), 293.15)
    fit = jr.fit_prony(master, n_terms=1)
    assert fit.n_terms == 1
    np.testing.assert_allclose(float(fit.material.G_inf), 1e6, rtol=1e-6)
    np.testing.assert_allclose(np.asarray(fit.material.G), np.asarray(true.G), rtol=1e-6)
    np.testing.assert_allclose(np.asarray(fit.material.tau), np.asarray(true.tau), rtol=1e-6)
    assert fit.rms < 1e-8
    # with the default one time per decade, NNLS + refinement reproduces the curves
    many = jr.fit_prony(master)
    assert many.rms < 2e-3
    np.testing.assert_allclose(float(many.material.glassy_modulus()), 3e6, rtol=5e-3)


def test_end_to_end_synthetic_master_curve_matches_known_material(synthetic):
    sw, sh = synthetic
    fit = jr.fit_prony(jr.master_curve(sw, sh))
    # the known material at the fitted reference temperature, over the data's reduced range
    ref = jr.at_temperature(TRUE_MAT, TRUE_WLF, sh.T_ref)
    m = jr.master_curve(sw, sh)
    w = np.logspace(np.log10(m.omega.min()), np.log10(m.omega.max()), 60)
    got, want = np.asarray(jr.complex_modulus(fit.material, w)), np.asarray(jr.complex_modulus(ref, w))
    # 1 % noise, shift errors <= 0.12 decade (log G' rising 0.2 per decade): within 12 % at
    # the ends of the range (the coldest set's shift error), 4 % rms
    for part in (np.real, np.imag):
        rel = np.log(part(got) / part(want))
        assert np.max(np.abs(rel)) < 0.12 and np.sqrt(np.mean(rel**2)) < 0.04
    assert fit.rms < 0.05


def test_prony_weights_leave_values_out():
    """A loss value 100 x off with weight 0 does not move the one-term fit (exact recovery);
    unit weights are the default; a wrong shape or a negative weight is refused."""
    true = jr.StandardLinearSolid(G0=1e6, tau=0.02, f=2.0).to_prony()
    w = np.logspace(-1, 5, 40)
    g = np.asarray(jr.complex_modulus(true, w))
    loss = g.imag.copy()
    loss[7] *= 100.0
    master = jr.materials.MasterCurve(w, g.real, loss, np.zeros(w.size, int), 293.15)
    weights = np.ones((w.size, 2))
    weights[7, 1] = 0.0
    fit = jr.fit_prony(master, n_terms=1, weights=weights)
    np.testing.assert_allclose(np.asarray(fit.material.tau), np.asarray(true.tau), rtol=1e-6)
    assert fit.rms < 1e-8 and fit.residuals[7, 1] == pytest.approx(-math.log(100.0), rel=1e-6)
    np.testing.assert_array_equal(fit.weights, weights)
    plain = jr.fit_prony(master, n_terms=1)
    assert jr.fit_prony(master, n_terms=1, weights=np.ones((w.size, 2))).rms == plain.rms and plain.rms > 0.1
    for bad in (np.ones((w.size, 1)), -weights):
        with pytest.raises(ValueError, match="weights must be finite, >= 0"):
            jr.fit_prony(master, weights=bad)


def test_loss_artifacts_flag_a_top_frequency_upturn_and_nothing_in_clean_sweeps(tmp_path):
    """The rule flags exactly the loss values at the top frequency when every set's loss there
    is 25 % high (the shipped file's median excess at 100 Hz is ~21 %), and nothing in the same
    sweeps without it; leaving them out brings the fitted loss back to the known material over
    the reduced frequencies the remaining loss values cover (beyond, the fit extrapolates).
    The known spectrum has three times per decade (TRUE_MAT's one per decade ripples the loss
    by ~+-15 % between its times, more than a real compound's smooth loss and the artifact)."""
    smooth = jr.GeneralizedMaxwell(G_inf=1e6, G=2e5 / 3 * 10.0 ** (0.2 * np.arange(52) / 3)[::-1],
                                   tau=np.logspace(-13, 4, 52))
    fits = {}
    for name, upturn in (("clean", 1.0), ("bent", 1.25)):
        sw = jr.read_dma_sweeps(_write_sweeps(tmp_path / f"{name}.csv", upturn=upturn, material=smooth))
        sh = jr.fit_shift_factors(sw, T_ref=293.15)  # storage only: the same shifts for both files
        m = jr.master_curve(sw, sh)
        flagged = jr.materials.loss_artifacts(m)
        top = np.isclose(m.frequency, 2 * np.pi * FREQS_HZ[-1])
        np.testing.assert_array_equal(flagged, top if upturn > 1 else np.zeros_like(top))
        weights = np.ones((len(m.omega), 2))
        weights[flagged, 1] = 0.0
        fits[name] = (m, jr.fit_prony(m), jr.fit_prony(m, weights=weights))
    m, _, _ = fits["bent"]
    w = np.logspace(np.log10(m.omega.min()), np.log10(m.omega[~jr.materials.loss_artifacts(m)].max()), 200)
    want = np.asarray(jr.materials.loss_modulus(jr.at_temperature(smooth, TRUE_WLF, 293.15), w))

    def loss_error(fit):
        return float(np.sqrt(np.mean(np.log(np.asarray(jr.materials.loss_modulus(fit.material, w)) / want) ** 2)))

    _, kept, dropped = fits["bent"]
    clean = loss_error(fits["clean"][1])
    # measured rms log error: 0.039 clean, 0.048 with the artifact fitted, 0.034 without it
    assert loss_error(dropped) < min(loss_error(kept) - 0.005, 1.2 * clean)
    assert loss_error(kept) > 1.1 * clean


def test_loss_artifacts_of_the_shipped_file_are_its_100_hz_loss_values():
    """The shipped file's loss turns up at 100 Hz in every set: the rule flags those 21 values
    and nothing else; the fit without them follows the rest of the master curve closer (loss
    rms 0.144 -> 0.128, storage 0.087 -> 0.072) with the same 33 terms. The glassy modulus
    barely moves (4.04 -> 3.98 GPa): what lifts it above the measured ~3.1 GPa is the glassy
    loss itself, which by Kramers-Kronig asks for a steeper G' than measured."""
    sw = jr.read_dma_sweeps(DATA)
    m = jr.master_curve(sw, jr.fit_shift_factors(sw, T_ref=298.15))
    flagged = jr.materials.loss_artifacts(m)
    np.testing.assert_array_equal(flagged, np.isclose(m.frequency, 2 * np.pi * 100.0, rtol=1e-6))
    weights = np.ones((len(m.omega), 2))
    weights[flagged, 1] = 0.0
    kept, dropped = jr.fit_prony(m), jr.fit_prony(m, weights=weights)

    def rms(fit, k, mask):
        return float(np.sqrt(np.mean(fit.residuals[mask, k] ** 2)))

    assert rms(dropped, 1, ~flagged) < rms(kept, 1, ~flagged) - 0.01
    assert rms(dropped, 0, slice(None)) < rms(kept, 0, slice(None)) - 0.01
    assert 3.9e9 < float(dropped.material.glassy_modulus()) < float(kept.material.glassy_modulus())
    with pytest.raises(ValueError, match="measured frequency"):
        jr.materials.loss_artifacts(jr.materials.MasterCurve(m.omega, m.storage, m.loss, m.set, m.T_ref))


# ---------------------------------------------------------------------------------------- exports


def _material():
    return jr.GeneralizedMaxwell(G_inf=1.25e6, G=np.array([3.5e6, 1.1e7, 2.2e8]), tau=np.array([1e-6, 3e-3, 7.5]))


@pytest.mark.parametrize("suffix", [".json", ".csv"])
def test_save_load_round_trip(tmp_path, suffix):
    mat, wlf = _material(), jr.WLF(C1=9.1, C2=105.3, T_ref=298.15)
    jr.save_material(tmp_path / f"m{suffix}", mat, wlf)
    got, shift = jr.load_material(tmp_path / f"m{suffix}")
    assert float(got.G_inf) == float(mat.G_inf)
    np.testing.assert_array_equal(np.asarray(got.G), np.asarray(mat.G))
    np.testing.assert_array_equal(np.asarray(got.tau), np.asarray(mat.tau))
    assert (float(shift.C1), float(shift.C2), float(shift.T_ref)) == (9.1, 105.3, 298.15)
    arr = jr.Arrhenius(activation_energy=1.5e5, T_ref=300.0)
    jr.save_material(tmp_path / f"a{suffix}", mat, arr)
    assert float(jr.load_material(tmp_path / f"a{suffix}")[1].activation_energy) == 1.5e5


def test_abaqus_and_ansys_exports(tmp_path):
    mat, wlf = _material(), jr.WLF(C1=9.1, C2=105.3, T_ref=298.15)
    G0 = 1.25e6 + 3.5e6 + 1.1e7 + 2.2e8
    jr.materials.write_abaqus(mat, tmp_path / "m.inp", shift=wlf, poisson=0.49)
    lines = (tmp_path / "m.inp").read_text().splitlines()
    i = lines.index("*VISCOELASTIC, TIME=PRONY")
    table = np.array([[float(v) for v in ln.split(",")] for ln in lines[i + 1 : i + 4]])
    np.testing.assert_allclose(table[:, 0] * G0, [3.5e6, 1.1e7, 2.2e8], rtol=1e-9)
    np.testing.assert_array_equal(table[:, 1], 0.0)
    np.testing.assert_allclose(table[:, 2], [1e-6, 3e-3, 7.5], rtol=1e-9)
    j = lines.index("*ELASTIC, MODULI=INSTANTANEOUS")
    E0, nu = (float(v) for v in lines[j + 1].split(","))
    assert nu == 0.49 and math.isclose(E0, 2 * G0 * 1.49, rel_tol=1e-9)
    assert lines[i + 4] == "*TRS, DEFINITION=WLF"
    np.testing.assert_allclose([float(v) for v in lines[i + 5].split(",")], [298.15, 9.1, 105.3])

    jr.materials.write_ansys(mat, tmp_path / "m.mac", shift=wlf)
    text = (tmp_path / "m.mac").read_text().splitlines()
    assert "TB,PRONY,1,,3,SHEAR" in text
    data = [ln for ln in text if ln.startswith("TBDATA,1,") and "TB,SHIFT" not in ln]
    vals = np.array([float(v) for v in data[0].split(",")[2:]])
    np.testing.assert_allclose(vals[0::2] * G0, [3.5e6, 1.1e7, 2.2e8], rtol=1e-9)  # a_i = G_i / G_0
    np.testing.assert_allclose(vals[1::2], [1e-6, 3e-3, 7.5], rtol=1e-9)
    k = text.index("TB,SHIFT,1,,3,WLF")
    np.testing.assert_allclose([float(v) for v in text[k + 1].split(",")[2:]], [298.15, 9.1, 105.3])


def test_load_material_rejects_other_files(tmp_path):
    (tmp_path / "x.json").write_text('{"G": [1]}')
    with pytest.raises(ValueError, match="not a jaxroll material file"):
        jr.load_material(tmp_path / "x.json")
    with pytest.raises(ValueError, match="use a .json or .csv"):
        jr.load_material(tmp_path / "x.txt")


# ---------------------------------------------------------------------------------------- the shipped data


@pytest.fixture(scope="module")
def shipped():
    sw = jr.read_dma_sweeps(DATA)
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    return sw, sh, jr.fit_wlf(sh), jr.fit_prony(jr.master_curve(sw, sh))


def test_shipped_pipeline(shipped):
    sw, sh, wlf, pf = shipped
    assert abs(sh.T_ref - 298.15) < 0.2
    assert np.all(np.diff(sh.log10_aT) < 0)  # hotter: faster
    lo, hi = wlf.ci95["C1"]
    assert lo < wlf.params["C1"] < hi and wlf.params["C2"] > sh.T_ref - sh.temperature[0]
    # the Prony curve follows the measured master curve (its scatter: ~9 % in G', ~19 % in G'')
    assert pf.rms < 0.2 and pf.n_terms >= 10
    # physical bounds: G_inf near the rubbery plateau, G_0 near the glassy one (E/3)
    assert 0.5 < float(pf.material.G_inf) / (256.5e6 / 3) < 1.5
    assert 0.8 < float(pf.material.glassy_modulus()) / (9228.6e6 / 3) < 1.6


def test_peer_pyvisco(shipped):
    """pyvisco (NREL, BSD-3) on the same file at the same reference set (25 degC).

    Tolerances and why: pyvisco shifts each set by the mean horizontal distance between power
    laws fitted to the two sets' E'; we minimise a robust vertical distance to a quadratic in
    log-log. Where E' has slope (above about -5 degC) the two agree to 0.1 decade; in the
    glassy region E' changes by ~0.01 decade per decade of frequency, the shift is weakly
    determined (our sigma ~0.2 decade) and the accumulated difference reaches 0.3 decade at
    -50 degC (within 2.5 of our sigmas). WLF: both least squares of log a_T (pyvisco bounds
    C1, C2 <= 5000, not active here), so the constants agree to 10 %; the laws differ by up to
    0.37 decade at -50 degC, the end of the range, well inside the WLF fit's own rms residual
    (0.67 decade: one WLF law does not describe the glassy and the rubbery side alike).
    Prony: pyvisco fits E/E_0 in absolute terms (the loss, 1-5 % of E_0 in the glass, barely
    counts), we fit relative errors of both: the storage curves agree to 25 % (rms 12 %) over
    the measured range; for the loss we check that ours is the closer to the measured master
    curve."""
    pyvisco = pytest.importorskip("pyvisco")
    sw, sh, wlf, pf = shipped
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df_raw, _, _ = pyvisco.load.user_raw(pyvisco.load.file(str(DATA)), "freq", "E")
        df_aT, _ = pyvisco.master.get_aT(df_raw, 25)
        pv_wlf = pyvisco.shift.fit_WLF(25, df_aT)
        df_master = pyvisco.master.smooth(pyvisco.master.get_curve(df_raw, df_aT, 25), 1)
        prony, _ = pyvisco.prony.fit(pyvisco.prony.discretize(df_master, "round"), df_master, opt=True)
    np.testing.assert_allclose(df_aT["T"].values, np.round(sh.temperature - 273.15))
    diff = sh.log10_aT - df_aT["log_aT"].values
    assert np.max(np.abs(diff)) < 0.35, diff
    assert np.max(np.abs(diff[sh.temperature > 268.15])) < 0.12, diff
    assert np.all(np.abs(diff) < 2.5 * sh.sigma + 0.02)
    C1, C2 = float(pv_wlf["C1"].iloc[0]), float(pv_wlf["C2"].iloc[0])
    assert abs(wlf.params["C1"] / C1 - 1) < 0.1 and abs(wlf.params["C2"] / C2 - 1) < 0.1
    dT = sh.temperature - 298.15
    ours = np.log10(np.asarray(jr.materials.shift_factor(wlf.shift, sh.temperature)))
    assert np.max(np.abs(ours - (-C1 * dT / (C2 + dT)))) < 0.45 and wlf.rms > 0.45

    E0, a, tau = prony["E_0"] * 1e6, prony["df_terms"]["alpha_i"].values, prony["df_terms"]["tau_i"].values

    def pv_moduli(w):
        x = w * tau[:, None]
        return E0 * (1 - a.sum()) + (E0 * a) @ (x**2 / (1 + x**2)), (E0 * a) @ (x / (1 + x**2))

    m = jr.master_curve(sw, sh)
    w = np.logspace(np.log10(m.omega.min()), np.log10(m.omega.max()), 200)
    es, _ = pv_moduli(w)
    ours = 3.0 * np.asarray(jr.materials.storage_modulus(pf.material, w))  # E = 2 (1 + 0.5) G
    rel = np.log(ours / es)
    assert np.max(np.abs(rel)) < 0.25 and np.sqrt(np.mean(rel**2)) < 0.12
    wm = df_master["omega"].values
    ps, pl = pv_moduli(wm)
    pv_rms_loss = np.sqrt(np.mean(np.log(pl / (df_master["E_loss"].values * 1e6)) ** 2))
    assert np.sqrt(np.mean(pf.residuals[:, 1] ** 2)) < pv_rms_loss


# ---------------------------------------------------------------------------------------- maps


@pytest.mark.parametrize("geometry, load", [("sphere", 5.0), ("cylinder", 500.0)])
def test_resistance_map_values_and_gradients(tmp_path, geometry, load):
    """Each map point equals the front door's value at that temperature; dR/dT and dR/dH
    agree with central finite differences of the front door (1e-4 relative)."""
    mat = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=1.0).to_prony()
    wlf = jr.WLF(C1=8.86, C2=101.6, T_ref=293.15)
    layer = jr.Layer(H=0.01)
    Ts, Vs = np.array([283.15, 303.15]), np.array([1e-3, 3e-2])
    m = jr.resistance_map(mat, wlf, layer, radius=0.01, load=load, temperatures=Ts, speeds=Vs, geometry=geometry)
    assert m.value.shape == (2, 2) and m.valid.all() and m.seconds > 0
    assert m.result.shape == (2, 2) and np.all(m.result == jr.RESULTS.successful)

    def rr(T, V, H):
        return float(jr.rolling_resistance(jr.at_temperature(mat, wlf, T), jr.Layer(H=H), radius=0.01, load=load,
                                           speed=V, geometry=geometry, method="direct").value)

    for i, T in enumerate(Ts):
        for j, V in enumerate(Vs):
            assert math.isclose(m.value[i, j], rr(T, V, 0.01), rel_tol=1e-12)
            fd_T = (rr(T + 0.01, V, 0.01) - rr(T - 0.01, V, 0.01)) / 0.02
            fd_H = (rr(T, V, 0.01 * (1 + 1e-5)) - rr(T, V, 0.01 * (1 - 1e-5))) / 2e-7
            assert math.isclose(m.dR_dT[i, j], fd_T, rel_tol=1e-4), (m.dR_dT[i, j], fd_T)
            assert math.isclose(m.dR_dH[i, j], fd_H, rel_tol=1e-4), (m.dR_dH[i, j], fd_H)
    m.write_csv(tmp_path / "map.csv")
    table = np.genfromtxt(tmp_path / "map.csv", delimiter=",", skip_header=2)
    np.testing.assert_allclose(table[:, 2].reshape(2, 2), m.value, rtol=1e-7)
