"""Fig. 8: the objective (eq. 5) over scattered or gridded (c1, c5) points against the response at
theta*, in normalised coordinates theta_bar = theta / theta*, with the Hessian at theta* whose
level set is the certainty ellipse of eq. 6."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..campaign.loader import CampaignData, load_campaign
from ..forward.predictor import Prediction
from ..forward.spec import ModelSpec
from .objective import PAPER_WEIGHTS, Objective, check_weights
from .study import DesignStudy, fe_design_study

__all__ = ["ObjectiveMap", "campaign_objective_map", "objective_map"]


@dataclass
class ObjectiveMap:
    """F over the parameter plane (Fig. 8), the Hessian at theta* and its eq. 6 bounds.

    Attributes
    ----------
    theta_bar : numpy.ndarray
        (n, p) the points, theta / theta*.
    F : numpy.ndarray
        (n,) the objective of eq. 5 at them.
    hessian : numpy.ndarray
        (p, p) the Hessian at theta* in theta_bar (eq. 7).
    s : float
        Eq. 8's s of the bounds.
    bounds_pct : numpy.ndarray
        (p,) eq. 6's bounds, percent.
    theta_star : numpy.ndarray
        (p,) theta*, kPa.
    eta : numpy.ndarray
        (4,) the weights.
    radius : float
        The indenter's radius, mm.
    """

    theta_bar: np.ndarray
    F: np.ndarray
    hessian: np.ndarray
    s: float
    bounds_pct: np.ndarray
    theta_star: np.ndarray
    eta: np.ndarray
    radius: float


def objective_map(
    theta: np.ndarray, responses: Prediction, study: DesignStudy, weights=PAPER_WEIGHTS, s: float = 0.05
) -> ObjectiveMap:
    """F (eq. 5) of ``responses`` at ``theta`` against the study's response at theta*, with its Hessian.

    Parameters
    ----------
    theta : numpy.ndarray
        (n, p) the points, kPa.
    responses : Prediction
        The responses at them.
    study : DesignStudy
        The study at theta*, holding its response (``study.baseline``) and Hessians.
    weights : array_like, default PAPER_WEIGHTS
        The weights of eq. 5.
    s : float, default 0.05
        Eq. 8's s of the bounds.

    Returns
    -------
    ObjectiveMap
        F at the points, the Hessian for ``weights`` and its eq. 6 bounds.

    Raises
    ------
    ValueError
        If the study holds no response at theta*.
    """
    if study.baseline is None:
        raise ValueError("the design study holds no response at theta* to measure the objective against")
    eta = check_weights(weights)
    radius = float(study.spec["indenter"]["radius"])
    objective = Objective.from_prediction(study.baseline, radius=radius, reading=study.reading)
    return ObjectiveMap(
        theta_bar=np.asarray(theta, float) / study.theta_star,
        F=objective.value(responses, eta),
        hessian=study.hessian(eta),
        s=float(s),
        bounds_pct=study.bounds(eta, s),
        theta_star=study.theta_star,
        eta=eta,
        radius=radius,
    )


def campaign_objective_map(
    campaign: str | Path | CampaignData,
    theta_star=(10.0, 350.0),
    weights=PAPER_WEIGHTS,
    s: float = 0.05,
    reading: str = "paper",
    study: DesignStudy | None = None,
    runs_dir: str | Path = "runs",
) -> ObjectiveMap:
    """Fig. 8 over a campaign's points: the objective map against the response at theta*.

    theta* is simulated on the campaign's own model with sensitivities (exact Gauss-Newton
    Hessian) unless a ``study`` at theta* is given; missing FEBio steps are filled from the
    point's own neighbouring steps.

    Parameters
    ----------
    campaign : str, pathlib.Path or CampaignData
        The campaign (name, folder or loaded).
    theta_star : array_like, default (10.0, 350.0)
        (c1, c5), kPa.
    weights : array_like, default PAPER_WEIGHTS
        The weights of eq. 5.
    s : float, default 0.05
        Eq. 8's s of the bounds.
    reading : str, default "paper"
        How eq. 4 is read.
    study : DesignStudy, optional
        A study at theta* (saves the simulation).
    runs_dir : str or pathlib.Path, default "runs"
        Where named campaigns live.

    Returns
    -------
    ObjectiveMap
        As :func:`objective_map`.
    """
    data = campaign if isinstance(campaign, CampaignData) else load_campaign(campaign, runs_dir)
    if study is None:
        study = fe_design_study(ModelSpec.from_dict(data.spec["model"]), theta_star, "exact", reading)
    # a FEBio point's steps flagged off equilibrium: filled from its own neighbouring steps
    return objective_map(data.theta, data.prediction(filled=True), study, weights, s)
