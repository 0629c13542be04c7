"""The options the import commands share (:class:`LabOptions`), built once from their flags by
:func:`lab_options`: the protocol, where the force comes from (a load-frame record and how to read
it, or a force.csv), the indenter points, the DIC frame of each step, and how the files are read.
The commands are :mod:`~indentation_studio.studio.import_cli`'s."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer

from .. import inference  # lazy: a command imports what it runs
from .options import OVERWRITE, RADIUS, STEP_SIZE, STEPS, option_group, specimen_geometry

__all__ = ["LAB_FLAGS", "RECORD_FLAGS", "LabOptions", "lab_options"]

FIBER = Annotated[
    float | None,
    typer.Option(help="fiber direction in the DIC frame, degrees from x (default: from the strain)"),
]
EXCLUDE = Annotated[str, typer.Option(help="steps left out of the fit, e.g. 3,7")]
LOAD_FRAME = Annotated[
    Path | None, typer.Option(help="the load frame's continuous record (CSV: time, position, force)")
]
FORCE_CSV = Annotated[
    Path | None, typer.Option(help="or a force.csv already in hold form (step, time_s, force_mN)")
]
INDENTER = Annotated[Path, typer.Option(help="indenter points: CSV (x, y, z), MatchID folder or DuoDIC .mat")]
INDENTER_UNIT = Annotated[
    str | None, typer.Option(help="length unit of the indenter points (if the file states none)")
]
FRAMES = Annotated[str | None, typer.Option(help="the DIC frame of every step, e.g. 1:28, 2:56:2 or 3,5,9")]
FRAME_TIMES = Annotated[
    Path | None,
    typer.Option(help="CSV of frame and time: frames matched to the holds by time (the last in each)"),
]
_TIME_OFFSET_HELP = (
    "added to the DIC frame times to reach the load frame's clock, s; 'auto': found from the data "
    "(the frames' indentation against the stage's depth)"
)
TIME_OFFSET = Annotated[str, typer.Option(help=_TIME_OFFSET_HELP)]
TIME_COL = Annotated[str | None, typer.Option(help="record: time column (default: found by name)")]
POSITION_COL = Annotated[str | None, typer.Option(help="record: position column")]
FORCE_COL = Annotated[str | None, typer.Option(help="record: force column")]
TIME_UNIT = Annotated[
    str | None, typer.Option(help="record: time unit (s, ms, min) if the header states none")
]
POSITION_UNIT = Annotated[str | None, typer.Option(help="record: position unit (mm, um, m)")]
FORCE_UNIT = Annotated[str | None, typer.Option(help="record: force unit (mN, N, g for a balance)")]
MIN_HOLD = Annotated[float, typer.Option(help="record: shortest hold, s")]
CONTACT = Annotated[
    float | None,
    typer.Option(
        help="record: the position at zero depth, mm (default: where the force leaves its baseline)"
    ),
]
DESCRIPTION = Annotated[str, typer.Option(help="free text for experiment.json")]
ENCODING = Annotated[
    str | None,
    typer.Option(help="text encoding of the CSV files, e.g. cp1252 (default: UTF-8, else detected)"),
]
DELIMITER = Annotated[
    str | None,
    typer.Option(help="the CSV files' field delimiter: ',', ';' or 'tab' (default: detected)"),
]
DECIMAL = Annotated[
    str | None,
    typer.Option(
        help="the CSV files' decimal separator: '.' or ',' (default: detected; ',' with ';' or tab)"
    ),
]


def _offset(text: str) -> float | None:
    if text.strip().lower() == "auto":
        return None
    try:
        return float(text)
    except ValueError as exc:
        raise ValueError(f"--time-offset: {text!r} is neither a number of seconds nor 'auto'") from exc


def _specimen_mm(text: str) -> dict[str, float]:
    """``--specimen WIDTHxDEPTHxTHICKNESS`` as experiment.json's ``specimen_mm``."""
    g = specimen_geometry(text)
    return {"width": 2.0 * g.half_x, "depth": 2.0 * g.half_y, "thickness": g.height}


def _steps(text: str) -> tuple[int, ...]:
    try:
        return tuple(sorted({int(v) for v in text.split(",") if v.strip()}))
    except ValueError as exc:
        raise ValueError(f"--exclude-steps: {text!r} is not a list of steps like 3,7") from exc


@dataclass(frozen=True, kw_only=True)
class LabOptions:
    """The options the import commands share, built once from their flags (:func:`lab_options`):
    the protocol, where the force comes from (a load-frame record and how to read it, or a
    force.csv), the indenter points, the DIC frame of each step, and how the files are read."""

    radius: float
    step_size: float
    steps: int
    indenter: Path | None = None
    load_frame: Path | None = None
    force_csv: Path | None = None
    fiber_angle: float | None = None
    exclude_steps: str = ""
    frames: str | None = None
    frame_times: Path | None = None
    time_offset: str = "auto"
    indenter_unit: str | None = None
    time_col: str | None = None
    position_col: str | None = None
    force_col: str | None = None
    time_unit: str | None = None
    position_unit: str | None = None
    force_unit: str | None = None
    contact_position: float | None = None
    min_hold: float = 5.0
    description: str = ""
    overwrite: bool = False
    encoding: str | None = None
    delimiter: str | None = None
    decimal: str | None = None
    specimen: str | None = None

    def csv_reading(self):
        """The block in which CSV files are read with ``encoding``, ``delimiter`` and ``decimal``
        (:func:`inference.lab.csv_text.csv_reading`)."""
        return inference.lab.csv_reading(self.encoding, delimiter=self.delimiter, decimal=self.decimal)

    def protocol(self) -> inference.lab.ProtocolInfo:
        """The protocol: radius, step size, steps, fiber angle, description and steps left out."""
        return inference.lab.ProtocolInfo(
            self.radius,
            self.step_size,
            self.steps,
            self.fiber_angle,
            self.description,
            _steps(self.exclude_steps),
            None if self.specimen is None else _specimen_mm(self.specimen),
        )

    def force(self) -> inference.lab.ForceSource:
        """Where the force comes from: the load-frame record (its columns, units, contact, holds) or a force.csv."""
        columns = inference.lab.LoadFrameColumns(
            self.time_col,
            self.position_col,
            self.force_col,
            self.time_unit,
            self.position_unit,
            self.force_unit,
        )
        return inference.lab.ForceSource(
            load_frame=self.load_frame,
            columns=columns,
            contact_position_mm=self.contact_position,
            min_hold_s=self.min_hold,
            force_csv=self.force_csv,
        )

    def indenter_points(self) -> inference.lab.IndenterSource:
        """The indenter points and their length unit."""
        return inference.lab.IndenterSource(self.indenter, self.indenter_unit)

    def frame_choice(self) -> inference.lab.FrameChoice:
        """The DIC frame of every step: given, matched by time, and the clocks' offset."""
        return inference.lab.FrameChoice(
            frames=inference.lab.parse_frames(self.frames) if self.frames else None,
            times_file=self.frame_times,
            time_offset_s=_offset(self.time_offset),
        )

    def sources(self) -> dict:
        """The importers' shared keywords: protocol, force, indenter, frames and overwrite."""
        return {
            "protocol": self.protocol(),
            "force": self.force(),
            "indenter": self.indenter_points(),
            "frames": self.frame_choice(),
            "overwrite": self.overwrite,
        }


#: The flag of each :class:`LabOptions` field.
SPECIMEN_MM = Annotated[
    str | None,
    typer.Option(
        "--specimen",
        help="the specimen's size WIDTHxDEPTHxTHICKNESS, mm (experiment.json's specimen_mm: a fit then looks for "
        "a surrogate of that specimen)",
    ),
]
LAB_FLAGS = {
    "radius": RADIUS,
    "specimen": SPECIMEN_MM,
    "step_size": STEP_SIZE,
    "steps": STEPS,
    "indenter": INDENTER,
    "load_frame": LOAD_FRAME,
    "force_csv": FORCE_CSV,
    "fiber_angle": FIBER,
    "exclude_steps": EXCLUDE,
    "frames": FRAMES,
    "frame_times": FRAME_TIMES,
    "time_offset": TIME_OFFSET,
    "indenter_unit": INDENTER_UNIT,
    "time_col": TIME_COL,
    "position_col": POSITION_COL,
    "force_col": FORCE_COL,
    "time_unit": TIME_UNIT,
    "position_unit": POSITION_UNIT,
    "force_unit": FORCE_UNIT,
    "contact_position": CONTACT,
    "min_hold": MIN_HOLD,
    "description": DESCRIPTION,
    "overwrite": OVERWRITE,
    "encoding": ENCODING,
    "delimiter": DELIMITER,
    "decimal": DECIMAL,
}
#: The flags of the load-frame record alone (``import load-frame``).
RECORD_FLAGS = (
    "radius",
    "step_size",
    "steps",
    "exclude_steps",
    "time_col",
    "position_col",
    "force_col",
    "time_unit",
    "position_unit",
    "force_unit",
    "contact_position",
    "min_hold",
    "encoding",
    "delimiter",
    "decimal",
)


def lab_options(*flags: str, **values: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Give an import command the lab flags ``flags`` (none: all) in place of its ``lab: LabOptions``
    parameter (:func:`studio.options.option_group`); ``values``: flag defaults, as there.

    Parameters
    ----------
    *flags : str
        The :class:`LabOptions` fields the command has flags for.
    **values
        A flag's default, or the value of a field without a flag.

    Returns
    -------
    Callable
        The decorator.
    """
    return option_group(LabOptions, LAB_FLAGS, "lab", flags, values)
