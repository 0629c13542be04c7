"""Where numba keeps the compiled element kernels (``cache=True`` in :mod:`forward.hex8_kernel_numba`).

A fresh process loads the kernels from numba's on-disk cache (about 0.4 s) instead of compiling
them (several seconds). numba keeps it in ``NUMBA_CACHE_DIR`` if set, else in the ``__pycache__``
folder beside the source when that is writable (a checkout, an editable install, a writable
site-packages), else in its user-wide folder; when it finds no writable place (a read-only
install run without a writable home, a container) it refuses to decorate a cached function and
the solver cannot be imported. :func:`ensure_numba_cache_dir` runs when :mod:`forward` is
imported, before numba is: where the source folder is read-only it names a cache folder itself,
the user's (``~/.cache/indentation-studio/numba``) or a private one under the temporary folder.
It costs one ``access`` call when the source folder is writable.
"""

from __future__ import annotations

import os
import stat
import sys
import tempfile
from pathlib import Path

__all__ = ["ensure_numba_cache_dir"]

_HERE = Path(os.path.abspath(__file__)).parent  # as numba sees the kernels' file


def _writable(folder: Path) -> bool:
    """Whether numba could keep its cache in ``folder`` (or create it there)."""
    while not folder.exists():
        folder = folder.parent
    return os.access(folder, os.W_OK)


def _user_cache_folder() -> Path:
    """``$XDG_CACHE_HOME/indentation-studio/numba`` (``~/.cache`` without the variable)."""
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "indentation-studio" / "numba"


def _private_temporary_folder() -> Path:
    """``<tmp>/indentation-studio-numba-<uid>``, made with mode 0700 and used only if this user
    owns it and nobody else can write to it (a cache holds code that is run); else a new one."""
    uid = os.getuid() if hasattr(os, "getuid") else None
    folder = Path(tempfile.gettempdir()) / f"indentation-studio-numba-{uid if uid is not None else 'user'}"
    try:
        folder.mkdir(mode=0o700, exist_ok=True)
        st = folder.lstat()
        private = stat.S_ISDIR(st.st_mode) and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)
        if private and (uid is None or st.st_uid == uid):
            return folder
    except OSError:
        pass
    return Path(tempfile.mkdtemp(prefix="indentation-studio-numba-"))


def ensure_numba_cache_dir() -> Path | None:
    """Name a cache folder for numba when it would find none writable.

    Nothing is changed when ``NUMBA_CACHE_DIR`` is set or when the ``__pycache__`` beside the
    kernels is writable (the usual case, editable installs included). Otherwise
    ``NUMBA_CACHE_DIR`` (and numba's configuration, if numba is already imported) is set to
    ``$XDG_CACHE_HOME/indentation-studio/numba`` (``~/.cache/...``) if that can be written, else to
    a private folder under the system's temporary folder, so that a read-only install imports the
    solver and compiles its kernels once instead of failing.

    Returns
    -------
    pathlib.Path or None
        The folder named, or None if numba's own choice stands.

    Examples
    --------
    >>> from indentation_studio.forward.numba_cache import ensure_numba_cache_dir
    >>> ensure_numba_cache_dir() is None  # a writable checkout  # doctest: +SKIP
    True
    """
    if os.environ.get("NUMBA_CACHE_DIR") or _writable(_HERE / "__pycache__"):
        return None
    try:
        folder = _user_cache_folder()
        folder.mkdir(parents=True, exist_ok=True)
        if not os.access(folder, os.W_OK):
            folder = _private_temporary_folder()
    except (OSError, RuntimeError):  # no home (RuntimeError from Path.home) or not writable
        try:
            folder = _private_temporary_folder()
        except OSError:  # no temporary folder either: numba says so itself
            return None
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    if "numba" in sys.modules:  # numba read the variable when it was imported
        sys.modules["numba"].config.CACHE_DIR = str(folder)
    return folder
