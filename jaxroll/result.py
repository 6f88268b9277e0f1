"""The result object returned by :func:`jaxroll.rolling_resistance` for every method."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

__all__ = ["RollingResult", "REGIMES", "full_model_result"]

#: Integer codes of ``RollingResult.regime`` (an array, so it survives jit/vmap).
REGIMES = {0: "thick", 1: "thin", 2: "thin-compressible", 3: "elastic", 4: "full"}


class RollingResult(eqx.Module):
    """Rolling resistance and diagnostics.

    Attributes:
        value: rolling resistance R_r, positive, opposing motion [N for a sphere, N/m for a
            cylinder].
        contact_radius: contact radius (sphere) or half-width (cylinder) of the pressure model
            or of the solved contact [m].
        gamma: ``contact_radius / H`` [-] (0 for a half-space).
        regime: integer code of the pressure model / method, see :data:`REGIMES`.
        valid: True where the inputs lie inside the method's range of validity.
        truncation: estimated relative truncation / discretisation error of ``value`` [-].
        penetration: rigid-body penetration [m] (full models; else None).
        pressure: contact pressure on the grid [Pa] (full models; else None).
        grid: coordinates of the pressure grid [m] (full models; else None).
        status: solver status code, 0 = converged (full models; else None).
        iterations: solver iterations (full models; else None).
        residual: final solver residual (full models; else None).
    """

    value: jax.Array
    contact_radius: jax.Array
    gamma: jax.Array
    regime: jax.Array
    valid: jax.Array
    truncation: jax.Array
    penetration: jax.Array | None = None
    pressure: jax.Array | None = None
    grid: jax.Array | tuple | None = None
    status: jax.Array | None = None
    iterations: jax.Array | None = None
    residual: jax.Array | None = None


def full_model_result(resistance, resistance_dissipation, contact_radius, H, *, ok, penetration, pressure, grid,
                      status, iterations, residual) -> RollingResult:
    """The :class:`RollingResult` of a full contact model (2D cylinder, 3D sphere, slices):
    ``value`` is the pressure-moment form of R_r, ``truncation`` its relative difference to the
    dissipation form (a discretisation-error indicator), ``regime = 4``, ``valid = ok``."""
    finite = jnp.isfinite(H)
    gamma = jnp.where(finite, contact_radius / jnp.where(finite, H, 1.0), 0.0)
    scale = jnp.maximum(jnp.abs(resistance), 1e-300)
    trunc = jax.lax.stop_gradient(jnp.abs(resistance - resistance_dissipation) / scale)
    return RollingResult(value=resistance, contact_radius=contact_radius, gamma=gamma, regime=jnp.asarray(4),
                         valid=ok, truncation=trunc, penetration=penetration, pressure=pressure, grid=grid,
                         status=status, iterations=iterations, residual=residual)
