"""The one place that unpickles a surrogate: the one-time conversion of a format 1 file (a joblib
pickle, as Indentation Studio wrote before format 2) into the safe format. Unpickling runs any code
the file holds, so this is only ever done when a user asks for it, on a file they trust
(``indent-studio surrogate convert``); :func:`load_surrogate` never does it."""

from __future__ import annotations

from pathlib import Path

from .base import FieldSurrogate
from .persistence import save_surrogate
from .safe_file import SurrogateFileError, file_kind

__all__ = ["OLD_FORMAT", "convert_pickled_surrogate"]

OLD_FORMAT = "indentation-studio-surrogate/1"


def convert_pickled_surrogate(old: str | Path, new: str | Path) -> Path:
    """Convert a format 1 (pickle, joblib) surrogate file to the safe format.

    Unpickling ``old`` RUNS ANY CODE IT HOLDS: only for files you trust. The model's ``meta``
    gains ``converted_from`` (the old file, its format and its versions).

    Parameters
    ----------
    old : str or pathlib.Path
        The format 1 file.
    new : str or pathlib.Path
        Where to write the safe file (not ``old``).

    Returns
    -------
    pathlib.Path
        ``new``, as written by :func:`save_surrogate`.

    Raises
    ------
    FileNotFoundError
        If ``old`` does not exist.
    SurrogateFileError
        If ``old`` is already a safe file, not a pickle, unreadable, not an Indentation Studio
        surrogate, or ``new`` is ``old``.
    """
    import joblib

    old, new = Path(old), Path(new)
    if not old.is_file():
        raise FileNotFoundError(f"no surrogate file {old}")
    kind = file_kind(old)
    if kind == "safetensors":
        raise SurrogateFileError(f"{old} is already a safe (safetensors) surrogate file: nothing to convert")
    if kind not in ("pickle", "joblib-compressed"):
        raise SurrogateFileError(f"{old} is not a pickle (joblib) surrogate file ({kind} format)")
    if new.resolve() == old.resolve():
        raise SurrogateFileError(f"{new}: write the converted surrogate to another file than {old}")
    try:
        payload = joblib.load(old)
    except Exception as exc:  # a truncated or foreign pickle
        raise SurrogateFileError(f"{old}: not a readable joblib surrogate file ({exc})") from exc
    if not isinstance(payload, dict) or payload.get("format") != OLD_FORMAT:
        raise SurrogateFileError(f"{old}: a pickle, but not an Indentation Studio surrogate ({OLD_FORMAT})")
    model = payload.get("model")
    if not isinstance(model, FieldSurrogate):
        raise SurrogateFileError(f"{old}: its 'model' is a {type(model).__name__}, not a surrogate")
    model.meta["converted_from"] = {
        "file": str(old),
        "format": OLD_FORMAT,
        "versions": model.meta.get("versions"),
    }
    return save_surrogate(model, new)
