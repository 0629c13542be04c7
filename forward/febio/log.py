"""Read a FEBio 4 logfile into the studio's result schema.

FEBio writes a ``Data Record`` block per logfile request after every converged increment; the
writer (:mod:`forward.febio.writer`) asks for the top-surface displacements ``ux;uy;uz``, the
rigid indenter's ``z;Fx;Fy;Fz`` and the bottom reactions ``Rz``. Only the must points are kept:
the whole times 0, 1, ..., steps (one time unit per indentation step). The quarter model's
indentation force is ``-Fz`` (FEBio's rigid-body reaction is negative while the sphere pushes
down); the whole specimen's is 4 times that. Every step is checked for equilibrium against the
bottom reactions (:mod:`forward.febio.equilibrium`): a step FEBio accepted off equilibrium is
flagged and its force is NaN.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..mesh import build_mesh
from ..result import SYMMETRY_FACTOR, SimulationResult
from ..spec import ModelSpec
from .equilibrium import (
    BOTTOM_KEY,
    DEFAULT_EQUILIBRIUM_TOLERANCE,
    EquilibriumTolerance,
    check_equilibrium,
)
from .writer import BOTTOM_DATA, INDENTER_DATA, TOP_DATA

NORMAL_TERMINATION = "N O R M A L   T E R M I N A T I O N"
ERROR_TERMINATION = "E R R O R   T E R M I N A T I O N"

_RECORD = re.compile(
    r"^Data Record #\d+\s*\n=+\s*\nStep = (\d+)\s*\nTime = (\S+)\s*\nData = (.+?)\s*\n", re.M
)
_NUMERIC_LINES = re.compile(r"(?:[ \t]*[-+0-9.eEinfaINFA][-+0-9.eEinfaINFA \t]*\n)*")
_CONVERGED = re.compile(r"^------- converged at time : (\S+)", re.M)
_FAILED = re.compile(r"^------- failed to converge at time : (\S+)", re.M)
_ITERATIONS = re.compile(r"number of iterations\s*:\s*(\d+)")
_VERSION = re.compile(r"^\s*version (\d+\.\d+[\w.]*)", re.M)


class FebioLogError(ValueError):
    """A FEBio logfile that cannot be read; the message names the file and the problem."""


@dataclass
class FebioLog:
    """Everything read from one logfile: per data name, the records in time order."""

    path: Path
    version: str | None
    terminated: str  # "normal", "error" or "unfinished"
    times: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (r,)
    ids: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (rows,) first column
    values: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (r, rows, cols)
    converged_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    iterations: np.ndarray = field(default_factory=lambda: np.zeros(0, int))  # per converged increment
    failed_attempts: int = 0
    tail: str = ""

    def last_lines(self, n: int = 12) -> str:
        return "\n".join(self.tail.rstrip().splitlines()[-n:])


def read_febio_log(path: str | Path) -> FebioLog:
    """Parse every data record, the convergence history and the termination of a logfile."""
    path = Path(path)
    try:
        text = path.read_text(encoding="latin-1")
    except OSError as exc:
        raise FebioLogError(f"{path}: cannot read the FEBio log ({exc})") from exc
    if NORMAL_TERMINATION in text:
        terminated = "normal"
    elif ERROR_TERMINATION in text:
        terminated = "error"
    else:
        terminated = "unfinished"
    version = _VERSION.search(text)

    times: dict[str, list[float]] = {}
    ids: dict[str, np.ndarray] = {}
    rows: dict[str, list[np.ndarray]] = {}
    matches = list(_RECORD.finditer(text))
    for m in matches:
        name, t = m.group(3), float(m.group(2))
        block = _NUMERIC_LINES.match(text, m.end())
        block = block.group(0).strip() if block else ""
        try:
            table = np.array([[float(v) for v in line.split()] for line in block.splitlines()], ndmin=2)
        except ValueError as exc:
            raise FebioLogError(f"{path}: malformed data record {name!r} at time {t:g} ({exc})") from exc
        if table.size == 0 or table.shape[1] < 2:
            raise FebioLogError(f"{path}: empty data record {name!r} at time {t:g}")
        if name in ids and (len(table) != len(ids[name]) or np.any(table[:, 0] != ids[name])):
            raise FebioLogError(f"{path}: record {name!r} at time {t:g} lists other items than before")
        ids.setdefault(name, table[:, 0].astype(np.int64))
        times.setdefault(name, []).append(t)
        rows.setdefault(name, []).append(table[:, 1:])

    converged = [float(v) for v in _CONVERGED.findall(text)]
    iterations = [int(v) for v in _ITERATIONS.findall(text)]
    return FebioLog(
        path=path,
        version=version.group(1) if version else None,
        terminated=terminated,
        times={k: np.array(v) for k, v in times.items()},
        ids=ids,
        values={k: np.stack(v) for k, v in rows.items()},
        converged_times=np.array(converged),
        iterations=np.array(iterations[-len(converged) :] if converged else [], dtype=np.int64),
        failed_attempts=len(_FAILED.findall(text)),
        tail=text[-4000:],
    )


def must_point_rows(times: np.ndarray, steps: int | None, tol: float = 1e-6) -> np.ndarray:
    """Indices of the records at the whole times 0, 1, ..., steps (the must points).

    A time that appears twice (FEBio re-reports after a restart) keeps its last record.
    """
    whole = np.abs(times - np.round(times)) < tol
    if steps is not None:
        whole &= np.round(times) <= steps
    picked: dict[int, int] = {}
    for i in np.nonzero(whole)[0]:
        picked[round(float(times[i]))] = int(i)
    return np.array([picked[k] for k in sorted(picked)], dtype=np.int64)


def depth_reached(log: FebioLog) -> float:
    """The indentation depth of the last converged increment, mm (rigid body z below its start)."""
    if INDENTER_DATA not in log.values:
        return 0.0
    z = log.values[INDENTER_DATA][:, 0, 0]
    return float(z[0] - z[-1])


def febio_result(
    log: FebioLog,
    spec: dict[str, Any] | None = None,
    feb_file: str | Path | None = None,
    steps: int | None = None,
    wall_s: float = 0.0,
    tolerance: EquilibriumTolerance = DEFAULT_EQUILIBRIUM_TOLERANCE,
) -> SimulationResult:
    """The must-point records of ``log`` as a :class:`SimulationResult` (depth 0 first).

    Steps off equilibrium by ``tolerance`` (:func:`forward.febio.equilibrium.check_equilibrium`)
    are flagged in ``off_equilibrium`` and their forces are NaN. Raises :class:`FebioLogError`
    when the log lacks the writer's data requests.
    """
    for name in (TOP_DATA, INDENTER_DATA):
        if name not in log.values:
            raise FebioLogError(f"{log.path}: no {name!r} data records (was it written by export-feb?)")
    t_body = log.times[INDENTER_DATA]
    rows = must_point_rows(t_body, steps)
    if len(rows) == 0 or abs(t_body[rows[0]]) > 1e-9:
        raise FebioLogError(f"{log.path}: no record at time 0")
    t_top = log.times[TOP_DATA]
    top_rows = must_point_rows(t_top, steps)
    if not np.array_equal(np.round(t_top[top_rows]), np.round(t_body[rows])):
        raise FebioLogError(f"{log.path}: {TOP_DATA!r} and {INDENTER_DATA!r} records are at different times")
    body = log.values[INDENTER_DATA][rows, 0, :]  # z, Fx, Fy, Fz
    force_quarter = -body[:, 3]
    depth_from_z = body[0, 0] - body[:, 0]
    step_size = (spec or {}).get("protocol", {}).get("step_size")
    # nominal depths (time x step size) when the spec is known; the rigid body's own z otherwise
    depth = np.round(t_body[rows]) * step_size if step_size else depth_from_z
    convergence: dict[str, np.ndarray] = {"time": t_body[rows], "depth_from_z": depth_from_z}
    if len(log.converged_times):
        # equilibrium iterations of all increments that ended at or before each must point
        ends = np.searchsorted(log.converged_times, t_body[rows] + 1e-9)
        cum = np.concatenate([[0], np.cumsum(log.iterations)])
        convergence["newton_iterations"] = np.diff(np.concatenate([[0], cum[ends]]))
    if BOTTOM_DATA in log.values:
        b_rows = must_point_rows(log.times[BOTTOM_DATA], steps)
        if np.array_equal(np.round(log.times[BOTTOM_DATA][b_rows]), np.round(t_body[rows])):
            convergence[BOTTOM_KEY] = log.values[BOTTOM_DATA][b_rows, :, 0].sum(axis=1)
    top_xyz = np.full((len(log.ids[TOP_DATA]), 3), np.nan)
    if spec is not None:
        top_xyz = _top_coordinates(spec, log.ids[TOP_DATA], top_xyz)
    raw = SimulationResult(
        depth=depth,
        force=SYMMETRY_FACTOR * force_quarter,
        top_node_ids=log.ids[TOP_DATA],
        top_xyz=top_xyz,
        displacement=log.values[TOP_DATA][top_rows, :, :3],
        spec=spec or {},
        solver={
            "name": "febio",
            "version": log.version,
            "feb_file": str(feb_file) if feb_file else None,
            "log_file": str(log.path),
            "terminated": log.terminated,
            "failed_attempts": log.failed_attempts,
        },
        convergence=convergence,
        wall_s=wall_s,
    )
    return check_equilibrium(raw, tolerance)


def _top_coordinates(spec: dict[str, Any], top_ids: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Reference coordinates of the logged top nodes from the mesh the spec names."""

    mesh = build_mesh(ModelSpec.from_dict(spec))
    where = {int(i): k for k, i in enumerate(mesh.node_ids)}
    try:
        return mesh.nodes[[where[int(i)] for i in top_ids]]
    except KeyError:
        return fallback
