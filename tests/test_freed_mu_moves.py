"""The mesh's error with the fit's own free parameters (issue 57, option (i)): the budget's points'
output differences moved through the fit by refits with mu held and with mu free, their file,
and a fit freeing mu carrying them (inference.budgets.freed_mu_moves, surrogate.mesh_differences)."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from indentation_studio.design.objective import Objective
from indentation_studio.inference.budgets.freed_mu_moves import (
    freed_mu_moves,
    mesh_moves,
    points_read,
    with_freed_mu,
)
from indentation_studio.inference.budgets.model_error_parts import ModelError
from indentation_studio.surrogate import mesh_differences as md
from indentation_studio.surrogate.mesh_differences import MeshDifferences, shipped_mesh_differences

THETA = np.array([9.0, 330.0, 0.5])
ETA = [0.45, 0.35, 0.2, 0.0]
#: Four points around THETA: it lies inside their hull.
CORNERS = np.array([[6.0, 250.0], [12.0, 250.0], [6.0, 450.0], [12.0, 450.0]])


def _objective(model):
    p = model.predict(THETA[None], jacobian=True)
    return Objective(p.force[0], p.displacement[0], p.top_xyz, radius=4.77), p


def _along(p, k: int, delta: float) -> np.ndarray:
    """The outputs' first-order change when parameter k moves by a fraction ``delta`` of itself."""
    d_log_force = p.force_jacobian[0, :, k] * THETA[k] * delta / p.force[0]
    d_field = p.displacement_jacobian[0, ..., k] * THETA[k] * delta
    return np.concatenate([d_log_force, d_field.ravel()])


def _differences(p, outputs: np.ndarray, points=CORNERS, meta=None) -> MeshDifferences:
    steps, nodes = p.force.shape[1], len(p.top_xyz)
    n = len(points)
    field = np.broadcast_to(outputs[steps:].reshape(steps, nodes, 3), (n, steps, nodes, 3))
    return MeshDifferences(
        np.asarray(points, float), np.tile(outputs[:steps], (n, 1)), np.array(field), p.top_xyz, meta or {}
    )


def test_a_change_the_fit_can_take_in_c5_moves_nothing_more_when_mu_is_freed(mu_surrogate):
    objective, p = _objective(mu_surrogate)
    d = freed_mu_moves(objective, ETA, mu_surrogate, THETA, _differences(p, _along(p, 1, 0.03)))
    # held and free both take it as c5 3 % lower: freeing mu adds nothing (to second order in 3 %)
    assert d.shape == (4, 2)
    np.testing.assert_allclose(d, 0.0, atol=2e-4)


def test_a_change_that_looks_like_slip_is_taken_by_mu_when_it_is_freed(mu_surrogate):
    objective, p = _objective(mu_surrogate)
    delta = 1e-3
    d = freed_mu_moves(objective, ETA, mu_surrogate, THETA, _differences(p, _along(p, 2, delta)))
    # mu held: (c1, c5) move by -(J2^T J2)^-1 J2^T J_mu delta; mu free: mu takes it all, (c1, c5) stay
    J = objective.jacobian(p, np.asarray(ETA))[0] * THETA
    held = -np.linalg.lstsq(J[:, :2], J[:, 2] * delta, rcond=None)[0]
    assert np.max(np.abs(held)) > 1e-5  # mu's change is not orthogonal to c1's and c5's
    np.testing.assert_allclose(d, np.tile(-held, (4, 1)), rtol=2e-2, atol=1e-8)


def test_a_large_change_of_mu_is_taken_whole_by_mu_where_a_first_order_move_is_not(mu_surrogate):
    objective, p = _objective(mu_surrogate)
    # the data moved by exactly what mu 0.5 -> 1.5 changes (nonlinear): with mu free the refit lands
    # on (c1, c5, 1.5), so (c1, c5) do not move; with mu held they take part of it
    other = mu_surrogate.predict(np.array([[THETA[0], THETA[1], 1.5]]))
    change = np.concatenate(
        [np.log(other.force[0]) - np.log(p.force[0]), (other.displacement[0] - p.displacement[0]).ravel()]
    )
    free, held = mesh_moves(objective, ETA, mu_surrogate, THETA, change)
    np.testing.assert_allclose(free, 0.0, atol=1e-8)
    assert abs(held[1]) > 1e-2  # c5 1.4 % with mu held
    # one Gauss-Newton step at the fit (the first-order move) misses the refit's free move
    J = objective.jacobian(p, np.asarray(ETA))[0] * THETA
    dr = (
        objective.residuals(mu_surrogate.predict(np.array([[THETA[0], THETA[1], 1.5]])), np.asarray(ETA))[0]
        - objective.residuals(p, np.asarray(ETA))[0]
    )
    first_order = np.linalg.lstsq(J, dr, rcond=1e-8)[0]  # the step the data's move asks
    assert abs(first_order[1]) > 1e-4  # c5 moves 0.06 %: mu's step (0.29 in log) falls short of log 3


def test_the_freed_move_corrects_the_budget_and_widens_it_by_as_much(mu_surrogate):
    objective, p = _objective(mu_surrogate)
    differences = _differences(p, _along(p, 2, 0.02))
    moves = 100.0 * np.expm1(freed_mu_moves(objective, ETA, mu_surrogate, THETA, differences)[0])
    base = ModelError(
        np.zeros(2),
        np.array([1.0, 2.0]),
        np.zeros((2, 2)),
        {"file": "b.json"},
        correction_pct=np.array([0.5, -1.0]),
    )
    out = with_freed_mu(base, objective, ETA, mu_surrogate, THETA, differences)
    np.testing.assert_allclose(out.budget_pct, np.array([1.0, 2.0]) + np.abs(moves), rtol=1e-9)
    np.testing.assert_allclose(out.correction_pct, np.array([0.5, -1.0]) - moves, rtol=1e-9)
    assert out.budget_source["file"] == "b.json" and out.budget_source["mu_free"]["where"] == "interpolated"
    outside = with_freed_mu(
        base, objective, ETA, mu_surrogate, THETA, _differences(p, _along(p, 2, 0.02), CORNERS * 3)
    )
    assert outside.budget_source["mu_free"]["where"] == "outside"
    one = with_freed_mu(
        base, objective, ETA, mu_surrogate, THETA, _differences(p, _along(p, 2, 0.02), CORNERS[:2])
    )
    assert one.budget_source["mu_free"]["where"] == "largest"  # two points: the largest move, no correction
    np.testing.assert_allclose(one.budget_pct, np.array([1.0, 2.0]) + np.abs(moves), rtol=1e-9)
    np.testing.assert_allclose(one.correction_pct, [0.5, -1.0])


def test_a_fit_without_mu_or_a_stack_of_changes_is_named(mu_surrogate):
    objective, p = _objective(mu_surrogate)
    d = _along(p, 1, 0.03)
    with pytest.raises(ValueError, match=r"\(c1, c5, mu\), got 2 values"):
        mesh_moves(objective, ETA, mu_surrogate, THETA[:2], d)
    with pytest.raises(ValueError, match=r"one vector, got the shape \(2, "):
        mesh_moves(objective, ETA, mu_surrogate, THETA, np.stack([d, d]))
    with pytest.raises(ValueError, match=r"got 2 values"):
        freed_mu_moves(objective, ETA, mu_surrogate, THETA[:2], _differences(p, d))


def test_only_the_points_the_budget_reads_at_the_fit_are_moved():
    # inside the hull: the three vertices of the triangle holding the fit (near the first corner)
    inside = points_read(CORNERS, np.array([6.3, 260.0, 0.5]))
    assert inside[0] and inside.sum() == 3
    # outside: the nearest three (surrogate.error_budgets.NEAREST_OUTSIDE)
    outside = points_read(CORNERS * 3, THETA)
    np.testing.assert_array_equal(outside, [True, True, True, False])
    # two points cannot be read between: all of them (the largest move is taken)
    assert points_read(CORNERS[:2], THETA).all()


def test_mesh_differences_read_back_and_follow_other_nodes(tmp_path, mu_surrogate):
    _, p = _objective(mu_surrogate)
    xyz = p.top_xyz
    steps = p.force.shape[1]
    # a field linear in x and y is interpolated exactly wherever the nodes move on the top surface
    field = np.stack(
        [
            np.stack([0.01 * s * xyz[:, 0], -0.02 * xyz[:, 1], 0.003 * s * xyz[:, 0] + xyz[:, 1] * 1e-3], -1)
            for s in range(1, steps + 1)
        ]
    )
    diff = MeshDifferences(
        CORNERS[:1], np.full((1, steps), 0.01), field[None], xyz, {"model": {"mesh": {"preset": "x"}}}
    )
    back = MeshDifferences.load(diff.save(tmp_path / "d.npz"))
    np.testing.assert_allclose(back.outputs_at(xyz), diff.outputs_at(xyz), rtol=1e-6, atol=1e-9)
    assert back.meta == diff.meta
    inner = xyz[(xyz[:, 0] < 0.8 * xyz[:, 0].max()) & (xyz[:, 1] < 0.8 * xyz[:, 1].max())]
    moved = inner + np.array([0.3, 0.2, 0.0])
    want = np.stack(
        [
            np.stack(
                [0.01 * s * moved[:, 0], -0.02 * moved[:, 1], 0.003 * s * moved[:, 0] + moved[:, 1] * 1e-3],
                -1,
            )
            for s in range(1, steps + 1)
        ]
    )
    np.testing.assert_allclose(back.outputs_at(moved)[0, steps:], want.ravel(), atol=1e-6)


def test_bad_mesh_differences_are_named(tmp_path):
    with pytest.raises(ValueError, match="field holds a NaN"):
        MeshDifferences(CORNERS[:1], np.zeros((1, 2)), np.full((1, 2, 3, 3), np.nan), np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"\(points, steps, nodes, 3\)"):
        MeshDifferences(CORNERS[:1], np.zeros((1, 2)), np.zeros((1, 2, 4, 3)), np.zeros((3, 3)))
    (tmp_path / "x.npz").write_text("not a file")
    with pytest.raises(ValueError, match="not a mesh-differences file"):
        MeshDifferences.load(tmp_path / "x.npz")


@pytest.mark.parametrize(("tag", "radius"), [("R4.77", 4.77), ("R8", 8.0)])
def test_the_shipped_differences_are_found_by_test_and_mesh(tag, radius):
    from indentation_studio.surrogate.shipped import load_shipped, shipped_surrogates

    entry = next(e for e in shipped_surrogates() if e.name.endswith(tag))
    model = load_shipped(entry).meta["campaign"]["model"]
    found = shipped_mesh_differences(model)
    assert (
        found is not None
        and found.meta["coarse_mesh"] == "contact-L3"
        and found.meta["fine_mesh"] == "contact-L4"
    )
    assert len(found.points) == 9 and found.meta["file"].endswith(f"mesh-differences-{tag}.npz")
    assert found.meta["model"]["indenter"]["radius"] == radius
    # level 3 is stiffer than level 4 at every budget point: its force is higher at 14 mm
    assert np.all(found.force_log[:, -1] > 0)
    other = json.loads(json.dumps(model))
    other["indenter"]["radius"] = 6.0
    assert shipped_mesh_differences(other) is None
    other["indenter"]["radius"] = radius
    other["mesh"]["preset"] = "contact-L2"
    assert shipped_mesh_differences(other) is None


def test_a_fit_freeing_mu_carries_the_freed_move_and_one_holding_it_does_not(
    mu_surrogate, tmp_path, monkeypatch
):
    from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
    from indentation_studio.inference.fit.workflow import fit_experiment

    model = copy.copy(mu_surrogate)
    spec = json.loads(json.dumps(model.meta["campaign"]["model"]))
    model.meta = dict(model.meta) | {
        "error_budget": {
            "c1_pct": 3.0,
            "c5_pct": 4.0,
            "source": {"model": "coarse", "points": 9, "file": "b.json"},
        }
    }
    _, p = _objective(model)
    _differences(p, _along(p, 2, 0.05), meta={"model": spec}).save(tmp_path / "mesh-differences-test.npz")
    monkeypatch.setattr(md, "shipped_budgets_folder", lambda: tmp_path)
    exp = write_synthetic_experiment(model, THETA, tmp_path / "e", radius=4.77, step_size=0.5, seed=2)
    freed = fit_experiment(exp, model, refine=False, reading="paper", friction="marginalise").to_dict()
    held = fit_experiment(exp, model, refine=False, reading="paper", friction=0.5).to_dict()
    added = freed["model_error"]["error_budget_source"]["mu_free"]
    assert added["points"] == 4 and added["c5_pct"] > 0.01
    np.testing.assert_allclose(
        freed["model_error"]["error_budget_pct"], [3.0 + added["c1_pct"], 4.0 + added["c5_pct"]]
    )
    np.testing.assert_allclose(
        freed["model_error"]["correction_pct"], [added["c1_correction_pct"], added["c5_correction_pct"]]
    )
    assert "mu_free" not in (held["model_error"]["error_budget_source"] or {})
    np.testing.assert_allclose(held["model_error"]["error_budget_pct"], [3.0, 4.0])
    # the mesh's move on mu itself (its outputs changed as mu 5 % higher at THETA: at the noisy
    # fit, mu moves 3.8 %, the rest taken by c1 and c5) is a part of mu's model error: root sum of
    # squares with the others, so at least it
    assert 2.0 < added["mu_pct"] < 5.0
    assert freed["friction"]["mu_model_pct"] >= added["mu_pct"]


def test_the_mesh_moves_mu_itself_by_what_its_change_looks_like_in_mu(mu_surrogate):
    objective, p = _objective(mu_surrogate)
    other = mu_surrogate.predict(np.array([[THETA[0], THETA[1], 1.5]]))
    change = np.concatenate(
        [np.log(other.force[0]) - np.log(p.force[0]), (other.displacement[0] - p.displacement[0]).ravel()]
    )
    free, held = mesh_moves(objective, ETA, mu_surrogate, THETA, change, with_mu=True)
    assert free.shape == (3,) and held.shape == (2,)
    np.testing.assert_allclose(free, [0.0, 0.0, np.log(0.5 / 1.5)], atol=1e-6)
    moves = freed_mu_moves(objective, ETA, mu_surrogate, THETA, _differences(p, change), with_mu=True)
    np.testing.assert_allclose(moves[:, 2], np.log(0.5 / 1.5), atol=1e-6)
    np.testing.assert_allclose(moves[:, :2], -np.tile(held, (4, 1)), atol=1e-6)


def test_a_fit_freeing_mu_without_the_outputs_says_its_bound_leaves_that_out(
    mu_surrogate, tmp_path, monkeypatch
):
    from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
    from indentation_studio.inference.fit.workflow import fit_experiment

    model = copy.copy(mu_surrogate)
    model.meta = dict(model.meta) | {
        "error_budget": {
            "c1_pct": 3.0,
            "c5_pct": 4.0,
            "source": {"model": "coarse", "points": 9, "file": "b.json"},
        }
    }
    (tmp_path / "none").mkdir()
    monkeypatch.setattr(md, "shipped_budgets_folder", lambda: tmp_path / "none")
    exp = write_synthetic_experiment(model, THETA, tmp_path / "e", radius=4.77, step_size=0.5, seed=2)
    d = fit_experiment(exp, model, refine=False, reading="paper", friction="marginalise").to_dict()
    assert d["model_error"]["error_budget_source"]["mu_free"] == {"measured": False}
    np.testing.assert_allclose(d["model_error"]["error_budget_pct"], [3.0, 4.0])
    assert "not what freeing mu, as this fit does, adds to the mesh's error" in d["bounds_include"]
