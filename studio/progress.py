"""Progress on stderr: a live rich bar on a terminal, one line per update otherwise (CI logs,
notebooks, files), so a long run always says where it stands."""

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

    def update(self, completed: int, info: str = "", total: int | None = None) -> None:
        self.total = total if total is not None else self.total
        elapsed = time.perf_counter() - self.t0
        eta = elapsed / completed * (self.total - completed) if completed else float("nan")
        self.console.print(
            f"{self.label}: {completed}/{self.total} {info}  elapsed {elapsed:.1f} s, eta {eta:.1f} s",
            highlight=False,
        )


class _BarProgress:
    def __init__(self, progress: Progress, task: int) -> None:
        self.progress, self.task = progress, task

    def update(self, completed: int, info: str = "", total: int | None = None) -> None:
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
