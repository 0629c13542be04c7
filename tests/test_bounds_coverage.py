"""Coverage of the fit's bounds over 200 seeded noise draws (noise only, no model error).

The small model is a Gaussian-process surrogate of the coarse mesh with four steps, trained on a
3 x 3 campaign. The data are that surrogate's own response at a truth inside its box, so the
model is exact and only noise separates the data from it. The noise is what eq. 8 assumes:
every residual of eq. 5 independent with one standard deviation (force readings 0.3 % of the
force over sqrt(eta_force); each displacement reading 0.3 % over sqrt(eta_j) of eq. 4b's scale at
its node). Each draw is fitted with :func:`inverse_fit.fit_parameters` (Levenberg-Marquardt on the
surrogate, the fit the studio reports) and its eq. 6 to 8 bounds are compared with the truth.

What the hit rates must be: eq. 6 bounds theta_hat +- s sqrt(2 (H^-1)_ii) with eq. 8's s (p F_{p,
n-p}) are the projections on each axis of the joint 95 % certainty region {F(theta) - F_hat <=
s^2}. The region holds the truth 95 % of the time; each projected bound holds it more often,
P(F_{1, n-p} <= p F_{p, n-p}^0.95) = 98.6 % for p = 2. So three rates, each inside the 99 %
binomial interval of n = 200 around its nominal level: the joint region (95 %), the eq. 6
bound of c1 and of c5 (98.6 %), and the marginal 95 % bound of c1 and of c5 (the same H and s,
the half-width scaled by sqrt(F_{1, n-p}^0.95 / (p F_{p, n-p}^0.95))).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from indentation_studio.campaign.loader import load_campaign
from indentation_studio.campaign.runner import run_named_campaign
from indentation_studio.design.objective import Objective
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.fit.inverse_fit import PAPER_START, fit_parameters
from indentation_studio.surrogate.training import train_surrogate

SPEC = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=4))
ETA = np.array([0.45, 0.35, 0.2, 0.0])  # the paper's weights (PAPER_WEIGHTS)
TRUTH = np.array([10.0, 300.0])
DRAWS = 200
SIGMA = 0.003  # sd of one residual of eq. 5 (times sqrt(eta_k)): bounds of about 1 %, a linear regime


@pytest.fixture(scope="module")
def surrogate(tmp_path_factory):
    runs = tmp_path_factory.mktemp("runs")
    summary = run_named_campaign("coverage", "c1=6:14:3,c5=200:400:3", SPEC, runs_dir=runs, jobs=1)
    assert summary["failed"] == 0
    return train_surrogate(load_campaign("coverage", runs), "gp")


def _noisy_objective(clean: Objective, force, displacement, top, rng) -> Objective:
    """The data of one draw: residual noise SIGMA / sqrt(eta_k) on every weighted reading."""
    noisy_force = force * (1.0 + SIGMA / np.sqrt(ETA[0]) * rng.standard_normal(force.shape))
    scale = clean.displacement_residual_scale()  # (nodes, 3): sqrt(w) / max |u|, 0 where unmeasured
    per_eta = np.divide(SIGMA, np.sqrt(ETA[1:]), out=np.zeros(3), where=ETA[1:] > 0)  # uz: no weight
    sd = np.divide(per_eta, scale, out=np.zeros_like(scale), where=scale > 0)
    noisy_u = displacement + sd * rng.standard_normal(displacement.shape)
    return Objective(noisy_force, noisy_u, top, radius=SPEC.indenter.radius)


@pytest.mark.slow
def test_the_fit_bounds_hold_the_truth_as_often_as_they_say(surrogate):
    target = surrogate.predict(TRUTH[None, :])
    force, displacement, top = target.force[0], target.displacement[0], target.top_xyz
    clean = Objective(force, displacement, top, radius=SPEC.indenter.radius)
    rng = np.random.default_rng(20261125)
    joint, projected, marginal, errors = [], [], [], []
    for _ in range(DRAWS):
        objective = _noisy_objective(clean, force, displacement, top, rng)
        fit = fit_parameters(objective, surrogate, ETA, theta0=PAPER_START)
        d = np.log(TRUTH / fit.theta)  # theta_bar - 1 to first order, the Hessian's coordinates
        n, p = fit.n_residuals, fit.theta.size
        joint.append(d @ fit.hessian @ d / 2.0 <= fit.s**2)
        lo, hi = fit.interval().T
        projected.append((lo <= TRUTH) & (TRUTH <= hi))
        to_marginal = np.sqrt(stats.f.ppf(0.95, 1, n - p) / (p * stats.f.ppf(0.95, p, n - p)))
        marginal.append(np.abs(d) <= to_marginal * fit.bounds_pct / 100.0)
        errors.append(fit.theta / TRUTH - 1.0)
    joint_hits, projected_hits, marginal_hits = (
        int(np.sum(joint)),
        np.sum(projected, axis=0),
        np.sum(marginal, axis=0),
    )
    nominal_projected = stats.f.cdf(p * stats.f.ppf(0.95, p, n - p), 1, n - p)
    at_95 = stats.binom.interval(0.99, DRAWS, 0.95)
    at_projected = stats.binom.interval(0.99, DRAWS, nominal_projected)
    report = (
        f"of {DRAWS} draws: joint region {joint_hits}, eq. 6 bounds (c1, c5) {projected_hits.tolist()}, "
        f"marginal 95 % (c1, c5) {marginal_hits.tolist()}; 99 % binomial interval around 95 %: {at_95}, "
        f"around {nominal_projected:.4f}: {at_projected}; mean error (c1, c5) "
        f"{np.round(100 * np.mean(errors, axis=0), 3).tolist()} %"
    )
    print(report)
    assert at_95[0] <= joint_hits <= at_95[1], report
    for name, hits in zip(("c1", "c5"), marginal_hits, strict=True):
        assert at_95[0] <= hits <= at_95[1], f"{name}: {report}"
    for name, hits in zip(("c1", "c5"), projected_hits, strict=True):
        assert at_projected[0] <= hits <= at_projected[1], f"{name}: {report}"
