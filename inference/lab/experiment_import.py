"""A lab's files into the studio's experiment folder (:mod:`.experiment_data`): a DIC export
(MatchID, DuoDIC or a mapped CSV), the force (the load frame's continuous record, cut into holds,
or a force.csv already in hold form), the indenter's tracked points and the protocol.

The folder is built beside its destination, validated by :func:`load_experiment`, and only then
moved into place: a failed import leaves nothing behind (and an existing folder untouched).
Every file goes through :func:`atomic_write`. ``experiment.json`` records where each part came
from: the source, the frame of every step, every hold's rows and eq. 9 fit.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from ...atomic_write import atomic_write
from ..experiment.data import ExperimentDataError
from ..experiment.folder import write_experiment_folder
from .clock_offset import ClockOffset, find_clock_offset, indentation_signal
from .dic_series import DICSeries, frames_by_list, frames_by_time
from .duodic_results import read_duodic
from .import_csv import read_dic_csv
from .import_sources import ForceSource as ForceSource  # X as X: re-exported
from .import_sources import FrameChoice, ImportResult, IndenterSource, ProtocolInfo, read_indenter_points
from .import_sources import parse_frames as parse_frames
from .load_frame import find_holds, hold_force_table, read_load_frame
from .matchid_export import read_matchid
from .table_columns import find_column, numeric_column, read_table
from .units import resolve_unit


def _frame_times(dic: DICSeries, choice: FrameChoice) -> np.ndarray | None:
    if choice.times_s is not None:
        return np.asarray(choice.times_s, float)
    if choice.times_file is None:
        return dic.times_s
    path = Path(choice.times_file)
    table = read_table(path)
    fcol = next((c for c in table.columns if c.lower().startswith(("frame", "image"))), None)
    tcol = next((c for c in table.columns if c.lower().startswith("time")), None)
    if fcol is None or tcol is None:
        raise ExperimentDataError(f"{path}: needs a frame (or image) column and a time column")
    frames = numeric_column(table, fcol, path, False).astype(int)
    times = numeric_column(table, tcol, path, False) * resolve_unit(tcol, choice.time_unit, "time", str(path))
    lookup = dict(zip(frames.tolist(), times.tolist(), strict=True))
    missing = [int(f) for f in dic.frame_ids if int(f) not in lookup]
    if missing:
        raise ExperimentDataError(f"{path}: no time for frame(s) {', '.join(map(str, missing[:10]))}")
    return np.array([lookup[int(f)] for f in dic.frame_ids])


def _forces(
    protocol: ProtocolInfo, source: ForceSource
) -> tuple[pd.DataFrame, np.ndarray | None, list, float, dict]:
    """The hold readings (step, time_s, force_mN), the hold windows on the record's clock (or None)
    the holds as dicts, the tare and what the record said of the contact point and the drift."""
    if (source.load_frame is None) == (source.force_csv is None):
        raise ExperimentDataError(
            "give the force as either a load-frame record or a force.csv, not both or neither"
        )
    if source.force_csv is not None:
        path = Path(source.force_csv)
        table = read_table(path)
        columns = {c: find_column(table, c, path) for c in ("step", "time_s", "force_mN")}
        return table.rename(columns={v: k for k, v in columns.items()}), None, [], 0.0, {}
    record = read_load_frame(source.load_frame, source.columns)
    search = find_holds(
        record,
        protocol.step_size_mm,
        protocol.steps,
        protocol.radius_mm,
        contact_position_mm=source.contact_position_mm,
        position_sign=source.position_sign,
        force_sign=source.force_sign,
        level_tol=source.level_tol,
        min_hold_s=source.min_hold_s,
        tare=source.tare,
        excluded_steps=protocol.excluded_steps,
    )
    windows = np.full((protocol.steps, 2), np.nan)  # a missing (excluded) step's hold stays NaN
    for h in search.holds:
        windows[h.step - 1] = (h.start_s, h.end_s)
    info = {
        "contact_position_mm": search.contact_position_mm,
        "contact_from": search.contact_from,
        "drift_mN_per_s": search.drift_mN_per_s,
        "notes": list(record.notes) + list(search.notes),
        "_track": (record.time_s, search.position_sign * (record.position_mm - search.contact_position_mm)),
    }
    return (
        hold_force_table(record, search),
        windows,
        [h.to_dict() for h in search.holds],
        search.tare_mN,
        info,
    )


def import_experiment(
    dic: DICSeries,
    out_dir: str | Path,
    *,
    protocol: ProtocolInfo,
    force: ForceSource,
    indenter: IndenterSource,
    frames: FrameChoice = FrameChoice(),
    overwrite: bool = False,
    source_format: str = "",
) -> ImportResult:
    """Assemble and write an experiment folder from a read DIC export (module docstring).

    The folder is built beside its destination, validated by :func:`load_experiment`, and only
    then moved into place.

    Parameters
    ----------
    dic : DICSeries
        The DIC export, read.
    out_dir : str or pathlib.Path
        The experiment folder to write.
    protocol : ProtocolInfo
        The indenter's radius, the step size and count (mm), the fiber direction.
    force : ForceSource
        The load frame's record or a ``force.csv`` in hold form.
    indenter : IndenterSource
        The indenter's tracked points.
    frames : FrameChoice, optional
        The DIC frame of each step (by number, or by time).
    overwrite : bool, default False
        Replace an experiment folder already there.
    source_format : str, default ""
        The export's format, recorded in experiment.json.

    Returns
    -------
    ImportResult
        The folder, the source, points and frames per step, the holds and the tare.

    Raises
    ------
    ExperimentDataError
        If the parts do not make a valid experiment (naming what is wrong), or the folder exists.
    """
    table, windows, holds, tare, record_info = _forces(protocol, force)
    track = record_info.pop("_track", None)
    clock = None
    if frames.frames is not None:
        index = frames_by_list(dic, frames.frames, protocol.steps)
    elif windows is not None:
        times = _frame_times(dic, frames)
        if times is None:
            raise ExperimentDataError(
                f"{dic.source}: the export has no frame times; give them (--frame-times), or name the frame of every step (--frames)"
            )
        if frames.time_offset_s is None:
            clock = find_clock_offset(times, indentation_signal(dic), *track, windows)
        else:
            given = frames.time_offset_s
            clock = ClockOffset(given, given, given, np.nan, np.nan, np.nan, "given")
        index = frames_by_time(dic, windows, clock.offset_s, times)
    else:
        raise ExperimentDataError(
            "name the DIC frame of every step (frames), or give the load-frame record so that frames are matched "
            "to its holds by time"
        )
    u = np.where((index >= 0)[:, None, None], dic.u[index], np.nan)
    seen = np.isfinite(u).all(axis=2).any(axis=0)
    xyz, u = dic.xyz[seen], u[:, seen]
    indenter_xyz = read_indenter_points(indenter)
    frame_ids = [int(dic.frame_ids[i]) if i >= 0 else None for i in index]
    meta = {
        "radius_mm": protocol.radius_mm,
        "step_size_mm": protocol.step_size_mm,
        "steps": protocol.steps,
        "fiber_angle_deg": protocol.fiber_angle_deg,
        "excluded_steps": sorted(protocol.excluded_steps),
        "description": protocol.description,
        **({} if protocol.specimen_mm is None else {"specimen_mm": dict(protocol.specimen_mm)}),
        "imported": {
            "format": source_format,
            "dic_source": dic.source,
            "frames": {str(k + 1): f for k, f in enumerate(frame_ids)},
            "force_source": str(force.load_frame or force.force_csv),
            "holds": holds,
            "tare_mN": tare,
            "load_frame": record_info,
            "clock_offset": None if clock is None else clock.to_dict(),
            "indenter_source": str(indenter.path),
            "notes": dic.notes,
        },
    }
    out = write_experiment_folder(Path(out_dir), meta, table, xyz, u, indenter_xyz, overwrite=overwrite)
    return ImportResult(
        out,
        dic.source,
        points=len(xyz),
        frames=frame_ids,
        points_per_step=np.isfinite(u).all(axis=2).sum(axis=1).tolist(),
        indenter_points=len(indenter_xyz),
        holds=holds,
        tare_mN=tare,
        notes=list(dic.notes)
        + record_info.get("notes", [])
        + ([clock.describe()] if clock is not None else []),
    )


def import_matchid(
    folder: str | Path,
    out_dir: str | Path,
    *,
    protocol: ProtocolInfo,
    force: ForceSource,
    indenter: IndenterSource,
    frames: FrameChoice = FrameChoice(),
    length_unit: str | None = None,
    max_sigma: float | None = None,
    overwrite: bool = False,
) -> ImportResult:
    """Import a MatchID export folder (:mod:`.matchid_export`) into an experiment folder.

    Parameters
    ----------
    folder : str or pathlib.Path
        The MatchID CSV exports, one per image.
    out_dir : str or pathlib.Path
        The experiment folder to write.
    protocol, force, indenter, frames, overwrite
        As :func:`import_experiment`.
    length_unit : str, optional
        The export's length unit (default: read from it).
    max_sigma : float, optional
        Drop points whose ``stats.Sigma`` is larger, mm.

    Returns
    -------
    ImportResult
        As :func:`import_experiment`.
    """
    dic = read_matchid(folder, length_unit, max_sigma=max_sigma, allow_gaps=frames.frames is not None)
    return import_experiment(
        dic,
        out_dir,
        protocol=protocol,
        force=force,
        indenter=indenter,
        frames=frames,
        overwrite=overwrite,
        source_format="MatchID CSV",
    )


def import_duodic(
    path: str | Path,
    out_dir: str | Path,
    *,
    protocol: ProtocolInfo,
    force: ForceSource,
    indenter: IndenterSource,
    length_unit: str,
    frames: FrameChoice = FrameChoice(),
    max_corr: float | None = None,
    rigid_body_removed: bool = False,
    variable: str | None = None,
    overwrite: bool = False,
) -> ImportResult:
    """Import a DuoDIC results .mat (:mod:`.duodic_results`) into an experiment folder.

    Parameters
    ----------
    path : str or pathlib.Path
        The DuoDIC results file.
    out_dir : str or pathlib.Path
        The experiment folder to write.
    protocol, force, indenter, frames, overwrite
        As :func:`import_experiment`.
    length_unit : str
        The results' length unit.
    max_corr : float, optional
        Drop points whose combined correlation coefficient is larger.
    rigid_body_removed : bool, default False
        Use the displacements with rigid body motion removed (``DispVec_ARBM``).
    variable : str, optional
        The MATLAB variable holding the results.

    Returns
    -------
    ImportResult
        As :func:`import_experiment`.
    """
    dic = read_duodic(path, length_unit, variable, max_corr, rigid_body_removed)
    return import_experiment(
        dic,
        out_dir,
        protocol=protocol,
        force=force,
        indenter=indenter,
        frames=frames,
        overwrite=overwrite,
        source_format="DuoDIC .mat",
    )


def import_dic_csv(
    source: str | Path,
    mapping,
    out_dir: str | Path,
    *,
    protocol: ProtocolInfo,
    force: ForceSource,
    indenter: IndenterSource,
    frames: FrameChoice = FrameChoice(),
    pattern: str = "*.csv",
    max_sigma: float | None = None,
    overwrite: bool = False,
) -> ImportResult:
    """Import a mapped DIC CSV export (:mod:`.import_csv`) into an experiment folder.

    Parameters
    ----------
    source : str or pathlib.Path
        A folder of per-frame CSVs, or one long CSV with a ``frame`` column.
    mapping : CSVMapping
        Which columns hold what, and their units.
    out_dir : str or pathlib.Path
        The experiment folder to write.
    protocol, force, indenter, frames, overwrite
        As :func:`import_experiment`.
    pattern : str, default "*.csv"
        The per-frame files in a folder.
    max_sigma : float, optional
        Drop points whose uncertainty is larger, mm.

    Returns
    -------
    ImportResult
        As :func:`import_experiment`.
    """
    dic = read_dic_csv(source, mapping, pattern, max_sigma, allow_gaps=frames.frames is not None)
    return import_experiment(
        dic,
        out_dir,
        protocol=protocol,
        force=force,
        indenter=indenter,
        frames=frames,
        overwrite=overwrite,
        source_format="mapped CSV",
    )


def import_load_frame(
    record: str | Path, out_csv: str | Path, protocol: ProtocolInfo, force: ForceSource = ForceSource()
) -> dict:
    """Cut the load frame's record into the protocol's holds and write them as a ``force.csv``.

    Parameters
    ----------
    record : str or pathlib.Path
        The load frame's continuous record.
    out_csv : str or pathlib.Path
        The ``force.csv`` to write, in the format's hold form.
    protocol : ProtocolInfo
        The step size and count.
    force : ForceSource, optional
        The record's columns and units, and how holds are found.

    Returns
    -------
    dict
        The holds (rows, times, depth, eq. 9 fit) and the tare.
    """
    source = replace(force, load_frame=Path(record), force_csv=None)
    table, _, holds, tare, info = _forces(protocol, source)
    info.pop("_track", None)
    atomic_write(Path(out_csv), table.to_csv(index=False))
    return {"force_csv": str(out_csv), "holds": holds, "tare_mN": tare, "readings": len(table), **info}
