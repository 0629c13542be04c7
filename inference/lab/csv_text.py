"""The text of a lab's CSV file as the programs that write them lay it out: its encoding (UTF-8,
or detected, or declared), its dialect (the delimiter between fields and the decimal separator:
detected, or declared), headers with brackets that hold the separator
(MatchID's ``defgradient.F[0,0] [-]``), and a vendor's header block and unit row before the data
(Instron Bluehill, MTS TestSuite: lines of test information, the column names, their units).

:func:`parse_csv_text` gives the column names (a unit row's unit appended as ``Name [unit]``, so
that the usual header-unit reading applies), the data lines and the file line of the first data
row; :func:`decode` the text. An encoding that fails is named in the error with the way out
(``--encoding``).

The dialect: :class:`csv.Sniffer` says which of ``,``, ``;`` and tab splits the data lines
consistently (and how they are quoted); of those that do, the one whose fields are all numbers
is taken, with a decimal comma when the delimiter is not a comma and the numbers write one (the
export of lab software under German, French or Italian settings: ``0,5;37,5;-0,012``); pandas then
reads the numbers with that decimal separator. ``--delimiter`` and ``--decimal`` state them
(:func:`csv_reading`); an error reading the file names the dialect it tried.
"""

from __future__ import annotations

import contextlib
import contextvars
import csv
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from ..experiment.errors import ExperimentDataError

#: how many lines a vendor's header block may have before the column names
MAX_PREAMBLE = 200
#: a data block starts where this many lines in a row are numbers
DATA_RUN = 3

#: the decimal separators a CSV may use
DECIMALS = (".", ",")
#: the data lines sniffed for the dialect
SNIFF_LINES = 30

_encoding: contextvars.ContextVar[str | None] = contextvars.ContextVar("csv_encoding", default=None)
_dialect: contextvars.ContextVar[tuple[str | None, str | None]] = contextvars.ContextVar(
    "csv_dialect", default=(None, None)
)
_NUMBER = {
    d: re.compile(rf"^[+-]?(\d+\{d}?\d*|\{d}\d+)([eE][+-]?\d+)?$|^(nan|NaN|NAN|-?inf|-?Inf)?$")
    for d in DECIMALS
}
_UNIT_CELL = re.compile(r"^[\[(]?\s*([^\[\]()]{0,12}?)\s*[\])]?$")


@contextlib.contextmanager
def csv_encoding(encoding: str | None) -> Iterator[None]:
    """Every CSV read inside the block is decoded as ``encoding`` (None: UTF-8, else detected)."""
    token = _encoding.set(encoding)
    try:
        yield
    finally:
        _encoding.reset(token)


@contextlib.contextmanager
def csv_reading(
    encoding: str | None = None, *, delimiter: str | None = None, decimal: str | None = None
) -> Iterator[None]:
    """Every CSV read inside the block is decoded as ``encoding`` and split at ``delimiter``
    with ``decimal`` as the decimal separator (each None: detected, module docstring).

    Parameters
    ----------
    encoding : str, optional
        The text encoding, e.g. ``cp1252``.
    delimiter : str, optional
        The field delimiter: ``,``, ``;``, ``tab`` (or a tab character) or another single character.
    decimal : str, optional
        The decimal separator, ``.`` or ``,``.

    Yields
    ------
    None
        Inside the block, the files are read so.

    Raises
    ------
    ExperimentDataError
        A delimiter that is not one character, a decimal separator other than ``.`` or ``,``,
        or the two the same.
    """
    delimiter = "\t" if delimiter in ("tab", "\\t") else delimiter
    if delimiter is not None and len(delimiter) != 1:
        raise ExperimentDataError(f"delimiter {delimiter!r}: one character (',', ';', 'tab')")
    if decimal is not None and decimal not in DECIMALS:
        raise ExperimentDataError(f"decimal separator {decimal!r}: '.' or ','")
    if delimiter is not None and delimiter == decimal:
        raise ExperimentDataError(f"the delimiter and the decimal separator are both {delimiter!r}")
    token = _dialect.set((delimiter, decimal))
    try:
        with csv_encoding(encoding):
            yield
    finally:
        _dialect.reset(token)


def describe_dialect(sep: str, decimal: str) -> str:
    """``';' between fields, ',' for decimals``: a dialect as an error names it."""
    return f"{'tab' if sep == chr(9) else repr(sep)} between fields, {decimal!r} for decimals"


def _is_number(cell: str, decimal: str) -> bool:
    return bool(_NUMBER[decimal].match(cell.strip()))


def sniff_dialect(lines: list[str], path: Path) -> tuple[str, str]:
    """The delimiter and decimal separator of a CSV's ``lines`` (module docstring), or those
    :func:`csv_reading` states."""
    given_sep, given_decimal = _dialect.get()
    body = [line for line in lines[-4 * SNIFF_LINES :] if line.strip()][-SNIFF_LINES:]
    candidates = [given_sep] if given_sep else [",", ";", "\t"]
    found = []
    for sep in candidates:
        try:
            dialect = csv.Sniffer().sniff("\n".join(body), delimiters=sep)
        except csv.Error:
            if given_sep is None:
                continue
            dialect = None
        rows = [next(csv.reader([line], dialect or "excel", delimiter=sep)) for line in body]
        for decimal in [given_decimal] if given_decimal else (list(DECIMALS) if sep != "," else ["."]):
            numbers = sum(all(_is_number(c, decimal) for c in r) for r in rows)
            found.append((numbers, len(rows[0]) if rows else 0, decimal == ".", sep, decimal))
    if not found:
        return given_sep or ",", given_decimal or "."
    *_, sep, decimal = max(found)
    return sep, decimal


def decode(path: Path, encoding: str | None = None) -> tuple[str, str]:
    """The file's text and the encoding it was read with: ``encoding`` when given (or set by
    :func:`csv_encoding`), else UTF-8 (with or without BOM), else cp1252 when it reads as Latin
    text (:func:`_windows_text`), else what charset detection (charset-normalizer) finds."""
    raw = path.read_bytes()
    encoding = encoding or _encoding.get()
    if encoding:
        try:
            return raw.decode(encoding), encoding
        except LookupError:
            raise ExperimentDataError(f"{path}: unknown encoding {encoding!r}") from None
        except UnicodeDecodeError as exc:
            raise ExperimentDataError(
                f"{path}: not readable as {encoding} (byte {exc.start}: {raw[exc.start : exc.start + 1]!r}); "
                "give the file's encoding (--encoding, e.g. cp1252, latin-1, utf-16)"
            ) from None
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        return raw.decode("utf-16"), "utf-16"
    try:
        return raw.decode("utf-8-sig"), "utf-8"
    except UnicodeDecodeError as exc:
        first_bad = exc.start
    western = _windows_text(raw)
    if western is not None:
        return western, "cp1252"
    from charset_normalizer import from_bytes

    best = from_bytes(raw).best()
    if best is None or best.encoding is None:
        raise ExperimentDataError(
            f"{path}: not UTF-8 (byte {first_bad}: {raw[first_bad : first_bad + 1]!r}) and no other encoding "
            "fits; give the file's encoding (--encoding, e.g. cp1252, latin-1)"
        )
    try:
        return raw.decode(best.encoding), best.encoding
    except UnicodeDecodeError:  # pragma: no cover - the detector decoded it already
        raise ExperimentDataError(
            f"{path}: not readable as {best.encoding} (detected); give the file's encoding (--encoding)"
        ) from None


def _windows_text(raw: bytes) -> str | None:
    """``raw`` as cp1252 (what Windows lab software writes) when that gives only Latin
    characters and the signs of units and numbers (µ, °, ², ±, accented letters), else None: a
    few bytes of a short header are too little for a detector, which may read ``µm`` as CJK."""
    try:
        text = raw.decode("cp1252")
    except UnicodeDecodeError:
        return None
    odd = {c for c in text if ord(c) > 127}
    plausible = all(0xA0 <= ord(c) <= 0xFF or c in "€–—‘’“”•…‰" for c in odd)
    return text if plausible else None


def split_fields(line: str, sep: str) -> list[str]:
    """``line`` split at ``sep`` outside quotes and brackets: ``a,"b,c",F[0,0] [-]`` -> 3 fields."""
    out, cur, depth, quote = [], [], 0, False
    for ch in line:
        if ch == '"':
            quote = not quote
        elif not quote and ch in "[(":
            depth += 1
        elif not quote and ch in "])":
            depth = max(depth - 1, 0)
        if ch == sep and not quote and depth == 0:
            out.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    out.append("".join(cur))
    return [f.strip().strip('"').strip() for f in out]


def _numeric_row(fields: list[str], decimal: str = ".") -> bool:
    return len(fields) >= 2 and all(_is_number(f, decimal) for f in fields) and any(f.strip() for f in fields)


def _unit_row(fields: list[str], n: int, decimal: str = ".") -> bool:
    """A row of units under the column names: n short cells, none a number, most with letters."""
    if len(fields) != n or any(_is_number(f, decimal) and f for f in fields):
        return False
    cells = [f for f in fields if f]
    return bool(cells) and all(_UNIT_CELL.match(f) for f in fields) and all(len(f) <= 14 for f in fields)


@dataclass
class CSVText:
    """The parsed layout of a CSV file."""

    columns: list[str]
    data: list[str]  # the data lines, as in the file
    sep: str
    first_data_line: int  # the file line (1-based, as an editor counts) of the first data line
    encoding: str
    notes: list[str] = field(default_factory=list)
    decimal: str = "."

    @property
    def dialect(self) -> str:
        """The dialect as an error names it (:func:`describe_dialect`)."""
        return describe_dialect(self.sep, self.decimal)


def parse_csv_text(path: Path, encoding: str | None = None) -> CSVText:
    """The columns and data lines of ``path`` (module docstring): the column-name row is the
    last non-numeric line before the first run of ``DATA_RUN`` numeric lines, or the one before it
    when that line is a unit row (units then appended to the names)."""
    text, used = decode(path, encoding)
    lines = text.splitlines()
    notes = [] if used == "utf-8" else [f"{path.name} read as {used}"]
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise ExperimentDataError(f"{path}: no rows")
    sep, decimal = sniff_dialect(lines, path)
    if sep != "," or decimal != ".":
        notes.append(f"{path.name}: {describe_dialect(sep, decimal)}")
    head = split_fields(lines[0], sep)
    start = _first_data_block(lines, sep, decimal)
    if start is None or start <= 1:
        if start == 0:
            raise ExperimentDataError(f"{path}: no header row (the first line holds numbers)")
        if len(lines) > 1:
            n = len(split_fields(lines[1], sep))
            if n != len(head) and _numeric_row(split_fields(lines[1], sep), decimal):
                raise ExperimentDataError(
                    f"{path}: line 1 has {len(head)} header fields but line 2 has {n} data fields (read with "
                    f"{describe_dialect(sep, decimal)}; give --delimiter, --decimal if the file has others)"
                )
        return CSVText(head, lines[1:], sep, 2, used, notes, decimal)
    # a vendor layout: a header block, the column names, perhaps their units, then the numbers
    i = start
    n = len(split_fields(lines[i], sep))
    above = split_fields(lines[i - 1], sep)
    if _unit_row(above, n, decimal) and len(split_fields(lines[i - 2], sep)) == n:
        names = split_fields(lines[i - 2], sep)
        units = [_UNIT_CELL.match(u).group(1).strip() for u in above]
        columns = [
            f"{c} [{u}]" if u and not c.endswith((")", "]")) else c for c, u in zip(names, units, strict=True)
        ]
        notes.append(
            f"{path.name}: {i - 2} lines of header block skipped; column names on line {i - 1}, units on line {i}"
        )
    elif len(above) == n:
        columns = above
        notes.append(f"{path.name}: {i - 1} lines of header block skipped; column names on line {i}")
    else:
        raise ExperimentDataError(
            f"{path}: line {i}: {len(above)} header fields for {n} data fields on line {i + 1} (read with "
            f"{describe_dialect(sep, decimal)}; give --delimiter, --decimal if the file has others)"
        )
    return CSVText(columns, lines[i:], sep, i + 1, used, notes, decimal)


def _first_data_block(lines: list[str], sep: str, decimal: str) -> int | None:
    """The index of the first of ``DATA_RUN`` numeric lines in a row with one field count."""
    for i in range(min(len(lines), MAX_PREAMBLE + 3)):
        block = lines[i : i + DATA_RUN]
        if not block:
            return None
        fields = [split_fields(line, sep) for line in block]
        if all(_numeric_row(f, decimal) and len(f) == len(fields[0]) for f in fields):
            return i
    return None
