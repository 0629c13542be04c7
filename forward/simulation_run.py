"""One simulation as the command line runs it: on the embedded solver or FEBio (or read back from
a FEBio log), the result saved, the steps finished before a failure kept, and optionally every step
of the whole block as VTU for ParaView."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from .febio.equilibrium import equilibrium_notes
from .febio.readback import read_febio_run
from .febio.runner import FebioSolver
from .result import SimulationResult
from .solver import EmbeddedSolver, SimulationError
from .spec import ModelSpec

__all__ = ["SimulationRun", "run_simulation"]

SOLVERS = ("embedded", "febio")


@dataclass
class SimulationRun:
    """The result, where it was written, the VTU series (if asked for) and warnings to show."""

    result: SimulationResult
    result_file: Path
    vtu_series: Path | None
    warnings: list[str]


def run_simulation(
    spec: ModelSpec,
    out: str | Path,
    *,
    solver: str = "embedded",
    sensitivities: bool = False,
    vtu: str | Path | None = None,
    from_log: str | Path | None = None,
    progress: Callable[[int, int, float], None] | None = None,
    say: Callable[[str], None] | None = None,
) -> SimulationRun:
    """Solve ``spec`` on ``solver`` ('embedded' or 'febio'; ``from_log`` reads an existing FEBio run
    back instead) and write the result to ``out``. ``progress(step, steps, value)`` gets the force
    (embedded) or the depth (FEBio). A failed simulation keeps its finished steps in
    ``<out>.partial.npz`` and raises :class:`SimulationError` naming the depth reached."""
    out = Path(out)
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; use one of {', '.join(SOLVERS)}")
    if (solver == "febio" or from_log is not None) and (sensitivities or vtu is not None):
        raise ValueError(
            "--sensitivities and --vtu need the embedded solver (FEBio writes its own .xplt for FEBio Studio)"
        )
    engine = None
    try:
        if from_log is not None:
            result = read_febio_run(Path(from_log), spec)
        elif solver == "febio":
            engine = FebioSolver(spec, workdir=out.with_name(out.stem + ".febio"))
            result = engine.run(progress=progress)
        else:
            engine = EmbeddedSolver(spec)
            result = engine.run(sensitivities=sensitivities, progress=progress, full_field=vtu is not None)
    except SimulationError as exc:
        if exc.partial is not None and len(exc.partial.depth) > 1:
            partial = exc.partial.save(out.with_name(out.stem + ".partial.npz"))
            if say is not None:
                say(f"steps completed before the failure are kept in {partial}")
        raise
    path = result.save(out)
    pvd = None
    if vtu is not None:
        from .vtu_export import write_vtu_series

        pvd = write_vtu_series(result, engine.mesh, vtu)
    return SimulationRun(result, path, pvd, list(equilibrium_notes(result)))
