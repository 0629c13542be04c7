"""``indent-studio fit | posterior | confirm``: from a measured experiment to (c1, c5) with bounds, a
posterior and an FE confirmation (paper 2.7, 2.8, 3.4). Each command calls one workflow of
:mod:`indentation_studio.inference` and prints what it returns."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .. import inference, studio  # lazy: a command imports what it runs
from ..atomic_write import strict_json
from . import inference_printout as printout
from .options import CHAIN_STEPS, EXPERIMENT, JSON, SEED, WEIGHTS, fail, say

SURROGATE = Annotated[
    Path | None,
    typer.Option(
        help="a trained surrogate file (indent-studio surrogate train); default: the one shipped for the "
        "experiment's test (the paper's R = 4.77 and 8 mm, 28 x 0.5 mm), checked against its sha256"
    ),
]
TESTS = Annotated[
    Path | None,
    typer.Option(
        help="a prepared test's folder (indent-studio test prepare), read before the shipped surrogates; "
        "INDENTATION_STUDIO_TESTS names more (os.pathsep-separated); files that do not match its manifest are refused"
    ),
]
OUT = Annotated[Path | None, typer.Option(help="folder for the result files (default: <experiment>/results)")]
EXCLUDE = Annotated[
    str, typer.Option(help="steps (1..N, comma-separated) to leave out beside those experiment.json excludes")
]
CHECK_MESH = Annotated[
    str | None,
    typer.Option(
        help="then solve at the fit on this finer mesh preset (e.g. reference): the fit carried there, with "
        "bounds that add that mesh's discretisation uncertainty (inference/budgets/mesh_check.py)"
    ),
]

DECLARED_FORCE_NOISE = Annotated[
    float | None,
    typer.Option(
        help="declared force noise, relative, of one reading (e.g. 0.02); default: measured from each "
        "hold's eq. 9 residuals (the model-adequacy test)"
    ),
]
DECLARED_DIC_NOISE = Annotated[
    float | None,
    typer.Option(
        help="declared DIC noise, mm; default: measured from the DIC data (the model-adequacy test)"
    ),
]

FIT_FRICTION = Annotated[
    str | None,
    typer.Option(
        help="the indenter's friction coefficient mu: a value (known), identify (fitted with c1, c5) or "
        "marginalise (a log-uniform prior; :LO:HI sets its range, default the surrogate's or 0.1..3) or "
        "assumed (the surrogate's contact); default: marginalise where the fit can bring mu in (a "
        "surrogate with mu, or the FE stage of a single-level surrogate without --check-mesh), else assumed"
    ),
]

POSTERIOR_FRICTION = Annotated[
    str | None,
    typer.Option(
        help="on a surrogate trained with mu: a value (known), marginalise (sampled, log-uniform prior; "
        ":LO:HI its range; the default there) or identify (sampled, uniform prior)"
    ),
]

REFINE = Annotated[bool, typer.Option(help="run an FE stage after the surrogate's fit (--no-refine: none)")]
FE_STAGE = Annotated[
    str,
    typer.Option(
        help="after the surrogate's fit: confirm (one FE run at the fit and the Gauss-Newton step it points "
        "to, seconds), fit (Levenberg-Marquardt on the FE solver with exact sensitivities, minutes with mu) "
        "or auto (confirm on a surrogate trained with mu, fit on one without)"
    ),
]
#: ``inference.REGISTRATION_MM`` (written out: the command line imports no numerics until a command
#: runs; tests/test_cli.py checks they agree)
REGISTRATION_DEFAULT_MM = 0.1
REGISTRATION = Annotated[
    float,
    typer.Option(
        "--registration-mm",
        help="how far the indentation point found from the indenter's tracked points may lie from the true "
        "one, mm: the bounds carry its effect and that of taking the DIC points to the nodes, measured at "
        "the fit",
    ),
]
PAPER_STOP = Annotated[bool, typer.Option(help="stop as soon as F < 3e-2 (the paper's rule)")]
WALKERS = Annotated[int, typer.Option(help="emcee walkers")]
MESH_CHECK = Annotated[
    Path | None,
    typer.Option(
        help="a fit.json or confirm.json made with --check-mesh: carry the posterior to the "
        "finer mesh (shifted by the check's shift, spread by that mesh's GCI)"
    ),
]
FITTED_C1 = Annotated[
    float,
    typer.Option(help="the model's fitted c1, kPa (fit.json's model_fit where a budget corrected the fit)"),
]
FITTED_C5 = Annotated[
    float,
    typer.Option(help="the model's fitted c5, kPa (fit.json's model_fit where a budget corrected the fit)"),
]
CONFIRM_SOLVER = Annotated[str, typer.Option(help="embedded or febio")]
CONFIRM_FRICTION = Annotated[
    float | None,
    typer.Option(help="run with this Coulomb mu (a fit that marginalised mu: fit.json's friction.mu)"),
]


def _weights(text: str) -> list[float]:
    return [float(v) for v in text.split(",")]


def _steps(text: str) -> list[int]:
    return [int(v) for v in text.split(",") if v.strip()]


def fit(
    experiment: EXPERIMENT,
    surrogate: SURROGATE = None,
    weights: WEIGHTS = "0.45,0.35,0.2,0",
    refine: REFINE = True,
    fe_stage: FE_STAGE = "auto",
    paper_stop: PAPER_STOP = False,
    check_mesh: CHECK_MESH = None,
    exclude_steps: EXCLUDE = "",
    friction: FIT_FRICTION = None,
    force_noise: DECLARED_FORCE_NOISE = None,
    dic_noise: DECLARED_DIC_NOISE = None,
    registration_mm: REGISTRATION = REGISTRATION_DEFAULT_MM,
    out: OUT = None,
    tests: TESTS = None,
    as_json: JSON = False,
) -> None:
    """Inverse fit (2.8.2): Levenberg-Marquardt from {6, 300} kPa on the surrogate, then the FE
    stage: on a surrogate trained with mu one FE run confirms the fit (the step it points to against
    the bounds), else Levenberg-Marquardt on the FE solver with its exact sensitivities (--fe-stage
    chooses); bounds from eq. 6 to 8 with s from the data. With
    --check-mesh, the fit carried to the finer mesh (``posterior --mesh-check`` reads fit.json then).
    ``--friction`` holds the indenter's friction coefficient mu at a value, or identifies or
    marginalises it with (c1, c5) (docs/guide/fit-and-posterior.md, friction). Every fit is tested for model adequacy
    (its residuals against the data's noise: chi-square, flagged beyond the 0.1 % tail) and says
    when no error budget is known for its test."""
    try:
        result = inference.fit_experiment(
            experiment,
            surrogate,
            weights=_weights(weights),
            refine=refine,
            paper_stop=paper_stop,
            check_mesh=check_mesh,
            exclude_steps=_steps(exclude_steps),
            say=say,
            friction=friction,
            force_noise=force_noise,
            dic_noise=dic_noise,
            fe_stage=fe_stage,
            registration_mm=registration_mm,
            tests=tests,
        )
        path = result.save(out or Path(experiment) / "results")
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc), as_json)
    payload = result.to_dict() | {"result_file": str(path)}
    if as_json:
        print(strict_json(payload))
        return
    printout.print_fit(result, payload, check_mesh)


def posterior(
    experiment: EXPERIMENT,
    surrogate: SURROGATE = None,
    weights: WEIGHTS = "0.45,0.35,0.2,0",
    walkers: WALKERS = 32,
    steps: CHAIN_STEPS = 4000,
    seed: SEED = 0,
    mesh_check: MESH_CHECK = None,
    exclude_steps: EXCLUDE = "",
    friction: POSTERIOR_FRICTION = None,
    registration_mm: REGISTRATION = REGISTRATION_DEFAULT_MM,
    out: OUT = None,
    tests: TESTS = None,
    as_json: JSON = False,
) -> None:
    """Posterior of (c1, c5) with emcee on the surrogate: log L = -F / (2 sigma^2), sigma^2 =
    F(theta_hat) / (n - p) of the surrogate fit; uniform prior on the surrogate's training box;
    corner plot with the eq. 6 ellipse. On a surrogate trained with mu as a parameter,
    ``--friction`` holds mu or samples it (marginalise: log-uniform prior) with (c1, c5)."""
    folder = out or Path(experiment) / "results"
    try:
        result = inference.sample_posterior_for(
            experiment,
            surrogate,
            weights=_weights(weights),
            walkers=walkers,
            steps=steps,
            seed=seed,
            mesh_check=mesh_check,
            fit=None,
            exclude_steps=_steps(exclude_steps),
            say=say,
            friction=friction,
            registration_mm=registration_mm,
            tests=tests,
        )
        corner = studio.posterior_corner_figure(result)
        png = studio.save_figure(corner, folder / "corner.png", 120)
        result.save(folder, corner_png=str(png))
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc), as_json)
    payload = result.to_dict() | {"corner_png": str(png)}
    if as_json:
        print(strict_json(payload))
        return
    printout.print_posterior(result, payload, png)


def confirm(
    experiment: EXPERIMENT,
    c1: FITTED_C1,
    c5: FITTED_C5,
    surrogate: SURROGATE = None,
    weights: WEIGHTS = "0.45,0.35,0.2,0",
    solver: CONFIRM_SOLVER = "embedded",
    check_mesh: CHECK_MESH = None,
    exclude_steps: EXCLUDE = "",
    friction: CONFIRM_FRICTION = None,
    out: OUT = None,
    tests: TESTS = None,
    as_json: JSON = False,
) -> None:
    """FE confirmation of a fit: F(theta_hat) from an FE run, and how far the surrogate's prediction
    is from that run (with --friction, the FE run has that friction coefficient). With --check-mesh, the parameter shift the finer mesh would give, the fit's
    bounds with the mesh's uncertainty added, and the fit carried to the finer mesh. Written to
    confirm.json (``indent-studio posterior --mesh-check`` reads it)."""
    try:
        result = inference.confirm(
            experiment,
            surrogate,
            [c1, c5],
            weights=_weights(weights),
            solver=solver,
            check_mesh=check_mesh,
            exclude_steps=_steps(exclude_steps),
            say=say,
            friction=friction,
            tests=tests,
        )
        path = result.save(out or Path(experiment) / "results")
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc), as_json)
    payload = result.to_dict() | {"result_file": str(path)}
    if as_json:
        print(strict_json(payload))
        return
    printout.print_confirmation(payload, solver)


def register(app: typer.Typer) -> None:
    """Add the inference commands to the studio's CLI."""
    app.command("fit")(fit)
    app.command("posterior")(posterior)
    app.command("confirm")(confirm)
