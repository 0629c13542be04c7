"""``indent-studio fit | posterior | confirm``: from a measured experiment to (c1, c5) with bounds, a
posterior and an FE confirmation (paper 2.7, 2.8, 3.4). Each command calls one workflow of
:mod:`indentation_studio.inference` and prints what it returns."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.panel import Panel

from .. import inference, studio  # lazy: a command imports what it runs
from ..atomic_write import strict_json
from .mu_wording import mu_statement
from .options import CHAIN_STEPS, EXPERIMENT, JSON, SEED, WEIGHTS, err, fail, say

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
    _print_fit(result, payload, check_mesh)


def _surrogate_part(model_error: dict) -> str:
    """The surrogate's own error and the processing's among a fit's printed parts ('' when not carried)."""
    own, processing = model_error.get("surrogate_pct"), model_error.get("processing")
    text = "" if own is None else f", surrogate {own[0]:.2f} / {own[1]:.2f}"
    if processing is not None:
        pct = processing["processing_pct"]
        text += f", processing {pct[0]:.2f} / {pct[1]:.2f}"
    return text


def _print_fit(result: inference.ExperimentFit, payload: dict, check_mesh: str | None) -> None:
    """A fit's (c1, c5) and bounds, its model error, adequacy and warnings, mu and the mesh check."""
    if payload["excluded_steps"]:
        Console().print(f"steps left out of the fit: {payload['excluded_steps']}")
    final = result.fit
    Console().print(
        f"c1 = {payload['c1']:.3f} kPa +- {payload['c1_pct']:.1f} %, c5 = {payload['c5']:.1f} kPa +- "
        f"{payload['c5_pct']:.1f} %  (95 %; F = {final.F:.3g}, s = {final.s:.3g}, n = {final.n_residuals})"
    )
    correction = payload.get("correction")
    if correction is not None:
        model_fit = payload["model_fit"]
        Console().print(
            f"  corrected from the model's fit c1 = {model_fit['c1']:.3f}, c5 = {model_fit['c5']:.1f} kPa by "
            f"{correction['c1_pct']:+.2f} % / {correction['c5_pct']:+.2f} % ({correction['reference']})"
        )
    stat = payload["statistical_pct"]
    if payload["model_error"] is not None:
        m = payload["model_error"]
        Console().print(
            f"  statistical +- {stat[0]:.2f} % / {stat[1]:.2f} %; model error +- {m['model_pct'][0]:.2f} % / "
            f"{m['model_pct'][1]:.2f} % (discrepancy {m['discrepancy_pct'][0]:.2f} / {m['discrepancy_pct'][1]:.2f}, "
            f"error budget {m['error_budget_pct'][0]:.2f} / {m['error_budget_pct'][1]:.2f}"
            + _surrogate_part(m)
            + ")"
        )
    _loud_warnings(payload)
    for warning in payload["warnings"]:
        err.print(f"[yellow]warning:[/yellow] {warning}")
    fr = payload["friction"]
    if "mu_pct" in fr:
        share = fr["mu_share_pct"]
        said = "  " + mu_statement(fr)
        Console().print(
            f"{said}; mu's share of the bounds "
            f"+- {share[0]:.2f} % / {share[1]:.2f} % (with mu known: +- {fr['conditional_pct'][0]:.2f} % / "
            f"{fr['conditional_pct'][1]:.2f} %)"
        )
        for side, note in fr["mu_reach_notes"].items():
            if note.startswith("taken as reached"):
                Console().print(f"  mu's {side} end {note}")
        if fr.get("mu_model_unmeasured"):
            Console().print(f"  mu not claimed: {fr['mu_model_unmeasured']}")
    Console().print(f"  bounds: {payload['bounds_include']}")
    confirmation = payload["fe_confirmation"]
    if confirmation is not None and confirmation["error"] is None:
        shift = ", ".join(
            f"{k} {v:+.2f} %"
            for k, v in zip(confirmation["parameters"], confirmation["gauss_newton_shift_pct"], strict=True)
        )
        Console().print(
            f"  FE confirmation ({confirmation['wall_s']:.1f} s): F = {confirmation['F_fe']:.4g} on the FE model "
            f"(surrogate {confirmation['F_surrogate']:.4g}); one Gauss-Newton step from it moves {shift}"
        )
    check = payload["mesh_check"]
    if check is not None:
        t, u = check["theta_on_finer_mesh"], check["corrected_combined_pct"]
        Console().print(
            f"carried to '{check_mesh}' ({check['nodes'][1]} nodes): c1 = {t[0]:.3f} kPa +- {u[0]:.1f} %, "
            f"c5 = {t[1]:.1f} kPa +- {u[1]:.1f} % (95 %, statistical and that mesh's GCI); on the fit's mesh "
            f"with its GCI: +- {check['combined_pct'][0]:.1f} %, +- {check['combined_pct'][1]:.1f} %"
        )


def _loud_warnings(payload: dict) -> None:
    """The adequacy flag (red) and a test without an error budget (yellow) as panels under the
    headline numbers: they say the numbers above are not to be trusted as they stand (fit.json
    holds them under 'adequacy' and 'error_budget')."""
    console = Console()
    adequacy = payload["adequacy"]
    if "flagged" not in adequacy:
        console.print(f"  model adequacy: not tested ({adequacy.get('note')})")
    elif adequacy["flagged"]:
        named = "".join(f"\n  {d['parameter']}: {d['reason']}" for d in adequacy["named_parameters"])
        terms = ", ".join(
            f"{k} {v['statistic']:.4g} / {v['n']}" for k, v in adequacy["terms"].items() if v["n"]
        )
        console.print(
            Panel(
                f"[bold]{inference.CANNOT_EXPLAIN}[/bold]\n"
                f"chi-square {adequacy['statistic']:.4g} on {adequacy['dof']} degrees of freedom "
                f"({adequacy['per_degree']:.3g} per degree), p = {adequacy['p_value']:.3g} < {adequacy['alpha']:g}"
                f"\nper term (statistic / points): {terms}"
                f"\nnoise: {_noise_words(adequacy['noise'])}{_field_error_words(adequacy)}"
                + (f"\nparameters named:{named}" if named else ""),
                title="[bold red]MODEL INADEQUATE[/bold red]",
                border_style="red",
            )
        )
    else:
        console.print(
            f"  model adequacy: chi-square {adequacy['statistic']:.4g} on {adequacy['dof']} degrees of freedom, "
            f"p = {adequacy['p_value']:.3g} (not flagged; noise: {_noise_words(adequacy['noise'])}"
            f"{_field_error_words(adequacy)})"
        )
        for d in adequacy["named_parameters"]:
            console.print(f"  [yellow]{d['parameter']}[/yellow]: {d['reason']}")
    budget = payload["error_budget"]
    if budget["warning"]:
        words = "ERROR BUDGET NOT MEASURED HERE" if budget["known"] else "NO ERROR BUDGET FOR THIS TEST"
        title = f"[bold yellow]{words}[/bold yellow]"
        console.print(Panel(budget["warning"], title=title, border_style="yellow"))


def _field_error_words(adequacy: dict) -> str:
    """The high fidelity's field error the test held, short ('' where none)."""
    fe = adequacy.get("field_error")
    if not fe:
        return ""
    return (
        f"; {fe['coarse_mesh']}'s field error against {fe['fine_mesh']} (measured at {fe['points']} "
        f"points, {fe['file']}) held"
    )


def _noise_words(noise: dict) -> str:
    """The noise levels an adequacy test used, short."""
    dic = ", ".join(f"{v:.3g}" for v in noise["dic_sd_mm"])
    reg = max(noise["registration_sd_mm"])
    return (
        f"force {noise['force_sd_pct_median']:.3g} % of f_inf per step (median; {noise['force_source']}); "
        f"DIC ({dic}) mm ({noise['dic_source']}); registration {reg:.2g} mm"
    )


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
    _print_posterior(result, payload, png)


def _print_posterior(result: inference.ExperimentPosterior, payload: dict, png: Path) -> None:
    """Each parameter's median, interval and sd, the chain's convergence and the mesh carry."""
    for k, name in enumerate(result.posterior.parameters):
        lo, hi = payload["ci95"][k]
        if name in result.not_identified:
            Console().print(
                f"{name} is not identified by these data: its 95 % interval [{lo:.4g}, {hi:.4g}] reaches its "
                f"prior's end {list(result.mu_range)} (the model's own errors on it counted: "
                f"+- {payload['friction'].get('mu_model_pct') or 0:.3g} %)"
            )
            if payload["friction"].get("mu_model_unmeasured"):
                Console().print(
                    f"  its samples are its prior's: {payload['friction']['mu_model_unmeasured']}"
                )
            continue
        fit_lo, fit_hi = payload["fit_bounds"][k]
        Console().print(
            f"{name}: median {payload['median'][k]:.4g}, 95 % [{lo:.4g}, {hi:.4g}], sd {payload['std'][k]:.3g} "
            f"(the fit's 95 % bounds [{fit_lo:.4g}, {fit_hi:.4g}])"
        )
    Console().print(f"intervals: {payload['intervals_include']}")
    post = result.posterior
    colour = "green" if post.converged else "yellow"
    Console().print(
        f"[{colour}]{post.convergence_message}[/{colour}]; acceptance {post.acceptance_fraction:.2f}; {png}"
    )
    carried = result.carried
    if carried is not None:
        Console().print(
            f"carried to the '{carried['check_mesh']}' mesh ({carried['nodes'][1]} nodes): shifted by "
            f"{[round(v, 2) for v in carried['shift_pct']]} %, spread by its GCI "
            f"{[round(v, 2) for v in carried['corrected_uncertainty_pct']]} % (95 %)"
        )


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
    _print_confirmation(payload, solver)


def _print_confirmation(payload: dict, solver: str) -> None:
    """F on the FE model beside the surrogate's, their difference, and the mesh check."""
    Console().print(
        f"F(theta_hat) on {solver}: {payload['F_fe']:.4g} (surrogate {payload['F_surrogate']:.4g}); surrogate vs "
        f"FE: force {payload['force_diff_max_pct']:.2f} %, field {payload['displacement_diff_max_pct']:.2f} % of max |u|"
    )
    m = payload.get("mesh_check")
    if m is not None:
        Console().print(
            f"mesh check ({m['nodes'][0]} -> {m['nodes'][1]} nodes): the finer mesh moves c1 by "
            f"{m['shift_pct'][0]:+.2f} % and c5 by {m['shift_pct'][1]:+.2f} %; 95 % bounds c1 +-"
            f"{m['statistical_pct'][0]:.2f} % (statistical, eq. 6-8) -> +-{m['combined_pct'][0]:.2f} % with the "
            f"mesh's uncertainty, c5 +-{m['statistical_pct'][1]:.2f} % -> +-{m['combined_pct'][1]:.2f} %"
        )
        t, u = m["theta_on_finer_mesh"], m["corrected_combined_pct"]
        Console().print(
            f"carried to the finer mesh: c1 = {t[0]:.4g} kPa +- {u[0]:.2f} %, c5 = {t[1]:.4g} kPa +- {u[1]:.2f} % "
            f"(95 %, statistical and the finer mesh's GCI)"
        )


def register(app: typer.Typer) -> None:
    """Add the inference commands to the studio's CLI."""
    app.command("fit")(fit)
    app.command("posterior")(posterior)
    app.command("confirm")(confirm)
