"""A sampled posterior of an experiment: its samples, the fit they centre on, what it carries and
what it claims of mu (:class:`ExperimentPosterior`, written as ``posterior.json``), and the rule by
which a marginal reaching its prior's end is not an identification
(:func:`interval_reaches_prior_end`). Sampled by :func:`.workflow.sample_posterior_for`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...atomic_write import atomic_write_json
from ...design.certainty import bounds_pct
from ...design.friction_treatment import FrictionTreatment, friction_bounds
from ..budgets.model_error import ModelError, combined_pct, model_error_scope
from ..fit.error_parts import left_out_with_friction
from ..fit.held_out_refits import HeldOutRefits
from ..fit.inputs import FitInputs
from ..fit.inverse_fit import FitResult
from .sampling import Posterior

__all__ = ["PRIOR_END_FRACTION", "ExperimentPosterior", "interval_reaches_prior_end"]


@dataclass
class ExperimentPosterior:
    """The posterior of an experiment: the samples, the fit they centre on, the noise level.

    Attributes
    ----------
    inputs : FitInputs
        The experiment, surrogate and objective.
    posterior : Posterior
        The samples.
    fit : FitResult
        The fit on the surrogate the posterior was sampled on.
    sigma : float
        The likelihood's residual sd, ``fit.residual_sd``.
    carried : dict or None
        The mesh check the samples were carried by.
    model_error : ModelError or None
        Spread into the samples (multi-fidelity surrogate).
    friction : FrictionTreatment
        How mu was treated.
    mu_range : tuple of float or None
        The prior's range when mu is sampled.
    """

    inputs: FitInputs
    posterior: Posterior
    fit: FitResult  # the fit on the surrogate the posterior was sampled on
    sigma: float  # the likelihood's residual sd, fit.residual_sd
    carried: dict | None = None  # the mesh check read by inference.budgets.mesh_check.load_mesh_check
    model_error: ModelError | None = None  # spread into the samples (multi-fidelity surrogate)
    friction: FrictionTreatment = field(default_factory=FrictionTreatment)
    mu_range: tuple[float, float] | None = None  # the prior's range when mu is sampled
    mu_model_pct: float | None = None  # the model's own errors on mu spread into its samples
    mu_refits: HeldOutRefits | None = None  # the fit made again with the discrepancy's held-out errors
    # why mu's model error at the high fidelity is not measured (its samples are then the prior's)
    mu_unmeasured: str | None = None

    @property
    def mu_identified(self) -> bool | None:
        """Whether the posterior identifies mu (None: mu not sampled).

        mu's 95 % interval reaches neither end of its prior's range: an end within
        :data:`PRIOR_END_FRACTION` of the range (in log mu) counts as reached, since a marginal that
        the data do not bound there runs to the prior's end. Nor where a fit made again with one of
        the discrepancy's held-out errors ends on an end (:attr:`mu_refits`): the fit then does not
        claim mu either, and the posterior says what the fit says.
        """
        if self.mu_range is None or "mu" not in self.posterior.parameters:
            return None
        if self.mu_unmeasured is not None:
            return False
        if self.mu_refits is not None and any(self.mu_refits.reaches(2).values()):
            return False
        k = self.posterior.parameters.index("mu")
        return not any(interval_reaches_prior_end(self.posterior.interval(0.95)[k], self.mu_range).values())

    @property
    def not_identified(self) -> tuple[str, ...]:
        """The sampled parameters the data do not identify (mu, where :attr:`mu_identified` is False)."""
        return ("mu",) if self.mu_identified is False else ()

    @property
    def fit_bounds(self) -> np.ndarray:
        """(p, 2) the fit's 95 % bounds as a fit reports them (eq. 6 and the same model-error parts).

        Around the fit moved as the samples were (:attr:`marker`); mu's within its prior's range, as
        the fit's interval is (nothing is known outside it: the demo's was [-12.3, 15.3]).
        """
        pct = combined_pct(self._laplace_pct(self.fit.s), self.model_error)
        centre = self.marker
        bounds = np.column_stack([centre * (1 - pct / 100.0), centre * (1 + pct / 100.0)])
        if self.friction.fits_mu and self.mu_range is not None:
            k = self.posterior.parameters.index("mu")
            bounds[k] = np.clip(bounds[k], *self.mu_range)
        return bounds

    @property
    def contact(self) -> str:
        """What the intervals assume of the contact, in words."""
        return self.friction.describe(self.inputs.spec.contact.describe(), self.mu_range)

    def _friction_dict(self) -> dict:
        """posterior.json's 'friction': the treatment; with mu sampled, its interval and the Laplace
        parts at the fit (the bounds of (c1, c5) with mu known there, and mu's share)."""
        out = {"treatment": self.friction.mode, "contact": self.contact}
        if self.friction.mode == "known":
            out["mu"] = self.friction.value
        if self.friction.fits_mu:
            k = self.posterior.parameters.index("mu")
            f = self.fit
            fb = friction_bounds(f.hessian, f.s, self.sigma, self.friction, self.mu_range, f.n_residuals)
            out |= {
                "mu_range": list(self.mu_range),
                "prior": "log-uniform" if self.friction.mode == "marginalise" else "uniform",
                "mu_median": float(np.median(self.posterior.samples[:, k])),
                "mu_ci95": self.posterior.interval(0.95)[k].tolist(),
                "mu_model_pct": self.mu_model_pct,
                "mu_identified": self.mu_identified,
                "mu_held_out_refits": None if self.mu_refits is None else self.mu_refits.describe(2),
                "mu_model_unmeasured": self.mu_unmeasured,
                "mu_reaches_prior_end": interval_reaches_prior_end(
                    self.posterior.interval(0.95)[k], self.mu_range
                ),
                "laplace_conditional_pct": fb["conditional_pct"],
                "laplace_mu_share_pct": fb["mu_share_pct"],
            }
        return out

    @property
    def marker(self) -> np.ndarray:
        """The fit, moved as the samples were: by a corrected budget, or carried to a finer mesh."""
        theta = self.fit.theta if self.model_error is None else self.model_error.corrected(self.fit.theta)
        if self.carried is None:
            return theta
        return theta + np.asarray(self.carried["theta"]) * np.asarray(self.carried["shift_pct"]) / 100.0

    def _laplace_pct(self, s: float) -> np.ndarray:
        """Eq. 6's half-widths (percent) at the fit for ``s``; with mu sampled, those of
        :func:`friction_bounds` (mu's prior in them when marginalised, (c1, c5) finite where the
        data hold nothing on mu), mu's last."""
        if not self.friction.fits_mu:
            return bounds_pct(self.fit.hessian, s)
        f = self.fit
        fb = friction_bounds(f.hessian, s, self.sigma, self.friction, self.mu_range, f.n_residuals)
        return np.append(fb["bounds_pct"], fb["mu_pct"])

    @property
    def hessian_sd(self) -> np.ndarray:
        """The Gaussian approximation's sd at the fit: cov = 2 sigma^2 H^-1 (H in theta_bar)."""
        return self.fit.theta * self._laplace_pct(self.sigma) / 100.0

    def to_dict(self) -> dict:
        """posterior.json: the summary (median, sd, 68 % and 95 % intervals, chain diagnostics)."""
        return {
            **self.posterior.summary(),
            "parameters": list(self.posterior.parameters),
            "fit": self.fit.theta.tolist(),
            "hessian_sd": self.hessian_sd.tolist(),
            "hessian_bounds_pct": self._laplace_pct(self.fit.s).tolist(),
            "fit_bounds": self.fit_bounds.tolist(),
            "sigma": self.sigma,
            "carried_to_finer_mesh": self.carried,
            "model_error": None if self.model_error is None else self.model_error.to_dict(),
            "intervals_include": model_error_scope(
                self.model_error,
                noise="measurement noise",
                contact=self.contact,
                unmeasured=left_out_with_friction(self.inputs),
            ),
            "friction": self._friction_dict(),
            "inputs": {**self.inputs.sources, "weights": self.inputs.eta.tolist()},
        }

    def save(self, folder: str | Path, **extra) -> Path:
        """Write ``folder/posterior.json`` atomically.

        Parameters
        ----------
        folder : str or pathlib.Path
            The folder.
        **extra
            Further keys, e.g. the corner plot's path.

        Returns
        -------
        pathlib.Path
            The file written.
        """
        return atomic_write_json(Path(folder) / "posterior.json", {**self.to_dict(), **extra})


#: A 95 % interval whose end lies within this fraction of the prior's range (in log) of the range's
#: end reaches it: a marginal the data leave open runs to the prior's end (a log-uniform prior puts
#: 2.5 % of its mass in the last 2.5 % of its log range).
PRIOR_END_FRACTION = 0.05


def interval_reaches_prior_end(interval, prior_range) -> dict[str, bool]:
    """Whether a positive parameter's 95 % interval reaches each end of its prior's range.

    Parameters
    ----------
    interval : sequence of float
        The interval (lower, upper).
    prior_range : sequence of float
        The prior's range (lo, hi), both > 0.

    Returns
    -------
    dict
        ``{"lower": bool, "upper": bool}``.

    Examples
    --------
    >>> from indentation_studio.inference.posterior.experiment_posterior import interval_reaches_prior_end
    >>> interval_reaches_prior_end((0.105, 2.9), (0.1, 3.0))
    {'lower': True, 'upper': True}
    >>> interval_reaches_prior_end((0.4, 0.6), (0.1, 3.0))
    {'lower': False, 'upper': False}
    """
    lo, hi = (float(v) for v in prior_range)
    a, b = (float(v) for v in interval)
    margin = PRIOR_END_FRACTION * np.log(hi / lo)
    return {"lower": bool(np.log(a / lo) <= margin), "upper": bool(np.log(hi / b) <= margin)}
