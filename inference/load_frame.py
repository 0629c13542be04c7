"""The load frame's continuous record (time, indenter position, force) cut into the holds of the
protocol, each assigned its step and fitted with eq. 9 (paper 2.7).

The stage moves by one step, stops, and holds while the force relaxes; the balance or load cell
reads all along. A reading belongs to a hold when the depth (position from the contact position,
signed so that it grows into the specimen) sits within ``level_tol`` step sizes of a whole number
k of steps; a run of such readings at one k lasting at least ``min_hold_s`` and standing still
(its depth spanning at most half that tolerance) is step k's hold.
A run that stands still elsewhere (off every level) is a slipped step and an error naming its
rows; so are a hold beyond the protocol, a step held twice, and a count of holds that differs from
the protocol's steps (both counts named). The readings before step 1 (depth 0) tare the force
when there are enough of them.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .experiment_data import ExperimentDataError
from .experiment_processing import RelaxationFit, relaxation_fit
from .hold_checks import check_hold_forces
from .table_columns import find_column, numeric_column, read_table
from .units import resolve_unit

_OFF = -(10**9)  # the label of a reading off every level
_TIME_NAMES = ("time", "t", "elapsed")
_POSITION_NAMES = ("position", "pos", "displacement", "disp", "depth", "extension", "z", "stage")
_FORCE_NAMES = ("force", "load", "f", "weight", "mass", "reading")


@dataclass(frozen=True)
class LoadFrameColumns:
    """Column names of the record (None: found by their usual names) and their units (None: read
    from the header; a unit declared here must agree with a unit the header states)."""

    time: str | None = None
    position: str | None = None
    force: str | None = None
    time_unit: str | None = None
    position_unit: str | None = None
    force_unit: str | None = None


@dataclass
class LoadFrameRecord:
    path: Path
    time_s: np.ndarray
    position_mm: np.ndarray
    force_mN: np.ndarray
    columns: dict[str, str]


@dataclass
class Hold:
    """One step's hold: rows of the record (as an editor counts them, header = row 1), times on the
    record's clock, its depth, and its eq. 9 fit."""

    step: int
    first_row: int
    last_row: int
    start_s: float
    end_s: float
    depth_mm: float
    readings: int
    f_inf_mN: float
    f_inf_std_mN: float
    amplitude_mN: float
    rate_per_s: float

    def to_dict(self) -> dict:
        return asdict(self)


def _guess(table: pd.DataFrame, given: str | None, names: tuple[str, ...], path: Path, role: str) -> str:
    if given is not None:
        return find_column(table, given, path, role)
    from .table_columns import bare_name

    for c in table.columns:
        words = bare_name(c).lower().replace("_", " ").replace("-", " ").split()
        if words and words[0] in names:
            return c
    raise ExperimentDataError(
        f"{path}: no {role} column found by name (has {', '.join(table.columns)}); name it explicitly"
    )


def read_load_frame(path: str | Path, columns: LoadFrameColumns = LoadFrameColumns()) -> LoadFrameRecord:
    """Read the record; times in s, positions in mm and forces in mN after the units (declared or
    from the headers); readings ordered in time (an error naming the row where time goes back)."""
    path = Path(path)
    table = read_table(path)
    t_col = _guess(table, columns.time, _TIME_NAMES, path, "time")
    p_col = _guess(table, columns.position, _POSITION_NAMES, path, "position")
    f_col = _guess(table, columns.force, _FORCE_NAMES, path, "force")
    t = numeric_column(table, t_col, path, False) * resolve_unit(t_col, columns.time_unit, "time", str(path))
    p = numeric_column(table, p_col, path, False) * resolve_unit(
        p_col, columns.position_unit, "length", str(path)
    )
    f = numeric_column(table, f_col, path, False) * resolve_unit(
        f_col, columns.force_unit, "force", str(path)
    )
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        raise ExperimentDataError(
            f"{path}: row {back[0] + 3}, column '{t_col}': time {t[back[0] + 1]:g} s does not follow {t[back[0]]:g} s"
        )
    return LoadFrameRecord(path, t, p, f, {"time": t_col, "position": p_col, "force": f_col})


def _runs(labels: np.ndarray) -> list[tuple[int, int, int]]:
    """(label, first, last) of each maximal run of equal labels."""
    edges = np.flatnonzero(np.diff(labels) != 0)
    starts = np.concatenate([[0], edges + 1])
    ends = np.concatenate([edges, [len(labels) - 1]])
    return [(int(labels[a]), int(a), int(b)) for a, b in zip(starts, ends, strict=True)]


@dataclass
class HoldSearch:
    holds: list[Hold]
    tare_mN: float
    position_sign: float
    force_sign: float
    contact_position_mm: float


def find_holds(
    record: LoadFrameRecord,
    step_size: float,
    steps: int,
    radius: float,
    contact_position_mm: float | None = None,
    position_sign: float | None = None,
    force_sign: float | None = None,
    level_tol: float = 0.1,
    min_hold_s: float = 5.0,
    tare: bool = True,
    excluded_steps: tuple[int, ...] = (),
) -> HoldSearch:
    """The protocol's holds in ``record`` (module docstring), each fitted with eq. 9.

    ``contact_position_mm`` is the position at zero depth (default: the first reading);
    ``position_sign`` +1 when the position grows into the specimen, -1 when it falls (default: the
    sign of the largest excursion); ``force_sign`` makes compression positive (default: the sign
    of the force at the deepest hold). A step of ``excluded_steps`` may have no hold and its
    readings are not checked."""
    where = str(record.path)
    p0 = float(record.position_mm[0] if contact_position_mm is None else contact_position_mm)
    excursion = record.position_mm - p0
    sign = float(
        position_sign if position_sign is not None else np.sign(excursion[np.argmax(np.abs(excursion))])
    )
    if sign == 0:
        raise ExperimentDataError(f"{where}: the position never changes: no hold found")
    depth = sign * excursion
    level = np.rint(depth / step_size)
    on_level = np.abs(depth - level * step_size) <= level_tol * step_size
    labels = np.where(on_level, level, _OFF).astype(np.int64)
    t = record.time_s
    still = 0.5 * level_tol * step_size  # a hold stands still: its depth spans no more than this
    runs = [
        (k, a, b)
        for k, a, b in _runs(labels)
        if t[b] - t[a] >= min_hold_s and (b - a + 1) >= 4 and (k == _OFF or np.ptp(depth[a : b + 1]) <= still)
    ]
    # a stretch that stands still off every level: a step that slipped or stopped short
    for k, a0, b0 in _runs(labels):
        if k != _OFF:
            continue
        moving = (np.abs(np.diff(depth[a0 : b0 + 1])) > still).astype(int)
        pieces = [(a0 + i, a0 + j + 1) for m, i, j in _runs(moving) if m == 0] if moving.size else []
        for a, b in pieces:
            d = float(np.median(depth[a : b + 1]))
            if t[b] - t[a] < min_hold_s or np.ptp(depth[a : b + 1]) > still or not 0 < d < steps * step_size:
                continue
            raise ExperimentDataError(
                f"{where}: rows {a + 2}..{b + 2} (t = {t[a]:g} .. {t[b]:g} s) hold at depth {d:.4g} mm, between "
                f"steps {int(d // step_size)} and {int(d // step_size) + 1} of {step_size:g} mm: a slipped step?"
            )
    level_runs = [(k, a, b) for k, a, b in runs if k >= 1]
    if not level_runs:
        raise ExperimentDataError(
            f"{where}: no hold found: the position never stays within {level_tol * step_size:g} mm of a multiple of "
            f"the {step_size:g} mm step for {min_hold_s:g} s (step size, units or --min-hold wrong?)"
        )
    held = [k for k, _, _ in level_runs]
    for i, k in enumerate(held):
        if k > steps:
            _, a, b = level_runs[i]
            raise ExperimentDataError(
                f"{where}: found {len(set(held))} holds but the protocol has {steps} steps: rows {a + 2}..{b + 2} "
                f"hold at step {k} ({k * step_size:g} mm)"
            )
        if held.count(k) > 1:
            rows = [f"{a + 2}..{b + 2}" for kk, a, b in level_runs if kk == k]
            raise ExperimentDataError(f"{where}: step {k} is held more than once (rows {', '.join(rows)})")
    missing = sorted(set(range(1, steps + 1)) - set(held) - set(excluded_steps))
    if missing:
        raise ExperimentDataError(
            f"{where}: found {len(held)} holds but the protocol has {steps} steps (no hold at step(s) "
            f"{', '.join(map(str, missing[:10]))})"
        )
    before = [(a, b) for k, a, b in runs if k == 0 and b < level_runs[0][1]]
    tare_mN = (
        float(np.median(record.force_mN[before[-1][0] : before[-1][1] + 1])) if (tare and before) else 0.0
    )
    f_all = record.force_mN - tare_mN
    _, a, b = level_runs[-1]
    fsign = float(force_sign if force_sign is not None else np.sign(np.median(f_all[a : b + 1])) or 1.0)
    holds = []
    for k, a, b in sorted(level_runs):
        tt, ff = t[a : b + 1] - t[a], fsign * f_all[a : b + 1]
        try:
            fit = relaxation_fit(tt, ff)
        except ExperimentDataError as exc:
            if k not in excluded_steps:
                raise ExperimentDataError(f"{where}: step {k} (rows {a + 2}..{b + 2}): {exc}") from None
            fit = RelaxationFit(np.nan, np.nan, np.nan, np.nan)
        holds.append(
            Hold(
                k,
                a + 2,
                b + 2,
                float(t[a]),
                float(t[b]),
                float(np.median(depth[a : b + 1])),
                b - a + 1,
                fit.f_inf,
                fit.f_inf_std,
                fit.amplitude,
                fit.rate,
            )
        )
    table = hold_force_table(record, HoldSearch(holds, tare_mN, sign, fsign, p0))
    check_hold_forces(
        table,
        radius,
        step_size,
        where,
        rows=np.concatenate([np.arange(h.first_row, h.last_row + 1) for h in holds]),
        force_column=record.columns["force"],
        excluded_steps=excluded_steps,
    )
    return HoldSearch(holds, tare_mN, sign, fsign, p0)


def hold_force_table(record: LoadFrameRecord, search: HoldSearch) -> pd.DataFrame:
    """The readings of every hold in the experiment format's ``force.csv`` layout: ``step``,
    ``time_s`` from the start of that hold, ``force_mN`` (tared, compression positive)."""
    parts = []
    for h in search.holds:
        a, b = h.first_row - 2, h.last_row - 2
        parts.append(
            pd.DataFrame(
                {
                    "step": h.step,
                    "time_s": record.time_s[a : b + 1] - record.time_s[a],
                    "force_mN": search.force_sign * (record.force_mN[a : b + 1] - search.tare_mN),
                }
            )
        )
    return pd.concat(parts, ignore_index=True)
