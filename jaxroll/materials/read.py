"""Reading raw multi-temperature DMA frequency sweeps into :class:`DMASweeps` (shear, SI).

An instrument-style CSV: pyvisco's layout ``f, E_stor, E_loss, T, Set`` with a units row, or
units in the names (``E_stor [MPa]``); tension ``E`` or shear ``G``. Tensile moduli become shear
moduli through ``G = E / (2 (1 + nu))`` (``nu = 0.5``: ``G = E/3``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..io import UNITS, Column, read_table


@dataclasses.dataclass(frozen=True)
class DMASweeps:
    """Frequency sweeps at several temperatures, in shear, SI.

    Attributes:
        omega: angular frequency [rad/s] per row.
        storage, loss: shear storage / loss modulus ``G'``, ``G''`` [Pa] per row.
        temperature: temperature [K] per row (the set's value where the file gives it per set).
        set: index of the temperature set of each row, ``0 .. n_sets-1`` in increasing
            temperature.
        set_temperature: mean temperature of each set [K], increasing.
        source: how the moduli were obtained (``"shear"`` or ``"tension, nu = 0.5"``).
    """

    omega: np.ndarray
    storage: np.ndarray
    loss: np.ndarray
    temperature: np.ndarray
    set: np.ndarray
    set_temperature: np.ndarray
    source: str = "shear"

    def __post_init__(self):
        n = len(self.omega)
        for name in ("storage", "loss", "temperature", "set"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"DMASweeps: {name} has {len(getattr(self, name))} entries, omega has {n}")
        for name in ("omega", "storage", "loss", "temperature", "set_temperature"):
            x = np.asarray(getattr(self, name), float)
            if not np.all(np.isfinite(x) & (x > 0)):
                raise ValueError(f"DMASweeps: {name} must be finite and positive")
        if np.any(np.diff(self.set_temperature) <= 0):
            raise ValueError("DMASweeps: set temperatures must increase with the set index")

    @property
    def n_sets(self) -> int:
        return len(self.set_temperature)

    def select(self, i):
        """``(omega, storage, loss)`` of set ``i``, sorted by frequency."""
        m = self.set == i
        order = np.argsort(self.omega[m])
        return self.omega[m][order], self.storage[m][order], self.loss[m][order]


def _sweep_columns():
    """The columns of a raw DMA file (names case-insensitive)."""
    mod, opt = UNITS["modulus"], dict(required=False, positive=True)
    return [
        Column("frequency", UNITS["frequency"], aliases=("f", "freq", "omega", "angular_frequency"), **opt),
        Column("E_storage", mod, aliases=("e_stor", "e'", "estor", "storage_modulus_e"), **opt),
        Column("E_loss", mod, aliases=("e_loss", "e''", "eloss", "loss_modulus_e"), **opt),
        Column("G_storage", mod, aliases=("g_stor", "g'", "gstor", "storage_modulus"), **opt),
        Column("G_loss", mod, aliases=("g_loss", "g''", "gloss", "loss_modulus"), **opt),
        Column("temperature", UNITS["temperature"], aliases=("t", "temp"), blank=True, **opt),
        Column("set", None, aliases=("set_id", "segment", "step"), required=False),
    ]


def _cluster_temperatures(T, tol=1.0):
    """Set index per row from temperatures alone: sorted values split at gaps > ``tol`` [K]."""
    order = np.argsort(T)
    labels = np.empty(len(T), int)
    labels[order] = np.concatenate([[0], np.cumsum(np.diff(T[order]) > tol)])
    return labels


def read_dma_sweeps(path, *, poisson=0.5) -> DMASweeps:
    """Read raw multi-temperature DMA (frequency sweeps at several temperatures).

    The file: a header row of names, then an optional row of units (or units in the names,
    ``E_stor [MPa]``), then data rows; blank lines and lines starting with ``#`` are skipped; a
    UTF-8 byte-order mark is accepted. Columns (case-insensitive):

    * frequency: ``f`` / ``freq`` / ``frequency`` / ``omega`` in ``Hz`` or ``rad/s``;
    * tension ``E_stor``, ``E_loss`` (or ``E'``, ``E''``) or shear ``G_stor``, ``G_loss`` (or
      ``G'``, ``G''``, ``storage_modulus``, ``loss_modulus``) in ``Pa``/``kPa``/``MPa``/``GPa``;
    * temperature: ``T`` / ``temp`` / ``temperature`` in ``C`` (``degC``, ``°C``) or ``K``, on
      every row, or per set (on at least one row of each set, the other cells empty);
    * optional ``Set``: the set (temperature step) of each row; without it rows are grouped by
      temperature (sets more than 1 K apart).

    Args:
        path: the CSV file.
        poisson: Poisson's ratio [-] that converts tensile moduli to shear,
            ``G = E / (2 (1 + nu))`` (default 0.5, incompressible: ``G = E/3``). Unused for
            shear data.

    Returns:
        :class:`DMASweeps` (shear moduli [Pa], omega [rad/s], temperatures [K]).

    Raises:
        ValueError: naming the line and column of what is wrong.
    """
    if not (0.0 <= poisson <= 0.5):
        raise ValueError(f"poisson must be in [0, 0.5]; got {poisson}")
    t = read_table(path, _sweep_columns(), units_row="optional", kind="DMA", case_sensitive=False)
    path = t.path
    tension = {m for m in ("E", "G") if f"{m}_storage" in t or f"{m}_loss" in t}
    if len(tension) > 1:
        raise ValueError(f"{path}: storage and loss moduli mix tension (E) and shear (G): "
                         f"{sorted(t.header.values())}")
    mode = tension.pop() if tension else "G"
    missing = [r for r, c in (("frequency", "frequency"), ("storage", f"{mode}_storage"), ("loss", f"{mode}_loss"),
                              ("temperature", "temperature")) if c not in t]
    if missing:
        raise ValueError(f"{path}: no column for {missing}; the header has {sorted(t.header.values()) + t.unused} "
                         f"(expected e.g. f, E_stor, E_loss, T[, Set] or f, G_stor, G_loss, T)")
    if "set" not in t and np.any(np.isnan(t["temperature"])):
        k = int(np.argmax(np.isnan(t["temperature"])))
        raise ValueError(f"{path}, line {t.lines[k]}: missing value in column {t.header['temperature']!r} (without a "
                         f"Set column every row needs its temperature)")
    omega = t["frequency"]
    factor = 1.0 / (2.0 * (1.0 + poisson)) if mode == "E" else 1.0
    storage = t[f"{mode}_storage"] * factor
    loss = t[f"{mode}_loss"] * factor
    T = t["temperature"].copy()
    lines = t.lines
    if "set" in t:
        raw_set = t["set"]
        labels = np.unique(raw_set, return_inverse=True)[1].ravel()
        for s in range(labels.max() + 1):  # temperature per set: fill the blanks
            m = labels == s
            if np.all(np.isnan(T[m])):
                raise ValueError(f"{path}, line {lines[m][0]}: set {raw_set[m][0]:g} has no temperature")
            T[m & np.isnan(T)] = np.nanmean(T[m])
    else:
        labels = _cluster_temperatures(T)
    set_T = np.array([T[labels == s].mean() for s in range(labels.max() + 1)])
    order = np.argsort(set_T)
    if np.any(np.diff(set_T[order]) <= 0):
        raise ValueError(f"{path}: two sets have the same mean temperature")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    source = f"tension, nu = {poisson:g}" if mode == "E" else "shear"
    return DMASweeps(omega, storage, loss, T, rank[labels], set_T[order], source)
