"""Your own test (issue 59): ``prepare_test`` makes what a shipped test has on a small plan (the
contact family's levels 0 to 2, 2 steps), resumes without solving anything twice, and a fit finds
the prepared test by its folder and refuses a file that does not match its manifest."""

from __future__ import annotations

import json

import numpy as np
import pytest

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import Indenter, ModelSpec, Protocol
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.workflow import fit_experiment
from indentation_studio.inference.preparation import TestRecipe, estimate_cost, prepare_test
from indentation_studio.surrogate.safe_file import SurrogateFileError
from indentation_studio.surrogate.shipped import TESTS_ENV, file_sha256

pytestmark = pytest.mark.slow

SMALL = TestRecipe(
    spec=ModelSpec(indenter=Indenter(4.77), protocol=Protocol(step_size=0.5, steps=2)),
    low_mesh="contact-L0",
    high_mesh="contact-L1",
    stick_grid="c1=1:21:3:log,c5=82.5:578:3",
    test_grid="lhs:3:5",
    mu_grid="sobol:8:1,mu=0.1:3:log",
    high_grid="c1=1:21:2:log,c5=82.5:578:2:log",
    budget_points=((4.0, 200.0), (12.0, 400.0)),
    budget_levels=(0, 1, 2),
    kfold=2,
)


@pytest.fixture(scope="module")
def prepared(tmp_path_factory):
    folder = tmp_path_factory.mktemp("own-test")
    said: list[str] = []
    return prepare_test(SMALL, folder, jobs=1, say=said.append), said


def test_a_small_test_is_prepared_end_to_end(prepared):
    done, said = prepared
    assert said[0].startswith("test-R4.77-2x0.5-100x100x60: estimated cost")
    assert any("the error budget is measured at 2 points" in line for line in said)  # a choice stated
    manifest = json.loads((done.folder / "manifest.json").read_text())
    (entry,) = manifest["surrogates"]
    assert entry["name"] == SMALL.name and entry["file"] == done.surrogate.name
    assert entry["sha256"] == file_sha256(done.surrogate)
    assert entry["error_budget_file"]["sha256"] == file_sha256(done.budget)
    assert entry["test"]["depths_mm"] == [0.5, 1.0] and entry["test"]["block_mm"]["height"] == 60.0
    assert [c["done"] for c in entry["campaigns"]] == [9, 3, 8, 4]  # every campaign complete
    assert entry["kind"] == "mf" and entry["parameters"] == ["c1", "c5", "mu"]
    assert entry["choices"] == SMALL.choices() and entry["made"]["versions"]["numpy"]
    # the budget of the high level carried by the surrogate, against the study's level 1 with its GCI
    assert entry["error_budget"]["source"]["model"] == "contact-L1"
    assert entry["error_budget"]["c5_pct"] > 0
    assert done.solved_now == 9 + 3 + 8 + 4 + 2 * 3  # the campaigns' points and the study's runs
    assert estimate_cost(SMALL, cores=1).stages["mu campaign"][0] == 8


def test_a_preparation_begun_again_solves_and_trains_nothing(prepared):
    done, _ = prepared
    stamps = {p: p.stat().st_mtime_ns for p in (done.surrogate, done.budget)}
    said: list[str] = []
    again = prepare_test(SMALL, done.folder, jobs=1, say=said.append)
    assert again.solved_now == 0
    assert not any(line.startswith("training") for line in said)
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    other = TestRecipe(**{**SMALL.__dict__, "kfold": 3})
    with pytest.raises(ValueError, match=r"begun with another recipe.*kfold"):
        prepare_test(other, done.folder, jobs=1)


def test_a_fit_finds_the_prepared_test_and_refuses_a_changed_file(prepared, tmp_path, monkeypatch):
    done, _ = prepared
    truth = np.array([9.0, 300.0])
    fe = FESolverPredictor(SMALL.model(SMALL.high_mesh))
    exp = write_synthetic_experiment(fe, truth, tmp_path / "exp", radius=4.77, step_size=0.5, seed=3)
    fit = fit_experiment(exp, tests=done.folder, friction="marginalise", fe_stage="none")
    assert fit.inputs.sources["surrogate"].startswith(f"the prepared test {done.folder} -> {SMALL.name}")
    assert np.all(np.abs(fit.theta / truth - 1) * 100 <= np.maximum(fit.bounds_pct, 1e-9)), (
        fit.theta,
        fit.bounds_pct,
    )
    monkeypatch.setenv(TESTS_ENV, str(done.folder))  # the environment variable finds it too
    assert (
        fit_experiment(exp, friction="marginalise", fe_stage="none").inputs.sources["surrogate"]
        == fit.inputs.sources["surrogate"]
    )
    data = bytearray(done.surrogate.read_bytes())
    data[-1] ^= 1
    done.surrogate.write_bytes(bytes(data))
    with pytest.raises(SurrogateFileError, match=r"sha256 .* is not the manifest's"):
        fit_experiment(exp, tests=done.folder, friction="marginalise", fe_stage="none")
    with pytest.raises(SurrogateFileError, match=r"no manifest\.json"):
        fit_experiment(exp, tests=tmp_path, friction="marginalise", fe_stage="none")
