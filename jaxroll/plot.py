"""Figures (matplotlib, Agg backend; every function returns the Figure and optionally saves it)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from . import layer as _layer  # noqa: E402
from . import material as _material  # noqa: E402

__all__ = ["plot_master_curves", "plot_compliance"]


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
