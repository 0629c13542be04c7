"""The composite phantom as an experiment (paper 2.4.2, 3.3.1; Table 2's "Simulation" rows).

The phantom's FE model (fibers and matrix as two materials, :mod:`forward.composite_mesh`) is
indented with the paper's protocol; its indenter force and top-surface field become an experiment
folder in the lab format (DIC-like points over a field of view, noise, a registration error:
:func:`inference.experiment.synthetic.write_experiment_from_model`), which the studio's ``fit``
identifies with the homogeneous model, surrogate and all, as the paper did. There is no true
(c1, c5): experiment.json says so (``synthetic.theta`` null) and names the composite model.

:func:`~.composite_comparison.compare_with_homogeneous` (in
:mod:`~indentation_studio.inference.experiment.composite_comparison`, its names importable from
here too) puts the homogeneous model at a fitted (c1, c5) beside the composite: force against
depth and the top-surface field, where the fibers show.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...forward.result import SimulationResult
from ...forward.simulation_run import run_simulation
from ...forward.spec import Contact, Indenter, ModelSpec, Protocol
from .composite_comparison import CompositeComparison as CompositeComparison  # X as X: re-exported
from .composite_comparison import compare_with_fit as compare_with_fit
from .composite_comparison import compare_with_homogeneous as compare_with_homogeneous
from .composite_comparison import fitted_model as fitted_model
from .composite_comparison import top_fiber_bands as top_fiber_bands
from .folder import refuse_existing_experiment
from .synthetic import LAB_RECORDING, Recording, write_experiment_from_model

__all__ = [
    "CompositeComparison",
    "CompositeExperiment",
    "compare_with_fit",
    "compare_with_homogeneous",
    "composite_indentation",
    "experiment_from_composite",
    "fitted_model",
    "top_fiber_bands",
    "write_composite_experiment",
]

#: The result file a composite experiment folder keeps beside the experiment.
RESULT_FILE = "composite-result.npz"


def composite_spec(
    radius: float = 4.77,
    preset: str = "composite",
    steps: int = 28,
    step_size: float = 0.5,
    friction: float | None = None,
    *,
    contact: Contact | None = None,
) -> ModelSpec:
    """The phantom's indentation spec: its constituents (3.1) on the composite mesh ``preset``,
    the sphere of ``radius``, ``steps`` x ``step_size`` mm, the paper's stick (or Coulomb mu);
    ``contact``, when given, is the whole contact (e.g. the surface-integrated stick) and
    ``friction`` is not read."""
    return ModelSpec.composite_phantom(
        preset,
        indenter=Indenter(radius=radius),
        protocol=Protocol(steps=steps, step_size=step_size),
        contact=contact if contact is not None else Contact(friction=friction),
    )


def composite_indentation(
    out_dir: str | Path,
    radius: float = 4.77,
    preset: str = "composite",
    steps: int = 28,
    step_size: float = 0.5,
    friction: float | None = None,
    progress: Callable[[int, int, float], None] | None = None,
    say: Callable[[str], None] | None = None,
    *,
    contact: Contact | None = None,
    **experiment_options,
) -> tuple[SimulationResult, Path]:
    """Indent the composite phantom on the embedded solver and write the experiment folder from it.

    The result is kept in ``out_dir``/composite-result.npz; the experiment folder ``out_dir`` is
    written by :func:`experiment_from_composite`. A run that fails keeps its finished steps in
    composite-result.partial.npz.

    Parameters
    ----------
    out_dir : str or pathlib.Path
        The experiment folder.
    radius : float, default 4.77
        The indenter's radius, mm.
    preset : str, default "composite"
        The phantom's mesh preset (:func:`composite_spec`).
    steps : int, default 28
        Steps of the protocol.
    step_size : float, default 0.5
        Indentation per step, mm.
    friction : float, optional
        Coulomb's mu; None: the perfect stick.
    progress : callable, optional
        ``progress(step, steps, force)`` of the run.
    say : callable, optional
        Where messages go.
    contact : Contact, optional
        The whole contact (e.g. ``Contact(integration="surface", order=1)``); ``friction`` is then
        not read.
    **experiment_options
        Passed to :func:`experiment_from_composite` (``seed``, ``overwrite``, recording options).

    Returns
    -------
    result : SimulationResult
        The composite's result.
    experiment : pathlib.Path
        The experiment folder.

    Raises
    ------
    FileExistsError
        If an experiment is already in ``out_dir`` (unless ``overwrite``).
    SimulationError
        If the run fails.
    """
    out = Path(out_dir)
    refuse_existing_experiment(out, overwrite=bool(experiment_options.get("overwrite", False)))
    out.mkdir(parents=True, exist_ok=True)
    spec = composite_spec(radius, preset, steps, step_size, friction, contact=contact)
    run = run_simulation(spec, out / RESULT_FILE, progress=progress, say=say)
    return run.result, experiment_from_composite(run.result, out, **experiment_options)


@dataclass
class CompositeExperiment:
    """A composite indentation written as an experiment folder.

    Attributes
    ----------
    result : SimulationResult
        The composite's result.
    experiment : pathlib.Path
        The experiment folder.
    result_file : pathlib.Path
        The result file it came from.
    wall_s : float
        Wall time, s.
    """

    result: SimulationResult
    experiment: Path
    result_file: Path
    wall_s: float

    def to_dict(self) -> dict[str, Any]:
        """The experiment as ``composite indent --json`` prints it.

        Returns
        -------
        dict
            The folder, the result file, depths, forces, the mesh, Newton iterations and the
            simulation's and the whole run's wall times.
        """
        result = self.result
        return {
            "experiment": str(self.experiment),
            "result_file": str(self.result_file),
            "depth_mm": result.depth.tolist(),
            "force_mN": result.force.tolist(),
            "mesh": result.solver.get("mesh"),
            "newton_iterations": result.newton_iterations,
            "simulation_wall_s": result.wall_s,
            "wall_s": self.wall_s,
        }


def write_composite_experiment(
    out_dir: str | Path,
    *,
    from_result: str | Path | None = None,
    radius: float = 4.77,
    preset: str = "composite",
    steps: int = 28,
    step_size: float = 0.5,
    friction: float | None = None,
    contact: Contact | None = None,
    progress: Callable[[int, int, float], None] | None = None,
    say: Callable[[str], None] | None = None,
    seed: int = 0,
    overwrite: bool = False,
) -> CompositeExperiment:
    """Write the experiment folder ``out_dir`` of a composite indentation, run now or read from a file.

    Run now by :func:`composite_indentation`, or written from the result file ``from_result`` (no
    run).

    Parameters
    ----------
    out_dir : str or Path
        The experiment folder (a run keeps its result in it).
    from_result : str or Path, optional
        A composite result (.npz) to write the experiment from instead of running.
    radius, preset, steps, step_size, friction, contact
        The run's model (:func:`composite_spec`).
    progress, say
        The run's progress and messages (:func:`composite_indentation`).
    seed : int
        The noise seed.
    overwrite : bool
        Replace an experiment already in ``out_dir``.

    Returns
    -------
    CompositeExperiment
        The result, the folder and the result file.
    """
    t0 = time.perf_counter()
    if from_result is not None:
        result = SimulationResult.load(from_result)
        folder = experiment_from_composite(result, out_dir, seed=seed, overwrite=overwrite)
        return CompositeExperiment(result, folder, Path(from_result), time.perf_counter() - t0)
    result, folder = composite_indentation(
        out_dir,
        radius,
        preset,
        steps,
        step_size,
        friction,
        progress=progress,
        say=say,
        contact=contact,
        seed=seed,
        overwrite=overwrite,
    )
    return CompositeExperiment(result, folder, Path(out_dir) / RESULT_FILE, time.perf_counter() - t0)


def experiment_from_composite(
    result: SimulationResult | str | Path,
    out_dir: str | Path,
    *,
    recording: Recording = LAB_RECORDING,
    seed: int = 0,
    overwrite: bool = False,
) -> Path:
    """Write the experiment folder of a composite indentation: its force and top field as a lab records them.

    Parameters
    ----------
    result : SimulationResult, str or pathlib.Path
        The composite's result, or its .npz.
    out_dir : str or pathlib.Path
        The experiment folder.
    seed : int, default 0
        The noise seed.
    overwrite : bool, default False
        Replace an experiment already there.
    recording : Recording, default LAB_RECORDING
        How the run is recorded (:class:`~indentation_studio.inference.experiment.synthetic.Recording`).

    Returns
    -------
    pathlib.Path
        The experiment folder.

    Raises
    ------
    ValueError
        If the result is not of the composite phantom, or has non-finite forces.
    FileExistsError
        If an experiment is already there (unless ``overwrite``).
    """
    if not isinstance(result, SimulationResult):
        result = SimulationResult.load(result)
    if "composite" not in result.spec:
        raise ValueError("not a composite phantom's result (its spec has no composite materials)")
    out = Path(out_dir)
    refuse_existing_experiment(out, overwrite=overwrite)
    spec = ModelSpec.from_dict(result.spec)
    if not np.all(np.isfinite(result.force)):
        raise ValueError("the composite result has non-finite forces")
    source = {
        "solver": result.solver.get("name"),
        "mesh": result.solver.get("mesh"),
        "version": result.solver.get("version"),
        "note": "the composite phantom (fibers and matrix): no homogeneous (c1, c5) made these data",
    }
    return write_experiment_from_model(
        result.force[1:],
        result.displacement[1:],
        result.top_xyz,
        out,
        radius=spec.indenter.radius,
        step_size=spec.protocol.step_size,
        truth=None,
        model=result.spec,
        recording=recording,
        seed=seed,
        source=source,
    )
