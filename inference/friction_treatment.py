"""Moved to :mod:`indentation_studio.design.friction_treatment` (how a fit or a design treats the
friction coefficient is certainty-bound math, eq. 6 to 8); this path is kept for one version."""

from ..design.friction_treatment import *  # noqa: F403
from ..design.friction_treatment import __all__  # noqa: F401
from ..moved_names import warn_moved_module

warn_moved_module(__name__, "indentation_studio.design.friction_treatment")
