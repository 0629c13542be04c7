"""The result of one indentation simulation and its file (``.npz``, written atomically).

Every solver (embedded, FEBio) returns this schema. Forces are for the whole specimen: the
quarter model's force times 4 (``force_quarter`` keeps the quarter's). Displacements are of the
top-surface nodes, per step, with the nodes' ids and reference coordinates.
"""

from __future__ import annotations

import json
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic_write import atomic_write_npz

#: Whole specimen = this many quarter models (symmetry planes x = 0 and y = 0).
SYMMETRY_FACTOR = 4


def _numpy_scalar(value):
    """A numpy scalar (a counter summed from numpy values, in the solver's record) as its Python
    value, for the result's JSON; anything else is not JSON."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


@dataclass
class SimulationResult:
    """Per-step outputs of one simulation (steps + 1 rows: depth 0 first).

    Attributes
    ----------
    depth : numpy.ndarray
        (s,) indentation depth, mm.
    force : numpy.ndarray
        (s,) force of the whole specimen (4 x the quarter model's), mN.
    top_node_ids : numpy.ndarray
        (nt,) node ids of the top surface.
    top_xyz : numpy.ndarray
        (nt, 3) their reference coordinates, mm.
    displacement : numpy.ndarray
        (s, nt, 3) their displacements, mm.
    spec : dict
        The model's ``ModelSpec.to_dict()``.
    solver : dict
        The solver's name, version, mesh and options.
    convergence : dict of str to numpy.ndarray
        Per-step convergence records (e.g. ``newton_iterations``).
    wall_s : float
        Wall time, s.
    force_sensitivity : numpy.ndarray or None
        (s, p) d force / d theta, mN per kPa.
    displacement_sensitivity : numpy.ndarray or None
        (s, nt, 3, p) d u / d theta, mm per kPa.
    parameters : tuple of str
        The parameters of the sensitivities.
    full_displacement : numpy.ndarray or None
        (s, n, 3) every node's displacement, mm, when asked for (VTU export).
    off_equilibrium : numpy.ndarray or None
        (s,) bool: steps a FEBio run accepted off equilibrium (force NaN there); None when not
        checked (the embedded solver, old files).
    contact_status : numpy.ndarray or None
        (s, nt) int8: each top node's contact per step, 0 free, 1 stuck, 2 slipping (embedded
        solver; None for FEBio runs and old files).
    """

    depth: np.ndarray  # (s,) mm
    force: np.ndarray  # (s,) mN, whole specimen
    top_node_ids: np.ndarray  # (nt,)
    top_xyz: np.ndarray  # (nt, 3) reference coordinates, mm
    displacement: np.ndarray  # (s, nt, 3) mm
    spec: dict[str, Any]
    solver: dict[str, Any]  # name, version, mesh, options
    convergence: dict[str, np.ndarray] = field(default_factory=dict)  # per step
    wall_s: float = 0.0
    force_sensitivity: np.ndarray | None = None  # (s, p) mN per kPa: d force / d theta
    displacement_sensitivity: np.ndarray | None = None  # (s, nt, 3, p) mm per kPa
    parameters: tuple[str, ...] = ("c1", "c5")
    full_displacement: np.ndarray | None = None  # (s, n, 3) mm: every node, when asked for (VTU export)
    # (s,) bool: steps a FEBio run accepted off equilibrium (force NaN there, see
    # forward.febio.equilibrium); None when not checked (the embedded solver, old files)
    off_equilibrium: np.ndarray | None = None
    # (s, nt) int8: each top node's contact per step, 0 free, 1 stuck, 2 slipping (embedded
    # solver; None for FEBio runs and old files)
    contact_status: np.ndarray | None = None

    @property
    def force_quarter(self) -> np.ndarray:
        """(s,) the quarter model's force (the whole specimen's / 4), mN."""
        return self.force / SYMMETRY_FACTOR

    @property
    def newton_iterations(self) -> int:
        """Newton's iterations over all steps (0 when not recorded)."""
        it = self.convergence.get("newton_iterations")
        return int(np.sum(it)) if it is not None else 0

    @property
    def off_equilibrium_depths(self) -> list[float]:
        """Depths (mm) of the steps flagged off equilibrium; empty when none or not checked."""
        if self.off_equilibrium is None:
            return []
        return [float(d) for d in np.asarray(self.depth)[np.asarray(self.off_equilibrium, bool)]]

    def table(self) -> list[dict[str, float]]:
        """Depth and force per step.

        Returns
        -------
        list of dict
            ``{"depth_mm", "force_mN"}`` per step (whole specimen).
        """
        return [
            {"depth_mm": float(d), "force_mN": float(f)} for d, f in zip(self.depth, self.force, strict=True)
        ]

    def save(self, path: str | Path) -> Path:
        """Write the result atomically (temporary file in the same folder, then rename).

        Parameters
        ----------
        path : str or pathlib.Path
            The ``.npz`` file.

        Returns
        -------
        pathlib.Path
            The file written.
        """
        arrays: dict[str, np.ndarray] = {
            "depth": self.depth,
            "force": self.force,
            "force_quarter": self.force_quarter,
            "top_node_ids": self.top_node_ids,
            "top_xyz": self.top_xyz,
            "displacement": self.displacement,
        }
        arrays.update({f"conv_{k}": np.asarray(v) for k, v in self.convergence.items()})
        if self.full_displacement is not None:
            arrays["full_displacement"] = self.full_displacement
        if self.off_equilibrium is not None:
            arrays["off_equilibrium"] = np.asarray(self.off_equilibrium, bool)
        if self.contact_status is not None:
            arrays["contact_status"] = np.asarray(self.contact_status, np.int8)
        if self.force_sensitivity is not None:
            arrays["force_sensitivity"] = self.force_sensitivity
            arrays["displacement_sensitivity"] = self.displacement_sensitivity
        meta = {
            "schema": "indentation-studio/simulation/1",
            "spec": self.spec,
            "solver": self.solver,
            "wall_s": self.wall_s,
            "parameters": list(self.parameters),
            "units": {"length": "mm", "stress": "kPa", "force": "mN"},
            "force": "whole specimen = 4 x quarter model",
        }

        return atomic_write_npz(path, meta=np.array(json.dumps(meta, default=_numpy_scalar)), **arrays)

    @classmethod
    def load(cls, path: str | Path) -> SimulationResult:
        """Read a result written by :meth:`save`.

        Parameters
        ----------
        path : str or pathlib.Path
            The ``.npz`` file.

        Returns
        -------
        SimulationResult
            The result.

        Raises
        ------
        ValueError
            If the file is missing, truncated, damaged or unreadable.
        """
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                conv = {k[5:]: z[k] for k in z.files if k.startswith("conv_")}
                sens = "force_sensitivity" in z.files
                return cls(
                    depth=z["depth"],
                    force=z["force"],
                    top_node_ids=z["top_node_ids"],
                    top_xyz=z["top_xyz"],
                    displacement=z["displacement"],
                    spec=meta["spec"],
                    solver=meta["solver"],
                    convergence=conv,
                    wall_s=float(meta.get("wall_s", 0.0)),
                    force_sensitivity=z["force_sensitivity"] if sens else None,
                    displacement_sensitivity=z["displacement_sensitivity"] if sens else None,
                    parameters=tuple(meta.get("parameters", ("c1", "c5"))),
                    full_displacement=z["full_displacement"] if "full_displacement" in z.files else None,
                    off_equilibrium=z["off_equilibrium"] if "off_equilibrium" in z.files else None,
                    contact_status=z["contact_status"] if "contact_status" in z.files else None,
                )
        except FileNotFoundError as exc:
            raise ValueError(f"{path}: no such result file") from exc
        except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
            # a file cut short, a flipped byte (a bad CRC or deflate stream), a missing array
            what = (
                "a truncated or damaged file"
                if isinstance(exc, (zipfile.BadZipFile, zlib.error, EOFError))
                else "unreadable"
            )
            raise ValueError(
                f"{path}: not a readable simulation result, {what} ({type(exc).__name__}: {exc})"
            ) from exc
