"""Figures (matplotlib): every function draws into new Axes, or into the caller's (``ax=``: one
Axes, or a sequence of as many Axes as the figure has panels), returns the Figure and optionally
saves it (``path``).

The module never chooses the matplotlib backend: in a notebook the figures show inline, in a
script they follow the user's backend (the command line selects the file-only ``Agg`` backend
for itself).
"""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize

from ..engines import layer as _layer
from ..materials import material as _material

__all__ = ["plot_master_curves", "plot_compliance", "plot_rolling_curves", "plot_fit", "plot_method_comparison",
           "plot_relative_error", "plot_error_maps", "plot_pressure_profile", "plot_pressure_map", "plot_master_fit",
           "plot_resistance_map", "plot_shift_factors", "masked_mean", "close"]


def _save(fig, path):
    if path is not None:
        fig.savefig(path, dpi=130, bbox_inches="tight")
    return fig


def _figure(ax, nrows=1, ncols=1, *, squeeze=True, **subplots_kw):
    """``(figure, axes)`` as ``plt.subplots(nrows, ncols, squeeze=squeeze, **subplots_kw)``
    returns them, or, when the caller gives ``ax`` (one Axes, or a sequence of ``nrows * ncols``
    Axes of one figure), those Axes in that shape and their figure (``subplots_kw`` then unused)."""
    if ax is None:
        return plt.subplots(nrows, ncols, squeeze=squeeze, **subplots_kw)
    axes = np.asarray(ax, dtype=object).ravel()
    if axes.size != nrows * ncols:
        raise ValueError(f"ax: this figure needs {nrows * ncols} Axes ({nrows} x {ncols}); got {axes.size}")
    fig = axes[0].figure
    if squeeze:
        return fig, axes[0] if axes.size == 1 else axes
    return fig, axes.reshape(nrows, ncols)


def masked_mean(e, axis):
    """Mean of the finite entries of ``e`` along ``axis`` (NaN where there are none) and their
    count: NaN marks points left out (e.g. not valid)."""
    e = np.asarray(e, float)
    ok = np.isfinite(e)
    n = ok.sum(axis=axis)
    total = np.where(ok, e, 0.0).sum(axis=axis)
    return np.where(n > 0, total / np.maximum(n, 1), np.nan), n


def close(fig):
    """Release a figure returned by this module (``matplotlib.pyplot.close``)."""
    plt.close(fig)


def plot_master_curves(materials: dict, omega=None, *, shift=None, temperatures=None, ax=None, path=None):
    """G', G'' [Pa] and tan delta against angular frequency [rad/s] for named materials.

    With ``shift`` (:class:`jaxroll.WLF` or :class:`jaxroll.Arrhenius`) and ``temperatures``
    [K], each material is also drawn at each temperature through time-temperature
    superposition (:func:`jaxroll.at_temperature`: ``G*(omega; T) = G*_ref(omega a_T)``).
    """
    omega = np.logspace(-3, 4, 300) if omega is None else np.asarray(omega)
    fig, (ax1, ax2) = _figure(ax, 1, 2, figsize=(10, 4))
    if (shift is None) != (temperatures is None):
        raise ValueError("plot_master_curves: give both shift= and temperatures=, or neither")
    if shift is not None:
        materials = {f"{name}, T = {T:g} K": _material.at_temperature(mat, shift, float(T))
                     for name, mat in materials.items() for T in np.atleast_1d(temperatures)}
    for name, mat in materials.items():
        g = np.asarray(_material.complex_modulus(mat, omega))
        (line,) = ax1.loglog(omega, g.real, label=f"G' {name}")
        ax1.loglog(omega, g.imag, "--", color=line.get_color(), label=f"G'' {name}")
        ax2.semilogx(omega, g.imag / g.real, color=line.get_color(), label=name)
    ax1.set(xlabel="angular frequency ω [rad/s]", ylabel="modulus [Pa]", title="master curves")
    ax2.set(xlabel="angular frequency ω [rad/s]", ylabel="tan δ [-]", title="loss factor")
    ax1.legend(fontsize=8)
    ax2.legend(fontsize=8)
    ax1.grid(True, which="both", alpha=0.3)
    ax2.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return _save(fig, path)


def plot_compliance(material, layers: dict, speed, q=None, *, ax=None, path=None):
    """Re T and Im T [m/Pa] (plane strain, q_y = 0) against wavenumber q [rad/m] for named
    layers at rolling speed ``speed`` [m/s], with the half-space ``1/(2 G0 q)`` for reference."""
    q = np.logspace(0, 5, 400) if q is None else np.asarray(q)
    fig, ax = _figure(ax, figsize=(6.5, 4.5))
    for name, lay in layers.items():
        t = np.asarray(_layer.surface_compliance(lay, material, q, 0.0, speed))
        (line,) = ax.loglog(q, t.real, label=f"Re T, {name}")
        ax.loglog(q, t.imag, "--", color=line.get_color(), label=f"Im T, {name}")
    g0 = float(_material.relaxed_modulus(material))
    ax.loglog(q, 1 / (2 * g0 * q), "k:", lw=1, label="1/(2 G0 q) (half-space, static)")
    ax.set(xlabel="wavenumber q [rad/m]", ylabel="T [m/Pa]", title=f"surface compliance at V = {speed:g} m/s")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return _save(fig, path)


def _load_unit(unit):
    """The load unit that goes with a rolling-resistance unit (N for spheres, N/m for cylinders)."""
    return "N/m" if unit == "N/m" else "N"


def _load_colorbar(fig, axes, loads, unit):
    """A labelled colorbar for a family of curves coloured by load (viridis, low to high)."""
    loads = np.asarray(loads, float)
    lo, hi = float(loads.min()), float(loads.max())
    sm = ScalarMappable(norm=Normalize(lo, hi if hi > lo else lo + 1.0), cmap="viridis")
    cb = fig.colorbar(sm, ax=axes, pad=0.02)
    cb.set_label(f"load P [{_load_unit(unit)}]")
    if len(loads) <= 8:
        cb.set_ticks(loads)
    return cb


def _load_colors(loads):
    loads = np.asarray(loads, float)
    lo, hi = float(loads.min()), float(loads.max())
    cmap = plt.get_cmap("viridis")
    return [cmap((P - lo) / (hi - lo) if hi > lo else 0.0) for P in loads]


def plot_rolling_curves(speeds, loads, values, *, unit="N", reference=None, labels=("model", "reference"),
                        valid=None, title=None, ax=None, path=None):
    """R_r against speed (log axis), one curve per load, coloured by load (colorbar).

    ``values`` [unit] has shape ``(len(loads), len(speeds))``; ``reference`` (same shape,
    optional) is drawn as circles; ``valid`` (same shape, boolean, optional) marks the points
    outside their method's validity with a red cross.
    """
    speeds, values = np.asarray(speeds), np.asarray(values)
    fig, ax = _figure(ax, figsize=(7, 4.5), layout="constrained")
    colors = _load_colors(loads)
    for i in range(len(colors)):
        ax.semilogx(speeds, values[i], color=colors[i])
        if reference is not None:
            ax.semilogx(speeds, np.asarray(reference)[i], "o", ms=3, color=colors[i], mfc="none")
    handles = [plt.Line2D([], [], color="0.3", label=labels[0])]
    if reference is not None:
        handles.append(plt.Line2D([], [], color="0.3", marker="o", ms=3, mfc="none", ls="", label=labels[1]))
    if valid is not None and not np.all(valid):
        bad = ~np.asarray(valid, bool)
        ax.semilogx(np.broadcast_to(speeds, values.shape)[bad], values[bad], "x", color="red", ms=6)
        handles.append(plt.Line2D([], [], color="red", marker="x", ls="",
                                  label=f"not valid ({int(bad.sum())} points)"))
    ax.set(xlabel="speed V [m/s]", ylabel=f"rolling resistance R_r [{unit}]", title=title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(handles=handles, fontsize=8)
    _load_colorbar(fig, ax, loads, unit)
    return _save(fig, path)


def plot_fit(speeds, loads, measured, fitted, *, unit="N", ax=None, path=None):
    """Measured (circles) and fitted (lines) rolling resistance [unit] against speed [m/s], one
    colour per load (colorbar), and the relative residuals [%]."""
    speeds, loads = np.asarray(speeds), np.asarray(loads)
    measured, fitted = np.asarray(measured), np.asarray(fitted)
    fig, (ax1, ax2) = _figure(ax, 1, 2, figsize=(12, 4.2), layout="constrained")
    ul = np.unique(loads)
    for P, c in zip(ul, _load_colors(ul)):
        sel = loads == P
        order = np.argsort(speeds[sel])
        ax1.semilogx(speeds[sel][order], measured[sel][order], "o", ms=3, color=c, mfc="none")
        ax1.semilogx(speeds[sel][order], fitted[sel][order], "-", color=c)
        ax2.semilogx(speeds[sel][order], 100 * (measured[sel][order] / fitted[sel][order] - 1), ".", color=c)
    ax1.set(xlabel="speed V [m/s]", ylabel=f"rolling resistance R_r [{unit}]", title="measured and fitted")
    ax1.legend(handles=[plt.Line2D([], [], color="0.3", marker="o", ms=3, mfc="none", ls="", label="measured"),
                        plt.Line2D([], [], color="0.3", label="fitted")], fontsize=8)
    ax2.axhline(0, color="k", lw=0.8)
    ax2.set(xlabel="speed V [m/s]", ylabel="residual, measured/fitted - 1 [%]", title="relative residuals")
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.3)
    _load_colorbar(fig, [ax1, ax2], ul, unit)
    return _save(fig, path)


def plot_method_comparison(speeds, loads, reference, estimates: dict, *, unit="N", title=None, valid=None,
                           reference_valid=None, ax=None, path=None):
    """R_r against speed (log axis) per load: one panel per method, the method as lines and the
    reference (e.g. the full 3D model) as circles.

    Args:
        speeds: ``(n_speeds,)`` [m/s]; loads: ``(n_loads,)`` [N].
        reference: ``(n_loads, n_speeds)`` [unit].
        estimates: method name -> ``(n_loads, n_speeds)`` array [unit] (may be empty: the
            reference alone is drawn).
        valid: method name -> boolean ``(n_loads, n_speeds)``, optional: the method's points
            that are not valid get a red cross; reference_valid: the same for the reference
            (a black plus). Each kind has a legend entry with its count.
    """
    speeds, loads, reference = np.asarray(speeds), np.asarray(loads), np.asarray(reference)
    n = max(1, len(estimates))
    ncol = min(n, 2)
    nrow = math.ceil(n / ncol)
    fig, axes = _figure(ax, nrow, ncol, figsize=(5.2 * ncol + 1.0, 3.6 * nrow), squeeze=False, sharey=True,
                             layout="constrained")
    colors = _load_colors(loads)
    items = list(estimates.items()) or [("reference", None)]
    for k, (name, est) in enumerate(items):
        ax = axes.flat[k]
        for i in range(len(loads)):
            ax.semilogx(speeds, reference[i], "o", ms=3, mfc="none", color=colors[i])
            if est is not None:
                ax.semilogx(speeds, np.asarray(est)[i], "-", color=colors[i])
        ax.set(title=name, xlabel="speed V [m/s]")
        ax.grid(True, which="both", alpha=0.3)
        handles = [plt.Line2D([], [], color="0.3", marker="o", ms=3, mfc="none", ls="", label="reference")]
        if est is not None:
            handles.insert(0, plt.Line2D([], [], color="0.3", label=name))
        grid_v = np.broadcast_to(speeds, reference.shape)
        for mask, values, style, label in ((reference_valid, reference, dict(marker="+", color="k"), "reference"),
                                           ((valid or {}).get(name), est, dict(marker="x", color="red"), name)):
            if mask is None or values is None or np.all(mask):
                continue
            bad = ~np.asarray(mask, bool)
            ax.semilogx(grid_v[bad], np.asarray(values)[bad], ls="", ms=6, **style)
            handles.append(plt.Line2D([], [], ls="", ms=6, **style, label=f"{label} not valid ({int(bad.sum())})"))
        ax.legend(handles=handles, fontsize=7)
    for ax in axes[:, 0]:
        ax.set_ylabel(f"rolling resistance R_r [{unit}]")
    for ax in list(axes.flat)[len(items):]:
        ax.set_visible(False)
    _load_colorbar(fig, [ax for ax in axes.flat if ax.get_visible()], loads, unit)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def plot_relative_error(speeds, loads, errors: dict, *, title=None, ax=None, path=None):
    """Mean relative error [%] of each method against the reference: against speed (averaged
    over loads, log axis) and against load (averaged over speeds), as in [ZG] figs. 3-8 (b).

    ``errors``: method name -> ``(n_loads, n_speeds)`` relative errors [-]
    (``estimate/reference - 1``); NaN marks a point left out (not valid), which the means skip
    and the legend counts.
    """
    speeds, loads = np.asarray(speeds), np.asarray(loads)
    fig, (ax1, ax2) = _figure(ax, 1, 2, figsize=(10, 3.8))
    for name, e in errors.items():
        e = 100.0 * np.asarray(e, float)
        left_out = int(np.sum(~np.isfinite(e)))
        label = f"{name} ({left_out} of {e.size} points not valid, left out)" if left_out else name
        ax1.semilogx(speeds, masked_mean(e, 0)[0], "o-", ms=3, label=label)
        ax2.plot(loads, masked_mean(e, 1)[0], "o-", ms=3, label=label)
    ax1.set(xlabel="speed V [m/s]", ylabel="mean relative error [%]", title="against speed (mean over loads)")
    ax2.set(xlabel="load P [N]", ylabel="mean relative error [%]", title="against load (mean over speeds)")
    for ax in (ax1, ax2):
        ax.axhline(0.0, color="k", lw=0.8)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def _cell_edges(x, *, log):
    """Cell edges around the sample points ``x`` (sorted): midpoints (geometric on a log axis),
    the outer cells as wide as their neighbours, and never below 0 on a linear axis."""
    x = np.asarray(x, float)
    if x.size == 1:
        return np.array([x[0] / 1.5, x[0] * 1.5]) if log else np.array([max(0.0, x[0] - 0.5), x[0] + 0.5])
    y = np.log(x) if log else x
    mid = 0.5 * (y[1:] + y[:-1])
    edges = np.concatenate([[y[0] - (mid[0] - y[0])], mid, [y[-1] + (y[-1] - mid[-1])]])
    return np.exp(edges) if log else np.maximum(edges, 0.0)


def plot_error_maps(speeds, loads, errors: dict, *, title=None, limit=None, ax=None, path=None):
    """Relative error [%] over the speed x load grid, one panel per method, on a diverging
    colormap centred at 0 (red: the method overestimates, blue: underestimates).

    ``errors``: method name -> ``(n_loads, n_speeds)`` relative errors [-], NaN for points left
    out (not valid: grey cells, with a legend entry); ``limit``: colour range +-limit [%]
    (default: the largest absolute error, shared by all panels).
    """
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.patches import Patch

    speeds, loads = np.asarray(speeds), np.asarray(loads)
    n = max(1, len(errors))
    fig, axes = _figure(ax, 1, n, figsize=(3.4 * n + 1.2, 3.4), squeeze=False, layout="constrained")
    vals = [100.0 * np.asarray(e) for e in errors.values()]
    lim = limit if limit is not None else max([float(np.max(np.abs(v[np.isfinite(v)]), initial=0.0)) for v in vals]
                                              + [1e-3])
    norm = TwoSlopeNorm(vcenter=0.0, vmin=-lim, vmax=lim)
    mesh = None
    v_edges, p_edges = _cell_edges(speeds, log=True), _cell_edges(loads, log=False)
    for ax, (name, v) in zip(axes.flat, zip(errors, vals)):
        mesh = ax.pcolormesh(v_edges, p_edges, np.ma.masked_invalid(v), cmap="RdBu_r", norm=norm)
        ax.set_xscale("log")
        ax.set(title=name, xlabel="speed V [m/s]")
        left_out = int(np.sum(~np.isfinite(v)))
        if left_out:
            ax.set_facecolor("0.75")  # masked cells show the background
            ax.legend(handles=[Patch(facecolor="0.75", label=f"not valid ({left_out})")], fontsize=7, loc="lower left")
    axes[0, 0].set_ylabel("load P [N]")
    if mesh is not None:
        fig.colorbar(mesh, ax=list(axes.flat), label="relative error [%]", shrink=0.9, pad=0.02)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def plot_pressure_profile(x, pressures: dict, *, title=None, ax=None, path=None):
    """Contact pressure [Pa] of the 2D cylinder model against ``x`` [m] (rolling toward +x),
    one curve per named solution (e.g. per speed), drawn in mm and MPa."""
    x = np.asarray(x)
    fig, ax = _figure(ax, figsize=(6.0, 3.8))
    for name, p in pressures.items():
        ax.plot(1e3 * x, 1e-6 * np.asarray(p), label=name)
    ax.axvline(0.0, color="k", lw=0.6, ls=":")
    ax.set(xlabel="x [mm] (rolling toward +x)", ylabel="pressure p [MPa]", title=title or "2D cylinder pressure")
    p_all = np.concatenate([np.asarray(p) for p in pressures.values()]) if pressures else np.zeros(1)
    on = np.abs(x)[np.any(np.stack([np.asarray(p) for p in pressures.values()]) > 0, axis=0)] if pressures else x
    if on.size:
        half = 1.4e3 * float(np.max(on))
        ax.set_xlim(-half, half)
    ax.set_ylim(bottom=0.0, top=1.1e-6 * float(np.max(p_all)) or None)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def plot_pressure_map(x, y, pressure, *, contact=None, title=None, ax=None, path=None):
    """Contact pressure [Pa] of the 3D sphere model on its window (``pressure[i, j]`` at
    ``(x[i], y[j])`` [m], rolling toward +x), drawn in MPa over mm, with the outline of the
    contact set (``contact``: boolean array of the same shape; default ``pressure > 0``)."""
    x, y, p = np.asarray(x), np.asarray(y), np.asarray(pressure)
    c = (p > 0) if contact is None else np.asarray(contact)
    fig, ax = _figure(ax, figsize=(5.4, 4.4))
    mesh = ax.pcolormesh(1e3 * x, 1e3 * y, 1e-6 * p.T, cmap="magma", shading="nearest")
    ax.contour(1e3 * x, 1e3 * y, c.T.astype(float), levels=[0.5], colors="w", linewidths=1.0)
    ax.plot([0.0], [0.0], "c+", ms=8)
    ax.set_aspect("equal")
    ax.set(xlabel="x [mm] (rolling toward +x)", ylabel="y [mm]", title=title or "3D sphere pressure")
    fig.colorbar(mesh, ax=ax, label="pressure p [MPa]")
    return _save(fig, path)


def plot_master_fit(master, prony, *, ax=None, path=None):
    """A master curve (points coloured by temperature set) with its Prony fit, and the fit's
    relative residuals ``log(G_fit / G_meas)`` (``master``: :class:`jaxroll.materials.MasterCurve`,
    ``prony``: :class:`jaxroll.materials.PronyFit`); loss values the fit left out (weight 0) are circled."""
    w = np.logspace(math.log10(master.omega.min()), math.log10(master.omega.max()), 400)
    g = np.asarray(_material.complex_modulus(prony.material, w))
    fig, (ax1, ax2) = _figure(ax, 2, 1, figsize=(8, 7), sharex=True, gridspec_kw={"height_ratios": [3, 1.4]})
    sc = ax1.scatter(master.omega, master.storage, c=master.set, s=9, cmap="viridis", label="G' measured")
    ax1.scatter(master.omega, master.loss, c=master.set, s=9, cmap="viridis", marker="x", label="G'' measured")
    out = np.zeros(len(master.omega), bool) if prony.weights is None else prony.weights[:, 1] == 0
    if out.any():
        ax1.scatter(master.omega[out], master.loss[out], s=60, facecolors="none", edgecolors="r",
                    label="G'' left out of the fit")
    ax1.loglog(w, g.real, "k-", lw=1.2, label=f"G' Prony ({prony.n_terms} terms)")
    ax1.loglog(w, g.imag, "k--", lw=1.2, label="G'' Prony")
    fig.colorbar(sc, ax=ax1, label="temperature set")
    ax1.set(ylabel="shear modulus [Pa]", title=f"master curve at T_ref = {master.T_ref:.2f} K")
    ax1.legend(fontsize=8)
    ax2.semilogx(master.omega, prony.residuals[:, 0], ".", ms=4, label="storage")
    ax2.semilogx(master.omega[~out], prony.residuals[~out, 1], "x", ms=4, label="loss")
    if out.any():
        ax2.semilogx(master.omega[out], prony.residuals[out, 1], "o", ms=6, mfc="none", mec="r", label="loss, left out")
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set(xlabel="reduced angular frequency ω a_T [rad/s]", ylabel="log(G_fit / G_meas)",
            title=f"residuals (rms {prony.rms:.3f})")
    ax2.legend(fontsize=8)
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return _save(fig, path)


def plot_resistance_map(rmap, *, unit="N", title=None, ax=None, path=None):
    """Heat maps with contours of ``R_r(T, V)`` and ``dR_r/dT`` (``rmap``:
    :class:`jaxroll.materials.ResistanceMap`); invalid points hatched out (masked)."""
    T = rmap.temperatures - 273.15
    V = rmap.speeds
    fig, axes = _figure(ax, 1, 2, figsize=(12, 4.5))
    for ax, data, label in ((axes[0], rmap.value, f"R_r [{unit}]"), (axes[1], rmap.dR_dT, f"dR_r/dT [{unit}/K]")):
        z = np.ma.masked_where(~rmap.valid, data)
        if not z.count():  # no valid point: an empty panel (a log scale needs values)
            im = ax.pcolormesh(V, T, z, shading="nearest")
        elif data is rmap.value:
            im = ax.pcolormesh(V, T, z, shading="nearest", norm=plt.matplotlib.colors.LogNorm())
            ax.contour(V, T, np.log10(np.where(rmap.valid, data, np.nan)), colors="w", linewidths=0.7)
        else:
            lim = float(np.nanmax(np.abs(z))) if z.count() else 1.0
            im = ax.pcolormesh(V, T, z, shading="nearest", cmap="RdBu_r", vmin=-lim, vmax=lim)
            ax.contour(V, T, np.where(rmap.valid, data, np.nan), levels=[0.0], colors="k", linewidths=0.8)
        ax.set_xscale("log")
        ax.set(xlabel="speed V [m/s]", ylabel="temperature [°C]")
        fig.colorbar(im, ax=ax, label=label)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)


def plot_shift_factors(shifts, fits: dict, *, ax=None, path=None):
    """Shift factors ``log10 a_T`` against temperature with 95 % error bars and the fitted
    laws (``shifts``: :class:`jaxroll.materials.ShiftFactors`; ``fits``: ``{label: ShiftFit}``, e.g.
    ``{"WLF": jr.fit_wlf(shifts), "Arrhenius": jr.materials.fit_arrhenius(shifts)}``)."""
    T = shifts.temperature
    Tf = np.linspace(T.min(), T.max(), 200)
    fig, ax = _figure(ax, figsize=(7, 4.5))
    ax.errorbar(T - 273.15, shifts.log10_aT, yerr=1.96 * shifts.sigma, fmt="o", ms=4, capsize=2, color="k",
                label="from the data (95 %)")
    for label, fit in fits.items():
        ax.plot(Tf - 273.15, np.asarray(fit.shift.log_shift(Tf)) / math.log(10.0), lw=1.2,
                label=f"{label} (rms {fit.rms:.2f} decades)")
    ax.axvline(shifts.T_ref - 273.15, color="0.6", lw=0.8, ls=":")
    ax.set(xlabel="temperature [°C]", ylabel="log10 a_T", title=f"shift factors, T_ref = {shifts.T_ref:.2f} K")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)
