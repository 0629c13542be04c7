"""``indent-studio design bounds | weights``: certainty bounds (eq. 6) and the layout of Table 1."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from .. import design, studio  # lazy packages: a command imports what it runs
from ..atomic_write import atomic_write_json, strict_json
from ..forward.mesh_presets import FIT_MESH
from ..forward.spec import SpecError
from .options import (
    JSON,
    MODEL_FLAGS,
    RADII,
    WEIGHTS,
    ModelOptions,
    err,
    fail,
    model_options,
    number_list,
)

design_app = typer.Typer(
    help="Experiment design: certainty bounds and objective weights (paper 2.6, Table 1)."
)

THETA = Annotated[str, typer.Option(help="theta* = c1,c5 in kPa")]
S = Annotated[float, typer.Option("--s", help="noise level s of eq. 6 (design stage: 0.05)")]
METHOD = Annotated[str, typer.Option(help="Hessian: exact (Gauss-Newton, solver sensitivities) or fd")]
READING = Annotated[
    str,
    typer.Option(
        help="objective reading: paper (eq. 4 as printed, DIC from 1 R), fit (the studio's fits: DIC from "
        "1.5 R) or authors (their code's 1.2 R to 5.5 R ring)"
    ),
]
FD_STEP = Annotated[
    str,
    typer.Option(
        help="fd step in theta/theta*: one number, c1,c5, or 'grid' (the paper grid's spacing, "
        "as the authors' code)"
    ),
]
FD_JOBS = Annotated[int, typer.Option("--jobs", help="parallel simulations for the fd stencil")]


def _fd_step(text: str):
    from ..design.certainty import PAPER_GRID_STEP

    if text.strip() == "grid":
        return PAPER_GRID_STEP
    values = [float(v) for v in text.split(",")]
    return values[0] if len(values) == 1 else tuple(values)


def _study(
    model: ModelOptions, theta: str, method: str, reading: str, fd_step: str, jobs: int, as_json: bool
):
    """The design study at theta* = ``theta`` ('c1,c5') on the model of the command's options."""
    try:
        c1, c5 = (float(v) for v in theta.split(","))
        spec = model.replace(c1=c1, c5=c5).spec()
        err.print(
            f"design study at theta* = ({c1:g}, {c5:g}) kPa, R = {model.radius:g} mm, {method} Hessian ..."
        )
        return design.model_design_study(
            spec, method=method, reading=reading, h=_fd_step(fd_step), n_jobs=jobs
        )
    except (SpecError, ValueError) as exc:
        fail(str(exc), as_json)


def _fmt(eta) -> str:
    return "(" + ",".join(f"{v:.2f}" for v in eta) + ")"


def _pair(c1: float, c5: float) -> str:
    return f"{c1:.1f} / {c5:.1f}"


MU_PRIOR = Annotated[
    str, typer.Option(help="with --friction: the range LO:HI of mu's log-uniform prior as a nuisance")
]
CRITERION = Annotated[str, typer.Option(help="c1, c5, combined (sum of squared bounds) or det")]
WEIGHTS_OUT = Annotated[Path | None, typer.Option(help="also write the table as JSON here")]


@design_app.command("bounds")
@model_options(*(f for f in MODEL_FLAGS if f not in ("c1", "c5")))
def bounds(
    weights: WEIGHTS = "0.45,0.35,0.2,0",
    s: S = 0.05,
    theta: THETA = "10,350",
    *,
    model: ModelOptions,
    method: METHOD = "exact",
    reading: READING = "paper",
    fd_step: FD_STEP = "0.02",
    jobs: FD_JOBS = 1,
    mu_prior: MU_PRIOR = "0.1:3",
    as_json: JSON = False,
) -> None:
    """Certainty bounds of c1 and c5 (eq. 6) for one set of objective weights. With ``--friction
    MU`` the model has Coulomb friction mu and the bounds are given three ways: mu known,
    identified with (c1, c5), and a nuisance with a log-uniform prior (``--mu-prior``)."""
    try:
        eta = design.check_weights([float(v) for v in weights.split(",")])
        prior = tuple(float(v) for v in mu_prior.split(":"))
        if len(prior) != 2 or not 0 < prior[0] < prior[1]:
            raise ValueError(f"--mu-prior {mu_prior!r}: expected LO:HI with 0 < LO < HI")
    except ValueError as exc:
        fail(str(exc), as_json)
    study = _study(model, theta, method, reading, fd_step, jobs, as_json)
    try:
        result = design.design_bounds(study, eta, s, mu_prior=prior)
    except ValueError as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json(result.to_dict()))
        return
    _print_bounds(result, mu_prior)


def _print_bounds(result: design.DesignBounds, mu_prior: str) -> None:
    """The bounds of c1 and c5 (and with friction, mu's three treatments) and the Hessian."""
    b, with_mu, s = result.bounds_pct, result.friction, result.s
    Console().print(f"weights {_fmt(result.weights)}: c1 +-{b[0]:.1f} %, c5 +-{b[1]:.1f} %   (s = {s:g})")
    if with_mu is not None and "note" in with_mu:
        Console().print(f"  {with_mu['note']}")
    elif with_mu is not None:
        i, n = with_mu["identified_pct"], with_mu["nuisance_pct"]
        Console().print(
            f"  mu = {with_mu['mu']:g} known: the above; identified with them: c1 +-{i[0]:.1f} %, c5 +-{i[1]:.1f} %, "
            f"mu +-{with_mu['identified_mu_pct']:.0f} %; a nuisance (log-uniform on {mu_prior}): "
            f"c1 +-{n[0]:.1f} %, c5 +-{n[1]:.1f} %"
        )
    Console().print(f"bounds: {design.DESIGN_BOUNDS_INCLUDE}")
    H = result.study.hessian(result.weights)
    Console().print(f"H(theta*) (normalised) = {np.array2string(H, precision=3)}")


@design_app.command("weights")
@model_options(*(f for f in MODEL_FLAGS if f not in ("c1", "c5", "friction")))
def weights_cmd(
    criterion: CRITERION = "combined",
    s: S = 0.05,
    theta: THETA = "10,350",
    *,
    model: ModelOptions,
    method: METHOD = "exact",
    reading: READING = "paper",
    fd_step: FD_STEP = "0.02",
    jobs: FD_JOBS = 1,
    out: WEIGHTS_OUT = None,
    as_json: JSON = False,
) -> None:
    """The layout of Table 1: force only; deformation only; optimal for c1; for c5; combined; each
    row beside the paper's bounds and ours at the paper's weights."""
    study = _study(model, theta, method, reading, fd_step, jobs, as_json)
    try:
        table = design.weights_table(study, s, criterion, fd_step=fd_step)
    except ValueError as exc:
        fail(str(exc), as_json)
    payload = table.to_dict()
    if out is not None:
        atomic_write_json(out, payload)
    if as_json:
        print(strict_json(payload))
        return
    _print_weights(table, theta)


def _print_weights(table: design.WeightsTable, theta: str) -> None:
    """Table 1 beside the paper's, and H(theta*) at the paper's weights beside its eq. 14."""
    study = table.study
    view = Table(
        title=f"Table 1 at theta* = {theta} kPa, s = {table.s:g} ({study.method} Hessian, {study.reading} reading)"
    )
    for col in (
        "+- % of c1 / c5",
        "paper",
        "paper weights",
        "ours, paper weights",
        "ours, optimised",
        "our weights",
    ):
        view.add_column(col)
    for r in table.rows:
        view.add_row(
            r.name,
            _pair(r.paper_c1_pct, r.paper_c5_pct),
            _fmt(r.paper_weights),
            _pair(r.c1_pct_at_paper_weights, r.c5_pct_at_paper_weights),
            _pair(r.c1_pct, r.c5_pct),
            _fmt(r.weights),
        )
    Console(width=130).print(view)
    H = table.hessian_paper_weights
    P = design.PAPER_HESSIAN
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
    try:
        base = design.baseline_from_constituents(mu_matrix, fiber_c1, fiber_c2, fvf, equibiaxial=equibiaxial)
    except (OSError, ValueError, RuntimeError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json(base.to_dict()))
        return
    Console().print(f"eq. 11: c1 = {base.c1:.2f} kPa, c5 = {base.c5:.1f} kPa (FVF {fvf:g})")
    if base.equibiaxial_fit is not None:
        v, e = base.equibiaxial_fit.values, base.equibiaxial_fit.std_errors
        Console().print(
            f"eq. 10 fit: c1 = {v['c1']:.2f} +- {e['c1']:.2f} kPa, c5 = {v['c5']:.1f} +- {e['c5']:.1f} kPa"
        )


@design_app.command("map")
def map_cmd(
    campaign: Annotated[str, typer.Option(help="campaign name under runs/ (or its folder)")],
    weights: WEIGHTS = "0.45,0.35,0.2,0",
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
    try:
        theta_star = number_list(theta)
        err.print(f"simulating theta* = {theta} kPa on the campaign's model with sensitivities ...")
        omap = design.campaign_objective_map(campaign, theta_star, number_list(weights), s, reading)
        name = Path(campaign).name
        title = f"F over {len(omap.F)} simulations, weights {_fmt(omap.eta)}, R = {omap.radius:g} mm"
        path = studio.save_figure(
            studio.objective_map_figure(omap, title), out or Path("runs") / name / "figure8.png"
        )
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


DEPTHS = Annotated[str, typer.Option(help="maximum depths, mm")]
EVERY = Annotated[str, typer.Option(help="measure every k-th 0.5 mm step (k values)")]
FOVS = Annotated[str, typer.Option(help="DIC field-of-view radii, mm ('all' = whole top)")]
NOISE_LEVELS = Annotated[str, typer.Option("--s", help="noise levels s")]
FIXED_WEIGHTS = Annotated[str, typer.Option(help="fixed weights to report beside the optimum")]
OPTIMUM = Annotated[str, typer.Option(help="weight optimum: c1, c5, combined or det")]
COMPARISON_DIR = Annotated[Path, typer.Option(help="folder for design-comparison.csv and .png")]


@design_app.command("compare")
@model_options("kappa", "step_size", "mesh", "mesh_from", mesh=FIT_MESH)
def compare_cmd(
    radii: RADII = "4.77,8",
    depths: DEPTHS = "5,7,10.5,14",
    every: EVERY = "1",
    fovs: FOVS = "all",
    noise: NOISE_LEVELS = "0.05",
    weights: FIXED_WEIGHTS = "0.45,0.35,0.2,0",
    criterion: OPTIMUM = "combined",
    theta: THETA = "10,350",
    *,
    model: ModelOptions,
    reading: READING = "fit",
    out_dir: COMPARISON_DIR = Path("runs/design"),
    as_json: JSON = False,
) -> None:
    """Which experiment to run: bounds of every candidate design (radius x depth x sampling x field
    of view x noise), as a table and a plot (one simulation with sensitivities per radius), on the
    fit's model and objective (contact-L1, DIC from 1.5 R) unless told otherwise."""
    try:
        c1, c5 = number_list(theta)
        steps = int(np.ceil(max(number_list(depths)) / model.step_size - 1e-9))  # the deepest candidate's
        comparison = design.compare_candidate_designs(
            model.replace(c1=c1, c5=c5, steps=steps).spec(),
            out_dir,
            **_candidate_axes(radii, depths, every, fovs, noise),
            weights=number_list(weights),
            criterion=criterion,
            reading=reading,
            progress=err.print,
        )
    except (SpecError, ValueError) as exc:
        fail(str(exc), as_json)
    png = studio.save_figure(
        studio.design_comparison_figure(comparison.table), Path(out_dir) / "design-comparison.png"
    )
    if as_json:
        print(strict_json(comparison.to_dict(png=png)))
        return
    _print_comparison(
        comparison, f"theta* = {theta} kPa (fixed weights {weights}; optimised for {criterion})"
    )
    Console().print(f"wrote {comparison.csv} and {png}")


def _candidate_axes(radii: str, depths: str, every: str, fovs: str, noise: str) -> dict[str, list]:
    """The candidate designs' axes from the command's comma lists ('all': the whole top)."""
    return {
        "radii": number_list(radii),
        "depths": number_list(depths),
        "every": [int(v) for v in number_list(every)],
        "fovs": [None if v.strip() == "all" else float(v) for v in fovs.split(",")],
        "noise": number_list(noise),
    }


def _print_comparison(comparison: design.DesignComparison, at: str) -> None:
    """The candidate designs' bounds as a table."""
    view = Table(title=f"candidate designs at {at}")
    for col in (
        "R mm",
        "depth mm",
        "steps",
        "FOV mm",
        "s",
        "c1 / c5 fixed",
        "c1 / c5 optimised",
        "c1 / c5 with model error",
        "weights",
    ):
        view.add_column(col)
    for r in comparison.table.itertuples():
        view.add_row(
            f"{r.radius_mm:g}",
            f"{r.max_depth_mm:g}",
            str(r.steps),
            "all" if np.isnan(r.fov_mm) else f"{r.fov_mm:g}",
            f"{r.s:g}",
            _pair(r.c1_pct, r.c5_pct),
            _pair(r.c1_pct_optimised, r.c5_pct_optimised),
            "statistical only" if np.isnan(r.c1_model_pct) else _pair(r.c1_total_pct, r.c5_total_pct),
            _fmt(r.optimised_weights),
        )
    Console(width=150).print(view)
    Console().print(f"bounds: {design.DESIGN_BOUNDS_INCLUDE}")
    sources = sorted({s for s in comparison.table["model_error"] if s != "statistical only"})
    Console().print(
        "model error: the error budget of the high fidelity a fit's surrogate emulates, where one exists for the "
        f"test ({'; '.join(sources) or 'none of these tests'}); a fit adds its discrepancy's, surrogate's and "
        "processing's parts"
    )
