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
    """F at ``theta_bar`` (n, p) points, the Hessian at theta* (theta_bar) and its eq. 6 bounds."""

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
    """F (eq. 5) of ``responses`` at ``theta`` (n, p) against the study's response at theta*
    (``study.baseline``), with the study's Hessian for ``weights``."""
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
    """Fig. 8 over a campaign's points: theta* is simulated on the campaign's own model with
    sensitivities (exact Gauss-Newton Hessian) unless a ``study`` at theta* is given."""
    data = campaign if isinstance(campaign, CampaignData) else load_campaign(campaign, runs_dir)
    if study is None:
        study = fe_design_study(ModelSpec.from_dict(data.spec["model"]), theta_star, "exact", reading)
    # a FEBio point's steps flagged off equilibrium: filled from its own neighbouring steps
    return objective_map(data.theta, data.prediction(filled=True), study, weights, s)
