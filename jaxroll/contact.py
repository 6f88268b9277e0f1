"""Differentiable steady-state rolling contact on a periodic viscoelastic surface.

One solver for a rigid profile pressed on a periodic surface whose compliance is a (generally
non-symmetric) convolution: the 1D line of a rolling cylinder (plane strain) and the 2D grid
of a rolling sphere use the same code; only the grid dimension differs.

Discretisation and Fourier convention
-------------------------------------
The period ``L_k`` of axis ``k`` is split into ``N_k`` cells of width ``dx_k = L_k/N_k``. The
pressure is **piecewise constant** on the cells; the surface displacement ``u`` (positive into
the layer) is **collocated at the cell centres**. A Fourier mode is ``e^{+i q.x}`` with
``q_k = 2 pi m_k / L_k`` (``m_k`` any integer); ``T(q)`` is the layer's surface compliance
(:func:`jaxroll.layer.surface_compliance`, displacement per unit pressure of that mode).

The exact Fourier coefficient of the piecewise-constant pressure is
``p_hat_m = (1/N) S(q_m) DFT(p)_{m mod N}`` with the load-patch factor
``S(q) = prod_k sinc(q_k dx_k / 2)`` (``sinc z = sin z / z``), and since cell-centre separations
are multiples of ``dx``, all modes ``m = r + l N`` (aliases) give the same phase at the cell
centres. Hence the displacement at the centres is *exactly*

    ``u = IDFT(K * DFT(p))``,  ``K_r = sum_{l in Z^d} T(q_{r + l N}) S(q_{r + l N})``   (1)

with numpy's FFT normalisation. This is the periodic-image (alias) sum done in Fourier space;
``K_0 = T(0) = 0`` (every alias of ``r = 0`` has ``S = 0``), so ``u`` has zero mean and the
rigid-body penetration ``d`` carries the mean. In 1D the alias sum is evaluated with ``2M``
explicit images and an analytic tail: beyond the last image ``T`` is replaced by its local
``C/|q|`` asymptote (``C`` taken from ``T`` at the first omitted image on each side), whose
remaining alternating series sums in closed form with the trigamma function,
``sum_{k>=0} (-1)^k/(a+k)^2 = [psi'(a/2) - psi'((a+1)/2)]/4``. For the elastic half-space this
makes (1) exact. For a viscoelastic layer the tail model is least accurate where ``q V tau ~ 1``
at the image wavenumbers (low speed): measured influence-coefficient errors (relative to the
self compliance) 1e-4 / 5e-5 / 2e-5 for ``M = 1 / 2 / 4`` at ``V tau/a0 = 1e-3``, below 1e-6 for
``V tau/a0 >= 1``; the rolling resistance relative to ``M = 8`` changes by up to 1.1e-4 for
``M = 1`` and 1.5e-5 for ``M = 2`` (worst case measured: 5 mm layer, ``V tau/a0 ~ 0.02`` at
25 cells per half-width), below 1e-6 for ``V tau/a0 >= 1``. In 2D the
alias sum is truncated at ``M`` images per axis (no tail; relative error ~ 1/M^2 at the
highest modes only; see :func:`periodic_kernel`).

Windowed operator
-----------------
The contact occupies a small part of the period (the period must be long, ``L >= 20 max(a0,
V tau)``, to let the material recover between passes). Pressure is therefore carried only on a
*window* of ``W`` cells around the contact; the displacement on the window is the restriction of
the periodic convolution (1), i.e. a Toeplitz operator whose coefficients are the real-space
influence coefficients ``c = IDFT(K)`` (one size-``N`` FFT). It is applied matrix-free by an
FFT of size ``>= 2W - 1`` (circulant embedding, :func:`embedding_size`), so the per-iteration
cost does not grow with the period. No dense matrix is formed.

Contact problem and solver
--------------------------
Unknowns: pressure ``p >= 0`` on the window cells, penetration ``d``. Gap
``g = h - d + C p >= 0``, ``p g = 0``, ``sum(p) dA = P`` (``h`` = height of the rigid profile
above its lowest point, ``dA`` = cell area). That is the load-controlled problem; in the
penetration-controlled one ``d`` is given and the last equation is ``d = d_given`` instead (same
unknowns, same solver; the load is ``sum(p) dA`` afterwards). ``C`` is not symmetric for a
viscoelastic layer, so the Polonsky-Keer CG is not used: the solver is a primal-dual
active-set method (semismooth Newton on ``min(p, g) = 0``). Each step solves the
equality-constrained system on the current contact set ``A`` (``g_A = 0``, ``p`` off ``A`` = 0,
load or penetration) by restarted GMRES on the windowed FFT operator, then updates
``A = {p > 0 on A} U {g < 0 off A}``; it stops when ``A`` repeats.

GMRES on a 2D window (the sphere) is right-preconditioned (``linear_preconditioner``, on by
default in 2D, off in 1D; see below) by the inverse of a periodic approximation of ``C``: its
coefficients folded onto a period of about one window (:func:`preconditioner_size`, e.g. 56
cells for the paper's 55-cell window, against the operator's 112-point embedding), divided by
that operator's Fourier multiplier (its modulus floored at 1e-3 of the largest), applied to the
residual on the contact set and masked back to it, with the load/penetration row eliminated
exactly (block Schur complement). The converged solution is the same (the stopping test stays
on the true residual); the Krylov iterations drop 4-9x for the 3D sphere at the paper's
resolution (e.g. ``P = 150 N``: 942 -> 101 operator applications per solve, measured with the
full 112-point embedding; the folded one needs 1-3 % more iterations at a quarter of the cost
per application) and 2.5-4x in 1D; the same preconditioner (transposed for the adjoint) serves
the implicit-differentiation solves and, with the soft-min weights, the Newton steps of the
smoothed contact edge. Values are unchanged to 7e-11 relative, derivatives to 1e-10. In 1D it
is off by default: the default cylinder solve gains only 1.1x, and at fine resolution (100 cells
per half-width, the slow tests of ``tests/test_cylinder.py``) the preconditioned GMRES stalled
above the tolerance (``linear_solve_failed``) where the plain one converges.

Speed (``benchmarks/bench_sphere3d.py``, the paper's reference case of 345 solves): each solve
takes ~4-5 active-set steps and ~40 operator applications; an operator application is one FFT
pair pruned to the window (:func:`circulant_window_apply`), a preconditioner application one
FFT pair of the folded period, and the Krylov bookkeeping (:func:`jaxroll._numerics.gmres`)
costs less than either.

Differentiation
---------------
On the converged contact set the solution is the solution of a linear system whose matrix
depends on ``T`` (material, layer, speed) and whose right-hand side depends on ``h`` and ``P``
(or the prescribed ``d``).
The returned pressure and penetration come out of :func:`jax.lax.custom_linear_solve` on that
system, so derivatives of any functional of the solution follow from the implicit function
theorem (one adjoint GMRES solve), never from unrolling the active-set iterations (which run
on ``stop_gradient`` inputs). The contact set is piecewise constant in the parameters; at a
contact-edge event the derivative is the finite one-sided derivative of the discrete problem.

Smoothed contact edge (``smoothing=eps``)
-----------------------------------------
Because the contact set changes by whole cells, any functional of the exact discrete solution
(e.g. the rolling resistance) is only piecewise smooth: it wiggles around its continuum value
with a kink at every contact-set change (0.2-0.3 % for a 3D sphere at 9-23 cells per contact
radius). Least-squares fits along nearly degenerate parameter valleys stall on such wiggles.
With ``smoothing`` the complementarity ``min(c0 p, g) = 0`` becomes the log-sum-exp soft
minimum ``exp(-c0 p/eps) + exp(-g/eps) = 1``: a cell enters the contact gradually, the solution
is C-infinity in the parameters, and it is found by damped Newton (Armijo on the residual) from
the exact active-set solution, each step a GMRES solve on the whole window with the soft-min
weights (the active-set system is the special case of 0/1 weights). Derivatives: one extra
Newton correction whose right-hand side carries the parameter dependence, through
:func:`jax.lax.custom_linear_solve` (implicit function theorem). The price is a bias: the soft
edge lets cells with a small gap carry load; the 3D rolling resistance falls by ~1 % on
average at the smoothing used for fits (see :func:`jaxroll.sphere3d.solve_sphere`,
``edge_smoothing``), and the bias vanishes with ``eps``.
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import scipy.special as sps

from ._numerics import check_input, gmres
from .result import RESULTS, first_failure

__all__ = [
    "ContactSolution",
    "WindowedCompliance",
    "periodic_kernel",
    "windowed_compliance",
    "solve_contact",
    "WarmStart",
    "WindowKernel",
    "active_set_loop",
    "periodic_window_kernel",
    "toeplitz_operator",
    "embedding_size",
    "preconditioner_size",
    "fold_offsets",
    "circulant_window_apply",
    "edge_gap_scale",
]

# ---------------------------------------------------------------------------------------------
# Compliance kernel (exact alias sum) and the windowed operator
# ---------------------------------------------------------------------------------------------


def _alternating_inverse_square(a):
    """``sum_{k>=0} (-1)^k / (a + k)^2`` for ``a > 0`` (numpy, trace-time constant)."""
    return 0.25 * (sps.polygamma(1, 0.5 * a) - sps.polygamma(1, 0.5 * (a + 1.0)))


def periodic_kernel(compliance_fn, period, n_cells, images: int = 2, dissipation: bool = False):
    """Fourier multiplier ``K`` of the periodic cell-to-centre compliance, eq. (1) above.

    Args:
        compliance_fn: ``T(q)`` [m/Pa]; called with one real wavenumber array per axis
            (``compliance_fn(qx)`` in 1D, ``compliance_fn(qx, qy)`` in 2D) [rad/m], broadcasting;
            must return 0 at ``q = 0`` and satisfy ``T(-q) = conj T(q)``; elementwise in ``q``
            (in 1D it is called twice: on the base wavenumbers and on the images, which all
            have ``|q| >= pi/dx``).
        period: tuple of periods ``L_k`` [m] (traced allowed).
        n_cells: tuple of static cell counts ``N_k`` (the last one even).
        images: static number ``M`` of alias images on each side per axis.
        dissipation: also return ``K2_r = sum_l q_x Im T S^2`` [m/Pa per m], the multiplier of
            the exact dissipated power of the piecewise-constant pressure (1D tail included).

    Returns:
        ``K`` of shape ``(N_1, ..., N_{d-1}, N_d//2 + 1)`` (``rfftn`` layout), complex; with
        ``dissipation=True`` the pair ``(K, K2)``.
    """
    period = tuple(period)
    n_cells = tuple(int(n) for n in n_cells)
    ndim = len(n_cells)
    if len(period) != ndim:
        raise ValueError(f"period has {len(period)} axes but n_cells has {ndim}")
    if n_cells[-1] % 2:
        raise ValueError(f"the last cell count must be even; got {n_cells[-1]}")
    if images < 1:
        raise ValueError("images must be >= 1")
    M = int(images)
    # Normalised alias wavenumber w = r/N + l per axis, q = 2 pi w / dx.
    ws = []
    for k, n in enumerate(n_cells):
        r = np.arange(n // 2 + 1) if k == ndim - 1 else np.fft.fftfreq(n) * n
        z = r / n
        if k != ndim - 1:
            z = np.where(z < 0, z + 1.0, z)  # map to [0, 1)
        ws.append(z)
    ls = np.arange(-M, M)
    # shapes: grid axes first, then one image axis per grid axis
    grids = np.meshgrid(*ws, indexing="ij")
    img = np.meshgrid(*([ls] * ndim), indexing="ij")
    wfull = [g.reshape(g.shape + (1,) * ndim) + i.reshape((1,) * ndim + i.shape) for g, i in zip(grids, img)]
    dxs = [jnp.asarray(L) / n for L, n in zip(period, n_cells)]
    qs = [2.0 * jnp.pi * w / dx for w, dx in zip(wfull, dxs)]
    S = np.ones(wfull[0].shape)
    for w in wfull:
        S = S * np.sinc(w)
    if ndim == 1:
        # The base column (l = 0) and the images are evaluated in two calls: every image has
        # |q| >= pi/dx, so a compliance function can take a cheaper branch for them at run time
        # (e.g. the half-space form of a layer much thicker than a cell, see
        # jaxroll.cylinder.compliance_function); the values are the same either way. Image
        # columns: l = -M..M-1 without 0, then the first omitted image on each side (l = M and
        # -M-1) for the analytic tail. All weights are trace-time constants: with
        # q = 2 pi w/dx, the tail weight dx |q| / (2 pi^2) is |w|/pi.
        z = ws[0]
        dx = dxs[0]
        l_img = np.concatenate([np.arange(-M, 0), np.arange(1, M)]).astype(float)
        a_hi, a_lo = z + M, 1.0 - z + M
        w_img = np.concatenate([z[:, None] + l_img[None, :], np.stack([a_hi, -a_lo], axis=-1)], axis=-1)
        sz = np.sin(np.pi * z)
        sign = (-1.0) ** M
        wt = np.concatenate(
            [
                np.sinc(w_img[:, :-2]),
                np.stack([sz * sign * a_hi * _alternating_inverse_square(a_hi),
                          sz * sign * a_lo * _alternating_inverse_square(a_lo)], axis=-1) / np.pi,
            ],
            axis=-1,
        )
        T_base = compliance_fn(2.0 * jnp.pi * z / dx)
        T_img = compliance_fn(2.0 * jnp.pi * w_img / dx)
        K = T_base * np.sinc(z).astype(complex) + jnp.sum(T_img * wt.astype(complex), axis=-1)
        K2 = None
        if dissipation:
            # q Im T S^2 on the explicit images; tail dx sz^2/(2 pi^3) q|q| Im T zeta(3, .)
            wt2 = np.concatenate(
                [
                    2.0 * np.pi * w_img[:, :-2] * np.sinc(w_img[:, :-2]) ** 2,
                    np.stack([2.0 * sz**2 * a_hi**2 * sps.zeta(3.0, a_hi),
                              -2.0 * sz**2 * a_lo**2 * sps.zeta(3.0, a_lo)], axis=-1) / np.pi,
                ],
                axis=-1,
            )
            K2 = (jnp.imag(T_base) * (2.0 * np.pi * z * np.sinc(z) ** 2) + jnp.sum(jnp.imag(T_img) * wt2, axis=-1)) / dx
    else:
        T = compliance_fn(*qs)
        img_axes = tuple(range(ndim, 2 * ndim))
        K = jnp.sum(T * S.astype(complex), axis=img_axes)
        K2 = None
        if dissipation:
            K2 = jnp.sum(qs[0] * jnp.imag(T) * S * S, axis=img_axes)
    return (K, K2) if dissipation else K


class WindowedCompliance(eqx.Module):
    """A Toeplitz (convolution) operator on a window of cells, applied by FFT (no dense matrix).

    ``u = C p`` for pressures and displacements on the window grid, with
    ``C[i, j] = offsets[i - j]``: the influence coefficients of the layer (periodic or not) for
    every cell offset the window holds, ``-(W_k - 1) .. W_k - 1`` per axis. Applied through a
    circulant embedding of size :func:`embedding_size` per axis. The same operator type carries the
    dissipation coefficients of a :class:`WindowKernel`.

    Attributes:
        multiplier: ``rfftn`` of the embedded coefficients.
        offsets: the coefficients, shape ``(2 W_1 - 1, ..., 2 W_d - 1)``, offset ``0`` at the
            centre index ``W_k - 1`` (e.g. [m/Pa] for a compliance).
        shape: static window shape ``(W_1, ..., W_d)``.
    """

    multiplier: jax.Array
    offsets: jax.Array
    shape: tuple = eqx.field(static=True)

    @property
    def ndim(self) -> int:
        return len(self.shape)

    @property
    def embedding(self) -> tuple:
        """Static FFT sizes of the circulant embedding (:func:`embedding_size` per axis)."""
        return tuple(embedding_size(w) for w in self.shape)

    def __call__(self, p):
        """``C p`` on the window (e.g. displacement [m] from pressure [Pa])."""
        return circulant_window_apply(self.multiplier, p, self.embedding)

    @property
    def self_compliance(self):
        """The zero-offset coefficient (a cell centre's displacement per unit pressure on that
        cell [m/Pa])."""
        return self.offsets[tuple(w - 1 for w in self.shape)]

    def dense(self):
        """The dense ``(W, W)`` matrix ``C[i, j] = offsets[i - j]`` of a 1D operator."""
        if self.ndim != 1:
            raise ValueError("dense() is for 1D windows")
        (W,) = self.shape
        i = np.arange(W)
        return self.offsets[i[:, None] - i[None, :] + W - 1]


def circulant_window_apply(multiplier, p, embedding):
    """``irfftn(multiplier * rfftn(p, s=embedding))`` restricted to the window ``p.shape``: the
    circulant operator of FFT sizes ``embedding`` (and Fourier multiplier ``multiplier``, the
    layout of ``rfftn``) applied to window data zero-padded to the embedding.

    Computed one axis at a time so that no transform runs over rows that are known zeros on the
    way in or discarded on the way out: the first axes are transformed on the window's rows only
    after the last one, and inverted back onto the window before the last axis's inverse. This
    is the same result as the full ``rfftn``/``irfftn`` pair to rounding, ~25 % faster for the
    paper's 55 x 55 window in a 112 x 112 embedding on CPU.
    """
    shape = p.shape
    d = len(shape)
    ph = jnp.fft.rfft(p, n=embedding[-1], axis=-1)
    for k in range(d - 1):
        ph = jnp.fft.fft(ph, n=embedding[k], axis=k)
    ph = multiplier * ph
    for k in reversed(range(d - 1)):
        ph = jax.lax.slice_in_dim(jnp.fft.ifft(ph, axis=k), 0, shape[k], axis=k)
    return jnp.fft.irfft(ph, n=embedding[-1], axis=-1)[..., :shape[-1]]


def _smooth_size(n: int) -> int:
    """The smallest ``2^a 3^b 5^c 7^d >= n`` (an FFT length without large prime factors)."""
    while True:
        m = n
        for f in (2, 3, 5, 7):
            while m % f == 0:
                m //= f
        if m == 1:
            return n
        n += 1


def embedding_size(window: int) -> int:
    """The FFT size of the circulant embedding of a ``window``-cell Toeplitz operator: the
    smallest ``2^a 3^b 5^c 7^d >= 2 W - 1`` (``2 W`` itself can hold a large prime factor, e.g.
    106 = 2 x 53, which made the paper's 53-cell window 1.9x slower than the 55-cell one)."""
    return _smooth_size(2 * int(window) - 1)


def preconditioner_size(window: int) -> int:
    """The FFT size of the contact preconditioner's periodic operator on a ``window``-cell axis:
    the smallest ``2^a 3^b 5^c 7^d >= W + 1``, about half the exact embedding.

    The preconditioner inverts the coefficients folded onto this period (:func:`fold_offsets`):
    an approximation of the window's Toeplitz operator, as the circulant inverse on the contact
    set already is. Measured on the paper's reference case (55-cell window: 56 instead of 112
    points per axis), GMRES needs 1-3 % more iterations and each preconditioner application
    costs a quarter: the case runs ~17 % faster."""
    return _smooth_size(int(window) + 1)


def fold_offsets(offsets, embedding):
    """The window's coefficients ``offsets`` (shape ``(2 W_k - 1, ...)``, offset 0 at index
    ``W_k - 1``) summed onto a periodic array of sizes ``embedding``: entry ``i`` holds every
    offset ``= i (mod E_k)``. For ``E_k >= 2 W_k - 1`` no two offsets meet: the exact circulant
    embedding (offsets ``0 .. W-1`` first, zeros, then ``-(W-1) .. -1``); smaller periods alias."""
    offsets = jnp.asarray(offsets)
    idx = np.ix_(*[np.arange(-(n // 2), n // 2 + 1) % E for n, E in zip(offsets.shape, embedding)])
    return jnp.zeros(tuple(embedding), offsets.dtype).at[idx].add(offsets)


def toeplitz_operator(offsets) -> WindowedCompliance:
    """The :class:`WindowedCompliance` of coefficients ``offsets`` (shape ``(2 W_k - 1, ...)``,
    offset 0 at index ``W_k - 1``), applied through the circulant embedding of size
    ``E_k = embedding_size(W_k)`` (:func:`fold_offsets`)."""
    offsets = jnp.asarray(offsets)
    shape = []
    for n in offsets.shape:
        if n % 2 == 0:
            raise ValueError(f"offset arrays have odd sizes 2 W - 1; got {offsets.shape}")
        shape.append((n + 1) // 2)
    emb = fold_offsets(offsets, [embedding_size(w) for w in shape])
    return WindowedCompliance(multiplier=jnp.fft.rfftn(emb), offsets=offsets, shape=tuple(shape))


def periodic_offsets(kernel, n_cells, window):
    """Influence coefficients of the window offsets from the ``rfftn``-layout multiplier
    ``kernel`` of a periodic grid of ``n_cells`` cells: ``c = irfftn(kernel)`` read at the offsets
    ``-(W-1) .. W-1`` (modulo the period) per axis."""
    n_cells = tuple(int(n) for n in n_cells)
    window = tuple(int(w) for w in window)
    if len(window) != len(n_cells):
        raise ValueError("window and n_cells must have the same number of axes")
    for w, n in zip(window, n_cells):
        if not 1 <= w <= n:
            raise ValueError(f"window size {w} must lie in [1, {n}] (cells per period)")
    col = jnp.fft.irfftn(kernel, s=n_cells)
    idx = [np.mod(np.arange(-(w - 1), w), n) for w, n in zip(window, n_cells)]
    return col[np.ix_(*idx)]


def windowed_compliance(kernel, n_cells, window) -> WindowedCompliance:
    """The windowed operator of the periodic compliance multiplier ``K`` of
    :func:`periodic_kernel` (``rfftn`` layout for the period grid ``n_cells``; static tuples
    ``n_cells`` and ``window``, ``window <= n_cells``)."""
    return toeplitz_operator(periodic_offsets(kernel, n_cells, window))


class WindowKernel(eqx.Module):
    """What a contact model needs of a layer on a window of cells: two Toeplitz operators.

    * ``compliance``: ``u = C p``, displacement [m] at the cell centres from the cell pressures
      [Pa];
    * ``dissipation``: ``D`` with the exact rolling resistance of the piecewise-constant
      pressure ``R_r = -int p du/dx dA = dA^2 p . (D p)`` ([ZG] eq. 26/29 with the solved
      pressure; ``dA`` the cell area, [m^2] in 3D, the cell width [m] in 2D):
      ``D(delta) = (2 pi)^-d int q_x Im T(q) S(q)^2 e^{i q.delta} d^d q`` on an infinite layer,
      the alias sum ``(1/A) sum_m q_x Im T S^2 e^{i q_m.delta}`` on a periodic one.
    """

    compliance: WindowedCompliance
    dissipation: WindowedCompliance

    def resistance(self, pressure, cell_area):
        """``R_r = dA^2 p . (D p)`` [N/m in 2D, N in 3D] of a window pressure [Pa]."""
        return cell_area * cell_area * jnp.sum(pressure * self.dissipation(pressure))


def periodic_window_kernel(kernel, kernel2, n_cells, period, window) -> WindowKernel:
    """:class:`WindowKernel` of a periodic grid from the multipliers ``(K, K2)`` of
    :func:`periodic_kernel` (``dissipation=True``) or :func:`jaxroll.sphere3d.sphere_kernel`.

    With ``A = prod L_k`` and ``dA = A/prod N_k``, ``R_r = (dA^2/A) sum_r |DFT(p)_r|^2 K2_r``
    over the full spectrum equals ``dA^2 sum_jk p_j p_k D_{j-k}`` with
    ``D = irfftn(K2)/dA``: exact for a pressure carried on the window.
    """
    n_cells = tuple(int(n) for n in n_cells)
    area = 1.0
    for L in period:
        area = area * L
    dA = area / math.prod(n_cells)
    C = toeplitz_operator(periodic_offsets(kernel, n_cells, window))
    D = toeplitz_operator(periodic_offsets(kernel2, n_cells, window) / dA)
    return WindowKernel(compliance=C, dissipation=D)


# ---------------------------------------------------------------------------------------------
# Solver
# ---------------------------------------------------------------------------------------------


class ContactSolution(eqx.Module):
    """Solution of the rolling contact problem on the window grid.

    Attributes:
        pressure: contact pressure [Pa] on the window cells.
        penetration: rigid-body penetration ``d`` [m] (the given one in penetration mode).
        contact: boolean contact set (cells with ``g = 0``; with ``smoothing``, the cells
            where ``c0 p > g``).
        gap: gap ``h - d + C p`` [m] (0 on the contact set).
        displacement: surface displacement ``C p`` [m] (zero-mean periodic part).
        iterations: active-set iterations.
        residual: final scaled residual, ``max |min(p/p_s, g/g_s)|`` with the load (or
            penetration) equation and the linear residual (scales: load mode, ``p_s`` = mean
            contact pressure of the initial set and ``g_s = c0 p_s``; penetration mode,
            ``g_s = |d|`` and ``p_s = g_s/c0``; ``c0`` = self compliance).
        result: :data:`jaxroll.result.RESULTS` code (``successful``, ``max_steps_reached``,
            ``linear_solve_failed``, ``window_too_small``, ``nonfinite``).
    """

    pressure: jax.Array
    penetration: jax.Array
    contact: jax.Array
    gap: jax.Array
    displacement: jax.Array
    iterations: jax.Array
    residual: jax.Array
    result: jax.Array


class WarmStart(eqx.Module):
    """A start for :func:`solve_contact` from a solved neighbour (another load or speed): the
    contact set, pressure [Pa] and penetration [m] to begin from. ``valid`` is False where there is
    no usable neighbour (the solver's own start is used then)."""

    contact: jax.Array
    pressure: jax.Array
    penetration: jax.Array
    valid: jax.Array

    @classmethod
    def none(cls, shape) -> "WarmStart":
        """No neighbour: the solver's own start."""
        return cls(jnp.zeros(shape, bool), jnp.zeros(shape), jnp.asarray(0.0), jnp.asarray(False))

    @classmethod
    def of(cls, solution: "ContactSolution") -> "WarmStart":
        """The start at ``solution`` itself (e.g. for the same load at a neighbouring speed)."""
        sg = jax.lax.stop_gradient
        p, mask, d = sg(solution.pressure), sg(solution.contact), sg(solution.penetration)
        ok = jnp.any(mask) & (jnp.sum(p) > 0) & jnp.all(jnp.isfinite(p)) & jnp.isfinite(d)
        return cls(mask & ok, jnp.where(ok, p, 0.0), jnp.where(ok, d, 0.0), ok)

    @classmethod
    def stretched(cls, solution: "ContactSolution", stretch, load_ratio) -> "WarmStart":
        """The start for the same contact at ``load_ratio`` times the load of ``solution``,
        whose contact size is expected to be ``stretch`` times as large: the pressure and
        contact set stretched about the centre of pressure (bilinear and nearest cell), the
        pressure scaled to the new load, the penetration by ``stretch^2`` (Hertz: ``d ~ a^2/R``).

        From the previous load of the paper's reference case (``stretch`` from the stationary
        radius estimates) the stretched set is 20-70 cells off a ~1000-cell contact and the
        solve needs ~15 % fewer operator applications than from the previous set as it was.
        Data only (``stop_gradient``): a start changes the iterations, never the solution."""
        base = cls.of(solution)  # the data, zeroed where there is no usable solution
        s, ratio = (jax.lax.stop_gradient(jnp.asarray(v, float)) for v in (stretch, load_ratio))
        ok = base.valid & (s > 0) & jnp.isfinite(s) & (ratio > 0) & jnp.isfinite(ratio)
        s, ratio = jnp.where(ok, s, 1.0), jnp.where(ok, ratio, 1.0)
        p, mask = jnp.where(ok, base.pressure, 0.0), base.contact
        total = jnp.where(ok, jnp.sum(p), 1.0)
        new_p, new_mask = p, mask.astype(float)
        for axis, n in enumerate(p.shape):
            # target cell i takes the data at c + (i - c)/s (c: centre of pressure on this axis):
            # interpolation matrices, linear for the pressure, nearest cell for the set
            k = jnp.arange(n, dtype=float)
            c = jnp.sum(jnp.moveaxis(p, axis, -1) * k) / total
            src = c + (k - c) / s
            linear = jnp.maximum(0.0, 1.0 - jnp.abs(src[:, None] - k[None, :]))
            nearest = (jnp.round(src)[:, None] == k[None, :]).astype(float)
            new_p = jnp.moveaxis(jnp.tensordot(linear, new_p, axes=(1, axis)), 0, axis)
            new_mask = jnp.moveaxis(jnp.tensordot(nearest, new_mask, axes=(1, axis)), 0, axis)
        new_mask = new_mask > 0.5
        new_p = jnp.where(new_mask, new_p, 0.0) * ratio / s ** p.ndim
        return cls(new_mask & ok, new_p, jnp.where(ok, base.penetration * s * s, 0.0), ok)


def _flat(p, d):
    return jnp.concatenate([p.ravel(), d[None]])


def active_set_loop(step, state0, aux0, max_steps):
    """The primal-dual active-set iteration shared by every contact solver of the library.

    ``step(state, aux) -> (new_state, aux)`` solves the equality-constrained problem on the
    contact set ``state`` (a boolean mask, or any pytree that describes the set, such as an
    interval ``(first, length)``) and returns the next set (cells in contact with ``p > 0``
    plus free cells with ``g < 0``) and any solution data ``aux`` (e.g. the Krylov warm start).
    The loop stops when the set repeats, when ``aux`` holds a non-finite value, or after
    ``max_steps`` steps; it runs on ``stop_gradient`` data (the solvers differentiate the final
    solve on the converged set, never the iteration).

    Returns:
        ``(state, aux, iterations, converged)``.
    """

    def same(a, b):
        return functools.reduce(jnp.logical_and, [jnp.all(x == y) for x, y in zip(
            jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b))], jnp.asarray(True))

    def finite(a):
        return functools.reduce(jnp.logical_and, [jnp.all(jnp.isfinite(x)) for x in jax.tree_util.tree_leaves(a)
                                                  if jnp.issubdtype(x.dtype, jnp.inexact)], jnp.asarray(True))

    def body(c):
        state, aux, it, _ = c
        new, aux = step(state, aux)
        done = same(new, state) | ~finite(aux)
        new = jax.tree_util.tree_map(lambda n, o: jnp.where(done, o, n), new, state)
        return new, aux, it + 1, done

    def cond(c):
        return (~c[3]) & (c[2] < max_steps)

    return jax.lax.while_loop(cond, body, (state0, aux0, jnp.asarray(0), jnp.asarray(False)))


def solve_contact(
    compliance: "WindowedCompliance",
    profile,
    load=None,
    cell_area=None,
    *,
    penetration=None,
    initial_contact=None,
    warm_start: "WarmStart | None" = None,
    tol: float = 1e-10,
    max_steps: int = 50,
    linear_restart: int | None = None,
    linear_maxiter: int | None = None,
    linear_solver: str = "gmres",
    linear_preconditioner: bool | None = None,
    smoothing=None,
) -> "ContactSolution":
    """Solve frictionless steady-state rolling contact of a rigid profile (any dimension).

    Load-controlled (``load``): find ``p >= 0``, ``d`` with ``g = h - d + C p >= 0``,
    ``p g = 0``, ``sum(p) dA = P``. Penetration-controlled (``penetration=d``): the same with
    ``d`` given and no load equation (the load is ``sum(p) dA``). Give exactly one of the two.

    Args:
        compliance: :class:`WindowedCompliance` (non-symmetric allowed).
        profile: ``h`` [m], height of the rigid surface above its lowest point, on the window
            grid (shape ``compliance.shape``).
        load: total load ``P`` [N per unit length in 1D, N in 2D], positive (load mode).
        cell_area: cell size ``dA`` [m in 1D, m^2 in 2D]; required in load mode, not used in
            penetration mode.
        penetration: prescribed rigid-body penetration ``d`` [m] (penetration mode; keyword
            only). ``d <= 0`` gives ``p = 0``.
        initial_contact: boolean initial guess of the contact set (default: load mode, the
            cells where ``h`` lies in the lowest 10 % of its range; penetration mode, the
            geometric overlap ``h < d``).
        warm_start: optional :class:`WarmStart` (a solved neighbour's contact set, pressure and
            penetration; :meth:`WarmStart.stretched`): where valid, it replaces
            ``initial_contact`` and the uniform initial pressure. It changes the number of
            iterations, not the solution (to the tolerance).
        tol: tolerance on the scaled residual (the linear solves use ``1e-3 tol``).
        max_steps: static maximum number of active-set iterations per phase (the loose search,
            then the strict confirmation; see the module docstring).
        linear_solver: static, the linear solver of each contact-set system: ``"gmres"``
            (default; matrix-free restarted GMRES on the FFT operator) or ``"dense"`` (LU on the
            explicit ``(n + 1) x (n + 1)`` system, built by applying the operator to the unit
            vectors: exact to rounding and faster for 1D windows of a few hundred cells).
        linear_restart, linear_maxiter: Krylov basis size and maximum number of restart cycles
            per linear solve (:func:`jaxroll._numerics.gmres`). Default restart: 20 with the
            preconditioner (2D windows: its solves converge in ~10-20 iterations, and every
            Arnoldi step orthogonalises against the whole padded basis, so a shorter basis is
            cheaper), 80 without; maxiter ``1600 // restart``.
        linear_preconditioner: static; right-precondition GMRES with the inverse of the
            folded periodic approximation of ``C`` (:func:`preconditioner_size`) on the contact
            set. Default ``None``: on for 2D windows (the
            3D sphere: 4-5x faster), off in 1D (see the module docstring).
            The converged solution and its derivatives do not depend on it (to the solver
            tolerance); only the number of GMRES iterations does.
        smoothing: ``None`` (default: the exact complementarity above) or a gap scale
            ``eps`` [m] > 0 (traced allowed) for the *smoothed contact edge*: the condition
            ``min(c0 p, g) = 0`` (``c0`` = self compliance, so ``c0 p`` is the gap the cell's
            own pressure closes) is replaced by ``exp(-c0 p/eps) + exp(-g/eps) = 1``, i.e.
            ``smin_eps(c0 p, g) = 0`` with the log-sum-exp soft minimum. Cells whose gap or
            ``c0 p`` is below ~``eps`` share the load partially, so a cell enters the contact
            gradually as the parameters change: the solution is then a smooth (C-infinity)
            function of the compliance, profile and load (or penetration) instead of a
            piecewise smooth one with a kink at every contact-set change (what makes
            least-squares fits on the discrete model stall). Outside the contact the pressure
            decays like ``(eps/c0) exp(-g/eps)``. The exact solution is recovered as ``eps -> 0`` (the
            smoothed and exact problems differ by ``O(eps)`` in ``d`` and at the edge cells).
            Solved by damped Newton on the smoothed equations, started from the exact
            (active-set) solution.
    Never raises on a failed solve: the reason is in ``ContactSolution.result``.

    Returns:
        :class:`ContactSolution`; ``pressure`` and ``penetration`` are differentiable
        (implicit function theorem on the converged contact set) w.r.t. the compliance, the
        profile and the load or the prescribed penetration.
    """
    if (load is None) == (penetration is None):
        raise ValueError("give exactly one of load (load-controlled) and penetration "
                         "(penetration-controlled)")
    if penetration is None and cell_area is None:
        raise ValueError("cell_area is required with a load")
    penetration_mode = penetration is not None
    h = jnp.asarray(profile, dtype=float)
    if h.shape != compliance.shape:
        raise ValueError(f"profile shape {h.shape} does not match the window shape {compliance.shape}")
    value = jnp.asarray(penetration if penetration_mode else load, dtype=float)
    if value.shape != ():
        raise ValueError(f"{'penetration' if penetration_mode else 'load'} must be a scalar; "
                         f"got shape {value.shape}")
    if initial_contact is None:
        if penetration_mode:
            initial_contact = h < jax.lax.stop_gradient(value)
        else:
            hmin, hmax = jnp.min(h), jnp.max(h)
            initial_contact = h <= hmin + 0.1 * (hmax - hmin)
    initial_contact = jnp.asarray(initial_contact, bool)
    if initial_contact.shape != h.shape:
        raise ValueError("initial_contact must have the window shape")
    if linear_solver not in ("gmres", "dense"):
        raise ValueError(f"linear_solver must be 'gmres' or 'dense'; got {linear_solver!r}")
    if smoothing is not None:
        smoothing = eqx.error_if(jnp.asarray(smoothing, dtype=float), ~(jnp.asarray(smoothing) > 0),
                                 "smoothing must be a positive gap scale [m] (or None)")
    precondition = ((len(compliance.shape) == 2) if linear_preconditioner is None
                    else bool(linear_preconditioner)) and linear_solver == "gmres"
    if linear_restart is None:
        linear_restart = 12 if precondition else 80
    if linear_maxiter is None:
        linear_maxiter = 1600 // linear_restart
    warm = None
    if warm_start is not None:
        if warm_start.pressure.shape != h.shape or warm_start.contact.shape != h.shape:
            raise ValueError("warm_start must have the window shape")
        initial_contact = jnp.where(warm_start.valid, warm_start.contact, initial_contact)
        warm = warm_start
    if not penetration_mode:
        value = check_input(value, ~(value > 0), "the load must be positive")
    return _solve_contact(
        compliance,
        h,
        value,
        None if penetration_mode else jnp.asarray(cell_area, dtype=float),
        initial_contact,
        warm,
        smoothing,
        penetration_mode=penetration_mode,
        tol=tol,
        max_steps=max_steps,
        linear_restart=linear_restart,
        linear_maxiter=linear_maxiter,
        linear_solver=linear_solver,
        linear_preconditioner=precondition,
    )


#: Relative residual of the linear solves while the contact set is searched (the final set is
#: confirmed and solved at ``1e-3 tol``; see ``_solve_contact``).
LOOSE_LINEAR_RTOL = 1e-6

#: Floor of the modulus of the preconditioner's Fourier multiplier, relative to its maximum.
_PRECOND_FLOOR = 1e-3


@eqx.filter_jit
def _solve_contact(
    compliance: WindowedCompliance,
    profile,
    value,
    cell_area,
    initial_contact,
    warm,
    smoothing,
    *,
    penetration_mode: bool = False,
    tol: float = 1e-10,
    max_steps: int = 50,
    linear_restart: int = 80,
    linear_maxiter: int = 20,
    linear_solver: str = "gmres",
    linear_preconditioner: bool = True,
) -> ContactSolution:
    shape = compliance.shape
    h = profile
    mask0 = initial_contact

    # ---- scales (preconditioning only; constants for differentiation) ----
    # Unknowns x = (p/p_s, d/g_s). The last equation is last_row(p~, d~) = value / value_s:
    # load mode, load_w sum(p~) = load / load_ng (i.e. dA sum(p) = load); penetration mode,
    # d~ = d / g_s (d pinned; its derivative enters through this right-hand side).
    sg = jax.lax.stop_gradient
    c0 = sg(jnp.abs(compliance.self_compliance))
    if penetration_mode:
        g_s = sg(jnp.maximum(jnp.abs(value), 1e-300))
        p_s = g_s / c0
        value_s = g_s
        load_w = None

        def last_row(pt, dt, lw):
            return dt
    else:
        n0 = jnp.maximum(jnp.sum(mask0), 1).astype(float)
        p_s = sg(value / (cell_area * n0))
        g_s = p_s * c0
        value_s = sg(value)
        load_w = cell_area * p_s / sg(value)

        def last_row(pt, dt, lw):
            return lw * jnp.sum(pt)

    def make_matvec(C, mask, lw):
        maskf = mask.astype(float)

        def matvec(x):
            pt = x[:-1].reshape(shape)
            dt = x[-1]
            gap_rows = maskf * (C(maskf * pt) * (p_s / g_s) - dt) + (1.0 - maskf) * pt
            return jnp.concatenate([gap_rows.ravel(), last_row(maskf * pt, dt, lw)[None]])

        return matvec

    def rhs(hh, mask, target):
        maskf = mask.astype(float)
        return jnp.concatenate([(-maskf * hh / g_s).ravel(), target[None]])

    def lin_solve(mv, b, x0, precond=None, rtol=tol * 1e-3):
        if linear_solver == "dense":  # the operator's matrix, column by column (mv is linear)
            A = jax.vmap(mv, out_axes=1)(jnp.eye(b.shape[0], dtype=b.dtype))
            return jnp.linalg.solve(A, b)
        # right preconditioning: the stopping test is on the true residual |b - A x| <= rtol |b|
        x0 = jnp.zeros_like(b) if x0 is None else x0
        x, _ = gmres(mv, b, x0, atol=rtol * jnp.linalg.norm(b), precond=precond, restart=linear_restart,
                     maxiter=linear_maxiter)
        return x

    # ---- preconditioner: inverse of a periodic (circulant) approximation of C ----
    # For the block system [[B, u], [v^T, c]] (B: gap/pressure rows, u: the d column, v: the last
    # row) with an approximate inverse P of B, the exact block elimination
    #     d = (r2 - v.P r1) / (c - v.P u),  p = P (r1 - u d)
    # is applied. P acts on the cells "in contact" (mask; weights s_i of C) as the inverse of the
    # coefficients folded onto a period of about the window (preconditioner_size: an E-periodic
    # operator, divided by its Fourier multiplier) and as a diagonal elsewhere. The
    # preconditioner uses stop_gradient data only: it changes the GMRES iterations, not the
    # converged solution, so the implicit derivatives are unaffected.
    emb = tuple(preconditioner_size(w) for w in shape)
    # The folded multiplier can vanish: K_0 = 0 (zero-mean periodic displacement) makes the
    # window sum of the influence coefficients, i.e. its q = 0 mode, ~0 when they
    # decay within the window (thin layers). Its modulus is floored at _PRECOND_FLOOR of the
    # largest one (phase kept), so the preconditioner stays bounded; this affects only modes the
    # contact set barely sees (the sphere at the paper's resolution has min/max ~ 3e-3: unchanged).
    mult = jnp.fft.rfftn(fold_offsets(sg(compliance.offsets), emb))
    mod = jnp.abs(mult)
    floor = _PRECOND_FLOOR * jnp.max(mod)
    big = mod >= floor
    one = jnp.ones_like(mult)
    phase = jnp.where(mod > 0, jnp.conj(mult) / jnp.where(mod > 0, mod, 1.0).astype(mult.dtype), one)
    inv_mult = jnp.where(big, one / jnp.where(big, mult, one), phase / floor.astype(mult.dtype))
    scale_inv = g_s / p_s  # C p (p_s/g_s) is the scaled operator

    def circ_inv(r, transpose):
        mult = jnp.conj(inv_mult) if transpose else inv_mult
        return circulant_window_apply(mult, r, emb) * scale_inv

    def make_precond(in_set, w_in, w_out, u, v, c, transpose):
        """M ~ A^-1 (or A^-T). in_set: bool mask; rows on it ~ w_in * (scaled C) on the set,
        rows off it ~ w_out * identity; u, v: window-shaped d column and last row; c: corner."""
        mf = in_set.astype(float)
        w_out = jnp.where(in_set, 1.0, w_out)
        w_in = jnp.where(in_set, w_in, 1.0)
        if transpose:
            u, v = v, u

            def P(r):
                return mf * circ_inv(mf * r, True) / w_in + (1.0 - mf) * r / w_out
        else:
            def P(r):
                return mf * circ_inv(mf * r / w_in, False) + (1.0 - mf) * r / w_out

        Pu = P(u)
        den = c - jnp.sum(v * Pu)
        ok = jnp.abs(den) > 1e-300
        den_safe = jnp.where(ok, den, 1.0)

        def M(r):
            r1 = r[:-1].reshape(shape)
            r2 = r[-1]
            Pr1 = P(r1)
            d = jnp.where(ok, (r2 - jnp.sum(v * Pr1)) / den_safe, r2)
            return _flat(Pr1 - d * Pu, d)

        return M

    def active_set_precond(mask, lw, transpose=False):
        if not linear_preconditioner:
            return None
        mf = mask.astype(float)
        ones = jnp.ones(shape)
        if penetration_mode:
            v, c = jnp.zeros(shape), jnp.asarray(1.0)
        else:
            v, c = lw * mf, jnp.asarray(0.0)
        return make_precond(mask, ones, ones, -mf, v, c, transpose)

    # ---- primal-dual active-set iterations on stop_gradient inputs ----
    C_ng = jax.tree_util.tree_map(sg, compliance)
    h_ng = sg(h)
    b_ratio = sg(value) / value_s
    lw_ng = sg(load_w)
    x_init = _flat(mask0.astype(float), jnp.asarray(0.0))  # uniform pressure on the initial set
    if warm is not None:
        x_init = jnp.where(warm.valid, sg(_flat(jnp.where(mask0, warm.pressure, 0.0) / p_s, warm.penetration / g_s)),
                           x_init)
    eps = 1e-12

    strict = tol * 1e-3
    loose = max(strict, LOOSE_LINEAR_RTOL)

    # Two phases in one loop: the contact set is found with loose linear solves (relative residual
    # LOOSE_LINEAR_RTOL, set decisions beyond 100x that: they need the pressure's sign, not 13
    # digits); once the set repeats (or after max_steps loose steps) the phase turns strict and the
    # same iteration confirms the set with solves at 1e-3 tol, warm started (usually one step, which
    # also catches a set decided wrongly by a loose solve). The state compared for convergence is
    # (set, phase): it repeats only when a strict step keeps the set. One loop body (one GMRES in
    # the program, not one per phase) keeps the compile time down.
    def step(state, aux):
        mask, is_strict = state
        x, k = aux
        rtol = jnp.where(is_strict, strict, loose)
        margin = jnp.where(is_strict, eps, 100.0 * loose)
        mv = make_matvec(C_ng, mask, lw_ng)
        x = lin_solve(mv, rhs(h_ng, mask, b_ratio), x, active_set_precond(mask, lw_ng), rtol)
        pt = x[:-1].reshape(shape)
        gt = h_ng / g_s - x[-1] + C_ng(pt) * (p_s / g_s)
        new = jnp.where(mask, pt > -margin, gt < -margin)
        turn = jnp.all(new == mask) | (k + 1 >= max_steps)
        return (new, is_strict | turn), (x, k + 1)

    (mask, _), (x_ng, _), iters, done = active_set_loop(step, (mask0, jnp.asarray(loose <= strict)),
                                                        (x_init, jnp.asarray(0)), 2 * max_steps)
    mask = sg(mask)
    x_ng = sg(x_ng)

    if smoothing is None:
        # ---- differentiable solution on the converged contact set (implicit function theorem) ----
        # x_ng already solves the system to 1e-3 tol: it is returned as the root of
        # F(x) = A(theta) x - b(theta), and only the derivatives solve again (custom_root: the
        # implicit function theorem, dx = -A^-1 dF, the tangent solve a custom_linear_solve so
        # that reverse mode runs the transposed solve). The forward pass costs no extra solve.
        mv = make_matvec(compliance, mask, load_w)
        b = rhs(h, mask, value / value_s)

        def tangent_solve(g, y):
            return jax.lax.custom_linear_solve(
                g, y,
                solve=lambda f, bb: lin_solve(f, bb, None, active_set_precond(mask, lw_ng)),
                transpose_solve=lambda f, bb: lin_solve(f, bb, None, active_set_precond(mask, lw_ng, True)),
            )

        x = jax.lax.custom_root(lambda x: mv(x) - b, x_ng, lambda f, x0: x0, tangent_solve)
    else:
        # ---- smoothed contact edge: damped Newton on smin_eps(c0 p, g) = 0 from the exact solution ----
        # scaled variables as above (p~ = p/p_s, g~ = g/g_s, c0 p/g_s = p~); eps~ = eps/g_s
        eps_t = smoothing / g_s
        c0_ratio = jnp.abs(compliance.self_compliance) / c0  # 1, carries the derivative of c0

        def smoothed_residual(x, C, hh, ratio, eps, lw, target):
            pt = x[:-1].reshape(shape)
            gt = hh / g_s - x[-1] + C(pt) * (p_s / g_s)
            a = ratio * pt
            F = -eps * jnp.logaddexp(-a / eps, -gt / eps)
            return jnp.concatenate([F.ravel(), (last_row(pt, x[-1], lw) - target)[None]]), a, gt

        eps_ng = sg(eps_t)

        def residual_ng(x):
            return smoothed_residual(x, C_ng, h_ng, 1.0, eps_ng, lw_ng, b_ratio)

        def jacobian_matvec(a, gt):
            w_a = jax.nn.sigmoid((gt - a) / eps_ng)  # d smin / d a; d smin / d g = 1 - w_a

            def matvec(v):
                vp = v[:-1].reshape(shape)
                rows = w_a * vp + (1.0 - w_a) * (C_ng(vp) * (p_s / g_s) - v[-1])
                return jnp.concatenate([rows.ravel(), last_row(vp, v[-1], lw_ng)[None]])

            return matvec

        def jacobian_precond(a, gt, transpose=False):
            if not linear_preconditioner:
                return None
            w_a = jax.nn.sigmoid((gt - a) / eps_ng)
            in_set = w_a < 0.5  # gap-dominated rows (the contact): ~ (1 - w_a) C
            if penetration_mode:
                v, c = jnp.zeros(shape), jnp.asarray(1.0)
            else:
                v, c = lw_ng * jnp.ones(shape), jnp.asarray(0.0)
            return make_precond(in_set, 1.0 - w_a, w_a, -(1.0 - w_a), v, c, transpose)

        alphas = 0.5 ** jnp.arange(10.0)

        def newton(state):
            # carries the residual and soft-min arguments of the current iterate (one evaluation
            # per trial step: the accepted trial's values become the next iterate's)
            x, (F, a, gt), it, _ = state
            step = lin_solve(jacobian_matvec(a, gt), -F, None, jacobian_precond(a, gt))
            trials = jax.vmap(lambda al: residual_ng(x + al * step))(alphas)
            merit = jnp.sum(trials[0] ** 2, axis=1)
            ok = merit <= (1.0 - 1e-4 * alphas) * jnp.sum(F * F)  # Armijo on |F|^2
            k = jnp.where(jnp.any(ok), jnp.argmax(ok), alphas.size - 1)
            x = x + alphas[k] * step
            res_k = jax.tree_util.tree_map(lambda t: t[k], trials)
            done = (jnp.max(jnp.abs(res_k[0])) <= tol) | ~jnp.all(jnp.isfinite(x))
            return x, res_k, it + 1, done

        x_s, (F_s, a_s, gt_s), n_it, n_done = jax.lax.while_loop(
            lambda s: (~s[3]) & (s[2] < max_steps), newton,
            (x_ng, residual_ng(x_ng), jnp.asarray(0), jnp.asarray(False)),
        )
        x_s, F_s, a_s, gt_s = sg(x_s), sg(F_s), sg(a_s), sg(gt_s)
        # differentiable: one Newton correction whose right-hand side carries the parameter
        # dependence (implicit function theorem: dx = -J^{-1} dF; the value is unchanged to tol)
        F_theta, _, _ = smoothed_residual(x_s, compliance, h, c0_ratio, eps_t, load_w,
                                          value / value_s)
        x = x_s + jax.lax.custom_linear_solve(
            jacobian_matvec(a_s, gt_s),
            -F_theta,
            solve=lambda f, bb: lin_solve(f, bb, None, jacobian_precond(a_s, gt_s)),
            transpose_solve=lambda f, bb: lin_solve(f, bb, None, jacobian_precond(a_s, gt_s, True)),
        )

    pt = x[:-1].reshape(shape)
    p = pt * p_s
    d = value if penetration_mode else x[-1] * g_s  # the given d exactly (x[-1] g_s = d to tol)
    u = compliance(p)
    g = h - d + u

    # ---- diagnostics ----
    if smoothing is None:
        gs = sg(g / g_s)
        comp = jnp.max(jnp.abs(jnp.minimum(sg(pt), gs)))
        # the linear system's residual from the same displacement: g on the set, p off it, the
        # load (or penetration) row (the off-set p enters u only at the solve's own tolerance)
        lin_res = jnp.maximum(jnp.max(jnp.abs(jnp.where(mask, gs, sg(pt)))),
                              jnp.abs(sg(last_row(jnp.where(mask, pt, 0.0), x[-1], load_w) - value / value_s)))
        residual = sg(jnp.maximum(comp, lin_res))
    else:
        mask = sg(gt_s < a_s)  # cells where the contact condition is the gap one (c0 p > g)
        iters = iters + n_it
        done = done & n_done
        residual = jnp.max(jnp.abs(F_s))

    edge = _edge_mask(shape)
    touches = jnp.any(mask & edge)
    finite = jnp.all(jnp.isfinite(p)) & jnp.isfinite(d)
    result = first_failure((~finite, RESULTS.nonfinite), (touches, RESULTS.window_too_small),
                           (~done, RESULTS.max_steps_reached), (residual > tol * 1e3, RESULTS.linear_solve_failed))
    return ContactSolution(
        pressure=p,
        penetration=d,
        contact=mask,
        gap=g,
        displacement=u,
        iterations=iters,
        residual=residual,
        result=result,
    )


def _edge_mask(shape):
    """Boolean array, True on the outer cells of the window."""
    m = np.zeros(shape, bool)
    for k in range(len(shape)):
        sl = [slice(None)] * len(shape)
        sl[k] = 0
        m[tuple(sl)] = True
        sl[k] = -1
        m[tuple(sl)] = True
    return jnp.asarray(m)


def edge_gap_scale(kappa, cell_size, contact_radius, radius):
    """Gap scale ``eps`` [m] for ``smoothing`` of :func:`solve_contact`: ``kappa a^{3/2} c^{1/2} / R``.

    Near the edge of a Hertz contact (sphere or cylinder) of radius/half-width ``c`` and
    penetration ``~ c^2/R`` the gap grows like ``(c^2/R) (s/c)^{3/2}`` with the distance ``s``
    outside the edge, so this is (up to an O(1) factor) the gap one cell of size ``a`` outside
    the edge, and ``kappa`` measures the smoothing in cells. Give a smooth estimate of ``c``
    (e.g. the Hertz/Jaffar radius), never the discrete contact size, or the smoothed solution
    stops being smooth in the parameters. ``kappa = None`` returns ``None`` (no smoothing).
    """
    if kappa is None:
        return None
    return kappa * cell_size * jnp.sqrt(cell_size * contact_radius) / radius
