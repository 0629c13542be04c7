"""Options, spec building and error reporting shared by the ``indent-studio`` commands."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from ..atomic_write import strict_json
from ..forward.mesh_presets import COMPOSITE_MESH_PRESETS
from ..forward.spec import (
    CompositeMaterial,
    Contact,
    Geometry,
    Indenter,
    Material,
    MeshChoice,
    ModelSpec,
    Protocol,
    SolverOptions,
)

err = Console(stderr=True)


def say(message: str) -> None:
    """A workflow's progress line, on stderr (stdout is the --json contract's)."""
    err.print(message, highlight=False)


class SolverName(StrEnum):
    embedded = "embedded"
    febio = "febio"


def fail(message: str, as_json: bool, code: int = 1) -> None:
    if as_json:
        print(strict_json({"error": message}))
    err.print(f"[bold red]error:[/] {message}", soft_wrap=True, highlight=False)
    raise typer.Exit(code)


def model_spec(
    c1: float,
    c5: float,
    *,
    kappa: float,
    radius: float,
    steps: int,
    step_size: float,
    mesh: str,
    mesh_from: Path | None,
    substeps: int,
    friction: float | None = None,
) -> ModelSpec:
    """The model spec the command-line options describe (a composite mesh preset gets the
    phantom's constituents, 2.4.2)."""

    composite = CompositeMaterial() if mesh in COMPOSITE_MESH_PRESETS and not mesh_from else None
    return ModelSpec(
        composite=composite,  # a composite mesh preset: the phantom's constituents (2.4.2)
        geometry=Geometry(),
        indenter=Indenter(radius),
        protocol=Protocol(step_size=step_size, steps=steps),
        material=Material(c1=c1, c5=c5, kappa=kappa),
        mesh=MeshChoice(preset=mesh, feb_file=str(mesh_from) if mesh_from else None),
        solver=SolverOptions(substeps=substeps),
        contact=Contact(friction=friction),
    )


C1 = Annotated[float, typer.Option(help="c1, kPa (eq. 3)")]
C5 = Annotated[float, typer.Option(help="c5, kPa (eq. 3)")]
KAPPA = Annotated[float, typer.Option(help="bulk-like modulus kappa, kPa")]
RADIUS = Annotated[float, typer.Option(help="sphere radius, mm (paper: 4.77 or 8)")]
STEPS = Annotated[int, typer.Option(help="number of indentation steps")]
STEP_SIZE = Annotated[float, typer.Option(help="depth per step, mm")]
MESH = Annotated[
    str,
    typer.Option(
        help="mesh preset: coarse, default, fine, reference; composite-coarse, composite-medium, composite: the composite "
        "phantom (its constituents, not c1/c5)"
    ),
]
MESH_FROM = Annotated[Path | None, typer.Option(help="run on the hex8 block mesh of this FEBio .feb file")]
SUBSTEPS = Annotated[int, typer.Option(help="solver increments per step")]
FRICTION = Annotated[
    float | None,
    typer.Option(
        "--friction",
        help="Coulomb friction coefficient mu between sphere and block (0: frictionless); "
        "default: the paper's near-perfect stick",
    ),
]
JSON = Annotated[bool, typer.Option("--json", help="print one JSON object on stdout")]
