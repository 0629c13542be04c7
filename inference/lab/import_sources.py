"""What an import is told and what it returns: the protocol (:class:`ProtocolInfo`), where the
force comes from (:class:`ForceSource`), the DIC frame of each step (:class:`FrameChoice`,
:func:`parse_frames`), the indenter's tracked points (:class:`IndenterSource`,
:func:`read_indenter_points`), and the summary of what was written (:class:`ImportResult`). The
import itself is :mod:`~indentation_studio.inference.lab.experiment_import`'s."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..experiment.data import ExperimentDataError
from .duodic_results import read_duodic
from .load_frame import LoadFrameColumns
from .matchid_export import read_matchid
from .table_columns import find_column, numeric_column, read_table
from .units import resolve_unit

__all__ = [
    "ForceSource",
    "FrameChoice",
    "ImportResult",
    "IndenterSource",
    "ProtocolInfo",
    "parse_frames",
    "read_indenter_points",
]


@dataclass(frozen=True)
class ProtocolInfo:
    """What the experiment.json states: the indenter's radius, the step size and count (mm), the
    fiber direction in the DIC frame (degrees from x; None: estimate it), the steps left out."""

    radius_mm: float
    step_size_mm: float
    steps: int
    fiber_angle_deg: float | None = None
    description: str = ""
    excluded_steps: tuple[int, ...] = ()
    specimen_mm: dict[str, float] | None = None  # width, depth, thickness: experiment.json's specimen_mm


@dataclass(frozen=True)
class ForceSource:
    """Either the load frame's continuous record (``load_frame``, its columns and units, and how
    holds are found: :func:`.load_frame.find_holds`) or a ``force_csv`` in the format's hold form."""

    load_frame: Path | None = None
    columns: LoadFrameColumns = field(default_factory=LoadFrameColumns)
    contact_position_mm: float | None = None
    position_sign: float | None = None
    force_sign: float | None = None
    level_tol: float = 0.1
    min_hold_s: float = 5.0
    tare: bool = True
    force_csv: Path | None = None


@dataclass(frozen=True)
class FrameChoice:
    """The DIC frame of each step: ``frames`` (one frame number per step), or by time: the last
    frame during each hold, with frame times from the export, ``times_s`` (one per frame) or
    ``times_file`` (a CSV of frame, time), plus ``time_offset_s`` onto the load frame's clock
    (None: found from the data, :mod:`.clock_offset`)."""

    frames: tuple[int, ...] | None = None
    times_s: tuple[float, ...] | None = None
    times_file: Path | None = None
    time_unit: str | None = None
    time_offset_s: float | None = None


@dataclass(frozen=True)
class IndenterSource:
    """The indenter's tracked points in the reference state: a CSV of x, y, z (``columns``), a
    MatchID export folder or a DuoDIC .mat of the indenter's region (its reference positions)."""

    path: Path
    length_unit: str | None = None
    columns: tuple[str, str, str] = ("x", "y", "z")


@dataclass
class ImportResult:
    experiment: Path
    source: str
    points: int
    frames: list[int]
    points_per_step: list[int]
    indenter_points: int
    holds: list[dict] = field(default_factory=list)
    tare_mN: float = 0.0
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        out = asdict(self)
        out["experiment"] = str(self.experiment)
        return out


def parse_frames(text: str) -> tuple[int, ...]:
    """``1:28`` (inclusive), ``2:56:2`` or ``3,5,9`` as frame numbers."""
    out: list[int] = []
    try:
        for part in filter(None, (p.strip() for p in text.split(","))):
            if ":" in part:
                a, b, *s = (int(v) for v in part.split(":"))
                out.extend(range(a, b + 1, s[0] if s else 1))
            else:
                out.append(int(part))
    except ValueError as exc:
        raise ExperimentDataError(f"frames: {text!r} is not a list like 1:28, 2:56:2 or 3,5,9") from exc
    return tuple(out)


def read_indenter_points(source: IndenterSource) -> np.ndarray:
    """The indenter's points (n, 3) in mm from a CSV, a MatchID folder or a DuoDIC .mat."""
    path = Path(source.path)
    if path.is_dir():
        return read_matchid(path, source.length_unit, allow_gaps=True).xyz
    if path.suffix.lower() == ".mat":
        if source.length_unit is None:
            raise ExperimentDataError(f"{path}: DuoDIC stores no units; declare the indenter's length unit")
        return read_duodic(path, source.length_unit).xyz
    table = read_table(path)
    cols = []
    for name in source.columns:
        header = find_column(table, name, path)
        cols.append(
            numeric_column(table, header, path, False)
            * resolve_unit(header, source.length_unit, "length", str(path))
        )
    return np.column_stack(cols)
