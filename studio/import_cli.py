"""``indent-studio import matchid | duodic | csv | load-frame | febio`` and ``indent-studio check``: a lab's
files into the experiment format, and the data check before any fit. Each command parses its
options, calls one library function (inference/lab/experiment_import.py, studio/check_report.py) and
prints one JSON object with ``--json``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ..atomic_write import strict_json
from .options import JSON, err, fail

import_app = typer.Typer(help="Import a lab's files (DIC export, load-frame record) as an experiment folder.")

OUT = Annotated[
    Path, typer.Option(help="the experiment folder to write (refused if it exists, unless --overwrite)")
]
RADIUS = Annotated[float, typer.Option(help="indenter sphere radius, mm")]
STEP_SIZE = Annotated[float, typer.Option(help="depth per step, mm")]
STEPS = Annotated[int, typer.Option(help="number of indentation steps (holds)")]
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
OVERWRITE = Annotated[bool, typer.Option(help="replace an existing experiment folder")]
DESCRIPTION = Annotated[str, typer.Option(help="free text for experiment.json")]
ENCODING = Annotated[
    str | None,
    typer.Option(help="text encoding of the CSV files, e.g. cp1252 (default: UTF-8, else detected)"),
]


def csv_encoding(encoding: str | None):
    """The block's CSV files read as ``encoding`` (:func:`inference.lab.csv_text.csv_encoding`)."""
    from ..inference.lab.csv_text import csv_encoding as block

    return block(encoding)


def _offset(text: str) -> float | None:
    if text.strip().lower() == "auto":
        return None
    try:
        return float(text)
    except ValueError as exc:
        raise ValueError(f"--time-offset: {text!r} is neither a number of seconds nor 'auto'") from exc


def _steps(text: str) -> tuple[int, ...]:
    try:
        return tuple(sorted({int(v) for v in text.split(",") if v.strip()}))
    except ValueError as exc:
        raise ValueError(f"--exclude-steps: {text!r} is not a list of steps like 3,7") from exc


def _sources(o: dict):
    """The protocol, force, indenter and frame choice of the import commands' common options."""
    from ..inference.lab.experiment_import import (
        ForceSource,
        FrameChoice,
        IndenterSource,
        ProtocolInfo,
        parse_frames,
    )
    from ..inference.lab.load_frame import LoadFrameColumns

    protocol = ProtocolInfo(
        o["radius"],
        o["step_size"],
        o["steps"],
        o["fiber_angle"],
        o["description"],
        _steps(o["exclude_steps"]),
    )
    columns = LoadFrameColumns(
        o["time_col"], o["position_col"], o["force_col"], o["time_unit"], o["position_unit"], o["force_unit"]
    )
    force = ForceSource(
        load_frame=o["load_frame"],
        columns=columns,
        contact_position_mm=o["contact_position"],
        min_hold_s=o["min_hold"],
        force_csv=o["force_csv"],
    )
    frames = FrameChoice(
        frames=parse_frames(o["frames"]) if o["frames"] else None,
        times_file=o["frame_times"],
        time_offset_s=_offset(o["time_offset"]),
    )
    return protocol, force, IndenterSource(o["indenter"], o["indenter_unit"]), frames


def _report(result: dict, as_json: bool) -> None:
    if as_json:
        print(strict_json(result))
    else:
        err.print(
            f"[green]wrote[/] {result.get('experiment') or result.get('force_csv') or result.get('report')}"
        )
        for line in result.get("warnings", []):
            err.print(f"[yellow]warning:[/] {line}")


@import_app.command("matchid")
def import_matchid_command(
    dic: Annotated[Path, typer.Option(help="folder of MatchID CSV exports, one per image")],
    out: OUT,
    radius: RADIUS,
    step_size: STEP_SIZE,
    steps: STEPS,
    indenter: INDENTER,
    load_frame: LOAD_FRAME = None,
    force_csv: FORCE_CSV = None,
    fiber_angle: FIBER = None,
    exclude_steps: EXCLUDE = "",
    frames: FRAMES = None,
    frame_times: FRAME_TIMES = None,
    time_offset: TIME_OFFSET = "auto",
    length_unit: LENGTH_UNIT = None,
    max_sigma: Annotated[
        float | None, typer.Option(help="drop points whose stats.Sigma exceeds this, mm")
    ] = None,
    indenter_unit: INDENTER_UNIT = None,
    time_col: TIME_COL = None,
    position_col: POSITION_COL = None,
    force_col: FORCE_COL = None,
    time_unit: TIME_UNIT = None,
    position_unit: POSITION_UNIT = None,
    force_unit: FORCE_UNIT = None,
    contact_position: CONTACT = None,
    min_hold: MIN_HOLD = 5.0,
    description: DESCRIPTION = "",
    overwrite: OVERWRITE = False,
    encoding: ENCODING = None,
    as_json: JSON = False,
) -> None:
    """A MatchID export folder (+ load-frame record, indenter points) into an experiment folder."""
    from ..inference.lab.experiment_import import import_matchid

    try:
        with csv_encoding(encoding):
            protocol, force, ind, choice = _sources(locals())
            result = import_matchid(
                dic,
                out,
                protocol=protocol,
                force=force,
                indenter=ind,
                frames=choice,
                length_unit=length_unit,
                max_sigma=max_sigma,
                overwrite=overwrite,
            )
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(result.to_dict(), as_json)


@import_app.command("duodic")
def import_duodic_command(
    mat: Annotated[Path, typer.Option(help="DuoDIC results (DIC3DPPresults.mat), MATLAB v7 or v7.3")],
    out: OUT,
    radius: RADIUS,
    step_size: STEP_SIZE,
    steps: STEPS,
    indenter: INDENTER,
    length_unit: Annotated[
        str, typer.Option(help="the calibration target's length unit (DuoDIC stores none)")
    ],
    load_frame: LOAD_FRAME = None,
    force_csv: FORCE_CSV = None,
    fiber_angle: FIBER = None,
    exclude_steps: EXCLUDE = "",
    frames: FRAMES = None,
    frame_times: FRAME_TIMES = None,
    time_offset: TIME_OFFSET = "auto",
    max_corr: Annotated[float | None, typer.Option(help="drop points whose corrComb exceeds this")] = None,
    rigid_body_removed: Annotated[bool, typer.Option(help="use Disp.DispVec_ARBM")] = False,
    variable: Annotated[str | None, typer.Option(help="the structure's name in the file")] = None,
    indenter_unit: INDENTER_UNIT = None,
    time_col: TIME_COL = None,
    position_col: POSITION_COL = None,
    force_col: FORCE_COL = None,
    time_unit: TIME_UNIT = None,
    position_unit: POSITION_UNIT = None,
    force_unit: FORCE_UNIT = None,
    contact_position: CONTACT = None,
    min_hold: MIN_HOLD = 5.0,
    description: DESCRIPTION = "",
    overwrite: OVERWRITE = False,
    encoding: ENCODING = None,
    as_json: JSON = False,
) -> None:
    """DuoDIC results (+ load-frame record, indenter points) into an experiment folder."""
    from ..inference.lab.experiment_import import import_duodic

    try:
        with csv_encoding(encoding):
            protocol, force, ind, choice = _sources(locals())
            result = import_duodic(
                mat,
                out,
                protocol=protocol,
                force=force,
                indenter=ind,
                length_unit=length_unit,
                frames=choice,
                max_corr=max_corr,
                rigid_body_removed=rigid_body_removed,
                variable=variable,
                overwrite=overwrite,
            )
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(result.to_dict(), as_json)


@import_app.command("csv")
def import_csv_command(
    dic: Annotated[Path, typer.Option(help="folder of per-frame CSVs, or one CSV with a frame column")],
    columns: Annotated[
        str,
        typer.Option(help="mapping, e.g. x=X,y=Y,z=Z,ux=U,uy=V,uz=W,sigma=sigma (id=a+b; frame=..; time=..)"),
    ],
    out: OUT,
    radius: RADIUS,
    step_size: STEP_SIZE,
    steps: STEPS,
    indenter: INDENTER,
    positions: Annotated[
        str, typer.Option(help="x, y, z are the 'reference' or the 'current' positions")
    ] = "reference",
    pattern: Annotated[str, typer.Option(help="file pattern in the folder")] = "*.csv",
    load_frame: LOAD_FRAME = None,
    force_csv: FORCE_CSV = None,
    fiber_angle: FIBER = None,
    exclude_steps: EXCLUDE = "",
    frames: FRAMES = None,
    frame_times: FRAME_TIMES = None,
    time_offset: TIME_OFFSET = "auto",
    length_unit: LENGTH_UNIT = None,
    max_sigma: Annotated[float | None, typer.Option(help="drop points whose sigma exceeds this")] = None,
    indenter_unit: INDENTER_UNIT = None,
    time_col: TIME_COL = None,
    position_col: POSITION_COL = None,
    force_col: FORCE_COL = None,
    time_unit: TIME_UNIT = None,
    position_unit: POSITION_UNIT = None,
    force_unit: FORCE_UNIT = None,
    contact_position: CONTACT = None,
    min_hold: MIN_HOLD = 5.0,
    description: DESCRIPTION = "",
    overwrite: OVERWRITE = False,
    encoding: ENCODING = None,
    as_json: JSON = False,
) -> None:
    """Any DIC CSV export (VIC-3D, GOM, Ncorr) with a column mapping into an experiment folder."""
    from ..inference.lab.experiment_import import import_dic_csv
    from ..inference.lab.import_csv import CSVMapping

    try:
        with csv_encoding(encoding):
            mapping = CSVMapping.parse(columns, positions=positions, length_unit=length_unit)
            protocol, force, ind, choice = _sources(locals())
            result = import_dic_csv(
                dic,
                mapping,
                out,
                protocol=protocol,
                force=force,
                indenter=ind,
                frames=choice,
                pattern=pattern,
                max_sigma=max_sigma,
                overwrite=overwrite,
            )
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(result.to_dict(), as_json)


@import_app.command("load-frame")
def import_load_frame_command(
    record: Annotated[Path, typer.Option(help="the load frame's continuous record (CSV)")],
    out: Annotated[Path, typer.Option(help="force.csv to write (hold form)")],
    radius: RADIUS,
    step_size: STEP_SIZE,
    steps: STEPS,
    exclude_steps: EXCLUDE = "",
    time_col: TIME_COL = None,
    position_col: POSITION_COL = None,
    force_col: FORCE_COL = None,
    time_unit: TIME_UNIT = None,
    position_unit: POSITION_UNIT = None,
    force_unit: FORCE_UNIT = None,
    contact_position: CONTACT = None,
    min_hold: MIN_HOLD = 5.0,
    encoding: ENCODING = None,
    as_json: JSON = False,
) -> None:
    """Cut a load-frame record into the protocol's holds (one per step, eq. 9 fit each) as force.csv."""
    from ..inference.lab.experiment_import import ForceSource, ProtocolInfo, import_load_frame
    from ..inference.lab.load_frame import LoadFrameColumns

    try:
        with csv_encoding(encoding):
            protocol = ProtocolInfo(radius, step_size, steps, excluded_steps=_steps(exclude_steps))
            columns = LoadFrameColumns(
                time_col, position_col, force_col, time_unit, position_unit, force_unit
            )
            result = import_load_frame(
                record,
                out,
                protocol,
                ForceSource(columns=columns, contact_position_mm=contact_position, min_hold_s=min_hold),
            )
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report(result, as_json)


@import_app.command("febio")
def import_febio_command(
    log: Annotated[Path, typer.Option(help="the FEBio 4 run's log file (its material echoed in it)")],
    out: OUT,
    feb: Annotated[Path | None, typer.Option(help="the run's .feb (default: beside the log)")] = None,
    radius: Annotated[float, typer.Option(help="the run's indenter radius, mm")] = 4.77,
    steps: Annotated[int, typer.Option(help="the run's number of steps")] = 28,
    step_size: Annotated[float, typer.Option(help="the run's depth per step, mm")] = 0.5,
    dic_noise: Annotated[float, typer.Option(help="DIC displacement noise (sd), mm")] = 0.02,
    force_noise: Annotated[float, typer.Option(help="force noise (sd) relative to the force")] = 0.02,
    misregistration: Annotated[
        float, typer.Option(help="registration error of the indentation point, mm")
    ] = 0.1,
    fov: Annotated[float, typer.Option(help="DIC field of view (radius from the indenter), mm")] = 25.0,
    points: Annotated[int, typer.Option(help="DIC points over the field of view")] = 6000,
    fiber_angle: Annotated[float, typer.Option(help="fiber direction in the DIC frame, degrees")] = 60.0,
    seed: Annotated[int, typer.Option(help="random seed of the noise and the DIC points")] = 0,
    overwrite: OVERWRITE = False,
    as_json: JSON = False,
) -> None:
    """A real FEBio run as a DIC-like experiment: its force and top-node field seen by DIC points
    (the indenter's shadow, noise, a registration error); steps FEBio accepted off equilibrium left
    out. For checking a fit against a solver the studio shares no code with."""
    from ..forward.febio.log import FebioLogError
    from ..forward.febio.readback import FebioRunError
    from ..inference.febio_experiment import experiment_from_febio_run

    try:
        path = experiment_from_febio_run(
            log,
            out,
            feb_file=feb,
            radius=radius,
            steps=steps,
            step_size=step_size,
            u_noise_mm=dic_noise,
            f_noise=force_noise,
            misregistration_mm=misregistration,
            fov=fov,
            points=points,
            fiber_angle_deg=fiber_angle,
            seed=seed,
            overwrite=overwrite,
        )
    except (FebioLogError, FebioRunError, ValueError, OSError) as exc:
        fail(str(exc), as_json)
    meta = json.loads((path / "experiment.json").read_text())
    src = meta["synthetic"]["source"]
    result = {
        "experiment": str(path),
        "theta": [src["c1"], src["c5"]],
        "excluded_steps": meta.get("excluded_steps", []),
        "off_equilibrium_depths_mm": src["off_equilibrium_depths_mm"],
        "warnings": [f"steps FEBio accepted off equilibrium left out: {meta['excluded_steps']}"]
        if meta.get("excluded_steps")
        else [],
    }
    _report(result, as_json)


def register(app: typer.Typer) -> None:
    """Add ``import ...`` and ``check`` to the studio's CLI."""
    app.add_typer(import_app, name="import")

    @app.command("check")
    def check(
        experiment: Annotated[Path, typer.Option(help="experiment folder")],
        out: Annotated[Path | None, typer.Option(help="report folder (default <experiment>/check)")] = None,
        mesh: Annotated[
            str, typer.Option(help="mesh preset whose top nodes are matched to the DIC data")
        ] = "default",
        as_json: JSON = False,
    ) -> None:
        """The data check before any fit: holds and their eq. 9 fits, DIC coverage, sphere fit,
        registration, nodes obscured, DIC noise and warnings with numbers (HTML + PNGs)."""
        from .check_report import write_check_report

        try:
            result = write_check_report(experiment, out, mesh)
        except (ValueError, OSError) as exc:
            fail(str(exc), as_json)
        _report(result, as_json)
