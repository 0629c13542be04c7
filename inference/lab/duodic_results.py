"""DuoDIC results (``DIC3DPPresults.mat`` of STEP 4, or ``DIC3Dstereo.mat`` of STEP 3): MATLAB
v7 and v7.3 (HDF5) files read with pymatreader.

The structure (``DIC3DPPresults`` or ``DIC3D``) holds one cell per frame, the first frame being
the reference:

* ``Points3D{i}`` (points, 3): the points' positions in frame i, NaN where not reconstructed;
* ``Disp.DispVec{i}`` (points, 3): Points3D{i} - Points3D{1} (``Disp.DispVec_ARBM`` after rigid
  body motion is removed, with ``rigid_body_removed``);
* ``corrComb{i}`` (points,): the worse of the two cameras' correlation coefficients (Ncorr's,
  smaller is better), used to drop points above ``max_corr``.

DuoDIC stores no units: they are the calibration target's (``length_unit`` is required). Frame
numbers count from 0 (the reference), like MatchID's ``Image_0000``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..experiment.data import ExperimentDataError
from .dic_series import DICSeries
from .units import unit_factor

VARIABLES = ("DIC3DPPresults", "DIC3D")
#: fields DuoDIC saves beside the points that the import does not need: skipped when reading a
#: v7.3 file (calibration objects pymatreader cannot read, the 2D results, per-face measures)
SKIPPED_FIELDS = (
    "stereoParams",
    "DIC2Dinfo",
    "FaceColors",
    "FaceCentroids",
    "FaceCentroids_ARBM",
    "FaceCorrComb",
    "FacereprojectionErrors",
    "FaceIsoInd",
    "reprojectionErrors",
    "Deform",
    "Deform_ARBM",
    "RBM",
)


def _reader_notes(caught: list[warnings.WarningMessage]) -> list[str]:
    """pymatreader's warnings said in the studio's words: its "Complex objects (like classes)
    are not supported" is raised for every MATLAB object DuoDIC saves beside the results (camera
    parameters, class instances), none of which the import reads; other warnings are passed on."""
    objects = sum("Complex objects" in str(w.message) for w in caught)
    strings = sum("string variables" in str(w.message) for w in caught)
    notes = []
    if objects or strings:
        notes.append(
            f"{objects + strings} MATLAB object(s) in the file (classes{', strings' if strings else ''}) not read: the "
            "import needs only Points3D, Disp and corrComb"
        )
    for w in caught:
        text = str(w.message)
        if "Complex objects" not in text and "string variables" not in text:
            warnings.warn(f"reading a DuoDIC file: {text}", stacklevel=3)
    return notes


def _cells(value, name: str, path: Path) -> list[np.ndarray]:
    """A MATLAB cell row as a list of float arrays (pymatreader gives a list, an object array, or
    the bare array of a 1 x 1 cell)."""
    if isinstance(value, np.ndarray) and value.dtype != object:
        return [np.asarray(value, float)]
    if isinstance(value, np.ndarray | list | tuple):
        items = list(value) if isinstance(value, list | tuple) else list(value.ravel())
        out = []
        for i, v in enumerate(items):
            try:
                out.append(np.asarray(v, float))
            except (TypeError, ValueError) as exc:
                raise ExperimentDataError(f"{path}: {name}{{{i + 1}}} is not a numeric array") from exc
        return out
    raise ExperimentDataError(f"{path}: {name} is not a cell array of frames")


def _points(a: np.ndarray, name: str, i: int, n: int | None, path: Path) -> np.ndarray:
    a = np.atleast_2d(a)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ExperimentDataError(f"{path}: {name}{{{i + 1}}} must be (points, 3), got {a.shape}")
    if n is not None and len(a) != n:
        raise ExperimentDataError(
            f"{path}: {name}{{{i + 1}}} has {len(a)} points, {name}{{1}} has {n} (every frame lists the same points)"
        )
    return a


def read_duodic(
    path: str | Path,
    length_unit: str,
    variable: str | None = None,
    max_corr: float | None = None,
    rigid_body_removed: bool = False,
) -> DICSeries:
    """Read a DuoDIC results file into a :class:`DICSeries` (module docstring)."""
    from pymatreader import read_mat

    path = Path(path)
    if not path.is_file():
        raise ExperimentDataError(f"{path}: missing file")
    scale = unit_factor(length_unit, "length", str(path))
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            content = read_mat(str(path), ignore_fields=list(SKIPPED_FIELDS))
    except Exception as exc:  # scipy and h5py raise several types for files that are not .mat
        raise ExperimentDataError(f"{path}: not a readable MATLAB file ({exc})") from exc
    library_notes = _reader_notes(caught)
    content = {k: v for k, v in content.items() if not k.startswith("__")}  # scipy's header entries
    names = [variable] if variable else [v for v in VARIABLES if v in content]
    if variable and variable not in content:
        raise ExperimentDataError(f"{path}: no variable '{variable}' (has {', '.join(sorted(content))})")
    if not names:
        names = [k for k, v in content.items() if isinstance(v, dict) and "Points3D" in v]
    if not names:
        raise ExperimentDataError(
            f"{path}: no DuoDIC results: none of the variables ({', '.join(sorted(content)) or 'none'}) holds "
            "'Points3D' (save DIC3DPPresults from DuoDIC's STEP 4)"
        )
    name = names[0]
    result = content[name]
    if not isinstance(result, dict) or "Points3D" not in result:
        fields = ", ".join(sorted(result)) if isinstance(result, dict) else type(result).__name__
        raise ExperimentDataError(f"{path}: no 'Points3D' in {name} (has {fields})")
    points = _cells(result["Points3D"], f"{name}.Points3D", path)
    n = len(_points(points[0], f"{name}.Points3D", 0, None, path))
    points = [_points(p, f"{name}.Points3D", i, n, path) for i, p in enumerate(points)]
    key = "DispVec_ARBM" if rigid_body_removed else "DispVec"
    disp_field = result.get("Disp", {})
    if isinstance(disp_field, dict) and key in disp_field:
        disp = _cells(disp_field[key], f"{name}.Disp.{key}", path)
        if len(disp) != len(points):
            raise ExperimentDataError(
                f"{path}: {name}.Disp.{key} has {len(disp)} frames, {name}.Points3D {len(points)}"
            )
        disp = [_points(d, f"{name}.Disp.{key}", i, n, path) for i, d in enumerate(disp)]
    elif rigid_body_removed:
        raise ExperimentDataError(f"{path}: no Disp.DispVec_ARBM in {name} (run DuoDIC's STEP 4)")
    else:
        disp = [p - points[0] for p in points]
    u = np.stack(disp) * scale
    ok = np.isfinite(u).all(axis=2)
    if max_corr is not None:
        if "corrComb" not in result:
            raise ExperimentDataError(f"{path}: no corrComb in {name} to filter by correlation")
        corr = _cells(result["corrComb"], f"{name}.corrComb", path)
        if len(corr) != len(points) or any(np.size(c) != n for c in corr):
            raise ExperimentDataError(f"{path}: {name}.corrComb does not have one value per point and frame")
        ok &= np.stack([np.ravel(c) for c in corr]) <= max_corr
    u[~ok] = np.nan
    xyz = points[0] * scale
    seen = np.isfinite(xyz).all(axis=1)
    dropped = int((~seen).sum())
    notes = [f"{dropped} points not reconstructed in the reference frame dropped"] if dropped else []
    notes += library_notes
    return DICSeries(
        str(path),
        xyz[seen],
        u[:, seen],
        np.arange(len(points)),
        [f"{name}.Points3D{{{i + 1}}}" for i in range(len(points))],
        None,
        notes,
    )
