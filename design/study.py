"""One design study: the term Hessians at theta* for a model spec, from the embedded solver's exact
sensitivities (Gauss-Newton) or finite differences on any Predictor, and the bounds they give."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from ..forward.fe_predictor import FESolverPredictor
from ..forward.predictor import Prediction
from ..forward.spec import ModelSpec
from .certainty import (
    DESIGN_BOUNDS_INCLUDE,
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
    """Term Hessians H_k (4, p, p) in theta_bar at ``theta_star`` and where they came from.

    ``hessian(eta)`` combines them (eq. 5, 7) and ``bounds(eta, s)`` gives eq. 6's bounds.

    Attributes
    ----------
    theta_star : numpy.ndarray
        (p,) theta*, kPa (and mu).
    term_hessians : numpy.ndarray
        (4, p, p) Hessians of the force and the ux, uy, uz objectives, in theta_bar = theta / theta*.
    method : {"exact", "fd"}
        Gauss-Newton from sensitivities, or finite differences.
    reading : str
        How eq. 4 was read.
    spec : dict
        The model's ``ModelSpec.to_dict()``.
    baseline : Prediction or None
        The response at theta*.
    objective : Objective or None
        The objective against that response.
    """

    theta_star: np.ndarray
    term_hessians: np.ndarray
    method: str
    reading: str
    spec: dict
    baseline: Prediction | None = field(default=None, repr=False)
    objective: Objective | None = field(default=None, repr=False)

    def hessian(self, eta) -> np.ndarray:
        """H(eta) = sum_k eta_k H_k (eq. 5, 7).

        Parameters
        ----------
        eta : array_like
            The four weights.

        Returns
        -------
        numpy.ndarray
            (p, p) in theta_bar.
        """
        return combine(self.term_hessians, eta)

    def bounds(self, eta, s: float = 0.05) -> np.ndarray:
        """Eq. 6's bounds at theta* for the weights ``eta``, percent.

        Parameters
        ----------
        eta : array_like
            The four weights.
        s : float, default 0.05
            Eq. 6's s.

        Returns
        -------
        numpy.ndarray
            (p,) half-widths, percent.
        """
        return bounds_pct(self.hessian(eta), s)

    def objective_points(self, eta) -> int:
        """n, the data points the objective weighs with ``eta`` (eq. 8).

        Parameters
        ----------
        eta : array_like
            The four weights.

        Returns
        -------
        int
            n.

        Raises
        ------
        ValueError
            If the study keeps no objective (made without :func:`fe_design_study`).
        """
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
    """The design study at ``theta_star``: term Hessians (eq. 7) from the embedded FE solver.

    Parameters
    ----------
    spec : ModelSpec
        The model.
    theta_star : array_like, default (10.0, 350.0)
        theta*, one value per parameter (kPa; mu unitless).
    method : {"exact", "fd"}, default "exact"
        ``exact``: Gauss-Newton with the solver's sensitivities (one simulation); ``fd``: central
        differences of F_k over a 3^p stencil of step ``h``.
    reading : str, default "paper"
        How eq. 4 is read.
    step : int, optional
        Compare this step only (:class:`Objective`).
    h : float or tuple of float, default 0.02
        The finite-difference step in theta_bar (``fd``).
    n_jobs : int, default 1
        Parallel simulations (``fd``).
    parameters : tuple of str, default ("c1", "c5")
        ``("c1", "c5", "mu")`` with theta* = (c1, c5, mu) gives 3 x 3 Hessians, the friction
        coefficient's row and column beside (c1, c5)'s (:func:`friction_design_bounds`).

    Returns
    -------
    DesignStudy
        The term Hessians, the response at theta* and its objective.

    Raises
    ------
    ValueError
        If ``theta_star`` does not give one value per parameter, or the method is unknown.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> study = ins.fe_design_study(ins.ModelSpec())  # doctest: +SKIP
    >>> study.bounds(ins.PAPER_WEIGHTS, s=0.05)  # doctest: +SKIP
    """
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
    """The bounds (percent) of c1 and c5 of a study with mu, for mu known, identified or a nuisance.

    A nuisance has a log-uniform prior on ``mu_prior`` (the Laplace stand-in of
    :func:`design.friction_treatment.friction_bounds`); mu's own bound is given when identified.
    With mu fitted too the region is 3-D and s is read for p = 3 (eq. 8, n the objective's data
    points), and the residual sd the prior is weighed against is s / sqrt(2 F_{2, n-2}^0.95).

    Parameters
    ----------
    study : DesignStudy
        A study with mu (3 x 3 Hessians).
    eta : array_like
        The weights of eq. 5.
    s : float
        The design's noise level for (c1, c5) as without friction (eq. 8 with p = 2), so that the
        bounds with mu known are those of ``design bounds`` on that contact.
    mu_prior : tuple of float
        The support of mu's log-uniform prior.

    Returns
    -------
    dict
        ``mu``, ``s``, ``s_with_mu``, ``known_pct``, ``identified_pct``, ``identified_mu_pct``,
        ``nuisance_pct``, ``nuisance_mu_share_pct``, ``mu_prior``.

    Raises
    ------
    ValueError
        If the study has no mu, or ``s`` is not a positive number.
    """
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


def model_design_study(
    spec: ModelSpec,
    *,
    method: str = "exact",
    reading: str = "paper",
    h: float | tuple[float, ...] = 0.02,
    n_jobs: int = 1,
) -> DesignStudy:
    """The design study at the model's own (c1, c5), and its mu when the contact has friction.

    theta* is the spec's material, and with a friction coefficient mu > 0 its contact's mu too
    (3 x 3 Hessians; mu = 0, frictionless, has no d/d(log mu): (c1, c5) alone).

    Parameters
    ----------
    spec : ModelSpec
        The model at theta*.
    method, reading, h, n_jobs
        As :func:`fe_design_study`.

    Returns
    -------
    DesignStudy
        The term Hessians at theta*.
    """
    mu = spec.contact.friction
    with_mu = mu is not None and mu > 0
    theta = (spec.material.c1, spec.material.c5, *((mu,) if with_mu else ()))
    parameters = ("c1", "c5", "mu") if with_mu else ("c1", "c5")
    return fe_design_study(spec, theta, method, reading, h=h, n_jobs=n_jobs, parameters=parameters)


@dataclass
class DesignBounds:
    """The certainty bounds (eq. 6) of c1 and c5 for one set of weights at a study's theta*.

    With friction, also the three treatments of mu (:func:`friction_design_bounds`).

    Attributes
    ----------
    study : DesignStudy
        The study the bounds come from.
    weights : numpy.ndarray
        (4,) the weights eta (eq. 5).
    s : float
        The noise level of eq. 6.
    bounds_pct : numpy.ndarray
        (2,) the bounds of c1 and c5, percent (with friction: mu known).
    friction : dict or None
        :func:`friction_design_bounds`' result (or, for mu = 0, the known bounds alone); None
        without friction.
    """

    study: DesignStudy
    weights: np.ndarray
    s: float
    bounds_pct: np.ndarray
    friction: dict[str, Any] | None

    def to_dict(self) -> dict[str, Any]:
        """The bounds as ``design bounds --json`` prints them.

        Returns
        -------
        dict
            c1_pct, c5_pct, friction, hessian, weights, s, method, reading, term_hessians and
            what the bounds include.
        """
        return {
            "c1_pct": float(self.bounds_pct[0]),
            "c5_pct": float(self.bounds_pct[1]),
            "friction": self.friction,
            "hessian": self.study.hessian(self.weights).tolist(),
            "weights": self.weights.tolist(),
            "s": self.s,
            "method": self.study.method,
            "reading": self.study.reading,
            "term_hessians": self.study.term_hessians.tolist(),
            "bounds_include": DESIGN_BOUNDS_INCLUDE,
        }


def design_bounds(
    study: DesignStudy, eta, s: float = 0.05, *, mu_prior: tuple[float, float] = (0.1, 3.0)
) -> DesignBounds:
    """The bounds of c1 and c5 (eq. 6) for the weights ``eta`` at a study's theta*.

    On a model with friction mu: with mu known, identified and a nuisance with a log-uniform prior
    on ``mu_prior`` (mu = 0: known only).

    Parameters
    ----------
    study : DesignStudy
        The study (:func:`model_design_study`); its spec's contact says the friction.
    eta : array_like
        The objective's weights (force, ux, uy, uz).
    s : float
        The noise level of eq. 6.
    mu_prior : tuple of float
        The range of mu's log-uniform prior as a nuisance.

    Returns
    -------
    DesignBounds
        The bounds, percent.
    """
    eta = np.asarray(eta, float)
    mu = study.spec.get("contact", {}).get("friction")
    friction = None
    if mu is None:
        b = study.bounds(eta, s)
    elif mu == 0:  # the end of mu's range, where mu has no log: the frictionless bounds alone
        b = study.bounds(eta, s)
        friction = {"mu": 0.0, "known_pct": b.tolist(), "identified_pct": None, "nuisance_pct": None}
        friction["note"] = "mu = 0 (frictionless): only the bounds with mu known; give mu > 0 for the others"
    else:
        friction = friction_design_bounds(study, eta, s, mu_prior)
        b = np.array(friction["known_pct"])
    return DesignBounds(study, eta, s, b, friction)
