"""The text of a lab's CSV file as the programs that write them lay it out: its encoding (UTF-8,
or detected, or declared), its separator, headers with brackets that hold the separator
(MatchID's ``defgradient.F[0,0] [-]``), and a vendor's header block and unit row before the data
(Instron Bluehill, MTS TestSuite: lines of test information, the column names, their units).

:func:`parse_csv_text` gives the column names (a unit row's unit appended as ``Name [unit]``, so
that the usual header-unit reading applies), the data lines and the file line of the first data
row; :func:`decode` the text. An encoding that fails is named in the error with the way out
(``--encoding``).
"""

from __future__ import annotations

import contextlib
import contextvars
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from ..experiment_data import ExperimentDataError

SEPARATORS = (",", ";", "\t")
#: how many lines a vendor's header block may have before the column names
MAX_PREAMBLE = 200
#: a data block starts where this many lines in a row are numbers
DATA_RUN = 3

_encoding: contextvars.ContextVar[str | None] = contextvars.ContextVar("csv_encoding", default=None)
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^(nan|NaN|NAN|-?inf|-?Inf)?$")
_UNIT_CELL = re.compile(r"^[\[(]?\s*([^\[\]()]{0,12}?)\s*[\])]?$")


@contextlib.contextmanager
def csv_encoding(encoding: str | None) -> Iterator[None]:
    """Every CSV read inside the block is decoded as ``encoding`` (None: UTF-8, else detected)."""
    token = _encoding.set(encoding)
    try:
        yield
    finally:
        _encoding.reset(token)


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


def _numeric_row(fields: list[str]) -> bool:
    return (
        len(fields) >= 2 and all(_NUMBER.match(f.strip()) for f in fields) and any(f.strip() for f in fields)
    )


def _separator(line: str) -> str:
    return max(SEPARATORS, key=lambda s: len(split_fields(line, s)))


def _unit_row(fields: list[str], n: int) -> bool:
    """A row of units under the column names: n short cells, none a number, most with letters."""
    if len(fields) != n or any(_NUMBER.match(f) and f for f in fields):
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
    sep = _separator(lines[0])
    head = split_fields(lines[0], sep)
    start = _first_data_block(lines)
    if start is None or start <= 1:
        if start == 0:
            raise ExperimentDataError(f"{path}: no header row (the first line holds numbers)")
        if len(lines) > 1:
            n = len(split_fields(lines[1], sep))
            if n != len(head) and _numeric_row(split_fields(lines[1], sep)):
                raise ExperimentDataError(
                    f"{path}: line 1 has {len(head)} header fields but line 2 has {n} data fields ({sep!r} separated)"
                )
        return CSVText(head, lines[1:], sep, 2, used, notes)
    # a vendor layout: a header block, the column names, perhaps their units, then the numbers
    i = start
    sep = _separator(lines[i])
    n = len(split_fields(lines[i], sep))
    above = split_fields(lines[i - 1], sep)
    if _unit_row(above, n) and len(split_fields(lines[i - 2], sep)) == n:
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
            f"{path}: line {i}: {len(above)} header fields for {n} data fields on line {i + 1}"
        )
    return CSVText(columns, lines[i:], sep, i + 1, used, notes)


def _first_data_block(lines: list[str]) -> int | None:
    """The index of the first of ``DATA_RUN`` numeric lines in a row with one field count."""
    for i in range(min(len(lines), MAX_PREAMBLE + 3)):
        block = lines[i : i + DATA_RUN]
        if not block:
            return None
        sep = _separator(block[0])
        fields = [split_fields(line, sep) for line in block]
        if all(_numeric_row(f) and len(f) == len(fields[0]) for f in fields):
            return i
    return None
