"""How a change of a model's outputs moves a fit, to first order: the residuals' change, the
fit's move in log theta, and the surrogate's own error pushed through the fit (issue 46)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...design.objective import Objective, check_weights
from ...forward.predictor import Prediction
from ...forward.spec import ModelSpec

__all__ = [
    "FEW_HELD_OUT",
    "contact_of",
    "emulation_error_pct",
    "emulation_moves",
    "fit_moves",
    "has_high_fidelity_level",
    "moved_prediction",
    "residual_changes",
]


def has_high_fidelity_level(surrogate) -> bool:
    """Whether a surrogate knows a discrepancy to a high-fidelity model (a multi-fidelity one)."""
    return callable(getattr(surrogate, "discrepancy_covariance_factor", None))


def moved_prediction(prediction: Prediction, force_log: np.ndarray, field: np.ndarray) -> Prediction:
    """The prediction with its log force and field moved by one output-space change.

    The change is the same at every theta, so the force's Jacobian is scaled with the force and
    the field's is unchanged.

    Parameters
    ----------
    prediction : Prediction
        The prediction.
    force_log : numpy.ndarray
        (steps,) the change of log force.
    field : numpy.ndarray
        (steps * nodes * 3,) the change of the field, mm.

    Returns
    -------
    Prediction
    """
    factor = np.exp(force_log)
    return replace(
        prediction,
        force=prediction.force * factor[None],
        displacement=prediction.displacement + field.reshape(prediction.displacement.shape[1:])[None],
        force_jacobian=None
        if prediction.force_jacobian is None
        else prediction.force_jacobian * factor[None, :, None],
    )


def contact_of(surrogate) -> str:
    """The contact of the FE model a surrogate emulates, in words (the perfect stick when its
    file does not say)."""
    model = (getattr(surrogate, "meta", None) or {}).get("campaign", {}).get("model")
    return ModelSpec.from_dict(model).contact.describe() if model else "perfect stick"


def fit_moves(
    objective: Objective, e, surrogate, theta: np.ndarray, free: int, outputs: np.ndarray
) -> np.ndarray:
    """How far each output-space change moves the fit, to first order: (k, free) in log theta.

    ``outputs`` (k, steps + steps * nodes * 3): log force per step, then the field (mm). Each row
    moves the residuals by dr_k, and the fit by -(J^T J)^-1 J^T dr_k over the first ``free``
    parameters, the rest held at ``theta``."""
    pred = surrogate.predict(theta[None, :], jacobian=True)
    J = (objective.jacobian(pred, e)[0] * theta)[:, :free]  # d r / d log theta (the free ones)
    dr = residual_changes(objective, e, pred, outputs)  # (k, m)
    A = np.linalg.solve(J.T @ J, J.T)  # (free, m)
    return -dr @ A.T


def residual_changes(objective: Objective, eta, prediction: Prediction, outputs: np.ndarray) -> np.ndarray:
    """How each output-space change moves eq. 5's residual vector at a prediction.

    Parameters
    ----------
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    prediction : Prediction
        One point's prediction (the residuals' base).
    outputs : numpy.ndarray
        (k, steps + steps * nodes * 3): log force per step, then the field (mm).

    Returns
    -------
    numpy.ndarray
        (k, residuals) r(prediction moved by row k) - r(prediction).
    """
    e = check_weights(eta)
    r0 = objective.residuals(prediction, e)[0]
    steps = prediction.force.shape[1]
    return np.stack(
        [
            objective.residuals(moved_prediction(prediction, row[:steps], row[steps:]), e)[0] - r0
            for row in outputs
        ]
    )


#: Below this many held-out points the surrogate's part is the largest move, not a percentile.
FEW_HELD_OUT = 20


def emulation_moves(
    objective: Objective, eta, surrogate, theta: np.ndarray, *, free: int | None = None
) -> np.ndarray | None:
    """How far each of the surrogate's held-out error vectors moves the fit at ``theta`` (issue 46).

    To first order a held-out error moves the fit by d log theta_k = -(J^T J)^-1 J^T dr_k
    (:func:`fit_moves`); :func:`emulation_error_pct` takes its 95th percentile.

    Parameters
    ----------
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    surrogate : FieldSurrogate
        The surrogate fitted.
    theta : numpy.ndarray
        (p,) the fit.
    free : int, optional
        The first ``free`` parameters move, the rest are held (as :func:`model_error_at`).

    Returns
    -------
    numpy.ndarray or None
        (n, free) |d log theta| of each held-out point (the rows of
        ``surrogate.emulation_error.theta``); None when the surrogate kept no held-out errors.
    """
    emulation = getattr(surrogate, "emulation_error", None)
    if emulation is None:
        return None
    theta = np.asarray(theta, float)
    free = len(theta) if free is None else free
    # one residual evaluation per kept direction (each scaled to a typical error), not one per
    # held-out point on the whole (points x outputs) error matrix
    scores = emulation.scores.astype(float)
    scale = np.sqrt(np.mean(scores**2, axis=0))
    scale = np.where(scale > 0, scale, 1.0)
    along = fit_moves(
        objective,
        check_weights(eta),
        surrogate,
        theta,
        free,
        emulation.directions.astype(float) * scale[:, None],
    )
    return np.abs((scores / scale) @ along)


def emulation_error_pct(
    objective: Objective, eta, surrogate, theta: np.ndarray, *, free: int | None = None
) -> np.ndarray | None:
    """The surrogate's own error as a 95 % half-width of the fit at ``theta`` (issue 46).

    Each of the surrogate's held-out error vectors (``surrogate.emulation_error``) moves the fit,
    to first order, by d log theta_k = -(J^T J)^-1 J^T dr_k (:func:`emulation_moves`); the
    half-width is the 95th percentile of |d log theta_k| over the held-out points (their largest
    when there are fewer than :data:`FEW_HELD_OUT`), in percent.

    Parameters
    ----------
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    surrogate : FieldSurrogate
        The surrogate fitted.
    theta : numpy.ndarray
        (p,) the fit.
    free : int, optional
        The first ``free`` parameters move, the rest are held (as :func:`model_error_at`).

    Returns
    -------
    numpy.ndarray or None
        (free,) percent; None when the surrogate kept no held-out errors.
    """
    moves = emulation_moves(objective, eta, surrogate, theta, free=free)
    if moves is None:
        return None
    q = 1.0 if len(moves) < FEW_HELD_OUT else 0.95
    return 100.0 * np.expm1(np.quantile(moves, q, axis=0, method="higher"))
