"""Names that moved to another module keep their old import path for one version, with a
``DeprecationWarning`` that says where they went (docs/changelog.md lists every move)."""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable
from typing import Any

__all__ = ["REMOVED_IN", "moved_getattr", "moved_module", "warn_moved_module"]

#: The version in which the old paths go.
REMOVED_IN = "0.3"


def warn_moved_module(old: str, new: str) -> None:
    """Warn that module ``old`` is now ``new`` (call at the top of the old module)."""
    warnings.warn(
        f"{old} moved to {new}; the old path goes in {REMOVED_IN}", DeprecationWarning, stacklevel=3
    )


def moved_getattr(
    package: str, moved: dict[str, str], fallback: Callable[[str], Any]
) -> Callable[[str], Any]:
    """A module ``__getattr__`` for ``package``: a name in ``moved`` (name -> its new module) is
    fetched from there with a warning; any other name goes to ``fallback`` (lazy_loader's)."""

    def __getattr__(name: str) -> Any:
        if name in moved:
            warnings.warn(
                f"{package}.{name} moved to {moved[name]}.{name}; the old path goes in {REMOVED_IN}",
                DeprecationWarning,
                stacklevel=2,
            )
            return getattr(importlib.import_module(moved[name]), name)
        return fallback(name)

    return __getattr__


def moved_module(old: str, new: str) -> Callable[[str], Any]:
    """The body of a moved module's old path: warn now that ``old`` is ``new`` and return the
    ``__getattr__`` that reads every name from ``new``."""
    warn_moved_module(old, new)
    module = importlib.import_module(new)

    def __getattr__(name: str) -> Any:
        return getattr(module, name)

    return __getattr__
