"""The approximate methods against the full model: their real error, their own error estimate
(``RollingResult.approximation``), and where their gradients agree with the full model's.

    python benchmarks/approx_validity.py errors [--out rows.csv] [--quick]
    python benchmarks/approx_validity.py gradients
    python benchmarks/approx_validity.py differences
    python benchmarks/approx_validity.py inertia [--out rows.csv] [--quick]

``errors``: tables ``speeds x loads`` of every approximate method (``jr.Direct`` with the
relaxed (``"static"``), dynamic and glassy contact modulus; ``jr.Slices`` PD, PP, SP) and of the
reference, the full 3D model with its default grid (``jr.Full()``), through
``jr.rolling_resistance_grid``:

* SLS G0 = 3 MPa, tau = 0.25 s, f = 0.1, 0.3, 1, 3, 10; R = 2 cm, P = 30 and 100 N, 11 speeds
  1e-4..10 m/s; H = half-space, 0.2, 0.03, 0.01, 0.005, 0.002 m;
* the shipped measured Prony material (``jr.datasets``, pyvisco DMA, WLF shift) at -25, 0, 25,
  50, 75 degC; R = 1 cm, P = 3 and 10 N; H = half-space, 10 mm, 2 mm.

Writes one CSV row per point and method (inputs, value, RESULTS code, the method's estimate,
the full model's value and code) and prints per method: points, points where both are valid,
points the method calls valid, the worst |error| among those, and how often the estimate is at
least the real error. ``--quick``: f = 1, 3 layers, 2 Prony temperatures.

``gradients``: d ln R_r / d ln p for p = G0, tau, f, H of every method and of the full model (SLS
G0 = 3 MPa, tau = 0.25 s, f = 1) at 1e-3, 1e-2 (the R_r peak) and 1 m/s, sphere (R = 2 cm,
100 N) on H = 30 mm and a half-space, cylinder (R = 2 cm, 5000 N/m) on H = 30 mm; by jax.grad
through each method with the grid resolved at the point. The reference is the full model with
the smoothed contact edge (``edge_smoothing=0.5``, the fitting default): the exact discrete
contact's gradient also carries the jumps of the contact edge from cell to cell, which dominate
where R_r barely depends on the parameter (the unsmoothed full model is printed too). Each
approximate entry is marked ``ok`` (same sign, within 30 %), ``size`` (same sign, further),
``SIGN`` or ``~0`` (both below 0.05). Prints the table quoted in docs/methods.md sec. 6.

``differences``: the full model's (exact discrete contact) sensitivities of the same cases by
central differences over +-10 % with the automatic grid re-resolved at each point (the grid
scales with the contact): the check that the smoothed model's gradient is the physical one.

``inertia``: the same comparison on layers with inertia (``rho = 1000 kg/m^3``), at speeds that
are fractions 0.05..0.8 of the shear-wave speed ``c_s = sqrt(G0/rho)`` (SLS G0 = 3 MPa, f = 0.1,
1, 3, tau = 1e-6 s (relaxed regime), 1e-4 s (the loss peak), 0.25 s (glassy); half-space and
H = 30 mm; sphere R = 2 cm, 100 N, and cylinder R = 2 cm, 5000 N/m): the data of the inertia term
of the direct method's estimate (``jaxroll.engines.direct.inertia_error``). Prints per method
and ``V/c_s`` the worst real error and the worst real error over the estimate.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
import warnings

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll as jr

APPROX = {
    "direct-relaxed": jr.Direct(modulus="static"),
    "direct-dynamic": jr.Direct(modulus="dynamic"),
    "direct-glassy": jr.Direct(modulus="glassy"),
    "PD": jr.Slices("PD"),
    "PP": jr.Slices("PP"),
    "SP": jr.Slices("SP"),
}
FIELDS = ["case", "material", "T", "G0", "tau", "f", "H", "R", "P", "V", "method", "value", "result", "estimate",
          "contact_radius", "full", "full_result", "full_contact_radius", "full_truncation"]


def shipped_prony():
    """The Prony material and WLF shift fitted to the shipped pyvisco DMA data (as docs/dma.md's example)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sw = jr.read_dma_sweeps(jr.datasets.path("pyvisco_freq_user_raw.csv"))
        sh = jr.fit_shift_factors(sw, T_ref=298.15)
        return jr.fit_prony(jr.master_curve(sw, sh)).material, jr.fit_wlf(sh).shift


def cases(quick):
    speeds = np.logspace(-4, 1, 11)
    fs = (1.0,) if quick else (0.1, 0.3, 1.0, 3.0, 10.0)
    layers = (math.inf, 0.03, 0.005) if quick else (math.inf, 0.2, 0.03, 0.01, 0.005, 0.002)
    for f in fs:
        for H in layers:
            yield dict(material=f"SLS f={f:g}", T=math.nan, G0=3e6, tau=0.25, f=f, H=H, R=0.02,
                       loads=np.array([30.0, 100.0]), speeds=speeds)
    temps = (273.15, 323.15) if quick else (248.15, 273.15, 298.15, 323.15, 348.15)
    for T in temps:
        for H in ((math.inf, 0.01) if quick else (math.inf, 0.01, 0.002)):
            yield dict(material="pyvisco", T=T, G0=math.nan, tau=math.nan, f=math.nan, H=H, R=0.01,
                       loads=np.array([3.0, 10.0]), speeds=speeds)


def material_of(case, prony):
    if case["material"] == "pyvisco":
        return jr.at_temperature(prony[0], prony[1], case["T"])
    return jr.StandardLinearSolid(case["G0"], case["tau"], case["f"])


def table(material, case, method):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return jr.rolling_resistance_grid(material, jr.Layer(case["H"]), radius=case["R"], loads=case["loads"],
                                          speeds=case["speeds"], method=method)


def estimate_of(res):
    est = getattr(res, "approximation", None)
    return np.full(np.shape(res.value), np.nan) if est is None else np.asarray(est)


def errors(args):
    prony = shipped_prony()
    rows = []
    with open(args.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, FIELDS)
        w.writeheader()
        for k, case in enumerate(cases(args.quick)):
            t0 = time.perf_counter()
            mat = material_of(case, prony)
            try:
                full = table(mat, case, jr.Full())
            except ValueError as err:  # a grid above the memory budget
                print(f"case {k} skipped: {err}", flush=True)
                continue
            for name, method in APPROX.items():
                res = table(mat, case, method)
                for i, V in enumerate(case["speeds"]):
                    for j, P in enumerate(case["loads"]):
                        row = {key: case[key] for key in ("material", "T", "G0", "tau", "f", "H", "R")}
                        row.update(case=k, P=P, V=V, method=name, value=float(res.value[i, j]),
                                   result=int(res.result[i, j]), estimate=float(estimate_of(res)[i, j]),
                                   contact_radius=float(res.contact_radius[i, j]), full=float(full.value[i, j]),
                                   full_result=int(full.result[i, j]),
                                   full_contact_radius=float(full.contact_radius[i, j]),
                                   full_truncation=float(full.truncation[i, j]))
                        w.writerow(row)
                        rows.append(row)
            fh.flush()
            print(f"case {k} ({case['material']} T={case['T']:g} H={case['H']:g}): {time.perf_counter() - t0:.1f} s",
                  flush=True)
    report(rows)


def report(rows):
    """Per method: points, points where the reference is valid, valid points, the worst valid
    |error| (and less the reference's truncation), and the share of points where the estimate
    (and the estimate plus the reference's truncation) is at least the measured |error|."""
    print(f"{'method':16s} {'points':>6s} {'ref ok':>6s} {'valid':>6s} {'worst valid':>11s} {'- trunc':>8s} "
          f"{'est>=|err|':>10s} {'est+trunc>=|err|':>16s}")
    for name in APPROX:
        r = [x for x in rows if x["method"] == name and int(x["full_result"]) == 0]
        err = np.abs(np.array([float(x["value"]) / float(x["full"]) - 1 for x in r]))
        ok = np.array([int(x["result"]) == 0 for x in r])
        est = np.array([float(x["estimate"]) for x in r])
        trunc = np.array([float(x["full_truncation"]) for x in r])
        worst = np.max(err[ok]) if ok.any() else math.nan
        worst_t = np.max(err[ok] - trunc[ok]) if ok.any() else math.nan
        print(f"{name:16s} {len([x for x in rows if x['method'] == name]):6d} {len(r):6d} {int(ok.sum()):6d} "
              f"{worst:11.1%} {worst_t:8.1%} {np.mean(est >= err):10.1%} {np.mean(est + trunc >= err):16.1%}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["errors", "gradients", "differences", "inertia"])
    ap.add_argument("--out", default="approx_validity.csv")
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    print(f"device: {jax.devices()[0].device_kind}", file=sys.stderr)
    if args.what == "errors":
        errors(args)
    elif args.what == "gradients":
        gradients(args)
    elif args.what == "inertia":
        inertia(args)
    else:
        differences(args)


RHO = 1000.0
INERTIA_FRACTIONS = (0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8)


def inertia_cases(quick):
    G0 = 3e6
    c_s = math.sqrt(G0 / RHO)
    speeds = c_s * np.asarray(INERTIA_FRACTIONS)
    for tau in ((1e-6, 1e-4) if quick else (1e-6, 1e-4, 0.25)):
        for f in ((1.0,) if quick else (0.1, 1.0, 3.0)):
            for H in (math.inf, 0.03):
                for geometry, P in (("sphere", 100.0), ("cylinder", 5000.0)):
                    yield dict(material=f"SLS f={f:g} tau={tau:g}", T=math.nan, G0=G0, tau=tau, f=f, H=H, R=0.02,
                               loads=np.array([P]), speeds=speeds, geometry=geometry)


def inertia(args):
    """The approximate methods against the full model on layers with inertia (module docstring)."""
    rows = []
    fields = FIELDS + ["geometry", "V_over_cs"]
    with open(args.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fields)
        w.writeheader()
        for k, case in enumerate(inertia_cases(args.quick)):
            t0 = time.perf_counter()
            mat = jr.StandardLinearSolid(case["G0"], case["tau"], case["f"])
            layer = jr.Layer(case["H"], rho=RHO)
            methods = {n: m for n, m in APPROX.items() if case["geometry"] == "sphere" or n.startswith("direct")}

            def run(method):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    return jr.rolling_resistance_grid(mat, layer, radius=case["R"], loads=case["loads"],
                                                      speeds=case["speeds"], method=method,
                                                      geometry=case["geometry"])
            full = run(jr.Full())
            for name, method in methods.items():
                res = run(method)
                for i, V in enumerate(case["speeds"]):
                    row = {key: case[key] for key in ("material", "T", "G0", "tau", "f", "H", "R", "geometry")}
                    row.update(case=k, P=case["loads"][0], V=V, V_over_cs=V / math.sqrt(case["G0"] / RHO),
                               method=name, value=float(res.value[i, 0]), result=int(res.result[i, 0]),
                               estimate=float(estimate_of(res)[i, 0]), contact_radius=float(res.contact_radius[i, 0]),
                               full=float(full.value[i, 0]), full_result=int(full.result[i, 0]),
                               full_contact_radius=float(full.contact_radius[i, 0]),
                               full_truncation=float(full.truncation[i, 0]))
                    w.writerow(row)
                    rows.append(row)
            fh.flush()
            print(f"case {k} ({case['material']} H={case['H']:g} {case['geometry']}): "
                  f"{time.perf_counter() - t0:.1f} s", flush=True)
    report(rows)
    print("\nper method and V/c_s: worst |error| where both are successful, and worst |error|/estimate")
    for name in APPROX:
        line = []
        for frac in INERTIA_FRACTIONS:
            sel = [r for r in rows if r["method"] == name and abs(r["V_over_cs"] - frac) < 1e-9
                   and r["full_result"] == 0 and r["full"] > 0]
            if not sel:
                continue
            err = [abs(r["value"] / r["full"] - 1) for r in sel]
            over = [e / r["estimate"] for e, r in zip(err, sel)]
            line.append(f"{frac:g}: {max(err):.3f} ({max(over):.2f}x)")
        print(f"{name:16s} " + "  ".join(line))


GRAD_CASES = [  # geometry, H [m], load, radius
    ("sphere", 0.03, 100.0, 0.02),
    ("sphere", math.inf, 100.0, 0.02),
    ("cylinder", 0.03, 5000.0, 0.02),
]
GRAD_SPEEDS = (1e-3, 1e-2, 1.0)
PARAMS = ("G0", "tau", "f", "H")


def log_sensitivities(method, geometry, H, P, R, V):
    """``d ln R_r / d ln p`` for p = G0, tau, f, H (SLS 3 MPa, 0.25 s, f = 1) by ``jax.grad``
    through the front door with the method resolved at the point; also R_r and validity."""
    mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
    layer = jr.Layer(H)
    m = jr.methods.as_method(method).resolve(mat, layer, radius=R, loads=[P], speeds=[V], geometry=geometry)

    def log_r(logp):
        p = {k: jnp.exp(v) for k, v in logp.items()}
        lay = jr.Layer(p["H"]) if math.isfinite(H) else layer
        res = jr.rolling_resistance(jr.StandardLinearSolid(p["G0"], p["tau"], p["f"]), lay, radius=R, load=P,
                                    speed=V, geometry=geometry, method=m, throw=False)
        return jnp.log(res.value), res

    logp = {"G0": jnp.log(3e6), "tau": jnp.log(0.25), "f": jnp.log(1.0), "H": jnp.log(H if math.isfinite(H) else 1.0)}
    g, res = jax.grad(log_r, has_aux=True)(logp)
    return {k: float(g[k]) for k in PARAMS}, float(res.value), bool(res.valid)


def agree(approx, full):
    """Same sign and within 30 % of the full model's sensitivity, or both below 0.05 (negligible)."""
    if abs(full) < 0.05 and abs(approx) < 0.05:
        return "~0"
    if np.sign(approx) != np.sign(full):
        return "SIGN"
    return "ok" if abs(approx / full - 1) <= 0.3 else "size"


def full_difference(geometry, H, P, R, V, step=0.1):
    """``d ln R_r / d ln p`` of the full model (exact discrete contact) by central differences
    of ``ln R_r`` over ``p (1 +- step)``, the automatic grid re-resolved at each point: the grid
    then scales with the contact, so its discretisation error is the same on both sides and
    the difference sees the physics, not the contact edge crossing cells."""
    base = dict(G0=3e6, tau=0.25, f=1.0, H=H)
    out = {}
    for k in PARAMS:
        if k == "H" and not math.isfinite(H):
            out[k] = 0.0
            continue
        logs = []
        for sgn in (1.0, -1.0):
            p = dict(base)
            p[k] = base[k] * (1.0 + sgn * step)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = jr.rolling_resistance(jr.StandardLinearSolid(p["G0"], p["tau"], p["f"]), jr.Layer(p["H"]),
                                            radius=R, load=P, speed=V, geometry=geometry, throw=False)
            logs.append(math.log(float(res.value)))
        out[k] = (logs[0] - logs[1]) / (math.log(1.0 + step) - math.log(1.0 - step))
    return out


def differences(args):
    """The full model's sensitivities by central differences (see :func:`full_difference`)."""
    print("geometry | H [mm] | V [m/s] | full, central differences +-10 %, grid re-resolved | "
          + " | ".join(f"dlnR/dln{k}" for k in PARAMS))
    for geometry, H, P, R in GRAD_CASES:
        for V in GRAD_SPEEDS:
            d = full_difference(geometry, H, P, R, V)
            print(f"{geometry} | {H * 1e3:g} | {V:g} | full (differences) | " + " | ".join(f"{d[k]:+.3f}" for k in PARAMS),
                  flush=True)


def gradients(args):
    names = {"sphere": ["full", "full-smooth", "direct-relaxed", "direct-dynamic", "direct-glassy", "PD", "SP"],
             "cylinder": ["full", "full-smooth", "direct-relaxed", "direct-dynamic", "direct-glassy"]}
    print("geometry | H [mm] | V [m/s] | method | valid | " + " | ".join(f"dlnR/dln{k}" for k in PARAMS))
    for geometry, H, P, R in GRAD_CASES:
        for V in GRAD_SPEEDS:
            full = None
            for name in names[geometry]:
                method = {"full": jr.Full(), "full-smooth": jr.Full(edge_smoothing=jr.methods.FIT_EDGE_SMOOTHING)}.get(
                    name, APPROX.get(name))
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    t0 = time.perf_counter()
                    g, value, valid = log_sensitivities(method, geometry, H, P, R, V)
                if name == "full-smooth":
                    full = g
                cells = [f"{g[k]:+.3f}" + ("" if full is None or name == "full-smooth" else f" ({agree(g[k], full[k])})")
                         for k in PARAMS]
                print(f"{geometry} | {H * 1e3:g} | {V:g} | {name} | {'yes' if valid else 'no'} | " + " | ".join(cells)
                      + f"   [{time.perf_counter() - t0:.1f} s]", flush=True)


if __name__ == "__main__":
    main()
