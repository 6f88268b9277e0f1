"""Timing helper shared by the benchmark scripts (run as ``python benchmarks/NAME.py``)."""

from __future__ import annotations

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
    for _ in range(repeat):
        t = time.perf_counter()
        out = jax.block_until_ready(fn(*args))
        runs.append(time.perf_counter() - t)
    return first, (runs if all_runs else statistics.median(runs)), out
