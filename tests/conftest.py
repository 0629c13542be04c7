"""Shared fixtures. ``febio_baseline``: the real FEBio 4 run of ../shared/febio/baseline, or a skip
that names the missing folder when the clone has no ../shared beside it; ``mu_surrogate``: a GP over
(c1, c5, mu) on a small coarse campaign."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from filelock import FileLock
from threadpoolctl import threadpool_limits

from indentation_studio.forward.threads import THREADS_ENV

# The suite runs in two processes on CI's two cores (pyproject's addopts), so every solve takes one
# thread: two runs a test compares then use the same thread count whatever the machine's load
# (the thread policy, which reads the load, is tested with the variable removed: test_threads.py).
os.environ.setdefault(THREADS_ENV, "1")

#: The BLAS/OpenMP libraries (OpenBLAS under numpy and scipy, MKL, torch's OpenMP) take one thread too,
#: in this process (those loaded already) and in what it starts (the docs build, its notebook
#: kernels, the CLI, campaign workers: those read the variables when they load the libraries). With
#: two test processes on two cores, a second BLAS thread only waits for a busy core: the GP fits of
#: tests/test_multi_fidelity.py took 63 s with it and 13 s without, on a loaded machine.
BLAS_THREADS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
for _name, _value in BLAS_THREADS.items():
    os.environ.setdefault(_name, _value)
_BLAS_LIMITS = threadpool_limits(1)

#: The longest test files, longest first (each measured alone: the docs build about 145 s of CPU,
#: the demo 55, the campaign tests 50, then 40 down to 15). The collection puts them first and
#: pyproject's ``--no-loadscope-reorder`` keeps pytest-xdist from ordering the files by their number
#: of tests, so that each of the two workers starts on a long file, the docs build at once, and the
#: short files fill in at the end: a long file handed out last makes one worker finish minutes after
#: the other (the last run before this order: 1045 s of tests on one worker, 969 s on the other).
LONGEST_FIRST = (
    "test_docs.py",
    "test_demo.py",
    "test_campaign.py",
    "test_surrogate.py",
    "test_multi_fidelity_fit.py",
    "test_lab_example.py",
    "test_friction_fit.py",
    "test_readme.py",
    "test_surface_contact.py",
    "test_fit_confirmation.py",
    "test_experiment.py",
    "test_friction.py",
    "test_study_budget.py",
    "test_inverse_fit.py",
    "test_multi_fidelity.py",
    "test_reduced_objective.py",
    "test_composite_experiment.py",
    "test_guide_commands.py",
    "test_adequacy.py",
    "test_error_budget.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The files of :data:`LONGEST_FIRST` first, in its order; the others after, as collected."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: a file's tests stay in order


SHARED = Path(__file__).resolve().parents[2] / "shared"
#: The real FEBio 4 run of the paper's baseline (tests that need it skip, naming it, when absent).
FEBIO_BASELINE = SHARED / "febio" / "baseline"
#: Its input, log and result files.
FEBIO_FEB, FEBIO_LOG, FEBIO_NPZ = (FEBIO_BASELINE / f"baseline.{ext}" for ext in ("feb", "log", "npz"))


@pytest.fixture(scope="session")
def febio_baseline() -> Path:
    """The folder of the shared FEBio baseline run (baseline.feb, .log, .npz, .json)."""
    folder = FEBIO_BASELINE
    if not (folder / "baseline.feb").is_file() or not (folder / "baseline.npz").is_file():
        pytest.skip(f"shared FEBio data absent: {folder} (clone with ../shared beside it to run this test)")
    return folder


def run_folder(tmp_path_factory) -> Path:
    """A folder every test process of this run sees: pytest-xdist's workers' base temporary folders
    share their parent (a run in one process has its own base folder)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@pytest.fixture(scope="session")
def mu_campaign(tmp_path_factory) -> Path:
    """The runs folder of campaign ``mu``: a 2 x 2 x 3 coarse grid over (c1, c5, mu), 3 steps of 0.5 mm.

    Solved once per test run (the first worker that asks solves it under a lock, the other waits and
    copies it); each worker gets a runs folder of its own, since tests write beside the campaign."""
    from indentation_studio.campaign.runner import run_named_campaign
    from indentation_studio.forward.spec import MeshChoice, ModelSpec, Protocol

    solved = run_folder(tmp_path_factory) / "mu-campaign"
    with FileLock(f"{solved}.lock"):
        if not (solved / "summary.json").is_file():
            base = ModelSpec(mesh=MeshChoice("coarse"), protocol=Protocol(step_size=0.5, steps=3))
            grid = "c1=6:12:2,c5=250:450:2,mu=0.2:2:3:log"
            summary = run_named_campaign("mu", grid, base, runs_dir=solved / "runs", jobs=1)
            (solved / "summary.json").write_text(json.dumps({"done": summary["done"]}))
    assert json.loads((solved / "summary.json").read_text())["done"] == 12
    runs = tmp_path_factory.mktemp("runs")
    shutil.copytree(solved / "runs" / "mu", runs / "mu")
    return runs


@pytest.fixture(scope="session")
def mu_surrogate(mu_campaign):
    """A GP over (c1, c5, mu) trained on campaign ``mu``."""
    from indentation_studio.surrogate.training import train_surrogate

    return train_surrogate("mu", "gp", runs_dir=mu_campaign)
