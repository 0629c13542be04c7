"""The multi-fidelity surrogate (surrogate/multi_fidelity.py) on synthetic two-level data: a low
"model" and a high one that is the low plus a known smooth discrepancy, on different top nodes.
The discrepancy is learned, Jacobians are exact, files round-trip, the discrepancy's uncertainty
vanishes at its data, and a fit on it recovers what the low level alone misses."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.model_selection import KFold

from indentation_studio.campaign.loader import CampaignData
from indentation_studio.design.objective import Objective
from indentation_studio.design.reduced_objective import FieldObjective, ReducedObjective, objective_function
from indentation_studio.forward.convergence.mesh_study import top_field_interpolator
from indentation_studio.forward.predictor import Prediction
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.error_parts import FRICTION_DISCREPANCY_UNMEASURED
from indentation_studio.inference.fit.held_out_refits import HeldOutRefits, held_out_refits
from indentation_studio.inference.fit.inverse_fit import fit_parameters
from indentation_studio.inference.fit.workflow import fit_experiment
from indentation_studio.surrogate.base import FieldSurrogate, TrainingData
from indentation_studio.surrogate.emulation_error import EmulationError
from indentation_studio.surrogate.gaussian_process import GaussianProcessSurrogate
from indentation_studio.surrogate.multi_fidelity import MultiFidelitySurrogate, interpolation_matrix
from indentation_studio.surrogate.persistence import load_surrogate, save_surrogate
from indentation_studio.surrogate.slip_surrogate import SlipSurrogate
from indentation_studio.surrogate.training import make_surrogate, train_multi_fidelity
from indentation_studio.surrogate.training_set import merged_training_data
from indentation_studio.surrogate.validation import prediction_errors

LO, HI = np.array([2.0, 100.0]), np.array([20.0, 500.0])
DEPTH = np.array([0.5, 1.0, 1.5, 2.0])
RADIUS = 2.0
ETA = (0.45, 0.35, 0.2, 0.0)
MODEL = {
    "geometry": {"half_x": 10.0, "half_y": 10.0, "height": 10.0},
    "indenter": {"radius": RADIUS},
    "protocol": {"step_size": 0.5, "steps": 4},
}


def grid_nodes(n: int) -> np.ndarray:
    """A quarter top surface [0, 10]^2 (a tensor grid, finer towards the axis)."""
    x = 10.0 * np.linspace(0.0, 1.0, n) ** 1.5
    X, Y = np.meshgrid(x, x, indexing="ij")
    return np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, 10.0)])


LOW_XYZ, HIGH_XYZ = grid_nodes(6), grid_nodes(9)


def response(theta: np.ndarray, xyz: np.ndarray, high: bool) -> tuple[np.ndarray, np.ndarray]:
    """Force (n, steps) mN and field (n, steps, nodes, 3) mm of the synthetic models: the low one,
    or the low one plus a smooth discrepancy in log force (about 5 %) and in the field."""
    a, b = (np.log(theta[:, j])[:, None, None] for j in range(2))  # (n, 1, 1)
    d = DEPTH[None, :, None]
    x, y = xyz[None, None, :, 0], xyz[None, None, :, 1]
    r2 = x**2 + y**2
    a2, b2, d2 = a[..., 0], b[..., 0], d[..., 0]  # (n, 1), (n, 1), (1, steps)
    log_f = 0.5 * a2 + 0.3 * b2 + 1.5 * np.log(d2) + 0.05 * a2 * b2 - 2.0
    width = 2.0 + 0.4 * a - 0.15 * b + 1.0
    uz = -d * np.exp(-r2 / (2.0 * width**2))
    ux = 0.05 * d * x * np.exp(-r2 / (3.0 * width**2)) * (1.0 + 0.1 * a)
    uy = 0.04 * d * y * np.exp(-r2 / (3.0 * width**2)) * (1.0 + 0.05 * b)
    if high:
        log_f = log_f + 0.05 * np.sin(a2) * (1.0 + 0.2 * d2) + 0.02 * b2 - 0.1
        uz = uz + 0.05 * d * np.cos(b) * np.exp(-r2 / 20.0)
        ux = ux + 0.01 * d * x / 10.0 * np.sin(a)
    return np.exp(log_f), np.stack(np.broadcast_arrays(ux, uy, uz), axis=-1)


def synthetic(theta: np.ndarray, high: bool, name: str) -> TrainingData:
    xyz = HIGH_XYZ if high else LOW_XYZ
    force, disp = response(theta, xyz, high)
    mesh = {"preset": "default" if high else "coarse"}
    return TrainingData(
        theta, force, disp, DEPTH, xyz, source={"name": name, "model": {**MODEL, "mesh": mesh}}
    )


def box_points(n: int, seed: int) -> np.ndarray:
    """n points of the box, uniform in log theta (Latin hypercube)."""
    rng = np.random.default_rng(seed)
    u = (np.argsort(rng.random((2, n)), axis=1).T + rng.random((n, 2))) / n
    return np.exp(np.log(LO) + u * (np.log(HI) - np.log(LO)))


@pytest.fixture(scope="module")
def low() -> GaussianProcessSurrogate:
    g = np.exp(np.linspace(np.log(LO), np.log(HI), 10))
    theta = np.stack(np.meshgrid(g[:, 0], g[:, 1], indexing="ij"), axis=-1).reshape(-1, 2)
    return make_surrogate("gp", restarts=1).fit(synthetic(theta, False, "low-campaign"))


HIGH_THETA = box_points(20, seed=1)


@pytest.fixture(scope="module")
def high_data() -> TrainingData:
    return synthetic(HIGH_THETA, True, "high-campaign")


@pytest.fixture(scope="module")
def mf(low, high_data) -> MultiFidelitySurrogate:
    return MultiFidelitySurrogate(low, restarts=1, folds=4).fit(high_data, seed=0)


def held_out(n: int = 30) -> np.ndarray:
    """n points inside the high campaign's box (smaller than the low one's), none of its points."""
    lo, hi = HIGH_THETA.min(axis=0), HIGH_THETA.max(axis=0)
    u = (np.log(box_points(n, seed=7)) - np.log(LO)) / (np.log(HI) - np.log(LO))
    return np.exp(np.log(lo) + u * (np.log(hi) - np.log(lo)))


def test_interpolation_matrix_is_the_top_field_interpolator():
    rng = np.random.default_rng(0)
    field = rng.standard_normal((len(LOW_XYZ), 5))
    W = interpolation_matrix(LOW_XYZ, HIGH_XYZ)  # tensor grid: bilinear
    np.testing.assert_allclose(W @ field, top_field_interpolator(LOW_XYZ, field)(HIGH_XYZ), atol=1e-12)
    scattered = np.vstack([[[0, 0, 10], [10, 0, 10], [0, 10, 10], [10, 10, 10]], rng.random((30, 3)) * 10])
    W = interpolation_matrix(scattered, HIGH_XYZ)  # Delaunay triangles
    f = rng.standard_normal((len(scattered), 3))
    np.testing.assert_allclose(W @ f, top_field_interpolator(scattered, f)(HIGH_XYZ), atol=1e-12)
    np.testing.assert_allclose(W.sum(axis=1), 1.0)
    with pytest.raises(ValueError, match="outside the triangulation"):
        interpolation_matrix(scattered[4:], HIGH_XYZ)


def test_discrepancy_is_learned(mf, low):
    """At held-out points the multi-fidelity prediction matches the high model closely; the low
    surrogate (carried to the high nodes) misses it by the discrepancy."""
    theta = held_out()
    force, disp = response(theta, HIGH_XYZ, True)
    p = mf.predict(theta)
    assert p.force.shape == force.shape and p.displacement.shape == disp.shape
    assert np.array_equal(p.top_xyz, HIGH_XYZ)
    low_p = low.predict(theta)
    low_disp = np.moveaxis(
        top_field_interpolator(LOW_XYZ, np.moveaxis(low_p.displacement, 2, 0))(HIGH_XYZ), 0, 2
    )
    mf_f, low_f = np.abs(p.force / force - 1).max(), np.abs(low_p.force / force - 1).max()
    mf_u, low_u = np.abs(p.displacement - disp).max(), np.abs(low_disp - disp).max()
    assert mf_f < 1e-3 and low_f > 0.05  # measured 2e-5 and 0.085
    assert mf_u < 2e-3 and low_u > 0.05  # mm, of |u| up to 2 mm; measured 4e-4 and 0.125
    kfold = mf.meta["discrepancy_kfold"]
    assert kfold["folds"] == 4 and kfold["points"] == 20 and 0 < kfold["force_max_pct"] < 0.1
    assert 0 < kfold["field_rms_mm"] < kfold["field_max_mm"] < 0.01
    truncation = mf.meta["discrepancy"]["truncation"]  # what the PCA leaves of the training data
    assert truncation["force_max_pct"] < 0.01 and truncation["field_max_mm"] < 0.01


def test_jacobians_are_the_derivatives(mf):
    """Against central differences (steps of 1e-3 theta: the GPs of these very smooth functions
    are ill-conditioned, and smaller steps see their rounding)."""
    theta = np.array([[5.0, 180.0], [13.0, 420.0]])
    p = mf.predict(theta, jacobian=True)
    assert p.force_jacobian.shape == (2, 4, 2) and p.displacement_jacobian.shape == (2, 4, 81, 3, 2)
    for j in range(2):
        h = 1e-3 * theta[:, j]
        up, down = theta.copy(), theta.copy()
        up[:, j] += h
        down[:, j] -= h
        a, b = mf.predict(up), mf.predict(down)
        fd_f = (a.force - b.force) / (2 * h[:, None])
        fd_u = (a.displacement - b.displacement) / (2 * h[:, None, None, None])
        np.testing.assert_allclose(p.force_jacobian[..., j], fd_f, rtol=0, atol=2e-5 * np.abs(fd_f).max())
        np.testing.assert_allclose(
            p.displacement_jacobian[..., j], fd_u, rtol=0, atol=2e-5 * np.abs(fd_u).max()
        )


def test_reduced_basis_gives_the_prediction_and_the_objective(mf):
    theta = held_out(5)
    p, basis = mf.predict(theta), mf.reduced_basis()
    zf, zu = basis.coordinates(theta)
    np.testing.assert_allclose(np.exp(zf @ basis.force_basis + basis.force_mean), p.force, rtol=1e-12)
    field = (zu @ basis.field_basis + basis.field_mean).reshape(p.displacement.shape)
    np.testing.assert_allclose(field, p.displacement, atol=1e-12)
    objective = Objective.from_prediction(mf.predict([[9.0, 250.0]]), radius=RADIUS)
    reduced = objective_function(objective, mf, ETA)
    assert isinstance(reduced, ReducedObjective)
    np.testing.assert_allclose(
        reduced.value(theta), FieldObjective(objective, mf, ETA).value(theta), rtol=1e-9
    )


def test_save_load_round_trip(mf, tmp_path):
    path = save_surrogate(mf, tmp_path / "surrogate-mf.safetensors")
    again = load_surrogate(path)
    assert isinstance(again, MultiFidelitySurrogate) and isinstance(again, FieldSurrogate)
    theta = held_out(4)
    a, b = mf.predict(theta, jacobian=True), again.predict(theta, jacobian=True)
    for name in ("force", "displacement", "force_jacobian", "displacement_jacobian"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(
        mf.discrepancy_covariance_factor(theta[0]), again.discrepancy_covariance_factor(theta[0])
    )
    # both campaigns named: the high one is the model a fit's FE stage runs
    assert again.meta["campaign"]["name"] == "high-campaign"
    assert again.meta["campaign"]["model"]["mesh"]["preset"] == "default"
    assert again.meta["low_fidelity"]["campaign"]["name"] == "low-campaign"
    assert again.low.meta["campaign"]["name"] == "low-campaign"
    assert again.meta["kind"] == again.kind == "mf" and again.hyperparameters() == mf.hyperparameters()
    assert len(again.discrepancy.gps) == mf.meta["force_components"] + mf.meta["field_components"]
    np.testing.assert_array_equal(again.inside_box(theta), True)


def test_discrepancy_std_vanishes_at_the_data_and_grows_away(mf, high_data):
    L = mf.discrepancy_covariance_factor(high_data.theta[0])
    d = mf.discrepancy
    assert L.shape == (d.k_force + d.field_pca.n_components_, 4 + 4 * 81 * 3)
    sd_f, sd_u = mf.discrepancy_std(high_data.theta[0])
    np.testing.assert_allclose(np.sqrt(np.sum(L**2, axis=0)), np.concatenate([sd_f, sd_u.ravel()]))

    def largest(theta):
        f, u = mf.discrepancy_std(theta)
        return f.max(), u.max()

    at_data = np.array([largest(t) for t in high_data.theta]).max(axis=0)
    # between the data (the held-out points), and beyond the box (the GP extrapolates)
    between = np.array([largest(t) for t in held_out(10)]).max(axis=0)
    beyond = np.array(largest(HIGH_THETA.max(axis=0) * [1.5, 1.0]))
    assert np.all(at_data < 0.05 * between) and np.all(between < beyond)
    assert np.all(at_data < 1e-5)  # log force; mm (measured 2e-7, 3e-7; between 3e-5, 5e-5)


def test_fit_recovers_what_the_low_level_misses(mf, low):
    """Noise-free data of the high model at a truth: the fit on the multi-fidelity surrogate lands
    on the truth; the fit on the low surrogate (with the same data at its own nodes) is biased."""
    truth = np.array([8.0, 260.0])
    force, disp = response(truth[None], HIGH_XYZ, True)
    data = Prediction(force, disp, DEPTH, HIGH_XYZ)
    fit = fit_parameters(Objective.from_prediction(data, radius=RADIUS), mf, ETA, theta0=(6.0, 300.0))
    force, disp = response(truth[None], LOW_XYZ, True)  # the same high model at the low nodes
    data = Prediction(force, disp, DEPTH, LOW_XYZ)
    fit_low = fit_parameters(Objective.from_prediction(data, radius=RADIUS), low, ETA, theta0=(6.0, 300.0))
    assert np.abs(fit.theta / truth - 1).max() < 1e-3  # measured 2e-5
    assert np.abs(fit_low.theta / truth - 1).max() > 0.05  # measured c1 +11.5 %, c5 -4.6 %


def test_a_file_keeps_the_low_levels_errors_and_moves_them_to_the_high_nodes(mf, tmp_path):
    """The low surrogate's held-out errors are the multi-fidelity surrogate's own, carried by W
    (eq. 1b) to the high nodes; the file keeps them on the low nodes, in half precision."""
    steps, nodes = len(DEPTH), len(LOW_XYZ)
    errors = 1e-3 * np.random.default_rng(3).standard_normal((6, steps + steps * nodes * 3))
    low_error = EmulationError.from_errors(box_points(6, seed=5), errors, steps=steps, source="test")
    model = load_surrogate(save_surrogate(mf, tmp_path / "copy.safetensors"))
    model.restore_emulation_error(low_error)
    moved = model.emulation_error.errors()
    field = errors[:, steps:].reshape(6, steps, nodes, 3)
    expected = np.hstack(
        [
            errors[:, :steps],
            (model.interpolation @ field.transpose(2, 0, 1, 3).reshape(nodes, -1))
            .reshape(len(HIGH_XYZ), 6, steps, 3)
            .transpose(1, 2, 0, 3)
            .reshape(6, -1),
        ]
    )
    np.testing.assert_allclose(moved, expected, atol=1e-8)
    again = load_surrogate(save_surrogate(model, tmp_path / "with-errors.safetensors"))
    assert again.low_emulation_error.directions.shape[1] == steps + steps * nodes * 3 < moved.shape[1]
    np.testing.assert_allclose(again.emulation_error.errors(), moved, atol=2e-3 * np.abs(moved).max())
    assert not np.array_equal(again.emulation_error.errors(), moved)  # half precision in the file
    # its discrepancy learned anew on a high campaign (a shipped file as --low): the low level's
    # errors come with its low level, so the new surrogate carries them too
    anew = train_multi_fidelity(tmp_path / "with-errors.safetensors", mf_campaign(), folds=0)
    np.testing.assert_allclose(anew.emulation_error.errors(), again.emulation_error.errors(), atol=1e-6)


def as_campaign(data: TrainingData) -> CampaignData:
    """Training data as a campaign's data (what train_multi_fidelity reads)."""
    return CampaignData(
        data.theta,
        data.force,
        displacement=data.displacement,
        depth=data.depth,
        top_xyz=data.top_xyz,
        top_node_ids=np.arange(len(data.top_xyz)),
        parameters=data.parameters,
        points=np.arange(data.n),
        spec=data.source,
    )


def mf_campaign() -> CampaignData:
    """The high campaign as a campaign's data."""
    return as_campaign(synthetic(HIGH_THETA, True, "high-campaign"))


def test_training_function_and_refusals(low, high_data, tmp_path):
    low_file = save_surrogate(low, tmp_path / "low.safetensors")
    campaign = mf_campaign()
    model = train_multi_fidelity(low_file, campaign, folds=0)
    assert model.meta["validation"]["training"]["force_max_pct"] < 0.01
    assert "discrepancy_kfold" not in model.meta and model.meta["campaign"]["name"] == "high-campaign"
    # a multi-fidelity surrogate given as the low level: its low level, the discrepancy learned anew
    # (a shipped surrogate on a wider high campaign), the same model as from the low level itself
    again = train_multi_fidelity(save_surrogate(model, tmp_path / "mf.safetensors"), campaign, folds=0)
    assert type(again.low) is type(low) and not isinstance(again.low, MultiFidelitySurrogate)
    theta = high_data.theta[:2] * 1.01
    np.testing.assert_allclose(again.predict(theta).force, model.predict(theta).force, rtol=1e-9)
    with pytest.raises(ValueError, match=r"'mf'.*train_multi_fidelity"):
        make_surrogate("mf")

    def changed(**changes) -> TrainingData:
        d = TrainingData(**{**vars(high_data), "source": {**high_data.source}})
        for key, value in changes.items():
            if key == "model":
                d.source["model"] = {**MODEL, **value}
            else:
                setattr(d, key, value)
        return d

    with pytest.raises(ValueError, match=r"indenter: \{'radius': 2.0\} \(low\) vs \{'radius': 3.0\}"):
        MultiFidelitySurrogate(low).fit(changed(model={"indenter": {"radius": 3.0}}))
    with pytest.raises(ValueError, match=r"depths: 4 steps to 2 mm \(low\) vs 4 steps to 4 mm"):
        MultiFidelitySurrogate(low).fit(changed(depth=2 * DEPTH))
    with pytest.raises(ValueError, match="outside the low-fidelity surrogate's training box"):
        MultiFidelitySurrogate(low).fit(changed(theta=high_data.theta * [1.0, 1.3]))


MU_LO, MU_HI = 0.2, 3.0


def slip_response(theta: np.ndarray, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The low model with friction (n, 3): slip lowers the force and the in-plane field by a share
    that fades with mu (zero at the stick)."""
    force, disp = response(theta[:, :2], xyz, False)
    slip = np.exp(-theta[:, 2])[:, None]  # (n, 1)
    disp = disp.copy()
    disp[..., :2] *= (1.0 - 0.3 * slip)[:, :, None, None]
    return force * (1.0 - 0.1 * slip), disp


@pytest.fixture(scope="module")
def slip_low(low):
    """A stick-plus-slip low level over (c1, c5, mu): the `low` GP and a small MLP of the slip."""
    rng = np.random.default_rng(3)
    theta = np.column_stack([box_points(60, seed=4), np.exp(rng.uniform(np.log(MU_LO), np.log(MU_HI), 60))])
    force, disp = slip_response(theta, LOW_XYZ)
    model = {**MODEL, "mesh": {"preset": "coarse"}}
    data = TrainingData(
        theta, force, disp, DEPTH, LOW_XYZ, ("c1", "c5", "mu"), {"name": "mu-campaign", "model": model}
    )
    return SlipSurrogate(low, width=16, hidden_layers=2, adam_epochs=300, lbfgs_steps=20).fit(data)


@pytest.fixture(scope="module")
def mf3(slip_low, high_data) -> MultiFidelitySurrogate:
    """Over (c1, c5, mu): the stick-plus-slip low level and a discrepancy learned at the stick."""
    return MultiFidelitySurrogate(slip_low, restarts=1, folds=0).fit(high_data, seed=0)


def test_a_discrepancy_learned_at_the_stick_carries_mu(mf3, slip_low, low, high_data, tmp_path):
    """Module eq. 2: over a stick-plus-slip low level, a perfect-stick high campaign over (c1, c5)
    gives a surrogate over (c1, c5, mu) whose discrepancy is the stick's at every mu; its stick
    level is the multi-fidelity surrogate of the low level's stick surrogate."""
    assert mf3.parameters == ("c1", "c5", "mu") and mf3.learned_at_stick
    assert mf3.meta["discrepancy_parameters"] == ["c1", "c5"]
    theta = np.array([[6.0, 200.0, 0.3], [12.0, 400.0, 2.0]])
    pred, low_pred = mf3.predict(theta, jacobian=True), slip_low.predict(theta)
    delta = mf3.discrepancy.predict(theta[:, :2])
    np.testing.assert_allclose(pred.force, low_pred.force * delta.force, rtol=1e-12)  # eq. 2a
    W = interpolation_matrix(LOW_XYZ, HIGH_XYZ).toarray()
    carried = np.einsum("ij,nsjk->nsik", W, low_pred.displacement)
    np.testing.assert_allclose(pred.displacement, carried + delta.displacement, atol=1e-12)  # eq. 2b
    # Jacobian against central differences; d/dmu is the low level's alone, carried to the high nodes
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-4 * theta[0, k]
        up, down = mf3.predict(theta[:1] + e), mf3.predict(theta[:1] - e)
        fd_f = (up.force - down.force)[0] / (2 * e[k])
        fd_u = (up.displacement - down.displacement)[0] / (2 * e[k])
        np.testing.assert_allclose(pred.force_jacobian[0, :, k], fd_f, rtol=0, atol=1e-4 * np.abs(fd_f).max())
        np.testing.assert_allclose(
            pred.displacement_jacobian[0, ..., k], fd_u, rtol=0, atol=1e-4 * np.abs(fd_u).max()
        )
    # learned against the low level at its mu range end, where it gives the stick campaign back,
    # and the stick level is itself there
    end = float(slip_low.scaler.hi[2])
    assert mf3.stick_mu == end and mf3.hyperparameters()["stick_mu"] == end
    at_end = np.column_stack([high_data.theta[:4], np.full(4, end)])
    np.testing.assert_allclose(mf3.predict(at_end).force, high_data.force[:4], rtol=1e-4)
    np.testing.assert_array_equal(
        mf3.stick_level().predict(high_data.theta[:4]).force, mf3.predict(at_end).force
    )
    # learned against the stick surrogate (files made before stick_mu): the stick level is the
    # 2-parameter multi-fidelity surrogate of the stick surrogate, exactly
    before = MultiFidelitySurrogate(slip_low, restarts=1, folds=0, stick_mu=None).fit(high_data, seed=0)
    direct = MultiFidelitySurrogate(low, restarts=1, folds=0).fit(high_data, seed=0)
    np.testing.assert_allclose(
        before.stick_level().predict(theta[:, :2]).force, direct.predict(theta[:, :2]).force, rtol=1e-12
    )
    missed = np.abs(before.predict(at_end).force / high_data.force[:4] - 1).max()
    assert missed > 1e-3  # the low level's slip at its end is not its stick (measured 0.0069)
    # the box: (c1, c5) the high campaign's, mu the low level's; saved and loaded bit for bit
    np.testing.assert_allclose(mf3.scaler.lo, [*HIGH_THETA.min(axis=0), slip_low.scaler.lo[2]])
    again = load_surrogate(save_surrogate(mf3, tmp_path / "mf3.safetensors"))
    np.testing.assert_array_equal(again.predict(theta).force, pred.force)
    np.testing.assert_array_equal(again.scaler.hi, mf3.scaler.hi)
    assert again.learned_at_stick and again.discrepancy_covariance_factor(theta[0]).shape[1] == 4 + 4 * 81 * 3


def test_stick_runs_are_compared_with_the_stick_level_of_a_surrogate_with_mu(mf3, high_data, slip_low):
    # the campaign the discrepancy was learned on (over (c1, c5)) against the surrogate over (c1, c5, mu)
    errors = prediction_errors(mf3, high_data)
    assert errors == prediction_errors(mf3.stick_level(), high_data)
    assert errors["force_rms_pct"] < 0.1  # the GP interpolates its own campaign
    with pytest.raises(ValueError, match=r"only with a multi-fidelity surrogate's stick level"):
        prediction_errors(slip_low.stick, TrainingData(**{**vars(high_data), "parameters": ("c1", "x")}))


def test_a_high_campaign_with_mu_learns_the_discrepancy_over_mu(slip_low):
    """Module eq. 1 over (c1, c5, mu): a high campaign with the mu axis (where the finer mesh's
    change depends on friction) gives a discrepancy over all three parameters."""
    rng = np.random.default_rng(5)
    theta = np.column_stack([HIGH_THETA, np.exp(rng.uniform(np.log(0.3), np.log(2.5), len(HIGH_THETA)))])
    force, disp = slip_response(theta, HIGH_XYZ)
    high_force, _ = response(theta[:, :2], HIGH_XYZ, True)
    low_force, _ = response(theta[:, :2], HIGH_XYZ, False)
    force = force * high_force / low_force * (1.0 + 0.02 * np.exp(-theta[:, 2]))[:, None]  # mu-dependent
    model = {**MODEL, "mesh": {"preset": "default"}}
    data = TrainingData(
        theta, force, disp, DEPTH, HIGH_XYZ, ("c1", "c5", "mu"), {"name": "hi-mu", "model": model}
    )
    mf3 = MultiFidelitySurrogate(slip_low, restarts=1, folds=0).fit(data, seed=0)
    assert not mf3.learned_at_stick and mf3.discrepancy.parameters == ("c1", "c5", "mu")
    np.testing.assert_allclose(mf3.predict(theta[:3]).force, force[:3], rtol=1e-4)  # the GP interpolates


def _friction_high_data(seed: int = 5) -> TrainingData:
    """The high model with friction (a mu axis), its discrepancy changing with mu."""
    rng = np.random.default_rng(seed)
    theta = np.column_stack([HIGH_THETA, np.exp(rng.uniform(np.log(0.3), np.log(2.5), len(HIGH_THETA)))])
    force, disp = slip_response(theta, HIGH_XYZ)
    high_force, _ = response(theta[:, :2], HIGH_XYZ, True)
    low_force, _ = response(theta[:, :2], HIGH_XYZ, False)
    force = force * high_force / low_force * (1.0 + 0.02 * np.exp(-theta[:, 2]))[:, None]
    model = {**MODEL, "mesh": {"preset": "default"}}
    return TrainingData(
        theta, force, disp, DEPTH, HIGH_XYZ, ("c1", "c5", "mu"), {"name": "hi-mu", "model": model}
    )


def test_a_stick_campaign_and_one_with_mu_merged_learn_one_discrepancy_over_mu(slip_low, high_data):
    """The stick's points taken at mu = the low level's range end, beside the friction campaign's:
    one GP over (c1, c5, mu) that gives both campaigns back (it interpolates) and is not the
    stick's applied at every mu."""
    friction, end = _friction_high_data(), float(slip_low.scaler.hi[2])
    merged = merged_training_data([high_data, friction], stick_mu=end)
    assert merged.parameters == ("c1", "c5", "mu") and merged.n == high_data.n + friction.n
    np.testing.assert_array_equal(merged.theta[: high_data.n, 2], end)
    assert merged.source["name"] == "high-campaign+hi-mu" and merged.source["stick_mu"] == end
    mf3 = MultiFidelitySurrogate(slip_low, restarts=1, folds=0).fit(merged, seed=0)
    assert not mf3.learned_at_stick and mf3.discrepancy.parameters == ("c1", "c5", "mu")
    np.testing.assert_allclose(mf3.predict(merged.theta[:3]).force, high_data.force[:3], rtol=1e-4)
    np.testing.assert_allclose(mf3.predict(friction.theta[:3]).force, friction.force[:3], rtol=1e-4)
    # its stick level is itself where the stick's points were taken: the stick campaign given back
    assert prediction_errors(mf3, high_data)["force_max_pct"] < 0.01
    at_stick = MultiFidelitySurrogate(slip_low, restarts=1, folds=0).fit(high_data, seed=0)
    stick_error = np.abs(at_stick.predict(friction.theta).force / friction.force - 1).max()
    assert stick_error > 0.005  # the stick's discrepancy misses the friction campaign (measured 0.014)


def test_merged_stick_points_are_judged_by_the_stick_surrogates_box(slip_low):
    """The shipped slip's change is learned a little inside the stick's box (c1 from 1.016 kPa), so
    the stick campaign's corner at c1 = 1 kPa, taken at the mu range end, was refused ("outside
    the low-fidelity surrogate's training box") although the stick surrogate covers it; a point
    outside the stick's box is still refused, and so is a friction point outside the slip's."""
    end = float(slip_low.scaler.hi[2])
    corner = np.array([LO, [LO[0], HI[1]]])  # on the stick's box, outside the slip's
    assert not slip_low.inside_box(np.column_stack([corner, [end, end]])).any()
    assert slip_low.stick.inside_box(corner).all()
    stick = synthetic(np.vstack([HIGH_THETA, corner]), True, "high-campaign")
    merged = merged_training_data([stick, _friction_high_data()], stick_mu=end)
    mf3 = MultiFidelitySurrogate(slip_low, restarts=1, folds=0).fit(merged, seed=0)
    np.testing.assert_allclose(mf3.predict(merged.theta[20:22]).force, stick.force[20:22], rtol=1e-4)
    beyond = synthetic(np.vstack([HIGH_THETA, 0.9 * LO]), True, "high-campaign")
    with pytest.raises(ValueError, match=r"1 high-fidelity points .* outside the low-fidelity surrogate's"):
        MultiFidelitySurrogate(slip_low, restarts=1, folds=0).fit(
            merged_training_data([beyond, _friction_high_data()], stick_mu=end), seed=0
        )
    friction = _friction_high_data()
    friction.theta[0, :2] = LO  # with mu inside its range: the slip's box holds
    with pytest.raises(ValueError, match=r"1 high-fidelity points .* outside the low-fidelity surrogate's"):
        MultiFidelitySurrogate(slip_low, restarts=1, folds=0).fit(
            merged_training_data([stick, friction], stick_mu=end), seed=0
        )


def test_the_k_fold_of_a_merged_campaign_keeps_friction_points_in_every_folds_rest(slip_low, high_data):
    """With two friction points beside twenty stick points, a plain 5-fold split can hold both out
    together; the fold's rest then has mu at one value and its model over mu cannot be fitted ("cannot
    be scaled", session 35 on the shipped campaigns). The folds are stratified by stick / friction."""
    end = float(slip_low.scaler.hi[2])
    merged = merged_training_data([high_data, _friction_high_data().subset(np.arange(2))], stick_mu=end)
    friction = np.flatnonzero(merged.theta[:, 2] != end)
    seed = next(  # a seed whose plain KFold holds both friction points out in one fold
        k
        for k in range(100)
        if any(
            set(friction) <= set(test)
            for _, test in KFold(5, shuffle=True, random_state=k).split(merged.theta)
        )
    )
    mf3 = MultiFidelitySurrogate(slip_low, restarts=1, folds=5).fit(merged, seed=seed)
    kfold = mf3.meta["discrepancy_kfold"]
    assert kfold["folds"] == 5 and kfold["points"] == 22 and np.isfinite(kfold["force_max_pct"])
    one = merged_training_data([high_data, _friction_high_data().subset(np.arange(1))], stick_mu=end)
    with pytest.raises(ValueError, match="at least two stick points and two with mu, got 20 and 1"):
        MultiFidelitySurrogate(slip_low, restarts=1, folds=5).fit(one, seed=0)


def test_the_training_function_merges_campaigns_at_the_low_levels_mu_end(slip_low, tmp_path):
    low_file = save_surrogate(slip_low, tmp_path / "slip.safetensors")
    model = train_multi_fidelity(low_file, [mf_campaign(), as_campaign(_friction_high_data())], folds=0)
    end = float(slip_low.scaler.hi[2])
    assert (
        model.meta["campaign"]["stick_mu"] == end and model.meta["campaign"]["name"] == "high-campaign+hi-mu"
    )
    assert model.meta["training_points"] == 2 * len(HIGH_THETA) and not model.learned_at_stick
    stick = mf_campaign()
    at_end = np.column_stack([stick.theta[:2], [end, end]])
    np.testing.assert_allclose(model.predict(at_end).force, stick.force[:2], rtol=1e-4)


def test_campaigns_that_cannot_be_merged_are_named(high_data):
    friction = _friction_high_data()
    with pytest.raises(ValueError, match=r"high-campaign: a stick campaign over \(c1, c5\) needs stick_mu"):
        merged_training_data([high_data, friction])
    other_mesh = TrainingData(**{**vars(friction), "top_xyz": friction.top_xyz * 1.01})
    with pytest.raises(ValueError, match="top nodes differ from the first campaign's"):
        merged_training_data([high_data, other_mesh], stick_mu=MU_HI)
    held = TrainingData(**{**vars(high_data), "source": {**high_data.source}})
    held.source["model"] = {**held.source["model"], "contact": {"friction": 0.3}}
    with pytest.raises(ValueError, match=r"its mu is held at 0.3"):
        merged_training_data([held, friction], stick_mu=MU_HI)
    wider = TrainingData(**{**vars(friction), "source": {**friction.source}})
    wider.source["model"] = {**wider.source["model"], "indenter": {"radius": 3.0}}
    with pytest.raises(ValueError, match=r"model indenter \{'radius': 3.0\} differs"):
        merged_training_data([high_data, wider], stick_mu=MU_HI)


def test_a_discrepancy_at_the_stick_is_refused_where_it_cannot_be(slip_low, low, high_data):
    with_mu = TrainingData(**{**vars(high_data), "source": {**high_data.source}})
    with_mu.source["model"] = {**with_mu.source["model"], "contact": {"friction": 0.3}}
    with pytest.raises(ValueError, match=r"with mu = 0.3 cannot be learned at the stick"):
        MultiFidelitySurrogate(slip_low, folds=0).fit(with_mu)
    other = TrainingData(**{**vars(high_data), "parameters": ("c1", "c5", "x")})
    with pytest.raises(ValueError, match=r"needs a stick-plus-slip low surrogate"):
        MultiFidelitySurrogate(low, folds=0).fit(other)
    with pytest.raises(ValueError, match="learned over the low level's parameters, not at the stick"):
        MultiFidelitySurrogate(low, restarts=1, folds=0).fit(high_data).stick_level()


def test_a_fit_with_mu_carries_the_discrepancy_into_its_bounds(mf3, tmp_path):
    """A fit on the surrogate over (c1, c5, mu) marginalises mu and adds the discrepancy's
    uncertainty to the bounds of (c1, c5), mu held (its own bound is its profile's)."""
    truth = np.array([8.0, 260.0, 0.5])
    exp = write_synthetic_experiment(
        mf3, truth, tmp_path / "e", radius=RADIUS, step_size=0.5, u_noise_mm=0.002, f_noise=0.002, seed=1
    )
    d = fit_experiment(exp, mf3, refine=False).to_dict()
    error = d["model_error"]
    assert len(error["discrepancy_pct"]) == 2 and min(error["discrepancy_pct"]) > 0  # measured 0.03, 0.06 %
    assert "Coulomb friction, mu marginalised" in error["includes"]
    assert d["friction"]["treatment"] == "marginalise"
    # the discrepancy was learned at the stick: mu's error at the high fidelity is not measured, so
    # mu is not claimed (issue 57: mu 0.5 made on contact-L3 was fitted 1.12, 95 % in (0.61, 1.64))
    assert mf3.learned_at_stick and "learned at the stick" in d["friction"]["mu_model_unmeasured"]
    # and (c1, c5)'s bounds say they leave out how that discrepancy changes with friction
    assert d["bounds_include"].endswith(f"; not {FRICTION_DISCREPANCY_UNMEASURED}")
    held = fit_experiment(exp, mf3, refine=False, friction="0.5").to_dict()  # mu known: the same holds
    assert held["friction"].get("mu_model_unmeasured") is None  # mu not fitted: nothing said of it
    assert held["bounds_include"].endswith(f"; not {FRICTION_DISCREPANCY_UNMEASURED}")
    assert d["friction"]["mu_identified"] is False
    assert d["friction"]["mu_interval"] == pytest.approx(d["friction"]["mu_range"])


def test_a_posterior_with_mu_unmeasured_at_the_high_fidelity_has_the_priors_mu(mf3, tmp_path):
    """The posterior says what the fit says: mu's samples are its log-uniform prior's (their log
    uniform over the range), (c1, c5) as sampled."""
    from scipy import stats

    from indentation_studio.inference.posterior.workflow import sample_posterior_for

    exp = write_synthetic_experiment(
        mf3,
        np.array([8.0, 260.0, 0.5]),
        tmp_path / "e",
        radius=RADIUS,
        step_size=0.5,
        u_noise_mm=0.002,
        f_noise=0.002,
        seed=1,
    )
    post = sample_posterior_for(exp, mf3, walkers=16, steps=300, seed=3)
    assert post.mu_identified is False and post.not_identified == ("mu",)
    lo, hi = post.mu_range
    u = np.log(post.posterior.samples[:, 2] / lo) / np.log(hi / lo)
    assert stats.kstest(u, "uniform").pvalue > 1e-3
    assert abs(np.median(post.posterior.samples[:, 0]) / 8.0 - 1) < 0.05


def test_the_discrepancys_held_out_errors_are_kept_and_read_back(mf, tmp_path):
    """The k-fold errors of the discrepancy are kept as error vectors (issue 57): one per high point,
    as large as meta's k-fold summary says, and a file keeps them."""
    kept = mf.discrepancy_error
    assert kept is not None and kept.points == len(HIGH_THETA) == 20
    assert kept.width(len(HIGH_XYZ)) == kept.directions.shape[1]
    # meta's field RMS is over the same error vectors (the SVD keeps 99.99 % of their squares)
    assert kept.describe()["field_rms_mm"] == pytest.approx(
        mf.meta["discrepancy_kfold"]["field_rms_mm"], rel=1e-3
    )
    again = load_surrogate(save_surrogate(mf, tmp_path / "mf-errors.safetensors"))
    scale = np.abs(kept.errors()).max()
    np.testing.assert_allclose(again.discrepancy_error.errors(), kept.errors(), atol=2e-3 * scale)
    assert again.meta["discrepancy_error"]["points"] == 20


def test_a_refit_with_a_held_out_error_lands_where_that_error_points(mf):
    """Data of the surrogate at theta_b; an error vector that is the surrogate's change from theta_a
    to theta_b: the fit made again with it lands on theta_a; with a zero error on theta_b."""
    theta_a, theta_b = np.array([6.0, 220.0]), np.array([9.0, 300.0])
    a, b = mf.predict(theta_a[None]), mf.predict(theta_b[None])
    objective = Objective.from_prediction(b, radius=RADIUS)
    error = np.hstack(
        [np.log(b.force[0]) - np.log(a.force[0]), (b.displacement[0] - a.displacement[0]).ravel()]
    )
    errors = EmulationError.from_errors(
        np.stack([theta_a, theta_b]), np.stack([error, 0.0 * error]), steps=len(DEPTH), source="two"
    )
    refits = held_out_refits(objective, ETA, mf, theta_b, (mf.scaler.lo, mf.scaler.hi), errors)
    np.testing.assert_allclose(refits.refits[0], theta_a, rtol=1e-3)
    np.testing.assert_allclose(refits.refits[1], theta_b, rtol=1e-6)
    moved = np.log(theta_a / theta_b)
    assert refits.half_width_pct(1) == pytest.approx(
        100 * np.expm1(abs(moved[1])), rel=1e-2
    )  # 2 refits: the largest
    assert refits.reaches(0) == {"lower": False, "upper": False}
    ends = HeldOutRefits(theta_b, np.array([[2.01, 300.0], [9.0, 300.0]]), (LO, HI), "two")
    assert ends.reaches(0) == {"lower": True, "upper": False}
