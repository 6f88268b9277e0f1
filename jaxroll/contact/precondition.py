"""Preconditioner of the contact systems: the inverse of the circulant embedding of ``C``.

For the block system ``[[B, u], [v^T, c]]`` of a contact set (``B``: gap rows on the set and
pressure rows off it, ``u``: the ``d`` column, ``v``: the last row, ``c``: its corner) with an
approximate inverse ``P`` of ``B``, the exact block elimination (Schur complement)

    ``d = (r2 - v.P r1) / (c - v.P u)``,  ``p = P (r1 - u d)``

is applied. ``P`` acts on the cells in the set (row weights ``w_in`` of ``C``) as the inverse of
the circulant embedding that applies ``C`` (:func:`~jaxroll.contact.operator.embedding_size`:
every window offset once, none aliased; divided by its Fourier multiplier) and as a diagonal
``w_out`` elsewhere. It is built from ``stop_gradient`` data: it changes the GMRES iterations,
never the converged solution, so the implicit derivatives do not depend on it.

Two levels, cheap first: the coefficients folded onto a period of about one window (``W + 1``
points per axis, :func:`folded_size`; a quarter of the cost per application) are applied first,
and the inverse of the whole embedding only where a solve stagnates with them
(:class:`~jaxroll.contact.linear.GMRES` takes the pair: the first solve with the folded one, its
fallback from where it stopped with the whole embedding's). Folding aliases the long-range part
of the viscoelastic kernel, strongest near the resistance peak, and the preconditioned spectrum
spreads as the grid is refined. Measured on a half-space sphere (SLS f = 1, ``zeta = V tau/a0 =
1``, operator applications per solve, GMRES(32)): folded 112 / 215 / 2879 at 12 / 24 / 48 cells
per radius, the whole embedding 118 / 173 / 150; at 1.5 windows still 940 at 48 cells. So the
folded one serves the coarse grids and most points of a table at a lower cost, the whole one
the fine grids near the peak. The whole embedding's level alone (transposed for the adjoint)
serves the implicit-differentiation solves (one solve each, no set decisions to make fast), and
the pair, with the soft-min weights, the Newton steps of the smoothed contact edge.

Where the compliance carries its layer's symbol (:attr:`~jaxroll.contact.WindowedCompliance.symbol`:
the 3D sphere, on any layer or stack), the whole level inverts the symbol, the layer's own
compliance on the embedding's period, instead of the embedded window coefficients. Those are cut
at the window's offsets, and a loss-dominated material's creep trail runs far beyond the window
(SLS ``f = 1000``, ``tau = 0.25`` s at 0.1 m/s: retardation length ``V tau (1 + f)`` = 25 m):
measured at 24 cells per radius on a 30 mm layer, 84 % of the embedding's modes lay below 1e-3 of
its largest (floored) and 43 % had a negative real part, and GMRES(96) stagnated at a relative
residual of 3e-5 (``linear_solve_failed``; at ``f = 100``, 32 cells, ``max_steps_reached`` after
230 s). With the symbol, whose real part is positive, the same solves converged in 0.35 and
0.18 s, and 26 solves over ``f = 1, 30``, half-space and 5 mm layer, 0.2 mm/s..2 m/s, default
grid and 24 and 48 cells per radius gave the same values to 10 digits as before
(benchmarks/LOG.md, 2026-11-29). A stack and a layer with inertia (whose symbol is evaluated per
speed) failed in the same way at ``f = 1000``, 0.1 m/s, 24 cells (``linear_solve_failed`` and
``max_steps_reached``) and converge with it, at 10-13 % more time on ordinary tables.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .linear import Deferred
from .operator import WindowedCompliance, _smooth_size, circulant_window_apply, fold_offsets
from .system import ContactSystem, flat

__all__ = ["CirculantPreconditioner", "folded_size"]


def folded_size(window: int) -> int:
    """FFT size of the cheap preconditioner's period on a ``window``-cell axis: the smallest
    ``2^a 3^b 5^c 7^d >= W + 1``, about half the exact embedding (a quarter of its points in 2D)."""
    return _smooth_size(int(window) + 1)

#: Floor of the modulus of the preconditioner's Fourier multiplier, relative to its maximum.
#: The multiplier can vanish: ``K_0 = 0`` (zero-mean periodic displacement) makes the sum of the
#: window's influence coefficients, i.e. its ``q = 0`` mode, ~0 when they decay within the
#: window (thin layers). Flooring (phase kept) keeps the preconditioner bounded; it affects
#: only modes the contact set barely sees (the sphere at the paper's resolution has min/max
#: ~3e-3: unchanged).
PRECONDITIONER_FLOOR = 1e-3


class CirculantPreconditioner(eqx.Module):
    """Approximate inverse of a scaled contact system (see the module docstring).

    Attributes:
        inverse_multiplier: Fourier multiplier of the inverse of the circulant embedding.
        folded_multiplier: Fourier multiplier of the inverse of the coefficients folded onto
            :func:`folded_size` per axis (the cheap level).
        scale: ``g_s/p_s`` (the system's operator is ``C p~ (p_s/g_s)``).
        embedding, folded: static FFT sizes of the embedding and of the folded period.
        shape: static window shape.
    """

    inverse_multiplier: jax.Array
    folded_multiplier: jax.Array
    scale: jax.Array
    embedding: tuple = eqx.field(static=True)
    folded: tuple = eqx.field(static=True)
    shape: tuple = eqx.field(static=True)

    @classmethod
    def build(cls, compliance: WindowedCompliance, system: ContactSystem) -> "CirculantPreconditioner":
        sg = jax.lax.stop_gradient
        folded = tuple(folded_size(w) for w in compliance.shape)
        # the embedding that applies C (rfftn of its coefficients), and the folded period
        if compliance.symbol is None:
            whole = _inverse(sg(compliance.multiplier))
        else:  # the layer's own compliance on the embedding's period (WindowedCompliance.symbol)
            whole = _symbol_inverse(sg(compliance.symbol))
        cheap = _inverse(jnp.fft.rfftn(fold_offsets(sg(compliance.offsets), folded)))
        return cls(whole, cheap, sg(system.g_s / system.p_s), compliance.embedding, folded, compliance.shape)

    def _circulant_inverse(self, r, transpose, cheap):
        mult, emb = (self.folded_multiplier, self.folded) if cheap else (self.inverse_multiplier, self.embedding)
        mult = jnp.conj(mult) if transpose else mult
        return circulant_window_apply(mult, r, emb) * self.scale

    def block(self, in_set, w_in, w_out, u, v, c, transpose=False):
        """``(M_cheap, M_whole)``, each ``~ A^-1`` (or ``A^-T``) of the bordered system: rows on
        ``in_set`` ~ ``w_in`` times the scaled ``C`` on the set, rows off it ~ ``w_out`` times the
        identity; ``u, v``: window-shaped ``d`` column and last row; ``c``: corner. ``M_cheap``
        inverts the folded coefficients, ``M_whole`` the whole embedding; ``M_whole`` comes as a
        :class:`~jaxroll.contact.linear.Deferred` (its set-up, one application, runs only where
        it is used)."""
        return (self._block(in_set, w_in, w_out, u, v, c, transpose, True),
                Deferred(lambda *a: self._block(*a, transpose, False), in_set, w_in, w_out, u, v, c))

    def _block(self, in_set, w_in, w_out, u, v, c, transpose, cheap):
        mf = in_set.astype(float)
        w_out = jnp.where(in_set, 1.0, w_out)
        w_in = jnp.where(in_set, w_in, 1.0)
        if transpose:
            u, v = v, u

            def P(r):
                return mf * self._circulant_inverse(mf * r, True, cheap) / w_in + (1.0 - mf) * r / w_out
        else:
            def P(r):
                return mf * self._circulant_inverse(mf * r / w_in, False, cheap) + (1.0 - mf) * r / w_out

        Pu = P(u)
        den = c - jnp.sum(v * Pu)
        ok = jnp.abs(den) > 1e-300
        den_safe = jnp.where(ok, den, 1.0)

        def M(r):
            r1 = r[:-1].reshape(self.shape)
            r2 = r[-1]
            Pr1 = P(r1)
            d = jnp.where(ok, (r2 - jnp.sum(v * Pr1)) / den_safe, r2)
            return flat(Pr1 - d * Pu, d)

        return M

    def active_set(self, system: ContactSystem, mask, transpose=False):
        """``(M_cheap, M_whole)`` for the active-set system of :meth:`ContactSystem.matvec` on ``mask``."""
        mf = mask.astype(float)
        ones = jnp.ones(self.shape)
        v, c = system.border(mf)
        return self.block(mask, ones, ones, -mf, v, c, transpose)


def _symbol_inverse(symbol):
    """The inverse of a compliance symbol (:attr:`~jaxroll.contact.WindowedCompliance.symbol`),
    0 at the zero mode, where the symbol is ``T(0) = 0`` (the zero-mean convention of the
    periodic compliance): the mean is the penetration's, which the block elimination carries.
    A passive layer's symbol has no other zero (``Re T > 0``), so nothing is floored."""
    zero = jnp.zeros(symbol.shape, bool).at[(0,) * symbol.ndim].set(True)
    return jnp.where(zero, 0.0, 1.0 / jnp.where(zero, 1.0, symbol))


def _inverse(mult):
    """The inverse of a Fourier multiplier, its modulus floored at :data:`PRECONDITIONER_FLOOR`
    times its maximum (phase kept)."""
    mod = jnp.abs(mult)
    floor = PRECONDITIONER_FLOOR * jnp.max(mod)
    big = mod >= floor
    one = jnp.ones_like(mult)
    phase = jnp.where(mod > 0, jnp.conj(mult) / jnp.where(mod > 0, mod, 1.0).astype(mult.dtype), one)
    return jnp.where(big, one / jnp.where(big, mult, one), phase / floor.astype(mult.dtype))
