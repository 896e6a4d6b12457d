"""Laboratory CSV files (logger exports) read into a time-series table: measurements and load histories.

A logger export is rarely the toolkit's own ``t,<face>,...`` file (:mod:`aromm.core.observables`).  This reader
accepts what loggers and spreadsheets write, and says what it did:

* **encodings**: UTF-8 (with or without the byte-order mark of spreadsheet exports), UTF-16 (with its byte-order
  mark: "Unicode text" from Excel), else latin-1 (a ``°`` written by a Windows logger); the encoding used is reported
  when it is not UTF-8;
* **comment and metadata lines**: lines starting with ``#`` are skipped (anywhere in the file), and so are the lines
  before the header (``Datalogger: Agilent 34972A``), the header being the first line whose first column names the
  time (reported);
* **delimiter and decimal mark**: ``,``, ``;`` or a tab, found by :class:`csv.Sniffer` on the first lines, and a
  decimal comma (``20,5``) when the delimiter is not a comma;
* **units**: a units row under the header (``s;°C;°C``) or a unit in the column name (``t (min)``, ``TC1 [K]``):
  times in ``ms``, ``s``, ``min``, ``h`` are converted to s, temperatures in ``K`` to °C, each conversion reported;
* **column names**: the first column is the time (``t``, ``time``, ``temps``, ``zeit``, ``tiempo``, ``tempo``,
  ``elapsed``, or any name mapped onto ``t``: ``--column Zeit=t``); the others are the scene's outputs (faces,
  sensors) or are mapped onto them (``columns={"TC1": "z0"}``, ``--column TC1=z0``), unmapped columns then being
  ignored (reported); empty trailing columns (a spreadsheet's ``,,``) are dropped (reported);
* **clock times**: ``09:14:01`` (``hh:mm:ss``, fractions of seconds allowed) are converted to seconds after the
  first row, across midnight (reported: the heating may have started at another moment, a clock offset);
* **missing values**: an empty cell or ``NA``, ``N/A``, ``-``, ``null`` drops its row; the rows dropped are counted;
* **physical checks** (:mod:`aromm.core.labchecks`): logger sentinels, values below absolute zero or outside a plausible
  range, a single outlier, are refused naming the file, line and column.

Every problem raises :class:`~aromm.core.errors.InputError` naming the file, the line (of the file, comments counted)
and the column.  Why the standard library's :mod:`csv` rather than pandas: pandas is a large dependency that the
base install does not need, and it loses the file's line numbers once comment and units rows are skipped, while
every message here must name the line; the quirks above are a few lines each on top of :class:`csv.Sniffer`.
"""

from __future__ import annotations

import csv
import logging
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from aromm.core.errors import InputError
from aromm.core.labchecks import PLAUSIBLE, Quantity, check_values
from aromm.core.observables import Observables, output_kind
from aromm.core.system import FloatArray

log = logging.getLogger(__name__)

TIME_NAMES = ("t", "time", "temps", "zeit", "tiempo", "tempo", "elapsed", "elapsed time")
_CLOCK = re.compile(r"^(?P<h>\d{1,2}):(?P<m>\d{2}):(?P<s>\d{2}(?:[.,]\d+)?)$")
#: Time units and their factor to seconds.
TIME_UNITS = {"ms": 1e-3, "s": 1.0, "sec": 1.0, "min": 60.0, "h": 3600.0, "hr": 3600.0}
#: Temperature spellings: every one means °C or K.
CELSIUS = ("°c", "degc", "deg c", "c", "ºc", "celsius")
KELVIN = ("k", "kelvin")
TEMPERATURE_UNITS = ("°C", "K")
#: Units of a non-temperature history (heat flux, or a moisture flux g): read as they are.
FLUX_UNITS = ("w/m2", "w/m²", "w m-2", "w/(m2)", "w/(m²)")
MOISTURE_FLUX_UNITS = ("kg/(m2 s)", "kg/(m² s)", "kg/m2/s", "kg/m²/s", "kg m-2 s-1", "kg/(m2.s)", "kg/(m²·s)")
MISSING = ("", "na", "n/a", "-", "--", "null", "none")
KELVIN_OFFSET = 273.15
SNIFF_LINES = 20
MAX_BYTES = 1_000_000_000  #: largest CSV read (bytes): about ten million rows of a few columns
_UNIT_IN_NAME = re.compile(r"^(?P<name>.*?)\s*[\(\[](?P<unit>[^\)\]]*)[\)\]]\s*$")


@dataclass(frozen=True)
class LabTable:
    """The table read (times in s, temperatures in °C) and what the reader did to get it.

    ``notes`` are the conversions, the ignored columns, the dropped rows and the encoding, one sentence each;
    ``lines`` the file line of each kept row; ``temperature_stated`` whether the file or the caller stated the
    temperature unit (else °C was assumed: :func:`aromm.core.labchecks.kelvin_suspect` can then be asked).
    """

    table: Observables
    notes: tuple[str, ...]
    lines: tuple[int, ...]
    temperature_stated: bool
    columns: Mapping[str, str] = field(default_factory=dict)  # output -> column name in the file


def _decode(path: Path, what: str) -> tuple[str, str]:
    """The file's text and encoding; a folder, a device or a pipe (which may never end), or a file above
    :data:`MAX_BYTES`, is refused before it is read."""
    try:
        if path.exists() and not path.is_file():
            raise InputError(f"{path}: the {what} is not a regular file (a folder, a device or a pipe); give a CSV "
                             "file")
        if path.is_file() and path.stat().st_size > MAX_BYTES:
            raise InputError(f"{path}: the {what} is {path.stat().st_size / 1e9:.3g} GB, above the {MAX_BYTES / 1e9:g} "
                             "GB a logger's CSV may take here (ten million rows); thin it out (every n-th row)")
        raw = path.read_bytes()
    except OSError as err:
        raise InputError(f"{path}: cannot read the {what} ({err.strerror or err})") from None
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        try:
            return raw.decode("utf-16"), "UTF-16"
        except UnicodeDecodeError:
            pass
    try:
        return raw.decode("utf-8-sig"), "utf-8"
    except UnicodeDecodeError:
        return raw.decode("latin-1"), "latin-1"


def _header_row(rows: list[tuple[int, list[str]]], time_names: set[str], notes: list[str]) -> int:
    """The index of the header among ``rows``: the first with a column after the time whose first cell names the
    time; the rows before it are a logger's metadata (reported).  0 when none does (the header check then says
    what a header must be)."""
    for i, (_, cells) in enumerate(rows):
        if len(cells) >= 2 and _split_name(cells[0])[0].lower() in time_names:
            if i:
                notes.append(f"{i} metadata line(s) before the header skipped (line(s) {rows[0][0]}–{rows[i - 1][0]})")
            return i
    return 0


def _without_empty_tail(rows: list[tuple[int, list[str]]], notes: list[str]) -> list[tuple[int, list[str]]]:
    """``rows`` without the trailing columns that are empty in the header and in every row (``,,``)."""
    width = len(rows[0][1])
    keep = width
    while keep > 2 and all(len(cells) < keep or not cells[keep - 1] for _, cells in rows):
        keep -= 1
    if keep == width:
        return rows
    notes.append(f"{width - keep} empty trailing column(s) dropped")
    return [(n, cells[:keep]) for n, cells in rows]


def _clock_seconds(p: Path, body: list[tuple[int, list[str]]], notes: list[str]) -> list[tuple[int, list[str]]]:
    """Clock times ``hh:mm:ss`` in the first column → seconds after the first row (a day added at each wrap)."""
    if not body or not _CLOCK.match(body[0][1][0]):
        return body
    out, day, last, first = [], 0.0, -1.0, None
    for line, cells in body:
        m = _CLOCK.match(cells[0])
        if m is None:
            raise InputError(f"{p} line {line}: time {cells[0]!r} is not a clock time hh:mm:ss like the first row's")
        clock = int(m["h"]) * 3600 + int(m["m"]) * 60 + float(m["s"].replace(",", "."))
        if clock + day < last:
            day += 86400.0
        last = clock + day
        first = last if first is None else first
        out.append((line, [repr(last - first), *cells[1:]]))
    notes.append(f"clock times converted to seconds after the first row ({body[0][1][0]}); if the heating started "
                 "at another moment, identify the offset too (--unknown time_offset=LOW:HIGH)")
    return out


def _dialect(lines: list[str]) -> tuple[str, bool]:
    """(delimiter, decimal comma) of the first data-like lines."""
    sample = "\n".join(lines[:SNIFF_LINES])
    try:
        delimiter = csv.Sniffer().sniff(sample, delimiters=",;\t").delimiter
    except csv.Error:
        counts = {d: lines[0].count(d) for d in ";\t,"}
        delimiter = max(counts, key=lambda d: counts[d]) if any(counts.values()) else ","
    if delimiter != "," and any(c in lines[0] for c in ";\t") and lines[0].count(delimiter) == 0:
        delimiter = ";" if ";" in lines[0] else "\t"
    decimal_comma = delimiter != "," and any(re.search(r"\d,\d", ln) for ln in lines[1:SNIFF_LINES])
    return delimiter, decimal_comma


def _split_name(text: str) -> tuple[str, str | None]:
    """``"TC1 (°C)"`` → ``("TC1", "°C")``; a name without a unit → ``(name, None)``."""
    text = text.strip().strip('"').strip()
    m = _UNIT_IN_NAME.match(text)
    return (m["name"].strip(), m["unit"].strip()) if m and m["name"].strip() else (text, None)


def _is_number(cell: str, decimal_comma: bool) -> bool:
    try:
        float(cell.strip().replace(",", ".") if decimal_comma else cell.strip())
    except ValueError:
        return False
    return True


def _time_factor(unit: str | None, where: str, given: str | None) -> tuple[float, str]:
    spelled = (unit or given or "s").strip()
    if spelled.lower() not in TIME_UNITS:
        raise InputError(f"{where}: unknown time unit {spelled!r}; allowed: {', '.join(TIME_UNITS)}")
    return TIME_UNITS[spelled.lower()], spelled


def _temperature_kelvin(unit: str, where: str) -> bool:
    low = unit.strip().lower().replace("\u00a0", " ")
    if low in CELSIUS:
        return False
    if low in KELVIN:
        return True
    raise InputError(f"{where}: unknown temperature unit {unit!r}; allowed: °C (degC, C) or K")


def _cells(path: Path, number: int, line: str, delimiter: str) -> list[str]:
    """The cells of one line, each stripped; a quote left open (``1,"0.1,0.05``) is refused with its line: a
    quoted cell never spans lines in a logger's export."""
    try:
        return [c.strip() for c in next(csv.reader([line], delimiter=delimiter, strict=True), [])]
    except csv.Error as err:
        raise InputError(f"{path} line {number}: {err} (a quote \" left open?): {line.strip()!r}") from None


def read_lab_csv(path: str | os.PathLike[str], outputs: Iterable[str] | None = None, *,
                 columns: Mapping[str, str] | None = None, time_unit: str | None = None,
                 temperature_unit: str | None = None, quantity: Quantity = "temperature",
                 plausible: tuple[float, float] = PLAUSIBLE, what: str = "measurement file") -> LabTable:
    """Read a laboratory CSV (module docstring); ``outputs`` lists the allowed output names, ``columns`` maps
    file columns onto them (file name → output), ``time_unit`` / ``temperature_unit`` state units the file
    does not carry (a unit in the file wins only when it agrees; a conflict is refused).  ``quantity`` is what the
    value columns hold (``"temperature"`` in °C or K; ``"flux"`` in W/m², a load history; ``"humidity"`` a
    relative humidity, a fraction or %RH; ``"moisture_flux"`` in kg/(m² s)); ``plausible`` the range (°C) a
    temperature may take.

    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "log.csv"
    >>> _ = f.write_text("# logger 7\\ntime;TC1\\nmin;°C\\n0;20,5\\n0,5;21,0\\n", encoding="latin-1")
    >>> lab = read_lab_csv(f, ["z0"], columns={"TC1": "z0"})
    >>> lab.table.t.tolist(), lab.table.mean_T["z0"].tolist()
    ([0.0, 30.0], [20.5, 21.0])
    """
    p = Path(path)
    text, encoding = _decode(p, what)
    numbered = [(i + 1, ln) for i, ln in enumerate(text.splitlines())
                if ln.strip() and not ln.lstrip().startswith("#")]
    if not numbered:
        raise InputError(f"{p}: empty file (no header, no rows: lines starting with # are comments); expected a "
                         "header 't,<face>,...' and one row per time")
    notes = [] if encoding == "utf-8" else [f"read as {encoding} (not UTF-8)"]
    delimiter, decimal_comma = _dialect([ln for _, ln in numbered])
    rows = [(n, _cells(p, n, ln, delimiter)) for n, ln in numbered]
    if delimiter != "," or decimal_comma:
        notes.append(f"delimiter {'tab' if delimiter == chr(9) else repr(delimiter)}"
                     + (", decimal comma" if decimal_comma else ""))
    time_columns = [k for k, v in (columns or {}).items() if v in ("t", "time")]
    time_names = set(TIME_NAMES) | {k.lower() for k in time_columns}
    columns = {k: v for k, v in (columns or {}).items() if v not in ("t", "time")} or None
    rows = _without_empty_tail(rows[_header_row(rows, time_names, notes):], notes)
    header_line, header_cells = rows[0]
    split = [_split_name(c) for c in header_cells]
    names = [n for n, _ in split]
    units: list[str | None] = [u for _, u in split]
    if len(names) < 2 or names[0].lower() not in time_names:
        raise InputError(f"{p} line {header_line}: the header must be 't,<face>,...' (the time first, named "
                         f"{' or '.join(repr(n) for n in TIME_NAMES[:2])}, then one column per face or sensor), "
                         f"got {delimiter.join(header_cells)!r}")
    if time_columns and names[0].lower() not in {k.lower() for k in time_columns}:
        raise InputError(f"{p} line {header_line}: --column {time_columns[0]}=t: the time column is {names[0]!r}, "
                         f"not {time_columns[0]!r}; its columns: {', '.join(names)}")
    body = rows[1:]
    if body and not any(_is_number(c, decimal_comma) for c in body[0][1]) and len(body[0][1]) == len(names):
        unit_line, unit_cells = body[0]
        for j, cell in enumerate(unit_cells):
            if cell and units[j] is not None and cell != units[j]:
                raise InputError(f"{p} line {unit_line}, column {names[j]!r}: unit {cell!r} disagrees with the "
                                 f"header's {units[j]!r}")
            units[j] = cell or units[j]
        body = body[1:]
    for col, name in enumerate(names[1:], start=2):
        if not name:
            raise InputError(f"{p} line {header_line}, column {col}: empty column name")
        if names.count(name) > 1:
            raise InputError(f"{p} line {header_line}: column {name!r} appears twice")
    chosen = _map_columns(p, header_line, names[1:], outputs=outputs, columns=columns, notes=notes)
    if not body:
        raise InputError(f"{p}: no data rows after the header")
    where_t = f"{p} line {header_line}, column {names[0]!r}"
    factor, t_unit = _time_factor(units[0], where_t, time_unit)
    if units[0] is not None and time_unit is not None and TIME_UNITS.get(time_unit.lower()) != factor:
        raise InputError(f"{where_t}: the file says times are in {units[0]!r}, the option says {time_unit!r}")
    if factor != 1.0:
        notes.append(f"times converted from {t_unit} to s (× {factor:g})")
    data, lines, dropped = _numbers(p, _clock_seconds(p, body, notes), names, decimal_comma)
    if dropped:
        shown = ", ".join(str(n) for n in dropped[:5]) + (", ..." if len(dropped) > 5 else "")
        notes.append(f"{len(dropped)} row(s) with missing values dropped (line(s) {shown})")
    if not lines:
        raise InputError(f"{p}: every data row has a missing value; nothing left to read")
    data[:, 0] *= factor
    _check_times(p, data[:, 0], lines)
    humid = {out: name for out, name in chosen.items() if output_kind(out) == "phi" or quantity == "humidity"}
    stated, kelvin_cols = _temperature_units(p, header_line, names, units, given=temperature_unit, quantity=quantity,
                                             chosen={o: n for o, n in chosen.items() if o not in humid})
    values = {}
    for out, name in chosen.items():
        j = names.index(name)
        v = data[:, j]
        if out in humid:
            values[out] = _humidity(p, v, lines, name, unit=units[j], line=header_line)
            continue
        if name in kelvin_cols:
            notes.append(f"column {name!r} converted from K to °C (− {KELVIN_OFFSET})")
        check_values(p, v, lines, name, quantity, kelvin=name in kelvin_cols, plausible=plausible)
        values[out] = v - KELVIN_OFFSET if name in kelvin_cols else v.copy()
    for note in notes:
        log.info("%s: %s", p, note)
    table = Observables(data[:, 0].copy(), values, source=str(p))
    return LabTable(table, tuple(notes), tuple(lines), stated, dict(chosen))


#: Units of a relative-humidity column (a ``phi:<face>`` output): its factor to the fraction the model uses.
HUMIDITY_UNITS = {"1": 1.0, "-": 1.0, "rh": 1.0, "%": 0.01, "%rh": 0.01}
#: A relative humidity read above this (a saturated sensor reads a little over 100 %RH) is refused.
HUMIDITY_MAX = 1.05


def _humidity(p: Path, v: FloatArray, lines: Sequence[int], name: str, *, unit: str | None, line: int) -> FloatArray:
    """A relative-humidity column as a fraction: its unit (none: a fraction) from :data:`HUMIDITY_UNITS`, values in
    [0, :data:`HUMIDITY_MAX`]; InputError naming the file, line and column otherwise."""
    key = "1" if unit is None else unit.lower().replace(" ", "")
    if key not in HUMIDITY_UNITS:
        raise InputError(f"{p} line {line}, column {name!r}: unit {unit!r} for a relative humidity; allowed: "
                         "1 (a fraction, the default), %RH or %")
    check_values(p, v, lines, name, "humidity")  # sentinels and non-finite values, as every column
    out = v * HUMIDITY_UNITS[key]
    bad = np.flatnonzero((out < 0) | (out > HUMIDITY_MAX))
    if bad.size:
        i = int(bad[0])
        raise InputError(f"{p} line {lines[i]}, column {name!r}: relative humidity {v[i]:g} {unit or ''} is outside "
                         f"[0, {HUMIDITY_MAX:g}] as a fraction (state %RH in the units row if the column is in "
                         "percent)")
    return out


def _map_columns(p: Path, line: int, names: list[str], *, outputs: Iterable[str] | None,
                 columns: Mapping[str, str] | None, notes: list[str]) -> dict[str, str]:
    """Output → file column: every column when no mapping is given, else the mapped ones."""
    allowed = tuple(outputs) if outputs is not None else None
    if not columns:
        for col, name in enumerate(names, start=2):
            if allowed is not None and name not in allowed:
                raise InputError(f"{p} line {line}, column {col}: {name!r} is not an output of the model (a face "
                                 f"or a sensor); allowed: {', '.join(allowed) or '(none)'}; or map the column "
                                 f"with --column {name}=OUTPUT")
        return {n: n for n in names}
    out: dict[str, str] = {}
    for source, target in columns.items():
        if source not in names:
            raise InputError(f"{p} line {line}: --column {source}={target}: the file has no column {source!r}; "
                             f"its columns: {', '.join(names)}")
        if allowed is not None and target not in allowed:
            raise InputError(f"--column {source}={target}: {target!r} is not an output of the model; "
                             f"allowed: {', '.join(allowed) or '(none)'}")
        if target in out:
            raise InputError(f"--column: {out[target]!r} and {source!r} are both mapped onto {target!r}")
        out[target] = source
    ignored = [n for n in names if n not in out.values()]
    if ignored:
        notes.append(f"column(s) {', '.join(ignored)} ignored (not mapped with --column)")
    notes.extend(f"column {s!r} read as output {t!r}" for t, s in out.items() if s != t)
    return out


def _numbers(p: Path, body: list[tuple[int, list[str]]], names: list[str],
             decimal_comma: bool) -> tuple[FloatArray, list[int], list[int]]:
    """The numeric rows (rows with a missing cell dropped), their lines, the dropped lines."""
    data, lines, dropped = [], [], []
    for line, row in body:
        if len(row) != len(names):
            raise InputError(f"{p} line {line}: {len(row)} fields, the header has {len(names)}")
        if any(c.lower() in MISSING for c in row):
            dropped.append(line)
            continue
        values = []
        for name, cell in zip(names, row, strict=True):
            try:
                value = float(cell.replace(",", ".") if decimal_comma else cell)
            except ValueError:
                raise InputError(f"{p} line {line}, column {name!r}: {cell!r} is not a number") from None
            if not np.isfinite(value):
                raise InputError(f"{p} line {line}, column {name!r}: {cell!r} is not finite (a logger's 'no "
                                 "reading'?); remove the row or leave the cell empty (rows with an empty cell "
                                 "are dropped)")
            values.append(value)
        data.append(values)
        lines.append(line)
    return np.array(data, dtype=float).reshape(len(data), len(names)), lines, dropped


def _check_times(p: Path, t: FloatArray, lines: list[int]) -> None:
    for i, (ti, line) in enumerate(zip(t, lines, strict=True)):
        if not np.isfinite(ti):
            raise InputError(f"{p} line {line}, column 't': time {ti!r} is not finite")
        if ti < 0:
            raise InputError(f"{p} line {line}: time t = {ti:g} s is negative; times must be >= 0")
        if i and ti <= t[i - 1]:
            raise InputError(f"{p} line {line}: time t = {ti:g} s does not increase (previous row t = "
                             f"{t[i - 1]:g} s); times must be strictly increasing")


def _temperature_units(p: Path, line: int, names: list[str], units: list[str | None], *, chosen: Mapping[str, str],
                       given: str | None, quantity: Quantity) -> tuple[bool, set[str]]:
    """(whether the unit is stated, the columns in kelvin); a file unit and ``given`` must agree."""
    given_kelvin = given is not None and quantity == "temperature" and _temperature_kelvin(given, "--temperature-unit")
    kelvin: set[str] = set()
    stated = given is not None
    for name in chosen.values():
        unit = units[names.index(name)]
        where = f"{p} line {line}, column {name!r}"
        if unit is None:
            if given_kelvin:
                kelvin.add(name)
            continue
        if quantity == "moisture_flux":
            if unit.lower() not in MOISTURE_FLUX_UNITS:
                raise InputError(f"{where}: unit {unit!r} for a moisture flux history; allowed: kg/(m2 s)")
            continue
        if quantity != "temperature":
            if unit.lower() not in FLUX_UNITS:
                raise InputError(f"{where}: unit {unit!r} for a heat flux history; allowed: W/m2 (W/m²)")
            continue
        is_kelvin = _temperature_kelvin(unit, where)
        if given is not None and is_kelvin != given_kelvin:
            raise InputError(f"{where}: the file says {unit!r}, --temperature-unit says {given!r}")
        stated = True
        if is_kelvin:
            kelvin.add(name)
    return stated, kelvin
