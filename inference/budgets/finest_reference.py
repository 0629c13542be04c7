"""A budget moved to a verification study's finest level (issue 57's decision,
docs/explanation/model-error.md, "Budgets against level 4: the fit corrected"): a level's fit
corrected to the extrapolated value where the finest triplet is monotone, to the finest level where
it oscillates, the finest level's own uncertainty its width."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...forward.convergence.gci import observed_order
from ...forward.mesh_presets import CONTACT_MESH_LEVELS
from .study_budget import ORDER_LIMITS, reference_uncertainty_pct
from .study_files import merge_verification_studies

__all__ = ["ReferenceCorrection", "finest_reference_budget", "reference_correction", "with_finest_reference"]


@dataclass(frozen=True)
class ReferenceCorrection:
    """What a level's fit is corrected by, and how uncertain the corrected value is (issue 57's rule).

    Attributes
    ----------
    reference : str
        ``"extrapolated"`` (the finest triplet is monotone) or ``"level N"`` (it oscillates: the
        finest level itself).
    reference_value : float
        The reference, in the study's values (the finest level's fits).
    correction_pct : float
        Added to a fit made with the level's model, % of that fit: theta = theta_hat (1 + c / 100).
    width_pct : float
        The corrected value's 95 % half-width, % of it: the finest level's own uncertainty
        (:func:`reference_uncertainty_pct`), never less than the distance from the finest level
        to the extrapolated value.
    """

    reference: str
    reference_value: float
    correction_pct: float
    width_pct: float

    def to_dict(self) -> dict:
        """The correction as a budget row records it."""
        return {
            "reference": self.reference,
            "reference_value": self.reference_value,
            "correction_pct": self.correction_pct,
            "width_pct": self.width_pct,
        }


def reference_correction(
    values: Sequence[float], sizes: Sequence[float], level_index: int, *, finest_level: int | None = None
) -> ReferenceCorrection:
    """The correction of a fit made on one level of a verification study, and its uncertainty.

    ``values`` are a study's fitted parameter on each level made by the finest level's model
    (:mod:`inference.budgets.verification_study`): to first order f_k = theta + d_k - d_0, where the level-k
    model at theta answers as the converged model at theta + d_k. A fit made with level k's model
    of a converged experiment is theta - d_k, so the correction that brings it to the converged
    value is d_k = f_k - f_inf, with f_inf = theta - d_0 the values' limit. The decision of issue
    57 (the budgets' reference):

    * the finest triplet monotone (finite observed order, no sign change): f_inf is Richardson's
      extrapolation of the finest two levels with that order held to :data:`ORDER_LIMITS`;
    * oscillating (or no order): the finest level itself, f_inf = f_0 (the correction is then
      d_k - d_0, level k brought to the finest level).

    The width is the finest level's own uncertainty by the study's rule,
    :func:`reference_uncertainty_pct` at index 0 (Roache's factor of safety, 3 outside the
    asymptotic range; the order held to [1, 2]), never narrower than the distance between the finest
    level and the extrapolated value. No factor of safety is relaxed.

    Parameters
    ----------
    values, sizes : sequences of float
        The fitted parameter and the representative cell size on each level, finest first.
    level_index : int
        The corrected level's index in ``values`` (0 the finest).
    finest_level : int, optional
        The finest level's number, for the words of :attr:`ReferenceCorrection.reference`.

    Returns
    -------
    ReferenceCorrection
        The reference, the correction and the width, percent.

    Raises
    ------
    ValueError
        If fewer than three levels are given or ``level_index`` is not one of them.

    Examples
    --------
    >>> from indentation_studio.inference import reference_correction
    >>> # level k answers as the converged model at theta (1 + 0.05 h_k): f_k = 100 (1 + 0.05 (h_k - h_0))
    >>> h = [1.0, 1.5, 2.25]
    >>> rc = reference_correction([100 + 5 * (x - 1.0) for x in h], h, 1)
    >>> # theta = 100: level 1 fits 100 - 7.5 = 92.5 kPa to a converged experiment, +8.108 % brings it back
    >>> rc.reference, round(rc.reference_value, 6), round(rc.correction_pct, 3)
    ('extrapolated', 95.0, 8.108)
    """
    v, h = [float(x) for x in values], [float(x) for x in sizes]
    k = int(level_index)
    if len(v) < 3 or len(h) != len(v):
        raise ValueError(f"a reference needs three levels or more with their sizes; got {len(v)} values")
    if not 0 <= k < len(v):
        raise ValueError(f"level index {k} is not one of the {len(v)} levels")
    finest = observed_order(v[:3], h[:3])
    name = "level 0" if finest_level is None else f"level {finest_level}"
    width = reference_uncertainty_pct(v, h, 0)
    if finest.oscillatory or not np.isfinite(finest.order) or finest.order <= 0:
        reference, f_inf = name, v[0]
    else:
        p = float(np.clip(finest.order, *ORDER_LIMITS))
        f_inf = v[0] + (v[0] - v[1]) / ((h[1] / h[0]) ** p - 1.0)
        reference = "extrapolated"
        width = max(width, 100.0 * abs(f_inf - v[0]) / abs(f_inf))
    theta_hat = v[0] - v[k] + f_inf  # theta - d_k: the level's fit of a converged experiment, first order
    correction = 100.0 * (v[k] - f_inf) / theta_hat
    return ReferenceCorrection(reference, float(f_inf), float(correction), float(width))


def with_finest_reference(budget: dict, study: dict, models: dict[str, int]) -> dict:
    """An error budget's rows moved to a verification study's finest level (issue 57's decision).

    For each row of a model in ``models`` at one of the study's points, :func:`reference_correction`
    of the fitted c1 and c5: the level's row (the one a multi-fidelity surrogate emulates) gets
    ``<p>_correction_pct`` (what a fit on it is corrected by) and ``<p>_reference_gci_pct`` = the
    width, its bias set to 0 (corrected); a coarser model's row keeps its measured bias against
    that level and carries the level's correction as an uncorrected error beside the width
    (|correction| + width). The budget's ``reference`` then names the study, its finest level and
    the rule.

    Parameters
    ----------
    budget : dict
        An error-budget.json's payload whose rows were measured against ``study``'s levels (e.g. a
        budget against level 3, ``study_error_budget``).
    study : dict
        A verification study (``study.json``) with a finer level than the budget's reference, at
        the budget's points.
    models : dict of str to int
        Each model's name in the budget and its level in the study, e.g. ``{"contact-L3": 3}``;
        the first is the corrected level, the others are carried.

    Returns
    -------
    dict
        The new payload (the input is not changed).

    Raises
    ------
    ValueError
        If the study lacks a level, or a budget point is not one of the study's.
    """
    levels = list(study["levels"])
    corrected, *_ = models
    missing = [lv for lv in models.values() if lv not in levels]
    if missing:
        raise ValueError(f"the study has levels {levels}, not {missing}")
    cases = {tuple(float(x) for x in c["theta"]): c for c in study["cases"]}
    rows = []
    for row in budget["rows"]:
        if row["model"] not in models:
            rows.append(dict(row))
            continue
        key = (float(row["c1_true"]), float(row["c5_true"]))
        if key not in cases:
            raise ValueError(f"the budget's point {key} is not one of the study's {sorted(cases)}")
        case, out = cases[key], dict(row)
        sizes = [lv["h_mm"] for lv in case["levels"]]
        for p in ("c1", "c5"):
            rc = reference_correction(
                case["quantities"][f"fit {p}"]["values"],
                sizes,
                levels.index(models[corrected]),
                finest_level=levels[0],
            )
            out[f"{p}_reference"] = rc.reference
            if row["model"] == corrected:
                out |= {f"{p}_bias_pct": 0.0, f"{p}_correction_pct": rc.correction_pct}
                out[f"{p}_reference_gci_pct"] = rc.width_pct
            else:
                out[f"{p}_reference_gci_pct"] = abs(rc.correction_pct) + rc.width_pct
        rows.append(out)
    reference = dict(budget.get("reference") or {}) | {
        "level": levels[0],
        "corrected_level": models[corrected],
        "rule": (
            "level 3's fit corrected to the extrapolated value where the finest triplet is monotone for "
            "that parameter at that point, to the finest level where it oscillates; the width is the "
            "finest level's own uncertainty (Roache's GCI, factor of safety 3 outside the asymptotic "
            "range, order held to [1, 2])"
        ),
        "corrected": True,
        "gci_carried": True,
    }
    return dict(budget) | {"rows": rows, "reference": reference}


def finest_reference_budget(budget_file: str | Path, study_file: str | Path | Sequence[str | Path]) -> dict:
    """A budget file against a study's level moved to a finer study's finest level (issue 57).

    The budget's own reference level (``reference.level``, the level a multi-fidelity surrogate
    emulates) is the corrected one; its other ``contact-L`` models are carried
    (:func:`with_finest_reference`). The description says what was done, with both files.

    Parameters
    ----------
    budget_file : str or pathlib.Path
        An error-budget.json against a verification study's level (``design study-budget``).
    study_file : str, pathlib.Path or a sequence of them
        A verification study's ``study.json`` (or its copy) whose finest level is finer, at the
        budget's points and radius; or several made at different points, merged
        (:func:`merge_verification_studies`).

    Returns
    -------
    dict
        The new budget's payload.

    Raises
    ------
    ValueError
        If the budget has no reference level, the study's finest level is not finer, or the radii
        differ.
    """
    budget = json.loads(Path(budget_file).read_text())
    files = [study_file] if isinstance(study_file, str | Path) else list(study_file)
    study = merge_verification_studies(files)
    study_file = ", ".join(str(f) for f in files)
    level = (budget.get("reference") or {}).get("corrected_level") or (budget.get("reference") or {}).get(
        "level"
    )
    if level is None:
        raise ValueError(
            f"{budget_file}: no reference level in it (a budget against a verification study's level)"
        )
    if study["levels"][0] <= int(level):
        raise ValueError(
            f"{study_file}: its finest level {study['levels'][0]} is not finer than level {level}"
        )
    radius = float(budget["reference"]["model"]["indenter"]["radius"])
    radii = sorted({float(c["radius"]) for c in study["cases"]})
    if radii != [radius]:
        raise ValueError(f"{study_file}: radii {radii}; the budget is at R = {radius:g} mm")
    names = sorted({row["model"] for row in budget["rows"]})
    models = {f"contact-L{level}": int(level)} | {
        name: CONTACT_MESH_LEVELS[name] for name in names if name in CONTACT_MESH_LEVELS
    }
    out = with_finest_reference(budget, study, models)
    out["reference"]["finest_study"] = study_file
    out["description"] = (
        f"{budget.get('description', '')} Moved to level {study['levels'][0]} of {study_file} by "
        f"indent-studio design budget-reference (issue 57's rule: {out['reference']['rule']})."
    ).strip()
    return out
