"""The experiment data format and its validation (paper 2.7, 2.8.1).

An experiment is a folder:

``experiment.json``
    ``{"radius_mm": 4.77, "step_size_mm": 0.5, "steps": 28, "fiber_angle_deg": 90.0 | null,
    "excluded_steps": [7], "description": "..."}``. ``fiber_angle_deg`` is the fiber direction in
    the DIC frame, counter-clockwise from x (null: estimate it from the strain field);
    ``excluded_steps`` (optional) are steps left out of the fit (a hold with a load-cell spike, a
    slipped step, a lost DIC frame): their readings may be missing or wrong and are not checked.
    ``specimen_mm`` (optional) ``{"width": 100, "depth": 100, "thickness": 60}``: the specimen's
    full widths across and along the fibers and its thickness; a fit then looks for a surrogate
    of that specimen (absent: the test is read from the indenter and the protocol alone).
``force.csv``
    The indenter force readings during each step's hold: columns ``step`` (1..N), ``time_s``
    (from the start of that step's hold), ``force_mN``.
``dic.npz`` (or ``dic/step_NN.csv``)
    The DIC point cloud of each step: reference position ``x, y, z`` (mm) and displacement
    ``ux, uy, uz`` (mm) from the reference (undeformed, zero-depth) state. There is no step 0:
    the reference state is where displacements are zero, and step k is the k-th hold. In ``dic.npz``: ``xyz`` (points, 3) and ``u`` (steps, points, 3) with
    NaN where a point was not correlated; as CSVs one file per step with columns
    ``x, y, z, ux, uy, uz``.
``indenter.csv``
    Points tracked on the indenter's sphere in the reference state: ``x, y, z`` (mm).

Loading checks everything a fit relies on and names the file, row and column of the first
problem: missing files or columns, NaN or infinite values, an empty step, a step that is not
in the protocol, and units that cannot be right (forces whose Hertz-implied shear modulus,
F / (16/3 sqrt(R) d^1.5), lies outside 0.1 kPa .. 100 MPa over the steps: newtons or
micronewtons; displacements larger than the specimen read as microns). One hold whose readings
are wrong (a spike, a slipped step) is named by its step and rows (:mod:`.hold_checks`).
"""

from __future__ import annotations

import json
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..lab.table_columns import read_table
from .errors import ExperimentDataError
from .hold_checks import check_hold_forces


@dataclass
class ExperimentData:
    """A loaded, validated experiment (coordinates in the DIC frame, mm; forces mN; times s).

    Attributes
    ----------
    root : pathlib.Path
        The experiment folder.
    radius : float
        The indenter's radius, mm.
    step_size : float
        Indentation per step, mm.
    steps : int
        Number of steps N.
    fiber_angle_deg : float or None
        The fiber direction in the DIC frame, degrees from x; None: to be estimated.
    force : pandas.DataFrame
        The force readings: ``step``, ``time_s``, ``force_mN``.
    dic_xyz : numpy.ndarray
        (points, 3) DIC reference positions.
    dic_u : numpy.ndarray
        (steps, points, 3) DIC displacements, NaN where not correlated.
    indenter_xyz : numpy.ndarray
        (points, 3) the indenter's tracked points.
    description : str
        Free text.
    excluded_steps : tuple of int
        Steps (1..N) left out of the fit.
    missing_steps : tuple of int
        Of those, the ones left out for lack of data (``exclude_missing``).
    synthetic : dict
        experiment.json's ``synthetic`` block (a synthetic or FEBio-made experiment's truth,
        noise and source); empty for a lab's experiment.
    imported : dict
        experiment.json's ``imported`` block (what an importer recorded: its sources, the
        contact, the clock offset and its range); empty for one written otherwise.
    """

    root: Path
    radius: float
    step_size: float
    steps: int
    fiber_angle_deg: float | None
    force: pd.DataFrame  # step, time_s, force_mN
    dic_xyz: np.ndarray  # (points, 3) reference positions
    dic_u: np.ndarray  # (steps, points, 3), NaN where not correlated
    indenter_xyz: np.ndarray  # (points, 3)
    description: str = ""
    excluded_steps: tuple[int, ...] = ()  # steps (1..N) left out of the fit
    missing_steps: tuple[int, ...] = ()  # of those, the ones left out for lack of data (exclude_missing)
    synthetic: dict[str, Any] = field(default_factory=dict)  # experiment.json's 'synthetic' block
    imported: dict[str, Any] = field(default_factory=dict)  # experiment.json's 'imported' block
    specimen_mm: dict[str, float] | None = None  # width, depth, thickness (experiment.json's specimen_mm)

    @property
    def block(self) -> dict[str, float] | None:
        """The quarter model's geometry of the stated specimen (``half_x``, ``half_y``, ``height``), or None."""
        if self.specimen_mm is None:
            return None
        s = self.specimen_mm
        return {"half_x": s["width"] / 2.0, "half_y": s["depth"] / 2.0, "height": s["thickness"]}

    @property
    def used_steps(self) -> np.ndarray:
        """The steps (1..N) the fit uses."""
        return np.array([k for k in range(1, self.steps + 1) if k not in self.excluded_steps], int)

    @property
    def depths(self) -> np.ndarray:
        """(N,) the depth of each step, mm."""
        return self.step_size * np.arange(1, self.steps + 1)


def _require_columns(table: pd.DataFrame, columns: tuple[str, ...], path: Path) -> None:
    missing = [c for c in columns if c not in table.columns]
    if missing:
        read = f"; read with {table.attrs['dialect']}" if "dialect" in table.attrs else ""
        raise ExperimentDataError(
            f"{path}: missing column(s) {', '.join(missing)} (has {', '.join(table.columns)}{read})"
        )


def _require_finite(table: pd.DataFrame, columns: tuple[str, ...], path: Path) -> None:
    values = table[list(columns)].to_numpy(dtype=float)
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        # +2: one for the header line, one because rows count from 1 in an editor
        raise ExperimentDataError(f"{path}: row {row + 2}, column '{columns[col]}': not a finite number")


def _read_csv(path: Path, columns: tuple[str, ...]) -> pd.DataFrame:

    table = read_table(path)
    _require_columns(table, columns, path)
    for c in columns:
        converted = pd.to_numeric(table[c], errors="coerce")
        bad = converted.isna() & table[c].notna()
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise ExperimentDataError(
                f"{path}: row {row + 2}, column '{c}': {table[c].iloc[row]!r} is not a number"
            )
        table[c] = converted
    _require_finite(table, columns, path)
    return table


def _read_meta(root: Path) -> dict:
    path = root / "experiment.json"
    if not path.is_file():
        raise ExperimentDataError(f"{path}: missing file")
    try:
        meta = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ExperimentDataError(f"{path}: not valid JSON ({exc})") from exc
    for key in ("radius_mm", "step_size_mm", "steps"):
        if key not in meta:
            raise ExperimentDataError(f"{path}: missing key '{key}'")
        value = meta[key]
        if not isinstance(value, int | float) or not np.isfinite(value) or value <= 0:
            raise ExperimentDataError(f"{path}: '{key}' must be a positive number, got {value!r}")
    if int(meta["steps"]) != meta["steps"]:
        raise ExperimentDataError(f"{path}: 'steps' must be a whole number, got {meta['steps']!r}")
    angle = meta.get("fiber_angle_deg")
    if angle is not None and (not isinstance(angle, int | float) or not np.isfinite(angle)):
        raise ExperimentDataError(f"{path}: 'fiber_angle_deg' must be a number or null, got {angle!r}")
    excluded = meta.get("excluded_steps", [])
    if not isinstance(excluded, list) or not all(
        isinstance(k, int) and not isinstance(k, bool) and 1 <= k <= meta["steps"] for k in excluded
    ):
        raise ExperimentDataError(
            f"{path}: 'excluded_steps' must be a list of steps in 1..{meta['steps']}, got {excluded!r}"
        )
    if len(excluded) >= meta["steps"]:
        raise ExperimentDataError(f"{path}: 'excluded_steps' leaves no step to fit")
    return meta


def _read_dic(root: Path, steps: int) -> tuple[np.ndarray, np.ndarray]:
    npz = root / "dic.npz"
    if npz.is_file():
        try:
            with np.load(npz, allow_pickle=False) as z:
                for key in ("xyz", "u"):
                    if key not in z:
                        raise ExperimentDataError(f"{npz}: missing array '{key}'")
                xyz, u = np.asarray(z["xyz"], float), np.asarray(z["u"], float)
        except ExperimentDataError:
            raise
        except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
            # cut short, a flipped byte (a bad CRC), empty, not an npz
            raise ExperimentDataError(
                f"{npz}: not a readable DIC file, truncated or damaged ({type(exc).__name__}: {exc})"
            ) from exc
        if xyz.ndim != 2 or xyz.shape[1] != 3:
            raise ExperimentDataError(f"{npz}: 'xyz' must be (points, 3), got {xyz.shape}")
        if u.shape != (steps, xyz.shape[0], 3):
            raise ExperimentDataError(
                f"{npz}: 'u' must be (steps={steps}, points={xyz.shape[0]}, 3), got {u.shape}"
            )
        bad = ~np.isfinite(xyz)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            raise ExperimentDataError(f"{npz}: xyz row {row}, column '{'xyz'[col]}': not a finite number")
        return xyz, u
    folder = root / "dic"
    if not folder.is_dir():
        raise ExperimentDataError(f"{root}: missing DIC data (dic.npz or dic/step_NN.csv)")
    tables = []
    for k in range(1, steps + 1):
        path = folder / f"step_{k:02d}.csv"
        tables.append(_read_csv(path, ("x", "y", "z", "ux", "uy", "uz")))
    xyz = tables[0][["x", "y", "z"]].to_numpy(float)
    u = np.full((steps, len(xyz), 3), np.nan)
    for k, t in enumerate(tables):
        if len(t) != len(xyz) or not np.allclose(t[["x", "y", "z"]].to_numpy(float), xyz):
            raise ExperimentDataError(
                f"{folder / f'step_{k + 1:02d}.csv'}: the reference points differ from step_01.csv "
                "(every step must list the same points in the same order)"
            )
        u[k] = t[["ux", "uy", "uz"]].to_numpy(float)
    return xyz, u


def load_experiment(root: str | Path, exclude_missing: bool = False) -> ExperimentData:
    """Read and validate an experiment folder (module docstring).

    Parameters
    ----------
    root : str or pathlib.Path
        The experiment folder.
    exclude_missing : bool, default False
        A step with fewer than 4 force readings or no correlated DIC point is left out (listed in
        ``missing_steps``) instead of refused: the data check reports it.

    Returns
    -------
    ExperimentData
        The experiment.

    Raises
    ------
    ExperimentDataError
        If the folder is missing or its files are not a valid experiment (naming what is wrong).

    Examples
    --------
    >>> import indentation_studio as ins
    >>> exp = ins.load_experiment("runs/experiments/synthetic")  # doctest: +SKIP
    >>> exp.steps, exp.radius  # doctest: +SKIP
    """
    root = Path(root)
    if not root.is_dir():
        raise ExperimentDataError(f"{root}: no such experiment folder")
    meta = _read_meta(root)
    steps = int(meta["steps"])
    excluded = tuple(sorted(set(meta.get("excluded_steps", []))))
    force_path = root / "force.csv"
    force = _read_csv(force_path, ("step", "time_s", "force_mN"))
    unknown = sorted(set(force["step"].astype(int)) - set(range(1, steps + 1)))
    if unknown:
        row = int(np.flatnonzero(force["step"].astype(int).to_numpy() == unknown[0])[0])
        raise ExperimentDataError(
            f"{force_path}: row {row + 2}, column 'step': step {unknown[0]} is not in 1..{steps}"
        )
    missing: list[int] = []
    for k in range(1, steps + 1):
        if k in excluded:
            continue
        rows = force[force["step"] == k]
        if len(rows) < 4 and exclude_missing:
            missing.append(k)
        elif len(rows) < 4:
            raise ExperimentDataError(
                f"{force_path}: step {k} has {len(rows)} force readings; the relaxation fit (eq. 9) needs at least 4"
            )
    check_hold_forces(
        force,
        float(meta["radius_mm"]),
        float(meta["step_size_mm"]),
        str(force_path),
        excluded_steps=(*excluded, *missing),
    )
    xyz, u = _read_dic(root, steps)
    for k in range(steps):
        if k + 1 not in excluded and not np.isfinite(u[k]).all(axis=1).any():
            if not exclude_missing:
                raise ExperimentDataError(f"{root}: DIC step {k + 1} has no correlated point")
            missing.append(k + 1)
    missing = sorted(set(missing))
    if len(set(excluded) | set(missing)) >= steps:
        raise ExperimentDataError(f"{root}: no step has both force readings and DIC points")
    span = float(np.ptp(xyz[:, :2], axis=0).max())
    u_max = float(np.nanmax(np.abs(u))) if np.isfinite(u).any() else 0.0
    if u_max > max(span, 1.0):
        raise ExperimentDataError(
            f"{root}: DIC displacements up to {u_max:g} exceed the field's {span:g} mm extent (microns, not mm?)"
        )
    indenter = _read_csv(root / "indenter.csv", ("x", "y", "z"))[["x", "y", "z"]].to_numpy(float)
    if len(indenter) < 4:
        raise ExperimentDataError(
            f"{root / 'indenter.csv'}: a sphere fit needs at least 4 points, got {len(indenter)}"
        )
    return ExperimentData(
        root=root,
        radius=float(meta["radius_mm"]),
        step_size=float(meta["step_size_mm"]),
        steps=steps,
        fiber_angle_deg=None if meta.get("fiber_angle_deg") is None else float(meta["fiber_angle_deg"]),
        force=force,
        dic_xyz=xyz,
        dic_u=u,
        indenter_xyz=indenter,
        description=str(meta.get("description", "")),
        excluded_steps=tuple(sorted(set(excluded) | set(missing))),
        missing_steps=tuple(missing),
        synthetic=dict(meta.get("synthetic") or {}),
        imported=dict(meta.get("imported") or {}),
        specimen_mm=_specimen(meta.get("specimen_mm"), root),
    )


def _specimen(value: Any, root: Path) -> dict[str, float] | None:
    """experiment.json's ``specimen_mm``, checked: three positive numbers (width, depth, thickness)."""
    if value is None:
        return None
    try:
        out = {k: float(value[k]) for k in ("width", "depth", "thickness")}
    except (KeyError, TypeError, ValueError):
        raise ExperimentDataError(
            f"{root / 'experiment.json'}: specimen_mm must be {{'width': W, 'depth': D, 'thickness': T}} in mm, got {value!r}"
        ) from None
    if not all(np.isfinite(v) and v > 0 for v in out.values()):
        raise ExperimentDataError(
            f"{root / 'experiment.json'}: specimen_mm {value!r}: sizes must be positive numbers"
        )
    return out
