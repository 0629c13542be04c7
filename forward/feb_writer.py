"""Moved to :mod:`indentation_studio.forward.febio.writer` (the FEBio backend is one subpackage);
this path is kept for one version."""

from ..moved_names import moved_module

__getattr__ = moved_module(__name__, "indentation_studio.forward.febio.writer")
