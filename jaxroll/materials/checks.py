"""Plausibility checks of DMA data: what a unit slip, a swapped column or a repeated point does
to frequency sweeps, found before the shifts and fits silently absorb it.

:func:`check_sweeps` returns one message per finding, each naming the set (index and
temperature) and the likely fix; :func:`jaxroll.materials.read_dma_sweeps` issues them as
:class:`jaxroll.DataWarning`. The thresholds are module constants, stated with their reason.
"""

from __future__ import annotations

import math

import numpy as np

from .read import DMASweeps

#: A set whose median log modulus differs from what its neighbours predict (linear in
#: temperature) by more than this many decades, and by a multiple of 3 to within
#: ``LEVEL_PREFIX_TOL``, is off by a unit prefix (10^3, 10^6). Real sets 5-10 K apart differ
#: from that prediction by < 0.05 decade in the shipped file through the glass transition; the
#: loss of a narrow spectrum 20 K apart (``jaxroll/datasets/dma_example.csv``) by 1.9 decades.
LEVEL_JUMP_DECADES, LEVEL_PREFIX_TOL = 2.0, 0.7
#: Shear moduli above this [Pa] are no polymer's (steel: 8e10 Pa): a unit slip.
MAX_MODULUS = 1e11
#: A glassy plateau: a set whose larger modulus has a median above this [Pa] (shear).
GLASSY_MODULUS = 1e8
#: Sets closer than this [K] are one temperature measured twice (their shift is undetermined).
MIN_SET_SPACING = 0.5
#: A set's storage falls with frequency when its log-log slope is negative by more than this many
#: standard errors and the fall across the set exceeds ``MIN_FALL_DECADES`` (storage rises
#: monotonically with frequency: Kramers-Kronig).
FALL_T_STAT, MIN_FALL_DECADES = 3.0, 0.05
#: On a glassy plateau the storage rises by only ~0.01 decade per decade (the shipped file's four
#: coldest sets: slopes 0.008-0.015, 3-16 standard errors), so a reversed glassy set falls by
#: less than ``MIN_FALL_DECADES``; there the flat glassy sets (median storage above
#: ``GLASSY_MODULUS``, changing by at most ``MIN_FALL_DECADES``) count as falling together when
#: most of them (and at least two) fall by more than ``FALL_T_STAT`` standard errors: one set's
#: artifact does not trip it.
#: Relative tolerance of a "round" frequency (1, 2, 2.5, 5 x 10^k) and of repeated frequencies.
ROUND_RTOL, SAME_RTOL = 2e-3, 1e-9


def set_name(sweeps: DMASweeps, i: int) -> str:
    """``'set 3 (20.00 degC)'``."""
    return f"set {i} ({sweeps.set_temperature[i] - 273.15:.2f} degC)"


def _lines(sweeps, mask):
    if sweeps.line is None:
        return ""
    lines = np.asarray(sweeps.line)[mask]
    text = ", ".join(str(int(x)) for x in lines[:8]) + (", ..." if len(lines) > 8 else "")
    return f" (lines {text})"


def _round(x):
    """Whether ``x`` is 1, 2, 2.5 or 5 times a power of ten (to ``ROUND_RTOL``)."""
    m = x / 10.0 ** np.floor(np.log10(x) + 1e-9)
    return bool(np.any(np.abs(m / np.array([1.0, 2.0, 2.5, 5.0, 10.0]) - 1.0) < ROUND_RTOL))


def _level_outliers(T, level):
    """``{set: decades}`` of sets whose level differs from the line through their neighbours
    (extrapolated at the ends) by a unit prefix (see ``LEVEL_JUMP_DECADES``); the worst first, each
    replaced by its prediction before the next is sought (one bad set does not flag its
    neighbours)."""
    level = level.copy()
    found = {}
    n = len(level)
    for _ in range(n):
        pred = np.empty(n)
        for i in range(n):
            a, b = (i - 1, i + 1) if 0 < i < n - 1 else ((1, 2) if i == 0 else (n - 2, n - 3))
            pred[i] = level[a] + (level[b] - level[a]) * (T[i] - T[a]) / (T[b] - T[a])
        dev = level - pred
        prefix = (np.abs(dev) > LEVEL_JUMP_DECADES) & (np.abs(dev - 3 * np.round(dev / 3)) < LEVEL_PREFIX_TOL)
        if not prefix.any():
            break
        k = int(np.argmax(np.where(prefix, np.abs(dev), 0.0)))
        if k in found:
            break
        found[k] = float(dev[k])
        level[k] = pred[k]
    return found


def _temperature_findings(sweeps: DMASweeps) -> list[str]:
    """Sets measured twice, and temperature units (degC labelled K or K labelled degC)."""
    out = []
    Ts = sweeps.set_temperature
    # sets closer than 0.5 K
    for i in np.flatnonzero(np.diff(Ts) < MIN_SET_SPACING):
        out.append(f"{set_name(sweeps, i)} and {set_name(sweeps, i + 1)} are {Ts[i + 1] - Ts[i]:.2g} K apart: one "
                   f"temperature measured twice? Give both the same Set label, or drop one (their shift is "
                   "undetermined)")
    # temperatures: degC labelled K, K labelled degC
    if Ts[-1] < 200.0:
        out.append(f"set temperatures {Ts[0]:.4g}..{Ts[-1]:.4g} K: no polymer is measured below 200 K only; are they "
                   "degC labelled K? Check the temperature unit")
    elif Ts[0] > 473.15:
        out.append(f"set temperatures {Ts[0] - 273.15:.4g}..{Ts[-1] - 273.15:.4g} degC: are they kelvin labelled degC? "
                   "Check the temperature unit")
    return out


def _unit_findings(sweeps: DMASweeps) -> list[str]:
    """Modulus and frequency units (a set's level decades off, moduli no polymer reaches, rad/s
    labelled Hz) and swapped storage/loss columns."""
    out = []
    n = sweeps.n_sets
    Ts = sweeps.set_temperature
    # unit prefixes: modulus levels and absolute size
    big = (sweeps.storage > MAX_MODULUS) | (sweeps.loss > MAX_MODULUS)
    if big.any():
        sets = sorted({int(s) for s in sweeps.set[big]})
        out.append(f"moduli up to {max(sweeps.storage.max(), sweeps.loss.max()):.3g} Pa (shear) in "
                   f"{', '.join(set_name(sweeps, s) for s in sets[:4])}{', ...' if len(sets) > 4 else ''}: above "
                   f"{MAX_MODULUS:.0e} Pa no polymer is that stiff; check the modulus unit (Pa vs MPa)")
    if n >= 3:
        for k, label in ((sweeps.storage, "storage"), (sweeps.loss, "loss")):
            level = np.array([np.median(np.log10(k[sweeps.set == i])) for i in range(n)])
            for i, d in _level_outliers(Ts, level).items():
                factor = 3 * round(d / 3)
                out.append(f"{set_name(sweeps, i)}: the {label} modulus is {d:+.1f} decades off its neighbours "
                           f"(10^{factor}: a unit slip such as Pa under an MPa header?); check that set's values")
    # rad/s labelled Hz: f / 2 pi round (the instrument's sweep in Hz) where omega / 2 pi is not
    looks_rad = 0
    for i in range(n):
        w = sweeps.select(i)[0]
        ends = (w[0], w[-1])
        if all(_round(x / (4 * math.pi**2)) for x in ends) and not all(_round(x / (2 * math.pi)) for x in ends):
            looks_rad += 1
    if looks_rad > n / 2:
        out.append(f"in {looks_rad} of {n} sets the frequencies read in Hz are 2 pi times round values: are they rad/s "
                   "labelled Hz? Check the frequency unit")
    # swapped storage and loss on a glassy plateau
    w0, s0, l0 = sweeps.select(0)
    if np.median(np.maximum(s0, l0)) > GLASSY_MODULUS and np.median(l0 / s0) > 1.0:
        out.append(f"{set_name(sweeps, 0)}: loss above storage on the glassy plateau at {int(np.sum(l0 > s0))} of "
                   f"{len(l0)} points (median tan delta {np.median(l0 / s0):.3g}): are the storage and loss columns "
                   "swapped?")
    return out


def _falling_findings(sweeps: DMASweeps) -> list[str]:
    """Sets with fewer than 3 frequencies, and storage falling with frequency (Kramers-Kronig)."""
    out = []
    n = sweeps.n_sets
    # storage falling with frequency; repeated points
    falling, glassy_falls = [], []
    for i in range(n):
        m = sweeps.set == i
        x, y = np.log10(sweeps.omega[m]), np.log10(sweeps.storage[m])
        distinct = np.unique(np.round(x, 9))
        if len(distinct) < 3:
            out.append(f"{set_name(sweeps, i)} has {len(distinct)} distinct frequenc{'y' if len(distinct) == 1 else 'ies'}"
                       f"{_lines(sweeps, m)}: a frequency sweep needs at least 3 to be shifted; check the frequency "
                       "column")
            continue
        if len(x) > 3:
            A = np.stack([x - x.mean(), np.ones_like(x)], axis=1)
            c, *_ = np.linalg.lstsq(A, y, rcond=None)
            r = y - A @ c
            se = math.sqrt(max(float(r @ r) / (len(x) - 2), 1e-30) / float(np.sum((x - x.mean()) ** 2)))
            significant = c[0] < -FALL_T_STAT * se
            if significant and -c[0] * (x.max() - x.min()) > MIN_FALL_DECADES:
                falling.append(i)
            elif np.median(sweeps.storage[m]) > GLASSY_MODULUS and abs(c[0]) * (x.max() - x.min()) <= MIN_FALL_DECADES:
                glassy_falls.append((i, significant))  # a flat glassy set
    if len(glassy_falls) >= 2 and sum(f for _, f in glassy_falls) > len(glassy_falls) / 2:
        falling = sorted(set(falling) | {i for i, f in glassy_falls if f})
    if falling:
        which = ", ".join(set_name(sweeps, i) for i in falling[:3]) + (", ..." if len(falling) > 3 else "")
        out.append(f"storage falls with frequency in {len(falling)} of {n} sets ({which}) (it can only rise: Kramers-Kronig): are the rows' "
                   "frequencies reversed, or the storage column another quantity?")
    return out


def _repeat_findings(sweeps: DMASweeps) -> list[str]:
    """Repeated rows, and repeated frequencies within a set."""
    out = []
    n = sweeps.n_sets
    key = np.stack([sweeps.set, sweeps.omega, sweeps.storage, sweeps.loss], axis=1)
    _, first, count = np.unique(key, axis=0, return_index=True, return_counts=True)
    dup = np.ones(len(key), bool)
    dup[first] = False
    if dup.any():
        out.append(f"{int(dup.sum())} repeated row(s){_lines(sweeps, dup)}: each copy weighs in the fits again; remove "
                   "them")
    for i in range(n):
        m = np.flatnonzero((sweeps.set == i) & ~dup)
        x = np.sort(sweeps.omega[m])
        same = np.diff(x) <= SAME_RTOL * x[1:]
        if same.any() and len(np.unique(np.round(np.log10(x), 9))) >= 3:
            out.append(f"{set_name(sweeps, i)} repeats {int(same.sum())} frequenc{'y' if same.sum() == 1 else 'ies'} "
                       f"(e.g. {x[1:][same][0] / (2 * math.pi):.4g} Hz): repeated measurements weigh more in the "
                       "shift; average or remove them")
    return out


def check_sweeps(sweeps: DMASweeps) -> list[str]:
    """Plausibility of multi-temperature DMA sweeps; one message per finding (empty: none).

    Found: a set whose modulus level is 10^3 or 10^6 off from its neighbours (Pa vs kPa/MPa);
    moduli above :data:`MAX_MODULUS`; frequencies that look like rad/s labelled Hz; temperatures
    that look like degC labelled K (or K labelled degC); loss above storage on a glassy plateau
    (swapped columns); storage falling with frequency; repeated rows and repeated frequencies
    within a set; sets with fewer than 3 distinct frequencies; sets closer than
    :data:`MIN_SET_SPACING`.
    """
    return (_temperature_findings(sweeps) + _unit_findings(sweeps) + _falling_findings(sweeps)
            + _repeat_findings(sweeps))
