"""Which experiment to run: certainty bounds (eq. 6) of candidate test designs before the test.

A candidate is an indenter radius, a maximum depth, a measurement every ``every``-th step of
the protocol, a DIC field of view (radius around the indentation point, mm) and a noise level s.
One simulation with exact sensitivities at theta* per radius serves all candidates of that
radius: a shallower or sparser test measures a subset of the deeper test's steps (quasi-static
loading), and a smaller field of view masks nodes. For each candidate the bounds are given at
fixed weights (default: the paper's combined weights, eq. 13) and at the weights optimised for
that design (:func:`design.weights.optimise_weights`).
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..atomic_write import atomic_write
from ..forward.fe_predictor import FESolverPredictor
from ..forward.mesh_presets import HIGH_FIDELITY_MESH
from ..forward.predictor import Prediction
from ..forward.spec import Indenter, MeshChoice, ModelSpec, Protocol
from ..surrogate.error_budgets import budget_at, shipped_budget
from .certainty import DESIGN_BOUNDS_INCLUDE, bounds_pct, combine, gauss_newton_term_hessians
from .objective import PAPER_WEIGHTS, Objective, check_weights
from .weights import optimise_weights

PAPER_COMBINED_WEIGHTS = PAPER_WEIGHTS


@dataclass(frozen=True)
class Candidate:
    """One test design. ``fov`` None: the whole top surface is seen."""

    radius: float
    max_depth: float
    every: int = 1
    fov: float | None = None
    s: float = 0.05


def _subset(pred: Prediction, steps: np.ndarray) -> Prediction:
    return replace(
        pred,
        force=pred.force[:, steps],
        displacement=pred.displacement[:, steps],
        depth=pred.depth[steps],
        force_jacobian=pred.force_jacobian[:, steps],
        displacement_jacobian=pred.displacement_jacobian[:, steps],
    )


def measured_steps(depth: np.ndarray, candidate: Candidate) -> np.ndarray:
    """Indices of the protocol steps a candidate measures: every ``every``-th step down to its
    maximum depth, the deepest one included."""
    if candidate.max_depth > depth[-1] + 1e-9:
        raise ValueError(
            f"max depth {candidate.max_depth:g} mm is deeper than the simulation ({depth[-1]:g} mm)"
        )
    if int(candidate.every) != candidate.every or candidate.every < 1:
        raise ValueError(f"'every' must be a positive whole number of steps, got {candidate.every!r}")
    within = np.flatnonzero(depth <= candidate.max_depth + 1e-9)
    steps = within[::-1][:: int(candidate.every)][::-1]  # keep the deepest step, thin toward the surface
    if steps.size == 0:
        raise ValueError(f"no protocol step is as shallow as {candidate.max_depth:g} mm")
    return steps


def candidate_term_hessians(
    base: Prediction, candidate: Candidate, theta_star: np.ndarray, reading: str = "paper"
) -> np.ndarray:
    """H_k (4, p, p) of one candidate from the deepest simulation ``base`` of its radius."""
    sub = _subset(base, measured_steps(base.depth, candidate))
    mask = None
    if candidate.fov is not None:
        if not (np.isfinite(candidate.fov) and candidate.fov > 0):
            raise ValueError(f"the field of view must be a positive radius in mm, got {candidate.fov!r}")
        mask = np.hypot(base.top_xyz[:, 0], base.top_xyz[:, 1]) <= candidate.fov
    objective = Objective.from_prediction(sub, radius=candidate.radius, reading=reading, mask=mask)
    return gauss_newton_term_hessians(objective, sub, theta_star)


def compare_designs(
    spec: ModelSpec,
    candidates: list[Candidate],
    theta_star=(10.0, 350.0),
    weights=PAPER_COMBINED_WEIGHTS,
    criterion: str = "combined",
    reading: str = "fit",
    progress=None,
) -> pd.DataFrame:
    """Compare candidate test designs by their certainty bounds (eq. 6) at ``theta_star``.

    Each radius is simulated once, with sensitivities, to the deepest candidate; each candidate's
    Hessians come from the steps and field of view it measures.

    Parameters
    ----------
    spec : ModelSpec
        The model; its step size is the protocol's.
    candidates : list of Candidate
        The designs (:func:`candidate_grid`).
    theta_star : array_like, default (10.0, 350.0)
        (c1, c5) at which to compare, kPa.
    weights : array_like, default PAPER_WEIGHTS
        The weights eta (eq. 5).
    criterion : str, default "combined"
        What :func:`optimise_weights` minimises.
    reading : str, default "fit"
        How the objective is read (:class:`Objective`): design advice for a new test uses the
        fit's objective, as the fit of that test will.
    progress : callable, optional
        Called with a message before each simulation.

    Returns
    -------
    pandas.DataFrame
        One row per candidate: its design (``radius_mm``, ``max_depth_mm``, ``steps``, ``every``,
        ``fov_mm``, ``s``), the bounds at ``weights`` (``c1_pct``, ``c5_pct``) and at its own
        optimum (``c1_pct_optimised``, ``c5_pct_optimised``, ``optimised_weights``), and the model
        error a fit of that test would carry (:func:`candidate_model_error`): ``c1_model_pct``,
        ``c5_model_pct`` (NaN where no budget exists), ``c1_total_pct``, ``c5_total_pct`` (the
        optimised bounds and the model error, root sum of squares; the statistical bound alone
        where none exists) and ``model_error`` (its source, or ``"statistical only"``).
    """
    theta_star = np.asarray(theta_star, float)
    eta = check_weights(weights)
    base_by_radius: dict[float, Prediction] = {}
    deepest = max(c.max_depth for c in candidates)
    step = spec.protocol.step_size
    protocol = Protocol(step_size=step, steps=int(np.ceil(deepest / step - 1e-9)))
    rows = []
    for c in candidates:
        if c.radius not in base_by_radius:
            if progress is not None:
                progress(f"simulating R = {c.radius:g} mm to {protocol.max_depth:g} mm with sensitivities")
            r_spec = replace(spec, indenter=Indenter(radius=c.radius), protocol=protocol)
            base_by_radius[c.radius] = FESolverPredictor(r_spec, sensitivities=True).predict(theta_star)
        H = candidate_term_hessians(base_by_radius[c.radius], c, theta_star, reading)
        b_fixed = bounds_pct(combine(H, eta), c.s)
        eta_opt = optimise_weights(H, criterion)
        b_opt = bounds_pct(combine(H, eta_opt), c.s)
        model_pct, source = candidate_model_error(spec, c, theta_star)
        total = b_opt if model_pct is None else np.hypot(b_opt, model_pct)
        rows.append(
            {
                "radius_mm": c.radius,
                "max_depth_mm": c.max_depth,
                "steps": int(measured_steps(base_by_radius[c.radius].depth, c).size),
                "every": c.every,
                "fov_mm": np.nan if c.fov is None else c.fov,
                "s": c.s,
                "c1_pct": float(b_fixed[0]),
                "c5_pct": float(b_fixed[1]),
                "c1_pct_optimised": float(b_opt[0]),
                "c5_pct_optimised": float(b_opt[1]),
                "optimised_weights": tuple(round(float(v), 4) for v in eta_opt),
                "c1_model_pct": np.nan if model_pct is None else float(model_pct[0]),
                "c5_model_pct": np.nan if model_pct is None else float(model_pct[1]),
                "c1_total_pct": float(total[0]),
                "c5_total_pct": float(total[1]),
                "model_error": source,
            }
        )
    return pd.DataFrame(rows)


def candidate_model_error(spec: ModelSpec, candidate: Candidate, theta_star) -> tuple[np.ndarray | None, str]:
    """The model error a fit of a candidate test would carry: its error budget's half-width at theta*.

    The budget is the one shipped for that test (radius, depth in the spec's steps, specimen,
    contact) on the high fidelity a fit's surrogate emulates (``HIGH_FIDELITY_MESH``), read at
    theta* as a fit reads it (:func:`surrogate.error_budgets.budget_at`; outside its points the
    nearest ones' largest). The discrepancy's, the surrogate's own and the processing's parts of a
    real fit come on top; a test without a budget says "statistical only".

    Parameters
    ----------
    spec : ModelSpec
        The model (its step size is the protocol's).
    candidate : Candidate
        The design.
    theta_star : array_like
        (c1, c5), kPa.

    Returns
    -------
    tuple
        ((c1, c5) percent or None, the source in words).
    """
    step = spec.protocol.step_size
    steps = round(candidate.max_depth / step)
    test = replace(
        spec,
        indenter=Indenter(radius=candidate.radius),
        protocol=Protocol(step_size=step, steps=steps),
        mesh=MeshChoice(HIGH_FIDELITY_MESH),
    )
    budget = budget_at(shipped_budget(test), theta_star)
    if budget is None:
        return None, "statistical only"
    where = budget["source"].get("where", "")
    words = f"{budget['source']['file']} ({HIGH_FIDELITY_MESH}, {where})"
    return np.array([budget["c1_pct"], budget["c5_pct"]], float), words


def candidate_grid(
    radii=(4.77, 8.0), depths=(7.0, 10.5, 14.0), every=(1,), fovs=(None,), noise=(0.05,)
) -> list[Candidate]:
    """Every combination of the given design choices.

    Parameters
    ----------
    radii : sequence of float, default (4.77, 8.0)
        Indenter radii, mm.
    depths : sequence of float, default (7.0, 10.5, 14.0)
        Maximum depths, mm.
    every : sequence of int, default (1,)
        Measure every this many protocol steps.
    fovs : sequence of float or None, default (None,)
        Field-of-view radii, mm (None: the whole top surface).
    noise : sequence of float, default (0.05,)
        The s of eq. 8.

    Returns
    -------
    list of Candidate
        One per combination.

    Examples
    --------
    >>> from indentation_studio.design import candidate_grid
    >>> len(candidate_grid())
    6
    """
    return [Candidate(*c) for c in itertools.product(radii, depths, every, fovs, noise)]


@dataclass
class DesignComparison:
    """The candidate designs' bounds at theta* and the CSV they were written to.

    Attributes
    ----------
    table : pandas.DataFrame
        The table of :func:`compare_designs`.
    theta_star : tuple of float
        (c1, c5) of the comparison, kPa.
    csv : pathlib.Path
        The file the table was written to.
    """

    table: pd.DataFrame
    theta_star: tuple[float, float]
    csv: Path

    def to_dict(self, *, png: str | Path | None = None) -> dict[str, Any]:
        """The comparison as ``design compare --json`` prints it.

        Parameters
        ----------
        png : str or Path, optional
            The plot of the comparison, if one was drawn.

        Returns
        -------
        dict
            The rows, the CSV and PNG files, theta* and what the bounds include.
        """
        rows = json.loads(self.table.to_json(orient="records"))
        payload = {"rows": rows, "csv": str(self.csv), "png": str(png) if png is not None else None}
        return payload | {"theta_star": list(self.theta_star), "bounds_include": DESIGN_BOUNDS_INCLUDE}


def compare_candidate_designs(
    spec: ModelSpec,
    out_dir: str | Path,
    *,
    radii=(4.77, 8.0),
    depths=(7.0, 10.5, 14.0),
    every=(1,),
    fovs=(None,),
    noise=(0.05,),
    weights=PAPER_COMBINED_WEIGHTS,
    criterion: str = "combined",
    reading: str = "fit",
    progress=None,
) -> DesignComparison:
    """Compare every candidate design of the given choices at the spec's own (c1, c5).

    The candidates are :func:`candidate_grid`'s; the table is written to
    ``out_dir/design-comparison.csv``.

    Parameters
    ----------
    spec : ModelSpec
        The model at theta*; its step size is the protocol's.
    out_dir : str or Path
        The folder for the CSV (made if missing).
    radii, depths, every, fovs, noise
        The design choices (see :class:`Candidate`).
    weights, criterion, reading, progress
        As :func:`compare_designs`.

    Returns
    -------
    DesignComparison
        The table and its CSV.
    """
    theta_star = (spec.material.c1, spec.material.c5)
    candidates = candidate_grid(radii, depths, every, fovs, noise)
    table = compare_designs(spec, candidates, theta_star, weights, criterion, reading, progress=progress)
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    csv = Path(out_dir) / "design-comparison.csv"
    atomic_write(csv, table.to_csv(index=False))
    return DesignComparison(table, theta_star, csv)
