"""The output differences between two meshes' runs at the same points (level 3 less level 4: the
log force per step and the top field at a surrogate's nodes), as
:class:`surrogate.mesh_differences.MeshDifferences`: what :mod:`.freed_mu_moves` carries through
the fit with mu free (``tools/make_mesh_differences.py`` writes the shipped ones)."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime

import numpy as np

from ...forward.result import SimulationResult
from ...surrogate.mesh_differences import MeshDifferences
from .mesh_check import prediction_at_nodes

__all__ = ["mesh_differences_from_runs"]


def mesh_differences_from_runs(
    pairs: Sequence[tuple[SimulationResult, SimulationResult]],
    top_xyz: np.ndarray,
    *,
    runs: Sequence[dict] | None = None,
    version: str = "",
) -> MeshDifferences:
    """The coarse runs' outputs less the fine runs' at ``top_xyz`` (a surrogate's top nodes).

    Parameters
    ----------
    pairs : sequence of (SimulationResult, SimulationResult)
        (coarse, fine) at each point, the same spec but the mesh.
    top_xyz : numpy.ndarray
        (nodes, 3) where the field is kept (both runs' fields interpolated there).
    runs : sequence of dict, optional
        What each pair was read from (files, versions), recorded in ``meta``.
    version : str, optional
        The studio's version, recorded in ``meta['made']``.

    Returns
    -------
    MeshDifferences

    Raises
    ------
    ValueError
        If a pair differs in c1, c5 or depths, or its fine run is not finer.
    """
    points, force_log, field = [], [], []
    for coarse, fine in pairs:
        theta = [coarse.spec["material"][k] for k in ("c1", "c5")]
        if not np.allclose(theta, [fine.spec["material"][k] for k in ("c1", "c5")]):
            raise ValueError(f"mesh differences: a pair at {theta} kPa was run at other parameters")
        if coarse.depth.shape != fine.depth.shape or not np.allclose(coarse.depth, fine.depth):
            raise ValueError(f"mesh differences: the pair at {theta} kPa was run to other depths")
        if int(fine.solver["mesh"]["nodes"]) <= int(coarse.solver["mesh"]["nodes"]):
            raise ValueError(f"mesh differences: the pair at {theta} kPa: the fine run is not finer")
        a, b = prediction_at_nodes(coarse, top_xyz), prediction_at_nodes(fine, top_xyz)
        points.append(theta)
        force_log.append(np.log(a.force[0]) - np.log(b.force[0]))
        field.append(a.displacement[0] - b.displacement[0])
    first_coarse, first_fine = pairs[0]
    meta = {
        "model": first_coarse.spec,
        "coarse_mesh": (first_coarse.spec.get("mesh") or {}).get("preset"),
        "fine_mesh": (first_fine.spec.get("mesh") or {}).get("preset"),
        "runs": list(runs or []),
        "made": {
            "by": "inference.budgets.mesh_difference_runs",
            "version": version,
            "at": datetime.now(UTC).isoformat(),
        },
    }
    return MeshDifferences(
        np.array(points), np.array(force_log), np.array(field), np.asarray(top_xyz, float), meta
    )
