"""Training a surrogate on a campaign, with its validation recorded in the model's provenance."""

from __future__ import annotations

from pathlib import Path

from ..campaign.loader import CampaignData, load_campaign
from .base import FieldSurrogate, TrainingData
from .validation import k_fold_errors, prediction_errors

__all__ = ["SURROGATE_KINDS", "make_surrogate", "train_surrogate", "training_data"]

SURROGATE_KINDS = ("gp", "mlp")


def make_surrogate(kind: str, input_scale: str = "log", pca_tol: float = 1e-3, **kwargs) -> FieldSurrogate:
    """An untrained surrogate of ``kind``: 'gp' (scikit-learn) or 'mlp' (torch ensemble)."""
    if kind == "gp":
        from .gaussian_process import GaussianProcessSurrogate

        return GaussianProcessSurrogate(input_scale=input_scale, pca_tol=pca_tol, **kwargs)
    if kind == "mlp":
        from .mlp import MLPSurrogate

        return MLPSurrogate(input_scale=input_scale, pca_tol=pca_tol, **kwargs)
    raise ValueError(f"unknown surrogate kind {kind!r}; use 'gp' or 'mlp'")


def training_data(campaign: str | Path | CampaignData, runs_dir: str | Path = "runs") -> TrainingData:
    """A campaign (name, folder or loaded) as training data."""
    data = campaign if isinstance(campaign, CampaignData) else load_campaign(campaign, runs_dir)
    return TrainingData.from_campaign(data)


def train_surrogate(
    campaign: str | Path | CampaignData,
    kind: str = "gp",
    input_scale: str = "log",
    pca_tol: float = 1e-3,
    test_campaign: str | Path | CampaignData | None = None,
    kfold: int = 0,
    seed: int = 0,
    runs_dir: str | Path = "runs",
) -> FieldSurrogate:
    """Train a ``kind`` surrogate on ``campaign``; its errors on the training points, by ``kfold``
    cross-validation and on ``test_campaign`` go to ``model.meta['validation']`` (percent)."""
    data = training_data(campaign, runs_dir)
    model = make_surrogate(kind, input_scale, pca_tol).fit(data, seed=seed)
    validation = {"training": prediction_errors(model, data)}
    if kfold:
        validation["kfold"] = k_fold_errors(
            lambda: make_surrogate(kind, input_scale, pca_tol), data, kfold, seed
        )
    if test_campaign is not None:
        validation["test"] = prediction_errors(model, training_data(test_campaign, runs_dir))
    model.meta["validation"] = validation
    return model
