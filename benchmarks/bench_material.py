"""Time the steps of ``jaxroll material`` on the shipped 21-temperature DMA file (compute only:
no figures, no files).

Each step is timed after one warm-up call (its compilation reported apart), median of
``--repeat`` runs. Run: ``python benchmarks/bench_material.py [--repeat 5]``.
"""

import argparse
import statistics
import time
import warnings
from pathlib import Path

import numpy as np

import jaxroll as jr

DATA = Path(__file__).resolve().parents[1] / "jaxroll" / "datasets" / "pyvisco_freq_user_raw.csv"


def steps():
    """``{step: seconds}`` of one pass of the pipeline."""
    out = {}
    t = time.perf_counter()
    sw = jr.read_dma_sweeps(DATA)
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


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    warnings.simplefilter("ignore", jr.DataWarning)
    t = time.perf_counter()
    first, pf = steps()
    print(f"first pass (with compilation): {time.perf_counter() - t:.2f} s; Prony {pf.n_terms} terms, rms {pf.rms:.4f}")
    runs = [steps()[0] for _ in range(args.repeat)]
    for k in runs[0]:
        print(f"  {k:28s} median {statistics.median(r[k] for r in runs):7.3f} s  (min {min(r[k] for r in runs):.3f})")
    print(f"numpy {np.__version__}")


if __name__ == "__main__":
    main()
