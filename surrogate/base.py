"""What the Gaussian-process and the MLP emulators share (:class:`FieldSurrogate`): input scaling,
the PCA reduction of the force curves and of the displacement field (their pieces:
:mod:`~indentation_studio.surrogate.scaling`), the reconstruction, the chain rule for Jacobians,
and the Predictor seam (docs/architecture.md, "The Predictor seam"). What a surrogate is trained on
is :mod:`~indentation_studio.surrogate.training_set`'s (``TrainingData``, importable from here
too).

Inputs: theta scaled to [0, 1] over the training box, in log (default) or linearly (``input_scale``);
log serves better because the response changes fastest at small c1 (README, "Surrogates").
Outputs: log(force) per step (relative force errors are what eq. 4a weighs) and the top-surface
displacement field (steps x nodes x 3), each reduced with scikit-learn's PCA to the components
that keep the training set's reconstruction error under ``pca_tol`` (force: relative; field:
relative to max |u| of each direction); the regressors learn the standardised component scores.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from ..forward.predictor import Prediction, ReducedBasis
from .scaling import INPUT_SCALES as INPUT_SCALES  # X as X: re-exported
from .scaling import InputScaler, pca_reduction
from .scaling import padded_jacobian as padded_jacobian
from .sklearn_state import estimator_from_state, estimator_state
from .training_set import TrainingData

#: A point whose nearest training point lies more than this many median training spacings away
#: (:meth:`FieldSurrogate.training_gap`) lies in a region without training points. Inside a
#: space-filling design every point of the box lies within about 1 of them.
SPARSE_GAP = 2.0


class FieldSurrogate(ABC):
    """An emulator of the forward model trained on a campaign; a Predictor.

    See docs/architecture.md, "The Predictor seam". The inputs are scaled to [0, 1] over the
    training box; the log-force and the displacement field are each reduced by PCA and the scores
    learned by the subclass's regressor (module docstring).

    Parameters
    ----------
    input_scale : {"log", "linear"}, default "log"
        How the parameters are scaled to [0, 1] over the training box.
    pca_tol : float, default 1e-3
        The reconstruction error of the training set the PCA components keep under.
    max_components : int, default 40
        At most this many PCA components per output.
    """

    kind = "abstract"
    #: Its errors at held-out points (``surrogate.emulation_error.EmulationError``), set by training
    #: with a test campaign or a k-fold; fits carry them in their bounds. None: not measured.
    emulation_error = None

    def kept_emulation_error(self):
        """The held-out errors its file keeps (:func:`surrogate.persistence.save_surrogate`).

        Returns
        -------
        EmulationError or None
            Here :attr:`emulation_error` itself; a multi-fidelity surrogate keeps its low level's.
        """
        return self.emulation_error

    def restore_emulation_error(self, kept) -> None:
        """Set :attr:`emulation_error` from what its file kept (:meth:`kept_emulation_error`).

        Parameters
        ----------
        kept : EmulationError or None
            The errors read from the file.
        """
        self.emulation_error = kept

    def __init__(self, input_scale: str = "log", pca_tol: float = 1e-3, max_components: int = 40) -> None:
        self.input_scale = input_scale
        self.training_theta: np.ndarray | None = None  # the campaign's points, kept for training_gap
        self.pca_tol = pca_tol
        self.max_components = max_components
        self.meta: dict[str, Any] = {}

    # ------------------------------------------------------------------ training
    def fit(self, data: TrainingData, seed: int = 0) -> FieldSurrogate:
        """Train on ``data``: the inputs scaled, log-force and field reduced by PCA, the scores regressed.

        Parameters
        ----------
        data : TrainingData
            Positive, finite parameters and forces.
        seed : int, default 0
            Seed of the regressor's training.

        Returns
        -------
        FieldSurrogate
            ``self``, trained; ``meta`` records the components, PCA errors, box and fit time.

        Raises
        ------
        ValueError
            If a parameter or a force is not positive and finite.
        """
        theta = np.asarray(data.theta, float)
        if not np.all(np.isfinite(theta)) or np.any(theta <= 0):
            raise ValueError("training parameters must be positive and finite")
        if np.any(~np.isfinite(data.force)) or np.any(data.force <= 0):
            raise ValueError("training forces must be positive and finite (the force is learned in log)")
        t0 = time.perf_counter()
        self.parameters = tuple(data.parameters)
        self.depth = np.asarray(data.depth, float)
        self.top_xyz = np.asarray(data.top_xyz, float)
        self.n_steps, self.n_nodes = data.displacement.shape[1], data.displacement.shape[2]
        self.scaler = InputScaler(theta.min(axis=0), theta.max(axis=0), self.input_scale)
        self.training_theta = theta.copy()
        logf = np.log(data.force)
        U = data.displacement.reshape(data.n, -1)
        u_max = np.abs(data.displacement).max(axis=(0, 1, 2))  # per direction
        u_scale = np.broadcast_to(np.maximum(u_max, 1e-12), data.displacement.shape[1:]).reshape(-1)
        self.force_pca = pca_reduction(logf, np.ones(logf.shape[1]), self.pca_tol, self.max_components)
        self.field_pca = pca_reduction(U, u_scale, self.pca_tol, self.max_components)
        scores = np.hstack([self.force_pca.transform(logf), self.field_pca.transform(U)])
        self.score_mean, self.score_std = scores.mean(axis=0), scores.std(axis=0) + 1e-300
        self.k_force = self.force_pca.n_components_
        X = self.scaler(theta)
        self._fit_regressor(X, (scores - self.score_mean) / self.score_std, seed)
        self.meta.update(
            {
                "kind": self.kind,
                "input_scale": self.input_scale,
                "training_points": int(data.n),
                "force_components": int(self.k_force),
                "field_components": int(self.field_pca.n_components_),
                "pca_tol": self.pca_tol,
                "force_pca_error": self.force_pca.reconstruction_error_,
                "field_pca_error": self.field_pca.reconstruction_error_,
                "box": [self.scaler.lo.tolist(), self.scaler.hi.tolist()],
                "fit_s": time.perf_counter() - t0,
                "campaign": data.source,
            }
        )
        return self

    @abstractmethod
    def _fit_regressor(self, X: np.ndarray, T: np.ndarray, seed: int) -> None: ...

    @abstractmethod
    def _regress(self, X: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """Standardised scores (n, k) at scaled inputs X (n, p) and, if asked, d scores / dX (n, k, p)."""

    def _score_function(self) -> Callable[[np.ndarray], np.ndarray]:
        """Standardised scores (n, k) at scaled inputs X (n, p), without derivatives, as a function
        prepared once and called many times (by a sampler); the same numbers as ``_regress``."""
        return lambda X: self._regress(X, False)[0]

    # ------------------------------------------------------------------ prediction
    def _checked_theta(self, theta) -> np.ndarray:
        theta = np.atleast_2d(np.asarray(theta, float))
        if theta.shape[1] != len(self.parameters):
            raise ValueError(
                f"theta must have {len(self.parameters)} columns {self.parameters}, got {theta.shape}"
            )
        if not np.all(np.isfinite(theta)) or np.any(theta <= 0):
            raise ValueError("parameters must be positive and finite")
        return theta

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        """Force curves and fields at ``theta``; with ``jacobian`` also their derivatives.

        Parameters
        ----------
        theta : array_like
            (n, p) points, kPa.
        jacobian : bool, default False
            Also d force / d theta and d u / d theta.

        Returns
        -------
        Prediction
            Forces (mN), top-surface displacements (mm) and, if asked, their Jacobians.
        """
        theta = self._checked_theta(theta)
        T, dT = self._regress(self.scaler(theta), jacobian)
        S = T * self.score_std + self.score_mean
        kf = self.k_force
        logf = S[:, :kf] @ self.force_pca.components_ + self.force_pca.mean_
        force = np.exp(logf)
        U = S[:, kf:] @ self.field_pca.components_ + self.field_pca.mean_
        disp = U.reshape(len(theta), self.n_steps, self.n_nodes, 3)
        fj = dj = None
        if jacobian:
            dS = dT * self.score_std[None, :, None] * self.scaler.derivative(theta)[:, None, :]  # (n, k, p)
            fj = force[..., None] * np.einsum("kt,nkp->ntp", self.force_pca.components_, dS[:, :kf])
            dU = np.einsum("kt,nkp->ntp", self.field_pca.components_, dS[:, kf:])
            dj = dU.reshape(len(theta), self.n_steps, self.n_nodes, 3, -1)
        return Prediction(force, disp, self.depth, self.top_xyz, self.parameters, fj, dj)

    def reduced_basis(self) -> ReducedBasis:
        """The prediction as affine maps of the PCA scores (log force and field), scores as a function of theta.

        What lets an objective skip rebuilding the fields (design/reduced_objective.py). The
        regressor is prepared once for repeated calls.

        Returns
        -------
        ReducedBasis
            Means, bases and the coordinates function.
        """
        regress, scaler = self._score_function(), self.scaler
        mean, std, kf = self.score_mean, self.score_std, self.k_force

        def coordinates(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            S = regress(scaler(self._checked_theta(theta))) * std + mean
            return S[:, :kf], S[:, kf:]

        return ReducedBasis(
            force_mean=self.force_pca.mean_,
            force_basis=self.force_pca.components_,
            field_mean=self.field_pca.mean_,
            field_basis=self.field_pca.components_,
            steps=self.n_steps,
            nodes=self.n_nodes,
            coordinates=coordinates,
        )

    # ------------------------------------------------------------------ saving (no pickle)
    def hyperparameters(self) -> dict[str, Any]:
        """The constructor's arguments: what makes an untrained surrogate of this kind."""
        return {
            "input_scale": self.input_scale,
            "pca_tol": self.pca_tol,
            "max_components": self.max_components,
        }

    def to_state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The trained surrogate as (JSON-ready configuration, named arrays), nothing pickled.

        :meth:`from_state` rebuilds it with bit-for-bit the same predictions.

        Returns
        -------
        config : dict
            Kind, hyperparameters, parameters, sizes and the estimators' configurations.
        arrays : dict of str to numpy.ndarray
            The named arrays.
        """
        force_pca, force_arrays = estimator_state(self.force_pca, "force_pca")
        field_pca, field_arrays = estimator_state(self.field_pca, "field_pca")
        regressor, regressor_arrays = self._regressor_state()
        config = {
            "kind": self.kind,
            "hyperparameters": self.hyperparameters(),
            "parameters": list(self.parameters),
            "n_steps": int(self.n_steps),
            "n_nodes": int(self.n_nodes),
            "k_force": int(self.k_force),
            "input_scale": self.scaler.scale,
            "force_pca": force_pca,
            "field_pca": field_pca,
            "regressor": regressor,
        }
        arrays = {
            "depth": self.depth,
            "top_xyz": self.top_xyz,
            "scaler.lo": self.scaler.lo,
            "scaler.hi": self.scaler.hi,
            "score_mean": self.score_mean,
            "score_std": self.score_std,
            **({} if self.training_theta is None else {"training_theta": self.training_theta}),
            **force_arrays,
            **field_arrays,
            **regressor_arrays,
        }
        return config, arrays

    @classmethod
    def from_state(cls, config: dict[str, Any], arrays: dict[str, np.ndarray]) -> FieldSurrogate:
        """The surrogate that :meth:`to_state` described (``cls`` must be of its ``kind``).

        Parameters
        ----------
        config : dict
            The JSON-ready configuration.
        arrays : dict of str to numpy.ndarray
            The named arrays.

        Returns
        -------
        FieldSurrogate
            The surrogate, with bit-for-bit the same predictions.
        """
        if config["kind"] != cls.kind:
            raise ValueError(f"a {config['kind']!r} surrogate cannot be rebuilt as {cls.kind!r}")
        missing = [
            k
            for k in ("depth", "top_xyz", "scaler.lo", "scaler.hi", "score_mean", "score_std")
            if k not in arrays
        ]
        if missing:
            raise KeyError(f"arrays {missing} missing")
        model = cls(**config["hyperparameters"])
        model.parameters = tuple(config["parameters"])
        model.n_steps, model.n_nodes, model.k_force = config["n_steps"], config["n_nodes"], config["k_force"]
        model.depth, model.top_xyz = arrays["depth"], arrays["top_xyz"]
        model.scaler = InputScaler(arrays["scaler.lo"], arrays["scaler.hi"], config["input_scale"])
        model.score_mean, model.score_std = arrays["score_mean"], arrays["score_std"]
        model.training_theta = arrays.get("training_theta")  # None in files written before it was kept
        model.force_pca = estimator_from_state(config["force_pca"], arrays, "force_pca")
        model.field_pca = estimator_from_state(config["field_pca"], arrays, "field_pca")
        model._restore_regressor(config["regressor"], arrays)
        return model

    @abstractmethod
    def _regressor_state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The fitted regressor as (JSON-ready configuration, named arrays)."""

    @abstractmethod
    def _restore_regressor(self, config: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        """Set the regressor that :meth:`_regressor_state` described."""

    def training_gap(self, theta) -> np.ndarray:
        """How far each point lies from the nearest training point, in median training spacings.

        The distance is measured in the scaled inputs the regressor sees, in units of the training
        points' own median nearest-neighbour spacing. About 1 or below: the point lies among
        training points; well above (``SPARSE_GAP``): in a region without them (a corner of the box,
        or a hole left by campaign points that did not converge), where the surrogate interpolates
        over a long way.

        Parameters
        ----------
        theta : array_like
            (n, p) points, kPa.

        Returns
        -------
        numpy.ndarray
            (n,) gaps; NaN for a surrogate saved before its training points were kept.
        """
        theta = np.atleast_2d(np.asarray(theta, float))
        if self.training_theta is None or len(self.training_theta) < 2:
            return np.full(len(theta), np.nan)
        tree = cKDTree(self.scaler(self.training_theta))
        spacing = float(np.median(tree.query(tree.data, k=2)[0][:, 1]))
        return tree.query(self.scaler(theta))[0] / max(spacing, 1e-12)

    def inside_box(self, theta) -> np.ndarray:
        """Which points lie in the training box (the surrogate extrapolates outside it).

        Parameters
        ----------
        theta : array_like
            (n, p) points, kPa.

        Returns
        -------
        numpy.ndarray
            (n,) bool.
        """
        theta = np.atleast_2d(np.asarray(theta, float))
        return np.all((theta >= self.scaler.lo - 1e-12) & (theta <= self.scaler.hi + 1e-12), axis=1)
