"""Loss-curve extrema and glassy-plateau bias of Prony fits to the shipped master curve and a
synthetic one (docs/dma.md, "Smooth Prony series" and "The glassy plateau"): the smoothed fits, and the
instrument error model of the joint storage/loss fit (``phase_sigma``) against a storage-only fit
and the storage that the measured loss implies by Kramers-Kronig.

Plateau bias: the fit's storage over the measured storage on the coldest set (mean relative
error) on the shipped file; on a Kramers-Kronig-consistent synthetic curve with a glassy plateau
(:func:`synthetic`), sampled with the instrument errors, the fit's glassy storage over the true
one. (The instrument-layout files of tests/data hold four sets of the shipped file 38-60 K apart
that do not overlap: they test the readers, not a master curve.) Loss near the peak: the rms log residual of the loss where
tan delta is above half its maximum. Kramers-Kronig consistency of the data: a loss-only fit
(a Prony series is KK-consistent by construction) gives the storage the measured loss implies,
up to the constant ``G_inf``, set so that it meets the measured storage on the warmest set; its
plateau bias is computed for the measured phase and for the phase moved by -4..+1 times
``INSTRUMENT_PHASE_SIGMA`` (0.1 deg).

With ``--rolling``: the extrema in temperature of the rolling resistance of a 1 cm ball (10 N,
H = 10 mm) from -40 to 100 degC, by the direct method (1 K steps; 1 mm/s, 0.1 m/s, 1 m/s),
for the fewest-terms fit, smoothness 1 and 3 (the default), and the default with the instrument
error model (``phase_sigma`` 0.1 deg); and the change of R(T) between the two, by the direct
method and by the full 3D model (5 K steps; 1 mm/s, 1 m/s).

Run: ``python benchmarks/prony_smoothness.py [--rolling] [--record]`` (a minute; several with
--rolling). ``--record`` stores the tables in benchmarks/numbers.json (``prony_plateau``; with
``--rolling``, ``prony_rolling``) for ``benchmarks/render_docs.py``."""

import sys
from pathlib import Path

import numpy as np

import jaxroll as jr
from jaxroll.materials import prony

DATA = jr.datasets.path("pyvisco_freq_user_raw.csv")
PHASES = (0.0, 1e-3, prony.INSTRUMENT_PHASE_SIGMA, 3e-3)
#: tan delta bands of the loss bias (mean log residual of the loss): plateaus, transition, peak
BANDS = (("< 0.02", 0.0, 0.02), ("0.02-0.1", 0.02, 0.1), (">= 0.1", 0.1, np.inf))


def master(path):
    sw = jr.read_dma_sweeps(path)
    return jr.master_curve(sw, jr.materials.fit_shift_factors(sw))


def cold_bias(mc, material):
    """Mean relative error of the fit's storage on the coldest set."""
    cold = mc.set == mc.set.min()
    return float(np.mean(np.asarray(jr.complex_modulus(material, mc.omega[cold])).real / mc.storage[cold] - 1))


def row(mc, pf, label):
    """Plateau bias, rms of storage and loss log residuals, loss rms near the peak."""
    tan = mc.loss / mc.storage
    peak = tan >= 0.5 * tan.max()
    r = pf.residuals
    bands = {name: (tan >= lo) & (tan < hi) for name, lo, hi in BANDS}
    return {"fit": label, "terms": pf.n_terms, "cold_bias": cold_bias(mc, pf.material),
            "rms_storage": float(np.sqrt(np.mean(r[:, 0] ** 2))), "rms_loss": float(np.sqrt(np.mean(r[:, 1] ** 2))),
            "rms_loss_peak": float(np.sqrt(np.mean(r[peak, 1] ** 2))),
            "loss_bias_by_tan": {k: float(np.mean(r[b, 1])) for k, b in bands.items() if b.any()}}


def kk_implied_bias(mc, dphi=0.0):
    """Plateau bias of the storage the loss implies (Kramers-Kronig through a loss-only Prony fit),
    with the measured phase moved by ``dphi`` [rad]; ``G_inf`` meets the warmest set's storage."""
    mag, delta = np.hypot(mc.storage, mc.loss), np.arctan2(mc.loss, mc.storage) + dphi
    moved = jr.materials.MasterCurve(mc.omega, mag * np.cos(delta), mag * np.sin(delta), mc.set, mc.T_ref)
    w = np.ones((len(mc.omega), 2))
    w[:, 0] = 0.0
    mat = jr.fit_prony(moved, weights=w, phase_sigma=0.0).material
    relaxing = np.asarray(jr.complex_modulus(mat, mc.omega)).real - mat.G_inf
    warm = mc.set == mc.set.max()
    g_inf = float(np.median(mc.storage[warm] - relaxing[warm]))
    cold = mc.set == mc.set.min()
    return float(np.mean((g_inf + relaxing[cold]) / mc.storage[cold] - 1))


def plateau_rows(mc):
    """The error-model rows of one master curve."""
    rows = [row(mc, jr.fit_prony(mc, phase_sigma=p), f"phase_sigma {p * 1e3:.2f} mrad") for p in PHASES]
    w = np.ones((len(mc.omega), 2))
    w[:, 1] = 0.0
    rows.append(row(mc, jr.fit_prony(mc, weights=w, phase_sigma=0.0), "storage only"))
    kk = {f"{s:+d}": kk_implied_bias(mc, s * prony.INSTRUMENT_PHASE_SIGMA) for s in (-4, -2, -1, 0, 1)}
    return {"rows": rows, "kk_implied": kk}


def synthetic(n_omega=161, seed=2):
    """``(true material, omega)``: a spectrum with a log-normal peak (1e7 Pa per term, 10 per decade,
    centred at 0.1 s, 2 decades wide) on a flat background (5e5 Pa per term below 1 ms, 1e4 Pa
    above) from 1e-14 to 1e8 s, G_inf = 1 MPa; sampled at ``n_omega`` frequencies over 1e-6..1e10
    rad/s: tan delta 0.006-0.8, a glassy plateau above 1e8 rad/s."""
    tau = np.logspace(-14, 8, 221)
    G = 1e7 * np.exp(-0.5 * ((np.log10(tau) + 1) / 2.0) ** 2) + np.where(tau < 1e-3, 5e5, 1e4)
    return jr.GeneralizedMaxwell(G_inf=1e6, G=G, tau=tau), np.logspace(-6, 10, n_omega)


def synthetic_rows(seed=2):
    """Glassy (omega > 1e8 rad/s) storage bias of fits to the synthetic curve sampled with 1 % on
    |G*| and INSTRUMENT_PHASE_SIGMA on delta (random), and the same plus a phase offset of
    +-INSTRUMENT_PHASE_SIGMA."""
    true, w = synthetic()
    g = np.asarray(jr.complex_modulus(true, w))
    rng = np.random.default_rng(seed)
    top, out = w > 1e8, []
    sp = prony.INSTRUMENT_PHASE_SIGMA
    for label, offset in (("random", 0.0), ("offset +0.1 deg", sp), ("offset -0.1 deg", -sp)):
        mag = np.abs(g) * (1 + prony.MODULUS_SIGMA * rng.standard_normal(w.size))
        delta = np.angle(g) + sp * rng.standard_normal(w.size) + offset
        mc = jr.materials.MasterCurve(w, mag * np.cos(delta), mag * np.sin(delta), np.zeros(w.size, int), 293.15)
        bias = {}
        for p in (0.0, sp):
            fit = np.asarray(jr.complex_modulus(jr.fit_prony(mc, phase_sigma=p).material, w[top])).real
            bias[f"{p * 1e3:.2f}"] = float(np.mean(fit / g.real[top] - 1))
        out.append({"errors": label, "glassy_bias": bias})
    sets = np.repeat(np.arange(w.size), 7)[: w.size][::-1]  # 'temperature sets' of 7 points, coldest at the top
    exact = jr.materials.MasterCurve(w, g.real, g.imag, sets, 293.15)
    return out, kk_implied_bias(exact)


def extrema(mc, material):
    """Local extrema of log G'' over the data's range (40 points per decade)."""
    lo, hi = np.log10(mc.omega[0]), np.log10(mc.omega[-1])
    x = np.linspace(lo, hi, int(40 * (hi - lo)) + 1)
    y = np.log(np.asarray(jr.complex_modulus(material, 10**x)).imag)
    return int(np.sum(np.diff(np.sign(np.diff(y))) != 0))


def smoothness_rows(mc):
    out = []
    for lam in (None, 0.3, 1.0, 3.0):
        pf = jr.fit_prony(mc, smoothness=lam)
        out.append({"smoothness": lam, "terms": pf.n_terms, "rms": pf.rms, "loss_extrema": extrema(mc, pf.material),
                    "cold_bias": cold_bias(mc, pf.material)})
    return out


#: the fits of ``--rolling``: (name, fit_prony keywords); the full model runs the last two
ROLLING_FITS = (("smoothness=None (fewest terms)", {"smoothness": None}), ("smoothness=1", {"smoothness": 1.0}),
                ("smoothness=3 (default)", {}),
                ("smoothness=3, phase_sigma 0.1 deg", {"phase_sigma": prony.INSTRUMENT_PHASE_SIGMA}))
#: (method, temperature step [K], speeds [m/s]) of ``--rolling``
ROLLING_RUNS = (("direct", 1.0, (1e-3, 0.1, 1.0)), ("full", 5.0, (1e-3, 1.0)))
#: temperatures [degC] at which ``--rolling`` reports the change of R(T) by the error model
CHANGE_AT = (-40, -35, 0, 25, 60, 100)


def rolling(sw):
    """Extrema of R(T) per fit and speed (the temperatures where dR/dT changes sign), and the
    change of R(T) from the default (phase_sigma = 0) to the instrument error model: the direct
    method for every fit, the full model (5 K steps) for those two. Returns the ``prony_rolling``
    section of numbers.json."""
    shifts = jr.fit_shift_factors(sw, T_ref=298.15)
    shift, mc = jr.fit_wlf(shifts).shift, jr.master_curve(sw, shifts)
    fits = {name: jr.fit_prony(mc, **kw) for name, kw in ROLLING_FITS}
    default, model = ROLLING_FITS[2][0], ROLLING_FITS[3][0]
    extrema_rows, change_rows = [], []
    for method, step, speeds in ROLLING_RUNS:
        T = np.arange(233.15, 373.15 + step / 2, step)
        R = {}
        for name, pf in fits.items():
            if method == "full" and name not in (default, model):
                continue
            m = jr.resistance_map(pf.material, shift, jr.Layer(H=0.01), radius=0.01, load=10.0, temperatures=T,
                                  speeds=np.array(speeds), method=None if method == "full" else method)
            d, valid, R[name] = np.asarray(m.dR_dT), np.asarray(m.valid), np.asarray(m.value)
            for j, V in enumerate(speeds):
                at = T[np.flatnonzero(np.diff(np.sign(d[:, j])) != 0)] - 273.15
                extrema_rows.append({"fit": name, "terms": pf.n_terms, "method": method, "step": step, "speed": V,
                                     "at_degC": [round(float(t), 1) for t in at], "valid": int(valid[:, j].sum()),
                                     "points": len(T)})
                print(f"{method:6s} {name:34s} ({pf.n_terms:3d} terms) V {V:g} m/s: {len(at):2d} sign changes of "
                      f"dR/dT at {np.round(at).astype(int).tolist()} degC; {int(valid[:, j].sum())} of {len(T)} valid",
                      flush=True)
        change = R[model] / R[default] - 1
        for j, V in enumerate(speeds):
            k = int(np.argmax(np.abs(change[:, j])))
            at = {f"{t:d}": float(change[np.argmin(np.abs(T - 273.15 - t)), j]) for t in CHANGE_AT}
            change_rows.append({"method": method, "speed": V, "median": float(np.median(change[:, j])),
                                "largest": float(change[k, j]), "largest_at_degC": round(float(T[k] - 273.15), 1),
                                "at": at})
            print(f"{method:6s} R(T) phase_sigma 0.1 deg / default - 1 at V {V:g} m/s: median "
                  f"{np.median(change[:, j]):+.1%}, largest {change[k, j]:+.1%} at {T[k] - 273.15:.0f} degC; at "
                  + ", ".join(f"{t} degC {v:+.1%}" for t, v in at.items()), flush=True)
    return {"command": "python benchmarks/prony_smoothness.py --rolling --record", "extrema": extrema_rows,
            "change": change_rows}


def _record(section, data):
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _numbers

    _numbers.record(section, data)


def main():
    if "--rolling" in sys.argv:
        data = rolling(jr.read_dma_sweeps(DATA))
        if "--record" in sys.argv:
            _record("prony_rolling", data)
        return
    mc = master(DATA)
    smooth = smoothness_rows(mc)
    for r in smooth:
        print(f"smoothness {str(r['smoothness']):5s} terms {r['terms']:3d}  rms {r['rms']:.4f}  loss extrema "
              f"{r['loss_extrema']:3d}  coldest-set storage {r['cold_bias']:+.1%}")
    plateau = {"shipped (21 sets)": plateau_rows(mc)}
    for name, sec in plateau.items():
        print(f"\n{name}: storage implied by the loss (KK) with the phase moved by -4, -2, -1, 0, +1 x "
              f"{prony.INSTRUMENT_PHASE_SIGMA * 1e3:.2f} mrad: " + ", ".join(f"{v:+.1%}" for v in sec["kk_implied"].values()))
        for r in sec["rows"]:
            print(f"  {r['fit']:24s} coldest-set storage {r['cold_bias']:+6.1%}  rms storage {r['rms_storage']:.3f}  "
                  f"loss {r['rms_loss']:.3f}  loss near the peak {r['rms_loss_peak']:.3f}; mean loss residual at tan "
                  "delta " + ", ".join(f"{k}: {v:+.3f}" for k, v in r["loss_bias_by_tan"].items()))
    syn, kk_exact = synthetic_rows()
    print(f"\nsynthetic KK-consistent curve: storage implied by its exact loss {kk_exact:+.2%}; "
          "glassy storage bias of fits at phase_sigma 0 (default) / 0.1 deg:")
    for r in syn:
        print(f"  {r['errors']:16s} " + " / ".join(f"{v:+.2%}" for v in r["glassy_bias"].values()))
    if "--record" in sys.argv:
        _record("prony_plateau", {"command": "python benchmarks/prony_smoothness.py --record",
                                  "phase_sigma": prony.INSTRUMENT_PHASE_SIGMA, "smoothness": smooth,
                                  "plateau": plateau, "synthetic": syn, "synthetic_kk_implied": kk_exact})


if __name__ == "__main__":
    main()
