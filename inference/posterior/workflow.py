"""The posterior of (c1, c5) given a measured experiment, sampled on the surrogate (emcee), with the
noise level from the surrogate fit's residuals; optionally carried to a finer mesh by a stored
mesh check (:func:`inference.posterior.sampling.carried_to_finer_mesh`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from ...atomic_write import atomic_write_json
from ...design.certainty import bounds_pct
from ...design.friction_treatment import FrictionTreatment, friction_bounds
from ...design.objective import PAPER_WEIGHTS
from ...surrogate.base import FieldSurrogate
from ..budgets.mesh_check import load_mesh_check
from ..budgets.model_error import (
    ModelError,
    combined_pct,
    model_error_at,
    model_error_scope,
    with_model_error,
)
from ..experiment.data import ExperimentData
from ..experiment.processing_error import REGISTRATION_MM
from ..fit.error_parts import (
    left_out_with_friction,
    model_error_with_mu,
    mu_held_out_refits,
    mu_model_error_pct,
    mu_model_error_unmeasured,
    with_processing_part,
)
from ..fit.friction import _mu_range, fit_on_surrogate_with_mu, surrogate_with_mu
from ..fit.held_out_refits import HeldOutRefits
from ..fit.inputs import FitInputs, prepare_fit
from ..fit.inverse_fit import FitResult, fit_parameters
from .sampling import Posterior, carried_to_finer_mesh, sample_posterior

__all__ = ["PRIOR_END_FRACTION", "ExperimentPosterior", "interval_reaches_prior_end", "sample_posterior_for"]


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
    >>> from indentation_studio.inference.posterior.workflow import interval_reaches_prior_end
    >>> interval_reaches_prior_end((0.105, 2.9), (0.1, 3.0))
    {'lower': True, 'upper': True}
    >>> interval_reaches_prior_end((0.4, 0.6), (0.1, 3.0))
    {'lower': False, 'upper': False}
    """
    lo, hi = (float(v) for v in prior_range)
    a, b = (float(v) for v in interval)
    margin = PRIOR_END_FRACTION * np.log(hi / lo)
    return {"lower": bool(np.log(a / lo) <= margin), "upper": bool(np.log(hi / b) <= margin)}


@threadpool_limits.wrap(limits=1, user_api="blas")  # OpenBLAS spins: see forward.threads
def sample_posterior_for(
    experiment: str | Path | ExperimentData,
    surrogate: str | Path | FieldSurrogate | None = None,
    *,
    weights=PAPER_WEIGHTS,
    walkers: int = 32,
    steps: int = 4000,
    seed: int = 0,
    mesh_check: str | Path | None = None,
    fit: FitResult | None = None,
    exclude_steps=(),
    say: Callable[[str], None] | None = None,
    friction: FrictionTreatment | str | float | None = None,
    reading: str = "fit",
    registration_mm: float = REGISTRATION_MM,
    tests: str | Path | None = None,
) -> ExperimentPosterior:
    """Sample the posterior of (c1, c5) of an experiment on the surrogate with emcee.

    log L = -F / (2 sigma^2) with sigma the fit's residual sd (:attr:`FitResult.residual_sd`),
    uniform prior on the surrogate's training box, walkers started at the surrogate fit. On a
    multi-fidelity surrogate each sample is spread by the model error at the fit
    (:func:`inference.budgets.model_error.with_model_error`).

    Parameters
    ----------
    experiment : str, pathlib.Path or ExperimentData
        The experiment (folder or loaded).
    surrogate : str, pathlib.Path, FieldSurrogate or None
        The surrogate (file or loaded); None (default): the one shipped for the experiment's test
        (:func:`~indentation_studio.inference.fit.inputs.prepare_fit`), said in ``say``.
    weights : array_like, default PAPER_WEIGHTS
        The weights of eq. 5.
    walkers : int, default 32
        emcee walkers.
    steps : int, default 4000
        Steps per walker.
    seed : int, default 0
        Seed of the sampler.
    mesh_check : str or pathlib.Path, optional
        A fit.json or confirm.json made with a mesh check: the samples are carried to that finer
        mesh.
    fit : FitResult, optional
        The surrogate fit to start at; computed when not given.
    exclude_steps : sequence of int, default ()
        Steps (1..N) left out beside those the experiment excludes.
    say : callable, optional
        Where progress messages go.
    friction : FrictionTreatment, str or float, optional
        On a surrogate trained with mu as a parameter: a known mu (held), ``marginalise[:LO:HI]``
        (mu sampled with a log-uniform prior and marginalised: the intervals of (c1, c5) hold its
        uncertainty) or ``identify`` (the same with a uniform prior).
    reading : str, default "fit"
        The objective (eq. 4's reading): the fit's (DIC from 1.5 R) or ``paper``; as the fit's.
    registration_mm : float, default REGISTRATION_MM
        The indentation point's uncertainty, mm: the samples are spread by the processing's part
        as the fit's bounds carry it (``inference.experiment.processing_error``).

    tests : str or pathlib.Path, optional
        A prepared test's folder (``indent-studio test prepare``) read before the shipped surrogates
        (:func:`~indentation_studio.surrogate.shipped.find_test`).
    Returns
    -------
    ExperimentPosterior
        The samples, the fit, the noise level and what they were carried by.

    Raises
    ------
    ValueError
        If a friction treatment is asked of a surrogate without mu, a surrogate with mu gets none,
        or friction is combined with a mesh check (made with the perfect stick).
    """
    say = say or (lambda message: None)
    inputs = prepare_fit(experiment, surrogate, weights, exclude_steps, reading=reading, tests=tests)
    if surrogate is None:
        say(f"surrogate: {inputs.sources['surrogate']}")
    model = inputs.surrogate
    # by default mu is marginalised where the surrogate has it (as fit_experiment does)
    treatment = (
        FrictionTreatment("marginalise" if "mu" in model.parameters else "assumed")
        if friction is None
        else FrictionTreatment.parse(friction)
    )
    if mesh_check is not None and "mu" in model.parameters:
        raise ValueError("friction: the mesh check is made with the perfect stick; sample without it")
    predictor, mu_range, log_uniform = model, None, ()
    box = (np.array(model.scaler.lo, float), np.array(model.scaler.hi, float))
    if treatment.mode != "assumed" or "mu" in model.parameters:
        if "mu" not in model.parameters:
            raise ValueError(
                "friction: a posterior samples the surrogate, and this one has no mu; train one on a "
                "campaign with a mu axis (campaign run --grid ...,mu=LO:HI:N:log) or fit with --friction"
            )
        if treatment.mode == "assumed":
            raise ValueError(
                "friction: this surrogate was trained with mu as a parameter; say how the posterior "
                "treats it (a value, 'marginalise' or 'identify')"
            )
        mu_range = _mu_range(treatment, model)  # inside the training range
        predictor, box = surrogate_with_mu(model, treatment, mu_range)
        if fit is None:  # where the walkers start: fit_experiment's multi-start surrogate stage
            fit = fit_on_surrogate_with_mu(inputs.objective, model, inputs.eta, treatment, mu_range)
        log_uniform = (2,) if treatment.mode == "marginalise" else ()
    if fit is None:
        fit = fit_parameters(inputs.objective, predictor, inputs.eta)
    sigma = fit.residual_sd
    say(f"sampling with {walkers} walkers x {steps} steps (sigma = {sigma:.3g}) ...")
    centre = np.clip(fit.theta, box[0] + 1e-6 * (box[1] - box[0]), box[1] - 1e-6 * (box[1] - box[0]))
    post = sample_posterior(
        inputs.objective,
        predictor,
        inputs.eta,
        s=sigma,
        box=box,
        start=centre,
        walkers=walkers,
        steps=steps,
        seed=seed,
        log_uniform=log_uniform,
    )
    mu_model_pct, refits = None, None
    if "mu" in model.parameters:  # the parts the fit carries (fit.error_parts.model_error_with_mu)
        model_error = model_error_with_mu(
            inputs,
            treatment,
            mu_range,
            fit.theta,
            on_surrogate=True,
            registration_mm=registration_mm,
            say=say,
        )
        if fit.theta.size == 3 and model_error is not None:  # mu sampled: its own model error beside
            refits = mu_held_out_refits(inputs, fit.theta)
            mu_model_pct = mu_model_error_pct(
                inputs,
                fit.theta,
                on_surrogate=True,
                refits=refits,
                model_error=model_error,
            )
            model_error = model_error.with_mu(mu_model_pct)
    else:
        model_error = model_error_at(inputs.objective, inputs.eta, model, fit.theta)
        model_error = with_processing_part(
            model_error, inputs, fit.theta, inputs.spec.contact.describe(), registration_mm, say
        )
    if model_error is not None:  # spread by the model error, moved by a corrected budget's correction
        spread = with_model_error(post.samples, model_error, seed, box=box)
        post = replace(post, samples=model_error.corrected(spread))
    unmeasured = mu_model_error_unmeasured(inputs) if mu_range is not None else None
    if unmeasured is not None:  # what the data say of mu cannot be told from the model's error in it
        post = replace(
            post, samples=_mu_from_prior(post.samples, mu_range, log_uniform=bool(log_uniform), seed=seed)
        )
    carried = None
    if mesh_check is not None:
        carried = load_mesh_check(mesh_check, inputs.experiment.root, fit.theta)
        post = carried_to_finer_mesh(
            post, carried["theta"], carried["shift_pct"], carried["corrected_uncertainty_pct"], seed
        )
    return ExperimentPosterior(
        inputs,
        post,
        fit=fit,
        sigma=sigma,
        carried=carried,
        model_error=model_error,
        friction=treatment,
        mu_range=mu_range,
        mu_model_pct=mu_model_pct,
        mu_refits=refits,
        mu_unmeasured=unmeasured,
    )


def _mu_from_prior(samples: np.ndarray, mu_range, *, log_uniform: bool, seed: int) -> np.ndarray:
    """The samples with mu (their last column) drawn again from its prior, independently: where
    mu's model error is not measured (:func:`~indentation_studio.inference.fit.error_parts.mu_model_error_unmeasured`)
    the data's pull on mu cannot be told from the model's error, and the prior is what is known."""
    rng = np.random.default_rng(seed + 1)
    lo, hi = (float(v) for v in mu_range)
    out = samples.copy()
    u = rng.random(len(out))
    out[:, -1] = np.exp(np.log(lo) + u * np.log(hi / lo)) if log_uniform else lo + u * (hi - lo)
    return out
