"""The two-level workflow on two small real campaigns (16 points on `coarse`, 9 on `default`, 3
steps), run once for this file and copied into each test's folder: a fit on the multi-fidelity
surrogate lands on the `default` mesh's truth where the coarse one alone is biased; from the command
line, an error budget of the high-fidelity mesh, a multi-fidelity surrogate that carries it, and a
fit and a posterior whose bounds hold model error reported apart from the statistical part."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.campaign.loader import StoredResponses, load_campaign
from indentation_studio.campaign.runner import run_named_campaign
from indentation_studio.design.objective import Objective
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.solver import simulate
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.budgets.mesh_check import prediction_at_nodes
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.inverse_fit import fit_parameters
from indentation_studio.studio.cli import app
from indentation_studio.surrogate.training import train_multi_fidelity, train_surrogate

PROTOCOL = Protocol(step_size=0.5, steps=3)
COARSE, DEFAULT, FINE = (
    ModelSpec(mesh=MeshChoice(m), protocol=PROTOCOL) for m in ("coarse", "default", "fine")
)
ETA = (0.45, 0.35, 0.2, 0.0)


@pytest.fixture(scope="module")
def two_levels(tmp_path_factory) -> Path:
    """A runs folder with campaign `low` (4 x 4 on `coarse`) and `high` (3 x 3 on `default`)."""
    runs = tmp_path_factory.mktemp("two-levels")
    assert run_named_campaign("low", "c1=4:16:4,c5=150:500:4", COARSE, runs_dir=runs, jobs=1)["done"] == 16
    assert run_named_campaign("high", "c1=5:14:3,c5=180:450:3", DEFAULT, runs_dir=runs, jobs=1)["done"] == 9
    return runs


def _copy_campaigns(two_levels: Path, runs: Path) -> None:
    """The two campaigns' stores copied into ``runs`` (a test writes beside them: surrogates, budgets)."""
    for name in ("low", "high"):
        shutil.copytree(two_levels / name, runs / name)


def _run(*args: str) -> dict:
    res = CliRunner().invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_fit_on_two_fe_campaigns(two_levels, tmp_path):
    """The fit to the `default` mesh's response at a truth lands on it with the multi-fidelity
    surrogate, whose FE model is the `default` mesh's; the coarse surrogate alone is biased."""
    _copy_campaigns(two_levels, tmp_path)
    low = train_surrogate("low", "gp", runs_dir=tmp_path)
    mf = train_multi_fidelity(low, "high", folds=3, runs_dir=tmp_path)
    fe_model = ModelSpec.from_dict(mf.meta["campaign"]["model"])
    assert fe_model.mesh.preset == "default" and mf.meta["low_fidelity"]["campaign"]["name"] == "low"
    truth = np.array([9.0, 300.0])
    result = simulate(fe_model.with_material(c1=truth[0], c5=truth[1]))
    fit = fit_parameters(
        Objective.from_prediction(prediction_at_nodes(result, mf.top_xyz), radius=4.77), mf, ETA
    )
    data_at_coarse_nodes = Objective.from_prediction(prediction_at_nodes(result, low.top_xyz), radius=4.77)
    fit_low = fit_parameters(data_at_coarse_nodes, low, ETA)
    assert np.abs(fit.theta / truth - 1).max() < 5e-3  # measured c1 -0.02 %, c5 -0.08 %
    assert np.abs(fit_low.theta / truth - 1).max() > 0.1  # measured c1 +1.5 %, c5 -29 %
    assert 0 < mf.meta["discrepancy_kfold"]["force_max_pct"] < 2.0  # measured 0.66 % (3 folds of 9)
    # the FE stage's model: the low level's FE model corrected by the same discrepancy, so that it
    # differs from the surrogate by the low surrogate's own error alone (eq. 1a, 1b)
    low_fe = FESolverPredictor(ModelSpec.from_dict(low.meta["campaign"]["model"]))
    corrected = mf.corrected(low_fe)
    theta = truth[None, :]
    on_fe, on_sur, fe_low, sur_low = (m.predict(theta) for m in (corrected, mf, low_fe, low))
    np.testing.assert_allclose(on_fe.force / on_sur.force, fe_low.force / sur_low.force, rtol=1e-12)
    np.testing.assert_allclose(
        on_fe.displacement - on_sur.displacement,
        mf._carried(fe_low.displacement - sur_low.displacement),
        atol=1e-12,
    )
    assert np.abs(fe_low.force / sur_low.force - 1).max() > 1e-6  # not the same model by accident
    with pytest.raises(ValueError, match="the low model is over"):
        mf.corrected(type("P", (), {"parameters": ("c5",)})())


def test_fit_and_posterior_carry_model_error(two_levels, tmp_path):
    runs = str(tmp_path)
    _copy_campaigns(two_levels, tmp_path)
    run_named_campaign("ref", "c1=9:9:1,c5=300:300:1", FINE, runs_dir=runs, jobs=1)
    budget = _run("design", "error-budget", "--reference", "ref", "--model", "default", "--runs-dir", runs)
    low = _run("surrogate", "train", "--campaign", "low", "--runs-dir", runs)["model_file"]
    mf = _run(
        *("surrogate", "train-mf", "--low", low, "--campaign", "high", "--runs-dir", runs),
        *("--error-budget", budget["json_file"]),
    )
    left = mf["error_budget"]
    assert left["source"]["model"] == "default"  # the high campaign's mesh preset, read from the budget
    b = budget["rows"][0]["c5_bias_pct"] / 100  # in % of the fit, never less than of the truth
    assert left["c5_pct"] == pytest.approx(100 * max(abs(b), abs(1 / (1 + b) - 1)), rel=1e-12)
    reference = StoredResponses(load_campaign("ref", runs))
    exp = write_synthetic_experiment(
        reference,
        np.array([9.0, 300.0]),
        tmp_path / "exp",
        radius=4.77,
        step_size=0.5,
        seed=2,
        u_noise_mm=0.02,
    )
    fitted = _run("fit", "--experiment", str(exp), "--surrogate", mf["model_file"])
    assert fitted["inputs"]["model"]["mesh"]["preset"] == "default"  # the surrogate's model: the high level
    # its FE stage: one run of the low level corrected by the discrepancy, not one of the high level
    assert fitted["inputs"]["fe_stage_model"] == "coarse corrected by the learned discrepancy toward default"
    model = fitted["model_error"]
    assert "model error" in fitted["bounds_include"] and model["error_budget_pct"] == [
        left["c1_pct"],
        left["c5_pct"],
    ]
    assert all(v > 0 for v in model["discrepancy_pct"])
    stat, total = np.array(fitted["statistical_pct"]), np.array([fitted["c1_pct"], fitted["c5_pct"]])
    np.testing.assert_allclose(total, np.hypot(stat, model["model_pct"]))
    assert np.all(total > stat)
    post = _run(
        *("posterior", "--experiment", str(exp), "--surrogate", mf["model_file"]),
        *("--walkers", "8", "--steps", "300", "--out", str(tmp_path / "post")),
    )
    assert post["model_error"] is not None and "model error" in post["intervals_include"]
