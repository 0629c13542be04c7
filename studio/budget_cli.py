"""``indent-studio design error-budget | study-budget | budget-reference | merge-budgets``: a
model's error budget against a reference campaign or a verification study, a budget moved to the
study's finest level, budgets of one test made at different points merged (the library's
:mod:`indentation_studio.inference.budgets`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from .. import inference
from ..atomic_write import atomic_write_json, strict_json
from ..forward.spec import SpecError
from .options import (
    DIC_NOISE,
    FORCE_NOISE,
    JSON,
    RUNS_DIR,
    WEIGHTS,
    err,
    fail,
    number_list,
)

REFERENCE = Annotated[
    str, typer.Option(help="campaign of noise-free responses on a finer mesh: its points are the tests")
]
BUDGET_MODELS = Annotated[
    list[str],
    typer.Option(
        help="a mesh preset, a .feb file or a surrogate file; repeat for several; PRESET@stick or "
        "PRESET@mu=VALUE: that mesh with another contact (a stick model fitted to frictional data)"
    ),
]
FE_STEPS = Annotated[int, typer.Option(help="Gauss-Newton steps of an FE model's fit")]
FOV = Annotated[float, typer.Option(help="DIC field of view: radius around the axis, mm (0: whole top)")]
BUDGET_OUT = Annotated[
    Path | None, typer.Option(help="JSON to write (default runs/<reference>/error-budget.json)")
]


def error_budget_cmd(
    reference: REFERENCE,
    model: BUDGET_MODELS,
    weights: WEIGHTS = "0.45,0.35,0.2,0",
    force_noise: FORCE_NOISE = 0.02,
    dic_noise: DIC_NOISE = 0.02,
    fe_steps: FE_STEPS = 3,
    fov: FOV = 25.0,
    out: BUDGET_OUT = None,
    runs_dir: RUNS_DIR = Path("runs"),
    as_json: JSON = False,
) -> None:
    """The error budget of models: the bias each causes in a fit of the reference's noise-free
    responses, beside a typical experiment's 95 % half-width (converged: bias below a third).
    The JSON is saved after every row; run again with the same settings to resume a stopped one."""
    # imported here: the campaign loader brings pandas and numba, which the command line must not
    # load to start (tests/test_cold_start.py)
    from ..campaign.loader import open_campaign

    try:
        path = out or open_campaign(reference, runs_dir).root / "error-budget.json"
        budget = inference.campaign_error_budget(
            reference,
            model,
            weights=number_list(weights),
            force_noise=force_noise,
            dic_noise=dic_noise,
            fe_steps=fe_steps,
            runs_dir=runs_dir,
            progress=err.print,
            fov_mm=fov or None,
            out=path,
        )
    except (SpecError, ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report_budget(budget, path, reference, as_json)


def _report_budget(budget: inference.ErrorBudget, path: Path, reference: str, as_json: bool) -> None:
    """A budget command's output: its JSON with the file's path, or the table and the path."""
    if as_json:
        print(strict_json(budget.to_dict() | {"json_file": str(path)}))
        return
    _print_budget(budget, reference)
    Console().print(f"wrote {path}")


STUDY_DIR = Annotated[
    Path, typer.Option(help="a verification study's folder (study.json and its runs), one radius")
]
STUDY_MODELS = Annotated[str, typer.Option(help="comma-separated contact-L presets to budget")]
REFERENCE_LEVEL = Annotated[int, typer.Option(help="the study's high-fidelity level (its GCI is carried)")]
STUDY_BUDGET_OUT = Annotated[Path, typer.Option(help="JSON to write")]


def study_budget_cmd(
    study: STUDY_DIR,
    out: STUDY_BUDGET_OUT,
    models: STUDY_MODELS = "contact-L1",
    reference_level: REFERENCE_LEVEL = 3,
    weights: WEIGHTS = "0.45,0.35,0.2,0",
    force_noise: FORCE_NOISE = 0.02,
    dic_noise: DIC_NOISE = 0.02,
    fe_steps: FE_STEPS = 2,
    fov: FOV = 25.0,
    as_json: JSON = False,
) -> None:
    """The error budget of the fit's model against a verification study's high-fidelity level,
    that level's GCI carried in every row (what the studio ships for the paper's tests)."""
    try:
        budget = inference.study_error_budget(
            study,
            [m for m in models.split(",") if m],
            reference_level=reference_level,
            weights=number_list(weights),
            force_noise=force_noise,
            dic_noise=dic_noise,
            fe_steps=fe_steps,
            fov_mm=fov or None,
            progress=err.print,
        )
        atomic_write_json(out, budget.to_dict())
    except (SpecError, ValueError, OSError) as exc:
        fail(str(exc), as_json)
    _report_budget(budget, out, f"level {reference_level} of {study}", as_json)


BUDGET_FILE = Annotated[Path, typer.Option(help="an error-budget.json against a verification study's level")]
FINEST_STUDY = Annotated[
    list[Path],
    typer.Option(
        help="a verification study's study.json with a finer level, at the budget's points; "
        "repeat it for studies made a few points at a time (merged)"
    ),
]


def budget_reference_cmd(
    budget: BUDGET_FILE, study: FINEST_STUDY, out: STUDY_BUDGET_OUT, as_json: JSON = False
) -> None:
    """Move a budget to a finer study's finest level: its level's fit corrected to the extrapolated
    value where the finest triplet is monotone, to the finest level where it oscillates; the width
    is the finest level's own GCI (docs/explanation/model-error.md)."""
    payload = _written(lambda: inference.finest_reference_budget(budget, study), out, as_json)
    if payload is None:
        return
    level = payload["reference"]["corrected_level"]
    view = Table(
        title=f"contact-L{level} moved to level {payload['reference']['level']} of {payload['reference']['finest_study']}"
    )
    for col in (
        "c1, c5 kPa",
        "c1 reference",
        "c1 correction %",
        "c1 +-95 %",
        "c5 reference",
        "c5 correction %",
        "c5 +-95 %",
    ):
        view.add_column(col)
    for r in payload["rows"]:
        if r["model"] != f"contact-L{level}":
            continue
        view.add_row(
            f"{r['c1_true']:g}, {r['c5_true']:g}",
            *(
                cell
                for p in ("c1", "c5")
                for cell in (
                    r[f"{p}_reference"],
                    f"{r[f'{p}_correction_pct']:+.2f}",
                    f"{r[f'{p}_reference_gci_pct']:.2f}",
                )
            ),
        )
    Console(width=140).print(view)
    Console().print(f"wrote {out}")


def _print_budget(budget: inference.ErrorBudget, reference: str) -> None:
    """Each model's bias per test point beside the 95 % half-width, and whether it converged."""
    view = Table(title=f"error budget against {reference} ({budget.reference['points']} test points)")
    for col in (
        "model",
        "c1 true",
        "c5 true",
        "c1 bias %",
        "c5 bias %",
        "c1 +-95 %",
        "c5 +-95 %",
        "split c5 %",
    ):
        view.add_column(col)
    for r in budget.table.to_dict(orient="records"):
        split = ""
        if "c5_discretisation_pct" in r and r["c5_discretisation_pct"] == r["c5_discretisation_pct"]:
            split = f"mesh {r['c5_discretisation_pct']:+.2f}, surrogate {r['c5_surrogate_pct']:+.2f}"
        if r.get("c5_reference_gci_pct") is not None:  # a budget against a verification study's level
            split = f"reference GCI {r['c5_reference_gci_pct']:.2f}"
        view.add_row(
            r["model"],
            f"{r['c1_true']:g}",
            f"{r['c5_true']:g}",
            f"{r['c1_bias_pct']:+.2f}",
            f"{r['c5_bias_pct']:+.2f}",
            f"{r['c1_half_width_pct']:.2f}",
            f"{r['c5_half_width_pct']:.2f}",
            split,
        )
    Console(width=140).print(view)
    summary = budget.summary()
    for r in summary.to_dict(orient="records"):
        Console().print(
            f"{r['model']}: max |bias| c1 {r['c1_max_bias_pct']:.2f} %, c5 {r['c5_max_bias_pct']:.2f} % "
            f"(at most {r['c1_max_bias_over_half_width']:.2f} and {r['c5_max_bias_over_half_width']:.2f} of the "
            f"half-width): {'converged' if r['converged'] else 'NOT converged'} for this test"
        )


BUDGETS_TO_MERGE = Annotated[
    list[Path],
    typer.Option(
        "--budget",
        help="an error-budget.json of the test; repeat it (two or more, the same test, objective, noise "
        "and reference rule, made at different points)",
    ),
]


def merge_budgets_cmd(budget: BUDGETS_TO_MERGE, out: STUDY_BUDGET_OUT, as_json: JSON = False) -> None:
    """Merge error budgets of one test measured at different points (a budget grown by a point, e.g.
    a one-point study where a fit lay outside the budget's points) into one."""
    payload = _written(lambda: inference.merge_error_budgets(budget), out, as_json)
    if payload is None:
        return
    points = sorted({(r["c1_true"], r["c5_true"]) for r in payload["rows"]})
    Console().print(
        f"wrote {out}: {payload['reference']['points']} points ("
        + ", ".join("{" + f"{c1:g}, {c5:g}" + "}" for c1, c5 in points)
        + f" kPa) from {len(budget)} budgets",
        soft_wrap=True,  # the path whole, whatever its length
        highlight=False,
    )


def _written(make, out: Path, as_json: bool) -> dict | None:
    """A budget's payload made by ``make()`` and written to ``out``; a bad input ends the command
    with its error named. With ``as_json`` the payload is printed and None returned."""
    try:
        payload = make()
        atomic_write_json(out, payload)
    except (ValueError, OSError, KeyError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json(payload | {"json_file": str(out)}))
        return None
    return payload


def register_budget_commands(app: typer.Typer) -> None:
    """Add the budget commands to ``indent-studio design`` (after its design commands)."""
    commands = {
        "error-budget": error_budget_cmd,
        "study-budget": study_budget_cmd,
        "budget-reference": budget_reference_cmd,
        "merge-budgets": merge_budgets_cmd,
    }
    for name, command in commands.items():
        app.command(name)(command)
