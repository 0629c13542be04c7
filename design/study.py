"""One design study: the term Hessians at theta* for a model spec, from the embedded solver's exact
sensitivities (Gauss-Newton) or finite differences on any Predictor, and the bounds they give."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..forward.predictor import FESolverPredictor, Prediction
from ..forward.spec import ModelSpec
from .certainty import bounds_pct, combine, finite_difference_term_hessians, gauss_newton_term_hessians
from .objective import Objective


@dataclass
class DesignStudy:
    """Term Hessians H_k (4, p, p) in theta_bar at ``theta_star`` and where they came from."""

    theta_star: np.ndarray
    term_hessians: np.ndarray
    method: str
    reading: str
    spec: dict
    baseline: Prediction | None = field(default=None, repr=False)

    def hessian(self, eta) -> np.ndarray:
        return combine(self.term_hessians, eta)

    def bounds(self, eta, s: float = 0.05) -> np.ndarray:
        return bounds_pct(self.hessian(eta), s)


def fe_design_study(
    spec: ModelSpec,
    theta_star=(10.0, 350.0),
    method: str = "exact",
    reading: str = "paper",
    step: int | None = None,
    h: float | tuple[float, ...] = 0.02,
    n_jobs: int = 1,
) -> DesignStudy:
    """Hessians from the embedded FE solver: ``exact`` (Gauss-Newton with its sensitivities, one
    simulation) or ``fd`` (central differences of F_k over a 3^p stencil of step ``h``)."""
    theta_star = np.asarray(theta_star, float)
    base = FESolverPredictor(spec, sensitivities=(method == "exact")).predict(theta_star)
    objective = Objective.from_prediction(base, radius=spec.indenter.radius, reading=reading, step=step)
    if method == "exact":
        H = gauss_newton_term_hessians(objective, base, theta_star)
    elif method == "fd":
        H = finite_difference_term_hessians(objective, FESolverPredictor(spec, n_jobs=n_jobs), theta_star, h)
    else:
        raise ValueError(f"unknown Hessian method {method!r}; use 'exact' or 'fd'")
    return DesignStudy(theta_star, H, method, reading, spec.to_dict(), base)
