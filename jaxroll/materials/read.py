"""Reading raw multi-temperature DMA frequency sweeps into :class:`DMASweeps` (shear, SI).

Instrument exports and spreadsheets: pyvisco's layout ``f, E_stor, E_loss, T, Set`` with a
units row, or units in the names (``E_stor [MPa]``); Eplexor, TA TRIOS and Anton Paar
RheoCompass exports; any encoding, delimiter and decimal mark :func:`jaxroll.io.read_rows`
sniffs; tension ``E`` or shear ``G``, as storage and loss or as ``|M*|`` and ``tan delta``. Tensile moduli become shear
moduli through ``G = E / (2 (1 + nu))`` (``nu = 0.5``: ``G = E/3``).
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings

import numpy as np

from ..io import UNITS, Column, DataWarning, read_blocks


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
        line: the file line of each row (for messages), or None.
    """

    omega: np.ndarray
    storage: np.ndarray
    loss: np.ndarray
    temperature: np.ndarray
    set: np.ndarray
    set_temperature: np.ndarray
    source: str = "shear"
    line: np.ndarray | None = None

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
    """The columns of a raw DMA file (names case-insensitive, spaces read as ``_``)."""
    mod, opt = UNITS["modulus"], dict(required=False, positive=True, blank=True)
    return [
        Column("frequency", UNITS["frequency"], aliases=("f", "freq", "omega", "angular_frequency", "reduced_frequency",
                                                         "reduced_angular_frequency", "reduced_omega"), **opt),
        Column("E_storage", mod, aliases=("e_stor", "e'", "estor", "storage_modulus_e", "e_storage"), **opt),
        Column("E_loss", mod, aliases=("e_loss", "e''", "eloss", "loss_modulus_e"), **opt),
        Column("E_complex", mod, aliases=("|e*|", "e*", "e_comp", "complex_modulus_e"), **opt),
        Column("G_storage", mod, aliases=("g_stor", "g'", "gstor", "storage_modulus"), **opt),
        Column("G_loss", mod, aliases=("g_loss", "g''", "gloss", "loss_modulus"), **opt),
        Column("G_complex", mod, aliases=("|g*|", "g*", "g_comp", "complex_modulus", "complex_shear_modulus"), **opt),
        Column("tan_delta", UNITS["dimensionless"], aliases=("tan_delta", "tan(delta)", "tan_δ", "tanδ", "tan_d",
                                                             "tan_del", "loss_factor", "damping_factor"), **opt),
        Column("temperature", UNITS["temperature"], aliases=("t", "temp"), **opt),
        Column("set", None, aliases=("set_id", "segment", "step"), required=False),
        Column("point", None, aliases=("index", "point_no.", "no."), required=False),  # read, not used
    ]


#: What a DMA file must give, for messages.
_EXPECTED = ("a header row naming the frequency, the moduli (E', E'' or G', G'', or |E*| and tan delta) and the "
             "temperature, e.g. 'f, E_stor, E_loss, T[, Set]' with a units row 'Hz, MPa, MPa, C'")
#: Angular frequencies [rad/s] a DMA sweep can hold (1e-8..1e8 Hz): outside, a column or unit is wrong.
_OMEGA_RANGE = (2 * np.pi * 1e-8, 2 * np.pi * 1e8)
_TITLE_TEMPERATURE = re.compile(r"(-?\d+(?:\.\d+)?)\s*(°\s*C|ºC|degC|K)\b")


def _cluster_temperatures(T, tol=1.0):
    """Set index per row from temperatures alone: sorted values split at gaps > ``tol`` [K]."""
    order = np.argsort(T)
    labels = np.empty(len(T), int)
    labels[order] = np.concatenate([[0], np.cumsum(np.diff(T[order]) > tol)])
    return labels


def _moduli(path, t, mode):
    """Storage and loss of mode ``E`` or ``G`` per row from the columns the table has: the pair
    itself, or ``|M*|`` and ``tan delta`` (``M' = |M*| / sqrt(1 + tan^2)``, ``M'' = M' tan``),
    row by row where a value is missing; ``nan`` where nothing gives it."""
    n = len(t.lines)
    nan = np.full(n, np.nan)
    storage, loss = t.get(f"{mode}_storage", nan).copy(), t.get(f"{mode}_loss", nan).copy()
    tan, comp = t.get("tan_delta", nan), t.get(f"{mode}_complex", nan)
    from_comp = comp / np.sqrt(1.0 + tan**2)
    storage = np.where(np.isnan(storage), from_comp, storage)
    loss = np.where(np.isnan(loss), storage * tan, loss)
    return storage, loss


#: Tensile over shear modulus, ``E/G = 2 (1 + nu)``, of any isotropic solid (0 <= nu <= 0.5),
#: widened by the scatter of an instrument's two computed columns: outside, one is mislabelled.
E_OVER_G = (1.8, 3.3)


def _mode(path, tables):
    """``"E"`` or ``"G"``: the kind of moduli the tables give (None: neither). Tables with both
    E and G storage columns must hold ``E'/G'`` within :data:`E_OVER_G` (then shear is read);
    otherwise one column is mislabelled (a shear/tension mix-up) and reading stops."""
    def has(t, m):
        return any(f"{m}_{k}" in t for k in ("storage", "loss", "complex"))

    modes = {m for t in tables for m in ("E", "G") if has(t, m)}
    if len(modes) < 2:
        return modes.pop() if modes else None
    both = [t for t in tables if all(f"{m}_storage" in t for m in ("E", "G"))]
    if not both:
        raise ValueError(f"{path}: storage and loss moduli mix tension (E) and shear (G): "
                         f"{sorted({h for t in tables for h in t.header.values()})}")
    E, G = (np.concatenate([t[f"{m}_storage"] for t in both]) for m in ("E", "G"))
    ok = np.isfinite(E) & np.isfinite(G)
    ratio = float(np.median(E[ok] / G[ok])) if ok.any() else math.nan
    if not E_OVER_G[0] <= ratio <= E_OVER_G[1]:
        names = [both[0].header[f"{m}_storage"] for m in ("E", "G")]
        raise ValueError(f"{path}: the file gives both {names[0]!r} and {names[1]!r}, but E'/G' = {ratio:.3g} (median "
                         f"of {int(ok.sum())} rows), where E = 2 (1 + nu) G needs {E_OVER_G[0]}..{E_OVER_G[1]} (3 for "
                         f"nu = 0.5): one column is mislabelled (shear under a tension header, or the reverse); keep "
                         "the right one")
    return "G"


def read_dma_sweeps(path, *, poisson=0.5) -> DMASweeps:
    """Read raw multi-temperature DMA (frequency sweeps at several temperatures).

    Layouts (each documented with an example in ``docs/dma.md``); :func:`jaxroll.io.read_rows`
    sniffs the encoding (UTF-8 with or without BOM, UTF-16, cp1252), the delimiter (comma,
    semicolon, tab) and a decimal comma, and reads ``.xls`` / ``.xlsx`` workbooks (extra
    ``jaxroll[excel]``):

    * a plain table: a header row of names, then an optional row of units (or units in the
      names, ``E_stor [MPa]``), then data rows; blank lines and lines starting with ``#`` are
      skipped;
    * Netzsch/GABO Eplexor "Exported Data" (sheet or text): names and units in two header rows,
      ``---`` for missing values;
    * TA TRIOS text exports: one table per ``[step]`` segment (each a set), the temperature in
      a column or in the step's name (``Frequency sweep (25.0 °C)``);
    * Anton Paar RheoCompass exports (UTF-16, decimal commas): one ``Interval data:`` table per
      interval (each a set), units in brackets.

    Columns (case-insensitive):

    * frequency: ``f`` / ``freq`` / ``frequency`` / ``omega`` / ``Angular Frequency`` in ``Hz``,
      ``1/s`` or ``rad/s``;
    * tension ``E_stor``, ``E_loss`` (or ``E'``, ``E''``) or shear ``G_stor``, ``G_loss`` (or
      ``G'``, ``G''``, ``Storage Modulus``, ``Loss Modulus``) in ``Pa``/``kPa``/``MPa``/``GPa``;
      or the magnitude ``|E*|`` / ``|G*|`` (``Complex Modulus``) with ``tan delta`` (``Loss
      Factor``), converted to ``M' = |M*| / sqrt(1 + tan^2 delta)``, ``M'' = M' tan delta``;
    * temperature: ``T`` / ``temp`` / ``temperature`` in ``C`` (``degC``, ``°C``) or ``K``, on
      every row, or per set (on at least one row of each set, the other cells empty);
    * optional ``Set``: the set (temperature step) of each row; without it (and in a one-table
      file) rows are grouped by temperature (sets more than 1 K apart).

    Rows whose frequency or moduli are missing (``---``, empty) are skipped with a
    :class:`jaxroll.DataWarning` naming their lines.

    Args:
        path: the file.
        poisson: Poisson's ratio [-] that converts tensile moduli to shear,
            ``G = E / (2 (1 + nu))`` (default 0.5, incompressible: ``G = E/3``). Unused for
            shear data.

    Returns:
        :class:`DMASweeps` (shear moduli [Pa], omega [rad/s], temperatures [K]).

    Raises:
        ValueError: one line naming the line and column of what is wrong, or, for a file that
            matches no layout, what was found and what was expected.
    """
    from .checks import check_sweeps

    sweeps = _read_sweeps(path, poisson)
    for message in check_sweeps(sweeps):
        warnings.warn(f"{path}: {message}", DataWarning, stacklevel=2)
    return sweeps


def _read_sweeps(path, poisson):
    """:func:`read_dma_sweeps` without the plausibility checks."""
    if not (0.0 <= poisson <= 0.5):
        raise ValueError(f"poisson must be in [0, 0.5]; got {poisson}")
    raw, blocks = read_blocks(path, _sweep_columns(), min_names=2, kind="DMA")
    path = raw.path
    if not blocks:
        first = [" ".join(c.strip() for c in r if c.strip())[:60] for _, r in raw.rows[:2]]
        raise ValueError(f"{path}: no DMA table found (read as {raw.describe()}; it begins {first}); expected "
                         f"{_EXPECTED}")
    tables = [t for _, t in blocks]
    mode = _mode(path, tables) or "G"
    parts = []
    for b, (title, t) in enumerate(blocks):
        tan, polar = "tan_delta" in t, f"{mode}_complex" in t
        has_storage = f"{mode}_storage" in t or (polar and tan)
        has_loss = f"{mode}_loss" in t or (tan and has_storage)
        title_T = _TITLE_TEMPERATURE.search(title)
        missing = [r for r, ok in (("frequency", "frequency" in t), ("storage", has_storage), ("loss", has_loss),
                                   ("temperature", "temperature" in t or title_T)) if not ok]
        if missing:
            where = f", line {t.lines[0] - 1}" if len(blocks) > 1 else ""
            raise ValueError(f"{path}{where}: no column for {missing}; the header has "
                             f"{sorted(t.header.values()) + t.unused} (expected {_EXPECTED})")
        storage, loss = _moduli(path, t, mode)
        if "temperature" in t:
            T = t["temperature"].copy()
        else:
            T = np.full(len(t.lines), np.nan)
        if title_T and np.all(np.isnan(T)):
            value, unit = title_T.groups()
            T[:] = float(value) + (0.0 if unit == "K" else 273.15)
        if len(blocks) > 1 and "set" not in t:
            raw_set = np.full(len(t.lines), float(b))
        else:
            raw_set = t.get("set")
        parts.append((t["frequency"], storage, loss, T, raw_set, t.lines))
    omega, storage, loss, T = (np.concatenate([p[k] for p in parts]) for k in range(4))
    lines = np.concatenate([p[5] for p in parts])
    raw_set = None if any(p[4] is None for p in parts) else np.concatenate([p[4] for p in parts])
    bad = np.isnan(omega) | np.isnan(storage) | np.isnan(loss)
    if bad.all():
        raise ValueError(f"{path}: no row gives the frequency, storage and loss moduli (missing values throughout)")
    if bad.any():
        warnings.warn(f"{path}: {int(bad.sum())} row(s) with a missing frequency or modulus skipped (lines "
                      f"{_line_list(lines[bad])})", DataWarning, stacklevel=3)
        keep = ~bad
        omega, storage, loss, T, lines = omega[keep], storage[keep], loss[keep], T[keep], lines[keep]
        raw_set = None if raw_set is None else raw_set[keep]
    out = (omega < _OMEGA_RANGE[0]) | (omega > _OMEGA_RANGE[1])
    if out.any():
        k = int(np.argmax(out))
        raise ValueError(f"{path}, line {lines[k]}: frequency {omega[k] / (2 * np.pi):.3g} Hz lies outside "
                         f"{_OMEGA_RANGE[0] / (2 * np.pi):.0e}..{_OMEGA_RANGE[1] / (2 * np.pi):.0e} Hz, where no DMA "
                         "measures; check the frequency column and its unit")
    if raw_set is None and np.any(np.isnan(T)):
        k = int(np.argmax(np.isnan(T)))
        name = next((t.header["temperature"] for t in tables if "temperature" in t), "temperature")
        raise ValueError(f"{path}, line {lines[k]}: missing value in column {name!r} (without a "
                         f"Set column every row needs its temperature)")
    factor = 1.0 / (2.0 * (1.0 + poisson)) if mode == "E" else 1.0
    storage, loss = storage * factor, loss * factor
    if raw_set is not None:
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
    return DMASweeps(omega, storage, loss, T, rank[labels], set_T[order], source, lines)


def _line_list(lines, n=8):
    """``'3, 4, 9'`` or ``'3, 4, ... (12 lines)'``."""
    text = ", ".join(str(int(x)) for x in lines[:n])
    return text + (f", ... ({len(lines)} lines)" if len(lines) > n else "")


def read_master_curve(path, *, T_ref, poisson=0.5):
    """Read a master curve that is already shifted (reduced frequency and moduli, no
    temperature sets) into the :class:`jaxroll.materials.MasterCurve` that
    :func:`jaxroll.fit_prony` takes.

    The file: any layout :func:`read_dma_sweeps` reads (encodings, delimiters, decimal commas,
    workbooks, units rows or units in the names), with the reduced frequency (``f``, ``omega``,
    ``frequency``: ``Hz`` or ``rad/s``) and the moduli (``E'``, ``E''`` / ``G'``, ``G''``, or
    ``|E*|`` and ``tan delta``); a temperature column, if any, is ignored.

    Args:
        path: the file.
        T_ref: the reference temperature of the curve [K] (files rarely say it).
        poisson: converts tensile moduli to shear, ``G = E / (2 (1 + nu))`` (default 0.5).

    Returns:
        :class:`MasterCurve` sorted by reduced frequency (one set, ``frequency`` None).
    """
    from .shift import MasterCurve

    if not (0.0 <= poisson <= 0.5):
        raise ValueError(f"poisson must be in [0, 0.5]; got {poisson}")
    raw, blocks = read_blocks(path, _sweep_columns(), min_names=2, kind="master-curve")
    path = raw.path
    tables = [t for _, t in blocks]
    mode = _mode(path, tables) if tables else None
    if mode is None or any("frequency" not in t for t in tables):
        raise ValueError(f"{path}: no master curve found (read as {raw.describe()}); expected a header row naming the "
                         "reduced frequency and the storage and loss moduli of one kind (E or G), e.g. "
                         "'f, E_stor, E_loss' with a units row 'Hz, MPa, MPa'")
    omega, storage, loss = (np.concatenate(x) for x in zip(*[(t["frequency"], *_moduli(path, t, mode))
                                                               for t in tables]))
    bad = np.isnan(omega) | np.isnan(storage) | np.isnan(loss)
    if bad.all():
        raise ValueError(f"{path}: no row gives the frequency, storage and loss moduli")
    if bad.any():
        warnings.warn(f"{path}: {int(bad.sum())} row(s) with a missing frequency or modulus skipped", DataWarning,
                      stacklevel=2)
    factor = 1.0 / (2.0 * (1.0 + poisson)) if mode == "E" else 1.0
    omega, storage, loss = omega[~bad], storage[~bad] * factor, loss[~bad] * factor
    order = np.argsort(omega, kind="stable")
    return MasterCurve(omega[order], storage[order], loss[order], np.zeros(len(omega), int), float(T_ref))


def _prony_columns():
    """The columns of a Prony table (names case-sensitive: ``g_i`` is normalised, ``G_i`` a
    modulus)."""
    mod, opt = UNITS["modulus"], dict(required=False, positive=True)
    return [
        Column("tau", UNITS["time"], aliases=("tau_i", "Tau", "Tau_i", "TAU", "TAU_I", "relaxation_time",
                                              "Relaxation time", "t_i"), required=False, finite=False, positive=True),
        Column("E", mod, aliases=("E_i", "Ei"), **opt),
        Column("G", mod, aliases=("G_i", "Gi"), **opt),
        Column("g", UNITS["dimensionless"], aliases=("g_i", "alpha_i", "alpha", "a_i", "e_i", "gi", "ai"), **opt),
        Column("index", None, aliases=("i", "I", "Index", "No.", "no.", "n"), required=False),  # read, not used
    ]


def read_prony_table(path, *, G_0=None, G_inf=None, E_0=None, E_inf=None, poisson=0.5):
    """Read a Prony series table into a shear :class:`jaxroll.GeneralizedMaxwell`.

    Tables as pyvisco, spreadsheets and FE pre-processors write them (any layout and encoding
    :func:`jaxroll.io.read_rows` reads; names case-sensitive): a relaxation time column
    ``tau_i`` [s] and either

    * moduli ``G_i`` (shear) or ``E_i`` (tension) in ``Pa`` .. ``GPa``, the long-term modulus
      given as ``G_inf`` / ``E_inf`` or as a row ``tau = inf``; or
    * normalised moduli ``g_i`` (``alpha_i``, as pyvisco and Abaqus write them), the fraction
      of the instantaneous modulus, ``G_i = g_i G_0``, ``G_inf = G_0 (1 - sum g_i)``; the scale
      given as the instantaneous ``G_0`` / ``E_0`` or the long-term ``G_inf`` / ``E_inf``
      (then ``G_0 = G_inf / (1 - sum g_i)``).

    Tensile moduli become shear moduli through ``G = E / (2 (1 + nu))``. Abaqus and ANSYS
    decks read through :func:`jaxroll.materials.load_material`.

    Args:
        path: the file.
        G_0, G_inf, E_0, E_inf: the instantaneous or long-term shear / tensile modulus [Pa]
            (one of them; none when the table's long-term modulus is a row ``tau = inf``).
        poisson: Poisson's ratio [-] for tensile moduli (default 0.5).

    Returns:
        :class:`jaxroll.GeneralizedMaxwell` (shear, Pa, s), terms sorted by ``tau``.
    """
    from .material import GeneralizedMaxwell

    if not (0.0 <= poisson <= 0.5):
        raise ValueError(f"poisson must be in [0, 0.5]; got {poisson}")
    scale = {k: v for k, v in dict(G_0=G_0, G_inf=G_inf, E_0=E_0, E_inf=E_inf).items() if v is not None}
    if len(scale) > 1:
        raise ValueError(f"read_prony_table: give one of G_0, G_inf, E_0, E_inf; got {sorted(scale)}")
    (key, value), = scale.items() if scale else ((None, None),)
    if value is not None and not (math.isfinite(value) and value > 0):
        raise ValueError(f"read_prony_table: {key} must be finite and > 0 [Pa]; got {value}")
    raw, blocks = read_blocks(path, _prony_columns(), min_names=2, kind="Prony", case_sensitive=True)
    expected = ("a header row naming the relaxation time 'tau_i' [s] and the moduli 'G_i' or 'E_i' [Pa..GPa], or "
                "the normalised 'g_i' / 'alpha_i' [-]")
    if len(blocks) != 1 or "tau" not in blocks[0][1]:
        raise ValueError(f"{raw.path}: no Prony table found (read as {raw.describe()}); expected {expected}")
    t = blocks[0][1]
    kinds = [k for k in ("G", "E", "g") if k in t]
    if len(kinds) != 1:
        raise ValueError(f"{raw.path}: the table needs one modulus column, G_i, E_i or g_i/alpha_i; found "
                         f"{[t.header[k] for k in kinds] or sorted(t.header.values()) + t.unused}")
    tau, m = t["tau"], t[kinds[0]]
    if np.any(np.isnan(tau) | np.isnan(m)):
        raise ValueError(f"{raw.path}, line {t.lines[np.argmax(np.isnan(tau) | np.isnan(m))]}: missing value")
    long = np.isinf(tau)
    if long.sum() > 1:
        raise ValueError(f"{raw.path}: more than one row with tau = inf")
    to_shear = 1.0 / (2.0 * (1.0 + poisson))
    if kinds[0] == "g":
        if long.any():
            raise ValueError(f"{raw.path}, line {t.lines[long][0]}: normalised terms take no row tau = inf")
        g = m
        if g.sum() >= 1.0:
            raise ValueError(f"{raw.path}: normalised terms need sum g_i < 1; got {g.sum():.6g}")
        if key is None:
            raise ValueError(f"{raw.path}: normalised terms (g_i) need the modulus they are fractions of: G_0 or "
                             "E_0 (instantaneous) or G_inf or E_inf (long-term) [Pa]")
        M0 = value if key.endswith("_0") else value / (1.0 - g.sum())
        G0 = M0 * (to_shear if key.startswith("E") else 1.0)
        order = np.argsort(tau)
        return GeneralizedMaxwell(G_inf=G0 * (1.0 - g.sum()), G=G0 * g[order], tau=tau[order])
    factor = to_shear if kinds[0] == "E" else 1.0
    if long.any() == (key is not None) or (key is not None and not key.endswith("_inf")):
        raise ValueError(f"{raw.path}: a table of moduli needs its long-term modulus once: a row tau = inf or "
                         f"G_inf/E_inf [Pa]; got {'a row tau = inf and ' if long.any() else ''}"
                         f"{key or 'no argument'}")
    G_inf = float(m[long][0]) * factor if long.any() else value * (to_shear if key.startswith("E") else 1.0)
    order = np.argsort(tau[~long])
    return GeneralizedMaxwell(G_inf=G_inf, G=m[~long][order] * factor, tau=tau[~long][order])


def read_shift_factors(path, *, T_ref=None):
    """Read shift factors (a temperature and ``log10 a_T`` per row, as instruments, pyvisco and
    ``jaxroll material``'s ``shift_factors.csv`` write them) into the
    :class:`jaxroll.materials.ShiftFactors` that :func:`jaxroll.materials.fit_wlf` takes.

    Columns (case-insensitive; any layout :func:`jaxroll.io.read_rows` reads): the temperature
    (``T``, ``temp``, ``temperature``; ``K`` or ``degC``) and ``log10_aT`` (``log_aT``,
    ``log(aT)``) or the factor itself, ``aT`` (``a_T``, ``shift_factor``); optional
    ``sigma``, ``step_sigma`` (their standard errors) and ``reference`` (1 on the reference
    row). Other columns are ignored.

    Args:
        path: the file.
        T_ref: the reference temperature [K] (default: the row marked ``reference``, else the
            row whose ``log10 a_T`` is 0). A ``T_ref`` between the rows is allowed: every row
            then counts in the fit.

    Returns:
        :class:`jaxroll.materials.ShiftFactors`, rows sorted by temperature (``reference`` -1
        when no row lies at ``T_ref``; unknown standard errors are 0).
    """
    from .shift import ShiftFactors

    opt = dict(required=False, blank=False)
    columns = [Column("temperature", UNITS["temperature"], aliases=("t", "temp"), **opt),
               Column("log10_aT", UNITS["dimensionless"], aliases=("log_aT", "log(aT)", "log10(aT)", "log_a_t",
                                                                   "log10_a_t", "log_shift_factor"), **opt),
               Column("aT", UNITS["dimensionless"], aliases=("a_t", "shift_factor"), positive=True, **opt),
               Column("sigma", UNITS["dimensionless"], **opt), Column("step_sigma", UNITS["dimensionless"], **opt),
               Column("reference", None, **opt)]
    raw, blocks = read_blocks(path, columns, min_names=2, kind="shift factor", warn_unused=False)
    tables = [t for _, t in blocks if "temperature" in t and ("log10_aT" in t or "aT" in t)]
    if len(tables) != 1:
        raise ValueError(f"{raw.path}: no shift-factor table found (read as {raw.describe()}); expected a header row "
                         "naming the temperature and log10_aT (or aT), e.g. 'T, log10_aT' with a units row 'K, -'")
    t = tables[0]
    T = t["temperature"]
    y = t["log10_aT"] if "log10_aT" in t else np.log10(t["aT"])
    order = np.argsort(T)
    T, y = T[order], y[order]
    if np.any(np.diff(T) <= 0):
        raise ValueError(f"{raw.path}: two rows give the same temperature")
    if T_ref is None:
        ref = np.flatnonzero(t["reference"][order] == 1) if "reference" in t else np.flatnonzero(y == 0.0)
        if len(ref) != 1:
            raise ValueError(f"{raw.path}: which row is the reference? No single row has log10_aT = 0 (or reference = "
                             "1); give T_ref")
        T_ref = float(T[ref[0]])
    T_ref = float(T_ref)
    at = np.flatnonzero(np.abs(T - T_ref) < 1e-6)
    zero = np.zeros(len(T))
    sigma, step = (t[k][order] if k in t else zero for k in ("sigma", "step_sigma"))
    return ShiftFactors(T, y, sigma, step, T_ref, int(at[0]) if len(at) else -1)


def read_isochronal(path, shift=None, *, T_ref=None, poisson=0.5):
    """Read isochronal temperature sweeps (moduli over temperature at one or a few fixed
    frequencies) into a master curve at the shift law's reference temperature.

    Every point moves to its reduced frequency ``omega a_T(T)`` with its own temperature:
    ``shift`` given (a :class:`jaxroll.WLF` or :class:`jaxroll.Arrhenius`), it is applied; else
    (two or more frequencies per temperature) the points are grouped into sets by temperature
    (more than 1 K apart), shifted (:func:`fit_shift_factors`) and a WLF law fitted to the
    shifts (:func:`fit_wlf`) is applied.

    The file: any layout :func:`read_dma_sweeps` reads (frequency, moduli, temperature
    columns); the plausibility checks of frequency sweeps (at least three frequencies per set,
    sets 0.5 K apart) do not apply to it.

    Args:
        path: the file.
        shift: the shift law; None: fitted (needs several frequencies).
        T_ref: reference temperature [K] of a fitted law (default: the middle of the measured
            range). Unused when ``shift`` is given (its ``T_ref`` is the master curve's).
        poisson: as :func:`read_dma_sweeps`.

    Returns:
        ``(MasterCurve, shift)``: the :class:`jaxroll.materials.MasterCurve` (``set``: each
        point's temperature set; ``frequency``: its measured frequency) and the law applied.
    """
    from .shift import MasterCurve, fit_shift_factors, fit_wlf

    sweeps = _read_sweeps(path, poisson)
    if shift is None:
        if len(np.unique(np.round(np.log10(sweeps.omega), 9))) < 2:
            raise ValueError(f"{path}: an isochronal sweep at one frequency determines no shift law; give the shift "
                             "law (read_isochronal(path, WLF(...)))")
        shift = fit_wlf(fit_shift_factors(sweeps, T_ref=T_ref)).shift
    w = sweeps.omega * np.exp(np.asarray(shift.log_shift(sweeps.temperature)))
    order = np.argsort(w, kind="stable")
    return (MasterCurve(w[order], sweeps.storage[order], sweeps.loss[order], sweeps.set[order], float(shift.T_ref),
                        sweeps.omega[order]), shift)
