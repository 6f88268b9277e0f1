"""Figures (matplotlib, Agg backend; every function returns the Figure and optionally saves it)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import layer as _layer  # noqa: E402
from . import material as _material  # noqa: E402

__all__ = ["plot_master_curves", "plot_compliance", "plot_rolling_curves", "plot_fit"]


def _save(fig, path):
    if path is not None:
        fig.savefig(path, dpi=130, bbox_inches="tight")
    return fig


def plot_master_curves(materials: dict, omega=None, path=None):
    """G', G'' [Pa] and tan delta against angular frequency [rad/s] for named materials."""
    omega = np.logspace(-3, 4, 300) if omega is None else np.asarray(omega)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
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


def plot_compliance(material, layers: dict, speed, q=None, path=None):
    """Re T and Im T [m/Pa] (plane strain, q_y = 0) against wavenumber q [rad/m] for named
    layers at rolling speed ``speed`` [m/s], with the half-space ``1/(2 G0 q)`` for reference."""
    q = np.logspace(0, 5, 400) if q is None else np.asarray(q)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
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


def plot_rolling_curves(speeds, loads, values, *, unit="N", reference=None, labels=("model", "reference"),
                        title=None, path=None):
    """R_r against speed (log axis), one curve per load. ``values`` has shape
    ``(len(loads), len(speeds))``; ``reference`` (same shape, optional) is drawn as markers."""
    speeds, values = np.asarray(speeds), np.asarray(values)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    cmap = plt.get_cmap("viridis")
    for i, P in enumerate(np.asarray(loads)):
        c = cmap(i / max(1, len(loads) - 1))
        ax.semilogx(speeds, values[i], color=c, label=f"P = {P:g}" if i in (0, len(loads) - 1) else None)
        if reference is not None:
            ax.semilogx(speeds, np.asarray(reference)[i], "o", ms=3, color=c, mfc="none")
    ax.set(xlabel="speed V [m/s]", ylabel=f"rolling resistance R_r [{unit}]",
           title=title or ("lines: " + labels[0] + (f", circles: {labels[1]}" if reference is not None else "")))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def plot_fit(speeds, loads, measured, fitted, *, unit="N", path=None):
    """Measured (markers) and fitted (lines) rolling resistance against speed per load, and the
    relative residuals."""
    speeds, loads = np.asarray(speeds), np.asarray(loads)
    measured, fitted = np.asarray(measured), np.asarray(fitted)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ul = np.unique(loads)
    cmap = plt.get_cmap("viridis")
    for i, P in enumerate(ul):
        sel = loads == P
        order = np.argsort(speeds[sel])
        c = cmap(i / max(1, len(ul) - 1))
        ax1.semilogx(speeds[sel][order], measured[sel][order], "o", ms=3, color=c, mfc="none")
        ax1.semilogx(speeds[sel][order], fitted[sel][order], "-", color=c,
                     label=f"P = {P:g}" if i in (0, len(ul) - 1) else None)
        ax2.semilogx(speeds[sel][order], 100 * (measured[sel][order] / fitted[sel][order] - 1), ".", color=c)
    ax1.set(xlabel="speed V [m/s]", ylabel=f"R_r [{unit}]", title="measured (o) and fitted (-)")
    ax2.axhline(0, color="k", lw=0.8)
    ax2.set(xlabel="speed V [m/s]", ylabel="residual, measured/fitted - 1 [%]", title="relative residuals")
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.3)
    ax1.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)
