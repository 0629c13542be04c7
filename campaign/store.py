"""The campaign store ``runs/<name>/``: ``campaign.json`` (the spec and code version, its sha256
in ``campaign.sha256``), one result file per point under ``points/`` (written atomically by the
run's parent process), and ``index.parquet`` (one row per point: parameters, status, wall time,
iterations, error, and the sha256 and size of the point's file as written).

Nothing is trusted blindly (:meth:`CampaignStore.verify`): opening a store for a run checks
every point file against its recorded sha256 and size (a file of an older store, without them,
is first checked to load and then hashed), and a file that fails (missing, cut short, changed,
unreadable) is named, moved to ``damaged/`` and its point solved again. An index that is
unreadable, or has a row missing, repeated or of another point, is rebuilt from the point files;
``campaign.json`` is checked against its sha256. ``campaign status`` makes the same checks and
only reports.

Nothing is done twice (:class:`RunIdentity`, :meth:`CampaignStore.claim_next`): a run claims a
point before solving it by writing a lease ``leases/<n>.json`` (host, pid, start time, a
heartbeat renewed while it solves) under a short file lock on the store (``filelock``), and
other runs of the same campaign (on this machine or others sharing the folder) skip the points
held by a live lease. A lease whose heartbeat is older than the lease timeout, or whose process
is gone (same host), belongs to a run that died and is taken over. Every index update is made
under the lock and merged with what other runs wrote.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import socket
import time
import uuid
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from filelock import FileLock, Timeout

from .. import __version__
from ..atomic_write import atomic_write
from ..forward.mesh import build_mesh
from ..forward.result import SimulationResult
from ..forward.spec import ModelSpec
from .designs import Design
from .errors import CampaignError, DiskFullError

SCHEMA = "indentation-studio/campaign/1"
STATUSES = ("pending", "done", "failed")
#: Default equilibrium tolerance of FEBio campaign points: 2 % of the step's own force, the
#: force noise a fit assumes at that step (eq. 4a weighs each step relative to its own force).
CAMPAIGN_EQUILIBRIUM_REL = 0.02
#: Index columns added by this version (older indexes get them on their first resume).
CHECK_COLUMNS = ("sha256", "bytes", "attempts", "flagged_steps", "rerun_s")


#: How long a run waits for the store's lock (held only for short updates) before giving up.
LOCK_TIMEOUT_S = 120.0
#: A lease whose heartbeat is older than this belongs to a run that died (default; ``campaign
#: run --lease-timeout``). Heartbeats are renewed every quarter of it.
DEFAULT_LEASE_TIMEOUT_S = 120.0


def file_digest(path: str | Path) -> tuple[str, int]:
    """(sha256 hex, size in bytes) of a file."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return h.hexdigest(), size


def disk_full(exc: BaseException, path: Path) -> CampaignError | None:
    """A clear error for a full disk (ENOSPC, EDQUOT), else None."""
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return DiskFullError(
            f"disk full while writing {path}: nothing was written half (the file is either whole or "
            f"absent); free space and run again, finished points are kept"
        )
    return None


def _raise_if_full(exc: BaseException, path: Path) -> None:
    full = disk_full(exc, path)
    if full is not None:
        raise full from exc


@dataclass(frozen=True)
class RunIdentity:
    """Who holds a claim: one ``campaign run`` (its own id, host, pid and start time)."""

    run_id: str
    host: str
    pid: int
    started: float  # epoch s

    @classmethod
    def new(cls) -> RunIdentity:
        return cls(uuid.uuid4().hex[:12], socket.gethostname(), os.getpid(), time.time())

    def lease(self, point: int) -> dict[str, Any]:
        return {
            "point": point,
            "run_id": self.run_id,
            "host": self.host,
            "pid": self.pid,
            "started": self.started,
            "claimed": time.time(),
            "heartbeat": time.time(),
        }


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


@dataclass
class Problem:
    """A point file (or a store file) that failed its check, and what was done about it."""

    file: str
    reason: str
    point: int | None = None
    action: str = "reported"

    def to_dict(self) -> dict[str, Any]:
        return {"point": self.point, "file": self.file, "reason": self.reason, "action": self.action}


@dataclass
class ClaimOutcome:
    """What :meth:`CampaignStore.claim_next` found: the point claimed (or None), the candidates
    finished by another run meanwhile, and those held by another live run (with its lease)."""

    point: int | None
    finished_elsewhere: set[int]
    held: dict[int, dict[str, Any]]


@dataclass(frozen=True)
class CampaignSpec:
    """What a campaign computes: a design of parameter points on one model and solver.

    Parameters
    ----------
    name : str
        The campaign's folder name (no path separator, not starting with a dot).
    design : Design
        The parameter points.
    model : ModelSpec
        The forward model every point is solved with.
    solver : {"embedded", "febio"}, default "embedded"
        The forward solver.
    extra : dict, optional
        Further settings, e.g. ``equilibrium_rel`` (FEBio, see :attr:`equilibrium_rel`).

    Raises
    ------
    CampaignError
        If the name is not a plain folder name or the solver is unknown.
    """

    name: str
    design: Design
    model: ModelSpec
    solver: str = "embedded"
    extra: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.name or any(c in self.name for c in "/\\") or self.name.startswith("."):
            raise CampaignError(f"campaign name {self.name!r}: use a plain folder name")
        if self.solver not in ("embedded", "febio"):
            raise CampaignError(f"solver {self.solver!r}: use 'embedded' or 'febio'")

    def to_dict(self) -> dict[str, Any]:
        """The spec as ``campaign.json`` records it.

        Returns
        -------
        dict
            The schema, name, design (description, parameters, points), model, solver and extra.
        """
        return {
            "schema": SCHEMA,
            "name": self.name,
            "design": {
                "description": self.design.description,
                "parameters": list(self.design.parameters),
                "points": self.design.points.tolist(),
            },
            "model": self.model.to_dict(),
            "solver": self.solver,
            "extra": self.extra,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CampaignSpec:
        """The spec a ``campaign.json`` records (the inverse of :meth:`to_dict`).

        Parameters
        ----------
        d : dict
            The JSON's content.

        Returns
        -------
        CampaignSpec
            The spec.
        """
        des = d["design"]
        return cls(
            name=d["name"],
            design=Design(np.array(des["points"], float), tuple(des["parameters"]), des["description"]),
            model=ModelSpec.from_dict(d["model"]),
            solver=d.get("solver", "embedded"),
            extra=d.get("extra", {}),
        )

    def differences(self, other: CampaignSpec) -> list[str]:
        """What makes ``other`` a different campaign (empty when it is the same).

        Parameters
        ----------
        other : CampaignSpec
            The spec to compare with.

        Returns
        -------
        list of str
            The model fields, solver, design and (FEBio) equilibrium tolerance that differ.
        """
        a, b = self.to_dict(), other.to_dict()
        out = (
            ["model " + ", ".join(_changed_fields(a["model"], b["model"]))]
            if a["model"] != b["model"]
            else []
        )
        if a["solver"] != b["solver"]:
            out.append(f"solver ({a['solver']} vs {b['solver']})")
        if a["design"]["parameters"] != b["design"]["parameters"] or not np.array_equal(
            self.design.points, other.design.points
        ):
            out.append(f"design ({a['design']['description']} vs {b['design']['description']})")
        if self.solver == "febio" and self.equilibrium_rel != other.equilibrium_rel:
            out.append(f"equilibrium tolerance ({self.equilibrium_rel:g} vs {other.equilibrium_rel:g})")
        return out

    @property
    def equilibrium_rel(self) -> float:
        """The fraction of a step's own force a FEBio step's imbalance may reach before it is flagged.

        README, "Campaigns"; ``campaign run --equilibrium-tol``.
        """
        return float(self.extra.get("equilibrium_rel", CAMPAIGN_EQUILIBRIUM_REL))


def _changed_fields(a: Any, b: Any, prefix: str = "") -> list[str]:
    """The leaves where two nested dicts differ, as 'path: old -> new'."""
    if isinstance(a, dict) and isinstance(b, dict):
        out: list[str] = []
        for key in sorted(set(a) | set(b)):
            out += _changed_fields(a.get(key), b.get(key), f"{prefix}{key}.")
        return out
    return [] if a == b else [f"{prefix.rstrip('.')}: {a!r} -> {b!r}"]


class CampaignStore:
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
        self.root = Path(root)
        self.spec = spec
        self.index = _with_check_columns(index)
        self.problems: list[Problem] = []
        self.hashed_now: list[int] = []  # files of an older store hashed (after loading) by this open
        self._dirty: set[int] = set()
        self.lock = FileLock(self.root / ".lock", timeout=LOCK_TIMEOUT_S)

    # ----------------------------------------------------------------- files
    @property
    def points_dir(self) -> Path:
        """The folder of the points' result files, ``points/``."""
        return self.root / "points"

    @property
    def leases_dir(self) -> Path:
        """The folder of the claims' lease files, ``leases/``."""
        return self.root / "leases"

    def result_path(self, point: int) -> Path:
        """The result file of a point, ``points/<point>.npz``.

        Parameters
        ----------
        point : int
            The point.

        Returns
        -------
        pathlib.Path
            The file.
        """
        return self.points_dir / f"{point:05d}.npz"

    def partial_path(self, point: int) -> Path:
        """The file of a failed point's finished steps, ``points/<point>.partial.npz``.

        Parameters
        ----------
        point : int
            The point.

        Returns
        -------
        pathlib.Path
            The file.
        """
        return self.points_dir / f"{point:05d}.partial.npz"

    def lease_path(self, point: int) -> Path:
        """The lease file of a point, ``leases/<point>.json``.

        Parameters
        ----------
        point : int
            The point.

        Returns
        -------
        pathlib.Path
            The file.
        """
        return self.leases_dir / f"{point:05d}.json"

    def locked(self):
        """The store's lock, as a context (short critical sections only).

        A lock not had in ``LOCK_TIMEOUT_S`` is a clear error.
        """
        return _Locked(self.lock, self.root)

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
        root = Path(runs_dir) / spec.name
        meta = root / "campaign.json"
        mesh = build_mesh(spec.model).geometry_record()
        spec = replace(spec, extra=spec.extra | {"mesh": mesh})
        if not meta.is_file():
            root.mkdir(parents=True, exist_ok=True)
            with FileLock(root / ".lock", timeout=LOCK_TIMEOUT_S):
                if not meta.is_file():  # another run may have created it meanwhile
                    (root / "points").mkdir(exist_ok=True)
                    record = spec.to_dict() | {
                        "code_version": __version__,
                        "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
                    }
                    text = json.dumps(record, indent=1)
                    _write(root / "campaign.json", text)
                    _write(root / "campaign.sha256", hashlib.sha256(text.encode()).hexdigest() + "\n")
                    store = cls(root, spec, cls._fresh_index(spec))
                    _write(root / "index.parquet", lambda tmp: store.index.to_parquet(tmp, index=False))
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
        root = Path(root)
        meta = root / "campaign.json"
        if not meta.is_file():
            raise CampaignError(f"{root}: no campaign here (campaign.json missing)")
        spec = _read_spec(meta, repair)
        store = cls(root, spec, cls._fresh_index(spec))
        if not repair:  # read only (a store on a read-only share too): every write is a rename
            store.index, store.problems = store._read_index()
            store.verify(repair=False)
            return store
        with store.locked():
            store.index, store.problems = store._read_index()
            store.verify(repair=True)
            store._clean_temporaries()
            store.write_index()
        return store

    @staticmethod
    def _fresh_index(spec: CampaignSpec) -> pd.DataFrame:
        n = len(spec.design.points)
        table = pd.DataFrame({"point": np.arange(n)})
        for j, k in enumerate(spec.design.parameters):
            table[k] = spec.design.points[:, j]
        table["status"] = pd.Categorical(["pending"] * n, categories=STATUSES)
        table["wall_s"] = np.nan
        table["newton_iterations"] = pd.array([pd.NA] * n, dtype="Int64")
        table["error"] = pd.array([None] * n, dtype="string")
        table["finished"] = pd.array([None] * n, dtype="string")
        return _with_check_columns(table)

    def _read_index(self) -> tuple[pd.DataFrame, list[Problem]]:
        """The index on disk checked against the design: an unreadable file, or rows missing,
        repeated, of no point or of other parameters give a fresh row (the point files then
        restore what they hold). Call under the lock."""
        path = self.root / "index.parquet"
        fresh = self._fresh_index(self.spec)
        problems: list[Problem] = []
        if not path.is_file():
            problems.append(Problem(str(path), "missing: rebuilt from the point files", action="rebuilt"))
            return fresh, problems
        try:
            raw = pd.read_parquet(path).copy(deep=True)  # a deep copy: arrays may be read-only views
            if "point" not in raw or "status" not in raw:
                raise ValueError("no point or status column")
        except Exception as exc:  # pyarrow's errors for a damaged file are of many kinds
            problems.append(
                Problem(str(path), f"unreadable ({type(exc).__name__}: {exc}); rebuilt from the point files")
            )
            return fresh, problems
        raw = _with_check_columns(raw)
        names = list(self.spec.design.parameters)
        n = len(fresh)
        pts = pd.to_numeric(raw["point"], errors="coerce").to_numpy(float)
        ok = np.isfinite(pts) & (pts >= 0) & (pts < n) & (pts == np.round(pts))
        at = np.where(ok, pts, 0).astype(int)
        for j, k in enumerate(names):
            values = (
                pd.to_numeric(raw[k], errors="coerce").to_numpy(float)
                if k in raw
                else np.full(len(raw), np.nan)
            )
            ok &= np.isclose(values, self.spec.design.points[at, j], rtol=1e-12, atol=0)
        ok &= raw["status"].astype(str).isin(STATUSES).to_numpy()
        ok &= ~pd.Series(np.where(ok, at, -1 - np.arange(len(raw)))).duplicated().to_numpy()
        for r in np.flatnonzero(~ok):
            problems.append(
                Problem(
                    str(path),
                    f"row {r} (point {raw['point'].iloc[r]!r}) is not a row of the design, or repeats one",
                )
            )
        good = raw[ok]
        rows = at[ok]
        for col in fresh.columns:
            if col in good.columns and col not in ("point", *names):
                fresh.loc[rows, col] = good[col].to_numpy()
        for i in sorted(set(range(n)) - set(rows.tolist())):
            problems.append(Problem(str(path), f"no row for point {i}: restored from its file, if any", i))
        for p in problems:
            p.action = "rebuilt from the point files"
        return fresh, problems

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
            path = self.result_path(i)
            row = self.index.loc[i]
            if i not in present:
                if status[i] == "done":
                    found.append(Problem(str(path), "missing (the index says done)", i, "solve again"))
                    if repair:
                        self.record(i, _PENDING, write=False)
                continue
            sha, size = row["sha256"], row["bytes"]
            if status[i] == "done" and not _missing(sha):
                try:
                    now_sha, now_size = file_digest(path)
                except OSError as exc:
                    reason = f"unreadable ({exc})"
                else:
                    if now_size != int(size):
                        reason = f"{now_size} bytes, {int(size)} written (cut short or changed)"
                    elif now_sha != sha:
                        reason = (
                            f"content changed since written (sha256 {now_sha[:12]}..., {sha[:12]}... written)"
                        )
                    else:
                        continue
                found.append(Problem(str(path), reason, i, "solve again"))
                if repair:
                    self._set_aside(path)
                    self.record(i, _PENDING, write=False)
                continue
            # a file without a hash (an older store) or without a done row: it must load
            try:
                result = SimulationResult.load(path)
                digest = file_digest(path)
            except (ValueError, OSError) as exc:
                found.append(Problem(str(path), f"unreadable: {_reason(exc)}", i, "solve again"))
                if repair:
                    self._set_aside(path)
                    self.record(i, _PENDING, write=False)
                continue
            if repair:
                self.hashed_now.append(i)
                row_update: dict[str, Any] = {"sha256": digest[0], "bytes": digest[1]}
                if status[i] != "done":
                    row_update |= _result_row(result) | {"status": "done", "error": None}
                    row_update["attempts"] = max(int(_int(row["attempts"]) or 0), 1)
                self.record(i, row_update, write=False)
        if not repair:
            for p in found:
                p.action = "reported: `campaign run` solves it again"
        self.problems += found
        return found

    def _set_aside(self, path: Path) -> None:
        """A file that failed its check, kept in ``damaged/`` to look at (never read again)."""
        target = self.root / "damaged" / f"{path.name}.{time.strftime('%Y%m%dT%H%M%S')}"
        target.parent.mkdir(exist_ok=True)
        try:
            os.replace(path, target)
        except OSError:
            path.unlink(missing_ok=True)

    def _clean_temporaries(self) -> None:
        """Temporary files of writes cut short by a kill (never renamed), except those of points
        a live run holds (it may be writing them now)."""
        held = {int(k) for k, lease in self.leases().items() if lease_alive(lease, DEFAULT_LEASE_TIMEOUT_S)}
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
        path = self.root / "index.parquet"
        with self.locked():
            merged = self._merged()
            try:
                atomic_write(path, lambda tmp: merged.to_parquet(tmp, index=False))
            except OSError as exc:
                _raise_if_full(exc, path)
                raise
            self.index = merged
            self._dirty.clear()

    def refresh(self) -> None:
        """Read what other runs recorded (this run's unwritten rows kept)."""
        with self.locked():
            self.index = self._merged()

    def _merged(self) -> pd.DataFrame:
        disk, problems = self._read_index()
        if problems:  # unreadable or damaged on disk: ours is the checked one
            disk = self.index.copy()
        dirty = sorted(self._dirty)
        if dirty:
            for col in disk.columns:
                disk.loc[dirty, col] = self.index.loc[dirty, col].to_numpy()
        return disk

    # ---------------------------------------------------------------- claims
    def leases(self) -> dict[int, dict[str, Any]]:
        """Every lease file, by point (an unreadable one as an expired lease)."""
        out: dict[int, dict[str, Any]] = {}
        for f in self.leases_dir.glob("[0-9]*.json"):
            try:
                out[int(f.stem)] = json.loads(f.read_text())
            except (OSError, ValueError):
                out[int(f.stem)] = {"heartbeat": 0.0, "host": "?", "pid": -1, "run_id": "?"}
        return out

    def _lease(self, point: int) -> dict[str, Any] | None:
        try:
            return json.loads(self.lease_path(point).read_text())
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return {"heartbeat": 0.0, "host": "?", "pid": -1, "run_id": "?"}

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
        finished: set[int] = set()
        held: dict[int, dict[str, Any]] = {}
        with self.locked():
            self.index = self._merged()
            status = self.index["status"].astype(str).to_numpy()
            now = time.time()
            for i in candidates:
                attempts = int(_int(self.index.loc[i, "attempts"]) or 0)
                if status[i] == "done" or (
                    attempts_at_start is not None and attempts > attempts_at_start.get(i, 0)
                ):
                    finished.add(i)
                    continue
                lease = self._lease(i)
                if (
                    lease is not None
                    and lease.get("run_id") != run.run_id
                    and lease_alive(lease, lease_timeout_s, now)
                ):
                    held[i] = lease
                    continue
                if self.result_path(i).is_file():  # written by a run that died before its index row
                    before = len(self.problems)
                    self.verify(repair=True)
                    self.write_index()
                    if str(self.index.loc[i, "status"]) == "done":
                        finished.add(i)
                        continue
                    del self.problems[before:]
                try:
                    _write(self.lease_path(i), json.dumps(run.lease(i)))
                except OSError as exc:
                    _raise_if_full(exc, self.lease_path(i))
                    raise
                return ClaimOutcome(i, finished, held)
        return ClaimOutcome(None, finished, held)

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
        lost: set[int] = set()
        with self.locked():
            for i in points:
                lease = self._lease(i)
                if lease is None or lease.get("run_id") != run.run_id:
                    lost.add(i)
                    continue
                lease["heartbeat"] = time.time()
                try:
                    _write(self.lease_path(i), json.dumps(lease))
                except OSError:
                    pass  # a full disk: the old heartbeat stands; the timeout is long
        return lost

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
        lease = self._lease(point)
        return lease is not None and lease.get("run_id") == run.run_id

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
            if self.holds(point, run):
                self.lease_path(point).unlink(missing_ok=True)

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
        now = time.time()
        out = []
        for i, lease in sorted(self.leases().items()):
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
            try:
                result.save(path)
            except OSError as exc:
                _raise_if_full(exc, path)
                raise
            update["sha256"], update["bytes"] = file_digest(path)
        if partial is not None:
            try:
                partial.save(self.partial_path(point))
            except OSError as exc:
                _raise_if_full(exc, self.partial_path(point))
                raise
        update["attempts"] = int(_int(self.index.loc[point, "attempts"]) or 0) + 1
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


_PENDING = {"status": "pending", "sha256": None, "bytes": None, "error": None, "flagged_steps": None}


class _Locked:
    """The store's file lock as a context, its timeout a :class:`CampaignError`."""

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


def _write(path: Path, content: Any) -> None:
    try:
        atomic_write(path, content)
    except OSError as exc:
        _raise_if_full(exc, path)
        raise


def _read_spec(meta: Path, repair: bool) -> CampaignSpec:
    """campaign.json parsed and checked against its sha256 (written with it; an older store gets
    it on its first resume)."""
    try:
        text = meta.read_bytes()
        spec = CampaignSpec.from_dict(json.loads(text))
    except (ValueError, KeyError, TypeError, OSError) as exc:
        raise CampaignError(f"{meta}: unreadable campaign spec ({type(exc).__name__}: {exc})") from exc
    sums = meta.with_name("campaign.sha256")
    digest = hashlib.sha256(text).hexdigest()
    if sums.is_file():
        recorded = sums.read_text().strip()
        if recorded != digest:
            raise CampaignError(
                f"{meta}: changed since the campaign was created (sha256 {digest[:12]}..., "
                f"{recorded[:12]}... recorded in {sums.name}); restore it, or delete the folder to start over"
            )
    elif repair:
        _write(sums, digest + "\n")
    return spec


def _with_check_columns(index: pd.DataFrame) -> pd.DataFrame:
    """The columns of this version added to an older index (empty)."""
    index = index.copy()
    n = len(index)
    if "sha256" not in index:
        index["sha256"] = pd.array([None] * n, dtype="string")
    for col in ("bytes", "attempts", "flagged_steps"):
        if col not in index:
            index[col] = pd.array([pd.NA] * n, dtype="Int64")
    if "rerun_s" not in index:
        index["rerun_s"] = np.nan
    if "status" in index and not isinstance(index["status"].dtype, pd.CategoricalDtype):
        index["status"] = pd.Categorical(index["status"].astype(str), categories=STATUSES)
    return index


def _missing(value: Any) -> bool:
    try:
        return value is None or bool(pd.isna(value))
    except (TypeError, ValueError):
        return False


def _int(value: Any) -> int | None:
    return None if _missing(value) else int(value)


def _reason(exc: BaseException) -> str:
    text = str(exc)
    return text.split(": ", 1)[1] if text.startswith("/") and ": " in text else text


def _result_row(result: SimulationResult) -> dict[str, Any]:
    """The index fields a result file restores (wall time, iterations, flagged steps, rerun)."""
    flagged = int(np.sum(result.off_equilibrium)) if result.off_equilibrium is not None else 0
    rerun = result.solver.get("rerun") or {}
    walls = rerun.get("wall_s")
    return {
        "wall_s": result.wall_s,
        "newton_iterations": result.newton_iterations,
        "flagged_steps": flagged,
        "rerun_s": float(walls[1]) if isinstance(walls, list) and len(walls) > 1 else None,
    }
