"""Batches of full-model points solved per grid class: the host-side driver of
:meth:`jaxroll.grids.AutoGrid.buckets`.

The automatic grid of the full models is sized by the regime of a point (cells per contact
radius, :func:`jaxroll.grids.sphere_cells_per_radius`); one grid for a whole envelope would be
sized at its finest point, so every point would pay for the finest. Here the points are grouped
by the grid each asks for alone; each group is solved in one warm-started ``lax.scan``
(:meth:`jaxroll.methods.Full.evaluate_points`) in the order of its speeds, on its own grid, so
the numbers are the per-point front door's. The window is static and the cell size traced, so
the groups of one class share a compiled program; the groups are padded to a power of two
(points not solved, ``count``), the groups of one class to that of its largest
(:func:`class_lengths`), so that groups of other sizes share it too.
"""

from __future__ import annotations

import functools
import math
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _compilation_cache
from ._numerics import as_float, check_roller_values, input_checks
from ._xla_options import compiler_options

__all__ = ["padded", "class_lengths", "compiled", "evaluate_buckets"]

#: Compiled programs by function, static configuration and argument shapes (:func:`compiled`).
_PROGRAMS: dict = {}


def padded(idx, at_least=8) -> tuple:
    """``(indices, count)``: ``idx`` padded to a power of two (at least 8, and at least
    ``at_least``) with copies of its last entry, and the number of real entries."""
    idx = np.asarray(idx)
    size = max(8, 1 << int(math.ceil(math.log2(max(idx.size, at_least, 1)))))
    return np.concatenate([idx, np.full(size - idx.size, idx[-1])]), idx.size


def class_lengths(windows, sizes) -> list:
    """For each group (its grid's static ``windows[i]``, ``None`` without a grid, and its
    number of points ``sizes[i]``) the number of points of the largest group of its window, the
    length to pad it to: the automatic grid's groups of one class differ only in their cell size
    (the counting size of :func:`jaxroll.grids.counting_size`, below the relaxed one), and padded
    alike they share one compiled program (padding points are not solved: each costs a skipped
    scan step)."""
    longest = {}
    for w, n in zip(windows, sizes):
        longest[w] = max(longest.get(w, 0), n)
    return [longest[w] for w in windows]


def compiled(fn, args, static, store=False) -> tuple:
    """``(call, compile seconds)``: ``fn`` (an ``eqx.filter_jit`` function) compiled ahead of time
    for ``args`` and the keyword arguments ``static``, kept by the static part and the shapes of
    ``args`` (new values of the same shapes compile nothing; ``0.0`` seconds then). ``store``: the
    program holds no host callback (its inputs were checked on the host), so with the persistent
    cache on its lowered program is stored too (:func:`jaxroll._compilation_cache.compiled`) and a
    later process neither traces nor compiles it (a program with a callback cannot be stored:
    trying would lower it twice)."""
    leaves, treedef = jax.tree_util.tree_flatten(args)
    key = (fn, treedef, tuple((x.shape, x.dtype) if eqx.is_array(x) else x for x in leaves),
           tuple(sorted(static.items())))
    seconds = 0.0
    if key not in _PROGRAMS:
        t = time.perf_counter()
        stored = store and _compilation_cache.compiled(fn, args, static)
        _PROGRAMS[key] = stored or functools.partial(fn.lower(*args, **static).compile(compiler_options()), **static)
        seconds = time.perf_counter() - t
    return _PROGRAMS[key], seconds


@eqx.filter_jit
def _points_program(method, material, layer, R, P, V, count, *, geometry):
    """Values and result codes of :func:`evaluate_buckets`' points, whose inputs' rules it checked
    on the host: the program holds no input checks (no host callback: its lowered program is
    stored)."""
    from .rolling import _validated

    with input_checks(False):
        res = method.evaluate_points(material, layer, R, P, V, geometry, axes=(None, None, None, 0, 0), count=count)
        res = jax.vmap(lambda r, p, v: _validated(method, material, layer, r, R, p, v, geometry))(res, P, V)
    return res.value, res.result


def evaluate_buckets(method, material, layer, radius, loads, speeds, geometry="sphere", *, buckets=None) -> tuple:
    """``(values, results, compile_s, run_s)`` of the full model ``method`` (a
    :class:`~jaxroll.Full` with an :class:`~jaxroll.grids.AutoGrid`) at the points
    ``(loads[i], speeds[i])`` (concrete 1D arrays of one length, or broadcast): ``R_r`` [N or
    N/m] and the :data:`jaxroll.RESULTS` code per point, each point on the grid the rule asks for
    at that point alone (:meth:`~jaxroll.grids.AutoGrid.buckets`), the points of a grid solved in
    one warm-started scan in the order of their speeds. Equal to
    :func:`jaxroll.rolling_resistance` at each point to the solver tolerance. ``buckets``: the
    result of that method for these points, if already computed."""
    loads, speeds = np.broadcast_arrays(np.asarray(loads, float).ravel(), np.asarray(speeds, float).ravel())
    from .rolling import _check_models_on_host

    check_roller_values(radius, loads, speeds)  # every rule of the concrete inputs, on the host (as the front doors)
    _check_models_on_host(material, layer, speeds)
    values, results = np.empty(loads.size), np.empty(loads.size, int)
    compile_s = run_s = 0.0
    if buckets is None:
        buckets = method.grid.buckets(material, layer, radius, loads, speeds, geometry)
    lengths = class_lengths([g.window for g, _ in buckets], [len(i) for _, i in buckets])
    for (grid, idx), length in zip(buckets, lengths):
        m = method.on_grid(grid).for_points(material, layer, radius, loads[idx], speeds[idx], geometry)
        m.check_memory(geometry)
        idx = idx[np.argsort(speeds[idx], kind="stable")]
        pad, count = padded(idx, length)
        args = (m.dynamic(), material, layer, as_float(radius), jnp.asarray(loads[pad]),
                jnp.asarray(speeds[pad]), jnp.asarray(count))
        call, c = compiled(_points_program, args, dict(geometry=geometry), store=True)
        t = time.perf_counter()
        v, r = (np.asarray(x)[:count] for x in jax.block_until_ready(call(*args)))
        run_s, compile_s = run_s + time.perf_counter() - t, compile_s + c
        values[idx], results[idx] = v, r
    return values, results, compile_s, run_s
