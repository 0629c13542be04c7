"""The posterior of theta given a measurement (issue: inference), sampled with emcee.

log L(theta) = -F(theta) / (2 s^2) with F of eq. 5 and s the standard deviation of one normalised
residual (for measured data, sqrt(F(theta_hat) / (n - p)); not eq. 8's s, which carries the 95 %
quantile of the F distribution on top), a uniform prior on a box (the surrogate's training box), and an
affine-invariant ensemble sampler whose walkers start in a small ball around the fit. The
predictor is called with all walkers at once (emcee's vectorize), so a surrogate evaluates a
whole ensemble in one batch. A Predictor with a reduced basis (the surrogates) is not asked for
its fields at all: F is evaluated in its PCA space (design/reduced_objective.py), exactly up to
rounding and without rebuilding steps x nodes x 3 values per walker. The chain is checked:
integrated autocorrelation time (the chain must be longer than 50 of them for emcee's estimate to
be trusted: :data:`AUTOCORRELATION_TOL`, emcee's own ``tol``) and acceptance fraction. The chain
runs on until that rule holds, up to a cap; a chain stopped at the cap says so and how many steps
the rule asks for.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import emcee
import numpy as np

from ...design.objective import Objective, check_weights
from ...design.reduced_objective import ReducedObjective, objective_function

#: emcee's rule: a chain is long enough when it holds this many integrated autocorrelation times
#: (``emcee.autocorr.integrated_time``'s ``tol``).
AUTOCORRELATION_TOL = 50
#: A chain that has not converged is run on by at most this many times its first length.
MAX_STEPS_FACTOR = 8


@dataclass
class Posterior:
    """Posterior samples (n, p) after burn-in and thinning, with their summary and diagnostics.

    Attributes
    ----------
    samples : numpy.ndarray
        (n, p) the samples, kPa (mu unitless).
    parameters : tuple of str
        The parameters of the columns.
    autocorrelation_steps : numpy.ndarray
        (p,) emcee's integrated autocorrelation time per parameter, steps.
    acceptance_fraction : float
        The walkers' mean acceptance fraction.
    converged : bool
        Whether the chain is longer than :data:`AUTOCORRELATION_TOL` autocorrelation times (every
        one finite).
    wall_s : float
        Wall time, s.
    s : float
        The likelihood's noise level.
    objective_path : {"full", "reduced"}
        ``reduced``: F in the predictor's PCA space; ``full``: from its fields.
    steps : int
        Steps each walker ran (0: not recorded).
    """

    samples: np.ndarray
    parameters: tuple[str, ...]
    autocorrelation_steps: np.ndarray
    acceptance_fraction: float
    converged: bool
    wall_s: float
    s: float
    objective_path: str = "full"  # "reduced": F in the predictor's PCA space; "full": from its fields
    steps: int = 0  # steps each walker ran

    @property
    def steps_needed(self) -> int | None:
        """The steps emcee's rule asks for (:data:`AUTOCORRELATION_TOL` autocorrelation times), or None.

        Returns
        -------
        int or None
            None where an autocorrelation time is not finite.
        """
        tau = np.asarray(self.autocorrelation_steps, float)
        if tau.size == 0 or not np.all(np.isfinite(tau)):
            return None
        return int(np.ceil(AUTOCORRELATION_TOL * tau.max())) + 1

    @property
    def convergence_message(self) -> str:
        """The chain's convergence in words, as the CLI, the JSON and the report say it."""
        tau = ", ".join(f"{t:.1f}" for t in np.asarray(self.autocorrelation_steps, float))
        if self.converged:
            return (
                f"converged: {self.steps} steps, more than {AUTOCORRELATION_TOL} autocorrelation times "
                f"({tau} steps)"
            )
        needed = self.steps_needed
        more = "an autocorrelation time that is not finite" if needed is None else f"{needed} steps"
        return (
            f"not converged: {self.steps} steps where emcee's rule ({AUTOCORRELATION_TOL} autocorrelation "
            f"times of {tau} steps) asks for {more}; run with --steps {needed or 2 * self.steps} or more"
        )

    def median(self) -> np.ndarray:
        """(p,) the samples' median.

        Returns
        -------
        numpy.ndarray
            One value per parameter.
        """
        return np.median(self.samples, axis=0)

    def interval(self, level: float = 0.95) -> np.ndarray:
        """The central credible interval of each parameter.

        Parameters
        ----------
        level : float, default 0.95
            The probability inside.

        Returns
        -------
        numpy.ndarray
            (p, 2) lower and upper ends.
        """
        q = 100.0 * (1.0 - level) / 2.0
        return np.percentile(self.samples, [q, 100.0 - q], axis=0).T

    def std(self) -> np.ndarray:
        """(p,) the samples' standard deviation (ddof 1).

        Returns
        -------
        numpy.ndarray
            One value per parameter.
        """
        return self.samples.std(axis=0, ddof=1)

    def summary(self) -> dict:
        """The posterior's summary and diagnostics, JSON-ready.

        Returns
        -------
        dict
            Median, standard deviation, 68 % and 95 % intervals, autocorrelation, acceptance,
            convergence, number of samples, wall time, s and the objective's path.
        """
        return {
            "median": self.median().tolist(),
            "std": self.std().tolist(),
            "ci68": self.interval(0.68).tolist(),
            "ci95": self.interval(0.95).tolist(),
            "autocorrelation_steps": self.autocorrelation_steps.tolist(),
            "acceptance_fraction": self.acceptance_fraction,
            "converged": self.converged,
            "steps": self.steps,
            "steps_needed": self.steps_needed,
            "convergence": self.convergence_message,
            "samples": len(self.samples),
            "wall_s": self.wall_s,
            "s": self.s,
            "objective_path": self.objective_path,
        }


def sample_posterior(
    objective: Objective,
    predictor,
    eta,
    *,
    s: float,
    box: tuple[np.ndarray, np.ndarray],
    start: np.ndarray,
    walkers: int = 32,
    steps: int = 3000,
    seed: int = 0,
    progress: bool = False,
    reduced: bool | None = None,
    log_uniform: tuple[int, ...] = (),
    max_steps: int | None = None,
) -> Posterior:
    """Sample the posterior of theta with emcee, for log L = -F / (2 s^2) (F of eq. 5).

    The chain runs ``steps``, then on until it holds :data:`AUTOCORRELATION_TOL` integrated
    autocorrelation times (emcee's rule) or reaches ``max_steps``; :attr:`Posterior.converged`
    says which.

    Parameters
    ----------
    objective : Objective
        The target.
    predictor : Predictor
        The model.
    eta : array_like
        The weights of eq. 5.
    s : float
        The likelihood's noise level (> 0).
    box : tuple of numpy.ndarray
        (lo, hi): the prior is uniform on it.
    start : numpy.ndarray
        (p,) the walkers start around it, inside ``box``.
    walkers : int, default 32
        emcee walkers (at least 2 p).
    steps : int, default 3000
        Steps per walker at least.
    seed : int, default 0
        Seed of the start and the sampler.
    progress : bool, default False
        Show emcee's progress bar.
    reduced : bool, optional
        Evaluate F in the predictor's reduced space (its ``reduced_basis()``); None (default) does
        so whenever the predictor offers one, False rebuilds the fields and calls
        ``objective.value`` (the same F up to rounding, slower).
    log_uniform : tuple of int, default ()
        Indices of parameters whose prior is log-uniform on the box instead (a friction
        coefficient, whose scale is unknown: density 1 / mu).
    max_steps : int, optional
        Steps per walker at most; default :data:`MAX_STEPS_FACTOR` times ``steps``.

    Returns
    -------
    Posterior
        The samples after burn-in and thinning, with diagnostics.

    Raises
    ------
    ValueError
        If ``s`` is not positive, the start lies outside the box, or there are too few walkers.
    """
    eta = check_weights(eta)
    if not (np.isfinite(s) and s > 0):
        raise ValueError(f"s must be a positive number, got {s!r}")
    lo, hi = (np.asarray(b, float) for b in box)
    start = np.asarray(start, float)
    if np.any(start <= lo) or np.any(start >= hi):
        raise ValueError(
            f"the start {start.tolist()} lies outside the prior box {lo.tolist()} .. {hi.tolist()}"
        )
    p = start.size
    if walkers < 2 * p:
        raise ValueError(f"emcee needs at least {2 * p} walkers for {p} parameters, got {walkers}")

    t0 = time.perf_counter()
    F_of_theta = objective_function(objective, predictor, eta, reduced)

    def log_prob(thetas: np.ndarray) -> np.ndarray:
        out = np.full(len(thetas), -np.inf)
        inside = np.all((thetas > lo) & (thetas < hi), axis=1)
        if inside.any():
            out[inside] = -F_of_theta.value(thetas[inside]) / (2.0 * s**2)
            if log_uniform:
                out[inside] -= np.log(thetas[inside][:, list(log_uniform)]).sum(axis=1)
        return out

    rng = np.random.default_rng(seed)
    p0 = start * (1.0 + 1e-3 * rng.standard_normal((walkers, p)))
    p0 = np.clip(p0, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
    sampler = emcee.EnsembleSampler(walkers, p, log_prob, vectorize=True)
    sampler.random_state = np.random.RandomState(seed).get_state()
    cap = max(int(steps), int(max_steps if max_steps is not None else MAX_STEPS_FACTOR * steps))
    sampler.run_mcmc(p0, steps, progress=progress)
    while True:
        tau = sampler.get_autocorr_time(tol=0, quiet=True)
        steps = sampler.iteration
        finite = bool(np.all(np.isfinite(tau)))
        converged = bool(finite and steps > AUTOCORRELATION_TOL * np.max(tau))
        if converged or steps >= cap:
            break
        # on to 20 % beyond what the rule asks for now (tau's estimate grows with the chain)
        wanted = int(1.2 * AUTOCORRELATION_TOL * np.max(tau)) if finite else 2 * steps
        sampler.run_mcmc(None, min(cap, max(wanted, steps + steps // 4)) - steps, progress=progress)
    burn = int(min(steps // 2, np.ceil(3 * np.nanmax(tau)))) if np.all(np.isfinite(tau)) else steps // 2
    thin = max(int(np.nanmin(tau) // 2), 1) if np.all(np.isfinite(tau)) else 1
    samples = sampler.get_chain(discard=burn, thin=thin, flat=True)
    return Posterior(
        samples=samples,
        parameters=tuple(getattr(predictor, "parameters", ("c1", "c5"))),
        autocorrelation_steps=np.asarray(tau),
        acceptance_fraction=float(np.mean(sampler.acceptance_fraction)),
        converged=converged,
        wall_s=time.perf_counter() - t0,
        s=float(s),
        objective_path="reduced" if isinstance(F_of_theta, ReducedObjective) else "full",
        steps=int(steps),
    )


def carried_to_finer_mesh(
    posterior: Posterior,
    theta_hat: np.ndarray,
    shift_pct: np.ndarray,
    uncertainty_pct: np.ndarray,
    seed: int = 0,
) -> Posterior:
    """The posterior of theta on a finer mesh, from one sampled on the fit's mesh and a mesh
    check at ``theta_hat`` (inference/budgets/mesh_check.py): each sample moved by the check's first-order
    shift, theta_hat shift_pct / 100, plus an independent normal error whose 95 % half-width is
    the finer mesh's GCI, ``uncertainty_pct`` of theta_hat. The discretisation error is thus
    treated as a second, independent source of error beside the measurement noise, and the
    intervals cover both (ASME V&V 20's combination of numerical and data uncertainty)."""
    theta_hat = np.asarray(theta_hat, float)
    shift = theta_hat * np.asarray(shift_pct, float) / 100.0
    sd = theta_hat * np.asarray(uncertainty_pct, float) / 100.0 / 1.959963984540054
    if not (np.all(np.isfinite(shift)) and np.all(np.isfinite(sd)) and np.all(sd >= 0)):
        raise ValueError(
            f"the mesh check's shift {shift_pct} and uncertainty {uncertainty_pct} must be finite"
        )
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal(posterior.samples.shape) * sd
    return replace(posterior, samples=posterior.samples + shift + noise)
