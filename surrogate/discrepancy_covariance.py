"""What a multi-fidelity surrogate's discrepancy GP says of its own uncertainty at a point: a factor
of its predictive covariance in the output space and its standard deviations
(:class:`surrogate.multi_fidelity.MultiFidelitySurrogate`, what a fit adds to its bounds as model
error)."""

from __future__ import annotations

import numpy as np

__all__ = ["DiscrepancyCovariance"]


class DiscrepancyCovariance:
    """The discrepancy's predictive covariance, a base of
    :class:`~surrogate.multi_fidelity.MultiFidelitySurrogate` (which holds ``discrepancy``, a
    :class:`~surrogate.gaussian_process.GaussianProcessSurrogate`, and maps theta to its inputs)."""

    def discrepancy_covariance_factor(self, theta) -> np.ndarray:
        """A factor L of the discrepancy's predictive covariance L^T L at one point, in the output space.

        The output space is log force (steps) then the field (steps x nodes x 3, mm): row j is
        score j's GP standard deviation times its score scale times its PCA component (the
        scores' GPs are independent). Zero rows in the other part's columns.

        Parameters
        ----------
        theta : array_like
            (p,) one point, kPa.

        Returns
        -------
        numpy.ndarray
            (k, steps + steps * nodes * 3) L.

        Raises
        ------
        ValueError
            If more than one point is given.
        """
        theta = self._checked_theta(theta)
        if len(theta) != 1:
            raise ValueError(f"one parameter point at a time, got {len(theta)}")
        d = self.discrepancy
        scale = d.predict_std(self._discrepancy_theta(theta))[0] * d.score_std  # (k,): score units
        kf, n_force = d.k_force, d.force_pca.components_.shape[1]
        L = np.zeros((len(scale), n_force + d.field_pca.components_.shape[1]))
        L[:kf, :n_force] = scale[:kf, None] * d.force_pca.components_
        L[kf:, n_force:] = scale[kf:, None] * d.field_pca.components_
        return L

    def discrepancy_std(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """The discrepancy's predictive standard deviations at one point: the diagonal of L^T L.

        Parameters
        ----------
        theta : array_like
            (p,) one point, kPa.

        Returns
        -------
        force_sd : numpy.ndarray
            (steps,) of log force.
        field_sd : numpy.ndarray
            (steps, nodes, 3) of the field, mm.
        """
        L = self.discrepancy_covariance_factor(theta)
        sd = np.sqrt(np.einsum("ko,ko->o", L, L))
        return sd[: self.n_steps], sd[self.n_steps :].reshape(self.n_steps, self.n_nodes, 3)
