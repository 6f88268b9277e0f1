"""Timing helper shared by the benchmark scripts (run as ``python benchmarks/NAME.py``)."""

from __future__ import annotations

import statistics
import time

import jax


def timed(fn, *args, repeat=5):
    """``(first, median, output)``: seconds of the first call (compile + run), median seconds of
    ``repeat`` further calls, each timed with ``block_until_ready``, and the last output."""
    t = time.perf_counter()
    out = jax.block_until_ready(fn(*args))
    first = time.perf_counter() - t
    runs = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = jax.block_until_ready(fn(*args))
        runs.append(time.perf_counter() - t)
    return first, statistics.median(runs), out
