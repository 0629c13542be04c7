"""The error budget of the fit's model against the verification study's high-fidelity level, with
that level's own uncertainty carried (docs/explanation/model-error.md, "Budgets against level 3").

At each of a verification study's points the fit's model (a ``contact-L`` preset, with the
surface contact the study used) is fitted to the high-fidelity level's noise-free response, as
:func:`~indentation_studio.inference.budgets.error_budget.compute_error_budget` fits any model; each
row then also carries how far that level itself may be from the converged model,
:func:`reference_uncertainty_pct` of the study's fitted (c1, c5) over its levels. A fit's budget
(:func:`~indentation_studio.surrogate.error_budgets.remaining_bias`) adds the two, so a bound is
never narrower than what the verification study measured, and interpolates them between the
points (the reference is no single mesh whose own error is left out).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ...design.objective import PAPER_WEIGHTS
from ...forward.convergence.gci import observed_order
from ...forward.mesh_presets import CONTACT_MESH_LEVELS
from ...forward.predictor import CachedPredictor, FESolverPredictor
from ...forward.result import SimulationResult
from ...forward.spec import Indenter, MeshChoice, ModelSpec
from .error_budget import ErrorBudget, compute_error_budget
from .verification_study import load_verification_study

__all__ = [
    "FS_ASYMPTOTIC",
    "FS_OUTSIDE",
    "ReferenceCorrection",
    "finest_reference_budget",
    "reference_correction",
    "reference_uncertainty_pct",
    "study_error_budget",
    "with_finest_reference",
]

#: Roache's factor of safety of a GCI whose levels are in the asymptotic range ...
FS_ASYMPTOTIC = 1.25
#: ... and outside it (an order that the levels do not confirm, or an oscillating sequence).
FS_OUTSIDE = 3.0
#: The observed order is used within these limits: above the element's formal order a high
#: observed order (levels that happen to agree) would make the GCI small by chance.
ORDER_LIMITS = (1.0, 2.0)


def reference_uncertainty_pct(values: Sequence[float], sizes: Sequence[float], level_index: int) -> float:
    """How far the level at ``level_index`` may be from the converged value, % of its value.

    Roache's GCI with the next coarser level: Fs |f_k - f_(k+1)| / |f_k| / (r^p - 1), with p the
    observed order of the triplet that starts at that level limited to :data:`ORDER_LIMITS`
    (2 when the triplet oscillates or has no order), and Fs :data:`FS_ASYMPTOTIC` when the
    study's levels are in the asymptotic range there (two triplets whose orders agree within 0.5,
    neither oscillating) and :data:`FS_OUTSIDE` otherwise. Where the study has a finer level, the
    level is never given less than what that level measured: its distance to the finer level
    plus the finer level's own uncertainty (by this rule), so that levels which agree by chance
    (an oscillating or stalled sequence) do not make the bound narrower than the study's data.

    Parameters
    ----------
    values, sizes : sequences of float
        The quantity and the representative cell size on each level, finest first.
    level_index : int
        The level's index in ``values`` (0 the finest); it needs a coarser level after it.

    Returns
    -------
    float
        The uncertainty, % of the level's value.

    Raises
    ------
    ValueError
        If the level has no coarser level in the sequence.

    Examples
    --------
    >>> from indentation_studio.inference import reference_uncertainty_pct
    >>> # c5 on levels 3, 2, 1, 0 at {11, 330} kPa, R = 4.77 mm: monotone, orders 2.02 and 1.60
    >>> round(reference_uncertainty_pct([330.0, 336.1, 350.1, 376.8], [1.0, 1.5, 2.25, 3.375], 0), 2)
    1.85
    >>> # the same levels under a finer one 2.3 % away (oscillating: Fs 3): 2.3 % plus its own 5.5 %
    >>> v = [337.7, 330.0, 336.1, 350.1, 376.8]
    >>> round(reference_uncertainty_pct(v, [0.667, 1.0, 1.5, 2.25, 3.375], 1), 2)
    7.94
    """
    v, h = [float(x) for x in values], [float(x) for x in sizes]
    k = int(level_index)
    if not 0 <= k < len(v) - 1:
        raise ValueError(f"level index {k} has no coarser level among {len(v)} values")
    r = h[k + 1] / h[k]
    triplets = [observed_order(v[i : i + 3], h[i : i + 3]) for i in range(k, min(k + 2, len(v) - 2))]
    first = triplets[0] if triplets else None
    if first is None or first.oscillatory or not np.isfinite(first.order) or first.order <= 0:
        p = ORDER_LIMITS[1]
    else:
        p = float(np.clip(first.order, *ORDER_LIMITS))
    asymptotic = (
        len(triplets) == 2
        and not any(t.oscillatory for t in triplets)
        and abs(triplets[0].order - triplets[1].order) <= 0.5
    )
    fs = FS_ASYMPTOTIC if asymptotic else FS_OUTSIDE
    own = float(100.0 * fs * abs(v[k] - v[k + 1]) / abs(v[k]) / (r**p - 1.0))
    if k == 0:
        return own
    finer = reference_uncertainty_pct(v, h, k - 1) * abs(v[k - 1])  # % times its value
    return max(own, float((100.0 * abs(v[k] - v[k - 1]) + finer) / abs(v[k])))


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


def _case_folder(study_dir: Path, radius: float, theta: Sequence[float]) -> Path:
    return study_dir / f"R{radius:g}" / f"c1-{theta[0]:g}_c5-{theta[1]:g}"


def _reference_row(row: dict, own: str, fitted: str) -> dict:
    """The reference level's row at a fitted model's point: no bias (the study's data are its own
    noise-free responses, a fit from the truth stays there), its GCI carried as that row's; the
    half-widths (the typical experiment's noise, which the budget reports beside the biases and
    no fit carries) are the fitted model's at that point, and the row says so."""
    out = dict(row) | {"model": own, "half_width_of": fitted}
    for p in ("c1", "c5"):
        out[f"{p}_fit"] = row[f"{p}_true"]
        out[f"{p}_bias_pct"] = 0.0
    return out


def study_error_budget(
    study_dir: str | Path,
    models: Sequence[str] = ("contact-L1",),
    *,
    reference_level: int = 3,
    weights=PAPER_WEIGHTS,
    force_noise: float = 0.02,
    dic_noise: float = 0.02,
    fe_steps: int = 2,
    fov_mm: float | None = 25.0,
    reading: str = "fit",
    progress: Callable[[str], None] | None = None,
) -> ErrorBudget:
    """The error budget of ``models`` against a verification study's ``reference_level``, its GCI carried.

    Parameters
    ----------
    study_dir : str or pathlib.Path
        A verification study's folder (its ``study.json`` and runs) of one radius, on the
        ``contact-L`` family at that radius, made with the same ``reading`` (the carried
        uncertainty is that of these fits).
    models : sequence of str, default ("contact-L1",)
        ``contact-L`` presets fitted, each with the study's contact. The reference level itself
        (``contact-L<reference_level>``, beside a fitted one) gets rows without a fit: no bias, its
        GCI carried, so a multi-fidelity surrogate whose high level it is carries that GCI.
    reference_level : int, default 3
        The high-fidelity level; it and a coarser level must be in the study.
    weights : array_like, default PAPER_WEIGHTS
        eta of eq. 5.
    force_noise, dic_noise : float, default 0.02
        The typical experiment's noise (relative; mm) of the half-widths beside the biases.
    fe_steps : int, default 2
        Gauss-Newton steps of each fit, from the truth.
    fov_mm : float or None, default 25.0
        The DIC field of view, mm.
    reading : str, default "fit"
        How eq. 4 is read (the fit's objective: DIC from 1.5 R).
    progress : callable, optional
        Told of every fit.

    Returns
    -------
    ErrorBudget
        Its rows also hold ``c1_reference_gci_pct`` and ``c5_reference_gci_pct``
        (:func:`reference_uncertainty_pct` of the study's fitted c1 and c5 at that point); its
        reference names the study, the level, its mesh and ``"gci_carried": true``.

    Raises
    ------
    ValueError
        If the study lacks the level, a run, or a model is not a ``contact-L`` preset.
    """
    root = Path(study_dir)
    study = load_verification_study(root / "study.json")
    levels = list(study["levels"])
    if reference_level not in levels or levels.index(reference_level) == len(levels) - 1:
        raise ValueError(
            f"{root}: the study has levels {levels}; level {reference_level} and a coarser one are needed"
        )
    unknown = [m for m in models if m not in CONTACT_MESH_LEVELS]
    if unknown:
        raise ValueError(f"models {unknown}: an error budget against the study takes contact-L presets")
    studied = study["inputs"].get("reading", "paper")
    if studied != reading:
        raise ValueError(
            f"{root}: the study fitted with the {studied!r} objective, the budget asks for {reading!r}: "
            f"run the study's command again with --reading {reading} (its runs are read back)"
        )
    radii = sorted({float(c["radius"]) for c in study["cases"]})
    if len(radii) != 1:
        raise ValueError(f"{root}: a budget is one test; the study has radii {radii} (one study per radius)")
    index = levels.index(reference_level)
    spec = replace(ModelSpec.from_dict(study["inputs"]["model"]), indenter=Indenter(radii[0]))
    results = [
        SimulationResult.load(_case_folder(root, radii[0], c["theta"]) / f"L{reference_level}-s1.npz")
        for c in study["cases"]
    ]
    own = f"contact-L{reference_level}"
    fitted = [name for name in models if name != own]
    if not fitted:
        raise ValueError(
            f"models {list(models)}: the reference level {own} needs a fitted model beside it (e.g. "
            f"contact-L1,{own}), whose half-widths its rows share"
        )
    predictors = {
        name: CachedPredictor(FESolverPredictor(replace(spec, mesh=MeshChoice(name)))) for name in fitted
    }
    budget = compute_error_budget(
        results,
        predictors,
        weights=weights,
        force_noise=force_noise,
        dic_noise=dic_noise,
        fe_steps=fe_steps,
        progress=progress,
        fov_mm=fov_mm,
        reading=reading,
    )
    carried = {}
    for case in study["cases"]:
        sizes = [lv["h_mm"] for lv in case["levels"]]
        carried[tuple(case["theta"])] = [
            reference_uncertainty_pct(case["quantities"][f"fit {p}"]["values"], sizes, index)
            for p in ("c1", "c5")
        ]
    names = ("c1_reference_gci_pct", "c5_reference_gci_pct")
    rows = []
    for row in budget.table.to_dict(orient="records"):
        u = carried[(row["c1_true"], row["c5_true"])]
        rows.append(row | {names[0]: u[0], names[1]: u[1]})
    if own in models:  # the reference level's own rows: its data are its own, its GCI all it leaves
        first = [row for row in rows if row["model"] == fitted[0]]
        rows += [_reference_row(row, own, fitted[0]) for row in first]
    reference = {
        "study": str(root),
        "family": study["family"]["name"],
        "level": reference_level,
        "points": len(results),
        "gci_carried": True,
        "model": replace(spec, mesh=MeshChoice(f"contact-L{reference_level}")).to_dict(),
    }
    return replace(budget, table=pd.DataFrame(rows), reference=reference)


def finest_reference_budget(budget_file: str | Path, study_file: str | Path) -> dict:
    """A budget file against a study's level moved to a finer study's finest level (issue 57).

    The budget's own reference level (``reference.level``, the level a multi-fidelity surrogate
    emulates) is the corrected one; its other ``contact-L`` models are carried
    (:func:`with_finest_reference`). The description says what was done, with both files.

    Parameters
    ----------
    budget_file : str or pathlib.Path
        An error-budget.json against a verification study's level (``design study-budget``).
    study_file : str or pathlib.Path
        A verification study's ``study.json`` (or its copy) whose finest level is finer, at the
        budget's points and radius.

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
    study = load_verification_study(study_file)
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
    out["reference"]["finest_study"] = str(study_file)
    out["description"] = (
        f"{budget.get('description', '')} Moved to level {study['levels'][0]} of {study_file} by "
        f"indent-studio design budget-reference (issue 57's rule: {out['reference']['rule']})."
    ).strip()
    return out
