"""Where a campaign's points are solved: :func:`solve_point`, the worker's job (one point,
single-threaded, its index row and result returned, never raising), and the executors that run it
in this process (:class:`InProcess`, ``jobs=1``), in local processes (:class:`Processes`, loky,
joblib's executor) or on a dask.distributed cluster (:class:`DaskCluster`); :func:`executor_for`
picks one. The run itself (claims, heartbeat, recording) is
:mod:`~indentation_studio.campaign.runner`'s."""

from __future__ import annotations

import concurrent.futures as cf
import logging
import os
import time
import traceback
from typing import Any

import numpy as np

from ..forward.checkpoint import CheckpointMismatch
from ..forward.febio.equilibrium import EquilibriumTolerance
from ..forward.febio.runner import FebioSolver
from ..forward.result import SimulationResult
from ..forward.solver import EmbeddedSolver
from ..forward.spec import ModelSpec
from .errors import CampaignError
from .index import result_row
from .spec import CAMPAIGN_EQUILIBRIUM_REL

__all__ = ["DaskCluster", "InProcess", "PointTimeout", "Processes", "executor_for", "solve_point"]

log = logging.getLogger(__name__)

#: An embedded point writes its checkpoint after a step only when this long has passed since the
#: last one (forward.solver.EmbeddedSolver.run's ``checkpoint_every_s``): a point of seconds (the
#: paper's campaign on ``default``: 2 s, of which a file after every step took 3 to 4 %) writes
#: none, a fine level's point of hours loses at most this much.
POINT_CHECKPOINT_S = 30.0


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
    equilibrium_rel: float | None = None,
    checkpoint: str | None = None,
) -> dict[str, Any]:
    """Solve one point; returns its index row with the result (or the partial result of a
    failure) for the parent to save. Never raises: a failure becomes the row's error.

    An embedded point given ``checkpoint`` writes its state there after a step at most every
    ``POINT_CHECKPOINT_S`` and, when the
    file exists (a point stopped by a kill, a lost worker or its timeout), resumes after its last
    finished step; the parent deletes the file once the result is kept. A checkpoint this run
    cannot resume from (written by another version of the package, or cut short) is kept beside
    as ``<file>.refused`` and the point solved from its start."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {
        "point": point,
        "status": "failed",
        "wall_s": np.nan,
        "newton_iterations": None,
        "error": None,
    }
    try:
        spec = ModelSpec.from_dict(model).with_parameters(**dict(zip(parameters, values, strict=True)))
        if solver == "febio":
            # steps FEBio accepted off equilibrium (after its one rerun, made only when a
            # step is flagged) are kept as NaN forces: the point is done, its flagged steps
            # counted (forward.febio.equilibrium; the loader and training handle them)
            tolerance = EquilibriumTolerance(relative=equilibrium_rel or CAMPAIGN_EQUILIBRIUM_REL)
            result = FebioSolver(spec, workdir=workdir, timeout_s=timeout_s, tolerance=tolerance).run()
        else:

            def deadline(k: int, n: int, f: float) -> None:
                if timeout_s is not None and time.perf_counter() - t0 > timeout_s:
                    raise PointTimeout(f"timeout: {timeout_s:g} s exceeded after step {k} of {n}")

            def solve() -> SimulationResult:
                # one thread: a worker among as many as the cores (forward.threads)
                return EmbeddedSolver(spec).run(
                    progress=deadline, threads=1, checkpoint=checkpoint, checkpoint_every_s=POINT_CHECKPOINT_S
                )

            try:
                result = solve()
            except CheckpointMismatch as exc:
                refused = f"{checkpoint}.refused"
                os.replace(checkpoint, refused)
                log.warning("point %d: %s; kept as %s, solved from its start", point, exc, refused)
                result = solve()
        row.update(status="done", result=result, **result_row(result))
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


class InProcess:
    """``jobs=1``: each point solved in this process when submitted."""

    def __init__(self) -> None:
        self.ready: list[tuple[int, dict[str, Any] | BaseException]] = []

    def capacity(self) -> int:
        return 1

    def in_flight(self) -> int:
        return len(self.ready)

    def submit(self, point: int, args: tuple) -> None:
        self.ready.append((point, solve_point(*args)))

    def collect(self, timeout: float) -> list[tuple[int, dict[str, Any] | BaseException]]:
        out, self.ready = self.ready, []
        return out

    def close(self) -> None:
        pass


class Processes:
    """Local worker processes (joblib's loky executor, the reusable one its ``Parallel`` uses);
    a dead worker fails its points (``worker lost``, for ``--retry-failed``)."""

    def __init__(self, jobs: int) -> None:
        from joblib.executor import get_memmapping_executor  # the one joblib's Parallel shares

        self.jobs = jobs
        self.get = lambda: get_memmapping_executor(jobs, timeout=60)
        self.executor = self.get()
        self.futures: dict[cf.Future, int] = {}

    def capacity(self) -> int:
        return self.jobs

    def in_flight(self) -> int:
        return len(self.futures)

    def submit(self, point: int, args: tuple) -> None:
        try:
            future = self.executor.submit(solve_point, *args)
        except Exception:  # a broken executor (a worker was killed): a fresh one
            self.executor = self.get()
            future = self.executor.submit(solve_point, *args)
        self.futures[future] = point

    def collect(self, timeout: float) -> list[tuple[int, dict[str, Any] | BaseException]]:
        if not self.futures:
            return []
        done, _ = cf.wait(list(self.futures), timeout=timeout, return_when=cf.FIRST_COMPLETED)
        out = []
        for f in done:
            point = self.futures.pop(f)
            try:
                out.append((point, f.result()))
            except BaseException as exc:  # the worker process died
                out.append((point, exc))
        return out

    def close(self) -> None:
        pass  # the reusable executor stays for the next campaign of this process


class DaskCluster:
    """A dask.distributed cluster: tasks the scheduler moves to another worker when theirs dies;
    a task that killed too many workers is an error here, recorded failed."""

    def __init__(self, scheduler: str, wait_for_workers_s: float = 60.0) -> None:
        from distributed import Client

        self.client = Client(scheduler, timeout=wait_for_workers_s)
        try:
            self.client.wait_for_workers(1, timeout=wait_for_workers_s)
        except Exception as exc:
            self.client.close()
            raise CampaignError(
                f"dask scheduler {scheduler}: no worker joined within {wait_for_workers_s:g} s"
            ) from exc
        self.futures: dict[Any, int] = {}

    def capacity(self) -> int:
        try:
            threads = sum(self.client.nthreads().values())
        except Exception:
            threads = 1
        return 2 * max(threads, 1)

    def in_flight(self) -> int:
        return len(self.futures)

    def submit(self, point: int, args: tuple) -> None:
        future = self.client.submit(
            solve_point, *args, pure=False, key=f"point-{point:05d}-{os.urandom(4).hex()}"
        )
        self.futures[future] = point

    def collect(self, timeout: float) -> list[tuple[int, dict[str, Any] | BaseException]]:
        from distributed import wait

        if not self.futures:
            return []
        try:
            done, _ = wait(list(self.futures), timeout=timeout, return_when="FIRST_COMPLETED")
        except Exception as exc:  # a timeout (none finished yet), or the scheduler gone
            if getattr(self.client, "status", "running") not in ("running", "connecting"):
                raise CampaignError(
                    f"lost the dask scheduler ({type(exc).__name__}: {exc}); the points in flight "
                    "are released and the finished ones kept: run again"
                ) from exc
            return []
        out = []
        for f in done:
            point = self.futures.pop(f)
            try:
                out.append((point, f.result(timeout=timeout)))
            except BaseException as exc:  # KilledWorker, a cancelled or lost task
                out.append((point, exc))
        return out

    def close(self) -> None:
        for f in self.futures:
            f.cancel()
        self.client.close()


def executor_for(jobs: int, scheduler: str | None) -> InProcess | Processes | DaskCluster:
    """Where a run's points are solved: a dask cluster at ``scheduler``, else ``jobs`` local
    processes, else this process (``jobs=1``)."""
    return DaskCluster(scheduler) if scheduler else Processes(jobs) if jobs > 1 else InProcess()
