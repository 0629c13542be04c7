"""A store's claims (:class:`StoreClaims`, ``store.claims``): nothing is done twice. A run claims
a point before solving it by writing a lease under a short file lock on the store, and other runs
of the same campaign (on this machine or others sharing the folder) skip the points held by a
live lease. The lease files themselves are :mod:`~indentation_studio.campaign.leases`'s."""

from __future__ import annotations

from typing import Any

from .index import as_int
from .leases import DEFAULT_LEASE_TIMEOUT_S, ClaimOutcome, LeaseFiles, RunIdentity
from .store_checks import recorded_from_its_file
from .store_index import StoreIndex

__all__ = ["StoreClaims"]


class StoreClaims:
    """The claims on one store's points, each made under the store's lock.

    Parameters
    ----------
    store : StoreIndex
        The store (its lock, its index and its files).
    """

    def __init__(self, store: StoreIndex) -> None:
        self.store = store
        self.files = LeaseFiles(store)

    def leases(self) -> dict[int, dict[str, Any]]:
        """Every lease file, by point (an unreadable one as an expired lease).

        Returns
        -------
        dict of int to dict
            Point -> its lease (host, pid, run, start time, heartbeat).
        """
        return self.files.all()

    def claim_next(
        self,
        candidates: list[int],
        run: RunIdentity,
        lease_timeout_s: float = DEFAULT_LEASE_TIMEOUT_S,
        attempts_at_start: dict[int, int] | None = None,
    ) -> ClaimOutcome:
        """Claim the first of ``candidates`` that no live run holds and no run has finished since.

        Made under the lock: two runs never claim the same point.

        Parameters
        ----------
        candidates : list of int
            The points to try, in order.
        run : RunIdentity
            The claiming run.
        lease_timeout_s : float, default 120
            A lease not renewed for this long belongs to a dead run and is taken over, s.
        attempts_at_start : dict of int to int, optional
            Each point's attempts when this run started: a point another run attempted since is
            not claimed again.

        Returns
        -------
        ClaimOutcome
            The point claimed (or None), the candidates finished elsewhere meanwhile, and those
            another live run holds.
        """
        store = self.store
        with store.locked():
            store.index = store.merged()
            attempts = store.index["attempts"].map(lambda a: int(as_int(a) or 0)).to_numpy()
            status = store.index["status"].astype(str).to_numpy()
            finished = {
                i
                for i in candidates
                if status[i] == "done"
                or (attempts_at_start is not None and attempts[i] > attempts_at_start.get(i, 0))
            }
            return self.files.claim_first(
                candidates, run, lease_timeout_s, finished, lambda i: recorded_from_its_file(store, i)
            )

    def renew(self, points: list[int], run: RunIdentity) -> set[int]:
        """Renew this run's leases (their heartbeat).

        Parameters
        ----------
        points : list of int
            The points the run holds.
        run : RunIdentity
            The run.

        Returns
        -------
        set of int
            The points whose lease another run took over.
        """
        with self.store.locked():
            return self.files.renew(points, run)

    def holds(self, point: int, run: RunIdentity) -> bool:
        """Whether ``run`` holds the lease of ``point`` (True when the point's lease names it)."""
        return self.files.held_by(point, run)

    def release(self, point: int, run: RunIdentity) -> None:
        """Give up ``run``'s claim on ``point`` (its lease file removed, under the lock).

        Parameters
        ----------
        point : int
            The point.
        run : RunIdentity
            The run; a lease another run holds is left alone.
        """
        with self.store.locked():
            self.files.release(point, run)

    def holders(self, lease_timeout_s: float = DEFAULT_LEASE_TIMEOUT_S) -> list[dict[str, Any]]:
        """The claims on the store and whether each holding run is alive.

        Parameters
        ----------
        lease_timeout_s : float, default 120
            A claim whose heartbeat is older is expired (taken over by the next run), s.

        Returns
        -------
        list of dict
            Per claim: point, host, pid, start time of the holding run, heartbeat age, alive.
        """
        return self.files.holders(lease_timeout_s)
