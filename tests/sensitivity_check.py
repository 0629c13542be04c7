"""Whole simulations' sensitivities against central differences of whole simulations."""

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
