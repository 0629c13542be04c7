"""Whether a fit identifies mu: its certainty region against the ends of mu's range (the statistical
profile of F at each end and the model's own errors on mu), and its 95 % interval there."""

from __future__ import annotations

import numpy as np

from ...design.friction_treatment import FixedParameter
from ...forward.fe_predictor import FESolverPredictor
from ...forward.solver import SimulationError
from .inverse_fit import FitResult, fit_parameters, residuals_at

__all__ = ["interval_is_whole_range", "mu_is_identified", "mu_reach_by_model_error"]


def mu_is_identified(reach: dict, mu_pct: float, interval, mu_range) -> bool:
    """Whether a fit identifies mu (fit.json's ``friction.mu_identified``).

    Its certainty region reaches neither end of mu's range (``reach``: the statistical profile's
    answer merged with :func:`mu_reach_by_model_error`, the model's own errors on mu, so that a mu
    the model's error could move to the range's end is not claimed: issue 57, mu = 0.69 claimed on
    data made with the stick), its half-width is finite and its 95 % interval is not the whole range.

    Parameters
    ----------
    reach : dict
        ``{"lower": bool, "upper": bool}``: whether mu's certainty region reaches each end.
    mu_pct : float
        mu's 95 % half-width, percent (eq. 6, with the surrogate's part).
    interval : sequence of float
        mu's 95 % interval, within the range.
    mu_range : sequence of float
        The range (prior) of mu.

    Returns
    -------
    bool
    """
    return bool(
        not (reach.get("lower") or reach.get("upper"))
        and np.isfinite(mu_pct)
        and not interval_is_whole_range(interval, mu_range)
    )


def mu_reach_by_model_error(mu: float, model_pct: float | None, mu_range) -> dict[str, bool]:
    """Whether the model's own errors on mu (a 95 % half-width, percent) can move it to its range's ends.

    Read in log mu (mu is a scale): the lower end is reached when mu / (1 + m / 100) <= lo, the
    upper when mu (1 + m / 100) >= hi. The statistical profile (``_mu_reach``) does not see these
    errors, so a fit reports an end reached when either says so.

    Parameters
    ----------
    mu : float
        The fitted mu.
    model_pct : float or None
        :func:`mu_model_error_pct`; None: nothing known, nothing reached.
    mu_range : sequence of float
        mu's range (lo, hi).

    Returns
    -------
    dict
        ``{"lower": bool, "upper": bool}``.

    Examples
    --------
    >>> from indentation_studio.inference.fit.mu_reach import mu_reach_by_model_error
    >>> mu_reach_by_model_error(1.59, 1500.0, (0.1, 3.0))
    {'lower': True, 'upper': True}
    >>> mu_reach_by_model_error(0.5, 20.0, (0.1, 3.0))
    {'lower': False, 'upper': False}
    """
    lo, hi = (float(v) for v in mu_range)
    if model_pct is None or not np.isfinite(model_pct):
        return {"lower": model_pct is not None, "upper": model_pct is not None}
    factor = 1.0 + float(model_pct) / 100.0
    return {"lower": bool(mu / factor <= lo), "upper": bool(mu * factor >= hi)}


def interval_is_whole_range(interval, mu_range) -> bool:
    """Whether mu's 95 % interval is its whole range: the data bound it nowhere.

    Parameters
    ----------
    interval : sequence of float
        mu's 95 % interval, within the range.
    mu_range : sequence of float
        The range (prior) of mu.

    Returns
    -------
    bool
    """
    return bool(interval[0] <= mu_range[0] and interval[1] >= mu_range[1])


def _mu_reach(
    objective,
    predictor,
    eta,
    fit: FitResult,
    mu_range: tuple[float, float],
    box: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[dict[str, bool], dict[str, str], tuple[np.ndarray, float] | None]:
    """Whether eq. 6's certainty region of the fit, F(theta) - F(theta_hat) <= s^2, reaches each end
    of mu's range: the profile of F at the end, (c1, c5) fitted again with mu held there (on a
    surrogate a fit within ``box``; on the FE model, where a run takes minutes, one Gauss-Newton
    step from the fit's (c1, c5): the linearised least squares ||r - J (J^T J)^-1 J^T r||^2 of the
    (c1, c5) columns, one run with sensitivities). Holding (c1, c5) at the fit instead would
    overstate F there, as (c1, c5) move with mu, and call mu bounded where it is not. A fit on an
    end counts as reaching it; an end whose simulation fails counts as reached (nothing known there),
    the reason in the notes. Where nothing slips the data say nothing of mu and F is flat above
    some mu: the Hessian's bound of mu (local) would then be a confident wrong answer.

    Also returns a better point, (theta, F), where one was found with F below F(theta_hat) - s^2
    (on the FE model the Gauss-Newton step's point, run once more when its linearised F is that
    low): then the fit is not the minimum (None otherwise)."""
    reach, notes, better = {}, {}, None
    for side, end in zip(("lower", "upper"), mu_range, strict=True):
        if abs(np.log(fit.theta[2] / end)) < 1e-3:
            reach[side], notes[side] = True, "the fit ends on it"
            continue
        try:
            F_end, theta_end, F_there = _profile_at(
                objective, predictor, eta, fit.theta[:2], end, box, fit.F - fit.s**2
            )
        except SimulationError as exc:
            reach[side] = True
            notes[side] = f"taken as reached: the simulation at mu = {end:g} failed ({exc})"
            continue
        reach[side] = bool(F_end - fit.F <= fit.s**2)
        if F_there is not None and F_there < fit.F - fit.s**2 and (better is None or F_there < better[1]):
            better = (theta_end, F_there)
    return reach, notes, better


def _profile_at(
    objective, predictor, eta, c1_c5: np.ndarray, mu: float, box, below: float
) -> tuple[float, np.ndarray, float | None]:
    """min over (c1, c5) of F(c1, c5, mu): a fit of (c1, c5) with mu held (cheap predictors), or on
    the FE model one Gauss-Newton step's linearised value from ``c1_c5``. Returns that value, the
    point (c1, c5, mu) it is at, and F there as evaluated (on the FE model only when the
    linearised value is ``below``, one run more; else None)."""
    if isinstance(predictor, FESolverPredictor) or isinstance(
        getattr(predictor, "low", None), FESolverPredictor
    ):
        theta = np.array([c1_c5[0], c1_c5[1], mu])
        r, J = residuals_at(objective, predictor, eta, theta)
        step, *_ = np.linalg.lstsq(J[:, :2], -r, rcond=None)
        left = r + J[:, :2] @ step
        stepped = theta * np.exp(np.append(step, 0.0))
        F_there = None
        if float(left @ left) < below:
            try:
                F_there = float(objective.value(predictor.predict(stepped[None, :]), eta)[0])
            except SimulationError:
                F_there = None
        return float(left @ left), stepped, F_there
    held = FixedParameter(predictor, "mu", mu)
    two = None if box is None else (box[0][:2], box[1][:2])
    start = c1_c5 if two is None else np.clip(c1_c5, two[0], two[1])
    profile = fit_parameters(objective, held, eta, theta0=start, box=two)
    return profile.F, np.append(profile.theta, mu), profile.F
