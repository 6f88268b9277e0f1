r"""Bonded ply stacks: the surface compliance of several viscoelastic plies on a rigid base or
on a viscoelastic half-space.

A :class:`Stack` is a list of :class:`Ply` (top ply first, in contact with the roller), each
with its own material, thickness ``H``, density ``rho`` and Poisson ratio ``nu``, bonded to one
another and to the base: ``base="rigid"`` or ``base=HalfSpace(material, nu=..., rho=...)``.
It goes where a :class:`~jaxroll.engines.layer.Layer` goes (the methods and front doors); its
materials are its own, so the front doors take it in place of the material and layer,
``jr.rolling_resistance(stack, radius=..., load=..., speed=...)``.

Compliance (same Fourier convention and mode modulus ``G_m = conj(G*(q_x V))`` as
:mod:`jaxroll.engines.layer`). By isotropy the 3D mode ``(q_x, q_y)`` is the plane-strain
problem at ``q = |q|`` with ``eps = rho V^2 q_x^2/(G_m q^2)`` in every ply. In ply ``j`` the
state ``y = (U, W, S/(G_j q), N/(G_j q))`` (``u_x = i U``, ``u_z = W`` positive downward into
the stack, ``sigma_xz = i S``, ``sigma_zz = N``) obeys ``dy/d(qz) = A y`` with::

    A = [[0, -1, 1, 0], [c1, 0, 0, c2], [2/(1-nu) - eps, 0, 0, -c1], [0, -eps, 1, 0]],
    c1 = nu/(1-nu),  c2 = (1-2nu)/(2(1-nu)),

whose eigenvalues are ``+-1, +-s``, ``s = sqrt(1 - eps)`` (incompressible with inertia, or
any ``nu`` quasi-statically). So the ply propagator ``P = expm(A a)``, ``a = q H_j``, is the
cubic ``alpha I + beta A + gamma A^2 + delta A^3`` (Cayley-Hamilton) with
``alpha + gamma mu = cosh(sqrt(mu) a)`` and ``beta + delta mu = sinh(sqrt(mu) a)/sqrt(mu)`` on
``mu in {1, s^2}``: divided differences, evaluated (i) by their Taylor series for ``a <= 1``,
(ii) through ``sinh(y)/y``, ``y = (s-1) a/2``, where ``|y| < 1/2`` (no ``0/0`` as ``eps -> 0``),
(iii) directly otherwise; every term is scaled by ``e^{-a max(1, Re s)}`` (no overflow; the
scale cancels below).

Composition, from the base up, as the 2x2 compliance ``C`` of the interface, ``(U, W) = C (S, N)``
in ply units (``C~ = C G_j q``)::

    C~_top = (P11 - C~_bottom P21)^{-1} (C~_bottom P22 - P12)

(``P`` in 2x2 blocks), a Moebius map with bounded coefficients: the scaled propagator never
overflows, and a deep ply's growing modes make ``C~_top`` its half-space value whatever lies
below (the neglected terms are ``O(e^{-2a Re s})``). Rigid base: ``C~ = 0``; half-space base:
the same map for a base ply of ``a = A_CAP/min(1, Re s)`` on a rigid base (its half-space value
to ``e^{-2 A_CAP}``, ``A_CAP = 20``). Between plies ``C~`` is rescaled by ``G_{j-1}/G_j``; each
ply's ``a`` is capped at ``A_CAP/min(1, Re s)`` (the plies below it then matter to
``e^{-40}``). With inertia the growing modes ``e^{a}`` and ``e^{s a}`` of one ply differ by
``e^{(1 - Re s) a}``, more than the round-off of one scale, so a ply with inertia and
``a > 4`` is crossed in ``N_SUB = 8`` sub-plies. The surface compliance is
``T = -C~_top,zz/(G_1 q)`` (``sigma_zz = -p`` at the surface, ``S = 0``), ``T(0) = 0``.
Checked against the product of the plies' high-precision ``expm`` of [ZG] eq. 22 to 1e-12
(tests/test_stack.py).
"""

from __future__ import annotations

import operator

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._numerics import any_traced, as_float, check_input, to_complex as _c, where_safe
from ..materials.material import AbstractMaterial, _leaf, _require, complex_modulus, relaxed_modulus
from .layer import SUPERSONIC, Layer, _density, _sinhc_minus_one

__all__ = ["Ply", "HalfSpace", "Stack", "stack_compliance", "ply_propagator", "models", "cover_path", "cover_thickness",
           "with_cover_thickness", "with_cover_material", "A_CAP"]

#: cap on each ply's ``q H min(1, Re s)``: beyond it the plies below matter to ``e^{-2 A_CAP}``
A_CAP = 20.0
#: sub-plies of a ply with inertia (module docstring)
N_SUB = 8


def _check_material(material, where):
    if not isinstance(material, AbstractMaterial):
        raise ValueError(f"{where}: material must be a jaxroll material (jr.StandardLinearSolid, "
                         f"jr.GeneralizedMaxwell, jr.at_temperature(...), ...); got {type(material).__name__}")


class Ply(eqx.Module):
    """One bonded ply of a :class:`Stack`.

    Args:
        material: the ply's material (any jaxroll material, temperature-shifted ones included).
        H: thickness [m], finite and positive.
        nu: Poisson's ratio (static); ``nu < 0.5`` is quasi-static (``rho = 0``), as for
            :class:`~jaxroll.engines.layer.Layer`.
        rho: mass density [kg/m^3]; 0 neglects inertia.
    """

    material: AbstractMaterial
    H: jax.Array = eqx.field(converter=_leaf)
    rho: jax.Array = eqx.field(converter=_density, default=0.0)
    nu: float = eqx.field(static=True, default=0.5)

    def __check_init__(self):
        _check_material(self.material, "Ply")
        if isinstance(self.H, jax.Array) and not isinstance(self.H, jax.core.Tracer) and np.any(np.isinf(self.H)):
            raise ValueError("Ply.H must be finite: a half-space under the plies is base=jr.HalfSpace(material)")
        self.layer  # the rules of jr.Layer (H > 0, rho >= 0, nu in [0, 0.5], nu < 0.5 only with rho = 0)

    @property
    def layer(self) -> Layer:
        """The ply as a :class:`~jaxroll.engines.layer.Layer` (same ``H``, ``rho``, ``nu``)."""
        return Layer(H=self.H, rho=self.rho, nu=self.nu)


class HalfSpace(eqx.Module):
    """A viscoelastic (or elastic: a material without relaxation) half-space under the plies.

    Args:
        material: the base material.
        nu: Poisson's ratio (static); ``nu < 0.5`` needs ``rho = 0``.
        rho: density [kg/m^3]; 0 neglects inertia.
    """

    material: AbstractMaterial
    rho: jax.Array = eqx.field(converter=_density, default=0.0)
    nu: float = eqx.field(static=True, default=0.5)

    def __check_init__(self):
        _check_material(self.material, "HalfSpace")
        Layer(H=np.inf, rho=self.rho, nu=self.nu)


def _as_base(base):
    if isinstance(base, str):
        if base != "rigid":
            raise ValueError(f'Stack.base must be "rigid" or a jr.HalfSpace(material, ...); got {base!r}')
        return None
    return base


class Stack(eqx.Module):
    """Bonded plies (top ply first, in contact) on a rigid base or on a half-space.

    ``jr.Stack([jr.Ply(cover, H=0.008), jr.Ply(carcass, H=0.004, nu=0.45)], base="rigid")``.

    Args:
        plies: a non-empty sequence of :class:`Ply`, top first.
        base: ``"rigid"`` (default) or a :class:`HalfSpace`.

    The stack carries its materials: the front doors take it alone,
    ``jr.rolling_resistance(stack, radius=..., load=..., speed=...)``. The methods receive it
    in place of the layer, with :attr:`material` (the top ply's) in place of the material;
    contact-size estimates, grid rules and error bounds, which are single-layer formulas, see
    the equivalent layer :attr:`H`, :attr:`nu`, :attr:`rho`; the compliance is the stack's.
    """

    plies: tuple
    base: HalfSpace | None = eqx.field(converter=_as_base, default=None)

    def __init__(self, plies, base="rigid"):
        plies = tuple(plies) if isinstance(plies, (list, tuple)) else plies
        self.plies = plies
        self.base = base

    def __check_init__(self):
        if not isinstance(self.plies, tuple) or not self.plies or not all(isinstance(p, Ply) for p in self.plies):
            raise ValueError(f"Stack needs a non-empty list of jr.Ply, top first; got {self.plies!r}")
        if self.base is not None and not isinstance(self.base, HalfSpace):
            raise ValueError(f'Stack.base must be "rigid" or a jr.HalfSpace(material, ...); got {self.base!r}')

    # --- the equivalent single layer seen by the single-layer heuristics ---------------------
    @property
    def material(self) -> AbstractMaterial:
        """The top ply's material: the material of the contact-size and grid heuristics."""
        return self.plies[0].material

    @property
    def nu(self) -> float:
        """The top ply's Poisson ratio."""
        return self.plies[0].nu

    @property
    def rho(self):
        """The top ply's density."""
        return self.plies[0].rho

    @property
    def H(self) -> jax.Array:
        """Thickness [m] of the equivalent layer of the top material on a rigid base used by the
        single-layer heuristics (contact size, grid rules, error bounds; not the compliance):
        each ply counts with the ratio of relaxed moduli ``G_top/G_j`` (thin-layer compliances
        in series); a half-space base makes it ``inf`` unless the base is 100 times stiffer than
        the top ply (then the base counts as rigid)."""
        xp = np if not any_traced(self) else jnp  # concrete: host arithmetic (the front doors' checks)
        g_top = xp.asarray(relaxed_modulus(self.material))
        h = sum(xp.asarray(p.H) * g_top / xp.asarray(relaxed_modulus(p.material)) for p in self.plies)
        if self.base is not None:
            h = xp.where(xp.asarray(relaxed_modulus(self.base.material)) >= 100.0 * g_top, h, xp.inf)
        return as_float(h)

    def equivalent_layer(self) -> Layer:
        """The :class:`~jaxroll.engines.layer.Layer` (:attr:`H`, :attr:`rho`, :attr:`nu`) of the
        single-layer heuristics, with :attr:`material`."""
        return Layer(H=self.H, rho=self.rho, nu=self.nu)

    @property
    def thickness(self) -> jax.Array:
        """Total thickness of the plies [m]."""
        return sum(as_float(p.H) for p in self.plies)

    @property
    def layers(self):
        """Each ply's :class:`~jaxroll.engines.layer.Layer` (and the base's, ``H = inf``)."""
        out = [p.layer for p in self.plies]
        if self.base is not None:
            out.append(Layer(H=jnp.inf, rho=self.base.rho, nu=self.base.nu))
        return out

    def checked(self) -> "Stack":
        """The stack with every ply's ``H`` and ``rho`` checked (:meth:`Layer.checked`), and every
        ply's and the base's material (``material.checked()``: e.g. a temperature-shifted ply's
        temperature in its shift law's domain): concrete values on the host (``ValueError``; NumPy
        only, no device work: the front doors check every call), traced ones inside compiled
        programs (the materials where they are used)."""
        if not any_traced(self):
            for p in self.plies:
                _require("Ply.H", np.asarray(p.H), lambda v: v > 0, "a positive, finite thickness in m")
                _require("Ply.rho", np.asarray(p.rho), lambda v: v >= 0, "a finite, non-negative density in kg/m^3")
                p.material.checked()
            if self.base is not None:
                self.base.material.checked()
            return self
        plies = []
        for p in self.plies:
            lay = p.layer.checked()
            plies.append(eqx.tree_at(lambda x: (x.H, x.rho), p, (lay.H, lay.rho)))
        return eqx.tree_at(lambda s: s.plies, self, tuple(plies))


def cover_path(layer):
    """The path (for :func:`equinox.tree_at`) to the thickness of the cover: ``H`` of a
    :class:`~jaxroll.Layer`, or of the top ply of a :class:`~jaxroll.Stack` (the thickness the
    maps differentiate and the fits may free)."""
    if isinstance(layer, Layer):
        return lambda l: l.H
    if isinstance(layer, Stack):
        return lambda l: l.plies[0].H
    raise ValueError(f"expected a jr.Layer or jr.Stack; got a {type(layer).__name__}")


def cover_thickness(layer):
    """The cover's thickness [m] (:func:`cover_path`)."""
    return cover_path(layer)(layer)


def with_cover_thickness(layer, H):
    """``layer`` with its cover thickness (:func:`cover_path`) set to ``H`` [m]."""
    return eqx.tree_at(cover_path(layer), layer, H)


def with_cover_material(stack, material):
    """``stack`` with ``material`` in its top ply (the cover a map shifts or a fit frees)."""
    return eqx.tree_at(lambda s: s.plies[0].material, stack, material)


def models(material, layer):
    """``(material, layer)`` as the methods take them: a :class:`~jaxroll.Stack` given alone
    (``layer=None``) becomes ``(stack.material, stack)`` (its top ply's material for the
    single-layer heuristics; the compliance is the stack's)."""
    if isinstance(layer, Stack):
        if material is layer.material:  # already split (the front doors' own calls)
            return material, layer
        raise ValueError("a jr.Stack carries its plies' materials: give it alone, "
                         "rolling_resistance(stack, radius=..., ...), not with a material")
    if isinstance(material, Stack):
        if layer is not None:
            raise ValueError(f"a jr.Stack replaces both the material and the layer; got a layer too ({layer!r})")
        return material.material, material
    if layer is None:
        raise ValueError("give a material and a jr.Layer, or a jr.Stack alone")
    return material, layer


# --------------------------------------------------------------------------------------
# the ply propagator

_N_SERIES = 12


def _scaled_cosh(z, m_a):
    """``e^{-m_a} cosh z`` (``Re z <= m_a``)."""
    return 0.5 * (jnp.exp(z - m_a) + jnp.exp(-z - m_a))


def _scaled_sinh(z, m_a):
    return 0.5 * (jnp.exp(z - m_a) - jnp.exp(-z - m_a))


def _coefficients_static(a):
    """``(alpha, beta, gamma, delta) e^{-a}`` of ``expm(A a)`` at ``eps = 0`` (``s = 1``), real:
    ``gamma = a sinh(a)/2``, ``delta = (a cosh a - sinh a)/2`` (series for ``a <= 1``)."""
    e2 = jnp.exp(-2.0 * a)
    ch, sh = 0.5 * (1.0 + e2), -0.5 * jnp.expm1(-2.0 * a)
    gamma = 0.5 * a * sh
    small = a <= 1.0
    a_s = where_safe(small, a, 0.5)
    a2 = a_s * a_s
    term, d_ser = a_s, jnp.zeros_like(a_s)
    for k in range(1, _N_SERIES):  # delta = sum_k k a^{2k+1}/(2k+1)!
        term = term * a2 / ((2 * k) * (2 * k + 1))
        d_ser = d_ser + k * term
    delta = jnp.where(small, d_ser * jnp.exp(-a_s), 0.5 * (a * ch - sh))
    return ch - gamma, sh - delta, gamma, delta


def _coefficients(a, eps):
    """``(alpha, beta, gamma, delta) e^{-a m}`` of ``expm(A a)`` (module docstring), complex,
    for real ``a >= 0`` (capped) and complex ``eps``."""
    a_c = _c(a)
    mu = 1.0 - eps
    s = jnp.sqrt(mu)
    m_a = _c(a * jnp.maximum(1.0, jnp.real(s)))
    ch, sh = _scaled_cosh(a_c, m_a), _scaled_sinh(a_c, m_a)

    # (i) Taylor series in a (a <= 1): gamma = sum a^2k/(2k)! h_{k-1}, delta = sum a^{2k+1}/(2k+1)! h_{k-1}
    small = a <= 1.0
    a_s = _c(where_safe(small, a, 0.5))
    a2 = a_s * a_s
    term = a2 / 2.0  # a^{2k}/(2k)! at k = 1

    def series_step(k, carry):  # a loop, not unrolled: compile time
        term, h, g, d = carry
        kf = k.astype(jnp.complex128)
        h = 1.0 + mu * h
        term = term * a2 / ((2 * kf - 1) * (2 * kf))
        return term, h, g + term * h, d + term * a_s / (2 * kf + 1) * h

    h0 = jnp.ones_like(mu)
    _, _, g_ser, d_ser = jax.lax.fori_loop(2, _N_SERIES, series_step, (term, h0, term * h0, term * a_s / 3.0 * h0))
    scale_s = jnp.exp(-jnp.where(small, m_a, 0.5))
    g_ser, d_ser = g_ser * scale_s, d_ser * scale_s

    # (ii) near-degenerate: |y| < 1/2, y = (s - 1) a/2, through sinh(y)/y
    y = (s - 1.0) * a_c / 2.0
    near = jnp.abs(y) < 0.5
    shc = 1.0 + _sinhc_minus_one(jnp.where(near, y, 0.1))
    w = (s + 1.0) * a_c / 2.0
    g_near = a_c * _scaled_sinh(w, m_a) / (s + 1.0) * shc
    d_near = (a_c * _scaled_cosh(w, m_a) * shc - sh) / (s * (s + 1.0))

    # (iii) direct divided differences
    eps_f = jnp.where(near, 0.5, eps)
    s_f = jnp.sqrt(1.0 - eps_f)
    g_far = (ch - _scaled_cosh(s_f * a_c, m_a)) / eps_f
    d_far = -(_scaled_sinh(s_f * a_c, m_a) / s_f - sh) / eps_f

    gamma = jnp.where(small, g_ser, jnp.where(near, g_near, g_far))
    delta = jnp.where(small, d_ser, jnp.where(near, d_near, d_far))
    return ch - gamma, sh - delta, gamma, delta


# 4x4 matrices as nested lists whose entries are Python floats (0.0 skipped) or arrays: the
# products unroll into elementwise arithmetic that XLA fuses (batched 4x4 dots are slow on CPU)

def _is_zero(x):
    return isinstance(x, float) and x == 0.0


def _same(x, y):
    """``x, y`` with a real array made complex next to a complex one (strict promotion)."""
    cx, cy = jnp.iscomplexobj(x), jnp.iscomplexobj(y)
    if cx and not cy and not isinstance(y, float):
        y = _c(y)
    elif cy and not cx and not isinstance(x, float):
        x = _c(x)
    return x, y


def _add(x, y):
    return y if _is_zero(x) else x if _is_zero(y) else operator.add(*_same(x, y))


def _mul(x, y):
    return 0.0 if _is_zero(x) or _is_zero(y) else operator.mul(*_same(x, y))


def _matmul(X, Y):
    n, m, k = len(X), len(Y[0]), len(Y)
    out = []
    for i in range(n):
        row = []
        for j in range(m):
            acc = 0.0
            for t in range(k):
                acc = _add(acc, _mul(X[i][t], Y[t][j]))
            row.append(acc)
        out.append(row)
    return out


def _state_matrix(nu, eps):
    """``A`` of the module docstring (``eps``: an array, or the float 0.0)."""
    c1, c2, c3 = nu / (1.0 - nu), (1.0 - 2.0 * nu) / (2.0 * (1.0 - nu)), 2.0 / (1.0 - nu)
    return [[0.0, -1.0, 1.0, 0.0], [c1, 0.0, 0.0, c2], [c3 - eps, 0.0, 0.0, -c1], [0.0, -eps if not _is_zero(eps)
                                                                                   else 0.0, 1.0, 0.0]]


def _propagator(a, nu, eps):
    """``expm(A a)`` scaled (module docstring) as a nested 4x4 list; ``eps = 0.0`` (a Python
    float): the real quasi-static propagator."""
    if _is_zero(eps):
        coef = _coefficients_static(a)
        A = np.array(_state_matrix(nu, 0.0))
        powers = [np.eye(4), A, A @ A, A @ A @ A]
        return [[sum(float(pw[i, j]) * c for pw, c in zip(powers, coef) if pw[i, j] != 0.0) for j in range(4)]
                for i in range(4)]
    coef = _coefficients(a, eps)
    A = _state_matrix(nu, eps)
    A2 = _matmul(A, A)
    A3 = _matmul(A2, A)
    eye = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    return [[_add(_add(_mul(coef[0], eye[i][j]), _mul(coef[1], A[i][j])), _add(_mul(coef[2], A2[i][j]),
                                                                                 _mul(coef[3], A3[i][j])))
             for j in range(4)] for i in range(4)]


def ply_propagator(a, nu, eps):
    """``expm(A a) e^{-a max(1, Re s)}`` (module docstring), shape ``(..., 4, 4)``, complex.

    Args:
        a: ``q H`` [-], real, ``>= 0`` (broadcasts with ``eps``).
        nu: Poisson's ratio (static).
        eps: ``rho V^2 q_x^2/(G_m q^2)`` [-], complex.
    """
    a, eps = jnp.broadcast_arrays(as_float(a), _c(eps))
    P = _propagator(a, nu, eps)
    return jnp.stack([jnp.stack([jnp.broadcast_to(_c(x), a.shape) for x in row], -1) for row in P], -2)


def _through(P, C, factor=None, zz_only=False):
    """``C~_top = (P11 - C' P21)^{-1} (C' P22 - P12)``, ``C' = factor C`` (2x2 nested lists;
    ``C = None``: rigid, 0). The products ``C P21``, ``C P22`` are formed before the factor (the
    interface's modulus ratio), so on tensor grids they stay on the smaller shape of ``C`` and
    ``P``. ``zz_only``: only the entry ``C~_top,zz`` (the surface)."""
    P11 = [row[:2] for row in P[:2]]
    P12 = [row[2:] for row in P[:2]]
    P21 = [row[:2] for row in P[2:]]
    P22 = [row[2:] for row in P[2:]]
    if C is None:
        M, N = P11, [[_mul(-1.0, x) for x in row] for row in P12]
    else:
        scale = (lambda x: x) if factor is None else (lambda x: _mul(factor, x))  # noqa: E731
        CP21, CP22 = _matmul(C, P21), _matmul(C, P22)
        M = [[_add(P11[i][j], _mul(-1.0, scale(CP21[i][j]))) for j in range(2)] for i in range(2)]
        N = [[_add(scale(CP22[i][j]), _mul(-1.0, P12[i][j])) for j in range(2)] for i in range(2)]
    det = _add(_mul(M[0][0], M[1][1]), _mul(-1.0, _mul(M[0][1], M[1][0])))
    if zz_only:
        return _add(_mul(M[0][0], N[1][1]), _mul(-1.0, _mul(M[1][0], N[0][1]))) / det
    inv_det = 1.0 / det
    Minv = [[_mul(M[1][1], inv_det), _mul(-inv_det, M[0][1])], [_mul(-inv_det, M[1][0]), _mul(M[0][0], inv_det)]]
    return _matmul(Minv, N)


def _static_zero(rho) -> bool:
    return isinstance(rho, float) and rho == 0.0


def _eps(rho, V, qx, q2_safe, G):
    if _static_zero(rho):
        return 0.0
    return _c(rho * V * V * qx * qx / q2_safe) / G


def _shear_speed_ok(V, rho, material):
    if _static_zero(rho):
        return V
    c_s = jnp.where(rho > 0, jnp.sqrt(relaxed_modulus(material) / where_safe(rho > 0, rho, 1.0)), jnp.inf)
    return check_input(V, jnp.abs(V) >= c_s, SUPERSONIC.format(where="a ply or the base"))


def stack_compliance(stack: Stack, qx, qy, V, q=None) -> jax.Array:
    """Surface compliance ``T(q_x, q_y)`` [m/Pa] of a :class:`Stack` under a steadily moving
    load (module docstring); same conventions as
    :func:`jaxroll.engines.layer.surface_compliance`.

    Args:
        stack: :class:`Stack`.
        qx, qy: wavenumbers [rad/m] (broadcast together).
        V: rolling speed [m/s] (broadcasts); below every ply's shear-wave speed.
        q: optional ``|(q_x, q_y)|`` [rad/m] on a smaller shape that broadcasts to theirs (e.g.
            ``(n, 1)`` against ``(n, m)`` tensor grids): the quasi-static plies' real
            propagators, which depend on ``q`` only, are then evaluated on that shape.

    Returns:
        complex ``T`` [m/Pa], shape of the broadcast inputs; ``T(0, 0) = 0``.
    """
    qx, qy, V = as_float(qx), as_float(qy), as_float(V)
    q_small = None if q is None else as_float(q)
    media = [(p.material, p.rho, p.nu, as_float(p.H)) for p in stack.plies]
    if stack.base is not None:
        media.append((stack.base.material, stack.base.rho, stack.base.nu, None))
    for material, rho, _, _ in media:
        V = _shear_speed_ok(V, rho, material)
    q2 = qx * qx + qy * qy
    q_pos = q2 > 0
    q2_safe = where_safe(q_pos, q2, 1.0)
    q = jnp.sqrt(q2_safe)
    C, G_below = None, None
    for k, (material, rho, nu, H) in enumerate(reversed(media)):
        top = k == len(media) - 1
        G = jnp.conj(complex_modulus(material, qx * V))
        eps = _eps(rho, V, qx, q2_safe, G)
        ratio = None if C is None else G / G_below
        if _is_zero(eps):  # quasi-static ply: a real propagator, s = 1
            qq = q if q_small is None else q_small
            a = jnp.full(qq.shape, A_CAP) if H is None else jnp.minimum(qq * H, A_CAP)
            C = _through(_propagator(a, nu, 0.0), C, ratio, zz_only=top)
        else:
            if ratio is not None:
                C = [[_mul(x, ratio) for x in row] for row in C]
            C = _through_inertial(C, q, H, nu, eps)
            C = C[1][1] if top else C
        G_below = G
    T = -_c(C) / (G_below * _c(q))
    return jnp.where(q_pos, T, 0.0)


def _through_inertial(C, q, H, nu, eps):
    """A ply with inertia: its cap is ``A_CAP/min(1, Re s)`` (the plies below couple through
    ``e^{-2 a Re s}``); where ``a > 4`` it is crossed in ``N_SUB`` sub-plies, since the modes
    ``e^{a}`` and ``e^{s a}`` grow at different rates and one scale keeps only the faster."""
    a_cap = A_CAP / jnp.minimum(1.0, jnp.real(jnp.sqrt(1.0 - eps)))
    a = a_cap if H is None else jnp.minimum(q * H, a_cap)
    split = a > 4.0
    P = _propagator(jnp.where(split, a / N_SUB, a), nu, eps)
    C = _through(P, C)

    def step(_, C):  # a loop, not unrolled: compile time
        C_next = _through(P, C)
        return [[jnp.where(split, x, y) for x, y in zip(rn, rc)] for rn, rc in zip(C_next, C)]

    return jax.lax.fori_loop(0, N_SUB - 1, step, C)
