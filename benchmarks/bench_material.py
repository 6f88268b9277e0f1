"""Time the steps of ``jaxroll material`` on the shipped 21-temperature DMA file (compute only:
no figures, no files), and pyvisco's pipeline on the same file side by side where pyvisco is
importable (the ``peer`` extra): its shift factors, WLF fit, master curve and Prony fit with
the optimisation its own test of this file uses (``tests/test_dma.py::test_peer_pyvisco``).

Each step is timed after one warm-up call (its compilation reported apart), median of
``--repeat`` runs. ``--rows N`` times jaxroll on a file of N rows instead: each of the shipped
file's 21 sweeps resampled at N/21 log-spaced frequencies over its 0.1-100 Hz (moduli
interpolated log-log), written to a temporary CSV. Run:
``python benchmarks/bench_material.py [--repeat 5] [--rows 100000]``.
"""

import argparse
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import jaxroll as jr

DATA = Path(__file__).resolve().parents[1] / "jaxroll" / "datasets" / "pyvisco_freq_user_raw.csv"


def resampled(n_rows, folder):
    """The shipped file with every sweep resampled at ``n_rows / 21`` frequencies (see the module
    docstring); returns its path."""
    raw = np.genfromtxt(DATA, delimiter=",", skip_header=2)
    per = n_rows // 21
    rows = []
    for s in np.unique(raw[:, 4]):
        d = raw[raw[:, 4] == s]
        f = np.logspace(np.log10(d[:, 0].min()), np.log10(d[:, 0].max()), per)
        e1, e2 = (np.exp(np.interp(np.log(f), np.log(d[:, 0]), np.log(d[:, k]))) for k in (1, 2))
        rows.append(np.column_stack([f, e1, e2, np.full(per, d[:, 3].mean()), np.full(per, s)]))
    path = Path(folder) / f"resampled_{n_rows}.csv"
    np.savetxt(path, np.vstack(rows), delimiter=",", fmt="%.10g", header="f,E_stor,E_loss,T,Set\nHz,MPa,MPa,C,-",
               comments="")
    return path


def steps(path=DATA):
    """``{step: seconds}`` of one pass of the pipeline on ``path``."""
    out = {}
    t = time.perf_counter()
    sw = jr.read_dma_sweeps(path)
    out["read"] = time.perf_counter() - t
    t = time.perf_counter()
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    out["shift factors"] = time.perf_counter() - t
    t = time.perf_counter()
    jr.fit_wlf(sh), jr.materials.fit_arrhenius(sh)
    out["WLF + Arrhenius"] = time.perf_counter() - t
    t = time.perf_counter()
    master = jr.master_curve(sw, sh)
    jr.materials.loss_artifacts(master)
    out["master curve + artifacts"] = time.perf_counter() - t
    t = time.perf_counter()
    pf = jr.fit_prony(master)
    out["Prony fit"] = time.perf_counter() - t
    out["total"] = sum(out.values())
    return out, pf


def pyvisco_steps(pyvisco):
    """``{step: seconds}`` of pyvisco's pipeline on the same file (E, Hz, degC as it reads it)."""
    out = {}
    t = time.perf_counter()
    df_raw, _, _ = pyvisco.load.user_raw(pyvisco.load.file(str(DATA)), "freq", "E")
    out["read"] = time.perf_counter() - t
    t = time.perf_counter()
    df_aT, _ = pyvisco.master.get_aT(df_raw, 25)
    out["shift factors"] = time.perf_counter() - t
    t = time.perf_counter()
    pyvisco.shift.fit_WLF(25, df_aT)
    out["WLF"] = time.perf_counter() - t
    t = time.perf_counter()
    df_master = pyvisco.master.smooth(pyvisco.master.get_curve(df_raw, df_aT, 25), 1)
    out["master curve"] = time.perf_counter() - t
    t = time.perf_counter()
    pyvisco.prony.fit(pyvisco.prony.discretize(df_master, "round"), df_master, opt=True)
    out["Prony fit"] = time.perf_counter() - t
    out["total"] = sum(out.values())
    return out


def report(label, runs):
    print(label)
    for k in runs[0]:
        print(f"  {k:28s} median {statistics.median(r[k] for r in runs):7.3f} s  (min {min(r[k] for r in runs):.3f})")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--rows", type=int, default=None, help="time a resampled file of this many rows instead")
    args = ap.parse_args()
    warnings.simplefilter("ignore", jr.DataWarning)
    if args.rows:
        with tempfile.TemporaryDirectory() as folder:
            path = resampled(args.rows, folder)
            t = time.perf_counter()
            _, pf = steps(path)
            print(f"{args.rows} rows, first pass (with compilation): {time.perf_counter() - t:.2f} s; Prony "
                  f"{pf.n_terms} terms, rms {pf.rms:.4f}")
            report(f"jaxroll, {args.rows} rows", [steps(path)[0] for _ in range(args.repeat)])
        return
    t = time.perf_counter()
    first, pf = steps()
    print(f"first pass (with compilation): {time.perf_counter() - t:.2f} s; Prony {pf.n_terms} terms, rms {pf.rms:.4f}")
    report("jaxroll", [steps()[0] for _ in range(args.repeat)])
    try:
        import pyvisco
    except ImportError:
        print("pyvisco not importable (pip install '.[peer]'): its side is not measured")
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pyvisco_steps(pyvisco)  # warm-up
            report(f"pyvisco {getattr(pyvisco, '__version__', '')}", [pyvisco_steps(pyvisco) for _ in range(args.repeat)])
    print(f"numpy {np.__version__}")


if __name__ == "__main__":
    main()
