"""Derivatives against central differences: a whole simulation's sensitivities, a predictor's
Jacobian."""

from __future__ import annotations

import numpy as np

from indentation_studio.forward.mesh import BlockMesh
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import ModelSpec


def assert_sensitivities_match_central_differences(
    spec: ModelSpec, result: SimulationResult, mesh: BlockMesh | None = None, *, rel: float = 1e-4
) -> None:
    """Each of ``result``'s parameters (c1, c5 and mu when it has it) moved by 1e-4 of its value
    both ways: the force's and the top field's central differences match the sensitivities to
    ``rel`` of their largest value. A friction history is path dependent, so the runs must take
    the same increments (asserted)."""
    values = {"c1": spec.material.c1, "c5": spec.material.c5, "mu": spec.contact.friction}
    for k, name in enumerate(result.parameters):
        value = values[name]
        h = 1e-4 * value

        def run(v: float, name: str = name) -> SimulationResult:
            s = spec.with_friction(v) if name == "mu" else spec.with_material(**{name: v})
            return EmbeddedSolver(s, mesh).run()

        rp, rm = run(value + h), run(value - h)
        assert np.array_equal(rp.convergence["increments"], result.convergence["increments"])
        f_fd = (rp.force - rm.force) / (2 * h)
        assert np.abs(result.force_sensitivity[1:, k] - f_fd[1:]).max() < rel * np.abs(f_fd[1:]).max(), name
        u_fd = (rp.displacement - rm.displacement) / (2 * h)
        err = np.abs(result.displacement_sensitivity[1:, ..., k] - u_fd[1:]).max()
        assert err < rel * np.abs(u_fd[1:]).max(), name


def assert_jacobian_matches_central_differences(
    model,
    theta: np.ndarray,
    *,
    step: float,
    force_rtol: float,
    field_rtol: float = 1e-7,
    field_atol_of_max: float = 0.0,
) -> None:
    """A predictor's force and field Jacobians at ``theta`` against central differences of its
    predictions, each parameter moved by ``step`` of its value both ways: the force to
    ``force_rtol``, the field to ``field_rtol`` plus ``field_atol_of_max`` of the largest
    difference quotient (at least 1e-12 absolute)."""
    p = model.predict(theta[None], jacobian=True)
    for i in range(theta.size):
        h = np.zeros(theta.size)
        h[i] = step * theta[i]
        up, down = model.predict((theta + h)[None]), model.predict((theta - h)[None])
        np.testing.assert_allclose(
            p.force_jacobian[..., i], (up.force - down.force) / (2 * h[i]), rtol=force_rtol
        )
        fd = (up.displacement - down.displacement) / (2 * h[i])
        atol = max(field_atol_of_max * float(np.abs(fd).max()), 1e-12)
        np.testing.assert_allclose(p.displacement_jacobian[..., i], fd, rtol=field_rtol, atol=atol)
