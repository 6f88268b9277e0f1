"""Methods: the configuration objects of the rolling-resistance models.

A method is an equinox module whose configuration is static and hashable (diffrax's solver
objects are the model): it is the compilation cache key of the front doors
:func:`jaxroll.rolling_resistance` and :func:`jaxroll.rolling_resistance_grid`, so a second call
with new values of the same shapes compiles nothing.

* :class:`Direct`: the direct Fourier-series method of [ZG] sec. 4 (stationary pressure;
  :mod:`jaxroll.engines.direct`), spheres and cylinders. No grid (quadrature or the periodic series).
  :class:`DirectElastic` is the same dissipation with the static elastic pressure solved on the
  full 3D model's grid (spheres).
* :class:`Full`: the full rolling-contact model, 2D (cylinder, :mod:`jaxroll.engines.cylinder`) or 3D
  (sphere, :mod:`jaxroll.engines.sphere3d`), picked by the ``geometry`` argument of the front door.
* :class:`Slices`: the sphere from 2D cylinder slices, algorithms PD, PP, SP of [ZG] sec. 3
  (:mod:`jaxroll.engines.slices`).

The strings ``"direct"``, ``"full"``, ``"PD"``, ``"PP"``, ``"SP"`` are shortcuts for the default
objects. Grids (:class:`jaxroll.grids.AutoGrid`, :class:`jaxroll.grids.FixedGrid`) are explicit:
``method.resolve(material, layer, radius=..., loads=..., speeds=..., geometry=...)`` returns the
method with the :class:`~jaxroll.grids.FixedGrid` that covers the whole envelope, which is what
``jit``/``vmap``/``grad`` need (an :class:`~jaxroll.grids.AutoGrid` cannot be sized from traced
values).
"""

from __future__ import annotations

import abc
import dataclasses
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import contact as _contact
from ._numerics import as_float
from .contact.linear import check_linear_solver
from .engines import cylinder, direct, slices, sphere3d
from .engines.stack import models
from .geometry import as_geometry, check_geometry
from .grids import AutoGrid, FixedGrid, check_memory, counting_size, edge_smoothing_error, loss_dominated_points
from .result import RollingResult

__all__ = ["AbstractMethod", "Direct", "DirectElastic", "Full", "Slices", "as_method", "default_method",
           "METHOD_NAMES", "FIT_EDGE_SMOOTHING", "EDGE_BIAS_ORDER"]

#: The full model of each geometry: a module with ``kernel_builder``, ``solve`` and ``result``.
_FULL_MODELS = {"sphere": sphere3d, "cylinder": cylinder}


class AbstractMethod(eqx.Module):
    """A rolling-resistance method: static configuration, and the model evaluations the front
    doors call inside their compiled programs."""

    geometries = ("sphere", "cylinder")

    #: Largest ``RollingResult.truncation`` (the method's own relative error estimate) of a
    #: valid result; see each method.
    max_truncation = 0.1
    #: Largest ``RollingResult.approximation`` (an approximate method's estimated error against
    #: the full model) of a valid result: 10 %.
    max_approximation = 0.1

    @abc.abstractmethod
    def evaluate(self, material, layer, R, P, V, geometry) -> RollingResult:
        """``R_r`` at one point (checked float64 scalars ``R`` [m], ``P`` [N or N/m], ``V``
        [m/s]) with a resolved grid."""

    def evaluate_grid(self, material, layer, R, loads, speeds, geometry) -> RollingResult:
        """``R_r`` on ``speeds x loads`` (fields ``(n_speeds, n_loads)``); default: every
        point by :meth:`evaluate` (``lax.map`` over speeds, ``vmap`` over loads)."""
        return jax.lax.map(lambda V: jax.vmap(lambda P: self.evaluate(material, layer, R, P, V, geometry))(loads),
                           speeds)

    def evaluate_points(self, material, layer, R, P, V, geometry, *, axes=(0, 0, 0, 0, 0),
                        order=None, count=None, adjoint=False) -> RollingResult:
        """``R_r`` at ``n`` points: each of ``material``, ``layer``, ``R`` [m], ``P`` [N or
        N/m], ``V`` [m/s] is batched along a leading axis of length ``n`` (``axes`` entry 0:
        every array leaf has it; scalar leaves are shared, so ``jr.Layer(H=thicknesses)`` keeps
        its Python-float ``rho = 0``, the quasi-static formulation) or shared by every point
        (``None``). ``order``: a permutation of ``range(n)``, the order the points are solved
        in (methods that warm-start along the batch, :meth:`Full.evaluate_points`); results
        are in the given point order either way. ``count``: solve only the first ``count``
        points of that order (:meth:`Full.evaluate_points`); the default evaluates all.
        ``adjoint``: only ``value`` is differentiated, by one adjoint solve per point shared by
        every tangent direction (:meth:`Full.evaluate_points`; other methods ignore it).
        Default: ``jax.vmap`` of :meth:`evaluate`."""
        del order, count, adjoint
        args = (material, layer, R, P, V)
        _batch_size(args, axes)
        in_axes = tuple(None if ax is None else jax.tree_util.tree_map(lambda x: 0 if np.ndim(x) else None, a)
                        for a, ax in zip(args, axes))
        return jax.vmap(lambda m, l, r, p, v: self.evaluate(m, l, r, p, v, geometry), in_axes=in_axes)(*args)

    def resolve(self, material, layer=None, *, radius, loads, speeds, geometry="sphere") -> "AbstractMethod":
        """This method with every :class:`~jaxroll.grids.AutoGrid` replaced by the
        :class:`~jaxroll.grids.FixedGrid` covering all ``loads`` [N or N/m] and ``speeds``
        [m/s] (concrete values): the method to pass under ``jit``/``vmap``/``grad``. A
        :class:`jaxroll.Stack` is given alone, ``method.resolve(stack, radius=..., ...)``."""
        material, layer = models(material, layer)
        self.check_geometry(geometry)
        return self

    def needs_resolution(self, geometry) -> bool:
        """Whether an :class:`~jaxroll.grids.AutoGrid` must be sized from concrete inputs."""
        return False

    def check_memory(self, geometry) -> None:
        """``ValueError`` before anything is allocated when the (resolved) grid needs more
        working memory than :func:`jaxroll.grids.memory_budget` allows."""
        if self.uses_grid(geometry) and isinstance(self.grid, FixedGrid):
            check_memory(self.grid, self.grid_ndim(geometry), type(self).__name__)

    def uses_grid(self, geometry) -> bool:
        """Whether an evaluation at ``geometry`` runs on ``self.grid``."""
        return False

    def grid_ndim(self, geometry) -> int:
        """Dimension of the grid an evaluation at ``geometry`` uses (2: the 3D sphere kernel)."""
        return 1

    def check_geometry(self, geometry) -> None:
        check_geometry(geometry)
        if geometry not in self.geometries:
            raise ValueError(f"{type(self).__name__} computes geometry {self.geometries}; got {geometry!r}")

    def dynamic(self) -> "AbstractMethod":
        """The method with the lengths of its grids as float64 arrays, so that the compiled
        program takes them as values (a new cell size or period does not recompile)."""
        return jax.tree_util.tree_map(lambda v: as_float(v) if isinstance(v, float) else v, self)


def _check_grid(grid, name):
    if not isinstance(grid, (AutoGrid, FixedGrid)):
        raise ValueError(f"{name}.grid must be a jr.AutoGrid or a jr.FixedGrid; got {grid!r}")


def _check_choice(name, value, choices):
    if value not in choices:
        raise ValueError(f"{name} must be one of {choices}; got {value!r}")


class Direct(AbstractMethod):
    """The direct Fourier-series method of [ZG] sec. 4: a stationary pressure (Hertz/Jaffar on
    thick layers, or the thin-layer shapes) dissipating in
    the rolling compliance ([ZG] eqs. 26, 29, 37, 42, 47). Cheap (milliseconds per point) but the
    stationary-pressure assumption is low by ~20 % near and above the R_r peak (see the
    accuracy table of docs/methods.md sec. 3): for screening. Each result carries
    ``approximation``, the estimated error against the full model
    (:func:`jaxroll.engines.direct.approximation_error`: contact size, stationary pressure,
    inertia); above :attr:`max_approximation` (10 %) it is flagged ``RESULTS.approximation_error``.

    Args:
        pressure: ``"auto"`` (thick model where Jaffar's law has a solution, else thin),
            ``"thick"``, ``"thin"`` or ``"thin-compressible"``. The static elastic pressure
            solved on a grid is its own method, :class:`DirectElastic`.
        modulus: modulus of the contact radius: ``"static"`` (``G'(0)``, reproduces the paper's
            radii), ``"glassy"``, ``"dynamic"`` (``G'`` at ``V / r_static``) or a value [Pa].
        rtol: target relative accuracy of the aperiodic quadrature.
        period: ``None`` (default): the aperiodic limit, a single roller on an infinite layer.
            A period [m] (scalar, or ``(Lx, Ly)`` for spheres) selects [ZG]'s periodic series of
            ``n_terms`` terms per direction.
        n_terms: terms per direction of the periodic series.
    """

    pressure: str = eqx.field(static=True, default="auto")
    modulus: str | float = eqx.field(static=True, default="static")
    rtol: float = eqx.field(static=True, default=1e-4)
    period: float | tuple | None = eqx.field(static=True, default=None)
    n_terms: int | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        if self.pressure == "elastic":
            raise ValueError("the direct method with the static elastic pressure solved on a grid is "
                             "jr.DirectElastic(grid=...)")
        _check_choice("Direct.pressure", self.pressure, ("auto", "thick", "thin", "thin-compressible"))
        if not (isinstance(self.rtol, float) and 0 < self.rtol < 1):
            raise ValueError(f"Direct.rtol must be a number in (0, 1); got {self.rtol!r}")
        if (self.period is None) != (self.n_terms is None):
            raise ValueError("Direct: the periodic series needs both period and n_terms (or neither, for the "
                             "aperiodic limit)")

    def evaluate(self, material, layer, R, P, V, geometry):
        return direct.direct_rolling_resistance(material, layer, radius=R, load=P, speed=V, geometry=geometry,
                                                pressure=self.pressure, period=self.period, n_terms=self.n_terms,
                                                rtol=self.rtol, modulus=self.modulus)


class _GridMethod(AbstractMethod):
    """A method whose every evaluation runs on a grid (``self.grid``)."""

    def needs_resolution(self, geometry):
        return isinstance(self.grid, AutoGrid)

    def uses_grid(self, geometry):
        return True

    def on_grid(self, grid, resolved=()) -> "_GridMethod":
        """This method on ``grid`` (e.g. the union of several resolved grids), with the static
        options that ``resolved`` (this method resolved for parts of the envelope) chose."""
        return eqx.tree_at(lambda m: m.grid, self, grid)

    def for_points(self, material, layer, radius, loads, speeds, geometry="sphere") -> "_GridMethod":
        """This method with the static options it would resolve for the points ``(loads[i],
        speeds[i])`` (concrete), for callers that size grids themselves (a map's buckets): none
        here (see :meth:`Full.for_points`)."""
        return self


class DirectElastic(_GridMethod):
    """The direct method of [ZG] sec. 4 with the exact static elastic contact pressure: the
    pressure of the rigid sphere pressed on the layer at rest is solved on ``grid`` by the 3D
    contact solver (valid for any thickness, [ZG] footnote 4's open case) and dissipates in the
    rolling compliance through the periodic [ZG] eq. 26 on the grid's period. Spheres only.

    Args:
        grid: :class:`~jaxroll.grids.AutoGrid` (default: periodic, ``period="auto"``) or a
            periodic :class:`~jaxroll.grids.FixedGrid`.
    """

    geometries = ("sphere",)
    grid: AutoGrid | FixedGrid = AutoGrid(period="auto")

    def __check_init__(self):
        _check_grid(self.grid, "DirectElastic")

    def grid_ndim(self, geometry):
        return 2

    def resolve(self, material, layer=None, *, radius, loads, speeds, geometry="sphere"):
        material, layer = models(material, layer)  # a jr.Stack alone: (its top material, the stack)
        self.check_geometry(geometry)
        if not self.needs_resolution(geometry):
            return self
        return eqx.tree_at(lambda m: m.grid, self, self.grid.sphere(material, layer, radius, loads, speeds,
                                                                    model="static"))

    def evaluate(self, material, layer, R, P, V, geometry):
        return sphere3d.direct_elastic_rolling_resistance(material, layer, R, P, V, self.grid)


class Full(_GridMethod):
    """The full rolling-contact model: the pressure and contact set are solved (primal-dual active
    set, FFT-applied compliance, implicit gradients). ``geometry="cylinder"``: the 2D plane-strain
    model (Qiu type); ``geometry="sphere"``: the 3D model, the reference of [ZG] sec. 2.

    Args:
        grid: :class:`~jaxroll.grids.AutoGrid` (default; sized from the inputs) or
            :class:`~jaxroll.grids.FixedGrid`.
        edge_smoothing: ``None`` (exact discrete contact) or ``kappa > 0``: the smoothed contact
            edge (log-sum-exp complementarity with the gap scale ``kappa a^{3/2} r^{1/2}/R``),
            which makes ``R_r`` smooth in every parameter for least-squares fits, at a bias that
            vanishes with the cell size; the fits' default (``default_method(geometry,
            fit=True)``) uses it with ``edge_extrapolation``, which removes most of that bias
            (docs/validation.md, edge-smoothing table).
        edge_extrapolation: with ``edge_smoothing``: Richardson extrapolation of the smoothed
            edge to ``kappa -> 0`` (solutions at ``kappa`` and ``2 kappa`` combined with the
            measured bias order :data:`EDGE_BIAS_ORDER`): still smooth, the bias mostly removed,
            about twice the smoothing's cost (the ``2 kappa`` solve converged to
            :data:`jaxroll.contact.smoothing.PARTNER_TOL_FACTOR` times ``tol``, at most
            :data:`jaxroll.contact.smoothing.PARTNER_TOL_MAX`).
        tol: contact solver tolerance on the scaled residual.
        max_steps: active-set (and smoothing Newton) iteration limit. Where the compliance is
            local (thin layers) an active-set step moves a contact edge by about one cell, so a
            start far from the contact takes about as many steps as cells lie between them: the
            cylinder at 400 cells per half-width on a layer of a/H = 2 (f = 10, zeta = 3e-3)
            took 144 (the default grids go up to 400); explicit grids finer than that need
            more (800 cells, f = 12, a/H = 2.8, zeta = 8e-3: 345 steps).
        linear_solver: the linear solver of the contact-set systems
            (:class:`jaxroll.contact.GMRES`, default, or :class:`jaxroll.contact.Dense`).
        continuation: sphere only: where the contact's active-set search gives up (a
            loss-dominated contact: the set fragments, or 16 steps pass), start it again from the
            smoothed edge's continuation (``continuation`` of :func:`jaxroll.contact.solve_contact`:
            the same solution, SLS f = 1000 at 32 cells per radius in 1.1 s instead of 86-91 s,
            for about 3 s more compilation). ``None`` (default): on where an
            :class:`~jaxroll.grids.AutoGrid` is sized for an envelope with a loss-dominated point
            (:func:`jaxroll.grids.loss_dominated_points`; also a map's per-class grids and the
            CLI's sweep), off otherwise (a :class:`~jaxroll.grids.FixedGrid`).
    """

    #: Largest estimated relative error of a valid result: ``truncation`` bounds the error of
    #: the reported dissipation form (:func:`jaxroll.grids.full_model_error`); on the default grid
    #: it is <= 1.3 % from zeta = 0.01 up (twice the measured error envelope) and <= 3.2 % below
    #: (3D), so the threshold flags coarse explicit grids, not the default.
    max_truncation = 0.05

    grid: AutoGrid | FixedGrid = AutoGrid()
    edge_smoothing: float | None = eqx.field(static=True, default=None)
    edge_extrapolation: bool = eqx.field(static=True, default=False)
    tol: float = eqx.field(static=True, default=1e-10)
    max_steps: int = eqx.field(static=True, default=200)
    linear_solver: _contact.AbstractLinearSolver = _contact.GMRES()
    continuation: bool | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        _check_grid(self.grid, "Full")
        if self.continuation not in (None, False, True):
            raise ValueError(f"Full.continuation must be None, True or False; got {self.continuation!r}")
        if self.edge_smoothing is not None and not (isinstance(self.edge_smoothing, (int, float))
                                                    and self.edge_smoothing > 0):
            raise ValueError(f"Full.edge_smoothing must be None or a positive number; got {self.edge_smoothing!r}")
        if self.edge_extrapolation not in (False, True) or (self.edge_extrapolation and self.edge_smoothing is None):
            raise ValueError(f"Full.edge_extrapolation must be True or False, and True needs edge_smoothing; got "
                             f"{self.edge_extrapolation!r} with edge_smoothing={self.edge_smoothing!r}")
        if not (isinstance(self.tol, float) and 0 < self.tol < 1):
            raise ValueError(f"Full.tol must be a number in (0, 1); got {self.tol!r}")
        if isinstance(self.max_steps, bool) or not isinstance(self.max_steps, (int, np.integer)) or self.max_steps < 1:
            raise ValueError(f"Full.max_steps must be a positive integer; got {self.max_steps!r}")
        check_linear_solver(self.linear_solver, (_contact.GMRES, _contact.Dense), "Full.linear_solver")

    def grid_ndim(self, geometry):
        return as_geometry(geometry).surface_dims

    def resolve(self, material, layer=None, *, radius, loads, speeds, geometry="sphere"):
        material, layer = models(material, layer)  # a jr.Stack alone: (its top material, the stack)
        self.check_geometry(geometry)
        if not self.needs_resolution(geometry):
            return self
        rule = self.grid.sphere if geometry == "sphere" else self.grid.line
        out = eqx.tree_at(lambda m: m.grid, self, rule(material, layer, radius, loads, speeds, model="full"))
        P, V = (x.ravel() for x in np.meshgrid(np.ravel(loads), np.ravel(speeds), indexing="ij"))
        return out.for_points(material, layer, radius, P, V, geometry)

    def for_points(self, material, layer, radius, loads, speeds, geometry="sphere"):
        """With ``continuation`` ``None`` on a sphere: ``True`` where any point ``(loads[i],
        speeds[i])`` (concrete) is loss-dominated (:func:`jaxroll.grids.loss_dominated_points`),
        else ``False``; otherwise unchanged."""
        if geometry != "sphere" or self.continuation is not None:
            return self
        material, layer = models(material, layer)
        lossy = loss_dominated_points(material, layer, radius, loads, speeds, geometry)
        return dataclasses.replace(self, continuation=bool(np.any(lossy)))

    def on_grid(self, grid, resolved=()):
        out = super().on_grid(grid, resolved)
        if self.continuation is not None or not resolved:
            return out
        return dataclasses.replace(out, continuation=any(bool(r.continuation) for r in resolved))

    def _solve(self, model, kernel, R, P, size, init=None):
        extra = {"continuation": bool(self.continuation)} if _engine_name(model) == "sphere3d" else {}
        return model.solve(kernel, self.grid, R, P, size, tol=self.tol, max_steps=self.max_steps,
                           edge_smoothing=self.edge_smoothing, init=init, linear_solver=self.linear_solver,
                           edge_order=EDGE_BIAS_ORDER[_engine_name(model)] if self.edge_extrapolation
                           else None, **extra)

    def _result(self, model, s, layer, V, material):
        """The :class:`RollingResult` of solution ``s``; with ``edge_extrapolation`` its
        ``truncation`` raised by the bound on the bias left after the extrapolation
        (:func:`jaxroll.grids.edge_smoothing_error`). The plain smoothed edge's larger bias
        (1-4 % at kappa = 0.25-0.5, docs/validation.md sec. 3) is documented, not added: its
        users (gradients, screening fits) take it knowingly."""
        out = model.result(s, self.grid, layer, V, material)
        if not self.edge_extrapolation:
            return out
        bias = edge_smoothing_error(self.edge_smoothing, True, _engine_name(model))
        return eqx.tree_at(lambda r: r.truncation, out, out.truncation + bias)

    def evaluate(self, material, layer, R, P, V, geometry):
        """``R_r`` [N, or N/m] from the full model of ``geometry``: the contact solved on the grid's
        window with the model's kernel (:mod:`jaxroll.engines.sphere3d` / :mod:`jaxroll.engines.cylinder`),
        ``R_r = (1/R) sum p x dA`` of the solved pressure.

        Under ``jax.vmap`` the batch is solved by :meth:`evaluate_points` (:func:`_sequential_under_vmap`):
        the points one after the other in the order of their counting sizes, each warm-started
        from the previous one, instead of lockstep lanes whose while loops all run to the slowest
        lane's count from a cold start. The numbers are each point's to the solver tolerance; the
        derivatives are those of the point (forward and reverse mode)."""
        return _sequential_under_vmap(self, (material, layer, R, P, V), geometry)

    def _evaluate_one(self, material, layer, R, P, V, geometry):
        """:meth:`evaluate` at one point (the body that ``jax.vmap`` does not see)."""
        model = _FULL_MODELS[geometry]
        size = counting_size(material, layer, R, P, V, geometry)
        s = self._solve(model, model.kernel_builder(material, layer, self.grid)(V), R, P, size)
        return self._result(model, s, layer, V, material)

    def evaluate_grid(self, material, layer, R, loads, speeds, geometry):
        """The table ``speeds x loads``: the speed-independent layer work once, the kernel once per
        speed (a ``lax.scan`` over speeds: memory bounded), the loads of a speed in a ``lax.scan``
        in the given order (give loads sorted). Each solve starts from its neighbour
        (:meth:`jaxroll.contact.WarmStart.extrapolated`): the previous load's solution, extrapolated
        from the load before (2D windows; 1D: :meth:`~jaxroll.contact.WarmStart.stretched`) and
        stretched by the ratio of the counting sizes (:func:`jaxroll.grids.counting_size`), or for
        a speed's first load the previous speed's first solution. Each point equals
        :meth:`evaluate` to the solver tolerance."""
        model = _FULL_MODELS[geometry]
        build = model.kernel_builder(material, layer, self.grid)
        # the load ratio from each load to the next (the last pair is not used)
        ratio = jnp.append(loads[1:] / loads[:-1], 1.0)
        shape = (self.grid.window,) * self.grid_ndim(geometry)

        first_load = jnp.arange(loads.shape[0]) == 0
        extrapolate = self.grid_ndim(geometry) == 2  # it pays on 2D windows; in 1D it took more steps

        def one_speed(first_start, V):
            kernel = build(V)
            sizes = jax.vmap(lambda P: counting_size(material, layer, R, P, V, geometry))(loads)
            stretch = jnp.append(sizes[1:] / sizes[:-1], 1.0)  # from each load's size to the next

            def step(carry, args):
                start, first = carry
                P, size, s_next, r_next, is_first = args
                s = self._solve(model, kernel, R, P, size, init=start)
                first = jax.tree_util.tree_map(lambda a, b: jnp.where(is_first, a, b),
                                               _contact.WarmStart.of(s.contact), first)
                nxt = (_contact.WarmStart.extrapolated(start, s.contact, s_next, r_next, ~is_first) if extrapolate
                       else _contact.WarmStart.stretched(s.contact, s_next, r_next))
                return ((nxt, first),
                        self._result(model, s, layer, V, material))

            step = jax.checkpoint(step, prevent_cse=False, policy=_contact.SAVED_FOR_DERIVATIVES)
            (_, first), out = jax.lax.scan(step, (first_start, first_start),
                                           (loads, sizes, stretch, ratio, first_load))
            return first, out

        return jax.lax.scan(one_speed, _contact.WarmStart.none(shape), speeds)[1]

    def evaluate_points(self, material, layer, R, P, V, geometry, *, axes=(0, 0, 0, 0, 0), order=None, count=None,
                        adjoint=False, builder=None, starts=None):
        """``R_r`` at ``n`` points (arguments batched or shared as in
        :meth:`AbstractMethod.evaluate_points`), solved one after the other in a ``lax.scan``
        along ``order`` (default: as given; ``count``, a traced integer: only the first
        ``count`` points of that order are solved, the others, padding that lets batches of
        different lengths share one compiled program, come back zero): each solve starts from the previous point's
        solution (:meth:`jaxroll.contact.WarmStart.stretched` by the ratio of the counting
        sizes, :func:`jaxroll.grids.counting_size`, and of the loads), so give an order in which neighbours are alike (e.g.
        sorted by speed, or by reduced speed ``V a_T`` over temperatures). Unlike ``jax.vmap``
        of :meth:`evaluate`, whose while loops run every lane to the slowest lane's count from a
        cold start, each point costs about a point of :meth:`evaluate_grid`'s table, plus its own
        kernel (and the layer's integrals when the layer is batched). Each
        point equals :meth:`evaluate` to the solver tolerance; derivatives are implicit per
        point (the start is data only). ``adjoint=True``: the derivatives of ``value`` alone (the
        other fields carry none), each point's by one reverse-mode pass (one transposed contact
        solve, :func:`_value_by_adjoint`) that every tangent direction shares: forward-mode
        derivatives along ``k`` directions (``jax.vmap`` of ``jax.jvp``) then cost one solve per
        point instead of ``k``. ``builder``: the ``V -> kernel`` of the shared material and layer
        (``model.kernel_builder``), if the caller formed it (:func:`jaxroll.maps._map_program`).

        ``starts``: ``None``, or each point's own start ``(warm, sizes)`` (batched along the points
        as given: a :class:`jaxroll.contact.WarmStart` and the counting sizes it was solved at),
        e.g. the ``finals`` of a previous call at nearby parameters on the same grid (a fit's
        previous evaluation). A valid start, stretched by the ratio of the counting sizes,
        replaces the previous point's; a smoothed-edge solution (``edge_smoothing``) starts the
        smoothed edge's Newton iteration itself (no exact solve). Then the return is
        ``(results, finals)``, ``finals`` each point's own solution as such a start."""
        model = _FULL_MODELS[geometry]
        args = (material, layer, R, P, V)
        n = _batch_size(args, axes)
        if order is not None:
            order = jnp.asarray(order)
            args = _take(args, axes, order)
            starts = None if starts is None else jax.tree_util.tree_map(lambda x: x[order], starts)
        at = functools.partial(_take, args, axes)  # the point at an index

        def size_and_load(i):
            m, l, r, p, v = at(i)
            return counting_size(m, l, r, p, v, geometry), jnp.asarray(p, float)

        sizes, loads = jax.vmap(size_and_load)(jnp.arange(n))
        # the stretch and load ratio from each point to the next (the last pair is not used)
        stretch = jnp.append(sizes[1:] / sizes[:-1], 1.0)
        ratio = jnp.append(loads[1:] / loads[:-1], 1.0)

        # material and layer shared: their speed-independent work once (as in evaluate_grid)
        shared = builder
        if shared is None and axes[0] is None and axes[1] is None:
            shared = model.kernel_builder(material, layer, self.grid)

        def point(start, m, l, r, p, v, size):
            kernel = (shared or model.kernel_builder(m, l, self.grid))(v)
            s = self._solve(model, kernel, r, p, size, init=start)
            return self._result(model, s, l, v, m), s.contact

        smoothed = self.edge_smoothing is not None

        def solve(start, xs):
            i, s_next, r_next = xs
            if starts is not None:  # the point's own start, where it has one
                own = jax.tree_util.tree_map(lambda x: x[i], starts[0]).stretch(sizes[i] / starts[1][i], 1.0)
                start = jax.tree_util.tree_map(lambda a, b: jnp.where(own.valid, a, b), own, start)
            args = (start, *at(i), sizes[i])
            res, contact = _value_by_adjoint(point, args) if adjoint else point(*args)
            nxt = _contact.WarmStart.stretched(contact, s_next, r_next)
            return nxt, res if starts is None else (res, _contact.WarmStart.of(contact, smoothed))

        def step(start, xs):
            if count is None:
                return solve(start, xs)
            zeros = jax.tree_util.tree_map(lambda x: jnp.zeros(x.shape, x.dtype), jax.eval_shape(solve, start, xs)[1])
            return jax.lax.cond(xs[0] < count, solve, lambda s, _: (s, zeros), start, xs)

        shape = (self.grid.window,) * self.grid_ndim(geometry)
        out = jax.lax.scan(step, _contact.WarmStart.none(shape), (jnp.arange(n), stretch, ratio))[1]
        if starts is not None:
            out = (out[0], (out[1], sizes))
        if order is not None:
            inverse = jnp.zeros(n, order.dtype).at[order].set(jnp.arange(n, dtype=order.dtype))
            out = jax.tree_util.tree_map(lambda x: x[inverse], out)
        return out


def _value_by_adjoint(point, args):
    """``point(*args)`` (a :class:`RollingResult` and data) whose only derivative is that of the
    result's ``value``, by reverse mode: ``jax.vjp`` of ``value`` w.r.t. every floating-point
    input that carries a tangent (the arguments and the arrays ``point`` closes over, e.g. a
    shared kernel factor; inputs whose tangent is a symbolic zero, such as quadrature tables, form
    no cotangent: each point's contact solve differentiated by one transposed solve), contracted
    with the incoming tangents. Under ``jax.vmap`` of ``jax.jvp`` the pass depends on the
    primals only, so it runs once for all the tangent directions. The other outputs carry zero
    derivatives."""
    dyn, static = eqx.partition(args, eqx.is_array)  # Python scalars (a layer's rho = 0) stay static
    # every value the point reads, its arguments and what it closes over, as explicit inputs
    closed, shapes = jax.make_jaxpr(lambda d: point(*eqx.combine(d, static)), return_shape=True)(dyn)
    consts = list(closed.consts)

    def converted(d, *c):
        out = jax.core.eval_jaxpr(closed.jaxpr, c, *jax.tree_util.tree_leaves(d))
        return jax.tree_util.tree_unflatten(jax.tree_util.tree_structure(shapes), out)

    @jax.custom_jvp
    def run(consts, dyn):
        return converted(dyn, *consts)

    def run_jvp(primals, tangents):
        leaves, treedef = jax.tree_util.tree_flatten(primals)
        tangent = treedef.flatten_up_to(tangents)
        # only the inputs with a tangent: constants (quadrature weights, index tables) cost nothing
        active = [i for i, (x, t) in enumerate(zip(leaves, tangent))
                  if eqx.is_inexact_array(x) and not isinstance(t, jax.custom_derivatives.SymbolicZero)]

        def value(xs):
            swapped = dict(zip(active, xs))
            c, d = jax.tree_util.tree_unflatten(treedef, [swapped.get(i, x) for i, x in enumerate(leaves)])
            out = converted(d, *c)
            return out[0].value, out

        _, vjp, out = jax.vjp(value, [leaves[i] for i in active], has_aux=True)
        (grads,) = vjp(jnp.ones_like(out[0].value))
        dots = [jnp.real(jnp.sum(g * tangent[i])) for g, i in zip(grads, active)]
        zeros = jax.tree_util.tree_map(
            lambda x: jnp.zeros_like(x) if eqx.is_inexact_array(x) else np.zeros(np.shape(x), jax.dtypes.float0), out)
        return out, eqx.tree_at(lambda z: z[0].value, zeros, functools.reduce(jnp.add, dots, jnp.zeros(())))

    run.defjvp(run_jvp, symbolic_zeros=True)
    return run(consts, dyn)


def _sequential_under_vmap(method, args, geometry):
    """``method._evaluate_one(*args, geometry)`` with a batching rule: under ``jax.vmap`` the
    points go to :meth:`Full.evaluate_points` (a warm-started ``lax.scan``, in the order of the
    counting sizes, :func:`jaxroll.grids.counting_size`, so that neighbours are alike), unless the
    method's own arrays (the grid's cell size) are batched (then plain ``jax.vmap``). Derivatives
    (``jax.jvp``, hence ``jax.grad`` and ``jax.jacfwd``) are those of the single point: a
    ``custom_jvp`` whose rule differentiates the unbatched body (``custom_vmap`` alone has no
    reverse mode). Only the array leaves are arguments; Python scalars (a layer's ``rho = 0``,
    which selects the quasi-static formulation) stay static."""
    dyn, static = eqx.partition((method, *args), eqx.is_array)

    def plain(dyn):
        m, *a = eqx.combine(dyn, static)
        return m._evaluate_one(*a, geometry)

    def rule(axis_size, in_batched, dyn):
        (batched,) = in_batched
        if any(jax.tree_util.tree_leaves(batched[0])):  # a batched grid: lockstep lanes
            axes = jax.tree_util.tree_map(lambda b: 0 if b else None, batched)
            out = jax.vmap(plain, in_axes=(axes,))(dyn)
            return out, jax.tree_util.tree_map(lambda _: True, out)
        # an argument with a batched leaf is batched whole: its other array leaves are broadcast
        grown = jax.tree_util.tree_map(lambda x, b: x if b else jnp.broadcast_to(x, (axis_size,) + x.shape), dyn,
                                       batched)
        axes = tuple(0 if any(jax.tree_util.tree_leaves(b)) else None for b in batched[1:])
        m, *given = eqx.combine(dyn, static)
        a = tuple(g if ax == 0 else x for g, x, ax in zip(eqx.combine(grown, static)[1:], given, axes))
        sizes = jax.vmap(lambda i: counting_size(*_take(a, axes, i), geometry))(jnp.arange(axis_size))
        out = m.evaluate_points(*a, geometry, axes=axes, order=jnp.argsort(sizes))
        return out, jax.tree_util.tree_map(lambda _: True, out)

    batched_plain = jax.custom_batching.custom_vmap(plain)
    batched_plain.def_vmap(rule)
    f = jax.custom_jvp(batched_plain)
    f.defjvp(lambda primals, tangents: jax.jvp(plain, primals, tangents))
    return f(dyn)


def _take(args, axes, index):
    """``args`` at ``index`` along the leading axis of the batched arguments' array leaves;
    scalar leaves (e.g. a layer's Python-float ``rho = 0``, which keeps the quasi-static
    formulation) are shared."""
    pick = lambda x: x[index] if np.ndim(x) else x  # noqa: E731
    return tuple(a if ax is None else jax.tree_util.tree_map(pick, a) for a, ax in zip(args, axes))


def _batch_size(args, axes) -> int:
    """The common leading length of the batched arguments' array leaves (``axes`` entry 0)."""
    if len(axes) != len(args) or any(ax not in (0, None) for ax in axes):
        raise ValueError(f"axes must give 0 (batched) or None (shared) for each of material, layer, R, P, V; "
                         f"got {axes!r}")
    sizes = {np.shape(x)[0] for a, ax in zip(args, axes) if ax == 0 for x in jax.tree_util.tree_leaves(a)
             if np.ndim(x)}
    if len(sizes) != 1:
        raise ValueError(f"the batched arguments need one common leading length; got {sorted(sizes)}")
    return sizes.pop()


class Slices(_GridMethod):
    """A rigid sphere from 2D cylinder slices ([ZG] sec. 3): ``"PD"`` (penetration consistency,
    eq. 9), ``"PP"`` (load equilibrium, eq. 10) or ``"SP"`` (both, eq. 11, the most accurate on
    thin and intermediate layers). Each result carries ``approximation``, the estimated error
    against the full 3D model (:func:`jaxroll.engines.slices.approximation_error`: plane strain
    at high speed on thick layers, PD's load defect); above :attr:`max_approximation` (10 %) it
    is flagged ``RESULTS.approximation_error``.

    Args:
        algorithm: ``"PD"``, ``"PP"`` or ``"SP"``.
        n_slices: odd number of slices across the contact (paper: 21).
        grid: the 1D grid shared by the slices (sized for the middle slice).
        tol, max_steps: contact tolerance (GMRES only) and active-set iteration limit.
        root_tol, root_max_steps: tolerance on ``log d_o`` and iteration limit of the root finds.
        linear_solver: :class:`jaxroll.engines.slices.Interval` (Levinson tables, fastest),
            :class:`jaxroll.contact.Dense` or :class:`jaxroll.contact.GMRES`.
    """

    geometries = ("sphere",)
    algorithm: str = eqx.field(static=True, default="SP")
    n_slices: int = eqx.field(static=True, default=21)
    grid: AutoGrid | FixedGrid = AutoGrid()
    tol: float = eqx.field(static=True, default=1e-10)
    max_steps: int = eqx.field(static=True, default=60)
    root_tol: float = eqx.field(static=True, default=1e-10)
    root_max_steps: int = eqx.field(static=True, default=40)
    linear_solver: eqx.Module = slices.Interval()

    def __check_init__(self):
        slices.check_options(self.algorithm, self.n_slices, self.linear_solver)
        _check_grid(self.grid, "Slices")

    def resolve(self, material, layer=None, *, radius, loads, speeds, geometry="sphere"):
        material, layer = models(material, layer)  # a jr.Stack alone: (its top material, the stack)
        self.check_geometry(geometry)
        if not self.needs_resolution(geometry):
            return self
        loads = np.atleast_1d(np.asarray(loads, dtype=float))
        middle = np.asarray(jax.vmap(lambda P: slices.middle_slice_load(material, layer, radius, P))(
            jnp.asarray(loads)))
        return eqx.tree_at(lambda m: m.grid, self, self.grid.line(material, layer, radius, middle, speeds))

    def _options(self):
        return dict(algorithm=self.algorithm, n_slices=self.n_slices, tol=self.tol, max_steps=self.max_steps,
                    root_tol=self.root_tol, root_max_steps=self.root_max_steps, linear_solver=self.linear_solver)

    def evaluate(self, material, layer, R, P, V, geometry):
        return slices.rolling_resistance(material, layer, R, P, V, self.grid, **self._options())

    def evaluate_grid(self, material, layer, R, loads, speeds, geometry):
        return slices.rolling_resistance_grid(material, layer, R, loads, speeds, self.grid, **self._options())


METHOD_NAMES = ("direct", "full", "PD", "PP", "SP")

def _engine_name(model) -> str:
    """``"sphere3d"`` or ``"cylinder"``: the key of a full-model engine module in the measured
    tables :data:`EDGE_BIAS_ORDER` and :data:`jaxroll.grids.EDGE_EXTRAPOLATED_BIAS`."""
    return model.__name__.rsplit(".", 1)[-1]


#: ``Full.edge_smoothing`` of the default fitting method (with ``edge_extrapolation``: the
#: smoothed solutions at kappa = 0.125 and 0.25 extrapolated to kappa -> 0).
FIT_EDGE_SMOOTHING = 0.125

#: Order ``q`` of the smoothed edge's bias ``~ kappa^q`` by model (engine module name), used by
#: ``Full(edge_extrapolation=True)``: measured on the default grid from the bias of R_r against
#: the exact discrete contact at kappa = 0.125, 0.25, 0.5 (benchmarks/edge_smoothing_bias.py),
#: the exponent that best cancels it over zeta = 0.01..100 between kappa = 0.125 and 0.25.
EDGE_BIAS_ORDER = {"sphere3d": 1.75, "cylinder": 2.0}


def default_method(geometry="sphere", *, fit=False) -> AbstractMethod:
    """The method used wherever none is named (every front door, :func:`jaxroll.resistance_map`,
    :func:`jaxroll.fit_material`, the command line): the full model of ``geometry``, 3D for a
    sphere, 2D plane strain for a cylinder, on an infinite layer (aperiodic) with an
    :class:`~jaxroll.grids.AutoGrid`. ``fit=True``: the same with the smoothed contact edge
    (``edge_smoothing=FIT_EDGE_SMOOTHING``, ``edge_extrapolation=True``), whose R_r is smooth in
    the fitted parameters and within 0.14 % of the exact discrete contact on the same grid
    (measured, benchmarks/edge_smoothing_bias.py).

    The direct method and the slices stay explicit screening choices (docs/methods.md lists
    their measured errors against the full model)."""
    check_geometry(geometry)
    return Full(edge_smoothing=FIT_EDGE_SMOOTHING, edge_extrapolation=True) if fit else Full()


def as_method(method) -> AbstractMethod:
    """A method object from a method or one of the shortcuts ``"direct"``, ``"full"``, ``"PD"``,
    ``"PP"``, ``"SP"``."""
    if isinstance(method, AbstractMethod):
        return method
    if method == "direct":
        return Direct()
    if method == "full":
        return Full()
    if method in slices.ALGORITHMS:
        return Slices(algorithm=method)
    raise ValueError(f"unknown method {method!r}; give jr.Direct(...), jr.Full(...), jr.Slices(...) or one of "
                     f"{METHOD_NAMES}")
