"""Richardson extrapolation of two meshes (forward.convergence.richardson) and the caching Predictor."""

from __future__ import annotations

import numpy as np
from sensitivity_check import assert_jacobian_matches_central_differences

from indentation_studio.forward.convergence.richardson import RichardsonPredictor
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.predictor import CachedPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol, SolverOptions

PROTOCOL = Protocol(step_size=0.5, steps=2)
TIGHT = SolverOptions(residual_tol=1e-11)  # finite differences of whole simulations
COARSE = FESolverPredictor(ModelSpec(mesh=MeshChoice("coarse"), protocol=PROTOCOL, solver=TIGHT))
DEFAULT = FESolverPredictor(ModelSpec(mesh=MeshChoice("default"), protocol=PROTOCOL, solver=TIGHT))
THETA = np.array([8.0, 300.0])


def test_extrapolation_formula_and_jacobian():
    model = RichardsonPredictor(DEFAULT, COARSE, order=1.0)
    assert model.ratio > 1 and np.isclose(model.factor, 1 / (model.ratio - 1))
    p = model.predict(THETA[None], jacobian=True)
    pf, pc = DEFAULT.predict(THETA[None]), COARSE.predict(THETA[None])
    expected = np.log(pf.force) + model.factor * (np.log(pf.force) - np.log(pc.force))
    np.testing.assert_allclose(np.log(p.force), expected, rtol=1e-12)
    # the field: the fine top nodes, the coarse field read there; at the indentation point both meshes have a node
    at_axis = np.flatnonzero(np.all(np.abs(model.top_xyz[:, :2]) < 1e-9, axis=1))[0]
    axis_c = np.flatnonzero(np.all(np.abs(pc.top_xyz[:, :2]) < 1e-9, axis=1))[0]
    uf, uc = pf.displacement[0, :, at_axis], pc.displacement[0, :, axis_c]
    np.testing.assert_allclose(p.displacement[0, :, at_axis], uf + model.factor * (uf - uc), atol=1e-12)
    assert_jacobian_matches_central_differences(
        model, THETA, step=1e-4, force_rtol=1e-5, field_atol_of_max=1e-5
    )


def test_cached_predictor_solves_each_point_once():
    calls = []

    class Counting:
        parameters = ("c1", "c5")

        def predict(self, theta, jacobian=False):
            calls.append((len(np.atleast_2d(theta)), jacobian))
            return COARSE.predict(theta, jacobian)

    cached = CachedPredictor(Counting())
    a = cached.predict(THETA[None])
    b = cached.predict(np.array([THETA, THETA * 1.1]), jacobian=True)
    c = cached.predict(np.array([THETA * 1.1, THETA]))
    assert calls == [(1, False), (2, True)]  # the Jacobian asked for later solves again, once
    np.testing.assert_array_equal(c.force[1], b.force[0])  # the answer with the Jacobian replaced the first
    np.testing.assert_allclose(c.force[1], a.force[0], rtol=1e-12)
    np.testing.assert_array_equal(c.force[0], b.force[1])
    assert c.force_jacobian is None and b.force_jacobian.shape == (2, 2, 2)
