"""``indent-studio composite``: the composite phantom (paper 2.4.2, 2.9, 3.3).

- ``equibiaxial``: its equibiaxial stretch and the eq. 10 fit of its homogenised (c1, c5) (Fig. 14);
- ``indent``: its indentation written as an experiment folder, for ``indent-studio fit``;
- ``compare``: the homogeneous model at a fitted (c1, c5) beside the composite (Fig. 12, 13)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from ..atomic_write import strict_json
from .options import FRICTION, JSON, RADIUS, STEP_SIZE, STEPS, err, fail, say
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
    from ..design.composite_homogenisation import composite_equibiaxial_fit
    from ..forward.spec import SpecError

    try:
        done = composite_equibiaxial_fit(max_stretch, steps, cell, bulk_to_shear)
        if figure is not None:
            from .figures import equibiaxial_figure, save_figure

            r = done.stretch
            save_figure(
                equibiaxial_figure(r.stretch_x, r.sigma_fiber, r.sigma_transverse, done.fit.values), figure
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


@composite_app.command("indent")
def indent(
    out: Annotated[Path, typer.Option(help="experiment folder to write (the result is kept in it)")],
    radius: RADIUS = 4.77,
    mesh: Annotated[
        str,
        typer.Option(
            help="composite mesh preset: composite (paper size), composite-medium or composite-coarse"
        ),
    ] = "composite",
    steps: STEPS = 28,
    step_size: STEP_SIZE = 0.5,
    friction: FRICTION = None,
    from_result: Annotated[
        Path | None, typer.Option(help="write the experiment from this composite result (.npz), no run")
    ] = None,
    seed: Annotated[int, typer.Option(help="noise seed")] = 0,
    overwrite: Annotated[bool, typer.Option(help="replace an experiment already in --out")] = False,
    as_json: JSON = False,
) -> None:
    """Indent the composite phantom (its fibers and matrix, the paper's stick) and write the run as
    a DIC-like experiment (0.02 mm DIC noise, 2 % force noise, 0.1 mm misregistration) that
    ``indent-studio fit --experiment OUT`` identifies with the homogeneous model."""
    import time

    from ..forward.result import SimulationResult
    from ..forward.solver import SimulationError
    from ..forward.spec import SpecError
    from ..inference.composite_experiment import (
        RESULT_FILE,
        composite_indentation,
        experiment_from_composite,
    )

    t0 = time.perf_counter()
    try:
        if from_result is not None:
            result = SimulationResult.load(from_result)
            folder = experiment_from_composite(result, out, seed=seed, overwrite=overwrite)
            result_file = from_result
        else:
            with step_progress(err, "composite indentation", steps) as bar:
                result, folder = composite_indentation(
                    out,
                    radius,
                    mesh,
                    steps,
                    step_size,
                    friction,
                    progress=lambda k, n, f: bar.update(k, f"{f:.1f} mN"),
                    say=say,
                    seed=seed,
                    overwrite=overwrite,
                )
            result_file = out / RESULT_FILE
    except (SpecError, ValueError, FileExistsError, SimulationError, OSError) as exc:
        fail(str(exc), as_json)
    payload = {
        "experiment": str(folder),
        "result_file": str(result_file),
        "depth_mm": result.depth.tolist(),
        "force_mN": result.force.tolist(),
        "mesh": result.solver.get("mesh"),
        "newton_iterations": result.newton_iterations,
        "simulation_wall_s": result.wall_s,
        "wall_s": time.perf_counter() - t0,
    }
    if as_json:
        print(strict_json(payload))
        return
    Console().print(
        f"composite R = {result.spec['indenter']['radius']:g} mm: {result.force[-1]:.1f} mN at "
        f"{result.depth[-1]:g} mm ({result.solver['mesh']['nodes']} nodes, {result.wall_s:.0f} s); "
        f"experiment: {folder}"
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
    import json

    from ..forward.solver import SimulationError
    from ..forward.spec import SpecError
    from ..inference.composite_experiment import compare_with_homogeneous, fitted_model

    try:
        if fit is not None:
            (c1_fit, c5_fit), mu_fit = fitted_model(fit)
            c1 = c1_fit if c1 is None else c1
            c5 = c5_fit if c5 is None else c5
            friction = mu_fit if friction is None else friction  # the model the fit found
        if c1 is None or c5 is None:
            raise ValueError("give --c1 and --c5, or --fit")
        done = compare_with_homogeneous(
            result, (c1, c5), mesh, friction="composite" if friction is None else friction
        )
        if figure is not None:
            from .figures import composite_comparison_figure, save_figure

            save_figure(composite_comparison_figure(done), figure)
    except (SpecError, ValueError, KeyError, SimulationError, OSError, json.JSONDecodeError) as exc:
        fail(f"{exc}", as_json)
    payload = done.to_dict() | {"figure": str(figure) if figure is not None else None}
    if as_json:
        print(strict_json(payload))
        return
    Console().print(
        f"homogeneous {{c1, c5}} = {{{c1:g}, {c5:g}}} kPa against the composite: force gap at the last "
        f"step {100 * payload['force_rel_gap_last']:+.1f} % (largest {100 * payload['force_rel_gap_max']:.1f} %); "
        f"field rms gap (x, y, z) {', '.join(f'{v:.3f}' for v in payload['field_rms_gap_mm'].values())} mm"
    )
