"""The checks of a campaign store's files: the sha256 and size of each point file as written
(:func:`file_digest`, :func:`point_file_reason`), a point file without them checked by loading it
(:func:`check_point_file`), a file that fails kept aside in ``damaged/`` (:func:`set_aside`),
``campaign.json`` against ``campaign.sha256`` (:func:`write_spec`, :func:`read_spec`), and a full
disk named as such (:func:`disk_full`, :func:`full_disk_as_error`) for every write
(:func:`write_checked`: atomic, the file whole or absent)."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..atomic_write import atomic_write
from ..forward.result import SimulationResult
from .errors import CampaignError, DiskFullError
from .spec import CampaignSpec

__all__ = [
    "FileCheck",
    "Problem",
    "check_point_file",
    "disk_full",
    "file_digest",
    "full_disk_as_error",
    "point_file_reason",
    "raise_if_full",
    "read_spec",
    "set_aside",
    "spec_digest",
    "write_checked",
    "write_spec",
]


@dataclass
class Problem:
    """A point file (or a store file) that failed its check, and what was done about it."""

    file: str
    reason: str
    point: int | None = None
    action: str = "reported"

    def to_dict(self) -> dict[str, Any]:
        """The problem as ``campaign status`` reports it (point, file, reason, action)."""
        return {"point": self.point, "file": self.file, "reason": self.reason, "action": self.action}


def file_digest(path: str | Path) -> tuple[str, int]:
    """(sha256 hex, size in bytes) of a file."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return h.hexdigest(), size


def spec_digest(text: str | bytes) -> str:
    """The sha256 hex of ``campaign.json``'s text, as ``campaign.sha256`` records it."""
    return hashlib.sha256(text.encode() if isinstance(text, str) else text).hexdigest()


def point_file_reason(path: Path, sha256: str, size: int) -> str | None:
    """Why a point file fails its check against the sha256 and size recorded when it was
    written (unreadable, cut short, changed), or None when it passes.

    Parameters
    ----------
    path : pathlib.Path
        The point file.
    sha256 : str
        Its recorded sha256 hex.
    size : int
        Its recorded size, bytes.

    Returns
    -------
    str or None
        The reason, or None.
    """
    try:
        now_sha, now_size = file_digest(path)
    except OSError as exc:
        return f"unreadable ({exc})"
    if now_size != int(size):
        return f"{now_size} bytes, {int(size)} written (cut short or changed)"
    if now_sha != sha256:
        return f"content changed since written (sha256 {now_sha[:12]}..., {sha256[:12]}... written)"
    return None


@dataclass
class FileCheck:
    """What the check of one point file found: why it fails (None when it passes) and, for a file
    checked by loading it (no sha256 recorded), its result and its (sha256, size) to record."""

    reason: str | None
    result: SimulationResult | None = None
    digest: tuple[str, int] | None = None


def check_point_file(path: Path, recorded: tuple[str, int] | None) -> FileCheck:
    """Check a point file against the sha256 and size recorded when it was written or, without
    them (an older store, a run killed between writing the file and its index row), by loading it.

    Parameters
    ----------
    path : pathlib.Path
        The point file (it exists).
    recorded : tuple of (str, int) or None
        Its recorded sha256 hex and size in bytes, or None when none was recorded.

    Returns
    -------
    FileCheck
        The reason it fails, or (a file loaded) its result and digest.
    """
    if recorded is not None:
        return FileCheck(point_file_reason(path, *recorded))
    try:
        result = SimulationResult.load(path)
        digest = file_digest(path)
    except (ValueError, OSError) as exc:
        return FileCheck(f"unreadable: {_reason(exc)}")
    return FileCheck(None, result, digest)


def set_aside(path: Path, damaged_dir: Path) -> None:
    """Move a file that failed its check into ``damaged_dir`` to look at (never read again).

    Parameters
    ----------
    path : pathlib.Path
        The file; removed when it cannot be moved.
    damaged_dir : pathlib.Path
        The store's ``damaged/`` folder (made when missing); the file is renamed there with the
        time appended.
    """
    target = damaged_dir / f"{path.name}.{time.strftime('%Y%m%dT%H%M%S')}"
    target.parent.mkdir(exist_ok=True)
    try:
        os.replace(path, target)
    except OSError:
        path.unlink(missing_ok=True)


def _reason(exc: BaseException) -> str:
    """An error's message without the path it starts with (the problem names the file)."""
    text = str(exc)
    return text.split(": ", 1)[1] if text.startswith("/") and ": " in text else text


def disk_full(exc: BaseException, path: Path) -> CampaignError | None:
    """A clear error for a full disk (ENOSPC, EDQUOT), else None."""
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return DiskFullError(
            f"disk full while writing {path}: nothing was written half (the file is either whole or "
            f"absent); free space and run again, finished points are kept"
        )
    return None


def raise_if_full(exc: BaseException, path: Path) -> None:
    """Raise :func:`disk_full`'s error (from ``exc``) when ``exc`` is a full disk writing ``path``."""
    full = disk_full(exc, path)
    if full is not None:
        raise full from exc


@contextmanager
def full_disk_as_error(path: Path) -> Iterator[None]:
    """A context in which a full disk while writing ``path`` is raised as
    :class:`~indentation_studio.campaign.errors.DiskFullError` (other errors unchanged).

    Parameters
    ----------
    path : pathlib.Path
        The file written, named in the error.

    Yields
    ------
    None
        Nothing: the writes are made inside the context.
    """
    try:
        yield
    except OSError as exc:
        raise_if_full(exc, path)
        raise


def write_checked(path: Path, content: Any) -> None:
    """Write ``path`` atomically (:func:`~indentation_studio.atomic_write.atomic_write`), a full
    disk raised as :class:`~indentation_studio.campaign.errors.DiskFullError`."""
    with full_disk_as_error(path):
        atomic_write(path, content)


def write_spec(meta: Path, text: str) -> None:
    """Write ``campaign.json`` and, beside it, ``campaign.sha256`` (its sha256, which
    :func:`read_spec` checks).

    Parameters
    ----------
    meta : pathlib.Path
        The store's ``campaign.json``.
    text : str
        Its text.
    """
    write_checked(meta, text)
    write_checked(meta.with_name("campaign.sha256"), spec_digest(text) + "\n")


def read_spec(meta: Path, repair: bool) -> CampaignSpec:
    """``campaign.json`` parsed and checked against its sha256 (written with it; an older store
    gets it on its first resume).

    Parameters
    ----------
    meta : pathlib.Path
        The store's ``campaign.json``.
    repair : bool
        Write a missing ``campaign.sha256`` (an older store).

    Returns
    -------
    CampaignSpec
        The spec.

    Raises
    ------
    CampaignError
        If the file cannot be read or parsed, or changed since it was written.
    """
    try:
        text = meta.read_bytes()
        spec = CampaignSpec.from_dict(json.loads(text))
    except (ValueError, KeyError, TypeError, OSError) as exc:
        raise CampaignError(f"{meta}: unreadable campaign spec ({type(exc).__name__}: {exc})") from exc
    sums = meta.with_name("campaign.sha256")
    digest = spec_digest(text)
    if sums.is_file():
        recorded = sums.read_text().strip()
        if recorded != digest:
            raise CampaignError(
                f"{meta}: changed since the campaign was created (sha256 {digest[:12]}..., "
                f"{recorded[:12]}... recorded in {sums.name}); restore it, or delete the folder to start over"
            )
    elif repair:
        write_checked(sums, digest + "\n")
    return spec
