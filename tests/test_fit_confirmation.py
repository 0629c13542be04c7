"""A fit on a surrogate over (c1, c5, mu) ended by one FE confirmation (inference.fit.confirm_stage):
the run's F and the Gauss-Newton step it points to, recorded in fit.json and checked against the
FE model by hand; a shift beyond the bound and a failed run said; the three-parameter MLP's
Jacobian against central differences; where a fit lies in the training data."""

from __future__ import annotations

import json

import numpy as np
import pytest

from indentation_studio.campaign.loader import load_campaign
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.solver import SimulationError
from indentation_studio.forward.spec import ModelSpec
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.confirm_stage import confirm_fit, gauss_newton_step
from indentation_studio.inference.fit.workflow import FE_STAGES, fit_experiment, resolved_fe_stage
from indentation_studio.surrogate.base import SPARSE_GAP, TrainingData
from indentation_studio.surrogate.mlp import MLPSurrogate
from indentation_studio.surrogate.persistence import load_surrogate, save_surrogate

TRUTH = np.array([9.0, 330.0, 0.35])


@pytest.fixture(scope="module")
def fe_experiment(mu_surrogate, tmp_path_factory):
    """Data of the coarse FE model the surrogate emulates, at TRUTH, and that model over (c1, c5, mu)."""
    spec = ModelSpec.from_dict(mu_surrogate.meta["campaign"]["model"])
    fe = FESolverPredictor(spec, parameters=("c1", "c5", "mu"))
    folder = tmp_path_factory.mktemp("exp") / "e"
    exp = write_synthetic_experiment(
        fe, TRUTH, folder, radius=4.77, step_size=0.5, u_noise_mm=0.002, f_noise=0.002, seed=1
    )
    return exp, fe


def test_the_fe_stage_is_confirm_on_a_surrogate_with_mu_and_fit_on_one_without(mu_surrogate):
    stick = type("Stick", (), {"parameters": ("c1", "c5")})()
    assert resolved_fe_stage("auto", mu_surrogate) == "confirm"
    assert resolved_fe_stage("auto", stick) == "fit"
    assert resolved_fe_stage("fit", mu_surrogate) == "fit"
    assert resolved_fe_stage("confirm", mu_surrogate, refine=False) == "none"
    assert FE_STAGES == ("auto", "confirm", "fit", "none")
    with pytest.raises(ValueError, match="fe_stage 'lm': use one of auto, confirm, fit, none"):
        resolved_fe_stage("lm", mu_surrogate)


def test_confirm_on_a_surrogate_with_mu_compares_it_at_the_given_mu_and_asks_for_one(
    mu_surrogate, fe_experiment
):
    """``confirm`` runs the FE model with friction mu and compares the surrogate at (c1, c5, mu);
    without mu a surrogate over mu has nothing to compare at, and says so."""
    from indentation_studio.inference.confirmation import confirm

    exp, fe = fe_experiment
    check = confirm(exp, mu_surrogate, TRUTH[:2], friction=float(TRUTH[2]))
    np.testing.assert_allclose(check.fe.force, fe.predict(TRUTH[None, :]).force, rtol=1e-10)
    np.testing.assert_array_equal(check.surrogate.force, mu_surrogate.predict(TRUTH[None, :]).force)
    with pytest.raises(ValueError, match=r"friction: this surrogate is over \('c1', 'c5', 'mu'\); give mu"):
        confirm(exp, mu_surrogate, TRUTH[:2])


def test_the_default_fit_is_confirmed_by_one_fe_run_recorded_in_fit_json(
    mu_surrogate, fe_experiment, tmp_path
):
    exp, fe = fe_experiment
    said: list[str] = []
    fit = fit_experiment(exp, mu_surrogate, say=said.append)
    assert not fit.refined and fit.friction.mode == "marginalise"
    assert any(line.startswith("confirming on the FE solver") for line in said)
    d = json.loads(fit.save(tmp_path).read_text())
    c = d["fe_confirmation"]
    assert d["fe_fit"] is None and c["error"] is None and c["parameters"] == ["c1", "c5", "mu"]
    theta = np.array(c["theta"])
    np.testing.assert_array_equal(theta, fit.fit.theta)  # at the surrogate's fit, mu included
    # F and the step, computed again by hand from the FE model: eq. 4's residuals and their exact
    # sensitivities in log theta, delta = -(J^T J)^-1 J^T r
    obj, eta = fit.inputs.objective, fit.inputs.eta
    pred = fe.predict(theta[None, :], jacobian=True)
    r, J = obj.residuals(pred, eta)[0], obj.jacobian(pred, eta)[0] * theta
    np.testing.assert_allclose(c["F_fe"], r @ r, rtol=1e-10)
    assert c["F_fe"] == pytest.approx(float(obj.value(pred, eta)[0]), rel=1e-10)
    assert c["F_surrogate"] == pytest.approx(fit.fit.F, rel=1e-12)
    np.testing.assert_allclose(c["statistical_pct"][:2], d["statistical_pct"], rtol=1e-12)
    mu_half = d["friction"][
        "mu_statistical_pct"
    ]  # mu's own bound beside them (None where the data do not bound it)
    assert c["statistical_pct"][2] == (mu_half if mu_half is not None and np.isfinite(mu_half) else None)
    # the step: least squares of the linearised residuals, mu kept in its range (optimality by hand:
    # the gradient J^T (r + J delta) vanishes in a free parameter and points out of the range in one
    # held on its edge)
    delta = np.log1p(np.array(c["gauss_newton_shift_pct"]) / 100)
    lo, hi = fit.mu_range
    mu_after = theta[2] * np.exp(delta[2])
    assert lo * (1 - 1e-9) <= mu_after <= hi * (1 + 1e-9)
    g = J.T @ (r + J @ delta)
    scale = np.abs(J.T @ r).max()
    np.testing.assert_allclose(g[:2], 0.0, atol=1e-6 * scale)
    if np.isclose(mu_after, lo):
        assert g[2] >= -1e-6 * scale
    elif np.isclose(mu_after, hi):
        assert g[2] <= 1e-6 * scale
    else:
        assert abs(g[2]) <= 1e-6 * scale
    free = gauss_newton_step(r, J, theta)  # no range: the normal equations
    np.testing.assert_allclose(free, np.linalg.solve(J.T @ J, -J.T @ r), rtol=1e-8)
    shift = np.abs(c["gauss_newton_shift_pct"])
    half = np.array([np.inf if b is None else b for b in c["allowed_pct"]])
    stat = np.array([np.inf if b is None else b for b in c["statistical_pct"]])
    own = np.array([np.inf if b is None else b for b in c["surrogate_pct"]])
    np.testing.assert_allclose(half, np.hypot(stat, own), rtol=1e-12)
    beyond = [k for k, s, b in zip(("c1", "c5", "mu"), shift, half, strict=True) if s > b]
    assert c["shift_beyond_bound"] == beyond
    assert any("FE confirmation disagrees" in w for w in d["warnings"]) == bool(beyond)
    region = d["training_region"]
    assert region["at_box_edge"] == [] and region["gap"] < SPARSE_GAP
    # the adequacy test reads the FE model's residuals one Gauss-Newton step from the fit
    # (linearised), not the surrogate's
    assert d["adequacy"]["tested_on"] == "the FE model one Gauss-Newton step from the fit (linearised)"
    np.testing.assert_allclose(fit.tested_fit.residuals, r + J @ delta, rtol=1e-9, atol=1e-12)
    assert fit.tested_fit.F <= c["F_fe"] * (1 + 1e-12) and fit.fit.F == c["F_surrogate"]


def test_a_shift_beyond_the_bound_is_a_warning_and_a_failed_run_keeps_the_fit(mu_surrogate, fe_experiment):
    exp, fe = fe_experiment
    fit = fit_experiment(exp, mu_surrogate, refine=False)
    obj, eta, theta = fit.inputs.objective, fit.inputs.eta, fit.fit.theta
    tight = confirm_fit(obj, fe, eta, theta, F_surrogate=fit.fit.F, statistical_pct=[1e-6, 1e-6])
    assert tight.shift_beyond_bound == ["c1", "c5"]
    (warning,) = tight.warnings
    assert (
        f"c1 {tight.shift_pct[0]:+.2f} % (bound +- 0.00 %, statistical)" in warning
        and "--fe-stage fit" in warning
    )
    loose = confirm_fit(obj, fe, eta, theta, F_surrogate=fit.fit.F, statistical_pct=[1e6, 1e6])
    assert loose.warnings == [] and loose.F_fe == tight.F_fe
    # the surrogate's own error is the part of the bound that holds its miss: a shift inside the
    # two combined is no warning; beyond them it is, naming both
    shift = np.abs(tight.shift_pct[:2])
    held = confirm_fit(
        obj, fe, eta, theta, F_surrogate=fit.fit.F, statistical_pct=0.6 * shift, surrogate_pct=0.9 * shift
    )
    assert held.shift_beyond_bound == [] and held.warnings == []
    np.testing.assert_allclose(held.allowed_pct, np.hypot(0.6, 0.9) * shift, rtol=1e-12)
    short = confirm_fit(
        obj, fe, eta, theta, F_surrogate=fit.fit.F, statistical_pct=0.6 * shift, surrogate_pct=0.7 * shift
    )
    assert short.shift_beyond_bound == ["c1", "c5"]
    assert "statistical and the surrogate's own error" in short.warnings[0]

    class Diverges:
        parameters = fe.parameters

        def predict(self, theta, jacobian=False):
            raise SimulationError("Newton did not converge at 1.5 mm", 1.0)

    failed = confirm_fit(obj, Diverges(), eta, theta, F_surrogate=fit.fit.F, statistical_pct=[1.0, 1.0])
    assert failed.F_fe is None and failed.shift_pct is None and "Newton did not converge" in failed.error
    assert "failed" in failed.warnings[0] and "kept unconfirmed" in failed.warnings[0]
    # mu on its range's edge with the free step pointing out of the range: held there, and the
    # others' step is no longer the free one
    free = confirm_fit(obj, fe, eta, theta, F_surrogate=fit.fit.F, statistical_pct=[1, 1])
    outward = np.sign(free.shift_pct[2])
    lo = np.array([0.0, 0.0, theta[2] if outward < 0 else 0.01])
    hi = np.array([np.inf, np.inf, theta[2] if outward > 0 else 100.0])
    held = confirm_fit(obj, fe, eta, theta, F_surrogate=fit.fit.F, statistical_pct=[1, 1], box=(lo, hi))
    assert held.shift_pct[2] == 0.0 and not np.allclose(held.shift_pct[:2], free.shift_pct[:2])
    wide = confirm_fit(
        obj, fe, eta, theta, F_surrogate=fit.fit.F, statistical_pct=[1, 1], box=(lo * 0, hi * 0 + 1e9)
    )
    np.testing.assert_allclose(wide.shift_pct, free.shift_pct, rtol=1e-8)  # a box it stays inside


def test_a_three_parameter_mlp_has_the_jacobian_of_its_central_differences(mu_campaign, tmp_path):
    data = TrainingData.from_campaign(load_campaign("mu", runs_dir=mu_campaign))
    model = MLPSurrogate(width=16, hidden_layers=2, adam_epochs=150, lbfgs_steps=20).fit(data, seed=0)
    assert model.parameters == ("c1", "c5", "mu")
    theta = np.array([[8.0, 300.0, 0.5]])
    pred = model.predict(theta, jacobian=True)
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-5 * theta[0, k]
        up, down = model.predict(theta + e), model.predict(theta - e)
        fd_f = (up.force - down.force) / (2 * e[k])
        fd_u = (up.displacement - down.displacement) / (2 * e[k])
        np.testing.assert_allclose(pred.force_jacobian[0, :, k], fd_f[0], rtol=1e-5, atol=1e-9)
        np.testing.assert_allclose(pred.displacement_jacobian[0, ..., k], fd_u[0], rtol=1e-4, atol=1e-8)
    # the training points travel with the saved file; a point far from them is named sparse
    again = load_surrogate(save_surrogate(model, tmp_path / "s.safetensors"))
    np.testing.assert_array_equal(again.training_theta, data.theta)
    gaps = again.training_gap(np.vstack([data.theta[:1], [[12.0, 450.0, 2.0]], [[6.0, 250.0, 0.2]]]))
    assert gaps[0] == 0.0 and gaps[2] == 0.0
    # inside a cell of the 2 x 2 x 3 grid (log-scaled to the unit cube: mu's levels at 0, 1/2, 1, so
    # the median spacing is 1/2): the nearest corner lies sqrt(dc1^2 + dc5^2 + dmu^2) away
    x = np.log([9.0 / 6.0, 350.0 / 250.0, 0.6 / 0.2]) / np.log([2.0, 1.8, 10.0])
    nearest = np.minimum(x, 1 - x)
    nearest[2] = min(abs(x[2] - 0.5), x[2])
    expected = np.sqrt(np.sum(nearest**2)) / 0.5
    assert again.training_gap(np.array([[9.0, 350.0, 0.6]]))[0] == pytest.approx(expected, rel=1e-9)
    # a box's corner far from any point: beyond SPARSE_GAP
    assert again.training_gap(np.array([[12.0, 450.0, 2.0 * 10.0**1.2]]))[0] > SPARSE_GAP


@pytest.fixture(scope="module")
def stick_and_slip(mu_campaign, mu_surrogate):
    """A perfect-stick MLP over (c1, c5) on the coarse model of campaign ``mu``, and a slip surrogate on it."""
    from indentation_studio.campaign.runner import run_named_campaign
    from indentation_studio.surrogate.training import train_surrogate

    spec = ModelSpec.from_dict(mu_surrogate.meta["campaign"]["model"])
    run_named_campaign("stick", "c1=5:13:3,c5=200:500:3", spec, runs_dir=mu_campaign, jobs=1)
    small = {"width": 16, "hidden_layers": 2, "adam_epochs": 150, "lbfgs_steps": 20}
    stick = MLPSurrogate(**small).fit(
        TrainingData.from_campaign(load_campaign("stick", runs_dir=mu_campaign))
    )
    slip = train_surrogate("mu", "slip", runs_dir=mu_campaign, stick=stick)
    return stick, slip


def test_a_slip_surrogate_is_the_stick_plus_an_mlp_of_the_slip(stick_and_slip, mu_campaign, tmp_path):
    from indentation_studio.surrogate.slip_surrogate import SlipSurrogate

    stick, slip = stick_and_slip
    assert isinstance(slip, SlipSurrogate) and slip.parameters == ("c1", "c5", "mu")
    theta = np.array([[8.0, 300.0, 0.5], [11.0, 420.0, 1.7]])
    pred, s, d = slip.predict(theta, jacobian=True), stick.predict(theta[:, :2]), slip.slip.predict(theta)
    np.testing.assert_allclose(pred.force, s.force * d.force, rtol=1e-12)  # eq. 1a
    np.testing.assert_allclose(pred.displacement, s.displacement + d.displacement, rtol=1e-12, atol=1e-15)
    for k in range(3):  # its Jacobian against central differences, d/dmu from the slip part alone
        e = np.zeros(3)
        e[k] = 1e-5 * theta[0, k]
        up, down = slip.predict(theta[:1] + e), slip.predict(theta[:1] - e)
        np.testing.assert_allclose(
            pred.force_jacobian[0, :, k], (up.force - down.force)[0] / (2 * e[k]), rtol=1e-5, atol=1e-9
        )
        fd_u = (up.displacement - down.displacement)[0] / (2 * e[k])
        np.testing.assert_allclose(pred.displacement_jacobian[0, ..., k], fd_u, rtol=1e-4, atol=1e-8)
    # the reduced basis gives the same prediction (the posterior evaluates F there)
    basis = slip.reduced_basis()
    zf, zu = basis.coordinates(theta)
    np.testing.assert_allclose(np.exp(basis.force_mean + zf @ basis.force_basis), pred.force, rtol=1e-10)
    field = (basis.field_mean + zu @ basis.field_basis).reshape(pred.displacement.shape)
    np.testing.assert_allclose(field, pred.displacement, rtol=1e-10, atol=1e-12)
    # saved and loaded bit for bit; it is over the slip MLP's box and training points
    again = load_surrogate(save_surrogate(slip, tmp_path / "slip.safetensors"))
    np.testing.assert_array_equal(again.predict(theta).force, pred.force)
    np.testing.assert_array_equal(again.training_theta, slip.slip.training_theta)
    np.testing.assert_allclose([again.scaler.lo[2], again.scaler.hi[2]], [0.2, 2.0])
    # a campaign without mu, or over another box, is refused with the reason
    with pytest.raises(ValueError, match=r"need the stick surrogate's \('c1', 'c5'\) then 'mu'"):
        SlipSurrogate(stick).fit(TrainingData.from_campaign(load_campaign("stick", runs_dir=mu_campaign)))
    narrow = MLPSurrogate(width=8, hidden_layers=1, adam_epochs=20, lbfgs_steps=2).fit(
        TrainingData.from_campaign(load_campaign("stick", runs_dir=mu_campaign)).subset(np.arange(4))
    )
    with pytest.raises(ValueError, match="outside the stick surrogate's training box"):
        SlipSurrogate(narrow).fit(TrainingData.from_campaign(load_campaign("mu", runs_dir=mu_campaign)))


def test_a_fit_at_the_training_box_edge_is_named(mu_surrogate, tmp_path):
    truth = np.array([5.5, 330.0, 0.35])  # c1 below the box's 6 kPa: the fit stops on its edge
    exp = write_synthetic_experiment(
        mu_surrogate,
        truth,
        tmp_path / "e",
        radius=4.77,
        step_size=0.5,
        u_noise_mm=0.002,
        f_noise=0.002,
        seed=2,
    )
    fit = fit_experiment(exp, mu_surrogate, refine=False)
    d = fit.to_dict()
    assert fit.fit.theta[0] == pytest.approx(6.0, rel=1e-6)
    assert d["training_region"]["at_box_edge"] == ["c1"] and d["fe_confirmation"] is None
    assert any("edge of the surrogate's training box in c1" in w for w in d["warnings"])


def test_a_surrogate_fit_at_the_edge_of_its_box_is_fitted_on_the_fe_model_instead(mu_surrogate, tmp_path):
    """Data made below the surrogate's c5 range (250 .. 450 kPa): its fit is held at the box's edge,
    where a confirmation's Gauss-Newton step is held too (the shipped R = 8 mm surrogate at
    {18, 110} kPa put c5 +9.9 % off inside a +-1.2 % bound); the fit goes on on the FE model."""
    spec = ModelSpec.from_dict(mu_surrogate.meta["campaign"]["model"])
    truth = np.array([9.0, 200.0, 0.5])
    exp = write_synthetic_experiment(
        FESolverPredictor(spec, parameters=("c1", "c5", "mu")),
        truth,
        tmp_path / "below",
        radius=4.77,
        step_size=0.5,
        u_noise_mm=0.002,
        f_noise=0.002,
        seed=3,
    )
    said: list[str] = []
    fit = fit_experiment(exp, mu_surrogate, say=said.append)
    assert fit.surrogate_fit.theta[1] == pytest.approx(250.0, rel=0.006)  # held at the box's edge
    assert any("edge of its training box in c5" in line and "FE model instead" in line for line in said)
    assert fit.refined and fit.confirmation is None
    assert abs(fit.theta[1] / truth[1] - 1.0) * 100 <= fit.bounds_pct[1]
