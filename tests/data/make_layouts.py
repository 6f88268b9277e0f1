"""Writes the instrument-layout test files of this folder from the shipped DMA data.

The layouts follow the formats' public descriptions (no instrument file was copied): Eplexor
"Exported Data" (names and units in two header rows, ``---`` for a missing value, ``|E*|`` and
``tan delta``), TA TRIOS text export (tab-separated ``[step]`` segments, the temperature in the
step name), Anton Paar RheoCompass export (UTF-16 with BOM, tab-separated, decimal commas,
``Interval data:`` blocks with units in brackets). The numbers are four temperature sets of
``jaxroll/datasets/pyvisco_freq_user_raw.csv`` (tension, MPa), written as the instrument would:
tension for Eplexor, shear ``G = E / 3`` [Pa] and ``omega`` [rad/s] for the rheometers.

Run from the repository root: ``python tests/data/make_layouts.py``.
"""

import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
SETS = (0, 7, 12, 20)  # about -50, 2.5, 40, 100 degC


def shipped():
    raw = np.genfromtxt(HERE.parent.parent / "jaxroll/datasets/pyvisco_freq_user_raw.csv", delimiter=",", skip_header=2)
    return [raw[raw[:, 4] == s] for s in SETS]


def g(x):
    return f"{x:.10g}"


def eplexor(sets):
    """cp1252, semicolons, decimal commas; |E*| and tan delta; one E' cell '---'."""
    rows = ["Index;Set;T;f;E';E'';|E*|;tan delta", ";;°C;Hz;MPa;MPa;MPa;-"]
    k = 0
    for s, d in zip(SETS, sets):
        for f, e1, e2, T, _ in d:
            k += 1
            E1 = "---" if k == 5 else g(e1)  # a missing storage modulus: |E*| and tan delta give it
            rows.append(";".join([str(k), str(s), g(T), g(f), E1, g(e2), g(math.hypot(e1, e2)), g(e2 / e1)]))
    text = "\r\n".join(r.replace(".", ",") if i >= 2 else r for i, r in enumerate(rows)) + "\r\n"
    (HERE / "eplexor_exported_data.csv").write_bytes(text.encode("cp1252"))


def trios(sets):
    lines = ["Filename\tpyvisco_sample.tri", "Instrument type\tRheometer", "Geometry\tparallel plate 8 mm", ""]
    for k, d in enumerate(sets):
        T = d[:, 3].mean()  # the set point, to 0.1 degC in the step name
        lines += ["[step]", f"Frequency sweep ({T:.1f} °C)", "Number of points\t10",
                  "Angular frequency\tStorage modulus\tLoss modulus\ttan(delta)\tStep time",
                  "rad/s\tPa\tPa\t\ts"]
        for i, (f, e1, e2, _, _) in enumerate(d):
            lines.append("\t".join([g(2 * math.pi * f), g(e1 * 1e6 / 3), g(e2 * 1e6 / 3), g(e2 / e1), g(5.0 * i)]))
        lines.append("")
    (HERE / "trios_frequency_sweeps.txt").write_text("\n".join(lines), encoding="utf-8")


def rheocompass(sets):
    lines = ["Project:\tpyvisco sample", "Test:\tfrequency sweeps", "Result:\tfrequency sweeps 1",
             "Interval and data points:\t" + "\t".join([str(len(sets))] + ["10"] * len(sets))]
    for d in sets:
        lines += ["Interval data:\tPoint No.\tAngular Frequency\tStorage Modulus\tLoss Modulus\tLoss Factor\t"
                  "Temperature\tStatus", "\t[]\t[rad/s]\t[Pa]\t[Pa]\t[]\t[°C]\t[]"]
        for i, (f, e1, e2, T, _) in enumerate(d):
            cells = [str(i + 1), g(2 * math.pi * f), g(e1 * 1e6 / 3), g(e2 * 1e6 / 3), g(e2 / e1), g(T)]
            lines.append("\t" + "\t".join(c.replace(".", ",") for c in cells) + "\tDy_auto")
    (HERE / "rheocompass_intervals.txt").write_bytes(("\r\n".join(lines) + "\r\n").encode("utf-16"))


if __name__ == "__main__":
    s = shipped()
    eplexor(s)
    trios(s)
    rheocompass(s)
