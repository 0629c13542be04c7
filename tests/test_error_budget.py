"""The error budget of a model (inference.budgets.error_budget; its files: surrogate.error_budgets): a model fitted to its own response has no
bias; the expected noise objective matches Monte Carlo; a coarser mesh's bias is the fit it causes."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import indentation_studio as ins
from indentation_studio.design.objective import PAPER_WEIGHTS, Objective
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.solver import simulate
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.budgets.error_budget import (
    compute_error_budget,
    model_top_xyz,
    noise_objective_value,
    reference_prediction,
    resolve_model,
)
from indentation_studio.inference.fit.inverse_fit import fit_parameters
from indentation_studio.surrogate.error_budgets import remaining_bias, shipped_budget

PROTOCOL = Protocol(step_size=0.5, steps=3)
COARSE = ModelSpec(mesh=MeshChoice("coarse"), protocol=PROTOCOL)
FINER = ModelSpec(mesh=MeshChoice("default"), protocol=PROTOCOL)
THETA = (8.0, 300.0)


def _reference(spec: ModelSpec):
    return simulate(spec.with_material(c1=THETA[0], c5=THETA[1]))


def test_noise_objective_matches_monte_carlo():
    ref = _reference(COARSE)
    target = reference_prediction(ref, ref.top_xyz)
    objective = Objective.from_prediction(target, radius=COARSE.indenter.radius)
    expected = noise_objective_value(objective, PAPER_WEIGHTS, 0.02, 0.02)
    rng = np.random.default_rng(1)
    values = []
    for _ in range(400):
        noisy_force = target.force * (1 + 0.02 * rng.standard_normal(target.force.shape))
        noisy_u = target.displacement + 0.02 * rng.standard_normal(target.displacement.shape)
        # residuals of the truth against a noisy target: scale kept from the noise-free target
        r = objective.residuals(
            type(target)(noisy_force, noisy_u, target.depth, target.top_xyz), PAPER_WEIGHTS
        )
        values.append(float(r[0] @ r[0]))
    mc = np.mean(values)
    # Monte Carlo error of the mean: sd / sqrt(400); the force term divides by the noise-free force
    assert abs(mc - expected) < 4 * np.std(values) / np.sqrt(len(values))
    assert expected > 0


def test_model_against_its_own_response_has_no_bias():
    fe = FESolverPredictor(COARSE)
    budget = compute_error_budget([_reference(COARSE)], {"coarse": fe})
    row = budget.table.iloc[0]
    # Newton stops at 1e-4 of the reactions: the same model agrees with itself to about 1e-5
    assert abs(row.c1_bias_pct) < 0.01 and abs(row.c5_bias_pct) < 0.01
    assert 0 < row.c1_half_width_pct < 50 and 0 < row.c5_half_width_pct < 200
    assert bool(budget.summary().converged.iloc[0])


def _budget_and_lm_bias(reference, model) -> tuple[list[float], np.ndarray]:
    """The budget's (c1, c5) bias of ``model`` against ``reference`` (Gauss-Newton, 4 steps, whole
    top) and that of a full Levenberg-Marquardt fit of the model to the same target, in %."""
    row = compute_error_budget([reference], {"model": model}, fe_steps=4, fov_mm=None).table.iloc[0]
    objective = Objective.from_prediction(
        reference_prediction(reference, model_top_xyz(model)), radius=COARSE.indenter.radius, reading="fit"
    )  # the budget reads eq. 4 as the fits do
    lm = fit_parameters(objective, model, PAPER_WEIGHTS, theta0=THETA)
    return [row.c1_bias_pct, row.c5_bias_pct], 100 * (lm.theta / np.array(THETA) - 1)


def test_coarse_mesh_bias_is_the_fit_it_causes():
    """Against a finer mesh's noise-free response, the budget's Gauss-Newton bias of the coarse FE
    model equals a full Levenberg-Marquardt fit of that model to the same target."""
    budget_row, lm_bias = _budget_and_lm_bias(_reference(FINER), FESolverPredictor(COARSE))
    assert abs(lm_bias[1]) > 0.5  # the coarse mesh does move the fit
    np.testing.assert_allclose(budget_row, lm_bias, atol=0.05)


def test_error_budget_command(tmp_path):
    import json

    from typer.testing import CliRunner

    from indentation_studio.campaign.runner import run_named_campaign
    from indentation_studio.studio.cli import app

    run_named_campaign("ref", "c1=6:12:2,c5=200:200:1", FINER, runs_dir=tmp_path, jobs=1)
    args = ["design", "error-budget", "--reference", "ref", "--model", "coarse", "--runs-dir", str(tmp_path)]
    out = CliRunner().invoke(app, [*args, "--fe-steps", "1", "--json"])
    assert out.exit_code == 0, out.output
    payload = json.loads(out.stdout)
    assert [r["c1_true"] for r in payload["rows"]] == [6.0, 12.0]
    assert payload["summary"][0]["model"] == "coarse" and payload["reference"]["points"] == 2
    assert payload["half_width_include"].startswith(
        "eq. 6 to 8 of a typical experiment: measurement noise only"
    )
    assert (tmp_path / "ref" / "error-budget.json").is_file()
    left = remaining_bias(tmp_path / "ref" / "error-budget.json", "coarse")
    # the largest distance between truth and fit, in percent of the fit (and at least of the truth)
    b = np.array([r["c5_bias_pct"] for r in payload["rows"]]) / 100
    expected = 100 * np.max(np.maximum(np.abs(b), np.abs(1 / (1 + b) - 1)))
    assert left["c5_pct"] == pytest.approx(expected, rel=1e-12) and left["source"]["points"] == 2
    with pytest.raises(ValueError, match="no model 'fine'"):
        remaining_bias(tmp_path / "ref" / "error-budget.json", "fine")

    # a budget stopped after its first row resumes from its file: the kept row is not fitted again
    path = tmp_path / "ref" / "error-budget.json"
    partial = json.loads(path.read_text())
    assert partial["complete"] is True and partial["fe_steps"] == 1
    partial["rows"] = partial["rows"][:1]
    partial["rows"][0]["c5_bias_pct"] = 123.0  # a mark: only a resumed row keeps it
    partial["complete"] = False
    path.write_text(json.dumps(partial))
    resumed = json.loads(CliRunner().invoke(app, [*args, "--fe-steps", "1", "--json"]).stdout)
    assert resumed["complete"] is True
    assert [r["c5_bias_pct"] for r in resumed["rows"]] == [123.0, payload["rows"][1]["c5_bias_pct"]]
    # other settings start afresh
    path.write_text(json.dumps(partial))
    fresh = json.loads(CliRunner().invoke(app, [*args, "--fe-steps", "2", "--json"]).stdout)
    assert fresh["rows"][0]["c5_bias_pct"] != 123.0 and len(fresh["rows"]) == 2
    bad = CliRunner().invoke(
        app,
        ["design", "error-budget", "--reference", "ref", "--model", "nowhere", "--runs-dir", str(tmp_path)],
    )
    assert bad.exit_code != 0 and "not a mesh preset" in bad.output


class _Emulator:
    """A stand-in surrogate (not an FE model, so fitted by LM): the coarse FE model's answers
    scaled by a known factor in force, to give it a surrogate part of its own."""

    def __init__(self, fe, factor: float) -> None:
        self.fe, self.factor = fe, factor
        self.parameters, self.depth = fe.parameters, np.asarray(fe.spec.protocol.depths)
        self.top_xyz, self.meta = model_top_xyz(fe), {}

    def predict(self, theta, jacobian: bool = False):
        from dataclasses import replace

        p = self.fe.predict(theta, jacobian=jacobian)
        fj = None if p.force_jacobian is None else p.force_jacobian * self.factor
        return replace(p, force=p.force * self.factor, force_jacobian=fj)


def test_surrogate_split_reuses_the_fe_models_row():
    """A surrogate's discretisation part is its FE model's fit: when that FE model is budgeted
    too, its row is used (no second fit, the same numbers) and the two parts add up to the bias."""
    from indentation_studio.forward.predictor import CachedPredictor

    fe = CachedPredictor(FESolverPredictor(COARSE))
    calls = []

    class Counting(FESolverPredictor):  # an FE model (fitted by Gauss-Newton) that counts its calls
        def predict(self, theta, jacobian=False):
            calls.append(jacobian)
            return fe.predict(theta, jacobian=jacobian)

    reference = [_reference(FINER)]
    models = {"coarse": fe, "emulator": _Emulator(fe, 1.01)}
    budget = compute_error_budget(
        reference,
        models,
        fe_models={"emulator": Counting(COARSE)},
        fe_steps=2,
        fe_names={"emulator": "coarse"},
    )
    fe_row, em_row = budget.table.iloc[0], budget.table.iloc[1]
    assert calls == []  # the FE fit was taken from the 'coarse' row
    assert em_row.c5_discretisation_pct == pytest.approx(fe_row.c5_bias_pct, abs=1e-12)
    assert em_row.c5_discretisation_pct + em_row.c5_surrogate_pct == pytest.approx(em_row.c5_bias_pct)
    assert abs(em_row.c5_surrogate_pct) > 0.1  # a 1 % force error does move the fit
    # without the name the split fits the FE model itself, to the same numbers
    again = compute_error_budget(
        reference, {"emulator": models["emulator"]}, fe_models={"emulator": Counting(COARSE)}, fe_steps=2
    )
    assert calls and again.table.iloc[0].c5_discretisation_pct == pytest.approx(fe_row.c5_bias_pct, abs=1e-9)


def _budget_file(folder, reference_spec: ModelSpec, rows: list[dict], complete: bool = True):
    import json

    from indentation_studio.inference.budgets.error_budget import ErrorBudget

    budget = ErrorBudget(
        __import__("pandas").DataFrame(rows),
        np.asarray(PAPER_WEIGHTS, float),
        0.02,
        0.02,
        {"campaign": "ref", "points": 2, "model": reference_spec.to_dict()},
    )
    path = folder / "budget.json"
    path.write_text(json.dumps(budget.to_dict() | {"complete": complete}))
    return path


def test_shipped_budget_applies_to_the_same_test_only(tmp_path):
    """A shipped budget gives a mesh its largest bias when the test (radius, protocol, kappa,
    fibers) is the budget's, whatever c1 and c5; another radius, an unbudgeted mesh or an
    unfinished budget give None."""
    from dataclasses import replace

    from indentation_studio.forward.spec import Indenter
    from indentation_studio.surrogate.error_budgets import shipped_budget

    reference = replace(FINER, mesh=MeshChoice("reference"))
    row = {"c1_half_width_pct": 0.2, "c5_half_width_pct": 1.0, "c1_fit": 1.0, "c5_fit": 1.0}
    rows = [
        {"model": "coarse", "c1_true": 3.0, "c5_true": 120.0, "c1_bias_pct": -2.5, "c5_bias_pct": 7.0} | row,
        {"model": "coarse", "c1_true": 19.0, "c5_true": 540.0, "c1_bias_pct": 1.0, "c5_bias_pct": -21.0}
        | row,
    ]
    _budget_file(tmp_path, reference, rows)
    left = shipped_budget(COARSE.with_material(c1=12.0, c5=250.0), tmp_path)
    # -21 % of the truth is 26.6 % of the fit; -2.5 % is 2.56 %: bounds are in percent of the fit
    assert left["c1_pct"] == pytest.approx(100 * (1 / 0.975 - 1)) and left["c5_pct"] == pytest.approx(
        100 * (1 / 0.79 - 1)
    )
    assert left["source"]["reference_mesh"] == "reference" and left["source"]["points"] == 2
    assert shipped_budget(replace(COARSE, indenter=Indenter(radius=8.0)), tmp_path) is None
    assert shipped_budget(FINER, tmp_path) is None  # 'default' is not in that budget
    _budget_file(tmp_path, reference, rows, complete=False)
    assert shipped_budget(COARSE, tmp_path) is None


def test_single_level_surrogate_carries_its_meshs_budget():
    """A single-level surrogate with an error budget: the model error is that budget alone, the
    bounds its root sum of squares with the statistical ones, and they say what they hold."""
    from indentation_studio.inference.budgets.model_error import (
        combined_pct,
        model_error_at,
        model_error_scope,
    )

    fe = FESolverPredictor(COARSE)
    sur = _Emulator(fe, 1.0)
    ref = _reference(COARSE)
    objective = Objective.from_prediction(reference_prediction(ref, ref.top_xyz), radius=4.77)
    assert model_error_at(objective, PAPER_WEIGHTS, sur, np.array(THETA)) is None
    assert "hold no model error" in model_error_scope(None)
    sur.meta = {"error_budget": {"c1_pct": 3.0, "c5_pct": 24.0, "source": {"model": "coarse", "points": 9}}}
    me = model_error_at(objective, PAPER_WEIGHTS, sur, np.array(THETA))
    np.testing.assert_allclose(me.half_width_pct, [3.0, 24.0])
    np.testing.assert_allclose(combined_pct([0.4, 3.2], me), np.hypot([0.4, 3.2], [3.0, 24.0]))
    assert not me.has_discrepancy and "mesh's error budget" in me.to_dict()["includes"]
    assert "not the surrogate's own error" in model_error_scope(me)


def test_the_shipped_budget_of_the_paper_test():
    """The studio ships the 9-point budget of the paper's test against 'reference': a surrogate
    on 'default' or 'fine' for that test carries what it leaves (from its rows), other meshes and
    tests none; a surrogate file from before the record takes it at fit time."""
    from indentation_studio.surrogate.error_budgets import (
        shipped_budget,
        shipped_budgets_folder,
        surrogate_error_budget,
    )

    path = shipped_budgets_folder() / "paper-test-R4.77.json"
    paper = ModelSpec()  # R = 4.77 mm, 28 x 0.5 mm on 'default'
    for mesh in ("default", "fine"):
        left = shipped_budget(_on(paper, mesh))
        assert left["c5_pct"] == pytest.approx(remaining_bias(path, mesh)["c5_pct"])
        assert left["source"]["points"] == 9 and left["source"]["reference_mesh"] == "reference"
    assert 20 < shipped_budget(paper)["c5_pct"] < 40  # default: c5 24 % below the truth at {3, 540}
    assert shipped_budget(_on(paper, "coarse")) is None and shipped_budget(FINER) is None

    class OldFile:  # a surrogate saved before meta['error_budget'] was recorded
        def __init__(self, meta: dict) -> None:
            self.meta = meta

    old = OldFile({"campaign": {"model": paper.to_dict()}})
    assert surrogate_error_budget(old)["source"]["model"] == "default"
    recorded = OldFile({"campaign": {"model": paper.to_dict()}, "error_budget": None})
    assert surrogate_error_budget(recorded) is None  # recorded as none: kept


def test_a_budget_varies_with_theta_between_its_points_and_says_where_it_is_read():
    """The shipped budget of 'default' at the paper's test holds its largest value everywhere (it
    was measured against one finer mesh). Its rows read as a budget against extrapolated values:
    at a test point what that point leaves (c5 24.1 % below the truth at {3, 540} is 31.8 % of the
    fit; 11.6 % at {11, 330}), between two points linear in log theta, outside them the largest of
    the nearest three, and the bounds' sentence says which."""
    from indentation_studio.inference.budgets.model_error import ModelError, model_error_scope
    from indentation_studio.surrogate.error_budgets import budget_at, shipped_budget

    shipped = shipped_budget(ModelSpec())  # against one finer mesh ('reference'): its largest value
    assert budget_at(shipped, [11.0, 330.0])["c5_pct"] == shipped["c5_pct"]
    assert budget_at(shipped, [11.0, 330.0])["source"]["where"] == "largest"
    held = ModelError(
        np.zeros(2), np.zeros(2), np.zeros((2, 2)), budget_at(shipped, [11, 330])["source"], False
    )
    assert "measured against one finer mesh, not interpolated" in model_error_scope(held)
    # the same rows as if measured against extrapolated values
    left = shipped | {"source": shipped["source"] | {"reference_extrapolated": True}}
    assert len(left["points"]) == 9 and left["c5_pct"] == pytest.approx(
        100 * (1 / (1 - 0.2414) - 1), abs=0.05
    )
    at = budget_at(left, [3.0, 540.0])
    assert at["c5_pct"] == pytest.approx(left["c5_pct"]) and at["source"]["where"] == "interpolated"
    middle = budget_at(left, [11.0, 330.0])
    assert middle["c5_pct"] == pytest.approx(11.56, abs=0.01) and middle["c1_pct"] == pytest.approx(
        2.78, abs=0.01
    )
    # halfway in log c5 between {11, 120} (9.55 %) and {11, 330} (11.56 %)
    half = budget_at(left, [11.0, float(np.sqrt(120.0 * 330.0))])
    assert half["c5_pct"] == pytest.approx(0.5 * (9.55 + 11.56), abs=0.01)
    outside = budget_at(left, [1.0, 540.0])  # c1 below the points' 3 kPa
    assert outside["source"]["where"] == "outside" and [3.0, 540.0] in outside["source"]["nearest"]
    assert outside["c5_pct"] == pytest.approx(left["c5_pct"])  # {3, 540} is among the nearest
    assert budget_at(left, [2.0, 120.0, 0.3])["source"]["where"] == "outside"  # mu is not in a budget
    words = model_error_scope(ModelError(np.zeros(2), np.zeros(2), np.zeros((2, 2)), middle["source"], False))
    assert "interpolated at the fit between 9 test points" in words
    words = model_error_scope(
        ModelError(np.zeros(2), np.zeros(2), np.zeros((2, 2)), outside["source"], False)
    )
    assert "outside the verified region (the 9 test points" in words and "{3, 540}" in words
    old = {k: v for k, v in left.items() if k != "points"}  # recorded before the points were
    assert budget_at(old, [11.0, 330.0])["c5_pct"] == left["c5_pct"]
    assert budget_at(old, [11.0, 330.0])["source"]["where"] == "largest"


def _on(spec: ModelSpec, mesh: str) -> ModelSpec:
    from dataclasses import replace

    return replace(spec, mesh=MeshChoice(mesh))


def test_contact_model_bias_of_a_stick_fit_to_frictional_data():
    """``PRESET@stick`` is the reference's model with the perfect stick: its budget row against a
    frictional reference is the fit the stick assumption causes (a full LM fit agrees)."""
    from indentation_studio.inference.budgets.error_budget import resolve_model

    frictional = COARSE.with_friction(0.3)
    stick, _ = resolve_model("coarse@stick", frictional)
    assert stick.predictor.spec.contact.friction is None
    other, _ = resolve_model("coarse@mu=1", frictional)
    assert other.predictor.spec.contact.friction == 1.0
    with pytest.raises(ValueError, match="@stick or @mu"):
        resolve_model("coarse@slip", frictional)
    budget_row, lm_bias = _budget_and_lm_bias(_reference(frictional), stick)
    assert abs(lm_bias[1]) > 0.1  # friction does move the fit
    np.testing.assert_allclose(budget_row, lm_bias, atol=0.05)


def test_moved_names_have_only_their_new_path():
    """0.2.0 removed the old paths of the names that moved (docs/changelog.md): a design module
    forwarding to inference by strings, and the modules that only forwarded a moved one."""
    for old in (
        "indentation_studio.design.error_budget",
        "indentation_studio.inference.friction_treatment",
        "indentation_studio.inference.units",
        "indentation_studio.forward.feb_writer",
    ):
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(old)
    for package, name in (
        ("design", "shipped_budget"),
        ("design", "resolve_model"),
        ("inference", "FrictionTreatment"),
    ):
        assert not hasattr(importlib.import_module(f"indentation_studio.{package}"), name)
    assert ins.surrogate.shipped_budget is shipped_budget and ins.inference.resolve_model is resolve_model
