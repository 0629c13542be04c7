"""The surrogates shipped with the package for the paper's two tests (issue 46): found by the test an
experiment was made with, checked against their recorded sha256 before anything is read.

The package data folder ``indentation_studio/surrogates`` holds one safetensors file per test and a
``manifest.json`` that lists, for each file, its sha256 and size, the test it emulates (indenter
radius, steps, depth per step), the campaigns it was trained on (grid, points, failures, wall time),
its held-out errors, the package version and commit that made it and the one command that remakes it
(``tools/ship_surrogates.py``). A fit or a posterior given no surrogate takes the one whose test
matches the experiment's (:func:`shipped_for_test`) and says so; a test none matches gets the command
to build one (:func:`recipe_for_test`).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic_write import atomic_write_json
from .base import FieldSurrogate
from .persistence import load_surrogate
from .safe_file import SurrogateFileError

__all__ = [
    "MANIFEST_NAME",
    "TESTS_ENV",
    "ShippedSurrogate",
    "add_to_manifest",
    "file_sha256",
    "find_test",
    "load_shipped",
    "recipe_for_test",
    "shipped_for_test",
    "shipped_surrogates",
    "shipped_surrogates_folder",
    "test_folders",
]

#: The manifest's file name in the shipped folder.
MANIFEST_NAME = "manifest.json"
_SCHEMA = "indentation-studio/shipped-surrogates/1"
_TOLERANCE_MM = 1e-6  # radius and depths must agree to this


def shipped_surrogates_folder() -> Path:
    """Where the shipped surrogates are: ``indentation_studio/surrogates`` (package data).

    Returns
    -------
    pathlib.Path
        The folder of the installed package's surrogate files.
    """
    return Path(str(files("indentation_studio") / "surrogates"))


def file_sha256(path: str | Path) -> str:
    """The sha256 of a file's bytes, hex.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    str
        64 hex digits.
    """
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@dataclass(frozen=True, eq=False)
class ShippedSurrogate:
    """One shipped surrogate as its manifest lists it.

    Attributes
    ----------
    name : str
        Its name (``paper-test-R8``).
    path : pathlib.Path
        The file.
    sha256 : str
        The sha256 its bytes must have.
    bytes : int
        Its size.
    radius : float
        The indenter radius of its test, mm.
    depths : numpy.ndarray
        (steps,) the depth of each step, mm.
    recipe : str
        The command that remakes it.
    provenance : dict
        The rest of its manifest entry (campaigns, held-out errors, version, commit).
    block : dict or None
        Its specimen's quarter (``half_x``, ``half_y``, ``height``, mm), where the manifest says.
    """

    name: str
    path: Path
    sha256: str
    bytes: int
    radius: float
    depths: np.ndarray
    recipe: str
    provenance: dict[str, Any] = field(default_factory=dict)
    block: dict[str, float] | None = None

    @property
    def test(self) -> str:
        """The test in words: ``R = 8 mm, 28 x 0.5 mm``."""
        return _test_words(self.radius, self.depths)

    def matches(self, radius: float, depths, block: dict[str, float] | None = None) -> bool:
        """Whether an experiment with this indenter radius and these step depths is its test.

        Parameters
        ----------
        radius : float
            The indenter radius, mm.
        depths : array_like
            (steps,) the depth of each step, mm.
        block : dict, optional
            The specimen's quarter (``half_x``, ``half_y``, ``height``, mm); None: not compared.

        Returns
        -------
        bool
            Radius, every depth and (where both are known) the specimen within 1e-6 mm.
        """
        depths = np.asarray(depths, float)
        same_block = (
            block is None
            or self.block is None
            or all(
                abs(float(self.block[k]) - float(block[k])) <= _TOLERANCE_MM
                for k in ("half_x", "half_y", "height")
            )
        )
        return (
            abs(self.radius - float(radius)) <= _TOLERANCE_MM
            and depths.shape == self.depths.shape
            and bool(np.allclose(depths, self.depths, rtol=0.0, atol=_TOLERANCE_MM))
            and same_block
        )

    def verified_path(self) -> Path:
        """The file, after checking its size and sha256 against the manifest.

        Returns
        -------
        pathlib.Path
            The file.

        Raises
        ------
        SurrogateFileError
            Naming the file, if it is missing or its bytes are not those the manifest records.
        """
        if not self.path.is_file():
            raise SurrogateFileError(f"shipped surrogate {self.path} is missing (the manifest lists it)")
        found = file_sha256(self.path)
        if found != self.sha256:
            raise SurrogateFileError(
                f"shipped surrogate {self.path}: sha256 {found} is not the manifest's {self.sha256}; "
                f"the file was changed or damaged, so it is not used (remake it: {self.recipe})"
            )
        return self.path

    def describe(self) -> str:
        """One line: its name, test and file (a prepared test's: its folder)."""
        shipped = self.path.parent.resolve() == shipped_surrogates_folder().resolve()
        kind = "the shipped surrogate" if shipped else f"the prepared test {self.path.parent} ->"
        return f"{kind} {self.name} ({self.test}; {self.path.name}, {self.bytes / 1e6:.1f} MB)"


def _test_words(radius: float, depths: np.ndarray) -> str:
    depths = np.asarray(depths, float)
    step = depths[0] if depths.size else 0.0
    return f"R = {radius:g} mm, {depths.size} x {step:g} mm"


def _entry(folder: Path, item: dict[str, Any]) -> ShippedSurrogate:
    test = item["test"]
    depths = np.asarray(test["depths_mm"], float)
    known = {"name", "file", "sha256", "bytes", "test", "recipe"}
    return ShippedSurrogate(
        name=str(item["name"]),
        path=folder / str(item["file"]),
        sha256=str(item["sha256"]),
        bytes=int(item["bytes"]),
        radius=float(test["radius_mm"]),
        depths=depths,
        recipe=str(item["recipe"]),
        provenance={k: v for k, v in item.items() if k not in known},
        block=test.get("block_mm"),
    )


def shipped_surrogates(folder: str | Path | None = None) -> list[ShippedSurrogate]:
    """The shipped surrogates the manifest lists (none when there is no manifest).

    Parameters
    ----------
    folder : str or pathlib.Path, optional
        Where to look; default :func:`shipped_surrogates_folder`.

    Returns
    -------
    list of ShippedSurrogate
        In the manifest's order.

    Raises
    ------
    SurrogateFileError
        If the manifest is not JSON or lacks a field (its KeyError, TypeError or ValueError).
    """
    folder = Path(folder or shipped_surrogates_folder())
    manifest = folder / MANIFEST_NAME
    if not manifest.is_file():
        return []
    try:
        payload = json.loads(manifest.read_text())
        if payload.get("schema") != _SCHEMA:
            raise KeyError(f"schema {payload.get('schema')!r}, expected {_SCHEMA!r}")
        return [_entry(folder, item) for item in payload["surrogates"]]
    except (ValueError, KeyError, TypeError) as exc:
        raise SurrogateFileError(f"{manifest}: not a shipped-surrogates manifest ({exc})") from exc


#: Folders of prepared tests (``indent-studio test prepare``), os.pathsep-separated, that a fit looks
#: in before the shipped surrogates.
TESTS_ENV = "INDENTATION_STUDIO_TESTS"


def test_folders(tests: str | Path | None = None) -> list[Path]:
    """Where a fit looks for its test's surrogate: ``tests``, then :data:`TESTS_ENV`'s, then the shipped.

    Parameters
    ----------
    tests : str or pathlib.Path, optional
        A folder of prepared tests (a prepared test's own folder, with its ``manifest.json``).

    Returns
    -------
    list of pathlib.Path
        The folders in the order they are read.
    """
    named = [Path(tests)] if tests is not None else []
    named += [Path(p) for p in os.environ.get(TESTS_ENV, "").split(os.pathsep) if p]
    return [*named, shipped_surrogates_folder()]


def find_test(
    radius: float, depths, *, tests: str | Path | None = None, block: dict[str, float] | None = None
) -> ShippedSurrogate | None:
    """The prepared or shipped surrogate of a test, read in :func:`test_folders`' order.

    Parameters
    ----------
    radius : float
        The indenter radius, mm.
    depths : array_like
        (steps,) the depth of each step, mm.
    tests : str or pathlib.Path, optional
        A folder of prepared tests, read first.
    block : dict, optional
        The specimen's quarter (``half_x``, ``half_y``, ``height``, mm); None: not compared.

    Returns
    -------
    ShippedSurrogate or None
        The first that matches; its file is checked against its manifest when it is loaded
        (:func:`load_shipped`).

    Raises
    ------
    SurrogateFileError
        If a named folder has no manifest (a folder that is not a prepared test).
    """
    for folder in test_folders(tests):
        if folder != shipped_surrogates_folder() and not (folder / MANIFEST_NAME).is_file():
            raise SurrogateFileError(
                f"{folder}: no {MANIFEST_NAME} (a prepared test's folder holds one: indent-studio test prepare)"
            )
        entry = shipped_for_test(radius, depths, folder=folder, block=block)
        if entry is not None:
            return entry
    return None


def shipped_for_test(
    radius: float, depths, *, folder: str | Path | None = None, block: dict[str, float] | None = None
) -> ShippedSurrogate | None:
    """The shipped surrogate whose test is an indenter of ``radius`` pushed to ``depths``, if any.

    Parameters
    ----------
    radius : float
        The indenter radius, mm.
    depths : array_like
        (steps,) the depth of each step, mm.
    folder : str or pathlib.Path, optional
        Where to look; default :func:`shipped_surrogates_folder`.
    block : dict, optional
        The specimen's quarter (``half_x``, ``half_y``, ``height``, mm); None: not compared.

    Returns
    -------
    ShippedSurrogate or None
        The first that matches (radius, every depth and a stated specimen within 1e-6 mm).
    """
    for entry in shipped_surrogates(folder):
        if entry.matches(radius, depths, block):
            return entry
    return None


def recipe_for_test(radius: float, depths, *, folder: str | Path | None = None) -> str:
    """What to do for a test no shipped surrogate matches: the command that builds one.

    The paragraph names the test, the shipped tests and the recipe's command for this test.

    Parameters
    ----------
    radius : float
        The indenter radius, mm.
    depths : array_like
        (steps,) the depth of each step, mm.
    folder : str or pathlib.Path, optional
        Where to look; default :func:`shipped_surrogates_folder`.

    Returns
    -------
    str
        A paragraph naming the test, the shipped tests and the command.
    """
    depths = np.asarray(depths, float)
    shipped = shipped_surrogates(folder)
    have = "; ".join(entry.test for entry in shipped) or "none"
    step = depths[0] if depths.size else 0.5
    return (
        f"no shipped surrogate matches this test ({_test_words(radius, depths)}; shipped: {have}). "
        f"Prepare it (its surrogates and error budget; the cost is said first) and fit with --tests: "
        f"`indent-studio test prepare --radius {radius:g} --steps {depths.size} --step-size {step:g} "
        f"--folder tests/R{radius:g}` (add --specimen WxDxT for another specimen; docs/guide/own-test.md)"
    )


def load_shipped(entry: ShippedSurrogate) -> FieldSurrogate:
    """Load a shipped surrogate after checking its sha256.

    Parameters
    ----------
    entry : ShippedSurrogate
        From :func:`shipped_surrogates` or :func:`shipped_for_test`.

    Returns
    -------
    FieldSurrogate
        The surrogate, its ``meta['shipped']`` naming the file and its sha256.

    Raises
    ------
    SurrogateFileError
        If its bytes are not those the manifest records (naming the file).
    """
    model = load_surrogate(entry.verified_path())
    model.meta["shipped"] = {"name": entry.name, "file": entry.path.name, "sha256": entry.sha256}
    return model


def add_to_manifest(folder: str | Path, entry: dict[str, Any]) -> Path:
    """Add one surrogate's entry to ``folder``'s manifest (replacing one of the same name).

    Parameters
    ----------
    folder : str or pathlib.Path
        The folder of the surrogate files.
    entry : dict
        ``name``, ``file`` (in ``folder``), ``sha256``, ``bytes``, ``test`` (``radius_mm``,
        ``depths_mm``), ``recipe`` and any provenance.

    Returns
    -------
    pathlib.Path
        The manifest written.

    Raises
    ------
    SurrogateFileError
        If the entry's file is not in ``folder`` or its sha256 is not the entry's.
    """
    folder = Path(folder)
    checked = _entry(folder, entry)
    checked.verified_path()
    manifest = folder / MANIFEST_NAME
    payload = (
        json.loads(manifest.read_text()) if manifest.is_file() else {"schema": _SCHEMA, "surrogates": []}
    )
    kept = [item for item in payload["surrogates"] if item["name"] != entry["name"]]
    payload["surrogates"] = sorted([*kept, entry], key=lambda item: item["test"]["radius_mm"])
    return atomic_write_json(manifest, payload)
