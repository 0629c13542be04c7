"""A surrogate fitted to runs it was not trained on (inference.fit.run_refits): the fit of a run is
the plain fit's, noise-free, and its error says how far the surrogate's parameters are from the
run's."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.inference.fit.run_refits import refit_campaign, refit_runs, refit_summary
from indentation_studio.studio.cli import app
from indentation_studio.surrogate.persistence import save_surrogate
from indentation_studio.surrogate.training_set import TrainingData


def _runs_made_by(surrogate, made_at, labelled, parameters=("c1", "c5", "mu")) -> TrainingData:
    """Runs whose outputs are the surrogate's own at ``made_at``, labelled with ``labelled``."""
    pred = surrogate.predict(np.asarray(made_at, float))
    return TrainingData(
        np.asarray(labelled, float),
        pred.force,
        pred.displacement,
        np.asarray(surrogate.depth, float),
        np.asarray(surrogate.top_xyz, float),
        parameters,
    )


def test_a_run_made_by_the_surrogate_itself_is_fitted_at_its_parameters_and_a_moved_one_by_the_move(
    mu_surrogate,
):
    # inside the campaign's box (c1 6..12, c5 250..450, mu 0.2..2), away from its points
    truth = [[8.0, 330.0, 0.5], [10.5, 300.0, 0.9]]
    moved = [[8.0 * 1.03, 330.0 * 0.97, 0.5], [10.5, 300.0 * 1.04, 0.9]]
    exact = refit_runs(mu_surrogate, _runs_made_by(mu_surrogate, truth, truth))
    off = refit_runs(mu_surrogate, _runs_made_by(mu_surrogate, moved, truth))
    for r in exact:
        assert (
            abs(r.error_pct("c1")) < 1e-3 and abs(r.error_pct("c5")) < 1e-3 and abs(r.error_pct("mu")) < 0.1
        )
    np.testing.assert_allclose([off[0].error_pct("c1"), off[0].error_pct("c5")], [3.0, -3.0], atol=0.01)
    np.testing.assert_allclose([off[1].error_pct("c1"), off[1].error_pct("c5")], [0.0, 4.0], atol=0.01)
    summary = refit_summary(off)
    assert summary["runs"] == 2
    assert summary["c5"]["max_abs_pct"] == pytest.approx(4.0, abs=0.01)
    assert summary["c1"]["mean_pct"] == pytest.approx(1.5, abs=0.01)
    row = off[0].to_dict()
    assert row["c5_true"] == 330.0 and row["c5_fit"] == pytest.approx(320.1, abs=0.01)


def test_stick_runs_on_a_surrogate_with_mu_report_mu_fitted_and_no_error_in_it(mu_surrogate):
    runs = _runs_made_by(mu_surrogate, [[9.0, 350.0, 2.0]], [[9.0, 350.0]], ("c1", "c5"))
    (r,) = refit_runs(mu_surrogate, runs)
    assert abs(r.error_pct("c5")) < 1e-2 and np.isnan(r.error_pct("mu"))
    assert "mu_fit" in r.to_dict() and "mu_error_pct" not in r.to_dict()


def test_runs_of_other_nodes_steps_or_parameters_are_refused_by_name(mu_surrogate):
    runs = _runs_made_by(mu_surrogate, [[9.0, 350.0, 0.5]], [[9.0, 350.0, 0.5]])
    with pytest.raises(ValueError, match="top nodes are not the surrogate's"):
        refit_runs(mu_surrogate, dataclasses.replace(runs, top_xyz=runs.top_xyz + 0.1))
    with pytest.raises(ValueError, match="another test"):
        refit_runs(mu_surrogate, dataclasses.replace(runs, depth=runs.depth * 2))
    with pytest.raises(ValueError, match="not the surrogate's"):
        refit_runs(mu_surrogate, dataclasses.replace(runs, parameters=("c5", "c1", "mu")))


def test_the_cli_fits_every_run_of_a_campaign_on_the_surrogate(mu_surrogate, mu_campaign, tmp_path):
    # the command prints what the library's refit_campaign gives, run by run
    model = save_surrogate(mu_surrogate, tmp_path / "mu.safetensors")
    args = [
        "surrogate",
        "evaluate",
        "--model",
        str(model),
        "--campaign",
        "mu",
        "--runs-dir",
        str(mu_campaign),
    ]
    res = CliRunner().invoke(app, [*args, "--refits", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout.strip().splitlines()[-1])
    refits = out["refits"]
    assert refits["summary"]["runs"] == len(refits["refits"]) == 12
    direct = refit_campaign(mu_surrogate, "mu", mu_campaign)
    for printed, made in zip(refits["refits"], direct["refits"], strict=True):
        assert printed == pytest.approx(made, rel=1e-9)
    assert {"c1_true", "c5_true", "mu_true", "mu_fit", "c5_error_pct", "F"} <= set(refits["refits"][0])
