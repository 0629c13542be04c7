"""``indent-studio verification-study``: the mesh study done as the V&V literature does it (a
family of systematically refined meshes, refined increments, observed orders and GCI), beside
``mesh-study``'s comparison of presets against one reference mesh."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from .. import forward, inference, studio  # lazy packages: a command imports what it runs
from ..atomic_write import strict_json
from ..forward.spec import SpecError
from .options import JSON, RADII, ModelOptions, err, fail, model_options, number_list, say
from .progress import step_progress


def parse_family(text: str) -> forward.MeshFamily:
    """'CXY x CZ : H0 : RATIO [: coreMM[xFRACTION]]' (e.g. '8x8:1.2:1.5' or '8x8:1.2:1.5:core8'):
    base cells along x (and y) and z, the base level's first cell (mm, both axes; along z only
    with a core), the refinement ratio, and a core of uniform cells MM wide along x and y holding
    FRACTION of their cells (0.5 unless given) that the contact's edge sweeps."""
    try:
        cells, h0, ratio, *core = text.split(":")
        cxy, cz = cells.lower().split("x")
        extra = {}
        if core:
            if len(core) > 1 or not core[0].lower().startswith("core"):
                raise ValueError("the fourth part is coreMM or coreMMxFRACTION")
            width, _, fraction = core[0][4:].lower().partition("x")
            extra = {"core_xy": float(width), "core_fraction": float(fraction or 0.5)}
        return forward.MeshFamily(int(cxy), int(cz), float(h0), float(h0), float(ratio), **extra)
    except ValueError as exc:
        raise ValueError(
            f"--family {text!r}: use CXYxCZ:H0:RATIO[:coreMM[xFRACTION]], e.g. 8x8:1.2:1.5 or "
            f"8x8:1.2:1.5:core8 ({exc})"
        ) from exc


def parse_points(text: str) -> list[tuple[float, float]]:
    """'c1:c5,c1:c5,...' in kPa."""
    try:
        return [(float(a), float(b)) for a, b in (p.split(":") for p in text.split(",") if p.strip())]
    except ValueError as exc:
        raise ValueError(f"--points {text!r}: use c1:c5 pairs, e.g. 3:540,11:330 ({exc})") from exc


FAMILY = Annotated[
    str, typer.Option(help="CXYxCZ:H0:RATIO[:coreMM[xFRACTION]], the base level, the ratio and a core")
]
LEVELS = Annotated[str, typer.Option(help="comma-separated levels (0 the coarsest)")]
POINTS = Annotated[str, typer.Option(help="c1:c5 pairs, kPa")]
SUBSTEP_COUNTS = Annotated[str, typer.Option(help="increments per step; all of them on the finest levels")]
SUBSTEP_LEVELS = Annotated[int, typer.Option(help="how many finest levels get every substep count")]
OUT_DIR = Annotated[Path, typer.Option(help="every run and study.json; a run already there is read back")]
FIGURE = Annotated[Path | None, typer.Option(help="PNG of the first case's convergence (log-log)")]
READING = Annotated[
    str,
    typer.Option(
        help="objective of the fitted (c1, c5): fit (DIC from 1.5 R, the studio's fits) or paper (from 1 R)"
    ),
]

FITTING_LEVEL = Annotated[
    int | None,
    typer.Option(help="level whose sensitivities fit every level's response (the finest by default)"),
]


@model_options("kappa", "steps", "step_size", "contact", "contact_order", "contact_penalty", "fiber_stretch")
def verification_study(
    family: FAMILY = "8x8:1.2:1.5",
    levels: LEVELS = "0,1,2,3",
    points: POINTS = "3:540,11:330,19:120",
    radii: RADII = "4.77,8",
    substeps: SUBSTEP_COUNTS = "1,2,4",
    substep_levels: SUBSTEP_LEVELS = 2,
    *,
    model: ModelOptions,
    out_dir: OUT_DIR = Path("runs/verification"),
    figure: FIGURE = None,
    reading: READING = "fit",
    fitting_level: FITTING_LEVEL = None,
    as_json: JSON = False,
) -> None:
    """Verification study (Roache's GCI, ASME V&V 20): observed orders, asymptotic range,
    extrapolated values and GCI of the force, the top field and the fit's (c1, c5) over a family of
    systematically refined meshes; resumable (run the same command again: finished runs are read
    back, a run stopped part way goes on from its last step)."""
    try:
        fam = parse_family(family)
        level_list = [int(v) for v in number_list(levels, "--levels")]
        sub = [int(v) for v in number_list(substeps, "--substeps")]
        pts, rad = parse_points(points), number_list(radii, "--radii")
        spec = model.replace(radius=rad[0] if rad else model.radius).spec()
        total = len(pts) * len(rad) * model.steps * (len(level_list) + (len(sub) - 1) * substep_levels)
        with step_progress(err, "verification study", total) as bar:
            study = inference.run_verification_study(
                spec,
                fam,
                level_list,
                points=pts,
                radii=rad,
                substeps=sub,
                substep_levels=substep_levels,
                out_dir=out_dir,
                progress=_steps_progress(bar),
                say=say,
                reading=reading,
                fitting_level=fitting_level,
            )
    except (SpecError, ValueError, forward.SimulationError, OSError) as exc:
        fail(str(exc), as_json)
    payload = study.to_dict() | {"study_file": str(Path(out_dir) / "study.json")}
    if figure is not None and study.cases:
        payload["figure"] = str(_save_figure(study.cases[0], figure))
    if as_json:
        print(strict_json(payload))
        return
    _print_study(study)
    if "figure" in payload:
        Console().print(f"figure: {payload['figure']}")


def _steps_progress(bar) -> Callable[[str, int, int, float], None]:
    """The study's progress on ``bar``: steps solved over every run, the last run's step and force."""
    done: dict[str, int] = {}

    def report(label: str, k: int, n: int, f: float) -> None:
        done[label] = done.get(label, 0) + 1
        bar.update(sum(done.values()), f"{label} step {k}/{n}: {f:.1f} mN")

    return report


def _save_figure(case: dict, path: Path) -> Path:
    """The convergence of one case (log-log) as a PNG at ``path``."""
    title = f"R = {case['radius']:g} mm, (c1, c5) = ({case['theta'][0]:g}, {case['theta'][1]:g}) kPa"
    fig = studio.figures.verification_figure(case, title=title)  # matplotlib: only for a figure
    return studio.figures.save_figure(fig, path)


def _print_study(study: inference.VerificationStudy) -> None:
    """Per case: each quantity's values, orders, asymptotic range, extrapolation and GCI; then the
    increments' study on the finest levels."""
    console = Console()
    for case in study.cases:
        table = Table(
            title=f"R = {case['radius']:g} mm, (c1, c5) = ({case['theta'][0]:g}, {case['theta'][1]:g}) kPa; "
            f"levels {', '.join(str(lv['nodes']) for lv in case['levels'])} nodes"
        )
        for col in (
            "quantity",
            "values (finest first)",
            "orders p",
            "asymptotic",
            "extrapolated",
            "GCI % per level",
        ):
            table.add_column(col, justify="right")
        for name, q in case["quantities"].items():
            table.add_row(
                name,
                ", ".join(f"{v:.5g}" for v in q["values"]),
                ", ".join(f"{p:.2f}" for p in q["orders"]),
                "yes" if q["asymptotic"] else "no",
                f"{q['extrapolated']:.5g}",
                ", ".join(f"{g:.2f}" for g in q["gci_pct"]),
            )
        console.print(table)
        for inc in case["increments"]:
            console.print(
                f"level {inc['level']}: substeps {inc['substeps']}, force at the deepest step "
                f"{', '.join(f'{f:.1f}' for f in inc['force_deepest_mN'])} mN, order {inc['order']:.2f}, "
                f"GCI {inc['gci_pct']:.3f} %",
                highlight=False,
            )


def register(app: typer.Typer) -> None:
    """Add ``verification-study`` to the studio's command line."""
    app.command("verification-study")(verification_study)
