"""Coulomb friction in the embedded contact (forward.coulomb_contact): the law's derivatives,
its limits (frictionless against Hertz, mu -> infinity against the exact stick), the stick
zone growing with depth, and the sensitivities, d/dmu included, against whole simulations."""

import dataclasses

import numpy as np
import pytest
from sensitivity_check import assert_sensitivities_match_central_differences

from indentation_studio.forward import (
    linear_solver,
    linear_steps,
    penalty_contact,
    penalty_newton,
    sensitivity_solves,
)
from indentation_studio.forward.contact_quadrature import cells_within, tributary_areas
from indentation_studio.forward.coulomb_law import (
    CONTACT,
    FREE,
    capsule_projection,
    contact_response,
)
from indentation_studio.forward.mesh import preset_mesh
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver, SimulationError
from indentation_studio.forward.spec import (
    Contact,
    Material,
    MeshChoice,
    ModelSpec,
    Protocol,
    SolverOptions,
    SpecError,
)


def _nodes(seed: int = 0, n: int = 8):
    """Nodes near the lower hemisphere (and two above the equator), anchors on the surface."""
    rng = np.random.default_rng(seed)
    radius = 4.77
    d = rng.normal(size=(n, 3))
    d[: n - 2, 2] = -np.abs(d[: n - 2, 2]) - 0.5
    d[n - 2 :, 2] = np.abs(d[n - 2 :, 2]) + 0.2
    d /= np.linalg.norm(d, axis=1)[:, None]
    anchor = capsule_projection(radius * d, radius)[0]
    r = anchor + 0.02 * rng.normal(size=(n, 3)) - 0.01 * d
    eps = 1000.0 * (1.0 + rng.random(n))
    return r, anchor, eps


@pytest.mark.parametrize("mu", [0.0, 0.3, 5.0])
def test_contact_law_derivatives_match_central_differences(mu):
    r, a, eps = _nodes()
    status = np.full(r.shape[0], CONTACT, np.int8)
    status[0] = FREE
    resp = contact_response(r, a, eps, mu, status)
    assert resp.slipping.any()
    h = 1e-7
    for wrt, exact in (("r", resp.df_dr), ("a", resp.df_da)):
        num = np.zeros_like(exact)
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            args_p = (r + e, a) if wrt == "r" else (r, a + e)
            args_m = (r - e, a) if wrt == "r" else (r, a - e)
            fp = contact_response(*args_p, eps, mu, status).force
            fm = contact_response(*args_m, eps, mu, status).force
            num[:, :, k] = (fp - fm) / (2 * h)
        assert np.abs(num - exact).max() < 1e-5 * np.abs(exact).max()
    fp = contact_response(r, a, eps, mu + h, status).force
    fm = contact_response(r, a, eps, max(mu - h, 0.0), status).force
    num_mu = (fp - fm) / (h + min(h, mu))
    assert np.abs(num_mu - resp.dt_dmu).max() < 1e-5 * max(np.abs(resp.dt_dmu).max(), 1.0)


def test_stick_is_a_spring_to_the_anchor_and_slip_sits_on_the_cone():
    r, a, eps = _nodes(1)
    status = np.full(r.shape[0], CONTACT, np.int8)
    stuck = contact_response(r, a, eps, 1e9, status)
    pushed = stuck.pressure > 0  # a pulled node (p < 0) carries no friction
    assert pushed.sum() >= 5 and not stuck.slipping[pushed].any()
    assert np.allclose(stuck.force[pushed], -eps[pushed, None] * (r - a)[pushed])
    slid = contact_response(r, a, eps, 0.2, status)
    on = slid.slipping & (slid.pressure > 0)
    assert on.any()
    size = np.linalg.norm(slid.traction[on], axis=1)
    assert np.allclose(size, 0.2 * slid.pressure[on])
    assert np.allclose(np.einsum("ij,ij->i", slid.traction, slid.normal), 0.0, atol=1e-9)


def test_tributary_areas_cover_the_top_face():
    mesh = preset_mesh("coarse")
    area = tributary_areas(mesh.nodes, mesh.elements, mesh.top)
    assert area.sum() == pytest.approx(50.0 * 50.0, rel=1e-12)
    assert np.all(area > 0)


def test_friction_in_the_spec():
    spec = ModelSpec()
    assert "contact" not in spec.to_dict()  # specs written before friction compare equal
    frictional = spec.with_friction(0.3)
    assert frictional.to_dict()["contact"]["friction"] == 0.3
    assert ModelSpec.from_dict(frictional.to_dict()) == frictional
    assert frictional.contact.describe() == "Coulomb friction mu = 0.3"
    assert Contact(friction=0.0).describe() == "frictionless"
    for bad in (-0.1, float("nan"), float("inf"), "x"):
        with pytest.raises(SpecError, match=r"contact\.friction"):
            spec.with_friction(bad)
    with pytest.raises(SpecError, match=r"contact\.penalty"):
        Contact(friction=0.3, penalty=0.0)


def test_frictionless_indentation_matches_hertz_at_small_depth():
    """Hertz's contact is frictionless: a neo-Hookean half-space (c5 = 0, mu = 2 c1), R = 4.77 mm,
    0.5 mm deep, on the ``fine`` mesh: F = 16/3 mu sqrt(R) d^1.5 (incompressible)."""
    spec = ModelSpec(
        material=Material(c1=10.0, c5=0.0),
        protocol=Protocol(step_size=0.5, steps=1),
        mesh=MeshChoice("fine"),
    ).with_friction(0.0)
    r = EmbeddedSolver(spec).run()
    hertz = 16.0 / 3.0 * 20.0 * np.sqrt(4.77) * 0.5**1.5
    assert r.force[1] / hertz == pytest.approx(1.0, abs=0.05)
    # for an incompressible half-space friction does not couple to the normal problem (Hertz's
    # and Spence's forces agree: the coupling goes with 1 - 2 nu), so the stick force is the same
    stick = EmbeddedSolver(dataclasses.replace(spec, contact=Contact())).run()
    assert r.force[1] / stick.force[1] == pytest.approx(1.0, abs=0.005)


@pytest.fixture(scope="module")
def coarse_runs():
    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=5))
    return {mu: EmbeddedSolver(spec.with_friction(mu)).run() for mu in (None, 0.0, 0.3, 1e6)}


def test_limits_of_the_friction_coefficient(coarse_runs):
    stick, large = coarse_runs[None], coarse_runs[1e6]
    # mu -> infinity: the penalty spring to the anchor against the exact node-wise stick
    assert np.abs(large.force[1:] / stick.force[1:] - 1).max() < 2e-3
    assert np.abs(large.displacement - stick.displacement).max() < 0.01
    assert not coarse_runs[1e6].contact_status[-1].__eq__(2).any()  # nothing slips
    free = coarse_runs[0.0]
    on_axis = np.linalg.norm(free.top_xyz[:, :2], axis=1) < 1e-9  # by symmetry, nothing to slip
    assert (free.contact_status[1:, ~on_axis] != 1).all()  # frictionless: every other node slips
    assert np.all(free.force[1:] <= coarse_runs[0.3].force[1:] * (1 + 1e-6))
    assert np.all(coarse_runs[0.3].force[1:] <= large.force[1:] * (1 + 1e-6))
    assert free.parameters == ("c1", "c5", "mu") and stick.parameters == ("c1", "c5")


def test_stick_zone_grows_with_depth(coarse_runs):
    r = coarse_runs[0.3]
    radius = np.linalg.norm(r.top_xyz[:, :2], axis=1)
    stuck_edge = [radius[s == 1].max(initial=0.0) for s in r.contact_status[1:]]
    contact_edge = [radius[s > 0].max(initial=0.0) for s in r.contact_status[1:]]
    assert np.all(np.diff(contact_edge) >= 0) and contact_edge[-1] > contact_edge[0]
    assert np.all(np.diff(stuck_edge) >= 0) and stuck_edge[-1] > stuck_edge[0]
    slipping = r.contact_status[-1] == 2
    assert slipping.any() and radius[slipping].min() > 0.0  # the centre sticks, the rim slips


def test_sensitivities_with_friction_match_central_differences():
    spec = ModelSpec(
        mesh=MeshChoice("coarse"),
        protocol=Protocol(step_size=0.5, steps=4),
        solver=SolverOptions(residual_tol=1e-11),
    ).with_friction(1.0)
    r = EmbeddedSolver(spec).run(sensitivities=True)
    assert r.force_sensitivity.shape == (5, 3) and r.displacement_sensitivity.shape[-1] == 3
    assert r.convergence["slipping_nodes"].max() > 0  # slip is exercised
    # measured: relative errors 3e-8 (c1), 3e-7 (c5), 3e-5 (mu) in force, 1e-6 in the field
    assert_sensitivities_match_central_differences(spec, r)


def test_sensitivities_where_gmres_cannot_bridge_the_slip_come_from_the_tangents_own_lu(monkeypatch):
    """Where slip makes the tangent too far from its symmetric part for GMRES (the fit issue's
    FE confirmation at R = 8 mm, mu = 0.78, contact-L1), K itself is factorised: the same
    sensitivities as GMRES gives where it converges."""

    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=3)).with_friction(1.0)
    r = EmbeddedSolver(spec).run(sensitivities=True)
    krylov = linear_steps.LinearSteps.krylov

    def no_sensitivity_krylov(self, K, cmask, rhs, rtol, maxiter, **options):
        return (
            None
            if rtol == sensitivity_solves.SENSITIVITY_RTOL
            else krylov(self, K, cmask, rhs, rtol, maxiter, **options)
        )

    monkeypatch.setattr(linear_steps.LinearSteps, "krylov", no_sensitivity_krylov)
    lu = EmbeddedSolver(spec).run(sensitivities=True)
    assert np.array_equal(lu.convergence["increments"], r.convergence["increments"])
    assert r.convergence["slipping_nodes"].max() > 0
    np.testing.assert_allclose(lu.force_sensitivity, r.force_sensitivity, rtol=1e-7, atol=1e-9)
    scale = np.abs(r.displacement_sensitivity).max()
    np.testing.assert_allclose(
        lu.displacement_sensitivity, r.displacement_sensitivity, rtol=0, atol=1e-7 * scale
    )


def test_friction_as_a_campaign_axis(tmp_path):
    from indentation_studio.campaign.loader import load_campaign
    from indentation_studio.campaign.runner import run_named_campaign

    base = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=2))
    summary = run_named_campaign("mu", "c1=5:10:2,c5=200:200:1,mu=0.3:3:2", base, runs_dir=tmp_path, jobs=1)
    assert summary["done"] == 4 and summary["failed"] == 0
    data = load_campaign("mu", tmp_path)
    assert data.theta.shape == (4, 3) and data.parameters == ("c1", "c5", "mu")
    store = tmp_path / "mu" / "points"
    for point, theta in zip(data.points, data.theta, strict=True):
        result = SimulationResult.load(store / f"{point:05d}.npz")
        assert result.spec["contact"]["friction"] == theta[2]
        assert result.parameters == ("c1", "c5", "mu")
    # mu changes the response at the same (c1, c5): at 1 mm, 0.3 against 3
    assert not np.allclose(data.force[0], data.force[1], rtol=1e-4)
    for bad in ({"c1": 5.0, "nu": 0.4}, {"fiber": 1.0}):
        with pytest.raises(SpecError, match="unknown parameter"):
            base.with_parameters(**bad)


def test_fe_predictor_with_mu_as_a_parameter():
    from indentation_studio.forward.fe_predictor import FESolverPredictor

    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=2))
    three = FESolverPredictor(spec, parameters=("c1", "c5", "mu")).predict(
        np.array([[10.0, 350.0, 1.0]]), True
    )
    assert three.force_jacobian.shape == (1, 2, 3) and three.displacement_jacobian.shape[-1] == 3
    fixed = FESolverPredictor(spec.with_friction(1.0)).predict(np.array([[10.0, 350.0]]), True)
    assert fixed.force_jacobian.shape == (1, 2, 2)  # mu fixed: its column is left out
    assert np.array_equal(fixed.force_jacobian, three.force_jacobian[..., :2])
    assert np.array_equal(fixed.force, three.force)


def test_bounds_name_the_contact_they_assume():
    from indentation_studio.inference.budgets.model_error import model_error_scope

    assert "perfect stick assumed" in model_error_scope(None)
    said = model_error_scope(None, contact=ModelSpec().with_friction(0.3).contact.describe())
    assert "Coulomb friction mu = 0.3 assumed" in said and "hold no model error" in said
    from indentation_studio.inference.budgets.model_error import ModelError

    carried = ModelError(np.zeros(2), np.ones(2), np.zeros((2, 2)), None, False, "frictionless")
    assert "frictionless assumed" in carried.to_dict()["includes"]


def test_a_contact_correction_capped_below_the_contact_set_still_solves():
    """The factorisation of the tangent's symmetric part, its contact blocks put back by Woodbury
    for at most max_extra // 3 nodes: with fewer than slip (a large mesh's contact set), every step
    made with a fresh factorisation is GMRES on the true tangent, and the run ends where the
    uncapped one does (within the path dependence of a friction history: 0.05 % measured)."""
    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=4)).with_friction(0.3)
    full = EmbeddedSolver(spec)
    r_full = full.run(sensitivities=True)
    capped = EmbeddedSolver(spec)
    capped.linear.max_extra = 3  # one node's blocks at most
    r_capped = capped.run(sensitivities=True)
    assert r_full.convergence["slipping_nodes"].max() > 1  # more slip than the cap holds
    np.testing.assert_allclose(r_capped.force[1:], r_full.force[1:], rtol=2e-3)
    np.testing.assert_allclose(r_capped.force_sensitivity[1:], r_full.force_sensitivity[1:], rtol=0.05)
    assert capped.linear._W.shape[1] <= 3  # the kept columns stay within max_extra


@pytest.mark.parametrize("mu", [None, 0.3, 3.0])
def test_the_correction_columns_cap_is_400_below_a_gigabyte_and_more_columns_cut_the_krylov_work(mu):
    """The factorisation keeps up to MAX_EXTRA columns of the contact's correction unless they
    would pass EXTRA_COLUMNS_DOUBLES (contact-L4's 222,264 dofs: 400, not the 90 of 2e7 doubles).
    A cap below the changed cells (one cell's 12 dofs) leaves the rest to the Krylov solve: with
    mu = 0.3 more iterations and factorisations for the same forces and sensitivities; under the
    stick and mu = 3 on this small mesh no step changes more than one cell, and the runs are the
    same to the last digit (docs/validation/solver-and-speed.md, "The correction's columns on the
    finest level")."""
    assert linear_solver.MAX_EXTRA == 400
    assert min(linear_solver.MAX_EXTRA, linear_solver.EXTRA_COLUMNS_DOUBLES // 222_264) == 400
    assert (
        linear_solver.EXTRA_COLUMNS_DOUBLES // 700_000 < 400
    )  # a mesh past about 1 GB of columns keeps fewer
    base = ModelSpec(mesh=MeshChoice("contact-L0"), protocol=Protocol(step_size=0.5, steps=8))
    spec = (
        base.with_friction(mu)
        if mu
        else dataclasses.replace(base, contact=Contact(integration="surface", order=1))
    )
    full = EmbeddedSolver(spec)
    assert full.linear.max_extra == 400
    r_full = full.run(sensitivities=True)
    one_cell = EmbeddedSolver(spec)
    one_cell.linear.max_extra = 12  # one contact cell's 4 nodes
    r_one = one_cell.run(sensitivities=True)
    np.testing.assert_allclose(r_one.force[1:], r_full.force[1:], rtol=1e-5)
    np.testing.assert_allclose(
        r_one.force_sensitivity[1:], r_full.force_sensitivity[1:], rtol=1e-4, atol=1e-6
    )
    if mu == 0.3:
        assert full.stats["krylov_iterations"] < one_cell.stats["krylov_iterations"]
        assert full.stats["factorizations"] < one_cell.stats["factorizations"]
    else:
        assert full.stats["krylov_iterations"] == one_cell.stats["krylov_iterations"]
        np.testing.assert_array_equal(r_one.force, r_full.force)


def test_cells_within_counts_the_distinct_dofs_of_neighbouring_cells():
    """A 10 x 10 patch of quad cells on an 11 x 11 grid of nodes: 121 nodes, 363 dofs. The 400
    columns hold all 100 cells, where 3 dofs per node of each cell (12 a cell) would hold 33;
    the prefix stops at the first cell whose new nodes pass the columns; order matters."""
    node = np.arange(121).reshape(11, 11)
    quads = np.stack([node[:-1, :-1], node[:-1, 1:], node[1:, 1:], node[1:, :-1]], axis=-1).reshape(-1, 4)
    dofs = 3 * quads[:, :, None] + np.arange(3)
    assert cells_within(dofs, 400) == 100
    assert cells_within(dofs, 363) == 100 and cells_within(dofs, 362) == 99
    # row by row: the first cell 4 nodes, each next in the row 2 more, each next row's first 2
    assert cells_within(dofs, 12) == 1 and cells_within(dofs, 17) == 1 and cells_within(dofs, 18) == 2
    assert cells_within(dofs, 3 * 22) == 10  # the first row: 22 nodes
    assert cells_within(dofs, 3 * 22 + 5) == 10 and cells_within(dofs, 3 * 24) == 11
    far = dofs[[0, 99, 9, 90]]  # four cells apart from each other: 4 new nodes each
    assert cells_within(far, 47) == 3 and cells_within(far, 48) == 4
    assert cells_within(dofs[:0], 400) == 0 and cells_within(dofs, 5) == 1


def test_the_correction_holds_as_many_changed_cells_as_their_distinct_dofs_fit(monkeypatch):
    """With friction on contact-L1 and the correction's columns cut to 36 (three cells' 12 dofs
    each, the rule before), the cells of a correction share nodes and more of them fit: the
    correction never asks for more than 36 columns, holds more than three cells, and the run's
    forces stay those of the full correction (docs/validation/solver-and-speed.md, "The correction's
    columns on the finest level")."""
    spec = ModelSpec(mesh=MeshChoice("contact-L1"), protocol=Protocol(step_size=0.5, steps=6)).with_friction(
        0.3
    )
    taken, asked = [], []
    within = penalty_contact.cells_within

    def counted(cell_dofs, columns):
        taken.append(within(cell_dofs, columns))
        return taken[-1]

    made = penalty_contact.LowRankUpdate

    def recorded(solver, dofs, D):
        asked.append(np.asarray(dofs).size)
        return made(solver, dofs, D)

    monkeypatch.setattr(penalty_contact, "cells_within", counted)
    monkeypatch.setattr(penalty_contact, "LowRankUpdate", recorded)
    cut = EmbeddedSolver(spec)
    cut.linear.max_extra = 36
    r_cut = cut.run()
    monkeypatch.undo()
    r_full = EmbeddedSolver(spec).run()
    assert taken and max(taken) > 36 // 12
    assert max(asked) <= 36
    np.testing.assert_allclose(r_cut.force[1:], r_full.force[1:], rtol=1e-5)


def test_a_point_predicted_to_stick_answers_with_the_stick_law():
    r, a, eps = _nodes(1)
    status = np.full(r.shape[0], CONTACT, np.int8)
    slid = contact_response(r, a, eps, 0.2, status)
    on = np.flatnonzero(slid.slipping & (slid.pressure > 0))
    assert on.size >= 2
    stuck = np.zeros(r.shape[0], bool)
    stuck[on[0]] = True
    predicted = contact_response(r, a, eps, 0.2, status, stuck=stuck)
    spring = contact_response(r, a, eps, 1e9, status)  # the stick by the same penalty
    k = on[0]
    assert np.allclose(predicted.force[k], spring.force[k]) and not predicted.slipping[k]
    assert np.allclose(predicted.df_dr[k], spring.df_dr[k])
    assert np.linalg.norm(predicted.traction[k]) > 0.2 * predicted.pressure[k]  # off the cone
    rest = np.arange(r.shape[0]) != k  # every other point as the law has it
    assert np.array_equal(predicted.force[rest], slid.force[rest])
    assert np.array_equal(predicted.df_dr[rest], slid.df_dr[rest])


def test_a_slipping_point_turns_round_when_a_step_takes_it_past_its_anchor():
    from indentation_studio.forward.coulomb_contact import FrictionContactState
    from indentation_studio.forward.stick_contact import RigidSphere

    sphere = RigidSphere(4.77, 60.0)
    x0 = np.array([[0.5, 0.0, 60.0]])
    state = FrictionContactState(sphere, x0, np.array([1000.0]), 0.3)
    depth = 1.0
    centre = sphere.centre(depth)
    state.status[:] = CONTACT
    state.anchor[:] = capsule_projection(x0 - centre, sphere.radius)[0]
    n = state.anchor[0] / sphere.radius  # the sphere's outward normal there
    along = np.array([n[2], 0.0, -n[0]])  # the tangent in the x-z plane, +x
    u = (state.anchor + centre - x0) + 0.05 * along - 0.002 * n  # slid 0.05 mm along +x, pressed in
    assert state.response(u, depth).slipping[0] and state.response(u, depth).pressure[0] > 0
    back = -0.08 * along[None, :]  # past the anchor's plane
    assert state.turning(u, back, depth)[0]
    assert state.step_fraction(u, back, depth) == pytest.approx(0.05 / 0.08, rel=0.02)
    assert not state.turning(u, 0.5 * back, depth)[0]  # back, but not as far as the anchor
    assert not state.turning(u, -back, depth)[0]  # on along its slip


def test_turning_points_predicted_to_stick_save_newton_iterations_not_accuracy(monkeypatch):
    """The coarse mesh, R = 8 mm, mu = 0.3, 6 steps: the Newton steps that turn slipping points
    round are made again with their stick predicted (PenaltyContact._turning_points_stick): 46
    Newton iterations instead of 64 (measured), the forces the same to the solver's tolerance."""
    from indentation_studio.forward.spec import Indenter

    spec = (
        ModelSpec(
            mesh=MeshChoice("coarse"), indenter=Indenter(8.0), protocol=Protocol(step_size=0.5, steps=6)
        )
        .with_material(c1=7.0, c5=520.0)
        .with_friction(0.3)
    )
    predicted = EmbeddedSolver(spec).run()
    monkeypatch.setattr(penalty_newton, "TURNING_ROUNDS", 0)  # the whole step cut at the first anchor
    cut = EmbeddedSolver(spec).run()
    n_predicted = int(predicted.convergence["newton_iterations"].sum())
    n_cut = int(cut.convergence["newton_iterations"].sum())
    assert n_predicted < 0.85 * n_cut
    np.testing.assert_allclose(predicted.force[1:], cut.force[1:], rtol=2e-5)


@pytest.mark.slow
def test_a_friction_increment_that_newton_cannot_finish_in_twenty_steps_is_cut_back(monkeypatch):
    """contact-L0, R = 4.77 mm, {3, 540} kPa, mu = 0.3, 28 x 0.5 mm (measured 2026-11-29): with
    the cap of 60 damped steps two increments take 31 and 61 (one cut back after 60); with 20
    they are cut back early, 289 -> 234 Newton iterations, and the forces move by at most 4e-4
    relative, under the increments' own error (1.05e-3 against four increments a step, the same
    for both caps). Under the stick the cap stays 60."""

    assert penalty_newton.FRICTION_NEWTON == 20 and penalty_newton.STICK_NEWTON == 60
    spec = (
        ModelSpec(mesh=MeshChoice("contact-L0"), protocol=Protocol(step_size=0.5, steps=28))
        .with_material(c1=3.0, c5=540.0)
        .with_friction(0.3)
    )
    early = EmbeddedSolver(spec).run(threads=1)
    monkeypatch.setattr(penalty_newton, "FRICTION_NEWTON", 60)
    late = EmbeddedSolver(spec).run(threads=1)
    assert early.convergence["cutbacks"].sum() > late.convergence["cutbacks"].sum()
    assert (
        early.convergence["newton_iterations"].max()
        <= 2 * 20 + 1
        < late.convergence["newton_iterations"].max()
    )
    assert early.convergence["newton_iterations"].sum() < 0.9 * late.convergence["newton_iterations"].sum()
    np.testing.assert_allclose(early.force[1:], late.force[1:], rtol=1e-3)


def _soft_corner_runs_now_and_with(monkeypatch, friction, module, name, value):
    """contact-L0, {3, 540} kPa, 28 x 0.5 mm with sensitivities, as the solver runs it now and with
    ``module.name`` set to ``value`` (a setting before a change)."""
    spec = (
        ModelSpec(mesh=MeshChoice("contact-L0"), protocol=Protocol(step_size=0.5, steps=28))
        .with_material(c1=3.0, c5=540.0)
        .with_friction(friction)
    )
    now = EmbeddedSolver(spec).run(threads=1, sensitivities=True)
    monkeypatch.setattr(module, name, value)
    return now, EmbeddedSolver(spec).run(threads=1, sensitivities=True)


@pytest.mark.parametrize("friction", [None, 3.0])
def test_the_friction_cap_leaves_runs_it_does_not_reach_as_they_were(monkeypatch, friction):
    """contact-L0, {3, 540} kPa, 28 x 0.5 mm, with sensitivities: with mu = 3 no Newton solve needs
    more than 12 damped steps (measured), and the stick keeps its own cap of 60, so the results are
    those of the cap of 60 to the last bit."""

    now, before = _soft_corner_runs_now_and_with(monkeypatch, friction, penalty_newton, "FRICTION_NEWTON", 60)
    np.testing.assert_array_equal(now.force, before.force)
    np.testing.assert_array_equal(now.force_sensitivity, before.force_sensitivity)
    assert now.convergence["newton_iterations"].max() <= 20


def test_gmres_on_a_factorisation_just_made_goes_on_past_its_first_cycle():
    """scipy's GMRES ends a cycle when the preconditioned residual meets the tolerance and only
    then checks the true one: on the solver's own factorisation (contact-L0's tangent) of a tangent
    with a slip-like skew part on the top's tangential dofs, one cycle stops after a few
    iterations short of 1e-8 and counts as failed; the fresh step's ``GMRES_CYCLES`` get there
    (issue 58: a fresh step then took the symmetric part's step and Newton stalled)."""
    import scipy.sparse as sp

    spec = (
        ModelSpec(mesh=MeshChoice("contact-L0"), protocol=Protocol(step_size=0.5, steps=2))
        .with_material(c1=3.0, c5=540.0)
        .with_friction(0.3)
    )
    solver = EmbeddedSolver(spec)
    _, K, _ = solver.assemble(np.zeros((solver.mesh.n_nodes, 3)))
    cmask = solver.bc_fixed.ravel()
    solver.factorize(K, cmask)
    dofs = (3 * solver.top[:, None] + np.array([0, 1])).ravel()
    m = len(dofs)
    B = sp.random(m, m, density=0.05, random_state=2)
    put = sp.csr_matrix((np.ones(m), (dofs, np.arange(m))), shape=(K.shape[0], m))
    rhs = np.where(cmask, 0.0, np.random.default_rng(1).standard_normal(K.shape[0]))
    try:
        for share, one_cycle_stops_at in ((1e-3, 10), (3e-2, 45)):
            A = (K + put @ ((B - B.T) * share * K.diagonal()[dofs].mean()) @ put.T).tocsr()
            before = solver.stats["krylov_iterations"]
            assert solver.krylov(A, cmask, rhs, linear_steps.FRESH_RTOL, linear_steps.FRESH_MAXITER) is None
            assert solver.stats["krylov_iterations"] - before < one_cycle_stops_at  # ended early
            x = solver.krylov(
                A,
                cmask,
                rhs,
                linear_steps.FRESH_RTOL,
                linear_steps.FRESH_MAXITER,
                cycles=linear_steps.GMRES_CYCLES,
            )
            assert x is not None
            residual = np.linalg.norm(np.where(cmask, 0.0, A @ x - rhs)) / np.linalg.norm(rhs)
            assert residual <= linear_steps.FRESH_RTOL
    finally:
        solver.linear.release()


@pytest.mark.parametrize("friction", [None, 0.3, 3.0])
def test_gmres_cycles_leave_runs_whose_first_cycles_get_there_as_they_were(monkeypatch, friction):
    """contact-L0, {3, 540} kPa, 28 x 0.5 mm with sensitivities (measured 2026-11-29): with mu =
    0.3 every fresh step's GMRES meets its tolerance in its first cycle, so the forces with one
    cycle and with ``GMRES_CYCLES`` are the same to the last bit; a sensitivity solve whose GMRES
    now ends in a second cycle instead of on the tangent's own LU moves the sensitivities by 1e-9
    relative (both solve to ``SENSITIVITY_RTOL``). With mu = 3 such a solve leaves another
    factorisation in hand for the next increment's Newton steps, whose path then moves the last
    three steps' forces by 1.4e-6 and their sensitivities by 5e-5, within Newton's own tolerance
    (``residual_tol`` 1e-4 of the reactions). The stick's CG has no cycles: the same run."""

    assert linear_steps.GMRES_CYCLES == 3
    now, before = _soft_corner_runs_now_and_with(monkeypatch, friction, linear_steps, "GMRES_CYCLES", 1)
    same = 26 if friction == 3.0 else len(now.force)  # the steps before the paths part
    np.testing.assert_array_equal(now.force[:same], before.force[:same])
    np.testing.assert_allclose(now.force, before.force, rtol=1e-5)
    np.testing.assert_allclose(
        now.force_sensitivity[:same], before.force_sensitivity[:same], rtol=1e-7, atol=1e-9
    )
    np.testing.assert_allclose(now.force_sensitivity, before.force_sensitivity, rtol=1e-4, atol=1e-9)
    if friction is None:
        np.testing.assert_array_equal(now.force_sensitivity, before.force_sensitivity)


def test_an_increment_of_the_smallest_size_gets_the_full_newton_cap_before_the_run_fails(monkeypatch):
    """Friction's cap on Newton's damped steps (``FRICTION_NEWTON``) is for speed: a step whose
    increments fail within it down to the smallest size is made again from its start with
    ``STICK_NEWTON`` before the run fails (a fit's FE confirmation at R = 8 mm, {1.498, 101.45}
    kPa, mu 0.383, contact-L1, failed at 9.508 mm with 20; made again, step 20 takes the path of a
    run with 60 throughout, to its force at 14 mm to the last bit). Here the cap is set to 3 on
    contact-L0, 3 steps, at most 2 cut-backs: every step is made again, as the uncapped run makes
    it (the same Newton iterations; forces within 1e-5, measured 2.0e-6); without the last resort
    the run fails, naming the depth and the cap."""

    spec = ModelSpec(mesh=MeshChoice("contact-L0"), protocol=Protocol(step_size=0.5, steps=3))
    spec = spec.with_material(c1=10.0, c5=350.0).with_friction(0.3)
    spec = dataclasses.replace(spec, solver=dataclasses.replace(spec.solver, max_cutbacks=2))
    plain = EmbeddedSolver(spec).run(threads=1)
    monkeypatch.setattr(penalty_newton, "FRICTION_NEWTON", 3)
    capped = EmbeddedSolver(spec).run(threads=1)
    assert np.all(capped.convergence["cutbacks"][1:] >= 2) and plain.convergence["cutbacks"].sum() == 0
    np.testing.assert_array_equal(
        capped.convergence["newton_iterations"], plain.convergence["newton_iterations"]
    )
    np.testing.assert_allclose(capped.force[1:], plain.force[1:], rtol=1e-5)
    monkeypatch.setattr(penalty_contact.PenaltyContact, "has_a_last_resort", property(lambda self: False))
    with pytest.raises(SimulationError, match=r"failed at depth 0\.25 mm .*did not converge in 3 iterations"):
        EmbeddedSolver(spec).run(threads=1)


@pytest.mark.parametrize("friction", [None, 0.3])
def test_a_friction_solve_that_stops_lowering_its_residual_fails_at_once(monkeypatch, friction):
    """A Newton solve whose damped steps leave the state where it is (as at a point on its
    cone's edge, contact-L3 mu 2.17, session 35) fails after ``STALL_STEPS`` Newton steps with
    friction, its error naming the stall, instead of after 20 (60 in the last resort); the stick
    keeps its cap of 60 iterations (the surface penalty's stick, as the campaigns run it)."""

    newton_steps = []

    def no_progress(self, u, du, norm, cmask, halve):
        newton_steps.append(halve)
        if not halve:
            return None  # a correction that does not lower the residual: a Newton step next
        R, _, _ = self.solver.assemble(u.reshape(-1, 3), tangent=False)
        return u.copy(), R

    spec = ModelSpec(
        mesh=MeshChoice("contact-L0"),
        protocol=Protocol(step_size=0.5, steps=2),
        contact=Contact(integration="surface", order=1, friction=friction),
    ).with_material(c1=3.0, c5=540.0)
    solver = EmbeddedSolver(spec)
    monkeypatch.setattr(penalty_newton.PenaltyNewton, "_damped_step", no_progress)
    with pytest.raises(SimulationError) as failed:
        solver.run(threads=1)
    if friction is None:
        assert "did not converge in 60 iterations" in str(failed.value)
        assert solver.stats["stalled_solves"] == 0
        assert sum(newton_steps) > 0 and sum(newton_steps) % 60 == 0  # each solve 60 Newton steps
    else:
        assert "Newton stalled: 3 Newton steps in a row lowered the residual by less than 1%" in str(
            failed.value
        )
        # every increment tried (the step's cut-backs, then its last resort) failed as stalled,
        # each after three Newton steps
        assert solver.stats["stalled_solves"] >= 8
        assert sum(newton_steps) == 3 * solver.stats["stalled_solves"]
