"""Moved to :mod:`indentation_studio.inference.lab.table_columns` (the readers of a lab's files are one
subpackage); this path is kept for one version."""

from typing import Any

from ..moved_names import warn_moved_module
from .lab import table_columns as _moved

warn_moved_module(__name__, "indentation_studio.inference.lab.table_columns")


def __getattr__(name: str) -> Any:
    return getattr(_moved, name)
