"""The low level as a multi-fidelity surrogate's discrepancy sees it (:mod:`surrogate.multi_fidelity`,
eq. 1 and 2): W, the fixed linear interpolation from the low level's top nodes to the high
level's, and a stick-plus-slip low level held at the mu its stick campaign is compared at."""

from __future__ import annotations

import numpy as np
from scipy import sparse

from ..forward.convergence.mesh_study import top_field_interpolator
from ..forward.predictor import FixedParameter
from .slip_surrogate import SlipSurrogate

__all__ = ["LowAtStickMu", "interpolation_matrix"]


def interpolation_matrix(source_xyz: np.ndarray, target_xyz: np.ndarray) -> sparse.csr_array:
    """W (targets, sources) with ``W @ f`` equal to ``top_field_interpolator(source_xyz, f)`` at
    ``target_xyz`` for any field f (sources, ...): that interpolation (bilinear on a tensor grid,
    linear on Delaunay triangles otherwise) is linear in f, so W's columns interpolate unit vectors."""
    source_xyz, target_xyz = np.asarray(source_xyz, float), np.asarray(target_xyz, float)
    W = top_field_interpolator(source_xyz, np.eye(len(source_xyz)))(target_xyz)
    outside = ~np.all(np.isfinite(W), axis=1)
    if outside.any():
        raise ValueError(
            f"{int(outside.sum())} high-fidelity top nodes (e.g. {target_xyz[outside][0, :2].tolist()} mm) "
            "lie outside the triangulation of the low-fidelity top nodes"
        )
    W[np.abs(W) < 1e-13] = 0.0  # rounding of the interpolants of unit vectors
    return sparse.csr_array(W)


class LowAtStickMu(FixedParameter):
    """A stick-plus-slip low level at the mu a stick campaign is compared at (eq. 2): a Predictor
    over (c1, c5) whose box is its stick surrogate's (the slip's change is learned from a
    space-filling design a little inside that box, c1 from 1.016 rather than 1 kPa in the shipped
    ones; a fit on the multi-fidelity surrogate reads it there already, its box the discrepancy's)."""

    def __init__(self, low: SlipSurrogate, mu: float) -> None:
        super().__init__(low, "mu", mu)
        self.scaler = low.stick.scaler

    def inside_box(self, theta) -> np.ndarray:
        """Which (c1, c5) points lie in the stick surrogate's box.

        Parameters
        ----------
        theta : array_like
            (n, 2) points, kPa.

        Returns
        -------
        numpy.ndarray
            (n,) bool.
        """
        return self.predictor.stick.inside_box(theta)
