"""Tables on disk: one reader and one writer for every CSV file jaxroll reads or writes.

Layout (the common convention of DMA instruments and spreadsheets): a header row of column
names, a row of units (required, optional, or absent; a unit may also be written in the name,
``E_stor [MPa]`` or ``E_stor (MPa)``), then one data row per point. Lines starting with ``#``
are comments (provenance) and blank lines are skipped; a UTF-8 byte-order mark is accepted and
Windows (CRLF) line ends are read alike. :func:`write_table` writes the same layout with LF line
ends, so what it writes :func:`read_table` reads back.

Reading happens in two steps:

1. :func:`read_rows`: bytes -> text -> cells, each row with its line number in the file. This
   is the one place that knows about encodings and delimiters.
2. :func:`read_table`: cells -> named SI columns, matched against :class:`Column` specs (names,
   aliases, allowed units with their conversion to SI, positivity, blanks).

Every error is a :class:`ValueError` of one line naming the file, the line, the column and what
was expected.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import re
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

__all__ = ["Column", "DataWarning", "MISSING", "RawTable", "Table", "TYPICAL", "UNITS", "read_blocks", "read_rows",
           "read_table", "write_table"]


class DataWarning(UserWarning):
    """Data that read, but look wrong: unused columns, skipped rows, implausible values (a unit
    slip, swapped columns, repeated points), or a fit that the data do not determine."""


#: Units understood per quantity, as ``unit: (scale, offset)`` with ``SI = value * scale + offset``.
UNITS = {
    "speed": {"m/s": (1.0, 0.0), "mm/s": (1e-3, 0.0), "km/h": (1 / 3.6, 0.0)},
    "force": {"N": (1.0, 0.0), "mN": (1e-3, 0.0), "kN": (1e3, 0.0)},
    "line_force": {"N/m": (1.0, 0.0), "mN/m": (1e-3, 0.0), "kN/m": (1e3, 0.0)},
    "frequency": {"Hz": (2 * math.pi, 0.0), "1/s": (2 * math.pi, 0.0), "rad/s": (1.0, 0.0)},
    "modulus": {"Pa": (1.0, 0.0), "kPa": (1e3, 0.0), "MPa": (1e6, 0.0), "GPa": (1e9, 0.0)},
    "temperature": {"K": (1.0, 0.0), "degC": (1.0, 273.15), "C": (1.0, 273.15), "°C": (1.0, 273.15),
                    "deg C": (1.0, 273.15), "ºC": (1.0, 273.15), "° C": (1.0, 273.15)},
    "time": {"s": (1.0, 0.0)},
    "dimensionless": {"-": (1.0, 0.0), "": (1.0, 0.0), "1": (1.0, 0.0)},
}


#: Typical SI magnitudes (median of a column) per quantity of :data:`UNITS`: a column outside
#: its range whose numbers would fall inside it in another accepted unit probably has the wrong
#: unit in its units row (a :class:`DataWarning` names the likelier unit). Forces have none
#: (rolling resistances span mN..kN); DMA moduli are checked per temperature set where the
#: DMA readers check their data.
TYPICAL = {
    "speed": (1e-4, 10.0),  # m/s: rolling tests and machines, 0.1 mm/s .. 36 km/h
    "temperature": (150.0, 500.0),  # K: -123 .. 227 degC
}


def _quantity(unit):
    """The :data:`UNITS` quantity ``unit`` belongs to (``None`` if none or several)."""
    hits = [q for q, table in UNITS.items() if _conversion(table, unit) is not None]
    return hits[0] if len(hits) == 1 else None


def _check_magnitudes(path, label, unit, conv, values):
    """A :class:`DataWarning` when the median of a column's SI ``values`` is untypical of its
    quantity (:data:`TYPICAL`) but typical in another unit of it: a units-row slip."""
    q = _quantity(unit)
    v = values[np.isfinite(values)]
    if q not in TYPICAL or not v.size:
        return
    lo, hi = TYPICAL[q]
    median = float(np.median(v))
    if lo <= median <= hi:
        return
    written = (median - conv[1]) / conv[0]
    likely = [u for u, (scale, offset) in UNITS[q].items() if lo <= written * scale + offset <= hi]
    if likely:
        warnings.warn(f"{path}: column {label!r} in {unit} has a median of {median:.3g} in SI units, untypical "
                      f"of a {q} ({lo:g}..{hi:g}); the numbers look like {likely[0]}: check the units row",
                      DataWarning, stacklevel=4)


@dataclasses.dataclass(frozen=True)
class Column:
    """What :func:`read_table` expects of one column.

    Attributes:
        name: the key of the column in the returned :class:`Table`, and its first accepted name.
        units: ``{unit: (scale, offset)}`` accepted units and their conversion to SI
            (``SI = value * scale + offset``); unit names match exactly, else case-insensitively
            when that is unambiguous. ``None``: a label or count, read as written (any unit
            text is ignored).
        required: a file without the column is an error (otherwise the column is optional).
        aliases: other accepted names in the header.
        positive: SI values must be > 0 (finite values are always required).
        finite: values must be finite (``False`` admits ``inf``; ``nan`` is never accepted).
        blank: empty cells are allowed (read as ``nan``).
    """

    name: str
    units: Mapping = dataclasses.field(default_factory=lambda: UNITS["dimensionless"])
    required: bool = True
    aliases: tuple = ()
    positive: bool = False
    finite: bool = True
    blank: bool = False

    @property
    def names(self):
        return (self.name, *self.aliases)


@dataclasses.dataclass(frozen=True)
class RawTable:
    """The cells of a table file: ``rows`` is a list of ``(line number, cells)``, comments and
    blank lines removed; ``comments`` the comment lines' text after ``#``; ``path`` names the
    file in messages."""

    path: Path
    rows: list
    comments: list
    encoding: str = "utf-8"
    delimiter: str | None = ","
    decimal: str = "."

    def describe(self) -> str:
        """How the file was read, for messages: ``'UTF-16, tab-separated, decimal comma'``."""
        if self.delimiter is None:
            return self.encoding
        sep = {",": "comma", ";": "semicolon", "\t": "tab"}.get(self.delimiter, repr(self.delimiter))
        return f"{self.encoding}, {sep}-separated" + (", decimal comma" if self.decimal == "," else "")


@dataclasses.dataclass(frozen=True)
class Table:
    """Columns read by :func:`read_table`.

    Attributes:
        columns: ``{name: SI float array}`` of the columns found (by :class:`Column` name).
        units: ``{name: unit as written in the file}``.
        header: ``{name: the column's name as written in the file}``.
        lines: file line number of each data row.
        unused: header names that matched no column.
        comments: the comment lines' text (after ``#``).
        path: the file.
    """

    columns: dict
    units: dict
    header: dict
    lines: np.ndarray
    unused: list
    comments: list
    path: Path

    def __getitem__(self, name):
        return self.columns[name]

    def __contains__(self, name):
        return name in self.columns

    def get(self, name, default=None):
        return self.columns.get(name, default)


#: Byte-order marks and the encodings they announce (UTF-16 first: its BOM is a prefix of none).
_BOMS = ((b"\xef\xbb\xbf", "utf-8-sig", "UTF-8"), (b"\xff\xfe", "utf-16", "UTF-16"),
         (b"\xfe\xff", "utf-16", "UTF-16"))
#: Magic numbers of spreadsheet workbooks: OLE2 (``.xls``) and zip (``.xlsx``).
_WORKBOOK_MAGIC = (b"\xd0\xcf\x11\xe0", b"PK\x03\x04")
#: Text that marks a missing value in instrument exports (Eplexor writes ``---``).
MISSING = ("", "---", "--", "n/a", "nan")
_DECIMAL_COMMA = re.compile(r"\s*[+-]?(\d+,\d*|,\d+)([eE][+-]?\d+)?\s*")
_DECIMAL_POINT = re.compile(r"\s*[+-]?(\d+\.\d*|\.\d+)([eE][+-]?\d+)?\s*")


def _decode(data: bytes):
    """``(text, encoding name)``: a byte-order mark decides; else UTF-16 without a mark (every
    other byte NUL), UTF-8, and cp1252 (Windows; Latin-1 where cp1252 leaves a byte undefined)."""
    for bom, codec, name in _BOMS:
        if data.startswith(bom):
            return data.decode(codec), name
    head = data[:4000]
    if len(head) >= 4 and head[1::2].count(0) > 0.4 * len(head[1::2]):
        return data.decode("utf-16-le", errors="replace"), "UTF-16LE"
    if len(head) >= 4 and head[0::2].count(0) > 0.4 * len(head[0::2]):
        return data.decode("utf-16-be", errors="replace"), "UTF-16BE"
    try:
        return data.decode("utf-8"), "UTF-8"
    except UnicodeDecodeError:
        pass
    try:
        return data.decode("cp1252"), "cp1252"
    except UnicodeDecodeError:
        return data.decode("latin-1"), "Latin-1"


def _sniff_delimiter(lines):
    """The delimiter of most lines: tab, semicolon or comma. Each candidate scores the number of
    lines that share its most common non-zero count; tab and semicolon win ties with the comma
    (a decimal comma adds commas to every number)."""
    scores = {}
    for d in ("\t", ";", ","):
        counts = [line.count(d) for line in lines if line.count(d)]
        if counts:
            mode = max(set(counts), key=counts.count)
            scores[d] = counts.count(mode)
    if not scores:
        return ","
    best = max(scores.values())
    return next(d for d in ("\t", ";", ",") if scores.get(d, 0) >= 0.5 * best)


def _read_workbook(path):
    """The cells of a workbook's data sheet (``Exported Data`` when there is one, as Eplexor
    writes it; else the first sheet with cells), each row with its row number; numbers as text
    in full precision. Needs the ``excel`` extra (openpyxl for ``.xlsx``, xlrd for ``.xls``)."""
    data = path.read_bytes()[:8]
    xls = data.startswith(_WORKBOOK_MAGIC[0])
    module = "xlrd" if xls else "openpyxl"
    try:
        lib = __import__(module)
    except ImportError:
        raise ValueError(f"{path}: reading an Excel workbook needs {module}: pip install \"jaxroll[excel]\" (or save "
                         "the sheet as CSV)") from None

    def cell(v):
        if v is None:
            return ""
        if isinstance(v, float):
            return repr(v)
        return str(v)

    if xls:
        book = lib.open_workbook(str(path))
        names = book.sheet_names()
        sheets = [book.sheet_by_name(n) for n in names]
        grids = [[[cell(c) for c in sh.row_values(i)] for i in range(sh.nrows)] for sh in sheets]
    else:
        book = lib.load_workbook(path, read_only=True, data_only=True)
        names = book.sheetnames
        grids = [[[cell(c) for c in row] for row in book[n].iter_rows(values_only=True)] for n in names]
        book.close()
    pick = names.index("Exported Data") if "Exported Data" in names else next(
        (k for k, g in enumerate(grids) if any(any(c.strip() for c in r) for r in g)), 0)
    return [(i + 1, r) for i, r in enumerate(grids[pick])], f"{'xls' if xls else 'xlsx'} sheet {names[pick]!r}"


def read_rows(path) -> RawTable:
    """Read a delimited text file or a spreadsheet into rows of cells with their line numbers.

    What is sniffed:

    * encoding: UTF-8 with or without a byte-order mark, UTF-16 (with a mark, or without one),
      cp1252 / Latin-1 (Windows exports with ``°C``);
    * delimiter: comma, semicolon or tab (the one that splits most lines alike);
    * decimal mark: a decimal comma (``1,5``) where the delimiter is not a comma and such
      numbers outnumber ``1.5``; cells are returned with a decimal point;
    * workbooks (``.xls``, ``.xlsx``, or a file starting with their magic number): the sheet
      ``Exported Data`` or the first sheet with cells, through the optional ``excel`` extra.

    ``\\n``, ``\\r\\n`` or ``\\r`` line ends. Lines whose first cell starts with ``#`` and lines of
    empty cells are dropped."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise ValueError(f"{path}: cannot read the file ({e.strerror or e})") from None
    if path.suffix.lower() in (".xls", ".xlsx", ".xlsm") or data.startswith(_WORKBOOK_MAGIC):
        rows, what = _read_workbook(path)
        encoding, delimiter, comments = what, None, []
    else:
        text, encoding = _decode(data)
        lines = text.splitlines()
        comments = [line.lstrip()[1:].strip() for line in lines if line.lstrip().startswith("#")]
        delimiter = _sniff_delimiter([ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")])
        rows = [(i + 1, r) for i, r in enumerate(csv.reader(lines, delimiter=delimiter))]
    rows = [(i, r) for i, r in rows if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    decimal = "."
    if delimiter != ",":
        cells = [c for _, r in rows for c in r]
        n_comma = sum(bool(_DECIMAL_COMMA.fullmatch(c)) for c in cells)
        if n_comma > sum(bool(_DECIMAL_POINT.fullmatch(c)) for c in cells):
            decimal = ","
            rows = [(i, [c.replace(",", ".") if _DECIMAL_COMMA.fullmatch(c) else c for c in r]) for i, r in rows]
    return RawTable(path, rows, comments, encoding, delimiter, decimal)


def _split_name(text, known=()):
    """``'E_stor [MPa]'`` / ``'E_stor (MPa)'`` -> ``('E_stor', 'MPa')``; ``'f'`` -> ``('f', None)``;
    a name in ``known`` stays whole (``'tan(delta)'``)."""
    if text.strip() in known:
        return text.strip(), None
    m = re.fullmatch(r"\s*(.*?)\s*[\[(]\s*(.*?)\s*[\])]\s*", text)
    return (m.group(1), m.group(2)) if m else (text.strip(), None)


def _unit_cell(text):
    """A units-row cell without brackets: ``'[Pa]'`` -> ``'Pa'``, ``'[]'`` -> ``''``."""
    text = text.strip()
    return text[1:-1].strip() if len(text) >= 2 and text[0] + text[-1] in ("[]", "()") else text


def _is_number(text):
    try:
        float(text)
        return True
    except ValueError:
        return False


#: First letters that are SI prefixes whose case changes the unit (milli/mega, pico/peta, kilo
#: and Kelvin, giga, nano, micro): a unit starting with one must match that letter's case.
_PREFIX_LETTERS = "mpkgnu"


def _conversion(units, unit):
    """``(scale, offset)`` of ``unit`` in ``units``, or None: an exact match, else the unique
    case-insensitive one whose first letter agrees in case where it is an SI prefix letter
    (``'hz'`` is Hz and ``'MPA'`` MPa, but ``'mpa'`` and ``'MN'`` are refused: milli/mega)."""
    if unit in units:
        return units[unit]

    def same_prefix(u):
        return not u or u[0].lower() not in _PREFIX_LETTERS or u[0] == unit[0]

    hits = [u for u in units if u.lower() == unit.lower() and same_prefix(u)]
    return units[hits[0]] if len(hits) == 1 else None


def _normaliser(case_sensitive):
    return (lambda s: s) if case_sensitive else (lambda s: s.lower().replace(" ", "_"))


def _match_columns(path, hline, header, names, columns, case_sensitive, require=True):
    """``{spec name: file column index}`` and the header names that match no spec; a spec
    matched twice is an error."""
    norm = _normaliser(case_sensitive)
    by_name = {norm(n): c for c in columns for n in c.names}
    where, unused = {}, []
    for j, n in enumerate(names):
        spec = by_name.get(norm(n))
        if spec is None:
            if header[j]:
                unused.append(header[j])
        elif spec.name in where:
            first = header[where[spec.name]]
            if norm(first) == norm(header[j]):
                raise ValueError(f"{path}, line {hline}: column name(s) {[spec.name]} appear more than once")
            raise ValueError(f"{path}, line {hline}: two columns give the {spec.name} ({first!r} and {header[j]!r})")
        else:
            where[spec.name] = j
    missing = [c.name for c in columns if c.required and c.name not in where]
    if missing and require:
        raise ValueError(f"{path}, line {hline}: missing column(s) {missing}; the header has {header}")
    return where, unused


def _header_names(header, columns, case_sensitive):
    """Names and units written in the names of a header row's cells."""
    norm = _normaliser(case_sensitive)
    known = {h for h in header if norm(h) in {norm(n) for c in columns for n in c.names}}
    return zip(*[_split_name(h, known) for h in header])


def read_table(path, columns: Sequence[Column], *, units_row="required", kind="data", case_sensitive=True,
               warn_unused=True) -> Table:
    """Read a CSV table into SI columns.

    Args:
        path: the file (see the module docstring for the layout; :func:`read_rows` for what is
            sniffed), or a :class:`RawTable` already read.
        columns: one :class:`Column` per expected column.
        units_row: ``"required"`` (the second row holds the units), ``"optional"`` (a second row
            without numbers holds the units; otherwise units come from the names, ``f [Hz]``).
        kind: what the file holds, for messages (``"DMA"``, ``"rolling-resistance"``).
        case_sensitive: match column names exactly (``False``: ignoring case and with spaces
            read as ``_``).
        warn_unused: warn (:class:`DataWarning`) about header names that match no column.

    Returns:
        :class:`Table`.

    Raises:
        ValueError: one line naming the file, line and column of what is wrong and what was
            expected.
    """
    if units_row not in ("required", "optional"):
        raise ValueError(f"units_row must be 'required' or 'optional'; got {units_row!r}")
    raw = path if isinstance(path, RawTable) else read_rows(path)
    need = 3 if units_row == "required" else 2
    if len(raw.rows) < need:
        raise ValueError(f"{raw.path}: a {kind} CSV needs a header row of names, "
                         + ("a row of units " if units_row == "required" else "") + "and data rows")
    return _read_block(raw, raw.rows, columns, units_row=units_row, kind=kind, case_sensitive=case_sensitive,
                       warn_unused=warn_unused)


def read_blocks(path, columns: Sequence[Column], *, min_names=2, kind="data", case_sensitive=False, warn_unused=True):
    """Read every table of a file whose header row names at least ``min_names`` of ``columns``:
    instrument exports with one table per step or interval (TA TRIOS ``[step]`` segments,
    Anton Paar RheoCompass ``Interval data:`` blocks) or one table under a preamble.

    Each block is a header row, an optional units row (units may also sit in the names, or in
    brackets, ``[Pa]``), and the data rows that follow while the matched columns hold numbers
    (or a missing mark, ``---``); the text rows before a header (step or interval names) are its
    ``title``. Names that match no column are ignored.

    Args:
        path: the file, or a :class:`RawTable` already read.
        columns, kind, case_sensitive: as :func:`read_table`.
        min_names: how many of ``columns`` a header row must name.
        warn_unused: warn (:class:`DataWarning`) about names that match no column when the
            file is one plain table (its header the first row); instrument exports with a
            preamble or several blocks carry many other columns and are not warned about.

    Returns:
        ``(raw, blocks)``: the :class:`RawTable` and a list of ``(title, Table)``, in file order
        (empty when no row looks like a header).
    """
    raw = path if isinstance(path, RawTable) else read_rows(path)
    rows = raw.rows
    norm = _normaliser(case_sensitive)
    names = {norm(n) for c in columns for n in c.names}
    heads = []
    for k, (_, r) in enumerate(rows):
        cells = [h.strip() for h in r]
        if any(_is_number(c) for c in cells if c):  # a data row (fast path: most rows)
            continue
        found = {norm(n) for n in next(iter(_header_names(cells, columns, case_sensitive)), ())} & names
        if len(found) >= min_names:
            heads.append(k)
    blocks, prev_end = [], 0
    for n, k in enumerate(heads):
        stop = heads[n + 1] if n + 1 < len(heads) else len(rows)
        header = [h.strip() for h in rows[k][1]]
        hnames, _ = _header_names(header, columns, case_sensitive)
        where, _ = _match_columns(raw.path, rows[k][0], header, hnames, columns, case_sensitive, require=False)
        cols = list(where.values())

        def numeric(r):
            """Fraction of the matched cells that hold numbers (or a missing mark), or 0 if none
            holds a number."""
            cells = [r[j].strip() if j < len(r) else "" for j in cols]
            good = sum(_is_number(c) or c.lower() in MISSING for c in cells)
            return good / max(len(cells), 1) if any(_is_number(c) for c in cells) else 0.0

        end = k + 1
        if end < stop and numeric(rows[end][1]) < 1:
            end += 1  # units row
        # data rows; a row with a bad cell among numbers stays in, so that its error names it
        while end < stop and numeric(rows[end][1]) >= 0.5:
            end += 1
        title = " ".join(" ".join(c.strip() for c in r if c.strip()) for _, r in rows[prev_end:k]).strip()
        plain = len(heads) == 1 and k == 0
        blocks.append((title, _read_block(raw, rows[k:end], columns, units_row="optional", kind=kind,
                                          case_sensitive=case_sensitive, warn_unused=warn_unused and plain,
                                          require=False)))
        prev_end = end
    return raw, blocks


def _read_block(raw, rows, columns, *, units_row, kind, case_sensitive, warn_unused, require=True):
    """One table: ``rows[0]`` the header, then a units row (required or optional), then data."""
    path = raw.path
    if len(rows) < 2:
        raise ValueError(f"{path}, line {rows[0][0]}: a header row without data rows")
    hline, header = rows[0]
    header = [h.strip() for h in header]
    names, name_units = _header_names(header, columns, case_sensitive)
    where, unused = _match_columns(path, hline, header, names, columns, case_sensitive, require=require)
    if unused and warn_unused:
        expected = [c.name for c in columns if c.required]
        optional = [c.name for c in columns if not c.required]
        warnings.warn(f"{path}: column(s) {unused} not used (a {kind} CSV has {expected}"
                      + (f", optional {optional}" if optional else "") + "); check the spelling",
                      DataWarning, stacklevel=3)

    # units: a row, or in the names
    body = rows[1:]
    uline, first = body[0]
    units = list(name_units)
    used = sorted(where.values())
    first_used = [first[j] for j in used if j < len(first)]
    has_units_row = units_row == "required" or not any(_is_number(c) for c in first_used if c.strip())
    if has_units_row:
        if units_row == "required" and len(first) != len(header) or len(first) < max(used, default=-1) + 1:
            raise ValueError(f"{path}, line {uline}: the units row has {len(first)} entries for {len(header)} columns")
        units = [u if u is not None else _unit_cell(first[j]) if j < len(first) else "" for j, u in enumerate(units)]
        body = body[1:]
    elif any(not _is_number(c) for c in first_used if c.strip().lower() not in MISSING):
        raise ValueError(f"{path}, line {uline}: mixes numbers and text; expected a units row or a data row")
    if not body:
        raise ValueError(f"{path}: no data rows")
    for line, r in body:
        if len(r) > len(header) and any(c.strip() for c in r[len(header):]):
            raise ValueError(f"{path}, line {line}: {len(r)} cells for {len(header)} columns (extra values after "
                             f"{header[-1]!r})")

    out, out_units, out_header = {}, {}, {}
    for spec in columns:
        if spec.name not in where:
            continue
        j = where[spec.name]
        unit = units[j]
        if spec.units is None:
            conv = (1.0, 0.0)
        elif unit is None:
            example = next(iter(spec.units))
            raise ValueError(f"{path}, line {hline}: column {header[j]!r} has no unit; give a units row or write the "
                             f"unit in the name, e.g. '{names[j]} [{example}]'")
        else:
            conv = _conversion(spec.units, unit)
        if conv is None:
            hint = " (is the units row missing?)" if _is_number(unit) else ""
            raise ValueError(f"{path}, line {uline if has_units_row else hline}: unit {unit!r} of column {header[j]!r} "
                             f"not understood{hint}; expected one of {sorted(spec.units)}")
        out[spec.name] = _convert(path, body, j, header[j], spec, unit, conv)
        if spec.units is not None:
            _check_magnitudes(path, header[j], unit, conv, out[spec.name])
        out_units[spec.name], out_header[spec.name] = unit, header[j]
    return Table(out, out_units, out_header, np.array([line for line, _ in body]), unused,
                 raw.comments, path)


def _convert(path, body, j, label, spec, unit, conv):
    """The SI values of column ``j`` (``nan`` for allowed blanks and missing marks such as
    ``---``); errors name the line."""
    scale, offset = conv
    try:  # fast path: every cell a finite number
        v = np.array([r[j] if j < len(r) else "" for _, r in body], dtype=float) * scale + offset
        if np.all(np.isfinite(v)) and (not spec.positive or np.all(v > 0)):
            return v
    except ValueError:
        pass
    values = np.full(len(body), np.nan)  # the slow path finds the blanks and names what is wrong
    for k, (line, r) in enumerate(body):
        text = r[j].strip() if j < len(r) else ""
        if text.lower() in MISSING:
            if spec.blank:
                continue
            raise ValueError(f"{path}, line {line}: missing value in column {label!r}")
        try:
            v = float(text)
        except ValueError:
            raise ValueError(f"{path}, line {line}: {label} = {text!r} is not a number") from None
        if math.isnan(v) or (spec.finite and not math.isfinite(v)):
            raise ValueError(f"{path}, line {line}: {label} is {text!r}; values must be finite")
        v = v * scale + offset
        if spec.positive and not v > 0:
            what = "above absolute zero" if offset or unit == "K" else "positive"
            hint = " (degC labelled K?)" if unit == "K" else ""
            raise ValueError(f"{path}, line {line}: {label} must be {what}, got {text} {unit or ''}".rstrip() + hint)
        values[k] = v
    return values


def write_table(path, columns: Mapping[str, Sequence], units: Sequence[str], *, formats=None, comments=()):
    """Write a CSV table: a header row, a units row, one row per point, LF line ends.

    Args:
        path: the file (overwritten).
        columns: ``{name: values}``, all of one length; values are numbers or text.
        units: one unit per column (``"-"`` for none), in ``columns`` order.
        formats: a format spec for numbers (e.g. ``".8g"``), or ``{name: spec}`` per column;
            numbers without a spec are written in full precision (``repr``); integers and text
            as they are.
        comments: lines written first, each prefixed ``# ``.
    """
    names = list(columns)
    if len(units) != len(names):
        raise ValueError(f"write_table: {len(units)} units for {len(names)} columns")
    data = [list(columns[n]) if not isinstance(columns[n], np.ndarray) else columns[n].tolist() for n in names]
    lengths = {len(d) for d in data}
    if len(lengths) > 1:
        raise ValueError(f"write_table: columns of different lengths {dict(zip(names, map(len, data)))}")
    spec = formats if isinstance(formats, Mapping) else dict.fromkeys(names, formats)

    def cell(x, fmt):
        if isinstance(x, str) or isinstance(x, (bool, int, np.bool_, np.integer)):
            return str(int(x)) if isinstance(x, (bool, np.bool_)) else str(x)
        return format(float(x), fmt) if fmt else repr(float(x))

    with open(path, "w", newline="", encoding="utf-8") as fh:
        for c in comments:
            fh.write(f"# {c}\n")
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(names)
        w.writerow(list(units))
        for row in zip(*data):
            w.writerow([cell(x, spec.get(n)) for x, n in zip(row, names)])
