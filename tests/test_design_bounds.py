"""Design tools: Appendix B weights, eq. 4/5 objective, eq. 6 to 8 bounds, weight optimisation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from indentation_studio.design.certainty import (
    bounds_pct,
    combine,
    finite_difference_term_hessians,
    gauss_newton_term_hessians,
    s_from_data,
)
from indentation_studio.design.nodal_weights import default_selection, nodal_weights
from indentation_studio.design.objective import Objective, check_weights
from indentation_studio.design.weights import optimise_weights
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol

THETA = np.array([10.0, 350.0])


def test_appendix_b_weights():
    xy = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [6.0, 0.0], [0.0, 6.0], [6.0, 8.0]])
    measured = default_selection(4.77).measured(xy)
    np.testing.assert_array_equal(measured, [False, False, False, True, True, True])
    w = nodal_weights(xy, measured)
    for name in ("ux", "uy", "uz"):
        assert w[name].sum() == pytest.approx(1.0) and np.all(w[name][:3] == 0)
    # B.1: (0.1 x^2 + y^2)^-1/2, normalised: node (6, 0) vs (0, 6) weighs sqrt(10) times more for ux
    assert w["ux"][3] / w["ux"][4] == pytest.approx(np.sqrt(10))
    assert w["uy"][4] / w["uy"][3] == pytest.approx(np.sqrt(10))
    assert w["uz"][3] / w["uz"][5] == pytest.approx(10.0 / 6.0)
    ring = default_selection(4.77, "authors").measured(xy)  # 1.2 R to 5.5 R
    np.testing.assert_array_equal(ring, [False, False, False, True, True, True])
    assert not default_selection(1.0, "authors").measured(np.array([[6.0, 0.0]]))[0]  # beyond 5.5 R


@pytest.mark.parametrize("radius", [4.77, 8.0])
def test_fit_reading_leaves_the_rings_under_one_and_a_half_radii_out(radius):
    # nodes on the x and y axes and a diagonal at 0.5 to 3 R: the paper's objective takes r > R,
    # the fit's r > 1.5 R; both normalise B.1 to B.3 over what they take
    rho = np.array([0.5, 0.99, 1.01, 1.3, 1.49, 1.51, 2.0, 3.0]) * radius
    xy = np.concatenate([np.c_[rho, 0 * rho], np.c_[0 * rho, rho], np.c_[rho, rho] / np.sqrt(2)])
    paper = default_selection(radius).measured(xy)
    fit = default_selection(radius, "fit").measured(xy)
    np.testing.assert_array_equal(paper, np.tile([0, 0, 1, 1, 1, 1, 1, 1], 3).astype(bool))
    np.testing.assert_array_equal(fit, np.tile([0, 0, 0, 0, 0, 1, 1, 1], 3).astype(bool))
    w = nodal_weights(xy, fit, "fit")
    assert all(w[k].sum() == pytest.approx(1.0) and np.all(w[k][~fit] == 0) for k in ("ux", "uy", "uz"))
    # on the same nodes the weights are the paper's renormalised: ratios between nodes unchanged
    wp = nodal_weights(xy, paper)
    np.testing.assert_allclose(w["ux"][fit] / w["ux"][fit][0], wp["ux"][fit] / wp["ux"][fit][0])
    with pytest.raises(ValueError, match="unknown reading 'rings'"):
        default_selection(radius, "rings")


def test_simplex_is_enforced():
    assert check_weights([0.45, 0.35, 0.2, 0]).sum() == pytest.approx(1)
    for bad in ([0.5, 0.5, 0.5, 0], [1.2, -0.2, 0, 0], [0.5, 0.5, 0], [np.nan, 1, 0, 0]):
        with pytest.raises(ValueError, match=r"simplex|4 finite"):
            check_weights(bad)


def test_bounds_scale_linearly_with_s_and_eq6():
    H = np.array([[2.07, -0.12], [-0.12, 0.07]])  # the paper's H(theta*)
    b = bounds_pct(H, 0.05)
    inv = np.linalg.inv(H)
    np.testing.assert_allclose(b, 100 * 0.05 * np.sqrt(2 * np.diag(inv)))
    np.testing.assert_allclose(bounds_pct(H, 0.1), 2 * b)
    np.testing.assert_allclose(bounds_pct(H, 0.013), 0.26 * b)
    assert np.all(np.isinf(bounds_pct(np.array([[1.0, 1.0], [1.0, 1.0]]), 0.05)))  # singular
    with pytest.raises(ValueError, match="positive"):
        bounds_pct(H, -0.05)


def test_eq8_s_from_the_f_distribution():
    n, p, F_hat = 120, 2, 0.3
    expected = np.sqrt(p / (n - p) * stats.f.ppf(0.95, p, n - p) * F_hat)
    assert s_from_data(F_hat, n, p, 0.05) == pytest.approx(expected)
    with pytest.raises(ValueError, match="more data points"):
        s_from_data(F_hat, 2, 2)


def test_weight_optimum_matches_the_analytic_one():
    a, b = 4.0, 0.25  # term 1 informs c1 only, term 2 c5 only
    H = np.zeros((4, 2, 2))
    H[0, 0, 0], H[1, 1, 1] = a, b
    eta = optimise_weights(H, "combined")  # min 1/(eta1 a) + 1/(eta2 b) on eta1 + eta2 = 1
    expected = np.sqrt(1 / a) / (np.sqrt(1 / a) + np.sqrt(1 / b))
    np.testing.assert_allclose(eta, [expected, 1 - expected, 0, 0], atol=1e-4)


@pytest.fixture(scope="module")
def small_design():
    spec = ModelSpec(protocol=Protocol(step_size=0.5, steps=3), mesh=MeshChoice("coarse"))
    exact = FESolverPredictor(spec, sensitivities=True).predict(THETA)
    return spec, exact


@pytest.mark.parametrize("reading", ["paper", "authors"])
def test_objective_residuals_and_hessians_exact_vs_fd(small_design, reading):
    spec, exact = small_design
    obj = Objective.from_prediction(exact, radius=spec.indenter.radius, reading=reading)
    eta = [0.45, 0.35, 0.2, 0.0]
    assert obj.value(exact, eta)[0] == 0.0
    moved = FESolverPredictor(spec).predict(THETA * [1.1, 0.9])
    r = obj.residuals(moved, eta)
    assert np.sum(r**2) == pytest.approx(obj.value(moved, eta)[0], rel=1e-12)
    Hgn = gauss_newton_term_hessians(obj, exact, THETA)
    Hfd = finite_difference_term_hessians(obj, FESolverPredictor(spec), THETA, h=0.01)
    for eta in ([0.45, 0.35, 0.2, 0.0], [0.0, 0.35, 0.35, 0.3]):
        a, b = combine(Hgn, eta), combine(Hfd, eta)
        assert np.abs(a - b).max() <= 0.02 * np.abs(a).max()
    # bounds of the paper's combined weights (displacements alone are ill-conditioned on 3 steps)
    a, b = combine(Hgn, [0.45, 0.35, 0.2, 0.0]), combine(Hfd, [0.45, 0.35, 0.2, 0.0])
    np.testing.assert_allclose(bounds_pct(a, 0.05), bounds_pct(b, 0.05), rtol=0.02)


def test_design_bounds_command_says_what_its_bounds_hold():
    """The design-stage bounds are eq. 6 at a given s: the command's JSON and text say they hold
    the measurement noise only, and where the model error is measured."""
    import json

    from typer.testing import CliRunner

    from indentation_studio.studio.cli import app

    args = ["design", "bounds", "--mesh", "coarse", "--steps", "3", "--weights", "0.45,0.35,0.2,0"]
    out = CliRunner().invoke(app, [*args, "--json"])
    assert out.exit_code == 0, out.output
    payload = json.loads(out.stdout)
    assert payload["c1_pct"] > 0 and "measurement noise only" in payload["bounds_include"]
    text = CliRunner().invoke(app, args)
    assert "no model error" in text.output and "error-budget" in text.output


def test_design_bounds_with_friction_zero_one_and_a_bad_step():
    """``--friction 0`` gives the frictionless bounds with mu known (mu has no log there), a
    positive mu all three readings as strict JSON (mu's bound null where nothing slips), and a
    finite-difference step per parameter that misses mu is named."""
    import json

    from typer.testing import CliRunner

    from indentation_studio.studio.cli import app

    args = ["design", "bounds", "--mesh", "coarse", "--steps", "3", "--json"]
    zero = CliRunner().invoke(app, [*args, "--friction", "0"])
    assert zero.exit_code == 0, zero.output
    payload = json.loads(zero.stdout)
    assert payload["friction"]["identified_pct"] is None and "frictionless" in payload["friction"]["note"]
    stick = json.loads(CliRunner().invoke(app, args).stdout)
    assert payload["c5_pct"] > 0 and abs(payload["c5_pct"] / stick["c5_pct"] - 1) > 0.01  # another contact
    with_mu = CliRunner().invoke(app, [*args, "--friction", "0.5"])
    assert with_mu.exit_code == 0, with_mu.output
    fr = json.loads(with_mu.stdout, parse_constant=lambda c: pytest.fail(f"not JSON: {c}"))["friction"]
    assert fr["known_pct"][1] <= fr["nuisance_pct"][1] <= fr["identified_pct"][1]
    bad = CliRunner().invoke(app, [*args, "--friction", "0.5", "--method", "fd", "--fd-step", "0.02,0.02"])
    assert bad.exit_code != 0 and "one per parameter (3)" in bad.stdout
