"""Training a surrogate on a campaign, with its validation recorded in the model's provenance."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..campaign.loader import CampaignData, load_campaign
from .base import FieldSurrogate, TrainingData
from .emulation_error import EmulationError, held_out_errors
from .error_budgets import surrogate_error_budget
from .multi_fidelity import MultiFidelitySurrogate
from .persistence import load_surrogate
from .registry import surrogate_class
from .training_set import merged_training_data
from .validation import k_fold_errors, prediction_errors

__all__ = ["SURROGATE_KINDS", "make_surrogate", "train_multi_fidelity", "train_surrogate", "training_data"]

#: The kinds trained on one campaign alone; a stick-plus-slip surrogate ('slip') is trained on a
#: campaign with a mu axis from a trained perfect-stick one (``make_surrogate("slip", stick=...)``),
#: and a multi-fidelity surrogate ('mf') on a second campaign from one of them
#: (:func:`train_multi_fidelity`).
SURROGATE_KINDS = ("gp", "mlp")


def make_surrogate(kind: str, input_scale: str = "log", pca_tol: float = 1e-3, **kwargs) -> FieldSurrogate:
    """An untrained surrogate of ``kind``.

    Parameters
    ----------
    kind : {"gp", "mlp", "slip"}
        ``gp``: :class:`GaussianProcessSurrogate` (scikit-learn); ``mlp``: :class:`MLPSurrogate`
        (torch ensemble); ``slip``: :class:`surrogate.slip_surrogate.SlipSurrogate`, a perfect-stick
        surrogate (``stick=``, a trained surrogate or its file) plus an MLP of what slip changes.
    input_scale : {"log", "linear"}, default "log"
        Scaling of the inputs over the training box.
    pca_tol : float, default 1e-3
        PCA tolerance of the outputs.
    **kwargs
        Further constructor arguments of the class.

    Returns
    -------
    FieldSurrogate
        The untrained surrogate.

    Raises
    ------
    ValueError
        If ``kind`` is unknown, or ``mf`` (use :func:`train_multi_fidelity`).
    """
    if kind in ("gp", "mlp"):  # through the registry: a GP never imports torch
        return surrogate_class(kind)(input_scale=input_scale, pca_tol=pca_tol, **kwargs)
    if kind == "slip":
        if "stick" not in kwargs:
            raise ValueError("a 'slip' surrogate is built on a trained perfect-stick surrogate: give stick=")
        stick = kwargs.pop("stick")
        stick = stick if isinstance(stick, FieldSurrogate) else load_surrogate(stick)
        return surrogate_class("slip")(stick, input_scale=input_scale, pca_tol=pca_tol, **kwargs)
    if kind == "mf":
        raise ValueError(
            "a multi-fidelity surrogate ('mf') is made from a trained low-fidelity surrogate and a "
            "high-fidelity campaign: use train_multi_fidelity"
        )
    raise ValueError(f"unknown surrogate kind {kind!r}; use 'gp', 'mlp' or 'slip'")


def training_data(campaign: str | Path | CampaignData, runs_dir: str | Path = "runs") -> TrainingData:
    """A campaign (name, folder or loaded) as training data.

    Parameters
    ----------
    campaign : str, pathlib.Path or CampaignData
        A campaign name under ``runs_dir``, its folder, or loaded data.
    runs_dir : str or pathlib.Path, default "runs"
        Where named campaigns live.

    Returns
    -------
    TrainingData
        The done points, missing forces filled (:meth:`TrainingData.from_campaign`).
    """
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
    stick: str | Path | FieldSurrogate | None = None,
    say: Callable[[str], None] | None = None,
) -> FieldSurrogate:
    """Train a ``kind`` surrogate on ``campaign``, with its validation and error budget in ``meta``.

    Its errors on the training points, by ``kfold`` cross-validation and on ``test_campaign`` go
    to ``model.meta['validation']`` (percent, :func:`prediction_errors`).

    Parameters
    ----------
    campaign : str, pathlib.Path or CampaignData
        The training campaign (name, folder or loaded).
    kind : {"gp", "mlp", "slip"}, default "gp"
        The surrogate (:func:`make_surrogate`).
    input_scale : {"log", "linear"}, default "log"
        Scaling of the inputs over the training box.
    pca_tol : float, default 1e-3
        PCA tolerance of the outputs.
    test_campaign : str, pathlib.Path or CampaignData, optional
        A campaign to validate on.
    kfold : int, default 0
        Folds of a cross-validation (0: none).
    seed : int, default 0
        Seed of the training.
    runs_dir : str or pathlib.Path, default "runs"
        Where named campaigns live.
    error_budget : dict, optional
        What a budget leaves for the campaign's mesh (:func:`surrogate.error_budgets.remaining_bias`);
        default the studio's shipped budget for that mesh and test, if any. It goes to
        ``meta['error_budget']``: fits carry it in their bounds.
    stick : str, pathlib.Path or FieldSurrogate, optional
        ``kind="slip"``: the perfect-stick surrogate over (c1, c5) on the same mesh and test.
    say : callable, optional
        Told of the cross-validation's progress, fold by fold.

    Returns
    -------
    FieldSurrogate
        The trained surrogate.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> model = ins.train_surrogate("paper", "gp", kfold=5)  # doctest: +SKIP
    >>> model.meta["validation"]["kfold"]["force_rms_pct"]  # doctest: +SKIP
    """
    data = training_data(campaign, runs_dir)
    extra = {}
    if stick is not None:
        extra["stick"] = stick if isinstance(stick, FieldSurrogate) else load_surrogate(stick)
    model = make_surrogate(kind, input_scale, pca_tol, **extra).fit(data, seed=seed)
    validation = {"training": prediction_errors(model, data)}
    if kfold:
        steps, nodes = data.displacement.shape[1:3]
        errors = np.zeros((data.n, steps * (1 + 3 * nodes)))
        validation["kfold"] = k_fold_errors(
            lambda: make_surrogate(kind, input_scale, pca_tol, **extra),
            data,
            kfold,
            seed,
            held_out=errors,
            say=say,
        )
        source = f"{kfold}-fold cross-validation of its {data.n} training points"
        model.emulation_error = EmulationError.from_errors(data.theta, errors, steps=steps, source=source)
    if test_campaign is not None:
        test = training_data(test_campaign, runs_dir)
        validation["test"] = prediction_errors(model, test)
        model.emulation_error = _test_errors(model, test)
    model.meta["validation"] = validation
    _record_error_budget(model, error_budget)
    return model


def _test_errors(model: FieldSurrogate, test: TrainingData) -> EmulationError:
    """The model's errors at a test campaign's points (what fits carry as its own error)."""
    where = test.source.get("name") or test.source.get("campaign") or "a test campaign"
    return EmulationError.from_errors(
        test.theta,
        held_out_errors(model, test),
        steps=test.displacement.shape[1],
        source=f"{test.n} points of the test campaign {where}",
    )


def _record_error_budget(model: FieldSurrogate, error_budget: dict | None) -> None:
    """meta['error_budget']: the one given, else the shipped one for the FE model the surrogate
    emulates, else None (fits then say their bounds hold no model error)."""
    model.meta.pop("error_budget", None)
    known = error_budget if error_budget is not None else surrogate_error_budget(model)
    model.meta["error_budget"] = None if known is None else dict(known)


def train_multi_fidelity(
    low: str | Path | FieldSurrogate,
    high_campaign: str | Path | CampaignData | Sequence[str | Path | CampaignData],
    pca_tol: float = 1e-3,
    max_components: int = 8,
    folds: int = 5,
    test_campaign: str | Path | CampaignData | None = None,
    seed: int = 0,
    runs_dir: str | Path = "runs",
    error_budget: dict | None = None,
    *,
    stick_mu: float | None = None,
) -> MultiFidelitySurrogate:
    """Train a multi-fidelity surrogate: ``low`` corrected by the GP of its discrepancy from ``high_campaign``.

    It predicts the high fidelity on the high campaign's top nodes, and its FE model
    (``meta['campaign']``) is the high campaign's. The discrepancy's ``folds``-fold errors go to
    ``meta['discrepancy_kfold']`` (force %, field mm); its errors on the training points and on
    ``test_campaign`` (percent, as for :func:`train_surrogate`) to ``meta['validation']``.

    Parameters
    ----------
    low : str, pathlib.Path or FieldSurrogate
        A surrogate file or a trained surrogate, e.g. on a large campaign on a coarser mesh; a
        multi-fidelity one gives its low level (its discrepancy learned anew from
        ``high_campaign``, e.g. a shipped surrogate on a wider high-fidelity campaign).
    high_campaign : str, pathlib.Path, CampaignData or a sequence of them
        A few tens of points on the finer mesh, same test. Several campaigns of that mesh (e.g. one
        at the stick and one with a mu axis) are merged into one over (c1, c5, mu)
        (:func:`~.training_set.merged_training_data`): the discrepancy is then learned with
        friction, not at the stick alone.
    pca_tol : float, default 1e-3
        PCA tolerance of the discrepancy.
    max_components : int, default 8
        At most this many PCA components per part of the discrepancy.
    folds : int, default 5
        Folds of the discrepancy's cross-validation.
    test_campaign : str, pathlib.Path or CampaignData, optional
        A high-fidelity campaign to validate on.
    seed : int, default 0
        Seed of the training.
    runs_dir : str or pathlib.Path, default "runs"
        Where named campaigns live.
    error_budget : dict, optional
        What the budget leaves for the high-fidelity mesh
        (:func:`surrogate.error_budgets.remaining_bias`); default the shipped budget for that mesh
        and test, if any. It goes to ``meta['error_budget']``, where fits read the systematic part
        of their model error.
    stick_mu : float, optional
        With several campaigns, the mu a stick campaign's points are taken as; default the low
        level's mu range end (where nothing slips).

    Returns
    -------
    MultiFidelitySurrogate
        The trained surrogate.
    """
    low_model = low if isinstance(low, FieldSurrogate) else load_surrogate(low)
    if isinstance(low_model, MultiFidelitySurrogate):  # a discrepancy learned anew on its low level
        # with the low level's held-out errors, which its file kept at the multi-fidelity level
        kept = low_model.low_emulation_error
        low_model = low_model.low
        if low_model.emulation_error is None and kept is not None:
            low_model.emulation_error = kept
    if isinstance(high_campaign, (str, Path, CampaignData)):
        data = training_data(high_campaign, runs_dir)
    else:
        if stick_mu is None and "mu" in low_model.parameters:  # where the low level's slip ends
            stick_mu = float(low_model.scaler.hi[low_model.parameters.index("mu")])
        data = merged_training_data([training_data(c, runs_dir) for c in high_campaign], stick_mu=stick_mu)
    model = surrogate_class("mf")(
        low_model,
        pca_tol=pca_tol,
        max_components=max_components,
        folds=folds,
        stick_mu="end" if stick_mu is None else stick_mu,
    ).fit(data, seed=seed)
    validation = {"training": prediction_errors(model, data)}
    if test_campaign is not None:
        test = training_data(test_campaign, runs_dir)
        validation["test"] = prediction_errors(model, test)
    model.meta["validation"] = validation
    model.restore_emulation_error(low_model.emulation_error)  # the low level's own, at the high nodes
    _record_error_budget(model, error_budget)
    return model
