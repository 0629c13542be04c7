"""What a multi-fidelity surrogate's discrepancy model leaves (:mod:`surrogate.multi_fidelity`).

Two measurements made when it is trained: what the discrepancy's PCA leaves of its own training
data, and its k-fold held-out errors, i.e. the multi-fidelity prediction's errors at the
high-fidelity points (what a fit pushes through to its bounds, :class:`EmulationError`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
from sklearn.model_selection import KFold, StratifiedKFold

from .base import TrainingData
from .emulation_error import EmulationError
from .gaussian_process import GaussianProcessSurrogate

__all__ = ["k_fold_discrepancy_errors", "pca_truncation_errors"]


def pca_truncation_errors(discrepancy: GaussianProcessSurrogate, data: TrainingData) -> dict[str, float]:
    """What the discrepancy's PCA leaves of its training data.

    Parameters
    ----------
    discrepancy : GaussianProcessSurrogate
        The trained discrepancy model (its force is the ratio F_hi / F_lo, learned in log).
    data : TrainingData
        The discrepancies it was trained on.

    Returns
    -------
    dict
        ``force_max_pct`` (largest relative force error, percent) and ``field_max_mm``.
    """
    log_ratio = np.log(data.force)
    U = data.displacement.reshape(data.n, -1)
    f = discrepancy.force_pca.inverse_transform(discrepancy.force_pca.transform(log_ratio)) - log_ratio
    u = discrepancy.field_pca.inverse_transform(discrepancy.field_pca.transform(U)) - U
    return {
        "force_max_pct": 100.0 * float(np.abs(np.expm1(f)).max()),
        "field_max_mm": float(np.abs(u).max()),
    }


def k_fold_discrepancy_errors(
    make_model: Callable[[], GaussianProcessSurrogate],
    data: TrainingData,
    *,
    folds: int,
    seed: int,
    steps: int,
    strata: np.ndarray | None = None,
) -> tuple[EmulationError, dict[str, Any]]:
    """Held-out errors of the discrepancy model (PCA truncation and GP together).

    The model is refitted on each fold's rest and predicts the fold: the multi-fidelity
    prediction's errors at the high-fidelity points.

    Parameters
    ----------
    make_model : callable
        A new, untrained discrepancy model.
    data : TrainingData
        The discrepancies at the high-fidelity points.
    folds : int
        Folds (at most the points).
    seed : int
        Seed of the folds' shuffle and of the GP's training.
    steps : int
        Steps of the test (the outputs' log force part).
    strata : ndarray of bool, shape (n,), optional
        The points of a merged campaign that are stick points (the others have a mu axis): the
        folds are stratified by it (scikit-learn's ``StratifiedKFold``), so that every fold's rest
        keeps points of both and the model over mu can be fitted (with two friction points, a
        plain ``KFold`` could hold both out together). None: ``KFold``.

    Returns
    -------
    EmulationError
        The FE response minus the prediction at every point (as a low surrogate's held-out errors
        are kept).
    dict
        Folds, points, and the errors' RMS and largest values (force percent, field mm).

    Raises
    ------
    ValueError
        With ``strata``, where fewer than two points are of one kind (a fold's rest would have none).
    """
    folds = min(folds, data.n)
    if strata is None:
        splits = KFold(folds, shuffle=True, random_state=seed).split(data.theta)
    else:
        strata = np.asarray(strata, bool)
        fewest = min(int(strata.sum()), int((~strata).sum()))
        if fewest < 2:
            raise ValueError(
                f"the k-fold errors of a merged campaign need at least two stick points and two with "
                f"mu, got {int(strata.sum())} and {int((~strata).sum())}: train with more, or without folds"
            )
        with warnings.catch_warnings():  # fewer of a kind than folds: some folds hold none of it
            warnings.filterwarnings("ignore", message="The least populated class", category=UserWarning)
            splits = list(StratifiedKFold(folds, shuffle=True, random_state=seed).split(data.theta, strata))
    df, du, held = [], [], []
    for train, test in splits:
        held.append(test)
        model = make_model().fit(data.subset(train), seed=seed)
        pred = model.predict(data.theta[test])
        df.append(np.log(pred.force) - np.log(data.force[test]))
        du.append(pred.displacement - data.displacement[test])
    rel_f = np.expm1(np.concatenate(df))
    err_u = np.concatenate(du)
    order = np.concatenate(held)
    error = EmulationError.from_errors(
        data.theta[order],
        -np.hstack([np.concatenate(df), err_u.reshape(len(order), -1)]),
        steps=steps,
        source=f"{folds}-fold cross-validation of the discrepancy at {data.n} high-fidelity points",
    )
    summary = {
        "folds": folds,
        "points": int(data.n),
        "force_rms_pct": 100.0 * float(np.sqrt(np.mean(rel_f**2))),
        "force_max_pct": 100.0 * float(np.abs(rel_f).max()),
        "field_rms_mm": float(np.sqrt(np.mean(err_u**2))),
        "field_max_mm": float(np.abs(err_u).max()),
        **{f"u{'xyz'[j]}_rms_mm": float(np.sqrt(np.mean(err_u[..., j] ** 2))) for j in range(3)},
    }
    return error, summary
