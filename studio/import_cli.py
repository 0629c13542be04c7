"""``indent-studio import matchid | duodic | csv | load-frame | febio`` and ``indent-studio check``: a lab's
files into the experiment format, and the data check before any fit. Each command parses its
options, calls one library function (inference/lab/experiment_import.py, studio/check_report.py) and
prints one JSON object with ``--json``."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import typer

from .. import forward, inference  # lazy: a command imports what it runs
from ..atomic_write import strict_json
from .help_text import first_sentence
from .options import (
    DIC_NOISE,
    EXPERIMENT,
    FORCE_NOISE,
    JSON,
    OVERWRITE,
    RADIUS,
    REQUIRED,
    SEED,
    STEP_SIZE,
    STEPS,
    err,
    fail,
    option_group,
    specimen_geometry,
)

import_app = typer.Typer(help="Import a lab's files (DIC export, load-frame record) as an experiment folder.")

OUT = Annotated[
    Path, typer.Option(help="the experiment folder to write (refused if it exists, unless --overwrite)")
]
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
TIME_OFFSET = Annotated[
    str,
    typer.Option(
        help="added to the DIC frame times to reach the load frame's clock, s; 'auto': found from the data "
        "(the frames' indentation against the stage's depth)"
    ),
]
LENGTH_UNIT = Annotated[
    str | None, typer.Option(help="length unit of the DIC export (if its headers state none)")
]
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


def _report(result: dict, as_json: bool) -> None:
    """What a command wrote and what it noted (what it dropped, found or refused to guess), or the
    check's report, its fiber direction and clock, and a line for each warning."""
    if as_json:
        print(strict_json(result))
        return
    if "report" in result:
        err.print(f"[green]wrote[/] {result['report']} (and check.json, figures beside it)", highlight=False)
        for line in (result.get("fiber_text"), result.get("clock_offset")):
            if line:
                err.print(line, highlight=False, soft_wrap=True)
        warnings = result.get("warnings", [])
        err.print(f"{len(warnings)} warning(s)" + (":" if warnings else ""), highlight=False)
        for line in warnings:
            err.print(f"[yellow]warning:[/] {first_sentence(line, 160)}", highlight=False, soft_wrap=True)
        return
    err.print(f"[green]wrote[/] {result.get('experiment') or result.get('force_csv')}", highlight=False)
    for line in result.get("notes", []):
        err.print(f"note: {line}", highlight=False, soft_wrap=True)
    for line in result.get("warnings", []):
        err.print(f"[yellow]warning:[/] {line}", highlight=False, soft_wrap=True)


MAX_SIGMA = Annotated[float | None, typer.Option(help="drop points whose stats.Sigma exceeds this, mm")]
DUODIC_UNIT = Annotated[str, typer.Option(help="the calibration target's length unit (DuoDIC stores none)")]
MAX_CORR = Annotated[float | None, typer.Option(help="drop points whose corrComb exceeds this")]
RIGID_BODY_REMOVED = Annotated[bool, typer.Option(help="use Disp.DispVec_ARBM")]
VARIABLE = Annotated[str | None, typer.Option(help="the structure's name in the file")]
COLUMNS = Annotated[
    str,
    typer.Option(help="mapping, e.g. x=X,y=Y,z=Z,ux=U,uy=V,uz=W,sigma=sigma (id=a+b; frame=..; time=..)"),
]
POSITIONS = Annotated[str, typer.Option(help="x, y, z are the 'reference' or the 'current' positions")]
PATTERN = Annotated[str, typer.Option(help="file pattern in the folder")]
CSV_MAX_SIGMA = Annotated[float | None, typer.Option(help="drop points whose sigma exceeds this")]


@import_app.command("matchid")
@lab_options(indenter=REQUIRED)
def import_matchid_command(
    dic: Annotated[Path, typer.Option(help="folder of MatchID CSV exports, one per image")],
    out: OUT,
    *,
    lab: LabOptions,
    length_unit: LENGTH_UNIT = None,
    max_sigma: MAX_SIGMA = None,
    as_json: JSON = False,
) -> None:
    """A MatchID export folder (+ load-frame record, indenter points) into an experiment folder."""
    try:
        with lab.csv_reading():
            result = inference.lab.import_matchid(
                dic, out, **lab.sources(), length_unit=length_unit, max_sigma=max_sigma
            )
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(result.to_dict(), as_json)


@import_app.command("duodic")
@lab_options(indenter=REQUIRED)
def import_duodic_command(
    mat: Annotated[Path, typer.Option(help="DuoDIC results (DIC3DPPresults.mat), MATLAB v7 or v7.3")],
    out: OUT,
    length_unit: DUODIC_UNIT,
    *,
    lab: LabOptions,
    max_corr: MAX_CORR = None,
    rigid_body_removed: RIGID_BODY_REMOVED = False,
    variable: VARIABLE = None,
    as_json: JSON = False,
) -> None:
    """DuoDIC results (+ load-frame record, indenter points) into an experiment folder."""
    try:
        with lab.csv_reading():
            result = inference.lab.import_duodic(
                mat,
                out,
                **lab.sources(),
                length_unit=length_unit,
                max_corr=max_corr,
                rigid_body_removed=rigid_body_removed,
                variable=variable,
            )
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(result.to_dict(), as_json)


@import_app.command("csv")
@lab_options(indenter=REQUIRED)
def import_csv_command(
    dic: Annotated[Path, typer.Option(help="folder of per-frame CSVs, or one CSV with a frame column")],
    columns: COLUMNS,
    out: OUT,
    *,
    lab: LabOptions,
    positions: POSITIONS = "reference",
    pattern: PATTERN = "*.csv",
    length_unit: LENGTH_UNIT = None,
    max_sigma: CSV_MAX_SIGMA = None,
    as_json: JSON = False,
) -> None:
    """Any DIC CSV export (VIC-3D, GOM, Ncorr) with a column mapping into an experiment folder."""
    try:
        with lab.csv_reading():
            mapping = inference.lab.CSVMapping.parse(columns, positions=positions, length_unit=length_unit)
            result = inference.lab.import_dic_csv(
                dic, mapping, out, **lab.sources(), pattern=pattern, max_sigma=max_sigma
            )
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(result.to_dict(), as_json)


@import_app.command("load-frame")
@lab_options(*RECORD_FLAGS)
def import_load_frame_command(
    record: Annotated[Path, typer.Option(help="the load frame's continuous record (CSV)")],
    out: Annotated[Path, typer.Option(help="force.csv to write (hold form)")],
    *,
    lab: LabOptions,
    as_json: JSON = False,
) -> None:
    """Cut a load-frame record into the protocol's holds (one per step, eq. 9 fit each) as force.csv."""
    try:
        with lab.csv_reading():
            result = inference.lab.import_load_frame(record, out, lab.protocol(), lab.force())
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(result, as_json)


FEBIO_LOG = Annotated[Path, typer.Option(help="the FEBio 4 run's log file (its material echoed in it)")]
FEB = Annotated[Path | None, typer.Option(help="the run's .feb (default: beside the log)")]
MISREGISTRATION = Annotated[float, typer.Option(help="registration error of the indentation point, mm")]
FOV = Annotated[float, typer.Option(help="DIC field of view (radius from the indenter), mm")]
DIC_POINTS = Annotated[int, typer.Option(help="DIC points over the field of view")]
RUN_FIBER = Annotated[float, typer.Option(help="fiber direction in the DIC frame, degrees")]


@import_app.command("febio")
def import_febio_command(
    log: FEBIO_LOG,
    out: OUT,
    feb: FEB = None,
    radius: RADIUS = 4.77,
    steps: STEPS = 28,
    step_size: STEP_SIZE = 0.5,
    dic_noise: DIC_NOISE = 0.02,
    force_noise: FORCE_NOISE = 0.02,
    misregistration: MISREGISTRATION = 0.1,
    fov: FOV = 25.0,
    points: DIC_POINTS = 6000,
    fiber_angle: RUN_FIBER = 60.0,
    seed: SEED = 0,
    overwrite: OVERWRITE = False,
    as_json: JSON = False,
) -> None:
    """A real FEBio run as a DIC-like experiment: its force and top-node field seen by DIC points
    (the indenter's shadow, noise, a registration error); steps FEBio accepted off equilibrium left
    out. For checking a fit against a solver the studio shares no code with."""
    try:
        path = inference.experiment_from_febio_run(
            log,
            out,
            feb_file=feb,
            radius=radius,
            steps=steps,
            step_size=step_size,
            recording=inference.Recording(
                u_noise_mm=dic_noise,
                f_noise=force_noise,
                misregistration_mm=misregistration,
                fov=fov,
                points=points,
                fiber_angle_deg=fiber_angle,
            ),
            seed=seed,
            overwrite=overwrite,
        )
    except (forward.febio.FebioLogError, forward.febio.FebioRunError, ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(inference.febio_experiment_summary(path), as_json)


def register(app: typer.Typer) -> None:
    """Add ``import ...`` and ``check`` to the studio's CLI."""
    app.add_typer(import_app, name="import")

    @app.command("check")
    def check(
        experiment: EXPERIMENT,
        out: Annotated[Path | None, typer.Option(help="report folder (default <experiment>/check)")] = None,
        mesh: Annotated[
            str, typer.Option(help="mesh preset whose top nodes are matched to the DIC data")
        ] = "default",
        delimiter: DELIMITER = None,
        decimal: DECIMAL = None,
        as_json: JSON = False,
    ) -> None:
        """The data check before any fit: holds and their eq. 9 fits, DIC coverage, sphere fit,
        registration, nodes obscured, DIC noise and warnings with numbers (HTML + PNGs)."""
        from .check_report import write_check_report

        try:
            with inference.lab.csv_reading(delimiter=delimiter, decimal=decimal):
                result = write_check_report(experiment, out, mesh)
        except (ValueError, OSError) as exc:
            fail(str(exc), as_json)
        _report(result, as_json)
