"""``indent-studio composite equibiaxial``: the composite phantom's equibiaxial stretch and the
eq. 10 fit of its homogenised (c1, c5) (paper 2.9, 3.3.2, Fig. 14)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from ..atomic_write import strict_json
from .options import JSON, fail

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
