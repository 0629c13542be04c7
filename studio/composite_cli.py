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
    import time

    from ..design.constituents import fit_equibiaxial, rule_of_mixtures
    from ..forward.block_stretch import equibiaxial_phantom_mesh, equibiaxial_stretch
    from ..forward.composite_mesh import PHANTOM
    from ..forward.spec import CompositeMaterial, Constituent, ModelSpec, SpecError

    try:
        composite = CompositeMaterial()
        if bulk_to_shear is not None:
            composite = CompositeMaterial(
                *(
                    Constituent(c.name, c.c1, c.c2, c.c5, bulk_to_shear * c.shear_modulus)
                    for c in composite.constituents
                )
            )
        spec = ModelSpec.composite_phantom("composite-coarse", composite=composite)
        mesh = equibiaxial_phantom_mesh(spec, cell)
        t = time.perf_counter()
        result = equibiaxial_stretch(spec, max_stretch, steps, mesh=mesh)
        wall = time.perf_counter() - t
        lam = result.stretch_x[1:]
        fit = fit_equibiaxial(lam, result.sigma_fiber[1:], result.sigma_transverse[1:])
        fvf = PHANTOM.fiber_volume_fraction(2 * spec.geometry.half_x, spec.geometry.height)
        m, f = composite.matrix, composite.fibers
        eq11 = rule_of_mixtures(m.shear_modulus, f.c1, f.c2, fvf)
        if figure is not None:
            from .figures import equibiaxial_figure, save_figure

            save_figure(
                equibiaxial_figure(result.stretch_x, result.sigma_fiber, result.sigma_transverse, fit.values),
                figure,
            )
    except (SpecError, ValueError, RuntimeError, OSError) as exc:
        fail(str(exc), as_json)
    payload = {
        **result.to_dict(),
        "fit": {
            "values": fit.values,
            "std_errors": fit.std_errors,
            "rms_kPa": fit.rms_kPa,
            "n_points": fit.n_points,
        },
        "eq11": {"c1": eq11[0], "c5": eq11[1], "fiber_volume_fraction": fvf},
        "mesh": {"nodes": mesh.n_nodes, "elements": mesh.n_elements, "source": mesh.source},
        "kappa_kPa": {c.name: c.kappa for c in composite.constituents},
        "wall_s": wall,
        "figure": str(figure) if figure is not None else None,
    }
    if as_json:
        print(strict_json(payload))
        return
    v, e = fit.values, fit.std_errors
    Console().print(
        f"eq. 10 fit: c1 = {v['c1']:.2f} +- {e['c1']:.2f} kPa, c5 = {v['c5']:.1f} +- {e['c5']:.1f} kPa "
        f"(standard errors; rms {fit.rms_kPa:.2f} kPa); eq. 11: c1 = {eq11[0]:.2f}, c5 = {eq11[1]:.1f} kPa; "
        f"{mesh.n_nodes} nodes, {wall:.1f} s"
    )
