"""Run the pending points of a campaign in parallel: in this process (``jobs=1``), in local
processes (loky, joblib's executor), or on a dask.distributed cluster (``scheduler=
"tcp://host:8786"``); the worker's job and the executors are
:mod:`~indentation_studio.campaign.executors`'.

Each worker solves one point single-threaded (BLAS/MKL and numba threads pinned to 1, so that
``jobs`` processes use ``jobs`` cores) and returns its index row with the result; the parent
writes each result file atomically as it arrives, with its sha256 and size in the index, so
workers need no access to the store and a worker killed mid-point writes nothing: on a dask
cluster the scheduler gives its task to another worker (solved again), and a task that killed
its workers too often comes back as an error and is recorded failed. A point that fails (spec
error, no convergence, solver error, timeout) is recorded with its reason and the campaign goes
on; the steps it did solve are kept in ``points/<n>.partial.npz``. A FEBio point with steps
flagged off equilibrium is done, those steps' forces NaN (``flagged_steps`` in the index).

Each point is solved once however many runs of the campaign are started (store module
docstring): a run claims a point (a lease under the store's lock) just before it is solved,
renews its leases from a heartbeat thread, and releases each once its result is recorded. A run
takes the points nobody holds; then, by default, it waits for the points another live run holds
(taking over any whose holder dies), so that when it returns the campaign is complete; with
``wait_for_held=False`` it returns at once and lists them as ``held_by_other_runs``.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..forward.febio.runner import find_febio
from ..forward.spec import ModelSpec
from .designs import Design, design_from_option
from .errors import CampaignError
from .executors import PointTimeout as PointTimeout  # X as X: re-exported
from .executors import executor_for
from .executors import solve_point as solve_point
from .leases import DEFAULT_LEASE_TIMEOUT_S, RunIdentity
from .spec import CampaignSpec
from .store import CampaignStore


class _Heartbeat(threading.Thread):
    """Renews the leases of the points this run holds, every quarter of the lease timeout."""

    def __init__(self, store: CampaignStore, run: RunIdentity, every_s: float) -> None:
        super().__init__(daemon=True, name="campaign-heartbeat")
        self.store, self.run_id, self.every_s = store, run, every_s
        self.held: set[int] = set()
        self.lost: set[int] = set()
        self.guard = threading.Lock()
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.wait(self.every_s):
            with self.guard:
                points = sorted(self.held)
            if points:
                try:
                    lost = self.store.claims.renew(points, self.run_id)
                except Exception:  # a lock not had this time: the next beat tries again
                    continue
                with self.guard:
                    self.lost |= lost


def run_campaign(
    store: CampaignStore,
    jobs: int = 1,
    scheduler: str | None = None,
    retry_failed: bool = False,
    timeout_s: float | None = None,
    progress: Callable[[int, int, dict[str, int]], None] | None = None,
    index_every_s: float = 1.0,
    lease_timeout_s: float = DEFAULT_LEASE_TIMEOUT_S,
    wait_for_held: bool = True,
    poll_s: float = 0.5,
) -> dict[str, Any]:
    """Solve the pending points of a store (and failed ones with ``retry_failed``) no other run holds.

    Each point is claimed under a lease (renewed by a heartbeat), solved, its files written, then
    its index row; an interrupted run releases its claims.

    Parameters
    ----------
    store : CampaignStore
        The campaign to solve.
    jobs : int, default 1
        Worker processes (1: in this process); ignored when ``scheduler`` is given.
    scheduler : str, optional
        Address of a dask scheduler to run the points on.
    retry_failed : bool, default False
        Solve the failed points again too.
    timeout_s : float, optional
        Time limit of one point's solve, s.
    progress : callable, optional
        Called as ``progress(handled, total, counts)`` after each point.
    index_every_s : float, default 1.0
        Kept for callers: the index is written as each point finishes (other runs read it).
    lease_timeout_s : float, default 120
        A claim not renewed for this long is taken to belong to a dead run, s.
    wait_for_held : bool, default True
        Wait for points another live run holds instead of returning.
    poll_s : float, default 0.5
        Polling interval while waiting, s.

    Returns
    -------
    dict
        The store's summary (counts by status) with ``problems``, ``wall_s``, ``solved_now`` (points
        this run solved) and ``held_by_other_runs`` (those another live run held when it returned).
    """
    spec = store.spec
    model = spec.model.to_dict()
    statuses = ("pending", "failed") if retry_failed else ("pending",)
    todo = [int(i) for i in store.points_with(*statuses)]
    attempts_at_start = {
        i: int(store.index.loc[i, "attempts"]) if not _na(store.index.loc[i, "attempts"]) else 0 for i in todo
    }
    t0 = time.perf_counter()
    total = len(todo)
    run = RunIdentity.new()
    solved = 0
    handled = 0
    held: dict[int, dict[str, Any]] = {}
    if total:
        executor = executor_for(jobs, scheduler)
        beat = _Heartbeat(store, run, max(lease_timeout_s / 4.0, 0.05))
        beat.start()
        remaining = list(todo)
        claimed: set[int] = set()

        def args(i: int) -> tuple:
            febio = spec.solver == "febio"
            workdir = str(store.root / "febio" / f"{i:05d}") if febio else None
            checkpoint = None if febio else str(store.checkpoint_path(i))
            values = spec.design.points[i].tolist()
            return (
                i,
                model,
                spec.solver,
                spec.design.parameters,
                values,
                timeout_s,
                workdir,
                spec.equilibrium_rel,
                checkpoint,
            )

        try:
            while remaining or claimed:
                # claim and submit up to the executor's capacity
                while executor.in_flight() < executor.capacity() and remaining:
                    outcome = store.claims.claim_next(
                        [i for i in remaining if i not in claimed], run, lease_timeout_s, attempts_at_start
                    )
                    for i in outcome.finished_elsewhere:
                        remaining.remove(i)
                        handled += 1
                    held = outcome.held
                    if outcome.point is None:
                        break
                    i = outcome.point
                    claimed.add(i)
                    with beat.guard:
                        beat.held.add(i)
                    executor.submit(i, args(i))
                if not claimed:
                    if not remaining or not wait_for_held:
                        break
                    time.sleep(poll_s)  # every left point is held by another live run
                    continue
                for i, row in executor.collect(poll_s):
                    with beat.guard:
                        beat.held.discard(i)
                        lost = i in beat.lost
                        beat.lost.discard(i)
                    solved += _finish(store, run, i, row, lost)  # a full disk raises: lease released below
                    claimed.discard(i)
                    remaining.remove(i)
                    handled += 1
                    if progress is not None:
                        progress(handled, total, store.counts())
        finally:
            beat.stop.set()
            executor.close()
            for i in list(claimed):
                store.claims.release(i, run)  # interrupted: the points go back to the pool
            store.refresh()
            held = {
                i: lease
                for i, lease in held.items()
                if i in remaining and str(store.index.loc[i, "status"]) != "done"
            }
    summary = store.summary(lease_timeout_s)
    summary["problems"] = [p.to_dict() for p in store.problems]
    return summary | {
        "wall_s": time.perf_counter() - t0,
        "solved_now": solved,
        "held_by_other_runs": [
            {"point": i, "host": lease.get("host"), "pid": lease.get("pid")}
            for i, lease in sorted(held.items())
        ],
    }


def _na(value: Any) -> bool:
    import pandas as pd

    return value is None or bool(pd.isna(value))


def _finish(
    store: CampaignStore, run: RunIdentity, i: int, row: dict[str, Any] | BaseException, lost: bool
) -> int:
    """Record one point's outcome (its files written, then its index row, then its lease
    released); returns 1 when the point was solved here and recorded."""
    if isinstance(row, BaseException):
        row = {
            "status": "failed",
            "error": f"worker lost: {type(row).__name__}: {row}"[:2000],
            "finished": time.strftime("%Y-%m-%dT%H:%M:%S"),
        }
    row = dict(row)
    row.pop("point", None)
    result, partial = row.pop("result", None), row.pop("partial", None)
    with store.locked():
        if lost or not store.claims.holds(i, run):
            store.refresh()
            if str(store.index.loc[i, "status"]) == "done":  # another run took it over and finished
                return 0
    store.save_point(i, result, partial, row)
    store.write_index()
    store.claims.release(i, run)
    return 1


def default_runs_dir() -> Path:
    return Path("runs")


def run_named_campaign(
    name: str,
    design: Design | str,
    model: ModelSpec,
    *,
    runs_dir: str | Path = "runs",
    solver: str = "embedded",
    jobs: int = 0,
    scheduler: str | None = None,
    retry_failed: bool = False,
    timeout_s: float | None = None,
    progress: Callable[[int, int, dict[str, int]], None] | None = None,
    lease_timeout_s: float = DEFAULT_LEASE_TIMEOUT_S,
    wait_for_held: bool = True,
    equilibrium_rel: float | None = None,
    verify_only: bool = False,
) -> dict[str, Any]:
    """Create (or resume) the campaign ``runs_dir/name`` and solve what is left.

    Parameters
    ----------
    name : str
        The campaign's name: its folder under ``runs_dir``.
    design : Design or str
        The points, or a grid option such as ``'paper'``, ``'lhs:200:7'``,
        ``'c1=2:20:10,c5=100:500:9'`` (:func:`design_from_option`).
    model : ModelSpec
        The forward model every point is solved with.
    runs_dir : str or pathlib.Path, default "runs"
        Where campaigns live.
    solver : {"embedded", "febio"}, default "embedded"
        The forward solver.
    jobs : int, default 0
        Worker processes; 0 means all cores.
    scheduler : str, optional
        Address of a dask scheduler.
    retry_failed : bool, default False
        Solve the failed points again too.
    timeout_s : float, optional
        Time limit of one point's solve, s.
    progress : callable, optional
        Called as ``progress(handled, total, counts)`` after each point.
    lease_timeout_s : float, default 120
        A claim not renewed for this long belongs to a dead run, s.
    wait_for_held : bool, default True
        Wait for points another live run holds.
    equilibrium_rel : float, optional
        FEBio: the fraction of a step's own force its imbalance may reach before the step is
        flagged (default 2 %).
    verify_only : bool, default False
        Check the store's files and report, repairing and solving nothing.

    Returns
    -------
    dict
        The summary of :func:`run_campaign` with ``name``, ``root`` and ``jobs`` (with
        ``verify_only``: the store's summary, ``verify_only`` True and ``solved_now`` 0).

    Raises
    ------
    CampaignError
        If the store was started with another spec (naming the fields), or, with ``verify_only``,
        there is no campaign at ``runs_dir/name``.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> summary = ins.run_named_campaign("small", "lhs:20:7", ins.ModelSpec(), jobs=2)  # doctest: +SKIP
    >>> summary["solved_now"]  # doctest: +SKIP
    20
    """
    if isinstance(design, str):
        design = design_from_option(design)
    extra = {"equilibrium_rel": float(equilibrium_rel)} if solver == "febio" and equilibrium_rel else {}
    spec = CampaignSpec(name, design, model, solver, extra)
    if verify_only:
        root = Path(runs_dir) / name
        if not (root / "campaign.json").is_file():
            raise CampaignError(f"{root}: no campaign here (campaign.json missing)")
        store = CampaignStore.open(root, repair=False)
        diff = store.spec.differences(spec)
        if diff:
            raise CampaignError(f"campaign {name!r} in {root} was started with a different {', '.join(diff)}")
        return store.summary(lease_timeout_s) | {
            "name": name,
            "root": str(root),
            "verify_only": True,
            "solved_now": 0,
            "wall_s": 0.0,
        }
    store = CampaignStore.create_or_open(runs_dir, spec)
    if solver == "febio":
        find_febio()  # absent FEBio is a clear error before anything runs
    n_jobs = jobs if jobs > 0 else (os.cpu_count() or 1)
    summary = run_campaign(
        store,
        n_jobs,
        scheduler,
        retry_failed=retry_failed,
        timeout_s=timeout_s,
        progress=progress,
        lease_timeout_s=lease_timeout_s,
        wait_for_held=wait_for_held,
    )
    return summary | {"name": name, "root": str(store.root), "jobs": n_jobs}
