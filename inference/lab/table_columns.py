"""Columns of lab CSV files found by name (with or without the unit a header carries) and read as
numbers, with errors that name the file, the column and the row."""

from __future__ import annotations

import difflib
import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..experiment.errors import ExperimentDataError
from .csv_text import parse_csv_text

_UNIT_SUFFIX = re.compile(r"\s*[\[(][^\])]*[\])]\s*$")


def bare_name(header: str) -> str:
    """The header without its unit: ``coor.X [mm]`` -> ``coor.X``."""
    return _UNIT_SUFFIX.sub("", str(header)).strip()


def read_table(path: Path, encoding: str | None = None) -> pd.DataFrame:
    """A CSV (comma, semicolon or tab separated, decimal points or commas: the dialect detected
    or stated, :mod:`.csv_text`; quoted headers as VIC-3D writes them; brackets
    that hold the separator, as MatchID's ``F[0,0]``; a vendor's header block and unit row
    before the data, :mod:`.csv_text`) with its headers stripped; an error naming the file when
    it cannot be read, naming the dialect tried. ``table.attrs``: ``first_data_line`` (the file
    line of the first row, so that errors name rows as an editor counts them), ``encoding``,
    ``dialect``, ``notes``."""
    if not path.is_file():
        raise ExperimentDataError(f"{path}: missing file")
    text = parse_csv_text(path, encoding)
    if not text.data:
        raise ExperimentDataError(f"{path}: no rows")
    names = list(range(len(text.columns)))
    try:
        table = pd.read_csv(
            io.StringIO("\n".join(text.data)),
            sep=text.sep,
            decimal=text.decimal,
            header=None,
            names=names,
            skipinitialspace=True,
        )
    except Exception as exc:  # pandas raises several types for unreadable text
        msg = str(exc)
        m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", msg)
        if m:
            line = int(m.group(2)) + text.first_data_line - 1
            msg = f"line {line} has {m.group(3)} fields, the header {len(text.columns)}"
        raise ExperimentDataError(
            f"{path}: not a readable CSV ({msg}; read with {text.dialect}: give --delimiter, --decimal if the "
            "file has others)"
        ) from exc
    table.columns = [str(c).strip().strip('"').strip() for c in text.columns]
    if table.empty:
        raise ExperimentDataError(f"{path}: no rows")
    table.attrs.update(
        first_data_line=text.first_data_line, encoding=text.encoding, dialect=text.dialect, notes=text.notes
    )
    return table


def read_with(table: pd.DataFrame) -> str:
    """``; read with ';' between fields, ',' for decimals (...)``: the dialect a table was read
    with, for an error about its columns or cells (empty for a table not read by :func:`read_table`)."""
    if "dialect" not in table.attrs:
        return ""
    return f"; read with {table.attrs['dialect']}: give --delimiter, --decimal if the file has others"


def first_row(table: pd.DataFrame) -> int:
    """The file line of the table's first row (2 for a plain CSV: the header is line 1)."""
    return int(table.attrs.get("first_data_line", 2))


def find_column(table: pd.DataFrame, name: str, path: Path, role: str = "") -> str:
    """The header of ``table`` that is ``name``, exactly or but for its unit (and then, when no
    header matches so, but for its case); an error naming the file and the closest headers when
    there is none."""
    if name in table.columns:
        return name
    wanted = bare_name(name)
    hits = [c for c in table.columns if bare_name(c) == wanted]
    if not hits:  # ``x`` for ``X [mm]``: the same name but for its case
        hits = [c for c in table.columns if bare_name(c).lower() == wanted.lower()]
    if len(hits) == 1:
        return hits[0]
    if len(hits) > 1:
        raise ExperimentDataError(f"{path}: column '{name}' is ambiguous: {', '.join(hits)}")
    close = difflib.get_close_matches(name, list(table.columns), n=3, cutoff=0.5)
    what = f" ({role})" if role else ""
    hint = f"; closest: {', '.join(repr(c) for c in close)}" if close else ""
    raise ExperimentDataError(f"{path}: no column '{name}'{what}{hint}{read_with(table)}")


def numeric_column(table: pd.DataFrame, column: str, path: Path, allow_missing: bool = True) -> np.ndarray:
    """``column`` as floats; blank cells are NaN when ``allow_missing``; text where a number belongs
    is an error naming the row (as an editor counts it, the header being row 1)."""
    raw = table[column]
    line0 = first_row(table)
    values = pd.to_numeric(raw, errors="coerce")
    blank = raw.isna() | (raw.astype(str).str.strip() == "")
    bad = values.isna() & ~blank
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise ExperimentDataError(
            f"{path}: row {row + line0}, column '{column}': {raw.iloc[row]!r} is not a number{read_with(table)}"
        )
    if not allow_missing and blank.any():
        row = int(np.flatnonzero(blank.to_numpy())[0])
        raise ExperimentDataError(f"{path}: row {row + line0}, column '{column}': empty")
    out = values.to_numpy(float)
    inf = np.isinf(out)
    if inf.any():
        row = int(np.flatnonzero(inf)[0])
        raise ExperimentDataError(f"{path}: row {row + line0}, column '{column}': not a finite number")
    return out


def frame_number(path: Path) -> int:
    """The frame (image) number in a file name: the first run of digits (``Image_0012_0.tiff.csv``
    -> 12, ``B00012.csv`` -> 12)."""
    match = re.search(r"(\d+)", path.name)
    if not match:
        raise ExperimentDataError(f"{path}: no frame number in the file name")
    return int(match.group(1))
