"""Result codes and the result object returned by every method.

:data:`RESULTS` is the one enumeration of outcomes of the library: every solver (contact
active set, linear solves, root finds) and every validity check (window, period, pressure-model
range, error indicators) reports one of its integer codes, and :class:`RollingResult` carries it
as ``result``. ``valid`` is ``result == RESULTS.successful``: a promise that the value is
trustworthy, never a guess.
"""

from __future__ import annotations

import enum

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

__all__ = ["RESULTS", "GridSolution", "RollingResult", "REGIMES", "SolverError", "ValidityWarning", "check_validity", "first_failure",
           "full_model_result", "merge_results", "raise_on_failure", "MAX_CONTACT_RATIO"]

#: Largest contact radius (sphere) or half-width (cylinder) over roller radius of a valid
#: result: every model uses the parabolic profile ``h = r^2/(2R)``, whose error grows like
#: ``(r/R)^2`` (the gap of a sphere at r = 0.3 R is 2.4 % below the parabola's), and the
#: small-strain layer theory assumes ``r << R``.
MAX_CONTACT_RATIO = 0.3

class REGIMES(enum.IntEnum):
    """Integer codes of ``RollingResult.regime``: which pressure model or method produced the value
    (stored as an integer array, so it survives jit/vmap; ``REGIMES(int(res.regime)).label``)."""

    thick = 0  #: Hertz/Jaffar stationary pressure of the direct method ([ZG] sec. 4.3)
    thin = 1  #: thin incompressible layer pressure ([ZG] sec. 4.4)
    thin_compressible = 2  #: thin compressible layer pressure ([ZG] sec. 4.5)
    elastic = 3  #: the static elastic pressure solved on a grid (direct method)
    full = 4  #: a full rolling-contact model (2D, 3D, or the slices built on the 2D one)

    @property
    def label(self) -> str:
        """The name used by ``Direct(pressure=...)``, e.g. ``"thin-compressible"``."""
        return self.name.replace("_", "-")


class ValidityWarning(UserWarning):
    """A result is not successful (see :data:`RESULTS`); issued by eager calls with ``throw=False``."""


class _Results:
    """An enumeration of integer result codes with messages.

    ``RESULTS.successful`` (0), ``RESULTS.max_steps_reached``, ... are Python ints; result arrays
    hold these codes. ``RESULTS.message(code)`` is the explanation of a code, ``RESULTS.names``
    maps codes to names. Where several reasons apply to one value, the solver failures come
    first (they make every later check meaningless), then the checks in the order listed.
    """

    def __init__(self, items):
        object.__setattr__(self, "_names", tuple(name for name, _ in items))
        object.__setattr__(self, "_messages", tuple(msg for _, msg in items))
        for code, name in enumerate(self._names):
            object.__setattr__(self, name, code)

    def __setattr__(self, name, value):
        raise AttributeError("RESULTS is read-only")

    @property
    def names(self) -> dict:
        """``{code: name}``."""
        return dict(enumerate(self._names))

    def message(self, code) -> str:
        """The message of one integer code."""
        code = int(code)
        if not 0 <= code < len(self._messages):
            raise ValueError(f"unknown result code {code}")
        return self._messages[code]

    def messages(self) -> tuple:
        """All messages, indexed by code."""
        return self._messages

    def __len__(self):
        return len(self._names)

    def __iter__(self):
        return iter(range(len(self._names)))

    def __repr__(self):
        return "RESULTS(" + ", ".join(f"{n}={i}" for i, n in enumerate(self._names)) + ")"


RESULTS = _Results([
    ("successful", "successful"),
    ("max_steps_reached", "the contact active-set iteration did not converge within max_steps (raise max_steps)"),
    ("linear_solve_failed", "the linear solve on the contact set did not reach the tolerance (raise tol or the "
                            "resolution)"),
    ("window_too_small", "the contact reaches the edge of the computational window: the contact is wider than the "
                         "grid's window (raise FixedGrid.window, or resolve the method over the whole envelope)"),
    ("nonfinite", "non-finite solution (check the inputs: positive load, finite compliance)"),
    ("root_find_failed", "a root find of the slice algorithm (eq. 7 or 11) did not converge"),
    ("period_too_short", "the period is shorter than 20 max(contact radius, V x longest retardation time): the "
                         "layer does not recover between passes, so the value is that of a train of rollers "
                         "(lengthen the period, or use an infinite layer)"),
    ("outside_pressure_model", "the contact lies outside the range of validity of the stationary pressure model "
                               "(gamma = r_c/H: Jaffar's thick model needs gamma <= 0.9, the thin model gamma >= "
                               "10); use jr.DirectElastic or the full model"),
    ("truncation_too_large", "the method's own error estimate (quadrature or series truncation, or the gap between "
                             "the moment and dissipation forms of R_r) exceeds its threshold (refine the method)"),
    ("contact_too_large", "the contact radius exceeds 0.3 R: not a small-strain contact (the models assume a "
                          "parabolic roller profile)"),
    ("nonpositive", "non-positive rolling resistance: below the method's resolution (refine the grid)"),
    ("outside_measured_range", "the temperature, or the contact's reduced frequency V a_T / a, lies outside what the "
                               "material was measured over: the shift law or the Prony series is extrapolated there "
                               "(measure there, or read the value as a guess)"),
    ("approximation_error", "the approximate method's estimated error against the full model (RollingResult."
                            "approximation) exceeds 10 %: its assumptions (stationary pressure and contact size of "
                            "the direct method, plane-strain slices) fail here; use the full model (method=None or "
                            "jr.Full())"),
])


class SolverError(RuntimeError):
    """A result is not trustworthy (``throw=True``): one line naming the :data:`RESULTS` code
    and its reason.

    Attributes:
        code: the integer :data:`RESULTS` code (the first failing point's, for a table).
        name: its name, e.g. ``"window_too_small"``.
        reason: its message (what went wrong and what to change).
        count: number of failing points; ``total``: number of points.

    Raised on the host by the front doors when their inputs are concrete. Under a user's
    ``jax.jit``/``jax.vmap``/``jax.grad`` the check runs inside the compiled program
    (``equinox.error_if``) and surfaces as JAX's runtime error; its text contains
    :meth:`message` of the code.
    """

    def __init__(self, code, *, count: int = 1, total: int = 1):
        self.code = int(code)
        self.name = RESULTS.names[self.code]
        self.reason = RESULTS.message(self.code)
        self.count, self.total = int(count), int(total)
        where = f" at {self.count} of {self.total} points (the first one's reason)" if self.total > 1 else ""
        super().__init__(f"{self.message(self.code)}{where}")

    @staticmethod
    def message(code) -> str:
        """The one-line text of a failure with :data:`RESULTS` code ``code``."""
        return f"rolling resistance not trustworthy [RESULTS.{RESULTS.names[int(code)]}]: {RESULTS.message(code)}"


def raise_on_failure(result) -> None:
    """Raise :class:`SolverError` if any entry of the concrete :data:`RESULTS` code array
    ``result`` is not ``successful`` (host side: no callback in the compiled program)."""
    codes = np.asarray(result).ravel()
    bad = np.flatnonzero(codes != RESULTS.successful)
    if bad.size:
        raise SolverError(codes[bad[0]], count=bad.size, total=codes.size)


class GridSolution(eqx.Module):
    """What a grid model's contact solve leaves besides ``R_r`` (:attr:`RollingResult.solution`;
    the full 2D/3D models, the slices and :class:`~jaxroll.DirectElastic` fill it).

    Attributes:
        penetration: rigid-body penetration [m] (the slices: of the middle slice).
        pressure: contact pressure on the grid [Pa].
        grid: coordinates of the pressure grid [m]: ``x`` (cylinder) or ``(x, y)`` (sphere).
        iterations: active-set iterations (None where not iterated).
        residual: final solver residual (None where not iterated).
        resistance_dissipation: ``R_r`` from the dissipated power, ``-int p du/dx`` [N or N/m]
            (the full models and slices; the value reported by the full 2D/3D models).
        resistance_moment: ``R_r`` from the pressure moment, ``(1/R) int p x dA`` [N or N/m]
            (the value reported by the slices). The two forms are equal in the continuum.
    """

    penetration: jax.Array
    pressure: jax.Array
    grid: jax.Array | tuple
    iterations: jax.Array | None = None
    residual: jax.Array | None = None
    resistance_dissipation: jax.Array | None = None
    resistance_moment: jax.Array | None = None


class RollingResult(eqx.Module):
    """Rolling resistance and diagnostics.

    Attributes:
        value: rolling resistance R_r, positive, opposing motion [N for a sphere, N/m for a
            cylinder].
        contact_radius: contact radius (sphere) or half-width (cylinder) of the pressure model
            or of the solved contact [m].
        gamma: ``contact_radius / H`` [-] (0 for a half-space).
        regime: integer code of the pressure model / method, see :data:`REGIMES`.
        truncation: estimated relative truncation / discretisation error of ``value`` [-] (0 where
            nothing rolls, ``V = 0`` or an elastic material: the value is round-off of a true 0).
        result: integer :data:`RESULTS` code, ``RESULTS.successful`` (0) when the value is
            trustworthy; otherwise the first reason it is not.
        solution: the grid models' :class:`GridSolution` (pressure, penetration, grid,
            iterations, residual); None for the direct method.
        approximation: the approximate methods' (direct, slices) estimate of their own relative
            error against the full model, ``|R_r/R_r,full - 1|`` [-] (the model error of the
            method's assumptions, apart from ``truncation``, its numerical error); a valid
            result has it at most the method's ``max_approximation`` (0.1). None for the full
            models.
    """

    value: jax.Array
    contact_radius: jax.Array
    gamma: jax.Array
    regime: jax.Array
    truncation: jax.Array
    result: jax.Array
    solution: GridSolution | None = None
    approximation: jax.Array | None = None

    @property
    def valid(self) -> jax.Array:
        """True where ``result == RESULTS.successful``."""
        return self.result == RESULTS.successful

    def reasons(self) -> np.ndarray:
        """The :data:`RESULTS` message of every entry (host NumPy array of strings; eager only)."""
        codes = np.asarray(self.result)
        return np.vectorize(RESULTS.message, otypes=[object])(codes) if codes.ndim else np.asarray(
            RESULTS.message(codes), dtype=object)

    def _table(self, speeds, loads, geometry):
        if geometry not in ("sphere", "cylinder"):
            raise ValueError(f"geometry must be 'sphere' or 'cylinder', got {geometry!r}")
        unit = "N" if geometry == "sphere" else "N/m"
        coords = {"speed": (np.asarray(speeds, float), "m/s"), "load": (np.asarray(loads, float), unit)}
        fields = {"rolling_resistance": (np.asarray(self.value), unit), "valid": (np.asarray(self.valid), "-"),
                  "result": (np.asarray(self.result), "-"), "contact_radius": (np.asarray(self.contact_radius), "m"),
                  "gamma": (np.asarray(self.gamma), "-"), "truncation": (np.asarray(self.truncation), "-")}
        if self.approximation is not None:
            fields["approximation"] = (np.asarray(self.approximation), "-")
        return coords, fields, {"geometry": geometry, "result_names": list(RESULTS.names)}

    def to_xarray(self, speeds, loads, *, geometry="sphere"):
        """The result of :func:`jaxroll.rolling_resistance_grid` as an ``xarray.Dataset`` with
        dimensions ``(speed, load)`` (the grid's axes, which the result does not store: pass the
        same ``speeds`` [m/s] and ``loads`` [N, or N/m for cylinders]); variables
        ``rolling_resistance``, ``valid``, ``result`` (:data:`RESULTS` codes; names in
        ``attrs["result_names"]``), ``contact_radius`` [m], ``gamma``, ``truncation`` (and
        ``approximation`` for the approximate methods), each with ``attrs["units"]``. Needs
        xarray (an optional dependency)."""
        from ._labelled import to_xarray

        return to_xarray(*self._table(speeds, loads, geometry))

    def to_pandas(self, speeds, loads, *, geometry="sphere"):
        """As :meth:`to_xarray`, a ``pandas.DataFrame`` with one row per point (index
        ``(speed, load)``, load fastest) and the units in ``attrs["units"]``. Needs pandas."""
        from ._labelled import to_pandas

        return to_pandas(*self._table(speeds, loads, geometry))


def first_failure(*checks) -> jax.Array:
    """The :data:`RESULTS` code of the first failed check: ``checks`` are ``(failed, code)``
    pairs in priority order (``failed`` a bool array, ``code`` a RESULTS int)."""
    out = jnp.asarray(RESULTS.successful)
    for failed, code in reversed(checks):
        out = jnp.where(failed, code, out)
    return out


def check_validity(res: RollingResult, *, radius, speed, contact_size, dissipative, max_truncation,
                   max_approximation=0.1) -> RollingResult:
    """``res`` with the checks that every method shares applied after its own (``result``
    keeps the first failure):

    * the value is finite (``nonfinite``);
    * the contact is small against the roller, ``contact_size <= MAX_CONTACT_RATIO R``
      (``contact_too_large``), with the stationary estimate of every method alike (relaxed
      modulus: the largest contact; the slices' eq.-2 radius is the geometric chord, not it);
    * the method's own error estimate ``truncation`` is at most ``max_truncation``
      (``truncation_too_large``);
    * the value is positive (``nonpositive``): a rolling roller on a dissipative material has
      ``R_r > 0``. At ``V = 0`` or on an elastic material the true ``R_r`` is 0 and the value
      (round-off of either sign) is not checked for sign or truncation, and ``truncation`` and
      ``approximation`` are reported as 0 there;
    * an approximate method's estimated error against the full model, ``approximation`` (where
      the method gives one), is at most ``max_approximation`` (``approximation_error``; not
      checked where nothing rolls, as above).

    ``radius`` [m], ``speed`` [m/s] and ``contact_size`` [m] broadcast against the fields;
    works under jit/vmap.
    """
    value = res.value
    finite = jnp.isfinite(value)
    # no dissipation (V = 0, or an elastic material): the true R_r is 0, so the computed value
    # is round-off of either sign and its relative error estimate means nothing
    rolling = (jnp.asarray(speed) > 0) & jnp.asarray(dissipative)
    nonpositive = rolling & (value <= 0)
    checks = first_failure(
        (~finite, RESULTS.nonfinite),
        # (before the truncation: a contact far larger than the model allows, e.g. a modulus in
        # MPa given as Pa, also defeats the grid, and its size is the reason to report)
        (contact_size > MAX_CONTACT_RATIO * jnp.asarray(radius), RESULTS.contact_too_large),
        (rolling & ~(res.truncation <= max_truncation), RESULTS.truncation_too_large),
        (nonpositive, RESULTS.nonpositive),
        (rolling & ~(_approximation(res) <= max_approximation), RESULTS.approximation_error),
    )
    res = eqx.tree_at(lambda r: r.result, res, merge_results(res.result, checks))
    # where nothing rolls the relative estimates mean nothing (they read 1e285 or inf on a value
    # of round-off): reported as 0, the value's error being round-off of a true 0
    for field in ("truncation", "approximation"):
        est = getattr(res, field)
        if est is not None and jnp.broadcast_shapes(jnp.shape(rolling), jnp.shape(est)) == jnp.shape(est):
            res = eqx.tree_at(lambda r, f=field: getattr(r, f), res, jnp.where(rolling, est, jnp.zeros_like(est)))
    return res


def _approximation(res):
    return jnp.zeros_like(res.value) if res.approximation is None else res.approximation


def merge_results(first, second) -> jax.Array:
    """``first`` where it is a failure, else ``second`` (both RESULTS code arrays)."""
    return jnp.where(first != RESULTS.successful, first, second)


def full_model_result(resistance, resistance_dissipation, contact_radius, H, *, result, penetration, pressure, grid,
                      iterations, residual, error=None, value=None) -> RollingResult:
    """The :class:`RollingResult` of a full contact model (2D cylinder, 3D sphere, slices),
    ``regime = 4``. With ``error`` (the full 2D/3D models: the estimate of
    :func:`jaxroll.grids.full_model_error`) and ``value`` (of :func:`jaxroll.grids.full_model_value`:
    the dissipation form of R_r, which converges faster and more regularly than the moment form,
    blended toward their midpoint at very low zeta; docs/validation.md sec. 3), ``truncation``
    is ``error``; without (the slices), ``value`` is the pressure-moment form and
    ``truncation`` its relative difference to the dissipation form (an indicator). The other
    form stays in ``solution`` (``resistance_dissipation``, ``resistance_moment``)."""
    H = jnp.asarray(H, float)
    finite = jnp.isfinite(H)
    gamma = jnp.where(finite, contact_radius / jnp.where(finite, H, 1.0), 0.0)
    if error is None:
        value = resistance
        scale = jnp.maximum(jnp.abs(resistance), 1e-300)
        trunc = jax.lax.stop_gradient(jnp.abs(resistance - resistance_dissipation) / scale)
    else:
        value, trunc = (resistance_dissipation if value is None else value), error
    return RollingResult(value=value, contact_radius=contact_radius, gamma=gamma,
                         regime=jnp.asarray(int(REGIMES.full)), truncation=trunc, result=result,
                         solution=GridSolution(penetration=penetration, pressure=pressure, grid=grid,
                                                  iterations=iterations, residual=residual,
                                                  resistance_dissipation=resistance_dissipation,
                                                  resistance_moment=resistance))
