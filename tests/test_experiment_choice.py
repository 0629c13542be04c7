"""Which experiment to run: candidate designs cut from one sensitivity simulation, and the figures."""

from __future__ import annotations

import numpy as np
import pytest

from indentation_studio.design.certainty import gauss_newton_term_hessians
from indentation_studio.design.experiment_choice import (
    Candidate,
    candidate_term_hessians,
    compare_designs,
    measured_steps,
)
from indentation_studio.design.objective import Objective
from indentation_studio.design.objective_over_plane import ObjectiveMap
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.studio.figures import (
    certainty_ellipse,
    design_comparison_figure,
    objective_map_figure,
    save_figure,
)

THETA = np.array([10.0, 350.0])


@pytest.fixture(scope="module")
def coarse():
    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=6))
    return spec, FESolverPredictor(spec, sensitivities=True).predict(THETA)


def test_measured_steps_keep_the_deepest_and_thin_toward_the_surface():
    depth = 0.5 * np.arange(1, 29)
    np.testing.assert_array_equal(measured_steps(depth, Candidate(4.77, 14.0)), np.arange(28))
    np.testing.assert_array_equal(measured_steps(depth, Candidate(4.77, 7.0, every=4)), [1, 5, 9, 13])
    with pytest.raises(ValueError, match="deeper"):
        measured_steps(depth, Candidate(4.77, 15.0))
    with pytest.raises(ValueError, match="whole number"):
        measured_steps(depth, Candidate(4.77, 7.0, every=0))


def test_full_candidate_equals_the_plain_study_and_subsets_lose_information(coarse):
    _, base = coarse
    full = candidate_term_hessians(base, Candidate(4.77, 3.0), THETA)
    objective = Objective.from_prediction(base, radius=4.77)
    np.testing.assert_allclose(full, gauss_newton_term_hessians(objective, base, THETA), rtol=1e-12)
    # a field of view that excludes every node outside the shadow leaves no displacement data
    with pytest.raises(ValueError, match="no top-surface node"):
        candidate_term_hessians(base, Candidate(4.77, 3.0, fov=4.0), THETA)
    # the force term with fewer steps (same normalisation, eq. 4a per step) is a partial sum
    sub = candidate_term_hessians(base, Candidate(4.77, 3.0, every=2), THETA)
    assert 0 < sub[0, 0, 0] < full[0, 0, 0]
    with pytest.raises(ValueError, match="field of view"):
        candidate_term_hessians(base, Candidate(4.77, 3.0, fov=-1.0), THETA)


def test_compare_designs_table_and_plot(coarse, tmp_path):
    spec, _ = coarse
    table = compare_designs(
        spec, [Candidate(4.77, 3.0), Candidate(4.77, 2.0), Candidate(4.77, 3.0, s=0.1)], THETA
    )
    assert list(table["steps"]) == [6, 4, 6]
    # eq. 6 is linear in s
    assert table["c1_pct"][2] == pytest.approx(2 * table["c1_pct"][0])
    assert table["c5_pct_optimised"][2] == pytest.approx(2 * table["c5_pct_optimised"][0], rel=1e-6)
    fig = design_comparison_figure(table)
    assert [len(ax.lines) for ax in fig.axes] == [2, 2]  # one line per (radius, FOV, sampling, s)
    assert save_figure(fig, tmp_path / "d.png").stat().st_size > 10_000


def test_certainty_ellipse_is_the_level_set_and_fig8_is_written(tmp_path):
    H = np.array([[2.07, -0.12], [-0.12, 0.07]])
    e = certainty_ellipse(H, 0.05)
    d = e - 1.0
    np.testing.assert_allclose(np.einsum("ni,ij,nj->n", d, H, d), 0.05**2, rtol=1e-10)
    # the half-width along c1 of the level set is s sqrt(H^-1_11), i.e. eq. 6's bound / sqrt(2)
    assert np.abs(d[:, 0]).max() == pytest.approx(0.05 * np.sqrt(np.linalg.inv(H)[0, 0]), rel=1e-3)
    with pytest.raises(ValueError, match="positive definite"):
        certainty_ellipse(np.diag([1.0, -1.0]), 0.05)
    g1, g5 = np.meshgrid(np.linspace(0.5, 1.5, 9), np.linspace(0.5, 1.5, 9))
    F = 0.5 * (H[0, 0] * (g1 - 1) ** 2 + 2 * H[0, 1] * (g1 - 1) * (g5 - 1) + H[1, 1] * (g5 - 1) ** 2)
    theta_star = np.array([10.0, 350.0])
    omap = ObjectiveMap(
        np.column_stack([g1.ravel(), g5.ravel()]),
        F.ravel(),
        hessian=H,
        s=0.05,
        bounds_pct=np.ones(2),
        theta_star=theta_star,
        eta=np.ones(4) / 4,
        radius=4.77,
    )
    fig = objective_map_figure(omap)
    np.testing.assert_allclose(fig.axes[0].lines[1].get_xydata(), e)  # the ellipse drawn is the level set
    assert save_figure(fig, tmp_path / "f8.png").stat().st_size > 10_000


def test_a_candidate_with_a_budget_carries_its_model_error_and_one_without_says_so():
    from indentation_studio.design.experiment_choice import candidate_model_error
    from indentation_studio.forward.mesh_presets import FIT_MESH, HIGH_FIDELITY_MESH
    from indentation_studio.forward.spec import Indenter
    from indentation_studio.surrogate.error_budgets import budget_at, shipped_budget

    spec = ModelSpec(mesh=MeshChoice(FIT_MESH), protocol=Protocol(step_size=0.5, steps=28))
    for radius in (4.77, 8.0):
        pct, source = candidate_model_error(spec, Candidate(radius, 14.0), THETA)
        paper = ModelSpec(mesh=MeshChoice(HIGH_FIDELITY_MESH), indenter=Indenter(radius))
        expected = budget_at(shipped_budget(paper), THETA)
        np.testing.assert_allclose(pct, [expected["c1_pct"], expected["c5_pct"]])
        assert f"fit-model-R{radius:g}.json" in source and "interpolated" in source
        # a shallower test: no budget was measured for it, and the advice says so
        assert candidate_model_error(spec, Candidate(radius, 7.0), THETA) == (None, "statistical only")
    # the table's totals and the figure's second line where the model error is known
    import pandas as pd

    rows = [
        {"radius_mm": 4.77, "max_depth_mm": d, "every": 1, "fov_mm": np.nan, "s": 0.05,
         "c1_pct_optimised": 0.1, "c5_pct_optimised": 0.5, "c1_model_pct": m, "c5_model_pct": m,
         "c1_total_pct": np.hypot(0.1, m) if m == m else 0.1, "c5_total_pct": np.hypot(0.5, m) if m == m else 0.5}
        for d, m in ((7.0, np.nan), (10.5, np.nan), (14.0, 3.0))
    ]  # fmt: skip
    fig = design_comparison_figure(pd.DataFrame(rows))
    assert [len(ax.lines) for ax in fig.axes] == [2, 2]  # statistical, and with the model error
