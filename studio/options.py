"""Options, spec building and error reporting shared by the ``indent-studio`` commands."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console

from ..atomic_write import strict_json
from ..forward.mesh_presets import COMPOSITE_MESH_PRESETS
from ..forward.spec import (
    DEFAULT_CONTACT_PENALTY,
    CompositeMaterial,
    Contact,
    Geometry,
    Indenter,
    Material,
    MeshChoice,
    ModelSpec,
    Protocol,
    SolverOptions,
    SpecError,
)
from .option_group import REQUIRED as REQUIRED  # a command's required flag, imported from here too
from .option_group import option_group

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


def number_list(text: str, option: str = "") -> list[float]:
    """The numbers of a comma-separated option (``"4.77,8"``); a ValueError naming ``option``."""
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise ValueError(f"{option + ' ' if option else ''}{text!r}: use comma-separated numbers") from exc


@dataclass(frozen=True, kw_only=True)
class ModelOptions:
    """The model a command's options describe, built once from the typer parameters (see
    :func:`model_options`); its defaults are the paper's baseline.

    Parameters
    ----------
    c1, c5, kappa : float
        The material (eq. 3), kPa.
    radius : float
        The sphere's radius, mm.
    steps : int
        Indentation steps.
    step_size : float
        Depth per step, mm.
    mesh : str
        A mesh preset; a composite preset gets the phantom's constituents (2.4.2), not c1 and c5.
    mesh_from : Path or None
        The hex8 block mesh of this FEBio .feb file instead of a preset.
    substeps : int
        Solver increments per step.
    friction : float or None
        Coulomb's friction coefficient mu (0: frictionless); None: the paper's near-perfect stick.
    contact : {"node", "surface"} or None
        Where the contact is evaluated: node by node (the stick exact), or at Gauss points of
        the top faces (stick and friction by a penalty; forward.contact_quadrature); None: the
        mesh's own (surface on the contact-L meshes, node elsewhere; forward.spec.Contact).
    contact_order : int or None
        Gauss points per face edge of the surface contact; None: the mesh's own (1 on the
        contact-L meshes, 2 elsewhere).
    contact_penalty : float
        The penalty contact's stiffness, kPa per mm of penetration (and of elastic slip under
        stick), times each contact point's area.
    fiber_stretch : {"gauss", "mean"}
        Where the element evaluates the fiber term: at its Gauss points (FEBio's) or at its mean
        stretch (forward.spec.SolverOptions).
    specimen : str
        The specimen's size ``WIDTHxDEPTHxTHICKNESS`` in mm (full widths along x and y, across
        and along the fibers; the model is its quarter): :func:`specimen_geometry`.
    """

    c1: float = 10.0
    c5: float = 350.0
    kappa: float = 1000.0
    radius: float = 4.77
    steps: int = 28
    step_size: float = 0.5
    mesh: str = "default"
    mesh_from: Path | None = None
    substeps: int = 1
    friction: float | None = None
    contact: str | None = None
    contact_order: int | None = None
    contact_penalty: float = DEFAULT_CONTACT_PENALTY
    fiber_stretch: str = "gauss"
    specimen: str = "100x100x60"

    def spec(self) -> ModelSpec:
        """The model spec of these options.

        Returns
        -------
        ModelSpec
            The spec (a composite mesh preset without ``mesh_from`` gets the phantom's
            constituents, 2.4.2).

        Raises
        ------
        SpecError
            An option out of its range, named by the spec's field.
        """
        composite = self.mesh in COMPOSITE_MESH_PRESETS and not self.mesh_from
        return ModelSpec(
            composite=CompositeMaterial() if composite else None,
            geometry=specimen_geometry(self.specimen),
            indenter=Indenter(self.radius),
            protocol=Protocol(step_size=self.step_size, steps=self.steps),
            material=Material(c1=self.c1, c5=self.c5, kappa=self.kappa),
            mesh=MeshChoice(preset=self.mesh, feb_file=str(self.mesh_from) if self.mesh_from else None),
            solver=SolverOptions(substeps=self.substeps, fiber_stretch=self.fiber_stretch),
            contact=self.contact_spec(),
        )

    def contact_spec(self) -> Contact:
        """The contact of these options.

        Returns
        -------
        Contact
            Friction (or the stick), where it is evaluated, its order and penalty.

        Raises
        ------
        SpecError
            An option out of its range.
        """
        return Contact(
            friction=self.friction,
            integration=self.contact,
            order=self.contact_order,
            penalty=self.contact_penalty,
        )

    def replace(self, **changes: Any) -> ModelOptions:
        """These options with ``changes`` (field name -> value), e.g. a command's fixed mesh."""
        return dataclasses.replace(self, **changes)


def specimen_geometry(text: str) -> Geometry:
    """The quarter model's geometry of a specimen written ``WIDTHxDEPTHxTHICKNESS`` (mm).

    Parameters
    ----------
    text : str
        Full width along x (across the fibers), along y (along them) and thickness, mm, e.g. the
        paper's block ``100x100x60``.

    Returns
    -------
    Geometry
        Half the widths and the thickness.

    Raises
    ------
    SpecError
        A text that is not three positive numbers joined by ``x``.

    Examples
    --------
    >>> from indentation_studio.studio.options import specimen_geometry
    >>> specimen_geometry("60x60x30")
    Geometry(half_x=30.0, half_y=30.0, height=30.0)
    """
    parts = str(text).lower().replace(" ", "").split("x")
    try:
        width, depth, thickness = (float(v) for v in parts)
    except ValueError:
        raise SpecError(
            "specimen",
            f"{text!r}: give its size as WIDTHxDEPTHxTHICKNESS in mm, e.g. 100x100x60 (the paper's block)",
        ) from None
    return Geometry(half_x=width / 2.0, half_y=depth / 2.0, height=thickness)


C1 = Annotated[float, typer.Option(help="c1, kPa (eq. 3)")]
C5 = Annotated[float, typer.Option(help="c5, kPa (eq. 3)")]
KAPPA = Annotated[float, typer.Option(help="bulk-like modulus kappa, kPa")]
RADIUS = Annotated[float, typer.Option(help="sphere radius, mm (paper: 4.77 or 8)")]
STEPS = Annotated[int, typer.Option(help="number of indentation steps")]
STEP_SIZE = Annotated[float, typer.Option(help="depth per step, mm")]
MESH = Annotated[
    str,
    typer.Option(
        help="mesh preset: coarse, default, fine, reference; contact-L0 .. contact-L4: meshes that follow the "
        "indenter's contact (a uniform core 1.65 R wide; the verification study's levels); composite-coarse, "
        "composite-medium, composite, composite-contact (its core follows the contact): the composite phantom (its "
        "constituents, not c1/c5)"
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
CONTACT = Annotated[
    str | None,
    typer.Option(
        "--contact",
        help="where the contact is evaluated: node (node by node, the stick exact) or surface (Gauss "
        "points of the top faces, stick and friction by a penalty); default: the mesh's own, surface "
        "on the meshes that follow the contact (contact-L0 .. contact-L4, composite-contact), node on every other mesh",
    ),
]
CONTACT_ORDER = Annotated[
    int | None,
    typer.Option(
        help="Gauss points per face edge of --contact surface; default: 1 on the meshes that follow the contact, 2 elsewhere"
    ),
]
CONTACT_PENALTY = Annotated[
    float,
    typer.Option(
        help="the penalty contact's stiffness (friction, or --contact surface), kPa per mm of penetration "
        "times each point's area"
    ),
]
SPECIMEN = Annotated[
    str,
    typer.Option(
        help="the specimen's size WIDTHxDEPTHxTHICKNESS, mm (full widths across and along the fibers; "
        "the model is its quarter); the paper's block 100x100x60"
    ),
]
FIBER_STRETCH = Annotated[
    str,
    typer.Option(
        help="where the element evaluates the fiber term: gauss (at its Gauss points, FEBio's) or mean "
        "(once, at its mean stretch: no locking by stiff fibers)"
    ),
]
JSON = Annotated[bool, typer.Option("--json", help="print one JSON object on stdout")]

# The options several commands share, each defined here once (a command's own options stay beside
# it; an option of the same name that means something else there, such as fit's declared
# --force-noise, is named for what it is).
RUNS_DIR = Annotated[Path, typer.Option(help="where campaigns live")]
SEED = Annotated[int, typer.Option(help="random seed")]
JOBS = Annotated[int, typer.Option(help="parallel processes (0: all cores)")]
SCHEDULER = Annotated[
    str | None, typer.Option(help="dask.distributed scheduler address, e.g. tcp://10.0.0.1:8786")
]
SOLVER = Annotated[SolverName, typer.Option(help="FE solver")]
WEIGHTS = Annotated[str, typer.Option(help="eta = force,ux,uy,uz on the simplex")]
RADII = Annotated[str, typer.Option(help="indenter radii, mm")]
FORCE_NOISE = Annotated[float, typer.Option(help="force noise (sd) relative to the force, per step")]
DIC_NOISE = Annotated[float, typer.Option(help="DIC displacement noise (sd), mm")]
OVERWRITE = Annotated[bool, typer.Option(help="replace an experiment already in --out")]
EXPERIMENT = Annotated[
    Path, typer.Option(help="experiment folder (its format: docs/guide/import-and-check.md)")
]
CHAIN_STEPS = Annotated[int, typer.Option(help="emcee steps per walker")]

#: The flag of each :class:`ModelOptions` field, in the order the commands list them.
MODEL_FLAGS = {
    "c1": C1,
    "c5": C5,
    "kappa": KAPPA,
    "radius": RADIUS,
    "steps": STEPS,
    "step_size": STEP_SIZE,
    "mesh": MESH,
    "mesh_from": MESH_FROM,
    "substeps": SUBSTEPS,
    "friction": FRICTION,
    "contact": CONTACT,
    "contact_order": CONTACT_ORDER,
    "contact_penalty": CONTACT_PENALTY,
    "fiber_stretch": FIBER_STRETCH,
    "specimen": SPECIMEN,
}


def model_options(*flags: str, **values: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Give a command the model flags ``flags`` in place of its ``model: ModelOptions`` parameter.

    Typer sees the flags (``--c1``, ``--radius``, ...) where ``model`` stands in the command's
    signature; the command gets one :class:`ModelOptions` built from them (:func:`option_group`).

    Parameters
    ----------
    *flags : str
        The :class:`ModelOptions` fields the command has flags for; none: all of them.
    **values
        A flag's default (a field in ``flags``), or the value of a field without a flag (e.g.
        ``substeps=2``); other fields keep :class:`ModelOptions`'s defaults.

    Returns
    -------
    Callable
        The decorator.
    """
    return option_group(ModelOptions, MODEL_FLAGS, "model", flags, values)
