"""The thread policy: a lone run takes the idle cores, a fixed count is honoured, and the numbers
do not depend on the thread count beyond round-off."""

import json
import os
import subprocess
import sys

import numba
import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

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

    monkeypatch.setattr(EmbeddedSolver, "run", run)
    spec = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=2))
    row = runner.solve_point(0, spec.to_dict(), "embedded", ("c1", "c5"), [10.0, 350.0], None)
    assert row["status"] == "done" and seen == [1]


@pytest.mark.parametrize(
    "preset, expected",
    [
        ({}, {"GOMP_SPINCOUNT": "3000", "KMP_BLOCKTIME": "0", "OMP_WAIT_POLICY": None}),
        (
            {"OMP_WAIT_POLICY": "ACTIVE"},
            {"GOMP_SPINCOUNT": None, "KMP_BLOCKTIME": None, "OMP_WAIT_POLICY": "ACTIVE"},
        ),
        ({"GOMP_SPINCOUNT": "0"}, {"GOMP_SPINCOUNT": "0", "KMP_BLOCKTIME": None, "OMP_WAIT_POLICY": None}),
    ],
)
def test_importing_the_package_makes_waiting_openmp_threads_spin_briefly_unless_the_user_chose(
    preset, expected
):
    env = {k: v for k, v in os.environ.items() if k not in expected}
    env.update(preset)
    code = "import json, os, indentation_studio; print(json.dumps({k: os.environ.get(k) for k in %r}))"
    out = subprocess.run(
        [sys.executable, "-c", code % sorted(expected)], env=env, capture_output=True, text=True, check=True
    )
    assert json.loads(out.stdout) == expected


class _Stop(Exception):
    pass


@pytest.mark.parametrize(
    "module, workflow",
    [("fit.workflow", "fit_experiment"), ("posterior.workflow", "sample_posterior_for")],
)
def test_the_experiment_workflows_keep_blas_on_one_thread(monkeypatch, module, workflow):
    import importlib

    mod = importlib.import_module(f"indentation_studio.inference.{module}")
    seen = []

    def record(*args, **kwargs):
        seen.extend(p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas")
        raise _Stop

    monkeypatch.setattr(mod, "prepare_fit", record)
    with threadpool_limits(limits=2, user_api="blas"):
        if not any(p["user_api"] == "blas" and p["num_threads"] == 2 for p in threadpool_info()):
            pytest.skip("no BLAS here that takes two threads")
        with pytest.raises(_Stop):
            getattr(mod, workflow)("any-experiment")
        assert seen and all(n == 1 for n in seen)
        assert any(p["user_api"] == "blas" and p["num_threads"] == 2 for p in threadpool_info())  # restored
