"""The examples of fitting/README.md, run as written, with what they return and what they cost.

Each example is a ``jaxroll fit`` command of fitting/README.md (the same words: this script runs
it through the command line's own parser and ``run``, in one process, into a temporary folder),
on a data set of ``jaxroll.datasets`` made with known parameters (G0 = 3 MPa, tau = 0.25 s,
f = 1; the file's ``#`` header says by which model). Per example it reports the fitted values, their 95 %
intervals (and whether they hold the truth), the reduced chi^2, the kind of interval, the grid the
fit ended on and the wall-clock and CPU time of the command (the process's CPU time over all
threads: on a shared machine the better measure of the work). The examples run in the order
given, each compiling its own programs (the first of them also pays jaxroll's import).

Run: ``python benchmarks/fit_examples.py [--only NAME ...] [--grids] [--record]`` (``--only``: these examples, in
the order given) (``--grids``: only the grid the default fit resolves over each sphere data set at the examples'
start; ``--record`` stores each
example as it finishes in the section ``fit_examples`` of benchmarks/numbers.json, keeping the
examples not run; ``benchmarks/render_docs.py`` writes fitting/README.md's table from it).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import shlex
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

# each example compiles its own programs: a cold figure, not one of programs another run left in the
# persistent compilation cache (set before jaxroll is imported; JAXROLL_COMPILATION_CACHE=1 to measure a warm one)
os.environ.setdefault("JAXROLL_COMPILATION_CACHE", "0")

TRUE = {"G0": 3e6, "tau": 0.25, "f": 1.0}
COMMAND = "python benchmarks/fit_examples.py --record"

#: (name, command of fitting/README.md, data set): the README's examples, in its order
EXAMPLES = [
    ("direct", "jaxroll fit synthetic_sphere.csv --radius 0.02 --H 0.03 --method direct --out fit-sphere",
     "synthetic_sphere.csv"),
    ("joint", "jaxroll fit rolling_example.csv --dma dma_example.csv --wlf 8.86,101.6,293.15 --radius 0.02 --H 0.03 "
              "--rho 1000 --method direct --out fit-joint", "rolling_example.csv"),
    ("cylinder", "jaxroll fit fit_cylinder.csv --geometry cylinder --radius 0.02 --initial G0=2e6,tau=0.35,f=0.7 "
                 "--starts 1 --out fit-cylinder", "fit_cylinder.csv"),
    ("sphere", "jaxroll fit fit_sphere.csv --radius 0.02 --initial G0=2e6,tau=0.35,f=0.7 --starts 1 --out fit-full",
     "fit_sphere.csv"),
]

#: (data set, layer thickness [m]): the grids the default fit resolves at the examples' start
GRIDS = [("synthetic_sphere.csv", 0.03), ("fit_sphere.csv", float("inf"))]
START = {"G0": 2e6, "tau": 0.35, "f": 0.7}


def default_grids() -> dict:
    """The grid the default fit resolves over each sphere data set's envelope (every speed and
    load) at the examples' start: what one evaluation of its model costs."""
    import jaxroll as jr
    from jaxroll.identify.fit import _resolve_for_fit, read_rolling_csv

    out = {}
    for name, H in GRIDS:
        data = read_rolling_csv(jr.datasets.path(name))
        method, _ = _resolve_for_fit(jr.methods.default_method("sphere", fit=True), jr.StandardLinearSolid(**START),
                                     jr.Layer(H=H), 0.02, data, "sphere")
        out[name] = {"spacing": float(method.grid.spacing), "window": int(method.grid.window)}
    return out


def _grid(method) -> str:
    grid = getattr(method, "grid", None)
    if grid is None or not hasattr(grid, "spacing"):
        return ""
    return f"{float(grid.spacing) * 1e3:.3g} mm cells, window {grid.window}"


def _intervals(result, args, kwargs) -> str:
    """Which 95 % intervals the fit gave: ``FitResult.interval_method`` where the library has it,
    else the rule of ``fit_material(intervals=...)`` applied to the arguments of the call."""
    from jaxroll.identify import fit as jfit

    if getattr(result, "interval_method", None):
        return result.interval_method
    choice = kwargs.get("intervals", "auto")
    rolling, dma = (list(args) + [kwargs.get("rolling"), kwargs.get("dma")])[:2]
    auto = jfit._valley_fit(rolling, dma, kwargs.get("method"), kwargs.get("geometry", "sphere"))
    return "profile" if choice == "profile" or (choice == "auto" and auto) else "linearised"


def run_example(command: str, folder: Path) -> dict:
    """Run one ``jaxroll fit`` command in ``folder``; the FitResult it made, its times and output."""
    import jaxroll as jr
    from jaxroll.apps.cli import build_parser
    from jaxroll.identify import fit as jfit

    words = shlex.split(command)
    for name in words:
        if name.endswith(".csv"):
            (folder / name).write_bytes(jr.datasets.path(name).read_bytes())
    args = build_parser().parse_args(words[1:])
    args.data = str(folder / args.data) if args.data else None
    args.dma = str(folder / args.dma) if args.dma else None
    args.out = str(folder / args.out)
    captured = []
    original = jfit.fit_material

    def capture(*a, **k):
        captured.append((original(*a, **k), a, k))
        return captured[-1][0]

    jfit.fit_material = capture
    out = io.StringIO()
    try:
        t, c = time.perf_counter(), time.process_time()
        with contextlib.redirect_stdout(out), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the identifiability and misfit warnings are in the report
            args.func(args)
        seconds, cpu = time.perf_counter() - t, time.process_time() - c
    finally:
        jfit.fit_material = original
    result, a, k = captured[-1]
    return {"result": result, "intervals": _intervals(result, a, k), "seconds": seconds, "cpu": cpu, "report": out.getvalue()}


def summary(name: str, command: str, data: str, run: dict) -> dict:
    r = run["result"]
    params = {n: float(np.ravel(r.params[n])[0]) for n in TRUE if n in r.params}
    ci95 = {n: [float(np.ravel(r.ci95[n][0])[0]), float(np.ravel(r.ci95[n][1])[0])] for n in params}
    return {
        "command": command, "data": data, "params": params, "ci95": ci95,
        "deviation": {n: params[n] / TRUE[n] - 1 for n in params},
        "covered": {n: bool(ci95[n][0] <= TRUE[n] <= ci95[n][1]) for n in params},
        "correlation": {f"{a},{b}": float(r.correlation[i, j]) for i, a in enumerate(r.names)
                        for j, b in enumerate(r.names) if i < j},
        "reduced_chi2": float(r.reduced_chi2), "converged": bool(r.converged), "sigma_mode": r.sigma_mode,
        "intervals": run["intervals"], "method": type(r.method).__name__ if r.method else None,
        "grid": _grid(r.method), "seconds": round(run["seconds"], 1), "cpu_s": round(run["cpu"], 1),
        "load_after": round(os.getloadavg()[0], 1),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", choices=[e[0] for e in EXAMPLES], help="run these examples only")
    ap.add_argument("--record", action="store_true", help="store the results in benchmarks/numbers.json")
    ap.add_argument("--grids", action="store_true", help="only the grids the default fit resolves (seconds)")
    args = ap.parse_args()
    if args.grids:
        grids = default_grids()
        print(grids)
        if args.record:
            from _numbers import load as load_numbers
            from _numbers import record

            section = load_numbers().get("fit_examples", {})
            section.pop("measured", None)
            record("fit_examples", {**section, "command": COMMAND, "truth": TRUE, "grids": grids})
        return
    chosen = {e[0]: e for e in EXAMPLES}
    for name in args.only or chosen:
        _, command, data = chosen[name]
        load = os.getloadavg()[0]
        with tempfile.TemporaryDirectory() as tmp:
            row = summary(name, command, data, run_example(command, Path(tmp)))
        row["load_before"] = round(load, 1)
        row["date"] = time.strftime("%Y-%m-%d", time.gmtime())
        print(f"{name}: {row}", flush=True)
        if args.record:
            from _numbers import load as load_numbers
            from _numbers import record

            section = load_numbers().get("fit_examples", {})
            section.pop("measured", None)
            section.setdefault("rows", {})[name] = row
            record("fit_examples", {**section, "command": COMMAND, "truth": TRUE})


if __name__ == "__main__":
    main()
