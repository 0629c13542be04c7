"""Model error carried into a fit (inference.budgets.model_error): the discrepancy's covariance pushed
through the fit equals the spread of refits of targets drawn from it; the error budget adds."""

from __future__ import annotations

import numpy as np
import pytest
from sensitivity_check import assert_jacobian_matches_central_differences

from indentation_studio.design.objective import PAPER_WEIGHTS, Objective
from indentation_studio.forward.predictor import Prediction
from indentation_studio.inference.budgets.model_error import (
    Z95,
    combined_pct,
    model_error_at,
    with_model_error,
)
from indentation_studio.inference.fit.inverse_fit import fit_parameters

STEPS = 4
XY = np.stack(np.meshgrid(np.linspace(0, 30, 9), np.linspace(0, 30, 9), indexing="ij"), -1).reshape(-1, 2)
TOP = np.column_stack([XY, np.full(len(XY), 60.0)])
TRUTH = np.array([8.0, 300.0])


class PowerLawModel:
    """An analytic Predictor (force and field power laws in c1, c5) with a known discrepancy factor."""

    parameters = ("c1", "c5")
    top_xyz = TOP

    def __init__(self, factor_scale: float = 0.01, k: int = 3):
        rng = np.random.default_rng(7)
        n = len(TOP)
        self.depth = 0.5 * np.arange(1, STEPS + 1)
        r = np.linalg.norm(XY, axis=1) + 1.0
        self.shape = np.stack([-np.ones(n), XY[:, 0] / r, XY[:, 1] / r], -1) / r[:, None] * 5.0
        self.L_force = factor_scale * rng.standard_normal((k, STEPS))
        self.L_field = factor_scale * rng.standard_normal((k, STEPS * n * 3))
        self.meta = {"error_budget": {"c1_pct": 0.4, "c5_pct": 2.5, "source": "test"}}

    def predict(self, theta, jacobian=False):
        theta = np.atleast_2d(theta)
        c1, c5 = theta[:, 0:1], theta[:, 1:2]
        force = 100.0 * self.depth**1.5 * (c1 / 8.0) ** 0.8 * (c5 / 300.0) ** 0.15
        ax = (c5 / 300.0) ** -0.3 * (c1 / 8.0) ** -0.1  # (n, 1): the field's y component scales with it
        base = self.depth[None, :, None, None] * self.shape[None, None]  # (1, steps, nodes, 3)
        scale = np.stack([np.ones_like(ax), ax, np.ones_like(ax)], -1)[:, :, None, :]  # (n, 1, 1, 3)
        field = base * scale
        fj = dj = None
        if jacobian:
            fj = np.stack([force * 0.8 / c1, force * 0.15 / c5], -1)
            dax = np.stack([-0.1 * ax / c1, -0.3 * ax / c5], -1)  # (n, 1, 2)
            dj = np.zeros((*field.shape, 2))
            dj[..., 1, :] = base[..., 1, None] * dax[:, :, None, :]
        return Prediction(force, field, self.depth, TOP, self.parameters, fj, dj)

    def discrepancy_covariance_factor(self, theta):
        return np.hstack([self.L_force, self.L_field])


def _objective(model, force_log=0.0, field=0.0):
    p = model.predict(TRUTH[None])
    return Objective(p.force[0] * np.exp(force_log), p.displacement[0] + field, TOP, radius=4.77)


def test_power_law_model_jacobian():
    assert_jacobian_matches_central_differences(
        PowerLawModel(), TRUTH, step=1e-6, force_rtol=1e-6, field_rtol=1e-5
    )


def test_discrepancy_covariance_matches_refits():
    model = PowerLawModel()
    me = model_error_at(_objective(model), PAPER_WEIGHTS, model, TRUTH)
    rng = np.random.default_rng(0)
    fits = []
    for _ in range(300):
        z = rng.standard_normal(len(model.L_force))
        target = _objective(model, z @ model.L_force, (z @ model.L_field).reshape(STEPS, len(TOP), 3))
        fits.append(np.log(fit_parameters(target, model, PAPER_WEIGHTS, theta0=TRUTH).theta / TRUTH))
    sd_mc = np.std(fits, axis=0, ddof=1)
    sd = np.sqrt(np.diag(me.covariance_log))
    np.testing.assert_allclose(sd_mc, sd, rtol=0.15)  # 300 draws: sd known to about 4 %, plus linearisation
    np.testing.assert_allclose(me.discrepancy_pct, 100 * Z95 * sd)
    np.testing.assert_allclose(me.budget_pct, [0.4, 2.5])
    np.testing.assert_allclose(me.half_width_pct, np.hypot(me.discrepancy_pct, [0.4, 2.5]))
    np.testing.assert_allclose(combined_pct([1.0, 3.0], me), np.hypot([1.0, 3.0], me.half_width_pct))
    assert np.all(me.discrepancy_pct > 0)


def test_posterior_samples_spread_by_model_error():
    model = PowerLawModel(factor_scale=0.03)
    me = model_error_at(_objective(model), PAPER_WEIGHTS, model, TRUTH)
    samples = np.tile(TRUTH, (20000, 1))
    spread = np.log(with_model_error(samples, me, seed=3) / TRUTH)
    np.testing.assert_allclose(np.cov(spread.T), me.covariance_with_budget(), rtol=0.05, atol=1e-7)


def test_without_a_high_fidelity_level_there_is_no_model_error():
    class Plain(PowerLawModel):
        discrepancy_covariance_factor = None

    model = Plain()
    budget = model.meta.get("error_budget")
    model.meta = {}  # no high-fidelity level and no error budget: no model error
    assert model_error_at(_objective(model), PAPER_WEIGHTS, model, TRUTH) is None
    if budget:  # a single level with its mesh's budget carries that budget alone
        model.meta = {"error_budget": budget}
        alone = model_error_at(_objective(model), PAPER_WEIGHTS, model, TRUTH)
        np.testing.assert_allclose(alone.half_width_pct, [budget["c1_pct"], budget["c5_pct"]])
        assert not alone.has_discrepancy
    np.testing.assert_allclose(combined_pct([1.0, 3.0], None), [1.0, 3.0])


class Plain(PowerLawModel):
    """A single-level surrogate (no discrepancy) without an error budget."""

    discrepancy_covariance_factor = None

    def __init__(self):
        super().__init__()
        self.meta = {}


class SkewedTruth(PowerLawModel):
    """The "FE model" a Plain surrogate emulates with a known error: force (1 + 0.02 d / d_max)
    times the surrogate's, and a field 0.01 mm off along x at every node."""

    def predict(self, theta, jacobian=False):
        p = super().predict(theta, jacobian)
        force = p.force * (1.0 + 0.02 * self.depth / self.depth[-1])
        field = p.displacement + np.array([0.01, 0.0, 0.0])
        return Prediction(force, field, p.depth, TOP, self.parameters)


def _held_out(surrogate, truth, theta):
    """TrainingData of ``truth`` at ``theta`` (the surrogate's held-out points)."""
    from indentation_studio.surrogate.base import TrainingData

    p = truth.predict(theta)
    return TrainingData(theta, p.force, p.displacement, surrogate.depth, TOP)


def test_the_surrogates_own_error_is_how_far_it_moves_a_fit_of_the_model_it_emulates():
    """Issue 46: a surrogate with a known error (SkewedTruth) fits noise-free data of the model it
    emulates off the truth; the part its held-out errors give is that shift, to first order, and
    the truth lies inside the bounds that carry it."""
    from indentation_studio.inference.budgets.model_error import emulation_error_pct
    from indentation_studio.surrogate.emulation_error import EmulationError, held_out_errors

    surrogate, truth = Plain(), SkewedTruth()
    data = truth.predict(TRUTH[None])
    objective = Objective(data.force[0], data.displacement[0], TOP, radius=4.77)
    fit = fit_parameters(objective, surrogate, PAPER_WEIGHTS, theta0=TRUTH * 1.1)
    shift_pct = 100.0 * np.abs(fit.theta / TRUTH - 1.0)
    assert np.all(shift_pct > 0.2), shift_pct  # the surrogate's error moves the fit

    assert model_error_at(objective, PAPER_WEIGHTS, surrogate, fit.theta) is None  # not measured: none
    points = np.array([[4.0, 150.0], [12.0, 450.0], [8.0, 300.0]])
    errors = held_out_errors(surrogate, _held_out(surrogate, truth, points))
    np.testing.assert_allclose(
        errors[:, :STEPS], np.log1p(0.02 * surrogate.depth / surrogate.depth[-1])[None].repeat(3, 0)
    )
    surrogate.emulation_error = EmulationError.from_errors(
        points, errors, steps=STEPS, source="3 test points"
    )
    assert surrogate.emulation_error.directions.shape[0] == 1  # one error, the same at every point
    np.testing.assert_allclose(surrogate.emulation_error.errors(), errors, atol=1e-6)

    own = emulation_error_pct(objective, PAPER_WEIGHTS, surrogate, fit.theta)
    np.testing.assert_allclose(own, shift_pct, rtol=0.05)  # first order: within 5 % of the real shift
    me = model_error_at(objective, PAPER_WEIGHTS, surrogate, fit.theta)
    np.testing.assert_allclose(me.surrogate_pct, own)
    assert me.budget_source is None and "the surrogate's own error (3 test points" in me.to_dict()["includes"]
    assert np.all(combined_pct(fit.bounds_pct, me) >= shift_pct)  # the truth inside
    assert fit.bounds_pct[0] < shift_pct[0]  # c1 not inside the statistical bound alone
    # a fit refined on the FE model does not carry the surrogate's error
    assert model_error_at(objective, PAPER_WEIGHTS, surrogate, fit.theta, on_surrogate=False) is None

    # fewer than 20 held-out points: the largest move; the error twice as large at one point
    surrogate.emulation_error = EmulationError.from_errors(
        np.vstack([points, [[6.0, 200.0]]]), np.vstack([errors, 2.0 * errors[:1]]), steps=STEPS, source="4"
    )
    np.testing.assert_allclose(
        emulation_error_pct(objective, PAPER_WEIGHTS, surrogate, fit.theta), 2 * own, rtol=0.02
    )


def test_held_out_errors_kept_in_a_surrogate_file_and_by_training(mu_campaign, mu_surrogate, tmp_path):
    """A surrogate trained with a k-fold keeps each point's held-out error; its file keeps them."""
    from indentation_studio.surrogate.persistence import load_surrogate, save_surrogate
    from indentation_studio.surrogate.training import train_surrogate

    assert mu_surrogate.emulation_error is None  # trained without held-out points: not measured
    model = train_surrogate("mu", "gp", runs_dir=mu_campaign, kfold=3)
    own = model.emulation_error
    assert own is not None and own.points == 12 and own.steps == 3
    # the force part of the held-out errors: the k-fold's own force error (its RMS, percent)
    force_rms = 100.0 * np.sqrt(np.mean(np.expm1(-own.errors()[:, :3]) ** 2))  # pred / fe - 1
    assert force_rms == pytest.approx(model.meta["validation"]["kfold"]["force_rms_pct"], rel=1e-4)
    # by bands of mu: every point in one band, the bands' errors pooled are the whole's
    middle = float(np.median(own.theta[:, 2]))
    bands = own.describe_bands(2, (0.0, middle, np.inf))
    below = int((own.theta[:, 2] < middle).sum())
    assert [b["points"] for b in bands] == [below, own.points - below] and 0 < below < own.points
    pooled = np.sqrt(sum(b["force_rms_pct"] ** 2 * b["points"] for b in bands) / own.points)
    assert pooled == pytest.approx(own.describe()["force_rms_pct"], rel=1e-9)
    again = load_surrogate(save_surrogate(model, tmp_path / "s.safetensors"))
    np.testing.assert_array_equal(again.emulation_error.scores, own.scores)
    # the directions in half precision (1 part in 2,000 of each entry), the rest as computed
    np.testing.assert_allclose(again.emulation_error.directions, own.directions, rtol=1e-3, atol=1e-7)
    assert again.meta["emulation_error"]["points"] == own.points and "fold" in again.emulation_error.source
