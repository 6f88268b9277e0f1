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
from .prony import PronyFit


#: Terms whose modulus is below this fraction of the instantaneous modulus ``G_0`` are left out
#: of the FE decks: they change no modulus by more than that fraction (a refined fit can leave
#: terms of 1e-8 Pa beside moduli of 1e9 Pa), and the decks say how many were left out.
NEGLIGIBLE_TERM = 1e-6


def _terms(material: GeneralizedMaxwell):
    """``(G_0, g_i, tau_i, note)``: the relative moduli ``g_i = G_i/G_0`` of the terms kept and a
    comment on those left out (``None`` if none)."""
    G0 = float(material.glassy_modulus())
    g, tau = np.asarray(material.G) / G0, np.asarray(material.tau)
    keep = g >= NEGLIGIBLE_TERM
    note = None
    if not keep.all():
        note = (f"{int((~keep).sum())} term(s) with g_i < {NEGLIGIBLE_TERM:g} left out (together {g[~keep].sum():.3g} "
                "of G_0)")
    return G0, g[keep], tau[keep], note


def write_abaqus(material: GeneralizedMaxwell, path, *, shift: WLF | None = None, poisson=0.49):
    """Write an Abaqus material block: ``*ELASTIC, MODULI=INSTANTANEOUS`` (``E_0 = 2 G_0 (1 +
    nu)``, ``G_0`` the instantaneous shear modulus), ``*VISCOELASTIC, TIME=PRONY`` with lines
    ``g_i, k_i, tau_i`` (``g_i = G_i / G_0``; ``k_i = 0``: the bulk modulus does not relax),
    and, with a WLF shift, ``*TRS, DEFINITION=WLF`` (``T_ref`` [K], ``C1``, ``C2`` [K]).
    ``poisson`` (default 0.49) is the instantaneous Poisson's ratio Abaqus needs (< 0.5).
    Units SI (Pa, s, K)."""
    G0, g, tau, note = _terms(material)
    lines = ["** jaxroll Prony series (shear), SI units: Pa, s, K",
             f"** G_0 = {G0:.10g} Pa (instantaneous shear), G_inf = {float(material.G_inf):.10g} Pa"]
    lines += [f"** {note}"] if note else []
    lines += ["*ELASTIC, MODULI=INSTANTANEOUS", f"{2 * G0 * (1 + poisson):.10g}, {poisson:g}",
             "*VISCOELASTIC, TIME=PRONY"]
    lines += [f"{gi:.10g}, 0., {ti:.10g}" for gi, ti in zip(g, tau)]
    if shift is not None:
        lines += ["*TRS, DEFINITION=WLF", f"{float(shift.T_ref):.10g}, {float(shift.C1):.10g}, {float(shift.C2):.10g}"]
    Path(path).write_text("\n".join(lines) + "\n")


def write_ansys(material: GeneralizedMaxwell, path, *, shift: WLF | None = None, poisson=0.49, mat_id=1):
    """Write ANSYS APDL commands: ``MP,EX`` / ``MP,PRXY`` (instantaneous), ``TB,PRONY,,,n,SHEAR``
    with ``TBDATA`` pairs ``a_i, tau_i`` (``a_i = G_i / G_0``, six values per line) and, with a
    WLF shift, ``TB,SHIFT,,,3,WLF`` (``T_ref`` [K], ``C1``, ``C2`` [K]). Units SI."""
    G0, g, tau, note = _terms(material)
    flat = [v for pair in zip(g, tau) for v in pair]
    lines = ["! jaxroll Prony series (shear), SI units: Pa, s, K"] + ([f"! {note}"] if note else []) + [
             f"MP,EX,{mat_id},{2 * G0 * (1 + poisson):.10g}", f"MP,PRXY,{mat_id},{poisson:g}",
             f"TB,PRONY,{mat_id},,{len(g)},SHEAR"]
    for i in range(0, len(flat), 6):
        lines.append(f"TBDATA,{i + 1}," + ",".join(f"{v:.10g}" for v in flat[i : i + 6]))
    if shift is not None:
        lines += [f"TB,SHIFT,{mat_id},,3,WLF",
                  f"TBDATA,1,{float(shift.T_ref):.10g},{float(shift.C1):.10g},{float(shift.C2):.10g}"]
    Path(path).write_text("\n".join(lines) + "\n")


def save_material(path, material: GeneralizedMaxwell | PronyFit, shift: WLF | Arrhenius | None = None, *, info=None):
    """Save a Prony series (and its shift law) for :func:`load_material`: ``.json`` (full
    precision, with ``info``: any JSON-serialisable provenance) or ``.csv`` (columns ``tau``
    [s], ``G`` [Pa], first data row ``inf, G_inf``; the shift law in a ``#`` comment line).

    A :class:`PronyFit` saves its material, and the JSON's ``info["prony"]`` says how it was
    fitted: the error model its residuals were weighed by (``phase_sigma`` [rad],
    ``modulus_sigma`` [-]), its rms log residual and number of terms (``info``'s own ``prony``
    entries are kept beside them)."""
    path = Path(path)
    if isinstance(material, PronyFit):
        given = dict(info or {})
        fitted = {**material.error_model(), "rms_log": material.rms, "n_terms": material.n_terms}
        info = {**given, "prony": {**fitted, **given.get("prony", {})}}
        material = material.material
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


def _read_deck(path, text):
    """``(GeneralizedMaxwell, WLF or None)`` from an Abaqus (``*ELASTIC, MODULI=INSTANTANEOUS``,
    ``*VISCOELASTIC, TIME=PRONY``, ``*TRS, DEFINITION=WLF``) or ANSYS (``MP,EX``, ``MP,PRXY``,
    ``TB,PRONY``, ``TB,SHIFT`` WLF) deck of shear Prony terms: ``G_0 = E_0 / (2 (1 + nu))``,
    ``G_i = g_i G_0``, ``G_inf = G_0 (1 - sum g_i)``. Temperatures as written (jaxroll's decks:
    K)."""

    def numbers(line):
        try:
            return [float(v) for v in line.split(",") if v.strip()]
        except ValueError:
            raise ValueError(f"{path}: expected numbers in {line.strip()!r}") from None

    lines = [ln.strip() for ln in text.splitlines()]
    E0 = nu = None
    terms, wlf = [], None
    if any(ln.upper().startswith("*VISCOELASTIC") for ln in lines):  # Abaqus
        block = None
        for ln in lines:
            if not ln or ln.startswith("**"):
                continue
            if ln.startswith("*"):
                key = ln.upper().replace(" ", "")
                block = ("elastic" if key.startswith("*ELASTIC") else "prony" if key.startswith("*VISCOELASTIC")
                         and "TIME=PRONY" in key else "trs" if key.startswith("*TRS") and "WLF" in key else None)
                continue
            if block == "elastic" and E0 is None:
                E0, nu = numbers(ln)[:2]
            elif block == "prony":
                v = numbers(ln)
                terms.append((v[0], v[2]))
            elif block == "trs":
                wlf = numbers(ln)[:3]
    elif any(ln.upper().startswith("TB,PRONY") for ln in lines):  # ANSYS
        table = None
        data = {"PRONY": [], "SHIFT": []}
        for ln in lines:
            u = ln.upper()
            if u.startswith("MP,EX,"):
                E0 = numbers(ln.split(",", 3)[3])[0]
            elif u.startswith("MP,PRXY,"):
                nu = numbers(ln.split(",", 3)[3])[0]
            elif u.startswith("TB,"):
                table = "PRONY" if u.startswith("TB,PRONY") else "SHIFT" if "WLF" in u else None
            elif u.startswith("TBDATA,") and table:
                data[table] += numbers(ln.split(",", 2)[2])
        flat = data["PRONY"]
        terms = list(zip(flat[0::2], flat[1::2]))
        wlf = data["SHIFT"][:3] or None
    else:
        raise ValueError(f"{path}: neither an Abaqus deck (*VISCOELASTIC, TIME=PRONY) nor an ANSYS one (TB,PRONY)")
    if E0 is None or nu is None or not terms:
        raise ValueError(f"{path}: the deck needs the instantaneous E and nu (Abaqus *ELASTIC, MODULI=INSTANTANEOUS; "
                         "ANSYS MP,EX and MP,PRXY) and at least one Prony term")
    g, tau = np.array(terms).T
    if np.any(g <= 0) or np.any(tau <= 0) or g.sum() >= 1:
        raise ValueError(f"{path}: Prony terms need g_i > 0, tau_i > 0 and sum g_i < 1; got sum {g.sum():.6g}")
    G0 = E0 / (2.0 * (1.0 + nu))
    shift = None if wlf is None else WLF(C1=wlf[1], C2=wlf[2], T_ref=wlf[0])
    return GeneralizedMaxwell(G_inf=G0 * (1.0 - g.sum()), G=G0 * g, tau=tau), shift


def load_material(path):
    """Load a Prony series (shear) and its shift law: ``(GeneralizedMaxwell, shift or None)``.

    Reads what :func:`save_material` writes (``.json``, ``.csv``) and the decks of
    :func:`write_abaqus` / :func:`write_ansys` or any Abaqus (``*VISCOELASTIC, TIME=PRONY``) or
    ANSYS (``TB,PRONY``) deck of shear Prony terms (``.inp``, ``.mac``, ``.ans``, ``.dat``)."""
    path = Path(path)
    if path.suffix.lower() in (".inp", ".mac", ".ans", ".dat"):
        try:
            text = path.read_text(encoding="utf-8", errors="replace")
        except OSError as e:
            raise ValueError(f"{path}: cannot read the file ({e.strerror or e})") from None
        return _read_deck(path, text)
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
        raise ValueError(f"load_material: {path.name}: use a .json or .csv file, or an Abaqus/ANSYS deck (.inp, .mac)")
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
