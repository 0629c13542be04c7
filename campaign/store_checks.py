"""A store's point files checked against its index, and repaired (:func:`verify_points`): every
point file against its recorded sha256 and size (a file of an older store, without them, is first
checked to load and then hashed); a file that fails (missing, cut short, changed, unreadable) is
named, moved to ``damaged/`` and its point made pending. The check of one file is
:func:`~indentation_studio.campaign.checksums.check_point_file`."""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

from .checksums import Problem, check_point_file, set_aside
from .index import PENDING_ROW, as_int, is_missing, result_row
from .store_index import StoreIndex

__all__ = ["clean_temporaries", "recorded_from_its_file", "verify_points"]


def verify_points(store: StoreIndex, repair: bool = True) -> list[Problem]:
    """Check every point file of ``store`` against its row (call under the lock when repairing).

    Parameters
    ----------
    store : StoreIndex
        The store.
    repair : bool, default True
        A file that fails is moved to ``damaged/`` and its point made pending, a file with no
        row or hash (an older store, a run killed between writing the file and the index) is
        checked to load, hashed and recorded done.

    Returns
    -------
    list of Problem
        The problems (also added to ``store.problems``).
    """
    found: list[Problem] = []
    present = {int(p.stem) for p in store.points_dir.glob("[0-9]*.npz") if p.stem.isdigit()}
    status = store.index["status"].astype(str).to_numpy()
    for i in range(len(store.index)):
        path, row, done = store.result_path(i), store.index.loc[i], status[i] == "done"
        if i not in present:
            if done:
                found.append(Problem(str(path), "missing (the index says done)", i, "solve again"))
                if repair:
                    store.record(i, PENDING_ROW, write=False)
            continue
        hashed = done and not is_missing(row["sha256"])
        check = check_point_file(path, (row["sha256"], int(row["bytes"])) if hashed else None)
        if check.reason is not None:
            found.append(Problem(str(path), check.reason, i, "solve again"))
            if repair:
                set_aside(path, store.damaged_dir)
                store.record(i, PENDING_ROW, write=False)
        elif repair and check.digest is not None:  # loaded (no hash recorded): hashed now
            store.hashed_now.append(i)
            update: dict[str, Any] = {"sha256": check.digest[0], "bytes": check.digest[1]}
            if not done:
                update |= result_row(check.result) | {"status": "done", "error": None}
                update["attempts"] = max(int(as_int(row["attempts"]) or 0), 1)
            store.record(i, update, write=False)
    if not repair:
        for p in found:
            p.action = "reported: `campaign run` solves it again"
    store.problems += found
    return found


def clean_temporaries(store: StoreIndex, held: Collection[int]) -> None:
    """Remove the temporary files of writes cut short by a kill (never renamed).

    Parameters
    ----------
    store : StoreIndex
        The store.
    held : collection of int
        The points a live run holds: their temporaries are kept (it may be writing them now).
    """
    for stale in store.points_dir.glob("*.tmp"):
        head = stale.name.split(".", 1)[0]
        if head.isdigit() and int(head) in held:
            continue
        stale.unlink(missing_ok=True)


def recorded_from_its_file(store: StoreIndex, point: int) -> bool:
    """Whether ``point``'s result file, left by a run that died before its index row, passes its
    check and is now recorded done (call under the lock).

    Parameters
    ----------
    store : StoreIndex
        The store.
    point : int
        The point.

    Returns
    -------
    bool
        True when the file passed and the point is recorded done.
    """
    if not store.result_path(point).is_file():
        return False
    before = len(store.problems)
    verify_points(store, repair=True)
    store.write_index()
    if str(store.index.loc[point, "status"]) == "done":
        return True
    del store.problems[before:]
    return False
