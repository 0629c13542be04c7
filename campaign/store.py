"""The campaign store ``runs/<name>/`` (:class:`CampaignStore`): a campaign's spec, its index of
points and their result files, kept by concern in modules of their own, as emcee keeps a
backend's interface apart from each backend:

- :mod:`~indentation_studio.campaign.layout`: where each file of the store lives;
- :mod:`~indentation_studio.campaign.spec`: what the campaign computes (``campaign.json``);
- :mod:`~indentation_studio.campaign.checksums`: the sha256 and size of each file as written,
  the check of a point file, setting a failed one aside, and a full disk named as such;
- :mod:`~indentation_studio.campaign.index`: ``index.parquet``, one row per point, checked
  against the design and merged with what other runs wrote;
- :mod:`~indentation_studio.campaign.store_index`: the index as a run holds it, updated under the
  store's lock;
- :mod:`~indentation_studio.campaign.store_checks`: every point file checked against the index,
  and repaired;
- :mod:`~indentation_studio.campaign.leases` and :mod:`~indentation_studio.campaign.claims`: the
  lease files, and the claims on points made with them under the store's lock (``store.claims``).

Nothing is trusted blindly (:meth:`CampaignStore.verify`): opening a store for a run checks
every point file against its recorded sha256 and size (a file of an older store, without them,
is first checked to load and then hashed), and a file that fails (missing, cut short, changed,
unreadable) is named, moved to ``damaged/`` and its point solved again. An index that is
unreadable, or has a row missing, repeated or of another point, is rebuilt from the point files;
``campaign.json`` is checked against its sha256. ``campaign status`` makes the same checks and
only reports.

Nothing is done twice (``store.claims.claim_next``): a run claims a point before solving it
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

import pandas as pd
from filelock import FileLock

from .. import __version__
from ..forward.checkpoint import checkpoint_progress
from ..forward.mesh import build_mesh
from ..forward.result import SimulationResult
from .checksums import Problem, file_digest, full_disk_as_error, read_spec, write_checked, write_spec
from .claims import StoreClaims
from .errors import CampaignError
from .index import as_int, fresh_index, read_index
from .layout import StoreLayout
from .leases import DEFAULT_LEASE_TIMEOUT_S, LOCK_TIMEOUT_S
from .spec import CampaignSpec
from .store_checks import clean_temporaries, verify_points
from .store_index import StoreIndex

__all__ = ["CampaignStore"]


class CampaignStore(StoreIndex):
    """One campaign folder: its spec, its index of points and their result files.

    Make one with :meth:`create_or_open` (which refuses a spec that differs from the stored one)
    or :meth:`open`. ``open(root, repair=True)`` (what a run does) repairs what its checks find;
    with ``repair=False`` (``campaign status``, the loaders) nothing is written and
    ``problems`` lists what failed. The index's upkeep (``record``, ``write_index``,
    ``refresh``, ``counts``, ``points_with``) is :class:`~.store_index.StoreIndex`'s; the claims on
    points are :attr:`claims` (:class:`~.claims.StoreClaims`).

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
        super().__init__(root, spec, index)
        self.claims = StoreClaims(self)

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
            ``problems`` (status, loaders).

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

        :func:`~.store_checks.verify_points` on this store; call under the lock when repairing.

        Parameters
        ----------
        repair : bool, default True
            Set a failed file aside and make its point pending; hash and record a file of an
            older store.

        Returns
        -------
        list of Problem
            The problems (also added to ``problems``).
        """
        return verify_points(self, repair)

    def _clean_temporaries(self) -> None:
        """Temporary files of writes cut short by a kill, except those of points a live run holds."""
        clean_temporaries(self, self.claims.files.alive_points(DEFAULT_LEASE_TIMEOUT_S))

    def reconcile(self) -> int:
        """Check the files and repair (what ``open`` does); returns how many problems were found."""
        with self.locked():
            found = self.verify(repair=True)
            self.write_index()
        return len(found)

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
            self.checkpoint_path(point).unlink(missing_ok=True)  # the result kept: no resume needed
        if partial is not None:
            with full_disk_as_error(self.partial_path(point)):
                partial.save(self.partial_path(point))
        update["attempts"] = int(as_int(self.index.loc[point, "attempts"]) or 0) + 1
        self.record(point, update, write=False)

    def summary(self, lease_timeout_s: float = DEFAULT_LEASE_TIMEOUT_S) -> dict[str, Any]:
        """The store's state, as ``campaign status`` prints it.

        Parameters
        ----------
        lease_timeout_s : float, default 120
            Claims with an older heartbeat are reported expired (:meth:`~.claims.StoreClaims.holders`), s.

        Returns
        -------
        dict
            Name, folder, points and counts by status, flagged FEBio steps and reruns, wall
            times, failures, the slowest points, problems, claims, the unfinished points that
            resume from a checkpoint (``resumable``) and where each stood there (``resumable_at``:
            :func:`forward.checkpoint.checkpoint_progress`), and the store's size.
        """
        c = self.counts()
        resumable = sorted(int(p.stem) for p in self.checkpoints_dir.glob("[0-9]*.pkl") if p.stem.isdigit())
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
            "claims": self.claims.holders(lease_timeout_s),
            "resumable": resumable,
            "resumable_at": [
                {"point": i, **(checkpoint_progress(self.checkpoint_path(i)) or {"unreadable": True})}
                for i in resumable
            ],
            "store_bytes": sum(p.stat().st_size for p in self.root.rglob("*") if p.is_file()),
        }
