"""Progress on stderr: a live rich bar on a terminal, one line per update otherwise (CI logs,
notebooks, files), so a long run always says where it stands.

A run resumed from a checkpoint first reports the step after the ones it read back: its time
left is the rate of the work done since it started (the first update counts as one unit), not
of the whole count (a contact-L4 run resumed at step 17 said "eta 622 s" with 8 steps of about
1,100 s each left)."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn


class _LineProgress:
    def __init__(self, console: Console, label: str, total: int) -> None:
        self.console, self.label, self.total = console, label, total
        self.t0 = time.perf_counter()
        self.start: int | None = None  # the count before this run's first unit of work

    def update(self, completed: int, info: str = "", total: int | None = None) -> None:
        self.total = total if total is not None else self.total
        elapsed = time.perf_counter() - self.t0
        if self.start is None and completed:
            self.start = completed - 1
        done_here = completed - (self.start or 0)
        eta = elapsed / done_here * (self.total - completed) if done_here > 0 else float("nan")
        self.console.print(
            f"{self.label}: {completed}/{self.total} {info}  elapsed {elapsed:.1f} s, eta {eta:.1f} s",
            highlight=False,
        )


class _BarProgress:
    def __init__(self, progress: Progress, task: int) -> None:
        self.progress, self.task = progress, task
        self.started = False

    def update(self, completed: int, info: str = "", total: int | None = None) -> None:
        if not self.started and completed > 1:  # resumed: the bar's rate starts here
            self.progress.reset(self.task, completed=completed - 1, total=total)
        self.started = True
        self.progress.update(self.task, completed=completed, info=info, total=total)


@contextmanager
def step_progress(console: Console, label: str, total: int) -> Iterator[_LineProgress | _BarProgress]:
    """Context manager yielding an object with ``update(completed, info, total=None)`` (a ``total``
    given there replaces the one given here)."""
    if not console.is_terminal:
        yield _LineProgress(console, label, total)
        return
    with Progress(
        TextColumn(f"[bold]{label}[/]"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
    ) as bar:
        yield _BarProgress(bar, bar.add_task(label, total=total, info=""))
