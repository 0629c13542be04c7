"""The campaign store ``runs/<name>/`` (:class:`CampaignStore`): a campaign's spec, its index of
points and their result files, kept by concern in modules of their own, as emcee keeps a
backend's interface apart from each backend:

- :mod:`~indentation_studio.campaign.layout`: where each file of the store lives;
- :mod:`~indentation_studio.campaign.spec`: what the campaign computes (``campaign.json``);
- :mod:`~indentation_studio.campaign.checksums`: the sha256 and size of each file as written,
  the check of a point file, setting a failed one aside, and a full disk named as such;
- :mod:`~indentation_studio.campaign.index`: ``index.parquet``, one row per point, checked
  against the design and merged with what other runs wrote;
- :mod:`~indentation_studio.campaign.leases`: claims on points and their leases (claiming,
  renewing, releasing); the store calls them under its lock.

Nothing is trusted blindly (:meth:`CampaignStore.verify`): opening a store for a run checks
every point file against its recorded sha256 and size (a file of an older store, without them,
is first checked to load and then hashed), and a file that fails (missing, cut short, changed,
unreadable) is named, moved to ``damaged/`` and its point solved again. An index that is
unreadable, or has a row missing, repeated or of another point, is rebuilt from the point files;
``campaign.json`` is checked against its sha256. ``campaign status`` makes the same checks and
only reports.

Nothing is done twice (:meth:`CampaignStore.claim_next`): a run claims a point before solving it
by writing a lease under a short file lock on the store, and other runs of the same campaign (on
this machine or others sharing the folder) skip the points held by a live lease. Every index
update is made under the lock and merged with what other runs wrote.
"""

from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from filelock import FileLock

from .. import __version__
from ..forward.mesh import build_mesh
from ..forward.result import SimulationResult
from .checksums import (
    Problem,
    check_point_file,
    file_digest,
    full_disk_as_error,
    read_spec,
    set_aside,
    write_checked,
    write_spec,
)
from .errors import CampaignError
from .index import (
    PENDING_ROW,
    STATUSES,
    as_int,
    fresh_index,
    is_missing,
    merge_rows,
    read_index,
    result_row,
    with_check_columns,
)
from .layout import StoreLayout
from .leases import (
    DEFAULT_LEASE_TIMEOUT_S,
    LOCK_TIMEOUT_S,
    ClaimOutcome,
    LeaseFiles,
    RunIdentity,
    StoreLock,
)
from .spec import CampaignSpec

__all__ = ["CampaignStore"]


class CampaignStore(StoreLayout):
    """One campaign folder: its spec, its index of points and their result files.

    Make one with :meth:`create_or_open` (which refuses a spec that differs from the stored one)
    or :meth:`open`. ``open(root, repair=True)`` (what a run does) repairs what its checks find;
    with ``repair=False`` (``campaign status``, the loaders) nothing is written and
    :attr:`problems` lists what failed.

    Parameters
    ----------
    root : pathlib.Path
        The campaign folder (``runs/<name>/``).
    spec : CampaignSpec
        What the campaign computes.
    index : pandas.DataFrame
        One row per point: its parameters, ``status``, ``wall_s``, ``newton_iterations``,
        ``error``, ``finished`` and the file checks.
    """

    def __init__(self, root: Path, spec: CampaignSpec, index: pd.DataFrame) -> None:
        super().__init__(root)
        self.spec = spec
        self.index = with_check_columns(index)
        self.problems: list[Problem] = []
        self.hashed_now: list[int] = []  # files of an older store hashed (after loading) by this open
        self._dirty: set[int] = set()
        self.lock = FileLock(self.lock_path, timeout=LOCK_TIMEOUT_S)
        self._leases = LeaseFiles(self)

    def locked(self) -> StoreLock:
        """The store's lock, as a context (short critical sections only).

        A lock not had in ``LOCK_TIMEOUT_S`` is a clear error.
        """
        return StoreLock(self.lock, self.root)

    # ------------------------------------------------------------ open/create
    @classmethod
    def create_or_open(cls, runs_dir: str | Path, spec: CampaignSpec, repair: bool = True) -> CampaignStore:
        """The store ``runs_dir/<spec.name>``: created when missing, else opened and compared.

        Parameters
        ----------
        runs_dir : str or pathlib.Path
            Where campaigns live.
        spec : CampaignSpec
            What the campaign computes; its mesh's geometry is recorded with it.
        repair : bool, default True
            Repair what the checks find (:meth:`open`).

        Returns
        -------
        CampaignStore
            The store.

        Raises
        ------
        CampaignError
            If the stored campaign was started with another spec, or solved on a mesh that
            changed under the same preset name (naming what changed).
        """
        layout = StoreLayout(Path(runs_dir) / spec.name)
        root = layout.root
        mesh = build_mesh(spec.model).geometry_record()
        spec = replace(spec, extra=spec.extra | {"mesh": mesh})
        if not layout.spec_path.is_file():
            root.mkdir(parents=True, exist_ok=True)
            with FileLock(layout.lock_path, timeout=LOCK_TIMEOUT_S):
                if not layout.spec_path.is_file():  # another run may have created it meanwhile
                    layout.points_dir.mkdir(exist_ok=True)
                    record = spec.to_dict() | {
                        "code_version": __version__,
                        "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
                    }
                    write_spec(layout.spec_path, json.dumps(record, indent=1))
                    store = cls(root, spec, fresh_index(spec))
                    write_checked(layout.index_path, lambda tmp: store.index.to_parquet(tmp, index=False))
        store = cls.open(root, repair=repair)
        stored = store.spec.extra.get("mesh")  # None in a store written before meshes were recorded
        if stored is not None and stored != mesh:
            changed = ", ".join(
                f"{k} {stored.get(k)!r} -> {mesh[k]!r}" for k in mesh if stored.get(k) != mesh[k]
            )
            raise CampaignError(
                f"campaign {spec.name!r} in {root} was solved on another mesh than {mesh['source']} builds "
                f"today ({changed}); its points would not be this mesh's: use another --name, or delete "
                "the folder to start over"
            )
        diff = store.spec.differences(spec)
        if diff:
            raise CampaignError(
                f"campaign {spec.name!r} in {root} was started with a different "
                f"{', '.join(diff)}; use another --name, or delete the folder to start over"
            )
        return store

    @classmethod
    def open(cls, root: str | Path, repair: bool = True) -> CampaignStore:
        """Open the store at ``root``, every check made (module docstring).

        Parameters
        ----------
        root : str or pathlib.Path
            The campaign folder.
        repair : bool, default True
            Fix what fails (a run); else nothing is written and the failures are only listed in
            :attr:`problems` (status, loaders).

        Returns
        -------
        CampaignStore
            The store.

        Raises
        ------
        CampaignError
            If there is no campaign at ``root`` (or its spec cannot be read).
        """
        layout = StoreLayout(root)
        if not layout.spec_path.is_file():
            raise CampaignError(f"{layout.root}: no campaign here (campaign.json missing)")
        spec = read_spec(layout.spec_path, repair)
        store = cls(root, spec, fresh_index(spec))
        if not repair:  # read only (a store on a read-only share too): every write is a rename
            store.index, store.problems = read_index(store.index_path, spec)
            store.verify(repair=False)
            return store
        with store.locked():
            store.index, store.problems = read_index(store.index_path, spec)
            store.verify(repair=True)
            store._clean_temporaries()
            store.write_index()
        return store

    # ------------------------------------------------------------ the checks
    def verify(self, repair: bool = True) -> list[Problem]:
        """Check every point file against its row (module docstring).

        Call under the lock when repairing.

        Parameters
        ----------
        repair : bool, default True
            A file that fails is moved to ``damaged/`` and its point made pending, a file with no
            row or hash (an older store, a run killed between writing the file and the index) is
            checked to load, hashed and recorded done.

        Returns
        -------
        list of Problem
            The problems (also added to :attr:`problems`).
        """
        found: list[Problem] = []
        present = {int(p.stem) for p in self.points_dir.glob("[0-9]*.npz") if p.stem.isdigit()}
        status = self.index["status"].astype(str).to_numpy()
        for i in range(len(self.index)):
            path, row, done = self.result_path(i), self.index.loc[i], status[i] == "done"
            if i not in present:
                if done:
                    found.append(Problem(str(path), "missing (the index says done)", i, "solve again"))
                    if repair:
                        self.record(i, PENDING_ROW, write=False)
                continue
            hashed = done and not is_missing(row["sha256"])
            check = check_point_file(path, (row["sha256"], int(row["bytes"])) if hashed else None)
            if check.reason is not None:
                found.append(Problem(str(path), check.reason, i, "solve again"))
                if repair:
                    set_aside(path, self.damaged_dir)
                    self.record(i, PENDING_ROW, write=False)
            elif repair and check.digest is not None:  # loaded (no hash recorded): hashed now
                self.hashed_now.append(i)
                update: dict[str, Any] = {"sha256": check.digest[0], "bytes": check.digest[1]}
                if not done:
                    update |= result_row(check.result) | {"status": "done", "error": None}
                    update["attempts"] = max(int(as_int(row["attempts"]) or 0), 1)
                self.record(i, update, write=False)
        if not repair:
            for p in found:
                p.action = "reported: `campaign run` solves it again"
        self.problems += found
        return found

    def _clean_temporaries(self) -> None:
        """Temporary files of writes cut short by a kill (never renamed), except those of points
        a live run holds (it may be writing them now)."""
        held = self._leases.alive_points(DEFAULT_LEASE_TIMEOUT_S)
        for stale in self.points_dir.glob("*.tmp"):
            head = stale.name.split(".", 1)[0]
            if head.isdigit() and int(head) in held:
                continue
            stale.unlink(missing_ok=True)

    # ------------------------------------------------------------ index upkeep
    def reconcile(self) -> int:
        """Check the files and repair (what ``open`` does); returns how many problems were found."""
        with self.locked():
            found = self.verify(repair=True)
            self.write_index()
        return len(found)

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
            merged = self._merged()
            write_checked(path, lambda tmp: merged.to_parquet(tmp, index=False))
            self.index = merged
            self._dirty.clear()

    def refresh(self) -> None:
        """Read what other runs recorded (this run's unwritten rows kept)."""
        with self.locked():
            self.index = self._merged()

    def _merged(self) -> pd.DataFrame:
        """The index on disk with this run's changed rows merged in (call under the lock)."""
        disk, problems = read_index(self.index_path, self.spec)
        if problems:  # unreadable or damaged on disk: ours is the checked one
            disk = self.index.copy()
        return merge_rows(disk, self.index, sorted(self._dirty))

    # ---------------------------------------------------------------- claims
    def leases(self) -> dict[int, dict[str, Any]]:
        """Every lease file, by point (an unreadable one as an expired lease)."""
        return self._leases.all()

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
        with self.locked():
            self.index = self._merged()
            attempts = self.index["attempts"].map(lambda a: int(as_int(a) or 0)).to_numpy()
            status = self.index["status"].astype(str).to_numpy()
            finished = {
                i
                for i in candidates
                if status[i] == "done"
                or (attempts_at_start is not None and attempts[i] > attempts_at_start.get(i, 0))
            }
            return self._leases.claim_first(
                candidates, run, lease_timeout_s, finished, self._recorded_from_its_file
            )

    def _recorded_from_its_file(self, point: int) -> bool:
        """Whether ``point``'s result file, left by a run that died before its index row, passes
        its check and is now recorded done (call under the lock)."""
        if not self.result_path(point).is_file():
            return False
        before = len(self.problems)
        self.verify(repair=True)
        self.write_index()
        if str(self.index.loc[point, "status"]) == "done":
            return True
        del self.problems[before:]
        return False

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
        with self.locked():
            return self._leases.renew(points, run)

    def holds(self, point: int, run: RunIdentity) -> bool:
        """Whether ``run`` holds the lease of ``point``.

        Parameters
        ----------
        point : int
            The point.
        run : RunIdentity
            The run.

        Returns
        -------
        bool
            True when the point's lease names the run.
        """
        return self._leases.held_by(point, run)

    def release(self, point: int, run: RunIdentity) -> None:
        """Give up ``run``'s claim on ``point`` (its lease file removed, under the lock).

        Parameters
        ----------
        point : int
            The point.
        run : RunIdentity
            The run; a lease another run holds is left alone.
        """
        with self.locked():
            self._leases.release(point, run)

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
        return self._leases.holders(lease_timeout_s)

    # ---------------------------------------------------------------- results
    def save_point(
        self,
        point: int,
        result: SimulationResult | None,
        partial: SimulationResult | None,
        row: dict[str, Any],
    ) -> None:
        """Write a solved point's files (atomically) and its index row with the file's sha256 and size.

        Parameters
        ----------
        point : int
            The point.
        result : SimulationResult or None
            Its result (a done point).
        partial : SimulationResult or None
            The finished steps of a failed point.
        row : dict
            The index row (status, wall time, Newton iterations, error, ...).

        Raises
        ------
        DiskFullError
            If the disk fills (nothing written half).
        """
        update = dict(row)
        if result is not None:
            path = self.result_path(point)
            with full_disk_as_error(path):
                result.save(path)
            update["sha256"], update["bytes"] = file_digest(path)
        if partial is not None:
            with full_disk_as_error(self.partial_path(point)):
                partial.save(self.partial_path(point))
        update["attempts"] = int(as_int(self.index.loc[point, "attempts"]) or 0) + 1
        self.record(point, update, write=False)

    # ---------------------------------------------------------------- queries
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

    def summary(self, lease_timeout_s: float = DEFAULT_LEASE_TIMEOUT_S) -> dict[str, Any]:
        """The store's state, as ``campaign status`` prints it.

        Parameters
        ----------
        lease_timeout_s : float, default 120
            Claims with an older heartbeat are reported expired (:meth:`holders`), s.

        Returns
        -------
        dict
            Name, folder, points and counts by status, flagged FEBio steps and reruns, wall
            times, failures, the slowest points, problems, claims and the store's size.
        """
        c = self.counts()
        walls = self.index["wall_s"].dropna()
        failed = self.index[self.index["status"].astype(str) == "failed"]
        slowest = self.index.dropna(subset=["wall_s"]).nlargest(5, "wall_s")
        done = self.index[self.index["status"].astype(str) == "done"]
        flagged = done[done["flagged_steps"].fillna(0).astype(int) > 0]
        rerun = self.index["rerun_s"].dropna()
        return {
            "name": self.spec.name,
            "folder": str(self.root),
            "points": len(self.index),
            **c,
            "done_with_flagged_steps": len(flagged),
            "flagged_steps": int(flagged["flagged_steps"].astype(int).sum()) if len(flagged) else 0,
            "flagged": [
                {"point": int(r.point), "flagged_steps": int(r.flagged_steps)}
                for r in flagged.itertuples(index=False)
            ],
            "febio_reruns": len(rerun),
            "febio_rerun_s": float(rerun.sum()),
            "solver_wall_s": float(walls.sum()),
            "median_point_s": float(walls.median()) if len(walls) else None,
            "failures": [
                {"point": int(r.point), "error": str(r.error)} for r in failed.itertuples(index=False)
            ],
            "slowest": [
                {
                    "point": int(r.point),
                    **{k: float(getattr(r, k)) for k in self.spec.design.parameters},
                    "wall_s": float(r.wall_s),
                }
                for r in slowest.itertuples(index=False)
            ],
            "problems": [p.to_dict() for p in self.problems],
            "hashed_now": len(self.hashed_now),
            "claims": self.holders(lease_timeout_s),
            "store_bytes": sum(p.stat().st_size for p in self.root.rglob("*") if p.is_file()),
        }
