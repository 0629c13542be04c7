"""The load frame's continuous record (time, indenter position, force) cut into the holds of the
protocol, each assigned its step and fitted with eq. 9 (paper 2.7).

The stage moves by one step, stops, and holds while the force relaxes; the balance or load cell
reads all along, at any rate (1 Hz .. 1 kHz). The depth is the position from the contact point
(given, or the onset of a power law fitted to the loading, :mod:`.contact_onset`), signed so that it grows into the
specimen. A run of readings whose depth sits within ``level_tol`` step sizes of a whole number k
of steps is trimmed to the stretch where the stage stood still (:mod:`.hold_detection`: within a
band of a few times the position's noise, so a ramp's readings never count in a hold); lasting at
least ``min_hold_s`` it is step k's hold. A stretch that stands still elsewhere (off every level)
is a slipped step and an error naming its rows; so are a hold beyond the protocol, a step held
twice, and a count of holds that differs from the protocol's steps (both counts named, and the
levels and durations where the stage did stand still). The readings before step 1 (depth 0) tare
the force; unloaded readings after the last hold give the load cell's drift, taken off.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..experiment.data import ExperimentDataError
from ..experiment.hold_checks import check_hold_forces
from ..experiment.relaxation import RelaxationFit, relaxation_fit
from .contact_onset import ContactOnset, power_law_onset
from .hold_detection import OFF, describe_stretches, robust_noise, still_stretches
from .table_columns import bare_name, find_column, first_row, numeric_column, read_table, read_with
from .units import resolve_unit

_TIME_NAMES = ("time", "t", "elapsed")
_POSITION_NAMES = (
    "position",
    "pos",
    "displacement",
    "disp",
    "depth",
    "extension",
    "z",
    "stage",
    "crosshead",
)
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
    notes: list[str] = field(default_factory=list)
    first_line: int = 2  # the file line of the first reading (2: the header is line 1)


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
    """The column of ``role``: ``given``, else the first whose name starts with one of ``names``,
    else the first with one of them as a word (``Axial Force`` for a force, as MTS names it)."""
    if given is not None:
        return find_column(table, given, path, role)
    words = {
        c: bare_name(c).lower().replace("_", " ").replace("-", " ").replace(".", " ").split()
        for c in table.columns
    }
    for c in table.columns:
        if words[c] and words[c][0] in names:
            return c
    for c in table.columns:
        if any(w in names for w in words[c][1:]):
            return c
    raise ExperimentDataError(
        f"{path}: no {role} column found by name (has {', '.join(table.columns)}); name it (--{role}-col)"
        f"{read_with(table)}"
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
            f"{path}: row {back[0] + 1 + first_row(table)}, column '{t_col}': time {t[back[0] + 1]:g} s does not follow {t[back[0]]:g} s"
        )
    return LoadFrameRecord(
        path,
        t,
        p,
        f,
        {"time": t_col, "position": p_col, "force": f_col},
        list(table.attrs.get("notes", [])),
        first_row(table),
    )


@dataclass
class HoldSearch:
    holds: list[Hold]
    tare_mN: float
    position_sign: float
    force_sign: float
    contact_position_mm: float
    contact_from: str = "given"  # "given", "force onset" or "first reading"
    drift_mN_per_s: float = 0.0  # the load cell's drift, from the unloaded readings before and after
    tare_time_s: float = 0.0  # the time the tare was read at (the drift's origin)
    notes: list[str] = field(default_factory=list)

    def baseline(self, t: np.ndarray) -> np.ndarray:
        """The unloaded reading at times ``t``: the tare and the drift since it was read."""
        return self.tare_mN + self.drift_mN_per_s * (np.asarray(t, float) - self.tare_time_s)


def _into_specimen(position: np.ndarray, force: np.ndarray) -> float:
    """+1 when the position grows into the specimen, -1 when it falls, 0 when it never changes.

    The way the stage went from its first reading to where the force strayed farthest from its
    first readings' (the top 5 % of the readings: the deepest holds), when that force stands
    clear of the noise; else the way of its largest excursion from its first reading. Not from
    the contact: an approach through air from farther above the contact than the steps go below
    it is the largest excursion from the contact, the wrong way.
    """
    p, f = np.asarray(position, float), np.asarray(force, float)
    stray = np.abs(f - np.median(f[: max(3, f.size // 100)]))
    loaded = stray >= np.quantile(stray, 0.95)
    way = float(np.sign(np.median(p[loaded]) - p[0]))
    if way and float(np.median(stray[loaded])) > 10.0 * robust_noise(f):
        return way
    excursion = p - p[0]
    return float(np.sign(excursion[np.argmax(np.abs(excursion))]))


def _contact(
    record: LoadFrameRecord, given: float | None, step_size: float
) -> tuple[float, str, ContactOnset | None]:
    """The position at zero depth: ``given``, else the onset of a power law fitted to the loading
    (:func:`.contact_onset.power_law_onset`), else the first reading."""
    if given is not None:
        return float(given), "given", None
    p = record.position_mm
    sign = _into_specimen(p, record.force_mN) or 1.0
    onset = power_law_onset(record.time_s, p, record.force_mN, step_size, sign)
    if onset is None:
        return float(p[0]), "first reading", None
    return onset.position_mm, onset.source, onset


def _elsewhere(
    held, p0: float, sign: float, step_size: float, level_tol: float, how: str, min_hold_s: float
) -> str:
    """The way out when the holds do not fit the protocol from the contact used: where the holds
    that stood still for ``min_hold_s`` sit from their steps, and the option that sets the contact."""
    deep = np.array([s.depth_mm for _, s in held if s.depth_mm > 0.5 * step_size])
    hint = ""
    if deep.size:
        off = deep - np.rint(deep / step_size) * step_size
        shift = float(np.median(off))
        if abs(shift) > level_tol * step_size and float(np.ptp(off)) <= level_tol * step_size:
            hint = (
                f" The {deep.size} holds sit {shift:+.3g} mm from whole steps from this contact: a contact at "
                f"{p0 + sign * shift:g} mm fits them."
            )
    where = "the contact given" if how == "given" else f"the contact found ({how})"
    return f".{hint} If {where} is not where the steps are counted from, give it: --contact-position MM"


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
    drift: bool = True,
) -> HoldSearch:
    """The protocol's holds in ``record`` (module docstring), each fitted with eq. 9.

    ``contact_position_mm`` is the position at zero depth (default: the onset of a power law
    fitted to the loading, :func:`.contact_onset.power_law_onset`, or the first reading of a
    record that starts at the contact; the first reading when nothing can be fitted: the message
    of holds that do not fit the protocol names the option); ``position_sign`` +1 when the position grows into the specimen, -1 when it falls
    (default: the way the stage went to load the specimen, :func:`_into_specimen`); ``force_sign`` makes compression positive
    (default: the sign of the force at the deepest hold). A step of ``excluded_steps`` may have no
    hold and its readings are not checked. With ``drift``, unloaded readings after the last hold
    (the indenter withdrawn to the contact point or above) give the load cell's drift since the
    tare, which is taken off every reading (linear in time)."""
    where = str(record.path)
    r0 = record.first_line
    p0, contact_from, onset = _contact(record, contact_position_mm, step_size)
    excursion = record.position_mm - p0
    sign = float(
        position_sign if position_sign is not None else _into_specimen(record.position_mm, record.force_mN)
    )
    if sign == 0:
        raise ExperimentDataError(f"{where}: the position never changes: no hold found")
    depth = sign * excursion
    t = record.time_s
    stretches = still_stretches(t, depth, step_size, level_tol)
    held = [(k, s) for k, s in stretches if s.duration_s >= min_hold_s and s.readings >= 4]
    seen = [(k, s) for k, s in stretches if s.duration_s >= min(1.0, min_hold_s) and s.readings >= 4]
    saw = (
        f"the stage stood still at {describe_stretches([x for x in seen if x[1].depth_mm > -step_size])} "
        f"(depths from the contact at {p0:g} mm, {contact_from})"
    )
    # a stretch that stands still off every level: a step that slipped or stopped short
    for k, s in held:
        if k == OFF and 0 < s.depth_mm < steps * step_size:
            d = s.depth_mm
            raise ExperimentDataError(
                f"{where}: rows {s.first + r0}..{s.last + r0} (t = {s.start_s:g} .. {s.end_s:g} s) hold at depth "
                f"{d:.4g} mm, between steps {int(d // step_size)} and {int(d // step_size) + 1} of {step_size:g} mm: "
                f"a slipped step?{_elsewhere(held, p0, sign, step_size, level_tol, contact_from, min_hold_s)}"
            )
    level_runs = [(k, s.first, s.last) for k, s in held if k >= 1]
    if not level_runs:
        raise ExperimentDataError(
            f"{where}: no hold found: the position never stays within {level_tol * step_size:g} mm of a multiple of "
            f"the {step_size:g} mm step for {min_hold_s:g} s; {saw} (step size, units, --contact-position or "
            "--min-hold wrong?)"
        )
    levels = [k for k, _, _ in level_runs]
    for i, k in enumerate(levels):
        if k > steps:
            _, a, b = level_runs[i]
            raise ExperimentDataError(
                f"{where}: found {len(set(levels))} holds but the protocol has {steps} steps: rows {a + r0}..{b + r0} "
                f"hold at step {k} ({k * step_size:g} mm); {saw}{_elsewhere(held, p0, sign, step_size, level_tol, contact_from, min_hold_s)}"
            )
        if levels.count(k) > 1:
            rows = [f"{a + r0}..{b + r0}" for kk, a, b in level_runs if kk == k]
            raise ExperimentDataError(f"{where}: step {k} is held more than once (rows {', '.join(rows)})")
    missing = sorted(set(range(1, steps + 1)) - set(levels) - set(excluded_steps))
    if missing:
        raise ExperimentDataError(
            f"{where}: found {len(levels)} holds but the protocol has {steps} steps (no hold at step(s) "
            f"{', '.join(map(str, missing[:10]))}); {saw}{_elsewhere(held, p0, sign, step_size, level_tol, contact_from, min_hold_s)}"
        )
    search = HoldSearch([], 0.0, sign, 1.0, p0, contact_from)
    if onset is not None:
        search.notes += onset.notes
    first_hold, last_hold = min(a for _, a, _ in level_runs), max(b for _, _, b in level_runs)
    before = [s for k, s in stretches if k == 0 and s.last < first_hold and s.readings >= 3]
    preload = onset is not None and onset.start_load_mN != 0.0
    if tare and before:
        s = before[-1]
        search.tare_mN = float(np.median(record.force_mN[s.first : s.last + 1]))
        search.tare_time_s = 0.5 * (s.start_s + s.end_s)
        after = [
            s
            for k, s in stretches
            if s.first > last_hold and s.depth_mm <= level_tol * step_size and s.readings >= 3
        ]
        if drift and preload:
            # a preload tared: the unloaded readings after the withdrawal sit below it by the preload,
            # not by a drift; the drift is the fitted baseline's
            search.drift_mN_per_s = onset.drift_mN_per_s
            search.notes.append(
                f"the record starts loaded ({onset.start_load_mN:.3g} mN above the unloaded baseline): the force "
                f"is tared at {search.tare_mN:.4g} mN, the readings before step 1; load-cell drift "
                f"{search.drift_mN_per_s:.3g} mN/s (the fitted baseline's) taken off"
            )
        elif drift and after:
            e = after[-1]
            end_f = float(np.median(record.force_mN[e.first : e.last + 1]))
            end_t = 0.5 * (e.start_s + e.end_s)
            search.drift_mN_per_s = (end_f - search.tare_mN) / (end_t - search.tare_time_s)
            search.notes.append(
                f"load-cell drift {search.drift_mN_per_s:.3g} mN/s taken off (unloaded {search.tare_mN:.4g} mN at "
                f"t = {search.tare_time_s:g} s, {end_f:.4g} mN at t = {end_t:g} s)"
            )
    elif tare and onset is not None:  # no wait at the contact (an approach into step 1): the fitted baseline
        search.tare_mN, search.tare_time_s = onset.baseline_mN, onset.time_s
        search.drift_mN_per_s = onset.drift_mN_per_s if drift else 0.0
        search.notes.append(
            f"force tared by the baseline fitted with the contact: {search.tare_mN:.4g} mN at t = {search.tare_time_s:g} s"
            + (
                f", load-cell drift {search.drift_mN_per_s:.3g} mN/s taken off"
                if search.drift_mN_per_s
                else ""
            )
        )
    f_all = record.force_mN - search.baseline(t)
    _, a, b = max(level_runs)
    search.force_sign = float(
        force_sign if force_sign is not None else np.sign(np.median(f_all[a : b + 1])) or 1.0
    )
    for k, a, b in sorted(level_runs):
        tt, ff = t[a : b + 1] - t[a], search.force_sign * f_all[a : b + 1]
        try:
            fit = relaxation_fit(tt, ff)
        except ExperimentDataError as exc:
            if k not in excluded_steps:
                raise ExperimentDataError(f"{where}: step {k} (rows {a + r0}..{b + r0}): {exc}") from None
            fit = RelaxationFit(np.nan, np.nan, np.nan, np.nan)
        search.holds.append(
            Hold(
                k,
                a + r0,
                last_row=b + r0,
                start_s=float(t[a]),
                end_s=float(t[b]),
                depth_mm=float(np.median(depth[a : b + 1])),
                readings=b - a + 1,
                f_inf_mN=fit.f_inf,
                f_inf_std_mN=fit.f_inf_std,
                amplitude_mN=fit.amplitude,
                rate_per_s=fit.rate,
            )
        )
    table = hold_force_table(record, search)
    check_hold_forces(
        table,
        radius,
        step_size,
        where,
        rows=np.concatenate([np.arange(h.first_row, h.last_row + 1) for h in search.holds]),
        force_column=record.columns["force"],
        excluded_steps=excluded_steps,
    )
    return search


def hold_force_table(record: LoadFrameRecord, search: HoldSearch) -> pd.DataFrame:
    """The readings of every hold in the experiment format's ``force.csv`` layout: ``step``,
    ``time_s`` from the start of that hold, ``force_mN`` (tared, compression positive)."""
    parts = []
    for h in search.holds:
        a, b = h.first_row - record.first_line, h.last_row - record.first_line
        parts.append(
            pd.DataFrame(
                {
                    "step": h.step,
                    "time_s": record.time_s[a : b + 1] - record.time_s[a],
                    "force_mN": search.force_sign
                    * (record.force_mN[a : b + 1] - search.baseline(record.time_s[a : b + 1])),
                }
            )
        )
    return pd.concat(parts, ignore_index=True)
