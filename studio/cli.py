"""The ``indent-studio`` command line (typer).

Contract (docs/architecture.md, "The CLI contract"): every command takes ``--json`` and then prints exactly one JSON object
on stdout; progress and logs go to stderr.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from pathlib import Path
from typing import Annotated, Any

import click
import typer
from rich.console import Console
from rich.table import Table
from typer.core import TyperGroup

from .. import forward  # lazy: a command imports what it runs
from ..atomic_write import strict_json
from ..forward.spec import SpecError
from .budget_cli import register_budget_commands
from .campaign_cli import campaign_app
from .composite_cli import composite_app
from .design_cli import design_app
from .help_text import COMMAND_ORDER, place_commands, tidy_help
from .import_cli import register as register_import
from .inference_cli import register as register_inference
from .options import (
    CHAIN_STEPS,
    JOBS,
    JSON,
    MODEL_FLAGS,
    SOLVER,
    ModelOptions,
    SolverName,
    err,
    fail,
    model_options,
    say,
)
from .own_test_cli import own_test_app
from .progress import step_progress
from .surrogate_cli import surrogate_app
from .verification_cli import register as register_verification

#: What click (and the copy of click typer 0.2x carries, ``typer._click``, whose exceptions are not
#: click's) raises for a usage error or an exit: left to typer, which prints the command's usage
#: line, the error ("Missing option '--experiment'", "No such command 'fitt'. Did you mean 'fit'?")
#: and exits with code 2 (usage) as click does. The copy's base class is found through a public
#: name, ``typer.BadParameter``.
CLICK_EXITS = tuple(
    {
        typer.Exit,
        typer.Abort,
        click.exceptions.Exit,
        click.ClickException,
        click.exceptions.Abort,
        *(c for c in typer.BadParameter.__mro__ if c.__name__ in ("ClickException", "Exit", "Abort")),
    }
)


class StudioGroup(TyperGroup):
    """The command group with the JSON error contract's safety net: a library error no command
    caught (a bug, or a file damaged in a way no loader foresaw) becomes the studio's own error,
    one line on stderr and, with --json, ``{"error": ...}`` on stdout, exit code 1: never a
    traceback. ``INDENT_STUDIO_TRACEBACK=1`` shows the traceback instead (for a bug report). Its
    ``--help`` lists the commands in a user's order (``help_text.COMMAND_PANELS``)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        """The commands in the order of their panels (``help_text.COMMAND_ORDER``), any other after."""
        rank = {name: k for k, name in enumerate(COMMAND_ORDER)}
        return sorted(super().list_commands(ctx), key=lambda name: rank.get(name, len(rank)))

    def invoke(self, ctx: click.Context) -> Any:
        raw = [*getattr(ctx, "_protected_args", []), *ctx.args, *sys.argv[1:]]
        try:
            return super().invoke(ctx)
        except CLICK_EXITS:
            raise
        except BrokenPipeError:  # the reader of stdout stopped (| head): not an error of the studio's
            with contextlib.suppress(OSError, ValueError):  # nothing more to write there, even at exit
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            raise typer.Exit(0) from None
        except Exception as exc:
            if os.environ.get("INDENT_STUDIO_TRACEBACK"):
                raise
            fail(
                f"{type(exc).__name__}: {exc} (unexpected: set INDENT_STUDIO_TRACEBACK=1 to see where)",
                "--json" in raw,
            )


app = typer.Typer(
    cls=StudioGroup,
    help="Indentation Studio: identify (c1, c5) of soft tissue from indentation force and 3D-DIC.",
    no_args_is_help=True,
    add_completion=False,
)


@app.callback()
def _headless() -> None:
    """Figures are written to files from the command line: matplotlib's Agg backend, set here
    (the entry point) and nowhere else, so notebooks keep their inline backend. Through
    ``MPLBACKEND`` when matplotlib is not imported yet: importing it here cost every command
    0.15 to 0.2 s, most of which never draw (docs/validation/solver-and-speed.md, "Cold start")."""
    if "matplotlib" in sys.modules:
        sys.modules["matplotlib"].use("Agg")
    else:
        os.environ["MPLBACKEND"] = "Agg"


app.add_typer(campaign_app, name="campaign")
app.add_typer(composite_app, name="composite")
register_budget_commands(design_app)
app.add_typer(design_app, name="design")
app.add_typer(surrogate_app, name="surrogate")
app.add_typer(own_test_app, name="test")
register_inference(app)
register_import(app)
register_verification(app)


SENSITIVITIES = Annotated[
    bool, typer.Option(help="also d(force, displacement)/d(c1, c5) (and d/d(mu) with --friction)")
]
RESULT_OUT = Annotated[Path | None, typer.Option(help="result file (.npz); default under runs/simulations/")]
VTU = Annotated[
    Path | None, typer.Option(help="also write the whole block per step as VTU (+ .pvd) for ParaView here")
]
RESTART = Annotated[
    bool,
    typer.Option(
        help="keep the run's state after every step in <out>.checkpoint.pkl (as FEBio's restart dump) "
        "and resume from it when it exists: a long run stopped part way goes on from its last step"
    ),
]
FROM_LOG = Annotated[
    Path | None,
    typer.Option(
        help="read back this FEBio log instead of running FEBio (implies --solver febio; the model "
        "options must be the run's; --mesh-from defaults to the .feb beside the log)"
    ),
]


@app.command()
@model_options()
def simulate(
    model: ModelOptions,
    solver: SOLVER = SolverName.embedded,
    sensitivities: SENSITIVITIES = False,
    out: RESULT_OUT = None,
    vtu: VTU = None,
    from_log: FROM_LOG = None,
    restart: RESTART = False,
    as_json: JSON = False,
) -> None:
    """One indentation simulation (default: the paper's baseline, R = 4.77 mm, 28 x 0.5 mm).

    ``--solver febio`` runs the same model on FEBio 4 (FEBIO_PATH or PATH); its .feb, log and
    plot file stay in a folder beside the result file. Steps FEBio accepted off equilibrium are
    named on stderr and their forces are NaN (null in --json)."""
    if from_log is not None:
        solver, model = SolverName.febio, _model_of_log(model, from_log, as_json)
    unit = "mm" if solver == SolverName.febio else "mN"
    with step_progress(err, f"simulate ({solver.value})", model.steps) as bar:
        try:
            run = forward.run_simulation(
                model.spec(),
                out,
                solver=solver.value,
                sensitivities=sensitivities,
                vtu=vtu,
                from_log=from_log,
                restart=restart,
                progress=lambda k, n, v: bar.update(k, f"{v:.2f} {unit}"),
                say=say,
            )
        except _simulation_errors() as exc:
            fail(str(exc), as_json)
    for note in run.warnings:
        err.print(f"[bold yellow]warning:[/] {note}", soft_wrap=True, highlight=False)
    if as_json:
        print(strict_json(run.to_dict()))
        return
    _print_simulation(run, model, solver.value)


def _simulation_errors() -> tuple[type[Exception], ...]:
    """What a simulation raises for bad input or a run that does not converge (a clear error, no
    traceback); a function, so that importing the command line does not import the solver."""
    return (SpecError, ValueError, OSError, forward.SimulationError, forward.febio.FebioLogError)


def _model_of_log(model: ModelOptions, from_log: Path, as_json: bool) -> ModelOptions:
    """The model of a FEBio run read back from its log: its mesh is the .feb beside the log unless
    ``--mesh-from`` names one."""
    model = model.replace(mesh_from=model.mesh_from or forward.feb_beside_log(from_log))
    if model.mesh_from is None:
        fail(
            f"--from-log {from_log}: no {from_log.with_suffix('.feb').name} beside it; give --mesh-from",
            as_json,
        )
    return model


def _print_simulation(run: forward.SimulationRun, model: ModelOptions, solver: str) -> None:
    """A simulation's forces per depth as a table, and its wall time and result file."""
    result, mesh = run.result, run.to_dict()["mesh"]["source"]
    table = Table(
        title=f"c1 = {model.c1:g} kPa, c5 = {model.c5:g} kPa, R = {model.radius:g} mm, {solver}, mesh {mesh}"
    )
    table.add_column("depth [mm]", justify="right")
    table.add_column("force [mN] (whole specimen)", justify="right")
    for d, f in zip(result.depth, result.force, strict=True):
        table.add_row(f"{d:.2f}", f"{f:.2f}")
    Console().print(table)
    Console().print(
        f"wall time {run.wall_s:.2f} s, {result.newton_iterations} Newton iterations, result: {run.result_file}"
    )


@app.command("export-feb")
@model_options(*(f for f in MODEL_FLAGS if f != "substeps"), substeps=2)
def export_feb(
    out: Annotated[Path, typer.Option(help="the .feb file to write")],
    model: ModelOptions,
    as_json: JSON = False,
) -> None:
    """Write the model as a FEBio 4.0 .feb to run with febio4 or open in FEBio Studio
    (``--friction MU``: sliding-elastic with that friction coefficient, 0 frictionless)."""
    try:
        path = forward.write_feb(model.spec(), out)
    except (SpecError, ValueError, OSError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json({"feb_file": str(path), "log_file": str(path.with_suffix(".log"))}))
    else:
        Console().print(
            f"wrote {path}: run it with  febio4 -i {path.name}  (data log: {path.with_suffix('.log').name})"
        )


@app.command("mesh-study")
@model_options("c1", "c5", "kappa", "radius", "steps", "step_size", "substeps", c1=9.4, c5=321.0)
def mesh_study(
    presets: Annotated[
        str, typer.Option(help="comma-separated presets to compare with 'reference'")
    ] = "coarse,default,fine",
    reference: Annotated[str, typer.Option(help="the 'ground truth' preset")] = "reference",
    *,
    model: ModelOptions,
    out_dir: Annotated[
        Path | None,
        typer.Option(
            help="keep each mesh's result file here; a file already there for the same spec is reused"
        ),
    ] = None,
    as_json: JSON = False,
) -> None:
    """Mesh convergence (eq. 1a, 1b) of presets against a reference mesh (paper: c1 = 9.4, c5 = 321).
    With --out-dir, a mesh already solved there for the same model spec is read back instead of
    solved again (the reference takes many minutes)."""
    names = [p.strip() for p in presets.split(",") if p.strip()]
    with step_progress(err, "mesh study", model.steps * (len(names) + 1)) as bar:
        done = {name: 0 for name in [*names, reference]}

        def report(mesh: str, k: int, n: int, f: float) -> None:
            done[mesh] = k
            bar.update(sum(done.values()), f"{mesh}: {f:.1f} mN")

        try:
            spec = model.replace(mesh=reference).spec()
            rows = forward.convergence_study(spec, names, reference, out_dir, report, say)
        except (SpecError, ValueError, forward.SimulationError) as exc:
            fail(str(exc), as_json)
    if as_json:
        nodes = forward.MESH_PRESETS[reference].node_count()
        print(strict_json({"reference": reference, "reference_nodes": nodes, "rows": rows}))
        return
    _print_mesh_study(rows, reference)


def _print_mesh_study(rows: list[dict[str, Any]], reference: str) -> None:
    """The mesh study's rows as a table."""
    table = Table(title=f"mesh convergence against '{reference}' (eq. 1a, 1b)")
    columns = (
        "preset",
        "nodes",
        "E_f (eq. 1a) %",
        "||dF||/||F|| %",
        "E_u contact nodes %",
        "E_u whole top %",
        "wall s",
    )
    for col in columns:
        table.add_column(col, justify="right")
    for r in rows:
        table.add_row(
            r["preset"],
            str(r["nodes"]),
            f"{r['E_f_pct']:.3f}",
            f"{r['E_f_rel_pct']:.2f}",
            f"{r['E_u_contact_pct']:.2f} ({r['contact_nodes']})",
            f"{r['E_u_pct']:.2f}",
            f"{r['wall_s']:.1f}",
        )
    Console().print(table)


@app.command("demo")
def demo(
    name: Annotated[str, typer.Option(help="campaign and report name under runs/")] = "demo",
    full: Annotated[bool, typer.Option(help="the paper's 775-point grid instead of a 9 x 9 one")] = False,
    jobs: JOBS = 0,
    posterior_steps: CHAIN_STEPS = 1500,
    as_json: JSON = False,
) -> None:
    """The paper's results from nothing, on the embedded solver: campaign, surrogates, Table 1,
    Fig. 8, indenter comparison, the fit of the shipped example with posterior and confirmation,
    and an HTML report in runs/<name>/report/."""
    from .demo import run_demo

    t0 = time.perf_counter()
    try:
        report = run_demo(
            name, full, jobs, posterior_steps=posterior_steps, say=lambda m: err.print(m, highlight=False)
        )
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json({"report": str(report), "wall_s": time.perf_counter() - t0}))
        return
    Console().print(f"report: {report} ({time.perf_counter() - t0:.0f} s)")


tidy_help(app)  # every command above is registered: plain help texts with their guide page
place_commands(app)  # and the panels of --help, in a user's order


def main() -> None:  # pragma: no cover
    sys.exit(app())


if __name__ == "__main__":  # pragma: no cover
    main()
