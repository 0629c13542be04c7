"""The index of a campaign store, ``index.parquet``: one row per point (its parameters, status,
wall time, Newton iterations, error, and the sha256 and size of its file as written). An index
that is unreadable, or has a row missing, repeated or of another point, is rebuilt from the
design (:func:`read_index`; the point files then restore what they hold), and each run's rows
are merged with what other runs wrote (:func:`merge_rows`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..forward.result import SimulationResult
from .checksums import Problem
from .spec import CampaignSpec

__all__ = [
    "CHECK_COLUMNS",
    "PENDING_ROW",
    "STATUSES",
    "as_int",
    "fresh_index",
    "is_missing",
    "merge_rows",
    "read_index",
    "result_row",
    "with_check_columns",
]

STATUSES = ("pending", "done", "failed")
#: Index columns of the file checks (an older index gets them on its first resume).
CHECK_COLUMNS = ("sha256", "bytes", "attempts", "flagged_steps", "rerun_s")
#: The fields of a point made pending again (its file missing or failing its check).
PENDING_ROW = {"status": "pending", "sha256": None, "bytes": None, "error": None, "flagged_steps": None}


def fresh_index(spec: CampaignSpec) -> pd.DataFrame:
    """The index of a campaign with no point solved: every point pending.

    Parameters
    ----------
    spec : CampaignSpec
        The campaign.

    Returns
    -------
    pandas.DataFrame
        One row per design point.
    """
    n = len(spec.design.points)
    table = pd.DataFrame({"point": np.arange(n)})
    for j, k in enumerate(spec.design.parameters):
        table[k] = spec.design.points[:, j]
    table["status"] = pd.Categorical(["pending"] * n, categories=STATUSES)
    table["wall_s"] = np.nan
    table["newton_iterations"] = pd.array([pd.NA] * n, dtype="Int64")
    table["error"] = pd.array([None] * n, dtype="string")
    table["finished"] = pd.array([None] * n, dtype="string")
    return with_check_columns(table)


def with_check_columns(index: pd.DataFrame) -> pd.DataFrame:
    """The columns of this version added to an older index (empty), status made categorical."""
    index = index.copy()
    n = len(index)
    if "sha256" not in index:
        index["sha256"] = pd.array([None] * n, dtype="string")
    for col in ("bytes", "attempts", "flagged_steps"):
        if col not in index:
            index[col] = pd.array([pd.NA] * n, dtype="Int64")
    if "rerun_s" not in index:
        index["rerun_s"] = np.nan
    if "status" in index and not isinstance(index["status"].dtype, pd.CategoricalDtype):
        index["status"] = pd.Categorical(index["status"].astype(str), categories=STATUSES)
    return index


def read_index(path: Path, spec: CampaignSpec) -> tuple[pd.DataFrame, list[Problem]]:
    """The index on disk checked against the design (call under the store's lock).

    An unreadable file, or rows missing, repeated, of no point or of other parameters give a
    fresh row (the point files then restore what they hold).

    Parameters
    ----------
    path : pathlib.Path
        The store's ``index.parquet``.
    spec : CampaignSpec
        The campaign.

    Returns
    -------
    pandas.DataFrame
        The index, one row per design point.
    list of Problem
        What failed its check.
    """
    fresh = fresh_index(spec)
    problems: list[Problem] = []
    if not path.is_file():
        problems.append(Problem(str(path), "missing: rebuilt from the point files", action="rebuilt"))
        return fresh, problems
    try:
        raw = pd.read_parquet(path).copy(deep=True)  # a deep copy: arrays may be read-only views
        if "point" not in raw or "status" not in raw:
            raise ValueError("no point or status column")
    except Exception as exc:  # pyarrow's errors for a damaged file are of many kinds
        problems.append(
            Problem(str(path), f"unreadable ({type(exc).__name__}: {exc}); rebuilt from the point files")
        )
        return fresh, problems
    raw = with_check_columns(raw)
    names = list(spec.design.parameters)
    n = len(fresh)
    pts = pd.to_numeric(raw["point"], errors="coerce").to_numpy(float)
    ok = np.isfinite(pts) & (pts >= 0) & (pts < n) & (pts == np.round(pts))
    at = np.where(ok, pts, 0).astype(int)
    for j, k in enumerate(names):
        values = (
            pd.to_numeric(raw[k], errors="coerce").to_numpy(float) if k in raw else np.full(len(raw), np.nan)
        )
        ok &= np.isclose(values, spec.design.points[at, j], rtol=1e-12, atol=0)
    ok &= raw["status"].astype(str).isin(STATUSES).to_numpy()
    ok &= ~pd.Series(np.where(ok, at, -1 - np.arange(len(raw)))).duplicated().to_numpy()
    for r in np.flatnonzero(~ok):
        problems.append(
            Problem(
                str(path),
                f"row {r} (point {raw['point'].iloc[r]!r}) is not a row of the design, or repeats one",
            )
        )
    good = raw[ok]
    rows = at[ok]
    for col in fresh.columns:
        if col in good.columns and col not in ("point", *names):
            fresh.loc[rows, col] = good[col].to_numpy()
    for i in sorted(set(range(n)) - set(rows.tolist())):
        problems.append(Problem(str(path), f"no row for point {i}: restored from its file, if any", i))
    for p in problems:
        p.action = "rebuilt from the point files"
    return fresh, problems


def merge_rows(disk: pd.DataFrame, ours: pd.DataFrame, dirty: list[int]) -> pd.DataFrame:
    """The index on disk with this run's changed rows (``dirty``) taken from ``ours``."""
    if dirty:
        for col in disk.columns:
            disk.loc[dirty, col] = ours.loc[dirty, col].to_numpy()
    return disk


def is_missing(value: Any) -> bool:
    """Whether an index cell is empty (None, NaN, NA)."""
    try:
        return value is None or bool(pd.isna(value))
    except (TypeError, ValueError):
        return False


def as_int(value: Any) -> int | None:
    """An index cell as an int, None when empty."""
    return None if is_missing(value) else int(value)


def result_row(result: SimulationResult) -> dict[str, Any]:
    """The index fields a result file restores (wall time, iterations, flagged steps, rerun)."""
    flagged = int(np.sum(result.off_equilibrium)) if result.off_equilibrium is not None else 0
    rerun = result.solver.get("rerun") or {}
    walls = rerun.get("wall_s")
    return {
        "wall_s": result.wall_s,
        "newton_iterations": result.newton_iterations,
        "flagged_steps": flagged,
        "rerun_s": float(walls[1]) if isinstance(walls, list) and len(walls) > 1 else None,
    }
