"""Read back a FEBio run made elsewhere (its ``.log`` and the ``.feb`` it ran) as a result.

The result is the one :class:`forward.febio.runner.FebioSolver` would have returned for the same
model spec, equilibrium check included (:mod:`forward.febio.equilibrium`), without running
FEBio. The log must be of that spec: the block material's c1, c5 and k that FEBio echoes, the
indenter's starting height (block height + radius), the number of steps, the depth of every
step and the top-surface node ids are checked, and the first mismatch is named.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..result import SimulationResult
from ..solver import SimulationError
from ..spec import ModelSpec
from .equilibrium import DEFAULT_EQUILIBRIUM_TOLERANCE, EquilibriumTolerance
from .log import (
    FebioLog,
    FebioLogError,
    depth_reached,
    febio_result,
    must_point_rows,
    read_febio_log,
)
from .writer import INDENTER_DATA

_MATERIAL_SECTION = re.compile(r"MATERIAL DATA\s*\n=+\s*\n(.*?)\n\s*\n", re.S)
_PARAMETER = re.compile(r"^\s*(\w+) \.+ : (\S+)", re.M)
_ELAPSED = re.compile(r"Total elapsed time \.+ : \S+ \(([\d.eE+-]+) sec\)")
#: Relative agreement asked of the material parameters FEBio echoes (it prints about 6 digits).
PARAMETER_RTOL = 1e-5
#: Agreement asked of the indenter's depth at each step and of its starting height, mm.
DEPTH_ATOL_MM = 1e-6


class FebioRunError(SimulationError):
    """A read-back FEBio run that did not terminate normally (``partial`` holds its steps)."""


def logged_block_material(text: str) -> dict[str, float]:
    """The first material's numeric parameters as FEBio echoes them under MATERIAL DATA."""
    section = _MATERIAL_SECTION.search(text)
    if section is None:
        return {}
    values: dict[str, float] = {}
    for name, value in _PARAMETER.findall(section.group(1).split("---")[0]):
        try:
            values.setdefault(name, float(value))
        except ValueError:
            continue
    return values


def _check_material(path: Path, text: str, spec: ModelSpec) -> None:
    logged = logged_block_material(text)
    expected = {"c1": spec.material.c1, "c5": spec.material.c5, "k": spec.material.kappa}
    for name, value in expected.items():
        if name not in logged:
            raise FebioLogError(f"{path}: the log echoes no block material parameter {name!r}")
        if not np.isclose(logged[name], value, rtol=PARAMETER_RTOL, atol=0.0):
            raise FebioLogError(
                f"{path}: the run's {name} = {logged[name]:g} kPa, the spec's {value:g} kPa "
                f"(give the run's parameters, e.g. --c1/--c5/--kappa)"
            )


def _check_geometry(path: Path, log: FebioLog, result: SimulationResult, spec: ModelSpec) -> None:
    z0 = float(log.values[INDENTER_DATA][0, 0, 0])
    expected_z0 = spec.geometry.height + spec.indenter.radius
    if abs(z0 - expected_z0) > DEPTH_ATOL_MM:
        raise FebioLogError(
            f"{path}: the indenter starts at z = {z0:g} mm, the spec's block height + radius is "
            f"{expected_z0:g} mm (give the run's --radius)"
        )
    from_z = np.asarray(result.convergence["depth_from_z"])
    off = np.nonzero(np.abs(from_z - result.depth) > DEPTH_ATOL_MM)[0]
    if len(off):
        k = int(off[0])
        raise FebioLogError(
            f"{path}: step {k}: the indenter is {from_z[k]:g} mm deep, the spec's depth is "
            f"{result.depth[k]:g} mm (give the run's --step-size and --steps)"
        )
    if not np.all(np.isfinite(result.top_xyz)):
        raise FebioLogError(
            f"{path}: the log's top-surface nodes are not nodes of the spec's mesh "
            f"({spec.mesh.feb_file or spec.mesh.preset}); give the .feb that ran (--mesh-from)"
        )


def read_febio_run(
    log_path: str | Path,
    spec: ModelSpec,
    feb_file: str | Path | None = None,
    tolerance: EquilibriumTolerance = DEFAULT_EQUILIBRIUM_TOLERANCE,
) -> SimulationResult:
    """The FEBio run logged in ``log_path`` as the :class:`SimulationResult` of ``spec``.

    ``feb_file`` (recorded in the result) defaults to the spec's mesh file. Steps off
    equilibrium are flagged and NaN, as in a run. Raises :class:`FebioLogError` when the log is
    unreadable or not of ``spec`` (naming what differs) and :class:`FebioRunError` when FEBio
    did not terminate normally or the log holds fewer steps than the spec (the steps it holds
    are the error's ``partial``).
    """
    path = Path(log_path)
    log = read_febio_log(path)
    text = path.read_text(encoding="latin-1")
    _check_material(path, text, spec)
    feb = feb_file if feb_file is not None else spec.mesh.feb_file
    elapsed = _ELAPSED.search(text)
    steps = spec.protocol.steps
    result = febio_result(
        log,
        spec.to_dict(),
        feb_file=feb,
        steps=steps,
        wall_s=float(elapsed.group(1)) if elapsed else 0.0,
        tolerance=tolerance,
    )
    result.solver["read_back"] = True
    logged_steps = len(must_point_rows(log.times[INDENTER_DATA], None)) - 1
    if log.terminated == "normal" and logged_steps != steps:
        raise FebioLogError(
            f"{path}: the run has {logged_steps} steps, the spec {steps} (give the run's --steps)"
        )
    if log.terminated != "normal" or len(result.depth) != steps + 1:
        raise FebioRunError(
            f"{path}: {log.terminated} termination with {len(result.depth) - 1} of {steps} steps "
            f"(depth {depth_reached(log):.3f} mm); last lines:\n{log.last_lines()}",
            depth_reached(log),
            result,
        )
    _check_geometry(path, log, result, spec)
    return result
