"""One simulation as the command line runs it: on the embedded solver or FEBio (or read back from
a FEBio log), the result saved, the steps finished before a failure kept, and optionally every step
of the whole block as VTU for ParaView."""

from __future__ import annotations

import math
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .febio.equilibrium import equilibrium_notes
from .febio.readback import read_febio_run
from .febio.runner import FebioSolver
from .result import SimulationResult
from .solver import EmbeddedSolver, SimulationError
from .spec import DEFAULT_CONTACT_PENALTY, ModelSpec
from .vtu_export import write_vtu_series

__all__ = [
    "SimulationRun",
    "default_result_file",
    "feb_beside_log",
    "run_simulation",
    "termination_as_interrupt",
]

SOLVERS = ("embedded", "febio")


@dataclass
class SimulationRun:
    """One simulation run: the result, where it was written, and what to tell the user.

    Attributes
    ----------
    result : SimulationResult
        The result.
    result_file : pathlib.Path
        Where it was written.
    vtu_series : pathlib.Path or None
        The VTU series' .pvd, if asked for.
    warnings : list of str
        Warnings to show (steps off equilibrium).
    wall_s : float
        Wall time of the run, s.
    """

    result: SimulationResult
    result_file: Path
    vtu_series: Path | None
    warnings: list[str]
    wall_s: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """The run as the command line's ``simulate --json`` prints it.

        Returns
        -------
        dict
            Depths (mm), whole-specimen forces (mN; a step off equilibrium: None), wall time,
            Newton iterations, the result file, solver and mesh, the VTU series, the depths off
            equilibrium and FEBio's rerun record.
        """
        result, mesh = self.result, self.result.spec.get("mesh", {})
        return {
            "depth_mm": result.depth.tolist(),
            "force_mN": [float(f) if math.isfinite(f) else None for f in result.force],
            "force_is": "whole specimen (4 x quarter model)",
            "wall_s": self.wall_s,
            "newton_iterations": result.newton_iterations,
            "result_file": str(self.result_file),
            "solver": result.solver["name"],
            "mesh": result.solver.get("mesh", {"source": str(mesh.get("feb_file") or mesh.get("preset"))}),
            "vtu_series": str(self.vtu_series) if self.vtu_series else None,
            "off_equilibrium_depths_mm": result.off_equilibrium_depths,
            "febio_rerun": result.solver.get("rerun"),
        }


def default_result_file(spec: ModelSpec, solver: str = "embedded") -> Path:
    """Where a simulation's result goes unless told: a file under ``runs/simulations/``.

    It is named by its material, radius, contact (runs with another contact kept apart), mesh and
    solver.

    Parameters
    ----------
    spec : ModelSpec
        The model.
    solver : str
        'embedded' or 'febio'.

    Returns
    -------
    Path
        ``runs/simulations/c1=.._c5=.._R=..[_mu=..][_surface<order>][_penalty=..]_<mesh>_<solver>.npz``
        (the penalty where a penalty contact's is not the default).
    """
    tag = Path(spec.mesh.feb_file).stem if spec.mesh.feb_file else spec.mesh.preset
    mu = spec.contact.friction
    contact = "" if mu is None else f"_mu={mu:g}"
    if spec.contact.integration == "surface":
        contact += f"_surface{spec.contact.order}"
    if spec.contact.penalised and spec.contact.penalty != DEFAULT_CONTACT_PENALTY:
        contact += f"_penalty={spec.contact.penalty:g}"
    m = spec.material
    return (
        Path("runs/simulations")
        / f"c1={m.c1:g}_c5={m.c5:g}_R={spec.indenter.radius:g}{contact}_{tag}_{solver}.npz"
    )


def feb_beside_log(log: str | Path) -> Path | None:
    """The .feb file beside a FEBio log (the run's model), or None if there is none.

    Parameters
    ----------
    log : str or Path
        A FEBio log file.

    Returns
    -------
    Path or None
        ``<log>.feb`` if that file exists.
    """
    feb = Path(log).with_suffix(".feb")
    return feb if feb.is_file() else None


@contextmanager
def termination_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises KeyboardInterrupt as Ctrl-C does.

    So a run killed by a scheduler or ``kill`` can keep its finished steps; the previous handler is
    restored after. Outside the main thread (where signals cannot be handled) it does nothing.

    Yields
    ------
    None
        The block runs with SIGTERM as an interrupt.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run_simulation(
    spec: ModelSpec,
    out: str | Path | None = None,
    *,
    solver: str = "embedded",
    sensitivities: bool = False,
    vtu: str | Path | None = None,
    from_log: str | Path | None = None,
    restart: bool = False,
    progress: Callable[[int, int, float], None] | None = None,
    say: Callable[[str], None] | None = None,
) -> SimulationRun:
    """Solve ``spec`` and write the result: what ``indent-studio simulate`` does.

    A failed simulation keeps its finished steps in ``<out>.partial.npz``, and so does an embedded
    run stopped by Ctrl-C or SIGTERM (:func:`termination_as_interrupt`) before it re-raises.

    Parameters
    ----------
    spec : ModelSpec
        The model.
    out : str or pathlib.Path, optional
        The result file; default :func:`default_result_file`.
    solver : {"embedded", "febio"}, default "embedded"
        The FE solver.
    sensitivities : bool, default False
        Solve for the exact sensitivities too (embedded solver).
    vtu : str or pathlib.Path, optional
        A folder for a VTU series of every node's displacement (embedded solver).
    from_log : str or pathlib.Path, optional
        Read an existing FEBio run back instead of solving.
    restart : bool, default False
        Keep the embedded run's state after every step in ``<out>.checkpoint.pkl`` and resume
        from it when it exists (:meth:`EmbeddedSolver.run`'s ``checkpoint``); it is deleted once
        the result is written.
    progress : callable, optional
        ``progress(step, steps, value)``: the force (embedded) or the depth (FEBio).
    say : callable, optional
        Where to say that the steps of a failed run are kept.

    Returns
    -------
    SimulationRun
        The result, its file, the VTU series, warnings and wall time.

    Raises
    ------
    ValueError
        If the solver is unknown, or sensitivities or VTU are asked of FEBio.
    SimulationError
        If the simulation fails; names the depth reached.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> run = ins.forward.run_simulation(ins.ModelSpec(), "out.npz")  # doctest: +SKIP
    >>> run.result.force[-1]  # whole specimen, mN  # doctest: +SKIP
    """
    t0 = time.perf_counter()
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; use one of {', '.join(SOLVERS)}")
    if (solver == "febio" or from_log is not None) and (sensitivities or vtu is not None or restart):
        raise ValueError(
            "--sensitivities, --vtu and --restart need the embedded solver (FEBio writes its own "
            ".xplt for FEBio Studio)"
        )
    out = (
        Path(out)
        if out is not None
        else default_result_file(spec, "febio" if from_log is not None else solver)
    )
    engine = None
    checkpoint = out.with_name(out.stem + ".checkpoint.pkl") if restart else None
    try:
        if from_log is not None:
            result = read_febio_run(Path(from_log), spec)
        elif solver == "febio":
            engine = FebioSolver(spec, workdir=out.with_name(out.stem + ".febio"))
            result = engine.run(progress=progress)
        else:
            engine = EmbeddedSolver(spec)
            with termination_as_interrupt():
                result = engine.run(
                    sensitivities=sensitivities,
                    progress=progress,
                    full_field=vtu is not None,
                    checkpoint=checkpoint,
                )
    except (SimulationError, KeyboardInterrupt) as exc:
        kept = getattr(exc, "partial", None)
        if kept is not None and len(kept.depth) > 1:
            partial = kept.save(out.with_name(out.stem + ".partial.npz"))
            if say is not None:
                what = "the failure" if isinstance(exc, SimulationError) else "the interruption"
                say(f"steps completed before {what} are kept in {partial}")
        raise
    path = result.save(out)
    if checkpoint is not None:
        checkpoint.unlink(missing_ok=True)
    pvd = None
    if vtu is not None:
        pvd = write_vtu_series(result, engine.mesh, vtu)
    return SimulationRun(result, path, pvd, list(equilibrium_notes(result)), time.perf_counter() - t0)
