"""Saving and loading a trained surrogate with what made it (the campaign spec, the library
versions, the validation scores) in one file that runs no code when it is opened.

The file (format ``indentation-studio-surrogate/2``, default suffix ``.safetensors``) is one
safetensors container (see ``safe_file``): every array of the model (PCA components and means,
the GPs' training inputs, alpha_ and Cholesky factors, the networks' weights, the input box) and,
in its header, JSON text: ``surrogate`` (the class hyperparameters and the fitted scalars and
kernels: see ``sklearn_state``), ``meta`` (the provenance) and ``self_check`` (names of the
arrays holding predictions made when saving: forces at three points of the box, the field at
its centre). Loading rebuilds
the model from scikit-learn and torch classes named in fixed lists, predicts at those points and
refuses the file if the predictions differ from the saved ones (a damaged file, or libraries
whose internals changed). Pickles and joblib files are refused by name; ``pickle_conversion``
converts one knowingly.
"""

from __future__ import annotations

import json
import platform
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from .base import FieldSurrogate
from .emulation_error import DISCREPANCY_PREFIX, EmulationError
from .registry import surrogate_class
from .safe_file import FORMAT, SurrogateFileError, json_header_field, read_container, write_container

__all__ = ["DEFAULT_SUFFIX", "SurrogateFileError", "load_surrogate", "save_surrogate", "versions"]

DEFAULT_SUFFIX = ".safetensors"
SELF_CHECK_ARRAYS = frozenset(f"self_check.{name}" for name in ("theta", "force", "displacement"))
SELF_CHECK_TOLERANCE = 1e-9  # relative to the largest |value|: exact on one machine, BLAS builds differ


def _library_version(name: str) -> str:
    try:
        return version(name)
    except PackageNotFoundError:
        return "not installed"


def versions() -> dict[str, str]:
    """The versions a surrogate was made with (read from the installed metadata, nothing imported)."""
    return {
        "indentation_studio": __version__,
        "numpy": np.__version__,
        "scikit-learn": _library_version("scikit-learn"),
        "torch": _library_version("torch"),
        "safetensors": _library_version("safetensors"),
        "python": platform.python_version(),
    }


def _json_default(value: Any) -> Any:
    if isinstance(value, np.integer | np.bool_):
        return value.item()
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"a {type(value).__name__} in the surrogate's meta cannot be written as JSON")


def _self_check_points(model: FieldSurrogate) -> np.ndarray:
    """Three points inside the training box (its centre and two off-diagonal points)."""
    lo, hi = model.scaler.lo, model.scaler.hi
    fractions = np.array([0.5, 0.25, 0.8])[:, None] * np.ones(len(lo))
    fractions[1:, 1::2] = 1.0 - fractions[1:, 1::2]  # not on the diagonal of the box
    return lo + fractions * (hi - lo)


def _self_check_arrays(model: FieldSurrogate, theta: np.ndarray) -> dict[str, np.ndarray]:
    """Forces at every point of ``theta`` and the field at the first (the field is most of a
    file's size: one point of it is enough to catch damage). No Jacobians: they come from the
    same arrays, and the MLP's (torch.func) would add about 2 s to a fresh process's load."""
    p = model.predict(theta)
    return {
        "self_check.theta": theta,
        "self_check.force": p.force,
        "self_check.displacement": p.displacement[:1],
    }


def save_surrogate(surrogate: FieldSurrogate, path: str | Path) -> Path:
    """Write a surrogate to a file in the safe format ``indentation-studio-surrogate/2``.

    One safetensors file, written atomically (the CLI names it ``surrogate-<kind>.safetensors``),
    with ``meta`` holding its provenance and a self check of predictions that
    :func:`load_surrogate` verifies.

    Parameters
    ----------
    surrogate : FieldSurrogate
        A trained surrogate.
    path : str or pathlib.Path
        The file to write.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        If the surrogate's array names clash with those reserved for the self check.
    """
    surrogate.meta["versions"] = versions()
    config, arrays = surrogate.to_state()
    emulation = surrogate.emulation_error
    if emulation is not None:
        surrogate.meta["emulation_error"] = emulation.describe()
        arrays = {**arrays, **surrogate.kept_emulation_error().to_arrays()}
    discrepancy = getattr(surrogate, "discrepancy_error", None)
    if discrepancy is not None:
        surrogate.meta["discrepancy_error"] = discrepancy.describe()
        arrays = {**arrays, **discrepancy.to_arrays(DISCREPANCY_PREFIX)}
    check = _self_check_arrays(surrogate, _self_check_points(surrogate))
    header = {
        "format": FORMAT,
        "kind": surrogate.kind,
        "surrogate": json.dumps(config),
        "meta": json.dumps(surrogate.meta, default=_json_default),
        "self_check": json.dumps(sorted(check)),
    }
    clash = set(check) & set(arrays)
    if clash:
        raise ValueError(f"array names {sorted(clash)} are reserved for the self check")
    return write_container(path, header, {**arrays, **check})


def _verify(path: Path, model: FieldSurrogate, arrays: dict[str, np.ndarray], names: list[str]) -> None:
    """The rebuilt model predicts what the saved one did at the self-check points."""
    missing = sorted(SELF_CHECK_ARRAYS - set(arrays))
    if missing or set(names) != SELF_CHECK_ARRAYS:
        raise SurrogateFileError(f"{path}: self-check arrays {missing or names} missing or unexpected")
    try:
        with np.errstate(all="ignore"):  # a damaged model may overflow: that is what is checked
            again = _self_check_arrays(model, arrays["self_check.theta"])
    except (ValueError, TypeError, RuntimeError, IndexError, AttributeError) as exc:
        raise SurrogateFileError(f"{path}: the loaded surrogate cannot predict ({exc})") from exc
    for name in sorted(SELF_CHECK_ARRAYS):
        saved, now = arrays[name], again[name]
        tolerance = SELF_CHECK_TOLERANCE * float(np.abs(saved).max(initial=0.0))
        if saved.shape != now.shape or not np.all(np.abs(now - saved) <= tolerance):  # NaN fails too
            raise SurrogateFileError(
                f"{path}: the loaded surrogate does not reproduce its saved predictions ({name}); the "
                f"file is damaged or was written with other library versions "
                f"({model.meta.get('versions')} vs {versions()})"
            )


def load_surrogate(path: str | Path) -> FieldSurrogate:
    """Read a surrogate saved by :func:`save_surrogate`.

    Nothing in the file is run: a pickle or joblib file (the old format 1, see
    :func:`convert_pickled_surrogate`), or any other file, is refused by name without being
    unpickled.

    Parameters
    ----------
    path : str or pathlib.Path
        The surrogate file.

    Returns
    -------
    FieldSurrogate
        The surrogate, its ``meta`` restored and its self check passed.

    Raises
    ------
    SurrogateFileError
        If the file is not a safe surrogate file, is inconsistent, or fails its self check.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> model = ins.load_surrogate("runs/paper/surrogate-gp.safetensors")  # doctest: +SKIP
    >>> model.predict([[5.0, 300.0]]).force.shape  # doctest: +SKIP
    """
    path = Path(path)
    header, arrays = read_container(path)
    config = json_header_field(path, header, "surrogate")
    meta = json_header_field(path, header, "meta")
    check = json_header_field(path, header, "self_check")
    try:
        model = surrogate_class(config["kind"]).from_state(config, arrays)
    except (KeyError, TypeError, ValueError, RuntimeError) as exc:
        reason = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        raise SurrogateFileError(f"{path}: inconsistent surrogate file ({reason})") from exc
    model.meta = meta
    _verify(path, model, arrays, check)
    kept = meta.get("emulation_error") if isinstance(meta, dict) else None
    model.restore_emulation_error(
        EmulationError.from_arrays(arrays, (kept or {}).get("source", "held-out points"))
    )
    if hasattr(model, "discrepancy_error"):
        kept = meta.get("discrepancy_error") if isinstance(meta, dict) else None
        model.discrepancy_error = EmulationError.from_arrays(
            arrays, (kept or {}).get("source", "held-out points"), prefix=DISCREPANCY_PREFIX
        )
    return model
