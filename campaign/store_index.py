"""A campaign store's index as one run holds it (:class:`StoreIndex`): its rows in memory, the
store's lock, and every update written under that lock and merged with what other runs wrote.
:class:`~indentation_studio.campaign.store.CampaignStore` is one; its file checks
(:mod:`~indentation_studio.campaign.store_checks`) and claims
(:mod:`~indentation_studio.campaign.claims`) work on it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from filelock import FileLock

from .checksums import Problem, write_checked
from .index import STATUSES, merge_rows, read_index, with_check_columns
from .layout import StoreLayout
from .leases import LOCK_TIMEOUT_S, StoreLock
from .spec import CampaignSpec

__all__ = ["StoreIndex"]


class StoreIndex(StoreLayout):
    """A store's spec and index, and the lock its updates are made under (built with the
    folder, the spec and the index :class:`~.store.CampaignStore` takes)."""

    def __init__(self, root: Path, spec: CampaignSpec, index: pd.DataFrame) -> None:
        super().__init__(root)
        self.spec = spec
        self.index = with_check_columns(index)
        self.problems: list[Problem] = []
        self.hashed_now: list[int] = []  # files of an older store hashed (after loading) by this open
        self._dirty: set[int] = set()
        self.lock = FileLock(self.lock_path, timeout=LOCK_TIMEOUT_S)

    def locked(self) -> StoreLock:
        """The store's lock, as a context (short critical sections only).

        A lock not had in ``LOCK_TIMEOUT_S`` is a clear error.
        """
        return StoreLock(self.lock, self.root)

    def record(self, point: int, row: dict[str, Any], write: bool = True) -> None:
        """Set fields of a point's index row.

        Parameters
        ----------
        point : int
            The point.
        row : dict
            Column -> value.
        write : bool, default True
            Write the index now (:meth:`write_index`).
        """
        for k, v in row.items():
            self.index.loc[point, k] = v
        self._dirty.add(int(point))
        if write:
            self.write_index()

    def write_index(self) -> None:
        """Write this run's changed rows into the index on disk, merged with what other runs wrote.

        Made under the lock; ``self.index`` becomes the merged table.
        """
        path = self.index_path
        with self.locked():
            merged = self.merged()
            write_checked(path, lambda tmp: merged.to_parquet(tmp, index=False))
            self.index = merged
            self._dirty.clear()

    def refresh(self) -> None:
        """Read what other runs recorded (this run's unwritten rows kept)."""
        with self.locked():
            self.index = self.merged()

    def merged(self) -> pd.DataFrame:
        """The index on disk with this run's changed rows merged in (call under the lock).

        Returns
        -------
        pandas.DataFrame
            The merged index (this run's copy where the one on disk is unreadable or damaged).
        """
        disk, problems = read_index(self.index_path, self.spec)
        if problems:  # unreadable or damaged on disk: ours is the checked one
            disk = self.index.copy()
        return merge_rows(disk, self.index, sorted(self._dirty))

    def counts(self) -> dict[str, int]:
        """The number of points of each status.

        Returns
        -------
        dict of str to int
            Status (``pending``, ``done``, ``failed``) -> count.
        """
        c = self.index["status"].astype(str).value_counts()
        return {s: int(c.get(s, 0)) for s in STATUSES}

    def points_with(self, *statuses: str) -> np.ndarray:
        """The points whose status is one of ``statuses``.

        Parameters
        ----------
        *statuses : str
            Statuses, e.g. ``"done"``, ``"pending"``, ``"failed"``.

        Returns
        -------
        numpy.ndarray
            Their point numbers, ascending.
        """
        return self.index.loc[self.index["status"].astype(str).isin(statuses), "point"].to_numpy(int)
