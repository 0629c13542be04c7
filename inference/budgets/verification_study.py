"""A verification study of the forward model, as the V&V literature does it (Roache's GCI, ASME
V&V 20): a family of systematically refined meshes (:class:`forward.convergence.mesh_family.MeshFamily`) and
refined increments, solved at a few parameter points and radii; for each quantity the observed
order, whether the levels are in the asymptotic range, the extrapolated value and the GCI
(:mod:`forward.convergence.gci`).

Quantities, for each (point, radius) (read by :mod:`inference.budgets.study_quantities`):

* the indenter force at 2, 7 and 14 mm (those of the protocol's depths that it reaches);
* the top field at the deepest step at rings of 1, 1.5, 2 and 3 R from the axis: uz and ux on the
  x axis (across the fibers), uy on the y axis (along them);
* the parameter bias: the (c1, c5) that the studio's default objective (eq. 4, 5, the paper's
  weights, a 25 mm field of view) fits to each level's noise-free response. The fitting model is
  the finest level at the true parameters with its exact sensitivities, and the fit is its
  Gauss-Newton step in log theta (first order in the response's difference, which is a few % at
  most). Its value on the finest level is the truth itself; the sequence over the levels is a
  functional of the response that converges like it, so its order, its extrapolated value and
  each level's GCI say how far a fit made with that level's model would move on a converged one.
  The Jacobian may come from a coarser level (``fitting_level``, e.g. the high-fidelity level 3
  when level 4 is added), interpolated at the finest level's top nodes: the finest level is then
  solved without sensitivities, about a quarter of their cost, and the objective (its nodes, its
  weights) stays the finest level's, so the fitted values change only to second order (the
  response's difference times the Jacobians' difference between the two levels).

Every run is kept in ``out_dir`` (one ``.npz`` per level, point, radius and substep count) and read
back when the same spec and mesh are asked for again, so a study killed half-way (it is hours of
CPU at paper scale) resumes where it stopped.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ... import __version__
from ...atomic_write import atomic_write_json
from ...design.objective import PAPER_WEIGHTS
from ...forward.convergence.gci import ConvergenceOfQuantity, observed_order, study_quantity
from ...forward.convergence.mesh_family import MeshFamily
from ...forward.result import SimulationResult
from ...forward.solver import EmbeddedSolver
from ...forward.spec import Indenter, ModelSpec
from .study_quantities import (
    FIT_FIELD_OF_VIEW,
    FORCE_DEPTHS,
    field_quantities,
    parameter_bias,
    step_at,
)

__all__ = ["VerificationStudy", "run_verification_study"]


@dataclass
class VerificationStudy:
    """The verification study's tables: one entry per (radius, point).

    Each entry holds each quantity's convergence, the costs of every level, and the increments'
    study on the finest levels.

    Attributes
    ----------
    family : MeshFamily
        The refined meshes.
    levels : tuple of int
        The levels solved, finest first.
    cases : list of dict
        One per (radius, point).
    inputs : dict
        The study's inputs (model, points, radii, substeps, weights, field of view, solver).
    """

    family: MeshFamily
    levels: tuple[int, ...]  # finest first
    cases: list[dict[str, Any]] = field(default_factory=list)
    inputs: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The study as ``study.json`` records it.

        Returns
        -------
        dict
            Schema, code version, the family, levels, inputs and cases.
        """
        return {
            "schema": "indentation-studio/verification-study/1",
            "code_version": __version__,
            "family": self.family.to_dict() | {"name": self.family.name},
            "levels": list(self.levels),
            "inputs": self.inputs,
            "cases": self.cases,
        }


def _solve_or_reuse(
    spec: ModelSpec,
    family: MeshFamily,
    level: int,
    path: Path,
    *,
    sensitivities: bool,
    progress: Callable[[int, int, float], None] | None,
    say: Callable[[str], None] | None,
) -> SimulationResult:
    """``spec`` on the family's ``level``, read back from ``path`` when it holds the same spec on
    the same mesh (and sensitivities where asked for), else solved and kept there (resumed from
    ``<path stem>.checkpoint.pkl`` when an earlier study was stopped mid-run)."""
    mesh = family.mesh(level, spec.geometry)
    if path.is_file():
        try:
            old = SimulationResult.load(path)
        except ValueError:
            old = None
        if (
            old is not None
            and old.spec == spec.to_dict()
            and old.solver.get("mesh", {}).get("nodes") == mesh.n_nodes
            and old.solver.get("mesh", {}).get("source") == mesh.source
            and (old.force_sensitivity is not None or not sensitivities)
        ):
            if say is not None:
                say(f"{path.name}: read back (same spec and mesh)")
            return old
    # a level-4 run outlasts a session: its steps are kept as they finish and a study run again
    # resumes it (EmbeddedSolver.run's checkpoint)
    restart = path.with_name(path.stem + ".checkpoint.pkl")
    result = EmbeddedSolver(spec, mesh=mesh).run(
        sensitivities=sensitivities, progress=progress, checkpoint=restart
    )
    result.save(path)
    restart.unlink(missing_ok=True)
    return result


def _case(
    spec: ModelSpec,
    family: MeshFamily,
    levels: Sequence[int],
    folder: Path,
    *,
    substeps: Sequence[int],
    substep_levels: int,
    progress: Callable[[str, int, int, float], None] | None,
    say: Callable[[str], None] | None,
    reading: str,
    fitting_level: int,
) -> dict[str, Any]:
    """One (point, radius): every level solved (the fitting level with sensitivities), the
    quantities' convergence, the costs, and the increments' study on the finest levels."""
    radius = spec.indenter.radius
    runs: dict[tuple[int, int], SimulationResult] = {}
    for level in levels:
        for n in substeps if level in levels[:substep_levels] else substeps[:1]:
            at = replace(spec, solver=replace(spec.solver, substeps=n))
            label = f"L{level}-s{n}"
            report = None if progress is None else (lambda k, m, f, lab=label: progress(lab, k, m, f))
            runs[(level, n)] = _solve_or_reuse(
                at,
                family,
                level,
                folder / f"{label}.npz",
                sensitivities=(level == fitting_level and n == substeps[0]),
                progress=report,
                say=say,
            )
    base = [runs[(level, substeps[0])] for level in levels]
    sizes = [family.size(level, spec.geometry) for level in levels]
    values: dict[str, list[float]] = {}
    for depth in FORCE_DEPTHS:
        k = step_at(base[0], depth)
        if k is not None:
            values[f"force({depth:g}mm)"] = [float(r.force[k]) for r in base]
    for r in base:
        for name, v in field_quantities(r, radius).items():
            values.setdefault(name, []).append(v)
    jacobian = None if fitting_level == levels[0] else base[levels.index(fitting_level)]
    for r in base:
        c1, c5 = parameter_bias(base[0], r, reading=reading, jacobian_from=jacobian)
        values.setdefault("fit c1", []).append(float(c1))
        values.setdefault("fit c5", []).append(float(c5))
    quantities: dict[str, ConvergenceOfQuantity] = {
        name: study_quantity(name, v, sizes) for name, v in values.items()
    }
    increments = []
    if len(substeps) >= 3:
        for level in levels[:substep_levels]:
            f = [float(runs[(level, n)].force[-1]) for n in substeps[:3]][::-1]  # finest increment first
            dt = [spec.protocol.step_size / n for n in substeps[:3]][::-1]
            t = observed_order(f, dt)
            increments.append(
                {
                    "level": level,
                    "substeps": list(substeps[:3]),
                    "force_deepest_mN": f[::-1],
                    "order": t.order,
                    "oscillatory": t.oscillatory,
                    "extrapolated_mN": t.extrapolated,
                    "gci_pct": t.gci_fine_pct,
                    "change_1_to_finest_pct": 100.0 * (f[-1] - f[0]) / f[0],
                }
            )
    return {
        "radius": radius,
        "theta": [spec.material.c1, spec.material.c5],
        "levels": [
            {
                "level": level,
                "h_mm": h,
                "nodes": int(r.solver["mesh"]["nodes"]),
                "wall_s": float(r.wall_s),
                "newton_iterations": int(r.newton_iterations),
                "sensitivities": r.force_sensitivity is not None,
            }
            for level, h, r in zip(levels, sizes, base, strict=True)
        ],
        "quantities": {name: q.to_dict() for name, q in quantities.items()},
        "increments": increments,
        "fitting_level": int(fitting_level),
    }


def run_verification_study(
    spec: ModelSpec,
    family: MeshFamily,
    levels: Sequence[int],
    *,
    points: Sequence[tuple[float, float]] = ((3.0, 540.0), (11.0, 330.0), (19.0, 120.0)),
    radii: Sequence[float] = (4.77, 8.0),
    substeps: Sequence[int] = (1, 2, 4),
    substep_levels: int = 2,
    out_dir: str | Path,
    progress: Callable[[str, int, int, float], None] | None = None,
    say: Callable[[str], None] | None = None,
    reading: str = "fit",
    fitting_level: int | None = None,
) -> VerificationStudy:
    """Solve and tabulate the verification study; resumable through ``out_dir``.

    Parameters
    ----------
    spec : ModelSpec
        The model (protocol, kappa, contact, solver options); its mesh, (c1, c5) and radius are
        replaced by the study's.
    family : MeshFamily
        The refined meshes.
    levels : sequence of int
        At least three levels of ``family``; any order.
    points, radii : optional
        (c1, c5) points (kPa) and indenter radii (mm).
    substeps : sequence of int, optional
        Increments per step; the first for every level, all of them on the ``substep_levels``
        finest levels (three or more for the increments' observed order).
    substep_levels : int, default 2
        How many of the finest levels are solved with every ``substeps``.
    out_dir : path
        Where every run and ``study.json`` are kept.
    progress : callable, optional
        ``progress(label, step, steps, force)`` after each step of each run.
    say : callable, optional
        Messages (runs read back).
    reading : str, default "fit"
        The objective of the fitted (c1, c5) (:func:`parameter_bias`): the fit's (DIC from
        1.5 R) or ``paper`` (from 1 R); the runs do not depend on it, so a study read back
        with another reading only refits.
    fitting_level : int, optional
        The level solved with sensitivities, whose Jacobian fits every level's response
        (:func:`parameter_bias`); the finest by default. A coarser one spares the finest level
        its sensitivities (module docstring).

    Returns
    -------
    VerificationStudy
        The study's tables.

    Raises
    ------
    ValueError
        If fewer than three levels are given, ``fitting_level`` is not one of them or a substep
        is not a whole number >= 1.
    """
    ordered = tuple(sorted({int(k) for k in levels}, reverse=True))
    if len(ordered) < 3:
        raise ValueError(f"a verification study needs three or more levels, got {list(levels)}")
    fitting = ordered[0] if fitting_level is None else int(fitting_level)
    if fitting not in ordered:
        raise ValueError(f"the fitting level {fitting} is not one of the study's levels {list(ordered)}")
    if not substeps or any(int(n) < 1 for n in substeps):
        raise ValueError(f"substeps must be whole numbers >= 1, got {list(substeps)}")
    out = Path(out_dir)
    study = VerificationStudy(
        family,
        ordered,
        inputs={
            "model": spec.to_dict(),
            "points": [list(map(float, p)) for p in points],
            "radii": [float(r) for r in radii],
            "substeps": [int(n) for n in substeps],
            "substep_levels": int(substep_levels),
            "weights": list(PAPER_WEIGHTS),
            "field_of_view_mm": FIT_FIELD_OF_VIEW,
            "reading": reading,
            "fitting_level": fitting,
            "solver": "embedded",
        },
    )
    t0 = time.perf_counter()
    for radius in radii:
        for c1, c5 in points:
            case_spec = replace(spec, indenter=Indenter(float(radius))).with_material(
                c1=float(c1), c5=float(c5)
            )
            folder = out / f"R{radius:g}" / f"c1-{c1:g}_c5-{c5:g}"
            study.cases.append(
                _case(
                    case_spec,
                    family,
                    ordered,
                    folder,
                    substeps=[int(n) for n in substeps],
                    substep_levels=substep_levels,
                    progress=progress,
                    say=say,
                    reading=reading,
                    fitting_level=fitting,
                )
            )
            atomic_write_json(out / "study.json", study.to_dict() | {"wall_s": time.perf_counter() - t0})
    return study
