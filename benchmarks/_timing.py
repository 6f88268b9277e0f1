"""Timing helpers shared by the benchmark scripts (run as ``python benchmarks/NAME.py``).

Every script times the library through its front doors (``jr.rolling_resistance``,
``jr.rolling_resistance_grid``, ``jr.sweep``, ``jr.fit_material``, ...): compile time apart
(ahead of time with :func:`aot`, or the first call minus the median of the warm calls), then the
median of warm calls, each ended by ``jax.block_until_ready``. :func:`summary` prints one
machine-readable line per headline figure, collected by ``benchmarks/run_all.py``.
"""

from __future__ import annotations

import json
import statistics
import time

import jax


def timed(fn, *args, repeat=5, all_runs=False):
    """``(first, median, output)``: seconds of the first call (compile + run; a warm-up for an
    ahead-of-time compiled ``fn``), median seconds of ``repeat`` further calls, each timed with
    ``block_until_ready``, and the last output; ``all_runs=True`` returns the list of run times
    instead of their median."""
    t = time.perf_counter()
    out = jax.block_until_ready(fn(*args))
    first = time.perf_counter() - t
    runs = []
    for _ in range(max(1, repeat)):
        t = time.perf_counter()
        out = jax.block_until_ready(fn(*args))
        runs.append(time.perf_counter() - t)
    return first, (runs if all_runs else statistics.median(runs)), out


def aot(fn, *args, repeat=5, options=None):
    """``(compile, median, output, compiled)``: ``jax.jit(fn)`` lowered and compiled ahead of time
    (timed alone, as ``jaxroll.apps.reproduce`` does; ``options``: XLA compile options, e.g.
    jaxroll's own, ``jaxroll._xla_options.compiler_options()``), then one warm-up call and the
    median of ``repeat`` timed calls of the compiled program."""
    t = time.perf_counter()
    compiled = jax.jit(fn).lower(*args).compile(options)
    comp = time.perf_counter() - t
    _, median, out = timed(compiled, *args, repeat=repeat)
    return comp, median, out, compiled


def summary(command, median_s, compile_s, baseline="", ratio="", note=""):
    """Print one ``SUMMARY {json}`` line (read by ``benchmarks/run_all.py``)."""
    print("SUMMARY " + json.dumps(dict(command=command, median_s=median_s, compile_s=compile_s, baseline=baseline,
                                       ratio=ratio, note=note)), flush=True)
