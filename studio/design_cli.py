"""``indent-studio design bounds | weights``: certainty bounds (eq. 6) and the layout of Table 1."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from ..forward.spec import SpecError
from .options import (
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


def _study(theta, kappa, radius, steps, step_size, mesh, mesh_from, substeps, method, reading, as_json):
    from ..design.study import fe_design_study

    try:
        c1, c5 = (float(v) for v in theta.split(","))
        spec = model_spec(c1, c5, kappa, radius, steps, step_size, mesh, mesh_from, substeps)
        err.print(f"design study at theta* = ({c1:g}, {c5:g}) kPa, R = {radius:g} mm, {method} Hessian ...")
        return fe_design_study(spec, (c1, c5), method=method, reading=reading)
    except (SpecError, ValueError) as exc:
        fail(str(exc), as_json)


def _fmt(eta) -> str:
    return "(" + ", ".join(f"{v:.2f}" for v in eta) + ")"


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
    as_json: JSON = False,
) -> None:
    """Certainty bounds of c1 and c5 (eq. 6) for one set of objective weights."""
    from ..design.objective import check_weights

    try:
        eta = check_weights([float(v) for v in weights.split(",")])
    except ValueError as exc:
        fail(str(exc), as_json)
    study = _study(
        theta, kappa, radius, steps, step_size, mesh, mesh_from, substeps, method, reading, as_json
    )
    H = study.hessian(eta)
    b = study.bounds(eta, s)
    payload = {
        "c1_pct": float(b[0]),
        "c5_pct": float(b[1]),
        "hessian": H.tolist(),
        "weights": eta.tolist(),
        "s": s,
        "method": method,
        "reading": reading,
        "term_hessians": study.term_hessians.tolist(),
    }
    if as_json:
        print(json.dumps(payload))
        return
    Console().print(f"weights {_fmt(eta)}: c1 +-{b[0]:.1f} %, c5 +-{b[1]:.1f} %   (s = {s:g})")
    Console().print(
        f"H(theta*) (normalised) = [[{H[0, 0]:.3g}, {H[0, 1]:.3g}], [{H[1, 0]:.3g}, {H[1, 1]:.3g}]]"
    )


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
    out: Annotated[Path | None, typer.Option(help="also write the table as JSON here")] = None,
    as_json: JSON = False,
) -> None:
    """The layout of Table 1: force only; deformation only; optimal for c1; for c5; combined."""
    from ..design.weights import table1

    study = _study(
        theta, kappa, radius, steps, step_size, mesh, mesh_from, substeps, method, reading, as_json
    )
    try:
        rows = table1(study.term_hessians, s, criterion)
    except ValueError as exc:
        fail(str(exc), as_json)
    payload = {
        "rows": [r.__dict__ for r in rows],
        "s": s,
        "criterion": criterion,
        "method": method,
        "reading": reading,
        "theta_star": study.theta_star.tolist(),
        "hessian_combined": study.hessian(rows[-1].weights).tolist(),
        "term_hessians": study.term_hessians.tolist(),
        "spec": study.spec,
    }
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(payload, indent=1))
    if as_json:
        print(json.dumps(payload))
        return
    table = Table(
        title=f"Table 1 layout at theta* = {theta} kPa, s = {s:g} ({method} Hessian, {reading} reading)"
    )
    for col in ("test design", "c1", "c5", "weights (force, ux, uy, uz)"):
        table.add_column(col)
    for r in rows:
        table.add_row(r.name, f"+-{r.c1_pct:.1f} %", f"+-{r.c5_pct:.1f} %", _fmt(r.weights))
    Console().print(table)
