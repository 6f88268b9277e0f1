"""Loss-curve extrema and glassy-plateau bias of Prony fits to the shipped master curve
(docs/dma.md, "Smooth Prony series"): the default fit, smoothed fits, and fits that weigh the
loss less (storage only, loss artifacts left out, a phase uncertainty).

Run: ``python benchmarks/prony_smoothness.py`` (seconds)."""

from pathlib import Path

import numpy as np

import jaxroll as jr

DATA = Path(__file__).resolve().parents[1] / "fitting" / "data" / "pyvisco_freq_user_raw.csv"


def stats(mc, pf, label):
    """Terms, rms, loss extrema over the data's range (40 points per decade) and the mean
    relative storage error on the coldest set."""
    lo, hi = np.log10(mc.omega[0]), np.log10(mc.omega[-1])
    x = np.linspace(lo, hi, int(40 * (hi - lo)) + 1)
    y = np.log(np.asarray(jr.complex_modulus(pf.material, 10**x)).imag)
    extrema = int(np.sum(np.diff(np.sign(np.diff(y))) != 0))
    cold = mc.set == 0
    bias = np.mean(np.asarray(jr.complex_modulus(pf.material, mc.omega[cold])).real / mc.storage[cold] - 1)
    print(f"{label:32s} terms {pf.n_terms:3d}  rms {pf.rms:.4f}  loss extrema {extrema:3d}  coldest-set storage "
          f"{bias * 100:+.1f} %  (loss rms {np.sqrt(np.mean(pf.residuals[:, 1] ** 2)):.3f})")


def main():
    sw = jr.read_dma_sweeps(DATA)
    mc = jr.master_curve(sw, jr.materials.fit_shift_factors(sw))
    for lam in (None, 0.3, 1.0, 3.0):
        stats(mc, jr.fit_prony(mc, smoothness=lam), f"smoothness {lam}")
    n = len(mc.omega)
    w = np.ones((n, 2))
    w[:, 1] = 0.0
    stats(mc, jr.fit_prony(mc, weights=w), "storage only")
    w = np.ones((n, 2))
    w[jr.materials.loss_artifacts(mc), 1] = 0.0
    stats(mc, jr.fit_prony(mc, weights=w), "loss artifacts left out")
    tan = mc.loss / mc.storage
    for dphi in (1e-3, 3e-3):
        w = np.ones((n, 2))
        w[:, 1] = 1.0 / np.sqrt(0.01**2 + (dphi / tan) ** 2)
        w[:, 1] /= w[:, 1].max()
        stats(mc, jr.fit_prony(mc, weights=w), f"loss weighted, dphi {dphi:g} rad")


if __name__ == "__main__":
    main()
