"""Exports of a fitted material: Abaqus and ANSYS Prony decks, and jaxroll's own JSON
(:func:`save_material` / :func:`load_material`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..io import UNITS, Column, read_table, write_table
from .material import WLF, Arrhenius, GeneralizedMaxwell


def _terms(material: GeneralizedMaxwell):
    G0 = float(material.glassy_modulus())
    return G0, np.asarray(material.G) / G0, np.asarray(material.tau)


def write_abaqus(material: GeneralizedMaxwell, path, *, shift: WLF | None = None, poisson=0.49):
    """Write an Abaqus material block: ``*ELASTIC, MODULI=INSTANTANEOUS`` (``E_0 = 2 G_0 (1 +
    nu)``, ``G_0`` the instantaneous shear modulus), ``*VISCOELASTIC, TIME=PRONY`` with lines
    ``g_i, k_i, tau_i`` (``g_i = G_i / G_0``; ``k_i = 0``: the bulk modulus does not relax),
    and, with a WLF shift, ``*TRS, DEFINITION=WLF`` (``T_ref`` [K], ``C1``, ``C2`` [K]).
    ``poisson`` (default 0.49) is the instantaneous Poisson's ratio Abaqus needs (< 0.5).
    Units SI (Pa, s, K)."""
    G0, g, tau = _terms(material)
    lines = ["** jaxroll Prony series (shear), SI units: Pa, s, K",
             f"** G_0 = {G0:.10g} Pa (instantaneous shear), G_inf = {float(material.G_inf):.10g} Pa",
             "*ELASTIC, MODULI=INSTANTANEOUS", f"{2 * G0 * (1 + poisson):.10g}, {poisson:g}",
             "*VISCOELASTIC, TIME=PRONY"]
    lines += [f"{gi:.10g}, 0., {ti:.10g}" for gi, ti in zip(g, tau)]
    if shift is not None:
        lines += ["*TRS, DEFINITION=WLF", f"{float(shift.T_ref):.10g}, {float(shift.C1):.10g}, {float(shift.C2):.10g}"]
    Path(path).write_text("\n".join(lines) + "\n")


def write_ansys(material: GeneralizedMaxwell, path, *, shift: WLF | None = None, poisson=0.49, mat_id=1):
    """Write ANSYS APDL commands: ``MP,EX`` / ``MP,PRXY`` (instantaneous), ``TB,PRONY,,,n,SHEAR``
    with ``TBDATA`` pairs ``a_i, tau_i`` (``a_i = G_i / G_0``, six values per line) and, with a
    WLF shift, ``TB,SHIFT,,,3,WLF`` (``T_ref`` [K], ``C1``, ``C2`` [K]). Units SI."""
    G0, g, tau = _terms(material)
    flat = [v for pair in zip(g, tau) for v in pair]
    lines = ["! jaxroll Prony series (shear), SI units: Pa, s, K",
             f"MP,EX,{mat_id},{2 * G0 * (1 + poisson):.10g}", f"MP,PRXY,{mat_id},{poisson:g}",
             f"TB,PRONY,{mat_id},,{len(g)},SHEAR"]
    for i in range(0, len(flat), 6):
        lines.append(f"TBDATA,{i + 1}," + ",".join(f"{v:.10g}" for v in flat[i : i + 6]))
    if shift is not None:
        lines += [f"TB,SHIFT,{mat_id},,3,WLF",
                  f"TBDATA,1,{float(shift.T_ref):.10g},{float(shift.C1):.10g},{float(shift.C2):.10g}"]
    Path(path).write_text("\n".join(lines) + "\n")


def save_material(path, material: GeneralizedMaxwell, shift: WLF | Arrhenius | None = None, *, info=None):
    """Save a Prony series (and its shift law) for :func:`load_material`: ``.json`` (full
    precision, with ``info``: any JSON-serialisable provenance) or ``.csv`` (columns ``tau``
    [s], ``G`` [Pa], first data row ``inf, G_inf``; the shift law in a ``#`` comment line)."""
    path = Path(path)
    shift_d = None
    if isinstance(shift, WLF):
        shift_d = {"law": "WLF", "C1": float(shift.C1), "C2": float(shift.C2), "T_ref": float(shift.T_ref)}
    elif isinstance(shift, Arrhenius):
        shift_d = {"law": "Arrhenius", "activation_energy": float(shift.activation_energy),
                   "T_ref": float(shift.T_ref)}
    G, tau = np.asarray(material.G).tolist(), np.asarray(material.tau).tolist()
    if path.suffix.lower() == ".json":
        payload = {"material": "GeneralizedMaxwell", "G_inf": float(material.G_inf), "G": G, "tau": tau,
                   "shift": shift_d, "units": {"G_inf": "Pa", "G": "Pa", "tau": "s", "C2": "K", "T_ref": "K",
                                               "activation_energy": "J/mol"}, "info": info or {}}
        path.write_text(json.dumps(payload, indent=2) + "\n")
    elif path.suffix.lower() == ".csv":
        comments = ["jaxroll GeneralizedMaxwell (shear); row tau = inf holds G_inf"]
        comments += [] if shift_d is None else ["shift " + json.dumps(shift_d)]
        write_table(path, {"tau": [math.inf, *tau], "G": [float(material.G_inf), *G]}, ["s", "Pa"],
                    comments=comments)
    else:
        raise ValueError(f"save_material: {path.name}: use a .json or .csv file")


def load_material(path):
    """Load what :func:`save_material` wrote: ``(GeneralizedMaxwell, shift or None)``."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        try:
            d = json.loads(path.read_text())
        except (UnicodeDecodeError, json.JSONDecodeError) as e:
            raise ValueError(f"{path}: not a JSON file ({e})") from None
        if not isinstance(d, dict) or d.get("material") != "GeneralizedMaxwell":
            raise ValueError(f"{path}: not a jaxroll material file (no 'material': 'GeneralizedMaxwell')")
        missing = [k for k in ("G_inf", "G", "tau") if k not in d]
        if missing:
            raise ValueError(f"{path}: the material has no {missing}; a GeneralizedMaxwell needs 'G_inf' [Pa], "
                             "'G' [Pa] and 'tau' [s] (lists of one length)")
        try:
            G, tau = np.asarray(d["G"], float).ravel(), np.asarray(d["tau"], float).ravel()
            G_inf = float(d["G_inf"])
        except (TypeError, ValueError):
            raise ValueError(f"{path}: 'G_inf', 'G' and 'tau' must be numbers (lists for G and tau)") from None
        if len(G) != len(tau) or not (np.all(np.isfinite(G) & (G > 0)) and np.all(np.isfinite(tau) & (tau > 0))
                                      and math.isfinite(G_inf) and G_inf >= 0):
            raise ValueError(f"{path}: 'G' and 'tau' need one length and finite positive values, 'G_inf' >= 0; got "
                             f"{len(G)} G and {len(tau)} tau")
        mat = GeneralizedMaxwell(G_inf=G_inf, G=G, tau=tau)
        s = d.get("shift")
    elif path.suffix.lower() == ".csv":
        t = read_table(path, [Column("tau", UNITS["time"], positive=True, finite=False),
                              Column("G", UNITS["modulus"], positive=True)], kind="material")
        if not np.isinf(t["tau"][0]) or np.any(np.isinf(t["tau"][1:])):
            raise ValueError(f"{path}, line {t.lines[0]}: expected the row 'inf, G_inf' first, then finite tau")
        s = next((json.loads(c[len("shift "):]) for c in t.comments if c.startswith("shift ")), None)
        mat = GeneralizedMaxwell(G_inf=float(t["G"][0]), G=t["G"][1:], tau=t["tau"][1:])
    else:
        raise ValueError(f"load_material: {path.name}: use a .json or .csv file")
    shift = None
    if s is not None:
        need = {"WLF": ("C1", "C2", "T_ref"), "Arrhenius": ("activation_energy", "T_ref")}
        law = s.get("law") if isinstance(s, dict) else None
        if law not in need or any(k not in s for k in need[law]):
            raise ValueError(f"{path}: the shift law needs 'law': 'WLF' with C1, C2 [K], T_ref [K], or 'Arrhenius' "
                             f"with activation_energy [J/mol], T_ref [K]; got {s}")
        shift = (WLF(C1=s["C1"], C2=s["C2"], T_ref=s["T_ref"]) if law == "WLF"
                 else Arrhenius(activation_energy=s["activation_energy"], T_ref=s["T_ref"]))
    return mat, shift
