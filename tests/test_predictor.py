"""The Predictor seam: FE solvers behind predict(theta) -> Prediction."""

from __future__ import annotations

import numpy as np
import pytest

from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.predictor import Prediction, Predictor
from indentation_studio.forward.solver import simulate
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol, SpecError


@pytest.fixture(scope="module")
def spec() -> ModelSpec:
    return ModelSpec(protocol=Protocol(step_size=0.5, steps=3), mesh=MeshChoice("coarse"))


def test_embedded_predictor_stacks_results_and_sensitivities(spec):
    pred = FESolverPredictor(spec, sensitivities=True, n_jobs=2)
    assert isinstance(pred, Predictor)
    theta = np.array([[10.0, 350.0], [4.0, 120.0]])
    p = pred.predict(theta)
    assert isinstance(p, Prediction) and p.parameters == ("c1", "c5")
    assert p.force.shape == (2, 3) and p.displacement.shape == (2, 3, len(p.top_xyz), 3)
    np.testing.assert_allclose(p.depth, [0.5, 1.0, 1.5])
    one = simulate(spec.with_material(c1=4.0, c5=120.0), sensitivities=True)
    np.testing.assert_allclose(p.force[1], one.force[1:], rtol=1e-10)
    np.testing.assert_allclose(p.force_jacobian[1], one.force_sensitivity[1:], rtol=1e-8)
    assert p.displacement_jacobian.shape == (2, 3, len(p.top_xyz), 3, 2)
    assert p.force[0, -1] > p.force[1, -1] > 0  # stiffer material, larger force


def test_predictor_rejects_bad_points_before_solving(spec):
    pred = FESolverPredictor(spec)
    with pytest.raises(SpecError, match=r"material\.c1"):
        pred.predict([[10.0, 350.0], [-1.0, 350.0]])
    with pytest.raises(ValueError, match="NaN"):
        pred.predict([[np.nan, 350.0]])
    with pytest.raises(ValueError, match="2 columns"):
        pred.predict([[1.0, 2.0, 3.0]])
