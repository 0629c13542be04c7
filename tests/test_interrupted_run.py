"""A run stopped from outside (Ctrl-C, SIGTERM) keeps its finished steps (forward.simulation_run)."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

from indentation_studio.forward.node_stick import NodeStickContact
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.simulation_run import run_simulation
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol

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
