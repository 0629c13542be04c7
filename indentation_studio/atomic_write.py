"""Every file the studio writes goes through :func:`atomic_write`: a temporary file in the target's
folder, renamed over the target only once it is complete. A run killed half-way leaves the old
file (or none) and a ``*.tmp`` the stores clean up, never a truncated result."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["atomic_write", "atomic_write_json"]


def atomic_write(path: str | Path, content: str | bytes | Callable[[Path], Any]) -> Path:
    """Write ``content`` to ``path`` atomically and return ``path``.

    ``content`` is text (UTF-8), bytes, or a function that writes the file it is given (for
    writers that take a file name: ``np.savez``, ``DataFrame.to_parquet``, ``ElementTree.write``).
    The temporary name is unique (``mkstemp``), so two writers of the same target never share it.
    The file gets the permissions of a file created the ordinary way (0666 less the umask), not
    ``mkstemp``'s owner-only 0600, so a colleague can read a shared result.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    tmp = Path(name)
    try:
        if callable(content):
            os.close(fd)
            content(tmp)
        else:
            with os.fdopen(fd, "wb") as fh:
                fh.write(content.encode() if isinstance(content, str) else content)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_json(path: str | Path, payload: Any, indent: int | None = 1) -> Path:
    """``payload`` as JSON at ``path``, atomically (numpy scalars written as floats)."""
    return atomic_write(path, json.dumps(payload, indent=indent, default=float))
