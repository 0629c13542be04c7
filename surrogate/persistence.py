"""Saving and loading a trained surrogate with what made it: the campaign spec, the library
versions and the validation scores (one joblib file, written atomically)."""

from __future__ import annotations

import platform
from pathlib import Path

import joblib
import numpy as np
import sklearn
import torch

from .. import __version__
from ..atomic_write import atomic_write
from .base import FieldSurrogate


def versions() -> dict[str, str]:
    return {
        "indentation_studio": __version__,
        "numpy": np.__version__,
        "scikit-learn": sklearn.__version__,
        "torch": torch.__version__,
        "python": platform.python_version(),
    }


def save_surrogate(surrogate: FieldSurrogate, path: str | Path) -> Path:
    """Write ``surrogate`` (with ``meta`` holding its provenance) to ``path``."""
    surrogate.meta["versions"] = versions()
    payload = {"format": "indentation-studio-surrogate/1", "model": surrogate}
    return atomic_write(path, lambda tmp: joblib.dump(payload, tmp))


def load_surrogate(path: str | Path) -> FieldSurrogate:
    """A surrogate saved by :func:`save_surrogate`; a file of another kind is refused by name."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no surrogate file {path}")
    try:
        payload = joblib.load(path)
    except Exception as exc:  # a truncated or foreign file
        raise ValueError(f"{path}: not a readable surrogate file ({exc})") from exc
    if not isinstance(payload, dict) or payload.get("format") != "indentation-studio-surrogate/1":
        raise ValueError(f"{path}: not an Indentation Studio surrogate file")
    return payload["model"]
