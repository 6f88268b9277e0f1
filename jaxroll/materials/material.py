"""Viscoelastic material models: complex shear modulus G*(omega) and its relatives.

Convention ([ZG] eq. 12): harmonic time dependence ``e^{+i omega t}``, so the loss modulus
``G'' = Im G*`` is positive for ``omega > 0``. Angular frequency ``omega`` in rad/s, moduli in
Pa, times in s, temperatures in K.

Every material is an :class:`equinox.Module` whose physical floats are pytree leaves, so
``jax.grad(loss)(material).G0`` works, and ``jax.vmap`` over a batch of materials works.
"""

from __future__ import annotations

import abc
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._numerics import any_traced, as_float, check_input, to_complex

__all__ = [
    "AbstractMaterial",
    "AbstractShift",
    "StandardLinearSolid",
    "GeneralizedMaxwell",
    "WLF",
    "Arrhenius",
    "AtTemperature",
    "at_temperature",
    "shift_factor",
    "complex_modulus",
    "storage_modulus",
    "loss_modulus",
    "tan_delta",
    "relaxation_modulus",
    "relaxed_modulus",
    "glassy_modulus",
]

GAS_CONSTANT = 8.314462618  # J/(mol K)


def _leaf(x):
    """Converter for physical fields: numbers and arrays become float64 arrays; anything else
    (``None``, sentinels used by ``jax.tree_util`` / ``vmap`` axis specs) passes through, and so
    does a list that is not numeric or is ragged: the class's check then names the field."""
    if isinstance(x, (int, float, np.ndarray, np.generic, jax.Array, list, tuple)):
        try:
            return as_float(x)
        except (ValueError, TypeError):
            return x
    return x


def _i_times(x):
    """``1j * x`` for a real array ``x`` without relying on implicit float -> complex promotion
    (which strict dtype promotion forbids)."""
    return jax.lax.complex(jnp.zeros_like(x), x)


def _require(name: str, value, predicate, message: str) -> None:
    """Raise ``ValueError`` at construction for a concrete (non-traced) invalid value."""
    if isinstance(value, (str, bytes, list, tuple)):
        raise ValueError(f"{name} must be a number or an array of numbers; got {value!r}")
    if isinstance(value, jax.core.Tracer) or not isinstance(value, (jax.Array, np.ndarray)):
        return
    v = np.asarray(value)
    if not np.all(np.isfinite(v)) or not np.all(predicate(v)):
        shown = f"{float(v):g}" if v.ndim == 0 else np.array2string(v, precision=4, threshold=8)
        raise ValueError(f"{name} must be {message}; got {shown}")


class AbstractMaterial(eqx.Module):
    """A linear viscoelastic material in shear: the protocol every material implements.

    Methods (all SI; ``omega`` [rad/s], ``t`` [s], moduli [Pa]):

    * ``complex_modulus(omega)``: ``G*(omega) = G' + i G''`` (``e^{+i omega t}`` convention,
      ``G'' > 0`` for ``omega > 0``);
    * ``relaxation_modulus(t)``: ``G(t)``;
    * ``relaxed_modulus()``: ``G'(0)``, ``glassy_modulus()``: ``G'(inf)``;
    * ``longest_time()``: the slowest retardation (creep) time [s]: the time over which the
      layer keeps the memory of a load. Grid rules need it (the material behind a roller at
      speed ``V`` recovers over a length ``~ V`` times it).

    Callers use these methods (or the module-level functions of the same names); they never
    probe a material's fields.

    Parameter rules: ``_rules`` lists ``(field, test, rule)``; they are checked at construction
    for concrete values (``ValueError``) and, for traced values, inside compiled programs by
    :meth:`checked` (``eqx.error_if``: works under jit/vmap/grad), so a traced negative time or modulus raises
    instead of returning a wrong number.
    """

    _rules: ClassVar[tuple] = ()

    def __check_init__(self):
        for name, test, rule in self._rules:
            _require(name, getattr(self, name), test, rule)

    def checked(self) -> "AbstractMaterial":
        """This material with every parameter checked: concrete values on the host
        (``ValueError``), traced ones inside compiled programs (non-finite values and values
        breaking the rules raise :class:`equinox.EquinoxRuntimeError`)."""
        return _checked(self, self._rules)

    @abc.abstractmethod
    def complex_modulus(self, omega) -> jax.Array:
        """``G*(omega)`` [Pa] at angular frequency ``omega`` [rad/s] (float64 array)."""

    @abc.abstractmethod
    def relaxation_modulus(self, t) -> jax.Array:
        """``G(t)`` [Pa] at time ``t`` [s]."""

    @abc.abstractmethod
    def relaxed_modulus(self) -> jax.Array:
        """Relaxed (static, long-term) shear modulus ``G'(0)`` [Pa]."""

    @abc.abstractmethod
    def glassy_modulus(self) -> jax.Array:
        """Glassy (instantaneous) shear modulus ``G'(inf)`` [Pa]."""

    @abc.abstractmethod
    def longest_time(self) -> jax.Array:
        """Slowest retardation time [s] (see the class docstring)."""


def _checked(module, rules):
    """``module`` with each ruled field checked (finite and ``test``): a concrete value on the
    host (``ValueError``, as at construction), a traced one inside the compiled program
    (:func:`jaxroll._numerics.check_input`)."""
    for name, test, rule in rules:
        v = getattr(module, name)
        if not isinstance(v, jax.core.Tracer):
            _require(name, v, test, rule)
            continue
        bad = ~(jnp.isfinite(v) & test(v))
        module = eqx.tree_at(lambda m, name=name: getattr(m, name), module, check_input(v, bad, f"{name} must be {rule}"))
    return module


class AbstractShift(eqx.Module):
    """A time-temperature shift law: ``log a_T`` at temperature ``T`` [K], ``a_T(T_ref) = 1``."""

    #: The one-line error where :meth:`undefined` holds.
    UNDEFINED: ClassVar[str] = "shift law undefined at this temperature"
    #: The largest ``|log10 a_T|`` accepted: a law that shifts the spectrum by more decades is far
    #: outside any range it was measured over (a WLF just above its pole, an Arrhenius law at a few
    #: kelvin), and past ~308 decades ``a_T`` overflows float64 (the reduced speeds became ``inf``
    #: and the model NaN). 100 decades keep every product of ``a_T`` with a time, a speed or a
    #: frequency (and its square) finite.
    MAX_DECADES: ClassVar[float] = 100.0

    @abc.abstractmethod
    def log_shift(self, T) -> jax.Array:
        """Natural logarithm of the shift factor ``a_T`` at temperature ``T`` [K]."""

    def undefined(self, T) -> jax.Array:
        """Where the law has no value at ``T`` [K] (boolean, shaped like ``T``): nowhere unless a
        law says so."""
        return jnp.zeros(jnp.shape(T), bool)

    def check_temperatures(self, T) -> None:
        """Host check of concrete temperatures ``T`` [K]: ``ValueError`` (one line, the first
        offending temperature) where ``T`` is not positive or the law is undefined (the same rules
        that :meth:`log_shift` and :func:`shift_factor` check inside a compiled program)."""
        T = np.asarray(T, float)
        bad = ~(np.isfinite(T) & (T > 0))
        if bad.any():
            raise ValueError(f"temperature must be positive, in kelvin; got T = {T[bad].flat[0]:g} K")
        host = jax.tree_util.tree_map(np.asarray, self)  # NumPy leaves: the rule without device work
        bad = np.asarray(host.undefined(T))
        if bad.any():
            raise ValueError(f"{self.UNDEFINED}; got T = {T[bad].flat[0]:g} K")
        with np.errstate(all="ignore"):
            decades = np.asarray(host.log_shift(T), float) / np.log(10.0)
        bad = ~(np.abs(decades) <= self.MAX_DECADES)
        if bad.any():
            raise ValueError(f"{_out_of_range(self)}; got log10 a_T = {decades[bad].flat[0]:.4g} at "
                             f"T = {T[bad].flat[0]:g} K")


class StandardLinearSolid(AbstractMaterial):
    """Standard linear solid (three-parameter Zener solid), [ZG] eq. 12.

    ``G*(omega) = G0 (1 + i omega tau) / (1 + i omega tau/(1+f))``

    Args:
        G0: relaxed (static) shear modulus ``G'(0)`` [Pa].
        tau: retardation (creep) time [s]; the relaxation time is ``tau/(1+f)``.
        f: relaxation strength, ``f = G'(inf)/G'(0) - 1`` [-] (so the glassy modulus is
            ``G0 (1+f)``).

    Deviation from paper: [ZG]'s text states ``f = G'(0)/G'(inf) - 1``; its eq. 12 implies
    ``f = G'(inf)/G'(0) - 1``, which is what is implemented.
    """

    G0: jax.Array = eqx.field(converter=_leaf)
    tau: jax.Array = eqx.field(converter=_leaf)
    f: jax.Array = eqx.field(converter=_leaf)

    _rules: ClassVar[tuple] = (("G0", lambda v: v > 0, "a positive, finite shear modulus in Pa"),
                               ("tau", lambda v: v > 0, "a positive, finite time in s"),
                               ("f", lambda v: v >= 0, "finite and >= 0 (f = 0: elastic)"))

    def to_prony(self) -> "GeneralizedMaxwell":
        """The equivalent one-term Prony series: ``G_inf = G0``, ``G_1 = G0 f``,
        ``tau_1 = tau/(1+f)``."""
        return GeneralizedMaxwell(
            G_inf=self.G0,
            G=jnp.atleast_1d(self.G0 * self.f),
            tau=jnp.atleast_1d(self.tau / (1.0 + self.f)),
        )

    def complex_modulus(self, omega):
        iwt = _i_times(as_float(omega) * self.tau)
        return to_complex(self.G0) * (1.0 + iwt) / (1.0 + iwt / to_complex(1.0 + self.f))

    def relaxation_modulus(self, t):
        return self.G0 * (1.0 + self.f * jnp.exp(-as_float(t) * (1.0 + self.f) / self.tau))

    def relaxed_modulus(self):
        return self.G0

    def glassy_modulus(self):
        return self.G0 * (1.0 + self.f)

    def longest_time(self):
        """The retardation time ``tau`` ([ZG] eq. 12: ``1/G*`` has its pole at ``omega = i/tau``)."""
        return self.tau


class GeneralizedMaxwell(AbstractMaterial):
    """Generalized Maxwell solid (Prony series).

    ``G*(omega) = G_inf + sum_i G_i (i omega tau_i) / (1 + i omega tau_i)``,
    ``G(t) = G_inf + sum_i G_i exp(-t/tau_i)``.

    Args:
        G_inf: long-term (relaxed) shear modulus [Pa].
        G: Prony moduli ``G_i`` [Pa], shape ``(n,)``.
        tau: relaxation times ``tau_i`` [s], shape ``(n,)``.
    """

    G_inf: jax.Array = eqx.field(converter=_leaf)
    G: jax.Array = eqx.field(converter=_leaf)
    tau: jax.Array = eqx.field(converter=_leaf)

    _vectors: ClassVar[tuple] = ("G", "tau")  # 1D (check_parameter_shapes); every other field a scalar
    _rules: ClassVar[tuple] = (("G_inf", lambda v: v > 0, "a positive, finite shear modulus in Pa"),
                               ("G", lambda v: v >= 0, "finite, non-negative moduli in Pa"),
                               ("tau", lambda v: v > 0, "positive, finite times in s"))

    def __check_init__(self):
        if hasattr(self.G, "shape") and hasattr(self.tau, "shape") and self.G.shape != self.tau.shape:
            raise ValueError(f"G and tau must have the same shape; got {self.G.shape} and {self.tau.shape}")

    def complex_modulus(self, omega):
        omega = as_float(omega)[..., None]
        iwt = _i_times(omega * self.tau)
        return to_complex(self.G_inf) + jnp.sum(to_complex(self.G) * iwt / (1.0 + iwt), axis=-1)

    def relaxation_modulus(self, t):
        t = as_float(t)[..., None]
        return self.G_inf + jnp.sum(self.G * jnp.exp(-t / self.tau), axis=-1)

    def relaxed_modulus(self):
        return self.G_inf

    def glassy_modulus(self):
        return self.G_inf + jnp.sum(self.G, axis=-1)

    def longest_time(self):
        """Upper estimate of the slowest retardation time: the slowest relaxation time times
        ``G'(inf)/G'(0)`` (exact for one term, where it equals the standard linear solid's
        ``tau``; the retardation times interlace the relaxation times and the slowest one lies
        between ``max tau_i`` and this bound)."""
        return jnp.max(self.tau, axis=-1) * self.glassy_modulus() / self.relaxed_modulus()


class WLF(AbstractShift):
    """Williams-Landel-Ferry shift: ``log10 a_T = -C1 (T - T_ref) / (C2 + T - T_ref)``.

    Args:
        C1: [-]. C2: [K]. T_ref: reference temperature [K].
    """

    C1: jax.Array = eqx.field(converter=_leaf)
    C2: jax.Array = eqx.field(converter=_leaf)
    T_ref: jax.Array = eqx.field(converter=_leaf)

    UNDEFINED: ClassVar[str] = "WLF shift undefined: C2 + T - T_ref <= 0 (temperature too far below T_ref)"

    def __check_init__(self):
        _require("WLF.C1", self.C1, np.isfinite, "a finite number")
        # (C2 <= 0 puts the pole at or above T_ref: the law is undefined at its own reference)
        _require("WLF.C2", self.C2, lambda v: v > 0, "a positive, finite number of kelvin")
        _require("WLF.T_ref", self.T_ref, lambda v: v > 0, "a positive, finite temperature in K")

    def undefined(self, T):
        return self.C2 + (T - self.T_ref) <= 0

    def log_shift(self, T):
        dT = T - self.T_ref
        denom = check_input(self.C2 + dT, self.undefined(T), self.UNDEFINED)
        return -self.C1 * dT / denom * jnp.log(10.0)


class Arrhenius(AbstractShift):
    """Arrhenius shift: ``ln a_T = (E_a / R_gas) (1/T - 1/T_ref)``.

    Args:
        activation_energy: ``E_a`` [J/mol]. T_ref: reference temperature [K].
    """

    activation_energy: jax.Array = eqx.field(converter=_leaf)
    T_ref: jax.Array = eqx.field(converter=_leaf)

    def __check_init__(self):
        _require("Arrhenius.activation_energy", self.activation_energy, np.isfinite, "a finite energy in J/mol")
        _require("Arrhenius.T_ref", self.T_ref, lambda v: v > 0, "a positive, finite temperature in K")

    def log_shift(self, T):
        return self.activation_energy / GAS_CONSTANT * (1.0 / T - 1.0 / self.T_ref)


def shift_factor(shift: AbstractShift, T) -> jax.Array:
    """Time-temperature shift factor ``a_T`` at temperature ``T`` [K] (``a_T(T_ref) = 1``).

    The material at temperature ``T`` behaves as the reference material at ``omega a_T``.
    """
    T = as_float(T)
    T = check_input(T, T <= 0, "temperature must be positive, in kelvin")
    log_a = shift.log_shift(T)
    log_a = check_input(log_a, ~(jnp.abs(log_a) <= shift.MAX_DECADES * np.log(10.0)), _out_of_range(shift))
    return jnp.exp(log_a)


def _out_of_range(shift: AbstractShift) -> str:
    """The one-line error of a shift factor beyond ``shift.MAX_DECADES``."""
    return (f"{type(shift).__name__} shift factor out of range: |log10 a_T| > {shift.MAX_DECADES:g} (the law is "
            "far outside any measured range at this temperature)")


class AtTemperature(AbstractMaterial):
    """A material evaluated at temperature ``T`` through time-temperature superposition:
    ``G*(omega; T) = G*_ref(omega a_T)`` and ``G(t; T) = G_ref(t / a_T)``."""

    material: AbstractMaterial
    shift: AbstractShift
    T: jax.Array = eqx.field(converter=_leaf)

    _rules: ClassVar[tuple] = (("T", lambda v: v > 0, "a positive, finite temperature in K"),)

    def checked(self):
        out = _checked(self, self._rules)
        if not any_traced(self.shift, self.T):
            self.shift.check_temperatures(self.T)  # (traced: log_shift checks inside the program)
        return eqx.tree_at(lambda m: m.material, out, self.material.checked())

    def complex_modulus(self, omega):
        return self.material.complex_modulus(as_float(omega) * shift_factor(self.shift, self.T))

    def relaxation_modulus(self, t):
        return self.material.relaxation_modulus(as_float(t) / shift_factor(self.shift, self.T))

    def relaxed_modulus(self):
        return self.material.relaxed_modulus()

    def glassy_modulus(self):
        return self.material.glassy_modulus()

    def longest_time(self):
        """The reference material's slowest retardation time times ``a_T``."""
        return self.material.longest_time() * shift_factor(self.shift, self.T)


def at_temperature(material: AbstractMaterial, shift: AbstractShift, T) -> AtTemperature:
    """``material`` (characterised at ``shift.T_ref``) evaluated at temperature ``T`` [K]."""
    return AtTemperature(material, shift, T)


def complex_modulus(material, omega) -> jax.Array:
    """Complex shear modulus ``G*(omega) = G' + i G''`` [Pa] at angular frequency ``omega``
    [rad/s] (any shape; ``e^{+i omega t}`` convention, [ZG] eq. 12)."""
    return material.complex_modulus(omega)


def storage_modulus(material, omega) -> jax.Array:
    """Storage modulus ``G'(omega)`` [Pa]."""
    return jnp.real(complex_modulus(material, omega))


def loss_modulus(material, omega) -> jax.Array:
    """Loss modulus ``G''(omega)`` [Pa] (positive for ``omega > 0``)."""
    return jnp.imag(complex_modulus(material, omega))


def tan_delta(material, omega) -> jax.Array:
    """Loss factor ``tan delta = G''/G'`` [-]."""
    g = complex_modulus(material, omega)
    return jnp.imag(g) / jnp.real(g)


def relaxation_modulus(material, t) -> jax.Array:
    """Shear relaxation modulus ``G(t)`` [Pa] at time ``t`` [s] (closed form for every model)."""
    return material.relaxation_modulus(t)


def relaxed_modulus(material) -> jax.Array:
    """Relaxed (static, long-term) shear modulus ``G'(0)`` [Pa]."""
    return material.relaxed_modulus()


def glassy_modulus(material) -> jax.Array:
    """Glassy (instantaneous) shear modulus ``G'(inf)`` [Pa]."""
    return material.glassy_modulus()
