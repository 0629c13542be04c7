"""The checks of a campaign store's files: the sha256 and size of each point file as written
(:func:`file_digest`, :func:`point_file_reason`), ``campaign.json`` against ``campaign.sha256``
(:func:`read_spec`), and a full disk named as such (:func:`disk_full`) for every write
(:func:`write_checked`: atomic, the file whole or absent)."""

from __future__ import annotations

import errno
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..atomic_write import atomic_write
from .errors import CampaignError, DiskFullError
from .spec import CampaignSpec

__all__ = [
    "Problem",
    "disk_full",
    "file_digest",
    "point_file_reason",
    "raise_if_full",
    "read_spec",
    "spec_digest",
    "write_checked",
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


def write_checked(path: Path, content: Any) -> None:
    """Write ``path`` atomically (:func:`~indentation_studio.atomic_write.atomic_write`), a full
    disk raised as :class:`~indentation_studio.campaign.errors.DiskFullError`."""
    try:
        atomic_write(path, content)
    except OSError as exc:
        raise_if_full(exc, path)
        raise


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
