"""The demo end to end on a small setting: every step runs and the report holds its figures."""

from __future__ import annotations

import json

import numpy as np
import pytest

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.studio.demo import run_demo


@pytest.mark.slow
def test_demo_small_end_to_end(tmp_path):
    protocol = Protocol(step_size=0.5, steps=4)
    spec = ModelSpec(mesh=MeshChoice("contact-L1"), protocol=protocol)  # the fit's model, 4 steps
    # made on the demo's own model (the fit's, contact-L1): what moves the fit is the noise, the
    # surrogate and the processing of DIC points to nodes
    exp = write_synthetic_experiment(
        FESolverPredictor(spec),
        np.array([12.0, 250.0]),
        tmp_path / "exp",
        radius=4.77,
        step_size=0.5,
        points=1500,
    )
    report = run_demo(
        "t",
        jobs=1,  # one process: the suite's two workers already take the two cores
        runs_dir=tmp_path / "runs",
        posterior_steps=300,
        say=lambda m: None,
        spec=spec,
        # 3 x 3 and 3 held out (each point a contact-L1 run): the surrogates start the fit, the FE
        # stage lands it where the 4 x 4 grid's did (measured: the same theta to 1e-6)
        grid="c1=4:20:3,c5=120:560:3",
        test_grid="lhs:3:3",
        experiment=exp,
        design_depths=(1.0, 2.0),
    )
    assert report.name == "index.html" and report.is_file()
    page = report.read_text()
    for png in (
        "figure8",
        "surrogate-parity",
        "design-comparison",
        "force-depth",
        "displacement-maps",
        "corner",
        "mesh",
    ):
        assert (report.parent / f"{png}.png").stat().st_size > 10_000
        assert f"{png}.png" in page
    results = json.loads((report.parent / "results.json").read_text())
    assert results["campaign"]["points"] == 9 and results["campaign"]["failed"] == 0
    assert len(results["table1"]) == 5 and results["fit"]["truth"] == [12.0, 250.0]
    fit = results["fit"]
    theta, bounds = np.asarray(fit["theta"]), np.asarray(fit["bounds_pct"])
    off_pct = 100.0 * np.abs(theta / np.array([12.0, 250.0]) - 1.0)
    # the fit is refined on the FE model (its own model made the data), so what moves it off the
    # truth is the noise and the processing: the bounds carry the processing (DIC points to nodes,
    # the registration), measured at the fit (issue 45), and hold the truth; the statistical part
    # alone did not (c1 +0.27 % against +-0.19 %, c5 -1.6 % against +-0.92 %)
    assert np.all(off_pct <= bounds), (theta, bounds)
    assert np.all(bounds < [2.0, 6.0]), bounds
    processing = fit["model_error"]["processing"]
    assert (
        np.all(np.asarray(processing["processing_pct"]) > 0)
        and "DIC points to nodes" in fit["bounds_include"]
    )
    assert fit["model_error"]["surrogate_pct"] is None  # the FE stage's fit: the surrogate does not move it
    assert fit["error_budget"]["known"] is False and "No error budget for this test" in page
    if fit["adequacy"]["flagged"]:
        assert "Model inadequate" in page and "These bounds hold" not in page
    else:
        assert "These bounds hold" in page and "Model inadequate" not in page
