"""Indentation Studio: identifiability-aware identification of soft-tissue parameters.

The subpackages live in the repository's top-level folders (``forward/``, ``design/``,
``surrogate/``, ``studio/``) and are installed under this one import name.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("indentation-studio")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
