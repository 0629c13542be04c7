"""F of eq. 5 in a surrogate's PCA space (design/reduced_objective.py): equal to the objective on
the rebuilt fields, with the node masks and weights of a measured experiment, for the GP and the
MLP; the posterior sampled through it is the same chain; the FE predictor keeps the field path."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from indentation_studio.campaign.designs import design_from_option
from indentation_studio.campaign.loader import load_campaign
from indentation_studio.campaign.runner import run_campaign
from indentation_studio.campaign.spec import CampaignSpec
from indentation_studio.campaign.store import CampaignStore
from indentation_studio.design.objective import Objective
from indentation_studio.design.reduced_objective import FieldObjective, ReducedObjective, objective_function
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.predictor import ReducedPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.experiment.data import load_experiment
from indentation_studio.inference.experiment.processing import experiment_objective
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.posterior.sampling import sample_posterior
from indentation_studio.surrogate.base import TrainingData
from indentation_studio.surrogate.training import make_surrogate

MODEL = ModelSpec(protocol=Protocol(step_size=0.5, steps=4), mesh=MeshChoice("coarse"))
TRUE = np.array([11.0, 260.0])
WEIGHTS = [(0.45, 0.35, 0.2, 0.0), (0.25, 0.25, 0.25, 0.25), (1.0, 0.0, 0.0, 0.0), (0.0, 0.3, 0.0, 0.7)]


@pytest.fixture(scope="module", autouse=True)
def one_torch_thread():
    """Batches of a few walkers: torch's second thread only adds contention (see surrogate/mlp.py)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


@pytest.fixture(scope="module")
def training(tmp_path_factory) -> TrainingData:
    root = tmp_path_factory.mktemp("runs")
    spec = CampaignSpec("train", design_from_option("c1=4:16:4,c5=150:500:4"), MODEL)
    assert run_campaign(CampaignStore.create_or_open(root, spec), jobs=1)["failed"] == 0
    return TrainingData.from_campaign(load_campaign("train", root))


@pytest.fixture(scope="module", params=["gp", "mlp"])
def surrogate(request, training):
    # exactness does not need accuracy: short trainings (an ensemble of 2 still tests the stacking)
    extra = (
        {"adam_epochs": 150, "lbfgs_steps": 20, "ensemble": 2} if request.param == "mlp" else {"restarts": 0}
    )
    return make_surrogate(request.param, **extra).fit(training, seed=0)


@pytest.fixture(scope="module")
def measured(surrogate, tmp_path_factory):
    """A synthetic experiment (2 % noise, a shifted and rotated DIC frame, the indenter's shadow)
    processed as a real one: static forces, registration, DIC to nodes, nodes without data off."""
    folder = write_synthetic_experiment(
        surrogate, TRUE, tmp_path_factory.mktemp("exp") / "e", radius=4.77, step_size=0.5, seed=5
    )
    objective, _ = experiment_objective(load_experiment(folder), surrogate.top_xyz)
    return objective


def _random_thetas(surrogate, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo, hi = surrogate.scaler.lo, surrogate.scaler.hi
    return lo + (hi - lo) * rng.random((n, len(lo)))


def test_prepared_regressor_equals_the_library_one(surrogate):
    """The GP means without scikit-learn's per-call overhead and the MLP ensemble in numpy give the
    library's numbers."""
    X = surrogate.scaler(_random_thetas(surrogate, 16, seed=3))
    fast = surrogate._score_function()(X)
    if surrogate.kind == "gp":
        library = np.hstack([gp.predict(X).reshape(len(X), -1) for gp in surrogate.gps])
    else:
        with torch.no_grad():
            library = np.mean([net(torch.from_numpy(X)).numpy() for net in surrogate.nets], axis=0)
    assert fast.shape == library.shape == (16, surrogate.score_mean.size)
    np.testing.assert_allclose(fast, library, rtol=0, atol=1e-12 * np.abs(library).max())


def test_reduced_F_equals_F_of_the_rebuilt_fields(surrogate, measured):
    assert isinstance(surrogate, ReducedPredictor)
    n_nodes = len(surrogate.top_xyz)
    # the experiment leaves nodes without data: the mask is not the default one
    assert 4 <= measured.measured.sum() < n_nodes
    thetas = np.vstack([_random_thetas(surrogate, 40, seed=1), TRUE])
    prediction = surrogate.predict(thetas)
    for eta in WEIGHTS:
        reduced = ReducedObjective(measured, surrogate.reduced_basis(), eta)
        F_full = measured.value(prediction, eta)
        F_reduced = reduced.value(thetas)
        assert F_full.shape == F_reduced.shape == (41,)
        np.testing.assert_allclose(F_reduced, F_full, rtol=1e-10, atol=0)
        # F is far from constant over the box, so the comparison is not trivially met
        assert F_full.max() > 10 * F_full.min() > 0


def test_reduced_F_with_the_authors_reading_and_one_step(surrogate):
    """The other reading (one step, force over max |f|, the 1.2 R to 5.5 R ring, unnormalised
    weights) and a baseline target from the surrogate itself: F vanishes at theta*."""
    target = surrogate.predict(TRUE[None])
    thetas = np.vstack([_random_thetas(surrogate, 20, seed=2), TRUE])
    prediction = surrogate.predict(thetas)
    for kwargs in ({"reading": "authors"}, {"reading": "paper", "step": 2}):
        objective = Objective.from_prediction(target, radius=4.77, **kwargs)
        for eta in WEIGHTS:
            F_full = objective.value(prediction, eta)
            F_reduced = ReducedObjective(objective, surrogate.reduced_basis(), eta).value(thetas)
            np.testing.assert_allclose(F_reduced[:-1], F_full[:-1], rtol=1e-10, atol=0)
            # at theta* both are rounding noise next to F elsewhere
            assert abs(F_reduced[-1]) < 1e-12 * F_full[:-1].max()
            assert abs(F_full[-1]) < 1e-12 * F_full[:-1].max()


def test_reduced_F_with_excluded_steps(surrogate, measured):
    """Steps left out of eq. 4a and 4b (experiment.json's excluded_steps) may hold NaN targets."""
    force, field = measured.force.copy(), measured.displacement.copy()
    force[1], field[1] = np.nan, np.nan
    objective = Objective(
        force, field, measured.top_xyz, radius=4.77, mask=measured.measured, excluded_steps=(2,)
    )
    assert objective.steps.tolist() == [0, 2, 3]
    thetas = _random_thetas(surrogate, 20, seed=4)
    prediction = surrogate.predict(thetas)
    for eta in WEIGHTS:
        F_full = objective.value(prediction, eta)
        F_reduced = ReducedObjective(objective, surrogate.reduced_basis(), eta).value(thetas)
        assert np.all(np.isfinite(F_full))
        np.testing.assert_allclose(F_reduced, F_full, rtol=1e-10, atol=0)


def test_posterior_is_the_same_chain_on_either_path(surrogate, measured):
    eta = WEIGHTS[0]
    box = (surrogate.scaler.lo, surrogate.scaler.hi)
    start = np.array([10.0, 280.0])
    runs = {
        path: sample_posterior(
            measured, surrogate, eta, s=0.05, box=box, start=start, walkers=8, steps=300, seed=4, reduced=path
        )
        for path in (True, False)
    }
    fast, slow = runs[True], runs[False]
    assert fast.objective_path == "reduced" and slow.objective_path == "full"
    assert fast.samples.shape == slow.samples.shape and len(fast.samples) > 50
    np.testing.assert_allclose(fast.samples, slow.samples, rtol=1e-9)
    assert fast.acceptance_fraction == slow.acceptance_fraction > 0.1
    # the default picks the reduced path for a surrogate
    again = sample_posterior(
        measured, surrogate, eta, s=0.05, box=box, start=start, walkers=8, steps=300, seed=4
    )
    assert again.objective_path == "reduced"
    np.testing.assert_array_equal(again.samples, fast.samples)


def test_fe_predictor_keeps_the_field_path(measured):
    fe = FESolverPredictor(MODEL)
    assert not isinstance(fe, ReducedPredictor)
    assert isinstance(objective_function(measured, fe, WEIGHTS[0]), FieldObjective)
    with pytest.raises(ValueError, match="no reduced basis"):
        objective_function(measured, fe, WEIGHTS[0], reduced=True)


def test_a_basis_of_another_model_is_refused(surrogate, measured):
    basis = surrogate.reduced_basis()
    objective = Objective(
        measured.force[:3], measured.displacement[:3], measured.top_xyz, radius=4.77, mask=measured.mask
    )
    with pytest.raises(ValueError, match=r"\(steps, nodes, 3\)"):
        ReducedObjective(objective, basis, WEIGHTS[0])
