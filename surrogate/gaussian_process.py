"""Gaussian-process emulator (scikit-learn): one GaussianProcessRegressor for the force scores and
one for the field scores, each with an anisotropic Matern 5/2 kernel times a constant plus a white
noise term, hyperparameters by maximum marginal likelihood with restarts. The mean's derivative
with respect to the scaled inputs is analytic for this kernel: d k(x, x_i) / dx times alpha."""

from __future__ import annotations

import numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

from .base import FieldSurrogate
from .sklearn_state import estimator_from_state, estimator_state


def _matern52_gradient(X: np.ndarray, Xt: np.ndarray, length: np.ndarray, amplitude: float) -> np.ndarray:
    """d k(x, x_t) / dx (n, m, p) for amplitude * Matern 5/2 with per-axis ``length``."""
    D = (X[:, None, :] - Xt[None, :, :]) / length  # (n, m, p)
    r = np.sqrt(np.sum(D**2, axis=-1))  # (n, m)
    s5 = np.sqrt(5.0)
    # k = a (1 + s5 r + 5 r^2 / 3) exp(-s5 r); dk/dr = -a (5 r / 3)(1 + s5 r) exp(-s5 r)
    # dr/dx = D / (r length): dk/dx = -a (5 / 3)(1 + s5 r) exp(-s5 r) D / length
    g = -amplitude * (5.0 / 3.0) * (1.0 + s5 * r) * np.exp(-s5 * r)
    return g[..., None] * D / length


class GaussianProcessSurrogate(FieldSurrogate):
    kind = "gp"

    def __init__(self, restarts: int = 3, **kwargs) -> None:
        super().__init__(**kwargs)
        self.restarts = restarts

    def hyperparameters(self) -> dict:
        return {**super().hyperparameters(), "restarts": self.restarts}

    def _regressor_state(self):
        configs, arrays = [], {}
        for i, gp in enumerate(self.gps):
            config, gp_arrays = estimator_state(gp, f"gp{i}")
            configs.append(config)
            arrays.update(gp_arrays)
        return {"gps": configs}, arrays

    def _restore_regressor(self, config, arrays) -> None:
        self.gps = [estimator_from_state(c, arrays, f"gp{i}") for i, c in enumerate(config["gps"])]

    def _fit_regressor(self, X: np.ndarray, T: np.ndarray, seed: int) -> None:
        p = X.shape[1]
        self.gps = []
        for block in (slice(0, self.k_force), slice(self.k_force, T.shape[1])):
            kernel = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(
                length_scale=np.full(p, 0.5), length_scale_bounds=(1e-2, 1e2), nu=2.5
            ) + WhiteKernel(1e-6, (1e-12, 1e-2))
            gp = GaussianProcessRegressor(
                kernel, n_restarts_optimizer=self.restarts, normalize_y=False, random_state=seed
            )
            gp.fit(X, T[:, block])
            self.gps.append(gp)
        self.meta["kernels"] = [str(gp.kernel_) for gp in self.gps]

    def _regress(self, X: np.ndarray, jacobian: bool):
        means, grads = [], []
        for gp in self.gps:
            mean = gp.predict(X)
            means.append(mean.reshape(len(X), -1))
            if jacobian:
                kern = gp.kernel_.k1  # Constant * Matern (the white term has no gradient)
                amp, length = kern.k1.constant_value, np.broadcast_to(kern.k2.length_scale, (X.shape[1],))
                dk = _matern52_gradient(X, gp.X_train_, np.asarray(length, float), amp)  # (n, m, p)
                alpha = gp.alpha_.reshape(len(gp.X_train_), -1)  # (m, k)
                grads.append(np.einsum("nmp,mk->nkp", dk, alpha))
        T = np.hstack(means)
        return T, (np.concatenate(grads, axis=1) if jacobian else None)

    def predict_std(self, theta) -> np.ndarray:
        """The GP's standard deviation of the standardised scores (n, k): how far from its data a
        point is, for deciding where to add simulations."""
        X = self.scaler(np.atleast_2d(np.asarray(theta, float)))
        return np.hstack([gp.predict(X, return_std=True)[1].reshape(len(X), -1) for gp in self.gps])
