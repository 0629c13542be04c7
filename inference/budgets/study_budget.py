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

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from ...design.objective import PAPER_WEIGHTS
from ...forward.convergence.gci import observed_order
from ...forward.fe_predictor import FESolverPredictor
from ...forward.mesh_presets import CONTACT_MESH_LEVELS
from ...forward.predictor import CachedPredictor
from ...forward.result import SimulationResult
from ...forward.spec import Indenter, MeshChoice, ModelSpec
from .error_budget import ErrorBudget, compute_error_budget
from .study_files import load_verification_study

__all__ = ["FS_ASYMPTOTIC", "FS_OUTSIDE", "reference_uncertainty_pct", "study_error_budget"]

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
