"""Moved to :mod:`indentation_studio.forward.febio.log` (the FEBio backend is one subpackage);
this path is kept for one version."""

from typing import Any

from ..moved_names import warn_moved_module
from .febio import log as _moved

warn_moved_module(__name__, "indentation_studio.forward.febio.log")


def __getattr__(name: str) -> Any:
    return getattr(_moved, name)
