"""Compliance kernels and the windowed Toeplitz operator of the contact solvers.

Discretisation and Fourier convention
-------------------------------------
The period ``L_k`` of axis ``k`` is split into ``N_k`` cells of width ``dx_k = L_k/N_k``. The
pressure is **piecewise constant** on the cells; the surface displacement ``u`` (positive into
the layer) is **collocated at the cell centres**. A Fourier mode is ``e^{+i q.x}`` with
``q_k = 2 pi m_k / L_k`` (``m_k`` any integer); ``T(q)`` is the layer's surface compliance
(:func:`jaxroll.engines.layer.surface_compliance`, displacement per unit pressure of that mode).

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
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

__all__ = [
    "WindowedCompliance",
    "WindowKernel",
    "periodic_kernel",
    "periodic_offsets",
    "windowed_compliance",
    "periodic_window_kernel",
    "toeplitz_operator",
    "embedding_size",
    "fold_offsets",
    "circulant_window_apply",
]


def _alternating_inverse_square(a):
    """``sum_{k>=0} (-1)^k / (a + k)^2`` for ``a > 0`` (numpy, trace-time constant)."""
    import scipy.special as sps  # here, not at import: a program loaded from the cache needs no SciPy

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
        K, K2 = _line_alias_sum(compliance_fn, ws[0], dxs[0], M, dissipation)
    else:
        T = compliance_fn(*qs)
        img_axes = tuple(range(ndim, 2 * ndim))
        K = jnp.sum(T * S.astype(complex), axis=img_axes)
        K2 = None
        if dissipation:
            K2 = jnp.sum(qs[0] * jnp.imag(T) * S * S, axis=img_axes)
    return (K, K2) if dissipation else K


def _line_alias_sum(compliance_fn, z, dx, M, dissipation):
    """The 1D alias sum of :func:`periodic_kernel`: ``2M`` explicit images and the analytic tail.

    ``z = r/N`` are the normalised base wavenumbers (``q = 2 pi z/dx``). The base column
    (``l = 0``) and the images are evaluated in two calls: every image has ``|q| >= pi/dx``, so a
    compliance function can take a cheaper branch for them at run time (e.g. the half-space form
    of a layer much thicker than a cell, see :func:`jaxroll.engines.cylinder.compliance_function`); the
    values are the same either way. Image columns: ``l = -M..M-1`` without 0, then the first
    omitted image on each side (``l = M`` and ``-M-1``) for the tail. All weights are trace-time
    constants: with ``q = 2 pi w/dx``, the tail weight ``dx |q| / (2 pi^2)`` is ``|w|/pi``.

    Returns:
        ``(K, K2)``, ``K2 = None`` unless ``dissipation``.
    """
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
    if not dissipation:
        return K, None
    # q Im T S^2 on the explicit images; tail dx sz^2/(2 pi^3) q|q| Im T zeta(3, .)
    import scipy.special as sps

    wt2 = np.concatenate(
        [
            2.0 * np.pi * w_img[:, :-2] * np.sinc(w_img[:, :-2]) ** 2,
            np.stack([2.0 * sz**2 * a_hi**2 * sps.zeta(3.0, a_hi),
                      -2.0 * sz**2 * a_lo**2 * sps.zeta(3.0, a_lo)], axis=-1) / np.pi,
        ],
        axis=-1,
    )
    K2 = (jnp.imag(T_base) * (2.0 * np.pi * z * np.sinc(z) ** 2) + jnp.sum(jnp.imag(T_img) * wt2, axis=-1)) / dx
    return K, K2


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
        symbol: ``None``, or the ``rfftn``-layout Fourier multiplier of the layer's compliance
            on the embedding's own period (:attr:`embedding` cells per axis, the alias sum (1)
            of the layer's ``T S`` on that period): a circulant approximation of this operator
            without the truncation at the window's offsets, which the preconditioner inverts
            instead of :attr:`multiplier` (:mod:`jaxroll.contact.precondition`). Not used to
            apply the operator.
    """

    multiplier: jax.Array
    offsets: jax.Array
    shape: tuple = eqx.field(static=True)
    symbol: jax.Array | None = None

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

    def with_symbol(self, symbol) -> "WindowedCompliance":
        """This operator with :attr:`symbol` set (the same operator; only its preconditioner
        changes)."""
        return WindowedCompliance(self.multiplier, self.offsets, self.shape, symbol)

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
    paper's 55 x 55 window in a 112 x 112 embedding on CPU. Where the window fills more than half
    of every axis (a folded period, :func:`~jaxroll.contact.precondition.folded_size`) there is
    little to prune and the full pair is used (55 x 55 in 56 x 56: 21.9 against 24.3 us).
    """
    shape = p.shape
    d = len(shape)
    if all(2 * w > e for w, e in zip(shape, embedding)):
        return jnp.fft.irfftn(multiplier * jnp.fft.rfftn(p, s=embedding), s=embedding)[tuple(slice(w) for w in shape)]
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
    :func:`periodic_kernel` (``dissipation=True``) or :func:`jaxroll.engines.sphere3d.sphere_kernel`.

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
