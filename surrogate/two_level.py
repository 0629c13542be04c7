"""The shape shared by surrogates that predict through two trained surrogates, the second correcting
the first: the multi-fidelity surrogate (a coarse mesh's surrogate and a GP of its discrepancy from
a finer mesh) and the stick-plus-slip surrogate (a perfect-stick surrogate and an MLP of what slip
changes). What they share is how they are kept: the first level's record inside theirs, and both
levels' states in one file under their names; how they predict is each one's own."""

from __future__ import annotations

from abc import abstractmethod
from typing import Any, ClassVar

import numpy as np

from .base import FieldSurrogate, TrainingData
from .registry import surrogate_class

__all__ = ["TwoLevelSurrogate", "model_differences"]

# the parts of the two levels' FE models that must agree (the mesh, the solver and the contact may differ)
SHARED_MODEL_PARTS = ("geometry", "indenter", "protocol")


def model_differences(low: dict[str, Any], high: dict[str, Any]) -> list[str]:
    """The parts of two campaigns' FE model specs (campaign.json ``model``) that differ and must not.

    Parameters
    ----------
    low, high : dict
        The two specs (the first level's campaign's, the second's).

    Returns
    -------
    list of str
        Geometry, indenter and protocol where they differ; empty when they agree.
    """
    return [
        f"{part}: {low.get(part)} (low) vs {high.get(part)} (high)"
        for part in SHARED_MODEL_PARTS
        if low.get(part) != high.get(part)
    ]


class TwoLevelSurrogate(FieldSurrogate):
    """A surrogate made of two trained surrogates, saved as one.

    The base of :class:`surrogate.multi_fidelity.MultiFidelitySurrogate` and
    :class:`surrogate.slip_surrogate.SlipSurrogate`. A subclass names its two levels' attributes in ``levels`` (the first, the one the second
    corrects, is set before ``FieldSurrogate.__init__`` runs), the key of the first level's record
    in its own ``meta`` in ``first_meta_key``, and rebuilds itself from the two levels in
    :meth:`_from_levels`.

    Attributes
    ----------
    levels : tuple of str
        The attributes holding the two levels, the corrected one first.
    first_meta_key : str
        Where the first level's ``meta`` is kept in this one's.
    """

    levels: ClassVar[tuple[str, str]]
    first_meta_key: ClassVar[str]

    @property
    def meta(self) -> dict[str, Any]:
        """The surrogate's record (provenance, validation, error budget); the first level's inside it."""
        return self._meta

    @meta.setter
    def meta(self, value: dict[str, Any]) -> None:
        """A loaded model gets its meta after it is built: the first level's goes back to it."""
        self._meta = value
        if self.first_meta_key in value:
            getattr(self, self.levels[0]).meta = value[self.first_meta_key]

    def _same_test_problems(self, data: TrainingData, labels: tuple[str, str]) -> list[str]:
        """Where the campaign ``data`` (the second level's) does not describe the first level's test:
        its depths, and the parts of its FE model that must agree (:func:`model_differences`)."""
        first = getattr(self, self.levels[0])
        problems = []
        depth = np.asarray(data.depth, float)
        if depth.shape != first.depth.shape or not np.allclose(depth, first.depth, rtol=0, atol=1e-9):
            problems.append(
                f"depths: {len(first.depth)} steps to {first.depth[-1]:g} mm ({labels[0]}) vs "
                f"{len(depth)} steps to {depth[-1]:g} mm ({labels[1]})"
            )
        first_model = (first.meta.get("campaign") or {}).get("model")
        model = (data.source or {}).get("model")
        if first_model is not None and model is not None:
            problems += model_differences(first_model, model)
        return problems

    @staticmethod
    def _correction_data(data: TrainingData, force: np.ndarray, displacement: np.ndarray) -> TrainingData:
        """What the second level learns at the campaign's points: F / F_first (learned in log) and
        u - u_first, with the first level's prediction ``force``, ``displacement`` there."""
        return TrainingData(
            data.theta,
            data.force / force,
            data.displacement - displacement,
            data.depth,
            data.top_xyz,
            tuple(data.parameters),
            data.source,
        )

    # the single-level regressor hooks: these surrogates fit and predict through their two levels
    def _fit_regressor(self, X: np.ndarray, T: np.ndarray, seed: int) -> None:
        raise NotImplementedError(f"a {self.kind!r} surrogate fits its second level in fit()")

    def _regress(self, X: np.ndarray, jacobian: bool):
        raise NotImplementedError(f"a {self.kind!r} surrogate predicts through its two levels")

    def _regressor_state(self):
        raise NotImplementedError(f"a {self.kind!r} surrogate saves its two levels in to_state()")

    def _restore_regressor(self, config, arrays) -> None:
        raise NotImplementedError(f"a {self.kind!r} surrogate restores its two levels in from_state()")

    def to_state(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Both levels' states, each level's arrays under its name (``low.``, ``discrepancy.``, ...).

        Returns
        -------
        config : dict
            Kind, hyperparameters, parameters and both levels' configurations.
        arrays : dict of str to numpy.ndarray
            The named arrays.
        """
        config = {
            "kind": self.kind,
            "hyperparameters": self.hyperparameters(),
            "parameters": list(self.parameters),
        }
        arrays: dict[str, np.ndarray] = {}
        for name in self.levels:
            level_config, level_arrays = getattr(self, name).to_state()
            config[name] = level_config
            arrays |= {f"{name}.{k}": v for k, v in level_arrays.items()}
        return config, arrays

    @classmethod
    def from_state(cls, config: dict[str, Any], arrays: dict[str, np.ndarray]) -> TwoLevelSurrogate:
        """The surrogate that :meth:`to_state` described.

        Parameters
        ----------
        config : dict
            Both levels' configurations.
        arrays : dict of str to numpy.ndarray
            The arrays under each level's name.

        Returns
        -------
        TwoLevelSurrogate
            The surrogate, with bit-for-bit the same predictions.
        """
        if config["kind"] != cls.kind:
            raise ValueError(f"a {config['kind']!r} surrogate cannot be rebuilt as {cls.kind!r}")

        def level(name: str) -> FieldSurrogate:
            prefix = f"{name}."
            own = {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix)}
            return surrogate_class(config[name]["kind"]).from_state(config[name], own)

        first, second = (level(name) for name in cls.levels)
        model = cls._from_levels(config, first, second)
        model.parameters = tuple(config["parameters"])
        model.depth, model.top_xyz = second.depth, second.top_xyz
        model.n_steps, model.n_nodes = second.n_steps, second.n_nodes
        return model

    @classmethod
    @abstractmethod
    def _from_levels(
        cls, config: dict[str, Any], first: FieldSurrogate, second: FieldSurrogate
    ) -> TwoLevelSurrogate:
        """The surrogate from its two rebuilt levels (its sizes and parameters are set after)."""
