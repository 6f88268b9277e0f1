"""Reproduction of the paper's examples ([ZG] sec. 3.4 and 4.6) with every method side by side
against the full 3D model, and a timing table in the form of [ZG] Table 1 measured here.

Cases (material: standard linear solid G0 = 3 MPa, tau = 0.25 s, f = 1, [ZG] eq. 12;
quasi-static layer, rho = 0; 23 log-spaced speeds 1e-4..1 m/s):

==========  =========  ==========  =============  ==========================================
case        H          R           loads          methods compared with the full 3D model
==========  =========  ==========  =============  ==========================================
``H2mm``    2 mm       2 cm        10..150 N      PD, PP, SP ([ZG] sec. 3.4, figure 3)
``H5mm``    5 mm       2 cm        10..150 N      PD, PP, SP, direct (figures 4, 7)
``H30mm``   30 mm      2 cm        10..150 N      PD, PP, SP, direct (figures 5, 6)
``H10um``   10 um      2000 m      200..2000 N    direct (figure 8)
==========  =========  ==========  =============  ==========================================

The reference is the full 3D model (``jr.Full`` with a :class:`jaxroll.FixedGrid`) at the
paper's resolution (period L = 0.2 m, cells a = 0.25 mm, 500 Fourier terms per axis); the
slice algorithms use the 2D cylinder model with the same period; the direct method is
evaluated in its aperiodic limit (quadrature, ``rtol = 1e-4``) with the automatic stationary
pressure (Jaffar thick layer / thin layer).

Every method is a method object (:func:`full_method`, :func:`compared_method`) evaluated through
the library's front door :func:`jaxroll.rolling_resistance_grid` by one adapter (``_run``), which
compiles ahead of time (``jax.jit(...).lower(...).compile()``) so that compile time is measured
apart from run time, and reuses the compiled program across cases where the shapes allow.

Entry points: :func:`run` (compute, returns a :class:`Reproduction`), :func:`write_outputs`
(figures, ``report.md``, ``results.csv``, ``timing.csv``), :func:`reproduce` (both; used by
``jaxroll reproduce``).
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from .._xla_options import compiler_options
from ..io import write_table
from ..result import RESULTS

__all__ = ["Case", "CASES", "Settings", "FULL", "QUICK", "PAPER_TIMES", "PAPER_FACTORS", "Reproduction", "run",
           "write_outputs", "reproduce", "METHOD_NAMES", "error_stats"]

#: Material of the examples ([ZG] sec. 3.4): G0 [Pa], tau [s], f [-].
G0, TAU, F = 3.0e6, 0.25, 1.0

#: [ZG] Table 1 and sec. 2 / 4.1: seconds per reference case (23 speeds x 15 loads), Intel i7 M620.
PAPER_TIMES = {"full": 54 * 60.0, "PD": 21.0, "PP": 20.0, "SP": 107.0, "direct": 23.0}
#: [ZG] speed factors against the full 3D model (Table 1; direct: sec. 4.1).
PAPER_FACTORS = {"PD": 153, "PP": 161, "SP": 30, "direct": 141}
METHOD_NAMES = {"full": "full 3D", "PD": "PD (slices)", "PP": "PP (slices)", "SP": "SP (slices)",
                "direct": "direct series"}
SLICE_METHODS = ("PD", "PP", "SP")
ALL_METHODS = ("PD", "PP", "SP", "direct")


@dataclasses.dataclass(frozen=True)
class Case:
    """One example of the paper: layer thickness ``H`` [m], sphere radius ``R`` [m], load range
    ``loads`` = (lowest, highest) [N], and the methods compared with the full 3D model."""

    key: str
    label: str
    H: float
    R: float
    loads: tuple[float, float]
    methods: tuple[str, ...]
    figure: str


CASES = {
    "H2mm": Case("H2mm", "H = 2 mm, R = 2 cm", 2e-3, 0.02, (10.0, 150.0), SLICE_METHODS, "[ZG] fig. 3"),
    "H5mm": Case("H5mm", "H = 5 mm, R = 2 cm", 5e-3, 0.02, (10.0, 150.0), SLICE_METHODS + ("direct",),
                 "[ZG] figs. 4, 7"),
    "H30mm": Case("H30mm", "H = 30 mm, R = 2 cm", 3e-2, 0.02, (10.0, 150.0), SLICE_METHODS + ("direct",),
                  "[ZG] figs. 5, 6"),
    "H10um": Case("H10um", "H = 10 um, R = 2000 m", 1e-5, 2000.0, (200.0, 2000.0), ("direct",), "[ZG] fig. 8"),
}


@dataclasses.dataclass(frozen=True)
class Settings:
    """Resolution of a reproduction run.

    Attributes:
        n_speeds, n_loads: grid size (speeds log-spaced over ``speed_range`` [m/s], loads
            linear over each case's range).
        spacing: 3D cell size ``a`` [m] (paper 0.25 mm); n_terms: 3D Fourier cut-off per axis
            (paper 500); period: ``L`` [m] of the slices (paper 0.2 m); reference_period: ``L``
            [m] of the 3D reference (paper 0.2 m), or ``None`` for an infinite layer (a single
            roller: aperiodic kernels, never ``period_too_short``).
        reference_grid: ``"fixed"`` (one grid of ``spacing`` for every point) or ``"rule"``
            (infinite layer: each point on the grid the full model's regime rule asks for at
            that point alone, :meth:`jaxroll.grids.AutoGrid.buckets`, so the reference is as
            accurate as the default front door at every point; ``spacing``, ``n_terms`` and
            ``reference_period`` are then unused).
        slice_cells, slice_window: cells per period and window cells of the 2D slices;
            n_slices: number of slices (paper 21).
        direct_rtol: relative accuracy of the direct method's aperiodic quadrature.
        cases, methods: which cases and (non-reference) methods to run.
        pressure_fields: also solve one 2D cylinder and one 3D sphere for the pressure figures.
        label: shown in the report header.
    """

    n_speeds: int = 23
    n_loads: int = 15
    speed_range: tuple[float, float] = (1e-4, 1.0)
    spacing: float = 2.5e-4
    n_terms: int = 500
    period: float = 0.2
    reference_period: float | None = 0.2
    reference_grid: str = "fixed"
    slice_cells: int = 2**10
    slice_window: int = 160
    n_slices: int = 21
    direct_rtol: float = 1e-4
    cases: tuple[str, ...] = ("H2mm", "H5mm", "H30mm", "H10um")
    methods: tuple[str, ...] = ALL_METHODS
    pressure_fields: bool = True
    label: str = "full (the paper's resolution)"


#: The paper's resolution (23 speeds x 15 loads, 0.25 mm cells, 500 terms).
FULL = Settings()
#: Reduced run: 7 speeds 1e-3..1 m/s x 3 loads, an aperiodic 3D reference on the grids of the
#: regime rule (per point: 12-24 cells per contact radius here, so it is valid at every point of
#: H = 2, 5, 30 mm; a fixed 0.5 mm grid has ~11 cells per radius, below what the rule asks for at
#: 1e-3 m/s, and was flagged truncation_too_large there), slices on 512 cells with 11 slices.
#: H = 10 um is not valid there (see the report).
QUICK = Settings(n_speeds=7, n_loads=3, speed_range=(1e-3, 1.0), spacing=5e-4, n_terms=250, reference_period=None,
                 reference_grid="rule", slice_cells=2**9, slice_window=80, n_slices=11,
                 label="quick (reduced: 7 speeds 1e-3..1 m/s x 3 loads, aperiodic 3D reference on the regime "
                       "rule's grids, slices 512 cells / 11 slices)")


@dataclasses.dataclass
class MethodResult:
    values: np.ndarray  # (n_loads, n_speeds) [N]
    status: np.ndarray  # RESULTS codes (0 = successful)
    compile_s: float
    run_s: float


@dataclasses.dataclass
class CaseResult:
    case: Case
    loads: np.ndarray
    speeds: np.ndarray
    reference: MethodResult
    methods: dict  # name -> MethodResult

    def relative_error(self, method) -> np.ndarray:
        """(estimate - reference)/reference, shape (n_loads, n_speeds) [-]."""
        return self.methods[method].values / self.reference.values - 1.0

    def both_valid(self, method) -> np.ndarray:
        """True where the method and the full 3D reference are both valid (RESULTS code 0). An
        approximate method's ``approximation_error`` counts as valid here: it flags the method's
        estimated error against the full model, which is what the report measures."""
        return _compared(self.methods[method].status) & (self.reference.status == 0)

    def valid_error(self, method) -> np.ndarray:
        """:meth:`relative_error` where :meth:`both_valid`, NaN elsewhere: every statistic and
        error figure of the report uses only those points."""
        return np.where(self.both_valid(method), self.relative_error(method), np.nan)


def _compared(status) -> np.ndarray:
    """Where a method's value enters the error statistics: valid, or flagged only for its own
    estimated ``approximation_error``."""
    return np.isin(status, (RESULTS.successful, RESULTS.approximation_error))


def error_stats(e) -> dict:
    """Statistics of a NaN-masked relative-error array (NaN: left out): ``n`` points used of
    ``total``, ``mean``, ``mean_abs``, ``max_abs`` [-] and the index ``at`` of the largest
    (NaN and None when no point is left)."""
    e = np.asarray(e, float)
    ok = np.isfinite(e)
    n = int(ok.sum())
    if n == 0:
        return dict(n=0, total=e.size, mean=np.nan, mean_abs=np.nan, max_abs=np.nan, at=None)
    a = np.where(ok, np.abs(e), -1.0)
    at = np.unravel_index(int(np.argmax(a)), e.shape)
    return dict(n=n, total=e.size, mean=float(np.mean(e[ok])), mean_abs=float(np.mean(np.abs(e[ok]))),
                max_abs=float(a[at]), at=at)


@dataclasses.dataclass
class Reproduction:
    """Everything :func:`run` computed (all arrays host NumPy, ``(n_loads, n_speeds)``)."""

    settings: Settings
    cases: list
    wall_s: float
    pressure: dict | None = None
    environment: dict = dataclasses.field(default_factory=dict)

    def timing(self) -> dict:
        """Per method: mean run seconds per case scaled to the 345-point reference case, the
        total compile seconds (paid once per process and shape), the measured points, and the speed factor against the full 3D
        model on the same cases."""
        out = {}
        for name in ("full",) + ALL_METHODS:
            runs, comps, pts, ref_runs = [], [], [], []
            for cr in self.cases:
                r = cr.reference if name == "full" else cr.methods.get(name)
                if r is None:
                    continue
                n = r.values.size
                runs.append(r.run_s * 345.0 / n)
                comps.append(r.compile_s)
                pts.append(n)
                ref_runs.append(cr.reference.run_s * 345.0 / n)
            if runs:
                t = float(np.mean(runs))
                out[name] = dict(per_case_s=t, compile_s=float(np.sum(comps)), points=int(np.sum(pts)),
                                 single_s=t / 345.0, n_cases=len(runs), factor=float(np.mean(ref_runs)) / t)
        return out


# ---------------------------------------------------------------------------------------------
# progress
# ---------------------------------------------------------------------------------------------


class _Progress:
    def __init__(self, stream):
        self.stream = stream
        self.t0 = time.perf_counter()

    def __call__(self, msg):
        if self.stream is not None:
            print(f"[{time.perf_counter() - self.t0:7.1f} s] {msg}", file=self.stream, flush=True)


def _invalid(codes) -> str:
    """``"all valid"`` or the count of points per :data:`jaxroll.RESULTS` reason."""
    codes = np.asarray(codes)
    bad = codes[codes != 0]
    if not bad.size:
        return "all valid"
    return "not valid: " + ", ".join(f"{int(np.sum(bad == c))} {RESULTS.names[int(c)]}" for c in np.unique(bad))


# ---------------------------------------------------------------------------------------------
# adapters: one per method, R_r on the (loads x speeds) grid
# ---------------------------------------------------------------------------------------------


def _material():
    import jaxroll as jr

    return jr.StandardLinearSolid(G0, TAU, F)


def _run(method, case: Case, loads, speeds, cache: dict) -> MethodResult:
    """``R_r`` of ``method`` (resolved: explicit grids) on the case's loads x speeds through
    :func:`jaxroll.rolling_resistance_grid`, compiled ahead of time once per method and grid
    shape (``jax.jit(...).lower(...).compile()``, cached: the cases share the compiled program),
    so the compile time is measured apart from the run time."""
    import jaxroll as jr

    def fn(H, R, P, V):
        out = jr.rolling_resistance_grid(_material(), jr.Layer(H), radius=R, loads=P, speeds=V, method=method)
        return out.value.T, out.result.T  # (n_loads, n_speeds)

    args = (jnp.asarray(case.H), jnp.asarray(case.R), jnp.asarray(loads), jnp.asarray(speeds))
    key = (method, len(loads), len(speeds))
    c = 0.0
    if key not in cache:
        t = time.perf_counter()
        cache[key] = jax.jit(fn).lower(*args).compile(compiler_options())
        c = time.perf_counter() - t
    t = time.perf_counter()
    v, st = jax.block_until_ready(cache[key](*args))
    return MethodResult(np.asarray(v), np.asarray(st), c, time.perf_counter() - t)


#: Largest window (cells per side) of the regime rule's reference grids; a case whose rule asks
#: for more (H = 10 um: the rule's 2 r/H cells per radius give windows of ~2000 cells) falls back
#: to the fixed grid of the settings.
MAX_RULE_WINDOW = 255


def _run_rule_reference(case: Case, loads, speeds) -> MethodResult | None:
    """The full 3D reference on an infinite layer with each point on the grid of the regime rule
    (:func:`jaxroll.buckets.evaluate_buckets`: the points grouped by grid, one compiled program
    per class of cells per radius); ``None`` where a grid would exceed :data:`MAX_RULE_WINDOW`."""
    import jaxroll as jr
    from jaxroll.buckets import evaluate_buckets

    P, V = (a.ravel() for a in np.meshgrid(loads, speeds, indexing="ij"))
    method, material, layer = jr.Full(), _material(), jr.Layer(case.H)
    buckets = method.grid.buckets(material, layer, case.R, P, V, "sphere")
    if max(g.window for g, _ in buckets) > MAX_RULE_WINDOW:
        return None
    v, st, c, r = evaluate_buckets(method, material, layer, case.R, P, V, "sphere", buckets=buckets)
    return MethodResult(v.reshape(len(loads), len(speeds)), st.reshape(len(loads), len(speeds)), c, r)


def _reference_period(s: Settings) -> str:
    if s.reference_grid == "rule":
        return (f"infinite layer (aperiodic kernels), each point on the grid of the regime rule (a case whose rule "
                f"asks for windows over {MAX_RULE_WINDOW} cells: cells a = {s.spacing * 1e3:g} mm)")
    if s.reference_period is None:
        return "infinite layer (aperiodic kernels)"
    return f"period L = {s.reference_period} m, {s.n_terms} Fourier terms per axis"


def full_method(s: Settings, window: int):
    """The full 3D reference at the settings' resolution (the paper's: period 0.2 m, 0.25 mm
    cells, 500 terms)."""
    import jaxroll as jr

    periodic = s.reference_period is not None
    return jr.Full(grid=jr.FixedGrid(s.spacing, window, period=s.reference_period, n_terms=s.n_terms if periodic else None))


def compared_method(name: str, s: Settings):
    """PD / PP / SP on the settings' slice grid (the paper's period), or the direct method in its
    aperiodic limit with the automatic stationary pressure."""
    import jaxroll as jr

    if name in SLICE_METHODS:
        return jr.Slices(algorithm=name, n_slices=s.n_slices,
                         grid=jr.FixedGrid(s.period / s.slice_cells, s.slice_window, period=s.period))
    if name == "direct":
        return jr.Direct(rtol=s.direct_rtol)
    raise ValueError(f"unknown method {name!r}; choose from {ALL_METHODS}")


def _full_window(s: Settings, cases: Sequence[Case]) -> int:
    """One 3D pressure window (odd cell count) large enough for the largest static contact of
    every case (1.15 x the estimated radius each side, at least the paper's 41 cells), so the
    reference compiles once."""
    import jaxroll as jr

    r = max(float(jr.engines.contact_size.estimate_contact_size(_material(), jr.Layer(c.H), c.R, c.loads[1])) for c in cases)
    return max(41 if s.spacing <= 2.5e-4 else 1, 2 * math.ceil(1.15 * r / s.spacing) + 1)


def _pressure_fields(s: Settings, log) -> dict:
    """One 2D cylinder and one 3D sphere solution (H = 5 mm, near the R_r peak) for the
    pressure figures."""
    import jaxroll as jr

    mat, layer = _material(), jr.Layer(5e-3)
    V, P = 0.01, 100.0
    # middle-slice load per length of [ZG] eq. 6, with the paper's contact radius 4.87 mm (H = 5 mm,
    # 120 N; sec. 4.6): a half-width of 0.28 R, inside the small-strain range (0.3 R)
    P_line = 3.0 * P / (4.0 * 4.87e-3)
    t = time.perf_counter()
    cyl = jr.rolling_resistance(mat, layer, radius=0.02, load=P_line, speed=V, geometry="cylinder", method="full")
    cyl0 = jr.rolling_resistance(mat, layer, radius=0.02, load=P_line, speed=0.0, geometry="cylinder",
                                 method=jr.Full().resolve(mat, layer, radius=0.02, loads=P_line, speeds=V,
                                                          geometry="cylinder"))
    sph = jr.rolling_resistance(mat, layer, radius=0.02, load=P, speed=V, method=jr.Full(
        grid=jr.AutoGrid(cells_per_radius=8 if s.spacing > 2.5e-4 else 12)))
    log(f"pressure fields (H = 5 mm, P = {P:g} N, V = {V:g} m/s): {time.perf_counter() - t:.1f} s")
    x, y = sph.solution.grid
    return dict(
        V=V, P=P, cylinder_load=P_line,
        cylinder_x=np.asarray(cyl.solution.grid), cylinder_p=np.asarray(cyl.solution.pressure),
        cylinder_p0=np.asarray(cyl0.solution.pressure),
        cylinder_R=float(cyl.value),
        x=np.asarray(x), y=np.asarray(y), p=np.asarray(sph.solution.pressure),
        contact=np.asarray(sph.solution.pressure) > 0, R_r=float(sph.value),
    )


# ---------------------------------------------------------------------------------------------
# run
# ---------------------------------------------------------------------------------------------


def run(settings: Settings = FULL, *, progress=sys.stderr) -> Reproduction:
    """Compute every case of ``settings``: the full 3D reference and each method's ``R_r`` on
    the loads x speeds grid, with compile and run times. Progress lines (elapsed seconds) go to
    ``progress`` (a text stream, or None)."""
    s = settings
    unknown = [c for c in s.cases if c not in CASES]
    if unknown or not s.cases:
        raise ValueError(f"unknown or no case(s) {unknown}; choose from {list(CASES)}")
    bad = [m for m in s.methods if m not in ALL_METHODS]
    if bad:
        raise ValueError(f"unknown method(s) {bad}; choose from {list(ALL_METHODS)}")
    if s.n_speeds < 1 or s.n_loads < 1:
        raise ValueError("n_speeds and n_loads must be >= 1")
    log = _Progress(progress)
    t0 = time.perf_counter()
    cases = [CASES[k] for k in s.cases]
    speeds = np.geomspace(s.speed_range[0], s.speed_range[1], s.n_speeds)
    window = _full_window(s, cases)
    log(f"jaxroll reproduce: {s.label}; {len(cases)} case(s), {s.n_speeds} speeds x {s.n_loads} loads; "
        + (f"3D reference: {_reference_period(s)}" if s.reference_grid == "rule" else
           f"3D window {window}^2 cells of {s.spacing * 1e3:g} mm, {_reference_period(s)}"))
    cache: dict = {}
    out = []
    for case in cases:
        loads = np.linspace(case.loads[0], case.loads[1], s.n_loads)
        log(f"{case.label}: full 3D reference ({s.n_loads} x {s.n_speeds}) ...")
        ref = _run_rule_reference(case, loads, speeds) if s.reference_grid == "rule" else None
        if ref is None:
            if s.reference_grid == "rule":
                log(f"{case.label}: the regime rule's grid exceeds {MAX_RULE_WINDOW} cells per side: the fixed "
                    f"{s.spacing * 1e3:g} mm grid (window {window})")
            ref = _run(full_method(s, window), case, loads, speeds, cache)
        log(f"{case.label}: full 3D done: run {_fmt_time(ref.run_s)}, compile {_fmt_time(ref.compile_s)}; "
            f"{_invalid(ref.status)}")
        res = {}
        for m in case.methods:
            if m not in s.methods:
                continue
            log(f"{case.label}: {METHOD_NAMES[m]} ...")
            r = _run(compared_method(m, s), case, loads, speeds, cache)
            res[m] = r
            st = error_stats(np.where(_compared(r.status) & (ref.status == 0), r.values / ref.values - 1.0, np.nan))
            stats = (f"over the {st['n']} of {st['total']} points valid in both: mean error {100 * st['mean']:+.1f} %, "
                     f"mean |error| {100 * st['mean_abs']:.1f} %" if st["n"] else
                     f"no point of {st['total']} valid in both")
            log(f"{case.label}: {METHOD_NAMES[m]} done: run {_fmt_time(r.run_s)}, compile {_fmt_time(r.compile_s)}; "
                f"{stats}; {_invalid(r.status)}")
        out.append(CaseResult(case, loads, speeds, ref, res))
    pressure = _pressure_fields(s, log) if s.pressure_fields else None
    wall = time.perf_counter() - t0
    env = dict(jax=jax.__version__, device=f"{jax.devices()[0].platform} x {len(jax.devices())}",
               cpus=os.cpu_count(), load_avg=os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan"))
    log(f"computed in {wall:.1f} s")
    return Reproduction(s, out, wall, pressure, env)


# ---------------------------------------------------------------------------------------------
# outputs
# ---------------------------------------------------------------------------------------------


def _fmt_time(t):
    if t >= 120:
        return f"{t / 60:.1f} min"
    if t >= 1:
        return f"{t:.1f} s"
    if t >= 1e-3:
        return f"{t * 1e3:.0f} ms"
    return f"{t * 1e6:.0f} us"


def timing_table(rep: Reproduction) -> str:
    """Markdown table in the form of [ZG] Table 1, measured here, next to the paper's figures."""
    tim = rep.timing()
    rows = ["| method | single run (here) | reference case, 23 x 15 (here) | speed factor vs full 3D (here) "
            "| compile (here, apart) | paper: reference case | paper: speed factor |",
            "|---|---|---|---|---|---|---|"]
    for name, t in tim.items():
        pf = PAPER_FACTORS.get(name)
        factor = "1" if name == "full" else f"{t['factor']:.0f}"
        rows.append(f"| {METHOD_NAMES[name]} | {_fmt_time(t['single_s'])} | {_fmt_time(t['per_case_s'])} | "
                    f"{factor} | {_fmt_time(t['compile_s'])} | "
                    f"{_fmt_time(PAPER_TIMES[name])} | {'1' if name == 'full' else pf} |")
    return "\n".join(rows)


def accuracy_table(rep: Reproduction) -> str:
    """Markdown table: mean signed, mean absolute and largest relative error of each method
    against the full 3D model, per case, over the points where both are valid (counted)."""
    rows = ["| case | method | points valid in both | mean error | mean abs. error | max abs. error | at (P, V) of max |",
            "|---|---|---|---|---|---|---|"]
    for cr in rep.cases:
        for m in cr.methods:
            st = error_stats(cr.valid_error(m))
            if st["n"] == 0:
                rows.append(f"| {cr.case.label} | {METHOD_NAMES[m]} | 0 of {st['total']} | - | - | - | - |")
                continue
            i, j = st["at"]
            rows.append(f"| {cr.case.label} | {METHOD_NAMES[m]} | {st['n']} of {st['total']} | "
                        f"{100 * st['mean']:+.1f} % | {100 * st['mean_abs']:.1f} % | {100 * st['max_abs']:.1f} % | "
                        f"({cr.loads[i]:g} N, {cr.speeds[j]:.2g} m/s) |")
    return "\n".join(rows)


def _write_figures(rep: Reproduction, out: Path):
    """The comparison and error figures of every case, master curves and pressure fields; return
    ``(figures per case key, every written path)``."""
    from . import plot

    written = []
    figs = {}
    for cr in rep.cases:
        k = cr.case.key
        est = {METHOD_NAMES[m]: r.values for m, r in cr.methods.items()}
        err = {METHOD_NAMES[m]: cr.valid_error(m) for m in cr.methods}  # NaN where either is not valid
        name = f"rr_{k}.png"
        f = plot.plot_method_comparison(cr.speeds, cr.loads, cr.reference.values, est, unit="N",
                                        title=f"{cr.case.label}: methods (lines) vs full 3D (circles)",
                                        valid={METHOD_NAMES[m]: r.status == 0 for m, r in cr.methods.items()},
                                        reference_valid=cr.reference.status == 0, path=out / name)
        figs[k] = [name]
        plot.close(f)
        if err:
            name = f"error_{k}.png"
            plot.close(plot.plot_relative_error(cr.speeds, cr.loads, err, title=f"{cr.case.label}: mean relative "
                                                "error vs full 3D", path=out / name))
            figs[k].append(name)
            name = f"errormap_{k}.png"
            plot.close(plot.plot_error_maps(cr.speeds, cr.loads, err, title=cr.case.label, path=out / name))
            figs[k].append(name)
        written += [out / n for n in figs[k]]
    extra = []
    plot.close(plot.plot_master_curves({"[ZG] SLS": _material()}, path=out / "master_curves.png"))
    extra.append("master_curves.png")
    if rep.pressure is not None:
        pr = rep.pressure
        plot.close(plot.plot_pressure_profile(pr["cylinder_x"], {"V = 0 (static)": pr["cylinder_p0"],
                                                                 f"V = {pr['V']:g} m/s": pr["cylinder_p"]},
                                              title=f"2D cylinder, H = 5 mm, P' = {pr['cylinder_load']:.0f} N/m",
                                              path=out / "pressure_cylinder.png"))
        plot.close(plot.plot_pressure_map(pr["x"], pr["y"], pr["p"], contact=pr["contact"],
                                          title=f"3D sphere, H = 5 mm, P = {pr['P']:g} N, V = {pr['V']:g} m/s",
                                          path=out / "pressure_sphere.png"))
        extra += ["pressure_cylinder.png", "pressure_sphere.png"]
    written += [out / n for n in extra]

    return figs, written


def _write_tables(rep: Reproduction, out: Path) -> list:
    """``results.csv`` (every point of every method with the reference) and ``timing.csv``."""
    rows = []
    for cr in rep.cases:
        for m, r in [("full", cr.reference)] + list(cr.methods.items()):
            for i, P in enumerate(cr.loads):
                for j, V in enumerate(cr.speeds):
                    ref = cr.reference.values[i, j]
                    rows.append((cr.case.key, f"{cr.case.H:g}", f"{cr.case.R:g}", m, P, V, r.values[i, j], ref,
                                 f"{r.values[i, j] / ref - 1:.6g}", int(r.status[i, j] == 0),
                                 RESULTS.names[int(r.status[i, j])]))
    names = ["case", "H", "R", "method", "load", "speed", "rolling_resistance", "reference_full3d", "relative_error",
             "valid", "result"]
    write_table(out / "results.csv", dict(zip(names, zip(*rows))) if rows else dict.fromkeys(names, ()),
                ["", "m", "m", "", "N", "m/s", "N", "N", "-", "-", "-"],
                formats=".8g")
    timing = rep.timing()
    write_table(out / "timing.csv",
                {"method": list(timing), **{col: [f"{t[key]:.6g}" for t in timing.values()] for col, key in
                                            (("run_per_reference_case", "per_case_s"), ("single_run", "single_s"),
                                             ("compile", "compile_s"), ("speed_factor", "factor"))},
                 "points_measured": [t["points"] for t in timing.values()],
                 "paper_reference_case": [PAPER_TIMES[n] for n in timing],
                 "paper_speed_factor": [PAPER_FACTORS.get(n, 1) for n in timing]},
                ["", "s", "s", "s", "-", "", "s", "-"])
    return [out / "results.csv", out / "timing.csv"]



def _case_error_tables(cr) -> list:
    """Markdown lines: the mean relative error of each method against V and against P, over the
    points valid for the method and the full 3D model (their counts)."""
    from .plot import masked_mean

    def cell(mean, n):
        return f"{100 * mean:+.1f} ({n})" if n else "- (0)"

    header = ["| " + " | ".join(METHOD_NAMES[m] for m in cr.methods) + " |", "|---" * (len(cr.methods) + 1) + "|"]
    e_v = {m: masked_mean(cr.valid_error(m), axis=0) for m in cr.methods}
    lines = ["Mean relative error [%] against V over the loads valid for the method and the full 3D "
             "model (their count in parentheses):", "", "| V [m/s] " + header[0], header[1]]
    for j, V in enumerate(cr.speeds):
        lines.append(f"| {V:.3g} | " + " | ".join(cell(e_v[m][0][j], e_v[m][1][j]) for m in cr.methods) + " |")
    e_p = {m: masked_mean(cr.valid_error(m), axis=1) for m in cr.methods}
    lines += ["", "Mean relative error [%] against P over the speeds valid for both (count):", "",
              "| P [N] " + header[0], header[1]]
    for i, P in enumerate(cr.loads):
        lines.append(f"| {P:g} | " + " | ".join(cell(e_p[m][0][i], e_p[m][1][i]) for m in cr.methods) + " |")
    return lines + [""]


def _report_lines(rep: Reproduction, figs: dict) -> list:
    """The lines of ``report.md``."""
    s = rep.settings
    env = rep.environment
    lines = [
        "# jaxroll reproduce: [ZG]'s examples, every method against the full 3D model",
        "",
        f"**Mode: {s.label}.** Cases: {', '.join(cr.case.label for cr in rep.cases)}; "
        f"{s.n_speeds} log-spaced speeds {s.speed_range[0]:g}..{s.speed_range[1]:g} m/s x {s.n_loads} loads per case. "
        f"Total wall time {rep.wall_s:.1f} s (compute; figures apart) on {env.get('device')} "
        f"({env.get('cpus')} CPUs, load average {env.get('load_avg', float('nan')):.1f} at the end), jax {env.get('jax')}.",
        "",
        f"Material: standard linear solid G0 = {G0 / 1e6:g} MPa, tau = {TAU:g} s, f = {F:g} ([ZG] eq. 12); "
        "quasi-static incompressible layer (rho = 0, nu = 0.5); no friction.",
        "Reference: full 3D model, "
        + ("" if s.reference_grid == "rule" else f"cells a = {s.spacing * 1e3:g} mm, ")
        + f"{_reference_period(s)} (paper: 0.25 mm, period 0.2 m, 500 terms). Slices PD/PP/SP: {s.n_slices} slices, 2D period {s.period} m on "
        f"{s.slice_cells} cells (window {s.slice_window} cells). Direct: aperiodic limit (rtol {s.direct_rtol:g}), "
        "automatic stationary pressure (Jaffar thick layer, thin layer for 10 um).",
        "Relative error = method / full 3D - 1 (positive: the method overestimates R_r). Every statistic and "
        "error figure uses only the points where both the method and the full 3D model are valid (RESULTS code 0; "
        "counts given; a method's own approximation_error flag, its estimate of the error measured here, counts as "
        "valid); the comparison figures mark the points that are not valid.",
        "",
        "## Timing, in the form of [ZG] Table 1",
        "",
        "Measured here: run time per grid point x 345 (the paper's reference case, 23 speeds x 15 loads), "
        "averaged over the cases where the method applies; compile time is reported apart (total per "
        "method in this run: paid once per process and grid shape, shared by the cases). The paper's figures are for an Intel i7 M620 (2010).",
        "",
        timing_table(rep),
        "",
        "## Accuracy against the full 3D model",
        "",
        accuracy_table(rep),
        "",
    ]
    for cr in rep.cases:
        lines += [f"### {cr.case.label} ({cr.case.figure})", ""]
        lines += [f"![{n[:-4]}]({n})" for n in figs[cr.case.key]]
        lines.append("")
        for name, r in [("Full 3D", cr.reference)] + [(METHOD_NAMES[m], r) for m, r in cr.methods.items()]:
            if np.any(r.status != 0):
                lines += [f"{name}: {_invalid(r.status)} (column `result` of results.csv).", ""]
        if cr.methods:
            lines += _case_error_tables(cr)
    lines += ["## Material and pressure fields", "", "![master curves](master_curves.png)", ""]
    if rep.pressure is not None:
        pr = rep.pressure
        lines += [f"Full-model pressures at H = 5 mm, V = {pr['V']:g} m/s (near the R_r peak): the 2D cylinder "
                  f"(R_r = {pr['cylinder_R']:.3g} N/m) and the 3D sphere (P = {pr['P']:g} N, R_r = {pr['R_r']:.3g} N; "
                  "white line: contact set outline).", "",
                  "![2D cylinder pressure](pressure_cylinder.png)", "", "![3D sphere pressure](pressure_sphere.png)", ""]
    lines += ["Numbers: `results.csv` (every grid point, every method, with the reference and the relative error), "
              "`timing.csv`.", ""]
    return lines


def write_outputs(rep: Reproduction, out) -> list:
    """Write figures (PNG), ``report.md``, ``results.csv`` and ``timing.csv`` into ``out``;
    return the written paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figs, written = _write_figures(rep, out)
    written += _write_tables(rep, out)
    (out / "report.md").write_text("\n".join(_report_lines(rep, figs)))
    return [out / "report.md", *written]


def reproduce(settings: Settings = FULL, out="jaxroll-reproduce", *, progress=sys.stderr) -> Reproduction:
    """Run :func:`run` and :func:`write_outputs`; print the accuracy and timing tables to
    ``progress``."""
    rep = run(settings, progress=progress)
    t = time.perf_counter()
    write_outputs(rep, out)
    if progress is not None:
        print(f"figures and report written to {out} ({time.perf_counter() - t:.1f} s)", file=progress)
    return rep


def settings_for(quick: bool, *, cases: Sequence[str] | None = None, methods: Sequence[str] | None = None,
                 **overrides) -> Settings:
    """:data:`QUICK` or :data:`FULL` with optional case/method selection and field overrides."""
    s = QUICK if quick else FULL
    kw = dict(overrides)
    if cases is not None:
        kw["cases"] = tuple(cases)
    if methods is not None:
        kw["methods"] = tuple(methods)
    if kw:
        s = dataclasses.replace(s, **kw)
    return s

