"""A run stopped from outside (Ctrl-C, SIGTERM) keeps its finished steps (forward.simulation_run)."""

from __future__ import annotations

import dataclasses
import os
import pickle
import signal

import numpy as np
import pytest

from indentation_studio.forward import checkpoint as checkpoint_file
from indentation_studio.forward.checkpoint import CheckpointMismatch
from indentation_studio.forward.node_stick import NodeStickContact
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.simulation_run import run_simulation
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Contact, Material, MeshChoice, ModelSpec, Protocol

SPEC = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(steps=5))


def test_sigterm_stops_a_run_and_keeps_the_steps_done(tmp_path):
    said = []

    def progress(k, n, force):
        if k == 2:
            os.kill(os.getpid(), signal.SIGTERM)

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt):
        run_simulation(SPEC, tmp_path / "run.npz", progress=progress, say=said.append)
    assert signal.getsignal(signal.SIGTERM) is before  # the handler is put back
    kept = SimulationResult.load(tmp_path / "run.partial.npz")
    assert np.allclose(kept.depth, [0.0, 0.5, 1.0]) and kept.force.shape == (3,)
    assert kept.displacement.shape[0] == 3 and kept.force[2] > kept.force[1] > 0
    assert "interruption" in said[0] and not (tmp_path / "run.npz").exists()


def test_ctrl_c_in_the_middle_of_a_step_keeps_only_whole_steps(tmp_path, monkeypatch):
    """Ctrl-C inside the third step's increment keeps the two steps before it, sensitivities
    included, equal to an uninterrupted run's; Ctrl-C inside the first keeps nothing."""
    whole = run_simulation(SPEC, tmp_path / "whole.npz", sensitivities=True).result
    original = NodeStickContact.increment
    calls = {"n": 0, "stop_at": 3}

    def increment(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == calls["stop_at"]:
            raise KeyboardInterrupt
        return original(self, *args, **kwargs)

    monkeypatch.setattr(NodeStickContact, "increment", increment)
    with pytest.raises(KeyboardInterrupt):
        run_simulation(SPEC, tmp_path / "run.npz", sensitivities=True)
    kept = SimulationResult.load(tmp_path / "run.partial.npz")
    assert kept.depth.size == 3 and kept.force_sensitivity.shape[0] == 3
    np.testing.assert_allclose(kept.force, whole.force[:3], rtol=1e-9)
    np.testing.assert_allclose(kept.force_sensitivity, whole.force_sensitivity[:3], rtol=1e-9)
    calls.update(n=0, stop_at=1)
    with pytest.raises(KeyboardInterrupt):
        run_simulation(SPEC, tmp_path / "none.npz")
    assert not (tmp_path / "none.partial.npz").exists()


@pytest.mark.parametrize(
    "contact",
    [
        Contact(),
        Contact(integration="surface", order=1),
        Contact(integration="surface", order=1, friction=0.3),
    ],
    ids=["node stick", "surface stick", "surface mu 0.3"],
)
def test_a_run_stopped_part_way_resumes_from_its_checkpoint(tmp_path, contact):
    """Stopped after its second step with a checkpoint, the run given the same checkpoint again
    solves only steps 3 to 5 and ends where an uninterrupted run does (forces, displacements,
    sensitivities, and so the anchors carried in the contact's state) within the Newton
    tolerance (residual 1e-4 of its scale): the resumed run has no factorisation to reuse, so its
    iterations differ. Steps 1 and 2 are the checkpoint's, bit for bit."""
    spec = dataclasses.replace(SPEC, contact=contact)
    whole = EmbeddedSolver(spec).run(sensitivities=True)
    restart = tmp_path / "run.checkpoint.pkl"

    def stop_after_two(k, n, force):
        if k == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        EmbeddedSolver(spec).run(sensitivities=True, progress=stop_after_two, checkpoint=restart)
    assert restart.is_file()
    resumed_solver = EmbeddedSolver(spec)
    steps = []
    resumed = resumed_solver.run(
        sensitivities=True, checkpoint=restart, progress=lambda k, n, f: steps.append(k)
    )
    assert steps == [3, 4, 5]
    assert resumed.force.shape == whole.force.shape == (6,)
    np.testing.assert_array_equal(resumed.force[:3], whole.force[:3])
    np.testing.assert_allclose(resumed.force, whole.force, rtol=1e-4)
    np.testing.assert_allclose(resumed.displacement, whole.displacement, atol=1e-4 * spec.protocol.max_depth)
    np.testing.assert_allclose(
        resumed.force_sensitivity,
        whole.force_sensitivity,
        rtol=1e-3,
        atol=1e-4 * abs(whole.force_sensitivity).max(),
    )
    np.testing.assert_array_equal(
        resumed.convergence["newton_iterations"][:3], whole.convergence["newton_iterations"][:3]
    )


def test_a_checkpoint_of_another_run_is_refused_by_name(tmp_path):
    restart = tmp_path / "run.checkpoint.pkl"

    def stop_after_one(k, n, force):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        EmbeddedSolver(SPEC).run(progress=stop_after_one, checkpoint=restart)
    other = dataclasses.replace(SPEC, material=Material(c1=5.0, c5=200.0))
    with pytest.raises(CheckpointMismatch, match="spec"):
        EmbeddedSolver(other).run(checkpoint=restart)
    with pytest.raises(CheckpointMismatch, match="sensitivities"):
        EmbeddedSolver(SPEC).run(sensitivities=True, checkpoint=restart)
    restart.write_bytes(restart.read_bytes()[:40])  # a file cut short by a full disk
    with pytest.raises(CheckpointMismatch, match="not a readable checkpoint"):
        EmbeddedSolver(SPEC).run(checkpoint=restart)


def test_simulate_restart_deletes_its_checkpoint_once_the_result_is_written(tmp_path):
    def stop_after_three(k, n, force):
        if k == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_simulation(SPEC, tmp_path / "run.npz", restart=True, progress=stop_after_three)
    assert (tmp_path / "run.checkpoint.pkl").is_file()
    steps = []
    run = run_simulation(SPEC, tmp_path / "run.npz", restart=True, progress=lambda k, n, f: steps.append(k))
    assert steps == [4, 5] and run.result.force.shape == (6,)
    assert not (tmp_path / "run.checkpoint.pkl").exists()
    with pytest.raises(ValueError, match="--restart need the embedded solver"):
        run_simulation(SPEC, tmp_path / "f.npz", solver="febio", restart=True)


def test_a_run_stopped_inside_a_step_resumes_from_its_last_converged_increment(tmp_path, monkeypatch):
    """With two increments a step and a checkpoint after every converged increment
    (``MID_STEP_CHECKPOINT_S`` = 0), a run stopped in the second increment of step 3 resumes at
    1.25 mm: step 3 solves only its second increment (one call), steps 4 and 5 two each; the
    forces end where an uninterrupted run's do, and step 3's record counts both increments."""
    spec = dataclasses.replace(SPEC, solver=dataclasses.replace(SPEC.solver, substeps=2))
    whole = EmbeddedSolver(spec).run()
    monkeypatch.setattr(checkpoint_file, "MID_STEP_CHECKPOINT_S", 0.0)
    original = NodeStickContact.increment
    calls = {"n": 0, "stop_at": 6, "depths": []}

    def increment(self, u, u_pred, d0, d1, *args, **kwargs):
        calls["n"] += 1
        calls["depths"].append(d1)
        if calls["n"] == calls["stop_at"]:
            raise KeyboardInterrupt
        return original(self, u, u_pred, d0, d1, *args, **kwargs)

    monkeypatch.setattr(NodeStickContact, "increment", increment)
    restart = tmp_path / "run.checkpoint.pkl"
    with pytest.raises(KeyboardInterrupt):
        EmbeddedSolver(spec).run(checkpoint=restart)
    calls.update(n=0, stop_at=0, depths=[])
    steps = []
    resumed = EmbeddedSolver(spec).run(checkpoint=restart, progress=lambda k, n, f: steps.append(k))
    assert steps == [3, 4, 5]
    np.testing.assert_allclose(calls["depths"], [1.5, 1.75, 2.0, 2.25, 2.5])
    np.testing.assert_allclose(resumed.force, whole.force, rtol=1e-4)
    np.testing.assert_array_equal(resumed.convergence["increments"], whole.convergence["increments"])


def test_a_checkpoint_of_whole_steps_only_from_before_is_still_read(tmp_path):
    """A checkpoint of format 1 (whole steps, no ``mid_step``) resumes as it did."""
    restart = tmp_path / "run.checkpoint.pkl"

    def stop_after_two(k, n, force):
        if k == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        EmbeddedSolver(SPEC).run(progress=stop_after_two, checkpoint=restart)
    saved = pickle.loads(restart.read_bytes())
    saved["identity"]["format"] = 1
    del saved["state"]["mid_step"]
    restart.write_bytes(pickle.dumps(saved))
    steps = []
    EmbeddedSolver(SPEC).run(checkpoint=restart, progress=lambda k, n, f: steps.append(k))
    assert steps == [3, 4, 5]
