"""The full models' automatic grid where the material is much stiffer at the rolling frequency
than relaxed: the counting size (:func:`jaxroll.grids.counting_size`) against the solved contact,
and the reported ``truncation`` against the error measured by a grid twice as fine (same window
in metres) and, for the cylinder on a half-space with a standard linear solid, against the exact
solution (:func:`jaxroll.reference.exact_cylinder_halfspace`).

    python benchmarks/dynamic_contact.py [--quick] [--refine 2]
    python benchmarks/dynamic_contact.py --calibration

``--calibration``: the solved contacts of the error tables' study and validation files
(``benchmarks/resistance_forms_study.csv``, ``..._validation.csv``; the smallest over the grids
of a point) against the relaxed, dynamic and counting sizes: the measurement behind
``jaxroll.grids.CALIBRATED_CONTACT_RATIO`` and ``DYNAMIC_CONTACT_RATIO``.

Cases: the shipped measured material (``pyvisco_freq_user_raw.csv``, the Prony series of
``fitting/dma_to_rolling.py``) under a ball (R = 1 cm, 10 N) and a cylinder (R = 1 cm, 10 kN/m)
on a 10 mm cover at reduced speeds ``V a_T`` over its 25 x 25 map (1e-16..1e11 m/s); standard
linear solids (G0 = 3 MPa, tau = 0.25 s, f = 3 and 30) on a half-space (R = 2 cm, 100 N;
10 kN/m) at zeta = V tau/a0 = 10..1000. Per point: the relaxed, dynamic and counting sizes, the
solved contact over the dynamic size, the cells per counting size, the value, ``truncation``,
the relative difference to the finer grid, the Richardson bound on the coarse grid's error from
the pair at first order (``2 |v - v_fine|``), and the exact error where known.
"""

import argparse
import math

import jax.numpy as jnp
import numpy as np

import jaxroll as jr
from jaxroll import grids
from jaxroll.engines.contact_size import dynamic_contact_size, estimate_contact_size
from jaxroll.reference import exact_cylinder_halfspace
from jaxroll.rolling import _point


def shipped_material():
    """The Prony series of the shipped DMA file (as ``fitting/dma_to_rolling.py`` fits it)."""
    sw = jr.read_dma_sweeps(jr.datasets.path("pyvisco_freq_user_raw.csv"))
    sh = jr.fit_shift_factors(sw, T_ref=298.15)
    return jr.fit_prony(jr.master_curve(sw, sh)).material


def finer(grid, refine, geometry):
    """The grid with ``refine`` times the cells over the same window width [m]."""
    if geometry == "sphere":
        return jr.FixedGrid(grid.spacing / refine, refine * (grid.window - 1) + 1)
    return jr.FixedGrid(grid.spacing / refine, refine * grid.window)


def solve(method, material, layer, R, P, V, geometry):
    return _point(method.dynamic(), material, layer, jnp.asarray(R, float), jnp.asarray(P, float),
                  jnp.asarray(V, float), geometry, True)


def study(name, material, layer, R, P, speeds, geometry, refine, exact=None):
    """Rows of the study at ``speeds`` (see the module docstring)."""
    rows = []
    a_rel = float(estimate_contact_size(material, layer, R, P, geometry))
    for V in speeds:
        m = jr.Full().resolve(material, layer, radius=R, loads=[P], speeds=[V], geometry=geometry)
        a_dyn = float(dynamic_contact_size(material, layer, R, P, V, geometry))
        a_c = float(grids.counting_size(material, layer, R, P, V, geometry))
        coarse = solve(m, material, layer, R, P, V, geometry)
        fine = solve(jr.Full(grid=finer(m.grid, refine, geometry)), material, layer, R, P, V, geometry)
        v, vf = float(coarse.value), float(fine.value)
        solved = float(coarse.contact_radius)
        row = dict(case=name, geometry=geometry, V=V, a_rel=a_rel, dyn_rel=a_dyn / a_rel, count_rel=a_c / a_rel,
                   solved_dyn=solved / a_dyn, solved_count=solved / a_c, cells=a_c / float(m.grid.spacing),
                   window=m.grid.window, value=v, truncation=float(coarse.truncation),
                   diff_fine=(v - vf) / vf, bound=2 * abs(v - vf) / abs(vf),
                   result=jr.RESULTS.names[int(coarse.result)], result_fine=jr.RESULTS.names[int(fine.result)],
                   exact=math.nan)
        if exact is not None:
            row["exact"] = (v - exact(V)) / exact(V)
        rows.append(row)
        print(f"{name:9s} {geometry:8s} V {V:8.1e}  dyn/rel {row['dyn_rel']:.3f} count/rel {row['count_rel']:.3f} "
              f"solved/dyn {row['solved_dyn']:.3f} solved/count {row['solved_count']:.3f} cells {row['cells']:5.1f} "
              f"W {m.grid.window:4d}  trunc {100 * row['truncation']:6.3f} %  vs fine {100 * row['diff_fine']:+7.3f} %"
              f"  bound {100 * row['bound']:6.3f} %  exact {100 * row['exact']:+7.3f} %  {row['result']}"
              f"/{row['result_fine']}", flush=True)
    return rows


def calibration():
    """Solved over relaxed, dynamic and counting sizes at the tables' calibration points."""
    import csv
    from pathlib import Path

    import resistance_forms as rf

    here = Path(__file__).parent
    smallest = {}
    for name in ("resistance_forms_study.csv", "resistance_forms_validation.csv"):
        for row in csv.reader(open(here / name)):
            g, tag, z, V, solved = row[0], row[1], float(row[2]), float(row[3]), float(row[8])
            P = float(row[10]) if len(row) > 10 else rf.LOAD[g]
            key = (name, g, tag, z, P, V)
            if math.isfinite(solved) and solved < smallest.get(key, math.inf):
                smallest[key] = solved
    rows = []
    for (name, g, tag, z, P, V), solved in smallest.items():
        m = rf.MATERIALS[tag]
        sizes = [float(f(m, rf.HALF, 0.02, P, V, g)) for f in (
            lambda m, la, R, P, V, g: estimate_contact_size(m, la, R, P, g), dynamic_contact_size, grids.counting_size)]
        rows.append((solved / sizes[2], solved / sizes[0], solved / sizes[1], f"{name[17:-4]} {g} {tag} {z:g} P={P:g}"))
    rows.sort()
    for r in rows[:8]:
        print(f"solved / counting {r[0]:.3f}, / relaxed {r[1]:.3f}, / dynamic {r[2]:.3f}: {r[3]}")
    for i, what in enumerate(("counting", "relaxed", "dynamic")):
        print(f"solved / {what} size: {min(r[i] for r in rows):.3f}..{max(r[i] for r in rows):.3f} ({len(rows)} points)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a few speeds per case")
    ap.add_argument("--refine", type=int, default=2)
    ap.add_argument("--calibration", action="store_true", help="the error tables' calibration points")
    args = ap.parse_args()
    if args.calibration:
        return calibration()
    shipped = shipped_material()
    cover, half = jr.Layer(H=0.01), jr.Layer(H=jnp.inf)
    reduced = 10.0 ** (np.arange(-12, 12, 3.0) if args.quick else np.arange(-14, 12, 1.0))
    rows = study("shipped", shipped, cover, 0.01, 10.0, reduced, "sphere", args.refine)
    rows += study("shipped", shipped, cover, 0.01, 1e4, reduced, "cylinder", args.refine)
    zetas = np.array([10.0, 1000.0]) if args.quick else np.array([10.0, 100.0, 1000.0])
    for f in (3.0, 30.0):
        sls = jr.StandardLinearSolid(G0=3e6, tau=0.25, f=f)
        a0 = float(estimate_contact_size(sls, half, 0.02, 100.0, "sphere"))
        rows += study(f"SLS f={f:g}", sls, half, 0.02, 100.0, zetas * a0 / 0.25, "sphere", args.refine)
        a0 = float(estimate_contact_size(sls, half, 0.02, 1e4, "cylinder"))
        exact = lambda V, sls=sls: float(exact_cylinder_halfspace(sls, 0.02, 1e4, V).rolling_resistance)  # noqa: E731
        rows += study(f"SLS f={f:g}", sls, half, 0.02, 1e4, zetas * a0 / 0.25, "cylinder", args.refine, exact)
    ok = [r for r in rows if r["result"] in ("successful", "truncation_too_large")]
    print(f"smallest solved/dynamic size {min(r['solved_dyn'] for r in rows):.3f}; "
          f"smallest solved/counting size {min(r['solved_count'] for r in rows):.3f}; "
          f"largest |error vs fine| / truncation {max(abs(r['diff_fine']) / r['truncation'] for r in ok):.3f}; "
          f"largest first-order bound / truncation {max(r['bound'] / r['truncation'] for r in ok):.3f}")


if __name__ == "__main__":
    main()
