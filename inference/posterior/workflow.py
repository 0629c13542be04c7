"""The posterior of (c1, c5) given a measured experiment, sampled on the surrogate (emcee), with the
noise level from the surrogate fit's residuals and the parts the fit's bounds carry; optionally
carried to a finer mesh by a stored mesh check
(:func:`inference.posterior.sampling.carried_to_finer_mesh`). What it returns is
:class:`.experiment_posterior.ExperimentPosterior`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from ...design.friction_treatment import FrictionTreatment
from ...design.objective import PAPER_WEIGHTS
from ...surrogate.base import FieldSurrogate
from ..budgets.mesh_check import load_mesh_check
from ..budgets.model_error import model_error_at, with_model_error
from ..experiment.data import ExperimentData
from ..experiment.processing_error import REGISTRATION_MM
from ..fit.error_parts import (
    model_error_with_mu,
    mu_held_out_refits,
    mu_model_error_pct,
    mu_model_error_unmeasured,
    with_processing_part,
)
from ..fit.friction import _mu_range, fit_on_surrogate_with_mu, surrogate_with_mu
from ..fit.inputs import prepare_fit
from ..fit.inverse_fit import FitResult, fit_parameters
from .experiment_posterior import ExperimentPosterior
from .sampling import carried_to_finer_mesh, sample_posterior

__all__ = ["sample_posterior_for"]


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
