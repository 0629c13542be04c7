"""One design study: the term Hessians at theta* for a model spec, from the embedded solver's exact
sensitivities (Gauss-Newton) or finite differences on any Predictor, and the bounds they give."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..forward.predictor import FESolverPredictor, Prediction
from ..forward.spec import ModelSpec
from .certainty import (
    bounds_pct,
    combine,
    finite_difference_term_hessians,
    gauss_newton_term_hessians,
    s_for_parameters,
)
from .friction_treatment import FrictionTreatment, friction_bounds
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
    objective: Objective | None = field(default=None, repr=False)

    def hessian(self, eta) -> np.ndarray:
        return combine(self.term_hessians, eta)

    def bounds(self, eta, s: float = 0.05) -> np.ndarray:
        return bounds_pct(self.hessian(eta), s)

    def objective_points(self, eta) -> int:
        """n, the data points the objective weighs with ``eta`` (eq. 8)."""
        if self.objective is None:
            raise ValueError("the study keeps no objective (made without fe_design_study)")
        return self.objective.data_points(eta)


def fe_design_study(
    spec: ModelSpec,
    theta_star=(10.0, 350.0),
    method: str = "exact",
    reading: str = "paper",
    step: int | None = None,
    h: float | tuple[float, ...] = 0.02,
    n_jobs: int = 1,
    parameters: tuple[str, ...] = ("c1", "c5"),
) -> DesignStudy:
    """Hessians from the embedded FE solver: ``exact`` (Gauss-Newton with its sensitivities, one
    simulation) or ``fd`` (central differences of F_k over a 3^p stencil of step ``h``).
    ``parameters`` ('c1', 'c5', 'mu') with theta* = (c1, c5, mu) gives 3 x 3 Hessians, the friction
    coefficient's row and column beside (c1, c5)'s (:func:`design.study.friction_design_bounds`)."""
    theta_star = np.asarray(theta_star, float)
    if theta_star.shape != (len(parameters),):
        raise ValueError(f"theta* must give {parameters}, got {theta_star.tolist()}")
    base = FESolverPredictor(spec, sensitivities=(method == "exact"), parameters=parameters).predict(
        theta_star
    )
    objective = Objective.from_prediction(base, radius=spec.indenter.radius, reading=reading, step=step)
    if method == "exact":
        H = gauss_newton_term_hessians(objective, base, theta_star)
    elif method == "fd":
        fe = FESolverPredictor(spec, n_jobs=n_jobs, parameters=parameters)
        H = finite_difference_term_hessians(objective, fe, theta_star, h)
    else:
        raise ValueError(f"unknown Hessian method {method!r}; use 'exact' or 'fd'")
    return DesignStudy(theta_star, H, method, reading, spec.to_dict(), base, objective)


def friction_design_bounds(study: DesignStudy, eta, s: float, mu_prior: tuple[float, float]) -> dict:
    """The bounds (percent) of c1 and c5 of a study with mu (3 x 3 Hessians) when mu is known,
    identified with them, or a nuisance with a log-uniform prior on ``mu_prior`` (the Laplace
    stand-in of :func:`design.friction_treatment.friction_bounds`), and mu's own bound when
    identified. ``s`` is the design's noise level for (c1, c5) as without friction (eq. 8 with
    p = 2), so that the bounds with mu known are those of ``design bounds`` on that contact; with
    mu fitted too the region is 3-D and s is read for p = 3 (eq. 8, n the objective's data
    points), and the residual sd the prior is weighed against is s / sqrt(2 F_{2, n-2}^0.95)."""
    H = study.hessian(eta)
    if H.shape != (3, 3):
        raise ValueError("the study has no mu: run it with parameters ('c1', 'c5', 'mu')")
    if not (np.isfinite(s) and s > 0):
        raise ValueError(f"s must be a positive number, got {s!r}")
    n = study.objective_points(eta)
    sigma = s / np.sqrt(2 * stats.f.ppf(0.95, 2, n - 2))
    s3 = s_for_parameters(s, n, 2, 3)
    ident = friction_bounds(H, s3, sigma, FrictionTreatment("identify"), mu_prior, n)
    nuisance = friction_bounds(H, s3, sigma, FrictionTreatment("marginalise"), mu_prior, n)
    return {
        "mu": float(study.theta_star[2]),
        "s": s,
        "s_with_mu": s3,
        "known_pct": ident["conditional_pct"],
        "identified_pct": ident["bounds_pct"],
        "identified_mu_pct": ident["mu_pct"],
        "nuisance_pct": nuisance["bounds_pct"],
        "nuisance_mu_share_pct": nuisance["mu_share_pct"],
        "mu_prior": list(mu_prior),
    }
