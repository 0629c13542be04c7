"""Surrogates trained on a small coarse campaign: held-out errors, derivatives, the Predictor seam,
saving and loading, the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.campaign.designs import design_from_option
from indentation_studio.campaign.loader import load_campaign
from indentation_studio.campaign.runner import run_campaign
from indentation_studio.campaign.spec import CampaignSpec
from indentation_studio.campaign.store import CampaignStore
from indentation_studio.forward.predictor import Predictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.studio.cli import app
from indentation_studio.surrogate.base import InputScaler, TrainingData
from indentation_studio.surrogate.persistence import load_surrogate, save_surrogate
from indentation_studio.surrogate.training import make_surrogate
from indentation_studio.surrogate.validation import k_fold_errors, prediction_errors

MODEL = ModelSpec(protocol=Protocol(step_size=0.5, steps=4), mesh=MeshChoice("coarse"))
FAST_MLP = {"adam_epochs": 2500, "lbfgs_steps": 200}


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    for name, design in (("train", "c1=4:16:6,c5=150:500:6"), ("test", "lhs:8:11")):
        spec = CampaignSpec(name, design_from_option(design), MODEL)
        if name == "test":  # LHS over the paper box: keep the points inside the training box
            pts = spec.design.points
            spec.design.points[:] = np.column_stack(
                [4 + (pts[:, 0] - 1) / 20 * 12, 150 + (pts[:, 1] - 82.5) / (578 - 82.5) * 350]
            )
        # one process: the suite's two workers already take CI's two cores (a second one only waits)
        s = run_campaign(CampaignStore.create_or_open(root, spec), jobs=1)
        assert s["failed"] == 0
    return (
        root,
        TrainingData.from_campaign(load_campaign("train", root)),
        TrainingData.from_campaign(load_campaign("test", root)),
    )


@pytest.fixture(scope="module", params=["gp", "mlp"])
def trained(request, campaigns):
    _, train, _ = campaigns
    extra = FAST_MLP if request.param == "mlp" else {}
    return make_surrogate(request.param, **extra).fit(train, seed=0)


def test_input_scaler_linear_and_log():
    s = InputScaler(np.array([1.0, 82.5]), np.array([21.0, 578.0]))
    np.testing.assert_allclose(s(np.array([[1.0, 82.5], [21.0, 578.0]])), [[0, 0], [1, 1]])
    g = InputScaler(np.array([1.0, 82.5]), np.array([21.0, 578.0]), "log")
    np.testing.assert_allclose(g(np.array([[np.sqrt(21.0), np.sqrt(82.5 * 578)]])), [[0.5, 0.5]])
    with pytest.raises(ValueError, match="scale"):
        InputScaler(np.array([1.0]), np.array([2.0]), "cubic")


def test_held_out_errors_are_small(trained, campaigns):
    _, _, test = campaigns
    e = prediction_errors(trained, test)
    assert isinstance(trained, Predictor)
    # 36 coarse training runs over c1 4..16, c5 150..500, 8 LHS points held out; measured:
    # GP force RMS 0.05 %, max 0.14 %, field RMS 0.08 %, max 0.94 %; MLP 0.15 %, 0.39 %, 0.04 %, 0.75 %
    assert e["force_rms_pct"] < 0.3 and e["force_max_pct"] < 0.8
    assert e["displacement_rms_pct"] < 0.2 and e["displacement_max_pct"] < 2.0


def test_jacobian_is_the_derivative_of_the_prediction(trained):
    theta = np.array([[9.0, 300.0], [13.0, 220.0]])
    p = trained.predict(theta, jacobian=True)
    for k, h in enumerate((1e-4 * 9.0, 1e-4 * 300.0)):
        step = np.zeros(2)
        step[k] = h
        fp, fm = trained.predict(theta + step), trained.predict(theta - step)
        df = (fp.force - fm.force) / (2 * h)
        np.testing.assert_allclose(p.force_jacobian[..., k], df, rtol=1e-5, atol=1e-8 * np.abs(df).max())
        du = (fp.displacement - fm.displacement) / (2 * h)
        np.testing.assert_allclose(p.displacement_jacobian[..., k], du, atol=1e-6 * np.abs(du).max())


def test_save_load_round_trip_and_bad_file(trained, tmp_path):
    path = save_surrogate(trained, tmp_path / "m.safetensors")
    again = load_surrogate(path)
    theta = np.array([[10.0, 350.0]])
    np.testing.assert_array_equal(again.predict(theta).force, trained.predict(theta).force)
    assert again.meta["versions"]["torch"] and again.meta["training_points"] == 36
    (tmp_path / "bad.safetensors").write_text("not a model")
    with pytest.raises(ValueError, match="surrogate"):
        load_surrogate(tmp_path / "bad.safetensors")


def test_kfold_and_cli(campaigns, tmp_path):
    root, train, _ = campaigns
    told = []
    e = k_fold_errors(lambda: make_surrogate("gp"), train, folds=3, say=told.append)
    assert e["points"] == 36 and e["force_rms_pct"] < 2.0
    # a line per fold, each with its 12 held-out points and the time left
    assert [t.split(":")[0].strip() for t in told] == ["fold 1/3", "fold 2/3", "fold 3/3"]
    assert all("12 held-out points" in t and "eta" in t for t in told) and told[-1].endswith("eta 0 s")
    res = CliRunner().invoke(
        app,
        [
            *("surrogate", "train", "--campaign", "train", "--kind", "gp", "--test-campaign", "test"),
            *("--runs-dir", str(root), "--out", str(tmp_path / "gp.safetensors"), "--json"),
        ],
    )
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert out["model_file"] == str(tmp_path / "gp.safetensors") and out["test_errors"]["force_rms_pct"] < 1.0
    res = CliRunner().invoke(
        app, ["surrogate", "evaluate", "--model", out["model_file"], "--timing", "1000", "--json"]
    )
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["timing"]["points"] == 1000
    res = CliRunner().invoke(app, ["surrogate", "evaluate", "--model", str(tmp_path / "none"), "--json"])
    assert res.exit_code == 1 and "no surrogate file" in json.loads(res.stdout)["error"]


@pytest.mark.slow
def test_confirm_with_mesh_check_cli(campaigns, tmp_path):
    """`confirm --check-mesh`: an experiment made on `default`, the fit's model on `coarse` (the
    campaign's mesh): the check solves both meshes and reports the shift and the widened bounds."""
    from indentation_studio.forward.fe_predictor import FESolverPredictor
    from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment

    root, _, _ = campaigns
    model_file = tmp_path / "gp.safetensors"
    res = CliRunner().invoke(
        app,
        [
            *("surrogate", "train", "--campaign", "train", "--kind", "gp", "--runs-dir", str(root)),
            *("--out", str(model_file), "--json"),
        ],
    )
    assert res.exit_code == 0, res.output
    made_on = ModelSpec(protocol=MODEL.protocol)  # the default mesh, finer than the campaign's
    exp = write_synthetic_experiment(
        FESolverPredictor(made_on),
        np.array([10.0, 300.0]),
        tmp_path / "exp",
        radius=4.77,
        step_size=0.5,
        seed=5,
    )
    fit_args = ["fit", "--experiment", str(exp), "--surrogate", str(model_file), "--no-refine"]
    res = CliRunner().invoke(app, [*fit_args, "--check-mesh", "default", "--json"])
    assert res.exit_code == 0, res.output
    fitted = json.loads(res.stdout)
    theta = np.array([fitted["c1"], fitted["c5"]])
    registration = fitted["registration"]  # what the fit used, reported (issue: a lab's files in)
    assert registration["sphere_radius_mm"] == pytest.approx(4.77, abs=0.02)
    assert registration["sphere_fit_rms_mm"] < 0.01 and fitted["excluded_steps"] == []
    # a single-fidelity surrogate without a budget: the statistical bounds and the processing's part
    # measured at the fit; they say they hold no mesh error
    me = fitted["model_error"]
    assert me["error_budget_pct"] == [0.0, 0.0] and me["surrogate_pct"] is None
    assert (
        "no error budget is known" in fitted["bounds_include"]
        and "DIC points to nodes" in fitted["bounds_include"]
    )
    np.testing.assert_allclose(me["model_pct"], me["processing"]["processing_pct"])
    np.testing.assert_allclose(
        [fitted["c1_pct"], fitted["c5_pct"]], np.hypot(fitted["statistical_pct"], me["model_pct"])
    )
    res = CliRunner().invoke(
        app, [*fit_args, "--exclude-steps", "2", "--out", str(tmp_path / "fewer"), "--json"]
    )
    assert res.exit_code == 0, res.output
    fewer = json.loads(res.stdout)
    assert fewer["excluded_steps"] == [2]
    assert fewer["n"] == fitted["n"] * 3 // 4  # one of four steps left out of every term
    args = ["confirm", "--experiment", str(exp), "--surrogate", str(model_file)]
    args += ["--c1", str(float(theta[0])), "--c5", str(float(theta[1]))]
    res = CliRunner().invoke(app, [*args, "--check-mesh", "default", "--json"])
    assert res.exit_code == 0, res.output
    check = json.loads(res.stdout)["mesh_check"]
    assert check["nodes"] == [576, 1452] and check["refinement_ratio"] == pytest.approx(
        (1452 / 576) ** (1 / 3)
    )
    shift, unc = np.array(check["shift_pct"]), np.array(check["uncertainty_pct"])
    r = check["refinement_ratio"]
    np.testing.assert_allclose(unc, 3.0 * np.abs(shift) * r / (r - 1.0))  # two-mesh GCI, p = 1, Fs = 3
    stat, combined = np.array(check["statistical_pct"]), np.array(check["combined_pct"])
    np.testing.assert_allclose(combined, np.hypot(stat, unc))
    assert np.all(np.abs(shift) > 0.1)  # coarse and default differ
    # carried to the finer mesh: theta (1 + shift), with the fine-grid GCI Fs |shift| / (r - 1)
    np.testing.assert_allclose(check["theta_on_finer_mesh"], theta * (1 + shift / 100))
    np.testing.assert_allclose(check["corrected_uncertainty_pct"], unc / r)
    np.testing.assert_allclose(check["corrected_combined_pct"], np.hypot(stat, unc / r))
    confirm_file = exp / "results" / "confirm.json"
    assert json.loads(confirm_file.read_text())["mesh_check"] == check
    np.testing.assert_allclose(fitted["mesh_check"]["shift_pct"], shift)  # fit --check-mesh: the same check
    # the posterior carried there: moved by the shift, spread by the GCI read as a 95 % half-width
    post_args = ["posterior", "--experiment", str(exp), "--surrogate", str(model_file), "--steps", "600"]
    plain = json.loads(CliRunner().invoke(app, [*post_args, "--json"]).stdout)
    words = plain["intervals_include"]  # says what it holds and what it leaves out
    assert (
        words.startswith("measurement noise, the processing's (DIC points to nodes")
        and "no mesh error" in words
    )
    res = CliRunner().invoke(app, [*post_args, "--mesh-check", str(confirm_file), "--json"])
    assert res.exit_code == 0, res.output
    moved = json.loads(res.stdout)
    res = CliRunner().invoke(app, [*post_args, "--mesh-check", str(exp / "results" / "fit.json"), "--json"])
    assert res.exit_code == 0, res.output
    np.testing.assert_allclose(json.loads(res.stdout)["median"], moved["median"])  # same check, same seed
    sd_mesh = theta * (unc / r) / 100 / 1.96
    moved_by = np.array(moved["median"]) - np.array(plain["median"])
    assert np.all(np.abs(moved_by - theta * shift / 100) <= 0.1 * np.hypot(plain["std"], sd_mesh))
    np.testing.assert_allclose(moved["std"], np.hypot(plain["std"], sd_mesh), rtol=0.1)
    other = tmp_path / "other.json"
    payload = json.loads(confirm_file.read_text())
    payload["inputs"]["experiment"] = str(tmp_path / "elsewhere")
    other.write_text(json.dumps(payload))
    res = CliRunner().invoke(app, [*post_args, "--mesh-check", str(other), "--json"])
    assert res.exit_code == 1 and "not" in json.loads(res.stdout)["error"]
    res = CliRunner().invoke(app, [*args, "--check-mesh", "coarse", "--json"])
    assert res.exit_code == 1 and "finer" in json.loads(res.stdout)["error"]
    # a fit that marginalised mu is confirmed with its mu: the FE run has that contact
    res = CliRunner().invoke(app, [*args, "--friction", "0.5", "--out", str(tmp_path / "c"), "--json"])
    assert res.exit_code == 0, res.output
    with_mu = json.loads(res.stdout)
    assert with_mu["contact"] == "Coulomb friction mu = 0.5"
    assert with_mu["inputs"]["model"]["contact"]["friction"] == 0.5
    res = CliRunner().invoke(app, [*args, "--friction", "0.5", "--check-mesh", "default", "--json"])
    assert res.exit_code == 1 and "perfect stick" in json.loads(res.stdout)["error"]
