"""Any DIC export as CSV, with a column mapping (VIC-3D, ZEISS/GOM Correlate, Ncorr, in-house
scripts): one file per frame, or one long file with a frame column.

The mapping names the columns of the reference (or current) position ``x, y, z`` and the
displacement ``ux, uy, uz``, and optionally ``id`` (one or more columns that identify a point
across frames; without it every frame must list the same points in the same order), ``frame``
(one long file), ``time`` (frame times, s after its unit) and ``sigma`` (a correlation measure: a
negative or missing value, as VIC-3D writes -1, marks a point not correlated; ``max_sigma`` drops
larger ones). Units come from the headers (``X [mm]``, ``U (mm)``) or are declared.

VIC-3D, for instance: ``x="X", y="Y", z="Z", ux="U", uy="V", uz="W", sigma="sigma"`` (X, Y, Z are
the reference positions there); GOM exports with current positions use ``positions="current"``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..experiment.data import ExperimentDataError
from .dic_series import DICSeries, require_consecutive_frames
from .table_columns import find_column, first_row, frame_number, numeric_column, read_table
from .units import resolve_unit

REQUIRED = ("x", "y", "z", "ux", "uy", "uz")
OPTIONAL = ("id", "frame", "time", "sigma")


@dataclass(frozen=True)
class CSVMapping:
    """Column of each quantity (``id`` may list several, comma-separated), the positions' state
    (``reference`` or ``current``) and the declared units (None: read from the header)."""

    columns: Mapping[str, str]
    positions: str = "reference"
    length_unit: str | None = None
    time_unit: str | None = None

    def __post_init__(self) -> None:
        unknown = sorted(set(self.columns) - set(REQUIRED) - set(OPTIONAL))
        if unknown:
            raise ExperimentDataError(
                f"column mapping: unknown key(s) {', '.join(unknown)} (use {', '.join(REQUIRED + OPTIONAL)})"
            )
        missing = [k for k in REQUIRED if k not in self.columns]
        if missing:
            raise ExperimentDataError(f"column mapping: no column given for {', '.join(missing)}")
        if self.positions not in ("reference", "current"):
            raise ExperimentDataError(
                f"column mapping: positions must be reference or current, got {self.positions!r}"
            )

    @classmethod
    def parse(cls, text: str, **kwargs) -> CSVMapping:
        """``x=X,y=Y,z=Z,ux=U,uy=V,uz=W,id=i+j`` (several id columns joined by '+')."""
        pairs = {}
        for item in filter(None, (p.strip() for p in text.split(","))):
            if "=" not in item:
                raise ExperimentDataError(f"column mapping: {item!r} is not key=column")
            key, value = (s.strip() for s in item.split("=", 1))
            pairs[key] = value.replace("+", ",") if key == "id" else value
        return cls(pairs, **kwargs)


def _frame_table(table: pd.DataFrame, path: Path, mapping: CSVMapping, max_sigma: float | None) -> dict:
    cols = mapping.columns
    values = {}
    for key in REQUIRED:
        header = find_column(table, cols[key], path, key)
        values[key] = numeric_column(table, header, path) * resolve_unit(
            header, mapping.length_unit, "length", str(path)
        )
    xyz = np.column_stack([values[k] for k in ("x", "y", "z")])
    u = np.column_stack([values[k] for k in ("ux", "uy", "uz")])
    ok = np.isfinite(xyz).all(axis=1) & np.isfinite(u).all(axis=1)
    if "sigma" in cols:
        sigma = numeric_column(table, find_column(table, cols["sigma"], path, "sigma"), path)
        ok &= np.isfinite(sigma) & (sigma >= 0)
        if max_sigma is not None:
            ok &= sigma <= max_sigma
    if mapping.positions == "current":
        xyz = xyz - u
    ids = None
    if "id" in cols:
        ids = pd.MultiIndex.from_arrays(
            [
                numeric_column(table, find_column(table, c.strip(), path, "id"), path, False)
                for c in cols["id"].split(",")
            ]
        )
        dup = ids.duplicated()
        if dup.any():
            raise ExperimentDataError(
                f"{path}: row {int(np.flatnonzero(dup)[0]) + first_row(table)}: point id listed twice"
            )
    time = None
    if "time" in cols:
        header = find_column(table, cols["time"], path, "time")
        t = numeric_column(table, header, path) * resolve_unit(header, mapping.time_unit, "time", str(path))
        time = float(np.nanmedian(t)) if np.isfinite(t).any() else None
    return {"xyz": xyz, "u": u, "ok": ok, "ids": ids, "time": time, "rows": len(table)}


def read_dic_csv(
    source: str | Path,
    mapping: CSVMapping,
    pattern: str = "*.csv",
    max_sigma: float | None = None,
    allow_gaps: bool = False,
) -> DICSeries:
    """Read a folder of per-frame CSVs (``pattern``; frame numbers from the file names) or one
    long CSV with a ``frame`` column into a :class:`DICSeries`."""
    source = Path(source)
    frames: list[dict] = []
    if source.is_dir():
        files = sorted(source.glob(pattern), key=frame_number)
        if not files:
            raise ExperimentDataError(f"{source}: no DIC files ({pattern})")
        frames = [_frame_table(read_table(p), p, mapping, max_sigma) for p in files]
        ids = np.array([frame_number(p) for p in files])
        names = [p.name for p in files]
    else:
        if "frame" not in mapping.columns:
            raise ExperimentDataError(
                f"{source}: one file holds every frame only with a 'frame' column mapped"
            )
        table = read_table(source)
        fcol = find_column(table, mapping.columns["frame"], source, "frame")
        fvals = numeric_column(table, fcol, source, False)
        ids = np.unique(fvals).astype(int)
        for f in ids:
            part = table[fvals == f].reset_index(drop=True)
            frames.append(_frame_table(part, source, mapping, max_sigma))
        names = [f"{source.name} frame {f}" for f in ids]
    if not allow_gaps:
        require_consecutive_frames(str(source), ids, names)
    if frames[0]["ids"] is None:
        n = frames[0]["rows"]
        for name, f in zip(names, frames, strict=True):
            if f["rows"] != n:
                raise ExperimentDataError(
                    f"{source}: {name} has {f['rows']} points, {names[0]} has {n}; without an id column every "
                    "frame must list the same points in the same order (map 'id')"
                )
        keys = None
    else:
        keys = frames[0]["ids"].append([f["ids"] for f in frames[1:]]).unique().sort_values()
        n = len(keys)
    xyz = np.full((n, 3), np.nan)
    u = np.full((len(frames), n, 3), np.nan)
    for k in reversed(range(len(frames))):  # the earliest frame that has a point sets its reference
        f = frames[k]
        where = np.arange(n) if keys is None else keys.get_indexer(f["ids"])
        sel = where[f["ok"]]
        u[k, sel] = f["u"][f["ok"]]
        xyz[sel] = f["xyz"][f["ok"]]
    seen = np.isfinite(xyz).all(axis=1)
    times = [f["time"] for f in frames]
    t = np.array(times, float) if all(v is not None for v in times) else None
    return DICSeries(str(source), xyz[seen], u[:, seen], ids, names, t)
