"""Model adequacy (inference.adequacy): a fit's residuals whitened by the data's noise give a
chi-square statistic with n - p degrees of freedom; data the model made are not flagged (over
20 noise draws at most one beyond the 0.1 % tail), data it cannot explain (a force scale 10 %
off, fibers declared 90 deg from where they are) are. And a fit without an error budget for its
test says so (inference.budgets.check), in the CLI's text and the report too."""

from __future__ import annotations

import json
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.predictor import Prediction
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.adequacy.chi_square import ALPHA, CANNOT_EXPLAIN
from indentation_studio.inference.adequacy.noise import dic_noise_mm
from indentation_studio.inference.adequacy.of_fit import model_adequacy, parameters_at_ends
from indentation_studio.inference.budgets.check import budget_status
from indentation_studio.inference.budgets.model_error import ModelError
from indentation_studio.inference.experiment.data import load_experiment
from indentation_studio.inference.experiment.processing import experiment_objective, to_model_frame
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.inverse_fit import fit_parameters

SPEC = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=4))
TRUE = np.array([12.0, 250.0])
ETA = np.array([0.45, 0.35, 0.2, 0.0])


class Linearised:
    """The FE model linearised about TRUE (one run with sensitivities): exact to first order over
    a fit's percent-wide moves, and fast enough for many noise draws."""

    def __init__(self, spec: ModelSpec):
        self.spec = spec
        self.at = FESolverPredictor(spec).predict(TRUE, jacobian=True)

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        theta = np.atleast_2d(np.asarray(theta, float))
        d = theta - TRUE
        a = self.at
        force = a.force[0] + np.einsum("sp,np->ns", a.force_jacobian[0], d)
        field = a.displacement[0] + np.einsum("skdp,np->nskd", a.displacement_jacobian[0], d)
        out = replace(a, force=force, displacement=field, force_jacobian=None, displacement_jacobian=None)
        if jacobian:
            n = len(theta)
            out = replace(
                out,
                force_jacobian=np.repeat(a.force_jacobian, n, axis=0),
                displacement_jacobian=np.repeat(a.displacement_jacobian, n, axis=0),
            )
        return out


@pytest.fixture(scope="module")
def model():
    return Linearised(SPEC)


def _experiment(model, folder, seed: int):
    return write_synthetic_experiment(
        model, TRUE, folder, radius=4.77, step_size=0.5, seed=seed, u_noise_mm=0.02, f_noise=0.02
    )


def _fit_and_test(model, root, **declared):
    exp = load_experiment(root)
    objective, dic = experiment_objective(exp, model.at.top_xyz)
    fit = fit_parameters(objective, model, ETA)
    inputs = SimpleNamespace(objective=objective, experiment=exp, dic=dic, eta=ETA)
    return fit, model_adequacy(inputs, fit, **declared)


@pytest.mark.slow
def test_clean_data_are_not_flagged_over_noise_draws(model, tmp_path):
    # measured: 0 of 20 flagged; chi-square per degree 0.83 .. 1.09 (mean 0.98) on about 170 degrees
    # of freedom, the smallest p 0.18
    flagged, ratios = 0, []
    for seed in range(20):
        _, a = _fit_and_test(model, _experiment(model, tmp_path / f"e{seed}", seed))
        assert a.dof == a.n - 2 and a.n == sum(t["n"] for t in a.terms.values())
        assert a.p_value == pytest.approx(stats.chi2.sf(a.statistic, a.dof))
        flagged += a.flagged
        ratios.append(a.ratio)
        # the noise the data carry, measured back: 0.02 mm DIC, f_inf's standard error from the holds
        np.testing.assert_allclose(a.noise.dic_sd_mm, 0.02, rtol=0.1)
    assert flagged <= 1, ratios
    assert 0.85 < np.mean(ratios) < 1.15, ratios


def test_the_declared_registration_is_profiled_by_running_the_processing_about_other_points(model, tmp_path):
    # the same data recorded twice, once with the indentation point 0.1 mm off (a lab's registration),
    # little noise so that the misregistration shows; the fit declares 0.1 mm
    roots = {
        m: write_synthetic_experiment(
            model,
            TRUE,
            tmp_path / f"m{m}",
            radius=4.77,
            step_size=0.5,
            seed=3,
            u_noise_mm=0.002,
            misregistration_mm=m,
        )
        for m in (0.0, 0.1)
    }
    _, off_plain = _fit_and_test(model, roots[0.1])
    _, off = _fit_and_test(model, roots[0.1], registration_mm=0.1)
    _, clean = _fit_and_test(model, roots[0.0], registration_mm=0.1)
    # the least over 1 + 48 readings of the data, two degrees of freedom given to the choice
    assert off.dof == off_plain.dof - 2 and off.statistic <= off_plain.statistic
    profile = off.terms["registration_profile"]
    assert (
        profile["reading"] >= 1 and profile["statistic"] < 0
    )  # another indentation point explains them better
    # data registered right gain far less from another point than data registered 0.1 mm off
    # (measured: -7.3 against -27.4; what 48 readings of the same noise take off by chance)
    assert clean.terms["registration_profile"]["statistic"] > 0.5 * profile["statistic"]


def test_the_models_stated_uncertainty_is_a_low_rank_term_of_the_covariance(model, tmp_path):
    # along the residual itself, g = a r, Sherman-Morrison gives r^T (C + g g^T)^-1 r = P / (1 + a^2 P)
    # with P = r^T C^-1 r the statistic without it (at the fit: no refit, no operator bias)
    root = _experiment(model, tmp_path / "e", 4)
    exp = load_experiment(root)
    objective, dic = experiment_objective(exp, model.at.top_xyz)
    fit = replace(fit_parameters(objective, model, ETA), jacobian=None, prediction=None)
    inputs = SimpleNamespace(objective=objective, experiment=exp, dic=dic, eta=ETA)
    plain = model_adequacy(inputs, fit)
    P, a = plain.statistic, 0.05
    held = model_adequacy(inputs, fit, model_directions=a * fit.residuals[None, :])
    assert held.statistic == pytest.approx(P / (1 + a**2 * P), rel=1e-9) and held.dof == plain.dof
    assert held.terms["model_uncertainty"]["statistic"] == pytest.approx(held.statistic - P, rel=1e-9)
    # a direction the residuals do not have (the force scale) changes the statistic far less
    other = np.zeros_like(fit.residuals)
    other[: len(objective.steps)] = 1.0
    moved = model_adequacy(inputs, fit, model_directions=a * other[None, :])
    assert 0 <= P - moved.statistic < 0.1 * (P - held.statistic)
    with pytest.raises(ValueError, match="model_directions have 3 entries"):
        model_adequacy(inputs, fit, model_directions=np.ones((1, 3)))


def test_a_wrong_force_scale_is_flagged(model, tmp_path):
    root = _experiment(model, tmp_path / "scaled", 1)
    force = pd.read_csv(root / "force.csv")
    force["force_mN"] *= np.where(force["step"] >= 3, 1.1, 1.0)  # the load cell's scale off at two steps
    force.to_csv(root / "force.csv", index=False)
    fit, a = _fit_and_test(model, root)
    assert a.flagged and a.p_value < ALPHA
    assert a.terms["force"]["statistic"] > 20 * a.terms["force"]["n"]  # the force carries the misfit
    assert a.to_dict()["flagged"] and CANNOT_EXPLAIN in a.message()
    # mu identified narrowly while the model misses is named: it absorbs model error
    friction = {"mu_identified": True, "mu": 0.21, "mu_interval": [0.19, 0.23]}
    exp = load_experiment(root)
    objective, dic = experiment_objective(exp, model.at.top_xyz)
    inputs = SimpleNamespace(objective=objective, experiment=exp, dic=dic, eta=ETA)
    named = model_adequacy(inputs, fit, friction=friction).named
    assert [d["parameter"] for d in named] == ["mu"] and "absorbs model error" in named[0]["reason"]
    # pressed against its range's end (the composite at R = 8 with mu identified: 0.111 in [0.1, 0.157])
    pressed = {"mu_identified": False, "mu": 0.111, "mu_interval": [0.1, 0.157]}
    pressed["mu_reaches_range_end"] = {"lower": True, "upper": False}
    named = model_adequacy(inputs, fit, friction=pressed).named
    assert [d["parameter"] for d in named] == ["mu"] and "range's lower end" in named[0]["reason"]


def test_a_parameter_at_the_end_of_the_training_box_is_named():
    surrogate = SimpleNamespace(
        parameters=("c1", "c5"), kind="gp", scaler=SimpleNamespace(lo=[2.0, 100.0], hi=[20.0, 500.0])
    )
    result = SimpleNamespace(
        fit=SimpleNamespace(theta=np.array([19.97, 300.0])),
        friction=SimpleNamespace(fits_mu=False),
        inputs=SimpleNamespace(surrogate=surrogate),
        refined=False,
    )
    named = parameters_at_ends(result)
    assert [d["parameter"] for d in named] == ["c1"] and "upper end" in named[0]["reason"]
    result.fit.theta = np.array([12.0, 300.0])
    assert parameters_at_ends(result) == []


def test_a_model_with_the_fibers_elsewhere_is_flagged(model, tmp_path):
    """Data made with the fibers along one direction, fitted by the model with them 90 deg away:
    the field's anisotropy is not the model's (the force alone would not tell)."""
    root = _experiment(model, tmp_path / "fibers", 2)
    _, clean = _fit_and_test(model, root)
    meta = json.loads((root / "experiment.json").read_text())
    meta["fiber_angle_deg"] = (meta["fiber_angle_deg"] + 90.0) % 180.0
    (root / "experiment.json").write_text(json.dumps(meta))
    _, a = _fit_and_test(model, root)
    assert not clean.flagged and a.flagged
    assert a.statistic > 3 * a.dof


def test_declared_noise_replaces_the_measured(model, tmp_path):
    root = _experiment(model, tmp_path / "declared", 3)
    _, measured = _fit_and_test(model, root)
    _, half = _fit_and_test(model, root, dic_noise=0.01, force_noise=0.01)
    assert half.noise.dic_source.startswith("declared") and half.noise.force_source.startswith("declared")
    np.testing.assert_allclose(half.noise.dic_sd_mm, 0.01)
    # half the noise: four times the statistic, and the data then fail the test
    assert half.statistic == pytest.approx(4 * measured.statistic, rel=0.15)
    assert half.flagged and not measured.flagged


def test_dic_noise_is_measured_without_the_fields_curvature():
    """A strongly curved field (a Gaussian dimple 2 mm deep) with 0.02 mm noise: the local
    quadratics with their exact leverage give the noise back within 5 %."""
    rng = np.random.default_rng(0)
    r = 20 * np.sqrt(rng.random(5000))
    phi = 2 * np.pi * rng.random(5000)
    xy = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
    dimple = -2.0 * np.exp(-(r**2) / 20.0)
    u = np.column_stack([0.1 * xy[:, 0] * np.exp(-(r**2) / 30.0), 0.05 * xy[:, 1] / 20, dimple])
    sd = dic_noise_mm(xy, u + 0.02 * rng.standard_normal(u.shape))
    np.testing.assert_allclose(sd, 0.02, rtol=0.05)


def _result(tmp_path, model, model_error, mesh_check=None):
    root = _experiment(model, tmp_path / "budget", 4)
    exp = load_experiment(root)
    dic = to_model_frame(exp)
    inputs = SimpleNamespace(dic=dic, spec=SPEC)
    return SimpleNamespace(inputs=inputs, model_error=model_error, mesh_check=mesh_check, check_mesh=None)


def test_a_test_without_an_error_budget_says_so(model, tmp_path):
    status = budget_status(_result(tmp_path, model, None))
    assert not status["known"] and "no error budget is known for this test" in status["warning"]
    assert "R = 4.77 mm, 4 x 0.5 mm" in status["test"] and "design study-budget" in status["warning"]
    assert "verification-study --family 8x8:1.2:1.5:core8 " in status["warning"]
    source = {"file": "x.json", "model": "coarse", "points": 9, "field_of_view_mm": 25.0}
    known = ModelError(np.zeros(2), np.array([3.0, 24.0]), np.zeros((2, 2)), source, False)
    assert budget_status(_result(tmp_path, model, known))["known"]  # the data cover 25 mm too
    narrow = ModelError(
        np.zeros(2), np.array([3.0, 24.0]), np.zeros((2, 2)), source | {"field_of_view_mm": 8.0}, False
    )
    status = budget_status(_result(tmp_path, model, narrow))
    assert not status["known"] and "8 mm field of view" in status["warning"]
    outside = ModelError(
        np.zeros(2),
        np.array([3.0, 24.0]),
        np.zeros((2, 2)),
        source | {"where": "outside", "at": [1.5, 560.0]},
        False,
    )
    status = budget_status(_result(tmp_path, model, outside))
    assert status["known"] and "lies outside the region its error budget verified" in status["warning"]
    assert "add this point (1.5:560) to the study's points" in status["warning"]
    assert status["warning"].endswith("'No error budget')")
    from indentation_studio.studio.report import fit_warnings_html

    assert "<b>Error budget not measured here.</b>" in fit_warnings_html({"error_budget": status})
    inside = ModelError(
        np.zeros(2), np.array([3.0, 24.0]), np.zeros((2, 2)), source | {"where": "interpolated"}, False
    )
    assert budget_status(_result(tmp_path, model, inside))["warning"] is None


def test_the_cli_and_the_report_show_the_flag_loudly(model, tmp_path, capsys):
    from indentation_studio.studio.inference_printout import loud_warnings
    from indentation_studio.studio.report import fit_warnings_html

    root = _experiment(model, tmp_path / "loud", 5)
    force = pd.read_csv(root / "force.csv")
    force["force_mN"] *= 1.1 ** (force["step"] - 1)
    force.to_csv(root / "force.csv", index=False)
    _, a = _fit_and_test(model, root)
    a.named = [{"parameter": "mu", "reason": "on its range's upper limit"}]
    payload = {"adequacy": a.to_dict(), "error_budget": budget_status(_result(tmp_path, model, None))}
    loud_warnings(payload)
    out = capsys.readouterr().out
    assert "MODEL INADEQUATE" in out and "NO ERROR BUDGET FOR THIS TEST" in out
    assert "the model cannot explain these data" in " ".join(out.split())
    assert f"{a.dof}" in out and "mu" in out
    page = fit_warnings_html(payload)
    assert "class='alarm'" in page and "class='caution'" in page and "its bounds are not meaningful" in page


def test_the_high_fidelitys_field_error_is_a_variance_at_each_node(model, tmp_path):
    """A model error of 0.05 mm (2.5 times the DIC noise) in ux at every measured node and step,
    drawn independently, is flagged by the plain test; with its variance held at the nodes
    (``field_variance``) the statistic is chi-square again (within 15 % of its degrees of
    freedom); a zero variance leaves the plain statistic."""
    root = _experiment(model, tmp_path / "e", 5)
    exp = load_experiment(root)
    objective, dic = experiment_objective(exp, model.at.top_xyz)
    fit = replace(fit_parameters(objective, model, ETA), jacobian=None, prediction=None)
    inputs = SimpleNamespace(objective=objective, experiment=exp, dic=dic, eta=ETA)
    s, m = len(objective.steps), int(objective.measured.sum())
    scale = objective.displacement_residual_scale()[objective.measured][:, 0]  # (m,)
    error = 0.05 * np.random.default_rng(0).standard_normal((s, m))
    r = fit.residuals.copy()
    r[s : s + s * m] += (np.sqrt(ETA[1]) * scale[None, :] * error).ravel()
    erred = replace(fit, residuals=r)
    variance = np.zeros((s, m, 3))
    plain = model_adequacy(inputs, erred)
    assert model_adequacy(inputs, erred, field_variance=variance).statistic == pytest.approx(plain.statistic)
    variance[..., 0] = 0.05**2
    held = model_adequacy(inputs, erred, field_variance=variance)
    assert plain.flagged and not held.flagged
    assert abs(held.ratio - 1.0) < 0.15 and held.dof == plain.dof
