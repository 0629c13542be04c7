"""Moved to :mod:`indentation_studio.design.friction_treatment` (how a fit or a design treats the
friction coefficient is certainty-bound math, eq. 6 to 8); this path is kept for one version."""

from ..moved_names import moved_module

__getattr__ = moved_module(__name__, "indentation_studio.design.friction_treatment")
