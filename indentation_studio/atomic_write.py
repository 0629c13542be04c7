"""Every file the studio writes goes through :func:`atomic_write`: a temporary file in the target's
folder, renamed over the target only once it is complete. A run killed half-way leaves the old
file (or none) and a ``*.tmp`` the stores clean up, never a truncated result."""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["atomic_write", "atomic_write_json", "atomic_write_npz", "strict_json"]


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


def strict_json(payload: Any, indent: int | None = None) -> str:
    """``payload`` as standard JSON: numpy scalars and arrays as numbers and lists, and a number
    that is not finite (an unbounded parameter's inf bound, a failed step's NaN force) as null,
    since 'Infinity' and 'NaN' are not JSON and a strict reader (JavaScript, jq, a database)
    refuses them."""
    return json.dumps(_finite(payload), indent=indent, allow_nan=False)


def _finite(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):  # numpy array or scalar
        return _finite(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (str, int, bool)) or value is None:
        return value
    if isinstance(value, Path):
        return str(value)
    return _finite(float(value))


def atomic_write_json(path: str | Path, payload: Any, indent: int | None = 1) -> Path:
    """``payload`` as JSON at ``path``, atomically (:func:`strict_json`: numpy as numbers, a
    number that is not finite as null)."""
    return atomic_write(path, strict_json(payload, indent=indent))


def atomic_write_npz(path: str | Path, **arrays: Any) -> Path:
    """``arrays`` as a compressed ``.npz`` at ``path``, atomically (written through a file object:
    ``np.savez`` given a name would append ``.npz`` to the temporary one)."""

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)

    return atomic_write(path, write)
