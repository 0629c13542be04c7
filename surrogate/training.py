"""Training a surrogate on a campaign, with its validation recorded in the model's provenance."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..campaign.loader import CampaignData, load_campaign
from .base import FieldSurrogate, TrainingData
from .error_budgets import surrogate_error_budget
from .validation import k_fold_errors, prediction_errors

if TYPE_CHECKING:
    from .multi_fidelity import MultiFidelitySurrogate

__all__ = ["SURROGATE_KINDS", "make_surrogate", "train_multi_fidelity", "train_surrogate", "training_data"]

#: The kinds trained on one campaign; a multi-fidelity surrogate ('mf') is trained on a second
#: campaign from one of them (:func:`train_multi_fidelity`).
SURROGATE_KINDS = ("gp", "mlp")


def make_surrogate(kind: str, input_scale: str = "log", pca_tol: float = 1e-3, **kwargs) -> FieldSurrogate:
    """An untrained surrogate of ``kind``: 'gp' (scikit-learn) or 'mlp' (torch ensemble)."""
    if kind == "gp":
        from .gaussian_process import GaussianProcessSurrogate

        return GaussianProcessSurrogate(input_scale=input_scale, pca_tol=pca_tol, **kwargs)
    if kind == "mlp":
        from .mlp import MLPSurrogate

        return MLPSurrogate(input_scale=input_scale, pca_tol=pca_tol, **kwargs)
    if kind == "mf":
        raise ValueError(
            "a multi-fidelity surrogate ('mf') is made from a trained low-fidelity surrogate and a "
            "high-fidelity campaign: use train_multi_fidelity"
        )
    raise ValueError(f"unknown surrogate kind {kind!r}; use 'gp' or 'mlp'")


def training_data(campaign: str | Path | CampaignData, runs_dir: str | Path = "runs") -> TrainingData:
    """A campaign (name, folder or loaded) as training data."""
    data = campaign if isinstance(campaign, CampaignData) else load_campaign(campaign, runs_dir)
    return TrainingData.from_campaign(data)


def train_surrogate(
    campaign: str | Path | CampaignData,
    kind: str = "gp",
    *,
    input_scale: str = "log",
    pca_tol: float = 1e-3,
    test_campaign: str | Path | CampaignData | None = None,
    kfold: int = 0,
    seed: int = 0,
    runs_dir: str | Path = "runs",
    error_budget: dict | None = None,
) -> FieldSurrogate:
    """Train a ``kind`` surrogate on ``campaign``; its errors on the training points, by ``kfold``
    cross-validation and on ``test_campaign`` go to ``model.meta['validation']`` (percent).
    ``error_budget`` (what a budget leaves for the campaign's mesh,
    :func:`surrogate.error_budgets.remaining_bias`; default: the studio's shipped budget for that
    mesh and test, if any) goes to meta['error_budget']: fits carry it in their bounds."""
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
    _record_error_budget(model, error_budget)
    return model


def _record_error_budget(model: FieldSurrogate, error_budget: dict | None) -> None:
    """meta['error_budget']: the one given, else the shipped one for the FE model the surrogate
    emulates, else None (fits then say their bounds hold no model error)."""
    model.meta.pop("error_budget", None)
    known = error_budget if error_budget is not None else surrogate_error_budget(model)
    model.meta["error_budget"] = None if known is None else dict(known)


def train_multi_fidelity(
    low: str | Path | FieldSurrogate,
    high_campaign: str | Path | CampaignData,
    pca_tol: float = 1e-3,
    max_components: int = 8,
    folds: int = 5,
    test_campaign: str | Path | CampaignData | None = None,
    seed: int = 0,
    runs_dir: str | Path = "runs",
    error_budget: dict | None = None,
) -> MultiFidelitySurrogate:
    """A multi-fidelity surrogate: ``low`` (a surrogate file or a trained surrogate, e.g. on a
    large campaign on a coarser mesh) corrected by the GP of its discrepancy from
    ``high_campaign`` (a few tens of points on the finer mesh, same test). It predicts the high
    fidelity on the high campaign's top nodes, and its FE model (meta['campaign']) is the high
    campaign's. The discrepancy's ``folds``-fold errors go to meta['discrepancy_kfold'] (force %,
    field mm); its errors on the training points and on ``test_campaign`` (percent, as for
    :func:`train_surrogate`) to meta['validation']. ``error_budget`` (what the budget leaves for the
    high-fidelity mesh, :func:`surrogate.error_budgets.remaining_bias`; default: the shipped budget for
    that mesh and test, if any) goes to meta['error_budget'], where fits read the systematic part
    of their model error."""
    from .multi_fidelity import MultiFidelitySurrogate
    from .persistence import load_surrogate

    low_model = low if isinstance(low, FieldSurrogate) else load_surrogate(low)
    data = training_data(high_campaign, runs_dir)
    model = MultiFidelitySurrogate(
        low_model, pca_tol=pca_tol, max_components=max_components, folds=folds
    ).fit(data, seed=seed)
    validation = {"training": prediction_errors(model, data)}
    if test_campaign is not None:
        validation["test"] = prediction_errors(model, training_data(test_campaign, runs_dir))
    model.meta["validation"] = validation
    _record_error_budget(model, error_budget)
    return model
