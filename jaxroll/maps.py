"""Rolling-resistance maps over temperature x speed of a temperature-shifted material, with
the gradients a designer needs (``dR_r/dT``, ``dR_r/dH``).
"""

from __future__ import annotations

import dataclasses
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._numerics import as_float, check_plausible, input_checks
from .engines.layer import Layer, is_quasistatic
from .engines.stack import cover_thickness, with_cover_material, with_cover_thickness
from .io import write_table


@dataclasses.dataclass(frozen=True)
class ResistanceMap:
    """Rolling resistance over temperature x speed (:func:`resistance_map`).

    Attributes:
        temperatures [K], speeds [m/s]: the axes.
        value: ``R_r`` [N for a sphere, N/m for a cylinder], shape ``(n_T, n_V)``.
        valid: ``result == RESULTS.successful`` per point.
        dR_dT: ``dR_r/dT`` [N/K or N/(m K)] and dR_dH: ``dR_r/dH`` [N/m or N/m^2] (per point, one adjoint solve
            for both with the full models).
        seconds: wall time of the compiled map (values and gradients, compilation excluded)
            divided by the number of points [s].
        result: the :data:`jaxroll.RESULTS` code per point (why a point is not valid).
    """

    temperatures: np.ndarray
    speeds: np.ndarray
    value: np.ndarray
    valid: np.ndarray
    dR_dT: np.ndarray
    dR_dH: np.ndarray
    seconds: float
    result: np.ndarray | None = None

    def _table(self, unit):
        if unit not in ("N", "N/m"):
            raise ValueError(f"unit must be 'N' (sphere) or 'N/m' (cylinder), got {unit!r}")
        coords = {"temperature": (self.temperatures, "K"), "speed": (self.speeds, "m/s")}
        fields = {"rolling_resistance": (self.value, unit), "dR_dT": (self.dR_dT, f"{unit}/K"),
                  "dR_dH": (self.dR_dH, f"{unit}/m"), "valid": (np.asarray(self.valid), "-")}
        if self.result is not None:
            fields["result"] = (np.asarray(self.result), "-")
        return coords, fields, {}

    def to_xarray(self, *, unit="N"):
        """An ``xarray.Dataset`` with dimensions ``(temperature, speed)`` [K, m/s] and variables
        ``rolling_resistance`` [``unit``: N for a sphere, N/m for a cylinder], ``dR_dT``,
        ``dR_dH``, ``valid`` and ``result``, each with ``attrs["units"]``. Needs xarray."""
        from ._labelled import to_xarray

        return to_xarray(*self._table(unit))

    def to_pandas(self, *, unit="N"):
        """As :meth:`to_xarray`, a ``pandas.DataFrame`` with one row per point (index
        ``(temperature, speed)``, speed fastest), units in ``attrs["units"]``. Needs pandas."""
        from ._labelled import to_pandas

        return to_pandas(*self._table(unit))

    def write_csv(self, path, *, unit="N"):
        """One row per point: temperature [K], speed [m/s], R_r, dR/dT, dR/dH, valid and (when
        known) the name of the point's :data:`jaxroll.RESULTS` code."""
        from .result import RESULTS

        T, V = (a.ravel() for a in np.meshgrid(self.temperatures, self.speeds, indexing="ij"))
        cols = {"temperature": T, "speed": V, "rolling_resistance": np.ravel(self.value), "dR_dT": np.ravel(self.dR_dT),
                "dR_dH": np.ravel(self.dR_dH), "valid": np.ravel(self.valid).astype(int)}
        units = ["K", "m/s", unit, f"{unit}/K", f"{unit}/m", "-"]
        if self.result is not None:
            cols["result"] = [RESULTS.names[int(c)] for c in np.ravel(self.result)]
            units.append("-")
        write_table(path, cols, units, formats={"temperature": ".6g", "speed": ".6g", "rolling_resistance": ".8g",
                                                "dR_dT": ".6g", "dR_dH": ".6g"})


def resistance_map(material, shift, layer, *, radius, load, temperatures, speeds, geometry="sphere",
                   method=None, measured_temperatures=None, measured_frequencies=None) -> ResistanceMap:
    """``R_r(T, V)`` of a rigid sphere or cylinder on a layer of a material characterised at
    ``shift.T_ref`` (``jr.at_temperature(material, shift, T)``), with ``dR_r/dT`` and
    ``dR_r/dH`` (with the full models, one adjoint solve per point for all derivatives: the
    ``adjoint`` of :func:`_map_program`), all points in one compiled program
    (:meth:`~jaxroll.methods.AbstractMethod.evaluate_points`: the full models solve the points
    one after the other in the order of the reduced speed ``V a_T``, each warm-started from the
    previous one; per point the numbers of :func:`jaxroll.rolling_resistance` to the solver
    tolerance).

    Args:
        material: e.g. the :class:`PronyFit`'s ``material``; shift: its WLF/Arrhenius law.
        layer: :class:`jaxroll.Layer` (its ``H`` [m] is the thickness differentiated), or a
            :class:`jaxroll.Stack` whose top ply holds ``material`` (or the stack alone,
            ``layer=None``): each point shifts the top ply by ``shift`` and every ply or
            half-space base of a temperature-shifted material by its own law
            (:func:`models_at`); ``dR_dH`` is then the top ply's thickness.
        radius [m], load [N, or N/m for a cylinder]; temperatures [K], speeds [m/s]: 1D axes.
        geometry: ``"sphere"`` or ``"cylinder"``.
        method: a method object or shortcut; default :func:`jaxroll.methods.default_method`
            (the full model on an infinite layer). A full model with an
            :class:`~jaxroll.grids.AutoGrid` on a layer without inertia solves each point on
            the grid its rule asks for at that point alone (:meth:`~jaxroll.grids.AutoGrid.buckets`:
            the points grouped by cells per radius, one compiled program and one warm-started
            scan per class, so each value is the front door's at that point); other methods
            with an AutoGrid get one grid for the whole map, the union of the grids resolved
            at the lowest and the highest temperature. The periodic full models
            need periods of ~20 V tau_max, impractical for spectra of 20 decades; ``"direct"``
            is a screening choice (milliseconds per point, see docs/methods.md for its error
            against the full model).
        measured_temperatures: ``(T_min, T_max)`` [K] the material was measured over (e.g. the
            ``temperature_range`` that ``jaxroll material`` writes into ``material.json``):
            points outside are computed but not valid, ``RESULTS.outside_measured_range`` (the
            shift law is extrapolated there). ``None``: not checked.
        measured_frequencies: ``(omega_min, omega_max)`` [rad/s], the master curve's range of
            reduced angular frequency at ``shift.T_ref`` (the ``reduced_frequency_range`` of
            ``material.json``): points whose contact is excited at a reduced frequency
            ``V a_T(T) / a`` (``a`` the contact radius or half-width) outside it are not valid,
            ``RESULTS.outside_measured_range`` (the Prony series is extrapolated there).
            ``None``: not checked.
    """
    T = np.asarray(temperatures, float)
    V = np.asarray(speeds, float)
    if T.ndim != 1 or V.ndim != 1 or T.size == 0 or V.size == 0:
        raise ValueError(f"temperatures and speeds must be non-empty 1D arrays (the map's axes); got shapes {T.shape} "
                         f"and {V.shape}")
    Tp, Vp = (a.ravel() for a in np.meshgrid(T, V, indexing="ij"))
    out = map_points(material, shift, layer, radius=radius, loads=np.full(Tp.shape, float(load)), temperatures=Tp,
                     speeds=Vp, geometry=geometry, method=method, measured_temperatures=measured_temperatures,
                     measured_frequencies=measured_frequencies, where="resistance_map")
    shape = (T.shape[0], V.shape[0])
    return ResistanceMap(T, V, out.value.reshape(shape), out.valid.reshape(shape), out.dR_dT.reshape(shape),
                         out.dR_dH.reshape(shape), out.seconds, out.result.reshape(shape))


@dataclasses.dataclass(frozen=True)
class MapPoints:
    """Rolling resistance at ``n`` points ``(T, V, P)`` with its derivatives (:func:`map_points`).

    Attributes:
        value: ``R_r`` [N or N/m] per point; result: :data:`jaxroll.RESULTS` code; valid.
        dR_dT [per K], dR_dH [per m]: derivatives at each point (:func:`_map_program`).
        dR_ddirection: ``(n_directions, n)``, the derivative along each material direction
            (``d R_r / d s`` of ``material + s * direction`` at ``s = 0``).
        contact_radius [m]: the solved contact radius or half-width; seconds: wall time per
            point of the compiled program (compilation excluded).
    """

    value: np.ndarray
    result: np.ndarray
    valid: np.ndarray
    dR_dT: np.ndarray
    dR_dH: np.ndarray
    dR_ddirection: np.ndarray
    contact_radius: np.ndarray
    seconds: float


def map_points(material, shift, layer, *, radius, loads, temperatures, speeds, geometry="sphere", method=None,
               measured_temperatures=None, measured_frequencies=None, directions=(), where="map") -> MapPoints:
    """The engine of :func:`resistance_map` and :func:`jaxroll.conveyor.conveyor_map`: ``R_r``
    at the points ``(temperatures[i], speeds[i], loads[i])`` (1D arrays of one length, K, m/s,
    N or N/m) of a temperature-shifted material on ``layer``, with ``dR_r/dT``, ``dR_r/dH``
    (the thickness of the layer, or of the top ply of a layer-like object) and the derivative
    along each of ``directions`` (pytrees shaped like ``material``: tangents of its parameters;
    with a :class:`jaxroll.Stack`, of the top ply's compound, every shifted ply at the point's
    temperature: :func:`models_at`),
    one compiled program per grid class; the points are solved in the order of the reduced speed
    ``V a_T`` and then the load. ``measured_temperatures``/``measured_frequencies``: as in
    :func:`resistance_map` (points outside are ``RESULTS.outside_measured_range``)."""
    import time

    from ._numerics import check_roller_shapes, check_roller_values
    from .buckets import class_lengths
    from .rolling import _check_models, _check_models_on_host
    from .result import RESULTS

    material, layer = _split_stack(material, layer)
    _check_models(material, layer)  # (types and parameter shapes, before anything is sized or traced)
    check_roller_shapes(radius, 1.0, 0.0)
    T, V, P = (np.asarray(x, float).ravel() for x in (temperatures, speeds, loads))
    if not T.shape == V.shape == P.shape:
        raise ValueError(f"temperatures, speeds and loads must have one length; got {T.size}, {V.size}, {P.size}")
    # the map's points are traced: the plausibility of its concrete inputs is checked here
    check_plausible(where, radius=radius, H=cover_thickness(layer), G0=material.relaxed_modulus(), speed=V)
    check_roller_values(radius, P, V)
    _check_models_on_host(material, layer, V)  # (a_T leaves the relaxed modulus, so the shear-wave speeds, as they are)
    _check_cover(material, shift, layer)
    shift.check_temperatures(T)
    # under time-temperature superposition the contact depends on T and V through the reduced
    # speed V a_T (up to the layer's inertia): each class is solved in that order, then the load
    Vr = V * np.exp(np.asarray(shift.log_shift(jnp.asarray(T))))
    directions = tuple(directions)
    buckets = _map_buckets(method, material, shift, layer, radius, P, T, V, Vr, geometry)
    lengths = class_lengths([getattr(getattr(m, "grid", None), "window", None) for m, _, _ in buckets],
                            [len(idx) for _, idx, _ in buckets])
    programs = [_bucket_program(m, idx, Vr, P, T, V, material, shift, layer, radius, directions, geometry, reduced,
                                length) for (m, idx, reduced), length in zip(buckets, lengths)]
    v, code, dT, dH, a = (np.empty(T.size) for _ in range(5))
    dd = np.empty((len(directions), T.size))
    t0 = time.perf_counter()
    outs = [jax.block_until_ready(call(*args)) for call, args, _ in programs]
    seconds = (time.perf_counter() - t0) / T.size
    for (_, _, idx), out in zip(programs, outs):
        k = idx.size
        for dest, x in zip((v, code, dT, dH, a), (out[0], out[1], out[2], out[3], out[5])):
            dest[idx] = np.asarray(x)[:k]
        dd[:, idx] = np.asarray(out[4])[:, :k]
    outside = _outside_measured(shift, T, V, a, measured_temperatures, measured_frequencies)
    code = np.where(outside & (code == RESULTS.successful), RESULTS.outside_measured_range, code).astype(int)
    return MapPoints(v, code, code == RESULTS.successful, dT, dH, dd, a, seconds)


def _map_buckets(method, material, shift, layer, radius, P, T, V, Vr, geometry) -> list:
    """``[(method, point indices, reduced)]`` of a map: a full model with an
    :class:`~jaxroll.grids.AutoGrid` on a layer without inertia gets one grid per class of the
    points (:meth:`~jaxroll.grids.AutoGrid.buckets`: the grid the rule asks for at each point
    alone, the reference material at the reduced speed ``Vr``); other methods with an AutoGrid
    one grid, the union of the grids resolved at the lowest and the highest temperature over
    every load; ``reduced``: :func:`_reduced`."""
    from .grids import union
    from .methods import as_method, default_method

    method = as_method(default_method(geometry) if method is None else method)
    method.check_geometry(geometry)
    reduced = _reduced(method, layer)
    everything = np.arange(T.size)
    if method.needs_resolution(geometry) and reduced:
        out = [(method.on_grid(g).for_points(material, layer, radius, P[idx], Vr[idx], geometry), idx, reduced)
               for g, idx in method.grid.buckets(material, layer, radius, P, Vr, geometry)]
    elif method.needs_resolution(geometry):
        resolved = [method.resolve(*models_at(material, shift, layer, Ti), radius=radius, loads=np.unique(P),
                                   speeds=jnp.asarray(np.unique(V)), geometry=geometry)
                    for Ti in (float(np.min(T)), float(np.max(T)))]
        out = [(method.on_grid(union([r.grid for r in resolved]), resolved), everything, reduced)]
    else:
        out = [(method, everything, reduced)]
    for m, _, _ in out:
        m.check_memory(geometry)
    return out


def _bucket_program(method, idx, Vr, P, T, V, material, shift, layer, radius, directions, geometry, reduced,
                    length=8):
    """``(call, args, points)`` of :func:`_map_program` compiled for the points ``idx`` in the
    order of the reduced speed ``Vr`` and then the load (``points``: them in that order, the
    order of the outputs' first ``len(idx)`` entries), padded (:func:`jaxroll.buckets.padded`, to
    at least ``length`` points: :func:`jaxroll.buckets.class_lengths`) so that buckets and classes
    of other sizes share the program, kept by its static configuration and
    shapes (:func:`jaxroll.buckets.compiled`: a new material value, cell size or temperature
    compiles nothing)."""
    from .buckets import compiled, padded

    with np.errstate(divide="ignore"):  # V = 0 (a static point) sorts first, at log 0 = -inf
        idx = idx[np.lexsort((P[idx], np.round(np.log(Vr[idx]), 12)))]
    pad, count = padded(idx, length)
    args = (method.dynamic(), material, shift, layer, as_float(radius), jnp.asarray(P[pad]),
            jnp.asarray(T[pad]), jnp.asarray(V[pad]), jnp.asarray(count), directions)
    # map_points checked every rule of a Layer on the host; a Stack's plies may carry shift laws
    # of their own, evaluated at the map's temperatures: their domains are checked inside
    checked = isinstance(layer, Layer)
    call, _ = compiled(_map_program, args, dict(geometry=geometry, reduced=reduced, checked=checked), store=checked)
    return call, args, idx


def _outside_measured(shift, T, V, a, measured_temperatures, measured_frequencies) -> np.ndarray:
    """Points outside the measured temperatures ``(T_min, T_max)`` [K] or whose reduced
    frequency ``V a_T / a`` leaves the master curve's ``(omega_min, omega_max)`` [rad/s]."""
    outside = np.zeros(np.shape(T), bool)
    if measured_temperatures is not None:
        lo, hi = sorted(float(t) for t in measured_temperatures)
        outside |= (T < lo - 1e-6) | (T > hi + 1e-6)
    if measured_frequencies is not None:
        lo, hi = sorted(float(w) for w in measured_frequencies)
        aT = np.asarray(jnp.exp(shift.log_shift(jnp.asarray(T))))
        with np.errstate(divide="ignore", invalid="ignore"):
            w = aT * V / a
        outside |= ~((w >= lo * (1 - 1e-9)) & (w <= hi * (1 + 1e-9)))
    return outside


def models_at(material, shift, layer, T):
    """``(material, layer)`` at temperature ``T`` [K] as the methods take them (scalar ``T``;
    jittable). A :class:`jaxroll.Layer`: ``(at_temperature(material, shift, T), layer)``. A
    :class:`jaxroll.Stack`: the stack with its top ply's material ``at_temperature(material,
    shift, T)`` (the map's compound: the top ply holds ``material`` or that material at any
    temperature), every other ply and a half-space base whose material is temperature-shifted
    (:func:`jaxroll.at_temperature`, with its own shift law) shifted to ``T`` too, and plies of
    unshifted materials (e.g. a steel-cord carcass) left as they are; returned as
    ``(stack.material, stack)``."""
    from .engines.stack import Stack
    from .materials.material import AtTemperature, at_temperature

    top = at_temperature(material, shift, T)
    if not isinstance(layer, Stack):
        return top, layer

    def shifted(m):
        return eqx.tree_at(lambda x: x.T, m, jnp.asarray(T, float)) if isinstance(m, AtTemperature) else m

    stack = with_cover_material(layer, top)
    plies = stack.plies[:1] + tuple(eqx.tree_at(lambda p: p.material, p, shifted(p.material)) for p in stack.plies[1:])
    stack = eqx.tree_at(lambda s: s.plies, stack, plies)
    if stack.base is not None:
        stack = eqx.tree_at(lambda s: s.base.material, stack, shifted(stack.base.material))
    return stack.material, stack


def _split_stack(material, layer):
    """``(material, layer)`` of the maps: a :class:`jaxroll.Stack` given alone (``layer=None``)
    becomes ``(its top ply's compound at shift.T_ref, the stack)``."""
    from .engines.stack import Stack
    from .materials.material import AtTemperature

    if isinstance(material, Stack) and layer is None:
        top = material.plies[0].material
        return (top.material if isinstance(top, AtTemperature) else top), material
    return material, layer


def _check_cover(material, shift, layer):
    """``ValueError`` unless a :class:`jaxroll.Stack`'s top ply holds the map's compound
    (``material``, or ``material`` at some temperature through ``shift``)."""
    from .engines.stack import Stack
    from .materials.material import AtTemperature

    if not isinstance(layer, Stack):
        return
    top = layer.plies[0].material
    if isinstance(top, AtTemperature):
        same = bool(eqx.tree_equal(top.material, material)) and bool(eqx.tree_equal(top.shift, shift))
    else:
        same = top is material or bool(eqx.tree_equal(top, material))
    if not same:
        raise ValueError("a map of a jr.Stack shifts its top ply's material, which must be the map's material (or "
                         "jr.at_temperature(material, shift, T) of it): give the cover compound at shift.T_ref as "
                         "material and the stack with it in the top ply")


def _batched_models(material, shift, layer, T):
    """``(materials, layers, layer_axis)`` at the 1D temperatures ``T`` as
    :meth:`~jaxroll.methods.AbstractMethod.evaluate_points` takes them: a Layer is shared
    (``layer_axis = None``); a Stack is batched (every array leaf gets the leading axis, its
    Python-float leaves, such as a static ``rho = 0``, stay shared so that quasi-static plies
    keep their formulation)."""
    from .engines.stack import Stack

    if not isinstance(layer, Stack):
        return jax.vmap(lambda t: models_at(material, shift, layer, t)[0].checked())(T), layer, None
    stacks = jax.vmap(lambda t: models_at(material, shift, layer, t)[1])(T)
    template = models_at(material, shift, layer, T[0])[1]
    stacks = jax.tree_util.tree_map(lambda b, t: t if isinstance(t, float) else b, stacks, template)
    mats = jax.vmap(lambda m: m.checked())(stacks.material)
    return mats, eqx.tree_at(lambda s: s.plies[0].material, stacks, mats), 0


def _batch_axes(tree):
    """``vmap`` axes of a batched tree: 0 for array leaves, ``None`` for Python-float leaves."""
    return jax.tree_util.tree_map(lambda x: 0 if np.ndim(x) else None, tree)


def _thickness_builder(method, material, layer, H, geometry):
    """``V -> kernel`` of the full model of ``geometry`` for ``material`` on ``layer`` with the
    cover thickness ``H`` [m] (``model.kernel_builder``: the layer's speed-independent integrals
    formed once), whose derivative in ``H`` is formed once: one forward pass with a unit tangent,
    scaled by each direction's ``dH``. Under ``jax.vmap`` of ``jax.jvp`` (the map's tangent
    directions, :func:`_map_program`) the layer's integrals then cost one derivative, not one per
    direction; the numbers are those of the plain builder."""
    from .methods import _FULL_MODELS

    model, converted = _FULL_MODELS[geometry], []

    def arrays(H):  # the arrays the builder closes over, as a function of H
        fn, consts = jax.closure_convert(
            model.kernel_builder(material, with_cover_thickness(layer, H), method.grid), jnp.ones(()))
        converted.append(fn)
        return consts

    once = jax.custom_jvp(arrays)

    @once.defjvp
    def _(primals, tangents):
        consts, per_unit = jax.jvp(arrays, primals, (jnp.ones_like(primals[0]),))
        return consts, [d * tangents[0] if jnp.issubdtype(d.dtype, jnp.inexact) else d for d in per_unit]

    consts = once(jnp.asarray(H, float))
    return lambda V: converted[-1](V, *consts)


def _reduced(method, layer) -> bool:
    """Whether the map evaluates the reference material at the reduced speed ``V a_T(T)``: the
    full models on a layer without inertia, where ``G*(q V; T) = G*_ref(q V a_T)`` makes the
    whole contact problem (kernel, contact size estimate, period check ``V tau_max``) that of the
    reference material at ``V a_T``. One material for all points lets the full models do the
    layer's speed-independent work once (:meth:`~jaxroll.methods.Full.evaluate_points`)."""
    from .methods import Full

    return isinstance(method, Full) and is_quasistatic(layer)


@eqx.filter_jit
def _map_program(method, material, shift, layer, R, P, T, V, count, directions, *, geometry, reduced,
                 adjoint=True, checked=False):
    """Values, result codes, ``dR/dT``, ``dR/dH``, the derivatives along the material
    ``directions`` and contact radii at the points ``(T, V, P)`` (1D), the first ``count`` by
    :meth:`~jaxroll.methods.AbstractMethod.evaluate_points` in the given order (the full models:
    one ``lax.scan``, each point warm-started from the previous one; the rest is padding, not
    solved). The derivatives are forward
    mode: the tangent ``dT = 1`` at every point gives every ``dR_i/dT_i`` at once (each point
    depends on its own temperature only; the warm starts carry no derivative), ``dH = 1`` every
    ``dR_i/dH``, a material tangent every derivative along it. ``adjoint`` (static; default):
    the full models differentiate each point's value by one transposed contact solve that all
    these tangents share (``evaluate_points(adjoint=True)``), instead of one tangent solve per
    direction; ``False``: one per direction (the same numbers to the solver tolerance).
    ``checked`` (static): the inputs' rules were checked on the host (:func:`map_points`), so the
    program holds no input checks (no host callback: JAX's persistent compilation cache can keep
    it)."""
    from .materials.material import shift_factor
    from .rolling import _validated

    with input_checks(not checked):
        def values(T, H, mat):
            mats, lays, ax = _batched_models(mat, shift, with_cover_thickness(layer, H), T)
            if reduced:  # the reference material at V a_T (see _reduced)
                res = method.evaluate_points(mat, lays, R, P, V * jax.vmap(shift_factor, (None, 0))(shift, T),
                                             geometry, axes=(None, None, None, 0, 0), count=count, adjoint=adjoint,
                                             builder=None if directions else _thickness_builder(method, mat, layer, H,
                                                                                                geometry))
            else:
                res = method.evaluate_points(mats, lays, R, P, V, geometry, axes=(0, ax, None, 0, 0), count=count,
                                             adjoint=adjoint)
            lay_axes = None if ax is None else _batch_axes(lays)
            res = jax.vmap(lambda r, m, l, p, v: _validated(method, m, l, r, R, p, v, geometry),
                           in_axes=(0, 0, lay_axes, 0, 0))(res, mats, lays, P, V)
            return res.value, (res.result, res.contact_radius)

        H = jnp.asarray(cover_thickness(layer), float)
        tangents = [(jnp.ones_like(T), jnp.zeros(())), (jnp.zeros_like(T), jnp.ones(()))]
        if directions:
            zero = jax.tree_util.tree_map(jnp.zeros_like, material)
            tangents = [t + (zero,) for t in tangents] + [(jnp.zeros_like(T), jnp.zeros(()), d) for d in directions]
            primals = (T, H, material)
        else:  # no material direction: the material is a constant, its derivatives are not formed
            primals = (T, H)
            values = functools.partial(values, mat=material)
        stacked = jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *tangents)
        v, dv, (code, a) = jax.vmap(lambda t: jax.jvp(values, primals, t, has_aux=True))(stacked)
        return v[0], code[0], dv[0], dv[1], dv[2:], a[0]
