"""Moved to :mod:`indentation_studio.inference.lab.hold_detection` (the readers of a lab's files are one
subpackage); this path is kept for one version."""

from ..moved_names import moved_module

__getattr__ = moved_module(__name__, "indentation_studio.inference.lab.hold_detection")
