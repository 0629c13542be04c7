"""A mesh's output differences at an error budget's points: the fit's model (level 3) less its
reference (level 4), force and top field, kept so that a fit can move them through its own free
parameters (issue 57, option (i): an error budget is measured with mu held, a plain fit frees mu,
and mu takes up the part of the mesh's error that looks like slip).

Reading only, below the surrogates and the fits (as :mod:`.error_budgets`): making the file from
runs is :mod:`indentation_studio.inference.budgets.mesh_difference_runs`' job and
``tools/make_mesh_differences.py``'s (moving them through a fit,
:mod:`indentation_studio.inference.budgets.freed_mu_moves`'). Shipped files are package data,
``indentation_studio/error_budgets/mesh-differences-*.npz``, found by test and mesh as the budgets
are (:func:`shipped_mesh_differences`). See docs/validation/model-error.md ("The mesh's move with mu
free")."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..forward.convergence.mesh_study import top_field_interpolator
from .error_budgets import indentation_test_of, shipped_budgets_folder

__all__ = ["MeshDifferences", "shipped_mesh_differences", "surrogate_mesh_differences"]

#: How shipped files are named in the budgets' folder.
PATTERN = "mesh-differences-*.npz"


@dataclass(frozen=True)
class MeshDifferences:
    """The coarse mesh's outputs less the fine mesh's at a budget's points.

    Attributes
    ----------
    points : numpy.ndarray
        (n, 2) c1, c5 of each point, kPa.
    force_log : numpy.ndarray
        (n, steps) log(coarse force) - log(fine force) at each step (depth 0 left out).
    field : numpy.ndarray
        (n, steps, nodes, 3) coarse top displacement less fine, mm, at ``top_xyz``.
    top_xyz : numpy.ndarray
        (nodes, 3) where the field is given, mm.
    meta : dict
        ``model`` (the coarse run's spec, for :func:`indentation_test_of`), ``coarse_mesh``,
        ``fine_mesh``, ``runs`` (each pair's files and versions), ``made`` (by, version, at).
    """

    points: np.ndarray
    force_log: np.ndarray
    field: np.ndarray
    top_xyz: np.ndarray
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        n, steps = np.shape(self.force_log)
        if np.shape(self.points) != (n, 2):
            raise ValueError(f"mesh differences: {n} points need (n, 2) c1, c5, got {np.shape(self.points)}")
        if np.shape(self.field) != (n, steps, len(self.top_xyz), 3):
            raise ValueError(
                f"mesh differences: the field must be (points, steps, nodes, 3) = "
                f"({n}, {steps}, {len(self.top_xyz)}, 3), got {np.shape(self.field)}"
            )
        for name in ("points", "force_log", "field", "top_xyz"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"mesh differences: {name} holds a NaN or an infinity")

    def outputs_at(self, top_xyz: np.ndarray) -> np.ndarray:
        """The differences in a surrogate's output space at its top nodes ``top_xyz``.

        The field is interpolated from this file's nodes over the top surface
        (:func:`forward.convergence.mesh_study.top_field_interpolator`) unless the nodes are the same.

        Parameters
        ----------
        top_xyz : numpy.ndarray
            (nodes, 3) the surrogate's top nodes, mm.

        Returns
        -------
        numpy.ndarray
            (n, steps + steps * nodes * 3): log force per step, then the field (mm), as
            :func:`inference.budgets.fit_moves.fit_moves` reads them.
        """
        top_xyz = np.asarray(top_xyz, float)
        field = np.asarray(self.field, float)
        if top_xyz.shape != self.top_xyz.shape or not np.allclose(top_xyz, self.top_xyz, atol=1e-9):
            n, steps = self.force_log.shape
            stacked = np.moveaxis(field, 2, 0).reshape(len(self.top_xyz), n * steps, 3)  # (nodes, n*steps, 3)
            moved = top_field_interpolator(self.top_xyz, stacked)(top_xyz)  # (new nodes, n*steps, 3)
            field = np.moveaxis(moved.reshape(len(top_xyz), n, steps, 3), 0, 2)
        n = len(self.points)
        return np.concatenate([np.asarray(self.force_log, float), field.reshape(n, -1)], axis=1)

    def save(self, path: str | Path) -> Path:
        """Write the differences (compressed npz, the field in single precision, meta as JSON).

        Parameters
        ----------
        path : str or pathlib.Path
            The file.

        Returns
        -------
        pathlib.Path
            The file written.
        """
        path = Path(path)
        np.savez_compressed(
            path,
            points=np.asarray(self.points, float),
            force_log=np.asarray(self.force_log, float),
            field=np.asarray(self.field, np.float32),
            top_xyz=np.asarray(self.top_xyz, float),
            meta=np.array(json.dumps(self.meta)),
        )
        return path

    @classmethod
    def load(cls, path: str | Path) -> MeshDifferences:
        """Read a file written by :meth:`save`.

        Parameters
        ----------
        path : str or pathlib.Path
            The file.

        Returns
        -------
        MeshDifferences

        Raises
        ------
        ValueError
            If the file is not such a file (its error names it).
        """
        try:
            with np.load(Path(path)) as f:
                return cls(f["points"], f["force_log"], f["field"], f["top_xyz"], json.loads(str(f["meta"])))
        except (OSError, KeyError, ValueError) as exc:
            raise ValueError(f"{path}: not a mesh-differences file ({exc})") from exc


def shipped_mesh_differences(model: dict, folder: str | Path | None = None) -> MeshDifferences | None:
    """The shipped mesh differences for ``model``'s test and mesh, if any were measured.

    A file counts when its coarse run is the same test (:func:`indentation_test_of`: geometry,
    indenter, protocol, contact, material but c1 and c5) on the same mesh preset.

    Parameters
    ----------
    model : dict
        A spec's ``to_dict()`` (a surrogate's ``meta['campaign']['model']``).
    folder : str or pathlib.Path, optional
        Where to look; default the shipped budgets' folder.

    Returns
    -------
    MeshDifferences or None
    """
    preset = (model.get("mesh") or {}).get("preset")
    if preset is None:
        return None
    test = json.loads(json.dumps(indentation_test_of(model)))
    for path in sorted(Path(folder or shipped_budgets_folder()).glob(PATTERN)):
        try:
            found = MeshDifferences.load(path)
        except ValueError:
            continue
        coarse = found.meta.get("model") or {}
        if (coarse.get("mesh") or {}).get("preset") != preset:
            continue
        if json.loads(json.dumps(indentation_test_of(coarse))) != test:
            continue
        file = f"indentation_studio/error_budgets/{path.name}" if folder is None else str(path)
        return MeshDifferences(
            found.points, found.force_log, found.field, found.top_xyz, found.meta | {"file": file}
        )
    return None


def surrogate_mesh_differences(surrogate) -> MeshDifferences | None:
    """The shipped mesh differences for the FE model a surrogate emulates (its high fidelity).

    Parameters
    ----------
    surrogate : FieldSurrogate
        Any object with a ``meta`` dict holding ``campaign.model``.

    Returns
    -------
    MeshDifferences or None
    """
    model = ((getattr(surrogate, "meta", None) or {}).get("campaign") or {}).get("model")
    return shipped_mesh_differences(model) if model else None
