"""The two-level workflow from the command line: an error budget of the high-fidelity mesh, a
multi-fidelity surrogate that carries it, and a fit and a posterior whose bounds hold model error
reported apart from the statistical part."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.campaign.loader import StoredResponses, load_campaign
from indentation_studio.campaign.runner import run_named_campaign
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.synthetic_experiment import write_synthetic_experiment
from indentation_studio.studio.cli import app

PROTOCOL = Protocol(step_size=0.5, steps=3)


def _run(*args: str) -> dict:
    res = CliRunner().invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_fit_and_posterior_carry_model_error(tmp_path):
    runs = str(tmp_path)
    coarse, default, fine = (
        ModelSpec(mesh=MeshChoice(m), protocol=PROTOCOL) for m in ("coarse", "default", "fine")
    )
    run_named_campaign("low", "c1=4:16:4,c5=150:500:4", coarse, runs_dir=runs, jobs=1)
    run_named_campaign("high", "c1=5:14:3,c5=180:450:3", default, runs_dir=runs, jobs=1)
    run_named_campaign("ref", "c1=9:9:1,c5=300:300:1", fine, runs_dir=runs, jobs=1)
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
    assert fitted["inputs"]["model"]["mesh"]["preset"] == "default"  # the FE stage ran on the high level
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
