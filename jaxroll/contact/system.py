"""The scaled contact system: unknowns, equations and scales of one contact problem.

Unknowns ``x = (p/p_s, d/g_s)``: the window pressure [Pa] and the penetration [m], made
dimensionless by a pressure scale ``p_s`` and a gap scale ``g_s`` (preconditioning only: the
scales are ``stop_gradient`` constants for differentiation). The equations on a contact set
``A`` are ``g_A = 0`` (the gap ``g = h - d + C p``, scaled by ``g_s``), ``p = 0`` off ``A``, and the
last row: load mode, ``dA sum(p) = P`` (``load_weight sum(p~) = P / P_s``); penetration mode,
``d~ = d / g_s`` (``d`` pinned; its derivative enters through the right-hand side).

Scales: load mode, ``p_s`` = mean contact pressure of the initial set and ``g_s = c0 p_s``;
penetration mode, ``g_s = |d|`` and ``p_s = g_s/c0`` (``c0`` = self compliance).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .operator import WindowedCompliance

__all__ = ["ContactSystem", "flat"]


def flat(p, d):
    """The unknown vector ``(p.ravel(), d)``."""
    return jnp.concatenate([p.ravel(), d[None]])


class ContactSystem(eqx.Module):
    """One contact problem in scaled variables (see the module docstring).

    Attributes:
        compliance: the window operator ``C``.
        profile: ``h`` [m] on the window.
        target: right-hand side of the last row (``P/P_s``, or ``d/g_s``).
        load_weight: ``dA p_s / P_s`` (load mode), ``None`` (penetration mode).
        p_s, g_s: pressure [Pa] and gap [m] scales (``stop_gradient``).
        penetration_mode: static; which last row.
    """

    compliance: WindowedCompliance
    profile: jax.Array
    target: jax.Array
    load_weight: jax.Array | None
    p_s: jax.Array
    g_s: jax.Array
    penetration_mode: bool = eqx.field(static=True)

    @classmethod
    def build(cls, compliance, profile, value, cell_area, initial_contact, penetration_mode):
        """The system of ``value`` (the load [N, N/m] or the penetration [m]) with the scales of
        ``initial_contact``. Load mode needs ``value > 0`` (the caller checks)."""
        sg = jax.lax.stop_gradient
        c0 = sg(jnp.abs(compliance.self_compliance))
        if penetration_mode:
            g_s = sg(jnp.maximum(jnp.abs(value), 1e-300))
            return cls(compliance, profile, value / g_s, None, g_s / c0, g_s, True)
        n0 = jnp.maximum(jnp.sum(initial_contact), 1).astype(float)
        p_s = sg(value / (cell_area * n0))
        return cls(compliance, profile, value / sg(value), cell_area * p_s / sg(value), p_s, p_s * c0, False)

    @property
    def shape(self) -> tuple:
        return self.compliance.shape

    def stopped(self) -> "ContactSystem":
        """The same system on ``stop_gradient`` data (for the iterations)."""
        return jax.tree_util.tree_map(jax.lax.stop_gradient, self)

    def last_row(self, pt, dt):
        """The load (``load_weight sum(p~)``) or penetration (``d~``) row."""
        return dt if self.penetration_mode else self.load_weight * jnp.sum(pt)

    def border(self, weights):
        """``(v, c)``: the last row's coefficients on the pressure (weighted by ``weights``, a
        window array) and on ``d~``, for the block elimination of the preconditioner."""
        if self.penetration_mode:
            return jnp.zeros(self.shape), jnp.asarray(1.0)
        return self.load_weight * weights, jnp.asarray(0.0)

    def gap(self, pt, dt):
        """Scaled gap ``g/g_s = h/g_s - d~ + C p~ (p_s/g_s)``."""
        return self.profile / self.g_s - dt + self.compliance(pt) * (self.p_s / self.g_s)

    def matvec(self, mask, with_gap=False):
        """The operator of the equality-constrained system on the contact set ``mask``;
        ``with_gap``: ``x -> (A x, g~)`` with the scaled gap of the pressure on the set,
        ``h/g_s - d~ + C (mask p~) (p_s/g_s)``, from the same product (off the set ``p~`` is 0
        at the solution, to the solve's tolerance)."""
        maskf = mask.astype(float)
        ratio = self.p_s / self.g_s

        def matvec(x):
            pt = x[:-1].reshape(self.shape)
            dt = x[-1]
            cu = self.compliance(maskf * pt) * ratio - dt
            gap_rows = maskf * cu + (1.0 - maskf) * pt
            out = jnp.concatenate([gap_rows.ravel(), self.last_row(maskf * pt, dt)[None]])
            return (out, self.profile / self.g_s + cu) if with_gap else out

        return matvec

    def rhs(self, mask):
        """The right-hand side on the contact set ``mask``."""
        return jnp.concatenate([(-mask.astype(float) * self.profile / self.g_s).ravel(), self.target[None]])

    def elliptic_start(self, mask):
        """Scaled unknowns of a Hertz-shaped start on the set ``mask``: the pressure
        ``~ sqrt(h_max - h)`` (``h_max`` the profile's largest value on the set; for a paraboloid
        ``sqrt(a^2 - r^2)``), scaled to the load (load mode), and the penetration that closes the
        set's mean gap (penetration mode: the pressure's scale closes it, at least 0). One operator
        application. The start of :func:`jaxroll.contact.smoothing.continuation_solve` from a cold
        set: unlike a solve on a set far from the contact's (a loss-dominated contact's first
        active-set solve peaks at 280 times the mean pressure, benchmarks/LOG.md 2026-12-08), it
        is positive and smooth."""
        maskf = mask.astype(float)
        h_max = jnp.max(jnp.where(mask, self.profile, -jnp.inf))
        shape = maskf * jnp.sqrt(jnp.maximum(h_max - self.profile, 0.0))
        shape = jnp.where(jnp.sum(shape) > 0, shape, maskf)  # a flat profile on the set: uniform
        n = jnp.maximum(jnp.sum(maskf), 1.0)
        base = jnp.sum(maskf * self.profile) / (n * self.g_s)  # mean of h/g_s on the set
        lifted = jnp.sum(maskf * self.compliance(shape)) * (self.p_s / self.g_s) / n  # of C shape
        if self.penetration_mode:
            scale = jnp.maximum((self.target - base) / jnp.where(lifted > 0, lifted, 1.0), 0.0)
            return flat(scale * shape, self.target)
        scale = self.target / (self.load_weight * jnp.maximum(jnp.sum(shape), 1e-300))
        return flat(scale * shape, base + scale * lifted)

    def unscale(self, x):
        """``(p [Pa], d [m])`` of the scaled unknowns."""
        return x[:-1].reshape(self.shape) * self.p_s, x[-1] * self.g_s
