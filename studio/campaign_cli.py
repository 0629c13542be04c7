"""``indent-studio campaign run | status | export``."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from .. import campaign  # lazy: a command imports what it runs
from ..atomic_write import atomic_write, strict_json
from ..campaign.errors import CampaignError, DesignError
from ..forward.spec import SpecError
from .options import (
    JOBS,
    JSON,
    MODEL_FLAGS,
    RUNS_DIR,
    SCHEDULER,
    SOLVER,
    ModelOptions,
    SolverName,
    err,
    fail,
    model_options,
)
from .progress import step_progress

campaign_app = typer.Typer(help="Many simulations over a parameter design, resumable, in parallel.")

NAME = Annotated[str, typer.Option(help="campaign name: its folder under --runs-dir")]


def _print_summary(summary: dict[str, Any], title: str) -> None:
    table = Table(title=title)
    keys = (
        "points",
        "done",
        "failed",
        "pending",
        "solved_now",
        "solver_wall_s",
        "median_point_s",
        "store_bytes",
    )
    for key in keys:
        if key not in summary:
            continue
        value = summary.get(key)
        if key == "done" and summary.get("done_with_flagged_steps"):
            value = (
                f"{value} ({summary['done_with_flagged_steps']} done, {summary['flagged_steps']} steps "
                "flagged off equilibrium: null)"
            )
        table.add_row(key, f"{value:.3g}" if isinstance(value, float) else str(value))
    if summary.get("febio_reruns"):
        table.add_row("febio_reruns", f"{summary['febio_reruns']} ({summary['febio_rerun_s']:.3g} s)")
    Console().print(table)
    out = Console()
    for f in summary.get("failures", [])[:10]:
        out.print(f"failed point {f['point']}: {f['error']}", soft_wrap=True, highlight=False)
    for p in summary.get("problems", []):
        where = f"point {p['point']}: " if p.get("point") is not None else ""
        out.print(
            f"check failed: {where}{p['file']}: {p['reason']}; {p['action']}",
            soft_wrap=True,
            highlight=False,
        )
    if summary.get("hashed_now"):
        out.print(
            f"{summary['hashed_now']} point files without a recorded hash (an older store, or a run "
            "killed before its index row) checked to load, hashed and recorded",
            highlight=False,
        )
    for c in summary.get("claims", []):
        state = "running" if c["alive"] else "expired (the next run takes it over)"
        out.print(
            f"point {c['point']} held by {c['host']} pid {c['pid']} (run started {c['run_started']}, "
            f"heartbeat {c['heartbeat_age_s']:g} s ago): {state}",
            highlight=False,
        )
    failed = {f["point"] for f in summary.get("failures", [])}
    pending = [i for i in summary.get("resumable", []) if i not in failed]
    if pending:
        points = ", ".join(str(i) for i in pending[:10])
        out.print(
            f"{len(pending)} unfinished points resume from their last finished step (checkpoints/): {points}",
            highlight=False,
        )
    kept = [i for i in summary.get("resumable", []) if i in failed]  # a failed point keeps its checkpoint
    if kept:
        points = ", ".join(str(i) for i in kept[:10])
        out.print(
            f"{len(kept)} failed points resume from their last finished step only with --retry-failed: {points}",
            highlight=False,
        )
    for r in summary.get("resumable_at", [])[:10]:
        where = (
            "its checkpoint is unreadable (solved from its start)"
            if r.get("unreadable")
            else f"{r['depth_mm']:g} of {r['of_mm']:g} mm ({r['steps_done']} of {r['steps']} steps) after "
            f"{r['elapsed_s']:.0f} s of solver time"
        )
        state = " (failed)" if r["point"] in failed else ""
        out.print(f"point {r['point']}{state} at its last checkpoint: {where}", highlight=False)
    for h in summary.get("held_by_other_runs", []):
        out.print(
            f"point {h['point']}: left to the run holding it ({h['host']} pid {h['pid']})", highlight=False
        )


GRID = Annotated[
    str,
    typer.Option(
        help="paper | FILE.csv | c1=LO:HI:N,c5=LO:HI:N | lhs:N[:SEED] | sobol:N[:SEED]; "
        "mu=LO:HI:N[:log] adds friction as a third axis (:log spaces it in log)"
    ),
]
TIMEOUT = Annotated[float | None, typer.Option(help="per-point timeout, s")]
RETRY_FAILED = Annotated[bool, typer.Option(help="solve the failed points again")]
VERIFY_ONLY = Annotated[
    bool,
    typer.Option(help="check the store's files against their hashes and report; repair and solve nothing"),
]
WAIT = Annotated[
    bool,
    typer.Option(
        help="wait for the points another run of this campaign holds (--no-wait: return, listing them)"
    ),
]
LEASE_TIMEOUT = Annotated[
    float, typer.Option(help="s without a heartbeat after which a run's claim on a point is taken over")
]
EQUILIBRIUM_TOL = Annotated[
    float,
    typer.Option(
        help="FEBio: flag a step whose imbalance exceeds this % of the step's own force (its force null)"
    ),
]


@campaign_app.command("run")
# the material of the base spec is a placeholder: each point sets its own
@model_options(*(f for f in MODEL_FLAGS if f not in ("c1", "c5")), c1=1.0, c5=1.0)
def run(
    name: NAME,
    grid: GRID = "paper",
    *,
    model: ModelOptions,
    solver: SOLVER = SolverName.embedded,
    jobs: JOBS = 0,
    scheduler: SCHEDULER = None,
    timeout: TIMEOUT = None,
    retry_failed: RETRY_FAILED = False,
    verify_only: VERIFY_ONLY = False,
    wait: WAIT = True,
    lease_timeout: LEASE_TIMEOUT = 120.0,
    equilibrium_tol: EQUILIBRIUM_TOL = 2.0,
    runs_dir: RUNS_DIR = Path("runs"),
    as_json: JSON = False,
) -> None:
    """Run (or resume) a campaign; finished points are skipped, failures recorded. Every point
    file is checked against its hash first: one that fails is named and solved again."""
    where = f"dask {scheduler}" if scheduler else f"{jobs or 'all'} processes"
    err.print(f"campaign {name}: grid {grid}, {where}, store {Path(runs_dir) / name}", highlight=False)
    with step_progress(err, f"campaign {name}", 1) as bar:
        try:
            summary = campaign.run_named_campaign(
                name,
                grid,
                model.spec(),
                runs_dir=runs_dir,
                solver=solver.value,
                jobs=jobs,
                scheduler=scheduler,
                retry_failed=retry_failed,
                timeout_s=timeout,
                progress=_points_progress(bar),
                lease_timeout_s=lease_timeout,
                wait_for_held=wait,
                equilibrium_rel=equilibrium_tol / 100.0,
                verify_only=verify_only,
            )
        except (DesignError, CampaignError, SpecError, ValueError, FileNotFoundError, OSError) as exc:
            fail(f"campaign {name}: {exc} (finished points are kept in {Path(runs_dir) / name})", as_json)
    if as_json:
        print(strict_json(summary))
        return
    title = f"campaign {name}: " + ("checked" if verify_only else f"{summary['wall_s']:.1f} s")
    _print_summary(summary, title)


def _points_progress(bar) -> Callable[[int, int, dict[str, int]], None]:
    """The runner's progress on ``bar``: points finished, done and failed, and the pace (points a
    minute, or minutes a point where a point takes longer: a level-3 friction campaign's said
    "0.0 points/min")."""
    t0 = time.perf_counter()

    def report(done: int, total: int, counts: dict[str, int]) -> None:
        rate = done / max(time.perf_counter() - t0, 1e-9) * 60.0
        pace = f"{rate:.1f} points/min" if rate >= 1.0 or rate == 0.0 else f"{1.0 / rate:.1f} min a point"
        bar.update(done, f"done {counts['done']} failed {counts['failed']}  {pace}", total)

    return report


@campaign_app.command("status")
def status(name: NAME, runs_dir: RUNS_DIR = Path("runs"), as_json: JSON = False) -> None:
    """Done (and with how many FEBio steps flagged), failed and pending points, wall time,
    failures with their reasons, the point files that fail their check (reported, not repaired:
    `campaign run` solves them again) and the runs holding points (host, pid, start)."""
    try:
        store = campaign.open_campaign(name, runs_dir, repair=False)
    except (CampaignError, OSError) as exc:
        fail(str(exc), as_json)
    summary = store.summary()
    if as_json:
        print(strict_json(summary))
        return
    _print_summary(summary, f"campaign {name} ({store.root})")


@campaign_app.command("export")
def export(
    name: NAME,
    out: Annotated[Path, typer.Option(help="table file: .parquet or .csv")],
    runs_dir: RUNS_DIR = Path("runs"),
    as_json: JSON = False,
) -> None:
    """A tidy table of force per step (point, c1, c5, step, depth_mm, force_mN) for pandas."""
    try:
        store = campaign.open_campaign(name, runs_dir)
        table = campaign.force_table(store)
        if out.suffix not in (".csv", ".parquet"):
            raise ValueError(f"{out}: use a .parquet or .csv file name")
        csv = out.suffix == ".csv"
        atomic_write(
            out, table.to_csv(index=False) if csv else lambda tmp: table.to_parquet(tmp, index=False)
        )
    except (CampaignError, ValueError, OSError) as exc:
        fail(str(exc), as_json)
    payload = {
        "table": str(out),
        "rows": len(table),
        "points": int(table["point"].nunique()) if len(table) else 0,
    }
    if as_json:
        print(strict_json(payload))
    else:
        Console().print(f"wrote {payload['rows']} rows ({payload['points']} points) to {out}")
