"""Gaussian-process emulator (scikit-learn): one GaussianProcessRegressor for the force scores and
one for the field scores, each with an anisotropic Matern 5/2 kernel times a constant plus a white
noise term, hyperparameters by maximum marginal likelihood with restarts. The mean's derivative
with respect to the scaled inputs is analytic for this kernel: d k(x, x_i) / dx times alpha.

The mean at new points, k(x, X_train) alpha, is evaluated by :class:`GaussianProcessMeans` from
arrays prepared once (the training inputs divided by the length scales): the white-noise term is
zero between distinct points, so only the constant x Matern part enters, and a sampler's many
small batches skip scikit-learn's per-call validation and kernel-object dispatch."""

from __future__ import annotations

import numpy as np
from scipy.spatial.distance import cdist
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern, Product, Sum, WhiteKernel

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


class GaussianProcessMeans:
    """The posterior means of fitted GaussianProcessRegressors with the kernel this module builds
    (constant x Matern 5/2 + white), side by side: X (n, p) -> (n, sum of their outputs). The same
    numbers as ``gp.predict`` (k(x, X_train) alpha, scaled back), without per-call overhead."""

    def __init__(self, gps: list[GaussianProcessRegressor]) -> None:
        self.blocks = []
        for gp in gps:
            kernel = gp.kernel_
            ok = (
                isinstance(kernel, Sum)
                and isinstance(kernel.k1, Product)
                and isinstance(kernel.k1.k1, ConstantKernel)
                and isinstance(kernel.k1.k2, Matern)
                and kernel.k1.k2.nu == 2.5
                and isinstance(kernel.k2, WhiteKernel)
            )
            if not ok:
                raise ValueError(f"GaussianProcessMeans needs constant x Matern 5/2 + white, got {kernel}")
            length = np.broadcast_to(np.asarray(kernel.k1.k2.length_scale, float), (gp.X_train_.shape[1],))
            alpha = gp.alpha_.reshape(len(gp.X_train_), -1)
            # scikit-learn's normalize_y (False here: std 1, mean 0) undone as gp.predict does
            y_std = np.broadcast_to(np.asarray(getattr(gp, "_y_train_std", 1.0), float), alpha.shape[1:])
            y_mean = np.broadcast_to(np.asarray(getattr(gp, "_y_train_mean", 0.0), float), alpha.shape[1:])
            amplitude = float(kernel.k1.k1.constant_value)
            self.blocks.append((gp.X_train_ / length, length.copy(), amplitude, alpha, y_std, y_mean))

    def __call__(self, X: np.ndarray) -> np.ndarray:
        out = []
        for X_train, length, amplitude, alpha, y_std, y_mean in self.blocks:
            K = cdist(X / length, X_train) * np.sqrt(5.0)
            K = amplitude * ((1.0 + K + K**2 / 3.0) * np.exp(-K))
            out.append(y_std * (K @ alpha) + y_mean)
        return np.hstack(out)


class GaussianProcessSurrogate(FieldSurrogate):
    """A surrogate whose PCA scores are learned by scikit-learn Gaussian processes (module docstring).

    Parameters
    ----------
    restarts : int, default 3
        Restarts of the optimiser of the marginal likelihood.
    per_component : bool, default False
        One GP per PCA score; otherwise one GP for the force scores and one for the field's.
    **kwargs
        ``input_scale``, ``pca_tol``, ``max_components`` of :class:`FieldSurrogate`.
    """

    kind = "gp"

    def __init__(self, restarts: int = 3, per_component: bool = False, **kwargs) -> None:
        super().__init__(**kwargs)
        self.restarts = restarts
        self.per_component = per_component

    def hyperparameters(self) -> dict:
        """The constructor's arguments: :meth:`FieldSurrogate.hyperparameters` with the GP's."""
        return {**super().hyperparameters(), "restarts": self.restarts, "per_component": self.per_component}

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
        if self.per_component:
            blocks = [slice(j, j + 1) for j in range(T.shape[1])]
        else:
            blocks = [slice(0, self.k_force), slice(self.k_force, T.shape[1])]
        for block in blocks:
            kernel = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(
                length_scale=np.full(p, 0.5), length_scale_bounds=(1e-2, 1e2), nu=2.5
            ) + WhiteKernel(1e-6, (1e-12, 1e-2))
            gp = GaussianProcessRegressor(
                kernel, n_restarts_optimizer=self.restarts, normalize_y=False, random_state=seed
            )
            gp.fit(X, T[:, block])
            self.gps.append(gp)
        self.meta["kernels"] = [str(gp.kernel_) for gp in self.gps]

    def _score_function(self):
        return GaussianProcessMeans(self.gps)

    def _regress(self, X: np.ndarray, jacobian: bool):
        T = GaussianProcessMeans(self.gps)(X)
        if not jacobian:
            return T, None
        grads = []
        for gp in self.gps:
            kern = gp.kernel_.k1  # Constant * Matern (the white term has no gradient)
            amp, length = kern.k1.constant_value, np.broadcast_to(kern.k2.length_scale, (X.shape[1],))
            dk = _matern52_gradient(X, gp.X_train_, np.asarray(length, float), amp)  # (n, m, p)
            alpha = gp.alpha_.reshape(len(gp.X_train_), -1)  # (m, k)
            grads.append(np.einsum("nmp,mk->nkp", dk, alpha))
        return T, np.concatenate(grads, axis=1)

    def predict_std(self, theta) -> np.ndarray:
        """The GP's standard deviation of the standardised scores: how far from its data a point is.

        For deciding where to add simulations.

        Parameters
        ----------
        theta : array_like
            (n, p) points, kPa.

        Returns
        -------
        numpy.ndarray
            (n, k) one column per score.
        """
        X = self.scaler(np.atleast_2d(np.asarray(theta, float)))
        return np.hstack([gp.predict(X, return_std=True)[1].reshape(len(X), -1) for gp in self.gps])
