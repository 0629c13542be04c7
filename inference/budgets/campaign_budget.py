"""The error budget of a reference campaign (``indent-studio design budget``): its finished points
read, the models resolved (:mod:`.budget_models`), the budget computed (:mod:`.error_budget`)
and written row by row to ``error-budget.json``, an interrupted one resumed."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

from ...atomic_write import atomic_write_json
from ...campaign.loader import load_point, open_campaign, require_sound
from ...design.objective import PAPER_WEIGHTS, check_weights
from .budget_models import resolve_model
from .budget_table import ErrorBudget
from .error_budget import compute_error_budget

__all__ = ["campaign_error_budget"]


def campaign_error_budget(
    reference: str,
    models: Sequence[str],
    *,
    weights=PAPER_WEIGHTS,
    force_noise: float = 0.02,
    dic_noise: float = 0.02,
    fe_steps: int = 3,
    runs_dir="runs",
    progress: Callable[[str], None] | None = None,
    fov_mm: float | None = 25.0,
    out=None,
    reading: str = "fit",
) -> ErrorBudget:
    """:func:`compute_error_budget` with the reference given as a campaign and the models by name.

    Parameters
    ----------
    reference : str
        The reference campaign (name or folder): its done points are the test points.
    models : sequence of str
        The models, by name (:func:`resolve_model`).
    weights : array_like, default PAPER_WEIGHTS
        The weights of eq. 5.
    force_noise : float, default 0.02
        Relative force noise per step.
    dic_noise : float, default 0.02
        DIC noise, mm.
    fe_steps : int, default 3
        Gauss-Newton steps of the FE models' fits.
    runs_dir : str or pathlib.Path, default "runs"
        Where named campaigns live.
    progress : callable, optional
        Told of every fit.
    fov_mm : float or None, default 25.0
        The field of view measured, mm (None: the whole top).
    out : str or pathlib.Path, optional
        A JSON path: the budget is saved after every row (``"complete": false`` until the end),
        and a budget stopped before its end resumes from that file when run again with the same
        reference and settings: finished rows are not fitted again.
    reading : str, default "fit"
        How eq. 4 is read (:func:`compute_error_budget`).

    Returns
    -------
    ErrorBudget
        The table of biases and half-widths.

    Raises
    ------
    ValueError
        If the reference campaign has no finished points (or as :func:`compute_error_budget`).
    """

    store = open_campaign(reference, runs_dir)
    require_sound(store)  # a point file that fails its check is named, not read
    done = store.points_with("done")
    if len(done) == 0:
        raise ValueError(f"reference campaign {store.spec.name!r} has no finished points")
    results = [load_point(store, i) for i in done]
    predictors, fe_models, fe_names, cache = {}, {}, {}, {}
    for name in models:
        predictors[name], fe = resolve_model(name, store.spec.model, cache)
        if fe is not None:
            fe_models[name] = fe
            mesh = fe.spec.mesh
            fe_names[name] = mesh.preset or str(mesh.feb_file)
    source = {"campaign": str(store.root), "points": len(results), "model": store.spec.model.to_dict()}
    settings = {"weights": check_weights(weights).tolist(), "force_noise": force_noise}
    settings |= {
        "dic_noise_mm": dic_noise,
        "field_of_view_mm": fov_mm,
        "fe_steps": fe_steps,
        "reading": reading,
    }
    done_rows = _resumable_rows(out, source, settings) if out is not None else []
    if done_rows and progress is not None:
        progress(f"resuming {out}: {len(done_rows)} rows kept")

    def save(partial: ErrorBudget, complete: bool = False) -> None:

        atomic_write_json(out, partial.to_dict(complete))

    budget = compute_error_budget(
        results,
        predictors,
        fe_models=fe_models,
        weights=weights,
        force_noise=force_noise,
        dic_noise=dic_noise,
        reference_source=source,
        fe_steps=fe_steps,
        progress=progress,
        fov_mm=fov_mm,
        done_rows=done_rows,
        on_row=save if out is not None else None,
        fe_names=fe_names,
        reading=reading,
    )
    if out is not None:
        save(budget, complete=True)
    return budget


def _resumable_rows(out, source: dict, settings: dict) -> list[dict]:
    """Rows of an earlier budget at ``out`` made with the same reference and settings (none if
    the file is absent, unreadable, or was made otherwise)."""
    try:
        payload = json.loads(Path(out).read_text())
    except (OSError, ValueError):
        return []
    same = payload.get("reference") == json.loads(json.dumps(source))
    same &= all(payload.get(k) == json.loads(json.dumps(v)) for k, v in settings.items())
    return list(payload.get("rows", [])) if same else []
