"""The thread policy: a lone run takes the idle cores, a fixed count is honoured, and the numbers
do not depend on the thread count beyond round-off."""

import numba
import numpy as np
import pytest

from indentation_studio.forward import threads
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol


def test_one_and_two_threads_give_the_same_run_to_round_off():
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba was started with one thread")
    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=6))
    one = EmbeddedSolver(spec).run(sensitivities=True, threads=1)
    two = EmbeddedSolver(spec).run(sensitivities=True, threads=2)
    assert one.force[-1] > 0
    np.testing.assert_allclose(two.force, one.force, rtol=1e-8, atol=1e-10 * one.force.max())
    scale = np.abs(one.displacement).max()
    assert np.abs(two.displacement - one.displacement).max() <= 1e-8 * scale
    sens = np.abs(one.force_sensitivity).max(axis=0)
    assert np.all(np.abs(two.force_sensitivity - one.force_sensitivity).max(axis=0) <= 1e-8 * sens)


def test_the_idle_cores_make_the_thread_count(monkeypatch):
    monkeypatch.delenv(threads.THREADS_ENV, raising=False)
    monkeypatch.setattr(threads, "available_cores", lambda: 4)
    monkeypatch.setattr(threads, "busy_cores", lambda: 0)
    assert threads.solver_threads() == 4
    monkeypatch.setattr(threads, "busy_cores", lambda: 3)
    assert threads.solver_threads() == 1
    monkeypatch.setattr(threads, "busy_cores", lambda: 9)  # an oversubscribed machine: still one
    assert threads.solver_threads() == 1


def test_the_environment_fixes_the_thread_count(monkeypatch):
    monkeypatch.setenv(threads.THREADS_ENV, "3")
    assert threads.solver_threads() == 3
    monkeypatch.setenv(threads.THREADS_ENV, "none")
    with pytest.raises(ValueError, match="INDENTATION_STUDIO_THREADS"):
        threads.solver_threads()


def test_busy_cores_reads_the_kernel_and_limits_are_restored():
    assert 0 <= threads.busy_cores() <= 4096
    before = numba.get_num_threads()
    with threads.thread_limits(1):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before


def test_a_campaign_worker_solves_on_one_thread(monkeypatch):
    """A worker is one of as many as the cores: it must not take the idle cores itself."""
    from indentation_studio.campaign import runner

    seen = []
    original = EmbeddedSolver.run

    def run(self, *args, **kwargs):
        seen.append(kwargs.get("threads"))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(runner.EmbeddedSolver, "run", run)
    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=2))
    row = runner.solve_point(0, spec.to_dict(), "embedded", ("c1", "c5"), [10.0, 350.0], None)
    assert row["status"] == "done" and seen == [1]
