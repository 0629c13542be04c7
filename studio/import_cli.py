"""``indent-studio import matchid | duodic | csv | load-frame | febio`` and ``indent-studio check``: a lab's
files into the experiment format, and the data check before any fit. Each command parses its
options, calls one library function (inference/lab/experiment_import.py, studio/check_report.py) and
prints one JSON object with ``--json``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .. import forward, inference  # lazy: a command imports what it runs
from ..atomic_write import strict_json
from .help_text import first_sentence
from .lab_options import DECIMAL, DELIMITER, RECORD_FLAGS, lab_options
from .lab_options import LabOptions as LabOptions  # X as X: re-exported (the commands' annotation)
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
)

import_app = typer.Typer(help="Import a lab's files (DIC export, load-frame record) as an experiment folder.")

OUT = Annotated[
    Path, typer.Option(help="the experiment folder to write (refused if it exists, unless --overwrite)")
]
LENGTH_UNIT = Annotated[
    str | None, typer.Option(help="length unit of the DIC export (if its headers state none)")
]


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
