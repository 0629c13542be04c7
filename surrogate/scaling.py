"""What a surrogate's regressors see: theta scaled to [0, 1] over the training box, in log or
linearly (:class:`InputScaler`), and the responses reduced to the fewest PCA components that keep
the reconstruction error under a tolerance (:func:`pca_reduction`); :func:`padded_jacobian` extends
a Jacobian by parameters a part does not depend on."""

from __future__ import annotations

import numpy as np
from sklearn.decomposition import PCA

__all__ = ["INPUT_SCALES", "InputScaler", "padded_jacobian", "pca_reduction"]

INPUT_SCALES = ("linear", "log")


def padded_jacobian(jacobian: np.ndarray, parameters: int) -> np.ndarray:
    """A Jacobian over the leading parameters extended with zero columns to ``parameters`` (the
    derivative of a part that does not depend on the trailing ones, e.g. mu: last axis)."""
    missing = parameters - jacobian.shape[-1]
    return np.pad(jacobian, [(0, 0)] * (jacobian.ndim - 1) + [(0, missing)])


class InputScaler:
    """theta -> x in [0, 1]^p over the box [lo, hi], linearly or in log(theta)."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, scale: str = "linear") -> None:
        if scale not in INPUT_SCALES:
            raise ValueError(f"input scale {scale!r}: use one of {', '.join(INPUT_SCALES)}")
        self.lo, self.hi, self.scale = np.asarray(lo, float), np.asarray(hi, float), scale
        if np.any(self.hi <= self.lo) or (scale == "log" and np.any(self.lo <= 0)):
            raise ValueError(
                f"training box {self.lo.tolist()} .. {self.hi.tolist()} cannot be scaled ({scale})"
            )

    def _t(self, theta: np.ndarray) -> np.ndarray:
        return np.log(theta) if self.scale == "log" else theta

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        a, b = self._t(self.lo), self._t(self.hi)
        return (self._t(np.asarray(theta, float)) - a) / (b - a)

    def derivative(self, theta: np.ndarray) -> np.ndarray:
        """dx/dtheta (n, p), diagonal."""
        a, b = self._t(self.lo), self._t(self.hi)
        theta = np.asarray(theta, float)
        d = 1.0 / theta if self.scale == "log" else np.ones_like(theta)
        return d / (b - a)


def pca_reduction(Y: np.ndarray, scale: np.ndarray, tol: float, max_components: int) -> PCA:
    """The smallest PCA whose reconstruction error, divided by ``scale`` (per column), stays
    under ``tol`` (max over the training rows of the RMS error)."""
    n_max = int(min(max_components, Y.shape[0] - 1, Y.shape[1]))
    full = PCA(n_components=n_max, svd_solver="full").fit(Y)
    scores = full.transform(Y)
    for k in range(1, n_max + 1):
        recon = scores[:, :k] @ full.components_[:k] + full.mean_
        err = np.sqrt(np.mean(((recon - Y) / scale) ** 2, axis=1)).max()
        if err <= tol:
            break
    pca = PCA(n_components=k, svd_solver="full").fit(Y)
    pca.reconstruction_error_ = float(err)
    return pca
