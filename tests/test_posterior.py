"""The posterior sampler against a target whose answer is known in closed form (the way emcee tests
itself): a predictor linear in theta makes the residuals of eq. 4, 5 linear, F quadratic and the
posterior exp(-F / (2 s^2)) Gaussian with mean theta_LS and covariance s^2 (J^T J)^-1. Mean and sd
of the chain must match within a few Monte Carlo standard errors."""

from __future__ import annotations

import numpy as np
import pytest

from indentation_studio.design import PAPER_WEIGHTS, Objective
from indentation_studio.forward import Prediction
from indentation_studio.inference import sample_posterior
from indentation_studio.inference.posterior.sampling import carried_to_finer_mesh


class LinearResponse:
    """A Predictor whose force and top displacements are linear in theta: f = A theta, u = B theta."""

    parameters = ("c1", "c5")

    def __init__(self, steps: int = 3, grid: int = 6, seed: int = 1) -> None:
        rng = np.random.default_rng(seed)
        x, y = np.meshgrid(np.linspace(0.0, 20.0, grid), np.linspace(0.0, 20.0, grid))
        self.top_xyz = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, 60.0)])
        self.depth = 0.5 * np.arange(1, steps + 1)
        n = len(self.top_xyz)
        self.A = self.depth[:, None] * np.array([20.0, 0.3]) * (1 + 0.1 * rng.random((steps, 2)))
        decay = np.exp(-np.hypot(x, y).ravel() / 8.0)
        self.B = (
            self.depth[:, None, None, None]
            * decay[None, :, None, None]
            * rng.normal(0.0, 0.01, (steps, n, 3, 2))
        )

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        theta = np.atleast_2d(np.asarray(theta, float))
        m = len(theta)
        return Prediction(
            force=theta @ self.A.T,
            displacement=np.einsum("sjdp,np->nsjd", self.B, theta),
            depth=self.depth,
            top_xyz=self.top_xyz,
            force_jacobian=np.broadcast_to(self.A, (m, *self.A.shape)) if jacobian else None,
            displacement_jacobian=np.broadcast_to(self.B, (m, *self.B.shape)) if jacobian else None,
        )


@pytest.fixture(scope="module")
def linear_target():
    model = LinearResponse()
    rng = np.random.default_rng(7)
    truth = np.array([10.0, 300.0])
    exact = model.predict(truth)
    force = exact.force[0] * (1 + 0.02 * rng.standard_normal(exact.force.shape[1]))
    u = exact.displacement[0] + 0.002 * rng.standard_normal(exact.displacement.shape[1:])
    objective = Objective(force, u, model.top_xyz, radius=4.77)
    J = objective.jacobian(model.predict(truth, jacobian=True), PAPER_WEIGHTS)[0]
    r0 = objective.residuals(exact, PAPER_WEIGHTS)[0]
    theta_ls = truth - np.linalg.solve(J.T @ J, J.T @ r0)
    return model, objective, J, theta_ls


def test_gaussian_posterior_matches_closed_form(linear_target):
    model, objective, J, theta_ls = linear_target
    s = 0.05
    cov = s**2 * np.linalg.inv(J.T @ J)
    sd = np.sqrt(np.diag(cov))
    box = (theta_ls - 40 * sd, theta_ls + 40 * sd)  # uniform prior far wider than the posterior
    walkers, steps = 32, 3000
    post = sample_posterior(
        objective, model, PAPER_WEIGHTS, s=s, box=box, start=theta_ls, walkers=walkers, steps=steps, seed=3
    )
    assert post.converged
    tau = float(np.max(post.autocorrelation_steps))
    n_eff = walkers * steps / 2 / tau  # at most half the chain is burnt
    mc_mean = sd / np.sqrt(n_eff)  # Monte Carlo standard error of the mean
    mc_sd = sd / np.sqrt(2 * n_eff)  # ... and of the standard deviation
    assert np.all(np.abs(post.samples.mean(axis=0) - theta_ls) < 4 * mc_mean)
    assert np.all(np.abs(post.std() - sd) < 4 * mc_sd)
    corr = np.corrcoef(post.samples.T)[0, 1]
    assert corr == pytest.approx(cov[0, 1] / (sd[0] * sd[1]), abs=0.05)
    lo, hi = post.interval(0.95).T
    np.testing.assert_allclose(hi - lo, 2 * 1.959964 * sd, rtol=0.08)


def test_carried_posterior_is_shifted_and_widened_by_the_mesh_check(linear_target):
    model, objective, J, theta_ls = linear_target
    s = 0.01
    sd = np.sqrt(np.diag(s**2 * np.linalg.inv(J.T @ J)))
    post = sample_posterior(
        objective,
        model,
        PAPER_WEIGHTS,
        s=s,
        box=(theta_ls * 0.5, theta_ls * 1.5),
        start=theta_ls,
        walkers=16,
        steps=1500,
        seed=1,
    )
    shift_pct, gci_pct = np.array([-3.0, 12.0]), np.array([8.0, 15.0])
    moved = carried_to_finer_mesh(post, theta_ls, shift_pct, gci_pct, seed=2)
    mesh_sd = theta_ls * gci_pct / 100 / 1.959963984540054
    moved_by = moved.samples.mean(axis=0) - post.samples.mean(axis=0)
    assert np.all(np.abs(moved_by - theta_ls * shift_pct / 100) < 4 * mesh_sd / np.sqrt(len(post.samples)))
    np.testing.assert_allclose(moved.std(), np.hypot(post.std(), mesh_sd), rtol=0.1)
    assert np.all(sd < mesh_sd)  # the check's spread dominates here, so the test sees it


def test_corner_figure_shows_a_truth_far_from_the_samples():
    from indentation_studio.inference.posterior.sampling import Posterior
    from indentation_studio.studio.figures import corner_figure

    rng = np.random.default_rng(0)
    samples = rng.normal([11.7, 299.5], [0.023, 3.6], (4000, 2))
    post = Posterior(samples, ("c1", "c5"), np.array([20.0, 20.0]), 0.7, True, 1.0, 0.004)
    fig = corner_figure(
        post, np.array([11.7, 299.3]), np.array([[19.5, 2.27], [2.27, 0.47]]), 0.01, truth=[12, 250]
    )
    (x0, x1), (y0, y1) = fig.axes[2].get_xlim(), fig.axes[2].get_ylim()
    assert x0 < 11.7 < 12.0 < x1 and y0 < 250.0 < 299.5 < y1  # the 17 % miss is on the plot
    assert len(fig.axes[2].lines) >= 4  # fit and truth cross-hairs, the ellipse


def test_a_log_uniform_mu_not_identified_is_drawn_flat_on_a_log_axis():
    """mu drawn from its log-uniform prior: on a log axis its histogram is flat (no bin more than
    twice another), where a linear axis piles it at the range's low end as if the data said so."""
    from indentation_studio.inference.posterior.sampling import Posterior
    from indentation_studio.studio.figures import corner_figure

    rng = np.random.default_rng(0)
    mu = np.exp(rng.uniform(np.log(0.1), np.log(3.0), 8000))
    samples = np.column_stack([rng.normal(12.0, 0.1, 8000), rng.normal(250.0, 7.0, 8000), mu])
    post = Posterior(samples, ("c1", "c5", "mu"), np.array([20.0, 20.0, 20.0]), 0.7, True, 1.0, 0.004)
    heights = {}
    for scale in ((), ("mu",)):
        fig = corner_figure(post, np.array([12.0, 250.0, 0.5]), not_identified=("mu",), log_axes=scale)
        diag = fig.axes[8]
        assert diag.get_xscale() == ("log" if scale else "linear")
        bins = diag.patches[0].get_path().vertices[1::2, 1]  # corner's histogram: one step polygon
        bins = bins[bins > 0]
        heights[scale] = bins[1:-1]  # the end bins reach past the range (the plot's 5 % margin)
    flat, piled = heights[("mu",)], heights[()]
    assert flat.max() < 2 * flat.min() and piled.max() > 5 * piled.min()


def test_the_chain_runs_on_until_emcees_rule_holds_or_says_what_it_needs(linear_target):
    from indentation_studio.inference.posterior.sampling import AUTOCORRELATION_TOL

    model, objective, J, theta_ls = linear_target
    s, truth = 0.05, theta_ls
    sd = np.sqrt(np.diag(s**2 * np.linalg.inv(J.T @ J)))
    box = (theta_ls - 40 * sd, theta_ls + 40 * sd)
    short = sample_posterior(
        objective, model, PAPER_WEIGHTS, s=s, box=box, start=truth, walkers=8, steps=60, max_steps=60
    )
    assert not short.converged and short.steps == 60
    assert short.steps_needed == int(np.ceil(AUTOCORRELATION_TOL * short.autocorrelation_steps.max())) + 1
    assert "not converged: 60 steps" in short.convergence_message
    assert f"--steps {short.steps_needed}" in short.convergence_message
    summary = short.summary()
    assert summary["converged"] is False and summary["steps_needed"] == short.steps_needed
    long = sample_posterior(
        objective, model, PAPER_WEIGHTS, s=s, box=box, start=truth, walkers=8, steps=60, max_steps=20_000
    )
    assert long.converged and long.steps > AUTOCORRELATION_TOL * long.autocorrelation_steps.max()
    assert long.steps > 60 and long.convergence_message.startswith("converged")
