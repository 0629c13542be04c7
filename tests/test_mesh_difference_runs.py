"""The output differences of two meshes' runs at the same point (inference.budgets.mesh_difference_runs):
what the mesh's move with mu free is made from (tools/make_mesh_differences.py)."""

from __future__ import annotations

import numpy as np
import pytest

from indentation_studio.forward.solver import simulate
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.budgets.mesh_check import prediction_at_nodes
from indentation_studio.inference.budgets.mesh_difference_runs import mesh_differences_from_runs

THETA = (9.0, 330.0)


@pytest.fixture(scope="module")
def runs():
    """coarse and default at THETA, and coarse at another c1 and to another depth (two steps each)."""

    def spec(mesh: str, c1: float = THETA[0], step_size: float = 0.5) -> ModelSpec:
        protocol = Protocol(steps=2, step_size=step_size)
        return ModelSpec(protocol=protocol, mesh=MeshChoice(mesh)).with_material(c1=c1, c5=THETA[1])

    return {
        "coarse": simulate(spec("coarse")),
        "fine": simulate(spec("default")),
        "other_c1": simulate(spec("coarse", c1=10.0)),
        "deeper": simulate(spec("coarse", step_size=0.6)),
    }


def test_the_differences_are_the_coarse_runs_outputs_less_the_fine_runs_at_the_nodes_asked(runs):
    coarse, fine = runs["coarse"], runs["fine"]
    assert int(fine.solver["mesh"]["nodes"]) > int(coarse.solver["mesh"]["nodes"])
    top = coarse.top_xyz
    d = mesh_differences_from_runs([(coarse, fine)], top, runs=[{"file": "a.npz"}], version="9.9")
    np.testing.assert_allclose(d.points, [THETA])
    # the force per step (depth 0 left out), in log
    np.testing.assert_allclose(d.force_log[0], np.log(coarse.force[1:]) - np.log(fine.force[1:]), rtol=1e-12)
    # at the coarse run's own top nodes its field is itself; the fine run's is interpolated there
    expected = coarse.displacement[1:] - prediction_at_nodes(fine, top).displacement[0]
    np.testing.assert_allclose(d.field[0], expected, atol=1e-12)
    assert np.abs(d.field[0]).max() > 1e-3  # two meshes, not one run twice (mm)
    assert d.meta["coarse_mesh"] == "coarse" and d.meta["fine_mesh"] == "default"
    assert d.meta["runs"] == [{"file": "a.npz"}]
    assert d.meta["made"]["by"] == "inference.budgets.mesh_difference_runs"
    assert d.meta["made"]["version"] == "9.9"


@pytest.mark.parametrize(
    ("pair", "message"),
    [
        (("other_c1", "fine"), "other parameters"),
        (("deeper", "fine"), "other depths"),
        (("fine", "coarse"), "not finer"),
    ],
)
def test_a_pair_that_is_not_one_point_on_two_meshes_is_named(runs, pair, message):
    a, b = (runs[k] for k in pair)
    with pytest.raises(ValueError, match=message):
        mesh_differences_from_runs([(a, b)], runs["coarse"].top_xyz)
