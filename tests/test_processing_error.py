"""The processing's part of a fit's bounds (inference.experiment.processing_error, issue 45): the replay at the
fit predicts how far the DIC-points-to-nodes planes move a noise-free fit on the FE model."""

from __future__ import annotations

import numpy as np
import pytest

from indentation_studio.design.objective import PAPER_WEIGHTS
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.budgets.model_error import model_error_scope, with_processing_error
from indentation_studio.inference.experiment.data import load_experiment
from indentation_studio.inference.experiment.processing import experiment_objective
from indentation_studio.inference.experiment.processing_error import processing_error_at
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.inverse_fit import fit_parameters

TRUTH = np.array([12.0, 250.0])


@pytest.fixture(scope="module")
def noise_free(tmp_path_factory):
    """A noise-free experiment of the coarse mesh (3 steps, 1,500 DIC points), its objective."""
    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=3))
    fe = FESolverPredictor(spec, sensitivities=True)
    folder = tmp_path_factory.mktemp("exp") / "noise-free"
    write_synthetic_experiment(
        fe, TRUTH, folder, radius=4.77, step_size=0.5, points=1500, u_noise=0.0, f_noise=0.0
    )
    exp = load_experiment(folder)
    objective, dic = experiment_objective(exp, fe.predict(TRUTH[None]).top_xyz)
    return fe, exp, objective, dic


def test_the_replay_predicts_the_processing_shift_of_a_noise_free_fit(noise_free):
    fe, exp, objective, dic = noise_free
    fit = fit_parameters(objective, fe, PAPER_WEIGHTS, theta0=TRUTH)
    shift_pct = 100.0 * (fit.theta / TRUTH - 1.0)  # the data are the model's own: the processing alone
    assert np.all(np.abs(shift_pct) > 0.01), shift_pct
    part = processing_error_at(objective, dic, fe, TRUTH, PAPER_WEIGHTS, used_steps=exp.used_steps)
    # measured on contact-L1 (4 steps): the noise-free fit c1 +0.228 %, c5 -2.41 %; the replay 0.229, 2.48 %
    np.testing.assert_allclose(part.interpolation_shift_pct, shift_pct, rtol=0.1, atol=0.01)
    # the half-width is the shift's size in log, the larger way round: never below |shift|
    assert np.all(part.interpolation_pct >= np.abs(part.interpolation_shift_pct))
    np.testing.assert_allclose(part.interpolation_pct, np.abs(part.interpolation_shift_pct), rtol=0.05)
    assert np.all(part.registration_pct > 0) and part.registration_mm == 0.1
    np.testing.assert_allclose(part.half_width_pct, np.hypot(part.interpolation_pct, part.registration_pct))
    # an experiment whose indenter points lie 0.1 mm off: its fit moves by no more than the part
    spec = fe.spec
    off = write_synthetic_experiment(
        fe,
        TRUTH,
        exp.root.parent / "off",
        radius=4.77,
        step_size=0.5,
        points=1500,
        u_noise=0.0,
        f_noise=0.0,
        misregistration_mm=0.1,
    )
    off_exp = load_experiment(off)
    off_objective, _ = experiment_objective(off_exp, fe.predict(TRUTH[None]).top_xyz)
    off_fit = fit_parameters(
        off_objective, FESolverPredictor(spec, sensitivities=True), PAPER_WEIGHTS, theta0=TRUTH
    )
    moved_pct = 100.0 * np.abs(off_fit.theta / fit.theta - 1.0)
    assert np.all(moved_pct <= part.registration_pct * 1.05), (moved_pct, part.registration_pct)
    assert np.all(moved_pct >= 0.2 * part.registration_pct), (moved_pct, part.registration_pct)
    carried = with_processing_error(None, part, "perfect stick")
    np.testing.assert_allclose(carried.half_width_pct, part.half_width_pct)
    words = model_error_scope(carried)
    assert "DIC points to nodes" in words and "within 0.1 mm" in words and "no error budget" in words
