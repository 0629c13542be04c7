"""``indent-studio composite``: the composite phantom (paper 2.4.2, 2.9, 3.3).

- ``equibiaxial``: its equibiaxial stretch and the eq. 10 fit of its homogenised (c1, c5) (Fig. 14);
- ``indent``: its indentation written as an experiment folder, for ``indent-studio fit``;
- ``compare``: the homogeneous model at a fitted (c1, c5) beside the composite (Fig. 12, 13)."""

from __future__ import annotations

import json
from contextlib import nullcontext
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from .. import design, forward, inference, studio  # lazy packages: a command imports what it runs
from ..atomic_write import strict_json
from ..forward.spec import SpecError
from .options import JSON, OVERWRITE, SEED, ModelOptions, err, fail, model_options, say
from .progress import step_progress

composite_app = typer.Typer(help="The composite phantom (paper 2.4.2, 2.9): TPU fibers in a silicone matrix.")


@composite_app.command("equibiaxial")
def equibiaxial(
    max_stretch: Annotated[float, typer.Option(help="final stretch lambda in x and y")] = 1.3,
    steps: Annotated[int, typer.Option(help="equal stretch steps")] = 30,
    cell: Annotated[
        float, typer.Option(help="cell size between fibers, mm (2 cells across each fiber)")
    ] = 0.8,
    bulk_to_shear: Annotated[
        float | None,
        typer.Option(help="kappa / 2 (c1 + c2) of both constituents; default spec.BULK_TO_SHEAR"),
    ] = None,
    figure: Annotated[Path | None, typer.Option(help="write Fig. 14 (stress against stretch) here")] = None,
    as_json: JSON = False,
) -> None:
    """Stretch the phantom equibiaxially (fibers along y, top free) and fit eq. 10 to its
    volume-averaged true stresses; eq. 11's rule of mixtures beside it."""
    try:
        done = design.composite_equibiaxial_fit(max_stretch, steps, cell, bulk_to_shear)
        if figure is not None:
            r = done.stretch
            studio.figures.save_figure(
                studio.figures.equibiaxial_figure(
                    r.stretch_x, r.sigma_fiber, r.sigma_transverse, done.fit.values
                ),
                figure,
            )
    except (SpecError, ValueError, RuntimeError, OSError) as exc:
        fail(str(exc), as_json)
    payload = done.to_dict() | {"figure": str(figure) if figure is not None else None}
    fit, eq11, mesh, wall = done.fit, done.eq11, done.mesh, done.wall_s
    if as_json:
        print(strict_json(payload))
        return
    v, e = fit.values, fit.std_errors
    Console().print(
        f"eq. 10 fit: c1 = {v['c1']:.2f} +- {e['c1']:.2f} kPa, c5 = {v['c5']:.1f} +- {e['c5']:.1f} kPa "
        f"(standard errors; rms {fit.rms_kPa:.2f} kPa); eq. 11: c1 = {eq11[0]:.2f}, c5 = {eq11[1]:.1f} kPa; "
        f"{mesh.n_nodes} nodes, {wall:.1f} s"
    )


EXPERIMENT_OUT = Annotated[Path, typer.Option(help="experiment folder to write (the result is kept in it)")]
COMPOSITE_MESH = Annotated[
    str,
    typer.Option(
        help="composite mesh preset: composite (paper size), composite-medium, composite-coarse or composite-contact (its core follows the contact, surface contact by default)"
    ),
]
FROM_RESULT = Annotated[
    Path | None, typer.Option(help="write the experiment from this composite result (.npz), no run")
]


@composite_app.command("indent")
@model_options("radius", "steps", "step_size", "friction", "contact", "contact_order", "contact_penalty")
def indent(
    out: EXPERIMENT_OUT,
    mesh: COMPOSITE_MESH = "composite",
    from_result: FROM_RESULT = None,
    seed: SEED = 0,
    overwrite: OVERWRITE = False,
    as_json: JSON = False,
    *,
    model: ModelOptions,
) -> None:
    """Indent the composite phantom (its fibers and matrix, the paper's stick) and write the run as
    a DIC-like experiment (0.02 mm DIC noise, 2 % force noise, 0.1 mm misregistration) that
    ``indent-studio fit --experiment OUT`` identifies with the homogeneous model."""
    run_now = from_result is None  # a progress bar only for a run
    try:
        with step_progress(err, "composite indentation", model.steps) if run_now else nullcontext() as bar:
            done = inference.write_composite_experiment(
                out,
                from_result=from_result,
                radius=model.radius,
                preset=mesh,
                steps=model.steps,
                step_size=model.step_size,
                contact=model.contact_spec(),
                progress=lambda k, n, f: bar.update(k, f"{f:.1f} mN"),
                say=say,
                seed=seed,
                overwrite=overwrite,
            )
    except (SpecError, ValueError, FileExistsError, forward.SimulationError, OSError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json(done.to_dict()))
        return
    result = done.result
    Console().print(
        f"composite R = {result.spec['indenter']['radius']:g} mm: {result.force[-1]:.1f} mN at "
        f"{result.depth[-1]:g} mm ({result.solver['mesh']['nodes']} nodes, {result.wall_s:.0f} s); "
        f"experiment: {done.experiment}"
    )


@composite_app.command("compare")
def compare(
    result: Annotated[Path, typer.Option(help="the composite result (.npz; composite-result.npz of indent)")],
    c1: Annotated[float | None, typer.Option(help="homogeneous c1, kPa (default: --fit's)")] = None,
    c5: Annotated[float | None, typer.Option(help="homogeneous c5, kPa (default: --fit's)")] = None,
    fit: Annotated[Path | None, typer.Option(help="a fit.json whose (c1, c5) to use")] = None,
    mesh: Annotated[str, typer.Option(help="the homogeneous model's mesh preset")] = "default",
    friction: Annotated[
        float | None,
        typer.Option(
            help="the homogeneous model's Coulomb mu (default: --fit's mu, else the composite's contact)"
        ),
    ] = None,
    figure: Annotated[
        Path | None, typer.Option(help="write force-depth and displacement maps (Fig. 12, 13) here")
    ] = None,
    as_json: JSON = False,
) -> None:
    """The homogeneous model at (c1, c5) beside the composite: force against depth and the
    top-surface field at the last step, where the top fibers show."""
    try:
        done = inference.compare_with_fit(result, c1=c1, c5=c5, fit=fit, mesh=mesh, friction=friction)
        if figure is not None:
            studio.figures.save_figure(studio.figures.composite_comparison_figure(done), figure)
    except (SpecError, ValueError, KeyError, forward.SimulationError, OSError, json.JSONDecodeError) as exc:
        fail(f"{exc}", as_json)
    payload = done.to_dict() | {"figure": str(figure) if figure is not None else None}
    if as_json:
        print(strict_json(payload))
        return
    Console().print(
        f"homogeneous {{c1, c5}} = {{{done.theta[0]:g}, {done.theta[1]:g}}} kPa against the composite: force gap at the last "
        f"step {100 * payload['force_rel_gap_last']:+.1f} % (largest {100 * payload['force_rel_gap_max']:.1f} %); "
        f"field rms gap (x, y, z) {', '.join(f'{v:.3f}' for v in payload['field_rms_gap_mm'].values())} mm"
    )
