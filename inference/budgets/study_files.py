"""A verification study's files: ``study.json`` read back, and studies made at different points
merged into one (:mod:`inference.budgets.verification_study` writes them)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["PER_POINT_INPUTS", "load_verification_study", "merge_verification_studies"]


def load_verification_study(path: str | Path) -> dict[str, Any]:
    """A study's ``study.json`` as written.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    dict
        The study (schema, code version, family, levels, inputs, cases).

    Raises
    ------
    ValueError
        A file that cannot be read or is not a verification study (naming it).
    """
    p = Path(path)
    try:
        data = json.loads(p.read_text())
    except (OSError, ValueError) as exc:
        raise ValueError(f"{p}: not a readable verification study ({exc})") from exc
    if data.get("schema") != "indentation-studio/verification-study/1":
        raise ValueError(f"{p}: not a verification study (schema {data.get('schema')!r})")
    return data


#: The inputs in which studies made point by point may differ (what :func:`merge_verification_studies` unites).
PER_POINT_INPUTS = ("points", "radii")


def merge_verification_studies(paths: Sequence[str | Path]) -> dict[str, Any]:
    """One study from studies of the same family, levels and inputs made at different points.

    A level-4 study is hours of CPU a point: it may be made a point (or a few) at a time, on
    different machines or days, each with its own ``study.json``. Merged, they are the study of all
    their points, as if made by one command (the cases in the order of the files, then of each file).

    Parameters
    ----------
    paths : sequence of str or pathlib.Path
        ``study.json`` files (or their copies); one is returned as it is.

    Returns
    -------
    dict
        A study as ``study.json`` records it, with ``inputs["points"]`` and ``inputs["radii"]`` the
        union of the files', ``wall_s`` their sum (where each has one) and ``merged_from`` the files.

    Raises
    ------
    ValueError
        No file, a file that is not a study, two files whose family, levels or other inputs differ
        (naming the first that differs), or the same (radius, point) in two files.

    Examples
    --------
    >>> study = merge_verification_studies(["study-3-330.json", "study-11-330.json"])  # doctest: +SKIP
    """
    if not paths:
        raise ValueError("no verification study to merge")
    studies = [load_verification_study(p) for p in paths]
    first, merged = studies[0], dict(studies[0])
    if len(studies) == 1:
        return merged
    cases, seen, points, radii = [], {}, [], []
    for path, study in zip(paths, studies, strict=True):
        for key in ("family", "levels"):
            if study[key] != first[key]:
                raise ValueError(f"{path}: its {key} differs from {paths[0]}'s")
        for key in sorted(set(study["inputs"]) | set(first["inputs"])):
            if key not in PER_POINT_INPUTS and study["inputs"].get(key) != first["inputs"].get(key):
                raise ValueError(f"{path}: its input {key!r} differs from {paths[0]}'s")
        for case in study["cases"]:
            key = (float(case["radius"]), *(float(x) for x in case["theta"]))
            if key in seen:
                raise ValueError(f"{path}: R = {key[0]:g} mm at {key[1:]} is also in {seen[key]}")
            seen[key] = path
            cases.append(case)
        points += [p for p in study["inputs"].get("points", []) if p not in points]
        radii += [r for r in study["inputs"].get("radii", []) if r not in radii]
    merged["inputs"] = dict(first["inputs"]) | {"points": points, "radii": radii}
    merged["cases"] = cases
    walls = [s.get("wall_s") for s in studies]
    if all(w is not None for w in walls):
        merged["wall_s"] = float(sum(walls))
    merged["merged_from"] = [str(p) for p in paths]
    return merged
