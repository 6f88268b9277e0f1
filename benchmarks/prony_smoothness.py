"""Loss-curve extrema and glassy-plateau bias of Prony fits to the shipped master curve
(docs/dma.md, "Smooth Prony series"): the default fit, smoothed fits, and fits that weigh the
loss less (storage only, loss artifacts left out, a phase uncertainty).

With ``--rolling``: the extrema in temperature of the rolling resistance of a 1 cm ball (10 N,
H = 10 mm) from -40 to 100 degC, by the direct method (1 K steps; 1 mm/s, 0.1 m/s, 1 m/s) and
the full 3D model (2 K steps; 1 mm/s, 1 m/s), for the fewest-terms fit and smoothness 1 and 3
(the default, ``jaxroll.materials.prony.SMOOTHNESS``).

Run: ``python benchmarks/prony_smoothness.py [--rolling]`` (seconds; minutes with --rolling)."""

import sys

import numpy as np

import jaxroll as jr

DATA = jr.datasets.path("pyvisco_freq_user_raw.csv")


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


def rolling_extrema(sw):
    """Temperatures [degC] where dR/dT changes sign, per speed, for each fit and method."""
    shifts = jr.fit_shift_factors(sw, T_ref=298.15)
    shift, mc = jr.fit_wlf(shifts).shift, jr.master_curve(sw, shifts)
    for method, step, speeds in (("direct", 1.0, (1e-3, 0.1, 1.0)), ("full", 2.0, (1e-3, 1.0))):
        T = np.arange(233.15, 373.15 + step / 2, step)
        for lam in (None, 1.0, 3.0):
            pf = jr.fit_prony(mc, smoothness=lam)
            m = jr.resistance_map(pf.material, shift, jr.Layer(H=0.01), radius=0.01, load=10.0, temperatures=T,
                                  speeds=np.array(speeds), method=None if method == "full" else method)
            d, valid = np.asarray(m.dR_dT), np.asarray(m.valid)
            for j, V in enumerate(speeds):
                at = T[np.flatnonzero(np.diff(np.sign(d[:, j])) != 0)] - 273.15
                print(f"{method:6s} smoothness {str(lam):4s} ({pf.n_terms:3d} terms) V {V:g} m/s: {len(at):2d} sign "
                      f"changes of dR/dT at {np.round(at).astype(int).tolist()} degC; {int(valid[:, j].sum())} of "
                      f"{len(T)} valid", flush=True)


def main():
    sw = jr.read_dma_sweeps(DATA)
    if "--rolling" in sys.argv:
        rolling_extrema(sw)
        return
    mc = jr.master_curve(sw, jr.materials.fit_shift_factors(sw))
    for lam in (None, 0.3, 1.0, 3.0):
        stats(mc, jr.fit_prony(mc, smoothness=lam), f"smoothness {lam}")
    n = len(mc.omega)
    w = np.ones((n, 2))
    w[:, 1] = 0.0
    stats(mc, jr.fit_prony(mc, smoothness=None, weights=w), "storage only")
    w = np.ones((n, 2))
    w[jr.materials.loss_artifacts(mc), 1] = 0.0
    stats(mc, jr.fit_prony(mc, smoothness=None, weights=w), "loss artifacts left out")
    tan = mc.loss / mc.storage
    for dphi in (1e-3, 3e-3):
        w = np.ones((n, 2))
        w[:, 1] = 1.0 / np.sqrt(0.01**2 + (dphi / tan) ** 2)
        w[:, 1] /= w[:, 1].max()
        stats(mc, jr.fit_prony(mc, smoothness=None, weights=w), f"loss weighted, dphi {dphi:g} rad")


if __name__ == "__main__":
    main()
