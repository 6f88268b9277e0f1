"""Public entry point :func:`rolling_resistance`: one call for every method and geometry."""

from __future__ import annotations

import inspect
import warnings

import jax
import numpy as np

from .result import REGIMES, RollingResult

__all__ = ["rolling_resistance", "ValidityWarning"]


class ValidityWarning(UserWarning):
    """A result lies outside the range of validity of its pressure model / method."""


def _is_concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


def _check_options(options, fn, what):
    """ValueError naming the ``options`` that ``fn`` (the function that consumes them) does not
    take, instead of a TypeError from deep inside; functions taking ``**kwargs`` check their own."""
    params = inspect.signature(fn).parameters
    if any(p.kind is p.VAR_KEYWORD for p in params.values()):
        return
    bad = sorted(set(options) - set(params))
    if bad:
        known = sorted(k for k, p in params.items() if p.kind is p.KEYWORD_ONLY)
        raise ValueError(f"{what} does not take the option(s) {bad}; its options are {known}")


def rolling_resistance(material, layer, *, radius, load, speed, geometry="sphere", method="direct",
                       pressure="auto", period=None, n_terms=None, rtol=1e-4, **options) -> RollingResult:
    """Rolling resistance of a rigid sphere or cylinder on a viscoelastic layer.

    Args:
        material: a material of :mod:`jaxroll.material` (e.g. ``StandardLinearSolid(G0, tau, f)``).
        layer: :class:`jaxroll.layer.Layer` (``H`` [m], ``jnp.inf`` for a half-space).
        radius: roller radius ``R`` [m].
        load: ``P`` [N] (sphere) or ``P'`` [N/m] (cylinder, per unit length).
        speed: rolling speed ``V`` [m/s], ``>= 0``.
        geometry: ``"sphere"`` or ``"cylinder"``.
        method: ``"direct"`` (the Fourier-series method of [ZG] sec. 4, stationary pressure) or
            ``"full"`` (the full rolling-contact solution: :mod:`jaxroll.cylinder`,
            :mod:`jaxroll.sphere3d`), or ``"PD"``, ``"PP"``, ``"SP"`` (sphere from cylinder
            slices, [ZG] sec. 3, :mod:`jaxroll.slices`). ``pressure``/``rtol`` apply to
            ``"direct"`` only; ``period`` is passed on to the full/slice models.
        pressure: stationary pressure model of the direct method: ``"auto"`` (default; chosen
            from ``gamma = r_c/H``), ``"thick"``, ``"thin"``, ``"thin-compressible"``, or
            ``"elastic"`` (spheres: the static elastic contact pressure solved on a grid by the 3D
            contact solver, valid for any thickness, [ZG] footnote 4's open case).
        period: ``None`` (default): the aperiodic limit (single roller on an infinite layer).
            A period [m] (scalar, or ``(Lx, Ly)`` for spheres) selects [ZG]'s periodic series.
        n_terms: number of Fourier terms per direction of the periodic series.
        rtol: target relative accuracy of the aperiodic quadrature.
        **options: passed to the method (direct: ``modulus``, ``quadrature``; full: see
            :func:`jaxroll.cylinder.rolling_resistance_full`).

    Returns:
        :class:`jaxroll.result.RollingResult`: ``value`` [N for a sphere, N/m for a cylinder]
        and diagnostics. ``valid`` is False outside the method's range of validity: under
        ``jit``/``vmap`` this is only a flag; called eagerly, a :class:`ValidityWarning` is
        also issued.

    Works under ``jax.jit``, ``jax.vmap`` (scalar ``radius``, ``load``, ``speed`` per call) and
    ``jax.grad`` with respect to the material and layer parameters, ``R``, ``P`` and ``V``.
    """
    if method == "direct" and pressure == "elastic":
        if geometry != "sphere" or period is not None or n_terms is not None:
            raise ValueError("pressure='elastic' (static elastic contact pressure from the 3D contact solver) is "
                             "implemented for geometry='sphere'; its resolution goes through **options")
        from .sphere3d import direct_elastic_rolling_resistance

        res = direct_elastic_rolling_resistance(material, layer, radius, load, speed, **options)
    elif method == "direct":
        from .direct import direct_rolling_resistance

        _check_options(options, direct_rolling_resistance, "method='direct'")
        res = direct_rolling_resistance(material, layer, radius=radius, load=load, speed=speed,
                                        geometry=geometry, pressure=pressure, period=period, n_terms=n_terms,
                                        rtol=rtol, **options)
    elif method in ("full", "PD", "PP", "SP"):
        if n_terms is not None:
            if not (method == "full" and geometry == "sphere"):
                raise ValueError(f"method={method!r} takes its resolution through **options, not n_terms")
            options = dict(options, n_terms=n_terms)
        if period is not None:
            options = dict(options, period=period)
        if method == "full" and geometry == "cylinder":
            from .cylinder import rolling_resistance_full, solve_cylinder

            _check_options(options, solve_cylinder, "method='full' on a cylinder")
            res = rolling_resistance_full(material, layer, radius, load, speed, **options)
        elif method == "full" and geometry == "sphere":
            from .sphere3d import rolling_resistance_full as sphere_full
            from .sphere3d import solve_sphere

            _check_options(options, solve_sphere, "method='full' on a sphere")
            res = sphere_full(material, layer, radius, load, speed, **options)
        elif geometry == "sphere":
            from .slices import rolling_resistance_slices

            res = rolling_resistance_slices(material, layer, radius, load, speed, algorithm=method, **options)
        else:
            raise NotImplementedError(f"method={method!r} builds a sphere from cylinder slices: use "
                                      "geometry='sphere' (for cylinders use 'direct' or 'full')")
    else:
        raise ValueError(f"unknown method {method!r}; choose 'direct', 'full', 'PD', 'PP' or 'SP'")

    valid = res.valid
    if _is_concrete(valid) and not bool(np.all(np.asarray(valid))):
        regimes = sorted({REGIMES.get(int(c), str(c)) for c in np.atleast_1d(np.asarray(res.regime))})
        warnings.warn(
            f"rolling_resistance: result outside the range of validity of the {'/'.join(regimes)} model "
            f"(gamma = r_c/H = {np.asarray(res.gamma) if _is_concrete(res.gamma) else 'traced'}); see RollingResult.valid",
            ValidityWarning,
            stacklevel=2,
        )
    return res
