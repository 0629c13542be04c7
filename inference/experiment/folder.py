"""The one writer of the experiment folder (experiment.json, force.csv, dic.npz, indenter.csv; the
format is :mod:`inference.experiment.data`'s): every path that makes one (the importers, the
synthetic, FEBio and composite experiments) writes it here, validated and atomically."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from ...atomic_write import atomic_write, atomic_write_json, atomic_write_npz
from .data import ExperimentDataError, load_experiment

__all__ = ["refuse_existing_experiment", "write_experiment_folder"]


def refuse_existing_experiment(out_dir: str | Path, *, overwrite: bool) -> None:
    """Refuse, before anything is solved, to make an experiment where one is already.

    Parameters
    ----------
    out_dir : str or pathlib.Path
        The experiment folder to be.
    overwrite : bool
        Replace it (nothing is refused).

    Raises
    ------
    FileExistsError
        If ``out_dir`` holds an experiment.json and not ``overwrite``.
    """
    if (Path(out_dir) / "experiment.json").exists() and not overwrite:
        raise FileExistsError(
            f"{out_dir}: an experiment is already there (overwrite=True, or --overwrite, replaces it)"
        )


def write_experiment_folder(
    out_dir: Path,
    meta: dict,
    force: pd.DataFrame,
    xyz: np.ndarray,
    u: np.ndarray,
    indenter_xyz: np.ndarray,
    *,
    overwrite: bool = False,
    keep_other_files: bool = False,
) -> Path:
    """Write the experiment folder ``out_dir`` (experiment.json ``meta``, force.csv from ``force``'s
    step, time_s and force_mN, dic.npz of ``xyz`` and ``u``, indenter.csv of ``indenter_xyz``)
    into a temporary folder beside it, check that it loads (:func:`load_experiment`), and only
    then put it in place: a folder is never half-written nor invalid. An existing non-empty folder
    is refused unless ``overwrite``; it is replaced whole, or, with ``keep_other_files`` (a model
    run's result kept beside its experiment), only the four files are replaced, experiment.json
    last (a folder without it is no experiment). Returns its path."""
    out = Path(out_dir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not overwrite:
        raise ExperimentDataError(f"{out}: exists and is not empty (overwrite it explicitly)")
    tmp = out.parent / f".{out.name}.importing-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        atomic_write(tmp / "force.csv", force[["step", "time_s", "force_mN"]].to_csv(index=False))
        atomic_write_npz(tmp / "dic.npz", xyz=xyz, u=u)
        atomic_write(
            tmp / "indenter.csv", pd.DataFrame(indenter_xyz, columns=["x", "y", "z"]).to_csv(index=False)
        )
        atomic_write_json(tmp / "experiment.json", meta)
        try:
            load_experiment(tmp)
        except ExperimentDataError as exc:
            raise ExperimentDataError(str(exc).replace(str(tmp), str(out))) from None
        if out.is_dir() and keep_other_files:
            (out / "experiment.json").unlink(missing_ok=True)
            for name in ("force.csv", "dic.npz", "indenter.csv", "experiment.json"):
                os.replace(tmp / name, out / name)
        elif out.exists():
            backup = out.parent / f".{out.name}.replaced-{os.getpid()}"
            os.replace(out, backup)
            os.replace(tmp, out)
            shutil.rmtree(backup, ignore_errors=True)
        else:
            os.replace(tmp, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out
