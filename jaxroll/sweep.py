"""Large parameter sweeps: memory-bounded chunking, sharded over every available device.

:func:`sweep` evaluates any jittable function of a parameter pytree over

* a :class:`Grid` -- the outer product of named 1D axes; results carry the grid's axes, so a
  sweep over ``Grid(V=speeds, P=loads)`` returns arrays of shape ``(len(speeds), len(loads))
  + output_shape``; or
* a list of points -- any pytree whose leaves share a leading batch axis of length ``N``;
  results have shape ``(N,) + output_shape``.

How it runs
-----------
The ``N`` points are split evenly over a one-axis device mesh (``jax.make_mesh`` with
``AxisType.Auto``: under the default Explicit axes a vmapped ``jnp.linalg.solve`` raises
``ShardingTypeError``), and inside ``jax.shard_map`` each device walks its share in chunks of
``chunk_size`` points with a ``lax.scan`` over ``jax.vmap(fn)`` (or, ``vectorize=False``, over a
``lax.map`` of ``fn``: the points of a chunk one after the other, for iterative solvers whose
while loops would otherwise run every lane to the slowest lane's count; the full models batch
their own points, see ``vectorize``): the working memory is
that of one chunk per device, whatever ``N`` is. ``N`` need not divide anything: the points
are padded to ``devices * n_chunks * chunk`` (points by repeating the last point, grids by
clamping the flat index, so the padding is always a valid parameter point and cannot raise or
produce NaN) and the padding is sliced off afterwards. Grid points are never materialised: each
device gathers its points from the (replicated) 1D axes by flat index.

The sweep is one jitted program without collectives; dropping the padding and replicating the
result is a second one. ``sweep`` also works inside ``jax.jit`` and under ``jax.grad`` /
``jax.vjp`` (then both are part of the caller's program): differentiate a scalar reduction of
the results with respect to parameters that ``fn`` closes over, or with respect to the points
or grid axes themselves. Each chunk is wrapped in ``jax.checkpoint`` (``checkpoint=True``), so
the reverse pass also works chunk by chunk: measured for 345 points x 5000 modes, 3.7 MiB
working memory against 230 MiB without it.

Results equal the single-device path (``devices=1``): every point runs the same vectorised code
on whichever device holds it. The tests find them bitwise identical (8 forced CPU devices
against 1 and 3, uneven sizes). The chunk width per device depends on the device count (see
``chunk_size``), and XLA may round differently in the last bit for different vector widths
(chunks of 1 against vectorised chunks: 6e-16 relative, measured), so compare with a
tolerance of a few ulp where bitwise identity is not essential.

Memory and speed: docs/design.md sec. 4 measured 345 cases x 5000 Fourier modes in 3.6 s with
7 MiB working memory in chunks of 1, against 4.7-5.7 s with 2-5 GB as one vmap.
``benchmarks/bench_sweep.py`` (one CPU device, 345 points x 5000 modes of a closed-form series,
2 cores shared with other jobs, so timings are noisy): sweeps in chunks of 1-256 ran 1.3-4x
faster than one ``jit(vmap)`` over all points, with 0.1-20 MiB working memory against 40 MiB;
for a few-flop function the scan loop costs little (1e6 points: 0.06 s in chunks of 1, 0.036 s
in chunks of 64-1024). The default ``chunk_size`` is :data:`DEFAULT_CHUNK_SIZE` (16 on CPU):
mind the working memory per point of heavy models (the full 2D cylinder model at its default
resolution: ~45 MiB per point, so ~0.7 GiB per device in chunks of 16).

Multi-host
----------
``jax.distributed`` is JAX's own machinery for many hosts; ``sweep`` needs nothing extra. Start
the same script on every host, call ``jax.distributed.initialize()`` before any other JAX call
(arguments ``coordinator_address="host0:1234", num_processes=n, process_id=i``, or none on a
cluster that JAX detects: SLURM, Open MPI, Cloud TPU), build the same grid or points on every
process, and call ``sweep``: the default mesh spans ``jax.devices()``, which then lists the
devices of all processes. The result is replicated on every device, so every process can read
all of it (``np.asarray(result)``); the gather happens once, after the sweep has finished.
``benchmarks/multihost_example.py`` is a runnable example; it can launch
two CPU processes on localhost to try it on one machine.

Caveats
-------
* ``fn`` is traced once per distinct (``fn``, shapes, chunking, devices); pass the same
  function object to reuse the compiled program (as for ``jax.jit``).
* The body runs under ``jax.shard_map(..., check_vma=False)``: equinox's ``error_if`` (a
  ``lax.cond`` whose branches differ in their varying-axis types) is rejected under the default
  ``check_vma=True``. Nothing in the body communicates across devices, so no check is lost.
* Runtime errors (``equinox.error_if`` on a bad parameter point, as raised by the rolling
  resistance entry points) surface as an exception when ``sweep`` is called outside any
  transformation: the sweep program is run to completion before the results are gathered.
  Under ``jax.jit`` / ``jax.grad`` on several devices the sweep and the gather (or any
  reduction the caller does) are one program: a device that raises leaves the others waiting
  at the collective, and XLA's CPU runtime aborts the process after 40 s. In a multi-host run
  the same happens whenever one process raises: the others wait in the final gather. There,
  validate the inputs first, use result codes (``throw=False`` options), or start Python with
  ``EQX_ON_ERROR=nan`` (read when equinox is imported) so that a bad point yields NaN instead.
* Progress callbacks are ``jax.debug.callback`` s: they fire while the program runs, from the
  first device of the mesh only, once per chunk (in the forward pass under ``jax.grad``).
"""

from __future__ import annotations

import collections
import functools
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import AxisType, Mesh, NamedSharding, PartitionSpec

from ._numerics import check_x64

__all__ = ["Grid", "sweep", "sweep_mesh", "DEFAULT_CHUNK_SIZE"]

DEFAULT_CHUNK_SIZE = {"cpu": 16, "gpu": 1024, "tpu": 1024}
"""Points per vectorised chunk and device when ``chunk_size`` is not given, by platform.

CPU: measured (``benchmarks/bench_sweep.py``): chunks of 8-16 were fastest for a 5000-mode
series per point and within 10 % of the best for a few-flop function (the ``lax.scan`` step
costs well under a microsecond), at a working memory of 16 points. GPU/TPU: a guess, not
measured here; accelerators need wide batches, so raise it if a chunk fits in memory."""

_AXIS = "sweep"


# ------------------------------------------------------------------------------------------
# Grid
# ------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=None)
def _point_type(names: tuple[str, ...]) -> type:
    """One namedtuple class per tuple of axis names (cached, so jit sees a stable type)."""
    return collections.namedtuple("GridPoint", names)


def _refuse_nan(leaves, what):
    """One-line ``ValueError`` where a concrete leaf of ``what`` holds a NaN (``inf`` stays: e.g. a
    half-space ``H``): inside the swept function it would fail as a runtime error of the compiled
    program, its reason buried in a callback dump, or give a NaN."""
    for leaf in leaves:
        if isinstance(leaf, jax.core.Tracer):
            continue
        a = np.asarray(leaf)
        if np.issubdtype(a.dtype, np.inexact) and np.isnan(a).any():
            raise ValueError(f"{what} holds a NaN at index {int(np.argwhere(np.isnan(a))[0][0])}")


class Grid:
    """Outer product of named 1D axes: the parameter points of a full-factorial sweep.

    ``Grid(V=speeds, P=loads)`` (or ``Grid({"V": speeds, "P": loads})``) has shape
    ``(len(speeds), len(loads))``; axes keep the order given. Each axis is a 1D array, or any
    pytree whose leaves share a leading axis (e.g. a batch of materials built by ``jax.vmap``
    or with array fields), which is then one grid axis.

    The swept function receives one grid point as a namedtuple ``GridPoint`` whose fields are
    the axis names, so ``fn = lambda p: ... p.V ... p.P`` (scalars, or the pytree entry of a
    pytree axis). Axis names must be valid Python identifiers.
    """

    def __init__(self, axes: Mapping[str, Any] | None = None, /, **kwargs):
        merged = dict(axes or {})
        for k, v in kwargs.items():
            if k in merged:
                raise ValueError(f"grid axis {k!r} given twice")
            merged[k] = v
        if not merged:
            raise ValueError("a Grid needs at least one axis")
        for name, axis in merged.items():  # a list of numbers is a 1D axis, not a pytree
            if isinstance(axis, (list, tuple)) and all(np.ndim(a) == 0 for a in axis):
                merged[name] = np.asarray(axis)
        lengths = []
        for name, axis in merged.items():
            if not (isinstance(name, str) and name.isidentifier() and not name.startswith("_")):
                raise ValueError(f"grid axis names must be identifiers not starting with '_'; got {name!r}")
            leaves = jax.tree_util.tree_leaves(axis)
            if not leaves:
                raise ValueError(f"grid axis {name!r} has no array leaves")
            ns = set()
            for leaf in leaves:
                shape = np.shape(leaf)
                if len(shape) < 1:
                    raise ValueError(f"grid axis {name!r}: leaves need a leading axis; got shape {shape}")
                ns.add(shape[0])
            if len(ns) != 1:
                raise ValueError(f"grid axis {name!r}: leaves disagree on the axis length {sorted(ns)}")
            (n,) = ns
            if n < 1:
                raise ValueError(f"grid axis {name!r} is empty")
            _refuse_nan(leaves, f"grid axis {name!r}")
            if isinstance(axis, (np.ndarray, jax.Array)) and np.ndim(axis) != 1:
                raise ValueError(
                    f"grid axis {name!r} must be 1D (a pytree for vector-valued entries); got shape {np.shape(axis)}"
                )
            lengths.append(int(n))
        self.axes: dict[str, Any] = {
            k: jax.tree_util.tree_map(lambda x: x if isinstance(x, jax.Array) else np.asarray(x), v)
            for k, v in merged.items()
        }
        self.names: tuple[str, ...] = tuple(merged)
        self.shape: tuple[int, ...] = tuple(lengths)
        self.size: int = math.prod(lengths)

    def point(self, index) -> tuple:
        """The grid point at a flat (row-major) ``index`` as a ``GridPoint`` namedtuple."""
        return _grid_point(self.names, self.shape, tuple(self.axes.values()), index)

    def points(self) -> tuple:
        """All grid points as a ``GridPoint`` of arrays with a leading axis of length ``size``
        (row-major), i.e. the equivalent point list; materialises the grid."""
        return _grid_point(self.names, self.shape, tuple(self.axes.values()), jnp.arange(self.size))

    def __repr__(self) -> str:
        return "Grid(" + ", ".join(f"{k}: {n}" for k, n in zip(self.names, self.shape)) + ")"


def _grid_point(names, shape, axes, index):
    idx = jnp.unravel_index(index, shape)
    values = [jax.tree_util.tree_map(lambda leaf, i=i: jnp.asarray(leaf)[i], ax) for ax, i in zip(axes, idx)]
    return _point_type(names)(*values)


# ------------------------------------------------------------------------------------------
# mesh and chunking
# ------------------------------------------------------------------------------------------


def sweep_mesh(devices: int | Sequence[jax.Device] | None = None) -> Mesh:
    """The one-axis device mesh (axis name ``"sweep"``, ``AxisType.Auto``) a sweep runs on.

    Args:
        devices: ``None`` for all of ``jax.devices()`` (all processes' devices after
            ``jax.distributed.initialize``), an int ``k`` for the first ``k`` of them, or a
            sequence of devices.
    """
    all_devices = jax.devices()
    if devices is None:
        devs = list(all_devices)
    elif isinstance(devices, (int, np.integer)) and not isinstance(devices, bool):
        if not 1 <= devices <= len(all_devices):
            raise ValueError(f"devices={devices} but {len(all_devices)} device(s) are available")
        devs = list(all_devices[: int(devices)])
    else:
        devs = list(devices)
        if not devs:
            raise ValueError("devices is an empty sequence")
    return jax.make_mesh((len(devs),), (_AXIS,), axis_types=(AxisType.Auto,), devices=devs)


def _plan(n: int, n_dev: int, chunk_size: int) -> tuple[int, int]:
    """(n_chunks, chunk) per device covering ``n`` points with the least padding."""
    per_device = -(-n // n_dev)
    n_chunks = -(-per_device // chunk_size)
    chunk = -(-per_device // n_chunks)
    return n_chunks, chunk


class _Progress:
    """Host side of the progress report: called from device 0 once per chunk.

    Compared by value, so a repeated sweep reuses its compiled program; the start time lives in
    a class-level table because the compiled program keeps the first equal instance.
    """

    _t0: dict = {}

    def __init__(self, report, total, per_chunk, n_chunks):
        self.report, self.total, self.per_chunk, self.n_chunks = report, total, per_chunk, n_chunks

    def start(self):
        _Progress._t0[self._key()] = time.perf_counter()

    def _key(self):
        return (self.report, self.total, self.per_chunk, self.n_chunks)

    def __eq__(self, other):
        return isinstance(other, _Progress) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    def __call__(self, chunk_index, device_index):
        if int(device_index) != 0:
            return
        k = int(chunk_index) + 1
        done = min(k * self.per_chunk, self.total)
        if self.report is True:
            elapsed = time.perf_counter() - _Progress._t0.get(self._key(), time.perf_counter())
            end = "\n" if k == self.n_chunks else ""
            sys.stderr.write(
                f"\rsweep: chunk {k}/{self.n_chunks}, {done}/{self.total} points, {elapsed:.1f} s{end}"
            )
            sys.stderr.flush()
        else:
            self.report(done, self.total)


# ------------------------------------------------------------------------------------------
# sweep
# ------------------------------------------------------------------------------------------


def sweep(
    fn: Callable[[Any], Any],
    points_or_grid: Any,
    *,
    chunk_size: int | None = None,
    devices: int | Sequence[jax.Device] | None = None,
    progress: bool | Callable[[int, int], Any] = False,
    checkpoint: bool = True,
    vectorize: bool = True,
):
    """Evaluate ``fn`` at every point of a grid or point list, chunked and sharded.

    Args:
        fn: jittable function of one parameter point returning a pytree of arrays (e.g.
            ``lambda p: jr.rolling_resistance(mat(p), layer(p), radius=R, load=p.P,
            speed=p.V).value``). It may close over shared parameters (also traced ones, so
            ``jax.grad`` with respect to them works).
        points_or_grid: a :class:`Grid` (``fn`` receives a ``GridPoint`` namedtuple), or a
            pytree whose leaves all have the same leading length ``N`` (``fn`` receives the
            same pytree with that axis removed).
        chunk_size: points per vectorised chunk on each device (bounds the working memory:
            one chunk of ``jax.vmap(fn)`` per device at a time). Default
            :data:`DEFAULT_CHUNK_SIZE` for the devices' platform (16 on CPU); it is lowered
            to balance the chunks, never raised.
        devices: ``None`` (all of ``jax.devices()``), a number ``k`` of devices (the first
            ``k``), or a sequence of devices; see :func:`sweep_mesh`.
        progress: ``True`` writes a progress line to stderr once per chunk; a callable is
            called as ``progress(points_done, points_total)`` once per chunk (counts are
            global estimates: all devices advance together). Both are ``jax.debug.callback``
            s and work under ``jax.jit`` and ``jax.grad``. The callable is part of the
            compilation key: pass the same object to reuse the compiled program.
        checkpoint: wrap each chunk in ``jax.checkpoint``, so that reverse-mode
            differentiation stores only the chunk inputs and recomputes the chunk in the
            backward pass: the gradient's working memory stays bounded by one chunk per
            device too (docs/design.md sec. 4: 1.5 GB without, 150 MiB with). No effect on a plain
            evaluation; ``False`` skips the recomputation (not faster in our measurement).
        vectorize: ``True`` (default): each chunk is one ``jax.vmap(fn)``, its points in
            lockstep lanes (best for closed forms, e.g. the direct method); the full models'
            ``Full.evaluate`` has its own batching rule, so a chunk of their points runs as one
            warm-started scan (:meth:`jaxroll.methods.Full.evaluate_points`). ``False``: the
            points of a chunk run one after the other (``lax.map``), each at its own cost and
            from a cold start: for other iterative solvers, whose while loops under ``vmap`` run
            every lane to the slowest lane's iteration count (benchmarks/bench_batched.py).

    Returns:
        The pytree ``fn`` returns, each leaf with the sweep's shape prepended: ``grid.shape``
        for a grid, ``(N,)`` for points, replicated on every device of the mesh (so with
        several processes, ``jax.distributed``, every process can read the whole result).

    Raises:
        ValueError: empty or ragged points, bad ``chunk_size`` or ``devices``.

    Example::

        grid = jr.Grid(V=jnp.logspace(-4, 0, 23), P=jnp.linspace(10.0, 150.0, 15))
        mat = jr.StandardLinearSolid(3e6, 0.25, 1.0)
        out = jr.sweep(lambda p: {"tan_delta": jr.materials.tan_delta(mat, p.V / 1e-3), "P": p.P}, grid)
        out["tan_delta"].shape  # (23, 15)

        # gradient of a sum over the sweep w.r.t. shared parameters (closure)
        def total(G0):
            m = jr.StandardLinearSolid(G0, 0.25, 1.0)
            return jnp.sum(jr.sweep(lambda p: jr.materials.loss_modulus(m, p.V / 1e-3), grid))
        jax.grad(total)(3e6)
    """
    data, run_kw, finish_kw = _prepare(points_or_grid, chunk_size, devices, progress)
    run_kw["checkpoint"] = bool(checkpoint)
    run_kw["vectorize"] = bool(vectorize)
    if run_kw["report"] is not None:
        run_kw["report"].start()
    padded = _run(fn, data, **run_kw)
    if any(_is_traced(y) for y in jax.tree_util.tree_leaves(padded)):
        # Under an outer jit/grad/vmap: finish inside the caller's program.
        return _finish(padded, **finish_kw)
    # Outside any trace: let the sweep program complete first, so that a runtime error raised
    # on one device (equinox.error_if) surfaces here as an exception instead of leaving the
    # other devices waiting at the gather below (which aborts the process on CPU).
    jax.block_until_ready(padded)
    return _finish(padded, **finish_kw)


def _prepare(points_or_grid, chunk_size, devices, progress):
    """Validate, plan the chunks, place concrete inputs; -> (data, _run kwargs, _finish kwargs)."""
    check_x64()
    mesh = sweep_mesh(devices)
    n_dev = mesh.devices.size
    if chunk_size is None:
        chunk_size = DEFAULT_CHUNK_SIZE.get(mesh.devices.flat[0].platform, 16)
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)) or chunk_size < 1:
        raise ValueError(f"chunk_size must be a positive integer; got {chunk_size!r}")
    if not (isinstance(progress, bool) or callable(progress)):
        raise ValueError(f"progress must be a bool or a callable(done, total); got {progress!r}")

    if isinstance(points_or_grid, Grid):
        grid = points_or_grid
        n, out_shape = grid.size, grid.shape
        data = tuple(grid.axes.values())
        grid_key = (grid.names, grid.shape)
    else:
        leaves = jax.tree_util.tree_leaves(points_or_grid)
        if not leaves:
            raise ValueError("points has no array leaves")
        lengths = {np.shape(leaf)[0] if np.ndim(leaf) else None for leaf in leaves}
        if None in lengths:
            raise ValueError("every leaf of points needs a leading batch axis (got a scalar leaf)")
        if len(lengths) != 1:
            raise ValueError(f"the leaves of points disagree on the batch length: {sorted(lengths)}")
        (n,) = lengths
        if n < 1:
            raise ValueError("points is empty")
        _refuse_nan(leaves, "points")
        out_shape = (n,)
        data = points_or_grid
        grid_key = None

    n = int(n)
    n_chunks, chunk = _plan(n, n_dev, int(chunk_size))
    total = n_chunks * chunk * n_dev
    report = None if progress is False else _Progress(progress, n, chunk * n_dev, n_chunks)

    # Concrete inputs are padded on the host and placed directly in their final sharding
    # (points split over the devices, grid axes replicated); traced ones are padded inside
    # the program.
    if grid_key is None:
        spec = NamedSharding(mesh, PartitionSpec(_AXIS))
        data = jax.tree_util.tree_map(lambda x: x if _is_traced(x) else jax.device_put(_pad_host(x, total), spec), data)
    else:
        spec = NamedSharding(mesh, PartitionSpec())
        data = jax.tree_util.tree_map(lambda x: x if _is_traced(x) else jax.device_put(np.asarray(x), spec), data)
    run_kw = dict(grid_key=grid_key, n=n, mesh=mesh, n_chunks=n_chunks, chunk=chunk, report=report)
    return data, run_kw, dict(n=n, out_shape=out_shape, mesh=mesh)


def _compiled(fn, points_or_grid, *, chunk_size=None, devices=None, checkpoint=True, vectorize=True):
    """The compiled sweep program (for ``.memory_analysis()`` / ``.cost_analysis()`` in the
    benchmarks): its ``temp_size_in_bytes`` is the working memory per device."""
    data, run_kw, _ = _prepare(points_or_grid, chunk_size, devices, False)
    return _run.lower(fn, data, checkpoint=checkpoint, vectorize=vectorize, **run_kw).compile()


def _is_traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)


def _pad_host(x, total: int) -> np.ndarray:
    """Pad a leaf to ``total`` rows by repeating its last row (a valid point: the padding
    cannot raise or produce NaN)."""
    x = np.asarray(x)
    if x.shape[0] == total:
        return x
    return np.concatenate([x, np.broadcast_to(x[-1:], (total - x.shape[0],) + x.shape[1:])])


@functools.partial(
    jax.jit, static_argnames=("fn", "grid_key", "n", "mesh", "n_chunks", "chunk", "report", "checkpoint", "vectorize")
)
def _run(fn, data, *, grid_key, n, mesh, n_chunks, chunk, report, checkpoint=True, vectorize=True):
    """The sweep program: padded outputs of shape ``(devices * n_chunks * chunk, ...)``,
    sharded over the mesh axis. No collectives."""
    n_dev = mesh.devices.size
    per_device = n_chunks * chunk
    total = per_device * n_dev

    def scan_chunks(point_of, local):
        """Walk ``n_chunks`` chunks of ``chunk`` points; ``point_of(local, i)`` -> chunk i."""
        device = jax.lax.axis_index(_AXIS)
        chunk_fn = jax.vmap(fn) if vectorize else functools.partial(jax.lax.map, fn)
        batched = jax.checkpoint(chunk_fn) if checkpoint else chunk_fn

        def step(_, i):
            out = batched(point_of(local, i))
            if report is not None:
                jax.debug.callback(report, i, device)
            return None, out

        _, outs = jax.lax.scan(step, None, jnp.arange(n_chunks))
        # (n_chunks, chunk, ...) -> (per_device, ...)
        return jax.tree_util.tree_map(lambda y: y.reshape((per_device,) + y.shape[2:]), outs)

    if grid_key is not None:
        names, shape = grid_key

        def grid_chunk(axes, i):
            device = jax.lax.axis_index(_AXIS).astype(i.dtype)
            start = device * per_device + i * chunk
            flat = jnp.minimum(start + jnp.arange(chunk, dtype=i.dtype), n - 1)  # padding: repeat the last point
            return _grid_point(names, shape, axes, flat)

        body = functools.partial(scan_chunks, grid_chunk)
        in_spec = PartitionSpec()  # axes replicated; each device gathers its own points
        args = data
    else:

        def pad(leaf):  # traced inputs only; concrete ones arrive padded (_pad_host)
            if leaf.shape[0] == total:
                return leaf
            return jnp.concatenate([leaf, jnp.broadcast_to(leaf[-1:], (total - n,) + leaf.shape[1:])])

        def point_chunk(local, i):
            return jax.tree_util.tree_map(
                lambda leaf: jax.lax.dynamic_slice_in_dim(leaf, i * chunk, chunk, axis=0), local
            )

        body = functools.partial(scan_chunks, point_chunk)
        in_spec = PartitionSpec(_AXIS)
        args = jax.tree_util.tree_map(pad, data)

    return jax.shard_map(body, mesh=mesh, in_specs=(in_spec,), out_specs=PartitionSpec(_AXIS), check_vma=False)(
        args
    )


@functools.partial(jax.jit, static_argnames=("n", "out_shape", "mesh"))
def _finish(padded, *, n, out_shape, mesh):
    """Drop the padding, give the results the sweep's shape, replicate them over the mesh.

    Replicated because an uneven leading length cannot be tiled over the mesh axis; it also
    makes the result readable on every process of a multi-host run.
    """
    replicated = NamedSharding(mesh, PartitionSpec())
    return jax.tree_util.tree_map(
        lambda y: jax.lax.with_sharding_constraint(y[:n].reshape(out_shape + y.shape[1:]), replicated), padded
    )
