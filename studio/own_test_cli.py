"""``indent-studio test prepare``: your own test (its indenter, protocol and specimen) prepared as a
shipped test is, on this machine or a dask cluster (docs/guide/own-test.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from .. import inference
from ..atomic_write import strict_json
from ..forward.spec import SpecError
from .options import JOBS, JSON, SCHEDULER, SEED, ModelOptions, err, fail, model_options

own_test_app = typer.Typer(
    help="Your own test: what a shipped test has (surrogates, error budget, manifest) for your indenter, "
    "protocol and specimen.",
    no_args_is_help=True,
)

FOLDER = Annotated[
    Path, typer.Option(help="the test's folder (begun again with the same options, it resumes)")
]
BUDGET_POINTS = Annotated[
    str,
    typer.Option(help="the error budget's verification points c1:c5 (kPa), comma-separated"),
]
ESTIMATE_ONLY = Annotated[bool, typer.Option(help="print what it would cost and stop")]


def _points(text: str) -> tuple[tuple[float, float], ...]:
    """``3:120,11:330`` as ((3, 120), (11, 330))."""
    try:
        return tuple((float(a), float(b)) for a, b in (part.split(":") for part in text.split(",") if part))
    except ValueError:
        raise ValueError(
            f"--budget-points {text!r}: give c1:c5 pairs in kPa, e.g. 3:120,11:330,19:540"
        ) from None


@own_test_app.command("prepare")
@model_options("kappa", "radius", "steps", "step_size", "specimen")
def prepare(
    folder: FOLDER,
    *,
    model: ModelOptions,
    budget_points: BUDGET_POINTS = "3:120,3:540,11:330,19:120,19:540",
    jobs: JOBS = 0,
    scheduler: SCHEDULER = None,
    seed: SEED = 0,
    estimate_only: ESTIMATE_ONLY = False,
    as_json: JSON = False,
) -> None:
    """Prepare a test from nothing: the fit's model's stick and mu campaigns, the high fidelity's
    campaign over the box, the verification study and error budget, the multi-fidelity surrogate
    and a manifest; says what it will cost first, shows progress, resumes after a stop, and runs
    its campaigns on joblib or on a dask cluster (--scheduler). fit, posterior and confirm find it
    with --tests FOLDER (or INDENTATION_STUDIO_TESTS)."""
    try:
        recipe = inference.TestRecipe(spec=model.spec(), budget_points=_points(budget_points))
        if estimate_only:
            estimate = inference.estimate_cost(recipe, cores=jobs or 2)
            if as_json:
                print(
                    strict_json(
                        {"test": recipe.name, "estimate": estimate.to_dict(), "choices": recipe.choices()}
                    )
                )
            else:
                Console().print(f"{recipe.name}: {estimate.describe()}")
                for choice in recipe.choices():
                    Console().print(f"note: {choice}")
            return
        done = inference.prepare_test(
            recipe, folder, jobs=jobs, scheduler=scheduler, say=err.print, seed=seed
        )
    except (SpecError, ValueError, OSError, RuntimeError) as exc:
        fail(str(exc), as_json)
    payload = {
        "test": recipe.name,
        "folder": str(done.folder),
        "surrogate": str(done.surrogate),
        "budget": str(done.budget),
        "solved_now": done.solved_now,
        "wall_s": done.wall_s,
        "estimate": done.estimate.to_dict(),
    }
    if as_json:
        print(strict_json(payload))
        return
    Console().print(
        f"{recipe.name}: prepared in {done.folder} ({done.solved_now} runs solved now, {done.wall_s:.0f} s); fit "
        f"with: indent-studio fit --experiment DIR --tests {done.folder}"
    )
