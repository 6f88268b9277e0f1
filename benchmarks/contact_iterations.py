"""Operator applications and time per contact solve of the full 3D sphere, by resolution.

Run:  python benchmarks/contact_iterations.py CELLS ZETAS [F] [--restart N] [--no-count]
      e.g. python benchmarks/contact_iterations.py 12,24,48 0.01,0.3,1,3,100 1.0

Half-space, R = 2 cm, P = 100 N, SLS G0 = 3 MPa, tau = 0.25 s, ratio F (default 1);
``zeta = V tau/a0`` with the relaxed Hertz radius a0 = 5 mm; grid
``jr.AutoGrid(cells_per_radius=CELLS)`` resolved per resolution, one compiled solve each.
Prints per solve: the active-set steps, the circulant applications of the compliance (``C``:
GMRES's operator plus ~2 for the residual and the dissipation) and of the preconditioner
(``M``), counted with a debug callback (``--no-count`` for the timing alone: the callbacks cost
time), and the best of three runs.
"""

from __future__ import annotations

import argparse
import time

import jax

import jaxroll as jr
from jaxroll.contact import operator as _op, precondition as _pc
from jaxroll.engines import sphere3d
from jaxroll.engines.contact_size import estimate_contact_size

COUNT = {"C": 0, "M": 0}


def _counting(tag, apply):
    def counted(mult, p, emb):
        jax.debug.callback(lambda: COUNT.__setitem__(tag, COUNT[tag] + 1))
        return apply(mult, p, emb)
    return counted


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("cells")
    ap.add_argument("zetas")
    ap.add_argument("f", nargs="?", type=float, default=1.0)
    ap.add_argument("--restart", type=int, default=None)
    ap.add_argument("--no-count", action="store_true")
    args = ap.parse_args()
    if not args.no_count:
        apply = _op.circulant_window_apply
        _op.circulant_window_apply, _pc.circulant_window_apply = _counting("C", apply), _counting("M", apply)
    R, P, tau = 0.02, 100.0, 0.25
    mat, layer = jr.StandardLinearSolid(3e6, tau, args.f), jr.Layer(float("inf"))
    solver = jr.contact.GMRES(restart=args.restart)
    r_est = float(estimate_contact_size(mat, layer, R, P, "sphere"))
    for cells in (int(c) for c in args.cells.split(",")):
        grid = jr.Full(grid=jr.AutoGrid(cells_per_radius=cells)).resolve(
            mat, layer, radius=R, loads=P, speeds=1.0, geometry="sphere").grid
        build = sphere3d.kernel_builder(mat, layer, grid)

        @jax.jit
        def run(V, build=build, grid=grid):
            s = sphere3d.solve(build(V), grid, R, P, r_est, linear_solver=solver)
            return s.resistance, s.contact.result, s.contact.iterations

        for zeta in (float(z) for z in args.zetas.split(",")):
            V = zeta * 5e-3 / tau
            jax.block_until_ready(run(V))  # compile
            COUNT.update(C=0, M=0)
            times = []
            for _ in range(3):
                t = time.perf_counter()
                out = jax.block_until_ready(run(V))
                times.append(time.perf_counter() - t)
            print(f"cells {cells} window {grid.window} zeta {zeta:g} f {args.f:g}: R_r {float(out[0]):.7g} N, "
                  f"result {int(out[1])}, steps {int(out[2])}, C {COUNT['C'] // 3}, M {COUNT['M'] // 3}, "
                  f"best {min(times) * 1e3:.1f} ms", flush=True)


if __name__ == "__main__":
    main()
