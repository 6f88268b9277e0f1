r"""Influence coefficients of an infinite layer on a window of cells (no period).

A window of ``W`` cells per axis (cell size ``dx``, piecewise-constant pressure, displacement
collocated at the cell centres) only ever needs the layer's influence coefficients between its
own cells: ``2 W - 1`` offsets per axis. On an infinite layer they are Fourier integrals (the
``L -> infinity`` limit of the periodic alias sum of :mod:`jaxroll.contact`, eq. (1))::

    c(delta)  = dA (2 pi)^-d  int T(q) S(q) e^{i q.delta} d^d q            (compliance, [m/Pa])
    D(delta)  =    (2 pi)^-d  int q_x Im T(q) S(q)^2 e^{i q.delta} d^d q    (dissipation)

with ``S(q) = prod_k sinc(q_k dx/2)`` the load-patch factor, ``dA = dx^d`` and ``d = 1`` (plane
strain) or ``2`` (the 3D surface). ``T(-q_x, q_y) = conj T(q_x, q_y)`` and ``T`` is even in
``q_y``, so both reduce to integrals over ``q_k >= 0``:
``c = (dA/pi^d) Re int_0^inf ... e^{i q_x delta_x} cos(q_y delta_y)``, and ``D`` likewise with
cosines. Their cost depends on the window and the accuracy asked, never on ``V tau``: the
slowest material memory only moves features of ``T`` toward ``q -> 0``, where the quadrature
below is graded.

Quadrature (per axis, in the dimensionless wavenumber ``w = q dx/(2 pi)``; the cell-centre phase
is ``e^{2 pi i w j}`` for the offset ``j`` cells, independent of ``dx``):

* ``0 < w < 1/N_f`` (``N_f = 2 W``, so that ``e^{2 pi i w j}`` turns by less than a half turn):
  Gauss-Legendre panels graded by factors of 4 from ``w = 1e-12`` up, 8 nodes each. A pole of
  ``T`` at ``i w_0`` (a relaxation or retardation time ``lambda`` at ``w_0 = dx/(2 pi V
  lambda)``, the layer's own scale ``dx/(2 pi H)``) sits at least one panel width off each
  panel, which bounds the panel error near ``3^{-16}`` wherever ``w_0`` lies. Below ``1e-12``
  the integrand is bounded, so that strip contributes ``< 1e-12`` relative.
* ``1/N_f < w < w_Q``: uniform panels of width ``1/N_f``, 8 Gauss nodes each. The panel sum is
  an exact discrete Fourier transform in the panel index: each of the 8 node sets is folded
  modulo ``N_f`` and transformed by one FFT of size ``N_f``, so the cost is
  ``O(8 w_Q N_f + 8 N_f log N_f)``, not (offsets x nodes).
* ``w > w_Q`` (1D only): ``T`` is replaced by its local asymptote ``C/q`` (``C = Q T(Q)``), whose
  integrals against the load-patch factor have closed forms in the sine and cosine integrals
  (the same tail model as the 1D periodic kernel). In 3D the integral is truncated at
  ``|w_k| <= w_Q = 1``, the same cut-off as the periodic model's default (``n_terms`` = cells per
  period), so that the periodic model converges to this one as its period grows.

The 1D half-space (plane strain, ``T ~ 1/|q|``) has a logarithmically divergent kernel: the
displacement of a 2D half-space is defined up to a constant, which the penetration absorbs
(the load is prescribed, or, for the slices, a penetration relative to a reference level). It
is made finite by subtracting ``e^{-q l}`` from the phase, ``l = W dx`` (the window length):
the displacement is measured from the level of a point ~``l`` away. Layers of finite thickness
have finite kernels and are used as they are (``T_1(0)`` is finite).

Quasi-static layers (``rho = 0``): ``T = T_1(|q|)/conj G*(q_x V)``. In 3D the ``q_y`` integral of
``T_1 S_y`` is done once per grid (speed independent); each speed costs one ``G*`` per ``q_x``
node and one transform along x. ``T_1`` is the half-space's ``(1 - nu)/q`` plus a layer
correction that is exponentially small for ``qH > 20``: the half-space part's integrals are a
constant of the window (scaled by ``dx``), and the correction is summed, on the same nodes, only
where it is not negligible (:func:`layer_factor_pair`): at the window 55, 5 of its 36 tiles
(8 % of the ``K^2`` nodes) for a layer 20 cells thick, 3 (5 %) from 50 cells up. Layers with inertia (``T`` per speed) sum all nodes, chunked over
``q_x`` so the memory stays ~``chunk x nodes`` (:func:`surface_factor_pair`).
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import scipy.special as sps

from .. import contact as _contact

__all__ = ["FourierRule", "fourier_rule", "layer_factor_pair", "line_window_kernel", "surface_factor",
           "surface_factor_pair", "surface_window_kernel"]

#: Gauss-Legendre nodes per panel.
NODES_PER_PANEL = 8
#: Lowest dimensionless wavenumber of the graded panels (the strip below is neglected).
W_LOW = 1e-12
#: Grading factor of the low-wavenumber panels.
GRADING = 4.0
#: Upper end of the quadrature: ``w_Q`` in 1D (beyond it the analytic tail), the cut-off in 3D.
W_TAIL_LINE = 8
W_CUT_SURFACE = 1
#: x-nodes per chunk of the speed-independent 3D layer integral (memory ~ chunk x nodes).
SURFACE_CHUNK = 64
#: Nodes per side of the tiles of :func:`layer_factor_pair` (the correction near ``q = 0``).
LAYER_TILE = 128


class FourierRule:
    """Trace-time quadrature of ``F_j = int_0^{w_Q} f(w) e^{2 pi i w j} dw`` for the offsets
    ``j = -(W - 1) .. W - 1`` (see the module docstring).

    Attributes (NumPy):
        w: all nodes, the graded ones first, then the uniform ones panel by panel (``(K,)``).
        weight: quadrature weights (``(K,)``; zero on the first uniform panel, covered by the
            graded ones).
        window: ``W``; n_fold: ``N_f``; n_graded: number of graded nodes; w_max: ``w_Q``.
    """

    def __init__(self, window: int, w_max: int):
        self.window, self.w_max = int(window), int(w_max)
        self.n_fold = 2 * self.window
        x, wx = np.polynomial.legendre.leggauss(NODES_PER_PANEL)
        u, wu = 0.5 * (x + 1.0), 0.5 * wx  # nodes and weights on [0, 1]
        top = 1.0 / self.n_fold
        n_graded = max(1, int(math.ceil(math.log(top / W_LOW) / math.log(GRADING))))
        edges = top * GRADING ** -np.arange(n_graded, -1, -1.0)
        lo, width = edges[:-1], np.diff(edges)
        wg = (lo[:, None] + width[:, None] * u[None, :]).ravel()
        weg = (width[:, None] * wu[None, :]).ravel()
        n_panels = self.w_max * self.n_fold
        p = np.arange(n_panels)
        wuni = ((p[:, None] + u[None, :]) / self.n_fold).ravel()
        weuni = (np.where(p >= 1, 1.0, 0.0)[:, None] * wu[None, :] / self.n_fold).ravel()
        self.u = u
        self.n_graded = wg.size
        self.w = np.concatenate([wg, wuni])
        self.weight = np.concatenate([weg, weuni])
        j = np.arange(-(self.window - 1), self.window)
        self.offsets = j
        self._graded_phase = np.exp(2j * np.pi * np.outer(j, wg))  # (2W-1, Kg)
        self._node_phase = np.exp(2j * np.pi * np.outer(j, u) / self.n_fold)  # (2W-1, 8)

    def transform(self, f):
        """``F_j = sum_k weight_k f_k e^{2 pi i w_k j}`` for ``f`` of shape ``(K, ...)`` (node axis
        first, any trailing batch axes): shape ``(2 W - 1, ...)``, complex."""
        f = jnp.asarray(f)
        batch = f.shape[1:]
        fw = f * jnp.asarray(self.weight.reshape((-1,) + (1,) * len(batch)), f.dtype)
        g = fw[: self.n_graded]
        out = jnp.tensordot(self._graded_phase, g.astype(complex), axes=1)
        uni = fw[self.n_graded:].reshape((self.w_max, self.n_fold, NODES_PER_PANEL) + batch).sum(axis=0)
        # sum_r g_r e^{2 pi i r j / N_f} = N_f ifft(g)_j (j taken modulo N_f)
        G = self.n_fold * jnp.fft.ifft(uni, axis=0)
        G = jnp.take(G, np.mod(self.offsets, self.n_fold), axis=0)  # (2W-1, 8, ...)
        phase = self._node_phase.reshape(self._node_phase.shape + (1,) * len(batch))
        return out + jnp.sum(phase * G, axis=1)

    def cosine(self, f):
        """``int_0^{w_Q} f(w) cos(2 pi w m) dw`` for ``m = 0 .. W - 1`` (real or complex ``f``)."""
        F = self.transform(f)
        W = self.window
        cos = 0.5 * (F[W - 1:] + F[W - 1::-1])
        return cos if jnp.iscomplexobj(f) else jnp.real(cos)


@functools.lru_cache(maxsize=64)
def fourier_rule(window: int, w_max: int) -> FourierRule:
    """The cached :class:`FourierRule` of a window (static sizes)."""
    return FourierRule(window, w_max)


# ---------------------------------------------------------------------------------------------
# closed-form tails (1D)
# ---------------------------------------------------------------------------------------------


def _int_sin_over_w2(beta, a):
    """``int_a^inf sin(beta w)/w^2 dw`` (NumPy, elementwise in ``beta``; ``a > 0``)."""
    b = np.abs(beta)
    si, ci = sps.sici(np.where(b > 0, b * a, 1.0))
    val = np.where(b > 0, np.sin(b * a) / a - b * ci, 0.0)
    return np.sign(beta) * val


def _int_cos_over_w2(beta, a):
    """``int_a^inf cos(beta w)/w^2 dw`` (NumPy, elementwise in ``beta``; ``a > 0``)."""
    b = np.abs(beta)
    si, ci = sps.sici(np.where(b > 0, b * a, 1.0))
    return np.where(b > 0, np.cos(b * a) / a - b * (0.5 * np.pi - si), 1.0 / a)


@functools.lru_cache(maxsize=64)
def _line_tails(window: int, w_max: int):
    """``(tau_j, sigma_j)``: ``int_{w_Q}^inf sin(pi w) e^{2 pi i w j}/w^2 dw`` and
    ``int_{w_Q}^inf sinc(w)^2 cos(2 pi w j) dw`` for the window offsets ``j``."""
    j = np.arange(-(window - 1), window).astype(float)
    a = float(w_max)
    bp, bm = np.pi * (1.0 + 2.0 * j), np.pi * (1.0 - 2.0 * j)
    tau = 0.5 * (_int_sin_over_w2(bp, a) + _int_sin_over_w2(bm, a)) \
        + 0.5j * (_int_cos_over_w2(bm, a) - _int_cos_over_w2(bp, a))
    sigma = (0.5 * _int_cos_over_w2(2.0 * np.pi * j, a)
             - 0.25 * (_int_cos_over_w2(2.0 * np.pi * (1.0 + j), a) + _int_cos_over_w2(2.0 * np.pi * (1.0 - j), a)))
    return tau, sigma / np.pi**2


@functools.lru_cache(maxsize=8)
def _tail_rule():
    """Nodes ``u`` and weights on ``(0, 1]``, graded by factors of 4 toward 0 (``u = w_Q/w``)."""
    x, wx = np.polynomial.legendre.leggauss(NODES_PER_PANEL)
    u, wu = 0.5 * (x + 1.0), 0.5 * wx
    n = int(math.ceil(math.log(1.0 / W_LOW) / math.log(GRADING)))
    edges = GRADING ** -np.arange(n, -1, -1.0)
    lo, width = edges[:-1], np.diff(edges)
    return (lo[:, None] + width[:, None] * u).ravel(), (width[:, None] * wu).ravel()


def _dissipation_tail_correction(compliance_fn, dx, window):
    """The non-oscillating part of the dissipation tail beyond ``w_Q`` that the ``C/q`` model
    misses (in units of ``D pi/scale``).

    ``sinc(w)^2 cos(2 pi w j)`` has a non-oscillating part ``1/(2 pi^2 w^2)`` at ``j = 0`` and
    ``-1/(4 pi^2 w^2)`` at ``j = +-1``; against it the tail of ``g = q Im T`` is integrated
    exactly (``u = w_Q/w``, graded nodes, so any local power law of ``Im T`` is followed: ``Im T``
    falls like ``1/q^2`` above the material's transition and is ~constant below it). The
    oscillating parts keep the closed-form ``C/q`` model: their error is ``O(g'/(2 pi j)^2)``.
    """
    scale = 2.0 * jnp.pi / dx
    u, wt = _tail_rule()
    wq = float(W_TAIL_LINE)
    Q = scale * wq
    g = scale * (wq / u) * jnp.imag(compliance_fn(scale * wq / u))
    g_model = Q * jnp.imag(compliance_fn(jnp.reshape(Q, (1,)))[0])
    E = jnp.sum(wt * (g - g_model)) / (np.pi**2 * wq)
    j = np.arange(-(window - 1), window)
    return E * np.where(j == 0, 0.5, np.where(np.abs(j) == 1, -0.25, 0.0))


# ---------------------------------------------------------------------------------------------
# plane strain (the cylinder and the slices)
# ---------------------------------------------------------------------------------------------


def line_offsets(compliance_fn, dx, window: int, halfspace):
    """Influence coefficients ``(c, D)`` of an infinite plane-strain layer at the offsets
    ``-(W - 1) .. W - 1`` cells.

    Args:
        compliance_fn: ``T(q)`` [m/Pa] of a real wavenumber array [rad/m] (elementwise, complex),
            e.g. :func:`jaxroll.engines.cylinder.compliance_function`.
        dx: cell width [m] (traced allowed).
        window: static ``W``.
        halfspace: (traced) bool, True for an infinite thickness: the kernel is referred to the
            level at a distance ``~ W dx`` (see the module docstring).

    Returns:
        ``c`` [m/Pa], ``D`` [m/Pa per m^2] (``R_r = dx^2 p.(D p)``), each of shape ``(2 W - 1,)``.
    """
    rule = fourier_rule(window, W_TAIL_LINE)
    scale = 2.0 * jnp.pi / dx
    w = rule.w
    T = compliance_fn(scale * w)
    S = np.sinc(w)
    F = rule.transform(T * S.astype(complex))
    # half-space reference level: subtract int T S e^{-q l} (l = W dx, a dx-free phase e^{-2 pi w W})
    ref = jnp.sum((rule.weight * np.exp(-2.0 * np.pi * w * window) * S).astype(complex) * T)
    F = F - jnp.where(halfspace, ref, 0j)
    tau, sigma = _line_tails(window, W_TAIL_LINE)
    Q = scale * W_TAIL_LINE
    C = compliance_fn(jnp.reshape(Q, (1,)))[0] * jax.lax.complex(Q, jnp.zeros_like(Q))
    # c = (dx/pi) Re int_0^inf T S e^{i q delta} dq, dq = scale dw; tail: C/q -> (dx/pi^2) Re(C tau)
    c = (dx / jnp.pi) * scale * jnp.real(F) + (dx / jnp.pi**2) * jnp.real(C * tau)
    # D = (1/pi) int_0^inf q Im T S^2 cos(q delta) dq; tail: q Im T -> Im C
    Fd = rule.transform(scale * w * jnp.imag(T) * S * S)
    D = (scale / jnp.pi) * (jnp.real(Fd) + jnp.imag(C) * sigma + _dissipation_tail_correction(compliance_fn, dx, window))
    return c, D


def line_window_kernel(compliance_fn, dx, window: int, halfspace) -> _contact.WindowKernel:
    """:class:`jaxroll.contact.WindowKernel` of an infinite plane-strain layer (see
    :func:`line_offsets`)."""
    c, D = line_offsets(compliance_fn, dx, window, halfspace)
    return _contact.WindowKernel(compliance=_contact.toeplitz_operator(c),
                                 dissipation=_contact.toeplitz_operator(D))


# ---------------------------------------------------------------------------------------------
# the 3D surface (the sphere)
# ---------------------------------------------------------------------------------------------


def _surface_chunks(chunk_fn, dx, window: int):
    """``chunk_fn(t_of, rule, w)`` over the x nodes of the surface rule in chunks of
    ``SURFACE_CHUNK`` (``lax.map``), ``t_of(t_fn)`` the ``(K_y, chunk)`` values of ``t_fn``;
    the outputs (each ``(chunk, ...)``) concatenated over the ``K`` x nodes."""
    rule = fourier_rule(window, W_CUT_SURFACE)
    scale = 2.0 * jnp.pi / dx
    w = rule.w
    K = w.size
    n_chunks = -(-K // SURFACE_CHUNK)
    wx = np.concatenate([w, np.full(n_chunks * SURFACE_CHUNK - K, w[-1])]).reshape(n_chunks, SURFACE_CHUNK)

    # rematerialised in reverse mode: a chunk's intermediates (the layer compliance's dozens of
    # (K_y, chunk) arrays) are recomputed by the backward pass instead of being stacked over the
    # chunks, which XLA:CPU did by copying the stacks at every step (a gradient through a layer
    # with inertia cost 3.4 s against 0.05 s for its forward pass, 2026-11-26)
    @jax.checkpoint
    def chunk(wxc):
        return chunk_fn(lambda t_fn: t_fn(scale * wxc[None, :], scale * w[:, None]), rule, w)

    out = jax.lax.map(chunk, jnp.asarray(wx))
    return jax.tree_util.tree_map(lambda x: x.reshape((n_chunks * SURFACE_CHUNK,) + x.shape[2:])[:K], out)


def surface_factor(t_fn, dx, window: int, squared: bool):
    """``A(i, m) = int_0^{w_Q} t(q_x_i, q_y) S(q_y)^s cos(2 pi w_y m) dw_y`` for every x node
    ``i`` of the rule and ``m = 0 .. W - 1`` (``s = 2`` if ``squared`` else 1), chunked over the x
    nodes (``lax.map``) so the working memory is ``SURFACE_CHUNK x K``.

    Args:
        t_fn: ``t(q_x, q_y)`` of broadcasting wavenumber arrays [rad/m] (real or complex).
    """
    def chunk(t_of, rule, w):
        t = t_of(t_fn)  # (K_y, chunk)
        return rule.cosine(t * jnp.asarray(np.sinc(w)[:, None] ** (2 if squared else 1), t.dtype)).T  # (chunk, W)

    return _surface_chunks(chunk, dx, window)


def surface_factor_pair(t_fn, dx, window: int, imag_second: bool = False):
    """``(A, B)``: :func:`surface_factor` of ``t_fn`` with ``S_y`` and with ``S_y^2`` (of
    ``Im t`` for ``B`` with ``imag_second``), from one evaluation of ``t`` per node: a layer's
    speed-independent integrals, or a compliance evaluated per speed (a layer with inertia, a
    ply stack), cost one pass instead of two."""
    def chunk(t_of, rule, w):
        t = t_of(t_fn)
        sy = np.sinc(w)[:, None]
        b = jnp.imag(t) if imag_second else t
        return rule.cosine(t * jnp.asarray(sy, t.dtype)).T, rule.cosine(b * jnp.asarray(sy**2, b.dtype)).T

    return _surface_chunks(chunk, dx, window)


@functools.lru_cache(maxsize=16)
def _layer_factor_constants(window: int):
    """NumPy constants of :func:`layer_factor_pair`: ``C`` (``(K_t, 2W)``), the rule's cosine sums
    as one matrix, ``C[k] = weight_k (S_k cos(2 pi w_k m), S_k^2 cos(2 pi w_k m))`` for
    ``m = 0 .. W-1`` (rows past ``K`` zero: the nodes padded to whole tiles, at ``w = 1``);
    ``half`` (``(K, 2W)``), the y-integrals of the half-space ``1/q`` at ``dx = 1`` on every x
    node, ``(1/(2 pi |w|)) @ C`` (the same rule, summed directly instead of by FFT); ``w``
    (``(K_t,)``, padded); and the tiles ``(i, j)`` (``i <= j``, tile indices) with ``r``, the
    smallest ``|w|`` of their nodes."""
    rule = fourier_rule(window, W_CUT_SURFACE)
    w, K, B = rule.w, rule.w.size, LAYER_TILE
    n = -(-K // B)
    cos = rule.weight[:, None] * np.cos(2.0 * np.pi * np.outer(w, np.arange(window)))
    s = np.sinc(w)[:, None]
    C = np.concatenate([cos * s, cos * s * s], axis=1)
    half = (0.5 / np.pi / np.hypot(w[:, None], w[None, :])) @ C
    w_pad = np.concatenate([w, np.ones(n * B - K)])
    C = np.concatenate([C, np.zeros((n * B - K, C.shape[1]))])
    low = w_pad.reshape(n, B).min(axis=1)
    i, j = np.triu_indices(n)
    return C, half, w_pad, i, j, np.hypot(low[i], low[j])


def layer_factor_pair(t1_fn, t_inf, q_cut, dx, window: int):
    """``(A, B)`` of :func:`surface_factor_pair` for a radial real ``t(q_x, q_y) = t1_fn(|q|)``
    [m] that equals its half-space asymptote ``t_inf/|q|`` to rounding for ``|q| >= q_cut``
    (:func:`jaxroll.engines.layer.halfspace_asymptote`): the same quadrature, split as
    ``t = t_inf/q + (t - t_inf/q)``.

    The half-space part is thickness independent, ``t_inf dx/(2 pi |w|)``: its integrals are a
    constant of the window (:func:`_layer_factor_constants`) times ``t_inf dx``. The correction
    vanishes outside the disc ``|w| < w_c = q_cut dx/(2 pi)``; it is summed on the rule's own
    nodes in tiles of ``LAYER_TILE^2`` nodes (a ``lax.scan`` over the tiles ``i <= j``: ``q`` is
    symmetric in ``(x, y)``), each one only if it reaches into the disc (``lax.cond``), by matrix
    products with the cosine sums. A layer ``H`` cells thick needs ``|w| < 3.2/(H/dx)``. Equal
    to :func:`surface_factor_pair` up to rounding and the dropped correction
    (tests/test_aperiodic.py). Under a batched ``jax.vmap`` every tile runs (the conditions
    become selects): the full square once.

    Args:
        t1_fn: ``t1(|q|)`` of a wavenumber array [rad/m] (e.g. :func:`jaxroll.engines.layer.static_compliance`).
        t_inf: the asymptote's coefficient ``t1 |q|`` (static float, ``1 - nu`` for a layer).
        q_cut: wavenumber [rad/m] beyond which ``t1`` equals ``t_inf/q`` (traced; 0: ``t1`` is the half-space).
        dx: cell size [m]; window: static ``W``.
    """
    C, half, w, ti, tj, r = _layer_factor_constants(window)
    B, K, W = LAYER_TILE, half.shape[0], window
    scale = 2.0 * jnp.pi / dx
    w_cut = q_cut / scale
    C, w = jnp.asarray(C), jnp.asarray(w)

    def tile(acc, ij):
        i, j = ij[0] * B, ij[1] * B
        q = scale * jnp.hypot(jax.lax.dynamic_slice_in_dim(w, i, B)[:, None], jax.lax.dynamic_slice_in_dim(w, j, B))
        g = t1_fn(q) - t_inf / q  # (x nodes of tile i, y nodes of tile j)
        acc = jax.lax.dynamic_update_slice_in_dim(
            acc, jax.lax.dynamic_slice_in_dim(acc, i, B) + g @ jax.lax.dynamic_slice_in_dim(C, j, B), i, 0)
        mirror = jnp.where(ij[0] < ij[1], g.T, 0.0) @ jax.lax.dynamic_slice_in_dim(C, i, B)
        return jax.lax.dynamic_update_slice_in_dim(acc, jax.lax.dynamic_slice_in_dim(acc, j, B) + mirror, j, 0)

    def step(acc, xs):
        ij, r_tile = xs
        return jax.lax.cond(r_tile < w_cut, tile, lambda acc, _: acc, acc, ij), None

    acc = jnp.zeros(C.shape, jnp.result_type(dx, float))
    acc = jax.lax.scan(step, acc, (jnp.asarray(np.stack([ti, tj], axis=1)), jnp.asarray(r)))[0]
    out = t_inf * dx * jnp.asarray(half) + acc[:K]
    return out[:, :W], out[:, W:]


def _mirror_y(a):
    """``(2W-1, W)`` values at ``m = 0..W-1`` -> ``(2W-1, 2W-1)`` at ``m = -(W-1)..W-1`` (even)."""
    return jnp.concatenate([a[:, :0:-1], a], axis=1)


def surface_offsets(A, B, inv_g, dx, window: int):
    """Influence coefficients ``(c, D)`` of an infinite layer's surface at the offsets
    ``-(W-1) .. W-1`` per axis, from the y-integrals of :func:`surface_factor`.

    Args:
        A: ``int T S_y cos`` per x node (``(K, W)``; for a quasi-static layer the speed-independent
            ``int T_1 S_y cos``, multiplied here by ``inv_g``).
        B: ``int (Im T or T_1) S_y^2 cos`` per x node (``(K, W)``).
        inv_g: per x node, ``1/conj G*(q_x V)`` (``(K,)``) for a quasi-static layer, or ``None``.
        dx: cell size [m]; window: static ``W``.

    Returns:
        ``c`` [m/Pa] and ``D`` [m/Pa per m^4], each ``(2 W - 1, 2 W - 1)`` (x = axis 0).
    """
    rule = fourier_rule(window, W_CUT_SURFACE)
    scale = 2.0 * jnp.pi / dx
    w = rule.w
    Sx = np.sinc(w)
    if inv_g is not None:
        A = A.astype(complex) * inv_g[:, None]
        B = B * jnp.imag(inv_g)[:, None]
    c = (dx * dx / jnp.pi**2) * scale**2 * jnp.real(rule.transform(A * jnp.asarray(Sx[:, None], A.dtype)))
    D = (scale**3 / jnp.pi**2) * jnp.real(rule.transform((w * Sx * Sx)[:, None] * B))
    return _mirror_y(c), _mirror_y(D)


def surface_window_kernel(A, B, inv_g, dx, window: int) -> _contact.WindowKernel:
    """:class:`jaxroll.contact.WindowKernel` of an infinite layer's surface (see
    :func:`surface_offsets`)."""
    c, D = surface_offsets(A, B, inv_g, dx, window)
    return _contact.WindowKernel(compliance=_contact.toeplitz_operator(c),
                                 dissipation=_contact.toeplitz_operator(D))
