"""Model error carried into a fit's bounds and its posterior.

The bounds of eq. 6 to 8 are statistical: they hold the measurement noise only. A fit on a
multi-fidelity surrogate also knows two model errors, which are reported beside them:

* the discrepancy's uncertainty: the surrogate's predictive covariance of the high-fidelity
  response, L^T L in its output space (log force per step, top-surface field), pushed through
  the fit: each row l of L moves the residuals by dr_l and the fit, to first order, by
  d log theta_l = -(J^T J)^-1 J^T dr_l; the covariance is sum_l d log theta_l d log theta_l^T;
* what the error budget leaves: the largest bias of the high-fidelity mesh itself against the
  reference at the budget's test points (``inference.budgets.error_budget``), a systematic half-width
  recorded in the surrogate's provenance (``meta['error_budget']``);
* the surrogate's own error (issue 46), for a fit whose final stage is on the surrogate: its error
  vectors at held-out points (``surrogate.emulation_error``), each moving the fit to first order
  as above, d log theta_k = -(J^T J)^-1 J^T dr_k; the part is the 95th percentile of |d log theta_k|
  over the held-out points (the largest of them when there are fewer than 20), a systematic
  half-width, not a standard deviation.

A single-level surrogate knows the second part only, when an error budget of its own mesh for the
same test is known (given at training, or shipped with the studio:
:func:`surrogate.error_budgets.shipped_budget`); its bounds then hold that mesh's error and say so.

Both are 95 % half-widths in percent of theta_hat and are combined with the statistical one by
root sum of squares (independent sources, as ASME V&V 20 combines uncertainties)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...design.objective import Objective, check_weights
from ...surrogate.error_budgets import budget_at, surrogate_error_budget
from ..experiment.processing_error import ProcessingError
from .fit_moves import (
    contact_of,
    emulation_error_pct,
    fit_moves,
    has_high_fidelity_level,
    residual_changes,
)
from .model_error_parts import Z95, ModelError, combined_pct, model_error_scope

__all__ = [
    "Z95",
    "ModelError",
    "budget_correction",
    "combined_pct",
    "emulation_error_pct",
    "has_high_fidelity_level",
    "model_error_at",
    "model_error_scope",
    "residual_changes",
    "with_emulation_error",
    "with_model_error",
    "with_processing_error",
]


def with_emulation_error(
    model: ModelError | None,
    objective: Objective,
    eta,
    surrogate,
    theta: np.ndarray,
    *,
    free: int | None = None,
) -> ModelError | None:
    """``model`` with the surrogate's own error added (:func:`emulation_error_pct`).

    For a fit whose final stage is on ``surrogate``; a fit refined on the FE model does not carry it.

    Parameters
    ----------
    model : ModelError or None
        The other parts (None: none known).
    objective, eta, surrogate, theta, free
        As :func:`emulation_error_pct`.

    Returns
    -------
    ModelError or None
        The parts with ``surrogate_pct`` set; ``model`` unchanged when the surrogate kept no
        held-out errors.
    """
    pct = emulation_error_pct(objective, eta, surrogate, theta, free=free)
    if pct is None:
        return model
    source = surrogate.emulation_error.source
    if model is None:
        p = len(pct)
        return ModelError(
            np.zeros(p), np.zeros(p), np.zeros((p, p)), None, False, contact_of(surrogate), pct, source
        )
    return replace(model, surrogate_pct=pct, surrogate_source=source)


def with_processing_error(model: ModelError | None, processing: ProcessingError, contact: str) -> ModelError:
    """``model`` with the experiment's processing part (``inference.experiment.processing_error``) added.

    Parameters
    ----------
    model : ModelError or None
        The other parts (None: none known).
    processing : ProcessingError
        The processing's parts at the fit.
    contact : str
        The contact the model assumes, for a ``model`` of None.

    Returns
    -------
    ModelError
        The parts with ``processing`` set.
    """
    if model is None:
        p = len(processing.interpolation_pct)
        return ModelError(
            np.zeros(p), np.zeros(p), np.zeros((p, p)), None, False, contact, processing=processing
        )
    return replace(model, processing=processing)


def model_error_at(
    objective: Objective,
    eta,
    surrogate,
    theta: np.ndarray,
    *,
    free: int | None = None,
    on_surrogate: bool = True,
) -> ModelError | None:
    """The model-error parts at the fit ``theta`` on ``surrogate``.

    A multi-fidelity surrogate gives the discrepancy's part (its predictive covariance carried to
    theta by the linearised fit) and its error budget's. A single-level surrogate with an error
    budget of its mesh (``meta['error_budget']``) carries that budget alone. A fit whose final
    stage is on the surrogate (``on_surrogate``) also carries the surrogate's own error when it
    kept held-out errors (:func:`with_emulation_error`).

    Parameters
    ----------
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    surrogate : FieldSurrogate
        The surrogate fitted.
    theta : numpy.ndarray
        (p,) the fit, kPa.
    free : int, optional
        Only the first ``free`` parameters move with the discrepancy, the rest held at ``theta``
        (mu of a fit with friction, whose own bound is its profile's; at mu's range ends, where
        nothing slips, d/dmu vanishes and a fit over all three would not be determined). The parts
        are then over those ``free`` parameters. Default all.
    on_surrogate : bool, default True
        The fit's final stage is on the surrogate (False: refined on the FE model, whose fit the
        surrogate's own error does not move).

    Returns
    -------
    ModelError or None
        The parts; None for a single-level surrogate without a budget or held-out errors (its
        bounds then hold no model error, and say so).
    """
    budget = budget_at(surrogate_error_budget(surrogate), theta) or {}
    contact = contact_of(surrogate)
    theta = np.asarray(theta, float)
    names = surrogate.parameters[:free]
    budget_pct = np.array([float(budget.get(f"{name}_pct", 0.0)) for name in names])
    correction = budget_correction(budget, names)
    p = len(names)
    if not has_high_fidelity_level(surrogate):
        known = (
            ModelError(
                np.zeros(p),
                budget_pct,
                np.zeros((p, p)),
                budget.get("source"),
                False,
                contact,
                correction_pct=correction,
            )
            if budget
            else None
        )
    else:
        L = surrogate.discrepancy_covariance_factor(theta)  # (k, steps + steps * nodes * 3)
        moves = fit_moves(objective, check_weights(eta), surrogate, theta, p, L)  # (k, p) in log theta
        cov = moves.T @ moves
        known = ModelError(
            discrepancy_pct=100.0 * Z95 * np.sqrt(np.diag(cov)),
            budget_pct=budget_pct,
            covariance_log=cov,
            budget_source=budget.get("source") if budget else None,
            contact=contact,
            correction_pct=correction,
        )
    if not on_surrogate:
        return known
    return with_emulation_error(known, objective, eta, surrogate, theta, free=free)


def budget_correction(budget: dict | None, names) -> np.ndarray | None:
    """A budget's correction of the fit at a point (``surrogate.error_budgets.budget_at``), or None.

    Parameters
    ----------
    budget : dict or None
        What ``budget_at`` read at the fit.
    names : sequence of str
        The fit's parameters; those without a correction in the budget (mu) get 0.

    Returns
    -------
    numpy.ndarray or None
        (len(names),) percent; None where the budget corrects nothing.
    """
    if not budget or budget.get("c1_correction_pct") is None:
        return None
    return np.array([float(budget.get(f"{name}_correction_pct", 0.0)) for name in names])


def with_model_error(
    samples: np.ndarray,
    model: ModelError,
    seed: int = 0,
    *,
    box: tuple[np.ndarray, np.ndarray] | None = None,
    tries: int = 50,
) -> np.ndarray:
    """Posterior samples spread by the model error: each multiplied by exp(e).

    e is normal with the model error's covariance of log theta (discrepancy, error budget and
    the surrogate's own error). With a prior ``box``, the spread is truncated to it (the prior
    times the spread): a sample moved outside is drawn again, so a parameter whose model error
    is as wide as its range (mu on data with no slip) fills the range instead of piling at its ends.

    Parameters
    ----------
    samples : numpy.ndarray
        (n, p) the samples.
    model : ModelError
        The model-error parts.
    seed : int, default 0
        Seed of e.
    box : tuple of numpy.ndarray, optional
        (lo, hi) the prior's box; None: no truncation.
    tries : int, default 50
        Draws of e for a sample before it is held at its own value (its spread then nil).

    Returns
    -------
    numpy.ndarray
        (n, p) the spread samples.
    """
    rng = np.random.default_rng(seed)
    cov = model.covariance_with_budget()
    samples = np.asarray(samples, float)
    e = rng.multivariate_normal(np.zeros(len(cov)), cov, size=len(samples), method="eigh")
    out = samples * np.exp(e)
    if box is None:
        return out
    lo, hi = (np.asarray(b, float) for b in box)
    outside = ~np.all((out > lo) & (out < hi), axis=1)
    for _ in range(tries):
        if not outside.any():
            break
        e = rng.multivariate_normal(np.zeros(len(cov)), cov, size=int(outside.sum()), method="eigh")
        out[outside] = samples[outside] * np.exp(e)
        outside = ~np.all((out > lo) & (out < hi), axis=1)
    out[outside] = samples[outside]
    return out
