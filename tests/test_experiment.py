"""Experiment data: the format's validation (file, row and column named), the processing steps
(eq. 9 relaxation fit, sphere fit, registration, DIC to nodes), and a synthetic experiment made
on a finer mesh fitted back on a coarser one."""

from __future__ import annotations

import ast
import copy
import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.experiment.data import ExperimentDataError, load_experiment
from indentation_studio.inference.experiment.processing import (
    experiment_objective,
    fit_sphere,
    relaxation_fit,
    static_forces,
    to_model_frame,
)
from indentation_studio.inference.experiment.synthetic import (
    LAB_RECORDING,
    Recording,
    write_experiment_from_model,
    write_synthetic_experiment,
)
from indentation_studio.inference.fit.inverse_fit import fit_parameters

PROTOCOL = Protocol(step_size=0.5, steps=4)
FINE = ModelSpec(mesh=MeshChoice("fine"), protocol=PROTOCOL)  # makes the data
FIT = ModelSpec(mesh=MeshChoice("default"), protocol=PROTOCOL)  # fits it (no inverse crime)
TRUE = np.array([12.0, 250.0])
ETA = (0.45, 0.35, 0.2, 0.0)
ROOT = Path(__file__).resolve().parents[1]


class SolvedOnce(FESolverPredictor):
    """The FE predictor, each point solved once: the fine mesh's response at the truth makes the
    synthetic experiment and is the reference its static forces are checked against (a copy is
    handed out each time, so that nothing a caller does to it reaches the next one)."""

    def __init__(self, spec: ModelSpec) -> None:
        super().__init__(spec)
        self.solved: dict = {}

    def predict(self, theta, jacobian=False):
        key = (np.atleast_2d(np.asarray(theta, float)).tobytes(), jacobian)
        if key not in self.solved:
            self.solved[key] = super().predict(theta, jacobian)
        return copy.deepcopy(self.solved[key])


@pytest.fixture(scope="module")
def fine_model() -> SolvedOnce:
    """The model that makes the data (the fine mesh), its solves shared by this file's tests."""
    return SolvedOnce(FINE)


@pytest.fixture(scope="module")
def experiment(tmp_path_factory, fine_model):
    root = tmp_path_factory.mktemp("exp") / "synthetic"
    return write_synthetic_experiment(fine_model, TRUE, root, radius=4.77, step_size=0.5, seed=3)


def _copy(experiment, tmp_path):
    dst = tmp_path / "e"
    shutil.copytree(experiment, dst)
    return dst


def test_relaxation_fit_recovers_f_inf():
    t = np.arange(0, 31.0)
    f = 100.0 + 40.0 * np.exp(-t / 6.0)
    fit = relaxation_fit(t, f + 0.1 * np.random.default_rng(0).standard_normal(t.size))
    assert fit.f_inf == pytest.approx(100.0, abs=0.3) and fit.rate == pytest.approx(1 / 6.0, rel=0.05)
    assert 0 < fit.f_inf_std < 0.3


@pytest.mark.slow
def test_experiment_json_is_read_only_by_load_experiment(experiment):
    """The synthetic block comes with the loaded experiment, and no other module of the package
    parses experiment.json itself (``json.load(s)`` on an expression naming it)."""
    exp = load_experiment(experiment)
    np.testing.assert_array_equal(exp.synthetic["theta"], TRUE)
    assert exp.synthetic["f_noise"] == 0.02
    reads = []
    for folder in ("forward", "campaign", "surrogate", "design", "inference", "studio"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if (
                    isinstance(node, ast.Call)
                    and isinstance(node.func, ast.Attribute)
                    and node.func.attr in ("load", "loads")
                    and isinstance(node.func.value, ast.Name)
                    and node.func.value.id == "json"
                    and any(
                        isinstance(n, ast.Constant) and n.value == "experiment.json" for n in ast.walk(node)
                    )
                ):
                    reads.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert reads == [], "experiment.json read directly (use load_experiment):\n" + "\n".join(reads)


def test_sphere_fit_and_registration(experiment, fine_model):
    exp = load_experiment(experiment)
    _, r = fit_sphere(exp.indenter_xyz)
    assert r == pytest.approx(4.77, abs=0.01)
    dic = to_model_frame(exp)
    meta = json.loads((experiment / "experiment.json").read_text())
    np.testing.assert_allclose(dic.origin, meta["synthetic"]["frame_offset"], atol=0.01)
    np.testing.assert_allclose(np.abs(dic.xyz[:, 2]).max(), 0.0, atol=0.01)
    f_inf, f_std = static_forces(exp)
    assert np.all(f_std > 0)
    truth = fine_model.predict(TRUE).force[0]  # the fine mesh's force at the truth (solved once)
    np.testing.assert_allclose(f_inf, truth, rtol=0.03)


def test_fiber_direction_estimated_from_strain(experiment, tmp_path):
    dst = _copy(experiment, tmp_path)
    meta = json.loads((dst / "experiment.json").read_text())
    meta["fiber_angle_deg"] = None
    (dst / "experiment.json").write_text(json.dumps(meta))
    dic = to_model_frame(load_experiment(dst))
    assert dic.fiber_angle_estimated
    err = (dic.fiber_angle_deg - meta["synthetic"]["true_fiber_angle_deg"] + 90) % 180 - 90
    assert abs(err) < 10.0


@pytest.mark.slow
def test_synthetic_experiment_fit_on_a_coarser_mesh(experiment):
    exp = load_experiment(experiment)
    fit_model = FESolverPredictor(FIT)
    top = fit_model.predict(TRUE).top_xyz
    objective, _ = experiment_objective(exp, top)
    assert objective.measured.sum() >= 6
    fit = fit_parameters(objective, fit_model, ETA)
    # measured: theta_hat (11.89, 256.9) kPa with 95 % bounds 0.47 % and 2.1 % (2 % noise, 4 steps, 54
    # nodes with data): the bounds are statistical and do not cover the discretisation difference
    # between the fine mesh that made the data and the default mesh that fits it
    err = np.abs(fit.theta / TRUE - 1)
    assert err[0] < 0.02 and err[1] < 0.06, fit.theta
    assert np.all(fit.bounds_pct > 0) and np.all(fit.bounds_pct < [3.0, 15.0])
    assert 0 < fit.s < 0.05


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (
            lambda d: (d / "force.csv").write_text("step,time_s\n1,0\n"),
            r"force.csv: missing column\(s\) force_mN",
        ),
        (
            lambda d: (
                pd.read_csv(d / "force.csv")
                .assign(force_mN=lambda t: t.force_mN.where(t.index != 5))
                .to_csv(d / "force.csv", index=False)
            ),
            r"force.csv: row 7, column 'force_mN': not a finite number",
        ),
        (
            lambda d: (
                pd.read_csv(d / "force.csv")
                .assign(force_mN=lambda t: t.force_mN / 1e3)
                .to_csv(d / "force.csv", index=False)
            ),
            r"cannot be millinewtons",
        ),
        (
            lambda d: pd.read_csv(d / "force.csv").query("step != 2").to_csv(d / "force.csv", index=False),
            r"step 2 has 0 force readings",
        ),
        (lambda d: (d / "indenter.csv").unlink(), r"indenter.csv: missing file"),
        (
            lambda d: (d / "experiment.json").write_text(
                json.dumps({"radius_mm": -1, "step_size_mm": 0.5, "steps": 4})
            ),
            r"'radius_mm' must be a positive number",
        ),
    ],
)
def test_malformed_input_is_named(experiment, tmp_path, mutate, message):
    dst = _copy(experiment, tmp_path)
    mutate(dst)
    with pytest.raises(ExperimentDataError, match=message):
        load_experiment(dst)


def test_dic_problems_are_named(experiment, tmp_path):
    dst = _copy(experiment, tmp_path)
    with np.load(dst / "dic.npz") as z:
        xyz, u = z["xyz"], z["u"]
    bad = u.copy()
    bad[1] = np.nan
    np.savez(dst / "dic.npz", xyz=xyz, u=bad)
    with pytest.raises(ExperimentDataError, match="DIC step 2 has no correlated point"):
        load_experiment(dst)
    np.savez(dst / "dic.npz", xyz=xyz, u=u * 1000.0)
    with pytest.raises(ExperimentDataError, match="microns"):
        load_experiment(dst)


def test_shipped_example_experiment_loads_and_registers():
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "examples" / "synthetic-12-250"
    exp = load_experiment(root)
    assert exp.steps == 28 and exp.radius == 4.77 and exp.dic_u.shape == (28, len(exp.dic_xyz), 3)
    dic = to_model_frame(exp)
    np.testing.assert_allclose(dic.origin, [3.0, -2.0, 12.0], atol=0.01)
    assert dic.sphere_radius == pytest.approx(4.77, abs=0.01)
    f_inf, _ = static_forces(exp)
    assert np.all(np.diff(f_inf) > 0)  # the force grows with depth


def test_misregistration_and_absolute_dic_noise(tmp_path):
    """A synthetic experiment with its indenter cap moved by 0.3 mm registers 0.3 mm off (in the DIC
    frame's plane), and its DIC noise in mm is what the displacements carry."""
    from indentation_studio.forward.predictor import Prediction

    class Flat:
        parameters = ("c1", "c5")

        def predict(self, theta, jacobian=False):
            xy = np.stack(np.meshgrid(np.linspace(0, 50, 11), np.linspace(0, 50, 11), indexing="ij"), -1)
            top = np.column_stack([xy.reshape(-1, 2), np.full(121, 60.0)])
            return Prediction(np.array([[10.0, 20.0]]), np.zeros((1, 2, 121, 3)), np.array([0.5, 1.0]), top)

    exp = write_synthetic_experiment(
        Flat(),
        TRUE,
        tmp_path / "m",
        radius=4.77,
        step_size=0.5,
        seed=1,
        u_noise_mm=0.05,
        misregistration_mm=0.3,
    )
    meta = json.loads((exp / "experiment.json").read_text())["synthetic"]
    data = load_experiment(exp)
    off = to_model_frame(data).origin - np.asarray(meta["frame_offset"])
    assert np.linalg.norm(off) == pytest.approx(0.3, abs=0.01) and abs(off[2]) < 0.01
    assert meta["u_noise_mm"] == 0.05 and np.linalg.norm(meta["misregistration_mm"]) == pytest.approx(0.3)
    assert np.std(data.dic_u) == pytest.approx(0.05, rel=0.02)  # the field is zero: what is left is noise
    # the same recording as an object: the same files, byte for byte in the DIC array
    again = write_synthetic_experiment(
        Flat(),
        TRUE,
        tmp_path / "m2",
        radius=4.77,
        step_size=0.5,
        seed=1,
        recording=Recording(u_noise_mm=0.05, misregistration_mm=0.3),
    )
    np.testing.assert_array_equal(load_experiment(again).dic_u, data.dic_u)
    with pytest.raises(TypeError):  # the recording is keyword-only
        write_experiment_from_model(
            np.ones(2), np.zeros((2, 121, 3)), np.zeros((121, 3)), tmp_path / "x", 4.77, 0.5
        )
    assert LAB_RECORDING.u_noise_mm == 0.02 and LAB_RECORDING.misregistration_mm == 0.1
    with pytest.raises(dataclasses.FrozenInstanceError):
        LAB_RECORDING.f_noise = 0.5  # type: ignore[misc]
