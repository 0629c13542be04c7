"""Run the pending points of a campaign in parallel with joblib: local processes, or the dask
backend on a dask.distributed cluster (``scheduler="tcp://host:8786"``).

Each worker solves one point single-threaded (BLAS/MKL and numba threads pinned to 1, so that
``jobs`` processes use ``jobs`` cores) and returns its index row with the result; the parent
writes each result file atomically as it arrives and records the row, so cluster workers need no
access to the store. A point that fails (spec error, no convergence,
solver error, timeout, FEBio steps off equilibrium) is recorded with its reason and the campaign
goes on; the steps it did solve are kept in ``points/<n>.partial.npz``.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable
from contextlib import nullcontext
from pathlib import Path
from typing import Any

import numpy as np

from ..forward.febio_runner import find_febio
from ..forward.spec import ModelSpec
from .designs import Design, design_from_option
from .store import CampaignSpec, CampaignStore


class PointTimeout(RuntimeError):
    """A point that ran longer than the campaign's per-point timeout."""


def solve_point(
    point: int,
    model: dict[str, Any],
    solver: str,
    parameters: tuple[str, ...],
    values: list[float],
    timeout_s: float | None,
    workdir: str | None = None,
) -> dict[str, Any]:
    """Solve one point; returns its index row with the result (or the partial result of a
    failure) for the parent to save. Never raises: a failure becomes the row's error."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {
        "point": point,
        "status": "failed",
        "wall_s": np.nan,
        "newton_iterations": None,
        "error": None,
    }
    try:
        from ..forward.solver import thread_limits

        with thread_limits(1):  # one worker per core: numba and MKL on one thread each
            spec = ModelSpec.from_dict(model).with_parameters(**dict(zip(parameters, values, strict=True)))
            if solver == "febio":
                from ..forward.febio_runner import FebioSolver, require_equilibrium

                # steps FEBio accepted off equilibrium (after its one rerun) fail the point:
                # a force curve with holes is no training sample (forward.febio_equilibrium)
                result = require_equilibrium(FebioSolver(spec, workdir=workdir, timeout_s=timeout_s).run())
            else:
                from ..forward.solver import EmbeddedSolver

                def deadline(k: int, n: int, f: float) -> None:
                    if timeout_s is not None and time.perf_counter() - t0 > timeout_s:
                        raise PointTimeout(f"timeout: {timeout_s:g} s exceeded after step {k} of {n}")

                result = EmbeddedSolver(spec).run(progress=deadline)
        row.update(status="done", newton_iterations=result.newton_iterations, result=result)
    except Exception as exc:  # recorded, never propagated: one bad point must not stop a campaign
        partial = getattr(exc, "partial", None)
        if partial is not None and len(partial.depth) > 1:
            row["partial"] = partial
        message = f"{type(exc).__name__}: {exc}".strip()
        if not isinstance(exc, (ValueError, RuntimeError, TimeoutError, OSError)):
            message += " | " + traceback.format_exc(limit=3).replace("\n", " ")
        row["error"] = message[:2000]
    row["wall_s"] = time.perf_counter() - t0
    row["finished"] = time.strftime("%Y-%m-%dT%H:%M:%S")
    return row


def run_campaign(
    store: CampaignStore,
    jobs: int = 1,
    scheduler: str | None = None,
    retry_failed: bool = False,
    timeout_s: float | None = None,
    progress: Callable[[int, int, dict[str, int]], None] | None = None,
    index_every_s: float = 1.0,
) -> dict[str, Any]:
    """Solve the pending points (and the failed ones with ``retry_failed``); returns the summary."""
    from joblib import Parallel, delayed, parallel_config

    todo = store.points_with("pending", "failed") if retry_failed else store.points_with("pending")
    spec = store.spec
    model = spec.model.to_dict()
    t0 = time.perf_counter()
    total = len(todo)
    if total:
        client = None
        if scheduler:
            from distributed import Client

            client = Client(scheduler)
            context = parallel_config(backend="dask", wait_for_workers_timeout=60)
        else:
            context = nullcontext()
        calls = (
            delayed(solve_point)(
                int(i),
                model,
                spec.solver,
                spec.design.parameters,
                spec.design.points[i].tolist(),
                timeout_s,
                str(store.root / "febio" / f"{i:05d}") if spec.solver == "febio" else None,
            )
            for i in todo
        )
        try:
            with context:
                runner = Parallel(n_jobs=jobs if not scheduler else -1, return_as="generator_unordered")
                last_write = time.perf_counter()
                done = 0
                for row in runner(calls):  # in completion order; each row names its point
                    i = int(row.pop("point"))
                    result, partial = row.pop("result", None), row.pop("partial", None)
                    if result is not None:
                        result.save(store.result_path(i))  # atomic: temporary file, then rename
                    if partial is not None:
                        partial.save(store.partial_path(i))
                    store.record(i, row, write=False)
                    done += 1
                    if time.perf_counter() - last_write > index_every_s or done == total:
                        store.write_index()
                        last_write = time.perf_counter()
                    if progress is not None:
                        progress(done, total, store.counts())
        finally:
            store.write_index()
            if client is not None:
                client.close()
    return store.summary() | {"wall_s": time.perf_counter() - t0, "solved_now": total}


def default_runs_dir() -> Path:
    return Path("runs")


def run_named_campaign(
    name: str,
    design: Design | str,
    model: ModelSpec,
    runs_dir: str | Path = "runs",
    solver: str = "embedded",
    jobs: int = 0,
    scheduler: str | None = None,
    retry_failed: bool = False,
    timeout_s: float | None = None,
    progress: Callable[[int, int, dict[str, int]], None] | None = None,
) -> dict[str, Any]:
    """Create (or resume) the campaign ``runs_dir/name`` of ``model`` over ``design`` (a Design or a
    grid option such as 'paper', 'lhs:200:7', 'c1=2:20:10,c5=100:500:9') and solve what is left.
    ``jobs`` 0 means all cores. A store started with another spec is refused, naming the fields."""
    if isinstance(design, str):
        design = design_from_option(design)
    store = CampaignStore.create_or_open(runs_dir, CampaignSpec(name, design, model, solver))
    if solver == "febio":
        find_febio()  # absent FEBio is a clear error before anything runs
    n_jobs = jobs if jobs > 0 else (os.cpu_count() or 1)
    summary = run_campaign(
        store, n_jobs, scheduler, retry_failed=retry_failed, timeout_s=timeout_s, progress=progress
    )
    return summary | {"name": name, "root": str(store.root), "jobs": n_jobs}
