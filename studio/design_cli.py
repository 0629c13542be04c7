"""``indent-studio design bounds | weights``: certainty bounds (eq. 6) and the layout of Table 1."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from .. import design, inference  # lazy packages: a command imports what it runs
from ..atomic_write import atomic_write, atomic_write_json, strict_json
from ..forward.spec import SpecError
from .options import (
    FRICTION,
    JSON,
    KAPPA,
    MESH,
    MESH_FROM,
    RADIUS,
    STEP_SIZE,
    STEPS,
    SUBSTEPS,
    err,
    fail,
    model_spec,
)

design_app = typer.Typer(
    help="Experiment design: certainty bounds and objective weights (paper 2.6, Table 1)."
)

THETA = Annotated[str, typer.Option(help="theta* = c1,c5 in kPa")]
S = Annotated[float, typer.Option("--s", help="noise level s of eq. 6 (design stage: 0.05)")]
METHOD = Annotated[str, typer.Option(help="Hessian: exact (Gauss-Newton, solver sensitivities) or fd")]
READING = Annotated[str, typer.Option(help="objective reading: paper (eq. 4 as printed) or authors")]
FD_STEP = Annotated[
    str,
    typer.Option(
        help="fd step in theta/theta*: one number, c1,c5, or 'grid' (the paper grid's spacing, "
        "as the authors' code)"
    ),
]
JOBS = Annotated[int, typer.Option("--jobs", help="parallel simulations for the fd stencil")]


def _fd_step(text: str):
    from ..design.certainty import PAPER_GRID_STEP

    if text.strip() == "grid":
        return PAPER_GRID_STEP
    values = [float(v) for v in text.split(",")]
    return values[0] if len(values) == 1 else tuple(values)


def _study(
    theta,
    kappa,
    radius,
    steps,
    step_size,
    mesh,
    mesh_from,
    substeps,
    method,
    reading,
    as_json,
    fd_step,
    jobs,
    friction: float | None = None,
):
    from ..design.study import fe_design_study

    try:
        c1, c5 = (float(v) for v in theta.split(","))
        spec = model_spec(
            c1,
            c5,
            kappa=kappa,
            radius=radius,
            steps=steps,
            step_size=step_size,
            mesh=mesh,
            mesh_from=mesh_from,
            substeps=substeps,
            friction=friction,
        )
        err.print(f"design study at theta* = ({c1:g}, {c5:g}) kPa, R = {radius:g} mm, {method} Hessian ...")
        with_mu = friction is not None and friction > 0  # mu = 0: frictionless, no d/d(log mu)
        return fe_design_study(
            spec,
            (c1, c5, friction) if with_mu else (c1, c5),
            method=method,
            reading=reading,
            h=_fd_step(fd_step),
            n_jobs=jobs,
            parameters=("c1", "c5", "mu") if with_mu else ("c1", "c5"),
        )
    except (SpecError, ValueError) as exc:
        fail(str(exc), as_json)


def _fmt(eta) -> str:
    return "(" + ",".join(f"{v:.2f}" for v in eta) + ")"


def _pair(c1: float, c5: float) -> str:
    return f"{c1:.1f} / {c5:.1f}"


@design_app.command("bounds")
def bounds(
    weights: Annotated[str, typer.Option(help="eta = force,ux,uy,uz on the simplex")] = "0.45,0.35,0.2,0",
    s: S = 0.05,
    theta: THETA = "10,350",
    kappa: KAPPA = 1000.0,
    radius: RADIUS = 4.77,
    steps: STEPS = 28,
    step_size: STEP_SIZE = 0.5,
    mesh: MESH = "default",
    mesh_from: MESH_FROM = None,
    substeps: SUBSTEPS = 1,
    method: METHOD = "exact",
    reading: READING = "paper",
    fd_step: FD_STEP = "0.02",
    jobs: JOBS = 1,
    friction: FRICTION = None,
    mu_prior: Annotated[
        str, typer.Option(help="with --friction: the range LO:HI of mu's log-uniform prior as a nuisance")
    ] = "0.1:3",
    as_json: JSON = False,
) -> None:
    """Certainty bounds of c1 and c5 (eq. 6) for one set of objective weights. With ``--friction
    MU`` the model has Coulomb friction mu and the bounds are given three ways: mu known,
    identified with (c1, c5), and a nuisance with a log-uniform prior (``--mu-prior``)."""
    from ..design.objective import check_weights

    try:
        eta = check_weights([float(v) for v in weights.split(",")])
        prior = tuple(float(v) for v in mu_prior.split(":"))
        if len(prior) != 2 or not 0 < prior[0] < prior[1]:
            raise ValueError(f"--mu-prior {mu_prior!r}: expected LO:HI with 0 < LO < HI")
    except ValueError as exc:
        fail(str(exc), as_json)
    study = _study(
        theta,
        kappa,
        radius,
        steps,
        step_size,
        mesh,
        mesh_from,
        substeps,
        method,
        reading,
        as_json,
        fd_step,
        jobs,
        friction,
    )
    H = study.hessian(eta)
    b = study.bounds(eta, s) if not friction else None
    with_mu = None
    if friction == 0:  # the end of mu's range, where mu has no log: the frictionless bounds alone
        with_mu = {"mu": 0.0, "known_pct": b.tolist(), "identified_pct": None, "nuisance_pct": None}
        with_mu["note"] = "mu = 0 (frictionless): only the bounds with mu known; give mu > 0 for the others"
    elif friction is not None:
        from ..design.study import friction_design_bounds

        try:
            with_mu = friction_design_bounds(study, eta, s, prior)
        except ValueError as exc:
            fail(str(exc), as_json)
        b = np.array(with_mu["known_pct"])
    payload = {
        "c1_pct": float(b[0]),
        "c5_pct": float(b[1]),
        "friction": with_mu,
        "hessian": H.tolist(),
        "weights": eta.tolist(),
        "s": s,
        "method": method,
        "reading": reading,
        "term_hessians": study.term_hessians.tolist(),
        "bounds_include": design.DESIGN_BOUNDS_INCLUDE,
    }
    if as_json:
        print(strict_json(payload))
        return
    Console().print(f"weights {_fmt(eta)}: c1 +-{b[0]:.1f} %, c5 +-{b[1]:.1f} %   (s = {s:g})")
    if with_mu is not None and "note" in with_mu:
        Console().print(f"  {with_mu['note']}")
    elif with_mu is not None:
        i, n = with_mu["identified_pct"], with_mu["nuisance_pct"]
        Console().print(
            f"  mu = {friction:g} known: the above; identified with them: c1 +-{i[0]:.1f} %, c5 +-{i[1]:.1f} %, "
            f"mu +-{with_mu['identified_mu_pct']:.0f} %; a nuisance (log-uniform on {mu_prior}): "
            f"c1 +-{n[0]:.1f} %, c5 +-{n[1]:.1f} %"
        )
    Console().print(f"bounds: {design.DESIGN_BOUNDS_INCLUDE}")
    Console().print(f"H(theta*) (normalised) = {np.array2string(H, precision=3)}")


@design_app.command("weights")
def weights_cmd(
    criterion: Annotated[
        str, typer.Option(help="c1, c5, combined (sum of squared bounds) or det")
    ] = "combined",
    s: S = 0.05,
    theta: THETA = "10,350",
    kappa: KAPPA = 1000.0,
    radius: RADIUS = 4.77,
    steps: STEPS = 28,
    step_size: STEP_SIZE = 0.5,
    mesh: MESH = "default",
    mesh_from: MESH_FROM = None,
    substeps: SUBSTEPS = 1,
    method: METHOD = "exact",
    reading: READING = "paper",
    fd_step: FD_STEP = "0.02",
    jobs: JOBS = 1,
    out: Annotated[Path | None, typer.Option(help="also write the table as JSON here")] = None,
    as_json: JSON = False,
) -> None:
    """The layout of Table 1: force only; deformation only; optimal for c1; for c5; combined; each
    row beside the paper's bounds and ours at the paper's weights."""
    from ..design.weights import PAPER_HESSIAN, compare_with_paper

    study = _study(
        theta,
        kappa,
        radius,
        steps,
        step_size,
        mesh,
        mesh_from,
        substeps,
        method,
        reading,
        as_json,
        fd_step,
        jobs,
    )
    try:
        rows = compare_with_paper(study.term_hessians, s, criterion)
    except ValueError as exc:
        fail(str(exc), as_json)
    H_paper_weights = study.hessian(rows[-1].paper_weights)
    payload = {
        "rows": [
            {"name": r.name, "weights": list(r.weights), "c1_pct": r.c1_pct, "c5_pct": r.c5_pct} for r in rows
        ],
        "paper_rows": [r.__dict__ for r in rows],
        "s": s,
        "criterion": criterion,
        "method": method,
        "reading": reading,
        "fd_step": fd_step if method == "fd" else None,
        "theta_star": study.theta_star.tolist(),
        "hessian_combined": study.hessian(rows[-1].weights).tolist(),
        "hessian_paper_weights": H_paper_weights.tolist(),
        "paper_hessian": [list(r) for r in PAPER_HESSIAN],
        "term_hessians": study.term_hessians.tolist(),
        "spec": study.spec,
    }
    if out is not None:
        atomic_write_json(out, payload)
    if as_json:
        print(strict_json(payload))
        return
    table = Table(title=f"Table 1 at theta* = {theta} kPa, s = {s:g} ({method} Hessian, {reading} reading)")
    for col in (
        "+- % of c1 / c5",
        "paper",
        "paper weights",
        "ours, paper weights",
        "ours, optimised",
        "our weights",
    ):
        table.add_column(col)
    for r in rows:
        table.add_row(
            r.name,
            _pair(r.paper_c1_pct, r.paper_c5_pct),
            _fmt(r.paper_weights),
            _pair(r.c1_pct_at_paper_weights, r.c5_pct_at_paper_weights),
            _pair(r.c1_pct, r.c5_pct),
            _fmt(r.weights),
        )
    Console(width=130).print(table)
    H = H_paper_weights
    P = PAPER_HESSIAN
    Console(width=130).print(
        f"H(theta*) at the paper's combined weights: [[{H[0, 0]:.3g}, {H[0, 1]:.3g}], [{H[1, 0]:.3g}, {H[1, 1]:.3g}]]"
        f"   (paper eq. 14: [[{P[0][0]}, {P[0][1]}], [{P[1][0]}, {P[1][1]}]])"
    )


@design_app.command("baseline")
def baseline_cmd(
    mu_matrix: Annotated[float, typer.Option(help="matrix neo-Hookean shear modulus mu, kPa")] = 19.4,
    fiber_c1: Annotated[float, typer.Option(help="fiber Mooney-Rivlin c1, kPa")] = -1227.0,
    fiber_c2: Annotated[float, typer.Option(help="fiber Mooney-Rivlin c2, kPa")] = 5945.0,
    fvf: Annotated[float, typer.Option(help="fiber volume fraction (0..1)")] = 0.07,
    equibiaxial: Annotated[
        Path | None,
        typer.Option(
            help="CSV of equibiaxial data (stretch, sigma_fiber, sigma_transverse; kPa) to fit eq. 10"
        ),
    ] = None,
    as_json: JSON = False,
) -> None:
    """Baseline theta* from the constituents (eq. 11) and, if given, the eq. 10 fit of equibiaxial data."""
    import pandas as pd

    from ..design.constituents import fit_equibiaxial, rule_of_mixtures

    try:
        c1, c5 = rule_of_mixtures(mu_matrix, fiber_c1, fiber_c2, fvf)
        payload = {"c1": c1, "c5": c5, "source": "eq. 11 (rule of mixtures)"}
        if equibiaxial is not None:
            table = pd.read_csv(equibiaxial)
            missing = {"stretch", "sigma_fiber", "sigma_transverse"} - set(table.columns)
            if missing:
                raise ValueError(f"{equibiaxial}: missing column(s) {', '.join(sorted(missing))}")
            fit = fit_equibiaxial(table["stretch"], table["sigma_fiber"], table["sigma_transverse"])
            payload["equibiaxial_fit"] = {
                "values": fit.values,
                "std_errors": fit.std_errors,
                "rms_kPa": fit.rms_kPa,
            }
    except (OSError, ValueError, RuntimeError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json(payload))
        return
    Console().print(f"eq. 11: c1 = {c1:.2f} kPa, c5 = {c5:.1f} kPa (FVF {fvf:g})")
    if "equibiaxial_fit" in payload:
        v, e = fit.values, fit.std_errors
        Console().print(
            f"eq. 10 fit: c1 = {v['c1']:.2f} +- {e['c1']:.2f} kPa, c5 = {v['c5']:.1f} +- {e['c5']:.1f} kPa"
        )


@design_app.command("map")
def map_cmd(
    campaign: Annotated[str, typer.Option(help="campaign name under runs/ (or its folder)")],
    weights: Annotated[str, typer.Option(help="eta = force,ux,uy,uz on the simplex")] = "0.45,0.35,0.2,0",
    s: S = 0.05,
    theta: THETA = "10,350",
    reading: READING = "paper",
    out: Annotated[
        Path | None, typer.Option(help="PNG to write (default runs/<campaign>/figure8.png)")
    ] = None,
    as_json: JSON = False,
) -> None:
    """Fig. 8: the objective over a campaign's (c1, c5) points against the response at theta*
    (simulated on the campaign's model with sensitivities), the certainty ellipse and theta*."""
    from ..design.objective_over_plane import campaign_objective_map
    from .figures import objective_map_figure, save_figure

    try:
        theta_star = _floats(theta)
        err.print(f"simulating theta* = {theta} kPa on the campaign's model with sensitivities ...")
        omap = campaign_objective_map(campaign, theta_star, _floats(weights), s, reading)
        name = Path(campaign).name
        title = f"F over {len(omap.F)} simulations, weights {_fmt(omap.eta)}, R = {omap.radius:g} mm"
        path = save_figure(objective_map_figure(omap, title), out or Path("runs") / name / "figure8.png")
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    b = omap.bounds_pct
    payload = {
        "png": str(path),
        "points": len(omap.F),
        "hessian": omap.hessian.tolist(),
        "c1_pct": float(b[0]),
        "c5_pct": float(b[1]),
    }
    if as_json:
        print(strict_json(payload))
        return
    Console().print(f"wrote {path} ({len(omap.F)} points); bounds c1 +-{b[0]:.1f} %, c5 +-{b[1]:.1f} %")


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


@design_app.command("compare")
def compare_cmd(
    radii: Annotated[str, typer.Option(help="indenter radii, mm")] = "4.77,8",
    depths: Annotated[str, typer.Option(help="maximum depths, mm")] = "5,7,10.5,14",
    every: Annotated[str, typer.Option(help="measure every k-th 0.5 mm step (k values)")] = "1",
    fovs: Annotated[str, typer.Option(help="DIC field-of-view radii, mm ('all' = whole top)")] = "all",
    noise: Annotated[str, typer.Option("--s", help="noise levels s")] = "0.05",
    weights: Annotated[
        str, typer.Option(help="fixed weights to report beside the optimum")
    ] = "0.45,0.35,0.2,0",
    criterion: Annotated[str, typer.Option(help="weight optimum: c1, c5, combined or det")] = "combined",
    theta: THETA = "10,350",
    kappa: KAPPA = 1000.0,
    step_size: STEP_SIZE = 0.5,
    mesh: MESH = "default",
    mesh_from: MESH_FROM = None,
    reading: READING = "paper",
    out_dir: Annotated[Path, typer.Option(help="folder for design-comparison.csv and .png")] = Path(
        "runs/design"
    ),
    as_json: JSON = False,
) -> None:
    """Which experiment to run: bounds of every candidate design (radius x depth x sampling x field
    of view x noise), as a table and a plot (one simulation with sensitivities per radius)."""
    import numpy as np

    from ..design.experiment_choice import candidate_grid, compare_designs
    from .figures import design_comparison_figure, save_figure

    try:
        c1, c5 = _floats(theta)
        max_depth = max(_floats(depths))
        spec = model_spec(
            c1,
            c5,
            kappa=kappa,
            radius=4.77,
            steps=int(np.ceil(max_depth / step_size - 1e-9)),
            step_size=step_size,
            mesh=mesh,
            mesh_from=mesh_from,
            substeps=1,
        )
        fov_values = [None if v.strip() == "all" else float(v) for v in fovs.split(",")]
        candidates = candidate_grid(
            _floats(radii), _floats(depths), [int(v) for v in _floats(every)], fov_values, _floats(noise)
        )
        table = compare_designs(
            spec, candidates, (c1, c5), _floats(weights), criterion, reading, progress=err.print
        )
    except (SpecError, ValueError) as exc:
        fail(str(exc), as_json)
    out_dir.mkdir(parents=True, exist_ok=True)
    csv = out_dir / "design-comparison.csv"
    atomic_write(csv, table.to_csv(index=False))
    png = save_figure(design_comparison_figure(table), out_dir / "design-comparison.png")
    if as_json:
        rows = json.loads(table.to_json(orient="records"))
        payload = {"rows": rows, "csv": str(csv), "png": str(png), "theta_star": [c1, c5]}
        print(strict_json(payload | {"bounds_include": design.DESIGN_BOUNDS_INCLUDE}))
        return
    view = Table(
        title=f"candidate designs at theta* = {theta} kPa (fixed weights {weights}; optimised for {criterion})"
    )
    for col in ("R mm", "depth mm", "steps", "FOV mm", "s", "c1 / c5 fixed", "c1 / c5 optimised", "weights"):
        view.add_column(col)
    for r in table.itertuples():
        view.add_row(
            f"{r.radius_mm:g}",
            f"{r.max_depth_mm:g}",
            str(r.steps),
            "all" if np.isnan(r.fov_mm) else f"{r.fov_mm:g}",
            f"{r.s:g}",
            _pair(r.c1_pct, r.c5_pct),
            _pair(r.c1_pct_optimised, r.c5_pct_optimised),
            _fmt(r.optimised_weights),
        )
    Console(width=130).print(view)
    Console().print(f"bounds: {design.DESIGN_BOUNDS_INCLUDE}")
    Console().print(f"wrote {csv} and {png}")


@design_app.command("error-budget")
def error_budget_cmd(
    reference: Annotated[
        str, typer.Option(help="campaign of noise-free responses on a finer mesh: its points are the tests")
    ],
    model: Annotated[
        list[str],
        typer.Option(
            help="a mesh preset, a .feb file or a surrogate file; repeat for several; PRESET@stick or "
            "PRESET@mu=VALUE: that mesh with another contact (a stick model fitted to frictional data)"
        ),
    ],
    weights: Annotated[str, typer.Option(help="eta = force,ux,uy,uz on the simplex")] = "0.45,0.35,0.2,0",
    force_noise: Annotated[float, typer.Option(help="relative force noise per step")] = 0.02,
    dic_noise: Annotated[float, typer.Option(help="DIC noise per node, mm")] = 0.02,
    fe_steps: Annotated[int, typer.Option(help="Gauss-Newton steps of an FE model's fit")] = 3,
    fov: Annotated[
        float, typer.Option(help="DIC field of view: radius around the axis, mm (0: whole top)")
    ] = 25.0,
    out: Annotated[
        Path | None, typer.Option(help="JSON to write (default runs/<reference>/error-budget.json)")
    ] = None,
    runs_dir: Annotated[Path, typer.Option(help="where campaigns live")] = Path("runs"),
    as_json: JSON = False,
) -> None:
    """The error budget of models: the bias each causes in a fit of the reference's noise-free
    responses, beside a typical experiment's 95 % half-width (converged: bias below a third).
    The JSON is saved after every row; run again with the same settings to resume a stopped one."""
    from ..campaign.loader import open_campaign

    try:
        path = out or open_campaign(reference, runs_dir).root / "error-budget.json"
        budget = inference.campaign_error_budget(
            reference,
            model,
            weights=_floats(weights),
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
    payload = budget.to_dict()
    payload["json_file"] = str(path)
    if as_json:
        print(strict_json(payload))
        return
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
    Console().print(f"wrote {path}")
