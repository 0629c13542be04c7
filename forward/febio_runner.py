"""Moved to :mod:`indentation_studio.forward.febio.runner` (the FEBio backend is one subpackage);
this path is kept for one version."""

from typing import Any

from ..moved_names import warn_moved_module
from .febio import runner as _moved

warn_moved_module(__name__, "indentation_studio.forward.febio.runner")


def __getattr__(name: str) -> Any:
    return getattr(_moved, name)
