"""MatchID (STEREO) CSV exports: one file per image, headers ``category.Long name [unit]``.

The export MatchID writes with "Header format [Category].[Long variable name].[units]" and "each
time step in a different file" (as in the public exports of SolavLab/DuoDIC, MatchID_data/):

* a point is identified by its subset's position in the reference image,
  ``Coordinates.Image X [Pixel]`` and ``Coordinates.Image Y [Pixel]``; a point may be present in
  some images and not in others (it was not correlated there);
* ``coor.X``, ``coor.Y``, ``coor.Z`` are the point's position in the *current* image and
  ``disp.Horizontal Displacement U``, ``disp.Vertical Displacement V``, ``disp.Out-Of-Plane: W``
  its displacement from the reference image, so the reference position is coor - disp;
* the frame number is ``ext.Current Image [#]`` when exported, else the first number in the file
  name (``Image_0012_0.tiff.csv`` -> 12).

Units come from the headers (``[mm]``); a declared ``length_unit`` must agree with them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..experiment.data import ExperimentDataError
from .dic_series import DICSeries, require_consecutive_frames
from .table_columns import find_column, first_row, frame_number, numeric_column, read_table
from .units import resolve_unit


@dataclass(frozen=True)
class MatchIDColumns:
    """The headers (without units) MatchID writes; change one if an export names it differently."""

    image_x: str = "Coordinates.Image X"
    image_y: str = "Coordinates.Image Y"
    x: str = "coor.X"
    y: str = "coor.Y"
    z: str = "coor.Z"
    ux: str = "disp.Horizontal Displacement U"
    uy: str = "disp.Vertical Displacement V"
    uz: str = "disp.Out-Of-Plane: W"
    frame: str = "ext.Current Image"
    sigma: str = "stats.Sigma"


def _read_frame(path: Path, cols: MatchIDColumns, length_unit: str | None, max_sigma: float | None):
    table = read_table(path)
    ids = np.column_stack(
        [
            numeric_column(table, find_column(table, c, path, "point id"), path, False)
            for c in (cols.image_x, cols.image_y)
        ]
    )
    values = []
    for name in (cols.x, cols.y, cols.z, cols.ux, cols.uy, cols.uz):
        header = find_column(table, name, path)
        values.append(
            numeric_column(table, header, path) * resolve_unit(header, length_unit, "length", str(path))
        )
    coor, disp = np.column_stack(values[:3]), np.column_stack(values[3:])
    ok = np.isfinite(coor).all(axis=1) & np.isfinite(disp).all(axis=1)
    nan_rows = (np.flatnonzero(~ok) + first_row(table)).tolist()
    sigma_dropped = 0
    if max_sigma is not None:
        header = find_column(table, cols.sigma, path, "correlation uncertainty")
        sigma = numeric_column(table, header, path) * resolve_unit(header, length_unit, "length", str(path))
        sigma_dropped = int(np.count_nonzero(ok & ~(sigma <= max_sigma)))
        ok &= sigma <= max_sigma
    frame = frame_number(path)
    if any(c.startswith(cols.frame) for c in table.columns):
        f = numeric_column(table, find_column(table, cols.frame, path), path)
        if np.isfinite(f).any():
            frame = int(np.nanmedian(f))
    keys = pd.MultiIndex.from_arrays([ids[:, 0], ids[:, 1]])
    dup = keys.duplicated()
    if dup.any():
        row = int(np.flatnonzero(dup)[0])
        raise ExperimentDataError(
            f"{path}: row {row + first_row(table)}: point at image position ({ids[row, 0]:g}, {ids[row, 1]:g}) listed twice"
        )
    dropped = {"nan_rows": nan_rows, "sigma": sigma_dropped, "rows": len(table)}
    return frame, ids[ok], coor[ok] - disp[ok], disp[ok], list(table.columns), dropped


def _dropped_notes(files: list[Path], dropped: list[dict], max_sigma: float | None) -> list[str]:
    """What the import left out of each image: rows without coordinates or displacements (NaN
    or empty: not correlated there), and points beyond ``max_sigma``."""
    notes = []
    nan = [(p.name, d["nan_rows"], d["rows"]) for p, d in zip(files, dropped, strict=True) if d["nan_rows"]]
    if nan:
        each = "; ".join(
            f"{name}: {len(rows)} of {n} (row{'s' if len(rows) > 1 else ''} "
            f"{', '.join(map(str, rows[:5]))}{' ...' if len(rows) > 5 else ''})"
            for name, rows, n in nan[:8]
        )
        more = f"; and {len(nan) - 8} more images" if len(nan) > 8 else ""
        notes.append(
            f"rows without coordinates or displacements (NaN: not correlated there) dropped in "
            f"{len(nan)} image(s): {each}{more}"
        )
    beyond = sum(d["sigma"] for d in dropped)
    if beyond:
        notes.append(f"{beyond} points beyond --max-sigma {max_sigma:g} mm dropped over {len(files)} images")
    return notes


def read_matchid(
    folder: str | Path,
    length_unit: str | None = None,
    columns: MatchIDColumns = MatchIDColumns(),
    max_sigma: float | None = None,
    pattern: str = "*.csv",
    allow_gaps: bool = False,
) -> DICSeries:
    """Read a folder of MatchID CSV exports (one per image) into a :class:`DICSeries`.

    Points are matched across images by their reference subset position; ``max_sigma`` (mm)
    drops points whose ``stats.Sigma`` is larger; a gap in the frame numbers (a file missing from
    the folder) is an error unless ``allow_gaps`` (the frames of the steps are then named
    explicitly); every file must carry the same columns as the first.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ExperimentDataError(f"{folder}: no such MatchID export folder")
    files = sorted(folder.glob(pattern), key=frame_number)
    if not files:
        raise ExperimentDataError(f"{folder}: no MatchID CSV files ({pattern})")
    frames = [_read_frame(p, columns, length_unit, max_sigma) for p in files]
    order = np.argsort([f[0] for f in frames], kind="stable")
    frames = [frames[i] for i in order]
    files = [files[i] for i in order]
    first_columns = frames[0][4]
    for path, f in zip(files, frames, strict=True):
        missing = [c for c in first_columns if c not in f[4]]
        if missing:
            raise ExperimentDataError(
                f"{path}: column '{missing[0]}' of {files[0].name} is not in this file (renamed?)"
            )
    ids = np.array([f[0] for f in frames])
    if not allow_gaps:
        require_consecutive_frames(str(folder), ids, [p.name for p in files])
    # every point correlated in some image, keyed by its reference subset position
    all_keys = (
        pd.MultiIndex.from_arrays(np.concatenate([f[1] for f in frames]).T, names=["image_x", "image_y"])
        .unique()
        .sort_values()
    )
    n = len(all_keys)
    xyz = np.full((n, 3), np.nan)
    u = np.full((len(frames), n, 3), np.nan)
    spread = 0.0
    for k in reversed(range(len(frames))):  # the earliest image that has a point sets its reference
        _, fid, ref, disp, *_ = frames[k]
        where = all_keys.get_indexer(pd.MultiIndex.from_arrays(fid.T))
        u[k, where] = disp
        seen = np.isfinite(xyz[where]).all(axis=1)
        if seen.any():
            spread = max(spread, float(np.abs(xyz[where][seen] - ref[seen]).max()))
        xyz[where] = ref
    notes = [f"reference positions agree across images to {spread:.2g} mm (coor - disp)"]
    notes += _dropped_notes(files, [f[5] for f in frames], max_sigma)
    return DICSeries(str(folder), xyz, u, ids, [p.name for p in files], None, notes)
