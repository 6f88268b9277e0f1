"""The reference table's small loads on a smaller window: exactness and cost (window bands: dropped, LOG.md).

Run:  python benchmarks/window_bands.py [--split 80] [--repeat 5]

The reference case (``bench_sphere3d.py --H 0.03 --period none``: 0.25 mm cells, infinite layer,
R = 2 cm, SLS 3 MPa / 0.25 s / f 1, 23 speeds x 15 loads 10..150 N) solves every load on the
window sized for the largest contact (55 cells), though the contact radius grows as ~P^(1/3):
the loads up to ``--split`` N fit a window ``W'`` sized the same way for that load (45 cells at
80 N). Two measurements:

1. **Exactness**: the Toeplitz operators (compliance and dissipation) of the full window cropped
   to the centre ``W'`` cells (``offsets[W - W' : W + W' - 1]`` per axis) define the same
   discrete problem for a contact inside ``W'``: ``R_r`` of a solve on the cropped operators
   against the full window, at 4 speeds x 3 loads (relative difference; the solver tolerance is
   1e-13 on the linear solves). A smaller ``jr.FixedGrid`` is *not* exact (its aperiodic kernel
   is built on the smaller embedding: ~1e-8 relative).
2. **Cost**: the table of the loads up to ``--split`` N at window ``W`` and ``W'`` (the
   ``jr.FixedGrid`` of each window: the same shapes and about the same iterations as the
   cropped operators) and the whole table at ``W``, process CPU seconds, alternating, median
   of ``--repeat``; the whole table's ratio with those loads on ``W'`` is estimated from them.
"""

from __future__ import annotations

import argparse
import math
import os
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from jaxroll._xla_options import compiler_options
from jaxroll.contact.operator import WindowKernel, toeplitz_operator
from jaxroll.engines import sphere3d
from jaxroll.engines.contact_size import estimate_contact_size
from jaxroll.grids import counting_size

G0, TAU, F, R, H, SPACING = 3e6, 0.25, 1.0, 0.02, 0.03, 2.5e-4


def window_for(material, layer, load):
    """The benchmark's window rule (``bench_sphere3d.py``): 15 % beyond the estimated radius."""
    r = float(estimate_contact_size(material, layer, R, load))
    return max(41, 2 * math.ceil(1.15 * r / SPACING) + 1)


def cropped(op, W, Wp):
    """The Toeplitz operator ``op`` of a ``W``-cell window on the centre ``Wp`` cells."""
    k = W - Wp
    return toeplitz_operator(op.offsets[k:2 * W - 1 - k, k:2 * W - 1 - k])


def exactness(material, layer, W, Wp, loads):
    worst = 0.0
    for V in (1e-4, 3e-3, 0.05, 1.0):
        kernel = sphere3d.kernel_builder(material, layer, jr.FixedGrid(SPACING, W))(V)
        small = WindowKernel(cropped(kernel.compliance, W, Wp), cropped(kernel.dissipation, W, Wp))
        for P in loads:
            size = counting_size(material, layer, R, P, V, "sphere")
            a = sphere3d.solve(kernel, jr.FixedGrid(SPACING, W), R, P, size)
            b = sphere3d.solve(small, jr.FixedGrid(SPACING, Wp), R, P, size)
            assert int(a.contact.result) == int(b.contact.result) == 0
            worst = max(worst, abs(float(b.resistance) / float(a.resistance) - 1))
    return worst


def table_program(window, loads, speeds):
    method = jr.Full(grid=jr.FixedGrid(SPACING, window, period=None, n_terms=None), tol=1e-10)

    def table(G, tau, f, h, loads, speeds):
        out = jr.rolling_resistance_grid(jr.StandardLinearSolid(G, tau, f), jr.Layer(h), radius=R, loads=loads,
                                         speeds=speeds, method=method)
        return out.value, out.solution.iterations

    args = (G0, TAU, F, H, jnp.asarray(loads), jnp.asarray(speeds))
    return jax.jit(table).lower(*args).compile(compiler_options()), args


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--split", type=float, default=80.0)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    material, layer = jr.StandardLinearSolid(G0, TAU, F), jr.Layer(H)
    all_loads, speeds = np.linspace(10, 150, 15), np.logspace(-4, 0, 23)
    loads = all_loads[all_loads <= args.split]
    W, Wp = window_for(material, layer, float(all_loads.max())), window_for(material, layer, float(loads.max()))
    print(f"windows: {W} cells (all loads), {Wp} (loads <= {args.split:g} N: {len(loads)} of {len(all_loads)})")
    print(f"exactness: R_r on the cropped operators against the full window, max relative difference "
          f"{exactness(material, layer, W, Wp, (10.0, 40.0, float(loads.max()))):.1e} (4 speeds x 3 loads)")
    programs = {w: table_program(w, loads, speeds) for w in (W, Wp)}
    programs["all"] = table_program(W, all_loads, speeds)
    steps = {w: float(np.mean(np.asarray(jax.block_until_ready(c(*a))[1]))) for w, (c, a) in programs.items()}
    times = {w: [] for w in programs}
    load0 = os.getloadavg()[0]
    for _ in range(args.repeat):
        for w, (c, a) in programs.items():
            t = time.process_time()
            jax.block_until_ready(c(*a))
            times[w].append(time.process_time() - t)
    med = {w: float(np.median(t)) for w, t in times.items()}
    print(f"table of the {len(loads)} loads <= {args.split:g} N x {len(speeds)} speeds, process CPU s (median of "
          f"{args.repeat}, load avg {load0:.1f} -> {os.getloadavg()[0]:.1f}): window {W} {med[W]:.3f} "
          f"({steps[W]:.2f} steps per solve), window {Wp} {med[Wp]:.3f} ({steps[Wp]:.2f}): {med[Wp] / med[W]:.2f}x; "
          f"the whole table at window {W} {med['all']:.3f}: with these loads at {Wp} "
          f"{(med['all'] - med[W] + med[Wp]) / med['all']:.2f}x (estimate: the two tables' difference)")


if __name__ == "__main__":
    main()
