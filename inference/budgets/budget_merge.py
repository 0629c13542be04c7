"""Error budgets of one test measured at different points, merged into one (issue 57: a budget
grown by a point, e.g. the box's corner where a fit lay outside the budget's points).

Each budget is made and moved to its finest level as one is (``design study-budget`` on a
verification study of its points, then ``design budget-reference``); the merge checks that they
are of the same test, objective, noise, field of view and reference rule, and joins their rows.
A fit then reads the merged budget between all its points (``surrogate.error_budgets.budget_at``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from ...surrogate.error_budgets import indentation_test_of
from .budget_table import ErrorBudget

__all__ = ["merge_error_budgets"]

#: What must be equal in the budgets merged (their meaning differs otherwise).
SAME = ("weights", "force_noise", "dic_noise_mm", "field_of_view_mm", "reading", "fe_steps")
#: ... and in their references.
SAME_REFERENCE = ("family", "level", "corrected_level", "rule", "gci_carried", "corrected")


def merge_error_budgets(files: Sequence[str | Path]) -> dict:
    """One error budget from several of the same test measured at different points.

    Parameters
    ----------
    files : sequence of str or pathlib.Path
        Two or more error-budget.json files (``design study-budget``, each moved or not by
        ``design budget-reference`` as the others).

    Returns
    -------
    dict
        The first file's payload with every file's rows, the summary made again over them, the
        reference's ``points`` counted again and ``merged_from`` naming the files.

    Raises
    ------
    ValueError
        If fewer than two files are given, a file is incomplete, the budgets differ in test,
        objective, noise, field of view or reference rule, or two hold the same model at the
        same point.
    """
    if len(files) < 2:
        raise ValueError("merging error budgets needs two files or more")
    payloads = [json.loads(Path(f).read_text()) for f in files]
    first = payloads[0]
    test = json.dumps(indentation_test_of(first["reference"]["model"]), sort_keys=True)
    for path, payload in zip(files, payloads, strict=True):
        if not payload.get("complete", True):
            raise ValueError(f"{path}: an incomplete budget (its rows are still to come)")
    for path, payload in zip(files[1:], payloads[1:], strict=True):
        if json.dumps(indentation_test_of(payload["reference"]["model"]), sort_keys=True) != test:
            raise ValueError(
                f"{path}: another test (geometry, indenter, protocol, contact or material) than {files[0]}"
            )
        for key in SAME:
            if payload.get(key) != first.get(key):
                raise ValueError(f"{path}: {key} {payload.get(key)!r}, {files[0]} has {first.get(key)!r}")
        for key in SAME_REFERENCE:
            if payload["reference"].get(key) != first["reference"].get(key):
                raise ValueError(
                    f"{path}: reference {key} {payload['reference'].get(key)!r}, "
                    f"{files[0]} has {first['reference'].get(key)!r}"
                )
    rows = [row for payload in payloads for row in payload["rows"]]
    keys = [(row["model"], float(row["c1_true"]), float(row["c5_true"])) for row in rows]
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:
        raise ValueError(f"the budgets hold the same model at the same point: {twice}")
    table = pd.DataFrame(rows)
    summary = ErrorBudget(
        table, np.asarray(first["weights"], float), first["force_noise"], first["dic_noise_mm"]
    )
    points = len({(c1, c5) for _, c1, c5 in keys})
    reference = dict(first["reference"]) | {
        "points": points,
        "study": [p["reference"].get("study") for p in payloads],
    }
    if "finest_study" in first["reference"]:
        reference["finest_study"] = [p["reference"].get("finest_study") for p in payloads]
    return dict(first) | {
        "rows": rows,
        "summary": summary.summary().to_dict(orient="records"),
        "reference": reference,
        "merged_from": [str(f) for f in files],
        "description": f"{first.get('description', '')} Merged with {', '.join(str(f) for f in files[1:])} "
        f"by indent-studio design merge-budgets ({points} points).".strip(),
    }
