"""Write the generated parts of the docs from benchmarks/numbers.json.

    python benchmarks/render_docs.py            # rewrite the generated blocks in place
    python benchmarks/render_docs.py --check    # exit 1 (and name them) where a block is stale

A generated block sits between ``<!-- generated: NAME -->`` and ``<!-- /generated: NAME -->`` in
a Markdown file; its text is :data:`BLOCKS` ``[NAME](numbers)``. tests/test_docs_numbers.py runs
the check, so a number quoted in the docs cannot drift from the file its script wrote.
"""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
NUMBERS = ROOT / "benchmarks" / "numbers.json"

#: README method rows: (shortcut, README method cell, what it solves, geometry, default for)
METHOD_ROWS = [
    ("full", '`jr.Full()`, `"full"`', "the rolling contact: pressure and contact set solved",
     "sphere (3D), cylinder (2D)", "sphere, cylinder"),
    ("SP", '`jr.Slices("SP")`, `"SP"`', "[ZG] sec. 3: sphere from 21 plane-strain slices", "sphere", ""),
    ("PP", '`jr.Slices("PP")`, `"PP"`', "slices, load equilibrium", "sphere", ""),
    ("PD", '`jr.Slices("PD")`, `"PD"`', "slices, penetration consistency", "sphere", ""),
    ("direct", '`jr.Direct()`, `"direct"`', "[ZG] sec. 4: stationary pressure, no grid", "sphere, cylinder", ""),
]


def _machine(m: dict) -> str:
    load = "-".join(f"{x:g}" for x in sorted({m["load_average"][0], m["load_average"][-1]}))
    return (f"{m['date']}, commit {m['commit']}, jax {m['jax']}, {m['cores']}-core {m['cpu']} "
            f"({m['device']}), load average {load}")


def _pct(x):
    return f"{x:+.0%}".replace("+0%", "0 %").replace("%", " %") if abs(x) >= 0.005 else "0 %"


def _deviations(rows, geometry, H, method):
    """'+3, +1, -9, -13 %' over the recorded speeds, '(N flagged)' for the points not valid."""
    sel = sorted((r for r in rows if r["geometry"] == geometry and r["H"] == H and r["method"] == method),
                 key=lambda r: r["V"])
    if not sel or method == "full":
        return "reference" if sel else ""
    parts = [f"{r['deviation']:+.0%}".replace("%", "").replace("+0", "0").replace("-0", "0") for r in sel]
    flagged = sum(not r["valid"] for r in sel)
    note = "" if not flagged else (" (flagged)" if flagged == len(sel) else f" ({flagged} of {len(sel)} flagged)")
    return ", ".join(parts) + " %" + note


def methods_table(numbers: dict) -> str:
    sec = numbers["default_method"]
    rows = sec["rows"]
    speeds = sorted({r["V"] for r in rows})
    lines = [
        f"Deviation from the full model for a sphere (100 N, R = 2 cm) at V = {', '.join(f'{v:g}' for v in speeds)} "
        f"m/s on H = 5 mm / 30 mm, measured by `{sec['command']}` ({_machine(sec['measured'])}); a point the "
        "method itself marks not valid is flagged. Costs and the cylinder: [docs/methods.md](docs/methods.md) and "
        "[benchmarks/README.md](benchmarks/README.md).",
        "",
        "| `method=` | what it solves | geometry | default for | vs full, H = 5 mm | vs full, H = 30 mm |",
        "|---|---|---|---|---|---|",
    ]
    for key, cell, what, geometry, default in METHOD_ROWS:
        lines.append(f"| {cell} | {what} | {geometry} | {default} | {_deviations(rows, 'sphere', 0.005, key)} | "
                     f"{_deviations(rows, 'sphere', 0.03, key)} |")
    return "\n".join(lines)


def _time(s):
    return f"{s * 1e3:.1f} ms" if s < 1 else f"{s:.2f} s"


def default_method_table(numbers: dict) -> str:
    sec = numbers["default_method"]
    lines = [
        f"`{sec['command']}`, {_machine(sec['measured'])}. Paper material (G0 = 3 MPa, tau = 0.25 s, f = 1), "
        "R = 2 cm, P = 100 N (sphere) or 5000 N/m (cylinder), one `jr.rolling_resistance` call per point with the "
        "method's automatic grid. First call = grid sizing + compilation + run, in the order of the rows (a later "
        "row reuses a compiled program when the shapes match); run = median of 3 further calls. Deviation = "
        "method / full model - 1.",
        "",
        "| geometry | H | V [m/s] | method | first call | run | R_r | vs full |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in sec["rows"]:
        unit = "N" if r["geometry"] == "sphere" else "N/m"
        flag = "" if r["valid"] else f" (not valid: {r['reasons']})"
        dev = "" if r["deviation"] is None or r["method"] == "full" else f"{r['deviation']:+.1%}"
        lines.append(f"| {r['geometry']} | {r['H'] * 1e3:g} mm | {r['V']:g} | {r['method']} | {_time(r['first_s'])} | "
                     f"{_time(r['run_s'])} | {r['value']:.4g} {unit}{flag} | {dev} |")
    return "\n".join(lines)


#: docs/methods.md's comparison rows: (method, what it solves, geometries)
COMPARED_ROWS = [
    ("full", "pressure and contact set (primal-dual active set, FFT-applied compliance, implicit gradients)",
     ("sphere", "cylinder")),
    ("SP", "[ZG] sec. 3: 21 plane-strain slices, penetration and load consistent (eq. 11)", ("sphere",)),
    ("PP", "slices in load equilibrium (eq. 10)", ("sphere",)),
    ("PD", "slices with consistent penetration (eq. 9)", ("sphere",)),
    ("direct", "[ZG] sec. 4: a stationary (elastic) pressure dissipating in the rolling compliance",
     ("sphere", "cylinder")),
]


def _range(values, fmt):
    lo, hi = fmt(min(values)), fmt(max(values))
    return lo if lo == hi else f"{lo}-{hi}"


def methods_compared(numbers: dict) -> str:
    """docs/methods.md's table: each method's deviation from the full model at the recorded speeds
    (one decimal), points it flags, and its per-call and first-call costs (ranges)."""
    sec = numbers["default_method"]
    rows = sec["rows"]
    speeds = sorted({r["V"] for r in rows})
    lines = [f"`{sec['command']}` ({_machine(sec['measured'])}); deviation = method / full model - 1 at "
             f"V = {', '.join(f'{v:g}' for v in speeds)} m/s, `*` = the method flags the point not valid:",
             "", "| `method=` | solves | geometry | vs full, H = 5 mm | vs full, H = 30 mm | per call | first call |",
             "|---|---|---|---|---|---|---|"]
    for method, solves, geometries in COMPARED_ROWS:
        for k, g in enumerate(geometries):
            sel = [r for r in rows if r["method"] == method and r["geometry"] == g]
            if not sel:
                continue
            cells = []
            for H in (0.005, 0.03):
                pts = sorted((r for r in sel if r["H"] == H), key=lambda r: r["V"])
                cells.append("reference" if method == "full" else
                             ", ".join(f"{100 * r['deviation']:+.1f}{'' if r['valid'] else '*'}" for r in pts) + " %")
            run = _range([r["run_s"] for r in sel], _time)
            first = _range([r["first_s"] for r in sel if r["first_s"] > 0.5] or [r["first_s"] for r in sel], _time)
            name = {"full": "jr.Full()", "direct": "jr.Direct()"}.get(method, f'jr.Slices("{method}")')
            head = f"`{name}` | {solves}" if k == 0 else " | "
            lines.append(f"| {head} | {g} | {cells[0]} | {cells[1]} | {run} | {first} |")
    return "\n".join(lines)


def first_use(numbers: dict) -> str:
    sec = numbers["first_use"]
    m = sec["measured"]
    parts = []
    if "reproduce_quick" in sec:
        r = sec["reproduce_quick"]
        parts.append(f"`jaxroll reproduce --quick` took {r['seconds']:.0f} s in an empty folder with an empty "
                     f"compilation cache (load average {r['load_before']:g} before, {r['load_after']:g} after)")
    if "suite" in sec:
        s = sec["suite"]
        counts = ", ".join(f"{s[k]} {k}" for k in ("passed", "failed", "skipped", "deselected") if s.get(k))
        parts.append(f"the tests ({counts}) took {s['pytest_s'] / 60:.1f} min of pytest inside "
                     f"{s['ci_run_s'] / 60:.1f} min of `.ci/run` on a clean clone (install included; load average "
                     f"{s['load_before']:g} before, {s['load_after']:g} after)")
    return (f"Measured by `python benchmarks/first_use.py` on {m['cores']} cores, {m['cpu']} ({m['date']}, "
            f"commit {m['commit']}): " + "; ".join(parts) + ".")


def _batched_parts(numbers: dict, prefix: str) -> list:
    """The recorded ``bench_batched.py`` runs of one device, reference-case rows first."""
    return [numbers[k] for k in (f"{prefix}_all", f"{prefix}_reference", f"{prefix}_map") if k in numbers]


def _batched_header(sec: dict) -> str:
    return (f"`{sec['command']}`, {_machine(sec['measured'])}; {sec['load_start']:g} at the start of the run")


def batched_table(numbers: dict) -> str:
    """Every batched entry point on the CPU, per point and against the warm-started table."""
    parts = _batched_parts(numbers, "batched")
    lines = ["; ".join(_batched_header(sec) for sec in parts) + ". The machine is shared: each entry ran "
             "alternately with its baseline in the same process, so compare the ratio column. Medians; compile "
             "ahead of time, apart.", "",
             "| entry | per point | compile | ratio to the table | note |", "|---|---|---|---|---|"]
    for sec in parts:
        for r in sec["rows"]:
            lines.append(f"| {r['entry']} | {r['per_point_s'] * 1e3:.2f} ms | {r['compile_s']:.1f} s "
                         f"| {r['ratio']:.2f}x | {r['note']} |")
    return "\n".join(lines)


def _commits_differ(gpu: list, cpu: list) -> str:
    """A warning when the GPU and CPU rows measured different commits."""
    g = sorted({sec["measured"]["commit"] for sec in gpu})
    c = sorted({sec["measured"]["commit"] for sec in cpu})
    if g == c:
        return ""
    return (f" The GPU rows measured commit {', '.join(g)} and the CPU rows {', '.join(c)}: where the code of an "
            "entry changed in between, the ratio compares different code (benchmarks/LOG.md).")


def batched_gpu_table(numbers: dict) -> str:
    """The same entry points on a GPU, with the CPU's figure where the CPU table has the entry."""
    parts = _batched_parts(numbers, "batched_gpu")
    cpu = {r["entry"]: r for sec in _batched_parts(numbers, "batched") for r in sec["rows"]}
    jax_version = parts[0]["measured"]["jax"] if parts else ""
    lines = ["; ".join(_batched_header(sec) for sec in parts) + f". jax {jax_version} is the one installed on that "
             "machine (the project's pin below 0.10 guards against a deadlock on the CPU). Medians; compile ahead of "
             "time, apart; \"GPU / CPU\" divides the GPU's time per point by the CPU's in the table above."
             + _commits_differ(parts, _batched_parts(numbers, "batched")), "",
             "| entry | per point | compile | ratio to the table | GPU / CPU | note |", "|---|---|---|---|---|---|"]
    for sec in parts:
        for r in sec["rows"]:
            c = cpu.get(r["entry"])
            vs = f"{r['per_point_s'] / c['per_point_s']:.2f}x" if c else "not on the CPU table"
            lines.append(f"| {r['entry']} | {r['per_point_s'] * 1e3:.2f} ms | {r['compile_s']:.1f} s "
                         f"| {r['ratio']:.2f}x | {vs} | {r['note']} |")
    return "\n".join(lines)


def defaults_table(numbers: dict) -> str:
    """Time per point and first call in a fresh process of every entry point with its default method."""
    sec = numbers["defaults"]
    sec_s = lambda x: "not measured" if x is None else f"{x:.1f} s"  # noqa: E731
    lines = [f"`{sec['command']}`, {_machine(sec['measured'])}; {sec['load_start']:g} at the start of the run. "
             "First call: `import jaxroll`, the inputs and the first call, timed inside a new Python process, with "
             "the persistent compilation cache off, and on in a second process after a first one filled a new "
             "cache folder.", "",
             "| entry | per point | first call, cache off | first call, cache on (second process) |",
             "|---|---|---|---|"]
    for r in sec["rows"]:
        lines.append(f"| {r['entry']} | {r['per_point_s'] * 1e3:.1f} ms | {sec_s(r['first_cache_off_s'])} "
                     f"| {sec_s(r['first_cache_on_s'])} |")
    return "\n".join(lines)


def compile_options_table(numbers: dict) -> str:
    """Compile and run CPU seconds of jaxroll's heavy programs per XLA option set, against XLA's
    defaults (``compile_options.py --record``), and a new interpreter's first call."""
    sec = numbers["compile_options"]
    names = {"reference": "reference table (23 x 15, window 55)", "reference-grad": "its gradient (G0, tau, f, H)",
             "point": "default sphere point", "point-grad": "its gradient (G0, tau, f, H)",
             "point-rho": "default sphere point, layer with inertia",
             "map": "resistance map's largest program (9 x 9)", "fit": "sphere fit's evaluation (residuals, Jacobian)"}
    base = {r["program"]: r for r in sec["rows"] if r["set"] == "base"}
    lines = [f"`{sec['command']}`, {_machine(sec['measured'])}; {sec['load_start']:g} at the start of the run. "
             "CPU seconds (process user + system), medians over the rounds, each compile from a fresh lowering; "
             "\"max rel diff\": the outputs' largest relative difference to XLA's defaults. Option sets: "
             + "; ".join(f"{s}: " + (", ".join(f"`{k}={v}`" for k, v in o.items()) or "XLA's defaults")
                         for s, o in sec["options"].items()) + ".", "",
             "| program | options | compile | vs defaults | run | vs defaults | max rel diff |",
             "|---|---|---|---|---|---|---|"]
    for r in sec["rows"]:
        b = base[r["program"]]
        lines.append(f"| {names.get(r['program'], r['program'])} | {r['set']} | {r['compile_cpu_s']:.2f} s | "
                     f"{r['compile_cpu_s'] / b['compile_cpu_s']:.2f}x | {_time(r['run_cpu_s'])} | "
                     f"{r['run_cpu_s'] / b['run_cpu_s']:.2f}x | {r['max_rel_diff']:.1e} |")
    first = numbers.get("compile_options_first_call")
    if first:
        on = [r["cpu_s"] for r in first["rows"] if r["options"]]
        off = [r["cpu_s"] for r in first["rows"] if not r["options"]]
        span = lambda xs: f"{min(xs):.1f}" + (f"-{max(xs):.1f}" if max(xs) - min(xs) >= 0.05 else "")  # noqa: E731
        lines += ["", f"A new interpreter's first call of the default sphere point (import, grid sizing, compiles, an "
                  f"empty compilation cache; `{first['command']}`, {_machine(first['measured'])}): "
                  f"**{span(on)} s CPU with jaxroll's options, {span(off)} s with XLA's defaults** "
                  f"({len(on)} runs each, alternating)."]
    return "\n".join(lines)


def slowest_tests(numbers: dict) -> str:
    """The 25 slowest tests of the recorded clean-clone suite run (pytest's ``--durations``, wall
    seconds inside one pytest-xdist worker)."""
    sec = numbers["first_use"]
    m, s = sec["measured"], sec["suite"]
    lines = [f"The 25 slowest tests of that run (wall seconds in one of the pytest-xdist workers; {m['cores']} cores, "
             f"{m['cpu']}, commit {m['commit']}, load average {s['load_before']:g} before, {s['load_after']:g} "
             f"after; `pytest` prints them after every run):", "", "| s | test |", "|---:|---|"]
    lines += [f"| {sec_:.1f} | `{name.removeprefix('tests/')}`{'' if phase == 'call' else f' ({phase})'} |"
              for sec_, phase, name in s.get("slowest", [])]
    return "\n".join(lines)


#: resistance_forms.py's material tags, as the docs name them
_FORMS_MATERIALS = {"s01": "SLS f = 0.1", "s03": "SLS f = 0.3", "s05": "SLS f = 0.5", "s1": "SLS f = 1",
                    "s2": "SLS f = 2", "s3": "SLS f = 3", "s10": "SLS f = 10",
                    "pr": "Prony, 20 decades", "st": "Prony, 12 decades"}


def _forms_source(sec: dict) -> str:
    return f"`{sec['command']}` ({_machine(sec['measured'])})"


def forms_convergence(numbers: dict) -> str:
    """Errors of M / D by regime and cells per radius: standard linear solid f = 1, cylinder
    against the exact solution, sphere against D extrapolated to zero cell size."""
    sec = numbers["resistance_forms"]
    rows = {(r["geometry"], r["zeta"]): r["grids"] for r in sec["rows"]
            if r["material"] == "s1" and not r["validation"] and r["load"] in (100.0, 1e4)}
    cols = [("cylinder", 12), ("cylinder", 25), ("cylinder", 100), ("sphere", 12), ("sphere", 16), ("sphere", 24),
            ("sphere", 48)]
    lines = [f"Written from {_forms_source(sec)}.", "",
             "| zeta | cylinder 12 | 25 | 100 | sphere 12 | 16 | 24 | 48 |", "|---|---|---|---|---|---|---|---|"]
    for z in (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1000.0):
        cells = []
        for g, c in cols:
            m, d, _flag = rows[(g, z)][str(c)]
            cells.append(f"{m:+.2f} / {d:+.2f}")
        lines.append(f"| {z:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _forms_label(r: dict) -> str:
    z = r["zeta"]
    where = f"zeta = {z:g}" if z > 0 else f"V = {-z:g} m/s"
    load = "" if r["load"] in (100.0, 1e4) else f", {r['load']:g} N"
    return f"{_FORMS_MATERIALS[r['material']]}, {where}{load}"


def default_grid_accuracy(numbers: dict) -> str:
    """The default grid at every point of the study: cells, error of the reported value and its
    truncation, with a count of the points whose error the truncation bounds."""
    sec = numbers["resistance_forms"]
    points = {}
    for r in sec["rows"]:
        other_load = 0.0 if r["load"] in (100.0, 1e4) else r["load"]  # the study's loads: 100 N, 10 kN/m
        points.setdefault((r["validation"], r["material"], other_load, r["zeta"]), {})[r["geometry"]] = r
    lines = [f"Written from {_forms_source(sec)}: the default grid's cells per counting contact size, the "
             "error [%] of the study's run at that grid and, in brackets, the `truncation` [%] the default "
             "reports; rows in brackets are the validation set (points off the tables' calibration). The study's "
             "runs count cells on the relaxed contact size; the one used is the finest not finer than the "
             "default's grid (named where its count differs); - : none.",
             "", "| point | cylinder | sphere |", "|---|---|---|"]
    bounded = total = 0
    for key in sorted(points, key=lambda k: (k[0], list(_FORMS_MATERIALS).index(k[1]), k[2], k[3] < 0, abs(k[3]))):
        by_geometry = points[key]
        cells = []
        for g in ("cylinder", "sphere"):
            d = by_geometry.get(g, {}).get("default")
            if d is None:
                cells.append("-")
                continue
            total += 1
            bounded += abs(d["error"]) <= d["truncation"]
            run = "" if d["study_cells"] == d["cells"] else f" (study run: {d['study_cells']})"
            cells.append(f"{d['error']:+.2f} ({d['truncation']:.2f}), {d['cells']} cells{run}")
        label = _forms_label(next(iter(by_geometry.values())))
        lines.append(f"| {'[' + label + ']' if key[0] else label} | {cells[0]} | {cells[1]} |")
    lines += ["", f"The truncation bounds the error at {bounded} of the {total} default points."]
    return "\n".join(lines)


def thin_layer_accuracy(numbers: dict) -> str:
    """The default grid on layers thinner than the half-space calibration, by thickness band:
    points, valid ones, the worst error of the valid ones, and how many errors the truncation
    bounds."""
    sec = numbers["thin_layer_error"]
    lines = [f"Written from `{sec['command']}` ({_machine(sec['measured'])}): the default grid's cells per "
             "counting contact size at each point of the study (rows in brackets: the validation set), how many "
             "points are valid (solved, `truncation` <= 5 %), the largest |error| [%] of a valid point against the "
             "value extrapolated to zero cell size, and at how many points the `truncation` bounds the error.",
             "", "| geometry | a/H | default cells | points | valid | worst valid error [%] | bounded |",
             "|---|---|---|---|---|---|---|"]
    for r in sec["summary"]:
        lo, hi = r["ratios"]
        band = f"{lo:g}-{hi:g}" if hi < 100 else f">= {lo:g}"
        band = f"[{band}]" if r["validation"] else band
        lines.append(f"| {r['geometry']} | {band} | {r['cells'][0]}-{r['cells'][1]} | {r['points']} | {r['valid']} | "
                     f"{r['worst_valid_error']:.2f} | {r['bounded']} of {r['points']} |")
    return "\n".join(lines)


def _summary(path: Path) -> str:
    """The first sentence of a script's docstring, on one line."""
    import ast

    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    first = " ".join(doc.split("\n\n")[0].split())
    end = re.search(r"\.(\s+(?=[A-Z])|$)", first)  # a full stop before a capital or at the end
    return first[:end.start() + 1] if end else first


def scripts(numbers: dict) -> str:
    """One line per benchmark script (``benchmarks/*.py`` without a leading underscore), from its
    docstring; every script prints its own usage with ``--help``."""
    folder = ROOT / "benchmarks"
    rows = [f"| `{p.name}` | {_summary(p)} |" for p in sorted(folder.glob("*.py")) if not p.name.startswith("_")]
    return "\n".join(["| script | what it measures |", "|---|---|", *rows])


def _round1(x: float) -> str:
    """A regime to one significant digit (the runs aim at 0.01, 0.1, ... and land within 0.2 %)."""
    return f"{float(f'{x:.1g}'):g}"


_EDGE_RUNS = {"f0.3": "SLS f = 0.3", "f1": "SLS f = 1", "f3": "SLS f = 3", "prony": "a 6-term Prony series"}


def edge_smoothing(numbers: dict) -> str:
    """Bias [%] of the smoothed edge at kappa and 2 kappa and of its extrapolation (the fitting
    default) against the exact discrete contact on the default grid; the cylinder's errors against
    the exact 2D solution; one line with the largest extrapolated bias of every other run."""
    runs = numbers["edge_smoothing"]["runs"]
    sphere, cylinder = runs["sphere-f1"], runs["cylinder-f1"]
    k = sphere["kappa"]
    zetas = [r["zeta"] for r in sphere["rows"]]
    lines = [f"Written from `{sphere['command']}` ({_machine(sphere['measured'])}) and its `--geometry cylinder` run; "
             "half-space, standard linear solid f = 1; bias of the reported dissipation form [%]:", "",
             "| zeta | " + " | ".join(_round1(z) for z in zetas) + " |", "|---" * (len(zetas) + 1) + "|"]

    def row(label, values, fmt="{:+.3f}", bold=False):
        cells = [(f"**{fmt.format(v)}**" if bold else fmt.format(v)) if v is not None else "-" for v in values]
        lines.append(f"| {f'**{label}**' if bold else label} | " + " | ".join(cells) + " |")

    for name, run, unit in (("sphere", sphere, "cells per radius"), ("cylinder", cylinder, "cells per half-width")):
        rs = run["rows"]
        row(f"{name} {unit}", [r["cells"] for r in rs], "{:.0f}")
        row(f"{name}, kappa {2 * run['kappa']:g}", [r["kappa2"] for r in rs], "{:+.2f}")
        row(f"{name}, kappa {run['kappa']:g}", [r["kappa"] for r in rs], "{:+.2f}")
        row(f"{name}, extrapolated (fit default)", [r["extrapolated"] for r in rs], bold=True)
    row("cylinder: exact discrete vs the exact 2D solution", [r["exact_vs_2d"] for r in cylinder["rows"]], "{:+.2f}")
    row("cylinder: extrapolated vs the exact 2D solution", [r["extrapolated_vs_2d"] for r in cylinder["rows"]],
        "{:+.2f}")
    others = []
    for key in sorted(runs):
        if key in ("sphere-f1", "cylinder-f1"):
            continue
        geometry, material = key.split("-", 1)
        rs = runs[key]["rows"]
        worst = max(rs, key=lambda r: abs(r["extrapolated"]))
        span = f"zeta {_round1(min(r['zeta'] for r in rs))}-{_round1(max(r['zeta'] for r in rs))}"
        label = _EDGE_RUNS.get(material) or f"SLS f = {material.removeprefix('f')}"
        others.append(f"{label} ({geometry}, {span}) {abs(worst['extrapolated']):.3f} % "
                      f"(at zeta = {_round1(worst['zeta'])})")
    flagged = {}
    for key, run in runs.items():
        for r in run["rows"]:
            for name in set(r.get("results", [])) - {"successful"}:
                flagged.setdefault(name, []).append(key)
    note = "; ".join(f"`{name}` at {len(keys)} points (run {', '.join(sorted(set(keys)))}), by the exact and the "
                     "smoothed model alike" for name, keys in flagged.items())
    lines += ["", "Largest extrapolated bias of the other runs (same script, `--f` / `--prony` / `--geometry`): "
              + "; ".join(others) + ". Points flagged not valid by the models: " + (note or "none") + "."]
    return "\n".join(lines)


def _pct1(x):
    return f"{x * 100:+.1f} %"


def prony_smoothness_table(numbers: dict) -> str:
    """docs/dma.md: terms, rms, loss extrema and plateau bias of the smoothed fits."""
    sec = numbers["prony_plateau"]
    lines = ["| fit | terms | rms log residual | loss extrema | coldest-set storage |", "|---|---|---|---|---|"]
    for r in sec["smoothness"]:
        lam = r["smoothness"]
        label = ("`smoothness=None` (fewest terms)" if lam is None else
                 f"`smoothness={lam:g}`" + (" (default)" if lam == 3.0 else ""))
        lines.append(f"| {label} | {r['terms']} | {r['rms']:.4f} | {r['loss_extrema']} | {_pct1(r['cold_bias'])} |")
    lines.append(f"\n(`{sec['command']}`, {_machine(sec['measured'])}.)")
    return "\n".join(lines)


def prony_plateau_table(numbers: dict) -> str:
    """docs/dma.md: the instrument error model against the glassy plateau, the loss near its peak,
    the storage the loss implies and the synthetic check."""
    sec = numbers["prony_plateau"]
    ship = sec["plateau"]["shipped (21 sets)"]
    lines = ["| smooth fit | coldest-set storage | rms log storage | rms log loss | loss near the peak "
             "| mean log loss residual, tan delta < 0.02 / 0.02-0.1 / >= 0.1 |", "|---|---|---|---|---|---|"]
    for r in ship["rows"]:
        label = r["fit"].replace("phase_sigma", "`phase_sigma`")
        if r["fit"] == f"phase_sigma {sec['phase_sigma'] * 1e3:.2f} mrad":
            label += " (0.1 deg, assumed)"
        elif r["fit"] == "phase_sigma 0.00 mrad":
            label += " (default)"
        bands = " / ".join(f"{r['loss_bias_by_tan'][k]:+.2f}" for k in ("< 0.02", "0.02-0.1", ">= 0.1"))  # json sorts keys
        lines.append(f"| {label} | {_pct1(r['cold_bias'])} | {r['rms_storage']:.3f} | {r['rms_loss']:.3f} | "
                     f"{r['rms_loss_peak']:.3f} | {bands} |")
    kk = ship["kk_implied"]
    lines += ["", "Storage that the measured loss implies (Kramers-Kronig), coldest set: "
              f"{_pct1(kk['+0'])}; with the phase moved by -0.4, -0.2, -0.1, +0.1 deg: "
              f"{', '.join(_pct1(kk[k]) for k in ('-4', '-2', '-1', '+1'))}. The same estimate on the exact "
              f"synthetic curve: {sec['synthetic_kk_implied'] * 100:+.2f} %.", "",
              "| synthetic curve, errors | glassy storage, `phase_sigma=0` (default) | `phase_sigma` 0.1 deg |",
              "|---|---|---|"]
    for r in sec["synthetic"]:
        b = [r["glassy_bias"]["0.00"], r["glassy_bias"][f"{sec['phase_sigma'] * 1e3:.2f}"]]
        lines.append(f"| 1 % on \\|G*\\|, 0.1 deg on delta, {r['errors']} | {b[0] * 100:+.2f} % | {b[1] * 100:+.2f} % |")
    lines.append(f"\n(`{sec['command']}`, {_machine(sec['measured'])}.)")
    return "\n".join(lines)


def _speed(v):
    return f"{v * 1e3:g} mm/s" if v < 0.1 else f"{v:g} m/s"


def prony_rolling_table(numbers: dict) -> str:
    """docs/dma.md: the temperatures where dR/dT changes sign per fit, method and speed, and the
    change of R(T) by the instrument error model (``prony_smoothness.py --rolling --record``)."""
    sec = numbers["prony_rolling"]
    runs = {}
    for r in sec["extrema"]:
        runs.setdefault((r["method"], r["step"]), []).append(r)
    names = {"direct": "direct method", "full": "full 3D model"}
    heads = [f"{names[m]}, {step:g} K steps: " + ", ".join(dict.fromkeys(_speed(r["speed"]) for r in rs))
             for (m, step), rs in runs.items()]
    lines = ["| fit | " + " | ".join(heads) + " |", "|---" * (len(heads) + 1) + "|"]
    for fit in dict.fromkeys(r["fit"] for r in sec["extrema"]):
        cells = []
        for rs in runs.values():
            mine = [r for r in rs if r["fit"] == fit]
            cells.append("; ".join(f"{len(r['at_degC'])}" + (f" ({', '.join(f'{t + 0.0:.0f}' for t in r['at_degC'])})"
                                                              if 0 < len(r["at_degC"]) <= 4 else "") for r in mine))
        lines.append(f"| `{fit}` | " + " | ".join(cells) + " |")
    valid = {m: sorted({r["valid"] for r in rs}) for (m, _), rs in runs.items()}
    points = {m: rs[0]["points"] for (m, _), rs in runs.items()}
    lines += ["", "Points valid, per speed: " + "; ".join(
        f"{names[m]} {v[0]}" + (f"-{v[-1]}" if v[-1] != v[0] else "") + f" of {points[m]}" for m, v in valid.items())
        + ".", ""]
    at = sorted(sec["change"][0]["at"], key=float)  # numbers.json sorts the keys as strings
    lines += ["| R(T), `phase_sigma` 0.1 deg over the default, - 1 | " + " | ".join(f"{t} degC" for t in at)
              + " | median | largest |", "|---" * (len(at) + 3) + "|"]
    for r in sec["change"]:
        lines.append(f"| {names[r['method']]}, {_speed(r['speed'])} | " + " | ".join(_pct1(r["at"][t]) for t in at)
                     + f" | {_pct1(r['median'])} | {_pct1(r['largest'])} at {r['largest_at_degC']:.0f} degC |")
    lines.append(f"\n(`{sec['command']}`, {_machine(sec['measured'])}.)")
    return "\n".join(lines)


#: fitting/README.md's examples (``fit_examples.py``): their number and the model each fits with
FIT_EXAMPLES = {"direct": ("1", "direct"), "joint": ("2", "direct, with DMA"), "cylinder": ("3", "default: full 2D"),
                "sphere": ("4", "default: full 3D")}
_FIT_UNITS = {"G0": (1e6, "MPa"), "tau": (1.0, "s"), "f": (1.0, "")}


def _g3(x: float) -> str:
    """Three significant digits, trailing zeros kept (2.80, 1.00)."""
    return f"{x:#.3g}".rstrip(".")


def _fit_cell(row, name):
    scale, unit = _FIT_UNITS[name]
    lo, hi = (_g3(x / scale) for x in row["ci95"][name])
    miss = "" if row["covered"][name] else " misses"
    return (f"{_g3(row['params'][name] / scale)}{(' ' + unit) if unit else ''} ({row['deviation'][name]:+.1%}) "
            f"[{lo}, {hi}]{miss}").replace("%", " %")


def fit_examples_table(numbers: dict) -> str:
    """fitting/README.md: what each example returns and costs (``fit_examples.py --record``)."""
    sec = numbers["fit_examples"]
    rows = [(key, sec["rows"][key]) for key in FIT_EXAMPLES if key in sec["rows"]]
    lines = [f"`{sec['command']}` ({_machine(sec['measured'])}), each example run as written in one process, one "
             "after the other (each compiles its own programs; the first also pays the import). Value (deviation "
             "from the truth) [95 % interval; \"misses\" where it does not hold the truth]. Time: wall clock on the "
             "shared machine, and the process's CPU time over all threads, at the load average before the example.",
             "", "| example | data | model (grid it ended on) | G0 | tau | f | reduced chi^2 | intervals | time |",
             "|---|---|---|---|---|---|---|---|---|"]
    for key, r in rows:
        number, model = FIT_EXAMPLES[key]
        grid = f" ({r['grid']})" if r["grid"] else ""
        chi2 = f"{r['reduced_chi2']:.3g}" + (" (relative residuals)" if r["sigma_mode"] == "relative" else "")
        lines.append(f"| {number} | `{r['data']}` | {model}{grid} | " + " | ".join(_fit_cell(r, n) for n in _FIT_UNITS)
                     + f" | {chi2} | {r['intervals']} | {r['seconds']:.0f} s wall, {r['cpu_s']:.0f} s CPU "
                       f"(load {r['load_before']:g}; {r['date']}) |")
    pairs = [("G0,tau", "G0-tau"), ("G0,f", "G0-f"), ("tau,f", "tau-f")]
    lines += ["", "Correlations of the log-parameters at the optimum (" + ", ".join(p for _, p in pairs) + "): "
              + "; ".join(f"example {FIT_EXAMPLES[key][0]}: " + ", ".join(f"{r['correlation'][k]:+.3f}" for k, _ in pairs)
                          for key, r in rows) + "."]
    if "grids" in sec:
        lines += ["", "The grid the default fit resolves at the examples' start (`fit_examples.py --grids`): " + "; ".join(
            f"`{name}`: {g['spacing'] * 1e3:.3g} mm cells, window {g['window']} x {g['window']} ({g['window'] ** 2} cells)"
            for name, g in sec["grids"].items()) + "."]
    return "\n".join(lines)


def _binomial_range(n: int, p: float, mass: float = 0.99):
    """Central ``mass`` acceptance range of Binomial(n, p), as scipy's ``ppf`` at (1 -+ mass)/2."""
    cdf, out, total = [], [], 0.0
    for k in range(n + 1):
        total += math.comb(n, k) * p**k * (1 - p) ** (n - k)
        cdf.append(total)
    lo = next(k for k, c in enumerate(cdf) if c >= (1 - mass) / 2)
    hi = next(k for k, c in enumerate(cdf) if c >= (1 + mass) / 2 - 1e-12)
    return lo, hi


#: the intervals each geometry's default fit gives (``intervals="auto"``)
_COVERAGE_INTERVALS = {"cylinder": "profile-likelihood", "sphere": "linearised"}


def fit_coverage(numbers: dict, geometry: str = "cylinder") -> str:
    """fitting/README.md: a geometry's default fit and its intervals' coverage (``fit_coverage.py``)."""
    sec = numbers[f"fit_{geometry}"]
    per, (hits, total), draws = sec["coverage_per_parameter"], sec["coverage"], sec["draws"]
    lo, hi = _binomial_range(draws, 0.95)
    fitted = "; ".join(f"{n} {_g3(sec['params'][n] / _FIT_UNITS[n][0])} [{_g3(sec['ci95'][n][0] / _FIT_UNITS[n][0])}, "
                       f"{_g3(sec['ci95'][n][1] / _FIT_UNITS[n][0])}]" for n in _FIT_UNITS)
    return (f"Measured {_machine(sec['measured'])}: the shipped set gives {fitted} (G0 in MPa, tau in s), "
            f"{sec['first_fit_cpu_s']:g} s of CPU with compilation ({sec['first_fit_s']:g} s wall at load average "
            f"{sec['load_average']:g}). Over {draws} noise draws the 95 % {_COVERAGE_INTERVALS[geometry]} intervals hold the truth in "
            f"**{per['G0']} (G0), {per['tau']} (tau) and {per['f']} (f) of {draws} draws** ({hits} of {total} "
            f"intervals); honest 95 % intervals give {lo}-{hi} per parameter with 99 % probability (binomial; the "
            "three parameters miss together, so the draws are the independent trials).")


#: generated block name -> renderer of numbers.json
BLOCKS = {
    "prony-smoothness": prony_smoothness_table,
    "prony-plateau": prony_plateau_table,
    "prony-rolling": prony_rolling_table,
    "methods-table": methods_table,
    "default-method-table": default_method_table,
    "methods-compared": methods_compared,
    "first-use": first_use,
    "batched-table": batched_table,
    "batched-gpu-table": batched_gpu_table,
    "defaults-table": defaults_table,
    "slowest-tests": slowest_tests,
    "compile-options": compile_options_table,
    "forms-convergence": forms_convergence,
    "default-grid-accuracy": default_grid_accuracy,
    "thin-layer-accuracy": thin_layer_accuracy,
    "edge-smoothing": edge_smoothing,
    "scripts": scripts,
    "fit-examples": fit_examples_table,
    "fit-coverage": fit_coverage,
    "fit-coverage-sphere": lambda numbers: fit_coverage(numbers, "sphere"),
}

#: files holding generated blocks
FILES = [ROOT / "README.md", ROOT / "benchmarks" / "README.md", ROOT / "docs" / "validation.md", ROOT / "docs" / "dma.md",
         ROOT / "docs" / "methods.md", ROOT / "fitting" / "README.md"]

_BLOCK = re.compile(r"(<!-- generated: ([\w-]+) -->\n)(.*?)(\n<!-- /generated: \2 -->)", re.S)


def render(text: str, numbers: dict) -> str:
    """``text`` with every generated block rewritten from ``numbers``."""
    return _BLOCK.sub(lambda m: m.group(1) + BLOCKS[m.group(2)](numbers) + m.group(4), text)


def blocks(text: str) -> list:
    return [m.group(2) for m in _BLOCK.finditer(text)]


def main(argv):
    numbers = json.loads(NUMBERS.read_text())
    stale = []
    for path in FILES:
        text = path.read_text()
        new = render(text, numbers)
        if new != text:
            stale.append(path.relative_to(ROOT).as_posix())
            if "--check" not in argv:
                path.write_text(new)
    if "--check" in argv and stale:
        print("stale generated blocks in: " + ", ".join(stale) + " (run python benchmarks/render_docs.py)")
        return 1
    print(("rewrote " + ", ".join(stale)) if stale else "every generated block is current")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
