"""Mesh convergence errors of the paper (eq. 1a, 1b) against a reference mesh's result."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from .result import SimulationResult


def interpolate_top_displacement(reference: SimulationResult, xy: np.ndarray, step: int = -1) -> np.ndarray:
    """The reference's top-surface displacement at step ``step`` interpolated at points ``xy``
    (n, 2). The top surface of a structured block is a tensor grid, so the interpolation is
    bilinear on it, as the mesh's own shape functions are."""
    x = np.unique(np.round(reference.top_xyz[:, 0], 9))
    y = np.unique(np.round(reference.top_xyz[:, 1], 9))
    if x.size * y.size != reference.top_xyz.shape[0]:
        raise ValueError("the reference's top surface is not a structured grid")
    ix = np.searchsorted(x, np.round(reference.top_xyz[:, 0], 9))
    iy = np.searchsorted(y, np.round(reference.top_xyz[:, 1], 9))
    grid = np.empty((x.size, y.size, 3))
    grid[ix, iy] = reference.displacement[step]
    interp = RegularGridInterpolator((x, y), grid, method="linear")
    return interp(np.clip(xy, [x[0], y[0]], [x[-1], y[-1]]))


@dataclass(frozen=True)
class MeshErrors:
    """E_f and E_u in percent; ``E_f_pct`` is eq. 1a as printed (with its 1/N_s factor),
    ``E_f_rel_pct`` the plain relative norm ||F - F_ref|| / ||F_ref|| (stricter by N_s)."""

    E_f_pct: float
    E_f_rel_pct: float
    E_u_pct: float


def mesh_errors(result: SimulationResult, reference: SimulationResult) -> MeshErrors:
    """Eq. 1a (forces over all steps) and eq. 1b (final top-surface displacements, the
    reference interpolated at the result's top nodes), in percent."""
    if result.depth.shape != reference.depth.shape or not np.allclose(result.depth, reference.depth):
        raise ValueError("result and reference must share the protocol (depths)")
    F, Fr = result.force[1:], reference.force[1:]
    rel = float(np.linalg.norm(F - Fr) / np.linalg.norm(Fr))
    n_steps = F.size
    u = result.displacement[-1]
    ur = interpolate_top_displacement(reference, result.top_xyz[:, :2])
    norm_r = np.linalg.norm(ur, axis=1)
    keep = norm_r > 1e-12
    E_u = float(np.mean(np.linalg.norm(u - ur, axis=1)[keep] / norm_r[keep]))
    return MeshErrors(100.0 * rel / n_steps, 100.0 * rel, 100.0 * E_u)
