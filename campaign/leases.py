"""Claims and leases: a run (:class:`RunIdentity`) claims a point before solving it by writing a
lease ``leases/<n>.json`` (host, pid, start time, a heartbeat renewed while it solves) under a
short file lock on the store (:class:`StoreLock`); other runs skip the points a live lease holds
(:func:`lease_alive`). A lease whose heartbeat is older than the lease timeout, or whose process
is gone (same host), belongs to a run that died and is taken over. :class:`LeaseFiles` reads and
writes one store's leases, claims a point (:meth:`LeaseFiles.claim_first`) and releases it."""

from __future__ import annotations

import json
import os
import socket
import time
import uuid
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from filelock import FileLock, Timeout

from .checksums import write_checked
from .errors import CampaignError
from .layout import StoreLayout

__all__ = [
    "DEFAULT_LEASE_TIMEOUT_S",
    "LOCK_TIMEOUT_S",
    "ClaimOutcome",
    "LeaseFiles",
    "RunIdentity",
    "StoreLock",
    "lease_alive",
]

#: How long a run waits for the store's lock (held only for short updates) before giving up.
LOCK_TIMEOUT_S = 120.0
#: A lease whose heartbeat is older than this belongs to a run that died (default; ``campaign
#: run --lease-timeout``). Heartbeats are renewed every quarter of it.
DEFAULT_LEASE_TIMEOUT_S = 120.0
#: What an unreadable lease file reads as: an expired lease of no run.
_UNREADABLE = {"heartbeat": 0.0, "host": "?", "pid": -1, "run_id": "?"}


@dataclass(frozen=True)
class RunIdentity:
    """Who holds a claim: one ``campaign run`` (its own id, host, pid and start time)."""

    run_id: str
    host: str
    pid: int
    started: float  # epoch s

    @classmethod
    def new(cls) -> RunIdentity:
        """This process's identity, with a fresh run id."""
        return cls(uuid.uuid4().hex[:12], socket.gethostname(), os.getpid(), time.time())

    def lease(self, point: int) -> dict[str, Any]:
        """The lease this run writes to claim ``point`` (its heartbeat now)."""
        return {
            "point": point,
            "run_id": self.run_id,
            "host": self.host,
            "pid": self.pid,
            "started": self.started,
            "claimed": time.time(),
            "heartbeat": time.time(),
        }


@dataclass
class ClaimOutcome:
    """What :meth:`LeaseFiles.claim_first` found: the point claimed (or None), the candidates
    finished by another run meanwhile, and those held by another live run (with its lease)."""

    point: int | None
    finished_elsewhere: set[int]
    held: dict[int, dict[str, Any]]


def _iso(t: float) -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(t))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


def lease_alive(lease: dict[str, Any], timeout_s: float, now: float | None = None) -> bool:
    """A lease is alive while its heartbeat is younger than ``timeout_s`` and, on this host, its
    process still runs."""
    now = time.time() if now is None else now
    try:
        if now - float(lease["heartbeat"]) > timeout_s:
            return False
        if lease["host"] == socket.gethostname() and int(lease["pid"]) != os.getpid():
            return _pid_alive(int(lease["pid"]))
    except (KeyError, TypeError, ValueError):
        return False
    return True


class StoreLock:
    """A store's file lock as a context, its timeout a :class:`CampaignError`.

    Parameters
    ----------
    lock : filelock.FileLock
        The lock (``<root>/.lock``).
    root : pathlib.Path
        The store, named in the error.
    """

    def __init__(self, lock: FileLock, root: Path) -> None:
        self.lock, self.root = lock, root

    def __enter__(self) -> None:
        try:
            self.lock.acquire()
        except Timeout as exc:
            raise CampaignError(
                f"{self.root}: the store's lock {self.lock.lock_file} was not free for {LOCK_TIMEOUT_S:g} s"
            ) from exc

    def __exit__(self, *exc: object) -> None:
        self.lock.release()


class LeaseFiles:
    """The lease files of one store, ``leases/<point>.json``.

    Parameters
    ----------
    layout : StoreLayout
        The store's files.
    """

    def __init__(self, layout: StoreLayout) -> None:
        self.layout = layout

    def path(self, point: int) -> Path:
        """The lease file of ``point``."""
        return self.layout.lease_path(point)

    def read(self, point: int) -> dict[str, Any] | None:
        """The lease of ``point`` (None when unclaimed; an unreadable one as an expired lease)."""
        try:
            return json.loads(self.path(point).read_text())
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return dict(_UNREADABLE)

    def all(self) -> dict[int, dict[str, Any]]:
        """Every lease file, by point (an unreadable one as an expired lease)."""
        out: dict[int, dict[str, Any]] = {}
        for f in self.layout.leases_dir.glob("[0-9]*.json"):
            try:
                out[int(f.stem)] = json.loads(f.read_text())
            except (OSError, ValueError):
                out[int(f.stem)] = dict(_UNREADABLE)
        return out

    def write(self, point: int, lease: dict[str, Any]) -> None:
        """Write the lease of ``point`` (atomically; a full disk is a clear error)."""
        write_checked(self.path(point), json.dumps(lease))

    def held_by(self, point: int, run: RunIdentity) -> bool:
        """Whether ``run``'s lease is the one on ``point``."""
        lease = self.read(point)
        return lease is not None and lease.get("run_id") == run.run_id

    def held_elsewhere(
        self, point: int, run: RunIdentity, lease_timeout_s: float, now: float | None = None
    ) -> dict[str, Any] | None:
        """The lease of another live run on ``point``, or None (unclaimed, ``run``'s, or expired).

        Parameters
        ----------
        point : int
            The point.
        run : RunIdentity
            The run asking.
        lease_timeout_s : float
            A lease not renewed for this long belongs to a dead run, s.
        now : float, optional
            The time to judge the heartbeat by (epoch s; default now).

        Returns
        -------
        dict or None
            The other run's lease.
        """
        lease = self.read(point)
        if lease is None or lease.get("run_id") == run.run_id or not lease_alive(lease, lease_timeout_s, now):
            return None
        return lease

    def claim_first(
        self,
        candidates: Iterable[int],
        run: RunIdentity,
        lease_timeout_s: float,
        finished: Collection[int],
        solved_meanwhile: Callable[[int], bool],
    ) -> ClaimOutcome:
        """Claim the first of ``candidates`` that is not finished and no other live run holds, by
        writing ``run``'s lease on it (call under the store's lock: two runs never claim the same
        point).

        Parameters
        ----------
        candidates, run, lease_timeout_s
            As :meth:`~indentation_studio.campaign.claims.StoreClaims.claim_next` takes them.
        finished : collection of int
            Points already finished (skipped before their lease is read).
        solved_meanwhile : callable
            Asked of a point no live run holds, just before claiming it: True when it was solved
            meanwhile (the store's check of a file a dead run left without its index row).

        Returns
        -------
        ClaimOutcome
            What was claimed, found finished, held elsewhere.
        """
        done: set[int] = set()
        held: dict[int, dict[str, Any]] = {}
        now = time.time()
        for i in candidates:
            if i in finished:
                done.add(i)
                continue
            lease = self.held_elsewhere(i, run, lease_timeout_s, now)
            if lease is not None:
                held[i] = lease
                continue
            if solved_meanwhile(i):
                done.add(i)
                continue
            self.write(i, run.lease(i))
            return ClaimOutcome(i, done, held)
        return ClaimOutcome(None, done, held)

    def release(self, point: int, run: RunIdentity) -> None:
        """Remove ``run``'s lease on ``point``, another run's left alone (call under the store's
        lock: :meth:`~indentation_studio.campaign.claims.StoreClaims.release`)."""
        if self.held_by(point, run):
            self.path(point).unlink(missing_ok=True)

    def renew(self, points: list[int], run: RunIdentity) -> set[int]:
        """Renew ``run``'s heartbeat on ``points`` (call under the lock); the points whose lease
        another run took over are returned."""
        lost: set[int] = set()
        for i in points:
            lease = self.read(i)
            if lease is None or lease.get("run_id") != run.run_id:
                lost.add(i)
                continue
            lease["heartbeat"] = time.time()
            try:
                write_checked(self.path(i), json.dumps(lease))
            except OSError:
                pass  # a full disk: the old heartbeat stands; the timeout is long
        return lost

    def holders(self, lease_timeout_s: float = DEFAULT_LEASE_TIMEOUT_S) -> list[dict[str, Any]]:
        """The claims and whether each holding run is alive
        (:meth:`~indentation_studio.campaign.claims.StoreClaims.holders`)."""
        now = time.time()
        out = []
        for i, lease in sorted(self.all().items()):
            try:
                started, beat = float(lease.get("started", 0.0)), float(lease.get("heartbeat", 0.0))
            except (TypeError, ValueError):
                started, beat = 0.0, 0.0
            out.append(
                {
                    "point": i,
                    "host": lease.get("host"),
                    "pid": lease.get("pid"),
                    "run_started": _iso(started),
                    "heartbeat_age_s": round(now - beat, 1),
                    "alive": lease_alive(lease, lease_timeout_s, now),
                }
            )
        return out

    def alive_points(self, lease_timeout_s: float = DEFAULT_LEASE_TIMEOUT_S) -> set[int]:
        """The points a live run holds."""
        return {int(k) for k, lease in self.all().items() if lease_alive(lease, lease_timeout_s)}
