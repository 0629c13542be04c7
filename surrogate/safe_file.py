"""The surrogate file container: one safetensors file holding named arrays and a JSON header, and
the recognition of files of other formats (pickles, joblib files, zip/npz archives) by their
first bytes, so that such a file is refused by name and never unpickled.

Why safetensors: a safetensors file is an 8-byte header length, a JSON header (array names,
dtypes, shapes, byte offsets and a ``__metadata__`` map of strings) and the raw little-endian
array bytes; its reader (Rust) checks every offset and runs nothing on load, and any safetensors
tool can list what a surrogate file holds. One file per surrogate: the configuration and the
provenance travel in ``__metadata__`` as JSON text beside the arrays.

safetensors stores C-ordered data only; a Fortran-ordered array (scikit-learn's PCA components
and GP Cholesky factor are) is stored as its transpose and given back in Fortran order, so that a
loaded model runs the same BLAS calls on the same memory layout as the saved one (bit-for-bit
predictions).
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic_write import atomic_write

__all__ = [
    "FORMAT",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "SurrogateFileError",
    "file_kind",
    "read_container",
    "write_container",
]

FORMAT_NAME = "indentation-studio-surrogate"
FORMAT_VERSION = 2
FORMAT = f"{FORMAT_NAME}/{FORMAT_VERSION}"
_LAYOUT_KEY = "array_layouts"  # header entry: {array name: "F"} for Fortran-ordered arrays

# first bytes of joblib's compressed files (joblib/compressor.py and numpy_pickle_compat.py)
_COMPRESSED_JOBLIB = {
    b"ZF": "zlib (old joblib)",
    b"\x1f\x8b": "gzip",
    b"BZh": "bz2",
    b"\xfd7zXZ": "xz",
    b"]\x00\x00": "lzma",
    b"\x04\x22\x4d\x18": "lz4",
}
# opcodes a protocol 0 or 1 pickle can start with: MARK, GLOBAL, EMPTY_LIST/DICT/TUPLE, INT ...
_OLD_PICKLE_FIRST = b"(c]})ILFSNVXJKMGU"


class SurrogateFileError(ValueError):
    """A surrogate file that cannot be read: of another format, damaged or inconsistent."""


def file_kind(path: str | Path) -> str:
    """What ``path`` holds, from its first and last bytes only (nothing is parsed or run):
    'safetensors', 'pickle', 'joblib-compressed', 'zip' or 'unknown'."""
    path = Path(path)
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(16)
        fh.seek(max(size - 1, 0))
        last = fh.read(1)
    if len(head) >= 9:
        (header_len,) = struct.unpack("<Q", head[:8])
        if 2 <= header_len <= size - 8 and head[8:9] == b"{":
            return "safetensors"
    if head[:1] == b"\x80" and head[1:2] and head[1] <= 5:  # PROTO opcode: pickle protocol 2 to 5
        return "pickle"
    if head[:1] in (b"x",) and len(head) >= 2 and (head[0] * 256 + head[1]) % 31 == 0:
        return "joblib-compressed"  # a zlib stream: joblib.dump(..., compress=n)
    if any(head.startswith(magic) for magic in _COMPRESSED_JOBLIB):
        return "joblib-compressed"
    if head.startswith(b"PK\x03\x04") or head.startswith(b"PK\x05\x06"):
        return "zip"
    if head[:1] and head[:1] in _OLD_PICKLE_FIRST and last == b".":  # ... ends with STOP
        return "pickle"
    return "unknown"


def refusal(path: Path, kind: str) -> SurrogateFileError:
    """The error for a file that is not in the safe format, naming what it is."""
    if kind in ("pickle", "joblib-compressed"):
        what = "a pickle (joblib) surrogate file" if kind == "pickle" else "a compressed joblib (pickle) file"
        return SurrogateFileError(
            f"{path} is {what}; loading it would run any code it holds, so it is not opened. "
            f"If you trust where it came from, convert it knowingly with "
            f"`indent-studio surrogate convert --model {path} --out NEW.safetensors`"
        )
    if kind == "zip":
        return SurrogateFileError(
            f"{path} is a zip (or npz) archive, not an Indentation Studio surrogate file"
        )
    return SurrogateFileError(f"{path} is not an Indentation Studio surrogate file (unknown format)")


def _storable(name: str, array: np.ndarray) -> tuple[np.ndarray, bool]:
    """(C-ordered data to store, whether it is the transpose of a Fortran-ordered array)."""
    array = np.asarray(array)
    if array.dtype.kind not in "biuf":
        raise SurrogateFileError(f"array {name!r} has dtype {array.dtype}: only numbers can be saved")
    if array.ndim >= 2 and array.flags.f_contiguous and not array.flags.c_contiguous:
        return np.ascontiguousarray(array.T), True
    return np.ascontiguousarray(array), False


def write_container(path: str | Path, header: dict[str, str], arrays: dict[str, np.ndarray]) -> Path:
    """Write ``arrays`` and the string map ``header`` (which must hold ``format``) to one
    safetensors file at ``path``, atomically."""
    from safetensors.numpy import save

    if header.get("format") != FORMAT or _LAYOUT_KEY in header:
        raise ValueError(f"a surrogate file header needs format {FORMAT!r} and no {_LAYOUT_KEY!r}")
    stored, fortran = {}, []
    for name, array in arrays.items():
        stored[name], transposed = _storable(name, array)
        if transposed:
            fortran.append(name)
    metadata = {**header, _LAYOUT_KEY: json.dumps(dict.fromkeys(fortran, "F"))}
    return atomic_write(path, save(stored, metadata=metadata))


def _check_format(path: Path, metadata: dict[str, str] | None) -> None:
    found = (metadata or {}).get("format")
    if found is None:
        raise SurrogateFileError(
            f"{path} is a safetensors file but not an Indentation Studio surrogate (no 'format' field)"
        )
    name, _, version = found.partition("/")
    if name != FORMAT_NAME:
        raise SurrogateFileError(f"{path}: format {found!r} is not an Indentation Studio surrogate")
    if version != str(FORMAT_VERSION):
        raise SurrogateFileError(
            f"{path}: surrogate file format {found!r}; this version of Indentation Studio reads {FORMAT!r}"
        )


def read_container(path: str | Path) -> tuple[dict[str, str], dict[str, np.ndarray]]:
    """The header (string map) and the arrays of a file written by :func:`write_container`. A
    file of another format is refused by name without being parsed beyond its first bytes."""
    from safetensors import safe_open

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no surrogate file {path}")
    kind = file_kind(path)
    if kind != "safetensors":
        raise refusal(path, kind)
    try:
        with safe_open(path, framework="numpy") as fh:
            metadata = fh.metadata()
            _check_format(path, metadata)
            arrays = {name: fh.get_tensor(name) for name in fh.keys()}
    except SurrogateFileError:
        raise
    except Exception as exc:  # the reader's own errors: a truncated or damaged file
        raise SurrogateFileError(f"{path}: damaged surrogate file ({exc})") from exc
    try:
        fortran = json.loads(metadata.pop(_LAYOUT_KEY, "{}"))
    except json.JSONDecodeError as exc:
        raise SurrogateFileError(f"{path}: header field {_LAYOUT_KEY!r} is not JSON ({exc})") from exc
    for name in fortran:
        if name not in arrays:
            raise SurrogateFileError(f"{path}: header field {_LAYOUT_KEY!r} names no array {name!r}")
        arrays[name] = arrays[name].T  # the transpose of C-ordered data: Fortran-ordered again
    return metadata, arrays


def json_header_field(path: Path, header: dict[str, str], field: str) -> Any:
    """``header[field]`` parsed as JSON, or an error naming the file and the field."""
    if field not in header:
        raise SurrogateFileError(f"{path}: header field {field!r} missing")
    try:
        return json.loads(header[field])
    except json.JSONDecodeError as exc:
        raise SurrogateFileError(f"{path}: header field {field!r} is not JSON ({exc})") from exc
