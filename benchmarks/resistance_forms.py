"""Convergence of the two forms of R_r of the full models over V tau/a0 = 1e-3..1e3.

The full models report the pressure-moment form ``R_r = (1/R) int p x`` as ``value`` and the
dissipation form ``-int p du/dx`` as ``solution.resistance_dissipation``; in the continuum they
are equal. This script measures how each converges with the cells per contact radius:

* cylinder (full 2D) on an SLS half-space against the exact solution
  (``jr.reference.exact_cylinder_halfspace``), relative errors in %;
* sphere (full 3D, infinite layer) on an SLS half-space: a convergence study, relative
  differences in % to the finest grid's dissipation form.

Material G0 = 3 MPa, tau = 0.25 s, f = 1 (the paper's); sphere R = 2 cm, P = 100 N; cylinder
R = 2 cm, P = 10 kN/m. Run: ``python benchmarks/resistance_forms.py [--quick]`` (about 15 min on
2 cores; ``--quick``: three speeds, coarser grids).
"""

import argparse
import warnings

import jax.numpy as jnp

import jaxroll as jr

MAT = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=1.0)
HALF = jr.Layer(H=jnp.inf)


def forms(geometry, load, speed, cells):
    method = jr.Full(grid=jr.AutoGrid(cells_per_radius=cells))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", jr.ValidityWarning)  # coarse grids at low zeta are flagged
        r = jr.rolling_resistance(MAT, HALF, radius=0.02, load=load, speed=speed, geometry=geometry, method=method,
                                  throw=False)
    return float(r.value), float(r.solution.resistance_dissipation), bool(r.valid)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    zetas = [1e-2, 1.0, 1e2] if args.quick else [1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3]
    line_cells = [12, 25] if args.quick else [12, 25, 50, 100]
    sphere_cells = [8, 12, 16] if args.quick else [8, 12, 16, 24, 32, 48]

    P_line = 1e4
    a_line = float(jr.reference.hertz_cylinder(P_line, 0.02, MAT.G0))
    print("cylinder on a half-space, error against the exact solution [%]: moment form M / dissipation form D")
    print("zeta    " + "".join(f"{c:>20d}" for c in line_cells))
    for z in zetas:
        V = z * a_line / MAT.tau
        exact = float(jr.reference.exact_cylinder_halfspace(MAT, radius=0.02, load=P_line, speed=V).rolling_resistance)
        cols = []
        for c in line_cells:
            M, D, ok = forms("cylinder", P_line, V, c)
            cols.append(f"{100 * (M / exact - 1):+8.3f} /{100 * (D / exact - 1):+8.3f}{'' if ok else '*'}")
        print(f"{z:<8g}" + "".join(f"{s:>20s}" for s in cols), flush=True)

    a_sph = float(jr.reference.hertz_sphere(100.0, 0.02, MAT.G0).contact_radius)
    print(f"\nsphere on a half-space, difference to D at {sphere_cells[-1]} cells per radius [%]: M / D")
    print("zeta    " + "".join(f"{c:>20d}" for c in sphere_cells))
    for z in zetas:
        V = z * a_sph / MAT.tau
        rows = [forms("sphere", 100.0, V, c) for c in sphere_cells]
        ref = rows[-1][1]
        print(f"{z:<8g}" + "".join(f"{100 * (M / ref - 1):+8.3f} /{100 * (D / ref - 1):+8.3f}{'' if ok else '*'}"
                                   .rjust(20) for M, D, ok in rows), flush=True)
    print("\n* not valid (the method's own flag)")


if __name__ == "__main__":
    main()
