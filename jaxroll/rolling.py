"""The front doors: :func:`rolling_resistance` (one point) and :func:`rolling_resistance_grid`
(a speeds x loads table), for every method and geometry.

Both are compiled once per static setup: the method object (static, hashable configuration),
the geometry, ``throw`` and the input shapes are the cache key; the physical values (material
and layer parameters, radius, loads, speeds, and the grid's cell size and period) are traced
values of the compiled program. So a second call with new values compiles nothing, and under
``jax.jit``, ``jax.vmap`` and ``jax.grad`` the numbers are those of an eager call with the same
(resolved) method. With concrete inputs and the compilation cache on, a new process runs the
lowered program that an earlier one stored for the same static setup and shapes
(:func:`jaxroll._compilation_cache.call`) instead of tracing it again, with the same numbers.

Checks and failures: with concrete inputs (an ordinary call) the input rules are checked on the
host before anything is compiled (``ValueError``; values allowed but far outside the physical
range, likely unit slips, give a :class:`~jaxroll.PlausibilityWarning`), the compiled program
carries the :data:`~jaxroll.RESULTS` code of each point in ``result``, and ``throw=True`` raises
:class:`~jaxroll.SolverError` on the host. So the compiled programs hold no host callbacks and
JAX's persistent compilation cache can keep them across processes. With traced inputs (under a
user's ``jax.jit``, ``jax.vmap``, ``jax.grad``) the same checks run inside the program
(``equinox.error_if``) and surface as JAX's runtime error, whose text contains the reason.
"""

from __future__ import annotations

import sys
import time
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _compilation_cache
from ._numerics import (any_traced, as_float, check_parameter_shapes, check_plausible, check_roller_shapes,
                        check_roller_values, input_checks, roller_inputs)
from .engines.layer import Layer, check_subsonic
from .engines.stack import Stack, models
from .materials.material import AbstractMaterial
from .engines.contact_size import estimate_contact_size
from .geometry import check_geometry
from .methods import as_method, default_method
from .result import RESULTS, RollingResult, SolverError, ValidityWarning, check_validity, raise_on_failure

__all__ = ["rolling_resistance", "rolling_resistance_grid", "ValidityWarning"]

_AUTOGRID_TRACED = (
    "{method} sizes its grid (jr.AutoGrid) from concrete input values, but the inputs are traced "
    "(jax.jit / jax.vmap / jax.grad). Resolve the grid once from concrete values first, "
    "method = method.resolve(material, layer, radius=..., loads=[...], speeds=[...], geometry=...), "
    "and pass that method, or give a jr.FixedGrid."
)


def _check_models(material, layer):
    if not isinstance(material, AbstractMaterial):
        raise ValueError(f"material must be a jaxroll material (jr.StandardLinearSolid, jr.GeneralizedMaxwell, "
                         f"jr.materials.AtTemperature, ...); got {type(material).__name__}")
    if not isinstance(layer, (Layer, Stack)):
        raise ValueError(f"layer must be a jr.Layer (or give a jr.Stack alone); got {type(layer).__name__}")
    check_parameter_shapes(material, "material"), check_parameter_shapes(layer, "layer")


def _check_models_on_host(material, layer, speeds):
    """The rules of concrete models on the host (``ValueError``): the material's and the layer's
    parameters (a Stack: every ply's and the base's material too) and the speeds below every
    shear-wave speed of the layer. After them a program may be traced without its input checks
    (:func:`jaxroll._numerics.input_checks`): the front doors, the maps, the batched points."""
    material.checked(), layer.checked()
    check_subsonic(material, layer, speeds)


def _prepare(method, material, layer, radius, loads, speeds, geometry):
    """The method to run (resolved and memory-checked), after the host checks of every concrete
    input; and whether the inputs are traced (then the checks go into the program)."""
    check_geometry(geometry)
    method = as_method(default_method(geometry) if method is None else method)
    _check_models(material, layer)
    check_roller_values(radius, loads, speeds)
    traced = any_traced(material, layer, radius, loads, speeds)
    if not traced:  # concrete values: the rules of jr.Layer and the material, on the host
        _check_models_on_host(material, layer, speeds)
        H = layer.H if isinstance(layer, Layer) else [p.H for p in layer.plies]  # a Stack: each ply's thickness
        check_plausible("rolling_resistance", radius=radius, H=H, G0=material.relaxed_modulus(), speed=speeds,
                        stacklevel=4)
    method.check_geometry(geometry)
    if method.needs_resolution(geometry):
        if traced:
            raise ValueError(_AUTOGRID_TRACED.format(method=type(method).__name__))
        method = method.resolve(material, layer, radius=radius, loads=loads, speeds=speeds, geometry=geometry)
    method.check_memory(geometry)
    return method, traced


def _raise_in_program(res: RollingResult) -> RollingResult:
    """``res`` with a check inside the compiled program that raises the one-line
    :meth:`SolverError.message` of the first failure (traced inputs only: a host callback)."""
    value = eqx.branched_error_if(res.value, res.result != RESULTS.successful, res.result,
                                  [SolverError.message(c) for c in RESULTS])
    return eqx.tree_at(lambda r: r.value, res, value)


def _warn_if_invalid(res: RollingResult, where: str) -> None:
    codes = res.result
    if isinstance(codes, jax.core.Tracer):
        return
    codes = np.asarray(codes)
    bad = codes[codes != RESULTS.successful]
    if bad.size:
        reasons = "; ".join(f"{int(np.sum(bad == c))} x {RESULTS.message(c)}" for c in np.unique(bad))
        warnings.warn(f"{where}: {bad.size} of {codes.size} result(s) not valid: {reasons}", ValidityWarning,
                      stacklevel=3)


def _validated(method, material, layer, res, R, P, V, geometry):
    """The checks every method shares (:func:`jaxroll.result.check_validity`); ``P`` a scalar
    or a 1D array of loads (the grid's second axis)."""
    size_of = lambda p: estimate_contact_size(material, layer, R, p, geometry)  # noqa: E731
    size = size_of(P) if jnp.ndim(P) == 0 else jax.vmap(size_of)(P)
    return check_validity(res, radius=R, speed=V, contact_size=size, max_truncation=method.max_truncation,
                          max_approximation=method.max_approximation,
                          dissipative=material.glassy_modulus() > material.relaxed_modulus())


@eqx.filter_jit
def _point(method, material, layer, radius, load, speed, geometry, traced):
    """One point; ``traced`` (static): the inputs are traced, so the input checks and the
    failure check of ``throw=True`` go into the program."""
    with input_checks(traced):
        R, P, V = roller_inputs(radius, load, speed)
        material, layer = material.checked(), layer.checked()
        res = method.evaluate(material, layer, R, P, V, geometry)
        res = _validated(method, material, layer, res, R, P, V, geometry)
    return res


@eqx.filter_jit
def _grid(method, material, layer, radius, loads, speeds, geometry, traced):
    """The ``speeds x loads`` table; ``traced`` as in :func:`_point`."""
    with input_checks(traced):
        R = roller_inputs(radius, 1.0, 0.0)[0]
        material, layer = material.checked(), layer.checked()
        loads = jax.vmap(lambda P: roller_inputs(1.0, P, 0.0)[1])(loads)
        speeds = jax.vmap(lambda V: roller_inputs(1.0, 1.0, V)[2])(speeds)
        res = method.evaluate_grid(material, layer, R, loads, speeds, geometry)
        res = _validated(method, material, layer, res, R, loads, speeds[:, None], geometry)
    return res


def _finish(res: RollingResult, throw: bool, where: str) -> RollingResult:
    """``throw``: raise on a failure (on the host when the result is concrete, inside the
    program when the call is part of a user's trace); otherwise an eager call warns."""
    if throw:
        if isinstance(res.result, jax.core.Tracer):
            return _raise_in_program(res)
        raise_on_failure(res.result)
    else:
        _warn_if_invalid(res, where)
    return res


def rolling_resistance(material, layer=None, *, radius, load, speed, geometry="sphere", method=None,
                       throw=True) -> RollingResult:
    """Rolling resistance of a rigid sphere or cylinder on a viscoelastic layer, at one point.

    Args:
        material: a material (``jr.StandardLinearSolid(G0, tau, f)``, ``jr.GeneralizedMaxwell``,
            ``jr.at_temperature(...)``, any :class:`jaxroll.materials.material.AbstractMaterial`).
        layer: :class:`jaxroll.engines.layer.Layer` (``H`` [m], ``jnp.inf`` for a half-space).
            Bonded plies: a :class:`jaxroll.Stack` given alone in place of ``material``,
            ``rolling_resistance(stack, radius=..., ...)`` (it carries its materials).
        radius: roller radius ``R`` [m].
        load: ``P`` [N] (sphere) or ``P'`` [N/m] (cylinder, per unit length).
        speed: rolling speed ``V`` [m/s], ``>= 0`` (the roller travels toward +x).
        geometry: ``"sphere"`` or ``"cylinder"``.
        method: a method object (:class:`jaxroll.Direct`, :class:`jaxroll.Full`,
            :class:`jaxroll.Slices`) or a shortcut ``"direct"``, ``"full"``, ``"PD"``, ``"PP"``,
            ``"SP"``; default :func:`jaxroll.methods.default_method` (the full model: 3D for a
            sphere, 2D for a cylinder, infinite layer, automatic grid). Under
            ``jit``/``vmap``/``grad`` a method with a grid must be resolved first
            (``method.resolve(...)``).
        throw: raise if the result is not trustworthy (``result != RESULTS.successful``: a
            solver failure or a validity check): :class:`jaxroll.SolverError`, one line with
            the code's name and reason (under a user's ``jax.jit``/``vmap``/``grad``, JAX's
            runtime error, whose text contains that line). With
            ``throw=False`` the reason is returned in ``result`` (use it under ``vmap``), and an
            eager call warns (:class:`jaxroll.ValidityWarning`).

    Returns:
        :class:`jaxroll.result.RollingResult`: ``value`` [N for a sphere, N/m for a cylinder]
        and diagnostics; ``valid`` is ``result == RESULTS.successful``.

    Works under ``jax.jit``, ``jax.vmap`` (scalar ``radius``, ``load``, ``speed`` per call) and
    ``jax.grad`` with respect to the material and layer parameters, ``R``, ``P`` and ``V``.
    """
    material, layer = models(material, layer)
    check_roller_shapes(radius, load, speed)  # (before an AutoGrid is resolved from them)
    method, traced = _prepare(method, material, layer, radius, load, speed, geometry)
    radius, load, speed = as_float(radius), as_float(load), as_float(speed)
    res = _compilation_cache.call(_point, method.dynamic(), material, layer, radius, load, speed, geometry, traced)
    return _finish(res, bool(throw), "rolling_resistance")


def rolling_resistance_grid(material, layer=None, *, radius, loads, speeds, geometry="sphere", method=None,
                            throw=False, progress=False) -> RollingResult:
    """Rolling resistance on the table ``speeds x loads`` (the paper's "reference case").

    Same arguments as :func:`rolling_resistance`, with ``loads`` [N or N/m] and ``speeds``
    [m/s] 1D arrays. Per-speed work (compliance kernels, the slices' factorisations) is shared
    by all loads of the speed; the full models start each load from the previous load's contact
    set (give loads sorted). An :class:`~jaxroll.grids.AutoGrid` is sized once for the whole
    table. ``throw=False`` by default: a table keeps going past a bad point, whose reason is in
    ``result`` (an eager call warns with the count per reason).

    ``progress``: ``False`` (default), ``True`` (a line on stderr after each block of speeds: done,
    total, seconds) or a callable ``progress(speeds_done, speeds_total)``, for long tables
    (a loss-dominated material on a fine grid: minutes). The table is then solved in
    :data:`GRID_PROGRESS_BLOCKS` blocks of speeds by one compiled program (the last block padded
    with its last speed), each block's first speed from a cold start instead of the previous
    speed's solution: the same values to the solver tolerance. Concrete inputs only.

    Returns:
        :class:`jaxroll.result.RollingResult` whose fields are ``(n_speeds, n_loads)`` arrays
        (pressure fields ``(n_speeds, n_loads, ...)``).
    """
    loads, speeds = as_float(loads), as_float(speeds)
    if loads.ndim != 1 or speeds.ndim != 1 or loads.size == 0 or speeds.size == 0:
        raise ValueError(f"loads and speeds must be non-empty 1D arrays; got shapes {loads.shape} and {speeds.shape}")
    material, layer = models(material, layer)
    if not (isinstance(progress, bool) or callable(progress)):
        raise ValueError(f"progress must be a bool or a callable(done, total); got {progress!r}")
    method, traced = _prepare(method, material, layer, radius, loads, speeds, geometry)
    if progress is False:
        res = _compilation_cache.call(_grid, method.dynamic(), material, layer, as_float(radius), loads, speeds,
                                      geometry, traced)
    elif traced:
        raise ValueError("rolling_resistance_grid: progress needs concrete inputs (it runs the table in blocks "
                         "from the host); call it outside jit/vmap/grad, or with progress=False")
    else:
        res = _grid_in_blocks(method, material, layer, as_float(radius), loads, speeds, geometry, progress)
    return _finish(res, bool(throw), "rolling_resistance_grid")


#: Blocks of speeds of :func:`rolling_resistance_grid` with ``progress`` (at most this many reports).
GRID_PROGRESS_BLOCKS = 10


def _grid_in_blocks(method, material, layer, radius, loads, speeds, geometry, progress) -> RollingResult:
    """The table of :func:`_grid` (concrete inputs) in blocks of speeds of one length (one
    program), reporting after each block (``progress``: ``True``, a line on stderr, or a callable
    ``(done, total)``)."""
    n = speeds.shape[0]
    k = -(-n // GRID_PROGRESS_BLOCKS)
    padded = jnp.concatenate([speeds, jnp.repeat(speeds[-1:], -n % k)])
    t0, parts = time.perf_counter(), []
    for i in range(0, padded.shape[0], k):
        part = jax.device_get(_compilation_cache.call(_grid, method.dynamic(), material, layer, radius, loads,
                                                      padded[i:i + k], geometry, False))
        parts.append(part)
        done = min(i + k, n)
        if progress is True:
            end = "\n" if done == n else ""
            sys.stderr.write(f"\rrolling_resistance_grid: {done}/{n} speeds, {time.perf_counter() - t0:.1f} s{end}")
            sys.stderr.flush()
        else:
            progress(done, n)

    def joined(*leaves):  # every field of a table has the speeds first (the docstring above)
        if any(np.ndim(x) == 0 or np.shape(x)[0] != k for x in leaves):
            raise AssertionError("a table field without the speed axis first")
        return jnp.asarray(np.concatenate(leaves)[:n])

    return jax.tree_util.tree_map(joined, *parts)
